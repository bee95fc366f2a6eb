//! The message vocabulary: what flows into the engine, what it outputs, and the ground truth the
//! simulator writes for the evaluator. Recordings are sequences of these (see `nomen-recording`).

use crate::error::{Result, check_finite_all, check_finite_all_lazy, check_range};
use crate::ids::{CameraId, DeviceId, SubjectId, TagId, TrackId};
use crate::sensor::{ImuSample, RssiRead, RtlsFix, UwbRange};
use crate::skeleton::{JointObservation, Joints, SkeletonObservation};
use crate::time::SessionTime;
use nalgebra::Point3;
use serde::{Deserialize, Serialize};

/// Who a skeleton is: a registered subject, or explicitly nobody we know.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Identity {
    /// A registered subject.
    Subject(SubjectId),
    /// Not (yet) identified, or a person who wears nothing: nomen does not guess.
    Anonymous,
}

impl Identity {
    /// The subject, if any.
    pub fn subject(&self) -> Option<&SubjectId> {
        match self {
            Identity::Subject(s) => Some(s),
            Identity::Anonymous => None,
        }
    }
}

/// One piece of evidence behind an identity decision.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Evidence {
    /// Which modality produced it: `imu`, `uwb`, `rssi`, `cnn`, ...
    pub modality: String,
    /// The device whose signal was compared with the skeleton.
    pub device: DeviceId,
    /// The modality's score for this (device, skeleton) pair; higher is more alike.
    pub score: f64,
}

/// The rule that gave an identity (see the engine's documentation for each).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DecisionRule {
    /// The camera's assignment of subjects to its tracks named the track: its score cleared the
    /// rejection threshold and no other track of the camera took the subject.
    Assigned,
    /// The subject went to an earlier or later track of the same camera that never coexisted with
    /// this one (one person under successive track ids), and this track takes it too.
    SuccessiveTrack,
    /// An earlier decision about the track named it (observations of the warm-up, or waiting
    /// for their decision while the track's latest decision leaves it anonymous).
    EarlierDecision,
    /// The track that continues this one (stitched) carries the name.
    ContinuedTrack,
    /// The track continues an ended one (stitched) and carries its name until its own first
    /// decision.
    Stitched,
    /// Another camera's view of the same person carries the name.
    OtherCameraView,
    /// Anonymous: no subject's score clears the rejection threshold.
    BelowThreshold,
    /// Anonymous: the best subject went to another track of the camera.
    TakenByOtherTrack,
    /// Anonymous: the best subject is held by a coexisting track of the camera that scored
    /// better for it (the exclusion rule).
    Excluded,
    /// Anonymous: the best subject is held by a better-scoring track of another camera, far
    /// from this one (one person, one place).
    HeldFarAway,
    /// Anonymous: a name withheld while its subject's clock offsets are unknown and another
    /// track scores almost as well for it.
    HeldBack,
    /// Anonymous: no evidence about any subject yet.
    NoEvidence,
    /// Anonymous: a rule gave a name whose calibrated probability of being right is below the
    /// run's minimum (the engine's `min_name_probability`, or `open_set_min_name_probability`
    /// where more people were seen than subjects whose wearables stream, or
    /// `tag_min_name_probability` for a name a location tag or RSSI supports that the track
    /// has not carried with that probability before), or a name resting on motion whose score
    /// is below the engine's `open_set_min_score` where more people were seen.
    Improbable,
}

impl DecisionRule {
    /// Every rule, naming ones first.
    pub const ALL: [DecisionRule; 13] = [
        DecisionRule::Assigned,
        DecisionRule::SuccessiveTrack,
        DecisionRule::EarlierDecision,
        DecisionRule::ContinuedTrack,
        DecisionRule::Stitched,
        DecisionRule::OtherCameraView,
        DecisionRule::BelowThreshold,
        DecisionRule::TakenByOtherTrack,
        DecisionRule::Excluded,
        DecisionRule::HeldFarAway,
        DecisionRule::HeldBack,
        DecisionRule::NoEvidence,
        DecisionRule::Improbable,
    ];

    /// The rule's name as recordings spell it (`assigned`, `held_far_away`, ...).
    pub fn as_str(self) -> &'static str {
        match self {
            DecisionRule::Assigned => "assigned",
            DecisionRule::SuccessiveTrack => "successive_track",
            DecisionRule::EarlierDecision => "earlier_decision",
            DecisionRule::ContinuedTrack => "continued_track",
            DecisionRule::Stitched => "stitched",
            DecisionRule::OtherCameraView => "other_camera_view",
            DecisionRule::BelowThreshold => "below_threshold",
            DecisionRule::TakenByOtherTrack => "taken_by_other_track",
            DecisionRule::Excluded => "excluded",
            DecisionRule::HeldFarAway => "held_far_away",
            DecisionRule::HeldBack => "held_back",
            DecisionRule::NoEvidence => "no_evidence",
            DecisionRule::Improbable => "improbable",
        }
    }

    /// Whether the rule gives a name (the others leave the track anonymous).
    pub fn names(self) -> bool {
        matches!(
            self,
            DecisionRule::Assigned
                | DecisionRule::SuccessiveTrack
                | DecisionRule::EarlierDecision
                | DecisionRule::ContinuedTrack
                | DecisionRule::Stitched
                | DecisionRule::OtherCameraView
        )
    }
}

/// A subject and its score for a track: pooled over the modalities and the cameras' views, the
/// score the decision compares (higher is more alike).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Candidate {
    /// The subject.
    pub subject: SubjectId,
    /// Its pooled score.
    pub score: f64,
}

/// A short trace of the decision behind an identity.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DecisionTrace {
    /// The rule that gave the identity.
    pub rule: DecisionRule,
    /// Session time of the decision (the end of its evidence window).
    pub decided_at: SessionTime,
    /// The named subject and its score, for a named track (for a name from elsewhere, its score
    /// on the track or decision that gave it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub named: Option<Candidate>,
    /// The best other subject and its score (for an anonymous track, the best subject).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub runner_up: Option<Candidate>,
}

/// An engine output: a skeleton observation with the identity nomen gives it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct IdentifiedSkeleton {
    /// Time of the underlying observation.
    pub t: SessionTime,
    /// The camera that saw it.
    pub camera: CameraId,
    /// The camera's track id of the observation.
    pub track: TrackId,
    /// The identity nomen gives it.
    pub identity: Identity,
    /// Confidence in the identity, `0..=1`: for nomen's engine, the probability that the
    /// identity (the subject, or `Anonymous` for someone who wears nothing) is right, as
    /// fitted on scenes with known truth (`nomen_engine::ConfidenceMap`).
    pub confidence: f64,
    /// Evidence used for the decision.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub evidence: Vec<Evidence>,
    /// Why the identity was given, when the producer says (nomen's engine always does).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub decision: Option<DecisionTrace>,
    /// The (possibly refined) joints; may be omitted to keep results small.
    #[serde(default, skip_serializing_if = "Joints::is_empty")]
    pub joints: Joints<JointObservation>,
}

/// An engine output: a tag position corrected with the skeleton it was fused with.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TagCorrection {
    /// Time of the tag fix.
    pub t: SessionTime,
    /// The tag.
    pub tag: TagId,
    /// The fix as the location system reported it, world frame, metres.
    pub raw_position_m: Point3<f64>,
    /// nomen's corrected position, world frame, metres.
    pub corrected_position_m: Point3<f64>,
}

/// Ground truth for one skeleton observation (written by the simulator, read by the evaluator).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TruthSkeleton {
    /// Time of the observation.
    pub t: SessionTime,
    /// The camera that reported it.
    pub camera: CameraId,
    /// The track id the camera gave it.
    pub track: TrackId,
    /// The physical person, stable over the whole scene (also for people who wear nothing).
    pub person: String,
    /// The registered subject this person is, or `None` for someone who wears nothing and should
    /// stay anonymous.
    #[serde(default)]
    pub subject: Option<SubjectId>,
    /// True joint positions in the world frame, metres (optional).
    #[serde(default, skip_serializing_if = "Joints::is_empty")]
    pub joints_world_m: Joints<Point3<f64>>,
}

/// Ground truth for a tag at the time of one of its fixes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TruthTag {
    /// Time of the fix.
    pub t: SessionTime,
    /// The tag.
    pub tag: TagId,
    /// True position, world frame, metres.
    pub position_m: Point3<f64>,
}

/// Every message nomen reads or writes, tagged by `type` in files.
///
/// The three variants that carry a whole skeleton (about 2.4 kB of joints each) are boxed, so a
/// message is 160 bytes, not 2.5 kB: a recording held in memory (the simulator's, a sorted
/// batch) and every move of a message (queues, output vectors) pay for what it holds. The
/// boxes do not show in files.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum Message {
    /// A camera skeleton.
    Skeleton(Box<SkeletonObservation>),
    /// An IMU sample.
    Imu(ImuSample),
    /// An RTLS position fix.
    RtlsFix(RtlsFix),
    /// A raw UWB range.
    UwbRange(UwbRange),
    /// An RSSI read.
    Rssi(RssiRead),
    /// Engine output: an identified skeleton.
    Identified(Box<IdentifiedSkeleton>),
    /// Engine output: a corrected tag position.
    TagCorrection(TagCorrection),
    /// Ground truth for a skeleton observation.
    TruthSkeleton(Box<TruthSkeleton>),
    /// Ground truth for a tag fix.
    TruthTag(TruthTag),
}

impl From<SkeletonObservation> for Message {
    fn from(m: SkeletonObservation) -> Self {
        Message::Skeleton(Box::new(m))
    }
}

impl From<IdentifiedSkeleton> for Message {
    fn from(m: IdentifiedSkeleton) -> Self {
        Message::Identified(Box::new(m))
    }
}

impl From<TruthSkeleton> for Message {
    fn from(m: TruthSkeleton) -> Self {
        Message::TruthSkeleton(Box::new(m))
    }
}

impl Message {
    /// The message's time on the session clock.
    pub fn t(&self) -> SessionTime {
        match self {
            Message::Skeleton(m) => m.t,
            Message::Imu(m) => m.t,
            Message::RtlsFix(m) => m.t,
            Message::UwbRange(m) => m.t,
            Message::Rssi(m) => m.t,
            Message::Identified(m) => m.t,
            Message::TagCorrection(m) => m.t,
            Message::TruthSkeleton(m) => m.t,
            Message::TruthTag(m) => m.t,
        }
    }

    /// The `type` tag as written in files.
    pub fn type_name(&self) -> &'static str {
        match self {
            Message::Skeleton(_) => "skeleton",
            Message::Imu(_) => "imu",
            Message::RtlsFix(_) => "rtls_fix",
            Message::UwbRange(_) => "uwb_range",
            Message::Rssi(_) => "rssi",
            Message::Identified(_) => "identified",
            Message::TagCorrection(_) => "tag_correction",
            Message::TruthSkeleton(_) => "truth_skeleton",
            Message::TruthTag(_) => "truth_tag",
        }
    }

    /// Checks the message's own values (finiteness, units sanity, a time within
    /// [`crate::time::MAX_ABS_SESSION_TIME_S`] of the session's origin). Cross-message checks
    /// (known ids, monotonic time) belong to readers.
    pub fn validate(&self) -> Result<()> {
        // The sensor messages' own checks include the time.
        if !matches!(
            self,
            Message::Skeleton(_)
                | Message::Imu(_)
                | Message::RtlsFix(_)
                | Message::UwbRange(_)
                | Message::Rssi(_)
        ) {
            self.t().check_plausible()?;
        }
        match self {
            Message::Skeleton(m) => m.validate(),
            Message::Imu(m) => m.validate(),
            Message::RtlsFix(m) => m.validate(),
            Message::UwbRange(m) => m.validate(),
            Message::Rssi(m) => m.validate(),
            Message::Identified(m) => {
                check_range("confidence", m.confidence, 0.0, 1.0, "")?;
                for (i, e) in m.evidence.iter().enumerate() {
                    check_finite_all_lazy(|| format!("evidence[{i}].score"), &[e.score])?;
                }
                if let Some(d) = &m.decision {
                    for (name, c) in [
                        ("decision.named", &d.named),
                        ("decision.runner_up", &d.runner_up),
                    ] {
                        if let Some(c) = c {
                            check_finite_all_lazy(|| format!("{name}.score"), &[c.score])?;
                        }
                    }
                }
                // The joints follow the skeleton rules (finite, plausible, finite covariance).
                SkeletonObservation {
                    t: m.t,
                    camera: m.camera.clone(),
                    track: m.track,
                    joints: m.joints.clone(),
                }
                .validate()
            }
            Message::TagCorrection(m) => {
                check_finite_all("raw_position_m", m.raw_position_m.coords.as_slice())?;
                check_finite_all(
                    "corrected_position_m",
                    m.corrected_position_m.coords.as_slice(),
                )
            }
            Message::TruthSkeleton(m) => {
                for (j, p) in m.joints_world_m.iter() {
                    check_finite_all_lazy(|| format!("joints_world_m.{j}"), p.coords.as_slice())?;
                }
                Ok(())
            }
            Message::TruthTag(m) => check_finite_all("position_m", m.position_m.coords.as_slice()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::skeleton::Joint;
    use nalgebra::Vector3;

    #[test]
    fn a_message_stays_small_whatever_its_skeleton_holds() {
        // The skeleton variants are boxed: an unboxed one made every message 2.5 kB.
        assert!(std::mem::size_of::<Message>() <= 256);
        assert!(std::mem::size_of::<SkeletonObservation>() > 1024);
    }

    #[test]
    fn messages_are_type_tagged_and_round_trip() {
        let mut joints = Joints::new();
        joints.insert(
            Joint::RightWrist,
            JointObservation::tracked(Point3::new(0.1, 0.2, 1.0)),
        );
        let msgs = vec![
            Message::Skeleton(Box::new(SkeletonObservation {
                t: SessionTime(33_000_000),
                camera: CameraId::new("kinect"),
                track: TrackId(7),
                joints,
            })),
            Message::Imu(ImuSample {
                t: SessionTime(1),
                device: DeviceId::new("band"),
                accel_mps2: Vector3::new(0.0, 0.0, 9.81),
                gyro_radps: Some(Vector3::zeros()),
                mag_ut: None,
                orientation_wxyz: None,
            }),
            Message::Identified(Box::new(IdentifiedSkeleton {
                t: SessionTime(2),
                camera: CameraId::new("kinect"),
                track: TrackId(7),
                identity: Identity::Anonymous,
                confidence: 0.5,
                evidence: vec![],
                decision: Some(DecisionTrace {
                    rule: DecisionRule::BelowThreshold,
                    decided_at: SessionTime(3),
                    named: None,
                    runner_up: Some(Candidate {
                        subject: SubjectId::new("ana"),
                        score: 0.1,
                    }),
                }),
                joints: Joints::new(),
            })),
        ];
        for m in &msgs {
            let line = serde_json::to_string(m).unwrap();
            assert!(
                line.starts_with(&format!("{{\"type\":\"{}\"", m.type_name())),
                "{line}"
            );
            let back: Message = serde_json::from_str(&line).unwrap();
            assert_eq!(&back, m);
        }
        let s = serde_json::to_string(&msgs[0]).unwrap();
        assert!(
            s.contains(r#""right_wrist":{"position_m":[0.1,0.2,1.0]"#),
            "{s}"
        );
        for rule in DecisionRule::ALL {
            assert_eq!(
                serde_json::to_string(&rule).unwrap(),
                format!("\"{}\"", rule.as_str())
            );
        }
        let id = serde_json::to_string(&Identity::Subject(SubjectId::new("ana"))).unwrap();
        assert_eq!(id, r#"{"subject":"ana"}"#);
        assert_eq!(
            serde_json::to_string(&Identity::Anonymous).unwrap(),
            r#""anonymous""#
        );
    }
}
