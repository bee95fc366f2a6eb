//! RSSI model: residuals, read rate, blocking and directionality match the configuration.

#![allow(clippy::unwrap_used, clippy::print_stdout)]

use nalgebra::{Point3, UnitQuaternion, Vector3};
use nomen_core::skeleton::Joints;
use nomen_core::{Antenna, AntennaId, Joint, TagId};
use nomen_sim::body::{BodyMotion, BodyPose, JointPose};
use nomen_sim::rng::stream;
use nomen_sim::sensors::rssi::{RssiConfig, RssiRun, simulate_rssi};

/// A person standing still with every joint at (0, 0, 1.3).
struct Still;

impl BodyMotion for Still {
    fn span_s(&self) -> (f64, f64) {
        (0.0, 1e6)
    }
    fn pose_at(&self, t_s: f64) -> BodyPose {
        let mut pose = Joints::new();
        for j in Joint::ALL {
            pose.insert(j, self.joint_at(t_s, j));
        }
        pose
    }
    fn joint_at(&self, _t_s: f64, _joint: Joint) -> JointPose {
        JointPose {
            position_m: Point3::new(0.0, 0.0, 1.3),
            world_from_joint: UnitQuaternion::identity(),
        }
    }
}

fn antenna(i: usize, x: f64, boresight: Option<Vector3<f64>>) -> Antenna {
    Antenna {
        id: AntennaId::new(format!("ant{i}")),
        position_m: Point3::new(x, 0.0, 1.3),
        boresight,
    }
}

fn run(antennas: &[Antenna], config: &RssiConfig, duration_s: f64, seed: u64) -> RssiRun {
    simulate_rssi(
        &Still,
        Joint::Chest,
        &TagId::new("tag"),
        antennas,
        (0.0, duration_s),
        &|_, _| 0,
        config,
        &mut stream(seed, "rssi"),
    )
    .unwrap()
}

fn values(run: &RssiRun, antenna: &str) -> Vec<f64> {
    run.reads
        .iter()
        .filter(|r| r.antenna.as_str() == antenna)
        .map(|r| r.rssi_dbm)
        .collect()
}

fn mean_sd(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    (
        m,
        (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt(),
    )
}

#[test]
fn residual_sigma_and_mean_follow_the_log_distance_model() {
    let config = RssiConfig {
        antenna_offset_sigma_db: 0.0,
        read_probability_loss_per_m2: 0.0,
        read_probability_at_0m: 1.0,
        ..RssiConfig::default()
    };
    let r = run(&[antenna(0, 4.0, None)], &config, 2000.0, 1);
    let v = values(&r, "ant0");
    let (m, s) = mean_sd(&v);
    let want = -47.0 - 20.2 * 4f64.log10();
    assert!((m - want).abs() < 0.2, "{m} vs {want}");
    // σ² = 7² + 1²/12 (integer dBm).
    assert!(
        (s / (49.0f64 + 1.0 / 12.0).sqrt() - 1.0).abs() < 0.03,
        "{s}"
    );
    assert!(
        v.iter()
            .all(|x| x.fract() == 0.0 && *x > -150.0 && *x < 30.0)
    );
    assert!(r.reads.windows(2).all(|w| w[0].t <= w[1].t));
}

#[test]
fn read_rate_falls_with_distance_as_configured() {
    let config = RssiConfig::default();
    let r = run(
        &[antenna(0, 2.0, None), antenna(1, 9.5, None)],
        &config,
        4000.0,
        2,
    );
    let polls = 40_000.0;
    for (name, d) in [("ant0", 2.0), ("ant1", 9.5)] {
        let rate = values(&r, name).len() as f64 / polls;
        let want = config.read_probability(d);
        assert!((rate - want).abs() < 0.006, "{name}: {rate} vs {want}");
    }
    // Fitted bins: 92–93 % at 1–3 m, 81.5 % at 9–10 m (the quadratic gives 92.4 %, 84.9 %).
    assert!((config.read_probability(2.0) - 0.925).abs() < 0.01);
    assert!((config.read_probability(9.5) - 0.815).abs() < 0.04);
}

#[test]
fn shadowing_is_ar1_correlated_when_asked() {
    let config = RssiConfig {
        antenna_offset_sigma_db: 0.0,
        read_probability_at_0m: 1.0,
        read_probability_loss_per_m2: 0.0,
        quantisation_db: 0.0,
        shadowing_correlation_time_s: 1.0,
        ..RssiConfig::default()
    };
    let r = run(&[antenna(0, 3.0, None)], &config, 4000.0, 3);
    let v = values(&r, "ant0");
    let (m, s) = mean_sd(&v);
    let lag1 =
        v.windows(2).map(|w| (w[0] - m) * (w[1] - m)).sum::<f64>() / ((v.len() - 1) as f64 * s * s);
    let want = (-0.1f64).exp();
    assert!((lag1 - want).abs() < 0.02, "{lag1} vs {want}");
    assert!((s / 7.0 - 1.0).abs() < 0.05, "{s}");
}

#[test]
fn each_blocking_body_attenuates_by_the_configured_amount() {
    let config = RssiConfig {
        shadowing_sigma_db: 0.0,
        quantisation_db: 0.0,
        ..RssiConfig::noise_free()
    };
    let ants = [antenna(0, 3.0, None), antenna(1, -3.0, None)];
    let r = simulate_rssi(
        &Still,
        Joint::Chest,
        &TagId::new("tag"),
        &ants,
        (0.0, 5.0),
        &|_, i| if i == 0 { 2 } else { 0 },
        &config,
        &mut stream(4, "b"),
    )
    .unwrap();
    let (a0, a1) = (values(&r, "ant0"), values(&r, "ant1"));
    assert!(!a0.is_empty() && a0.len() == a1.len());
    for (x, y) in a0.iter().zip(&a1) {
        assert!((y - x - 20.0).abs() < 1e-9);
    }
}

#[test]
fn antennas_looking_away_read_less() {
    let config = RssiConfig::noise_free();
    // Antenna 0 looks at the tag, antenna 1 (same distance) looks sideways.
    let ants = [
        antenna(0, 3.0, Some(Vector3::new(-1.0, 0.0, 0.0))),
        antenna(1, -3.0, Some(Vector3::new(0.0, 1.0, 0.0))),
    ];
    let r = run(&ants, &config, 2.0, 5);
    let (a0, a1) = (values(&r, "ant0"), values(&r, "ant1"));
    let drop = a0[0] - a1[0];
    assert!(
        (drop - 5.0 * std::f64::consts::FRAC_PI_2).abs() < 0.5 + 1e-9,
        "{drop}"
    );
}

#[test]
fn same_seed_same_output_different_seed_different_output() {
    let ants = [antenna(0, 3.0, None)];
    let c = RssiConfig::default();
    assert_eq!(run(&ants, &c, 10.0, 7), run(&ants, &c, 10.0, 7));
    assert_ne!(run(&ants, &c, 10.0, 7).reads, run(&ants, &c, 10.0, 8).reads);
}

#[test]
fn invalid_configs_name_the_field() {
    for (config, field) in [
        (
            RssiConfig {
                shadowing_sigma_db: -1.0,
                ..RssiConfig::default()
            },
            "rssi.shadowing_sigma_db",
        ),
        (
            RssiConfig {
                read_rate_hz: 0.0,
                ..RssiConfig::default()
            },
            "rssi.read_rate_hz",
        ),
        (
            RssiConfig {
                p1_dbm: f64::NAN,
                ..RssiConfig::default()
            },
            "rssi.p1_dbm",
        ),
        (
            RssiConfig {
                antenna_offsets_db: vec![0.0, f64::INFINITY],
                ..RssiConfig::default()
            },
            "rssi.antenna_offsets_db[1]",
        ),
    ] {
        let e = config.validate().unwrap_err().to_string();
        assert!(e.contains(field), "{e} should name {field}");
    }
}
