//! Multilateration on a real UWB recording (LIAS, `../shared/data/uwb/lias`): the horizontal
//! error against motion-capture truth must stay where `examples/lias_report.rs` measured it.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use nomen_fit::load::{UwbCsvFormat, parse_mocap_csv, parse_uwb_csv};
use nomen_fit::rtls_lias::{BiasMode, evaluate_recording, range_truths, tag_in_world};
use nomen_fit::uwb::{UwbSetup, check_quat_convention, interpolate_pose, range_errors_mocap};
use nomen_rtls::multilat::{MultilaterationConfig, estimate_range_bias};
use nomen_rtls::track::TagFilterConfig;
use std::path::{Path, PathBuf};

/// Every how many UWB rows one is kept (the files hold ~40 000 (row, tag) solves each; a tenth
/// keeps the test quick in the dev profile and the figure within a few millimetres).
const ROW_STEP: usize = 10;

fn lias_dir() -> Option<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../../shared/data/uwb/lias");
    if dir.join("Dynamic/UWB_dynamic_exp_fast.csv").is_file() {
        Some(dir)
    } else {
        eprintln!("skipping: LIAS data not found at {}", dir.display());
        None
    }
}

#[test]
fn per_anchor_bias_keeps_the_fast_walk_within_nine_centimetres() {
    let Some(lias) = lias_dir() else { return };
    let setup = UwbSetup::lias_2022_08_14();
    let format = UwbCsvFormat::lias();
    let load = |speed: &str| {
        let read = |name: String| {
            let path = lias.join("Dynamic").join(name);
            (
                std::fs::read_to_string(&path).unwrap(),
                path.display().to_string(),
            )
        };
        let (u, un) = read(format!("UWB_dynamic_exp_{speed}.csv"));
        let (m, mn) = read(format!("motion_capture_dynamic_exp_{speed}.csv"));
        let mut uwb = parse_uwb_csv(&u, &un, &format).unwrap();
        uwb.rows = uwb.rows.into_iter().step_by(ROW_STEP).collect();
        (uwb, parse_mocap_csv(&m, &mn).unwrap())
    };
    let (fast_uwb, fast_mocap) = load("fast");
    let (mid_uwb, mid_mocap) = load("mid");
    let convention = check_quat_convention(&fast_uwb, &fast_mocap, &setup, 0.05)
        .unwrap()
        .chosen;
    // The biases come from the other (mid-speed) walk, so the fast walk is out of sample.
    let bias = estimate_range_bias(
        &range_truths(&range_errors_mocap(&mid_uwb, &mid_mocap, &setup, convention, 0.05).unwrap()),
        setup.anchors_m.len(),
    )
    .unwrap();
    let truth = |t: f64, tag: usize| {
        interpolate_pose(&fast_mocap, convention, t, 0.05)
            .and_then(|p| tag_in_world(&setup, &p, tag))
    };
    let rmse = |mode: BiasMode| {
        let row = evaluate_recording(
            &fast_uwb,
            &setup,
            &truth,
            &bias,
            mode,
            true,
            false,
            &MultilaterationConfig::default(),
            &TagFilterConfig::default(),
        )
        .unwrap();
        let raw = row.raw.expect("estimates with truth");
        assert!(
            raw.num > 2000,
            "only {} estimates had truth ({} unsolved)",
            raw.num,
            row.num_unsolved
        );
        raw.rmse_m
    };
    // Measured on every row: 21.5 cm without bias removal, 6.3 cm with per-anchor biases.
    let per_anchor = rmse(BiasMode::PerAnchor);
    assert!(per_anchor < 0.09, "per-anchor-bias RMSE {per_anchor} m");
    let none = rmse(BiasMode::None);
    eprintln!(
        "fast walk, every {ROW_STEP}th row: horizontal RMSE {:.1} cm without bias removal, {:.1} cm with per-anchor biases",
        100.0 * none,
        100.0 * per_anchor
    );
    assert!(
        none > 2.0 * per_anchor,
        "bias removal should matter: {none} m without, {per_anchor} m with"
    );
}
