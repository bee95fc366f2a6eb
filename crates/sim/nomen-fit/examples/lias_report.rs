//! Prints the LIAS position-error report: TWR multilateration (raw) and the tag Kalman filter,
//! static and dynamic, with no bias correction, a constant bias and per-anchor biases (biases
//! estimated on the dynamic `mid` run with its mocap truth, so that row is in-sample).
//!
//! `cargo run -p nomen-fit --example lias_report [DATA_DIR]` (default `$NOMEN_DATA`, else
//! `../shared/data`).

#![allow(clippy::print_stdout)]

use nomen_fit::dataset::static_world_from_body;
use nomen_fit::load::{UwbCsvFormat, parse_mocap_csv, parse_uwb_csv};
use nomen_fit::rtls_lias::{
    BiasMode, evaluate_recording, range_truths, render_report, tag_in_world,
};
use nomen_fit::uwb::{UwbSetup, check_quat_convention, interpolate_pose, range_errors_mocap};
use nomen_rtls::multilat::{MultilaterationConfig, estimate_range_bias};
use nomen_rtls::track::TagFilterConfig;
use std::path::PathBuf;

/// The static poses of `Static/README.md` (2022-08-14): file, yaw (°), x, y (m).
const STATIC: [(&str, f64, f64, f64); 3] = [
    (
        "UWB_static_exp_8_14_pos1_deg_0.csv",
        -0.019,
        -1.9298,
        -1.2368,
    ),
    (
        "UWB_static_exp_8_14_pos3_deg_120.csv",
        121.417,
        1.7556,
        1.2200,
    ),
    (
        "UWB_static_exp_8_14_pos5_deg_0.csv",
        0.233,
        -0.0475,
        -0.0122,
    ),
];

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let data = std::env::args()
        .nth(1)
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("NOMEN_DATA").map(PathBuf::from))
        .unwrap_or_else(|| {
            PathBuf::from(concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/../../../../shared/data"
            ))
        });
    let lias = data.join("uwb/lias");
    if !lias.exists() {
        println!("skipping: {} is absent", lias.display());
        return Ok(());
    }
    let setup = UwbSetup::lias_2022_08_14();
    let format = UwbCsvFormat::lias();
    let read = |p: PathBuf| std::fs::read_to_string(&p).map(|t| (t, p.display().to_string()));
    let load = |speed: &str| -> Result<_, Box<dyn std::error::Error>> {
        let (u, un) = read(lias.join(format!("Dynamic/UWB_dynamic_exp_{speed}.csv")))?;
        let (m, mn) = read(lias.join(format!("Dynamic/motion_capture_dynamic_exp_{speed}.csv")))?;
        Ok((parse_uwb_csv(&u, &un, &format)?, parse_mocap_csv(&m, &mn)?))
    };
    let (fast_uwb, fast_mocap) = load("fast")?;
    let (mid_uwb, mid_mocap) = load("mid")?;
    let convention = check_quat_convention(&fast_uwb, &fast_mocap, &setup, 0.05)?.chosen;
    let bias = estimate_range_bias(
        &range_truths(&range_errors_mocap(
            &mid_uwb, &mid_mocap, &setup, convention, 0.05,
        )?),
        setup.anchors_m.len(),
    )?;
    println!(
        "range bias from the mid run: constant {:+.3} m, per anchor {:?}",
        bias.constant_m,
        bias.per_anchor_m
            .iter()
            .map(|b| format!("{b:+.3}"))
            .collect::<Vec<_>>()
    );
    let config = MultilaterationConfig::default();
    let filter = TagFilterConfig::default();
    let modes = [BiasMode::None, BiasMode::Constant, BiasMode::PerAnchor];
    let mut rows = Vec::new();
    for (uwb, mocap, is_mid) in [
        (&fast_uwb, &fast_mocap, false),
        (&mid_uwb, &mid_mocap, true),
    ] {
        let truth = |t: f64, tag: usize| {
            interpolate_pose(mocap, convention, t, 0.05).and_then(|p| tag_in_world(&setup, &p, tag))
        };
        for mode in modes {
            rows.push(evaluate_recording(
                uwb, &setup, &truth, &bias, mode, true, is_mid, &config, &filter,
            )?);
        }
    }
    let body_z: Vec<f64> = fast_mocap.rows.iter().map(|r| r.position_m.z).collect();
    let body_z_m = {
        let mut z = body_z.clone();
        z.sort_by(f64::total_cmp);
        z[z.len() / 2]
    };
    for (file, yaw_deg, x, y) in STATIC {
        let (u, un) = read(lias.join("Static/8.14").join(file))?;
        let uwb = parse_uwb_csv(&u, &un, &format)?;
        let pose = static_world_from_body(yaw_deg.to_radians(), x, y, body_z_m);
        let truth = |_: f64, tag: usize| tag_in_world(&setup, &pose, tag);
        for mode in modes {
            rows.push(evaluate_recording(
                &uwb, &setup, &truth, &bias, mode, false, false, &config, &filter,
            )?);
        }
    }
    print!("{}", render_report(&rows));
    Ok(())
}
