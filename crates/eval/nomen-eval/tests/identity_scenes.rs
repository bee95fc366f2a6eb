//! Identity evaluator on hand-built scenes. Every expected value is derived in the comments from
//! how the scene is built.

// Helpers outside #[test] functions unwrap too: a failure there is a test failure.
#![allow(clippy::unwrap_used)]

use nalgebra::Point3;
use nomen_core::skeleton::Joints;
use nomen_core::{
    CameraId, DecisionRule, DecisionTrace, IdentifiedSkeleton, Identity, Joint, Message,
    SessionTime, SubjectId, TagCorrection, TagId, TrackId, TruthSkeleton, TruthTag,
};
use nomen_eval::identity::{EvalConfig, EvalReport, SceneData, evaluate};

const FPS: f64 = 30.0;

/// Time of frame `k` at 30 fps, rounded to the nanosecond.
fn frame_t(k: u32) -> SessionTime {
    SessionTime::from_secs_f64(f64::from(k) / FPS).unwrap()
}

fn truth(k: u32, track: u64, person: &str, subject: Option<&str>, x_m: f64) -> Message {
    let mut joints = Joints::new();
    joints.insert(Joint::Pelvis, Point3::new(x_m, 0.0, 1.0));
    Message::TruthSkeleton(Box::new(TruthSkeleton {
        t: frame_t(k),
        camera: CameraId::new("cam"),
        track: TrackId(track),
        person: person.into(),
        subject: subject.map(SubjectId::new),
        joints_world_m: joints,
    }))
}

fn label(k: u32, track: u64, subject: Option<&str>) -> Message {
    Message::Identified(Box::new(IdentifiedSkeleton {
        t: frame_t(k),
        camera: CameraId::new("cam"),
        track: TrackId(track),
        identity: subject.map_or(Identity::Anonymous, |s| {
            Identity::Subject(SubjectId::new(s))
        }),
        confidence: 0.9,
        evidence: vec![],
        decision: None,
        joints: Joints::new(),
    }))
}

fn run(truth: &[Message], result: &[Message], config: &EvalConfig) -> EvalReport {
    evaluate(&[SceneData::from_messages("scene", truth, result)], config).unwrap()
}

fn close(a: Option<f64>, b: f64) -> bool {
    a.is_some_and(|a| (a - b).abs() < 1e-9)
}

#[test]
fn perfect_labels_give_full_accuracy_and_no_switches() {
    // ana (track 1) and bob (track 2) labelled correctly, eve (track 3, wears nothing) left
    // anonymous, for 30 frames.
    let (mut t, mut r) = (Vec::new(), Vec::new());
    for k in 0..30 {
        t.push(truth(k, 1, "ana", Some("ana"), 0.0));
        t.push(truth(k, 2, "bob", Some("bob"), 3.0));
        t.push(truth(k, 3, "eve", None, 6.0));
        r.push(label(k, 1, Some("ana")));
        r.push(label(k, 2, Some("bob")));
        r.push(label(k, 3, None));
    }
    let m = run(&t, &r, &EvalConfig::default()).overall;
    assert_eq!(m.num_frames, 90);
    assert_eq!(m.id_accuracy, Some(1.0));
    assert_eq!(m.id_switches, 0);
    assert_eq!(m.false_identities, 0);
    assert_eq!(m.intruder_anonymous_rate, Some(1.0));
    assert_eq!(
        (m.ca, m.cna, m.na, m.incorrect),
        (Some(1.0), Some(1.0), Some(0.0), Some(0.0))
    );
    assert_eq!(m.delay_frames, Some(0.0));
    assert_eq!(m.time_to_identify_s, Some(0.0));
    assert_eq!(m.time_to_identify.num_appearances, 2); // ana and bob, one each
    assert_eq!((m.idf1, m.mota, m.motp), (Some(1.0), Some(1.0), Some(0.0)));
    assert_eq!(m.mot.as_ref().unwrap().num_switches, 0);
    assert_eq!((m.num_unlabelled, m.num_result_without_truth), (0, 0));
    assert_eq!(m.tag_rmse_raw_m, None); // no tags in this scene
}

/// ana (track 1, x = 0) and bob (track 2, x = `bob_x_m`) for 20 frames; labels right for frames
/// 0..10 and swapped for frames 10..20.
fn swap_scene(bob_x_m: f64) -> (Vec<Message>, Vec<Message>) {
    let (mut t, mut r) = (Vec::new(), Vec::new());
    for k in 0..20 {
        t.push(truth(k, 1, "ana", Some("ana"), 0.0));
        t.push(truth(k, 2, "bob", Some("bob"), bob_x_m));
        let swapped = k >= 10;
        r.push(label(k, 1, Some(if swapped { "bob" } else { "ana" })));
        r.push(label(k, 2, Some(if swapped { "ana" } else { "bob" })));
    }
    (t, r)
}

#[test]
fn a_label_swap_mid_scene_is_two_switches_and_half_accuracy() {
    let (t, r) = swap_scene(3.0);
    let m = run(&t, &r, &EvalConfig::default()).overall;
    // 20 of 40 frames right; each person's label changes once (ana -> bob, bob -> ana).
    assert_eq!(m.id_accuracy, Some(0.5));
    assert_eq!(m.id_switches, 2);
    assert_eq!(m.per_subject["ana"].id_switches, 1);
    // The 20 swapped frames carry a wrong subject.
    assert_eq!(m.false_identities, 20);
    assert_eq!(m.false_identities_on_intruders, 0);
    // Each subject's label is on its wearer for 10 of 20 frames and 3 m away (> 1 m) for 10.
    assert_eq!((m.ca, m.cna, m.na), (Some(0.5), Some(0.5), Some(0.0)));
    assert_eq!(m.incorrect, Some(0.5));
    // MOT: at frame 10 each object pairs with the other label: two SWITCH events. The best
    // global id assignment keeps 10 of each object's 20 frames: IDF1 = 2*20/(40+40) = 0.5.
    let mot = m.mot.as_ref().unwrap();
    assert_eq!(mot.num_switches, 2);
    assert_eq!(m.idf1, Some(0.5));
    // MOTA = 1 - (0 misses + 2 switches + 0 FP) / 40 objects.
    assert!(close(m.mota, 1.0 - 2.0 / 40.0));
    // The correct label does not hold to the end of the appearance: no delay.
    assert_eq!(m.delay_frames, None);
    assert_eq!(m.delay.num_never_held, 2);
    // But it was right from the first frame.
    assert_eq!(m.time_to_identify_s, Some(0.0));
}

#[test]
fn a_swap_between_close_people_is_near_but_not_correct() {
    // bob 0.5 m from ana (within the 1 m near distance): the swapped frames are CNA, not CA.
    let (t, r) = swap_scene(0.5);
    let m = run(&t, &r, &EvalConfig::default()).overall;
    assert_eq!(
        (m.ca, m.cna, m.na, m.incorrect),
        (Some(0.5), Some(1.0), Some(0.0), Some(0.0))
    );
}

#[test]
fn a_hold_window_lets_the_delay_stop_before_the_swap() {
    // With a 0.2 s hold, frame 0 is followed by correct frames up to frame 9 (0.3 s): delay 0.
    let (t, r) = swap_scene(3.0);
    let config = EvalConfig {
        delay_hold_s: Some(0.2),
        ..EvalConfig::default()
    };
    let m = run(&t, &r, &config).overall;
    assert_eq!(m.delay_frames, Some(0.0));
    assert_eq!(m.delay.num_never_held, 0);
}

#[test]
fn an_intruder_labelled_with_a_subject_is_a_false_identity() {
    // ana (track 1) labelled right for 10 frames; eve (track 2, wears nothing) labelled "ana" in
    // frames 5..10 and anonymous before.
    let (mut t, mut r) = (Vec::new(), Vec::new());
    for k in 0..10 {
        t.push(truth(k, 1, "ana", Some("ana"), 0.0));
        t.push(truth(k, 2, "eve", None, 4.0));
        r.push(label(k, 1, Some("ana")));
        r.push(label(k, 2, if k >= 5 { Some("ana") } else { None }));
    }
    let m = run(&t, &r, &EvalConfig::default()).overall;
    assert_eq!(m.false_identities, 5);
    assert_eq!(m.false_identities_on_intruders, 5);
    assert_eq!(m.per_subject["ana"].num_false_identities_as, 5);
    // eve: 5 of 10 frames anonymous.
    assert_eq!(m.intruder_anonymous_rate, Some(0.5));
    assert_eq!(m.anonymous_people.num_wrong_subject, 5);
    // 10 (ana) + 5 (eve) right of 20.
    assert_eq!(m.id_accuracy, Some(0.75));
    // ana's label is on ana in every frame (also on eve in 5): CA = 1.
    assert_eq!(m.ca, Some(1.0));
    // MOT: the second "ana" label is an extra hypothesis, a false positive in 5 frames:
    // MOTA = 1 - 5 / 10.
    assert_eq!(m.data_issues.num_duplicate_labels, 5);
    assert_eq!(m.mot.as_ref().unwrap().num_false_positives, 5);
    assert!(close(m.mota, 0.5));
}

#[test]
fn a_wearer_anonymous_for_12_frames_is_identified_after_0_4_s() {
    // 30 frames at 30 fps, anonymous for frames 0..12 then right.
    let (mut t, mut r) = (Vec::new(), Vec::new());
    for k in 0..30 {
        t.push(truth(k, 1, "ana", Some("ana"), 0.0));
        r.push(label(k, 1, (k >= 12).then_some("ana")));
    }
    let report = run(&t, &r, &EvalConfig::default());
    let m = &report.overall;
    // First correct frame is frame 12, and it stays correct: delay 12 frames, 12/30 = 0.4 s.
    assert_eq!(m.delay_frames, Some(12.0));
    assert!(close(m.time_to_identify_s, 0.4));
    // 12 of 30 frames have no association.
    assert!(close(m.na, 0.4));
    assert!(close(m.ca, 0.6));
    assert!(close(m.id_accuracy, 0.6));
    assert_eq!(m.id_switches, 0); // anonymous frames are skipped, never a switch
    let appearance = &report.per_scene["scene"].appearances[0];
    assert_eq!(appearance.delay_frames, Some(12));
    assert_eq!(appearance.num_frames, 30);
    // Over time: bin 0 ([0, 1) s) holds all 30 frames.
    assert_eq!(m.over_time.len(), 1);
    assert_eq!(m.over_time[0].num_correct, 18);
}

#[test]
fn a_name_given_to_frames_by_a_later_decision_counts_from_that_decision() {
    // 30 frames at 30 fps, all named right, but by a decision made at frame 18 (0.6 s): the
    // name is known from 0.6 s, not from the first frame. Frames after 18 carry a decision made
    // at their own time, so the earliest time the name is known is 0.6 s.
    let (mut t, mut r) = (Vec::new(), Vec::new());
    for k in 0..30 {
        t.push(truth(k, 1, "ana", Some("ana"), 0.0));
        let mut m = label(k, 1, Some("ana"));
        if let Message::Identified(id) = &mut m {
            id.decision = Some(DecisionTrace {
                rule: DecisionRule::Assigned,
                decided_at: frame_t(k.max(18)),
                named: None,
                runner_up: None,
            });
        }
        r.push(m);
    }
    let m = run(&t, &r, &EvalConfig::default()).overall;
    assert!(close(m.time_to_identify_s, 0.6));
    // The frames themselves are right: accuracy and Llorca's delay count labels, not timing.
    assert!(close(m.id_accuracy, 1.0));
    assert_eq!(m.delay_frames, Some(0.0));
}

#[test]
fn a_person_who_leaves_and_comes_back_has_two_appearances() {
    // ana seen in frames 0..10 (0 to 0.3 s), gone, seen again in frames 75..85 (2.5 s on: a
    // 2.2 s gap, more than the 1 s reappearance gap). Right at once the first time; anonymous
    // for the first 3 frames (0.1 s) the second time.
    let (mut t, mut r) = (Vec::new(), Vec::new());
    for k in (0..10).chain(75..85) {
        t.push(truth(k, 1, "ana", Some("ana"), 0.0));
        r.push(label(k, 1, (!(10..78).contains(&k)).then_some("ana")));
    }
    let report = run(&t, &r, &EvalConfig::default());
    let appearances = &report.per_scene["scene"].appearances;
    assert_eq!(appearances.len(), 2);
    assert_eq!(appearances[0].time_to_identify_s, Some(0.0));
    assert!(close(appearances[1].time_to_identify_s, 0.1));
    assert_eq!(appearances[1].delay_frames, Some(3));
    let m = &report.overall;
    assert_eq!(m.per_subject["ana"].num_appearances, 2);
    // Median and mean of {0, 0.1}.
    assert!(close(m.time_to_identify_s, 0.05));
    assert!(close(m.time_to_identify.mean_s, 0.05));
    // Mean delay of {0, 3} frames.
    assert_eq!(m.delay_frames, Some(1.5));
    // The gap needs to reach 1 s: with a 3 s reappearance gap it is one appearance.
    let one = run(
        &t,
        &r,
        &EvalConfig {
            reappearance_gap_s: 3.0,
            ..EvalConfig::default()
        },
    );
    assert_eq!(one.per_scene["scene"].appearances.len(), 1);
}

#[test]
fn a_never_identified_appearance_is_counted() {
    let (mut t, mut r) = (Vec::new(), Vec::new());
    for k in 0..10 {
        t.push(truth(k, 1, "ana", Some("ana"), 0.0));
        r.push(label(k, 1, None));
    }
    let m = run(&t, &r, &EvalConfig::default()).overall;
    assert_eq!(m.time_to_identify.num_never_identified, 1);
    assert_eq!(m.time_to_identify_s, None);
    assert_eq!(m.per_subject["ana"].num_never_identified, 1);
    assert_eq!(m.na, Some(1.0));
}

fn tag_fix(
    k: u32,
    tag: &str,
    truth_m: Point3<f64>,
    raw_off: [f64; 3],
    corr_off: [f64; 3],
) -> [Message; 2] {
    let off = |o: [f64; 3]| truth_m + nalgebra::Vector3::from(o);
    [
        Message::TruthTag(TruthTag {
            t: frame_t(k),
            tag: TagId::new(tag),
            position_m: truth_m,
        }),
        Message::TagCorrection(TagCorrection {
            t: frame_t(k),
            tag: TagId::new(tag),
            raw_position_m: off(raw_off),
            corrected_position_m: off(corr_off),
        }),
    ]
}

#[test]
fn tag_rmse_measures_the_constructed_offsets() {
    // "band": raw 0.3 m off along x, corrected 0.1 m off along y, 10 fixes.
    // "belt": raw 0.4 m off along y, corrected 0.2 m off along z, 10 fixes.
    let mut msgs = Vec::new();
    for k in 0..10 {
        let p = Point3::new(0.1 * f64::from(k), 1.0, 1.0);
        msgs.extend(tag_fix(k, "band", p, [0.3, 0.0, 0.0], [0.0, 0.1, 0.0]));
        msgs.extend(tag_fix(k, "belt", p, [0.0, 0.4, 0.0], [0.0, 0.0, 0.2]));
    }
    // A correction without truth at its time, and one with a NaN: counted, not used.
    msgs.push(Message::TagCorrection(TagCorrection {
        t: frame_t(100),
        tag: TagId::new("band"),
        raw_position_m: Point3::origin(),
        corrected_position_m: Point3::origin(),
    }));
    msgs.push(Message::TagCorrection(TagCorrection {
        t: frame_t(101),
        tag: TagId::new("band"),
        raw_position_m: Point3::new(f64::NAN, 0.0, 0.0),
        corrected_position_m: Point3::origin(),
    }));
    let m = run(&msgs, &[], &EvalConfig::default()).overall;
    let band = &m.tags.per_tag["band"];
    assert_eq!(band.num_samples, 10);
    assert!(close(band.rmse_raw_m, 0.3));
    assert!(close(band.rmse_corrected_m, 0.1));
    // Pooled: sqrt((10·0.3² + 10·0.4²) / 20) = sqrt(0.125); sqrt((10·0.1² + 10·0.2²) / 20).
    assert!(close(m.tag_rmse_raw_m, 0.125_f64.sqrt()));
    assert!(close(m.tag_rmse_corrected_m, 0.025_f64.sqrt()));
    assert_eq!(m.tags.pooled.raw_errors_m.len(), 20);
    assert!(close(m.tags.pooled.raw_m.as_ref().map(|b| b.median), 0.35));
    assert_eq!(m.tags.num_corrections_without_truth, 1);
    assert_eq!(m.data_issues.num_nonfinite_tag_samples, 1);
}

#[test]
fn result_lines_without_truth_and_truth_without_result_are_counted() {
    // ana in frames 0..4, labelled in frames 0..3 only; a ghost track 9 labelled "ana" in
    // frame 0 and an anonymous ghost in frame 1.
    let mut t = Vec::new();
    let mut r = Vec::new();
    for k in 0..4 {
        t.push(truth(k, 1, "ana", Some("ana"), 0.0));
    }
    for k in 0..3 {
        r.push(label(k, 1, Some("ana")));
    }
    r.push(label(0, 9, Some("ana")));
    r.push(label(1, 9, None));
    let m = run(&t, &r, &EvalConfig::default()).overall;
    assert_eq!(m.num_result_without_truth, 2);
    assert_eq!(m.num_result_without_truth_labelled, 1);
    assert_eq!(m.num_unlabelled, 1);
    // The unlabelled frame counts as anonymous: 3 of 4 right.
    assert_eq!(m.id_accuracy, Some(0.75));
    assert_eq!(m.per_subject["ana"].identification.num_anonymous, 1);
    // The ghost's label is a false positive for MOT, not a false identity (no truth person).
    assert_eq!(m.false_identities, 0);
    // MOT: in frame 0 "ana" sits on ana (match) and its duplicate "ana#2" on the ghost (false
    // positive); in frame 3 ana has no label (miss).
    let mot = m.mot.as_ref().unwrap();
    assert_eq!((mot.num_false_positives, mot.num_misses), (1, 1));
}

#[test]
fn scenes_are_reported_separately_and_pooled() {
    // Scene a: 10 right frames; scene b: 10 anonymous frames of the same subject.
    let (mut ta, mut ra, mut tb, mut rb) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for k in 0..10 {
        ta.push(truth(k, 1, "ana", Some("ana"), 0.0));
        ra.push(label(k, 1, Some("ana")));
        tb.push(truth(k, 1, "ana", Some("ana"), 0.0));
        rb.push(label(k, 1, None));
    }
    let scenes = [
        SceneData::from_messages("a", &ta, &ra),
        SceneData::from_messages("b", &tb, &rb),
    ];
    let report = evaluate(&scenes, &EvalConfig::default()).unwrap();
    assert_eq!(report.per_scene["a"].metrics.id_accuracy, Some(1.0));
    assert_eq!(report.per_scene["b"].metrics.id_accuracy, Some(0.0));
    assert_eq!(report.overall.num_frames, 20);
    assert_eq!(report.overall.id_accuracy, Some(0.5));
    // MOT pooled: 10 matches of 20 objects, 10 misses: MOTA 0.5.
    assert!(close(report.overall.mota, 0.5));
    assert_eq!(report.overall.mot.as_ref().unwrap().num_frames, 20);
    let same_name = [
        SceneData::from_messages("a", &ta, &ra),
        SceneData::from_messages("a", &tb, &rb),
    ];
    let err = evaluate(&same_name, &EvalConfig::default()).unwrap_err();
    assert!(err.to_string().contains("scene `a`"), "{err}");
}

#[test]
fn the_json_report_has_the_documented_top_level_keys() {
    let t = [truth(0, 1, "ana", Some("ana"), 0.0)];
    let r = [label(0, 1, Some("ana"))];
    let report = run(&t, &r, &EvalConfig::default());
    let json = serde_json::to_value(&report).unwrap();
    let object = json.as_object().unwrap();
    for key in [
        "id_accuracy",
        "ca",
        "cna",
        "na",
        "delay_frames",
        "time_to_identify_s",
        "id_switches",
        "false_identities",
        "intruder_anonymous_rate",
        "idf1",
        "idp",
        "idr",
        "mota",
        "motp",
        "tag_rmse_raw_m",
        "tag_rmse_corrected_m",
        "num_frames",
        "per_scene",
        "per_subject",
        "over_time",
    ] {
        assert!(object.contains_key(key), "missing key {key}");
    }
    assert!(object["tag_rmse_raw_m"].is_null());
    assert!(object["intruder_anonymous_rate"].is_null());
    assert_eq!(object["id_accuracy"], 1.0);
    assert!(object["per_scene"]["scene"]["appearances"].is_array());
    let table = report.to_table();
    assert!(
        table.contains("id_accuracy") && table.contains("100.0%"),
        "{table}"
    );
}

#[test]
fn confidences_are_scored_against_whether_each_identity_was_right() {
    // Frames 0-9: ana (track 1) named ana, eve (track 2, wears nothing) named ana, both at the
    // helper's confidence 0.9; a result line for a track without truth (track 9), which no
    // confidence measure sees. Right: ana's 10 frames; wrong: eve's 10.
    let mut truth_msgs = Vec::new();
    let mut result = Vec::new();
    for k in 0..10 {
        truth_msgs.push(truth(k, 1, "p1", Some("ana"), 0.0));
        truth_msgs.push(truth(k, 2, "p2", None, 2.0));
        result.push(label(k, 1, Some("ana")));
        result.push(label(k, 2, Some("ana")));
        result.push(label(k, 9, None));
    }
    let report = run(&truth_msgs, &result, &EvalConfig::default());
    let c = &report.overall.confidence;
    assert_eq!(c.num_frames, 20);
    // One bin (0.9-1.0): mean confidence 0.9, half right.
    assert!(close(report.overall.confidence_ece, 0.4));
    // Brier: half the frames (0.9 - 1)², half 0.9².
    assert!(close(
        report.overall.confidence_brier,
        0.5 * 0.01 + 0.5 * 0.81
    ));
    assert_eq!(c.bins[9].num_frames, 20);
    // The samples for fitting: the same 20 frames, all named, eve's wrong.
    let scene = SceneData::from_messages("scene", &truth_msgs, &result);
    let samples = nomen_eval::identity::confidence_samples(&scene);
    assert_eq!(samples.len(), 20);
    assert_eq!(samples.iter().filter(|s| s.is_correct).count(), 10);
    assert!(samples.iter().all(|s| s.is_named && s.confidence == 0.9));
    // Eve left anonymous instead: right, and not named.
    let result: Vec<Message> = (0..10)
        .flat_map(|k| [label(k, 1, Some("ana")), label(k, 2, None)])
        .collect();
    let scene = SceneData::from_messages("scene", &truth_msgs, &result);
    let samples = nomen_eval::identity::confidence_samples(&scene);
    assert!(samples.iter().all(|s| s.is_correct));
    assert_eq!(samples.iter().filter(|s| !s.is_named).count(), 10);
}
