//! A body-tracking depth camera (Kinect v2 / Azure Kinect class): what it reports of the people
//! in front of it, frame by frame, and the matching ground truth.
//!
//! **Camera frame** (OpenCV and Azure Kinect depth-camera convention): +Z forward along the
//! optical axis, +X right in the image, +Y down in the image, metres. Kinect v2 "camera space"
//! (X left, Y up) would be converted at ingest; the simulator reports in this frame only.
//! [`CameraModel::world_from_camera`] maps it into the world (Z up).
//!
//! What is modelled:
//! - field of view and depth range (a body is reported only while its pelvis is inside);
//! - occlusion per joint by other people's capsules, static boxes and, coarsely, the person's own
//!   trunk ([`OcclusionConfig`]): hidden joints are `Inferred` (held where they were last seen
//!   relative to the pelvis, with larger noise) and `Missing` after a while; a body with too few
//!   visible joints is not reported;
//! - depth-dependent joint noise ([`JointNoiseConfig`]);
//! - track ids as SDKs give them ([`TrackingConfig`]): acquisition delay, id kept over short
//!   occlusions, new id after long ones and on re-entry (also after an absence from the room),
//!   occasional swaps after close encounters, occasional left/right flips of people facing away,
//!   optional re-labelling of bodies that stay visible.
//!
//! Not modelled (yet): systematic per-joint bias and bone-length errors, depth-image artefacts
//! (multipath, flying pixels, sunlight), lens distortion, frame drops and the camera clock (the
//! caller maps times with the registry's `ClockModel`).

mod config;
mod position_only;
mod sim;

pub use config::{
    CameraModelConfig, JointNoiseConfig, OcclusionConfig, PositionOnlyConfig, TrackingConfig,
};
pub use position_only::to_position_only;
pub(crate) use sim::is_limb;
pub use sim::{CameraModel, CameraOutput, CameraSimulator, PersonInScene};
