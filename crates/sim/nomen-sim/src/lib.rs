//! Scene simulator driven by real motion capture: people, cameras, IMUs, UWB and RSSI tags with noise fitted to real recordings, plus ground truth.
//!
//! The simulator is sans-IO: it takes parsed motion-capture clips, a scenario and a seed, and
//! returns messages. Reading BVH files and writing recordings is the CLI's job.
//!
//! - [`body`]: the interface between people and sensors: a [`body::BodyMotion`] gives a smooth
//!   whole-body pose at any time; sensors sample it where they are mounted.
//! - [`family`]: scene families, randomized scenarios drawn from one definition (the held-out
//!   benchmark's scenes).
//! - [`faults`]: sensor faults injected into a scene's messages (lost samples, a dark camera,
//!   wrong clocks, UWB outliers, duplicated and late messages), for `nomen experiment faults`.
//! - [`rng`]: seeded, named random streams, so that adding a device does not change the noise of
//!   the others.

pub mod body;
pub mod camera;
pub mod clips;
mod error;
pub mod family;
pub mod faults;
pub mod geometry;
pub mod motion;
pub mod rng;
pub mod scenario;
pub mod scene;
pub mod sensors;

pub use error::{Result, SimError};
pub use scenario::Scenario;
pub use scene::{SceneDescription, SimOutput, load_clip, load_scenario_clips, simulate};
