//! Closed-form least-squares fit of a rigid or similarity transform to point pairs, and the
//! residual report with its "poor fit" rule.
//!
//! Umeyama (1991), *Least-squares estimation of transformation parameters between two point
//! patterns*, IEEE TPAMI 13(4): with centroids `μx`, `μy`, source variance `σx²` and the
//! cross-covariance `Σ = 1/n Σ (y − μy)(x − μx)ᵀ = U D Vᵀ`,
//!
//! ```text
//! S = diag(1, 1, sign(det U · det V)),   R = U S Vᵀ,   c = tr(D S) / σx²,   t = μy − c R μx
//! ```
//!
//! minimises `Σ ‖y − (c R x + t)‖²`. The rigid fit (Kabsch) is the same with `c = 1`. The sign
//! matrix `S` keeps `R` a proper rotation when the best orthogonal matrix would be a reflection.

use crate::error::{CalibError, Result, check_positive};
use nalgebra::{Isometry3, Matrix3, Matrix4, Point3, Translation3, UnitQuaternion, Vector3};
use nomen_core::RigidTransform;
use serde::{Deserialize, Serialize};

/// Which transform family to fit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum FitKind {
    /// Rotation and translation (both frames in metres).
    #[default]
    Rigid,
    /// Rotation, translation and one uniform scale (a frame in unknown or wrong units).
    Similarity,
}

/// `target = scale · (rotation · source) + translation`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SimilarityTransform {
    /// Uniform scale (1 for a rigid fit).
    pub scale: f64,
    /// Rotation and translation (metres in the target frame).
    pub isometry: Isometry3<f64>,
}

impl SimilarityTransform {
    /// The identity.
    pub fn identity() -> Self {
        Self {
            scale: 1.0,
            isometry: Isometry3::identity(),
        }
    }

    /// The rotation part.
    pub fn rotation(&self) -> UnitQuaternion<f64> {
        self.isometry.rotation
    }

    /// The translation, metres.
    pub fn translation_m(&self) -> Vector3<f64> {
        self.isometry.translation.vector
    }

    /// Maps a source point into the target frame.
    pub fn apply(&self, p: &Point3<f64>) -> Point3<f64> {
        self.isometry * Point3::from(p.coords * self.scale)
    }

    /// The inverse transform (`source_from_target`).
    pub fn inverse(&self) -> Self {
        let inv_scale = 1.0 / self.scale;
        let r_inv = self.isometry.rotation.inverse();
        let t = -(r_inv * self.isometry.translation.vector) * inv_scale;
        Self {
            scale: inv_scale,
            isometry: Isometry3::from_parts(Translation3::from(t), r_inv),
        }
    }

    /// `self ∘ other`: first `other`, then `self` (`a_from_c = a_from_b.compose(&b_from_c)`).
    pub fn compose(&self, other: &Self) -> Self {
        let r = self.isometry.rotation * other.isometry.rotation;
        let t = self.scale * (self.isometry.rotation * other.isometry.translation.vector)
            + self.isometry.translation.vector;
        Self {
            scale: self.scale * other.scale,
            isometry: Isometry3::from_parts(Translation3::from(t), r),
        }
    }

    /// The 4×4 homogeneous matrix.
    pub fn to_homogeneous(&self) -> Matrix4<f64> {
        let mut m = self.isometry.to_homogeneous();
        let scaled = m.fixed_view::<3, 3>(0, 0) * self.scale;
        m.fixed_view_mut::<3, 3>(0, 0).copy_from(&scaled);
        m
    }

    /// As nomen's file-level transform; the scale is dropped (check [`Self::scale`] first).
    pub fn to_rigid_transform(&self) -> RigidTransform {
        RigidTransform::from_isometry(&self.isometry)
    }

    /// From nomen's file-level transform (scale 1).
    pub fn from_rigid_transform(t: &RigidTransform) -> Self {
        Self {
            scale: 1.0,
            isometry: t.to_isometry(),
        }
    }
}

fn is_finite_point(p: &Point3<f64>) -> bool {
    p.iter().all(|v| v.is_finite())
}

/// Singular values (descending) of the centred source points' scatter, metres (RMS spread along
/// the three principal axes). The second one near zero means the points lie on a line.
pub fn principal_spread_m(points: &[Point3<f64>]) -> [f64; 3] {
    let n = points.len();
    if n == 0 {
        return [0.0; 3];
    }
    let mean = points.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / n as f64;
    let mut c = Matrix3::zeros();
    for p in points {
        let d = p.coords - mean;
        c += d * d.transpose();
    }
    c /= n as f64;
    let mut ev: Vec<f64> = c
        .symmetric_eigenvalues()
        .iter()
        .map(|v| v.max(0.0).sqrt())
        .collect();
    ev.sort_by(|a, b| b.total_cmp(a));
    [ev[0], ev[1], ev[2]]
}

/// Smallest spread (second principal axis, m) below which the points count as collinear and the
/// rotation about their line is undetermined.
const MIN_SPREAD_M: f64 = 1e-9;

/// Umeyama's fit of `target ≈ T(source)` over finite pairs (pairs with a non-finite coordinate
/// are skipped). Needs three pairs that are not on one line.
pub fn fit_transform(
    source: &[Point3<f64>],
    target: &[Point3<f64>],
    kind: FitKind,
) -> Result<SimilarityTransform> {
    if source.len() != target.len() {
        return Err(CalibError::LengthMismatch {
            what: "umeyama fit",
            source_len: source.len(),
            target_len: target.len(),
        });
    }
    let pairs: Vec<(Point3<f64>, Point3<f64>)> = source
        .iter()
        .zip(target)
        .filter(|(x, y)| is_finite_point(x) && is_finite_point(y))
        .map(|(x, y)| (*x, *y))
        .collect();
    fit_pairs(&pairs, kind)
}

/// Kabsch's rigid fit (Umeyama with the scale fixed at 1).
pub fn kabsch(source: &[Point3<f64>], target: &[Point3<f64>]) -> Result<SimilarityTransform> {
    fit_transform(source, target, FitKind::Rigid)
}

pub(crate) fn fit_pairs(
    pairs: &[(Point3<f64>, Point3<f64>)],
    kind: FitKind,
) -> Result<SimilarityTransform> {
    let n = pairs.len();
    if n < 3 {
        return Err(CalibError::TooFewPoints {
            what: "umeyama fit",
            needed: 3,
            got: n,
        });
    }
    let nf = n as f64;
    let mu_x = pairs
        .iter()
        .fold(Vector3::zeros(), |a, (x, _)| a + x.coords)
        / nf;
    let mu_y = pairs
        .iter()
        .fold(Vector3::zeros(), |a, (_, y)| a + y.coords)
        / nf;
    let mut sigma = Matrix3::zeros();
    let mut var_x = 0.0;
    for (x, y) in pairs {
        let dx = x.coords - mu_x;
        let dy = y.coords - mu_y;
        sigma += dy * dx.transpose();
        var_x += dx.norm_squared();
    }
    sigma /= nf;
    var_x /= nf;
    let svd = sigma.svd(true, true);
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
        return Err(CalibError::Degenerate {
            what: "umeyama fit",
            reason: "singular value decomposition failed".into(),
        });
    };
    let mut d = svd.singular_values;
    // nalgebra returns singular values unsorted in general: sort with their vectors.
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| d[b].total_cmp(&d[a]));
    let u = Matrix3::from_columns(&[u.column(order[0]), u.column(order[1]), u.column(order[2])]);
    let v_t = Matrix3::from_rows(&[v_t.row(order[0]), v_t.row(order[1]), v_t.row(order[2])]);
    d = Vector3::new(d[order[0]], d[order[1]], d[order[2]]);
    let spread = principal_spread_m(&pairs.iter().map(|(x, _)| *x).collect::<Vec<_>>());
    if spread[1] <= MIN_SPREAD_M * (1.0 + spread[0]) {
        return Err(CalibError::Degenerate {
            what: "umeyama fit",
            reason: format!(
                "points lie on a line (principal spreads {:.3e}, {:.3e}, {:.3e} m)",
                spread[0], spread[1], spread[2]
            ),
        });
    }
    let det_sign = if u.determinant() * v_t.determinant() < 0.0 {
        -1.0
    } else {
        1.0
    };
    let s = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, det_sign));
    let r = u * s * v_t;
    let scale = match kind {
        FitKind::Rigid => 1.0,
        FitKind::Similarity => (d[0] + d[1] + det_sign * d[2]) / var_x,
    };
    if !(scale.is_finite() && scale > 0.0) {
        return Err(CalibError::Degenerate {
            what: "umeyama fit",
            reason: format!("scale {scale} is not positive"),
        });
    }
    let rotation = UnitQuaternion::from_matrix(&r);
    let t = mu_y - scale * (rotation * mu_x);
    Ok(SimilarityTransform {
        scale,
        isometry: Isometry3::from_parts(Translation3::from(t), rotation),
    })
}

/// Euclidean residuals `‖target − T(source)‖`, metres (NaN where a point is not finite).
pub fn residuals_m(
    transform: &SimilarityTransform,
    source: &[Point3<f64>],
    target: &[Point3<f64>],
) -> Vec<f64> {
    source
        .iter()
        .zip(target)
        .map(|(x, y)| (y - transform.apply(x)).norm())
        .collect()
}

/// Thresholds of the "poor fit" rule (see [`ResidualReport::new`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FitQualityConfig {
    /// Fewer inlier pairs than this is a warning. Default 6: the low end of the 6–10 known
    /// points Belmonte-Hernández's calibration tool asks for (three pairs fix a transform exactly
    /// and leave no residual to judge it by).
    pub min_points: usize,
    /// An inlier RMS residual above this is a warning, m. Default 0.05 m for surveyed points;
    /// use about twice the sensor's 3D error when fitting noisy fixes.
    pub max_rmse_m: f64,
    /// An inlier fraction below this is a warning. Default 0.7 (more than 30 % of the pairs
    /// disagree with the fit: mismatched points or a wrong clock offset).
    pub min_inlier_fraction: f64,
    /// A second principal spread of the source points below this is a warning, m: the points
    /// are nearly on one line and the rotation about it is poorly determined. Default 0.3 m.
    pub min_spread_m: f64,
    /// A similarity scale further than this from 1 is a warning (a unit mistake?). Default 0.05.
    pub max_scale_deviation: f64,
    /// A median residual over all pairs above this is a warning, m: most pairs disagree with the
    /// fit. Default 0.05 m for surveyed points; use about three times the median a good fit
    /// leaves when fitting noisy fixes.
    pub max_median_m: f64,
}

impl Default for FitQualityConfig {
    fn default() -> Self {
        Self {
            min_points: 6,
            max_rmse_m: 0.05,
            min_inlier_fraction: 0.7,
            min_spread_m: 0.3,
            max_scale_deviation: 0.05,
            max_median_m: 0.05,
        }
    }
}

impl FitQualityConfig {
    /// The rule for a tagged walk, where the targets are location fixes with about 0.4 m of 3D
    /// noise rather than surveyed points: an inlier RMS above 0.5 m or a median residual above
    /// 1 m (about three times the 0.35 m median a right fit leaves against UWB fixes) is poor.
    pub fn for_location_fixes() -> Self {
        Self {
            max_rmse_m: 0.5,
            max_median_m: 1.0,
            ..Self::default()
        }
    }

    /// Checks every field.
    pub fn validate(&self) -> Result<()> {
        check_positive("max_rmse_m", self.max_rmse_m)?;
        check_positive("min_spread_m", self.min_spread_m)?;
        check_positive("max_scale_deviation", self.max_scale_deviation)?;
        check_positive("max_median_m", self.max_median_m)?;
        if !(0.0..=1.0).contains(&self.min_inlier_fraction) {
            return Err(CalibError::InvalidParameter {
                name: "min_inlier_fraction",
                reason: format!("must be in 0..=1, got {}", self.min_inlier_fraction),
            });
        }
        Ok(())
    }
}

/// Why a fit is poor.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum FitWarning {
    /// Too few inlier pairs.
    TooFewPoints {
        /// Inliers.
        num_inliers: usize,
        /// Threshold.
        min_points: usize,
    },
    /// The inlier residual is large.
    LargeResidual {
        /// Inlier RMS residual, m.
        rmse_m: f64,
        /// Threshold, m.
        max_rmse_m: f64,
    },
    /// Many pairs are outliers.
    FewInliers {
        /// Inlier fraction.
        inlier_fraction: f64,
        /// Threshold.
        min_inlier_fraction: f64,
    },
    /// The source points are nearly collinear.
    NearlyCollinear {
        /// Second principal spread, m.
        spread_m: f64,
        /// Threshold, m.
        min_spread_m: f64,
    },
    /// The similarity scale is far from 1.
    ScaleNotOne {
        /// Fitted scale.
        scale: f64,
    },
    /// The median residual over all pairs is large.
    LargeMedianResidual {
        /// Median residual, m.
        median_m: f64,
        /// Threshold, m.
        max_median_m: f64,
    },
}

impl FitWarning {
    /// Whether the warning says that the transform does not explain the pairs (too few
    /// inliers, few inliers, a large inlier or median residual), rather than that it may be
    /// poorly determined (nearly collinear points) or surprising (a scale far from 1).
    pub fn is_disqualifying(&self) -> bool {
        match self {
            Self::TooFewPoints { .. }
            | Self::LargeResidual { .. }
            | Self::FewInliers { .. }
            | Self::LargeMedianResidual { .. } => true,
            Self::NearlyCollinear { .. } | Self::ScaleNotOne { .. } => false,
        }
    }
}

impl std::fmt::Display for FitWarning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::TooFewPoints {
                num_inliers,
                min_points,
            } => write!(
                f,
                "only {num_inliers} inlier pairs (want at least {min_points})"
            ),
            Self::LargeResidual { rmse_m, max_rmse_m } => write!(
                f,
                "inlier RMS residual {:.1} cm exceeds {:.1} cm",
                rmse_m * 100.0,
                max_rmse_m * 100.0
            ),
            Self::FewInliers {
                inlier_fraction,
                min_inlier_fraction,
            } => write!(
                f,
                "only {:.0}% of the pairs are inliers (want at least {:.0}%)",
                inlier_fraction * 100.0,
                min_inlier_fraction * 100.0
            ),
            Self::NearlyCollinear {
                spread_m,
                min_spread_m,
            } => write!(
                f,
                "points are nearly on one line (second spread {:.2} m < {:.2} m): walk a loop, not a line",
                spread_m, min_spread_m
            ),
            Self::ScaleNotOne { scale } => write!(
                f,
                "scale {scale:.4} differs from 1: are both frames in metres?"
            ),
            Self::LargeMedianResidual {
                median_m,
                max_median_m,
            } => write!(
                f,
                "median residual {:.1} cm exceeds {:.1} cm",
                median_m * 100.0,
                max_median_m * 100.0
            ),
        }
    }
}

/// Residual statistics of a fit and the warnings of the "poor fit" rule.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ResidualReport {
    /// Pairs with finite residuals.
    pub num_points: usize,
    /// Pairs counted as inliers.
    pub num_inliers: usize,
    /// RMS residual over inliers, m.
    pub rmse_inliers_m: f64,
    /// RMS residual over all pairs, m.
    pub rmse_all_m: f64,
    /// Median residual over all pairs, m.
    pub median_m: f64,
    /// 95th percentile of the residual over all pairs, m.
    pub p95_m: f64,
    /// Largest residual, m.
    pub max_m: f64,
    /// Second principal spread of the inlier source points, m.
    pub spread_m: f64,
    /// Fitted scale.
    pub scale: f64,
    /// The warnings; empty for a good fit.
    pub warnings: Vec<FitWarning>,
}

/// Percentile `q ∈ [0, 1]` of sorted values, linear interpolation (NumPy's default).
pub fn percentile_sorted(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let pos = q.clamp(0.0, 1.0) * (sorted.len() - 1) as f64;
    let lo = pos.floor() as usize;
    let hi = pos.ceil() as usize;
    let f = pos - lo as f64;
    sorted[lo] * (1.0 - f) + sorted[hi.min(sorted.len() - 1)] * f
}

fn rms(v: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x * x, n + 1));
    if n == 0 {
        f64::NAN
    } else {
        (s / n as f64).sqrt()
    }
}

impl ResidualReport {
    /// Builds the report. `inliers[i]` says whether pair `i` is an inlier (all pairs for a plain
    /// fit). The fit is **poor** when any of these holds (each adds a [`FitWarning`]): fewer
    /// than `min_points` inliers; inlier RMS above `max_rmse_m`; inlier fraction below
    /// `min_inlier_fraction`; second principal spread of the inlier source points below
    /// `min_spread_m`; for a similarity, `|scale − 1| > max_scale_deviation`; median residual
    /// over all pairs above `max_median_m`.
    pub fn new(
        transform: &SimilarityTransform,
        kind: FitKind,
        source: &[Point3<f64>],
        target: &[Point3<f64>],
        inliers: &[bool],
        config: &FitQualityConfig,
    ) -> Self {
        let residuals = residuals_m(transform, source, target);
        let mut finite: Vec<f64> = residuals
            .iter()
            .copied()
            .filter(|r| r.is_finite())
            .collect();
        finite.sort_by(f64::total_cmp);
        let inlier_residuals: Vec<f64> = residuals
            .iter()
            .zip(inliers)
            .filter(|(r, is_in)| **is_in && r.is_finite())
            .map(|(r, _)| *r)
            .collect();
        let inlier_points: Vec<Point3<f64>> = source
            .iter()
            .zip(inliers)
            .filter(|(p, is_in)| **is_in && is_finite_point(p))
            .map(|(p, _)| *p)
            .collect();
        let num_inliers = inlier_residuals.len();
        let spread_m = principal_spread_m(&inlier_points)[1];
        let rmse_inliers_m = rms(inlier_residuals.iter().copied());
        let mut warnings = Vec::new();
        if num_inliers < config.min_points {
            warnings.push(FitWarning::TooFewPoints {
                num_inliers,
                min_points: config.min_points,
            });
        }
        if rmse_inliers_m.is_nan() || rmse_inliers_m > config.max_rmse_m {
            warnings.push(FitWarning::LargeResidual {
                rmse_m: rmse_inliers_m,
                max_rmse_m: config.max_rmse_m,
            });
        }
        let inlier_fraction = if finite.is_empty() {
            0.0
        } else {
            num_inliers as f64 / finite.len() as f64
        };
        if inlier_fraction < config.min_inlier_fraction {
            warnings.push(FitWarning::FewInliers {
                inlier_fraction,
                min_inlier_fraction: config.min_inlier_fraction,
            });
        }
        if spread_m < config.min_spread_m {
            warnings.push(FitWarning::NearlyCollinear {
                spread_m,
                min_spread_m: config.min_spread_m,
            });
        }
        if kind == FitKind::Similarity && (transform.scale - 1.0).abs() > config.max_scale_deviation
        {
            warnings.push(FitWarning::ScaleNotOne {
                scale: transform.scale,
            });
        }
        let median_m = percentile_sorted(&finite, 0.5);
        if median_m.is_nan() || median_m > config.max_median_m {
            warnings.push(FitWarning::LargeMedianResidual {
                median_m,
                max_median_m: config.max_median_m,
            });
        }
        Self {
            num_points: finite.len(),
            num_inliers,
            rmse_inliers_m,
            rmse_all_m: rms(finite.iter().copied()),
            median_m,
            p95_m: percentile_sorted(&finite, 0.95),
            max_m: finite.last().copied().unwrap_or(f64::NAN),
            spread_m,
            scale: transform.scale,
            warnings,
        }
    }

    /// True when the fit triggered any warning.
    pub fn is_poor(&self) -> bool {
        !self.warnings.is_empty()
    }

    /// True when a warning says the transform does not explain the pairs
    /// ([`FitWarning::is_disqualifying`]): `nomen calibrate frames` then writes nothing and
    /// fails unless told to accept it.
    pub fn is_disqualified(&self) -> bool {
        self.warnings.iter().any(FitWarning::is_disqualifying)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    fn cloud() -> Vec<Point3<f64>> {
        (0..20)
            .map(|i| {
                let f = i as f64;
                Point3::new((f * 0.7).sin() * 3.0, (f * 1.3).cos() * 2.0, 0.1 * f)
            })
            .collect()
    }

    #[test]
    fn umeyama_recovers_a_known_similarity() {
        let truth = SimilarityTransform {
            scale: 1.37,
            isometry: Isometry3::from_parts(
                Translation3::new(-2.0, 0.5, 1.2),
                UnitQuaternion::from_euler_angles(0.3, -1.1, 2.4),
            ),
        };
        let src = cloud();
        let dst: Vec<_> = src.iter().map(|p| truth.apply(p)).collect();
        let fit = fit_transform(&src, &dst, FitKind::Similarity).unwrap();
        assert_relative_eq!(fit.scale, 1.37, epsilon = 1e-10);
        assert!(fit.rotation().angle_to(&truth.rotation()) < 1e-10);
        assert_relative_eq!(fit.translation_m(), truth.translation_m(), epsilon = 1e-9);
        // A rigid fit of the same data cannot absorb the scale: it leaves residuals.
        let rigid = kabsch(&src, &dst).unwrap();
        assert_eq!(rigid.scale, 1.0);
        let worst = residuals_m(&rigid, &src, &dst)
            .into_iter()
            .fold(0.0, f64::max);
        assert!(worst > 0.1, "{worst}");
    }

    #[test]
    fn reflection_is_never_returned() {
        // Planar points mirrored through their plane: the best orthogonal map is a reflection;
        // Umeyama's sign matrix must return a proper rotation.
        let src: Vec<_> = cloud().iter().map(|p| Point3::new(p.x, p.y, 0.0)).collect();
        let dst: Vec<_> = src.iter().map(|p| Point3::new(p.x, -p.y, 0.0)).collect();
        let fit = kabsch(&src, &dst).unwrap();
        let r = fit.rotation().to_rotation_matrix();
        assert_relative_eq!(r.matrix().determinant(), 1.0, epsilon = 1e-9);
    }

    #[test]
    fn collinear_points_are_degenerate() {
        let src: Vec<_> = (0..5).map(|i| Point3::new(i as f64, 0.0, 0.0)).collect();
        let err = kabsch(&src, &src).unwrap_err();
        assert!(matches!(err, CalibError::Degenerate { .. }), "{err}");
        assert!(matches!(
            kabsch(&src[..2], &src[..2]),
            Err(CalibError::TooFewPoints { .. })
        ));
    }

    #[test]
    fn inverse_and_compose_round_trip() {
        let a = SimilarityTransform {
            scale: 0.8,
            isometry: Isometry3::from_parts(
                Translation3::new(1.0, 2.0, 3.0),
                UnitQuaternion::from_euler_angles(0.2, 0.1, -0.5),
            ),
        };
        let p = Point3::new(0.3, -0.7, 2.0);
        assert_relative_eq!(a.inverse().apply(&a.apply(&p)), p, epsilon = 1e-12);
        let id = a.compose(&a.inverse());
        assert_relative_eq!(id.apply(&p), p, epsilon = 1e-12);
        let h = a.to_homogeneous() * p.to_homogeneous();
        assert_relative_eq!(
            Point3::from_homogeneous(h).unwrap(),
            a.apply(&p),
            epsilon = 1e-12
        );
    }

    #[test]
    fn noisy_fit_with_few_points_on_a_line_is_flagged_poor() {
        let src: Vec<_> = (0..4)
            .map(|i| Point3::new(i as f64, 0.01 * (i % 2) as f64, 0.02 * i as f64))
            .collect();
        let dst: Vec<_> = src
            .iter()
            .enumerate()
            .map(|(i, p)| p + Vector3::new(0.0, 0.1 * (i as f64 - 1.5), 0.0))
            .collect();
        let fit = kabsch(&src, &dst).unwrap();
        let report = ResidualReport::new(
            &fit,
            FitKind::Rigid,
            &src,
            &dst,
            &[true; 4],
            &FitQualityConfig::default(),
        );
        assert!(report.is_poor());
        assert!(
            report
                .warnings
                .iter()
                .any(|w| matches!(w, FitWarning::TooFewPoints { .. }))
        );
        assert!(
            report
                .warnings
                .iter()
                .any(|w| matches!(w, FitWarning::NearlyCollinear { .. }))
        );
        // An exact fit on a good spread of points is not poor.
        let good = cloud();
        let fit = kabsch(&good, &good).unwrap();
        let report = ResidualReport::new(
            &fit,
            FitKind::Rigid,
            &good,
            &good,
            &vec![true; good.len()],
            &FitQualityConfig::default(),
        );
        assert!(!report.is_poor(), "{:?}", report.warnings);
    }
}
