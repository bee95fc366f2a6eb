//! RSSI reads of a worn tag at fixed antennas (BLE anchors, passive UHF RFID reader ports).
//!
//! Received power, dBm:
//!
//! `P = P1 − 10·n·log10(d / 1 m) + G(θ) + offset_antenna − L_body·num_blocking + S(t)`
//!
//! - log-distance path loss with `P1`, `n` fitted on Kolakowski's BLE data
//!   (`docs/sensor-models.md`, "BLE RSSI (Kolakowski)" rows);
//! - `G(θ)`, a directional term for antennas with a boresight (θ = angle between the boresight
//!   and the direction to the tag): Llorca's linear `K2·θ` (default) or a `cos^q θ` pattern;
//!   antennas without a boresight are omnidirectional;
//! - a constant offset per antenna (drawn, plus any explicit offsets);
//! - an attenuation per body on the line of sight, counted by a closure the caller supplies
//!   (the lead computes it with the geometry module);
//! - shadowing `S(t)`: Gaussian, optionally AR(1)-correlated in time per antenna.
//!
//! Each antenna polls the tag at `read_rate_hz` (random phase per antenna); a poll yields a read
//! with a probability that falls with distance (fitted to Kolakowski's read-rate bins) and only
//! if the power is above the receiver's sensitivity. Values are dBm, quantised like a real
//! receiver reports them, never dBm×100.

use super::{DeviceDraw, MAX_DEVICE_SPREAD, check_in, check_span, is_one, normal};
use crate::body::BodyMotion;
use crate::error::{Result, SimError};
use crate::rng::SimRng;
use nomen_core::{Antenna, Joint, RssiRead, SessionTime, TagId};
use rand::Rng;
use serde::{Deserialize, Serialize};

/// How the antenna's gain falls off the boresight.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DirectionalModel {
    /// Llorca's linear term `directional_db_per_rad · θ`.
    Linear,
    /// A `cos^q θ` power pattern, `10·q·log10(cos θ)` dB, floored at `back_lobe_floor_db`
    /// (smooth at the boresight, and bounded behind the antenna, which the linear term is not).
    Cosine,
}

/// Path loss, shadowing and read behaviour of RSSI tags. Defaults are BLE (Kolakowski); a passive
/// UHF RFID scenario must override `p1_dbm`, `path_loss_exponent`, `read_rate_hz`,
/// `sensitivity_dbm` and the read curve.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RssiConfig {
    /// Polls per second per antenna, Hz, in `0.1..=1000`. Default 10 Hz: **an assumption**
    /// (a BLE tag advertising every 100 ms); the fitted table is resampled and cannot tell.
    pub read_rate_hz: f64,
    /// Received power at 1 m on the boresight, dBm. Default −47.0: Kolakowski "pooled P1" row
    /// (per anchor −51.8 … −41.7).
    pub p1_dbm: f64,
    /// Path-loss exponent n (Llorca's K = 10·n). Default 2.02: Kolakowski "pooled n" row (per
    /// anchor 1.54 … 3.11).
    pub path_loss_exponent: f64,
    /// Distances below this are taken as this, m (keeps the log finite). Default 0.1 m.
    pub min_distance_m: f64,
    /// Directional pattern for antennas with a boresight. Default `linear` (Llorca).
    pub directional_model: DirectionalModel,
    /// Slope of the linear pattern, dB/rad (negative: less power off the boresight). Default
    /// −5 dB/rad: **not in the data** (Kolakowski's anchors are omnidirectional); a typical
    /// UHF RFID patch antenna (half-power beamwidth ≈ 70°) loses 3 dB at 35° ≈ 0.6 rad.
    pub directional_db_per_rad: f64,
    /// Exponent q of the cosine pattern. Default 3.5: the same 70° half-power beamwidth
    /// (`cos^q 35° = 0.5`).
    pub cosine_exponent: f64,
    /// Lowest gain of the cosine pattern (behind the antenna), dB. Default −20 dB (a patch
    /// antenna's front-to-back ratio is of this order; assumption).
    pub back_lobe_floor_db: f64,
    /// σ of the constant offset drawn per antenna, dB. Default 3.5 dB: the sample σ of the six
    /// per-anchor P1 values in Kolakowski's table (confounded with their differing n).
    pub antenna_offset_sigma_db: f64,
    /// Explicit offsets per antenna (same order as the antennas), dB, added to the drawn ones;
    /// missing entries are 0.
    pub antenna_offsets_db: Vec<f64>,
    /// σ of the shadowing, dB. Default 7.0 dB: Kolakowski "shadowing σ" row (robust 6.9;
    /// per anchor 5.1–7.7).
    pub shadowing_sigma_db: f64,
    /// Correlation time of the shadowing (AR(1), per antenna), s; 0 = independent reads.
    /// Default 0: **not fitted** (the table is preprocessed). A walker crossing a ~1–2 m
    /// decorrelation distance (Gudmundson's model) at ~1 m/s suggests 1–2 s.
    pub shadowing_correlation_time_s: f64,
    /// Attenuation per human body on the line of sight, dB. Default 10 dB: **literature, not the
    /// data** (the fitted tag rode a robot); body shadowing at 2.4 GHz and at UHF is reported at
    /// roughly 5–20 dB depending on posture and orientation.
    pub body_attenuation_db: f64,
    /// Read probability extrapolated to 0 m: `p(d) = p0 − c·d²`, clamped to `0..=1`. Default
    /// 0.928, with `c` below: a least-squares fit (weighted by rows) to Kolakowski's read-rate
    /// bins from 1 to 10 m (92–93 % at 1–3 m … 81.5 % at 9–10 m; rms misfit 1.0 point). The 0–1 m
    /// bin (84 %, 119 rows) is left out.
    pub read_probability_at_0m: f64,
    /// Quadratic fall of the read probability, per m². Default 8.76e-4 (same fit).
    pub read_probability_loss_per_m2: f64,
    /// Reads below this power are missed, dBm. Default −100 dBm: BLE receiver sensitivity of
    /// the order of −95 … −100 dBm (datasheets); passive UHF readers are around −80 dBm.
    pub sensitivity_dbm: f64,
    /// Resolution of reported values, dB (0 = none). Default 1 dB: BLE reports integer dBm.
    pub quantisation_db: f64,
    /// Spread `k ≥ 1` of the tags around this model: each tag draws its own multiplier of
    /// `shadowing_sigma_db`, log-uniform in `[1/k, k]` (see [`DeviceDraw`]). Default 1 (every
    /// tag exactly the model); at most 10. **Not fitted.** Read losses follow the read curve
    /// and have no per-tag range.
    #[serde(skip_serializing_if = "is_one")]
    pub device_spread: f64,
}

impl Default for RssiConfig {
    fn default() -> Self {
        Self {
            read_rate_hz: 10.0,
            p1_dbm: -47.0,
            path_loss_exponent: 2.02,
            min_distance_m: 0.1,
            directional_model: DirectionalModel::Linear,
            directional_db_per_rad: -5.0,
            cosine_exponent: 3.5,
            back_lobe_floor_db: -20.0,
            antenna_offset_sigma_db: 3.5,
            antenna_offsets_db: Vec::new(),
            shadowing_sigma_db: 7.0,
            shadowing_correlation_time_s: 0.0,
            body_attenuation_db: 10.0,
            read_probability_at_0m: 0.928,
            read_probability_loss_per_m2: 8.76e-4,
            sensitivity_dbm: -100.0,
            quantisation_db: 1.0,
            device_spread: 1.0,
        }
    }
}

impl RssiConfig {
    /// The mean model without randomness: no shadowing, offsets, quantisation or missed reads.
    pub fn noise_free() -> Self {
        Self {
            antenna_offset_sigma_db: 0.0,
            shadowing_sigma_db: 0.0,
            read_probability_at_0m: 1.0,
            read_probability_loss_per_m2: 0.0,
            sensitivity_dbm: -150.0,
            quantisation_db: 0.0,
            ..Self::default()
        }
    }

    /// Checks every field; errors name it (`rssi.shadowing_sigma_db`, ...).
    pub fn validate(&self) -> Result<()> {
        let p = "rssi";
        check_in(p, "read_rate_hz", self.read_rate_hz, 0.1, 1000.0)?;
        check_in(p, "p1_dbm", self.p1_dbm, -150.0, 30.0)?;
        check_in(p, "path_loss_exponent", self.path_loss_exponent, 0.0, 10.0)?;
        check_in(p, "min_distance_m", self.min_distance_m, 1e-3, 100.0)?;
        check_in(
            p,
            "directional_db_per_rad",
            self.directional_db_per_rad,
            -100.0,
            100.0,
        )?;
        check_in(p, "cosine_exponent", self.cosine_exponent, 0.0, 100.0)?;
        check_in(
            p,
            "back_lobe_floor_db",
            self.back_lobe_floor_db,
            -100.0,
            0.0,
        )?;
        check_in(
            p,
            "antenna_offset_sigma_db",
            self.antenna_offset_sigma_db,
            0.0,
            50.0,
        )?;
        for (i, o) in self.antenna_offsets_db.iter().enumerate() {
            check_in(p, &format!("antenna_offsets_db[{i}]"), *o, -100.0, 100.0)?;
        }
        check_in(p, "shadowing_sigma_db", self.shadowing_sigma_db, 0.0, 50.0)?;
        check_in(
            p,
            "shadowing_correlation_time_s",
            self.shadowing_correlation_time_s,
            0.0,
            1e6,
        )?;
        check_in(
            p,
            "body_attenuation_db",
            self.body_attenuation_db,
            0.0,
            100.0,
        )?;
        check_in(
            p,
            "read_probability_at_0m",
            self.read_probability_at_0m,
            0.0,
            1.0,
        )?;
        check_in(
            p,
            "read_probability_loss_per_m2",
            self.read_probability_loss_per_m2,
            0.0,
            1.0,
        )?;
        check_in(p, "sensitivity_dbm", self.sensitivity_dbm, -200.0, 30.0)?;
        check_in(p, "quantisation_db", self.quantisation_db, 0.0, 10.0)?;
        check_in(
            p,
            "device_spread",
            self.device_spread,
            1.0,
            MAX_DEVICE_SPREAD,
        )
    }

    /// The model of one tag: `shadowing_sigma_db` times `draw.noise_multiplier`. The identity
    /// draw returns the model unchanged.
    pub fn for_device(&self, draw: &DeviceDraw) -> Self {
        Self {
            shadowing_sigma_db: self.shadowing_sigma_db * draw.noise_multiplier,
            ..self.clone()
        }
    }

    /// Probability that a poll at distance `d_m` yields a read (before the sensitivity check).
    pub fn read_probability(&self, d_m: f64) -> f64 {
        (self.read_probability_at_0m - self.read_probability_loss_per_m2 * d_m * d_m)
            .clamp(0.0, 1.0)
    }

    /// The mean received power without antenna offset, bodies or shadowing, dBm, for a tag at
    /// distance `d_m` and angle `theta_rad` off the boresight (`None`: omnidirectional).
    pub fn mean_power_dbm(&self, d_m: f64, theta_rad: Option<f64>) -> f64 {
        let d = d_m.max(self.min_distance_m);
        let gain = match theta_rad {
            None => 0.0,
            Some(theta) => match self.directional_model {
                DirectionalModel::Linear => self.directional_db_per_rad * theta,
                DirectionalModel::Cosine => {
                    let c = theta.cos();
                    if c <= 0.0 {
                        self.back_lobe_floor_db
                    } else {
                        (10.0 * self.cosine_exponent * c.log10()).max(self.back_lobe_floor_db)
                    }
                }
            },
        };
        self.p1_dbm - 10.0 * self.path_loss_exponent * d.log10() + gain
    }
}

/// Reads of one tag and what was drawn.
#[derive(Debug, Clone, PartialEq)]
pub struct RssiRun {
    /// Reads from all antennas, non-decreasing in time.
    pub reads: Vec<RssiRead>,
    /// The total constant offset of each antenna (drawn + explicit), dB, in the antennas' order.
    pub antenna_offset_db: Vec<f64>,
    /// Polls that gave no read (missed, or below the sensitivity).
    pub num_missed: usize,
}

/// Simulates the RSSI reads of a tag worn at `site` at `antennas` over `span_s`.
///
/// `num_blocking_bodies(t_s, antenna_index)` counts the bodies on the line of sight between the
/// tag and antenna `antenna_index` at session time `t_s` (the wearer's own body included, if the
/// caller counts it).
#[allow(clippy::too_many_arguments)]
pub fn simulate_rssi(
    motion: &dyn BodyMotion,
    site: Joint,
    tag: &TagId,
    antennas: &[Antenna],
    span_s: (f64, f64),
    num_blocking_bodies: &dyn Fn(f64, usize) -> usize,
    config: &RssiConfig,
    rng: &mut SimRng,
) -> Result<RssiRun> {
    config.validate()?;
    check_span(&format!("rssi {tag}"), span_s)?;
    for a in antennas {
        let finite_boresight = a.boresight.is_none_or(|b| b.iter().all(|v| v.is_finite()));
        if !a.position_m.iter().all(|v| v.is_finite()) || !finite_boresight {
            return Err(SimError::InvalidScenario(format!(
                "antenna {}: position or boresight is not finite",
                a.id
            )));
        }
    }
    let antenna_offset_db: Vec<f64> = antennas
        .iter()
        .enumerate()
        .map(|(i, _)| {
            config.antenna_offset_sigma_db * normal(rng)
                + config.antenna_offsets_db.get(i).copied().unwrap_or(0.0)
        })
        .collect();
    let period_s = 1.0 / config.read_rate_hz;
    let rho = if config.shadowing_correlation_time_s > 0.0 {
        (-period_s / config.shadowing_correlation_time_s).exp()
    } else {
        0.0
    };
    let innovation = config.shadowing_sigma_db * (1.0 - rho * rho).sqrt();
    let num_polls = ((span_s.1 - span_s.0) / period_s).floor() as usize + 1;
    let mut run = RssiRun {
        reads: Vec::with_capacity(num_polls * antennas.len()),
        antenna_offset_db,
        num_missed: 0,
    };
    for (i, antenna) in antennas.iter().enumerate() {
        let phase_s = rng.random::<f64>() * period_s;
        let boresight = antenna.boresight.and_then(|b| b.try_normalize(1e-12));
        let offset = run.antenna_offset_db.get(i).copied().unwrap_or(0.0);
        let mut shadow = config.shadowing_sigma_db * normal(rng);
        for k in 0..num_polls {
            let t_s = span_s.0 + phase_s + k as f64 * period_s;
            if t_s > span_s.1 {
                break;
            }
            if k > 0 {
                shadow = rho * shadow + innovation * normal(rng);
            }
            let u: f64 = rng.random();
            let to_tag = motion.joint_at(t_s, site).position_m - antenna.position_m;
            let d = to_tag.norm();
            let theta = boresight.map(|b| {
                to_tag
                    .try_normalize(1e-12)
                    .map_or(0.0, |v| b.dot(&v).clamp(-1.0, 1.0).acos())
            });
            let bodies = num_blocking_bodies(t_s, i) as f64;
            let mut p = config.mean_power_dbm(d, theta) + offset
                - config.body_attenuation_db * bodies
                + shadow;
            if config.quantisation_db > 0.0 {
                p = (p / config.quantisation_db).round() * config.quantisation_db;
            }
            if u >= config.read_probability(d) || p < config.sensitivity_dbm {
                run.num_missed += 1;
                continue;
            }
            let Some(t) = SessionTime::from_secs_f64(t_s) else {
                continue;
            };
            run.reads.push(RssiRead {
                t,
                tag: tag.clone(),
                antenna: antenna.id.clone(),
                rssi_dbm: p.clamp(-150.0, 30.0),
                phase_rad: None,
            });
        }
    }
    run.reads.sort_by_key(|r| r.t);
    Ok(run)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_read_curve_stays_near_the_fitted_bins() {
        let c = RssiConfig::default();
        // Kolakowski read-rate bins (centre m, rate) from docs/sensor-models.md.
        let bins = [
            (1.5, 0.920),
            (2.5, 0.931),
            (3.5, 0.916),
            (4.5, 0.908),
            (5.5, 0.889),
            (6.5, 0.909),
            (7.5, 0.882),
            (8.5, 0.860),
            (9.5, 0.815),
        ];
        for (d, p) in bins {
            let diff = c.read_probability(d) - p;
            assert!(diff.abs() < 0.035, "{d} m: {diff}");
        }
    }

    #[test]
    fn cosine_pattern_loses_three_db_at_35_degrees_and_is_floored_behind() {
        let c = RssiConfig {
            directional_model: DirectionalModel::Cosine,
            ..RssiConfig::noise_free()
        };
        let on = c.mean_power_dbm(2.0, Some(0.0));
        let off = c.mean_power_dbm(2.0, Some(35f64.to_radians()));
        assert!((on - off - 3.0).abs() < 0.1, "{}", on - off);
        let back = c.mean_power_dbm(2.0, Some(3.0));
        assert!((on - back - 20.0).abs() < 1e-9);
        assert!((c.mean_power_dbm(1.0, None) + 47.0).abs() < 1e-12);
    }
}
