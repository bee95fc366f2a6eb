//! The streaming identity engine: messages in any interleaving, identified skeletons out, from wearable evidence fused over time.
//!
//! # Pipeline
//! [`Engine::push`] takes messages in any interleaving across sources, as long as each source
//! is late by at most [`EngineConfig::reorder_window_s`] behind its own newest message. Each
//! source is *settled* in time order below that frontier:
//! - skeleton joints go to the world frame (`world_from_camera` from the registry) and through
//!   a constant-velocity Kalman filter per joint ([`EngineConfig::joint_filter`]);
//! - IMU samples go through Madgwick's `update_imu` for `world_from_sensor`, giving the
//!   linear-acceleration magnitude `|R·a − g ẑ|` and the angular-rate magnitude.
//!
//! Every [`EngineConfig::hop_s`] a window of [`EngineConfig::window_s`] ending at a multiple of
//! the hop is processed once every source has delivered past its end plus the reorder window,
//! or once any source is [`EngineConfig::silence_timeout_s`] beyond that (a silent source
//! never blocks output). In each window:
//! 1. **clock offsets**, estimated jointly with identity: a device without an accepted offset
//!    is searched every [`EngineConfig::offset_search_interval_s`]. For every track covering
//!    [`EngineConfig::offset_min_track_s`] of the last [`EngineConfig::offset_estimation_window_s`],
//!    each IMU of the subject gets a lag curve (mean Pearson correlation of De Marchi's
//!    acceleration and orientation-change magnitudes, lags ±[`EngineConfig::max_clock_offset_s`]
//!    in 10 ms steps; near-tied peaks go to the smaller |lag|). The subject's score for a track is
//!    the mean of its IMUs' peaks; only when the best track beats the next one of its camera by
//!    [`EngineConfig::offset_margin`] (and reaches [`EngineConfig::offset_min_correlation`]) is
//!    each IMU's peak lag on it a candidate, and [`EngineConfig::offset_num_consistent`]
//!    candidates in a row within [`EngineConfig::offset_consistency_s`] make the offset. It is
//!    refined every [`EngineConfig::offset_refine_interval_s`] against the assigned track;
//! 2. **evidence**: per camera, a `nomen_evidence::ScoreTensor` (tracks × subjects × sites) of
//!    `geometric_scores` (De Marchi's acc/vel/ori correlations) for every active track and every
//!    IMU, resampled onto the track's timestamps at its offset — before the offset is accepted,
//!    at that (track, IMU) pair's own lag-curve peak, i.e. the max over the lag range, so
//!    identity can be found meanwhile. `nomen_evidence::fuse` with [`EngineConfig::fusion`]
//!    gives one score per (track, subject), accumulated by an exponentially weighted mean;
//! 3. **identity**: per camera, the accumulated track × subject matrix is solved by `nomen_assign::solve` with
//!    [`EngineConfig::rejection_threshold`]; the track's current label gets
//!    [`EngineConfig::switch_margin`] as a bonus (hysteresis). One subject never goes to two
//!    tracks of one camera; a track below threshold is [`nomen_core::Identity::Anonymous`].
//!
//! # Output and latency
//! Exactly one `Message::Identified` per accepted skeleton observation, with its `(t, camera,
//! track)`, labelled with the decision of the first window ending at or after
//! `t + decision_delay_s`. While all sources send, an observation is emitted at most
//! `decision_delay_s + hop_s + reorder_window_s` (default 2.25 s) of stream time after `t`
//! ([`EngineConfig::latency_s`]); a silent source adds at most `silence_timeout_s`.
//! Rejected messages produce no output.
//!
//! Sans-IO and deterministic: no clocks, files, threads or printing; all maps are ordered.
#![warn(missing_docs)]

mod config;
mod engine;
mod error;
mod signal;
mod stats;
mod tags;

pub use config::{EngineConfig, MotionScore};
pub use engine::Engine;
pub use error::{EngineError, Result};
pub use nomen_evidence::{Fusion, FusionConfig, GeometricConfig, KinematicConfig};
pub use stats::{ClockOffsetEstimate, EngineStats, RejectCounts};

use nomen_core::{Message, Registry};

/// Runs a whole recording through a fresh engine: pushes every message in order (bad messages
/// are rejected and counted, not fatal), polls, finishes. Returns the outputs and the stats.
pub fn run_batch(
    registry: &Registry,
    messages: &[Message],
    config: &EngineConfig,
) -> Result<(Vec<Message>, EngineStats)> {
    run_batch_with_rssi(registry, messages, config, None)
}

/// [`run_batch`] with RSSI evidence from a calibrated model ([`Engine::with_rssi_model`]).
pub fn run_batch_with_rssi(
    registry: &Registry,
    messages: &[Message],
    config: &EngineConfig,
    rssi_model: Option<&nomen_rssi::RssiModel>,
) -> Result<(Vec<Message>, EngineStats)> {
    let mut engine = Engine::new(registry.clone(), *config)?;
    if let Some(model) = rssi_model {
        engine = engine.with_rssi_model(model)?;
    }
    let mut out = Vec::new();
    for msg in messages {
        // A rejected message is counted in the stats; the run goes on.
        let _ = engine.push(msg);
        engine.poll(&mut out);
    }
    engine.finish(&mut out);
    Ok((out, engine.stats().clone()))
}
