//! Time, frames, skeletons, sensor messages and the registry: the data model every nomen crate speaks, with no I/O.
//!
//! Conventions that hold everywhere in nomen (see `ARCHITECTURE.md`):
//! - time is [`SessionTime`]: integer nanoseconds on the session clock;
//! - the world frame is Z up, the floor is the XY plane, lengths are metres;
//! - transforms are named `target_from_source` (`world_from_camera * p_in_camera`);
//! - angles are radians, rates rad/s, accelerations m/s², magnetic fields µT, RSSI dBm.
//!
//! Nothing in this crate opens files or sockets or reads clocks; [`bounded`] reads, within
//! limits, the readers it is given.

pub mod bounded;
mod error;
pub mod frame;
pub mod geometry;
pub mod ids;
pub mod message;
pub mod registry;
pub mod sensor;
pub mod skeleton;
pub mod time;

pub use error::{CoreError, Result};
pub use frame::RigidTransform;
pub use ids::{AnchorId, AntennaId, CameraId, DeviceId, SubjectId, TagId, TrackId};
pub use message::{
    Candidate, DecisionRule, DecisionTrace, Evidence, IdentifiedSkeleton, Identity, Message,
    TagCorrection, TruthSkeleton, TruthTag,
};
pub use registry::{
    Anchor, Antenna, Calibration, Camera, CameraCalibration, CameraIntrinsics, DeviceCalibration,
    DeviceKind, Registry, Subject, Wearable,
};
pub use sensor::{ImuSample, RssiRead, RtlsFix, UwbRange};
pub use skeleton::{Joint, JointObservation, JointState, SkeletonObservation};
pub use time::{ClockModel, MAX_ABS_SESSION_TIME_S, SessionTime};
