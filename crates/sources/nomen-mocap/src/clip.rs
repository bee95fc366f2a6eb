//! Conversion of a parsed BVH file into a [`MocapClip`] on nomen's canonical skeleton.

use crate::bvh::Bvh;
use crate::error::{MocapError, Result};
use crate::fk::{JointPose, forward_kinematics};
use crate::mapping::{JointMapping, SkeletonVariant, map_joints};
use nomen_core::skeleton::Joints;
use nomen_core::{CameraId, Joint, JointObservation, SessionTime, SkeletonObservation, TrackId};
use std::fmt;

/// Plausible vertical extent of a skeleton's rest pose (all channels zero), metres. A T-posed
/// BVH skeleton is shorter than its owner: CMU rest poses splay the legs and the head's End Site
/// is not the top of the skull (1.35–1.50 m for the CMU files at their true scale, 1.64–1.67 m
/// for the MakeHuman and Poser ones). Wide on purpose: the check catches unit mistakes (×100,
/// ×0.01, ×0.056, ×1.4), not body size.
pub const PLAUSIBLE_STATURE_M: (f64, f64) = (1.3, 2.2);
/// Plausible median pelvis (root) height above z = 0 over a clip, metres (0.83–1.04 m in the
/// CMU files at their true scale).
pub const PLAUSIBLE_PELVIS_HEIGHT_M: (f64, f64) = (0.7, 1.3);
/// Typical rest-pose extent used to suggest a scale, metres (middle of the range seen above).
const TYPICAL_STATURE_M: f64 = 1.5;
/// Typical median pelvis height used to suggest a scale, metres.
const TYPICAL_PELVIS_HEIGHT_M: f64 = 0.95;
/// A header rate this close (relative) to a whole number of Hz is that whole number: BVH writers
/// print `Frame Time` with 4–6 digits (`.0083333` for 120 Hz).
const RATE_SNAP_RELATIVE: f64 = 1e-3;

/// Whether to move the clip vertically so that it stands on z = 0.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Grounding {
    /// Keep the file's vertical origin (after scale and axis change). The default.
    #[default]
    Keep,
    /// Shift every position down by the lowest ankle or foot height over the whole clip (over
    /// both clips for [`convert_pair`]), so that the lowest foot point touches z = 0.
    LowestFootToZero,
}

/// How to convert a BVH file. Everything defaults to "trust the file".
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ConvertOptions {
    /// Multiplier from file length units to metres. `None`: 1.0 (file in metres). BVH files
    /// carry no unit; check the warnings of the result.
    pub scale: Option<f64>,
    /// True frame rate, Hz, overriding the header's `Frame Time`. `None`: the header's rate.
    pub fps_hz: Option<f64>,
    /// Naming variant to use. `None`: detect from the joint names.
    pub variant: Option<SkeletonVariant>,
    /// Vertical re-grounding (off by default; nothing is ever re-centred horizontally).
    pub grounding: Grounding,
}

/// Something about the converted clip that looks wrong but does not stop conversion.
#[derive(Debug, Clone, PartialEq)]
pub enum MocapWarning {
    /// The rest-pose standing height is outside [`PLAUSIBLE_STATURE_M`].
    ImplausibleStature {
        /// Vertical extent of the rest pose, metres (with the scale used).
        stature_m: f64,
        /// Scale that would make the rest pose 1.5 m tall (a typical adult BVH skeleton).
        suggested_scale: f64,
    },
    /// The median pelvis height over the clip is outside [`PLAUSIBLE_PELVIS_HEIGHT_M`].
    ImplausiblePelvisHeight {
        /// Median pelvis z, metres.
        height_m: f64,
        /// Scale that would put the pelvis at 0.95 m (meaningful only if the floor is z = 0);
        /// `None` when the pelvis is at or below z = 0.
        suggested_scale: Option<f64>,
    },
}

impl fmt::Display for MocapWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MocapWarning::ImplausibleStature {
                stature_m,
                suggested_scale,
            } => write!(
                f,
                "rest-pose height is {stature_m:.3} m, implausible for a person: wrong units? a scale of about {suggested_scale:.4} would make it 1.5 m"
            ),
            MocapWarning::ImplausiblePelvisHeight {
                height_m,
                suggested_scale,
            } => {
                write!(
                    f,
                    "median pelvis height is {height_m:.3} m above z = 0, implausible for a person: wrong units or floor?"
                )?;
                match suggested_scale {
                    Some(s) => write!(f, " a scale of about {s:.4} would make it 0.95 m"),
                    None => write!(f, " (is the file really Y up?)"),
                }
            }
        }
    }
}

/// A BVH clip on nomen's canonical skeleton: Z-up world, metres, a known frame rate.
///
/// Nothing is re-centred: positions keep the file's horizontal origin, so clips recorded in one
/// coordinate frame (18_01 and 19_01) stay in it.
#[derive(Debug, Clone, PartialEq)]
pub struct MocapClip {
    /// Source name (file name).
    pub source: String,
    /// Frame rate used, Hz (the override, or the header's rate snapped to a whole number of Hz
    /// when within 0.1%).
    pub rate_hz: f64,
    /// Scale used, file units → metres.
    pub scale: f64,
    /// Amount subtracted from every z by [`Grounding::LowestFootToZero`], metres (0 otherwise).
    pub ground_offset_m: f64,
    /// Number of frames.
    pub num_frames: usize,
    /// The naming variant and which BVH node each canonical joint comes from.
    pub mapping: JointMapping,
    /// Canonical joints per frame (all 20 present).
    pub frames: Vec<Joints<JointPose>>,
    /// Plausibility warnings.
    pub warnings: Vec<MocapWarning>,
    /// The parsed file (hierarchy and raw channel values, file units, Y up).
    pub bvh: Bvh,
    /// World pose of every BVH node, frame-major: `node_poses[frame * bvh.nodes.len() + node]`.
    node_poses: Vec<JointPose>,
}

impl MocapClip {
    /// Time of `frame` since the clip's start, seconds.
    pub fn time_s(&self, frame: usize) -> f64 {
        frame as f64 / self.rate_hz
    }

    /// Duration from the first to one frame past the last, seconds.
    pub fn duration_s(&self) -> f64 {
        self.num_frames as f64 / self.rate_hz
    }

    /// Pose of canonical `joint` in `frame`.
    pub fn joint(&self, frame: usize, joint: Joint) -> Option<&JointPose> {
        self.frames.get(frame)?.get(joint)
    }

    /// Poses of all BVH nodes (joints and End Sites, in [`Bvh::nodes`] order) in `frame`.
    pub fn node_poses(&self, frame: usize) -> Option<&[JointPose]> {
        let n = self.bvh.nodes.len();
        let start = frame.checked_mul(n)?;
        self.node_poses.get(start..start.checked_add(n)?)
    }

    /// One skeleton observation per frame: all 20 joints tracked with confidence 1, positions in
    /// the Z-up world (use a camera whose `world_from_camera` is the identity, or transform them),
    /// at `t0 + frame / rate_hz` rounded to the nanosecond.
    pub fn to_skeletons(
        &self,
        camera: CameraId,
        track: TrackId,
        t0: SessionTime,
    ) -> Vec<SkeletonObservation> {
        self.frames
            .iter()
            .enumerate()
            .map(|(i, joints)| SkeletonObservation {
                t: t0 + frame_offset_ns(i, self.rate_hz),
                camera: camera.clone(),
                track,
                joints: joints.map(|_, p| JointObservation::tracked(p.position_m)),
            })
            .collect()
    }
}

/// `frame / rate_hz` in integer nanoseconds, computed without accumulating rounding.
fn frame_offset_ns(frame: usize, rate_hz: f64) -> i64 {
    (frame as f64 * 1e9 / rate_hz).round() as i64
}

fn check_options(options: &ConvertOptions) -> Result<()> {
    if let Some(s) = options.scale
        && !(s.is_finite() && s > 0.0)
    {
        return Err(MocapError::InvalidOption(format!(
            "scale must be a positive number, got {s}"
        )));
    }
    if let Some(f) = options.fps_hz
        && !(f.is_finite() && f > 0.0)
    {
        return Err(MocapError::InvalidOption(format!(
            "frame rate must be a positive number of Hz, got {f}"
        )));
    }
    Ok(())
}

/// Converts a parsed BVH file into a clip on the canonical skeleton (see the crate docs for the
/// conventions).
pub fn convert(bvh: &Bvh, options: &ConvertOptions) -> Result<MocapClip> {
    let mut clip = convert_unground(bvh, options)?;
    if options.grounding == Grounding::LowestFootToZero {
        let z = lowest_foot_z(&clip);
        shift_down(&mut clip, z);
    }
    clip.warnings = plausibility_warnings(&clip);
    Ok(clip)
}

/// Converts two files recorded together (one person each, one coordinate frame and clock, e.g.
/// CMU 18_01 and 19_01, or a salsa pair) with the same options. Frame *i* of both clips is the
/// same instant. Nothing is re-centred; [`Grounding::LowestFootToZero`] uses one offset for both
/// (the lower of the two clips' lowest foot).
///
/// Fails when the two clips end up with different frame rates.
pub fn convert_pair(
    first: &Bvh,
    second: &Bvh,
    options: &ConvertOptions,
) -> Result<(MocapClip, MocapClip)> {
    let mut a = convert_unground(first, options)?;
    let mut b = convert_unground(second, options)?;
    if (a.rate_hz - b.rate_hz).abs() > 1e-9 * a.rate_hz {
        return Err(MocapError::PairMismatch {
            first: a.source.clone(),
            second: b.source.clone(),
            detail: format!("frame rates {} Hz and {} Hz differ", a.rate_hz, b.rate_hz),
        });
    }
    if options.grounding == Grounding::LowestFootToZero {
        let z = lowest_foot_z(&a).min(lowest_foot_z(&b));
        shift_down(&mut a, z);
        shift_down(&mut b, z);
    }
    a.warnings = plausibility_warnings(&a);
    b.warnings = plausibility_warnings(&b);
    Ok((a, b))
}

fn convert_unground(bvh: &Bvh, options: &ConvertOptions) -> Result<MocapClip> {
    check_options(options)?;
    let mapping = map_joints(bvh, options.variant)?;
    let scale = options.scale.unwrap_or(1.0);
    let rate_hz = options.fps_hz.unwrap_or_else(|| {
        let header = bvh.header_rate_hz();
        let whole = header.round();
        if whole > 0.0 && (header - whole).abs() <= RATE_SNAP_RELATIVE * whole {
            whole
        } else {
            header
        }
    });
    let num_nodes = bvh.nodes.len();
    let mut node_poses = Vec::with_capacity(bvh.num_frames.saturating_mul(num_nodes));
    let mut frames = Vec::with_capacity(bvh.num_frames);
    let mut buf = Vec::with_capacity(num_nodes);
    for f in 0..bvh.num_frames {
        let values = bvh.frame(f).unwrap_or(&[]);
        forward_kinematics(bvh, values, scale, &mut buf);
        frames.push(
            mapping
                .nodes
                .map(|_, &i| buf.get(i).copied().unwrap_or_default()),
        );
        node_poses.extend_from_slice(&buf);
    }
    Ok(MocapClip {
        source: bvh.source.clone(),
        rate_hz,
        scale,
        ground_offset_m: 0.0,
        num_frames: bvh.num_frames,
        mapping,
        frames,
        warnings: Vec::new(),
        bvh: bvh.clone(),
        node_poses,
    })
}

const FOOT_JOINTS: [Joint; 4] = [
    Joint::LeftAnkle,
    Joint::LeftFoot,
    Joint::RightAnkle,
    Joint::RightFoot,
];

fn lowest_foot_z(clip: &MocapClip) -> f64 {
    let z = clip
        .frames
        .iter()
        .flat_map(|f| FOOT_JOINTS.iter().filter_map(|&j| f.get(j)))
        .map(|p| p.position_m.z)
        .fold(f64::INFINITY, f64::min);
    if z.is_finite() { z } else { 0.0 }
}

fn shift_down(clip: &mut MocapClip, dz: f64) {
    clip.ground_offset_m += dz;
    for frame in &mut clip.frames {
        for j in nomen_core::Joint::ALL {
            if let Some(p) = frame.get_mut(j) {
                p.position_m.z -= dz;
            }
        }
    }
    for p in &mut clip.node_poses {
        p.position_m.z -= dz;
    }
}

/// Vertical extent of the rest pose (all channels zero), metres: the standing height of a
/// T-posed skeleton (to the top-of-head End Site where there is one).
pub fn rest_stature_m(bvh: &Bvh, scale: f64) -> f64 {
    let mut buf = Vec::new();
    forward_kinematics(bvh, &[], scale, &mut buf);
    let (lo, hi) = buf
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p.position_m.z), hi.max(p.position_m.z))
        });
    if hi >= lo { hi - lo } else { 0.0 }
}

fn median(mut v: Vec<f64>) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    Some(v[v.len() / 2])
}

fn plausibility_warnings(clip: &MocapClip) -> Vec<MocapWarning> {
    let mut out = Vec::new();
    let stature_m = rest_stature_m(&clip.bvh, clip.scale);
    if stature_m > 0.0 && !(PLAUSIBLE_STATURE_M.0..=PLAUSIBLE_STATURE_M.1).contains(&stature_m) {
        out.push(MocapWarning::ImplausibleStature {
            stature_m,
            suggested_scale: clip.scale * TYPICAL_STATURE_M / stature_m,
        });
    }
    let pelvis = median(
        clip.frames
            .iter()
            .filter_map(|f| f.get(Joint::Pelvis))
            .map(|p| p.position_m.z)
            .collect(),
    );
    if let Some(height_m) = pelvis
        && !(PLAUSIBLE_PELVIS_HEIGHT_M.0..=PLAUSIBLE_PELVIS_HEIGHT_M.1).contains(&height_m)
    {
        out.push(MocapWarning::ImplausiblePelvisHeight {
            height_m,
            suggested_scale: (height_m > 0.0)
                .then(|| clip.scale * TYPICAL_PELVIS_HEIGHT_M / height_m),
        });
    }
    out
}
