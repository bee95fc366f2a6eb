//! Constant-velocity Kalman filter for one 3D joint (De Marchi et al. filter every skeleton joint
//! before differentiating it).
//!
//! State `x = [p_x, p_y, p_z, v_x, v_y, v_z]` in metres and m/s; measurement `z = p + noise`.
//! The prediction over `dt` uses the continuous white-noise-acceleration model (Bar-Shalom, Li &
//! Kirubarajan, *Estimation with Applications to Tracking and Navigation*, §6.2.2): per axis
//!
//! ```text
//! F = [1 dt; 0 1],   Q = q · [dt³/3  dt²/2; dt²/2  dt]
//! ```
//!
//! with `q` the acceleration power spectral density in m²/s³. The measurement covariance `R` is
//! given with every update, so joints the pose SDK only *inferred* can carry a larger `R`.
//!
//! The predict/update algebra is [`adskalman`] 0.18 (Joseph-form covariance update), which works
//! on statically sized nalgebra 0.35 matrices — the same nalgebra as the workspace — so a step
//! does not allocate. The filter is zero-latency: [`JointKalman::step`] predicts to the
//! measurement time and then updates, so the estimate refers to the measurement instant.
//!
//! While every measurement covariance is diagonal (the usual case: pose SDKs report one
//! confidence per joint), the three axes never couple: `F`, `Q` and `H` are per-axis and a
//! block-diagonal covariance stays block-diagonal. The filter then runs three 2-state filters
//! with the same Joseph-form update written out for a scalar measurement, about a tenth of the
//! 6-state work; the first full `R` switches it to [`adskalman`] for good. Both paths agree to
//! rounding (a test runs them side by side). While `R` is moreover isotropic, as a pose SDK's
//! one confidence per joint gives, the three axes' covariances stay equal bit for bit, and one
//! axis's covariance arithmetic (prediction, gain, the smoother's gain) serves all three; the
//! states still step per axis, with the same numbers as three separate axes.

use crate::error::{FilterError, Result, check_non_negative, check_positive};
use adskalman::{
    CovarianceUpdateMethod, ObservationModel, StateAndCovariance, TransitionModelLinearNoControl,
};
use nalgebra::{Matrix3, Matrix6, OMatrix, Point3, U3, U6, Vector3, Vector6};
use nomen_core::SessionTime;
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;

/// Configuration of the constant-velocity joint filter.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
pub struct ConstantVelocityConfig {
    /// Power spectral density of the white acceleration driving each axis, m²/s³. Bar-Shalom's
    /// rule of thumb: `q ≈ a_max² · T` for accelerations of about `a_max` over the sampling period.
    pub accel_psd_m2ps3: f64,
    /// Standard deviation of the initial velocity, m/s (the first measurement fixes position only).
    pub initial_velocity_std_mps: f64,
}

impl Default for ConstantVelocityConfig {
    /// Human joints: accelerations of a few m/s² at 30 Hz give `q ≈ 10² / 30 ≈ 3` m²/s³; an initial
    /// velocity within ±2 m/s (walking speed).
    fn default() -> Self {
        Self {
            accel_psd_m2ps3: 3.0,
            initial_velocity_std_mps: 2.0,
        }
    }
}

impl ConstantVelocityConfig {
    fn validate(&self) -> Result<()> {
        check_positive("accel_psd_m2ps3", self.accel_psd_m2ps3)?;
        check_positive("initial_velocity_std_mps", self.initial_velocity_std_mps)
    }
}

/// What an update did with a measurement.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum UpdateOutcome {
    /// The measurement corrected the estimate.
    Applied,
    /// The first valid measurement initialised the filter.
    Initialized,
    /// The measurement (or its covariance) was not finite: treated as missing, predict only.
    RejectedAsMissing,
}

/// The constant-velocity transition `F(dt)` and the white-acceleration `Q(dt)` for three axes.
pub fn constant_velocity_model(dt_s: f64, accel_psd_m2ps3: f64) -> (Matrix6<f64>, Matrix6<f64>) {
    let mut f = Matrix6::identity();
    let mut q = Matrix6::zeros();
    let q_pp = accel_psd_m2ps3 * dt_s.powi(3) / 3.0;
    let q_pv = accel_psd_m2ps3 * dt_s.powi(2) / 2.0;
    let q_vv = accel_psd_m2ps3 * dt_s;
    for i in 0..3 {
        f[(i, i + 3)] = dt_s;
        q[(i, i)] = q_pp;
        q[(i, i + 3)] = q_pv;
        q[(i + 3, i)] = q_pv;
        q[(i + 3, i + 3)] = q_vv;
    }
    (f, q)
}

/// The position-only observation matrix `H = [I₃ 0]`.
pub fn position_observation() -> OMatrix<f64, U3, U6> {
    let mut h = OMatrix::<f64, U3, U6>::zeros();
    for i in 0..3 {
        h[(i, i)] = 1.0;
    }
    h
}

struct Transition {
    f: Matrix6<f64>,
    ft: Matrix6<f64>,
    q: Matrix6<f64>,
}

impl TransitionModelLinearNoControl<f64, U6> for Transition {
    fn F(&self) -> &Matrix6<f64> {
        &self.f
    }
    fn FT(&self) -> &Matrix6<f64> {
        &self.ft
    }
    fn Q(&self) -> &Matrix6<f64> {
        &self.q
    }
}

struct PositionObservation {
    h: OMatrix<f64, U3, U6>,
    ht: OMatrix<f64, U6, U3>,
    r: Matrix3<f64>,
}

impl ObservationModel<f64, U6, U3> for PositionObservation {
    fn H(&self) -> &OMatrix<f64, U3, U6> {
        &self.h
    }
    fn HT(&self) -> &OMatrix<f64, U6, U3> {
        &self.ht
    }
    fn R(&self) -> &Matrix3<f64> {
        &self.r
    }
}

/// True when `r` is finite and symmetric with a positive diagonal (a usable covariance).
pub(crate) fn is_usable_covariance(r: &Matrix3<f64>) -> bool {
    let is_positive_diagonal = (0..3).all(|i| r[(i, i)] > 0.0);
    if is_diagonal(r) {
        // The usual, per-joint isotropic noise: symmetric as it stands, and finite where its
        // diagonal is (the rest is zero).
        return is_positive_diagonal && (0..3).all(|i| r[(i, i)].is_finite());
    }
    r.iter().all(|v| v.is_finite())
        && is_positive_diagonal
        && (r - r.transpose()).abs().max() <= 1e-9 * (1.0 + r.abs().max())
}

/// One axis of a decoupled estimate: position (m), velocity (m/s) and their covariance.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Axis {
    p: f64,
    v: f64,
    pp: f64,
    pv: f64,
    vv: f64,
}

impl Axis {
    /// `F P Fᵀ + Q` with `F = [1 dt; 0 1]` and the white-acceleration `Q` of PSD `q`.
    fn predict(&mut self, dt: f64, q: f64) {
        self.p += dt * self.v;
        self.pp += dt * (2.0 * self.pv + dt * self.vv) + q * dt.powi(3) / 3.0;
        self.pv += dt * self.vv + q * dt.powi(2) / 2.0;
        self.vv += q * dt;
    }

    /// Joseph-form update with a position measurement `z` of variance `r`:
    /// `P ← (I − KH) P (I − KH)ᵀ + K r Kᵀ`, `H = [1 0]`.
    fn update(&mut self, z: f64, r: f64) -> bool {
        let Some(gain) = self.update_gain(r) else {
            return false;
        };
        self.apply(z, &gain);
        true
    }

    /// The covariance half of [`Axis::update`]: the gain `K` and the posterior covariance,
    /// which depend on the prior covariance and `r` alone; `None` where the innovation's
    /// variance is not positive.
    fn update_gain(&self, r: f64) -> Option<AxisGain> {
        let s = self.pp + r;
        if !(s.is_finite() && s > 0.0) {
            return None;
        }
        let (k0, k1) = (self.pp / s, self.pv / s);
        let a = 1.0 - k0;
        let (pp, pv, vv) = (self.pp, self.pv, self.vv);
        Some(AxisGain {
            k0,
            k1,
            pp: a * a * pp + k0 * k0 * r,
            pv: a * (pv - k1 * pp) + k0 * k1 * r,
            vv: k1 * k1 * pp - 2.0 * k1 * pv + vv + k1 * k1 * r,
        })
    }

    /// The state half of [`Axis::update`], with `gain` from [`Axis::update_gain`].
    fn apply(&mut self, z: f64, gain: &AxisGain) {
        let innovation = z - self.p;
        self.p += gain.k0 * innovation;
        self.v += gain.k1 * innovation;
        self.pp = gain.pp;
        self.pv = gain.pv;
        self.vv = gain.vv;
    }

    /// Whether `other` has the same covariance, bit for bit (then every covariance step from
    /// here gives both the same).
    fn has_covariance_of(&self, other: &Axis) -> bool {
        self.pp.to_bits() == other.pp.to_bits()
            && self.pv.to_bits() == other.pv.to_bits()
            && self.vv.to_bits() == other.vv.to_bits()
    }
}

/// A scalar update's gain `K = [k0 k1]ᵀ` and the posterior covariance it leaves.
#[derive(Debug, Clone, Copy)]
struct AxisGain {
    k0: f64,
    k1: f64,
    pp: f64,
    pv: f64,
    vv: f64,
}

/// Whether the three axes' covariances are the same bit for bit: the usual case, every
/// measurement covariance isotropic since the filter started. The covariance arithmetic of one
/// axis then serves all three.
fn share_covariance(axes: &[Axis; 3]) -> bool {
    let [x, y, z] = axes;
    x.has_covariance_of(y) && x.has_covariance_of(z)
}

/// [`Axis::predict`] on each axis; with [`share_covariance`], the covariance is predicted once.
fn predict_axes(axes: &mut [Axis; 3], dt: f64, q: f64) {
    if !share_covariance(axes) {
        for a in axes.iter_mut() {
            a.predict(dt, q);
        }
        return;
    }
    let [x, y, z] = axes;
    x.predict(dt, q);
    for a in [y, z] {
        a.p += dt * a.v;
        a.pp = x.pp;
        a.pv = x.pv;
        a.vv = x.vv;
    }
}

/// The estimate: three decoupled axes while every `R` was diagonal, else the full 6-state form.
#[derive(Debug, Clone)]
enum Estimate {
    Axes([Axis; 3]),
    /// Boxed: rare, and three times the size of the axes.
    Full(Box<StateAndCovariance<f64, U6>>),
}

impl Estimate {
    fn state(&self) -> Vector6<f64> {
        match self {
            Estimate::Axes(axes) => {
                let mut x = Vector6::zeros();
                for (i, a) in axes.iter().enumerate() {
                    x[i] = a.p;
                    x[i + 3] = a.v;
                }
                x
            }
            Estimate::Full(e) => *e.state(),
        }
    }

    fn covariance(&self) -> Matrix6<f64> {
        match self {
            Estimate::Axes(axes) => {
                let mut p = Matrix6::zeros();
                for (i, a) in axes.iter().enumerate() {
                    p[(i, i)] = a.pp;
                    p[(i, i + 3)] = a.pv;
                    p[(i + 3, i)] = a.pv;
                    p[(i + 3, i + 3)] = a.vv;
                }
                p
            }
            Estimate::Full(e) => *e.covariance(),
        }
    }

    fn to_full(&self) -> StateAndCovariance<f64, U6> {
        match self {
            Estimate::Axes(_) => StateAndCovariance::new(self.state(), self.covariance()),
            Estimate::Full(e) => (**e).clone(),
        }
    }
}

/// Updates each axis with its coordinate of `z` and its variance on `r`'s diagonal; on a
/// numerical failure the axes stay as they were.
fn update_axes(axes: &mut [Axis; 3], z: &Point3<f64>, r: &Matrix3<f64>) -> Result<()> {
    let failed = || FilterError::Numerical("joint kalman update");
    // Isotropic noise on a shared covariance: one gain for the three axes.
    let r_xx = r[(0, 0)];
    if share_covariance(axes)
        && r[(1, 1)].to_bits() == r_xx.to_bits()
        && r[(2, 2)].to_bits() == r_xx.to_bits()
    {
        let gain = axes[0].update_gain(r_xx).ok_or_else(failed)?;
        for (i, a) in axes.iter_mut().enumerate() {
            a.apply(z[i], &gain);
        }
        return Ok(());
    }
    let mut next = *axes;
    for (i, a) in next.iter_mut().enumerate() {
        if !a.update(z[i], r[(i, i)]) {
            return Err(failed());
        }
    }
    *axes = next;
    Ok(())
}

/// True when the off-diagonal entries of `r` are exactly zero.
fn is_diagonal(r: &Matrix3<f64>) -> bool {
    (0..3).all(|i| (0..3).all(|j| i == j || r[(i, j)] == 0.0))
}

/// Constant-velocity Kalman filter for one joint.
#[derive(Debug, Clone)]
pub struct JointKalman {
    config: ConstantVelocityConfig,
    estimate: Option<Estimate>,
    last_t: Option<SessionTime>,
    /// Use the 6-state [`adskalman`] form even for diagonal `R` (tests compare the two paths).
    is_full_only: bool,
}

impl JointKalman {
    /// A filter with no estimate yet; the first valid measurement initialises it.
    pub fn new(config: ConstantVelocityConfig) -> Result<Self> {
        config.validate()?;
        Ok(Self {
            config,
            estimate: None,
            last_t: None,
            is_full_only: false,
        })
    }

    /// The same filter computed with the 6-state [`adskalman`] algebra throughout (the
    /// reference the per-axis form is tested against).
    pub fn new_full(config: ConstantVelocityConfig) -> Result<Self> {
        let mut kf = Self::new(config)?;
        kf.is_full_only = true;
        Ok(kf)
    }

    /// True once a measurement has initialised the state.
    pub fn is_initialized(&self) -> bool {
        self.estimate.is_some()
    }

    /// Position estimate, if initialised.
    pub fn position(&self) -> Option<Point3<f64>> {
        self.estimate.as_ref().map(|e| match e {
            Estimate::Axes([x, y, z]) => Point3::new(x.p, y.p, z.p),
            Estimate::Full(e) => Point3::from(e.state().fixed_rows::<3>(0).into_owned()),
        })
    }

    /// Velocity estimate, if initialised.
    pub fn velocity(&self) -> Option<Vector3<f64>> {
        self.estimate.as_ref().map(|e| match e {
            Estimate::Axes([x, y, z]) => Vector3::new(x.v, y.v, z.v),
            Estimate::Full(e) => e.state().fixed_rows::<3>(3).into_owned(),
        })
    }

    /// Full state `[p; v]`, if initialised.
    pub fn state(&self) -> Option<Vector6<f64>> {
        self.estimate.as_ref().map(Estimate::state)
    }

    /// State covariance, if initialised.
    pub fn covariance(&self) -> Option<Matrix6<f64>> {
        self.estimate.as_ref().map(Estimate::covariance)
    }

    /// Time of the last [`Self::step`], if any.
    pub fn last_time(&self) -> Option<SessionTime> {
        self.last_t
    }

    /// Propagates the estimate by `dt_s` seconds (`dt_s` ≥ 0 and finite). Does nothing before
    /// initialisation.
    pub fn predict(&mut self, dt_s: f64) -> Result<()> {
        check_non_negative("dt_s", dt_s)?;
        match &mut self.estimate {
            Some(Estimate::Axes(axes)) => predict_axes(axes, dt_s, self.config.accel_psd_m2ps3),
            Some(Estimate::Full(estimate)) => {
                let (f, q) = constant_velocity_model(dt_s, self.config.accel_psd_m2ps3);
                let model = Transition {
                    f,
                    ft: f.transpose(),
                    q,
                };
                **estimate = model.predict(estimate);
            }
            None => {}
        }
        Ok(())
    }

    /// Corrects the estimate with a position measurement `z` of covariance `r` (m²). A
    /// non-finite `z` or an unusable `r` is treated as a missing measurement.
    pub fn update(&mut self, z: &Point3<f64>, r: &Matrix3<f64>) -> Result<UpdateOutcome> {
        if !z.iter().all(|v| v.is_finite()) || !is_usable_covariance(r) {
            return Ok(UpdateOutcome::RejectedAsMissing);
        }
        let is_separable = !self.is_full_only && is_diagonal(r);
        let Some(prior) = &mut self.estimate else {
            let v2 = self.config.initial_velocity_std_mps.powi(2);
            self.estimate = Some(if is_separable {
                Estimate::Axes(std::array::from_fn(|i| Axis {
                    p: z[i],
                    v: 0.0,
                    pp: r[(i, i)],
                    pv: 0.0,
                    vv: v2,
                }))
            } else {
                let mut p = Matrix6::zeros();
                p.fixed_view_mut::<3, 3>(0, 0).copy_from(r);
                p.fixed_view_mut::<3, 3>(3, 3)
                    .copy_from(&(Matrix3::identity() * v2));
                let mut x = Vector6::zeros();
                x.fixed_rows_mut::<3>(0).copy_from(&z.coords);
                Estimate::Full(Box::new(StateAndCovariance::new(x, p)))
            });
            return Ok(UpdateOutcome::Initialized);
        };
        if is_separable && let Estimate::Axes(axes) = prior {
            update_axes(axes, z, r)?;
            return Ok(UpdateOutcome::Applied);
        }
        let h = position_observation();
        let model = PositionObservation {
            h,
            ht: h.transpose(),
            r: *r,
        };
        let posterior = model
            .update(
                &prior.to_full(),
                &z.coords,
                CovarianceUpdateMethod::JosephForm,
            )
            .map_err(|_| FilterError::Numerical("joint kalman update"))?;
        *prior = Estimate::Full(Box::new(posterior));
        Ok(UpdateOutcome::Applied)
    }

    /// Zero-latency step at time `t`: predicts from the previous step's time to `t`, then
    /// updates with `measurement` (position, covariance) if there is one. `None`, a NaN position
    /// or an unusable covariance mean "no measurement": predict only. Time must strictly increase.
    pub fn step(
        &mut self,
        t: SessionTime,
        measurement: Option<(&Point3<f64>, &Matrix3<f64>)>,
    ) -> Result<Option<UpdateOutcome>> {
        if let Some(last) = self.last_t {
            if t <= last {
                return Err(FilterError::NonIncreasingTime {
                    index: 0,
                    previous_ns: last.as_ns(),
                    current_ns: t.as_ns(),
                });
            }
            self.predict(t.secs_since(last))?;
        }
        self.last_t = Some(t);
        match measurement {
            Some((z, r)) => self.update(z, r).map(Some),
            None => Ok(None),
        }
    }
}

impl JointKalman {
    /// [`Self::step`] where it stays on the per-axis form (initialised per axis, `t` after the
    /// last step, no measurement that would switch to the full form), returning the prior at
    /// `t` as well; `None` elsewhere, with nothing changed. `dt_s` is `t`'s distance from the
    /// last step. The same arithmetic as [`Self::predict`] then [`Self::update`], and the same
    /// errors, with nothing changed before an error's cause is checked.
    fn step_per_axis(
        &mut self,
        t: SessionTime,
        dt_s: f64,
        measurement: Option<(&Point3<f64>, &Matrix3<f64>)>,
    ) -> Option<Result<([Axis; 3], Option<UpdateOutcome>)>> {
        if self.last_t.is_none_or(|last| t <= last) {
            return None;
        }
        let usable =
            measurement.filter(|(z, r)| z.iter().all(|v| v.is_finite()) && is_usable_covariance(r));
        if usable.is_some_and(|(_, r)| self.is_full_only || !is_diagonal(r)) {
            return None;
        }
        let Some(Estimate::Axes(axes)) = &mut self.estimate else {
            return None;
        };
        if let Err(e) = check_non_negative("dt_s", dt_s) {
            return Some(Err(e));
        }
        predict_axes(axes, dt_s, self.config.accel_psd_m2ps3);
        let prior = *axes;
        self.last_t = Some(t);
        let outcome = match (measurement, usable) {
            (None, _) => None,
            (Some(_), None) => Some(UpdateOutcome::RejectedAsMissing),
            (Some(_), Some((z, r))) => {
                if let Err(e) = update_axes(axes, z, r) {
                    return Some(Err(e));
                }
                Some(UpdateOutcome::Applied)
            }
        };
        Some(Ok((prior, outcome)))
    }

    /// The three decoupled axes, while the filter is initialised and in the per-axis form.
    fn axes(&self) -> Option<[Axis; 3]> {
        match &self.estimate {
            Some(Estimate::Axes(axes)) => Some(*axes),
            _ => None,
        }
    }
}

/// One step of a [`JointSmoother`]'s history: the prior at `t` (predicted from the step before)
/// and the posterior after the step's measurement, if any.
#[derive(Debug, Clone, Copy)]
struct SmootherStep {
    prior: [Axis; 3],
    posterior: [Axis; 3],
    /// Per axis, the RTS gain `C = P Fᵀ (P⁻)⁻¹` from this step to the next (`None` until the
    /// next step comes, or where its prior is singular): it depends on covariances only, so it
    /// is computed once.
    gain: [Option<[f64; 4]>; 3],
}

/// A fixed-lag Rauch–Tung–Striebel smoother on top of [`JointKalman`]: the positions of every
/// step within `lag` of the newest, each given every measurement up to the newest (Bar-Shalom,
/// Li & Kirubarajan, §8.6).
///
/// The filter alone estimates a moving joint late: its estimate at `t` only knows the
/// measurements up to `t`, and with a smooth motion model it trails a swinging wrist by tens of
/// milliseconds. The backward pass over the last `lag` seconds removes that delay for the steps
/// a lag behind the newest, and lowers their noise, at the price of revising them. The newest
/// step's smoothed position is the filter's.
///
/// The history is kept while the filter runs per axis (every measurement covariance diagonal,
/// the usual case); after a full covariance, or before the first measurement, nothing is
/// smoothed ([`JointSmoother::smooth`] gives nothing) and the filter's estimate is all there is.
#[derive(Debug, Clone)]
pub struct JointSmoother {
    filter: JointKalman,
    lag_ns: i64,
    history: VecDeque<SmootherStep>,
    /// The times of `history`'s steps, kept apart: each step checks the oldest against the
    /// lag, and in a 370-byte step that read missed the cache (half of the step's time with
    /// 320 joints in flight).
    history_t: VecDeque<SessionTime>,
    /// The posterior of `history`'s newest step, kept apart for the same reason: the next
    /// step's RTS gain reads it.
    newest_posterior: Option<[Axis; 3]>,
    smoothed: Vec<(SessionTime, Point3<f64>)>,
}

impl JointSmoother {
    /// A smoother over the last `lag_s` seconds (finite and ≥ 0; 0 gives the filter alone).
    pub fn new(config: ConstantVelocityConfig, lag_s: f64) -> Result<Self> {
        check_non_negative("lag_s", lag_s)?;
        Ok(Self {
            filter: JointKalman::new(config)?,
            // Rounded to whole nanoseconds; lags are a fraction of a second.
            lag_ns: (lag_s * 1e9).round() as i64,
            history: VecDeque::new(),
            history_t: VecDeque::new(),
            newest_posterior: None,
            smoothed: Vec::new(),
        })
    }

    /// The filter underneath (its estimate refers to the newest step).
    pub fn filter(&self) -> &JointKalman {
        &self.filter
    }

    /// [`JointKalman::step`]; the step joins the history the backward pass
    /// ([`JointSmoother::smooth`]) runs over, and steps older than the lag leave it.
    pub fn step(
        &mut self,
        t: SessionTime,
        measurement: Option<(&Point3<f64>, &Matrix3<f64>)>,
    ) -> Result<Option<UpdateOutcome>> {
        let dt_s = match self.filter.last_time() {
            Some(last) if t > last => t.secs_since(last),
            // The first step, or one the filter refuses below.
            _ => 0.0,
        };
        let (prior, outcome) = match self.filter.step_per_axis(t, dt_s, measurement) {
            Some(stepped) => {
                let (prior, outcome) = stepped?;
                (Some(prior), outcome)
            }
            None => {
                // The prior at `t`: the filter's step predicts first, so predicting a copy
                // gives it.
                let prior = match self.filter.axes() {
                    Some(mut axes) if self.filter.last_time().is_some_and(|last| t > last) => {
                        predict_axes(&mut axes, dt_s, self.filter.config.accel_psd_m2ps3);
                        Some(axes)
                    }
                    _ => None,
                };
                (prior, self.filter.step(t, measurement)?)
            }
        };
        match (prior, self.filter.axes()) {
            (Some(prior), Some(posterior)) => {
                if let (Some(last), Some(cur)) = (self.history.back_mut(), &self.newest_posterior) {
                    last.gain = if share_covariance(cur) && share_covariance(&prior) {
                        [rts_gain(&cur[0], &prior[0], dt_s); 3]
                    } else {
                        std::array::from_fn(|i| rts_gain(&cur[i], &prior[i], dt_s))
                    };
                }
                self.history.push_back(SmootherStep {
                    prior,
                    posterior,
                    gain: [None; 3],
                });
                self.history_t.push_back(t);
                self.newest_posterior = Some(posterior);
            }
            // The first step of a fresh estimate has no prior: it starts the history.
            (None, Some(posterior)) => {
                self.history.clear();
                self.history_t.clear();
                self.history.push_back(SmootherStep {
                    prior: posterior,
                    posterior,
                    gain: [None; 3],
                });
                self.history_t.push_back(t);
                self.newest_posterior = Some(posterior);
            }
            (_, None) => {
                self.history.clear();
                self.history_t.clear();
                self.newest_posterior = None;
            }
        }
        let num_old = self
            .history_t
            .iter()
            .take_while(|first| t.as_ns() - first.as_ns() > self.lag_ns)
            .count();
        self.history.drain(..num_old);
        self.history_t.drain(..num_old);
        Ok(outcome)
    }

    /// The smoothed positions of the steps within the lag of the newest, oldest first, each
    /// given every measurement so far (empty while there is no per-axis estimate; see the
    /// type's docs). Computed on demand: a caller that steps many times and reads once pays
    /// for one backward pass.
    pub fn smooth(&mut self) -> &[(SessionTime, Point3<f64>)] {
        self.smoothed.clear();
        let (Some(newest), Some(&newest_t)) = (self.history.back(), self.history_t.back()) else {
            return &self.smoothed;
        };
        // Smoothed (position, velocity) per axis, from the newest step back.
        let mut next: [(f64, f64); 3] = std::array::from_fn(|i| {
            let a = newest.posterior[i];
            (a.p, a.v)
        });
        self.smoothed
            .push((newest_t, Point3::new(next[0].0, next[1].0, next[2].0)));
        for k in (0..self.history.len().saturating_sub(1)).rev() {
            let (Some(cur), Some(after), Some(&cur_t)) = (
                self.history.get(k),
                self.history.get(k + 1),
                self.history_t.get(k),
            ) else {
                break;
            };
            for (i, n) in next.iter_mut().enumerate() {
                let (x, prior) = (&cur.posterior[i], &after.prior[i]);
                *n = match cur.gain[i] {
                    Some([c00, c01, c10, c11]) => {
                        let (dp, dv) = (n.0 - prior.p, n.1 - prior.v);
                        (x.p + c00 * dp + c01 * dv, x.v + c10 * dp + c11 * dv)
                    }
                    None => (x.p, x.v),
                };
            }
            self.smoothed
                .push((cur_t, Point3::new(next[0].0, next[1].0, next[2].0)));
        }
        self.smoothed.reverse();
        &self.smoothed
    }
}

/// The RTS gain `C = P Fᵀ (P⁻)⁻¹` on one axis, row-major, from a step's filtered covariance
/// `cur` to the next step's prior `after`, predicted `dt_s` later (`F = [1 dt; 0 1]`); `None`
/// for a singular prior. The smoothed estimate is then `x̂ = x + C (x̂⁺ − x⁻)`.
fn rts_gain(cur: &Axis, after: &Axis, dt_s: f64) -> Option<[f64; 4]> {
    let det = after.pp * after.vv - after.pv * after.pv;
    if !(det.is_finite() && det > 0.0) {
        return None;
    }
    // P Fᵀ.
    let (a00, a01) = (cur.pp + dt_s * cur.pv, cur.pv);
    let (a10, a11) = (cur.pv + dt_s * cur.vv, cur.vv);
    // (P⁻)⁻¹ = [vv −pv; −pv pp] / det.
    let (i00, i01, i11) = (after.vv / det, -after.pv / det, after.pp / det);
    Some([
        a00 * i00 + a01 * i01,
        a00 * i01 + a01 * i11,
        a10 * i00 + a11 * i01,
        a10 * i01 + a11 * i11,
    ])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn white_acceleration_noise_is_symmetric_and_grows_with_dt() {
        let (_, q1) = constant_velocity_model(0.01, 3.0);
        let (_, q2) = constant_velocity_model(0.1, 3.0);
        assert_eq!(q1, q1.transpose());
        assert!(q2[(0, 0)] > q1[(0, 0)] && q2[(3, 3)] > q1[(3, 3)]);
        assert!((q2[(0, 3)] - 3.0 * 0.01 / 2.0).abs() < 1e-15);
    }

    #[test]
    fn nan_measurement_is_treated_as_missing() {
        let mut kf = JointKalman::new(ConstantVelocityConfig::default()).unwrap();
        let r = Matrix3::identity() * 1e-4;
        kf.step(
            SessionTime::from_ns(0),
            Some((&Point3::new(1.0, 2.0, 3.0), &r)),
        )
        .unwrap();
        let out = kf
            .step(
                SessionTime::from_ns(33_000_000),
                Some((&Point3::new(f64::NAN, 2.0, 3.0), &r)),
            )
            .unwrap();
        assert_eq!(out, Some(UpdateOutcome::RejectedAsMissing));
        assert!(kf.position().unwrap().iter().all(|v| v.is_finite()));
        let bad_r = Matrix3::identity() * -1.0;
        assert_eq!(
            kf.update(&Point3::origin(), &bad_r).unwrap(),
            UpdateOutcome::RejectedAsMissing
        );
    }

    #[test]
    fn per_axis_filter_matches_the_six_state_filter() {
        // Irregular steps, missing frames, varying diagonal R; then one full R, after which
        // both run the 6-state algebra.
        let config = ConstantVelocityConfig::default();
        let mut fast = JointKalman::new(config).unwrap();
        let mut full = JointKalman::new_full(config).unwrap();
        let mut t_ns = 0i64;
        for k in 0..300 {
            t_ns += 20_000_000 + (k % 7) * 3_000_000;
            let s = k as f64 * 0.05;
            let z = Point3::new(s.sin(), 0.5 * s.cos(), 1.0 + 0.1 * s);
            let var = if k % 5 == 0 { 4e-4 } else { 1e-4 };
            let mut r = Matrix3::from_diagonal(&Vector3::new(var, 2.0 * var, var));
            if k == 250 {
                r[(0, 1)] = 2e-5;
                r[(1, 0)] = 2e-5;
            }
            let m = (k % 11 != 3).then_some((&z, &r));
            let t = SessionTime::from_ns(t_ns);
            assert_eq!(fast.step(t, m).unwrap(), full.step(t, m).unwrap());
            let (a, b) = (fast.state().unwrap(), full.state().unwrap());
            assert!((a - b).abs().max() < 1e-12, "state differs at step {k}");
            let (pa, pb) = (fast.covariance().unwrap(), full.covariance().unwrap());
            assert!(
                (pa - pb).abs().max() < 1e-12 * pb.abs().max(),
                "covariance differs at step {k}"
            );
            assert_eq!(
                fast.position(),
                Some(Point3::from(a.fixed_rows::<3>(0).into_owned()))
            );
            assert!(matches!(
                (k >= 250, &fast.estimate),
                (true, Some(Estimate::Full(_))) | (false, Some(Estimate::Axes(_)))
            ));
        }
    }

    #[test]
    fn axes_sharing_a_covariance_step_as_each_axis_alone_bit_for_bit() {
        // Isotropic noise (shared covariance, one gain for three axes), missing frames, a
        // larger isotropic R now and then; from step 120 one axis's R differs, which splits
        // the covariances for good. Each axis must match a lone axis stepped with the plain
        // predict and update, bit for bit, as must the smoother's gains.
        let config = ConstantVelocityConfig::default();
        let mut kf = JointSmoother::new(config, 0.3).unwrap();
        let mut lone: Option<[Axis; 3]> = None;
        let mut t_ns = 0i64;
        let mut num_shared = 0;
        for k in 0..200 {
            let dt_ns = 33_333_333 + (k % 3 == 2) as i64;
            t_ns += dt_ns;
            let s = k as f64 * 0.07;
            let z = Point3::new(s.sin(), 0.5 * s.cos(), 1.0 + 0.1 * s);
            let var = if k % 9 == 4 { 9e-4 } else { 1e-4 };
            let mut r = Matrix3::identity() * var;
            if k >= 120 {
                r[(1, 1)] = 2.0 * var;
            }
            let m = (k % 13 != 6).then_some((&z, &r));
            if let Some(axes) = kf.filter().axes() {
                num_shared += share_covariance(&axes) as usize;
            }
            kf.step(SessionTime::from_ns(t_ns), m).unwrap();
            // The reference: each axis on its own.
            let dt = dt_ns as f64 * 1e-9;
            let prior = lone.map(|mut axes| {
                for a in &mut axes {
                    a.predict(dt, config.accel_psd_m2ps3);
                }
                axes
            });
            let mut posterior = prior;
            match (&mut posterior, m) {
                (Some(axes), Some((z, r))) => {
                    for (i, a) in axes.iter_mut().enumerate() {
                        assert!(a.update(z[i], r[(i, i)]));
                    }
                }
                (None, Some((z, r))) => {
                    posterior = Some(std::array::from_fn(|i| Axis {
                        p: z[i],
                        v: 0.0,
                        pp: r[(i, i)],
                        pv: 0.0,
                        vv: config.initial_velocity_std_mps.powi(2),
                    }));
                }
                _ => {}
            }
            let got = kf.filter().axes().unwrap();
            // Debug formatting tells every two bit patterns apart but `NaN`s (none here).
            let want = posterior.unwrap();
            assert_eq!(format!("{got:?}"), format!("{want:?}"), "step {k}");
            if let (Some(before), Some(prior)) = (lone, prior) {
                let want: [Option<[f64; 4]>; 3] =
                    std::array::from_fn(|i| rts_gain(&before[i], &prior[i], dt));
                let n = kf.history.len();
                let gain = kf.history.get(n - 2).map(|step| step.gain).unwrap();
                assert_eq!(format!("{gain:?}"), format!("{want:?}"), "gain at step {k}");
            }
            lone = posterior;
        }
        // The shortcut ran (before the split) and the general path too (after it).
        assert!(
            (100..190).contains(&num_shared),
            "{num_shared} steps shared"
        );
    }

    #[test]
    fn time_going_backwards_is_an_error() {
        let mut kf = JointKalman::new(ConstantVelocityConfig::default()).unwrap();
        kf.step(SessionTime::from_ns(10), None).unwrap();
        assert!(matches!(
            kf.step(SessionTime::from_ns(10), None),
            Err(FilterError::NonIncreasingTime { .. })
        ));
        assert!(kf.predict(f64::NAN).is_err());
        assert!(kf.predict(-1.0).is_err());
    }

    /// A step's time and measurement (position, covariance), if any.
    type Step = (SessionTime, Option<(Point3<f64>, Matrix3<f64>)>);

    /// A batch RTS smoother in the 6-state matrix form, as the reference for `JointSmoother`.
    fn batch_rts(config: ConstantVelocityConfig, steps: &[Step]) -> Vec<Vector6<f64>> {
        let mut kf = JointKalman::new_full(config).unwrap();
        // (dt to this step, prior mean, prior covariance, posterior mean, posterior covariance)
        let mut rows = Vec::new();
        for (t, m) in steps {
            let dt = kf.last_time().map_or(0.0, |last| t.secs_since(last));
            let (f, q) = constant_velocity_model(dt, config.accel_psd_m2ps3);
            let prior = kf
                .state()
                .map(|x| (f * x, f * kf.covariance().unwrap() * f.transpose() + q));
            kf.step(*t, m.as_ref().map(|(z, r)| (z, r))).unwrap();
            if let (Some(x), Some(p)) = (kf.state(), kf.covariance()) {
                rows.push((dt, prior, x, p));
            }
        }
        let mut out = vec![Vector6::zeros(); rows.len()];
        let last = rows.len() - 1;
        out[last] = rows[last].2;
        for k in (0..last).rev() {
            let (dt, prior, _, _) = rows[k + 1];
            let (x_prior, p_prior) = prior.unwrap();
            let (f, _) = constant_velocity_model(dt, config.accel_psd_m2ps3);
            let c = rows[k].3 * f.transpose() * p_prior.try_inverse().unwrap();
            out[k] = rows[k].2 + c * (out[k + 1] - x_prior);
        }
        out
    }

    fn noisy_swing(n: usize) -> Vec<Step> {
        let mut state = 12345u64;
        let mut noise = move || {
            // A small LCG: deterministic noise in ±0.02 m.
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 33) as f64 / (1u64 << 31) as f64 - 0.5) * 0.04
        };
        (0..n)
            .map(|k| {
                let t = k as f64 / 30.0;
                let truth = Point3::new((2.0 * t).sin(), 0.3 * (3.0 * t).cos(), 1.0 + 0.1 * t);
                let z = Point3::new(truth.x + noise(), truth.y + noise(), truth.z + noise());
                let var = if k % 4 == 0 { 9e-4 } else { 1e-4 };
                let m = (k % 13 != 5).then_some((z, Matrix3::identity() * var));
                (SessionTime::from_ns((k as i64) * 33_333_333), m)
            })
            .collect()
    }

    #[test]
    fn a_usable_covariance_is_finite_symmetric_and_positive_on_its_diagonal() {
        // The definition, checked entry by entry, against the shortcut for diagonal ones.
        let reference = |r: &Matrix3<f64>| {
            r.iter().all(|v| v.is_finite())
                && (0..3).all(|i| r[(i, i)] > 0.0)
                && (r - r.transpose()).abs().max() <= 1e-9 * (1.0 + r.abs().max())
        };
        let mut cases = Vec::new();
        for bad in [0.0, -1e-4, f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 1e-4] {
            for i in 0..3 {
                let mut r = Matrix3::identity() * 1e-4;
                r[(i, i)] = bad;
                cases.push(r);
                let mut off = Matrix3::identity() * 1e-4;
                off[(i, (i + 1) % 3)] = bad;
                cases.push(off);
                let mut symmetric = off;
                symmetric[((i + 1) % 3, i)] = bad;
                cases.push(symmetric);
            }
        }
        let (mut num_usable, mut num_not) = (0, 0);
        for r in &cases {
            assert_eq!(is_usable_covariance(r), reference(r), "{r}");
            if reference(r) {
                num_usable += 1;
            } else {
                num_not += 1;
            }
        }
        assert!(num_usable > 0 && num_not > 0);
    }

    #[test]
    fn the_smoothers_filter_steps_exactly_as_the_filter_alone() {
        // Measurements, gaps, a NaN, an unusable and a full covariance, a repeated time and a
        // time going back: the smoother's filter (which takes a per-axis shortcut) must give
        // the filter's own outcomes, errors and estimates, bit for bit.
        let mut steps = noisy_swing(60);
        if let Some((_, m)) = steps.get_mut(7) {
            *m = Some((Point3::new(f64::NAN, 0.0, 1.0), Matrix3::identity() * 1e-4));
        }
        if let Some((_, m)) = steps.get_mut(11) {
            *m = Some((Point3::new(0.1, 0.0, 1.0), Matrix3::identity() * -1.0));
        }
        let repeat = steps[20].0;
        steps.insert(21, (repeat, None));
        steps.insert(30, (SessionTime::from_ns(0), None));
        if let Some((_, m)) = steps.get_mut(45) {
            let mut r = Matrix3::identity() * 1e-4;
            r[(0, 1)] = 2e-5;
            r[(1, 0)] = 2e-5;
            *m = Some((Point3::new(0.9, 0.1, 1.1), r));
        }
        let config = ConstantVelocityConfig::default();
        let mut alone = JointKalman::new(config).unwrap();
        let mut smoother = JointSmoother::new(config, 0.2).unwrap();
        let bits = |kf: &JointKalman| -> Option<Vec<u64>> {
            let (x, p) = (kf.state()?, kf.covariance()?);
            Some(x.iter().chain(p.iter()).map(|v| v.to_bits()).collect())
        };
        let (mut num_errors, mut num_full) = (0, 0);
        for (t, m) in &steps {
            let m = m.as_ref().map(|(z, r)| (z, r));
            let a = alone.step(*t, m);
            let b = smoother.step(*t, m);
            assert_eq!(format!("{a:?}"), format!("{b:?}"), "at {t:?}");
            assert_eq!(bits(&alone), bits(smoother.filter()), "at {t:?}");
            assert_eq!(alone.last_time(), smoother.filter().last_time());
            num_errors += usize::from(a.is_err());
            num_full += usize::from(alone.axes().is_none());
        }
        assert_eq!(num_errors, 2);
        assert!(num_full > 0, "the full covariance switched the form");
    }

    #[test]
    fn fixed_lag_smoother_over_the_whole_run_equals_batch_rts() {
        let config = ConstantVelocityConfig::default();
        let steps = noisy_swing(120);
        let mut smoother = JointSmoother::new(config, 10.0).unwrap();
        for (t, m) in &steps {
            smoother.step(*t, m.as_ref().map(|(z, r)| (z, r))).unwrap();
        }
        let reference = batch_rts(config, &steps);
        let newest = smoother.filter().position().unwrap();
        let got = smoother.smooth().to_vec();
        assert_eq!(got.len(), reference.len());
        for (k, ((_, p), x)) in got.iter().zip(&reference).enumerate() {
            let err = (p.coords - x.fixed_rows::<3>(0)).abs().max();
            assert!(err < 1e-9, "step {k}: smoothed position off by {err}");
        }
        // The newest step's smoothed position is the filter's.
        assert!((got.last().unwrap().1 - newest).norm() < 1e-12);
    }

    #[test]
    fn fixed_lag_smoother_removes_the_filters_delay() {
        // A joint swinging at 1 Hz, measured exactly at 30 Hz (the filter told 1 cm noise): the
        // filter's estimate trails the swing (8.8 mm RMS); the estimate 0.3 s behind the newest,
        // smoothed, does not (1.1 mm).
        let config = ConstantVelocityConfig {
            accel_psd_m2ps3: 1.0,
            ..ConstantVelocityConfig::default()
        };
        let truth = |k: i64| (std::f64::consts::TAU * k as f64 / 30.0).sin() * 0.3;
        let mut smoother = JointSmoother::new(config, 0.3).unwrap();
        let r = Matrix3::identity() * 1e-4;
        let (mut filtered_sq, mut smoothed_sq, mut n) = (0.0, 0.0, 0);
        for k in 0..600i64 {
            let z = Point3::new(truth(k), 0.0, 0.0);
            let t = SessionTime::from_ns(k * 33_333_333);
            smoother.step(t, Some((&z, &r))).unwrap();
            if k >= 60 {
                let filtered = smoother.filter().position().unwrap().x;
                filtered_sq += (filtered - truth(k)).powi(2);
                let (t_old, p_old) = smoother.smooth()[0];
                let k_old = (t_old.as_ns() + 1) / 33_333_333;
                assert_eq!(k - k_old, 9, "the oldest smoothed step lies 0.3 s back");
                smoothed_sq += (p_old.x - truth(k_old)).powi(2);
                n += 1;
            }
        }
        let filtered_rms = (filtered_sq / n as f64).sqrt();
        let smoothed_rms = (smoothed_sq / n as f64).sqrt();
        assert!(
            smoothed_rms < 0.25 * filtered_rms,
            "smoothed {smoothed_rms} m against filtered {filtered_rms} m"
        );
    }

    #[test]
    fn smoother_refuses_a_bad_lag_and_stays_empty_without_measurements() {
        assert!(JointSmoother::new(ConstantVelocityConfig::default(), -1.0).is_err());
        assert!(JointSmoother::new(ConstantVelocityConfig::default(), f64::NAN).is_err());
        let mut s = JointSmoother::new(ConstantVelocityConfig::default(), 0.5).unwrap();
        s.step(SessionTime::from_ns(0), None).unwrap();
        assert!(s.smooth().is_empty());
        let r = Matrix3::identity() * 1e-4;
        s.step(SessionTime::from_ns(10), Some((&Point3::origin(), &r)))
            .unwrap();
        assert_eq!(s.smooth().len(), 1);
        assert!(s.step(SessionTime::from_ns(10), None).is_err());
        assert_eq!(s.smooth().len(), 1, "a refused step changes nothing");
    }
}
