//! RANSAC around Umeyama's fit (Fischler & Bolles 1981): fit minimal samples of three pairs,
//! keep the transform with the largest consensus (ties: the smaller inlier residual), then refit
//! on the consensus and re-collect inliers until the set stops changing.

use crate::error::{CalibError, Result, check_positive};
use crate::fit::{FitKind, SimilarityTransform, fit_pairs};
use nalgebra::Point3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// RANSAC settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RansacConfig {
    /// Minimal samples drawn. Default 500: with 30 % outliers a 3-pair sample is clean with
    /// probability 0.343, so 500 draws miss every clean sample with probability < 1e-90.
    pub num_iterations: usize,
    /// A pair is an inlier when its residual is below this, m. Default 0.5 m: about 1.5 × the
    /// 3D RMS error of a UWB fix with the simulator's default noise (0.37 m); use a few
    /// centimetres for surveyed points.
    pub inlier_threshold_m: f64,
    /// Refit-and-recollect rounds after the best sample. Default 5.
    pub num_refinements: usize,
    /// Seed of the sample stream (ChaCha8).
    pub seed: u64,
}

impl Default for RansacConfig {
    fn default() -> Self {
        Self {
            num_iterations: 500,
            inlier_threshold_m: 0.5,
            num_refinements: 5,
            seed: 0,
        }
    }
}

/// A RANSAC result.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RansacFit {
    /// The transform refitted on the inliers.
    pub transform: SimilarityTransform,
    /// Per input pair: is it an inlier of the final transform?
    pub inliers: Vec<bool>,
    /// Number of inliers.
    pub num_inliers: usize,
}

fn consensus(
    t: &SimilarityTransform,
    pairs: &[(Point3<f64>, Point3<f64>)],
    threshold_m: f64,
) -> (Vec<bool>, usize, f64) {
    let mut inliers = Vec::with_capacity(pairs.len());
    let mut n = 0;
    let mut sum2 = 0.0;
    for (x, y) in pairs {
        let r = (y - t.apply(x)).norm();
        let is_in = r.is_finite() && r < threshold_m;
        if is_in {
            n += 1;
            sum2 += r * r;
        }
        inliers.push(is_in);
    }
    (inliers, n, sum2)
}

/// Robust fit of `target ≈ T(source)`. Pairs with a non-finite coordinate are never inliers.
pub fn fit_ransac(
    source: &[Point3<f64>],
    target: &[Point3<f64>],
    kind: FitKind,
    config: &RansacConfig,
) -> Result<RansacFit> {
    if source.len() != target.len() {
        return Err(CalibError::LengthMismatch {
            what: "ransac fit",
            source_len: source.len(),
            target_len: target.len(),
        });
    }
    check_positive("inlier_threshold_m", config.inlier_threshold_m)?;
    let pairs: Vec<(Point3<f64>, Point3<f64>)> =
        source.iter().copied().zip(target.iter().copied()).collect();
    let finite: Vec<usize> = (0..pairs.len())
        .filter(|&i| {
            let (x, y) = &pairs[i];
            x.iter().chain(y.iter()).all(|v| v.is_finite())
        })
        .collect();
    if finite.len() < 3 {
        return Err(CalibError::TooFewPoints {
            what: "ransac fit",
            needed: 3,
            got: finite.len(),
        });
    }
    let mut rng = ChaCha8Rng::seed_from_u64(config.seed);
    let mut best: Option<(SimilarityTransform, usize, f64)> = None;
    for _ in 0..config.num_iterations.max(1) {
        let a = finite[rng.random_range(0..finite.len())];
        let b = finite[rng.random_range(0..finite.len())];
        let c = finite[rng.random_range(0..finite.len())];
        if a == b || b == c || a == c {
            continue;
        }
        // Degenerate (collinear) samples fail the fit and are simply skipped.
        let Ok(t) = fit_pairs(&[pairs[a], pairs[b], pairs[c]], kind) else {
            continue;
        };
        let (_, n, sum2) = consensus(&t, &pairs, config.inlier_threshold_m);
        let is_better = match &best {
            None => true,
            Some((_, bn, bs)) => n > *bn || (n == *bn && sum2 < *bs),
        };
        if is_better {
            best = Some((t, n, sum2));
        }
    }
    // Every sample degenerate (or too few distinct pairs): fall back to the plain fit.
    let mut transform = match best {
        Some((t, _, _)) => t,
        None => {
            let all: Vec<_> = finite.iter().map(|&i| pairs[i]).collect();
            fit_pairs(&all, kind)?
        }
    };
    let (mut inliers, mut n, _) = consensus(&transform, &pairs, config.inlier_threshold_m);
    for _ in 0..config.num_refinements {
        let chosen: Vec<_> = pairs
            .iter()
            .zip(&inliers)
            .filter(|(_, is_in)| **is_in)
            .map(|(p, _)| *p)
            .collect();
        let Ok(t) = fit_pairs(&chosen, kind) else {
            break;
        };
        let (new_inliers, new_n, _) = consensus(&t, &pairs, config.inlier_threshold_m);
        if new_n < n {
            break;
        }
        let is_same = new_inliers == inliers;
        transform = t;
        inliers = new_inliers;
        n = new_n;
        if is_same {
            break;
        }
    }
    Ok(RansacFit {
        transform,
        inliers,
        num_inliers: n,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
    use rand_distr::{Distribution, Normal};

    #[test]
    fn ransac_rejects_thirty_percent_outliers() {
        let truth = SimilarityTransform {
            scale: 1.0,
            isometry: Isometry3::from_parts(
                Translation3::new(3.0, -1.0, 0.4),
                UnitQuaternion::from_euler_angles(0.05, -0.02, 1.9),
            ),
        };
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let noise = Normal::new(0.0, 0.01).unwrap();
        let n = 60;
        let src: Vec<Point3<f64>> = (0..n)
            .map(|_| {
                Point3::new(
                    rng.random_range(-3.0..3.0),
                    rng.random_range(-2.0..2.0),
                    rng.random_range(0.0..2.0),
                )
            })
            .collect();
        let mut dst: Vec<Point3<f64>> = src
            .iter()
            .map(|p| {
                truth.apply(p)
                    + Vector3::new(
                        noise.sample(&mut rng),
                        noise.sample(&mut rng),
                        noise.sample(&mut rng),
                    )
            })
            .collect();
        let num_outliers = n * 3 / 10;
        for d in dst.iter_mut().take(num_outliers) {
            *d += Vector3::new(
                rng.random_range(1.0..5.0),
                -rng.random_range(1.0..5.0),
                rng.random_range(-2.0..2.0),
            );
        }
        let cfg = RansacConfig {
            inlier_threshold_m: 0.05,
            seed: 3,
            ..RansacConfig::default()
        };
        let fit = fit_ransac(&src, &dst, FitKind::Rigid, &cfg).unwrap();
        assert_eq!(fit.num_inliers, n - num_outliers);
        assert!(fit.inliers[..num_outliers].iter().all(|i| !i));
        assert!(fit.transform.rotation().angle_to(&truth.rotation()) < 0.01);
        assert!((fit.transform.translation_m() - truth.translation_m()).norm() < 0.02);
        // The plain least-squares fit is dragged away by the same outliers.
        let plain = crate::fit::kabsch(&src, &dst).unwrap();
        assert!((plain.translation_m() - truth.translation_m()).norm() > 0.2);
    }
}
