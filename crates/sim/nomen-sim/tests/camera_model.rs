//! The simulated body-tracking camera against hand-built scenes: occlusion, noise, frames,
//! field of view, track ids, swaps, flips, determinism.

// Helpers outside `#[test]` functions unwrap too: a failed unwrap is a failed test.
#![allow(clippy::unwrap_used)]

use approx::assert_relative_eq;
use nalgebra::{Point3, UnitQuaternion, Vector3};
use nomen_core::skeleton::{Joint, Joints};
use nomen_core::{JointState, SkeletonObservation, SubjectId, TrackId};
use nomen_sim::body::{BodyMotion, BodyPose, JointPose};
use nomen_sim::camera::{CameraModel, CameraModelConfig, CameraOutput, PersonInScene};
use nomen_sim::geometry::BoxObstacle;
use nomen_sim::rng::stream;

type Path = Box<dyn Fn(f64) -> [f64; 2] + Send + Sync>;

/// A rigid standing figure (1.75 m adult, arms down or left arm held out sideways) moving its
/// feet point along `path`, facing `yaw_rad` (0 = facing +X; its left is then +Y).
struct Figure {
    path: Path,
    yaw_rad: f64,
    is_left_arm_out: bool,
    span_s: (f64, f64),
    /// Spans `[from, to)` during which the figure is out of the room.
    absent_s: Vec<[f64; 2]>,
}

impl Figure {
    fn standing(x: f64, y: f64, yaw_rad: f64) -> Self {
        Self {
            path: Box::new(move |_| [x, y]),
            yaw_rad,
            is_left_arm_out: false,
            span_s: (0.0, 1e4),
            absent_s: Vec::new(),
        }
    }

    fn moving(path: impl Fn(f64) -> [f64; 2] + Send + Sync + 'static, yaw_rad: f64) -> Self {
        Self {
            path: Box::new(path),
            yaw_rad,
            is_left_arm_out: false,
            span_s: (0.0, 1e4),
            absent_s: Vec::new(),
        }
    }

    /// Offsets in the figure's frame (x forward, y left, z up), m.
    fn offset(&self, j: Joint) -> [f64; 3] {
        use Joint::*;
        let arm_out = self.is_left_arm_out;
        let left = |o: [f64; 3]| o;
        let right = |o: [f64; 3]| [o[0], -o[1], o[2]];
        match j {
            Pelvis => [0.0, 0.0, 0.95],
            Chest => [0.0, 0.0, 1.25],
            Neck => [0.0, 0.0, 1.50],
            Head => [0.0, 0.0, 1.65],
            LeftShoulder => left([0.0, 0.19, 1.45]),
            LeftElbow if arm_out => [0.0, 0.47, 1.45],
            LeftWrist if arm_out => [0.0, 0.72, 1.45],
            LeftHand if arm_out => [0.0, 0.80, 1.45],
            LeftElbow => left([0.0, 0.22, 1.17]),
            LeftWrist => left([0.0, 0.24, 0.92]),
            LeftHand => left([0.0, 0.25, 0.84]),
            RightShoulder => right([0.0, 0.19, 1.45]),
            RightElbow => right([0.0, 0.22, 1.17]),
            RightWrist => right([0.0, 0.24, 0.92]),
            RightHand => right([0.0, 0.25, 0.84]),
            LeftHip => left([0.0, 0.09, 0.92]),
            LeftKnee => left([0.0, 0.10, 0.50]),
            LeftAnkle => left([0.0, 0.10, 0.08]),
            LeftFoot => left([0.12, 0.10, 0.02]),
            RightHip => right([0.0, 0.09, 0.92]),
            RightKnee => right([0.0, 0.10, 0.50]),
            RightAnkle => right([0.0, 0.10, 0.08]),
            RightFoot => right([0.12, 0.10, 0.02]),
        }
    }
}

impl BodyMotion for Figure {
    fn span_s(&self) -> (f64, f64) {
        self.span_s
    }
    fn is_present_at(&self, t_s: f64) -> bool {
        t_s >= self.span_s.0
            && t_s <= self.span_s.1
            && !self.absent_s.iter().any(|&[a, b]| t_s >= a && t_s < b)
    }
    fn pose_at(&self, t_s: f64) -> BodyPose {
        let [x, y] = (self.path)(t_s);
        let rot = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), self.yaw_rad);
        let mut pose = Joints::new();
        for j in Joint::ALL {
            let o = self.offset(j);
            pose.insert(
                j,
                JointPose {
                    position_m: Point3::new(x, y, 0.0) + rot * Vector3::from(o),
                    world_from_joint: rot,
                },
            );
        }
        pose
    }
}

const FACING_CAMERA: f64 = std::f64::consts::PI;
const FACING_AWAY: f64 = 0.0;

/// Camera at 1.2 m height at the origin looking horizontally along +X.
fn config() -> CameraModelConfig {
    CameraModelConfig {
        position_m: [0.0, 0.0, 1.2],
        look_at_m: [5.0, 0.0, 1.2],
        ..CameraModelConfig::default()
    }
}

fn run(
    cfg: CameraModelConfig,
    figures: &[&Figure],
    obstacles: &[BoxObstacle],
    t1_s: f64,
    seed: u64,
) -> CameraOutput {
    let model = CameraModel::new(cfg).unwrap();
    let people: Vec<PersonInScene> = figures
        .iter()
        .enumerate()
        .map(|(i, f)| {
            PersonInScene::new(
                format!("p{i}"),
                Some(SubjectId::new(format!("s{i}"))),
                *f as &dyn BodyMotion,
            )
        })
        .collect();
    let mut rng = stream(seed, "camera/test");
    let relabel_rng = stream(seed, "camera/test/relabel");
    model
        .simulate_with_relabel_rng(&people, obstacles, 0.0, t1_s, &mut rng, relabel_rng)
        .unwrap()
}

/// Observations of person `name`, with their truths.
fn of<'a>(
    out: &'a CameraOutput,
    name: &str,
) -> Vec<(&'a SkeletonObservation, &'a nomen_core::TruthSkeleton)> {
    out.observations
        .iter()
        .zip(&out.truths)
        .filter(|(_, t)| t.person == name)
        .collect()
}

fn state(obs: &SkeletonObservation, j: Joint) -> JointState {
    obs.joints.get(j).unwrap().state
}

/// A facing the camera at 3 m with its left arm held out; its left wrist is at world
/// (3, −0.72, 1.45). The ray from the camera to it crosses x = 1.5 at (1.5, −0.36, 1.325).
fn a_with_arm_out() -> Figure {
    Figure {
        is_left_arm_out: true,
        ..Figure::standing(3.0, 0.0, FACING_CAMERA)
    }
}

#[test]
fn another_body_on_the_ray_hides_the_wrist_and_moving_it_aside_reveals_it() {
    let a = a_with_arm_out();
    let wrist = a.pose_at(0.0).get(Joint::LeftWrist).unwrap().position_m;
    assert_relative_eq!(wrist, Point3::new(3.0, -0.72, 1.45), epsilon = 1e-12);

    // B stands with its trunk axis exactly on the ray.
    let b_blocking = Figure::standing(1.5, -0.36, FACING_CAMERA);
    let out = run(config(), &[&a, &b_blocking], &[], 1.0, 1);
    let a_obs = of(&out, "p0");
    assert!(!a_obs.is_empty(), "A must still be reported");
    for (obs, _) in &a_obs {
        assert_ne!(state(obs, Joint::LeftWrist), JointState::Tracked);
        assert_eq!(state(obs, Joint::RightWrist), JointState::Tracked);
        assert_eq!(state(obs, Joint::Pelvis), JointState::Tracked);
    }

    // B one metre aside: nothing of A is hidden.
    let b_aside = Figure::standing(1.5, -1.36, FACING_CAMERA);
    let out = run(config(), &[&a, &b_aside], &[], 1.0, 1);
    let a_obs = of(&out, "p0");
    assert!(!a_obs.is_empty());
    for (obs, _) in &a_obs {
        for (j, o) in obs.joints.iter() {
            assert_eq!(o.state, JointState::Tracked, "{j}");
        }
    }
}

#[test]
fn a_box_between_camera_and_wrist_hides_it() {
    let a = a_with_arm_out();
    let cube = |y: f64| BoxObstacle {
        name: "cube".into(),
        centre_m: [1.5, y, 1.325],
        size_m: [0.1, 0.1, 0.1],
        yaw_rad: 0.0,
    };
    let out = run(config(), &[&a], &[cube(-0.36)], 1.0, 2);
    assert!(!out.observations.is_empty());
    for obs in &out.observations {
        assert_eq!(state(obs, Joint::LeftWrist), JointState::Inferred);
        // The elbow's ray passes at y = −0.235, clear of the cube's y ∈ [−0.41, −0.31].
        assert_eq!(state(obs, Joint::LeftElbow), JointState::Tracked);
    }
    let out = run(config(), &[&a], &[cube(1.0)], 1.0, 2);
    assert!(!out.observations.is_empty());
    for obs in &out.observations {
        assert_eq!(state(obs, Joint::LeftWrist), JointState::Tracked);
    }
}

#[test]
fn hidden_joint_turns_missing_after_max_inferred_time() {
    let a = a_with_arm_out();
    let cube = BoxObstacle {
        centre_m: [1.5, -0.36, 1.325],
        size_m: [0.1, 0.1, 0.1],
        ..BoxObstacle::default()
    };
    let mut cfg = config();
    cfg.occlusion.max_inferred_s = 0.5;
    cfg.tracking.new_body_delay_frames = 0;
    let out = run(cfg, &[&a], &[cube], 1.0, 3);
    for obs in &out.observations {
        let expected = if obs.t.as_secs_f64() <= 0.5 + 1e-9 {
            JointState::Inferred
        } else {
            JointState::Missing
        };
        assert_eq!(state(obs, Joint::LeftWrist), expected, "t = {:?}", obs.t);
    }
}

/// Per-axis σ of tracked-joint errors (camera frame) of a person facing the camera at `depth_m`.
fn measured_sigma(depth_m: f64, joint: Option<Joint>) -> (f64, f64) {
    let a = Figure::standing(depth_m, 0.0, FACING_CAMERA);
    let model = CameraModel::new(config()).unwrap();
    let camera_from_world = model.world_from_camera().inverse();
    let out = run(config(), &[&a], &[], 60.0, 4);
    let (mut sum2, mut n, mut expected) = (0.0, 0usize, 0.0);
    for (obs, truth) in out.observations.iter().zip(&out.truths) {
        for (j, o) in obs.joints.iter() {
            if o.state != JointState::Tracked || joint.is_some_and(|x| x != j) {
                continue;
            }
            let p = camera_from_world * truth.joints_world_m.get(j).unwrap();
            let e = o.position_m - p;
            sum2 += e.norm_squared();
            n += 3;
            expected = model.config().noise.sigma_m(p.z);
        }
    }
    ((sum2 / n as f64).sqrt(), expected)
}

#[test]
fn joint_noise_sigma_grows_with_depth_as_configured() {
    // σ(z) = 0.008 + 0.0015 z²: 1.14 cm at 1.5 m, 3.2 cm at 4 m.
    for depth in [1.5, 4.0] {
        let (sigma, expected) = measured_sigma(depth, Some(Joint::Pelvis));
        assert_relative_eq!(expected, 0.008 + 0.0015 * depth * depth, epsilon = 1e-12);
        assert!(
            (sigma / expected - 1.0).abs() < 0.05,
            "depth {depth}: σ {sigma} vs {expected}"
        );
    }
    let (near, _) = measured_sigma(1.5, None);
    let (far, _) = measured_sigma(4.0, None);
    assert!(far > 2.5 * near, "{near} {far}");
}

#[test]
fn joints_are_reported_in_the_camera_frame() {
    let a = Figure::standing(3.0, 0.5, FACING_CAMERA);
    let model = CameraModel::new(config()).unwrap();
    let out = run(config(), &[&a], &[], 2.0, 5);
    assert!(!out.observations.is_empty());
    let w = model.world_from_camera();
    for (obs, truth) in out.observations.iter().zip(&out.truths) {
        assert_eq!(obs.track, truth.track);
        assert_eq!(obs.t, truth.t);
        assert_eq!(truth.subject, Some(SubjectId::new("s0")));
        // Camera frame: the pelvis at world (3, 0.5, 0.95) is 3 m ahead, 0.5 m to the left
        // (−X) and 0.25 m below the optical axis (+Y).
        let pelvis = obs.position(Joint::Pelvis).unwrap();
        assert!((pelvis.z - 3.0).abs() < 0.2 && (pelvis.x + 0.5).abs() < 0.2);
        assert!((pelvis.y - 0.25).abs() < 0.2);
        for (j, o) in obs.joints.iter() {
            if o.state != JointState::Tracked {
                continue;
            }
            let back = w * o.position_m;
            let err = (back - truth.joints_world_m.get(j).unwrap()).norm();
            assert!(err < 6.0 * 0.0215, "{j}: {err}");
        }
    }
}

#[test]
fn people_outside_the_field_of_view_or_range_are_not_reported() {
    let beside = Figure::standing(3.0, 3.0, FACING_CAMERA); // half-width at 3 m is 2.12 m
    let too_far = Figure::standing(5.5, 0.0, FACING_CAMERA);
    let too_near = Figure::standing(0.3, 0.2, FACING_CAMERA);
    let behind = Figure::standing(-3.0, 0.0, 0.0);
    let seen = Figure::standing(3.0, -1.5, FACING_CAMERA);
    // One at a time, and the near one off the line of sight to the seen one: someone 0.3 m in
    // front of the lens hides most of the room.
    for unseen in [&beside, &too_far, &too_near, &behind] {
        let out = run(config(), &[unseen, &seen], &[], 2.0, 6);
        assert!(!out.observations.is_empty());
        assert!(out.truths.iter().all(|t| t.person == "p1"));
    }
}

fn ids_of(out: &CameraOutput, name: &str) -> Vec<(f64, TrackId)> {
    of(out, name)
        .iter()
        .map(|(o, _)| (o.t.as_secs_f64(), o.track))
        .collect()
}

fn distinct(ids: &[(f64, TrackId)]) -> Vec<TrackId> {
    let mut v: Vec<TrackId> = Vec::new();
    for (_, id) in ids {
        if v.last() != Some(id) {
            v.push(*id);
        }
    }
    v
}

fn longest_gap_s(ids: &[(f64, TrackId)]) -> f64 {
    ids.windows(2).map(|w| w[1].0 - w[0].0).fold(0.0, f64::max)
}

#[test]
fn track_id_survives_a_short_occlusion_and_is_renewed_after_a_long_one() {
    // A walks across at 3.5 m depth, 1 m/s, behind a tall pillar at 1.75 m depth.
    let walker = || Figure::moving(|t| [3.5, -1.6 + t], FACING_CAMERA);
    let pillar = |width: f64| BoxObstacle {
        name: "pillar".into(),
        centre_m: [1.75, 0.0, 1.5],
        size_m: [0.2, width, 3.0],
        yaw_rad: 0.0,
    };
    let mut cfg = config();
    cfg.tracking.keep_id_max_gap_s = 1.0;
    let a = walker();

    // A 0.2 m pillar (0.4 m shadow at A's depth): a short loss, same id.
    let ids = ids_of(&run(cfg.clone(), &[&a], &[pillar(0.2)], 3.2, 7), "p0");
    let gap = longest_gap_s(&ids);
    assert!(gap > 0.1 && gap < 1.0, "gap {gap}");
    assert_eq!(distinct(&ids).len(), 1);

    // A 1 m pillar (2 m shadow): lost for longer than 1 s, back with the next id.
    let ids = ids_of(&run(cfg, &[&a], &[pillar(1.0)], 3.2, 7), "p0");
    assert!(longest_gap_s(&ids) > 1.0);
    let d = distinct(&ids);
    assert_eq!(d.len(), 2, "{d:?}");
    assert_eq!(d[1].0, d[0].0 + 1);
}

#[test]
fn track_id_is_renewed_on_reentry_even_after_a_short_absence() {
    // At 3 m depth the half-width of the view is 2.12 m: swinging ±2.5 m leaves it for about
    // 1 s on each side.
    let a = Figure::moving(
        |t| [3.0, 2.5 * (std::f64::consts::TAU * t / 6.0).sin()],
        FACING_CAMERA,
    );
    let mut cfg = config();
    cfg.tracking.keep_id_max_gap_s = 5.0;
    let ids = ids_of(&run(cfg, &[&a], &[], 6.0, 8), "p0");
    let d = distinct(&ids);
    assert_eq!(d.len(), 3, "{d:?}");
    assert!(d.windows(2).all(|w| w[1].0 == w[0].0 + 1));
}

#[test]
fn new_bodies_are_reported_after_the_configured_delay() {
    for delay in [0_u32, 5, 12] {
        let early = Figure::standing(3.0, -1.0, FACING_CAMERA);
        let late = Figure {
            span_s: (2.0, 10.0),
            ..Figure::standing(3.0, 1.0, FACING_CAMERA)
        };
        let mut cfg = config();
        cfg.tracking.new_body_delay_frames = delay;
        let out = run(cfg, &[&early, &late], &[], 4.0, 9);
        let first = |name: &str| ids_of(&out, name).first().unwrap().0;
        assert_relative_eq!(first("p0"), f64::from(delay) / 30.0, epsilon = 1e-6);
        assert_relative_eq!(first("p1"), 2.0 + f64::from(delay) / 30.0, epsilon = 1e-6);
    }
}

#[test]
fn track_ids_start_at_a_random_base_and_do_not_follow_the_people_list() {
    let a = Figure::standing(4.0, 0.5, FACING_CAMERA);
    let b = Figure::standing(2.0, -0.5, FACING_CAMERA);
    let bases: Vec<TrackId> = (0..5)
        .map(|seed| {
            let out = run(config(), &[&a, &b], &[], 0.5, seed);
            // B is nearer, so B gets the first id although it is listed second.
            let (ia, ib) = (ids_of(&out, "p0")[0].1, ids_of(&out, "p1")[0].1);
            assert_eq!(ia.0, ib.0 + 1);
            ib
        })
        .collect();
    let mut unique = bases.clone();
    unique.sort();
    unique.dedup();
    assert!(unique.len() >= 4, "{bases:?}");
}

#[test]
fn ids_swap_after_close_encounters_at_the_configured_rate() {
    // A at 2.5 m and B at 3.5 m swing in opposite directions and cross every 2 s: 200 crossings.
    let period = 4.0;
    let w = std::f64::consts::TAU / period;
    let a = Figure::moving(move |t| [2.5, 1.5 * (w * t).sin()], FACING_CAMERA);
    let b = Figure::moving(move |t| [3.5, -2.1 * (w * t).sin()], FACING_CAMERA);
    let mut cfg = config();
    cfg.tracking.swap_probability = 0.3;
    cfg.tracking.keep_id_max_gap_s = 3.0;
    let t1 = 401.0;
    let out = run(cfg, &[&a, &b], &[], t1, 10);
    let (mut last_a, mut last_b) = (None, None);
    let mut num_swaps = 0;
    let mut ids = Vec::new();
    for obs in out.truths.iter() {
        if !ids.contains(&obs.track) {
            ids.push(obs.track);
        }
        if obs.person == "p0" {
            if last_a.is_some() && last_a != Some(obs.track) && Some(obs.track) == last_b {
                num_swaps += 1;
            }
            last_a = Some(obs.track);
        } else {
            last_b = Some(obs.track);
        }
    }
    assert_eq!(ids.len(), 2, "no renewals in this scene: {ids:?}");
    // 200 encounters × 0.3 = 60, binomial σ = 6.5.
    assert!((40..=80).contains(&num_swaps), "{num_swaps} swaps");
}

#[test]
fn people_facing_away_flip_left_and_right_at_the_configured_rate() {
    let away = Figure::standing(3.0, -0.6, FACING_AWAY);
    let towards = Figure::standing(3.0, 0.6, FACING_CAMERA);
    let mut cfg = config();
    cfg.tracking.flip_rate_hz = 0.2;
    cfg.tracking.flip_duration_s = 0.5;
    let t1 = 300.0;
    let out = run(cfg, &[&away, &towards], &[], t1, 11);
    let model = CameraModel::new(config()).unwrap();
    let cw = model.world_from_camera().inverse();
    let count_flips = |name: &str| {
        let mut flips = 0;
        let mut was_flipped = false;
        for (obs, truth) in of(&out, name) {
            let reported = obs.position(Joint::LeftShoulder).unwrap();
            let true_left = cw * truth.joints_world_m.get(Joint::LeftShoulder).unwrap();
            let true_right = cw * truth.joints_world_m.get(Joint::RightShoulder).unwrap();
            let is_flipped = (reported - true_right).norm() < (reported - true_left).norm();
            if is_flipped && !was_flipped {
                flips += 1;
            }
            was_flipped = is_flipped;
        }
        flips
    };
    // Starts only when not flipped: 300 s / (1/0.2 + 0.5 s) ≈ 55 flips, σ ≈ 7.
    let n = count_flips("p0");
    assert!((35..=75).contains(&n), "{n} flips");
    assert_eq!(count_flips("p1"), 0);
}

fn busy_scene_people() -> Vec<Figure> {
    (0..8)
        .map(|i| {
            let fi = i as f64;
            let depth = 1.5 + 0.35 * fi;
            let phase = 0.7 * fi;
            let speed = 0.3 + 0.05 * fi;
            Figure::moving(
                move |t| [depth, 1.2 * (speed * t + phase).sin()],
                if i % 3 == 0 {
                    FACING_AWAY
                } else {
                    FACING_CAMERA
                },
            )
        })
        .collect()
}

fn busy_obstacles() -> Vec<BoxObstacle> {
    vec![
        BoxObstacle::from_corners("table", [2.0, 0.3, 0.0], [2.8, 1.1, 0.75]),
        BoxObstacle {
            name: "pillar".into(),
            centre_m: [3.2, -0.8, 1.5],
            size_m: [0.3, 0.3, 3.0],
            yaw_rad: 0.4,
        },
    ]
}

#[test]
fn same_seed_gives_identical_output_and_another_seed_does_not() {
    let people = busy_scene_people();
    let refs: Vec<&Figure> = people.iter().collect();
    let obstacles = busy_obstacles();
    let a = run(config(), &refs, &obstacles, 5.0, 12);
    let b = run(config(), &refs, &obstacles, 5.0, 12);
    let c = run(config(), &refs, &obstacles, 5.0, 13);
    assert!(a.observations.len() > 100);
    assert_eq!(a, b);
    assert_ne!(a, c);
    for o in &a.observations {
        o.validate().unwrap();
    }
}

#[test]
fn config_reads_from_toml_with_defaults_and_rejects_unknown_fields() {
    let text = r#"
        id = "kinect_door"
        position_m = [0.0, -2.0, 2.1]
        look_at_m = [0.0, 2.0, 1.0]
        max_range_m = 3.86
        [noise]
        sigma_base_m = 0.005
        [tracking]
        swap_probability = 0.1
    "#;
    let cfg: CameraModelConfig = toml::from_str(text).unwrap();
    assert_eq!(cfg.id, "kinect_door");
    assert_eq!(cfg.noise.sigma_base_m, 0.005);
    assert_eq!(cfg.noise.sigma_per_depth2_m, 0.0015);
    assert_eq!(cfg.fps_hz, 30.0);
    assert_eq!(cfg.tracking.swap_probability, 0.1);
    assert_eq!(cfg.tracking.new_body_delay_frames, 5);
    CameraModel::new(cfg.clone()).unwrap();
    let back: CameraModelConfig = toml::from_str(&toml::to_string(&cfg).unwrap()).unwrap();
    assert_eq!(back, cfg);
    assert!(toml::from_str::<CameraModelConfig>("fov_deg = 70").is_err());
    assert!(toml::from_str::<CameraModelConfig>("[noise]\nsigma = 1").is_err());
    let bad = CameraModelConfig {
        min_range_m: 5.0,
        ..CameraModelConfig::default()
    };
    assert!(
        CameraModel::new(bad)
            .unwrap_err()
            .to_string()
            .contains("min_range_m")
    );
}

#[test]
fn a_visible_body_is_relabelled_at_the_configured_rate_and_truth_follows() {
    // A standing figure in full view for the whole run: every new id is a re-label.
    let a = Figure::standing(3.0, 0.0, FACING_CAMERA);
    let rate_hz = 0.1;
    let t1_s = 200.0;
    let seeds = 0..8_u64;
    let mut num_relabels = 0;
    for seed in seeds.clone() {
        let mut cfg = config();
        cfg.tracking.relabel_rate_hz = rate_hz;
        let out = run(cfg, &[&a], &[], t1_s, seed);
        let ids = ids_of(&out, "p0");
        let d = distinct(&ids);
        // Fresh ids come from the counter of new tracks, and none comes back.
        assert!(d.windows(2).all(|w| w[1].0 == w[0].0 + 1), "{d:?}");
        // Truth carries the same track, and the same person, on every frame.
        for (obs, truth) in of(&out, "p0") {
            assert_eq!(obs.track, truth.track);
        }
        num_relabels += d.len() - 1;
    }
    // Poisson: mean r·T per run; the tracked time is T less one acquisition delay per
    // re-label (5 frames), under 1 %. Four standard deviations of the sum.
    let expected = rate_hz * t1_s * seeds.count() as f64;
    let n = num_relabels as f64;
    assert!(
        (n - expected).abs() < 4.0 * expected.sqrt(),
        "{n} re-labels, expected {expected}"
    );

    // Without a rate, one id for the whole run.
    let out = run(config(), &[&a], &[], 60.0, 3);
    assert_eq!(distinct(&ids_of(&out, "p0")).len(), 1);
}

#[test]
fn relabelling_changes_ids_only_not_the_joint_noise_or_other_people() {
    let a = Figure::standing(3.0, -0.8, FACING_CAMERA);
    let b = Figure::standing(3.5, 0.8, FACING_CAMERA);
    let mut cfg = config();
    cfg.tracking.new_body_delay_frames = 0;
    let plain = run(cfg.clone(), &[&a, &b], &[], 20.0, 4);
    cfg.tracking.relabel_rate_hz = 0.5;
    let relabelled = run(cfg, &[&a, &b], &[], 20.0, 4);
    // Without an acquisition delay a re-labelled body is reported on every frame still, with
    // the same joints: re-labelling draws from its own stream.
    assert_eq!(plain.observations.len(), relabelled.observations.len());
    for (p, r) in plain.observations.iter().zip(&relabelled.observations) {
        assert_eq!(p.t, r.t);
        assert_eq!(p.joints, r.joints);
    }
    let d = distinct(&ids_of(&relabelled, "p0"));
    assert!(d.len() > 2, "{d:?}");
}

#[test]
fn relabelling_needs_its_stream_and_a_valid_rate() {
    let a = Figure::standing(3.0, 0.0, FACING_CAMERA);
    let mut cfg = config();
    cfg.tracking.relabel_rate_hz = 0.2;
    let model = CameraModel::new(cfg).unwrap();
    let people = [PersonInScene::new("p0", None, &a as &dyn BodyMotion)];
    let err = model
        .simulate(&people, &[], 0.0, 1.0, &mut stream(1, "camera/test"))
        .unwrap_err()
        .to_string();
    assert!(err.contains("relabel"), "{err}");
    for rate in [-0.1, f64::NAN, f64::INFINITY, 11.0] {
        let mut cfg = config();
        cfg.tracking.relabel_rate_hz = rate;
        let err = CameraModel::new(cfg).unwrap_err().to_string();
        assert!(err.contains("tracking.relabel_rate_hz"), "{rate}: {err}");
    }
}

#[test]
fn an_absent_body_is_not_seen_hides_nothing_and_returns_with_a_new_id() {
    // A stands in front of B on B's line of sight to the camera and leaves from 2 s to 4 s.
    let a = Figure {
        absent_s: vec![[2.0, 4.0]],
        ..Figure::standing(1.5, 0.0, FACING_CAMERA)
    };
    let b = Figure::standing(3.5, 0.0, FACING_CAMERA);
    let mut cfg = config();
    cfg.tracking.keep_id_max_gap_s = 10.0;
    let out = run(cfg, &[&a, &b], &[], 6.0, 5);
    let a_ids = ids_of(&out, "p0");
    assert!(a_ids.iter().all(|(t, _)| !(2.0..4.0).contains(t)));
    let before: Vec<TrackId> = distinct(
        &a_ids
            .iter()
            .copied()
            .filter(|x| x.0 < 2.0)
            .collect::<Vec<_>>(),
    );
    let after: Vec<TrackId> = distinct(
        &a_ids
            .iter()
            .copied()
            .filter(|x| x.0 >= 4.0)
            .collect::<Vec<_>>(),
    );
    assert_eq!((before.len(), after.len()), (1, 1), "{a_ids:?}");
    assert_ne!(before[0], after[0]);
    // While A is away, B's pelvis (straight behind A) is tracked, not inferred.
    let b_pelvis = |lo: f64, hi: f64| {
        of(&out, "p1")
            .iter()
            .filter(|(o, _)| (lo..hi).contains(&o.t.as_secs_f64()))
            .map(|(o, _)| state(o, Joint::Pelvis))
            .collect::<Vec<_>>()
    };
    assert!(b_pelvis(2.5, 4.0).iter().all(|s| *s == JointState::Tracked));
    assert!(b_pelvis(0.5, 2.0).iter().all(|s| *s != JointState::Tracked));
}

/// Release timing of the workload in the brief: 8 people, 30 fps, 60 s, one camera.
/// `cargo test --release -p nomen-sim --test camera_model -- --ignored --nocapture`
#[test]
#[ignore = "timing; run in release"]
fn eight_people_sixty_seconds_timing() {
    let people = busy_scene_people();
    let refs: Vec<&Figure> = people.iter().collect();
    let obstacles = busy_obstacles();
    let start = std::time::Instant::now();
    let out = run(config(), &refs, &obstacles, 60.0, 14);
    let elapsed = start.elapsed();
    eprintln!(
        "8 people × 60 s × 30 fps: {} skeletons in {:.1} ms",
        out.observations.len(),
        elapsed.as_secs_f64() * 1e3
    );
    assert!(elapsed.as_secs_f64() < 0.5);
}
