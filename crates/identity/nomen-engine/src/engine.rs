//! The streaming engine: ingest, settle, windows, evidence, assignment, output.

mod decide;
mod offsets;
mod rssi;
mod scoring;
mod tracks;

use crate::confidence::ConfidenceMap;
use crate::config::{EngineConfig, ns};
use crate::error::{EngineError, Result};
use crate::lag_memo::ImuLagMemo;
use crate::signal::ImuSeries;
use crate::stats::EngineStats;
use crate::tags::{Fix, Height, MAX_PAIR_DT_NS, TagState, corrected_position, fix_sigma_m};
use crate::time_queue::TimeQueue;
use decide::pooled_mean;
use nalgebra::{Isometry3, Matrix3, Point3, UnitQuaternion, Vector3};
use nomen_core::skeleton::{JointState, Joints};
use nomen_core::{
    AntennaId, CameraId, Candidate, ClockModel, DecisionRule, DecisionTrace, DeviceId, DeviceKind,
    Evidence, IdentifiedSkeleton, Identity, ImuSample, Joint, Message, Registry, RssiRead, RtlsFix,
    SessionTime, SkeletonObservation, SubjectId, TagCorrection, TrackId, UwbRange,
};
use nomen_evidence::PairScorer;
use nomen_evidence::belmonte::axis_pitches_rad;
use nomen_evidence::features::axis_elevations_rad;
use nomen_filters::kalman::JointSmoother;
use nomen_filters::median;
use nomen_filters::orientation::{Madgwick, level_from_accel};
use nomen_rssi::RssiModel;
use nomen_rtls::{EpochConfig, EpochStats, RangeEpochs};
use rssi::{RssiEvidence, RssiPair};
use scoring::key_joint_near;
use std::cell::Cell;
use std::collections::{BTreeMap, BTreeSet, HashMap, VecDeque};

/// Step of the clock-offset search, ns (one IMU sample at 100 Hz).
const LAG_STEP_NS: i64 = 10_000_000;

/// Common frame times of two cameras' views of a person: at most this far apart (under half a
/// frame at 30 Hz).
const CAMERA_PAIR_MAX_DT_NS: i64 = 16_000_000;

/// Fewest common frame times over which two cameras' tracks may be found to show the same person (a
/// sixth of a second at 30 Hz), and fewest settled frames for a track to take part at all (as a
/// partner or as a rival that makes a pairing ambiguous). A camera's fresh track after an occlusion
/// is named from the other camera's view of the person as soon as this many frames match, so fewer
/// frames name it sooner; 5 are enough to tell the views apart.
const CAMERA_PAIR_MIN_FRAMES: usize = 5;

/// How far back two cameras' tracks are compared, in evidence windows: long enough to hold
/// the whole of a short track whose frames are still being decided.
const CAMERA_PAIR_LOOKBACK_WINDOWS: i64 = 2;

/// A track seen this recently before a decision's end may still be in view after it (three
/// frames at 30 Hz).
const ALIVE_AT_END_NS: i64 = 100_000_000;

/// Longest chain of stitched tracks [`Engine::successors_name`] follows for a name.
const MAX_SUCCESSORS: usize = 16;

/// Another camera's view of a track's person names the track's observations up to this long after
/// the view's last one, ns. Its name (or its successor's) at the time of sending may be a later
/// decision's about someone else: a person without a tag whose track kept the view it had been
/// paired with would take that view's later name, given to someone else, a second or two after the
/// view ended.
const VIEW_NAMES_AFTER_END_NS: i64 = 1_000_000_000;

/// A search for an unknown offset first steps this many [`LAG_STEP_NS`] at a time (40 ms: ten
/// points per 0.4–0.5 s stride period, so the coarse curve still shows every stride peak), then
/// refines around its peak at [`LAG_STEP_NS`].
const COARSE_LAG_STEPS: usize = 4;

/// The coarse lag curves (every [`COARSE_LAG_STEPS`]-th lag, over the whole offset range) pair
/// every this-many-th of the lag search's track samples with the IMU: 7.5 Hz from a 30-Hz camera,
/// still above twice the 3-Hz low-pass the models are smoothed with, and the fine curve around each
/// coarse peak pairs them all. It saves about a tenth of the engine's instructions with offsets
/// searched (`cargo bench -p nomen-engine`) and finds the same clock offsets; every third sample
/// (10 Hz) saves more but finds them less exactly and names fewer frames right.
const COARSE_TRACK_STRIDE: usize = 2;

/// Longest gap between two IMU samples across which the engine interpolates, ns (a dropout of
/// a few packets at 50–100 Hz; longer gaps are missing data).
const MAX_IMU_GAP_NS: i64 = 60_000_000;

/// Longest gap the engine interpolates across for an IMU whose samples are `t_ns`: 1.9 times
/// their mean interval (a slow watch at 10–12.5 Hz has 80–100 ms between samples), and at
/// least [`MAX_IMU_GAP_NS`], which is what every IMU of 35 Hz or more gets.
fn max_imu_gap_ns(t_ns: &[i64]) -> i64 {
    match (t_ns.first(), t_ns.last()) {
        (Some(&first), Some(&last)) if t_ns.len() > 1 => {
            let mean_ns = (last - first) / (t_ns.len() as i64 - 1);
            MAX_IMU_GAP_NS.max(mean_ns.saturating_mul(19) / 10)
        }
        _ => MAX_IMU_GAP_NS,
    }
}

/// The lag search correlates every this-many-th camera sample (15 Hz from 30 Hz): its signals
/// are low-passed at 3 Hz or smoothed over longer spans, so half the samples carry the same
/// curve at half the cost.
const LAG_DECIMATION: usize = 2;

/// The IMU side of the lag search keeps every n-th sample, n the largest that leaves it at least
/// this rate, Hz, for the same reason: 33 Hz from 100 Hz (n = 3), still above the track's 15 Hz;
/// 50 Hz from 50 Hz. Each IMU's n is fixed from its rate when its orientation filter first starts
/// ([`imu_lag_step`]). A fixed n = 3 would leave a 50-Hz IMU at 17 Hz, where interpolating the lag
/// curve's shifts between samples 60 ms apart moves the peaks (clock offsets about twice as far
/// off, and a 25-Hz band's offset not found at all).
const IMU_LAG_MIN_RATE_HZ: f64 = 30.0;

/// The lag search's IMU step (see [`IMU_LAG_MIN_RATE_HZ`]) for samples `dt_ns` apart on
/// median: at least 1.
fn imu_lag_step(dt_ns: i64) -> usize {
    if dt_ns <= 0 {
        return 1;
    }
    let rate_hz = 1e9 / dt_ns as f64;
    ((rate_hz / IMU_LAG_MIN_RATE_HZ).floor() as usize).max(1)
}

/// A track observed more than this after the newest sample of a subject's IMUs, while none of them
/// has sent anything for a whole window, loses its motion evidence for that subject, ns. The wearer
/// left or took the bands off: an accumulated score is a mean that only moves when a window scores
/// the pair, so it would stay as it was, and a look-alike who stayed would keep the departed
/// wearer's name. The slack keeps the wearer's own last frames, decided a window later.
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
/// time; the observation after an SDK swap jumps 0.36–1.8 m onto the other person). A jump beyond
/// this allowance only counts as a swap when it lands near another track's last observation, so the
/// allowance can sit below the frame-to-frame spread: 0.08 m also undoes swaps between people a
/// step apart, or after the track was unseen for 0.1–0.5 s, without exchanging tracks wrongly,
/// which a tighter allowance starts to do...
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

/// Refuses a message stamped more than `max_ns` ahead of every time seen so far, unless the
/// message of its source before it was refused for that too and lies before it, less than
/// `max_ns` earlier, and no message since (of any source) was at the old time: a corrupt
/// timestamp is refused, and a session resuming after a general silence is followed from each
/// source's second message on. A source whose stamps jump while the others go on where they
/// were contradicts them: each of its messages is refused (two corrupt frames in a row, with
/// the other sources' samples between them, are two refusals, not a jump taken that would
/// leave every later frame of that camera late). Messages at the same time as the refused one
/// (a camera frame's other tracks) are refused as well: they are the same frame, not a second
/// one.
struct TimeJumpGuard {
    max_ns: i64,
    /// Per source, the time of its last message, if that was refused as a jump.
    refused: BTreeMap<String, i64>,
}

/// Where the session's first message stands (see [`Engine::push`]).
enum FirstMessage {
    /// Nothing the engine would take has come yet.
    Awaited,
    /// The first message (and its session time), waiting for the next one.
    Held(Box<Message>, i64),
    /// Taken or dropped: every message is checked against the ones before it.
    Taken,
}

/// The id a refusal names for `msg`'s source (a device, camera or `tag@antenna`).
fn message_source(msg: &Message) -> String {
    match msg {
        Message::Imu(s) => s.device.to_string(),
        Message::Skeleton(s) => s.camera.to_string(),
        Message::RtlsFix(f) => f.tag.to_string(),
        Message::Rssi(r) => rssi_source(r),
        other => other.type_name().to_string(),
    }
}

/// The source an RSSI read's refusals name: `tag@antenna`.
fn rssi_source(r: &RssiRead) -> String {
    format!("{}@{}", r.tag, r.antenna)
}

impl TimeJumpGuard {
    fn new(max_ns: i64) -> Self {
        Self {
            max_ns,
            refused: BTreeMap::new(),
        }
    }

    /// Checks a message of `source` at session time `t` (stamped `stamp`) against `newest`,
    /// the newest session time so far.
    fn check(
        &mut self,
        newest: Option<i64>,
        kind: &'static str,
        source: &str,
        t: i64,
        stamp: SessionTime,
    ) -> Result<()> {
        let ahead_ns = newest.map_or(0, |n| t.saturating_sub(n));
        if ahead_ns <= self.max_ns {
            // A message at the old time: no jump waiting for confirmation is confirmed by it,
            // and the sources that jumped are contradicted. (Most messages find nothing to
            // clear.)
            if !self.refused.is_empty() {
                self.refused.clear();
            }
            return Ok(());
        }
        if let Some(&before) = self.refused.get(source)
            && before < t
            && t - before <= self.max_ns
        {
            self.refused.remove(source);
            return Ok(());
        }
        self.refused.insert(source.to_string(), t);
        Err(EngineError::TimeJump {
            kind,
            source_id: source.to_string(),
            t: stamp,
            ahead_s: ahead_ns as f64 * 1e-9,
        })
    }
}

struct CameraState {
    id: CameraId,
    world_from_camera: Isometry3<f64>,
    /// Metres per camera-frame unit: a joint `p` is at `world_from_camera * (scale · p)`.
    scale: f64,
    /// The registry's clock of the camera: a frame stamped `t` is at `clock.to_session(t)`.
    clock: ClockModel,
    newest: Option<i64>,
    frontier: i64,
    /// The first distinct frame times settled, until there are [`CAMERA_RATE_FRAMES`].
    first_frame_times: Vec<i64>,
    /// The camera's frame rate over [`REFERENCE_CAMERA_RATE_HZ`], fixed from the median
    /// interval of its first frames (`None` before: taken as 1). Sample counts of the
    /// correlations' configs, set for a 30-Hz camera, are scaled by it
    /// ([`Engine::camera_geometric`]).
    rate_scale: Option<f64>,
    /// Whether a settled skeleton of the camera has had an inferred joint (a depth SDK's
    /// guess for an occluded one), and the time of its first settled skeleton.
    reports_inferred: bool,
    first_settled_ns: Option<i64>,
    /// The camera's settled skeletons have carried no inferred joint for
    /// [`UNINFERRED_CAMERA_NS`] from its first: it drops occluded joints instead, and its
    /// joints' gaps are filled ([`EngineConfig::joint_gap_bridge_s`]).
    is_uninferred: bool,
}

/// How long a camera's settled skeletons must have carried no inferred joint before the
/// camera is taken for a pose estimator that drops occluded joints, ns. A depth SDK reports
/// some within a second or two of people moving about.
const UNINFERRED_CAMERA_NS: i64 = 2_000_000_000;

/// The camera rate the sample counts of [`nomen_evidence::GeometricConfig`] and
/// [`nomen_evidence::BelmonteConfig`] (`min_samples`, `moving_average_len`) are set for, Hz. A
/// camera at another rate gets them scaled, so that they span the same time: a correlation needs
/// 1 s of samples, the lag search 2 s. Unscaled, a 15-Hz camera's 2-s window would hold 30 samples
/// at most, all of which a correlation needs, and far fewer frames would be named.
const REFERENCE_CAMERA_RATE_HZ: f64 = 30.0;

/// Votes an `either_side` IMU needs before its side is reported: one per window and track
/// named after its wearer that compared it at both sites at its accepted offset (10 s at the
/// default hop with one such track in view), each the fit at one site less the fit at the
/// other.
const SIDE_MIN_VOTES: u32 = 20;

/// The mean vote, correlation units, by which one site must lead for the side to be reported.
const SIDE_MIN_MEAN_VOTE: f64 = 0.05;

/// Distinct frame times a camera's rate is estimated from (half a second at 30 Hz).
const CAMERA_RATE_FRAMES: usize = 16;

/// Fewest samples a track needs in a window to be scored there, at 30 Hz (0.27 s), scaled to
/// the camera's rate like the models' counts ([`scaled_count`]). Counted in samples at every
/// rate, the floor would be twice as long at 15 Hz and half as long at 60 Hz.
const WINDOW_MIN_TRACK_SAMPLES: usize = 8;

/// Fewest samples a track needs in the clock search's buffer to be searched, at 30 Hz
/// (0.53 s), scaled to the camera's rate as [`WINDOW_MIN_TRACK_SAMPLES`].
const LAG_MIN_TRACK_SAMPLES: usize = 16;

/// The median interval between consecutive `times`, ns (`None` with fewer than two): a
/// stream's sampling period, which a lost sample or a gap does not move.
fn median_interval_ns(times: &[i64]) -> Option<f64> {
    let mut intervals: Vec<f64> = times
        .windows(2)
        .filter_map(|w| match w {
            [a, b] => Some((b - a) as f64),
            _ => None,
        })
        .collect();
    median(&mut intervals)
}

/// `n` samples set for a 30-Hz camera, for a camera at `scale` times that rate: at least 1,
/// and `n` itself at 1 or for `scale` 1.
fn scaled_count(n: usize, scale: f64) -> usize {
    if n <= 1 || scale == 1.0 || !scale.is_finite() || scale <= 0.0 {
        return n;
    }
    ((n as f64 * scale).round() as usize).max(1)
}

/// Three numbers per settled IMU sample computed from its orientation alone, the first time a
/// window's grid reads them and kept for the windows after: a 30-Hz camera's grid takes one in
/// three of a 100-Hz IMU's orientations, so most are never read.
struct OrientationTerms {
    /// Per settled sample (aligned with [`ImuState::t`]), its terms once read.
    values: VecDeque<Cell<Option<[f64; 3]>>>,
    of: fn(&UnitQuaternion<f64>) -> [f64; 3],
}

impl OrientationTerms {
    fn new(of: fn(&UnitQuaternion<f64>) -> [f64; 3]) -> Self {
        Self {
            values: VecDeque::new(),
            of,
        }
    }

    /// A newly settled sample, its terms not computed yet.
    fn push(&mut self) {
        self.values.push_back(Cell::new(None));
    }

    /// The terms of settled sample `k`, whose orientation is `world_from_sensor[k]`: computed
    /// at the first read. `None` past the samples.
    fn get(&self, k: usize, world_from_sensor: &[UnitQuaternion<f64>]) -> Option<[f64; 3]> {
        let cell = self.values.get(k)?;
        if let Some(terms) = cell.get() {
            return Some(terms);
        }
        let terms = (self.of)(world_from_sensor.get(k)?);
        cell.set(Some(terms));
        Some(terms)
    }
}

struct ImuState {
    device: DeviceId,
    subject: usize,
    site: Joint,
    /// The other side an IMU registered with `either_side` may be on: every comparison is made
    /// with both and keeps the better ([`ImuState::sides`]).
    mirror_site: Option<Joint>,
    /// The sum, over windows and tracks named after its wearer that scored the IMU at its
    /// accepted offset, of the fit at `site` less the fit at `mirror_site`, and their number.
    side_votes: f64,
    num_side_votes: u32,
    /// Whether the device has a gyroscope: `None` until its first sample says (see
    /// [`Engine::push_imu`]). An accelerometer-only IMU's gyroscope values are `NaN`, and its
    /// orientation is its gravity frame ([`gravity_frame`]).
    has_gyro: Option<bool>,
    /// An accelerometer-only IMU's low-passed specific force (its estimate of gravity) and the
    /// device time of its last sample (see [`gravity_frame`]).
    gravity_mps2: Option<(i64, Vector3<f64>)>,
    /// Received, not yet settled: device time → (accel, gyro).
    pending: TimeQueue<(Vector3<f64>, Vector3<f64>)>,
    /// Settled samples, device time, increasing.
    t: VecDeque<i64>,
    /// Specific force, sensor frame, m/s².
    accel: VecDeque<Vector3<f64>>,
    /// Angular rate, sensor frame, rad/s.
    gyro: VecDeque<Vector3<f64>>,
    /// Madgwick's `world_from_sensor` after each sample.
    world_from_sensor: VecDeque<UnitQuaternion<f64>>,
    /// Per sample, the elevation of the sensor's axes
    /// ([`nomen_evidence::features::axis_elevations_rad`] of `world_from_sensor`), which every
    /// window grid that takes the sample's orientation reads.
    axis_elevation_rad: OrientationTerms,
    /// Whether windows build Belmonte-Hernández's band signals for this IMU (a forearm site,
    /// and [`EngineConfig::wants_belmonte`]).
    wants_band_pitch: bool,
    /// Per sample when `wants_band_pitch` (empty otherwise), the band pitches of the sensor's
    /// +axes ([`nomen_evidence::belmonte::axis_pitches_rad`]).
    axis_pitch_rad: OrientationTerms,
    /// Settled samples forgotten so far: the stream index of `t[0]`.
    num_forgotten: usize,
    /// The lag search's signals kept from one window to the next.
    lag_memo: ImuLagMemo,
    /// The lag search keeps every this-many-th sample ([`imu_lag_step`]), fixed from the
    /// samples' rate when the orientation filter first starts (`None` before).
    lag_step: Option<usize>,
    newest: Option<i64>,
    frontier: i64,
    ahrs: Option<Madgwick>,
    /// Device time of the last sample through `ahrs` (`None`: it has just started).
    ahrs_last_ns: Option<i64>,
    offset_ns: i64,
    is_offset_known: bool,
    last_refine_end: i64,
    /// The offset the last refinement left, and how many refinements in a row left it within
    /// 30 ms of where it was (see [`EngineConfig::offset_refine_max_interval_s`]).
    refined: Option<(i64, u32)>,
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
    /// Sum and count, per lag of the coarse grid around the registry's offset, of the best
    /// value over all candidate tracks of this IMU's lag curves, one pass per
    /// `offset_best_track_interval_s` (see [`Engine::update_offsets`]).
    best_track_curve: Vec<(f64, usize)>,
    /// Passes summed into `best_track_curve`.
    num_best_track_curves: usize,
    /// The votes of the latest passes of [`Engine::move_to_unexplained_peaks`] to move the
    /// accepted offset (`None`: no vote that pass), oldest first.
    unexplained_votes: VecDeque<Option<i64>>,
    /// The peak correlation the latest refinement found around the accepted offset (`None`:
    /// no peak, or no refinement yet); refinements with no labelled track to read leave it.
    refine_peak: Option<f64>,
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
    /// The sites the IMU is compared at: its own, and the mirror image it may be on instead
    /// (an IMU registered with `either_side`).
    fn sides(&self) -> (Joint, Option<Joint>) {
        (self.site, self.mirror_site)
    }

    /// The phase of the heading sums as a unit complex number `(re, im)`, once they span
    /// [`EngineConfig::heading_min_windows`] windows and agree to
    /// [`EngineConfig::heading_min_coherence`]; `None` before.
    fn heading(&self, config: &EngineConfig) -> Option<[f64; 2]> {
        // An accelerometer-only IMU's frame turns with the sensor: it has no heading.
        if self.has_gyro == Some(false) {
            return None;
        }
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

    /// Makes every buffer one slice. A ring that has wrapped is moved whole, so each keeps
    /// room for as many samples again as it holds: it then wraps once per buffer's worth of
    /// samples instead of once per the few hundred its capacity happened to spare (those moves
    /// would cost about 1 % of the engine's time).
    fn make_contiguous(&mut self) {
        fn contiguous<T>(ring: &mut VecDeque<T>) {
            if ring.capacity() < 2 * ring.len() {
                ring.reserve(ring.len());
            }
            ring.make_contiguous();
        }
        contiguous(&mut self.t);
        contiguous(&mut self.accel);
        contiguous(&mut self.gyro);
        contiguous(&mut self.world_from_sensor);
        contiguous(&mut self.axis_elevation_rad.values);
        contiguous(&mut self.axis_pitch_rad.values);
    }

    fn pop_front(&mut self) {
        if self.t.pop_front().is_some() {
            self.num_forgotten += 1;
        }
        self.accel.pop_front();
        self.gyro.pop_front();
        self.world_from_sensor.pop_front();
        self.axis_elevation_rad.values.pop_front();
        self.axis_pitch_rad.values.pop_front();
    }

    fn newest_session(&self) -> Option<i64> {
        self.newest.map(|t| t.saturating_add(self.offset_ns))
    }
}

struct TrackSample {
    t: i64,
    joints: Joints<Point3<f64>>,
    /// Joints (bit [`Joint::index`]) the smoother filled in a short gap, not observed.
    bridged: u32,
}

/// Exponentially weighted mean of one pair's window scores.
#[derive(Clone, Copy, Default)]
struct Accumulator {
    mean: f64,
    weight: f64,
}

/// One camera observation of a track waiting for the reorder window.
struct PendingFrame {
    joints_world_m: Joints<Point3<f64>>,
    /// The joints the camera reported as inferred.
    inferred: Joints<()>,
}

struct TrackState {
    pending: BTreeMap<i64, PendingFrame>,
    samples: VecDeque<TrackSample>,
    /// The joint filters (with their smoothers), one per [`Joint::ALL`].
    kalman: Vec<Option<JointSmoother>>,
    /// Samples settled since the smoothers last revised them ([`smooth_track`]).
    is_smoothing_due: bool,
    /// Earliest and newest observation times, session ns.
    first_t: i64,
    last_t: i64,
    /// Fused window scores per subject.
    evidence: BTreeMap<usize, Accumulator>,
    /// Location-tag window scores per subject (their own, faster half-life).
    tag_evidence: BTreeMap<usize, Accumulator>,
    /// RSSI scores per subject (tag half-life).
    rssi_evidence: BTreeMap<usize, Accumulator>,
    /// RSSI evidence per tag (index of [`RssiEvidence`]'s tags) that this track's person wears it.
    rssi_pairs: BTreeMap<usize, RssiPair>,
    /// Mean model score per IMU (reported as the evidence behind a label).
    device_evidence: BTreeMap<usize, Accumulator>,
    label: Option<usize>,
    /// The subject a location tag's or RSSI's evidence has named this track after with at
    /// least [`EngineConfig::tag_min_name_probability`]: that name is sent again however little
    /// it leads, any other such name only at that probability (a change of name needs a clear
    /// lead).
    confirmed_tag_name: Option<usize>,
    /// The rule behind `label` and the window end of that decision.
    decision: Decided,
    /// A subject whose move from this track to a coexisting one was held back (see
    /// [`Engine::hold_back_unsynced_names`]): this track still holds it for that rule while
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
    /// The later track that continues this one (stitched): this one no longer takes part in
    /// decisions, unless it is seen again, and while anonymous its observations still waiting
    /// to be sent take the name of the first named track of that chain
    /// ([`Engine::successors_name`]).
    superseded_by: Option<TrackKey>,
    /// Other cameras' tracks showing this track's person: those paired with it at the latest
    /// decision it took part in ([`Engine::camera_partners`]), then those found earlier that
    /// the decisions could not compare with it since (too few common frames, or the view has
    /// ended), including the view that [`Engine::view_from_other_camera`] found when this track
    /// was new. A view the decisions compared and did not pair is dropped. See
    /// [`Engine::name_from_elsewhere`].
    views: Vec<TrackKey>,
    /// This track's decisions while the warm-up's observations wait for theirs: window end,
    /// name (subject, score without the hysteresis bonus) and whether the decision is final
    /// (named after someone whose clock is known, [`Engine::is_name_final`], or anonymous
    /// without holding a withheld name); see [`Engine::emit`] and
    /// [`EngineConfig::warmup_sync_s`].
    warm_labels: Vec<WarmDecision>,
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

/// A track's decision during the warm-up (see [`TrackState::warm_labels`]).
#[derive(Debug, Clone, Copy)]
struct WarmDecision {
    end: i64,
    name: Option<(usize, f64)>,
    rule: DecisionRule,
    is_final: bool,
}

/// The rule of a track's latest decision and that decision's window end (session ns).
#[derive(Debug, Clone, Copy)]
struct Decided {
    rule: DecisionRule,
    end: i64,
}

/// The subject with the highest score other than `except` (the lower index on a tie).
fn best_of(scores: &BTreeMap<usize, f64>, except: Option<usize>) -> Option<(usize, f64)> {
    scores
        .iter()
        .filter(|(s, _)| except != Some(**s))
        .max_by(|a, b| a.1.total_cmp(b.1).then(b.0.cmp(a.0)))
        .map(|(s, v)| (*s, *v))
}

impl TrackState {
    /// Its label, with that subject's score at the latest decision (without the hysteresis
    /// bonus).
    fn named(&self) -> Option<(usize, f64)> {
        self.label
            .map(|s| (s, self.subject_scores.get(&s).copied().unwrap_or(0.0)))
    }
}

/// Device name → index into the engine's IMUs or tags.
type DeviceIndex = HashMap<DeviceId, usize, foldhash::fast::RandomState>;

/// The streaming identity engine. See the crate documentation for the pipeline and latency.
pub struct Engine {
    config: EngineConfig,
    /// [`EngineConfig::confidence_map`], or the map fitted for its motion score.
    confidence_map: ConfidenceMap,
    window_ns: i64,
    hop_ns: i64,
    reorder_ns: i64,
    silence_ns: i64,
    delay_ns: i64,
    decay_per_hop: f64,
    /// Per-hop decay of the motion evidence of a subject wearing several IMUs once one of their
    /// clock offsets is accepted ([`EngineConfig::network_evidence_half_life_s`]).
    network_decay_per_hop: f64,
    tag_decay_per_hop: f64,
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
    /// Looked up once per sample and never iterated, so hashed: a B-tree of 40 device names
    /// costs about 3 % of a steady-state run, and the standard library's SipHash about 1 %;
    /// foldhash (randomly seeded as well) costs a tenth of that.
    imu_index: DeviceIndex,
    tags: Vec<TagState>,
    tag_index: DeviceIndex,
    /// Per tag: whether it has sent a fix of its own (its raw ranges are then ignored).
    tags_report_fixes: Vec<bool>,
    /// Raw UWB ranges grouped into ranging cycles and multilaterated, for tags without fixes.
    range_epochs: RangeEpochs,
    /// A learned scorer of (IMU window, skeleton window) pairs ([`Engine::with_pair_scorer`]).
    pair_scorer: Option<Box<dyn PairScorer>>,
    /// RSSI evidence, when the registry has antennas and RSSI tags: with the fitted default
    /// model, or a calibrated one ([`Engine::with_rssi_model`]).
    rssi: Option<RssiEvidence>,
    /// The registry's antennas.
    antennas: BTreeSet<AntennaId>,
    /// Subject and site of every RFID/BLE tag, for RSSI reads.
    rssi_tags: BTreeMap<DeviceId, (usize, Joint)>,
    /// The registry's clock of every RFID/BLE tag: a read stamped `t` is at
    /// `clock.to_session(t)`.
    rssi_clocks: BTreeMap<DeviceId, ClockModel>,
    /// The kind of every registered device (for clear errors on mismatched messages).
    device_kinds: BTreeMap<DeviceId, DeviceKind>,
    tracks: BTreeMap<(usize, TrackId), TrackState>,
    pending_out: BTreeSet<(i64, usize, TrackId)>,
    /// Time of the session's first accepted skeleton, for the warm-up.
    first_frame_t: Option<i64>,
    /// [`EngineConfig::warmup_s`], ns.
    warmup_ns: i64,
    /// [`EngineConfig::warmup_sync_s`], ns.
    warmup_sync_ns: i64,
    /// The window end at which the warm-up's observations were sent, once reached.
    warm_release: Option<i64>,
    /// The latest decision's window end at which more people were in view than subjects whose
    /// wearables stream ([`EngineConfig::open_set_min_name_probability`]).
    open_set_seen_at: Option<i64>,
    /// The recent decisions' window ends that saw more people than streaming subjects.
    surplus_ends: VecDeque<i64>,
    /// Whether the latest decision counts the room as holding people who wear nothing.
    is_open_set: bool,
    next_end: Option<i64>,
    global_max: Option<i64>,
    /// Which [`DATA_SLOT_NS`]-long slots of session time hold a message, from where a window
    /// could still read on: for [`Engine::skip_idle`].
    data_slots: BTreeSet<i64>,
    /// The slots of the last messages noted, the newest first, so that a message in one of
    /// them costs no insert (sources on clocks a little apart alternate between two slots).
    recent_slots: [Option<i64>; 2],
    /// How far before its end a window may read anything, ns, generously (see
    /// [`Engine::skip_idle`]).
    idle_lookback_ns: i64,
    /// How far before the next data a window may still be skipped, ns.
    idle_lookahead_ns: i64,
    /// Refuses messages stamped implausibly far ahead of `global_max`.
    time_jumps: TimeJumpGuard,
    /// The session's first message, held until the next one vouches for its time.
    first: FirstMessage,
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
        let mut imu_index = DeviceIndex::default();
        let mut tags = Vec::new();
        let mut tag_index = DeviceIndex::default();
        let mut device_kinds = BTreeMap::new();
        let mut rssi_tags = BTreeMap::new();
        let mut rssi_clocks = BTreeMap::new();
        let mut subject_imus = Vec::new();
        for (s, subject) in registry.subjects.iter().enumerate() {
            let mut mine = Vec::new();
            for w in &subject.wears {
                device_kinds.insert(w.device.clone(), w.kind);
                if matches!(w.kind, DeviceKind::UwbTag | DeviceKind::BleTag) {
                    tag_index.insert(w.device.clone(), tags.len());
                    tags.push(TagState::new(w.device.clone(), s, w.site, w.clock));
                }
                if matches!(w.kind, DeviceKind::RfidTag | DeviceKind::BleTag) {
                    rssi_tags.insert(w.device.clone(), (s, w.site));
                    rssi_clocks.insert(w.device.clone(), w.clock);
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
                    mirror_site: (w.either_side && w.site.mirrored() != w.site)
                        .then(|| w.site.mirrored()),
                    side_votes: 0.0,
                    num_side_votes: 0,
                    has_gyro: None,
                    gravity_mps2: None,
                    pending: TimeQueue::default(),
                    t: VecDeque::new(),
                    accel: VecDeque::new(),
                    gyro: VecDeque::new(),
                    world_from_sensor: VecDeque::new(),
                    axis_elevation_rad: OrientationTerms::new(axis_elevations_rad),
                    wants_band_pitch: config.wants_belmonte()
                        && scoring::band_side(w.site).is_some(),
                    axis_pitch_rad: OrientationTerms::new(axis_pitches_rad),
                    num_forgotten: 0,
                    lag_memo: ImuLagMemo::default(),
                    lag_step: None,
                    newest: None,
                    frontier: i64::MIN,
                    ahrs: None,
                    ahrs_last_ns: None,
                    offset_ns: w.clock.offset_ns,
                    is_offset_known: config.known_clock_offsets,
                    last_refine_end: i64::MIN,
                    refined: None,
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
                    unexplained_votes: VecDeque::new(),
                    refine_peak: None,
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
                scale: c.scale,
                clock: c.clock,
                newest: None,
                frontier: i64::MIN,
                first_frame_times: Vec::new(),
                rate_scale: None,
                reports_inferred: false,
                first_settled_ns: None,
                is_uninferred: false,
            })
            .collect();
        let camera_index = cameras
            .iter()
            .enumerate()
            .map(|(i, c)| (c.id.clone(), i))
            .collect();
        // Only IMUs and RSSI tags need the warm-up (IMU windows fill and their clocks are found,
        // reads accumulate); a location tag's first fixes can name its wearer.
        let needs_warmup = !imus.is_empty() || !rssi_tags.is_empty();
        Ok(Engine {
            confidence_map: config
                .confidence_map
                .unwrap_or_else(|| ConfidenceMap::fitted(config.motion_score)),
            window_ns: ns(config.window_s),
            hop_ns: ns(config.hop_s),
            reorder_ns: ns(config.reorder_window_s),
            silence_ns: ns(config.silence_timeout_s),
            delay_ns: ns(config.decision_delay_s),
            decay_per_hop: 0.5f64.powf(config.hop_s / config.evidence_half_life_s),
            network_decay_per_hop: 0.5f64.powf(config.hop_s / config.network_evidence_half_life_s),
            tag_decay_per_hop: 0.5f64.powf(config.hop_s / config.tag_evidence_half_life_s),
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
            tags_report_fixes: vec![false; tags.len()],
            range_epochs: RangeEpochs::new(&registry.anchors, EpochConfig::default()),
            tags,
            tag_index,
            rssi: (!registry.antennas.is_empty() && !rssi_tags.is_empty()).then(|| {
                RssiEvidence::new(
                    RssiModel::fitted_default(&registry.antennas),
                    false,
                    &rssi_tags,
                    &config,
                )
            }),
            pair_scorer: None,
            antennas: registry.antennas.iter().map(|a| a.id.clone()).collect(),
            rssi_tags,
            rssi_clocks,
            device_kinds,
            tracks: BTreeMap::new(),
            pending_out: BTreeSet::new(),
            first_frame_t: None,
            warmup_ns: if needs_warmup { ns(config.warmup_s) } else { 0 },
            warmup_sync_ns: ns(config.warmup_sync_s),
            warm_release: None,
            open_set_seen_at: None,
            surplus_ends: VecDeque::new(),
            is_open_set: false,
            next_end: None,
            global_max: None,
            data_slots: BTreeSet::new(),
            recent_slots: [None; 2],
            idle_lookback_ns: ns(config.window_s
                + config.history_pad_s
                + config.offset_estimation_window_s
                + 4.0 * config.max_clock_offset_s
                + config.tag_window_s
                + config.track_timeout_s
                + config.stitch_max_gap_s
                + config.stitch_velocity_span_s
                + config.silence_timeout_s
                + 2.0 * config.hop_s)
            .saturating_add(DATA_SLOT_NS),
            idle_lookahead_ns: ns(2.0 * config.hop_s
                + 4.0 * config.max_clock_offset_s
                + config.reorder_window_s
                + config.silence_timeout_s)
            .saturating_add(DATA_SLOT_NS),
            time_jumps: TimeJumpGuard::new(ns(config.max_time_jump_s)),
            first: FirstMessage::Awaited,
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

    /// Lays an updated calibration over the running engine (a calibration refined online,
    /// `nomen run --calibrate auto`): each camera it names takes its pose and scale for the
    /// skeletons pushed from now on, each location tag its clock for the fixes pushed from
    /// now on (a fix the new clock puts before what the tag has settled is refused as late).
    /// A camera's clock cannot change in a running engine (its frames would move in time):
    /// a calibration that changes one is refused, as is one that names a camera or location
    /// tag the registry does not have; a refused calibration changes nothing.
    pub fn update_calibration(&mut self, calibration: &nomen_core::Calibration) -> Result<()> {
        let refuse = |why: String| Err(EngineError::Registry(nomen_core::CoreError::Invalid(why)));
        let mut camera_updates = Vec::with_capacity(calibration.cameras.len());
        for c in &calibration.cameras {
            let Some(i) = self.camera_index.get(&c.id).copied() else {
                return refuse(format!(
                    "the calibration has camera '{}', which the engine does not know",
                    c.id
                ));
            };
            let Some(camera) = self.cameras.get(i) else {
                return refuse(format!("camera '{}' has no state", c.id));
            };
            if c.clock.is_some_and(|k| k != camera.clock) {
                return refuse(format!(
                    "the calibration changes the clock of camera '{}', which a running engine keeps",
                    c.id
                ));
            }
            let world_from_camera = match c.world_from_camera {
                Some(t) => {
                    t.validate(&format!("camera '{}'.world_from_camera", c.id))
                        .map_err(EngineError::Registry)?;
                    t.to_isometry()
                }
                None => camera.world_from_camera,
            };
            let scale = c.scale.unwrap_or(camera.scale);
            let (lo, hi) = nomen_core::registry::CAMERA_SCALE_RANGE;
            if !(lo..=hi).contains(&scale) {
                return refuse(format!(
                    "camera '{}': scale {scale} is outside {lo}..={hi}",
                    c.id
                ));
            }
            camera_updates.push((i, world_from_camera, scale));
        }
        let mut tag_updates = Vec::with_capacity(calibration.devices.len());
        for d in &calibration.devices {
            let Some(i) = self.tag_index.get(&d.device).copied() else {
                return refuse(format!(
                    "the calibration has device '{}', which is no location tag of the engine",
                    d.device
                ));
            };
            tag_updates.push((i, d.clock));
        }
        for (i, world_from_camera, scale) in camera_updates {
            if let Some(camera) = self.cameras.get_mut(i) {
                camera.world_from_camera = world_from_camera;
                camera.scale = scale;
            }
        }
        for (i, clock) in tag_updates {
            if let Some(tag) = self.tags.get_mut(i) {
                tag.clock = clock;
            }
        }
        Ok(())
    }

    /// Scores RSSI reads with a calibrated model (`nomen calibrate rssi`) instead of the fitted
    /// default ([`RssiModel::fitted_default`]); gains are refined online either way. Errors when
    /// the model does not validate or names an antenna the registry does not list.
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
        self.rssi = Some(RssiEvidence::new(
            model.clone(),
            true,
            &self.rssi_tags,
            &self.config,
        ));
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

    /// Ingests one message. A bad message (invalid numbers, unknown source, duplicate, late,
    /// stamped too far ahead) is rejected with an error and counted; the engine keeps running.
    /// Message types the engine does not use are accepted and ignored.
    ///
    /// The session's first message has nothing to be checked against, so it waits for the next
    /// valid one from a known source: if that is stamped more than
    /// [`EngineConfig::max_time_jump_s`] before it, the first was a corrupt timestamp and is
    /// dropped (counted as a time jump, with the reason in
    /// [`EngineStats::first_message_dropped`](crate::EngineStats::first_message_dropped));
    /// otherwise it is taken just before the second. Without this, a first message stamped an
    /// hour ahead would make every later message of its source late. [`Engine::finish`] takes
    /// a first message that nothing followed.
    pub fn push(&mut self, msg: &Message) -> Result<()> {
        self.stats.num_messages += 1;
        // The session's first message has no earlier time to be checked against: it waits for
        // the next one that could vouch for it (see `EngineConfig::max_time_jump_s`).
        match std::mem::replace(&mut self.first, FirstMessage::Taken) {
            FirstMessage::Taken => {}
            FirstMessage::Awaited => match self.vouching_time(msg) {
                Some(t) => {
                    self.first = FirstMessage::Held(Box::new(msg.clone()), t);
                    return Ok(());
                }
                None => self.first = FirstMessage::Awaited,
            },
            FirstMessage::Held(first, first_t) => match self.vouching_time(msg) {
                None => self.first = FirstMessage::Held(first, first_t),
                Some(t) if first_t.saturating_sub(t) > self.time_jumps.max_ns => {
                    self.stats.rejected.num_time_jump += 1;
                    self.stats.first_message_dropped = Some(format!(
                        "the session's first message, {} from '{}' at {}, was stamped {:.1} s \
                         after the next one; dropped as a time jump",
                        first.type_name(),
                        message_source(&first),
                        first.t(),
                        first_t.saturating_sub(t) as f64 * 1e-9
                    ));
                }
                Some(_) => {
                    // Taken as if pushed now; nothing is in the engine yet to refuse it.
                    let _ = self.ingest(&first);
                }
            },
        }
        self.ingest(msg)
    }

    /// The session time of `msg` if it is a message the engine would take at the start of a
    /// session (of a kind it uses, from a known source, with valid values); `None` otherwise.
    fn vouching_time(&self, msg: &Message) -> Option<i64> {
        // Session time is the stamp on its source's clock (an IMU's at its current offset).
        let t = msg.t().as_ns();
        let session = match msg {
            Message::Imu(s) => t.saturating_add(
                self.imu_index
                    .get(&s.device)
                    .and_then(|&i| self.imus.get(i))?
                    .offset_ns,
            ),
            Message::Skeleton(s) => {
                let &c = self.camera_index.get(&s.camera)?;
                self.cameras.get(c)?.clock.to_session(t).as_ns()
            }
            Message::RtlsFix(f) => {
                let &i = self.tag_index.get(&f.tag)?;
                self.tags.get(i)?.clock.to_session(t).as_ns()
            }
            Message::Rssi(r) if self.rssi.is_some() && self.antennas.contains(&r.antenna) => {
                self.rssi_clocks.get(&r.tag)?.to_session(t).as_ns()
            }
            _ => return None,
        };
        msg.validate().is_ok().then_some(session)
    }

    /// [`Engine::push`] after the first message's check: takes `msg` or counts its refusal.
    fn ingest(&mut self, msg: &Message) -> Result<()> {
        let result = match msg {
            Message::Imu(s) => self.push_imu(s),
            Message::Skeleton(s) => self.push_skeleton(s),
            Message::RtlsFix(f) => {
                let result = self.push_fix(f);
                if result.is_ok()
                    && let Some(reports) = self
                        .tag_index
                        .get(&f.tag)
                        .and_then(|&i| self.tags_report_fixes.get_mut(i))
                {
                    *reports = true;
                }
                result
            }
            Message::Rssi(r) => self.push_rssi(r),
            Message::UwbRange(r) => self.push_range(r),
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
                EngineError::TimeJump { .. } => r.num_time_jump += 1,
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
        let session = t.saturating_add(imu.offset_ns);
        self.time_jumps
            .check(self.global_max, "imu", s.device.as_str(), session, s.t)?;
        // A device either always or never sends its angular rate: its first sample says which,
        // and a sample that says otherwise is refused (its orientation would be a mix of two
        // models).
        let has_gyro = s.gyro_radps.is_some();
        if imu.has_gyro.is_none() && !has_gyro {
            self.stats.accel_only_imus.push(s.device.clone());
        }
        if *imu.has_gyro.get_or_insert(has_gyro) != has_gyro {
            return Err(EngineError::InvalidMessage {
                kind: "imu",
                source_id: s.device.to_string(),
                t: s.t,
                error: nomen_core::CoreError::Invalid(if has_gyro {
                    "gyro_radps present, but the device's first sample had none (accelerometer-only)".into()
                } else {
                    "gyro_radps absent, but the device's first sample had one".into()
                }),
            });
        }
        let gyro = s.gyro_radps.unwrap_or(Vector3::repeat(f64::NAN));
        if imu.pending.insert(t, (s.accel_mps2, gyro)).is_err() {
            return Err(EngineError::Duplicate {
                kind: "imu",
                source_id: s.device.to_string(),
                t: s.t,
            });
        }
        imu.newest = Some(imu.newest.map_or(t, |n| n.max(t)));
        imu.frontier = imu.frontier.max(t.saturating_sub(self.reorder_ns));
        self.stats.num_imu_samples += 1;
        settle_imu(imu, &self.config, &mut self.stats);
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

    /// A raw UWB range: multilaterated with the rest of its tag's ranging cycle into a fix
    /// ([`RangeEpochs`]), which is taken as the tag's own fixes are. A tag that sends fixes of
    /// its own has its ranges ignored (its location system has solved them already).
    fn push_range(&mut self, r: &UwbRange) -> Result<()> {
        let Some(&i) = self.tag_index.get(&r.tag) else {
            return Err(self.device_error("uwb_range", &r.tag, r.t));
        };
        r.validate().map_err(|error| EngineError::InvalidMessage {
            kind: "uwb_range",
            source_id: r.tag.to_string(),
            t: r.t,
            error,
        })?;
        if self.tags_report_fixes.get(i).copied().unwrap_or(true) {
            self.stats.num_ranges_unused += 1;
            return Ok(());
        }
        // A range stamped far ahead of everything would hold its tag's epoch there.
        if let Some(tag) = self.tags.get(i) {
            let t = tag.clock.to_session(r.t.as_ns()).as_ns();
            self.time_jumps
                .check(self.global_max, "uwb_range", r.tag.as_str(), t, r.t)?;
        }
        let before = self.range_epochs.stats();
        let fix = self.range_epochs.push(r);
        self.note_range_epochs(before);
        if let Some(fix) = fix {
            self.take_range_fix(fix);
        }
        Ok(())
    }

    /// Takes a fix multilaterated from ranges as the tag's own fixes are; one the tag's
    /// buffers refuse (late, a duplicate) is counted, not blamed on the range that closed its
    /// cycle.
    fn take_range_fix(&mut self, fix: RtlsFix) {
        if self.push_fix(&without_covariance(fix)).is_ok() {
            self.stats.num_fixes_from_ranges += 1;
        } else {
            self.stats.num_range_fixes_refused += 1;
        }
    }

    /// Solves the ranging cycles of tags that went quiet before the window `end` passes them
    /// (their fixes would be late after it).
    fn close_quiet_range_epochs(&mut self, end: i64) {
        let (tags, tag_index) = (&self.tags, &self.tag_index);
        let before = self.range_epochs.stats();
        let fixes = self.range_epochs.close_where(|tag, last| {
            tag_index
                .get(tag)
                .and_then(|&i| tags.get(i))
                .is_none_or(|t| t.clock.to_session(last.as_ns()).as_ns() <= end)
        });
        self.note_range_epochs(before);
        for fix in fixes {
            self.take_range_fix(fix);
        }
    }

    /// Counts the ranges [`RangeEpochs`] left without a fix since `before`.
    fn note_range_epochs(&mut self, before: EpochStats) {
        let after = self.range_epochs.stats();
        self.stats.num_ranges_unused += after
            .num_unused_ranges
            .saturating_sub(before.num_unused_ranges);
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
        let t = tag.clock.to_session(f.t.as_ns()).as_ns();
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
        self.time_jumps
            .check(self.global_max, "rtls_fix", f.tag.as_str(), t, f.t)?;
        let height = Height::after(tag.height, f.position_m.z);
        let was_planar = matches!(tag.height, Some(Height::Planar { .. }));
        match height {
            Height::Planar { .. } if !was_planar => self.stats.planar_tags.push(tag.device.clone()),
            Height::Spatial if was_planar => self.stats.planar_tags.retain(|d| *d != tag.device),
            _ => {}
        }
        tag.height = Some(height);
        let sigma_m = match height {
            // A 2D fix says nothing about height.
            Height::Planar { .. } => (fix_sigma_m(f, defaults).0, f64::INFINITY),
            _ => fix_sigma_m(f, defaults),
        };
        tag.pending.insert(
            t,
            Fix {
                t,
                position_world_m: f.position_m,
                sigma_m,
            },
        );
        tag.newest = Some(tag.newest.map_or(t, |n| n.max(t)));
        tag.frontier = tag.frontier.max(t.saturating_sub(self.reorder_ns));
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
            source_id: rssi_source(r),
            t: r.t,
            error,
        })?;
        let reorder = self.reorder_ns;
        // Known tag and antenna: the stage exists (with the fitted default model at least).
        let Some(rssi) = self.rssi.as_mut() else {
            return Ok(());
        };
        let source = rssi_source(r);
        let clock = self.rssi_clocks.get(&r.tag).copied().unwrap_or_default();
        let t = clock.to_session(r.t.as_ns()).as_ns();
        let key = (t, r.tag.clone(), r.antenna.clone());
        if t < rssi.frontier {
            return Err(EngineError::Late {
                kind: "rssi",
                source_id: source,
                t: r.t,
            });
        }
        if rssi.pending.contains_key(&key) {
            return Err(EngineError::Duplicate {
                kind: "rssi",
                source_id: source,
                t: r.t,
            });
        }
        self.time_jumps
            .check(self.global_max, "rssi", &source, t, r.t)?;
        rssi.pending.insert(
            key,
            RssiRead {
                t: SessionTime::from_ns(t),
                ..r.clone()
            },
        );
        rssi.newest = Some(rssi.newest.map_or(t, |n| n.max(t)));
        rssi.frontier = rssi.frontier.max(t.saturating_sub(reorder));
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
        let t = cam.clock.to_session(s.t.as_ns()).as_ns();
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
        self.time_jumps
            .check(self.global_max, "skeleton", s.camera.as_str(), t, s.t)?;
        let mut world = Joints::new();
        let mut inferred = Joints::new();
        for (j, obs) in s.joints.iter() {
            if obs.state != JointState::Missing {
                world.insert(
                    j,
                    cam.world_from_camera * Point3::from(obs.position_m.coords * cam.scale),
                );
            }
            if obs.state == JointState::Inferred {
                inferred.insert(j, ());
            }
        }
        cam.newest = Some(cam.newest.map_or(t, |n| n.max(t)));
        cam.frontier = cam.frontier.max(t.saturating_sub(self.reorder_ns));
        let anchor = joint_centroid(&world);
        // A new track's predecessor, if any, is chosen later (`stitch_new_tracks`).
        let track = self
            .tracks
            .entry((c, s.track))
            .or_insert_with(|| TrackState {
                pending: BTreeMap::new(),
                samples: VecDeque::new(),
                kalman: Vec::new(),
                is_smoothing_due: false,
                first_t: t,
                last_t: t,
                evidence: BTreeMap::new(),
                tag_evidence: BTreeMap::new(),
                rssi_evidence: BTreeMap::new(),
                rssi_pairs: BTreeMap::new(),
                device_evidence: BTreeMap::new(),
                label: None,
                confirmed_tag_name: None,
                decision: Decided {
                    rule: DecisionRule::NoEvidence,
                    end: t,
                },
                held_back: None,
                subject_scores: BTreeMap::new(),
                outscored_by: BTreeMap::new(),
                last_anchor_world_m: anchor,
                superseded_by: None,
                views: Vec::new(),
                warm_labels: Vec::new(),
                is_stitch_pending: true,
                settled_t: i64::MIN,
                settled_anchor_world_m: None,
                return_from_gap: None,
            });
        track.pending.insert(
            t,
            PendingFrame {
                joints_world_m: world,
                inferred,
            },
        );
        track.first_t = track.first_t.min(t);
        if t >= track.last_t {
            track.last_t = t;
            if anchor.is_some() {
                track.last_anchor_world_m = anchor;
            }
        }
        self.pending_out.insert((t, c, s.track));
        self.first_frame_t = Some(self.first_frame_t.map_or(t, |f| f.min(t)));
        if let Some(a) = anchor {
            self.note_encounters(c, s.track, t, &a);
        }
        self.stats.num_skeletons += 1;
        // Observations settle when a window needs them (`process_window`), never further: the
        // joint smoothers revise a track's recent samples with every later observation, so a
        // window must not see more than the observations before its end, however far the
        // camera's messages ran ahead of the other sources'.
        self.note_time(t);
        Ok(())
    }

    fn note_time(&mut self, t: i64) {
        let slot = Some(t.div_euclid(DATA_SLOT_NS));
        if !self.recent_slots.contains(&slot) {
            self.data_slots.extend(slot);
            self.recent_slots = [slot, self.recent_slots[0]];
        }
        self.global_max = Some(self.global_max.map_or(t, |m| m.max(t)));
        if self.next_end.is_none() {
            self.next_end = Some(
                t.div_euclid(self.hop_ns)
                    .saturating_mul(self.hop_ns)
                    .saturating_add(self.hop_ns),
            );
        }
    }

    /// Tells the engine that the session clock has reached `now` with nothing sent since the
    /// last message: a live host's heartbeat while every source is quiet (the last people left
    /// the view and took their wearables with them, say). Every source then counts as silent
    /// since its newest message, so the windows it held back are processed once `now` is
    /// `silence_timeout_s` past them, and the decisions then due come out at the next
    /// [`Engine::poll`]: every observation is out once `now` is
    /// [`EngineConfig::latency_s`] + `silence_timeout_s` after it (the warm-up's, after
    /// [`EngineConfig::max_latency_s`] + `silence_timeout_s`). A message stamped before the
    /// windows processed is late afterwards, as from any source that fell silent.
    ///
    /// Does nothing before the session's first message is taken, or when `now` is not after
    /// the newest message. A `now` more than [`EngineConfig::max_time_jump_s`] ahead of the
    /// newest message is refused ([`EngineError::ClockAhead`]) and changes nothing.
    pub fn advance_to(&mut self, now: SessionTime) -> Result<()> {
        let t = now.as_ns();
        let Some(newest) = self.global_max.filter(|&newest| t > newest) else {
            return Ok(());
        };
        if t.saturating_sub(newest) > self.time_jumps.max_ns {
            return Err(EngineError::ClockAhead {
                now,
                ahead_s: t.saturating_sub(newest) as f64 * 1e-9,
            });
        }
        self.global_max = Some(t);
        Ok(())
    }

    /// Appends the decisions that are final (every window they depend on is processed).
    pub fn poll(&mut self, out: &mut Vec<Message>) {
        while let Some(end) = self.next_window() {
            let settle = end.saturating_add(self.reorder_ns);
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
                .is_some_and(|m| m >= settle.saturating_add(self.silence_ns));
            if !(all_settled || timed_out) {
                break;
            }
            if !all_settled {
                self.stats.num_windows_timed_out += 1;
            }
            let end = self.skip_idle(end);
            self.process_window(end);
        }
        out.append(&mut self.ready);
    }

    /// The end of the next window to process: none before the first message, nor at the end
    /// of the clock (a session stamped up to `i64::MAX` has no window after it).
    fn next_window(&self) -> Option<i64> {
        self.next_end.filter(|&end| end < i64::MAX)
    }

    /// Where to go on from window `end`: `end` itself, or past empty time. When no message lies
    /// within reach of the next windows (`idle_lookback_ns` before a window's end,
    /// `idle_lookahead_ns` after it: a recording paused for minutes, or a source whose clock
    /// jumped and then went on from there) and no observation waiting to be sent is due in
    /// them (`idle_lookahead_ns` before its window at the latest), those windows could read
    /// nothing, and stepping through them one hop at a time would take as long as the gap is
    /// wide (a day of gap is 172,800 windows). The engine jumps to the last window on the same
    /// grid that still reads nothing. A window that reads nothing changes nothing but what time
    /// alone changes: the
    /// heading estimates decay by the windows skipped, and what `forget` drops at the landing
    /// window is what it would have dropped by then. Only gaps of at least [`IDLE_SKIP_MIN_NS`]
    /// are skipped, so a recording without long gaps is processed as if none were.
    fn skip_idle(&mut self, end: i64) -> i64 {
        let from = end
            .saturating_sub(self.idle_lookback_ns)
            .div_euclid(DATA_SLOT_NS);
        let next_data = self.data_slots.range(from..).next().map(|&slot| {
            slot.saturating_mul(DATA_SLOT_NS)
                .saturating_sub(self.idle_lookahead_ns)
        });
        // An observation (or a tag fix) waiting to be sent lands as far before its own window
        // as a message would: the windows that decide and send it are processed one by one.
        // (A session resumed far ahead of its first messages, or a decision delay of hours,
        // would otherwise step through the time between.)
        let first_due = self
            .pending_out
            .first()
            .map(|p| p.0)
            .into_iter()
            .chain(
                self.tags
                    .iter()
                    .filter_map(|tag| tag.to_correct.front().map(|f| f.t)),
            )
            .map(|t| self.due_at(t).saturating_sub(self.idle_lookahead_ns))
            .min();
        // The earlier of the two; with neither a message ahead nor anything waiting, no jump.
        let Some(last_idle) = next_data.into_iter().chain(first_due).min() else {
            return end;
        };
        let room = last_idle.saturating_sub(end);
        if room < IDLE_SKIP_MIN_NS {
            return end;
        }
        let skipped = room / self.hop_ns;
        self.decay_headings(self.heading_decay_per_hop().powf(skipped as f64));
        self.stats.num_windows_skipped += skipped.unsigned_abs();
        end.saturating_add(skipped.saturating_mul(self.hop_ns))
    }

    /// Settles everything, processes every remaining window and emits every remaining decision.
    pub fn finish(&mut self, out: &mut Vec<Message>) {
        // A first message nothing came to vouch for is taken as it is.
        if let FirstMessage::Held(first, _) =
            std::mem::replace(&mut self.first, FirstMessage::Taken)
        {
            let _ = self.ingest(&first);
        }
        for imu in &mut self.imus {
            imu.frontier = i64::MAX;
            settle_imu(imu, &self.config, &mut self.stats);
        }
        for cam in &mut self.cameras {
            cam.frontier = i64::MAX;
        }
        // The last ranging cycles of tags that send ranges.
        let before = self.range_epochs.stats();
        let fixes = self.range_epochs.finish();
        self.note_range_epochs(before);
        for fix in fixes {
            let reports_fixes = self
                .tag_index
                .get(&fix.tag)
                .and_then(|&i| self.tags_report_fixes.get(i))
                .is_none_or(|r| *r);
            if reports_fixes {
                self.stats.num_range_fixes_refused += 1;
            } else {
                self.take_range_fix(fix);
            }
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
        while let Some(end) = self.next_window() {
            let more_data = self
                .global_max
                .is_some_and(|m| m >= end.saturating_sub(self.hop_ns));
            if self.pending_out.is_empty() && !more_data {
                break;
            }
            let end = self.skip_idle(end);
            self.process_window(end);
        }
        // Fixes after the last skeleton decision still get their (uncorrected or corrected) line.
        self.emit_corrections(i64::MAX);
        out.append(&mut self.ready);
    }

    fn process_window(&mut self, end: i64) {
        // At the end of the clock the next window ends at `i64::MAX`, which is never processed
        // (see `next_window`).
        self.next_end = Some(end.saturating_add(self.hop_ns));
        self.stats.num_windows += 1;
        for imu in &mut self.imus {
            imu.make_contiguous();
            // `poll` waited for this IMU's samples up to `end` on its current offset; an
            // offset accepted below must not make this window read past them.
            imu.settled_until_ns = end.saturating_sub(imu.offset_ns);
        }
        // This window is final: a tag that went quiet still has its fixes before `end` used
        // (a fix older than `end` arriving later is late).
        self.close_quiet_range_epochs(end);
        for tag in &mut self.tags {
            tag.frontier = tag.frontier.max(end);
            tag.settle();
        }
        if let Some(rssi) = self.rssi.as_mut() {
            rssi.frontier = rssi.frontier.max(end);
            // A read the bank refuses was validated at push; nothing else to do with it here.
            let _ = rssi.settle();
        }
        for c in 0..self.cameras.len() {
            let frontier = self.cameras.get(c).map_or(end, |cam| cam.frontier.min(end));
            self.settle_camera(c, frontier);
        }
        self.stitch_new_tracks(end);
        self.update_offsets(end);
        self.score_window(end);
        self.decide(end);
        self.end_warmup(end);
        self.emit(end);
        self.forget(end);
    }

    /// When an output for time `t` would be due without waiting for known clocks
    /// ([`EngineConfig::warmup_sync_s`]): `t + decision_delay`, or for the session's first
    /// observations (and tag fixes) the warm-up's end plus the delay.
    fn base_due_at(&self, t: i64) -> i64 {
        let warm_end = self
            .first_frame_t
            .map_or(t, |f| f.saturating_add(self.warmup_ns));
        t.max(warm_end).saturating_add(self.delay_ns)
    }

    /// When an output for time `t` is due: [`Engine::base_due_at`], and no earlier than the
    /// window that ends the warm-up ([`Engine::end_warmup`]; until it is known, its latest
    /// time). Non-decreasing in `t`, so the output stays in time order.
    fn due_at(&self, t: i64) -> i64 {
        let due = self.base_due_at(t);
        let Some(fixed_end) = self.fixed_warm_end() else {
            return due;
        };
        let release = self
            .warm_release
            .unwrap_or_else(|| fixed_end.saturating_add(self.warmup_sync_ns));
        due.max(release)
    }

    /// The fixed warm-up's end plus the decision delay, when the warm-up's observations would
    /// be due without waiting for known clocks: `first + warmup_s + decision_delay_s`. `None`
    /// before the first skeleton, and without a warm-up.
    fn fixed_warm_end(&self) -> Option<i64> {
        let first = self.first_frame_t.filter(|_| self.warmup_ns > 0)?;
        Some(
            first
                .saturating_add(self.warmup_ns)
                .saturating_add(self.delay_ns),
        )
    }

    /// Ends the warm-up at the window `end` if it is due ([`EngineConfig::warmup_sync_s`]): the
    /// fixed warm-up is over, and every track with observations waiting has a final decision
    /// at `end` (see [`TrackState::warm_labels`]; a track not decided at `end` by its latest
    /// label), or the longest wait is reached.
    fn end_warmup(&mut self, end: i64) {
        if self.warm_release.is_some() {
            return;
        }
        let (Some(first), Some(base_end)) = (self.first_frame_t, self.fixed_warm_end()) else {
            return;
        };
        if end < base_end {
            return;
        }
        let is_due = end >= base_end.saturating_add(self.warmup_sync_ns) || {
            let mut waiting: Vec<TrackKey> = self
                .pending_out
                .iter()
                .take_while(|(t, _, _)| self.base_due_at(*t) <= end)
                .map(|&(t, c, track)| (c, self.person_track(c, track, t)))
                .collect();
            waiting.sort_unstable();
            waiting.dedup();
            waiting.iter().all(|key| {
                self.tracks.get(key).is_none_or(|tr| {
                    match tr.warm_labels.last().filter(|d| d.end == end) {
                        Some(d) => d.is_final,
                        None => tr.label.is_none_or(|s| self.is_name_final(s)),
                    }
                })
            })
        };
        if is_due {
            self.warm_release = Some(end);
            self.stats.warmup_release_s = Some(end.saturating_sub(first) as f64 * 1e-9);
        }
    }

    /// For a track that a later one continues (stitched), the name of the first named track
    /// down that chain and its score there: the stitch took them for one person, and the later
    /// track may be named while this one's observations still wait to be sent. `None` for a
    /// track not continued, or a chain without a name.
    fn successors_name(&self, tr: &TrackState) -> Option<(usize, f64)> {
        let mut next = tr.superseded_by;
        // A chain is short (each link needs a track to end and a new one to start); the bound
        // only guards against a cycle.
        for _ in 0..MAX_SUCCESSORS {
            let later = self.tracks.get(&next?)?;
            if let Some(named) = later.named() {
                return Some(named);
            }
            next = later.superseded_by;
        }
        None
    }

    /// A name for an observation at `t` (session ns) of the track `key` that its own decision
    /// (left anonymous) did not give, in this order: the latest earlier decision that named the
    /// track, from the observation's due time `t + decision_delay_s` to `warm_until` (the
    /// warm-up's observations only, see [`EngineConfig::warmup_s`]); the name of the track
    /// that continues it ([`Engine::successors_name`]); the name of another camera's view of
    /// its person at its latest decision, or else of an earlier view the decisions could not
    /// compare with it since (`TrackState::views`), seen until `VIEW_NAMES_AFTER_END_NS` before
    /// `t` at the latest, or of that view's successor. An earlier decision's or a view's name
    /// is not given when another track of this camera seen over a span that holds `t` carries
    /// that name now: the per-camera assignment gives a subject one track at a time, and a
    /// name from elsewhere must not undo that (an earlier decision may have been made before
    /// the subject's clock was known, and named a look-alike). None of these is given when the
    /// observation's own decision `own` found evidence against naming the track (its best
    /// subject held by a better-scoring track of this camera or of another, the exclusion
    /// rules), unless
    /// [`EngineConfig::names_against_own_evidence`] is set. `None` where no rule gives a name.
    fn name_from_elsewhere(
        &self,
        key: TrackKey,
        tr: &TrackState,
        t: i64,
        own: Decided,
        warm_until: i64,
    ) -> Option<((usize, f64), DecisionRule)> {
        // A track whose own evidence points at a subject held elsewhere takes no name from
        // elsewhere ([`EngineConfig::names_against_own_evidence`]).
        let is_open = !matches!(own.rule, DecisionRule::Excluded | DecisionRule::HeldFarAway);
        if !is_open && !self.config.names_against_own_evidence {
            return None;
        }
        let is_held_here = |s: usize| {
            self.tracks
                .range((key.0, TrackId(0))..)
                .take_while(|(k, _)| k.0 == key.0)
                .any(|(k, other)| {
                    *k != key && other.label == Some(s) && other.first_t <= t && t <= other.last_t
                })
        };
        let warm = tr
            .warm_labels
            .iter()
            .rev()
            .filter(|d| d.end <= warm_until && d.end >= t.saturating_add(self.delay_ns))
            .find_map(|d| d.name)
            .filter(|(s, _)| !is_held_here(*s))
            .map(|name| (name, DecisionRule::EarlierDecision));
        let continued = || {
            self.successors_name(tr)
                .map(|name| (name, DecisionRule::ContinuedTrack))
        };
        warm.or_else(continued).or_else(|| {
            let (s, score) = tr
                .views
                .iter()
                .filter_map(|k| self.tracks.get(k))
                .filter(|view| t <= view.last_t.saturating_add(VIEW_NAMES_AFTER_END_NS))
                .find_map(|view| view.named().or_else(|| self.successors_name(view)))?;
            (!is_held_here(s)).then_some(((s, score), DecisionRule::OtherCameraView))
        })
    }

    /// Whether the warm-up's observations may still wait for the decision of a window ending
    /// at `end` (the last one they wait for included).
    fn is_warming_up(&self, end: i64) -> bool {
        self.warmup_ns > 0
            && self.first_frame_t.is_some()
            && self.warm_release.is_none_or(|release| end <= release)
    }

    /// Emits every observation whose decision window is `end` or earlier ([`Engine::due_at`]).
    /// An observation of the warm-up whose track this decision leaves anonymous takes the
    /// latest decision that named it since the observation's own due time, `t +
    /// decision_delay_s` (see [`EngineConfig::warmup_s`]); other anonymous tracks may take the
    /// name of the track that continues them or of another camera's view of their person
    /// ([`Engine::name_from_elsewhere`]).
    fn emit(&mut self, end: i64) {
        self.emit_corrections(end);
        let due: Vec<(i64, usize, TrackId)> = self
            .pending_out
            .iter()
            .take_while(|(t, _, _)| self.due_at(*t) <= end)
            .copied()
            .collect();
        for key in due {
            self.pending_out.remove(&key);
            let (t, c, track) = key;
            let Some(camera) = self.cameras.get(c).map(|cam| cam.id.clone()) else {
                continue;
            };
            let key = (c, self.person_track(c, track, t));
            let (identity, confidence, evidence, decision) = match self.tracks.get(&key) {
                Some(tr) => {
                    // An observation that waited for the warm-up's end takes its track's first
                    // final decision from its own due time on, if there was one.
                    let due = self.base_due_at(t);
                    let warm = tr.warm_labels.iter().find(|d| d.end >= due && d.is_final);
                    let (own, decided, warm_until) = match warm {
                        Some(d) => (
                            d.name,
                            Decided {
                                rule: d.rule,
                                end: d.end,
                            },
                            d.end,
                        ),
                        None => (tr.named(), tr.decision, i64::MAX),
                    };
                    let (name, decided) = match own {
                        Some(name) => (Some(name), decided),
                        None => match self.name_from_elsewhere(key, tr, t, decided, warm_until) {
                            Some((name, rule)) => (Some(name), Decided { rule, ..decided }),
                            None => (None, decided),
                        },
                    };
                    self.identity_as(tr, name, decided)
                }
                None => (Identity::Anonymous, 0.0, Vec::new(), None),
            };
            if identity != Identity::Anonymous {
                self.stats.num_identified += 1;
            }
            self.stats.num_decisions += 1;
            self.ready
                .push(Message::Identified(Box::new(IdentifiedSkeleton {
                    t: SessionTime::from_ns(t),
                    camera,
                    track,
                    identity,
                    confidence,
                    evidence,
                    decision,
                    joints: Joints::new(),
                })));
        }
    }

    /// Emits a [`TagCorrection`] for every settled fix due by `end` ([`Engine::due_at`]): the
    /// fix blended with its wearer's key joint when a track labelled with the wearer has it
    /// at that time, the raw fix otherwise (see [`crate::tags`]).
    fn emit_corrections(&mut self, end: i64) {
        let joint_sigma = self.config.joint_noise_std_m;
        for k in 0..self.tags.len() {
            while let Some(tag) = self.tags.get(k) {
                let Some(fix) = tag.to_correct.front().copied() else {
                    break;
                };
                if self.due_at(fix.t) > end {
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

    /// The identity of a track named `name` (subject and score, or anonymous) by the decision
    /// `decided`, a confidence in `0..=1`, the evidence behind it and the decision's trace.
    ///
    /// Confidence: the raw confidence (for a named track, its subject's score less the best
    /// other subject's, counted from 0 up; for an anonymous track, one minus the best
    /// candidate's score, 0 without any evidence), mapped by
    /// [`EngineConfig::confidence_map`] (or the map fitted for the motion score) to the
    /// probability that the identity is right.
    fn identity_as(
        &self,
        tr: &TrackState,
        name: Option<(usize, f64)>,
        decided: Decided,
    ) -> (Identity, f64, Vec<Evidence>, Option<DecisionTrace>) {
        // The best subject other than the one named (for an anonymous track, the best).
        let runner_up = best_of(&tr.subject_scores, name.map(|(s, _)| s));
        // The raw confidence (see `crate::confidence`), mapped to a probability.
        let (identity, raw, shown) = match (name, runner_up) {
            (Some((s, score)), _) => {
                let id = self
                    .subjects
                    .get(s)
                    .map_or(Identity::Anonymous, |id| Identity::Subject(id.clone()));
                (id, lead_over_runner_up(tr, s, score), Some(s))
            }
            (None, Some((s, score))) => {
                (Identity::Anonymous, (1.0 - score).clamp(0.0, 1.0), Some(s))
            }
            (None, None) => (Identity::Anonymous, 0.0, None),
        };
        let is_named = matches!(identity, Identity::Subject(_));
        let confidence = self.confidence_map.apply(is_named, raw);
        // A name less likely to be right than the run accepts goes out anonymous, with the
        // confidence of an anonymous frame whose best candidate is that subject.
        // The confidence map is fitted on motion evidence: a name that a tag's position or
        // reads also support keeps the run's own minimum if the track has carried it with a
        // clear lead before, and needs `tag_min_name_probability` if not.
        let is_motion_only = name.is_some_and(|(s, _)| !self.is_tag_supported(tr, s));
        let min_probability = if self.is_open_set && is_motion_only {
            self.config
                .min_name_probability
                .max(self.config.open_set_min_name_probability)
        } else if is_motion_only || name.map(|(s, _)| s) == tr.confirmed_tag_name {
            self.config.min_name_probability
        } else {
            self.config
                .min_name_probability
                .max(self.config.tag_min_name_probability)
        };
        // In a room known to hold people who wear nothing, a name that fits poorly is withheld
        // too, however it leads (`open_set_min_score`).
        let fits_poorly = self.is_open_set
            && is_motion_only
            && name.is_some_and(|(_, score)| score < self.config.open_set_min_score);
        let is_improbable = confidence < min_probability || fits_poorly;
        let (identity, confidence, is_named, decided) = if is_named && is_improbable {
            let raw = runner_up
                .into_iter()
                .chain(name)
                .map(|(_, v)| v)
                .fold(f64::NEG_INFINITY, f64::max);
            let raw = (1.0 - raw).clamp(0.0, 1.0);
            let decided = Decided {
                rule: DecisionRule::Improbable,
                ..decided
            };
            let confidence = self.confidence_map.apply(false, raw);
            (Identity::Anonymous, confidence, false, decided)
        } else {
            (identity, confidence, is_named, decided)
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
        let candidate = |(s, score): (usize, f64)| {
            self.subjects.get(s).map(|id| Candidate {
                subject: id.clone(),
                score,
            })
        };
        let named = name.filter(|_| is_named);
        // A name withheld as improbable is shown as the runner-up.
        let runner_up = match decided.rule {
            DecisionRule::Improbable => name,
            _ => runner_up,
        };
        let decision = DecisionTrace {
            rule: decided.rule,
            decided_at: SessionTime::from_ns(decided.end),
            named: named.and_then(candidate),
            runner_up: runner_up.and_then(candidate),
        };
        (identity, confidence, evidence, Some(decision))
    }

    /// Whether a location tag's or RSSI's evidence supports naming the track after subject `s`
    /// (its mean score clears [`EngineConfig::rejection_threshold`]).
    fn is_tag_supported(&self, tr: &TrackState, s: usize) -> bool {
        let supports = |acc: Option<&Accumulator>| {
            acc.is_some_and(|a| a.mean >= self.config.rejection_threshold)
        };
        supports(tr.tag_evidence.get(&s)) || supports(tr.rssi_evidence.get(&s))
    }

    /// The calibrated probability that naming the track after subject `s` is right, from its
    /// latest scores: `s`'s lead over the best other subject, mapped by the confidence map.
    fn name_probability(&self, tr: &TrackState, s: usize) -> f64 {
        tr.subject_scores.get(&s).map_or(0.0, |&score| {
            self.confidence_map
                .apply(true, lead_over_runner_up(tr, s, score))
        })
    }

    /// Drops samples no later window can use and tracks that went away.
    fn forget(&mut self, end: i64) {
        // Slots no later window's reach goes back to.
        let oldest_slot = end
            .saturating_sub(self.idle_lookback_ns)
            .div_euclid(DATA_SLOT_NS)
            - 1;
        self.data_slots = self.data_slots.split_off(&oldest_slot);
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

/// A fix multilaterated from raw ranges, without the solver's covariance: that counts the range
/// noise only, not the long bias of raw ranges or a body's shadow, so the fix takes the tag σ of
/// the configuration ([`EngineConfig::tag_sigma_horizontal_m`]) as a location system's fix does.
fn without_covariance(fix: RtlsFix) -> RtlsFix {
    RtlsFix {
        covariance_m2: None,
        ..fix
    }
}

/// Length of the slots of session time [`Engine::skip_idle`] marks as holding data, ns.
const DATA_SLOT_NS: i64 = 1_000_000_000;

/// Shortest run of empty windows [`Engine::skip_idle`] jumps over, ns.
const IDLE_SKIP_MIN_NS: i64 = 60_000_000_000;

/// Span of samples the orientation filter starts from, ns (see [`start_ahrs`]).
const AHRS_START_NS: i64 = 1_000_000_000;

/// A gap between an IMU's samples at least this long restarts its orientation filter, ns.
const AHRS_MAX_GAP_NS: i64 = 1_000_000_000;

/// Time constant of the low-pass that turns an accelerometer-only IMU's specific force into its
/// estimate of gravity, s. On the validation split of `scenarios/families/wrist_8_accel.toml`
/// (4 scenes) 1 s names 47.7 % of the frames right, 0.3 s 45.6 %, no low-pass 40.3 %.
const GRAVITY_LOWPASS_S: f64 = 1.0;

/// `world_from_sensor` of an accelerometer-only IMU: the shortest rotation that takes `up`, its
/// estimate of gravity in the sensor frame (the low-passed specific force), to the world
/// vertical (identity for a zero vector). It has no heading (it turns with the sensor), and
/// its tilt lags a swing; the magnitude of the specific force, `|a| = |a_lin + g ẑ|`, needs no
/// orientation at all.
fn gravity_frame(up: &Vector3<f64>) -> UnitQuaternion<f64> {
    level_from_accel(up).unwrap_or(UnitQuaternion::identity())
}

/// Settles an IMU's pending samples below its frontier: Madgwick's orientation per sample. The
/// filter (re)starts at the first sample and after a gap of a second or more (see
/// [`start_ahrs`]); samples wait until it can.
fn settle_imu(imu: &mut ImuState, config: &EngineConfig, stats: &mut EngineStats) {
    while let Some((t, &(accel, gyro))) = imu.pending.first() {
        if t >= imu.frontier {
            break;
        }
        let dt_ns = imu.ahrs_last_ns.map(|last| t - last);
        let is_accel_only = imu.has_gyro == Some(false);
        let q = match (imu.ahrs.as_mut(), dt_ns) {
            (Some(_), _) if is_accel_only => {
                // The specific force low-passed (first order, `GRAVITY_LOWPASS_S`), restarted
                // at the first sample and after a gap of a second.
                let g = match imu.gravity_mps2 {
                    Some((last, g)) if t > last && t - last < AHRS_MAX_GAP_NS => {
                        let k = 1.0 - (-((t - last) as f64 * 1e-9) / GRAVITY_LOWPASS_S).exp();
                        g + (accel - g) * k
                    }
                    _ => accel,
                };
                imu.gravity_mps2 = Some((t, g));
                gravity_frame(&g)
            }
            (Some(ahrs), Some(dt_ns)) if dt_ns > 0 && dt_ns < AHRS_MAX_GAP_NS => {
                ahrs.update_imu(&gyro, &accel, dt_ns as f64 * 1e-9)
            }
            (Some(ahrs), None) => ahrs.world_from_sensor(),
            _ => {
                if !start_ahrs(imu, config, stats) {
                    break;
                }
                continue;
            }
        };
        imu.pending.pop_first();
        imu.ahrs_last_ns = Some(t);
        imu.t.push_back(t);
        imu.accel.push_back(accel);
        imu.gyro.push_back(gyro);
        imu.world_from_sensor.push_back(q);
        imu.axis_elevation_rad.push();
        if imu.wants_band_pitch {
            imu.axis_pitch_rad.push();
        }
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
fn start_ahrs(imu: &mut ImuState, config: &EngineConfig, stats: &mut EngineStats) -> bool {
    let Some((first, _)) = imu.pending.first() else {
        return false;
    };
    // While the samples below the frontier span less than the start, none of them can end it
    // (neither its length nor a gap): wait without scanning them again.
    let is_finishing = imu.frontier == i64::MAX;
    let newest_settled = imu.pending.last_time_before(imu.frontier);
    if !is_finishing && newest_settled.is_none_or(|t| t.saturating_sub(first) < AHRS_START_NS) {
        return false;
    }
    // The current sample's frame as seen from the first one's.
    let mut first_from_sensor = UnitQuaternion::identity();
    let mut last: Option<(i64, Vector3<f64>)> = None;
    let mut up: [Vec<f64>; 3] = [Vec::new(), Vec::new(), Vec::new()];
    // The times the start reads, for the samples' rate.
    let mut times: Vec<i64> = Vec::new();
    let mut is_complete = is_finishing;
    for (t, (accel, gyro)) in imu.pending.iter() {
        if t >= imu.frontier {
            break;
        }
        if let Some((last_t, last_gyro)) = last {
            if t - last_t >= AHRS_MAX_GAP_NS {
                is_complete = true;
                break;
            }
            let dt_s = (t - last_t) as f64 * 1e-9;
            // An accelerometer-only IMU's (NaN) rates leave the frame where it is.
            if last_gyro.iter().all(|w| w.is_finite()) {
                first_from_sensor *= UnitQuaternion::from_scaled_axis(last_gyro * dt_s);
            }
        }
        times.push(t);
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
    // The samples' rate, from the median interval (a lost packet does not count), fixes the
    // lag search's step for good: its memo counts kept samples from the stream's first.
    if imu.lag_step.is_none()
        && let Some(dt_ns) = median_interval_ns(&times)
    {
        imu.lag_step = Some(imu_lag_step(dt_ns.round() as i64));
    }
    // What the filter took for gravity, kept from its first start: far from 9.81 m/s², the
    // accelerations are in other units (see `EngineStats::implausible_gravity`).
    let gravity_mps2 = up_first.norm();
    if gravity_mps2.is_finite() {
        stats
            .imu_start_gravity_mps2
            .entry(imu.device.clone())
            .or_insert(gravity_mps2);
    }
    imu.ahrs = Madgwick::new(config.madgwick, start).ok();
    imu.ahrs_last_ns = None;
    imu.ahrs.is_some()
}

/// Settles a track's pending observations below `frontier` through the joint filters, and
/// returns how many it left out because the track's history already reached their time (see
/// [`EngineStats::num_frames_behind_history`](crate::EngineStats::num_frames_behind_history)):
/// the history stays in time order.
fn settle_track(
    tr: &mut TrackState,
    frontier: i64,
    config: &EngineConfig,
    noise_std_m: f64,
) -> u64 {
    let r = Matrix3::identity() * noise_std_m * noise_std_m;
    let r_inferred = r * config.inferred_joint_noise_factor.powi(2);
    let mut num_behind = 0;
    while let Some(entry) = tr.pending.first_entry() {
        if *entry.key() >= frontier {
            break;
        }
        let (t, frame) = entry.remove_entry();
        if tr.samples.back().is_some_and(|newest| newest.t >= t) {
            num_behind += 1;
            continue;
        }
        let joints = frame.joints_world_m;
        let mut sample = TrackSample {
            t,
            joints: Joints::new(),
            bridged: 0,
        };
        let Some(kf_config) = config.joint_filter else {
            sample.joints = joints;
            tr.samples.push_back(sample);
            continue;
        };
        if tr.kalman.is_empty() {
            // Smoothed once per window's settle, the samples of the last hop as well as the
            // lag are revised, so each one is smoothed over at least the lag.
            let smoother_span_s = if config.joint_smoother_lag_s > 0.0 {
                config.joint_smoother_lag_s + config.hop_s
            } else {
                0.0
            };
            tr.kalman = Joint::ALL
                .iter()
                .map(|_| JointSmoother::new(kf_config, smoother_span_s).ok())
                .collect();
        }
        for (j, kf) in Joint::ALL.iter().zip(tr.kalman.iter_mut()) {
            let Some(kf) = kf.as_mut() else {
                continue;
            };
            let z = joints.get(*j);
            let r = if frame.inferred.get(*j).is_some() {
                &r_inferred
            } else {
                &r
            };
            let stepped = kf.step(SessionTime::from_ns(t), z.map(|p| (p, r)));
            if stepped.is_ok()
                && z.is_some()
                && let Some(p) = kf.filter().position()
            {
                sample.joints.insert(*j, p);
            }
        }
        tr.samples.push_back(sample);
        tr.is_smoothing_due = config.joint_smoother_lag_s > 0.0;
    }
    num_behind
}

/// Revises a track's recent samples with its joint smoothers, once per settle (see
/// [`EngineConfig::joint_smoother_lag_s`]): matched by time (an undone id swap may have moved a
/// sample between tracks), observed joints, and fills a joint's gaps of up to `bridge_ns`
/// between two observations with the smoother's estimate ([`EngineConfig::joint_gap_bridge_s`]
/// and [`EngineConfig::joint_gap_bridge_inferred_s`]).
fn smooth_track(tr: &mut TrackState, bridge_ns: i64) {
    tr.is_smoothing_due = false;
    let mut gap: Vec<(usize, Point3<f64>)> = Vec::new();
    for (j, kf) in Joint::ALL.iter().zip(tr.kalman.iter_mut()) {
        let Some(kf) = kf.as_mut() else {
            continue;
        };
        let revised = kf.smooth();
        let Some(&(oldest, _)) = revised.first() else {
            continue;
        };
        let bit = 1u32 << j.index();
        gap.clear();
        let mut revised = revised.iter().rev().peekable();
        for (k, sample) in tr.samples.iter_mut().enumerate().rev() {
            if sample.t < oldest.as_ns() {
                break;
            }
            while revised.next_if(|(ts, _)| ts.as_ns() > sample.t).is_some() {}
            let Some((ts, p)) = revised.peek() else {
                break;
            };
            if ts.as_ns() != sample.t {
                continue;
            }
            match sample.joints.get_mut(*j) {
                Some(q) => *q = *p,
                None if bridge_ns > 0 => gap.push((k, *p)),
                None => {}
            }
        }
        // Frames without the joint between two that observed it within `bridge_ns`: the
        // smoother's estimate there, which the observations on both sides pin down.
        let observed = |s: &TrackSample| s.joints.get(*j).is_some() && s.bridged & bit == 0;
        for &(k, p) in &gap {
            let Some(t) = tr.samples.get(k).map(|s| s.t) else {
                continue;
            };
            let newer = (tr.samples.range(k + 1..))
                .take_while(|s| s.t - t <= bridge_ns)
                .find(|s| observed(s))
                .map(|s| s.t);
            let older = (tr.samples.range(..k).rev())
                .take_while(|s| t - s.t <= bridge_ns)
                .find(|s| observed(s))
                .map(|s| s.t);
            if let (Some(newer), Some(older), Some(sample)) = (newer, older, tr.samples.get_mut(k))
                && newer - older <= bridge_ns
            {
                sample.joints.insert(*j, p);
                sample.bridged |= bit;
            }
        }
    }
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

/// Whether two closed time intervals `(first, last)` share an instant.
fn spans_overlap(a: (i64, i64), b: (i64, i64)) -> bool {
    a.0 <= b.1 && b.0 <= a.1
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

/// Adds one window score to an exponentially weighted mean (older scores decay per hop).
fn accumulate(acc: &mut Accumulator, score: f64, decay_per_hop: f64) {
    let w = acc.weight * decay_per_hop;
    acc.mean = (acc.mean * w + score) / (w + 1.0);
    acc.weight = w + 1.0;
}

/// [`accumulate`] with a window of weight `weight` (1 for a whole window's evidence, 0 for none):
/// a window of weight 0 leaves the mean where it was while older windows age.
fn accumulate_weighted(acc: &mut Accumulator, score: f64, weight: f64, decay_per_hop: f64) {
    let w = acc.weight * decay_per_hop;
    let weight = if weight.is_finite() {
        weight.max(0.0)
    } else {
        0.0
    };
    if w + weight > 0.0 {
        acc.mean = (acc.mean * w + score * weight) / (w + weight);
    }
    acc.weight = w + weight;
}

/// How far `score` for subject `s` leads the track's best other subject (a negative score
/// counting as 0), clamped to `0..=1`: the raw confidence of naming the track after `s`.
fn lead_over_runner_up(tr: &TrackState, s: usize, score: f64) -> f64 {
    let runner_up = best_of(&tr.subject_scores, Some(s)).map_or(0.0, |(_, v)| v.max(0.0));
    (score - runner_up).clamp(0.0, 1.0)
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_window_of_no_weight_leaves_the_evidence_where_it_was() {
        let mut acc = Accumulator::default();
        accumulate(&mut acc, 0.6, 0.5);
        accumulate_weighted(&mut acc, 0.1, 0.0, 0.5);
        assert!((acc.mean - 0.6).abs() < 1e-12 && (acc.weight - 0.5).abs() < 1e-12);
        // A whole window counts as `accumulate` counts it.
        let mut whole = acc;
        accumulate_weighted(&mut whole, 0.1, 1.0, 0.5);
        accumulate(&mut acc, 0.1, 0.5);
        assert!((whole.mean - acc.mean).abs() < 1e-12 && (whole.weight - acc.weight).abs() < 1e-12);
        // Nothing yet and no weight: still nothing.
        let mut empty = Accumulator::default();
        accumulate_weighted(&mut empty, 0.9, f64::NAN, 0.5);
        assert_eq!(empty.weight, 0.0);
    }
}
