//! Rebecchi's assembly scene: a person at a table reaches into the middle compartment of a shelf
//! unit (static, complex occlusion) while a box-shaped robot link sweeps between the depth camera
//! and the hand (dynamic, simple occlusion), for 25 cycles.
//!
//! The arm motion is **procedural**, not motion capture: the shoulder is fixed, the wrist follows
//! a smooth minimum-jerk path rest → shelf opening → inside the compartment → back, with a
//! seeded jitter of the target per cycle, and the elbow comes from two-link inverse kinematics
//! with constant bone lengths (elbow pointing down and outward). The rest of the body stands
//! still. Everything is in the world frame (Z up, metres); the person faces +X.
//!
//! The camera sees the scene through [`SceneDepth`], a lazily rendered depth image: a pixel is
//! ray-cast (environment meshes, robot link, the person's capsules from
//! [`nomen_core::geometry`]) only when someone asks for it, and cached for the frame.
//! [`AssemblyScene::render_depth_map`] renders the whole image at the camera's resolution. A
//! joint is *observed* when the depth image at its pixel is not nearer than the joint by more
//! than [`AssemblySceneConfig::visibility_margin_m`] (its own limb's surface is in front of it by
//! about a limb radius); observed joints get the camera's depth-dependent Gaussian noise
//! ([`JointNoiseConfig`]).

use crate::depth::{DepthMap, DepthProbe, PinholeCamera};
use crate::environment::{Environment, MeshData};
use crate::error::{OcclusionError, Result};
use nalgebra::{Isometry3, Point3, Rotation3, Translation3, UnitQuaternion, Vector3};
use nomen_core::SessionTime;
use nomen_core::geometry::{BodyRadii, BoxObstacle, Capsule};
use nomen_core::registry::CameraIntrinsics;
use nomen_core::skeleton::{Joint, Joints};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

/// Parameters of the assembly scene.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AssemblySceneConfig {
    /// Reaching cycles. Default 25 (Rebecchi).
    pub num_cycles: usize,
    /// Duration of one cycle, s. Default 4.
    pub cycle_s: f64,
    /// Camera frame rate, Hz. Default 30 (Kinect).
    pub fps_hz: f64,
    /// Depth camera's optical centre, world, m.
    pub camera_position_m: [f64; 3],
    /// A point on the camera's optical axis, world, m.
    pub camera_look_at_m: [f64; 3],
    /// Depth image width, px. Default 512 (Kinect v2).
    pub image_width_px: u32,
    /// Depth image height, px. Default 424 (Kinect v2).
    pub image_height_px: u32,
    /// Horizontal field of view, rad. Default 70.6° (Kinect v2).
    pub horizontal_fov_rad: f64,
    /// Vertical field of view, rad. Default 60° (Kinect v2).
    pub vertical_fov_rad: f64,
    /// Depth beyond which the sensor returns nothing, m. Default 4.5 (Kinect v2).
    pub max_range_m: f64,
    /// Centre of the robot link's sweep, world, m.
    pub robot_link_centre_m: [f64; 3],
    /// Horizontal direction of the sweep (normalised), world.
    pub robot_link_direction: [f64; 2],
    /// Amplitude of the sinusoidal sweep, m.
    pub robot_link_amplitude_m: f64,
    /// Period of the sweep, s (not a multiple of the cycle, so every phase meets the link).
    pub robot_link_period_s: f64,
    /// Size of the link box (along the sweep, across, vertical), m.
    pub robot_link_size_m: [f64; 3],
    /// Joint noise of the camera.
    pub noise: JointNoiseConfig,
    /// A joint is hidden when the depth image at its pixel is nearer than the joint by more
    /// than this, m. Default 0.10 (two limb radii).
    pub visibility_margin_m: f64,
    /// Per-cycle jitter of the reach target, uniform ± per axis, m. Default 0.03.
    pub target_jitter_m: f64,
    /// Seed of the scene's randomness (targets, joint noise).
    pub seed: u64,
}

impl Default for AssemblySceneConfig {
    fn default() -> Self {
        Self {
            num_cycles: 25,
            cycle_s: 4.0,
            fps_hz: 30.0,
            camera_position_m: [0.3, -2.0, 1.7],
            camera_look_at_m: [0.5, -0.3, 1.1],
            image_width_px: 512,
            image_height_px: 424,
            horizontal_fov_rad: 70.6_f64.to_radians(),
            vertical_fov_rad: 60.0_f64.to_radians(),
            max_range_m: 4.5,
            robot_link_centre_m: [0.35, -1.05, 1.3],
            robot_link_direction: [1.0, 0.0],
            robot_link_amplitude_m: 0.5,
            robot_link_period_s: 2.9,
            robot_link_size_m: [0.15, 0.15, 0.6],
            noise: JointNoiseConfig::default(),
            visibility_margin_m: 0.10,
            target_jitter_m: 0.03,
            seed: 1,
        }
    }
}

/// Depth-dependent Gaussian noise of a tracked joint, per axis: `σ(z) = σ₀ + k·z²` (the
/// Kinect-like model of `nomen-sim`'s camera, with its defaults).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct JointNoiseConfig {
    /// σ at zero depth, m. Default 0.008.
    pub sigma_base_m: f64,
    /// Growth of σ with squared depth, m per m². Default 0.0015.
    pub sigma_per_depth2_m: f64,
}

impl Default for JointNoiseConfig {
    fn default() -> Self {
        Self {
            sigma_base_m: 0.008,
            sigma_per_depth2_m: 0.0015,
        }
    }
}

impl JointNoiseConfig {
    /// σ per axis of a tracked joint at depth `depth_m`, m.
    pub fn sigma_m(&self, depth_m: f64) -> f64 {
        self.sigma_base_m + self.sigma_per_depth2_m * depth_m * depth_m
    }
}

/// Upper-arm length of the simulated person, m.
pub const UPPER_ARM_M: f64 = 0.31;
/// Forearm length of the simulated person, m.
pub const FOREARM_M: f64 = 0.27;
/// Wrist → hand joint distance, m.
const HAND_M: f64 = 0.08;

/// The static furniture as boxes: table top and legs, and the shelf unit standing on the table
/// (open toward the person, four boards, two sides, a back).
pub fn assembly_furniture() -> Vec<BoxObstacle> {
    let b = BoxObstacle::from_corners;
    let mut v = vec![b("table_top", [0.30, -0.90, 0.72], [1.00, 0.40, 0.76])];
    for (i, (x, y)) in [(0.32, -0.88), (0.93, -0.88), (0.32, 0.33), (0.93, 0.33)]
        .into_iter()
        .enumerate()
    {
        v.push(b(
            &format!("table_leg_{i}"),
            [x, y, 0.0],
            [x + 0.05, y + 0.05, 0.72],
        ));
    }
    let (x0, x1, y0, y1) = (0.55, 0.87, -0.77, -0.13);
    for (i, z) in [0.76, 1.06, 1.38, 1.66].into_iter().enumerate() {
        v.push(b(
            &format!("shelf_board_{i}"),
            [x0, y0, z],
            [x1, y1, z + 0.02],
        ));
    }
    v.push(b("shelf_side_right", [x0, y0, 0.76], [x1, y0 + 0.02, 1.68]));
    v.push(b("shelf_side_left", [x0, y1 - 0.02, 0.76], [x1, y1, 1.68]));
    v.push(b("shelf_back", [x1 - 0.02, y0, 0.76], [x1, y1, 1.68]));
    v
}

/// The furniture as one triangle mesh (world frame, so `world_from_mesh` is the identity);
/// `tessellation` cuts every box face into `n × n` quads.
pub fn assembly_mesh(tessellation: u32) -> MeshData {
    let mut mesh = MeshData {
        name: "assembly_scene".into(),
        vertices_m: Vec::new(),
        triangles: Vec::new(),
    };
    for b in assembly_furniture() {
        mesh.push_tessellated_box(&b, tessellation);
    }
    mesh
}

/// One frame of the scene.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneFrame {
    /// Frame index.
    pub index: usize,
    /// Session time.
    pub t: SessionTime,
    /// Which reaching cycle (0-based).
    pub cycle: usize,
    /// True joint positions, world, m.
    pub truth: Joints<Point3<f64>>,
    /// The robot link at this time.
    pub robot_link: BoxObstacle,
}

/// The assembly scene.
#[derive(Debug, Clone)]
pub struct AssemblyScene {
    config: AssemblySceneConfig,
    environment: Environment,
    camera: PinholeCamera,
    radii: BodyRadii,
    targets_m: Vec<Point3<f64>>,
}

const SHOULDER: [f64; 3] = [0.20, -0.30, 1.42];
const REST: [f64; 3] = [0.40, -0.10, 0.95];
const ENTRY: [f64; 3] = [0.48, -0.42, 1.22];
const TARGET: [f64; 3] = [0.68, -0.45, 1.20];

fn p3(a: [f64; 3]) -> Point3<f64> {
    Point3::new(a[0], a[1], a[2])
}

/// Minimum-jerk blend `10τ³ − 15τ⁴ + 6τ⁵` between `a` and `b`.
fn min_jerk(a: &Point3<f64>, b: &Point3<f64>, tau: f64) -> Point3<f64> {
    let s = tau.clamp(0.0, 1.0);
    let s = s * s * s * (10.0 - 15.0 * s + 6.0 * s * s);
    a + (b - a) * s
}

/// Two-link inverse kinematics: the elbow for shoulder `s` and desired wrist `w`, elbow toward
/// `pole`; the wrist is moved along the shoulder→wrist line when out of reach.
fn two_link_ik(
    s: &Point3<f64>,
    w: &Point3<f64>,
    l1: f64,
    l2: f64,
    pole: &Vector3<f64>,
) -> (Point3<f64>, Point3<f64>) {
    let sw = w - s;
    let e_axis = sw.try_normalize(1e-9).unwrap_or_else(Vector3::x);
    let d = sw.norm().clamp((l1 - l2).abs() + 1e-3, l1 + l2 - 1e-3);
    let a = (l1 * l1 - l2 * l2 + d * d) / (2.0 * d);
    let h = (l1 * l1 - a * a).max(0.0).sqrt();
    let perp = (pole - e_axis * pole.dot(&e_axis))
        .try_normalize(1e-9)
        .unwrap_or_else(|| e_axis.cross(&Vector3::z()).normalize());
    let elbow = s + e_axis * a + perp * h;
    (elbow, s + e_axis * d)
}

impl AssemblyScene {
    /// Builds the scene: furniture meshes, camera, per-cycle targets.
    ///
    /// # Errors
    /// [`OcclusionError::Config`] when a number is out of range or the camera looks straight
    /// up or down.
    pub fn new(config: AssemblySceneConfig) -> Result<Self> {
        let positive = [
            ("cycle_s", config.cycle_s),
            ("fps_hz", config.fps_hz),
            ("max_range_m", config.max_range_m),
            ("robot_link_period_s", config.robot_link_period_s),
            ("horizontal_fov_rad", config.horizontal_fov_rad),
            ("vertical_fov_rad", config.vertical_fov_rad),
        ];
        for (name, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(OcclusionError::Config(format!(
                    "scene {name} must be > 0, got {v}"
                )));
            }
        }
        if config.image_width_px == 0 || config.image_height_px == 0 {
            return Err(OcclusionError::Config(
                "scene image size must be > 0".into(),
            ));
        }
        let eye = Vector3::from(config.camera_position_m);
        let forward = Vector3::from(config.camera_look_at_m) - eye;
        let right = forward.cross(&Vector3::z());
        let (Some(z), Some(x)) = (forward.try_normalize(1e-9), right.try_normalize(1e-9)) else {
            return Err(OcclusionError::Config(
                "scene camera must not look straight up or down".into(),
            ));
        };
        let y = z.cross(&x);
        let rot = Rotation3::from_matrix_unchecked(nalgebra::Matrix3::from_columns(&[x, y, z]));
        let world_from_camera = Isometry3::from_parts(
            Translation3::from(eye),
            UnitQuaternion::from_rotation_matrix(&rot),
        );
        let (w, h) = (config.image_width_px, config.image_height_px);
        let intrinsics = CameraIntrinsics {
            width_px: w,
            height_px: h,
            fx_px: 0.5 * f64::from(w) / (config.horizontal_fov_rad * 0.5).tan(),
            fy_px: 0.5 * f64::from(h) / (config.vertical_fov_rad * 0.5).tan(),
            cx_px: 0.5 * f64::from(w),
            cy_px: 0.5 * f64::from(h),
        };
        let environment = Environment::from_meshes(&[(assembly_mesh(1), Isometry3::identity())])?;
        let mut rng = ChaCha8Rng::seed_from_u64(config.seed ^ 0x7A26_E7A1);
        let j = config.target_jitter_m.abs();
        let targets_m = (0..config.num_cycles)
            .map(|_| {
                let mut jitter = || j * (2.0 * rng.random::<f64>() - 1.0);
                p3(TARGET) + Vector3::new(jitter(), jitter(), jitter())
            })
            .collect();
        Ok(Self {
            camera: PinholeCamera::new(intrinsics, world_from_camera),
            environment,
            radii: BodyRadii::default(),
            targets_m,
            config,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &AssemblySceneConfig {
        &self.config
    }

    /// The static environment (furniture).
    pub fn environment(&self) -> &Environment {
        &self.environment
    }

    /// The depth camera.
    pub fn camera(&self) -> &PinholeCamera {
        &self.camera
    }

    /// Number of frames over all cycles.
    pub fn num_frames(&self) -> usize {
        (self.config.num_cycles as f64 * self.config.cycle_s * self.config.fps_hz).round() as usize
    }

    /// The robot link at time `t_s`.
    pub fn robot_link_at(&self, t_s: f64) -> BoxObstacle {
        let c = &self.config;
        let dir = Vector3::new(c.robot_link_direction[0], c.robot_link_direction[1], 0.0)
            .try_normalize(1e-9)
            .unwrap_or_else(Vector3::y);
        let offset = dir
            * c.robot_link_amplitude_m
            * (2.0 * std::f64::consts::PI * t_s / c.robot_link_period_s).sin();
        let centre = p3(c.robot_link_centre_m) + offset;
        BoxObstacle {
            name: "robot_link".into(),
            centre_m: [centre.x, centre.y, centre.z],
            size_m: c.robot_link_size_m,
            yaw_rad: dir.y.atan2(dir.x),
        }
    }

    /// True wrist position at time `t_s`, and the cycle.
    fn wrist_path(&self, t_s: f64) -> (Point3<f64>, usize) {
        let c = &self.config;
        let cycle =
            ((t_s / c.cycle_s).floor().max(0.0) as usize).min(c.num_cycles.saturating_sub(1));
        let tau = (t_s / c.cycle_s - cycle as f64).clamp(0.0, 1.0);
        let target = self
            .targets_m
            .get(cycle)
            .copied()
            .unwrap_or_else(|| p3(TARGET));
        let (rest, entry) = (p3(REST), p3(ENTRY));
        let seg = |a: f64, b: f64| (tau - a) / (b - a);
        let w = match tau {
            x if x < 0.15 => rest,
            x if x < 0.30 => min_jerk(&rest, &entry, seg(0.15, 0.30)),
            x if x < 0.42 => min_jerk(&entry, &target, seg(0.30, 0.42)),
            x if x < 0.62 => {
                // Small working motion inside the compartment.
                let s = (2.0 * std::f64::consts::PI * seg(0.42, 0.62)).sin();
                target + Vector3::new(0.0, 0.02 * s, 0.01 * s)
            }
            x if x < 0.74 => min_jerk(&target, &entry, seg(0.62, 0.74)),
            x if x < 0.89 => min_jerk(&entry, &rest, seg(0.74, 0.89)),
            _ => rest,
        };
        (w, cycle)
    }

    /// The frame with index `k`.
    pub fn frame(&self, k: usize) -> SceneFrame {
        let t_s = k as f64 / self.config.fps_hz;
        let (w_goal, cycle) = self.wrist_path(t_s);
        let s = p3(SHOULDER);
        let pole = Vector3::new(0.0, -0.5, -1.0);
        let (elbow, wrist) = two_link_ik(&s, &w_goal, UPPER_ARM_M, FOREARM_M, &pole);
        let hand = wrist + (wrist - elbow).normalize() * HAND_M;
        let mut truth = Joints::new();
        let (x, y) = (0.20, -0.11);
        let fixed = [
            (Joint::Pelvis, [x, y, 1.00]),
            (Joint::Chest, [x, y, 1.22]),
            (Joint::Neck, [x, y, 1.47]),
            (Joint::Head, [x, y, 1.62]),
            (Joint::LeftShoulder, [x, 0.08, 1.42]),
            (Joint::LeftElbow, [x - 0.02, 0.10, 1.12]),
            (Joint::LeftWrist, [x + 0.03, 0.10, 0.86]),
            (Joint::LeftHand, [x + 0.04, 0.10, 0.78]),
            (Joint::LeftHip, [x, 0.0, 0.95]),
            (Joint::LeftKnee, [x + 0.02, 0.0, 0.52]),
            (Joint::LeftAnkle, [x, 0.0, 0.08]),
            (Joint::LeftFoot, [x + 0.12, 0.0, 0.02]),
            (Joint::RightHip, [x, -0.22, 0.95]),
            (Joint::RightKnee, [x + 0.02, -0.22, 0.52]),
            (Joint::RightAnkle, [x, -0.22, 0.08]),
            (Joint::RightFoot, [x + 0.12, -0.22, 0.02]),
            (Joint::RightShoulder, SHOULDER),
        ];
        for (j, p) in fixed {
            truth.insert(j, p3(p));
        }
        truth.insert(Joint::RightElbow, elbow);
        truth.insert(Joint::RightWrist, wrist);
        truth.insert(Joint::RightHand, hand);
        SceneFrame {
            index: k,
            t: SessionTime::from_ns((t_s * 1e9).round() as i64),
            cycle,
            truth,
            robot_link: self.robot_link_at(t_s),
        }
    }

    /// A lazily rendered depth image of this scene; call [`SceneDepth::set_frame`] per frame.
    pub fn depth_probe(&self) -> SceneDepth<'_> {
        let n =
            self.camera.intrinsics.width_px as usize * self.camera.intrinsics.height_px as usize;
        SceneDepth {
            scene: self,
            capsules: Vec::with_capacity(nomen_core::skeleton::NUM_JOINTS),
            link: self.robot_link_at(0.0),
            generation: 1,
            cache_generation: vec![0; n],
            cache_depth_m: vec![0.0; n],
            filled_generation: vec![0; n],
            filled_depth_m: vec![0.0; n],
            filled_radius_px: None,
            num_rays: 0,
        }
    }

    /// The whole depth image of a frame at the camera's resolution.
    pub fn render_depth_map(&self, frame: &SceneFrame) -> DepthMap {
        let mut probe = self.depth_probe();
        probe.set_frame(frame);
        DepthMap::render(
            self.camera.clone(),
            self.config.max_range_m,
            |o, d, max_t| probe.cast(o, d, max_t),
        )
    }

    /// What the camera reports for a frame: joints that pass the depth test, with noise.
    /// Trunk, head and leg joints are always reported (the shelf and the link hide only the
    /// arm in this scene); arm joints only when visible.
    pub fn observe(
        &self,
        frame: &SceneFrame,
        depth: &mut SceneDepth<'_>,
        rng: &mut ChaCha8Rng,
    ) -> Joints<Point3<f64>> {
        let mut out = Joints::new();
        for (j, p) in frame.truth.iter() {
            let is_arm = matches!(
                j,
                Joint::LeftElbow
                    | Joint::LeftWrist
                    | Joint::LeftHand
                    | Joint::RightElbow
                    | Joint::RightWrist
                    | Joint::RightHand
            );
            let Some((u, v, z)) = self.camera.project(p) else {
                continue;
            };
            if is_arm {
                let Some((pu, pv)) = self.camera.pixel(u, v) else {
                    continue;
                };
                let d = f64::from(depth.raw_depth_m(pu, pv));
                if d > 0.0 && d < z - self.config.visibility_margin_m {
                    continue;
                }
            }
            let sigma = self.config.noise.sigma_m(z);
            let n = Vector3::new(
                rng.sample::<f64, _>(StandardNormal),
                rng.sample::<f64, _>(StandardNormal),
                rng.sample::<f64, _>(StandardNormal),
            ) * sigma;
            out.insert(j, p + n);
        }
        out
    }
}

/// A depth image of the scene rendered pixel by pixel on demand and cached for the frame.
#[derive(Debug)]
pub struct SceneDepth<'a> {
    scene: &'a AssemblyScene,
    capsules: Vec<Capsule>,
    link: BoxObstacle,
    generation: u32,
    cache_generation: Vec<u32>,
    cache_depth_m: Vec<f32>,
    /// Hole-filled depth per pixel for [`Self::filled_radius_px`] (NaN: nothing within the
    /// radius), valid where `filled_generation` is the frame's generation.
    filled_generation: Vec<u32>,
    filled_depth_m: Vec<f32>,
    /// The fill radius the cached filled depths were computed with.
    filled_radius_px: Option<u32>,
    num_rays: u64,
}

impl SceneDepth<'_> {
    /// Moves the person and the robot link to this frame and forgets the cached pixels.
    pub fn set_frame(&mut self, frame: &SceneFrame) {
        self.capsules.clear();
        for (j, p) in frame.truth.iter() {
            let Some(parent) = j.parent().and_then(|pj| frame.truth.get(pj)) else {
                continue;
            };
            let r = self.scene.radii.bone_radius_m(j);
            if r > 0.0 {
                self.capsules.push(Capsule {
                    a_m: *parent,
                    b_m: *p,
                    radius_m: r,
                });
            }
        }
        self.link = frame.robot_link.clone();
        self.generation = self.generation.wrapping_add(1).max(1);
        if self.generation == 1 {
            self.cache_generation.iter_mut().for_each(|g| *g = 0);
            self.filled_generation.iter_mut().for_each(|g| *g = 0);
        }
    }

    /// Pixels ray-cast so far.
    pub fn num_rays(&self) -> u64 {
        self.num_rays
    }

    fn cast(&self, o: &Point3<f64>, d: &Vector3<f64>, max_t: f64) -> Option<f64> {
        let mut best = self.scene.environment.cast_ray_static(o, d, max_t);
        let mut limit = best.unwrap_or(max_t);
        // Bounding spheres first: the exact tests live in another crate and are the costly part.
        let misses = |centre: &Point3<f64>, radius: f64, limit: f64| {
            let dd = d.norm_squared();
            let s = ((centre - o).dot(d) / dd).clamp(0.0, limit);
            (o + d * s - centre).norm_squared() > radius * radius
        };
        let half = Vector3::from(self.link.size_m) * 0.5;
        let link_centre = Point3::from(self.link.centre_m);
        if !misses(&link_centre, half.norm(), limit)
            && let Some(t) = self.link.ray_cast(o, d, limit)
        {
            best = Some(t);
            limit = t;
        }
        for c in &self.capsules {
            let centre = nalgebra::center(&c.a_m, &c.b_m);
            if misses(&centre, 0.5 * (c.b_m - c.a_m).norm() + c.radius_m, limit) {
                continue;
            }
            if let Some(t) = c.ray_cast(o, d, limit) {
                best = Some(t);
                limit = t;
            }
        }
        best
    }
}

impl DepthProbe for SceneDepth<'_> {
    fn camera(&self) -> &PinholeCamera {
        &self.scene.camera
    }

    fn raw_depth_m(&mut self, u: u32, v: u32) -> f32 {
        let w = self.scene.camera.intrinsics.width_px;
        let i = v as usize * w as usize + u as usize;
        if u >= w || i >= self.cache_depth_m.len() {
            return 0.0;
        }
        if self.cache_generation[i] != self.generation {
            let (o, d) = self.scene.camera.pixel_ray(u, v);
            self.num_rays += 1;
            self.cache_depth_m[i] = self
                .cast(&o, &d, self.scene.config.max_range_m)
                .map_or(0.0, |t| t as f32);
            self.cache_generation[i] = self.generation;
        }
        self.cache_depth_m[i]
    }

    fn filled_depth_m(&mut self, u: u32, v: u32, max_radius_px: u32) -> Option<f32> {
        let w = self.scene.camera.intrinsics.width_px;
        let i = v as usize * w as usize + u as usize;
        if u >= w || i >= self.filled_depth_m.len() {
            return crate::depth::filled_depth_m(self, u, v, max_radius_px);
        }
        if self.filled_radius_px != Some(max_radius_px) {
            // A new radius invalidates every cached fill.
            self.filled_radius_px = Some(max_radius_px);
            self.filled_generation.iter_mut().for_each(|g| *g = 0);
        }
        if self.filled_generation[i] != self.generation {
            self.filled_depth_m[i] =
                crate::depth::filled_depth_m(self, u, v, max_radius_px).unwrap_or(f32::NAN);
            self.filled_generation[i] = self.generation;
        }
        let d = self.filled_depth_m[i];
        (!d.is_nan()).then_some(d)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene() -> AssemblyScene {
        AssemblyScene::new(AssemblySceneConfig::default()).unwrap()
    }

    #[test]
    fn bones_keep_their_length_and_the_forearm_never_crosses_furniture() {
        let s = scene();
        for k in (0..s.num_frames()).step_by(7) {
            let f = s.frame(k);
            let sh = f.truth.get(Joint::RightShoulder).unwrap();
            let e = f.truth.get(Joint::RightElbow).unwrap();
            let w = f.truth.get(Joint::RightWrist).unwrap();
            assert!(((e - sh).norm() - UPPER_ARM_M).abs() < 1e-9);
            assert!(((w - e).norm() - FOREARM_M).abs() < 1e-9);
            assert!(
                s.environment().first_hit_on_segment(e, w).is_none(),
                "frame {k}"
            );
            assert!(
                s.environment().first_hit_on_segment(sh, e).is_none(),
                "frame {k}"
            );
        }
    }

    #[test]
    fn hand_in_the_shelf_is_hidden_and_hand_at_rest_is_seen() {
        let s = scene();
        let mut depth = s.depth_probe();
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let per_cycle = (s.config().cycle_s * s.config().fps_hz) as usize;
        // Middle of the hold phase: inside the compartment.
        let inside = s.frame(per_cycle / 2);
        depth.set_frame(&inside);
        let seen = s.observe(&inside, &mut depth, &mut rng);
        assert!(seen.get(Joint::RightWrist).is_none());
        assert!(seen.get(Joint::Pelvis).is_some());
        // Count: the wrist is hidden in a fair share of frames, seen in others.
        let mut hidden = 0;
        for k in 0..per_cycle {
            let f = s.frame(k);
            depth.set_frame(&f);
            hidden += usize::from(
                s.observe(&f, &mut depth, &mut rng)
                    .get(Joint::RightWrist)
                    .is_none(),
            );
        }
        assert!(
            hidden > per_cycle / 5 && hidden < per_cycle * 4 / 5,
            "{hidden}/{per_cycle}"
        );
    }

    #[test]
    fn cached_hole_filling_equals_the_search() {
        let s = AssemblyScene::new(AssemblySceneConfig {
            image_width_px: 96,
            image_height_px: 80,
            ..AssemblySceneConfig::default()
        })
        .unwrap();
        let mut cached = s.depth_probe();
        let mut plain = s.depth_probe();
        for k in [0, 60] {
            let f = s.frame(k);
            cached.set_frame(&f);
            plain.set_frame(&f);
            // Twice over the image, the second time from the cache; radius 3 leaves some
            // pixels without any return near them.
            for _ in 0..2 {
                for v in (0..80).step_by(3) {
                    for u in (0..96).step_by(3) {
                        let by_cache = DepthProbe::filled_depth_m(&mut cached, u, v, 3);
                        let by_search = crate::depth::filled_depth_m(&mut plain, u, v, 3);
                        assert_eq!(by_cache, by_search, "frame {k}, pixel ({u}, {v})");
                    }
                }
            }
        }
    }

    #[test]
    fn full_depth_map_has_the_camera_resolution_and_sees_the_shelf() {
        // A quarter of the Kinect resolution keeps the unoptimised test build quick.
        let s = AssemblyScene::new(AssemblySceneConfig {
            image_width_px: 128,
            image_height_px: 106,
            ..AssemblySceneConfig::default()
        })
        .unwrap();
        let f = s.frame(0);
        let map = s.render_depth_map(&f);
        assert_eq!(map.depth_m.len(), 128 * 106);
        // The shelf's right side wall faces the camera.
        let shelf_centre = Point3::new(0.71, -0.77, 1.2);
        let (u, v, z) = s.camera().project(&shelf_centre).unwrap();
        let (pu, pv) = s.camera().pixel(u, v).unwrap();
        assert!((f64::from(map.at(pu, pv)) - z).abs() < 0.1);
    }
}
