//! One constrained particle filter for one joint (Rebecchi's enhanced constrained particle
//! filter, after Casalino et al.).
//!
//! State per particle: position and velocity in the world frame. Each [`ConstrainedParticleFilter::step`]:
//!
//! 1. **predict** — constant velocity with white-acceleration process noise
//!    (`p += Δparent + v·dt + a·dt²/2`, `v += a·dt`, `a ~ N(0, σ_a² I)`). The joint rides on its
//!    parent: the parent's displacement since the last step is added, so velocity is relative to
//!    the parent (the kinematic hierarchy shoulder → elbow → wrist). In open loop the velocity
//!    can decay toward rest (`v ← e^{−dt/τ}·v + a·dt`, [`FilterConfig::open_loop_velocity_decay_s`]).
//!    With [`Proposal::Constrained`] the distance to the parent is drawn inside the crown and the
//!    velocity keeps only its part along the crown, so the skeletal-distance constraint holds by
//!    construction instead of by rejection;
//! 2. **weight** — Gaussian likelihood of the measurement when the joint is observed (closed
//!    loop), uniform when not (open loop);
//! 3. **constraints** — each a veto (weight 0): collision (ray parent → particle hits the
//!    environment: the particle is clamped to the hit point and discarded), skeletal distance
//!    (outside the crown `bone length ± tolerance` around the parent; the tolerance can follow
//!    the parent's σ, [`ConstraintConfig::bone_tolerance_sigmas`]), range of motion
//!    ([`crate::rom`]), and in open loop only occlusion (the depth camera saw a surface behind the
//!    particle by more than a margin that can grow with the depth noise,
//!    [`ConstraintConfig::occlusion_margin_at_m`]). Because every constraint is a veto the
//!    accepted set does not depend on the order; we test the cheap ones (distance, range of
//!    motion) first and cast rays only for the survivors, then read the depth image, whose
//!    empty pixels can cost a search of their neighbourhood;
//! 4. **estimate** — weighted mean and covariance of the particles with non-zero weight, before
//!    resampling, and the volume of the 95 % ellipsoid of that covariance;
//! 5. **systematic resampling**.
//!
//! [`ConstrainedParticleFilter::step_chained`] runs the same step with every particle riding on
//! its own particle of the parent's filter (kinematic-chain sampling) instead of on one parent
//! point.
//!
//! When every particle is vetoed the filter re-seeds them inside the constraints (on the crown
//! around the parent, or around the measurement), with a bounded number of draws; if even that
//! fails the predicted particles are kept with uniform weights and the estimate says so
//! ([`JointEstimate::is_starved`]). Non-finite inputs (NaN joints) are treated as missing and
//! never reach the particles. Buffers are allocated once, in [`ConstrainedParticleFilter::new`].

use crate::depth::{DepthProbe, Visibility, particle_visibility_at_depth};
use crate::environment::Environment;
use crate::error::{OcclusionError, Result};
use crate::rng::{ParticleRng, RandomStream};
use crate::rom::{RangeOfMotionConfig, RomLimits, TrunkFrame};
use nalgebra::{Matrix3, Point3, Vector3};
use rand::Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

/// χ² quantile for 3 degrees of freedom at 95 %: the 95 % ellipsoid is `xᵀΣ⁻¹x ≤ 7.8147`.
pub const CHI2_3DOF_95: f64 = 7.814_727_903_251_178;

/// Particle-filter parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FilterConfig {
    /// Particles per joint. Default 1000 (Rebecchi).
    pub num_particles: usize,
    /// Standard deviation of the white acceleration per axis, m/s². Default 3 (modelling
    /// choice: a reaching hand accelerates at a few m/s²).
    pub process_accel_sigma_mps2: f64,
    /// Smallest position diffusion per step and axis, m, so particles keep exploring when the
    /// step is short. Default 0.005 (modelling choice).
    pub min_position_noise_m: f64,
    /// Standard deviation of a joint measurement per axis, m. Default 0.02 (modelling choice:
    /// above the 1–1.5 cm joint noise of a Kinect-like camera at 2 m so the likelihood does not
    /// starve; Rebecchi's filter here: 0.03).
    pub measurement_sigma_m: f64,
    /// Spread of the particles around the first measurement, m. Default 0.02.
    pub initial_sigma_m: f64,
    /// Particle speeds relative to the parent are clamped to this, m/s. Default 3.
    pub max_speed_mps: f64,
    /// Draws per particle allowed when re-seeding a starved filter. Default 20.
    pub reseed_draws_per_particle: usize,
    /// How the particles meet the constraints. Default [`Proposal::Constrained`] with one draw
    /// (more draws gave larger errors on the assembly scene, seeds 1–5: a particle that needs
    /// several draws to meet the constraints would need a smaller weight; Rebecchi:
    /// [`Proposal::Rejection`]).
    pub proposal: Proposal,
    /// Time constant of the relative velocity's decay toward rest while the joint is not
    /// observed, s (`v ← e^{−dt/τ}·v + a·dt`: a hidden hand that was reaching comes to rest, as
    /// minimum-jerk reaches do). `None`: constant velocity (Rebecchi). Default 0.3 s (chosen
    /// among 0.15, 0.2 and 0.3 s on the assembly scene, seeds 1–5; see the crate README).
    pub open_loop_velocity_decay_s: Option<f64>,
    /// Standard deviation of the white acceleration while the joint is not observed, m/s²
    /// (`None`: [`Self::process_accel_sigma_mps2`]). Default `None` (1.5 and 2 m/s² gave
    /// smaller volumes but let the coverage of the 95 % ellipsoid fall below 93 % on the
    /// assembly scene, seeds 1–5).
    pub open_loop_accel_sigma_mps2: Option<f64>,
    /// The generator the filter draws from. Default [`RandomStream::Xoshiro256PlusPlus`]
    /// (the cheapest good generator; Rebecchi's filter here: [`RandomStream::ChaCha8`], the
    /// stream its figures were first measured with).
    pub random_stream: RandomStream,
}

/// How the particles meet the constraints.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Proposal {
    /// Predict freely and veto the particles that break a constraint (Rebecchi).
    Rejection,
    /// Sample inside the constraints: the distance to the parent is drawn inside the
    /// skeletal-distance crown (the velocity keeps only its part along the crown), and a
    /// particle that breaks another constraint redraws its motion noise, up to `max_draws`
    /// times, before it is vetoed.
    Constrained {
        /// Draws per particle and step, ≥ 1.
        max_draws: u32,
    },
}

impl Default for FilterConfig {
    fn default() -> Self {
        Self {
            num_particles: 1000,
            process_accel_sigma_mps2: 3.0,
            min_position_noise_m: 0.005,
            measurement_sigma_m: 0.02,
            initial_sigma_m: 0.02,
            max_speed_mps: 3.0,
            reseed_draws_per_particle: 20,
            proposal: Proposal::Constrained { max_draws: 1 },
            open_loop_velocity_decay_s: Some(0.3),
            open_loop_accel_sigma_mps2: None,
            random_stream: RandomStream::Xoshiro256PlusPlus,
        }
    }
}

impl FilterConfig {
    /// Rebecchi's filter: rejection of the particles that break a constraint, constant
    /// velocity in open loop (the baseline of `nomen experiment occlusion`).
    pub fn rebecchi() -> Self {
        Self {
            measurement_sigma_m: 0.03,
            proposal: Proposal::Rejection,
            open_loop_velocity_decay_s: None,
            open_loop_accel_sigma_mps2: None,
            random_stream: RandomStream::ChaCha8,
            ..Self::default()
        }
    }

    /// Checks that every number is finite and in range.
    ///
    /// # Errors
    /// [`OcclusionError::Config`] naming the field.
    pub fn validate(&self) -> Result<()> {
        let positive = [
            ("measurement_sigma_m", self.measurement_sigma_m),
            ("initial_sigma_m", self.initial_sigma_m),
            ("max_speed_mps", self.max_speed_mps),
        ];
        for (name, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(OcclusionError::Config(format!(
                    "{name} must be > 0, got {v}"
                )));
            }
        }
        for (name, v) in [
            ("process_accel_sigma_mps2", self.process_accel_sigma_mps2),
            ("min_position_noise_m", self.min_position_noise_m),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(OcclusionError::Config(format!(
                    "{name} must be >= 0, got {v}"
                )));
            }
        }
        if self.num_particles < 2 {
            return Err(OcclusionError::Config("num_particles must be >= 2".into()));
        }
        if let Some(tau) = self.open_loop_velocity_decay_s
            && !(tau.is_finite() && tau > 0.0)
        {
            return Err(OcclusionError::Config(format!(
                "open_loop_velocity_decay_s must be > 0, got {tau}"
            )));
        }
        if let Some(sa) = self.open_loop_accel_sigma_mps2
            && !(sa.is_finite() && sa >= 0.0)
        {
            return Err(OcclusionError::Config(format!(
                "open_loop_accel_sigma_mps2 must be >= 0, got {sa}"
            )));
        }
        if self.proposal == (Proposal::Constrained { max_draws: 0 }) {
            return Err(OcclusionError::Config(
                "proposal max_draws must be >= 1".into(),
            ));
        }
        Ok(())
    }
}

/// Which constraints are on (Rebecchi §7.3's variants are combinations of these).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ConstraintSet {
    /// Skeletal distance: the crown `bone length ± tolerance` around the parent.
    pub skeletal_distance: bool,
    /// Range of motion (the joint bounding volume).
    pub range_of_motion: bool,
    /// Collision with the environment (ray parent → particle).
    pub environment: bool,
    /// Occlusion against the depth map, open loop only.
    pub occlusion: bool,
}

impl Default for ConstraintSet {
    fn default() -> Self {
        Self::COMPLETE
    }
}

impl ConstraintSet {
    /// No constraint: a plain constant-velocity particle filter.
    pub const NONE: Self = Self {
        skeletal_distance: false,
        range_of_motion: false,
        environment: false,
        occlusion: false,
    };
    /// Rebecchi's "Original" (Casalino et al.): skeletal distance and occlusion.
    pub const ORIGINAL: Self = Self {
        skeletal_distance: true,
        range_of_motion: false,
        environment: false,
        occlusion: true,
    };
    /// "Joint Bounding Volume": Original plus range of motion.
    pub const JOINT_BOUNDING_VOLUME: Self = Self {
        skeletal_distance: true,
        range_of_motion: true,
        environment: false,
        occlusion: true,
    };
    /// "Complete": all four constraints.
    pub const COMPLETE: Self = Self {
        skeletal_distance: true,
        range_of_motion: true,
        environment: true,
        occlusion: true,
    };
}

/// Constraint parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ConstraintConfig {
    /// Which constraints are on.
    pub enabled: ConstraintSet,
    /// Half-width of the skeletal-distance crown, m. Default 0.03 (modelling choice: a few
    /// times the bone-length noise of a depth camera).
    pub bone_tolerance_m: f64,
    /// Range-of-motion limits.
    pub range_of_motion: RangeOfMotionConfig,
    /// A particle would have been seen when the camera saw a surface deeper than it by more
    /// than this (plus the depth-noise part, [`Self::occlusion_margin_sigmas`]), m. Default
    /// −0.03: a seen joint's own limb surface lies about a limb radius in front of it, so a
    /// surface seen less than that in front of the particle is that limb, not an occluder
    /// (Rebecchi: +0.05, a fixed margin).
    pub occlusion_margin_m: f64,
    /// Zero depth pixels are filled from the nearest non-zero pixel within this radius, px.
    /// Default 8.
    pub max_fill_radius_px: u32,
    /// The occlusion margin grows with the depth noise: at depth `z` it is
    /// `occlusion_margin_m + occlusion_margin_sigmas · depth_sigma_per_depth2_m · z²`. Default
    /// 3 (Rebecchi: 0, a fixed margin).
    pub occlusion_margin_sigmas: f64,
    /// Depth noise σ per squared metre of depth, m/m². Default 0.0015 (Kinect v2's axial
    /// noise is a few millimetres at 1–2 m and grows about with z²: Fankhauser et al. 2015).
    pub depth_sigma_per_depth2_m: f64,
    /// When set, the crown's half-width is this many times the parent's position σ
    /// ([`ChainContext::parent_sigma_m`]) whenever that is known, never more than
    /// [`Self::bone_tolerance_m`]. `None`: always `bone_tolerance_m` (Rebecchi). Default 2.5
    /// (2.0 and 2.5 gave the same errors on the assembly scene, seeds 1–5).
    pub bone_tolerance_sigmas: Option<f64>,
    /// The collision ray starts from a point drawn around the parent with its σ
    /// ([`ChainContext::parent_sigma_m`], when known) instead of from the parent's estimate,
    /// so that the parent's own uncertainty does not cut a limb that passes close to an edge
    /// on one side only. Default true (Rebecchi: false).
    pub sample_ray_origin: bool,
    /// Half-width of the crown when each particle rides on its own parent particle
    /// ([`ConstrainedParticleFilter::step_chained`]), m: the parent's uncertainty is then in
    /// the parents, and the crown holds only the error of the measured bone length. Default
    /// 0.01 (0.01, 0.02 and 0.03 m gave median errors within 0.3 cm of each other on seeds 1–2
    /// of the assembly scene, 0.01 the smallest volumes).
    pub chained_bone_tolerance_m: f64,
}

impl Default for ConstraintConfig {
    fn default() -> Self {
        Self {
            enabled: ConstraintSet::COMPLETE,
            bone_tolerance_m: 0.03,
            range_of_motion: RangeOfMotionConfig::default(),
            occlusion_margin_m: -0.03,
            max_fill_radius_px: 8,
            occlusion_margin_sigmas: 3.0,
            depth_sigma_per_depth2_m: 0.0015,
            bone_tolerance_sigmas: Some(2.5),
            sample_ray_origin: true,
            chained_bone_tolerance_m: 0.01,
        }
    }
}

impl ConstraintConfig {
    /// Rebecchi's constraint parameters (the baseline of `nomen experiment occlusion`): a fixed
    /// 3 cm crown and a fixed 5 cm occlusion margin.
    pub fn rebecchi(enabled: ConstraintSet) -> Self {
        Self {
            enabled,
            occlusion_margin_m: 0.05,
            occlusion_margin_sigmas: 0.0,
            bone_tolerance_sigmas: None,
            sample_ray_origin: false,
            ..Self::default()
        }
    }

    /// The occlusion margin at depth `z_m` (camera Z), m.
    pub fn occlusion_margin_at_m(&self, z_m: f64) -> f64 {
        self.occlusion_margin_m
            + self.occlusion_margin_sigmas * self.depth_sigma_per_depth2_m * z_m * z_m
    }
}

/// The range-of-motion test that applies to this joint.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RomContext {
    /// No range-of-motion test.
    None,
    /// The joint is an elbow: shoulder limits against the trunk.
    Shoulder {
        /// The trunk frame of this arm.
        trunk: TrunkFrame,
    },
    /// The joint is a wrist: elbow limits, given the shoulder and (if known) the hinge axis.
    Elbow {
        /// Shoulder position, world, m.
        shoulder_m: Point3<f64>,
        /// Unit hinge axis (see [`crate::rom::hinge_axis`]).
        hinge_axis: Option<Vector3<f64>>,
    },
}

/// Where the joint's parent is and what limits apply, for one step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChainContext {
    /// Parent joint position, world, m (NaN = unknown).
    pub parent_m: Point3<f64>,
    /// Measured bone length parent → joint, m.
    pub bone_length_m: f64,
    /// σ per axis of the parent's position, m (NaN = unknown: the crown keeps its configured
    /// half-width).
    pub parent_sigma_m: f64,
    /// Range-of-motion test.
    pub rom: RomContext,
}

/// The filter's output for one step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointEstimate {
    /// Weighted mean of the valid particles, world, m.
    pub position_m: Point3<f64>,
    /// Weighted covariance of the valid particles, m².
    pub covariance_m2: Matrix3<f64>,
    /// Volume of the 95 % confidence ellipsoid of that covariance, m³.
    pub ellipsoid_volume_m3: f64,
    /// Particles with non-zero weight before resampling.
    pub num_valid_particles: usize,
    /// Whether a measurement was used (closed loop).
    pub is_observed: bool,
    /// Whether every particle was vetoed and re-seeding failed too (constraints ignored).
    pub is_starved: bool,
}

/// Volume of the 95 % ellipsoid `{x : xᵀΣ⁻¹x ≤ χ²₃(0.95)}`: `4/3 π √det Σ · χ²^{3/2}`.
pub fn ellipsoid_volume_95_m3(covariance_m2: &Matrix3<f64>) -> f64 {
    let det = covariance_m2.determinant().max(0.0);
    4.0 / 3.0 * std::f64::consts::PI * det.sqrt() * CHI2_3DOF_95.powf(1.5)
}

fn finite(p: &Point3<f64>) -> bool {
    p.x.is_finite() && p.y.is_finite() && p.z.is_finite()
}

/// A constrained particle filter for one joint.
#[derive(Debug, Clone)]
pub struct ConstrainedParticleFilter {
    config: FilterConfig,
    constraints: ConstraintConfig,
    limits: RomLimits,
    rng: ParticleRng,
    pos: Vec<Vector3<f64>>,
    vel: Vec<Vector3<f64>>,
    log_w: Vec<f64>,
    w: Vec<f64>,
    next_pos: Vec<Vector3<f64>>,
    next_vel: Vec<Vector3<f64>>,
    last_parent: Option<Point3<f64>>,
    is_initialized: bool,
    /// Whether the last step re-seeded its particles (their parents' pairing is lost).
    was_reseeded: bool,
    /// Chained step: each particle's parent now (the parent filter's particle of the same
    /// index), and the parent each particle had after the last step.
    chain_parent_now: Vec<Vector3<f64>>,
    chain_parent_prev: Vec<Vector3<f64>>,
    is_chained: bool,
    has_chain_history: bool,
    resample_index: Vec<usize>,
    /// Half-width of the skeletal-distance crown in this step, m.
    tolerance_m: f64,
}

impl ConstrainedParticleFilter {
    /// A filter with its buffers allocated and its random stream seeded.
    ///
    /// # Errors
    /// [`OcclusionError::Config`] when the configuration is out of range.
    pub fn new(config: FilterConfig, constraints: ConstraintConfig, seed: u64) -> Result<Self> {
        config.validate()?;
        if !(constraints.bone_tolerance_m.is_finite() && constraints.bone_tolerance_m >= 0.0) {
            return Err(OcclusionError::Config(
                "bone_tolerance_m must be >= 0".into(),
            ));
        }
        if !(constraints.chained_bone_tolerance_m.is_finite()
            && constraints.chained_bone_tolerance_m >= 0.0)
        {
            return Err(OcclusionError::Config(
                "chained_bone_tolerance_m must be >= 0".into(),
            ));
        }

        if !constraints.occlusion_margin_m.is_finite() {
            return Err(OcclusionError::Config(
                "occlusion_margin_m must be finite".into(),
            ));
        }
        let n = config.num_particles;
        let random_stream = config.random_stream;
        Ok(Self {
            limits: RomLimits::new(&constraints.range_of_motion),
            config,
            constraints,
            rng: ParticleRng::new(random_stream, seed),
            pos: vec![Vector3::zeros(); n],
            vel: vec![Vector3::zeros(); n],
            log_w: vec![0.0; n],
            w: vec![0.0; n],
            next_pos: vec![Vector3::zeros(); n],
            next_vel: vec![Vector3::zeros(); n],
            last_parent: None,
            is_initialized: false,
            was_reseeded: false,
            chain_parent_now: Vec::with_capacity(n),
            chain_parent_prev: Vec::with_capacity(n),
            is_chained: false,
            has_chain_history: false,
            resample_index: vec![0; n],
            tolerance_m: 0.0,
        })
    }

    /// Forgets the state (the next step re-initialises).
    pub fn reset(&mut self) {
        self.is_initialized = false;
        self.last_parent = None;
        self.has_chain_history = false;
    }

    /// The particles' positions after the last step (resampled; after
    /// [`Self::step_chained`], until [`Self::resample_chained`], as weighted), world, m.
    pub fn particles_m(&self) -> &[Vector3<f64>] {
        &self.pos
    }

    /// Which constraints are on.
    pub fn constraints(&self) -> &ConstraintConfig {
        &self.constraints
    }

    fn gauss3(&mut self, sigma: f64) -> Vector3<f64> {
        Vector3::new(
            self.rng.sample::<f64, _>(StandardNormal),
            self.rng.sample::<f64, _>(StandardNormal),
            self.rng.sample::<f64, _>(StandardNormal),
        ) * sigma
    }

    /// Runs one step. `dt_s` is the time since the previous step (non-finite or negative = 0);
    /// `observation_m` is the measured joint position when the joint is observed (non-finite =
    /// not observed); `environment` and `depth` are needed only for the constraints that use
    /// them. Returns `None` only while the filter has never been initialised (no finite
    /// measurement and no finite parent yet).
    pub fn step(
        &mut self,
        dt_s: f64,
        ctx: &ChainContext,
        observation_m: Option<&Point3<f64>>,
        environment: Option<&Environment>,
        depth: Option<&mut dyn DepthProbe>,
    ) -> Option<JointEstimate> {
        self.is_chained = false;
        let estimate = self.step_weighted(dt_s, ctx, observation_m, environment, depth)?;
        self.systematic_resample();
        Some(estimate)
    }

    /// Kinematic-chain sampling: particle `i` of this joint rides on particle `i` of `parent`,
    /// which has run its [`Self::step`] for this frame (same number of particles; its resampled
    /// particles are a sample of its posterior). The particle keeps its offset from the parent
    /// it rode on in the last step, and its crown, range of motion and collision ray start from
    /// its own parent, so the joint's cloud carries the parent's uncertainty; the joint is
    /// weighted alone (weighting the pairs by the parent's likelihood too, and resampling them
    /// together, impoverished the hidden joint's cloud on the assembly scene). Finish with
    /// [`Self::resample_chained`]. `ctx.parent_m` is used only when `parent` has no particles
    /// to offer (then the step is a plain one, without resampling).
    pub fn step_chained(
        &mut self,
        parent: &ConstrainedParticleFilter,
        dt_s: f64,
        ctx: &ChainContext,
        observation_m: Option<&Point3<f64>>,
        environment: Option<&Environment>,
        depth: Option<&mut dyn DepthProbe>,
    ) -> Option<JointEstimate> {
        let n = self.pos.len();
        self.is_chained = parent.is_initialized && parent.pos.len() == n;
        if self.is_chained {
            self.chain_parent_now.clear();
            self.chain_parent_now.extend_from_slice(&parent.pos);
            if parent.was_reseeded {
                self.has_chain_history = false;
            }
        }
        let estimate = self.step_weighted(dt_s, ctx, observation_m, environment, depth);
        if estimate.is_none() {
            self.is_chained = false;
        }
        estimate
    }

    /// Resamples this filter alone after [`Self::step_chained`] on a resampled parent: each
    /// particle keeps the parent it had, so that the next chained step keeps its offset from it.
    pub fn resample_chained(&mut self) {
        self.systematic_resample();
        if !self.is_chained || self.chain_parent_now.len() != self.pos.len() {
            self.has_chain_history = false;
            return;
        }
        self.chain_parent_prev.clear();
        for &k in &self.resample_index {
            let k = k.min(self.chain_parent_now.len() - 1);
            self.chain_parent_prev.push(self.chain_parent_now[k]);
        }
        self.has_chain_history = true;
    }

    fn step_weighted(
        &mut self,
        dt_s: f64,
        ctx: &ChainContext,
        observation_m: Option<&Point3<f64>>,
        environment: Option<&Environment>,
        mut depth: Option<&mut dyn DepthProbe>,
    ) -> Option<JointEstimate> {
        self.was_reseeded = false;
        let dt = if dt_s.is_finite() && dt_s > 0.0 {
            dt_s
        } else {
            0.0
        };
        let observation = observation_m.filter(|p| finite(p)).copied();
        let parent = finite(&ctx.parent_m).then_some(ctx.parent_m);
        let bone_ok = ctx.bone_length_m.is_finite() && ctx.bone_length_m > 0.0;
        let ctx = ChainContext {
            bone_length_m: if bone_ok { ctx.bone_length_m } else { f64::NAN },
            ..*ctx
        };
        self.tolerance_m = match self.constraints.bone_tolerance_sigmas {
            _ if self.is_chained => self.constraints.chained_bone_tolerance_m,
            Some(k) if ctx.parent_sigma_m.is_finite() && ctx.parent_sigma_m >= 0.0 => {
                (k * ctx.parent_sigma_m).min(self.constraints.bone_tolerance_m)
            }
            _ => self.constraints.bone_tolerance_m,
        };

        let n_valid = if !self.is_initialized {
            if let Some(z) = observation {
                for i in 0..self.pos.len() {
                    self.pos[i] = z.coords + self.gauss3(self.config.initial_sigma_m);
                    self.vel[i] = Vector3::zeros();
                }
            } else if let (Some(p), true) = (parent, bone_ok) {
                for i in 0..self.pos.len() {
                    let centre = self.parent_of(i, &p.coords);
                    self.pos[i] = centre + self.random_unit() * ctx.bone_length_m;
                    self.vel[i] = Vector3::zeros();
                }
            } else {
                return None;
            }
            self.is_initialized = true;
            self.last_parent = parent;
            self.weigh(&ctx, parent, observation, environment, &mut depth)
        } else {
            match self.config.proposal {
                Proposal::Rejection => {
                    self.predict(dt, parent, observation.is_some());
                    if parent.is_some() {
                        self.last_parent = parent;
                    }
                    self.weigh(&ctx, parent, observation, environment, &mut depth)
                }
                Proposal::Constrained { max_draws } => {
                    let n = self.propose_constrained(
                        max_draws,
                        dt,
                        &ctx,
                        parent,
                        observation,
                        environment,
                        &mut depth,
                    );
                    if parent.is_some() {
                        self.last_parent = parent;
                    }
                    n
                }
            }
        };

        let mut is_starved = false;
        if n_valid == 0 {
            self.was_reseeded = true;
            let n = self.reseed(&ctx, parent, observation, environment, &mut depth);
            if n == 0 {
                is_starved = true;
                self.log_w.iter_mut().for_each(|w| *w = 0.0);
            }
        }
        Some(self.estimate(observation.is_some(), is_starved))
    }

    /// The parent of particle `i`: its own parent particle in a chained step, else `parent`.
    fn parent_of(&self, i: usize, parent: &Vector3<f64>) -> Vector3<f64> {
        if self.is_chained {
            self.chain_parent_now.get(i).copied().unwrap_or(*parent)
        } else {
            *parent
        }
    }

    /// The displacement of particle `i`'s parent since the last step.
    fn carry_of(&self, i: usize, carry: &Vector3<f64>) -> Vector3<f64> {
        if self.is_chained {
            if self.has_chain_history
                && let (Some(now), Some(prev)) =
                    (self.chain_parent_now.get(i), self.chain_parent_prev.get(i))
            {
                return now - prev;
            }
            return Vector3::zeros();
        }
        *carry
    }

    fn random_unit(&mut self) -> Vector3<f64> {
        loop {
            let v = self.gauss3(1.0);
            if let Some(u) = v.try_normalize(1e-9) {
                return u;
            }
        }
    }

    /// The motion model's parameters for a step of `dt` s: σ of the white acceleration, the
    /// velocity's decay factor `e^{−dt/τ}` and the distance factor `∫₀^dt e^{−s/τ} ds` (`dt`
    /// and 1 for constant velocity).
    fn motion(&self, dt: f64, is_observed: bool) -> (f64, f64, f64) {
        if is_observed {
            return (self.config.process_accel_sigma_mps2, 1.0, dt);
        }
        let sa = self
            .config
            .open_loop_accel_sigma_mps2
            .unwrap_or(self.config.process_accel_sigma_mps2);
        match self.config.open_loop_velocity_decay_s {
            Some(tau) => {
                let decay = (-dt / tau).exp();
                (sa, decay, tau * (1.0 - decay))
            }
            None => (sa, 1.0, dt),
        }
    }

    fn parent_carry(&self, parent: Option<Point3<f64>>) -> Vector3<f64> {
        match (parent, self.last_parent) {
            (Some(p), Some(q)) => p - q,
            _ => Vector3::zeros(),
        }
    }

    fn predict(&mut self, dt: f64, parent: Option<Point3<f64>>, is_observed: bool) {
        let carry = self.parent_carry(parent);
        let (sa, decay, reach_s) = self.motion(dt, is_observed);
        let vmax = self.config.max_speed_mps;
        let floor = self.config.min_position_noise_m;
        for i in 0..self.pos.len() {
            let a = self.gauss3(sa);
            let jitter = self.gauss3(floor);
            let mut v = self.vel[i] * decay + a * dt;
            let speed = v.norm();
            if speed > vmax {
                v *= vmax / speed;
            }
            let carry_i = self.carry_of(i, &carry);
            self.pos[i] += carry_i + self.vel[i] * reach_s + a * (0.5 * dt * dt) + jitter;
            self.vel[i] = v;
        }
    }

    /// Constrained sampling: predict each particle with its distance to the parent drawn inside
    /// the crown, redraw the motion noise while it breaks a constraint (at most `max_draws`
    /// draws), then weigh it. Returns the number of valid particles.
    #[allow(clippy::too_many_arguments)]
    fn propose_constrained(
        &mut self,
        max_draws: u32,
        dt: f64,
        ctx: &ChainContext,
        parent: Option<Point3<f64>>,
        observation: Option<Point3<f64>>,
        environment: Option<&Environment>,
        depth: &mut Option<&mut dyn DepthProbe>,
    ) -> usize {
        let carry = self.parent_carry(parent);
        let (sa, decay, reach_s) = self.motion(dt, observation.is_some());
        let vmax = self.config.max_speed_mps;
        let floor = self.config.min_position_noise_m;
        let inv_2s2 = 0.5 / (self.config.measurement_sigma_m * self.config.measurement_sigma_m);
        let crown = match parent {
            Some(c)
                if self.constraints.enabled.skeletal_distance && ctx.bone_length_m.is_finite() =>
            {
                Some((c.coords, ctx.bone_length_m))
            }
            _ => None,
        };
        let tol = self.tolerance_m;
        let mut n_valid = 0;
        for i in 0..self.pos.len() {
            let (p0, v0) = (self.pos[i], self.vel[i]);
            let carry_i = self.carry_of(i, &carry);
            let crown_i = crown.map(|(c, length)| (self.parent_of(i, &c), length));
            let mut ok = false;
            for _ in 0..max_draws {
                let a = self.gauss3(sa);
                let jitter = self.gauss3(floor);
                let mut v = v0 * decay + a * dt;
                let speed = v.norm();
                if speed > vmax {
                    v *= vmax / speed;
                }
                let mut p = p0 + carry_i + v0 * reach_s + a * (0.5 * dt * dt) + jitter;
                if let Some((c, length)) = crown_i {
                    let u = match (p - c).try_normalize(1e-9) {
                        Some(u) => u,
                        None => self.random_unit(),
                    };
                    let r = length + tol * (2.0 * self.rng.random::<f64>() - 1.0);
                    p = c + u * r;
                    v -= u * v.dot(&u);
                }
                self.pos[i] = p;
                self.vel[i] = v;
                if self.full_ok(
                    i,
                    ctx,
                    parent.as_ref(),
                    observation.is_some(),
                    environment,
                    depth,
                ) {
                    ok = true;
                    break;
                }
            }
            self.log_w[i] = if !ok {
                f64::NEG_INFINITY
            } else if let Some(z) = observation {
                -(self.pos[i] - z.coords).norm_squared() * inv_2s2
            } else {
                0.0
            };
            n_valid += usize::from(ok);
        }
        n_valid
    }

    /// Whether position `p` (world) passes the cheap constraints (distance, range of motion).
    fn cheap_ok(&self, p: &Vector3<f64>, ctx: &ChainContext, parent: Option<&Point3<f64>>) -> bool {
        let Some(parent) = parent else {
            return true;
        };
        let set = self.constraints.enabled;
        if set.skeletal_distance && ctx.bone_length_m.is_finite() {
            let d = (p - parent.coords).norm();
            if (d - ctx.bone_length_m).abs() > self.tolerance_m {
                return false;
            }
        }
        if set.range_of_motion {
            match &ctx.rom {
                RomContext::None => {}
                RomContext::Shoulder { trunk } => {
                    if !self.limits.shoulder_ok(&parent.coords, p, trunk) {
                        return false;
                    }
                }
                RomContext::Elbow {
                    shoulder_m,
                    hinge_axis,
                } => {
                    if finite(shoulder_m)
                        && !self.limits.elbow_ok(
                            &shoulder_m.coords,
                            &parent.coords,
                            p,
                            hinge_axis.as_ref(),
                        )
                    {
                        return false;
                    }
                }
            }
        }
        true
    }

    /// Applies the likelihood and constraints; returns the number of valid particles.
    fn weigh(
        &mut self,
        ctx: &ChainContext,
        parent: Option<Point3<f64>>,
        observation: Option<Point3<f64>>,
        environment: Option<&Environment>,
        depth: &mut Option<&mut dyn DepthProbe>,
    ) -> usize {
        let inv_2s2 = 0.5 / (self.config.measurement_sigma_m * self.config.measurement_sigma_m);
        let mut n_valid = 0;
        for i in 0..self.pos.len() {
            let ok = self.full_ok(
                i,
                ctx,
                parent.as_ref(),
                observation.is_some(),
                environment,
                depth,
            );
            self.log_w[i] = if !ok {
                f64::NEG_INFINITY
            } else if let Some(z) = observation {
                -(self.pos[i] - z.coords).norm_squared() * inv_2s2
            } else {
                0.0
            };
            n_valid += usize::from(ok);
        }
        n_valid
    }

    /// All constraints for particle `i`; clamps it to the environment on a hit.
    fn full_ok(
        &mut self,
        i: usize,
        ctx: &ChainContext,
        parent: Option<&Point3<f64>>,
        is_observed: bool,
        environment: Option<&Environment>,
        depth: &mut Option<&mut dyn DepthProbe>,
    ) -> bool {
        let p = self.pos[i];
        let parent_i = parent.map(|q| Point3::from(self.parent_of(i, &q.coords)));
        let parent = parent_i.as_ref();
        if !self.cheap_ok(&p, ctx, parent) {
            return false;
        }
        let set = self.constraints.enabled;
        if set.environment
            && let (Some(env), Some(parent)) = (environment, parent)
        {
            let origin = if !self.is_chained
                && self.constraints.sample_ray_origin
                && ctx.parent_sigma_m.is_finite()
                && ctx.parent_sigma_m > 0.0
            {
                parent + self.gauss3(ctx.parent_sigma_m)
            } else {
                *parent
            };
            let dir = p - origin.coords;
            if let Some(t) = env.cast_ray(&origin, &dir, 1.0) {
                // Rebecchi: the particle cannot pass the surface; clamp, then discard.
                self.pos[i] = origin.coords + dir * t;
                return false;
            }
        }
        if set.occlusion
            && !is_observed
            && let Some(depth) = depth
        {
            let v = particle_visibility_at_depth(
                &mut **depth,
                &Point3::from(p),
                |z| self.constraints.occlusion_margin_at_m(z),
                self.constraints.max_fill_radius_px,
            );
            if v == Visibility::WouldBeSeen {
                return false;
            }
        }
        true
    }

    /// Re-seeds vetoed particles inside the constraints; returns the number of valid ones.
    fn reseed(
        &mut self,
        ctx: &ChainContext,
        parent: Option<Point3<f64>>,
        observation: Option<Point3<f64>>,
        environment: Option<&Environment>,
        depth: &mut Option<&mut dyn DepthProbe>,
    ) -> usize {
        let n = self.pos.len();
        let max_draws = n.saturating_mul(self.config.reseed_draws_per_particle.max(1));
        let inv_2s2 = 0.5 / (self.config.measurement_sigma_m * self.config.measurement_sigma_m);
        let mut filled = 0;
        let mut draws = 0;
        let saved_first = self.pos[0];
        while filled < n && draws < max_draws {
            draws += 1;
            let candidate = if let Some(z) = observation {
                z.coords + self.gauss3(self.config.measurement_sigma_m)
            } else if let (Some(p), true) = (parent, ctx.bone_length_m.is_finite()) {
                let tol = self.tolerance_m;
                let r = ctx.bone_length_m + tol * (2.0 * self.rng.random::<f64>() - 1.0);
                self.parent_of(filled, &p.coords) + self.random_unit() * r
            } else {
                break;
            };
            self.pos[filled] = candidate;
            if self.full_ok(
                filled,
                ctx,
                parent.as_ref(),
                observation.is_some(),
                environment,
                depth,
            ) {
                self.vel[filled] = Vector3::zeros();
                self.log_w[filled] =
                    observation.map_or(0.0, |z| -(candidate - z.coords).norm_squared() * inv_2s2);
                filled += 1;
            }
        }
        if filled == 0 {
            self.pos[0] = saved_first;
            return 0;
        }
        // Slots not refilled copy accepted particles round-robin so that all weights are valid.
        for i in filled..n {
            let k = i % filled;
            self.pos[i] = self.pos[k];
            self.vel[i] = self.vel[k];
            self.log_w[i] = self.log_w[k];
        }
        n
    }

    fn estimate(&mut self, is_observed: bool, is_starved: bool) -> JointEstimate {
        let max_log = self.log_w.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let mut sum = 0.0;
        for (w, lw) in self.w.iter_mut().zip(&self.log_w) {
            *w = if max_log.is_finite() {
                (lw - max_log).exp()
            } else {
                1.0
            };
            sum += *w;
        }
        let inv = 1.0 / sum;
        let mut mean = Vector3::zeros();
        let mut n_valid = 0;
        for (w, p) in self.w.iter_mut().zip(&self.pos) {
            *w *= inv;
            if *w > 0.0 {
                mean += p * *w;
                n_valid += 1;
            }
        }
        let mut cov = Matrix3::zeros();
        let mut sum_w2 = 0.0;
        for (w, p) in self.w.iter().zip(&self.pos) {
            if *w > 0.0 {
                let d = p - mean;
                cov += d * d.transpose() * *w;
                sum_w2 += w * w;
            }
        }
        // Unbiased weighted covariance (reliability weights).
        if sum_w2 < 1.0 {
            cov /= 1.0 - sum_w2;
        }
        JointEstimate {
            position_m: Point3::from(mean),
            covariance_m2: cov,
            ellipsoid_volume_m3: ellipsoid_volume_95_m3(&cov),
            num_valid_particles: n_valid,
            is_observed,
            is_starved,
        }
    }

    /// Systematic resampling (one uniform draw, `n` evenly spaced pointers into the CDF).
    fn systematic_resample(&mut self) {
        let n = self.pos.len();
        let step = 1.0 / n as f64;
        let mut u = self.rng.random::<f64>() * step;
        let mut cumulative = self.w.first().copied().unwrap_or(1.0);
        let mut k = 0;
        self.resample_index.resize(n, 0);
        for i in 0..n {
            while u > cumulative && k + 1 < n {
                k += 1;
                cumulative += self.w[k];
            }
            self.resample_index[i] = k;
            u += step;
        }
        let index = std::mem::take(&mut self.resample_index);
        self.gather(&index);
        self.resample_index = index;
    }

    /// Keeps particle `index[i]` as particle `i` (positions and velocities).
    fn gather(&mut self, index: &[usize]) {
        let n = self.pos.len().min(index.len());
        for (i, &k) in index.iter().enumerate().take(n) {
            let k = k.min(n - 1);
            self.next_pos[i] = self.pos[k];
            self.next_vel[i] = self.vel[k];
        }
        std::mem::swap(&mut self.pos, &mut self.next_pos);
        std::mem::swap(&mut self.vel, &mut self.next_vel);
        // After resampling every particle carries the same weight.
        self.log_w.iter_mut().for_each(|w| *w = 0.0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn open_filter(
        filter: FilterConfig,
        constraints: ConstraintConfig,
    ) -> ConstrainedParticleFilter {
        ConstrainedParticleFilter::new(
            FilterConfig {
                num_particles: 400,
                ..filter
            },
            constraints,
            5,
        )
        .unwrap()
    }

    fn ctx(parent_sigma_m: f64) -> ChainContext {
        ChainContext {
            parent_m: Point3::new(0.0, 0.0, 1.0),
            bone_length_m: 0.26,
            parent_sigma_m,
            rom: RomContext::None,
        }
    }

    #[test]
    fn constrained_proposal_keeps_every_particle_on_the_crown() {
        let mut f = open_filter(
            FilterConfig::default(),
            ConstraintConfig {
                enabled: ConstraintSet {
                    skeletal_distance: true,
                    ..ConstraintSet::NONE
                },
                ..ConstraintConfig::default()
            },
        );
        let c = ctx(f64::NAN);
        f.step(0.0, &c, Some(&Point3::new(0.26, 0.0, 1.0)), None, None);
        for _ in 0..30 {
            let e = f.step(1.0 / 30.0, &c, None, None, None).unwrap();
            // Sampled inside the crown, no particle is vetoed by it.
            assert_eq!(e.num_valid_particles, 400);
            for p in f.particles_m() {
                let r = (p - c.parent_m.coords).norm();
                assert!((r - 0.26).abs() <= 0.03 + 1e-9, "{r}");
            }
        }
    }

    #[test]
    fn crown_narrows_with_a_certain_parent() {
        let constraints = ConstraintConfig {
            enabled: ConstraintSet {
                skeletal_distance: true,
                ..ConstraintSet::NONE
            },
            bone_tolerance_sigmas: Some(2.5),
            ..ConstraintConfig::default()
        };
        let mut f = open_filter(FilterConfig::default(), constraints);
        // Parent known to 4 mm: the crown is ±1 cm, not the configured ±3 cm.
        let c = ctx(0.004);
        f.step(0.0, &c, Some(&Point3::new(0.26, 0.0, 1.0)), None, None);
        for _ in 0..10 {
            f.step(1.0 / 30.0, &c, None, None, None).unwrap();
            for p in f.particles_m() {
                let r = (p - c.parent_m.coords).norm();
                assert!((r - 0.26).abs() <= 0.01 + 1e-9, "{r}");
            }
        }
    }

    /// Observes a joint moving at `speed` along x for a second, then hides it for a second;
    /// returns how far the estimate moved along x while hidden.
    fn advance_while_hidden(filter: FilterConfig, speed: f64) -> f64 {
        let mut f = open_filter(
            filter,
            ConstraintConfig {
                enabled: ConstraintSet::NONE,
                ..ConstraintConfig::default()
            },
        );
        let c = ctx(f64::NAN);
        let dt = 1.0 / 30.0;
        let mut last = 0.0;
        for k in 0..30 {
            let z = Point3::new(speed * dt * f64::from(k), 0.0, 1.0);
            last = f.step(dt, &c, Some(&z), None, None).unwrap().position_m.x;
        }
        let mut x = last;
        for _ in 0..30 {
            x = f.step(dt, &c, None, None, None).unwrap().position_m.x;
        }
        x - last
    }

    #[test]
    fn hidden_hand_comes_to_rest_with_velocity_decay() {
        let speed = 0.6;
        let constant = advance_while_hidden(FilterConfig::rebecchi(), speed);
        let decaying = advance_while_hidden(FilterConfig::default(), speed);
        // Constant velocity carries on for the whole second; a velocity decaying with τ
        // travels about v·τ in total.
        let tau = FilterConfig::default().open_loop_velocity_decay_s.unwrap();
        assert!(constant > 0.5 * speed, "{constant}");
        assert!(decaying < 2.0 * speed * tau, "{decaying}");
        assert!(decaying < constant);
    }

    #[test]
    fn occlusion_margin_grows_with_depth_noise_and_rebecchis_does_not() {
        let ours = ConstraintConfig::default();
        assert!(ours.occlusion_margin_at_m(3.0) > ours.occlusion_margin_at_m(1.0));
        let theirs = ConstraintConfig::rebecchi(ConstraintSet::COMPLETE);
        assert_eq!(
            theirs.occlusion_margin_at_m(1.0),
            theirs.occlusion_margin_at_m(3.0)
        );
    }

    #[test]
    fn chained_particles_keep_their_own_parents_bone_length() {
        let constraints = ConstraintConfig {
            enabled: ConstraintSet {
                skeletal_distance: true,
                ..ConstraintSet::NONE
            },
            ..ConstraintConfig::default()
        };
        let mut elbow = open_filter(FilterConfig::default(), constraints.clone());
        let mut wrist = open_filter(FilterConfig::default(), constraints);
        let shoulder = ctx(f64::NAN);
        let elbow_ctx = |e: Point3<f64>| ChainContext {
            parent_m: e,
            bone_length_m: 0.25,
            parent_sigma_m: f64::NAN,
            rom: RomContext::None,
        };
        let e0 = Point3::new(0.26, 0.0, 1.0);
        let w0 = Point3::new(0.26, 0.0, 0.75);
        for k in 0..40 {
            let seen = k < 10;
            let dt = if k == 0 { 0.0 } else { 1.0 / 30.0 };
            let e = elbow
                .step(dt, &shoulder, seen.then_some(&e0), None, None)
                .unwrap();
            wrist
                .step_chained(
                    &elbow,
                    dt,
                    &elbow_ctx(e.position_m),
                    seen.then_some(&w0),
                    None,
                    None,
                )
                .unwrap();
            if k > 0 {
                // Before resampling, every wrist particle lies on the crown of its own elbow
                // particle, which is narrower than the spread of the elbows.
                let tol = ConstraintConfig::default().chained_bone_tolerance_m;
                for (w, e) in wrist.particles_m().iter().zip(elbow.particles_m()) {
                    let r = (w - e).norm();
                    assert!((r - 0.25).abs() <= tol + 1e-9, "step {k}: {r}");
                }
            }
            wrist.resample_chained();
        }
        // Hidden for a second, the elbows spread over the shoulder's crown: more than the
        // wrists' own crown.
        let spread = |ps: &[Vector3<f64>]| {
            let m = ps.iter().sum::<Vector3<f64>>() / ps.len() as f64;
            (ps.iter().map(|p| (p - m).norm_squared()).sum::<f64>() / ps.len() as f64).sqrt()
        };
        assert!(spread(elbow.particles_m()) > ConstraintConfig::default().chained_bone_tolerance_m);
    }

    #[test]
    fn bad_motion_parameters_are_named() {
        let err = FilterConfig {
            open_loop_velocity_decay_s: Some(0.0),
            ..FilterConfig::default()
        }
        .validate()
        .unwrap_err()
        .to_string();
        assert!(err.contains("open_loop_velocity_decay_s"), "{err}");
        let err = FilterConfig {
            proposal: Proposal::Constrained { max_draws: 0 },
            ..FilterConfig::default()
        }
        .validate()
        .unwrap_err()
        .to_string();
        assert!(err.contains("max_draws"), "{err}");
    }
}
