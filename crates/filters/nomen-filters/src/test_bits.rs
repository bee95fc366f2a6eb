//! Bit-for-bit comparisons the tests share: a shortcut must give the general path's numbers,
//! not merely close ones.

use nalgebra::Vector3;

/// The bits of every component of `v`, in order.
pub(crate) fn vector_bits(v: &[Vector3<f64>]) -> Vec<u64> {
    v.iter()
        .flat_map(|p| p.iter().map(|c| c.to_bits()))
        .collect()
}

/// Whether `a` and `b` are the same number bit for bit, or both `NaN` (of any payload).
pub(crate) fn same_or_both_nan(a: f64, b: f64) -> bool {
    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
}
