//! Depth images and the occlusion test of the open-loop filter.
//!
//! A depth image stores, per pixel, the depth (camera Z, metres) of the first surface the camera
//! sees, or 0 where the sensor returned nothing. [`DepthProbe`] is the interface the filter
//! needs: a camera model and one pixel at a time, so a renderer can produce pixels lazily
//! ([`crate::scene`] does) and a dense [`DepthMap`] works as well.
//!
//! The occlusion constraint ([`particle_visibility`]) projects a particle with the pinhole model;
//! if the camera saw a surface *behind* the particle (deeper by more than a margin), a joint
//! there would have been seen, so the particle is discarded. Zero pixels are filled on demand,
//! for tested pixels only, from the nearest non-zero pixel ([`filled_depth_m`]).

use nalgebra::{Isometry3, Point3, Vector3};
use nomen_core::registry::CameraIntrinsics;

/// A pinhole camera: intrinsics and pose. Camera frame: +X right, +Y down, +Z forward (the
/// convention of every nomen camera).
#[derive(Debug, Clone, PartialEq)]
pub struct PinholeCamera {
    /// Image size and pinhole parameters.
    pub intrinsics: CameraIntrinsics,
    world_from_camera: Isometry3<f64>,
    camera_from_world: Isometry3<f64>,
}

impl PinholeCamera {
    /// A camera with these intrinsics at this pose.
    pub fn new(intrinsics: CameraIntrinsics, world_from_camera: Isometry3<f64>) -> Self {
        Self {
            intrinsics,
            world_from_camera,
            camera_from_world: world_from_camera.inverse(),
        }
    }

    /// The camera pose.
    pub fn world_from_camera(&self) -> &Isometry3<f64> {
        &self.world_from_camera
    }

    /// Moves the camera.
    pub fn set_world_from_camera(&mut self, world_from_camera: Isometry3<f64>) {
        self.world_from_camera = world_from_camera;
        self.camera_from_world = world_from_camera.inverse();
    }

    /// Pixel coordinates `(u, v)` and depth (camera Z, m) of a world point; `None` when the
    /// point is not in front of the camera or not finite.
    pub fn project(&self, p_world: &Point3<f64>) -> Option<(f64, f64, f64)> {
        let p = self.camera_from_world * p_world;
        if p.z.is_nan() || p.z <= 1e-6 || !p.x.is_finite() || !p.y.is_finite() {
            return None;
        }
        let k = &self.intrinsics;
        Some((
            k.fx_px * p.x / p.z + k.cx_px,
            k.fy_px * p.y / p.z + k.cy_px,
            p.z,
        ))
    }

    /// The pixel containing `(u, v)`, if inside the image.
    pub fn pixel(&self, u: f64, v: f64) -> Option<(u32, u32)> {
        let (w, h) = (
            f64::from(self.intrinsics.width_px),
            f64::from(self.intrinsics.height_px),
        );
        (u >= 0.0 && v >= 0.0 && u < w && v < h).then_some((u as u32, v as u32))
    }

    /// The ray through the centre of pixel `(u, v)`: the optical centre and a world direction
    /// scaled so that the ray parameter equals the depth (camera Z) in metres.
    pub fn pixel_ray(&self, u: u32, v: u32) -> (Point3<f64>, Vector3<f64>) {
        let k = &self.intrinsics;
        let d_cam = Vector3::new(
            (f64::from(u) + 0.5 - k.cx_px) / k.fx_px,
            (f64::from(v) + 0.5 - k.cy_px) / k.fy_px,
            1.0,
        );
        (
            Point3::from(self.world_from_camera.translation.vector),
            self.world_from_camera.rotation * d_cam,
        )
    }
}

/// Pixel access to a depth image: what the occlusion constraint needs.
pub trait DepthProbe {
    /// The camera that took the image.
    fn camera(&self) -> &PinholeCamera;
    /// Depth (camera Z) at a pixel inside the image, m; 0 where the sensor returned nothing.
    fn raw_depth_m(&mut self, u: u32, v: u32) -> f32;
    /// [`filled_depth_m`] at a pixel: the raw depth, or the nearest non-zero depth within
    /// `max_radius_px` where it is zero. A probe may cache the answer for its image; the
    /// answer must not differ from [`filled_depth_m`]'s.
    fn filled_depth_m(&mut self, u: u32, v: u32, max_radius_px: u32) -> Option<f32> {
        filled_depth_m(self, u, v, max_radius_px)
    }
}

/// A dense depth image, row-major (`v * width + u`).
#[derive(Debug, Clone, PartialEq)]
pub struct DepthMap {
    /// The camera that took the image.
    pub camera: PinholeCamera,
    /// Depth per pixel (camera Z), m; 0 = no return.
    pub depth_m: Vec<f32>,
}

impl DepthMap {
    /// Renders a depth image: for each pixel, `cast(origin, dir, max_t)` returns the first hit
    /// along `origin + t·dir` (with `t` = depth in metres, see [`PinholeCamera::pixel_ray`]).
    /// Hits beyond `max_range_m` (or none) give 0, like a sensor out of range.
    pub fn render(
        camera: PinholeCamera,
        max_range_m: f64,
        mut cast: impl FnMut(&Point3<f64>, &Vector3<f64>, f64) -> Option<f64>,
    ) -> Self {
        let (w, h) = (camera.intrinsics.width_px, camera.intrinsics.height_px);
        let mut depth_m = Vec::with_capacity(w as usize * h as usize);
        for v in 0..h {
            for u in 0..w {
                let (o, d) = camera.pixel_ray(u, v);
                depth_m.push(cast(&o, &d, max_range_m).map_or(0.0, |t| t as f32));
            }
        }
        Self { camera, depth_m }
    }

    /// Depth at a pixel inside the image, m (0 = no return); 0 outside.
    pub fn at(&self, u: u32, v: u32) -> f32 {
        let w = self.camera.intrinsics.width_px;
        if u >= w || v >= self.camera.intrinsics.height_px {
            return 0.0;
        }
        self.depth_m
            .get(v as usize * w as usize + u as usize)
            .copied()
            .unwrap_or(0.0)
    }
}

impl DepthProbe for DepthMap {
    fn camera(&self) -> &PinholeCamera {
        &self.camera
    }

    fn raw_depth_m(&mut self, u: u32, v: u32) -> f32 {
        self.at(u, v)
    }
}

/// Depth at a pixel, with a zero (no return) replaced by the nearest non-zero pixel within
/// `max_radius_px` (searched ring by ring in Chebyshev distance, nearest in Euclidean distance
/// within the first ring that has one). `None` when nothing is found.
pub fn filled_depth_m<P: DepthProbe + ?Sized>(
    probe: &mut P,
    u: u32,
    v: u32,
    max_radius_px: u32,
) -> Option<f32> {
    let d = probe.raw_depth_m(u, v);
    if d > 0.0 {
        return Some(d);
    }
    let (w, h) = (
        i64::from(probe.camera().intrinsics.width_px),
        i64::from(probe.camera().intrinsics.height_px),
    );
    let (cu, cv) = (i64::from(u), i64::from(v));
    for r in 1..=i64::from(max_radius_px) {
        let mut best: Option<(i64, f32)> = None;
        let mut consider = |pu: i64, pv: i64, probe: &mut P| {
            if pu < 0 || pv < 0 || pu >= w || pv >= h {
                return;
            }
            let d = probe.raw_depth_m(pu as u32, pv as u32);
            if d > 0.0 {
                let dist2 = (pu - cu).pow(2) + (pv - cv).pow(2);
                if best.is_none_or(|(b, _)| dist2 < b) {
                    best = Some((dist2, d));
                }
            }
        };
        for k in -r..=r {
            consider(cu + k, cv - r, probe);
            consider(cu + k, cv + r, probe);
        }
        for k in (-r + 1)..r {
            consider(cu - r, cv + k, probe);
            consider(cu + r, cv + k, probe);
        }
        if let Some((_, d)) = best {
            return Some(d);
        }
    }
    None
}

/// What the depth camera says about a point.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Visibility {
    /// The camera saw a surface behind the point: a joint there would have been seen.
    WouldBeSeen,
    /// Something in front of the point (or at its depth) hides it.
    Hidden,
    /// Outside the image, behind the camera, or no depth anywhere near: the camera says nothing.
    Unknown,
}

/// Rebecchi's occlusion test for one point: project, read (or fill) the depth, compare.
/// The point would have been seen when the observed depth exceeds its own depth by more than
/// `margin_m`.
pub fn particle_visibility(
    probe: &mut dyn DepthProbe,
    p_world: &Point3<f64>,
    margin_m: f64,
    max_fill_radius_px: u32,
) -> Visibility {
    particle_visibility_at_depth(probe, p_world, |_| margin_m, max_fill_radius_px)
}

/// [`particle_visibility`] with a margin that depends on the point's depth (camera Z, m), for a
/// margin drawn from the depth noise, which grows with depth.
pub fn particle_visibility_at_depth(
    probe: &mut dyn DepthProbe,
    p_world: &Point3<f64>,
    margin_m: impl Fn(f64) -> f64,
    max_fill_radius_px: u32,
) -> Visibility {
    let Some((u, v, z)) = probe.camera().project(p_world) else {
        return Visibility::Unknown;
    };
    let Some((pu, pv)) = probe.camera().pixel(u, v) else {
        return Visibility::Unknown;
    };
    match probe.filled_depth_m(pu, pv, max_fill_radius_px) {
        None => Visibility::Unknown,
        Some(d) if f64::from(d) > z + margin_m(z) => Visibility::WouldBeSeen,
        Some(_) => Visibility::Hidden,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, UnitQuaternion};

    /// A 64×48 camera at the origin looking along world +X (camera Z), no roll.
    pub(crate) fn camera() -> PinholeCamera {
        let rot = Rotation3::from_matrix_unchecked(nalgebra::Matrix3::from_columns(&[
            Vector3::new(0.0, -1.0, 0.0),
            Vector3::new(0.0, 0.0, -1.0),
            Vector3::new(1.0, 0.0, 0.0),
        ]));
        PinholeCamera::new(
            CameraIntrinsics {
                width_px: 64,
                height_px: 48,
                fx_px: 50.0,
                fy_px: 50.0,
                cx_px: 32.0,
                cy_px: 24.0,
            },
            Isometry3::from_parts(
                nalgebra::Translation3::identity(),
                UnitQuaternion::from_rotation_matrix(&rot),
            ),
        )
    }

    /// A wall at world x = `x_m`.
    fn wall(x_m: f64) -> DepthMap {
        DepthMap::render(camera(), 10.0, |o, d, max_t| {
            let t = (x_m - o.x) / d.x;
            (t >= 0.0 && t <= max_t).then_some(t)
        })
    }

    #[test]
    fn particle_in_plain_view_would_have_been_seen() {
        // Wall 3 m away; a particle 1.5 m away in front of it is in plain view.
        let mut depth = wall(3.0);
        let p = Point3::new(1.5, 0.1, -0.05);
        assert_eq!(
            particle_visibility(&mut depth, &p, 0.05, 4),
            Visibility::WouldBeSeen
        );
        // Behind the wall it is hidden.
        let q = Point3::new(3.5, 0.1, -0.05);
        assert_eq!(
            particle_visibility(&mut depth, &q, 0.05, 4),
            Visibility::Hidden
        );
        // Behind the camera: the camera says nothing.
        let r = Point3::new(-1.0, 0.0, 0.0);
        assert_eq!(
            particle_visibility(&mut depth, &r, 0.05, 4),
            Visibility::Unknown
        );
    }

    #[test]
    fn zero_pixels_are_filled_from_the_nearest_return() {
        let mut depth = wall(3.0);
        // Punch a hole of no-return pixels around the centre, with one nearer pixel at 2 px.
        for v in 20..29 {
            for u in 28..37 {
                let i = v * 64 + u;
                depth.depth_m[i] = 0.0;
            }
        }
        depth.depth_m[24 * 64 + 34] = 1.0;
        // The pixel 2 to the right is the nearest non-zero (others are ≥ 5 px away).
        assert_eq!(filled_depth_m(&mut depth, 32, 24, 10), Some(1.0));
        assert_eq!(filled_depth_m(&mut depth, 32, 24, 1), None);
        // A particle at 1.5 m there: the filled 1.0 m is in front → hidden.
        let p = Point3::new(1.5, 0.0, 0.0);
        assert_eq!(
            particle_visibility(&mut depth, &p, 0.05, 10),
            Visibility::Hidden
        );
    }

    #[test]
    fn projection_and_pixel_ray_agree() {
        let cam = camera();
        let p = Point3::new(2.0, -0.3, 0.2);
        let (u, v, z) = cam.project(&p).unwrap();
        assert!((z - 2.0).abs() < 1e-12);
        let (pu, pv) = cam.pixel(u, v).unwrap();
        let (o, d) = cam.pixel_ray(pu, pv);
        let q = o + d * z;
        // Within one pixel's footprint at 2 m (2/50 m).
        assert!((q - p).norm() < 2.0 * 2.0 / 50.0);
    }
}
