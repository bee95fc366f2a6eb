//! Robust statistics shared by the filters' users.

/// The median of `v`, which it sorts (`NaN`s last, by `f64::total_cmp`); the mean of the two
/// middle values for an even length; `None` when `v` is empty.
pub fn median(v: &mut [f64]) -> Option<f64> {
    v.sort_unstable_by(f64::total_cmp);
    let n = v.len();
    let upper = *v.get(n / 2)?;
    if n % 2 == 1 {
        Some(upper)
    } else {
        v.get(n / 2 - 1).map(|lower| 0.5 * (lower + upper))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn odd_even_and_empty() {
        assert_eq!(median(&mut [3.0, 1.0, 2.0]), Some(2.0));
        assert_eq!(median(&mut [4.0, 1.0, 3.0, 2.0]), Some(2.5));
        assert_eq!(median(&mut [7.0]), Some(7.0));
        assert_eq!(median(&mut []), None);
        // A knock among calm readings does not move it.
        assert_eq!(median(&mut [9.8, 9.7, 150.0, 9.9, 9.8]), Some(9.8));
    }
}
