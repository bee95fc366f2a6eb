//! A sans-IO reader for Acclaim motion files (`.amc`): text and its skeleton ([`Asf`]) in,
//! [`Bvh`] out, so that forward kinematics, joint mapping and conversion treat both formats
//! alike.
//!
//! Grammar accepted (lines starting with `#` are comments):
//!
//! ```text
//! :FULLY-SPECIFIED            (optional)
//! :DEGREES | :RADIANS         (optional; default: the ASF's angle unit)
//! <frame number>              (consecutive; CMU's start at 1)
//! <bone> <one value per dof, in the order of the bone's dof line (the root's: its order line)>
//! ...                         (every bone with dofs once per frame, in any order)
//! ```
//!
//! **The BVH it becomes.** One node per ASF bone, at the bone's *start*: `OFFSET` is the parent
//! bone's `direction · length` (zero for the root's children), and leaf bones get an End Site
//! (`<bone>_end`) at their own `direction · length`. Bones with dofs have the channels
//! `Zrotation Yrotation Xrotation`, whose values per frame are the Euler angles of the bone's
//! local rotation `C · M · C⁻¹` (see [`crate::asf`]); bones without dofs have none. The root is
//! the node `root` with `Xposition Yposition Zposition Zrotation Yrotation Xrotation`: the AMC
//! translation (the root's absolute position) and `C_root · M_root · C_root⁻¹`. BVH forward
//! kinematics `R_joint = R_parent · R_z · R_y · R_x` then gives the Acclaim `R_bone = R_parent ·
//! C · M · C⁻¹` exactly, and every bone ends at its start plus `R_bone · direction · length`.
//! AMC files carry no frame rate: `Frame Time` is set to CMU's 1/120 s
//! ([`CMU_FRAME_RATE_HZ`]; override it with [`crate::ConvertOptions::fps_hz`]).

use crate::asf::{AngleUnit, Asf, Dof, EulerAxes};
use crate::bvh::{Bvh, BvhNode, Channel, MAX_FRAME_VALUE, MAX_JOINT_POSES, parse_finite};
use crate::error::{MocapError, Result};
use nalgebra::{Rotation3, Vector3};
use std::collections::HashMap;

/// The rate CMU recorded its ASF/AMC takes at, Hz (AMC files do not state it).
pub const CMU_FRAME_RATE_HZ: f64 = 120.0;

/// Name of the root in AMC lines and of the root node of the BVH made from them.
const ROOT: &str = "root";

/// Channels of every bone with dofs: `local = R_z · R_y · R_x`.
const ROTATION_CHANNELS: [Channel; 3] =
    [Channel::Zrotation, Channel::Yrotation, Channel::Xrotation];

/// One thing an AMC line can give values to: the root (slot 0) or a bone (slot `1 + bone`).
struct Slot<'a> {
    name: &'a str,
    dofs: &'a [Dof],
    /// `C` and `C⁻¹` of the bone's axis (the root's orientation).
    c: Rotation3<f64>,
    c_inv: Rotation3<f64>,
    /// Node index of this slot in the BVH.
    node: usize,
    /// Index of the slot's first value in the frame's raw values.
    first_raw: usize,
}

/// Builds the BVH hierarchy of `asf`: the nodes, the number of channels and the node of each
/// slot (root first, then the bones in [`Asf::bones`] order).
fn hierarchy(asf: &Asf) -> (Vec<BvhNode>, usize, Vec<usize>) {
    let mut nodes = Vec::with_capacity(2 * asf.bones.len() + 1);
    nodes.push(BvhNode {
        name: ROOT.to_owned(),
        parent: None,
        offset: Vector3::zeros(),
        channels: vec![
            Channel::Xposition,
            Channel::Yposition,
            Channel::Zposition,
            Channel::Zrotation,
            Channel::Yrotation,
            Channel::Xrotation,
        ],
        first_channel: 0,
        is_end_site: false,
        line: asf.root.line,
    });
    let mut num_channels = 6;
    let mut has_child = vec![false; asf.bones.len()];
    for bone in &asf.bones {
        if let Some(flag) = bone.parent.and_then(|p| has_child.get_mut(p)) {
            *flag = true;
        }
    }
    let mut slot_node = Vec::with_capacity(asf.bones.len() + 1);
    slot_node.push(0);
    for (b, bone) in asf.bones.iter().enumerate() {
        // The parent's node and where this bone starts: the parent bone's end.
        let (parent_node, offset) =
            match bone.parent.and_then(|p| asf.bones.get(p).map(|pb| (p, pb))) {
                Some((p, parent)) => (slot_node.get(p + 1).copied().unwrap_or(0), parent.vector()),
                None => (0, Vector3::zeros()),
            };
        let channels = if bone.dofs.is_empty() {
            Vec::new()
        } else {
            ROTATION_CHANNELS.to_vec()
        };
        let node = nodes.len();
        slot_node.push(node);
        nodes.push(BvhNode {
            name: bone.name.clone(),
            parent: Some(parent_node),
            offset,
            first_channel: num_channels,
            is_end_site: false,
            line: bone.line,
            channels,
        });
        num_channels += if bone.dofs.is_empty() { 0 } else { 3 };
        if !has_child.get(b).copied().unwrap_or(false) {
            nodes.push(BvhNode {
                name: format!("{}_end", bone.name),
                parent: Some(node),
                offset: bone.vector(),
                channels: Vec::new(),
                first_channel: num_channels,
                is_end_site: true,
                line: bone.line,
            });
        }
    }
    (nodes, num_channels, slot_node)
}

/// The Euler angles `[z, y, x]` of `r`, degrees, with `r = R_z(z) · R_y(y) · R_x(x)` exactly
/// (to rounding) for every rotation, gimbal lock included: `z` is chosen first so that
/// `R_z(z)⁻¹ · r` has no `(1, 0)` element, and that matrix is `R_y(y) · R_x(x)`, whose
/// `y` and `x` are then read from one column and one row.
fn zyx_degrees(r: &Rotation3<f64>) -> [f64; 3] {
    let m = r.matrix();
    let z = m[(1, 0)].atan2(m[(0, 0)]);
    // R_y(y) · R_x(x) = [[cy, sy sx, sy cx], [0, cx, −sx], [−sy, cy sx, cy cx]].
    let yx = Rotation3::from_axis_angle(&Vector3::z_axis(), -z) * r;
    let m = yx.matrix();
    let y = (-m[(2, 0)]).atan2(m[(0, 0)]);
    let x = (-m[(1, 2)]).atan2(m[(1, 1)]);
    [z.to_degrees(), y.to_degrees(), x.to_degrees()]
}

/// `M`: the rotations of `dofs` with `values` (radians) applied in the order written, the first
/// first. Translation dofs do not rotate.
fn dof_rotation(dofs: &[Dof], values_rad: &[f64]) -> Rotation3<f64> {
    dofs.iter()
        .zip(values_rad)
        .fold(Rotation3::identity(), |m, (dof, &v)| match dof {
            Dof::Rotation(axis) => axis.rotation(v) * m,
            Dof::Translation(_) => m,
        })
}

/// Parses AMC text against its skeleton `asf` into a [`Bvh`] (file units, the ASF's axes,
/// degrees; see the module docs). `source` names the text in error messages.
pub fn parse_amc(text: &str, asf: &Asf, source: &str) -> Result<Bvh> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let (nodes, num_channels, slot_node) = hierarchy(asf);
    let rotation = |axes: &EulerAxes| {
        let c = axes.rotation();
        (c, c.inverse())
    };
    let mut slots = Vec::with_capacity(asf.bones.len() + 1);
    let (c, c_inv) = rotation(&asf.root.orientation);
    slots.push(Slot {
        name: ROOT,
        dofs: &asf.root.order,
        c,
        c_inv,
        node: 0,
        first_raw: 0,
    });
    let mut num_raw = asf.root.order.len();
    for (b, bone) in asf.bones.iter().enumerate() {
        let (c, c_inv) = rotation(&bone.axis);
        slots.push(Slot {
            name: &bone.name,
            dofs: &bone.dofs,
            c,
            c_inv,
            node: slot_node.get(b + 1).copied().unwrap_or(0),
            first_raw: num_raw,
        });
        num_raw += bone.dofs.len();
    }
    let slot_of: HashMap<&str, usize> =
        slots.iter().enumerate().map(|(i, s)| (s.name, i)).collect();

    let mut reader = FrameReader {
        file: source,
        nodes: &nodes,
        slots: &slots,
        num_channels,
        angle_unit: asf.angle_unit,
        raw: vec![0.0; num_raw],
        seen: vec![0; slots.len()],
        frame_values: vec![0.0; num_channels],
        values: Vec::new(),
        num_frames: 0,
    };
    // (frame number, its line) of the frame being read.
    let mut current: Option<(u64, usize)> = None;
    let mut last_line = 1;
    let mut is_recognised = false;
    for (i, raw_line) in text.lines().enumerate() {
        let line = i + 1;
        last_line = line;
        let l = raw_line.trim();
        if l.is_empty() || l.starts_with('#') {
            continue;
        }
        // Until a header keyword or a frame number shows this to be an AMC file, its lines are
        // not quoted in errors.
        let not_amc = || MocapError::NotOfKind {
            file: source.to_owned(),
            line,
            kind: "an AMC file",
            expected: "':FULLY-SPECIFIED', ':DEGREES', ':RADIANS' or a frame number",
        };
        if let Some(keyword) = l.strip_prefix(':') {
            if current.is_some() {
                return Err(unexpected(source, line, "a frame number or bone values", l));
            }
            match keyword.trim().to_ascii_uppercase().as_str() {
                "FULLY-SPECIFIED" => {}
                "DEGREES" => reader.angle_unit = AngleUnit::Degrees,
                "RADIANS" => reader.angle_unit = AngleUnit::Radians,
                _ if !is_recognised => return Err(not_amc()),
                _ => {
                    return Err(unexpected(
                        source,
                        line,
                        "':FULLY-SPECIFIED', ':DEGREES' or ':RADIANS'",
                        l,
                    ));
                }
            }
            is_recognised = true;
            continue;
        }
        let mut toks = l.split_whitespace();
        let first = toks.next().unwrap_or("");
        if first.bytes().all(|c| c.is_ascii_digit()) && toks.next().is_none() {
            let number: u64 = first.parse().map_err(|_| MocapError::NotANumber {
                file: source.to_owned(),
                line,
                what: "frame number".to_owned(),
                token: first.to_owned(),
            })?;
            if let Some((previous, frame_line)) = current {
                let expected = previous.saturating_add(1);
                if number != expected {
                    return Err(MocapError::FrameOrder {
                        file: source.to_owned(),
                        line,
                        expected,
                        found: number,
                    });
                }
                reader.end_frame(previous, frame_line, line)?;
            }
            if (reader.num_frames + 1).saturating_mul(nodes.len()) > MAX_JOINT_POSES {
                return Err(MocapError::TooLarge {
                    file: source.to_owned(),
                    line,
                    num_nodes: nodes.len(),
                    max: MAX_JOINT_POSES,
                });
            }
            current = Some((number, line));
            is_recognised = true;
            continue;
        }
        if current.is_none() {
            if !is_recognised {
                return Err(not_amc());
            }
            return Err(unexpected(source, line, "a frame number", l));
        }
        let Some(&slot) = slot_of.get(first) else {
            return Err(MocapError::UnknownBone {
                file: source.to_owned(),
                line,
                name: first.to_owned(),
            });
        };
        reader.bone_line(slot, l, line)?;
    }
    let Some((number, frame_line)) = current else {
        return Err(MocapError::UnexpectedEof {
            file: source.to_owned(),
            line: last_line,
            expected: "a frame number".to_owned(),
        });
    };
    reader.end_frame(number, frame_line, last_line)?;
    Ok(Bvh {
        source: source.to_owned(),
        num_channels,
        frame_time_s: 1.0 / CMU_FRAME_RATE_HZ,
        num_frames: reader.num_frames,
        values: reader.values,
        nodes,
    })
}

fn unexpected(file: &str, line: usize, expected: &str, found: &str) -> MocapError {
    MocapError::Unexpected {
        file: file.to_owned(),
        line,
        expected: expected.to_owned(),
        found: found.to_owned(),
    }
}

/// The frame being read and the values of those done.
struct FrameReader<'a> {
    file: &'a str,
    nodes: &'a [BvhNode],
    slots: &'a [Slot<'a>],
    num_channels: usize,
    angle_unit: AngleUnit,
    /// Values of the current frame as written, per slot from `Slot::first_raw`.
    raw: Vec<f64>,
    /// Line of each slot's values in the current frame; 0: none yet.
    seen: Vec<usize>,
    /// The BVH channel values of one frame.
    frame_values: Vec<f64>,
    values: Vec<f64>,
    num_frames: usize,
}

impl FrameReader<'_> {
    fn bone_line(&mut self, slot: usize, l: &str, line: usize) -> Result<()> {
        let Some(s) = self.slots.get(slot) else {
            return Ok(());
        };
        if let Some(&first_line) = self.seen.get(slot).filter(|&&f| f != 0) {
            return Err(MocapError::DuplicateBone {
                file: self.file.to_owned(),
                line,
                name: s.name.to_owned(),
                first_line,
            });
        }
        let toks: Vec<&str> = l.split_whitespace().skip(1).collect();
        if toks.len() != s.dofs.len() {
            return Err(MocapError::DofValueCount {
                file: self.file.to_owned(),
                line,
                bone: s.name.to_owned(),
                expected: s.dofs.len(),
                found: toks.len(),
                dofs: if s.dofs.is_empty() {
                    "none".to_owned()
                } else {
                    s.dofs
                        .iter()
                        .map(|d| d.name())
                        .collect::<Vec<_>>()
                        .join(" ")
                },
            });
        }
        for (k, (tok, dof)) in toks.iter().zip(s.dofs).enumerate() {
            let what = || format!("{} {}", s.name, dof.name());
            let value = parse_finite(tok, self.file, line, &what())?;
            if value.abs() > MAX_FRAME_VALUE {
                return Err(MocapError::Implausible {
                    file: self.file.to_owned(),
                    line,
                    what: what(),
                    token: (*tok).to_owned(),
                    max: MAX_FRAME_VALUE,
                });
            }
            if let Some(slot_value) = self.raw.get_mut(s.first_raw + k) {
                *slot_value = match dof {
                    Dof::Rotation(_) => self.angle_unit.to_radians(value),
                    Dof::Translation(_) => value,
                };
            }
        }
        if let Some(seen) = self.seen.get_mut(slot) {
            *seen = line;
        }
        Ok(())
    }

    /// Checks that frame `number` (from `frame_line`) has every slot with dofs, turns it into
    /// BVH channel values and starts the next; `line` is where the frame ends.
    fn end_frame(&mut self, number: u64, frame_line: usize, line: usize) -> Result<()> {
        let missing: Vec<&str> = self
            .slots
            .iter()
            .zip(&self.seen)
            .filter(|(s, seen)| !s.dofs.is_empty() && **seen == 0)
            .map(|(s, _)| s.name)
            .collect();
        if !missing.is_empty() {
            return Err(MocapError::IncompleteFrame {
                file: self.file.to_owned(),
                line,
                frame: number,
                frame_line,
                missing: missing.join(", "),
            });
        }
        self.frame_values.fill(0.0);
        for s in self.slots {
            if s.dofs.is_empty() {
                continue;
            }
            let raw = self
                .raw
                .get(s.first_raw..s.first_raw + s.dofs.len())
                .unwrap_or(&[]);
            let local = s.c * dof_rotation(s.dofs, raw) * s.c_inv;
            let Some(node) = self.nodes.get(s.node) else {
                continue;
            };
            let mut write = |k: usize, v: f64| {
                if let Some(slot) = self.frame_values.get_mut(node.first_channel + k) {
                    *slot = v;
                }
            };
            let mut k = 0;
            if s.node == 0 {
                // The root: translation first, as the AMC wrote it (absolute position).
                for (dof, &v) in s.dofs.iter().zip(raw) {
                    if let Dof::Translation(axis) = dof {
                        write(axis.index(), v);
                    }
                }
                k = 3;
            }
            for (j, angle) in zyx_degrees(&local).into_iter().enumerate() {
                write(k + j, angle);
            }
        }
        self.values.extend_from_slice(&self.frame_values);
        debug_assert_eq!(self.frame_values.len(), self.num_channels);
        self.seen.fill(0);
        self.num_frames += 1;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::asf::{Axis, parse_asf};

    const LEG_ASF: &str = ":units
  length 1
  angle deg
:root
  order TX TY TZ RX RY RZ
  axis XYZ
  position 0 0 0
  orientation 0 0 0
:bonedata
  begin
    name hipjoint
    direction 1 0 0
    length 1
  end
  begin
    name thigh
    direction 0 -1 0
    length 4
    axis 0 0 20 XYZ
    dof rx ry rz
  end
  begin
    name shin
    direction 0 -1 0
    length 4
    axis 0 0 20 XYZ
    dof rx
  end
:hierarchy
  begin
    root hipjoint
    hipjoint thigh
    thigh shin
  end
";

    /// Lines: 1–2 header, 3 frame 1, 4 root, 5 thigh, 6 shin, 7 frame 2, 8 root, 9 shin,
    /// 10 thigh.
    const WALK_AMC: &str = ":FULLY-SPECIFIED
:DEGREES
1
root 1 2 3 0 0 0
thigh 10 20 30
shin 45
2
root 1 2 3.5 0 90 0
shin 0
thigh 0 0 0
";

    fn leg() -> Asf {
        parse_asf(LEG_ASF, "leg.asf").unwrap()
    }

    fn err(amc: &str) -> String {
        parse_amc(amc, &leg(), "t.amc").unwrap_err().to_string()
    }

    fn without_line(text: &str, line: usize) -> String {
        text.lines()
            .enumerate()
            .filter(|(i, _)| i + 1 != line)
            .map(|(_, l)| format!("{l}\n"))
            .collect()
    }

    #[test]
    fn one_node_per_bone_at_its_start_with_end_sites_on_leaves() {
        let bvh = parse_amc(WALK_AMC, &leg(), "t.amc").unwrap();
        let names: Vec<&str> = bvh.nodes.iter().map(|n| n.name.as_str()).collect();
        assert_eq!(names, ["root", "hipjoint", "thigh", "shin", "shin_end"]);
        // Each node starts where its parent bone ends.
        let offsets: Vec<Vector3<f64>> = bvh.nodes.iter().map(|n| n.offset).collect();
        assert_eq!(
            offsets,
            [
                Vector3::zeros(),
                Vector3::zeros(),
                Vector3::new(1.0, 0.0, 0.0),
                Vector3::new(0.0, -4.0, 0.0),
                Vector3::new(0.0, -4.0, 0.0),
            ]
        );
        let channels: Vec<usize> = bvh.nodes.iter().map(|n| n.channels.len()).collect();
        assert_eq!(channels, [6, 0, 3, 3, 0]);
        assert_eq!(bvh.num_channels, 12);
        assert_eq!(bvh.num_frames, 2);
        assert!((bvh.header_rate_hz() - 120.0).abs() < 1e-9);
    }

    #[test]
    fn channel_values_rebuild_c_m_c_inverse_and_keep_the_root_translation() {
        let bvh = parse_amc(WALK_AMC, &leg(), "t.amc").unwrap();
        let f0 = bvh.frame(0).unwrap();
        assert_eq!(&f0[..3], &[1.0, 2.0, 3.0]);
        // thigh: C = R_z(20°), M = R_z(30°) · R_y(20°) · R_x(10°).
        let c = Axis::Z.rotation(20f64.to_radians());
        let m = Axis::Z.rotation(30f64.to_radians())
            * Axis::Y.rotation(20f64.to_radians())
            * Axis::X.rotation(10f64.to_radians());
        let want = c * m * c.inverse();
        let thigh = &f0[6..9];
        let got = reconstruct([thigh[0], thigh[1], thigh[2]]);
        assert!((got.matrix() - want.matrix()).abs().max() < 1e-14);
        // Frame 2: the root turned 90° about Y, every bone at its axis (zero dofs).
        let f1 = bvh.frame(1).unwrap();
        assert_eq!(&f1[..3], &[1.0, 2.0, 3.5]);
        assert!((f1[4] - 90.0).abs() < 1e-12 && f1[3].abs() < 1e-12 && f1[5].abs() < 1e-12);
        assert!(f1[6..].iter().all(|v| v.abs() < 1e-12), "{f1:?}");
    }

    #[test]
    fn radians_read_like_degrees() {
        let radians = WALK_AMC
            .replace(":DEGREES", ":RADIANS")
            .replace(
                "thigh 10 20 30",
                &format!(
                    "thigh {} {} {}",
                    10f64.to_radians(),
                    20f64.to_radians(),
                    30f64.to_radians()
                ),
            )
            .replace("shin 45", &format!("shin {}", 45f64.to_radians()))
            .replace("0 90 0", &format!("0 {} 0", 90f64.to_radians()));
        let a = parse_amc(&radians, &leg(), "t.amc").unwrap();
        let b = parse_amc(WALK_AMC, &leg(), "t.amc").unwrap();
        for (x, y) in a.values.iter().zip(&b.values) {
            assert!((x - y).abs() < 1e-9, "{x} vs {y}");
        }
    }

    #[test]
    fn unknown_bones_and_wrong_value_counts_name_the_line() {
        assert_eq!(
            err(&WALK_AMC.replace("shin 45", "calf 45")),
            "t.amc:6: unknown bone 'calf' (not defined in the skeleton's :bonedata)"
        );
        assert_eq!(
            err(&WALK_AMC.replace("shin 45", "shin 45 1")),
            "t.amc:6: bone 'shin' has 2 values, expected 1 (dof: rx)"
        );
        assert_eq!(
            err(&WALK_AMC.replace("thigh 10 20 30", "thigh 10 20")),
            "t.amc:5: bone 'thigh' has 2 values, expected 3 (dof: rx ry rz)"
        );
        assert_eq!(
            err(&WALK_AMC.replace("shin 45", "shin 45\nhipjoint 5")),
            "t.amc:7: bone 'hipjoint' has 1 values, expected 0 (dof: none)"
        );
    }

    #[test]
    fn non_finite_and_absurd_values_are_rejected() {
        assert_eq!(
            err(&WALK_AMC.replace("thigh 10 20 30", "thigh 10 NaN 30")),
            "t.amc:5: thigh ry is NaN, expected a finite number"
        );
        assert_eq!(
            err(&WALK_AMC.replace("root 1 2 3 0", "root 1 inf 3 0")),
            "t.amc:4: root ty is inf, expected a finite number"
        );
        assert_eq!(
            err(&WALK_AMC.replace("thigh 10 20 30", "thigh 10 2x 30")),
            "t.amc:5: thigh ry '2x' is not a number"
        );
        assert_eq!(
            err(&WALK_AMC.replace("shin 45", "shin 1e300")),
            "t.amc:6: shin rx is 1e300, beyond any motion capture (at most 100000 in size)"
        );
    }

    #[test]
    fn frames_must_follow_each_other_and_be_complete() {
        assert_eq!(
            err(&WALK_AMC.replace("\n2\n", "\n3\n")),
            "t.amc:7: frame number 3 out of order, expected 2"
        );
        assert_eq!(
            err(&WALK_AMC.replace("shin 45", "shin 45\nshin 1")),
            "t.amc:7: bone 'shin' appears twice (first at line 6)"
        );
        assert_eq!(
            err(&without_line(WALK_AMC, 6)),
            "t.amc:6: frame 1 (from line 3) ends without values for shin"
        );
        // Cut inside the last frame.
        assert_eq!(
            err(&without_line(WALK_AMC, 10)),
            "t.amc:9: frame 2 (from line 7) ends without values for thigh"
        );
        assert_eq!(
            err(&without_line(WALK_AMC, 3)),
            "t.amc:3: expected a frame number, found 'root 1 2 3 0 0 0'"
        );
        assert_eq!(
            err(":FULLY-SPECIFIED\n:DEGREES\n"),
            "t.amc:2: unexpected end of file, expected a frame number"
        );
        assert_eq!(
            err(&WALK_AMC.replace("\n2\n", "\n:RADIANS\n")),
            "t.amc:7: expected a frame number or bone values, found ':RADIANS'"
        );
        assert_eq!(
            err(&WALK_AMC.replace(":DEGREES", ":GRADIANS")),
            "t.amc:2: expected ':FULLY-SPECIFIED', ':DEGREES' or ':RADIANS', found ':GRADIANS'"
        );
        assert_eq!(
            err(&WALK_AMC.replace("\n1\n", "\n99999999999999999999999\n")),
            "t.amc:3: frame number '99999999999999999999999' is not a number"
        );
    }

    #[test]
    fn a_motion_past_the_joint_pose_limit_is_refused_at_the_frame_that_passes_it() {
        // 1,000 bones without dofs hanging from a root without dofs: 2,001 nodes with their
        // end sites, and frames of a bare number each (a 50-kB file).
        let mut asf = String::from(":root\n  order\n:bonedata\n");
        for k in 0..1_000 {
            asf.push_str(&format!(
                "begin\nname b{k}\ndirection 0 1 0\nlength 1\nend\n"
            ));
        }
        asf.push_str(":hierarchy\nbegin\nroot");
        for k in 0..1_000 {
            asf.push_str(&format!(" b{k}"));
        }
        asf.push_str("\nend\n");
        let asf = parse_asf(&asf, "wide.asf").unwrap();
        let amc: String = (1..=9_000).map(|f| format!("{f}\n")).collect();
        let first_past = MAX_JOINT_POSES / 2_001 + 1;
        assert_eq!(
            parse_amc(&amc, &asf, "t.amc").unwrap_err().to_string(),
            format!(
                "t.amc:{first_past}: too large: 2001 joints and end sites, with this frame more than {MAX_JOINT_POSES} joint poses"
            )
        );
        let fewer: String = (1..first_past).map(|f| format!("{f}\n")).collect();
        assert_eq!(
            parse_amc(&fewer, &asf, "t.amc").unwrap().num_frames,
            first_past - 1
        );
    }

    fn reconstruct(zyx: [f64; 3]) -> Rotation3<f64> {
        Axis::Z.rotation(zyx[0].to_radians())
            * Axis::Y.rotation(zyx[1].to_radians())
            * Axis::X.rotation(zyx[2].to_radians())
    }

    #[test]
    fn euler_decomposition_rebuilds_every_rotation_including_gimbal_lock() {
        // A grid of rotations, with pitches at and within 1e-9 rad of ±90°.
        let pitches = [
            -90.0,
            -89.999_999_9,
            -60.0,
            -1.0,
            0.0,
            1e-9,
            45.0,
            89.999_999_9,
            90.0,
        ];
        let mut worst: f64 = 0.0;
        for &y in &pitches {
            for z in (-180..=180).step_by(30) {
                for x in (-180..=180).step_by(30) {
                    let r = reconstruct([f64::from(z), y, f64::from(x)]);
                    let back = reconstruct(zyx_degrees(&r));
                    worst = worst.max((back.matrix() - r.matrix()).abs().max());
                }
            }
        }
        assert!(worst < 1e-14, "largest element error {worst:e}");
    }

    #[test]
    fn dofs_compose_first_written_first_applied() {
        // rx 90 then rz 90: +Y → +Z (about X) → +Z (about Z leaves it).
        let m = dof_rotation(
            &[Dof::Rotation(Axis::X), Dof::Rotation(Axis::Z)],
            &[90f64.to_radians(), 90f64.to_radians()],
        );
        let v = m * Vector3::y();
        assert!((v - Vector3::z()).norm() < 1e-15, "{v:?}");
        // rz 90 then rx 90: +Y → −X (about Z) → −X (about X leaves it).
        let m = dof_rotation(
            &[Dof::Rotation(Axis::Z), Dof::Rotation(Axis::X)],
            &[90f64.to_radians(), 90f64.to_radians()],
        );
        let v = m * Vector3::y();
        assert!((v + Vector3::x()).norm() < 1e-15, "{v:?}");
    }

    #[test]
    fn a_file_that_is_not_amc_is_refused_without_its_content() {
        let asf = leg();
        for text in [
            "#!/bin/sh\nroot:x:0:0:secret-token:/root:/bin/bash\n",
            ":secret-token\n1\n",
        ] {
            let err = parse_amc(text, &asf, "passwd").unwrap_err().to_string();
            assert!(err.contains("not an AMC file: expected"), "{err}");
            assert!(!err.contains("secret-token"), "{err}");
        }
        // Once a header keyword showed an AMC file, a bad line is quoted.
        let err = parse_amc(":DEGREES\nbad line\n", &asf, "walk.amc")
            .unwrap_err()
            .to_string();
        assert_eq!(err, "walk.amc:2: expected a frame number, found 'bad line'");
    }
}
