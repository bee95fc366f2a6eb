//! nomen's own motion models, beside De Marchi's three: signals that keep the *sign* and the
//! *timing* of the motion instead of a magnitude relative to the window's first sample, and the
//! body's turns.
//!
//! De Marchi's models compare magnitudes, which throws away direction, and the orientation model
//! measures the rotation from the window's first sample, which is dominated by slow heading
//! changes. Two people walking the same way at the same pace then look alike. These models use
//! what both sides measure without knowing the sensor's mounting on the segment or the AHRS's
//! heading reference:
//!
//! | model | IMU | skeleton |
//! |---|---|---|
//! | swing | rotation angle of `q_{k−L}⁻¹ q_k` (how far the sensor turned in the last `L` samples) | angle between the carrying bone's direction at `k−L` and at `k` |
//! | vertical acceleration | world `z` of the linear acceleration (gravity removed with the AHRS tilt, which is observable without a magnetometer), 3 Hz zero-phase low-pass | `z̈` of the joint through the same low-pass |
//! | vertical velocity | leaky integral of that vertical acceleration | `ż` of the joint through the same leak (see [`crate::geometric`]) |
//! | inclination | elevation of each sensor axis, `asin((q·e)_z)` | elevation of the carrying segment (the largest \|r\| over the three axes: the mounting is unknown) |
//! | turn rate | angular rate about the world vertical, `(q·ω)_z`, averaged over about a stride | rate of change of the body's heading (shoulder line, hip line where the shoulders are missing), averaged alike |
//!
//! The vertical components are signed, so a foot going up is not confused with one coming down;
//! the world `z` axis is shared by the camera calibration and the AHRS (gravity), unlike the
//! horizontal axes. The swing angle over a short lag (default 0.2 s) follows the limb's
//! swing rate, a signal with the gait's timing in it, and is invariant to the mounting. As in
//! De Marchi's orientation model the twist about the bone is invisible to the camera and only
//! lowers the correlation.
//!
//! The turn rate is what tells apart people who walk alike: gait is periodic, so with an unknown
//! clock offset of up to half a second the steps of anyone walking at the same cadence can be
//! lined up with an IMU, but the turns of a walk do not repeat. A rigid segment's angular
//! velocity is the same wherever the sensor sits on it, and its vertical component needs only
//! the AHRS tilt; every segment turns with the body, so the body's heading rate is the
//! skeleton side for any site. On the simulated 8-person body-area-network scene this model,
//! added to the scores and to the clock-offset search, raised the frames correctly identified
//! from 52 % to 65 % (seed 1, 3 s windows); over the ten imu-table scenes at seeds 1–3 it is
//! worth 6 points (60.6 % → 66.9 %, 2 s windows).
//!
//! Every score is a Pearson correlation in `-1..=1` (`None` when a signal is missing, constant or
//! too short), so the fusions treat these models like De Marchi's.

use crate::angle::{angle_between_rad, rotation_angle_rad};
use crate::belmonte::{
    BelmonteConfig, skeleton_yaw_rate_radps, smoothed_rate, vertical_rate_unsmoothed_radps,
};
use crate::features::{ImuFeatures, SegmentFeatures, compare_features};
use crate::geometric::{
    GeometricConfig, LeakSteps, bone_directions, filtered_joint_derivative, imu_linear_accel_world,
    segment_bones,
};
use crate::signal::{Derivative, grid_rate_hz, moving_average};
use crate::window::{ImuWindow, SkeletonWindow};
use nalgebra::{UnitQuaternion, Vector3};
use nomen_core::skeleton::Joint;
use serde::{Deserialize, Serialize};

/// Configuration of nomen's models.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(default, deny_unknown_fields)]
pub struct KinematicConfig {
    /// Lag over which the swing angle is measured, s. Default 0.2 s (a fifth of a gait cycle:
    /// long enough for the camera's bone direction noise to average out, short enough to keep
    /// the swing's timing).
    pub swing_lag_s: f64,
    /// Length of the moving average over the turn rates, s. Default 0.7 s: most of the
    /// shoulders' and the limbs' back-and-forth yaw within a gait cycle averages out, while a
    /// 2-s window still holds a turn's rise and fall. (It was 1.0 s, about one stride: a
    /// window then held barely two independent values. With the turn compared by concordance,
    /// 0.7 s gained 0.6 points per run over 138 simulated runs, as did 0.5 s, which cost the
    /// Belmonte intruder scenes more.)
    pub turn_smoothing_s: f64,
}

impl Default for KinematicConfig {
    fn default() -> Self {
        Self {
            swing_lag_s: 0.2,
            turn_smoothing_s: 0.7,
        }
    }
}

/// Correlations of nomen's models for one (IMU, skeleton joint) pair.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct KinematicScores {
    /// Swing angle over the lag.
    pub swing: Option<f64>,
    /// Vertical linear acceleration.
    pub vertical_accel: Option<f64>,
    /// Vertical velocity (leaky).
    pub vertical_vel: Option<f64>,
    /// Inclination of the carrying segment against the best-matching sensor axis.
    pub inclination: Option<f64>,
    /// Turn rate: the sensor's angular rate about the world vertical against the rate of
    /// change of the body's heading, by Lin's concordance ([`crate::concordance`]):
    /// both are rad/s, so a body that does not turn when the sensor does scores low even if
    /// its small wobbles happen to follow the sensor's.
    pub turn: Option<f64>,
}

impl KinematicScores {
    /// The scores present, in field order.
    pub fn present(&self) -> impl Iterator<Item = f64> + '_ {
        [
            self.swing,
            self.vertical_accel,
            self.vertical_vel,
            self.inclination,
            self.turn,
        ]
        .into_iter()
        .flatten()
    }
}

/// nomen's five correlations for the IMU worn at `site` and the joint `site` of a candidate
/// skeleton (see the module docs). Windows on different grids give all `None`.
pub fn kinematic_scores(
    imu: &ImuWindow,
    skel: &SkeletonWindow,
    site: Joint,
    geo: &GeometricConfig,
    cfg: &KinematicConfig,
) -> KinematicScores {
    if imu.t_s.len() != skel.t_s.len() || imu.t_s.is_empty() {
        return KinematicScores::default();
    }
    compare_features(
        &ImuFeatures::new(imu, geo, cfg),
        &SegmentFeatures::new(skel, site, geo, cfg),
        geo,
    )
    .1
}

/// Elevation of a vector above the horizontal plane, rad (NaN if degenerate).
pub(crate) fn elevation_rad(d: &Vector3<f64>) -> f64 {
    let horizontal = d.x.hypot(d.y);
    if (horizontal > 0.0 || d.z != 0.0) && d.iter().all(|v| v.is_finite()) {
        crate::angle::atan2(d.z, horizontal)
    } else {
        f64::NAN
    }
}

/// Rotation angle of the sensor over the last `lag` samples, rad (NaN where unknown).
pub(crate) fn imu_swing(imu: &ImuWindow, lag: usize) -> Vec<f64> {
    imu_swing_every(imu, lag, 1)
}

/// [`imu_swing`] at every `step`-th sample only (0, `step`, 2·`step`, …; `step` ≥ 1).
pub(crate) fn imu_swing_every(imu: &ImuWindow, lag: usize, step: usize) -> Vec<f64> {
    let ok = |q: &UnitQuaternion<f64>| q.coords.iter().all(|c| c.is_finite());
    (0..imu.t_s.len())
        .step_by(step.max(1))
        .map(|k| {
            let a = k
                .checked_sub(lag)
                .and_then(|i| imu.world_from_sensor.get(i));
            match (a, imu.world_from_sensor.get(k)) {
                (Some(a), Some(b)) if ok(a) && ok(b) => rotation_angle_rad(&(a.inverse() * b)),
                _ => f64::NAN,
            }
        })
        .collect()
}

/// Angle the carrying bone turned over the last `lag` samples, rad (NaN where unknown).
pub(crate) fn segment_swing(skel: &SkeletonWindow, site: Joint, lag: usize) -> Vec<f64> {
    let dirs = bone_directions(&segment_bones(skel, site));
    segment_swing_from(&dirs, skel.t_s.len(), lag)
}

/// [`segment_swing`] from the segment's directions ([`bone_directions`]) on a grid of `n`
/// samples.
pub(crate) fn segment_swing_from(dirs: &[Option<Vector3<f64>>], n: usize, lag: usize) -> Vec<f64> {
    (0..n)
        .map(|k| {
            let a = k
                .checked_sub(lag)
                .and_then(|i| dirs.get(i))
                .copied()
                .flatten();
            match (a, dirs.get(k).copied().flatten()) {
                (Some(a), Some(b)) => angle_between_rad(&a, &b),
                _ => f64::NAN,
            }
        })
        .collect()
}

/// Leaky integral of the IMU's vertical linear acceleration, m/s (starts at 0 in the window).
pub(crate) fn imu_vertical_velocity(
    imu: &ImuWindow,
    lin: &[Vector3<f64>],
    geo: &GeometricConfig,
) -> Vec<f64> {
    let mut v = 0.0;
    let mut started = false;
    let mut out = Vec::with_capacity(lin.len());
    let mut leaks = LeakSteps::new(geo);
    for (k, a) in lin.iter().enumerate() {
        if let (Some(t1), Some(t0)) = (
            imu.t_s.get(k),
            k.checked_sub(1).and_then(|i| imu.t_s.get(i)),
        ) {
            let dt = t1 - t0;
            v *= leaks.factor(dt);
            if started && a.z.is_finite() {
                v += a.z * dt;
            }
        }
        started |= a.z.is_finite();
        out.push(if started && a.z.is_finite() {
            v
        } else {
            f64::NAN
        });
    }
    out
}

/// The joint's vertical velocity through the IMU integrator's leak, m/s, from its low-passed
/// velocity `vel`.
pub(crate) fn joint_vertical_velocity(
    skel: &SkeletonWindow,
    vel: &[Vector3<f64>],
    geo: &GeometricConfig,
) -> Vec<f64> {
    let mut u = 0.0;
    let mut last: Option<f64> = None;
    let mut out = Vec::with_capacity(vel.len());
    let mut leaks = LeakSteps::new(geo);
    for (k, v) in vel.iter().enumerate() {
        if let (Some(t1), Some(t0)) = (
            skel.t_s.get(k),
            k.checked_sub(1).and_then(|i| skel.t_s.get(i)),
        ) {
            u *= leaks.factor(t1 - t0);
        }
        if v.z.is_finite() {
            if let Some(prev) = last {
                u += v.z - prev;
            }
            last = Some(v.z);
            out.push(u);
        } else {
            out.push(f64::NAN);
        }
    }
    out
}

/// The IMU's vertical linear acceleration on its window's own times, m/s² (world `z`, gravity
/// removed, 3 Hz zero-phase low-pass, moving average), for lag searches on longer buffers.
pub fn imu_vertical_accel(imu: &ImuWindow, geo: &GeometricConfig) -> Vec<f64> {
    let mut v: Vec<f64> = imu_linear_accel_world(imu, geo)
        .iter()
        .map(|a| a.z)
        .collect();
    moving_average(&mut v, geo.moving_average_len);
    v
}

/// A joint's vertical acceleration on the skeleton window's own times, m/s² (through the IMU's
/// low-pass and moving average).
pub fn joint_vertical_accel(skel: &SkeletonWindow, site: Joint, geo: &GeometricConfig) -> Vec<f64> {
    let mut v: Vec<f64> = filtered_joint_derivative(skel, site, Derivative::Acceleration, geo)
        .map(|d| d.iter().map(|a| a.z).collect())
        .unwrap_or_else(|| vec![f64::NAN; skel.t_s.len()]);
    moving_average(&mut v, geo.moving_average_len);
    v
}

/// The IMU's swing angle over the last `cfg.swing_lag_s` on its window's own times, rad.
pub fn imu_swing_signal(imu: &ImuWindow, geo: &GeometricConfig, cfg: &KinematicConfig) -> Vec<f64> {
    let lag = lag_samples(&imu.t_s, cfg);
    let mut v = imu_swing(imu, lag);
    moving_average(&mut v, geo.moving_average_len);
    v
}

/// The carrying segment's swing angle over the last `cfg.swing_lag_s` on the skeleton window's
/// own times, rad.
pub fn segment_swing_signal(
    skel: &SkeletonWindow,
    site: Joint,
    geo: &GeometricConfig,
    cfg: &KinematicConfig,
) -> Vec<f64> {
    let lag = lag_samples(&skel.t_s, cfg);
    let mut v = segment_swing(skel, site, lag);
    moving_average(&mut v, geo.moving_average_len);
    v
}

/// The sensor's angular rate about the world vertical, `(world_from_sensor · ω)_z`, averaged
/// over `cfg.turn_smoothing_s`, rad/s. The rate of a rigid segment is the same wherever and
/// however the sensor sits on it, and its vertical component needs only the AHRS tilt.
pub fn imu_turn_rate_signal(imu: &ImuWindow, cfg: &KinematicConfig) -> Vec<f64> {
    imu_turn_rate_from(imu, vertical_rate_unsmoothed_radps(imu), cfg)
}

/// [`imu_turn_rate_signal`] from the sensor's vertical rate before smoothing
/// ([`crate::belmonte::vertical_rate_unsmoothed_radps`] of `imu`; one of another length counts
/// as missing), for a caller that shares it between windows or with the band's yaw rate.
pub fn imu_turn_rate_from(
    imu: &ImuWindow,
    unsmoothed_vertical_rate_radps: Vec<f64>,
    cfg: &KinematicConfig,
) -> Vec<f64> {
    smoothed_rate(
        imu,
        unsmoothed_vertical_rate_radps,
        smoothing_samples(&imu.t_s, cfg),
    )
}

/// The body's turn rate: the derivative of its heading (shoulder line, hip line where the
/// shoulders are missing), averaged over `cfg.turn_smoothing_s`, rad/s. Every segment turns
/// with the body, so this is compared with the sensor's vertical rate wherever it is worn.
pub fn body_turn_rate_signal(skel: &SkeletonWindow, cfg: &KinematicConfig) -> Vec<f64> {
    let belmonte = BelmonteConfig {
        moving_average_len: smoothing_samples(&skel.t_s, cfg),
        ..BelmonteConfig::default()
    };
    skeleton_yaw_rate_radps(skel, &belmonte)
}

/// [`body_turn_rate_signal`] from the skeleton's yaw rate before smoothing
/// ([`crate::belmonte::skeleton_yaw_rate_unsmoothed_radps`] of `skel` with the default
/// [`BelmonteConfig`]), for a caller that smooths it for Belmonte-Hernández's model as well.
pub fn body_turn_rate_from(
    skel: &SkeletonWindow,
    mut unsmoothed_yaw_rate_radps: Vec<f64>,
    cfg: &KinematicConfig,
) -> Vec<f64> {
    moving_average(
        &mut unsmoothed_yaw_rate_radps,
        smoothing_samples(&skel.t_s, cfg),
    );
    unsmoothed_yaw_rate_radps
}

/// The turn-rate smoothing in samples of a grid (at least one, and no more than the grid has
/// plus one: an average longer than its series is that series' running mean, and a grid of
/// stamps a nanosecond apart would otherwise ask for billions).
fn smoothing_samples(t_s: &[f64], cfg: &KinematicConfig) -> usize {
    grid_rate_hz(t_s)
        .map(|r| {
            (cfg.turn_smoothing_s * r)
                .round()
                .clamp(1.0, t_s.len() as f64 + 1.0) as usize
        })
        .unwrap_or(1)
}

/// The swing lag in samples of a grid (at least one).
pub(crate) fn lag_samples(t_s: &[f64], cfg: &KinematicConfig) -> usize {
    grid_rate_hz(t_s)
        .map(|r| {
            (cfg.swing_lag_s * r)
                .round()
                .clamp(1.0, t_s.len().max(1) as f64) as usize
        })
        .unwrap_or(1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Point3;
    use nomen_core::skeleton::Joints;

    #[test]
    fn a_grid_of_stamps_a_nanosecond_apart_smooths_and_lags_within_its_own_length() {
        // The smoothing (0.7 s) and the swing lag (0.2 s) in samples of a 1-GHz grid are
        // hundreds of millions: the turn rate used to ask for gigabytes (at 1 ps, an abort).
        for dt_s in [1e-9, 1e-12, 1e-300] {
            let n = 3;
            let imu = ImuWindow {
                device: None,
                t_s: (0..n).map(|i| i as f64 * dt_s).collect(),
                accel_mps2: vec![Vector3::new(0.0, 0.0, 9.81); n],
                gyro_radps: vec![Vector3::new(0.0, 0.0, 0.5); n],
                world_from_sensor: vec![UnitQuaternion::identity(); n],
            };
            let cfg = KinematicConfig::default();
            let turn = imu_turn_rate_signal(&imu, &cfg);
            assert_eq!(turn.len(), n);
            assert!(
                turn.iter().all(|v| (v - 0.5).abs() < 1e-12),
                "{dt_s}: {turn:?}"
            );
            assert_eq!(lag_samples(&imu.t_s, &cfg), n);
            assert_eq!(smoothing_samples(&imu.t_s, &cfg), n + 1);
        }
    }

    /// A forearm (elbow fixed, wrist on a 0.3 m arc) swinging by `angle(t)` about the world y
    /// axis, seen by the camera, and an IMU on it with its orientation and specific force.
    fn windows(
        imu_angle: impl Fn(f64) -> f64,
        skel_angle: impl Fn(f64) -> f64,
    ) -> (ImuWindow, SkeletonWindow) {
        let t_s: Vec<f64> = (0..120).map(|k| k as f64 / 30.0).collect();
        let q: Vec<UnitQuaternion<f64>> = t_s
            .iter()
            .map(|&t| UnitQuaternion::from_axis_angle(&Vector3::y_axis(), imu_angle(t)))
            .collect();
        let accel = q
            .iter()
            .map(|q| q.inverse() * Vector3::new(0.0, 0.0, 9.81))
            .collect();
        let joints = t_s
            .iter()
            .map(|&t| {
                let a = skel_angle(t);
                let elbow = Point3::new(0.0, 0.0, 1.2);
                let mut j = Joints::new();
                j.insert(Joint::LeftElbow, elbow);
                j.insert(
                    Joint::LeftWrist,
                    elbow + Vector3::new(0.3 * a.sin(), 0.0, -0.3 * a.cos()),
                );
                j
            })
            .collect();
        (
            ImuWindow {
                device: None,
                t_s: t_s.clone(),
                accel_mps2: accel,
                gyro_radps: vec![Vector3::zeros(); t_s.len()],
                world_from_sensor: q,
            },
            SkeletonWindow {
                camera: None,
                track: None,
                t_s,
                joints_world_m: joints,
            },
        )
    }

    #[test]
    fn the_wearers_forearm_scores_above_someone_elses() {
        let mine = |t: f64| 0.6 * (2.0 * std::f64::consts::PI * 0.9 * t).sin();
        let other = |t: f64| 0.6 * (2.0 * std::f64::consts::PI * 1.4 * t + 1.0).sin();
        let (geo, cfg) = (GeometricConfig::default(), KinematicConfig::default());
        let (imu, skel) = windows(mine, mine);
        let right = kinematic_scores(&imu, &skel, Joint::LeftWrist, &geo, &cfg);
        let (imu, skel) = windows(mine, other);
        let wrong = kinematic_scores(&imu, &skel, Joint::LeftWrist, &geo, &cfg);
        let (r_swing, w_swing) = (right.swing.unwrap(), wrong.swing.unwrap());
        let (r_incl, w_incl) = (right.inclination.unwrap(), wrong.inclination.unwrap());
        assert!(
            r_swing > 0.9 && r_swing > w_swing + 0.3,
            "{right:?} {wrong:?}"
        );
        assert!(r_incl > 0.9 && r_incl > w_incl + 0.3, "{right:?} {wrong:?}");
    }

    /// A person whose heading follows `heading(t)` (shoulders across it), and an IMU on the
    /// pelvis, mounted tilted, turning with the body.
    fn turning(
        imu_heading: impl Fn(f64) -> f64,
        skel_heading: impl Fn(f64) -> f64,
    ) -> (ImuWindow, SkeletonWindow) {
        let t_s: Vec<f64> = (0..150).map(|k| k as f64 / 30.0).collect();
        let mount = UnitQuaternion::from_euler_angles(0.4, -0.3, 1.2);
        let dt = 1e-4;
        let q: Vec<UnitQuaternion<f64>> = t_s
            .iter()
            .map(|&t| UnitQuaternion::from_axis_angle(&Vector3::z_axis(), imu_heading(t)) * mount)
            .collect();
        let gyro = t_s
            .iter()
            .zip(&q)
            .map(|(&t, q)| {
                let rate = (imu_heading(t + dt) - imu_heading(t - dt)) / (2.0 * dt);
                q.inverse() * Vector3::new(0.0, 0.0, rate)
            })
            .collect();
        let accel = q
            .iter()
            .map(|q| q.inverse() * Vector3::new(0.0, 0.0, 9.81))
            .collect();
        let joints = t_s
            .iter()
            .map(|&t| {
                let psi = skel_heading(t);
                let across = Vector3::new(psi.cos(), psi.sin(), 0.0) * 0.2;
                let chest = Point3::new(0.0, 0.0, 1.4);
                let mut j = Joints::new();
                j.insert(Joint::LeftShoulder, chest - across);
                j.insert(Joint::RightShoulder, chest + across);
                j.insert(Joint::Pelvis, Point3::new(0.0, 0.0, 1.0));
                j.insert(Joint::Chest, chest);
                j
            })
            .collect();
        (
            ImuWindow {
                device: None,
                t_s: t_s.clone(),
                accel_mps2: accel,
                gyro_radps: gyro,
                world_from_sensor: q,
            },
            SkeletonWindow {
                camera: None,
                track: None,
                t_s,
                joints_world_m: joints,
            },
        )
    }

    #[test]
    fn the_turn_rate_follows_the_wearers_turns_whatever_the_mounting() {
        // A 90° turn over a second, at 1.5 s for the wearer and at 3 s for someone else.
        let turn_at = |t0: f64| {
            move |t: f64| {
                let x = ((t - t0) / 1.0).clamp(0.0, 1.0);
                std::f64::consts::FRAC_PI_2 * (3.0 * x * x - 2.0 * x * x * x)
            }
        };
        let (geo, cfg) = (GeometricConfig::default(), KinematicConfig::default());
        let (imu, skel) = turning(turn_at(1.5), turn_at(1.5));
        let right = kinematic_scores(&imu, &skel, Joint::Pelvis, &geo, &cfg);
        let (imu, skel) = turning(turn_at(1.5), turn_at(3.0));
        let wrong = kinematic_scores(&imu, &skel, Joint::Pelvis, &geo, &cfg);
        let (r, w) = (right.turn.unwrap(), wrong.turn.unwrap());
        assert!(r > 0.95, "{right:?}");
        assert!(r > w + 0.5, "{right:?} {wrong:?}");
        // The sensor side is the body's vertical rate, not the mounting's: the turn peaks at
        // 3π/4 ≈ 2.36 rad/s, a little less after the 0.7-s average.
        let rate = imu_turn_rate_signal(&imu, &cfg);
        let peak = rate
            .iter()
            .copied()
            .filter(|v| v.is_finite())
            .fold(0.0, f64::max);
        assert!((1.8..2.36).contains(&peak), "{peak}");
    }

    #[test]
    fn windows_on_different_grids_give_nothing() {
        let f = |t: f64| t.sin();
        let (mut imu, skel) = windows(f, f);
        imu.t_s.pop();
        let s = kinematic_scores(
            &imu,
            &skel,
            Joint::LeftWrist,
            &GeometricConfig::default(),
            &KinematicConfig::default(),
        );
        assert_eq!(s, KinematicScores::default());
    }
}
