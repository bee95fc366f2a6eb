//! Clock-offset estimation: the lag search over every IMU and candidate track, run at each
//! window before scoring (see the crate docs, step 1), and the per-window caches of its signals
//! and curves.

#[cfg(test)]
use super::MAX_IMU_GAP_NS;
use super::{
    COARSE_LAG_STEPS, COARSE_TRACK_STRIDE, Engine, ImuState, LAG_DECIMATION, LAG_MIN_TRACK_SAMPLES,
    LAG_STEP_NS, OFFSET_PEAK_SEPARATION_NS, TrackKey, TrackSample, TrackState, covered_span,
    max_imu_gap_ns, sample_range, scaled_count,
};
use crate::config::{EngineConfig, OFFSET_CONFIRM_HISTORY, ns};
use crate::lag_memo::{self, ImuLagMemo};
use crate::signal::{
    LagSignals, LagWeight, PEAK_DROP, curve_peak, falls_on_both_sides, is_contradicted, lag_curve,
    mean_curve, rival_value, summed_peak,
};
use crate::stats::EngineStats;
use nalgebra::Point3;
use nomen_core::skeleton::Joints;
use nomen_core::{DeviceId, Joint, TrackId};
use nomen_evidence::{
    GeometricConfig, SkeletonWindow, body_turn_rate_signal, segment_site_lag_models,
};
use std::cmp::Reverse;
use std::collections::BTreeMap;

impl Engine {
    /// Clock offsets. A device without an accepted offset is searched every
    /// `offset_search_interval_s` jointly with its wearer's identity: for every candidate track,
    /// each of the subject's IMUs gets a lag curve over `offset_estimation_window_s`; the
    /// subject's score for a track is the mean of its IMUs' peaks. When the best track beats the
    /// next one of its camera by `offset_margin` and every other subject's score on it by
    /// `offset_subject_margin` (a subject with accepted offsets is read at them only), each
    /// unaccepted IMU's peak lag on that track is a candidate; `offset_num_consistent` agreeing
    /// candidates in a row make the offset. Lag curves against the tracks labelled with an IMU's
    /// wearer are summed per IMU: a clear peak of the sum accepts an offset, or moves an accepted
    /// one, and a sum that contradicts an accepted offset withdraws it (see the crate docs).
    /// Every IMU also sums, over passes, the best value of its lag curves over all candidate
    /// tracks at each lag; a clear peak of that sum accepts or moves its offset. An
    /// accepted offset is refined every `offset_refine_interval_s` against the tracks labelled
    /// with its wearer (their curves averaged, weighted by coverage).
    pub(super) fn update_offsets(&mut self, end: i64) {
        let max_off = ns(self.config.max_clock_offset_s);
        let span = ns(self.config.offset_estimation_window_s);
        let hi = end - max_off;
        let lo = hi - span;
        // Lags relative to each device's prior (the registry's offset): the fine grid, and the
        // coarse one the searches for unknown offsets start from.
        let full: Vec<i64> = (-max_off / LAG_STEP_NS..=max_off / LAG_STEP_NS)
            .map(|k| k * LAG_STEP_NS)
            .collect();
        let coarse: Vec<i64> = full.iter().step_by(COARSE_LAG_STEPS).copied().collect();
        let min_track = ns(self.config.offset_min_track_s);
        let search_every = ns(self.config.offset_search_interval_s);
        let refine_every = ns(self.config.offset_refine_interval_s);
        let refine_max = ns(self.config.offset_refine_max_interval_s);
        let refine_range = ns(self.config.offset_refine_range_s);
        let confirm_apart = ns(self.config.offset_confirm_apart_s);
        let same_offset = ns(self.config.offset_consistency_s);
        // Each camera's rate over 30 Hz: a track's lag curves need as much time as at 30 Hz.
        let camera_scales: Vec<f64> = (0..self.cameras.len())
            .map(|c| self.camera_scale(c))
            .collect();
        let skel_cache = TrackLagCache::new(camera_scales.clone());
        // Each IMU's lag signals kept from the last window's search, put back at the end.
        let lag_memos: Vec<ImuLagMemo> = self
            .imus
            .iter_mut()
            .map(|m| std::mem::take(&mut m.lag_memo))
            .collect();
        // An IMU's buffer, per (IMU, offset it was cut with), for the three uses below.
        let imu_cache = ImuLagCache {
            lo: lo - max_off,
            hi: hi + max_off,
            signals: BTreeMap::new(),
        };
        // Interpolation weights and curve, reused by every lag curve.
        let scratch = LagScratch::default();
        let min_samples = self.config.geometric.min_samples;
        let fine = Vec::new();
        // Every subject's mean peak per track; the accepted offsets of a subject are read at
        // themselves only. Subjects with nothing to search still score the tracks a searching
        // subject would win, so a track that clearly belongs to someone else is no candidate
        // for a searching subject.
        // One search phase for everyone: subjects whose offsets are withdrawn or who are new
        // join the next search instead of adding their own.
        // A network IMU with nothing to be scored at searches at every window (see
        // `EngineConfig::offset_search_while_blind`), if it has samples the search can read: a
        // registered device that is not there (its wearer absent, or gone) would otherwise
        // keep every search at every window.
        let is_blind = self.config.offset_search_while_blind
            && self.imus.iter().any(|m| {
                !m.is_offset_known
                    && m.pair_offsets.is_empty()
                    && m.lag_hypotheses.is_empty()
                    && self.is_network(m.subject)
                    && m.t
                        .back()
                        .is_some_and(|&t| t.saturating_add(m.offset_ns) >= lo - max_off)
            });
        let is_search_time = is_blind || end.saturating_sub(self.last_search_end) >= search_every;
        let any_due = is_search_time && self.imus.iter().any(|m| !m.is_offset_known);
        if any_due {
            self.last_search_end = end;
        }
        // Nothing to search: the loops below do nothing.
        let num_scored = if any_due { self.subjects.len() } else { 0 };
        let candidates: Vec<(usize, TrackId)> = self
            .tracks
            .iter()
            .filter(|(_, tr)| covered_span(tr, lo, hi) >= min_track)
            .map(|(k, _)| *k)
            .collect();
        // While no track is long enough to be a candidate, the shorter ones: their lags score
        // them (see `EngineConfig::offset_short_track_s`), nothing more.
        // They read everything up to the window's end, not where the buffer stops: they are
        // never offset candidates, so lags whose IMU samples have not all arrived yet only cost
        // them a few pairs, and a track seen since the session's start is first scored at the
        // window ending at 1.5 s instead of 2.5 s.
        let short_min = ns(self.config.offset_short_track_s);
        let short_hi = end;
        let short: Vec<(usize, TrackId)> = if candidates.is_empty() && short_min > 0 {
            self.tracks
                .iter()
                .filter(|(_, tr)| {
                    covered_span(tr, lo, hi) < min_track
                        && covered_span(tr, lo, short_hi) >= short_min
                })
                .map(|(k, _)| *k)
                .collect()
        } else {
            Vec::new()
        };
        let short_skel_cache = TrackLagCache::new(camera_scales);
        let short_imu_cache = ImuLagCache {
            lo: lo - max_off,
            hi: short_hi + max_off,
            signals: BTreeMap::new(),
        };
        // Per subject: mean peak per track.
        let subject_scores: Vec<BTreeMap<(usize, TrackId), f64>> =
            vec![BTreeMap::new(); self.subjects.len()];
        // Per (unaccepted IMU, track): the peak lag, and whether the peak is clear (a short
        // track's is marked unclear: it only scores).
        let peaks: BTreeMap<(usize, (usize, TrackId)), (i64, bool)> = BTreeMap::new();
        // Whether each subject has an IMU still unaccepted: only those search. The others'
        // scores only matter on the tracks a searching subject would win (below).
        let is_searching: Vec<bool> = (0..num_scored)
            .map(|b| {
                self.subject_imus.get(b).is_some_and(|mine| {
                    mine.iter()
                        .any(|&i| self.imus.get(i).is_some_and(|m| !m.is_offset_known))
                })
            })
            .collect();
        let mut search = LagSearch {
            end,
            lo,
            hi,
            max_off,
            min_samples,
            min_track,
            refine_every,
            refine_max,
            refine_range,
            search_every,
            coarse,
            full,
            candidates,
            imu_cache,
            skel_cache,
            scratch,
            lag_memos,
            num_scored,
            is_searching,
            subject_scores,
            peaks,
            short,
            short_hi,
            short_skel_cache,
            short_imu_cache,
            fine,
            confirm_apart,
            same_offset,
        };
        self.score_subjects(&mut search);
        self.score_contested(&mut search);
        self.accept_joint_winners(&mut search);
        self.best_track_pass(&mut search);
        self.move_to_unexplained_peaks(&mut search);
        self.sum_labelled_curves(&mut search);
        self.refine_offsets(&mut search);
        for (imu, memo) in self.imus.iter_mut().zip(search.lag_memos) {
            imu.lag_memo = memo;
        }
    }

    /// The joint search's first step: every searching subject's lag curves against every
    /// candidate (and, while there is none, every short) track, giving the subject's mean
    /// peak per track and each unaccepted IMU's peak lag per track.
    fn score_subjects(&mut self, search: &mut LagSearch) {
        let lo = search.lo;
        let hi = search.hi;
        let max_off = search.max_off;
        let min_samples = search.min_samples;
        let num_scored = search.num_scored;
        let short_hi = search.short_hi;
        let coarse = &search.coarse;
        let candidates = &search.candidates;
        let is_searching = &search.is_searching;
        let short = &search.short;
        let imu_cache = &mut search.imu_cache;
        let skel_cache = &mut search.skel_cache;
        let scratch = &mut search.scratch;
        let lag_memos = &mut search.lag_memos;
        let subject_scores = &mut search.subject_scores;
        let peaks = &mut search.peaks;
        let short_skel_cache = &mut search.short_skel_cache;
        let short_imu_cache = &mut search.short_imu_cache;
        let fine = &mut search.fine;
        for b in 0..num_scored {
            let Some(mine) = self.subject_imus.get(b).cloned() else {
                continue;
            };
            if !is_searching.get(b).copied().unwrap_or(false) {
                continue;
            }
            let mut track_score: BTreeMap<(usize, TrackId), (f64, usize)> = BTreeMap::new();
            for &i in &mine {
                let Some(imu) = self.imus.get(i) else {
                    continue;
                };
                let Some(imu_sig) =
                    imu_cache.signals(i, imu, imu.offset_ns, lag_memos, &self.config)
                else {
                    continue;
                };
                let short_imu_sig = if short.is_empty() || imu.is_offset_known {
                    None
                } else {
                    short_imu_cache.signals(i, imu, imu.offset_ns, lag_memos, &self.config)
                };
                // Unknown offsets: a coarse grid over the whole range, then the fine grid
                // around the coarse peak (a quarter of the work of the fine grid throughout).
                // A known offset is only read at itself: the IMU's correlation there tells
                // which track its wearer is (refinement is separate, below).
                let prior = imu.registry_offset_ns;
                let offsets: Vec<i64> = if imu.is_offset_known {
                    vec![imu.offset_ns]
                } else {
                    coarse.iter().map(|o| o + prior).collect()
                };
                let is_coarse = !imu.is_offset_known;
                let shorts: &[(usize, TrackId)] = if is_coarse { short } else { &[] };
                for (key, is_short) in candidates
                    .iter()
                    .map(|k| (k, false))
                    .chain(shorts.iter().map(|k| (k, true)))
                {
                    let (imu_sig, sig) = if is_short {
                        let (Some(imu_sig), Some(sig)) = (
                            short_imu_sig,
                            short_skel_cache.signals(
                                &self.tracks,
                                *key,
                                imu.sides(),
                                lo,
                                short_hi,
                                &self.config,
                            ),
                        ) else {
                            continue;
                        };
                        (imu_sig, sig)
                    } else {
                        let Some(sig) = skel_cache.signals(
                            &self.tracks,
                            *key,
                            imu.sides(),
                            lo,
                            hi,
                            &self.config,
                        ) else {
                            continue;
                        };
                        (imu_sig, sig)
                    };
                    let curve = if is_short {
                        scratch.curve(imu_sig, sig, &offsets, min_samples)
                    } else if is_coarse {
                        scratch.coarse_curve(
                            i,
                            imu.offset_ns,
                            *key,
                            imu_sig,
                            sig,
                            &offsets,
                            min_samples,
                        )
                    } else {
                        scratch.curve(imu_sig, sig, &offsets, min_samples)
                    };
                    let Some((mut offset, mut value)) =
                        curve_peak(&offsets, curve, prior, self.config.offset_tie_tolerance)
                    else {
                        continue;
                    };
                    // Whether this pair's peak stands clear of every lag a stride or a
                    // look-alike away (on the coarse curve): only a clear one may be a
                    // candidate. A known offset is read at itself and is no candidate.
                    let is_clear = is_coarse
                        && is_clear_peak(
                            &offsets,
                            curve,
                            offset,
                            value,
                            self.config.offset_peak_clarity,
                        );
                    if is_coarse {
                        let reach = COARSE_LAG_STEPS as i64 * LAG_STEP_NS;
                        let near = offset.div_euclid(LAG_STEP_NS) * LAG_STEP_NS;
                        fine.clear();
                        fine.extend(
                            (-(COARSE_LAG_STEPS as i64)..=COARSE_LAG_STEPS as i64)
                                .map(|k| near + k * LAG_STEP_NS)
                                .filter(|o| {
                                    (o - prior).abs() <= max_off && (o - offset).abs() <= reach
                                }),
                        );
                        let curve = scratch.curve(imu_sig, sig, fine, min_samples);
                        if let Some(found) = curve_peak(fine, curve, prior, 0.0) {
                            (offset, value) = found;
                        }
                    }
                    if is_short {
                        // A short stretch's curve is noisy: only a clear peak scores it. It
                        // gives the subject no score (so no winner and no lag hypothesis) and
                        // is marked unclear, so it is never an offset candidate.
                        if is_clear && (offset - prior).abs() < max_off - LAG_STEP_NS / 2 {
                            peaks.insert((i, *key), (offset, false));
                        }
                        continue;
                    }
                    let e = track_score.entry(*key).or_insert((0.0, 0));
                    e.0 += value;
                    e.1 += 1;
                    // A peak at the end of the searched range only says the best lag lies
                    // beyond it: it scores the track but is no offset candidate.
                    if !imu.is_offset_known && (offset - prior).abs() < max_off - LAG_STEP_NS / 2 {
                        peaks.insert((i, *key), (offset, is_clear));
                    }
                }
            }
            if let Some(scores) = subject_scores.get_mut(b) {
                *scores = track_score
                    .iter()
                    .map(|(k, (s, n))| (*k, s / *n as f64))
                    .collect();
            }
        }
    }

    /// The joint search's second step. A subject whose offsets are all accepted is read at
    /// them only, and its score on a track only counts against a searching subject that would
    /// win that track: it is computed there alone (the mean of its IMUs' correlations at their
    /// offsets).
    fn score_contested(&mut self, search: &mut LagSearch) {
        let lo = search.lo;
        let hi = search.hi;
        let min_samples = search.min_samples;
        let num_scored = search.num_scored;
        let is_searching = &search.is_searching;
        let imu_cache = &mut search.imu_cache;
        let skel_cache = &mut search.skel_cache;
        let scratch = &mut search.scratch;
        let lag_memos = &mut search.lag_memos;
        let subject_scores = &mut search.subject_scores;
        let mut contested: Vec<(usize, TrackId)> = (0..num_scored)
            .filter(|&b| is_searching.get(b).copied().unwrap_or(false))
            .filter_map(|b| {
                subject_scores
                    .get(b)?
                    .iter()
                    .max_by(|a, b| a.1.total_cmp(b.1).then(b.0.cmp(a.0)))
                    .map(|(k, _)| *k)
            })
            .collect();
        contested.sort_unstable();
        contested.dedup();
        for c in 0..num_scored {
            if is_searching.get(c).copied().unwrap_or(false) {
                continue;
            }
            let Some(theirs) = self.subject_imus.get(c) else {
                continue;
            };
            for key in &contested {
                // Every IMU of a subject that is not searching has an accepted offset.
                let explained = mean_at_offsets(
                    &self.imus,
                    theirs,
                    |imu| imu.offset_ns,
                    &self.tracks,
                    *key,
                    (lo, hi, min_samples),
                    (imu_cache, skel_cache, scratch, lag_memos),
                    &self.config,
                );
                if let Some(v) = explained
                    && let Some(scores) = subject_scores.get_mut(c)
                {
                    scores.insert(*key, v);
                }
            }
        }
    }

    /// The joint search's last step: each searching subject's winning track, and the offset
    /// candidates of its unaccepted IMUs on it.
    fn accept_joint_winners(&mut self, search: &mut LagSearch) {
        let end = search.end;
        let num_scored = search.num_scored;
        let confirm_apart = search.confirm_apart;
        let same_offset = search.same_offset;
        let is_searching = &search.is_searching;
        let subject_scores = &mut search.subject_scores;
        let peaks = &mut search.peaks;
        for b in 0..num_scored {
            let Some(mine) = self.subject_imus.get(b).cloned() else {
                continue;
            };
            // Only subjects with an IMU still unaccepted search.
            if !is_searching.get(b).copied().unwrap_or(false) {
                continue;
            }
            let Some(scores) = subject_scores.get(b) else {
                continue;
            };
            // The best track, its margin over the next one of the same camera, and over every
            // other subject's score on it (two people walking alike must not both claim it).
            let best = scores
                .iter()
                .max_by(|a, b| a.1.total_cmp(b.1).then(b.0.cmp(a.0)))
                .map(|(k, v)| (*k, *v));
            let winner = best.and_then(|(key, top)| {
                let second = scores
                    .iter()
                    .filter(|(k, _)| k.0 == key.0 && **k != key)
                    .map(|(_, v)| *v)
                    .fold(0.0f64, f64::max);
                let other = subject_scores
                    .iter()
                    .enumerate()
                    .filter(|(c, _)| *c != b)
                    .filter_map(|(_, s)| s.get(&key).copied())
                    .fold(f64::NEG_INFINITY, f64::max);
                (top >= self.config.offset_min_correlation
                    && top - second >= self.config.offset_margin
                    && (self.config.offset_subject_margin < 0.0
                        || top - other >= self.config.offset_subject_margin))
                    .then_some((key, top))
            });
            // The subject's tracks, best first: where its IMUs' lag hypotheses come from.
            let mut ranked: Vec<(&(usize, TrackId), &f64)> = scores.iter().collect();
            ranked.sort_by(|a, b| b.1.total_cmp(a.1).then(a.0.cmp(b.0)));
            let ranked: Vec<(usize, TrackId)> = ranked.into_iter().map(|(k, _)| *k).collect();
            for &i in &mine {
                let pair_offsets: BTreeMap<(usize, TrackId), i64> = peaks
                    .range((i, (0, TrackId(0)))..)
                    .take_while(|((j, _), _)| *j == i)
                    .map(|((_, k), (o, _))| (*k, *o))
                    .collect();
                // The winning track's peak lag is a candidate only if it is clear.
                let candidate = winner
                    .and_then(|(key, _)| peaks.get(&(i, key)))
                    .and_then(|(o, is_clear)| is_clear.then_some(*o));
                let Some(imu) = self.imus.get_mut(i) else {
                    continue;
                };
                if imu.is_offset_known {
                    continue;
                }
                imu.pair_offsets = pair_offsets;
                imu.lag_hypotheses.clear();
                for key in &ranked {
                    if imu.lag_hypotheses.len() >= self.config.offset_hypotheses {
                        break;
                    }
                    if let Some((o, _)) = peaks.get(&(i, *key))
                        && imu
                            .lag_hypotheses
                            .iter()
                            .all(|h| (h - o).abs() > same_offset)
                    {
                        imu.lag_hypotheses.push(*o);
                    }
                }
                imu.candidates.push_back(candidate);
                imu.pending_offset = None;
                // Winners are kept only where they are read: a single IMU, the rule on.
                let is_confirming = confirm_apart > 0 && mine.len() == 1;
                if is_confirming && let (Some(o), Some((key, _))) = (candidate, winner) {
                    imu.winners.push_back((o, key, end));
                    while imu.winners.len() > OFFSET_CONFIRM_HISTORY {
                        imu.winners.pop_front();
                    }
                }
                while imu.candidates.len() > self.config.offset_num_consistent {
                    imu.candidates.pop_front();
                }
                let agreed: Option<Vec<i64>> = imu.candidates.iter().copied().collect();
                let Some(mut agreed) = agreed else {
                    continue;
                };
                if agreed.len() < self.config.offset_num_consistent {
                    continue;
                }
                agreed.sort_unstable();
                let (Some(&first), Some(&last)) = (agreed.first(), agreed.last()) else {
                    continue;
                };
                if last - first > ns(self.config.offset_consistency_s) {
                    continue;
                }
                let offset = agreed.get(agreed.len() / 2).copied().unwrap_or(last);
                // A single sensor's agreement is confirmed by another track, or by a winner
                // long enough ago that the two searches share little of their buffers.
                if is_confirming {
                    let tolerance = ns(self.config.offset_consistency_s);
                    let is_confirmed = winner.is_some_and(|(key, _)| {
                        imu.winners.iter().any(|(o, k, at)| {
                            (*k != key || end - at >= confirm_apart)
                                && (o - offset).abs() <= tolerance
                        })
                    });
                    if !is_confirmed {
                        imu.pending_offset = Some(offset);
                        continue;
                    }
                }
                imu.offset_ns = offset;
                imu.is_offset_known = true;
                imu.label_curve.clear();
                imu.num_label_curves = 0;
                imu.last_refine_end = end;
                record_offset(
                    &mut self.stats,
                    &imu.device,
                    offset,
                    winner.map_or(0.0, |w| w.1),
                );
            }
        }
    }

    /// Every IMU, accepted or not, against every candidate track: the lag curve's best
    /// value over the tracks at every coarse lag, summed over
    /// passes, leaving out the tracks someone else's synchronised IMU explains. The IMU's
    /// own labels do not enter this sum, so a wrong early label cannot confirm the offset it
    /// came from. Once it has `offset_best_track_curves` passes, a peak standing
    /// `offset_best_track_margin` above every lag more than `OFFSET_PEAK_SEPARATION_NS` away
    /// accepts the offset, or moves an accepted one that lies farther than that from it;
    /// `offset_settle_passes` such peaks in a row at the accepted offset settle it.
    fn best_track_pass(&mut self, search: &mut LagSearch) {
        let end = search.end;
        let lo = search.lo;
        let hi = search.hi;
        let max_off = search.max_off;
        let min_samples = search.min_samples;
        let refine_every = search.refine_every;
        let coarse = &search.coarse;
        let candidates = &search.candidates;
        let imu_cache = &mut search.imu_cache;
        let skel_cache = &mut search.skel_cache;
        let scratch = &mut search.scratch;
        let lag_memos = &mut search.lag_memos;
        let best_track_every = ns(self.config.offset_best_track_interval_s);
        if self.config.offset_best_track_curves > 0
            && !self.config.known_clock_offsets
            && end.saturating_sub(self.last_best_track_end) >= best_track_every
        {
            self.last_best_track_end = end;
            let mut best = Vec::new();
            let mut own = Vec::new();
            let mut grid = Vec::new();
            let best_grid_len = coarse.len();
            for i in 0..self.imus.len() {
                let Some(imu) = self.imus.get(i) else {
                    continue;
                };
                let is_settled = imu.is_offset_known
                    && imu
                        .best_track_settled_ns
                        .is_some_and(|o| (o - imu.offset_ns).abs() <= OFFSET_PEAK_SEPARATION_NS);
                if is_settled {
                    continue;
                }
                best.clear();
                best.resize(best_grid_len, f64::NAN);
                // Always cut at the registry's offset (the prior the grid is centred on),
                // accepted or not: the signals (the orientation change's reference sample)
                // depend on where the buffer starts, and every pass of the sum must measure the
                // same thing.
                let cut = imu.registry_offset_ns;
                grid.clear();
                // Every coarse lag (40 ms), not every second one: the smoothed joints'
                // acceleration peaks are narrow (0.92 at the true lag, 0.63 at 80 ms from it, in
                // a synthetic swing), so a coarser grid can miss the registry's lag itself and
                // let a periodic swing's alias half a period away win (the engine test of a
                // track-id change).
                grid.extend(coarse.iter().map(|o| o + cut));
                // The curves of the tracks named after this IMU's wearer, summed per lag.
                own.clear();
                own.resize(best_grid_len, (0.0, 0usize));
                if let Some(imu_sig) = imu_cache.signals(i, imu, cut, lag_memos, &self.config) {
                    // Where each candidate covers the buffer, for reading one view per person.
                    let covered = |k: TrackKey| {
                        candidates
                            .contains(&k)
                            .then(|| self.tracks.get(&k).map_or(0, |tr| covered_span(tr, lo, hi)))
                    };
                    for key in candidates.iter() {
                        // One view per person: the best value at each lag is the pass's, and
                        // two cameras' views of one person give the same curve to noise.
                        let views = self.tracks.get(key).map_or(&[][..], |tr| &tr.views[..]);
                        if covered(*key).is_some_and(|c| is_lesser_view(*key, views, c, covered)) {
                            continue;
                        }
                        // A track named after someone else with an accepted offset is
                        // explained by that person's IMU: a look-alike's track (the same gait
                        // a fraction of a stride off, the same turns for a while) would
                        // otherwise give this IMU a second peak in every pass.
                        let label = self.tracks.get(key).and_then(|tr| tr.label);
                        let is_explained =
                            label.is_some_and(|l| l != imu.subject && self.is_synced(l));
                        if is_explained {
                            continue;
                        }
                        let Some(sig) = skel_cache.signals(
                            &self.tracks,
                            *key,
                            imu.sides(),
                            lo,
                            hi,
                            &self.config,
                        ) else {
                            continue;
                        };
                        // The joint search may have read this curve already, and the
                        // labelled-track sum may read it next.
                        let curve =
                            scratch.coarse_curve(i, cut, *key, imu_sig, sig, &grid, min_samples);
                        // Read only to veto moving an accepted offset (below).
                        if imu.is_offset_known && label == Some(imu.subject) {
                            for (o, v) in own.iter_mut().zip(curve) {
                                if v.is_finite() {
                                    o.0 += v;
                                    o.1 += 1;
                                }
                            }
                        }
                        for (b, v) in best.iter_mut().zip(curve) {
                            // `NaN` (nothing yet) loses to any finite value.
                            if v.is_finite() {
                                *b = if b.is_nan() { *v } else { b.max(*v) };
                            }
                        }
                    }
                }
                let Some(imu) = self.imus.get_mut(i) else {
                    continue;
                };
                if best.iter().all(|v| !v.is_finite()) {
                    continue;
                }
                if imu.best_track_curve.len() != best_grid_len {
                    imu.best_track_curve = vec![(0.0, 0); best_grid_len];
                }
                for (acc, v) in imu.best_track_curve.iter_mut().zip(&best) {
                    if v.is_finite() {
                        acc.0 += v;
                        acc.1 += 1;
                    }
                }
                imu.num_best_track_curves += 1;
                if imu.num_best_track_curves < self.config.offset_best_track_curves {
                    continue;
                }
                let mean = mean_curve(&imu.best_track_curve);
                if !imu.is_offset_known {
                    note_search_edge(&mut self.stats, &imu.device, &mean, &coarse[..]);
                }
                let Some((offset, peak, rival)) = summed_peak(
                    &grid,
                    &mean,
                    cut,
                    max_off,
                    LAG_STEP_NS / 2,
                    OFFSET_PEAK_SEPARATION_NS,
                ) else {
                    continue;
                };
                let is_near_accepted = imu.is_offset_known
                    && (offset - imu.offset_ns).abs() <= OFFSET_PEAK_SEPARATION_NS;
                if peak - rival < self.config.offset_best_track_margin {
                    imu.num_best_track_agreements = 0;
                    continue;
                }
                if is_near_accepted {
                    imu.num_best_track_agreements += 1;
                    let settle = self.config.offset_settle_passes;
                    if settle > 0 && imu.num_best_track_agreements >= settle {
                        imu.best_track_settled_ns = Some(imu.offset_ns);
                        self.stats.num_offsets_settled += 1;
                    }
                    continue;
                }
                imu.num_best_track_agreements = 0;
                // A move away from an accepted offset needs the wearer's own named tracks, when
                // any is long enough to say, to fit the new lag better than the accepted one: a
                // person walking the wearer's gait half a stride off peaks at another lag on his
                // own track, and the sum would take it once her track fitted worse for a while.
                if imu.is_offset_known {
                    let at = |o: i64| {
                        let k = nearest_index(&grid, o)?;
                        let (sum, n) = own.get(k).copied()?;
                        (n > 0).then(|| sum / n as f64)
                    };
                    if let (Some(now), Some(new)) = (at(imu.offset_ns), at(offset))
                        && now >= new
                    {
                        continue;
                    }
                }
                if imu.is_offset_known {
                    self.stats.num_offsets_moved += 1;
                }
                imu.offset_ns = offset;
                imu.is_offset_known = true;
                imu.candidates.clear();
                imu.winners.clear();
                imu.pending_offset = None;
                imu.label_curve.clear();
                imu.num_label_curves = 0;
                // Refined at once (below) from the coarse step to the fine one.
                imu.last_refine_end = end - refine_every;
                record_offset(&mut self.stats, &imu.device, offset, peak);
            }
        }
    }

    /// Accepted offsets of single-IMU subjects that someone else's track contradicts (see
    /// [`EngineConfig::offset_unexplained_margin`]). At every best-track pass, each such IMU's
    /// coarse lag curve is taken against every candidate track:
    /// - another subject *explains* a track as well as the mean correlation of its accepted
    ///   IMUs there, each at its own offset;
    /// - the IMU's *support* is its best correlation at its own offset on a track it explains
    ///   better than anyone else (0 if none);
    /// - a *vote* is the highest clear peak (as the joint search's candidates) on a track,
    ///   farther than [`OFFSET_PEAK_SEPARATION_NS`] from the accepted offset, of at least
    ///   `offset_unexplained_min_peak`, that beats both the support and every other subject's
    ///   explanation of that track by the margin, while the IMU's last refinement found no
    ///   peak of `offset_min_correlation` (see [`ImuState::refine_peak`]).
    ///
    /// `offset_unexplained_votes` votes within `offset_consistency_s` of this one among the
    /// last `offset_unexplained_passes` passes move the offset there.
    fn move_to_unexplained_peaks(&mut self, search: &mut LagSearch) {
        let margin = self.config.offset_unexplained_margin;
        if margin <= 0.0
            || self.config.known_clock_offsets
            || self.last_best_track_end != search.end
        {
            return;
        }
        let end = search.end;
        let lo = search.lo;
        let hi = search.hi;
        let max_off = search.max_off;
        let min_samples = search.min_samples;
        let refine_every = search.refine_every;
        let same_offset = search.same_offset;
        let coarse = &search.coarse;
        let candidates = &search.candidates;
        let imu_cache = &mut search.imu_cache;
        let skel_cache = &mut search.skel_cache;
        let scratch = &mut search.scratch;
        let lag_memos = &mut search.lag_memos;
        let min_correlation = self.config.offset_min_correlation;
        // (subject, track) → the subject's mean correlation there at its accepted offsets.
        let mut explained: BTreeMap<(usize, TrackKey), Option<f64>> = BTreeMap::new();
        // Per IMU looked at: this pass's vote, if any, as `(offset, peak)`.
        let mut votes: Vec<(usize, Option<(i64, f64)>)> = Vec::new();
        for i in 0..self.imus.len() {
            let Some(imu) = self.imus.get(i) else {
                continue;
            };
            if !imu.is_offset_known || self.is_network(imu.subject) {
                continue;
            }
            // An offset the refinement still finds a peak at gets no vote this pass.
            if imu.refine_peak.is_some_and(|c| c >= min_correlation) {
                votes.push((i, None));
                continue;
            }
            // Always cut at the registry's offset, as the best-track pass does: the signals
            // depend on where the buffer starts, and every pass must measure the same thing.
            let cut = imu.registry_offset_ns;
            let grid: Vec<i64> = coarse.iter().map(|o| o + cut).collect();
            let Some(at_offset) = nearest_index(&grid, imu.offset_ns) else {
                continue;
            };
            let mut support = 0.0f64;
            let mut best: Option<(i64, f64)> = None;
            for key in candidates {
                let mut others = f64::NEG_INFINITY;
                for (l, imus) in self.subject_imus.iter().enumerate() {
                    if l == imu.subject || !self.is_synced(l) {
                        continue;
                    }
                    let e = *explained.entry((l, *key)).or_insert_with(|| {
                        mean_at_offsets(
                            &self.imus,
                            imus,
                            |other| other.registry_offset_ns,
                            &self.tracks,
                            *key,
                            (lo, hi, min_samples),
                            (imu_cache, skel_cache, scratch, lag_memos),
                            &self.config,
                        )
                    });
                    if let Some(e) = e {
                        others = others.max(e);
                    }
                }
                let (Some(imu_sig), Some(sig)) = (
                    imu_cache.signals(i, imu, cut, lag_memos, &self.config),
                    skel_cache.signals(&self.tracks, *key, imu.sides(), lo, hi, &self.config),
                ) else {
                    continue;
                };
                let curve = scratch
                    .coarse_curve(i, cut, *key, imu_sig, sig, &grid, min_samples)
                    .to_vec();
                let own = curve.get(at_offset).copied().unwrap_or(f64::NAN);
                if own.is_finite() && own > others {
                    support = support.max(own);
                }
                let Some((offset, value)) =
                    curve_peak(&grid, &curve, cut, self.config.offset_tie_tolerance)
                else {
                    continue;
                };
                if is_clear_peak(
                    &grid,
                    &curve,
                    offset,
                    value,
                    self.config.offset_peak_clarity,
                ) && (offset - imu.offset_ns).abs() > OFFSET_PEAK_SEPARATION_NS
                    && (offset - cut).abs() < max_off - LAG_STEP_NS / 2
                    && value >= self.config.offset_unexplained_min_peak
                    && value - others >= margin
                    && best.is_none_or(|(_, b)| value > b)
                {
                    best = Some((offset, value));
                }
            }
            votes.push((i, best.filter(|(_, v)| v - support >= margin)));
        }
        let passes = self.config.offset_unexplained_passes.max(1);
        let needed = self.config.offset_unexplained_votes.max(1);
        for (i, vote) in votes {
            let Some(imu) = self.imus.get_mut(i) else {
                continue;
            };
            imu.unexplained_votes.push_back(vote.map(|(o, _)| o));
            while imu.unexplained_votes.len() > passes {
                imu.unexplained_votes.pop_front();
            }
            let Some((offset, peak)) = vote else {
                continue;
            };
            let agreeing = imu
                .unexplained_votes
                .iter()
                .flatten()
                .filter(|o| (*o - offset).abs() <= same_offset)
                .count();
            if agreeing < needed {
                continue;
            }
            imu.unexplained_votes.clear();
            self.stats.num_offsets_moved += 1;
            imu.offset_ns = offset;
            imu.candidates.clear();
            imu.winners.clear();
            imu.pending_offset = None;
            imu.label_curve.clear();
            imu.num_label_curves = 0;
            // The best-track sum still holds the passes that agreed with the old offset, and
            // would move it back.
            imu.best_track_curve.clear();
            imu.num_best_track_curves = 0;
            imu.num_best_track_agreements = 0;
            imu.best_track_settled_ns = None;
            // Refined at once (below) from the coarse step to the fine one.
            imu.last_refine_end = end - refine_every;
            record_offset(&mut self.stats, &imu.device, offset, peak);
        }
    }

    /// Unaccepted IMUs whose wearer the decisions put on a track: the coarse lag curve
    /// against that track is summed over searches, so tracks too short for the joint search
    /// ([`Engine::update_offsets`]) still add up; the sum's peak is accepted once it is clear
    /// of every lag more than `OFFSET_PEAK_SEPARATION_NS` away.
    fn sum_labelled_curves(&mut self, search: &mut LagSearch) {
        let end = search.end;
        let lo = search.lo;
        let hi = search.hi;
        let max_off = search.max_off;
        let min_samples = search.min_samples;
        let refine_every = search.refine_every;
        let refine_max = search.refine_max;
        let search_every = search.search_every;
        let coarse = &search.coarse;
        let imu_cache = &mut search.imu_cache;
        let skel_cache = &mut search.skel_cache;
        let scratch = &mut search.scratch;
        let lag_memos = &mut search.lag_memos;
        let label_min = ns(self.config.offset_label_min_track_s);
        let mut held: Vec<HeldLabelPeak> = Vec::new();
        for i in 0..self.imus.len() {
            let Some(imu) = self.imus.get(i) else {
                continue;
            };
            // Accepted offsets are checked the same way, at the refinement's pace (its interval
            // doubling while the offset stays put).
            let every = if imu.is_offset_known {
                refine_interval(imu, refine_every, refine_max)
            } else {
                search_every
            };
            // With trusted offsets only the refinement moves them.
            if self.config.offset_label_curves == 0
                || self.config.known_clock_offsets
                || end.saturating_sub(imu.last_label_search_end) < every
            {
                continue;
            }
            let (subject, sites) = (imu.subject, imu.sides());
            // The coarse grid around the registry's offset, the prior.
            let prior = imu.registry_offset_ns;
            let grid: Vec<i64> = coarse.iter().map(|o| o + prior).collect();
            let mut added: Vec<Vec<f64>> = Vec::new();
            if let Some(imu_sig) = imu_cache.signals(i, imu, imu.offset_ns, lag_memos, &self.config)
            {
                for (key, tr) in self
                    .tracks
                    .iter()
                    .filter(|(_, tr)| tr.label == Some(subject) && tr.superseded_by.is_none())
                {
                    if covered_span(tr, lo, hi) < label_min {
                        continue;
                    }
                    let Some(sig) =
                        skel_cache.signals(&self.tracks, *key, sites, lo, hi, &self.config)
                    else {
                        continue;
                    };
                    let curve = scratch.coarse_curve(
                        i,
                        imu.offset_ns,
                        *key,
                        imu_sig,
                        sig,
                        &grid,
                        min_samples,
                    );
                    added.push(curve.to_vec());
                }
            }
            // Labels of a body-area network none of whose offsets is accepted yet came from
            // pairs scored at their own best lags; the joint search, which averages over the
            // network, usually finds its first offset, and this path waits for more curves.
            let is_unsynced_network =
                !imu.is_offset_known && !self.is_synced(subject) && self.is_network(subject);
            let needed = if is_unsynced_network {
                self.config
                    .offset_label_curves
                    .max(self.config.offset_label_curves_unsynced)
            } else {
                self.config.offset_label_curves
            };
            let Some(imu) = self.imus.get_mut(i) else {
                continue;
            };
            imu.last_label_search_end = end;
            if imu.is_offset_known {
                self.stats.num_offset_label_checks += 1;
            }
            if imu.label_curve.len() != grid.len() {
                imu.label_curve = vec![(0.0, 0); grid.len()];
            }
            for c in &added {
                for (acc, v) in imu.label_curve.iter_mut().zip(c) {
                    if v.is_finite() {
                        acc.0 += v;
                        acc.1 += 1;
                    }
                }
            }
            imu.num_label_curves += added.len();
            if imu.num_label_curves < needed {
                continue;
            }
            let mean = mean_curve(&imu.label_curve);
            // An accepted offset at which the wearer's tracks hardly correlate, while another
            // lag does better, was most likely found on someone else's track: it is withdrawn
            // and searched for again.
            if imu.is_offset_known
                && is_contradicted(
                    &grid,
                    &mean,
                    imu.offset_ns,
                    self.config.offset_withdraw_below,
                    self.config.offset_label_margin,
                )
            {
                imu.is_offset_known = false;
                imu.candidates.clear();
                imu.winners.clear();
                imu.pending_offset = None;
                imu.pair_offsets.clear();
                imu.lag_hypotheses.clear();
                imu.label_curve.clear();
                imu.num_label_curves = 0;
                imu.offset_ns = imu.registry_offset_ns;
                imu.num_best_track_agreements = 0;
                imu.best_track_settled_ns = None;
                self.stats.clock_offsets.remove(&imu.device);
                self.stats.num_offsets_withdrawn += 1;
                continue;
            }
            // The peak must lie inside the searched range (see the joint search).
            let found = summed_peak(
                &grid,
                &mean,
                prior,
                max_off,
                LAG_STEP_NS / 2,
                OFFSET_PEAK_SEPARATION_NS,
            );
            let accepted = found.filter(|&(offset, peak, rival)| {
                peak >= self.config.offset_label_min_correlation
                    && peak - rival >= self.config.offset_label_margin
                    // An offset the joint search agreed on and is confirming is not
                    // overruled here.
                    && (imu.is_offset_known
                        || imu
                            .pending_offset
                            .is_none_or(|p| (p - offset).abs() <= OFFSET_PEAK_SEPARATION_NS))
            });
            if is_unsynced_network {
                held.push(HeldLabelPeak {
                    imu: i,
                    subject,
                    peak: found.map_or(0.0, |f| f.1),
                    accepted: accepted.map(|(offset, peak, _)| (offset, peak)),
                });
                continue;
            }
            let Some((offset, peak, _)) = accepted else {
                continue;
            };
            // A fresh sum from here on: for an accepted offset, the check of the next curves.
            imu.label_curve.clear();
            imu.num_label_curves = 0;
            if imu.is_offset_known {
                if (offset - imu.offset_ns).abs() <= OFFSET_PEAK_SEPARATION_NS {
                    continue;
                }
                // The wearer's tracks clearly peak elsewhere: the accepted offset was wrong
                // (a stride away, or found on someone else's track).
                self.stats.num_offsets_moved += 1;
                imu.num_best_track_agreements = 0;
                imu.best_track_settled_ns = None;
            }
            take_label_offset(imu, &mut self.stats, offset, peak, end - refine_every);
        }
        // A network's first offsets: its labels came from pairs scored at their own best lags,
        // and a look-alike's tracks among them give each IMU a peak at another lag, lower on
        // average than the wearer's own tracks give. They are accepted together, when the
        // peaks of all of the network's summed curves average at least
        // `offset_label_network_min_peak`; otherwise the sums go on.
        let mut subjects: Vec<usize> = held
            .iter()
            .filter(|h| h.accepted.is_some())
            .map(|h| h.subject)
            .collect();
        subjects.sort_unstable();
        subjects.dedup();
        let min_peak = self.config.offset_label_network_min_peak;
        for subject in subjects {
            let theirs: Vec<&HeldLabelPeak> =
                held.iter().filter(|h| h.subject == subject).collect();
            let mean_peak = theirs.iter().map(|h| h.peak).sum::<f64>() / theirs.len().max(1) as f64;
            if min_peak > 0.0 && mean_peak < min_peak {
                continue;
            }
            for h in theirs {
                if let (Some((offset, peak)), Some(imu)) = (h.accepted, self.imus.get_mut(h.imu)) {
                    take_label_offset(imu, &mut self.stats, offset, peak, end - refine_every);
                }
            }
        }
    }

    /// Refinement of accepted offsets against the tracks labelled with the wearer.
    fn refine_offsets(&mut self, search: &mut LagSearch) {
        let end = search.end;
        let lo = search.lo;
        let hi = search.hi;
        let max_off = search.max_off;
        let min_samples = search.min_samples;
        let min_track = search.min_track;
        let refine_every = search.refine_every;
        let refine_range = search.refine_range;
        let refine_max = search.refine_max;
        let full = &search.full;
        let imu_cache = &mut search.imu_cache;
        let skel_cache = &mut search.skel_cache;
        let scratch = &mut search.scratch;
        let lag_memos = &mut search.lag_memos;
        for i in 0..self.imus.len() {
            let Some(imu) = self.imus.get(i) else {
                continue;
            };
            let num_kept = refinements_kept(imu);
            let every = refine_interval(imu, refine_every, refine_max);
            if !imu.is_offset_known || end.saturating_sub(imu.last_refine_end) < every {
                continue;
            }
            // The tracks labelled with the wearer that cover enough of the buffer, weighted by
            // how much each covers: a long track's peak is sharper than a short one's.
            let labelled: Vec<(TrackKey, f64)> = self
                .tracks
                .iter()
                .filter(|(_, tr)| tr.label == Some(imu.subject))
                .map(|(key, tr)| (*key, covered_span(tr, lo, hi)))
                .filter(|(_, covered)| *covered >= min_track)
                .map(|(key, covered)| (key, covered as f64 * 1e-9))
                .collect();
            // One view per person: of two cameras' labelled tracks that show the same person
            // (views, as the decisions pair them), only the one covering more of the buffer
            // (on a tie, the lower key) is read; both saw the same motion.
            let covered = |k: TrackKey| {
                labelled
                    .iter()
                    .find(|(other, _)| *other == k)
                    .map(|&(_, c)| c)
            };
            let tracks: Vec<(TrackKey, f64)> = labelled
                .iter()
                .filter(|&&(key, c)| {
                    let views = self.tracks.get(&key).map_or(&[][..], |tr| &tr.views[..]);
                    !is_lesser_view(key, views, c, covered)
                })
                .copied()
                .collect();
            if tracks.is_empty() {
                // Nothing to refine against (the wearer unseen or unnamed): not a refinement.
                if let Some(imu) = self.imus.get_mut(i) {
                    imu.last_refine_end = end;
                }
                continue;
            }
            let offsets: Vec<i64> = full
                .iter()
                .filter(|o| o.abs() <= refine_range)
                .map(|o| o + imu.offset_ns)
                .collect();
            let mut sum = vec![(0.0, 0.0); offsets.len()];
            if let Some(imu_sig) = imu_cache.signals(i, imu, imu.offset_ns, lag_memos, &self.config)
            {
                for &(key, w) in &tracks {
                    let Some(sig) =
                        skel_cache.signals(&self.tracks, key, imu.sides(), lo, hi, &self.config)
                    else {
                        continue;
                    };
                    let curve = scratch.curve(imu_sig, sig, &offsets, min_samples);
                    for (acc, v) in sum.iter_mut().zip(curve) {
                        if v.is_finite() {
                            acc.0 += w * v;
                            acc.1 += w;
                        }
                    }
                }
            }
            let mean: Vec<f64> = sum
                .iter()
                .map(|(s, w)| if *w > 0.0 { s / w } else { f64::NAN })
                .collect();
            let best = curve_peak(&offsets, &mean, imu.registry_offset_ns, 0.0);
            let Some(imu) = self.imus.get_mut(i) else {
                continue;
            };
            imu.last_refine_end = end;
            imu.refine_peak = best.map(|(_, c)| c);
            let before = imu.offset_ns;
            if let Some((offset, corr)) = best
                && corr >= self.config.offset_min_correlation
            {
                // Refinement never walks out of the searched range.
                let prior = imu.registry_offset_ns;
                imu.offset_ns = offset.clamp(prior - max_off, prior + max_off);
                record_offset(&mut self.stats, &imu.device, imu.offset_ns, corr);
            }
            let num_kept = if (imu.offset_ns - before).abs() <= REFINE_KEPT_NS {
                num_kept.saturating_add(1)
            } else {
                0
            };
            imu.refined = Some((imu.offset_ns, num_kept));
        }
    }
}

/// How far a refinement may move an accepted offset and still count as leaving it where it was
/// (for [`refine_interval`]), ns: three lag steps. A refinement's estimate scatters by about one
/// (given the true offsets of the 8-person scene, 226 refinements moved them by 8.3 ms on
/// average, sd 11.9 ms), so at one lag step a third of them restarted the interval on noise
/// alone. The offset itself still takes every refinement's estimate.
const REFINE_KEPT_NS: i64 = 3 * LAG_STEP_NS;

/// Whether a read of one view per person skips track `key`, which covers `covered` of the
/// buffer and has the views `views` (other cameras' tracks of its person, as the decisions pair
/// them): one of them is read too (`covered_of` gives how much of the buffer a read track
/// covers, `None` for a track not read) and covers more of it, or as much with a lower key.
fn is_lesser_view<C: PartialOrd + Copy>(
    key: TrackKey,
    views: &[TrackKey],
    covered: C,
    covered_of: impl Fn(TrackKey) -> Option<C>,
) -> bool {
    views.iter().any(|&v| {
        v.0 != key.0
            && covered_of(v).is_some_and(|theirs| (theirs, Reverse(v)) > (covered, Reverse(key)))
    })
}

/// How often an accepted offset is refined (and checked against its wearer's labelled tracks):
/// `refine_every`, doubled with every refinement in a row that left the offset within
/// [`REFINE_KEPT_NS`] of where it was, up to `refine_max`; an offset moved since (by any path)
/// starts again.
fn refine_interval(imu: &ImuState, refine_every: i64, refine_max: i64) -> i64 {
    refine_every
        .saturating_mul(1_i64 << refinements_kept(imu).min(16))
        .min(refine_max.max(refine_every))
}

/// Refinements in a row that left the IMU's offset within [`REFINE_KEPT_NS`] of where it was
/// (0 once the offset moved, by any other path).
fn refinements_kept(imu: &ImuState) -> u32 {
    match imu.refined {
        Some((o, n)) if o == imu.offset_ns => n,
        _ => 0,
    }
}

/// One window's lag search: the buffer's bounds, the lag grids, the tracks it reads, the caches,
/// and what the joint search's steps pass on to each other; shared by every step of
/// [`Engine::update_offsets`].
pub(super) struct LagSearch {
    end: i64,
    lo: i64,
    hi: i64,
    max_off: i64,
    min_samples: usize,
    min_track: i64,
    refine_every: i64,
    refine_max: i64,
    refine_range: i64,
    search_every: i64,
    coarse: Vec<i64>,
    full: Vec<i64>,
    candidates: Vec<TrackKey>,
    imu_cache: ImuLagCache,
    skel_cache: TrackLagCache,
    scratch: LagScratch,
    lag_memos: Vec<ImuLagMemo>,
    /// Subjects taking part in the joint search (0 when no search is due).
    num_scored: usize,
    /// Per subject: whether it has an IMU still unaccepted.
    is_searching: Vec<bool>,
    /// Per subject: its mean peak per track.
    subject_scores: Vec<BTreeMap<TrackKey, f64>>,
    /// Per (unaccepted IMU, track): the peak lag, and whether the peak is clear.
    peaks: BTreeMap<(usize, TrackKey), (i64, bool)>,
    /// Tracks too short to be candidates, scored while there is no candidate.
    short: Vec<TrackKey>,
    /// Where the short tracks' buffers end (the window's end).
    short_hi: i64,
    short_skel_cache: TrackLagCache,
    short_imu_cache: ImuLagCache,
    fine: Vec<i64>,
    confirm_apart: i64,
    same_offset: i64,
}

/// Scratch buffers of the lag search, reused by every curve of a window.
#[derive(Default)]
pub(super) struct LagScratch {
    weights: Vec<LagWeight>,
    curve: Vec<f64>,
    /// The curve at the mirror-image site, for an IMU that may be on either side.
    mirror_curve: Vec<f64>,
    /// Coarse-grid curves of this window per (IMU, offset its buffer was cut at, track): the
    /// joint search, the best-track pass and the labelled-track sum all read the curve on the
    /// coarse grid around the registry's offset, and often of the same buffers.
    coarse: BTreeMap<(usize, i64, TrackKey), Vec<f64>>,
}

impl LagScratch {
    /// [`LagScratch::curve`] on the coarse grid `offsets_ns` of IMU `imu_index` cut at
    /// `cut_ns`, against `track`: computed once per window.
    #[allow(clippy::too_many_arguments)]
    fn coarse_curve(
        &mut self,
        imu_index: usize,
        cut_ns: i64,
        track: TrackKey,
        imu: &LagSignals,
        track_signals: TrackSides<'_>,
        offsets_ns: &[i64],
        min_samples: usize,
    ) -> &[f64] {
        let Self {
            weights,
            curve,
            mirror_curve,
            coarse,
        } = self;
        coarse.entry((imu_index, cut_ns, track)).or_insert_with(|| {
            sides_curve(
                imu,
                track_signals,
                COARSE_TRACK_STRIDE,
                offsets_ns,
                min_samples,
                weights,
                (curve, mirror_curve),
            );
            curve.clone()
        })
    }

    /// The lag curve of `imu` against `track` at `offsets_ns` ([`lag_curve`], across IMU gaps
    /// up to [`max_imu_gap_ns`]).
    fn curve(
        &mut self,
        imu: &LagSignals,
        track: TrackSides<'_>,
        offsets_ns: &[i64],
        min_samples: usize,
    ) -> &[f64] {
        sides_curve(
            imu,
            track,
            1,
            offsets_ns,
            min_samples,
            &mut self.weights,
            (&mut self.curve, &mut self.mirror_curve),
        );
        &self.curve
    }
}

/// A track's lag signals at the IMU's site, and at its mirror image for an IMU registered with
/// `either_side` ([`TrackLagCache::signals`]).
pub(super) type TrackSides<'a> = (&'a LagSignals, Option<&'a LagSignals>);

/// The lag curve of `imu` against `track` ([`lag_curve`], across IMU gaps up to
/// [`max_imu_gap_ns`]) into `out.0`; with a mirror-image site, the larger of the two sides'
/// values at each lag (`out.1` holds the other side's curve). The search then finds the side
/// and the lag together: a band on the other wrist than its site peaks about half a stride
/// away on the site's wrist. Every `track_stride`-th of the track's samples is paired, and the
/// sample count a lag needs is scaled down by as much.
fn sides_curve(
    imu: &LagSignals,
    (track, mirror): TrackSides<'_>,
    track_stride: usize,
    offsets_ns: &[i64],
    min_samples: usize,
    weights: &mut Vec<LagWeight>,
    (out, mirror_out): (&mut Vec<f64>, &mut Vec<f64>),
) {
    // Every `track_stride`-th track sample counts as one of a camera that much slower.
    let scale = |side: &LagSignals| side.sample_scale / track_stride.max(1) as f64;
    lag_curve(
        imu,
        track,
        track_stride,
        offsets_ns,
        max_imu_gap_ns(&imu.t_ns),
        scaled_count(min_samples, scale(track)),
        weights,
        out,
    );
    if let Some(mirror) = mirror {
        lag_curve(
            imu,
            mirror,
            track_stride,
            offsets_ns,
            max_imu_gap_ns(&imu.t_ns),
            scaled_count(min_samples, scale(mirror)),
            weights,
            mirror_out,
        );
        for (v, m) in out.iter_mut().zip(mirror_out.iter()) {
            // `NaN` (no value) loses to any finite value.
            if m.is_finite() && !(v.is_finite() && *v >= *m) {
                *v = *m;
            }
        }
    }
}

/// How well the IMUs `theirs` (indices into `imus`; those without an accepted offset are
/// skipped) explain track `key`: the mean of their lag curves' values on it, each at its own
/// offset, over the search's buffer `(lo, hi, min_samples)`, each IMU's buffer cut at
/// `cut_ns(imu)`; `None` if none has a value.
#[allow(clippy::too_many_arguments)]
fn mean_at_offsets(
    imus: &[ImuState],
    theirs: &[usize],
    cut_ns: impl Fn(&ImuState) -> i64,
    tracks: &BTreeMap<TrackKey, TrackState>,
    key: TrackKey,
    (lo, hi, min_samples): (i64, i64, usize),
    (imu_cache, skel_cache, scratch, lag_memos): (
        &mut ImuLagCache,
        &mut TrackLagCache,
        &mut LagScratch,
        &mut [ImuLagMemo],
    ),
    config: &EngineConfig,
) -> Option<f64> {
    let (mut sum, mut num) = (0.0, 0usize);
    for &i in theirs {
        let Some(imu) = imus.get(i).filter(|m| m.is_offset_known) else {
            continue;
        };
        let (Some(imu_sig), Some(sig)) = (
            imu_cache.signals(i, imu, cut_ns(imu), lag_memos, config),
            skel_cache.signals(tracks, key, imu.sides(), lo, hi, config),
        ) else {
            continue;
        };
        let at = [imu.offset_ns];
        if let Some(v) = scratch
            .curve(imu_sig, sig, &at, min_samples)
            .first()
            .filter(|v| v.is_finite())
        {
            sum += v;
            num += 1;
        }
    }
    (num > 0).then(|| sum / num as f64)
}

/// Whether the peak `(offset_ns, value)` of `curve` over `offsets_ns` is clear: the curve falls
/// by [`PEAK_DROP`] on both sides of it and, unless `clarity` ≤ 0, it stands `clarity` above
/// every lag more than [`OFFSET_PEAK_SEPARATION_NS`] away.
fn is_clear_peak(
    offsets_ns: &[i64],
    curve: &[f64],
    offset_ns: i64,
    value: f64,
    clarity: f64,
) -> bool {
    nearest_index(offsets_ns, offset_ns).is_some_and(|k| falls_on_both_sides(curve, k, PEAK_DROP))
        && (clarity <= 0.0
            || value - rival_value(offsets_ns, curve, offset_ns, OFFSET_PEAK_SEPARATION_NS)
                >= clarity)
}

/// Index of the lag in `offsets_ns` nearest to `offset_ns` (`None` for an empty grid).
fn nearest_index(offsets_ns: &[i64], offset_ns: i64) -> Option<usize> {
    offsets_ns
        .iter()
        .enumerate()
        .min_by_key(|(_, o)| o.abs_diff(offset_ns))
        .map(|(k, _)| k)
}

/// An IMU of a body-area network none of whose offsets is accepted yet, as the labelled-track
/// path read it before accepting any of the network's offsets.
struct HeldLabelPeak {
    imu: usize,
    /// The IMU's wearer.
    subject: usize,
    /// Its summed curve's peak (0 without one).
    peak: f64,
    /// The offset and peak it would accept on its own, if any.
    accepted: Option<(i64, f64)>,
}

/// Accepts `offset` (its summed curve's `peak`) for `imu` from the tracks labelled with its
/// wearer: a fresh sum from here on, and the refinement due at `refine_at` (the window's end
/// minus the refinement interval: at once, from the coarse step to the fine one).
fn take_label_offset(
    imu: &mut ImuState,
    stats: &mut EngineStats,
    offset: i64,
    peak: f64,
    refine_at: i64,
) {
    imu.label_curve.clear();
    imu.num_label_curves = 0;
    imu.offset_ns = offset;
    imu.is_offset_known = true;
    imu.last_refine_end = refine_at;
    record_offset(stats, &imu.device, offset, peak);
}

/// Reports an accepted or updated clock offset of `device` in the run's statistics.
pub(super) fn record_offset(
    stats: &mut EngineStats,
    device: &DeviceId,
    offset_ns: i64,
    correlation: f64,
) {
    stats.offsets_at_search_edge.remove(device);
    let entry = stats.clock_offsets.entry(device.clone()).or_default();
    entry.offset_ns = offset_ns;
    entry.correlation = correlation;
    entry.num_updates += 1;
}

/// De Marchi's magnitude config for the lag search: no moving average (its causal delay would
/// differ between the IMU's rate and the camera's); the low-pass does the smoothing, zero phase
/// or causal as [`GeometricConfig::zero_phase`] says for the windows.
///
/// A causal low-pass delays both sides of a comparison alike only where both are filtered at
/// their true rates. The IMU is (its samples are regular); a track's own samples are not (the
/// frames it missed are absent), so a causal search puts the track on its camera's frame grid
/// first (`on_frame_grid`). On its own samples, whose mean rate is designed into the filter,
/// the skeleton comes out delayed by less than the IMU where the track missed frames, and the
/// offsets are found early (by about 10 ms with one frame in ten missed); on the frame grid
/// they are within a few milliseconds. A zero-phase filter has no delay to scale, and its
/// offsets are less exact on the frame grid than on the track's own samples, so it keeps the
/// own samples.
pub(super) fn lag_geometric(config: &EngineConfig) -> GeometricConfig {
    GeometricConfig {
        moving_average_len: 1,
        zero_phase: config.geometric.zero_phase,
        ..config.geometric
    }
}

/// An IMU's acceleration and orientation-change magnitudes (and the other lag models) at its
/// own sample times (device clock) in `[lo − cut_offset_ns, hi − cut_offset_ns)`, for the lag
/// search, and never past `settled_until_ns` (the samples the window waited for, whatever else
/// has arrived); the values earlier searches computed come from `memo` ([`ImuLagMemo`]).
///
/// Acceleration gives a sharp peak but repeats every step; the orientation change over the long
/// buffer follows the turns of the walk, which do not repeat, and picks the right step. (The
/// velocity model, a leaky integral over 12 s, correlates worse than either on the simulated
/// scenes.) The orientation's reference is the buffer's first sample on each side: at a
/// candidate lag `o` the IMU's lies `max offset + cut − o` before the track's, up to a second
/// apart, which matters for a limb that swings (see the best-track curve in
/// [`Engine::update_offsets`]). A reference per lag (the IMU's orientation at the track's
/// reference time, lag by lag) would remove that bias, but it does not change the accuracy on
/// the simulated scenes, so it is not done.
pub(super) fn imu_lag_signals(
    imu: &ImuState,
    memo: &mut ImuLagMemo,
    cut_offset_ns: i64,
    lo: i64,
    hi: i64,
    config: &EngineConfig,
) -> Option<LagSignals> {
    // Device times (the lag curve shifts them by each candidate offset itself), thinned like
    // the track's: interpolation walks every IMU sample once per candidate offset.
    lag_memo::imu_lag_signals(
        memo,
        &imu.series(),
        imu.num_forgotten,
        imu.lag_step.unwrap_or(1),
        lo - cut_offset_ns,
        (hi - cut_offset_ns).min(imu.settled_until_ns),
        &lag_geometric(config),
        &config.kinematic,
    )
}

/// The lag search's IMU side for one window: each IMU's signals over `[lo, hi)` (device clock
/// shifted by the offset the buffer is cut at), per (IMU, that offset).
pub(super) struct ImuLagCache {
    lo: i64,
    hi: i64,
    signals: BTreeMap<(usize, i64), Option<LagSignals>>,
}

impl ImuLagCache {
    /// [`imu_lag_signals`] of IMU `index` (`imu`, its memo in `memos`) cut at `cut_ns`; `None`
    /// if too short.
    fn signals<'a>(
        &'a mut self,
        index: usize,
        imu: &ImuState,
        cut_ns: i64,
        memos: &mut [ImuLagMemo],
        config: &EngineConfig,
    ) -> Option<&'a LagSignals> {
        let (lo, hi) = (self.lo, self.hi);
        self.signals
            .entry((index, cut_ns))
            .or_insert_with(|| {
                let memo = memos.get_mut(index)?;
                imu_lag_signals(imu, memo, cut_ns, lo, hi, config)
            })
            .as_ref()
    }
}

/// A track's buffer for the lag search: its times (session ns), its joints, and its body's
/// turn rate (the fifth lag model, the same for every site) thinned like the other models.
pub(super) type TrackLagWindow = (Vec<i64>, SkeletonWindow, Vec<f64>, Vec<bool>);

/// The lag search's track side for one window: each track's buffer, copied once, and its
/// signals per site.
pub(super) struct TrackLagCache {
    /// A track's buffer in `[lo, hi)`; `None` if too short.
    windows: BTreeMap<TrackKey, Option<TrackLagWindow>>,
    signals: BTreeMap<(TrackKey, Joint), Option<LagSignals>>,
    /// Per camera, its rate over 30 Hz (the signals' `sample_scale`).
    camera_scales: Vec<f64>,
}

impl TrackLagCache {
    /// An empty cache for cameras at `camera_scales` times 30 Hz.
    pub(super) fn new(camera_scales: Vec<f64>) -> Self {
        Self {
            windows: BTreeMap::new(),
            signals: BTreeMap::new(),
            camera_scales,
        }
    }

    /// [`TrackLagCache::one_site`] at `sites.0`, and at `sites.1` (the mirror image of an IMU
    /// registered with `either_side`) if given.
    fn signals(
        &mut self,
        tracks: &BTreeMap<TrackKey, TrackState>,
        key: TrackKey,
        (site, mirror): (Joint, Option<Joint>),
        lo: i64,
        hi: i64,
        config: &EngineConfig,
    ) -> Option<TrackSides<'_>> {
        if let Some(m) = mirror {
            let _ = self.one_site(tracks, key, m, lo, hi, config);
        }
        self.one_site(tracks, key, site, lo, hi, config)?;
        let own = self.signals.get(&(key, site))?.as_ref()?;
        let other = mirror.and_then(|m| self.signals.get(&(key, m))?.as_ref());
        Some((own, other))
    }

    /// The acceleration and carrying-segment orientation-change magnitudes (and the other lag
    /// models) of track `key` at `site` on its own times in `[lo, hi)`; `None` for an unknown
    /// or too short track.
    fn one_site(
        &mut self,
        tracks: &BTreeMap<TrackKey, TrackState>,
        key: TrackKey,
        site: Joint,
        lo: i64,
        hi: i64,
        config: &EngineConfig,
    ) -> Option<&LagSignals> {
        let Self {
            windows,
            signals,
            camera_scales,
        } = self;
        let sample_scale = camera_scales.get(key.0).copied().unwrap_or(1.0);
        signals
            .entry((key, site))
            .or_insert_with(|| {
                let window = windows.entry(key).or_insert_with(|| {
                    let tr = tracks.get(&key)?;
                    let (a, b) = sample_range(tr, lo, hi);
                    if b < a + scaled_count(LAG_MIN_TRACK_SAMPLES, sample_scale) {
                        return None;
                    }
                    // A causal low-pass delays a signal by a time that scales with the rate it
                    // is designed at: on the track's own samples that is their mean rate, below
                    // the camera's wherever frames were missed, and the skeleton would come out
                    // less delayed than the IMU (see `lag_geometric`). So a causal search puts
                    // the track on its camera's frames, the missed ones filled in but not
                    // compared.
                    let samples = tr.samples.range(a..b);
                    let grid = (!config.geometric.zero_phase)
                        .then(|| on_frame_grid(samples.clone()))
                        .flatten();
                    let (t_ns, joints_world_m, seen) = grid.unwrap_or_else(|| {
                        // The track's own samples, every one seen.
                        let (t, j) = samples.map(|s| (s.t, s.joints.clone())).unzip();
                        (t, j, Vec::new())
                    });
                    let skel = SkeletonWindow {
                        camera: None,
                        track: None,
                        t_s: t_ns.iter().map(|&t| t as f64 * 1e-9).collect(),
                        joints_world_m,
                    };
                    let mut turn: Vec<f64> = body_turn_rate_signal(&skel, &config.kinematic)
                        .into_iter()
                        .step_by(LAG_DECIMATION)
                        .collect();
                    mask_unseen(&mut turn, &seen);
                    Some((t_ns, skel, turn, seen))
                });
                window.as_ref().map(|(t_ns, skel, turn, seen)| {
                    // The signals are built at the camera's rate, then every `LAG_DECIMATION`-th
                    // sample is correlated: the models are low-passed well below the decimated
                    // Nyquist rate. The models are `segment_lag_models`', the turn rate shared.
                    let [acc, ori, vertical, swing] = segment_site_lag_models(
                        skel,
                        site,
                        &lag_geometric(config),
                        &config.kinematic,
                        LAG_DECIMATION,
                    );
                    let mut models = vec![acc, ori, vertical, swing, turn.clone()];
                    models.iter_mut().for_each(|m| mask_unseen(m, seen));
                    LagSignals {
                        sample_scale,
                        ..LagSignals::thinned(t_ns, models, LAG_DECIMATION)
                    }
                })
            })
            .as_ref()
    }
}

/// A track's buffer on its camera's frame grid: times (session ns), joints, and whether the
/// track was seen in each frame.
type FrameGrid = (Vec<i64>, Vec<Joints<Point3<f64>>>, Vec<bool>);

/// Longest run of missed frames that [`on_frame_grid`] fills in, ns: a third of a second (10
/// frames at 30 Hz, 5 at 15 Hz), longer than the gaps of the simulated Belmonte-Hernández
/// episodes' tracks (4 to 10 frames at 30 Hz). A causal filter restarted after every missed
/// frame never settles: with one frame in ten missed, unfilled frames give offsets 24–32 ms
/// early in the engine's synthetic test, filled ones 4–5 ms late. Filling longer runs (up to
/// 30 frames at 30 Hz) makes no difference.
const MAX_FILLED_NS: i64 = 333_333_333;

/// A track's samples on its camera's frame grid, and which frames the track was seen in: each
/// gap of about `m` frame intervals between two samples gets the `m − 1` frames the track
/// missed, evenly spaced, with joints interpolated linearly between the two samples for up to
/// [`MAX_FILLED_NS`] of missed frames and without joints (where the filters restart) for
/// more. The filled frames keep a causal filter's clock; their values are not compared
/// ([`mask_unseen`]). The frame interval is the mean of the samples' intervals within half of
/// one of their lower quartile, so a track must have been seen in more than a quarter of its
/// frames for the grid to be the camera's; `None` for samples that would need more than four
/// frames each (no regular frame interval among them).
fn on_frame_grid<'a>(samples: impl Iterator<Item = &'a TrackSample> + Clone) -> Option<FrameGrid> {
    let mut steps: Vec<i64> = samples
        .clone()
        .zip(samples.clone().skip(1))
        .map(|(a, b)| b.t - a.t)
        .collect();
    steps.sort_unstable();
    // The intervals of about one frame, around the lower quartile; their mean.
    let quartile = steps.get(steps.len() / 4).copied().unwrap_or(0);
    let single = steps
        .iter()
        .filter(|&&d| {
            d.saturating_mul(2) > quartile && d.saturating_mul(2) < quartile.saturating_mul(3)
        })
        .fold((0i128, 0i128), |(sum, n), &d| (sum + i128::from(d), n + 1));
    let step = if single.1 > 0 {
        (single.0 / single.1) as i64
    } else {
        0
    };
    // Frame intervals between two samples (1 where none was missed).
    let frames_in = |gap: i64| (gap as f64 / step as f64).round().max(1.0) as i64;
    let num_samples = steps.len() + 1;
    let num_frames = steps
        .iter()
        .fold(1i64, |n, &gap| n.saturating_add(frames_in(gap)));
    if step <= 0 || num_frames > 4 * num_samples as i64 {
        return None;
    }
    let max_filled_frames = (MAX_FILLED_NS as f64 / step as f64).round() as i64;
    let capacity = usize::try_from(num_frames).unwrap_or(num_samples);
    let mut t_out = Vec::with_capacity(capacity);
    let mut joints_out = Vec::with_capacity(capacity);
    let mut seen = Vec::with_capacity(capacity);
    let mut prev: Option<&TrackSample> = None;
    for s in samples {
        if let Some(p) = prev {
            let gap = s.t - p.t;
            let frames = frames_in(gap);
            let is_filled = frames - 1 <= max_filled_frames;
            for k in 1..frames {
                let f = k as f64 / frames as f64;
                t_out.push(p.t + (gap as f64 * f).round() as i64);
                let mut joints = Joints::new();
                if is_filled {
                    for (joint, a) in p.joints.iter() {
                        if let Some(b) = s.joints.get(joint) {
                            joints.insert(joint, Point3::from(a.coords.lerp(&b.coords, f)));
                        }
                    }
                }
                joints_out.push(joints);
                seen.push(false);
            }
        }
        t_out.push(s.t);
        joints_out.push(s.joints.clone());
        seen.push(true);
        prev = Some(s);
    }
    Some((t_out, joints_out, seen))
}

/// `NaN` in place of the values of `thinned` (every [`LAG_DECIMATION`]-th sample of a track's
/// lag buffer) at the frames `seen` says the track missed; nothing if `seen` is empty (every
/// frame was).
fn mask_unseen(thinned: &mut [f64], seen: &[bool]) {
    if seen.is_empty() {
        return;
    }
    for (v, s) in thinned.iter_mut().zip(seen.iter().step_by(LAG_DECIMATION)) {
        if !s {
            *v = f64::NAN;
        }
    }
}

/// Records in [`EngineStats::offsets_at_search_edge`] whether `mean`, an IMU's best-track sum
/// over `lags` (relative to its registry offset, increasing), peaks at an end of the search:
/// its largest finite value is the first or the last lag's.
fn note_search_edge(stats: &mut EngineStats, device: &DeviceId, mean: &[f64], lags: &[i64]) {
    let best = mean
        .iter()
        .enumerate()
        .filter(|(_, v)| v.is_finite())
        .max_by(|a, b| a.1.total_cmp(b.1))
        .map(|(k, _)| k);
    let edge = match best {
        Some(0) => lags.first(),
        Some(k) if k + 1 == mean.len() => lags.last(),
        _ => None,
    };
    match edge {
        Some(&lag_ns) => {
            stats
                .offsets_at_search_edge
                .insert(device.clone(), lag_ns as f64 * 1e-9);
        }
        None => {
            stats.offsets_at_search_edge.remove(device);
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn one_view_per_person_keeps_the_view_covering_more_then_the_lower_key() {
        let (a, b, c) = ((0, TrackId(7)), (1, TrackId(3)), (1, TrackId(9)));
        // Seconds of the buffer each read track covers; `c` is not read.
        let read = |k: TrackKey| match k {
            (0, TrackId(7)) => Some(4.0),
            (1, TrackId(3)) => Some(6.0),
            _ => None,
        };
        // `b` covers more: `a` is skipped, `b` read.
        assert!(is_lesser_view(a, &[b], 4.0, read));
        assert!(!is_lesser_view(b, &[a], 6.0, read));
        // A view that is not read, or one in the track's own camera, never skips it.
        assert!(!is_lesser_view(a, &[c], 4.0, read));
        assert!(!is_lesser_view((1, TrackId(1)), &[b], 1.0, read));
        // As much of the buffer: the lower key is read.
        let tied = |_: TrackKey| Some(5.0);
        assert!(!is_lesser_view(a, &[b], 5.0, tied));
        assert!(is_lesser_view(b, &[a], 5.0, tied));
        // No views: read.
        assert!(!is_lesser_view(a, &[], 4.0, read));
    }

    fn sample(t: i64, x: f64) -> TrackSample {
        let mut joints = Joints::new();
        joints.insert(Joint::LeftWrist, Point3::new(x, 0.0, 1.0));
        TrackSample {
            t,
            joints,
            bridged: 0,
        }
    }

    #[test]
    fn missed_frames_are_put_back_filled_and_unseen_long_gaps_empty() {
        const F: i64 = 33_333_333;
        // Frames 0, 1 (a little late), 3, 4, 14 and 26 to 35: one frame missed, then nine
        // (filled), then eleven (more than `MAX_FILLED_NS`, 10 frames at 30 Hz: a gap).
        let mut samples = vec![
            sample(0, 0.0),
            sample(F + 2_000_000, 1.0),
            sample(3 * F, 3.0),
            sample(4 * F, 4.0),
            sample(14 * F, 14.0),
        ];
        samples.extend((26..36).map(|k| sample(k * F, k as f64)));
        let (t, joints, seen) = on_frame_grid(samples.iter()).unwrap();
        assert_eq!((t.len(), joints.len(), seen.len()), (36, 36, 36));
        assert!(t.windows(2).all(|w| w[1] > w[0]));
        // The late frame is kept where it was; the missed frame lies halfway, interpolated.
        assert_eq!(t[1], F + 2_000_000);
        assert_eq!(t[2], (F + 2_000_000 + 3 * F) / 2);
        let x = |k: usize| joints[k].get(Joint::LeftWrist).map(|p| p.x);
        assert!((x(2).unwrap() - 2.0).abs() < 1e-12);
        assert!((5..14).all(|k| (x(k).unwrap() - k as f64).abs() < 1e-9));
        assert!((15..26).all(|k| joints[k].is_empty()));
        let unseen: Vec<usize> = (0..36).filter(|&k| !seen[k]).collect();
        let mut want = vec![2];
        want.extend(5..14);
        want.extend(15..26);
        assert_eq!(unseen, want);
        assert_eq!((t[14], t[26]), (14 * F, 26 * F));
        // The unseen frames' values are not compared.
        let mut thinned: Vec<f64> = (0..36).step_by(LAG_DECIMATION).map(|k| k as f64).collect();
        mask_unseen(&mut thinned, &seen);
        for (i, v) in thinned.iter().enumerate() {
            assert_eq!(v.is_nan(), !seen[i * LAG_DECIMATION]);
        }
        // A track seen in every frame is unchanged.
        let (t, _, seen) = on_frame_grid(samples[2..4].iter()).unwrap();
        assert_eq!((t, seen), (vec![3 * F, 4 * F], vec![true, true]));
        // Samples 1 µs apart and then a second apart: no regular frame interval, no grid (a
        // million frames otherwise), nor for no samples at all.
        let odd = [
            sample(0, 0.0),
            sample(1_000, 0.0),
            sample(2_000, 0.0),
            sample(3_000, 0.0),
            sample(1_000_000_000, 1.0),
        ];
        assert!(on_frame_grid(odd.iter()).is_none());
        assert!(on_frame_grid(odd[..0].iter()).is_none());
    }

    #[test]
    fn a_band_on_either_wrist_takes_the_better_sides_curve_lag_by_lag() {
        // The IMU's signal is the left wrist's; the right wrist's is the same half a second
        // later, and the left wrist's is missing for the track's first half.
        let t: Vec<i64> = (0..300).map(|k| k * 10_000_000).collect();
        let wave = |t: i64| {
            let s = t as f64 * 1e-9;
            (s * 5.3).sin() + (s * 2.1).cos() * 0.7
        };
        let signals = |f: &dyn Fn(i64) -> f64| LagSignals {
            t_ns: t.clone(),
            models: vec![t.iter().map(|&t| f(t)).collect()],
            sample_scale: 1.0,
        };
        let imu = signals(&wave);
        let left = signals(&|t| if t < 1_500_000_000 { f64::NAN } else { wave(t) });
        let right = signals(&|t| wave(t - 500_000_000));
        let offsets: Vec<i64> = (-60..=60).map(|k| k * 10_000_000).collect();
        let mut weights = Vec::new();
        let (mut one, mut other) = (Vec::new(), Vec::new());
        let (mut both, mut scratch) = (Vec::new(), Vec::new());
        let curve = |track, out: &mut Vec<f64>, weights: &mut Vec<LagWeight>| {
            lag_curve(&imu, track, 1, &offsets, MAX_IMU_GAP_NS, 16, weights, out);
        };
        curve(&left, &mut one, &mut weights);
        curve(&right, &mut other, &mut weights);
        sides_curve(
            &imu,
            (&left, Some(&right)),
            1,
            &offsets,
            16,
            &mut weights,
            (&mut both, &mut scratch),
        );
        for ((b, l), r) in both.iter().zip(&one).zip(&other) {
            let want = match (l.is_finite(), r.is_finite()) {
                (true, true) => l.max(*r),
                (true, false) => *l,
                (false, true) => *r,
                (false, false) => f64::NAN,
            };
            assert!(b == &want || (b.is_nan() && want.is_nan()), "{b} {l} {r}");
        }
        // Each side peaks where its wrist fits: the left at 0, the right half a second later.
        let peak = |c: &[f64]| {
            let k = (0..c.len())
                .filter(|&k| c[k].is_finite())
                .max_by(|&a, &b| c[a].total_cmp(&c[b]))
                .unwrap();
            offsets[k]
        };
        assert_eq!((peak(&one), peak(&other)), (0, 500_000_000));
        // Without a mirror image the curve is the site's own.
        sides_curve(
            &imu,
            (&left, None),
            1,
            &offsets,
            16,
            &mut weights,
            (&mut both, &mut scratch),
        );
        assert!(
            both.iter()
                .zip(&one)
                .all(|(b, l)| b == l || (b.is_nan() && l.is_nan()))
        );
    }

    #[test]
    fn the_longest_filled_gap_is_a_time_at_every_frame_rate() {
        // At 15 Hz a third of a second is 5 frames: 5 missed frames are filled, 6 are a gap.
        const F: i64 = 66_666_667;
        let samples = [
            sample(0, 0.0),
            sample(F, 1.0),
            sample(7 * F, 7.0),
            sample(8 * F, 8.0),
            sample(15 * F, 15.0),
            sample(16 * F, 16.0),
        ];
        let (t, joints, seen) = on_frame_grid(samples.iter()).unwrap();
        assert_eq!(t.len(), 17);
        let unseen: Vec<usize> = (0..17).filter(|&k| !seen[k]).collect();
        assert_eq!(unseen, [2, 3, 4, 5, 6, 9, 10, 11, 12, 13, 14]);
        assert!((2..7).all(|k| joints[k].get(Joint::LeftWrist).is_some()));
        assert!((9..15).all(|k| joints[k].is_empty()));
    }
}
