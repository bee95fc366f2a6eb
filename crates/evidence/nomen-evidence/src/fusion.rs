//! Score fusion: from per-(skeleton, subject, joint, model) correlations of one window to one
//! (skeleton × subject) score matrix for the assignment (De Marchi et al.).
//!
//! A *subject* is one body-area network (BAN): the set of IMUs one person wears, at known joints.
//! [`ScoreTensor`] holds, for one window, the [`ModelScores`] of every skeleton against every
//! subject at every instrumented joint (missing entries are `None`). [`fuse`] reduces it:
//!
//! - [`Fusion::Acc`], [`Fusion::Vel`], [`Fusion::Ori`], [`Fusion::Dl`]: one model, mean over the
//!   joints present.
//! - [`Fusion::Mean`]: mean over every present (joint, model) entry.
//! - [`Fusion::Max`]: maximum over them.
//! - [`Fusion::Threshold`]: fraction of present entries strictly above
//!   [`FusionConfig::threshold`].
//! - [`Fusion::ModelVote`], [`Fusion::ModelJointVote`]: De Marchi's multilevel voting
//!   (Algorithm 1), read as follows.
//!
//! # The learned model
//!
//! [`Model::Dl`] is a fourth model next to De Marchi's three: the score of a learned
//! [`PairScorer`](crate::PairScorer) (De Marchi's CNN), on the same `-1..=1` scale. Every fusion
//! that spans models (mean, max, threshold, both votes) takes it in wherever it is present, as
//! De Marchi et al. add their CNN as one more voter; where no scorer ran its entries are missing
//! and every fusion gives exactly what it gives with the three geometric models alone (a model
//! ballot with no entry is skipped under rule 1 below, without counting).
//!
//! # How we read Algorithm 1 (multilevel voting)
//!
//! A *ballot* is one source of evidence: for `ModelVote` each model (acc, vel, ori) with its
//! score per (skeleton, subject) being the mean over joints (the single-model fusion above); for
//! `ModelJointVote` each (model, joint) pair, scored by that entry alone. In every ballot, each
//! skeleton votes for the subject with its highest score in that ballot:
//!
//! 1. Only subjects with a score in the ballot are candidates; a skeleton with no candidate in a
//!    ballot *abstains* from it.
//! 2. A skeleton whose best score is not above [`FusionConfig::min_vote_score`] abstains too (a
//!    correlation at or below it is no evidence of a match).
//! 3. **Ties**: subjects whose score is within [`FusionConfig::tie_tolerance`] of the best share
//!    the vote equally (`1/num_tied` each), so a ballot never casts more than one vote per
//!    skeleton and no order (of subjects or of a `HashMap`) decides.
//! 4. **Normalisation**: a skeleton's votes for a subject are divided by the number of ballots in
//!    which that skeleton had at least one candidate (abstentions under rule 2 count in the
//!    denominator). Every entry is then in `0..=1`, the row sums to at most 1, and 1 means
//!    "every usable ballot chose this subject". This makes the matrix comparable across windows
//!    with different numbers of joints or models, so it can be thresholded and accumulated over
//!    time. A skeleton with no usable ballot gets `None` for every subject.
//!
//! Votes go from skeletons to subjects (rows), as in De Marchi et al., where each detected person
//! looks for its BAN; the assignment solver resolves the columns.

use crate::error::{EvidenceError, Result};
use crate::window::ModelScores;
use nomen_core::skeleton::Joint;
use serde::{Deserialize, Serialize};

/// One of De Marchi's three geometric models.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Model {
    /// Linear-acceleration magnitude.
    Acc,
    /// Velocity magnitude.
    Vel,
    /// Orientation-change magnitude.
    Ori,
    /// A learned pair scorer ([`crate::PairScorer`], De Marchi's CNN), mapped to `-1..=1`.
    Dl,
}

impl Model {
    /// All models, in tensor order (the geometric three, then the learned one).
    pub const ALL: [Model; 4] = [Model::Acc, Model::Vel, Model::Ori, Model::Dl];

    /// De Marchi's three geometric models.
    pub const GEOMETRIC: [Model; 3] = [Model::Acc, Model::Vel, Model::Ori];

    /// Index in [`Model::ALL`].
    pub const fn index(self) -> usize {
        self as usize
    }

    /// This model's score in `scores`.
    pub fn of(self, scores: &ModelScores) -> Option<f64> {
        match self {
            Model::Acc => scores.acc,
            Model::Vel => scores.vel,
            Model::Ori => scores.ori,
            Model::Dl => scores.dl,
        }
    }
}

/// The most entries a [`ScoreTensor`] may hold: 2^26, a gigabyte (a window of the engine holds
/// tracks × subjects × sites × 4, thousands).
pub const MAX_TENSOR_ENTRIES: usize = 1 << 26;

/// Scores of one window indexed by (skeleton, subject, joint, model); `None` = missing.
#[derive(Debug, Clone, PartialEq)]
pub struct ScoreTensor {
    num_skeletons: usize,
    num_subjects: usize,
    joints: Vec<Joint>,
    scores: Vec<Option<f64>>,
}

impl ScoreTensor {
    /// An all-missing tensor for `num_skeletons` skeletons, `num_subjects` subjects and the
    /// instrumented `joints` (duplicates are dropped; order kept). Refuses more than
    /// [`MAX_TENSOR_ENTRIES`] entries.
    pub fn new(num_skeletons: usize, num_subjects: usize, joints: &[Joint]) -> Result<Self> {
        let mut unique = Vec::with_capacity(joints.len());
        for &j in joints {
            if !unique.contains(&j) {
                unique.push(j);
            }
        }
        let len = num_skeletons
            .checked_mul(num_subjects)
            .and_then(|n| n.checked_mul(unique.len()))
            .and_then(|n| n.checked_mul(Model::ALL.len()))
            .filter(|&n| n <= MAX_TENSOR_ENTRIES)
            .ok_or(EvidenceError::TooLarge {
                num_skeletons,
                num_subjects,
                num_joints: unique.len(),
                num_models: Model::ALL.len(),
                max: MAX_TENSOR_ENTRIES,
            })?;
        Ok(Self {
            num_skeletons,
            num_subjects,
            joints: unique,
            scores: vec![None; len],
        })
    }

    /// Number of skeletons (rows of the fused matrix).
    pub fn num_skeletons(&self) -> usize {
        self.num_skeletons
    }

    /// Number of subjects (columns of the fused matrix).
    pub fn num_subjects(&self) -> usize {
        self.num_subjects
    }

    /// The instrumented joints, in tensor order.
    pub fn joints(&self) -> &[Joint] {
        &self.joints
    }

    fn flat_index(&self, skeleton: usize, subject: usize, joint: Joint) -> Result<usize> {
        if skeleton >= self.num_skeletons || subject >= self.num_subjects {
            return Err(EvidenceError::IndexOutOfRange {
                skeleton,
                subject,
                num_skeletons: self.num_skeletons,
                num_subjects: self.num_subjects,
            });
        }
        let j = self
            .joints
            .iter()
            .position(|&x| x == joint)
            .ok_or(EvidenceError::UnknownJoint { joint })?;
        Ok(((skeleton * self.num_subjects + subject) * self.joints.len() + j) * Model::ALL.len())
    }

    /// Stores the model scores of `skeleton` against `subject`'s IMU at `joint`, the learned one
    /// included (non-finite scores are stored as missing).
    pub fn set(
        &mut self,
        skeleton: usize,
        subject: usize,
        joint: Joint,
        scores: ModelScores,
    ) -> Result<()> {
        let base = self.flat_index(skeleton, subject, joint)?;
        for m in Model::ALL {
            if let Some(slot) = self.scores.get_mut(base + m.index()) {
                *slot = m.of(&scores).filter(|v| v.is_finite());
            }
        }
        Ok(())
    }

    /// The score of one entry (`None` if missing or out of range).
    pub fn get(&self, skeleton: usize, subject: usize, joint: Joint, model: Model) -> Option<f64> {
        let base = self.flat_index(skeleton, subject, joint).ok()?;
        self.scores.get(base + model.index()).copied().flatten()
    }

    /// Present scores of (skeleton, subject) over the joints for the `models` given.
    fn entries<'a>(
        &'a self,
        skeleton: usize,
        subject: usize,
        models: &'a [Model],
    ) -> impl Iterator<Item = f64> + 'a {
        self.joints.iter().flat_map(move |&j| {
            models
                .iter()
                .filter_map(move |&m| self.get(skeleton, subject, j, m))
        })
    }
}

/// A (skeleton × subject) score matrix, row-major; `None` = no evidence.
#[derive(Debug, Clone, PartialEq)]
pub struct ScoreMatrix {
    /// Number of rows (skeletons).
    pub num_skeletons: usize,
    /// Number of columns (subjects).
    pub num_subjects: usize,
    /// Scores, row-major: entry `(s, b)` at `s · num_subjects + b`.
    pub scores: Vec<Option<f64>>,
}

impl ScoreMatrix {
    /// An all-`None` matrix.
    pub fn new(num_skeletons: usize, num_subjects: usize) -> Self {
        Self {
            num_skeletons,
            num_subjects,
            scores: vec![None; num_skeletons * num_subjects],
        }
    }

    /// The score of skeleton `skeleton` for subject `subject`.
    pub fn get(&self, skeleton: usize, subject: usize) -> Option<f64> {
        if skeleton >= self.num_skeletons || subject >= self.num_subjects {
            return None;
        }
        self.scores
            .get(skeleton * self.num_subjects + subject)
            .copied()
            .flatten()
    }

    /// One skeleton's row.
    pub fn row(&self, skeleton: usize) -> &[Option<f64>] {
        let start = (skeleton * self.num_subjects).min(self.scores.len());
        let end = (start + self.num_subjects).min(self.scores.len());
        &self.scores[start..end]
    }

    /// The subject with the highest score for `skeleton` (ties: the lowest index).
    pub fn best_subject(&self, skeleton: usize) -> Option<usize> {
        let mut best: Option<(usize, f64)> = None;
        for (b, s) in self.row(skeleton).iter().enumerate() {
            if let Some(s) = *s
                && best.is_none_or(|(_, v)| s > v)
            {
                best = Some((b, s));
            }
        }
        best.map(|b| b.0)
    }

    fn set(&mut self, skeleton: usize, subject: usize, value: Option<f64>) {
        if let Some(slot) = self.scores.get_mut(skeleton * self.num_subjects + subject) {
            *slot = value;
        }
    }
}

/// How [`fuse`] reduces a [`ScoreTensor`] (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "snake_case")]
pub enum Fusion {
    /// Acceleration model, mean over joints.
    Acc,
    /// Velocity model, mean over joints.
    Vel,
    /// Orientation model, mean over joints.
    Ori,
    /// Learned model ([`Model::Dl`]) alone, mean over joints.
    Dl,
    /// Mean over every (joint, model) entry.
    Mean,
    /// Fraction of entries above [`FusionConfig::threshold`].
    Threshold,
    /// Maximum over every entry.
    Max,
    /// One ballot per model (joint-averaged), normalised vote share.
    ModelVote,
    /// One ballot per (model, joint), normalised vote share.
    ModelJointVote,
}

/// Configuration of [`fuse`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(default, deny_unknown_fields)]
pub struct FusionConfig {
    /// Correlation above which an entry counts for [`Fusion::Threshold`]. Default 0.5 (a
    /// "large" correlation in Cohen's convention; not a value from De Marchi et al.).
    pub threshold: f64,
    /// A skeleton votes in a ballot only if its best score is above this. Default 0.0: a
    /// non-positive correlation is no evidence of a match.
    pub min_vote_score: f64,
    /// Scores within this of a ballot's best are tied and share the vote. Default 1e-9
    /// (rounding only).
    pub tie_tolerance: f64,
}

impl Default for FusionConfig {
    fn default() -> Self {
        Self {
            threshold: 0.5,
            min_vote_score: 0.0,
            tie_tolerance: 1e-9,
        }
    }
}

/// Reduces one window's scores to a (skeleton × subject) matrix (see the module docs).
pub fn fuse(tensor: &ScoreTensor, fusion: Fusion, cfg: &FusionConfig) -> ScoreMatrix {
    let (ns, nb) = (tensor.num_skeletons, tensor.num_subjects);
    let mut out = ScoreMatrix::new(ns, nb);
    let single = |m: Model| -> [Model; 1] { [m] };
    match fusion {
        Fusion::Acc | Fusion::Vel | Fusion::Ori | Fusion::Dl => {
            let model = match fusion {
                Fusion::Acc => Model::Acc,
                Fusion::Vel => Model::Vel,
                Fusion::Dl => Model::Dl,
                _ => Model::Ori,
            };
            let models = single(model);
            for s in 0..ns {
                for b in 0..nb {
                    out.set(s, b, mean(tensor.entries(s, b, &models)));
                }
            }
        }
        Fusion::Mean | Fusion::Max | Fusion::Threshold => {
            for s in 0..ns {
                for b in 0..nb {
                    let it = tensor.entries(s, b, &Model::ALL);
                    let v = match fusion {
                        Fusion::Mean => mean(it),
                        Fusion::Max => it.fold(None, |acc: Option<f64>, v| {
                            Some(acc.map_or(v, |a| a.max(v)))
                        }),
                        _ => {
                            let (num, num_above) = it.fold((0usize, 0usize), |(n, k), v| {
                                (n + 1, k + usize::from(v > cfg.threshold))
                            });
                            (num > 0).then(|| num_above as f64 / num as f64)
                        }
                    };
                    out.set(s, b, v);
                }
            }
        }
        Fusion::ModelVote => {
            let ballots: Vec<Vec<Option<f64>>> = Model::ALL
                .iter()
                .map(|&m| {
                    let models = single(m);
                    (0..ns * nb)
                        .map(|i| mean(tensor.entries(i / nb.max(1), i % nb.max(1), &models)))
                        .collect()
                })
                .collect();
            vote(&ballots, ns, nb, cfg, &mut out);
        }
        Fusion::ModelJointVote => {
            let mut ballots = Vec::new();
            for &m in &Model::ALL {
                for &j in &tensor.joints {
                    ballots.push(
                        (0..ns * nb)
                            .map(|i| tensor.get(i / nb.max(1), i % nb.max(1), j, m))
                            .collect(),
                    );
                }
            }
            vote(&ballots, ns, nb, cfg, &mut out);
        }
    }
    out
}

/// Mean of an iterator; `None` if empty.
fn mean(it: impl Iterator<Item = f64>) -> Option<f64> {
    let (n, sum) = it.fold((0usize, 0.0), |(n, s), v| (n + 1, s + v));
    (n > 0).then(|| sum / n as f64)
}

/// Counts normalised votes (module docs, rules 1–4). Each ballot is row-major `ns × nb`.
fn vote(
    ballots: &[Vec<Option<f64>>],
    ns: usize,
    nb: usize,
    cfg: &FusionConfig,
    out: &mut ScoreMatrix,
) {
    let mut votes = vec![0.0; nb];
    for s in 0..ns {
        votes.iter_mut().for_each(|v| *v = 0.0);
        let mut num_usable = 0usize;
        for ballot in ballots {
            let row = ballot.get(s * nb..(s + 1) * nb).unwrap_or(&[]);
            let best = row
                .iter()
                .flatten()
                .copied()
                .fold(None, |acc: Option<f64>, v| {
                    Some(acc.map_or(v, |a| a.max(v)))
                });
            let Some(best) = best else {
                continue; // rule 1: no candidate, abstain without counting
            };
            num_usable += 1;
            if best <= cfg.min_vote_score {
                continue; // rule 2
            }
            let is_tied = |v: &Option<f64>| v.is_some_and(|v| v >= best - cfg.tie_tolerance);
            let num_tied = row.iter().filter(|v| is_tied(v)).count();
            if num_tied == 0 {
                continue;
            }
            let share = 1.0 / num_tied as f64;
            for (vote, v) in votes.iter_mut().zip(row) {
                if is_tied(v) {
                    *vote += share; // rule 3
                }
            }
        }
        for (b, v) in votes.iter().enumerate() {
            out.set(s, b, (num_usable > 0).then(|| v / num_usable as f64)); // rule 4
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scores(acc: f64, vel: f64, ori: f64) -> ModelScores {
        ModelScores {
            acc: Some(acc),
            vel: Some(vel),
            ori: Some(ori),
            dl: None,
        }
    }

    /// Two skeletons, two subjects, one joint. Skeleton s is subject s. Acceleration and velocity
    /// agree, modestly; orientation is strongly wrong.
    fn two_models_right_one_wrong() -> ScoreTensor {
        let mut t = ScoreTensor::new(2, 2, &[Joint::LeftWrist]).unwrap();
        let j = Joint::LeftWrist;
        t.set(0, 0, j, scores(0.6, 0.7, -0.9)).unwrap();
        t.set(0, 1, j, scores(0.5, 0.6, 0.9)).unwrap();
        t.set(1, 1, j, scores(0.8, 0.6, -0.8)).unwrap();
        t.set(1, 0, j, scores(0.2, 0.1, 0.95)).unwrap();
        t
    }

    #[test]
    fn model_vote_follows_two_of_three_models_where_mean_does_not() {
        let t = two_models_right_one_wrong();
        let cfg = FusionConfig::default();
        let votes = fuse(&t, Fusion::ModelVote, &cfg);
        assert_eq!(votes.best_subject(0), Some(0));
        assert_eq!(votes.best_subject(1), Some(1));
        assert!((votes.get(0, 0).unwrap() - 2.0 / 3.0).abs() < 1e-12);
        assert!((votes.get(0, 1).unwrap() - 1.0 / 3.0).abs() < 1e-12);
        // The mean and the max are pulled to the wrong subject by the one strong wrong model.
        assert_eq!(fuse(&t, Fusion::Mean, &cfg).best_subject(0), Some(1));
        assert_eq!(fuse(&t, Fusion::Max, &cfg).best_subject(0), Some(1));
        let joint_votes = fuse(&t, Fusion::ModelJointVote, &cfg);
        assert_eq!(joint_votes.best_subject(0), Some(0));
        assert_eq!(joint_votes.best_subject(1), Some(1));
    }

    #[test]
    fn single_model_and_threshold_fusions() {
        let t = two_models_right_one_wrong();
        let cfg = FusionConfig::default();
        assert_eq!(fuse(&t, Fusion::Acc, &cfg).get(1, 1), Some(0.8));
        assert_eq!(fuse(&t, Fusion::Ori, &cfg).get(0, 1), Some(0.9));
        // Entries above 0.5 for (0, 0): 0.6 and 0.7 of three.
        let th = fuse(&t, Fusion::Threshold, &cfg);
        assert!((th.get(0, 0).unwrap() - 2.0 / 3.0).abs() < 1e-12);
    }

    #[test]
    fn ties_share_the_vote_and_missing_rows_abstain() {
        let mut t = ScoreTensor::new(3, 2, &[Joint::LeftWrist, Joint::RightAnkle]).unwrap();
        let (w, a) = (Joint::LeftWrist, Joint::RightAnkle);
        t.set(0, 0, w, scores(0.5, 0.5, 0.5)).unwrap();
        t.set(0, 1, w, scores(0.5, 0.5, 0.5)).unwrap();
        // Skeleton 1: only negative correlations, so it never votes, but its ballots count.
        t.set(1, 0, a, scores(-0.2, -0.3, -0.1)).unwrap();
        let m = fuse(&t, Fusion::ModelJointVote, &FusionConfig::default());
        assert_eq!(m.get(0, 0), Some(0.5));
        assert_eq!(m.get(0, 1), Some(0.5));
        assert_eq!(m.get(1, 0), Some(0.0));
        // Skeleton 2 has no scores: no evidence rather than a zero.
        assert_eq!(m.row(2), &[None, None]);
        for v in m.scores.iter().flatten() {
            assert!((0.0..=1.0).contains(v));
        }
    }

    fn with_dl(mut s: ModelScores, dl: f64) -> ModelScores {
        s.dl = Some(dl);
        s
    }

    /// One skeleton, two subjects, two joints. Acceleration points to subject 0, orientation to
    /// subject 1, velocity is missing: the geometric ballots tie.
    fn split_geometry(dl: Option<[f64; 2]>) -> ScoreTensor {
        let joints = [Joint::LeftWrist, Joint::RightAnkle];
        let mut t = ScoreTensor::new(1, 2, &joints).unwrap();
        for &j in &joints {
            for b in 0..2 {
                let (acc, ori) = if b == 0 { (0.8, 0.3) } else { (0.4, 0.7) };
                let mut s = ModelScores {
                    acc: Some(acc),
                    vel: None,
                    ori: Some(ori),
                    dl: None,
                };
                if let Some(dl) = dl {
                    s = with_dl(s, dl[b]);
                }
                t.set(0, b, j, s).unwrap();
            }
        }
        t
    }

    #[test]
    fn learned_voter_breaks_a_geometric_tie() {
        let cfg = FusionConfig::default();
        let without = fuse(&split_geometry(None), Fusion::ModelVote, &cfg);
        assert_eq!(without.get(0, 0), Some(0.5));
        assert_eq!(without.get(0, 1), Some(0.5));
        // The learned model sides with subject 1: two ballots of three.
        let with = fuse(&split_geometry(Some([-0.6, 0.9])), Fusion::ModelVote, &cfg);
        assert_eq!(with.best_subject(0), Some(1));
        assert!((with.get(0, 1).unwrap() - 2.0 / 3.0).abs() < 1e-12);
        // Per (model, joint): the learned model casts one ballot per joint, 4 of 6 ballots.
        let joint_votes = fuse(
            &split_geometry(Some([-0.6, 0.9])),
            Fusion::ModelJointVote,
            &cfg,
        );
        assert!((joint_votes.get(0, 1).unwrap() - 4.0 / 6.0).abs() < 1e-12);
        assert!((joint_votes.get(0, 0).unwrap() - 2.0 / 6.0).abs() < 1e-12);
    }

    #[test]
    fn learned_score_enters_mean_max_and_threshold_only_when_present() {
        let cfg = FusionConfig::default();
        let plain = split_geometry(None);
        let learned = split_geometry(Some([-0.6, 0.9]));
        // Without a learned score the mean is over acc and ori only.
        assert!((fuse(&plain, Fusion::Mean, &cfg).get(0, 1).unwrap() - 0.55).abs() < 1e-12);
        // With it: (0.4 + 0.7 + 0.9) / 3 per joint.
        let mean = fuse(&learned, Fusion::Mean, &cfg);
        assert!((mean.get(0, 1).unwrap() - 2.0 / 3.0).abs() < 1e-12);
        assert_eq!(fuse(&plain, Fusion::Max, &cfg).get(0, 1), Some(0.7));
        assert_eq!(fuse(&learned, Fusion::Max, &cfg).get(0, 1), Some(0.9));
        // Above 0.5 for subject 1: ori and dl of three entries per joint.
        let th = fuse(&learned, Fusion::Threshold, &cfg);
        assert!((th.get(0, 1).unwrap() - 2.0 / 3.0).abs() < 1e-12);
        // The learned model alone, and nothing at all when it did not run.
        let dl = fuse(&learned, Fusion::Dl, &cfg);
        assert_eq!(dl.get(0, 0), Some(-0.6));
        assert_eq!(dl.best_subject(0), Some(1));
        assert_eq!(fuse(&plain, Fusion::Dl, &cfg).row(0), &[None, None]);
        // The geometric single-model columns ignore it.
        assert_eq!(
            fuse(&learned, Fusion::Acc, &cfg),
            fuse(&plain, Fusion::Acc, &cfg)
        );
    }

    #[test]
    fn bad_indices_are_errors_and_nan_is_missing() {
        let mut t = ScoreTensor::new(1, 1, &[Joint::Pelvis]).unwrap();
        assert!(t.set(1, 0, Joint::Pelvis, ModelScores::default()).is_err());
        assert!(t.set(0, 0, Joint::Chest, ModelScores::default()).is_err());
        t.set(0, 0, Joint::Pelvis, scores(f64::NAN, 0.3, 0.2))
            .unwrap();
        assert_eq!(t.get(0, 0, Joint::Pelvis, Model::Acc), None);
        assert_eq!(
            fuse(&t, Fusion::Acc, &FusionConfig::default()).get(0, 0),
            None
        );
        let empty = fuse(
            &ScoreTensor::new(0, 0, &[]).unwrap(),
            Fusion::ModelVote,
            &FusionConfig::default(),
        );
        assert!(empty.scores.is_empty());
        let mut u = ScoreTensor::new(1, 1, &[Joint::Pelvis]).unwrap();
        u.set(
            0,
            0,
            Joint::Pelvis,
            with_dl(scores(0.1, 0.3, 0.2), f64::INFINITY),
        )
        .unwrap();
        assert_eq!(u.get(0, 0, Joint::Pelvis, Model::Dl), None);
        assert_eq!(u.get(0, 0, Joint::Pelvis, Model::Acc), Some(0.1));
    }

    #[test]
    fn a_tensor_too_large_to_hold_is_refused_by_its_sizes() {
        let joints = [Joint::Pelvis, Joint::LeftWrist];
        // The product wraps past usize::MAX, or does not but is past the limit.
        for (skeletons, subjects) in [(usize::MAX, 3), (1 << 20, 1 << 10)] {
            let e = ScoreTensor::new(skeletons, subjects, &joints).unwrap_err();
            assert!(
                matches!(e, EvidenceError::TooLarge { num_skeletons, num_subjects, num_joints: 2, .. }
                    if num_skeletons == skeletons && num_subjects == subjects),
                "{e:?}"
            );
            assert!(e.to_string().contains("too large"), "{e}");
        }
        // One skeleton past the limit (at the limit it would take a gigabyte).
        let per_skeleton = 2 * Model::ALL.len();
        assert!(ScoreTensor::new(MAX_TENSOR_ENTRIES / per_skeleton + 1, 1, &joints).is_err());
    }
}
