//! The seam for learned pair scorers: a model outside this crate (e.g. De Marchi's two-branch
//! CNN in `nomen-cnn`) scores one (IMU window, skeleton window) pair, and the engine stores that
//! score as [`ModelScores::dl`](crate::ModelScores::dl) so every fusion can use it as one more
//! model ([`Model::Dl`](crate::Model::Dl)).
//!
//! The trait keeps this crate free of any neural-network dependency: the engine holds a
//! `Box<dyn PairScorer>` and never needs to know what is behind it.

use crate::window::{ImuWindow, SkeletonWindow};
use nomen_core::skeleton::Joint;

/// Scores how likely an IMU worn at `site` and the joint `site` of a camera skeleton belong to
/// the same person, from one synchronised window (both windows on the same grid, as given to
/// [`geometric_scores`](crate::geometric_scores)).
///
/// The score is on the **correlation scale** of [`ModelScores`](crate::ModelScores), `-1..=1`,
/// higher meaning "same person", so that [`fuse`](crate::fuse)'s thresholds and vote rules
/// apply to it as to De Marchi's correlations (a classifier giving a match probability `p`
/// returns `2p − 1`). `None` when the pair cannot be scored (window too short, signals missing,
/// grids that differ). Implementations must not panic on any input, and must be deterministic.
pub trait PairScorer: Send + Sync {
    /// The score of one pair, in `-1..=1`, or `None`.
    fn score(&self, imu: &ImuWindow, skeleton: &SkeletonWindow, site: Joint) -> Option<f64>;
}

impl<T: PairScorer + ?Sized> PairScorer for Box<T> {
    fn score(&self, imu: &ImuWindow, skeleton: &SkeletonWindow, site: Joint) -> Option<f64> {
        (**self).score(imu, skeleton, site)
    }
}

impl<T: PairScorer + ?Sized> PairScorer for std::sync::Arc<T> {
    fn score(&self, imu: &ImuWindow, skeleton: &SkeletonWindow, site: Joint) -> Option<f64> {
        (**self).score(imu, skeleton, site)
    }
}
