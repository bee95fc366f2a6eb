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
#[serde(rename_all = "snake_case")]
pub enum MotionScore {
    /// De Marchi et al. as published: their three correlations (acceleration, velocity,
    /// orientation magnitudes) fused by [`EngineConfig::fusion`].
    DeMarchi,
    /// nomen's: the mean over the subject's IMUs of De Marchi's three correlations *and* nomen's
    /// five (swing angle over a short lag, vertical acceleration, vertical velocity, segment
    /// inclination, turn rate; `nomen_evidence::kinematic`). On the simulated 8-person
    /// body-area-network scene with known clock offsets, adding the first three made the true
    /// subject the best single-window score in 84% of windows against 65% for De Marchi's three
    /// alone; inclination was added after that measurement (end to end it moved the 8-person
    /// wrist scene from 21.8 to 27.6 %), the turn rate after that (see its module docs), and
    /// Belmonte-Hernández's similarity for forearm bands after that (see [`ModelWeights`]).
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

/// Weights of the models in [`MotionScore::Nomen`]'s score: the window score of a (track,
/// subject) pair is `Σ w·r / Σ w` over every correlation `r` present (each IMU of the subject,
/// each model).
///
/// The defaults are each model's linear-discriminant weight `(μ_match − μ_other)/σ²`, scaled to
/// mean 1, measured on the CNN training scenes (`scenarios/train/*.toml` at seeds 101 and 102,
/// full body-area networks, true clock offsets, 2 s windows; 38 k pair windows): none of them
/// is an evaluation scene. Separations `d′` were 0.71 (acceleration), 0.58 (velocity), 0.57
/// (orientation), 0.89 (swing), 0.87 (vertical acceleration), 1.12 (vertical velocity), 0.85
/// (inclination) and 0.96 (turn rate). All weights 1 give the plain mean. Those were measured
/// with the turn rates compared by Pearson's correlation over 1-s averages; with the current
/// concordance over 0.7 s and the joint smoother, the same procedure (2 s windows, per IMU
/// pair, 46–67 k pair windows per model) gives `d′` 1.51 for the turn rate and weights 1.05 / 0.73 / 0.53 /
/// 0.78 / 1.14 / 1.00 / 1.09 / 1.67 in the order above; those changed the 138 simulated runs
/// of the engine README by +0.14 ± 0.12 points per run, within the noise, so the defaults
/// stay.
///
/// A band on a forearm (wrist, hand or elbow) also adds Belmonte-Hernández's similarity
/// (`MotionScore::Belmonte`'s score: wrist pitch and chest yaw rate, in [0, 1]) with weight
/// `belmonte`. Its default 1 was chosen on the ten imu-table scenes (seeds 1–6: mean accuracy
/// 72.9 % without it, 74.0 / 74.9 / 75.0 / 74.4 % at 0.5 / 1 / 2 / 3) and checked on seeds 7–9
/// (78.2 → 79.1 %; 8 people with one wrist IMU 41.8 → 48.2 %).
///
/// `heading` weighs the correlation of the horizontal accelerations of IMU and joint in the
/// room frame, once the IMU's heading (its AHRS frame's rotation about the vertical) is known
/// (see [`EngineConfig::heading_half_life_s`]). Unlike every other model it tells apart two
/// people who move alike in different directions. On the 8-person wrist scene at seed 1 with
/// true clock offsets, right pairs scored 0.34 ± 0.28 per window and wrong ones 0.00 ± 0.25
/// (`d′` 1.3; the others measured 0.57–1.12 on the training scenes). Its default 3 was chosen on the ten imu-table scenes,
/// seeds 1–9, with the heading settings at their defaults: mean accuracy 81.5 % without it,
/// 81.7 / 82.0 / 82.1 % at 2 / 3 / 4 (8 people, full network: 89.2 % without, 89.9 / 90.1 /
/// 90.1 %; one wrist IMU: 64.5 %, 64.0 / 65.1 / 65.0 %); with true clock offsets, 92.5 % without
/// and 93.0 % at 3.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
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
#[serde(default, deny_unknown_fields)]
pub struct EngineConfig {
    /// Evidence window length, s. Default 2 s (De Marchi et al. compare 1–4 s windows; 2 s holds
    /// about two gait cycles). Shorter windows mix fewer camera-track changes (re-labelling,
    /// id swaps, left/right flips) and give a new track evidence sooner: over the ten imu-table
    /// scenes at seeds 1–3, mean accuracy was 60.6 % at 4 s, 65.3 % at 3 s, 66.9 % at 2 s and
    /// 65.5 % at 1.5 s (half-life 1 s).
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
    /// message per source; a source that jumps while the others go on is refused throughout). Without it, one corrupt timestamp an hour ahead would put its source's
    /// reorder window an hour ahead, so that every later message of that source is refused as
    /// late, and every window until then would time out waiting for the others. The session's
    /// first message waits for the next one and is dropped if that is stamped more than this
    /// much before it ([`crate::Engine::push`]). Default 60 s.
    pub max_time_jump_s: f64,
    /// A skeleton observed at `t` is labelled with the decision of the first window ending at or
    /// after `t + decision_delay_s`, s. Larger values let the first frames of a new track use
    /// evidence from after them, at the price of latency. Default 1.5 s. Over the ten imu-table
    /// scenes, seeds 1–9, mean accuracy was 78.7 / 80.5 / 81.4 / 81.8 / 82.5 % at 1 / 1.5 / 2 /
    /// 2.5 / 3 s (8 people, full network: 85.7 / 89.0 / 90.0 / 89.6 / 88.9 %; one wrist IMU:
    /// 58.1 / 59.3 / 59.9 / 60.0 / 61.2 %); the Belmonte-Hernández intruder stayed anonymous in
    /// 93.2 / 93.1 / 93.0 / 92.9 % of his frames at 1.5 / 2 / 2.5 / 3 s. Each extra second is a
    /// second more before a frame's decision comes out; the gain is mostly at track starts.
    pub decision_delay_s: f64,
    /// A session's warm-up, s: an observation within `warmup_s` of the session's first skeleton
    /// is labelled with the decision of the first window ending at or after
    /// `first + warmup_s + decision_delay_s`, as if it had been observed at the warm-up's end;
    /// when that decision leaves its track anonymous, with the latest earlier one that named the
    /// track, from the observation's own due time `t + decision_delay_s` on. Until the first
    /// windows have filled and the first clock offsets are known, few people can be named, so
    /// without it a session's first frames come out anonymous whatever follows; with it they
    /// wait for the decisions that can name them, at most `warmup_s` longer (see
    /// [`EngineConfig::max_latency_s`]); later observations are not affected. Default 2.0 s.
    /// Over the 138 simulated runs of the engine README, 1 / 2 / 3 s gained 0.66 / 0.81 / 0.90
    /// points per run against none (every run better or the same at 1 s). Against 1 s, over
    /// the 120 runs of the engine README, 2 s gained 0.127 ± 0.029 points per run (61 better,
    /// 16 worse) and, with the earlier decisions it may fall back on, 0.130 ± 0.028; without
    /// them the Belmonte-Hernández wearer, named at the first decision, came out anonymous in
    /// her first 2 s once the man without a band walked in (episode 97.36 → 96.64 % over seeds
    /// 1–72; 97.36 % with them). The cost is the man's first frames named more often:
    /// anonymous in 99.74 → 99.68 % of his frames over seeds 1–72, 99.23 → 99.05 % over seeds
    /// 73–144; at 3 s, 99.52 and 98.56 %. Such an earlier name is not taken when another
    /// track of the camera, seen at the observation's time, carries it when the observation
    /// is sent (it was given before the subject's clock was known, to a look-alike): the man
    /// anonymous in 99.51 → 99.74 % of his frames over seeds 1–144 (episode 97.82 → 97.94 %,
    /// no seed worse). `0` turns it off (and `warmup_sync_s` with it). While no clock is known
    /// the warm-up may last longer: see [`EngineConfig::warmup_sync_s`].
    pub warmup_s: f64,
    /// How much longer than `warmup_s` the warm-up's observations may wait for decisions made
    /// at known clocks, s. Before any clock offset is accepted (about 4.5 s into a session at
    /// the earliest) each (IMU, track) pair is scored at its own best lag, and people who walk
    /// alike at different phases fit each other's tracks: the decision at the fixed warm-up's
    /// end can name them in a ring (on the 5-person scene at seed 2: Eva's track Ana, Ana's
    /// Dan, Dan's Ben, Ben's Eva). So the warm-up ends at the first decision, from
    /// `first + warmup_s + decision_delay_s` on, at which every track with observations still
    /// waiting has a final decision, or `warmup_sync_s` later at the latest. A decision is
    /// final when it names someone whose clock is known (one of their IMUs has an accepted
    /// offset, or they wear none), or leaves the track anonymous, unless the track holds a name
    /// withheld from another track for unknown clocks
    /// ([`EngineConfig::unsynced_switch_margin`]). Each waiting observation takes its track's
    /// first final decision from its own due time on (an anonymous one falls back as
    /// `warmup_s` says), or the track's decision at the warm-up's end when there was none.
    /// A track left anonymous otherwise is not waited for: after a camera has swapped two
    /// people's ids, a later decision can name the wearer's new track while the observations
    /// waiting on it are the other person's (the Belmonte-Hernández man without a band, named
    /// in his first 3 s when the whole warm-up waited 3 s more).
    ///
    /// Default 3.0 s: over the 162 simulated runs of the engine README, +0.36 ± 0.05 points per
    /// run against 0 (98 better, 3 worse: the one-wrist 5-person scene, by up to 1.6 points);
    /// 8 people, full network 99.10 → 99.32 % (seeds 1–27), one wrist IMU 98.18 → 98.63 %
    /// (seeds 1–33), 5 people, full network 95.88 → 97.18 % (seeds 1–15); on 42 runs simulated
    /// afterwards +0.35 ± 0.10 (32 better, 4 worse); the Belmonte-Hernández wearer beside the
    /// man without a band 97.36 → 97.73 % (seeds 1–72) and 97.50 → 97.91 % (73–144), the man
    /// as anonymous as before. Given the true offsets no decision changed. Against 3 s
    /// (measured before withheld names counted): 2 s −0.03 per run (8 worse), 4 s +0.00, 5 s
    /// +0.08 (64 better, 6 worse) for two seconds more. On the IMU scenes of 3 people or more
    /// the bound is usually reached: the warm-up's decisions then come from the window ending
    /// about 6.8 s after the session's first skeleton, and no observation waits longer than
    /// [`EngineConfig::max_latency_s`] (7.25 s by default). `0` keeps the fixed warm-up.
    pub warmup_sync_s: f64,
    /// Fraction of the window a track must cover (first to last sample) to be scored. Default 0.5.
    pub min_window_coverage: f64,
    /// Paired views take turns: a track that another camera's track shows the same person as
    /// (its view, [`EngineConfig::camera_pair_distance_m`]) gets no motion scores at the hops
    /// when its camera rests (the cameras take turns, one per hop), if that view was seen
    /// before the window, is named, will be scored in it, and the track is unnamed (new, most
    /// often) or named alike. Its motion evidence then ages by the hop as if scored with no
    /// weight. The decisions pool the views' evidence, so the person is still scored at every
    /// window. Location-tag and RSSI evidence are scored on every view at every window.
    ///
    /// Default true: on the 8-person scene of the bench (two cameras that both see everyone,
    /// seed 1), with the refinement's one view per person (engine README, stop 62), the
    /// engine's instructions fall by 16 % with every offset known and by 6.5 % with offsets
    /// searched (callgrind: 4.51 → 3.78 and 8.09 → 7.56 billion). Over the 259-run sweep of
    /// the engine README, +0.001 points per run (25 runs better, 18 worse, all with two
    /// cameras; 8 people full network 99.32 → 99.32 %, one wrist 98.61 → 98.62 %); over the 86
    /// runs of the second sweep −0.001 (two of the four 180-s 8-person runs better, two worse).
    /// Scenes with one camera are unchanged. Off, every view is scored at every window.
    pub alternate_paired_views: bool,
    /// Seconds of history before each window that the low-passed and smoothed signals of both
    /// sides are computed over before the window's part is scored, s (≥ 0); the
    /// window-anchored models (orientation change, velocity, vertical velocity) still start at
    /// the window's first sample. Default 0: every signal starts at the window.
    ///
    /// An experiment for streaming features: with a pad longer than the filters' memory, a
    /// window's signals are those a filter run once per sample would give, so they could be
    /// computed once and sliced per window, leaving per window only the anchored models (cheap
    /// to finish from per-sample orientations and integrals) and the low-pass's backward pass.
    /// At 1 s, against 0 (one run of each scene, paired, points per run): Belmonte's man
    /// without a band anonymous in 99.67 % of his frames instead of 99.51 % (seeds 1–144),
    /// accuracy per episode +0.16 ± 0.09; 8 people full network −0.01 ± 0.02 (99.32 → 99.30 %,
    /// seeds 1–27), one wrist +0.05 ± 0.04 (98.63 → 98.68 %, seeds 1–33); 5 people one wrist
    /// +0.17 ± 0.32 (seeds 1–10); 2 to 5 people full network within 0.03. Computed as here, the pad
    /// filtered again at every window, it costs about 40 % more engine time (8 people full
    /// network, every offset known), so it is off.
    pub history_pad_s: f64,
    /// How De Marchi's per-(joint, model) correlations of one window are fused into one score
    /// per (track, subject) (`nomen_evidence::fuse`). Default [`Fusion::Max`]: the best mean
    /// accuracy over the simulated wrist/BAN 2/4/8 scenes at seeds 1 and 2 (0.52 against 0.49 for
    /// `model_vote`, 0.43 for `mean`; see the crate README). `model_vote` is better on the
    /// 8-person body-area-network scene.
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
    /// `min_vote_score` 0.2: a track whose best correlation in a ballot is weaker abstains
    /// (still counted), so an intruder does not collect votes just by being the least bad match
    /// (with 0 or 0.15 the engine's intruder test fails; 0.3 cost 5–14 points on the wrist
    /// scenes). Chosen by measurement, not from the literature.
    pub fusion_config: FusionConfig,
    /// Filters and smoothing of De Marchi's magnitude signals (`nomen_evidence::geometric_scores`).
    pub geometric: GeometricConfig,
    /// Constant-velocity Kalman filter on every world-frame joint; `None`: raw joints. Default
    /// an acceleration noise density of 1.33 m²/s³ (Bar-Shalom's `a_max² · T` for about
    /// 6.3 m/s² at 30 Hz; the filter crate's generic default is 3, 10 m/s²) and an initial
    /// velocity within 2 m/s. The smoother joints fit their wearers' IMUs better: against 3,
    /// +1.24 ± 0.43 points per run over the 138 runs of [`Self::inferred_joint_noise_factor`]
    /// (60 better, 25 worse; the ten imu-table scenes 93.27 → 93.72 %) and +0.59 ± 0.23 over
    /// its 45 (23 better, 9 worse); 180-s scenes: full network 98.10 → 98.16 %, one wrist 91.88
    /// → 93.99 % (seeds 1–3) and 93.79 → 94.29 % (4–9); given the true offsets 97.64 → 97.71 %.
    /// At 0.75: +1.14 ± 0.55 and −0.10 ± 0.48. (All without the smoother below.) A causal
    /// filter delays a gait's signals, and the estimated clock offsets, which align the IMU with
    /// the filtered joints, absorbed it: at the end of the ten scenes' 90 runs they sat 29 ms
    /// (median) after the true offsets, 21 ms at 3; the smoother removes that delay.
    pub joint_filter: Option<ConstantVelocityConfig>,
    /// How far back the joint filter's estimates are revised by a fixed-lag Rauch–Tung–Striebel
    /// smoother, s (`nomen_filters::kalman::JointSmoother`; 0: the filter alone). The samples are
    /// revised once per window, those of the last hop as well, so each is smoothed over at least
    /// this much of what came after it; the engine waits 2.25 s for a decision anyway. Default
    /// 0.3 s. Against the filter alone (and the best-track pass on every second coarse lag):
    /// +2.86 ± 0.47 points per run over the 138 runs of [`Self::inferred_joint_noise_factor`]
    /// (96 better, 14 worse; the ten imu-table scenes 93.72 → 95.52 %), +2.92 ± 1.09 over its 45
    /// (31 better, 13 worse; 90.70 → 93.63 %); given the true offsets 97.71 → 98.12 %; 180-s
    /// scenes: full network 98.16 → 98.32 %, one wrist 93.99 → 93.96 % (seeds 1–3) and 94.29 →
    /// 95.64 % (4–9). Estimated offsets end 1.8 ms (median) after the true ones, not 29. Lags of
    /// 0.2 / 0.5 / 1.0 s gave −0.77 ± 0.38 / +0.18 ± 0.13 / +0.19 ± 0.12 per run against 0.3
    /// over the 138 runs (smoothing at every observation; at 0.5, +0.01 ± 0.16 over the 45 and
    /// −0.05 ± 0.04 given the true offsets). The price: sharper gait signals also fit a
    /// look-alike better. In the Belmonte-Hernández episode with one person unbanded, at seed
    /// 5 the intruder walks the wearer's clip half a second out of phase, inside the offset
    /// search's range, and fits the band better than the wearer for the first 10 s: he is
    /// named for half his frames (anonymous in 96.80 % over seeds 1–18, against 99.41 %
    /// without the smoother).
    pub joint_smoother_lag_s: f64,
    /// For a camera that drops occluded joints (a pose estimator such as OpenPose or MMPose,
    /// which reports no joint as inferred): gaps in a joint's observations up to this long,
    /// from the frame before the gap to the frame after it, are filled with the joint
    /// smoother's estimate there, s (0: none). Needs [`Self::joint_smoother_lag_s`] > 0, and
    /// fills only what the smoother still revises (`joint_smoother_lag_s + hop_s` back). A
    /// camera is taken for such an estimator once its skeletons have carried no inferred joint
    /// for their first 2 s; until then, and for good once one comes,
    /// [`Self::joint_gap_bridge_inferred_s`] applies. Default 0.5 s.
    ///
    /// Without inferred joints a wrist's track is full of short gaps: each one breaks the
    /// signals the models differentiate and correlate, and the clock offset search can lock
    /// onto a wrong peak (a band's offset found at +0.42 s instead of −0.40 s). On the sweep's
    /// scenes with every joint the simulated camera only inferred removed (18 % of the joints,
    /// a third of the wrists' frames), the share of frames named right without filling → with
    /// the defaults: one wrist band, 8 people (seeds 1–10) 83.73 → 97.22 % (92.21 % at 0.3 s;
    /// 98.6 % with the inferred joints); full networks, 8 people (seeds 1–5) 98.83 → 98.86 %;
    /// 5 people, full networks 95.22 → 96.36 %, one wrist 74.88 → 82.07 %; the
    /// Belmonte-Hernández episodes (seeds 1–36) 97.65 → 98.71 %, the man without a band
    /// anonymous in 98.45 → 99.60 % of his frames.
    pub joint_gap_bridge_s: f64,
    /// [`Self::joint_gap_bridge_s`] for a camera that reports occluded joints as inferred (a
    /// depth SDK: Kinect, Azure Kinect, ZED), whose remaining gaps are joints out of view.
    /// Default 0 (none): on the sweep's scenes, 0.3 s changed no decision of the
    /// Belmonte-Hernández episodes and moved the others within their noise (8 people, full
    /// networks 99.32 → 99.32 %, one wrist 98.63 → 98.60 %; 5 people, full networks 97.18 →
    /// 97.08 %, one wrist 92.70 → 92.42 %), while 0.4 s filled the episodes' 0.3–0.4 s gaps at
    /// the elbows and the man without a band was named in 1.26 % of his frames instead of
    /// 0.49 %.
    pub joint_gap_bridge_inferred_s: f64,
    /// Joint measurement noise (per axis standard deviation) for the Kalman filter, m. Default
    /// 0.03 m (Kinect v2 joint noise at 2–4 m, Otte et al. 2016).
    pub joint_noise_std_m: f64,
    /// Factor on [`Self::joint_noise_std_m`] for a joint the camera reports as inferred
    /// (`JointState::Inferred`: occluded, guessed by the SDK), so the Kalman filter leans on
    /// its motion model there instead of following the guess (Kinect v2 inferred joints err
    /// several times more than tracked ones, Wang et al. 2015); 1 treats both alike. In the
    /// 8-person scenes a wrist is inferred in about a quarter of the frames.
    ///
    /// Default 3, measured with the filter crate's default joint filter (3 m²/s³; see
    /// [`Self::joint_filter`]) over the ten imu-table scenes at seeds 1–9 given the true clock
    /// offsets (where no offset search can lock in): 97.20 % of frames right at 1, 97.44 /
    /// 97.64 / 97.69 / 97.80 % at 2 / 3 / 4 / 6 (at 3: +0.44 ± 0.09 points per run, 25 runs
    /// better, 1 worse; one wrist, 8 people 94.01 → 95.05 %). Dropping inferred joints instead
    /// (gaps) gave 92.96 %. With searched offsets the gain is smaller and noisier, since a
    /// sharper early fit also changes which look-alike's track an offset locks onto first: 3
    /// against 1 (with `offset_subject_margin` 0.05 and `offset_label_network_min_peak` 0.3)
    /// +0.13 ± 0.53 per run over 138 runs (the ten scenes at seeds 1–9, both 8-person scenes at
    /// 10–15, one wrist at 5 and 8 people at 16–33) and +0.32 ± 0.99 over 45 more (5 scenes at
    /// seeds 10–18). 4 did better there (+1.00 ± 0.32 per run against 3 over the 138, +0.62
    /// ± 0.97 over the 45), but in the Belmonte-Hernández intruder episode at seed 5 the
    /// intruder's first window fitted the band better than its wearer's track did and he was
    /// named for half of his frames: anonymous in 96.51 % of his frames over seeds 1–18
    /// (99.48 % at 3; seeds 19–36: 99.71 % at 4, 99.63 % at 3).
    pub inferred_joint_noise_factor: f64,
    /// Madgwick gains for every IMU's `world_from_sensor`.
    pub madgwick: MadgwickConfig,
    /// Gravity removed from the world-frame specific force, m/s².
    pub gravity_mps2: f64,
    /// Half-life of the exponentially weighted evidence of one (track, device) pair, s.
    /// Default 2 s: a window already spans `window_s`, and older evidence may belong to someone
    /// else (a camera's id swap, a stitch, an encounter), but once cameras pool their views
    /// (see [`EngineConfig::camera_pair_distance_m`]) and stitches inherit at a discount, a
    /// longer memory helps more than it costs. Over the ten imu-table scenes, seeds 1–9, mean
    /// accuracy was 79.4 % at 0.7 s, 79.9 % at 1 s, 80.6 % at 1.5 s, 80.5 % at 2 s and 80.7 % at
    /// 3 s (8 people, full network: 87.4, 88.7, 88.2, 89.0, 87.6 %; one wrist IMU: 53.9, 55.0,
    /// 59.0, 59.2, 60.8 %). An earlier sweep, before pooling and with 3 s windows, had favoured
    /// 0.5–1 s.
    pub evidence_half_life_s: f64,
    /// Half-life of the same evidence for a subject wearing a body-area network (more than one
    /// IMU) once one of its IMUs' clock offsets is accepted, s. Default 1 s. A network's window
    /// score is then the mean of several IMUs' correlations at their own clocks, steadier than
    /// one IMU's, so less of the past is needed to outweigh a bad window, and a shorter memory
    /// lets a track follow sooner when the camera's tracker hands it to another person. Before
    /// that, scores at unconfirmed lags are noisy and keep `evidence_half_life_s`. Measured over
    /// the full-network imu-table scenes (2–8 people, seeds 1–9; 3–5 people also at seeds
    /// 10–15; 8 people also at 10–15; the 180-s 8-person scene at 1–3), per run against 2 s:
    /// +0.14 points (46 better, 2 worse: −0.29, −0.02); 0.75 s +0.10 (10 worse), 1.25 s
    /// +0.07; the same 1 s from the first window +0.17 but 6 worse (the warm-up's few noisy
    /// windows decided alone). The one-wrist scenes of 2–5 people lost 0.2–0.5 points at
    /// 1.5 s, so a single IMU keeps the longer half-life.
    pub network_evidence_half_life_s: f64,
    /// Lowest accumulated score at which a track may be given a subject; below it the track stays
    /// anonymous. In the window score's units: a mean correlation for [`MotionScore::Nomen`]
    /// and the correlation fusions, a vote share for the voting fusions, a similarity for
    /// [`MotionScore::Belmonte`]. Default 0.15, measured for the default [`MotionScore::Nomen`]
    /// (on the simulated 8-person body-area-network scene 0.1–0.2 are within 2 points; wrong
    /// pairs average about 0.1 per window, right ones about 0.4). `nomen experiment imu-table`
    /// uses 0.3 for De Marchi's fusions and 0.2 for Belmonte's similarity. It is also the knob
    /// for where a wrong name costs more than none: pooled over the frames of the ten imu-table
    /// scenes (seeds 1–9), 0.15 / 0.22 / 0.3 name 77.3 / 75.9 / 72.0 % of frames right and
    /// 16.8 / 14.9 / 9.6 % wrong, and keep the Belmonte-Hernández intruder anonymous in 93.2 /
    /// 94.5 / 97.4 % of his frames. (Leaving a subject anonymous while a second coexisting track
    /// scores within 0.05 of its own, until its IMU offsets are known, traded worse: 74.6 % right,
    /// 13.8 % wrong, intruder 96.7 %.)
    pub rejection_threshold: f64,
    /// Bonus the current label of a track gets in the assignment, so another subject must beat
    /// it by this much to take over (hysteresis on top of the exponential averaging), in the
    /// window score's units. Default 0.02 (for [`MotionScore::Nomen`]: right and wrong subjects
    /// of similar-looking walkers differ by 0.05–0.1, so 0.1 locked early mistakes in).
    pub switch_margin: f64,
    /// While none of a subject's IMUs has an accepted clock offset, every (track, IMU) pair is
    /// scored at its own best lag, which flatters anyone who walks like the wearer. A label
    /// that would then move from one track to another that coexists with it (two people in
    /// view at once, one camera) must beat the holder's score by this much; if it does not,
    /// neither track holds the subject for that decision (no hysteresis bonus for either at the
    /// next), but the holder's track goes on holding her for this rule until its next named
    /// decision: otherwise the name, withheld once, reached the look-alike at the next window
    /// (a synthetic look-alike test: 90 of its frames). In the window score's units; 0
    /// disables. Default 0.1:
    /// the Belmonte-Hernández intruder stays anonymous in 99.27 % of his frames (98.83 % at 0,
    /// over seeds 1–9: of his 120 named frames, 75 were a label that moved to him by 0.04–0.06
    /// before the wearer's band offset was known), at 0.05 / 0.2 in 99.12 / 99.27 %. Over the
    /// ten imu-table scenes (seeds 1–9) 90.72 % of frames right at 0, 90.38 / 90.62 / 90.52 %
    /// at 0.05 / 0.1 / 0.2; with the margin at every decision, offsets known or not, 90.12 %.
    /// On unseen seeds 10–18 the intruder stays anonymous in 99.35 % of his frames (98.91 % at
    /// 0).
    /// The same margin guards a name no offset backs that is given for the first time or kept:
    /// the track must beat, by this much, every coexisting track the assignment left without
    /// a name (for subjects who wear IMUs). Without that, an intruder who walks like the wearer
    /// was named whenever his track scored a little above hers at the first decisions. Over
    /// seeds 1–72 of the Belmonte-Hernández episode with him, he stays anonymous in 99.17 % of
    /// his frames instead of 98.67 % (10 seeds better, none worse), and the episode's frames
    /// are 97.09 % right instead of 97.56 % (the wearer, too, waits while the two score within
    /// the margin); on seeds 73–144, 98.06 % instead of 97.28 % and 96.43 % instead of 96.38 %
    /// (all with `offset_margin` at 0.1; see [`EngineConfig::offset_margin`] for 0.125). The
    /// imu-table scenes do not move (the other tracks there hold names of their own).
    pub unsynced_switch_margin: f64,
    /// A track that was seen alongside the track holding a subject may take that subject later
    /// (the holder left, or lost it) only while its own score for the subject stays within this
    /// much of the holder's score at the last decision they shared; otherwise the subject is
    /// out of its reach. Two people walking together correlate with each other's wearables:
    /// when the wearer leaves, the companion's leftover score must not name him. Negative
    /// disables. Default 0.2 (in the window score's units). Over the ten imu-table scenes
    /// (seeds 1–9), 85.82 % of frames were right without it, 84.92 / 86.04 / 86.07 % at
    /// 0.1 / 0.2 / 0.3 (at 0.2: 8 people, full network 90.56 → 90.97 %, one wrist IMU 75.07 →
    /// 75.61 %; with true clock offsets 95.93 → 95.75 %); the Belmonte-Hernández intruder
    /// stayed anonymous in 98.1 → 98.7 % of his frames (accuracy 96.4 → 96.7 %), and his
    /// two-band episode went from 89.8 to 90.0 %. Too tight a margin (0.1) keeps a track from
    /// taking a subject it lost to a wrong holder. The memory does not expire (a companion may
    /// stay long after the wearer left): a track that turns out later to follow the subject,
    /// after an id swap the engine did not see, must first score within the margin of the
    /// holder's last score.
    pub exclusion_margin: f64,
    /// Largest difference searched for between a device's clock offset and the registry's
    /// offset for it (the prior; 0 when the registry says nothing), s. Default 0.6 s (the
    /// simulator draws up to ±0.5 s and registers 0).
    pub max_clock_offset_s: f64,
    /// Length of the buffer over which a device's clock offset is estimated, s. Default 12 s
    /// (several gait cycles *and* several turns, so the true lag beats the lags one stride off).
    /// Longer is not better: at 16 s the ten imu-table scenes (seeds 1–9) gave 92.66 % against
    /// 93.04 % (one wrist IMU, 5 people, 80.52 → 77.88 %).
    pub offset_estimation_window_s: f64,
    /// Shortest stretch of a track (first to last sample in the buffer) for it to be a candidate
    /// in the offset search, s. Default 2.5 s: the median simulated track lasts about 2.5 s, so
    /// a 4 s floor left most people without a candidate for the first 10–20 s. Over the ten
    /// imu-table scenes at seeds 1–6, mean accuracy was 64.4 % at 4 s, 69.6 % at 2.5 s and
    /// 68.8 % at 2 s (with `offset_subject_margin` 0; at 2.5 s without that check, 67.7 %).
    pub offset_min_track_s: f64,
    /// Shortest stretch of a track (as for `offset_min_track_s`) for it to be scored at its own
    /// lag-curve peak, when that peak is clear (`offset_peak_clarity`), against the IMUs whose
    /// offsets are not accepted yet, while no track is long enough for the offset search (the
    /// first seconds of a session, or of a wearer back in an empty view), s; such a track is
    /// never an offset candidate, and it gives no lag hypothesis. 0 disables. Default 1.5 s. Before, nobody was named in a
    /// session's first 2.5 s. Over the ten imu-table scenes (seeds 1–9), 90.07 % of frames
    /// right without and 90.55 % with it (2 people, full network 97.05 → 97.96 %; 8 people,
    /// 91.90 → 94.12 % and, one wrist IMU, 76.81 → 75.92 %, both within the spread wrong early
    /// offsets give these scenes), the same from 0.6 to 1.8 s (the searches run once a second);
    /// taking unclear peaks too gave 90.40 % and one run whose median time to identify passed
    /// 2 s (a two-person scene named the wrong way round for 1.5 s). The Belmonte-Hernández
    /// episodes: 56.3 → 64.0 % (lost and found again), 96.7 → 97.1 % (the intruder anonymous
    /// in 98.7 → 98.8 % of his frames) and 90.6 → 91.0 % (two bands, one lost). Such tracks
    /// read up to the window's end, not where the search's buffer stops 0.6 s earlier: a track
    /// seen since the session's start is scored at the window ending at 1.5 s, not 2.5 s (ten
    /// scenes 92.42 → 93.33 %; the engine README has the details). The lag curve itself needs
    /// [`GeometricConfig::min_samples`] (30) of the track's samples at the search's 15 Hz, so at
    /// 30 Hz a track is in practice scored from about 2 s of frames; counting 1 s instead named
    /// the Belmonte-Hernández intruder from his first frames in five seeds of 73–144 (the engine
    /// README, "A session's first two seconds").
    pub offset_short_track_s: f64,
    /// How often a device without an accepted offset is searched again, s. Default 1 s.
    pub offset_search_interval_s: f64,
    /// While an IMU of a body-area network (a subject with several IMUs) has neither an
    /// accepted offset nor a lag peak on any track (a session's first seconds, or after its
    /// offset was withdrawn), and has samples in the search's buffer, the search runs at every
    /// window instead of every `offset_search_interval_s`: its pairs get no score until a
    /// search finds their peaks, so a network's first names wait for the first search that
    /// does. A registered network whose IMUs send nothing (its wearer absent) does not count.
    /// Default true: over the ten imu-table scenes (seeds 1–9) 90.84 → 91.04 % of frames
    /// right (2 / 3 / 4 / 5 / 8 people, full network: 97.96 / 95.89 / 94.98 / 88.53 / 94.85
    /// → 98.18 / 96.93 / 95.40 / 88.92 / 94.79 %; frames of the session's 1–2 s named right 39.1 → 49.4 %), on unseen seeds
    /// 10–15 5 people 84.89 → 86.33 % and 8 people 94.75 → 95.03 %. For every subject, one
    /// IMU each included, the one-wrist scenes lost 0.5–2.7 points (90.47 % over the ten):
    /// a single IMU's early peaks on short tracks are often a look-alike's, and the network's
    /// mean over its IMUs is what makes them usable.
    pub offset_search_while_blind: bool,
    /// Lag hypotheses kept per IMU whose offset is not yet accepted: its lag-curve peaks on its
    /// subject's best-scoring tracks of the latest search. A track too short for the search
    /// ([`EngineConfig::offset_min_track_s`]: new tracks after an occlusion or an id change,
    /// median 2.5 s on the simulated scenes) used to get no score from such an IMU, so its
    /// first seconds were named only by stitching or another camera; it is now scored at the
    /// hypothesis that fits it best in the window. 0 disables. Default 3: over the ten
    /// imu-table scenes (seeds 1–9), 86.04 % of frames right at 0 and 89.19 % at 3 (4 people,
    /// full network 85.17 → 93.72 %, one wrist IMU 81.16 → 88.07 %; 8 people, full network
    /// 90.97 → 91.58 %, one wrist IMU 75.61 → 76.39 %); at 1 / 2 / 4 / 8, measured before a
    /// withdrawn offset cleared its hypotheses, 87.12 / 89.24 / 89.05 / 88.88 %. Scoring the
    /// long tracks at these hypotheses too, instead of at each pair's own peak, gave 88.88 %
    /// (and 84.62 % with the hypotheses on the long tracks only).
    pub offset_hypotheses: usize,
    /// Lowest peak correlation (mean over the subject's IMUs of the lag-curve peaks) for an
    /// offset candidate. Default 0.3.
    pub offset_min_correlation: f64,
    /// How much the best track's peak must beat the next track's (same camera) for its lag to be
    /// a candidate, correlation units. Default 0.125. With the unnamed-rival rule of
    /// [`EngineConfig::unsynced_switch_margin`] in place, 0.1 / 0.125 / 0.15 / 0.2 kept the
    /// Belmonte-Hernández intruder anonymous in 99.17 / 99.74 / 99.64 / 99.58 % of his frames
    /// over seeds 1–72 (episode 97.09 / 97.36 / 96.72 / 94.43 % right) and 98.06 / 99.23 /
    /// 99.23 / 99.19 % over seeds 73–144 (96.43 / 97.26 / 97.12 / 95.19 %): a wearer's band
    /// accepted at the lag of a non-wearer who walks like her was what remained. The imu-table
    /// scenes barely move (120 runs at 0.125: +0.03 ± 0.06 points per run, four runs changed,
    /// all with 5 people; the 8-person scenes, the 180-s scenes and the UWB scene not at all). Before that rule, 0.15 and 0.2 had named the intruder more (98.51 and
    /// 97.21 % over seeds 1–72, against 98.67 % at 0.1).
    pub offset_margin: f64,
    /// How much a subject's winning track's mean peak must beat every other subject's mean peak
    /// on that track, correlation units (negative: not checked): two people walking alike must
    /// not both take one track's lags as their offsets (on the simulated scenes some share a
    /// motion clip at another phase). Checking it at all (0 against negative) was worth 1.9
    /// points over the ten imu-table scenes at seeds 1–6 with 2.5-s tracks. Default 0.05:
    /// with inferred joints weighed down ([`Self::inferred_joint_noise_factor`]) the early fits
    /// are sharper and a look-alike's track wins more often by a hair; against 0 (with the
    /// filter crate's joint filter, 3 m²/s³), +0.35 ± 0.42
    /// points per run over the 138 runs (12 better, 8 worse) and +0.49 ± 0.37 over the 45 (9
    /// better, 1 worse); 0.03 / 0.1 within 0.2 points of 0.05 (with a factor of 4).
    pub offset_subject_margin: f64,
    /// Number of successive candidates that must agree within `offset_consistency_s` before an
    /// offset is accepted. Default 3.
    pub offset_num_consistent: usize,
    /// How close successive candidates must be to count as consistent, s. Default 0.05 s.
    pub offset_consistency_s: f64,
    /// Independent confirmation for subjects that wear a single IMU, s (0: off, the default).
    /// When on, an offset the joint search agreed on is accepted only once an earlier winner of
    /// the last [`OFFSET_CONFIRM_HISTORY`] searches gave the same offset (within
    /// `offset_consistency_s`) on another track, or at least this long before; meanwhile the
    /// labelled-track path may not accept an offset more than a third of a stride from it. Several
    /// IMUs already confirm each other in the subject's mean peak, so they are not held back.
    ///
    /// The trade-off, measured over the ten imu-table scenes at seeds 1–9 (simulate → run →
    /// eval): at 3 / 4.5 / 6 s the mean accuracy goes from 80.5 % to 80.9 / 81.2 / 81.3 %
    /// (the 8-person one-wrist scene from 59.3 % to 60.8 / 62.7 / 63.2 %, with fewer wrong
    /// offsets: 16 of 72 wrong at the end without it, 8 at 6 s); but until the offset is
    /// accepted, tracks are scored at their own lag-curve peaks, which flatters a person without
    /// an IMU, and the Belmonte-Hernández intruder is anonymous in 92.5 / 90.9 / 90.7 % of his
    /// frames instead of 93.2 %. Hence off by default; worth turning on where everyone in view
    /// wears a sensor.
    pub offset_confirm_apart_s: f64,
    /// Local maxima of a lag curve within this of its highest value are near-ties; the one with
    /// the smallest |lag| wins. Default 0.02.
    pub offset_tie_tolerance: f64,
    /// How far an IMU's own lag-curve peak on the joint search's winning track must stand above
    /// every lag more than 0.15 s from it for that peak to be a candidate offset, correlation
    /// units; 0 takes any peak. Default 0.1. The winner is chosen on the mean over the
    /// subject's IMUs, so one IMU's peak on the right track may still sit a stride away or on a
    /// look-alike's rhythm; and successive searches share most of their buffer, so agreeing
    /// candidates do not check each other much. An unclear IMU is left to the next searches and
    /// the other paths. Over the ten imu-table scenes (seeds 1–9), the first offset the joint
    /// search accepted was wrong for 132 of 574 IMUs (body-area networks) and 56 of 122 (one
    /// wrist IMU) without the check, and for 58 of 450 and 31 of 97 at 0.1; mean accuracy was
    /// 80.5 % without it and 80.8 / 81.1 / 81.5 / 81.3 / 81.1 / 80.7 % at 0.03 / 0.06 / 0.1 /
    /// 0.15 / 0.2 / 0.3 (seeds 1–6: 79.0 → 80.4 % at 0.1; held-out seeds 7–9: 83.5 → 83.7 %; 8
    /// people with one wrist IMU: 59.1 → 64.5 %); the Belmonte-Hernández intruder stayed
    /// anonymous in 93.2 % of his frames.
    pub offset_peak_clarity: f64,
    /// How often an accepted offset is re-estimated against the tracks labelled with its wearer
    /// (their lag curves averaged, weighted by coverage), s. Default 5 s.
    pub offset_refine_interval_s: f64,
    /// Longest interval between refinements of an offset that stays put, s: each refinement
    /// that leaves the offset within 30 ms (three lag steps, the refinement's own scatter) of
    /// where it was (its peak there, or no peak clear enough to move it) doubles the IMU's
    /// interval from `offset_refine_interval_s` up to this; an offset that moves farther (or
    /// by another path) starts again, and a wearer with no track to refine against is no
    /// refinement. Default 20 s (clocks drift by well under a lag step in that time); set it
    /// to `offset_refine_interval_s` to refine at a fixed pace. Counting moves of up to one
    /// lag step (10 ms) as staying put, as before stop 62, a third of the refinements restarted
    /// the interval on their own noise: on the 8-person scene, 3 % more instructions with every
    /// offset known and with offsets searched, for the same accuracy over the 259-run sweep
    /// (+0.001 points per run with 30 ms, 11 runs better, 9 worse).
    /// The check of an accepted offset against its wearer's labelled tracks
    /// (`offset_label_curves`) keeps the same pace: at the base interval, on the 259-run sweep
    /// of the simulated scenes, every run named the same frames (all metrics equal) and a cold
    /// run of the 8-person full network took 8–11 % longer.
    pub offset_refine_max_interval_s: f64,
    /// Lag range around the current estimate searched when refining, s. Default 0.1 s.
    pub offset_refine_range_s: f64,
    /// Shortest coverage, s, of the offset-estimation buffer by a track labelled with an IMU's
    /// wearer for its lag curve to join that IMU's summed curve. Default 2 s.
    pub offset_label_min_track_s: f64,
    /// Curves the summed lag curve of an IMU against its wearer's labelled tracks needs before
    /// its peak may be accepted as the clock offset; 0 disables this path. Default 6: early
    /// labels are often wrong, and a sum of more curves is wrong less often (on the 8-person
    /// scenes, 31 % of offsets accepted from fewer than 6 curves were wrong, 17 % of those from
    /// more). Over the ten imu-table scenes, mean accuracy was 72.3 / 72.4 / 72.9 / 72.6 % at
    /// 4 / 5 / 6 / 8 curves on seeds 1–6, and 74.5 % (4) against 78.2 % (6) on seeds 7–9.
    pub offset_label_curves: usize,
    /// The curves the same sum needs while none of its wearer's IMUs has an accepted offset,
    /// for a wearer with several IMUs (the larger of this and `offset_label_curves` applies).
    /// Her labels then come from pairs scored at their own best lags, and two people walking
    /// the same clip a stride apart get each other's: on 5 people, full network, seed 3, all
    /// five of one subject's offsets were accepted at 10 s on her look-alike's tracks, and that
    /// run named 59.7 % of its frames right. The joint search averages over the network and
    /// usually finds its first offset instead. Default 12: over the ten imu-table scenes
    /// (seeds 1–9) 90.62 % of frames right at 6 (the same as `offset_label_curves`),
    /// 90.77 / 90.84 / 90.83 % at 9 / 12 / 18 (at 12: 5 people 87.08 → 88.53 %, its seed 3
    /// 59.7 → 77.0 %; 8 people 93.95 → 94.85 %; the one-wrist scenes unchanged); with no label
    /// path at all until then, 90.82 % (5 people 88.39 %, but its typical seeds 2 points down:
    /// the path names most networks' first offsets at 10–20 s). On unseen seeds 10–15, 5 people
    /// 84.56 → 84.89 % and 8 people 94.94 → 94.75 % (one lock-in fixed, another appeared).
    pub offset_label_curves_unsynced: usize,
    /// How far the summed curve's peak must stand above every lag more than 0.15 s from it.
    /// Default 0.05.
    pub offset_label_margin: f64,
    /// Lowest summed-curve peak accepted as an offset. Default 0.15: a mean over many short
    /// tracks, lower than one long track's peak (`offset_min_correlation`); on the simulated
    /// wrist scenes right peaks were 0.2–0.3 and stood 0.08–0.15 above the rest.
    pub offset_label_min_correlation: f64,
    /// Lowest mean of the summed-curve peaks (`offset_label_min_correlation`'s curves) over a
    /// body-area network's IMUs for the network's first offsets to be accepted from its
    /// labels, all together; 0 lets each IMU's own peak decide. Default 0.3, the joint
    /// search's `offset_min_correlation`. Those labels came from pairs scored at their own
    /// best lags, and a look-alike's tracks among them give some IMUs a clear peak at the
    /// look-alike's lag while the network as a whole fits poorly: on 5 people, full network,
    /// seed 3, four of Ana's five IMUs had summed peaks of 0.20–0.43 at 16.5 s, all 0.2–0.8 s
    /// off, and were accepted one by one, to be moved by the best-track sum at 24.5 s; held,
    /// her offsets were accepted by the joint search at 22.5 s, right. Against 0 (the other
    /// defaults as now, but the filter crate's joint filter, 3 m²/s³): +0.07 ± 0.08 points per
    /// run over the 138 runs of [`Self::inferred_joint_noise_factor`]; over its 45 runs +0.83
    /// ± 0.77 (2 better, none worse; full network, 5 people, seeds 10–18: 85.81 → 89.97 %).
    pub offset_label_network_min_peak: f64,
    /// An accepted offset is withdrawn (and searched for again) when the summed lag curve of
    /// its IMU against the wearer's labelled tracks is below this at the offset and at least
    /// `offset_label_margin` higher at another lag. Default 0.05: on the simulated 8-person
    /// scenes right offsets read a median of 0.17 there (5 % of checks below 0.06), wrong ones
    /// 0.07 (a quarter below 0.02). Ignored with `known_clock_offsets`. −1 disables.
    pub offset_withdraw_below: f64,
    /// Passes of the best-track lag curve an IMU needs before its peak may accept or move the
    /// IMU's offset; 0 disables this path. Every `offset_best_track_interval_s`, each IMU's
    /// coarse lag curve is taken against every candidate track and the best value at each lag
    /// is summed. Tracks named after another subject one of whose IMUs has an accepted offset
    /// are left out: that IMU explains them, and a look-alike's track would otherwise give a
    /// second peak in every pass (one wrist IMU, 8 people: 85.46 → 87.58 % at seeds 1–9, 84.00
    /// → 85.59 % at 16–33, 77.59 → 78.90 % at 10–15; 5 people 81.37 → 80.76 %, 72.89 → 74.68 %
    /// at 16–33). Unlike the labelled-track curves, the IMU's own labels do not enter that sum,
    /// so a wrong early label cannot confirm the offset it came from (a wrong label naming
    /// someone else on the wearer's track hides that track, though). They only veto a move: an
    /// accepted offset stays while the wearer's named tracks of the pass fit it at least as
    /// well as the new peak. In the Belmonte-Hernández episode at seed 105, the man without a
    /// band walks her clip half a second out of phase; his track moved her band's offset from
    /// the right lag to his for 9 s, and took her name meanwhile (his frames anonymous 77.2 →
    /// 97.4 % with the veto); no other run of the engine README's sets changed. The path is
    /// slow (on twelve 4- to 8-person scenes its peak was right for 58 % of IMUs after 20 s,
    /// 85 % after 60 s), so it only decides late, and only on clear peaks. Default 7 (at 3 s).
    /// Over the ten imu-table scenes, mean accuracy on seeds 1–6 was 74.9 % without this path
    /// and 77.3 % with the defaults; on held-out seeds 7–9, 77.8 % and 80.1 %. The defaults
    /// were chosen on seeds 1–6 with a variant that cut the IMU's buffer at its current offset
    /// (77.0 / 77.5 / 76.8 % at 6 / 7 / 8 passes).
    pub offset_best_track_curves: usize,
    /// How often the best-track lag curve gains a pass, s. Default 3 s: every pass correlates
    /// every IMU with every candidate track over the whole offset buffer, and at 1 s (20
    /// passes) the engine took twice as long for the same accuracy (seeds 1–6: 77.2 % at 1 s
    /// and at 3 s with margin 0.06; 76.3 % at 4 s with 5 passes).
    pub offset_best_track_interval_s: f64,
    /// How far the best-track curve's peak must stand above every lag more than 0.15 s from it
    /// to accept or move an offset. Default 0.05 (seeds 1–6: 77.3 / 77.5 / 77.2 % at 0.04 /
    /// 0.05 / 0.06 with 7 passes at 3 s; on the twelve scenes above, the first peak this clear
    /// after 30 one-second passes was right for 141 IMUs and wrong for 11 at 0.06, 119 and 2 at
    /// 0.08).
    pub offset_best_track_margin: f64,
    /// Passes in a row whose best-track peak is clear (`offset_best_track_margin`) and within
    /// 0.15 s of an accepted offset that settle it: the best-track pass then skips the IMU while
    /// its offset stays there (the labelled-track check and the refinement still watch it), so
    /// a long session stops correlating every settled IMU with every track; 0 never settles.
    /// Default 6 (18 s at 3 s): mean accuracy over the ten imu-table scenes (seeds 1–9)
    /// unchanged at 80.52 %, 80.50 % at 4; on a 180-s 8-person full network 31 of 40 offsets
    /// settle, the whole `nomen run` takes 6–8 % less time and its last minute's engine time
    /// about a quarter less (`cargo bench -p nomen-engine`), with the same accuracy.
    pub offset_settle_passes: usize,
    /// How far a track's clear lag peak must beat both another subject's explanation of that
    /// track and the IMU's support at its own offset to vote for moving the accepted offset of
    /// a single-IMU subject there; 0 disables (see the crate docs, step 1). It runs at the
    /// best-track pass's pace, so not at all when `offset_best_track_curves` is 0. It undoes a
    /// lock-in the other paths keep: on the one-wrist scenes two people walk the same clip with
    /// the same wrist, a fraction of a stride apart, and an IMU whose offset was accepted on its
    /// look-alike's track names that track while its wearer's own track, which correlates
    /// clearly at the true offset, goes unnamed or to someone else; the labelled-track checks
    /// then read the wrong tracks, and the best-track sum still holds the passes that agreed
    /// with the wrong offset. Default 0.1, with peaks of at least
    /// `offset_unexplained_min_peak`, 4 votes among 6 passes (18 s at 3 s), and only while the
    /// refinement finds no peak of `offset_min_correlation`. Over the 138 runs of the engine
    /// README, +0.31 ± 0.12 points per run, 9 runs better and none worse (one wrist IMU,
    /// 5 people, seeds 16 / 24 / 27: 58.4 / 57.9 / 57.5 → 66.1 / 66.3 / 67.1 %; 8 people,
    /// seeds 3 / 32: 64.3 / 63.0 → 70.0 / 68.3 %); the full network's runs are untouched (its
    /// subjects have several IMUs); 180-s one-wrist scenes, seeds 1–3, 83.58 → 90.06 % (seed 3:
    /// 63.8 → 83.2 %), seeds 4–9 unchanged. Looser variants (with peaks of 0.3) gained more on
    /// average and lost runs: 3 votes among 5 passes +0.38 ± 0.16 (3 runs worse, up to 2.0
    /// points, and the 180-s seeds 4–9 −0.56); the same without the refinement's condition
    /// +0.34 ± 0.16 (7 worse); 2 votes in a row +0.23 ± 0.18 (9 worse, up to 6.9). Each pass
    /// correlates every unrefined single IMU with every candidate track over the coarse lag
    /// grid: `nomen run` of the 8-person one-wrist scene takes about a fifth more time (0.50 →
    /// 0.59 s user, seed 2, five runs each).
    pub offset_unexplained_margin: f64,
    /// Lowest peak that votes (see `offset_unexplained_margin`). Default 0.25: a wearer's own
    /// track in a crowd often peaks at 0.2–0.35 over the 12-s buffer; at 0.3 the 138 runs
    /// gained +0.19 ± 0.10 (6 better), at 0.2 +0.32 ± 0.13, the same runs as at 0.25.
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
    /// (tracking noise and the SDK's own smoothing), m. Default 0.25 m. With reach measured
    /// from the last position it was 0.5 m; from the heading point, over the 20 runs of
    /// `stitch_velocity_span_s`, 0.5 / 0.35 / 0.25 / 0.15 m stitched 449 / 467 / 485 / 491
    /// new tracks right and 91 / 94 / 91 / 90 wrong, and 0.25 m gained +0.05 ± 0.01 points
    /// per run over the 138 runs of the engine README (42 better, 5 worse by at most 0.04).
    pub stitch_radius_m: f64,
    /// Walking reach is measured from where an ended track's person was heading: its last
    /// position moved on over the gap at the horizontal velocity of its joint centroid over
    /// this last span of it (capped at `stitch_max_speed_mps`), s. Default 0.5 s; 0 measures
    /// from the last position. Over 20 simulated runs (the imu-table layouts, the 180-s
    /// 8-person scene, the three training scenes and the hospital, handshake and
    /// UWB-among-untagged scenes; the engine README lists them), stitches by walking reach
    /// went from 429 right and 138 wrong to 449 and 91 (0.25 s: 457 and 96; 1 s: 446 and 96):
    /// a walker's new track had often started nearer someone standing where the walker was
    /// heading than the walker's own old track. Over the 138 runs of the engine README,
    /// +0.28 ± 0.22 points per run (0.25 s: +0.09, 1 s: −0.32).
    pub stitch_velocity_span_s: f64,
    /// Weight a stitched track's inherited motion evidence keeps, relative to what it had on the
    /// ended track (0..=1): a stitch to the wrong one of two people who were close is then
    /// outvoted by the new track's own windows sooner. Default 0.5. Over the ten imu-table
    /// scenes, seeds 1–9 (with a 1 s evidence half-life): 79.7 % at 1 (the full weight),
    /// 79.9 % at 0.5, 79.8 % at 0.25 (5 people, full network: 76.8, 78.6, 78.8 %; 8 people,
    /// one wrist IMU: 55.8, 55.0, 56.3 %).
    /// Location-tag and RSSI evidence are inherited whole (their half-lives are short).
    pub stitch_evidence_weight: f64,
    /// Stitch through another camera: when a track of another camera follows a new track's
    /// person (torso positions within `stitch_view_distance_m` on average, every other track
    /// at least twice as far), the new track continues the ended track of its camera that this
    /// view followed when it ended, or none if it followed none of them; walking reach
    /// (`stitch_max_speed_mps`, `stitch_radius_m`) decides only for people no other camera
    /// sees. Default `true`. On the simulated 8-person scenes (two cameras facing each other,
    /// people hiding each other from one of them), walking reach alone stitched 401 new tracks
    /// to the right predecessor and 299 to a wrong one; with the other camera's view, 595 and
    /// 124. Over the ten imu-table scenes (seeds 1–9), 90.05 % of frames right without the view
    /// and 90.07 % with it (8 people, full network 91.37 → 91.90 %, one wrist IMU 77.08 →
    /// 76.81 %, within the spread that wrong early clock offsets give these scenes); with the
    /// true clock offsets, 96.53 → 97.11 % and 90.02 → 91.22 %.
    pub stitch_across_cameras: bool,
    /// How close on average another camera's view of a new track's person must stay to it for
    /// [`EngineConfig::stitch_across_cameras`] (the view that follows the new track, and the
    /// ended track that view followed), m. Default 0.3 m. It is wider than
    /// [`EngineConfig::camera_pair_distance_m`] because it is read at a new track's first
    /// frames, where the joint filter has only just started. On the simulated 8-person scenes
    /// (offsets searched; the full network seeds 1–15, one wrist IMU seeds 1–33), with pooling
    /// at 0.2 m, stitching at 0.3 m gave 98.36 % and 97.66 % of frames right, at 0.2 m 98.35 %
    /// and 97.55 %. 0 disables stitching through another camera.
    pub stitch_view_distance_m: f64,
    /// Tracks of different cameras whose torso positions (the pelvis, else the first of chest,
    /// neck, head and hips that both views have at that time) stayed this close on average over the
    /// last two evidence windows show the same person: each decides on the evidence of all of them
    /// (weighted by how much each has), so a fresh track seen by another camera for a while is
    /// named at once, and a wrong stitch is outvoted, m. Both tracks must be each other's
    /// nearest, the next candidate at least twice as far. Default 0.2 m. With the joint
    /// smoother, the same person's two views are 2.2 cm apart on average over the two windows
    /// (median; 3.7 cm at p95) on the simulated 8-person full-network scene, seeds 1–3 with the
    /// true clock offsets; the rare wider ones (1 % beyond 0.2 m) are windows with an SDK id
    /// swap or an inferred torso. Two people walking side by side 0.25 m apart, each hidden
    /// from one camera by the other, passed 0.3 m: their evidence was pooled and one took the
    /// other's name (Gia's front-camera track named Cleo for the first 2.5 s of every seed).
    /// With the true clock offsets, 0.3 → 0.2 m took the 8-person scenes, seeds 1–9, from
    /// 98.67 to 98.99 % (full network) and 97.95 to 98.18 % (one wrist IMU), all 18 runs
    /// better; with offsets searched, from 98.14 to 98.36 % (full network, seeds 1–15) and
    /// 97.68 to 97.66 % (one wrist IMU, seeds 1–33); 0.15 and 0.25 m were within 0.05 points
    /// of 0.2 m. An earlier sweep, before the joint smoother and with a 1 s evidence
    /// half-life, had given 88.7 / 88.5 / 88.4 % at 0.2 / 0.3 / 0.45 m (full network) and
    /// 54.2 / 55.8 / 55.2 % (one wrist IMU). 0 disables.
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
    /// among wearers only but once in four where people wear nothing.
    pub min_name_probability: f64,
    /// Two tracks of a camera closer than this across the line of sight are in a close
    /// encounter, after which their ids may have been swapped by the SDK (their evidence is
    /// pooled when they separate), m. Default 0: disabled. Swaps that move a track's
    /// observation onto where another track just was are undone directly (see the crate
    /// docs), and pooling at every encounter discards evidence most encounters did not
    /// disturb: with the true clock offsets given, mean accuracy over the ten imu-table scenes
    /// at seeds 1–6 was 86.6 % with pooling at 0.5 m and 88.7 % without (8 people, one wrist
    /// IMU: 59.4 and 68.0 %); with estimated offsets, 73.0 % both ways over seeds 1–9.
    pub encounter_distance_m: f64,
    /// Horizontal standard deviation of a location-tag fix when the system reports no
    /// covariance, m. Default 0.3 m (the simulator's UWB core error is 0.15 m per axis plus NLOS
    /// excess and outliers, fitted to the LIAS recordings; Bazo reports 0.39 m RMSE raw).
    pub tag_sigma_horizontal_m: f64,
    /// Vertical standard deviation of a fix without covariance, m. Default 0.5 m (UWB anchors
    /// mounted near one height resolve height poorly).
    pub tag_sigma_vertical_m: f64,
    /// Half-life of the accumulated location-tag evidence, s. Default 1 s: a position fix is
    /// decisive on its own, so old evidence should not hold a label after an id swap.
    pub tag_evidence_half_life_s: f64,
    /// Length of the window of fixes a location tag is scored over (the last part of the
    /// evidence window), s. Default 2 s (twenty fixes at 10 Hz): positions need no long window,
    /// and a short one follows id swaps quickly.
    pub tag_window_s: f64,
    /// Half-life of the accumulated RSSI evidence, s. Default 4 s: a single RSSI estimate
    /// hardly separates two people a metre apart; a few seconds of walking do.
    pub rssi_evidence_half_life_s: f64,
    /// Half-life of an IMU's heading estimate, s. An AHRS without a magnetometer knows up but
    /// not north, so its frame is the room's turned about the vertical by an unknown angle that
    /// drifts with the gyroscope's bias. Each window, for IMUs whose clock offset is known, the
    /// cross sum `Σ a·conj(s)` of the horizontal accelerations (as complex numbers) of the IMU
    /// and of its joint on each track labelled with its wearer is normalised and added to a
    /// decayed sum; that sum's phase is the angle (reported in `EngineStats::imu_headings`),
    /// and the heading model (`ModelWeights::heading`) correlates every pair in the room frame
    /// with it. Default 20 s: the simulator's gyroscope turn-on bias (up to 0.48 °/s) turns the
    /// frame by at most 10° in that time. Over the ten imu-table scenes, seeds 1–9, mean
    /// accuracy was 81.7 / 82.0 / 82.1 % at 5 / 20 / 30 s (weight 3, coherence 0.5).
    pub heading_half_life_s: f64,
    /// Coherence the heading sum needs before the heading model scores with it: the length of
    /// the decayed sum of normalised cross sums over the decayed sum of their lengths, in
    /// [0, 1] (1: every window gave the same angle). Default 0.5; at 0.3 / 0.7 mean accuracy over
    /// the ten imu-table scenes was 81.5 / 81.7 % (half-life 10 s, against 81.9 % at 0.5).
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
            stitch_across_cameras: true,
            stitch_view_distance_m: 0.3,
            camera_pair_distance_m: 0.2,
            camera_exclusion_distance_m: 1.0,
            camera_exclusion_margin: 0.0,
            names_against_own_evidence: false,
            min_name_probability: 0.0,
            encounter_distance_m: 0.0,
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
        ] {
            if !(v.is_finite() && (-1.0..=1.0).contains(&v)) {
                return Err(EngineError::InvalidConfig(format!(
                    "{name} must be in -1..=1, got {v}"
                )));
            }
        }
        for (name, v) in [
            ("stitch_evidence_weight", self.stitch_evidence_weight),
            ("heading_min_coherence", self.heading_min_coherence),
            ("min_name_probability", self.min_name_probability),
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
