//! Wearables that change hands mid-scene (`WearChange`): a device moved to another person
//! samples the new wearer's body, one left on a table lies still and feels gravity alone, and the
//! truth says who is whom at every frame.
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use common::data_dir;
use nomen_core::{Message, SubjectId};
use nomen_sim::{Scenario, load_scenario_clips, simulate};
use std::path::Path;

/// Ana walks a loop in front of the camera; Bo waves 2 m behind it and wears nothing of his own.
/// `{change_tag}` and `{change_imu}` are the `change` of Ana's tag and wrist IMU.
const SCENE: &str = r#"
name = "hands"
duration_s = 6.0

[[cameras]]
id = "kinect"
position_m = [4.0, 0.2, 1.6]
look_at_m = [4.0, 3.5, 1.0]

[sensors.imu.clock]
offset_s = 0.0
drift_ppm = 0.0

[[people]]
id = "ana"
subject = "s_ana"
motion = { clip = "walk_02_01", path = [[2.0, 1.5], [6.0, 1.5], [6.0, 2.5], [2.0, 2.5]] }
wears = [
  { device = "ana_tag", kind = "uwb_tag", site = "right_wrist" CHANGE_TAG },
  { device = "ana_lw", kind = "imu", site = "left_wrist" CHANGE_IMU },
]

[[people]]
id = "bo"
motion = { clip = "wave_141_16", position = [4.0, 4.5], heading_rad = -1.57 }
"#;

fn scene(change_tag: &str, change_imu: &str) -> String {
    SCENE
        .replace("CHANGE_TAG", change_tag)
        .replace("CHANGE_IMU", change_imu)
}

fn run(text: &str, seed: u64, data: &Path) -> nomen_sim::SimOutput {
    let scenario = Scenario::from_toml(text, "hands.toml").unwrap();
    let clips = load_scenario_clips(&scenario, &mut |file| {
        std::fs::read_to_string(data.join(file)).map_err(|e| e.to_string())
    })
    .unwrap();
    simulate(&scenario, &clips, seed, &mut |_, _| {}).unwrap()
}

/// Every truth skeleton's (person, time s, subject).
fn truth_subjects(truth: &[Message]) -> Vec<(String, f64, Option<SubjectId>)> {
    truth
        .iter()
        .filter_map(|m| match m {
            Message::TruthSkeleton(s) => {
                Some((s.person.clone(), s.t.as_secs_f64(), s.subject.clone()))
            }
            _ => None,
        })
        .collect()
}

#[test]
fn a_moved_tag_follows_its_new_wearer_and_the_truth_names_him() {
    let Some(data) = data_dir() else { return };
    let moved = r#", change = { kind = "moved_to", person = "bo", at_s = 3.0 }"#;
    for seed in [1, 2, 3] {
        // Both of Ana's devices go to Bo: from then on he is the one the system should name.
        let sim = run(&scene(moved, moved), seed, &data);
        let mut num_before = 0;
        let mut num_after = 0;
        for m in &sim.truth {
            if let Message::TruthTag(tag) = m {
                let t_s = tag.t.as_secs_f64();
                let from_bo =
                    ((tag.position_m.x - 4.0).powi(2) + (tag.position_m.y - 4.5).powi(2)).sqrt();
                // Bo waves in place at (4, 4.5); Ana walks 2 m away or more.
                if t_s < 2.9 {
                    assert!(
                        from_bo > 1.5,
                        "t {t_s}: {from_bo} m from Bo before the move"
                    );
                    num_before += 1;
                } else if t_s > 3.1 {
                    assert!(from_bo < 1.0, "t {t_s}: {from_bo} m from Bo after the move");
                    num_after += 1;
                }
            }
        }
        assert!(num_before > 10 && num_after > 10);
        let ana = Some(SubjectId::new("s_ana"));
        let mut seen = [false; 4];
        for (person, t_s, subject) in truth_subjects(&sim.truth) {
            let expected = match (person.as_str(), t_s < 3.0) {
                ("ana", true) | ("bo", false) => ana.clone(),
                _ => None,
            };
            assert_eq!(subject, expected, "{person} at {t_s} s");
            seen[usize::from(person == "bo") * 2 + usize::from(t_s < 3.0)] = true;
        }
        assert!(
            seen.iter().all(|s| *s),
            "both people before and after: {seen:?}"
        );
    }
}

#[test]
fn a_wearable_left_on_a_table_feels_gravity_alone_and_its_wearer_becomes_nobody() {
    let Some(data) = data_dir() else { return };
    let left = r#", change = { kind = "left_at", position_m = [6.0, 1.0, 0.75], at_s = 2.0 }"#;
    for seed in [1, 2, 3] {
        let sim = run(&scene(left, left), seed, &data);
        let (mut before, mut after) = (Vec::new(), Vec::new());
        for m in &sim.recording {
            if let Message::Imu(s) = m {
                // Clock offset and drift are 0: stamps are session times (± jitter).
                let t_s = s.t.as_secs_f64();
                if t_s < 1.9 {
                    before.push((s.accel_mps2.norm(), s.gyro_radps.unwrap().norm()));
                } else if t_s > 2.1 {
                    after.push((s.accel_mps2.norm(), s.gyro_radps.unwrap().norm()));
                }
            }
        }
        assert!(before.len() > 50 && after.len() > 100);
        let spread = |v: &[(f64, f64)]| {
            let mean = v.iter().map(|x| x.0).sum::<f64>() / v.len() as f64;
            let sd = (v.iter().map(|x| (x.0 - mean).powi(2)).sum::<f64>() / v.len() as f64).sqrt();
            (mean, sd)
        };
        let (mean_after, sd_after) = spread(&after);
        let (_, sd_before) = spread(&before);
        // Gravity plus the turn-on bias (≤ 0.063 m/s² per axis) and noise (0.027 m/s²).
        assert!((mean_after - 9.81).abs() < 0.2, "{mean_after}");
        assert!(sd_after < 0.1, "{sd_after}");
        assert!(
            sd_before > 5.0 * sd_after,
            "walking {sd_before} vs lying {sd_after}"
        );
        // Only the gyroscope's bias (≤ 8.3e-3 rad/s per axis) and noise remain.
        assert!(after.iter().all(|x| x.1 < 0.05));
        for m in &sim.truth {
            if let Message::TruthTag(tag) = m
                && tag.t.as_secs_f64() > 2.1
            {
                assert!((tag.position_m - nalgebra::Point3::new(6.0, 1.0, 0.75)).norm() < 1e-9);
            }
        }
        for (person, t_s, subject) in truth_subjects(&sim.truth) {
            let expected = (person == "ana" && t_s < 2.0).then(|| SubjectId::new("s_ana"));
            assert_eq!(subject, expected, "{person} at {t_s} s");
        }
    }
}

#[test]
fn a_person_who_keeps_one_own_device_stays_who_they_are() {
    let Some(data) = data_dir() else { return };
    let moved = r#", change = { kind = "moved_to", person = "bo", at_s = 3.0 }"#;
    let sim = run(&scene(moved, ""), 1, &data);
    for (person, _, subject) in truth_subjects(&sim.truth) {
        // Ana still wears her IMU; Bo wears a device of hers but is not her.
        let expected = (person == "ana").then(|| SubjectId::new("s_ana"));
        assert_eq!(subject, expected, "{person}");
    }
}

#[test]
fn bad_wear_changes_are_refused_naming_the_device() {
    for (change, expected) in [
        (
            r#", change = { kind = "moved_to", person = "ana", at_s = 3.0 }"#,
            "change.person 'ana' must be another person",
        ),
        (
            r#", change = { kind = "moved_to", person = "cy", at_s = 3.0 }"#,
            "change.person 'cy'",
        ),
        (
            r#", change = { kind = "left_at", position_m = [1.0, 1.0, 0.7], at_s = 6.0 }"#,
            "change.at_s must be in (0, duration_s)",
        ),
    ] {
        let err = Scenario::from_toml(&scene(change, ""), "hands.toml").unwrap_err();
        let err = err.to_string();
        assert!(err.contains("ana_tag") && err.contains(expected), "{err}");
    }
}
