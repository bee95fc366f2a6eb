//! The streaming engine: ingest, settle, windows, evidence, assignment, output.

use crate::config::{EngineConfig, Fusion, ns};
use crate::error::{EngineError, Result};
use crate::signal::{bin_average, pearson, site_bone, site_signals, smooth};
use crate::stats::EngineStats;
use nalgebra::{Isometry3, Matrix3, Point3, UnitQuaternion, Vector3};
use nomen_assign::{AssignConfig, CostMatrix, Objective, RowDecision, solve};
use nomen_core::skeleton::{JointState, Joints};
use nomen_core::{
    CameraId, DeviceId, DeviceKind, Evidence, IdentifiedSkeleton, Identity, ImuSample, Joint,
    Message, Registry, SessionTime, SkeletonObservation, SubjectId, TrackId,
};
use nomen_filters::kalman::JointKalman;
use nomen_filters::orientation::{Madgwick, level_from_accel};
use std::collections::{BTreeMap, BTreeSet, VecDeque};

/// Step of the coarse clock-offset search, ns (one IMU sample at 100 Hz).
const LAG_STEP_NS: i64 = 10_000_000;

/// Half width of the moving average applied to every magnitude signal on the grid before
/// correlating, samples (3 each side: about 0.23 s at 30 Hz, below the ~1 Hz gait content).
const SMOOTH_HALF_WIDTH: usize = 3;

struct CameraState {
    id: CameraId,
    world_from_camera: Isometry3<f64>,
    newest: Option<i64>,
    frontier: i64,
}

struct ImuState {
    device: DeviceId,
    subject: usize,
    site: Joint,
    /// Received, not yet settled: device time → (accel, gyro).
    pending: BTreeMap<i64, (Vector3<f64>, Vector3<f64>)>,
    /// Settled samples, device time, increasing.
    t: VecDeque<i64>,
    /// |world_from_sensor · accel − g ẑ|, m/s².
    acc_mag: VecDeque<f64>,
    /// |gyro|, rad/s.
    gyro_mag: VecDeque<f64>,
    newest: Option<i64>,
    frontier: i64,
    ahrs: Option<Madgwick>,
    offset_ns: i64,
    is_offset_known: bool,
    last_refine_end: i64,
}

impl ImuState {
    /// The settled samples as slices (complete after [`ImuState::make_contiguous`]).
    fn slices(&self) -> (&[i64], &[f64], &[f64]) {
        (
            self.t.as_slices().0,
            self.acc_mag.as_slices().0,
            self.gyro_mag.as_slices().0,
        )
    }

    fn make_contiguous(&mut self) {
        self.t.make_contiguous();
        self.acc_mag.make_contiguous();
        self.gyro_mag.make_contiguous();
    }

    fn newest_session(&self) -> Option<i64> {
        self.newest.map(|t| t.saturating_add(self.offset_ns))
    }
}

struct TrackSample {
    t: i64,
    joints: Joints<Point3<f64>>,
    velocities: Joints<Vector3<f64>>,
}

/// Exponentially weighted mean of one (track, device) pair's window scores.
#[derive(Clone, Copy)]
struct Accumulator {
    mean: f64,
    weight: f64,
}

struct TrackState {
    camera: usize,
    pending: BTreeMap<i64, Joints<Point3<f64>>>,
    samples: VecDeque<TrackSample>,
    kalman: Vec<Option<JointKalman>>,
    last_t: i64,
    evidence: BTreeMap<usize, Accumulator>,
    label: Option<usize>,
    /// Scores per subject at the last decision (without the hysteresis bonus).
    subject_scores: BTreeMap<usize, f64>,
}

/// The streaming identity engine. See the crate documentation for the pipeline and latency.
pub struct Engine {
    config: EngineConfig,
    window_ns: i64,
    hop_ns: i64,
    reorder_ns: i64,
    silence_ns: i64,
    delay_ns: i64,
    decay_per_hop: f64,
    subjects: Vec<SubjectId>,
    subject_imus: Vec<Vec<usize>>,
    cameras: Vec<CameraState>,
    camera_index: BTreeMap<CameraId, usize>,
    imus: Vec<ImuState>,
    imu_index: BTreeMap<DeviceId, usize>,
    other_devices: BTreeSet<DeviceId>,
    tracks: BTreeMap<(usize, TrackId), TrackState>,
    pending_out: BTreeSet<(i64, usize, TrackId)>,
    next_end: Option<i64>,
    global_max: Option<i64>,
    ready: Vec<Message>,
    stats: EngineStats,
}

impl Engine {
    /// An engine for the subjects, wearables and cameras of `registry`.
    pub fn new(registry: Registry, config: EngineConfig) -> Result<Engine> {
        config.validate()?;
        registry.validate().map_err(EngineError::Registry)?;
        let mut imus = Vec::new();
        let mut imu_index = BTreeMap::new();
        let mut other_devices = BTreeSet::new();
        let mut subject_imus = Vec::new();
        for (s, subject) in registry.subjects.iter().enumerate() {
            let mut mine = Vec::new();
            for w in &subject.wears {
                if w.kind != DeviceKind::Imu {
                    other_devices.insert(w.device.clone());
                    continue;
                }
                imu_index.insert(w.device.clone(), imus.len());
                mine.push(imus.len());
                imus.push(ImuState {
                    device: w.device.clone(),
                    subject: s,
                    site: w.site,
                    pending: BTreeMap::new(),
                    t: VecDeque::new(),
                    acc_mag: VecDeque::new(),
                    gyro_mag: VecDeque::new(),
                    newest: None,
                    frontier: i64::MIN,
                    ahrs: None,
                    offset_ns: w.clock.offset_ns,
                    is_offset_known: false,
                    last_refine_end: i64::MIN,
                });
            }
            subject_imus.push(mine);
        }
        let cameras: Vec<CameraState> = registry
            .cameras
            .iter()
            .map(|c| CameraState {
                id: c.id.clone(),
                world_from_camera: c.world_from_camera.to_isometry(),
                newest: None,
                frontier: i64::MIN,
            })
            .collect();
        let camera_index = cameras
            .iter()
            .enumerate()
            .map(|(i, c)| (c.id.clone(), i))
            .collect();
        Ok(Engine {
            window_ns: ns(config.window_s),
            hop_ns: ns(config.hop_s),
            reorder_ns: ns(config.reorder_window_s),
            silence_ns: ns(config.silence_timeout_s),
            delay_ns: ns(config.decision_delay_s),
            decay_per_hop: 0.5f64.powf(config.hop_s / config.evidence_half_life_s),
            config,
            subjects: registry.subjects.iter().map(|s| s.id.clone()).collect(),
            subject_imus,
            cameras,
            camera_index,
            imus,
            imu_index,
            other_devices,
            tracks: BTreeMap::new(),
            pending_out: BTreeSet::new(),
            next_end: None,
            global_max: None,
            ready: Vec::new(),
            stats: EngineStats::default(),
        })
    }

    /// What the engine has done so far.
    pub fn stats(&self) -> &EngineStats {
        &self.stats
    }

    /// The configuration in use.
    pub fn config(&self) -> &EngineConfig {
        &self.config
    }

    /// Ingests one message. A bad message (invalid numbers, unknown source, duplicate, late) is
    /// rejected with an error and counted; the engine keeps running. Message types the engine
    /// does not use are accepted and ignored.
    pub fn push(&mut self, msg: &Message) -> Result<()> {
        self.stats.num_messages += 1;
        let result = match msg {
            Message::Imu(s) => self.push_imu(s),
            Message::Skeleton(s) => self.push_skeleton(s),
            _ => {
                self.stats.num_ignored += 1;
                Ok(())
            }
        };
        if let Err(e) = &result {
            let r = &mut self.stats.rejected;
            match e {
                EngineError::InvalidMessage { .. } => r.num_invalid += 1,
                EngineError::UnknownDevice { .. } | EngineError::NotAnImu { .. } => {
                    r.num_unknown_device += 1
                }
                EngineError::UnknownCamera { .. } => r.num_unknown_camera += 1,
                EngineError::Duplicate { .. } => r.num_duplicate += 1,
                EngineError::Late { .. } => r.num_late += 1,
                _ => {}
            }
        }
        result
    }

    fn push_imu(&mut self, s: &ImuSample) -> Result<()> {
        let Some(&i) = self.imu_index.get(&s.device) else {
            return Err(if self.other_devices.contains(&s.device) {
                EngineError::NotAnImu {
                    device: s.device.clone(),
                    t: s.t,
                }
            } else {
                EngineError::UnknownDevice {
                    device: s.device.clone(),
                    t: s.t,
                }
            });
        };
        s.validate().map_err(|error| EngineError::InvalidMessage {
            kind: "imu",
            source_id: s.device.to_string(),
            t: s.t,
            error,
        })?;
        let Some(imu) = self.imus.get_mut(i) else {
            return Ok(());
        };
        let t = s.t.as_ns();
        if t < imu.frontier {
            return Err(EngineError::Late {
                kind: "imu",
                source_id: s.device.to_string(),
                t: s.t,
            });
        }
        if imu.pending.contains_key(&t) {
            return Err(EngineError::Duplicate {
                kind: "imu",
                source_id: s.device.to_string(),
                t: s.t,
            });
        }
        imu.pending.insert(t, (s.accel_mps2, s.gyro_radps));
        imu.newest = Some(imu.newest.map_or(t, |n| n.max(t)));
        imu.frontier = imu.frontier.max(t - self.reorder_ns);
        let session = t.saturating_add(imu.offset_ns);
        self.stats.num_imu_samples += 1;
        settle_imu(imu, &self.config);
        self.note_time(session);
        Ok(())
    }

    fn push_skeleton(&mut self, s: &SkeletonObservation) -> Result<()> {
        let Some(&c) = self.camera_index.get(&s.camera) else {
            return Err(EngineError::UnknownCamera {
                camera: s.camera.clone(),
                t: s.t,
            });
        };
        s.validate().map_err(|error| EngineError::InvalidMessage {
            kind: "skeleton",
            source_id: format!("{}/{}", s.camera, s.track),
            t: s.t,
            error,
        })?;
        let Some(cam) = self.cameras.get_mut(c) else {
            return Ok(());
        };
        let t = s.t.as_ns();
        if t < cam.frontier {
            return Err(EngineError::Late {
                kind: "skeleton",
                source_id: s.camera.to_string(),
                t: s.t,
            });
        }
        if self.pending_out.contains(&(t, c, s.track))
            || self
                .tracks
                .get(&(c, s.track))
                .is_some_and(|tr| tr.pending.contains_key(&t))
        {
            return Err(EngineError::Duplicate {
                kind: "skeleton",
                source_id: format!("{}/{}", s.camera, s.track),
                t: s.t,
            });
        }
        let mut world = Joints::new();
        for (j, obs) in s.joints.iter() {
            if obs.state != JointState::Missing {
                world.insert(j, cam.world_from_camera * obs.position_m);
            }
        }
        cam.newest = Some(cam.newest.map_or(t, |n| n.max(t)));
        cam.frontier = cam.frontier.max(t - self.reorder_ns);
        let frontier = cam.frontier;
        let track = self
            .tracks
            .entry((c, s.track))
            .or_insert_with(|| TrackState {
                camera: c,
                pending: BTreeMap::new(),
                samples: VecDeque::new(),
                kalman: Vec::new(),
                last_t: t,
                evidence: BTreeMap::new(),
                label: None,
                subject_scores: BTreeMap::new(),
            });
        track.pending.insert(t, world);
        track.last_t = track.last_t.max(t);
        self.pending_out.insert((t, c, s.track));
        self.stats.num_skeletons += 1;
        let noise = self.config.joint_noise_std_m;
        for tr in self.tracks.values_mut().filter(|tr| tr.camera == c) {
            settle_track(tr, frontier, &self.config, noise);
        }
        self.note_time(t);
        Ok(())
    }

    fn note_time(&mut self, t: i64) {
        self.global_max = Some(self.global_max.map_or(t, |m| m.max(t)));
        if self.next_end.is_none() {
            self.next_end = Some(t.div_euclid(self.hop_ns) * self.hop_ns + self.hop_ns);
        }
    }

    /// Appends the decisions that are final (every window they depend on is processed).
    pub fn poll(&mut self, out: &mut Vec<Message>) {
        while let Some(end) = self.next_end {
            let settle = end + self.reorder_ns;
            let all_settled = self
                .cameras
                .iter()
                .filter_map(|c| c.newest)
                .chain(self.imus.iter().filter_map(ImuState::newest_session))
                .all(|n| n >= settle);
            let timed_out = self
                .global_max
                .is_some_and(|m| m >= settle + self.silence_ns);
            if !(all_settled || timed_out) {
                break;
            }
            if !all_settled {
                self.stats.num_windows_timed_out += 1;
            }
            self.process_window(end);
        }
        out.append(&mut self.ready);
    }

    /// Settles everything, processes every remaining window and emits every remaining decision.
    pub fn finish(&mut self, out: &mut Vec<Message>) {
        let noise = self.config.joint_noise_std_m;
        for imu in &mut self.imus {
            imu.frontier = i64::MAX;
            settle_imu(imu, &self.config);
        }
        for cam in &mut self.cameras {
            cam.frontier = i64::MAX;
        }
        for tr in self.tracks.values_mut() {
            settle_track(tr, i64::MAX, &self.config, noise);
        }
        while let Some(end) = self.next_end {
            let more_data = self.global_max.is_some_and(|m| m >= end - self.hop_ns);
            if self.pending_out.is_empty() && !more_data {
                break;
            }
            self.process_window(end);
        }
        out.append(&mut self.ready);
    }

    fn process_window(&mut self, end: i64) {
        self.next_end = Some(end + self.hop_ns);
        self.stats.num_windows += 1;
        for imu in &mut self.imus {
            imu.make_contiguous();
        }
        self.update_offsets(end);
        self.score_window(end);
        self.decide(end);
        self.emit(end);
        self.forget(end);
    }

    /// Estimates (or refines) each IMU's clock offset by cross-correlating its magnitude
    /// signals with candidate tracks over `offset_estimation_window_s`.
    fn update_offsets(&mut self, end: i64) {
        let max_off = ns(self.config.max_clock_offset_s);
        let span = ns(self.config.offset_estimation_window_s);
        let refine_every = ns(self.config.offset_refine_interval_s);
        let refine_range = ns(self.config.offset_refine_range_s);
        let (lo, hi) = (end - span + max_off, end - max_off);
        for i in 0..self.imus.len() {
            let Some(imu) = self.imus.get(i) else {
                continue;
            };
            let has_span = imu
                .t
                .front()
                .is_some_and(|&f| f + imu.offset_ns <= end - span)
                && imu.t.back().is_some_and(|&b| b + imu.offset_ns >= hi);
            if !has_span {
                continue;
            }
            // Candidate tracks and the lag range.
            let (candidates, center, range): (Vec<(usize, TrackId)>, i64, i64) =
                if imu.is_offset_known {
                    if end - imu.last_refine_end < refine_every {
                        continue;
                    }
                    let assigned: Vec<_> = self
                        .tracks
                        .iter()
                        .filter(|(_, tr)| tr.label == Some(imu.subject))
                        .map(|(k, _)| *k)
                        .collect();
                    (assigned, imu.offset_ns, refine_range)
                } else {
                    (self.tracks.keys().copied().collect(), 0, max_off)
                };
            let mut best: Option<(f64, i64)> = None;
            for key in candidates {
                let Some(tr) = self.tracks.get_mut(&key) else {
                    continue;
                };
                let Some(sig) = track_signals(tr, imu.site, lo, hi, self.config.joint_filter)
                else {
                    continue;
                };
                if sig.t.len() < 3 || sig.t.last().is_some_and(|&l| l - sig.t[0] < (hi - lo) / 2) {
                    continue;
                }
                if let Some(found) = lag_search(imu, &sig, center, range, self.config.fusion)
                    && best.is_none_or(|b| found.0 > b.0)
                {
                    best = Some(found);
                }
            }
            let Some(imu) = self.imus.get_mut(i) else {
                continue;
            };
            imu.last_refine_end = end;
            if let Some((corr, offset)) = best
                && corr >= self.config.offset_min_correlation
            {
                imu.offset_ns = offset;
                imu.is_offset_known = true;
                let entry = self
                    .stats
                    .clock_offsets
                    .entry(imu.device.clone())
                    .or_default();
                entry.offset_ns = offset;
                entry.correlation = corr;
                entry.num_updates += 1;
            }
        }
    }

    /// Scores every (active track, IMU with a known offset) pair on this window and
    /// accumulates the scores.
    fn score_window(&mut self, end: i64) {
        let start = end - self.window_ns;
        let min_span = (self.config.min_window_coverage * self.window_ns as f64) as i64;
        let mut grid_imu = Vec::new();
        let mut grid_gyro = Vec::new();
        let mut scratch = Vec::new();
        for tr in self.tracks.values_mut() {
            let mut by_site: BTreeMap<Joint, Option<Signals>> = BTreeMap::new();
            for (i, imu) in self.imus.iter().enumerate() {
                if !imu.is_offset_known {
                    continue;
                }
                let sig = by_site.entry(imu.site).or_insert_with(|| {
                    track_signals(tr, imu.site, start, end, self.config.joint_filter)
                });
                let Some(sig) = sig.as_ref() else {
                    continue;
                };
                let covers =
                    sig.t.len() >= 8 && sig.t.last().is_some_and(|&l| l - sig.t[0] >= min_span);
                if !covers {
                    continue;
                }
                let (t, acc, gyro) = imu.slices();
                bin_average(t, acc, imu.offset_ns, &sig.t, &mut grid_imu);
                bin_average(t, gyro, imu.offset_ns, &sig.t, &mut grid_gyro);
                let score = correlate(
                    &mut grid_imu,
                    &mut grid_gyro,
                    sig,
                    self.config.fusion,
                    &mut scratch,
                );
                if let Some(s) = score {
                    let acc = tr.evidence.entry(i).or_insert(Accumulator {
                        mean: 0.0,
                        weight: 0.0,
                    });
                    let w = acc.weight * self.decay_per_hop;
                    acc.mean = (acc.mean * w + s) / (w + 1.0);
                    acc.weight = w + 1.0;
                }
            }
        }
    }

    /// Assigns subjects to the active tracks of each camera.
    fn decide(&mut self, end: i64) {
        let active_since = end - self.window_ns - self.delay_ns;
        for c in 0..self.cameras.len() {
            let keys: Vec<(usize, TrackId)> = self
                .tracks
                .iter()
                .filter(|(k, tr)| k.0 == c && tr.last_t >= active_since)
                .map(|(k, _)| *k)
                .collect();
            if keys.is_empty() || self.subjects.is_empty() {
                continue;
            }
            let mut rows = Vec::with_capacity(keys.len());
            for key in &keys {
                let Some(tr) = self.tracks.get_mut(key) else {
                    continue;
                };
                tr.subject_scores.clear();
                let mut row = vec![None; self.subjects.len()];
                for (s, imus) in self.subject_imus.iter().enumerate() {
                    let scores: Vec<f64> = imus
                        .iter()
                        .filter_map(|i| tr.evidence.get(i).map(|a| a.mean))
                        .collect();
                    if scores.is_empty() {
                        continue;
                    }
                    let mean = scores.iter().sum::<f64>() / scores.len() as f64;
                    tr.subject_scores.insert(s, mean);
                    let bonus = if tr.label == Some(s) {
                        self.config.switch_margin
                    } else {
                        0.0
                    };
                    if let Some(cell) = row.get_mut(s) {
                        *cell = Some(mean + bonus);
                    }
                }
                rows.push(row);
            }
            let Ok(matrix) = CostMatrix::from_gated_rows(&rows) else {
                continue;
            };
            let config = AssignConfig {
                objective: Objective::Maximize,
                rejection_threshold: Some(self.config.rejection_threshold),
                ..AssignConfig::default()
            };
            let Ok(assignment) = solve(&matrix, &config) else {
                continue;
            };
            for (key, decision) in keys.iter().zip(&assignment.rows) {
                let Some(tr) = self.tracks.get_mut(key) else {
                    continue;
                };
                let new_label = match decision {
                    RowDecision::Assigned { col, .. } => Some(*col),
                    _ => None,
                };
                if tr.label.is_some() && new_label.is_some() && tr.label != new_label {
                    self.stats.num_label_switches += 1;
                }
                tr.label = new_label;
            }
        }
    }

    /// Emits every observation whose decision window is `end` or earlier.
    fn emit(&mut self, end: i64) {
        let due: Vec<(i64, usize, TrackId)> = self
            .pending_out
            .iter()
            .take_while(|(t, _, _)| t.saturating_add(self.delay_ns) <= end)
            .copied()
            .collect();
        for key in due {
            self.pending_out.remove(&key);
            let (t, c, track) = key;
            let Some(camera) = self.cameras.get(c).map(|cam| cam.id.clone()) else {
                continue;
            };
            let tr = self.tracks.get(&(c, track));
            let (identity, confidence, evidence) = match tr {
                Some(tr) => self.identity_of(tr),
                None => (Identity::Anonymous, 0.0, Vec::new()),
            };
            if identity != Identity::Anonymous {
                self.stats.num_identified += 1;
            }
            self.stats.num_decisions += 1;
            self.ready.push(Message::Identified(IdentifiedSkeleton {
                t: SessionTime::from_ns(t),
                camera,
                track,
                identity,
                confidence,
                evidence,
                joints: Joints::new(),
            }));
        }
    }

    /// The track's current identity, a confidence in `0..=1` and the evidence behind it.
    ///
    /// Confidence: the subject's accumulated score for a labelled track; for an anonymous
    /// track, one minus the best candidate's score (0 without any evidence).
    fn identity_of(&self, tr: &TrackState) -> (Identity, f64, Vec<Evidence>) {
        let best = tr
            .subject_scores
            .iter()
            .max_by(|a, b| a.1.total_cmp(b.1).then(b.0.cmp(a.0)))
            .map(|(s, v)| (*s, *v));
        let (identity, confidence, shown) = match (tr.label, best) {
            (Some(s), _) => {
                let score = tr.subject_scores.get(&s).copied().unwrap_or(0.0);
                let id = self
                    .subjects
                    .get(s)
                    .map_or(Identity::Anonymous, |id| Identity::Subject(id.clone()));
                (id, score.clamp(0.0, 1.0), Some(s))
            }
            (None, Some((s, score))) => {
                (Identity::Anonymous, (1.0 - score).clamp(0.0, 1.0), Some(s))
            }
            (None, None) => (Identity::Anonymous, 0.0, None),
        };
        let evidence = shown
            .and_then(|s| self.subject_imus.get(s))
            .map(|imus| {
                imus.iter()
                    .filter_map(|i| {
                        let acc = tr.evidence.get(i)?;
                        let imu = self.imus.get(*i)?;
                        Some(Evidence {
                            modality: "imu".into(),
                            device: imu.device.clone(),
                            score: acc.mean,
                        })
                    })
                    .collect()
            })
            .unwrap_or_default();
        (identity, confidence, evidence)
    }

    /// Drops samples no later window can use and tracks that went away.
    fn forget(&mut self, end: i64) {
        let keep = ns(self
            .config
            .window_s
            .max(self.config.offset_estimation_window_s))
            + 2 * ns(self.config.max_clock_offset_s)
            + self.hop_ns;
        for imu in &mut self.imus {
            let cut = end - keep - imu.offset_ns;
            while imu.t.front().is_some_and(|&t| t < cut) {
                imu.t.pop_front();
                imu.acc_mag.pop_front();
                imu.gyro_mag.pop_front();
            }
        }
        let timeout = ns(self.config.track_timeout_s);
        for tr in self.tracks.values_mut() {
            while tr.samples.front().is_some_and(|s| s.t < end - keep) {
                tr.samples.pop_front();
            }
        }
        let pending_out = &self.pending_out;
        self.tracks.retain(|k, tr| {
            tr.last_t >= end - timeout.max(keep)
                || !tr.pending.is_empty()
                || pending_out.iter().any(|p| p.1 == k.0 && p.2 == k.1)
        });
    }
}

/// Settles an IMU's pending samples below its frontier: orientation and magnitude signals.
fn settle_imu(imu: &mut ImuState, config: &EngineConfig) {
    while let Some(entry) = imu.pending.first_entry() {
        if *entry.key() >= imu.frontier {
            break;
        }
        let (t, (accel, gyro)) = entry.remove_entry();
        let dt_s = imu.t.back().map_or(0.0, |&last| (t - last) as f64 * 1e-9);
        let q = match imu.ahrs.as_mut() {
            Some(ahrs) if dt_s > 0.0 && dt_s < 1.0 => ahrs.update_imu(&gyro, &accel, dt_s),
            _ => {
                let q = level_from_accel(&accel).unwrap_or(UnitQuaternion::identity());
                imu.ahrs = Madgwick::new(config.madgwick, q).ok();
                q
            }
        };
        let linear = q * accel - Vector3::z() * config.gravity_mps2;
        imu.t.push_back(t);
        imu.acc_mag.push_back(linear.norm());
        imu.gyro_mag.push_back(gyro.norm());
    }
}

/// Settles a track's pending observations below `frontier` through the joint filters.
fn settle_track(tr: &mut TrackState, frontier: i64, config: &EngineConfig, noise_std_m: f64) {
    let r = Matrix3::identity() * noise_std_m * noise_std_m;
    while let Some(entry) = tr.pending.first_entry() {
        if *entry.key() >= frontier {
            break;
        }
        let (t, joints) = entry.remove_entry();
        let mut sample = TrackSample {
            t,
            joints: Joints::new(),
            velocities: Joints::new(),
        };
        match config.joint_filter {
            Some(kf_config) => {
                if tr.kalman.is_empty() {
                    tr.kalman = Joint::ALL
                        .iter()
                        .map(|_| JointKalman::new(kf_config).ok())
                        .collect();
                }
                for (j, kf) in Joint::ALL.iter().zip(tr.kalman.iter_mut()) {
                    let Some(kf) = kf.as_mut() else {
                        continue;
                    };
                    let z = joints.get(*j);
                    let stepped = kf.step(SessionTime::from_ns(t), z.map(|p| (p, &r)));
                    if stepped.is_ok()
                        && z.is_some()
                        && let (Some(p), Some(v)) = (kf.position(), kf.velocity())
                    {
                        sample.joints.insert(*j, p);
                        sample.velocities.insert(*j, v);
                    }
                }
            }
            None => sample.joints = joints,
        }
        tr.samples.push_back(sample);
    }
}

/// A track's site signals on its own timestamps in `[lo, hi)`.
struct Signals {
    t: Vec<i64>,
    acc_mag: Vec<f64>,
    turn_rate: Vec<f64>,
}

fn track_signals(
    tr: &TrackState,
    site: Joint,
    lo: i64,
    hi: i64,
    filter: Option<nomen_filters::kalman::ConstantVelocityConfig>,
) -> Option<Signals> {
    let (from, to) = site_bone(site);
    let a = tr.samples.partition_point(|s| s.t < lo);
    let b = tr.samples.partition_point(|s| s.t < hi);
    if b <= a + 2 {
        return None;
    }
    let window = tr.samples.range(a..b);
    let t: Vec<i64> = window.clone().map(|s| s.t).collect();
    let pos: Vec<Option<Point3<f64>>> = window
        .clone()
        .map(|s| s.joints.get(site).copied())
        .collect();
    let vel: Vec<Option<Vector3<f64>>> = window
        .clone()
        .map(|s| s.velocities.get(site).copied())
        .collect();
    let bone: Vec<Option<Vector3<f64>>> = window
        .map(|s| match (s.joints.get(from), s.joints.get(to)) {
            (Some(p), Some(q)) => Some(q - p),
            _ => None,
        })
        .collect();
    let mut sig = site_signals(&t, &pos, filter.map(|_| vel.as_slice()), &bone);
    let mut scratch = Vec::new();
    smooth(&mut sig.acc_mag, SMOOTH_HALF_WIDTH, &mut scratch);
    smooth(&mut sig.turn_rate, SMOOTH_HALF_WIDTH, &mut scratch);
    Some(Signals {
        t,
        acc_mag: sig.acc_mag,
        turn_rate: sig.turn_rate,
    })
}

/// Smooths the four grid signals and fuses their correlations.
fn correlate(
    imu_acc: &mut [f64],
    imu_gyro: &mut [f64],
    sig: &Signals,
    fusion: Fusion,
    scratch: &mut Vec<f64>,
) -> Option<f64> {
    smooth(imu_acc, SMOOTH_HALF_WIDTH, scratch);
    smooth(imu_gyro, SMOOTH_HALF_WIDTH, scratch);
    fuse(
        pearson(imu_acc, &sig.acc_mag),
        pearson(imu_gyro, &sig.turn_rate),
        fusion,
    )
}

/// Fuses per-model correlations.
fn fuse(acc: Option<f64>, ori: Option<f64>, fusion: Fusion) -> Option<f64> {
    match fusion {
        Fusion::Acc => acc,
        Fusion::Ori => ori,
        Fusion::Mean => match (acc, ori) {
            (Some(a), Some(o)) => Some(0.5 * (a + o)),
            (a, o) => a.or(o),
        },
        Fusion::Max => match (acc, ori) {
            (Some(a), Some(o)) => Some(a.max(o)),
            (a, o) => a.or(o),
        },
    }
}

/// Best (score, offset) over offsets `center ± range` in [`LAG_STEP_NS`] steps, refined by a
/// parabola through the peak and its neighbours.
fn lag_search(
    imu: &ImuState,
    sig: &Signals,
    center: i64,
    range: i64,
    fusion: Fusion,
) -> Option<(f64, i64)> {
    let (t, acc, gyro) = imu.slices();
    let num_steps = range / LAG_STEP_NS;
    let mut grid_acc = Vec::with_capacity(sig.t.len());
    let mut grid_gyro = Vec::with_capacity(sig.t.len());
    let mut scratch = Vec::new();
    let mut curve = Vec::with_capacity((2 * num_steps + 1) as usize);
    for k in -num_steps..=num_steps {
        let offset = center + k * LAG_STEP_NS;
        bin_average(t, acc, offset, &sig.t, &mut grid_acc);
        bin_average(t, gyro, offset, &sig.t, &mut grid_gyro);
        let score = correlate(&mut grid_acc, &mut grid_gyro, sig, fusion, &mut scratch);
        curve.push((offset, score.unwrap_or(f64::NAN)));
    }
    let (k, &(offset, peak)) = curve
        .iter()
        .enumerate()
        .filter(|(_, (_, s))| s.is_finite())
        .max_by(|a, b| a.1.1.total_cmp(&b.1.1).then(b.0.cmp(&a.0)))?;
    let neighbours = (
        k.checked_sub(1).and_then(|i| curve.get(i)),
        curve.get(k + 1),
    );
    let refined = match neighbours {
        (Some(&(_, y0)), Some(&(_, y2))) if y0.is_finite() && y2.is_finite() => {
            let denom = y0 - 2.0 * peak + y2;
            if denom < 0.0 {
                let delta = (0.5 * (y0 - y2) / denom).clamp(-0.5, 0.5);
                offset + (delta * LAG_STEP_NS as f64).round() as i64
            } else {
                offset
            }
        }
        _ => offset,
    };
    Some((peak, refined))
}
