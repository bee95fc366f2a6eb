//! Magnitude signals, resampling onto a grid, Pearson correlation and lag search.
//!
//! Interim scoring used until `nomen_evidence::geometric_scores` lands: De Marchi's acceleration
//! model (linear-acceleration magnitudes) and an orientation-change model (gyro magnitude
//! against the turn rate of the bone that ends at the wearable's site).

use nalgebra::{Point3, Vector3};
use nomen_core::Joint;

/// The bone whose direction a wearable at `site` turns with: `(from, to)`.
pub(crate) fn site_bone(site: Joint) -> (Joint, Joint) {
    match site.parent() {
        Some(parent) => (parent, site),
        None => (Joint::LeftHip, Joint::RightHip),
    }
}

/// Central differences on uneven times (one-sided at the ends); NaN propagates.
pub(crate) fn central_difference(t_ns: &[i64], x: &[Vector3<f64>], out: &mut Vec<Vector3<f64>>) {
    out.clear();
    let n = x.len().min(t_ns.len());
    let nan = Vector3::repeat(f64::NAN);
    if n < 2 {
        out.resize(n, nan);
        return;
    }
    for i in 0..n {
        let (a, b) = (i.saturating_sub(1), (i + 1).min(n - 1));
        let dt = (t_ns[b] - t_ns[a]) as f64 * 1e-9;
        out.push(if dt > 0.0 { (x[b] - x[a]) / dt } else { nan });
    }
}

/// Skeleton signals of one site over a track's samples: acceleration magnitude (m/s²) and the
/// bone's turn rate (rad/s). `positions[i]` holds the site and bone joints at sample `i`
/// (`None` where missing); `velocities` the filtered site velocity when a filter ran.
pub(crate) struct SiteSignals {
    pub(crate) acc_mag: Vec<f64>,
    pub(crate) turn_rate: Vec<f64>,
}

pub(crate) fn site_signals(
    t_ns: &[i64],
    site: &[Option<Point3<f64>>],
    site_velocity: Option<&[Option<Vector3<f64>>]>,
    bone: &[Option<Vector3<f64>>],
) -> SiteSignals {
    let nan = Vector3::repeat(f64::NAN);
    let mut scratch = Vec::with_capacity(t_ns.len());
    let velocity: Vec<Vector3<f64>> = match site_velocity {
        Some(v) => v.iter().map(|v| v.unwrap_or(nan)).collect(),
        None => {
            let p: Vec<Vector3<f64>> = site.iter().map(|p| p.map_or(nan, |p| p.coords)).collect();
            central_difference(t_ns, &p, &mut scratch);
            std::mem::take(&mut scratch)
        }
    };
    let mut acc = Vec::with_capacity(t_ns.len());
    central_difference(t_ns, &velocity, &mut acc);
    let dirs: Vec<Vector3<f64>> = bone
        .iter()
        .map(|b| {
            b.and_then(|b| b.try_normalize(1e-6))
                .unwrap_or(Vector3::repeat(f64::NAN))
        })
        .collect();
    central_difference(t_ns, &dirs, &mut scratch);
    SiteSignals {
        acc_mag: acc.iter().map(|a| a.norm()).collect(),
        turn_rate: scratch.iter().map(|d| d.norm()).collect(),
    }
}

/// Mean of `src_v` (times `src_t + shift_ns`, increasing) in each grid point's bin (bounded by
/// the midpoints to its neighbours); NaN for an empty bin. Appends `grid.len()` values.
pub(crate) fn bin_average(
    src_t: &[i64],
    src_v: &[f64],
    shift_ns: i64,
    grid: &[i64],
    out: &mut Vec<f64>,
) {
    out.clear();
    for (j, &tg) in grid.iter().enumerate() {
        let prev = j.checked_sub(1).and_then(|i| grid.get(i)).copied();
        let next = grid.get(j + 1).copied();
        let half_before = prev.map(|p| (tg - p) / 2).or(next.map(|n| (n - tg) / 2));
        let half_after = next.map(|n| (n - tg) / 2).or(half_before);
        let lo = tg - half_before.unwrap_or(0) - shift_ns;
        let hi = tg + half_after.unwrap_or(0) - shift_ns;
        let a = src_t.partition_point(|&x| x < lo);
        let b = src_t.partition_point(|&x| x < hi);
        let vals = src_v.get(a..b).unwrap_or(&[]);
        let (sum, n) = vals
            .iter()
            .filter(|v| v.is_finite())
            .fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
        out.push(if n > 0 { sum / n as f64 } else { f64::NAN });
    }
}

/// Centred moving average over `half_width` samples each side (NaNs skipped), in place.
pub(crate) fn smooth(x: &mut [f64], half_width: usize, scratch: &mut Vec<f64>) {
    if half_width == 0 {
        return;
    }
    scratch.clear();
    scratch.extend_from_slice(x);
    for (i, out) in x.iter_mut().enumerate() {
        let lo = i.saturating_sub(half_width);
        let hi = (i + half_width + 1).min(scratch.len());
        let (sum, n) = scratch
            .get(lo..hi)
            .unwrap_or(&[])
            .iter()
            .filter(|v| v.is_finite())
            .fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
        *out = if n > 0 { sum / n as f64 } else { f64::NAN };
    }
}

/// Minimum number of valid pairs for a correlation.
const MIN_PAIRS: usize = 8;

/// Pearson correlation over the pairs where both values are finite; `None` with fewer than
/// [`MIN_PAIRS`] pairs or a constant signal.
pub(crate) fn pearson(a: &[f64], b: &[f64]) -> Option<f64> {
    let pairs = || {
        a.iter()
            .zip(b)
            .filter(|(x, y)| x.is_finite() && y.is_finite())
    };
    let n = pairs().count();
    if n < MIN_PAIRS {
        return None;
    }
    let (sa, sb) = pairs().fold((0.0, 0.0), |(sa, sb), (x, y)| (sa + x, sb + y));
    let (ma, mb) = (sa / n as f64, sb / n as f64);
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in pairs() {
        let (dx, dy) = (x - ma, y - mb);
        sab += dx * dy;
        saa += dx * dx;
        sbb += dy * dy;
    }
    let denom = (saa * sbb).sqrt();
    (denom > 1e-12).then(|| (sab / denom).clamp(-1.0, 1.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pearson_of_a_line_with_itself_is_one() {
        let a: Vec<f64> = (0..20).map(|i| i as f64).collect();
        let b: Vec<f64> = a.iter().map(|v| 3.0 * v + 1.0).collect();
        assert!((pearson(&a, &b).unwrap() - 1.0).abs() < 1e-12);
        assert!(pearson(&a, &[1.0; 20]).is_none());
    }

    #[test]
    fn bin_average_of_a_faster_stream_is_its_local_mean() {
        let src_t: Vec<i64> = (0..100).map(|i| i * 10).collect();
        let src_v: Vec<f64> = (0..100).map(|i| i as f64).collect();
        let grid = [300, 330, 360];
        let mut out = Vec::new();
        bin_average(&src_t, &src_v, 0, &grid, &mut out);
        assert_eq!(out.len(), 3);
        assert!((out[1] - 33.0).abs() < 1.0, "{out:?}");
    }
}
