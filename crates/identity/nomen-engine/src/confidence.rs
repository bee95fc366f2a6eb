//! What an output's confidence means: the probability that its identity is right.
//!
//! A decision's raw confidence is a score, not a probability: for a named frame, its subject's
//! decayed mean correlation on the track; for an anonymous one, 1 − the best subject's (0 when
//! no subject has a score there). Correlations of 0.5 are already strong evidence, so raw
//! confidences understate: on the 259-run sweep of the engine README a frame named at a raw 0.5
//! to 0.6 was right 98.9 % of the time. [`ConfidenceMap`] turns raw confidences into
//! probabilities with two monotone piecewise-linear maps, one for named and one for anonymous
//! frames, fitted by isotonic regression ([`ConfidenceMap::fit`]) on frames whose truth is
//! known. `nomen calibrate confidence` fits one from simulated (or annotated) scenes.
//!
//! The isotonic fit is the pool-adjacent-violators algorithm over a few equal-width bins of
//! raw confidence; it is written here because the Rust crates that offer it are either under
//! the LGPL (`pav_regression`) or a pre-release with heavy dependencies (`sklears-isotonic`),
//! for twenty lines of code.

use serde::{Deserialize, Serialize};

use crate::error::{EngineError, Result};

/// Bins of raw confidence per side in [`ConfidenceMap::fit`].
pub const CONFIDENCE_FIT_BINS: usize = 20;

/// Maps raw confidences to probabilities (see the module docs). Each side is a list of knots
/// `[raw, probability]`, raw strictly increasing in `0..=1` and probability non-decreasing in
/// `0..=1`; between knots the map is linear, beyond the ends constant. An empty side passes
/// raw confidences through. [`ConfidenceMap::raw`] leaves both sides empty. In a
/// configuration file, a side left out keeps the default's knots.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ConfidenceMap {
    /// Knots for frames named after a subject.
    pub named: Knots,
    /// Knots for anonymous frames.
    pub anonymous: Knots,
}

impl Default for ConfidenceMap {
    /// Fitted by `nomen calibrate confidence` on simulated scenes that none of the engine
    /// README's figures use (see the crate README, "Confidence").
    fn default() -> Self {
        Self {
            named: Knots::from_slice(DEFAULT_NAMED),
            anonymous: Knots::from_slice(DEFAULT_ANONYMOUS),
        }
    }
}

/// Up to [`MAX_KNOTS`] knots `[raw, probability]` of one side of a [`ConfidenceMap`], stored
/// inline so that the engine's configuration stays `Copy`; in TOML and JSON, a list of pairs.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "Vec<[f64; 2]>", into = "Vec<[f64; 2]>")]
pub struct Knots {
    len: usize,
    points: [[f64; 2]; MAX_KNOTS],
}

/// The most knots a side may have: one per bin of [`ConfidenceMap::fit`].
pub const MAX_KNOTS: usize = CONFIDENCE_FIT_BINS;

impl Knots {
    /// No knots: raw confidences pass through.
    pub const EMPTY: Knots = Knots {
        len: 0,
        points: [[0.0; 2]; MAX_KNOTS],
    };

    /// The first [`MAX_KNOTS`] of `points` (a fit never makes more).
    pub fn from_slice(points: &[[f64; 2]]) -> Self {
        let mut knots = Self::EMPTY;
        for (slot, p) in knots.points.iter_mut().zip(points) {
            *slot = *p;
            knots.len += 1;
        }
        knots
    }

    /// The knots, in order.
    pub fn as_slice(&self) -> &[[f64; 2]] {
        self.points.get(..self.len).unwrap_or(&[])
    }
}

impl TryFrom<Vec<[f64; 2]>> for Knots {
    type Error = String;

    fn try_from(points: Vec<[f64; 2]>) -> std::result::Result<Self, String> {
        if points.len() > MAX_KNOTS {
            return Err(format!(
                "a confidence map side has at most {MAX_KNOTS} knots, got {}",
                points.len()
            ));
        }
        Ok(Self::from_slice(&points))
    }
}

impl From<Knots> for Vec<[f64; 2]> {
    fn from(knots: Knots) -> Self {
        knots.as_slice().to_vec()
    }
}

/// The default map's named side (see [`ConfidenceMap::default`]).
const DEFAULT_NAMED: &[[f64; 2]] = &[
    [0.2028, 0.6854],
    [0.3169, 0.9375],
    [0.4521, 0.968],
    [0.6062, 0.991],
    [0.7037, 0.9959],
    [0.7736, 0.9986],
    [0.8198, 0.9999],
];
/// The default map's anonymous side.
const DEFAULT_ANONYMOUS: &[[f64; 2]] = &[
    [0.0, 0.0036],
    [0.2361, 0.0233],
    [0.2798, 0.5281],
    [0.3315, 0.6561],
    [0.3772, 0.7305],
    [0.568, 0.866],
    [0.8084, 0.9631],
    [0.876, 0.9888],
    [0.9489, 0.9961],
];

/// One frame for [`ConfidenceMap::fit`]: its raw confidence, whether it was named and whether
/// its identity was right.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RawConfidence {
    /// The raw confidence, in `0..=1`.
    pub raw: f64,
    /// Whether the frame was named after a subject.
    pub is_named: bool,
    /// Whether its identity was right.
    pub is_correct: bool,
}

impl ConfidenceMap {
    /// Raw confidences, unmapped.
    pub fn raw() -> Self {
        Self {
            named: Knots::EMPTY,
            anonymous: Knots::EMPTY,
        }
    }

    /// The probability for a frame with raw confidence `raw`, named or anonymous.
    pub fn apply(&self, is_named: bool, raw: f64) -> f64 {
        let knots = if is_named {
            &self.named
        } else {
            &self.anonymous
        };
        interpolate(knots.as_slice(), raw.clamp(0.0, 1.0)).clamp(0.0, 1.0)
    }

    /// Fits both sides by isotonic regression: the frames of each side are binned into
    /// [`CONFIDENCE_FIT_BINS`] equal-width bins of raw confidence, each bin's accuracy (with
    /// one right and one wrong frame added, so that no probability is exactly 0 or 1) is
    /// made non-decreasing by pooling adjacent violators, and each
    /// pooled block becomes a knot at its frames' mean raw confidence (both rounded to 4
    /// decimals, probabilities kept within 0.0001 of 0 and 1). A side without frames
    /// stays empty (raw). Frames with a raw confidence that is not a finite number in `0..=1`
    /// are left out.
    pub fn fit(samples: &[RawConfidence]) -> Self {
        let side = |named: bool| {
            Knots::from_slice(&fit_side(
                samples
                    .iter()
                    .filter(|s| s.is_named == named)
                    .filter(|s| s.raw.is_finite() && (0.0..=1.0).contains(&s.raw)),
            ))
        };
        Self {
            named: side(true),
            anonymous: side(false),
        }
    }

    /// Checks both sides' knots.
    ///
    /// # Errors
    /// [`EngineError::InvalidConfig`] naming the side and knot.
    pub fn validate(&self) -> Result<()> {
        for (name, knots) in [("named", &self.named), ("anonymous", &self.anonymous)] {
            let mut previous: Option<[f64; 2]> = None;
            for (k, &[raw, p]) in knots.as_slice().iter().enumerate() {
                let in_range = |v: f64| v.is_finite() && (0.0..=1.0).contains(&v);
                if !(in_range(raw) && in_range(p)) {
                    return Err(EngineError::InvalidConfig(format!(
                        "confidence_map.{name}[{k}] = [{raw}, {p}]: both must be in 0..=1"
                    )));
                }
                if let Some([raw0, p0]) = previous
                    && !(raw > raw0 && p >= p0)
                {
                    return Err(EngineError::InvalidConfig(format!(
                        "confidence_map.{name}[{k}] = [{raw}, {p}] after [{raw0}, {p0}]: raw \
                         confidences must increase and probabilities must not decrease"
                    )));
                }
                previous = Some([raw, p]);
            }
        }
        Ok(())
    }
}

/// Piecewise-linear through `knots` (raw increasing), constant beyond the ends; `x` itself
/// without knots.
fn interpolate(knots: &[[f64; 2]], x: f64) -> f64 {
    let (Some(first), Some(last)) = (knots.first(), knots.last()) else {
        return x;
    };
    if x <= first[0] {
        return first[1];
    }
    if x >= last[0] {
        return last[1];
    }
    let k = knots.partition_point(|knot| knot[0] <= x);
    match (knots.get(k.wrapping_sub(1)), knots.get(k)) {
        (Some(&[x0, y0]), Some(&[x1, y1])) if x1 > x0 => y0 + (y1 - y0) * (x - x0) / (x1 - x0),
        (Some(&[_, y0]), _) => y0,
        _ => x,
    }
}

/// One side's knots from its frames (see [`ConfidenceMap::fit`]).
fn fit_side<'a>(samples: impl Iterator<Item = &'a RawConfidence>) -> Vec<[f64; 2]> {
    // Per bin: frames, sum of raw confidences, frames right.
    let mut bins = [(0.0_f64, 0.0_f64, 0.0_f64); CONFIDENCE_FIT_BINS];
    for s in samples {
        let k = ((s.raw * CONFIDENCE_FIT_BINS as f64) as usize).min(CONFIDENCE_FIT_BINS - 1);
        if let Some(bin) = bins.get_mut(k) {
            bin.0 += 1.0;
            bin.1 += s.raw;
            bin.2 += if s.is_correct { 1.0 } else { 0.0 };
        }
    }
    // A block's accuracy with one right and one wrong frame added (Laplace's rule), so that
    // no probability is exactly 0 or 1 after finitely many frames.
    let rate = |(n, _, right): (f64, f64, f64)| (right + 1.0) / (n + 2.0);
    // Pool adjacent violators: a stack of blocks (frames, raw sum, right), each block's
    // accuracy above the one before it.
    let mut blocks: Vec<(f64, f64, f64)> = Vec::new();
    for bin in bins.into_iter().filter(|b| b.0 > 0.0) {
        let mut block = bin;
        while let Some(&top) = blocks.last()
            && rate(top) >= rate(block)
        {
            blocks.pop();
            block = (block.0 + top.0, block.1 + top.1, block.2 + top.2);
        }
        blocks.push(block);
    }
    // Knots rounded to 4 decimals (a knot whose raw confidence rounds onto the one before
    // it is dropped).
    let round = |v: f64| (v * 1e4).round() / 1e4;
    let mut knots: Vec<[f64; 2]> = Vec::with_capacity(blocks.len());
    for &block in &blocks {
        let knot = [
            round(block.1 / block.0),
            round(rate(block)).clamp(1e-4, 1.0 - 1e-4),
        ];
        if knots.last().is_none_or(|last| knot[0] > last[0]) {
            knots.push(knot);
        }
    }
    knots
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(raw: f64, is_named: bool, is_correct: bool) -> RawConfidence {
        RawConfidence {
            raw,
            is_named,
            is_correct,
        }
    }

    #[test]
    fn the_default_map_is_valid_and_raises_what_correlations_understate() {
        let map = ConfidenceMap::default();
        assert!(map.validate().is_ok());
        assert!(!map.named.as_slice().is_empty() && !map.anonymous.as_slice().is_empty());
        // A frame named at a raw 0.55 is right far more often than that.
        assert!(map.apply(true, 0.55) > 0.95);
        // An anonymous frame without any evidence is almost never right (the person is
        // someone's, not yet named).
        assert!(map.apply(false, 0.0) < 0.01);
    }

    #[test]
    fn raw_passes_through_and_knots_interpolate_and_hold_at_the_ends() {
        assert_eq!(ConfidenceMap::raw().apply(true, 0.37), 0.37);
        assert_eq!(ConfidenceMap::raw().apply(false, 1.7), 1.0);
        let map = ConfidenceMap {
            named: Knots::from_slice(&[[0.2, 0.5], [0.6, 0.9]]),
            anonymous: Knots::EMPTY,
        };
        assert_eq!(map.apply(true, 0.1), 0.5);
        assert!((map.apply(true, 0.4) - 0.7).abs() < 1e-12);
        assert_eq!(map.apply(true, 0.6), 0.9);
        assert_eq!(map.apply(true, 0.95), 0.9);
        assert_eq!(map.apply(false, 0.4), 0.4);
        assert!(map.validate().is_ok());
    }

    #[test]
    fn the_fit_pools_violators_into_a_non_decreasing_map() {
        // Named frames: bin 0.10-0.15 right 1 of 2 (rate (1 + 1) / (2 + 2) = 0.5), then bins
        // 0.30-0.35 and 0.40-0.45 right 0 of 1 each (rate 1/3: violators, pooled with the
        // first: 1 of 4 right, rate 2/6, at a mean raw 0.225), then bin 0.80-0.85 right 3 of 3
        // (rate 4/5).
        let mut samples = vec![
            sample(0.1, true, true),
            sample(0.1, true, false),
            sample(0.3, true, false),
            sample(0.4, true, false),
            sample(0.8, true, true),
            sample(0.8, true, true),
            sample(0.8, true, true),
            sample(f64::NAN, true, true),
        ];
        // Anonymous frames: one bin.
        samples.extend((0..4).map(|k| sample(0.5, false, k == 0)));
        let map = ConfidenceMap::fit(&samples);
        let named = map.named.as_slice();
        assert_eq!(named.len(), 2, "{named:?}");
        let [a, b] = named[0];
        assert!(
            (a - 0.225).abs() < 1e-12 && (b - 0.3333).abs() < 1e-12,
            "{a} {b}"
        );
        assert_eq!(named[1], [0.8, 0.8]);
        // Anonymous: 1 of 4 right, rate 2/6.
        assert_eq!(map.anonymous.as_slice(), &[[0.5, 0.3333]]);
        assert!(map.validate().is_ok());
    }

    #[test]
    fn knots_out_of_order_or_range_are_refused_by_name() {
        let bad = ConfidenceMap {
            named: Knots::from_slice(&[[0.5, 0.9], [0.4, 0.95]]),
            anonymous: Knots::EMPTY,
        };
        let e = bad.validate().unwrap_err().to_string();
        assert!(e.contains("confidence_map.named[1]"), "{e}");
        let bad = ConfidenceMap {
            named: Knots::EMPTY,
            anonymous: Knots::from_slice(&[[0.2, 0.5], [0.3, 0.4]]),
        };
        assert!(
            bad.validate()
                .unwrap_err()
                .to_string()
                .contains("anonymous[1]")
        );
        let bad = ConfidenceMap {
            named: Knots::from_slice(&[[f64::NAN, 0.5]]),
            anonymous: Knots::EMPTY,
        };
        assert!(bad.validate().is_err());
        // More knots than a fit makes are refused when read.
        let many: Vec<[f64; 2]> = (0..=MAX_KNOTS).map(|k| [k as f64 * 0.01, 0.5]).collect();
        assert!(Knots::try_from(many).is_err());
    }
}
