//! Whole scenes: the shipped scenario library parses, bad scenarios are refused with clear
//! errors, and simulation is deterministic by seed.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use nomen_core::Message;
use nomen_sim::{Scenario, SimError, load_scenario_clips, simulate};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../..")
}

fn data_dir() -> Option<PathBuf> {
    let dir = repo().join("../shared/data");
    if dir.join("mocap/cmu/02_01.bvh").is_file() {
        Some(dir)
    } else {
        eprintln!("skipping: shared data not found at {}", dir.display());
        None
    }
}

fn clips_for(scenario: &Scenario, data: &Path) -> BTreeMap<String, nomen_mocap::MocapClip> {
    load_scenario_clips(scenario, &mut |file| {
        std::fs::read_to_string(data.join(file)).map_err(|e| e.to_string())
    })
    .unwrap()
}

const SMALL: &str = r#"
name = "small"
duration_s = 4.0

[[cameras]]
id = "kinect"
position_m = [4.0, 0.2, 1.6]
look_at_m = [4.0, 3.5, 1.0]

[[antennas]]
id = "ant0"
position_m = [2.0, 0.5, 1.0]
boresight = [0.0, 1.0, 0.0]

[[anchors]]
id = "a0"
position_m = [0.2, 0.2, 2.5]

[[anchors]]
id = "a1"
position_m = [7.8, 0.2, 2.5]

[sensors.uwb_range]

[[people]]
id = "p1"
subject = "ana"
motion = { clip = "walk_02_01", path = [[3.0, 2.2], [5.0, 2.2], [5.0, 3.4]] }
wears = [
  { device = "ana_lw", kind = "imu", site = "left_wrist" },
  { device = "ana_tag", kind = "uwb_tag", site = "right_wrist" },
  { device = "ana_epc", kind = "rfid_tag", site = "chest" },
]

[[people]]
id = "p2"
motion = { clip = "wave_141_16", position = [4.0, 3.0], heading_rad = -1.57 }
"#;

#[test]
fn every_shipped_scenario_parses_and_validates() {
    let dir = repo().join("scenarios");
    let mut n = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "toml") {
            let text = std::fs::read_to_string(&path).unwrap();
            let s = Scenario::from_toml(&text, &path.display().to_string())
                .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            assert!(!s.people.is_empty(), "{}", path.display());
            n += 1;
        }
    }
    // 2/3/4/5/8 people × wrist/BAN, 3 Belmonte episodes, 3 UWB, crosswalk, hospital room.
    assert!(n >= 18, "only {n} scenarios in {}", dir.display());
}

#[test]
fn bad_scenarios_are_refused_naming_the_problem() {
    let cases = [
        (
            SMALL.replace("duration_s = 4.0", "duration_s = -1.0"),
            "duration_s",
        ),
        (
            SMALL.replace("walk_02_01", "walk_nowhere"),
            "unknown clip 'walk_nowhere'",
        ),
        (
            SMALL.replace(r#"id = "p2""#, r#"id = "p1""#),
            "person 'p1' is listed twice",
        ),
        (
            SMALL.replace(r#"subject = "ana""#, ""),
            "wears devices but has no subject",
        ),
        (
            SMALL.replace(r#""ana_tag""#, r#""ana_lw""#),
            "device 'ana_lw' is worn twice",
        ),
        (
            SMALL.replace("duration_s = 4.0", "duration_s = 4.0\ncolour = \"red\""),
            "unknown field",
        ),
        (
            SMALL.replace(r#"site = "chest""#, r#"site = "tail""#),
            "tail",
        ),
    ];
    for (text, expected) in cases {
        let err = Scenario::from_toml(&text, "bad.toml")
            .unwrap_err()
            .to_string();
        assert!(err.contains(expected), "expected '{expected}' in: {err}");
        // Every error names the file, the checks after parsing as well as the parser's.
        assert!(err.contains("bad.toml"), "{err}");
    }
}

#[test]
fn same_seed_gives_identical_scenes_and_another_seed_does_not() {
    let Some(data) = data_dir() else { return };
    let scenario = Scenario::from_toml(SMALL, "small.toml").unwrap();
    let clips = clips_for(&scenario, &data);
    let run = |seed| simulate(&scenario, &clips, seed, &mut |_, _| {}).unwrap();
    let (a, b, c) = (run(7), run(7), run(8));
    assert_eq!(a.recording, b.recording);
    assert_eq!(a.truth, b.truth);
    assert_ne!(a.recording, c.recording);

    let count = |kind: &str| a.recording.iter().filter(|m| m.type_name() == kind).count();
    // Every modality of the scene produced data.
    for kind in ["skeleton", "imu", "rtls_fix", "uwb_range", "rssi"] {
        assert!(count(kind) > 0, "no {kind} messages");
    }
    // Each skeleton has its truth, and the intruder's truth carries no subject.
    let truths: Vec<_> = a
        .truth
        .iter()
        .filter_map(|m| match m {
            Message::TruthSkeleton(t) => Some(t),
            _ => None,
        })
        .collect();
    assert_eq!(truths.len(), count("skeleton"));
    assert!(
        truths
            .iter()
            .any(|t| t.person == "p2" && t.subject.is_none())
    );
    assert!(
        truths
            .iter()
            .any(|t| t.person == "p1" && t.subject.as_ref().is_some_and(|s| s.as_str() == "ana"))
    );
    // Every message is valid by the data model's own rules.
    for m in a.recording.iter().chain(&a.truth) {
        m.validate().unwrap();
    }
    // The registry names the wearer, and the scene description the drawn clock offset.
    assert!(
        a.scene
            .registry
            .wearer(&nomen_core::DeviceId::new("ana_lw"))
            .is_some()
    );
    let imu = a
        .scene
        .devices
        .iter()
        .find(|d| d.device == "ana_lw")
        .unwrap();
    assert!(imu.clock_offset_s.abs() <= 0.5);
}

#[test]
fn a_sensor_pair_read_along_one_chain_equals_the_whole_body_pose() {
    use nomen_core::Joint;
    use nomen_sim::body::BodyMotion;
    use nomen_sim::motion::{ClipUse, MotionSpec, PersonMotion};
    let Some(data) = data_dir() else { return };
    let scenario = Scenario::from_toml(SMALL, "small.toml").unwrap();
    let clips = clips_for(&scenario, &data);
    let mut spec = MotionSpec::new("walk_02_01");
    spec.mirror = true;
    let motion = PersonMotion::new(&spec, ClipUse::new(&clips["walk_02_01"])).unwrap();
    for (a, b) in [
        (Joint::LeftWrist, Joint::LeftElbow),
        (Joint::LeftElbow, Joint::LeftWrist),
        (Joint::RightAnkle, Joint::RightKnee),
        (Joint::Head, Joint::LeftHand),
    ] {
        for t in [0.3, 1.234, 2.9] {
            let pose = motion.pose_at(t);
            let (pa, pb) = motion.joint_pair_at(t, a, b);
            for (p, j) in [(pa, a), (pb, b)] {
                let q = pose.get(j).unwrap();
                assert!((p.position_m - q.position_m).norm() < 1e-12, "{j} at {t}");
                assert!(
                    p.world_from_joint.angle_to(&q.world_from_joint) < 1e-9,
                    "{j} at {t}"
                );
            }
        }
    }
}

#[test]
fn every_shipped_scenario_fits_in_memory_and_an_hour_of_eight_people_is_refused() {
    use nomen_sim::scene::{CameraBytes, MAX_SCENE_MESSAGE_BYTES, wearable_message_bytes};
    let path = repo().join("scenarios/imu_ban_8_long.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let mut scenario = Scenario::from_toml(&text, "imu_ban_8_long.toml").unwrap();
    let largest_camera = |s: &Scenario| {
        s.cameras
            .iter()
            .map(|c| CameraBytes::estimate(s, c.fps_hz))
            .fold(0.0, f64::max)
    };
    // The largest shipped scene (8 people, full networks, 180 s) is within the bound ...
    let max = MAX_SCENE_MESSAGE_BYTES as f64;
    assert!(largest_camera(&scenario) < max && wearable_message_bytes(&scenario) < max);
    // ... and the same people for an hour are refused before anything is simulated (the clips
    // are not even loaded), with the longest duration that fits.
    scenario.duration_s = 3600.0;
    let err = simulate(&scenario, &BTreeMap::new(), 1, &mut |_, _| {}).unwrap_err();
    let SimError::TooLarge { max_duration_s, .. } = &err else {
        panic!("{err}");
    };
    let every_camera: f64 = scenario
        .cameras
        .iter()
        .map(|c| CameraBytes::estimate(&scenario, c.fps_hz))
        .sum();
    let fits = max / (every_camera + wearable_message_bytes(&scenario)) * 3600.0;
    assert_eq!(*max_duration_s, fits.floor());
    assert!(*max_duration_s >= 180.0, "{err}");
    assert!(
        err.to_string()
            .contains("more than the 2048 MiB a simulated scene may hold"),
        "{err}"
    );
}
