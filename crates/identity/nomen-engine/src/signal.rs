//! Resampling IMU samples onto a camera track's grid, and the clock-offset lag curve.
//!
//! Scoring itself is `nomen_evidence::geometric_scores`; this module only builds its windows
//! and, for the clock offset, correlates magnitude signals over many candidate offsets.

use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use nomen_evidence::{ImuWindow, PearsonSums, first_finite};

/// Settled IMU samples on the device clock, all the same length, time increasing.
pub(crate) struct ImuSeries<'a> {
    pub(crate) t_ns: &'a [i64],
    pub(crate) accel_mps2: &'a [Vector3<f64>],
    pub(crate) gyro_radps: &'a [Vector3<f64>],
    pub(crate) world_from_sensor: &'a [UnitQuaternion<f64>],
}

/// A quaternion of `NaN`s: a missing orientation (the evidence crate skips non-finite ones).
pub(crate) fn nan_quaternion() -> UnitQuaternion<f64> {
    UnitQuaternion::new_unchecked(Quaternion::new(f64::NAN, f64::NAN, f64::NAN, f64::NAN))
}

/// The IMU resampled at the session times `grid_ns` (device time = session − `offset_ns`):
/// accelerations and rates interpolated linearly, the orientation of the nearer sample. Only
/// samples before device time `until_ns` are used (the settled ones, so the result does not
/// depend on arrival order). A grid point whose neighbouring samples are more than `max_gap_ns`
/// apart (a dropout) or outside the samples used is missing (`NaN`). `orientation_from` gets,
/// per grid point, the index of the sample whose orientation it took (`None` where missing).
pub(crate) fn imu_window_on_grid(
    imu: &ImuSeries<'_>,
    offset_ns: i64,
    grid_ns: &[i64],
    max_gap_ns: i64,
    until_ns: i64,
    out: &mut ImuWindow,
    orientation_from: &mut Vec<Option<usize>>,
) {
    orientation_from.clear();
    orientation_from.reserve(grid_ns.len());
    out.t_s.clear();
    out.accel_mps2.clear();
    out.gyro_radps.clear();
    out.world_from_sensor.clear();
    let nan = Vector3::repeat(f64::NAN);
    let n = imu
        .t_ns
        .len()
        .min(imu.accel_mps2.len())
        .min(imu.gyro_radps.len())
        .min(imu.world_from_sensor.len());
    let n = n.min(imu.t_ns.partition_point(|&t| t < until_ns));
    let t = imu.t_ns.get(..n).unwrap_or(&[]);
    out.t_s.reserve(grid_ns.len());
    out.accel_mps2.reserve(grid_ns.len());
    out.gyro_radps.reserve(grid_ns.len());
    out.world_from_sensor.reserve(grid_ns.len());
    // Start the walk at the first grid time's place: the settled samples reach back over the
    // whole offset buffer (about 16 s), the grid over one window.
    let mut k = grid_ns
        .first()
        .map_or(0, |&g| t.partition_point(|&s| s < g - offset_ns));
    for &g in grid_ns {
        out.t_s.push(g as f64 * 1e-9);
        let d = g - offset_ns;
        while k < n && t[k] < d {
            k += 1;
        }
        // Neighbours a = k − 1 (< d) and b = k (≥ d).
        let sample = match (k.checked_sub(1), (k < n).then_some(k)) {
            (_, Some(b)) if t[b] == d => Some((b, b, 0.0)),
            (Some(a), Some(b)) if t[b] - t[a] <= max_gap_ns => {
                Some((a, b, (d - t[a]) as f64 / (t[b] - t[a]) as f64))
            }
            _ => None,
        };
        match sample {
            Some((a, b, f)) => {
                out.accel_mps2
                    .push(imu.accel_mps2[a] * (1.0 - f) + imu.accel_mps2[b] * f);
                out.gyro_radps
                    .push(imu.gyro_radps[a] * (1.0 - f) + imu.gyro_radps[b] * f);
                let nearer = if f < 0.5 { a } else { b };
                out.world_from_sensor.push(imu.world_from_sensor[nearer]);
                orientation_from.push(Some(nearer));
            }
            None => {
                orientation_from.push(None);
                out.accel_mps2.push(nan);
                out.gyro_radps.push(nan);
                out.world_from_sensor.push(nan_quaternion());
            }
        }
    }
}

/// Linear interpolation of `(t_ns, v)` (increasing times) at `t_query − shift_ns` for every
/// query time (increasing); `NaN` outside, across gaps longer than `max_gap_ns`, or next to a
/// `NaN`.
#[cfg(test)]
pub(crate) fn interpolate(
    t_ns: &[i64],
    v: &[f64],
    shift_ns: i64,
    t_query: &[i64],
    max_gap_ns: i64,
    out: &mut Vec<f64>,
) {
    let mut weights = Vec::new();
    interpolation_weights(t_ns, shift_ns, t_query, 1, max_gap_ns, &mut weights);
    out.clear();
    out.resize(t_query.len(), f64::NAN);
    for w in &weights {
        if let Some(o) = out.get_mut(w.query) {
            *o = w.interpolate(v);
        }
    }
}

/// Where one query time falls among a signal's samples: `(1 − frac)·v[lo] + frac·v[hi]` is the
/// signal there (`lo == hi`, `frac = 0` on an exact hit).
#[derive(Clone, Copy, Debug)]
pub(crate) struct LagWeight {
    /// The query's index.
    query: usize,
    lo: usize,
    hi: usize,
    frac: f64,
}

impl LagWeight {
    /// The signal `v` at this query: `NaN` next to a `NaN` or outside `v`.
    #[inline]
    fn interpolate(&self, v: &[f64]) -> f64 {
        match (v.get(self.lo), v.get(self.hi)) {
            (Some(x), Some(y)) => x * (1.0 - self.frac) + y * self.frac,
            _ => f64::NAN,
        }
    }
}

/// Magnitude signals of one side for the lag search: times and one series per model.
pub(crate) struct LagSignals {
    pub(crate) t_ns: Vec<i64>,
    pub(crate) models: Vec<Vec<f64>>,
    /// A track's camera rate over 30 Hz, which the sample counts a lag curve needs are set
    /// for (see `REFERENCE_CAMERA_RATE_HZ` in the engine); 1 for an IMU's signals.
    pub(crate) sample_scale: f64,
}

impl LagSignals {
    /// Every `step`-th of the times `t_ns`, with models already thinned the same way (as
    /// `nomen_evidence::imu_lag_models` returns them).
    pub(crate) fn thinned(t_ns: &[i64], models: Vec<Vec<f64>>, step: usize) -> LagSignals {
        LagSignals {
            t_ns: t_ns.iter().step_by(step.max(1)).copied().collect(),
            models,
            sample_scale: 1.0,
        }
    }
}

/// The lag curve: for each candidate offset in `offsets_ns` (session = device + offset), the
/// mean over models of the Pearson correlation between the IMU's signals (device clock, shifted
/// by the offset and interpolated onto the track's times) and the track's. `NaN` where the first
/// model (the acceleration, whose peak is sharp) has too few pairs, whatever the others have:
/// the slow models alone do not fix a lag. On the simulated 8-person one-wrist scenes a track
/// whose wrist the camera lost had only the body's turn rate left, and one turn on a 3.6 s track
/// correlated 0.87 with another person's band at a lag 0.8 s from that band's clock offset,
/// which the best-track sum then accepted.
///
/// Only every `track_stride`-th of the track's times (from its first) is paired: a stride of
/// 2 gives the curve of a track with half its samples, bit for bit, without copying them.
#[allow(clippy::too_many_arguments)]
pub(crate) fn lag_curve(
    imu: &LagSignals,
    track: &LagSignals,
    track_stride: usize,
    offsets_ns: &[i64],
    max_gap_ns: i64,
    min_samples: usize,
    weights: &mut Vec<LagWeight>,
    out: &mut Vec<f64>,
) {
    out.clear();
    // Each model's first value, the shift of the one-pass sums.
    let shifts: Vec<(f64, f64)> = imu
        .models
        .iter()
        .zip(&track.models)
        .map(|(a, b)| (first_finite(a), first_finite(b)))
        .collect();
    // Per model, whether both sides have a value at every time: then every pair the weights
    // make is complete, and the sums take them without a check each (the same sums in the
    // same order).
    let is_complete: Vec<bool> = imu
        .models
        .iter()
        .zip(&track.models)
        .map(|(a, b)| {
            a.len() >= imu.t_ns.len()
                && b.len() >= track.t_ns.len()
                && a.iter().chain(b).all(|v| v.is_finite())
        })
        .collect();
    for &offset in offsets_ns {
        // Where each track time falls among the IMU's samples at this offset, once for every
        // model; track times outside the IMU's samples or in a gap pair with nothing.
        interpolation_weights(
            &imu.t_ns,
            offset,
            &track.t_ns,
            track_stride,
            max_gap_ns,
            weights,
        );
        let (mut sum, mut num) = (0.0, 0usize);
        for (m, (((a, b), (sa, sb)), &is_complete)) in imu
            .models
            .iter()
            .zip(&track.models)
            .zip(&shifts)
            .zip(&is_complete)
            .enumerate()
        {
            let mut sums = PearsonSums::new(*sa, *sb);
            let pairs = weights.iter().map(|w| {
                (
                    w.interpolate(a),
                    b.get(w.query).copied().unwrap_or(f64::NAN),
                )
            });
            if is_complete {
                sums.extend_finite(pairs);
            } else {
                sums.extend(pairs);
            }
            match sums.correlation(min_samples) {
                Some(r) => {
                    sum += r;
                    num += 1;
                }
                // Without the first model (the sharp one) nothing fixes the lag.
                None if m == 0 => break,
                None => {}
            }
        }
        out.push(if num > 0 { sum / num as f64 } else { f64::NAN });
    }
}

/// For each query time (increasing; every `stride`-th of `t_query` from its first) that falls
/// among the IMU's samples at `t_query − shift_ns`, the sample at or before it and the
/// fraction of the way to the next one (an exact hit uses that sample alone); nothing for a
/// query outside the samples or across a gap longer than `max_gap_ns`. A weight's query index
/// is into `t_query` itself.
fn interpolation_weights(
    t_ns: &[i64],
    shift_ns: i64,
    t_query: &[i64],
    stride: usize,
    max_gap_ns: i64,
    out: &mut Vec<LagWeight>,
) {
    out.clear();
    let n = t_ns.len();
    // Start the walk at the first query's place instead of the buffer's start.
    let mut k = t_query
        .first()
        .map_or(0, |&q| t_ns.partition_point(|&t| t < q - shift_ns));
    let stride = stride.max(1);
    let mut query = 0;
    while let Some(&q) = t_query.get(query) {
        let d = q - shift_ns;
        while k < n && t_ns[k] < d {
            k += 1;
        }
        let w = match (k.checked_sub(1), (k < n).then_some(k)) {
            (_, Some(b)) if t_ns[b] == d => Some((b, b, 0.0)),
            (Some(a), Some(b)) if t_ns[b] - t_ns[a] <= max_gap_ns => {
                Some((a, b, (d - t_ns[a]) as f64 / (t_ns[b] - t_ns[a]) as f64))
            }
            _ => None,
        };
        if let Some((lo, hi, frac)) = w {
            out.push(LagWeight {
                query,
                lo,
                hi,
                frac,
            });
        }
        query = query.saturating_add(stride);
    }
}

/// The peak of a lag curve: `(offset, value)` of the local maximum closest to `prior_ns` (the
/// offset expected before any search) among those within `tie_tolerance` of the highest value,
/// refined by a parabola through its neighbours (by at most half a step). `None` if the curve
/// has no finite value.
pub(crate) fn curve_peak(
    offsets_ns: &[i64],
    curve: &[f64],
    prior_ns: i64,
    tie_tolerance: f64,
) -> Option<(i64, f64)> {
    let best = curve
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .fold(None, |m: Option<f64>, v| Some(m.map_or(v, |m| m.max(v))))?;
    let at = |i: usize| curve.get(i).copied().unwrap_or(f64::NAN);
    let is_local_max = |i: usize| {
        let v = at(i);
        let left = i.checked_sub(1).map_or(f64::NEG_INFINITY, at);
        let right = at(i + 1);
        let is_above = |x: f64| x.partial_cmp(&v) == Some(std::cmp::Ordering::Greater);
        v.is_finite() && !is_above(left) && !is_above(right)
    };
    let (k, &offset) = offsets_ns
        .iter()
        .enumerate()
        .take(curve.len())
        .filter(|&(i, _)| is_local_max(i) && at(i) >= best - tie_tolerance)
        .min_by_key(|&(_, o)| o.abs_diff(prior_ns))?;
    let peak = at(k);
    let (y0, y2) = (k.checked_sub(1).map_or(f64::NAN, at), at(k + 1));
    let step = match (
        k.checked_sub(1).and_then(|i| offsets_ns.get(i)),
        offsets_ns.get(k + 1),
    ) {
        (Some(a), Some(b)) => (b - a) / 2,
        _ => 0,
    };
    let denom = y0 - 2.0 * peak + y2;
    let refined = if y0.is_finite() && y2.is_finite() && denom < 0.0 {
        let delta = (0.5 * (y0 - y2) / denom).clamp(-0.5, 0.5);
        offset + (delta * step as f64).round() as i64
    } else {
        offset
    };
    Some((refined, peak))
}

/// The peak of a lag curve summed over many tracks or passes (`curve` over `offsets_ns`):
/// `(offset, value, rival)` of the highest finite value at a lag inside `prior_ns ±
/// max_offset_ns` less half a step (a peak at the end of the range only says the best lag lies
/// beyond it), with `rival` the highest value farther than `separation_ns` from it (`−∞` if
/// none). `None` if the curve does not fall by [`PEAK_DROP`] on both sides of that value (see
/// [`falls_on_both_sides`]): the top of a slope rising to the end of the range is no peak.
pub(crate) fn summed_peak(
    offsets_ns: &[i64],
    curve: &[f64],
    prior_ns: i64,
    max_offset_ns: i64,
    half_step_ns: i64,
    separation_ns: i64,
) -> Option<(i64, f64, f64)> {
    let (k, offset, peak) = offsets_ns
        .iter()
        .zip(curve)
        .enumerate()
        .filter(|(_, (o, v))| v.is_finite() && (*o - prior_ns).abs() < max_offset_ns - half_step_ns)
        .max_by(|a, b| a.1.1.total_cmp(b.1.1))
        .map(|(k, (o, v))| (k, *o, *v))?;
    if !falls_on_both_sides(curve, k, PEAK_DROP) {
        return None;
    }
    Some((
        offset,
        peak,
        rival_value(offsets_ns, curve, offset, separation_ns),
    ))
}

/// How far a lag curve must fall on each side of a peak, towards the ends of the searched range,
/// for the peak to be one: on the simulated 8-person one-wrist scenes, lag curves that keep
/// rising to an end of the range (a slow trend, not a step) have their highest value inside the
/// range next to that end, and without this check those values would be taken for clock
/// offsets, all wrong.
pub(crate) const PEAK_DROP: f64 = 0.02;

/// Whether `curve` falls at least `drop` below its value at index `k` somewhere on each side of
/// `k` (not necessarily next to it): a local maximum of the curve and not the top of a slope
/// that goes on rising past the end of the range. Missing values (`NaN`) count as no fall.
pub(crate) fn falls_on_both_sides(curve: &[f64], k: usize, drop: f64) -> bool {
    let Some(&peak) = curve.get(k) else {
        return false;
    };
    let falls = |v: &f64| v.is_finite() && *v <= peak - drop;
    curve.get(..k).is_some_and(|l| l.iter().any(falls))
        && curve.get(k + 1..).is_some_and(|r| r.iter().any(falls))
}

/// The highest finite value of a lag curve farther than `separation_ns` from `peak_ns` (`−∞`
/// if none): what a peak at `peak_ns` must stand above to be told from a lag a stride or a
/// look-alike away.
pub(crate) fn rival_value(
    offsets_ns: &[i64],
    curve: &[f64],
    peak_ns: i64,
    separation_ns: i64,
) -> f64 {
    offsets_ns
        .iter()
        .zip(curve)
        .filter(|(o, v)| (*o - peak_ns).abs() > separation_ns && v.is_finite())
        .map(|(_, v)| *v)
        .fold(f64::NEG_INFINITY, f64::max)
}

/// The mean of each `(sum, count)` pair; `NaN` where nothing was summed.
pub(crate) fn mean_curve(sums: &[(f64, usize)]) -> Vec<f64> {
    sums.iter()
        .map(|(sum, n)| if *n > 0 { sum / *n as f64 } else { f64::NAN })
        .collect()
}

/// Whether a summed lag curve (`curve` over `offsets_ns`) contradicts an accepted `offset_ns`:
/// its value at the grid point nearest the offset is below `below` and some lag reaches at
/// least `margin` more. A curve with no finite value contradicts nothing.
pub(crate) fn is_contradicted(
    offsets_ns: &[i64],
    curve: &[f64],
    offset_ns: i64,
    below: f64,
    margin: f64,
) -> bool {
    let at = offsets_ns
        .iter()
        .enumerate()
        .min_by_key(|(_, o)| (**o - offset_ns).abs())
        .and_then(|(k, _)| curve.get(k).copied())
        .unwrap_or(f64::NAN);
    let best = curve
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .fold(f64::NEG_INFINITY, f64::max);
    at < below && best - at >= margin
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolation_between_samples_is_linear_and_gaps_are_missing() {
        let t = [0, 10, 20, 100];
        let v = [0.0, 1.0, 2.0, 10.0];
        let mut out = Vec::new();
        interpolate(&t, &v, 0, &[5, 15, 50, 200], 20, &mut out);
        assert!((out[0] - 0.5).abs() < 1e-12);
        assert!((out[1] - 1.5).abs() < 1e-12);
        assert!(out[2].is_nan() && out[3].is_nan());
        // A shift of +10 reads the sample 10 earlier.
        interpolate(&t, &v, 10, &[20], 20, &mut out);
        assert!((out[0] - 1.0).abs() < 1e-12);
    }

    #[test]
    fn a_grid_takes_the_nearer_samples_orientation_and_reports_which() {
        // 100 Hz for 20 s with a 0.3 s dropout at 15 s; each sample's orientation is a turn by
        // its index, so the one a grid point took is recognisable.
        let t_ns: Vec<i64> = (0..2000i64)
            .map(|k| k * 10_000_000)
            .filter(|t| !(15_000_000_000..15_300_000_000).contains(t))
            .collect();
        let accel: Vec<Vector3<f64>> = (0..t_ns.len()).map(|k| Vector3::repeat(k as f64)).collect();
        let q: Vec<UnitQuaternion<f64>> = (0..t_ns.len())
            .map(|k| UnitQuaternion::from_euler_angles(0.0, 0.0, k as f64 * 1e-3))
            .collect();
        let series = ImuSeries {
            t_ns: &t_ns,
            accel_mps2: &accel,
            gyro_radps: &accel,
            world_from_sensor: &q,
        };
        // A 30 Hz grid over 14–16 s of session time, the device 2 ms behind.
        let offset_ns = 2_000_000;
        let grid: Vec<i64> = (0..60).map(|k| 14_000_000_000 + k * 33_333_333).collect();
        let (mut win, mut from) = (ImuWindow::default(), Vec::new());
        imu_window_on_grid(
            &series,
            offset_ns,
            &grid,
            50_000_000,
            i64::MAX,
            &mut win,
            &mut from,
        );
        assert_eq!((win.t_s.len(), from.len()), (grid.len(), grid.len()));
        let mut num_missing = 0;
        for ((&g, k), q_grid) in grid.iter().zip(&from).zip(&win.world_from_sensor) {
            let d = g - offset_ns;
            match k {
                Some(k) => {
                    // The sample nearest to the device time, and its very orientation.
                    let nearest = (0..t_ns.len())
                        .min_by_key(|&i| (t_ns[i] - d).abs())
                        .unwrap();
                    assert_eq!(*k, nearest, "grid time {g}");
                    assert_eq!(q_grid, &q[*k]);
                }
                None => {
                    // Only inside the dropout, between samples 0.31 s apart.
                    assert!(d > 14_990_000_000 && d < 15_300_000_000, "grid time {g}");
                    assert!(q_grid.coords.iter().all(|c| c.is_nan()));
                    num_missing += 1;
                }
            }
        }
        assert!(num_missing >= 8, "{num_missing} grid points in the dropout");
        // The settled limit cuts the samples used, wherever the walk starts.
        let until = 14_500_000_000;
        imu_window_on_grid(
            &series, offset_ns, &grid, 50_000_000, until, &mut win, &mut from,
        );
        let used = grid.iter().zip(&from).filter(|(_, k)| k.is_some());
        assert!(used.clone().all(|(&g, _)| g - offset_ns < until));
        assert!(used.count() >= 14);
    }

    #[test]
    fn an_offset_is_contradicted_only_by_a_low_value_there_and_a_better_lag() {
        let offsets = [-200, -100, 0, 100, 200];
        let curve = [0.02, 0.03, 0.01, 0.25, 0.1];
        // Low at 0 (nearest grid point to 20) and 0.24 higher at 100.
        assert!(is_contradicted(&offsets, &curve, 20, 0.05, 0.05));
        // At the peak itself: no.
        assert!(!is_contradicted(&offsets, &curve, 100, 0.05, 0.05));
        // Low everywhere (no better lag): no.
        let flat = [0.02, 0.03, 0.01, 0.04, 0.0];
        assert!(!is_contradicted(&offsets, &flat, 0, 0.05, 0.05));
        // Disabled, and no evidence at all.
        assert!(!is_contradicted(&offsets, &curve, 20, -1.0, 0.05));
        assert!(!is_contradicted(&offsets, &[f64::NAN; 5], 0, 0.05, 0.05));
    }

    #[test]
    fn a_summed_peak_skips_the_range_ends_and_its_own_neighbourhood() {
        let offsets: Vec<i64> = (-5..=5).map(|k| k * 100).collect();
        // Highest at the range end (−500), then at 200; its neighbour 100 is no rival.
        let curve = [0.9, 0.1, 0.1, 0.3, 0.1, 0.2, 0.55, 0.6, 0.4, 0.1, 0.1];
        let (offset, peak, rival) = summed_peak(&offsets, &curve, 0, 500, 50, 150).unwrap();
        assert_eq!(offset, 200);
        assert_eq!(peak, 0.6);
        // 0.9 at −500 is farther than 150 from 200 and counts as a rival; 0.55 at 100 does not.
        assert_eq!(rival, 0.9);
        // The same rival for a peak read elsewhere; nothing far enough away gives −∞.
        assert_eq!(rival_value(&offsets, &curve, 200, 150), 0.9);
        assert_eq!(rival_value(&offsets, &curve, 0, 1_000), f64::NEG_INFINITY);
        let none = [f64::NAN; 11];
        assert!(summed_peak(&offsets, &none, 0, 500, 50, 150).is_none());
        assert!(mean_curve(&[(1.0, 2), (0.0, 0)])[1].is_nan());
        assert_eq!(mean_curve(&[(1.0, 2)]), vec![0.5]);
    }

    #[test]
    fn a_peak_must_fall_on_both_sides_towards_the_range_ends() {
        // A slope rising to the end: its highest value inside the range is no peak.
        let offsets: Vec<i64> = (-5..=5).map(|k| k * 100).collect();
        let ramp = [0.0, 0.05, 0.1, 0.15, 0.2, 0.25, 0.3, 0.35, 0.4, 0.45, 0.46];
        assert!(!falls_on_both_sides(&ramp, 9, PEAK_DROP));
        assert!(summed_peak(&offsets, &ramp, 0, 500, 50, 150).is_none());
        // The same slope levelling off and falling before the end is one.
        let mut bent = ramp;
        bent[10] = 0.42;
        assert!(falls_on_both_sides(&bent, 9, PEAK_DROP));
        assert_eq!(
            summed_peak(&offsets, &bent, 0, 500, 50, 150).unwrap().0,
            400
        );
        // The fall may lie farther away than the neighbour, but must be `drop` deep; a missing
        // value is no fall, and neither is an index past the end.
        let shallow = [0.1, 0.29, 0.3, 0.29, 0.1];
        assert!(falls_on_both_sides(&shallow, 2, 0.02));
        assert!(!falls_on_both_sides(&shallow, 2, 0.25));
        assert!(!falls_on_both_sides(&[f64::NAN, 0.3, 0.1], 1, 0.02));
        assert!(!falls_on_both_sides(&shallow, 5, 0.02));
    }

    #[test]
    fn a_lag_curve_needs_the_first_model() {
        // Two models on a 10 ms grid; the second one identical on both sides, the first missing
        // on the track, then present.
        let t: Vec<i64> = (0..200).map(|k| k * 10).collect();
        let wave: Vec<f64> = t
            .iter()
            .map(|&t| (t as f64 * 0.013).sin() + (t as f64 * 0.031).cos())
            .collect();
        let imu = LagSignals {
            t_ns: t.clone(),
            models: vec![wave.clone(), wave.clone()],
            sample_scale: 1.0,
        };
        let blind = LagSignals {
            t_ns: t.clone(),
            models: vec![vec![f64::NAN; t.len()], wave.clone()],
            sample_scale: 1.0,
        };
        let (mut weights, mut out) = (Vec::new(), Vec::new());
        lag_curve(
            &imu,
            &blind,
            1,
            &[-20, 0, 20],
            50,
            16,
            &mut weights,
            &mut out,
        );
        assert!(out.iter().all(|v| v.is_nan()), "{out:?}");
        let seen = LagSignals {
            t_ns: t,
            models: vec![wave.clone(), wave],
            sample_scale: 1.0,
        };
        lag_curve(
            &imu,
            &seen,
            1,
            &[-20, 0, 20],
            50,
            16,
            &mut weights,
            &mut out,
        );
        assert!((out[1] - 1.0).abs() < 1e-9, "{out:?}");
        assert!(out[0] < out[1] && out[2] < out[1], "{out:?}");
    }

    #[test]
    fn a_track_stride_pairs_every_other_sample_as_a_thinned_track_would() {
        // An IMU at 30 ms (a dropout, a missing value) and a track at 33 ms whose models
        // differ at odd and even samples, so that a stride that pairs the wrong samples changes
        // the curve.
        let t_imu: Vec<i64> = (0..400)
            .filter(|k| !(150..153).contains(k))
            .map(|k| k * 30_000_000)
            .collect();
        let wave = |t: i64, f: f64| ((t as f64 * 1e-9) * f).sin() + 0.3 * (t as f64 * 3e-9).cos();
        let mut imu_models: Vec<Vec<f64>> = (1..=3)
            .map(|m| t_imu.iter().map(|&t| wave(t, m as f64)).collect())
            .collect();
        imu_models[1][40] = f64::NAN;
        let imu = LagSignals {
            t_ns: t_imu,
            models: imu_models,
            sample_scale: 1.0,
        };
        let t_track: Vec<i64> = (10..330).map(|k| k * 33_333_333).collect();
        let track_models: Vec<Vec<f64>> = (1..=3)
            .map(|m| {
                t_track
                    .iter()
                    .enumerate()
                    .map(|(i, &t)| {
                        wave(t + 50_000_000, m as f64) + if i % 2 == 1 { 0.4 } else { 0.0 }
                    })
                    .collect()
            })
            .collect();
        let thinned = LagSignals {
            t_ns: t_track.iter().step_by(2).copied().collect(),
            models: track_models
                .iter()
                .map(|m| m.iter().step_by(2).copied().collect())
                .collect(),
            sample_scale: 1.0,
        };
        let track = LagSignals {
            t_ns: t_track,
            models: track_models,
            sample_scale: 1.0,
        };
        let offsets: Vec<i64> = (-10..=10).map(|k| k * 40_000_000).collect();
        let (mut weights, mut strided, mut expected, mut every) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let gap = 60_000_000;
        lag_curve(
            &imu,
            &track,
            2,
            &offsets,
            gap,
            16,
            &mut weights,
            &mut strided,
        );
        lag_curve(
            &imu,
            &thinned,
            1,
            &offsets,
            gap,
            16,
            &mut weights,
            &mut expected,
        );
        lag_curve(&imu, &track, 1, &offsets, gap, 16, &mut weights, &mut every);
        let bits = |c: &[f64]| c.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert!(expected.iter().all(|v| v.is_finite()), "{expected:?}");
        assert_eq!(bits(&strided), bits(&expected));
        assert_ne!(bits(&every), bits(&expected));
    }

    #[test]
    fn near_tied_peaks_go_to_the_smaller_offset() {
        let offsets = [-30, -20, -10, 0, 10, 20, 30];
        // Two local maxima: 0.80 at +20 and 0.79 at −10.
        let curve = [0.1, 0.5, 0.79, 0.6, 0.7, 0.8, 0.6];
        let (o, v) = curve_peak(&offsets, &curve, 0, 0.02).unwrap();
        assert!((-15..=-5).contains(&o), "{o}");
        assert!((v - 0.79).abs() < 1e-12);
        let (o, _) = curve_peak(&offsets, &curve, 0, 0.0).unwrap();
        assert!((15..=25).contains(&o), "{o}");
    }
}
