//! The identity evaluator behind `nomen eval`: how well nomen names camera skeletons and corrects
//! tag positions, measured against the simulator's (or an annotator's) ground truth.
//!
//! Input, per named scene, is a [`SceneData`] built from [`Message`](nomen_core::Message)s:
//! truth ([`TruthSkeleton`](nomen_core::TruthSkeleton): the physical person and their subject,
//! or `None` for people who wear nothing; [`TruthTag`](nomen_core::TruthTag)) and result
//! ([`IdentifiedSkeleton`](nomen_core::IdentifiedSkeleton),
//! [`TagCorrection`](nomen_core::TagCorrection)). Truth and result skeletons are joined exactly
//! on (camera, time, track); tags exactly on (tag, time). [`evaluate`] returns an
//! [`EvalReport`]: serialisable to JSON with stable snake_case keys, printable with
//! [`EvalReport::to_table`]. Every definition is in `crates/eval/nomen-eval/METRICS.md` and on
//! the report's fields.
//!
//! ```
//! use nomen_eval::identity::{EvalConfig, SceneData, evaluate};
//!
//! let truth = vec![]; // nomen_core::Message values read by the caller
//! let result = vec![];
//! let scene = SceneData::from_messages("lab", &truth, &result);
//! let report = evaluate(&[scene], &EvalConfig::default())?;
//! assert_eq!(report.overall.num_frames, 0);
//! assert_eq!(report.overall.id_accuracy, None); // nothing to measure is not 100 %
//! println!("{}", report.to_table());
//! # Ok::<(), nomen_eval::EvalError>(())
//! ```
//!
//! Nothing here reads files or clocks.

mod confidence;
mod config;
mod evaluate;
mod input;
mod report;
mod stats;

pub use confidence::{
    ConfidenceBin, ConfidenceReport, ConfidenceSample, NUM_CONFIDENCE_BINS, confidence_report,
    confidence_samples,
};
pub use config::EvalConfig;
pub use evaluate::evaluate;
pub use input::SceneData;
pub use report::{
    Appearance, AssociationStats, DataIssues, DelaySummary, EvalReport, IdentificationStats,
    LabelOutcome, Metrics, SceneReport, SubjectReport, TagErrorStats, TagReport, TimeBin,
    TimeToIdentifySummary, Timeline, TimelineSegment,
};
pub use stats::BoxStats;
