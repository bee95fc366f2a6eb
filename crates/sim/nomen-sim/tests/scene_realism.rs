//! Scene-level realism: people who leave the room and come back, per-device spread of sensor
//! noise and loss, and the validation of those fields.
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use common::data_dir;
use nomen_core::{DeviceKind, Message, TrackId};
use nomen_sim::scene::DeviceTruth;
use nomen_sim::sensors::DeviceClock;
use nomen_sim::{Scenario, SimOutput, load_scenario_clips, simulate};

fn run(text: &str, seed: u64) -> Option<SimOutput> {
    let data = data_dir()?;
    let scenario = Scenario::from_toml(text, "test.toml").unwrap();
    let clips = load_scenario_clips(&scenario, &mut |file| {
        std::fs::read_to_string(data.join(file)).map_err(|e| e.to_string())
    })
    .unwrap();
    Some(simulate(&scenario, &clips, seed, &mut |_, _| {}).unwrap())
}

/// One person waving in front of the camera (always in view) with a wrist IMU, a UWB tag and an
/// RFID tag; `MOTION_EXTRA` is replaced by extra motion fields.
const AWAY: &str = r#"
name = "away"
duration_s = 12.0

[[cameras]]
id = "kinect"
position_m = [4.0, 0.2, 1.6]
look_at_m = [4.0, 3.5, 1.0]

[[anchors]]
id = "a0"
position_m = [0.2, 0.2, 2.5]

[[anchors]]
id = "a1"
position_m = [7.8, 0.2, 2.5]

[[anchors]]
id = "a2"
position_m = [4.0, 5.8, 2.5]

[[antennas]]
id = "ant0"
position_m = [2.0, 0.5, 1.0]

[sensors.uwb_range]

[[people]]
id = "p1"
subject = "ana"
motion = { clip = "wave_141_16", position = [4.0, 2.5], heading_rad = -1.57 MOTION_EXTRA }
wears = [
  { device = "ana_lw", kind = "imu", site = "left_wrist" },
  { device = "ana_tag", kind = "uwb_tag", site = "right_wrist" },
  { device = "ana_epc", kind = "rfid_tag", site = "chest" },
]
"#;

const AWAY_FROM_S: f64 = 4.0;
const AWAY_TO_S: f64 = 7.0;

fn away(extra: &str) -> String {
    AWAY.replace("MOTION_EXTRA", extra)
}

fn is_away(t_s: f64) -> bool {
    (AWAY_FROM_S..AWAY_TO_S).contains(&t_s)
}

fn device<'a>(out: &'a SimOutput, id: &str) -> &'a DeviceTruth {
    out.scene.devices.iter().find(|d| d.device == id).unwrap()
}

fn imu_times_s(out: &SimOutput) -> Vec<i64> {
    out.recording
        .iter()
        .filter_map(|m| match m {
            Message::Imu(s) => Some(s.t.as_ns()),
            _ => None,
        })
        .collect()
}

#[test]
fn an_absent_person_has_no_truth_and_comes_back_under_a_new_track_id() {
    let Some(out) = run(&away(", absent_s = [[4.0, 7.0]]"), 3) else {
        return;
    };
    let frames: Vec<(f64, TrackId)> = out
        .truth
        .iter()
        .filter_map(|m| match m {
            Message::TruthSkeleton(t) if t.person == "p1" => Some((t.t.as_secs_f64(), t.track)),
            _ => None,
        })
        .collect();
    assert!(frames.iter().all(|(t, _)| !is_away(*t)));
    let ids = |keep: &dyn Fn(f64) -> bool| {
        let mut v: Vec<TrackId> = frames
            .iter()
            .filter(|(t, _)| keep(*t))
            .map(|x| x.1)
            .collect();
        v.sort();
        v.dedup();
        v
    };
    let before = ids(&|t| t < AWAY_FROM_S);
    let after = ids(&|t| t >= AWAY_TO_S);
    assert_eq!((before.len(), after.len()), (1, 1), "{before:?} {after:?}");
    assert_ne!(before, after);
    // Every camera frame has its truth; nothing is reported while away.
    let skeletons = out
        .recording
        .iter()
        .filter(|m| matches!(m, Message::Skeleton(s) if is_away(s.t.as_secs_f64())))
        .count();
    assert_eq!(skeletons, 0);

    // Out of coverage: no fix describes an instant away, and no range or read falls in it.
    let latency_s = out.scene.scenario.sensors.rtls.latency_s;
    for m in &out.recording {
        match m {
            Message::RtlsFix(f) => assert!(!is_away(f.t.as_secs_f64() - latency_s)),
            Message::UwbRange(r) => assert!(!is_away(r.t.as_secs_f64())),
            Message::Rssi(r) => assert!(!is_away(r.t.as_secs_f64())),
            _ => {}
        }
    }
    for m in &out.truth {
        if let Message::TruthTag(t) = m {
            assert!(!is_away(t.t.as_secs_f64() - latency_s));
        }
    }
}

#[test]
fn streaming_imus_keep_their_rate_while_away_and_silent_ones_send_nothing() {
    let Some(present) = run(&away(""), 3) else {
        return;
    };
    let stream = run(&away(", absent_s = [[4.0, 7.0]]"), 3).unwrap();
    let silent = run(
        &away(", absent_s = [[4.0, 7.0]], wearables_when_absent = \"silent\""),
        3,
    )
    .unwrap();
    // Streaming: the IMU sends exactly what it sends when the person stays.
    assert_eq!(imu_times_s(&stream), imu_times_s(&present));
    assert!(imu_times_s(&present).len() > 1000);

    // Silent: nothing taken while away (session time by the device's true clock), everything
    // else unchanged.
    let truth = device(&silent, "ana_lw");
    let clock = DeviceClock {
        offset_s: truth.clock_offset_s,
        drift_ppm: truth.clock_drift_ppm,
    };
    let session_s = |ns: &i64| clock.to_session_s(*ns as f64 * 1e-9);
    let silent_times = imu_times_s(&silent);
    assert!(silent_times.iter().all(|t| !is_away(session_s(t))));
    let expected: Vec<i64> = imu_times_s(&present)
        .into_iter()
        .filter(|t| !is_away(session_s(t)))
        .collect();
    assert_eq!(silent_times, expected);
    // About 3 s of 100 Hz samples are missing (less the 1 % lost anyway).
    let missing = imu_times_s(&present).len() - silent_times.len();
    assert!((280..=300).contains(&missing), "{missing}");
    assert_eq!(device(&silent, "ana_lw").num_messages, silent_times.len());
}

/// Four people, each with two wrist IMUs and a UWB tag.
fn spread_scene(sensors: &str) -> String {
    let mut text = format!(
        "name = \"spread\"\nduration_s = 3.0\n[[anchors]]\nid = \"a0\"\nposition_m = [0.2, 0.2, 2.5]\n{sensors}\n"
    );
    for i in 0..4 {
        text.push_str(&format!(
            r#"
[[people]]
id = "p{i}"
subject = "s{i}"
motion = {{ clip = "wave_141_16", position = [{x}, 3.0] }}
wears = [
  {{ device = "s{i}_lw", kind = "imu", site = "left_wrist" }},
  {{ device = "s{i}_rw", kind = "imu", site = "right_wrist" }},
  {{ device = "s{i}_tag", kind = "uwb_tag", site = "chest" }},
]
"#,
            x = 1.0 + 1.5 * f64::from(i)
        ));
    }
    text
}

#[test]
fn each_device_draws_its_own_noise_bias_and_loss_within_the_documented_bounds() {
    let sensors = r#"
[sensors]
noise_scale = 1.5
[sensors.imu]
device_spread = 2.0
[sensors.imu.loss]
loss_fraction_range = [0.0, 0.2]
[sensors.rtls]
device_spread = 3.0
"#;
    let Some(out) = run(&spread_scene(sensors), 5) else {
        return;
    };
    let fitted = nomen_sim::sensors::imu::ImuConfig::default();
    let mut noise = Vec::new();
    for d in &out.scene.devices {
        let n = d.noise_multiplier.unwrap();
        match d.kind {
            DeviceKind::Imu => {
                // Log-uniform in [1/2, 2], times the scene's 1.5.
                assert!((0.75..=3.0).contains(&n), "{}: {n}", d.device);
                let b = d.bias_multiplier.unwrap();
                assert!((0.75..=3.0).contains(&b), "{}: {b}", d.device);
                let loss = d.loss_fraction.unwrap();
                assert!((0.0..=0.2).contains(&loss), "{}: {loss}", d.device);
                // The drawn turn-on bias lies within the device's own bound.
                let bound = fitted.gyro_turn_on_bias_max_radps * b;
                assert!(d.gyro_bias_radps.unwrap().iter().all(|v| v.abs() <= bound));
                noise.push(n);
            }
            DeviceKind::UwbTag => {
                assert!((0.5..=4.5).contains(&n), "{}: {n}", d.device);
                assert!(d.bias_multiplier.is_none() && d.loss_fraction.is_none());
            }
            _ => unreachable!(),
        }
    }
    // Eight IMUs, eight different draws.
    noise.sort_by(f64::total_cmp);
    noise.dedup();
    assert_eq!(noise.len(), 8);

    // The same scene without spread: no draws recorded, the fitted model everywhere.
    let plain = run(&spread_scene(""), 5).unwrap();
    for d in &plain.scene.devices {
        assert!(d.noise_multiplier.is_none() && d.bias_multiplier.is_none());
        assert!(d.loss_fraction.is_none() && d.range_loss_fraction.is_none());
    }
}

#[test]
fn a_spread_of_one_gives_every_device_exactly_the_fitted_model() {
    let Some(plain) = run(&spread_scene(""), 6) else {
        return;
    };
    let explicit = run(
        &spread_scene("[sensors]\nnoise_scale = 1.0\n[sensors.imu]\ndevice_spread = 1.0\n[sensors.rtls]\ndevice_spread = 1.0"),
        6,
    )
    .unwrap();
    assert_eq!(plain.recording, explicit.recording);
    assert_eq!(plain.truth, explicit.truth);
}

#[test]
fn default_scenes_serialise_none_of_the_optional_realism_fields() {
    let text = away("");
    let scenario = Scenario::from_toml(&text, "away.toml").unwrap();
    let written = toml::to_string(&scenario).unwrap();
    for field in [
        "relabel_rate_hz",
        "absent_s",
        "wearables_when_absent",
        "device_spread",
        "noise_scale",
        "loss_fraction_range",
        "blocked",
        "avoidance",
    ] {
        assert!(!written.contains(field), "{field} in\n{written}");
    }
}

#[test]
fn bad_realism_fields_are_refused_naming_the_field() {
    let camera_with = |line: &str| {
        away("").replace(
            "look_at_m = [4.0, 3.5, 1.0]",
            &format!("look_at_m = [4.0, 3.5, 1.0]\n[cameras.tracking]\n{line}"),
        )
    };
    let sensors_with = |table: &str| {
        away("").replace(
            "[sensors.uwb_range]",
            &format!("{table}\n[sensors.uwb_range]"),
        )
    };
    let cases = [
        (
            camera_with("relabel_rate_hz = -0.5"),
            "tracking.relabel_rate_hz",
        ),
        (
            camera_with("relabel_rate_hz = nan"),
            "tracking.relabel_rate_hz",
        ),
        (away(", absent_s = [[4.0, 20.0]]"), "absent_s[0]"),
        (away(", absent_s = [[-1.0, 2.0]]"), "absent_s[0]"),
        (away(", absent_s = [[7.0, 4.0]]"), "absent_s[0]"),
        (away(", absent_s = [[nan, 4.0]]"), "absent_s[0]"),
        (away(", absent_s = [[4.0, 7.0], [6.0, 9.0]]"), "absent_s[1]"),
        (away(", absent_s = [[6.0, 9.0], [1.0, 2.0]]"), "absent_s[1]"),
        (
            away(", wearables_when_absent = \"gone\""),
            "unknown variant `gone`",
        ),
        (
            sensors_with("[sensors.imu]\ndevice_spread = 0.5"),
            "imu.device_spread",
        ),
        (
            sensors_with("[sensors.imu]\ndevice_spread = nan"),
            "imu.device_spread",
        ),
        (
            sensors_with("[sensors.rtls]\ndevice_spread = 0.9"),
            "rtls.device_spread",
        ),
        (
            sensors_with("[sensors.rssi]\ndevice_spread = 11.0"),
            "rssi.device_spread",
        ),
        (
            sensors_with("[sensors]\nnoise_scale = 0.5"),
            "sensors.noise_scale",
        ),
        (
            sensors_with("[sensors]\nnoise_scale = 3.5"),
            "sensors.noise_scale",
        ),
        (
            sensors_with("[sensors.imu.loss]\nloss_fraction_range = [0.2, 0.1]"),
            "imu.loss.loss_fraction_range[1]",
        ),
        (
            sensors_with("[sensors.rtls.loss]\nloss_fraction_range = [-0.1, 0.1]"),
            "rtls.loss.loss_fraction_range[0]",
        ),
    ];
    for (text, field) in cases {
        let err = Scenario::from_toml(&text, "bad.toml")
            .unwrap_err()
            .to_string();
        assert!(err.contains(field), "expected '{field}' in: {err}");
        assert!(err.contains("bad.toml"), "{err}");
    }
}

/// One person waving at (4, 2.5), facing the camera (−y), a UWB tag on the right wrist; anchor
/// `a0` is behind a wall, `a1` in front of the person.
const WALLED: &str = r#"
name = "walled"
duration_s = 30.0

[room]
obstacles = [{ name = "wall", centre_m = [2.0, 2.5, 1.5], size_m = [0.2, 3.0, 3.0] }]

[[anchors]]
id = "a0"
position_m = [0.2, 2.5, 1.2]

[[anchors]]
id = "a1"
position_m = [5.0, 0.2, 2.0]

[sensors.uwb_range]
BLOCKED

[[people]]
id = "p1"
subject = "ana"
motion = { clip = "wave_141_16", position = [4.0, 2.5], heading_rad = -1.57 }
wears = [{ device = "ana_tag", kind = "uwb_tag", site = "right_wrist" }]
"#;

fn ranges_to(out: &SimOutput, anchor: &str) -> Vec<(i64, f64)> {
    out.recording
        .iter()
        .filter_map(|m| match m {
            Message::UwbRange(r) if r.anchor.as_str() == anchor => Some((r.t.as_ns(), r.range_m)),
            _ => None,
        })
        .collect()
}

#[test]
fn ranges_through_a_wall_carry_the_nlos_excess_and_clear_ones_do_not() {
    let Some(off) = run(&WALLED.replace("BLOCKED", ""), 2) else {
        return;
    };
    let on = run(&WALLED.replace("BLOCKED", "[sensors.uwb_range.blocked]"), 2).unwrap();
    let excess = |anchor: &str| -> Vec<f64> {
        let (a, b) = (ranges_to(&on, anchor), ranges_to(&off, anchor));
        assert_eq!(a.len(), b.len());
        a.iter()
            .zip(&b)
            .map(|(x, y)| {
                assert_eq!(x.0, y.0);
                x.1 - y.1
            })
            .collect()
    };
    // Behind the wall: never shorter, about half the ranges (default nlos_probability 0.5)
    // longer by 0.3 m on average (default excess_mean_m).
    let walled = excess("a0");
    assert!(walled.len() > 250);
    assert!(walled.iter().all(|e| *e > -1e-9));
    let n = walled.len() as f64;
    let nlos = walled.iter().filter(|e| **e > 0.005).count() as f64 / n;
    assert!((nlos - 0.5).abs() < 0.12, "{nlos}");
    let mean = walled.iter().sum::<f64>() / n;
    assert!((mean - 0.15).abs() < 0.06, "{mean}");
    // In front of the person, in the open: (almost) no range changes.
    let clear = excess("a1");
    let changed = clear.iter().filter(|e| e.abs() > 1e-9).count() as f64 / clear.len() as f64;
    assert!(changed < 0.05, "{changed}");
}

/// Two walkers on one line in opposite directions, meeting half-way; each with a pelvis IMU.
const HEAD_ON: &str = r#"
name = "head_on"
duration_s = 8.0
AVOIDANCE

[[people]]
id = "p0"
subject = "s0"
motion = { clip = "walk_02_01", path = [[0.5, 3.0], [9.5, 3.0]] }
wears = [{ device = "s0_pelvis", kind = "imu", site = "pelvis" }]

[[people]]
id = "p1"
subject = "s1"
motion = { clip = "walk_02_01", path = [[9.5, 3.05], [0.5, 3.05]], phase_s = 0.5 }
wears = [{ device = "s1_pelvis", kind = "imu", site = "pelvis" }]
"#;

#[test]
fn walkers_on_a_collision_course_step_aside_when_avoidance_is_on() {
    use nomen_sim::body::BodyMotion;
    use nomen_sim::motion::{AvoidingMotion, ClipUse, PersonMotion, plan_avoidance};
    let Some(data) = data_dir() else { return };
    let text = HEAD_ON.replace("AVOIDANCE", "[avoidance]\nenabled = true");
    let scenario = Scenario::from_toml(&text, "head_on.toml").unwrap();
    let clips = load_scenario_clips(&scenario, &mut |file| {
        std::fs::read_to_string(data.join(file)).map_err(|e| e.to_string())
    })
    .unwrap();
    let library = scenario.clip_library();
    let motions: Vec<PersonMotion> = scenario
        .people
        .iter()
        .map(|p| {
            let def = &library[&p.motion.clip];
            let source = ClipUse {
                clip: &clips[&p.motion.clip],
                skip_frames: def.skip_frames,
                travels: Some(def.travels),
            };
            PersonMotion::new(&p.motion, source).unwrap()
        })
        .collect();
    let planned: Vec<&dyn BodyMotion> = motions.iter().map(|m| m as &dyn BodyMotion).collect();
    let shifts = plan_avoidance(&planned, 0.0, 8.0, &scenario.avoidance);
    assert!(shifts[0].is_none(), "the first person keeps their path");
    let moved: Vec<AvoidingMotion> = motions
        .iter()
        .zip(shifts)
        .map(|(m, s)| AvoidingMotion::new(m, s))
        .collect();
    let closest = |a: &dyn BodyMotion, b: &dyn BodyMotion| {
        let mut best = f64::INFINITY;
        let mut t = 0.0;
        while t <= 8.0 {
            if a.is_present_at(t) && b.is_present_at(t) {
                let (p, q) = (
                    a.joint_at(t, nomen_core::Joint::Pelvis).position_m,
                    b.joint_at(t, nomen_core::Joint::Pelvis).position_m,
                );
                best = best.min(((p.x - q.x).powi(2) + (p.y - q.y).powi(2)).sqrt());
            }
            t += 0.01;
        }
        best
    };
    let before = closest(&motions[0], &motions[1]);
    let after = closest(&moved[0], &moved[1]);
    assert!(before < 0.2, "{before}");
    assert!(after > 0.8 * scenario.avoidance.min_distance_m, "{after}");

    // In the scene: the first walker's IMU is untouched, the second's feels the side-step.
    let imu = |out: &SimOutput, device: &str| -> Vec<nomen_core::ImuSample> {
        out.recording
            .iter()
            .filter_map(|m| match m {
                Message::Imu(s) if s.device.as_str() == device => Some(s.clone()),
                _ => None,
            })
            .collect()
    };
    let on = run(&text, 1).unwrap();
    let off = run(&HEAD_ON.replace("AVOIDANCE", ""), 1).unwrap();
    assert_eq!(imu(&on, "s0_pelvis"), imu(&off, "s0_pelvis"));
    assert_ne!(imu(&on, "s1_pelvis"), imu(&off, "s1_pelvis"));
    // A side-step, not a jolt: the pelvis never reads more than 3 g.
    assert!(
        imu(&on, "s1_pelvis")
            .iter()
            .all(|s| s.accel_mps2.norm() < 3.0 * 9.81)
    );
}
