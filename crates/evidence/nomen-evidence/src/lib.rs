//! Evidence that a wearable and a skeleton belong to the same person: De Marchi's geometric correlations, Belmonte-Hernández's pitch and yaw-rate costs, and score fusion by voting.
//!
//! Everything here works on one synchronised window at a time ([`window`]): an IMU's samples and
//! a camera track's joints on the same time grid, in the world frame. The engine builds the
//! windows; this crate turns them into scores. Sans-IO, no clocks.
//!
//! - [`geometric`]: De Marchi's three correlations ([`geometric_scores`]) and the magnitude
//!   signals behind them, public so the engine can run [`best_lag`] on longer buffers.
//! - [`features`]: the per-side signals of every model ([`ImuFeatures`], [`SegmentFeatures`]),
//!   built once per window and correlated with many candidates ([`compare_features`]).
//! - [`signal`]: [`pearson`] and the clock-offset search [`best_lag`].
//! - [`belmonte`]: Belmonte-Hernández's pitch and yaw-rate costs ([`belmonte_costs`]).
//! - [`fusion`]: [`ScoreTensor`] → [`ScoreMatrix`] by [`fuse`] (mean, max, threshold, voting).
//! - [`scorer`]: [`PairScorer`], the seam for a learned model (e.g. `nomen-cnn`) whose score
//!   enters the fusions as [`Model::Dl`] through [`ModelScores::dl`].
//!
//! Bad data never panics or errors: a score or cost that cannot be computed is `None`.

#![warn(missing_docs)]

mod error;
pub use error::{EvidenceError, Result};

pub mod angle;
pub mod belmonte;
pub mod features;
pub mod fusion;
pub mod geometric;
pub mod kinematic;
pub mod scorer;
pub mod signal;
pub mod window;

pub use belmonte::{
    BandSignals, BelmonteConfig, BelmonteCosts, ForearmSignals, SensorAxis, Side, axis_pitches_rad,
    belmonte_costs, belmonte_costs_from, vertical_rate_unsmoothed_radps,
};
pub use features::{
    HorizontalCross, ImuFeatures, ImuUnits, RawSignals, SegmentFeatures, SegmentUnits,
    axis_elevations_rad, compare_features, compare_prepared, horizontal_cross,
    horizontal_cross_prepared, imu_lag_models, imu_unanchored_lag_models, segment_lag_models,
    segment_site_lag_models,
};
pub use fusion::{Fusion, FusionConfig, MAX_TENSOR_ENTRIES, Model, ScoreMatrix, ScoreTensor, fuse};
pub use geometric::{
    GeometricConfig, carrying_segment, geometric_scores, imu_accel_magnitude,
    imu_linear_accel_world, imu_orientation_magnitude, imu_velocity_magnitude,
    joint_accel_magnitude, joint_velocity_magnitude, segment_orientation_magnitude,
};
pub use kinematic::{
    KinematicConfig, KinematicScores, body_turn_rate_from, body_turn_rate_signal, imu_swing_signal,
    imu_turn_rate_from, imu_turn_rate_signal, imu_vertical_accel, joint_vertical_accel,
    kinematic_scores, segment_swing_signal,
};
pub use scorer::PairScorer;
pub use signal::{
    LagConfig, PearsonSums, UnitSignal, best_lag, best_lag_with, concordance, first_finite,
    pearson, pearson_prepared,
};
pub use window::{ImuWindow, ModelScores, SkeletonWindow};
