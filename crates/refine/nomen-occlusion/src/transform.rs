//! Homogeneous transforms for aligning the camera, the robot and the environment meshes.
//!
//! Rebecchi aligns the depth camera with the robot through a marker held by the robot:
//! `A_0,kin = A_0,1 · A_1,char · A_kin,char⁻¹`, where `0` is the robot base (our world), `1` the
//! robot flange, `char` the characteristic marker and `kin` the Kinect. In nomen's naming that
//! reads `world_from_camera = world_from_flange · flange_from_marker · (camera_from_marker)⁻¹`
//! ([`world_from_camera_via_marker`]). Meshes are placed with a `world_from_mesh` transform that
//! is either known or fitted from point correspondences ([`fit_world_from_mesh`], delegated to
//! `nomen-calib`'s Kabsch/Umeyama fit).

use crate::error::{OcclusionError, Result};
use nalgebra::{Isometry3, Matrix3, Matrix4, Point3, Rotation3, Translation3, UnitQuaternion};

/// The product `m[0] · m[1] · … · m[n-1]` of homogeneous transforms (identity when empty): with
/// `target_from_source` naming, `compose(&[a_from_b, b_from_c])` is `a_from_c`.
pub fn compose(transforms: &[Matrix4<f64>]) -> Matrix4<f64> {
    transforms
        .iter()
        .fold(Matrix4::identity(), |acc, m| acc * m)
}

/// The inverse of a rigid homogeneous transform (rotation + translation), computed as
/// `[Rᵀ, −Rᵀt]`.
///
/// # Errors
/// [`OcclusionError::Fit`] when the matrix is not finite, its last row is not `[0 0 0 1]` or its
/// 3×3 block is not a rotation (orthonormality or determinant off by more than 1e-6).
pub fn invert_rigid(m: &Matrix4<f64>) -> Result<Matrix4<f64>> {
    let iso = rigid_from_homogeneous(m)?;
    Ok(iso.inverse().to_homogeneous())
}

/// A rigid homogeneous matrix as an isometry, after checking it is one (see [`invert_rigid`]).
///
/// # Errors
/// [`OcclusionError::Fit`] when the matrix is not a finite rigid transform.
pub fn rigid_from_homogeneous(m: &Matrix4<f64>) -> Result<Isometry3<f64>> {
    if !m.iter().all(|v| v.is_finite()) {
        return Err(OcclusionError::Fit(
            "homogeneous transform has non-finite entries".into(),
        ));
    }
    let last = m.fixed_view::<1, 4>(3, 0);
    if (last[0].abs() + last[1].abs() + last[2].abs() + (last[3] - 1.0).abs()) > 1e-9 {
        return Err(OcclusionError::Fit(
            "homogeneous transform's last row is not [0 0 0 1]".into(),
        ));
    }
    let r: Matrix3<f64> = m.fixed_view::<3, 3>(0, 0).into_owned();
    let orthonormality = (r.transpose() * r - Matrix3::identity()).norm();
    if orthonormality > 1e-6 || (r.determinant() - 1.0).abs() > 1e-6 {
        return Err(OcclusionError::Fit(format!(
            "homogeneous transform's 3x3 block is not a rotation (|RᵀR − I| = {orthonormality:.2e}, det = {:.6})",
            r.determinant()
        )));
    }
    let rotation = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r));
    let t = m.fixed_view::<3, 1>(0, 3).into_owned();
    Ok(Isometry3::from_parts(Translation3::from(t), rotation))
}

/// Rebecchi's camera alignment `A_0,kin = A_0,1 · A_1,char · A_kin,char⁻¹`:
/// `world_from_camera = world_from_flange · flange_from_marker · camera_from_marker⁻¹`.
///
/// # Errors
/// [`OcclusionError::Fit`] when `camera_from_marker` is not a rigid transform.
pub fn world_from_camera_via_marker(
    world_from_flange: &Matrix4<f64>,
    flange_from_marker: &Matrix4<f64>,
    camera_from_marker: &Matrix4<f64>,
) -> Result<Matrix4<f64>> {
    let marker_from_camera = invert_rigid(camera_from_marker)?;
    Ok(compose(&[
        *world_from_flange,
        *flange_from_marker,
        marker_from_camera,
    ]))
}

/// Fits `world_from_mesh` (rotation + translation) from at least three non-collinear point
/// pairs: the same physical points in the mesh's own frame and measured in the world.
///
/// # Errors
/// [`OcclusionError::Fit`] when the fit fails (too few or degenerate points, non-finite values).
pub fn fit_world_from_mesh(
    points_mesh_m: &[Point3<f64>],
    points_world_m: &[Point3<f64>],
) -> Result<Isometry3<f64>> {
    nomen_calib::fit_transform(points_mesh_m, points_world_m, nomen_calib::FitKind::Rigid)
        .map(|fit| fit.isometry)
        .map_err(|e| OcclusionError::Fit(e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    fn pose(axis_angle: Vector3<f64>, t: Vector3<f64>) -> Matrix4<f64> {
        Isometry3::new(t, axis_angle).to_homogeneous()
    }

    #[test]
    fn marker_alignment_recovers_the_camera_pose() {
        // Ground truth: robot flange, marker on the flange, camera in the world.
        let world_from_flange = pose(Vector3::new(0.1, -0.3, 0.8), Vector3::new(0.5, 0.2, 1.0));
        let flange_from_marker = pose(Vector3::new(0.0, 0.2, 0.0), Vector3::new(0.0, 0.0, 0.05));
        let world_from_camera = pose(Vector3::new(-0.4, 0.1, 2.0), Vector3::new(3.0, 1.0, 2.0));
        // What the camera would measure of the marker.
        let camera_from_marker =
            invert_rigid(&world_from_camera).unwrap() * world_from_flange * flange_from_marker;
        let got = world_from_camera_via_marker(
            &world_from_flange,
            &flange_from_marker,
            &camera_from_marker,
        )
        .unwrap();
        assert!((got - world_from_camera).norm() < 1e-12);
    }

    #[test]
    fn a_scaled_matrix_is_not_rigid() {
        let m = Matrix4::new_scaling(2.0);
        assert!(invert_rigid(&m).is_err());
    }

    #[test]
    fn mesh_pose_is_fitted_from_correspondences() {
        let truth = Isometry3::new(Vector3::new(1.0, -2.0, 0.5), Vector3::new(0.0, 0.0, 1.2));
        let mesh: Vec<Point3<f64>> = vec![
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(0.0, 0.5, 0.0),
            Point3::new(0.0, 0.0, 0.8),
            Point3::new(0.3, 0.3, 0.3),
        ];
        let world: Vec<Point3<f64>> = mesh.iter().map(|p| truth * p).collect();
        let fit = fit_world_from_mesh(&mesh, &world).unwrap();
        assert!((fit.to_homogeneous() - truth.to_homogeneous()).norm() < 1e-9);
        assert!(fit_world_from_mesh(&mesh[..1], &world[..1]).is_err());
    }
}
