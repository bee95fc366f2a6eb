//! How likely it is that a tag is worn at a skeleton's key joint, frame by frame: the helper the
//! engine calls for UWB evidence.
//!
//! With the filtered tag position `x̂` (covariance `P`), the key joint `j` (isotropic noise
//! `σ_j`) and `d = j − x̂`, the innovation covariance is `S = P + σ_j² I` and
//!
//! ```text
//! m²             = dᵀ S⁻¹ d                                   (squared Mahalanobis distance)
//! log_likelihood = −½ m² − ½ ln det(2π S)                    (Gaussian density of d, ln m⁻³)
//! score          = P(χ²₃ ≥ m²) = erfc(m/√2) + √(2/π) · m · e^(−m²/2)
//! ```
//!
//! The score is the probability that a tag truly worn at this joint would be at least this far
//! off: 1 at zero distance, 0.5 at `m² ≈ 2.37`, 0.05 at `m² ≈ 7.81`, 0.001 at `m² ≈ 16.3`. It
//! is calibrated whatever the tag's uncertainty, so a stale tag (large `P`) scores every nearby
//! skeleton alike instead of favouring one by chance.
//!
//! The key joint is configurable per tag ([`KeyJoints`]); the default is the registry's
//! `Wearable::site` for the tag.

use crate::track::TagState;
use nalgebra::{Matrix3, Point3};
use nomen_core::{Joint, Registry, TagId};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// The tag–joint comparison of one frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TagJointLikelihood {
    /// Squared Mahalanobis distance `m²`.
    pub mahalanobis2: f64,
    /// Gaussian log density of the offset, ln(m⁻³).
    pub log_likelihood: f64,
    /// `P(χ²₃ ≥ m²)` in `[0, 1]`.
    pub score: f64,
    /// Euclidean distance, m.
    pub distance_m: f64,
}

/// The χ²(3) survival function.
pub fn chi2_3_survival(m2: f64) -> f64 {
    if m2.is_nan() {
        return 0.0;
    }
    if m2 <= 0.0 {
        return 1.0;
    }
    let m = m2.sqrt();
    let v = libm::erfc(m / std::f64::consts::SQRT_2)
        + (2.0 / std::f64::consts::PI).sqrt() * m * (-0.5 * m2).exp();
    v.clamp(0.0, 1.0)
}

/// Compares a tag estimate with a key joint (see the module docs). `None` when the numbers are
/// not finite or `S` is singular.
pub fn tag_joint_likelihood(
    tag_position_m: &Point3<f64>,
    tag_covariance_m2: &Matrix3<f64>,
    joint_m: &Point3<f64>,
    joint_sigma_m: f64,
) -> Option<TagJointLikelihood> {
    let d = joint_m - tag_position_m;
    let s = tag_covariance_m2 + Matrix3::identity() * joint_sigma_m.powi(2);
    let chol = s.cholesky()?;
    let m2 = d.dot(&chol.solve(&d));
    let det = chol.determinant();
    let log_likelihood = -0.5 * m2 - 0.5 * (det.ln() + 3.0 * (2.0 * std::f64::consts::PI).ln());
    let out = TagJointLikelihood {
        mahalanobis2: m2,
        log_likelihood,
        score: chi2_3_survival(m2),
        distance_m: d.norm(),
    };
    (m2.is_finite() && log_likelihood.is_finite()).then_some(out)
}

/// [`tag_joint_likelihood`] from a filtered [`TagState`].
pub fn state_joint_likelihood(
    state: &TagState,
    joint_m: &Point3<f64>,
    joint_sigma_m: f64,
) -> Option<TagJointLikelihood> {
    tag_joint_likelihood(
        &state.position_m,
        &state.covariance_m2,
        joint_m,
        joint_sigma_m,
    )
}

/// Which joint each tag is compared with.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct KeyJoints {
    /// Per-tag overrides of the registry's wearing site.
    #[serde(default)]
    pub overrides: BTreeMap<TagId, Joint>,
}

impl KeyJoints {
    /// The key joint of `tag`: the override, else the site the registry says it is worn at;
    /// `None` for a tag nobody wears.
    pub fn key_joint(&self, registry: &Registry, tag: &TagId) -> Option<Joint> {
        self.overrides
            .get(tag)
            .copied()
            .or_else(|| registry.wearer(tag).map(|(_, w)| w.site))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nomen_core::{DeviceKind, Subject, Wearable};

    #[test]
    fn survival_matches_chi_square_quantiles() {
        // χ²(3) quantiles from statistical tables: 0.5 at 2.366, 0.05 at 7.815, 0.001 at 16.27.
        assert!((chi2_3_survival(2.366) - 0.5).abs() < 1e-3);
        assert!((chi2_3_survival(7.815) - 0.05).abs() < 1e-4);
        assert!((chi2_3_survival(16.27) - 0.001).abs() < 1e-5);
        assert_eq!(chi2_3_survival(0.0), 1.0);
        assert_eq!(chi2_3_survival(f64::NAN), 0.0);
    }

    #[test]
    fn closer_joint_is_more_likely_and_uncertainty_flattens_it() {
        let tag = Point3::new(1.0, 1.0, 1.0);
        let tight = Matrix3::identity() * 0.01;
        let near = tag_joint_likelihood(&tag, &tight, &Point3::new(1.1, 1.0, 1.0), 0.05).unwrap();
        let far = tag_joint_likelihood(&tag, &tight, &Point3::new(1.6, 1.0, 1.0), 0.05).unwrap();
        assert!(near.log_likelihood > far.log_likelihood);
        assert!(near.score > 0.8 && far.score < 0.01, "{near:?} {far:?}");
        let loose = Matrix3::identity() * 4.0;
        let far_loose =
            tag_joint_likelihood(&tag, &loose, &Point3::new(1.6, 1.0, 1.0), 0.05).unwrap();
        assert!(far_loose.score > 0.9);
        assert!(
            tag_joint_likelihood(&tag, &tight, &Point3::new(f64::NAN, 0.0, 0.0), 0.05).is_none()
        );
    }

    #[test]
    fn key_joint_defaults_to_the_wearing_site() {
        let reg = Registry {
            subjects: vec![Subject {
                id: "ana".into(),
                name: None,
                wears: vec![Wearable {
                    device: TagId::new("t"),
                    kind: DeviceKind::UwbTag,
                    site: Joint::RightWrist,
                    either_side: false,
                    clock: Default::default(),
                }],
            }],
            ..Default::default()
        };
        let mut keys = KeyJoints::default();
        assert_eq!(
            keys.key_joint(&reg, &TagId::new("t")),
            Some(Joint::RightWrist)
        );
        assert_eq!(keys.key_joint(&reg, &TagId::new("nobody")), None);
        keys.overrides.insert(TagId::new("t"), Joint::Chest);
        assert_eq!(keys.key_joint(&reg, &TagId::new("t")), Some(Joint::Chest));
    }
}
