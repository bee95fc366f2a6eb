//! A window's evidence: every (track, subject) pair's motion correlations, Belmonte's costs,
//! location-tag and RSSI scores, accumulated per track (see the crate docs, step 2).

use super::{
    Accumulator, Engine, OrientationTerms, SIDE_MIN_MEAN_VOTE, SIDE_MIN_VOTES,
    SILENT_WEARER_SLACK_NS, TrackKey, TrackState, WINDOW_MIN_TRACK_SAMPLES, accumulate,
    accumulate_weighted, covered_span, max_imu_gap_ns, sample_range, scaled_count,
};
use crate::config::MotionScore;
use crate::signal::imu_window_on_grid;
use crate::stats::{HeadingEstimate, TagNearCount};
use crate::tags::{MAX_PAIR_DT_NS, TagState, fix_informativeness, fix_similarity};
use nalgebra::{Point3, Vector3};
use nomen_core::skeleton::Joints;
use nomen_core::{DeviceId, Joint, TrackId};
use nomen_evidence::belmonte::skeleton_yaw_rate_unsmoothed_radps;
use nomen_evidence::signal::grid_rate_hz;
use nomen_evidence::{
    BandSignals, BelmonteConfig, ForearmSignals, ImuFeatures, ImuUnits, ImuWindow, RawSignals,
    ScoreTensor, SegmentFeatures, SegmentUnits, Side, SkeletonWindow, belmonte_costs_from,
    body_turn_rate_from, compare_prepared, fuse, horizontal_cross_prepared, imu_linear_accel_world,
};
use std::collections::{BTreeMap, BTreeSet};
use std::rc::Rc;

impl Engine {
    /// Scores this window: per camera, a [`ScoreTensor`] of De Marchi's correlations of every
    /// (active track, subject, site), fused by
    /// [`EngineConfig::fusion`](crate::EngineConfig::fusion) into one score per (track, subject)
    /// and accumulated. An IMU without an accepted offset is compared with a track at that pair's
    /// lag-curve peak (the max over the lag range, found on the long buffer).
    pub(super) fn score_window(&mut self, end: i64) {
        let start = end - self.window_ns;
        let min_span = (self.config.min_window_coverage * self.window_ns as f64) as i64;
        let mut sites: Vec<Joint> = self.imus.iter().map(|m| m.site).collect();
        sites.sort_unstable();
        sites.dedup();
        // Subjects wearing IMUs none of which has a settled sample in this window, with the
        // session time of their IMUs' newest settled sample: their motion evidence on a track
        // seen since then is dropped (see `SILENT_WEARER_SLACK_NS`).
        let silent: Vec<(usize, i64)> = (0..self.subjects.len())
            .filter_map(|b| {
                let imus = self.subject_imus.get(b)?;
                let mut newest = i64::MIN;
                for &i in imus {
                    let imu = self.imus.get(i)?;
                    let k = imu.t.partition_point(|&t| t < imu.settled_until_ns);
                    if let Some(&t) = k.checked_sub(1).and_then(|k| imu.t.get(k)) {
                        newest = newest.max(t + imu.offset_ns);
                    }
                }
                (!imus.is_empty() && newest > i64::MIN && newest < start).then_some((b, newest))
            })
            .collect();
        let wants_heading = self.config.motion_score == MotionScore::Nomen
            && self.config.model_weights.heading > 0.0;
        // Each IMU's heading where its estimate is coherent enough (the phase of its cross
        // sums, as a unit complex number), and this window's normalised cross sums against the
        // tracks labelled with its wearer, added after every camera is scored.
        let headings: Vec<Option<[f64; 2]>> =
            self.imus.iter().map(|m| m.heading(&self.config)).collect();
        // Each subject's motion evidence decays at its own rate, a network's faster once one of
        // its offsets is accepted (no offset changes while the cameras are scored).
        let decay: Vec<f64> = (0..self.subjects.len())
            .map(|b| {
                if self.is_network(b) && self.is_synced(b) {
                    self.network_decay_per_hop
                } else {
                    self.decay_per_hop
                }
            })
            .collect();
        // Each IMU's evidence decays at its wearer's rate.
        let imu_decay: Vec<f64> = self
            .imus
            .iter()
            .map(|imu| {
                decay
                    .get(imu.subject)
                    .copied()
                    .unwrap_or(self.decay_per_hop)
            })
            .collect();
        let resting = self.resting_views(start, end, min_span);
        let mut window = WindowScoring {
            start,
            end,
            pad_ns: (self.config.history_pad_s * 1e9) as i64,
            min_span,
            sites,
            wants_heading,
            headings,
            grids: Vec::new(),
            imu_cache: BTreeMap::new(),
            imu_bases: BTreeMap::new(),
            heading_updates: Vec::new(),
            side_updates: Vec::new(),
        };
        for c in 0..self.cameras.len() {
            // Tracks with a few samples in the window; the IMU models need more (below).
            let keys: Vec<(usize, TrackId)> = self
                .tracks
                .iter()
                .filter(|(k, tr)| {
                    k.0 == c && tr.superseded_by.is_none() && {
                        let (a, b) = sample_range(tr, start, end);
                        b >= a + 3
                    }
                })
                .map(|(k, _)| *k)
                .collect();
            if keys.is_empty() {
                continue;
            }
            // Every frame time of the camera in the window (any of its tracks), from the
            // history pad on.
            let pad_ns = window.pad_ns;
            let mut frame_times: Vec<i64> = keys
                .iter()
                .filter_map(|k| self.tracks.get(k))
                .flat_map(|tr| {
                    let (a, b) = sample_range(tr, start.saturating_sub(pad_ns), end);
                    tr.samples.range(a..b).map(|s| s.t)
                })
                .collect();
            frame_times.sort_unstable();
            frame_times.dedup();
            let CameraScores {
                tensor,
                device_scores,
                nomen_sums,
            } = self.score_camera_pairs(c, &mut window, &keys, &frame_times, &resting);
            let tag_decay = self.tag_decay_per_hop;
            let matrix = match self.config.motion_score {
                MotionScore::DeMarchi => tensor
                    .as_ref()
                    .map(|t| fuse(t, self.config.fusion, &self.config.fusion_config)),
                MotionScore::Nomen | MotionScore::Belmonte => None,
            };
            let rssi_matrix = match self.rssi.as_mut() {
                Some(rssi) => {
                    let mut tracks: Vec<&mut TrackState> = self
                        .tracks
                        .iter_mut()
                        .filter(|(k, _)| keys.contains(k))
                        .map(|(_, tr)| tr)
                        .collect();
                    rssi.camera_scores(c, &mut tracks, end, self.subjects.len())
                }
                None => Vec::new(),
            };
            let tag_matrix = {
                let tracks: Vec<Option<&TrackState>> =
                    keys.iter().map(|k| self.tracks.get(k)).collect();
                tag_window_scores(
                    &self.tags,
                    &tracks,
                    end - self.tag_window_ns,
                    end,
                    self.config.joint_noise_std_m,
                    self.subjects.len(),
                    &mut self.stats.tag_fixes_near,
                )
            };
            for (row, key) in keys.iter().enumerate() {
                let Some(tr) = self.tracks.get_mut(key) else {
                    continue;
                };
                // The track's newest settled observation in the window.
                let (_, seen_to) = sample_range(tr, start, end);
                let seen = seen_to
                    .checked_sub(1)
                    .and_then(|k| tr.samples.get(k))
                    .map(|s| s.t);
                for (b, newest) in &silent {
                    if seen.is_some_and(|t| t > newest + SILENT_WEARER_SLACK_NS) {
                        tr.evidence.remove(b);
                    }
                }
                let no_tags = Vec::new();
                let tag_scores = tag_matrix.get(row).unwrap_or(&no_tags);
                let no_rssi = Vec::new();
                let rssi_scores = rssi_matrix.get(row).unwrap_or(&no_rssi);
                for (b, tag_score) in tag_scores.iter().enumerate() {
                    let imu_score = match &matrix {
                        Some(m) => m.get(row, b),
                        None => nomen_sums
                            .get(&(row, b))
                            .filter(|(_, w)| *w > 0.0)
                            .map(|(sum, w)| sum / w),
                    };
                    if let Some(v) = imu_score
                        && let Some(&decay) = decay.get(b)
                    {
                        accumulate(tr.evidence.entry(b).or_default(), v, decay);
                    }
                    if let Some((v, weight)) = tag_score {
                        accumulate_weighted(
                            tr.tag_evidence.entry(b).or_default(),
                            *v,
                            *weight,
                            tag_decay,
                        );
                    }
                    // RSSI scores already weigh the whole read history (`rssi`).
                    if let Some(v) = rssi_scores.get(b).copied().flatten() {
                        *tr.rssi_evidence.entry(b).or_default() = Accumulator {
                            mean: v,
                            weight: 1.0,
                        };
                    }
                }
            }
            // A resting view's motion evidence ages by the hop, as over a window that
            // scored it with no weight: when next scored, it counts as old as it is.
            for key in keys.iter().filter(|k| resting.contains(k)) {
                let Some(tr) = self.tracks.get_mut(key) else {
                    continue;
                };
                for (b, acc) in &mut tr.evidence {
                    acc.weight *= decay.get(*b).copied().unwrap_or(self.decay_per_hop);
                }
                for (i, acc) in &mut tr.device_evidence {
                    acc.weight *= imu_decay.get(*i).copied().unwrap_or(self.decay_per_hop);
                }
            }
            for (key, i, v) in device_scores {
                let decay = imu_decay.get(i).copied().unwrap_or(self.decay_per_hop);
                if let Some(tr) = self.tracks.get_mut(&key) {
                    accumulate(tr.device_evidence.entry(i).or_default(), v, decay);
                }
            }
        }
        if wants_heading {
            self.update_headings(window.heading_updates);
        }
        self.update_sides(window.side_updates);
    }

    /// The tracks that rest in the window `[start, end)`
    /// ([`EngineConfig::alternate_paired_views`](crate::EngineConfig::alternate_paired_views)):
    /// those of this window's resting camera (the cameras take turns, one per hop) with a view
    /// in another camera that was seen before the window, is named, and has enough of the
    /// window to be scored, when the track is unnamed (new, most often) or named alike.
    fn resting_views(&self, start: i64, end: i64, min_span: i64) -> BTreeSet<TrackKey> {
        let num_cameras = self.cameras.len();
        if !self.config.alternate_paired_views || num_cameras < 2 || self.hop_ns <= 0 {
            return BTreeSet::new();
        }
        let turn = end.div_euclid(self.hop_ns).rem_euclid(num_cameras as i64);
        let Ok(c) = usize::try_from(turn) else {
            return BTreeSet::new();
        };
        self.tracks
            .range((c, TrackId(0))..)
            .take_while(|(k, _)| k.0 == c)
            .filter(|(_, tr)| tr.superseded_by.is_none())
            .filter(|(_, tr)| {
                tr.views.iter().any(|v| {
                    v.0 != c
                        && self.tracks.get(v).is_some_and(|view| {
                            let min_samples =
                                scaled_count(WINDOW_MIN_TRACK_SAMPLES, self.camera_scale(v.0));
                            view.superseded_by.is_none()
                                && view.first_t <= start
                                && view.label.is_some()
                                && (tr.label.is_none() || tr.label == view.label)
                                && is_scored(view, start, end, min_samples, min_span)
                        })
                })
            })
            .map(|(k, _)| *k)
            .collect()
    }

    /// Adds this window's votes on the sides of `either_side` IMUs, and reports for each with
    /// [`SIDE_MIN_VOTES`] votes that lead by [`SIDE_MIN_MEAN_VOTE`] on average the side they
    /// lead to ([`EngineStats::imu_sides`](crate::EngineStats::imu_sides)). The comparisons
    /// keep both sides: fixing the side there, once the votes lead, would cost the frames
    /// where a look-alike's other wrist won them.
    pub(super) fn update_sides(&mut self, updates: Vec<(usize, f64)>) {
        for (i, vote) in updates {
            let Some(imu) = self.imus.get_mut(i) else {
                continue;
            };
            let Some(mirror) = imu.mirror_site else {
                continue;
            };
            imu.side_votes += vote;
            imu.num_side_votes += 1;
            let mean = imu.side_votes / f64::from(imu.num_side_votes);
            if imu.num_side_votes >= SIDE_MIN_VOTES && mean.abs() >= SIDE_MIN_MEAN_VOTE {
                let side = if mean < 0.0 { mirror } else { imu.site };
                self.stats.imu_sides.insert(imu.device.clone(), side);
            }
        }
    }

    /// Every (track, IMU) pair of one camera in this window (`keys`, the camera's frame times
    /// `frame_times`): each track on its grid, each IMU's features built once per (grid,
    /// offset), De Marchi's correlations into the tensor, nomen's weighted correlations and
    /// Belmonte's similarity into the per-(row, subject) sums, and the heading's cross sums of
    /// tracks labelled with the IMU's wearer.
    fn score_camera_pairs(
        &self,
        c: usize,
        window: &mut WindowScoring,
        keys: &[TrackKey],
        frame_times: &[i64],
        resting: &BTreeSet<TrackKey>,
    ) -> CameraScores {
        // The models' sample counts at this camera's rate.
        let geometric = self.camera_geometric(c);
        let belmonte = self.camera_belmonte(c);
        let min_track_samples = scaled_count(WINDOW_MIN_TRACK_SAMPLES, self.camera_scale(c));
        let start = window.start;
        let end = window.end;
        let min_span = window.min_span;
        let wants_heading = window.wants_heading;
        let headings = &window.headings;
        let grids = &mut window.grids;
        let imu_cache = &mut window.imu_cache;
        let imu_bases = &mut window.imu_bases;
        let heading_updates = &mut window.heading_updates;
        let side_updates = &mut window.side_updates;
        // Tracks × subjects × sites × 4 entries: thousands, far below the tensor's limit; past
        // it (an absurd stream) the camera gets no De Marchi fusion in this window.
        let mut tensor = ScoreTensor::new(keys.len(), self.subjects.len(), &window.sites).ok();
        let mut device_scores: Vec<((usize, TrackId), usize, f64)> = Vec::new();
        // (row, subject) → (sum, count) of every correlation ([`MotionScore::Nomen`]).
        let mut nomen_sums: BTreeMap<(usize, usize), (f64, f64)> = BTreeMap::new();
        for (row, key) in keys.iter().enumerate() {
            let Some(tr) = self.tracks.get(key) else {
                continue;
            };
            if resting.contains(key) || !is_scored(tr, start, end, min_track_samples, min_span) {
                continue;
            }
            let (_, b) = sample_range(tr, start, end);
            // The camera's frame times from the track's first sample in the window (or in
            // the history pad before it) on; a frame the track missed is a gap (no joints).
            // Tracks seen since before the window share one grid, so an IMU's window and
            // features are built once per (grid, offset), and a track's once per site: a
            // track that missed the window's first frames takes the whole grid with gaps
            // there. Giving it a suffix of its own, as a track first seen inside the window
            // gets, would cost one more build of every IMU's features per such track (about a
            // tenth of the engine's instructions on the 8-person scene) for no accuracy.
            let padded_start = start.saturating_sub(window.pad_ns);
            let (pa, _) = sample_range(tr, padded_start, end);
            let first = if pa > 0 {
                padded_start
            } else {
                tr.samples.get(pa).map_or(start, |s| s.t)
            };
            let grid_from = frame_times.partition_point(|&t| t < first);
            let grid: Vec<i64> = frame_times.get(grid_from..).unwrap_or(&[]).to_vec();
            // Grid samples before the window (the history pad).
            let anchor = grid.partition_point(|&t| t < start);
            let mut samples = tr.samples.range(pa..b).peekable();
            let joints_world_m = grid
                .iter()
                .map(|&t| match samples.next_if(|s| s.t == t) {
                    Some(s) => s.joints.clone(),
                    None => Joints::new(),
                })
                .collect();
            let padded = SkeletonWindow {
                camera: None,
                track: Some(key.1),
                t_s: grid.iter().map(|&t| t as f64 * 1e-9).collect(),
                joints_world_m,
            };
            // The window's part, for the models that do not use the pad.
            let tail = (anchor > 0).then(|| padded.tail(anchor));
            let skel = tail.as_ref().unwrap_or(&padded);
            let mut index_of = |grid: &[i64]| match grids.iter().position(|g| g == grid) {
                Some(g) => g,
                None => {
                    grids.push(grid.to_vec());
                    grids.len() - 1
                }
            };
            let grid_index = index_of(&grid);
            let camera_grid_index = index_of(frame_times);
            // The skeleton's samples next to a run edge that the IMU's filter does not share.
            let run_edge_samples =
                grid_rate_hz(&skel.t_s).map_or(0, |rate| (RUN_EDGE_S * rate).round() as usize);
            let mut segments: Vec<(Joint, SegmentFeatures, SegmentUnits)> = Vec::new();
            // The body's turn rate, the same for every site: computed once per track.
            let mut turn_rate: Option<Vec<f64>> = None;
            // The body's yaw rate before smoothing, once per track: its turn rate smooths it,
            // and so does Belmonte-Hernández's forearm model where that reads the same window
            // and heading line.
            let mut unsmoothed_yaw: Option<Vec<f64>> = None;
            let heading_line = BelmonteConfig::default();
            let yaw_of_padded = || skeleton_yaw_rate_unsmoothed_radps(&padded, &heading_line);
            let shares_yaw =
                anchor == 0 && belmonte.min_heading_line_m == heading_line.min_heading_line_m;
            // The skeleton side of Belmonte's costs, per band side.
            let mut arms: Vec<(Side, ForearmSignals)> = Vec::new();
            for (i, imu) in self.imus.iter().enumerate() {
                // The IMU's window and features at `offset` on this grid, a suffix of the
                // camera's: the resampled samples and the low-passed linear acceleration are
                // sliced from the camera grid's (filtered from the window's start, so the
                // skeleton's run edges are dropped below).
                let mut build = |offset: i64| {
                    let base = imu_bases
                        .entry((i, offset, camera_grid_index))
                        .or_insert_with(|| {
                            let mut window = ImuWindow::default();
                            let mut orientation_from = Vec::new();
                            // Settled samples only: device times before `end` on the current
                            // clock estimate.
                            imu_window_on_grid(
                                &imu.series(),
                                offset,
                                frame_times,
                                max_imu_gap_ns(imu.series().t_ns),
                                (end - imu.offset_ns).min(imu.settled_until_ns),
                                &mut window,
                                &mut orientation_from,
                            );
                            window.device = Some(imu.device.clone());
                            let lin_world_mps2 = imu_linear_accel_world(&window, &geometric);
                            let raw = RawSignals::new(&window, &self.config.kinematic);
                            ImuBase {
                                window: Rc::new(window),
                                orientation_from,
                                lin_world_mps2,
                                raw,
                            }
                        });
                    // The camera's whole grid shares the base's window; a suffix copies its part.
                    let win = if grid_from == 0 {
                        Rc::clone(&base.window)
                    } else {
                        Rc::new(base.window.tail(grid_from))
                    };
                    let orientation_from = base.orientation_from.get(grid_from..).unwrap_or(&[]);
                    // The orientation's per-sample terms, computed at their first read.
                    let orientations = imu.world_from_sensor.as_slices().0;
                    let terms = |of: &OrientationTerms| -> Vec<[f64; 3]> {
                        orientation_from
                            .iter()
                            .map(|k| k.and_then(|k| of.get(k, orientations)))
                            .map(|v| v.unwrap_or([f64::NAN; 3]))
                            .collect()
                    };
                    let features = ImuFeatures::from_parts_anchored(
                        &win,
                        base.lin_world_mps2.get(grid_from..).unwrap_or(&[]),
                        &terms(&imu.axis_elevation_rad),
                        Some((&base.raw, grid_from)),
                        &geometric,
                        &self.config.kinematic,
                        anchor,
                    );
                    let win = if anchor == 0 {
                        win
                    } else {
                        Rc::new(win.tail(anchor))
                    };
                    let band = imu.wants_band_pitch.then(|| {
                        let pitches = terms(&imu.axis_pitch_rad);
                        let yaw_rate = RawSignals::vertical_rate_of(
                            Some((&base.raw, grid_from + anchor)),
                            &win,
                        );
                        BandSignals::from_parts(
                            &win,
                            pitches.get(anchor..).unwrap_or(&[]),
                            yaw_rate,
                            &belmonte,
                        )
                    });
                    Box::new(ImuGridFeatures {
                        window: win,
                        units: features.units(),
                        features,
                        band,
                    })
                };
                let hypotheses: &[i64] = if imu.is_offset_known {
                    &[]
                } else {
                    &imu.lag_hypotheses
                };
                let pair_offset = imu.pair_offsets.get(key).copied();
                if !imu.is_offset_known && pair_offset.is_none() && hypotheses.is_empty() {
                    continue;
                }
                // The segment's features at each site the IMU may be on: its own, and the
                // mirror image for an IMU registered with `either_side`.
                let mut seg_ids: [Option<usize>; 2] = [None, None];
                let (own_site, mirror_site) = imu.sides();
                let sites = std::iter::once(own_site).chain(mirror_site);
                for (slot, site) in seg_ids.iter_mut().zip(sites) {
                    *slot = Some(match segments.iter().position(|(j, _, _)| *j == site) {
                        Some(k) => k,
                        None => {
                            let turn = turn_rate
                                .get_or_insert_with(|| {
                                    let yaw = unsmoothed_yaw.get_or_insert_with(yaw_of_padded);
                                    body_turn_rate_from(
                                        &padded,
                                        yaw.clone(),
                                        &self.config.kinematic,
                                    )
                                })
                                .clone();
                            let features = SegmentFeatures::with_turn_rate_anchored(
                                &padded,
                                site,
                                &geometric,
                                &self.config.kinematic,
                                turn,
                                anchor,
                                (run_edge_samples, grid_from == 0),
                            );
                            let units = features.units();
                            segments.push((site, features, units));
                            segments.len() - 1
                        }
                    });
                }
                let seg_ids = seg_ids.into_iter().flatten();
                // The scores at the chosen hypothesis and site, already computed.
                let mut chosen: Option<(usize, PairScores)> = None;
                let offset = match (imu.is_offset_known, pair_offset) {
                    (true, _) => imu.offset_ns,
                    (false, Some(o)) => o,
                    // A track too short for the search: the lag hypothesis that fits it best.
                    (false, None) => {
                        let mut best: Option<(f64, i64, usize, PairScores)> = None;
                        for &o in hypotheses {
                            let imu_o = imu_cache
                                .entry((i, o, grid_index))
                                .or_insert_with(|| build(o));
                            for sid in seg_ids.clone() {
                                let Some((_, seg_features, seg_units)) = segments.get(sid) else {
                                    continue;
                                };
                                let (scores, k) = compare_prepared(
                                    &imu_o.features,
                                    &imu_o.units,
                                    seg_features,
                                    seg_units,
                                    &geometric,
                                );
                                if let Some(fit) =
                                    weighted_fit(&scores, &k, &self.config.model_weights)
                                    && best.as_ref().is_none_or(|(b, ..)| fit > *b)
                                {
                                    best = Some((fit, o, sid, (scores, k)));
                                }
                            }
                        }
                        match best {
                            Some((_, o, sid, pair)) => {
                                chosen = Some((sid, pair));
                                o
                            }
                            None => continue,
                        }
                    }
                };
                let cached = imu_cache
                    .entry((i, offset, grid_index))
                    .or_insert_with(|| build(offset));
                let (imu_win, imu_features) = (&cached.window, &cached.features);
                let (segment, (mut scores, k)) = match chosen {
                    Some(c) => c,
                    None => {
                        // The site that fits better (the IMU's own on a tie, or if neither
                        // has a fit).
                        let mut best: Option<(Option<f64>, usize, PairScores)> = None;
                        let mut fits = [None; 2];
                        for (sid, fit_out) in seg_ids.zip(&mut fits) {
                            let Some((_, seg_features, seg_units)) = segments.get(sid) else {
                                continue;
                            };
                            let pair = compare_prepared(
                                imu_features,
                                &cached.units,
                                seg_features,
                                seg_units,
                                &geometric,
                            );
                            let fit = weighted_fit(&pair.0, &pair.1, &self.config.model_weights);
                            *fit_out = fit;
                            let is_better = best.as_ref().is_none_or(|(b, ..)| match (fit, b) {
                                (Some(f), Some(b)) => f > *b,
                                (Some(_), None) => true,
                                (None, _) => false,
                            });
                            if is_better {
                                best = Some((fit, sid, pair));
                            }
                        }
                        // A vote on the side, where the IMU's clock and the track's name are
                        // both settled.
                        if let [Some(own), Some(mirror)] = fits
                            && imu.is_offset_known
                            && tr.label == Some(imu.subject)
                        {
                            side_updates.push((i, own - mirror));
                        }
                        match best {
                            Some((_, sid, pair)) => (sid, pair),
                            None => continue,
                        }
                    }
                };
                let Some((site, seg_features, seg_units)) = segments.get(segment) else {
                    continue;
                };
                let site = *site;
                // The heading model: only at a known offset, where the window's cross sum
                // is that of the IMU's own clock (a pair scored at its own best lag would
                // mix a lag error into the heading).
                let cross = (wants_heading && imu.is_offset_known)
                    .then(|| {
                        horizontal_cross_prepared(
                            imu_features,
                            &cached.units,
                            seg_features,
                            seg_units,
                            geometric.min_samples,
                        )
                    })
                    .flatten()
                    .filter(|c| c.norm() > 0.0);
                let heading_score = cross.and_then(|c| {
                    let [re, im] = headings.get(i).copied().flatten()?;
                    c.aligned_correlation(re, im)
                });
                if let Some(c) = cross
                    && tr.label == Some(imu.subject)
                {
                    heading_updates.push((i, [c.re / c.norm(), c.im / c.norm()]));
                }
                if let Some(scorer) = &self.pair_scorer {
                    scores.dl = scorer.score(imu_win, skel, site);
                }
                // An `either_side` band's costs are read at the wrist the correlations chose:
                // left free to pick their own, a wrong person's track would get two more
                // chances. Belmonte-Hernández's method alone keeps its rule,
                // the wrist whose pitch fits better.
                let side = if self.config.motion_score == MotionScore::Belmonte
                    && imu.mirror_site.is_some()
                {
                    Some(Side::Unknown)
                } else {
                    band_side(site)
                };
                if let (Some(band), Some(side)) = (&cached.band, side) {
                    let arm = match arms.iter().position(|(s, _)| *s == side) {
                        Some(k) => k,
                        None => {
                            // The yaw rate is the same for every side: built once.
                            let arm = match arms.first() {
                                Some((_, first)) => first.for_side(skel, side, &belmonte),
                                None if shares_yaw => {
                                    let yaw = unsmoothed_yaw.get_or_insert_with(yaw_of_padded);
                                    ForearmSignals::with_unsmoothed_yaw_rate(
                                        skel,
                                        side,
                                        &belmonte,
                                        yaw.clone(),
                                    )
                                }
                                None => ForearmSignals::new(skel, side, &belmonte),
                            };
                            arms.push((side, arm));
                            arms.len() - 1
                        }
                    };
                    let Some((_, arm)) = arms.get(arm) else {
                        continue;
                    };
                    let costs = belmonte_costs_from(band, arm, side, &belmonte);
                    if let (Some(p), Some(y)) = (costs.pitch_mse, costs.yaw_rate_mse) {
                        let sp = self.config.belmonte_pitch_sigma_rad;
                        let sy = self.config.belmonte_yaw_rate_sigma_radps;
                        let similarity = (-0.5 * (p / (sp * sp) + y / (sy * sy))).exp();
                        let w = match self.config.motion_score {
                            MotionScore::Belmonte => 1.0,
                            _ => self.config.model_weights.belmonte,
                        };
                        let cell = nomen_sums.entry((row, imu.subject)).or_insert((0.0, 0.0));
                        cell.0 += w * similarity;
                        cell.1 += w;
                    }
                }
                if self.config.motion_score == MotionScore::Nomen {
                    let cell = nomen_sums.entry((row, imu.subject)).or_insert((0.0, 0.0));
                    let w = &self.config.model_weights;
                    let weighted = motion_terms(&scores, &k, w)
                        .into_iter()
                        .chain([(scores.dl, w.dl), (heading_score, w.heading)]);
                    for (v, w) in weighted {
                        if let Some(v) = v {
                            cell.0 += w * v;
                            cell.1 += w;
                        }
                    }
                }
                let models = [scores.acc, scores.vel, scores.ori];
                let (sum, n) = models
                    .iter()
                    .flatten()
                    .fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
                if n > 0 {
                    device_scores.push((*key, i, sum / n as f64));
                }
                // The indices are in range by construction; a failure only drops a score.
                if let Some(tensor) = tensor.as_mut() {
                    let _ = tensor.set(row, imu.subject, imu.site, scores);
                }
            }
        }
        CameraScores {
            tensor,
            device_scores,
            nomen_sums,
        }
    }

    /// How much an IMU's heading sums keep over one hop (`heading_half_life_s`).
    pub(super) fn heading_decay_per_hop(&self) -> f64 {
        0.5f64.powf(self.config.hop_s / self.config.heading_half_life_s)
    }

    /// Multiplies every IMU's heading sums by `factor`.
    pub(super) fn decay_headings(&mut self, factor: f64) {
        for imu in &mut self.imus {
            imu.heading_sum = imu.heading_sum.map(|v| v * factor);
            imu.heading_magnitude *= factor;
            imu.heading_windows *= factor;
        }
    }

    /// Decays every IMU's heading sums by one hop, adds this window's normalised cross sums
    /// `(IMU, (re, im))`, and reports the headings that are coherent.
    pub(super) fn update_headings(&mut self, updates: Vec<(usize, [f64; 2])>) {
        self.decay_headings(self.heading_decay_per_hop());
        for (i, [re, im]) in updates {
            if let Some(imu) = self.imus.get_mut(i) {
                imu.heading_sum[0] += re;
                imu.heading_sum[1] += im;
                imu.heading_magnitude += re.hypot(im);
                imu.heading_windows += 1.0;
            }
        }
        for imu in &self.imus {
            if let Some([re, im]) = imu.heading(&self.config) {
                let magnitude = imu.heading_sum[0].hypot(imu.heading_sum[1]);
                self.stats.imu_headings.insert(
                    imu.device.clone(),
                    HeadingEstimate {
                        // The cross sums' phase turns room vectors into the IMU's frame.
                        room_from_imu_yaw_rad: (-im).atan2(re),
                        coherence: magnitude / imu.heading_magnitude,
                    },
                );
            }
        }
    }
}

/// What [`Engine::score_window`] shares between its cameras: the window, the IMU features built
/// so far per (IMU, offset, grid), and the heading updates collected.
struct WindowScoring {
    start: i64,
    end: i64,
    /// How far before `start` the filtered signals start (`EngineConfig::history_pad_s`).
    pad_ns: i64,
    /// Shortest span of the window a track must cover to be scored.
    min_span: i64,
    /// The IMUs' sites, sorted, once each: the tensor's columns per subject.
    sites: Vec<Joint>,
    wants_heading: bool,
    /// Each IMU's heading where its estimate is coherent enough.
    headings: Vec<Option<[f64; 2]>>,
    /// Camera grids seen so far in this window (an index into it keys `imu_cache`).
    grids: Vec<Vec<i64>>,
    /// An IMU's window and features per (IMU, offset, grid): cameras that share frame times
    /// (hardware-synchronised rigs) share them too.
    imu_cache: ImuFeatureCache,
    /// An IMU resampled onto a camera's whole grid per (IMU, offset, grid index), which the
    /// grids of tracks first seen inside the window (suffixes of it) slice.
    imu_bases: BTreeMap<(usize, i64, usize), ImuBase>,
    /// This window's normalised cross sums `(IMU, (re, im))` against the tracks labelled with
    /// the IMU's wearer.
    heading_updates: Vec<(usize, [f64; 2])>,
    /// Votes on the side of `either_side` IMUs: (IMU, fit at its site less fit at the mirror),
    /// one per pair compared at both sites at the IMU's accepted offset on a track named after
    /// its wearer.
    side_updates: Vec<(usize, f64)>,
}

/// An IMU resampled onto a camera's grid of one window at one offset
/// ([`imu_window_on_grid`]), with its low-passed world linear acceleration.
struct ImuBase {
    window: Rc<ImuWindow>,
    /// Per grid point, the IMU sample whose orientation it took.
    orientation_from: Vec<Option<usize>>,
    lin_world_mps2: Vec<Vector3<f64>>,
    /// The swing angles and vertical rates on the whole grid, which its suffixes share.
    raw: RawSignals,
}

/// How much of a skeleton run's low-passed signals is dropped next to its edges inside the
/// window, s ([`SegmentFeatures::drop_run_edges`]): a track first seen inside the window is
/// compared with the IMU's linear acceleration sliced from the camera's whole grid, which the
/// filter has settled on there while the skeleton's starts, and a track hidden for a while
/// restarts its filter after the gap. The zero-phase 3 Hz low-pass settles within about
/// 0.2 s. With the edges dropped, slicing the IMU's signals from the whole grid is as accurate
/// as filtering them per track; without dropping, slicing costs accuracy.
const RUN_EDGE_S: f64 = 0.2;

/// One camera's pair scores in a window ([`Engine::score_camera_pairs`]).
struct CameraScores {
    /// `None` past [`nomen_evidence::MAX_TENSOR_ENTRIES`].
    tensor: Option<ScoreTensor>,
    /// `(track, IMU, mean of De Marchi's three correlations)`.
    device_scores: Vec<(TrackKey, usize, f64)>,
    /// (row, subject) → (sum, count) of every correlation ([`MotionScore::Nomen`]).
    nomen_sums: BTreeMap<(usize, usize), (f64, f64)>,
}

/// Whether a track has enough of the window `[start, end)` for its motion to be scored: at
/// least `min_samples` settled samples there, spanning at least `min_span` ns.
fn is_scored(tr: &TrackState, start: i64, end: i64, min_samples: usize, min_span: i64) -> bool {
    let (a, b) = sample_range(tr, start, end);
    b >= a + min_samples && covered_span(tr, start, end) >= min_span
}

/// Per track of one camera (`tracks`, the rows) and per subject, the tag-versus-track window
/// score with its weight (see [`crate::tags`]): for each of the subject's tags, the mean of its
/// fixes' similarities to the track, each fix weighted by how well it tells the camera's
/// tracks apart ([`fix_informativeness`]), and the window's weight the mean of those weights;
/// over several tags, the means of both. `None` for a subject without a tag, or a track with
/// fewer than [`MIN_TAG_PAIRS`] fixes paired with it in the window.
///
/// Counts, per tag, the fixes compared with at least one track and those among them near one
/// (similarity at least [`NEAR_SIMILARITY`]) in `near` (a fix is counted in every window and
/// camera it is compared in).
pub(super) fn tag_window_scores(
    tags: &[TagState],
    tracks: &[Option<&TrackState>],
    start: i64,
    end: i64,
    joint_sigma_m: f64,
    num_subjects: usize,
    near: &mut BTreeMap<DeviceId, TagNearCount>,
) -> Vec<Vec<Option<(f64, f64)>>> {
    // Per row and subject: sums of scores and weights over tags, and the number of tags.
    let mut sums = vec![vec![(0.0, 0.0, 0usize); num_subjects]; tracks.len()];
    // Per row, one fix's similarity (`None`: the track has no joint near the fix's time), and
    // per row its weighted sum, weight sum and count of paired fixes over the tag's fixes.
    let mut similarity: Vec<Option<f64>> = vec![None; tracks.len()];
    let mut per_row = vec![(0.0, 0.0, 0usize); tracks.len()];
    for tag in tags {
        per_row.fill((0.0, 0.0, 0));
        for fix in tag.fixes_in(start, end) {
            for (sim, tr) in similarity.iter_mut().zip(tracks) {
                *sim = tr
                    .and_then(|tr| key_joint_or_ancestor(tr, tag.site, fix.t))
                    .map(|(joint, extra_m)| {
                        fix_similarity(fix, &joint, joint_sigma_m.hypot(extra_m))
                    });
            }
            let best = similarity
                .iter()
                .flatten()
                .copied()
                .fold(None, |m: Option<f64>, v| Some(m.map_or(v, |m| m.max(v))));
            if let Some(best) = best {
                let count = near.entry(tag.device.clone()).or_default();
                count.num_compared += 1;
                count.num_near += u64::from(best >= NEAR_SIMILARITY);
            }
            let weight = fix_informativeness(similarity.iter().flatten().copied());
            for (acc, sim) in per_row.iter_mut().zip(&similarity) {
                if let Some(sim) = sim {
                    acc.0 += weight * sim;
                    acc.1 += weight;
                    acc.2 += 1;
                }
            }
        }
        for (row, &(sum, weight, n)) in per_row.iter().enumerate() {
            if n < MIN_TAG_PAIRS {
                continue;
            }
            let score = if weight > 0.0 { sum / weight } else { 0.0 };
            if let Some(cell) = sums.get_mut(row).and_then(|r| r.get_mut(tag.subject)) {
                cell.0 += score;
                cell.1 += weight / n as f64;
                cell.2 += 1;
            }
        }
    }
    sums.into_iter()
        .map(|row| {
            row.into_iter()
                .map(|(score, weight, n)| (n > 0).then(|| (score / n as f64, weight / n as f64)))
                .collect()
        })
        .collect()
}

/// A fix at least this similar to a track's key joint is near it (about 2.5 σ away).
pub(super) const NEAR_SIMILARITY: f64 = 0.05;

/// Fewest fixes paired with a track in a window for a tag score (0.3 s of fixes at 10 Hz).
pub(super) const MIN_TAG_PAIRS: usize = 3;

/// The track's `joint` at the sample nearest to `t`, if within [`MAX_PAIR_DT_NS`].
pub(super) fn key_joint_near(tr: &TrackState, joint: Joint, t: i64) -> Option<Point3<f64>> {
    let i = tr.samples.partition_point(|s| s.t < t);
    let after = tr.samples.get(i);
    let before = i.checked_sub(1).and_then(|k| tr.samples.get(k));
    let nearest = match (before, after) {
        (Some(b), Some(a)) => {
            if t - b.t <= a.t - t {
                b
            } else {
                a
            }
        }
        (Some(b), None) => b,
        (None, Some(a)) => a,
        (None, None) => return None,
    };
    if (nearest.t - t).abs() > MAX_PAIR_DT_NS {
        return None;
    }
    nearest.joints.get(joint).copied()
}

/// The key joint at the track sample nearest to `t`, or, when the camera lost it, its nearest
/// observed ancestor (wrist → elbow → shoulder → chest → pelvis) with the extra uncertainty of
/// [`TAG_CHAIN_SIGMA_M`] per step: a hidden wrist still places the person.
pub(super) fn key_joint_or_ancestor(
    tr: &TrackState,
    joint: Joint,
    t: i64,
) -> Option<(Point3<f64>, f64)> {
    let mut j = Some(joint);
    let mut extra_m = 0.0;
    while let Some(cur) = j {
        if let Some(p) = key_joint_near(tr, cur, t) {
            return Some((p, extra_m));
        }
        extra_m += TAG_CHAIN_SIGMA_M;
        j = cur.parent();
    }
    None
}

/// Extra standard deviation per step up the kinematic chain when a tag's key joint is hidden
/// and an ancestor stands in for it, m (about a forearm's length).
pub(super) const TAG_CHAIN_SIGMA_M: f64 = 0.25;

/// Distance between `a` and `b` across the line of sight from `eye`: the angle between the two
/// rays times the nearer one's range, m.
pub(super) fn lateral_distance_m(eye: &Point3<f64>, a: &Point3<f64>, b: &Point3<f64>) -> f64 {
    let (ra, rb) = (a - eye, b - eye);
    let range = ra.norm().min(rb.norm());
    if range <= 0.0 || !range.is_finite() {
        return (a - b).norm();
    }
    ra.angle(&rb) * range
}

/// An IMU's window on a grid, its features and (for a forearm band) Belmonte's band signals,
/// per (IMU, offset, grid index). Boxed: the value is over a kilobyte, and an insertion into a
/// B-tree node shifts the node's values (inline, they cost about 1 % of the engine's time).
pub(super) type ImuFeatureCache = BTreeMap<(usize, i64, usize), Box<ImuGridFeatures>>;

/// An IMU's window on one grid at one offset, with what every pair reads from it.
pub(super) struct ImuGridFeatures {
    window: Rc<ImuWindow>,
    features: ImuFeatures,
    /// `features` prepared for the correlations with every track.
    units: ImuUnits,
    /// A forearm band's signals (Belmonte-Hernández).
    band: Option<BandSignals>,
}

/// De Marchi's and nomen's correlations of one pair in one window.
pub(super) type PairScores = (nomen_evidence::ModelScores, nomen_evidence::KinematicScores);

/// A pair's motion correlations with their [`crate::ModelWeights`]: De Marchi's three and
/// nomen's five (not the learned scorer's, the heading or Belmonte's similarity).
pub(super) fn motion_terms(
    scores: &nomen_evidence::ModelScores,
    k: &nomen_evidence::KinematicScores,
    w: &crate::ModelWeights,
) -> [(Option<f64>, f64); 8] {
    [
        (scores.acc, w.acc),
        (scores.vel, w.vel),
        (scores.ori, w.ori),
        (k.swing, w.swing),
        (k.vertical_accel, w.vertical_accel),
        (k.vertical_vel, w.vertical_vel),
        (k.inclination, w.inclination),
        (k.turn, w.turn),
    ]
}

/// The weighted mean of [`motion_terms`], or `None` when none could be computed: how well a
/// lag fits a pair, to choose among lag hypotheses.
pub(super) fn weighted_fit(
    scores: &nomen_evidence::ModelScores,
    k: &nomen_evidence::KinematicScores,
    w: &crate::ModelWeights,
) -> Option<f64> {
    let (sum, weight) = motion_terms(scores, k, w)
        .into_iter()
        .filter_map(|(v, w)| Some((w * v?, w)))
        .fold((0.0, 0.0), |(sum, weight), (v, w)| (sum + v, weight + w));
    (weight > 0.0).then(|| sum / weight)
}

/// Which forearm a band at `site` is on, for Belmonte-Hernández's costs; `None` off the
/// forearm. A band at the elbow or hand may be on either.
pub(super) fn band_side(site: Joint) -> Option<Side> {
    match site {
        Joint::LeftWrist => Some(Side::Left),
        Joint::RightWrist => Some(Side::Right),
        Joint::LeftElbow | Joint::RightElbow | Joint::LeftHand | Joint::RightHand => {
            Some(Side::Unknown)
        }
        _ => None,
    }
}
