//! Belmonte-Hernández et al.'s costs for a wrist band against a skeleton: the forearm's pitch and
//! the body's yaw rate, compared by mean squared error (lower = more alike).
//!
//! **Pitch.** The skeleton's forearm pitch is the elevation of the elbow→wrist vector,
//! `atan2(d_z, ‖d_xy‖)`. The band's pitch is the world elevation `asin((R_k e)_z)` of the sensor
//! axis `e` that lies along the forearm. The band's mounting is not known in general, so unless
//! [`BelmonteConfig::forearm_axis`] fixes it, every signed sensor axis (±x, ±y, ±z) is tried and
//! the one with the lowest MSE against *this* candidate is kept. Every candidate gets the same six
//! hypotheses, so the comparison between candidates stays fair; the axis picked is reported in
//! [`BelmonteCosts::forearm_axis`] so the engine can fix it once it trusts a match. Using the
//! elevation of a world-frame axis needs only the AHRS's tilt (gravity), not its heading.
//!
//! **Yaw rate.** The skeleton's yaw is the heading of its shoulder line (left→right shoulder,
//! projected on the horizontal plane), falling back to the hip line where the shoulders are
//! missing; it is unwrapped and differentiated. The band's yaw rate is the world-frame vertical
//! component of its angular rate, `(world_from_sensor · ω)_z`. While a person turns, the band
//! turns with the trunk; the arm's own yawing is the noise of this model.
//!
//! **Side.** [`Side::Unknown`] evaluates both wrists and keeps the one with the lower pitch MSE
//! (the yaw cost does not depend on the side).

use crate::kinematic::elevation_rad;
use crate::signal::{Derivative, differentiate_runs, moving_average};
use crate::window::{ImuWindow, SkeletonWindow};
use nalgebra::{UnitQuaternion, Vector3};
use nomen_core::skeleton::Joint;
use serde::{Deserialize, Serialize};

/// Which wrist a band is worn on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Side {
    /// Left wrist.
    Left,
    /// Right wrist.
    Right,
    /// Not known: both wrists are tried and the better kept.
    #[default]
    Unknown,
}

impl Side {
    /// The wrists a band on this side may be on.
    pub fn wrists(self) -> &'static [Joint] {
        match self {
            Side::Left => &[Joint::LeftWrist],
            Side::Right => &[Joint::RightWrist],
            Side::Unknown => &[Joint::LeftWrist, Joint::RightWrist],
        }
    }
}

/// A signed sensor axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "snake_case")]
pub enum SensorAxis {
    /// +x.
    PosX,
    /// −x.
    NegX,
    /// +y.
    PosY,
    /// −y.
    NegY,
    /// +z.
    PosZ,
    /// −z.
    NegZ,
}

impl SensorAxis {
    /// All six signed axes.
    pub const ALL: [SensorAxis; 6] = [
        SensorAxis::PosX,
        SensorAxis::NegX,
        SensorAxis::PosY,
        SensorAxis::NegY,
        SensorAxis::PosZ,
        SensorAxis::NegZ,
    ];

    /// The unit vector in the sensor frame.
    pub fn unit(self) -> Vector3<f64> {
        match self {
            SensorAxis::PosX => Vector3::x(),
            SensorAxis::NegX => -Vector3::x(),
            SensorAxis::PosY => Vector3::y(),
            SensorAxis::NegY => -Vector3::y(),
            SensorAxis::PosZ => Vector3::z(),
            SensorAxis::NegZ => -Vector3::z(),
        }
    }

    /// Which sensor axis (0 for x, 1 for y, 2 for z) and whether it points the positive way.
    pub fn index_and_sign(self) -> (usize, bool) {
        match self {
            SensorAxis::PosX => (0, true),
            SensorAxis::NegX => (0, false),
            SensorAxis::PosY => (1, true),
            SensorAxis::NegY => (1, false),
            SensorAxis::PosZ => (2, true),
            SensorAxis::NegZ => (2, false),
        }
    }

    /// The axis pointing the other way.
    pub fn opposite(self) -> SensorAxis {
        match self {
            SensorAxis::PosX => SensorAxis::NegX,
            SensorAxis::NegX => SensorAxis::PosX,
            SensorAxis::PosY => SensorAxis::NegY,
            SensorAxis::NegY => SensorAxis::PosY,
            SensorAxis::PosZ => SensorAxis::NegZ,
            SensorAxis::NegZ => SensorAxis::PosZ,
        }
    }
}

/// Configuration of [`belmonte_costs`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(default, deny_unknown_fields)]
pub struct BelmonteConfig {
    /// The sensor axis along the forearm (elbow→wrist), if the mounting is known. Default `None`:
    /// search all six signed axes per candidate (see the module docs).
    pub forearm_axis: Option<SensorAxis>,
    /// Moving-average length applied to every compared signal, samples (1 = none). Default 5, as
    /// [`crate::GeometricConfig::moving_average_len`].
    pub moving_average_len: usize,
    /// Fewest paired finite samples a cost needs. Default 30 (1 s at 30 Hz).
    pub min_samples: usize,
    /// Shortest horizontal shoulder (or hip) line that defines a heading, m. Default 0.05 m: a
    /// tenth of a typical 0.35–0.4 m shoulder width, below which the line is vertical or a
    /// detection error.
    pub min_heading_line_m: f64,
}

impl Default for BelmonteConfig {
    fn default() -> Self {
        Self {
            forearm_axis: None,
            moving_average_len: 5,
            min_samples: 30,
            min_heading_line_m: 0.05,
        }
    }
}

/// Belmonte-Hernández's costs for one (band, skeleton) pair; lower is more alike.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct BelmonteCosts {
    /// Mean squared difference of forearm pitch, rad². `None` when a signal is missing or short.
    pub pitch_mse: Option<f64>,
    /// Mean squared difference of yaw rate, (rad/s)². `None` when a signal is missing or short.
    pub yaw_rate_mse: Option<f64>,
    /// The wrist whose forearm gave `pitch_mse` (the better one for [`Side::Unknown`]).
    pub wrist: Option<Joint>,
    /// The sensor axis taken as the forearm for `pitch_mse`.
    pub forearm_axis: Option<SensorAxis>,
}

/// Mean squared difference over indices where both are finite; `None` below `min_samples`.
pub fn mse(x: &[f64], y: &[f64], min_samples: usize) -> Option<f64> {
    let (mut n, mut sum) = (0usize, 0.0);
    for (a, b) in x.iter().zip(y) {
        if a.is_finite() && b.is_finite() {
            n += 1;
            sum += (a - b).powi(2);
        }
    }
    (n >= min_samples.max(1)).then(|| sum / n as f64)
}

/// [`mse`] of `x` and of `x` negated against `y`, in one pass: the same sums in the same order
/// as each alone (`−a − b` is what `mse` computes for the negated `a`).
fn mse_and_negated(x: &[f64], y: &[f64], min_samples: usize) -> (Option<f64>, Option<f64>) {
    let (mut n, mut sum, mut sum_negated) = (0usize, 0.0, 0.0);
    for (a, b) in x.iter().zip(y) {
        if a.is_finite() && b.is_finite() {
            n += 1;
            sum += (a - b).powi(2);
            sum_negated += (-a - b).powi(2);
        }
    }
    let mean = |s: f64| (n >= min_samples.max(1)).then(|| s / n as f64);
    (mean(sum), mean(sum_negated))
}

/// Belmonte-Hernández's pitch and yaw-rate costs of the band `imu` worn on the `side` wrist
/// against the candidate skeleton `skel` (see the module docs). Never panics on bad data: a
/// cost is `None` when its signals are missing, inconsistent or too short.
pub fn belmonte_costs(
    imu: &ImuWindow,
    skel: &SkeletonWindow,
    side: Side,
    cfg: &BelmonteConfig,
) -> BelmonteCosts {
    if imu.t_s.len() != skel.t_s.len() {
        return BelmonteCosts::default();
    }
    belmonte_costs_from(
        &BandSignals::new(imu, cfg),
        &ForearmSignals::new(skel, side, cfg),
        side,
        cfg,
    )
}

/// The band side of [`belmonte_costs`], built once per window and compared with many
/// skeletons: the pitch of each candidate sensor axis and the yaw rate.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct BandSignals {
    /// Pitch per candidate forearm axis (`BelmonteConfig::forearm_axis`, or all six), rad; a
    /// negative axis's the exact negation of its positive axis's (private, so that it stays
    /// so: [`belmonte_costs_from`] prices both from one pass).
    axis_pitch_rad: Vec<(SensorAxis, Vec<f64>)>,
    /// Yaw rate ([`band_yaw_rate_radps`]).
    pub yaw_rate_radps: Vec<f64>,
}

impl BandSignals {
    /// Pitch per candidate forearm axis (`BelmonteConfig::forearm_axis`, or all six, in
    /// [`SensorAxis::ALL`]'s order), rad.
    pub fn axis_pitch_rad(&self) -> &[(SensorAxis, Vec<f64>)] {
        &self.axis_pitch_rad
    }

    /// The band's signals over its window.
    pub fn new(imu: &ImuWindow, cfg: &BelmonteConfig) -> Self {
        let pitches: Vec<[f64; 3]> = imu.world_from_sensor.iter().map(axis_pitches_rad).collect();
        Self::from_parts(imu, &pitches, vertical_rate_unsmoothed_radps(imu), cfg)
    }

    /// [`BandSignals::new`] from parts built beforehand by a caller that resamples the same IMU
    /// samples onto many grids: each grid sample's [`axis_pitches_rad`] (one per orientation of
    /// `imu`, in order), computed once per sample, and the window's
    /// [`vertical_rate_unsmoothed_radps`], which the grid's suffixes share (one of another length
    /// counts as missing).
    pub fn from_parts(
        imu: &ImuWindow,
        pitches: &[[f64; 3]],
        unsmoothed_yaw_rate_radps: Vec<f64>,
        cfg: &BelmonteConfig,
    ) -> Self {
        let axes: &[SensorAxis] = match &cfg.forearm_axis {
            Some(axis) => std::slice::from_ref(axis),
            None => &SensorAxis::ALL,
        };
        // A −axis's pitch is the +axis's negated, exactly (see [`axis_pitches_rad`]): the
        // arctangents are computed for three axes, not six, and once per sample. So is its
        // moving average (rounding is symmetric), which is smoothed once per axis too.
        let mut smoothed: [Option<Vec<f64>>; 3] = Default::default();
        let axis_pitch_rad = axes
            .iter()
            .map(|&axis| {
                let (k, is_positive) = axis.index_and_sign();
                let positive = smoothed[k].get_or_insert_with(|| {
                    let mut out: Vec<f64> = pitches.iter().map(|p| p[k]).collect();
                    out.resize(imu.t_s.len(), f64::NAN);
                    moving_average(&mut out, cfg.moving_average_len);
                    out
                });
                let out = if is_positive {
                    positive.clone()
                } else {
                    positive.iter().map(|v| -v).collect()
                };
                (axis, out)
            })
            .collect();
        BandSignals {
            axis_pitch_rad,
            yaw_rate_radps: smoothed_rate(imu, unsmoothed_yaw_rate_radps, cfg.moving_average_len),
        }
    }
}

/// The skeleton side of [`belmonte_costs`] for a band on `side`, built once per track and
/// window: the forearm pitch of each wrist the band may be on, and the chest yaw rate.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ForearmSignals {
    /// Forearm pitch per candidate wrist ([`forearm_pitch_rad`]), rad.
    pub wrist_pitch_rad: Vec<(Joint, Vec<f64>)>,
    /// Chest yaw rate ([`skeleton_yaw_rate_radps`]).
    pub yaw_rate_radps: Vec<f64>,
}

impl ForearmSignals {
    /// The skeleton's signals for a band on `side` over its window.
    pub fn new(skel: &SkeletonWindow, side: Side, cfg: &BelmonteConfig) -> Self {
        ForearmSignals {
            wrist_pitch_rad: wrist_pitches(skel, side, cfg),
            yaw_rate_radps: skeleton_yaw_rate_radps(skel, cfg),
        }
    }

    /// [`ForearmSignals::new`] with the skeleton's yaw rate before smoothing given
    /// ([`skeleton_yaw_rate_unsmoothed_radps`] of the same skeleton and config).
    pub fn with_unsmoothed_yaw_rate(
        skel: &SkeletonWindow,
        side: Side,
        cfg: &BelmonteConfig,
        mut yaw_rate_radps: Vec<f64>,
    ) -> Self {
        moving_average(&mut yaw_rate_radps, cfg.moving_average_len);
        ForearmSignals {
            wrist_pitch_rad: wrist_pitches(skel, side, cfg),
            yaw_rate_radps,
        }
    }

    /// [`ForearmSignals::new`] for `side`, of the skeleton and config these signals were built
    /// from: the yaw rate, which is the body's whatever the side, is taken from them.
    pub fn for_side(&self, skel: &SkeletonWindow, side: Side, cfg: &BelmonteConfig) -> Self {
        ForearmSignals {
            wrist_pitch_rad: wrist_pitches(skel, side, cfg),
            yaw_rate_radps: self.yaw_rate_radps.clone(),
        }
    }
}

/// [`forearm_pitch_rad`] of each wrist `side` names.
fn wrist_pitches(
    skel: &SkeletonWindow,
    side: Side,
    cfg: &BelmonteConfig,
) -> Vec<(Joint, Vec<f64>)> {
    side.wrists()
        .iter()
        .map(|&w| (w, forearm_pitch_rad(skel, w, cfg)))
        .collect()
}

/// [`belmonte_costs`] from signals built beforehand on the same grid; `side` picks the wrists
/// of `arm` compared (all default when the lengths differ).
pub fn belmonte_costs_from(
    band: &BandSignals,
    arm: &ForearmSignals,
    side: Side,
    cfg: &BelmonteConfig,
) -> BelmonteCosts {
    if band.yaw_rate_radps.len() != arm.yaw_rate_radps.len() {
        return BelmonteCosts::default();
    }
    let mut best: Option<(f64, Joint, SensorAxis)> = None;
    for (wrist, skel_pitch) in arm
        .wrist_pitch_rad
        .iter()
        .filter(|(w, _)| side.wrists().contains(w))
    {
        // The lowest pitch MSE over the candidate sensor axes, for this wrist, in the axes'
        // order. A negative axis right after its positive one is priced in the same pass: its
        // pitch is the other's negated, exactly (see `BandSignals::axis_pitch_rad`).
        let mut wrist_best: Option<(f64, SensorAxis)> = None;
        let mut consider = |cost: Option<f64>, axis: SensorAxis| {
            if let Some(cost) = cost
                && wrist_best.is_none_or(|(b, _)| cost < b)
            {
                wrist_best = Some((cost, axis));
            }
        };
        let mut axes = band.axis_pitch_rad.iter().peekable();
        while let Some((axis, pitch)) = axes.next() {
            let (k, is_positive) = axis.index_and_sign();
            match axes.next_if(|(next, _)| is_positive && next.index_and_sign() == (k, false)) {
                Some((negative, _)) => {
                    let (own, negated) = mse_and_negated(pitch, skel_pitch, cfg.min_samples);
                    consider(own, *axis);
                    consider(negated, *negative);
                }
                None => consider(mse(pitch, skel_pitch, cfg.min_samples), *axis),
            }
        }
        if let Some((cost, axis)) = wrist_best
            && best.is_none_or(|(b, _, _)| cost < b)
        {
            best = Some((cost, *wrist, axis));
        }
    }
    BelmonteCosts {
        pitch_mse: best.map(|b| b.0),
        yaw_rate_mse: mse(&band.yaw_rate_radps, &arm.yaw_rate_radps, cfg.min_samples),
        wrist: best.map(|b| b.1),
        forearm_axis: best.map(|b| b.2),
    }
}

/// Elevation of the elbow→wrist vector of `wrist`'s forearm, rad, smoothed (NaN where missing).
pub fn forearm_pitch_rad(skel: &SkeletonWindow, wrist: Joint, cfg: &BelmonteConfig) -> Vec<f64> {
    let elbow = wrist.parent().unwrap_or(wrist);
    let mut out: Vec<f64> = skel
        .joints_world_m
        .iter()
        .map(|j| match (j.get(elbow), j.get(wrist)) {
            (Some(e), Some(w)) => elevation_rad(&(w - e)),
            _ => f64::NAN,
        })
        .collect();
    out.resize(skel.t_s.len(), f64::NAN);
    moving_average(&mut out, cfg.moving_average_len);
    out
}

/// Unsmoothed world elevation of the sensor's +x, +y and +z axes for one orientation, rad
/// (`NaN` where not finite): a −axis's is the +axis's negated, exactly (the rotation, the
/// horizontal length and `atan2` are odd in the axis, and IEEE rounding is symmetric).
pub fn axis_pitches_rad(q: &UnitQuaternion<f64>) -> [f64; 3] {
    [Vector3::x(), Vector3::y(), Vector3::z()].map(|e| elevation_rad(&(q * e)))
}

/// World elevation of the sensor axis `axis`, rad, smoothed (NaN where missing).
pub fn band_axis_pitch_rad(imu: &ImuWindow, axis: SensorAxis, cfg: &BelmonteConfig) -> Vec<f64> {
    let e = axis.unit();
    let mut out: Vec<f64> = imu
        .world_from_sensor
        .iter()
        .map(|q| elevation_rad(&(q * e)))
        .collect();
    out.resize(imu.t_s.len(), f64::NAN);
    moving_average(&mut out, cfg.moving_average_len);
    out
}

/// The band's world-frame vertical angular rate `(world_from_sensor · ω)_z`, rad/s, smoothed.
pub fn band_yaw_rate_radps(imu: &ImuWindow, cfg: &BelmonteConfig) -> Vec<f64> {
    smoothed_rate(
        imu,
        vertical_rate_unsmoothed_radps(imu),
        cfg.moving_average_len,
    )
}

/// The sensor's world-frame vertical angular rate `(world_from_sensor · ω)_z` at each sample of
/// its window, rad/s, before any smoothing (`NaN` where not finite). Each value depends on its
/// own sample alone, so the suffixes of a window share it.
pub fn vertical_rate_unsmoothed_radps(imu: &ImuWindow) -> Vec<f64> {
    imu.world_from_sensor
        .iter()
        .zip(&imu.gyro_radps)
        .map(|(q, w): (&UnitQuaternion<f64>, _)| {
            let z = (q * w).z;
            if z.is_finite() { z } else { f64::NAN }
        })
        .collect()
}

/// `unsmoothed` (a rate per sample of `imu`'s window; all missing if its length is another)
/// averaged over `len` samples.
pub(crate) fn smoothed_rate(imu: &ImuWindow, mut unsmoothed: Vec<f64>, len: usize) -> Vec<f64> {
    let n = imu.t_s.len();
    if unsmoothed.len() != n {
        unsmoothed = vec![f64::NAN; n];
    }
    moving_average(&mut unsmoothed, len);
    unsmoothed
}

/// The skeleton's heading from its shoulder line (hip line where the shoulders are missing),
/// unwrapped within each run of present samples, rad (NaN where missing).
pub fn skeleton_heading_rad(skel: &SkeletonWindow, cfg: &BelmonteConfig) -> Vec<f64> {
    let line = |j: &nomen_core::skeleton::Joints<nalgebra::Point3<f64>>, l: Joint, r: Joint| {
        let d = j.get(r)? - j.get(l)?;
        let h = d.x.hypot(d.y);
        (h.is_finite() && h >= cfg.min_heading_line_m).then(|| crate::angle::atan2(d.y, d.x))
    };
    let mut out = Vec::with_capacity(skel.t_s.len());
    let mut prev: Option<f64> = None;
    for j in &skel.joints_world_m {
        let psi = line(j, Joint::LeftShoulder, Joint::RightShoulder)
            .or_else(|| line(j, Joint::LeftHip, Joint::RightHip));
        match psi {
            Some(psi) => {
                // Unwrap: move by the wrapped difference from the previous present sample.
                let unwrapped = match prev {
                    Some(p) => p + wrap_pi(psi - p),
                    None => psi,
                };
                prev = Some(unwrapped);
                out.push(unwrapped);
            }
            None => {
                prev = None;
                out.push(f64::NAN);
            }
        }
    }
    out.resize(skel.t_s.len(), f64::NAN);
    out
}

/// The skeleton's yaw rate, rad/s: derivative of [`skeleton_heading_rad`], smoothed.
pub fn skeleton_yaw_rate_radps(skel: &SkeletonWindow, cfg: &BelmonteConfig) -> Vec<f64> {
    let mut out = skeleton_yaw_rate_unsmoothed_radps(skel, cfg);
    moving_average(&mut out, cfg.moving_average_len);
    out
}

/// [`skeleton_yaw_rate_radps`] before its moving average (`cfg`'s other fields apply), for a
/// caller that smooths one skeleton's rate over several lengths.
pub fn skeleton_yaw_rate_unsmoothed_radps(skel: &SkeletonWindow, cfg: &BelmonteConfig) -> Vec<f64> {
    let heading: Vec<Vector3<f64>> = skeleton_heading_rad(skel, cfg)
        .into_iter()
        .map(|psi| Vector3::new(psi, 0.0, 0.0))
        .collect();
    differentiate_runs(&skel.t_s, &heading, Derivative::Velocity)
        .iter()
        .map(|v| v.x)
        .collect()
}

/// An angle wrapped into `(−π, π]`.
fn wrap_pi(a: f64) -> f64 {
    let tau = std::f64::consts::TAU;
    let w = a - tau * (a / tau).round();
    if w <= -std::f64::consts::PI {
        w + tau
    } else {
        w
    }
}
