//! Multi-object tracking metrics, reproducing py-motmetrics 1.4.0.
//!
//! The pipeline mirrors py-motmetrics':
//!
//! 1. per frame, a [`MotAccumulator`] takes the ground-truth object ids, the hypothesis ids and
//!    their distance matrix (NaN = cannot pair) and records [`MotEvent`]s (`MATCH`, `SWITCH`,
//!    `MISS`, `FP`, `TRANSFER`, `ASCEND`, `MIGRATE`, and `RAW` input records);
//! 2. [`MotMetrics::from_events`] turns the event list into MOTA, MOTP, IDF1 and the rest.
//!
//! For MOTChallenge files, [`parse_motchallenge`] reads the text (sans-IO: the caller reads the
//! file) and [`compare_to_groundtruth`] pairs boxes by IoU distance
//! ([`iou_distance_matrix`]) and fills the accumulator:
//!
//! ```
//! use nomen_eval::mot::{
//!     IouMatchConfig, MotChallengeConfig, compare_to_groundtruth, parse_motchallenge,
//! };
//!
//! let gt = "1,1,10,10,20,40,1,-1,-1,-1\n2,1,12,10,20,40,1,-1,-1,-1\n";
//! let test = "1,7,11,10,20,40,-1,-1,-1,-1\n2,7,13,11,20,40,-1,-1,-1,-1\n";
//! let loader = MotChallengeConfig::default();
//! let gt = parse_motchallenge(gt, "gt.txt", &loader)?;
//! let test = parse_motchallenge(test, "test.txt", &loader)?;
//! let acc = compare_to_groundtruth(&gt, &test, &IouMatchConfig::default())?;
//! let metrics = acc.metrics()?;
//! assert_eq!(metrics.num_matches, 2);
//! assert_eq!(metrics.mota, 1.0);
//! # Ok::<(), nomen_eval::EvalError>(())
//! ```
//!
//! Golden values from py-motmetrics and the script that regenerates them are in
//! `tests/fixtures/` (`make_mot_golden.py`).

mod accumulator;
mod assignment;
mod distance;
mod metrics;
mod motchallenge;

pub use accumulator::{MotAccumulator, MotAccumulatorConfig, MotEvent, MotEventKind};
pub use distance::{BoundingBox, iou_distance_matrix};
pub use metrics::{MOSTLY_LOST_RATIO, MOSTLY_TRACKED_RATIO, MotMetrics};
pub use motchallenge::{
    IouMatchConfig, MAX_FIELDS, MAX_MOT_BYTES, MAX_MOT_LINE_BYTES, MIN_FIELDS, MOT_LIMITS,
    MotChallengeConfig, MotChallengeRow, compare_to_groundtruth, parse_motchallenge,
};
