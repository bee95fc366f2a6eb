//! The camera model and its frame-by-frame simulator.

use super::config::CameraModelConfig;
use crate::body::{BodyMotion, BodyPose};
use crate::error::{Result, SimError};
use crate::geometry::{BodyCapsules, BodyRadii, BoxObstacle, obstacles_block_segment};
use crate::rng::SimRng;
use nalgebra::{Isometry3, Matrix3, Point3, Rotation3, Translation3, UnitQuaternion, Vector3};
use nomen_core::skeleton::{Joint, Joints, NUM_JOINTS};
use nomen_core::{
    Camera, CameraId, CameraIntrinsics, ClockModel, JointObservation, JointState, RigidTransform,
    SessionTime, SkeletonObservation, SubjectId, TrackId, TruthSkeleton,
};
use rand::Rng;
use rand_distr::StandardNormal;

/// One person in front of the camera.
pub struct PersonInScene<'a> {
    /// The physical person's name (ground truth only).
    pub person: String,
    /// The registered subject this person is, if any (ground truth only).
    pub subject: Option<SubjectId>,
    /// How the person moves; not in the room outside its span and while away
    /// ([`BodyMotion::is_present_at`]).
    pub motion: &'a dyn BodyMotion,
    /// Body capsule radii used for occlusion.
    pub radii: BodyRadii,
}

impl<'a> PersonInScene<'a> {
    /// A person with default body radii.
    pub fn new(
        person: impl Into<String>,
        subject: Option<SubjectId>,
        motion: &'a dyn BodyMotion,
    ) -> Self {
        Self {
            person: person.into(),
            subject,
            motion,
            radii: BodyRadii::default(),
        }
    }
}

/// Everything one camera reported, with ground truth: `truths[i]` belongs to `observations[i]`
/// (same time, camera and track).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CameraOutput {
    /// Skeletons as the SDK reports them (camera frame), in time order.
    pub observations: Vec<SkeletonObservation>,
    /// Who each skeleton really is and where its joints really were (world frame).
    pub truths: Vec<TruthSkeleton>,
}

/// A validated camera: pose, frustum and behaviour.
#[derive(Debug, Clone)]
pub struct CameraModel {
    config: CameraModelConfig,
    id: CameraId,
    world_from_camera: Isometry3<f64>,
    camera_from_world: Isometry3<f64>,
    tan_half_h: f64,
    tan_half_v: f64,
}

impl CameraModel {
    /// Validates the configuration and builds the camera pose from position and look-at point.
    pub fn new(config: CameraModelConfig) -> Result<Self> {
        config.validate()?;
        let world_from_camera = look_at(&config)?;
        Ok(Self {
            id: CameraId::new(config.id.clone()),
            world_from_camera,
            camera_from_world: world_from_camera.inverse(),
            tan_half_h: (config.horizontal_fov_rad * 0.5).tan(),
            tan_half_v: (config.vertical_fov_rad * 0.5).tan(),
            config,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &CameraModelConfig {
        &self.config
    }

    /// The camera id.
    pub fn id(&self) -> &CameraId {
        &self.id
    }

    /// Maps camera-frame points (+Z forward, +X right, +Y down) into the world (Z up).
    pub fn world_from_camera(&self) -> Isometry3<f64> {
        self.world_from_camera
    }

    /// Pinhole intrinsics matching the field of view and image size (no distortion).
    pub fn intrinsics(&self) -> CameraIntrinsics {
        let (w, h) = (self.config.image_width_px, self.config.image_height_px);
        CameraIntrinsics {
            width_px: w,
            height_px: h,
            fx_px: 0.5 * f64::from(w) / self.tan_half_h,
            fy_px: 0.5 * f64::from(h) / self.tan_half_v,
            cx_px: 0.5 * f64::from(w),
            cy_px: 0.5 * f64::from(h),
        }
    }

    /// The registry entry for this camera (clock on the session clock). A position-only
    /// tracker is registered at the identity, scale 1, without intrinsics: its frame is what a
    /// calibration finds.
    pub fn registry_camera(&self) -> Camera {
        if self.config.position_only.is_some() {
            return Camera {
                fps_hz: Some(self.config.fps_hz),
                ..Camera::new(self.id.clone(), RigidTransform::IDENTITY)
            };
        }
        Camera {
            id: self.id.clone(),
            world_from_camera: RigidTransform::from_isometry(&self.world_from_camera),
            scale: 1.0,
            intrinsics: Some(self.intrinsics()),
            fps_hz: Some(self.config.fps_hz),
            clock: ClockModel::default(),
        }
    }

    /// Whether a camera-frame point is inside the field of view and depth range.
    pub fn sees(&self, p_camera: &Point3<f64>) -> bool {
        let z = p_camera.z;
        z >= self.config.min_range_m
            && z <= self.config.max_range_m
            && p_camera.x.abs() <= z * self.tan_half_h
            && p_camera.y.abs() <= z * self.tan_half_v
    }

    /// Time of frame `k` for a run starting at `t0`, rounded to the nanosecond.
    pub fn frame_time(&self, t0: SessionTime, k: u64) -> SessionTime {
        let offset_ns = (k as f64 * 1e9 / self.config.fps_hz).round();
        t0 + offset_ns as i64
    }

    /// Simulates every frame in `[t0_s, t1_s]` (session seconds) and returns what the camera
    /// reported, with ground truth. A camera with a `tracking.relabel_rate_hz` needs
    /// [`CameraModel::simulate_with_relabel_rng`].
    pub fn simulate(
        &self,
        people: &[PersonInScene<'_>],
        obstacles: &[BoxObstacle],
        t0_s: f64,
        t1_s: f64,
        rng: &mut SimRng,
    ) -> Result<CameraOutput> {
        self.simulate_inner(people, obstacles, t0_s, t1_s, rng, None)
    }

    /// As [`CameraModel::simulate`], with the stream that decides when tracked bodies are
    /// re-labelled (`tracking.relabel_rate_hz`; the scene uses `camera/<id>/relabel`), kept apart
    /// from `rng` so that re-labelling leaves the joint noise unchanged.
    pub fn simulate_with_relabel_rng(
        &self,
        people: &[PersonInScene<'_>],
        obstacles: &[BoxObstacle],
        t0_s: f64,
        t1_s: f64,
        rng: &mut SimRng,
        relabel_rng: SimRng,
    ) -> Result<CameraOutput> {
        self.simulate_inner(people, obstacles, t0_s, t1_s, rng, Some(relabel_rng))
    }

    fn simulate_inner(
        &self,
        people: &[PersonInScene<'_>],
        obstacles: &[BoxObstacle],
        t0_s: f64,
        t1_s: f64,
        rng: &mut SimRng,
        relabel_rng: Option<SimRng>,
    ) -> Result<CameraOutput> {
        let (Some(t0), Some(t1)) = (
            SessionTime::from_secs_f64(t0_s),
            SessionTime::from_secs_f64(t1_s),
        ) else {
            return Err(SimError::InvalidScenario(format!(
                "camera '{}': time span [{t0_s}, {t1_s}] s is not finite",
                self.id
            )));
        };
        let mut sim = CameraSimulator::new(self.clone(), people, rng)?;
        if let Some(r) = relabel_rng {
            sim = sim.with_relabel_rng(r);
        }
        let mut out = CameraOutput::default();
        let expected = ((t1_s - t0_s).max(0.0) * self.config.fps_hz) as usize + 1;
        out.observations.reserve(expected * people.len());
        out.truths.reserve(expected * people.len());
        let mut k = 0_u64;
        loop {
            let t = self.frame_time(t0, k);
            if t > t1 {
                break;
            }
            sim.step(t, people, obstacles, rng, &mut out)?;
            k += 1;
        }
        Ok(out)
    }
}

/// `world_from_camera` from position and look-at point, no roll: camera +X = forward × world
/// up (horizontal, to the right), +Y = forward × +X (downward), +Z = forward.
fn look_at(config: &CameraModelConfig) -> Result<Isometry3<f64>> {
    let eye = Vector3::from(config.position_m);
    let forward = Vector3::from(config.look_at_m) - eye;
    let up = Vector3::z();
    let right = forward.cross(&up);
    let (fn_, rn) = (forward.norm(), right.norm());
    if !(fn_ > 1e-9 && rn > 1e-6 * fn_) {
        return Err(SimError::InvalidScenario(format!(
            "camera '{}': look_at_m must differ from position_m and not be straight above or below it",
            config.id
        )));
    }
    let z = forward / fn_;
    let x = right / rn;
    let y = z.cross(&x);
    let rot = Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[x, y, z]));
    Ok(Isometry3::from_parts(
        Translation3::from(eye),
        UnitQuaternion::from_rotation_matrix(&rot),
    ))
}

/// Joints on the trunk and head, which self-occlusion never hides.
pub(crate) fn is_limb(j: Joint) -> bool {
    !matches!(
        j,
        Joint::Pelvis
            | Joint::Chest
            | Joint::Neck
            | Joint::Head
            | Joint::LeftShoulder
            | Joint::RightShoulder
            | Joint::LeftHip
            | Joint::RightHip
    )
}

/// What the simulator remembers about one person between frames.
#[derive(Clone)]
struct PersonState {
    is_present: bool,
    pose: BodyPose,
    capsules: BodyCapsules,
    pelvis_w: Point3<f64>,
    pelvis_c: Point3<f64>,
    is_visible: [bool; NUM_JOINTS],
    hidden_since_s: [Option<f64>; NUM_JOINTS],
    offset_from_pelvis_w: [Vector3<f64>; NUM_JOINTS],
    noise_unit: [Vector3<f64>; NUM_JOINTS],
    is_noise_started: bool,
    /// Present again this frame after an absence.
    is_back: bool,
    is_body_visible: bool,
    is_in_view: bool,
    track: Option<TrackId>,
    num_acquire_frames: u32,
    lost_since_s: Option<f64>,
    flip_until_s: f64,
}

impl Default for PersonState {
    fn default() -> Self {
        Self {
            is_present: false,
            pose: BodyPose::new(),
            capsules: BodyCapsules::default(),
            pelvis_w: Point3::origin(),
            pelvis_c: Point3::origin(),
            is_visible: [false; NUM_JOINTS],
            hidden_since_s: [None; NUM_JOINTS],
            offset_from_pelvis_w: [Vector3::zeros(); NUM_JOINTS],
            noise_unit: [Vector3::zeros(); NUM_JOINTS],
            is_noise_started: false,
            is_back: false,
            is_body_visible: false,
            is_in_view: false,
            track: None,
            num_acquire_frames: 0,
            lost_since_s: None,
            flip_until_s: f64::NEG_INFINITY,
        }
    }
}

/// Frame-by-frame simulation of one camera, for callers that interleave devices in time.
///
/// State (tracks, per-joint occlusion timers, noise) lives here; every buffer is allocated once
/// in [`CameraSimulator::new`], so a step allocates only the messages it emits.
pub struct CameraSimulator {
    model: CameraModel,
    people: Vec<PersonState>,
    /// `is_close[i * n + k]` for `i < k`: the pair is in a close encounter.
    is_close: Vec<bool>,
    /// Scratch: people that start a new track this frame, with their depth.
    new_tracks: Vec<(f64, usize)>,
    /// Scratch: capsules of present people (absent people get an empty, far-away body).
    capsules: Vec<BodyCapsules>,
    next_track: u64,
    last_t_s: Option<f64>,
    /// Decides re-labelling (`tracking.relabel_rate_hz`); separate from the noise stream.
    relabel_rng: Option<SimRng>,
}

impl CameraSimulator {
    /// A simulator for `people` (the same list, in the same order, must be passed to every
    /// step). Draws the first track id from `rng`.
    pub fn new(model: CameraModel, people: &[PersonInScene<'_>], rng: &mut SimRng) -> Result<Self> {
        for p in people {
            p.radii
                .validate()
                .map_err(|e| SimError::InvalidScenario(format!("person '{}': {e}", p.person)))?;
        }
        let n = people.len();
        let next_track = rng.random_range(1..=model.config.tracking.track_id_base_max);
        Ok(Self {
            model,
            people: vec![PersonState::default(); n],
            is_close: vec![false; n * n],
            new_tracks: Vec::with_capacity(n),
            capsules: vec![BodyCapsules::default(); n],
            next_track,
            last_t_s: None,
            relabel_rng: None,
        })
    }

    /// Gives the simulator the stream that decides re-labelling; required when
    /// `tracking.relabel_rate_hz` is positive.
    pub fn with_relabel_rng(mut self, rng: SimRng) -> Self {
        self.relabel_rng = Some(rng);
        self
    }

    /// The camera.
    pub fn model(&self) -> &CameraModel {
        &self.model
    }

    /// Simulates the frame at `t` and appends what the camera reports to `out`.
    pub fn step(
        &mut self,
        t: SessionTime,
        people: &[PersonInScene<'_>],
        obstacles: &[BoxObstacle],
        rng: &mut SimRng,
        out: &mut CameraOutput,
    ) -> Result<()> {
        if people.len() != self.people.len() {
            return Err(SimError::InvalidScenario(format!(
                "camera '{}': simulator built for {} people, step given {}",
                self.model.id,
                self.people.len(),
                people.len()
            )));
        }
        let t_s = t.as_secs_f64();
        let dt_s = match self.last_t_s {
            Some(prev) if t_s > prev => t_s - prev,
            _ => 1.0 / self.model.config.fps_hz,
        };
        self.last_t_s = Some(t_s);
        if self.model.config.tracking.relabel_rate_hz > 0.0 && self.relabel_rng.is_none() {
            return Err(SimError::InvalidScenario(format!(
                "camera '{}': tracking.relabel_rate_hz is set but the simulator has no relabel \
                 stream (use CameraSimulator::with_relabel_rng)",
                self.model.id
            )));
        }
        for obstacle in obstacles {
            obstacle.validate().map_err(SimError::InvalidScenario)?;
        }
        self.update_poses(t_s, people);
        self.update_visibility(t_s, obstacles);
        self.update_tracks(t_s, dt_s);
        self.update_swaps(rng);
        self.emit(t, t_s, dt_s, people, rng, out);
        Ok(())
    }

    fn update_poses(&mut self, t_s: f64, people: &[PersonInScene<'_>]) {
        for ((state, person), caps) in self.people.iter_mut().zip(people).zip(&mut self.capsules) {
            let was_present = state.is_present;
            state.is_present = person.motion.is_present_at(t_s);
            if state.is_present && !was_present && state.is_noise_started {
                // Back from an absence: what the camera held of the joints is stale.
                state.hidden_since_s = [None; NUM_JOINTS];
                state.is_back = true;
            }
            if !state.is_present {
                // A body nobody can hit: zero radius, far below the floor.
                *caps = BodyCapsules {
                    centre_m: Point3::new(0.0, 0.0, -1e6),
                    bound_radius_m: 0.0,
                    ..BodyCapsules::default()
                };
                continue;
            }
            state.pose = person.motion.pose_at(t_s);
            state.capsules.update(&state.pose, &person.radii);
            *caps = state.capsules;
            state.pelvis_w = joint_position(&state.pose, Joint::Pelvis);
            state.pelvis_c = self.model.camera_from_world * state.pelvis_w;
        }
    }

    fn update_visibility(&mut self, t_s: f64, obstacles: &[BoxObstacle]) {
        let eye = Point3::from(self.model.world_from_camera.translation.vector);
        let occ = &self.model.config.occlusion;
        for (i, state) in self.people.iter_mut().enumerate() {
            if !state.is_present {
                state.is_body_visible = false;
                state.is_in_view = false;
                continue;
            }
            let mut num_visible = 0_usize;
            for j in Joint::ALL {
                let p_w = joint_position(&state.pose, j);
                let p_c = self.model.camera_from_world * p_w;
                let is_self_hidden = occ.self_occlusion
                    && is_limb(j)
                    && [Joint::Chest, Joint::Neck].iter().any(|b| {
                        state
                            .capsules
                            .bone(*b)
                            .is_some_and(|c| c.intersects_segment(&eye, &p_w))
                    });
                let is_visible = self.model.sees(&p_c)
                    && !is_self_hidden
                    && !obstacles_block_segment(obstacles, &eye, &p_w)
                    && !self
                        .capsules
                        .iter()
                        .enumerate()
                        .any(|(k, body)| k != i && body.intersects_segment(&eye, &p_w));
                let ji = j.index();
                state.is_visible[ji] = is_visible;
                if is_visible {
                    num_visible += 1;
                    state.hidden_since_s[ji] = None;
                    state.offset_from_pelvis_w[ji] = p_w - state.pelvis_w;
                } else if state.hidden_since_s[ji].is_none() {
                    state.hidden_since_s[ji] = Some(t_s);
                    if !state.is_noise_started || state.is_back {
                        // Never seen (since coming back): hold the true offset of this frame.
                        state.offset_from_pelvis_w[ji] = p_w - state.pelvis_w;
                    }
                }
            }
            state.is_back = false;
            state.is_in_view = self.model.sees(&state.pelvis_c);
            state.is_body_visible = state.is_in_view
                && num_visible as f64 >= occ.min_visible_fraction * NUM_JOINTS as f64;
        }
    }

    fn update_tracks(&mut self, t_s: f64, dt_s: f64) {
        let tr = &self.model.config.tracking;
        // Probability that a tracked body is re-labelled during this frame (Poisson process).
        let p_relabel = if tr.relabel_rate_hz > 0.0 {
            1.0 - (-tr.relabel_rate_hz * dt_s).exp()
        } else {
            0.0
        };
        self.new_tracks.clear();
        for (i, state) in self.people.iter_mut().enumerate() {
            if state.is_body_visible {
                state.lost_since_s = None;
                if state.track.is_some()
                    && p_relabel > 0.0
                    && let Some(rng) = self.relabel_rng.as_mut()
                    && rng.random::<f64>() < p_relabel
                {
                    // The SDK loses the body and acquires it again as a new one.
                    state.track = None;
                    state.num_acquire_frames = 0;
                }
                if state.track.is_none() {
                    state.num_acquire_frames = state.num_acquire_frames.saturating_add(1);
                    if state.num_acquire_frames > tr.new_body_delay_frames {
                        self.new_tracks.push((state.pelvis_c.z, i));
                    }
                }
                continue;
            }
            state.num_acquire_frames = 0;
            if state.track.is_some() {
                // Leaving the field of view or range ends the track at once (re-entry gets a
                // new id); an occlusion ends it only when it lasts too long.
                let lost_since = *state.lost_since_s.get_or_insert(t_s);
                if !state.is_in_view || t_s - lost_since > tr.keep_id_max_gap_s {
                    state.track = None;
                    state.lost_since_s = None;
                }
            }
        }
        // Nearest first, so that ids follow the scene, not the order of the people list.
        self.new_tracks
            .sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        for &(_, i) in &self.new_tracks {
            if let Some(state) = self.people.get_mut(i) {
                state.track = Some(TrackId(self.next_track));
                state.flip_until_s = f64::NEG_INFINITY;
                self.next_track = self.next_track.saturating_add(1);
            }
        }
    }

    fn update_swaps(&mut self, rng: &mut SimRng) {
        let tr = &self.model.config.tracking;
        let n = self.people.len();
        for i in 0..n {
            for k in i + 1..n {
                let (Some(a), Some(b)) = (self.people.get(i), self.people.get(k)) else {
                    continue;
                };
                let slot = i * n + k;
                let was_close = self.is_close.get(slot).copied().unwrap_or(false);
                let both = a.is_present && b.is_present && a.track.is_some() && b.track.is_some();
                let is_close =
                    both && lateral_distance_m(&a.pelvis_c, &b.pelvis_c) < tr.swap_distance_m;
                if let Some(c) = self.is_close.get_mut(slot) {
                    *c = is_close;
                }
                if both && was_close && !is_close && rng.random::<f64>() < tr.swap_probability {
                    let ta = self.people.get(i).and_then(|s| s.track);
                    let tb = self.people.get(k).and_then(|s| s.track);
                    if let Some(s) = self.people.get_mut(i) {
                        s.track = tb;
                    }
                    if let Some(s) = self.people.get_mut(k) {
                        s.track = ta;
                    }
                }
            }
        }
    }

    fn emit(
        &mut self,
        t: SessionTime,
        t_s: f64,
        dt_s: f64,
        people: &[PersonInScene<'_>],
        rng: &mut SimRng,
        out: &mut CameraOutput,
    ) {
        let cfg = &self.model.config;
        let noise = &cfg.noise;
        let rho = if noise.correlation_time_s > 0.0 {
            (-dt_s / noise.correlation_time_s).exp()
        } else {
            0.0
        };
        let innovation = (1.0 - rho * rho).sqrt();
        let p_flip = 1.0 - (-cfg.tracking.flip_rate_hz * dt_s).exp();
        let cos_away = cfg.tracking.facing_away_max_angle_rad.cos();
        let eye = Point3::from(self.model.world_from_camera.translation.vector);
        for (state, person) in self.people.iter_mut().zip(people) {
            if !state.is_present {
                continue;
            }
            // Noise evolves whether or not the body is reported.
            for z in &mut state.noise_unit {
                let n = Vector3::new(
                    rng.sample::<f64, _>(StandardNormal),
                    rng.sample::<f64, _>(StandardNormal),
                    rng.sample::<f64, _>(StandardNormal),
                );
                *z = if state.is_noise_started {
                    *z * rho + n * innovation
                } else {
                    n
                };
            }
            state.is_noise_started = true;
            let (Some(track), true) = (state.track, state.is_body_visible) else {
                continue;
            };
            // Left/right flips of people facing away.
            let facing = (joint_position(&state.pose, Joint::LeftHip)
                - joint_position(&state.pose, Joint::RightHip))
            .cross(&Vector3::z());
            let sight = Vector3::new(state.pelvis_w.x - eye.x, state.pelvis_w.y - eye.y, 0.0);
            let denom = facing.norm() * sight.norm();
            let is_facing_away = denom > 0.0 && facing.dot(&sight) >= cos_away * denom;
            if !is_facing_away {
                state.flip_until_s = f64::NEG_INFINITY;
            } else if t_s >= state.flip_until_s && rng.random::<f64>() < p_flip {
                state.flip_until_s = t_s + cfg.tracking.flip_duration_s;
            }
            let is_flipped = t_s < state.flip_until_s;

            let mut observed = [JointObservation::tracked(Point3::origin()); NUM_JOINTS];
            let mut truth = Joints::new();
            for j in Joint::ALL {
                let ji = j.index();
                let p_true_w = joint_position(&state.pose, j);
                truth.insert(j, p_true_w);
                let depth_m = (self.model.camera_from_world * p_true_w).z.max(0.0);
                let sigma = noise.sigma_m(depth_m);
                let noise_c = state.noise_unit.get(ji).copied().unwrap_or_default();
                let obs = if state.is_visible.get(ji).copied().unwrap_or(false) {
                    JointObservation {
                        position_m: self.model.camera_from_world * p_true_w + noise_c * sigma,
                        confidence: noise.tracked_confidence,
                        state: JointState::Tracked,
                        covariance_m2: None,
                    }
                } else {
                    let hidden_s = state
                        .hidden_since_s
                        .get(ji)
                        .copied()
                        .flatten()
                        .map_or(0.0, |s| t_s - s);
                    if hidden_s <= cfg.occlusion.max_inferred_s {
                        let offset = state
                            .offset_from_pelvis_w
                            .get(ji)
                            .copied()
                            .unwrap_or_default();
                        let held_w = state.pelvis_w + offset;
                        JointObservation {
                            position_m: self.model.camera_from_world * held_w
                                + noise_c * (sigma * noise.inferred_sigma_factor),
                            confidence: noise.inferred_confidence,
                            state: JointState::Inferred,
                            covariance_m2: None,
                        }
                    } else {
                        JointObservation {
                            position_m: Point3::origin(),
                            confidence: 0.0,
                            state: JointState::Missing,
                            covariance_m2: None,
                        }
                    }
                };
                if let Some(slot) = observed.get_mut(ji) {
                    *slot = obs;
                }
            }
            let mut joints = Joints::new();
            for j in Joint::ALL {
                let source = if is_flipped { j.mirrored() } else { j };
                if let Some(obs) = observed.get(source.index()) {
                    joints.insert(j, *obs);
                }
            }
            out.observations.push(SkeletonObservation {
                t,
                camera: self.model.id.clone(),
                track,
                joints,
            });
            out.truths.push(TruthSkeleton {
                t,
                camera: self.model.id.clone(),
                track,
                person: person.person.clone(),
                subject: person.subject.clone(),
                joints_world_m: truth,
            });
        }
    }
}

fn joint_position(pose: &BodyPose, j: Joint) -> Point3<f64> {
    pose.get(j).map_or_else(Point3::origin, |p| p.position_m)
}

/// Distance between two camera-frame points across the line of sight: the angle between their
/// viewing rays times the nearer depth (3D distance if either is behind the camera).
fn lateral_distance_m(a: &Point3<f64>, b: &Point3<f64>) -> f64 {
    if a.z <= 1e-6 || b.z <= 1e-6 {
        return (a - b).norm();
    }
    let dx = a.x / a.z - b.x / b.z;
    let dy = a.y / a.z - b.y / b.z;
    (dx * dx + dy * dy).sqrt() * a.z.min(b.z)
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn camera_axes_follow_the_opencv_convention() {
        // Looking along world +X from 1 m height: right is world −Y, down is world −Z.
        let model = CameraModel::new(CameraModelConfig {
            position_m: [0.0, 0.0, 1.0],
            look_at_m: [5.0, 0.0, 1.0],
            ..CameraModelConfig::default()
        })
        .unwrap();
        let w = model.world_from_camera();
        assert_relative_eq!(
            w * Point3::new(0.0, 0.0, 2.0),
            Point3::new(2.0, 0.0, 1.0),
            epsilon = 1e-12
        );
        assert_relative_eq!(
            w * Point3::new(1.0, 0.0, 0.0),
            Point3::new(0.0, -1.0, 1.0),
            epsilon = 1e-12
        );
        assert_relative_eq!(
            w * Point3::new(0.0, 1.0, 0.0),
            Point3::new(0.0, 0.0, 0.0),
            epsilon = 1e-12
        );
        // The registry transform is the same.
        let reg = model.registry_camera();
        assert_relative_eq!(
            reg.world_from_camera.apply(&Point3::new(0.3, -0.2, 2.0)),
            w * Point3::new(0.3, -0.2, 2.0),
            epsilon = 1e-12
        );
        // Pinhole: a point on the FoV edge projects onto the image edge.
        let k = model.intrinsics();
        let z = 2.0;
        let x = z * (model.config().horizontal_fov_rad * 0.5).tan();
        assert_relative_eq!(
            k.fx_px * x / z + k.cx_px,
            f64::from(k.width_px),
            epsilon = 1e-9
        );
    }

    #[test]
    fn looking_straight_down_is_rejected() {
        let err = CameraModel::new(CameraModelConfig {
            position_m: [0.0, 0.0, 3.0],
            look_at_m: [0.0, 0.0, 0.0],
            ..CameraModelConfig::default()
        })
        .unwrap_err();
        assert!(err.to_string().contains("look_at_m"), "{err}");
    }

    #[test]
    fn frustum_and_range_limits() {
        let model = CameraModel::new(CameraModelConfig::default()).unwrap();
        assert!(model.sees(&Point3::new(0.0, 0.0, 2.0)));
        assert!(!model.sees(&Point3::new(0.0, 0.0, 0.4)));
        assert!(!model.sees(&Point3::new(0.0, 0.0, 4.6)));
        assert!(!model.sees(&Point3::new(0.0, 0.0, -2.0)));
        let edge = 2.0 * (35.3_f64).to_radians().tan();
        assert!(model.sees(&Point3::new(edge - 1e-3, 0.0, 2.0)));
        assert!(!model.sees(&Point3::new(edge + 1e-3, 0.0, 2.0)));
    }

    #[test]
    fn lateral_distance_ignores_depth_difference_along_one_ray() {
        let a = Point3::new(0.5, 0.0, 2.0);
        let b = Point3::new(1.0, 0.0, 4.0);
        assert_relative_eq!(lateral_distance_m(&a, &b), 0.0, epsilon = 1e-12);
        let c = Point3::new(1.0, 0.0, 2.0);
        assert_relative_eq!(lateral_distance_m(&a, &c), 0.5, epsilon = 1e-12);
    }
}
