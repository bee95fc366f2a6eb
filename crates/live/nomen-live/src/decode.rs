//! Input payloads: one recording message as JSON (`nomen-recording`'s FORMAT.md), or the
//! registry, checked against the topic they came on.

use crate::topics::{InputTopic, input_source, parse_input_topic};
use nomen_core::{Message, Registry};

/// The most bytes a payload may have: a skeleton with every joint's covariance is about 6 kB of
/// JSON, a registry of a hundred people a few tens of kB.
pub const MAX_PAYLOAD_BYTES: usize = 1 << 20;

/// A decoded input.
#[derive(Debug, Clone, PartialEq)]
pub enum Input {
    /// A new registry.
    Registry(Box<Registry>),
    /// A sensor message, checked for its own values and its topic.
    Message(Message),
}

/// Decodes the payload of an input `topic`; the error is the reason to report, without the
/// topic (the health report pairs them).
pub fn decode(topic: &str, payload: &[u8]) -> Result<Input, String> {
    if payload.len() > MAX_PAYLOAD_BYTES {
        return Err(format!(
            "{} bytes, more than the {MAX_PAYLOAD_BYTES} a payload may have",
            payload.len()
        ));
    }
    match parse_input_topic(topic)? {
        InputTopic::Registry => {
            let registry: Registry =
                serde_json::from_slice(payload).map_err(|e| format!("invalid registry: {e}"))?;
            registry
                .validate()
                .map_err(|e| format!("invalid registry: {e}"))?;
            Ok(Input::Registry(Box::new(registry)))
        }
        InputTopic::Data { kind, source } => {
            let msg: Message = serde_json::from_slice(payload).map_err(|e| e.to_string())?;
            let Some((msg_kind, msg_source)) = input_source(&msg) else {
                return Err(format!(
                    "a message of type '{}' is not an input",
                    msg.type_name()
                ));
            };
            if msg_kind != kind {
                return Err(format!(
                    "a message of type '{}' on a '{}' topic",
                    msg_kind.name(),
                    kind.name()
                ));
            }
            if msg_source != source {
                return Err(format!(
                    "the message is from '{msg_source}', the topic says '{source}'"
                ));
            }
            msg.validate().map_err(|e| e.to_string())?;
            Ok(Input::Message(msg))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const IMU: &str = r#"{"type":"imu","t":1000000,"device":"w1","accel_mps2":[0.0,0.0,9.81],"gyro_radps":[0.0,0.0,0.0]}"#;

    #[test]
    fn an_imu_sample_decodes_on_its_own_topic() {
        let Ok(Input::Message(Message::Imu(m))) = decode("nomen/in/imu/w1", IMU.as_bytes()) else {
            panic!("decodes");
        };
        assert_eq!(m.device.as_str(), "w1");
    }

    #[test]
    fn a_payload_on_the_wrong_topic_is_refused_with_the_reason() {
        let e = decode("nomen/in/imu/w2", IMU.as_bytes()).unwrap_err();
        assert!(e.contains("from 'w1'"), "{e}");
        let e = decode("nomen/in/skeleton/w1", IMU.as_bytes()).unwrap_err();
        assert!(e.contains("type 'imu' on a 'skeleton' topic"), "{e}");
    }

    #[test]
    fn broken_json_and_bad_numbers_are_refused() {
        assert!(decode("nomen/in/imu/w1", b"{\"type\":").is_err());
        let nan = IMU.replace("9.81", "1e999");
        assert!(decode("nomen/in/imu/w1", nan.as_bytes()).is_err());
    }

    #[test]
    fn a_registry_decodes_and_is_validated() {
        let Ok(Input::Registry(r)) = decode(
            crate::topics::REGISTRY_TOPIC,
            br#"{"subjects":[],"cameras":[]}"#,
        ) else {
            panic!("decodes");
        };
        assert!(r.subjects.is_empty());
        assert!(decode(crate::topics::REGISTRY_TOPIC, b"[1]").is_err());
    }
}
