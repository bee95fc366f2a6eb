//! The streaming engine: ingest, settle, windows, evidence, assignment, output.

use crate::config::{EngineConfig, MotionScore, OFFSET_CONFIRM_HISTORY, ns};
use crate::error::{EngineError, Result};
use crate::lag_memo::{ImuLagMemo, imu_lag_signals as imu_lag_signals_from};
use crate::signal::{
    ImuSeries, LagSignals, LagWeight, PEAK_DROP, curve_peak, falls_on_both_sides,
    imu_window_on_grid, is_contradicted, lag_curve, mean_curve, rival_value, summed_peak,
};
use crate::stats::{EngineStats, HeadingEstimate};
use crate::tags::{Fix, MAX_PAIR_DT_NS, TagState, corrected_position, fix_sigma_m, fix_similarity};
use nalgebra::{Isometry3, Matrix3, Point3, UnitQuaternion, Vector3};
use nomen_assign::{AssignConfig, CostMatrix, Objective, RowDecision, solve};
use nomen_core::skeleton::{JointState, Joints};
use nomen_core::{
    AntennaId, CameraId, DeviceId, DeviceKind, Evidence, IdentifiedSkeleton, Identity, ImuSample,
    Joint, Message, Registry, RssiRead, RtlsFix, SessionTime, SkeletonObservation, SubjectId,
    TagCorrection, TrackId,
};
use nomen_evidence::{
    BandSignals, ForearmSignals, GeometricConfig, ImuFeatures, ImuWindow, PairScorer, ScoreTensor,
    SegmentFeatures, Side, SkeletonWindow, belmonte_costs_from, body_turn_rate_signal,
    compare_features, fuse, horizontal_cross, segment_site_lag_models,
};
use nomen_filters::kalman::JointKalman;
use nomen_filters::median;
use nomen_filters::orientation::{Madgwick, level_from_accel};
use nomen_rssi::{
    FilterBank, LikelihoodConfig, RssiKalmanConfig, RssiModel, RssiUnit, TagPlacement,
    background_log_likelihood, log_likelihood, pair_score,
};
use std::collections::{BTreeMap, BTreeSet, VecDeque};

/// Step of the clock-offset search, ns (one IMU sample at 100 Hz).
const LAG_STEP_NS: i64 = 10_000_000;

/// Common frame times of two cameras' views of a person: at most this far apart (under half a
/// frame at 30 Hz).
const CAMERA_PAIR_MAX_DT_NS: i64 = 16_000_000;

/// Fewest common frame times over which two cameras' tracks may be found to show the same
/// person (a sixth of a second at 30 Hz), and fewest settled frames for a track to take part
/// at all (as a partner or as a rival that makes a pairing ambiguous). A camera's fresh track
/// after an occlusion is named from the other camera's view of the person as soon as this
/// many frames match: on the 8-person scenes (seeds 1–9, measured when it was lowered), 15
/// frames gave 94.79 % (full network) and 78.10 % (one wrist IMU), 5 gave 95.37 % and 78.17 %
/// (given the true offsets, 97.15 → 97.73 % and 91.48 → 92.66 %; 8 frames and 3 frames were
/// within 0.1 points on the full network).
const CAMERA_PAIR_MIN_FRAMES: usize = 5;

/// How far back two cameras' tracks are compared, in evidence windows: long enough to hold
/// the whole of a short track whose frames are still being decided.
const CAMERA_PAIR_LOOKBACK_WINDOWS: i64 = 2;

/// A track seen this recently before a decision's end may still be in view after it (three
/// frames at 30 Hz).
const ALIVE_AT_END_NS: i64 = 100_000_000;

/// The best-track pass sums its curves on every this-many-th lag of the coarse grid (80 ms):
/// half the work, the same accuracy over the ten imu-table scenes (80.52 against 80.51 %, seeds
/// 1–9; three steps lost 0.4 points). Its accepted offsets are refined to the fine step at once.
const BEST_TRACK_LAG_STEPS: usize = 2;

/// A search for an unknown offset first steps this many [`LAG_STEP_NS`] at a time (40 ms: ten
/// points per 0.4–0.5 s stride period, so the coarse curve still shows every stride peak), then
/// refines around its peak at [`LAG_STEP_NS`].
const COARSE_LAG_STEPS: usize = 4;

/// Longest gap between two IMU samples across which the engine interpolates, ns (a dropout of
/// a few packets at 50–100 Hz; longer gaps are missing data).
const MAX_IMU_GAP_NS: i64 = 60_000_000;

/// The lag search correlates every this-many-th camera sample (15 Hz from 30 Hz): its signals
/// are low-passed at 3 Hz or smoothed over longer spans, so half the samples carry the same
/// curve at half the cost.
const LAG_DECIMATION: usize = 2;

/// The IMU side of the lag search keeps every this-many-th sample (33 Hz from 100 Hz, still
/// above the track's 15 Hz), for the same reason.
const IMU_LAG_DECIMATION: usize = 3;

/// A track observed more than this after the newest sample of a subject's IMUs, while none of
/// them has sent anything for a whole window, loses its motion evidence for that subject, ns.
/// The wearer left or took the bands off: an accumulated score is a mean that only moves when
/// a window scores the pair, so it stayed as it was, and a look-alike who stayed kept the
/// departed wearer's name (a synthetic test: 479 frames of 16 s; the 8-person one-wrist scene,
/// seed 4: Ana's band stopped at 55.7 s and her score on Cleo's track took Cleo's frames from
/// 56.5 to 58.5 s). The slack keeps the wearer's own last frames, decided a window later.
const SILENT_WEARER_SLACK_NS: i64 = 500_000_000;

/// A summed lag curve's peak must stand above every lag farther than this from it, ns (a third
/// of a stride: the neighbouring stride peaks of a walk lie beyond it).
const OFFSET_PEAK_SEPARATION_NS: i64 = 150_000_000;

/// A track that stopped less than this before a new one started is not yet considered ended
/// (three frames at 30 Hz), ns.
const STITCH_MIN_GAP_NS: i64 = 100_000_000;

/// Fewest common frame times over which another camera's track is found to follow a new track's
/// person, or an ended track's (0.1 s at 30 Hz: a new track is considered at the first window
/// end after its first frame, sometimes only a few frames later).
const STITCH_VIEW_MIN_FRAMES: usize = 3;

/// How far back from an ended track's last sample another camera's view of it is compared, ns.
const STITCH_VIEW_LOOKBACK_NS: i64 = 1_000_000_000;

/// Id-swap detection ([`Engine::swapped_with`]): joint-centroid noise between two frames, m
/// (centroids of the simulated 8-person scenes move less than 0.2 m per 33 ms frame 99 % of the
/// time; the observation after an SDK swap jumps 0.36–1.8 m onto the other person). A jump
/// beyond this allowance only counts as a swap when it lands near another track's last
/// observation, so the allowance can sit below the frame-to-frame spread: on the 8-person
/// scenes (seeds 1–9, true offsets) 0.25 m undid 210 swaps, 0.08 m 219 (the extra ones
/// between people a step apart, or after the track was unseen for 0.1–0.5 s), both with no
/// wrong exchange (0.04 m: 219 and one wrong)...
const SWAP_NOISE_M: f64 = 0.08;
/// ... the fastest a person is assumed to move, m/s ...
const SWAP_SPEED_MPS: f64 = 2.0;
/// ... and the longest a track may have been unseen, ns.
const SWAP_MAX_GAP_NS: i64 = 1_000_000_000;

/// A track unseen at least this long that comes back may have come back with someone else's
/// person (three frames at 30 Hz), ns ...
const SWAP_RETURN_GAP_NS: i64 = 100_000_000;
/// ... which the other track's own return shows within this long, ns.
const SWAP_RETURN_WINDOW_NS: i64 = 100_000_000;

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
    /// Specific force, sensor frame, m/s².
    accel: VecDeque<Vector3<f64>>,
    /// Angular rate, sensor frame, rad/s.
    gyro: VecDeque<Vector3<f64>>,
    /// Madgwick's `world_from_sensor` after each sample.
    world_from_sensor: VecDeque<UnitQuaternion<f64>>,
    /// Settled samples forgotten so far: the stream index of `t[0]`.
    num_forgotten: usize,
    /// The lag search's signals kept from one window to the next.
    lag_memo: ImuLagMemo,
    newest: Option<i64>,
    frontier: i64,
    ahrs: Option<Madgwick>,
    /// Device time of the last sample through `ahrs` (`None`: it has just started).
    ahrs_last_ns: Option<i64>,
    offset_ns: i64,
    is_offset_known: bool,
    last_refine_end: i64,
    /// The registry's offset: the prior, restored when an accepted offset is withdrawn.
    registry_offset_ns: i64,
    /// Offset candidates of the latest searches, oldest first (`None`: no clear winner).
    candidates: VecDeque<Option<i64>>,
    /// Winners of the latest searches: `(offset, track, search end)`, oldest first (see
    /// [`EngineConfig::offset_confirm_apart_s`]).
    winners: VecDeque<(i64, TrackKey, i64)>,
    /// An offset the joint search agreed on that awaits its confirmation.
    pending_offset: Option<i64>,
    /// Lag-curve peak per track from the latest search, used before the offset is accepted.
    pair_offsets: BTreeMap<(usize, TrackId), i64>,
    /// This IMU's lag-curve peaks on its subject's best-scoring tracks of the latest search,
    /// best first, at most [`EngineConfig::offset_hypotheses`] of them, no two within
    /// [`EngineConfig::offset_consistency_s`]: before the offset is accepted, a track too short
    /// for the search is scored at whichever of them fits it best.
    lag_hypotheses: Vec<i64>,
    /// Sum and count, per coarse lag, of the lag curves against the tracks labelled with the
    /// wearer (see [`Engine::update_offsets`]).
    label_curve: Vec<(f64, usize)>,
    /// Curves summed into `label_curve`.
    num_label_curves: usize,
    last_label_search_end: i64,
    /// Sum and count, per lag of the best-track grid ([`BEST_TRACK_LAG_STEPS`]), of the best
    /// value over all candidate tracks of this IMU's lag curves, one pass per
    /// `offset_best_track_interval_s` (see [`Engine::update_offsets`]).
    best_track_curve: Vec<(f64, usize)>,
    /// Passes summed into `best_track_curve`.
    num_best_track_curves: usize,
    /// Passes in a row whose best-track sum peaked clearly near the accepted offset.
    num_best_track_agreements: usize,
    /// The accepted offset the best-track sum settled ([`EngineConfig::offset_settle_passes`]):
    /// while the accepted offset stays within [`OFFSET_PEAK_SEPARATION_NS`] of it, the pass
    /// skips the IMU.
    best_track_settled_ns: Option<i64>,
    /// Device time up to which every sample is settled when the current window is processed
    /// (its end on the offset the window waited for); later samples may or may not have
    /// arrived, depending on arrival order, so nothing reads them.
    settled_until_ns: i64,
    /// Decayed sum of the normalised horizontal cross sums (`Σ a·conj(s)/norm`, as `(re, im)`)
    /// of this IMU against the tracks labelled with its wearer: its phase is the rotation of
    /// the room's heading into the IMU's (see [`EngineConfig::heading_half_life_s`]).
    heading_sum: [f64; 2],
    /// Decayed sum of the magnitudes of the terms of `heading_sum`.
    heading_magnitude: f64,
    /// Decayed count of the windows in `heading_sum`.
    heading_windows: f64,
}

impl ImuState {
    /// The phase of the heading sums as a unit complex number `(re, im)`, once they span
    /// [`EngineConfig::heading_min_windows`] windows and agree to
    /// [`EngineConfig::heading_min_coherence`]; `None` before.
    fn heading(&self, config: &EngineConfig) -> Option<[f64; 2]> {
        let [re, im] = self.heading_sum;
        let len = re.hypot(im);
        (self.heading_windows >= config.heading_min_windows
            && len >= config.heading_min_coherence * self.heading_magnitude
            && len > 0.0)
            .then(|| [re / len, im / len])
    }

    /// The settled samples as slices (complete after [`ImuState::make_contiguous`]).
    fn series(&self) -> ImuSeries<'_> {
        ImuSeries {
            t_ns: self.t.as_slices().0,
            accel_mps2: self.accel.as_slices().0,
            gyro_radps: self.gyro.as_slices().0,
            world_from_sensor: self.world_from_sensor.as_slices().0,
        }
    }

    fn make_contiguous(&mut self) {
        self.t.make_contiguous();
        self.accel.make_contiguous();
        self.gyro.make_contiguous();
        self.world_from_sensor.make_contiguous();
    }

    fn pop_front(&mut self) {
        if self.t.pop_front().is_some() {
            self.num_forgotten += 1;
        }
        self.accel.pop_front();
        self.gyro.pop_front();
        self.world_from_sensor.pop_front();
    }

    fn newest_session(&self) -> Option<i64> {
        self.newest.map(|t| t.saturating_add(self.offset_ns))
    }
}

struct TrackSample {
    t: i64,
    joints: Joints<Point3<f64>>,
}

/// Exponentially weighted mean of one pair's window scores.
#[derive(Clone, Copy, Default)]
struct Accumulator {
    mean: f64,
    weight: f64,
}

struct TrackState {
    pending: BTreeMap<i64, Joints<Point3<f64>>>,
    samples: VecDeque<TrackSample>,
    kalman: Vec<Option<JointKalman>>,
    /// Earliest and newest observation times, session ns.
    first_t: i64,
    last_t: i64,
    /// Fused window scores per subject.
    evidence: BTreeMap<usize, Accumulator>,
    /// Location-tag window scores per subject (their own, faster half-life).
    tag_evidence: BTreeMap<usize, Accumulator>,
    /// RSSI scores per subject (tag half-life).
    rssi_evidence: BTreeMap<usize, Accumulator>,
    /// Mean model score per IMU (reported as the evidence behind a label).
    device_evidence: BTreeMap<usize, Accumulator>,
    label: Option<usize>,
    /// A subject whose move from this track to a coexisting one was held back (see
    /// [`Engine::hold_back_unsynced_switches`]): this track still holds it for that rule while
    /// it is anonymous, until its next named decision.
    held_back: Option<usize>,
    /// Scores per subject at the last decision (without the hysteresis bonus).
    subject_scores: BTreeMap<usize, f64>,
    /// Per subject: the score (without the bonus) of the other track of this camera that held
    /// the subject at the latest decision where both took part and their observed spans
    /// overlapped (see [`EngineConfig::exclusion_margin`]); removed once this track holds it.
    outscored_by: BTreeMap<usize, f64>,
    /// Where the person was at the newest observation (mean of the observed joints), world, m.
    last_anchor_world_m: Option<Point3<f64>>,
    /// A later track continues this one (stitched): it no longer takes part in decisions.
    is_superseded: bool,
    /// Whether this track may still be found to continue an ended one: it is new, and its
    /// predecessor is chosen at the first window end after its first observation
    /// ([`Engine::stitch_new_tracks`]).
    is_stitch_pending: bool,
    /// The person's newest settled observation: time (session ns) and joint centroid (world,
    /// m); what id-swap detection compares the next settled observation with.
    settled_t: i64,
    settled_anchor_world_m: Option<Point3<f64>>,
    /// The newest observation that came after the track had been unseen for
    /// `SWAP_RETURN_GAP_NS` or more: `(its time, the settled anchor before the gap, that
    /// anchor's time)`. An id swap can hide in such a return (see [`Engine::swapped_with`]).
    return_from_gap: Option<GapReturn>,
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
    tag_decay_per_hop: f64,
    rssi_decay_per_hop: f64,
    tag_window_ns: i64,
    subjects: Vec<SubjectId>,
    subject_imus: Vec<Vec<usize>>,
    /// Window end of the latest joint offset search.
    last_search_end: i64,
    /// Window end of the latest best-track lag-curve pass.
    last_best_track_end: i64,
    cameras: Vec<CameraState>,
    camera_index: BTreeMap<CameraId, usize>,
    imus: Vec<ImuState>,
    imu_index: BTreeMap<DeviceId, usize>,
    tags: Vec<TagState>,
    tag_index: BTreeMap<DeviceId, usize>,
    /// A learned scorer of (IMU window, skeleton window) pairs ([`Engine::with_pair_scorer`]).
    pair_scorer: Option<Box<dyn PairScorer>>,
    /// RSSI evidence, when a calibrated model was given ([`Engine::with_rssi_model`]).
    rssi: Option<RssiState>,
    /// The registry's antennas.
    antennas: BTreeSet<AntennaId>,
    /// Subject and site of every RFID/BLE tag, for RSSI reads.
    rssi_tags: BTreeMap<DeviceId, (usize, Joint)>,
    /// The kind of every registered device (for clear errors on mismatched messages).
    device_kinds: BTreeMap<DeviceId, DeviceKind>,
    tracks: BTreeMap<(usize, TrackId), TrackState>,
    pending_out: BTreeSet<(i64, usize, TrackId)>,
    next_end: Option<i64>,
    global_max: Option<i64>,
    ready: Vec<Message>,
    stats: EngineStats,
    /// Pairs of tracks of one camera that are in a close encounter now (see
    /// [`Engine::note_encounters`]).
    close_pairs: BTreeSet<(usize, TrackId, TrackId)>,
    /// Undone id swaps per track, oldest first: `(t, other)` says the person this track showed
    /// before session time `t` has been followed on `other` since (see
    /// [`Engine::swapped_with`]); frames still to be emitted are decided for that person.
    swaps: BTreeMap<(usize, TrackId), Vec<(i64, TrackId)>>,
}

impl Engine {
    /// An engine for the subjects, wearables and cameras of `registry`.
    pub fn new(registry: Registry, config: EngineConfig) -> Result<Engine> {
        config.validate()?;
        registry.validate().map_err(EngineError::Registry)?;
        let mut imus = Vec::new();
        let mut imu_index = BTreeMap::new();
        let mut tags = Vec::new();
        let mut tag_index = BTreeMap::new();
        let mut device_kinds = BTreeMap::new();
        let mut rssi_tags = BTreeMap::new();
        let mut subject_imus = Vec::new();
        for (s, subject) in registry.subjects.iter().enumerate() {
            let mut mine = Vec::new();
            for w in &subject.wears {
                device_kinds.insert(w.device.clone(), w.kind);
                if matches!(w.kind, DeviceKind::UwbTag | DeviceKind::BleTag) {
                    tag_index.insert(w.device.clone(), tags.len());
                    tags.push(TagState::new(w.device.clone(), s, w.site));
                }
                if matches!(w.kind, DeviceKind::RfidTag | DeviceKind::BleTag) {
                    rssi_tags.insert(w.device.clone(), (s, w.site));
                }
                if w.kind != DeviceKind::Imu {
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
                    accel: VecDeque::new(),
                    gyro: VecDeque::new(),
                    world_from_sensor: VecDeque::new(),
                    num_forgotten: 0,
                    lag_memo: ImuLagMemo::default(),
                    newest: None,
                    frontier: i64::MIN,
                    ahrs: None,
                    ahrs_last_ns: None,
                    offset_ns: w.clock.offset_ns,
                    is_offset_known: config.known_clock_offsets,
                    last_refine_end: i64::MIN,
                    registry_offset_ns: w.clock.offset_ns,
                    candidates: VecDeque::new(),
                    winners: VecDeque::new(),
                    pending_offset: None,
                    pair_offsets: BTreeMap::new(),
                    lag_hypotheses: Vec::new(),
                    label_curve: Vec::new(),
                    num_label_curves: 0,
                    last_label_search_end: i64::MIN,
                    best_track_curve: Vec::new(),
                    num_best_track_curves: 0,
                    num_best_track_agreements: 0,
                    best_track_settled_ns: None,
                    settled_until_ns: i64::MIN,
                    heading_sum: [0.0; 2],
                    heading_magnitude: 0.0,
                    heading_windows: 0.0,
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
            tag_decay_per_hop: 0.5f64.powf(config.hop_s / config.tag_evidence_half_life_s),
            rssi_decay_per_hop: 0.5f64.powf(config.hop_s / config.rssi_evidence_half_life_s),
            tag_window_ns: ns(config.tag_window_s.min(config.window_s)),
            config,
            subjects: registry.subjects.iter().map(|s| s.id.clone()).collect(),
            subject_imus,
            last_search_end: i64::MIN,
            last_best_track_end: i64::MIN,
            cameras,
            camera_index,
            imus,
            imu_index,
            tags,
            tag_index,
            rssi: None,
            pair_scorer: None,
            antennas: registry.antennas.iter().map(|a| a.id.clone()).collect(),
            rssi_tags,
            device_kinds,
            tracks: BTreeMap::new(),
            pending_out: BTreeSet::new(),
            next_end: None,
            global_max: None,
            ready: Vec::new(),
            stats: EngineStats::default(),
            close_pairs: BTreeSet::new(),
            swaps: BTreeMap::new(),
        })
    }

    /// Adds a learned scorer (e.g. `nomen-cnn`'s) as one more model of every (IMU, track) window:
    /// its score is `ModelScores::dl`, which De Marchi's fusions count as a fourth model and
    /// [`crate::MotionScore::Nomen`] averages with the correlations.
    pub fn with_pair_scorer(mut self, scorer: Box<dyn PairScorer>) -> Engine {
        self.pair_scorer = Some(scorer);
        self
    }

    /// Enables RSSI evidence with a calibrated model (`nomen calibrate rssi`). Without one, RSSI
    /// reads are counted and ignored. Errors when the model does not validate or names an
    /// antenna the registry does not list.
    pub fn with_rssi_model(mut self, model: &RssiModel) -> Result<Engine> {
        model.validate()?;
        for a in &model.antennas {
            if !self.antennas.contains(&a.antenna) {
                return Err(EngineError::InvalidConfig(format!(
                    "the RSSI model has antenna '{}', which the registry does not list",
                    a.antenna
                )));
            }
        }
        self.rssi = Some(RssiState {
            bank: FilterBank::new(model, RssiKalmanConfig::default(), RssiUnit::Dbm)?,
            likelihood: LikelihoodConfig::default(),
            pending: BTreeMap::new(),
            newest: None,
            frontier: i64::MIN,
            estimates: Vec::new(),
        });
        Ok(self)
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
            Message::RtlsFix(f) => self.push_fix(f),
            Message::Rssi(r) => self.push_rssi(r),
            _ => {
                self.stats.num_ignored += 1;
                Ok(())
            }
        };
        if let Err(e) = &result {
            let r = &mut self.stats.rejected;
            match e {
                EngineError::InvalidMessage { .. } => r.num_invalid += 1,
                EngineError::UnknownDevice { .. }
                | EngineError::WrongDeviceKind { .. }
                | EngineError::UnknownAntenna { .. } => r.num_unknown_device += 1,
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
            return Err(self.device_error("imu", &s.device, s.t));
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

    /// The error for a message from `device` that is not of the kind the message needs.
    fn device_error(&self, kind: &'static str, device: &DeviceId, t: SessionTime) -> EngineError {
        match self.device_kinds.get(device) {
            Some(registered) => EngineError::WrongDeviceKind {
                kind,
                device: device.clone(),
                registered: *registered,
                t,
            },
            None => EngineError::UnknownDevice {
                kind,
                device: device.clone(),
                t,
            },
        }
    }

    fn push_fix(&mut self, f: &RtlsFix) -> Result<()> {
        let Some(&i) = self.tag_index.get(&f.tag) else {
            return Err(self.device_error("rtls_fix", &f.tag, f.t));
        };
        f.validate().map_err(|error| EngineError::InvalidMessage {
            kind: "rtls_fix",
            source_id: f.tag.to_string(),
            t: f.t,
            error,
        })?;
        let defaults = (
            self.config.tag_sigma_horizontal_m,
            self.config.tag_sigma_vertical_m,
        );
        let Some(tag) = self.tags.get_mut(i) else {
            return Ok(());
        };
        let t = f.t.as_ns();
        if t < tag.frontier {
            return Err(EngineError::Late {
                kind: "rtls_fix",
                source_id: f.tag.to_string(),
                t: f.t,
            });
        }
        if tag.pending.contains_key(&t) {
            return Err(EngineError::Duplicate {
                kind: "rtls_fix",
                source_id: f.tag.to_string(),
                t: f.t,
            });
        }
        tag.pending.insert(
            t,
            Fix {
                t,
                position_world_m: f.position_m,
                sigma_m: fix_sigma_m(f, defaults),
            },
        );
        tag.newest = Some(tag.newest.map_or(t, |n| n.max(t)));
        tag.frontier = tag.frontier.max(t - self.reorder_ns);
        tag.settle();
        self.stats.num_tag_fixes += 1;
        self.note_time(t);
        Ok(())
    }

    fn push_rssi(&mut self, r: &RssiRead) -> Result<()> {
        if !self.rssi_tags.contains_key(&r.tag) {
            return Err(self.device_error("rssi", &r.tag, r.t));
        }
        if !self.antennas.contains(&r.antenna) {
            return Err(EngineError::UnknownAntenna {
                antenna: r.antenna.clone(),
                t: r.t,
            });
        }
        r.validate().map_err(|error| EngineError::InvalidMessage {
            kind: "rssi",
            source_id: format!("{}@{}", r.tag, r.antenna),
            t: r.t,
            error,
        })?;
        let reorder = self.reorder_ns;
        let Some(rssi) = self.rssi.as_mut() else {
            self.stats.num_rssi_without_model += 1;
            return Ok(());
        };
        let t = r.t.as_ns();
        let key = (t, r.tag.clone(), r.antenna.clone());
        if t < rssi.frontier {
            return Err(EngineError::Late {
                kind: "rssi",
                source_id: format!("{}@{}", r.tag, r.antenna),
                t: r.t,
            });
        }
        if rssi.pending.contains_key(&key) {
            return Err(EngineError::Duplicate {
                kind: "rssi",
                source_id: format!("{}@{}", r.tag, r.antenna),
                t: r.t,
            });
        }
        rssi.pending.insert(key, r.clone());
        rssi.newest = Some(rssi.newest.map_or(t, |n| n.max(t)));
        rssi.frontier = rssi.frontier.max(t - reorder);
        let rejected = rssi.settle();
        self.stats.num_rssi_reads += 1;
        self.note_time(t);
        match rejected {
            Some(e) => Err(e.into()),
            None => Ok(()),
        }
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
        let anchor = joint_centroid(&world);
        // A new track's predecessor, if any, is chosen later (`stitch_new_tracks`).
        let track = self
            .tracks
            .entry((c, s.track))
            .or_insert_with(|| TrackState {
                pending: BTreeMap::new(),
                samples: VecDeque::new(),
                kalman: Vec::new(),
                first_t: t,
                last_t: t,
                evidence: BTreeMap::new(),
                tag_evidence: BTreeMap::new(),
                rssi_evidence: BTreeMap::new(),
                device_evidence: BTreeMap::new(),
                label: None,
                held_back: None,
                subject_scores: BTreeMap::new(),
                outscored_by: BTreeMap::new(),
                last_anchor_world_m: anchor,
                is_superseded: false,
                is_stitch_pending: true,
                settled_t: i64::MIN,
                settled_anchor_world_m: None,
                return_from_gap: None,
            });
        track.pending.insert(t, world);
        track.first_t = track.first_t.min(t);
        if t >= track.last_t {
            track.last_t = t;
            if anchor.is_some() {
                track.last_anchor_world_m = anchor;
            }
        }
        self.pending_out.insert((t, c, s.track));
        if let Some(a) = anchor {
            self.note_encounters(c, s.track, t, &a);
        }
        self.stats.num_skeletons += 1;
        self.settle_camera(c, frontier);
        self.note_time(t);
        Ok(())
    }

    /// Stitching, once a window's observations are all settled: each track first seen before
    /// `end` and not yet considered (in order of first observation) may continue an ended track
    /// of its camera, whose person the SDK re-labelled after an occlusion or on re-entry; it
    /// then takes over that track's label and evidence, the motion evidence at
    /// `stitch_evidence_weight`. See [`Engine::predecessor`] for the choice.
    fn stitch_new_tracks(&mut self, end: i64) {
        let mut new: Vec<(i64, TrackKey)> = self
            .tracks
            .iter()
            .filter(|(_, tr)| tr.is_stitch_pending)
            .filter_map(|(k, tr)| Some((tr.samples.front()?.t, *k)))
            .filter(|(t, _)| *t < end)
            .collect();
        new.sort_unstable();
        for (_, key) in new {
            let prev = self.predecessor(key, end);
            if let Some(tr) = self.tracks.get_mut(&key) {
                tr.is_stitch_pending = false;
            }
            let Some(old) = prev.and_then(|p| self.tracks.get_mut(&p)) else {
                continue;
            };
            old.is_superseded = true;
            let mut evidence = old.evidence.clone();
            // Continued, but at a discount: the stitch may have picked the wrong person.
            for acc in evidence.values_mut() {
                acc.weight *= self.config.stitch_evidence_weight;
            }
            let tag_evidence = old.tag_evidence.clone();
            let rssi_evidence = old.rssi_evidence.clone();
            let device_evidence = old.device_evidence.clone();
            let (label, held_back, subject_scores) =
                (old.label, old.held_back, old.subject_scores.clone());
            if let Some(tr) = self.tracks.get_mut(&key) {
                tr.evidence = evidence;
                tr.tag_evidence = tag_evidence;
                tr.rssi_evidence = rssi_evidence;
                tr.device_evidence = device_evidence;
                tr.label = label;
                tr.held_back = held_back;
                tr.subject_scores = subject_scores;
            }
            self.stats.num_stitched += 1;
        }
    }

    /// The ended track of its camera that the new track `key` continues, from the observations
    /// before `end`. Another camera decides first: when one of its tracks follows the new
    /// track's person ([`Engine::view_from_other_camera`]), the predecessor is the ended track
    /// that this view followed when it ended, and there is none if the view followed no ended
    /// track (the person was not seen by this camera just before). Without such a view, the
    /// predecessor is the ended track within walking reach ([`Engine::stitch_candidate`]). On
    /// the simulated 8-person scenes, where people hide each other from one camera while the
    /// other still sees them, walking reach alone chose the wrong person in 4 stitches of 10.
    fn predecessor(&self, key: TrackKey, end: i64) -> Option<TrackKey> {
        if self.config.stitch_max_gap_s <= 0.0 {
            return None;
        }
        let tr = self.tracks.get(&key)?;
        let first = tr.samples.front()?;
        if self.config.stitch_across_cameras
            && let Some(view) = self.view_from_other_camera(key, first.t, end)
        {
            return self.ended_track_followed_by(key, view, first.t, end);
        }
        self.stitch_candidate(key.0, first.t, &joint_centroid(&first.joints)?, end)
    }

    /// The track of another camera that shows the person of the new track `key` (first seen at
    /// `t0`): settled torso positions ([`anchor_path`]) from `t0` to `end` at most
    /// [`EngineConfig::camera_pair_distance_m`] apart on average over at least
    /// `STITCH_VIEW_MIN_FRAMES` common frame times, and every other track at least twice as far.
    fn view_from_other_camera(&self, key: TrackKey, t0: i64, end: i64) -> Option<TrackKey> {
        let limit = self.config.camera_pair_distance_m;
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
    /// most [`EngineConfig::camera_pair_distance_m`] apart on average, every other ended track
    /// at least twice as far.
    fn ended_track_followed_by(
        &self,
        key: TrackKey,
        view: TrackKey,
        t0: i64,
        end: i64,
    ) -> Option<TrackKey> {
        let view = self.tracks.get(&view)?;
        let distances = self
            .ended_before(key.0, t0, end)
            .filter_map(|(k, tr, last)| {
                let lo = last.t - STITCH_VIEW_LOOKBACK_NS;
                let theirs = anchor_path(tr, lo, last.t + 1);
                let mine = anchor_path(view, lo, last.t + 1);
                Some((
                    k,
                    mean_common_distance(&mine, &theirs, STITCH_VIEW_MIN_FRAMES)?,
                ))
            });
        unique_nearest(distances, self.config.camera_pair_distance_m)
    }

    /// The tracks of camera `c` that a track first seen at `t0` may continue, as the
    /// observations before `end` tell: not continued already, last seen at least
    /// `STITCH_MIN_GAP_NS` and at most `stitch_max_gap_s` before `t0`; with that last sample.
    fn ended_before(
        &self,
        c: usize,
        t0: i64,
        end: i64,
    ) -> impl Iterator<Item = (TrackKey, &TrackState, &TrackSample)> {
        let max_gap = ns(self.config.stitch_max_gap_s);
        self.tracks
            .range((c, TrackId(0))..)
            .take_while(move |(k, _)| k.0 == c)
            .filter(|(_, tr)| !tr.is_superseded)
            .filter_map(move |(k, tr)| {
                let (_, b) = sample_range(tr, i64::MIN, end);
                let last = tr.samples.get(b.checked_sub(1)?)?;
                let gap = t0 - last.t;
                (STITCH_MIN_GAP_NS..=max_gap)
                    .contains(&gap)
                    .then_some((*k, tr, last))
            })
    }

    /// The ended track of camera `c` (see [`Engine::ended_before`]) that a new track first
    /// seen at `t` at `anchor` continues by walking reach: its last position within
    /// `stitch_radius_m + stitch_max_speed_mps · gap`. When two are within reach, the nearer
    /// (relative to its reach) must be at most half as far as the other; otherwise nothing is
    /// stitched and evidence starts afresh.
    fn stitch_candidate(
        &self,
        c: usize,
        t: i64,
        anchor: &Point3<f64>,
        end: i64,
    ) -> Option<TrackKey> {
        let relative = self.ended_before(c, t, end).filter_map(|(k, _, last)| {
            let gap = t - last.t;
            let reach =
                self.config.stitch_radius_m + self.config.stitch_max_speed_mps * gap as f64 * 1e-9;
            let relative = (anchor - joint_centroid(&last.joints)?).norm() / reach;
            // Out of reach is no rival either.
            (relative <= 1.0).then_some((k, relative))
        });
        unique_nearest(relative, 1.0)
    }

    /// The track of camera `c` whose person the SDK most likely gave to `track` at `t`: the
    /// observation at `x` (joint centroid) lies farther from `track`'s last settled one than a
    /// person moves in the time between (`SWAP_NOISE_M` + `SWAP_SPEED_MPS` × elapsed), and
    /// within half that jump of another track's last settled observation (which also fits that
    /// track's elapsed time). Both must be at most `SWAP_MAX_GAP_NS` old.
    ///
    /// Failing that, two returns from occlusion: another track came back from a gap
    /// (`SWAP_RETURN_GAP_NS`) at most `SWAP_RETURN_WINDOW_NS` ago, while `track` was still
    /// unseen, where `track` was last seen, and `x` lies where that track was before its gap.
    /// Each move is measured against how far a person gets in its time; the exchanged moves
    /// must both be within reach and together under half the moves the ids say. That track's
    /// returning observation is returned with it (its time, the anchor before its gap and that
    /// anchor's time): it showed `track`'s person and goes with them.
    fn swapped_with(
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
                .filter(|(k, tr)| k.1 != track && !tr.is_superseded)
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
    fn settle_camera(&mut self, c: usize, frontier: i64) {
        let noise = self.config.joint_noise_std_m;
        loop {
            let next = self
                .tracks
                .range((c, TrackId(0))..)
                .take_while(|(k, _)| k.0 == c)
                .filter_map(|(k, tr)| {
                    let (&t, joints) = tr.pending.first_key_value()?;
                    (t < frontier).then(|| (t, k.1, joint_centroid(joints)))
                })
                .min_by_key(|(t, id, _)| (*t, *id));
            let Some((t, id, anchor)) = next else {
                break;
            };
            if let Some(x) = anchor
                && let Some((other, returned)) = self.swapped_with(c, id, t, &x)
                && let Some(mut mine) = self.tracks.remove(&(c, id))
            {
                if let Some(theirs) = self.tracks.get_mut(&other) {
                    exchange_people(&mut mine, theirs);
                    // The other track came back from a gap with this track's person: that one
                    // observation goes with the person, and each track's newest settled
                    // observation is its person's.
                    let mut swapped_at = t;
                    if let Some((ret_t, before, before_t)) = returned {
                        if mine.samples.back().is_some_and(|s| s.t == ret_t)
                            && let Some(sample) = mine.samples.pop_back()
                        {
                            theirs.samples.push_back(sample);
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
    }

    /// The track that now follows the person camera `c` showed as `track` at `t`: undone swaps
    /// after `t` moved that person's state to another track, perhaps more than once.
    fn person_track(&self, c: usize, track: TrackId, t: i64) -> TrackId {
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
    fn note_encounters(&mut self, c: usize, track: TrackId, t: i64, anchor: &Point3<f64>) {
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
            if key.0 != c || key.1 == track || tr.is_superseded {
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
                .chain(self.tags.iter().filter_map(|t| t.newest))
                .chain(self.rssi.iter().filter_map(|r| r.newest))
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
        for imu in &mut self.imus {
            imu.frontier = i64::MAX;
            settle_imu(imu, &self.config);
        }
        for cam in &mut self.cameras {
            cam.frontier = i64::MAX;
        }
        for tag in &mut self.tags {
            tag.frontier = i64::MAX;
            tag.settle();
        }
        if let Some(rssi) = self.rssi.as_mut() {
            rssi.frontier = i64::MAX;
            let _ = rssi.settle();
        }
        for c in 0..self.cameras.len() {
            self.settle_camera(c, i64::MAX);
        }
        while let Some(end) = self.next_end {
            let more_data = self.global_max.is_some_and(|m| m >= end - self.hop_ns);
            if self.pending_out.is_empty() && !more_data {
                break;
            }
            self.process_window(end);
        }
        // Fixes after the last skeleton decision still get their (uncorrected or corrected) line.
        self.emit_corrections(i64::MAX);
        out.append(&mut self.ready);
    }

    fn process_window(&mut self, end: i64) {
        self.next_end = Some(end + self.hop_ns);
        self.stats.num_windows += 1;
        for imu in &mut self.imus {
            imu.make_contiguous();
            // `poll` waited for this IMU's samples up to `end` on its current offset; an
            // offset accepted below must not make this window read past them.
            imu.settled_until_ns = end.saturating_sub(imu.offset_ns);
        }
        // This window is final: a tag that went quiet still has its fixes before `end` used
        // (a fix older than `end` arriving later is late).
        for tag in &mut self.tags {
            tag.frontier = tag.frontier.max(end);
            tag.settle();
        }
        if let Some(rssi) = self.rssi.as_mut() {
            rssi.frontier = rssi.frontier.max(end);
            // A read the bank refuses was validated at push; nothing else to do with it here.
            let _ = rssi.settle();
        }
        self.stitch_new_tracks(end);
        self.update_offsets(end);
        self.score_window(end);
        self.decide(end);
        self.emit(end);
        self.forget(end);
    }

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
    fn update_offsets(&mut self, end: i64) {
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
        let refine_range = ns(self.config.offset_refine_range_s);
        let confirm_apart = ns(self.config.offset_confirm_apart_s);
        let same_offset = ns(self.config.offset_consistency_s);
        let mut skel_cache = TrackLagCache::default();
        // Each IMU's lag signals kept from the last window's search, put back at the end.
        let mut lag_memos: Vec<ImuLagMemo> = self
            .imus
            .iter_mut()
            .map(|m| std::mem::take(&mut m.lag_memo))
            .collect();
        // An IMU's buffer, per (IMU, offset it was cut with), for the three uses below.
        let mut imu_cache = ImuLagCache {
            lo: lo - max_off,
            hi: hi + max_off,
            signals: BTreeMap::new(),
        };
        // Interpolation weights and curve, reused by every lag curve.
        let mut scratch = LagScratch::default();
        let min_samples = self.config.geometric.min_samples;
        let mut fine = Vec::new();
        // Every subject's mean peak per track; the accepted offsets of a subject are read at
        // themselves only. Subjects with nothing to search still score the tracks a searching
        // subject would win, so a track that clearly belongs to someone else is no candidate
        // for a searching subject.
        // One search phase for everyone: subjects whose offsets are withdrawn or who are new
        // join the next search instead of adding their own.
        // A network IMU with nothing to be scored at searches at every window (see
        // `EngineConfig::offset_search_while_blind`).
        let is_blind = self.config.offset_search_while_blind
            && self.imus.iter().any(|m| {
                !m.is_offset_known
                    && m.pair_offsets.is_empty()
                    && m.lag_hypotheses.is_empty()
                    && self.is_network(m.subject)
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
        let mut short_skel_cache = TrackLagCache::default();
        let mut short_imu_cache = ImuLagCache {
            lo: lo - max_off,
            hi: short_hi + max_off,
            signals: BTreeMap::new(),
        };
        // Per subject: mean peak per track.
        let mut subject_scores: Vec<BTreeMap<(usize, TrackId), f64>> =
            vec![BTreeMap::new(); self.subjects.len()];
        // Per (unaccepted IMU, track): the peak lag, and whether the peak is clear (a short
        // track's is marked unclear: it only scores).
        let mut peaks: BTreeMap<(usize, (usize, TrackId)), (i64, bool)> = BTreeMap::new();
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
                    imu_cache.signals(i, imu, imu.offset_ns, &mut lag_memos, &self.config)
                else {
                    continue;
                };
                let short_imu_sig = if short.is_empty() || imu.is_offset_known {
                    None
                } else {
                    short_imu_cache.signals(i, imu, imu.offset_ns, &mut lag_memos, &self.config)
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
                let shorts: &[(usize, TrackId)] = if is_coarse { &short } else { &[] };
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
                                imu.site,
                                lo,
                                short_hi,
                                &self.config,
                            ),
                        ) else {
                            continue;
                        };
                        (imu_sig, sig)
                    } else {
                        let Some(sig) =
                            skel_cache.signals(&self.tracks, *key, imu.site, lo, hi, &self.config)
                        else {
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
                    let clarity = self.config.offset_peak_clarity;
                    let is_clear = is_coarse
                        && offsets
                            .iter()
                            .enumerate()
                            .min_by_key(|(_, o)| o.abs_diff(offset))
                            .is_some_and(|(k, _)| falls_on_both_sides(curve, k, PEAK_DROP))
                        && (clarity <= 0.0
                            || value
                                - rival_value(&offsets, curve, offset, OFFSET_PEAK_SEPARATION_NS)
                                >= clarity);
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
                        let curve = scratch.curve(imu_sig, sig, &fine, min_samples);
                        if let Some(found) = curve_peak(&fine, curve, prior, 0.0) {
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
        // A subject whose offsets are all accepted is read at them only, and its score on a
        // track only counts against a searching subject that would win that track: it is
        // computed there alone (the mean of its IMUs' correlations at their offsets).
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
                let (mut sum, mut num) = (0.0, 0usize);
                for &i in theirs {
                    let Some(imu) = self.imus.get(i) else {
                        continue;
                    };
                    let Some(imu_sig) =
                        imu_cache.signals(i, imu, imu.offset_ns, &mut lag_memos, &self.config)
                    else {
                        continue;
                    };
                    let Some(sig) =
                        skel_cache.signals(&self.tracks, *key, imu.site, lo, hi, &self.config)
                    else {
                        continue;
                    };
                    let offsets = [imu.offset_ns];
                    let curve = scratch.curve(imu_sig, sig, &offsets, min_samples);
                    if let Some((_, value)) = curve_peak(
                        &offsets,
                        curve,
                        imu.registry_offset_ns,
                        self.config.offset_tie_tolerance,
                    ) {
                        sum += value;
                        num += 1;
                    }
                }
                if num > 0
                    && let Some(scores) = subject_scores.get_mut(c)
                {
                    scores.insert(*key, sum / num as f64);
                }
            }
        }
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
        // Every IMU, accepted or not, against every candidate track: the lag curve's best
        // value over the tracks at every `BEST_TRACK_LAG_STEPS`-th coarse lag, summed over
        // passes, leaving out the tracks someone else's synchronised IMU explains. The IMU's
        // own labels do not enter this sum, so a wrong early label cannot confirm the offset it
        // came from. Once it has `offset_best_track_curves` passes, a peak standing
        // `offset_best_track_margin` above every lag more than `OFFSET_PEAK_SEPARATION_NS` away
        // accepts the offset, or moves an accepted one that lies farther than that from it;
        // `offset_settle_passes` such peaks in a row at the accepted offset settle it.
        let best_track_every = ns(self.config.offset_best_track_interval_s);
        if self.config.offset_best_track_curves > 0
            && !self.config.known_clock_offsets
            && end.saturating_sub(self.last_best_track_end) >= best_track_every
        {
            self.last_best_track_end = end;
            let mut best = Vec::new();
            let mut grid = Vec::new();
            let mut thinned = Vec::new();
            let best_grid_len = coarse.iter().step_by(BEST_TRACK_LAG_STEPS).count();
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
                grid.extend(coarse.iter().step_by(BEST_TRACK_LAG_STEPS).map(|o| o + cut));
                if let Some(imu_sig) = imu_cache.signals(i, imu, cut, &mut lag_memos, &self.config)
                {
                    for key in &candidates {
                        // A track named after someone else with an accepted offset is
                        // explained by that person's IMU: a look-alike's track (the same gait
                        // a fraction of a stride off, the same turns for a while) would
                        // otherwise give this IMU a second peak in every pass.
                        let is_explained = self
                            .tracks
                            .get(key)
                            .and_then(|tr| tr.label)
                            .is_some_and(|l| l != imu.subject && self.is_synced(l));
                        if is_explained {
                            continue;
                        }
                        let Some(sig) =
                            skel_cache.signals(&self.tracks, *key, imu.site, lo, hi, &self.config)
                        else {
                            continue;
                        };
                        // The joint search may have read this curve on the full coarse grid
                        // already: every other value of it is this pass's curve.
                        let curve: &[f64] = match scratch.coarse.get(&(i, cut, *key)) {
                            Some(c) => {
                                thinned.clear();
                                thinned.extend(c.iter().step_by(BEST_TRACK_LAG_STEPS));
                                &thinned
                            }
                            None => scratch.curve(imu_sig, sig, &grid, min_samples),
                        };
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
        // Unaccepted IMUs whose wearer the decisions put on a track: the coarse lag curve
        // against that track is summed over searches, so tracks too short for the joint search
        // above still add up; the sum's peak is accepted once it is clear of every lag more
        // than `OFFSET_PEAK_SEPARATION_NS` away.
        let label_min = ns(self.config.offset_label_min_track_s);
        for i in 0..self.imus.len() {
            let Some(imu) = self.imus.get(i) else {
                continue;
            };
            // Accepted offsets are checked the same way, at the refinement's pace.
            let every = if imu.is_offset_known {
                refine_every
            } else {
                search_every
            };
            if self.config.offset_label_curves == 0
                || end.saturating_sub(imu.last_label_search_end) < every
            {
                continue;
            }
            let (subject, site) = (imu.subject, imu.site);
            // The coarse grid around the registry's offset, the prior.
            let prior = imu.registry_offset_ns;
            let grid: Vec<i64> = coarse.iter().map(|o| o + prior).collect();
            let mut added: Vec<Vec<f64>> = Vec::new();
            if let Some(imu_sig) =
                imu_cache.signals(i, imu, imu.offset_ns, &mut lag_memos, &self.config)
            {
                for (key, tr) in self
                    .tracks
                    .iter()
                    .filter(|(_, tr)| tr.label == Some(subject) && !tr.is_superseded)
                {
                    if covered_span(tr, lo, hi) < label_min {
                        continue;
                    }
                    let Some(sig) =
                        skel_cache.signals(&self.tracks, *key, site, lo, hi, &self.config)
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
            let needed =
                if !imu.is_offset_known && !self.is_synced(subject) && self.is_network(subject) {
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
                && !self.config.known_clock_offsets
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
            let Some((offset, peak, rival)) = summed_peak(
                &grid,
                &mean,
                prior,
                max_off,
                LAG_STEP_NS / 2,
                OFFSET_PEAK_SEPARATION_NS,
            ) else {
                continue;
            };
            if peak < self.config.offset_label_min_correlation
                || peak - rival < self.config.offset_label_margin
            {
                continue;
            }
            // An offset the joint search agreed on and is confirming is not overruled here.
            if !imu.is_offset_known
                && imu
                    .pending_offset
                    .is_some_and(|p| (p - offset).abs() > OFFSET_PEAK_SEPARATION_NS)
            {
                continue;
            }
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
            imu.offset_ns = offset;
            imu.is_offset_known = true;
            // Refined at once (below) from the coarse step to the fine one.
            imu.last_refine_end = end - refine_every;
            record_offset(&mut self.stats, &imu.device, offset, peak);
        }
        // Refinement of accepted offsets against the tracks labelled with the wearer.
        for i in 0..self.imus.len() {
            let Some(imu) = self.imus.get(i) else {
                continue;
            };
            if !imu.is_offset_known || end.saturating_sub(imu.last_refine_end) < refine_every {
                continue;
            }
            let offsets: Vec<i64> = full
                .iter()
                .filter(|o| o.abs() <= refine_range)
                .map(|o| o + imu.offset_ns)
                .collect();
            // The curves against every track labelled with the wearer, weighted by how much of
            // the buffer each covers: a long track's peak is sharper than a short one's.
            let mut sum = vec![(0.0, 0.0); offsets.len()];
            if let Some(imu_sig) =
                imu_cache.signals(i, imu, imu.offset_ns, &mut lag_memos, &self.config)
            {
                for (key, tr) in self
                    .tracks
                    .iter()
                    .filter(|(_, tr)| tr.label == Some(imu.subject))
                {
                    let covered = covered_span(tr, lo, hi);
                    if covered < min_track {
                        continue;
                    }
                    let Some(sig) =
                        skel_cache.signals(&self.tracks, *key, imu.site, lo, hi, &self.config)
                    else {
                        continue;
                    };
                    let curve = scratch.curve(imu_sig, sig, &offsets, min_samples);
                    let w = covered as f64 * 1e-9;
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
            if let Some((offset, corr)) = best
                && corr >= self.config.offset_min_correlation
            {
                // Refinement never walks out of the searched range.
                let prior = imu.registry_offset_ns;
                imu.offset_ns = offset.clamp(prior - max_off, prior + max_off);
                record_offset(&mut self.stats, &imu.device, imu.offset_ns, corr);
            }
        }
        for (imu, memo) in self.imus.iter_mut().zip(lag_memos) {
            imu.lag_memo = memo;
        }
    }

    /// Scores this window: per camera, a [`ScoreTensor`] of De Marchi's correlations of every
    /// (active track, subject, site), fused by [`EngineConfig::fusion`] into one score per
    /// (track, subject) and accumulated. An IMU without an accepted offset is compared with a
    /// track at that pair's lag-curve peak (the max over the lag range, found on the long buffer).
    fn score_window(&mut self, end: i64) {
        let start = end - self.window_ns;
        let min_span = (self.config.min_window_coverage * self.window_ns as f64) as i64;
        let mut sites: Vec<Joint> = self.imus.iter().map(|m| m.site).collect();
        sites.sort_unstable();
        sites.dedup();
        // An IMU's window and features per (IMU, offset, grid): cameras that share frame times
        // (hardware-synchronised rigs) share them too.
        let mut grids: Vec<Vec<i64>> = Vec::new();
        let mut imu_cache: ImuFeatureCache = BTreeMap::new();
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
        let wants_belmonte = self.config.motion_score == MotionScore::Belmonte
            || (self.config.motion_score == MotionScore::Nomen
                && self.config.model_weights.belmonte > 0.0);
        let wants_heading = self.config.motion_score == MotionScore::Nomen
            && self.config.model_weights.heading > 0.0;
        // Each IMU's heading where its estimate is coherent enough (the phase of its cross
        // sums, as a unit complex number), and this window's normalised cross sums against the
        // tracks labelled with its wearer, added after every camera is scored.
        let headings: Vec<Option<[f64; 2]>> =
            self.imus.iter().map(|m| m.heading(&self.config)).collect();
        let mut heading_updates: Vec<(usize, [f64; 2])> = Vec::new();
        for c in 0..self.cameras.len() {
            // Tracks with a few samples in the window; the IMU models need more (below).
            let keys: Vec<(usize, TrackId)> = self
                .tracks
                .iter()
                .filter(|(k, tr)| {
                    k.0 == c && !tr.is_superseded && {
                        let (a, b) = sample_range(tr, start, end);
                        b >= a + 3
                    }
                })
                .map(|(k, _)| *k)
                .collect();
            if keys.is_empty() {
                continue;
            }
            // Every frame time of the camera in the window (any of its tracks).
            let mut frame_times: Vec<i64> = keys
                .iter()
                .filter_map(|k| self.tracks.get(k))
                .flat_map(|tr| {
                    let (a, b) = sample_range(tr, start, end);
                    tr.samples.range(a..b).map(|s| s.t)
                })
                .collect();
            frame_times.sort_unstable();
            frame_times.dedup();
            let mut tensor = ScoreTensor::new(keys.len(), self.subjects.len(), &sites);
            let mut device_scores: Vec<((usize, TrackId), usize, f64)> = Vec::new();
            // (row, subject) → (sum, count) of every correlation ([`MotionScore::Nomen`]).
            let mut nomen_sums: BTreeMap<(usize, usize), (f64, f64)> = BTreeMap::new();
            for (row, key) in keys.iter().enumerate() {
                let Some(tr) = self.tracks.get(key) else {
                    continue;
                };
                let (a, b) = sample_range(tr, start, end);
                if b < a + 8 || covered_span(tr, start, end) < min_span {
                    continue;
                }
                // The camera's frame times from the track's first sample in the window on; a
                // frame the track missed is a gap (no joints). Tracks seen since before the
                // window share one grid, so an IMU's window and features are built once per
                // (grid, offset), and a track's once per site.
                let first = tr.samples.get(a).map_or(start, |s| s.t);
                let grid: Vec<i64> = frame_times
                    .get(frame_times.partition_point(|&t| t < first)..)
                    .unwrap_or(&[])
                    .to_vec();
                let mut samples = tr.samples.range(a..b).peekable();
                let joints_world_m = grid
                    .iter()
                    .map(|&t| match samples.next_if(|s| s.t == t) {
                        Some(s) => s.joints.clone(),
                        None => Joints::new(),
                    })
                    .collect();
                let skel = SkeletonWindow {
                    camera: None,
                    track: Some(key.1),
                    t_s: grid.iter().map(|&t| t as f64 * 1e-9).collect(),
                    joints_world_m,
                };
                let grid_index = match grids.iter().position(|g| *g == grid) {
                    Some(g) => g,
                    None => {
                        grids.push(grid.clone());
                        grids.len() - 1
                    }
                };
                let mut segments: Vec<(Joint, SegmentFeatures)> = Vec::new();
                // The body's turn rate, the same for every site: computed once per track.
                let mut turn_rate: Option<Vec<f64>> = None;
                // The skeleton side of Belmonte's costs, per band side.
                let mut arms: Vec<(Side, ForearmSignals)> = Vec::new();
                for (i, imu) in self.imus.iter().enumerate() {
                    // The IMU's window and features at `offset` on this grid.
                    let build = |offset: i64| {
                        let mut win = ImuWindow::default();
                        // Settled samples only: device times before `end` on the current clock
                        // estimate.
                        imu_window_on_grid(
                            &imu.series(),
                            offset,
                            &grid,
                            MAX_IMU_GAP_NS,
                            (end - imu.offset_ns).min(imu.settled_until_ns),
                            &mut win,
                        );
                        win.device = Some(imu.device.clone());
                        let features =
                            ImuFeatures::new(&win, &self.config.geometric, &self.config.kinematic);
                        let band = (wants_belmonte && band_side(imu.site).is_some())
                            .then(|| BandSignals::new(&win, &self.config.belmonte));
                        (win, features, band)
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
                    let segment = match segments.iter().position(|(j, _)| *j == imu.site) {
                        Some(k) => k,
                        None => {
                            let turn = turn_rate
                                .get_or_insert_with(|| {
                                    body_turn_rate_signal(&skel, &self.config.kinematic)
                                })
                                .clone();
                            segments.push((
                                imu.site,
                                SegmentFeatures::with_turn_rate(
                                    &skel,
                                    imu.site,
                                    &self.config.geometric,
                                    &self.config.kinematic,
                                    turn,
                                ),
                            ));
                            segments.len() - 1
                        }
                    };
                    let Some((_, seg_features)) = segments.get(segment) else {
                        continue;
                    };
                    // The scores at the chosen hypothesis, already computed.
                    let mut chosen: Option<PairScores> = None;
                    let offset = match (imu.is_offset_known, pair_offset) {
                        (true, _) => imu.offset_ns,
                        (false, Some(o)) => o,
                        // A track too short for the search: the lag hypothesis that fits it best.
                        (false, None) => {
                            let mut best: Option<(f64, i64, PairScores)> = None;
                            for &o in hypotheses {
                                let (_, features_o, _) = imu_cache
                                    .entry((i, o, grid_index))
                                    .or_insert_with(|| build(o));
                                let (scores, k) = compare_features(
                                    features_o,
                                    seg_features,
                                    &self.config.geometric,
                                );
                                if let Some(fit) =
                                    weighted_fit(&scores, &k, &self.config.model_weights)
                                    && best.as_ref().is_none_or(|(b, _, _)| fit > *b)
                                {
                                    best = Some((fit, o, (scores, k)));
                                }
                            }
                            match best {
                                Some((_, o, pair)) => {
                                    chosen = Some(pair);
                                    o
                                }
                                None => continue,
                            }
                        }
                    };
                    let cached = imu_cache
                        .entry((i, offset, grid_index))
                        .or_insert_with(|| build(offset));
                    let (imu_win, imu_features) = (&cached.0, &cached.1);
                    let (mut scores, k) = match chosen {
                        Some(pair) => pair,
                        None => {
                            compare_features(imu_features, seg_features, &self.config.geometric)
                        }
                    };
                    // The heading model: only at a known offset, where the window's cross sum
                    // is that of the IMU's own clock (a pair scored at its own best lag would
                    // mix a lag error into the heading).
                    let cross = (wants_heading && imu.is_offset_known)
                        .then(|| {
                            horizontal_cross(
                                imu_features,
                                seg_features,
                                self.config.geometric.min_samples,
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
                        scores.dl = scorer.score(imu_win, &skel, imu.site);
                    }
                    if let (Some(band), Some(side)) = (&cached.2, band_side(imu.site)) {
                        let arm = match arms.iter().position(|(s, _)| *s == side) {
                            Some(k) => k,
                            None => {
                                arms.push((
                                    side,
                                    ForearmSignals::new(&skel, side, &self.config.belmonte),
                                ));
                                arms.len() - 1
                            }
                        };
                        let Some((_, arm)) = arms.get(arm) else {
                            continue;
                        };
                        let costs = belmonte_costs_from(band, arm, side, &self.config.belmonte);
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
                    let _ = tensor.set(row, imu.subject, imu.site, scores);
                }
            }
            let decay = self.decay_per_hop;
            let tag_decay = self.tag_decay_per_hop;
            let rssi_decay = self.rssi_decay_per_hop;
            let matrix = match self.config.motion_score {
                MotionScore::DeMarchi => Some(fuse(
                    &tensor,
                    self.config.fusion,
                    &self.config.fusion_config,
                )),
                MotionScore::Nomen | MotionScore::Belmonte => None,
            };
            let rssi_matrix = match self.rssi.as_mut() {
                Some(rssi) => {
                    let tracks: Vec<Option<&TrackState>> =
                        keys.iter().map(|k| self.tracks.get(k)).collect();
                    rssi.camera_scores(&tracks, end, &self.rssi_tags, self.subjects.len())
                }
                None => Vec::new(),
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
                let tag_scores = tag_window_scores(
                    &self.tags,
                    tr,
                    end - self.tag_window_ns,
                    end,
                    self.config.joint_noise_std_m,
                    self.subjects.len(),
                );
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
                    if let Some(v) = imu_score {
                        accumulate(tr.evidence.entry(b).or_default(), v, decay);
                    }
                    if let Some(v) = tag_score {
                        accumulate(tr.tag_evidence.entry(b).or_default(), *v, tag_decay);
                    }
                    if let Some(v) = rssi_scores.get(b).copied().flatten() {
                        accumulate(tr.rssi_evidence.entry(b).or_default(), v, rssi_decay);
                    }
                }
            }
            for (key, i, v) in device_scores {
                if let Some(tr) = self.tracks.get_mut(&key) {
                    accumulate(tr.device_evidence.entry(i).or_default(), v, decay);
                }
            }
        }
        if wants_heading {
            self.update_headings(heading_updates);
        }
    }

    /// Decays every IMU's heading sums by one hop, adds this window's normalised cross sums
    /// `(IMU, (re, im))`, and reports the headings that are coherent.
    fn update_headings(&mut self, updates: Vec<(usize, [f64; 2])>) {
        let heading_decay = 0.5f64.powf(self.config.hop_s / self.config.heading_half_life_s);
        for imu in &mut self.imus {
            imu.heading_sum = imu.heading_sum.map(|v| v * heading_decay);
            imu.heading_magnitude *= heading_decay;
            imu.heading_windows *= heading_decay;
        }
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
    /// The tracks of other cameras that show the same person as each of `active` (see
    /// [`EngineConfig::camera_pair_distance_m`]): settled torso positions ([`anchor_path`])
    /// over the last `CAMERA_PAIR_LOOKBACK_WINDOWS` evidence windows, compared at common frame
    /// times (within `CAMERA_PAIR_MAX_DT_NS`). A pair needs `CAMERA_PAIR_MIN_FRAMES` of them
    /// and a mean distance within the limit, and every track seen at the same time as either
    /// of the two in its camera must be at least twice as far from the other one.
    fn camera_partners(&self, active: &[TrackKey], end: i64) -> BTreeMap<TrackKey, Vec<TrackKey>> {
        let mut partners: BTreeMap<TrackKey, Vec<TrackKey>> = BTreeMap::new();
        let limit = self.config.camera_pair_distance_m;
        if limit <= 0.0 || self.cameras.len() < 2 {
            return partners;
        }
        let start = end - CAMERA_PAIR_LOOKBACK_WINDOWS * self.window_ns;
        let paths: Vec<(TrackKey, AnchorPath)> = active
            .iter()
            .filter_map(|k| {
                let tr = self.tracks.get(k)?;
                let path = anchor_path(tr, start, end);
                (path.len() >= CAMERA_PAIR_MIN_FRAMES).then_some((*k, path))
            })
            .collect();
        // Mean distance of every pair of tracks of different cameras with enough common frames.
        let mut distance: BTreeMap<(TrackKey, TrackKey), f64> = BTreeMap::new();
        for (i, (ka, pa)) in paths.iter().enumerate() {
            for (kb, pb) in paths.iter().skip(i + 1) {
                if ka.0 == kb.0 {
                    continue;
                }
                if let Some(d) = mean_common_distance(pa, pb, CAMERA_PAIR_MIN_FRAMES) {
                    distance.insert((*ka, *kb), d);
                    distance.insert((*kb, *ka), d);
                }
            }
        }
        // Each track's time span in the lookback: only tracks seen at the same time as a
        // candidate are its rivals (a person's successive tracks in one camera are not).
        let span: BTreeMap<TrackKey, (i64, i64)> = paths
            .iter()
            .filter_map(|(k, p)| Some((*k, (p.first()?.0, p.last()?.0))))
            .collect();
        let overlaps = |x: &TrackKey, y: &TrackKey| match (span.get(x), span.get(y)) {
            (Some(a), Some(b)) => spans_overlap(*a, *b),
            _ => false,
        };
        // The nearest rival of `b` from `a`'s point of view: tracks of `b`'s camera seen with `b`.
        let rival = |a: &TrackKey, b: &TrackKey| {
            distance
                .range((*a, (b.0, TrackId(0)))..)
                .take_while(|((x, y), _)| x == a && y.0 == b.0)
                .filter(|((_, y), _)| y != b && overlaps(y, b))
                .map(|(_, d)| *d)
                .fold(f64::INFINITY, f64::min)
        };
        for ((a, b), d) in &distance {
            if *d <= limit && rival(a, b) >= 2.0 * d && rival(b, a) >= 2.0 * d {
                partners.entry(*a).or_default().push(*b);
            }
        }
        partners
    }

    /// Assigns subjects to the active tracks of each camera.
    fn decide(&mut self, end: i64) {
        // Only tracks with frames still to emit take part: one that ended before this decision's
        // frames (`end − delay − hop` onwards) keeps its last label, so a subject who walked
        // out and came back under a new id is not fought over by the old and the new track.
        let active_since = end - self.delay_ns - self.hop_ns;
        let active: Vec<TrackKey> = self
            .tracks
            .iter()
            .filter(|(_, tr)| tr.last_t >= active_since && !tr.is_superseded)
            .map(|(k, _)| *k)
            .collect();
        let partners = self.camera_partners(&active, end);
        for c in 0..self.cameras.len() {
            let keys: Vec<TrackKey> = active.iter().filter(|k| k.0 == c).copied().collect();
            if keys.is_empty() || self.subjects.is_empty() {
                continue;
            }
            let mut rows = Vec::with_capacity(keys.len());
            for key in &keys {
                // The track's own evidence and that of the other cameras' views of its person.
                let views: Vec<&TrackState> = std::iter::once(key)
                    .chain(partners.get(key).into_iter().flatten())
                    .filter_map(|k| self.tracks.get(k))
                    .collect();
                let label = self.tracks.get(key).and_then(|tr| tr.label);
                let outscored_by = self.tracks.get(key).map(|tr| &tr.outscored_by);
                let mut scores = BTreeMap::new();
                let mut row = vec![None; self.subjects.len()];
                for s in 0..self.subjects.len() {
                    // Every modality the subject has evidence from counts equally (crate docs).
                    let present: Vec<f64> = [
                        pooled_mean(views.iter().map(|tr| tr.evidence.get(&s))),
                        pooled_mean(views.iter().map(|tr| tr.tag_evidence.get(&s))),
                        pooled_mean(views.iter().map(|tr| tr.rssi_evidence.get(&s))),
                    ]
                    .into_iter()
                    .flatten()
                    .collect();
                    if present.is_empty() {
                        continue;
                    }
                    let mean = present.iter().sum::<f64>() / present.len() as f64;
                    scores.insert(s, mean);
                    let bonus = if label == Some(s) {
                        self.config.switch_margin
                    } else {
                        0.0
                    };
                    // Evidence gathered while the subject was plainly on someone else's track
                    // tells how alike the two move, not who this is.
                    let is_excluded = self.config.exclusion_margin >= 0.0
                        && outscored_by
                            .and_then(|m| m.get(&s))
                            .is_some_and(|&held| mean < held - self.config.exclusion_margin);
                    if !is_excluded && let Some(cell) = row.get_mut(s) {
                        *cell = Some(mean + bonus);
                    }
                }
                if let Some(tr) = self.tracks.get_mut(key) {
                    tr.subject_scores = scores;
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
            let mut labels: Vec<Option<usize>> = assignment
                .rows
                .iter()
                .map(|decision| match decision {
                    RowDecision::Assigned { col, .. } => Some(*col),
                    _ => None,
                })
                .collect();
            // Each track's span as the observations before `end` tell, for the three steps below.
            let spans: Vec<Option<(i64, i64)>> =
                keys.iter().map(|k| self.span_before(k, end)).collect();
            self.share_between_successive_tracks(&spans, &rows, &mut labels);
            let held_back = self.hold_back_unsynced_switches(&keys, &spans, &rows, &mut labels);
            self.note_exclusions(&keys, &spans, &labels);
            for (key, new_label) in keys.iter().zip(labels) {
                let Some(tr) = self.tracks.get_mut(key) else {
                    continue;
                };
                if tr.label.is_some() && new_label.is_some() && tr.label != new_label {
                    self.stats.num_label_switches += 1;
                }
                tr.label = new_label;
                if new_label.is_some() {
                    tr.held_back = None;
                }
            }
            for (q, subject) in held_back {
                if let Some(tr) = keys.get(q).and_then(|k| self.tracks.get_mut(k))
                    && tr.label.is_none()
                {
                    tr.held_back = Some(subject);
                }
            }
        }
    }

    /// A track's span as seen from the observations before `end` only (all of them have
    /// arrived by then, so the result does not depend on message order). A track seen within
    /// `ALIVE_AT_END_NS` of `end` may go on past it, and one not seen before `end` starts there:
    /// both count as alive from then on, so a track that starts after `end` coexists with
    /// everyone still in view, and only with them.
    fn span_before(&self, key: &TrackKey, end: i64) -> Option<(i64, i64)> {
        let tr = self.tracks.get(key)?;
        let pending = tr.pending.range(..end).next_back().map(|(t, _)| *t);
        let settled = tr
            .samples
            .partition_point(|s| s.t < end)
            .checked_sub(1)
            .and_then(|i| tr.samples.get(i))
            .map(|s| s.t);
        Some(match pending.max(settled) {
            Some(last) if last < end - ALIVE_AT_END_NS => (tr.first_t, last),
            Some(_) => (tr.first_t, i64::MAX),
            None => (end, i64::MAX),
        })
    }

    /// After a camera's decision: every track that took part alongside the holder of a subject
    /// (their `spans` overlap: two people at once) remembers the holder's score for it
    /// ([`EngineConfig::exclusion_margin`]); a track holding the subject forgets it.
    fn note_exclusions(
        &mut self,
        keys: &[TrackKey],
        spans: &[Option<(i64, i64)>],
        labels: &[Option<usize>],
    ) {
        let held: Vec<(TrackKey, usize, f64, (i64, i64))> = keys
            .iter()
            .zip(labels)
            .zip(spans)
            .filter_map(|((key, label), span)| {
                let s = (*label)?;
                let score = *self.tracks.get(key)?.subject_scores.get(&s)?;
                Some((*key, s, score, (*span)?))
            })
            .collect();
        for ((key, label), span) in keys.iter().zip(labels).zip(spans) {
            let (Some(tr), Some(mine)) = (self.tracks.get_mut(key), *span) else {
                continue;
            };
            for &(holder, s, score, theirs) in &held {
                if *label == Some(s) {
                    tr.outscored_by.remove(&s);
                } else if holder != *key && spans_overlap(mine, theirs) {
                    tr.outscored_by.insert(s, score);
                }
            }
        }
    }

    /// One person seen under successive ids by a camera: the assignment gives each subject to
    /// one track, but a track that ended and its successor (unstitched) may both still have
    /// frames to label. A track whose best subject went to another track that it never
    /// coexisted with (their `spans` do not overlap; see [`Engine::span_before`]) takes
    /// that subject too, if its score clears the rejection threshold; tracks are taken by
    /// decreasing best score.
    fn share_between_successive_tracks(
        &self,
        spans: &[Option<(i64, i64)>],
        rows: &[Vec<Option<f64>>],
        labels: &mut [Option<usize>],
    ) {
        let span = |r: usize| spans.get(r).copied().flatten();
        let mut best: Vec<(usize, usize, f64)> = rows
            .iter()
            .enumerate()
            .filter_map(|(r, row)| {
                let (s, v) = row
                    .iter()
                    .enumerate()
                    .filter_map(|(s, v)| Some((s, (*v)?)))
                    .max_by(|a, b| a.1.total_cmp(&b.1).then(b.0.cmp(&a.0)))?;
                (v >= self.config.rejection_threshold).then_some((r, s, v))
            })
            .collect();
        best.sort_by(|a, b| b.2.total_cmp(&a.2).then(a.0.cmp(&b.0)));
        for (r, s, _) in best {
            if labels.get(r).copied().flatten() == Some(s) {
                continue;
            }
            let Some(mine) = span(r) else {
                continue;
            };
            let coexists = labels.iter().enumerate().any(|(q, label)| {
                q != r
                    && *label == Some(s)
                    && span(q).is_some_and(|theirs| spans_overlap(mine, theirs))
            });
            if !coexists && let Some(label) = labels.get_mut(r) {
                *label = Some(s);
            }
        }
    }

    /// Whether `subject` wears a body-area network (several IMUs).
    fn is_network(&self, subject: usize) -> bool {
        self.subject_imus
            .get(subject)
            .is_some_and(|imus| imus.len() > 1)
    }

    /// Whether any of `subject`'s IMUs has an accepted clock offset.
    fn is_synced(&self, subject: usize) -> bool {
        self.subject_imus.get(subject).is_some_and(|imus| {
            imus.iter()
                .any(|&i| self.imus.get(i).is_some_and(|m| m.is_offset_known))
        })
    }

    /// A subject none of whose IMUs has an accepted offset, about to move from the track
    /// holding it to another track of the camera that coexists with it, goes to neither unless
    /// the newcomer's score beats the holder's by [`EngineConfig::unsynced_switch_margin`]:
    /// each pair is scored at its own best lag until then, so two people walking alike are
    /// hard to tell apart, and an early name is better withheld than moved on a narrow margin.
    fn hold_back_unsynced_switches(
        &self,
        keys: &[TrackKey],
        spans: &[Option<(i64, i64)>],
        rows: &[Vec<Option<f64>>],
        labels: &mut [Option<usize>],
    ) -> Vec<(usize, usize)> {
        let mut held_back = Vec::new();
        let margin = self.config.unsynced_switch_margin;
        if margin <= 0.0 {
            return held_back;
        }
        let holders: Vec<Option<usize>> = keys
            .iter()
            .map(|k| self.tracks.get(k).and_then(|tr| tr.label.or(tr.held_back)))
            .collect();
        let score = |r: usize, s: usize| rows.get(r).and_then(|row| row.get(s)).copied().flatten();
        for r in 0..labels.len() {
            let (Some(s), Some(mine)) = (
                labels.get(r).copied().flatten(),
                spans.get(r).copied().flatten(),
            ) else {
                continue;
            };
            if holders.get(r).copied().flatten() == Some(s) {
                continue;
            }
            if self.is_synced(s) {
                continue;
            }
            // The coexisting tracks that held the subject until now, and the best of their
            // scores (it carries the hysteresis bonus).
            let holders_of: Vec<usize> = (0..keys.len())
                .filter(|&q| q != r && holders.get(q).copied().flatten() == Some(s))
                .filter(|&q| {
                    spans
                        .get(q)
                        .copied()
                        .flatten()
                        .is_some_and(|theirs| spans_overlap(mine, theirs))
                })
                .collect();
            let held = holders_of
                .iter()
                .filter_map(|&q| score(q, s))
                .reduce(f64::max);
            if let (Some(held), Some(new)) = (held, score(r, s))
                && new - held < margin
                && let Some(label) = labels.get_mut(r)
            {
                *label = None;
                held_back.extend(holders_of.iter().map(|&q| (q, s)));
            }
        }
        held_back
    }

    /// Emits every observation whose decision window is `end` or earlier.
    fn emit(&mut self, end: i64) {
        self.emit_corrections(end);
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
            let tr = self.tracks.get(&(c, self.person_track(c, track, t)));
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

    /// Emits a [`TagCorrection`] for every settled fix at or before `end − decision_delay`: the
    /// fix blended with its wearer's key joint when a track labelled with the wearer has it
    /// at that time, the raw fix otherwise (see [`crate::tags`]).
    fn emit_corrections(&mut self, end: i64) {
        let joint_sigma = self.config.joint_noise_std_m;
        for k in 0..self.tags.len() {
            while let Some(tag) = self.tags.get(k) {
                let Some(fix) = tag.to_correct.front().copied() else {
                    break;
                };
                if fix.t.saturating_add(self.delay_ns) > end {
                    break;
                }
                let joint = self
                    .tracks
                    .values()
                    .filter(|tr| tr.label == Some(tag.subject))
                    .filter_map(|tr| key_joint_near(tr, tag.site, fix.t))
                    .min_by(|a, b| {
                        let da = (a - fix.position_world_m).norm();
                        let db = (b - fix.position_world_m).norm();
                        da.total_cmp(&db)
                    });
                let corrected = joint.map_or(fix.position_world_m, |j| {
                    corrected_position(&fix, &j, joint_sigma)
                });
                self.ready.push(Message::TagCorrection(TagCorrection {
                    t: SessionTime::from_ns(fix.t),
                    tag: tag.device.clone(),
                    raw_position_m: fix.position_world_m,
                    corrected_position_m: corrected,
                }));
                if joint.is_some() {
                    self.stats.num_tag_corrections += 1;
                }
                if let Some(tag) = self.tags.get_mut(k) {
                    tag.to_correct.pop_front();
                }
            }
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
                        let acc = tr.device_evidence.get(i)?;
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
            + 4 * ns(self.config.max_clock_offset_s)
            + self.hop_ns;
        for imu in &mut self.imus {
            let cut = end - keep - imu.offset_ns;
            while imu.t.front().is_some_and(|&t| t < cut) {
                imu.pop_front();
            }
        }
        for tag in &mut self.tags {
            tag.forget_before(end - keep);
        }
        let timeout = ns(self.config.track_timeout_s);
        for tr in self.tracks.values_mut() {
            while tr.samples.front().is_some_and(|s| s.t < end - keep) {
                tr.samples.pop_front();
            }
        }
        // A swap matters until every frame before it is emitted.
        let oldest_due = self.pending_out.first().map_or(end, |p| p.0);
        self.swaps.retain(|_, events| {
            events.retain(|(t, _)| *t > oldest_due);
            !events.is_empty()
        });
        let pending_out = &self.pending_out;
        self.tracks.retain(|k, tr| {
            tr.last_t >= end - timeout.max(keep)
                || !tr.pending.is_empty()
                || pending_out.iter().any(|p| p.1 == k.0 && p.2 == k.1)
        });
    }
}

/// Span of samples the orientation filter starts from, ns (see [`start_ahrs`]).
const AHRS_START_NS: i64 = 1_000_000_000;

/// A gap between an IMU's samples at least this long restarts its orientation filter, ns.
const AHRS_MAX_GAP_NS: i64 = 1_000_000_000;

/// Settles an IMU's pending samples below its frontier: Madgwick's orientation per sample. The
/// filter (re)starts at the first sample and after a gap of a second or more (see
/// [`start_ahrs`]); samples wait until it can.
fn settle_imu(imu: &mut ImuState, config: &EngineConfig) {
    while let Some((&t, &(accel, gyro))) = imu.pending.first_key_value() {
        if t >= imu.frontier {
            break;
        }
        let dt_ns = imu.ahrs_last_ns.map(|last| t - last);
        let q = match (imu.ahrs.as_mut(), dt_ns) {
            (Some(ahrs), Some(dt_ns)) if dt_ns > 0 && dt_ns < AHRS_MAX_GAP_NS => {
                ahrs.update_imu(&gyro, &accel, dt_ns as f64 * 1e-9)
            }
            (Some(ahrs), None) => ahrs.world_from_sensor(),
            _ => {
                if !start_ahrs(imu, config) {
                    break;
                }
                continue;
            }
        };
        imu.pending.remove(&t);
        imu.ahrs_last_ns = Some(t);
        imu.t.push_back(t);
        imu.accel.push_back(accel);
        imu.gyro.push_back(gyro);
        imu.world_from_sensor.push_back(q);
    }
}

/// Starts the IMU's orientation filter at its first pending sample, once the pending samples
/// below the frontier span [`AHRS_START_NS`] without a gap of a second (or at the end of the
/// input, with what there is): level, with the vertical the per-axis median of the specific
/// forces of those samples brought into the first sample's frame by integrating the gyroscope.
/// Over a stride the linear accelerations average out, and the median ignores a knock; one
/// sample alone reads an arm's swing (a pendulum's bob feels its force along the arm, not
/// along the vertical), and Madgwick's gain corrects that at only about 4°/s. Returns whether
/// the filter started.
fn start_ahrs(imu: &mut ImuState, config: &EngineConfig) -> bool {
    let Some(&first) = imu.pending.keys().next() else {
        return false;
    };
    // While the samples below the frontier span less than the start, none of them can end it
    // (neither its length nor a gap): wait without scanning them again.
    let is_finishing = imu.frontier == i64::MAX;
    let newest_settled = imu
        .pending
        .range(..imu.frontier)
        .next_back()
        .map(|(&t, _)| t);
    if !is_finishing && newest_settled.is_none_or(|t| t - first < AHRS_START_NS) {
        return false;
    }
    // The current sample's frame as seen from the first one's.
    let mut first_from_sensor = UnitQuaternion::identity();
    let mut last: Option<(i64, Vector3<f64>)> = None;
    let mut up: [Vec<f64>; 3] = [Vec::new(), Vec::new(), Vec::new()];
    let mut is_complete = is_finishing;
    for (&t, (accel, gyro)) in &imu.pending {
        if t >= imu.frontier {
            break;
        }
        if let Some((last_t, last_gyro)) = last {
            if t - last_t >= AHRS_MAX_GAP_NS {
                is_complete = true;
                break;
            }
            let dt_s = (t - last_t) as f64 * 1e-9;
            first_from_sensor *= UnitQuaternion::from_scaled_axis(last_gyro * dt_s);
        }
        if t - first >= AHRS_START_NS {
            is_complete = true;
            break;
        }
        let v = first_from_sensor * accel;
        for (axis, x) in up.iter_mut().zip(v.iter()) {
            axis.push(*x);
        }
        last = Some((t, *gyro));
    }
    if !is_complete {
        return false;
    }
    let up_first =
        Vector3::from_iterator(up.iter_mut().map(|axis| median(axis).unwrap_or(f64::NAN)));
    let start = level_from_accel(&up_first).unwrap_or(UnitQuaternion::identity());
    imu.ahrs = Madgwick::new(config.madgwick, start).ok();
    imu.ahrs_last_ns = None;
    imu.ahrs.is_some()
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
                        && let Some(p) = kf.position()
                    {
                        sample.joints.insert(*j, p);
                    }
                }
            }
            None => sample.joints = joints,
        }
        tr.samples.push_back(sample);
    }
}

/// RSSI evidence: reads wait for the reorder window, then feed one Kalman filter per (tag,
/// antenna) ([`FilterBank`]); at each window end the tracks of a camera are scored against
/// every tag ([`RssiState::camera_scores`]).
struct RssiState {
    bank: FilterBank,
    likelihood: LikelihoodConfig,
    pending: BTreeMap<(i64, DeviceId, AntennaId), RssiRead>,
    newest: Option<i64>,
    frontier: i64,
    estimates: Vec<Option<nomen_rssi::RssiEstimate>>,
}

impl RssiState {
    /// Feeds settled reads to the filters in time order; returns the first refusal, if any.
    fn settle(&mut self) -> Option<nomen_rssi::RssiError> {
        let mut first = None;
        while let Some(entry) = self.pending.first_entry() {
            if entry.key().0 >= self.frontier {
                break;
            }
            let read = entry.remove();
            if let Err(e) = self.bank.push(&read) {
                first.get_or_insert(e);
            }
        }
        first
    }

    /// For the tracks of one camera (rows) and every subject (columns): the mean over the
    /// subject's RSSI tags of how much more likely the tag is at this track's position than
    /// anywhere in the area. Per tag, the likelihood of the filtered RSSI at the track's
    /// position (its sample nearest to `end`, within [`MAX_PAIR_DT_NS`]) against the background
    /// likelihood gives `p = nomen_rssi::pair_score` (0.5: no better than background); the
    /// score is `2p − 1` clamped to `0..=1`. Tracks compete in the assignment, and RSSI evidence
    /// accumulates with its own, longer half-life ([`EngineConfig::rssi_evidence_half_life_s`]):
    /// one read says little, a walk across the antennas' field says much.
    fn camera_scores(
        &mut self,
        tracks: &[Option<&TrackState>],
        end: i64,
        tags: &BTreeMap<DeviceId, (usize, Joint)>,
        num_subjects: usize,
    ) -> Vec<Vec<Option<f64>>> {
        let mut sums = vec![vec![(0.0, 0usize); num_subjects]; tracks.len()];
        let placement = self.bank.model().placement;
        let mut lls = Vec::with_capacity(tracks.len());
        let t = SessionTime::from_ns(end);
        for (tag, (subject, site)) in tags {
            if !self.bank.estimates_at(tag, t, &mut self.estimates) {
                continue;
            }
            let model = self.bank.model();
            lls.clear();
            for tr in tracks {
                let last = tr.and_then(|tr| {
                    let i = tr.samples.partition_point(|s| s.t < end);
                    i.checked_sub(1)
                        .and_then(|k| tr.samples.get(k))
                        .filter(|s| end - s.t <= MAX_PAIR_DT_NS)
                });
                let position = last.and_then(|last| match placement {
                    TagPlacement::FixedHeight(h) => last
                        .joints
                        .get(Joint::Pelvis)
                        .copied()
                        .or_else(|| joint_centroid(&last.joints))
                        .map(|p| Point3::new(p.x, p.y, h)),
                    TagPlacement::RegistrySite => last
                        .joints
                        .get(*site)
                        .copied()
                        .or_else(|| last.joints.get(Joint::Pelvis).copied()),
                });
                lls.push(position.map_or(f64::NAN, |p| {
                    log_likelihood(model, &self.estimates, &p, &self.likelihood)
                }));
            }
            let bg = background_log_likelihood(model, &self.estimates, &self.likelihood);
            for (row, ll) in sums.iter_mut().zip(&lls) {
                if ll.is_nan() {
                    continue;
                }
                if let Some(cell) = row.get_mut(*subject) {
                    cell.0 += (2.0 * pair_score(*ll, bg) - 1.0).clamp(0.0, 1.0);
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

/// Per subject, the mean over their tags of the tag-versus-track window score (see [`crate::tags`]);
/// `None` for a subject without a tag or without enough paired fixes in the window.
fn tag_window_scores(
    tags: &[TagState],
    tr: &TrackState,
    start: i64,
    end: i64,
    joint_sigma_m: f64,
    num_subjects: usize,
) -> Vec<Option<f64>> {
    let mut sums = vec![(0.0, 0usize); num_subjects];
    for tag in tags {
        let (mut sum, mut n) = (0.0, 0usize);
        for fix in tag.fixes_in(start, end) {
            if let Some((joint, extra_m)) = key_joint_or_ancestor(tr, tag.site, fix.t) {
                let sigma = joint_sigma_m.hypot(extra_m);
                sum += fix_similarity(fix, &joint, sigma);
                n += 1;
            }
        }
        if n >= MIN_TAG_PAIRS
            && let Some(cell) = sums.get_mut(tag.subject)
        {
            cell.0 += sum / n as f64;
            cell.1 += 1;
        }
    }
    sums.into_iter()
        .map(|(sum, n)| (n > 0).then(|| sum / n as f64))
        .collect()
}

/// Fewest fixes paired with a track in a window for a tag score (0.3 s of fixes at 10 Hz).
const MIN_TAG_PAIRS: usize = 3;

/// The track's `joint` at the sample nearest to `t`, if within [`MAX_PAIR_DT_NS`].
fn key_joint_near(tr: &TrackState, joint: Joint, t: i64) -> Option<Point3<f64>> {
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
fn key_joint_or_ancestor(tr: &TrackState, joint: Joint, t: i64) -> Option<(Point3<f64>, f64)> {
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
const TAG_CHAIN_SIGMA_M: f64 = 0.25;

/// Distance between `a` and `b` across the line of sight from `eye`: the angle between the two
/// rays times the nearer one's range, m.
fn lateral_distance_m(eye: &Point3<f64>, a: &Point3<f64>, b: &Point3<f64>) -> f64 {
    let (ra, rb) = (a - eye, b - eye);
    let range = ra.norm().min(rb.norm());
    if range <= 0.0 || !range.is_finite() {
        return (a - b).norm();
    }
    ra.angle(&rb) * range
}

/// The per-key average of two evidence maps (a key in one map only keeps half its weight).
fn average_evidence<K: Ord + Copy>(
    a: &BTreeMap<K, Accumulator>,
    b: &BTreeMap<K, Accumulator>,
) -> BTreeMap<K, Accumulator> {
    let keys: BTreeSet<K> = a.keys().chain(b.keys()).copied().collect();
    keys.into_iter()
        .map(|k| {
            let (x, y) = (a.get(&k), b.get(&k));
            let w = x.map_or(0.0, |x| x.weight) + y.map_or(0.0, |y| y.weight);
            (
                k,
                Accumulator {
                    mean: pooled_mean([x, y].into_iter()).unwrap_or(0.0),
                    weight: 0.5 * w,
                },
            )
        })
        .collect()
}

/// Mean of a skeleton's observed joints (where the person is), `None` without any.
fn joint_centroid(joints: &Joints<Point3<f64>>) -> Option<Point3<f64>> {
    let (sum, n) = joints
        .iter()
        .fold((Vector3::zeros(), 0usize), |(s, n), (_, p)| {
            (s + p.coords, n + 1)
        });
    (n > 0).then(|| Point3::from(sum / n as f64))
}

/// The weighted mean of the accumulators present (each weighted by its evidence weight); `None`
/// without any.
fn pooled_mean<'a>(accs: impl Iterator<Item = Option<&'a Accumulator>>) -> Option<f64> {
    let (sum, weight) = accs
        .flatten()
        .filter(|a| a.weight > 0.0)
        .fold((0.0, 0.0), |(s, w), a| {
            (s + a.mean * a.weight, w + a.weight)
        });
    (weight > 0.0).then(|| sum / weight)
}

/// Whether two closed time intervals `(first, last)` share an instant.
fn spans_overlap(a: (i64, i64), b: (i64, i64)) -> bool {
    a.0 <= b.1 && b.0 <= a.1
}

/// Mean distance between two paths (time increasing) over their common times (samples at
/// most `CAMERA_PAIR_MAX_DT_NS` apart, each used once), each time measured at the first of the
/// [`TORSO_ANCHORS`] both paths have there (times without a shared one are skipped); `None`
/// with fewer than `min_frames` such times.
fn mean_common_distance(a: &[AnchorSample], b: &[AnchorSample], min_frames: usize) -> Option<f64> {
    let (mut i, mut j) = (0, 0);
    let (mut sum, mut n) = (0.0, 0usize);
    while let (Some((ta, pa)), Some((tb, pb))) = (a.get(i), b.get(j)) {
        if (ta - tb).abs() <= CAMERA_PAIR_MAX_DT_NS {
            let shared = pa
                .iter()
                .zip(pb)
                .find_map(|(x, y)| Some((x.as_ref()?, y.as_ref()?)));
            if let Some((x, y)) = shared {
                sum += (x - y).norm();
                n += 1;
            }
            i += 1;
            j += 1;
        } else if ta < tb {
            i += 1;
        } else {
            j += 1;
        }
    }
    (n >= min_frames.max(1)).then(|| sum / n as f64)
}

/// Joints that locate a person for comparing two cameras' views, in order of preference: the
/// pelvis, else up the spine, else a hip. A view often lacks the pelvis (hidden behind someone
/// in front) while the other camera sees it: comparing the same joint in both keeps the
/// distance free of the offset between different joints.
const TORSO_ANCHORS: [Joint; 6] = [
    Joint::Pelvis,
    Joint::Chest,
    Joint::Neck,
    Joint::Head,
    Joint::LeftHip,
    Joint::RightHip,
];

/// A track's settled [`TORSO_ANCHORS`] positions in `[lo, hi)` (samples with none left out).
fn anchor_path(tr: &TrackState, lo: i64, hi: i64) -> AnchorPath {
    let (a, b) = sample_range(tr, lo, hi);
    tr.samples
        .range(a..b)
        .filter_map(|s| {
            let anchors = TORSO_ANCHORS.map(|j| s.joints.get(j).copied());
            anchors
                .iter()
                .any(Option::is_some)
                .then_some((s.t, anchors))
        })
        .collect()
}

/// The key with the smallest value when that value is at most `limit` and every other value is
/// at least twice it.
fn unique_nearest(values: impl Iterator<Item = (TrackKey, f64)>, limit: f64) -> Option<TrackKey> {
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

/// Scratch buffers of the lag search, reused by every curve of a window.
#[derive(Default)]
struct LagScratch {
    weights: Vec<LagWeight>,
    curve: Vec<f64>,
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
        track_signals: &LagSignals,
        offsets_ns: &[i64],
        min_samples: usize,
    ) -> &[f64] {
        let Self {
            weights,
            curve,
            coarse,
        } = self;
        coarse.entry((imu_index, cut_ns, track)).or_insert_with(|| {
            lag_curve(
                imu,
                track_signals,
                offsets_ns,
                MAX_IMU_GAP_NS,
                min_samples,
                weights,
                curve,
            );
            curve.clone()
        })
    }

    /// The lag curve of `imu` against `track` at `offsets_ns` ([`lag_curve`], across IMU gaps
    /// up to [`MAX_IMU_GAP_NS`]).
    fn curve(
        &mut self,
        imu: &LagSignals,
        track: &LagSignals,
        offsets_ns: &[i64],
        min_samples: usize,
    ) -> &[f64] {
        lag_curve(
            imu,
            track,
            offsets_ns,
            MAX_IMU_GAP_NS,
            min_samples,
            &mut self.weights,
            &mut self.curve,
        );
        &self.curve
    }
}

/// Reports an accepted or updated clock offset of `device` in the run's statistics.
fn record_offset(stats: &mut EngineStats, device: &DeviceId, offset_ns: i64, correlation: f64) {
    let entry = stats.clock_offsets.entry(device.clone()).or_default();
    entry.offset_ns = offset_ns;
    entry.correlation = correlation;
    entry.num_updates += 1;
}

/// Adds one window score to an exponentially weighted mean (older scores decay per hop).
fn accumulate(acc: &mut Accumulator, score: f64, decay_per_hop: f64) {
    let w = acc.weight * decay_per_hop;
    acc.mean = (acc.mean * w + score) / (w + 1.0);
    acc.weight = w + 1.0;
}

/// A track: its camera's index and its id.
type TrackKey = (usize, TrackId);

/// A track's observation after a gap: its time (session ns), the track's settled anchor before
/// the gap (world, m) and that anchor's time (session ns).
type GapReturn = (i64, Point3<f64>, i64);

/// A track's [`TORSO_ANCHORS`] (world, m, where seen) at one of its times (session ns).
type AnchorSample = (i64, [Option<Point3<f64>>; TORSO_ANCHORS.len()]);

/// A track's [`AnchorSample`]s, time increasing.
type AnchorPath = Vec<AnchorSample>;

/// An IMU's window on a grid, its features and (for a forearm band) Belmonte's band signals,
/// per (IMU, offset, grid index).
type ImuFeatureCache = BTreeMap<(usize, i64, usize), (ImuWindow, ImuFeatures, Option<BandSignals>)>;

/// De Marchi's and nomen's correlations of one pair in one window.
type PairScores = (nomen_evidence::ModelScores, nomen_evidence::KinematicScores);

/// A pair's motion correlations with their [`crate::ModelWeights`]: De Marchi's three and
/// nomen's five (not the learned scorer's, the heading or Belmonte's similarity).
fn motion_terms(
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
fn weighted_fit(
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

/// Exchanges the people two tracks follow after an id swap: everything that describes the
/// person (settled joint history and filters, evidence, label, newest settled observation,
/// whether it is new to the camera and may still continue an ended track) moves, while what
/// belongs to the id stays (observations not settled yet, arrival times, whether a later track
/// continued it).
fn exchange_people(a: &mut TrackState, b: &mut TrackState) {
    std::mem::swap(&mut a.samples, &mut b.samples);
    std::mem::swap(&mut a.kalman, &mut b.kalman);
    std::mem::swap(&mut a.evidence, &mut b.evidence);
    std::mem::swap(&mut a.tag_evidence, &mut b.tag_evidence);
    std::mem::swap(&mut a.rssi_evidence, &mut b.rssi_evidence);
    std::mem::swap(&mut a.device_evidence, &mut b.device_evidence);
    std::mem::swap(&mut a.label, &mut b.label);
    std::mem::swap(&mut a.subject_scores, &mut b.subject_scores);
    std::mem::swap(&mut a.settled_t, &mut b.settled_t);
    std::mem::swap(&mut a.settled_anchor_world_m, &mut b.settled_anchor_world_m);
    std::mem::swap(&mut a.is_stitch_pending, &mut b.is_stitch_pending);
}

/// Which forearm a band at `site` is on, for Belmonte-Hernández's costs; `None` off the
/// forearm. A band at the elbow or hand may be on either.
fn band_side(site: Joint) -> Option<Side> {
    match site {
        Joint::LeftWrist => Some(Side::Left),
        Joint::RightWrist => Some(Side::Right),
        Joint::LeftElbow | Joint::RightElbow | Joint::LeftHand | Joint::RightHand => {
            Some(Side::Unknown)
        }
        _ => None,
    }
}

/// Index range of a track's settled samples in `[lo, hi)`.
fn sample_range(tr: &TrackState, lo: i64, hi: i64) -> (usize, usize) {
    (
        tr.samples.partition_point(|s| s.t < lo),
        tr.samples.partition_point(|s| s.t < hi),
    )
}

/// Time from a track's first to last sample in `[lo, hi)`, ns (0 without samples).
fn covered_span(tr: &TrackState, lo: i64, hi: i64) -> i64 {
    let (a, b) = sample_range(tr, lo, hi);
    match (
        tr.samples.get(a),
        b.checked_sub(1).and_then(|l| tr.samples.get(l)),
    ) {
        (Some(first), Some(last)) if b > a => last.t - first.t,
        _ => 0,
    }
}

/// De Marchi's magnitude config for the lag search: no moving average (its causal delay would
/// differ between the IMU's rate and the camera's); the zero-phase low-pass does the smoothing.
fn lag_geometric(config: &EngineConfig) -> GeometricConfig {
    GeometricConfig {
        moving_average_len: 1,
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
/// velocity model, a leaky integral over 12 s, correlated worse than either on the simulated
/// scenes.) The orientation's reference is the buffer's first sample on each side: at a
/// candidate lag `o` the IMU's lies `max offset + cut − o` before the track's, up to a second
/// apart, which matters for a limb that swings (see the best-track curve in
/// [`Engine::update_offsets`]). A reference per lag (the IMU's orientation at the track's
/// reference time, lag by lag) removes that bias, but changed nothing on the simulated scenes
/// (78.3 against 78.2 % over the ten imu-table scenes, seeds 1–9), so it is not done.
fn imu_lag_signals(
    imu: &ImuState,
    memo: &mut ImuLagMemo,
    cut_offset_ns: i64,
    lo: i64,
    hi: i64,
    config: &EngineConfig,
) -> Option<LagSignals> {
    // Device times (the lag curve shifts them by each candidate offset itself), thinned like
    // the track's: interpolation walks every IMU sample once per candidate offset.
    imu_lag_signals_from(
        memo,
        &imu.series(),
        imu.num_forgotten,
        IMU_LAG_DECIMATION,
        lo - cut_offset_ns,
        (hi - cut_offset_ns).min(imu.settled_until_ns),
        &lag_geometric(config),
        &config.kinematic,
    )
}

/// The lag search's IMU side for one window: each IMU's signals over `[lo, hi)` (device clock
/// shifted by the offset the buffer is cut at), per (IMU, that offset).
struct ImuLagCache {
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
type TrackLagWindow = (Vec<i64>, SkeletonWindow, Vec<f64>);

/// The lag search's track side for one window: each track's buffer, copied once, and its
/// signals per site.
#[derive(Default)]
struct TrackLagCache {
    /// A track's buffer in `[lo, hi)`; `None` if too short.
    windows: BTreeMap<TrackKey, Option<TrackLagWindow>>,
    signals: BTreeMap<(TrackKey, Joint), Option<LagSignals>>,
}

impl TrackLagCache {
    /// The acceleration and carrying-segment orientation-change magnitudes (and the other lag
    /// models) of track `key` at `site` on its own times in `[lo, hi)`; `None` for an unknown
    /// or too short track.
    fn signals(
        &mut self,
        tracks: &BTreeMap<TrackKey, TrackState>,
        key: TrackKey,
        site: Joint,
        lo: i64,
        hi: i64,
        config: &EngineConfig,
    ) -> Option<&LagSignals> {
        let Self { windows, signals } = self;
        signals
            .entry((key, site))
            .or_insert_with(|| {
                let window = windows.entry(key).or_insert_with(|| {
                    let tr = tracks.get(&key)?;
                    let (a, b) = sample_range(tr, lo, hi);
                    if b < a + 16 {
                        return None;
                    }
                    let t_ns: Vec<i64> = tr.samples.range(a..b).map(|s| s.t).collect();
                    let skel = SkeletonWindow {
                        camera: None,
                        track: None,
                        t_s: t_ns.iter().map(|&t| t as f64 * 1e-9).collect(),
                        joints_world_m: tr.samples.range(a..b).map(|s| s.joints.clone()).collect(),
                    };
                    let turn: Vec<f64> = body_turn_rate_signal(&skel, &config.kinematic)
                        .into_iter()
                        .step_by(LAG_DECIMATION)
                        .collect();
                    Some((t_ns, skel, turn))
                });
                window.as_ref().map(|(t_ns, skel, turn)| {
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
                    let models = vec![acc, ori, vertical, swing, turn.clone()];
                    LagSignals::thinned(t_ns, models, LAG_DECIMATION)
                })
            })
            .as_ref()
    }
}
