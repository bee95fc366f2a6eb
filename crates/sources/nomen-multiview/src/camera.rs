//! Calibrated cameras: pinhole intrinsics with Brown–Conrady distortion, a pose in the world, and
//! the camera file (`cameras.toml`) that describes a rig.
//!
//! Conventions are OpenCV's (<https://docs.opencv.org/4.x/d9/d0c/group__calib3d.html>): the camera
//! frame has x right, y down and z forward (the optical axis); a world point `p` is seen at
//! `p_in_camera = camera_from_world * p`, its *normalised* coordinates are `(x, y) = (X/Z, Y/Z)`,
//! distortion maps them to `(x_d, y_d)` with
//!
//! ```text
//! r² = x² + y²,   radial = 1 + k1 r² + k2 r⁴ + k3 r⁶
//! x_d = x · radial + 2 p1 x y + p2 (r² + 2 x²)
//! y_d = y · radial + p1 (r² + 2 y²) + 2 p2 x y
//! ```
//!
//! and the pixel is `(u, v) = (fx x_d + cx, fy y_d + cy)`, with the pixel grid's origin at the
//! centre of the top-left pixel. Undistortion inverts the polynomial by Newton's method.

use crate::error::{MultiviewError, Result, invalid};
use nalgebra::{
    Isometry3, Matrix2, Point2, Point3, Translation3, UnitQuaternion, Vector2, Vector3,
};
use nomen_core::CameraId;
use nomen_core::frame::RigidTransform;
use serde::Deserialize;

/// Smallest depth in front of a camera at which a point is projected, metres: a point closer to
/// (or behind) the camera centre has no image.
pub const MIN_DEPTH_M: f64 = 1e-6;

/// Most Newton steps of [`CalibratedCamera::undistort`].
const MAX_UNDISTORT_STEPS: usize = 30;

/// How close the distortion of an undistorted point must come to the measured one, in
/// normalised units (about 1e-9 pixel at a 1000-pixel focal length).
const UNDISTORT_TOLERANCE: f64 = 1e-12;

/// Most cameras a camera file may list.
pub const MAX_CAMERAS: usize = 64;

/// Brown–Conrady lens distortion, OpenCV's five coefficients (`k1, k2, p1, p2, k3`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Distortion {
    /// Radial, r² term.
    pub k1: f64,
    /// Radial, r⁴ term.
    pub k2: f64,
    /// Tangential (decentring), first.
    pub p1: f64,
    /// Tangential (decentring), second.
    pub p2: f64,
    /// Radial, r⁶ term.
    pub k3: f64,
}

impl Distortion {
    /// Whether every coefficient is zero.
    pub fn is_zero(&self) -> bool {
        [self.k1, self.k2, self.p1, self.p2, self.k3]
            .iter()
            .all(|c| *c == 0.0)
    }

    /// Distorts normalised coordinates (the formula in the module docs).
    pub fn apply(&self, xy: Vector2<f64>) -> Vector2<f64> {
        let (x, y) = (xy.x, xy.y);
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3));
        Vector2::new(
            x * radial + 2.0 * self.p1 * x * y + self.p2 * (r2 + 2.0 * x * x),
            y * radial + self.p1 * (r2 + 2.0 * y * y) + 2.0 * self.p2 * x * y,
        )
    }

    /// The Jacobian of [`Distortion::apply`] at `xy`.
    fn jacobian(&self, xy: Vector2<f64>) -> Matrix2<f64> {
        let (x, y) = (xy.x, xy.y);
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3));
        // d(radial)/d(r²)
        let g = self.k1 + r2 * (2.0 * self.k2 + 3.0 * self.k3 * r2);
        let dxx = radial + 2.0 * x * x * g + 2.0 * self.p1 * y + 6.0 * self.p2 * x;
        let dxy = 2.0 * x * y * g + 2.0 * self.p1 * x + 2.0 * self.p2 * y;
        let dyy = radial + 2.0 * y * y * g + 6.0 * self.p1 * y + 2.0 * self.p2 * x;
        Matrix2::new(dxx, dxy, dxy, dyy)
    }

    /// The normalised coordinates whose distortion is `xy_distorted`, by Newton's method from
    /// `xy_distorted` itself; `None` when it does not converge (a point beyond where the
    /// polynomial folds over, far outside any real lens's field of view).
    pub fn invert(&self, xy_distorted: Vector2<f64>) -> Option<Vector2<f64>> {
        if self.is_zero() {
            return Some(xy_distorted);
        }
        let mut xy = xy_distorted;
        for _ in 0..MAX_UNDISTORT_STEPS {
            let residual = self.apply(xy) - xy_distorted;
            if residual.norm() <= UNDISTORT_TOLERANCE {
                return Some(xy);
            }
            let step = self.jacobian(xy).try_inverse()? * residual;
            xy -= step;
            if !(xy.x.is_finite() && xy.y.is_finite()) {
                return None;
            }
        }
        ((self.apply(xy) - xy_distorted).norm() <= UNDISTORT_TOLERANCE).then_some(xy)
    }
}

/// Pinhole intrinsics with distortion, pixels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Intrinsics {
    /// Image width, pixels.
    pub width_px: u32,
    /// Image height, pixels.
    pub height_px: u32,
    /// Focal length along x, pixels.
    pub fx_px: f64,
    /// Focal length along y, pixels.
    pub fy_px: f64,
    /// Principal point x, pixels.
    pub cx_px: f64,
    /// Principal point y, pixels.
    pub cy_px: f64,
    /// Lens distortion.
    pub distortion: Distortion,
}

impl Intrinsics {
    /// Undistorted intrinsics of a `width_px × height_px` image with the principal point at its
    /// centre and a horizontal field of view of `hfov_rad`.
    pub fn from_fov(width_px: u32, height_px: u32, hfov_rad: f64) -> Self {
        let f = 0.5 * f64::from(width_px) / (0.5 * hfov_rad).tan();
        Self {
            width_px,
            height_px,
            fx_px: f,
            fy_px: f,
            cx_px: 0.5 * (f64::from(width_px) - 1.0),
            cy_px: 0.5 * (f64::from(height_px) - 1.0),
            distortion: Distortion::default(),
        }
    }

    /// Checks the numbers are finite and the focal lengths positive; errors name `path`.
    pub fn validate(&self, source_name: &str, path: &str) -> Result<()> {
        let d = &self.distortion;
        let fields = [
            ("fx_px", self.fx_px),
            ("fy_px", self.fy_px),
            ("cx_px", self.cx_px),
            ("cy_px", self.cy_px),
            ("k1", d.k1),
            ("k2", d.k2),
            ("p1", d.p1),
            ("p2", d.p2),
            ("k3", d.k3),
        ];
        for (name, v) in fields {
            if !v.is_finite() {
                return Err(invalid(source_name, format!("{path}.{name}"), "not finite"));
            }
        }
        for (name, v) in [("fx_px", self.fx_px), ("fy_px", self.fy_px)] {
            if v <= 0.0 {
                return Err(invalid(
                    source_name,
                    format!("{path}.{name}"),
                    format!("{v} is not a positive focal length"),
                ));
            }
        }
        if self.width_px == 0 || self.height_px == 0 {
            return Err(invalid(
                source_name,
                path,
                "width_px and height_px must be positive",
            ));
        }
        Ok(())
    }

    /// Whether a pixel lies on the image.
    pub fn contains_px(&self, px: &Point2<f64>) -> bool {
        px.x >= -0.5
            && px.y >= -0.5
            && px.x <= f64::from(self.width_px) - 0.5
            && px.y <= f64::from(self.height_px) - 0.5
    }
}

/// A calibrated camera: its id, intrinsics and pose.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibratedCamera {
    /// The camera's id (the view's name in keypoint inputs and messages).
    pub id: CameraId,
    /// Intrinsics and distortion.
    pub intrinsics: Intrinsics,
    world_from_camera: Isometry3<f64>,
    camera_from_world: Isometry3<f64>,
}

impl CalibratedCamera {
    /// A camera at `world_from_camera` (OpenCV camera axes, see the module docs).
    pub fn new(id: CameraId, intrinsics: Intrinsics, world_from_camera: Isometry3<f64>) -> Self {
        Self {
            id,
            intrinsics,
            world_from_camera,
            camera_from_world: world_from_camera.inverse(),
        }
    }

    /// A camera at `eye_m` looking at `target_m`, with the image's "up" (−y) as close to the
    /// world's +z as the view direction allows. `None` when the camera looks straight up or
    /// down, or `eye_m` equals `target_m`.
    pub fn looking_at(
        id: CameraId,
        intrinsics: Intrinsics,
        eye_m: Point3<f64>,
        target_m: Point3<f64>,
    ) -> Option<Self> {
        let z = (target_m - eye_m).try_normalize(1e-12)?;
        let x = z.cross(&Vector3::z()).try_normalize(1e-9)?;
        let y = z.cross(&x);
        let rotation =
            nalgebra::Rotation3::from_matrix_unchecked(nalgebra::Matrix3::from_columns(&[x, y, z]));
        let world_from_camera = Isometry3::from_parts(
            Translation3::from(eye_m.coords),
            UnitQuaternion::from_rotation_matrix(&rotation),
        );
        Some(Self::new(id, intrinsics, world_from_camera))
    }

    /// The camera's pose: camera-frame points to the world.
    pub fn world_from_camera(&self) -> &Isometry3<f64> {
        &self.world_from_camera
    }

    /// World points to the camera frame.
    pub fn camera_from_world(&self) -> &Isometry3<f64> {
        &self.camera_from_world
    }

    /// The optical centre in the world, metres.
    pub fn centre_m(&self) -> Point3<f64> {
        Point3::from(self.world_from_camera.translation.vector)
    }

    /// The undistorted normalised coordinates of a world point and its depth along the optical
    /// axis (metres); `None` for a point less than [`MIN_DEPTH_M`] in front of the camera.
    pub fn normalised_of(&self, p_world_m: &Point3<f64>) -> Option<(Vector2<f64>, f64)> {
        let p = self.camera_from_world * p_world_m;
        (p.z >= MIN_DEPTH_M).then(|| (Vector2::new(p.x / p.z, p.y / p.z), p.z))
    }

    /// The pixel of undistorted normalised coordinates (distortion applied).
    pub fn pixel_of_normalised(&self, xy: Vector2<f64>) -> Point2<f64> {
        let d = self.intrinsics.distortion.apply(xy);
        let k = &self.intrinsics;
        Point2::new(k.fx_px * d.x + k.cx_px, k.fy_px * d.y + k.cy_px)
    }

    /// Projects a world point to its pixel, distortion included; `None` behind the camera. The
    /// pixel may lie off the image ([`Intrinsics::contains_px`]).
    pub fn project_px(&self, p_world_m: &Point3<f64>) -> Option<Point2<f64>> {
        self.normalised_of(p_world_m)
            .map(|(xy, _)| self.pixel_of_normalised(xy))
    }

    /// The undistorted normalised coordinates of a pixel (see [`Distortion::invert`]); `None`
    /// for a non-finite pixel or where the distortion cannot be inverted.
    pub fn undistort(&self, px: &Point2<f64>) -> Option<Vector2<f64>> {
        if !(px.x.is_finite() && px.y.is_finite()) {
            return None;
        }
        let k = &self.intrinsics;
        let xy_d = Vector2::new((px.x - k.cx_px) / k.fx_px, (px.y - k.cy_px) / k.fy_px);
        k.distortion.invert(xy_d)
    }

    /// The unit direction, in the world, of the ray through undistorted normalised coordinates.
    pub fn ray_direction(&self, xy: Vector2<f64>) -> Vector3<f64> {
        (self.world_from_camera.rotation * Vector3::new(xy.x, xy.y, 1.0)).normalize()
    }

    /// The mean focal length, pixels: the factor from normalised to pixel errors.
    pub fn focal_px(&self) -> f64 {
        0.5 * (self.intrinsics.fx_px + self.intrinsics.fy_px)
    }
}

/// A camera file: the rig's cameras, the frame rate of their keypoint files, and where each
/// view's keypoints are.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraFile {
    /// Frame rate of the keypoint files, Hz: frame `i` is at `start_s + i / fps_hz`.
    pub fps_hz: f64,
    /// Session time of frame 0, seconds.
    pub start_s: f64,
    /// The cameras, in file order.
    pub cameras: Vec<CalibratedCamera>,
    /// Each camera's keypoint path as written (relative to the camera file), if given.
    pub keypoints: Vec<Option<String>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraFileToml {
    fps_hz: f64,
    #[serde(default)]
    start_s: f64,
    camera: Vec<CameraToml>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraToml {
    id: String,
    #[serde(default)]
    keypoints: Option<String>,
    width_px: u32,
    height_px: u32,
    fx_px: f64,
    fy_px: f64,
    cx_px: f64,
    cy_px: f64,
    #[serde(default)]
    k1: f64,
    #[serde(default)]
    k2: f64,
    #[serde(default)]
    p1: f64,
    #[serde(default)]
    p2: f64,
    #[serde(default)]
    k3: f64,
    #[serde(default)]
    world_from_camera: Option<RigidTransform>,
    #[serde(default)]
    camera_from_world_rvec_rad: Option<[f64; 3]>,
    #[serde(default)]
    camera_from_world_tvec_m: Option<[f64; 3]>,
}

/// Parses a camera file (TOML; `docs/multiview.md` describes it). Errors name `source_name` and
/// the line and column (syntax) or the camera and field (content).
pub fn parse_camera_file(text: &str, source_name: &str) -> Result<CameraFile> {
    let file: CameraFileToml = toml::from_str(text).map_err(|e| MultiviewError::Syntax {
        source_name: source_name.to_owned(),
        detail: e.to_string().trim_end().replace('\n', " "),
    })?;
    if !(file.fps_hz.is_finite() && file.fps_hz > 0.0) {
        return Err(invalid(
            source_name,
            "fps_hz",
            format!("{} is not a positive frame rate", file.fps_hz),
        ));
    }
    if !file.start_s.is_finite() {
        return Err(invalid(source_name, "start_s", "not finite"));
    }
    if file.camera.is_empty() {
        return Err(invalid(source_name, "camera", "no [[camera]] given"));
    }
    if file.camera.len() > MAX_CAMERAS {
        return Err(MultiviewError::TooLarge {
            source_name: source_name.to_owned(),
            detail: format!(
                "{} cameras, more than the {MAX_CAMERAS} a rig may have",
                file.camera.len()
            ),
        });
    }
    let mut cameras = Vec::with_capacity(file.camera.len());
    let mut keypoints = Vec::with_capacity(file.camera.len());
    for (i, c) in file.camera.into_iter().enumerate() {
        let path = format!("camera[{i}]");
        if c.id.trim().is_empty() {
            return Err(invalid(source_name, format!("{path}.id"), "empty id"));
        }
        if cameras
            .iter()
            .any(|o: &CalibratedCamera| o.id.as_str() == c.id)
        {
            return Err(invalid(
                source_name,
                format!("{path}.id"),
                format!("camera '{}' is listed twice", c.id),
            ));
        }
        let intrinsics = Intrinsics {
            width_px: c.width_px,
            height_px: c.height_px,
            fx_px: c.fx_px,
            fy_px: c.fy_px,
            cx_px: c.cx_px,
            cy_px: c.cy_px,
            distortion: Distortion {
                k1: c.k1,
                k2: c.k2,
                p1: c.p1,
                p2: c.p2,
                k3: c.k3,
            },
        };
        intrinsics.validate(source_name, &path)?;
        let world_from_camera = match (
            c.world_from_camera,
            c.camera_from_world_rvec_rad,
            c.camera_from_world_tvec_m,
        ) {
            (Some(t), None, None) => {
                t.validate(&format!("{path}.world_from_camera"))
                    .map_err(|e| invalid(source_name, &path, e.to_string()))?;
                t.to_isometry()
            }
            (None, Some(rvec), Some(tvec)) => {
                if !rvec.iter().chain(&tvec).all(|v| v.is_finite()) {
                    return Err(invalid(
                        source_name,
                        &path,
                        "camera_from_world_rvec_rad and camera_from_world_tvec_m must be finite",
                    ));
                }
                // OpenCV's rvec is an axis-angle vector (Rodrigues).
                let camera_from_world = Isometry3::from_parts(
                    Translation3::new(tvec[0], tvec[1], tvec[2]),
                    UnitQuaternion::from_scaled_axis(Vector3::from(rvec)),
                );
                camera_from_world.inverse()
            }
            _ => {
                return Err(invalid(
                    source_name,
                    &path,
                    "give the pose either as world_from_camera = { rotation_wxyz, translation_m } \
                     or as camera_from_world_rvec_rad and camera_from_world_tvec_m (OpenCV)",
                ));
            }
        };
        cameras.push(CalibratedCamera::new(
            CameraId::new(c.id),
            intrinsics,
            world_from_camera,
        ));
        keypoints.push(c.keypoints);
    }
    Ok(CameraFile {
        fps_hz: file.fps_hz,
        start_s: file.start_s,
        cameras,
        keypoints,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    fn wide_lens() -> Intrinsics {
        Intrinsics {
            distortion: Distortion {
                k1: -0.25,
                k2: 0.07,
                p1: 0.0012,
                p2: -0.0007,
                k3: -0.004,
            },
            ..Intrinsics::from_fov(1920, 1080, 90f64.to_radians())
        }
    }

    fn camera() -> CalibratedCamera {
        CalibratedCamera::looking_at(
            CameraId::new("c"),
            wide_lens(),
            Point3::new(4.0, -3.0, 2.5),
            Point3::new(0.0, 0.0, 1.0),
        )
        .unwrap()
    }

    #[test]
    fn undistortion_inverts_distortion_over_the_whole_image() {
        let cam = camera();
        let k = cam.intrinsics;
        let mut worst = 0.0_f64;
        for iy in 0..=20 {
            for ix in 0..=20 {
                let px = Point2::new(
                    f64::from(k.width_px - 1) * f64::from(ix) / 20.0,
                    f64::from(k.height_px - 1) * f64::from(iy) / 20.0,
                );
                let xy = cam.undistort(&px).expect("inside the image undistorts");
                let back = cam.pixel_of_normalised(xy);
                worst = worst.max((back - px).norm());
            }
        }
        assert!(worst < 1e-6, "worst pixel round trip {worst} px");
        // The lens really distorts: a corner moves by many pixels.
        let corner = Point2::new(0.0, 0.0);
        let xy = cam.undistort(&corner).unwrap();
        let pinhole = Point2::new(k.fx_px * xy.x + k.cx_px, k.fy_px * xy.y + k.cy_px);
        assert!((pinhole - corner).norm() > 50.0);
    }

    #[test]
    fn a_projected_point_lies_on_the_ray_of_its_pixel() {
        let cam = camera();
        let p = Point3::new(0.4, 0.7, 1.3);
        let px = cam.project_px(&p).unwrap();
        let dir = cam.ray_direction(cam.undistort(&px).unwrap());
        let to_p = (p - cam.centre_m()).normalize();
        assert_relative_eq!(dir, to_p, epsilon = 1e-9);
    }

    #[test]
    fn looking_at_puts_the_target_at_the_principal_point_and_up_at_the_top() {
        let cam = camera();
        let k = cam.intrinsics;
        let px = cam.project_px(&Point3::new(0.0, 0.0, 1.0)).unwrap();
        assert_relative_eq!(px, Point2::new(k.cx_px, k.cy_px), epsilon = 1e-9);
        let above = cam.project_px(&Point3::new(0.0, 0.0, 1.5)).unwrap();
        assert!(above.y < px.y, "higher points are higher in the image");
        assert!(cam.project_px(&Point3::new(8.0, -6.0, 4.0)).is_none());
    }

    #[test]
    fn opencv_extrinsics_and_rigid_transforms_give_the_same_camera() {
        let cam = camera();
        let cfw = cam.camera_from_world();
        let rvec = cfw.rotation.scaled_axis();
        let t = cfw.translation.vector;
        let wfc = RigidTransform::from_isometry(cam.world_from_camera());
        let text = format!(
            "fps_hz = 30\n\
             [[camera]]\nid = \"a\"\nwidth_px = 1920\nheight_px = 1080\n\
             fx_px = 800\nfy_px = 800\ncx_px = 960\ncy_px = 540\nk1 = -0.1\n\
             camera_from_world_rvec_rad = [{}, {}, {}]\ncamera_from_world_tvec_m = [{}, {}, {}]\n\
             [[camera]]\nid = \"b\"\nwidth_px = 1920\nheight_px = 1080\n\
             fx_px = 800\nfy_px = 800\ncx_px = 960\ncy_px = 540\n\
             world_from_camera = {{ rotation_wxyz = [{}, {}, {}, {}], translation_m = [{}, {}, {}] }}\n",
            rvec.x,
            rvec.y,
            rvec.z,
            t.x,
            t.y,
            t.z,
            wfc.rotation_wxyz[0],
            wfc.rotation_wxyz[1],
            wfc.rotation_wxyz[2],
            wfc.rotation_wxyz[3],
            wfc.translation_m[0],
            wfc.translation_m[1],
            wfc.translation_m[2],
        );
        let file = parse_camera_file(&text, "cameras.toml").unwrap();
        assert_eq!(file.cameras.len(), 2);
        assert_eq!(file.cameras[0].intrinsics.distortion.k1, -0.1);
        for c in &file.cameras {
            assert_relative_eq!(c.centre_m(), cam.centre_m(), epsilon = 1e-9);
            let p = Point3::new(0.3, 0.2, 1.0);
            assert_relative_eq!(
                c.camera_from_world() * p,
                cam.camera_from_world() * p,
                epsilon = 1e-9
            );
        }
    }

    #[test]
    fn camera_file_errors_name_the_camera_and_field() {
        let base = "fps_hz = 30\n[[camera]]\nid = \"a\"\nwidth_px = 10\nheight_px = 10\n\
                    cx_px = 5\ncy_px = 5\nfy_px = 10\n";
        let e = parse_camera_file(&format!("{base}fx_px = -3\nworld_from_camera = {{ rotation_wxyz = [1,0,0,0], translation_m = [0,0,0] }}\n"), "c.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("c.toml: camera[0].fx_px"), "{e}");
        let e = parse_camera_file(&format!("{base}fx_px = 3\n"), "c.toml")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("camera[0]") && e.contains("world_from_camera"),
            "{e}"
        );
        let e = parse_camera_file("fps_hz = 30\n[[camera]]\nid = 3\n", "c.toml")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("c.toml: ") && e.contains("line 3"), "{e}");
    }
}
