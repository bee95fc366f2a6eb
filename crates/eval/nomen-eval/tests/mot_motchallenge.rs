//! MOTChallenge loading and IoU comparison: malformed input gives precise errors; frames and
//! boxes are handled as py-motmetrics' `mot15-2D` loader and `compare_to_groundtruth` do.

// Helpers outside #[test] functions unwrap too: a failed unwrap is a failed test.
#![allow(clippy::unwrap_used)]

use nomen_eval::EvalError;
use nomen_eval::mot::{
    IouMatchConfig, MotChallengeConfig, compare_to_groundtruth, parse_motchallenge,
};

const GOOD: &str = "1,1,10,10,20,40,1,-1,-1,-1";

fn parse_err(text: &str) -> EvalError {
    parse_motchallenge(text, "gt.txt", &MotChallengeConfig::default()).unwrap_err()
}

#[test]
fn too_few_and_too_many_fields() {
    let err = parse_err(&format!("{GOOD}\n1,2,3\n"));
    assert_eq!(
        err,
        EvalError::TooFewFields {
            source_name: "gt.txt".into(),
            line: 2,
            found: 3,
            expected: 7
        }
    );
    assert_eq!(
        err.to_string(),
        "gt.txt:2: too few fields: found 3, expected at least 7"
    );
    let err = parse_err(&format!("{GOOD},5\n"));
    assert_eq!(
        err.to_string(),
        "gt.txt:1: too many fields: found 11, expected at most 10"
    );
}

#[test]
fn non_numeric_and_empty_fields() {
    let err = parse_err("1,1,abc,10,20,40,1,-1,-1,-1\n");
    assert_eq!(
        err,
        EvalError::NonNumericField {
            source_name: "gt.txt".into(),
            line: 1,
            field: "bb_left",
            value: "abc".into()
        }
    );
    assert_eq!(
        err.to_string(),
        "gt.txt:1: field `bb_left` is not a number: \"abc\""
    );
    let err = parse_err("1,1,10,10,20,40,1,-1,,-1\n");
    assert_eq!(err.to_string(), "gt.txt:1: field `y` is not a number: \"\"");
}

#[test]
fn nan_and_infinity_are_rejected() {
    let err = parse_err("1,1,10,NaN,20,40,1,-1,-1,-1\n");
    assert_eq!(
        err.to_string(),
        "gt.txt:1: field `bb_top` is not finite: \"NaN\""
    );
    // Infinite width is reported as non-finite, not as negative.
    let err = parse_err("1,1,10,10,inf,40,1,-1,-1,-1\n");
    assert!(
        matches!(
            err,
            EvalError::NonFiniteField {
                field: "bb_width",
                ..
            }
        ),
        "{err:?}"
    );
    let err = parse_err("1,1,10,10,20,40,-inf,-1,-1,-1\n");
    assert!(
        matches!(err, EvalError::NonFiniteField { field: "conf", .. }),
        "{err:?}"
    );
}

#[test]
fn negative_sizes_are_rejected() {
    let err = parse_err("1,1,10,10,-3,40,1,-1,-1,-1\n");
    assert_eq!(
        err,
        EvalError::NegativeSize {
            source_name: "gt.txt".into(),
            line: 1,
            field: "bb_width",
            value: "-3".into()
        }
    );
    assert_eq!(
        err.to_string(),
        "gt.txt:1: field `bb_width` is negative: \"-3\""
    );
    let err = parse_err("1,1,10,10,3,-0.5,1,-1,-1,-1\n");
    assert!(
        matches!(
            err,
            EvalError::NegativeSize {
                field: "bb_height",
                ..
            }
        ),
        "{err:?}"
    );
    // Negative positions are fine (boxes partly outside the image).
    assert!(
        parse_motchallenge(
            "1,1,-10,-10,3,5,1\n",
            "gt.txt",
            &MotChallengeConfig::default()
        )
        .is_ok()
    );
}

#[test]
fn frame_and_id_must_be_integers() {
    let err = parse_err("1.5,1,10,10,20,40,1,-1,-1,-1\n");
    assert_eq!(
        err.to_string(),
        "gt.txt:1: field `frame` is not an integer: \"1.5\""
    );
    let err = parse_err("1,x,10,10,20,40,1,-1,-1,-1\n");
    assert!(
        matches!(err, EvalError::NonNumericField { field: "id", .. }),
        "{err:?}"
    );
    let rows = parse_motchallenge(
        "2.0,7.0,1,1,1,1,1\n",
        "gt.txt",
        &MotChallengeConfig::default(),
    )
    .unwrap();
    assert_eq!((rows[0].frame, rows[0].id), (2, 7));
}

#[test]
fn line_numbers_count_blank_lines_and_crlf_is_accepted() {
    let err = parse_err(&format!("{GOOD}\r\n\r\n   \n1,2,3,4\r\n"));
    assert!(
        matches!(
            err,
            EvalError::TooFewFields {
                line: 4,
                found: 4,
                ..
            }
        ),
        "{err:?}"
    );
}

#[test]
fn repeated_frame_and_id_is_rejected_unless_filtered_out() {
    let text = format!("{GOOD}\n1,2,10,10,20,40,1,-1,-1,-1\n{GOOD}\n");
    let err = parse_err(&text);
    assert_eq!(
        err.to_string(),
        "gt.txt:3: duplicate id 1 in frame 1, first seen on line 1"
    );
    // A repeated row dropped by the confidence filter does not count.
    let text = format!("{GOOD}\n1,1,10,10,20,40,0,-1,-1,-1\n");
    let config = MotChallengeConfig {
        min_confidence: 1.0,
    };
    assert_eq!(
        parse_motchallenge(&text, "gt.txt", &config).unwrap().len(),
        1
    );
}

#[test]
fn frames_of_either_file_are_evaluated() {
    let loader = MotChallengeConfig::default();
    // Frame 1: both; frame 2: ground truth only (a miss); frame 3: tracker only (a false
    // positive). Frame 1's boxes overlap with IoU 400/(2*800-400) = 1/3 < 0.5: no match.
    let gt = parse_motchallenge("1,1,0,0,20,40,1\n2,1,0,0,20,40,1\n", "gt.txt", &loader).unwrap();
    let test =
        parse_motchallenge("3,5,0,0,20,40,-1\n1,5,10,0,20,40,-1\n", "test.txt", &loader).unwrap();
    let acc = compare_to_groundtruth(&gt, &test, &IouMatchConfig::default()).unwrap();
    let m = acc.metrics().unwrap();
    assert_eq!(m.num_frames, 3);
    assert_eq!(
        (m.num_matches, m.num_misses, m.num_false_positives),
        (0, 2, 2)
    );

    // With the gate opened to IoU distance 0.7, frame 1 matches at distance 2/3.
    let config = IouMatchConfig {
        max_iou_distance: 0.7,
        ..IouMatchConfig::default()
    };
    let m = compare_to_groundtruth(&gt, &test, &config)
        .unwrap()
        .metrics()
        .unwrap();
    assert_eq!(
        (m.num_matches, m.num_misses, m.num_false_positives),
        (1, 1, 1)
    );
    assert!((m.motp - 2.0 / 3.0).abs() < 1e-12);
}

#[test]
fn invalid_gate_is_rejected() {
    let config = IouMatchConfig {
        max_iou_distance: f64::NAN,
        ..IouMatchConfig::default()
    };
    let err = compare_to_groundtruth(&[], &[], &config).unwrap_err();
    assert!(matches!(err, EvalError::InvalidConfig(_)), "{err:?}");
}
