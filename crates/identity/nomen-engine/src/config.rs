//! Engine configuration: plain data, loadable from TOML, every field optional.

use crate::confidence::ConfidenceMap;
use crate::error::{EngineError, Result};
use crate::retrack::RetrackConfig;
use nomen_evidence::{BelmonteConfig, Fusion, FusionConfig, GeometricConfig, KinematicConfig};
use nomen_filters::kalman::ConstantVelocityConfig;
use nomen_filters::orientation::MadgwickConfig;
use serde::{Deserialize, Serialize};

/// Searches whose winners [`EngineConfig::offset_confirm_apart_s`] looks back over (30 s at the
/// default search interval).
pub const OFFSET_CONFIRM_HISTORY: usize = 30;

/// Which IMU-versus-skeleton evidence a window contributes per (track, subject).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "snake_case")]
pub enum MotionScore {
    /// De Marchi et al. as published: their three correlations (acceleration, velocity,
    /// orientation magnitudes) fused by [`EngineConfig::fusion`].
    DeMarchi,
    /// nomen's: the mean over the subject's IMUs of De Marchi's three correlations *and* nomen's
    /// five (swing angle over a short lag, vertical acceleration, vertical velocity, segment
    /// inclination, turn rate; `nomen_evidence::kinematic`), with Belmonte-Hernández's similarity
    /// for forearm bands and the room-frame horizontal acceleration once an IMU's heading is known
    /// (see [`ModelWeights`]).
    #[default]
    Nomen,
    /// Belmonte-Hernández et al.: for wrist bands only, the forearm pitch MSE and the yaw-rate
    /// MSE (`nomen_evidence::belmonte`), turned into a similarity
    /// `exp(−½(pitch_mse/σ_p² + yaw_rate_mse/σ_y²))` with
    /// [`EngineConfig::belmonte_pitch_sigma_rad`] and [`EngineConfig::belmonte_yaw_rate_sigma_radps`]
    /// so it accumulates and thresholds like the other scores (the paper thresholds the costs
    /// directly; the exponential is our reading). The wearing side is the registry's site (a
    /// band registered at an elbow or hand, or with `either_side`, is tried on both forearms
    /// and the better pitch kept, as the paper suggests for an unknown side); IMUs elsewhere on
    /// the body give no Belmonte evidence.
    Belmonte,
}

/// Weights of the models in [`MotionScore::Nomen`]'s score: the window score of a (track, subject)
/// pair is `Σ w·r / Σ w` over every correlation `r` present (each IMU of the subject, each model).
///
/// The defaults of the eight correlations are each model's linear-discriminant weight
/// `(μ_match − μ_other)/σ²`, scaled to mean 1, measured on the CNN training scenes
/// (`scenarios/train/*.toml`: full body-area networks, true clock offsets, 2 s windows), none of
/// which is an evaluation scene. All weights 1 ([`ModelWeights::equal`]) give the plain mean.
///
/// A band on a forearm (wrist, hand or elbow) also adds Belmonte-Hernández's similarity
/// (`MotionScore::Belmonte`'s score: wrist pitch and chest yaw rate, in [0, 1]) with weight
/// `belmonte`, default 1: it counts like one more correlation.
///
/// `heading` weighs the correlation of the horizontal accelerations of IMU and joint in the room
/// frame, once the IMU's heading (its AHRS frame's rotation about the vertical) is known (see
/// [`EngineConfig::heading_half_life_s`]). Unlike every other model it tells apart two people who
/// move alike in different directions, and it separates right from wrong pairs more clearly than
/// any of them, hence its default 3.
///
/// A weight is measured like any option, e.g.
/// `scenarios/families/sweep.sh model_weights.heading 0 3 -- --count 4` (the benchmark's validation
/// split).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(default, deny_unknown_fields)]
pub struct ModelWeights {
    /// De Marchi's acceleration magnitude.
    pub acc: f64,
    /// De Marchi's velocity magnitude.
    pub vel: f64,
    /// De Marchi's orientation-change magnitude.
    pub ori: f64,
    /// A learned scorer's score (`ModelScores::dl`), when one is plugged in.
    pub dl: f64,
    /// Swing angle.
    pub swing: f64,
    /// Vertical acceleration.
    pub vertical_accel: f64,
    /// Vertical velocity.
    pub vertical_vel: f64,
    /// Segment inclination.
    pub inclination: f64,
    /// Turn rate.
    pub turn: f64,
    /// Belmonte-Hernández's similarity of a forearm band (wrist pitch and chest yaw rate).
    pub belmonte: f64,
    /// Horizontal acceleration in the room frame, once the IMU's heading is known (see
    /// [`EngineConfig::heading_half_life_s`]); 0 turns the heading estimate off.
    pub heading: f64,
}

impl Default for ModelWeights {
    fn default() -> Self {
        Self {
            acc: 0.83,
            vel: 0.66,
            ori: 0.77,
            dl: 1.0,
            swing: 0.95,
            vertical_accel: 1.04,
            vertical_vel: 1.33,
            inclination: 1.58,
            turn: 0.85,
            belmonte: 1.0,
            heading: 3.0,
        }
    }
}

impl ModelWeights {
    /// All weights 1: the plain mean.
    pub fn equal() -> Self {
        Self {
            acc: 1.0,
            vel: 1.0,
            ori: 1.0,
            dl: 1.0,
            swing: 1.0,
            vertical_accel: 1.0,
            vertical_vel: 1.0,
            inclination: 1.0,
            turn: 1.0,
            belmonte: 1.0,
            heading: 1.0,
        }
    }

    fn all(&self) -> [(&'static str, f64); 11] {
        [
            ("acc", self.acc),
            ("vel", self.vel),
            ("ori", self.ori),
            ("dl", self.dl),
            ("swing", self.swing),
            ("vertical_accel", self.vertical_accel),
            ("vertical_vel", self.vertical_vel),
            ("inclination", self.inclination),
            ("turn", self.turn),
            ("belmonte", self.belmonte),
            ("heading", self.heading),
        ]
    }
}

/// Configuration of [`crate::Engine`]. Durations in seconds on the session clock.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(default, deny_unknown_fields)]
pub struct EngineConfig {
    /// Evidence window length, s. Default 2 s (De Marchi et al. compare 1–4 s windows; 2 s holds
    /// about two gait cycles). Shorter windows mix fewer camera-track changes (re-labelling, id
    /// swaps, left/right flips) and give a new track evidence sooner; longer ones average over more
    /// strides. Measured with `scenarios/families/sweep.sh window_s 1.5 2 3 -- --count 4` (the
    /// benchmark's validation split).
    pub window_s: f64,
    /// Distance between consecutive window ends (decision rate), s. Default 0.5 s.
    pub hop_s: f64,
    /// How far behind its source's newest message a message may arrive and still be used, s.
    /// Default 0.25 s.
    pub reorder_window_s: f64,
    /// How long past a window's settle time the engine waits for a silent source, s. Default 1 s.
    pub silence_timeout_s: f64,
    /// How far ahead of every time the engine has seen a message may be stamped, s; one stamped
    /// further is refused ([`crate::EngineError::TimeJump`]) unless the message of its source
    /// before it was refused for the same reason, less than this much earlier, with no message
    /// at the old time since (a session that resumed after everyone was silent costs one
    /// message per source; a source that jumps while the others go on is refused throughout).
    /// Without it, one corrupt timestamp an hour ahead would put its source's
    /// reorder window an hour ahead, so that every later message of that source is refused as
    /// late, and every window until then would time out waiting for the others. The session's
    /// first message waits for the next one and is dropped if that is stamped more than this
    /// much before it ([`crate::Engine::push`]). Default 60 s.
    pub max_time_jump_s: f64,
    /// A skeleton observed at `t` is labelled with the decision of the first window ending at or
    /// after `t + decision_delay_s`, s. Larger values let the first frames of a new track use
    /// evidence from after them, at the price of latency. Default 1.5 s: each extra second is a
    /// second more before a frame's decision comes out, and the gain is mostly at track starts.
    /// Measured with `scenarios/families/sweep.sh decision_delay_s 1 1.5 2 3 -- --count 4` (the
    /// benchmark's validation split). It is also the floor of the time to a correct name: with
    /// `scenarios/families/sweep.sh decision_delay_s 0.5 1 1.5 -- --count 4`, the median time
    /// from an appearance to its first correct name (`id all`) is 0.8–1.4 s at 0.5 s, 1.3–1.5 s
    /// at 1 s and 1.7–1.9 s at 1.5 s, while frames correct fall by 0.3 points (UWB tags) and
    /// 1.5–4.7 points (every family with IMUs) at 0.5 s, and by 0.1–2.2 points at 1 s.
    pub decision_delay_s: f64,
    /// A session's warm-up, s: an observation within `warmup_s` of the session's first skeleton is
    /// labelled with the decision of the first window ending at or after
    /// `first + warmup_s + decision_delay_s`, as if it had been observed at the warm-up's end; when
    /// that decision leaves its track anonymous, with the latest earlier one that named the track,
    /// from the observation's own due time `t + decision_delay_s` on. Until the first windows have
    /// filled and the first clock offsets are known, few people can be named, so without it a
    /// session's first frames come out anonymous whatever follows; with it they wait for the
    /// decisions that can name them, at most `warmup_s` longer (see
    /// [`EngineConfig::max_latency_s`]); later observations are not affected. The fallback on
    /// earlier decisions keeps a wearer named at the first decision from going anonymous in her
    /// first seconds when a look-alike walks in. Such an earlier name is not taken when another
    /// track of the camera, seen at the observation's time, carries it when the observation is sent
    /// (it was given before the subject's clock was known, to a look-alike).
    ///
    /// Default 2.0 s: it names most of a session's first frames, and a longer warm-up names a
    /// look-alike's first frames more often and delays the first output further. `0` turns it off
    /// (and `warmup_sync_s` with it). While no clock is known the warm-up may last longer: see
    /// [`EngineConfig::warmup_sync_s`]. Measured with
    /// `scenarios/families/sweep.sh warmup_s 0 1 2 3 -- --count 4` (the benchmark's validation
    /// split): without it, every family with IMUs loses 0.1–1.5 points, and the UWB tags'
    /// family keeps its figures while its wearers are named 1.9 s sooner (median time to a
    /// first correct name, 3.75 → 1.83 s). So a session whose registry has no IMU and no RSSI
    /// tag (location tags only: a first fix can name its wearer) has no warm-up.
    pub warmup_s: f64,
    /// How much longer than `warmup_s` the warm-up's observations may wait for decisions made at
    /// known clocks, s. Before any clock offset is accepted (about 4.5 s into a session at the
    /// earliest) each (IMU, track) pair is scored at its own best lag, and people who walk alike at
    /// different phases fit each other's tracks: the decision at the fixed warm-up's end can name
    /// them in a ring (A's track named B, B's named C, C's named A). So the warm-up ends at the
    /// first decision, from `first + warmup_s + decision_delay_s` on, at which every track with
    /// observations still waiting has a final decision, or `warmup_sync_s` later at the latest. A
    /// decision is final when it names someone whose clock is known (one of their IMUs has an
    /// accepted offset, or they wear none), or leaves the track anonymous, unless the track holds a
    /// name withheld from another track for unknown clocks
    /// ([`EngineConfig::unsynced_switch_margin`]). Each waiting observation takes its track's first
    /// final decision from its own due time on (an anonymous one falls back as `warmup_s` says), or
    /// the track's decision at the warm-up's end when there was none. A track left anonymous
    /// otherwise is not waited for: after a camera has swapped two people's ids, a later decision
    /// can name the wearer's new track while the observations waiting on it are the other person's.
    ///
    /// Default 3.0 s: the body-area networks' first offsets are usually known by then, and longer
    /// waits add latency for little. On the IMU scenes of 3 people or more the bound is usually
    /// reached: the warm-up's decisions then come from the window ending about 6.8 s after the
    /// session's first skeleton, and no observation waits longer than
    /// [`EngineConfig::max_latency_s`] (7.25 s by default). `0` keeps the fixed warm-up. Measured
    /// with `scenarios/families/sweep.sh warmup_sync_s 0 3 5 -- --count 4` (the benchmark's
    /// validation split).
    pub warmup_sync_s: f64,
    /// Fraction of the window a track must cover (first to last sample) to be scored. Default 0.5.
    pub min_window_coverage: f64,
    /// Paired views take turns: a track that another camera's track shows the same person as (its
    /// view, [`EngineConfig::camera_pair_distance_m`]) gets no motion scores at the hops when its
    /// camera rests (the cameras take turns, one per hop), if that view was seen before the window,
    /// is named, will be scored in it, and the track is unnamed (new, most often) or named alike.
    /// Its motion evidence then ages by the hop as if scored with no weight. The decisions pool the
    /// views' evidence, so the person is still scored at every window. Location-tag and RSSI
    /// evidence are scored on every view at every window.
    ///
    /// Default true: where two cameras see the same people it saves engine time
    /// (`cargo bench -p nomen-engine`, the 8-person scene with two cameras that both see everyone)
    /// for the same accuracy. Scenes with one camera are unchanged. Off, every view is scored at
    /// every window. Measured with
    /// `scenarios/families/sweep.sh alternate_paired_views true false -- --count 4` (the
    /// benchmark's validation split).
    pub alternate_paired_views: bool,
    /// Seconds of history before each window that the low-passed and smoothed signals of both sides
    /// are computed over before the window's part is scored, s (≥ 0); the window-anchored models
    /// (orientation change, velocity, vertical velocity) still start at the window's first sample.
    /// Default 0: every signal starts at the window.
    ///
    /// An experiment for streaming features: with a pad longer than the filters' memory, a window's
    /// signals are those a filter run once per sample would give, so they could be computed once
    /// and sliced per window, leaving per window only the anchored models (cheap to finish from
    /// per-sample orientations and integrals) and the low-pass's backward pass. Computed as here,
    /// the pad filtered again at every window, it costs about 40 % more engine time for accuracy
    /// within the noise, so it is off.
    pub history_pad_s: f64,
    /// How De Marchi's per-(joint, model) correlations of one window are fused into one score per
    /// (track, subject) (`nomen_evidence::fuse`). Default [`Fusion::Max`], the best of the fusions
    /// on the simulated wrist and body-area-network scenes; `model_vote` is better on the 8-person
    /// body-area-network scene.
    pub fusion: Fusion,
    /// Which evidence a window gives (default [`MotionScore::Nomen`]; `fusion` applies to
    /// [`MotionScore::DeMarchi`] only).
    pub motion_score: MotionScore,
    /// nomen's own motion models ([`MotionScore::Nomen`]).
    pub kinematic: KinematicConfig,
    /// Weights of the models in [`MotionScore::Nomen`]'s mean (see [`ModelWeights`]).
    pub model_weights: ModelWeights,
    /// How a decision's raw confidence becomes the output's, the probability that its identity
    /// is right. `None` (the default): the map fitted on simulated scenes for
    /// [`EngineConfig::motion_score`] ([`ConfidenceMap::fitted`]); a map with both sides empty
    /// ([`ConfidenceMap::raw`]) outputs the raw confidence. In TOML, a `[confidence_map]`
    /// table with `named` and `anonymous` knots (`nomen calibrate confidence` prints one).
    pub confidence_map: Option<ConfidenceMap>,
    /// Belmonte-Hernández's signals ([`MotionScore::Belmonte`]).
    pub belmonte: BelmonteConfig,
    /// Pitch error scale of the Belmonte similarity, rad. Default 0.3 rad (17°).
    pub belmonte_pitch_sigma_rad: f64,
    /// Yaw-rate error scale of the Belmonte similarity, rad/s. Default 2 rad/s: the band's yaw
    /// rate carries the arm's own swing, so even the right pair differs by about that much.
    pub belmonte_yaw_rate_sigma_radps: f64,
    /// Threshold and voting parameters of the fusion. Default: the evidence crate's, except
    /// `min_vote_score` 0.2: a track whose best correlation in a ballot is weaker abstains (still
    /// counted), so an intruder does not collect votes just by being the least bad match (with 0 or
    /// 0.15 the engine's intruder test fails; higher values make right matches abstain too). Chosen
    /// by measurement, not from the literature.
    pub fusion_config: FusionConfig,
    /// Filters and smoothing of De Marchi's magnitude signals (`nomen_evidence::geometric_scores`).
    pub geometric: GeometricConfig,
    /// Constant-velocity Kalman filter on every world-frame joint; `None`: raw joints. Default an
    /// acceleration noise density of 1.33 m²/s³ (Bar-Shalom's `a_max² · T` for about 6.3 m/s² at
    /// 30 Hz; the filter crate's generic default is 3, 10 m/s²) and an initial velocity within
    /// 2 m/s: the smoother joints fit their wearers' IMUs better than with the generic default. A
    /// causal filter delays a gait's signals, and the estimated clock offsets, which align the IMU
    /// with the filtered joints, would absorb that delay; [`Self::joint_smoother_lag_s`] removes
    /// it.
    pub joint_filter: Option<ConstantVelocityConfig>,
    /// How far back the joint filter's estimates are revised by a fixed-lag Rauch–Tung–Striebel
    /// smoother, s (`nomen_filters::kalman::JointSmoother`; 0: the filter alone). The samples are
    /// revised once per window, those of the last hop as well, so each is smoothed over at least
    /// this much of what came after it; the engine waits 2.25 s for a decision anyway.
    ///
    /// Default 0.3 s: smoothing sharpens the gait signals and removes the causal filter's delay
    /// from the estimated offsets (they end a few milliseconds from the true ones instead of about
    /// 30 ms after); shorter lags lose much of that, longer ones gain little. The price: sharper
    /// gait signals also fit a look-alike better, and a person without a band who walks the
    /// wearer's motion half a second out of phase, inside the offset search's range, can fit the
    /// band better than the wearer for the first seconds. Measured with
    /// `scenarios/families/sweep.sh joint_smoother_lag_s 0 0.3 0.5 -- --count 4` (the benchmark's
    /// validation split).
    pub joint_smoother_lag_s: f64,
    /// For a camera that drops occluded joints (a pose estimator such as OpenPose or MMPose, which
    /// reports no joint as inferred): gaps in a joint's observations up to this long, from the
    /// frame before the gap to the frame after it, are filled with the joint smoother's estimate
    /// there, s (0: none). Needs [`Self::joint_smoother_lag_s`] > 0, and fills only what the
    /// smoother still revises (`joint_smoother_lag_s + hop_s` back). A camera is taken for such an
    /// estimator once its skeletons have carried no inferred joint for their first 2 s; until then,
    /// and for good once one comes, [`Self::joint_gap_bridge_inferred_s`] applies. Default 0.5 s.
    ///
    /// Without inferred joints a wrist's track is full of short gaps: each one breaks the signals
    /// the models differentiate and correlate, and the clock offset search can lock onto a wrong
    /// peak. Filling gaps up to 0.5 s recovers most of what a camera's inferred joints give, above
    /// all on the one-wrist scenes; shorter fills leave more of the gaps.
    pub joint_gap_bridge_s: f64,
    /// [`Self::joint_gap_bridge_s`] for a camera that reports occluded joints as inferred (a depth
    /// SDK: Kinect, Azure Kinect, ZED), whose remaining gaps are joints out of view. Default 0
    /// (none): filling them up to 0.3 s changes accuracy within the noise, and longer fills bridge
    /// gaps at the elbows across which a person without a band comes to fit a wearer's track.
    pub joint_gap_bridge_inferred_s: f64,
    /// Joint measurement noise (per axis standard deviation) for the Kalman filter, m. Default
    /// 0.03 m (Kinect v2 joint noise at 2–4 m, Otte et al. 2016).
    pub joint_noise_std_m: f64,
    /// Factor on [`Self::joint_noise_std_m`] for a joint the camera reports as inferred
    /// (`JointState::Inferred`: occluded, guessed by the SDK), so the Kalman filter leans on its
    /// motion model there instead of following the guess (Kinect v2 inferred joints err several
    /// times more than tracked ones, Wang et al. 2015); 1 treats both alike. In the 8-person scenes
    /// a wrist is inferred in about a quarter of the frames. Dropping inferred joints instead
    /// (gaps) does worse than either.
    ///
    /// Default 3: given the true clock offsets, accuracy rises with the factor up to about 3 and
    /// levels off beyond; with searched offsets a larger factor sharpens the early fits, which also
    /// lets a look-alike without a band fit a band better than its wearer at a session's start.
    /// Measured with `scenarios/families/sweep.sh inferred_joint_noise_factor 1 3 4 -- --count 4`
    /// (the benchmark's validation split).
    pub inferred_joint_noise_factor: f64,
    /// Madgwick gains for every IMU's `world_from_sensor`.
    pub madgwick: MadgwickConfig,
    /// Gravity removed from the world-frame specific force, m/s².
    pub gravity_mps2: f64,
    /// Half-life of the exponentially weighted evidence of one (track, device) pair, s. Default
    /// 2 s: a window already spans `window_s`, and older evidence may belong to someone else (a
    /// camera's id swap, a stitch, an encounter), but once cameras pool their views (see
    /// [`EngineConfig::camera_pair_distance_m`]) and stitches inherit at a discount, a longer
    /// memory helps more than it costs, above all on the one-wrist scenes. Measured with
    /// `scenarios/families/sweep.sh evidence_half_life_s 1 2 3 -- --count 4` (the benchmark's
    /// validation split).
    pub evidence_half_life_s: f64,
    /// Half-life of the same evidence for a subject wearing a body-area network (more than one IMU)
    /// once one of its IMUs' clock offsets is accepted, s. Default 1 s. A network's window score is
    /// then the mean of several IMUs' correlations at their own clocks, steadier than one IMU's, so
    /// less of the past is needed to outweigh a bad window, and a shorter memory lets a track
    /// follow sooner when the camera's tracker hands it to another person. Before that, scores at
    /// unconfirmed lags are noisy and keep `evidence_half_life_s`, as do subjects with a single
    /// IMU, whose scores need the longer memory. Measured with
    /// `scenarios/families/sweep.sh network_evidence_half_life_s 0.75 1 2 -- --count 4` (the
    /// benchmark's validation split).
    pub network_evidence_half_life_s: f64,
    /// Lowest accumulated score at which a track may be given a subject; below it the track stays
    /// anonymous. In the window score's units: a mean correlation for [`MotionScore::Nomen`] and
    /// the correlation fusions, a vote share for the voting fusions, a similarity for
    /// [`MotionScore::Belmonte`]. Default 0.15, for the default [`MotionScore::Nomen`]: wrong pairs
    /// average about 0.1 per window, right ones about 0.4. `nomen experiment imu-table` uses 0.3
    /// for De Marchi's fusions and 0.2 for Belmonte's similarity. It is also the knob for where a
    /// wrong name costs more than none: a higher threshold names fewer frames wrong, fewer right,
    /// and people who wear nothing less often. Measured with
    /// `scenarios/families/sweep.sh rejection_threshold 0.15 0.25 0.3 -- --count 4` (the
    /// benchmark's validation split).
    pub rejection_threshold: f64,
    /// Bonus the current label of a track gets in the assignment, so another subject must beat it
    /// by this much to take over (hysteresis on top of the exponential averaging), in the window
    /// score's units. Default 0.02 (for [`MotionScore::Nomen`]: right and wrong subjects of
    /// similar-looking walkers differ by 0.05–0.1, so a margin near 0.1 locks early mistakes in).
    pub switch_margin: f64,
    /// While none of a subject's IMUs has an accepted clock offset, every (track, IMU) pair is
    /// scored at its own best lag, which flatters anyone who walks like the wearer. A label that
    /// would then move from one track to another that coexists with it (two people in view at once,
    /// one camera) must beat the holder's score by this much; if it does not, neither track holds
    /// the subject for that decision (no hysteresis bonus for either at the next), but the holder's
    /// track goes on holding her for this rule until its next named decision: otherwise the name,
    /// withheld once, would reach the look-alike at the next window. In the window score's units; 0
    /// disables. Default 0.1: before the wearer's offset is known, a label moving to a look-alike
    /// typically wins by 0.04–0.06, and a wider margin holds back the wearers' own names longer.
    ///
    /// The same margin guards a name no offset backs that is given for the first time or kept: the
    /// track must beat, by this much, every coexisting track the assignment left without a name
    /// (for subjects who wear IMUs). Without that, an intruder who walks like the wearer would be
    /// named whenever his track scored a little above hers at the first decisions; the wearer, too,
    /// waits while the two score within the margin (see also [`EngineConfig::offset_margin`]).
    /// Where every other track holds a name of its own, the rule does not apply. Measured with
    /// `scenarios/families/sweep.sh unsynced_switch_margin 0 0.1 0.2 -- --count 4` (the benchmark's
    /// validation split).
    pub unsynced_switch_margin: f64,
    /// A track that was seen alongside the track holding a subject may take that subject later (the
    /// holder left, or lost it) only while its own score for the subject stays within this much of
    /// the holder's score at the last decision they shared; otherwise the subject is out of its
    /// reach. Two people walking together correlate with each other's wearables: when the wearer
    /// leaves, the companion's leftover score must not name him. Negative disables. Default 0.2 (in
    /// the window score's units): a tighter margin (0.1) keeps a track from taking a subject it
    /// lost to a wrong holder. The memory does not expire (a companion may stay long after the
    /// wearer left): a track that turns out later to follow the subject, after an id swap the
    /// engine did not see, must first score within the margin of the holder's last score. Measured
    /// with `scenarios/families/sweep.sh exclusion_margin 0.1 0.2 0.3 -- --count 4` (the
    /// benchmark's validation split).
    pub exclusion_margin: f64,
    /// Largest difference searched for between a device's clock offset and the registry's
    /// offset for it (the prior; 0 when the registry says nothing), s. Default 0.6 s (the
    /// simulator draws up to ±0.5 s and registers 0).
    pub max_clock_offset_s: f64,
    /// Length of the buffer over which a device's clock offset is estimated, s. Default 12 s
    /// (several gait cycles *and* several turns, so the true lag beats the lags one stride off); a
    /// longer one is not more accurate and costs more per search. Measured with
    /// `scenarios/families/sweep.sh offset_estimation_window_s 12 16 -- --count 4` (the benchmark's
    /// validation split).
    pub offset_estimation_window_s: f64,
    /// Shortest stretch of a track (first to last sample in the buffer) for it to be a candidate in
    /// the offset search, s. Default 2.5 s: the median simulated track lasts about 2.5 s, so a 4 s
    /// floor leaves most people without a candidate for the first 10–20 s, and shorter tracks give
    /// less reliable peaks. Measured with
    /// `scenarios/families/sweep.sh offset_min_track_s 2 2.5 4 -- --count 4` (the benchmark's
    /// validation split).
    pub offset_min_track_s: f64,
    /// Shortest stretch of a track (as for `offset_min_track_s`) for it to be scored at its own
    /// lag-curve peak, when that peak is clear (`offset_peak_clarity`), against the IMUs whose
    /// offsets are not accepted yet, while no track is long enough for the offset search (the first
    /// seconds of a session, or of a wearer back in an empty view), s; such a track is never an
    /// offset candidate, and it gives no lag hypothesis. 0 disables. Default 1.5 s: without it
    /// nobody is named in a session's first 2.5 s; values from 0.6 to 1.8 s act alike (the searches
    /// run once a second), and taking unclear peaks too can name two people the wrong way round for
    /// a while. Such tracks read up to the window's end, not where the search's buffer stops 0.6 s
    /// earlier, so a track seen since the session's start is scored at the window ending at 1.5 s.
    /// The lag curve itself needs [`GeometricConfig::min_samples`] (30) of the track's samples at
    /// the search's 15 Hz, so at 30 Hz a track is in practice scored from about 2 s of frames;
    /// fewer samples let a look-alike without a band be named from his first frames. Measured with
    /// `scenarios/families/sweep.sh offset_short_track_s 0 1.5 -- --count 4` (the benchmark's
    /// validation split).
    pub offset_short_track_s: f64,
    /// How often a device without an accepted offset is searched again, s. Default 1 s.
    pub offset_search_interval_s: f64,
    /// While an IMU of a body-area network (a subject with several IMUs) has neither an accepted
    /// offset nor a lag peak on any track (a session's first seconds, or after its offset was
    /// withdrawn), and has samples in the search's buffer, the search runs at every window instead
    /// of every `offset_search_interval_s`: its pairs get no score until a search finds their
    /// peaks, so a network's first names wait for the first search that does. A registered network
    /// whose IMUs send nothing (its wearer absent) does not count. Default true: networks are named
    /// sooner in a session's first seconds. It does not apply to subjects with one IMU: a single
    /// IMU's early peaks on short tracks are often a look-alike's, and the network's mean over its
    /// IMUs is what makes them usable. Measured with
    /// `scenarios/families/sweep.sh offset_search_while_blind true false -- --count 4` (the
    /// benchmark's validation split).
    pub offset_search_while_blind: bool,
    /// Lag hypotheses kept per IMU whose offset is not yet accepted: its lag-curve peaks on its
    /// subject's best-scoring tracks of the latest search. A track too short for the search
    /// ([`EngineConfig::offset_min_track_s`]: new tracks after an occlusion or an id change, median
    /// 2.5 s on the simulated scenes) is scored at the hypothesis that fits it best in the window;
    /// without hypotheses its first seconds are named only by stitching or another camera. Long
    /// tracks stay scored at each pair's own peak, which fits them better. 0 disables. Default 3:
    /// fewer miss the right lag more often, more let a look-alike's lag fit. Measured with
    /// `scenarios/families/sweep.sh offset_hypotheses 0 3 8 -- --count 4` (the benchmark's
    /// validation split).
    pub offset_hypotheses: usize,
    /// Lowest peak correlation (mean over the subject's IMUs of the lag-curve peaks) for an
    /// offset candidate. Default 0.3.
    pub offset_min_correlation: f64,
    /// How much the best track's peak must beat the next track's (same camera) for its lag to be a
    /// candidate, correlation units. Default 0.125: with the unnamed-rival rule of
    /// [`EngineConfig::unsynced_switch_margin`] in place, what remains of intruders' names is a
    /// wearer's band accepted at the lag of a non-wearer who walks like her; 0.125 holds most of
    /// those back, and larger margins delay the wearers' own offsets. Measured with
    /// `scenarios/families/sweep.sh offset_margin 0.1 0.125 0.15 -- --count 4` (the benchmark's
    /// validation split).
    pub offset_margin: f64,
    /// How much a subject's winning track's mean peak must beat every other subject's mean peak on
    /// that track, correlation units (negative: not checked): two people walking alike must not
    /// both take one track's lags as their offsets (on the simulated scenes some share a motion
    /// clip at another phase). Default 0.05: with inferred joints weighed down
    /// ([`Self::inferred_joint_noise_factor`]) the early fits are sharper and a look-alike's track
    /// wins more often by a hair. Measured with
    /// `scenarios/families/sweep.sh offset_subject_margin -1 0 0.05 0.1 -- --count 4` (the
    /// benchmark's validation split).
    pub offset_subject_margin: f64,
    /// Number of successive candidates that must agree within `offset_consistency_s` before an
    /// offset is accepted. Default 3.
    pub offset_num_consistent: usize,
    /// How close successive candidates must be to count as consistent, s. Default 0.05 s.
    pub offset_consistency_s: f64,
    /// Independent confirmation for subjects that wear a single IMU, s (0: off, the default). When
    /// on, an offset the joint search agreed on is accepted only once an earlier winner of the last
    /// [`OFFSET_CONFIRM_HISTORY`] searches gave the same offset (within `offset_consistency_s`) on
    /// another track, or at least this long before; meanwhile the labelled-track path may not
    /// accept an offset more than a third of a stride from it. Several IMUs already confirm each
    /// other in the subject's mean peak, so they are not held back.
    ///
    /// The trade-off: fewer wrong offsets on the one-wrist scenes, but until the offset is
    /// accepted, tracks are scored at their own lag-curve peaks, which flatters a person without an
    /// IMU, so people who wear nothing are named more often. Hence off by default; worth turning on
    /// where everyone in view wears a sensor. Measured with
    /// `scenarios/families/sweep.sh offset_confirm_apart_s 0 4.5 -- --count 4` (the benchmark's
    /// validation split).
    pub offset_confirm_apart_s: f64,
    /// Local maxima of a lag curve within this of its highest value are near-ties; the one with
    /// the smallest |lag| wins. Default 0.02.
    pub offset_tie_tolerance: f64,
    /// How far an IMU's own lag-curve peak on the joint search's winning track must stand above
    /// every lag more than 0.15 s from it for that peak to be a candidate offset, correlation
    /// units; 0 takes any peak. Default 0.1. The winner is chosen on the mean over the subject's
    /// IMUs, so one IMU's peak on the right track may still sit a stride away or on a look-alike's
    /// rhythm; and successive searches share most of their buffer, so agreeing candidates do not
    /// check each other much. An unclear IMU is left to the next searches and the other paths. At
    /// 0.1 far fewer first offsets are wrong; stricter values hold back right ones too. Measured
    /// with `scenarios/families/sweep.sh offset_peak_clarity 0 0.1 0.2 -- --count 4` (the
    /// benchmark's validation split).
    pub offset_peak_clarity: f64,
    /// How often an accepted offset is re-estimated against the tracks labelled with its wearer
    /// (their lag curves averaged, weighted by coverage), s. Default 5 s.
    pub offset_refine_interval_s: f64,
    /// Longest interval between refinements of an offset that stays put, s: each refinement that
    /// leaves the offset within 30 ms (three lag steps, the refinement's own scatter) of where it
    /// was (its peak there, or no peak clear enough to move it) doubles the IMU's interval from
    /// `offset_refine_interval_s` up to this; an offset that moves farther (or by another path)
    /// starts again, and a wearer with no track to refine against is no refinement. Default 20 s
    /// (clocks drift by well under a lag step in that time); set it to `offset_refine_interval_s`
    /// to refine at a fixed pace. A tolerance of one lag step (10 ms) would let the refinement's
    /// own noise restart the interval. The check of an accepted offset against its wearer's
    /// labelled tracks (`offset_label_curves`) keeps the same pace: checking at the base interval
    /// names the same frames and costs engine time.
    pub offset_refine_max_interval_s: f64,
    /// Lag range around the current estimate searched when refining, s. Default 0.1 s.
    pub offset_refine_range_s: f64,
    /// Shortest coverage, s, of the offset-estimation buffer by a track labelled with an IMU's
    /// wearer for its lag curve to join that IMU's summed curve. Default 2 s.
    pub offset_label_min_track_s: f64,
    /// Curves the summed lag curve of an IMU against its wearer's labelled tracks needs before its
    /// peak may be accepted as the clock offset; 0 disables this path. Default 6: early labels are
    /// often wrong, and a sum of more curves is wrong less often, while more curves delay the
    /// offset. Measured with `scenarios/families/sweep.sh offset_label_curves 4 6 8 -- --count 4`
    /// (the benchmark's validation split).
    pub offset_label_curves: usize,
    /// The curves the same sum needs while none of its wearer's IMUs has an accepted offset, for a
    /// wearer with several IMUs (the larger of this and `offset_label_curves` applies). Her labels
    /// then come from pairs scored at their own best lags, and two people walking the same clip a
    /// stride apart get each other's: all of one subject's offsets can be accepted on her
    /// look-alike's tracks. The joint search averages over the network and usually finds its first
    /// offset instead. Default 12: it holds such lock-ins back while the path still names most
    /// networks' first offsets within 10–20 s; the one-wrist scenes are not affected. Measured with
    /// `scenarios/families/sweep.sh offset_label_curves_unsynced 6 12 18 -- --count 4` (the
    /// benchmark's validation split).
    pub offset_label_curves_unsynced: usize,
    /// How far the summed curve's peak must stand above every lag more than 0.15 s from it.
    /// Default 0.05.
    pub offset_label_margin: f64,
    /// Lowest summed-curve peak accepted as an offset. Default 0.15: a mean over many short tracks,
    /// lower than one long track's peak (`offset_min_correlation`); on the simulated wrist scenes
    /// right peaks are 0.2–0.3 and stand 0.08–0.15 above the rest.
    pub offset_label_min_correlation: f64,
    /// Lowest mean of the summed-curve peaks (`offset_label_min_correlation`'s curves) over a
    /// body-area network's IMUs for the network's first offsets to be accepted from its labels, all
    /// together; 0 lets each IMU's own peak decide. Default 0.3, the joint search's
    /// `offset_min_correlation`. Those labels come from pairs scored at their own best lags, and a
    /// look-alike's tracks among them give some IMUs a clear peak at the look-alike's lag while the
    /// network as a whole fits poorly: accepted one by one, such offsets stay wrong until the
    /// best-track sum moves them, while held back, the joint search accepts the right ones a few
    /// seconds later. Measured with
    /// `scenarios/families/sweep.sh offset_label_network_min_peak 0 0.3 -- --count 4` (the
    /// benchmark's validation split).
    pub offset_label_network_min_peak: f64,
    /// An accepted offset is withdrawn (and searched for again) when the summed lag curve of its
    /// IMU against the wearer's labelled tracks is below this at the offset and at least
    /// `offset_label_margin` higher at another lag. Default 0.05: on the simulated 8-person scenes
    /// right offsets read a median of 0.17 there, wrong ones 0.07. Ignored with
    /// `known_clock_offsets`. −1 disables.
    pub offset_withdraw_below: f64,
    /// Passes of the best-track lag curve an IMU needs before its peak may accept or move the IMU's
    /// offset; 0 disables this path. Every `offset_best_track_interval_s`, each IMU's coarse lag
    /// curve is taken against every candidate track and the best value at each lag is summed.
    /// Tracks named after another subject one of whose IMUs has an accepted offset are left out:
    /// that IMU explains them, and a look-alike's track would otherwise give a second peak in every
    /// pass. Unlike the labelled-track curves, the IMU's own labels do not enter that sum, so a
    /// wrong early label cannot confirm the offset it came from (a wrong label naming someone else
    /// on the wearer's track hides that track, though). They only veto a move: an accepted offset
    /// stays while the wearer's named tracks of the pass fit it at least as well as the new peak,
    /// so a man without a band who walks the wearer's motion half a second out of phase cannot move
    /// her band's offset to his lag and take her name. The path is slow (its peak is right for
    /// about half of the IMUs after 20 s and most after 60 s), so it only decides late, and only on
    /// clear peaks. Default 7 (21 s at 3 s). Measured with
    /// `scenarios/families/sweep.sh offset_best_track_curves 0 6 7 8 -- --count 4` (the benchmark's
    /// validation split).
    pub offset_best_track_curves: usize,
    /// How often the best-track lag curve gains a pass, s. Default 3 s: every pass correlates every
    /// IMU with every candidate track over the whole offset buffer, and passes every second double
    /// the engine's time for the same accuracy.
    pub offset_best_track_interval_s: f64,
    /// How far the best-track curve's peak must stand above every lag more than 0.15 s from it to
    /// accept or move an offset. Default 0.05: a stricter margin accepts fewer wrong peaks and
    /// waits longer for right ones. Measured with
    /// `scenarios/families/sweep.sh offset_best_track_margin 0.04 0.05 0.06 -- --count 4` (the
    /// benchmark's validation split).
    pub offset_best_track_margin: f64,
    /// Passes in a row whose best-track peak is clear (`offset_best_track_margin`) and within
    /// 0.15 s of an accepted offset that settle it: the best-track pass then skips the IMU while
    /// its offset stays there (the labelled-track check and the refinement still watch it), so a
    /// long session stops correlating every settled IMU with every track; 0 never settles. Default
    /// 6 (18 s at 3 s): the accuracy is that of never settling, and on a long 8-person full-network
    /// session most offsets settle and the engine's time in the later minutes falls
    /// (`cargo bench -p nomen-engine`).
    pub offset_settle_passes: usize,
    /// How far a track's clear lag peak must beat both another subject's explanation of that track
    /// and the IMU's support at its own offset to vote for moving the accepted offset of a
    /// single-IMU subject there; 0 disables (see the crate docs, step 1). It runs at the best-track
    /// pass's pace, so not at all when `offset_best_track_curves` is 0. It undoes a lock-in the
    /// other paths keep: on the one-wrist scenes two people walk the same clip with the same wrist,
    /// a fraction of a stride apart, and an IMU whose offset was accepted on its look-alike's track
    /// names that track while its wearer's own track, which correlates clearly at the true offset,
    /// goes unnamed or to someone else; the labelled-track checks then read the wrong tracks, and
    /// the best-track sum still holds the passes that agreed with the wrong offset.
    ///
    /// Default 0.1, with peaks of at least `offset_unexplained_min_peak`, 4 votes among 6 passes
    /// (18 s at 3 s), and only while the refinement finds no peak of `offset_min_correlation`: it
    /// frees such lock-ins on the one-wrist scenes and leaves the full networks untouched (their
    /// subjects have several IMUs); looser variants (fewer votes, lower peaks, no refinement
    /// condition) also move right offsets. Each pass correlates every unrefined single IMU with
    /// every candidate track over the coarse lag grid, which costs a one-wrist scene about a fifth
    /// more time. Measured with
    /// `scenarios/families/sweep.sh offset_unexplained_margin 0 0.1 -- --count 4` (the benchmark's
    /// validation split).
    pub offset_unexplained_margin: f64,
    /// Lowest peak that votes (see `offset_unexplained_margin`). Default 0.25: a wearer's own track
    /// in a crowd often peaks at 0.2–0.35 over the 12-s buffer.
    pub offset_unexplained_min_peak: f64,
    /// Votes (see `offset_unexplained_margin`) within `offset_consistency_s` of each other that
    /// move an accepted offset. Default 4.
    pub offset_unexplained_votes: usize,
    /// Best-track passes over which the votes count. Default 6.
    pub offset_unexplained_passes: usize,
    /// A track with no observation for this long is forgotten, s. Default 5 s.
    pub track_timeout_s: f64,
    /// Trust the registry's per-device clock offsets (wearables synchronised by PTP/NTP or
    /// calibrated beforehand): no offset search, only the periodic refinement. Default `false`:
    /// offsets are estimated from the data.
    pub known_clock_offsets: bool,
    /// Track stitching: a new camera track that starts within this long after another track of
    /// the same camera ended, close enough to where it ended, continues that track's identity
    /// and evidence (SDKs re-label people after occlusions and on re-entry), s. Default 3 s;
    /// 0 disables stitching. The predecessor is chosen at the first window end after the new
    /// track's first frame, from the observations before it, so the choice does not depend on
    /// message order (see also [`EngineConfig::stitch_across_cameras`]).
    pub stitch_max_gap_s: f64,
    /// Fastest a person is assumed to move while unseen, for stitching, m/s. Default 2 m/s
    /// (a brisk walk).
    pub stitch_max_speed_mps: f64,
    /// Distance allowed between where a track's person was heading
    /// ([`EngineConfig::stitch_velocity_span_s`]) and where its successor starts at zero gap
    /// (tracking noise and the SDK's own smoothing), m. Default 0.25 m: from the heading point, a
    /// tighter radius stitches as many new tracks right as a wider one (0.5 m) and fewer wrong.
    /// Measured with `scenarios/families/sweep.sh stitch_radius_m 0.15 0.25 0.5 -- --count 4` (the
    /// benchmark's validation split).
    pub stitch_radius_m: f64,
    /// Walking reach is measured from where an ended track's person was heading: its last position
    /// moved on over the gap at the horizontal velocity of its joint centroid over this last span
    /// of it (capped at `stitch_max_speed_mps`), s. Default 0.5 s; 0 measures from the last
    /// position. A walker's new track often starts nearer someone standing where the walker was
    /// heading than the walker's own old track; measured from the heading point, fewer such tracks
    /// are stitched wrong. The undoing of id swaps uses the same heading points when the last
    /// positions show no swap (see the crate docs). Measured with
    /// `scenarios/families/sweep.sh stitch_velocity_span_s 0 0.5 1 -- --count 4` (the benchmark's
    /// validation split).
    pub stitch_velocity_span_s: f64,
    /// Weight a stitched track's inherited motion evidence keeps, relative to what it had on the
    /// ended track (0..=1): a stitch to the wrong one of two people who were close is then outvoted
    /// by the new track's own windows sooner. Default 0.5: a right stitch keeps most of its
    /// evidence, and accuracy varies little between 0.25 and 1. Location-tag evidence keeps
    /// [`EngineConfig::stitch_tag_evidence_weight`]; RSSI evidence is inherited whole (each
    /// window rescores the tag's whole read history). Measured with
    /// `scenarios/families/sweep.sh stitch_evidence_weight 0.25 0.5 1 -- --count 4` (the
    /// benchmark's validation split).
    pub stitch_evidence_weight: f64,
    /// Weight a stitched track's inherited location-tag evidence keeps, relative to what it had
    /// on the ended track (0..=1). Windows whose fixes fit two people alike (they walk side by
    /// side) add almost no weight, so evidence inherited whole from the wrong one of them would
    /// hold the wrong name for as long as they stay together; at a discount the new track's
    /// own windows outvote it sooner, and its name needs a clear lead again
    /// ([`EngineConfig::tag_min_name_probability`]). Default 0.5.
    /// `scenarios/families/sweep.sh stitch_tag_evidence_weight 1 0.5 0.25 -- --count 8
    /// --family uwb_tags --family mixed_room` (validation), frames correct / frames of people
    /// wearing nothing named / wrong names / switches per person-hour at 1, 0.5 and 0.25: UWB
    /// tags 99.80 / 0.24 / 0.07 % / 7.6, 99.84 / 0.21 / 0.05 % / 4.7 and the same at 0.25;
    /// mixed rooms 95.89 / 1.77 / 0.23 % / 24.7 at 1 and 0.5, 95.90 / 1.75 / 0.21 % / 24.7 at
    /// 0.25; at `--count 4` (every family) UWB tags go from 99.74 / 0.23 / 0.11 % / 10.9 at 1
    /// to 99.80 / 0.16 / 0.10 % / 8.5 at 0.5, and the other eight families are unchanged. On
    /// the shipped `uwb_8_among_untagged` (`scenarios/uwb_switches.sh CONFIG 10`, the weight
    /// set in CONFIG): 99.21 % and 52 switches at 1, 99.20 % and 44 at 0.5, 99.19 % and 44 at
    /// 0.25, 99.05 % and 52 at 0 (the untagged people's frames named: 0.35, 0.38, 0.42,
    /// 0.45 %).
    pub stitch_tag_evidence_weight: f64,
    /// Stitch through another camera: when a track of another camera follows a new track's person
    /// (torso positions within `stitch_view_distance_m` on average, every other track at least
    /// twice as far), the new track continues the ended track of its camera that this view followed
    /// when it ended, or none if it followed none of them; walking reach (`stitch_max_speed_mps`,
    /// `stitch_radius_m`) decides only for people no other camera sees. Default `true`: where two
    /// cameras face each other and people hide each other from one of them, the other camera's view
    /// stitches far more new tracks to the right predecessor than walking reach does. Measured with
    /// `scenarios/families/sweep.sh stitch_across_cameras true false -- --count 4` (the benchmark's
    /// validation split).
    pub stitch_across_cameras: bool,
    /// How close on average another camera's view of a new track's person must stay to it for
    /// [`EngineConfig::stitch_across_cameras`] (the view that follows the new track, and the ended
    /// track that view followed), m. Default 0.3 m. It is wider than
    /// [`EngineConfig::camera_pair_distance_m`] because it is read at a new track's first frames,
    /// where the joint filter has only just started. 0 disables stitching through another camera.
    pub stitch_view_distance_m: f64,
    /// Tracks of different cameras whose torso positions (the pelvis, else the first of chest,
    /// neck, head and hips that both views have at that time) stayed this close on average over the
    /// last two evidence windows show the same person: each decides on the evidence of all of them
    /// (weighted by how much each has), so a fresh track seen by another camera for a while is
    /// named at once, and a wrong stitch is outvoted, m. Both tracks must be each other's nearest,
    /// the next candidate at least twice as far. Default 0.2 m. With the joint smoother, the same
    /// person's two views are a few centimetres apart on average over the two windows; the rare
    /// wider ones are windows with an SDK id swap or an inferred torso. Two people walking side by
    /// side 0.25 m apart, each hidden from one camera by the other, come within 0.3 m: their
    /// evidence is then pooled and one takes the other's name. 0.15 and 0.25 m do about as well as
    /// 0.2 m. 0 disables. Measured with
    /// `scenarios/families/sweep.sh camera_pair_distance_m 0.15 0.2 0.3 -- --count 4` (the
    /// benchmark's validation split).
    pub camera_pair_distance_m: f64,
    /// Tracks of different cameras whose torso positions stayed farther apart than this on
    /// average over their common frames of the last two evidence windows (measured as for
    /// [`EngineConfig::camera_pair_distance_m`]) show different people, m: a subject named on
    /// one of them is kept off the other unless the other's score for that subject is within
    /// [`EngineConfig::camera_exclusion_margin`] of the holder's. One camera's assignment gives
    /// a subject to one track at a time; this carries that across cameras: one person is in one
    /// place, and a wearer seen by one camera may fit someone else's track seen only by
    /// another. Default 1 m. 0 disables.
    pub camera_exclusion_distance_m: f64,
    /// How far below the score of a far holder (see
    /// [`EngineConfig::camera_exclusion_distance_m`]) a track's score for the subject may be
    /// and still take it, in the window score's units; negative disables. Default 0: the
    /// better-scoring of two places wins, as one assignment over all cameras would decide.
    /// `scenarios/families/sweep.sh camera_exclusion_margin 0 0.2 -- --count 4` (validation),
    /// frames correct at 0 / 0.2: intruders 91.2 / 86.0 %, same-motion crowds 80.9 / 75.9 %,
    /// 32-person crowds 91.6 / 90.3 %, 8 wrist IMUs 94.0 / 95.0 %, full networks 99.0 / 99.1 %;
    /// frames of people wearing nothing named 26 / 41 % (intruders) and 53 / 85 % (same
    /// motion). The shipped scenes (`scenarios/library.sh`, seeds 1–5) stay within 0.2 points.
    pub camera_exclusion_margin: f64,
    /// Two tracks far apart (see [`EngineConfig::camera_exclusion_distance_m`]) that one decision
    /// names after the same subject with scores within this much of each other both go
    /// anonymous, in the window score's units: one person is in one place, and the evidence
    /// cannot tell which. A holder that leads its far rivals by more keeps the name, and the
    /// rivals more than [`EngineConfig::camera_exclusion_margin`] below it go anonymous. Default
    /// 0.1: in 64-person crowds (the benchmark's validation split, scenes 0–3, one decision's
    /// name given to two far tracks at once), neither holder is the subject in half of the
    /// cases, and where one is, the lower-scoring one is as often as the higher when they
    /// score within 0.1. Negative disables the pass (a name then stays off a far track only
    /// once an earlier decision gave it elsewhere). `scenarios/families/sweep.sh
    /// camera_exclusion_tie -1 0.05 0.1 -- --count 4 --family wrist_8 --family wrist_32 --family
    /// crowd_64 --family same_motion` (validation), frames correct / wrong names / people
    /// wearing nothing named at -1 / 0.05 / 0.1: 64-person crowds 82.0 / 4.0 / 12.9, 81.9 / 1.9
    /// / 5.8, 82.0 / 1.3 / 4.2 %; 32 wrist IMUs 91.8 / 6.7, 89.8 / 4.1, 89.5 / 3.3 %;
    /// same-motion crowds 81.6 / 2.9 / 16.4, 82.3 / 2.7 / 11.6, 81.4 / 2.4 / 10.9 %; 8 wrist
    /// IMUs 95.4 / 2.9, 94.0 / 2.9, 93.9 / 3.0 %: the pass trades right names for wrong ones
    /// in crowds, and in a room of 8 it costs right names only. With
    /// `camera_exclusion_distance_m` at 2 m (`scenarios/families/sweep.sh
    /// camera_exclusion_distance_m 2 -- --count 4 --family wrist_8 --family crowd_64`), rooms of
    /// 8 give 94.5 / 3.7 % and crowds 81.9 / 1.4 / 4.7 %. These figures were measured with
    /// [`EngineConfig::camera_exclusion_in_shared_view`] on (the pass between every pair of
    /// cameras).
    pub camera_exclusion_tie: f64,
    /// Whether the pass of [`EngineConfig::camera_exclusion_tie`] (a tie between two far
    /// holders of one name, or a holder more than [`EngineConfig::camera_exclusion_margin`]
    /// below another) also applies between two cameras that see one person at once (a pair of
    /// their tracks shows one person at this decision, see
    /// [`EngineConfig::camera_pair_distance_m`]) when all cameras with tracks are linked that
    /// way (they watch one area) and the room is not known to hold people who wear nothing
    /// ([`EngineConfig::open_set_min_name_probability`]). Default false: each camera's
    /// assignment has already weighed the people it sees, and where every person in one area
    /// may be a wearer, the pass unnames right names for few or no wrong ones (below). In a
    /// room of several areas (a crowd in tiles), where the count of people in view cannot tell
    /// an open room, and in a room that holds people who wear nothing, the pass applies between
    /// every pair of cameras. `scenarios/families/sweep.sh camera_exclusion_in_shared_view true false
    /// -- --count 4` (validation), frames correct / wrong names at true and false: 8 wrist IMUs
    /// 93.94 / 2.98 and 95.37 / 2.92 %; full networks 98.56 / 0.32 and 98.82 / 0.40 %; every
    /// other family unchanged.
    pub camera_exclusion_in_shared_view: bool,
    /// Whether a track that its own decision leaves anonymous may take a name from elsewhere (an
    /// earlier decision about it, the track that continues it, another camera's view of its
    /// person) even when its own evidence speaks against it: its best subject is held by a
    /// better-scoring track of its camera that coexists with it
    /// ([`EngineConfig::exclusion_margin`]) or of another camera, far away
    /// ([`EngineConfig::camera_exclusion_margin`]). Default false: such a track stays
    /// anonymous. `scenarios/families/sweep.sh names_against_own_evidence true false --
    /// --count 6` (validation), frames correct at true / false: intruders 91.44 / 94.31 %,
    /// same-motion crowds 81.31 / 82.19 %, mixed rooms 92.40 / 93.77 %, leave-and-return 88.52
    /// / 89.47 %, 64-person crowds 79.38 / 79.96 %, full networks 98.33 / 98.19 %, 8 wrist IMUs
    /// 94.78 / 94.49 %, 32 wrist IMUs 91.57 / 91.40 %, UWB tags 99.65 / 99.71 %; frames of
    /// people wearing nothing named 24.6 / 12.7 % (intruders), 53.3 / 45.9 % (same motion),
    /// 22.1 / 15.9 % (mixed rooms), 53.3 / 45.6 % (leave-and-return).
    pub names_against_own_evidence: bool,
    /// The lowest calibrated probability of being right
    /// ([`EngineConfig::confidence_map`]) a name may have and still be sent; a frame whose
    /// name falls below it goes out anonymous with the rule `improbable`. It is the decision
    /// between a name and no name that weighs a wrong name `p / (1 − p)` times a missed one:
    /// 0.5 counts them alike. Default 0: every name is sent.
    /// `scenarios/families/sweep.sh min_name_probability 0 0.5 0.9 -- --count 4` (validation),
    /// frames correct / frames of people wearing nothing named / wrong names at 0, 0.5 and 0.9:
    /// intruders 94.5 / 13.1 / 1.2 %, 96.2 / 2.2 / 0.2 %, 95.0 / 0.9 / 0.1 %; leave-and-return
    /// 88.6 / 52.4 / 3.1 %, 91.9 / 4.2 / 1.2 %, 90.3 / 1.0 / 0.9 %; mixed rooms 92.7 / 18.0 /
    /// 1.2 %, 95.5 / 4.5 / 0.7 %, 93.8 / 1.8 / 0.3 %; same-motion crowds 81.9 / 43.7 / 8.8 %,
    /// 82.8 / 14.5 / 3.9 %, 76.7 / 10.2 / 2.5 %; 8 wrist IMUs 93.6 / – / 3.6 %, 87.2 / – /
    /// 1.4 %, 84.2 / – / 0.5 %; 32 wrist IMUs 91.5 / – / 6.9 %, 85.9 / – / 1.3 %, 79.4 / – /
    /// 0.5 %; full networks 98.8 / – / 0.4 %, 98.0 / – / 0.2 %, 96.2 / – / 0.1 %. The default
    /// stays 0 because the shipped scenes lose at 0.5 (`scenarios/library.sh`, seeds 1–12:
    /// imu_wrist_8 98.3 → 93.6 %, imu_ban_8 99.2 → 97.2 %): the probability is calibrated over
    /// every kind of scene at once, and a name that barely leads is right three times in four
    /// among wearers only but once in four where people wear nothing: where the engine counts
    /// people who wear nothing, [`EngineConfig::open_set_min_name_probability`] applies instead.
    pub min_name_probability: f64,
    /// The lowest calibrated probability ([`EngineConfig::confidence_map`]) a name resting on
    /// motion evidence alone may have while the room is known to hold people who wear nothing;
    /// replaces [`EngineConfig::min_name_probability`] there when higher. The room counts as
    /// such for `open_set_memory_s` after three decisions within 10 s that saw more people in
    /// view (every camera's tracks at one time; two cameras' tracks whose torsos lie within
    /// 0.4 m, one person) than subjects whose wearables streamed in the last 5 s (and those
    /// whose tags are only heard near an antenna). A name that a location tag's or RSSI's
    /// evidence also supports (its mean score clears [`EngineConfig::rejection_threshold`])
    /// has [`EngineConfig::tag_min_name_probability`] instead: the map is fitted on motion
    /// scores, and a tag's lead means something else (on `uwb_8_among_untagged`, seed 1, 441
    /// of the 479 frames this minimum would withhold from tag names are right). Default 0.5: a
    /// name is sent only when it is more likely right than wrong. Where everyone in view may be
    /// a wearer, a name that barely leads (the fitted map: probability 0.38 below a lead of
    /// 0.05) is right three times in four, since the assignment has a subject for every
    /// person; where some wear nothing, about once in four. Any value in (0.38, 0.85] acts alike with the fitted map.
    /// `scenarios/families/sweep.sh open_set_min_name_probability 0 0.5 -- --count 4`
    /// (validation), frames correct / frames of people wearing nothing named / wrong names at
    /// 0 and 0.5: intruders 94.5 / 13.1 / 1.2 % and 96.2 / 2.2 / 0.2 %; leave-and-return 88.6 /
    /// 52.4 / 3.1 % and 91.9 / 4.2 / 1.2 %; mixed rooms 92.8 / 17.5 / 1.2 % and 95.6 / 4.6 /
    /// 0.8 %; same-motion crowds 82.0 / 43.3 / 8.8 % and 82.5 / 14.4 / 3.8 %; 64-person crowds
    /// 83.1 / 74.9 / 8.7 % and 84.5 / 12.0 / 3.2 %; UWB tags 99.7 / 0.2 / 0.1 % at both; full
    /// networks and 8 and 32 wrist IMUs unchanged (nobody there is counted as wearing
    /// nothing). The shipped scenes (`scenarios/library.sh`, seeds 1–5) are unchanged.
    pub open_set_min_name_probability: f64,
    /// How long the room counts as holding people who wear nothing after the last decision
    /// that counted them (see [`EngineConfig::open_set_min_name_probability`]), s. Default 60 s:
    /// people who wear nothing are counted only while more people are in view than subjects
    /// stream, which a room where wearers come and go shows only now and then.
    /// `scenarios/families/sweep.sh open_set_memory_s 10 60 -- --count 4 --family leave_return
    /// --family crowd_64` (validation), frames correct / frames of people wearing nothing named
    /// at 10 and 60 s: leave-and-return 91.2 / 13.6 % and 91.9 / 4.2 %, 64-person crowds 84.5 /
    /// 13.5 % and 84.5 / 12.0 %.
    pub open_set_memory_s: f64,
    /// The lowest score (a subject's pooled evidence on the track, the `named` score of the
    /// decision trace) a name resting on motion evidence alone may have while the room is known
    /// to hold people who wear nothing (as for
    /// [`EngineConfig::open_set_min_name_probability`]); a weaker name goes out anonymous with
    /// the rule `improbable`. The lead that the confidence map reads says how much better a
    /// subject fits this track than the others; the score says whether the subject's wearables
    /// fit it at all. A subject who is out of view while his wearables stream leaves his name
    /// to the best of the tracks in view, which leads but fits poorly. Default 0.45: on the
    /// validation scenes, names given to people who wear nothing score 0.28–0.46 (median) and
    /// right names 0.66–0.71, with a tenth of them below 0.45–0.59.
    /// `scenarios/families/sweep.sh open_set_min_score 0 0.4 0.45 0.5 -- --count 4 --family
    /// intruders --family leave_return --family mixed_room --family same_motion --family
    /// crowd_64` (validation), frames correct / frames of people wearing nothing named at 0,
    /// 0.4, 0.45 and 0.5: intruders 96.2 / 2.2 %, 96.3 / 1.2 %, 96.2 / 0.9 %, 95.3 / 0.8 %;
    /// leave-and-return 91.9 / 4.2 %, 91.8 / 1.4 %, 91.5 / 0.8 %, 90.3 / 0.2 %; mixed rooms
    /// 95.6 / 4.6 %, 95.9 / 2.7 %, 95.5 / 2.5 %, 94.7 / 1.7 %; same-motion crowds 82.5 /
    /// 14.4 %, 82.0 / 14.1 %, 81.4 / 13.3 %, 80.3 / 12.2 %; 64-person crowds 84.5 / 12.0 %,
    /// 84.3 / 11.5 %, 83.7 / 10.4 %, 82.2 / 9.4 %. A name withheld leaves a frame anonymous,
    /// the lesser error: 0.45 trades up to a point of frames correct in crowds of people who
    /// move alike for a third to a fifth of the names given to people who wear nothing. Full
    /// networks, 8 and 32 wrist IMUs and UWB tags are unchanged at 0.4 and 0.45 (`--family ban
    /// --family wrist_8 --family wrist_32 --family uwb_tags`). The cost shows on the shipped
    /// `hospital_room` (`scenarios/library.sh`, seeds 1–5: 100 → 95.8 % frames correct): the
    /// doctor's one wrist band fits his walk at 0.33–0.74, and while a visitor is in the room
    /// his name is withheld where it dips below 0.45.
    pub open_set_min_score: f64,
    /// Two tracks of a camera closer than this across the line of sight are in a close encounter,
    /// after which their ids may have been swapped by the SDK (their evidence is pooled when they
    /// separate), m. Default 0: disabled. Swaps that move a track's observation onto where another
    /// track just was are undone directly (see the crate docs), and pooling at every encounter
    /// discards evidence most encounters did not disturb, which costs more accuracy than the swaps
    /// it catches.
    pub encounter_distance_m: f64,
    /// The lowest calibrated probability ([`EngineConfig::confidence_map`]) a name that a
    /// location tag's or RSSI's evidence supports may have the first time a track carries it
    /// (replaces [`EngineConfig::min_name_probability`] there when higher). Once a track has
    /// been named after the subject with at least this probability, the name is sent again
    /// however little it leads, and only another name needs the clear lead: a change of name
    /// needs clear evidence, while two tagged people who walk side by side keep the names they
    /// had. A track that continues an ended one (stitched) inherits its evidence but confirms
    /// its name itself. Default 0.5: a first name, or a change of name, is sent only when it is
    /// more likely right than wrong; any value in (0.38, 0.85] acts alike with the fitted map.
    /// `scenarios/families/sweep.sh tag_min_name_probability 0 0.5 -- --count 8 --family
    /// uwb_tags --family mixed_room` (validation), frames correct / frames of people wearing
    /// nothing named / wrong names / switches per person-hour at 0 and 0.5: UWB tags 99.80 /
    /// 0.24 / 0.07 % / 8.2 and 99.80 / 0.24 / 0.07 % / 7.6; mixed rooms 95.94 / 1.87 / 0.23 % /
    /// 24.7 and 95.89 / 1.77 / 0.23 % / 24.7 (at `--count 4` the other seven families are
    /// unchanged). On the shipped `uwb_8_among_untagged` (`scenarios/uwb_switches.sh`, seeds
    /// 1–10) the switches fall from 78 to 52 and frames correct from 99.32 to 99.21 % (right
    /// names on tracks new to a camera beside another wearer, withheld for up to a second).
    /// Applied to every tag name, not only the first on a track, 0.5 halves the switches of
    /// the validation UWB family (8.2 → 4.1 per person-hour) but costs the shipped scene a
    /// point (98.21 %): there two tagged people walk side by side for seconds and the right
    /// name leads by 0.03–0.06 (probability 0.38).
    pub tag_min_name_probability: f64,
    /// Horizontal standard deviation of a location-tag fix when the system reports no
    /// covariance, m. Default 0.3 m (the simulator's UWB core error is 0.15 m per axis plus NLOS
    /// excess and outliers, fitted to the LIAS recordings; Bazo reports 0.39 m RMSE raw).
    pub tag_sigma_horizontal_m: f64,
    /// Vertical standard deviation of a fix without covariance, m. Default 0.5 m (UWB anchors
    /// mounted near one height resolve height poorly).
    pub tag_sigma_vertical_m: f64,
    /// Half-life of the accumulated location-tag evidence, s. Default 1 s: a position fix is
    /// decisive on its own, so old evidence should not hold a label after an id swap. Each window
    /// enters with the mean weight of its fixes (how well each tells the camera's tracks apart),
    /// so the evidence holds through close passes whatever the half-life. On
    /// `scenarios/uwb_switches.sh CONFIG 10` (seeds 1–10, the half-life set in CONFIG), 2 s
    /// gives 99.08 % and 60 switches, 4 s 98.45 % and 68, against 99.21 % and 52 at 1 s.
    pub tag_evidence_half_life_s: f64,
    /// Length of the window of fixes a location tag is scored over (the last part of the
    /// evidence window), s. Default 2 s (twenty fixes at 10 Hz): positions need no long window,
    /// and a short one follows id swaps quickly.
    pub tag_window_s: f64,
    /// Half-life of the RSSI evidence, s: how fast a track's log-likelihood ratio (its path
    /// against the background, summed over the tag's reads) forgets. Default 4 s: a single read
    /// hardly separates two people a metre apart; a few seconds of walking do, and an id swap
    /// is forgotten as fast.
    pub rssi_evidence_half_life_s: f64,
    /// Half-life of an IMU's heading estimate, s. An AHRS without a magnetometer knows up but not
    /// north, so its frame is the room's turned about the vertical by an unknown angle that drifts
    /// with the gyroscope's bias. Each window, for IMUs whose clock offset is known, the cross sum
    /// `Σ a·conj(s)` of the horizontal accelerations (as complex numbers) of the IMU and of its
    /// joint on each track labelled with its wearer is normalised and added to a decayed sum; that
    /// sum's phase is the angle (reported in `EngineStats::imu_headings`), and the heading model
    /// (`ModelWeights::heading`) correlates every pair in the room frame with it. Default 20 s: the
    /// simulator's gyroscope turn-on bias (up to 0.48 °/s) turns the frame by at most 10° in that
    /// time.
    pub heading_half_life_s: f64,
    /// Coherence the heading sum needs before the heading model scores with it: the length of the
    /// decayed sum of normalised cross sums over the decayed sum of their lengths, in [0, 1] (1:
    /// every window gave the same angle). Default 0.5: lower lets noisy headings score, higher
    /// waits longer for a usable one.
    pub heading_min_coherence: f64,
    /// Decayed count of windows the heading sum needs before the heading model scores with it.
    /// Default 3.
    pub heading_min_windows: f64,
    /// How `nomen run --retrack` chains a tracker-less pose estimator's detections into tracks
    /// before they reach the engine ([`crate::Retracker`], table `[retrack]`); the engine itself
    /// does not read it.
    pub retrack: RetrackConfig,
}

impl Default for EngineConfig {
    fn default() -> Self {
        Self {
            window_s: 2.0,
            hop_s: 0.5,
            reorder_window_s: 0.25,
            silence_timeout_s: 1.0,
            max_time_jump_s: 60.0,
            decision_delay_s: 1.5,
            warmup_s: 2.0,
            warmup_sync_s: 3.0,
            min_window_coverage: 0.5,
            alternate_paired_views: true,
            history_pad_s: 0.0,
            fusion: Fusion::Max,
            motion_score: MotionScore::Nomen,
            kinematic: KinematicConfig::default(),
            model_weights: ModelWeights::default(),
            confidence_map: None,
            belmonte: BelmonteConfig::default(),
            belmonte_pitch_sigma_rad: 0.3,
            belmonte_yaw_rate_sigma_radps: 2.0,
            fusion_config: FusionConfig {
                min_vote_score: 0.2,
                ..FusionConfig::default()
            },
            geometric: GeometricConfig::default(),
            joint_filter: Some(ConstantVelocityConfig {
                accel_psd_m2ps3: 1.33,
                ..ConstantVelocityConfig::default()
            }),
            joint_smoother_lag_s: 0.3,
            joint_gap_bridge_s: 0.5,
            joint_gap_bridge_inferred_s: 0.0,
            joint_noise_std_m: 0.03,
            inferred_joint_noise_factor: 3.0,
            madgwick: MadgwickConfig::default(),
            gravity_mps2: 9.81,
            evidence_half_life_s: 2.0,
            network_evidence_half_life_s: 1.0,
            rejection_threshold: 0.15,
            switch_margin: 0.02,
            unsynced_switch_margin: 0.1,
            exclusion_margin: 0.2,
            max_clock_offset_s: 0.6,
            offset_estimation_window_s: 12.0,
            offset_min_track_s: 2.5,
            offset_short_track_s: 1.5,
            offset_search_interval_s: 1.0,
            offset_search_while_blind: true,
            offset_min_correlation: 0.3,
            offset_margin: 0.125,
            offset_subject_margin: 0.05,
            offset_num_consistent: 3,
            offset_consistency_s: 0.05,
            offset_hypotheses: 3,
            offset_confirm_apart_s: 0.0,
            offset_tie_tolerance: 0.02,
            offset_peak_clarity: 0.1,
            offset_refine_interval_s: 5.0,
            offset_refine_max_interval_s: 20.0,
            offset_refine_range_s: 0.1,
            offset_label_min_track_s: 2.0,
            offset_label_curves: 6,
            offset_label_curves_unsynced: 12,
            offset_label_margin: 0.05,
            offset_label_min_correlation: 0.15,
            offset_label_network_min_peak: 0.3,
            offset_withdraw_below: 0.05,
            offset_best_track_curves: 7,
            offset_best_track_interval_s: 3.0,
            offset_best_track_margin: 0.05,
            offset_settle_passes: 6,
            offset_unexplained_margin: 0.1,
            offset_unexplained_min_peak: 0.25,
            offset_unexplained_votes: 4,
            offset_unexplained_passes: 6,
            track_timeout_s: 5.0,
            known_clock_offsets: false,
            stitch_max_gap_s: 3.0,
            stitch_max_speed_mps: 2.0,
            stitch_radius_m: 0.25,
            stitch_velocity_span_s: 0.5,
            stitch_evidence_weight: 0.5,
            stitch_tag_evidence_weight: 0.5,
            stitch_across_cameras: true,
            stitch_view_distance_m: 0.3,
            camera_pair_distance_m: 0.2,
            camera_exclusion_distance_m: 1.0,
            camera_exclusion_margin: 0.0,
            camera_exclusion_tie: 0.1,
            camera_exclusion_in_shared_view: false,
            names_against_own_evidence: false,
            min_name_probability: 0.0,
            open_set_min_name_probability: 0.5,
            open_set_memory_s: 60.0,
            open_set_min_score: 0.45,
            encounter_distance_m: 0.0,
            tag_min_name_probability: 0.5,
            tag_sigma_horizontal_m: 0.3,
            tag_sigma_vertical_m: 0.5,
            tag_evidence_half_life_s: 1.0,
            tag_window_s: 2.0,
            rssi_evidence_half_life_s: 4.0,
            heading_half_life_s: 20.0,
            heading_min_coherence: 0.5,
            heading_min_windows: 3.0,
            retrack: RetrackConfig::default(),
        }
    }
}

/// Longest duration any setting may give, s (a day): longer ones would leave the engine
/// stepping through empty time window by window.
const MAX_DURATION_S: f64 = 86_400.0;

/// The most samples a model's setting may count (a moving average's length, a correlation's
/// minimum): far beyond any window, and small enough to allocate.
const MAX_MODEL_SAMPLES: usize = 100_000;

/// Shortest non-zero duration, s (a microsecond): shorter ones round to nothing in
/// nanoseconds, or nearly so.
const MIN_DURATION_S: f64 = 1e-6;

/// Shortest window and hop, s (a millisecond, far below a camera frame).
const MIN_HOP_S: f64 = 1e-3;

/// Seconds to integer nanoseconds.
pub(crate) fn ns(s: f64) -> i64 {
    (s * 1e9).round() as i64
}

impl EngineConfig {
    /// The models' own settings ([`EngineConfig::geometric`], [`EngineConfig::kinematic`],
    /// [`EngineConfig::belmonte`]): lengths and times that a window's signals can hold. Beyond
    /// them a moving average asked for billions of samples, and the engine ran out of memory.
    fn validate_models(&self) -> Result<()> {
        let (g, k, b) = (&self.geometric, &self.kinematic, &self.belmonte);
        for (name, v) in [
            ("geometric.moving_average_len", g.moving_average_len),
            ("belmonte.moving_average_len", b.moving_average_len),
            ("geometric.min_samples", g.min_samples),
            ("belmonte.min_samples", b.min_samples),
        ] {
            if v > MAX_MODEL_SAMPLES {
                return Err(EngineError::InvalidConfig(format!(
                    "{name} must be at most {MAX_MODEL_SAMPLES} samples, got {v}"
                )));
            }
        }
        for (name, v, max) in [
            ("kinematic.turn_smoothing_s", k.turn_smoothing_s, 60.0),
            ("kinematic.swing_lag_s", k.swing_lag_s, 60.0),
            (
                "geometric.leak_time_constant_s",
                g.leak_time_constant_s,
                3600.0,
            ),
            ("geometric.lowpass_cutoff_hz", g.lowpass_cutoff_hz, 1000.0),
            ("geometric.gravity_mps2", g.gravity_mps2, 100.0),
            ("belmonte.min_heading_line_m", b.min_heading_line_m, 10.0),
        ] {
            if !(v.is_finite() && (0.0..=max).contains(&v)) {
                return Err(EngineError::InvalidConfig(format!(
                    "{name} must be in 0..={max}, got {v}"
                )));
            }
        }
        Ok(())
    }

    /// Checks every value is finite and in range: every duration (a `_s` setting) at most a
    /// day and, unless zero, at least a microsecond; `window_s` and `hop_s` at least a
    /// millisecond; the models' own settings within what a window can hold.
    pub fn validate(&self) -> Result<()> {
        let positive = [
            ("window_s", self.window_s),
            ("hop_s", self.hop_s),
            ("joint_noise_std_m", self.joint_noise_std_m),
            ("gravity_mps2", self.gravity_mps2),
            ("evidence_half_life_s", self.evidence_half_life_s),
            (
                "network_evidence_half_life_s",
                self.network_evidence_half_life_s,
            ),
            (
                "offset_estimation_window_s",
                self.offset_estimation_window_s,
            ),
            ("offset_refine_interval_s", self.offset_refine_interval_s),
            (
                "offset_refine_max_interval_s",
                self.offset_refine_max_interval_s,
            ),
            ("offset_min_track_s", self.offset_min_track_s),
            ("offset_search_interval_s", self.offset_search_interval_s),
            (
                "offset_best_track_interval_s",
                self.offset_best_track_interval_s,
            ),
            ("track_timeout_s", self.track_timeout_s),
            ("max_time_jump_s", self.max_time_jump_s),
            ("stitch_max_speed_mps", self.stitch_max_speed_mps),
            ("belmonte_pitch_sigma_rad", self.belmonte_pitch_sigma_rad),
            (
                "belmonte_yaw_rate_sigma_radps",
                self.belmonte_yaw_rate_sigma_radps,
            ),
            ("stitch_radius_m", self.stitch_radius_m),
            ("tag_sigma_horizontal_m", self.tag_sigma_horizontal_m),
            ("tag_sigma_vertical_m", self.tag_sigma_vertical_m),
            ("tag_evidence_half_life_s", self.tag_evidence_half_life_s),
            ("tag_window_s", self.tag_window_s),
            ("rssi_evidence_half_life_s", self.rssi_evidence_half_life_s),
            ("heading_half_life_s", self.heading_half_life_s),
        ];
        let non_negative = [
            ("reorder_window_s", self.reorder_window_s),
            ("joint_smoother_lag_s", self.joint_smoother_lag_s),
            ("joint_gap_bridge_s", self.joint_gap_bridge_s),
            (
                "joint_gap_bridge_inferred_s",
                self.joint_gap_bridge_inferred_s,
            ),
            ("silence_timeout_s", self.silence_timeout_s),
            ("decision_delay_s", self.decision_delay_s),
            ("warmup_s", self.warmup_s),
            ("warmup_sync_s", self.warmup_sync_s),
            ("open_set_memory_s", self.open_set_memory_s),
            ("history_pad_s", self.history_pad_s),
            ("switch_margin", self.switch_margin),
            ("unsynced_switch_margin", self.unsynced_switch_margin),
            ("max_clock_offset_s", self.max_clock_offset_s),
            ("offset_refine_range_s", self.offset_refine_range_s),
            ("offset_label_min_track_s", self.offset_label_min_track_s),
            ("offset_short_track_s", self.offset_short_track_s),
            ("offset_label_margin", self.offset_label_margin),
            ("offset_best_track_margin", self.offset_best_track_margin),
            ("offset_unexplained_margin", self.offset_unexplained_margin),
            ("offset_margin", self.offset_margin),
            ("offset_consistency_s", self.offset_consistency_s),
            ("offset_confirm_apart_s", self.offset_confirm_apart_s),
            ("offset_tie_tolerance", self.offset_tie_tolerance),
            ("offset_peak_clarity", self.offset_peak_clarity),
            ("stitch_max_gap_s", self.stitch_max_gap_s),
            ("stitch_velocity_span_s", self.stitch_velocity_span_s),
            ("encounter_distance_m", self.encounter_distance_m),
            ("camera_pair_distance_m", self.camera_pair_distance_m),
            (
                "camera_exclusion_distance_m",
                self.camera_exclusion_distance_m,
            ),
            ("stitch_view_distance_m", self.stitch_view_distance_m),
            ("heading_min_windows", self.heading_min_windows),
        ];
        for (name, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(EngineError::InvalidConfig(format!(
                    "{name} must be > 0, got {v}"
                )));
            }
        }
        for (name, v) in non_negative {
            if !(v.is_finite() && v >= 0.0) {
                return Err(EngineError::InvalidConfig(format!(
                    "{name} must be >= 0, got {v}"
                )));
            }
        }
        // Durations become integer nanoseconds and step the engine's clock: a positive one
        // must stay positive once rounded (`hop_s = 1e-12` would be a zero step), and none may
        // be so long that the engine steps through it window by window (or overflows).
        for (name, v) in positive.iter().chain(&non_negative) {
            if !name.ends_with("_s") {
                continue;
            }
            if *v > MAX_DURATION_S {
                return Err(EngineError::InvalidConfig(format!(
                    "{name} must be at most {MAX_DURATION_S} s (a day), got {v}"
                )));
            }
            if *v > 0.0 && *v < MIN_DURATION_S {
                return Err(EngineError::InvalidConfig(format!(
                    "{name} must be 0 or at least {MIN_DURATION_S} s, got {v}"
                )));
            }
        }
        for (name, v) in [("window_s", self.window_s), ("hop_s", self.hop_s)] {
            if v < MIN_HOP_S {
                return Err(EngineError::InvalidConfig(format!(
                    "{name} must be at least {MIN_HOP_S} s, got {v}"
                )));
            }
        }
        for (name, v) in [
            ("min_window_coverage", self.min_window_coverage),
            (
                "offset_label_min_correlation",
                self.offset_label_min_correlation,
            ),
            ("rejection_threshold", self.rejection_threshold),
            ("offset_min_correlation", self.offset_min_correlation),
            ("offset_subject_margin", self.offset_subject_margin),
            ("offset_withdraw_below", self.offset_withdraw_below),
            (
                "offset_unexplained_min_peak",
                self.offset_unexplained_min_peak,
            ),
            (
                "offset_label_network_min_peak",
                self.offset_label_network_min_peak,
            ),
            ("exclusion_margin", self.exclusion_margin),
            ("camera_exclusion_margin", self.camera_exclusion_margin),
            ("camera_exclusion_tie", self.camera_exclusion_tie),
        ] {
            if !(v.is_finite() && (-1.0..=1.0).contains(&v)) {
                return Err(EngineError::InvalidConfig(format!(
                    "{name} must be in -1..=1, got {v}"
                )));
            }
        }
        for (name, v) in [
            ("stitch_evidence_weight", self.stitch_evidence_weight),
            (
                "stitch_tag_evidence_weight",
                self.stitch_tag_evidence_weight,
            ),
            ("heading_min_coherence", self.heading_min_coherence),
            ("min_name_probability", self.min_name_probability),
            ("tag_min_name_probability", self.tag_min_name_probability),
            (
                "open_set_min_name_probability",
                self.open_set_min_name_probability,
            ),
            ("open_set_min_score", self.open_set_min_score),
        ] {
            if !(v.is_finite() && (0.0..=1.0).contains(&v)) {
                return Err(EngineError::InvalidConfig(format!(
                    "{name} must be in 0..=1, got {v}"
                )));
            }
        }
        if !(self.inferred_joint_noise_factor.is_finite()
            && self.inferred_joint_noise_factor >= 1.0)
        {
            return Err(EngineError::InvalidConfig(format!(
                "inferred_joint_noise_factor must be >= 1, got {}",
                self.inferred_joint_noise_factor
            )));
        }
        self.validate_models()?;
        self.retrack.validate()?;
        if self.hop_s > self.window_s {
            return Err(EngineError::InvalidConfig(format!(
                "hop_s ({}) must not exceed window_s ({})",
                self.hop_s, self.window_s
            )));
        }
        if 2.0 * self.max_clock_offset_s >= self.offset_estimation_window_s {
            return Err(EngineError::InvalidConfig(
                "offset_estimation_window_s must exceed twice max_clock_offset_s".into(),
            ));
        }
        if self.offset_unexplained_margin > 0.0
            && !(1..=self.offset_unexplained_passes).contains(&self.offset_unexplained_votes)
        {
            return Err(EngineError::InvalidConfig(format!(
                "offset_unexplained_votes ({}) must be in 1..=offset_unexplained_passes ({})",
                self.offset_unexplained_votes, self.offset_unexplained_passes
            )));
        }
        if self.offset_num_consistent == 0 {
            return Err(EngineError::InvalidConfig(
                "offset_num_consistent must be >= 1".into(),
            ));
        }
        for (name, w) in self.model_weights.all() {
            if !(w.is_finite() && w >= 0.0) {
                return Err(EngineError::InvalidConfig(format!(
                    "model_weights.{name} must be >= 0, got {w}"
                )));
            }
        }
        self.madgwick.validate()?;
        if let Some(map) = &self.confidence_map {
            map.validate()?;
        }
        Ok(())
    }

    /// Whether windows score Belmonte-Hernández's band costs: alone
    /// ([`MotionScore::Belmonte`]) or weighted into nomen's score.
    pub fn wants_belmonte(&self) -> bool {
        self.motion_score == MotionScore::Belmonte
            || (self.motion_score == MotionScore::Nomen && self.model_weights.belmonte > 0.0)
    }

    /// Worst-case latency from an observation's time to its output, s, while every source keeps
    /// sending, once the session's warm-up is over: `decision_delay_s + hop_s +
    /// reorder_window_s`. A silent source adds at most `silence_timeout_s`.
    pub fn latency_s(&self) -> f64 {
        self.decision_delay_s + self.hop_s + self.reorder_window_s
    }

    /// Worst-case latency of any observation, s, while every source keeps sending:
    /// [`EngineConfig::latency_s`] plus `warmup_s` and `warmup_sync_s`, which only the
    /// session's first observations wait ([`EngineConfig::warmup_s`],
    /// [`EngineConfig::warmup_sync_s`]).
    pub fn max_latency_s(&self) -> f64 {
        if self.warmup_s > 0.0 {
            self.latency_s() + self.warmup_s + self.warmup_sync_s
        } else {
            self.latency_s()
        }
    }
}
