//! The identity metrics of `evaluate` against a brute-force count over generated scenes: every
//! definition of METRICS.md that is a plain count or ratio, recomputed here frame by frame.
// Test helpers outside #[test] functions unwrap too: a failure is a test failure.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use nalgebra::Point3;
use nomen_core::skeleton::Joints;
use nomen_core::{
    CameraId, IdentifiedSkeleton, Identity, Joint, Message, SessionTime, SubjectId, TrackId,
    TruthSkeleton,
};
use nomen_eval::identity::{EvalConfig, SceneData, evaluate};
use proptest::prelude::*;
use std::collections::BTreeMap;

/// What a result says about one truth frame: no line, `Anonymous`, or subject `sK` (K = 4 is
/// nobody's subject).
#[derive(Debug, Clone, Copy)]
enum Label {
    Missing,
    Anonymous,
    Subject(u8),
}

fn label() -> impl Strategy<Value = Label> {
    prop_oneof![
        1 => Just(Label::Missing),
        2 => Just(Label::Anonymous),
        5 => (0u8..5).prop_map(Label::Subject),
    ]
}

/// One truth frame: camera, frame index, person (its index is its track), the result's label.
#[derive(Debug, Clone, Copy)]
struct Frame {
    camera: u8,
    k: u32,
    person: u8,
    label: Label,
}

/// A scene: which people are intruders (no subject), the truth frames (one per person, camera
/// and frame at most) and result lines without truth (camera, frame, label).
#[derive(Debug, Clone)]
struct Scene {
    is_intruder: Vec<bool>,
    frames: Vec<Frame>,
    orphans: Vec<(u8, u32, Label)>,
}

fn scene() -> impl Strategy<Value = Scene> {
    (
        prop::collection::vec(prop::bool::weighted(0.3), 1..5),
        prop::collection::btree_map((0u8..2, 0u32..40, 0u8..4), label(), 0..120),
        prop::collection::vec((0u8..2, 0u32..40, label()), 0..6),
    )
        .prop_map(|(is_intruder, frames, orphans)| {
            let num_people = is_intruder.len() as u8;
            Scene {
                frames: frames
                    .into_iter()
                    .filter(|((_, _, person), _)| *person < num_people)
                    .map(|((camera, k, person), label)| Frame {
                        camera,
                        k,
                        person,
                        label,
                    })
                    .collect(),
                is_intruder,
                orphans,
            }
        })
}

const FRAME_NS: i64 = 33_333_333;
const ORPHAN_TRACK: u64 = 99;

fn subject_of(scene: &Scene, person: u8) -> Option<String> {
    (!scene.is_intruder[usize::from(person)]).then(|| format!("s{person}"))
}

fn identity(label: Label) -> Option<Identity> {
    match label {
        Label::Missing => None,
        Label::Anonymous => Some(Identity::Anonymous),
        Label::Subject(s) => Some(Identity::Subject(SubjectId::new(format!("s{s}")))),
    }
}

fn pelvis_at(x: f64) -> Joints<Point3<f64>> {
    let mut joints = Joints::new();
    joints.insert(Joint::Pelvis, Point3::new(x, 0.0, 1.0));
    joints
}

fn identified(camera: u8, k: u32, track: u64, identity: Identity) -> Message {
    Message::Identified(Box::new(IdentifiedSkeleton {
        t: SessionTime(i64::from(k) * FRAME_NS),
        camera: CameraId::new(format!("cam{camera}")),
        track: TrackId(track),
        identity,
        confidence: 0.5,
        evidence: Vec::new(),
        decision: None,
        joints: Joints::new(),
    }))
}

fn messages(scene: &Scene) -> (Vec<Message>, Vec<Message>) {
    let mut truth = Vec::new();
    let mut result = Vec::new();
    for f in &scene.frames {
        truth.push(Message::TruthSkeleton(Box::new(TruthSkeleton {
            t: SessionTime(i64::from(f.k) * FRAME_NS),
            camera: CameraId::new(format!("cam{}", f.camera)),
            track: TrackId(u64::from(f.person)),
            person: format!("p{}", f.person),
            subject: subject_of(scene, f.person).map(SubjectId::new),
            joints_world_m: pelvis_at(f64::from(f.person)),
        })));
        if let Some(id) = identity(f.label) {
            result.push(identified(f.camera, f.k, u64::from(f.person), id));
        }
    }
    for &(camera, k, label) in &scene.orphans {
        if let Some(id) = identity(label) {
            result.push(identified(camera, k, ORPHAN_TRACK, id));
        }
    }
    (truth, result)
}

/// The counts of METRICS.md, frame by frame.
#[derive(Debug, Default, PartialEq)]
struct Counts {
    num_frames: u64,
    num_correct: u64,
    false_identities: u64,
    false_identities_on_intruders: u64,
    num_unlabelled: u64,
    num_intruder_frames: u64,
    num_intruder_anonymous: u64,
    num_result_without_truth: u64,
    num_result_without_truth_labelled: u64,
    id_switches: u64,
}

fn brute_force(scene: &Scene) -> Counts {
    let mut c = Counts::default();
    // (person, camera) -> labels in time order (the frames come sorted by camera, k, person).
    let mut sequences: BTreeMap<(u8, u8), Vec<(u32, Label)>> = BTreeMap::new();
    for f in &scene.frames {
        let subject = subject_of(scene, f.person);
        c.num_frames += 1;
        let is_intruder = subject.is_none();
        c.num_intruder_frames += u64::from(is_intruder);
        match (f.label, &subject) {
            (Label::Missing, _) => {
                c.num_unlabelled += 1;
                c.num_correct += u64::from(is_intruder);
                c.num_intruder_anonymous += u64::from(is_intruder);
            }
            (Label::Anonymous, _) => {
                c.num_correct += u64::from(is_intruder);
                c.num_intruder_anonymous += u64::from(is_intruder);
            }
            (Label::Subject(s), Some(mine)) if format!("s{s}") == *mine => c.num_correct += 1,
            (Label::Subject(_), _) => {
                c.false_identities += 1;
                c.false_identities_on_intruders += u64::from(is_intruder);
            }
        }
        sequences
            .entry((f.person, f.camera))
            .or_default()
            .push((f.k, f.label));
    }
    for ((person, _), mut seq) in sequences {
        if subject_of(scene, person).is_none() {
            continue;
        }
        seq.sort_by_key(|&(k, _)| k);
        let labels: Vec<u8> = seq
            .iter()
            .filter_map(|&(_, l)| match l {
                Label::Subject(s) => Some(s),
                _ => None,
            })
            .collect();
        c.id_switches += labels.windows(2).filter(|w| w[0] != w[1]).count() as u64;
    }
    // Orphan result lines: one per (camera, frame) key, the first given kept.
    let mut seen = std::collections::BTreeSet::new();
    for &(camera, k, label) in &scene.orphans {
        if matches!(label, Label::Missing) || !seen.insert((camera, k)) {
            continue;
        }
        c.num_result_without_truth += 1;
        c.num_result_without_truth_labelled += u64::from(matches!(label, Label::Subject(_)));
    }
    c
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn identity_metrics_equal_a_frame_by_frame_count(scene in scene()) {
        let (truth, result) = messages(&scene);
        let data = SceneData::from_messages("generated", &truth, &result);
        let report = evaluate(&[data], &EvalConfig::default()).unwrap();
        let m = &report.overall;
        let want = brute_force(&scene);

        prop_assert_eq!(m.num_frames, want.num_frames);
        prop_assert_eq!(m.identification.num_correct, want.num_correct);
        prop_assert_eq!(m.false_identities, want.false_identities);
        prop_assert_eq!(m.false_identities_on_intruders, want.false_identities_on_intruders);
        prop_assert_eq!(m.num_unlabelled, want.num_unlabelled);
        prop_assert_eq!(m.num_result_without_truth, want.num_result_without_truth);
        prop_assert_eq!(
            m.num_result_without_truth_labelled,
            want.num_result_without_truth_labelled
        );
        prop_assert_eq!(m.id_switches, want.id_switches);
        let ratio = |a: u64, b: u64| (b > 0).then(|| a as f64 / b as f64);
        prop_assert_eq!(m.id_accuracy, ratio(want.num_correct, want.num_frames));
        prop_assert_eq!(
            m.intruder_anonymous_rate,
            ratio(want.num_intruder_anonymous, want.num_intruder_frames)
        );
    }
}
