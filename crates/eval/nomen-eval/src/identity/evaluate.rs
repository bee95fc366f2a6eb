//! The evaluation itself: joins truth and result, walks every camera frame once, and turns the
//! counts into a [`EvalReport`].

use std::collections::btree_map::Entry;
use std::collections::{BTreeMap, BTreeSet};

use nomen_core::{CameraId, SessionTime, SubjectId, TagId, TrackId};

use super::confidence::ConfidenceTally;
use super::config::EvalConfig;
use super::input::{ResultLabel, SceneData, TruthFrame};
use super::report::{
    Appearance, AssociationStats, DataIssues, DelaySummary, EvalReport, IdentificationStats,
    LabelOutcome, Metrics, SceneReport, SubjectReport, TagErrorStats, TagReport, TimeBin,
    TimeToIdentifySummary, Timeline, TimelineSegment,
};
use super::stats::{BoxStats, mean, median, ratio, rms};
use crate::error::{EvalError, Result};
use crate::mot::{MotAccumulator, MotAccumulatorConfig, MotEvent, MotMetrics};

/// Ids of the MOT accumulator: (scene index, subject label). The scene index keeps scenes apart
/// when they are pooled, as py-motmetrics renames ids when it merges sequences.
type MotId = (usize, String);

/// Frame interval assumed for the last observation of a timeline when nothing better is known.
const FALLBACK_FRAME_INTERVAL_NS: i64 = 33_333_333;

/// Evaluates scenes against their truth.
///
/// Scenes are evaluated independently; the top level of the report pools them (counts summed,
/// rates recomputed, medians over pooled samples).
///
/// # Errors
/// [`EvalError::InvalidConfig`] for a bad configuration, [`EvalError::DuplicateScene`] if two
/// scenes share a name, and the MOT accumulator's errors (which cannot happen on the frames built
/// here, but are returned rather than hidden).
pub fn evaluate(scenes: &[SceneData], config: &EvalConfig) -> Result<EvalReport> {
    config.validate()?;
    let mut per_scene = BTreeMap::new();
    let mut overall = Tally::default();
    for (index, scene) in scenes.iter().enumerate() {
        let (tally, appearances, timelines) = analyse_scene(index, scene, config)?;
        overall.merge(&tally);
        let report = SceneReport {
            metrics: tally.metrics(config)?,
            appearances,
            timelines,
        };
        if per_scene.insert(scene.name.clone(), report).is_some() {
            return Err(EvalError::DuplicateScene {
                name: scene.name.clone(),
            });
        }
    }
    Ok(EvalReport {
        overall: overall.metrics(config)?,
        per_scene,
        config: config.clone(),
    })
}

/// Additive counts and samples of one scene, or of several merged.
#[derive(Debug, Clone, Default)]
struct Tally {
    identification: IdentificationStats,
    per_subject: BTreeMap<SubjectId, SubjectReport>,
    anonymous_people: IdentificationStats,
    /// Time bin index -> (frames, correct).
    bins: BTreeMap<i64, (u64, u64)>,
    false_identities: u64,
    false_identities_on_intruders: u64,
    num_result_without_truth: u64,
    num_result_without_truth_labelled: u64,
    /// (delay frames, time to identify s) per appearance of a registered subject.
    appearance_samples: Vec<(Option<u64>, Option<f64>)>,
    mot_events: Vec<MotEvent<MotId>>,
    /// Next unused MOT frame id (frames of merged tallies are shifted past it).
    mot_next_frame: i64,
    tag_samples: BTreeMap<TagId, (Vec<f64>, Vec<f64>)>,
    /// Every frame with a result line: its confidence against its correctness.
    confidence: ConfidenceTally,
    num_corrections_without_truth: u64,
    num_truth_without_correction: u64,
    issues: DataIssues,
}

impl Tally {
    fn merge(&mut self, other: &Tally) {
        self.identification.merge(&other.identification);
        for (subject, r) in &other.per_subject {
            let mine = self.per_subject.entry(subject.clone()).or_default();
            mine.identification.merge(&r.identification);
            mine.association.merge(&r.association);
            mine.id_switches += r.id_switches;
            mine.num_false_identities_as += r.num_false_identities_as;
            mine.num_appearances += r.num_appearances;
            mine.num_never_identified += r.num_never_identified;
        }
        self.anonymous_people.merge(&other.anonymous_people);
        for (bin, (n, c)) in &other.bins {
            let mine = self.bins.entry(*bin).or_default();
            mine.0 += n;
            mine.1 += c;
        }
        self.false_identities += other.false_identities;
        self.false_identities_on_intruders += other.false_identities_on_intruders;
        self.num_result_without_truth += other.num_result_without_truth;
        self.num_result_without_truth_labelled += other.num_result_without_truth_labelled;
        self.appearance_samples
            .extend_from_slice(&other.appearance_samples);
        let offset = self.mot_next_frame;
        self.mot_events
            .extend(other.mot_events.iter().map(|e| MotEvent {
                frame: e.frame + offset,
                ..e.clone()
            }));
        self.mot_next_frame += other.mot_next_frame;
        for (tag, (raw, corrected)) in &other.tag_samples {
            let mine = self.tag_samples.entry(tag.clone()).or_default();
            mine.0.extend_from_slice(raw);
            mine.1.extend_from_slice(corrected);
        }
        self.confidence.merge(&other.confidence);
        self.num_corrections_without_truth += other.num_corrections_without_truth;
        self.num_truth_without_correction += other.num_truth_without_correction;
        self.issues.merge(&other.issues);
    }

    fn metrics(&self, config: &EvalConfig) -> Result<Metrics> {
        let mut association = AssociationStats::default();
        for r in self.per_subject.values() {
            association.merge(&r.association);
        }
        association.finish();

        let delays: Vec<f64> = self
            .appearance_samples
            .iter()
            .filter_map(|(d, _)| d.map(|d| d as f64))
            .collect();
        let times: Vec<f64> = self
            .appearance_samples
            .iter()
            .filter_map(|(_, t)| *t)
            .collect();
        let num_appearances = self.appearance_samples.len() as u64;
        let delay = DelaySummary {
            num_appearances,
            num_never_held: num_appearances - delays.len() as u64,
            mean_frames: mean(&delays),
            median_frames: median(&delays),
        };
        let time_to_identify = TimeToIdentifySummary {
            num_appearances,
            num_never_identified: num_appearances - times.len() as u64,
            median_s: median(&times),
            mean_s: mean(&times),
            box_s: BoxStats::from_samples(&times),
        };

        let mot = if self.mot_next_frame > 0 {
            Some(MotMetrics::from_events(&self.mot_events)?)
        } else {
            None
        };
        let finite = |x: f64| x.is_finite().then_some(x);
        let mot_value = |f: fn(&MotMetrics) -> f64| mot.as_ref().and_then(|m| finite(f(m)));

        let mut tags = TagReport {
            num_corrections_without_truth: self.num_corrections_without_truth,
            num_truth_without_correction: self.num_truth_without_correction,
            ..TagReport::default()
        };
        let (mut all_raw, mut all_corrected) = (Vec::new(), Vec::new());
        for (tag, (raw, corrected)) in &self.tag_samples {
            all_raw.extend_from_slice(raw);
            all_corrected.extend_from_slice(corrected);
            tags.per_tag.insert(
                tag.to_string(),
                tag_error_stats(raw.clone(), corrected.clone()),
            );
        }
        tags.pooled = tag_error_stats(all_raw, all_corrected);

        let bin_s = config.time_bin_s;
        let over_time = self
            .bins
            .iter()
            .map(|(&k, &(n, c))| TimeBin {
                start_s: k as f64 * bin_s,
                end_s: (k + 1) as f64 * bin_s,
                num_frames: n,
                num_correct: c,
                accuracy: ratio(c, n),
            })
            .collect();

        let confidence = self.confidence.report();
        Ok(Metrics {
            num_frames: self.identification.num_frames,
            id_accuracy: self.identification.accuracy,
            ca: association.ca,
            cna: association.cna,
            na: association.na,
            incorrect: association.incorrect,
            delay_frames: delay.mean_frames,
            time_to_identify_s: time_to_identify.median_s,
            id_switches: self.per_subject.values().map(|r| r.id_switches).sum(),
            false_identities: self.false_identities,
            false_identities_on_intruders: self.false_identities_on_intruders,
            intruder_anonymous_rate: self.anonymous_people.accuracy,
            idf1: mot_value(|m| m.idf1),
            idp: mot_value(|m| m.idp),
            idr: mot_value(|m| m.idr),
            mota: mot_value(|m| m.mota),
            motp: mot_value(|m| m.motp),
            tag_rmse_raw_m: tags.pooled.rmse_raw_m,
            tag_rmse_corrected_m: tags.pooled.rmse_corrected_m,
            confidence_ece: confidence.ece,
            confidence_brier: confidence.brier,
            num_unlabelled: self.identification.num_unlabelled,
            num_result_without_truth: self.num_result_without_truth,
            num_result_without_truth_labelled: self.num_result_without_truth_labelled,
            identification: self.identification.clone(),
            per_subject: self
                .per_subject
                .iter()
                .map(|(s, r)| {
                    let mut r = r.clone();
                    r.association.finish();
                    (s.to_string(), r)
                })
                .collect(),
            anonymous_people: self.anonymous_people.clone(),
            over_time,
            association,
            delay,
            time_to_identify,
            mot,
            tags,
            confidence,
            data_issues: self.issues.clone(),
        })
    }
}

fn tag_error_stats(raw: Vec<f64>, corrected: Vec<f64>) -> TagErrorStats {
    TagErrorStats {
        num_samples: raw.len() as u64,
        rmse_raw_m: rms(&raw),
        rmse_corrected_m: rms(&corrected),
        raw_m: BoxStats::from_samples(&raw),
        corrected_m: BoxStats::from_samples(&corrected),
        raw_errors_m: raw,
        corrected_errors_m: corrected,
    }
}

/// A scene's truth and result joined on (camera, time, track), each sorted by that key with
/// duplicates dropped (the first kept).
struct Join<'a> {
    truth: Vec<&'a TruthFrame>,
    results: Vec<&'a ResultLabel>,
    /// Per truth frame, its result line.
    labels: Vec<Option<&'a ResultLabel>>,
    num_duplicate_truth: u64,
    num_duplicate_results: u64,
    /// Result lines without a truth frame.
    unmatched: Vec<&'a ResultLabel>,
}

fn join(scene: &SceneData) -> Join<'_> {
    let mut truth: Vec<&TruthFrame> = scene.truth.iter().collect();
    let num_duplicate_truth = sort_dedup(&mut truth, truth_key);
    let mut results: Vec<&ResultLabel> = scene.results.iter().collect();
    let num_duplicate_results = sort_dedup(&mut results, result_key);
    // Both lists are sorted by the key.
    let mut labels: Vec<Option<&ResultLabel>> = vec![None; truth.len()];
    let mut unmatched = Vec::new();
    let mut j = 0;
    for (i, frame) in truth.iter().enumerate() {
        while let Some(r) = results.get(j)
            && result_key(r) < truth_key(frame)
        {
            unmatched.push(*r);
            j += 1;
        }
        if let Some(r) = results.get(j)
            && result_key(r) == truth_key(frame)
        {
            labels[i] = Some(r);
            j += 1;
        }
    }
    unmatched.extend_from_slice(results.get(j..).unwrap_or_default());
    Join {
        truth,
        results,
        labels,
        num_duplicate_truth,
        num_duplicate_results,
        unmatched,
    }
}

/// The truth frames of `scene` (sorted, duplicates dropped) and each one's result line.
pub(super) fn joined(scene: &SceneData) -> (Vec<&TruthFrame>, Vec<Option<&ResultLabel>>) {
    let Join { truth, labels, .. } = join(scene);
    (truth, labels)
}

/// How a truth frame with subject `truth` and label `label` counts.
pub(super) fn outcome(truth: Option<&SubjectId>, label: Option<&SubjectId>) -> LabelOutcome {
    match (truth, label) {
        (None, None) => LabelOutcome::Correct,
        (Some(_), None) => LabelOutcome::Anonymous,
        (Some(s), Some(l)) if s == l => LabelOutcome::Correct,
        (_, Some(_)) => LabelOutcome::WrongSubject,
    }
}

/// One observation of a person by a camera, for the per-person sequences.
#[derive(Debug, Clone, Copy)]
struct Observation<'a> {
    t: SessionTime,
    /// When its label was known (see [`ResultLabel::known_at`]); `t` when unlabelled.
    known_at: SessionTime,
    label: Option<&'a SubjectId>,
    outcome: LabelOutcome,
}

/// One person's observations by one camera, with the person's subject.
type Sequence<'a> = (Option<&'a SubjectId>, Vec<Observation<'a>>);

type Key<'a> = (&'a CameraId, SessionTime, TrackId);

fn truth_key(f: &TruthFrame) -> Key<'_> {
    (&f.camera, f.t, f.track)
}

fn result_key(r: &ResultLabel) -> Key<'_> {
    (&r.camera, r.t, r.track)
}

/// Sorts by key (stably, so the first of duplicates is the earliest given) and drops duplicates;
/// returns the number dropped.
fn sort_dedup<T>(items: &mut Vec<&T>, key: impl for<'x> Fn(&'x T) -> Key<'x>) -> u64 {
    items.sort_by(|a, b| key(a).cmp(&key(b)));
    let before = items.len();
    items.dedup_by(|b, a| key(a) == key(b));
    (before - items.len()) as u64
}

fn analyse_scene(
    scene_index: usize,
    scene: &SceneData,
    config: &EvalConfig,
) -> Result<(Tally, Vec<Appearance>, Vec<Timeline>)> {
    let mut tally = Tally::default();
    tally.issues.num_ignored_messages = scene.num_ignored_messages;
    tally.issues.num_nonfinite_joints = scene.num_nonfinite_joints;
    tally.issues.num_nonfinite_tag_samples = scene.num_nonfinite_tag_samples;

    let Join {
        truth,
        results,
        labels,
        num_duplicate_truth,
        num_duplicate_results,
        unmatched,
    } = join(scene);
    tally.issues.num_duplicate_truth = num_duplicate_truth;
    tally.issues.num_duplicate_results = num_duplicate_results;
    for r in unmatched {
        tally.num_result_without_truth += 1;
        tally.num_result_without_truth_labelled += u64::from(r.subject.is_some());
    }

    // Per frame: identification, false identities, time bins, per-person sequences.
    let bin_ns = config.time_bin_ns();
    let mut sequences: BTreeMap<(&str, &CameraId), Sequence> = BTreeMap::new();
    for (frame, result) in truth.iter().zip(&labels) {
        let label = result.and_then(|r| r.subject.as_ref());
        let is_unlabelled = result.is_none();
        let o = outcome(frame.subject.as_ref(), label);
        tally.identification.add(o, is_unlabelled);
        if let Some(r) = result {
            tally
                .confidence
                .add(r.confidence, o == LabelOutcome::Correct);
        }
        match &frame.subject {
            Some(s) => tally
                .per_subject
                .entry(s.clone())
                .or_default()
                .identification
                .add(o, is_unlabelled),
            None => tally.anonymous_people.add(o, is_unlabelled),
        }
        if o == LabelOutcome::WrongSubject {
            tally.false_identities += 1;
            tally.false_identities_on_intruders += u64::from(frame.subject.is_none());
            if let Some(l) = label {
                tally
                    .per_subject
                    .entry(l.clone())
                    .or_default()
                    .num_false_identities_as += 1;
            }
        }
        let bin = tally
            .bins
            .entry(frame.t.as_ns().div_euclid(bin_ns))
            .or_default();
        bin.0 += 1;
        bin.1 += u64::from(o == LabelOutcome::Correct);

        let (_, seq) = sequences
            .entry((frame.person.as_str(), &frame.camera))
            .or_insert_with(|| (frame.subject.as_ref(), Vec::new()));
        let obs = Observation {
            t: frame.t,
            known_at: result.map_or(frame.t, |r| r.known_at),
            label,
            outcome: o,
        };
        // Truth is sorted by (camera, time), so each sequence is in time order. A person seen
        // twice by one camera at one instant keeps one observation: a correct one if any.
        match seq.last_mut() {
            Some(last) if last.t == frame.t => {
                tally.issues.num_duplicate_person_frames += 1;
                if o == LabelOutcome::Correct {
                    *last = obs;
                }
            }
            _ => seq.push(obs),
        }
    }

    // Camera frames: Llorca's association and the MOT accumulator.
    walk_camera_frames(scene_index, &truth, &results, config, &mut tally)?;

    // Per (person, camera): appearances, delays, switches, timelines.
    let mut appearances = Vec::new();
    let mut timelines = Vec::new();
    let gap_ns = config.reappearance_gap_ns();
    let hold_ns = config.delay_hold_ns();
    for ((person, camera), (subject, seq)) in &sequences {
        let runs = split_appearances(seq, gap_ns);
        if let Some(subject) = subject {
            let report = tally.per_subject.entry((*subject).clone()).or_default();
            report.id_switches += count_switches(seq);
            for run in &runs {
                // A label given to a frame by a later decision counts from that decision.
                let first_correct = run
                    .iter()
                    .filter(|o| o.outcome == LabelOutcome::Correct)
                    .map(|o| o.known_at)
                    .min();
                let time_to_identify_s = first_correct.map(|t| t.secs_since(run[0].t));
                let delay_frames = llorca_delay(run, hold_ns);
                report.num_appearances += 1;
                report.num_never_identified += u64::from(first_correct.is_none());
                tally
                    .appearance_samples
                    .push((delay_frames, time_to_identify_s));
                appearances.push(Appearance {
                    person: (*person).to_owned(),
                    subject: subject.to_string(),
                    camera: camera.to_string(),
                    start_s: run[0].t.as_secs_f64(),
                    end_s: run[run.len() - 1].t.as_secs_f64(),
                    num_frames: run.len() as u64,
                    time_to_identify_s,
                    delay_frames,
                });
            }
        }
        timelines.push(Timeline {
            person: (*person).to_owned(),
            subject: subject.map(ToString::to_string),
            camera: camera.to_string(),
            segments: timeline_segments(&runs),
        });
    }

    tag_errors(scene, &mut tally);
    Ok((tally, appearances, timelines))
}

/// Splits a time-ordered sequence where consecutive observations are `gap_ns` or more apart.
/// Every returned run is non-empty.
fn split_appearances<'s, 'a>(
    seq: &'s [Observation<'a>],
    gap_ns: i64,
) -> Vec<&'s [Observation<'a>]> {
    let mut runs = Vec::new();
    let mut start = 0;
    for i in 1..seq.len() {
        if seq[i].t - seq[i - 1].t >= gap_ns {
            runs.push(&seq[start..i]);
            start = i;
        }
    }
    if start < seq.len() {
        runs.push(&seq[start..]);
    }
    runs
}

/// Identity switches of one person in one camera: subject labels in time order with unlabelled
/// and `Anonymous` observations skipped; a switch is a label different from the previous one.
fn count_switches(seq: &[Observation]) -> u64 {
    let mut previous: Option<&SubjectId> = None;
    let mut num_switches = 0;
    for label in seq.iter().filter_map(|o| o.label) {
        if previous.is_some_and(|p| p != label) {
            num_switches += 1;
        }
        previous = Some(label);
    }
    num_switches
}

/// Llorca's delay in one appearance: the index of the first correct observation `k` such that
/// every observation at `t <= t_k + hold_ns` is correct too (`hold_ns = i64::MAX`: to the end of
/// the appearance). `None` if there is no such observation.
fn llorca_delay(run: &[Observation], hold_ns: i64) -> Option<u64> {
    // next_bad[k]: first index >= k whose observation is not correct (run.len() if none).
    let mut next_bad = vec![run.len(); run.len() + 1];
    for k in (0..run.len()).rev() {
        next_bad[k] = if run[k].outcome == LabelOutcome::Correct {
            next_bad[k + 1]
        } else {
            k
        };
    }
    (0..run.len())
        .find(|&k| {
            run[k].outcome == LabelOutcome::Correct
                && run
                    .get(next_bad[k])
                    .is_none_or(|bad| bad.t - run[k].t > hold_ns)
        })
        .map(|k| k as u64)
}

/// Runs of equal outcome. Observation `i` covers `[t_i, t_{i+1})` inside an appearance; the last
/// of an appearance covers the median frame interval of the sequence.
fn timeline_segments(runs: &[&[Observation]]) -> Vec<TimelineSegment> {
    let intervals: Vec<f64> = runs
        .iter()
        .flat_map(|run| run.windows(2).map(|w| (w[1].t - w[0].t) as f64))
        .collect();
    let frame_ns = median(&intervals).map_or(FALLBACK_FRAME_INTERVAL_NS, |m| m.round() as i64);
    let mut segments: Vec<TimelineSegment> = Vec::new();
    for run in runs {
        for (i, o) in run.iter().enumerate() {
            let start_s = o.t.as_secs_f64();
            let end_s = run
                .get(i + 1)
                .map_or((o.t + frame_ns).as_secs_f64(), |next| next.t.as_secs_f64());
            match segments.last_mut() {
                Some(last) if last.outcome == o.outcome && last.end_s == start_s => {
                    last.end_s = end_s;
                }
                _ => segments.push(TimelineSegment {
                    start_s,
                    end_s,
                    outcome: o.outcome,
                }),
            }
        }
    }
    segments
}

/// Walks the camera frames (camera, time) of the union of truth and results, both sorted by
/// (camera, time, track): Llorca's association per subject, and one MOT frame per camera frame
/// with one accumulator per camera.
fn walk_camera_frames(
    scene_index: usize,
    truth: &[&TruthFrame],
    results: &[&ResultLabel],
    config: &EvalConfig,
    tally: &mut Tally,
) -> Result<()> {
    let (mut i, mut j) = (0, 0);
    let mut accumulator: Option<(&CameraId, MotAccumulator<MotId>)> = None;
    let mut oids: Vec<MotId> = Vec::new();
    let mut hids: Vec<MotId> = Vec::new();
    let mut distances: Vec<f64> = Vec::new();
    loop {
        let key = match (truth.get(i), results.get(j)) {
            (Some(a), Some(b)) => (&a.camera, a.t).min((&b.camera, b.t)),
            (Some(a), None) => (&a.camera, a.t),
            (None, Some(b)) => (&b.camera, b.t),
            (None, None) => break,
        };
        let i_end = i + truth[i..]
            .iter()
            .take_while(|f| (&f.camera, f.t) == key)
            .count();
        let j_end = j + results[j..]
            .iter()
            .take_while(|r| (&r.camera, r.t) == key)
            .count();
        let (frames, labels) = (&truth[i..i_end], &results[j..j_end]);
        (i, j) = (i_end, j_end);

        // Wearers in this camera frame, with their tracks.
        let mut wearers: BTreeMap<&SubjectId, Vec<&TruthFrame>> = BTreeMap::new();
        for f in frames {
            if let Some(s) = &f.subject {
                wearers.entry(s).or_default().push(f);
            }
        }

        // Llorca's association.
        for (subject, own) in &wearers {
            let anchor = own.iter().find_map(|f| f.anchor_m);
            let labelled = labels
                .iter()
                .filter(|r| r.subject.as_ref() == Some(*subject));
            let (mut any, mut is_ca, mut is_near) = (false, false, false);
            for r in labelled {
                any = true;
                if own.iter().any(|f| f.track == r.track) {
                    is_ca = true;
                } else if let (Some(a), Some(b)) = (
                    anchor,
                    frames
                        .iter()
                        .find(|f| f.track == r.track)
                        .and_then(|f| f.anchor_m),
                ) && (a - b).norm() <= config.near_distance_m
                {
                    is_near = true;
                }
            }
            let stats = &mut tally
                .per_subject
                .entry((*subject).clone())
                .or_default()
                .association;
            stats.num_frames += 1;
            stats.num_ca += u64::from(is_ca);
            stats.num_cna += u64::from(is_ca || is_near);
            stats.num_na += u64::from(!any);
            stats.num_incorrect += u64::from(any && !is_ca && !is_near);
        }

        // MOT: objects are the wearers, hypotheses the subject labels.
        let camera = key.0;
        if accumulator.as_ref().is_none_or(|(c, _)| *c != camera) {
            if let Some((_, acc)) = accumulator.take() {
                tally.mot_events.extend(acc.into_events());
            }
            accumulator = Some((camera, MotAccumulator::new(MotAccumulatorConfig::default())));
        }
        oids.clear();
        oids.extend(wearers.keys().map(|s| (scene_index, s.to_string())));
        let mut hyp_labels: Vec<(&SubjectId, TrackId)> = labels
            .iter()
            .filter_map(|r| r.subject.as_ref().map(|s| (s, r.track)))
            .collect();
        hyp_labels.sort();
        hids.clear();
        let mut num_same = 0;
        for (k, (s, _)) in hyp_labels.iter().enumerate() {
            if k > 0 && hyp_labels[k - 1].0 == *s {
                num_same += 1;
                tally.issues.num_duplicate_labels += 1;
                hids.push((scene_index, format!("{s}#{}", num_same + 1)));
            } else {
                num_same = 0;
                hids.push((scene_index, s.to_string()));
            }
        }
        distances.clear();
        for own in wearers.values() {
            for (_, track) in &hyp_labels {
                let is_on_own = own.iter().any(|f| f.track == *track);
                distances.push(if is_on_own { 0.0 } else { f64::NAN });
            }
        }
        if let Some((_, acc)) = accumulator.as_mut() {
            acc.update(tally.mot_next_frame, &oids, &hids, &distances)?;
        }
        tally.mot_next_frame += 1;
    }
    if let Some((_, acc)) = accumulator.take() {
        tally.mot_events.extend(acc.into_events());
    }
    Ok(())
}

/// Joins corrections with truth tags on (tag, time) and collects the errors.
fn tag_errors(scene: &SceneData, tally: &mut Tally) {
    let mut truth = BTreeMap::new();
    for t in &scene.tag_truth {
        match truth.entry((&t.tag, t.t)) {
            Entry::Vacant(e) => {
                e.insert(t.position_m);
            }
            Entry::Occupied(_) => tally.issues.num_duplicate_tag_truth += 1,
        }
    }
    let mut seen = BTreeSet::new();
    for fix in &scene.tag_fixes {
        if !seen.insert((&fix.tag, fix.t)) {
            tally.issues.num_duplicate_tag_corrections += 1;
            continue;
        }
        match truth.get(&(&fix.tag, fix.t)) {
            Some(p) => {
                let samples = tally.tag_samples.entry(fix.tag.clone()).or_default();
                samples.0.push((fix.raw_m - p).norm());
                samples.1.push((fix.corrected_m - p).norm());
            }
            None => tally.num_corrections_without_truth += 1,
        }
    }
    tally.num_truth_without_correction = truth.keys().filter(|k| !seen.contains(*k)).count() as u64;
}

#[cfg(test)]
mod tests {
    use super::*;

    fn obs<'a>(k: i64, label: Option<&'a SubjectId>, outcome: LabelOutcome) -> Observation<'a> {
        Observation {
            t: SessionTime(k * 100_000_000), // 10 Hz
            known_at: SessionTime(k * 100_000_000),
            label,
            outcome,
        }
    }

    #[test]
    fn a_gap_of_exactly_the_reappearance_gap_starts_a_new_appearance() {
        let c = LabelOutcome::Correct;
        // 0.0, 0.1 s, then 1.1 s (gap 1.0 s: new), then 2.0 s (gap 0.9 s: same).
        let seq = [
            obs(0, None, c),
            obs(1, None, c),
            obs(11, None, c),
            obs(20, None, c),
        ];
        let runs = split_appearances(&seq, 1_000_000_000);
        assert_eq!(runs.iter().map(|r| r.len()).collect::<Vec<_>>(), [2, 2]);
    }

    #[test]
    fn anonymous_stretches_do_not_break_or_make_a_switch() {
        let (ana, bob) = (SubjectId::new("ana"), SubjectId::new("bob"));
        let (c, a, w) = (
            LabelOutcome::Correct,
            LabelOutcome::Anonymous,
            LabelOutcome::WrongSubject,
        );
        // ana, -, ana: no switch. ana, -, bob, bob, ana: two switches.
        let same = [
            obs(0, Some(&ana), c),
            obs(1, None, a),
            obs(2, Some(&ana), c),
        ];
        assert_eq!(count_switches(&same), 0);
        let back_and_forth = [
            obs(0, Some(&ana), c),
            obs(1, None, a),
            obs(2, Some(&bob), w),
            obs(3, Some(&bob), w),
            obs(4, Some(&ana), c),
        ];
        assert_eq!(count_switches(&back_and_forth), 2);
    }

    #[test]
    fn the_delay_waits_for_a_correct_label_that_holds() {
        let ana = SubjectId::new("ana");
        let (c, a) = (LabelOutcome::Correct, LabelOutcome::Anonymous);
        // Correct at 1, lost at 2, correct from 3 to the end (10 Hz).
        let run = [
            obs(0, None, a),
            obs(1, Some(&ana), c),
            obs(2, None, a),
            obs(3, Some(&ana), c),
            obs(4, Some(&ana), c),
        ];
        assert_eq!(llorca_delay(&run, i64::MAX), Some(3));
        // A hold of 0.05 s (shorter than a frame) is met by frame 1 alone.
        assert_eq!(llorca_delay(&run, 50_000_000), Some(1));
        // Ending on a wrong frame: never holds to the end.
        assert_eq!(llorca_delay(&run[..3], i64::MAX), None);
    }

    #[test]
    fn timeline_runs_merge_equal_outcomes_and_stop_at_gaps() {
        let (c, a) = (LabelOutcome::Correct, LabelOutcome::Anonymous);
        let seq = [
            obs(0, None, a),
            obs(1, None, c),
            obs(2, None, c),
            obs(30, None, c),
        ];
        let runs = split_appearances(&seq, 1_000_000_000);
        let segments = timeline_segments(&runs);
        // [0, 0.1) anonymous, [0.1, 0.3) correct (last frame covers the 0.1 s median interval),
        // then [3.0, 3.1) correct after the gap.
        let expected = [(0.0, 0.1, a), (0.1, 0.3, c), (3.0, 3.1, c)];
        assert_eq!(segments.len(), expected.len());
        for (s, (start_s, end_s, outcome)) in segments.iter().zip(expected) {
            assert!((s.start_s - start_s).abs() < 1e-12 && (s.end_s - end_s).abs() < 1e-12);
            assert_eq!(s.outcome, outcome);
        }
    }
}
