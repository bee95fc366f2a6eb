//! Accelerometer-only and slow IMUs (`gyro = false`, `rate_hz` on a worn device): their samples
//! carry no angular rate, come at their own rate, and their accelerations are those of the same
//! device with a gyroscope.
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use common::data_dir;
use nomen_core::{ImuSample, Message};
use nomen_sim::{Scenario, load_scenario_clips, simulate};
use std::path::Path;

const SCENE: &str = r#"
name = "watches"
duration_s = 5.0

[[cameras]]
id = "kinect"
position_m = [4.0, 0.2, 1.6]
look_at_m = [4.0, 3.5, 1.0]

[[people]]
id = "ana"
subject = "s_ana"
motion = { clip = "walk_02_01", path = [[2.0, 1.5], [6.0, 1.5], [6.0, 2.5], [2.0, 2.5]] }
wears = [{ device = "ana_lw", kind = "imu", site = "left_wrist" WATCH }]
"#;

fn samples(watch: &str, seed: u64, data: &Path) -> Vec<ImuSample> {
    let text = SCENE.replace("WATCH", watch);
    let scenario = Scenario::from_toml(&text, "watches.toml").unwrap();
    let clips = load_scenario_clips(&scenario, &mut |file| {
        std::fs::read_to_string(data.join(file)).map_err(|e| e.to_string())
    })
    .unwrap();
    let sim = simulate(&scenario, &clips, seed, &mut |_, _| {}).unwrap();
    sim.recording
        .into_iter()
        .filter_map(|m| match m {
            Message::Imu(s) => Some(s),
            _ => None,
        })
        .collect()
}

#[test]
fn a_watch_without_gyroscope_sends_the_same_accelerations_and_no_angular_rate() {
    let Some(data) = data_dir() else {
        return;
    };
    for seed in [1, 2] {
        let full = samples("", seed, &data);
        let bare = samples(", gyro = false", seed, &data);
        assert!(full.iter().all(|s| s.gyro_radps.is_some()));
        assert!(bare.iter().all(|s| s.gyro_radps.is_none()));
        assert_eq!(full.len(), bare.len());
        for (a, b) in full.iter().zip(&bare) {
            assert_eq!((a.t, a.accel_mps2), (b.t, b.accel_mps2));
        }
    }
}

#[test]
fn a_watch_at_12_5_hz_samples_every_80_ms() {
    let Some(data) = data_dir() else {
        return;
    };
    let slow = samples(", gyro = false, rate_hz = 12.5", 3, &data);
    // Five seconds at 12.5 Hz, less the 1 % lost in bursts.
    assert!((55..=63).contains(&slow.len()), "{}", slow.len());
    let mut dts: Vec<f64> = slow.windows(2).map(|w| w[1].t.secs_since(w[0].t)).collect();
    dts.sort_by(f64::total_cmp);
    let median = dts[dts.len() / 2];
    assert!((median - 0.08).abs() < 0.002, "median interval {median} s");
}

#[test]
fn gyro_and_rate_are_for_imus_and_rates_below_10_hz_are_refused() {
    let tag = SCENE.replace(
        r#"{ device = "ana_lw", kind = "imu", site = "left_wrist" WATCH }"#,
        r#"{ device = "ana_tag", kind = "uwb_tag", site = "chest", gyro = false }"#,
    );
    let err = Scenario::from_toml(&tag, "t.toml").unwrap_err().to_string();
    assert!(err.contains("gyro and rate_hz are for IMUs only"), "{err}");
    let slow = SCENE.replace("WATCH", ", rate_hz = 4.0");
    let err = Scenario::from_toml(&slow, "t.toml")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("rate_hz must be in 10..=300 Hz, got 4"),
        "{err}"
    );
}
