//! Identifiers. Strings where a person types them in a registry, integers where a camera SDK
//! hands them out.

use serde::{Deserialize, Serialize};
use std::fmt;

macro_rules! string_id {
    ($(#[$doc:meta])* $name:ident) => {
        $(#[$doc])*
        #[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
        #[serde(transparent)]
        pub struct $name(pub String);

        impl $name {
            /// Creates an id from anything string-like.
            pub fn new(s: impl Into<String>) -> Self {
                Self(s.into())
            }
            /// The id as a string slice.
            pub fn as_str(&self) -> &str {
                &self.0
            }
        }

        impl fmt::Display for $name {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str(&self.0)
            }
        }

        impl From<&str> for $name {
            fn from(s: &str) -> Self {
                Self(s.to_owned())
            }
        }
    };
}

string_id!(
    /// A person known to the system (wears devices, or is listed so that it can be named).
    SubjectId
);
string_id!(
    /// A wearable device: an IMU, a smartwatch, a UWB/BLE tag, a passive RFID tag.
    DeviceId
);
string_id!(
    /// A camera (or a multi-camera system) that reports skeletons.
    CameraId
);
string_id!(
    /// A fixed UWB anchor.
    AnchorId
);
string_id!(
    /// A fixed RSSI receiving antenna (an RFID reader port or a BLE anchor).
    AntennaId
);

/// A location or RSSI tag is a device; the alias documents intent at use sites.
pub type TagId = DeviceId;

/// The camera SDK's own body/track id. **Not stable**: SDKs re-label a person after an occlusion,
/// on re-entry, or swap two ids when people cross. It never reveals who the person is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(transparent)]
pub struct TrackId(pub u64);

impl fmt::Display for TrackId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0)
    }
}
