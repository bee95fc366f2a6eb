//! Velocity and acceleration of sampled positions on non-uniform timestamps.
//!
//! Each derivative at sample `i` is the derivative of the quadratic through three neighbouring
//! samples (Lagrange interpolation; Fornberg's weights for three nodes):
//!
//! - interior `i`: nodes `i-1, i, i+1`, with `h₁ = t_i − t_{i−1}`, `h₂ = t_{i+1} − t_i`:
//!   ```text
//!   v_i = −h₂/(h₁(h₁+h₂)) x_{i−1} + (h₂−h₁)/(h₁h₂) x_i + h₁/(h₂(h₁+h₂)) x_{i+1}
//!   a_i = 2 [ x_{i−1}/(h₁(h₁+h₂)) − x_i/(h₁h₂) + x_{i+1}/(h₂(h₁+h₂)) ]
//!   ```
//!   (the central difference; second-order accurate in velocity on any spacing);
//! - first and last sample: the same quadratic through the first (last) three samples,
//!   evaluated at the end point (second-order one-sided difference for velocity; for acceleration
//!   the end value equals its neighbour's).
//!
//! The results are exact for quadratic trajectories. Differentiation amplifies noise: smooth the
//! positions first ([`crate::kalman::JointKalman`] or [`crate::lowpass::ZeroPhaseLowpass`]).
//! Savitzky–Golay was not chosen because it assumes uniform sampling, and skeleton streams are not.

use crate::error::{FilterError, Result};
use nalgebra::Vector3;
use nomen_core::SessionTime;
use std::ops::{Add, Mul};

/// A value that can be differentiated: `f64` or a 3D vector.
pub trait Differentiable: Copy + Add<Output = Self> + Mul<f64, Output = Self> {
    /// True when every component is finite.
    fn is_finite_value(&self) -> bool;
}

impl Differentiable for f64 {
    fn is_finite_value(&self) -> bool {
        self.is_finite()
    }
}

impl Differentiable for Vector3<f64> {
    fn is_finite_value(&self) -> bool {
        self.iter().all(|v| v.is_finite())
    }
}

/// Checks lengths, strictly increasing time, finite values; returns the sample count.
fn check_inputs<T: Differentiable>(
    t: &[SessionTime],
    x: &[T],
    out_len: usize,
    what: &'static str,
) -> Result<usize> {
    if x.len() != t.len() {
        return Err(FilterError::LengthMismatch {
            what,
            expected: t.len(),
            got: x.len(),
        });
    }
    if out_len != t.len() {
        return Err(FilterError::LengthMismatch {
            what,
            expected: t.len(),
            got: out_len,
        });
    }
    if t.len() < 3 {
        return Err(FilterError::WindowTooShort {
            what,
            needed: 2,
            got: t.len(),
        });
    }
    for (index, w) in t.windows(2).enumerate() {
        if w[1] <= w[0] {
            return Err(FilterError::NonIncreasingTime {
                index: index + 1,
                previous_ns: w[0].as_ns(),
                current_ns: w[1].as_ns(),
            });
        }
    }
    if let Some(index) = x.iter().position(|v| !v.is_finite_value()) {
        return Err(FilterError::NonFinite { what, index });
    }
    Ok(t.len())
}

/// Weights `(w₀, w₁, w₂)` of the first derivative at node `at` (0, 1 or 2) of the quadratic
/// through nodes at offsets `0, h1, h1 + h2`.
fn velocity_weights(h1: f64, h2: f64, at: usize) -> (f64, f64, f64) {
    let s = h1 + h2;
    match at {
        0 => (-(2.0 * h1 + h2) / (h1 * s), s / (h1 * h2), -h1 / (h2 * s)),
        1 => (-h2 / (h1 * s), (h2 - h1) / (h1 * h2), h1 / (h2 * s)),
        _ => (h2 / (h1 * s), -s / (h1 * h2), (h1 + 2.0 * h2) / (h2 * s)),
    }
}

/// The three nodes sample `i` of a series of `n` (≥ 3) is differentiated over: centred on
/// `c`, kept inside the series, the sample at node `at` (0, 1 or 2), with spacings `h1`, `h2`.
#[derive(Clone, Copy)]
struct Stencil {
    c: usize,
    at: usize,
    h1: f64,
    h2: f64,
}

// Inlined into the loops: called as functions, the stencil cost 0.7 % more of the engine.
impl Stencil {
    #[inline(always)]
    fn at(t: &[SessionTime], n: usize, i: usize) -> Stencil {
        let c = i.clamp(1, n - 2);
        Stencil {
            c,
            at: i + 1 - c,
            h1: t[c].secs_since(t[c - 1]),
            h2: t[c + 1].secs_since(t[c]),
        }
    }

    #[inline(always)]
    fn velocity<T: Differentiable>(self, x: &[T]) -> T {
        let Stencil { c, at, h1, h2 } = self;
        let (w0, w1, w2) = velocity_weights(h1, h2, at);
        x[c - 1] * w0 + x[c] * w1 + x[c + 1] * w2
    }

    #[inline(always)]
    fn acceleration<T: Differentiable>(self, x: &[T]) -> T {
        let Stencil { c, h1, h2, .. } = self;
        let s = h1 + h2;
        x[c - 1] * (2.0 / (h1 * s)) + x[c] * (-2.0 / (h1 * h2)) + x[c + 1] * (2.0 / (h2 * s))
    }
}

/// Velocity of `x` sampled at strictly increasing times `t`, written into `out` (same length,
/// at least 3 samples). Units: `x` units per second. Errors on non-increasing time or NaN.
pub fn velocity<T: Differentiable>(t: &[SessionTime], x: &[T], out: &mut [T]) -> Result<()> {
    let n = check_inputs(t, x, out.len(), "velocity")?;
    for (i, o) in out.iter_mut().enumerate() {
        *o = Stencil::at(t, n, i).velocity(x);
    }
    Ok(())
}

/// Acceleration (second derivative) of `x` sampled at strictly increasing times `t`, written
/// into `out` (same length, at least 3 samples). Units: `x` units per second squared.
pub fn acceleration<T: Differentiable>(t: &[SessionTime], x: &[T], out: &mut [T]) -> Result<()> {
    let n = check_inputs(t, x, out.len(), "acceleration")?;
    for (i, o) in out.iter_mut().enumerate() {
        *o = Stencil::at(t, n, i).acceleration(x);
    }
    Ok(())
}

/// [`velocity`] into `vel` and [`acceleration`] into `acc` at once: the same values as each
/// alone, with the inputs checked and each sample's spacings found once. Errors as [`velocity`]
/// (whose checks [`acceleration`] shares), or for an `acc` of another length; on an error
/// neither output is written.
pub fn velocity_and_acceleration<T: Differentiable>(
    t: &[SessionTime],
    x: &[T],
    vel: &mut [T],
    acc: &mut [T],
) -> Result<()> {
    let n = check_inputs(t, x, vel.len(), "velocity")?;
    if acc.len() != n {
        return Err(FilterError::LengthMismatch {
            what: "acceleration",
            expected: n,
            got: acc.len(),
        });
    }
    for (i, (v, a)) in vel.iter_mut().zip(acc.iter_mut()).enumerate() {
        let stencil = Stencil::at(t, n, i);
        *v = stencil.velocity(x);
        *a = stencil.acceleration(x);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_bits::vector_bits;

    #[test]
    fn both_derivatives_at_once_equal_each_alone_bit_for_bit() {
        let t: Vec<SessionTime> = (0..25)
            .map(|i| SessionTime::from_ns(i * 33_333_333 + (i * 7919 % 5_000_000)))
            .collect();
        let x: Vec<Vector3<f64>> = t
            .iter()
            .map(|t| {
                let s = t.as_secs_f64();
                Vector3::new((3.0 * s).sin(), s * s * s, 1.0 / (1.0 + s))
            })
            .collect();
        let zero = Vector3::zeros();
        let (mut v1, mut a1) = (vec![zero; 25], vec![zero; 25]);
        velocity(&t, &x, &mut v1).unwrap();
        acceleration(&t, &x, &mut a1).unwrap();
        let (mut v2, mut a2) = (vec![zero; 25], vec![zero; 25]);
        velocity_and_acceleration(&t, &x, &mut v2, &mut a2).unwrap();
        assert_eq!(vector_bits(&v1), vector_bits(&v2));
        assert_eq!(vector_bits(&a1), vector_bits(&a2));
        // Errors leave both outputs as they were.
        let mut back = t.clone();
        back.swap(3, 4);
        let (mut v3, mut a3) = (vec![zero; 25], vec![zero; 25]);
        assert!(matches!(
            velocity_and_acceleration(&back, &x, &mut v3, &mut a3),
            Err(FilterError::NonIncreasingTime { index: 4, .. })
        ));
        assert!(matches!(
            velocity_and_acceleration(&t, &x, &mut v3, &mut a3[..24]),
            Err(FilterError::LengthMismatch { .. })
        ));
        assert!(v3.iter().chain(&a3).all(|v| *v == zero));
    }

    #[test]
    fn quadratic_motion_has_exact_velocity_and_acceleration_on_jittered_times() {
        // x(t) = 1 + 2t - 3t²  →  v = 2 - 6t, a = -6, on jittered 30 Hz timestamps.
        let t: Vec<SessionTime> = (0..20)
            .map(|i| SessionTime::from_ns(i * 33_333_333 + (i * 7919 % 5_000_000)))
            .collect();
        let x: Vec<f64> = t
            .iter()
            .map(|t| {
                let s = t.as_secs_f64();
                1.0 + 2.0 * s - 3.0 * s * s
            })
            .collect();
        let mut v = vec![0.0; t.len()];
        let mut a = vec![0.0; t.len()];
        velocity(&t, &x, &mut v).unwrap();
        acceleration(&t, &x, &mut a).unwrap();
        for i in 0..t.len() {
            let s = t[i].as_secs_f64();
            assert!((v[i] - (2.0 - 6.0 * s)).abs() < 1e-6, "v[{i}] = {}", v[i]);
            assert!((a[i] + 6.0).abs() < 1e-4, "a[{i}] = {}", a[i]);
        }
    }

    #[test]
    fn repeated_timestamp_and_nan_are_errors() {
        let t = [0, 10, 10, 20].map(SessionTime::from_ns);
        let x = [0.0; 4];
        let mut out = [0.0; 4];
        assert!(matches!(
            velocity(&t, &x, &mut out),
            Err(FilterError::NonIncreasingTime { index: 2, .. })
        ));
        let t = [0, 10, 20, 30].map(SessionTime::from_ns);
        let x = [0.0, f64::NAN, 0.0, 0.0];
        assert!(acceleration(&t, &x, &mut out).is_err());
        assert!(velocity(&t[..2], &x[..2], &mut out[..2]).is_err());
    }
}
