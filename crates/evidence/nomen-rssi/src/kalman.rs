//! A Kalman filter per (tag, antenna) RSSI stream with a constant-variation state: the RSSI and
//! its rate of change, `x = [P dBm, Ṗ dB/s]`.
//!
//! Prediction over `dt` (continuous white-noise "acceleration" of the RSSI, Bar-Shalom, Li &
//! Kirubarajan, *Estimation with Applications to Tracking and Navigation*, §6.2.2):
//!
//! ```text
//! F = [1 dt; 0 1],   Q = q · [dt³/3  dt²/2; dt²/2  dt]
//! ```
//!
//! with `q` in dB²/s³; the measurement is `z = P + v`, `v ~ N(0, R)` with `R` the antenna's
//! calibrated residual variance. A missed read is just no update: the state is predicted to the
//! next read or query. After [`RssiKalmanConfig::reset_after_s`] without a read the filter
//! forgets (a tag that went quiet and comes back starts fresh) and reports no estimate.
//! The predict/update algebra is `adskalman` (Joseph form), as in `nomen-filters`.

use crate::error::{Result, RssiError};
use adskalman::{
    CovarianceUpdateMethod, ObservationModel, StateAndCovariance, TransitionModelLinearNoControl,
};
use nalgebra::{Matrix1, Matrix1x2, Matrix2, Matrix2x1, Vector1, Vector2};
use nomen_core::SessionTime;
use serde::{Deserialize, Serialize};

/// Settings of [`RssiKalman`]. Plain data, loadable from TOML.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RssiKalmanConfig {
    /// Power spectral density of the RSSI's rate changes, dB²/s³. Default 16: a walker at
    /// 1.4 m/s passing 1–3 m from an antenna (K ≈ 20 dB/decade) changes the mean RSSI at up to
    /// ~5 dB/s and turns that rate around within ~1–2 s (≈ 4 dB/s² ⇒ q ≈ 4²·1 s). An
    /// engineering assumption, not fitted.
    pub rate_psd_db2ps3: f64,
    /// Standard deviation of the initial rate, dB/s. Default 5 dB/s (same reasoning).
    pub initial_rate_std_dbps: f64,
    /// After this long without a read, the filter resets, s. Default 2 s: twenty missed polls at
    /// 10 Hz; the prediction has lost the walker by then.
    pub reset_after_s: f64,
}

impl Default for RssiKalmanConfig {
    fn default() -> Self {
        Self {
            rate_psd_db2ps3: 16.0,
            initial_rate_std_dbps: 5.0,
            reset_after_s: 2.0,
        }
    }
}

impl RssiKalmanConfig {
    /// Checks every field.
    pub fn validate(&self) -> Result<()> {
        let ok = [
            self.rate_psd_db2ps3,
            self.initial_rate_std_dbps,
            self.reset_after_s,
        ]
        .iter()
        .all(|v| v.is_finite() && *v > 0.0);
        if ok {
            Ok(())
        } else {
            Err(RssiError::InvalidConfig(format!(
                "rssi kalman: every value must be positive and finite: {self:?}"
            )))
        }
    }
}

/// The filtered RSSI at some time: mean and variance of the RSSI component.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RssiEstimate {
    /// Filtered RSSI, dBm.
    pub rssi_dbm: f64,
    /// Its variance, dB².
    pub variance_db2: f64,
    /// Filtered rate, dB/s.
    pub rate_dbps: f64,
    /// Time since the last read, s.
    pub age_s: f64,
}

struct Transition {
    f: Matrix2<f64>,
    ft: Matrix2<f64>,
    q: Matrix2<f64>,
}

impl TransitionModelLinearNoControl<f64, nalgebra::U2> for Transition {
    fn F(&self) -> &Matrix2<f64> {
        &self.f
    }
    fn FT(&self) -> &Matrix2<f64> {
        &self.ft
    }
    fn Q(&self) -> &Matrix2<f64> {
        &self.q
    }
}

struct Observation {
    h: Matrix1x2<f64>,
    ht: Matrix2x1<f64>,
    r: Matrix1<f64>,
}

impl ObservationModel<f64, nalgebra::U2, nalgebra::U1> for Observation {
    fn H(&self) -> &Matrix1x2<f64> {
        &self.h
    }
    fn HT(&self) -> &Matrix2x1<f64> {
        &self.ht
    }
    fn R(&self) -> &Matrix1<f64> {
        &self.r
    }
}

fn transition(dt_s: f64, q: f64) -> Transition {
    let f = Matrix2::new(1.0, dt_s, 0.0, 1.0);
    let q = q * Matrix2::new(
        dt_s.powi(3) / 3.0,
        dt_s * dt_s / 2.0,
        dt_s * dt_s / 2.0,
        dt_s,
    );
    Transition {
        f,
        ft: f.transpose(),
        q,
    }
}

/// The constant-variation RSSI filter of one (tag, antenna) stream.
#[derive(Debug, Clone)]
pub struct RssiKalman {
    config: RssiKalmanConfig,
    estimate: Option<StateAndCovariance<f64, nalgebra::U2>>,
    last_t: Option<SessionTime>,
    num_updates: u64,
}

impl RssiKalman {
    /// A filter with no estimate; the first read initialises it.
    pub fn new(config: RssiKalmanConfig) -> Result<Self> {
        config.validate()?;
        Ok(Self {
            config,
            estimate: None,
            last_t: None,
            num_updates: 0,
        })
    }

    /// Time of the last read, if any since the last reset.
    pub fn last_read(&self) -> Option<SessionTime> {
        self.last_t
    }

    /// Reads applied since the last reset.
    pub fn num_updates(&self) -> u64 {
        self.num_updates
    }

    /// Forgets the estimate.
    pub fn reset(&mut self) {
        self.estimate = None;
        self.last_t = None;
        self.num_updates = 0;
    }

    /// Applies a read `rssi_dbm` with variance `variance_db2` at `t`. A read older than the last
    /// one is ignored (returns `false`); a silence longer than `reset_after_s` resets the filter
    /// first. Non-finite values or a non-positive variance are ignored as missing data.
    pub fn update(&mut self, t: SessionTime, rssi_dbm: f64, variance_db2: f64) -> Result<bool> {
        if !(rssi_dbm.is_finite() && variance_db2.is_finite() && variance_db2 > 0.0) {
            return Ok(false);
        }
        if let Some(last) = self.last_t {
            if t < last {
                return Ok(false);
            }
            if t.secs_since(last) > self.config.reset_after_s {
                self.reset();
            }
        }
        let Some(prior) = &self.estimate else {
            let v = self.config.initial_rate_std_dbps.powi(2);
            self.estimate = Some(StateAndCovariance::new(
                Vector2::new(rssi_dbm, 0.0),
                Matrix2::new(variance_db2, 0.0, 0.0, v),
            ));
            self.last_t = Some(t);
            self.num_updates = 1;
            return Ok(true);
        };
        let dt = self.last_t.map_or(0.0, |last| t.secs_since(last));
        let predicted = transition(dt, self.config.rate_psd_db2ps3).predict(prior);
        let h = Matrix1x2::new(1.0, 0.0);
        let obs = Observation {
            h,
            ht: h.transpose(),
            r: Matrix1::new(variance_db2),
        };
        let posterior = obs
            .update(
                &predicted,
                &Vector1::new(rssi_dbm),
                CovarianceUpdateMethod::JosephForm,
            )
            .map_err(|e| RssiError::Numerical(format!("rssi kalman update: {e:?}")))?;
        self.estimate = Some(posterior);
        self.last_t = Some(t);
        self.num_updates += 1;
        Ok(true)
    }

    /// The estimate predicted to `t` (predict only; the filter is not changed). `None` before
    /// the first read, after a silence longer than `reset_after_s`, or for `t` before the last
    /// read by more than that.
    pub fn estimate_at(&self, t: SessionTime) -> Option<RssiEstimate> {
        let (estimate, last) = (self.estimate.as_ref()?, self.last_t?);
        let age = t.secs_since(last);
        if age.abs() > self.config.reset_after_s {
            return None;
        }
        // Never predict backwards: a query just before the last read uses the last estimate.
        let predicted = transition(age.max(0.0), self.config.rate_psd_db2ps3).predict(estimate);
        let x = predicted.state();
        let p = predicted.covariance();
        Some(RssiEstimate {
            rssi_dbm: x[0],
            variance_db2: p[(0, 0)],
            rate_dbps: x[1],
            age_s: age.max(0.0),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};

    fn t(s: f64) -> SessionTime {
        SessionTime::from_secs_f64(s).unwrap_or_default()
    }

    #[test]
    fn filter_tracks_a_ramp_and_shrinks_the_noise() {
        let mut k = RssiKalman::new(RssiKalmanConfig::default()).unwrap_or_else(|e| panic!("{e}"));
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let noise = Normal::new(0.0, 6.0).unwrap_or_else(|_| unreachable!());
        let mut sq_err = 0.0;
        let mut n = 0;
        let mut rate_sum = 0.0;
        for i in 0..200 {
            let ts = i as f64 * 0.1;
            let truth = -60.0 + 2.0 * ts;
            let _ = k.update(t(ts), truth + noise.sample(&mut rng), 36.0);
            if i >= 50 {
                let e = k
                    .estimate_at(t(ts))
                    .map_or(f64::NAN, |e| e.rssi_dbm - truth);
                sq_err += e * e;
                n += 1;
                rate_sum += k.estimate_at(t(ts)).map_or(f64::NAN, |e| e.rate_dbps);
            }
        }
        let rmse = (sq_err / n as f64).sqrt();
        assert!(rmse < 3.0, "filtered RMSE {rmse} dB vs 6 dB raw");
        // The rate of one step is noisy (6 dB reads); its mean over the run is not.
        let rate = rate_sum / n as f64;
        assert!((rate - 2.0).abs() < 0.5, "mean rate {rate}");
    }

    #[test]
    fn missed_reads_predict_and_a_long_silence_resets() {
        let mut k = RssiKalman::new(RssiKalmanConfig::default()).unwrap_or_else(|e| panic!("{e}"));
        for i in 0..20 {
            let _ = k.update(t(i as f64 * 0.1), -60.0, 25.0);
        }
        let fresh = k.estimate_at(t(1.9)).map_or(f64::NAN, |e| e.variance_db2);
        let stale = k.estimate_at(t(3.0)).map_or(f64::NAN, |e| e.variance_db2);
        assert!(stale > fresh, "prediction must widen: {fresh} → {stale}");
        assert!(
            k.estimate_at(t(4.0)).is_none(),
            "2.1 s of silence: no estimate"
        );
        // A read after the silence starts over at the new value.
        assert_eq!(k.update(t(5.0), -80.0, 25.0).ok(), Some(true));
        assert_eq!(k.num_updates(), 1);
        let e = k.estimate_at(t(5.0)).map_or(f64::NAN, |e| e.rssi_dbm);
        assert!((e + 80.0).abs() < 1e-9);
        // NaN and old reads are ignored.
        assert_eq!(k.update(t(5.1), f64::NAN, 25.0).ok(), Some(false));
        assert_eq!(k.update(t(4.9), -70.0, 25.0).ok(), Some(false));
    }
}
