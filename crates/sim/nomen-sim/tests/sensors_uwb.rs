//! UWB fixes and ranges: error statistics match the configuration.

#![allow(clippy::unwrap_used, clippy::print_stdout)]

use nalgebra::{Point3, UnitQuaternion};
use nomen_core::skeleton::Joints;
use nomen_core::{Anchor, AnchorId, Joint, TagId};
use nomen_sim::body::{BodyMotion, BodyPose, JointPose};
use nomen_sim::rng::stream;
use nomen_sim::sensors::BurstLossConfig;
use nomen_sim::sensors::uwb::{RtlsConfig, UwbRangeConfig, simulate_rtls, simulate_uwb_ranges};

/// Every joint at `p0 + v·t`.
struct Linear {
    p0: Point3<f64>,
    v: nalgebra::Vector3<f64>,
}

impl BodyMotion for Linear {
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
    fn joint_at(&self, t_s: f64, _joint: Joint) -> JointPose {
        JointPose {
            position_m: self.p0 + self.v * t_s,
            world_from_joint: UnitQuaternion::identity(),
        }
    }
}

fn still() -> Linear {
    Linear {
        p0: Point3::new(1.0, 2.0, 1.0),
        v: nalgebra::Vector3::zeros(),
    }
}

fn tag() -> TagId {
    TagId::new("tag0")
}

fn sd(v: &[f64]) -> f64 {
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

#[test]
fn fix_core_sigma_matches_the_configuration() {
    let config = RtlsConfig {
        nlos_probability: 0.0,
        jump_probability: 0.0,
        latency_s: 0.0,
        ..RtlsConfig::default()
    };
    let run = simulate_rtls(
        &still(),
        Joint::Pelvis,
        &tag(),
        (0.0, 2000.0),
        &config,
        &mut stream(1, "f"),
    )
    .unwrap();
    assert_eq!(run.fixes.len(), run.truth.len());
    for axis in 0..3 {
        let e: Vec<f64> = run
            .fixes
            .iter()
            .zip(&run.truth)
            .map(|(f, t)| {
                assert_eq!(f.t, t.t);
                f.position_m[axis] - t.position_m[axis]
            })
            .collect();
        let want = if axis == 2 { 0.30 } else { 0.15 };
        let s = sd(&e);
        assert!((s / want - 1.0).abs() < 0.03, "axis {axis}: {s}");
    }
    // Dropouts: default 1 % in bursts of 2.
    let frac = run.num_lost as f64 / (run.num_lost + run.fixes.len()) as f64;
    assert!((frac - 0.01).abs() < 0.003, "{frac}");
}

#[test]
fn nlos_outliers_and_jumps_occur_at_the_configured_rates() {
    let config = RtlsConfig {
        nlos_probability: 0.05,
        nlos_excess_mean_m: 5.0,
        jump_probability: 0.01,
        jump_min_m: 50.0,
        jump_max_m: 60.0,
        latency_s: 0.0,
        loss: BurstLossConfig::NONE,
        ..RtlsConfig::default()
    };
    let run = simulate_rtls(
        &still(),
        Joint::Pelvis,
        &tag(),
        (0.0, 5000.0),
        &config,
        &mut stream(2, "o"),
    )
    .unwrap();
    let n = run.fixes.len() as f64;
    let errs: Vec<f64> = run
        .fixes
        .iter()
        .zip(&run.truth)
        .map(|(f, t)| (f.position_m.xy() - t.position_m.xy()).norm())
        .collect();
    let jumps = errs.iter().filter(|e| **e > 40.0).count() as f64 / n;
    assert!((jumps - 0.01).abs() < 0.002, "{jumps}");
    assert!((run.num_nlos as f64 / n - 0.05).abs() < 0.004);
    // An exponential excess of mean 5 m exceeds 1 m with probability e^(-0.2) = 0.82; the
    // 0.15 m core barely changes that. A Gaussian core alone exceeds 1 m with e^(-22).
    let big = errs.iter().filter(|e| **e > 1.0 && **e < 40.0).count() as f64 / n;
    let want = 0.05 * (-0.2f64).exp() * 0.99;
    assert!((big / want - 1.0).abs() < 0.1, "{big} vs {want}");
}

#[test]
fn latency_makes_the_fix_lag_behind_the_truth() {
    let walker = Linear {
        p0: Point3::new(0.0, 0.0, 1.0),
        v: nalgebra::Vector3::new(1.2, 0.0, 0.0),
    };
    let config = RtlsConfig {
        latency_s: 0.25,
        ..RtlsConfig::noise_free()
    };
    let run = simulate_rtls(
        &walker,
        Joint::Pelvis,
        &tag(),
        (0.0, 10.0),
        &config,
        &mut stream(3, "l"),
    )
    .unwrap();
    assert!(run.fixes.len() >= 99);
    for (f, t) in run.fixes.iter().zip(&run.truth) {
        // The fix shows where the tag was 0.25 s earlier: 0.3 m behind.
        assert!((f.position_m.x - t.position_m.x + 0.3).abs() < 1e-9);
        assert!((t.position_m.x - 1.2 * t.t.as_secs_f64()).abs() < 1e-6);
    }
}

fn anchors(points: &[[f64; 3]]) -> Vec<Anchor> {
    points
        .iter()
        .enumerate()
        .map(|(i, p)| Anchor {
            id: AnchorId::new(format!("a{i}")),
            position_m: Point3::from(*p),
        })
        .collect()
}

#[test]
fn range_bias_spread_and_sigma_match_the_configuration() {
    // Tag at (1, 2, 1); anchors at 3 m (the reference range) in several directions.
    let anchors = anchors(&[
        [4.0, 2.0, 1.0],
        [-2.0, 2.0, 1.0],
        [1.0, 5.0, 1.0],
        [1.0, -1.0, 1.0],
    ]);
    let config = UwbRangeConfig {
        tail_weight: 0.0,
        ..UwbRangeConfig::default()
    };
    let run = simulate_uwb_ranges(
        &still(),
        Joint::Pelvis,
        &tag(),
        &anchors,
        (0.0, 1000.0),
        &config,
        &mut stream(4, "r"),
    )
    .unwrap();
    for (i, a) in anchors.iter().enumerate() {
        let e: Vec<f64> = run
            .ranges
            .iter()
            .zip(&run.true_range_m)
            .filter(|(r, _)| r.anchor == a.id)
            .map(|(r, d)| r.range_m - d)
            .collect();
        assert!((run.true_range_m[0] - 3.0).abs() < 1e-9);
        let mut e2 = e.clone();
        let med = median(&mut e2);
        let want = 0.17 + run.anchor_bias_m[i];
        assert!((med - want).abs() < 0.006, "anchor {i}: {med} vs {want}");
        // Core σ plus 1 cm quantisation (σ² + 0.01²/12).
        let s = sd(&e);
        assert!((s / 0.0662 - 1.0).abs() < 0.04, "anchor {i}: {s}");
    }
    // Per-anchor biases: many draws have σ 0.06 m.
    let many: Vec<f64> = (0..400)
        .flat_map(|seed| {
            simulate_uwb_ranges(
                &still(),
                Joint::Pelvis,
                &tag(),
                &anchors,
                (0.0, 0.05),
                &config,
                &mut stream(seed, "b"),
            )
            .unwrap()
            .anchor_bias_m
        })
        .collect();
    let s = sd(&many);
    assert!((s / 0.06 - 1.0).abs() < 0.06, "{s}");
}

#[test]
fn range_tail_weight_and_growth_with_range_match_the_configuration() {
    let anchors = anchors(&[[2.0, 2.0, 1.0], [9.0, 2.0, 1.0]]); // 1 m and 8 m
    let config = UwbRangeConfig {
        anchor_bias_sigma_m: 0.0,
        tail_mean_excess_m: 1.0,
        quantisation_m: 0.0,
        loss: BurstLossConfig::NONE,
        ..UwbRangeConfig::default()
    };
    let run = simulate_uwb_ranges(
        &still(),
        Joint::Pelvis,
        &tag(),
        &anchors,
        (0.0, 3000.0),
        &config,
        &mut stream(5, "t"),
    )
    .unwrap();
    let errs = |id: &str| -> Vec<f64> {
        run.ranges
            .iter()
            .zip(&run.true_range_m)
            .filter(|(r, _)| r.anchor.as_str() == id)
            .map(|(r, d)| r.range_m - d)
            .collect()
    };
    let (mut near, mut far) = (errs("a0"), errs("a1"));
    let bias_near = 0.17 + 0.015 * (1.0 - 3.0);
    // Tail: P(exp(mean 1) > 0.4) = e^-0.4; the core exceeds 0.4 m above its bias with ~1e-9.
    let tail = near.iter().filter(|e| **e - bias_near > 0.4).count() as f64 / near.len() as f64;
    let want = 0.05 * (-0.4f64).exp();
    assert!((tail / want - 1.0).abs() < 0.1, "{tail} vs {want}");
    let growth = median(&mut far) - median(&mut near);
    assert!((growth - 0.015 * 7.0).abs() < 0.004, "{growth}");
}

#[test]
fn same_seed_same_output_different_seed_different_output() {
    let sim = |seed| {
        simulate_rtls(
            &still(),
            Joint::Pelvis,
            &tag(),
            (0.0, 10.0),
            &RtlsConfig::default(),
            &mut stream(seed, "u"),
        )
        .unwrap()
    };
    assert_eq!(sim(1), sim(1));
    assert_ne!(sim(1).fixes, sim(2).fixes);
}

#[test]
fn invalid_configs_name_the_field() {
    let e = simulate_rtls(
        &still(),
        Joint::Pelvis,
        &tag(),
        (0.0, 1.0),
        &RtlsConfig {
            core_sigma_m: -0.1,
            ..RtlsConfig::default()
        },
        &mut stream(0, "x"),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("rtls.core_sigma_m"), "{e}");
    let e = RtlsConfig {
        rate_hz: 0.0,
        ..RtlsConfig::default()
    }
    .validate()
    .unwrap_err()
    .to_string();
    assert!(e.contains("rtls.rate_hz"), "{e}");
    let e = UwbRangeConfig {
        noise_sigma_m: f64::NAN,
        ..UwbRangeConfig::default()
    }
    .validate()
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("uwb_range.noise_sigma_m") && e.contains("finite"),
        "{e}"
    );
    let e = RtlsConfig {
        jump_min_m: 10.0,
        jump_max_m: 5.0,
        ..RtlsConfig::default()
    }
    .validate()
    .unwrap_err()
    .to_string();
    assert!(e.contains("rtls.jump_max_m"), "{e}");
}

#[test]
fn blocked_lines_add_the_nlos_excess_and_leave_clear_lines_untouched() {
    use nomen_sim::sensors::uwb::{BlockedLines, BlockedRangeConfig, simulate_uwb_ranges_blocked};
    // Anchor 0 is always blocked, anchor 1 never.
    let anchors = anchors(&[[4.0, 2.0, 1.0], [-2.0, 2.0, 1.0]]);
    let blocked_cfg = BlockedRangeConfig::default();
    let config = UwbRangeConfig {
        quantisation_m: 0.0,
        blocked: Some(blocked_cfg.clone()),
        ..UwbRangeConfig::default()
    };
    let clear = simulate_uwb_ranges(
        &still(),
        Joint::Pelvis,
        &tag(),
        &anchors,
        (0.0, 2000.0),
        &config,
        &mut stream(8, "r"),
    )
    .unwrap();
    let is_blocked = |_t: f64, i: usize| i == 0;
    let mut rng = stream(8, "r/blocked");
    let run = simulate_uwb_ranges_blocked(
        &still(),
        Joint::Pelvis,
        &tag(),
        &anchors,
        (0.0, 2000.0),
        &config,
        &mut stream(8, "r"),
        Some(BlockedLines {
            is_blocked: &is_blocked,
            num_anchors: anchors.len(),
            rng: &mut rng,
        }),
    )
    .unwrap();
    assert_eq!(run.ranges.len(), clear.ranges.len());
    let mut excess = Vec::new();
    for (b, c) in run.ranges.iter().zip(&clear.ranges) {
        assert_eq!((b.t, &b.anchor), (c.t, &c.anchor));
        if b.anchor.as_str() == "a1" {
            // A clear line: exactly the error it has without the blocked model.
            assert_eq!(b.range_m, c.range_m);
        } else {
            // A blocked line: never shorter, longer by the excess when NLOS.
            assert!(b.range_m >= c.range_m);
            excess.push(b.range_m - c.range_m);
        }
    }
    let n = excess.len() as f64;
    assert_eq!(run.num_blocked, excess.len());
    let nlos = excess.iter().filter(|e| **e > 0.0).count() as f64;
    let p = blocked_cfg.nlos_probability;
    assert!(
        (nlos / n - p).abs() < 4.0 * (p * (1.0 - p) / n).sqrt(),
        "{}",
        nlos / n
    );
    let mean_excess = excess.iter().sum::<f64>() / nlos;
    assert!(
        (mean_excess / blocked_cfg.excess_mean_m - 1.0).abs() < 0.05,
        "{mean_excess}"
    );
}

#[test]
fn fixes_blocked_from_most_anchors_are_outliers_at_the_configured_rate() {
    use nomen_sim::sensors::uwb::{BlockedLines, simulate_rtls_blocked};
    let config = RtlsConfig {
        blocked_nlos_probability: Some(0.4),
        loss: BurstLossConfig::NONE,
        ..RtlsConfig::default()
    };
    let rate = |blocked_anchors: usize| {
        let is_blocked = move |_t: f64, i: usize| i < blocked_anchors;
        let mut rng = stream(3, "f/blocked");
        let run = simulate_rtls_blocked(
            &still(),
            Joint::Pelvis,
            &tag(),
            (0.0, 2000.0),
            &config,
            &mut stream(3, "f"),
            Some(BlockedLines {
                is_blocked: &is_blocked,
                num_anchors: 4,
                rng: &mut rng,
            }),
        )
        .unwrap();
        (run.num_nlos as f64 / run.fixes.len() as f64, run)
    };
    let plain = simulate_rtls(
        &still(),
        Joint::Pelvis,
        &tag(),
        (0.0, 2000.0),
        &config,
        &mut stream(3, "f"),
    )
    .unwrap();
    // Two of four anchors is not most of them: the fixes are the plain ones.
    let (half, run) = rate(2);
    assert_eq!(run.fixes, plain.fixes);
    assert!((half - 0.05).abs() < 0.01, "{half}");
    // Three of four: NLOS at the blocked rate (20 000 fixes, σ 0.35 %).
    let (most, _) = rate(3);
    assert!((most - 0.4).abs() < 0.015, "{most}");
}

#[test]
fn bad_blocked_settings_are_refused_naming_the_field() {
    use nomen_sim::sensors::uwb::BlockedRangeConfig;
    let e = RtlsConfig {
        blocked_nlos_probability: Some(1.5),
        ..RtlsConfig::default()
    }
    .validate()
    .unwrap_err()
    .to_string();
    assert!(e.contains("rtls.blocked_nlos_probability"), "{e}");
    let e = UwbRangeConfig {
        blocked: Some(BlockedRangeConfig {
            excess_mean_m: f64::NAN,
            ..BlockedRangeConfig::default()
        }),
        ..UwbRangeConfig::default()
    }
    .validate()
    .unwrap_err()
    .to_string();
    assert!(e.contains("uwb_range.blocked.excess_mean_m"), "{e}");
}
