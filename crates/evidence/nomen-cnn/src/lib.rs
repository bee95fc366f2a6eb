//! De Marchi's two-branch 1D CNN: a learned score that an IMU window and a skeleton-joint window belong to the same person, trained and served on CPU with candle.
//!
//! De Marchi et al. pair their geometric correlations with a small convolutional network that
//! scores whether an IMU window and a skeleton-joint window come from the same person, and add
//! it as one more voter to their multilevel fusion. This crate is that network for nomen:
//!
//! - [`features`]: what the network sees — De Marchi's three magnitude signals per side
//!   (computed by `nomen_evidence`'s builders, not re-implemented), resampled onto a fixed
//!   3 s × 30 Hz grid and z-scored per window and channel ([`InputSpec`], [`pair_features`]).
//! - [`network`]: the two identical branches (Conv1D 3 → max-pool, …, the last block ending
//!   in global average pooling), concatenation, dense layers, two-class softmax
//!   ([`Network`], [`ModelSize::published`] and the smaller default [`ModelSize::small`]).
//! - [`dataset`]: training pairs recorded from the engine's own windows ([`PairRecorder`]),
//!   labelled from the simulator's ground truth ([`TruthLabels`]), balanced ([`balance`]).
//! - [`train`](mod@train): seeded CPU training with early stopping on held-out scenes
//!   ([`train()`](train::train), [`TrainConfig`]).
//! - [`model`]: weights (safetensors) + metadata (JSON) to and from bytes with integrity
//!   checks ([`CnnModel`]), and [`CnnScorer`], the engine's `nomen_evidence::PairScorer`.
//!
//! The score given to the engine is `2p − 1` for the match probability `p`, on the correlation
//! scale of `nomen_evidence::ModelScores`, where it enters every fusion as `Model::Dl`.
//!
//! Sans-IO: bytes in and out, progress through callbacks; the CLI (`nomen train cnn`) owns the
//! files and the terminal.

#![warn(missing_docs)]

mod error;
pub use error::{CnnError, Result};

pub mod dataset;
pub mod features;
pub mod model;
pub mod network;
pub mod train;

pub use dataset::{Example, PairRecorder, RecordedPair, TruthLabels, balance, label_pairs};
pub use features::{InputSpec, PairFeatures, pair_features};
pub use model::{CnnModel, CnnScorer, MAX_WEIGHTS_BYTES, ModelMeta, TrainingInfo, WEIGHTS_LIMITS};
pub use network::{ModelSize, Network};
pub use train::{TrainConfig, TrainEvent, data_digest, split_by_group};
