//! Camera re-labelling: settling a camera's observations in time order while undoing id swaps,
//! and stitching a new track to the ended track it continues.

use super::decide::{anchor_path, mean_common_distance};
use super::scoring::lateral_distance_m;
use super::{
    CAMERA_RATE_FRAMES, CameraState, REFERENCE_CAMERA_RATE_HZ, UNINFERRED_CAMERA_NS,
    median_interval_ns, scaled_count,
};
use super::{
    Decided, Engine, GapReturn, STITCH_MIN_GAP_NS, STITCH_VIEW_LOOKBACK_NS, STITCH_VIEW_MIN_FRAMES,
    SWAP_MAX_GAP_NS, SWAP_NOISE_M, SWAP_RETURN_GAP_NS, SWAP_RETURN_WINDOW_NS, SWAP_SPEED_MPS,
    TrackKey, TrackSample, TrackState, average_evidence, joint_centroid, sample_range,
    settle_track, smooth_track,
};
use crate::EngineConfig;
use crate::config::ns;
use nalgebra::Point3;
use nomen_core::{DecisionRule, TrackId};
use nomen_evidence::{BelmonteConfig, GeometricConfig};

impl Engine {
    /// Stitching, once a window's observations are all settled: each track first seen before
    /// `end` and not yet considered (in order of first observation) may continue an ended track
    /// of its camera, whose person the SDK re-labelled after an occlusion or on re-entry; it
    /// then takes over that track's label and evidence, the motion evidence at
    /// `stitch_evidence_weight`. See [`Engine::predecessor`] for the choice. Each such track
    /// also keeps the other camera's view of its person found then, which may name it before
    /// the decisions can compare the two (`TrackState::views`).
    pub(super) fn stitch_new_tracks(&mut self, end: i64) {
        let mut new: Vec<(i64, TrackKey)> = self
            .tracks
            .iter()
            .filter(|(_, tr)| tr.is_stitch_pending)
            .filter_map(|(k, tr)| Some((tr.samples.front()?.t, *k)))
            .filter(|(t, _)| *t < end)
            .collect();
        new.sort_unstable();
        // The view is kept until the decisions compare the two (see `TrackState::views`), only
        // where they pair views at all; stitching through it needs it too.
        let pairs_views = self.config.camera_pair_distance_m > 0.0;
        let wants_view = pairs_views
            || (self.config.stitch_across_cameras && self.config.stitch_max_gap_s > 0.0);
        if new.is_empty() {
            return;
        }
        let last_seen = LastSeen::before(self, end);
        for (t0, key) in new {
            let view = wants_view
                .then(|| self.view_from_other_camera(key, t0, end))
                .flatten();
            let prev = self.predecessor(key, view, &last_seen);
            if let Some(tr) = self.tracks.get_mut(&key) {
                tr.is_stitch_pending = false;
                if let Some(view) = view.filter(|v| pairs_views && !tr.views.contains(v)) {
                    tr.views.push(view);
                }
            }
            let Some(old) = prev.and_then(|p| self.tracks.get_mut(&p)) else {
                continue;
            };
            old.superseded_by = Some(key);
            let mut evidence = old.evidence.clone();
            // Continued, but at a discount: the stitch may have picked the wrong person.
            for acc in evidence.values_mut() {
                acc.weight *= self.config.stitch_evidence_weight;
            }
            let mut tag_evidence = old.tag_evidence.clone();
            for acc in tag_evidence.values_mut() {
                acc.weight *= self.config.stitch_tag_evidence_weight;
            }
            let rssi_evidence = old.rssi_evidence.clone();
            let rssi_pairs = old.rssi_pairs.clone();
            let device_evidence = old.device_evidence.clone();
            let (label, held_back, subject_scores) =
                (old.label, old.held_back, old.subject_scores.clone());
            if let Some(tr) = self.tracks.get_mut(&key) {
                tr.evidence = evidence;
                tr.tag_evidence = tag_evidence;
                tr.rssi_evidence = rssi_evidence;
                tr.rssi_pairs = rssi_pairs;
                tr.device_evidence = device_evidence;
                tr.label = label;
                tr.decision = Decided {
                    rule: DecisionRule::Stitched,
                    end,
                };
                tr.held_back = held_back;
                tr.subject_scores = subject_scores;
            }
            self.stats.num_stitched += 1;
        }
    }

    /// The ended track of its camera that the new track `key` continues, from the observations
    /// `last_seen` holds. Another camera decides first: when one of its tracks follows the new
    /// track's person (`view`, see [`Engine::view_from_other_camera`]), the predecessor is the
    /// ended track that this view followed when it ended, and there is none if the view
    /// followed no ended track (the person was not seen by this camera just before). Without
    /// such a view, the predecessor is the ended track within walking reach
    /// ([`Engine::stitch_candidate`]). On the simulated 8-person scenes, where people hide each
    /// other from one camera while the other still sees them, walking reach alone chose the
    /// wrong person in 4 stitches of 10.
    pub(super) fn predecessor(
        &self,
        key: TrackKey,
        view: Option<TrackKey>,
        last_seen: &LastSeen,
    ) -> Option<TrackKey> {
        if self.config.stitch_max_gap_s <= 0.0 {
            return None;
        }
        let first = self.tracks.get(&key)?.samples.front()?;
        if self.config.stitch_across_cameras
            && let Some(view) = view
        {
            return self.ended_track_followed_by(key, view, first.t, last_seen);
        }
        self.stitch_candidate(key.0, first.t, &joint_centroid(&first.joints)?, last_seen)
    }

    /// The track of another camera that shows the person of the new track `key` (first seen at
    /// `t0`): settled torso positions ([`anchor_path`]) from `t0` to `end` at most
    /// [`EngineConfig::stitch_view_distance_m`](crate::EngineConfig::stitch_view_distance_m) apart
    /// on average over at least `STITCH_VIEW_MIN_FRAMES` common frame times, and every other track
    /// at least twice as far.
    pub(super) fn view_from_other_camera(
        &self,
        key: TrackKey,
        t0: i64,
        end: i64,
    ) -> Option<TrackKey> {
        let limit = self.config.stitch_view_distance_m;
        if limit <= 0.0 || self.cameras.len() < 2 {
            return None;
        }
        let mine = anchor_path(self.tracks.get(&key)?, t0, end);
        let distances = self
            .tracks
            .iter()
            .filter(|(k, _)| k.0 != key.0)
            .filter_map(|(k, tr)| {
                let theirs = anchor_path(tr, t0, end);
                Some((
                    *k,
                    mean_common_distance(&mine, &theirs, STITCH_VIEW_MIN_FRAMES)?,
                ))
            });
        unique_nearest(distances, limit)
    }

    /// The ended track of `key`'s camera (see [`Engine::ended_before`]) that `view`, a track of
    /// another camera, followed over its last `STITCH_VIEW_LOOKBACK_NS`: the torso paths at
    /// most [`EngineConfig::stitch_view_distance_m`](crate::EngineConfig::stitch_view_distance_m)
    /// apart on average, every other ended track at least twice as far.
    pub(super) fn ended_track_followed_by(
        &self,
        key: TrackKey,
        view: TrackKey,
        t0: i64,
        last_seen: &LastSeen,
    ) -> Option<TrackKey> {
        let view = self.tracks.get(&view)?;
        let distances = self
            .ended_before(key.0, t0, last_seen)
            .filter_map(|(k, tr, last)| {
                let lo = last.t - STITCH_VIEW_LOOKBACK_NS;
                let theirs = anchor_path(tr, lo, last.t + 1);
                let mine = anchor_path(view, lo, last.t + 1);
                Some((
                    k,
                    mean_common_distance(&mine, &theirs, STITCH_VIEW_MIN_FRAMES)?,
                ))
            });
        unique_nearest(distances, self.config.stitch_view_distance_m)
    }

    /// The tracks of camera `c` that a track first seen at `t0` may continue, as the
    /// observations `last_seen` holds tell: not continued already, last seen at least
    /// `STITCH_MIN_GAP_NS` and at most `stitch_max_gap_s` before `t0`; with that last sample, in
    /// the order of their ids.
    pub(super) fn ended_before(
        &self,
        c: usize,
        t0: i64,
        last_seen: &LastSeen,
    ) -> impl Iterator<Item = (TrackKey, &TrackState, &TrackSample)> {
        let max_gap = ns(self.config.stitch_max_gap_s);
        let lo = (c, t0.saturating_sub(max_gap), TrackId(0));
        let hi = (c, t0.saturating_sub(STITCH_MIN_GAP_NS), TrackId(u64::MAX));
        let from = last_seen
            .0
            .partition_point(|&(c, t, id, _)| (c, t, id) < lo);
        let to = last_seen
            .0
            .partition_point(|&(c, t, id, _)| (c, t, id) <= hi);
        let mut ids: Vec<(TrackId, usize)> = last_seen
            .0
            .get(from..to)
            .unwrap_or(&[])
            .iter()
            .map(|&(_, _, id, b)| (id, b))
            .collect();
        ids.sort_unstable();
        ids.into_iter().filter_map(move |(id, b)| {
            let tr = self.tracks.get(&(c, id))?;
            let last = tr.samples.get(b)?;
            tr.superseded_by.is_none().then_some(((c, id), tr, last))
        })
    }

    /// The ended track of camera `c` (see [`Engine::ended_before`]) that a new track first
    /// seen at `t` at `anchor` continues by walking reach: where its person was heading
    /// ([`heading_point`]: its last position moved on by its last walking velocity over the
    /// gap) within `stitch_radius_m + stitch_max_speed_mps · gap`. When two are within reach,
    /// the nearer (relative to its reach) must be at most half as far as the other; otherwise
    /// nothing is stitched and evidence starts afresh. Measured from the last positions, a
    /// walker's new track often lies nearer someone standing where the walker was heading than
    /// to the walker's own old track
    /// ([`EngineConfig::stitch_velocity_span_s`](crate::EngineConfig::stitch_velocity_span_s)).
    pub(super) fn stitch_candidate(
        &self,
        c: usize,
        t: i64,
        anchor: &Point3<f64>,
        last_seen: &LastSeen,
    ) -> Option<TrackKey> {
        let relative = self
            .ended_before(c, t, last_seen)
            .filter_map(|(k, tr, last)| {
                let gap = t - last.t;
                let reach = self.config.stitch_radius_m
                    + self.config.stitch_max_speed_mps * gap as f64 * 1e-9;
                let relative =
                    (anchor - heading_point(tr, last, gap, &self.config)?).norm() / reach;
                // Out of reach is no rival either.
                (relative <= 1.0).then_some((k, relative))
            });
        unique_nearest(relative, 1.0)
    }

    /// The track of camera `c` whose person the SDK most likely gave to `track` at `t`: the
    /// observation at `x` (joint centroid) lies farther from `track`'s last settled one than a
    /// person moves in the time between (`SWAP_NOISE_M` + `SWAP_SPEED_MPS` × elapsed), and
    /// within half that jump of another track's last settled observation (which also fits that
    /// track's elapsed time). Both must be at most `SWAP_MAX_GAP_NS` old. Failing that, the same
    /// with every track's person moved on from its last observation by its walking velocity
    /// ([`heading_point`]): people who cross in depth hide each other, and the one who comes out
    /// under the other's id shows up where the other was heading, not where it was last seen.
    ///
    /// Failing that, two returns from occlusion: another track came back from a gap
    /// (`SWAP_RETURN_GAP_NS`) at most `SWAP_RETURN_WINDOW_NS` ago, while `track` was still
    /// unseen, where `track` was last seen, and `x` lies where that track was before its gap.
    /// Each move is measured against how far a person gets in its time; the exchanged moves
    /// must both be within reach and together under half the moves the ids say. That track's
    /// returning observation is returned with it (its time, the anchor before its gap and that
    /// anchor's time): it showed `track`'s person and goes with them.
    pub(super) fn swapped_with(
        &self,
        c: usize,
        track: TrackId,
        t: i64,
        x: &Point3<f64>,
    ) -> Option<(TrackKey, Option<GapReturn>)> {
        let reach_over = |elapsed: i64| SWAP_NOISE_M + SWAP_SPEED_MPS * elapsed as f64 * 1e-9;
        let reach = |tr: &TrackState| {
            let elapsed = t - tr.settled_t;
            (elapsed > 0 && elapsed <= SWAP_MAX_GAP_NS).then_some(reach_over(elapsed))
        };
        let me = self.tracks.get(&(c, track))?;
        let mine = me.settled_anchor_world_m?;
        let jump = (x - mine).norm();
        if jump <= reach(me)? {
            return None;
        }
        let others = || {
            self.tracks
                .range((c, TrackId(0))..)
                .take_while(|(k, _)| k.0 == c)
                .filter(|(k, tr)| k.1 != track && tr.superseded_by.is_none())
        };
        let onto_last = others()
            .filter_map(|(k, tr)| {
                let d = (x - tr.settled_anchor_world_m?).norm();
                (d <= reach(tr)? && d < 0.5 * jump).then_some((*k, d))
            })
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(k, _)| (k, None));
        if onto_last.is_some() {
            return onto_last;
        }
        // Two people crossing in depth hide each other, and the SDK gives the one that comes
        // out the other's id a few frames later: by then the other has walked on from where it
        // was last seen. The same test, with each track's person moved on by its walking
        // velocity over the time since its last observation ([`heading_point`]).
        let heading = |tr: &TrackState| {
            let last = tr.samples.back()?;
            heading_point(tr, last, t - last.t, &self.config)
        };
        if let Some(my_jump) = heading(me).map(|h| (x - h).norm())
            && reach(me).is_some_and(|r| my_jump > r)
        {
            let onto_heading = others()
                .filter_map(|(k, tr)| {
                    let d = (x - heading(tr)?).norm();
                    (d <= reach(tr)? && d < 0.5 * my_jump.min(jump)).then_some((*k, d))
                })
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .map(|(k, _)| (k, None));
            if onto_heading.is_some() {
                return onto_heading;
            }
        }
        // Both people unseen for a while and back under each other's ids: the other track
        // came back just before, where this one was, and this observation lies where the
        // other one was before its gap.
        others()
            .filter_map(|(k, tr)| {
                let (ret_t, before, before_t) = tr.return_from_gap?;
                let since_return = t - ret_t;
                // This track must still have been unseen when the other came back.
                if !(0..=SWAP_RETURN_WINDOW_NS).contains(&since_return)
                    || t - before_t > SWAP_MAX_GAP_NS
                    || me.settled_t >= ret_t
                {
                    return None;
                }
                let returned_at = tr.settled_anchor_world_m?;
                // Each move relative to how far a person gets in its time: as the ids say
                // (this track's jump is already out of reach) and exchanged.
                let kept = jump / reach_over(t - me.settled_t)
                    + (returned_at - before).norm() / reach_over(ret_t - before_t);
                let to_before = (x - before).norm() / reach_over(t - before_t);
                let to_me = (returned_at - mine).norm() / reach_over((ret_t - me.settled_t).max(0));
                let ok = to_before <= 1.0 && to_me <= 1.0 && to_before + to_me < 0.5 * kept;
                ok.then_some((*k, to_before + to_me, (ret_t, before, before_t)))
            })
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(k, _, returned)| (k, Some(returned)))
    }

    /// Settles camera `c`'s observations before `frontier` in time order across its tracks (the
    /// same order whatever order they arrived in), undoing id swaps on the way: before an
    /// observation joins its track, [`Engine::swapped_with`] checks whether it shows the person
    /// of another track, and if so the two tracks exchange their people.
    pub(super) fn settle_camera(&mut self, c: usize, frontier: i64) {
        let noise = self.config.joint_noise_std_m;
        // Every observation due, in (time, track) order. Settling one neither adds nor moves
        // another (an id swap exchanges people, not the observations still pending), so the
        // order is fixed here once, not by a scan of every track per observation.
        let mut due: Vec<(i64, TrackId)> = self
            .tracks
            .range((c, TrackId(0))..)
            .take_while(|(k, _)| k.0 == c)
            .flat_map(|(k, tr)| tr.pending.range(..frontier).map(move |(&t, _)| (t, k.1)))
            .collect();
        due.sort_unstable();
        if let Some(cam) = self.cameras.get_mut(c) {
            note_frame_times(cam, due.iter().map(|&(t, _)| t));
        }
        for (t, id) in due {
            let Some(frame) = self.tracks.get(&(c, id)).and_then(|tr| tr.pending.get(&t)) else {
                continue;
            };
            if let Some(cam) = self.cameras.get_mut(c) {
                cam.reports_inferred |= !frame.inferred.is_empty();
                let first = *cam.first_settled_ns.get_or_insert(t);
                cam.is_uninferred =
                    !cam.reports_inferred && t.saturating_sub(first) >= UNINFERRED_CAMERA_NS;
            }
            let anchor = joint_centroid(&frame.joints_world_m);
            if let Some(x) = anchor
                && let Some((other, returned)) = self.swapped_with(c, id, t, &x)
                && let Some(mut mine) = self.tracks.remove(&(c, id))
            {
                if let Some(theirs) = self.tracks.get_mut(&other) {
                    exchange_people(&mut mine, theirs);
                    // The other track came back from a gap with this track's person: its
                    // observations since (up to this very time, when it settled first) go
                    // with the person, and each track's newest settled observation is its
                    // person's. The person's history ended before that return, so both stay in
                    // time order.
                    let mut swapped_at = t;
                    if let Some((ret_t, before, before_t)) = returned {
                        let since_return = mine.samples.partition_point(|s| s.t < ret_t);
                        for sample in mine.samples.drain(since_return..) {
                            if theirs
                                .samples
                                .back()
                                .is_none_or(|newest| newest.t < sample.t)
                            {
                                theirs.samples.push_back(sample);
                            }
                        }
                        theirs.settled_t = mine.settled_t;
                        theirs.settled_anchor_world_m = mine.settled_anchor_world_m;
                        mine.settled_t = before_t;
                        mine.settled_anchor_world_m = Some(before);
                        swapped_at = ret_t;
                    }
                    mine.return_from_gap = None;
                    theirs.return_from_gap = None;
                    // Lags found against a track's history go with that history.
                    for imu in &mut self.imus {
                        let a = imu.pair_offsets.remove(&(c, id));
                        let b = imu.pair_offsets.remove(&other);
                        if let Some(o) = a {
                            imu.pair_offsets.insert(other, o);
                        }
                        if let Some(o) = b {
                            imu.pair_offsets.insert((c, id), o);
                        }
                    }
                    // Links to either track name its person: they follow the person.
                    for tr in self.tracks.values_mut() {
                        for link in tr.superseded_by.iter_mut().chain(tr.views.iter_mut()) {
                            if *link == (c, id) {
                                *link = other;
                            } else if *link == other {
                                *link = (c, id);
                            }
                        }
                    }
                    // Both at one time, or the walk in `person_track` would bounce back. This
                    // track had no frame between the other's return and now.
                    self.swaps
                        .entry((c, id))
                        .or_default()
                        .push((swapped_at, other.1));
                    self.swaps.entry(other).or_default().push((swapped_at, id));
                    self.stats.num_swaps += 1;
                }
                self.tracks.insert((c, id), mine);
            }
            if let Some(tr) = self.tracks.get_mut(&(c, id)) {
                // Taken for ended and continued by a new track, yet seen again: it had only
                // been hidden, and it takes part in decisions again (otherwise it would keep
                // whatever label it had, or none, to its end). The new track keeps what it
                // inherited; its own evidence decides from then on.
                if tr.superseded_by.is_some() {
                    tr.superseded_by = None;
                    self.stats.num_stitches_undone += 1;
                }
                self.stats.num_frames_behind_history +=
                    settle_track(tr, t + 1, &self.config, noise);
                if let Some(x) = anchor {
                    tr.return_from_gap = match tr.settled_anchor_world_m {
                        Some(before) if t - tr.settled_t >= SWAP_RETURN_GAP_NS => {
                            Some((t, before, tr.settled_t))
                        }
                        _ => tr.return_from_gap,
                    };
                    tr.settled_t = t;
                    tr.settled_anchor_world_m = Some(x);
                }
            }
        }
        let bridge_s = if self.cameras.get(c).is_some_and(|cam| cam.is_uninferred) {
            self.config.joint_gap_bridge_s
        } else {
            self.config.joint_gap_bridge_inferred_s
        };
        let bridge_ns = (bridge_s * 1e9) as i64;
        for (_, tr) in self
            .tracks
            .range_mut((c, TrackId(0))..)
            .take_while(|(k, _)| k.0 == c)
            .filter(|(_, tr)| tr.is_smoothing_due)
        {
            smooth_track(tr, bridge_ns);
        }
    }

    /// Camera `c`'s rate over the 30 Hz that sample counts are set for (1 until it is known;
    /// see [`super::REFERENCE_CAMERA_RATE_HZ`]).
    pub(super) fn camera_scale(&self, c: usize) -> f64 {
        self.cameras
            .get(c)
            .and_then(|cam| cam.rate_scale)
            .unwrap_or(1.0)
    }

    /// The geometric models' config for camera `c`'s windows: `min_samples` and
    /// `moving_average_len` scaled to its rate ([`Engine::camera_scale`]), so that they span
    /// the same time as at 30 Hz.
    pub(super) fn camera_geometric(&self, c: usize) -> GeometricConfig {
        let scale = self.camera_scale(c);
        let g = &self.config.geometric;
        GeometricConfig {
            min_samples: scaled_count(g.min_samples, scale),
            moving_average_len: scaled_count(g.moving_average_len, scale),
            ..*g
        }
    }

    /// Belmonte-Hernández's config for camera `c`'s windows, scaled as
    /// [`Engine::camera_geometric`].
    pub(super) fn camera_belmonte(&self, c: usize) -> BelmonteConfig {
        let scale = self.camera_scale(c);
        let b = &self.config.belmonte;
        BelmonteConfig {
            min_samples: scaled_count(b.min_samples, scale),
            moving_average_len: scaled_count(b.moving_average_len, scale),
            ..*b
        }
    }

    /// The track that now follows the person camera `c` showed as `track` at `t`: undone swaps
    /// after `t` moved that person's state to another track, perhaps more than once.
    pub(super) fn person_track(&self, c: usize, track: TrackId, t: i64) -> TrackId {
        let (mut track, mut since) = (track, t);
        // Each step moves strictly later in time, so the walk ends.
        while let Some(&(at, other)) = self
            .swaps
            .get(&(c, track))
            .and_then(|events| events.iter().find(|(at, _)| *at > since))
        {
            (track, since) = (other, at);
        }
        track
    }

    /// Close encounters. SDKs swap the ids of two people who pass close across the line of
    /// sight, so after such an encounter the engine no longer knows which track is which: when
    /// two tracks of a camera that were within `encounter_distance_m` of each other (measured
    /// across the line of sight, at the nearer one's depth) separate again, both get the
    /// average of their motion evidence, and new windows decide who is who. Location-tag
    /// evidence is not pooled: its short window and half-life re-decide within a second.
    pub(super) fn note_encounters(
        &mut self,
        c: usize,
        track: TrackId,
        t: i64,
        anchor: &Point3<f64>,
    ) {
        let near_m = self.config.encounter_distance_m;
        if near_m <= 0.0 {
            return;
        }
        let Some(eye) = self
            .cameras
            .get(c)
            .map(|cam| Point3::from(cam.world_from_camera.translation.vector))
        else {
            return;
        };
        let mut separated = Vec::new();
        for (key, tr) in self.tracks.range((c, TrackId(0))..) {
            if key.0 != c || key.1 == track || tr.superseded_by.is_some() {
                continue;
            }
            let pair = (c, key.1.min(track), key.1.max(track));
            let is_close_now = self.close_pairs.contains(&pair);
            // Only simultaneous observations (within two frames at 30 Hz) are compared.
            let Some(other) = tr
                .last_anchor_world_m
                .filter(|_| (t - tr.last_t).abs() <= 70_000_000)
            else {
                continue;
            };
            let d = lateral_distance_m(&eye, anchor, &other);
            if d < near_m && !is_close_now {
                self.close_pairs.insert(pair);
            } else if d > 1.5 * near_m && is_close_now {
                self.close_pairs.remove(&pair);
                separated.push(*key);
            }
        }
        for other in separated {
            self.stats.num_encounters += 1;
            let (Some(a), Some(b)) = (
                self.tracks
                    .get(&(c, track))
                    .map(|tr| (tr.evidence.clone(), tr.device_evidence.clone())),
                self.tracks
                    .get(&other)
                    .map(|tr| (tr.evidence.clone(), tr.device_evidence.clone())),
            ) else {
                continue;
            };
            let evidence = average_evidence(&a.0, &b.0);
            let device = average_evidence(&a.1, &b.1);

            for key in [(c, track), other] {
                if let Some(tr) = self.tracks.get_mut(&key) {
                    tr.evidence = evidence.clone();
                    tr.device_evidence = device.clone();
                }
            }
        }
        // Pairs whose tracks are gone are forgotten.
        let tracks = &self.tracks;
        self.close_pairs
            .retain(|(c, a, b)| tracks.contains_key(&(*c, *a)) && tracks.contains_key(&(*c, *b)));
    }
}

/// Exchanges the people two tracks follow after an id swap: everything that describes the
/// person (settled joint history and filters, evidence, label, newest settled observation,
/// whether it is new to the camera and may still continue an ended track) moves, while what
/// belongs to the id stays (observations not settled yet, arrival times, whether a later track
/// continued it).
pub(super) fn exchange_people(a: &mut TrackState, b: &mut TrackState) {
    std::mem::swap(&mut a.samples, &mut b.samples);
    std::mem::swap(&mut a.kalman, &mut b.kalman);
    std::mem::swap(&mut a.is_smoothing_due, &mut b.is_smoothing_due);
    std::mem::swap(&mut a.evidence, &mut b.evidence);
    std::mem::swap(&mut a.tag_evidence, &mut b.tag_evidence);
    std::mem::swap(&mut a.rssi_evidence, &mut b.rssi_evidence);
    std::mem::swap(&mut a.rssi_pairs, &mut b.rssi_pairs);
    std::mem::swap(&mut a.device_evidence, &mut b.device_evidence);
    std::mem::swap(&mut a.label, &mut b.label);
    std::mem::swap(&mut a.confirmed_tag_name, &mut b.confirmed_tag_name);
    std::mem::swap(&mut a.subject_scores, &mut b.subject_scores);
    std::mem::swap(&mut a.settled_t, &mut b.settled_t);
    std::mem::swap(&mut a.settled_anchor_world_m, &mut b.settled_anchor_world_m);
    std::mem::swap(&mut a.is_stitch_pending, &mut b.is_stitch_pending);
    std::mem::swap(&mut a.warm_labels, &mut b.warm_labels);
    std::mem::swap(&mut a.views, &mut b.views);
}

/// Notes a camera's settled frame times, in increasing order, until
/// [`CAMERA_RATE_FRAMES`] distinct ones fix its rate from their median interval.
fn note_frame_times(cam: &mut CameraState, times: impl Iterator<Item = i64>) {
    if cam.rate_scale.is_some() {
        return;
    }
    for t in times {
        if cam.first_frame_times.last().is_some_and(|&last| t <= last) {
            continue;
        }
        cam.first_frame_times.push(t);
        if cam.first_frame_times.len() >= CAMERA_RATE_FRAMES {
            cam.rate_scale = median_interval_ns(&cam.first_frame_times)
                .filter(|&dt_ns| dt_ns > 0.0)
                .map(|dt_ns| 1e9 / dt_ns / REFERENCE_CAMERA_RATE_HZ);
            cam.first_frame_times = Vec::new();
            return;
        }
    }
}

/// Every track's newest settled observation before a time, as `(camera, its time, track,
/// index in the track's samples)`, sorted: the tracks a new one may continue are a range of it
/// ([`Engine::ended_before`]), so stitching many new tracks at once does not scan every track
/// for each. Stitching moves no observation, so it holds for a whole round of stitching.
pub(super) struct LastSeen(Vec<(usize, i64, TrackId, usize)>);

impl LastSeen {
    /// The newest observation of each track of `engine` settled before `end`.
    fn before(engine: &Engine, end: i64) -> Self {
        let mut v: Vec<_> = engine
            .tracks
            .iter()
            .filter_map(|(&(c, id), tr)| {
                let (_, b) = sample_range(tr, i64::MIN, end);
                let b = b.checked_sub(1)?;
                Some((c, tr.samples.get(b)?.t, id, b))
            })
            .collect();
        v.sort_unstable();
        Self(v)
    }
}

/// The key with the smallest value when that value is at most `limit` and every other value is
/// at least twice it.
pub(super) fn unique_nearest(
    values: impl Iterator<Item = (TrackKey, f64)>,
    limit: f64,
) -> Option<TrackKey> {
    let mut best: Option<(TrackKey, f64)> = None;
    let mut second = f64::INFINITY;
    for (key, v) in values {
        match best {
            Some((_, b)) if v >= b => second = second.min(v),
            _ => {
                if let Some((_, b)) = best {
                    second = second.min(b);
                }
                best = Some((key, v));
            }
        }
    }
    let (key, v) = best?;
    (v <= limit && second >= 2.0 * v).then_some(key)
}

/// Where the person of an ended track `tr` would be `gap` ns after its `last` sample, walking on
/// at the horizontal velocity of its joint centroid over the last `stitch_velocity_span_s`
/// (capped at `stitch_max_speed_mps`): where it was last seen if it has no earlier sample in
/// that span. `None` if the last sample has no joints.
fn heading_point(
    tr: &TrackState,
    last: &TrackSample,
    gap: i64,
    config: &EngineConfig,
) -> Option<Point3<f64>> {
    let at_last = joint_centroid(&last.joints)?;
    let from = last.t.saturating_sub(ns(config.stitch_velocity_span_s));
    let earlier = tr
        .samples
        .get(tr.samples.partition_point(|s| s.t < from))
        .filter(|s| s.t < last.t)
        .and_then(|s| Some((s.t, joint_centroid(&s.joints)?)));
    let Some((t0, at_t0)) = earlier else {
        return Some(at_last);
    };
    let mut velocity_mps = (at_last - at_t0) / ((last.t - t0) as f64 * 1e-9);
    velocity_mps.z = 0.0;
    let speed_mps = velocity_mps.norm();
    if speed_mps > config.stitch_max_speed_mps {
        velocity_mps *= config.stitch_max_speed_mps / speed_mps;
    }
    Some(at_last + velocity_mps * (gap as f64 * 1e-9))
}
