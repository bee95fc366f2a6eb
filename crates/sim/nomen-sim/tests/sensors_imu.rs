//! IMU model: physical facts that could fail.

#![allow(clippy::unwrap_used, clippy::print_stdout)]

use nalgebra::{Point3, UnitQuaternion, Vector3};
use nomen_core::skeleton::Joints;
use nomen_core::{DeviceId, ImuSample, Joint};
use nomen_sim::body::{BodyMotion, BodyPose, GRAVITY_MPS2, JointPose, Mount, gravity_world};
use nomen_sim::rng::stream;
use nomen_sim::sensors::imu::{ImuConfig, MagnetometerConfig, simulate_imu};
use nomen_sim::sensors::{BurstLossConfig, ClockConfig};

/// Every joint moves the same way, given by a closure of time.
struct Analytic<F: Fn(f64) -> JointPose + Send + Sync>(F);

impl<F: Fn(f64) -> JointPose + Send + Sync> BodyMotion for Analytic<F> {
    fn span_s(&self) -> (f64, f64) {
        (0.0, 1e6)
    }
    fn pose_at(&self, t_s: f64) -> BodyPose {
        let mut pose = Joints::new();
        for j in Joint::ALL {
            pose.insert(j, (self.0)(t_s));
        }
        pose
    }
    fn joint_at(&self, t_s: f64, _joint: Joint) -> JointPose {
        (self.0)(t_s)
    }
}

fn still() -> Analytic<impl Fn(f64) -> JointPose + Send + Sync> {
    Analytic(|_t| JointPose {
        position_m: Point3::new(1.0, 2.0, 1.2),
        world_from_joint: UnitQuaternion::from_euler_angles(0.3, -0.2, 1.0),
    })
}

/// Yaw at 0.8 rad/s with a nodding roll 0.4·sin(1.3 t), walking a circle of 1.5 m at 1.2 rad/s.
fn wobbling_circle() -> Analytic<impl Fn(f64) -> JointPose + Send + Sync> {
    Analytic(|t: f64| JointPose {
        position_m: Point3::new(
            1.5 * (1.2 * t).cos(),
            1.5 * (1.2 * t).sin(),
            1.0 + 0.05 * (3.0 * t).sin(),
        ),
        world_from_joint: UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.8 * t)
            * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), 0.4 * (1.3 * t).sin()),
    })
}

fn wrist() -> Mount {
    Mount::at(Joint::LeftWrist, UnitQuaternion::identity())
}

fn dev() -> DeviceId {
    DeviceId::new("imu0")
}

fn mean_sd(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0);
    (m, var.sqrt())
}

#[test]
fn still_imu_reads_one_g_and_no_rotation_with_the_configured_noise() {
    let config = ImuConfig {
        gyro_turn_on_bias_max_radps: 0.0,
        accel_turn_on_bias_max_mps2: 0.0,
        loss: BurstLossConfig::NONE,
        ..ImuConfig::default()
    };
    let run = simulate_imu(
        &still(),
        &dev(),
        &wrist(),
        (0.0, 60.0),
        &config,
        &mut stream(1, "imu"),
    )
    .unwrap();
    assert!(run.samples.len() >= 5990, "{}", run.samples.len());
    let norms: Vec<f64> = run.samples.iter().map(|s| s.accel_mps2.norm()).collect();
    let (m, _) = mean_sd(&norms);
    assert!((m - GRAVITY_MPS2).abs() < 0.005, "{m}");
    for axis in 0..3 {
        let g: Vec<f64> = run
            .samples
            .iter()
            .map(|s| s.gyro_radps.unwrap()[axis])
            .collect();
        let (gm, gs) = mean_sd(&g);
        assert!(gm.abs() < 4.0 * config.gyro_sigma_radps() / (g.len() as f64).sqrt());
        assert!(
            (gs / config.gyro_sigma_radps() - 1.0).abs() < 0.04,
            "gyro {axis}: {gs}"
        );
        let a: Vec<f64> = run.samples.iter().map(|s| s.accel_mps2[axis]).collect();
        let (_, as_) = mean_sd(&a);
        assert!(
            (as_ / config.accel_sigma_mps2() - 1.0).abs() < 0.04,
            "accel {axis}: {as_}"
        );
    }
    // The default σ at 100 Hz is BROAD's density × 10: 1.02e-3 rad/s, 2.7e-2 m/s².
    assert!((config.gyro_sigma_radps() - 1.02e-3).abs() < 1e-12);
}

#[test]
fn turn_on_bias_is_constant_and_within_the_configured_bound() {
    let config = ImuConfig {
        gyro_noise_density_radps_per_sqrt_hz: 0.0,
        loss: BurstLossConfig::NONE,
        ..ImuConfig::default()
    };
    let run = simulate_imu(
        &still(),
        &dev(),
        &wrist(),
        (0.0, 5.0),
        &config,
        &mut stream(2, "b"),
    )
    .unwrap();
    let b = run.truth.gyro_bias_radps;
    assert!(b.amax() <= 8.3e-3 && b.norm() > 0.0);
    for s in &run.samples {
        assert!((s.gyro_radps.unwrap() - b).norm() < 1e-9);
    }
}

#[test]
fn noise_free_gyro_integrates_to_the_true_orientation_over_ten_seconds() {
    let config = ImuConfig {
        mount_max_angle_rad: 1.0,
        ..ImuConfig::noise_free()
    };
    let motion = wobbling_circle();
    let run = simulate_imu(
        &motion,
        &dev(),
        &wrist(),
        (0.0, 10.0),
        &config,
        &mut stream(3, "g"),
    )
    .unwrap();
    let truth_q = |t: f64| {
        motion.joint_at(t, Joint::LeftElbow).world_from_joint * run.truth.mount.segment_from_sensor
    };
    let s = &run.samples;
    let mut q = truth_q(s[0].t.as_secs_f64());
    for w in s.windows(2) {
        let dt = w[1].t.secs_since(w[0].t);
        // Trapezoidal rate, body-frame increment on the right (second-order accurate).
        let omega = 0.5 * (w[0].gyro_radps.unwrap() + w[1].gyro_radps.unwrap());
        q *= UnitQuaternion::from_scaled_axis(omega * dt);
    }
    let last = s.last().unwrap();
    let err = q.angle_to(&truth_q(last.t.as_secs_f64()));
    assert!(last.t.as_secs_f64() > 9.98);
    assert!(err < 1e-3, "orientation error {err} rad");
}

#[test]
fn specific_force_plus_gravity_is_the_second_derivative_of_position() {
    let config = ImuConfig {
        mount_max_angle_rad: 0.7,
        ..ImuConfig::noise_free()
    };
    let motion = wobbling_circle();
    let run = simulate_imu(
        &motion,
        &dev(),
        &wrist(),
        (0.0, 3.0),
        &config,
        &mut stream(4, "a"),
    )
    .unwrap();
    // Independent: five-point stencil with a 10 ms step (the simulator uses 2.5 ms, 3 points).
    let h = 0.01;
    let p = |t: f64| motion.joint_at(t, Joint::LeftWrist).position_m.coords;
    for s in run.samples.iter().step_by(7) {
        let t = s.t.as_secs_f64();
        let a = (-p(t + 2.0 * h) + 16.0 * p(t + h) - 30.0 * p(t) + 16.0 * p(t - h)
            - p(t - 2.0 * h))
            / (12.0 * h * h);
        let world_from_sensor = motion.joint_at(t, Joint::LeftElbow).world_from_joint
            * run.truth.mount.segment_from_sensor;
        let a_sim = world_from_sensor * s.accel_mps2 + gravity_world();
        assert!((a_sim - a).norm() < 1e-4, "t {t}: {a_sim} vs {a}");
    }
}

/// A motion that exists only during `(2, 8)` s and holds its pose outside, as a person who
/// enters and leaves the scene does.
struct Bounded<M: BodyMotion>(M);

impl<M: BodyMotion> BodyMotion for Bounded<M> {
    fn span_s(&self) -> (f64, f64) {
        (2.0, 8.0)
    }
    fn pose_at(&self, t_s: f64) -> BodyPose {
        self.0.pose_at(t_s.clamp(2.0, 8.0))
    }
    fn joint_at(&self, t_s: f64, joint: Joint) -> JointPose {
        self.0.joint_at(t_s.clamp(2.0, 8.0), joint)
    }
}

#[test]
fn the_first_and_last_samples_of_a_span_read_the_motion_not_a_shock() {
    let motion = Bounded(wobbling_circle());
    let run = simulate_imu(
        &motion,
        &dev(),
        &wrist(),
        motion.span_s(),
        &ImuConfig::noise_free(),
        &mut stream(4, "a"),
    )
    .unwrap();
    let (first, last) = (run.samples.first().unwrap(), run.samples.last().unwrap());
    // The circle's centripetal acceleration is 1.5 · 1.2² ≈ 2.2 m/s² and the bob's 0.45 m/s²,
    // so a reading stays within 3 m/s² of 1 g; a difference across an end of the span would
    // read the 1.8 m/s walking speed as a jump of hundreds of m/s².
    for s in [first, last] {
        let g = s.accel_mps2.norm();
        assert!(
            (g - GRAVITY_MPS2).abs() < 3.0,
            "t {}: |a| {g}",
            s.t.as_secs_f64()
        );
    }
    assert!((first.accel_mps2 - run.samples[1].accel_mps2).norm() < 0.5);
    assert!((last.accel_mps2 - run.samples[run.samples.len() - 2].accel_mps2).norm() < 0.5);
}

#[test]
fn mounting_rotation_rotates_the_readings() {
    let motion = wobbling_circle();
    let aligned = simulate_imu(
        &motion,
        &dev(),
        &wrist(),
        (0.0, 2.0),
        &ImuConfig::noise_free(),
        &mut stream(5, "m"),
    )
    .unwrap();
    let config = ImuConfig {
        mount_max_angle_rad: 1.5,
        ..ImuConfig::noise_free()
    };
    let turned = simulate_imu(
        &motion,
        &dev(),
        &wrist(),
        (0.0, 2.0),
        &config,
        &mut stream(5, "m"),
    )
    .unwrap();
    let r = turned.truth.mount.segment_from_sensor;
    assert!(r.angle() > 0.05, "{}", r.angle());
    assert_eq!(aligned.samples.len(), turned.samples.len());
    let mut max_diff: f64 = 0.0;
    for (a, b) in aligned.samples.iter().zip(&turned.samples) {
        assert_eq!(a.t, b.t);
        assert!((r.inverse() * a.gyro_radps.unwrap() - b.gyro_radps.unwrap()).norm() < 1e-9);
        assert!((r.inverse() * a.accel_mps2 - b.accel_mps2).norm() < 1e-9);
        max_diff = max_diff.max((a.accel_mps2 - b.accel_mps2).norm());
    }
    assert!(max_diff > 0.5, "{max_diff}");
}

#[test]
fn clock_offset_and_drift_shift_the_timestamps() {
    // Yaw = t²/2 about the world Z with no mount rotation: the gyro z reads the true time.
    let motion = Analytic(|t: f64| JointPose {
        position_m: Point3::origin(),
        world_from_joint: UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.5 * t * t),
    });
    let config = ImuConfig {
        clock: ClockConfig {
            offset_s: Some(0.3),
            drift_ppm: Some(100.0),
            ..ClockConfig::PERFECT
        },
        ..ImuConfig::noise_free()
    };
    let run = simulate_imu(
        &motion,
        &dev(),
        &wrist(),
        (1.0, 11.0),
        &config,
        &mut stream(6, "c"),
    )
    .unwrap();
    assert_eq!(run.truth.clock.offset_s, 0.3);
    let model = run.truth.clock.model();
    for s in &run.samples {
        let stamp = s.t.as_secs_f64();
        let true_t = s.gyro_radps.unwrap().z;
        // session = device·(1 + 1e-4) + 0.3
        assert!(
            (true_t - (stamp * (1.0 + 1e-4) + 0.3)).abs() < 1e-6,
            "{stamp} {true_t}"
        );
        assert!((model.to_session(s.t.as_ns()).as_secs_f64() - true_t).abs() < 1e-6);
        // Device ticks are on its own 10 ms grid.
        assert!((stamp * 100.0 - (stamp * 100.0).round()).abs() < 1e-6);
    }
    // Drawn offsets stay within ±max.
    for seed in 0..20 {
        let r = simulate_imu(
            &still(),
            &dev(),
            &wrist(),
            (0.0, 0.2),
            &ImuConfig::default(),
            &mut stream(seed, "c"),
        )
        .unwrap();
        assert!(r.truth.clock.offset_s.abs() <= 0.5 && r.truth.clock.drift_ppm.abs() <= 50.0);
    }
}

#[test]
fn packet_loss_matches_the_configured_rate_and_burst_length() {
    let config = ImuConfig {
        rate_hz: 50.0,
        loss: BurstLossConfig::bursts(0.08, 5.0),
        ..ImuConfig::noise_free()
    };
    let run = simulate_imu(
        &still(),
        &dev(),
        &wrist(),
        (0.0, 4000.0),
        &config,
        &mut stream(7, "l"),
    )
    .unwrap();
    let expected = 4000 * 50 + 1;
    let received = run.samples.len();
    assert_eq!(received + run.truth.num_lost, expected);
    let (mut lost, mut bursts) = (0i64, 0usize);
    for w in run.samples.windows(2) {
        let missing = ((w[1].t - w[0].t) as f64 / 2e7).round() as i64 - 1;
        if missing > 0 {
            lost += missing;
            bursts += 1;
        }
    }
    let frac = run.truth.num_lost as f64 / expected as f64;
    let burst = lost as f64 / bursts as f64;
    assert!((frac - 0.08).abs() < 0.008, "{frac}");
    assert!((burst - 5.0).abs() < 0.4, "{burst}");
}

#[test]
fn timestamps_strictly_increase_with_jitter_and_loss() {
    let run = simulate_imu(
        &wobbling_circle(),
        &dev(),
        &wrist(),
        (0.0, 30.0),
        &ImuConfig {
            timestamp_jitter_s: 0.004,
            ..ImuConfig::default()
        },
        &mut stream(8, "j"),
    )
    .unwrap();
    assert!(run.samples.windows(2).all(|w| w[0].t < w[1].t));
    assert!(run.samples.iter().all(|s| s.validate().is_ok()));
}

#[test]
fn magnetometer_reads_the_world_field_in_the_sensor_frame() {
    let mag = MagnetometerConfig {
        disturbance_amplitude_ut: 0.0,
        noise_ut: 0.0,
        ..MagnetometerConfig::default()
    };
    let config = ImuConfig {
        magnetometer: Some(mag.clone()),
        ..ImuConfig::noise_free()
    };
    let motion = still();
    let run = simulate_imu(
        &motion,
        &dev(),
        &wrist(),
        (0.0, 1.0),
        &config,
        &mut stream(9, "mag"),
    )
    .unwrap();
    let q = motion.joint_at(0.0, Joint::LeftElbow).world_from_joint;
    let want = q.inverse() * Vector3::from(mag.earth_field_world_ut);
    for s in &run.samples {
        let m = s.mag_ut.unwrap();
        assert!((m - want).norm() < 1e-9);
        assert!((m.norm() - 47.84).abs() < 0.1);
    }
}

fn gyro_x(samples: &[ImuSample]) -> Vec<f64> {
    samples.iter().map(|s| s.gyro_radps.unwrap().x).collect()
}

#[test]
fn same_seed_same_output_different_seed_different_output() {
    let sim = |seed| {
        simulate_imu(
            &wobbling_circle(),
            &dev(),
            &wrist(),
            (0.0, 5.0),
            &ImuConfig::default(),
            &mut stream(seed, "imu/x"),
        )
        .unwrap()
    };
    let (a, b, c) = (sim(10), sim(10), sim(11));
    assert_eq!(a.samples, b.samples);
    assert_eq!(a.truth, b.truth);
    assert_ne!(gyro_x(&a.samples), gyro_x(&c.samples));
}

#[test]
fn invalid_configs_name_the_field() {
    let cases: Vec<(ImuConfig, &str)> = vec![
        (
            ImuConfig {
                rate_hz: 0.0,
                ..ImuConfig::default()
            },
            "imu.rate_hz",
        ),
        (
            ImuConfig {
                gyro_noise_density_radps_per_sqrt_hz: -1e-4,
                ..ImuConfig::default()
            },
            "imu.gyro_noise_density_radps_per_sqrt_hz",
        ),
        (
            ImuConfig {
                accel_turn_on_bias_max_mps2: f64::NAN,
                ..ImuConfig::default()
            },
            "imu.accel_turn_on_bias_max_mps2",
        ),
        (
            ImuConfig {
                accel_range_mps2: 0.0,
                ..ImuConfig::default()
            },
            "imu.accel_range_mps2",
        ),
        (
            ImuConfig {
                gyro_range_radps: f64::INFINITY,
                ..ImuConfig::default()
            },
            "imu.gyro_range_radps",
        ),
        (
            ImuConfig {
                loss: BurstLossConfig::bursts(0.1, 0.5),
                ..ImuConfig::default()
            },
            "imu.loss.mean_burst_len",
        ),
        (
            ImuConfig {
                clock: ClockConfig {
                    max_offset_s: -1.0,
                    ..ClockConfig::default()
                },
                ..ImuConfig::default()
            },
            "imu.clock.max_offset_s",
        ),
    ];
    for (config, field) in cases {
        let e = simulate_imu(
            &still(),
            &dev(),
            &wrist(),
            (0.0, 1.0),
            &config,
            &mut stream(0, "x"),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains(field), "{e} should name {field}");
    }
    let e = simulate_imu(
        &still(),
        &dev(),
        &wrist(),
        (2.0, 1.0),
        &ImuConfig::default(),
        &mut stream(0, "x"),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("span"), "{e}");
}

/// Throughput: 8 people × 5 IMUs × 100 Hz × 60 s. Run with
/// `cargo test -p nomen-sim --release --test sensors_imu -- --ignored --nocapture`.
#[test]
#[ignore]
fn throughput_of_forty_imus_for_a_minute() {
    let motion = wobbling_circle();
    let config = ImuConfig::default();
    let mut rng = stream(1, "bench");
    let mut out = Vec::new();
    let start = std::time::Instant::now();
    for i in 0..40 {
        let id = DeviceId::new(format!("imu{i}"));
        nomen_sim::sensors::imu::simulate_imu_into(
            &motion,
            &id,
            &wrist(),
            (0.0, 60.0),
            &config,
            &mut rng,
            &mut out,
        )
        .unwrap();
    }
    let el = start.elapsed();
    println!("{} samples in {:.1} ms", out.len(), el.as_secs_f64() * 1e3);
}

#[test]
fn readings_saturate_exactly_at_the_full_scale_range_and_are_counted() {
    // A fast spin: 1 m circle at 15 rad/s (225 m/s² centripetal) while turning at 40 rad/s.
    let motion = Analytic(|t: f64| JointPose {
        position_m: Point3::new((15.0 * t).cos(), (15.0 * t).sin(), 1.0),
        world_from_joint: UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 40.0 * t)
            * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), 0.7 * (3.0 * t).sin()),
    });
    let sim = |config: &ImuConfig| {
        simulate_imu(
            &motion,
            &dev(),
            &wrist(),
            (0.0, 2.0),
            config,
            &mut stream(12, "sat"),
        )
        .unwrap()
    };
    let wide = sim(&ImuConfig {
        accel_range_mps2: 2000.0,
        gyro_range_radps: 200.0,
        ..ImuConfig::noise_free()
    });
    assert_eq!(wide.truth.num_accel_saturated, 0);
    assert_eq!(wide.truth.num_gyro_saturated, 0);
    let config = ImuConfig::noise_free();
    // Defaults: ±16 g and ±2000 °/s.
    assert!((config.accel_range_mps2 - 156.9064).abs() < 1e-3);
    assert!((config.gyro_range_radps - 34.9066).abs() < 1e-3);
    let run = sim(&config);
    assert_eq!(run.samples.len(), wide.samples.len());
    let (mut want_accel, mut want_gyro) = (0, 0);
    for (ideal, got) in wide.samples.iter().zip(&run.samples) {
        let (ra, rg) = (config.accel_range_mps2, config.gyro_range_radps);
        for axis in 0..3 {
            assert_eq!(got.accel_mps2[axis], ideal.accel_mps2[axis].clamp(-ra, ra));
            assert_eq!(
                got.gyro_radps.unwrap()[axis],
                ideal.gyro_radps.unwrap()[axis].clamp(-rg, rg)
            );
        }
        assert!(got.accel_mps2.amax() <= ra && got.gyro_radps.unwrap().amax() <= rg);
        want_accel += usize::from(ideal.accel_mps2.amax() > ra);
        want_gyro += usize::from(ideal.gyro_radps.unwrap().amax() > rg);
    }
    eprintln!(
        "{} samples: {want_accel} with the accelerometer saturated, {want_gyro} the gyroscope",
        run.samples.len()
    );
    assert!(want_accel > 50 && want_gyro > 50);
    assert_eq!(run.truth.num_accel_saturated, want_accel);
    assert_eq!(run.truth.num_gyro_saturated, want_gyro);
}
