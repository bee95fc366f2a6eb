//! Training pairs from simulated scenes.
//!
//! The pairs are the very windows the engine scores: [`PairRecorder`] is a
//! [`PairScorer`] that, plugged into the engine, computes the network input of every (track, IMU)
//! pair the engine scores and keeps it (returning `None`, so the engine's decisions are those
//! of a run without a learned voter). The engine builds those windows exactly as it will at
//! inference time (world-frame joints through its Kalman filter, Madgwick orientation, the
//! IMU resampled onto the track's timestamps at the estimated clock offset — or, before the
//! offset is accepted, at the pair's best lag, which makes negatives *harder*).
//!
//! [`TruthLabels`] labels a recorded pair from the scene's ground truth: the camera track's true
//! subject at the window's end (`truth_skeleton` messages) against the device's wearer (the
//! registry). Negatives are every other person in the scene, including people playing the same
//! motion-capture clip at another phase (the hard negatives of the scenario library).
//! [`balance`] keeps every positive and a seeded random subset of negatives.

use crate::features::{InputSpec, PairFeatures, pair_features};
use nomen_core::skeleton::Joint;
use nomen_core::{DeviceId, Message, Registry, SessionTime, SubjectId, TrackId};
use nomen_evidence::{ImuWindow, PairScorer, SkeletonWindow};
use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;
use std::collections::BTreeMap;
use std::sync::Mutex;

/// One pair the engine scored, with its network input.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordedPair {
    /// The camera track (from the skeleton window).
    pub track: Option<TrackId>,
    /// The IMU (from the IMU window).
    pub device: Option<DeviceId>,
    /// Where the IMU is worn.
    pub site: Joint,
    /// Last grid time of the window, session seconds.
    pub t_end_s: f64,
    /// The network input.
    pub features: PairFeatures,
}

/// A [`PairScorer`] that records every pair's network input and scores nothing (see the module
/// docs).
#[derive(Debug, Default)]
pub struct PairRecorder {
    spec: InputSpec,
    pairs: Mutex<Vec<RecordedPair>>,
}

impl PairRecorder {
    /// A recorder computing inputs by `spec`.
    pub fn new(spec: InputSpec) -> Self {
        Self {
            spec,
            pairs: Mutex::new(Vec::new()),
        }
    }

    /// Takes the pairs recorded so far, in the order the engine scored them.
    pub fn take(&self) -> Vec<RecordedPair> {
        match self.pairs.lock() {
            Ok(mut g) => std::mem::take(&mut *g),
            Err(poisoned) => std::mem::take(&mut *poisoned.into_inner()),
        }
    }
}

impl PairScorer for PairRecorder {
    fn score(&self, imu: &ImuWindow, skeleton: &SkeletonWindow, site: Joint) -> Option<f64> {
        let t_end_s = *skeleton.t_s.last()?;
        let features = pair_features(imu, skeleton, site, &self.spec)?;
        let pair = RecordedPair {
            track: skeleton.track,
            device: imu.device.clone(),
            site,
            t_end_s,
            features,
        };
        match self.pairs.lock() {
            Ok(mut g) => g.push(pair),
            Err(poisoned) => poisoned.into_inner().push(pair),
        }
        None
    }
}

/// Ground truth for labelling recorded pairs.
#[derive(Debug, Clone, Default)]
pub struct TruthLabels {
    /// (track, time ns) → true subject (`None`: someone who wears nothing). Tracks of different
    /// cameras that share an id at the same time with different people are marked ambiguous.
    by_track: BTreeMap<TrackId, BTreeMap<i64, Option<Option<SubjectId>>>>,
    wearer: BTreeMap<DeviceId, SubjectId>,
}

/// Largest distance between a window's end and a truth observation of its track, ns (one
/// frame at 20 Hz; the engine's grid is the track's own timestamps, so a match is exact up to
/// the seconds ↔ nanoseconds round trip).
const MAX_TRUTH_GAP_NS: i64 = 50_000_000;

impl TruthLabels {
    /// Indexes `truth_skeleton` messages and the registry's wearers.
    pub fn new(truth: &[Message], registry: &Registry) -> Self {
        let mut by_track: BTreeMap<TrackId, BTreeMap<i64, Option<Option<SubjectId>>>> =
            BTreeMap::new();
        for m in truth {
            if let Message::TruthSkeleton(s) = m {
                let slot = by_track
                    .entry(s.track)
                    .or_default()
                    .entry(s.t.as_ns())
                    .or_insert_with(|| Some(s.subject.clone()));
                if slot.as_ref().is_some_and(|sub| *sub != s.subject) {
                    *slot = None;
                }
            }
        }
        let mut wearer = BTreeMap::new();
        for subject in &registry.subjects {
            for w in &subject.wears {
                wearer.insert(w.device.clone(), subject.id.clone());
            }
        }
        Self { by_track, wearer }
    }

    /// Whether the pair's track is the device's wearer at the window's end; `None` when the
    /// track, time or device is unknown or ambiguous.
    pub fn is_match(&self, pair: &RecordedPair) -> Option<bool> {
        let wearer = self.wearer.get(pair.device.as_ref()?)?;
        let t = SessionTime::from_secs_f64(pair.t_end_s)?.as_ns();
        let track = self.by_track.get(&pair.track?)?;
        let before = track.range(..=t).next_back();
        let after = track.range(t..).next();
        let (t_truth, subject) = match (before, after) {
            (Some(b), Some(a)) => {
                if t - b.0 <= a.0 - t {
                    b
                } else {
                    a
                }
            }
            (Some(x), None) | (None, Some(x)) => x,
            (None, None) => return None,
        };
        if (t_truth - t).abs() > MAX_TRUTH_GAP_NS {
            return None;
        }
        let subject = subject.as_ref()?;
        Some(subject.as_ref() == Some(wearer))
    }
}

/// One labelled training pair.
#[derive(Debug, Clone, PartialEq)]
pub struct Example {
    /// Network input.
    pub features: PairFeatures,
    /// Same person.
    pub is_match: bool,
    /// Where it came from (a scene name): training and validation are split by group.
    pub group: String,
}

/// Labels recorded pairs with `labels` (pairs that cannot be labelled are dropped) and tags
/// them with `group`.
pub fn label_pairs(pairs: Vec<RecordedPair>, labels: &TruthLabels, group: &str) -> Vec<Example> {
    pairs
        .into_iter()
        .filter_map(|p| {
            labels.is_match(&p).map(|is_match| Example {
                features: p.features,
                is_match,
                group: group.to_owned(),
            })
        })
        .collect()
}

/// Keeps every positive and at most `negatives_per_positive` times as many negatives, chosen at
/// random with `seed`; the output keeps the input order.
pub fn balance(examples: Vec<Example>, negatives_per_positive: f64, seed: u64) -> Vec<Example> {
    let num_pos = examples.iter().filter(|e| e.is_match).count();
    let mut neg: Vec<usize> = (0..examples.len())
        .filter(|&i| !examples[i].is_match)
        .collect();
    let budget = (negatives_per_positive.max(0.0) * num_pos as f64).round() as usize;
    if neg.len() > budget {
        neg.shuffle(&mut ChaCha8Rng::seed_from_u64(seed));
        neg.truncate(budget);
    }
    let mut keep = vec![false; examples.len()];
    for i in neg {
        keep[i] = true;
    }
    examples
        .into_iter()
        .zip(keep)
        .filter(|(e, k)| e.is_match || *k)
        .map(|(e, _)| e)
        .collect()
}
