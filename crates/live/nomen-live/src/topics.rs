//! The topic scheme: `nomen/in/<kind>/<source id>` in, `nomen/out/...` out (`docs/live.md`).

use nomen_core::Message;

/// The filter `nomen serve` subscribes to: every input, the registry included, on one
/// subscription, so that a broker delivers them in the order one publisher sent them.
pub const INPUT_FILTER: &str = "nomen/in/#";
/// The registry (one JSON object, as in a recording's header), best published retained.
pub const REGISTRY_TOPIC: &str = "nomen/in/registry";
/// Sensor health, published every `health_period_s`.
pub const HEALTH_TOPIC: &str = "nomen/out/health";
/// Events: named, re-identified, lost, warnings.
pub const EVENT_TOPIC: &str = "nomen/out/event";
/// Prefix of the identified skeletons' topics (`nomen/out/identified/<camera>`).
pub const IDENTIFIED_PREFIX: &str = "nomen/out/identified/";
/// Prefix of the tag corrections' topics (`nomen/out/tag_correction/<tag>`).
pub const TAG_CORRECTION_PREFIX: &str = "nomen/out/tag_correction/";

const INPUT_PREFIX: &str = "nomen/in/";
/// Prefix of vendor payload topics (`nomen/in/vendor/<format>/<source>`).
pub const VENDOR_PREFIX: &str = "nomen/in/vendor/";

/// The vendor formats `nomen serve` decodes (`docs/adapters.md`), each named as in
/// `nomen import`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VendorFormat {
    /// One frame of Azure Kinect body tracking (`frames[i]` of the offline processor's JSON);
    /// the source is the camera.
    AzureKinect,
    /// A Pozyx MQTT positioning payload; the source names the Pozyx system.
    Pozyx,
    /// A Sewio WebSocket or UDP message; the source names the Sewio system.
    Sewio,
    /// An Impinj Speedway Connect report; the source is the reader.
    Impinj,
    /// A Zebra IoT Connector data event; the source is the reader.
    Zebra,
}

impl VendorFormat {
    /// Every vendor format.
    pub const ALL: [VendorFormat; 5] = [
        VendorFormat::AzureKinect,
        VendorFormat::Pozyx,
        VendorFormat::Sewio,
        VendorFormat::Impinj,
        VendorFormat::Zebra,
    ];

    /// The format's name: the topic's fourth level.
    pub fn name(self) -> &'static str {
        match self {
            VendorFormat::AzureKinect => "azure-kinect",
            VendorFormat::Pozyx => "pozyx",
            VendorFormat::Sewio => "sewio",
            VendorFormat::Impinj => "impinj",
            VendorFormat::Zebra => "zebra",
        }
    }

    fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|f| f.name() == name)
    }
}

/// The kinds of input message, as their `type` tag in the recording format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum InputKind {
    /// A camera skeleton; the source is the camera.
    Skeleton,
    /// An IMU sample; the source is the device.
    Imu,
    /// A location fix; the source is the tag.
    RtlsFix,
    /// A UWB range; the source is the tag.
    UwbRange,
    /// An RSSI read; the source is the tag.
    Rssi,
}

impl InputKind {
    /// Every input kind.
    pub const ALL: [InputKind; 5] = [
        InputKind::Skeleton,
        InputKind::Imu,
        InputKind::RtlsFix,
        InputKind::UwbRange,
        InputKind::Rssi,
    ];

    /// The kind's place in [`InputKind::ALL`].
    pub fn index(self) -> usize {
        self as usize
    }

    /// The kind's name: the message's `type` tag and the topic's third level.
    pub fn name(self) -> &'static str {
        match self {
            InputKind::Skeleton => "skeleton",
            InputKind::Imu => "imu",
            InputKind::RtlsFix => "rtls_fix",
            InputKind::UwbRange => "uwb_range",
            InputKind::Rssi => "rssi",
        }
    }

    fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == name)
    }
}

/// What an input topic addresses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InputTopic<'a> {
    /// [`REGISTRY_TOPIC`].
    Registry,
    /// `nomen/in/<kind>/<source>`.
    Data {
        /// The message kind.
        kind: InputKind,
        /// The camera, device or tag id (may contain `/`).
        source: &'a str,
    },
    /// `nomen/in/vendor/<format>/<source>`: a vendor's payload, several messages.
    Vendor {
        /// The vendor format.
        format: VendorFormat,
        /// The camera, reader or system it comes from (may contain `/`).
        source: &'a str,
    },
}

/// Reads an input topic; the error says what is wrong with it.
pub fn parse_input_topic(topic: &str) -> Result<InputTopic<'_>, String> {
    if topic == REGISTRY_TOPIC {
        return Ok(InputTopic::Registry);
    }
    if let Some(rest) = topic.strip_prefix(VENDOR_PREFIX) {
        let Some((format, source)) = rest.split_once('/') else {
            return Err(
                "no source id: vendor inputs are nomen/in/vendor/<format>/<source id>".to_owned(),
            );
        };
        let Some(format) = VendorFormat::from_name(format) else {
            let names: Vec<&str> = VendorFormat::ALL.iter().map(|f| f.name()).collect();
            return Err(format!(
                "unknown vendor format '{format}' ({})",
                names.join(", ")
            ));
        };
        if source.is_empty() {
            return Err("empty source id".to_owned());
        }
        return Ok(InputTopic::Vendor { format, source });
    }
    let Some(rest) = topic.strip_prefix(INPUT_PREFIX) else {
        return Err(format!(
            "not an input topic (they start with {INPUT_PREFIX})"
        ));
    };
    let Some((kind, source)) = rest.split_once('/') else {
        return Err("no source id: inputs are nomen/in/<kind>/<source id>".to_owned());
    };
    let Some(kind) = InputKind::from_name(kind) else {
        return Err(format!(
            "unknown kind '{kind}' (skeleton, imu, rtls_fix, uwb_range or rssi)"
        ));
    };
    if source.is_empty() {
        return Err("empty source id".to_owned());
    }
    Ok(InputTopic::Data { kind, source })
}

/// The kind and source id of an input message (`None` for outputs and ground truth).
pub fn input_source(msg: &Message) -> Option<(InputKind, &str)> {
    match msg {
        Message::Skeleton(m) => Some((InputKind::Skeleton, m.camera.as_str())),
        Message::Imu(m) => Some((InputKind::Imu, m.device.as_str())),
        Message::RtlsFix(m) => Some((InputKind::RtlsFix, m.tag.as_str())),
        Message::UwbRange(m) => Some((InputKind::UwbRange, m.tag.as_str())),
        Message::Rssi(m) => Some((InputKind::Rssi, m.tag.as_str())),
        Message::Identified(_)
        | Message::TagCorrection(_)
        | Message::TruthSkeleton(_)
        | Message::TruthTag(_) => None,
    }
}

/// The topic an input message is published on (`None` for outputs and ground truth).
pub fn input_topic(msg: &Message) -> Option<String> {
    input_source(msg).map(|(kind, source)| format!("{INPUT_PREFIX}{}/{source}", kind.name()))
}

/// The topic an engine output is published on (`None` for inputs and ground truth).
pub fn output_topic(msg: &Message) -> Option<String> {
    match msg {
        Message::Identified(m) => Some(format!("{IDENTIFIED_PREFIX}{}", m.camera)),
        Message::TagCorrection(m) => Some(format!("{TAG_CORRECTION_PREFIX}{}", m.tag)),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn input_topics_name_kind_and_source() {
        assert_eq!(
            parse_input_topic("nomen/in/imu/ana_left_wrist"),
            Ok(InputTopic::Data {
                kind: InputKind::Imu,
                source: "ana_left_wrist"
            })
        );
        assert_eq!(
            parse_input_topic("nomen/in/skeleton/cam/front"),
            Ok(InputTopic::Data {
                kind: InputKind::Skeleton,
                source: "cam/front"
            })
        );
        assert_eq!(
            parse_input_topic("nomen/in/registry"),
            Ok(InputTopic::Registry)
        );
    }

    #[test]
    fn bad_input_topics_say_why() {
        assert!(
            parse_input_topic("nomen/in/video/cam1")
                .unwrap_err()
                .contains("unknown kind 'video'")
        );
        assert!(
            parse_input_topic("nomen/in/imu")
                .unwrap_err()
                .contains("no source id")
        );
        assert!(
            parse_input_topic("nomen/in/imu/")
                .unwrap_err()
                .contains("empty")
        );
        assert!(
            parse_input_topic("other/imu/x")
                .unwrap_err()
                .contains("not an input topic")
        );
    }

    #[test]
    fn vendor_topics_name_format_and_source() {
        assert_eq!(
            parse_input_topic("nomen/in/vendor/zebra/dock/fx9600"),
            Ok(InputTopic::Vendor {
                format: VendorFormat::Zebra,
                source: "dock/fx9600"
            })
        );
        assert!(
            parse_input_topic("nomen/in/vendor/quuppa/x")
                .unwrap_err()
                .contains("unknown vendor format 'quuppa'")
        );
        assert!(
            parse_input_topic("nomen/in/vendor/pozyx")
                .unwrap_err()
                .contains("no source id")
        );
    }

    #[test]
    fn every_kind_round_trips_through_its_name() {
        for kind in InputKind::ALL {
            assert_eq!(InputKind::from_name(kind.name()), Some(kind));
        }
    }
}
