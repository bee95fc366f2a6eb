//! What an output's confidence means: the probability that its identity is right.
//!
//! A decision's raw confidence is a score, not a probability: for a named frame, its subject's
//! lead on the track, the subject's pooled score less the best other subject's (that one
//! counted from 0 up; the whole score when no other subject has one); for an anonymous one,
//! 1 − the best subject's score (0 when no subject has a score there). A name that barely
//! beats another is often wrong whatever its score: a look-alike, or a crowd walking alike,
//! scores high for several subjects at once. [`ConfidenceMap`] turns raw confidences into
//! probabilities with two monotone piecewise-linear maps, one for named and one for anonymous
//! frames, fitted by isotonic regression ([`ConfidenceMap::fit`]) on frames whose truth is
//! known. `nomen calibrate confidence` fits one from simulated (or annotated) scenes;
//! [`ConfidenceMap::fitted`] holds the engine's, one per motion score.
//!
//! The isotonic fit is the pool-adjacent-violators algorithm over a few equal-width bins of
//! raw confidence; it is written here because the Rust crates that offer it are either under
//! the LGPL (`pav_regression`) or a pre-release with heavy dependencies (`sklears-isotonic`),
//! for twenty lines of code.

use serde::{Deserialize, Serialize};

use crate::config::MotionScore;
use crate::error::{EngineError, Result};

/// Bins of raw confidence per side in [`ConfidenceMap::fit`].
pub const CONFIDENCE_FIT_BINS: usize = 20;

/// Maps raw confidences to probabilities (see the module docs). Each side is a list of knots
/// `[raw, probability]`, raw strictly increasing in `0..=1` and probability non-decreasing in
/// `0..=1`; between knots the map is linear, beyond the ends constant. An empty side passes
/// raw confidences through. [`ConfidenceMap::raw`] leaves both sides empty. In a
/// configuration file, a side left out has no knots (its raw confidences pass through).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(default, deny_unknown_fields)]
pub struct ConfidenceMap {
    /// Knots for frames named after a subject.
    #[cfg_attr(feature = "schema", schemars(with = "Vec<[f64; 2]>"))]
    pub named: Knots,
    /// Knots for anonymous frames.
    #[cfg_attr(feature = "schema", schemars(with = "Vec<[f64; 2]>"))]
    pub anonymous: Knots,
}

impl Default for ConfidenceMap {
    /// [`ConfidenceMap::raw`]: a configuration's table with a side left out passes that side's
    /// raw confidences through.
    fn default() -> Self {
        Self::raw()
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

/// The most knots a side may have: two per bin of [`ConfidenceMap::fit`].
pub const MAX_KNOTS: usize = 2 * CONFIDENCE_FIT_BINS;

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

/// The named side fitted for nomen's motion score ([`MotionScore::Nomen`]).
const NOMEN_NAMED: &[[f64; 2]] = &[
    [0.0, 0.381],
    [0.05, 0.381],
    [0.0501, 0.8501],
    [0.1, 0.8501],
    [0.15, 0.9477],
    [0.2, 0.9673],
    [0.25, 0.9814],
    [0.3, 0.9913],
    [0.9599, 0.9941],
];
/// The anonymous side fitted for nomen's motion score ([`MotionScore::Nomen`]).
#[allow(
    clippy::approx_constant,
    reason = "fitted probabilities; one may look like a mathematical constant"
)]
const NOMEN_ANONYMOUS: &[[f64; 2]] = &[
    [0.0, 0.0745],
    [0.2479, 0.0745],
    [0.2579, 0.3534],
    [0.399, 0.3534],
    [0.4, 0.4343],
    [0.4496, 0.4343],
    [0.4506, 0.5099],
    [0.4999, 0.5099],
    [0.5002, 0.6702],
    [0.5498, 0.6702],
    [0.55, 0.6737],
    [0.6, 0.6737],
    [0.6499, 0.7617],
    [0.6503, 0.8325],
    [0.7, 0.8325],
    [0.7001, 0.9026],
    [0.75, 0.9026],
    [0.8, 0.9674],
    [0.8001, 0.9707],
    [0.8499, 0.9707],
    [0.8501, 0.9858],
    [0.8999, 0.9858],
    [0.9001, 0.9971],
    [0.9499, 0.9971],
    [0.95, 0.9972],
    [1.0, 0.9972],
];
/// The named side fitted for De Marchi's ([`MotionScore::DeMarchi`]).
const DE_MARCHI_NAMED: &[[f64; 2]] = &[
    [0.0, 0.4886],
    [0.05, 0.4886],
    [0.1, 0.9245],
    [0.15, 0.9706],
    [0.9991, 0.9769],
];
/// The anonymous side fitted for De Marchi's ([`MotionScore::DeMarchi`]).
const DE_MARCHI_ANONYMOUS: &[[f64; 2]] = &[
    [0.0, 0.0974],
    [0.0496, 0.0974],
    [0.0503, 0.6771],
    [0.0998, 0.6771],
    [0.1001, 0.6969],
    [0.25, 0.6969],
    [0.2501, 0.7742],
    [0.2998, 0.7742],
    [0.3001, 0.8322],
    [0.35, 0.8322],
    [0.3501, 0.9508],
    [0.7484, 0.9508],
    [0.7506, 0.9775],
    [0.7993, 0.9775],
    [0.8001, 0.9975],
    [0.8499, 0.9975],
    [0.8501, 0.9999],
    [1.0, 0.9999],
];
/// The named side fitted for Belmonte-Hernández's ([`MotionScore::Belmonte`]).
const BELMONTE_NAMED: &[[f64; 2]] = &[
    [0.0, 0.6147],
    [0.05, 0.6147],
    [0.1, 0.8593],
    [0.15, 0.919],
    [0.2, 0.9501],
    [0.25, 0.9675],
    [0.3, 0.97],
    [0.6, 0.9704],
    [0.9849, 0.9799],
];
/// The anonymous side fitted for Belmonte-Hernández's ([`MotionScore::Belmonte`]).
const BELMONTE_ANONYMOUS: &[[f64; 2]] = &[
    [0.0, 0.0735],
    [0.1979, 0.0735],
    [0.201, 0.0747],
    [0.2481, 0.0747],
    [0.2508, 0.3222],
    [0.3499, 0.3222],
    [0.3507, 0.4067],
    [0.4, 0.4067],
    [0.4005, 0.4509],
    [0.75, 0.4509],
    [0.7501, 0.5737],
    [0.8, 0.5737],
    [0.85, 0.7142],
    [0.8999, 0.8397],
    [0.9, 0.9643],
    [0.9499, 0.9643],
    [0.9501, 0.9811],
    [1.0, 0.9811],
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
    /// The map fitted for `motion_score` by `scenarios/train/confidence.sh` (`nomen calibrate
    /// confidence` on 109 simulated scenes: the CNN's training scenes, library scenes at seeds
    /// from 1001 on and the first three validation scenes of every scene family; see the engine
    /// README's "Confidence" section). The raw confidences of each motion score differ, and so do
    /// their maps.
    pub fn fitted(motion_score: MotionScore) -> Self {
        let (named, anonymous) = match motion_score {
            MotionScore::Nomen => (NOMEN_NAMED, NOMEN_ANONYMOUS),
            MotionScore::DeMarchi => (DE_MARCHI_NAMED, DE_MARCHI_ANONYMOUS),
            MotionScore::Belmonte => (BELMONTE_NAMED, BELMONTE_ANONYMOUS),
        };
        Self {
            named: Knots::from_slice(named),
            anonymous: Knots::from_slice(anonymous),
        }
    }

    /// Raw confidences, unmapped.
    pub fn raw() -> Self {
        Self {
            named: Knots::EMPTY,
            anonymous: Knots::EMPTY,
        }
    }

    /// The probability for a frame with raw confidence `raw`, named or anonymous; 0 for a raw
    /// confidence that is not a number.
    pub fn apply(&self, is_named: bool, raw: f64) -> f64 {
        if raw.is_nan() {
            return 0.0;
        }
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
    /// made non-decreasing by pooling adjacent violators, and each pooled block becomes two
    /// knots at that accuracy, at its frames' lowest and highest raw confidence (rounded to 4
    /// decimals, probabilities kept within 0.0001 of 0 and 1). A side without frames
    /// stays empty (raw). Frames with a raw confidence that is not a finite number in `0..=1`
    /// are left out.
    pub fn fit(samples: &[RawConfidence]) -> Self {
        let side = |named: bool| {
            Knots::from_slice(&fit_side(
                samples
                    .iter()
                    .filter(|s| s.is_named == named)
                    .filter(|s| is_unit(s.raw)),
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
                if !(is_unit(raw) && is_unit(p)) {
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

/// Whether `v` is a finite number in `0..=1`.
fn is_unit(v: f64) -> bool {
    v.is_finite() && (0.0..=1.0).contains(&v)
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

/// One bin or pooled block of frames in [`fit_side`].
#[derive(Debug, Clone, Copy)]
struct Block {
    num: f64,
    num_right: f64,
    raw_min: f64,
    raw_max: f64,
}

impl Block {
    /// The accuracy with one right and one wrong frame added (Laplace's rule), so that no
    /// probability is exactly 0 or 1 after finitely many frames.
    fn rate(&self) -> f64 {
        (self.num_right + 1.0) / (self.num + 2.0)
    }
}

/// One side's knots from its frames (see [`ConfidenceMap::fit`]).
fn fit_side<'a>(samples: impl Iterator<Item = &'a RawConfidence>) -> Vec<[f64; 2]> {
    let mut bins: [Option<Block>; CONFIDENCE_FIT_BINS] = [None; CONFIDENCE_FIT_BINS];
    for s in samples {
        let k = ((s.raw * CONFIDENCE_FIT_BINS as f64) as usize).min(CONFIDENCE_FIT_BINS - 1);
        if let Some(bin) = bins.get_mut(k) {
            let right = if s.is_correct { 1.0 } else { 0.0 };
            *bin = Some(match *bin {
                Some(b) => Block {
                    num: b.num + 1.0,
                    num_right: b.num_right + right,
                    raw_min: b.raw_min.min(s.raw),
                    raw_max: b.raw_max.max(s.raw),
                },
                None => Block {
                    num: 1.0,
                    num_right: right,
                    raw_min: s.raw,
                    raw_max: s.raw,
                },
            });
        }
    }
    // Pool adjacent violators: a stack of blocks, each one's rate above the one before it.
    let mut blocks: Vec<Block> = Vec::new();
    for mut block in bins.into_iter().flatten() {
        while let Some(&top) = blocks.last()
            && top.rate() >= block.rate()
        {
            blocks.pop();
            block = Block {
                num: block.num + top.num,
                num_right: block.num_right + top.num_right,
                raw_min: top.raw_min,
                raw_max: block.raw_max,
            };
        }
        blocks.push(block);
    }
    // The isotonic fit is constant over each block: a knot at each end of the block's raw
    // confidences, the map linear in the gaps between blocks. Rounded to 4 decimals (a knot
    // whose raw confidence rounds onto the one before it is dropped), probabilities kept
    // within 0.0001 of 0 and 1.
    let round = |v: f64| (v * 1e4).round() / 1e4;
    let mut knots: Vec<[f64; 2]> = Vec::with_capacity(2 * blocks.len());
    for block in &blocks {
        let p = round(block.rate()).clamp(1e-4, 1.0 - 1e-4);
        for raw in [block.raw_min, block.raw_max] {
            let knot = [round(raw), p];
            if knots.last().is_none_or(|last| knot[0] > last[0]) {
                knots.push(knot);
            }
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
    fn the_fitted_maps_are_valid_and_raise_what_correlations_understate() {
        for score in [
            MotionScore::Nomen,
            MotionScore::DeMarchi,
            MotionScore::Belmonte,
        ] {
            let map = ConfidenceMap::fitted(score);
            assert!(map.validate().is_ok(), "{score:?}");
            assert!(!map.named.as_slice().is_empty() && !map.anonymous.as_slice().is_empty());
        }
        assert_eq!(ConfidenceMap::default(), ConfidenceMap::raw());
        let map = ConfidenceMap::fitted(MotionScore::Nomen);
        // A name that leads the next subject by 0.3 is right far more often than that.
        assert!(map.apply(true, 0.3) > 0.95);
        // One that barely leads is a coin toss at best.
        assert!(map.apply(true, 0.01) < 0.6);
        // An anonymous frame without any evidence is rarely right (the person is someone's,
        // not yet named).
        assert!(map.apply(false, 0.0) < 0.1);
    }

    #[test]
    fn raw_passes_through_and_knots_interpolate_and_hold_at_the_ends() {
        assert_eq!(ConfidenceMap::raw().apply(true, 0.37), 0.37);
        assert_eq!(ConfidenceMap::raw().apply(false, 1.7), 1.0);
        assert_eq!(ConfidenceMap::raw().apply(true, f64::NAN), 0.0);
        assert_eq!(
            ConfidenceMap::fitted(MotionScore::Nomen).apply(true, f64::NAN),
            0.0
        );
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
        // first: 1 of 4 right, rate 2/6, over raw 0.1 to 0.4), then bin 0.80-0.85 right 3 of 3
        // (rate 4/5, one raw value: one knot).
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
        assert_eq!(
            map.named.as_slice(),
            &[[0.1, 0.3333], [0.4, 0.3333], [0.8, 0.8]]
        );
        // Between blocks the map is linear.
        assert!((map.apply(true, 0.6) - (0.3333 + 0.8) / 2.0).abs() < 1e-12);
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
