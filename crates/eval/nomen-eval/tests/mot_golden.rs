//! nomen-eval's MOT metrics against golden values from py-motmetrics 1.4.0.
//!
//! The fixtures in `tests/fixtures/` were produced by `tests/fixtures/make_mot_golden.py`
//! (its header gives the pip versions and the command):
//! - `mot_golden.json`: TUD-Campus and TUD-Stadtmitte (from py-motmetrics' own test data,
//!   read here from `/work/shared/data/mot`), evaluated with
//!   `compare_to_groundtruth(gt, test, 'iou', distth=0.5)`;
//! - `mot_accumulator_cases.json`: seeded random and adversarial accumulator inputs with
//!   py-motmetrics' full event lists and metrics.

// Helpers outside #[test] functions unwrap too: a failed unwrap is a failed test.
#![allow(clippy::unwrap_used)]

use std::path::{Path, PathBuf};

use nomen_eval::EvalError;
use nomen_eval::mot::{
    IouMatchConfig, MotAccumulator, MotAccumulatorConfig, MotChallengeConfig, MotEvent,
    MotEventKind, MotMetrics, compare_to_groundtruth, parse_motchallenge,
};
use serde_json::Value;

const FLOAT_TOLERANCE: f64 = 1e-9;

fn fixture(name: &str) -> Value {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name);
    let text = std::fs::read_to_string(&path).unwrap();
    serde_json::from_str(&text).unwrap()
}

fn data_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../../shared/data/mot")
}

/// A golden float: a number, or "nan"/"inf"/"-inf".
fn golden_float(v: &Value) -> f64 {
    match v {
        Value::String(s) => s.parse().unwrap(),
        _ => v.as_f64().unwrap(),
    }
}

/// Compares every metric of `golden` (integers exactly, floats to `FLOAT_TOLERANCE`, NaN to
/// NaN) and checks `ours` has no metric py-motmetrics lacks.
fn assert_metrics_match(label: &str, ours: &MotMetrics, golden: &Value) {
    let ours = serde_json::to_value(ours).unwrap();
    let ours = ours.as_object().unwrap();
    let golden = golden.as_object().unwrap();
    assert_eq!(
        ours.keys().collect::<Vec<_>>().len(),
        golden.len(),
        "{label}: metric sets differ: ours {:?}, golden {:?}",
        ours.keys().collect::<Vec<_>>(),
        golden.keys().collect::<Vec<_>>()
    );
    for (name, expected) in golden {
        let actual = ours
            .get(name)
            .unwrap_or_else(|| panic!("{label}: missing {name}"));
        if let Some(expected) = expected.as_u64() {
            assert_eq!(actual.as_u64(), Some(expected), "{label}: {name}");
        } else {
            let expected = golden_float(expected);
            // serde_json writes non-finite floats as null.
            let actual = actual.as_f64().unwrap_or(f64::NAN);
            if expected.is_finite() {
                assert!(
                    (actual - expected).abs() <= FLOAT_TOLERANCE,
                    "{label}: {name}: ours {actual}, py-motmetrics {expected}"
                );
            } else {
                assert!(
                    !actual.is_finite(),
                    "{label}: {name}: ours {actual}, py-motmetrics {expected}"
                );
            }
        }
    }
}

#[test]
fn tud_sequences_match_py_motmetrics() {
    let golden = fixture("mot_golden.json");
    let data = data_dir();
    if !data.is_dir() {
        eprintln!("skipping: MOT data directory {} not found", data.display());
        return;
    }
    for (sequence, expected) in golden["sequences"].as_object().unwrap() {
        let gt_path = data.join(sequence).join("gt.txt");
        let test_path = data.join(sequence).join("test.txt");
        let (Ok(gt_text), Ok(test_text)) = (
            std::fs::read_to_string(&gt_path),
            std::fs::read_to_string(&test_path),
        ) else {
            eprintln!(
                "skipping {sequence}: {} or {} not found",
                gt_path.display(),
                test_path.display()
            );
            continue;
        };
        let loader = MotChallengeConfig::default();
        let gt = parse_motchallenge(&gt_text, &gt_path.display().to_string(), &loader).unwrap();
        let test =
            parse_motchallenge(&test_text, &test_path.display().to_string(), &loader).unwrap();
        let acc = compare_to_groundtruth(&gt, &test, &IouMatchConfig::default()).unwrap();
        let metrics = acc.metrics().unwrap();
        assert_metrics_match(sequence, &metrics, &expected["metrics"]);
        assert_eq!(
            acc.mot_events().count() as u64,
            expected["num_events"].as_u64().unwrap(),
            "{sequence}: number of non-RAW events"
        );
        eprintln!(
            "{sequence}: idf1 {:.6} mota {:.6} motp {:.6} switches {}",
            metrics.idf1, metrics.mota, metrics.motp, metrics.num_switches
        );
    }
}

fn kind_from_py(name: &str) -> MotEventKind {
    serde_json::from_value(Value::String(name.to_owned())).unwrap()
}

fn opt_f64(v: &Value) -> f64 {
    v.as_f64().unwrap_or(f64::NAN)
}

#[test]
fn accumulator_cases_match_py_motmetrics_event_for_event() {
    let fixture = fixture("mot_accumulator_cases.json");
    let cases = fixture["cases"].as_array().unwrap();
    assert!(cases.len() >= 20, "fixture has {} cases", cases.len());
    for case in cases {
        let name = case["name"].as_str().unwrap();
        let config = MotAccumulatorConfig {
            max_switch_time: case["max_switch_time"].as_u64(),
        };
        let mut acc = MotAccumulator::<i64>::new(config);
        let mut rejected = false;
        for frame in case["frames"].as_array().unwrap() {
            let ids = |key: &str| -> Vec<i64> {
                frame[key]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|v| v.as_i64().unwrap())
                    .collect()
            };
            let distances: Vec<f64> = frame["dists"]
                .as_array()
                .unwrap()
                .iter()
                .flat_map(|row| row.as_array().unwrap().iter().map(opt_f64))
                .collect();
            let result = acc.update(
                frame["frame"].as_i64().unwrap(),
                &ids("oids"),
                &ids("hids"),
                &distances,
            );
            if name == "duplicate_ids" {
                // py-motmetrics accepts repeated ids in a frame and reports idf1 = 1.6 here;
                // we reject them, as MOTChallenge's devkit and TrackEval do.
                assert!(
                    matches!(result, Err(EvalError::DuplicateId { .. })),
                    "{result:?}"
                );
                assert!(acc.events().is_empty());
                rejected = true;
                break;
            }
            result.unwrap();
        }
        if rejected {
            continue;
        }

        let expected: Vec<MotEvent<i64>> = case["events"]
            .as_array()
            .unwrap()
            .iter()
            .map(|e| MotEvent {
                frame: e[0].as_i64().unwrap(),
                kind: kind_from_py(e[1].as_str().unwrap()),
                oid: e[2].as_i64(),
                hid: e[3].as_i64(),
                distance: e[4].as_f64(),
            })
            .collect();
        let actual = acc.events();
        for (k, (a, e)) in actual.iter().zip(&expected).enumerate() {
            assert_eq!(a, e, "{name}: event {k}");
        }
        assert_eq!(actual.len(), expected.len(), "{name}: number of events");

        assert_metrics_match(name, &acc.metrics().unwrap(), &case["metrics"]);
    }
}
