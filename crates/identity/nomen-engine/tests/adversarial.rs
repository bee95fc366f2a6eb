//! Seeded streams of bad and hostile input: a clean recording with numbers broken, messages
//! duplicated, delayed within and beyond the reorder window, sent from unknown sources,
//! stamped an hour ahead or before the session, and skeletons with no joints. The engine must
//! not panic, must refuse messages only with an error of the kind their spoiling calls for,
//! naming their source, must keep nearly every skeleton and every name, must give every
//! skeleton it accepted exactly one identity (and none it refused), and must give the same
//! output for the same stream.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use common::{
    Person, accuracy, num_decided, num_skeletons, recording, registry, restamped,
    restamped_identified,
};
use nomen_core::skeleton::{JointState, Joints};
use nomen_core::{CameraId, DeviceId, Joint, Message};
use nomen_engine::{Engine, EngineConfig, EngineError};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::collections::BTreeMap;

/// Ways a message is spoiled, each with its share of the messages (they are drawn in turn, so
/// one message takes at most one).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Spoil {
    /// A NaN, an infinity or an absurd value in one number.
    Number,
    /// Sent twice, the copy a few messages later.
    Twice,
    /// Delayed by up to the reorder window.
    Late,
    /// Delayed by a second to three (refused as late, or accepted for a source that was
    /// behind anyway).
    VeryLate,
    /// Also sent from a source nobody registered.
    Stranger,
    /// Also sent stamped an hour later, or an hour before the session started.
    Stamp,
    /// A skeleton with no joints, or with every joint missing (valid, and identified).
    Empty,
}

const SHARES: [(Spoil, f64); 7] = [
    (Spoil::Number, 0.02),
    (Spoil::Twice, 0.02),
    (Spoil::Late, 0.03),
    (Spoil::VeryLate, 0.005),
    (Spoil::Stranger, 0.005),
    (Spoil::Stamp, 0.001),
    (Spoil::Empty, 0.005),
];

/// The stream in arrival order, each message with its spoiling (`None`: as recorded; of a
/// message sent twice, or also from a stranger or with another stamp, the first copy).
fn spoiled(msgs: &[Message], seed: u64) -> Vec<(Option<Spoil>, Message)> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    // (arrival time, tie-break, spoiling, message)
    let mut arrivals: Vec<(i64, usize, Option<Spoil>, Message)> = Vec::new();
    for m in msgs {
        let t = m.t().as_ns();
        let mut send = |at: i64, spoil: Option<Spoil>, m: Message| {
            let k = arrivals.len();
            arrivals.push((at, k, spoil, m));
        };
        let u: f64 = rng.random();
        let mut acc = 0.0;
        let spoil = SHARES.iter().find_map(|&(s, p)| {
            acc += p;
            (u < acc).then_some(s)
        });
        match spoil {
            None => send(t, None, m.clone()),
            Some(Spoil::Number) => send(t, spoil, broken_number(m, &mut rng)),
            Some(Spoil::Twice) => {
                send(t, None, m.clone());
                send(t + rng.random_range(0..50_000_000), spoil, m.clone());
            }
            Some(Spoil::Late) => send(t + rng.random_range(0..250_000_000), spoil, m.clone()),
            Some(Spoil::VeryLate) => send(
                t + rng.random_range(1_000_000_000..3_000_000_000),
                spoil,
                m.clone(),
            ),
            Some(Spoil::Stranger) => {
                send(t, None, m.clone());
                send(t, spoil, from_stranger(m));
            }
            Some(Spoil::Stamp) => {
                send(t, None, m.clone());
                let shift = if rng.random() {
                    3_600_000_000_000
                } else {
                    -3_600_000_000_000
                };
                send(t, spoil, restamped(m, t + shift));
            }
            Some(Spoil::Empty) => send(t, spoil, emptied(m, rng.random())),
        }
    }
    arrivals.sort_by_key(|(at, k, _, _)| (*at, *k));
    arrivals.into_iter().map(|(_, _, s, m)| (s, m)).collect()
}

/// The refusals a spoiling may draw (a message may also be taken: a broken number on a joint
/// marked missing is never read, a copy or a delay may land inside the reorder window, and a
/// stamp an hour before may be its source's first message).
fn allowed(spoil: Spoil, e: &EngineError) -> bool {
    match spoil {
        Spoil::Number => matches!(e, EngineError::InvalidMessage { .. }),
        Spoil::Twice => matches!(e, EngineError::Duplicate { .. } | EngineError::Late { .. }),
        Spoil::Late | Spoil::VeryLate => matches!(e, EngineError::Late { .. }),
        Spoil::Stranger => matches!(
            e,
            EngineError::UnknownDevice { .. } | EngineError::UnknownCamera { .. }
        ),
        Spoil::Stamp => matches!(e, EngineError::TimeJump { .. } | EngineError::Late { .. }),
        Spoil::Empty => false,
    }
}

fn broken_number(m: &Message, rng: &mut ChaCha8Rng) -> Message {
    let bad = [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 1e300];
    let v = bad[rng.random_range(0..bad.len())];
    let mut m = m.clone();
    match &mut m {
        Message::Imu(s) => {
            let axis = rng.random_range(0..3);
            if rng.random() {
                s.accel_mps2[axis] = v;
            } else {
                if let Some(g) = s.gyro_radps.as_mut() {
                    g[axis] = v;
                }
            }
        }
        Message::Skeleton(s) => {
            let joints: Vec<Joint> = s.joints.iter().map(|(j, _)| j).collect();
            if let Some(&j) = joints.get(rng.random_range(0..joints.len().max(1)))
                && let Some(o) = s.joints.get_mut(j)
            {
                if rng.random() {
                    o.position_m[rng.random_range(0..3)] = v;
                } else {
                    // A confidence out of its range.
                    o.confidence = if v.is_finite() { 2.0 } else { v };
                }
            }
        }
        _ => {}
    }
    m
}

fn from_stranger(m: &Message) -> Message {
    let mut m = m.clone();
    match &mut m {
        Message::Imu(s) => s.device = DeviceId::new("stranger_imu"),
        Message::Skeleton(s) => s.camera = CameraId::new("stranger_cam"),
        _ => {}
    }
    m
}

fn emptied(m: &Message, keep_missing: bool) -> Message {
    let mut m = m.clone();
    if let Message::Skeleton(s) = &mut m {
        if keep_missing {
            let joints: Vec<Joint> = s.joints.iter().map(|(j, _)| j).collect();
            for j in joints {
                if let Some(o) = s.joints.get_mut(j) {
                    o.state = JointState::Missing;
                }
            }
        } else {
            s.joints = Joints::new();
        }
    }
    m
}

/// What one run gives: every push's error (by arrival index), the skeletons accepted
/// (time, camera, track → count) and the outputs.
struct Run {
    errors: BTreeMap<usize, EngineError>,
    accepted: BTreeMap<(i64, CameraId, u64), usize>,
    out: Vec<Message>,
    /// Why the session's first message was dropped, if it was.
    first_dropped: Option<String>,
}

fn run<'a>(people: &[Person], stream: impl IntoIterator<Item = &'a Message>) -> Run {
    let mut engine = Engine::new(registry(people), EngineConfig::default()).unwrap();
    let mut errors = BTreeMap::new();
    let mut accepted = BTreeMap::new();
    let mut out = Vec::new();
    for (k, m) in stream.into_iter().enumerate() {
        match engine.push(m) {
            Ok(()) => {
                if let Message::Skeleton(s) = m {
                    *accepted
                        .entry((s.t.as_ns(), s.camera.clone(), s.track.0))
                        .or_insert(0) += 1;
                }
            }
            Err(e) => {
                errors.insert(k, e);
            }
        }
        engine.poll(&mut out);
    }
    engine.finish(&mut out);
    let first_dropped = engine.stats().first_message_dropped.clone();
    assert_eq!(
        engine.stats().rejected.total(),
        errors.len() as u64 + u64::from(first_dropped.is_some()),
        "every refusal is counted"
    );
    Run {
        errors,
        accepted,
        out,
        first_dropped,
    }
}

#[test]
fn a_spoiled_stream_is_refused_message_by_message_and_every_accepted_skeleton_is_identified() {
    let mut people = vec![
        Person::new(Some("ana"), 0.9, 0.0, 1),
        Person::new(Some("ben"), 1.3, 1.2, 2),
        Person::new(None, 1.1, 2.4, 3),
    ];
    people[1].imu_offset_s = 0.3;
    let clean = recording(&people, 12.0);
    let num_clean_skeletons = num_skeletons(&clean);
    let mut kinds_seen = BTreeMap::new();
    for seed in 1..=6 {
        let stream = spoiled(&clean, seed);
        let first = run(&people, stream.iter().map(|(_, m)| m));
        // No message is lost: each accepted skeleton has one identity, and only those.
        let mut identified: BTreeMap<(i64, CameraId, u64), usize> = BTreeMap::new();
        for m in &first.out {
            if let Message::Identified(id) = m {
                assert!(
                    id.confidence.is_finite() && (0.0..=1.0).contains(&id.confidence),
                    "seed {seed}: confidence {} at {}",
                    id.confidence,
                    id.t
                );
                *identified
                    .entry((id.t.as_ns(), id.camera.clone(), id.track.0))
                    .or_insert(0) += 1;
            }
        }
        assert_eq!(identified, first.accepted, "seed {seed}");
        assert!(first.accepted.values().all(|&n| n == 1), "seed {seed}");
        // Bad data does not cost good data: a message as recorded is never refused (below),
        // and nearly every skeleton is kept.
        assert!(
            first.accepted.len() as f64 > 0.9 * num_clean_skeletons as f64,
            "seed {seed}: {} of {num_clean_skeletons} skeletons accepted",
            first.accepted.len()
        );
        // Nor does it cost the names: Ben's clock offset is found and everyone is named.
        let named = accuracy(&people, &first.out, 6.0);
        assert!(
            named > 0.95,
            "seed {seed}: {named:.3} of frames after 6 s named right"
        );
        // Every refusal names its source, and is of a kind its spoiling calls for.
        for (k, e) in &first.errors {
            let text = e.to_string();
            let (spoil, m) = &stream[*k];
            assert!(
                spoil.is_some_and(|s| allowed(s, e)),
                "seed {seed}: {spoil:?} message refused with '{text}'"
            );
            let source = match m {
                Message::Imu(s) => s.device.to_string(),
                Message::Skeleton(s) => s.camera.to_string(),
                other => panic!("seed {seed}: refused {other:?}"),
            };
            assert!(
                text.contains(&source) || matches!(e, EngineError::Duplicate { .. }),
                "seed {seed}: '{text}' does not name '{source}'"
            );
            let kind = match e {
                EngineError::InvalidMessage { .. } => "invalid",
                EngineError::UnknownDevice { .. } | EngineError::UnknownCamera { .. } => "unknown",
                EngineError::Duplicate { .. } => "duplicate",
                EngineError::Late { .. } => "late",
                EngineError::TimeJump { .. } => "time jump",
                other => panic!("seed {seed}: unexpected refusal {other}"),
            };
            *kinds_seen.entry(kind).or_insert(0usize) += 1;
        }
        // Same stream, same output.
        let again = run(&people, stream.iter().map(|(_, m)| m));
        assert!(again.out == first.out, "seed {seed}: a second run differs");
        assert_eq!(
            again.errors.keys().collect::<Vec<_>>(),
            first.errors.keys().collect::<Vec<_>>()
        );
    }
    // Every kind of refusal was exercised.
    for kind in ["invalid", "unknown", "duplicate", "late", "time jump"] {
        assert!(
            kinds_seen.get(kind).is_some_and(|&n| n > 0),
            "{kinds_seen:?}"
        );
    }
}

#[test]
fn a_session_resuming_after_everyone_was_silent_loses_one_message_per_source() {
    let people = vec![
        Person::new(Some("ana"), 0.9, 0.0, 1),
        Person::new(Some("ben"), 1.3, 1.2, 2),
    ];
    // Twenty seconds of the scene, the last ten of them stamped 90 s later: nobody sent
    // anything for 90 s (a recording paused, every device off).
    let gap_ns = 90_000_000_000;
    let stream: Vec<Message> = recording(&people, 20.0)
        .iter()
        .map(|m| {
            let t = m.t().as_ns();
            if t >= 10_000_000_000 {
                restamped(m, t + gap_ns)
            } else {
                m.clone()
            }
        })
        .collect();
    let source = |k: usize| match &stream[k] {
        Message::Imu(s) => s.device.to_string(),
        Message::Skeleton(s) => s.camera.to_string(),
        other => panic!("{other:?}"),
    };
    let result = run(&people, &stream);
    // The refusals are time jumps: the first message after the gap of each source that sent
    // one before any source's second message came (for the camera, its first frame: one
    // message per track).
    assert!(!result.errors.is_empty());
    let mut refused: BTreeMap<String, Vec<i64>> = BTreeMap::new();
    for (k, e) in &result.errors {
        assert!(matches!(e, EngineError::TimeJump { .. }), "{e}");
        assert!(stream[*k].t().as_ns() >= 10_000_000_000 + gap_ns);
        refused
            .entry(source(*k))
            .or_default()
            .push(stream[*k].t().as_ns());
    }
    for (source, times) in &refused {
        assert!(times.iter().all(|t| *t == times[0]), "{source}: {times:?}");
    }
    // After the gap, both are named again.
    let after: Vec<Message> = result
        .out
        .iter()
        .filter(|m| m.t().as_ns() >= 10_000_000_000 + gap_ns)
        .map(|m| restamped_identified(m, -gap_ns))
        .collect();
    assert!(after.len() > 500, "{} frames after the gap", after.len());
    let named = accuracy(&people, &after, 13.0);
    assert!(
        named > 0.95,
        "{named:.3} of frames named right after the gap"
    );
}

#[test]
fn a_first_message_stamped_an_hour_ahead_is_dropped_when_the_next_one_comes() {
    let people = vec![
        Person::new(Some("ana"), 0.9, 0.0, 1),
        Person::new(Some("ben"), 1.3, 1.2, 2),
    ];
    let clean = recording(&people, 12.0);
    let num_clean = num_skeletons(&clean);
    let hour_ns = 3_600_000_000_000;
    let first_imu = clean
        .iter()
        .position(|m| matches!(m, Message::Imu(_)))
        .unwrap();
    let first_skeleton = clean
        .iter()
        .position(|m| matches!(m, Message::Skeleton(_)))
        .unwrap();
    for (k, source) in [(first_skeleton, "cam"), (first_imu, "ana_imu")] {
        // The message moved to the front of the stream, stamped an hour later: the session's
        // first message. Before the hold, a skeleton there made every later frame of its
        // camera late, and nobody was named.
        let mut stream = vec![restamped(&clean[k], clean[k].t().as_ns() + hour_ns)];
        stream.extend(
            clean
                .iter()
                .enumerate()
                .filter(|(i, _)| *i != k)
                .map(|(_, m)| m.clone()),
        );
        let result = run(&people, &stream);
        assert!(result.errors.is_empty(), "{source}: {:?}", result.errors);
        let why = result.first_dropped.expect("the first message is dropped");
        assert!(why.contains(source) && why.contains("3600"), "{why}");
        // Every skeleton but a dropped one is decided (its push had returned Ok: it waited).
        let num_kept = if source == "cam" {
            num_clean - 1
        } else {
            num_clean
        };
        assert_eq!(num_decided(&result.out), num_kept, "{source}");
        assert!(result.out.iter().all(|m| m.t().as_ns() < hour_ns));
        let named = accuracy(&people, &result.out, 6.0);
        assert!(named > 0.95, "{source}: {named:.3} of frames named right");
    }
    // A first message in time is taken, and so is one that nothing follows.
    let result = run(&people, &clean);
    assert!(result.first_dropped.is_none() && result.errors.is_empty());
    assert_eq!(result.accepted.len(), num_clean);
    let alone = run(&people, &clean[first_skeleton..=first_skeleton]);
    assert_eq!(alone.out.len(), 1, "{:?}", alone.out);
    // A message that cannot vouch (here a skeleton from an unknown camera) is refused as
    // before and leaves the first message waiting for one that can.
    let stranger = from_stranger(&clean[first_skeleton]);
    let mut stream = vec![
        restamped(
            &clean[first_skeleton],
            clean[first_skeleton].t().as_ns() + hour_ns,
        ),
        stranger,
    ];
    stream.extend(clean.iter().cloned());
    let result = run(&people, &stream);
    assert_eq!(result.errors.keys().copied().collect::<Vec<_>>(), vec![1]);
    assert!(result.first_dropped.is_some());
    assert_eq!(num_decided(&result.out), num_clean);
}
