//! De Marchi et al.'s geometric model: correlate magnitude signals of an IMU and of the joint that
//! carries it.
//!
//! For the IMU worn at `site` and the same joint on a candidate skeleton, three magnitude signals
//! are built on the window's grid, smoothed with a causal moving average of the same length on
//! both sides (same delay, so correlation is unaffected), and compared by Pearson correlation:
//!
//! | model | IMU | skeleton |
//! |---|---|---|
//! | acceleration | `‖world_from_sensor · f − g‖` after a zero-phase 3 Hz Butterworth on each world axis | `‖p̈‖` of the joint, through the same 3 Hz low-pass |
//! | velocity | `‖v‖` from a leaky integral of that linear acceleration | `‖ṗ‖` passed through the *same* leak (`u_k = λ u_{k−1} + (ṗ_k − ṗ_{k−1})`, `u_0 = 0`) |
//! | orientation | rotation angle `2·atan2(‖v‖, w)` of `q_0⁻¹ q_k` | angle between the carrying bone's direction at `k` and at `0` |
//!
//! **Velocity.** The IMU's integral starts at zero in every window and forgets with the leak time
//! constant τ, so it is the velocity *relative to the window start*, high-passed at `1/(2πτ)`.
//! Running the skeleton's velocity through the same recursion gives it exactly the same
//! transfer function and start, so a person walking at constant speed does not add an offset to
//! one side only.
//!
//! **Orientation.** A bone direction has two degrees of freedom (swing); the twist about the bone
//! (forearm pronation) is invisible to the camera. The sensor's mounting on the segment is
//! unknown, so its axis along the bone is unknown too. We therefore compare the IMU's full
//! rotation angle (orientation-invariant: it does not depend on the mounting nor on the world
//! heading reference of the AHRS) with the skeleton's swing angle. The two agree when swing
//! dominates; twist adds to the IMU side only and lowers the correlation for everybody alike.
//! The reference sample is the first one where each side is present.
//!
//! **Carrying segment** ([`carrying_segment`]): the bone from the site's parent to the site
//! (wrist: elbow→wrist, ankle: knee→ankle, elbow: shoulder→elbow, …); the trunk for the pelvis
//! and the chest (pelvis→chest), since the pelvis is the root and the chest's parent is the pelvis.

use crate::angle::{angle_between_rad, rotation_angle_rad};
use crate::features::{ImuFeatures, SegmentFeatures, compare_features};
use crate::kinematic::KinematicConfig;
use crate::signal::{
    Derivative, differentiate_runs, differentiate_runs_both, grid_rate_hz, is_finite3,
    lowpass_vector_pairs, lowpass_vectors, moving_average, nan3,
};
use crate::window::{ImuWindow, ModelScores, SkeletonWindow};
use nalgebra::{UnitQuaternion, Vector3};
use nomen_core::skeleton::Joint;
use nomen_filters::gravity::{STANDARD_GRAVITY_MPS2, remove_gravity_world};
use nomen_filters::lowpass::ButterworthConfig;
use serde::{Deserialize, Serialize};

/// Configuration of the geometric model ([`geometric_scores`] and the magnitude builders).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(default, deny_unknown_fields)]
pub struct GeometricConfig {
    /// Low-pass cut-off for the IMU's linear acceleration and the joint positions, Hz. Default 3 Hz
    /// (De Marchi et al.; [`ButterworthConfig::de_marchi_accelerometer`]).
    pub lowpass_cutoff_hz: f64,
    /// Butterworth order of that low-pass. Default 4 ([`ButterworthConfig::de_marchi_accelerometer`]).
    pub lowpass_order: usize,
    /// Length of the moving average applied to every magnitude signal, samples (1 = none).
    /// Default 5 (≈ 0.17 s at 30 Hz; its first spectral zero at 6 Hz at 30 Hz keeps the 3 Hz
    /// band). De Marchi et al. smooth with a moving average; this length is our choice.
    pub moving_average_len: usize,
    /// Fewest paired finite samples a correlation needs. Default 30 (1 s at 30 Hz, more than the
    /// zero-phase filter's 15-sample padding at order 4).
    pub min_samples: usize,
    /// Leak time constant of the velocity integrator, s. Default 2 s
    /// ([`nomen_filters::gravity::LeakyIntegratorConfig::default`]: corner 0.08 Hz, below human
    /// movement frequencies).
    pub leak_time_constant_s: f64,
    /// Gravity removed from the specific force, m/s². Default
    /// [`STANDARD_GRAVITY_MPS2`].
    pub gravity_mps2: f64,
    /// Whether the low-pass runs forward and backward (zero phase, as De Marchi et al.; the
    /// default) or forward only, as a filter run once per sample while the stream arrives
    /// would. Both sides of every comparison go through the same filter, so a causal one delays
    /// both alike. The engine's clock-offset search follows this setting; causal, it puts a
    /// track on its camera's frame grid first, so that the skeleton's filter keeps time as the
    /// IMU's does (see `nomen_engine`'s `lag_geometric`). Measured in the engine with
    /// `history_pad_s` = 1 s, against the defaults (one run of each scene, paired, points per
    /// run): Belmonte's man without a band anonymous in 99.53 % of his frames (99.51 % with the
    /// defaults; seeds 1–144), −0.22 ± 0.18 per episode; 8 people full network −0.13 ± 0.08
    /// (99.32 → 99.19 %, seeds 1–27), one wrist +0.11 ± 0.06 (98.63 → 98.74 %, seeds 1–33); 5
    /// people one wrist −0.47 ± 1.25 (seeds 1–10); 2 to 5 people full network within 0.09.
    pub zero_phase: bool,
}

impl Default for GeometricConfig {
    fn default() -> Self {
        let butter = ButterworthConfig::de_marchi_accelerometer(1.0);
        Self {
            lowpass_cutoff_hz: butter.cutoff_hz,
            lowpass_order: butter.order,
            moving_average_len: 5,
            min_samples: 30,
            leak_time_constant_s: 2.0,
            gravity_mps2: STANDARD_GRAVITY_MPS2,
            zero_phase: true,
        }
    }
}

impl GeometricConfig {
    fn butterworth(&self, sample_rate_hz: f64) -> ButterworthConfig {
        ButterworthConfig {
            order: self.lowpass_order,
            cutoff_hz: self.lowpass_cutoff_hz,
            sample_rate_hz,
        }
    }
}

/// The bone `(from, to)` whose motion carries a sensor worn at `site`: `(parent, site)`, or the
/// trunk `(Pelvis, Chest)` for the pelvis (the root).
pub fn carrying_segment(site: Joint) -> (Joint, Joint) {
    match site.parent() {
        Some(parent) => (parent, site),
        None => (Joint::Pelvis, Joint::Chest),
    }
}

/// De Marchi's three correlations for the IMU worn at `site` and the joint `site` of a candidate
/// skeleton (see the module docs). A model is `None` when either signal is missing, constant or
/// shorter than [`GeometricConfig::min_samples`], or when the windows' grids differ in length.
pub fn geometric_scores(
    imu: &ImuWindow,
    skel: &SkeletonWindow,
    site: Joint,
    cfg: &GeometricConfig,
) -> ModelScores {
    if imu.t_s.len() != skel.t_s.len() {
        return ModelScores::default();
    }
    let kin = KinematicConfig::default();
    compare_features(
        &ImuFeatures::new(imu, cfg, &kin),
        &SegmentFeatures::new(skel, site, cfg, &kin),
        cfg,
    )
    .0
}

/// Whether the IMU window's series all have the grid's length.
fn is_imu_consistent(imu: &ImuWindow) -> bool {
    let n = imu.t_s.len();
    imu.accel_mps2.len() == n && imu.world_from_sensor.len() == n
}

/// Linear acceleration in the world frame on the window's grid, m/s²: gravity removed with
/// `world_from_sensor`, each world axis zero-phase low-passed (De Marchi's 3 Hz). `NaN` where
/// missing; all `NaN` if the window is inconsistent or too short to filter.
pub fn imu_linear_accel_world(imu: &ImuWindow, cfg: &GeometricConfig) -> Vec<Vector3<f64>> {
    let n = imu.t_s.len();
    let (Some(rate), true) = (grid_rate_hz(&imu.t_s), is_imu_consistent(imu)) else {
        return vec![nan3(); n];
    };
    let mut lin: Vec<Vector3<f64>> = imu
        .world_from_sensor
        .iter()
        .zip(&imu.accel_mps2)
        .map(|(q, f)| remove_gravity_world(q, f, cfg.gravity_mps2).unwrap_or_else(nan3))
        .collect();
    lowpass_vectors(&mut lin, &cfg.butterworth(rate), cfg.zero_phase);
    lin
}

/// Norms of vectors, smoothed; NaN stays NaN.
pub(crate) fn smoothed_norms(v: &[Vector3<f64>], cfg: &GeometricConfig) -> Vec<f64> {
    let mut out: Vec<f64> = v
        .iter()
        .map(|v| if is_finite3(v) { v.norm() } else { f64::NAN })
        .collect();
    moving_average(&mut out, cfg.moving_average_len);
    out
}

/// The leak factor per grid step: `e^{−dt/τ}` (per-step dt from the grid).
pub(crate) fn leak(dt_s: f64, cfg: &GeometricConfig) -> f64 {
    if cfg.leak_time_constant_s > 0.0 && dt_s.is_finite() {
        (-dt_s / cfg.leak_time_constant_s).exp()
    } else {
        0.0
    }
}

/// [`leak`] over the successive steps of one grid, each distinct step computed once: a grid's
/// steps take few distinct values (a camera's frame interval as its times round), and the
/// exponential per step was about 2 % of the engine's time.
pub(crate) struct LeakSteps<'a> {
    cfg: &'a GeometricConfig,
    /// `(bits of dt_s, factor)` of the latest distinct steps, the newest at `next − 1`.
    seen: [(u64, f64); 4],
    len: usize,
    next: usize,
}

impl<'a> LeakSteps<'a> {
    pub(crate) fn new(cfg: &'a GeometricConfig) -> Self {
        Self {
            cfg,
            seen: [(0, 0.0); 4],
            len: 0,
            next: 0,
        }
    }

    /// [`leak`] of `dt_s`, bit for bit.
    pub(crate) fn factor(&mut self, dt_s: f64) -> f64 {
        let bits = dt_s.to_bits();
        if let Some(&(_, f)) = self.seen.iter().take(self.len).find(|(b, _)| *b == bits) {
            return f;
        }
        let f = leak(dt_s, self.cfg);
        if let Some(slot) = self.seen.get_mut(self.next) {
            *slot = (bits, f);
        }
        self.len = (self.len + 1).min(self.seen.len());
        self.next = (self.next + 1) % self.seen.len();
        f
    }
}

/// IMU linear-acceleration magnitude on the window's grid, m/s²: gravity removed with
/// `world_from_sensor`, each world axis zero-phase low-passed (De Marchi's 3 Hz), norm, moving
/// average. `NaN` where missing; all `NaN` if the window is inconsistent or too short to filter.
pub fn imu_accel_magnitude(imu: &ImuWindow, cfg: &GeometricConfig) -> Vec<f64> {
    smoothed_norms(&imu_linear_accel_world(imu, cfg), cfg)
}

/// IMU velocity magnitude, m/s: the low-passed world linear acceleration integrated with a leak
/// (`v_k = e^{−dt/τ} v_{k−1} + dt·a_k`, `v_0 = 0`; a missing sample only leaks), norm, moving
/// average. Compare with [`joint_velocity_magnitude`], which applies the same leak.
pub fn imu_velocity_magnitude(imu: &ImuWindow, cfg: &GeometricConfig) -> Vec<f64> {
    imu_velocity_magnitude_from(imu, &imu_linear_accel_world(imu, cfg), cfg)
}

/// [`imu_velocity_magnitude`] from the window's low-passed world linear acceleration `lin`.
pub(crate) fn imu_velocity_magnitude_from(
    imu: &ImuWindow,
    lin: &[Vector3<f64>],
    cfg: &GeometricConfig,
) -> Vec<f64> {
    let mut v = Vector3::zeros();
    let mut out = Vec::with_capacity(lin.len());
    let mut is_started = false;
    let mut leaks = LeakSteps::new(cfg);
    for (k, a) in lin.iter().enumerate() {
        if k > 0
            && let (Some(t1), Some(t0)) = (imu.t_s.get(k), imu.t_s.get(k - 1))
        {
            let dt_s = t1 - t0;
            v *= leaks.factor(dt_s);
            if is_started && is_finite3(a) {
                v += a * dt_s;
            }
        }
        is_started |= is_finite3(a);
        out.push(if is_started && is_finite3(a) {
            v
        } else {
            nan3()
        });
    }
    smoothed_norms(&out, cfg)
}

/// IMU orientation-change magnitude, rad: the angle `2·atan2(‖v‖, w)` of `q_0⁻¹ q_k`, with `q_0`
/// the first finite orientation of the window; moving average.
pub fn imu_orientation_magnitude(imu: &ImuWindow, cfg: &GeometricConfig) -> Vec<f64> {
    let mut out = imu_orientation_magnitude_every(imu, 1);
    moving_average(&mut out, cfg.moving_average_len);
    out
}

/// [`imu_orientation_magnitude`] without smoothing, at every `step`-th sample only (0, `step`,
/// 2·`step`, …; `step` ≥ 1); the reference is still the window's first finite orientation.
pub(crate) fn imu_orientation_magnitude_every(imu: &ImuWindow, step: usize) -> Vec<f64> {
    let n = imu.t_s.len();
    let step = step.max(1);
    if imu.world_from_sensor.len() != n {
        return vec![f64::NAN; n.div_ceil(step)];
    }
    let is_finite_q = |q: &UnitQuaternion<f64>| q.coords.iter().all(|c| c.is_finite());
    let q0 = imu
        .world_from_sensor
        .iter()
        .find(|q| is_finite_q(q))
        .copied();
    imu.world_from_sensor
        .iter()
        .step_by(step)
        .map(|q| match q0 {
            Some(q0) if is_finite_q(q) => rotation_angle_rad(&(q0.inverse() * q)),
            _ => f64::NAN,
        })
        .collect()
}

/// Positions of `joint` on the window's grid (NaN where absent or non-finite).
pub(crate) fn joint_positions(skel: &SkeletonWindow, joint: Joint) -> Vec<Vector3<f64>> {
    skel.joints_world_m
        .iter()
        .map(|j| j.get(joint).map_or_else(nan3, |p| p.coords))
        .map(|v| if is_finite3(&v) { v } else { nan3() })
        .collect()
}

/// The first or second derivative of `joint`'s position, then low-passed like the IMU (NaN where
/// missing or unfilterable). Differentiating first and filtering second is the same linear
/// operation in the interior, but keeps the ends right: the filter's odd padding of *positions*
/// would force zero curvature at the window's edges, while the IMU's acceleration is padded as an
/// acceleration.
pub(crate) fn filtered_joint_derivative(
    skel: &SkeletonWindow,
    joint: Joint,
    which: Derivative,
    cfg: &GeometricConfig,
) -> Option<Vec<Vector3<f64>>> {
    if skel.joints_world_m.len() != skel.t_s.len() {
        return None;
    }
    let rate = grid_rate_hz(&skel.t_s)?;
    let mut d = differentiate_runs(&skel.t_s, &joint_positions(skel, joint), which);
    lowpass_vectors(&mut d, &cfg.butterworth(rate), cfg.zero_phase);
    Some(d)
}

/// A joint's low-passed velocity and acceleration on a window's grid.
pub(crate) type JointDerivatives = (Vec<Vector3<f64>>, Vec<Vector3<f64>>);

/// [`filtered_joint_derivative`] for both derivatives, `(velocity, acceleration)`, each the
/// same as its own call, of a joint's positions read beforehand ([`joint_positions`] of the
/// same window): both are differentiated in one pass and filtered side by side.
pub(crate) fn filtered_derivatives_of(
    skel: &SkeletonWindow,
    positions: &[Vector3<f64>],
    cfg: &GeometricConfig,
) -> Option<JointDerivatives> {
    if skel.joints_world_m.len() != skel.t_s.len() {
        return None;
    }
    let rate = grid_rate_hz(&skel.t_s)?;
    let (mut vel, mut acc) = differentiate_runs_both(&skel.t_s, positions);
    lowpass_vector_pairs(&mut vel, &mut acc, &cfg.butterworth(rate), cfg.zero_phase);
    Some((vel, acc))
}

/// Joint acceleration magnitude, m/s²: second derivative of the position
/// ([`nomen_filters::derivative::acceleration`], per run of present samples), zero-phase
/// low-passed with the IMU's filter, norm, moving average. `NaN` where missing.
pub fn joint_accel_magnitude(
    skel: &SkeletonWindow,
    joint: Joint,
    cfg: &GeometricConfig,
) -> Vec<f64> {
    let Some(a) = filtered_joint_derivative(skel, joint, Derivative::Acceleration, cfg) else {
        return vec![f64::NAN; skel.t_s.len()];
    };
    smoothed_norms(&a, cfg)
}

/// Joint velocity magnitude, m/s: first derivative, low-passed with the IMU's filter, then the IMU
/// integrator's leak (`u_k = e^{−dt/τ} u_{k−1} + (ṗ_k − ṗ_{k−1})`, `u_0 = 0`; see the module
/// docs), norm, moving average. `NaN` where missing.
pub fn joint_velocity_magnitude(
    skel: &SkeletonWindow,
    joint: Joint,
    cfg: &GeometricConfig,
) -> Vec<f64> {
    let Some(vel) = filtered_joint_derivative(skel, joint, Derivative::Velocity, cfg) else {
        return vec![f64::NAN; skel.t_s.len()];
    };
    joint_velocity_magnitude_from(skel, &vel, cfg)
}

/// [`joint_velocity_magnitude`] from the joint's low-passed velocity `vel`.
pub(crate) fn joint_velocity_magnitude_from(
    skel: &SkeletonWindow,
    vel: &[Vector3<f64>],
    cfg: &GeometricConfig,
) -> Vec<f64> {
    let mut u = Vector3::zeros();
    let mut last: Option<Vector3<f64>> = None;
    let mut out = Vec::with_capacity(vel.len());
    let mut leaks = LeakSteps::new(cfg);
    for (k, v) in vel.iter().enumerate() {
        if k > 0
            && let (Some(t1), Some(t0)) = (skel.t_s.get(k), skel.t_s.get(k - 1))
        {
            u *= leaks.factor(t1 - t0);
        }
        if is_finite3(v) {
            if let Some(prev) = last {
                u += v - prev;
            }
            last = Some(*v);
            out.push(u);
        } else {
            out.push(nan3());
        }
    }
    smoothed_norms(&out, cfg)
}

/// Orientation-change magnitude of the segment carrying a sensor at `site`
/// ([`carrying_segment`]), rad: the angle between the bone direction at `k` and at the first
/// sample where the bone is present; moving average. `NaN` where missing or degenerate.
pub fn segment_orientation_magnitude(
    skel: &SkeletonWindow,
    site: Joint,
    cfg: &GeometricConfig,
) -> Vec<f64> {
    let dirs = bone_directions(&segment_bones(skel, site));
    segment_orientation_magnitude_from(&dirs, skel.t_s.len(), cfg)
}

/// The segment carrying a sensor at `site` ([`carrying_segment`]) per sample of a window, from
/// its parent joint to its child (`NaN` where either is missing).
pub(crate) fn segment_bones(skel: &SkeletonWindow, site: Joint) -> Vec<Vector3<f64>> {
    segment_bones_with(skel, site, &joint_positions(skel, site))
}

/// [`segment_bones`] with the positions of `site` itself read beforehand ([`joint_positions`]
/// of the same window), which the segment ends at unless `site` has no parent.
pub(crate) fn segment_bones_with(
    skel: &SkeletonWindow,
    site: Joint,
    site_positions: &[Vector3<f64>],
) -> Vec<Vector3<f64>> {
    let (from, to) = carrying_segment(site);
    let read;
    let to_positions = if to == site {
        site_positions
    } else {
        read = joint_positions(skel, to);
        &read
    };
    to_positions
        .iter()
        .zip(joint_positions(skel, from))
        .map(|(b, a)| b - a)
        .collect()
}

/// Each bone's unit direction (`None` where it is missing or shorter than a nanometre).
pub(crate) fn bone_directions(bones: &[Vector3<f64>]) -> Vec<Option<Vector3<f64>>> {
    bones
        .iter()
        .map(|d| d.try_normalize(1e-9).filter(is_finite3))
        .collect()
}

/// [`segment_orientation_magnitude`] from the segment's directions ([`bone_directions`]) on
/// a grid of `n` samples.
pub(crate) fn segment_orientation_magnitude_from(
    dirs: &[Option<Vector3<f64>>],
    n: usize,
    cfg: &GeometricConfig,
) -> Vec<f64> {
    let d0 = dirs.iter().flatten().next().copied();
    let mut out: Vec<f64> = dirs
        .iter()
        .map(|d| match (d0, d) {
            (Some(d0), Some(d)) => angle_between_rad(&d0, d),
            _ => f64::NAN,
        })
        .collect();
    out.resize(n, f64::NAN);
    moving_average(&mut out, cfg.moving_average_len);
    out
}
