//! Joint sets of common pose estimators and their mapping onto the canonical [`Joint`] set.
//!
//! Each set lists its joints in the estimator's own index order. Joints the canonical set has no
//! place for (eyes, ears, finger tips, thumbs, clavicles) map to `None` and are dropped. Canonical
//! joints a set lacks are *derived* where a textbook construction exists (COCO-17 has no neck:
//! the shoulders' midpoint is used) and marked [`JointState::Inferred`]; otherwise they stay absent.

use super::{Joint, JointObservation, JointState, Joints};
use crate::error::{CoreError, Result};
use nalgebra::Point3;
use serde::{Deserialize, Serialize};

/// A pose estimator's joint set.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum JointSet {
    /// Microsoft Kinect v2 (25 joints, `JointType_*`).
    KinectV2,
    /// Azure Kinect Body Tracking SDK (32 joints, `K4ABT_JOINT_*`).
    AzureKinect,
    /// COCO-17 keypoints (MMPose, Detectron2, YOLO-pose, OpenPose COCO).
    Coco17,
    /// OpenPose BODY_25.
    Body25,
}

use Joint::*;

/// Kinect v2 `JointType` order. Chest is `SpineMid` (mid thorax); `SpineShoulder` sits between
/// the shoulders just below the neck and has no separate canonical joint.
const KINECT_V2: [(&str, Option<Joint>); 25] = [
    ("SpineBase", Some(Pelvis)),
    ("SpineMid", Some(Chest)),
    ("Neck", Some(Neck)),
    ("Head", Some(Head)),
    ("ShoulderLeft", Some(LeftShoulder)),
    ("ElbowLeft", Some(LeftElbow)),
    ("WristLeft", Some(LeftWrist)),
    ("HandLeft", Some(LeftHand)),
    ("ShoulderRight", Some(RightShoulder)),
    ("ElbowRight", Some(RightElbow)),
    ("WristRight", Some(RightWrist)),
    ("HandRight", Some(RightHand)),
    ("HipLeft", Some(LeftHip)),
    ("KneeLeft", Some(LeftKnee)),
    ("AnkleLeft", Some(LeftAnkle)),
    ("FootLeft", Some(LeftFoot)),
    ("HipRight", Some(RightHip)),
    ("KneeRight", Some(RightKnee)),
    ("AnkleRight", Some(RightAnkle)),
    ("FootRight", Some(RightFoot)),
    ("SpineShoulder", None),
    ("HandTipLeft", None),
    ("ThumbLeft", None),
    ("HandTipRight", None),
    ("ThumbRight", None),
];

/// Azure Kinect `k4abt_joint_id_t` order.
const AZURE_KINECT: [(&str, Option<Joint>); 32] = [
    ("PELVIS", Some(Pelvis)),
    ("SPINE_NAVEL", None),
    ("SPINE_CHEST", Some(Chest)),
    ("NECK", Some(Neck)),
    ("CLAVICLE_LEFT", None),
    ("SHOULDER_LEFT", Some(LeftShoulder)),
    ("ELBOW_LEFT", Some(LeftElbow)),
    ("WRIST_LEFT", Some(LeftWrist)),
    ("HAND_LEFT", Some(LeftHand)),
    ("HANDTIP_LEFT", None),
    ("THUMB_LEFT", None),
    ("CLAVICLE_RIGHT", None),
    ("SHOULDER_RIGHT", Some(RightShoulder)),
    ("ELBOW_RIGHT", Some(RightElbow)),
    ("WRIST_RIGHT", Some(RightWrist)),
    ("HAND_RIGHT", Some(RightHand)),
    ("HANDTIP_RIGHT", None),
    ("THUMB_RIGHT", None),
    ("HIP_LEFT", Some(LeftHip)),
    ("KNEE_LEFT", Some(LeftKnee)),
    ("ANKLE_LEFT", Some(LeftAnkle)),
    ("FOOT_LEFT", Some(LeftFoot)),
    ("HIP_RIGHT", Some(RightHip)),
    ("KNEE_RIGHT", Some(RightKnee)),
    ("ANKLE_RIGHT", Some(RightAnkle)),
    ("FOOT_RIGHT", Some(RightFoot)),
    ("HEAD", Some(Head)),
    ("NOSE", None),
    ("EYE_LEFT", None),
    ("EAR_LEFT", None),
    ("EYE_RIGHT", None),
    ("EAR_RIGHT", None),
];

/// COCO-17 keypoint order. The nose stands in for the head.
const COCO_17: [(&str, Option<Joint>); 17] = [
    ("nose", Some(Head)),
    ("left_eye", None),
    ("right_eye", None),
    ("left_ear", None),
    ("right_ear", None),
    ("left_shoulder", Some(LeftShoulder)),
    ("right_shoulder", Some(RightShoulder)),
    ("left_elbow", Some(LeftElbow)),
    ("right_elbow", Some(RightElbow)),
    ("left_wrist", Some(LeftWrist)),
    ("right_wrist", Some(RightWrist)),
    ("left_hip", Some(LeftHip)),
    ("right_hip", Some(RightHip)),
    ("left_knee", Some(LeftKnee)),
    ("right_knee", Some(RightKnee)),
    ("left_ankle", Some(LeftAnkle)),
    ("right_ankle", Some(RightAnkle)),
];

/// OpenPose BODY_25 order. The nose stands in for the head and the big toe for the foot.
const BODY_25: [(&str, Option<Joint>); 25] = [
    ("Nose", Some(Head)),
    ("Neck", Some(Neck)),
    ("RShoulder", Some(RightShoulder)),
    ("RElbow", Some(RightElbow)),
    ("RWrist", Some(RightWrist)),
    ("LShoulder", Some(LeftShoulder)),
    ("LElbow", Some(LeftElbow)),
    ("LWrist", Some(LeftWrist)),
    ("MidHip", Some(Pelvis)),
    ("RHip", Some(RightHip)),
    ("RKnee", Some(RightKnee)),
    ("RAnkle", Some(RightAnkle)),
    ("LHip", Some(LeftHip)),
    ("LKnee", Some(LeftKnee)),
    ("LAnkle", Some(LeftAnkle)),
    ("REye", None),
    ("LEye", None),
    ("REar", None),
    ("LEar", None),
    ("LBigToe", Some(LeftFoot)),
    ("LSmallToe", None),
    ("LHeel", None),
    ("RBigToe", Some(RightFoot)),
    ("RSmallToe", None),
    ("RHeel", None),
];

impl JointSet {
    /// All supported sets.
    pub const ALL: [JointSet; 4] = [
        JointSet::KinectV2,
        JointSet::AzureKinect,
        JointSet::Coco17,
        JointSet::Body25,
    ];

    fn table(self) -> &'static [(&'static str, Option<Joint>)] {
        match self {
            JointSet::KinectV2 => &KINECT_V2,
            JointSet::AzureKinect => &AZURE_KINECT,
            JointSet::Coco17 => &COCO_17,
            JointSet::Body25 => &BODY_25,
        }
    }

    /// Number of joints the estimator reports.
    pub fn len(self) -> usize {
        self.table().len()
    }

    /// Whether the set is empty (never true; present for API completeness).
    pub fn is_empty(self) -> bool {
        self.table().is_empty()
    }

    /// The estimator's own name for joint `index`.
    pub fn joint_name(self, index: usize) -> Option<&'static str> {
        self.table().get(index).map(|(n, _)| *n)
    }

    /// The canonical joint for the estimator's joint `index`, if it has one.
    pub fn canonical(self, index: usize) -> Option<Joint> {
        self.table().get(index).and_then(|(_, j)| *j)
    }

    /// Looks an estimator joint up by its own name (exact match).
    pub fn index_of(self, name: &str) -> Option<usize> {
        self.table().iter().position(|(n, _)| *n == name)
    }

    /// Maps one frame of estimator joints (in the estimator's order) onto canonical joints, and
    /// derives the canonical joints the set lacks where possible.
    ///
    /// `joints.len()` must equal [`JointSet::len`].
    pub fn to_canonical(self, joints: &[JointObservation]) -> Result<Joints<JointObservation>> {
        if joints.len() != self.len() {
            return Err(CoreError::Invalid(format!(
                "{self:?} has {} joints, got {}",
                self.len(),
                joints.len()
            )));
        }
        let mut out = Joints::new();
        for (i, obs) in joints.iter().enumerate() {
            if let Some(j) = self.canonical(i) {
                out.insert(j, *obs);
            }
        }
        derive_midpoint(&mut out, Neck, LeftShoulder, RightShoulder);
        derive_midpoint(&mut out, Pelvis, LeftHip, RightHip);
        Ok(out)
    }
}

/// Fills `target` with the midpoint of `a` and `b` when it is absent and both are usable.
fn derive_midpoint(out: &mut Joints<JointObservation>, target: Joint, a: Joint, b: Joint) {
    if out.get(target).is_some() {
        return;
    }
    let (Some(pa), Some(pb)) = (out.get(a), out.get(b)) else {
        return;
    };
    if pa.state == JointState::Missing || pb.state == JointState::Missing {
        return;
    }
    let mid = Point3::from((pa.position_m.coords + pb.position_m.coords) * 0.5);
    let obs = JointObservation {
        position_m: mid,
        confidence: pa.confidence.min(pb.confidence),
        state: JointState::Inferred,
        covariance_m2: None,
    };
    out.insert(target, obs);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(n: usize) -> Vec<JointObservation> {
        (0..n)
            .map(|i| JointObservation::tracked(Point3::new(i as f64, 0.0, 1.0)))
            .collect()
    }

    #[test]
    fn set_sizes_match_the_sdks() {
        assert_eq!(JointSet::KinectV2.len(), 25);
        assert_eq!(JointSet::AzureKinect.len(), 32);
        assert_eq!(JointSet::Coco17.len(), 17);
        assert_eq!(JointSet::Body25.len(), 25);
    }

    #[test]
    fn no_canonical_joint_is_claimed_twice() {
        for set in JointSet::ALL {
            let mut seen = Joints::new();
            for i in 0..set.len() {
                if let Some(j) = set.canonical(i) {
                    assert!(seen.insert(j, i).is_none(), "{set:?} maps {j} twice");
                }
            }
        }
    }

    #[test]
    fn kinect_and_azure_cover_every_canonical_joint() {
        for set in [JointSet::KinectV2, JointSet::AzureKinect] {
            let out = set.to_canonical(&frame(set.len())).unwrap();
            assert_eq!(out.len(), super::super::NUM_JOINTS, "{set:?}");
        }
    }

    #[test]
    fn coco_neck_and_pelvis_are_inferred_midpoints() {
        let out = JointSet::Coco17.to_canonical(&frame(17)).unwrap();
        let neck = out.get(Neck).unwrap();
        assert_eq!(neck.state, JointState::Inferred);
        // Shoulders are COCO indices 5 and 6 → x = 5.5.
        assert!((neck.position_m.x - 5.5).abs() < 1e-12);
        assert!((out.get(Pelvis).unwrap().position_m.x - 11.5).abs() < 1e-12);
        assert!(out.get(Chest).is_none());
    }

    #[test]
    fn wrong_joint_count_is_an_error() {
        assert!(JointSet::Body25.to_canonical(&frame(18)).is_err());
        assert_eq!(JointSet::Body25.index_of("RWrist"), Some(4));
        assert_eq!(JointSet::Body25.canonical(4), Some(RightWrist));
    }
}
