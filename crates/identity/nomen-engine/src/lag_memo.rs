//! An IMU's lag-search signals, kept from one window's search to the next.
//!
//! Every search correlates each IMU over a buffer of about 14 s that moves by a hop (0.5 s)
//! per window. Built from the raw samples each time, every IMU sample would go through the
//! filters about 20 times on the 8-person body-area-network scene (600 buffers of 1,300
//! samples per 10 s of session), an eighth of the engine's time. The signals are local (the
//! 3 Hz zero-phase low-pass forgets within about a second, the swing angle looks 0.2 s back,
//! the turn rate averages over the last second), so a value far enough from the ends of the
//! samples it was computed from is close to what any longer buffer would give. A [`LagMemo`]
//! keeps those values; each search computes afresh only the newest part, with [`CONTEXT_NS`]
//! of older samples before it to let the filters settle, and joins the two.
//!
//! What changes against a buffer filtered from scratch: the buffer's first values are the
//! settled ones instead of the low-pass's start-up, and the kept samples (every `step`-th)
//! are counted from the stream's first sample instead of the buffer's. The orientation change
//! is still measured from the buffer's first kept sample: it is computed per request from the
//! kept orientations. Neither change moves the accuracy beyond the noise, and with known
//! offsets it does not move at all.
//!
//! The tracks' side is not kept this way: the camera-side models estimate the sampling rate
//! from the buffer (`(n − 1) / span`), which a track's missing frames lower, so a part computed
//! afresh is filtered at a different rate than the whole buffer, and values differ by a few
//! per cent, which costs accuracy for little speed (a track's buffer holds about 5 s, not 14).

use crate::signal::{ImuSeries, LagSignals};
use nalgebra::UnitQuaternion;
use nomen_evidence::angle::rotation_angle_rad;
use nomen_evidence::{GeometricConfig, ImuWindow, KinematicConfig, imu_unanchored_lag_models};
use std::collections::VecDeque;

/// Samples before the part computed afresh, ns: the low-pass's start-up and the turn rate's
/// one-second average are over within them.
const CONTEXT_NS: i64 = 1_500_000_000;

/// A value is kept for later searches once the samples it was computed from reach this far
/// beyond it, ns (the zero-phase low-pass's backward pass starts at the newest sample).
const MARGIN_NS: i64 = 1_000_000_000;

/// Kept values older than this before the newest buffer's start are dropped, ns: a buffer
/// cut at a newly accepted offset may start up to a second (twice the largest clock offset)
/// earlier than the last one; one that starts earlier still is computed from scratch.
const KEEP_NS: i64 = 2_000_000_000;

/// Fewest samples of a buffer (shorter ones have no signals).
const MIN_SAMPLES: usize = 16;

/// Values of a stream's kept samples (every `step`-th, counted from the stream's first) that
/// earlier requests computed far enough from both ends of their samples.
#[derive(Debug, Clone)]
pub(crate) struct LagMemo<V> {
    /// `(time, value)` of kept samples, time increasing.
    kept: VecDeque<(i64, V)>,
    /// Times `[from, until)` whose kept samples' values are final.
    from_ns: i64,
    until_ns: i64,
}

impl<V> Default for LagMemo<V> {
    fn default() -> Self {
        Self {
            kept: VecDeque::new(),
            from_ns: i64::MAX,
            until_ns: i64::MIN,
        }
    }
}

impl<V: Copy> LagMemo<V> {
    /// The values of the kept samples at times `[lo_ns, until_ns)` of a stream of `len`
    /// samples whose times are `time(0..len)` (increasing; sample 0 is the stream's sample
    /// `first_index`), with their times; `None` with fewer than [`MIN_SAMPLES`] samples there.
    /// `fresh(start, end)` computes, from the samples `start..end` alone, the values at
    /// `start`, `start + step`, … (`start` is a kept sample); only the newest part is asked
    /// for.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn values(
        &mut self,
        len: usize,
        time: impl Fn(usize) -> i64,
        first_index: usize,
        step: usize,
        lo_ns: i64,
        until_ns: i64,
        fresh: impl FnOnce(usize, usize) -> Vec<V>,
    ) -> Option<Vec<(i64, V)>> {
        let step = step.max(1);
        let before = |limit: i64| partition_point(len, &time, limit);
        let a = before(lo_ns);
        let b = before(until_ns);
        if b < a + MIN_SAMPLES {
            return None;
        }
        let is_valid = self.from_ns <= lo_ns && self.until_ns > lo_ns;
        if !is_valid {
            self.kept.clear();
            self.from_ns = lo_ns;
            self.until_ns = lo_ns;
        }
        // Where the values computed now take over from the kept ones.
        let fresh_from = self.until_ns;
        let computed: Vec<(i64, V)> = if fresh_from < until_ns {
            let start = before(fresh_from - CONTEXT_NS);
            // The first kept sample (its stream index a multiple of `step`) at or after it.
            let start = start + (step - (first_index + start) % step) % step;
            if start < b {
                let values = fresh(start, b);
                (start..b).step_by(step).map(&time).zip(values).collect()
            } else {
                Vec::new()
            }
        } else {
            Vec::new()
        };
        let joined: Vec<(i64, V)> = self
            .kept
            .iter()
            .filter(|(t, _)| *t >= lo_ns && *t < fresh_from.min(until_ns))
            .chain(
                computed
                    .iter()
                    .filter(|(t, _)| *t >= fresh_from && *t < until_ns),
            )
            .copied()
            .collect();
        // Keep what is now far enough from the newest sample; drop what no buffer will read.
        let final_until = until_ns - MARGIN_NS;
        if final_until > self.until_ns {
            let from = self.until_ns;
            self.kept.extend(
                computed
                    .iter()
                    .filter(|(t, _)| *t >= from && *t < final_until),
            );
            self.until_ns = final_until;
        }
        let keep_from = lo_ns - KEEP_NS;
        while self.kept.front().is_some_and(|(t, _)| *t < keep_from) {
            self.kept.pop_front();
        }
        self.from_ns = self.from_ns.max(keep_from);
        Some(joined)
    }
}

/// The number of samples `0..len` whose `time` is below `limit` (times increase).
fn partition_point(len: usize, time: impl Fn(usize) -> i64, limit: i64) -> usize {
    let (mut lo, mut hi) = (0, len);
    while lo < hi {
        let mid = lo + (hi - lo) / 2;
        if time(mid) < limit {
            lo = mid + 1;
        } else {
            hi = mid;
        }
    }
    lo
}

/// An IMU's kept lag values: its orientation and the four models that need no reference
/// (acceleration magnitude, vertical acceleration, swing, turn rate).
pub(crate) type ImuLagMemo = LagMemo<(UnitQuaternion<f64>, [f64; 4])>;

/// The lag signals of an IMU's samples at device times `[lo_ns, until_ns)`:
/// `nomen_evidence::imu_lag_models`' five (acceleration, orientation change from the first
/// kept sample, vertical acceleration, swing, turn rate) at every `step`-th sample counted
/// from the IMU's first (`series` starts at its sample `first_index`); `None` if too short.
#[allow(clippy::too_many_arguments)]
pub(crate) fn imu_lag_signals(
    memo: &mut ImuLagMemo,
    series: &ImuSeries<'_>,
    first_index: usize,
    step: usize,
    lo_ns: i64,
    until_ns: i64,
    geo: &GeometricConfig,
    kin: &KinematicConfig,
) -> Option<LagSignals> {
    let fresh = |start: usize, end: usize| -> Vec<(UnitQuaternion<f64>, [f64; 4])> {
        let (Some(t_ns), Some(accel), Some(gyro), Some(q)) = (
            series.t_ns.get(start..end),
            series.accel_mps2.get(start..end),
            series.gyro_radps.get(start..end),
            series.world_from_sensor.get(start..end),
        ) else {
            return Vec::new();
        };
        let window = ImuWindow {
            device: None,
            t_s: t_ns.iter().map(|&t| t as f64 * 1e-9).collect(),
            accel_mps2: accel.to_vec(),
            gyro_radps: gyro.to_vec(),
            world_from_sensor: q.to_vec(),
        };
        let [acc, vertical, swing, turn] = imu_unanchored_lag_models(&window, geo, kin, step);
        q.iter()
            .step_by(step)
            .zip(acc.iter().zip(&vertical).zip(swing.iter().zip(&turn)))
            .map(|(q, ((&a, &v), (&s, &r)))| (*q, [a, v, s, r]))
            .collect()
    };
    let t_ns = series.t_ns;
    let time = |i: usize| t_ns.get(i).copied().unwrap_or(i64::MAX);
    let kept = memo.values(t_ns.len(), time, first_index, step, lo_ns, until_ns, fresh)?;
    let is_finite = |q: &UnitQuaternion<f64>| q.coords.iter().all(|c| c.is_finite());
    let reference = kept
        .iter()
        .map(|(_, (q, _))| *q)
        .find(is_finite)
        .map(|q| q.inverse());
    let column = |m: usize| -> Vec<f64> {
        kept.iter()
            .map(|(_, (_, v))| v.get(m).copied().unwrap_or(f64::NAN))
            .collect()
    };
    let orientation = kept
        .iter()
        .map(|(_, (q, _))| match reference {
            Some(r) if is_finite(q) => rotation_angle_rad(&(r * q)),
            _ => f64::NAN,
        })
        .collect();
    Some(LagSignals {
        t_ns: kept.iter().map(|(t, _)| *t).collect(),
        models: vec![column(0), orientation, column(1), column(2), column(3)],
        sample_scale: 1.0,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    /// Times of a 100 Hz stream from 0 to `seconds`, ns.
    fn times(seconds: i64) -> Vec<i64> {
        (0..seconds * 100).map(|k| k * 10_000_000).collect()
    }

    /// Which samples each value was computed from: `(sample, start, end)` of its `fresh` call.
    type Provenance = (usize, usize, usize);

    #[test]
    fn every_value_comes_from_samples_that_reach_far_enough_around_it() {
        let t = times(40);
        let time = |i: usize| t.get(i).copied().unwrap_or(i64::MAX);
        let mut memo: LagMemo<Provenance> = LagMemo::default();
        let step = 3;
        let first_index = 7;
        let mut num_fresh_samples = 0;
        // A buffer of 14 s moving by 0.5 s, its end clipped at the stream's end.
        for window in 0..60 {
            let lo = window * 500_000_000 - 4_000_000_000;
            let until = (lo + 14_000_000_000).min(40_000_000_000);
            let values = memo
                .values(t.len(), time, first_index, step, lo, until, |start, end| {
                    num_fresh_samples += end - start;
                    (start..end)
                        .step_by(step)
                        .map(|i| (i, start, end))
                        .collect()
                })
                .expect("long enough");
            let b = t.partition_point(|&x| x < until);
            let a = t.partition_point(|&x| x < lo);
            // Every kept sample of the buffer, once, in order, counted from the stream's first.
            let expected: Vec<usize> = (a..b).filter(|i| (first_index + i) % step == 0).collect();
            let got: Vec<usize> = values.iter().map(|(_, (i, _, _))| *i).collect();
            assert_eq!(got, expected, "window {window}");
            for (time_ns, (i, start, end)) in &values {
                assert_eq!(*time_ns, time(*i));
                // Enough samples before it (or all there were; the computation starts at a
                // kept sample, up to `step − 1` samples after the context's start) ...
                let slack = (step as i64 - 1) * 10_000_000;
                assert!(*start < step || time(*start) <= time_ns - 1_500_000_000 + slack);
                // ... and a second after it, unless computed now, up to the buffer's end.
                assert!(*end == b || time(end - 1) >= time_ns + 990_000_000);
            }
        }
        // Far fewer samples went through `fresh` than 60 buffers of 14 s hold.
        assert!(num_fresh_samples < 60 * 1400 / 3, "{num_fresh_samples}");
    }

    #[test]
    fn a_buffer_starting_before_the_kept_values_is_computed_afresh() {
        let t = times(30);
        let time = |i: usize| t.get(i).copied().unwrap_or(i64::MAX);
        let mut memo: LagMemo<Provenance> = LagMemo::default();
        let fresh = |start: usize, end: usize| -> Vec<Provenance> {
            (start..end).map(|i| (i, start, end)).collect()
        };
        let lo = 10_000_000_000;
        memo.values(t.len(), time, 0, 1, lo, lo + 10_000_000_000, fresh)
            .expect("long enough");
        // Three seconds earlier: beyond what the memo keeps.
        let earlier = lo - 3_000_000_000;
        let values = memo
            .values(t.len(), time, 0, 1, earlier, lo + 10_000_000_000, fresh)
            .expect("long enough");
        assert_eq!(values.first().map(|(t, _)| *t), Some(earlier));
        let start = t.partition_point(|&x| x < earlier - CONTEXT_NS);
        assert!(values.iter().all(|(_, (_, s, _))| *s == start));
        // Too few samples: nothing.
        assert!(
            memo.values(t.len(), time, 0, 1, lo, lo + 100_000_000, fresh)
                .is_none()
        );
    }

    #[test]
    fn imu_signals_from_the_memo_match_a_buffer_filtered_at_once() {
        // A walking-like wrist: swinging about y at 1 Hz while the body turns slowly.
        let t = times(30);
        let q: Vec<UnitQuaternion<f64>> = t
            .iter()
            .map(|&t| {
                let s = t as f64 * 1e-9;
                UnitQuaternion::from_euler_angles(
                    0.0,
                    0.5 * (std::f64::consts::TAU * s).sin(),
                    0.1 * s,
                )
            })
            .collect();
        let accel: Vec<Vector3<f64>> = t
            .iter()
            .zip(&q)
            .map(|(&t, q)| {
                let s = t as f64 * 1e-9;
                let linear = Vector3::new(
                    2.0 * (std::f64::consts::TAU * s).cos(),
                    0.0,
                    (9.0 * s).sin(),
                );
                q.inverse() * (linear + Vector3::new(0.0, 0.0, 9.81))
            })
            .collect();
        let gyro: Vec<Vector3<f64>> = t
            .iter()
            .map(|&t| {
                let s = t as f64 * 1e-9;
                Vector3::new(
                    0.0,
                    0.5 * std::f64::consts::TAU * (std::f64::consts::TAU * s).cos(),
                    0.1,
                )
            })
            .collect();
        let series = ImuSeries {
            t_ns: &t,
            accel_mps2: &accel,
            gyro_radps: &gyro,
            world_from_sensor: &q,
        };
        let geo = GeometricConfig {
            moving_average_len: 1,
            ..GeometricConfig::default()
        };
        let kin = KinematicConfig::default();
        let mut memo = ImuLagMemo::default();
        for window in 0..20 {
            let lo = window * 500_000_000;
            let until = lo + 13_000_000_000;
            let got = imu_lag_signals(&mut memo, &series, 0, 3, lo, until, &geo, &kin)
                .expect("long enough");
            // The same buffer filtered at once, from its first kept sample.
            let a = t.partition_point(|&x| x < lo);
            let a = a + (3 - a % 3) % 3;
            let b = t.partition_point(|&x| x < until);
            let window_at_once = ImuWindow {
                device: None,
                t_s: t[a..b].iter().map(|&t| t as f64 * 1e-9).collect(),
                accel_mps2: accel[a..b].to_vec(),
                gyro_radps: gyro[a..b].to_vec(),
                world_from_sensor: q[a..b].to_vec(),
            };
            let at_once = nomen_evidence::imu_lag_models(&window_at_once, &geo, &kin, 3);
            assert_eq!(
                got.t_ns,
                t[a..b].iter().step_by(3).copied().collect::<Vec<_>>()
            );
            for (m, (mine, theirs)) in got.models.iter().zip(&at_once).enumerate() {
                let scale = theirs.iter().fold(0.0_f64, |s, v| s.max(v.abs()));
                for (k, (x, y)) in mine.iter().zip(theirs).enumerate() {
                    // Past the buffer's start-up, which the memo no longer has.
                    if got.t_ns[k] < lo + CONTEXT_NS || !y.is_finite() {
                        continue;
                    }
                    assert!(
                        (x - y).abs() <= 2e-3 * scale,
                        "window {window} model {m} sample {k}: {x} against {y} (scale {scale})"
                    );
                }
            }
        }
    }
}
