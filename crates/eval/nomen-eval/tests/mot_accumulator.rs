//! Hand-built accumulator scenarios whose events and metrics are derived by reasoning from
//! py-motmetrics' rules (see `MotAccumulator`), not copied from any output.

use nomen_eval::EvalError;
use nomen_eval::mot::{MotAccumulator, MotAccumulatorConfig, MotEventKind};

const NAN: f64 = f64::NAN;

/// Non-RAW events as `(frame, kind, oid, hid)`.
fn mot_events<I>(acc: &MotAccumulator<I>) -> Vec<(i64, &'static str, Option<I>, Option<I>)>
where
    I: Clone + Ord + std::fmt::Debug,
{
    acc.mot_events()
        .map(|e| (e.frame, e.kind.as_str(), e.oid.clone(), e.hid.clone()))
        .collect()
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-12
}

#[test]
fn switch_to_a_new_hypothesis_ascends_and_previous_match_is_kept() {
    let mut acc = MotAccumulator::<i64>::default();
    acc.update(0, &[1], &[10], &[0.1]).unwrap();
    acc.update(1, &[1], &[10], &[0.2]).unwrap();
    // Hypothesis 10 vanishes; 11, never matched before, takes object 1 over.
    acc.update(2, &[1], &[11], &[0.3]).unwrap();
    // 10 is back and closer, but object 1 keeps its current hypothesis 11.
    acc.update(3, &[1], &[10, 11], &[0.05, 0.3]).unwrap();
    assert_eq!(
        mot_events(&acc),
        vec![
            (0, "MATCH", Some(1), Some(10)),
            (1, "MATCH", Some(1), Some(10)),
            (2, "ASCEND", Some(1), Some(11)),
            (2, "SWITCH", Some(1), Some(11)),
            (3, "MATCH", Some(1), Some(11)),
            (3, "FP", None, Some(10)),
        ]
    );
    let m = acc.metrics().unwrap();
    assert_eq!((m.num_matches, m.num_switches, m.num_ascend), (3, 1, 1));
    assert_eq!(
        (m.num_objects, m.num_predictions, m.num_false_positives),
        (4, 5, 1)
    );
    // 1 - (0 misses + 1 switch + 1 fp) / 4 objects.
    assert_eq!(m.mota, 0.5);
    assert!(close(m.motp, (0.1 + 0.2 + 0.3 + 0.3) / 4.0));
    // Identity: object 1 is present 4 times, pairable with 10 in 3 frames (0, 1, 3) and with
    // 11 in 2 (2, 3); the best id mapping is 1 <-> 10: idtp 3, idfn 4 - 3, idfp 5 - 3.
    assert_eq!((m.idtp, m.idfn, m.idfp), (3, 1, 2));
    assert!(close(m.idf1, 6.0 / 9.0));
    assert!(close(m.idp, 3.0 / 5.0) && close(m.idr, 3.0 / 4.0));
    assert_eq!((m.mostly_tracked, m.num_fragmentations), (1, 0));
}

#[test]
fn hypothesis_moving_between_objects_is_a_transfer() {
    let mut acc = MotAccumulator::<i64>::default();
    acc.update(0, &[1, 2], &[10, 20], &[0.1, NAN, NAN, 0.1])
        .unwrap();
    // Object 1 leaves, object 3 arrives. 2 can only pair with 10 (was 1's), 3 only with 20
    // (was 2's).
    acc.update(1, &[2, 3], &[10, 20], &[0.2, NAN, NAN, 0.2])
        .unwrap();
    assert_eq!(
        mot_events(&acc),
        vec![
            (0, "MATCH", Some(1), Some(10)),
            (0, "MATCH", Some(2), Some(20)),
            // 2 changes hypothesis (switch, 10 was matched before: no ascend) and 10 changes
            // object (transfer, 2 was matched before: no migrate).
            (1, "TRANSFER", Some(2), Some(10)),
            (1, "SWITCH", Some(2), Some(10)),
            // 3 has no previous hypothesis (match), 20 changes object to one never matched
            // (migrate + transfer).
            (1, "MIGRATE", Some(3), Some(20)),
            (1, "TRANSFER", Some(3), Some(20)),
            (1, "MATCH", Some(3), Some(20)),
        ]
    );
    let m = acc.metrics().unwrap();
    assert_eq!(
        (m.num_switches, m.num_transfer, m.num_migrate, m.num_ascend),
        (1, 2, 1, 0)
    );
    assert_eq!(m.num_unique_objects, 3);
}

#[test]
fn each_loss_inside_a_track_is_one_fragmentation() {
    let mut acc = MotAccumulator::<i64>::default();
    acc.update(0, &[1], &[10], &[0.1]).unwrap(); // tracked
    acc.update(1, &[1], &[], &[]).unwrap(); // missed
    acc.update(2, &[1], &[10], &[0.1]).unwrap(); // tracked
    acc.update(3, &[1], &[10], &[NAN]).unwrap(); // missed, 10 is a false positive
    acc.update(4, &[1], &[], &[]).unwrap(); // missed
    acc.update(5, &[1], &[10], &[0.1]).unwrap(); // tracked
    acc.update(6, &[1], &[], &[]).unwrap(); // missed after the last tracked frame
    let kinds: Vec<_> = acc.mot_events().map(|e| e.kind).collect();
    use MotEventKind::{FalsePositive as Fp, Match, Miss};
    assert_eq!(kinds, vec![Match, Miss, Match, Miss, Fp, Miss, Match, Miss]);
    let m = acc.metrics().unwrap();
    assert_eq!(m.num_fragmentations, 2);
    // Tracked in 3 of 7 frames: between 20 % and 80 %.
    assert_eq!(
        (m.mostly_tracked, m.partially_tracked, m.mostly_lost),
        (0, 1, 0)
    );
    assert_eq!(
        (m.num_misses, m.num_false_positives, m.num_frames),
        (4, 1, 7)
    );
}

#[test]
fn forbidden_pairs_are_never_matched() {
    let mut acc = MotAccumulator::<i64>::default();
    // Only (1, 20) may pair; NaN and inf both mean "cannot pair".
    acc.update(0, &[1, 2], &[10, 20], &[NAN, 0.9, f64::INFINITY, NAN])
        .unwrap();
    acc.update(1, &[1, 2], &[10, 20], &[NAN; 4]).unwrap();
    assert_eq!(
        mot_events(&acc),
        vec![
            (0, "MATCH", Some(1), Some(20)),
            (0, "MISS", Some(2), None),
            (0, "FP", None, Some(10)),
            (1, "MISS", Some(1), None),
            (1, "MISS", Some(2), None),
            (1, "FP", None, Some(10)),
            (1, "FP", None, Some(20)),
        ]
    );
    // RAW events: frame marker, the finite pair, then objects and hypotheses without one.
    let raw: Vec<_> = acc
        .events()
        .iter()
        .filter(|e| e.frame == 0 && e.kind == MotEventKind::Raw)
        .map(|e| (e.oid, e.hid))
        .collect();
    assert_eq!(
        raw,
        vec![
            (None, None),
            (Some(1), Some(20)),
            (Some(2), None),
            (None, Some(10))
        ]
    );
    let m = acc.metrics().unwrap();
    assert_eq!((m.idtp, m.num_objects, m.num_predictions), (1, 4, 4));
}

#[test]
fn previous_match_beats_a_cheaper_reassignment() {
    let mut acc = MotAccumulator::<i64>::default();
    acc.update(0, &[1, 2], &[10, 20], &[0.1, 0.9, 0.9, 0.1])
        .unwrap();
    // Swapping would cost 0.0 in total, keeping costs 1.0: tracks are kept.
    acc.update(1, &[1, 2], &[10, 20], &[0.5, 0.0, 0.0, 0.5])
        .unwrap();
    let m = acc.metrics().unwrap();
    assert_eq!((m.num_matches, m.num_switches), (4, 0));
    assert!(close(m.motp, 1.2 / 4.0));
}

#[test]
fn switches_are_forgotten_after_max_switch_time() {
    let run = |max_switch_time| {
        let mut acc = MotAccumulator::<i64>::new(MotAccumulatorConfig { max_switch_time });
        acc.update(0, &[1], &[10], &[0.1]).unwrap();
        acc.update(10, &[1], &[11], &[0.1]).unwrap();
        acc.metrics().unwrap().num_switches
    };
    assert_eq!(run(None), 1);
    assert_eq!(run(Some(10)), 1, "a gap equal to the limit still switches");
    assert_eq!(run(Some(9)), 0);
}

#[test]
fn ids_can_be_any_ordered_type() {
    let mut acc = MotAccumulator::<&str>::default();
    acc.update(0, &["alice", "bob"], &["t1"], &[0.2, NAN])
        .unwrap();
    let m = acc.metrics().unwrap();
    assert_eq!(
        (m.num_matches, m.num_misses, m.num_unique_objects),
        (1, 1, 2)
    );
}

#[test]
fn bad_updates_are_rejected_and_leave_the_accumulator_unchanged() {
    let mut acc = MotAccumulator::<i64>::default();
    acc.update(5, &[1], &[10], &[0.1]).unwrap();
    let before = acc.events().to_vec();

    let err = acc.update(5, &[1], &[10], &[0.1]).unwrap_err();
    assert_eq!(
        err,
        EvalError::FrameOrder {
            frame: 5,
            previous: 5
        }
    );
    assert_eq!(
        err.to_string(),
        "frame 5: frames must be strictly increasing, previous frame was 5"
    );

    let err = acc.update(6, &[1, 2], &[10], &[0.1]).unwrap_err();
    assert_eq!(
        err.to_string(),
        "frame 6: distance matrix has 1 entries, expected 2 objects x 1 hypotheses"
    );

    let err = acc.update(6, &[1], &[10, 10], &[0.1, 0.2]).unwrap_err();
    assert_eq!(err.to_string(), "frame 6: duplicate hypothesis id 10");

    assert_eq!(acc.events(), &before[..]);
    // The failed frames did not count: frame 6 is still accepted.
    acc.update(6, &[1], &[10], &[0.1]).unwrap();
    assert_eq!(acc.metrics().unwrap().num_matches, 2);
}
