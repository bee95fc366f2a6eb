//! One frame of a calibrated rig: the detections of every view in, triangulated skeletons out.

use crate::associate::{AssociationConfig, PreparedDetection, associate, prepare};
use crate::camera::CalibratedCamera;
use crate::error::{MultiviewError, Result};
use crate::keypoints::Detection;
use crate::triangulate::{TriangulatedJoint, TriangulationConfig, ViewPoint, triangulate_joint};
use nomen_core::Joint;
use nomen_core::skeleton::Joints;

/// How a frame is reconstructed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReconstructionConfig {
    /// Cross-view association.
    pub association: AssociationConfig,
    /// Per-joint triangulation.
    pub triangulation: TriangulationConfig,
    /// Fewest triangulated joints a skeleton needs to be kept: below three, neither the bone
    /// check nor the joints' median can tell a wrong joint.
    pub min_joints: usize,
    /// The tallest person expected, metres: bones longer than this stature allows (with a
    /// margin, see [`BONES`]) make a skeleton implausible. 2.1 m is taller than 99.9 % of
    /// adults.
    pub max_stature_m: f64,
}

impl Default for ReconstructionConfig {
    fn default() -> Self {
        Self {
            association: AssociationConfig::default(),
            triangulation: TriangulationConfig::default(),
            min_joints: 3,
            max_stature_m: 2.1,
        }
    }
}

/// Segments whose length a body bounds, as fractions of stature: Drillis and Contini's segment
/// proportions as Winter tabulates them (*Biomechanics and Motor Control of Human Movement*, 4th
/// ed., Fig. 4.1): upper arm 0.186, forearm 0.146, hand 0.108, thigh 0.245, leg 0.246, foot
/// 0.152, shoulder width 0.259, hip width 0.191, shoulder to hip 0.288 (0.818 − 0.530), neck to
/// head top 0.182, hip joint to pelvis centre half the hip width; the chest (upper thorax) is
/// bounded by the trunk (0.288) from the pelvis and the neck and by the shoulder width from each
/// shoulder. A bone may be up to
/// [`BONE_MARGIN`] times its fraction of [`ReconstructionConfig::max_stature_m`] (keypoints are
/// not joint centres: COCO's nose stands in for the head, BODY_25's big toe for the foot).
pub const BONES: [(Joint, Joint, f64); 24] = [
    (Joint::LeftShoulder, Joint::LeftElbow, 0.186),
    (Joint::RightShoulder, Joint::RightElbow, 0.186),
    (Joint::LeftElbow, Joint::LeftWrist, 0.146),
    (Joint::RightElbow, Joint::RightWrist, 0.146),
    (Joint::LeftWrist, Joint::LeftHand, 0.108),
    (Joint::RightWrist, Joint::RightHand, 0.108),
    (Joint::LeftHip, Joint::LeftKnee, 0.245),
    (Joint::RightHip, Joint::RightKnee, 0.245),
    (Joint::LeftKnee, Joint::LeftAnkle, 0.246),
    (Joint::RightKnee, Joint::RightAnkle, 0.246),
    (Joint::LeftAnkle, Joint::LeftFoot, 0.152),
    (Joint::RightAnkle, Joint::RightFoot, 0.152),
    (Joint::LeftShoulder, Joint::RightShoulder, 0.259),
    (Joint::LeftHip, Joint::RightHip, 0.191),
    (Joint::LeftShoulder, Joint::LeftHip, 0.288),
    (Joint::RightShoulder, Joint::RightHip, 0.288),
    (Joint::Neck, Joint::Head, 0.182),
    (Joint::Pelvis, Joint::LeftHip, 0.096),
    (Joint::Pelvis, Joint::RightHip, 0.096),
    (Joint::Pelvis, Joint::Neck, 0.288),
    (Joint::Pelvis, Joint::Chest, 0.288),
    (Joint::Chest, Joint::Neck, 0.288),
    (Joint::Chest, Joint::LeftShoulder, 0.259),
    (Joint::Chest, Joint::RightShoulder, 0.259),
];

/// How much longer than its fraction of the tallest stature a bone may be.
pub const BONE_MARGIN: f64 = 1.3;

/// Checks the skeleton's bones ([`BONES`]): first a joint all of whose measurable bones are too
/// long, or farther than the tallest stature from the joints' median, is removed (a wrong
/// keypoint that two views happened to agree on), then the skeleton is
/// implausible (`false`) when more than a quarter of the bones left are too long (two detections
/// of different people, or of nobody, whose rays happen to meet).
fn check_bones(joints: &mut Joints<TriangulatedJoint>, max_stature_m: f64) -> bool {
    let is_long = |joints: &Joints<TriangulatedJoint>, a: Joint, b: Joint, fraction: f64| {
        let (pa, pb) = (joints.get(a)?, joints.get(b)?);
        Some((pa.position_m - pb.position_m).norm() > BONE_MARGIN * fraction * max_stature_m)
    };
    let mut num_bones = [0usize; nomen_core::skeleton::NUM_JOINTS];
    let mut num_long = [0usize; nomen_core::skeleton::NUM_JOINTS];
    for (a, b, fraction) in BONES {
        if let Some(long) = is_long(joints, a, b, fraction) {
            for j in [a, b] {
                num_bones[j.index()] += 1;
                num_long[j.index()] += usize::from(long);
            }
        }
    }
    let median = median_m(joints);
    for j in Joint::ALL {
        let is_far = median
            .zip(joints.get(j))
            .is_some_and(|(m, t)| (t.position_m - m).norm() > max_stature_m);
        if is_far || (num_bones[j.index()] > 0 && num_long[j.index()] == num_bones[j.index()]) {
            joints.remove(j);
        }
    }
    let (mut total, mut total_long) = (0usize, 0usize);
    for (a, b, fraction) in BONES {
        if let Some(long) = is_long(joints, a, b, fraction) {
            total += 1;
            total_long += usize::from(long);
        }
    }
    4 * total_long <= total
}

impl ReconstructionConfig {
    /// Checks every value is in range.
    pub fn validate(&self) -> Result<()> {
        let a = &self.association;
        let t = &self.triangulation;
        let positive = [
            ("association.max_ray_distance_m", a.max_ray_distance_m),
            ("triangulation.reprojection_gate_px", t.reprojection_gate_px),
            ("triangulation.confidence_scale_px", t.confidence_scale_px),
            ("max_stature_m", self.max_stature_m),
        ];
        for (name, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(MultiviewError::Config(format!(
                    "{name} = {v} must be a positive number"
                )));
            }
        }
        if !(0.0..=1.0).contains(&a.min_keypoint_confidence) {
            return Err(MultiviewError::Config(format!(
                "association.min_keypoint_confidence = {} must be within 0..=1",
                a.min_keypoint_confidence
            )));
        }
        Ok(())
    }
}

/// A person triangulated at one frame.
#[derive(Debug, Clone, PartialEq)]
pub struct TriangulatedSkeleton {
    /// Triangulated joints; joints seen in fewer than two agreeing views are absent.
    pub joints: Joints<TriangulatedJoint>,
    /// The detections it was made of: (view, index of the detection in its view).
    pub detections: Vec<(usize, usize)>,
}

/// The per-axis median of the joints' positions; `None` without joints.
fn median_m(joints: &Joints<TriangulatedJoint>) -> Option<nalgebra::Point3<f64>> {
    let mut axes: [Vec<f64>; 3] = Default::default();
    for (_, t) in joints.iter() {
        for (axis, v) in axes.iter_mut().zip(t.position_m.coords.iter()) {
            axis.push(*v);
        }
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        let n = v.len();
        if n % 2 == 1 {
            v[n / 2]
        } else {
            0.5 * (v[n / 2 - 1] + v[n / 2])
        }
    };
    if axes[0].is_empty() {
        return None;
    }
    let [x, y, z] = &mut axes;
    Some(nalgebra::Point3::new(median(x), median(y), median(z)))
}

impl TriangulatedSkeleton {
    /// Where the body is, for tracking: the per-axis median of the joints (near the lower
    /// chest), which one badly triangulated joint does not move; `None` without joints.
    pub fn anchor_m(&self) -> Option<nalgebra::Point3<f64>> {
        median_m(&self.joints)
    }
}

/// What one frame gave.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FrameReconstruction {
    /// The people, in a deterministic order (by their detections).
    pub skeletons: Vec<TriangulatedSkeleton>,
    /// Detections given, over all views.
    pub num_detections: usize,
    /// Detections that joined no multi-view person (false detections, people seen by one
    /// camera).
    pub num_unassociated: usize,
}

/// Reconstructs one frame: `views[i]` are the detections of `cameras[i]` (empty for a view
/// without detections). Views beyond the cameras are ignored.
pub fn reconstruct_frame(
    cameras: &[CalibratedCamera],
    views: &[Vec<Detection>],
    config: &ReconstructionConfig,
) -> FrameReconstruction {
    let mut prepared: Vec<PreparedDetection> = Vec::new();
    for (view, (camera, detections)) in cameras.iter().zip(views).enumerate() {
        prepared.extend(prepare(camera, view, detections, &config.association));
    }
    let clusters = associate(cameras, &prepared, &config.association);
    let mut skeletons = Vec::with_capacity(clusters.len());
    let mut num_associated = 0;
    let mut points: Vec<ViewPoint> = Vec::new();
    for cluster in clusters {
        let mut joints = Joints::new();
        for joint in Joint::ALL {
            points.clear();
            points.extend(
                cluster
                    .iter()
                    .filter_map(|&i| prepared[i].joints.get(joint).map(|k| k.point)),
            );
            if let Some(t) = triangulate_joint(cameras, &points, &config.triangulation) {
                joints.insert(joint, t);
            }
        }
        if !check_bones(&mut joints, config.max_stature_m)
            || joints.is_empty()
            || joints.len() < config.min_joints
        {
            continue;
        }
        num_associated += cluster.len();
        skeletons.push(TriangulatedSkeleton {
            joints,
            detections: cluster
                .iter()
                .map(|&i| (prepared[i].view, prepared[i].index))
                .collect(),
        });
    }
    let num_detections = prepared.len();
    FrameReconstruction {
        skeletons,
        num_detections,
        num_unassociated: num_detections - num_associated,
    }
}
