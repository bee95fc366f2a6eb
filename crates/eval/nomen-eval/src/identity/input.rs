//! The evaluator's input: one scene's truth and result messages, reduced to what the metrics use.

use nalgebra::Point3;
use nomen_core::skeleton::Joints;
use nomen_core::{CameraId, Identity, Joint, Message, SessionTime, SubjectId, TagId, TrackId};

/// One truth skeleton-frame: a person seen by a camera at an instant.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct TruthFrame {
    pub t: SessionTime,
    pub camera: CameraId,
    pub track: TrackId,
    pub person: String,
    pub subject: Option<SubjectId>,
    /// The person's reference point for "near" (pelvis, else joint centroid), world, metres.
    pub anchor_m: Option<Point3<f64>>,
}

/// One result line: the identity nomen gave a camera skeleton.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct ResultLabel {
    pub t: SessionTime,
    pub camera: CameraId,
    pub track: TrackId,
    /// `None` for [`Identity::Anonymous`].
    pub subject: Option<SubjectId>,
    /// The result's confidence in that identity.
    pub confidence: f64,
    /// When the label was known: the later of the frame's time and the time of the decision
    /// that gave it (a result may label a frame with a decision made after it).
    pub known_at: SessionTime,
}

/// A tag position: true, or raw and corrected.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct TagTruth {
    pub t: SessionTime,
    pub tag: TagId,
    pub position_m: Point3<f64>,
}

/// A tag correction from the result.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct TagFix {
    pub t: SessionTime,
    pub tag: TagId,
    pub raw_m: Point3<f64>,
    pub corrected_m: Point3<f64>,
}

/// One named scene: its truth and its result, collected from [`Message`]s.
///
/// Messages are routed by their type, whichever stream they come from:
/// [`Message::TruthSkeleton`] and [`Message::TruthTag`] are truth,
/// [`Message::Identified`] and [`Message::TagCorrection`] are result; every other message
/// (sensor input) is counted in `num_ignored_messages` and otherwise ignored.
/// Non-finite values are not errors: a non-finite truth joint is left out of the reference point,
/// a tag sample with a non-finite coordinate is left out of the errors; both are counted.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SceneData {
    pub(crate) name: String,
    pub(crate) truth: Vec<TruthFrame>,
    pub(crate) results: Vec<ResultLabel>,
    pub(crate) tag_truth: Vec<TagTruth>,
    pub(crate) tag_fixes: Vec<TagFix>,
    pub(crate) num_ignored_messages: u64,
    pub(crate) num_nonfinite_joints: u64,
    pub(crate) num_nonfinite_tag_samples: u64,
}

impl SceneData {
    /// An empty scene called `name`.
    pub fn new(name: impl Into<String>) -> Self {
        Self {
            name: name.into(),
            ..Self::default()
        }
    }

    /// A scene from its truth and result messages (routed by type, see [`SceneData`]).
    pub fn from_messages<'a>(
        name: impl Into<String>,
        truth: impl IntoIterator<Item = &'a Message>,
        result: impl IntoIterator<Item = &'a Message>,
    ) -> Self {
        let mut scene = Self::new(name);
        scene.extend(truth);
        scene.extend(result);
        scene
    }

    /// The scene's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Number of truth skeleton-frames taken so far (duplicates included).
    pub fn num_truth_skeletons(&self) -> usize {
        self.truth.len()
    }

    /// Number of result lines (identified skeletons) taken so far (duplicates included).
    pub fn num_identified(&self) -> usize {
        self.results.len()
    }

    /// Takes one message.
    pub fn push(&mut self, message: &Message) {
        match message {
            Message::TruthSkeleton(m) => {
                let (anchor_m, num_nonfinite) = reference_point(&m.joints_world_m);
                self.num_nonfinite_joints += num_nonfinite;
                self.truth.push(TruthFrame {
                    t: m.t,
                    camera: m.camera.clone(),
                    track: m.track,
                    person: m.person.clone(),
                    subject: m.subject.clone(),
                    anchor_m,
                });
            }
            Message::Identified(m) => self.results.push(ResultLabel {
                t: m.t,
                camera: m.camera.clone(),
                track: m.track,
                subject: match &m.identity {
                    Identity::Subject(s) => Some(s.clone()),
                    Identity::Anonymous => None,
                },
                confidence: m.confidence,
                known_at: m.decision.as_ref().map_or(m.t, |d| d.decided_at.max(m.t)),
            }),
            Message::TruthTag(m) => {
                if is_finite(&m.position_m) {
                    self.tag_truth.push(TagTruth {
                        t: m.t,
                        tag: m.tag.clone(),
                        position_m: m.position_m,
                    });
                } else {
                    self.num_nonfinite_tag_samples += 1;
                }
            }
            Message::TagCorrection(m) => {
                if is_finite(&m.raw_position_m) && is_finite(&m.corrected_position_m) {
                    self.tag_fixes.push(TagFix {
                        t: m.t,
                        tag: m.tag.clone(),
                        raw_m: m.raw_position_m,
                        corrected_m: m.corrected_position_m,
                    });
                } else {
                    self.num_nonfinite_tag_samples += 1;
                }
            }
            Message::Skeleton(_)
            | Message::Imu(_)
            | Message::RtlsFix(_)
            | Message::UwbRange(_)
            | Message::Rssi(_) => self.num_ignored_messages += 1,
        }
    }
}

impl<'a> Extend<&'a Message> for SceneData {
    fn extend<T: IntoIterator<Item = &'a Message>>(&mut self, iter: T) {
        for m in iter {
            self.push(m);
        }
    }
}

impl Extend<Message> for SceneData {
    fn extend<T: IntoIterator<Item = Message>>(&mut self, iter: T) {
        for m in iter {
            self.push(&m);
        }
    }
}

fn is_finite(p: &Point3<f64>) -> bool {
    p.coords.iter().all(|v| v.is_finite())
}

/// A person's reference point for the "near" test: the pelvis if present and finite, else the
/// centroid of the finite joints, else `None`. Also returns the number of non-finite joints.
fn reference_point(joints: &Joints<Point3<f64>>) -> (Option<Point3<f64>>, u64) {
    let mut sum = nalgebra::Vector3::zeros();
    let (mut num_finite, mut num_nonfinite) = (0u32, 0u64);
    for (_, p) in joints.iter() {
        if is_finite(p) {
            sum += p.coords;
            num_finite += 1;
        } else {
            num_nonfinite += 1;
        }
    }
    let pelvis = joints.get(Joint::Pelvis).filter(|p| is_finite(p)).copied();
    let centroid = (num_finite > 0).then(|| Point3::from(sum / f64::from(num_finite)));
    (pelvis.or(centroid), num_nonfinite)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nomen_core::{TruthSkeleton, TruthTag};

    #[test]
    fn reference_point_is_the_pelvis_else_the_centroid() {
        let mut joints = Joints::new();
        joints.insert(Joint::Head, Point3::new(0.0, 0.0, 1.7));
        joints.insert(Joint::LeftFoot, Point3::new(0.0, 0.0, 0.1));
        joints.insert(Joint::RightFoot, Point3::new(f64::NAN, 0.0, 0.1));
        let (p, bad) = reference_point(&joints);
        assert_eq!(p, Some(Point3::new(0.0, 0.0, 0.9)));
        assert_eq!(bad, 1);
        joints.insert(Joint::Pelvis, Point3::new(1.0, 2.0, 1.0));
        assert_eq!(reference_point(&joints).0, Some(Point3::new(1.0, 2.0, 1.0)));
        assert_eq!(reference_point(&Joints::new()).0, None);
    }

    #[test]
    fn messages_are_routed_by_type_and_others_are_counted() {
        let truth = [
            Message::TruthSkeleton(Box::new(TruthSkeleton {
                t: SessionTime(0),
                camera: CameraId::new("cam"),
                track: TrackId(1),
                person: "p".into(),
                subject: None,
                joints_world_m: Joints::new(),
            })),
            Message::TruthTag(TruthTag {
                t: SessionTime(0),
                tag: TagId::new("tag"),
                position_m: Point3::new(f64::NAN, 0.0, 0.0),
            }),
        ];
        let scene = SceneData::from_messages("s", &truth, &[]);
        assert_eq!(scene.num_truth_skeletons(), 1);
        assert_eq!(scene.num_nonfinite_tag_samples, 1);
        assert_eq!(scene.num_ignored_messages, 0);
    }
}
