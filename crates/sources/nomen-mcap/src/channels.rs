//! The channels of a nomen MCAP file: one per message kind, each with its JSON schema.

use nomen_core::Message;

/// A channel: its topic and the JSON schema of its messages.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Channel {
    /// The MCAP topic (as the MQTT topics of `nomen serve`, without the source level).
    pub topic: &'static str,
    /// The schema's name.
    pub schema_name: &'static str,
    /// The JSON schema (draft 2020-12) of the payloads.
    pub schema: &'static str,
}

/// The registry of the session: one message at the start of every file.
pub const REGISTRY: Channel = Channel {
    topic: "nomen/in/registry",
    schema_name: "nomen.Registry",
    schema: include_str!("../schemas/registry.json"),
};

/// The input channels, one per input kind, in the order of the recording format.
pub const INPUTS: [Channel; 5] = [
    Channel {
        topic: "nomen/in/skeleton",
        schema_name: "nomen.skeleton",
        schema: include_str!("../schemas/skeleton.json"),
    },
    Channel {
        topic: "nomen/in/imu",
        schema_name: "nomen.imu",
        schema: include_str!("../schemas/imu.json"),
    },
    Channel {
        topic: "nomen/in/rtls_fix",
        schema_name: "nomen.rtls_fix",
        schema: include_str!("../schemas/rtls_fix.json"),
    },
    Channel {
        topic: "nomen/in/uwb_range",
        schema_name: "nomen.uwb_range",
        schema: include_str!("../schemas/uwb_range.json"),
    },
    Channel {
        topic: "nomen/in/rssi",
        schema_name: "nomen.rssi",
        schema: include_str!("../schemas/rssi.json"),
    },
];

/// The engine's identified skeletons.
pub const IDENTIFIED: Channel = Channel {
    topic: "nomen/out/identified",
    schema_name: "nomen.identified",
    schema: include_str!("../schemas/identified.json"),
};

/// The engine's tag corrections.
pub const TAG_CORRECTION: Channel = Channel {
    topic: "nomen/out/tag_correction",
    schema_name: "nomen.tag_correction",
    schema: include_str!("../schemas/tag_correction.json"),
};

/// Every channel of nomen's own messages: the registry, the inputs, the engine's outputs.
pub const MESSAGE_CHANNELS: [Channel; 8] = [
    REGISTRY,
    INPUTS[0],
    INPUTS[1],
    INPUTS[2],
    INPUTS[3],
    INPUTS[4],
    IDENTIFIED,
    TAG_CORRECTION,
];

/// The channel a message goes to; `None` for ground truth, which a live service never has.
pub fn message_channel(msg: &Message) -> Option<&'static Channel> {
    match msg {
        Message::Skeleton(_) => Some(&INPUTS[0]),
        Message::Imu(_) => Some(&INPUTS[1]),
        Message::RtlsFix(_) => Some(&INPUTS[2]),
        Message::UwbRange(_) => Some(&INPUTS[3]),
        Message::Rssi(_) => Some(&INPUTS[4]),
        Message::Identified(_) => Some(&IDENTIFIED),
        Message::TagCorrection(_) => Some(&TAG_CORRECTION),
        Message::TruthSkeleton(_) | Message::TruthTag(_) => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_schema_is_a_json_object_schema_named_as_its_channel() {
        for c in MESSAGE_CHANNELS {
            let schema: serde_json::Value = serde_json::from_str(c.schema).unwrap();
            assert_eq!(schema["type"], "object", "{}", c.topic);
            assert_eq!(schema["title"], c.schema_name, "{}", c.topic);
        }
    }

    #[test]
    fn an_input_channel_is_named_after_its_type_tag() {
        for c in INPUTS {
            let schema: serde_json::Value = serde_json::from_str(c.schema).unwrap();
            let tag = schema["properties"]["type"]["const"].as_str().unwrap();
            assert_eq!(c.topic, format!("nomen/in/{tag}"));
        }
    }
}
