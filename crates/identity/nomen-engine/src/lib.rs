//! The streaming identity engine: messages in any interleaving, identified skeletons out, from wearable evidence fused over time.
//!
//! # Pipeline
//! [`Engine::push`] takes messages in any interleaving across sources, each stamped on its
//! source's clock: a camera's, a location or RSSI tag's message stamped `t` is at
//! `clock.to_session(t)` (the registry's clock of that camera or tag, offset and drift), an
//! IMU's at `t` plus its offset (estimated around the registry's, [`EngineStats`]), and outputs
//! carry session times. Each source may be late by at most [`EngineConfig::reorder_window_s`] behind its own newest message. A
//! message is refused, with an error naming its source and time, when it is invalid, from an
//! unknown source, a duplicate, later than that, or stamped more than
//! [`EngineConfig::max_time_jump_s`] ahead of every time seen so far (a corrupt timestamp,
//! which would otherwise put its source's frontier out of reach of its later messages; the
//! source's next message is taken if it follows on from the refused one, so a clock that really
//! jumped costs one message). The session's first message waits for the next one, and is
//! dropped if that is stamped more than `max_time_jump_s` before it. Each source is *settled*
//! in time order below that frontier:
//! - skeleton joints go to the world frame (`world_from_camera * (scale · p)`, the camera's
//!   similarity from the registry) and through
//!   a constant-velocity Kalman filter per joint ([`EngineConfig::joint_filter`]), a joint the
//!   camera reports as inferred with [`EngineConfig::inferred_joint_noise_factor`] times the
//!   measurement noise;
//! - IMU samples go through Madgwick's `update_imu` for `world_from_sensor`, giving the
//!   linear-acceleration magnitude `|R·a − g ẑ|` and the angular-rate magnitude. The filter
//!   (re)starts, at the first sample and after a gap of a second, from the vertical of the
//!   next second of samples (the per-axis median of their specific forces, brought into the
//!   first sample's frame by the gyroscope), not from one reading, which a swing or a knock
//!   turns away from the vertical. An IMU whose samples carry no `gyro_radps` (an
//!   accelerometer-only watch; a device either always or never sends it, and a sample that
//!   differs from the device's first is refused) takes its gravity frame instead: the
//!   shortest rotation onto the vertical of its specific force low-passed over 1 s, an
//!   estimate of gravity that needs no gyroscope. Its models read that frame
//!   ([`ACCEL_ONLY_EVIDENCE`], listed per device in [`EngineStats::accel_only_imus`]): the
//!   vertical acceleration and velocity, the acceleration magnitude, and the elevation of its
//!   axes and their change; its turn rate and heading are missing (the frame turns with the
//!   sensor);
//! - location-tag fixes (`rtls_fix`, UWB or BLE tags) are buffered per tag (`tags`);
//! - RSSI reads (RFID and BLE tags) wait for the reorder window and are then scored at each
//!   window against every track's path (`engine/rssi.rs`), with a calibrated model
//!   ([`Engine::with_rssi_model`]) or the fitted default, its gains learned online.
//!
//! A new camera track may continue an ended track of the same camera (stitching) and then
//! inherits its evidence and label, the motion evidence at
//! [`EngineConfig::stitch_evidence_weight`] of its weight and the location-tag evidence at
//! [`EngineConfig::stitch_tag_evidence_weight`] (the stitch may have picked the wrong one of
//! two people who were close). The choice is made at the first window end after the new
//! track's first frame, from settled observations only: when another camera follows the new
//! track's person, the predecessor is the ended track that this view followed when it ended
//! ([`EngineConfig::stitch_across_cameras`]); otherwise the ended track (within
//! [`EngineConfig::stitch_max_gap_s`]) within walking reach of where the new one starts,
//! reach measured from where the ended track's person was heading (its last walking velocity
//! carried over the gap, [`EngineConfig::stitch_velocity_span_s`]). The stitch also works
//! backwards for names: an anonymous ended track's observations still waiting to be sent take
//! the name of the first named track of its chain of successors. Failing that, they take the
//! name of another camera's view of the track's person (paired by the decisions, or found
//! earlier and not compared since: the view found when the track was new, or one that ended;
//! up to 1 s past the view's end), unless a track of their own camera seen at their time
//! carries it.
//! SDKs also swap the ids of two people who pass close to each other: when a track's
//! observation jumps farther than a person moves in the time since its last one (0.08 m plus
//! 2 m/s) onto within half that jump of where another track of the camera was last seen (both
//! seen within the last second), or, failing that, the same with both tracks' people moved on
//! from their last observations at their walking velocity (people who cross in depth hide each
//! other for a few frames, and the SDK's swap shows when they come out, where the other was
//! heading; [`EngineConfig::stitch_velocity_span_s`]), the engine exchanges the two tracks'
//! people (their joint history and filters, evidence and label), so each identity stays with
//! its person; frames
//! from before the swap still waiting for their decision are decided for the person they
//! showed ([`EngineStats::num_swaps`]). The check runs as observations settle, in time order
//! across the camera's tracks, so it does not depend on the order they arrived in.
//! Optionally, two tracks that pass within [`EngineConfig::encounter_distance_m`] across the
//! line of sight pool their motion evidence when they separate (off by default).
//!
//! Every [`EngineConfig::hop_s`] a window of [`EngineConfig::window_s`] ending at a multiple of
//! the hop is processed once every source has delivered past its end plus the reorder window,
//! or once any source is [`EngineConfig::silence_timeout_s`] beyond that (a silent source
//! never blocks output). A window reads each IMU only up to the device time it waited for (its
//! end on the offset the IMU had then), even when the window itself accepts a new offset, so
//! its result does not depend on which later samples happen to have arrived. In each window:
//! 1. **clock offsets**, estimated jointly with identity: a device without an accepted offset
//!    is searched every [`EngineConfig::offset_search_interval_s`] (at every window while an
//!    IMU of a body-area network has no lag peak on any track yet:
//!    [`EngineConfig::offset_search_while_blind`]). For every track covering
//!    [`EngineConfig::offset_min_track_s`] of the last [`EngineConfig::offset_estimation_window_s`],
//!    each IMU of the subject gets a lag curve (mean Pearson correlation of De Marchi's
//!    acceleration and orientation-change magnitudes and nomen's vertical acceleration, swing
//!    and turn rate, at 15 Hz on the track side and 33 Hz on the IMU's; lags within
//!    ±[`EngineConfig::max_clock_offset_s`] of the registry's offset for the device, the prior,
//!    in 40 ms steps, then 10 ms around the coarse peak; near-tied peaks go to the one nearer
//!    the prior; a peak at the end of the range is no candidate, and an IMU without an
//!    accepted offset whose best-track sum, below, peaks there is listed in
//!    [`EngineStats::offsets_at_search_edge`]). Every offset path searches
//!    around that prior. An IMU's lag signals are kept from one window's search to the next
//!    (`lag_memo`): each search filters only its newest samples, with 1.5 s of older ones
//!    before them, and keeps the values lying 1 s or more before the newest sample.
//!    The subject's score for a track is the mean of its IMUs' peaks; only when the best track
//!    beats the next one of its camera by [`EngineConfig::offset_margin`], beats every other
//!    subject's score on that track by [`EngineConfig::offset_subject_margin`] (two people
//!    walking alike must not both take one track's lags) and reaches
//!    [`EngineConfig::offset_min_correlation`] is each IMU's peak lag on it a candidate, if that
//!    peak stands [`EngineConfig::offset_peak_clarity`] above every lag more than 0.15 s away
//!    (one IMU's peak on the right track may still sit a stride away, or on a look-alike's
//!    rhythm), and [`EngineConfig::offset_num_consistent`] candidates in a row within
//!    [`EngineConfig::offset_consistency_s`] make the offset. Tracks too short for that still
//!    count once the decisions put the wearer on them: each IMU sums its coarse lag curves
//!    against the tracks labelled with its wearer, and after
//!    [`EngineConfig::offset_label_curves`] curves a peak standing
//!    [`EngineConfig::offset_label_margin`] above every lag more than 0.15 s away is accepted
//!    too (a wearer with several IMUs, none of them accepted yet, needs
//!    [`EngineConfig::offset_label_curves_unsynced`] curves: her labels then come from pairs
//!    scored at their own best lags; and her first offsets are accepted together, only when
//!    the peaks of all her IMUs' sums average
//!    [`EngineConfig::offset_label_network_min_peak`]). The same sum, restarted at acceptance and
//!    taken at the refinement's pace (below: every [`EngineConfig::offset_refine_interval_s`],
//!    less often while the offset stays put), moves an accepted offset whose wearer's tracks
//!    clearly peak elsewhere (a stride away, or first found on someone else's track), and
//!    withdraws one at which that sum stays below [`EngineConfig::offset_withdraw_below`] while
//!    another lag does better (the IMU is then searched for again). A third path uses no
//!    decision at all: every [`EngineConfig::offset_best_track_interval_s`] each IMU's lag
//!    curve is taken against every candidate track at every coarse lag (40 ms), the best value
//!    at each lag is summed, and after [`EngineConfig::offset_best_track_curves`] passes a peak
//!    standing [`EngineConfig::offset_best_track_margin`] above every lag more than 0.15 s away
//!    accepts the offset (a wrong early label cannot confirm itself there) or moves an accepted
//!    one, unless the wearer's own named tracks of that pass fit the accepted offset at least as
//!    well as the new one; [`EngineConfig::offset_settle_passes`] such peaks in a row at an
//!    accepted offset settle it, and the pass stops reading that IMU while it stays there. At the same
//!    passes, a single-IMU subject's accepted offset is compared with the clear peaks of its
//!    lag curves on tracks nobody else explains (another subject explains a track as well as
//!    its accepted IMUs correlate there, at their offsets): while the IMU's refinement finds no
//!    peak, a peak of [`EngineConfig::offset_unexplained_min_peak`] that beats both its
//!    correlation at its own offset on the tracks it explains best and every other subject's
//!    explanation of that track by
//!    [`EngineConfig::offset_unexplained_margin`] is a vote, and
//!    [`EngineConfig::offset_unexplained_votes`] votes within
//!    [`EngineConfig::offset_consistency_s`] among the last
//!    [`EngineConfig::offset_unexplained_passes`] passes move the offset there (it undoes an
//!    offset taken from a look-alike's track).
//!    Accepted offsets are refined every [`EngineConfig::offset_refine_interval_s`] against the tracks
//!    labelled with the wearer (their fine lag curves averaged, weighted by coverage, one
//!    view per person where two cameras' tracks show the same person; the
//!    interval doubles while refinements leave the offset where it was, up to
//!    [`EngineConfig::offset_refine_max_interval_s`]; with trusted offsets this is the only
//!    path that moves them);
//! 2. **evidence**: per camera, every active track against every subject. IMUs are resampled
//!    onto the track's timestamps at their offset (before it is accepted, at that pair's own
//!    lag-curve peak, so identity can be found meanwhile; a track too short for the search, at
//!    whichever of the IMU's lag hypotheses fits it best in the window: its peaks on the
//!    [`EngineConfig::offset_hypotheses`] best tracks of its subject; while no track is long
//!    enough for the search, as at a session's start, a track of at least
//!    [`EngineConfig::offset_short_track_s`] at its own peak when clear, read up to the
//!    window's end rather than where the search's buffer stops; a track first seen inside the
//!    window takes the IMU resampled onto the camera's whole grid and low-passed there, sliced,
//!    and its own low-passed signals drop 0.2 s next to run edges inside the window, where its
//!    filter starts or stops and the IMU's does not) and scored as
//!    [`EngineConfig::motion_score`] says: De Marchi's correlations fused by
//!    [`EngineConfig::fusion`], Belmonte-Hernández's costs, or (default) the weighted mean of
//!    De Marchi's and nomen's correlations (`nomen_evidence::kinematic`) and, for forearm bands,
//!    Belmonte-Hernández's similarity ([`ModelWeights`]), plus a learned scorer's when one is
//!    plugged in ([`Engine::with_pair_scorer`]). For an IMU with a known clock offset, the
//!    horizontal accelerations of IMU and joint, as complex numbers, give a cross sum per
//!    window whose phase is the rotation between the IMU's AHRS frame and the room; summed
//!    (decayed, [`EngineConfig::heading_half_life_s`]) over the tracks labelled with its wearer,
//!    that phase is the IMU's heading ([`EngineStats::imu_headings`]), and once it is coherent
//!    every pair is also correlated in the room frame (`ModelWeights::heading`), which tells
//!    apart people who move alike in different directions. An IMU registered with
//!    `either_side` is compared at its site and at the mirror image (the lag search keeps the
//!    larger curve at each lag, a window the better-fitting site), and the side its fits on
//!    its wearer's tracks lead to is reported ([`EngineStats::imu_sides`]). Tag fixes score by their distance to the
//!    tag's key joint over the last [`EngineConfig::tag_window_s`], each fix weighted by how
//!    well it tells the camera's tracks apart (a fix between two people who pass close fits
//!    both and weighs nearly nothing, so the evidence from before the pass holds through it;
//!    `tags`); RSSI by the log-likelihood ratio, track against background, of the tag's reads
//!    at the person's positions at the reads' times (a Kalman filter per track, tag and
//!    antenna; silence censored; per-tag gains and per-antenna slopes learned while the tag is
//!    associated), normalised into a posterior over the camera's tracks. Each modality is
//!    accumulated per (track, subject) by an exponentially weighted mean with its own half-life
//!    (motion: [`EngineConfig::evidence_half_life_s`], or the shorter
//!    [`EngineConfig::network_evidence_half_life_s`] for a body-area network once one of its
//!    clock offsets is accepted; a subject none of whose IMUs sent anything in the window
//!    loses her motion evidence on every track seen more than half a second after her IMUs'
//!    last sample: the wearer left);
//! 3. **identity**: per camera, the mean of the modalities a subject has evidence from gives the
//!    track × subject matrix, solved by `nomen_assign::solve` with
//!    [`EngineConfig::rejection_threshold`]; the track's current label gets
//!    [`EngineConfig::switch_margin`] as a bonus (hysteresis). Tracks of other cameras that
//!    show the same person (torso within [`EngineConfig::camera_pair_distance_m`] on average
//!    over the last two windows, each the other's unambiguous match) pool their evidence, each
//!    accumulator weighted by its weight: a track too new to be scored is named from another
//!    camera's view at once, and a wrong stitch is outweighed. While a track's view is named,
//!    the two take turns being scored, one camera resting per hop
//!    ([`EngineConfig::alternate_paired_views`]). One subject never goes to two
//!    tracks of one camera seen at the same time; after the assignment, a track whose best
//!    subject went to a track of its camera that it never coexisted with (the same person
//!    under an earlier or later id, both still with frames to label) takes that subject too, if
//!    it clears the threshold. A track below threshold is [`nomen_core::Identity::Anonymous`].
//!    After each decision, every track that took part alongside the holder of a subject (their
//!    spans overlap) keeps the holder's score for it: it may take that subject later only
//!    while its own score is within [`EngineConfig::exclusion_margin`] of that score, so a
//!    companion who merely moved like the wearer does not inherit her name when she leaves.
//!    Across cameras, a subject named on a track far from this one (torsos farther apart than
//!    [`EngineConfig::camera_exclusion_distance_m`] on average over the last two windows) is
//!    kept off it unless its score is within [`EngineConfig::camera_exclusion_margin`] (0: at
//!    least as high) of that track's: one person is not in two places. The same holds within
//!    a decision: once every camera has assigned, a subject given to tracks far apart stays
//!    with the best-scoring one if it leads the others by more than
//!    [`EngineConfig::camera_exclusion_tie`] (0.1), and otherwise none of them keeps it.
//!    Where all cameras with tracks see people in common (one area) and the room is not known
//!    to hold people who wear nothing, this pass leaves holders to each camera's own
//!    assignment, which has weighed the people it sees
//!    ([`EngineConfig::camera_exclusion_in_shared_view`]).
//!    While none of a subject's IMUs has an accepted offset, a move of her name from one
//!    track to another that coexists with it must beat the holder's score by
//!    [`EngineConfig::unsynced_switch_margin`], or neither track holds her for that decision;
//!    the track that held her then goes on holding her for this rule (anonymous) until its
//!    next named decision, so the name does not pass to the look-alike one window later.
//!    Named for the first time or kept (no other coexisting track held her), her name needs
//!    the same margin over every coexisting track the assignment left without a name: an
//!    intruder who walks like her scores almost as well at his own lag.
//!    A track left anonymous may still be named from elsewhere: an earlier decision about it,
//!    the track that continues it, or another camera's view of its person. None of these
//!    names a track whose own decision kept its best subject off it for a better-scoring
//!    holder (the exclusion rules above), unless [`EngineConfig::names_against_own_evidence`]
//!    is set: the track's own evidence then speaks against a name, and an intruder's track
//!    paired with a wrongly named view stays anonymous.
//!    Where the name is sent, one last rule: a name whose calibrated probability of being
//!    right is below [`EngineConfig::min_name_probability`] goes out anonymous (`improbable`).
//!    A name that a location tag's or RSSI's evidence supports needs
//!    [`EngineConfig::tag_min_name_probability`] (0.5) the first time its track carries it;
//!    from then on the track keeps it however little it leads, and only a change of name
//!    needs the clear lead again (two tagged people walking side by side keep their names).
//!    Once the room is known to hold people who wear nothing, the minimum is
//!    [`EngineConfig::open_set_min_name_probability`] (0.5) instead: at each decision the
//!    engine counts the people in view (every camera's tracks at one time, two cameras'
//!    tracks whose torsos lie within 0.4 m of each other counted once, one track per camera
//!    per person) against the subjects
//!    whose wearables streamed in the last 5 s (and those whose tags are only heard near an
//!    antenna); three decisions within 10 s that see more people than that make the room
//!    open for [`EngineConfig::open_set_memory_s`] (60 s). Where everyone in view may be a
//!    wearer, a name that barely leads is usually right (the assignment has a subject for
//!    every person); where some wear nothing, it is usually an intruder's. In such a room a
//!    name resting on motion alone also needs a score of at least
//!    [`EngineConfig::open_set_min_score`] (0.45): a subject out of view whose wearables
//!    stream leaves his name to the track in view that fits him best, which leads but fits
//!    poorly.
//!
//! Every output carries a [`nomen_core::DecisionTrace`]: the rule that gave its identity
//! ([`nomen_core::DecisionRule`]), the decision's window end, the named subject's pooled score
//! and the best other subject's (`nomen explain` prints it).
//!
//! # Output and latency
//! Exactly one `Message::Identified` per accepted skeleton observation, with its `(t, camera,
//! track)`, labelled with the decision of the first window ending at or after
//! `t + decision_delay_s`, and a confidence: the probability that the label is right, from the
//! decision's score through [`EngineConfig::confidence_map`] ([`ConfidenceMap::fitted`] by
//! default). While all sources send, an observation is emitted at most
//! `decision_delay_s + hop_s + reorder_window_s` (default 2.25 s) of stream time after `t`
//! ([`EngineConfig::latency_s`]), stream time being the session time every source has reached
//! (an IMU's stamps read through its current clock-offset estimate, so an IMU whose clock is
//! behind and whose offset is not yet known holds output back by that offset); a silent source
//! adds at most `silence_timeout_s`, and when every source falls silent the host's heartbeat
//! ([`Engine::advance_to`]) brings the rest out `silence_timeout_s` later. The
//! exception is the session's warm-up ([`EngineConfig::warmup_s`], 2 s): observations within
//! it wait for the decision due at its end, up to `warmup_s` longer, since before the first
//! windows fill nobody can be named; and while no clock offset is known the warm-up may last
//! up to [`EngineConfig::warmup_sync_s`] (3 s) more, for decisions at known clocks (every
//! observation then due waits with it). The bound is [`EngineConfig::max_latency_s`] (7.25 s
//! by default).
//! Every settled tag fix comes back once as a `Message::TagCorrection` on the same schedule:
//! blended with the key joint of the track labelled with the tag's wearer, raw otherwise.
//! Rejected messages produce no output.
//!
//! Sans-IO and deterministic: no clocks, files, threads or printing; all maps are ordered.
#![warn(missing_docs)]

mod confidence;
mod config;
mod engine;
mod error;
mod lag_memo;
pub mod retrack;
mod signal;
mod stats;
mod tags;
mod time_queue;

pub use confidence::{CONFIDENCE_FIT_BINS, ConfidenceMap, Knots, MAX_KNOTS, RawConfidence};
pub use config::{EngineConfig, ModelWeights, MotionScore, OFFSET_CONFIRM_HISTORY};
pub use engine::Engine;
pub use error::{EngineError, Result};
pub use nomen_evidence::{Fusion, FusionConfig, GeometricConfig, KinematicConfig};
pub use retrack::{RetrackConfig, Retracker};
pub use stats::{
    ACCEL_ONLY_EVIDENCE, ClockOffsetEstimate, EngineStats, FAR_TAG_MIN_COMPARED, HeadingEstimate,
    PLAUSIBLE_START_GRAVITY_MPS2, RejectCounts, TagNearCount,
};

use nomen_core::{Message, Registry};

/// Runs a whole recording through a fresh engine: pushes every message in order (bad messages
/// are rejected and counted, not fatal), polls, finishes. Returns the outputs and the stats.
pub fn run_batch(
    registry: &Registry,
    messages: &[Message],
    config: &EngineConfig,
) -> Result<(Vec<Message>, EngineStats)> {
    run_batch_with_rssi(registry, messages, config, None)
}

/// [`run_batch`] with RSSI reads scored by a calibrated model ([`Engine::with_rssi_model`])
/// instead of the fitted default.
pub fn run_batch_with_rssi(
    registry: &Registry,
    messages: &[Message],
    config: &EngineConfig,
    rssi_model: Option<&nomen_rssi::RssiModel>,
) -> Result<(Vec<Message>, EngineStats)> {
    let mut engine = Engine::new(registry.clone(), *config)?;
    if let Some(model) = rssi_model {
        engine = engine.with_rssi_model(model)?;
    }
    let mut out = Vec::new();
    for msg in messages {
        // A rejected message is counted in the stats; the run goes on.
        let _ = engine.push(msg);
        engine.poll(&mut out);
    }
    engine.finish(&mut out);
    Ok((out, engine.stats().clone()))
}
