//! Input payloads: one recording message as JSON (`nomen-recording`'s FORMAT.md), the
//! registry, or a vendor's payload (`docs/adapters.md`), checked against the topic they came
//! on.

use crate::topics::{InputTopic, VendorFormat, input_source, parse_input_topic};
use nomen_adapters::{
    AzureKinectConfig, RfidConfig, RtlsConfig, decode_azure_kinect_frame, decode_impinj,
    decode_pozyx, decode_sewio, decode_zebra,
};
use nomen_core::{CameraId, Message, Registry};

/// The most bytes a payload may have, nomen's own or a vendor's (the vendor readers' line
/// limit, [`nomen_adapters::MAX_LINE_BYTES`]): a skeleton with every joint's covariance is about
/// 6 kB of JSON, a registry of a hundred people a few tens of kB.
pub const MAX_PAYLOAD_BYTES: usize = nomen_adapters::MAX_LINE_BYTES;

/// A decoded input.
#[derive(Debug, Clone, PartialEq)]
pub enum Input {
    /// A new registry.
    Registry(Box<Registry>),
    /// A sensor message, checked for its own values and its topic.
    Message(Message),
}

/// Decodes the payload of any input `topic`: one input for nomen's own topics, the messages of a
/// vendor payload (`nomen/in/vendor/<format>/<source>`) in its order. The error is the reason to
/// report, without the topic.
pub fn decode_all(topic: &str, payload: &[u8]) -> Result<Vec<Input>, String> {
    let Ok(InputTopic::Vendor { format, source }) = parse_input_topic(topic) else {
        return decode(topic, payload).map(|input| vec![input]);
    };
    // Times are the vendor's (Unix epoch for RTLS and RFID, device time for the Kinect); 2D
    // fixes lie at z = 0.
    let rtls = RtlsConfig::default();
    let rfid = RfidConfig {
        reader: source.to_owned(),
        time_offset_ns: 0,
    };
    let decoded = match format {
        VendorFormat::AzureKinect => decode_azure_kinect_frame(
            payload,
            &AzureKinectConfig {
                camera: CameraId::new(source),
                time_offset_ns: 0,
            },
        ),
        VendorFormat::Pozyx => decode_pozyx(payload, &rtls),
        VendorFormat::Sewio => decode_sewio(payload, &rtls),
        VendorFormat::Impinj => decode_impinj(payload, &rfid),
        VendorFormat::Zebra => decode_zebra(payload, &rfid),
    }
    .map_err(|e| e.to_string())?;
    Ok(decoded.messages.into_iter().map(Input::Message).collect())
}

/// Decodes the payload of an input `topic` of nomen's own (one message or the registry); the
/// error is the reason to report, without the topic (the health report pairs them).
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
        InputTopic::Vendor { .. } => {
            Err("a vendor payload holds several messages: decode it with decode_all".to_owned())
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
    fn a_vendor_payload_decodes_into_its_messages() {
        let payload = br#"[{"tagId":"30331","timestamp":1715679000.1,"success":true,"data":{"coordinates":{"x":2510,"y":1804,"z":1290}}},{"tagId":"41022","timestamp":1715679000.2,"success":false}]"#;
        let inputs = decode_all("nomen/in/vendor/pozyx/hall", payload).unwrap();
        assert_eq!(inputs.len(), 1, "the unsuccessful update makes no fix");
        let Input::Message(Message::RtlsFix(fix)) = &inputs[0] else {
            panic!("a fix");
        };
        assert_eq!(fix.tag.as_str(), "30331");
        assert_eq!(fix.position_m.x, 2.51);
        let zebra = br#"{"data":{"idHex":"e280","antenna":2,"peakRssi":-60},"timestamp":"2024-05-14T09:30:00.108+0000","type":"SIMPLE"}"#;
        let inputs = decode_all("nomen/in/vendor/zebra/dock", zebra).unwrap();
        let [Input::Message(Message::Rssi(read))] = inputs.as_slice() else {
            panic!("one read");
        };
        assert_eq!(read.antenna.as_str(), "dock/2");
        let e = decode_all(
            "nomen/in/vendor/zebra/dock",
            br#"{"data":{"idHex":"e280"}}"#,
        )
        .unwrap_err();
        assert!(
            e.starts_with("payload: data: missing field 'antenna'"),
            "{e}"
        );
        // nomen's own topics decode as before.
        assert_eq!(
            decode_all("nomen/in/imu/w1", IMU.as_bytes()).unwrap().len(),
            1
        );
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
