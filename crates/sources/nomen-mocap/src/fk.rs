//! Exact forward kinematics of a [`Bvh`] frame, converted once from BVH's Y-up axes to nomen's
//! Z-up world.
//!
//! In the file's own axes (Y up), for every node in file order:
//!
//! ```text
//! R_joint = R_parent · R_ch1 · R_ch2 · R_ch3        (rotation channels in the order written)
//! p_joint = p_parent + R_parent · s · (OFFSET_joint + t_joint)
//! ```
//!
//! with angles in degrees converted to radians, `s` the unit scale to metres, `t_joint` the
//! joint's position channels (usually only the root has them; they add to `OFFSET`, which is
//! zero for the root in every file we know) and `R_parent = I`, `p_parent = 0` for the root.
//! Translation channels act in the parent frame whatever their place in the channel list.
//!
//! Then, once, with `C = z_up_from_y_up()` (+90° about X, see `nomen_core::frame`):
//! `position_m = C · p_joint` and `world_from_joint = C · R_joint`.
//!
//! **What `world_from_joint` means.** It takes a vector expressed in the joint's *own BVH frame*
//! (the frame its children's `OFFSET`s are written in; at the rest pose its +Y axis points up)
//! into the Z-up world. So `child − joint = world_from_joint · (s · OFFSET_child)`, with the
//! offset as written in the file (not axis-converted). At the rest pose (all channels zero) every
//! joint has `world_from_joint = C`. A sensor rigidly mounted on the segment that starts at this
//! joint, with mounting rotation `joint_from_sensor` (in the BVH joint frame), has orientation
//! `world_from_joint · joint_from_sensor`.

use crate::bvh::Bvh;
use nalgebra::{Point3, UnitQuaternion, Vector3};
use nomen_core::frame::z_up_from_y_up;

/// Pose of one node (joint or End Site) in the Z-up world.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointPose {
    /// Position in the world, metres, Z up.
    pub position_m: Point3<f64>,
    /// Rotation from the joint's own BVH frame to the Z-up world (see the module docs). An End
    /// Site has its parent's rotation.
    pub world_from_joint: UnitQuaternion<f64>,
}

impl Default for JointPose {
    fn default() -> Self {
        Self {
            position_m: Point3::origin(),
            world_from_joint: UnitQuaternion::identity(),
        }
    }
}

/// Computes the world pose of every node of `bvh` for the channel values `frame_values` (one
/// frame, [`Bvh::num_channels`] values), with lengths multiplied by `scale`.
///
/// `out` is resized to `bvh.nodes.len()` and filled in node order; pass the same buffer every
/// frame to avoid allocating.
pub fn forward_kinematics(bvh: &Bvh, frame_values: &[f64], scale: f64, out: &mut Vec<JointPose>) {
    let z_up_from_y_up = z_up_from_y_up();
    out.clear();
    // Y-up poses first (parents precede children), converted in a second pass.
    for node in &bvh.nodes {
        let mut translation = node.offset;
        let mut local = UnitQuaternion::identity();
        for (k, ch) in node.channels.iter().enumerate() {
            let v = frame_values
                .get(node.first_channel + k)
                .copied()
                .unwrap_or(0.0);
            if ch.is_rotation() {
                let axis = match ch.axis() {
                    0 => Vector3::x_axis(),
                    1 => Vector3::y_axis(),
                    _ => Vector3::z_axis(),
                };
                local *= UnitQuaternion::from_axis_angle(&axis, v.to_radians());
            } else {
                translation[ch.axis()] += v;
            }
        }
        let (p_parent, r_parent) = match node.parent.and_then(|i| out.get(i)) {
            Some(parent) => (parent.position_m, parent.world_from_joint),
            None => (Point3::origin(), UnitQuaternion::identity()),
        };
        out.push(JointPose {
            position_m: p_parent + r_parent * (translation * scale),
            world_from_joint: r_parent * local,
        });
    }
    for pose in out.iter_mut() {
        // BVH is Y up; nomen's world is Z up. The one axis change, at ingest.
        pose.position_m = z_up_from_y_up * pose.position_m;
        pose.world_from_joint = z_up_from_y_up * pose.world_from_joint;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::parse_bvh;
    use approx::assert_relative_eq;

    const ARM: &str = "HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation
  JOINT Arm
  {
    OFFSET 1 0 0
    CHANNELS 3 Zrotation Yrotation Xrotation
    End Site
    {
      OFFSET 2 0 0
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.5
10 20 30 0 0 0 0 0 0
10 20 30 90 0 0 0 90 0
";

    #[test]
    fn rest_pose_lies_along_the_offsets_with_y_up_turned_to_z_up() {
        let bvh = parse_bvh(ARM, "arm.bvh").unwrap();
        let mut out = Vec::new();
        forward_kinematics(&bvh, bvh.frame(0).unwrap(), 0.1, &mut out);
        // Root at (1, 2, 3) in Y-up file axes → (1, -3, 2) in Z-up.
        assert_relative_eq!(
            out[0].position_m,
            Point3::new(1.0, -3.0, 2.0),
            epsilon = 1e-12
        );
        assert_relative_eq!(
            out[2].position_m,
            Point3::new(1.3, -3.0, 2.0),
            epsilon = 1e-12
        );
        assert_relative_eq!(out[1].world_from_joint, z_up_from_y_up(), epsilon = 1e-12);
    }

    #[test]
    fn rotations_compose_parent_first_in_channel_order() {
        let bvh = parse_bvh(ARM, "arm.bvh").unwrap();
        let mut out = Vec::new();
        forward_kinematics(&bvh, bvh.frame(1).unwrap(), 1.0, &mut out);
        // Root turned 90° about Y-up's Z: the arm (offset +X) points along file +Y = world +Z.
        let root = out[0].position_m;
        assert_relative_eq!(
            out[1].position_m - root,
            Vector3::new(0.0, 0.0, 1.0),
            epsilon = 1e-12
        );
        // Arm then turns 90° about its own Y: its +X goes to its −Z, which the root's Z turn
        // leaves as file −Z = world +Y.
        assert_relative_eq!(
            out[2].position_m - out[1].position_m,
            Vector3::new(0.0, 2.0, 0.0),
            epsilon = 1e-12
        );
        // Child offset through world_from_joint gives the same vector.
        let v = out[1].world_from_joint * Vector3::new(2.0, 0.0, 0.0);
        assert_relative_eq!(v, out[2].position_m - out[1].position_m, epsilon = 1e-12);
    }
}
