//! Real-time location of UWB tags and their fusion with skeletons: multilateration (two-way ranging and TDoA), tag Kalman filtering with outlier gating, the tag-joint likelihood and Baptizo.
//!
//! - [`multilat`]: positions from raw ranges (robust Levenberg–Marquardt / IRLS), range bias.
//! - [`epochs`]: a stream of raw two-way ranges grouped into ranging cycles, each solved into a
//!   fix.
//! - [`track`]: a constant-velocity Kalman filter per tag with Mahalanobis gating, re-acquisition
//!   after consistent rejections and reset after silence.
//! - [`likelihood`]: the per-frame (tag, key joint) log-likelihood and `[0, 1]` score the engine
//!   uses as UWB evidence; the key joint per tag.
//! - [`baptizo`]: Bazo's Baptizo (FUSE, INIT, SENSOR_FUSION with the persistence map, ghosting)
//!   as a sans-IO struct and [`run_baptizo`] for `method = "baptizo"`.
//!
//! Nothing here opens files or reads clocks.

mod error;
pub use error::{Result, RtlsError};

pub mod baptizo;
pub mod epochs;
pub mod likelihood;
pub mod multilat;
pub mod track;

pub use baptizo::{Baptizo, BaptizoConfig, run_baptizo};
pub use epochs::{EpochConfig, EpochStats, RangeEpochs};
pub use likelihood::{KeyJoints, TagJointLikelihood, tag_joint_likelihood};
pub use multilat::{AnchorRange, MultilaterationConfig, PositionSolution, solve_tdoa, solve_twr};
pub use track::{TagFilterConfig, TagState, TagTracker};
