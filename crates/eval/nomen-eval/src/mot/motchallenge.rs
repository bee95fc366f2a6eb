//! MOTChallenge text files (`frame,id,bb_left,bb_top,bb_width,bb_height,conf,x,y,z`) and
//! their comparison with ground truth, as py-motmetrics' `mot15-2D` loader and
//! `utils.compare_to_groundtruth(..., 'iou')` do it.

use std::collections::BTreeMap;

use nomen_core::bounded::{KIB_BYTES, Limits, MIB_BYTES};
use serde::{Deserialize, Serialize};

use crate::error::{EvalError, Result};

use super::accumulator::{MotAccumulator, MotAccumulatorConfig};
use super::distance::{BoundingBox, iou_distance_matrix};

/// Field names of a MOTChallenge 2D line, as in the MOT15 documentation.
const FIELD_NAMES: [&str; 10] = [
    "frame",
    "id",
    "bb_left",
    "bb_top",
    "bb_width",
    "bb_height",
    "conf",
    "x",
    "y",
    "z",
];

/// Fewest fields a line may have: up to and including `conf`, which the loader filters on.
pub const MIN_FIELDS: usize = 7;

/// Most fields a line may have.
pub const MAX_FIELDS: usize = FIELD_NAMES.len();

/// The longest line a MOTChallenge file may have, bytes: 64 KiB (a line of ten numbers is
/// about 60 bytes).
pub const MAX_MOT_LINE_BYTES: u64 = 64 * KIB_BYTES;

/// The most bytes a MOTChallenge file may have: 128 MiB, about two million boxes, more than
/// MOT20's largest ground truth. Parsing holds a row (80 bytes) for every line (at least 14
/// bytes).
pub const MAX_MOT_BYTES: u64 = 128 * MIB_BYTES;

/// The limits a MOTChallenge file is read within.
pub const MOT_LIMITS: Limits =
    Limits::text("a MOTChallenge file", MAX_MOT_LINE_BYTES, MAX_MOT_BYTES);

/// How MOTChallenge files are filtered.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MotChallengeConfig {
    /// Lines with `conf` below this are dropped. py-motmetrics' default is -1 (keep every line
    /// of MOT15 files, whose detections carry `conf = -1`); MOTChallenge suggests 1 for ground
    /// truth whose `conf = 0` marks boxes to ignore.
    pub min_confidence: f64,
}

impl Default for MotChallengeConfig {
    fn default() -> Self {
        Self {
            min_confidence: -1.0,
        }
    }
}

/// One kept line of a MOTChallenge file.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MotChallengeRow {
    /// Frame number as written in the file.
    pub frame: i64,
    /// Object or track id.
    pub id: i64,
    /// The box, shifted from the file's 1-based (MATLAB) pixel coordinates to 0-based.
    pub bbox: BoundingBox,
    /// The `conf` field.
    pub confidence: f64,
    /// The optional 8th to 10th fields (MOT15: world `x`, `y`, `z`; MOT16: class, visibility).
    pub trailing: [Option<f64>; 3],
    /// 1-based line number in the source, for messages.
    pub line: usize,
}

/// Parses a MOTChallenge 2D text (ground truth or tracker output).
///
/// Fields are separated by commas (surrounding blanks ignored) or, on lines without a comma,
/// by whitespace; blank lines are skipped. Every field must be a finite number, `frame` and
/// `id` integers (`3.0` is accepted), widths and heights non-negative. `bb_left`/`bb_top` are
/// shifted by -1 as py-motmetrics does. Lines with `conf < config.min_confidence` are dropped.
/// A kept line repeating the (frame, id) of an earlier kept line is an error.
/// `source_name` only labels error messages (`source_name:line: ...`).
///
/// # Errors
/// The first malformed line: [`EvalError::TooFewFields`], [`EvalError::TooManyFields`],
/// [`EvalError::NonNumericField`], [`EvalError::NonFiniteField`],
/// [`EvalError::NonIntegerField`], [`EvalError::NegativeSize`] or
/// [`EvalError::DuplicateRow`].
pub fn parse_motchallenge(
    text: &str,
    source_name: &str,
    config: &MotChallengeConfig,
) -> Result<Vec<MotChallengeRow>> {
    let mut rows = Vec::new();
    let mut first_line_of: BTreeMap<(i64, i64), usize> = BTreeMap::new();
    let mut fields: Vec<&str> = Vec::with_capacity(MAX_FIELDS);
    // A byte-order mark (some Windows editors write one) is not part of the first frame number.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    for (index, raw_line) in text.lines().enumerate() {
        let line = index + 1;
        let content = raw_line.trim();
        if content.is_empty() {
            continue;
        }
        fields.clear();
        if content.contains(',') {
            fields.extend(content.split(',').map(str::trim));
        } else {
            fields.extend(content.split_whitespace());
        }
        let row = parse_fields(&fields, source_name, line)?;
        if row.confidence < config.min_confidence {
            continue;
        }
        if let Some(&first_line) = first_line_of.get(&(row.frame, row.id)) {
            return Err(EvalError::DuplicateRow {
                source_name: source_name.to_owned(),
                line,
                first_line,
                frame: row.frame,
                id: row.id,
            });
        }
        first_line_of.insert((row.frame, row.id), line);
        rows.push(row);
    }
    Ok(rows)
}

fn parse_fields(fields: &[&str], source_name: &str, line: usize) -> Result<MotChallengeRow> {
    if fields.len() < MIN_FIELDS {
        return Err(EvalError::TooFewFields {
            source_name: source_name.to_owned(),
            line,
            found: fields.len(),
            expected: MIN_FIELDS,
        });
    }
    if fields.len() > MAX_FIELDS {
        return Err(EvalError::TooManyFields {
            source_name: source_name.to_owned(),
            line,
            found: fields.len(),
            expected: MAX_FIELDS,
        });
    }
    let number = |k: usize| parse_finite(fields, k, source_name, line);
    let frame = parse_integer(fields, 0, source_name, line)?;
    let id = parse_integer(fields, 1, source_name, line)?;
    let (left, top) = (number(2)?, number(3)?);
    let width = non_negative(number(4)?, fields, 4, source_name, line)?;
    let height = non_negative(number(5)?, fields, 5, source_name, line)?;
    let confidence = number(6)?;
    let mut trailing = [None; 3];
    for (k, slot) in (MIN_FIELDS..fields.len()).zip(trailing.iter_mut()) {
        *slot = Some(number(k)?);
    }
    Ok(MotChallengeRow {
        frame,
        id,
        // MATLAB's 1-based pixel convention, as `motmetrics.io.load_motchallenge`.
        bbox: BoundingBox {
            left: left - 1.0,
            top: top - 1.0,
            width,
            height,
        },
        confidence,
        trailing,
        line,
    })
}

/// What is wrong with one field.
#[derive(Clone, Copy)]
enum FieldProblem {
    NonNumeric,
    NonFinite,
    NonInteger,
    Negative,
}

fn field_error(
    problem: FieldProblem,
    fields: &[&str],
    k: usize,
    source_name: &str,
    line: usize,
) -> EvalError {
    let source_name = source_name.to_owned();
    let field = FIELD_NAMES.get(k).copied().unwrap_or("?");
    let value = fields.get(k).copied().unwrap_or("").to_owned();
    match problem {
        FieldProblem::NonNumeric => EvalError::NonNumericField {
            source_name,
            line,
            field,
            value,
        },
        FieldProblem::NonFinite => EvalError::NonFiniteField {
            source_name,
            line,
            field,
            value,
        },
        FieldProblem::NonInteger => EvalError::NonIntegerField {
            source_name,
            line,
            field,
            value,
        },
        FieldProblem::Negative => EvalError::NegativeSize {
            source_name,
            line,
            field,
            value,
        },
    }
}

fn parse_finite(fields: &[&str], k: usize, source_name: &str, line: usize) -> Result<f64> {
    let text = fields.get(k).copied().unwrap_or("");
    let value: f64 = text
        .parse()
        .map_err(|_| field_error(FieldProblem::NonNumeric, fields, k, source_name, line))?;
    if value.is_finite() {
        Ok(value)
    } else {
        Err(field_error(
            FieldProblem::NonFinite,
            fields,
            k,
            source_name,
            line,
        ))
    }
}

fn parse_integer(fields: &[&str], k: usize, source_name: &str, line: usize) -> Result<i64> {
    let text = fields.get(k).copied().unwrap_or("");
    if let Ok(value) = text.parse::<i64>() {
        return Ok(value);
    }
    let value = parse_finite(fields, k, source_name, line)?;
    // Integral floats such as `12.0`, within the range where f64 -> i64 is exact.
    const EXACT: f64 = 9_007_199_254_740_992.0; // 2^53
    if value.fract() == 0.0 && value.abs() <= EXACT {
        Ok(value as i64)
    } else {
        Err(field_error(
            FieldProblem::NonInteger,
            fields,
            k,
            source_name,
            line,
        ))
    }
}

fn non_negative(
    value: f64,
    fields: &[&str],
    k: usize,
    source_name: &str,
    line: usize,
) -> Result<f64> {
    if value < 0.0 {
        Err(field_error(
            FieldProblem::Negative,
            fields,
            k,
            source_name,
            line,
        ))
    } else {
        Ok(value)
    }
}

/// How ground-truth and tracker boxes are paired.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct IouMatchConfig {
    /// Largest IoU distance `1 - IoU` at which a box pair may be matched (py-motmetrics'
    /// `distth`; the MOTChallenge benchmark uses 0.5, i.e. IoU ≥ 0.5).
    pub max_iou_distance: f64,
    /// Accumulator parameters.
    pub accumulator: MotAccumulatorConfig,
}

impl Default for IouMatchConfig {
    fn default() -> Self {
        Self {
            max_iou_distance: 0.5,
            accumulator: MotAccumulatorConfig::default(),
        }
    }
}

/// Accumulates the events of a tracker output against ground truth, frame by frame, over the
/// union of the frames of both (py-motmetrics' `compare_to_groundtruth(gt, dt, 'iou',
/// distth=max_iou_distance)`). Within a frame, ids keep the order of the input rows.
///
/// # Errors
/// [`EvalError::InvalidConfig`] if `max_iou_distance` is negative or not finite;
/// accumulator errors otherwise (none are expected for parsed rows).
pub fn compare_to_groundtruth(
    ground_truth: &[MotChallengeRow],
    hypotheses: &[MotChallengeRow],
    config: &IouMatchConfig,
) -> Result<MotAccumulator<i64>> {
    if !(config.max_iou_distance.is_finite() && config.max_iou_distance >= 0.0) {
        return Err(EvalError::InvalidConfig(format!(
            "max_iou_distance must be finite and non-negative, got {}",
            config.max_iou_distance
        )));
    }
    let mut frames: BTreeMap<i64, (Vec<&MotChallengeRow>, Vec<&MotChallengeRow>)> = BTreeMap::new();
    for row in ground_truth {
        frames.entry(row.frame).or_default().0.push(row);
    }
    for row in hypotheses {
        frames.entry(row.frame).or_default().1.push(row);
    }

    let mut acc = MotAccumulator::new(config.accumulator);
    let (mut oids, mut hids) = (Vec::new(), Vec::new());
    let (mut object_boxes, mut hypothesis_boxes) = (Vec::new(), Vec::new());
    for (&frame, (objects, hyps)) in &frames {
        oids.clear();
        oids.extend(objects.iter().map(|r| r.id));
        hids.clear();
        hids.extend(hyps.iter().map(|r| r.id));
        object_boxes.clear();
        object_boxes.extend(objects.iter().map(|r| r.bbox));
        hypothesis_boxes.clear();
        hypothesis_boxes.extend(hyps.iter().map(|r| r.bbox));
        let distances =
            iou_distance_matrix(&object_boxes, &hypothesis_boxes, config.max_iou_distance);
        acc.update(frame, &oids, &hids, &distances)?;
    }
    Ok(acc)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn comma_and_whitespace_lines_parse_alike() {
        let text =
            "1,2,10.5,20,30,40,1,-1,-1,-1\n\n1 3 11 21 31 41 0.5\n 2 , 2 , 1 , 1 , 0 , 0 , 1 \n";
        let rows = parse_motchallenge(text, "t.txt", &MotChallengeConfig::default()).unwrap();
        assert_eq!(rows.len(), 3);
        assert_eq!((rows[0].frame, rows[0].id), (1, 2));
        assert_eq!(rows[0].bbox.left, 9.5, "1-based to 0-based");
        assert_eq!(rows[0].trailing, [Some(-1.0); 3]);
        assert_eq!(rows[1].bbox.height, 41.0);
        assert_eq!(rows[1].trailing, [None; 3]);
        assert_eq!(rows[2].line, 4);
        // A byte-order mark before the first row is skipped.
        let marked = format!("\u{feff}{text}");
        let again = parse_motchallenge(&marked, "t.txt", &MotChallengeConfig::default()).unwrap();
        assert_eq!(again, rows);
    }

    #[test]
    fn low_confidence_lines_are_dropped() {
        let text = "1,1,0,0,1,1,0\n1,2,0,0,1,1,1\n";
        let config = MotChallengeConfig {
            min_confidence: 1.0,
        };
        let rows = parse_motchallenge(text, "gt.txt", &config).unwrap();
        assert_eq!(rows.iter().map(|r| r.id).collect::<Vec<_>>(), vec![2]);
    }
}
