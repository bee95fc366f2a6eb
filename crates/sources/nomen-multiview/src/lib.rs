//! Skeletons from calibrated cameras: camera models with distortion, 2D keypoint readers (OpenPose, COCO, MMPose), cross-view association, weighted DLT triangulation and track ids.
//!
//! A sans-IO pipeline in stages, each usable alone:
//!
//! 1. [`camera`]: a [`CalibratedCamera`] (pinhole intrinsics, Brown–Conrady distortion, its pose
//!    `world_from_camera`) projects world points to pixels and undistorts pixels to normalised
//!    points and world rays; [`parse_camera_file`] reads a rig's `cameras.toml`.
//! 2. [`keypoints`]: [`parse_keypoints`] reads one view's 2D detections from OpenPose, COCO or
//!    MMPose JSON onto the canonical joints.
//! 3. [`associate`]: detections of different views that are the same person, by the distance
//!    between the rays of their joints, clustered greedily under a threshold.
//! 4. [`triangulate`]: each joint of a person by confidence-weighted DLT, refined on the
//!    reprojection error, with views that disagree left out; a confidence from the number of
//!    views and the reprojection error. [`reconstruct_frame`] runs 3 and 4 on one frame.
//! 5. [`track`]: a [`Tracker`] gives the triangulated skeletons track ids (nearest pelvis within
//!    a gate) and turns them into the recording's `skeleton` messages, in the world frame.
//!
//! [`synth`] makes synthetic views (virtual cameras around a room, noise, missed joints, false
//! detections) for tests and `nomen experiment triangulation`. `docs/multiview.md` describes the
//! camera file, the formats and the measured accuracy.
//!
//! ```
//! use nomen_multiview::synth::{DetectionNoise, room_camera_intrinsics, room_rig, walker};
//! use nomen_multiview::{ReconstructionConfig, Tracker, TrackerConfig, reconstruct_frame};
//! use nomen_core::{CameraId, SessionTime};
//! use nalgebra::Point3;
//! use rand::SeedableRng;
//!
//! let cameras = room_rig(3, Point3::origin(), 4.0, 2.8, room_camera_intrinsics()).unwrap();
//! let person = walker(Point3::origin(), 1.5, 1.2, 0.0, 0.0);
//! let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
//! let views = nomen_multiview::synth::detect(&cameras, &[person], &DetectionNoise::pixel(1.0), 4.0, &mut rng);
//! let frame = reconstruct_frame(&cameras, &views, &ReconstructionConfig::default());
//! assert_eq!(frame.skeletons.len(), 1);
//! let config = TrackerConfig { min_frames: 1, ..TrackerConfig::default() };
//! let mut tracker = Tracker::new(CameraId::new("multiview"), config).unwrap();
//! let messages = tracker.push(SessionTime::ZERO, &frame.skeletons);
//! assert_eq!(messages[0].joints.len(), 20);
//! ```

#![warn(missing_docs)]

pub mod associate;
pub mod camera;
mod error;
pub mod keypoints;
pub mod reconstruct;
pub mod synth;
pub mod track;
pub mod triangulate;

pub use camera::{CalibratedCamera, CameraFile, Distortion, Intrinsics, parse_camera_file};
pub use error::{MultiviewError, Result};
pub use keypoints::{
    Detection, Keypoint, KeypointDocument, KeypointFormat, KeypointFrame, KeypointLimits,
    parse_keypoints,
};
pub use reconstruct::{
    FrameReconstruction, ReconstructionConfig, TriangulatedSkeleton, reconstruct_frame,
};
pub use track::{Tracker, TrackerConfig, joint_observations};
pub use triangulate::{TriangulatedJoint, TriangulationConfig};
