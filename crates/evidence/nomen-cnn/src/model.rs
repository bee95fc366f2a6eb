//! A trained model: the network plus its metadata, to and from bytes (safetensors weights and a
//! JSON metadata document), and its use as the engine's [`PairScorer`].
//!
//! # Files
//!
//! A model is two byte blobs (the CLI writes them as `MODEL.safetensors` and `MODEL.json`):
//! - the weights, safetensors, f32, one tensor per parameter (names in [`crate::network`]);
//! - the metadata, JSON ([`ModelMeta`]): format name and version, architecture, input
//!   specification (grid, channels, normalisation, filter settings), how the score is mapped,
//!   what it was trained on (a digest of the training pairs, counts, seed, epochs, validation
//!   figures) and the SHA-256 of the weights.
//!
//! [`CnnModel::from_bytes`] refuses anything it cannot vouch for, with an error naming the file
//! and what is wrong: metadata that is not JSON or not this format/version, an input
//! specification this build does not compute, weights whose digest differs from the metadata's
//! (a corrupt file, or weights of another model), unreadable safetensors, and missing, extra or
//! mis-shaped tensors.

use crate::error::{CnnError, Result};
use crate::features::{InputSpec, PairFeatures, pair_features};
use crate::network::{ModelSize, Network};
use candle_core::{Device, Tensor};
use nomen_core::bounded::{Limits, MIB_BYTES};
use nomen_core::skeleton::Joint;
use nomen_evidence::{ImuWindow, PairScorer, SkeletonWindow};
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

/// Format name written in every model's metadata.
pub const FORMAT: &str = "nomen-cnn";

/// Metadata version this build writes and reads.
pub const VERSION: u32 = 1;

/// How a match probability `p` becomes a score, as written in metadata.
pub const SCORE_MAPPING: &str = "2p-1";

/// The most bytes a model's weights file may have: 256 MiB. The shipped small model's weights
/// are 140 kB.
pub const MAX_WEIGHTS_BYTES: u64 = 256 * MIB_BYTES;

/// The limits a weights file (binary) is read within.
pub const WEIGHTS_LIMITS: Limits = Limits::binary("a model's weights file", MAX_WEIGHTS_BYTES);

/// What a model was trained on and how training went.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrainingInfo {
    /// SHA-256 (hex) over every training and validation pair's features, label and group, in
    /// order: two models with the same digest saw the same data.
    pub data_digest: String,
    /// Groups (scenes) used for training.
    pub train_groups: Vec<String>,
    /// Groups (scenes) held out for early stopping.
    pub val_groups: Vec<String>,
    /// Training pairs (positives + negatives).
    pub num_train_pairs: usize,
    /// Of which positives.
    pub num_train_positives: usize,
    /// Validation pairs.
    pub num_val_pairs: usize,
    /// Of which positives.
    pub num_val_positives: usize,
    /// Seed of initialisation, shuffling and dropout.
    pub seed: u64,
    /// Epochs run (early stopping may end before the maximum).
    pub num_epochs: usize,
    /// The epoch whose weights were kept (lowest validation loss), 1-based.
    pub best_epoch: usize,
    /// Validation cross-entropy at that epoch.
    pub best_val_loss: f64,
    /// Validation accuracy (p > 0.5 ⇔ same person) at that epoch.
    pub best_val_accuracy: f64,
}

/// A model's metadata document (see the module docs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelMeta {
    /// [`FORMAT`].
    pub format: String,
    /// [`VERSION`].
    pub version: u32,
    /// The crate version that wrote it.
    pub written_by: String,
    /// Architecture.
    pub size: ModelSize,
    /// Inputs.
    pub input: InputSpec,
    /// [`SCORE_MAPPING`]: the [`PairScorer`] score is `2p − 1` for match probability `p`.
    pub score: String,
    /// Training record.
    pub training: TrainingInfo,
    /// SHA-256 (hex) of the weights blob.
    pub weights_sha256: String,
}

/// A trained network with its metadata.
#[derive(Debug, Clone)]
pub struct CnnModel {
    meta: ModelMeta,
    network: Network,
}

/// Lower-case hex SHA-256 of `bytes`.
pub fn sha256_hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

impl CnnModel {
    /// Wraps a network and its metadata (the weights digest is filled in by
    /// [`CnnModel::to_bytes`]).
    pub fn new(meta: ModelMeta, network: Network) -> Self {
        Self { meta, network }
    }

    /// The metadata.
    pub fn meta(&self) -> &ModelMeta {
        &self.meta
    }

    /// The network.
    pub fn network(&self) -> &Network {
        &self.network
    }

    /// The weights (safetensors) and the metadata (pretty JSON, digest of those weights filled
    /// in).
    pub fn to_bytes(&self) -> Result<(Vec<u8>, String)> {
        let weights = safetensors::serialize(self.network.named_tensors(), None).map_err(|e| {
            CnnError::Safetensors {
                source_name: "<memory>".to_owned(),
                message: e.to_string(),
            }
        })?;
        let mut meta = self.meta.clone();
        meta.weights_sha256 = sha256_hex(&weights);
        let json = serde_json::to_string_pretty(&meta).map_err(|e| CnnError::Metadata {
            source_name: "<memory>".to_owned(),
            message: e.to_string(),
        })?;
        Ok((weights, json + "\n"))
    }

    /// Reads a model from its weights and metadata (see the module docs for what is checked).
    /// `weights_name` and `meta_name` name the sources in errors.
    pub fn from_bytes(
        weights: &[u8],
        weights_name: &str,
        meta_json: &str,
        meta_name: &str,
    ) -> Result<Self> {
        let meta = parse_meta(meta_json, meta_name)?;
        let found = sha256_hex(weights);
        if found != meta.weights_sha256 {
            return Err(CnnError::WeightsDigest {
                source_name: weights_name.to_owned(),
                expected: meta.weights_sha256.clone(),
                found,
            });
        }
        let tensors =
            candle_core::safetensors::load_buffer(weights, &Device::Cpu).map_err(|e| {
                CnnError::Safetensors {
                    source_name: weights_name.to_owned(),
                    message: e.to_string(),
                }
            })?;
        let network = Network::from_tensors(&meta.size, tensors, weights_name)?;
        Ok(Self { meta, network })
    }

    /// Match probabilities of a batch of pairs (all with this model's input length).
    pub fn match_probabilities(&self, pairs: &[&PairFeatures]) -> Result<Vec<f32>> {
        let (imu, skel) = batch_tensors(pairs, self.meta.input.num_samples)?;
        self.network.match_probability(&imu, &skel)
    }

    /// Match probability of one IMU window against one skeleton window at `site`; `None` when
    /// the pair has no usable features.
    pub fn match_probability(
        &self,
        imu: &ImuWindow,
        skeleton: &SkeletonWindow,
        site: Joint,
    ) -> Result<Option<f32>> {
        let Some(f) = pair_features(imu, skeleton, site, &self.meta.input) else {
            return Ok(None);
        };
        Ok(self.match_probabilities(&[&f])?.first().copied())
    }
}

/// Parses and checks metadata: JSON, format, version, supported input, valid size.
fn parse_meta(json: &str, source_name: &str) -> Result<ModelMeta> {
    let meta_err = |message: String| CnnError::Metadata {
        source_name: source_name.to_owned(),
        message,
    };
    let value: serde_json::Value =
        serde_json::from_str(json).map_err(|e| meta_err(e.to_string()))?;
    let format = value.get("format").and_then(|v| v.as_str()).unwrap_or("");
    let version = value
        .get("version")
        .and_then(serde_json::Value::as_u64)
        .unwrap_or(0);
    if format != FORMAT || version != u64::from(VERSION) {
        return Err(CnnError::Version {
            source_name: source_name.to_owned(),
            found_format: format.to_owned(),
            found_version: u32::try_from(version).unwrap_or(u32::MAX),
            expected_format: FORMAT,
            expected_version: VERSION,
        });
    }
    let meta: ModelMeta = serde_json::from_value(value).map_err(|e| meta_err(e.to_string()))?;
    if let Some(reason) = meta.input.unsupported_reason() {
        return Err(CnnError::InputSpec {
            source_name: source_name.to_owned(),
            message: reason,
        });
    }
    if meta.score != SCORE_MAPPING {
        return Err(CnnError::InputSpec {
            source_name: source_name.to_owned(),
            message: format!("score mapping {:?}, expected {SCORE_MAPPING:?}", meta.score),
        });
    }
    meta.size
        .validate(meta.input.num_samples)
        .map_err(|e| meta_err(e.to_string()))?;
    Ok(meta)
}

/// Stacks pairs into `[batch, channels, samples]` tensors for each branch.
pub(crate) fn batch_tensors(
    pairs: &[&PairFeatures],
    num_samples: usize,
) -> Result<(Tensor, Tensor)> {
    let len = crate::features::NUM_CHANNELS * num_samples;
    let mut imu = Vec::with_capacity(pairs.len() * len);
    let mut skel = Vec::with_capacity(pairs.len() * len);
    for p in pairs {
        if p.imu.len() != len || p.skeleton.len() != len {
            return Err(CnnError::Data(format!(
                "a pair has {} + {} values, the model takes {len} per branch",
                p.imu.len(),
                p.skeleton.len()
            )));
        }
        imu.extend_from_slice(&p.imu);
        skel.extend_from_slice(&p.skeleton);
    }
    let shape = (pairs.len(), crate::features::NUM_CHANNELS, num_samples);
    Ok((
        Tensor::from_vec(imu, shape, &Device::Cpu)?,
        Tensor::from_vec(skel, shape, &Device::Cpu)?,
    ))
}

/// A [`CnnModel`] as the engine's learned voter: the score is `2p − 1` for the model's match
/// probability `p` (the correlation scale of `nomen_evidence::ModelScores`), `None` when the
/// pair has no usable features or the backend fails (never a panic).
#[derive(Debug, Clone)]
pub struct CnnScorer {
    model: CnnModel,
}

impl CnnScorer {
    /// A scorer from a loaded model.
    pub fn new(model: CnnModel) -> Self {
        Self { model }
    }

    /// The model.
    pub fn model(&self) -> &CnnModel {
        &self.model
    }
}

impl PairScorer for CnnScorer {
    fn score(&self, imu: &ImuWindow, skeleton: &SkeletonWindow, site: Joint) -> Option<f64> {
        let p = self.model.match_probability(imu, skeleton, site).ok()??;
        let s = 2.0 * f64::from(p) - 1.0;
        s.is_finite().then(|| s.clamp(-1.0, 1.0))
    }
}
