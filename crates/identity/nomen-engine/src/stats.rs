//! Counters the engine keeps while it runs.

use nomen_core::{DeviceId, Joint};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Messages rejected by [`crate::Engine::push`], per reason.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct RejectCounts {
    /// Failed validation (NaN, out of range).
    pub num_invalid: u64,
    /// Sensor message from a device no subject wears, from a device of another kind, or from an
    /// antenna the registry does not list.
    pub num_unknown_device: u64,
    /// Skeleton from an unregistered camera.
    pub num_unknown_camera: u64,
    /// Same source and timestamp as an earlier message.
    pub num_duplicate: u64,
    /// Older than the source's reorder window.
    pub num_late: u64,
    /// Stamped implausibly far ahead ([`crate::EngineConfig::max_time_jump_s`]).
    #[serde(default)]
    pub num_time_jump: u64,
}

impl RejectCounts {
    /// All rejections.
    pub fn total(&self) -> u64 {
        self.num_invalid
            + self.num_unknown_device
            + self.num_unknown_camera
            + self.num_duplicate
            + self.num_late
            + self.num_time_jump
    }
}

/// The engine's estimate of one device's clock offset (`session = device + offset`).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct ClockOffsetEstimate {
    /// Estimated offset, ns.
    pub offset_ns: i64,
    /// Peak correlation of the last accepted estimate.
    pub correlation: f64,
    /// How many times the estimate was set or refined.
    pub num_updates: u64,
}

/// The engine's estimate of the rotation about the vertical between an IMU's AHRS frame and the
/// room (see `EngineConfig::heading_half_life_s`).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct HeadingEstimate {
    /// Yaw of the IMU's AHRS frame in the room frame, rad in (−π, π]: a horizontal vector with
    /// heading `h` in the IMU's frame has heading `h + room_from_imu_yaw_rad` in the room's.
    pub room_from_imu_yaw_rad: f64,
    /// How well the windows behind it agree, in [0, 1] (the length of the decayed mean of
    /// their unit phases, weighted by their correlations).
    pub coherence: f64,
}

/// What the engine has done so far.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct EngineStats {
    /// Messages pushed (accepted or not).
    pub num_messages: u64,
    /// IMU samples accepted.
    pub num_imu_samples: u64,
    /// Skeleton observations accepted.
    pub num_skeletons: u64,
    /// Messages of types the engine does not use (radio, outputs, truth), accepted and ignored.
    pub num_ignored: u64,
    /// Rejections per reason.
    pub rejected: RejectCounts,
    /// Evidence windows processed.
    pub num_windows: u64,
    /// Windows processed because a source stayed silent past the timeout.
    pub num_windows_timed_out: u64,
    /// Windows not processed because they lay in empty time, a minute or more without any
    /// message within their reach (see `EngineConfig::max_time_jump_s` for how a gap that
    /// wide is let in).
    pub num_windows_skipped: u64,
    /// Identified skeletons emitted.
    pub num_decisions: u64,
    /// Of which with a subject.
    pub num_identified: u64,
    /// Times a track's label changed from one subject to another.
    pub num_label_switches: u64,
    /// New camera tracks that continued an ended track's identity (stitching).
    pub num_stitched: u64,
    /// Stitched tracks seen again after a new track was taken to continue them: they had only
    /// been hidden, and take part in decisions again.
    pub num_stitches_undone: u64,
    /// RSSI reads accepted.
    pub num_rssi_reads: u64,
    /// Location-tag fixes accepted (those multilaterated from raw ranges included).
    pub num_tag_fixes: u64,
    /// Per location tag: its fixes compared with the tracks in view, and how many were near one
    /// (a fix counts once per window and camera it is compared in).
    pub tag_fixes_near: BTreeMap<DeviceId, TagNearCount>,
    /// Location tags taken as 2D: their first fixes all had one height (see `crate::tags`), so
    /// they are compared with the joints horizontally; a tag leaves the list when a fix at
    /// another height comes.
    pub planar_tags: Vec<DeviceId>,
    /// Fixes multilaterated from raw UWB ranges ([`nomen_rtls::RangeEpochs`]): tags that send
    /// ranges and no fixes.
    pub num_fixes_from_ranges: u64,
    /// Raw UWB ranges not used: their tag sends fixes of its own, or their ranging cycle gave no
    /// fix (too few anchors, a failed or poor solve, an unknown anchor, out of order).
    pub num_ranges_unused: u64,
    /// Fixes multilaterated from ranges that the tag's buffers refused (late, a duplicate), or
    /// whose tag had started sending fixes of its own.
    pub num_range_fixes_refused: u64,
    /// Tag fixes emitted corrected by their wearer's key joint.
    pub num_tag_corrections: u64,
    /// Close encounters after which two tracks' evidence was pooled (possible id swap).
    pub num_encounters: u64,
    /// Camera id swaps undone: a track's observation jumped onto where another track of its
    /// camera just was, so the two tracks' people (history, filters, evidence) were exchanged.
    pub num_swaps: u64,
    /// Skeleton observations left out of their track's history because that history already
    /// reached their time. Undoing an id swap keeps each track's history in time order, so
    /// this stays 0; it counts what a history in disorder would otherwise have broken (the
    /// windows read a track's frames in time order).
    pub num_frames_behind_history: u64,
    /// Accepted clock offsets moved: to a clearly better peak of the lag curves summed against
    /// the wearer's labelled tracks or of the best-track sum, or to a clear peak on a track
    /// nobody else explains.
    pub num_offsets_moved: u64,
    /// Settlings of accepted clock offsets: the best-track sum peaked clearly at one for
    /// `EngineConfig::offset_settle_passes` passes in a row, so the pass skips its IMU while it
    /// stays there (an offset that moves and settles again counts again).
    pub num_offsets_settled: u64,
    /// Accepted clock offsets withdrawn because the wearer's labelled tracks hardly correlate at
    /// them and better at another lag (see `EngineConfig::offset_withdraw_below`).
    pub num_offsets_withdrawn: u64,
    /// Checks of accepted clock offsets against the lag curves of the wearer's labelled tracks
    /// (one per IMU and check; see `EngineConfig::offset_label_curves`): they keep the
    /// refinement's pace, less often while an offset stays put.
    #[serde(default)]
    pub num_offset_label_checks: u64,
    /// Time from the session's first skeleton to the window whose decisions sent the warm-up's
    /// observations, s (`EngineConfig::warmup_s` plus the decision delay, and up to
    /// `EngineConfig::warmup_sync_s` more while clocks are unknown); `None` until then, and
    /// without a warm-up.
    pub warmup_release_s: Option<f64>,
    /// Clock offset estimates per IMU, once made; an estimate that is withdrawn is removed until
    /// the IMU's offset is found again.
    pub clock_offsets: BTreeMap<DeviceId, ClockOffsetEstimate>,
    /// The latest coherent heading estimate per IMU (kept when it later loses coherence).
    pub imu_headings: BTreeMap<DeviceId, HeadingEstimate>,
    /// For each IMU registered with `either_side`, the site its fits on its wearer's tracks
    /// lead to, once they clearly do (it may change as they accumulate).
    #[serde(default)]
    pub imu_sides: BTreeMap<DeviceId, Joint>,
    /// Per IMU, the magnitude of the specific force its orientation filter first started
    /// from (the per-axis median over its first second, m/s²): about 9.81 whether the wearer
    /// stands or walks. Far from it, the IMU's accelerations are in other units (1 for g,
    /// 1,000 for milli-g), which the engine cannot tell from motion: see
    /// [`EngineStats::implausible_gravity`].
    #[serde(default)]
    pub imu_start_gravity_mps2: BTreeMap<DeviceId, f64>,
    /// The IMUs without an accepted clock offset whose best-track sum (the lag curves' best
    /// value over the candidate tracks at each lag, summed over passes) last peaked at an end
    /// of the offset search (`EngineConfig::max_clock_offset_s` around the registry's offset):
    /// their offset is probably beyond it. With that end, s relative to the registry's offset
    /// (negative: the low end). An IMU whose offset is accepted later leaves the map.
    #[serde(default)]
    pub offsets_at_search_edge: BTreeMap<DeviceId, f64>,
    /// The IMUs without a gyroscope (every sample without `gyro_radps`): their evidence is
    /// [`ACCEL_ONLY_EVIDENCE`], the models that need no orientation.
    #[serde(default)]
    pub accel_only_imus: Vec<DeviceId>,
    /// Why the session's first message was dropped, if it was: the next message was stamped
    /// more than `EngineConfig::max_time_jump_s` before it (a corrupt timestamp). Counted in
    /// `rejected.num_time_jump`; no [`crate::Engine::push`] returned it, as the push that
    /// brought the message had already returned.
    #[serde(default)]
    pub first_message_dropped: Option<String>,
}

/// The specific force an IMU's orientation filter may start from, m/s², without its
/// accelerations being taken for other units: gravity (9.81) with a wide margin for motion in
/// the first second (on the 259 simulated scenes, a swinging wrist started from as little as
/// 5.9). Accelerations in g read about 1, in ft/s² about 32, in cm/s² about 981, in milli-g
/// about 1,000.
pub const PLAUSIBLE_START_GRAVITY_MPS2: std::ops::RangeInclusive<f64> = 3.0..=25.0;

/// The evidence an accelerometer-only IMU gives. Its frame is its gravity frame (the shortest
/// rotation onto the vertical of its specific force low-passed over 1 s, so no heading, and a
/// tilt that lags a swing): the vertical linear acceleration and its leaky integral against
/// the joint's, the acceleration magnitude, and the elevation of the sensor's axes and their
/// change against the carrying segment's (inclination, swing, De Marchi's orientation change,
/// Belmonte-Hernández's band pitch). The turn rate and the room-frame heading need a gyroscope
/// and are not used.
pub const ACCEL_ONLY_EVIDENCE: &str = "gravity frame from the low-passed accelerometer: \
     vertical acceleration and velocity, acceleration magnitude, axis elevations \
     (inclination, swing, orientation change); no turn rate or heading (they need a gyroscope)";

/// How often a tag's fixes were near a track they were compared with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct TagNearCount {
    /// Comparisons of a fix with the tracks in view.
    pub num_compared: u64,
    /// Comparisons in which some track's key joint was near the fix.
    pub num_near: u64,
}

/// Comparisons of a tag's fixes after which "never near a skeleton" is worth a warning (about
/// 5 s of fixes at 10 Hz, each compared in four windows).
pub const FAR_TAG_MIN_COMPARED: u64 = 200;

impl EngineStats {
    /// The location tags whose fixes, compared with the tracks in view at least
    /// [`FAR_TAG_MIN_COMPARED`] times, were near none of them in 99 % of the comparisons: most
    /// likely a frame, unit or clock problem (the tag's positions are not in the cameras' world
    /// frame, or not in metres), or a wearer never in view. With the share near.
    pub fn tags_far_from_skeletons(&self) -> impl Iterator<Item = (&DeviceId, f64)> {
        self.tag_fixes_near
            .iter()
            .filter(|(_, c)| c.num_compared >= FAR_TAG_MIN_COMPARED)
            .map(|(tag, c)| (tag, c.num_near as f64 / c.num_compared as f64))
            .filter(|(_, share)| *share < 0.01)
    }

    /// The IMUs whose filter started from a specific force outside
    /// [`PLAUSIBLE_START_GRAVITY_MPS2`], with it: their accelerations are most likely not in
    /// m/s², and their evidence is wrong.
    pub fn implausible_gravity(&self) -> impl Iterator<Item = (&DeviceId, f64)> {
        self.imu_start_gravity_mps2
            .iter()
            .filter(|(_, g)| !PLAUSIBLE_START_GRAVITY_MPS2.contains(*g))
            .map(|(device, &g)| (device, g))
    }
}
