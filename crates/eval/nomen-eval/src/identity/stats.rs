//! Small descriptive statistics: ratios, means, quantiles and box-plot summaries.

use serde::{Deserialize, Serialize};

/// `num / den`, or `None` when `den` is zero (a rate over nothing is not computable).
pub(crate) fn ratio(num: u64, den: u64) -> Option<f64> {
    (den > 0).then(|| num as f64 / den as f64)
}

/// Arithmetic mean, `None` for no samples.
pub(crate) fn mean(samples: &[f64]) -> Option<f64> {
    (!samples.is_empty()).then(|| samples.iter().sum::<f64>() / samples.len() as f64)
}

/// Root mean square, `None` for no samples.
pub(crate) fn rms(samples: &[f64]) -> Option<f64> {
    mean(&samples.iter().map(|e| e * e).collect::<Vec<_>>()).map(f64::sqrt)
}

/// Quantile `q` in `0..=1` of *sorted* samples, interpolating linearly between the two nearest
/// ranks (NumPy's default `linear` method, Hyndman and Fan's type 7). `None` for no samples.
pub(crate) fn quantile_sorted(sorted: &[f64], q: f64) -> Option<f64> {
    let last = sorted.len().checked_sub(1)?;
    let pos = q.clamp(0.0, 1.0) * last as f64;
    let lo = pos.floor() as usize;
    let hi = pos.ceil() as usize;
    let (a, b) = (*sorted.get(lo)?, *sorted.get(hi)?);
    Some(a + (b - a) * (pos - lo as f64))
}

/// Median (type-7 quantile 0.5), `None` for no samples.
pub(crate) fn median(samples: &[f64]) -> Option<f64> {
    let mut sorted = samples.to_vec();
    sorted.sort_by(f64::total_cmp);
    quantile_sorted(&sorted, 0.5)
}

/// Tukey box-plot summary of a sample: quartiles by linear interpolation (NumPy's default), whiskers
/// at the most extreme samples within 1.5 IQR of the box, and the samples beyond them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BoxStats {
    /// Number of samples.
    pub num_samples: u64,
    /// Smallest sample.
    pub min: f64,
    /// First quartile.
    pub q1: f64,
    /// Median.
    pub median: f64,
    /// Third quartile.
    pub q3: f64,
    /// Largest sample.
    pub max: f64,
    /// Lower whisker: the smallest sample `>= q1 - 1.5 (q3 - q1)`.
    pub whisker_low: f64,
    /// Upper whisker: the largest sample `<= q3 + 1.5 (q3 - q1)`.
    pub whisker_high: f64,
    /// Samples outside the whiskers.
    pub num_outliers: u64,
}

impl BoxStats {
    /// The summary of `samples` (non-finite samples are ignored); `None` when no finite sample.
    pub fn from_samples(samples: &[f64]) -> Option<Self> {
        let mut sorted: Vec<f64> = samples.iter().copied().filter(|x| x.is_finite()).collect();
        sorted.sort_by(f64::total_cmp);
        let q1 = quantile_sorted(&sorted, 0.25)?;
        let median = quantile_sorted(&sorted, 0.5)?;
        let q3 = quantile_sorted(&sorted, 0.75)?;
        let iqr = q3 - q1;
        let (fence_low, fence_high) = (q1 - 1.5 * iqr, q3 + 1.5 * iqr);
        let inside = || {
            sorted
                .iter()
                .copied()
                .filter(|&x| x >= fence_low && x <= fence_high)
        };
        // The quartiles lie inside the fences, so both whiskers exist when a sample does.
        let whisker_low = inside().next().unwrap_or(q1);
        let whisker_high = inside().next_back().unwrap_or(q3);
        Some(Self {
            num_samples: sorted.len() as u64,
            min: *sorted.first()?,
            q1,
            median,
            q3,
            max: *sorted.last()?,
            whisker_low,
            whisker_high,
            num_outliers: (sorted.len() - inside().count()) as u64,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quartiles_interpolate_like_numpy() {
        // numpy.percentile([1, 2, 3, 4], [25, 50, 75]) = [1.75, 2.5, 3.25].
        let b = BoxStats::from_samples(&[4.0, 1.0, 3.0, 2.0]).unwrap();
        assert_eq!((b.q1, b.median, b.q3), (1.75, 2.5, 3.25));
        assert_eq!((b.min, b.max, b.num_outliers), (1.0, 4.0, 0));
    }

    #[test]
    fn a_far_sample_is_an_outlier_beyond_the_whisker() {
        // Six samples: q1 = 2.25 (rank 1.25), q3 = 4.75 (rank 3.75), IQR 2.5, upper fence 8.5:
        // 100 is out and the whisker stops at 5.
        let b = BoxStats::from_samples(&[1.0, 2.0, 3.0, 4.0, 5.0, 100.0]).unwrap();
        assert_eq!(b.whisker_high, 5.0);
        assert_eq!(b.num_outliers, 1);
        assert!(BoxStats::from_samples(&[]).is_none());
    }

    #[test]
    fn rms_of_constant_errors_is_the_constant() {
        assert!((rms(&[0.3, 0.3, 0.3]).unwrap() - 0.3).abs() < 1e-15);
        assert_eq!(ratio(1, 0), None);
        assert_eq!(median(&[3.0, 1.0, 2.0]), Some(2.0));
    }
}
