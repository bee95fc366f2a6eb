//! Constant-velocity joint Kalman filter (adskalman) and its Tobit counterpart without limits.

use nalgebra::{Matrix3, Point3, Vector3};
use nomen_core::SessionTime;
use nomen_filters::kalman::{ConstantVelocityConfig, JointKalman, UpdateOutcome};
use nomen_filters::tobit::{CensoringLimits, TobitJointKalman};

/// Deterministic standard-normal noise (SplitMix64 + Box–Muller).
struct Noise(u64);

impl Noise {
    fn uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        ((z >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
    fn normal(&mut self) -> f64 {
        let (u1, u2) = (self.uniform(), self.uniform());
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }
}

const FRAME_NS: i64 = 33_333_333;

#[test]
fn stationary_joint_converges_to_its_position() {
    let truth = Point3::new(0.4, -1.2, 1.5);
    let sigma = 0.02;
    let r = Matrix3::identity() * sigma * sigma;
    let mut noise = Noise(1);
    let mut kf = JointKalman::new(ConstantVelocityConfig {
        accel_psd_m2ps3: 0.01,
        ..Default::default()
    })
    .unwrap();
    for i in 0..300 {
        let z = truth + Vector3::new(noise.normal(), noise.normal(), noise.normal()) * sigma;
        kf.step(SessionTime::from_ns(i * FRAME_NS), Some((&z, &r)))
            .unwrap();
    }
    let err = (kf.position().unwrap() - truth).norm();
    // A single measurement is off by ~sigma·√3 = 3.5 cm; the filtered estimate must be far better.
    assert!(err < 0.005, "error {err}");
    let speed = kf.velocity().unwrap().norm();
    assert!(speed < 0.05, "speed {speed}");
}

#[test]
fn joint_walking_at_constant_velocity_has_its_velocity_recovered() {
    let v = Vector3::new(1.2, 0.3, 0.0);
    let sigma = 0.01;
    let r = Matrix3::identity() * sigma * sigma;
    let mut noise = Noise(2);
    // A smooth walk: a small acceleration density is the right model.
    let mut kf = JointKalman::new(ConstantVelocityConfig {
        accel_psd_m2ps3: 0.05,
        ..Default::default()
    })
    .unwrap();
    for i in 0..200 {
        let t = SessionTime::from_ns(i * FRAME_NS);
        let z = Point3::origin()
            + v * t.as_secs_f64()
            + Vector3::new(noise.normal(), noise.normal(), noise.normal()) * sigma;
        kf.step(t, Some((&z, &r))).unwrap();
    }
    assert!(
        (kf.velocity().unwrap() - v).norm() < 0.1,
        "{}",
        kf.velocity().unwrap()
    );
}

#[test]
fn missing_measurements_extrapolate_along_the_velocity() {
    let v = Vector3::new(1.0, 0.0, 0.0);
    let r = Matrix3::identity() * 1e-6;
    let mut kf = JointKalman::new(ConstantVelocityConfig::default()).unwrap();
    for i in 0..60 {
        let t = SessionTime::from_ns(i * FRAME_NS);
        let z = Point3::origin() + v * t.as_secs_f64();
        kf.step(t, Some((&z, &r))).unwrap();
    }
    let var_before = kf.covariance().unwrap()[(0, 0)];
    // Occluded for 10 frames: no measurement, and a NaN one (rejected as missing).
    for i in 60..70 {
        let nan = Point3::new(f64::NAN, 0.0, 0.0);
        let out = kf
            .step(SessionTime::from_ns(i * FRAME_NS), Some((&nan, &r)))
            .unwrap();
        assert_eq!(out, Some(UpdateOutcome::RejectedAsMissing));
    }
    let expected_x = 69.0 * FRAME_NS as f64 * 1e-9;
    assert!((kf.position().unwrap().x - expected_x).abs() < 0.01);
    assert!(
        kf.covariance().unwrap()[(0, 0)] > var_before,
        "uncertainty grows while occluded"
    );
}

#[test]
fn inferred_joint_with_larger_noise_moves_the_estimate_less() {
    let mut tracked = JointKalman::new(ConstantVelocityConfig::default()).unwrap();
    let mut inferred = tracked.clone();
    let r_tracked = Matrix3::identity() * 0.01f64.powi(2);
    let r_inferred = Matrix3::identity() * 0.10f64.powi(2);
    for kf in [&mut tracked, &mut inferred] {
        for i in 0..30 {
            kf.step(
                SessionTime::from_ns(i * FRAME_NS),
                Some((&Point3::origin(), &r_tracked)),
            )
            .unwrap();
        }
    }
    let jump = Point3::new(0.2, 0.0, 0.0);
    let t = SessionTime::from_ns(30 * FRAME_NS);
    tracked.step(t, Some((&jump, &r_tracked))).unwrap();
    inferred.step(t, Some((&jump, &r_inferred))).unwrap();
    assert!(tracked.position().unwrap().x > 2.0 * inferred.position().unwrap().x);
}

#[test]
fn tobit_filter_without_censoring_limits_is_the_kalman_filter() {
    let config = ConstantVelocityConfig::default();
    let mut kf = JointKalman::new(config).unwrap();
    let mut tkf = TobitJointKalman::new(config).unwrap();
    let r_diag = Vector3::new(1e-4, 2e-4, 4e-4);
    let r = Matrix3::from_diagonal(&r_diag);
    let limits = CensoringLimits::none();
    let mut noise = Noise(3);
    for i in 0..100 {
        let t = SessionTime::from_ns(i * FRAME_NS + (i % 3) * 1_000_000);
        let z = Point3::new(
            (i as f64 * 0.1).sin(),
            noise.normal() * 0.01,
            1.0 + 0.01 * i as f64,
        );
        kf.step(t, Some((&z, &r))).unwrap();
        tkf.step(t, Some((&z, &r_diag, &limits))).unwrap();
    }
    let d = (kf.position().unwrap() - tkf.position().unwrap()).norm()
        + (kf.velocity().unwrap() - tkf.velocity().unwrap()).norm();
    assert!(d < 1e-9, "{d}");
}
