//! RSSI models per antenna (Llorca's standard and directional path loss) with a noise model
//! σ²(D, θ), and the model file the association loads.
//!
//! - standard: `P = P1 − K·log10(D / 1 m)`;
//! - directional: `P = P1 − K1·log10(D / 1 m) + K2·θ`, θ the angle between the antenna's
//!   boresight and the direction from the antenna to the tag, radians in `0..=π`.
//!
//! `K` is the path-loss slope in dB per decade of distance (free space: 20; Llorca's `K`, and
//! `10·n` in the log-distance notation of `nomen_fit::rssi`). Distances below
//! [`AntennaModel::min_distance_m`] are clamped before the logarithm.
//!
//! The noise is Gaussian in dB with a variance that depends on where the tag is (RSSI spreads
//! more far from the antenna and off its boresight): see [`NoiseModel`].

use crate::error::{Result, RssiError};
use nalgebra::{Point3, Vector3};
use nomen_core::{Antenna, AntennaId};
use serde::{Deserialize, Serialize};

/// Which RSSI model an antenna uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ModelKind {
    /// `P = P1 − K·log10(D)`.
    #[default]
    Standard,
    /// `P = P1 − K1·log10(D) + K2·θ` (needs an antenna boresight).
    Directional,
}

impl std::fmt::Display for ModelKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            ModelKind::Standard => "standard",
            ModelKind::Directional => "directional",
        })
    }
}

/// Residual variance as a low-order function of distance and angle:
///
/// `ln σ²(D, θ) = c0 + c_log_d·log10(D / 1 m) + c_theta·θ`, clamped to
/// `[sigma_min_db², sigma_max_db²]`.
///
/// Fitted by regressing `ln r²` of the calibration residuals on `(1, log10 D, θ)` (robustly)
/// and adding 1.2704, the offset `−E[ln χ²₁]`, so that the fit is of `ln σ²` rather than of
/// the mean log of a squared Gaussian. The clamp keeps extrapolation outside the calibrated
/// range sane: the bounds are the smallest and largest σ the fit gives on the calibration
/// points themselves.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct NoiseModel {
    /// Intercept of `ln σ²` (σ in dB).
    pub c0: f64,
    /// Change of `ln σ²` per decade of distance.
    pub c_log_d: f64,
    /// Change of `ln σ²` per radian off the boresight (0 for omnidirectional antennas).
    pub c_theta: f64,
    /// Lower clamp of σ, dB.
    pub sigma_min_db: f64,
    /// Upper clamp of σ, dB.
    pub sigma_max_db: f64,
}

impl NoiseModel {
    /// A constant σ, dB.
    pub fn constant(sigma_db: f64) -> Self {
        Self {
            c0: (sigma_db * sigma_db).ln(),
            c_log_d: 0.0,
            c_theta: 0.0,
            sigma_min_db: sigma_db,
            sigma_max_db: sigma_db,
        }
    }

    /// Residual variance at distance `distance_m` (already clamped by the caller) and angle
    /// `theta_rad` (0 for omnidirectional antennas), dB².
    pub fn variance_db2(&self, distance_m: f64, theta_rad: f64) -> f64 {
        let v = (self.c0 + self.c_log_d * distance_m.log10() + self.c_theta * theta_rad).exp();
        let lo = self.sigma_min_db * self.sigma_min_db;
        let hi = self.sigma_max_db * self.sigma_max_db;
        if v.is_finite() { v.clamp(lo, hi) } else { hi }
    }
}

/// The fitted model of one antenna, with its geometry (so that likelihoods need no registry).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AntennaModel {
    /// The antenna.
    pub antenna: AntennaId,
    /// Antenna position, world frame, m.
    pub position_m: Point3<f64>,
    /// Unit boresight in the world frame; `None` for an omnidirectional antenna.
    pub boresight: Option<Vector3<f64>>,
    /// Which model this antenna uses (a directional request on an antenna without boresight
    /// falls back to `standard`).
    pub kind: ModelKind,
    /// Received power at 1 m on the boresight, dBm.
    pub p1_dbm: f64,
    /// Path-loss slope K (standard) or K1 (directional), dB per decade of distance.
    pub k_db_per_decade: f64,
    /// Angular slope K2, dB per radian off the boresight (0 for the standard model).
    pub k2_db_per_rad: f64,
    /// Distances below this are clamped before the logarithm, m.
    pub min_distance_m: f64,
    /// Residual variance σ²(D, θ).
    pub noise: NoiseModel,
    /// Mean RSSI of the calibration reads, dBm: the *background* model's mean (the tag somewhere
    /// in the calibrated area).
    pub background_mean_dbm: f64,
    /// Standard deviation of the calibration reads around their mean, dB (background spread).
    pub background_std_db: f64,
    /// Weakest read the antenna reported in calibration, dBm: below it there is no evidence
    /// that the antenna can hear the tag (used as its effective sensitivity).
    pub weakest_read_dbm: f64,
}

impl AntennaModel {
    /// Distance (clamped) and boresight angle (0 when omnidirectional) of a tag at `tag_m`.
    pub fn geometry(&self, tag_m: &Point3<f64>) -> (f64, f64) {
        let to_tag = tag_m - self.position_m;
        let d = to_tag.norm().max(self.min_distance_m);
        (d, angle_off_boresight(self.boresight.as_ref(), &to_tag))
    }

    /// Expected RSSI at distance `distance_m` and angle `theta_rad`, dBm.
    pub fn predict_at(&self, distance_m: f64, theta_rad: f64) -> f64 {
        let d = distance_m.max(self.min_distance_m);
        let angular = match self.kind {
            ModelKind::Standard => 0.0,
            ModelKind::Directional => self.k2_db_per_rad * theta_rad,
        };
        self.p1_dbm - self.k_db_per_decade * d.log10() + angular
    }

    /// Expected RSSI and residual variance for a tag at `tag_m`: `(mean dBm, variance dB²)`.
    pub fn predict(&self, tag_m: &Point3<f64>) -> (f64, f64) {
        let (d, theta) = self.geometry(tag_m);
        (self.predict_at(d, theta), self.noise.variance_db2(d, theta))
    }

    /// The distance the model assigns to `rssi_dbm` at angle `theta_rad` (the inverse of
    /// [`Self::predict_at`]), m. `None` when the slope is not positive.
    pub fn distance_for(&self, rssi_dbm: f64, theta_rad: f64) -> Option<f64> {
        if self.k_db_per_decade <= 0.0 || !rssi_dbm.is_finite() {
            return None;
        }
        let angular = match self.kind {
            ModelKind::Standard => 0.0,
            ModelKind::Directional => self.k2_db_per_rad * theta_rad,
        };
        Some(10f64.powf((self.p1_dbm + angular - rssi_dbm) / self.k_db_per_decade))
    }
}

/// The angle between a boresight and a direction, radians in `0..=π`; 0 without boresight or
/// for a zero direction.
pub fn angle_off_boresight(boresight: Option<&Vector3<f64>>, direction: &Vector3<f64>) -> f64 {
    let (Some(b), Some(v)) = (
        boresight.and_then(|b| b.try_normalize(1e-12)),
        direction.try_normalize(1e-12),
    ) else {
        return 0.0;
    };
    b.dot(&v).clamp(-1.0, 1.0).acos()
}

/// Where the tag is assumed to be on a person.
///
/// Llorca fixes the tag height; nomen can also take the joint the registry says the tag is worn
/// at. The same choice must be used in calibration and association (the model file stores it).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TagPlacement {
    /// The person's ground position (pelvis x, y) at this height above the floor, m.
    FixedHeight(f64),
    /// The joint given as the wearable's `site` in the registry (pelvis when unknown).
    RegistrySite,
}

impl Default for TagPlacement {
    /// A fixed 1.3 m: a tag on a lanyard or at the chest of an adult (Kolakowski's tag rode at
    /// 1.3 m; Llorca fixes one height for all pedestrians). An assumption: set it per site.
    fn default() -> Self {
        TagPlacement::FixedHeight(1.3)
    }
}

/// A calibrated RSSI model for every antenna of a site: the file `nomen calibrate rssi --out`
/// writes and the association loads.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RssiModel {
    /// Which model was fitted (per antenna, see [`AntennaModel::kind`]).
    pub kind: ModelKind,
    /// Where the tag is assumed to be on a person (as used in calibration).
    pub placement: TagPlacement,
    /// One model per antenna.
    pub antennas: Vec<AntennaModel>,
}

impl RssiModel {
    /// The model for a site without calibration: Kolakowski's pooled BLE fit
    /// (`docs/sensor-models.md`, "BLE RSSI (Kolakowski)" rows: P1 −47.0 dBm at 1 m, K 20.2 dB per
    /// decade, shadowing σ 7.0 dB), the same for every antenna, omnidirectional (Kolakowski's
    /// anchors are: the data say nothing about a boresight), the tag at its registry site. Its
    /// background is the model's mean and spread over 1–10 m (a person somewhere in front of
    /// the antenna), and its sensitivity is a BLE receiver's −100 dBm (datasheets), so that
    /// silence counts only where the reads themselves show a weaker floor. A user of this
    /// model refines it online (per-tag, per-antenna gains: the engine's RSSI evidence).
    pub fn fitted_default(antennas: &[Antenna]) -> Self {
        const P1_DBM: f64 = -47.0;
        const K_DB_PER_DECADE: f64 = 20.2;
        const SHADOWING_STD_DB: f64 = 7.0;
        // Mean and spread of `P1 − K·log10 D` for D uniform in 1..10 m.
        let levels: Vec<f64> = (0..=90)
            .map(|i| P1_DBM - K_DB_PER_DECADE * (1.0 + 0.1 * f64::from(i)).log10())
            .collect();
        let n = levels.len() as f64;
        let mean = levels.iter().sum::<f64>() / n;
        let spread = (levels.iter().map(|l| (l - mean).powi(2)).sum::<f64>() / n).sqrt();
        let background_std_db = (spread * spread + SHADOWING_STD_DB * SHADOWING_STD_DB).sqrt();
        RssiModel {
            kind: ModelKind::Standard,
            placement: TagPlacement::RegistrySite,
            antennas: antennas
                .iter()
                .map(|a| AntennaModel {
                    antenna: a.id.clone(),
                    position_m: a.position_m,
                    boresight: a.boresight,
                    kind: ModelKind::Standard,
                    p1_dbm: P1_DBM,
                    k_db_per_decade: K_DB_PER_DECADE,
                    k2_db_per_rad: 0.0,
                    min_distance_m: 0.1,
                    noise: NoiseModel::constant(SHADOWING_STD_DB),
                    background_mean_dbm: mean,
                    background_std_db,
                    weakest_read_dbm: -100.0,
                })
                .collect(),
        }
    }

    /// The model of `antenna`, with its index.
    pub fn antenna(&self, antenna: &AntennaId) -> Option<(usize, &AntennaModel)> {
        self.antennas
            .iter()
            .enumerate()
            .find(|(_, a)| &a.antenna == antenna)
    }

    /// Checks that every value is finite and in range.
    pub fn validate(&self) -> Result<()> {
        if self.antennas.is_empty() {
            return Err(RssiError::ModelMismatch("the model has no antenna".into()));
        }
        if let TagPlacement::FixedHeight(h) = self.placement
            && !(h.is_finite() && (-10.0..=10.0).contains(&h))
        {
            return Err(RssiError::ModelMismatch(format!(
                "tag height {h} m is not a plausible height"
            )));
        }
        for a in &self.antennas {
            let nums = [
                a.p1_dbm,
                a.k_db_per_decade,
                a.k2_db_per_rad,
                a.min_distance_m,
                a.noise.c0,
                a.noise.c_log_d,
                a.noise.c_theta,
                a.noise.sigma_min_db,
                a.noise.sigma_max_db,
                a.background_mean_dbm,
                a.background_std_db,
                a.weakest_read_dbm,
            ];
            let finite_geometry = a.position_m.iter().all(|v| v.is_finite())
                && a.boresight.is_none_or(|b| b.iter().all(|v| v.is_finite()));
            if !nums.iter().all(|v| v.is_finite()) || !finite_geometry {
                return Err(RssiError::ModelMismatch(format!(
                    "antenna {}: a value is not finite",
                    a.antenna
                )));
            }
            if a.noise.sigma_min_db <= 0.0
                || a.noise.sigma_max_db < a.noise.sigma_min_db
                || a.background_std_db <= 0.0
                || a.min_distance_m <= 0.0
            {
                return Err(RssiError::ModelMismatch(format!(
                    "antenna {}: σ bounds, background σ and min distance must be positive",
                    a.antenna
                )));
            }
        }
        Ok(())
    }

    /// Checks that every registry antenna has a model with the registry's geometry (within
    /// 1 mm and 1°); models of antennas the registry does not list are an error too.
    pub fn check_against(&self, antennas: &[Antenna]) -> Result<()> {
        for a in antennas {
            let Some((_, m)) = self.antenna(&a.id) else {
                return Err(RssiError::ModelMismatch(format!(
                    "registry antenna {} has no calibrated model",
                    a.id
                )));
            };
            if (m.position_m - a.position_m).norm() > 1e-3 {
                return Err(RssiError::ModelMismatch(format!(
                    "antenna {} moved since calibration ({:?} → {:?})",
                    a.id, m.position_m, a.position_m
                )));
            }
            let angle = match (m.boresight, a.boresight) {
                (Some(x), Some(y)) => angle_off_boresight(Some(&x), &y),
                (None, None) => 0.0,
                _ => std::f64::consts::PI,
            };
            if angle > 1f64.to_radians() {
                return Err(RssiError::ModelMismatch(format!(
                    "antenna {} changed boresight since calibration",
                    a.id
                )));
            }
        }
        for m in &self.antennas {
            if !antennas.iter().any(|a| a.id == m.antenna) {
                return Err(RssiError::ModelMismatch(format!(
                    "model antenna {} is not in the registry",
                    m.antenna
                )));
            }
        }
        Ok(())
    }

    /// The model as pretty JSON.
    pub fn to_json(&self) -> Result<String> {
        serde_json::to_string_pretty(self).map_err(|e| RssiError::ModelFile {
            source_name: "<model>".into(),
            message: e.to_string(),
        })
    }

    /// Parses and validates a model file's text; `source_name` names it in errors.
    pub fn from_json(text: &str, source_name: &str) -> Result<Self> {
        let model: Self = serde_json::from_str(text).map_err(|e| RssiError::ModelFile {
            source_name: source_name.to_owned(),
            message: e.to_string(),
        })?;
        model.validate()?;
        Ok(model)
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    pub(crate) fn antenna_model(kind: ModelKind) -> AntennaModel {
        AntennaModel {
            antenna: AntennaId::new("a"),
            position_m: Point3::new(0.0, 0.0, 1.0),
            boresight: Some(Vector3::new(0.0, 1.0, 0.0)),
            kind,
            p1_dbm: -50.0,
            k_db_per_decade: 20.0,
            k2_db_per_rad: -5.0,
            min_distance_m: 0.25,
            noise: NoiseModel::constant(4.0),
            background_mean_dbm: -65.0,
            background_std_db: 8.0,
            weakest_read_dbm: -90.0,
        }
    }

    #[test]
    fn directional_model_loses_power_off_the_boresight() {
        let m = antenna_model(ModelKind::Directional);
        let on = m.predict(&Point3::new(0.0, 10.0, 1.0)).0;
        let off = m.predict(&Point3::new(10.0, 0.0, 1.0)).0;
        assert!((on + 70.0).abs() < 1e-9, "{on}");
        assert!((on - off - 5.0 * std::f64::consts::FRAC_PI_2).abs() < 1e-9);
        let s = antenna_model(ModelKind::Standard);
        assert!((s.predict(&Point3::new(10.0, 0.0, 1.0)).0 + 70.0).abs() < 1e-9);
    }

    #[test]
    fn inverting_the_model_returns_the_distance() {
        let m = antenna_model(ModelKind::Directional);
        let p = m.predict_at(7.0, 0.4);
        let d = m.distance_for(p, 0.4).unwrap_or(f64::NAN);
        assert!((d - 7.0).abs() < 1e-9);
    }

    #[test]
    fn model_round_trips_through_json_and_rejects_bad_values() {
        let model = RssiModel {
            kind: ModelKind::Standard,
            placement: TagPlacement::default(),
            antennas: vec![antenna_model(ModelKind::Standard)],
        };
        let text = model.to_json().unwrap_or_default();
        assert_eq!(RssiModel::from_json(&text, "m.json").ok(), Some(model));
        let broken = text.replace("\"background_std_db\": 8.0", "\"background_std_db\": -1.0");
        assert!(RssiModel::from_json(&broken, "m.json").is_err());
        let err = RssiModel::from_json("{", "m.json")
            .err()
            .map(|e| e.to_string());
        assert!(err.is_some_and(|e| e.contains("m.json")));
    }

    #[test]
    fn the_fitted_default_validates_and_falls_twenty_db_per_decade() {
        let antennas = [Antenna {
            id: AntennaId::new("ant0"),
            position_m: Point3::new(1.0, 2.0, 1.0),
            boresight: Some(Vector3::y()),
        }];
        let model = RssiModel::fitted_default(&antennas);
        assert!(model.validate().is_ok());
        assert!(model.check_against(&antennas).is_ok());
        let a = &model.antennas[0];
        let near = a.predict(&Point3::new(1.0, 3.0, 1.0)).0;
        let far = a.predict(&Point3::new(1.0, 12.0, 1.0)).0;
        assert!((near - far - 20.2).abs() < 1e-9, "{near} {far}");
        assert!(a.background_mean_dbm < near && a.background_mean_dbm > far);
    }

    #[test]
    fn noise_variance_is_clamped_to_the_calibrated_range() {
        let n = NoiseModel {
            c0: (16f64).ln(),
            c_log_d: 2.0,
            c_theta: 0.0,
            sigma_min_db: 3.0,
            sigma_max_db: 6.0,
        };
        assert!((n.variance_db2(1.0, 0.0) - 16.0).abs() < 1e-9);
        assert!((n.variance_db2(1000.0, 0.0) - 36.0).abs() < 1e-9);
        assert!((n.variance_db2(0.01, 0.0) - 9.0).abs() < 1e-9);
    }
}
