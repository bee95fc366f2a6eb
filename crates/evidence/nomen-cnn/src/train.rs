//! Training on CPU: AdamW on the cross-entropy of the two-class output, mini-batches in a seeded
//! order, dropout on the dense layers, early stopping on a held-out set of *groups* (scenes), the
//! best epoch's weights kept.
//!
//! Sans-IO: progress is reported through a callback (the CLI draws a bar); nothing here reads
//! a clock or a file.

use crate::dataset::Example;
use crate::error::{CnnError, Result};
use crate::features::InputSpec;
use crate::model::{CnnModel, FORMAT, ModelMeta, SCORE_MAPPING, TrainingInfo, VERSION};
use crate::network::{ModelSize, Network};
use candle_core::{Device, Tensor};
use candle_nn::Optimizer;
use candle_nn::optim::{AdamW, ParamsAdamW};
use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use std::collections::BTreeSet;

/// Training settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TrainConfig {
    /// Architecture. Default [`ModelSize::small`].
    pub size: ModelSize,
    /// Inputs. Default [`InputSpec::default`].
    pub input: InputSpec,
    /// Seed of initialisation, shuffling and dropout. Default 1.
    pub seed: u64,
    /// Pairs per mini-batch. Default 64.
    pub batch_size: usize,
    /// AdamW learning rate. Default 1e-3 (Kingma & Ba's default).
    pub learning_rate: f64,
    /// AdamW decoupled weight decay. Default 1e-4.
    pub weight_decay: f64,
    /// Dropout probability on the dense layers. Default 0.2 (De Marchi et al.).
    pub dropout: f32,
    /// Most epochs. Default 30.
    pub max_epochs: usize,
    /// Stop after this many epochs without a lower validation loss. Default 4.
    pub patience: usize,
}

impl Default for TrainConfig {
    fn default() -> Self {
        Self {
            size: ModelSize::small(),
            input: InputSpec::default(),
            seed: 1,
            batch_size: 64,
            learning_rate: 1e-3,
            weight_decay: 1e-4,
            dropout: 0.2,
            max_epochs: 30,
            patience: 4,
        }
    }
}

/// What training reports as it goes.
#[derive(Debug, Clone, PartialEq)]
pub enum TrainEvent {
    /// A mini-batch was applied.
    Batch {
        /// Epoch, 1-based.
        epoch: usize,
        /// Batch within the epoch, 1-based.
        batch: usize,
        /// Batches per epoch.
        num_batches: usize,
        /// The batch's loss.
        loss: f64,
    },
    /// An epoch ended and was validated.
    Epoch {
        /// Epoch, 1-based.
        epoch: usize,
        /// Mean training loss over the epoch.
        train_loss: f64,
        /// Validation loss.
        val_loss: f64,
        /// Validation accuracy.
        val_accuracy: f64,
        /// Whether this epoch is the best so far (its weights are kept).
        is_best: bool,
    },
}

/// Digest of the training data: SHA-256 over every example's group, label and features.
pub fn data_digest(train: &[Example], val: &[Example]) -> String {
    let mut h = Sha256::new();
    for (tag, set) in [(b"train", train), (b"valid", val)] {
        h.update(tag);
        h.update((set.len() as u64).to_le_bytes());
        for e in set {
            h.update((e.group.len() as u64).to_le_bytes());
            h.update(e.group.as_bytes());
            h.update([u8::from(e.is_match)]);
            for v in e.features.imu.iter().chain(&e.features.skeleton) {
                h.update(v.to_le_bytes());
            }
        }
    }
    h.finalize().iter().map(|b| format!("{b:02x}")).collect()
}

/// Splits examples by group: groups in `val_groups` are held out.
pub fn split_by_group(
    examples: Vec<Example>,
    val_groups: &[String],
) -> (Vec<Example>, Vec<Example>) {
    examples
        .into_iter()
        .partition(|e| !val_groups.contains(&e.group))
}

/// Trains a model on `train`, stopping early on `val` (see the module docs).
pub fn train(
    train: &[Example],
    val: &[Example],
    cfg: &TrainConfig,
    progress: &mut dyn FnMut(&TrainEvent),
) -> Result<CnnModel> {
    check_data(train, "training")?;
    check_data(val, "validation")?;
    if let Some(reason) = cfg.input.unsupported_reason() {
        return Err(CnnError::Config(reason));
    }
    cfg.size.validate(cfg.input.num_samples)?;
    if cfg.batch_size == 0 || cfg.max_epochs == 0 {
        return Err(CnnError::Config(
            "batch_size and max_epochs must be at least 1".to_owned(),
        ));
    }
    if !(0.0..1.0).contains(&cfg.dropout) {
        return Err(CnnError::Config(format!(
            "dropout {} outside 0..1",
            cfg.dropout
        )));
    }
    let len = cfg.input.branch_len();
    if let Some(bad) = train
        .iter()
        .chain(val)
        .find(|e| e.features.imu.len() != len || e.features.skeleton.len() != len)
    {
        return Err(CnnError::Data(format!(
            "a pair of group {:?} has {} + {} values, the input specification needs {len} per branch",
            bad.group,
            bad.features.imu.len(),
            bad.features.skeleton.len()
        )));
    }
    let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
    let network = Network::init(&cfg.size, &mut rng)?;
    let mut opt = AdamW::new(
        network.vars().to_vec(),
        ParamsAdamW {
            lr: cfg.learning_rate,
            weight_decay: cfg.weight_decay,
            ..ParamsAdamW::default()
        },
    )?;
    let num_batches = train.len().div_ceil(cfg.batch_size);
    let mut order: Vec<usize> = (0..train.len()).collect();
    let mut best: Option<(usize, f64, f64, Vec<Tensor>)> = None;
    let mut num_epochs = 0;
    for epoch in 1..=cfg.max_epochs {
        num_epochs = epoch;
        order.shuffle(&mut rng);
        let mut loss_sum = 0.0;
        for (b, chunk) in order.chunks(cfg.batch_size).enumerate() {
            let batch: Vec<&Example> = chunk.iter().filter_map(|&i| train.get(i)).collect();
            let (imu, skel, labels) = tensors(&batch, &cfg.input)?;
            let logits = network.forward(&imu, &skel, Some((cfg.dropout, &mut rng)))?;
            let loss = candle_nn::loss::cross_entropy(&logits, &labels)?;
            opt.backward_step(&loss)?;
            let loss = f64::from(loss.to_scalar::<f32>()?);
            loss_sum += loss * batch.len() as f64;
            progress(&TrainEvent::Batch {
                epoch,
                batch: b + 1,
                num_batches,
                loss,
            });
        }
        let (val_loss, val_accuracy) = evaluate(&network, val, &cfg.input, cfg.batch_size)?;
        let is_best = best.as_ref().is_none_or(|b| val_loss < b.1);
        if is_best {
            best = Some((epoch, val_loss, val_accuracy, network.snapshot()?));
        }
        progress(&TrainEvent::Epoch {
            epoch,
            train_loss: loss_sum / train.len() as f64,
            val_loss,
            val_accuracy,
            is_best,
        });
        if best.as_ref().is_some_and(|b| epoch >= b.0 + cfg.patience) {
            break;
        }
    }
    let Some((best_epoch, best_val_loss, best_val_accuracy, weights)) = best else {
        return Err(CnnError::Data("no epoch was run".to_owned()));
    };
    network.restore(&weights)?;
    let groups = |set: &[Example]| -> Vec<String> {
        set.iter()
            .map(|e| e.group.clone())
            .collect::<BTreeSet<_>>()
            .into_iter()
            .collect()
    };
    let meta = ModelMeta {
        format: FORMAT.to_owned(),
        version: VERSION,
        written_by: format!("nomen-cnn {}", env!("CARGO_PKG_VERSION")),
        size: cfg.size.clone(),
        input: cfg.input.clone(),
        score: SCORE_MAPPING.to_owned(),
        training: TrainingInfo {
            data_digest: data_digest(train, val),
            train_groups: groups(train),
            val_groups: groups(val),
            num_train_pairs: train.len(),
            num_train_positives: train.iter().filter(|e| e.is_match).count(),
            num_val_pairs: val.len(),
            num_val_positives: val.iter().filter(|e| e.is_match).count(),
            seed: cfg.seed,
            num_epochs,
            best_epoch,
            best_val_loss,
            best_val_accuracy,
        },
        weights_sha256: String::new(),
    };
    Ok(CnnModel::new(meta, network))
}

fn check_data(set: &[Example], what: &str) -> Result<()> {
    let num_pos = set.iter().filter(|e| e.is_match).count();
    if num_pos == 0 || num_pos == set.len() {
        return Err(CnnError::Data(format!(
            "the {what} set needs matched and mismatched pairs ({num_pos} matched of {})",
            set.len()
        )));
    }
    Ok(())
}

fn tensors(batch: &[&Example], input: &InputSpec) -> Result<(Tensor, Tensor, Tensor)> {
    let features: Vec<_> = batch.iter().map(|e| &e.features).collect();
    let (imu, skel) = crate::model::batch_tensors(&features, input.num_samples)?;
    let labels: Vec<u32> = batch.iter().map(|e| u32::from(e.is_match)).collect();
    let labels = Tensor::from_vec(labels, batch.len(), &Device::Cpu)?;
    Ok((imu, skel, labels))
}

/// Mean cross-entropy and accuracy (p > 0.5 ⇔ match) of `network` on `set`.
fn evaluate(
    network: &Network,
    set: &[Example],
    input: &InputSpec,
    batch_size: usize,
) -> Result<(f64, f64)> {
    let (mut loss_sum, mut num_right) = (0.0, 0usize);
    for chunk in set.chunks(batch_size.max(1)) {
        let batch: Vec<&Example> = chunk.iter().collect();
        let (imu, skel, labels) = tensors(&batch, input)?;
        let logits = network.forward(&imu, &skel, None)?;
        let loss = candle_nn::loss::cross_entropy(&logits, &labels)?;
        loss_sum += f64::from(loss.to_scalar::<f32>()?) * batch.len() as f64;
        let p = candle_nn::ops::softmax_last_dim(&logits)?
            .narrow(1, 1, 1)?
            .flatten_all()?
            .to_vec1::<f32>()?;
        num_right += p
            .iter()
            .zip(&batch)
            .filter(|(p, e)| (**p > 0.5) == e.is_match)
            .count();
    }
    let n = set.len().max(1) as f64;
    Ok((loss_sum / n, num_right as f64 / n))
}
