//! Triangulation of one joint from its keypoints in several views: confidence-weighted DLT on
//! undistorted normalised points, refined by Gauss–Newton on the reprojection error, with a
//! pairwise search for the views that agree when some do not.
//!
//! The DLT is Hartley & Zisserman's (*Multiple View Geometry*, 2nd ed., §12.2): each view with
//! camera matrix `P = [R | t]` (camera_from_world) and normalised point `(x, y)` gives the rows
//! `x P₃ − P₁` and `y P₃ − P₂` of `A X = 0`, solved by the eigenvector of `AᵀA` with the smallest
//! eigenvalue. Rows are weighted by the keypoint's confidence and, in a second solve, divided by
//! the point's depth in that view so that each view's algebraic error approximates its image
//! error. Gauss–Newton then minimises `Σ wᵢ ‖fᵢ (π(Rᵢ X + tᵢ) − xᵢ)‖²` (`fᵢ` the focal length in
//! pixels, so residuals are pixels).

use crate::camera::{CalibratedCamera, MIN_DEPTH_M};
use nalgebra::{Matrix3, Matrix4, Point2, Point3, RowVector4, Vector2, Vector3};

/// Gauss–Newton steps after the DLT.
const REFINE_STEPS: usize = 6;

/// One keypoint of one joint in one view, ready for triangulation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewPoint {
    /// Index of the view's camera.
    pub view: usize,
    /// Undistorted normalised coordinates.
    pub xy: Vector2<f64>,
    /// The keypoint as measured, pixels (for reprojection errors).
    pub pixel_px: Point2<f64>,
    /// Weight: the keypoint's confidence.
    pub weight: f64,
}

/// How joints are triangulated and how their confidence is computed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TriangulationConfig {
    /// A view whose reprojection error exceeds this is an outlier for the joint, pixels. Keypoint
    /// errors of 2D estimators are a few pixels (a keypoint 20 px off is another body part).
    pub reprojection_gate_px: f64,
    /// The reprojection error (RMS over the joint's views) at which the confidence is multiplied
    /// by `exp(-1/2)`, pixels.
    pub confidence_scale_px: f64,
}

impl Default for TriangulationConfig {
    fn default() -> Self {
        Self {
            reprojection_gate_px: 20.0,
            confidence_scale_px: 8.0,
        }
    }
}

/// A triangulated joint.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TriangulatedJoint {
    /// Position in the world, metres.
    pub position_m: Point3<f64>,
    /// Confidence in `0..=1`: the mean keypoint confidence of the views used, times
    /// `1 − 2^-(n−1)` for `n` views (1/2 for two, 3/4 for three), times
    /// `exp(−½ (e / confidence_scale_px)²)` for an RMS reprojection error `e`.
    pub confidence: f64,
    /// Number of views used.
    pub num_views: usize,
    /// RMS reprojection error over the views used, pixels.
    pub rms_reprojection_px: f64,
}

/// The DLT solution of `points` (at least two views), in the world, metres; `None` when the
/// views do not determine a finite point (fewer than two, parallel rays, a point at infinity).
pub fn triangulate_dlt(cameras: &[CalibratedCamera], points: &[ViewPoint]) -> Option<Point3<f64>> {
    if points.len() < 2 {
        return None;
    }
    let first = solve_weighted(cameras, points, |_| 1.0)?;
    // Second solve with rows divided by the depth of the first solution in each view.
    solve_weighted(cameras, points, |p| {
        cameras
            .get(p.view)
            .and_then(|c| c.normalised_of(&first))
            .map_or(1.0, |(_, depth)| 1.0 / depth)
    })
    .or(Some(first))
}

fn solve_weighted(
    cameras: &[CalibratedCamera],
    points: &[ViewPoint],
    scale: impl Fn(&ViewPoint) -> f64,
) -> Option<Point3<f64>> {
    let mut ata = Matrix4::<f64>::zeros();
    for p in points {
        let camera = cameras.get(p.view)?;
        let m = camera.camera_from_world().to_homogeneous();
        let row = |i: usize| -> RowVector4<f64> { m.fixed_view::<1, 4>(i, 0).into_owned() };
        let w = p.weight * scale(p);
        let r1 = (row(2) * p.xy.x - row(0)) * w;
        let r2 = (row(2) * p.xy.y - row(1)) * w;
        ata += r1.transpose() * r1 + r2.transpose() * r2;
    }
    let eigen = ata.symmetric_eigen();
    let (i_min, _) = eigen
        .eigenvalues
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(b.1))?;
    let v = eigen.eigenvectors.column(i_min);
    if v[3].abs() < 1e-12 * v.norm() {
        return None;
    }
    let p = Point3::new(v[0] / v[3], v[1] / v[3], v[2] / v[3]);
    (p.coords.iter().all(|c| c.is_finite())).then_some(p)
}

/// Gauss–Newton refinement of `start` on the weighted reprojection error (module docs); returns
/// `start` unchanged where a step would put the point behind a view.
pub fn refine(
    cameras: &[CalibratedCamera],
    points: &[ViewPoint],
    start: Point3<f64>,
) -> Point3<f64> {
    let mut x = start;
    for _ in 0..REFINE_STEPS {
        let mut jtj = Matrix3::<f64>::zeros();
        let mut jtr = Vector3::<f64>::zeros();
        for p in points {
            let Some(camera) = cameras.get(p.view) else {
                return x;
            };
            let q = camera.camera_from_world() * x;
            if q.z < MIN_DEPTH_M {
                return x;
            }
            let f = camera.focal_px();
            let residual = f * (Vector2::new(q.x / q.z, q.y / q.z) - p.xy);
            let d_proj = nalgebra::Matrix2x3::new(
                1.0 / q.z,
                0.0,
                -q.x / (q.z * q.z),
                0.0,
                1.0 / q.z,
                -q.y / (q.z * q.z),
            );
            let j = f
                * d_proj
                * camera
                    .camera_from_world()
                    .rotation
                    .to_rotation_matrix()
                    .matrix();
            jtj += p.weight * j.transpose() * j;
            jtr += p.weight * j.transpose() * residual;
        }
        let Some(step) = jtj.try_inverse().map(|inv| inv * jtr) else {
            return x;
        };
        if !step.iter().all(|s| s.is_finite()) {
            return x;
        }
        x -= step;
        if step.norm() < 1e-12 {
            break;
        }
    }
    x
}

/// The reprojection error of `point` against a keypoint, pixels (distortion included); `None`
/// behind the camera.
pub fn reprojection_error_px(
    cameras: &[CalibratedCamera],
    point: &Point3<f64>,
    p: &ViewPoint,
) -> Option<f64> {
    let px = cameras.get(p.view)?.project_px(point)?;
    Some((px - p.pixel_px).norm())
}

/// Triangulates one joint from its keypoints in several views (at most one per view), leaving
/// out the views that disagree: all views are tried first; when one is beyond the gate, every
/// pair is triangulated and the pair whose point most views agree with (ties: the smaller
/// summed error) picks the views used. `None` when fewer than two views agree.
pub fn triangulate_joint(
    cameras: &[CalibratedCamera],
    points: &[ViewPoint],
    config: &TriangulationConfig,
) -> Option<TriangulatedJoint> {
    if points.len() < 2 {
        return None;
    }
    let gate = config.reprojection_gate_px;
    let inliers_of = |x: &Point3<f64>| -> (Vec<ViewPoint>, f64) {
        let mut kept = Vec::with_capacity(points.len());
        let mut sum = 0.0;
        for p in points {
            if let Some(e) = reprojection_error_px(cameras, x, p)
                && e <= gate
            {
                kept.push(*p);
                sum += e;
            }
        }
        (kept, sum)
    };
    let all = triangulate_dlt(cameras, points).map(|x| refine(cameras, points, x));
    let mut chosen = all
        .map(|x| inliers_of(&x))
        .filter(|(k, _)| k.len() == points.len());
    if chosen.is_none() {
        let mut best: Option<(Vec<ViewPoint>, f64)> = None;
        for i in 0..points.len() {
            for j in i + 1..points.len() {
                let pair = [points[i], points[j]];
                let Some(x) = triangulate_dlt(cameras, &pair) else {
                    continue;
                };
                let (kept, sum) = inliers_of(&x);
                let better = match &best {
                    None => true,
                    Some((b, b_sum)) => {
                        kept.len() > b.len() || (kept.len() == b.len() && sum < *b_sum)
                    }
                };
                if better {
                    best = Some((kept, sum));
                }
            }
        }
        chosen = best;
    }
    let (used, _) = chosen.filter(|(k, _)| k.len() >= 2)?;
    let x = refine(cameras, &used, triangulate_dlt(cameras, &used)?);
    let mut sum_sq = 0.0;
    for p in &used {
        let e = reprojection_error_px(cameras, &x, p)?;
        if e > gate {
            return None;
        }
        sum_sq += e * e;
    }
    let n = used.len();
    let rms = (sum_sq / n as f64).sqrt();
    let mean_weight = used.iter().map(|p| p.weight).sum::<f64>() / n as f64;
    let view_factor = 1.0 - 0.5_f64.powi(n as i32 - 1);
    let error_factor = (-0.5 * (rms / config.confidence_scale_px).powi(2)).exp();
    Some(TriangulatedJoint {
        position_m: x,
        confidence: (mean_weight * view_factor * error_factor).clamp(0.0, 1.0),
        num_views: n,
        rms_reprojection_px: rms,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Distortion, Intrinsics};
    use nomen_core::CameraId;

    fn rig(n: usize) -> Vec<CalibratedCamera> {
        let intrinsics = Intrinsics {
            distortion: Distortion {
                k1: -0.2,
                k2: 0.05,
                p1: 0.001,
                p2: 0.0005,
                k3: 0.0,
            },
            ..Intrinsics::from_fov(1280, 720, 90f64.to_radians())
        };
        (0..n)
            .map(|i| {
                let a = i as f64 * std::f64::consts::TAU / n as f64;
                CalibratedCamera::looking_at(
                    CameraId::new(format!("c{i}")),
                    intrinsics,
                    Point3::new(4.0 * a.cos(), 4.0 * a.sin(), 2.6),
                    Point3::new(0.0, 0.0, 1.0),
                )
                .unwrap()
            })
            .collect()
    }

    fn observe(cameras: &[CalibratedCamera], p: &Point3<f64>) -> Vec<ViewPoint> {
        cameras
            .iter()
            .enumerate()
            .map(|(view, c)| {
                let pixel_px = c.project_px(p).unwrap();
                ViewPoint {
                    view,
                    xy: c.undistort(&pixel_px).unwrap(),
                    pixel_px,
                    weight: 0.8,
                }
            })
            .collect()
    }

    #[test]
    fn dlt_is_exact_without_noise_through_distorted_lenses() {
        let cameras = rig(3);
        for p in [
            Point3::new(0.0, 0.0, 1.0),
            Point3::new(1.2, -0.7, 0.1),
            Point3::new(-1.5, 1.1, 1.9),
        ] {
            let obs = observe(&cameras, &p);
            let x = triangulate_dlt(&cameras, &obs).unwrap();
            assert!((x - p).norm() < 1e-9, "{x} vs {p}");
            let x = triangulate_dlt(&cameras, &obs[..2]).unwrap();
            assert!((x - p).norm() < 1e-9, "two views: {x} vs {p}");
            let j = triangulate_joint(&cameras, &obs, &TriangulationConfig::default()).unwrap();
            assert!((j.position_m - p).norm() < 1e-9);
            assert_eq!(j.num_views, 3);
            assert!(j.rms_reprojection_px < 1e-6);
            assert!((j.confidence - 0.8 * 0.75).abs() < 1e-9);
        }
    }

    #[test]
    fn a_view_with_a_wrong_keypoint_is_left_out() {
        let cameras = rig(4);
        let p = Point3::new(0.3, 0.4, 1.2);
        let mut obs = observe(&cameras, &p);
        obs[2].pixel_px += nalgebra::Vector2::new(150.0, -80.0);
        obs[2].xy = cameras[2].undistort(&obs[2].pixel_px).unwrap();
        let j = triangulate_joint(&cameras, &obs, &TriangulationConfig::default()).unwrap();
        assert_eq!(j.num_views, 3);
        assert!((j.position_m - p).norm() < 1e-9);
        // Two views that disagree give nothing.
        let two = [obs[2], obs[0]];
        assert!(triangulate_joint(&cameras, &two, &TriangulationConfig::default()).is_none());
    }

    #[test]
    fn one_view_gives_no_point() {
        let cameras = rig(2);
        let obs = observe(&cameras, &Point3::new(0.0, 0.0, 1.0));
        assert!(triangulate_dlt(&cameras, &obs[..1]).is_none());
        assert!(triangulate_joint(&cameras, &obs[..1], &TriangulationConfig::default()).is_none());
    }
}
