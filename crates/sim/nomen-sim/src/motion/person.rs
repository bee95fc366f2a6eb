//! [`PersonMotion`]: precomputed spline control points of one clip, evaluated by forward
//! kinematics at any time (see the [module docs](super)).

use super::lowpass::{MAX_CUTOFF_FRACTION, ZeroPhaseLowpass};
use super::path::Path;
use super::{MotionSpec, TIME_WARP_RANGE};
use crate::body::{BodyMotion, BodyPose, JointPose};
use crate::error::{Result, SimError};
use nalgebra::{Point3, Quaternion, UnitQuaternion, Vector2, Vector3, Vector4};
use nomen_core::frame::z_up_from_y_up;
use nomen_core::skeleton::{Joint, Joints, NUM_JOINTS};
use nomen_mocap::bvh::BvhNode;
use nomen_mocap::{MocapClip, rest_stature_m};

/// Horizontal pelvis travel over one period (or the whole clip without `repeat`) from which a
/// clip counts as travelling, metres. The in-place CMU clips (wave, hop) drift less than 0.3 m;
/// the walks cover 2–10 m.
pub const TRAVEL_THRESHOLD_M: f64 = 0.5;
/// Most BVH nodes a clip may need for the canonical joints (ancestors included).
const MAX_NODES: usize = 64;
/// A path person who has not arrived after this long (scene seconds) is considered to never
/// arrive (an in-place clip on a path).
const MAX_ARRIVAL_SEARCH_S: f64 = 3600.0;
/// How far from each end of a repeating clip the automatic loop points are searched, seconds of
/// clip time (at most a third of the clip): more than one gait cycle (≈ 1.1 s) of a walk.
pub const LOOP_SEARCH_S: f64 = 2.5;
/// Weight of velocities against positions in the loop-point distance, seconds: a velocity
/// difference of 1 m/s counts as much as 0.1 m of pose difference.
const LOOP_VELOCITY_WEIGHT_S: f64 = 0.1;

/// One clip as the clip library provides it.
#[derive(Debug, Clone, Copy)]
pub struct ClipUse<'a> {
    /// The converted clip.
    pub clip: &'a MocapClip,
    /// Leading frames to ignore (a T-pose in frame 0); clip time 0 is the first frame kept.
    pub skip_frames: usize,
    /// Whether the clip travels; `None`: decide from the data ([`TRAVEL_THRESHOLD_M`]).
    pub travels: Option<bool>,
}

impl<'a> ClipUse<'a> {
    /// The whole clip, travelling decided from the data.
    pub fn new(clip: &'a MocapClip) -> Self {
        Self {
            clip,
            skip_frames: 0,
            travels: None,
        }
    }
}

/// A BVH node kept for evaluation.
#[derive(Debug, Clone)]
struct Node {
    /// Parent, as an index into `PersonMotion::nodes`.
    parent: Option<usize>,
    /// Bone offset in the parent's BVH frame, metres (scale and height factor applied).
    offset_m: Vector3<f64>,
    /// `Some(q)`: the local rotation never changes.
    fixed_rotation: Option<UnitQuaternion<f64>>,
}

#[derive(Debug, Clone)]
enum Placement {
    Path {
        path: Path,
        theta_d_rad: f64,
    },
    Fixed {
        position_m: Vector2<f64>,
        heading_rad: f64,
        theta_d_rad: f64,
    },
    ClipFrame {
        offset_m: Vector2<f64>,
        yaw_rad: f64,
    },
}

/// The rigid horizontal map of one instant: `world_h = R(yaw) · (p_h − anchor) + target`.
#[derive(Debug, Clone, Copy)]
struct Place {
    world_from_yup: UnitQuaternion<f64>,
    cos: f64,
    sin: f64,
    anchor: Vector2<f64>,
    target: Vector2<f64>,
    ground_m: f64,
}

impl Place {
    fn joint(&self, p_yup: &Vector3<f64>, r_yup: &UnitQuaternion<f64>) -> JointPose {
        // BVH Y up → Z up: (x, y, z) → (x, −z, y), as nomen_core::frame::z_up_from_y_up.
        let h = Vector2::new(p_yup.x, -p_yup.z) - self.anchor;
        JointPose {
            position_m: Point3::new(
                self.cos * h.x - self.sin * h.y + self.target.x,
                self.sin * h.x + self.cos * h.y + self.target.y,
                p_yup.y - self.ground_m,
            ),
            world_from_joint: self.world_from_yup * r_yup,
        }
    }
}

/// B-spline position in the control sequence at one instant.
#[derive(Debug, Clone, Copy)]
struct Knot {
    /// Segment index: the curve is between control points `i` and `i + 1`.
    i: i64,
    /// Uniform cubic B-spline basis for controls `i − 1 ..= i + 2`.
    basis: [f64; 4],
    /// Cumulative basis for the three rotation increments `ω_i, ω_{i+1}, ω_{i+2}`.
    cumulative: [f64; 3],
}

/// A person playing a motion-capture clip (see the [module docs](super)).
#[derive(Debug, Clone)]
pub struct PersonMotion {
    nodes: Vec<Node>,
    /// Local rotation per control and node: `q[c * nodes.len() + n]`.
    q: Vec<UnitQuaternion<f64>>,
    /// `log(q[c-1]⁻¹ q[c])` per control and node (zero for c = 0).
    omega: Vec<Vector3<f64>>,
    /// Root translation per control, metres, BVH Y-up axes.
    root: Vec<Vector3<f64>>,
    /// Loop period in controls (0: no repeat; controls are then clamped).
    period: usize,
    /// Selected part of the clip, `[first, last]` frame times in seconds after the skipped
    /// frames.
    range_s: (f64, f64),
    /// Root travel per period (BVH axes).
    drift: Vector3<f64>,
    /// Node of each canonical joint, and the chain root → joint.
    chains: Vec<Vec<usize>>,
    joint_node: [usize; NUM_JOINTS],
    rate_hz: f64,
    phase_s: f64,
    time_warp: f64,
    span_s: (f64, f64),
    placement: Placement,
    ground_m: f64,
    /// Mean travel (or facing) direction and origin of the moving frame, Z-up horizontal.
    dir: Vector2<f64>,
    origin: Vector2<f64>,
    /// Progress along `dir` at `start_s`.
    s0_m: f64,
    is_travelling: bool,
    height_factor: f64,
    stature_m: f64,
    /// Spans of session time during which the person is away, `[from, to)`.
    absent_s: Vec<[f64; 2]>,
}

fn invalid(msg: String) -> SimError {
    SimError::InvalidScenario(msg)
}

/// `M · R · M` for the reflection `M = diag(−1, 1, 1)`.
fn mirror_rotation(q: &UnitQuaternion<f64>) -> UnitQuaternion<f64> {
    let c = q.quaternion();
    UnitQuaternion::new_unchecked(Quaternion::new(c.w, c.i, -c.j, -c.k))
}

/// The node name of the other side, if the naming says so.
fn partner_names(name: &str) -> Vec<String> {
    let mut out = Vec::new();
    for (a, b) in [("Left", "Right"), ("left", "right"), ("LEFT", "RIGHT")] {
        if name.contains(a) {
            out.push(name.replacen(a, b, 1));
        }
        if name.contains(b) {
            out.push(name.replacen(b, a, 1));
        }
    }
    for (a, b) in [('L', 'R'), ('l', 'r')] {
        for (x, y) in [(a, b), (b, a)] {
            if let Some(rest) = name.strip_prefix(x) {
                out.push(format!("{y}{rest}"));
            }
        }
    }
    for (a, b) in [(".l", ".r"), ("_l", "_r"), (".L", ".R"), ("_L", "_R")] {
        for (x, y) in [(a, b), (b, a)] {
            if let Some(stem) = name.strip_suffix(x) {
                out.push(format!("{stem}{y}"));
            }
            let infix = format!("{x}.");
            if name.contains(&infix) {
                out.push(name.replacen(&infix, &format!("{y}."), 1));
            }
        }
    }
    out
}

fn local_motion(node: &BvhNode, values: &[f64]) -> (UnitQuaternion<f64>, Vector3<f64>) {
    let mut translation = node.offset;
    let mut local = UnitQuaternion::identity();
    for (k, ch) in node.channels.iter().enumerate() {
        let v = values.get(node.first_channel + k).copied().unwrap_or(0.0);
        let v = if v.is_finite() { v } else { 0.0 };
        if ch.is_rotation() {
            let axis = match ch.axis() {
                0 => Vector3::x_axis(),
                1 => Vector3::y_axis(),
                _ => Vector3::z_axis(),
            };
            local *= UnitQuaternion::from_axis_angle(&axis, v.to_radians());
        } else if let Some(t) = translation.get_mut(ch.axis()) {
            *t += v;
        }
    }
    (local, translation)
}

fn same_hemisphere(a: &UnitQuaternion<f64>, b: &UnitQuaternion<f64>) -> UnitQuaternion<f64> {
    if a.coords.dot(&b.coords) < 0.0 {
        UnitQuaternion::new_unchecked(-b.into_inner())
    } else {
        *b
    }
}

fn smoothstep(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

fn horizontal(p_yup: &Vector3<f64>) -> Vector2<f64> {
    Vector2::new(p_yup.x, -p_yup.z)
}

impl PersonMotion {
    /// Precomputes the spline control points of `source.clip` for `spec`.
    ///
    /// Fails with [`SimError::InvalidScenario`] (the message names the field) when the spec is
    /// out of range or the clip is too short for it.
    pub fn new(spec: &MotionSpec, source: ClipUse<'_>) -> Result<Self> {
        let clip = source.clip;
        let who = &spec.clip;
        check_spec(spec)?;
        let rate_hz = clip.rate_hz;
        if !(rate_hz.is_finite() && rate_hz > 0.0) {
            return Err(invalid(format!("clip '{who}': frame rate {rate_hz} Hz")));
        }
        // Usable frames (after the library's skipped ones).
        let avail = clip.num_frames.min(clip.bvh.num_frames);
        let usable = source.skip_frames..avail.max(source.skip_frames);
        if usable.len() < 4 {
            return Err(invalid(format!(
                "clip '{who}': fewer than 4 frames after the {} skipped",
                source.skip_frames
            )));
        }

        // Height.
        let stature0 = rest_stature_m(&clip.bvh, clip.scale);
        let height_factor = match spec.height_m {
            Some(h) if stature0 > 0.0 => h / stature0,
            Some(_) => {
                return Err(invalid(format!(
                    "motion of clip '{who}': height_m given but the clip has no rest stature"
                )));
            }
            None => 1.0,
        };
        let length_scale = clip.scale * height_factor;

        // Nodes needed: ancestors of the mapped joints (and of their mirror partners).
        let bvh_nodes = &clip.bvh.nodes;
        let partner: Vec<usize> = (0..bvh_nodes.len())
            .map(|i| {
                if !spec.mirror {
                    return i;
                }
                let name = bvh_nodes.get(i).map(|n| n.name.as_str()).unwrap_or("");
                partner_names(name)
                    .iter()
                    .find_map(|p| clip.bvh.node_index(p))
                    .unwrap_or(i)
            })
            .collect();
        let mut needed = vec![false; bvh_nodes.len()];
        for (_, &n) in clip.mapping.nodes.iter() {
            for start in [n, partner.get(n).copied().unwrap_or(n)] {
                let mut cur = Some(start);
                while let Some(c) = cur {
                    match needed.get_mut(c) {
                        Some(flag) if !*flag => *flag = true,
                        _ => break,
                    }
                    cur = bvh_nodes.get(c).and_then(|node| node.parent);
                }
            }
        }
        let mut reduced = vec![usize::MAX; bvh_nodes.len()];
        let mut kept: Vec<usize> = Vec::new();
        for (i, &is_needed) in needed.iter().enumerate() {
            if is_needed {
                reduced[i] = kept.len();
                kept.push(i);
            }
        }
        if kept.len() > MAX_NODES {
            return Err(invalid(format!(
                "clip '{who}': {} BVH joints needed, more than {MAX_NODES}",
                kept.len()
            )));
        }
        if kept
            .first()
            .and_then(|&i| bvh_nodes.get(i))
            .is_none_or(|n| n.parent.is_some())
        {
            return Err(invalid(format!(
                "clip '{who}': the first BVH node is not a root"
            )));
        }
        let num_nodes = kept.len();

        // Per-frame local rotations (mirrored if asked, sign-continuous in time) and root
        // translation, Y up, over every usable frame, so the low-pass sees the clip's own motion
        // beyond the selected range.
        let mut nodes = Vec::with_capacity(num_nodes);
        let first_values = clip.bvh.frame(usable.start).unwrap_or(&[]);
        for &b in &kept {
            let Some(node) = bvh_nodes.get(b) else {
                continue;
            };
            let (_, translation) = local_motion(node, first_values);
            nodes.push(Node {
                parent: node.parent.and_then(|p| reduced.get(p).copied()),
                offset_m: translation * length_scale,
                fixed_rotation: None,
            });
        }
        let mut all_q: Vec<UnitQuaternion<f64>> = Vec::with_capacity(usable.len() * num_nodes);
        let mut all_root = Vec::with_capacity(usable.len());
        let mut frame_q = vec![UnitQuaternion::identity(); num_nodes];
        for f in usable.clone() {
            let values = clip.bvh.frame(f).unwrap_or(&[]);
            for (slot, &b) in frame_q.iter_mut().zip(&kept) {
                if let Some(node) = bvh_nodes.get(b) {
                    *slot = local_motion(node, values).0;
                }
            }
            for (n, &b) in kept.iter().enumerate() {
                let src = partner.get(b).copied().unwrap_or(b);
                let src = reduced.get(src).copied().filter(|&r| r < num_nodes);
                let q = frame_q.get(src.unwrap_or(n)).copied().unwrap_or_default();
                let q = if spec.mirror { mirror_rotation(&q) } else { q };
                let prev = all_q
                    .len()
                    .checked_sub(num_nodes)
                    .and_then(|k| all_q.get(k));
                all_q.push(match prev {
                    Some(prev) => same_hemisphere(prev, &q),
                    None => q,
                });
            }
            let root_node = kept.first().and_then(|&b| bvh_nodes.get(b));
            let mut t = root_node
                .map(|n| local_motion(n, values).1)
                .unwrap_or_default()
                * length_scale;
            if spec.mirror {
                t.x = -t.x;
            }
            all_root.push(t);
        }
        // The root's offset is part of its translation.
        if let Some(root) = nodes.first_mut() {
            root.offset_m = Vector3::zeros();
        }
        if spec.lowpass_hz > 0.0 {
            let filter = ZeroPhaseLowpass::new(spec.lowpass_hz, rate_hz).ok_or_else(|| {
                invalid(format!(
                    "motion of clip '{who}': lowpass_hz {} must be at most {MAX_CUTOFF_FRACTION} \
                     of the clip's frame rate ({rate_hz} Hz)",
                    spec.lowpass_hz
                ))
            })?;
            lowpass_frames(&filter, num_nodes, &mut all_q, &mut all_root);
        }

        // Selected frames: `clip_range_s`, else for a loop the most similar pair of frames near
        // the start and the end, else the whole clip.
        let num_usable = usable.len();
        let blend = (spec.blend_s * rate_hz).round() as usize;
        let (first, end) = match spec.clip_range_s {
            Some([from_s, to_s]) => (
                (from_s * rate_hz).round() as usize,
                ((to_s * rate_hz).round() as usize + 1).min(num_usable),
            ),
            None if spec.repeat => {
                let features = loop_features(&nodes, &all_q, &all_root, rate_hz);
                loop_points(&features, blend, rate_hz)
            }
            None => (0, num_usable),
        };
        if end < first + 4 {
            return Err(invalid(format!(
                "motion of clip '{who}': clip_range_s selects fewer than 4 frames of {num_usable}"
            )));
        }
        let num_frames = end - first;
        let raw_q = all_q.get(first * num_nodes..end * num_nodes).unwrap_or(&[]);
        let raw_root = all_root.get(first..end).unwrap_or(&[]);

        // Loop structure.
        let (q, root, period, drift, is_travelling) = if spec.repeat {
            if 2 * blend > num_frames || num_frames - blend < 4 {
                return Err(invalid(format!(
                    "motion of clip '{who}': blend_s {} s is more than half the selected clip ({} s)",
                    spec.blend_s,
                    num_frames as f64 / rate_hz
                )));
            }
            let period = num_frames - blend;
            let mut drift = raw_root.get(period).copied().unwrap_or_default()
                - raw_root.first().copied().unwrap_or_default();
            drift.y = 0.0;
            let travels = source.travels.unwrap_or(drift.norm() >= TRAVEL_THRESHOLD_M);
            if !travels {
                drift = Vector3::zeros();
            }
            let mut q = Vec::with_capacity(2 * period * num_nodes);
            let mut root = Vec::with_capacity(2 * period);
            q.extend_from_slice(raw_q.get(..period * num_nodes).unwrap_or(&[]));
            root.extend_from_slice(raw_root.get(..period).unwrap_or(&[]));
            for m in 0..period {
                if m < blend {
                    // Weight of the clip's start rises from ~0 to ~1 across the blend.
                    let w = smoothstep((m + 1) as f64 / (blend + 1) as f64);
                    for n in 0..num_nodes {
                        let late = raw_q
                            .get((period + m) * num_nodes + n)
                            .copied()
                            .unwrap_or_default();
                        let early = raw_q.get(m * num_nodes + n).copied().unwrap_or_default();
                        let early = same_hemisphere(&late, &early);
                        q.push(late.slerp(&early, w));
                    }
                    let late = raw_root.get(period + m).copied().unwrap_or_default() - drift;
                    let early = raw_root.get(m).copied().unwrap_or_default();
                    root.push(late.lerp(&early, w) + drift);
                } else {
                    q.extend_from_slice(
                        raw_q.get(m * num_nodes..(m + 1) * num_nodes).unwrap_or(&[]),
                    );
                    root.push(raw_root.get(m).copied().unwrap_or_default() + drift);
                }
            }
            (q, root, period, drift, travels)
        } else {
            let mut net = raw_root.last().copied().unwrap_or_default()
                - raw_root.first().copied().unwrap_or_default();
            net.y = 0.0;
            let travels = source.travels.unwrap_or(net.norm() >= TRAVEL_THRESHOLD_M);
            (
                raw_q.to_vec(),
                raw_root.to_vec(),
                0,
                Vector3::zeros(),
                travels,
            )
        };
        let num_ctrl = root.len();
        if q.len() != num_ctrl * num_nodes {
            return Err(invalid(format!("clip '{who}': inconsistent frame data")));
        }
        let mut omega = vec![Vector3::zeros(); q.len()];
        for c in 1..num_ctrl {
            for n in 0..num_nodes {
                let k = c * num_nodes + n;
                if let (Some(a), Some(b)) = (q.get(k - num_nodes), q.get(k)) {
                    omega[k] = (a.inverse() * b).scaled_axis();
                }
            }
        }
        for (n, node) in nodes.iter_mut().enumerate() {
            let q0 = q.get(n).copied().unwrap_or_default();
            let fixed = (0..num_ctrl).all(|c| {
                q.get(c * num_nodes + n)
                    .is_some_and(|qc| qc.angle_to(&q0) < 1e-12)
            });
            if fixed {
                node.fixed_rotation = Some(q0);
            }
        }

        // Canonical joints → nodes and chains.
        let mut joint_node = [0usize; NUM_JOINTS];
        let mut chains = vec![Vec::new(); NUM_JOINTS];
        for j in Joint::ALL {
            let b = clip.mapping.nodes.get(j).copied().unwrap_or(0);
            let r = reduced
                .get(b)
                .copied()
                .filter(|&r| r < num_nodes)
                .unwrap_or(0);
            joint_node[j.index()] = r;
            let mut chain = Vec::new();
            let mut cur = Some(r);
            while let Some(c) = cur {
                chain.push(c);
                cur = nodes.get(c).and_then(|n| n.parent);
                if chain.len() > num_nodes {
                    break;
                }
            }
            chain.reverse();
            chains[j.index()] = chain;
        }

        let mut motion = PersonMotion {
            nodes,
            q,
            omega,
            root,
            period,
            range_s: (first as f64 / rate_hz, (end - 1) as f64 / rate_hz),
            drift,
            chains,
            joint_node,
            rate_hz,
            phase_s: spec.phase_s,
            time_warp: spec.time_warp,
            span_s: (spec.start_s, spec.end_s.unwrap_or(f64::INFINITY)),
            placement: Placement::ClipFrame {
                offset_m: Vector2::zeros(),
                yaw_rad: 0.0,
            },
            ground_m: 0.0,
            dir: Vector2::x(),
            origin: Vector2::zeros(),
            s0_m: 0.0,
            is_travelling,
            height_factor,
            stature_m: stature0 * height_factor,
            absent_s: spec.absent_s.clone(),
        };
        motion.place(spec, clip)?;
        Ok(motion)
    }

    /// Ground, moving frame, placement and span.
    fn place(&mut self, spec: &MotionSpec, clip: &MocapClip) -> Result<()> {
        let who = &spec.clip;
        let num_ctrl = self.root.len();
        let first_period = if self.period > 0 {
            self.period
        } else {
            num_ctrl
        };
        // Control poses (no spline) in the clip's Z-up frame.
        let mut lowest_foot = f64::INFINITY;
        let mut facing = Vector2::zeros();
        let mut mean_root = Vector2::zeros();
        let mut rot = [UnitQuaternion::identity(); MAX_NODES];
        let mut pos = [Vector3::zeros(); MAX_NODES];
        for c in 0..num_ctrl {
            for (n, node) in self.nodes.iter().enumerate() {
                let local = self
                    .q
                    .get(c * self.nodes.len() + n)
                    .copied()
                    .unwrap_or_default();
                match node.parent {
                    None => {
                        rot[n] = local;
                        pos[n] = self.root.get(c).copied().unwrap_or_default();
                    }
                    Some(p) => {
                        rot[n] = rot[p] * local;
                        pos[n] = pos[p] + rot[p] * node.offset_m;
                    }
                }
            }
            for j in [
                Joint::LeftAnkle,
                Joint::LeftFoot,
                Joint::RightAnkle,
                Joint::RightFoot,
            ] {
                lowest_foot = lowest_foot.min(pos[self.joint_node[j.index()]].y);
            }
            if c < first_period {
                let l = horizontal(&pos[self.joint_node[Joint::LeftHip.index()]])
                    - horizontal(&pos[self.joint_node[Joint::RightHip.index()]]);
                facing += Vector2::new(l.y, -l.x);
                mean_root += horizontal(&pos[0]);
            }
        }
        mean_root /= first_period as f64;
        let r0 = self.root.first().map(horizontal).unwrap_or_default();
        let travel = if self.period > 0 {
            horizontal(&self.drift)
        } else {
            self.root.last().map(horizontal).unwrap_or_default() - r0
        };
        let facing_dir = facing.try_normalize(1e-9).unwrap_or(Vector2::x());
        if self.is_travelling {
            self.dir = travel.try_normalize(1e-9).unwrap_or(facing_dir);
            let side = Vector2::new(-self.dir.y, self.dir.x);
            self.origin = r0 + side * (mean_root - r0).dot(&side);
        } else {
            self.dir = facing_dir;
            self.origin = mean_root;
        }
        let theta_d_rad = self.dir.y.atan2(self.dir.x);
        let start_s = self.span_s.0;
        self.s0_m = self.progress_raw_m(start_s);

        let num_placements = [
            spec.path.is_some(),
            spec.position.is_some(),
            spec.clip_frame.is_some(),
        ]
        .iter()
        .filter(|&&b| b)
        .count();
        if num_placements > 1 {
            return Err(invalid(format!(
                "motion of clip '{who}': give only one of path, position, clip_frame"
            )));
        }
        self.ground_m = if lowest_foot.is_finite() {
            lowest_foot
        } else {
            0.0
        };
        let mut end_s = self.span_s.1;
        if !spec.repeat && spec.end_s.is_none() {
            let clip_len_s = (num_ctrl.saturating_sub(1)) as f64 / self.rate_hz;
            let left_s = (clip_len_s - self.phase_s) / self.time_warp;
            if left_s <= 0.0 {
                return Err(invalid(format!(
                    "motion of clip '{who}': phase_s {} s is past the end of the clip",
                    self.phase_s
                )));
            }
            end_s = start_s + left_s;
        }
        if let Some(frame) = spec.clip_frame {
            self.ground_m = clip.ground_offset_m * self.height_factor;
            self.placement = Placement::ClipFrame {
                offset_m: Vector2::new(frame.offset_m[0], frame.offset_m[1]),
                yaw_rad: frame.yaw_rad,
            };
        } else if let Some(waypoints) = &spec.path {
            let path = Path::new(waypoints, spec.corner_radius_m).ok_or_else(|| {
                invalid(format!(
                    "motion of clip '{who}': path needs at least two finite, distinct consecutive waypoints"
                ))
            })?;
            let length_m = path.length_m();
            self.placement = Placement::Path { path, theta_d_rad };
            if let Some(arrival) = self.arrival_s(length_m, end_s) {
                end_s = end_s.min(arrival);
            }
        } else {
            let p = spec.position.unwrap_or([0.0, 0.0]);
            self.placement = Placement::Fixed {
                position_m: Vector2::new(p[0], p[1]),
                heading_rad: spec.heading_rad,
                theta_d_rad,
            };
        }
        self.span_s = (start_s, end_s);
        Ok(())
    }

    /// First instant the progress reaches `length_m`, searched up to `limit_s`.
    fn arrival_s(&self, length_m: f64, limit_s: f64) -> Option<f64> {
        let start = self.span_s.0;
        let limit = limit_s.min(start + MAX_ARRIVAL_SEARCH_S);
        let dt = 1.0 / 60.0;
        let progress = |t: f64| self.progress_raw_m(t) - self.s0_m;
        let mut t = start;
        while t < limit {
            let next = (t + dt).min(limit);
            if progress(next) >= length_m {
                let (mut lo, mut hi) = (t, next);
                for _ in 0..40 {
                    let mid = 0.5 * (lo + hi);
                    if progress(mid) >= length_m {
                        hi = mid;
                    } else {
                        lo = mid;
                    }
                }
                return Some(hi);
            }
            t = next;
        }
        None
    }

    /// Whether the clip travels (see [`TRAVEL_THRESHOLD_M`]).
    pub fn is_travelling(&self) -> bool {
        self.is_travelling
    }

    /// The part of the clip played, `(first, last)` frame times in seconds after the library's
    /// skipped frames: `clip_range_s`, or the automatic loop points of a repeating clip.
    pub fn clip_range_s(&self) -> (f64, f64) {
        self.range_s
    }

    /// Loop period in seconds of clip time (`None` without `repeat`). Seams (where the
    /// cross-fade of `blend_s` begins) are at clip times `k · period`, `k ≥ 1`.
    pub fn loop_period_s(&self) -> Option<f64> {
        (self.period > 0).then(|| self.period as f64 / self.rate_hz)
    }

    /// Factor applied to the clip's lengths by `height_m` (1 without it).
    pub fn height_factor(&self) -> f64 {
        self.height_factor
    }

    /// Rest-pose stature of the played body, metres (`height_m` when given).
    pub fn stature_m(&self) -> f64 {
        self.stature_m
    }

    /// Clip time (seconds into the selected part, before looping) at scene time `t_s`.
    pub fn clip_time_s(&self, t_s: f64) -> f64 {
        let t = t_s.clamp(self.span_s.0, self.span_s.1);
        self.phase_s + self.time_warp * (t - self.span_s.0)
    }

    fn knot(&self, t_s: f64) -> Knot {
        let x = self.clip_time_s(t_s) * self.rate_hz;
        let x = if x.is_finite() { x.max(0.0) } else { 0.0 };
        let i = x.floor();
        let u = x - i;
        let (u2, u3) = (u * u, u * u * u);
        let v = 1.0 - u;
        Knot {
            i: i as i64,
            basis: [
                v * v * v / 6.0,
                (3.0 * u3 - 6.0 * u2 + 4.0) / 6.0,
                (-3.0 * u3 + 3.0 * u2 + 3.0 * u + 1.0) / 6.0,
                u3 / 6.0,
            ],
            cumulative: [
                (5.0 + 3.0 * u - 3.0 * u2 + u3) / 6.0,
                (1.0 + 3.0 * u + 3.0 * u2 - 2.0 * u3) / 6.0,
                u3 / 6.0,
            ],
        }
    }

    /// Stored control index and completed loops of control `j ≥ 1` (`j ≤ 0` is handled by the
    /// callers: linear extrapolation before the first control, so the spline has no artificial
    /// acceleration at the start). Without `repeat`, controls past the end repeat the last one.
    fn slot(&self, j: i64) -> (usize, f64, bool) {
        let j = j.max(0) as usize;
        if self.period == 0 {
            let last = self.root.len().saturating_sub(1);
            return if j > last {
                (last, 0.0, false)
            } else {
                (j, 0.0, true)
            };
        }
        let p = self.period;
        if j < 2 * p {
            (j, 0.0, true)
        } else {
            let k = j - p;
            (p + k % p, (k / p) as f64, true)
        }
    }

    fn ctrl_root(&self, j: i64) -> Vector3<f64> {
        let at = |c: usize| self.root.get(c).copied().unwrap_or_default();
        if j < 0 {
            let (r0, r1) = (at(0), at(1));
            return r0 + (r1 - r0) * j as f64;
        }
        let (c, loops, _) = self.slot(j);
        at(c) + self.drift * loops
    }

    fn ctrl_omega(&self, n: usize, j: i64) -> Vector3<f64> {
        let nn = self.nodes.len();
        let (c, _, valid) = self.slot(j.max(1));
        if valid {
            self.omega.get(c * nn + n).copied().unwrap_or_default()
        } else {
            Vector3::zeros()
        }
    }

    fn root_at(&self, k: &Knot) -> Vector3<f64> {
        let mut r = Vector3::zeros();
        for (m, b) in k.basis.iter().enumerate() {
            r += self.ctrl_root(k.i - 1 + m as i64) * *b;
        }
        r
    }

    fn local_at(&self, n: usize, k: &Knot) -> UnitQuaternion<f64> {
        let Some(node) = self.nodes.get(n) else {
            return UnitQuaternion::identity();
        };
        if let Some(q) = node.fixed_rotation {
            return q;
        }
        let nn = self.nodes.len();
        let mut q = if k.i >= 1 {
            let (c0, _, _) = self.slot(k.i - 1);
            self.q.get(c0 * nn + n).copied().unwrap_or_default()
        } else {
            // q[-1] = q[0] · exp(−ω[1]): the rotation keeps its first angular velocity.
            self.q.get(n).copied().unwrap_or_default()
                * UnitQuaternion::from_scaled_axis(-self.ctrl_omega(n, 1))
        };
        for (m, b) in k.cumulative.iter().enumerate() {
            let w = self.ctrl_omega(n, k.i + m as i64);
            q *= UnitQuaternion::from_scaled_axis(w * *b);
        }
        q
    }

    /// Progress of the root along the mean travel direction at scene time `t_s`, before
    /// subtracting its value at the start.
    fn progress_raw_m(&self, t_s: f64) -> f64 {
        let r = self.root_at(&self.knot(t_s));
        (horizontal(&r) - self.origin).dot(&self.dir)
    }

    fn place_at(&self, root_yup: &Vector3<f64>) -> Place {
        let r_h = horizontal(root_yup);
        let (yaw, anchor, target) = match &self.placement {
            Placement::Path { path, theta_d_rad } => {
                let s_raw = (r_h - self.origin).dot(&self.dir);
                let s = s_raw - self.s0_m;
                let pt = path.at(s);
                (
                    path.smooth_heading_rad(s) - theta_d_rad,
                    self.origin + self.dir * s_raw,
                    pt.position_m,
                )
            }
            Placement::Fixed {
                position_m,
                heading_rad,
                theta_d_rad,
            } => (
                heading_rad - theta_d_rad,
                self.origin + self.dir * self.s0_m,
                *position_m,
            ),
            Placement::ClipFrame { offset_m, yaw_rad } => (*yaw_rad, Vector2::zeros(), *offset_m),
        };
        let (sin, cos) = yaw.sin_cos();
        Place {
            world_from_yup: UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw)
                * z_up_from_y_up(),
            cos,
            sin,
            anchor,
            target,
            ground_m: self.ground_m,
        }
    }
}

/// Low-passes, in place, every node's local rotation (its sign-continuous quaternion components,
/// renormalised: within the filter's ~0.1 s window a joint turns a fraction of a radian, where
/// this equals filtering in the tangent space to second order, and unlike one global log map it
/// does not break for a root that turns through more than π) and the root translation.
fn lowpass_frames(
    filter: &ZeroPhaseLowpass,
    num_nodes: usize,
    q: &mut [UnitQuaternion<f64>],
    root: &mut [Vector3<f64>],
) {
    let num_frames = root.len();
    let mut channel = vec![0.0; num_frames];
    let mut scratch = Vec::new();
    let mut filtered = vec![Vector4::zeros(); num_frames];
    for n in 0..num_nodes {
        for c in 0..4 {
            for (f, v) in channel.iter_mut().enumerate() {
                *v = q.get(f * num_nodes + n).map_or(0.0, |q| q.coords[c]);
            }
            filter.filtfilt(&mut channel, &mut scratch);
            for (out, v) in filtered.iter_mut().zip(&channel) {
                out[c] = *v;
            }
        }
        for (f, v) in filtered.iter().enumerate() {
            let norm = v.norm();
            if let Some(slot) = q.get_mut(f * num_nodes + n)
                && norm > 0.5
            {
                *slot = UnitQuaternion::new_unchecked(Quaternion::from(*v / norm));
            }
        }
    }
    for c in 0..3 {
        for (v, r) in channel.iter_mut().zip(root.iter()) {
            *v = r[c];
        }
        filter.filtfilt(&mut channel, &mut scratch);
        for (r, v) in root.iter_mut().zip(&channel) {
            r[c] = *v;
        }
    }
}

/// Per frame, the pose and velocity descriptor that [`loop_points`] compares (flat,
/// `features.len() / num_frames` values per frame): every kept node's position relative to the
/// root and the root height (divided by √(number of nodes), so that squared differences average
/// over the body), the velocities of both times [`LOOP_VELOCITY_WEIGHT_S`], and the root velocity
/// times the same weight. Positions in metres, BVH axes, from forward kinematics of the frames.
fn loop_features(
    nodes: &[Node],
    q: &[UnitQuaternion<f64>],
    root: &[Vector3<f64>],
    rate_hz: f64,
) -> (Vec<f64>, usize) {
    let num_nodes = nodes.len();
    let num_frames = root.len();
    let pose_dim = 3 * num_nodes.saturating_sub(1) + 1;
    let weight = 1.0 / (num_nodes.max(1) as f64).sqrt();
    let mut pose = vec![0.0; num_frames * pose_dim];
    let mut rot = [UnitQuaternion::identity(); MAX_NODES];
    let mut pos = [Vector3::zeros(); MAX_NODES];
    for (f, chunk) in pose.chunks_exact_mut(pose_dim).enumerate() {
        for (n, node) in nodes.iter().enumerate().take(MAX_NODES) {
            let local = q.get(f * num_nodes + n).copied().unwrap_or_default();
            match node.parent {
                Some(p) if p < n => {
                    rot[n] = rot[p] * local;
                    pos[n] = pos[p] + rot[p] * node.offset_m;
                }
                _ => {
                    rot[n] = local;
                    pos[n] = root.get(f).copied().unwrap_or_default();
                }
            }
        }
        let mut values = chunk.iter_mut();
        for p in pos.iter().take(num_nodes).skip(1) {
            for v in (p - pos[0]).iter() {
                if let Some(slot) = values.next() {
                    *slot = v * weight;
                }
            }
        }
        if let Some(slot) = values.next() {
            *slot = pos[0].y * weight;
        }
    }
    let dim = 2 * pose_dim + 3;
    let mut features = vec![0.0; num_frames * dim];
    let last = num_frames.saturating_sub(1);
    for (f, out) in features.chunks_exact_mut(dim).enumerate() {
        // Central differences (one-sided at the ends).
        let (a, b) = (f.saturating_sub(1), (f + 1).min(last));
        let scale = LOOP_VELOCITY_WEIGHT_S * rate_hz / (b - a).max(1) as f64;
        let at = |k: usize| pose.get(k * pose_dim..(k + 1) * pose_dim).unwrap_or(&[]);
        let (now, before, after) = (at(f), at(a), at(b));
        let (pose_out, rest) = out.split_at_mut(pose_dim);
        pose_out.copy_from_slice(now);
        let (vel_out, root_out) = rest.split_at_mut(pose_dim);
        for ((v, x0), x1) in vel_out.iter_mut().zip(before).zip(after) {
            *v = (x1 - x0) * scale;
        }
        let root_vel = (root.get(b).copied().unwrap_or_default()
            - root.get(a).copied().unwrap_or_default())
            * scale;
        root_out.copy_from_slice(root_vel.as_slice());
    }
    (features, dim)
}

/// Loop points of a repeating clip without `clip_range_s`: the frames `i` near the start and
/// `j` near the end (each within [`LOOP_SEARCH_S`] or a third of the clip of its end, and
/// `j − i` at least half the clip) whose [`loop_features`] are closest, returned as the
/// selected range `i .. j + blend` (so the loop period is `j − i` and the cross-fade runs over
/// `j .. j + blend` into `i .. i + blend`). For a walk this puts the same gait phase, with the
/// same limb velocities, on both sides of the seam. The whole clip when nothing fits.
fn loop_points((features, dim): &(Vec<f64>, usize), blend: usize, rate_hz: f64) -> (usize, usize) {
    let num_frames = if *dim > 0 { features.len() / dim } else { 0 };
    let whole = (0, num_frames);
    let Some(j_max) = num_frames.checked_sub(blend) else {
        return whole;
    };
    let window = (num_frames / 3).min((LOOP_SEARCH_S * rate_hz).round() as usize);
    let min_period = (num_frames / 2).max(blend).max(4);
    let at = |k: usize| features.get(k * dim..(k + 1) * dim).unwrap_or(&[]);
    let mut best = (f64::INFINITY, whole);
    for i in 0..=window {
        for j in j_max.saturating_sub(window)..=j_max {
            if j < i + min_period {
                continue;
            }
            let cost: f64 = at(i)
                .iter()
                .zip(at(j))
                .map(|(a, b)| (a - b) * (a - b))
                .sum();
            if cost < best.0 {
                best = (cost, (i, j + blend));
            }
        }
    }
    best.1
}

fn check_spec(spec: &MotionSpec) -> Result<()> {
    let who = &spec.clip;
    let bad = |field: &str, why: &str, v: f64| {
        Err(invalid(format!(
            "motion of clip '{who}': {field} {why}, got {v}"
        )))
    };
    let (lo, hi) = TIME_WARP_RANGE;
    if !(lo..=hi).contains(&spec.time_warp) {
        return bad(
            "time_warp",
            &format!("must be within {lo}..={hi}"),
            spec.time_warp,
        );
    }
    if !(spec.phase_s.is_finite() && spec.phase_s >= 0.0) {
        return bad("phase_s", "must be a non-negative number", spec.phase_s);
    }
    if !spec.start_s.is_finite() {
        return bad("start_s", "must be finite", spec.start_s);
    }
    if let Some(e) = spec.end_s
        && !(e.is_finite() && e > spec.start_s)
    {
        return bad("end_s", "must be finite and after start_s", e);
    }
    if !(spec.blend_s.is_finite() && spec.blend_s >= 0.0) {
        return bad("blend_s", "must be a non-negative number", spec.blend_s);
    }
    if let Some(h) = spec.height_m
        && !(h.is_finite() && (0.5..=2.5).contains(&h))
    {
        return bad("height_m", "must be within 0.5..=2.5", h);
    }
    if !(spec.corner_radius_m.is_finite() && spec.corner_radius_m >= 0.0) {
        return bad(
            "corner_radius_m",
            "must be a non-negative number",
            spec.corner_radius_m,
        );
    }
    if !(spec.lowpass_hz.is_finite() && spec.lowpass_hz >= 0.0) {
        return bad(
            "lowpass_hz",
            "must be a non-negative number",
            spec.lowpass_hz,
        );
    }
    if !spec.heading_rad.is_finite() {
        return bad("heading_rad", "must be finite", spec.heading_rad);
    }
    if let Some([a, b]) = spec.clip_range_s
        && !(a.is_finite() && b.is_finite() && a >= 0.0 && b > a)
    {
        return bad("clip_range_s", "must be [from, to] with 0 <= from < to", a);
    }
    let finite_pair = |p: &[f64; 2]| p.iter().all(|v| v.is_finite());
    if let Some(p) = &spec.position
        && !finite_pair(p)
    {
        return bad("position", "must be finite", p[0]);
    }
    if let Some(f) = &spec.clip_frame
        && !(finite_pair(&f.offset_m) && f.yaw_rad.is_finite())
    {
        return bad("clip_frame", "must be finite", f.yaw_rad);
    }
    super::check_absent_spans(&spec.absent_s, f64::INFINITY)
        .map_err(|why| invalid(format!("motion of clip '{who}': {why}")))?;
    Ok(())
}

impl PersonMotion {
    /// Forward kinematics along the chain from the root to `joint` only, also returning the pose
    /// of the chain node `also` (an ancestor of `joint`) when asked.
    fn chain_at(
        &self,
        t_s: f64,
        joint: Joint,
        also: Option<usize>,
    ) -> (JointPose, Option<JointPose>) {
        let k = self.knot(t_s);
        let Some(chain) = self.chains.get(joint.index()) else {
            return (JointPose::default(), None);
        };
        let mut rot = UnitQuaternion::identity();
        let mut pos = Vector3::zeros();
        let mut root = Vector3::zeros();
        let mut captured = None;
        for &n in chain {
            let Some(node) = self.nodes.get(n) else {
                continue;
            };
            let local = self.local_at(n, &k);
            match node.parent {
                None => {
                    rot = local;
                    pos = self.root_at(&k);
                    root = pos;
                }
                Some(_) => {
                    // The chain lists ancestors in order, so the running pose is the parent's.
                    pos += rot * node.offset_m;
                    rot *= local;
                }
            }
            if also == Some(n) {
                captured = Some((pos, rot));
            }
        }
        let place = self.place_at(&root);
        (
            place.joint(&pos, &rot),
            captured.map(|(p, r)| place.joint(&p, &r)),
        )
    }
}

impl BodyMotion for PersonMotion {
    fn span_s(&self) -> (f64, f64) {
        self.span_s
    }

    fn is_present_at(&self, t_s: f64) -> bool {
        t_s >= self.span_s.0 && t_s <= self.span_s.1 && !super::is_in_spans(&self.absent_s, t_s)
    }

    fn pose_at(&self, t_s: f64) -> BodyPose {
        let k = self.knot(t_s);
        let mut rot = [UnitQuaternion::identity(); MAX_NODES];
        let mut pos = [Vector3::zeros(); MAX_NODES];
        for (n, node) in self.nodes.iter().enumerate() {
            let local = self.local_at(n, &k);
            match node.parent {
                None => {
                    rot[n] = local;
                    pos[n] = self.root_at(&k);
                }
                Some(p) => {
                    rot[n] = rot[p] * local;
                    pos[n] = pos[p] + rot[p] * node.offset_m;
                }
            }
        }
        let place = self.place_at(&pos[0]);
        let mut out = Joints::new();
        for j in Joint::ALL {
            let n = self.joint_node[j.index()];
            out.insert(j, place.joint(&pos[n], &rot[n]));
        }
        out
    }

    fn joint_at(&self, t_s: f64, joint: Joint) -> JointPose {
        self.chain_at(t_s, joint, None).0
    }

    fn joint_pair_at(&self, t_s: f64, a: Joint, b: Joint) -> (JointPose, JointPose) {
        let node_of = |j: Joint| self.chains.get(j.index()).and_then(|c| c.last().copied());
        let in_chain = |j: Joint, node: Option<usize>| {
            node.is_some_and(|n| self.chains.get(j.index()).is_some_and(|c| c.contains(&n)))
        };
        if in_chain(a, node_of(b)) {
            let (pa, pb) = self.chain_at(t_s, a, node_of(b));
            (pa, pb.unwrap_or_default())
        } else if in_chain(b, node_of(a)) {
            let (pb, pa) = self.chain_at(t_s, b, node_of(a));
            (pa.unwrap_or_default(), pb)
        } else {
            (self.joint_at(t_s, a), self.joint_at(t_s, b))
        }
    }
}
