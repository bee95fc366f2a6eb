//! The two-branch 1D CNN (De Marchi et al.) on candle tensors.
//!
//! Each branch (one for the IMU window, one for the skeleton-joint window; same architecture,
//! separate weights) is `num_blocks` blocks of Conv1D (`filters` filters, kernel 3, same
//! padding, ReLU), each followed by max pooling of 2 except the last, which ends in global
//! average pooling over time. The two branch outputs are concatenated and go through the dense
//! layers (ReLU, dropout in training only) to two logits; softmax gives the probability that the
//! pair is the same person.
//!
//! Parameters are named `{imu,skel}.conv{i}.{w,b}`, `dense{i}.{w,b}` and `out.{w,b}`; conv
//! weights are `[out, in, 3]`, dense weights `[in, out]`. Weights are initialised here, from a
//! seeded ChaCha stream (He-normal, zero biases), because candle's CPU generator cannot be
//! seeded; dropout masks come from the same kind of stream. Training is therefore repeatable.

use crate::error::{CnnError, Result};
use crate::features::NUM_CHANNELS;
use candle_core::{D, DType, Device, Tensor, Var};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};

/// Kernel length of every convolution (De Marchi et al.).
pub const KERNEL_LEN: usize = 3;

/// The network's size.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelSize {
    /// Filters of every convolution.
    pub filters: usize,
    /// Conv blocks per branch; all but the last end in max pooling of 2, the last in global
    /// average pooling.
    pub num_blocks: usize,
    /// Widths of the dense layers after the concatenation.
    pub dense: Vec<usize>,
}

impl ModelSize {
    /// The sizes De Marchi et al. publish: 128 filters, dense 256 → 256 → 512 → 128. The number
    /// of conv repetitions is not stated in the text we work from ("repeated, the last ending in
    /// global average pooling"); we use 3, which takes the 90-sample window to 22 samples before
    /// the global pooling. About 0.53 M parameters (2.1 MB of f32).
    pub fn published() -> Self {
        Self {
            filters: 128,
            num_blocks: 3,
            dense: vec![256, 256, 512, 128],
        }
    }

    /// nomen's default: the published shape at a quarter of the width (32 filters, dense
    /// 64 → 64 → 128 → 32), about 36 k parameters, trainable in about a minute on two cores.
    pub fn small() -> Self {
        Self {
            filters: 32,
            num_blocks: 3,
            dense: vec![64, 64, 128, 32],
        }
    }

    /// A few-second-to-train network for tests (8 filters, 2 blocks, dense 16).
    pub fn tiny() -> Self {
        Self {
            filters: 8,
            num_blocks: 2,
            dense: vec![16],
        }
    }

    /// Checks the size is usable for a grid of `num_samples`.
    pub fn validate(&self, num_samples: usize) -> Result<()> {
        if self.filters == 0 || self.filters > 4096 {
            return Err(CnnError::Config(format!(
                "filters {} outside 1..=4096",
                self.filters
            )));
        }
        if self.num_blocks == 0 || self.num_blocks > 8 {
            return Err(CnnError::Config(format!(
                "num_blocks {} outside 1..=8",
                self.num_blocks
            )));
        }
        if self.dense.iter().any(|&w| w == 0 || w > 8192) || self.dense.len() > 8 {
            return Err(CnnError::Config(format!(
                "dense widths {:?}: at most 8 layers of 1..=8192",
                self.dense
            )));
        }
        // Every max pooling halves the time axis; the last block needs at least one sample.
        if num_samples >> (self.num_blocks - 1) == 0 {
            return Err(CnnError::Config(format!(
                "{} blocks pool a {num_samples}-sample window to nothing",
                self.num_blocks
            )));
        }
        Ok(())
    }

    /// Every parameter's name and shape, in a fixed order.
    pub fn parameter_shapes(&self) -> Vec<(String, Vec<usize>)> {
        let mut out = Vec::new();
        for side in ["imu", "skel"] {
            let mut c_in = NUM_CHANNELS;
            for i in 0..self.num_blocks {
                out.push((
                    format!("{side}.conv{i}.w"),
                    vec![self.filters, c_in, KERNEL_LEN],
                ));
                out.push((format!("{side}.conv{i}.b"), vec![self.filters]));
                c_in = self.filters;
            }
        }
        let mut d_in = 2 * self.filters;
        for (i, &w) in self.dense.iter().enumerate() {
            out.push((format!("dense{i}.w"), vec![d_in, w]));
            out.push((format!("dense{i}.b"), vec![w]));
            d_in = w;
        }
        out.push(("out.w".to_owned(), vec![d_in, 2]));
        out.push(("out.b".to_owned(), vec![2]));
        out
    }

    /// Number of scalar parameters.
    pub fn num_parameters(&self) -> usize {
        self.parameter_shapes()
            .iter()
            .map(|(_, s)| s.iter().product::<usize>())
            .sum()
    }
}

/// The network's parameters (candle variables, so the same struct trains and infers).
#[derive(Debug, Clone)]
pub struct Network {
    size: ModelSize,
    names: Vec<String>,
    vars: Vec<Var>,
}

impl Network {
    /// A freshly initialised network (He-normal weights from `rng`, zero biases).
    pub fn init(size: &ModelSize, rng: &mut ChaCha8Rng) -> Result<Self> {
        let mut names = Vec::new();
        let mut vars = Vec::new();
        for (name, shape) in size.parameter_shapes() {
            let len: usize = shape.iter().product();
            let data: Vec<f32> = if name.ends_with(".b") {
                vec![0.0; len]
            } else {
                // fan-in: inputs × kernel for a conv, inputs for a dense layer.
                let fan_in: usize = if shape.len() == 3 {
                    shape[1] * shape[2]
                } else {
                    shape[0]
                };
                let std = (2.0 / fan_in.max(1) as f64).sqrt();
                let normal = Normal::new(0.0, std)
                    .map_err(|e| CnnError::Config(format!("initialising {name}: {e}")))?;
                (0..len).map(|_| normal.sample(rng) as f32).collect()
            };
            let t = Tensor::from_vec(data, shape.as_slice(), &Device::Cpu)?;
            names.push(name);
            vars.push(Var::from_tensor(&t)?);
        }
        Ok(Self {
            size: size.clone(),
            names,
            vars,
        })
    }

    /// A network from named tensors (as read from a weights file): every parameter of `size`
    /// must be there with its shape and type f32, and nothing else.
    pub fn from_tensors(
        size: &ModelSize,
        mut tensors: std::collections::HashMap<String, Tensor>,
        source_name: &str,
    ) -> Result<Self> {
        let mut names = Vec::new();
        let mut vars = Vec::new();
        let err = |tensor: &str, message: String| CnnError::Tensor {
            source_name: source_name.to_owned(),
            tensor: tensor.to_owned(),
            message,
        };
        for (name, shape) in size.parameter_shapes() {
            let t = tensors
                .remove(&name)
                .ok_or_else(|| err(&name, "missing".to_owned()))?;
            if t.dims() != shape.as_slice() {
                return Err(err(
                    &name,
                    format!(
                        "shape {:?}, the metadata's architecture needs {shape:?}",
                        t.dims()
                    ),
                ));
            }
            if t.dtype() != DType::F32 {
                return Err(err(&name, format!("type {:?}, expected f32", t.dtype())));
            }
            names.push(name);
            vars.push(Var::from_tensor(&t)?);
        }
        let mut extra: Vec<&String> = tensors.keys().collect();
        extra.sort();
        if let Some(first) = extra.first() {
            return Err(err(
                first,
                "not part of the metadata's architecture".to_owned(),
            ));
        }
        Ok(Self {
            size: size.clone(),
            names,
            vars,
        })
    }

    /// The size.
    pub fn size(&self) -> &ModelSize {
        &self.size
    }

    /// The variables, for an optimiser.
    pub fn vars(&self) -> &[Var] {
        &self.vars
    }

    /// `(name, tensor)` of every parameter, in a fixed order.
    pub fn named_tensors(&self) -> impl Iterator<Item = (&str, &Tensor)> {
        self.names
            .iter()
            .map(String::as_str)
            .zip(self.vars.iter().map(Var::as_tensor))
    }

    /// Copies of the current parameter values (for keeping the best epoch).
    pub fn snapshot(&self) -> Result<Vec<Tensor>> {
        Ok(self
            .vars
            .iter()
            .map(|v| v.as_tensor().copy())
            .collect::<candle_core::Result<_>>()?)
    }

    /// Restores values taken by [`Network::snapshot`].
    pub fn restore(&self, values: &[Tensor]) -> Result<()> {
        for (v, t) in self.vars.iter().zip(values) {
            v.set(t)?;
        }
        Ok(())
    }

    fn param(&self, index: &mut usize) -> Result<&Tensor> {
        let v = self.vars.get(*index).ok_or_else(|| {
            CnnError::Config(format!("parameter {index} missing from the network"))
        })?;
        *index += 1;
        Ok(v.as_tensor())
    }

    /// Logits `[batch, 2]` (class 1 = same person) for `imu` and `skel` inputs
    /// `[batch, NUM_CHANNELS, num_samples]`. With `dropout = Some((p, rng))` the dense layers drop
    /// each activation with probability `p` (inverted dropout, training only).
    pub fn forward(
        &self,
        imu: &Tensor,
        skel: &Tensor,
        mut dropout: Option<(f32, &mut ChaCha8Rng)>,
    ) -> Result<Tensor> {
        let mut index = 0usize;
        let a = self.branch(imu, &mut index)?;
        let b = self.branch(skel, &mut index)?;
        let mut x = Tensor::cat(&[&a, &b], 1)?;
        for _ in 0..self.size.dense.len() {
            let w = self.param(&mut index)?;
            let bias = self.param(&mut index)?;
            x = x.matmul(w)?.broadcast_add(bias)?.relu()?;
            if let Some((p, rng)) = dropout.as_mut() {
                x = apply_dropout(&x, *p, rng)?;
            }
        }
        let w = self.param(&mut index)?;
        let bias = self.param(&mut index)?;
        Ok(x.matmul(w)?.broadcast_add(bias)?)
    }

    fn branch(&self, x: &Tensor, index: &mut usize) -> Result<Tensor> {
        let mut x = x.clone();
        for block in 0..self.size.num_blocks {
            let w = self.param(index)?;
            let b = self.param(index)?;
            x = x
                .conv1d(w, KERNEL_LEN / 2, 1, 1, 1)?
                .broadcast_add(&b.reshape((1, (), 1))?)?
                .relu()?;
            if block + 1 < self.size.num_blocks {
                let (n, c, t) = x.dims3()?;
                x = x
                    .reshape((n, c, 1, t))?
                    .max_pool2d((1, 2))?
                    .reshape((n, c, t / 2))?;
            } else {
                x = x.mean(D::Minus1)?;
            }
        }
        Ok(x)
    }

    /// Probability of "same person" per row of the batch.
    pub fn match_probability(&self, imu: &Tensor, skel: &Tensor) -> Result<Vec<f32>> {
        let logits = self.forward(imu, skel, None)?;
        let p = candle_nn::ops::softmax_last_dim(&logits)?;
        Ok(p.narrow(1, 1, 1)?.flatten_all()?.to_vec1::<f32>()?)
    }
}

/// Inverted dropout with a mask drawn from `rng`.
fn apply_dropout(x: &Tensor, p: f32, rng: &mut ChaCha8Rng) -> Result<Tensor> {
    if p <= 0.0 {
        return Ok(x.clone());
    }
    let keep = 1.0 - p;
    let mask: Vec<f32> = (0..x.elem_count())
        .map(|_| {
            if rng.random::<f32>() < keep {
                1.0 / keep
            } else {
                0.0
            }
        })
        .collect();
    let mask = Tensor::from_vec(mask, x.dims(), x.device())?;
    Ok(x.mul(&mask)?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn published_size_has_the_expected_parameter_count() {
        // Conv: 6·128·3 + 128 then 2 × (128·128·3 + 128), per branch; dense 256→256→256→512→128→2.
        let conv = (6 * 128 * 3 + 128) + 2 * (128 * 128 * 3 + 128);
        let dense = (256 * 256 + 256)
            + (256 * 256 + 256)
            + (256 * 512 + 512)
            + (512 * 128 + 128)
            + (128 * 2 + 2);
        assert_eq!(ModelSize::published().num_parameters(), 2 * conv + dense);
    }

    #[test]
    fn forward_gives_two_logits_per_pair_and_is_seeded() {
        let size = ModelSize::tiny();
        let n1 = Network::init(&size, &mut ChaCha8Rng::seed_from_u64(3)).unwrap();
        let n2 = Network::init(&size, &mut ChaCha8Rng::seed_from_u64(3)).unwrap();
        let x = Tensor::from_vec(
            (0..2 * NUM_CHANNELS * 20)
                .map(|i| (i as f32 * 0.37).sin())
                .collect::<Vec<f32>>(),
            (2, NUM_CHANNELS, 20),
            &Device::Cpu,
        )
        .unwrap();
        let p1 = n1.match_probability(&x, &x).unwrap();
        let p2 = n2.match_probability(&x, &x).unwrap();
        assert_eq!(p1.len(), 2);
        assert_eq!(p1, p2);
        assert!(p1.iter().all(|p| (0.0..=1.0).contains(p)));
    }

    #[test]
    fn sizes_that_pool_to_nothing_are_rejected() {
        let size = ModelSize {
            num_blocks: 8,
            ..ModelSize::tiny()
        };
        assert!(size.validate(90).is_err());
        assert!(ModelSize::published().validate(90).is_ok());
    }
}
