//! Skeletons: nomen's canonical joint set, observations from cameras, and mappings from the joint
//! sets of common pose estimators.

pub mod sets;

use crate::error::{CoreError, Result, check_finite_all_lazy, check_range_lazy};
use crate::ids::{CameraId, TrackId};
use crate::time::SessionTime;
use nalgebra::Point3;
use serde::de::{MapAccess, Visitor};
use serde::ser::SerializeMap;
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use std::fmt;

/// The canonical joint set. Every source (BVH, Kinect, Azure Kinect, COCO, BODY_25) is mapped
/// onto it at ingest.
///
/// `Wrist` is the wrist joint centre (where a band is worn); `Hand` is the middle of the palm or
/// the hand's end effector. `Ankle` is the ankle joint; `Foot` is the ball of the foot / toe base.
/// `Chest` is the upper thorax. `Pelvis` is the root of the body (BVH root, Kinect `SpineBase`,
/// Azure `PELVIS`, BODY_25 `MidHip`): within about 10 cm of the hip joints' midpoint, depending on
/// the source; COCO-17, which has no such point, gets the hips' midpoint.
#[allow(missing_docs)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Joint {
    Pelvis,
    Chest,
    Neck,
    Head,
    LeftShoulder,
    LeftElbow,
    LeftWrist,
    LeftHand,
    RightShoulder,
    RightElbow,
    RightWrist,
    RightHand,
    LeftHip,
    LeftKnee,
    LeftAnkle,
    LeftFoot,
    RightHip,
    RightKnee,
    RightAnkle,
    RightFoot,
}

/// Number of canonical joints.
pub const NUM_JOINTS: usize = 20;

impl Joint {
    /// All joints in index order.
    pub const ALL: [Joint; NUM_JOINTS] = [
        Joint::Pelvis,
        Joint::Chest,
        Joint::Neck,
        Joint::Head,
        Joint::LeftShoulder,
        Joint::LeftElbow,
        Joint::LeftWrist,
        Joint::LeftHand,
        Joint::RightShoulder,
        Joint::RightElbow,
        Joint::RightWrist,
        Joint::RightHand,
        Joint::LeftHip,
        Joint::LeftKnee,
        Joint::LeftAnkle,
        Joint::LeftFoot,
        Joint::RightHip,
        Joint::RightKnee,
        Joint::RightAnkle,
        Joint::RightFoot,
    ];

    /// Dense index in `0..NUM_JOINTS`.
    pub const fn index(self) -> usize {
        self as usize
    }

    /// The snake_case name used in files (`left_wrist`).
    pub fn name(self) -> &'static str {
        match self {
            Joint::Pelvis => "pelvis",
            Joint::Chest => "chest",
            Joint::Neck => "neck",
            Joint::Head => "head",
            Joint::LeftShoulder => "left_shoulder",
            Joint::LeftElbow => "left_elbow",
            Joint::LeftWrist => "left_wrist",
            Joint::LeftHand => "left_hand",
            Joint::RightShoulder => "right_shoulder",
            Joint::RightElbow => "right_elbow",
            Joint::RightWrist => "right_wrist",
            Joint::RightHand => "right_hand",
            Joint::LeftHip => "left_hip",
            Joint::LeftKnee => "left_knee",
            Joint::LeftAnkle => "left_ankle",
            Joint::LeftFoot => "left_foot",
            Joint::RightHip => "right_hip",
            Joint::RightKnee => "right_knee",
            Joint::RightAnkle => "right_ankle",
            Joint::RightFoot => "right_foot",
        }
    }

    /// Parses a snake_case name.
    pub fn from_name(name: &str) -> Result<Joint> {
        Joint::ALL
            .into_iter()
            .find(|j| j.name() == name)
            .ok_or_else(|| CoreError::Unknown {
                what: "joint",
                name: name.to_owned(),
            })
    }

    /// The parent in the kinematic tree (`None` for the pelvis, the root).
    pub fn parent(self) -> Option<Joint> {
        use Joint::*;
        Some(match self {
            Pelvis => return None,
            Chest => Pelvis,
            Neck => Chest,
            Head => Neck,
            LeftShoulder | RightShoulder => Chest,
            LeftElbow => LeftShoulder,
            LeftWrist => LeftElbow,
            LeftHand => LeftWrist,
            RightElbow => RightShoulder,
            RightWrist => RightElbow,
            RightHand => RightWrist,
            LeftHip | RightHip => Pelvis,
            LeftKnee => LeftHip,
            LeftAnkle => LeftKnee,
            LeftFoot => LeftAnkle,
            RightKnee => RightHip,
            RightAnkle => RightKnee,
            RightFoot => RightAnkle,
        })
    }

    /// The same joint on the other side of the body (itself for midline joints). Used to model
    /// left/right flips of people facing away from a camera, and for mirrored motion.
    pub fn mirrored(self) -> Joint {
        use Joint::*;
        match self {
            LeftShoulder => RightShoulder,
            LeftElbow => RightElbow,
            LeftWrist => RightWrist,
            LeftHand => RightHand,
            RightShoulder => LeftShoulder,
            RightElbow => LeftElbow,
            RightWrist => LeftWrist,
            RightHand => LeftHand,
            LeftHip => RightHip,
            LeftKnee => RightKnee,
            LeftAnkle => RightAnkle,
            LeftFoot => RightFoot,
            RightHip => LeftHip,
            RightKnee => LeftKnee,
            RightAnkle => LeftAnkle,
            RightFoot => LeftFoot,
            other => other,
        }
    }
}

impl fmt::Display for Joint {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A fixed-size map from every canonical joint to an optional value, indexed without hashing.
///
/// Serialised as a JSON object keyed by joint name, with absent joints omitted.
#[derive(Clone, PartialEq)]
pub struct Joints<T> {
    slots: [Option<T>; NUM_JOINTS],
}

impl<T> Default for Joints<T> {
    fn default() -> Self {
        Self {
            slots: std::array::from_fn(|_| None),
        }
    }
}

impl<T: fmt::Debug> fmt::Debug for Joints<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_map()
            .entries(self.iter().map(|(j, v)| (j.name(), v)))
            .finish()
    }
}

impl<T> Joints<T> {
    /// An empty map.
    pub fn new() -> Self {
        Self::default()
    }
    /// The value for `joint`, if present.
    pub fn get(&self, joint: Joint) -> Option<&T> {
        self.slots[joint.index()].as_ref()
    }
    /// Mutable access to the value for `joint`.
    pub fn get_mut(&mut self, joint: Joint) -> Option<&mut T> {
        self.slots[joint.index()].as_mut()
    }
    /// Sets the value for `joint`, returning the previous one.
    pub fn insert(&mut self, joint: Joint, value: T) -> Option<T> {
        self.slots[joint.index()].replace(value)
    }
    /// Removes the value for `joint`.
    pub fn remove(&mut self, joint: Joint) -> Option<T> {
        self.slots[joint.index()].take()
    }
    /// Present joints and values in canonical order.
    pub fn iter(&self) -> impl Iterator<Item = (Joint, &T)> {
        Joint::ALL
            .into_iter()
            .zip(self.slots.iter())
            .filter_map(|(j, v)| v.as_ref().map(|v| (j, v)))
    }
    /// Number of present joints.
    pub fn len(&self) -> usize {
        self.slots.iter().filter(|v| v.is_some()).count()
    }
    /// Whether no joint is present.
    pub fn is_empty(&self) -> bool {
        self.slots.iter().all(Option::is_none)
    }
    /// Applies `f` to every present value.
    pub fn map<U>(&self, mut f: impl FnMut(Joint, &T) -> U) -> Joints<U> {
        let mut out = Joints::new();
        for (j, v) in self.iter() {
            out.insert(j, f(j, v));
        }
        out
    }
}

impl<T: Serialize> Serialize for Joints<T> {
    fn serialize<S: Serializer>(&self, serializer: S) -> std::result::Result<S::Ok, S::Error> {
        let mut map = serializer.serialize_map(Some(self.len()))?;
        for (j, v) in self.iter() {
            map.serialize_entry(j.name(), v)?;
        }
        map.end()
    }
}

impl<'de, T: Deserialize<'de>> Deserialize<'de> for Joints<T> {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> std::result::Result<Self, D::Error> {
        struct JointsVisitor<T>(std::marker::PhantomData<T>);
        impl<'de, T: Deserialize<'de>> Visitor<'de> for JointsVisitor<T> {
            type Value = Joints<T>;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("an object keyed by canonical joint names")
            }
            fn visit_map<A: MapAccess<'de>>(
                self,
                mut access: A,
            ) -> std::result::Result<Self::Value, A::Error> {
                let mut out = Joints::new();
                while let Some(joint) = access.next_key::<Joint>()? {
                    let value = access.next_value::<T>()?;
                    if out.insert(joint, value).is_some() {
                        return Err(serde::de::Error::custom(format!(
                            "joint '{joint}' given twice"
                        )));
                    }
                }
                Ok(out)
            }
        }
        deserializer.deserialize_map(JointsVisitor(std::marker::PhantomData))
    }
}

/// How the pose estimator produced a joint.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum JointState {
    /// Seen directly.
    #[default]
    Tracked,
    /// Guessed by the SDK (occluded, extrapolated): expect a larger error.
    Inferred,
    /// Not available at all; the position is meaningless.
    Missing,
    /// Not seen by the camera but estimated by nomen's pose refinement (occluded-joint particle
    /// filter); [`JointObservation::covariance_m2`] says how sure the estimate is.
    Estimated,
}

/// One joint of one skeleton observation.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct JointObservation {
    /// Position in the observing camera's frame, metres.
    pub position_m: Point3<f64>,
    /// Estimator confidence in `0..=1`.
    #[serde(default = "one")]
    pub confidence: f64,
    /// Tracked, inferred, missing or estimated.
    #[serde(default)]
    pub state: JointState,
    /// Position covariance in the same frame, m², row-major 3×3: set on estimated joints.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub covariance_m2: Option<[[f64; 3]; 3]>,
}

fn one() -> f64 {
    1.0
}

impl JointObservation {
    /// Checks the confidence is in `0..=1` and, unless the joint is `Missing`, that every value
    /// is finite and every coordinate within [`MAX_COORDINATE_M`]; errors name the field as
    /// `joints.{joint}.…`.
    pub fn validate_as(&self, joint: impl std::fmt::Display) -> Result<()> {
        check_range_lazy(
            || format!("joints.{joint}.confidence"),
            self.confidence,
            0.0,
            1.0,
            "",
        )?;
        if self.state == JointState::Missing {
            return Ok(());
        }
        let field = || format!("joints.{joint}.position_m");
        check_finite_all_lazy(field, self.position_m.coords.as_slice())?;
        if let Some(c) = &self.covariance_m2 {
            check_finite_all_lazy(|| format!("joints.{joint}.covariance_m2"), c.as_flattened())?;
        }
        for (axis, v) in self.position_m.coords.iter().enumerate() {
            check_range_lazy(
                || format!("{}[{axis}]", field()),
                *v,
                -MAX_COORDINATE_M,
                MAX_COORDINATE_M,
                "m",
            )?;
        }
        Ok(())
    }
}

impl JointObservation {
    /// A tracked joint with full confidence.
    pub fn tracked(position_m: Point3<f64>) -> Self {
        Self {
            position_m,
            confidence: 1.0,
            state: JointState::Tracked,
            covariance_m2: None,
        }
    }
}

/// One skeleton reported by one camera at one instant.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SkeletonObservation {
    /// Capture time on the session clock.
    pub t: SessionTime,
    /// The reporting camera; its pose is `Registry::cameras[..].world_from_camera`.
    pub camera: CameraId,
    /// The camera's own track id. Not stable over time and never the subject.
    pub track: TrackId,
    /// Joint observations in the camera frame. Joints the source does not provide are absent.
    pub joints: Joints<JointObservation>,
}

/// Largest coordinate magnitude accepted anywhere, metres: a sanity bound that catches unit
/// mistakes (millimetres read as metres) rather than a physical limit.
pub const MAX_COORDINATE_M: f64 = 10_000.0;

impl SkeletonObservation {
    /// Checks the time ([`SessionTime::check_plausible`]) and the finiteness and plausibility of
    /// every joint that is not `Missing`.
    pub fn validate(&self) -> Result<()> {
        self.t.check_plausible()?;
        for (j, obs) in self.joints.iter() {
            obs.validate_as(j)?;
        }
        Ok(())
    }

    /// Position of a joint that is present and not `Missing`.
    pub fn position(&self, joint: Joint) -> Option<Point3<f64>> {
        self.joints
            .get(joint)
            .filter(|o| o.state != JointState::Missing)
            .map(|o| o.position_m)
    }

    /// The mean of the joints that are present and not `Missing` (camera frame); `None`
    /// without any.
    pub fn joint_centroid_m(&self) -> Option<Point3<f64>> {
        let (sum, n) = self
            .joints
            .iter()
            .filter(|(_, o)| o.state != JointState::Missing)
            .fold((nalgebra::Vector3::zeros(), 0usize), |(sum, n), (_, o)| {
                (sum + o.position_m.coords, n + 1)
            });
        (n > 0).then(|| Point3::from(sum / n as f64))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_joint_centroid_leaves_missing_joints_out() {
        let mut obs = SkeletonObservation {
            t: SessionTime::ZERO,
            camera: CameraId::new("cam"),
            track: TrackId(1),
            joints: Joints::new(),
        };
        assert_eq!(obs.joint_centroid_m(), None);
        obs.joints.insert(
            Joint::Pelvis,
            JointObservation::tracked(Point3::new(1.0, 0.0, 0.0)),
        );
        obs.joints.insert(
            Joint::Chest,
            JointObservation::tracked(Point3::new(3.0, 2.0, 0.0)),
        );
        let mut lost = JointObservation::tracked(Point3::new(100.0, 0.0, 0.0));
        lost.state = JointState::Missing;
        obs.joints.insert(Joint::Head, lost);
        assert_eq!(obs.joint_centroid_m(), Some(Point3::new(2.0, 1.0, 0.0)));
    }

    #[test]
    fn every_joint_reaches_the_pelvis_through_its_parents() {
        for j in Joint::ALL {
            let mut cur = j;
            let mut steps = 0;
            while let Some(p) = cur.parent() {
                cur = p;
                steps += 1;
                assert!(steps < NUM_JOINTS);
            }
            assert_eq!(cur, Joint::Pelvis);
        }
    }

    #[test]
    fn names_round_trip_and_mirroring_is_an_involution() {
        for (i, j) in Joint::ALL.into_iter().enumerate() {
            assert_eq!(j.index(), i);
            assert_eq!(Joint::from_name(j.name()).unwrap(), j);
            assert_eq!(j.mirrored().mirrored(), j);
        }
        assert!(Joint::from_name("left_pinky").is_err());
    }

    #[test]
    fn joints_serialise_as_an_object_and_reject_duplicates() {
        let mut joints = Joints::new();
        joints.insert(Joint::Head, 1.5_f64);
        joints.insert(Joint::LeftWrist, 0.5);
        let s = serde_json::to_string(&joints).unwrap();
        assert_eq!(s, r#"{"head":1.5,"left_wrist":0.5}"#);
        let back: Joints<f64> = serde_json::from_str(&s).unwrap();
        assert_eq!(back, joints);
        let dup = serde_json::from_str::<Joints<f64>>(r#"{"head":1,"head":2}"#);
        assert!(dup.unwrap_err().to_string().contains("twice"));
        assert!(serde_json::from_str::<Joints<f64>>(r#"{"tail":1}"#).is_err());
    }

    #[test]
    fn nan_joint_is_rejected_unless_missing() {
        let mut obs = SkeletonObservation {
            t: SessionTime(0),
            camera: CameraId::new("cam"),
            track: TrackId(1),
            joints: Joints::new(),
        };
        obs.joints.insert(
            Joint::Head,
            JointObservation::tracked(Point3::new(0.0, f64::NAN, 1.0)),
        );
        let err = obs.validate().unwrap_err().to_string();
        assert!(err.contains("joints.head.position_m[1]"), "{err}");
        obs.joints.get_mut(Joint::Head).unwrap().state = JointState::Missing;
        assert!(obs.validate().is_ok());
        assert!(obs.position(Joint::Head).is_none());
    }
}
