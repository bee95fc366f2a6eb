//! Whether a result's confidences mean what they say: a frame given confidence `p` should carry
//! the right identity (its subject, or `Anonymous` for a person who wears nothing) with
//! probability `p`. Measured over every truth skeleton-frame that has a result line, by the
//! expected calibration error over equal-width bins and the Brier score (see `METRICS.md`).

use serde::{Deserialize, Serialize};

use super::input::{ResultLabel, SceneData, TruthFrame};
use super::report::LabelOutcome;

/// Equal-width confidence bins of [`ConfidenceReport::bins`] and of the calibration error.
pub const NUM_CONFIDENCE_BINS: usize = 10;

/// One frame's confidence and whether its identity was right (see [`confidence_samples`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ConfidenceSample {
    /// The result's confidence, in `0..=1`.
    pub confidence: f64,
    /// Whether the result named a subject (`false`: `Anonymous`).
    pub is_named: bool,
    /// Whether the identity was right: the person's own subject, or `Anonymous` for a person
    /// whose subject is `None`.
    pub is_correct: bool,
}

/// The frames whose confidence fell in `[start, end)` (the last bin includes 1).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ConfidenceBin {
    /// Lower edge.
    pub start: f64,
    /// Upper edge.
    pub end: f64,
    /// Frames in the bin.
    pub num_frames: u64,
    /// Their mean confidence.
    pub mean_confidence: Option<f64>,
    /// The fraction of them whose identity was right.
    pub accuracy: Option<f64>,
}

/// How well the confidences predict correctness.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ConfidenceReport {
    /// Truth skeleton-frames with a result line and a finite confidence.
    pub num_frames: u64,
    /// Result lines joined to a truth frame whose confidence is not a finite number in
    /// `0..=1` (left out).
    pub num_invalid: u64,
    /// Expected calibration error: over [`NUM_CONFIDENCE_BINS`] equal-width bins, the mean of
    /// |mean confidence − accuracy| weighted by the bins' frame counts. 0 is perfectly
    /// calibrated.
    pub ece: Option<f64>,
    /// Brier score: the mean of (confidence − 1 if right, else 0)². 0 is perfect; always
    /// answering the overall accuracy `a` scores `a(1 − a)`.
    pub brier: Option<f64>,
    /// The bins (reliability diagram), empty ones included.
    pub bins: Vec<ConfidenceBin>,
}

/// Additive sums behind a [`ConfidenceReport`].
#[derive(Debug, Clone, Default)]
pub(crate) struct ConfidenceTally {
    /// Per bin: frames, sum of confidences, frames right.
    bins: [(u64, f64, u64); NUM_CONFIDENCE_BINS],
    squared_error_sum: f64,
    num_invalid: u64,
}

impl ConfidenceTally {
    pub(crate) fn add(&mut self, confidence: f64, is_correct: bool) {
        if !is_valid(confidence) {
            self.num_invalid += 1;
            return;
        }
        let k = bin_of(confidence);
        if let Some(bin) = self.bins.get_mut(k) {
            bin.0 += 1;
            bin.1 += confidence;
            bin.2 += u64::from(is_correct);
        }
        let target = if is_correct { 1.0 } else { 0.0 };
        self.squared_error_sum += (confidence - target).powi(2);
    }

    pub(crate) fn merge(&mut self, other: &Self) {
        for (mine, theirs) in self.bins.iter_mut().zip(&other.bins) {
            mine.0 += theirs.0;
            mine.1 += theirs.1;
            mine.2 += theirs.2;
        }
        self.squared_error_sum += other.squared_error_sum;
        self.num_invalid += other.num_invalid;
    }

    pub(crate) fn report(&self) -> ConfidenceReport {
        let n: u64 = self.bins.iter().map(|b| b.0).sum();
        let width = 1.0 / NUM_CONFIDENCE_BINS as f64;
        let bins: Vec<ConfidenceBin> = self
            .bins
            .iter()
            .enumerate()
            .map(|(k, &(count, sum, right))| ConfidenceBin {
                start: k as f64 * width,
                end: (k + 1) as f64 * width,
                num_frames: count,
                mean_confidence: (count > 0).then(|| sum / count as f64),
                accuracy: (count > 0).then(|| right as f64 / count as f64),
            })
            .collect();
        let ece = (n > 0).then(|| {
            bins.iter()
                .filter_map(|b| {
                    let gap = (b.mean_confidence? - b.accuracy?).abs();
                    Some(gap * b.num_frames as f64 / n as f64)
                })
                .sum()
        });
        ConfidenceReport {
            num_frames: n,
            num_invalid: self.num_invalid,
            ece,
            brier: (n > 0).then(|| self.squared_error_sum / n as f64),
            bins,
        }
    }
}

/// The [`ConfidenceReport`] of some samples (as [`evaluate`](super::evaluate) reports every
/// joined frame's).
pub fn confidence_report(samples: &[ConfidenceSample]) -> ConfidenceReport {
    let mut tally = ConfidenceTally::default();
    for s in samples {
        tally.add(s.confidence, s.is_correct);
    }
    tally.report()
}

/// Whether `confidence` is a finite number in `0..=1` (others are left out and counted).
fn is_valid(confidence: f64) -> bool {
    confidence.is_finite() && (0.0..=1.0).contains(&confidence)
}

/// The bin of a confidence in `0..=1`.
fn bin_of(confidence: f64) -> usize {
    ((confidence * NUM_CONFIDENCE_BINS as f64) as usize).min(NUM_CONFIDENCE_BINS - 1)
}

/// Every truth skeleton-frame of `scene` that has a result line, as a [`ConfidenceSample`]
/// (joined on camera, time and track as [`evaluate`](super::evaluate) joins them, duplicates
/// dropped the same way): the material for fitting a map from an engine's raw confidences to
/// probabilities. Frames whose confidence is not a finite number in `0..=1` are left out.
pub fn confidence_samples(scene: &SceneData) -> Vec<ConfidenceSample> {
    let (truth, labels) = super::evaluate::joined(scene);
    truth
        .iter()
        .zip(&labels)
        .filter_map(|(frame, result)| sample(frame, (*result)?))
        .collect()
}

fn sample(frame: &TruthFrame, result: &ResultLabel) -> Option<ConfidenceSample> {
    let confidence = result.confidence;
    is_valid(confidence).then(|| ConfidenceSample {
        confidence,
        is_named: result.subject.is_some(),
        is_correct: super::evaluate::outcome(frame.subject.as_ref(), result.subject.as_ref())
            == LabelOutcome::Correct,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn calibration_error_and_brier_score_by_hand() {
        let mut t = ConfidenceTally::default();
        // Bin 9: two frames at 0.9 and 0.95, one right. Bin 2: one frame at 0.2, wrong.
        t.add(0.9, true);
        t.add(0.95, false);
        t.add(0.2, false);
        t.add(f64::NAN, true);
        t.add(1.5, true);
        let r = t.report();
        assert_eq!(r.num_frames, 3);
        assert_eq!(r.num_invalid, 2);
        let bin9 = &r.bins[9];
        assert_eq!(bin9.num_frames, 2);
        assert!((bin9.mean_confidence.unwrap() - 0.925).abs() < 1e-12);
        assert!((bin9.accuracy.unwrap() - 0.5).abs() < 1e-12);
        // ECE: (2/3)·|0.925 − 0.5| + (1/3)·|0.2 − 0|.
        let ece = 2.0 / 3.0 * 0.425 + 1.0 / 3.0 * 0.2;
        assert!((r.ece.unwrap() - ece).abs() < 1e-12, "{:?}", r.ece);
        // Brier: (0.1² + 0.95² + 0.2²) / 3.
        let brier = (0.01 + 0.9025 + 0.04) / 3.0;
        assert!((r.brier.unwrap() - brier).abs() < 1e-12);
        assert_eq!(r.bins.len(), NUM_CONFIDENCE_BINS);
        assert_eq!(r.bins[0].accuracy, None);
    }

    #[test]
    fn a_confidence_of_one_falls_in_the_last_bin_and_merging_adds() {
        let mut a = ConfidenceTally::default();
        a.add(1.0, true);
        let mut b = ConfidenceTally::default();
        b.add(0.0, true);
        a.merge(&b);
        let r = a.report();
        assert_eq!(r.bins[NUM_CONFIDENCE_BINS - 1].num_frames, 1);
        assert_eq!(r.bins[0].num_frames, 1);
        // Half the frames say 0 and are right: ECE 0.5, Brier 0.5.
        assert!((r.ece.unwrap() - 0.5).abs() < 1e-12);
        assert!((r.brier.unwrap() - 0.5).abs() < 1e-12);
        assert_eq!(ConfidenceTally::default().report().ece, None);
    }
}
