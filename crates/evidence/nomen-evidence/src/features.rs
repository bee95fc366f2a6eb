//! Features: every signal one side of an (IMU, joint) comparison contributes to De Marchi's
//! models ([`crate::geometric`]) and to nomen's ([`crate::kinematic`]), built once per window and
//! compared with many candidates.
//!
//! An engine compares each IMU with the same joint of every track, and each track with the IMUs
//! of every subject. Filtering, differentiating and integrating a window costs far more than
//! correlating two finished signals, so [`ImuFeatures`] is built once per (IMU, window grid) and
//! [`SegmentFeatures`] once per (track, site), and [`compare_features`] only runs the Pearson
//! correlations; [`compare_prepared`] takes each side's signals prepared once as well
//! ([`ImuFeatures::units`], [`SegmentFeatures::units`]), so that a pair costs a dot product per
//! model. [`crate::geometric_scores`] and [`crate::kinematic_scores`] are this same path
//! for one pair.

use crate::belmonte::vertical_rate_unsmoothed_radps;
use crate::geometric::{
    GeometricConfig, bone_directions, filtered_derivatives_of, filtered_joint_derivative,
    imu_linear_accel_world, imu_orientation_magnitude, imu_orientation_magnitude_every,
    imu_velocity_magnitude_from, joint_positions, joint_velocity_magnitude_from, segment_bones,
    segment_bones_with, segment_orientation_magnitude, segment_orientation_magnitude_from,
    smoothed_norms,
};
use crate::kinematic::{
    KinematicConfig, KinematicScores, body_turn_rate_signal, elevation_rad, imu_swing,
    imu_swing_every, imu_turn_rate_from, imu_turn_rate_signal, imu_vertical_velocity,
    joint_vertical_velocity, lag_samples, segment_swing_from,
};
use crate::signal::{Derivative, UnitSignal, moving_average, pearson_prepared};
use crate::window::{ImuWindow, ModelScores, SkeletonWindow};
use nalgebra::{UnitQuaternion, Vector3};
use nomen_core::skeleton::Joint;

/// The IMU side of every model, on its window's grid (`NaN` where missing).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ImuFeatures {
    /// Linear-acceleration magnitude ([`crate::imu_accel_magnitude`]).
    pub accel_magnitude: Vec<f64>,
    /// Velocity magnitude ([`crate::imu_velocity_magnitude`]).
    pub velocity_magnitude: Vec<f64>,
    /// Orientation-change magnitude ([`crate::imu_orientation_magnitude`]).
    pub orientation_magnitude: Vec<f64>,
    /// Swing angle over the swing lag, smoothed.
    pub swing: Vec<f64>,
    /// World-vertical linear acceleration, smoothed.
    pub vertical_accel: Vec<f64>,
    /// Leaky vertical velocity, smoothed.
    pub vertical_velocity: Vec<f64>,
    /// Elevation of each sensor axis (x, y, z), smoothed.
    pub axis_elevation: [Vec<f64>; 3],
    /// Angular rate about the world vertical ([`crate::imu_turn_rate_signal`]).
    pub turn_rate: Vec<f64>,
    /// World-horizontal linear acceleration `(x, y)` in the IMU's own heading frame (its AHRS
    /// knows up, not north), smoothed.
    pub horizontal_accel: [Vec<f64>; 2],
}

impl ImuFeatures {
    /// Every IMU-side signal of `imu`'s window.
    pub fn new(imu: &ImuWindow, geo: &GeometricConfig, kin: &KinematicConfig) -> Self {
        let elevations: Vec<[f64; 3]> = imu
            .world_from_sensor
            .iter()
            .map(axis_elevations_rad)
            .collect();
        Self::from_parts(
            imu,
            &imu_linear_accel_world(imu, geo),
            &elevations,
            None,
            geo,
            kin,
        )
    }

    /// [`ImuFeatures::new`] from two parts built beforehand, for a caller that resamples the
    /// same IMU samples onto many grids: `lin_world_mps2`, the world linear acceleration on
    /// this window's grid, low-passed ([`imu_linear_accel_world`] of this window, or of a
    /// longer one that this window ends, sliced), and each orientation's
    /// [`axis_elevations_rad`], in order (computed once per IMU sample). A linear acceleration
    /// whose length is not the window's counts as missing.
    ///
    /// A sliced acceleration is filtered from before the window's start, where the skeleton's
    /// is not (its low-pass starts with the track): compare it with a skeleton whose run
    /// edges are dropped ([`SegmentFeatures::drop_run_edges`]).
    ///
    /// `shared_raw`, if given, is the [`RawSignals`] of a longer window that this one ends and
    /// the index of this window's first sample in it: the swing angles are taken from it where
    /// it holds them at the lag this window's swing uses, and the vertical rates before
    /// smoothing (the same values, each computed once for all the suffixes of a grid).
    pub fn from_parts(
        imu: &ImuWindow,
        lin_world_mps2: &[Vector3<f64>],
        elevations: &[[f64; 3]],
        shared_raw: Option<(&RawSignals, usize)>,
        geo: &GeometricConfig,
        kin: &KinematicConfig,
    ) -> Self {
        let smooth = |mut v: Vec<f64>| {
            moving_average(&mut v, geo.moving_average_len);
            v
        };
        let n = imu.t_s.len();
        let missing;
        let lin = if lin_world_mps2.len() == n {
            lin_world_mps2
        } else {
            missing = vec![Vector3::repeat(f64::NAN); n];
            &missing
        };
        let mut axis_elevation: [Vec<f64>; 3] = Default::default();
        for (k, axis) in axis_elevation.iter_mut().enumerate() {
            axis.extend(elevations.iter().map(|e| e[k]));
        }
        let [ex, ey, ez] = axis_elevation;
        ImuFeatures {
            accel_magnitude: smoothed_norms(lin, geo),
            velocity_magnitude: imu_velocity_magnitude_from(imu, lin, geo),
            orientation_magnitude: imu_orientation_magnitude(imu, geo),
            swing: smooth({
                let lag = lag_samples(&imu.t_s, kin);
                shared_raw
                    .and_then(|(raw, from)| raw.swing_suffix(from, lag, n))
                    .unwrap_or_else(|| imu_swing(imu, lag))
            }),
            vertical_accel: smooth(lin.iter().map(|a| a.z).collect()),
            vertical_velocity: smooth(imu_vertical_velocity(imu, lin, geo)),
            axis_elevation: [smooth(ex), smooth(ey), smooth(ez)],
            turn_rate: imu_turn_rate_from(imu, RawSignals::vertical_rate_of(shared_raw, imu), kin),
            horizontal_accel: [
                smooth(lin.iter().map(|a| a.x).collect()),
                smooth(lin.iter().map(|a| a.y).collect()),
            ],
        }
    }

    /// [`ImuFeatures::from_parts`] on a grid that starts `anchor` samples before the window:
    /// the filtered and smoothed signals carry the samples before the window (as a filter run
    /// per sample would), the window-anchored models (orientation change, velocity, vertical
    /// velocity) start at the window's first sample as always, and only the window's part of
    /// every signal is kept. `anchor` 0 is [`ImuFeatures::from_parts`].
    pub fn from_parts_anchored(
        imu: &ImuWindow,
        lin_world_mps2: &[Vector3<f64>],
        elevations: &[[f64; 3]],
        shared_raw: Option<(&RawSignals, usize)>,
        geo: &GeometricConfig,
        kin: &KinematicConfig,
        anchor: usize,
    ) -> Self {
        let mut features = Self::from_parts(imu, lin_world_mps2, elevations, shared_raw, geo, kin);
        if anchor == 0 {
            return features;
        }
        features.drop_front(anchor);
        let tail = imu.tail(anchor);
        let n = tail.t_s.len();
        let missing;
        let lin = match lin_world_mps2.get(anchor..) {
            Some(lin) if lin.len() == n => lin,
            _ => {
                missing = vec![Vector3::repeat(f64::NAN); n];
                &missing
            }
        };
        let mut vertical = imu_vertical_velocity(&tail, lin, geo);
        moving_average(&mut vertical, geo.moving_average_len);
        features.velocity_magnitude = imu_velocity_magnitude_from(&tail, lin, geo);
        features.orientation_magnitude = imu_orientation_magnitude(&tail, geo);
        features.vertical_velocity = vertical;
        features
    }

    /// Drops the first `k` grid samples of every signal.
    pub fn drop_front(&mut self, k: usize) {
        let [ex, ey, ez] = &mut self.axis_elevation;
        let [hx, hy] = &mut self.horizontal_accel;
        for v in [
            &mut self.accel_magnitude,
            &mut self.velocity_magnitude,
            &mut self.orientation_magnitude,
            &mut self.swing,
            &mut self.vertical_accel,
            &mut self.vertical_velocity,
            ex,
            ey,
            ez,
            &mut self.turn_rate,
            hx,
            hy,
        ] {
            v.drain(..k.min(v.len()));
        }
    }

    /// Grid length.
    pub fn len(&self) -> usize {
        self.accel_magnitude.len()
    }

    /// Whether the grid is empty.
    pub fn is_empty(&self) -> bool {
        self.accel_magnitude.is_empty()
    }
}

/// A window's IMU signals before smoothing, kept so that the window's suffixes take theirs
/// from it ([`ImuFeatures::from_parts`]): the swing angles (the angle each orientation turned
/// from the one `lag` samples before; `NaN` where either is missing or out of the window), and
/// the vertical angular rate ([`vertical_rate_unsmoothed_radps`]). A suffix's swing angle at a
/// sample whose earlier sample is in the suffix too is the same number, and so is every
/// sample's vertical rate, which depends on that sample alone.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RawSignals {
    lag: usize,
    swing: Vec<f64>,
    vertical_rate_radps: Vec<f64>,
}

impl RawSignals {
    /// The swing angles of `imu` at the lag [`ImuFeatures::from_parts`] uses for it, and its
    /// vertical rate.
    pub fn new(imu: &ImuWindow, kin: &KinematicConfig) -> Self {
        let lag = lag_samples(&imu.t_s, kin);
        Self {
            lag,
            swing: imu_swing(imu, lag),
            vertical_rate_radps: vertical_rate_unsmoothed_radps(imu),
        }
    }

    /// The swing angles of the `n` samples from `from` on at `lag`, as a window starting there
    /// has them (its first `lag` samples have no sample that far back); `None` at another lag
    /// or past the end.
    fn swing_suffix(&self, from: usize, lag: usize, n: usize) -> Option<Vec<f64>> {
        if lag != self.lag {
            return None;
        }
        let mut out = self.swing.get(from..from.checked_add(n)?)?.to_vec();
        out.iter_mut().take(lag).for_each(|v| *v = f64::NAN);
        Some(out)
    }

    /// The vertical rates before smoothing of the `n` samples from `from` on, as
    /// [`vertical_rate_unsmoothed_radps`] gives them for a window starting there; `None` past
    /// the end.
    pub fn vertical_rate_suffix(&self, from: usize, n: usize) -> Option<&[f64]> {
        self.vertical_rate_radps.get(from..from.checked_add(n)?)
    }

    /// The vertical rates before smoothing of `imu`: from `shared`, the [`RawSignals`] of a
    /// longer window that `imu` ends and the index of its first sample there, where that holds
    /// them ([`RawSignals::vertical_rate_suffix`]), else [`vertical_rate_unsmoothed_radps`] of
    /// `imu` itself (the same values).
    pub fn vertical_rate_of(shared: Option<(&RawSignals, usize)>, imu: &ImuWindow) -> Vec<f64> {
        shared
            .and_then(|(raw, from)| raw.vertical_rate_suffix(from, imu.t_s.len()))
            .map_or_else(|| vertical_rate_unsmoothed_radps(imu), <[f64]>::to_vec)
    }
}

/// Elevation of the sensor's x, y and z axes in the world for one orientation, rad: the world
/// `z` of each axis is the bottom row of the rotation matrix, and the axes are unit vectors, so
/// their elevation is its arcsine (`NaN` for a non-finite orientation).
pub fn axis_elevations_rad(q: &UnitQuaternion<f64>) -> [f64; 3] {
    if q.coords.iter().all(|c| c.is_finite()) {
        let m = q.to_rotation_matrix();
        let m = m.matrix();
        [m[(2, 0)], m[(2, 1)], m[(2, 2)]].map(|z| z.clamp(-1.0, 1.0).asin())
    } else {
        [f64::NAN; 3]
    }
}

/// The skeleton side of every model for the joint carrying a sensor at one site, on the
/// window's grid (`NaN` where missing).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SegmentFeatures {
    /// Joint acceleration magnitude ([`crate::joint_accel_magnitude`]).
    pub accel_magnitude: Vec<f64>,
    /// Joint velocity magnitude through the IMU's leak ([`crate::joint_velocity_magnitude`]).
    pub velocity_magnitude: Vec<f64>,
    /// Orientation change of the carrying segment ([`crate::segment_orientation_magnitude`]).
    pub orientation_magnitude: Vec<f64>,
    /// Angle the carrying bone turned over the swing lag, smoothed.
    pub swing: Vec<f64>,
    /// The joint's vertical acceleration, smoothed.
    pub vertical_accel: Vec<f64>,
    /// The joint's vertical velocity through the IMU's leak, smoothed.
    pub vertical_velocity: Vec<f64>,
    /// Elevation of the carrying bone, smoothed.
    pub elevation: Vec<f64>,
    /// The body's turn rate ([`crate::body_turn_rate_signal`]; the same for every site).
    pub turn_rate: Vec<f64>,
    /// The joint's world-horizontal acceleration `(x, y)`, smoothed.
    pub horizontal_accel: [Vec<f64>; 2],
}

/// A joint's positions on a window's grid ([`joint_positions`]), read once for its derivatives
/// and its segment, and its velocity and acceleration low-passed (`None` where they could not
/// be built).
struct SiteMotion {
    positions: Vec<Vector3<f64>>,
    vel: Option<Vec<Vector3<f64>>>,
    acc: Option<Vec<Vector3<f64>>>,
}

impl SiteMotion {
    fn new(skel: &SkeletonWindow, site: Joint, geo: &GeometricConfig) -> Self {
        let positions = joint_positions(skel, site);
        let (vel, acc) = filtered_derivatives_of(skel, &positions, geo).unzip();
        Self {
            positions,
            vel,
            acc,
        }
    }
}

impl SegmentFeatures {
    /// Every skeleton-side signal for a sensor worn at `site`.
    pub fn new(
        skel: &SkeletonWindow,
        site: Joint,
        geo: &GeometricConfig,
        kin: &KinematicConfig,
    ) -> Self {
        Self::with_turn_rate(skel, site, geo, kin, body_turn_rate_signal(skel, kin))
    }

    /// [`SegmentFeatures::new`] with the body's turn rate given: it is the same for every site,
    /// so a caller building several sites of one window computes it once
    /// ([`crate::body_turn_rate_signal`] of the same window and config).
    pub fn with_turn_rate(
        skel: &SkeletonWindow,
        site: Joint,
        geo: &GeometricConfig,
        kin: &KinematicConfig,
        turn_rate: Vec<f64>,
    ) -> Self {
        let motion = SiteMotion::new(skel, site, geo);
        Self::from_derivatives(skel, site, geo, kin, turn_rate, &motion)
    }

    /// [`SegmentFeatures::with_turn_rate`] from the joint's positions and their low-passed
    /// derivatives on the same grid.
    fn from_derivatives(
        skel: &SkeletonWindow,
        site: Joint,
        geo: &GeometricConfig,
        kin: &KinematicConfig,
        turn_rate: Vec<f64>,
        motion: &SiteMotion,
    ) -> Self {
        let (acc, vel) = (motion.acc.as_deref(), motion.vel.as_deref());
        let n = skel.t_s.len();
        let smooth = |mut v: Vec<f64>| {
            moving_average(&mut v, geo.moving_average_len);
            v
        };
        let missing = || vec![f64::NAN; n];
        // The carrying segment, read once for its inclination, orientation change and swing.
        let bones = segment_bones_with(skel, site, &motion.positions);
        let dirs = bone_directions(&bones);
        let elevation = bones.iter().map(elevation_rad).collect();
        // One world axis of the joint's acceleration, smoothed.
        let accel_axis = |axis: usize| {
            smooth(acc.map_or_else(missing, |a| {
                a.iter()
                    .map(|a| a.get(axis).copied().unwrap_or(f64::NAN))
                    .collect()
            }))
        };
        SegmentFeatures {
            accel_magnitude: acc.map_or_else(missing, |a| smoothed_norms(a, geo)),
            velocity_magnitude: vel
                .map_or_else(missing, |v| joint_velocity_magnitude_from(skel, v, geo)),
            orientation_magnitude: segment_orientation_magnitude_from(&dirs, n, geo),
            swing: smooth(segment_swing_from(&dirs, n, lag_samples(&skel.t_s, kin))),
            vertical_accel: accel_axis(2),
            vertical_velocity: smooth(
                vel.map_or_else(missing, |v| joint_vertical_velocity(skel, v, geo)),
            ),
            elevation: smooth(elevation),
            turn_rate,
            horizontal_accel: [accel_axis(0), accel_axis(1)],
        }
    }

    /// [`SegmentFeatures::with_turn_rate`] on a grid that starts `anchor` samples before the
    /// window (see [`ImuFeatures::from_parts_anchored`]): the run edges are dropped on the
    /// whole grid (`run_edges`: the samples and whether to keep the grid's start, as in
    /// [`SegmentFeatures::drop_run_edges`]), then only the window's part is kept, the
    /// window-anchored models starting at its first sample.
    pub fn with_turn_rate_anchored(
        skel: &SkeletonWindow,
        site: Joint,
        geo: &GeometricConfig,
        kin: &KinematicConfig,
        turn_rate: Vec<f64>,
        anchor: usize,
        run_edges: (usize, bool),
    ) -> Self {
        let motion = SiteMotion::new(skel, site, geo);
        let mut features = Self::from_derivatives(skel, site, geo, kin, turn_rate, &motion);
        let vel = motion.vel;
        features.drop_run_edges(run_edges.0, run_edges.1);
        if anchor == 0 {
            return features;
        }
        features.drop_front(anchor);
        let tail = skel.tail(anchor);
        let n = tail.t_s.len();
        // The velocity low-passed over the pad, the window's part.
        let vel = vel
            .as_deref()
            .and_then(|v| v.get(anchor..))
            .filter(|v| v.len() == n);
        // The anchored signals keep the NaNs the run edges put on the velocity-shaped ones.
        let keep_nan = |mut new: Vec<f64>, old: &[f64]| {
            for (x, o) in new.iter_mut().zip(old) {
                if !o.is_finite() {
                    *x = f64::NAN;
                }
            }
            new
        };
        let missing = || vec![f64::NAN; n];
        let velocity = vel.map_or_else(missing, |v| joint_velocity_magnitude_from(&tail, v, geo));
        let mut vertical = vel.map_or_else(missing, |v| joint_vertical_velocity(&tail, v, geo));
        moving_average(&mut vertical, geo.moving_average_len);
        features.velocity_magnitude = keep_nan(velocity, &features.velocity_magnitude);
        features.vertical_velocity = keep_nan(vertical, &features.vertical_velocity);
        features.orientation_magnitude = segment_orientation_magnitude(&tail, site, geo);
        features
    }

    /// Drops the first `k` grid samples of every signal.
    pub fn drop_front(&mut self, k: usize) {
        let [hx, hy] = &mut self.horizontal_accel;
        for v in [
            &mut self.accel_magnitude,
            &mut self.velocity_magnitude,
            &mut self.orientation_magnitude,
            &mut self.swing,
            &mut self.vertical_accel,
            &mut self.vertical_velocity,
            &mut self.elevation,
            &mut self.turn_rate,
            hx,
            hy,
        ] {
            v.drain(..k.min(v.len()));
        }
    }

    /// Drops (sets to `NaN`) the signals the low-pass shapes (acceleration, velocity and their
    /// vertical and horizontal parts) within `samples` of where a run of present samples starts
    /// or ends inside the grid: there the filter starts from the skeleton's first sample or
    /// stops at its last, while an IMU filtered over a longer span (see
    /// [`ImuFeatures::from_parts`]) has settled. A run starting at the grid's first sample
    /// keeps its start when `keep_grid_start` (the IMU's filter starts there too); every run
    /// keeps its end at the grid's last sample.
    pub fn drop_run_edges(&mut self, samples: usize, keep_grid_start: bool) {
        if samples == 0 {
            return;
        }
        let [hx, hy] = &mut self.horizontal_accel;
        for v in [
            &mut self.accel_magnitude,
            &mut self.velocity_magnitude,
            &mut self.vertical_accel,
            &mut self.vertical_velocity,
            hx,
            hy,
        ] {
            let n = v.len();
            // Each run of present samples `a..b` in turn (as `finite_runs` finds them, without
            // collecting them: the edges are blanked behind the scan).
            let mut b = 0;
            while let Some(a) = (b..n).find(|&i| v[i].is_finite()) {
                b = (a..n).find(|&i| !v[i].is_finite()).unwrap_or(n);
                let head = if a == 0 && keep_grid_start {
                    a
                } else {
                    a.saturating_add(samples).min(b)
                };
                let tail = if b == n {
                    b
                } else {
                    b.saturating_sub(samples).max(head)
                };
                v[a..head].fill(f64::NAN);
                v[tail..b].fill(f64::NAN);
            }
        }
    }

    /// Grid length.
    pub fn len(&self) -> usize {
        self.accel_magnitude.len()
    }

    /// Whether the grid is empty.
    pub fn is_empty(&self) -> bool {
        self.accel_magnitude.is_empty()
    }
}

/// The five signals a clock-offset search correlates at many lags, IMU side: linear-acceleration
/// magnitude, orientation-change magnitude, vertical acceleration, swing and turn rate (the
/// same values as [`crate::imu_accel_magnitude`], [`crate::imu_orientation_magnitude`],
/// [`crate::imu_vertical_accel`], [`crate::imu_swing_signal`] and
/// [`crate::imu_turn_rate_signal`], with the acceleration filtered once for two of them), at
/// every `step`-th sample of the window (0, `step`, 2·`step`, …; `step` 0 counts as 1).
///
/// The signals are built at the window's full rate and then thinned; without a moving average
/// (`geo.moving_average_len` ≤ 1) the orientation angles, which need no neighbours, are only
/// computed at the samples kept. Either way the values equal the full-rate signals' there.
pub fn imu_lag_models(
    imu: &ImuWindow,
    geo: &GeometricConfig,
    kin: &KinematicConfig,
    step: usize,
) -> [Vec<f64>; 5] {
    let step = step.max(1);
    let orientation = if geo.moving_average_len <= 1 {
        imu_orientation_magnitude_every(imu, step)
    } else {
        every_nth(imu_orientation_magnitude(imu, geo), step)
    };
    let [acc, vertical, swing, turn] = imu_unanchored_lag_models(imu, geo, kin, step);
    [acc, orientation, vertical, swing, turn]
}

/// [`imu_lag_models`] but the orientation change: the four models that do not measure from the
/// window's first sample (acceleration magnitude, vertical acceleration, swing, turn rate), the
/// same values, for a caller that keeps them from one buffer to the next and finishes the
/// orientation change per buffer itself.
pub fn imu_unanchored_lag_models(
    imu: &ImuWindow,
    geo: &GeometricConfig,
    kin: &KinematicConfig,
    step: usize,
) -> [Vec<f64>; 4] {
    let step = step.max(1);
    let lin = imu_linear_accel_world(imu, geo);
    let mut vertical: Vec<f64> = lin.iter().map(|a| a.z).collect();
    moving_average(&mut vertical, geo.moving_average_len);
    let lag = lag_samples(&imu.t_s, kin);
    let swing = if geo.moving_average_len <= 1 {
        imu_swing_every(imu, lag, step)
    } else {
        let mut swing = imu_swing(imu, lag);
        moving_average(&mut swing, geo.moving_average_len);
        every_nth(swing, step)
    };
    [
        every_nth(smoothed_norms(&lin, geo), step),
        every_nth(vertical, step),
        swing,
        every_nth(imu_turn_rate_signal(imu, kin), step),
    ]
}

/// Every `step`-th value of `v`, from the first.
fn every_nth(v: Vec<f64>, step: usize) -> Vec<f64> {
    if step <= 1 {
        return v;
    }
    v.into_iter().step_by(step).collect()
}

/// [`imu_lag_models`]' skeleton side for a sensor worn at `site`: the same values as
/// [`crate::joint_accel_magnitude`], [`crate::segment_orientation_magnitude`],
/// [`crate::joint_vertical_accel`], [`crate::segment_swing_signal`] and
/// [`crate::body_turn_rate_signal`], with the joint differentiated once for two of them, at
/// every `step`-th sample of the window (thinned after they are built at the full rate).
pub fn segment_lag_models(
    skel: &SkeletonWindow,
    site: Joint,
    geo: &GeometricConfig,
    kin: &KinematicConfig,
    step: usize,
) -> [Vec<f64>; 5] {
    let [acc, ori, vertical, swing] = segment_site_lag_models(skel, site, geo, kin, step);
    let turn = every_nth(body_turn_rate_signal(skel, kin), step.max(1));
    [acc, ori, vertical, swing, turn]
}

/// The first four of [`segment_lag_models`], the ones that depend on the site: a caller
/// building several sites of one window computes the body's turn rate, the fifth, once.
pub fn segment_site_lag_models(
    skel: &SkeletonWindow,
    site: Joint,
    geo: &GeometricConfig,
    kin: &KinematicConfig,
    step: usize,
) -> [Vec<f64>; 4] {
    let step = step.max(1);
    let n = skel.t_s.len();
    let acc = filtered_joint_derivative(skel, site, Derivative::Acceleration, geo);
    let mut vertical: Vec<f64> = acc
        .as_deref()
        .map_or_else(|| vec![f64::NAN; n], |a| a.iter().map(|a| a.z).collect());
    moving_average(&mut vertical, geo.moving_average_len);
    let dirs = bone_directions(&segment_bones(skel, site));
    let mut swing = segment_swing_from(&dirs, n, lag_samples(&skel.t_s, kin));
    moving_average(&mut swing, geo.moving_average_len);
    [
        every_nth(
            acc.as_deref()
                .map_or_else(|| vec![f64::NAN; n], |a| smoothed_norms(a, geo)),
            step,
        ),
        every_nth(segment_orientation_magnitude_from(&dirs, n, geo), step),
        every_nth(vertical, step),
        every_nth(swing, step),
    ]
}

/// De Marchi's three correlations and nomen's five for one IMU and one candidate segment whose
/// features were built on the same grid; all `None` if the grids' lengths differ.
pub fn compare_features(
    imu: &ImuFeatures,
    seg: &SegmentFeatures,
    geo: &GeometricConfig,
) -> (ModelScores, KinematicScores) {
    compare_by(imu, None, seg, None, geo)
}

/// [`compare_features`] with each side's signals prepared once ([`ImuFeatures::units`],
/// [`SegmentFeatures::units`]): the same scores to rounding, each correlation a dot product
/// corrected by the samples only one side has ([`UnitSignal::correlation`]), and
/// [`crate::pearson`]'s where a signal has no unit (no finite value).
pub fn compare_prepared(
    imu: &ImuFeatures,
    imu_units: &ImuUnits,
    seg: &SegmentFeatures,
    seg_units: &SegmentUnits,
    geo: &GeometricConfig,
) -> (ModelScores, KinematicScores) {
    compare_by(imu, Some(imu_units), seg, Some(seg_units), geo)
}

/// Each Pearson-correlated signal of an [`ImuFeatures`] prepared for many correlations
/// ([`UnitSignal`]; `None` where it is incomplete or constant). The turn rate is compared by
/// concordance, from the signal itself.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ImuUnits {
    accel_magnitude: Option<UnitSignal>,
    velocity_magnitude: Option<UnitSignal>,
    orientation_magnitude: Option<UnitSignal>,
    swing: Option<UnitSignal>,
    vertical_accel: Option<UnitSignal>,
    vertical_velocity: Option<UnitSignal>,
    axis_elevation: [Option<UnitSignal>; 3],
    /// Whether both horizontal accelerations have every sample ([`horizontal_cross_prepared`]).
    is_horizontal_complete: bool,
}

/// Each Pearson-correlated signal of a [`SegmentFeatures`] prepared for many correlations
/// ([`UnitSignal`]; `None` where it is incomplete or constant). The turn rate is compared by
/// concordance, from the signal itself.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SegmentUnits {
    accel_magnitude: Option<UnitSignal>,
    velocity_magnitude: Option<UnitSignal>,
    orientation_magnitude: Option<UnitSignal>,
    swing: Option<UnitSignal>,
    vertical_accel: Option<UnitSignal>,
    vertical_velocity: Option<UnitSignal>,
    elevation: Option<UnitSignal>,
    /// The samples where both horizontal accelerations are present, increasing; `None` where
    /// the two differ in length ([`horizontal_cross_prepared`]).
    horizontal_present: Option<Vec<usize>>,
}

impl ImuFeatures {
    /// The correlated signals prepared once, for [`compare_prepared`].
    pub fn units(&self) -> ImuUnits {
        let [ex, ey, ez] = &self.axis_elevation;
        ImuUnits {
            accel_magnitude: UnitSignal::new(&self.accel_magnitude),
            velocity_magnitude: UnitSignal::new(&self.velocity_magnitude),
            orientation_magnitude: UnitSignal::new(&self.orientation_magnitude),
            swing: UnitSignal::new(&self.swing),
            vertical_accel: UnitSignal::new(&self.vertical_accel),
            vertical_velocity: UnitSignal::new(&self.vertical_velocity),
            axis_elevation: [ex, ey, ez].map(|e| UnitSignal::new(e)),
            is_horizontal_complete: self
                .horizontal_accel
                .iter()
                .all(|h| h.iter().all(|v| v.is_finite())),
        }
    }
}

impl SegmentFeatures {
    /// The correlated signals prepared once, for [`compare_prepared`].
    pub fn units(&self) -> SegmentUnits {
        SegmentUnits {
            accel_magnitude: UnitSignal::new(&self.accel_magnitude),
            velocity_magnitude: UnitSignal::new(&self.velocity_magnitude),
            orientation_magnitude: UnitSignal::new(&self.orientation_magnitude),
            swing: UnitSignal::new(&self.swing),
            vertical_accel: UnitSignal::new(&self.vertical_accel),
            vertical_velocity: UnitSignal::new(&self.vertical_velocity),
            elevation: UnitSignal::new(&self.elevation),
            horizontal_present: {
                let [sx, sy] = &self.horizontal_accel;
                (sx.len() == sy.len()).then(|| {
                    (0..sx.len())
                        .filter(|&k| sx[k].is_finite() && sy[k].is_finite())
                        .collect()
                })
            },
        }
    }
}

/// The body of [`compare_features`] and [`compare_prepared`]: without units, every Pearson
/// correlation is [`crate::pearson`]'s; the turn rates go by [`crate::concordance`].
fn compare_by(
    imu: &ImuFeatures,
    imu_units: Option<&ImuUnits>,
    seg: &SegmentFeatures,
    seg_units: Option<&SegmentUnits>,
    geo: &GeometricConfig,
) -> (ModelScores, KinematicScores) {
    if imu.len() != seg.len() || imu.is_empty() {
        return (ModelScores::default(), KinematicScores::default());
    }
    let corr = |a: &[f64], ua: Option<&UnitSignal>, b: &[f64], ub: Option<&UnitSignal>| {
        pearson_prepared(a, ua, b, ub, geo.min_samples)
    };
    // One model's correlation: the IMU's and the segment's signals, each with its unit.
    macro_rules! model {
        ($imu:ident, $seg:ident) => {
            corr(
                &imu.$imu,
                imu_units.and_then(|u| u.$imu.as_ref()),
                &seg.$seg,
                seg_units.and_then(|u| u.$seg.as_ref()),
            )
        };
    }
    let geometric = ModelScores {
        acc: model!(accel_magnitude, accel_magnitude),
        vel: model!(velocity_magnitude, velocity_magnitude),
        ori: model!(orientation_magnitude, orientation_magnitude),
        dl: None,
    };
    // The axis along the segment is unknown (mounting) and its sign flips the correlation's:
    // the largest |r| over the three axes (it lifts wrong pairs a little, the same for all).
    let elevation_unit = seg_units.and_then(|u| u.elevation.as_ref());
    let inclination = imu
        .axis_elevation
        .iter()
        .enumerate()
        .filter_map(|(k, axis)| {
            let unit = imu_units
                .and_then(|u| u.axis_elevation.get(k))
                .and_then(Option::as_ref);
            corr(axis, unit, &seg.elevation, elevation_unit).map(f64::abs)
        })
        .reduce(f64::max);
    let kinematic = KinematicScores {
        swing: model!(swing, swing),
        vertical_accel: model!(vertical_accel, vertical_accel),
        vertical_vel: model!(vertical_velocity, vertical_velocity),
        inclination,
        // Same unit on both sides: concordance, not Pearson (see `KinematicScores::turn`).
        turn: crate::concordance(&imu.turn_rate, &seg.turn_rate, geo.min_samples),
    };
    (geometric, kinematic)
}

/// Cross sums of an IMU's and a joint's horizontal accelerations over one window, each side's
/// mean removed, read as complex numbers `a = x + iy`: `Σ a·conj(s)` and both powers. The
/// IMU's heading frame differs from the room's by an unknown rotation about the vertical; for
/// the IMU's own joint the cross sum's phase is that rotation, window after window, while for
/// anyone else it wanders as the two walk different ways.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HorizontalCross {
    /// Real part of `Σ a·conj(s)`, (m/s²)².
    pub re: f64,
    /// Imaginary part of `Σ a·conj(s)`, (m/s²)².
    pub im: f64,
    /// `Σ |a|²`, (m/s²)².
    pub imu_power: f64,
    /// `Σ |s|²`, (m/s²)².
    pub joint_power: f64,
}

impl HorizontalCross {
    /// `√(Σ|a|² Σ|s|²)`: the largest `|Σ a·conj(s)|` can be.
    pub fn norm(&self) -> f64 {
        (self.imu_power * self.joint_power).sqrt()
    }

    /// The correlation of the two in one frame, given the phase the cross sum has when the
    /// IMU's frame is turned by the expected angle: `Re(Σ a·conj(s) · conj(u)) / norm` for the
    /// unit complex number `u = re + i·im`, in [−1, 1]; `None` for a window without power.
    pub fn aligned_correlation(&self, re: f64, im: f64) -> Option<f64> {
        let norm = self.norm();
        (norm > 0.0 && norm.is_finite()).then(|| (self.re * re + self.im * im) / norm)
    }
}

/// [`HorizontalCross`] of an IMU's and a segment's features on the same grid, over the samples
/// where both are finite; `None` if fewer than `min_samples` are or the grids differ in length.
pub fn horizontal_cross(
    imu: &ImuFeatures,
    seg: &SegmentFeatures,
    min_samples: usize,
) -> Option<HorizontalCross> {
    if !horizontal_lengths_match(imu, seg) {
        return None;
    }
    let [ax, ay] = &imu.horizontal_accel;
    let [sx, sy] = &seg.horizontal_accel;
    let both = (0..ax.len()).filter(|&k| {
        ax[k].is_finite() && ay[k].is_finite() && sx[k].is_finite() && sy[k].is_finite()
    });
    cross_over(imu, seg, both, min_samples)
}

/// Whether the IMU's and the segment's horizontal accelerations, both axes, have one length.
fn horizontal_lengths_match(imu: &ImuFeatures, seg: &SegmentFeatures) -> bool {
    let [ax, ay] = &imu.horizontal_accel;
    let [sx, sy] = &seg.horizontal_accel;
    ax.len() == sx.len() && ay.len() == ax.len() && sy.len() == sx.len()
}

/// [`horizontal_cross`] with each side's units ([`ImuFeatures::units`],
/// [`SegmentFeatures::units`]): where the IMU has every sample, the samples both have are the
/// segment's, found once per segment. The same sums in the same order, so the same result.
pub fn horizontal_cross_prepared(
    imu: &ImuFeatures,
    imu_units: &ImuUnits,
    seg: &SegmentFeatures,
    seg_units: &SegmentUnits,
    min_samples: usize,
) -> Option<HorizontalCross> {
    match &seg_units.horizontal_present {
        Some(present) if imu_units.is_horizontal_complete && horizontal_lengths_match(imu, seg) => {
            cross_over(imu, seg, present.iter().copied(), min_samples)
        }
        _ => horizontal_cross(imu, seg, min_samples),
    }
}

/// The body of [`horizontal_cross`] over the samples `both` (increasing indices, in range,
/// each finite on both sides).
fn cross_over(
    imu: &ImuFeatures,
    seg: &SegmentFeatures,
    both: impl Iterator<Item = usize> + Clone,
    min_samples: usize,
) -> Option<HorizontalCross> {
    let [ax, ay] = &imu.horizontal_accel;
    let [sx, sy] = &seg.horizontal_accel;
    let at = |k: usize| (ax[k], ay[k], sx[k], sy[k]);
    let mut n = 0usize;
    let mut mean = [0.0f64; 4];
    for (ax, ay, sx, sy) in both.clone().map(at) {
        n += 1;
        for (m, v) in mean.iter_mut().zip([ax, ay, sx, sy]) {
            *m += v;
        }
    }
    if n < min_samples.max(2) {
        return None;
    }
    for m in &mut mean {
        *m /= n as f64;
    }
    let mut out = HorizontalCross::default();
    for (ax, ay, sx, sy) in both.map(at) {
        let (ax, ay, sx, sy) = (ax - mean[0], ay - mean[1], sx - mean[2], sy - mean[3]);
        out.re += ax * sx + ay * sy;
        out.im += ay * sx - ax * sy;
        out.imu_power += ax * ax + ay * ay;
        out.joint_power += sx * sx + sy * sy;
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{
        imu_accel_magnitude, imu_velocity_magnitude, joint_accel_magnitude,
        joint_velocity_magnitude, pearson,
    };
    use nalgebra::{Point3, UnitQuaternion, Vector3};
    use nomen_core::skeleton::Joints;

    /// A forearm swinging and turning, and an IMU on it, with a little disagreement so that no
    /// correlation is exactly 1.
    fn windows() -> (ImuWindow, SkeletonWindow) {
        let t_s: Vec<f64> = (0..120).map(|k| k as f64 / 30.0).collect();
        let swing = |t: f64| 0.5 * (2.0 * std::f64::consts::PI * 0.9 * t).sin();
        let heading = |t: f64| 0.4 * t;
        let q: Vec<UnitQuaternion<f64>> = t_s
            .iter()
            .map(|&t| {
                UnitQuaternion::from_axis_angle(&Vector3::z_axis(), heading(t))
                    * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), swing(t + 0.05))
            })
            .collect();
        let joints = t_s
            .iter()
            .map(|&t| {
                let (a, h) = (swing(t), heading(t));
                let elbow = Point3::new(0.1 * t, 0.0, 1.2);
                let along = Vector3::new(h.cos(), h.sin(), 0.0);
                let mut j = Joints::new();
                j.insert(Joint::LeftElbow, elbow);
                j.insert(
                    Joint::LeftWrist,
                    elbow + along * (0.3 * a.sin()) - Vector3::z() * (0.3 * a.cos()),
                );
                let across = Vector3::new(-h.sin(), h.cos(), 0.0) * 0.2;
                j.insert(
                    Joint::LeftShoulder,
                    Point3::new(0.1 * t, 0.0, 1.45) + across,
                );
                j.insert(
                    Joint::RightShoulder,
                    Point3::new(0.1 * t, 0.0, 1.45) - across,
                );
                j
            })
            .collect();
        let imu = ImuWindow {
            device: None,
            t_s: t_s.clone(),
            accel_mps2: q
                .iter()
                .enumerate()
                .map(|(k, q)| q.inverse() * Vector3::new(0.3 * (k as f64 * 0.7).sin(), 0.0, 9.81))
                .collect(),
            gyro_radps: q
                .iter()
                .map(|q| q.inverse() * Vector3::new(0.0, 0.2, 0.4))
                .collect(),
            world_from_sensor: q,
        };
        let skel = SkeletonWindow {
            camera: None,
            track: None,
            t_s,
            joints_world_m: joints,
        };
        (imu, skel)
    }

    /// Each orientation's [`axis_elevations_rad`], in order.
    fn axis_elevations_of(imu: &ImuWindow) -> Vec<[f64; 3]> {
        imu.world_from_sensor
            .iter()
            .map(axis_elevations_rad)
            .collect()
    }

    #[test]
    fn a_suffix_sharing_its_grids_raw_signals_gets_its_own_features_bit_for_bit() {
        let (mut imu, _) = windows();
        // A missing orientation, so that the shared angles carry gaps too.
        if let Some(q) = imu.world_from_sensor.get_mut(50) {
            *q = UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(f64::NAN, 0.0, 0.0, 0.0));
        }
        let geo = GeometricConfig::default();
        let kin = KinematicConfig::default();
        let elevations = axis_elevations_of(&imu);
        let lin = crate::imu_linear_accel_world(&imu, &geo);
        let raw = RawSignals::new(&imu, &kin);
        let bits = |f: &ImuFeatures| -> Vec<u64> { f.swing.iter().map(|v| v.to_bits()).collect() };
        let belmonte = crate::BelmonteConfig::default();
        let pitches_of = |w: &ImuWindow| -> Vec<[f64; 3]> {
            w.world_from_sensor
                .iter()
                .map(crate::axis_pitches_rad)
                .collect()
        };
        for from in [0, 1, 3, 45, 52, 100] {
            let tail = imu.tail(from);
            let (lin, elevations) = (&lin[from..], &elevations[from..]);
            let own = ImuFeatures::from_parts(&tail, lin, elevations, None, &geo, &kin);
            let shared =
                ImuFeatures::from_parts(&tail, lin, elevations, Some((&raw, from)), &geo, &kin);
            assert_eq!(bits(&own), bits(&shared), "from {from}");
            assert_eq!(
                format!("{own:?}"),
                format!("{shared:?}"),
                "every other signal too"
            );
            assert!(own.swing.iter().any(|v| v.is_finite()));
            let turn_bits =
                |f: &ImuFeatures| -> Vec<u64> { f.turn_rate.iter().map(|v| v.to_bits()).collect() };
            assert_eq!(turn_bits(&own), turn_bits(&shared), "from {from}");
            // A band's yaw rate takes the same shared rates.
            let rates = raw.vertical_rate_suffix(from, tail.t_s.len()).unwrap();
            let band = crate::BandSignals::from_parts(
                &tail,
                &pitches_of(&tail),
                rates.to_vec(),
                &belmonte,
            );
            let alone = crate::BandSignals::new(&tail, &belmonte);
            assert_eq!(format!("{band:?}"), format!("{alone:?}"), "from {from}");
            assert!(band.yaw_rate_radps.iter().any(|v| v.is_finite()));
        }
        // A suffix at another lag (another rate) computes its own.
        let other = KinematicConfig {
            swing_lag_s: kin.swing_lag_s * 2.0,
            ..kin
        };
        let own = ImuFeatures::from_parts(&imu, &lin, &elevations, None, &geo, &other);
        let shared =
            ImuFeatures::from_parts(&imu, &lin, &elevations, Some((&raw, 0)), &geo, &other);
        assert_eq!(bits(&own), bits(&shared));
        assert_eq!(raw.swing_suffix(110, raw.lag, 20), None, "past the end");
        assert_eq!(raw.vertical_rate_suffix(110, 20), None, "past the end");
        // Rates of another length than the window count as missing, without a panic.
        let short = vec![0.1; imu.t_s.len() - 1];
        let band =
            crate::BandSignals::from_parts(&imu, &pitches_of(&imu), short.clone(), &belmonte);
        assert_eq!(band.yaw_rate_radps.len(), imu.t_s.len());
        assert!(band.yaw_rate_radps.iter().all(|v| v.is_nan()));
        let turn = imu_turn_rate_from(&imu, short, &kin);
        assert_eq!(turn.len(), imu.t_s.len());
        assert!(turn.iter().all(|v| v.is_nan()));
    }

    #[test]
    fn a_segments_signals_read_from_one_set_of_bones_equal_each_built_alone() {
        let (_, mut skel) = windows();
        // A missing wrist, and an elbow on its wrist (a bone of no length).
        if let Some(j) = skel.joints_world_m.get_mut(30) {
            j.remove(Joint::LeftWrist);
        }
        if let Some(j) = skel.joints_world_m.get_mut(50)
            && let Some(&w) = j.get(Joint::LeftWrist)
        {
            j.insert(Joint::LeftElbow, w);
        }
        let geo = GeometricConfig::default();
        let kin = KinematicConfig::default();
        let bits = |v: &[f64]| -> Vec<u64> { v.iter().map(|x| x.to_bits()).collect() };
        let site = Joint::LeftWrist;
        let features = SegmentFeatures::new(&skel, site, &geo, &kin);
        // Each signal as it was built before the bones were shared: positions read, the bone
        // formed and (for the angles) normalised afresh per signal.
        let (from, to) = crate::geometric::carrying_segment(site);
        let bone = |j: &nomen_core::skeleton::Joints<nalgebra::Point3<f64>>| match (
            j.get(to),
            j.get(from),
        ) {
            (Some(b), Some(a)) => b - a,
            _ => Vector3::repeat(f64::NAN),
        };
        let mut elevation: Vec<f64> = skel
            .joints_world_m
            .iter()
            .map(|j| elevation_rad(&bone(j)))
            .collect();
        moving_average(&mut elevation, geo.moving_average_len);
        let dirs: Vec<Option<Vector3<f64>>> = skel
            .joints_world_m
            .iter()
            .map(|j| bone(j).try_normalize(1e-9))
            .collect();
        let lag = lag_samples(&skel.t_s, &kin);
        let mut swing: Vec<f64> = (0..dirs.len())
            .map(
                |k| match (k.checked_sub(lag).and_then(|i| dirs[i]), dirs[k]) {
                    (Some(a), Some(b)) => crate::angle::angle_between_rad(&a, &b),
                    _ => f64::NAN,
                },
            )
            .collect();
        moving_average(&mut swing, geo.moving_average_len);
        assert_eq!(bits(&features.elevation), bits(&elevation));
        assert_eq!(bits(&features.swing), bits(&swing));
        assert_eq!(
            bits(&features.orientation_magnitude),
            bits(&segment_orientation_magnitude(&skel, site, &geo))
        );
        assert!(
            features.swing.iter().any(|v| v.is_nan())
                && features.swing.iter().any(|v| v.is_finite())
        );
    }

    #[test]
    fn both_joint_derivatives_at_once_equal_each_alone_bit_for_bit() {
        let (_, mut skel) = windows();
        // Gaps: one frame, a run too short to differentiate, a run too short to filter.
        for k in [20, 40, 42, 43, 60, 70] {
            if let Some(j) = skel.joints_world_m.get_mut(k) {
                j.remove(Joint::LeftWrist);
            }
        }
        let bits = |v: &Option<Vec<Vector3<f64>>>| -> Option<Vec<u64>> {
            v.as_ref().map(|v| {
                v.iter()
                    .flat_map(|p| p.iter().map(|c| c.to_bits()))
                    .collect()
            })
        };
        for zero_phase in [true, false] {
            let geo = GeometricConfig {
                zero_phase,
                ..GeometricConfig::default()
            };
            for site in [Joint::LeftWrist, Joint::LeftElbow, Joint::RightWrist] {
                let positions = joint_positions(&skel, site);
                let (vel, acc) = filtered_derivatives_of(&skel, &positions, &geo).unzip();
                let vel1 = filtered_joint_derivative(&skel, site, Derivative::Velocity, &geo);
                let acc1 = filtered_joint_derivative(&skel, site, Derivative::Acceleration, &geo);
                assert_eq!(bits(&vel), bits(&vel1), "{site:?} zero phase {zero_phase}");
                assert_eq!(bits(&acc), bits(&acc1), "{site:?} zero phase {zero_phase}");
                if site == Joint::LeftWrist {
                    let v = vel.unwrap_or_default();
                    // Present, filtered samples and the missing ones both occur.
                    assert!(v.iter().any(|p| p.x.is_finite()) && v.iter().any(|p| p.x.is_nan()));
                }
            }
        }
    }

    #[test]
    fn features_from_a_windows_sliced_acceleration_differ_from_its_own_only_near_its_start() {
        let (imu, _) = windows();
        let geo = GeometricConfig::default();
        let kin = KinematicConfig::default();
        let elevations = axis_elevations_of(&imu);
        // A window's own parts give `new`'s features.
        let own = ImuFeatures::from_parts(
            &imu,
            &imu_linear_accel_world(&imu, &geo),
            &elevations,
            None,
            &geo,
            &kin,
        );
        assert_eq!(
            own.accel_magnitude,
            ImuFeatures::new(&imu, &geo, &kin).accel_magnitude
        );
        // The last 60 samples with the acceleration sliced from the whole window: the
        // horizontal acceleration (no reference) is the whole window's there, exactly, and
        // differs from the tail filtered on its own near the tail's start only.
        let tail = imu.tail(60);
        let sliced_lin = &imu_linear_accel_world(&imu, &geo)[60..];
        let sliced =
            ImuFeatures::from_parts(&tail, sliced_lin, &elevations[60..], None, &geo, &kin);
        let alone = ImuFeatures::new(&tail, &geo, &kin);
        let ma = geo.moving_average_len;
        assert_eq!(
            sliced.horizontal_accel[0][ma..],
            own.horizontal_accel[0][60 + ma..]
        );
        let gap = |k: usize| (sliced.horizontal_accel[0][k] - alone.horizontal_accel[0][k]).abs();
        assert!(
            gap(ma) > 1e-4,
            "the tail's own filter starts there: {}",
            gap(ma)
        );
        assert!(gap(45) < 0.1 * gap(ma), "{} vs {}", gap(45), gap(ma));
        // An acceleration of another length counts as missing.
        let short = ImuFeatures::from_parts(&imu, &sliced_lin[..10], &elevations, None, &geo, &kin);
        assert!(short.accel_magnitude.iter().all(|v| v.is_nan()));
        assert_eq!(short.orientation_magnitude, own.orientation_magnitude);
    }

    #[test]
    fn anchored_features_keep_the_pads_filtering_and_anchor_the_window_models_at_its_start() {
        let (imu, skel) = windows();
        let geo = GeometricConfig::default();
        let kin = KinematicConfig::default();
        let elevations = axis_elevations_of(&imu);
        let lin = imu_linear_accel_world(&imu, &geo);
        let anchor = 40;
        let whole = ImuFeatures::from_parts(&imu, &lin, &elevations, None, &geo, &kin);
        // Bit for bit (`NaN`s included).
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(
            format!(
                "{:?}",
                ImuFeatures::from_parts_anchored(&imu, &lin, &elevations, None, &geo, &kin, 0)
            ),
            format!("{whole:?}")
        );
        let padded =
            ImuFeatures::from_parts_anchored(&imu, &lin, &elevations, None, &geo, &kin, anchor);
        let tail = imu.tail(anchor);
        let own = ImuFeatures::from_parts(
            &tail,
            &lin[anchor..],
            &elevations[anchor..],
            None,
            &geo,
            &kin,
        );
        assert_eq!(padded.len(), imu.t_s.len() - anchor);
        // Filtered and smoothed over the pad: the whole grid's values, sliced.
        assert_eq!(
            bits(&padded.accel_magnitude),
            bits(&whole.accel_magnitude[anchor..])
        );
        assert_eq!(bits(&padded.swing), bits(&whole.swing[anchor..]));
        assert_eq!(bits(&padded.turn_rate), bits(&whole.turn_rate[anchor..]));
        // The tail's own moving average starts again, so its first values differ.
        assert_ne!(own.accel_magnitude[0], padded.accel_magnitude[0]);
        // Anchored at the window's first sample, from the pad's filtered acceleration.
        assert_eq!(
            bits(&padded.orientation_magnitude),
            bits(&own.orientation_magnitude)
        );
        assert_eq!(
            bits(&padded.velocity_magnitude),
            bits(&own.velocity_magnitude)
        );
        assert_eq!(
            bits(&padded.vertical_velocity),
            bits(&own.vertical_velocity)
        );
        assert!(padded.orientation_magnitude[0].abs() < 1e-12);

        let turn = body_turn_rate_signal(&skel, &kin);
        let whole =
            SegmentFeatures::with_turn_rate(&skel, Joint::LeftWrist, &geo, &kin, turn.clone());
        let padded = SegmentFeatures::with_turn_rate_anchored(
            &skel,
            Joint::LeftWrist,
            &geo,
            &kin,
            turn,
            anchor,
            (0, true),
        );
        let own = SegmentFeatures::new(&skel.tail(anchor), Joint::LeftWrist, &geo, &kin);
        assert_eq!(
            bits(&padded.accel_magnitude),
            bits(&whole.accel_magnitude[anchor..])
        );
        assert_eq!(bits(&padded.elevation), bits(&whole.elevation[anchor..]));
        assert_eq!(
            bits(&padded.orientation_magnitude),
            bits(&own.orientation_magnitude)
        );
        assert!(padded.orientation_magnitude[0].abs() < 1e-12);
        // The velocities leak from 0 at the window's start, but their low-pass ran over the pad.
        assert!(padded.velocity_magnitude.iter().all(|v| v.is_finite()));
        assert_ne!(
            padded.velocity_magnitude,
            whole.velocity_magnitude[anchor..]
        );
        assert_ne!(padded.velocity_magnitude, own.velocity_magnitude);
    }

    #[test]
    fn a_skeletons_run_edges_inside_the_grid_are_dropped_from_the_low_passed_signals() {
        // Ten samples: a run 0..4, a gap at 4, a run 5..10 (reaching the grid's end).
        let signal: Vec<f64> = (0..10)
            .map(|k| if k == 4 { f64::NAN } else { k as f64 })
            .collect();
        let fresh = || SegmentFeatures {
            accel_magnitude: signal.clone(),
            velocity_magnitude: signal.clone(),
            orientation_magnitude: signal.clone(),
            swing: signal.clone(),
            vertical_accel: signal.clone(),
            vertical_velocity: signal.clone(),
            elevation: signal.clone(),
            turn_rate: signal.clone(),
            horizontal_accel: [signal.clone(), signal.clone()],
        };
        let present =
            |v: &[f64]| -> Vec<usize> { (0..v.len()).filter(|&k| v[k].is_finite()).collect() };
        // The grid's start kept: the first run loses its last two samples (before the gap),
        // the second its first two; the grid's end is kept.
        let mut seg = fresh();
        seg.drop_run_edges(2, true);
        for v in [
            &seg.accel_magnitude,
            &seg.velocity_magnitude,
            &seg.vertical_accel,
            &seg.vertical_velocity,
            &seg.horizontal_accel[0],
            &seg.horizontal_accel[1],
        ] {
            assert_eq!(present(v), vec![0, 1, 7, 8, 9]);
        }
        // Signals the low-pass does not shape are untouched.
        for v in [
            &seg.orientation_magnitude,
            &seg.swing,
            &seg.elevation,
            &seg.turn_rate,
        ] {
            assert_eq!(present(v), present(&signal));
        }
        // A track first seen inside the window: its start goes too; a run shorter than the
        // edges goes entirely.
        let mut seg = fresh();
        seg.drop_run_edges(2, false);
        assert_eq!(present(&seg.accel_magnitude), vec![7, 8, 9]);
        let mut seg = fresh();
        seg.drop_run_edges(3, false);
        assert_eq!(present(&seg.vertical_accel), vec![8, 9]);
        // Nothing dropped at zero samples; every run dropped at `usize::MAX` (whose sum with a
        // run's start used to wrap, and panic on the slice).
        let mut seg = fresh();
        seg.drop_run_edges(0, false);
        assert_eq!(present(&seg.vertical_velocity), present(&signal));
        let mut seg = fresh();
        seg.drop_run_edges(usize::MAX, false);
        assert_eq!(present(&seg.accel_magnitude), Vec::<usize>::new());
    }

    #[test]
    fn prepared_comparisons_equal_the_pairwise_ones() {
        let (imu, skel) = windows();
        let (geo, kin) = (GeometricConfig::default(), KinematicConfig::default());
        let imu_features = ImuFeatures::new(&imu, &geo, &kin);
        let close = |a: Option<f64>, b: Option<f64>| match (a, b) {
            (Some(a), Some(b)) => (a - b).abs() < 1e-12,
            (a, b) => a == b,
        };
        // The full window, its skeleton with dropped edges (samples the IMU has and the
        // skeleton misses) and a joint the window lacks.
        let mut dropped = SegmentFeatures::new(&skel, Joint::LeftWrist, &geo, &kin);
        dropped.drop_run_edges(4, false);
        let mut num_compared = 0;
        for seg in [
            SegmentFeatures::new(&skel, Joint::LeftWrist, &geo, &kin),
            dropped,
            SegmentFeatures::new(&skel, Joint::RightAnkle, &geo, &kin),
        ] {
            let (g, k) = compare_features(&imu_features, &seg, &geo);
            let (gp, kp) = compare_prepared(
                &imu_features,
                &imu_features.units(),
                &seg,
                &seg.units(),
                &geo,
            );
            for (a, b) in [
                (g.acc, gp.acc),
                (g.vel, gp.vel),
                (g.ori, gp.ori),
                (k.swing, kp.swing),
                (k.vertical_accel, kp.vertical_accel),
                (k.vertical_vel, kp.vertical_vel),
                (k.inclination, kp.inclination),
                (k.turn, kp.turn),
            ] {
                assert!(close(a, b), "{a:?} against {b:?}");
                num_compared += usize::from(a.is_some());
            }
        }
        assert!(num_compared >= 12, "{num_compared} scores compared");
    }

    #[test]
    fn lag_models_equal_the_single_signal_builders() {
        let (imu, skel) = windows();
        let (geo, kin) = (GeometricConfig::default(), KinematicConfig::default());
        let site = Joint::LeftWrist;
        let same = |a: &[f64], b: &[f64]| {
            a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
        };
        let [acc, ori, vertical, swing, turn] = imu_lag_models(&imu, &geo, &kin, 1);
        assert!(acc.iter().any(|v| v.is_finite()));
        assert!(same(&acc, &imu_accel_magnitude(&imu, &geo)));
        assert!(same(&ori, &imu_orientation_magnitude(&imu, &geo)));
        assert!(same(&vertical, &crate::imu_vertical_accel(&imu, &geo)));
        assert!(same(&swing, &crate::imu_swing_signal(&imu, &geo, &kin)));
        assert!(same(&turn, &imu_turn_rate_signal(&imu, &kin)));
        // Without the orientation change, at the full rate and thinned, the same four.
        for step in [1, 3] {
            let all = imu_lag_models(&imu, &geo, &kin, step);
            let [acc, vertical, swing, turn] = imu_unanchored_lag_models(&imu, &geo, &kin, step);
            for (m, mine) in [(0, acc), (2, vertical), (3, swing), (4, turn)] {
                assert!(same(&mine, &all[m]), "step {step}, model {m}");
            }
        }
        let [acc, ori, vertical, swing, turn] = segment_lag_models(&skel, site, &geo, &kin, 1);
        assert!(acc.iter().any(|v| v.is_finite()));
        assert!(same(&acc, &joint_accel_magnitude(&skel, site, &geo)));
        assert!(same(
            &ori,
            &segment_orientation_magnitude(&skel, site, &geo)
        ));
        assert!(same(
            &vertical,
            &crate::joint_vertical_accel(&skel, site, &geo)
        ));
        assert!(same(
            &swing,
            &crate::segment_swing_signal(&skel, site, &geo, &kin)
        ));
        assert!(same(&turn, &body_turn_rate_signal(&skel, &kin)));
        // A joint the window lacks: every model missing, as the single builders give.
        let [acc, _, vertical, ..] = segment_lag_models(&skel, Joint::RightAnkle, &geo, &kin, 1);
        assert!(acc.iter().chain(&vertical).all(|v| v.is_nan()));
        // The site's four and the body's turn rate, built apart, are the same five.
        let [acc, ori, vertical, swing] = segment_site_lag_models(&skel, site, &geo, &kin, 2);
        let five = segment_lag_models(&skel, site, &geo, &kin, 2);
        for (a, b) in [acc, ori, vertical, swing].iter().zip(&five) {
            assert!(same(a, b));
        }
        let turn: Vec<f64> = body_turn_rate_signal(&skel, &kin)
            .into_iter()
            .step_by(2)
            .collect();
        assert!(same(&turn, &five[4]));
        // Features with the turn rate given equal those that compute it (compared as text:
        // both have `NaN`s where a signal is missing).
        let given = SegmentFeatures::with_turn_rate(
            &skel,
            site,
            &geo,
            &kin,
            body_turn_rate_signal(&skel, &kin),
        );
        assert_eq!(
            format!("{given:?}"),
            format!("{:?}", SegmentFeatures::new(&skel, site, &geo, &kin))
        );
    }

    #[test]
    fn thinned_lag_models_are_every_nth_value_of_the_full_rate_ones() {
        let (mut imu, skel) = windows();
        // A missing orientation: the thinned angles skip it like the full-rate ones.
        if let Some(q) = imu.world_from_sensor.get_mut(4) {
            *q = UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(f64::NAN, 0.0, 0.0, 0.0));
        }
        let kin = KinematicConfig::default();
        let same = |a: &[f64], b: &[f64]| {
            a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
        };
        let thin =
            |v: &[f64], step: usize| -> Vec<f64> { v.iter().step_by(step).copied().collect() };
        // Without a moving average the angles are computed at the kept samples only; with
        // one they are smoothed at the full rate first. Both must thin the full-rate values.
        for moving_average_len in [1, 5] {
            let geo = GeometricConfig {
                moving_average_len,
                ..GeometricConfig::default()
            };
            let imu_full = imu_lag_models(&imu, &geo, &kin, 1);
            let skel_full = segment_lag_models(&skel, Joint::LeftWrist, &geo, &kin, 1);
            for step in [2, 3, 7] {
                let imu_thin = imu_lag_models(&imu, &geo, &kin, step);
                let skel_thin = segment_lag_models(&skel, Joint::LeftWrist, &geo, &kin, step);
                for (full, thinned) in imu_full
                    .iter()
                    .zip(&imu_thin)
                    .chain(skel_full.iter().zip(&skel_thin))
                {
                    assert!(full.iter().any(|v| v.is_finite()));
                    assert!(
                        same(&thin(full, step), thinned),
                        "step {step}, average {moving_average_len}"
                    );
                }
            }
        }
        // Step 0 is step 1.
        let geo = GeometricConfig::default();
        assert_eq!(
            imu_lag_models(&imu, &geo, &kin, 0)[1].len(),
            imu_lag_models(&imu, &geo, &kin, 1)[1].len()
        );
    }

    #[test]
    fn features_compare_like_the_signal_builders_they_are_made_of() {
        let (imu, skel) = windows();
        let (geo, kin) = (GeometricConfig::default(), KinematicConfig::default());
        let site = Joint::LeftWrist;
        let (scores, k) = compare_features(
            &ImuFeatures::new(&imu, &geo, &kin),
            &SegmentFeatures::new(&skel, site, &geo, &kin),
            &geo,
        );
        let expect = |a: Vec<f64>, b: Vec<f64>| pearson(&a, &b, geo.min_samples);
        assert_eq!(
            scores.acc,
            expect(
                imu_accel_magnitude(&imu, &geo),
                joint_accel_magnitude(&skel, site, &geo)
            )
        );
        assert_eq!(
            scores.vel,
            expect(
                imu_velocity_magnitude(&imu, &geo),
                joint_velocity_magnitude(&skel, site, &geo)
            )
        );
        // The turn rates are compared by concordance (same unit on both sides).
        assert_eq!(
            k.turn,
            crate::concordance(
                &imu_turn_rate_signal(&imu, &kin),
                &body_turn_rate_signal(&skel, &kin),
                geo.min_samples
            )
        );
        // The swing and the inclination follow the forearm, which moves the same on both sides.
        assert!(k.swing.is_some_and(|r| r > 0.8), "{k:?}");
        assert!(k.inclination.is_some_and(|r| r > 0.8), "{k:?}");
        // The one-pair entry points are this path.
        assert_eq!(scores, crate::geometric_scores(&imu, &skel, site, &geo));
        assert_eq!(k, crate::kinematic_scores(&imu, &skel, site, &geo, &kin));
    }

    #[test]
    fn features_on_different_grids_compare_to_nothing() {
        let (imu, skel) = windows();
        let (geo, kin) = (GeometricConfig::default(), KinematicConfig::default());
        let mut shorter = skel.clone();
        shorter.t_s.pop();
        shorter.joints_world_m.pop();
        let (scores, k) = compare_features(
            &ImuFeatures::new(&imu, &geo, &kin),
            &SegmentFeatures::new(&shorter, Joint::LeftWrist, &geo, &kin),
            &geo,
        );
        assert_eq!(scores, ModelScores::default());
        assert_eq!(k, KinematicScores::default());
    }

    /// Features carrying only horizontal accelerations: the joint's `s`, and the IMU's the
    /// same vectors seen from a frame turned by `yaw_rad` (plus a little disagreement).
    fn horizontal_pair(yaw_rad: f64, len: usize) -> (ImuFeatures, SegmentFeatures) {
        let s: Vec<[f64; 2]> = (0..len)
            .map(|k| {
                let t = k as f64 / 30.0;
                // A stride's fore-aft swing along a heading that turns a quarter round.
                let heading = 1.6 * (t / 4.0).min(1.0);
                let swing = (2.0 * std::f64::consts::PI * 0.9 * t).sin() + 0.3 * (5.1 * t).cos();
                [swing * heading.cos(), swing * heading.sin()]
            })
            .collect();
        let (sin, cos) = (-yaw_rad).sin_cos();
        let a: Vec<[f64; 2]> = s
            .iter()
            .enumerate()
            .map(|(k, [x, y])| {
                let wobble = 0.05 * (k as f64 * 0.7).sin();
                [cos * x - sin * y + wobble, sin * x + cos * y]
            })
            .collect();
        let split = |v: &[[f64; 2]]| {
            [
                v.iter().map(|p| p[0]).collect(),
                v.iter().map(|p| p[1]).collect(),
            ]
        };
        (
            ImuFeatures {
                horizontal_accel: split(&a),
                ..ImuFeatures::default()
            },
            SegmentFeatures {
                horizontal_accel: split(&s),
                ..SegmentFeatures::default()
            },
        )
    }

    #[test]
    fn the_horizontal_cross_sum_turns_by_the_imus_heading_and_aligns_back() {
        let yaw = 0.9;
        let (imu, seg) = horizontal_pair(yaw, 150);
        let c = horizontal_cross(&imu, &seg, 10).expect("enough samples");
        // The phase of Σ a·conj(s) is the rotation from the room into the IMU's frame.
        assert!((c.im.atan2(c.re) + yaw).abs() < 0.02, "{c:?}");
        let (re, im) = (c.re / c.re.hypot(c.im), c.im / c.re.hypot(c.im));
        let aligned = c.aligned_correlation(re, im).expect("power");
        assert!(aligned > 0.99, "{aligned}");
        // Read at the opposite heading it anti-correlates; a quarter turn off, it says nothing.
        let opposite = c.aligned_correlation(-re, -im).expect("power");
        assert!((opposite + aligned).abs() < 1e-12, "{opposite}");
        let across = c.aligned_correlation(-im, re).expect("power");
        assert!(across.abs() < 0.05, "{across}");
    }

    #[test]
    fn the_prepared_horizontal_cross_sum_equals_the_plain_one_bit_for_bit() {
        let (imu, seg) = horizontal_pair(0.7, 40);
        let bits = |c: Option<HorizontalCross>| {
            c.map(|c| [c.re, c.im, c.imu_power, c.joint_power].map(f64::to_bits))
        };
        let check = |imu: &ImuFeatures, seg: &SegmentFeatures, min: usize| {
            let prepared = horizontal_cross_prepared(imu, &imu.units(), seg, &seg.units(), min);
            assert_eq!(bits(prepared), bits(horizontal_cross(imu, seg, min)));
            prepared
        };
        // Both complete; the segment with gaps (the shortcut); the IMU with a gap as well
        // (the plain path); too few samples left; grids of different lengths.
        assert!(check(&imu, &seg, 10).is_some());
        let mut gapped = seg.clone();
        gapped.horizontal_accel[0][5] = f64::NAN;
        gapped.horizontal_accel[1][6] = f64::INFINITY;
        gapped.horizontal_accel[1][30] = f64::NAN;
        assert!(
            gapped
                .units()
                .horizontal_present
                .is_some_and(|p| p.len() == 37)
        );
        assert!(check(&imu, &gapped, 10).is_some());
        let mut imu_gapped = imu.clone();
        imu_gapped.horizontal_accel[1][9] = f64::NAN;
        assert!(!imu_gapped.units().is_horizontal_complete);
        assert!(check(&imu_gapped, &gapped, 10).is_some());
        assert_eq!(check(&imu, &gapped, 38), None);
        let mut short = gapped.clone();
        short.horizontal_accel[0].truncate(20);
        assert_eq!(check(&imu, &short, 10), None);
    }

    #[test]
    fn the_horizontal_cross_sum_skips_missing_samples_and_needs_enough() {
        let (mut imu, mut seg) = horizontal_pair(0.0, 40);
        let full = horizontal_cross(&imu, &seg, 10).expect("enough samples");
        // A gap on either side drops that sample from both; the rest still aligns.
        imu.horizontal_accel[0][3] = f64::NAN;
        seg.horizontal_accel[1][7] = f64::NAN;
        let gapped = horizontal_cross(&imu, &seg, 10).expect("enough samples");
        assert_ne!(gapped, full);
        assert!(
            gapped
                .aligned_correlation(1.0, 0.0)
                .is_some_and(|r| r > 0.99)
        );
        assert_eq!(horizontal_cross(&imu, &seg, 39), None);
        // Grids of different lengths do not compare.
        seg.horizontal_accel[0].truncate(20);
        seg.horizontal_accel[1].truncate(20);
        assert_eq!(horizontal_cross(&imu, &seg, 10), None);
        // No power, no correlation.
        assert_eq!(
            HorizontalCross::default().aligned_correlation(1.0, 0.0),
            None
        );
    }
}
