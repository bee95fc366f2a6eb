//! The error type of `nomen-engine`.

use nomen_core::{AntennaId, CameraId, CoreError, DeviceId, DeviceKind, SessionTime};

/// Everything the engine can refuse.
///
/// A bad message is an error *for that message only*: [`crate::Engine::push`] returns it, counts
/// it in [`crate::EngineStats`] and the engine keeps running.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum EngineError {
    /// A configuration value is out of range.
    #[error("invalid engine config: {0}")]
    InvalidConfig(String),
    /// The registry does not validate.
    #[error("invalid registry: {0}")]
    Registry(CoreError),
    /// A message failed its own validation (NaN, out of range).
    #[error("{kind} from '{source_id}' at {t}: {error}")]
    InvalidMessage {
        /// Message type (`imu`, `skeleton`).
        kind: &'static str,
        /// Device or camera id.
        source_id: String,
        /// Message time.
        t: SessionTime,
        /// What is wrong with it.
        error: CoreError,
    },
    /// A sensor message from a device no subject wears.
    #[error("{kind} at {t} from unknown device '{device}'")]
    UnknownDevice {
        /// Message type (`imu`, `rtls_fix`, `rssi`).
        kind: &'static str,
        /// The device.
        device: DeviceId,
        /// Message time.
        t: SessionTime,
    },
    /// A sensor message from a registered device of another kind (an IMU sample from a tag, a
    /// position fix from an IMU).
    #[error("{kind} at {t} from device '{device}', which is registered as {registered:?}")]
    WrongDeviceKind {
        /// Message type.
        kind: &'static str,
        /// The device.
        device: DeviceId,
        /// What the registry says it is.
        registered: DeviceKind,
        /// Message time.
        t: SessionTime,
    },
    /// An RSSI read from an antenna the registry does not list.
    #[error("rssi read at {t} from unknown antenna '{antenna}'")]
    UnknownAntenna {
        /// The antenna.
        antenna: AntennaId,
        /// Message time.
        t: SessionTime,
    },
    /// A skeleton from a camera the registry does not list.
    #[error("skeleton at {t} from unknown camera '{camera}'")]
    UnknownCamera {
        /// The camera.
        camera: CameraId,
        /// Message time.
        t: SessionTime,
    },
    /// A second message with the same source and timestamp.
    #[error("duplicate {kind} from '{source_id}' at {t}")]
    Duplicate {
        /// Message type.
        kind: &'static str,
        /// Device id, or `camera/track`.
        source_id: String,
        /// Message time.
        t: SessionTime,
    },
    /// A message older than its source's reorder window allows.
    #[error("late {kind} from '{source_id}' at {t}: older than the reorder window")]
    Late {
        /// Message type.
        kind: &'static str,
        /// Device or camera id.
        source_id: String,
        /// Message time.
        t: SessionTime,
    },
    /// A message stamped further ahead of every time seen so far than
    /// [`crate::EngineConfig::max_time_jump_s`] allows.
    #[error(
        "{kind} from '{source_id}' at {t}: {ahead_s:.1} s ahead of the newest time so far; \
         refused as a time jump (the source's next message is taken if it follows on from \
         this one)"
    )]
    TimeJump {
        /// Message type.
        kind: &'static str,
        /// Device or camera id.
        source_id: String,
        /// Message time.
        t: SessionTime,
        /// How far ahead of the newest time so far, s.
        ahead_s: f64,
    },
    /// [`crate::Engine::advance_to`] with a time further ahead of the newest message than
    /// [`crate::EngineConfig::max_time_jump_s`] allows (a host clock off the session's).
    #[error(
        "advance_to {now}: {ahead_s:.1} s ahead of the newest message; refused as a time jump \
         (is the host's clock the session's?)"
    )]
    ClockAhead {
        /// The time the host gave.
        now: SessionTime,
        /// How far ahead of the newest message, s.
        ahead_s: f64,
    },
    /// A filter refused its configuration or input.
    #[error("filter: {0}")]
    Filter(#[from] nomen_filters::FilterError),
    /// The RSSI model or an RSSI read was refused (unknown antenna, implausible value).
    #[error("rssi: {0}")]
    Rssi(String),
    /// The assignment solver refused its input.
    #[error("assignment: {0}")]
    Assign(#[from] nomen_assign::AssignError),
}

impl From<nomen_rssi::RssiError> for EngineError {
    fn from(e: nomen_rssi::RssiError) -> Self {
        EngineError::Rssi(e.to_string())
    }
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, EngineError>;
