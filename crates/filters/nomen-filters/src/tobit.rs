//! Tobit Kalman filter for censored measurements (Allik, Miller, Piovoso & Zarchan, "The Tobit
//! Kalman Filter: An Estimator for Censored Measurements", IEEE Trans. Control Systems
//! Technology 24(1), 2016), as Belmonte-Hernández et al. use it for skeleton joints that the
//! camera clips at the image border or at its depth limit.
//!
//! # Model
//!
//! Linear dynamics `x_k = F x_{k-1} + w_k`, `w ~ N(0, Q)`, and a latent measurement
//! `y*_k = H x_k + v_k`, `v ~ N(0, R)` with **diagonal** `R = diag(σ_i²)`. What arrives is the
//! Tobit (type-1) censored value, component by component:
//!
//! ```text
//! y_i = a_i      if y*_i ≤ a_i      (lower censoring limit)
//! y_i = y*_i     if a_i < y*_i < b_i
//! y_i = b_i      if y*_i ≥ b_i      (upper censoring limit)
//! ```
//!
//! A limit may be infinite (no censoring on that side). The filter does not need to be told
//! which samples were censored: the update below weighs every component by the probability that
//! it was *not* censored, given the prediction.
//!
//! # Equations
//!
//! The paper's prediction is the ordinary Kalman prediction (its eqs. for `x̂_{k|k-1}` and
//! `P_{k|k-1}`). Its Tobit update, written per measurement component `i` with `ŷ = H x̂_{k|k-1}`,
//! `φ`/`Φ` the standard normal pdf/cdf (the paper's Section III; the equation numbers there run
//! roughly from the censoring probabilities to the covariance update — we name each quantity as the
//! paper does instead of quoting numbers we could not re-check here):
//!
//! ```text
//! α_i = (a_i − ŷ_i) / σ_i,   β_i = (b_i − ŷ_i) / σ_i                  standardised limits
//! P_unc = diag(Φ(β_i) − Φ(α_i))                                       probability of no censoring
//! λ_i = (φ(α_i) − φ(β_i)) / (Φ(β_i) − Φ(α_i))                         inverse Mills ratio
//! E[y_i] = P_unc,i (ŷ_i + σ_i λ_i) + Φ(α_i) a_i + (1 − Φ(β_i)) b_i    expected censored measurement
//! R_tt,i = σ_i² [1 + (α_i φ(α_i) − β_i φ(β_i)) / (Φ(β_i) − Φ(α_i)) − λ_i²]   truncated variance
//! P_xy = P_{k|k-1} Hᵀ P_unc                                           state–measurement covariance
//! P_yy = P_unc H P_{k|k-1} Hᵀ P_unc + diag(R_tt)                      measurement covariance
//! K = P_xy P_yy⁻¹                                                     Tobit Kalman gain
//! x̂_{k|k} = x̂_{k|k-1} + K (y − E[y])
//! P_{k|k} = (I − K P_unc H) P_{k|k-1}
//! ```
//!
//! With both limits infinite, `P_unc = I`, `λ = 0`, `R_tt = R`, `E[y] = ŷ`: the ordinary Kalman
//! filter. Numerical guards (ours, not the paper's): a component whose uncensored probability is
//! below 1e-12 contributes nothing (`P_unc,i = 0`, `λ_i = 0`); `R_tt,i` is kept ≥ 1e-12·σ_i²;
//! `P_{k|k}` is re-symmetrised.

use crate::error::{FilterError, Result, check_positive};
use crate::kalman::{ConstantVelocityConfig, UpdateOutcome, constant_velocity_model};
use nalgebra::{Cholesky, Point3, SMatrix, SVector, Vector3};
use nomen_core::SessionTime;

/// Standard normal probability density.
pub fn normal_pdf(x: f64) -> f64 {
    if x.is_infinite() {
        return 0.0;
    }
    (-0.5 * x * x).exp() / (2.0 * std::f64::consts::PI).sqrt()
}

/// Standard normal cumulative distribution, accurate in both tails (`erfc`-based).
pub fn normal_cdf(x: f64) -> f64 {
    0.5 * libm::erfc(-x / std::f64::consts::SQRT_2)
}

/// `x · φ(x)`, taken as 0 at ±∞.
fn x_pdf(x: f64) -> f64 {
    if x.is_infinite() {
        0.0
    } else {
        x * normal_pdf(x)
    }
}

/// Lower and upper censoring limits per measurement component (use ±∞ for "not censored").
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CensoringLimits<const M: usize> {
    /// Lower limits `a`.
    pub lower: SVector<f64, M>,
    /// Upper limits `b`.
    pub upper: SVector<f64, M>,
}

impl<const M: usize> CensoringLimits<M> {
    /// No censoring at all (the filter reduces to the Kalman filter).
    pub fn none() -> Self {
        Self {
            lower: SVector::repeat(f64::NEG_INFINITY),
            upper: SVector::repeat(f64::INFINITY),
        }
    }

    fn validate(&self) -> Result<()> {
        for i in 0..M {
            let (a, b) = (self.lower[i], self.upper[i]);
            if a.is_nan() || b.is_nan() || a >= b {
                return Err(FilterError::InvalidParameter {
                    name: "censoring limits",
                    reason: format!("component {i}: need lower < upper, got {a} and {b}"),
                });
            }
        }
        Ok(())
    }
}

/// Tobit Kalman filter with `N` states and `M` measurement components.
#[derive(Debug, Clone, PartialEq)]
pub struct TobitKalman<const N: usize, const M: usize> {
    x: SVector<f64, N>,
    p: SMatrix<f64, N, N>,
}

impl<const N: usize, const M: usize> TobitKalman<N, M> {
    /// A filter starting at state `x0` with covariance `p0` (finite, symmetric).
    pub fn new(x0: SVector<f64, N>, p0: SMatrix<f64, N, N>) -> Result<Self> {
        if let Some(index) = x0.iter().chain(p0.iter()).position(|v| !v.is_finite()) {
            return Err(FilterError::NonFinite {
                what: "tobit initial state or covariance",
                index,
            });
        }
        Ok(Self { x: x0, p: p0 })
    }

    /// State estimate.
    pub fn state(&self) -> &SVector<f64, N> {
        &self.x
    }

    /// State covariance.
    pub fn covariance(&self) -> &SMatrix<f64, N, N> {
        &self.p
    }

    /// Kalman prediction `x ← F x`, `P ← F P Fᵀ + Q`.
    pub fn predict(&mut self, f: &SMatrix<f64, N, N>, q: &SMatrix<f64, N, N>) -> Result<()> {
        if !f.iter().chain(q.iter()).all(|v| v.is_finite()) {
            return Err(FilterError::NonFinite {
                what: "tobit transition or process noise",
                index: 0,
            });
        }
        self.x = f * self.x;
        self.p = f * self.p * f.transpose() + q;
        Ok(())
    }

    /// Tobit update (see the module docs) with the received, possibly censored measurement `y`,
    /// observation matrix `h`, measurement variances `r_diag` (σ_i², > 0) and the censoring
    /// limits. A non-finite `y` is treated as missing (no update).
    pub fn update(
        &mut self,
        y: &SVector<f64, M>,
        h: &SMatrix<f64, M, N>,
        r_diag: &SVector<f64, M>,
        limits: &CensoringLimits<M>,
    ) -> Result<UpdateOutcome> {
        limits.validate()?;
        for i in 0..M {
            check_positive("r_diag", r_diag[i])?;
        }
        if !y.iter().all(|v| v.is_finite()) {
            return Ok(UpdateOutcome::RejectedAsMissing);
        }
        let y_pred = h * self.x;
        let mut p_unc = SVector::<f64, M>::zeros();
        let mut expected_y = SVector::<f64, M>::zeros();
        let mut r_tt = SVector::<f64, M>::zeros();
        for i in 0..M {
            let sigma = r_diag[i].sqrt();
            let (a, b) = (limits.lower[i], limits.upper[i]);
            let alpha = (a - y_pred[i]) / sigma;
            let beta = (b - y_pred[i]) / sigma;
            let (cdf_a, cdf_b) = (normal_cdf(alpha), normal_cdf(beta));
            let prob = cdf_b - cdf_a;
            // Censored mass times the limit; 0 · ∞ is 0 when that side is not censored.
            let lower_mass = if cdf_a > 0.0 { cdf_a * a } else { 0.0 };
            let upper_mass = if cdf_b < 1.0 { (1.0 - cdf_b) * b } else { 0.0 };
            if prob < 1e-12 {
                p_unc[i] = 0.0;
                expected_y[i] = lower_mass + upper_mass;
                r_tt[i] = r_diag[i];
                continue;
            }
            let lambda = (normal_pdf(alpha) - normal_pdf(beta)) / prob;
            p_unc[i] = prob;
            expected_y[i] = prob * (y_pred[i] + sigma * lambda) + lower_mass + upper_mass;
            let ratio = 1.0 + (x_pdf(alpha) - x_pdf(beta)) / prob - lambda * lambda;
            r_tt[i] = r_diag[i] * ratio.max(1e-12);
        }
        let p_unc_h = SMatrix::<f64, M, M>::from_diagonal(&p_unc) * h;
        let p_xy = self.p * p_unc_h.transpose();
        let p_yy = p_unc_h * p_xy + SMatrix::<f64, M, M>::from_diagonal(&r_tt);
        let chol =
            Cholesky::new(p_yy).ok_or(FilterError::Numerical("tobit innovation covariance"))?;
        let k_gain = p_xy * chol.inverse();
        self.x += k_gain * (y - expected_y);
        let p = (SMatrix::<f64, N, N>::identity() - k_gain * p_unc_h) * self.p;
        self.p = (p + p.transpose()) * 0.5;
        Ok(UpdateOutcome::Applied)
    }
}

/// Constant-velocity Tobit Kalman filter for one 3D joint (the Tobit counterpart of
/// [`crate::kalman::JointKalman`]: same state, same white-acceleration model).
#[derive(Debug, Clone, PartialEq)]
pub struct TobitJointKalman {
    config: ConstantVelocityConfig,
    filter: Option<TobitKalman<6, 3>>,
    last_t: Option<SessionTime>,
}

impl TobitJointKalman {
    /// A filter with no estimate; the first finite measurement initialises it.
    pub fn new(config: ConstantVelocityConfig) -> Result<Self> {
        check_positive("accel_psd_m2ps3", config.accel_psd_m2ps3)?;
        check_positive("initial_velocity_std_mps", config.initial_velocity_std_mps)?;
        Ok(Self {
            config,
            filter: None,
            last_t: None,
        })
    }

    /// Position estimate, if initialised.
    pub fn position(&self) -> Option<Point3<f64>> {
        self.filter
            .as_ref()
            .map(|f| Point3::from(f.state().fixed_rows::<3>(0).into_owned()))
    }

    /// Velocity estimate, if initialised.
    pub fn velocity(&self) -> Option<Vector3<f64>> {
        self.filter
            .as_ref()
            .map(|f| f.state().fixed_rows::<3>(3).into_owned())
    }

    /// Zero-latency step at `t`: predict from the previous step, then a Tobit update with the
    /// received position `z` (variances `r_diag_m2`, limits per axis) if there is one.
    pub fn step(
        &mut self,
        t: SessionTime,
        measurement: Option<(&Point3<f64>, &Vector3<f64>, &CensoringLimits<3>)>,
    ) -> Result<Option<UpdateOutcome>> {
        if let Some(last) = self.last_t {
            if t <= last {
                return Err(FilterError::NonIncreasingTime {
                    index: 0,
                    previous_ns: last.as_ns(),
                    current_ns: t.as_ns(),
                });
            }
            if let Some(filter) = &mut self.filter {
                let (f, q) =
                    constant_velocity_model(t.secs_since(last), self.config.accel_psd_m2ps3);
                filter.predict(&f, &q)?;
            }
        }
        self.last_t = Some(t);
        let Some((z, r_diag, limits)) = measurement else {
            return Ok(None);
        };
        let h = crate::kalman::position_observation();
        match &mut self.filter {
            Some(filter) => filter.update(&z.coords, &h, r_diag, limits).map(Some),
            None => {
                if !z.iter().chain(r_diag.iter()).all(|v| v.is_finite()) {
                    return Ok(Some(UpdateOutcome::RejectedAsMissing));
                }
                let mut x0 = SVector::<f64, 6>::zeros();
                x0.fixed_rows_mut::<3>(0).copy_from(&z.coords);
                let mut p0 = SMatrix::<f64, 6, 6>::zeros();
                let v2 = self.config.initial_velocity_std_mps.powi(2);
                for i in 0..3 {
                    p0[(i, i)] = r_diag[i];
                    p0[(i + 3, i + 3)] = v2;
                }
                self.filter = Some(TobitKalman::new(x0, p0)?);
                Ok(Some(UpdateOutcome::Initialized))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_cdf_matches_known_values() {
        assert!((normal_cdf(0.0) - 0.5).abs() < 1e-16);
        assert!((normal_cdf(1.959_963_984_540_054) - 0.975).abs() < 1e-15);
        assert!(normal_cdf(-40.0) >= 0.0 && normal_cdf(-40.0) < 1e-300);
        assert_eq!(normal_cdf(f64::INFINITY), 1.0);
        assert_eq!(normal_cdf(f64::NEG_INFINITY), 0.0);
    }

    #[test]
    fn censored_measurement_beyond_the_limit_barely_moves_a_prediction_beyond_it() {
        // Prediction 1.5 m beyond a 1.0 m limit; the camera reports the limit. A plain Kalman
        // update would pull the estimate to ~1.0; the Tobit update knows the value is only a bound.
        let mut tkf =
            TobitKalman::<1, 1>::new(SVector::<f64, 1>::new(1.5), SMatrix::<f64, 1, 1>::new(0.01))
                .unwrap();
        let limits = CensoringLimits {
            lower: SVector::<f64, 1>::new(f64::NEG_INFINITY),
            upper: SVector::<f64, 1>::new(1.0),
        };
        let h = SMatrix::<f64, 1, 1>::new(1.0);
        let r = SVector::<f64, 1>::new(0.01);
        tkf.update(&SVector::<f64, 1>::new(1.0), &h, &r, &limits)
            .unwrap();
        assert!((tkf.state()[0] - 1.5).abs() < 1e-3, "{}", tkf.state()[0]);
    }

    #[test]
    fn inverted_limits_are_rejected_and_nan_is_missing() {
        let mut tkf =
            TobitKalman::<1, 1>::new(SVector::<f64, 1>::zeros(), SMatrix::<f64, 1, 1>::new(1.0))
                .unwrap();
        let h = SMatrix::<f64, 1, 1>::new(1.0);
        let r = SVector::<f64, 1>::new(0.01);
        let bad = CensoringLimits {
            lower: SVector::<f64, 1>::new(1.0),
            upper: SVector::<f64, 1>::new(0.0),
        };
        assert!(
            tkf.update(&SVector::<f64, 1>::new(0.5), &h, &r, &bad)
                .is_err()
        );
        let out = tkf
            .update(
                &SVector::<f64, 1>::new(f64::NAN),
                &h,
                &r,
                &CensoringLimits::none(),
            )
            .unwrap();
        assert_eq!(out, UpdateOutcome::RejectedAsMissing);
        assert_eq!(tkf.state()[0], 0.0);
    }
}
