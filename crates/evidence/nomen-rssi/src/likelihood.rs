//! How well a person's position explains a tag's filtered RSSI.
//!
//! # Which space
//!
//! Llorca inverts each antenna's model to an RSSI-implied distance and scores the skeleton's
//! distance under a Gaussian around it. nomen scores in the **RSSI domain** instead: the
//! filtered RSSI at each antenna under the model's prediction at the person's position,
//!
//! ```text
//! ln L_a(x) = ln N(r̂_a; μ_a(x), P_a + σ_m²)
//! ```
//!
//! with `μ_a(x)` the antenna model at the tag position implied by the skeleton, `P_a` the
//! Kalman variance of the filtered RSSI `r̂_a` and `σ_m` a model-error term. Reasons: the
//! shadowing is Gaussian in dB, so a Gaussian in distance is mis-specified (the implied distance
//! is log-normal, its error grows with the distance); the directional model cannot be inverted
//! without the angle, which itself comes from the candidate position; and the RSSI domain keeps
//! the calibrated σ²(D, θ) meaningful. The per-read σ² is not used directly: the filter has
//! already averaged the reads (its variance `P_a` is computed with `R = σ²(D, θ)` at ingest),
//! and what the average cannot remove — a different tag's gain, a body in the way, slow
//! shadowing — is `σ_m` ([`LikelihoodConfig::model_error_std_db`]).
//!
//! Antennas multiply (independent shadowing per antenna): log-likelihoods add.
//!
//! # An antenna that does not hear the tag
//!
//! Llorca gives such an antenna probability zero (in a product that would veto every person;
//! in Llorca's sum of per-antenna probabilities it contributes nothing). nomen treats silence as
//! what it is, a **censored** read ([`NotHeard::Censored`], the default): the tag is either below
//! the antenna's sensitivity at that position, or the polls were missed,
//!
//! ```text
//! P(silent | x) = m + (1 − m) · Φ((S_a − μ_a(x)) / s_a)
//! ```
//!
//! with `S_a` the weakest read the antenna produced in calibration and `m` the probability that
//! a tag in range goes unheard for the whole silence window. Silence thus counts against people
//! close to the antenna and is neutral for people far from it. [`NotHeard::Ignore`] gives the
//! antenna no weight (Llorca's behaviour in log space).
//!
//! # Scores in `0..=1`
//!
//! A log-likelihood is not comparable across tags. The **background** hypothesis — the tag is
//! somewhere in the calibrated area, not on this skeleton — scores the same RSSI under the
//! spread of all calibration reads (`N(r̂; mean, std² + P)` per antenna; silence under the same
//! censoring). [`pair_score`] is `L / (L + L_bg)`, and [`posterior`] normalises over the
//! candidates of one frame plus the background.

use crate::error::{Result, RssiError};
use crate::kalman::RssiEstimate;
use crate::model::{AntennaModel, RssiModel};
use nalgebra::Point3;
use serde::{Deserialize, Serialize};

const LN_2PI: f64 = 1.837_877_066_409_345_3;

/// What an antenna without a current estimate of the tag contributes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NotHeard {
    /// A censored read: evidence against positions where the antenna should have heard it.
    #[default]
    Censored,
    /// No information (log-likelihood 0).
    Ignore,
}

/// Settings of the likelihood. Plain data, loadable from TOML.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LikelihoodConfig {
    /// Treatment of antennas that do not hear the tag.
    pub not_heard: NotHeard,
    /// Probability that a tag the antenna could hear goes unheard for a whole silence window
    /// (see the module docs). Default 0.05: at Kolakowski's ≈ 90 % read rate a 2 s window at
    /// 10 Hz is all-missed with probability 1e-20, but readers drop tags for other reasons
    /// (collisions, a person shielding it); an assumption.
    pub miss_probability: f64,
    /// Model error not averaged away by the filter, dB. Default 4.5 dB ≈ √(3² + 3.5²): about
    /// 3 dB of body attenuation and slow shadowing (several dB in the literature), plus the
    /// gain of *another* tag than the calibrated one, which one-tag calibration cannot measure:
    /// taken as the 3.5 dB spread of per-anchor P1 in Kolakowski's BLE fit (the same figure the
    /// simulator draws per-(tag, antenna) offsets with). With 3 dB, a second tag whose gain
    /// differs by a few dB never beat the background in the two-tag crosswalk scenes. An
    /// assumption; a per-site calibration with several tags should replace it.
    pub model_error_std_db: f64,
}

impl Default for LikelihoodConfig {
    fn default() -> Self {
        Self {
            not_heard: NotHeard::Censored,
            miss_probability: 0.05,
            model_error_std_db: 4.5,
        }
    }
}

impl LikelihoodConfig {
    /// Checks every field.
    pub fn validate(&self) -> Result<()> {
        let ok = self.miss_probability > 0.0
            && self.miss_probability <= 1.0
            && self.model_error_std_db.is_finite()
            && self.model_error_std_db >= 0.0;
        if !ok {
            return Err(RssiError::InvalidConfig(format!(
                "likelihood: miss_probability must be in (0, 1] and model_error_std_db ≥ 0: {self:?}"
            )));
        }
        Ok(())
    }
}

/// Standard normal CDF.
fn normal_cdf(z: f64) -> f64 {
    0.5 * libm::erfc(-z / std::f64::consts::SQRT_2)
}

fn log_normal_pdf(x: f64, mean: f64, var: f64) -> f64 {
    let d = x - mean;
    -0.5 * (LN_2PI + var.ln() + d * d / var)
}

fn log_silence(config: &LikelihoodConfig, sensitivity_dbm: f64, mean: f64, var: f64) -> f64 {
    let m = config.miss_probability;
    (m + (1.0 - m) * normal_cdf((sensitivity_dbm - mean) / var.sqrt())).ln()
}

fn antenna_term(
    a: &AntennaModel,
    estimate: Option<&RssiEstimate>,
    mean: f64,
    var_model: f64,
    config: &LikelihoodConfig,
) -> f64 {
    match estimate {
        Some(e) => log_normal_pdf(e.rssi_dbm, mean, var_model + e.variance_db2.max(0.0)),
        None => match config.not_heard {
            NotHeard::Ignore => 0.0,
            NotHeard::Censored => log_silence(config, a.weakest_read_dbm, mean, var_model),
        },
    }
}

/// Log-likelihood that the tag whose filtered RSSI per antenna is `tag` (indexed like
/// `model.antennas`; `None` = not heard now) is at `tag_position_m`. Missing entries beyond
/// `tag.len()` count as not heard.
pub fn log_likelihood(
    model: &RssiModel,
    tag: &[Option<RssiEstimate>],
    tag_position_m: &Point3<f64>,
    config: &LikelihoodConfig,
) -> f64 {
    let sm2 = config.model_error_std_db * config.model_error_std_db;
    model
        .antennas
        .iter()
        .enumerate()
        .map(|(i, a)| {
            let (mean, var) = a.predict(tag_position_m);
            let estimate = tag.get(i).and_then(Option::as_ref);
            // Heard: the filter already averaged the per-read σ² away; silence: one would-be
            // read against the sensitivity, with the per-read σ².
            let var_model = if estimate.is_some() { sm2 } else { var + sm2 };
            antenna_term(a, estimate, mean, var_model.max(1e-6), config)
        })
        .sum()
}

/// Log-likelihood of the same RSSI under the background hypothesis: the tag somewhere in the
/// calibrated area (per antenna, the calibration reads' mean and spread).
pub fn background_log_likelihood(
    model: &RssiModel,
    tag: &[Option<RssiEstimate>],
    config: &LikelihoodConfig,
) -> f64 {
    model
        .antennas
        .iter()
        .enumerate()
        .map(|(i, a)| {
            let var = a.background_std_db * a.background_std_db;
            antenna_term(
                a,
                tag.get(i).and_then(Option::as_ref),
                a.background_mean_dbm,
                var.max(1e-6),
                config,
            )
        })
        .sum()
}

/// True when at least one antenna has a current estimate of the tag.
pub fn is_heard(tag: &[Option<RssiEstimate>]) -> bool {
    tag.iter().any(Option::is_some)
}

/// `L / (L + L_bg)` from log-likelihoods: the probability that the tag is on this person rather
/// than somewhere else in the area, with even prior odds. NaN inputs give 0.
pub fn pair_score(log_likelihood: f64, background_log_likelihood: f64) -> f64 {
    let x = log_likelihood - background_log_likelihood;
    if x.is_nan() {
        return 0.0;
    }
    1.0 / (1.0 + (-x).exp())
}

/// Probabilities that one tag is on each candidate (log-likelihoods `candidates`) or on none of
/// them (`background`), normalised in log space. Returns one value per candidate; the remainder
/// to 1 is the background's. NaN candidates get 0.
pub fn posterior(candidates: &[f64], background: f64, out: &mut Vec<f64>) {
    out.clear();
    let max = candidates
        .iter()
        .copied()
        .filter(|v| !v.is_nan())
        .fold(background, f64::max);
    if !max.is_finite() {
        out.extend(candidates.iter().map(|_| 0.0));
        return;
    }
    let mut total = (background - max).exp();
    for c in candidates {
        if !c.is_nan() {
            total += (c - max).exp();
        }
    }
    out.extend(candidates.iter().map(|c| {
        if c.is_nan() {
            0.0
        } else {
            (c - max).exp() / total
        }
    }));
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::tests::antenna_model;
    use crate::model::{ModelKind, TagPlacement};
    use nomen_core::AntennaId;

    fn two_antenna_model() -> RssiModel {
        let mut a = antenna_model(ModelKind::Standard);
        let mut b = antenna_model(ModelKind::Standard);
        a.antenna = AntennaId::new("a0");
        b.antenna = AntennaId::new("a1");
        b.position_m = Point3::new(4.0, 0.0, 1.0);
        RssiModel {
            kind: ModelKind::Standard,
            placement: TagPlacement::default(),
            antennas: vec![a, b],
        }
    }

    fn est(rssi_dbm: f64) -> Option<RssiEstimate> {
        Some(RssiEstimate {
            rssi_dbm,
            variance_db2: 1.0,
            rate_dbps: 0.0,
            age_s: 0.0,
        })
    }

    #[test]
    fn the_true_position_scores_best() {
        let model = two_antenna_model();
        let truth = Point3::new(1.0, 3.0, 1.3);
        let tag: Vec<_> = model
            .antennas
            .iter()
            .map(|a| est(a.predict(&truth).0))
            .collect();
        let c = LikelihoodConfig::default();
        let at_truth = log_likelihood(&model, &tag, &truth, &c);
        let elsewhere = log_likelihood(&model, &tag, &Point3::new(3.5, 8.0, 1.3), &c);
        assert!(at_truth > elsewhere + 2.0, "{at_truth} vs {elsewhere}");
        let bg = background_log_likelihood(&model, &tag, &c);
        assert!(pair_score(at_truth, bg) > 0.5);
        let mut p = Vec::new();
        posterior(&[at_truth, elsewhere], bg, &mut p);
        assert!(p[0] > 0.5 && p[0] + p[1] < 1.0, "{p:?}");
    }

    #[test]
    fn silence_counts_against_people_next_to_the_deaf_antenna() {
        let model = two_antenna_model();
        // Heard at a0 only, at the level of a tag 2 m in front of a0.
        let r = model.antennas[0].predict(&Point3::new(0.0, 2.0, 1.3)).0;
        let tag = vec![est(r), None];
        let near_a1 = Point3::new(3.0, 1.5, 1.3); // close to a1, which should have heard it
        let far_from_a1 = Point3::new(-1.0, 1.7, 1.3);
        let censored = LikelihoodConfig::default();
        let ignore = LikelihoodConfig {
            not_heard: NotHeard::Ignore,
            ..censored
        };
        // Make a1 deaf beyond ~4 m: its weakest read is -62 dBm.
        let mut model = model;
        model.antennas[1].weakest_read_dbm = -62.0;
        let d_censored = log_likelihood(&model, &tag, &far_from_a1, &censored)
            - log_likelihood(&model, &tag, &near_a1, &censored);
        let d_ignore = log_likelihood(&model, &tag, &far_from_a1, &ignore)
            - log_likelihood(&model, &tag, &near_a1, &ignore);
        assert!(d_censored > d_ignore + 1.0, "{d_censored} vs {d_ignore}");
        assert!(log_likelihood(&model, &tag, &near_a1, &censored).is_finite());
    }

    #[test]
    fn scores_stay_in_the_unit_interval_for_extreme_and_nan_input() {
        assert_eq!(pair_score(f64::NAN, 0.0), 0.0);
        assert!((pair_score(1e6, 0.0) - 1.0).abs() < 1e-12);
        assert!(pair_score(-1e6, 0.0) >= 0.0);
        let mut p = Vec::new();
        posterior(
            &[f64::NAN, -1e308, f64::NEG_INFINITY],
            f64::NEG_INFINITY,
            &mut p,
        );
        assert!(p.iter().all(|v| (0.0..=1.0).contains(v)), "{p:?}");
    }
}
