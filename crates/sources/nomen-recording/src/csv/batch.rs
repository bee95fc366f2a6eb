//! Batched delivery: a device that stamps its samples when it sends them, a few at a time (a
//! watch delivering 3–6 samples within 3 ms every 50 ms), detected from its intervals and
//! re-timed at the rate fitted to the batches.

use std::fmt;

/// The fewest samples a source needs before its intervals are judged.
pub const MIN_BATCH_SAMPLES: usize = 16;

/// How many times the mean interval must exceed the median one for a source to count as
/// batched. A steady source has the two about equal (dropouts raise the mean by their share of
/// the time); a source delivering 3–6 samples a batch has a median 10 to 50 times below its
/// mean.
pub const BATCH_MEAN_OVER_MEDIAN: f64 = 4.0;

/// How many times the median gap between batches a gap may last and still count in the fitted
/// rate: batches leave at a steady interval, a lost batch doubles it.
pub const DROPOUT_GAP_OVER_MEDIAN: f64 = 1.5;

/// What an import does with a source it finds batched.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BatchPolicy {
    /// Re-time its samples at the fitted rate (the last of each batch keeps its time, the
    /// others step back at the fitted period) and report it.
    #[default]
    Retime,
    /// Keep the file's times and report it.
    Keep,
}

/// A source found batched: the numbers behind the finding and the rate fitted to it.
#[derive(Debug, Clone, PartialEq)]
pub struct Batching {
    /// The source, e.g. `imu sample of 'watch'`.
    pub source: String,
    /// Its samples.
    pub num_samples: usize,
    /// The batches they came in.
    pub num_batches: usize,
    /// The median interval between consecutive time stamps, s.
    pub median_interval_s: f64,
    /// The mean interval (first to last stamp over the samples), s.
    pub mean_interval_s: f64,
    /// The sampling rate fitted to the batches, Hz.
    pub fitted_rate_hz: f64,
    /// Whether the samples were re-timed at that rate.
    pub is_retimed: bool,
}

impl fmt::Display for Batching {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} arrives in batches: {} samples in {} batches, median interval {:.2} ms against \
             a mean of {:.2} ms; fitted rate {:.2} Hz",
            self.source,
            self.num_samples,
            self.num_batches,
            self.median_interval_s * 1e3,
            self.mean_interval_s * 1e3,
            self.fitted_rate_hz
        )?;
        if self.is_retimed {
            write!(
                f,
                ", samples re-timed at that rate (the last of each batch keeps its time)"
            )
        } else {
            write!(f, ", times kept as in the file")
        }
    }
}

/// The batches of sorted times `t_ns` and their fitted sample period, if the source is batched.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct BatchFit {
    /// Index one past the last sample of each batch.
    pub(crate) ends: Vec<usize>,
    /// The fitted sample period, ns.
    pub(crate) period_ns: f64,
    pub(crate) median_interval_ns: f64,
    pub(crate) mean_interval_ns: f64,
}

/// Finds batched delivery in sorted times: at least [`MIN_BATCH_SAMPLES`], a mean interval
/// [`BATCH_MEAN_OVER_MEDIAN`] times the median or more, and at least three batches, a batch
/// ending at an interval above half the mean. The period is the time between the ends of
/// consecutive batches over the samples the later one brought, summed over every batch after
/// the first whose gap is at most [`DROPOUT_GAP_OVER_MEDIAN`] times the median gap (a
/// dropout's gap, and the samples it lost, are left out).
pub(crate) fn detect(t_ns: &[i64]) -> Option<BatchFit> {
    let n = t_ns.len();
    if n < MIN_BATCH_SAMPLES {
        return None;
    }
    let (first, last) = (*t_ns.first()?, *t_ns.last()?);
    let mean = last.saturating_sub(first) as f64 / (n - 1) as f64;
    let mut intervals: Vec<i64> = t_ns.windows(2).map(|w| w[1].saturating_sub(w[0])).collect();
    let mid = intervals.len() / 2;
    let median = *intervals.select_nth_unstable(mid).1 as f64;
    if mean <= 0.0 || median * BATCH_MEAN_OVER_MEDIAN > mean {
        return None;
    }
    let mut ends: Vec<usize> = t_ns
        .windows(2)
        .enumerate()
        .filter(|(_, w)| w[1].saturating_sub(w[0]) as f64 > mean / 2.0)
        .map(|(i, _)| i + 1)
        .collect();
    ends.push(n);
    if ends.len() < 3 {
        return None;
    }
    // Per batch after the first: (gap since the previous batch's end, samples).
    let shares: Vec<(f64, f64)> = ends
        .windows(2)
        .map(|w| {
            let gap = t_ns[w[1] - 1].saturating_sub(t_ns[w[0] - 1]);
            (gap as f64, (w[1] - w[0]) as f64)
        })
        .collect();
    let mut gaps: Vec<f64> = shares.iter().map(|(g, _)| *g).collect();
    let mid = gaps.len() / 2;
    let median_gap = *gaps.select_nth_unstable_by(mid, f64::total_cmp).1;
    let (gap, num) = shares
        .iter()
        .filter(|(g, _)| *g <= DROPOUT_GAP_OVER_MEDIAN * median_gap)
        .fold((0.0, 0.0), |(sg, sk), (g, k)| (sg + g, sk + k));
    let period_ns = gap / num;
    (period_ns.is_finite() && period_ns > 0.0).then_some(BatchFit {
        ends,
        period_ns,
        median_interval_ns: median,
        mean_interval_ns: mean,
    })
}

/// Re-times batched samples: the last sample of each batch keeps its time (a batch leaves when
/// its last sample is taken) and the ones before it step back at the fitted period, or, where a
/// batch brought more samples than its gap holds at that period, at the gap over its samples,
/// so times stay in order.
pub(crate) fn retime(t_ns: &mut [i64], fit: &BatchFit) {
    let mut start = 0;
    let mut previous_end: Option<i64> = None;
    for &end in &fit.ends {
        let Some(&anchor) = end.checked_sub(1).and_then(|i| t_ns.get(i)) else {
            break;
        };
        let num = (end - start) as f64;
        let step = match previous_end {
            Some(p) => fit.period_ns.min(anchor.saturating_sub(p) as f64 / num),
            None => fit.period_ns,
        };
        for (k, t) in t_ns.iter_mut().enumerate().take(end).skip(start) {
            let back = (end - 1 - k) as f64 * step;
            *t = anchor.saturating_sub(back.round() as i64);
        }
        previous_end = Some(anchor);
        start = end;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 100-Hz watch that sends what it has every 50 ms,
    /// its samples stamped on arrival 0.5 ms apart
    /// (stamps and true times); `skip` leaves batch slots out (dropouts).
    fn watch(num_batches: usize, skip: &[usize]) -> (Vec<i64>, Vec<i64>) {
        let mut stamped = Vec::new();
        let mut truth = Vec::new();
        let mut next_sample = 0i64;
        for b in 1..=num_batches as i64 {
            let sent = b * 50_000_000;
            let mut batch = Vec::new();
            while next_sample <= sent - 1_000_000 {
                batch.push(next_sample);
                next_sample += 10_000_000;
            }
            if skip.contains(&(b as usize)) {
                continue;
            }
            let k = batch.len() as i64;
            for (i, t) in batch.into_iter().enumerate() {
                truth.push(t);
                stamped.push(sent - (k - 1 - i as i64) * 500_000);
            }
        }
        (stamped, truth)
    }

    #[test]
    fn a_watch_sending_every_50_ms_is_batched_at_100_hz() {
        let (stamped, truth) = watch(200, &[]);
        let fit = detect(&stamped).expect("batched");
        assert!(
            (fit.period_ns - 10_000_000.0).abs() < 1e3,
            "{}",
            fit.period_ns
        );
        assert!(fit.median_interval_ns <= 500_000.0);
        let mut t = stamped.clone();
        retime(&mut t, &fit);
        // Re-timed, every sample is as long after it was taken as the first (the delay from
        // the last sample of a batch to its sending), to the microsecond.
        let delay = t[0] - truth[0];
        for (re, true_t) in t.iter().zip(&truth) {
            assert!((re - true_t - delay).abs() < 1_000, "{re} vs {true_t}");
        }
    }

    #[test]
    fn dropouts_leave_the_rate_and_the_order_alone() {
        let (stamped, _) = watch(200, &[40, 41, 42, 100]);
        let fit = detect(&stamped).expect("batched");
        assert!(
            (fit.period_ns - 10_000_000.0).abs() < 1e3,
            "{}",
            fit.period_ns
        );
        let mut t = stamped;
        retime(&mut t, &fit);
        assert!(t.windows(2).all(|w| w[1] > w[0]));
    }

    #[test]
    fn a_steady_source_with_jitter_and_gaps_is_not_batched() {
        let t: Vec<i64> = (0..500i64)
            .filter(|i| i % 50 != 7)
            .map(|i| i * 10_000_000 + (i * 7919 % 13) * 100_000)
            .collect();
        assert_eq!(detect(&t), None);
        assert_eq!(detect(&[0, 1, 2]), None);
    }

    proptest::proptest! {
        #[test]
        fn any_sorted_times_are_judged_without_panic_and_retimed_in_order(
            mut t in proptest::collection::vec(-4_000_000_000_000_000_000i64..4_000_000_000_000_000_000, 0..200),
        ) {
            t.sort_unstable();
            if let Some(fit) = detect(&t) {
                let mut re = t.clone();
                retime(&mut re, &fit);
                proptest::prop_assert!(re.windows(2).all(|w| w[1] >= w[0]));
            }
        }

        #[test]
        fn batches_of_any_size_are_retimed_strictly_in_order(
            sizes in proptest::collection::vec(1usize..12, 20..80),
        ) {
            let mut t = Vec::new();
            for (b, &k) in sizes.iter().enumerate() {
                let sent = (b as i64 + 1) * 50_000_000;
                for i in 0..k {
                    t.push(sent - (k - 1 - i) as i64 * 300_000);
                }
            }
            if let Some(fit) = detect(&t) {
                retime(&mut t, &fit);
                proptest::prop_assert!(t.windows(2).all(|w| w[1] > w[0]), "{:?}", t);
            }
        }
    }
}
