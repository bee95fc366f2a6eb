//! People from real motion capture: a [`PersonMotion`] plays one [`MocapClip`](nomen_mocap::MocapClip) smoothly, looped,
//! time-warped, mirrored, scaled and placed in the scene, as a [`BodyMotion`](crate::body::BodyMotion).
//!
//! # Model
//!
//! **Low-pass.** The clip is first filtered as biomechanics filters marker data before
//! differentiating it (Winter, *Biomechanics and Motor Control of Human Movement*, 4th ed.,
//! §2.2.4): a second-order Butterworth run forward and backward (fourth order, zero phase), −3 dB
//! at `lowpass_hz` (default 6 Hz), ends padded by odd reflection. It acts on the root translation
//! and on each joint's local rotation (its sign-continuous quaternion components, renormalised),
//! over all usable frames of the clip. Raw 120 Hz marker jitter would otherwise reach the
//! simulated IMUs twice differentiated (0.5 mm of jitter ≈ 7 m/s²).
//!
//! **Smooth time.** Every BVH joint's *local* rotation (its rotation channels, composed in the
//! order written) is a control point of a cumulative cubic B-spline on SO(3) (Kim, Kim & Shin,
//! SIGGRAPH 1995), and the root translation a control point of a uniform cubic B-spline, one
//! control point per (filtered) mocap frame. Both are C² in time. Forward kinematics then runs at
//! the query time with the file's own bone offsets, so bone lengths are exactly constant. The
//! conventions are nomen-mocap's ([`nomen_mocap::fk`]): lengths times the clip's scale, then Y up
//! turned to Z up once, `world_from_joint = C · R_joint`. Before the first frame the controls are
//! extrapolated linearly (so the motion starts with the clip's own velocity, not a jolt).
//! B-splines *approximate*: at a frame instant the pose is the weighted mean
//! `(f[i-1] + 4 f[i] + f[i+1]) / 6` of three frames, a millimetre or so from the filtered pose.
//!
//! **Clip time.** At scene time `t` the clip plays at `τ = phase_s + time_warp · (t − start_s)`
//! seconds into the selected part of the clip. The selected part is `clip_range_s` (after the
//! frames the clip library skips) when given. Otherwise a repeating clip chooses its own **loop
//! points**: the frame `i` near the start and `j` near the end (each searched within
//! [`LOOP_SEARCH_S`] or a third of the clip of its end, `j − i` at least half the clip) with the
//! most similar pose and velocity (every joint relative to the pelvis, pelvis height, all their
//! velocities and the pelvis velocity), and the selected part is `i ..= j + blend_s`; for a walk
//! this puts the same gait phase on both sides of the seam
//! ([`PersonMotion::clip_range_s`] tells which part was chosen). A clip without `repeat` uses
//! all of it. With `repeat`, the clip loops with period `L − blend_s` (L the selected length,
//! i.e. `j − i`): the first pass plays the frames as recorded; at every seam the last `blend_s`
//! of the selected part is cross-faded (smoothstep weights; slerp for rotations, lerp for the
//! root) into its first `blend_s`, and the root's horizontal travel over one period is
//! accumulated, so a 3 s walk fills a minute walking forward without a jump. Without `repeat`
//! the pose holds the last frame.
//!
//! **Travelling or in place.** A clip *travels* when its pelvis moves at least
//! [`TRAVEL_THRESHOLD_M`] horizontally over one period (the clip library may say so instead).
//! A travelling clip is described in a moving frame: progress `s` along its mean direction of
//! travel (the straight line from its first to its last pelvis position) and everything else (the
//! pelvis' sway and bob, the body's yaw relative to that direction, the limbs) relative to the
//! point `s` on that line. An in-place clip has `s = 0`, its mean pelvis position as origin and
//! its mean facing direction (perpendicular to the hip line) as "forward".
//!
//! **Placement** (exactly one of):
//! - `path`: the moving frame's origin is put at arc length `s − s(start)` along the path and
//!   turned to the path's tangent. Progress therefore comes from the clip's own stepping (no
//!   speed is imposed; feet do not skate beyond what the turn of the tangent adds), the sway is
//!   kept. The pelvis follows circular arcs of radius `corner_radius_m` at the corners; the body's
//!   heading is the path tangent averaged over [`HEADING_WINDOW_M`] of path, so its turning rate
//!   is continuous (no velocity jump at a wrist when a turn begins). **When the path ends the person leaves the scene**: the span ends at the instant
//!   the progress reaches the path's length (or at `end_s` if that comes first). An in-place clip
//!   on a path stays at its start, facing along it.
//! - `position` + `heading_rad`: the moving frame's origin at the start is put at `position`,
//!   its forward direction along `heading_rad`. A travelling clip walks off in that direction.
//! - `clip_frame`: the clip's own world coordinates (after nomen-mocap's conversion, including
//!   the clip's own `ground_offset_m`) under the given rigid transform; nothing is re-centred or
//!   re-grounded. Use one transform for clips recorded together (18_01 + 19_01, salsa pairs) to
//!   keep their relative placement and timing (give them the same `start_s`, `phase_s`,
//!   `time_warp`, and no `height_m`, which scales about the clip frame's origin).
//!
//! **Ground.** For `path` and `position`, the body is lifted so that the lowest ankle or ball of
//! the foot over the whole (scaled, mirrored) clip touches z = 0.
//!
//! **Mirror.** The motion is reflected across a vertical plane (`x → −x` in the BVH's Y-up axes)
//! and left and right swap: a joint's local rotation becomes `M · R · M` (a proper rotation; for
//! the quaternion, `(w, x, y, z) → (w, x, −y, −z)`) of its partner on the other side (found by
//! name: `Left`/`Right`, `L`/`R`, `l`/`r` prefixes, `.l`/`.r` suffixes), the root translation is
//! reflected, and every joint keeps its own bone offset, so bone lengths are unchanged. A
//! right-hand wave becomes a left-hand wave.
//!
//! **Absence.** `absent_s` lists spans of session time during which the person is out of the
//! room ([`BodyMotion::is_present_at`](crate::body::BodyMotion::is_present_at) is false): the
//! clip keeps playing, cameras do not see the person and the body blocks nothing.
//!
//! # `MotionSpec` fields (scenario TOML)
//!
//! ```toml
//! [people.motion]
//! clip = "walk_02_01"          # required: a clip library name
//! clip_range_s = [0.5, 2.8]    # optional, default: automatic loop points (repeat) or all
//! lowpass_hz = 6.0             # default 6 (Winter); 0 = off
//! start_s = 0.0                # default 0
//! end_s = 60.0                 # optional
//! phase_s = 0.4                # default 0
//! time_warp = 1.05             # default 1, allowed 0.85..=1.15
//! mirror = false               # default false
//! height_m = 1.80              # optional, default the clip's own size
//! repeat = true                # default true
//! blend_s = 0.3                # default 0.3
//! path = [[1.0, 1.0], [6.0, 1.0], [6.0, 4.0]]
//! corner_radius_m = 0.6        # default 0.6
//! # or: position = [2.0, 3.0] and heading_rad = 1.57
//! # or: clip_frame = { offset_m = [0.0, 0.0], yaw_rad = 0.0 }
//! absent_s = [[20.0, 30.0]]    # default none: out of the room from 20 s to 30 s
//! wearables_when_absent = "stream"  # default; or "silent"
//! ```
//!
//! See the field docs of [`MotionSpec`] for each one.

pub mod avoid;
mod lowpass;
mod path;
mod person;

pub use avoid::{AvoidanceConfig, AvoidingMotion, PLAN_STEP_S, Shift, plan_avoidance};
pub use path::{HEADING_WINDOW_M, Path, PathPoint};
pub use person::{ClipUse, LOOP_SEARCH_S, PersonMotion, TRAVEL_THRESHOLD_M};

use serde::{Deserialize, Serialize};

/// How one person moves: which clip, when, how fast, how big and where. Embedded as-is in the
/// scenario TOML (see the [module docs](self) for the model).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MotionSpec {
    /// Name of the clip to play, from the scenario's clip library (e.g. `"walk_02_01"`).
    pub clip: String,
    /// Part of the clip to use, `[from, to]` seconds of clip time (after the library's skipped
    /// frames), e.g. the steady walking of a start–walk–stop clip; with `repeat` the loop wraps
    /// exactly this range. Default: for a repeating clip, loop points chosen automatically by
    /// pose and velocity similarity (see the [module docs](self)); otherwise the whole clip.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub clip_range_s: Option<[f64; 2]>,
    /// Scene time at which the person appears, seconds. Default 0.
    #[serde(default)]
    pub start_s: f64,
    /// Scene time at which the person leaves, seconds. Default: never (until the scene ends) for
    /// a repeating clip; the end of the clip without `repeat`; the end of the `path` with one
    /// (whichever comes first).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub end_s: Option<f64>,
    /// Offset into the clip at `start_s`, seconds of clip time (≥ 0). Several people on one clip
    /// with different phases move differently at the same instant. Default 0.
    #[serde(default)]
    pub phase_s: f64,
    /// Playback-rate factor: 1.1 plays 10 % faster (steps 10 % more often, walks 10 % faster).
    /// Allowed 0.85..=1.15 (beyond that the motion stops looking human). Default 1.
    #[serde(default = "one")]
    pub time_warp: f64,
    /// Play the left–right mirror image (a right-hand wave becomes a left-hand wave). Default
    /// false.
    #[serde(default)]
    pub mirror: bool,
    /// Scale the body (and its stride) uniformly so that the clip's rest-pose stature
    /// ([`nomen_mocap::rest_stature_m`]: floor to the top-of-head end site of the T-pose) is this
    /// many metres. Default: the clip's own size.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub height_m: Option<f64>,
    /// Loop the clip (with a cross-fade of `blend_s` at the seam). Default true. Without it the
    /// last frame is held.
    #[serde(default = "yes")]
    pub repeat: bool,
    /// Length of the cross-fade at the loop seam, seconds of clip time (0 allowed for clips that
    /// already loop; at most half the selected clip). Default 0.3.
    #[serde(default = "default_blend_s")]
    pub blend_s: f64,
    /// Waypoints `[[x, y], ...]` in the world, metres (floor z = 0), that the person walks along,
    /// starting at the first. At least two, consecutive ones distinct.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub path: Option<Vec<[f64; 2]>>,
    /// Radius of the arcs that round the corners of `path`, metres (shrunk where segments are
    /// short). Default 0.6 (a comfortable walking turn).
    #[serde(default = "default_corner_radius_m")]
    pub corner_radius_m: f64,
    /// Fixed placement `[x, y]`, metres: where the pelvis is (projected on the floor) at
    /// `start_s`. For in-place clips (wave, hop); a travelling clip walks off from here.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub position: Option<[f64; 2]>,
    /// With `position`: the direction the person faces (in-place clips) or walks (travelling
    /// clips), radians counter-clockwise from +x. Default 0.
    #[serde(default)]
    pub heading_rad: f64,
    /// Keep the clip's own world coordinates under this rigid transform (for clips recorded
    /// together).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub clip_frame: Option<ClipFrame>,
    /// Cut-off of the zero-phase low-pass applied to the clip's root translation and joint
    /// rotations before the splines are built, Hz (the −3 dB point of a second-order Butterworth
    /// run forward and backward). Default 6 Hz: Winter, *Biomechanics and Motor Control of Human
    /// Movement* (4th ed., 2009), §2.2.4.4–2.2.4.5, filters walking marker data at 6 Hz; raw
    /// 120 Hz marker jitter of 0.5 mm otherwise turns into ~7 m/s² of simulated acceleration.
    /// Raise it (10–12 Hz) for fast motions such as hops; 0 turns the filter off; at most 0.3 ×
    /// the clip's frame rate.
    #[serde(default = "default_lowpass_hz")]
    pub lowpass_hz: f64,
    /// Spans `[[from, to], ...]` of session seconds during which the person is out of the room:
    /// no camera sees them and their body hides nothing from cameras or radios; when they come
    /// back, cameras report them under a new track id. Each span is half-open (`from ≤ t < to`),
    /// inside the scene (`0 ≤ from < to ≤ duration_s`), and the spans are in increasing order
    /// without overlap. The motion keeps playing while the person is away. Default none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub absent_s: Vec<[f64; 2]>,
    /// What the person's devices send while they are away (see [`WhenAbsent`]). Default
    /// `stream`.
    #[serde(default, skip_serializing_if = "WhenAbsent::is_stream")]
    pub wearables_when_absent: WhenAbsent,
}

/// What a person's devices send during the spans of [`MotionSpec::absent_s`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum WhenAbsent {
    /// The person keeps moving elsewhere with their devices on: IMUs keep sending (the hard case
    /// for identification: inertial data with no skeleton to match); location tags and RSSI tags
    /// are out of the anchors' and antennas' coverage and give no fixes, ranges or reads.
    #[default]
    Stream,
    /// Every device of the person is silent while they are away (taken off, switched off).
    Silent,
}

impl WhenAbsent {
    fn is_stream(&self) -> bool {
        *self == Self::Stream
    }
}

/// A rigid horizontal transform from a clip's own world frame into the scene:
/// `p_scene = R_z(yaw_rad) · p_clip + offset_m`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClipFrame {
    /// Horizontal translation `[x, y]`, metres. Default `[0, 0]`.
    #[serde(default)]
    pub offset_m: [f64; 2],
    /// Rotation about the vertical, radians. Default 0.
    #[serde(default)]
    pub yaw_rad: f64,
}

fn one() -> f64 {
    1.0
}

fn yes() -> bool {
    true
}

fn default_blend_s() -> f64 {
    0.3
}

fn default_corner_radius_m() -> f64 {
    0.6
}

fn default_lowpass_hz() -> f64 {
    6.0
}

/// Whether `t_s` is in one of the half-open spans `[from, to)`.
pub(crate) fn is_in_spans(spans: &[[f64; 2]], t_s: f64) -> bool {
    spans.iter().any(|&[from, to]| t_s >= from && t_s < to)
}

/// Checks [`MotionSpec::absent_s`]: finite, `0 ≤ from < to ≤ duration_s`, increasing, no
/// overlap. The message names the span (`absent_s[i]`).
pub(crate) fn check_absent_spans(
    spans: &[[f64; 2]],
    duration_s: f64,
) -> std::result::Result<(), String> {
    let mut previous_end = 0.0;
    for (i, &[from, to]) in spans.iter().enumerate() {
        if !(from.is_finite() && to.is_finite() && from >= 0.0 && to > from && to <= duration_s) {
            return Err(format!(
                "absent_s[{i}] must be [from, to] with 0 <= from < to <= {duration_s} (inside \
                 the scene), got [{from}, {to}]"
            ));
        }
        if i > 0 && from < previous_end {
            return Err(format!(
                "absent_s[{i}] = [{from}, {to}] overlaps or precedes absent_s[{}] (spans must \
                 be in increasing order without overlap)",
                i - 1
            ));
        }
        previous_end = to;
    }
    Ok(())
}

/// Allowed range of [`MotionSpec::time_warp`].
pub const TIME_WARP_RANGE: (f64, f64) = (0.85, 1.15);

impl MotionSpec {
    /// A spec playing `clip` from t = 0, repeating, placed at the origin facing +x, with every
    /// other field at its default.
    pub fn new(clip: impl Into<String>) -> Self {
        Self {
            clip: clip.into(),
            clip_range_s: None,
            start_s: 0.0,
            end_s: None,
            phase_s: 0.0,
            time_warp: 1.0,
            mirror: false,
            height_m: None,
            repeat: true,
            blend_s: default_blend_s(),
            path: None,
            corner_radius_m: default_corner_radius_m(),
            position: None,
            heading_rad: 0.0,
            clip_frame: None,
            lowpass_hz: default_lowpass_hz(),
            absent_s: Vec::new(),
            wearables_when_absent: WhenAbsent::Stream,
        }
    }

    /// Whether `t_s` falls in one of the [`MotionSpec::absent_s`] spans.
    pub fn is_absent_at(&self, t_s: f64) -> bool {
        is_in_spans(&self.absent_s, t_s)
    }

    /// Names of the clips this motion needs from the library.
    pub fn clip_names(&self) -> impl Iterator<Item = &str> {
        std::iter::once(self.clip.as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use serde::de::value::{Error, MapDeserializer};

    fn from_pairs(pairs: Vec<(&'static str, &'static str)>) -> Result<MotionSpec, Error> {
        MotionSpec::deserialize(MapDeserializer::<_, Error>::new(pairs.into_iter()))
    }

    #[test]
    fn defaults_fill_a_minimal_spec() {
        let spec = from_pairs(vec![("clip", "walk_02_01")]).unwrap();
        assert_eq!(spec, MotionSpec::new("walk_02_01"));
    }

    #[test]
    fn unknown_fields_are_rejected() {
        assert!(from_pairs(vec![("clip", "a"), ("speed", "2")]).is_err());
    }
}
