//! RSSI evidence: passive RFID and BLE tags read at fixed antennas, scored against the camera
//! tracks by how well each track's path explains the reads over time.
//!
//! # Model
//!
//! A read of tag `j` at antenna `a` at time `t`, worn by the person of track `k`, is
//!
//! ```text
//! r = μ_a(x_k(t)) + ΔK2_a·θ_a(x_k(t)) + g_ja + b(t) + e,    e ~ N(0, σ_a²(x_k(t)))
//! ```
//!
//! with `μ_a` the antenna's model (standard or directional: distance *and* angle off the
//! boresight along the track's path), `ΔK2_a` a learned correction to its angular slope, `g_ja`
//! the tag's gain there (a tag is not the calibrated one; an antenna's cable and mounting differ
//! from an uncalibrated model's), `b(t)` slow shadowing (a random walk,
//! [`SHADOWING_DRIFT_DB2_PER_S`]) and `σ_a²` the model's residual variance. Each read is
//! compared with the model at the track's position **at the read's time**, so the time of the
//! RSSI peak, the direction of motion and the angle to the antenna over time all count, not
//! only the level. Per (track, tag, antenna) a scalar Kalman filter follows `b` from the
//! residuals (the gain's uncertainty added to each read's variance), and the sum of its
//! innovations' log-likelihoods scores the read sequence under "the tag is on this person".
//! A read that a body in the way weakens is an outlier: each innovation is scored under a
//! mixture with a broad component ([`OUTLIER_PROBABILITY`], [`OUTLIER_STD_DB`]) and moves the
//! filter by its inlier responsibility.
//!
//! The alternative, the **background**, is "the tag is on someone this track is not": each read
//! anywhere in the area, Gaussian with the model's background mean and spread (the calibration
//! reads'), shifted by the tag's gain as known, whose uncertainty it shares (Llorca's
//! background, read by read).
//! Each pair accumulates the log-likelihood ratio of its track against the background over the
//! reads it saw, forgetting with [`EngineConfig::rssi_evidence_half_life_s`]; a new track starts
//! at 0, as likely as the background.
//!
//! # Silence
//!
//! An antenna that hears nothing of a tag over a whole window while another antenna hears it
//! gives censored evidence (`nomen_rssi::NotHeard::Censored`):
//! `P(silent | x) = m + (1 − m)·Φ((S − μ) / s)`, with `S` the antenna's sensitivity (the weakest
//! read it has reported, or the model's when weaker) and `m` the probability that a tag in range
//! goes unheard for the window. Silence counts against people the antenna should have heard.
//!
//! # Gains and slopes, learned online
//!
//! `g_ja` has the prior `N(ĝ_a, τ²)`: `ĝ_a` the mean gain learned at antenna `a` over the other
//! tags (the antenna's offset from the model), `τ` [`GAIN_PRIOR_STD_DB`] (plus
//! [`UNCALIBRATED_GAIN_STD_DB`] for the fitted default model). A tag's reads refine its gains,
//! and every antenna's slope correction (a regression of the residuals on θ within each tag),
//! while the tag is associated: its pair on one track holds [`LEARN_POSTERIOR`] of the
//! posterior among the camera's tracks, or the track is the only person the camera sees (vision
//! alone tells who carries it). Learned gains make the level count, which tells apart people
//! walking abreast.
//!
//! # Scores
//!
//! Per tag heard within [`HEARD_WITHIN_NS`], the posterior over the camera's tracks and the
//! background (even prior odds) gives `p_k`; the track's score is `2p_k − 1` clamped to `0..=1`
//! (a track must be likelier than every alternative together to score), a subject's the mean
//! over her tags.

use super::{MAX_PAIR_DT_NS, TrackState, joint_centroid};
use crate::config::EngineConfig;
use nalgebra::Point3;
use nomen_core::{AntennaId, DeviceId, Joint, RssiRead};
use nomen_rssi::likelihood::NotHeard;
use nomen_rssi::read::checked_rssi_dbm;
use nomen_rssi::{LikelihoodConfig, RssiModel, RssiUnit, TagPlacement};
use std::collections::{BTreeMap, VecDeque};

/// Drift of the slow shadowing, dB² per second (a random walk): about 0.5 dB in a second,
/// 1.6 dB in ten. An assumption: people's bodies and orientation change the link slowly
/// compared with the 10 Hz reads.
pub(super) const SHADOWING_DRIFT_DB2_PER_S: f64 = 0.25;

/// Prior spread of a tag's gain at an antenna around the antenna's learned offset, dB: two tags
/// (the calibrated one and this one) each off the model by the 3.5 dB spread of per-anchor P1
/// in Kolakowski's BLE fit (`docs/sensor-models.md`), √2 · 3.5 ≈ 5.
pub(super) const GAIN_PRIOR_STD_DB: f64 = 5.0;

/// Prior spread of an antenna's offset from an uncalibrated model, dB: the whole range of
/// Kolakowski's per-anchor P1 (−51.8 … −41.7 dBm) as ±1σ. Used with the fitted default model.
pub(super) const UNCALIBRATED_GAIN_STD_DB: f64 = 5.0;

/// Probability that a read is weakened by something the model does not know (a body on the
/// line of sight, a reflection). An assumption: a few bodies cross the line in a crowd.
pub(super) const OUTLIER_PROBABILITY: f64 = 0.1;

/// Spread of such reads around the model, dB: body attenuation at UHF and 2.4 GHz is reported
/// at 5–20 dB.
pub(super) const OUTLIER_STD_DB: f64 = 12.0;

/// Prior spread of an antenna's correction to a calibrated model's angular slope K2, dB/rad
/// (the calibration fitted it, from one tag's walk).
pub(super) const CALIBRATED_SLOPE_STD_DB_PER_RAD: f64 = 2.0;

/// Prior spread of the angular slope of an uncalibrated antenna, dB/rad: the fitted default
/// is omnidirectional, and a patch antenna loses 3 dB at about 0.6 rad off its boresight
/// (−5 dB/rad).
pub(super) const UNCALIBRATED_SLOPE_STD_DB_PER_RAD: f64 = 5.0;

/// Share of a tag's posterior on one track from which its reads refine the tag's gains.
pub(super) const LEARN_POSTERIOR: f64 = 0.9;

/// A learned gain is never taken as more certain than this, dB (tags age, people turn).
const GAIN_FLOOR_STD_DB: f64 = 0.5;

/// A tag scores while some antenna heard it this recently, ns (the Kalman filters' reset window).
pub(super) const HEARD_WITHIN_NS: i64 = 2_000_000_000;

/// Settled reads older than this before a window's end are dropped unscored, ns.
const READ_MEMORY_NS: i64 = 10_000_000_000;

/// Fewest reads of an antenna before its weakest read counts as its sensitivity.
const MIN_READS_FOR_SENSITIVITY: u64 = 20;

/// Fewest polls' worth of silence (at the tag's read rate on other antennas) before silence
/// counts.
const MIN_SILENT_SPAN_NS: i64 = 300_000_000;

const LN_2PI: f64 = 1.837_877_066_409_345_3;

/// One (track, tag) pair's evidence, kept on the track (it follows the person through id swaps
/// and stitches).
#[derive(Clone, Debug, Default)]
pub(super) struct RssiPair {
    /// Log-likelihood ratio of "the tag is on this track" against the background, decayed.
    llr: f64,
    /// Time the ratio was last decayed to, ns.
    decayed_to: i64,
    /// Share of the tag's posterior on this track at the last scoring.
    posterior: f64,
    /// Share of the tag's posterior among the camera's tracks only (no background) at the last
    /// scoring.
    relative: f64,
    /// One filter per model antenna.
    channels: Vec<Channel>,
}

/// The filter of one (track, tag, antenna): the track hypothesis on the residuals.
#[derive(Clone, Copy, Debug, Default)]
struct Channel {
    /// Whether a read started the filters.
    is_started: bool,
    t: i64,
    /// Slow shadowing: the residual level beyond the tag's learned gain, dB.
    b: f64,
    p: f64,
}

/// A settled read: session time, tag index, antenna index in the model, dBm.
#[derive(Clone, Copy, Debug)]
struct Read {
    t: i64,
    tag: usize,
    antenna: usize,
    rssi_dbm: f64,
}

/// What a tag's reads at one antenna taught while it was associated: weighted sums (weights
/// 1/v) of the residuals `r` against the model and of the angle θ off the boresight, for the
/// regression `r = g + ΔK2·θ` (the tag's gain, the antenna's correction to the model's slope).
#[derive(Clone, Copy, Debug, Default)]
struct Gain {
    /// Σ 1/v.
    info: f64,
    /// Σ r/v.
    sum: f64,
    /// Σ θ/v.
    sum_theta: f64,
    /// Σ θ²/v.
    sum_theta2: f64,
    /// Σ θ·r/v.
    sum_theta_r: f64,
}

/// The RSSI evidence stage: reads wait for the reorder window (`pending`, `frontier`), settle
/// in time order, and are scored against each camera's tracks at every window end
/// ([`RssiEvidence::camera_scores`]).
pub(super) struct RssiEvidence {
    model: RssiModel,
    /// Prior spread of a tag's gain around the antenna's offset, dB.
    gain_prior_std_db: f64,
    /// Prior spread of an antenna's offset from the model, dB.
    antenna_prior_std_db: f64,
    /// Prior spread of an antenna's correction to the model's angular slope, dB/rad.
    slope_prior_std_db_per_rad: f64,
    /// Per antenna: the learned correction to the model's angular slope, dB/rad.
    slope_correction: Vec<f64>,
    likelihood: LikelihoodConfig,
    decay_per_s: f64,
    /// The RSSI tags: id, subject, site; indexed like `gains`.
    tags: Vec<(DeviceId, usize, Joint)>,
    tag_index: BTreeMap<DeviceId, usize>,
    /// Reads waiting for the reorder window, by (session ns, tag, antenna).
    pub(super) pending: BTreeMap<(i64, DeviceId, AntennaId), RssiRead>,
    pub(super) newest: Option<i64>,
    pub(super) frontier: i64,
    /// Settled reads not yet scored by every camera, time order.
    reads: VecDeque<Read>,
    /// Per camera: reads up to this time are scored, ns.
    scored_until: BTreeMap<usize, i64>,
    /// Per tag, per antenna: learned gain.
    gains: Vec<Vec<Gain>>,
    /// Per tag, per antenna: the newest read's time, ns.
    last_heard: Vec<Vec<Option<i64>>>,
    /// Per antenna: number of reads and the weakest, dBm.
    weakest: Vec<(u64, f64)>,
}

impl RssiEvidence {
    /// The stage for `model` (validated by the caller) and the registry's RSSI tags (id →
    /// subject, site). `is_calibrated` says whether the model was calibrated at this site (else
    /// it is the fitted default and antenna offsets are wider).
    pub(super) fn new(
        model: RssiModel,
        is_calibrated: bool,
        tags: &BTreeMap<DeviceId, (usize, Joint)>,
        config: &EngineConfig,
    ) -> Self {
        let num_antennas = model.antennas.len();
        let tags: Vec<(DeviceId, usize, Joint)> = tags
            .iter()
            .map(|(id, (s, site))| (id.clone(), *s, *site))
            .collect();
        let half_life_s = config.rssi_evidence_half_life_s;
        Self {
            gain_prior_std_db: GAIN_PRIOR_STD_DB,
            antenna_prior_std_db: if is_calibrated {
                0.0
            } else {
                UNCALIBRATED_GAIN_STD_DB
            },
            slope_prior_std_db_per_rad: if is_calibrated {
                CALIBRATED_SLOPE_STD_DB_PER_RAD
            } else {
                UNCALIBRATED_SLOPE_STD_DB_PER_RAD
            },
            slope_correction: vec![0.0; num_antennas],
            likelihood: LikelihoodConfig::default(),
            decay_per_s: if half_life_s > 0.0 {
                0.5f64.powf(1.0 / half_life_s)
            } else {
                0.0
            },
            tag_index: tags
                .iter()
                .enumerate()
                .map(|(i, (id, _, _))| (id.clone(), i))
                .collect(),
            gains: vec![vec![Gain::default(); num_antennas]; tags.len()],
            last_heard: vec![vec![None; num_antennas]; tags.len()],
            weakest: vec![(0, f64::INFINITY); num_antennas],
            tags,
            pending: BTreeMap::new(),
            newest: None,
            frontier: i64::MIN,
            reads: VecDeque::new(),
            scored_until: BTreeMap::new(),
            model,
        }
    }

    /// Moves the reads below the frontier into the settled queue, in time order; returns the
    /// first refusal (a value no receiver reports), if any.
    pub(super) fn settle(&mut self) -> Option<nomen_rssi::RssiError> {
        let mut first = None;
        while let Some(entry) = self.pending.first_entry() {
            if entry.key().0 >= self.frontier {
                break;
            }
            let read = entry.remove();
            let rssi_dbm = match checked_rssi_dbm(&read, RssiUnit::Dbm) {
                Ok(v) => v,
                Err(e) => {
                    first.get_or_insert(e);
                    continue;
                }
            };
            let (Some(&tag), Some((antenna, _))) = (
                self.tag_index.get(&read.tag),
                self.model.antenna(&read.antenna),
            ) else {
                continue;
            };
            let t = read.t.as_ns();
            if let Some(w) = self.weakest.get_mut(antenna) {
                w.0 += 1;
                w.1 = w.1.min(rssi_dbm);
            }
            if let Some(slot) = self
                .last_heard
                .get_mut(tag)
                .and_then(|v| v.get_mut(antenna))
            {
                *slot = Some(slot.map_or(t, |s| s.max(t)));
            }
            self.reads.push_back(Read {
                t,
                tag,
                antenna,
                rssi_dbm,
            });
        }
        first
    }

    /// The gain of `tag` at `antenna` as known now: mean and variance, dB and dB². The mean
    /// is the tag's learned gain (its residuals less the antenna's slope correction) pulled
    /// towards the antenna's offset (the mean learned gain of the other tags there).
    fn gain(&self, tag: usize, antenna: usize) -> (f64, f64) {
        let slope = self.slope_correction.get(antenna).copied().unwrap_or(0.0);
        let (mut sum, mut n) = (0.0, 0usize);
        for (j, g) in self.gains.iter().enumerate() {
            if j != tag
                && let Some(g) = g.get(antenna)
                && g.info > 0.0
            {
                sum += (g.sum - slope * g.sum_theta) / g.info;
                n += 1;
            }
        }
        let antenna_var = self.antenna_prior_std_db.powi(2);
        // The antenna's offset: the other tags' mean gain, its uncertainty shrinking with n.
        let (offset, offset_var) = if n > 0 {
            let v = self.gain_prior_std_db.powi(2) / n as f64;
            let w = antenna_var / (antenna_var + v).max(1e-12);
            (w * sum / n as f64, antenna_var * (1.0 - w))
        } else {
            (0.0, antenna_var)
        };
        let prior_var = (self.gain_prior_std_db.powi(2) + offset_var).max(1e-6);
        let g = self
            .gains
            .get(tag)
            .and_then(|g| g.get(antenna))
            .copied()
            .unwrap_or_default();
        let info = 1.0 / prior_var + g.info;
        (
            (offset / prior_var + g.sum - slope * g.sum_theta) / info,
            1.0 / info,
        )
    }

    /// Adds an associated read's residual (dB, variance dB²) at angle `theta_rad` to what the
    /// tag's gain and the antenna's slope are learned from, and refits the slope.
    fn learn_gain(
        &mut self,
        tag: usize,
        antenna: usize,
        residual_db: f64,
        theta_rad: f64,
        var_db2: f64,
    ) {
        let Some(g) = self.gains.get_mut(tag).and_then(|g| g.get_mut(antenna)) else {
            return;
        };
        let w = 1.0 / var_db2.max(1e-6);
        g.info += w;
        g.sum += w * residual_db;
        g.sum_theta += w * theta_rad;
        g.sum_theta2 += w * theta_rad * theta_rad;
        g.sum_theta_r += w * theta_rad * residual_db;
        let cap = 1.0 / (GAIN_FLOOR_STD_DB * GAIN_FLOOR_STD_DB);
        if g.info > cap {
            let f = cap / g.info;
            g.info = cap;
            g.sum *= f;
            g.sum_theta *= f;
            g.sum_theta2 *= f;
            g.sum_theta_r *= f;
        }
        // The slope correction: the within-tag regression of residual on angle (each tag its
        // own intercept), shrunk towards 0 by its prior.
        let (mut num, mut den) = (
            0.0,
            1.0 / self.slope_prior_std_db_per_rad.powi(2).max(1e-12),
        );
        for g in self.gains.iter().filter_map(|g| g.get(antenna)) {
            if g.info > 0.0 {
                num += g.sum_theta_r - g.sum_theta * g.sum / g.info;
                den += g.sum_theta2 - g.sum_theta * g.sum_theta / g.info;
            }
        }
        if let Some(slope) = self.slope_correction.get_mut(antenna) {
            *slope = num / den;
        }
    }

    /// The antenna's sensitivity: the weakest read it reported (after a few) or the model's,
    /// whichever is weaker, dBm.
    fn sensitivity_dbm(&self, antenna: usize) -> Option<f64> {
        let model = self.model.antennas.get(antenna)?.weakest_read_dbm;
        Some(match self.weakest.get(antenna) {
            Some(&(n, w)) if n >= MIN_READS_FOR_SENSITIVITY => w.min(model),
            _ => model,
        })
    }

    /// Scores the reads up to `end` against the tracks of `camera` (their pair state lives on
    /// the tracks) and returns, per track (rows, in `tracks` order) and subject (columns), the
    /// score in `0..=1`, `None` where the subject has no tag heard recently.
    pub(super) fn camera_scores(
        &mut self,
        camera: usize,
        tracks: &mut [&mut TrackState],
        end: i64,
        num_subjects: usize,
    ) -> Vec<Vec<Option<f64>>> {
        let from = self.scored_until.get(&camera).copied().unwrap_or(i64::MIN);
        self.scored_until.insert(camera, end);
        let num_antennas = self.model.antennas.len();
        let num_tags = self.tags.len();
        // Decay every pair to the window's end first: reads of this window count in full.
        for tr in tracks.iter_mut() {
            for pair in tr.rssi_pairs.values_mut() {
                if pair.decayed_to < end {
                    let dt_s = (end - pair.decayed_to) as f64 * 1e-9;
                    if pair.decayed_to > i64::MIN {
                        pair.llr *= self.decay_per_s.powf(dt_s);
                    }
                    pair.decayed_to = end;
                }
            }
        }
        let start = self.reads.partition_point(|r| r.t <= from);
        let stop = self.reads.partition_point(|r| r.t <= end);
        let mut heard_in_window = vec![vec![false; num_antennas]; num_tags];
        let mut first_read = vec![None::<i64>; num_tags];
        let placement = self.model.placement;
        for i in start..stop {
            let Some(&read) = self.reads.get(i) else {
                continue;
            };
            if let Some(h) = heard_in_window
                .get_mut(read.tag)
                .and_then(|v| v.get_mut(read.antenna))
            {
                *h = true;
            }
            if let Some(f) = first_read.get_mut(read.tag) {
                f.get_or_insert(read.t);
            }
            let Some(&(_, _, site)) = self.tags.get(read.tag) else {
                continue;
            };
            let Some(model) = self.model.antennas.get(read.antenna) else {
                continue;
            };
            let (gain_mean, gain_var) = self.gain(read.tag, read.antenna);
            // The background's spread already holds the shadowing: no per-read term.
            let bg_var_read = 0.0;
            let positions: Vec<Option<Point3<f64>>> = tracks
                .iter()
                .map(|tr| tag_position(tr, read.t, placement, site))
                .collect();
            let num_seen = positions.iter().flatten().count();
            let mut learned = None;
            let slope = self
                .slope_correction
                .get(read.antenna)
                .copied()
                .unwrap_or(0.0);
            for (tr, x) in tracks.iter_mut().zip(&positions) {
                let Some(x) = x else { continue };
                let (mean, var) = model.predict(x);
                let theta = model.geometry(x).1;
                let residual = read.rssi_dbm - mean;
                let pair = tr.rssi_pairs.entry(read.tag).or_insert_with(|| RssiPair {
                    decayed_to: end,
                    channels: vec![Channel::default(); num_antennas],
                    ..RssiPair::default()
                });
                if num_seen == 1 || pair.relative >= LEARN_POSTERIOR {
                    learned = Some((residual, theta, var));
                }
                let Some(ch) = pair.channels.get_mut(read.antenna) else {
                    continue;
                };
                let ll = ch.update(
                    read.t,
                    residual - slope * theta - gain_mean,
                    var + gain_var,
                    read.rssi_dbm,
                    bg_var_read,
                    (
                        model.background_mean_dbm + gain_mean,
                        model.background_std_db.powi(2) + gain_var,
                    ),
                );
                pair.llr += ll;
            }
            if let Some((residual, theta, var)) = learned {
                self.learn_gain(read.tag, read.antenna, residual, theta, var);
            }
        }
        // Silence: an antenna that heard nothing of a tag over the window while another did.
        if self.likelihood.not_heard == NotHeard::Censored {
            for tag in 0..num_tags {
                let Some(first) = first_read.get(tag).copied().flatten() else {
                    continue;
                };
                if end - first.max(from) < MIN_SILENT_SPAN_NS {
                    continue;
                }
                let Some(&(_, _, site)) = self.tags.get(tag) else {
                    continue;
                };
                for a in 0..num_antennas {
                    if heard_in_window
                        .get(tag)
                        .and_then(|v| v.get(a))
                        .is_none_or(|h| *h)
                    {
                        continue;
                    }
                    let (Some(model), Some(sensitivity)) =
                        (self.model.antennas.get(a), self.sensitivity_dbm(a))
                    else {
                        continue;
                    };
                    let (gain_mean, gain_var) = self.gain(tag, a);
                    let m = self.likelihood.miss_probability;
                    for tr in tracks.iter_mut() {
                        let Some(x) = tag_position(tr, end, placement, site) else {
                            continue;
                        };
                        let Some(pair) = tr.rssi_pairs.get_mut(&tag) else {
                            continue;
                        };
                        let Some(ch) = pair.channels.get(a) else {
                            continue;
                        };
                        let (mean, var) = model.predict(&x);
                        let mean = mean
                            + self.slope_correction.get(a).copied().unwrap_or(0.0)
                                * model.geometry(&x).1;
                        let (b, p) = if ch.is_started {
                            (ch.b, ch.p + gain_var)
                        } else {
                            (0.0, gain_var)
                        };
                        let (level, level_p) = (
                            model.background_mean_dbm + gain_mean,
                            model.background_std_db.powi(2) + gain_var,
                        );
                        let on = log_silence(m, sensitivity, mean + gain_mean + b, var + p);
                        let off = log_silence(m, sensitivity, level, level_p);
                        pair.llr += on - off;
                    }
                }
            }
        }
        // Forget reads every camera has scored, and any too old to matter.
        let oldest_needed = self
            .scored_until
            .values()
            .copied()
            .min()
            .unwrap_or(end)
            .max(end.saturating_sub(READ_MEMORY_NS));
        while self.reads.front().is_some_and(|r| r.t <= oldest_needed) {
            self.reads.pop_front();
        }
        // Posterior per heard tag over the camera's tracks and the background.
        let mut sums = vec![vec![(0.0, 0usize); num_subjects]; tracks.len()];
        for (tag, &(_, subject, _)) in self.tags.iter().enumerate() {
            let heard = self.last_heard.get(tag).is_some_and(|v| {
                v.iter()
                    .flatten()
                    .any(|&t| t <= end && end - t <= HEARD_WITHIN_NS)
            });
            let llrs: Vec<Option<f64>> = tracks
                .iter()
                .map(|tr| tr.rssi_pairs.get(&tag).map(|p| p.llr))
                .collect();
            let max = llrs.iter().flatten().copied().fold(0.0, f64::max);
            let total = (-max).exp() + llrs.iter().flatten().map(|l| (l - max).exp()).sum::<f64>();
            let max_tracks = llrs
                .iter()
                .flatten()
                .copied()
                .fold(f64::NEG_INFINITY, f64::max);
            let total_tracks: f64 = llrs.iter().flatten().map(|l| (l - max_tracks).exp()).sum();
            for ((tr, llr), row) in tracks.iter_mut().zip(&llrs).zip(sums.iter_mut()) {
                let Some(llr) = llr else { continue };
                let p = (llr - max).exp() / total;
                if let Some(pair) = tr.rssi_pairs.get_mut(&tag) {
                    pair.posterior = if heard { p } else { 0.0 };
                    pair.relative = if heard {
                        (llr - max_tracks).exp() / total_tracks
                    } else {
                        0.0
                    };
                }
                if !heard || !p.is_finite() {
                    continue;
                }
                if let Some(cell) = row.get_mut(subject) {
                    cell.0 += (2.0 * p - 1.0).clamp(0.0, 1.0);
                    cell.1 += 1;
                }
            }
        }
        sums.into_iter()
            .map(|row| {
                row.into_iter()
                    .map(|(sum, n)| (n > 0).then(|| sum / n as f64))
                    .collect()
            })
            .collect()
    }
}

impl Channel {
    /// One read: the track hypothesis on `residual_db` (the read minus the model at the track
    /// and the tag's learned gain; `var_db2` the per-read variance plus the gain's) and the
    /// background on the raw read (`bg_var_db2` per read, `bg_prior` the level's mean and
    /// variance at the start). Returns the log-likelihood ratio of the read, track against
    /// background.
    fn update(
        &mut self,
        t: i64,
        residual_db: f64,
        var_db2: f64,
        rssi_dbm: f64,
        bg_var_db2: f64,
        bg_prior: (f64, f64),
    ) -> f64 {
        if self.is_started {
            let dt_s = ((t - self.t) as f64 * 1e-9).max(0.0);
            self.p += SHADOWING_DRIFT_DB2_PER_S * dt_s;
        } else {
            self.is_started = true;
            self.b = 0.0;
            self.p = 0.0;
        }
        self.t = t;
        let on = robust_step(&mut self.b, &mut self.p, residual_db, var_db2);
        // The background has no state: each read anywhere in the area.
        let (mut level, mut level_p) = bg_prior;
        let off = robust_step(&mut level, &mut level_p, rssi_dbm, bg_var_db2);
        on - off
    }
}

/// One robust Kalman step of a constant level `x` (variance `p`) on a measurement `z` with
/// noise variance `r`: the innovation's log-likelihood under the inlier/outlier mixture, and
/// the update weighted by the inlier responsibility.
fn robust_step(x: &mut f64, p: &mut f64, z: f64, r: f64) -> f64 {
    let s = (*p + r).max(1e-6);
    let e = z - *x;
    let s_out = s + OUTLIER_STD_DB * OUTLIER_STD_DB;
    let l_in = (1.0 - OUTLIER_PROBABILITY) * (-0.5 * (LN_2PI + s.ln() + e * e / s)).exp();
    let l_out = OUTLIER_PROBABILITY * (-0.5 * (LN_2PI + s_out.ln() + e * e / s_out)).exp();
    let total = l_in + l_out;
    if !(total > 0.0 && total.is_finite()) {
        return -0.5 * (LN_2PI + s_out.ln() + e * e / s_out);
    }
    let w = l_in / total;
    let k = w * *p / s;
    *x += k * e;
    *p *= 1.0 - k;
    total.ln()
}

/// `ln P(silent)` of a read with mean `mean_dbm` and variance `var_db2` at an antenna of
/// sensitivity `sensitivity_dbm`, with `m` the probability that a read in range is missed.
fn log_silence(m: f64, sensitivity_dbm: f64, mean_dbm: f64, var_db2: f64) -> f64 {
    let z = (sensitivity_dbm - mean_dbm) / var_db2.max(1e-6).sqrt();
    let cdf = 0.5 * libm::erfc(-z / std::f64::consts::SQRT_2);
    (m + (1.0 - m) * cdf).max(1e-300).ln()
}

/// Where the tag of a track's person is at `t` (its sample nearest to `t`, within
/// [`MAX_PAIR_DT_NS`]): at the model's placement, the registry site's joint or the pelvis at a
/// fixed height.
fn tag_position(
    tr: &TrackState,
    t: i64,
    placement: TagPlacement,
    site: Joint,
) -> Option<Point3<f64>> {
    let i = tr.samples.partition_point(|s| s.t < t);
    let before = i.checked_sub(1).and_then(|k| tr.samples.get(k));
    let after = tr.samples.get(i);
    let sample = match (before, after) {
        (Some(a), Some(b)) => Some(if t - a.t <= b.t - t { a } else { b }),
        (a, b) => a.or(b),
    }
    .filter(|s| (s.t - t).abs() <= MAX_PAIR_DT_NS)?;
    let pelvis = || {
        sample
            .joints
            .get(Joint::Pelvis)
            .copied()
            .or_else(|| joint_centroid(&sample.joints))
    };
    match placement {
        TagPlacement::FixedHeight(h) => pelvis().map(|p| Point3::new(p.x, p.y, h)),
        TagPlacement::RegistrySite => sample.joints.get(site).copied().or_else(pelvis),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;
    use nomen_core::Antenna;

    fn evidence(is_calibrated: bool) -> RssiEvidence {
        let antennas = [Antenna {
            id: AntennaId::new("ant0"),
            position_m: Point3::new(0.0, 0.0, 1.0),
            boresight: Some(Vector3::y()),
        }];
        let tags: BTreeMap<DeviceId, (usize, Joint)> = [
            (DeviceId::new("a"), (0, Joint::Chest)),
            (DeviceId::new("b"), (1, Joint::Chest)),
        ]
        .into_iter()
        .collect();
        RssiEvidence::new(
            RssiModel::fitted_default(&antennas),
            is_calibrated,
            &tags,
            &EngineConfig::default(),
        )
    }

    #[test]
    fn silence_counts_against_a_person_the_antenna_should_have_heard() {
        // Sensitivity −70 dBm: a tag predicted at −50 dBm is heard unless the polls are missed.
        let near = log_silence(0.05, -70.0, -50.0, 49.0);
        let far = log_silence(0.05, -70.0, -85.0, 49.0);
        assert!(near < far - 2.0, "{near} {far}");
        assert!(
            near >= 0.05f64.ln() - 1e-9,
            "never below the miss probability: {near}"
        );
        assert!(far <= 0.0 && far > -0.5, "{far}");
    }

    #[test]
    fn a_read_a_body_weakened_moves_the_filter_less_than_a_plain_one() {
        let (mut x_in, mut p_in) = (0.0, 4.0);
        let (mut x_out, mut p_out) = (0.0, 4.0);
        let ll_in = robust_step(&mut x_in, &mut p_in, -3.0, 49.0);
        let ll_out = robust_step(&mut x_out, &mut p_out, -30.0, 49.0);
        assert!(x_in < 0.0 && x_out < 0.0);
        assert!(x_out.abs() < 10.0 * x_in.abs(), "{x_in} {x_out}");
        // The outlier is unlikely but not impossible: bounded by the broad component.
        assert!(ll_out < ll_in && ll_out > -12.0, "{ll_in} {ll_out}");
    }

    #[test]
    fn a_tags_gain_and_the_antennas_slope_are_learned_from_its_associated_reads() {
        let mut ev = evidence(false);
        // Tag 0 reads 8 dB above the model, and the antenna loses 3 dB per radian more than
        // the omnidirectional default says.
        for i in 0..150 {
            let theta = 0.2 + f64::from(i % 11) * 0.1;
            ev.learn_gain(0, 0, 8.0 - 3.0 * theta, theta, 49.0);
        }
        let (gain, var) = ev.gain(0, 0);
        let slope = ev.slope_correction[0];
        assert!((-3.3..=-2.0).contains(&slope), "{slope}");
        assert!((gain - 8.0).abs() < 1.0 && var < 1.0, "{gain} {var}");
        // Another tag at the same antenna starts from the antenna's offset so learned: with
        // one tag to learn it from and equal spreads of antenna offsets and tag gains, half of
        // that tag's gain.
        let (other, other_var) = ev.gain(1, 0);
        assert!(
            (other - 0.5 * gain).abs() < 0.5 && other_var > var,
            "{other} {other_var}"
        );
        // A calibrated model's antenna offset is known: another tag starts at 0.
        let mut calibrated = evidence(true);
        for _ in 0..150 {
            calibrated.learn_gain(0, 0, 8.0, 0.5, 49.0);
        }
        assert!(calibrated.gain(1, 0).0.abs() < 1e-9);
    }
}
