//! Which BVH node stands for each canonical [`Joint`], for the naming variants found in the wild.
//!
//! Decided by anatomy on the CMU files in `shared/data/mocap/cmu` (offsets in the rest pose):
//!
//! - **Pelvis** is the root (`Hips`/`hip`): the pelvis segment's origin and rotation. In CMU
//!   skeletons it sits about 10 cm above the hip-joint midpoint, in Poser/MakeHuman ones about
//!   3 cm below it.
//! - **Shoulder** is the glenohumeral joint: the joint whose child is the elbow at upper-arm
//!   length (`LeftArm`, CMU-131 `LeftShoulder`, `lShldr`, `lshoulder`), never the clavicle joint
//!   (`LeftShoulder` in cgspeed files has offset 0 from `Spine1`; `LeftCollar`, `lCollar`,
//!   `lcollar` sit at the sternum).
//! - **Wrist** is the joint at the end of the forearm (`LeftHand`, `LeftWrist`, `lHand`, `lhand`).
//! - **Hand** has no palm joint in these skeletons. cgspeed `LeftFingerBase` and CMU-131 `lhand`
//!   have offset 0 from the wrist, so the first joint beyond the wrist is used: `LeftHandIndex1`
//!   (about 4 cm; `LFingers` in 01_01 and the 131 files); in the Poser and MakeHuman skeletons, which model
//!   every finger, the middle finger's knuckle: `lMid1` (about 9 cm), `finger3-1.l` (about 9 cm).
//! - **Chest** is the upper thorax joint the clavicles hang from: `Spine1`, `Chest2`, `chest`.
//! - **Neck**: cgspeed `Neck` and CMU-131 `lowerneck` have offset 0 from the chest joint, so the
//!   next joint up is used (`Neck1`, `Neck`); Poser and MakeHuman `neck` sit at the base of the neck.
//! - **Head** is the `Head`/`head` joint (the base of the skull; the top of the head is its End
//!   Site).
//! - **Hip** is the femoral head: `LeftUpLeg`, `LeftHip`, `lThigh`, `lhip` (not the `LHipJoint`
//!   at the root or the `lButtock`/`lbuttock` above it).
//! - **Knee**, **ankle**: `LeftLeg`/`LeftKnee`/`lShin`/`lknee`, `LeftFoot`/`LeftAnkle`/`lFoot`/`lfoot`.
//! - **Foot** is the ball of the foot: `LeftToeBase`, `LeftToe`; the Poser foot has no toe joint,
//!   so its End Site (`lFoot_end`, about 10 cm forward of the ankle) is used; MakeHuman's
//!   second-toe base `toe2-1.l` lies on the foot's long axis.
//!
//! **CMU's ASF skeletons** ([`SkeletonVariant::CmuAsf`], `shared/data/mocap/cmu-asfamc`): a node
//! per bone sits at the bone's *start* (see [`crate::amc`]), so each joint is named after the
//! bone that begins there. Lengths below are subject 02's at 0.0564444 m per unit.
//!
//! - **Pelvis** is `root`, about 10 cm above the hip-joint midpoint (`lhipjoint` runs 14 cm down
//!   and out to the femoral head).
//! - **Chest** is where the clavicles hang from: the end of `thorax`, which is the start of
//!   `lowerneck`, `lclavicle` and `rclavicle` (one point; `lowerneck` is used, so the chest's
//!   `world_from_joint` turns with the lower neck). It lies about 35 cm above the root after
//!   `lowerback`, `upperback` and `thorax` (11.6–11.7 cm each).
//! - **Neck** is `upperneck` (the end of `lowerneck`, 8.9 cm up the neck), **head** is `head`
//!   (the end of `upperneck`, 8.8 cm higher: the base of the skull; `head_end` is 9.2 cm above).
//! - **Shoulder** is `lhumerus`, the end of the 20.7-cm `lclavicle` (the glenohumeral joint);
//!   **elbow** `lradius`, 27.5 cm further (the humerus); **wrist** `lwrist`, the end of the
//!   19-cm `lradius`. The `lwrist` bone (9.5 cm) spans the palm, so the first joints beyond the
//!   wrist with a non-zero offset are the two at its end, `lhand` and `lthumb`: **hand** is
//!   `lhand`, the knuckles (like Poser's `lMid1`); `lfingers` starts 3.7 cm further.
//! - **Hip** is `lfemur` (the femoral head, the end of `lhipjoint`), **knee** `ltibia` (42.9 cm
//!   down the femur), **ankle** `lfoot` (41.1 cm down the tibia), **foot** `ltoes`, the ball of
//!   the foot, 12.5 cm forward of the ankle (`ltoes` ends 6.3 cm further, at the toe tip).

use crate::bvh::Bvh;
use crate::error::{MocapError, Result};
use nomen_core::Joint;
use nomen_core::skeleton::{Joints, NUM_JOINTS};

/// A BVH joint-naming convention.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SkeletonVariant {
    /// CMU as converted by cgspeed (and Mixamo-like names): `Hips`, `LeftUpLeg`, `LeftForeArm`.
    Cgspeed,
    /// The CMU subject-131 files: `LeftHip`, `LeftElbow`, `LeftWrist`, `lhand`.
    Cmu131,
    /// Poser-style: `hip`, `abdomen`, `lShldr`, `lForeArm`, `lThigh`, `lShin`.
    Poser,
    /// MakeHuman's CMU-MB rig (164 joints): `hip`, `lshoulder`, `lelbow`, `lhip`, `toe2-1.l`.
    MakeHuman,
    /// CMU's ASF bone names, read with [`crate::parse_amc`]: `root`, `lhumerus`, `lradius`,
    /// `lfemur`, `ltibia`.
    CmuAsf,
}

use Joint::*;

/// `(canonical joint, BVH node names in order of preference)`; names are matched exactly first,
/// then ignoring ASCII case.
type Table = [(Joint, &'static [&'static str]); NUM_JOINTS];

const CGSPEED: Table = [
    (Pelvis, &["Hips"]),
    (Chest, &["Spine1"]),
    (Neck, &["Neck1"]),
    (Head, &["Head"]),
    (LeftShoulder, &["LeftArm"]),
    (LeftElbow, &["LeftForeArm"]),
    (LeftWrist, &["LeftHand"]),
    (LeftHand, &["LeftHandIndex1", "LFingers"]),
    (RightShoulder, &["RightArm"]),
    (RightElbow, &["RightForeArm"]),
    (RightWrist, &["RightHand"]),
    (RightHand, &["RightHandIndex1", "RFingers"]),
    (LeftHip, &["LeftUpLeg"]),
    (LeftKnee, &["LeftLeg"]),
    (LeftAnkle, &["LeftFoot"]),
    (LeftFoot, &["LeftToeBase"]),
    (RightHip, &["RightUpLeg"]),
    (RightKnee, &["RightLeg"]),
    (RightAnkle, &["RightFoot"]),
    (RightFoot, &["RightToeBase"]),
];

const CMU_131: Table = [
    (Pelvis, &["Hips"]),
    (Chest, &["Chest2"]),
    (Neck, &["Neck"]),
    (Head, &["Head"]),
    (LeftShoulder, &["LeftShoulder"]),
    (LeftElbow, &["LeftElbow"]),
    (LeftWrist, &["LeftWrist"]),
    (LeftHand, &["LFingers"]),
    (RightShoulder, &["RightShoulder"]),
    (RightElbow, &["RightElbow"]),
    (RightWrist, &["RightWrist"]),
    (RightHand, &["RFingers"]),
    (LeftHip, &["LeftHip"]),
    (LeftKnee, &["LeftKnee"]),
    (LeftAnkle, &["LeftAnkle"]),
    (LeftFoot, &["LeftToe"]),
    (RightHip, &["RightHip"]),
    (RightKnee, &["RightKnee"]),
    (RightAnkle, &["RightAnkle"]),
    (RightFoot, &["RightToe"]),
];

const POSER: Table = [
    (Pelvis, &["hip"]),
    (Chest, &["chest"]),
    (Neck, &["neck"]),
    (Head, &["head"]),
    (LeftShoulder, &["lShldr"]),
    (LeftElbow, &["lForeArm"]),
    (LeftWrist, &["lHand"]),
    (LeftHand, &["lMid1"]),
    (RightShoulder, &["rShldr"]),
    (RightElbow, &["rForeArm"]),
    (RightWrist, &["rHand"]),
    (RightHand, &["rMid1"]),
    (LeftHip, &["lThigh"]),
    (LeftKnee, &["lShin"]),
    (LeftAnkle, &["lFoot"]),
    (LeftFoot, &["lFoot_end"]),
    (RightHip, &["rThigh"]),
    (RightKnee, &["rShin"]),
    (RightAnkle, &["rFoot"]),
    (RightFoot, &["rFoot_end"]),
];

const MAKEHUMAN: Table = [
    (Pelvis, &["hip"]),
    (Chest, &["chest"]),
    (Neck, &["neck"]),
    (Head, &["head"]),
    (LeftShoulder, &["lshoulder"]),
    (LeftElbow, &["lelbow"]),
    (LeftWrist, &["lhand"]),
    (LeftHand, &["finger3-1.l"]),
    (RightShoulder, &["rshoulder"]),
    (RightElbow, &["relbow"]),
    (RightWrist, &["rhand"]),
    (RightHand, &["finger3-1.r"]),
    (LeftHip, &["lhip"]),
    (LeftKnee, &["lknee"]),
    (LeftAnkle, &["lfoot"]),
    (LeftFoot, &["toe2-1.l"]),
    (RightHip, &["rhip"]),
    (RightKnee, &["rknee"]),
    (RightAnkle, &["rfoot"]),
    (RightFoot, &["toe2-1.r"]),
];

const CMU_ASF: Table = [
    (Pelvis, &["root"]),
    (Chest, &["lowerneck"]),
    (Neck, &["upperneck"]),
    (Head, &["head"]),
    (LeftShoulder, &["lhumerus"]),
    (LeftElbow, &["lradius"]),
    (LeftWrist, &["lwrist"]),
    (LeftHand, &["lhand"]),
    (RightShoulder, &["rhumerus"]),
    (RightElbow, &["rradius"]),
    (RightWrist, &["rwrist"]),
    (RightHand, &["rhand"]),
    (LeftHip, &["lfemur"]),
    (LeftKnee, &["ltibia"]),
    (LeftAnkle, &["lfoot"]),
    (LeftFoot, &["ltoes"]),
    (RightHip, &["rfemur"]),
    (RightKnee, &["rtibia"]),
    (RightAnkle, &["rfoot"]),
    (RightFoot, &["rtoes"]),
];

impl SkeletonVariant {
    /// All variants, in the order detection tries them.
    pub const ALL: [SkeletonVariant; 5] = [
        SkeletonVariant::Cgspeed,
        SkeletonVariant::Cmu131,
        SkeletonVariant::Poser,
        SkeletonVariant::MakeHuman,
        SkeletonVariant::CmuAsf,
    ];

    /// A short name for messages.
    pub fn name(self) -> &'static str {
        match self {
            SkeletonVariant::Cgspeed => "cgspeed",
            SkeletonVariant::Cmu131 => "cmu-131",
            SkeletonVariant::Poser => "poser",
            SkeletonVariant::MakeHuman => "makehuman",
            SkeletonVariant::CmuAsf => "cmu-asf",
        }
    }

    /// `(canonical joint, BVH node names in order of preference)` for every canonical joint.
    /// End Sites are named `<parent>_end`.
    pub fn table(self) -> &'static [(Joint, &'static [&'static str]); NUM_JOINTS] {
        match self {
            SkeletonVariant::Cgspeed => &CGSPEED,
            SkeletonVariant::Cmu131 => &CMU_131,
            SkeletonVariant::Poser => &POSER,
            SkeletonVariant::MakeHuman => &MAKEHUMAN,
            SkeletonVariant::CmuAsf => &CMU_ASF,
        }
    }

    /// The BVH node names this variant looks for as `joint`, in order of preference.
    pub fn bvh_names(self, joint: Joint) -> &'static [&'static str] {
        self.table()[joint.index()].1
    }

    /// Looks every canonical joint up in `bvh`; returns the node indices, or the canonical joints
    /// not found.
    fn resolve(self, bvh: &Bvh) -> std::result::Result<Joints<usize>, Vec<Joint>> {
        let mut found = Joints::new();
        let mut missing = Vec::new();
        for &(joint, names) in self.table() {
            let index = names.iter().find_map(|name| {
                bvh.node_index(name).or_else(|| {
                    bvh.nodes
                        .iter()
                        .position(|n| n.name.eq_ignore_ascii_case(name))
                })
            });
            match index {
                Some(i) => {
                    found.insert(joint, i);
                }
                None => missing.push(joint),
            }
        }
        if missing.is_empty() {
            Ok(found)
        } else {
            Err(missing)
        }
    }
}

impl std::fmt::Display for SkeletonVariant {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// How every canonical joint maps onto the nodes of one BVH file.
#[derive(Debug, Clone, PartialEq)]
pub struct JointMapping {
    /// The naming variant used.
    pub variant: SkeletonVariant,
    /// Index into [`Bvh::nodes`] for every canonical joint (all 20 present).
    pub nodes: Joints<usize>,
}

/// Maps `bvh` with the given variant, or detects the variant when `variant` is `None` (the first
/// variant in [`SkeletonVariant::ALL`] whose names are all present wins).
///
/// The error lists the canonical joints missing from the best-matching variant.
pub fn map_joints(bvh: &Bvh, variant: Option<SkeletonVariant>) -> Result<JointMapping> {
    let candidates: &[SkeletonVariant] = match &variant {
        Some(v) => std::slice::from_ref(v),
        None => &SkeletonVariant::ALL,
    };
    let mut best: Option<(SkeletonVariant, Vec<Joint>)> = None;
    for &v in candidates {
        match v.resolve(bvh) {
            Ok(nodes) => return Ok(JointMapping { variant: v, nodes }),
            Err(missing) => {
                if best.as_ref().is_none_or(|(_, m)| missing.len() < m.len()) {
                    best = Some((v, missing));
                }
            }
        }
    }
    let (v, missing) = best.unwrap_or((SkeletonVariant::Cgspeed, Joint::ALL.to_vec()));
    Err(MocapError::MissingJoints {
        file: bvh.source.clone(),
        missing: missing
            .iter()
            .map(|j| j.name())
            .collect::<Vec<_>>()
            .join(", "),
        variant: v.name().to_owned(),
        expected: missing
            .iter()
            .map(|&j| v.bvh_names(j).join(" or "))
            .collect::<Vec<_>>()
            .join(", "),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tables_list_canonical_joints_in_index_order() {
        for v in SkeletonVariant::ALL {
            for (i, (j, _)) in v.table().iter().enumerate() {
                assert_eq!(j.index(), i, "{v}");
            }
        }
    }

    #[test]
    fn missing_joints_are_listed_by_canonical_and_expected_name() {
        let text = "HIERARCHY\nROOT Hips\n{\nOFFSET 0 0 0\nCHANNELS 3 Xposition Yposition Zposition\n\
                    JOINT LeftUpLeg\n{\nOFFSET 1 -1 0\nCHANNELS 1 Zrotation\nEnd Site\n{\nOFFSET 0 -1 0\n}\n}\n}\n\
                    MOTION\nFrames: 0\nFrame Time: 0.01\n";
        let bvh = crate::parse_bvh(text, "legs.bvh").unwrap();
        let e = map_joints(&bvh, None).unwrap_err().to_string();
        assert!(
            e.starts_with(
                "legs.bvh: cannot map to the canonical skeleton: no joint found for chest, neck,"
            ),
            "{e}"
        );
        assert!(e.contains("closest naming variant: cgspeed"), "{e}");
        assert!(e.contains("LeftHandIndex1 or LFingers"), "{e}");
        assert!(!e.contains("left_hip"), "{e}");
    }
}
