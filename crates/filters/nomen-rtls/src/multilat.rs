//! Tag position from raw UWB ranges: two-way-ranging (TWR) multilateration and time difference
//! of arrival (TDoA), by robust nonlinear least squares, plus range-bias handling.
//!
//! **Model.** TWR measures `ρᵢ = ‖x − aᵢ‖ + bias + noise`; TDoA measures range differences
//! `δᵢ = ‖x − aᵢ‖ − ‖x − a_ref‖ + noise` to a reference anchor. Biases are removed before the
//! solve with a [`RangeBias`] (a constant plus a per-anchor term, given in configuration or
//! estimated from data with ground truth by [`estimate_range_bias`]).
//!
//! **Solver.** Levenberg–Marquardt on the residuals `rᵢ(x)` with iteratively reweighted least
//! squares for a robust loss (Huber or Cauchy): each iteration weighs residuals by
//! `w(r) = ρ'(r)/r`, solves `(JᵀWJ + λ·diag(JᵀWJ)) δ = −JᵀW r`, and accepts the step if the
//! robust cost `Σ ρ(rᵢ)` falls (λ shrinks) or retries with a larger λ. Three unknowns, so the
//! normal equations are a 3×3 solve written by hand: the `levenberg-marquardt` crate (0.15) was
//! measured at 11.4 s of release build but pulls **nalgebra 0.34**, a second copy beside the
//! workspace's 0.35, for a problem this size gains nothing.
//!
//! **Geometry.** Anchors on one plane (ceiling or wall height) leave the height mirrored about
//! that plane and poorly determined near it. [`HeightConstraint::Fixed`] solves for x and y
//! only (a trolley, or a tag at a known body height); otherwise the start point is placed
//! `start_below_anchors_m` below the anchors' mean height so the solver settles on the floor
//! side.

use crate::error::{Result, RtlsError, check_positive};
use nalgebra::{Matrix3, Point3, Vector3};
use nomen_filters::median;
use serde::{Deserialize, Serialize};

/// One TWR range to an anchor.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AnchorRange {
    /// Anchor position, world frame, m.
    pub anchor_m: Point3<f64>,
    /// Measured range with its bias already removed, m.
    pub range_m: f64,
}

/// One TDoA measurement: `‖x − anchor‖ − ‖x − reference‖`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RangeDifference {
    /// The anchor, m.
    pub anchor_m: Point3<f64>,
    /// The reference anchor, m.
    pub reference_m: Point3<f64>,
    /// Measured range difference, m.
    pub difference_m: f64,
}

/// Robust loss of the residuals.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum RobustLoss {
    /// Plain least squares.
    Squared,
    /// Huber: quadratic within `k_m`, linear beyond.
    Huber {
        /// Threshold, m.
        k_m: f64,
    },
    /// Cauchy (Lorentzian): `c²/2 · ln(1 + (r/c)²)`, redescending.
    Cauchy {
        /// Scale, m.
        c_m: f64,
    },
}

impl RobustLoss {
    fn rho(&self, r: f64) -> f64 {
        match *self {
            Self::Squared => 0.5 * r * r,
            Self::Huber { k_m } => {
                if r.abs() <= k_m {
                    0.5 * r * r
                } else {
                    k_m * r.abs() - 0.5 * k_m * k_m
                }
            }
            Self::Cauchy { c_m } => 0.5 * c_m * c_m * (r / c_m).powi(2).ln_1p(),
        }
    }

    fn weight(&self, r: f64) -> f64 {
        match *self {
            Self::Squared => 1.0,
            Self::Huber { k_m } => {
                if r.abs() <= k_m {
                    1.0
                } else {
                    k_m / r.abs()
                }
            }
            Self::Cauchy { c_m } => 1.0 / (1.0 + (r / c_m).powi(2)),
        }
    }
}

/// Whether the height is solved for.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum HeightConstraint {
    /// Solve x, y and z.
    Free,
    /// z is known, m; solve x and y.
    Fixed(f64),
}

/// Solver settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MultilaterationConfig {
    /// Robust loss. Default Huber with k = 0.1 m: 1.5 × the LIAS core range σ (0.066 m), so
    /// core errors are treated as Gaussian and the heavy tail (5 %, mean excess 0.11 m) and
    /// NLOS ranges are down-weighted.
    pub loss: RobustLoss,
    /// Height handling.
    pub height: HeightConstraint,
    /// Iteration cap. Default 50.
    pub max_iterations: usize,
    /// Stop when a step moves the position less than this, m. Default 1e-9 m.
    pub tolerance_m: f64,
    /// Start this far below the anchors' mean height when no start point is given, m.
    /// Default 1.0 m (ceiling anchors, body-worn tags).
    pub start_below_anchors_m: f64,
    /// Range noise σ used for the reported covariance, m. Default 0.095 m: the LIAS raw range
    /// error σ including the spread of anchor biases (`docs/sensor-models.md`).
    pub range_sigma_m: f64,
}

impl Default for MultilaterationConfig {
    fn default() -> Self {
        Self {
            loss: RobustLoss::Huber { k_m: 0.1 },
            height: HeightConstraint::Free,
            max_iterations: 50,
            tolerance_m: 1e-9,
            start_below_anchors_m: 1.0,
            range_sigma_m: 0.095,
        }
    }
}

impl MultilaterationConfig {
    fn validate(&self) -> Result<()> {
        match self.loss {
            RobustLoss::Squared => {}
            RobustLoss::Huber { k_m } => check_positive("loss.k_m", k_m)?,
            RobustLoss::Cauchy { c_m } => check_positive("loss.c_m", c_m)?,
        }
        if let HeightConstraint::Fixed(z) = self.height
            && !z.is_finite()
        {
            return Err(RtlsError::InvalidParameter {
                name: "height",
                reason: format!("fixed height must be finite, got {z}"),
            });
        }
        check_positive("tolerance_m", self.tolerance_m)?;
        check_positive("range_sigma_m", self.range_sigma_m)
    }

    fn num_unknowns(&self) -> usize {
        match self.height {
            HeightConstraint::Free => 3,
            HeightConstraint::Fixed(_) => 2,
        }
    }
}

/// A solved position.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PositionSolution {
    /// Position, world frame, m.
    pub position_m: Point3<f64>,
    /// Covariance `σ² (JᵀWJ)⁻¹`, m² (with a fixed height, the z variance is `σ²`).
    pub covariance_m2: Matrix3<f64>,
    /// RMS of the final residuals, m.
    pub residual_rms_m: f64,
    /// Iterations taken.
    pub num_iterations: usize,
    /// Measurements used.
    pub num_measurements: usize,
    /// Whether the step tolerance was reached within the iteration cap.
    pub is_converged: bool,
}

/// Residual and gradient of measurement `i` at `x`.
type Model<'a> = &'a dyn Fn(usize, &Point3<f64>) -> Option<(f64, Vector3<f64>)>;

/// A redescending loss (Cauchy) has local minima far from the truth: start it from the Huber
/// solution with the same scale, which is convex.
fn solve(
    what: &'static str,
    num_measurements: usize,
    model: Model<'_>,
    start: Point3<f64>,
    config: &MultilaterationConfig,
) -> Result<PositionSolution> {
    let RobustLoss::Cauchy { c_m } = config.loss else {
        return solve_from(what, num_measurements, model, start, config);
    };
    let convex = MultilaterationConfig {
        loss: RobustLoss::Huber { k_m: c_m },
        ..*config
    };
    let first = solve_from(what, num_measurements, model, start, &convex)?;
    let mut second = solve_from(what, num_measurements, model, first.position_m, config)?;
    second.num_iterations += first.num_iterations;
    Ok(second)
}

fn solve_from(
    what: &'static str,
    num_measurements: usize,
    model: Model<'_>,
    start: Point3<f64>,
    config: &MultilaterationConfig,
) -> Result<PositionSolution> {
    let p = config.num_unknowns();
    if num_measurements < p {
        return Err(RtlsError::TooFewMeasurements {
            what,
            needed: p,
            got: num_measurements,
        });
    }
    let mask = |g: Vector3<f64>| {
        if p == 2 {
            Vector3::new(g.x, g.y, 0.0)
        } else {
            g
        }
    };
    let cost = |x: &Point3<f64>| -> f64 {
        (0..num_measurements)
            .map(|i| model(i, x).map_or(f64::INFINITY, |(r, _)| config.loss.rho(r)))
            .sum()
    };
    let mut x = start;
    if let HeightConstraint::Fixed(z) = config.height {
        x.z = z;
    }
    let mut current = cost(&x);
    let mut lambda = 1e-3;
    let mut num_iterations = 0;
    let mut is_converged = false;
    while num_iterations < config.max_iterations {
        num_iterations += 1;
        let mut jtwj = Matrix3::zeros();
        let mut jtwr = Vector3::zeros();
        for i in 0..num_measurements {
            let Some((r, g)) = model(i, &x) else { continue };
            let g = mask(g);
            let w = config.loss.weight(r);
            jtwj += w * g * g.transpose();
            jtwr += w * r * g;
        }
        if p == 2 {
            jtwj[(2, 2)] = 1.0;
        }
        let mut accepted = false;
        for _ in 0..20 {
            let mut a = jtwj;
            for i in 0..3 {
                a[(i, i)] += lambda * jtwj[(i, i)].max(1e-12);
            }
            let Some(delta) = a.lu().solve(&(-jtwr)) else {
                lambda *= 4.0;
                continue;
            };
            let delta = mask(delta);
            let candidate = x + delta;
            let c = cost(&candidate);
            if c.is_finite() && c <= current {
                let step = delta.norm();
                x = candidate;
                current = c;
                lambda = (lambda / 3.0).max(1e-12);
                accepted = true;
                if step < config.tolerance_m {
                    is_converged = true;
                }
                break;
            }
            lambda *= 4.0;
        }
        if !accepted {
            // No step lowers the cost: at a (local) minimum to machine precision.
            is_converged = true;
        }
        if is_converged {
            break;
        }
    }
    if !x.iter().all(|v| v.is_finite()) {
        return Err(RtlsError::NoSolution {
            what,
            reason: "the solution is not finite".into(),
        });
    }
    let mut jtwj = Matrix3::zeros();
    let mut sum2 = 0.0;
    let mut n = 0usize;
    for i in 0..num_measurements {
        if let Some((r, g)) = model(i, &x) {
            let g = mask(g);
            jtwj += config.loss.weight(r) * g * g.transpose();
            sum2 += r * r;
            n += 1;
        }
    }
    let sigma2 = config.range_sigma_m.powi(2);
    if p == 2 {
        jtwj[(2, 2)] = 1.0;
    }
    let covariance_m2 = jtwj
        .try_inverse()
        .map(|inv| inv * sigma2)
        .filter(|c| c.iter().all(|v| v.is_finite()))
        .ok_or_else(|| RtlsError::NoSolution {
            what,
            reason: "the anchor geometry does not determine the position".into(),
        })?;
    Ok(PositionSolution {
        position_m: x,
        covariance_m2,
        residual_rms_m: if n > 0 {
            (sum2 / n as f64).sqrt()
        } else {
            f64::NAN
        },
        num_iterations,
        num_measurements: n,
        is_converged,
    })
}

fn default_start(anchors: &[Point3<f64>], config: &MultilaterationConfig) -> Point3<f64> {
    let n = anchors.len().max(1) as f64;
    let mean = anchors.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / n;
    Point3::new(mean.x, mean.y, mean.z - config.start_below_anchors_m)
}

fn is_finite_point(p: &Point3<f64>) -> bool {
    p.iter().all(|v| v.is_finite())
}

/// TWR multilateration. Ranges with a non-finite or negative value are skipped. `start` is the
/// initial position (e.g. the last fix); `None` uses the default start (see the module docs).
pub fn solve_twr(
    ranges: &[AnchorRange],
    start: Option<Point3<f64>>,
    config: &MultilaterationConfig,
) -> Result<PositionSolution> {
    config.validate()?;
    let usable: Vec<AnchorRange> = ranges
        .iter()
        .filter(|r| r.range_m.is_finite() && r.range_m >= 0.0 && is_finite_point(&r.anchor_m))
        .copied()
        .collect();
    let model = |i: usize, x: &Point3<f64>| {
        let m = usable.get(i)?;
        let d = x - m.anchor_m;
        let dist = d.norm();
        (dist > 1e-12).then(|| (dist - m.range_m, d / dist))
    };
    let anchors: Vec<Point3<f64>> = usable.iter().map(|m| m.anchor_m).collect();
    let start = start
        .filter(is_finite_point)
        .unwrap_or_else(|| default_start(&anchors, config));
    solve("twr multilateration", usable.len(), &model, start, config)
}

/// TDoA multilateration on range differences (skips non-finite ones).
pub fn solve_tdoa(
    differences: &[RangeDifference],
    start: Option<Point3<f64>>,
    config: &MultilaterationConfig,
) -> Result<PositionSolution> {
    config.validate()?;
    let usable: Vec<RangeDifference> = differences
        .iter()
        .filter(|m| {
            m.difference_m.is_finite()
                && is_finite_point(&m.anchor_m)
                && is_finite_point(&m.reference_m)
        })
        .copied()
        .collect();
    let model = |i: usize, x: &Point3<f64>| {
        let m = usable.get(i)?;
        let da = x - m.anchor_m;
        let dr = x - m.reference_m;
        let (na, nr) = (da.norm(), dr.norm());
        (na > 1e-12 && nr > 1e-12).then(|| (na - nr - m.difference_m, da / na - dr / nr))
    };
    let mut anchors: Vec<Point3<f64>> = usable.iter().map(|m| m.anchor_m).collect();
    if let Some(first) = usable.first() {
        anchors.push(first.reference_m);
    }
    let start = start
        .filter(is_finite_point)
        .unwrap_or_else(|| default_start(&anchors, config));
    solve("tdoa multilateration", usable.len(), &model, start, config)
}

/// Range bias: `measured = true + constant_m + per_anchor_m[anchor] + noise`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct RangeBias {
    /// Bias common to all anchors, m.
    pub constant_m: f64,
    /// Extra bias per anchor index, m (missing entries are 0).
    #[serde(default)]
    pub per_anchor_m: Vec<f64>,
}

impl RangeBias {
    /// The range with the bias removed.
    pub fn correct(&self, anchor: usize, range_m: f64) -> f64 {
        range_m - self.constant_m - self.per_anchor_m.get(anchor).copied().unwrap_or(0.0)
    }

    /// Only the constant part.
    pub fn constant_only(&self) -> Self {
        Self {
            constant_m: self.constant_m,
            per_anchor_m: Vec::new(),
        }
    }
}

/// One range with its truth, for bias estimation.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RangeTruth {
    /// Anchor index.
    pub anchor: usize,
    /// Measured range, m.
    pub measured_m: f64,
    /// True range, m.
    pub true_m: f64,
}

/// Estimates the bias from ranges with ground truth: the constant is the median error (robust to
/// the one-sided NLOS tail), each anchor's term is its own median error minus the constant.
pub fn estimate_range_bias(samples: &[RangeTruth], num_anchors: usize) -> Result<RangeBias> {
    let mut all: Vec<f64> = samples
        .iter()
        .map(|s| s.measured_m - s.true_m)
        .filter(|e| e.is_finite())
        .collect();
    let constant_m = median(&mut all).ok_or(RtlsError::TooFewMeasurements {
        what: "range bias",
        needed: 1,
        got: 0,
    })?;
    let per_anchor_m = (0..num_anchors)
        .map(|a| {
            let mut e: Vec<f64> = samples
                .iter()
                .filter(|s| s.anchor == a)
                .map(|s| s.measured_m - s.true_m)
                .filter(|e| e.is_finite())
                .collect();
            median(&mut e).map_or(0.0, |m| m - constant_m)
        })
        .collect();
    Ok(RangeBias {
        constant_m,
        per_anchor_m,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn anchors() -> Vec<Point3<f64>> {
        vec![
            Point3::new(0.2, 0.2, 2.5),
            Point3::new(7.8, 0.3, 2.4),
            Point3::new(7.7, 5.8, 2.6),
            Point3::new(0.3, 5.7, 2.5),
            Point3::new(4.0, 3.0, 0.3),
        ]
    }

    #[test]
    fn exact_ranges_give_the_position_to_a_micrometre() {
        let truth = Point3::new(3.1, 2.4, 1.05);
        let ranges: Vec<_> = anchors()
            .iter()
            .map(|a| AnchorRange {
                anchor_m: *a,
                range_m: (truth - a).norm(),
            })
            .collect();
        for loss in [
            RobustLoss::Squared,
            RobustLoss::Huber { k_m: 0.1 },
            RobustLoss::Cauchy { c_m: 0.1 },
        ] {
            let cfg = MultilaterationConfig {
                loss,
                ..Default::default()
            };
            let s = solve_twr(&ranges, None, &cfg).unwrap();
            assert!((s.position_m - truth).norm() < 1e-6, "{loss:?}: {s:?}");
            assert!(s.is_converged);
        }
    }

    #[test]
    fn exact_tdoa_gives_the_position_to_a_micrometre() {
        let truth = Point3::new(5.2, 1.4, 1.3);
        let a = anchors();
        let reference = a[0];
        let diffs: Vec<_> = a[1..]
            .iter()
            .map(|p| RangeDifference {
                anchor_m: *p,
                reference_m: reference,
                difference_m: (truth - p).norm() - (truth - reference).norm(),
            })
            .collect();
        let s = solve_tdoa(&diffs, None, &MultilaterationConfig::default()).unwrap();
        assert!((s.position_m - truth).norm() < 1e-6, "{s:?}");
    }

    #[test]
    fn an_nlos_range_is_down_weighted_by_the_robust_loss() {
        let truth = Point3::new(2.0, 3.0, 1.0);
        let mut ranges: Vec<_> = anchors()
            .iter()
            .map(|a| AnchorRange {
                anchor_m: *a,
                range_m: (truth - a).norm(),
            })
            .collect();
        ranges.push(AnchorRange {
            anchor_m: Point3::new(8.0, 3.0, 2.5),
            range_m: (truth - Point3::new(8.0, 3.0, 2.5)).norm() + 1.5,
        });
        let plain = MultilaterationConfig {
            loss: RobustLoss::Squared,
            ..Default::default()
        };
        let e_plain = (solve_twr(&ranges, None, &plain).unwrap().position_m - truth).norm();
        let cauchy = MultilaterationConfig {
            loss: RobustLoss::Cauchy { c_m: 0.1 },
            ..Default::default()
        };
        let e_cauchy = (solve_twr(&ranges, None, &cauchy).unwrap().position_m - truth).norm();
        assert!(e_cauchy < 0.2 * e_plain, "{e_cauchy} vs {e_plain}");
    }

    #[test]
    fn coplanar_anchors_with_a_fixed_height_solve_in_the_plane() {
        let truth = Point3::new(1.0, -1.0, 0.97);
        let a = [
            Point3::new(-3.4, 3.0, 1.04),
            Point3::new(3.6, 3.0, 1.05),
            Point3::new(3.6, -3.0, 1.04),
            Point3::new(-3.5, -3.0, 1.05),
        ];
        let ranges: Vec<_> = a
            .iter()
            .map(|p| AnchorRange {
                anchor_m: *p,
                range_m: (truth - p).norm(),
            })
            .collect();
        let cfg = MultilaterationConfig {
            height: HeightConstraint::Fixed(0.97),
            ..Default::default()
        };
        let s = solve_twr(&ranges, None, &cfg).unwrap();
        assert!((s.position_m - truth).norm() < 1e-6);
        assert!(matches!(
            solve_twr(&ranges[..1], None, &cfg),
            Err(RtlsError::TooFewMeasurements { .. })
        ));
    }

    #[test]
    fn bias_is_estimated_and_removed() {
        let samples: Vec<RangeTruth> = (0..300)
            .map(|i| {
                let anchor = i % 3;
                let true_m = 2.0 + 0.01 * i as f64;
                let noise = 0.01 * ((i * 7919) % 13) as f64 / 13.0 - 0.005;
                RangeTruth {
                    anchor,
                    measured_m: true_m + 0.17 + [0.05, -0.05, 0.0][anchor] + noise,
                    true_m,
                }
            })
            .collect();
        let b = estimate_range_bias(&samples, 3).unwrap();
        assert!((b.constant_m - 0.17).abs() < 0.01, "{b:?}");
        assert!((b.per_anchor_m[0] - 0.05).abs() < 0.01, "{b:?}");
        assert!((b.correct(1, 3.0) - (3.0 - 0.17 + 0.05)).abs() < 0.02);
        assert!(estimate_range_bias(&[], 3).is_err());
    }
}
