//! Synthetic multi-view data for tests and measurements: virtual cameras around a room, 3D
//! people projected into them with pixel noise, missed joints and false detections, walkers
//! that need no motion capture, and the joint error of a reconstruction against the truth.
//!
//! Everything takes its random numbers from the caller's generator, so a seed reproduces a run.

use crate::camera::{CalibratedCamera, Distortion, Intrinsics};
use crate::keypoints::{Detection, Keypoint};
use crate::reconstruct::{ReconstructionConfig, TriangulatedSkeleton, reconstruct_frame};
use nalgebra::{Point2, Point3, UnitQuaternion, Vector3};
use nomen_core::skeleton::Joints;
use nomen_core::{CameraId, Joint};
use rand::Rng;
use rand::seq::SliceRandom;
use rand_distr::{Distribution, Normal};

/// A 1920 × 1080 camera with a 90° horizontal field of view and the mild barrel distortion of
/// a wide surveillance lens.
pub fn room_camera_intrinsics() -> Intrinsics {
    Intrinsics {
        distortion: Distortion {
            k1: -0.12,
            k2: 0.03,
            p1: 0.0005,
            p2: -0.0003,
            k3: 0.0,
        },
        ..Intrinsics::from_fov(1920, 1080, 90f64.to_radians())
    }
}

/// `num_views` cameras high in the corners of a square room of side `2 · half_side_m` centred
/// on `centre_m` (floor at `centre_m.z`), each looking at the point 1 m above the centre: with
/// two views adjacent corners, with three and four views three and four corners, and beyond
/// four, evenly around the room. `None` for zero views.
pub fn room_rig(
    num_views: usize,
    centre_m: Point3<f64>,
    half_side_m: f64,
    height_m: f64,
    intrinsics: Intrinsics,
) -> Option<Vec<CalibratedCamera>> {
    if num_views == 0 {
        return None;
    }
    let target = centre_m + Vector3::new(0.0, 0.0, 1.0);
    (0..num_views)
        .map(|i| {
            let angle = if num_views <= 4 {
                std::f64::consts::FRAC_PI_4 + i as f64 * std::f64::consts::FRAC_PI_2
            } else {
                std::f64::consts::FRAC_PI_4 + i as f64 * std::f64::consts::TAU / num_views as f64
            };
            let radius = half_side_m * std::f64::consts::SQRT_2;
            let eye = centre_m + Vector3::new(radius * angle.cos(), radius * angle.sin(), height_m);
            CalibratedCamera::looking_at(
                CameraId::new(format!("cam{}", i + 1)),
                intrinsics,
                eye,
                target,
            )
        })
        .collect()
}

/// How synthetic detections are made from true 3D joints.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DetectionNoise {
    /// Standard deviation of the Gaussian noise added to each pixel coordinate, pixels.
    pub pixel_noise_px: f64,
    /// Probability that a visible joint is not detected.
    pub miss_rate: f64,
    /// Probability that a detected joint is placed at a uniformly random pixel instead.
    pub false_joint_rate: f64,
    /// Mean number of false people per view and frame: a true person moved to a random place in
    /// the room and seen by that view only (a reflection, a poster, a ghost of the detector).
    pub false_people_per_view: f64,
}

impl DetectionNoise {
    /// Gaussian pixel noise only.
    pub fn pixel(pixel_noise_px: f64) -> Self {
        Self {
            pixel_noise_px,
            miss_rate: 0.0,
            false_joint_rate: 0.0,
            false_people_per_view: 0.0,
        }
    }
}

/// Projects people (true joint positions in the world) into every camera and returns each
/// view's detections in random order. Keypoint confidences are uniform in 0.5..1 and unrelated
/// to the noise; joints behind a camera or off its image are not detected.
pub fn detect(
    cameras: &[CalibratedCamera],
    people: &[Joints<Point3<f64>>],
    noise: &DetectionNoise,
    room_half_side_m: f64,
    rng: &mut impl Rng,
) -> Vec<Vec<Detection>> {
    let gaussian = Normal::new(0.0, noise.pixel_noise_px.max(0.0)).ok();
    cameras
        .iter()
        .map(|camera| {
            let mut detections: Vec<Detection> = people
                .iter()
                .map(|p| detect_one(camera, p, noise, gaussian.as_ref(), rng))
                .filter(|d| !d.joints.is_empty())
                .collect();
            let whole = noise.false_people_per_view.max(0.0);
            let num_false =
                whole.floor() as usize + usize::from(rng.random::<f64>() < whole.fract());
            for _ in 0..num_false {
                if people.is_empty() {
                    break;
                }
                let source = &people[rng.random_range(0..people.len())];
                let shift = Vector3::new(
                    rng.random_range(-room_half_side_m..room_half_side_m),
                    rng.random_range(-room_half_side_m..room_half_side_m),
                    0.0,
                );
                let ghost = source.map(|_, p| p + shift);
                let d = detect_one(camera, &ghost, noise, gaussian.as_ref(), rng);
                if !d.joints.is_empty() {
                    detections.push(d);
                }
            }
            detections.shuffle(rng);
            detections
        })
        .collect()
}

fn detect_one(
    camera: &CalibratedCamera,
    person: &Joints<Point3<f64>>,
    noise: &DetectionNoise,
    gaussian: Option<&Normal<f64>>,
    rng: &mut impl Rng,
) -> Detection {
    let k = &camera.intrinsics;
    let mut detection = Detection::default();
    for (joint, p) in person.iter() {
        let Some(px) = camera.project_px(p) else {
            continue;
        };
        if !k.contains_px(&px) || rng.random::<f64>() < noise.miss_rate {
            continue;
        }
        let mut pixel_px = match gaussian {
            Some(g) => Point2::new(px.x + g.sample(rng), px.y + g.sample(rng)),
            None => px,
        };
        if rng.random::<f64>() < noise.false_joint_rate {
            pixel_px = Point2::new(
                rng.random_range(0.0..f64::from(k.width_px)),
                rng.random_range(0.0..f64::from(k.height_px)),
            );
        }
        detection.joints.insert(
            joint,
            Keypoint {
                pixel_px,
                confidence: rng.random_range(0.5..1.0),
            },
        );
    }
    detection
}

/// A walking stick figure on the canonical joints, without motion capture: a 1.75 m adult
/// walking at `speed_mps` around a circle of `radius_m` about `centre_m` (floor at its z), starting
/// at `phase_rad` on the circle, at time `t_s`. Legs and arms swing at 0.9 strides per second.
pub fn walker(
    centre_m: Point3<f64>,
    radius_m: f64,
    speed_mps: f64,
    phase_rad: f64,
    t_s: f64,
) -> Joints<Point3<f64>> {
    use Joint::*;
    let angle = phase_rad + speed_mps * t_s / radius_m.max(0.1);
    let position = centre_m + Vector3::new(radius_m * angle.cos(), radius_m * angle.sin(), 0.0);
    // Facing along the circle (counter-clockwise); the body frame has x forward, y left, z up.
    let heading =
        UnitQuaternion::from_axis_angle(&Vector3::z_axis(), angle + std::f64::consts::FRAC_PI_2);
    let swing = (std::f64::consts::TAU * 0.9 * t_s).sin();
    let bob = 0.02 * (2.0 * std::f64::consts::TAU * 0.9 * t_s).cos();
    let body: [(Joint, [f64; 3]); 20] = [
        (Pelvis, [0.0, 0.0, 0.95 + bob]),
        (Chest, [0.02, 0.0, 1.25 + bob]),
        (Neck, [0.02, 0.0, 1.47 + bob]),
        (Head, [0.05, 0.0, 1.62 + bob]),
        (LeftShoulder, [0.0, 0.19, 1.43 + bob]),
        (LeftElbow, [-0.12 * swing, 0.21, 1.15 + bob]),
        (LeftWrist, [-0.25 * swing, 0.22, 0.90 + bob]),
        (LeftHand, [-0.28 * swing, 0.22, 0.82 + bob]),
        (RightShoulder, [0.0, -0.19, 1.43 + bob]),
        (RightElbow, [0.12 * swing, -0.21, 1.15 + bob]),
        (RightWrist, [0.25 * swing, -0.22, 0.90 + bob]),
        (RightHand, [0.28 * swing, -0.22, 0.82 + bob]),
        (LeftHip, [0.0, 0.1, 0.90 + bob]),
        (LeftKnee, [0.15 * swing, 0.1, 0.50]),
        (LeftAnkle, [0.3 * swing, 0.1, 0.08]),
        (LeftFoot, [0.3 * swing + 0.13, 0.1, 0.03]),
        (RightHip, [0.0, -0.1, 0.90 + bob]),
        (RightKnee, [-0.15 * swing, -0.1, 0.50]),
        (RightAnkle, [-0.3 * swing, -0.1, 0.08]),
        (RightFoot, [-0.3 * swing + 0.13, -0.1, 0.03]),
    ];
    let mut joints = Joints::new();
    for (joint, [x, y, z]) in body {
        joints.insert(joint, position + heading * Vector3::new(x, y, z));
    }
    joints
}

/// The joint errors of reconstructions against the truth, accumulated over frames.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct JointErrors {
    /// Distance of every triangulated joint of a matched skeleton to the truth, metres.
    pub errors_m: Vec<f64>,
    /// True people over all frames.
    pub num_true: usize,
    /// True people matched by a triangulated skeleton.
    pub num_matched: usize,
    /// Triangulated skeletons that matched no true person.
    pub num_false: usize,
    /// True joints of matched people that were not triangulated.
    pub num_joints_missing: usize,
}

/// Largest distance from a true pelvis to a triangulated skeleton's anchor (the median of its
/// joints) at which the skeleton is that person, metres.
pub const MATCH_DISTANCE_M: f64 = 0.5;

impl JointErrors {
    /// Adds one frame: every true person is matched to the skeleton nearest its pelvis within
    /// [`MATCH_DISTANCE_M`] (pairs in increasing distance).
    pub fn add_frame(&mut self, truth: &[Joints<Point3<f64>>], skeletons: &[TriangulatedSkeleton]) {
        let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
        for (ti, person) in truth.iter().enumerate() {
            let Some(pelvis) = person.get(Joint::Pelvis) else {
                continue;
            };
            for (si, s) in skeletons.iter().enumerate() {
                if let Some(a) = s.anchor_m() {
                    let d = (a - pelvis).norm();
                    if d <= MATCH_DISTANCE_M {
                        pairs.push((d, ti, si));
                    }
                }
            }
        }
        pairs.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
        let mut is_true_taken = vec![false; truth.len()];
        let mut is_skeleton_taken = vec![false; skeletons.len()];
        for (_, ti, si) in pairs {
            if is_true_taken[ti] || is_skeleton_taken[si] {
                continue;
            }
            is_true_taken[ti] = true;
            is_skeleton_taken[si] = true;
            for (joint, p) in truth[ti].iter() {
                match skeletons[si].joints.get(joint) {
                    Some(t) => self.errors_m.push((t.position_m - p).norm()),
                    None => self.num_joints_missing += 1,
                }
            }
        }
        self.num_true += truth.len();
        self.num_matched += is_true_taken.iter().filter(|t| **t).count();
        self.num_false += is_skeleton_taken.iter().filter(|t| !**t).count();
    }

    /// The `q`-quantile (0..=1) of the joint errors by nearest rank, metres; `None` without
    /// errors.
    pub fn quantile_m(&self, q: f64) -> Option<f64> {
        let mut sorted = self.errors_m.clone();
        sorted.sort_by(f64::total_cmp);
        let n = sorted.len();
        if n == 0 {
            return None;
        }
        let rank = ((q.clamp(0.0, 1.0) * n as f64).ceil() as usize).clamp(1, n);
        Some(sorted[rank - 1])
    }
}

/// Runs reconstruction on every frame of true people (`frames`), detected by `cameras` with
/// `noise`, and scores it.
pub fn measure(
    cameras: &[CalibratedCamera],
    frames: &[Vec<Joints<Point3<f64>>>],
    noise: &DetectionNoise,
    room_half_side_m: f64,
    config: &ReconstructionConfig,
    rng: &mut impl Rng,
) -> JointErrors {
    let mut errors = JointErrors::default();
    for people in frames {
        let views = detect(cameras, people, noise, room_half_side_m, rng);
        let frame = reconstruct_frame(cameras, &views, config);
        errors.add_frame(people, &frame.skeletons);
    }
    errors
}

/// Three walkers on circles of 1, 2 and 2.8 m about `centre_m` at 1.0–1.4 m/s, `num_frames`
/// frames at `rate_hz`.
pub fn walkers_scene(
    centre_m: Point3<f64>,
    num_frames: usize,
    rate_hz: f64,
) -> Vec<Vec<Joints<Point3<f64>>>> {
    (0..num_frames)
        .map(|i| {
            let t = i as f64 / rate_hz;
            vec![
                walker(centre_m, 1.0, 1.0, 0.0, t),
                walker(centre_m, 2.0, 1.2, 2.0, t),
                walker(centre_m, 2.8, 1.4, 4.0, t),
            ]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_walker_has_adult_proportions_and_walks_at_its_speed() {
        let centre = Point3::new(1.0, 2.0, 0.0);
        let a = walker(centre, 2.0, 1.2, 0.0, 0.0);
        let b = walker(centre, 2.0, 1.2, 0.0, 1.0);
        assert_eq!(a.len(), 20);
        let head = a.get(Joint::Head).unwrap();
        assert!((head.z - 1.64).abs() < 0.03);
        let moved = (b.get(Joint::Pelvis).unwrap() - a.get(Joint::Pelvis).unwrap())
            .xy()
            .norm();
        // A 1.2 m arc on a 2 m circle: chord 2 · 2 · sin(0.3).
        assert!((moved - 4.0 * 0.3_f64.sin()).abs() < 1e-9, "{moved}");
        // Left is on the left: the walker turns counter-clockwise, so its left side faces the centre.
        let l = a.get(Joint::LeftHip).unwrap();
        let r = a.get(Joint::RightHip).unwrap();
        assert!((l - centre).xy().norm() < (r - centre).xy().norm());
    }

    #[test]
    fn the_rig_sees_the_room_centre_from_every_corner() {
        let rig = room_rig(4, Point3::origin(), 4.0, 2.8, room_camera_intrinsics()).unwrap();
        assert_eq!(rig.len(), 4);
        let k = rig[0].intrinsics;
        for c in &rig {
            for p in [Point3::new(0.0, 0.0, 0.0), Point3::new(2.0, -2.0, 1.8)] {
                let px = c.project_px(&p).unwrap();
                assert!(k.contains_px(&px), "{} misses {p}", c.id);
            }
        }
    }
}
