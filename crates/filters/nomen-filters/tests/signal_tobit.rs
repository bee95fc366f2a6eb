//! Tobit Kalman filter on censored measurements.

use nalgebra::{Point3, SMatrix, SVector, Vector3};
use nomen_core::SessionTime;
use nomen_filters::kalman::ConstantVelocityConfig;
use nomen_filters::tobit::{CensoringLimits, TobitJointKalman, TobitKalman};

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

#[test]
fn tobit_tracks_a_clipped_sine_better_than_a_kalman_filter_fed_the_clipped_values() {
    // x(t) = sin(ωt), 0.5 Hz, sampled at 100 Hz with σ = 0.05 noise, clipped to [-0.6, 0.6]
    // (saturated ~60 % of the time). Both filters use the same harmonic-oscillator
    // model; the "plain" one is the same filter with no censoring limits, i.e. a Kalman filter.
    let dt = 0.01;
    let omega = 2.0 * std::f64::consts::PI * 0.5;
    let (c, s) = ((omega * dt).cos(), (omega * dt).sin());
    let f = SMatrix::<f64, 2, 2>::new(c, s / omega, -omega * s, c);
    let q = SMatrix::<f64, 2, 2>::new(1e-8, 0.0, 0.0, 1e-6);
    let h = SMatrix::<f64, 1, 2>::new(1.0, 0.0);
    let sigma = 0.05;
    let r = SVector::<f64, 1>::new(sigma * sigma);
    let limit = 0.6;
    let clip = CensoringLimits {
        lower: SVector::<f64, 1>::new(-limit),
        upper: SVector::<f64, 1>::new(limit),
    };
    let x0 = SVector::<f64, 2>::new(0.0, 0.5);
    let p0 = SMatrix::<f64, 2, 2>::new(0.1, 0.0, 0.0, 1.0);
    let mut tobit = TobitKalman::<2, 1>::new(x0, p0).unwrap();
    let mut plain = TobitKalman::<2, 1>::new(x0, p0).unwrap();
    let mut noise = Noise(7);
    let (mut se_tobit, mut se_plain, mut num_clipped) = (0.0, 0.0, 0);
    let num_steps = 2000;
    for k in 1..=num_steps {
        let truth = (omega * k as f64 * dt).sin();
        let y = (truth + sigma * noise.normal()).clamp(-limit, limit);
        if y.abs() >= limit {
            num_clipped += 1;
        }
        for filter in [&mut tobit, &mut plain] {
            filter.predict(&f, &q).unwrap();
        }
        let y = SVector::<f64, 1>::new(y);
        tobit.update(&y, &h, &r, &clip).unwrap();
        plain.update(&y, &h, &r, &CensoringLimits::none()).unwrap();
        if k > 200 {
            se_tobit += (tobit.state()[0] - truth).powi(2);
            se_plain += (plain.state()[0] - truth).powi(2);
        }
    }
    let n = (num_steps - 200) as f64;
    let (rmse_tobit, rmse_plain) = ((se_tobit / n).sqrt(), (se_plain / n).sqrt());
    println!(
        "clipped {num_clipped}/{num_steps}: RMSE tobit {rmse_tobit:.4}, kalman {rmse_plain:.4}"
    );
    assert!(num_clipped > num_steps / 4);
    assert!(
        rmse_tobit < 0.5 * rmse_plain,
        "tobit {rmse_tobit} vs kalman {rmse_plain}"
    );
    assert!(rmse_tobit < 0.05, "{rmse_tobit}");
}

#[test]
fn joint_leaving_the_depth_range_keeps_moving_in_the_tobit_estimate() {
    // A hand moving away at 1 m/s; the depth camera clips z at 2.0 m and reports 2.0.
    let mut tkf = TobitJointKalman::new(ConstantVelocityConfig::default()).unwrap();
    let r = Vector3::repeat(1e-4);
    let limits = CensoringLimits {
        lower: Vector3::repeat(f64::NEG_INFINITY),
        upper: Vector3::new(f64::INFINITY, f64::INFINITY, 2.0),
    };
    let frame_ns = 33_333_333;
    let mut truth_z = 0.0;
    for i in 0..60 {
        let t = SessionTime::from_ns(i * frame_ns);
        truth_z = 1.0 + t.as_secs_f64();
        let z = Point3::new(0.0, 0.0, truth_z.min(2.0));
        tkf.step(t, Some((&z, &r, &limits))).unwrap();
    }
    // After ~1 s beyond the limit the truth is ~2.97 m; the estimate must be well past 2.0.
    let est = tkf.position().unwrap().z;
    assert!(est > 2.5, "estimate {est}, truth {truth_z}");
    assert!((tkf.velocity().unwrap().z - 1.0).abs() < 0.2);
}
