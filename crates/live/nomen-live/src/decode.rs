//! Input payloads: one recording message as JSON (`nomen-recording`'s FORMAT.md), the
//! registry, or a vendor's payload (`docs/adapters.md`), checked against the topic they came
//! on.

use crate::topics::{InputKind, InputTopic, VendorFormat, input_source, parse_input_topic};
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
    let mut inputs = Vec::new();
    decode_into(topic, payload, &mut inputs)?;
    Ok(inputs)
}

/// [`decode_all`] into `inputs` (appended; a buffer the caller reuses, so that a message costs
/// no vector of its own). On an error nothing is appended.
pub fn decode_into(topic: &str, payload: &[u8], inputs: &mut Vec<Input>) -> Result<(), String> {
    let Ok(InputTopic::Vendor { format, source }) = parse_input_topic(topic) else {
        inputs.push(decode(topic, payload)?);
        return Ok(());
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
    inputs.extend(decoded.messages.into_iter().map(Input::Message));
    Ok(())
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
            let msg = decode_message(kind, payload)?;
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

/// The `type` of a message, every other field passed over.
#[derive(serde::Deserialize)]
struct TypeTag<'a> {
    #[serde(rename = "type", borrow)]
    kind: Option<std::borrow::Cow<'a, str>>,
}

/// Whether `payload` starts with `{"type":"<kind>",`, as nomen writes its messages (the tag
/// first, no spaces): its tag is then the topic's without a pass over the rest.
fn starts_with_tag(payload: &[u8], kind: InputKind) -> bool {
    let name = kind.name().as_bytes();
    payload
        .strip_prefix(br#"{"type":""#)
        .and_then(|rest| rest.strip_prefix(name))
        .is_some_and(|rest| rest.starts_with(br#"","#))
}

/// A message on a topic of `kind`. The topic names its type, so the payload is read straight
/// into that type once its `type` tag is known to be the topic's (from the payload's first
/// bytes when it starts with the tag, as nomen writes it, else from a pass over the payload): a
/// message read as [`Message`], an enum tagged by a field, is first buffered field by field,
/// which takes several times longer. A payload whose tag is not the topic's is read as a
/// [`Message`], for the reason to report.
fn decode_message(kind: InputKind, payload: &[u8]) -> Result<Message, String> {
    if !starts_with_tag(payload, kind) {
        let tag: TypeTag<'_> = serde_json::from_slice(payload).map_err(|e| e.to_string())?;
        if tag.kind.as_deref() != Some(kind.name()) {
            return serde_json::from_slice(payload).map_err(|e| e.to_string());
        }
    }
    let read = |e: serde_json::Error| e.to_string();
    Ok(match kind {
        InputKind::Skeleton => Message::Skeleton(serde_json::from_slice(payload).map_err(read)?),
        InputKind::Imu => Message::Imu(serde_json::from_slice(payload).map_err(read)?),
        InputKind::RtlsFix => Message::RtlsFix(serde_json::from_slice(payload).map_err(read)?),
        InputKind::UwbRange => Message::UwbRange(serde_json::from_slice(payload).map_err(read)?),
        InputKind::Rssi => Message::Rssi(serde_json::from_slice(payload).map_err(read)?),
    })
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
        assert!(m.gyro_radps.is_some());
    }

    #[test]
    fn an_accelerometer_only_sample_decodes_without_angular_rate() {
        let watch = r#"{"type":"imu","t":1000000,"device":"w1","accel_mps2":[0.3,-1.2,9.7]}"#;
        let Ok(Input::Message(Message::Imu(m))) = decode("nomen/in/imu/w1", watch.as_bytes())
        else {
            panic!("decodes");
        };
        assert_eq!(m.gyro_radps, None);
        assert_eq!(m.accel_mps2.y, -1.2);
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

    #[test]
    fn every_input_kind_decodes_as_the_tagged_enum_does() {
        let payloads = [
            ("nomen/in/imu/w1", IMU.to_owned()),
            (
                "nomen/in/rtls_fix/t1",
                r#"{"type":"rtls_fix","t":5,"tag":"t1","position_m":[1.0,2.0,0.5]}"#.to_owned(),
            ),
            (
                "nomen/in/skeleton/cam",
                r#"{"type":"skeleton","t":7,"camera":"cam","track":3,"joints":{"pelvis":{"position_m":[1.0,2.0,0.9]}}}"#
                    .to_owned(),
            ),
        ];
        for (topic, payload) in payloads {
            let expected: Message = serde_json::from_str(&payload).unwrap();
            let Ok(Input::Message(m)) = decode(topic, payload.as_bytes()) else {
                panic!("{topic} decodes");
            };
            assert_eq!(m, expected, "{topic}");
        }
        // A message that is no input, on an input topic: the tagged enum's reason.
        let e = decode(
            "nomen/in/imu/w1",
            br#"{"type":"truth_tag","t":1,"tag":"w1","position_m":[0.0,0.0,0.0]}"#,
        )
        .unwrap_err();
        assert!(e.contains("is not an input"), "{e}");
        // No tag at all.
        let e = decode("nomen/in/imu/w1", br#"{"t":1,"device":"w1"}"#).unwrap_err();
        assert!(e.contains("type"), "{e}");
        // The tag elsewhere than first, or spaced: read after a pass that finds it.
        let late = r#"{"t":1000000,"device":"w1","type":"imu","accel_mps2":[0.0,0.0,9.81],"gyro_radps":[0.0,0.0,0.0]}"#;
        let spaced = IMU.replace(r#""type":"imu""#, r#""type": "imu""#);
        for payload in [late, spaced.as_str()] {
            assert!(!starts_with_tag(payload.as_bytes(), InputKind::Imu));
            assert_eq!(
                decode("nomen/in/imu/w1", payload.as_bytes()),
                decode("nomen/in/imu/w1", IMU.as_bytes())
            );
        }
        assert!(starts_with_tag(IMU.as_bytes(), InputKind::Imu));
        assert!(!starts_with_tag(IMU.as_bytes(), InputKind::RtlsFix));
    }
}
