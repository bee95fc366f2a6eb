//! Madgwick and Mahony against the Python `ahrs` 0.4.0 package, sample by sample.
//!
//! The fixture `fixtures/ahrs_golden.json` holds a synthetic 1000-sample IMU/MARG recording
//! (100 Hz, smooth rotation, seeded noise, one zero accelerometer and one zero magnetometer
//! sample) and the quaternions `ahrs.filters.Madgwick.updateIMU/updateMARG` and
//! `ahrs.filters.Mahony.updateIMU/updateMARG` return for it. Regenerate with
//! `python3 crates/filters/nomen-filters/tests/fixtures/make_ahrs_golden.py` (versions in its
//! header).

// Test code: a malformed fixture should fail loudly.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use nomen_filters::orientation::{Madgwick, MadgwickConfig, Mahony, MahonyConfig};
use serde_json::Value;

/// Largest allowed difference per quaternion component.
const TOLERANCE: f64 = 1e-9;

struct Golden {
    dt_s: f64,
    q0: UnitQuaternion<f64>,
    madgwick: MadgwickConfig,
    mahony: MahonyConfig,
    gyro: Vec<Vector3<f64>>,
    accel: Vec<Vector3<f64>>,
    mag: Vec<Vector3<f64>>,
    fixture: Value,
}

fn f64_at(v: &Value, key: &str) -> f64 {
    v[key]
        .as_f64()
        .unwrap_or_else(|| panic!("fixture: '{key}' is not a number"))
}

fn floats(v: &Value) -> Vec<f64> {
    v.as_array()
        .expect("fixture: expected an array")
        .iter()
        .map(|x| x.as_f64().expect("fixture: expected a number"))
        .collect()
}

fn vectors(v: &Value) -> Vec<Vector3<f64>> {
    v.as_array()
        .expect("fixture: expected an array of rows")
        .iter()
        .map(|row| Vector3::from_column_slice(&floats(row)))
        .collect()
}

fn load() -> Golden {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/fixtures/ahrs_golden.json"
    );
    let text = std::fs::read_to_string(path).expect("read ahrs_golden.json");
    let fixture: Value = serde_json::from_str(&text).expect("parse ahrs_golden.json");
    let q0 = floats(&fixture["q0_wxyz"]);
    Golden {
        dt_s: f64_at(&fixture, "dt_s"),
        q0: UnitQuaternion::new_normalize(Quaternion::new(q0[0], q0[1], q0[2], q0[3])),
        madgwick: MadgwickConfig {
            gain_imu: f64_at(&fixture, "madgwick_gain_imu"),
            gain_marg: f64_at(&fixture, "madgwick_gain_marg"),
        },
        mahony: MahonyConfig {
            k_p: f64_at(&fixture, "mahony_k_p"),
            k_i: f64_at(&fixture, "mahony_k_i"),
        },
        gyro: vectors(&fixture["gyro_radps"]),
        accel: vectors(&fixture["accel_mps2"]),
        mag: vectors(&fixture["mag_ut"]),
        fixture,
    }
}

/// Runs `step` over every sample and returns the largest component difference to the
/// reference quaternions stored under `key`.
fn max_abs_diff(
    golden: &Golden,
    key: &str,
    mut step: impl FnMut(usize) -> UnitQuaternion<f64>,
) -> f64 {
    let reference = golden.fixture["quaternions_wxyz"][key]
        .as_array()
        .unwrap_or_else(|| panic!("fixture: no quaternions for {key}"));
    assert_eq!(reference.len(), golden.gyro.len());
    let mut worst = 0.0_f64;
    for (t, expected) in reference.iter().enumerate() {
        let q = step(t);
        let got = [q.w, q.i, q.j, q.k];
        for (g, e) in got.iter().zip(floats(expected)) {
            worst = worst.max((g - e).abs());
        }
    }
    eprintln!(
        "{key}: max |Δq| = {worst:.3e} over {} samples",
        reference.len()
    );
    worst
}

#[test]
fn madgwick_imu_matches_ahrs() {
    let g = load();
    let mut f = Madgwick::new(g.madgwick, g.q0).unwrap();
    let d = max_abs_diff(&g, "madgwick_imu", |t| {
        f.update_imu(&g.gyro[t], &g.accel[t], g.dt_s)
    });
    assert!(d < TOLERANCE, "max difference {d:e}");
}

#[test]
fn madgwick_marg_matches_ahrs() {
    let g = load();
    let mut f = Madgwick::new(g.madgwick, g.q0).unwrap();
    let d = max_abs_diff(&g, "madgwick_marg", |t| {
        f.update(&g.gyro[t], &g.accel[t], &g.mag[t], g.dt_s)
    });
    assert!(d < TOLERANCE, "max difference {d:e}");
}

#[test]
fn mahony_imu_matches_ahrs() {
    let g = load();
    let mut f = Mahony::new(g.mahony, g.q0).unwrap();
    let d = max_abs_diff(&g, "mahony_imu", |t| {
        f.update_imu(&g.gyro[t], &g.accel[t], g.dt_s)
    });
    assert!(d < TOLERANCE, "max difference {d:e}");
}

#[test]
fn mahony_marg_matches_ahrs() {
    let g = load();
    let mut f = Mahony::new(g.mahony, g.q0).unwrap();
    let d = max_abs_diff(&g, "mahony_marg", |t| {
        f.update(&g.gyro[t], &g.accel[t], &g.mag[t], g.dt_s)
    });
    assert!(d < TOLERANCE, "max difference {d:e}");
}
