//! The evaluation report: what `nomen eval` prints and writes as JSON.
//!
//! Every ratio is `null` (`None`) when its denominator is zero. Definitions are in the doc comments
//! and in `crates/eval/nomen-eval/METRICS.md`.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use serde::{Deserialize, Serialize};

use super::confidence::ConfidenceReport;
use super::config::EvalConfig;
use super::stats::{BoxStats, ratio};
use crate::mot::MotMetrics;

/// How one truth skeleton-frame was labelled.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LabelOutcome {
    /// The right label: the person's own subject, or `Anonymous` for a person whose subject is
    /// `None`.
    Correct,
    /// A subject label that is not the person's subject (a false identity).
    WrongSubject,
    /// A registered subject left `Anonymous`, or without any result line.
    Anonymous,
}

/// Identification counts of a group of truth skeleton-frames.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct IdentificationStats {
    /// Truth skeleton-frames in the group.
    pub num_frames: u64,
    /// Frames with the right label ([`LabelOutcome::Correct`]).
    pub num_correct: u64,
    /// Frames labelled with a subject that is not the person's.
    pub num_wrong_subject: u64,
    /// Frames of registered subjects labelled `Anonymous` or not labelled at all.
    pub num_anonymous: u64,
    /// Frames without any result line (counted as `Anonymous`; included in `num_correct` for
    /// people whose subject is `None`, in `num_anonymous` for registered subjects).
    pub num_unlabelled: u64,
    /// `num_correct / num_frames`.
    pub accuracy: Option<f64>,
}

impl IdentificationStats {
    pub(crate) fn add(&mut self, outcome: LabelOutcome, is_unlabelled: bool) {
        self.num_frames += 1;
        match outcome {
            LabelOutcome::Correct => self.num_correct += 1,
            LabelOutcome::WrongSubject => self.num_wrong_subject += 1,
            LabelOutcome::Anonymous => self.num_anonymous += 1,
        }
        self.num_unlabelled += u64::from(is_unlabelled);
        self.finish();
    }

    pub(crate) fn merge(&mut self, other: &Self) {
        self.num_frames += other.num_frames;
        self.num_correct += other.num_correct;
        self.num_wrong_subject += other.num_wrong_subject;
        self.num_anonymous += other.num_anonymous;
        self.num_unlabelled += other.num_unlabelled;
        self.finish();
    }

    fn finish(&mut self) {
        self.accuracy = ratio(self.num_correct, self.num_frames);
    }
}

/// Llorca's association counts of a subject (or pooled over subjects).
///
/// A frame is a (camera, time) at which the subject is observed by that camera. At each frame
/// the subject's label sits on the result skeletons labelled with it (zero, one or more):
/// - CA: one of them is the subject's own skeleton;
/// - CNA: CA, or one of them belongs to a person whose reference point is within
///   `near_distance_m` of the subject's (CNA ⊇ CA);
/// - NA: none is labelled with the subject;
/// - incorrect: labelled skeletons exist but none is the subject's or near it
///   (`incorrect = 1 - cna - na`).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct AssociationStats {
    /// Frames at which the subject is observed.
    pub num_frames: u64,
    /// Frames with a correct association.
    pub num_ca: u64,
    /// Frames with a correct or near association.
    pub num_cna: u64,
    /// Frames with no association.
    pub num_na: u64,
    /// Frames with an association to a skeleton that is neither the subject's nor near it.
    pub num_incorrect: u64,
    /// `num_ca / num_frames`.
    pub ca: Option<f64>,
    /// `num_cna / num_frames`.
    pub cna: Option<f64>,
    /// `num_na / num_frames`.
    pub na: Option<f64>,
    /// `num_incorrect / num_frames`.
    pub incorrect: Option<f64>,
}

impl AssociationStats {
    pub(crate) fn merge(&mut self, other: &Self) {
        self.num_frames += other.num_frames;
        self.num_ca += other.num_ca;
        self.num_cna += other.num_cna;
        self.num_na += other.num_na;
        self.num_incorrect += other.num_incorrect;
        self.finish();
    }

    pub(crate) fn finish(&mut self) {
        self.ca = ratio(self.num_ca, self.num_frames);
        self.cna = ratio(self.num_cna, self.num_frames);
        self.na = ratio(self.num_na, self.num_frames);
        self.incorrect = ratio(self.num_incorrect, self.num_frames);
    }
}

/// Everything measured about one registered subject.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct SubjectReport {
    /// Identification of the subject's skeleton-frames.
    pub identification: IdentificationStats,
    /// Llorca's association metrics of the subject.
    pub association: AssociationStats,
    /// Identity switches on the subject's skeletons (see [`Metrics::id_switches`]).
    pub id_switches: u64,
    /// Frames of other people labelled with this subject.
    pub num_false_identities_as: u64,
    /// Appearances of the subject (per camera).
    pub num_appearances: u64,
    /// Appearances in which the subject is never labelled correctly.
    pub num_never_identified: u64,
}

/// Accuracy in one time bin.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TimeBin {
    /// Bin start on the session clock, seconds.
    pub start_s: f64,
    /// Bin end (exclusive), seconds.
    pub end_s: f64,
    /// Truth skeleton-frames in the bin.
    pub num_frames: u64,
    /// Frames labelled correctly.
    pub num_correct: u64,
    /// `num_correct / num_frames`.
    pub accuracy: Option<f64>,
}

/// Llorca's delay over the appearances of registered subjects.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct DelaySummary {
    /// Appearances of registered subjects.
    pub num_appearances: u64,
    /// Appearances in which no correct association holds (no delay defined).
    pub num_never_held: u64,
    /// Mean delay over the appearances where it is defined, frames.
    pub mean_frames: Option<f64>,
    /// Median delay, frames.
    pub median_frames: Option<f64>,
}

/// Time to the first correct identity over the appearances of registered subjects.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TimeToIdentifySummary {
    /// Appearances of registered subjects.
    pub num_appearances: u64,
    /// Appearances never labelled correctly.
    pub num_never_identified: u64,
    /// Median over the identified appearances, seconds.
    pub median_s: Option<f64>,
    /// Mean over the identified appearances, seconds.
    pub mean_s: Option<f64>,
    /// Box-plot summary of the identified appearances, seconds.
    pub box_s: Option<BoxStats>,
}

/// Tag position errors, raw (as the location system reported) and corrected (by nomen).
///
/// A sample is a [`TagCorrection`](nomen_core::TagCorrection) joined with the
/// [`TruthTag`](nomen_core::TruthTag) of the same tag at exactly the same time; its errors are the
/// Euclidean distances (3D, metres) of the raw and of the corrected position to the truth.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TagErrorStats {
    /// Joined samples.
    pub num_samples: u64,
    /// Root mean square of the raw errors, metres.
    pub rmse_raw_m: Option<f64>,
    /// Root mean square of the corrected errors, metres.
    pub rmse_corrected_m: Option<f64>,
    /// Box-plot summary of the raw errors, metres.
    pub raw_m: Option<BoxStats>,
    /// Box-plot summary of the corrected errors, metres.
    pub corrected_m: Option<BoxStats>,
    /// Raw errors, metres, in input order (not serialised: use the box summaries).
    #[serde(skip)]
    pub raw_errors_m: Vec<f64>,
    /// Corrected errors, metres, in input order (not serialised).
    #[serde(skip)]
    pub corrected_errors_m: Vec<f64>,
}

/// Tag errors per tag and pooled.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TagReport {
    /// All tags' samples together.
    pub pooled: TagErrorStats,
    /// Per tag id.
    pub per_tag: BTreeMap<String, TagErrorStats>,
    /// Corrections without a truth tag at the same (tag, time).
    pub num_corrections_without_truth: u64,
    /// Truth tags without a correction at the same (tag, time).
    pub num_truth_without_correction: u64,
}

/// Input that was odd but not fatal: counted, never silently dropped.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct DataIssues {
    /// Truth skeletons with the same (camera, time, track) as an earlier one (the first is kept).
    pub num_duplicate_truth: u64,
    /// Result lines with the same (camera, time, track) as an earlier one (the first is kept).
    pub num_duplicate_results: u64,
    /// Extra result skeletons carrying a subject label already on another skeleton of the same
    /// camera frame (each is a separate hypothesis in the MOT metrics).
    pub num_duplicate_labels: u64,
    /// Extra truth skeletons of a person already seen by the same camera at the same time.
    pub num_duplicate_person_frames: u64,
    /// Messages that are neither truth nor result (sensor input), ignored.
    pub num_ignored_messages: u64,
    /// Non-finite truth joint positions (left out of the reference point).
    pub num_nonfinite_joints: u64,
    /// Tag samples with a non-finite coordinate (left out of the errors).
    pub num_nonfinite_tag_samples: u64,
    /// Truth tags with the same (tag, time) as an earlier one (the first is kept).
    pub num_duplicate_tag_truth: u64,
    /// Corrections with the same (tag, time) as an earlier one (the first is kept).
    pub num_duplicate_tag_corrections: u64,
}

impl DataIssues {
    pub(crate) fn merge(&mut self, o: &Self) {
        self.num_duplicate_truth += o.num_duplicate_truth;
        self.num_duplicate_results += o.num_duplicate_results;
        self.num_duplicate_labels += o.num_duplicate_labels;
        self.num_duplicate_person_frames += o.num_duplicate_person_frames;
        self.num_ignored_messages += o.num_ignored_messages;
        self.num_nonfinite_joints += o.num_nonfinite_joints;
        self.num_nonfinite_tag_samples += o.num_nonfinite_tag_samples;
        self.num_duplicate_tag_truth += o.num_duplicate_tag_truth;
        self.num_duplicate_tag_corrections += o.num_duplicate_tag_corrections;
    }
}

/// One appearance of a registered subject in one camera: a maximal run of its observations by
/// that camera in which consecutive observations are less than `reappearance_gap_s` apart.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Appearance {
    /// The physical person.
    pub person: String,
    /// The person's subject.
    pub subject: String,
    /// The camera.
    pub camera: String,
    /// First observation, session clock, seconds.
    pub start_s: f64,
    /// Last observation, seconds.
    pub end_s: f64,
    /// Observation instants in the appearance.
    pub num_frames: u64,
    /// Time from the first observation until a correct label for the appearance is known (the
    /// earliest, over correctly labelled frames, of the later of the frame's time and its
    /// decision's time), seconds; `None` if never labelled correctly.
    pub time_to_identify_s: Option<f64>,
    /// Llorca's delay: index (0 = first observation) of the first correctly labelled frame from
    /// which the label stays correct (see [`EvalConfig::delay_hold_s`]); `None` if there is none.
    pub delay_frames: Option<u64>,
}

/// A run of equally labelled observations on a timeline.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TimelineSegment {
    /// Start, session clock, seconds.
    pub start_s: f64,
    /// End (exclusive), seconds.
    pub end_s: f64,
    /// How the observations in it were labelled.
    pub outcome: LabelOutcome,
}

/// How one person was labelled over time by one camera (a row of the identity timeline plot).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Timeline {
    /// The physical person.
    pub person: String,
    /// The person's subject, `None` for people who wear nothing.
    pub subject: Option<String>,
    /// The camera.
    pub camera: String,
    /// Runs of equal outcome. An observation covers the time until the next observation of the
    /// same appearance; the last one of an appearance covers one typical frame interval.
    pub segments: Vec<TimelineSegment>,
}

/// The metrics of one scene, or of all scenes pooled.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Metrics {
    /// Truth skeleton-frames (one per truth skeleton after removing duplicates).
    pub num_frames: u64,
    /// Identification accuracy: fraction of truth skeleton-frames whose label is right.
    pub id_accuracy: Option<f64>,
    /// Llorca's CA, pooled over subjects (frames of all subjects together).
    pub ca: Option<f64>,
    /// Llorca's CNA, pooled.
    pub cna: Option<f64>,
    /// Llorca's NA, pooled.
    pub na: Option<f64>,
    /// Llorca's incorrect rate (`1 - cna - na`), pooled.
    pub incorrect: Option<f64>,
    /// Mean Llorca delay over appearances where it is defined, frames.
    pub delay_frames: Option<f64>,
    /// Median time to the first correct identity over identified appearances, seconds.
    pub time_to_identify_s: Option<f64>,
    /// Identity switches: over each registered subject's observations by one camera in time
    /// order, with frames labelled `Anonymous` or unlabelled skipped, the number of consecutive
    /// pairs whose subject labels differ.
    pub id_switches: u64,
    /// Truth skeleton-frames labelled with a subject that is not the person's (people who wear
    /// nothing included).
    pub false_identities: u64,
    /// The part of `false_identities` on people whose subject is `None`.
    pub false_identities_on_intruders: u64,
    /// Fraction of the frames of people whose subject is `None` that are labelled `Anonymous`
    /// (or not labelled).
    pub intruder_anonymous_rate: Option<f64>,
    /// IDF1 of the subject labels taken as tracker hypotheses (see `METRICS.md`).
    pub idf1: Option<f64>,
    /// Identity precision of the subject labels.
    pub idp: Option<f64>,
    /// Identity recall of the subject labels.
    pub idr: Option<f64>,
    /// MOTA of the subject labels.
    pub mota: Option<f64>,
    /// MOTP of the subject labels: 0 by construction whenever a label matches (distances are 0
    /// or "cannot pair").
    pub motp: Option<f64>,
    /// RMSE of the raw tag positions, metres.
    pub tag_rmse_raw_m: Option<f64>,
    /// RMSE of the corrected tag positions, metres.
    pub tag_rmse_corrected_m: Option<f64>,
    /// Expected calibration error of the result's confidences (see [`ConfidenceReport::ece`]).
    pub confidence_ece: Option<f64>,
    /// Brier score of the result's confidences (see [`ConfidenceReport::brier`]).
    pub confidence_brier: Option<f64>,
    /// Truth skeleton-frames without a result line (counted as `Anonymous`).
    pub num_unlabelled: u64,
    /// Result lines without a truth skeleton at the same (camera, time, track); not part of any
    /// accuracy.
    pub num_result_without_truth: u64,
    /// The part of `num_result_without_truth` that carries a subject label.
    pub num_result_without_truth_labelled: u64,
    /// Identification of all truth skeleton-frames.
    pub identification: IdentificationStats,
    /// Per registered subject.
    pub per_subject: BTreeMap<String, SubjectReport>,
    /// The people whose subject is `None`, as one group.
    pub anonymous_people: IdentificationStats,
    /// Accuracy per time bin (bins without truth frames are left out).
    pub over_time: Vec<TimeBin>,
    /// Llorca's association counts pooled over subjects.
    pub association: AssociationStats,
    /// Llorca's delay.
    pub delay: DelaySummary,
    /// Time to identify.
    pub time_to_identify: TimeToIdentifySummary,
    /// All py-motmetrics metrics of the subject labels; `None` without any camera frame.
    pub mot: Option<MotMetrics>,
    /// Tag position errors.
    pub tags: TagReport,
    /// How well the confidences predict correctness (reliability bins, calibration error).
    pub confidence: ConfidenceReport,
    /// Odd input, counted.
    pub data_issues: DataIssues,
}

/// One scene's metrics plus its per-appearance and per-person details.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct SceneReport {
    /// The scene's metrics.
    #[serde(flatten)]
    pub metrics: Metrics,
    /// Appearances of registered subjects, by person, camera and time.
    pub appearances: Vec<Appearance>,
    /// Identity timelines, one per (person, camera), by person.
    pub timelines: Vec<Timeline>,
}

/// The result of [`evaluate`](super::evaluate): metrics of all scenes pooled (at the top level of
/// the JSON) and per scene.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct EvalReport {
    /// All scenes pooled: every count is summed over scenes, every rate is computed from the
    /// summed counts, every median from the pooled samples.
    #[serde(flatten)]
    pub overall: Metrics,
    /// Per scene, by name.
    pub per_scene: BTreeMap<String, SceneReport>,
    /// The configuration used.
    pub config: EvalConfig,
}

impl EvalReport {
    /// A plain-text table for the terminal: headline metrics (overall and per scene), then per
    /// subject, then per tag.
    pub fn to_table(&self) -> String {
        let mut columns: Vec<(&str, &Metrics)> = vec![("overall", &self.overall)];
        if self.per_scene.len() > 1 {
            columns.extend(self.per_scene.iter().map(|(k, s)| (k.as_str(), &s.metrics)));
        }
        let rows: [Row; 25] = [
            ("truth frames", |m| m.num_frames.to_string()),
            ("id_accuracy", |m| pct(m.id_accuracy)),
            ("ca", |m| pct(m.ca)),
            ("cna", |m| pct(m.cna)),
            ("na", |m| pct(m.na)),
            ("incorrect", |m| pct(m.incorrect)),
            ("delay_frames (mean)", |m| num(m.delay_frames, 1)),
            ("time_to_identify_s (median)", |m| {
                num(m.time_to_identify_s, 3)
            }),
            ("appearances never identified", |m| {
                format!(
                    "{}/{}",
                    m.time_to_identify.num_never_identified, m.time_to_identify.num_appearances
                )
            }),
            ("appearances never held (delay)", |m| {
                format!("{}/{}", m.delay.num_never_held, m.delay.num_appearances)
            }),
            ("id_switches", |m| m.id_switches.to_string()),
            ("false_identities", |m| m.false_identities.to_string()),
            ("  on people wearing nothing", |m| {
                m.false_identities_on_intruders.to_string()
            }),
            (
                "intruder_anonymous_rate",
                |m| pct(m.intruder_anonymous_rate),
            ),
            ("idf1", |m| pct(m.idf1)),
            ("idp", |m| pct(m.idp)),
            ("idr", |m| pct(m.idr)),
            ("mota", |m| pct(m.mota)),
            ("mot switches", |m| {
                m.mot
                    .as_ref()
                    .map_or("-".into(), |x| x.num_switches.to_string())
            }),
            ("tag_rmse_raw_m", |m| num(m.tag_rmse_raw_m, 3)),
            ("tag_rmse_corrected_m", |m| num(m.tag_rmse_corrected_m, 3)),
            ("confidence_ece", |m| num(m.confidence_ece, 4)),
            ("confidence_brier", |m| num(m.confidence_brier, 4)),
            ("unlabelled truth frames", |m| m.num_unlabelled.to_string()),
            ("result lines without truth", |m| {
                m.num_result_without_truth.to_string()
            }),
        ];
        let mut table = Table::new(
            std::iter::once("metric")
                .chain(columns.iter().map(|(name, _)| *name))
                .map(str::to_owned)
                .collect(),
        );
        for (name, cell) in rows {
            table.push(
                std::iter::once(name.to_owned())
                    .chain(columns.iter().map(|(_, m)| cell(m)))
                    .collect(),
            );
        }
        let mut out = table.render();

        if !self.overall.per_subject.is_empty() || self.overall.anonymous_people.num_frames > 0 {
            let mut table = Table::new(
                [
                    "subject",
                    "frames",
                    "accuracy",
                    "wrong",
                    "anon",
                    "ca",
                    "cna",
                    "na",
                    "switches",
                    "appear.",
                    "never id.",
                ]
                .map(str::to_owned)
                .to_vec(),
            );
            for (subject, r) in &self.overall.per_subject {
                let (i, a) = (&r.identification, &r.association);
                table.push(vec![
                    subject.clone(),
                    i.num_frames.to_string(),
                    pct(i.accuracy),
                    i.num_wrong_subject.to_string(),
                    i.num_anonymous.to_string(),
                    pct(a.ca),
                    pct(a.cna),
                    pct(a.na),
                    r.id_switches.to_string(),
                    r.num_appearances.to_string(),
                    r.num_never_identified.to_string(),
                ]);
            }
            let anon = &self.overall.anonymous_people;
            if anon.num_frames > 0 {
                table.push(vec![
                    "(wearing nothing)".into(),
                    anon.num_frames.to_string(),
                    pct(anon.accuracy),
                    anon.num_wrong_subject.to_string(),
                    "-".into(),
                    "-".into(),
                    "-".into(),
                    "-".into(),
                    "-".into(),
                    "-".into(),
                    "-".into(),
                ]);
            }
            out.push('\n');
            out.push_str(&table.render());
        }

        let tags = &self.overall.tags;
        if !tags.per_tag.is_empty() {
            let mut table = Table::new(
                [
                    "tag",
                    "samples",
                    "rmse raw m",
                    "rmse corr. m",
                    "median raw m",
                    "median corr. m",
                ]
                .map(str::to_owned)
                .to_vec(),
            );
            let all = std::iter::once(("(all)", &tags.pooled))
                .chain(tags.per_tag.iter().map(|(k, v)| (k.as_str(), v)));
            for (tag, s) in all {
                table.push(vec![
                    tag.to_owned(),
                    s.num_samples.to_string(),
                    num(s.rmse_raw_m, 3),
                    num(s.rmse_corrected_m, 3),
                    num(s.raw_m.as_ref().map(|b| b.median), 3),
                    num(s.corrected_m.as_ref().map(|b| b.median), 3),
                ]);
            }
            out.push('\n');
            out.push_str(&table.render());
            if tags.num_corrections_without_truth > 0 {
                let _ = writeln!(
                    out,
                    "{} tag corrections had no truth at the same (tag, time)",
                    tags.num_corrections_without_truth
                );
            }
        }
        out
    }
}

/// A table row: its name and how to print a column's value.
type Row = (&'static str, fn(&Metrics) -> String);

/// A percentage with one decimal, `-` when not computable.
fn pct(x: Option<f64>) -> String {
    match x {
        Some(v) if v.is_finite() => format!("{:.1}%", 100.0 * v),
        _ => "-".into(),
    }
}

/// A number with `decimals` decimals, `-` when not computable.
fn num(x: Option<f64>, decimals: usize) -> String {
    match x {
        Some(v) if v.is_finite() => format!("{v:.decimals$}"),
        _ => "-".into(),
    }
}

/// A left-aligned first column and right-aligned others, padded to the widest cell.
struct Table {
    rows: Vec<Vec<String>>,
}

impl Table {
    fn new(header: Vec<String>) -> Self {
        Self { rows: vec![header] }
    }

    fn push(&mut self, row: Vec<String>) {
        self.rows.push(row);
    }

    fn render(&self) -> String {
        let num_columns = self.rows.iter().map(Vec::len).max().unwrap_or(0);
        let widths: Vec<usize> = (0..num_columns)
            .map(|c| {
                self.rows
                    .iter()
                    .filter_map(|r| r.get(c))
                    .map(|s| s.chars().count())
                    .max()
                    .unwrap_or(0)
            })
            .collect();
        let mut out = String::new();
        for (i, row) in self.rows.iter().enumerate() {
            let mut line = String::new();
            for (c, (cell, width)) in row.iter().zip(&widths).enumerate() {
                if c == 0 {
                    let _ = write!(line, "{cell:<width$}");
                } else {
                    let _ = write!(line, "  {cell:>width$}");
                }
            }
            out.push_str(line.trim_end());
            out.push('\n');
            if i == 0 {
                let total = widths.iter().sum::<usize>() + 2 * widths.len().saturating_sub(1);
                out.push_str(&"-".repeat(total));
                out.push('\n');
            }
        }
        out
    }
}
