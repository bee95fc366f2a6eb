//! Streams at the edges of time: a session stamped far from its origin or at the clock's ends, a first message
//! a year before the rest, two camera frames stamped a year ahead, and a decision delay of a
//! day; and a frame of thousands of tracks. The engine must neither hang (step through the
//! empty time one window at a time, or loop at the end of the clock) nor lose a source for
//! good. No test is timed: the number of windows the engine processed says whether it stepped
//! through the empty time.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use common::{
    Person, accuracy, num_decided, num_skeletons, recording, registry, restamped,
    restamped_identified,
};
use nomen_core::{Message, SessionTime, TrackId};
use nomen_engine::{Engine, EngineConfig, EngineError, EngineStats};

const YEAR_NS: i64 = 365 * 86_400_000_000_000;

fn people() -> Vec<Person> {
    vec![
        Person::new(Some("ana"), 0.9, 0.0, 1),
        Person::new(Some("ben"), 1.3, 1.2, 2),
    ]
}

/// Pushes `stream` (polling after each message), optionally tells the engine that the clock
/// reached `heartbeat`, and finishes; returns the refusals, the outputs and the statistics.
fn run(
    stream: &[Message],
    config: EngineConfig,
    heartbeat: Option<SessionTime>,
) -> (Vec<EngineError>, Vec<Message>, EngineStats) {
    let mut engine = Engine::new(registry(&people()), config).unwrap();
    let mut errors = Vec::new();
    let mut out = Vec::new();
    for m in stream {
        if let Err(e) = engine.push(m) {
            errors.push(e);
        }
        engine.poll(&mut out);
    }
    if let Some(now) = heartbeat {
        engine.advance_to(now).unwrap();
        engine.poll(&mut out);
    }
    engine.finish(&mut out);
    (errors, out, engine.stats().clone())
}

/// The clean stream moved by `shift_ns`, run: the refusals, how many skeletons were decided,
/// and the share named right.
fn run_shifted(shift_ns: i64) -> (Vec<EngineError>, usize, f64) {
    let clean = recording(&people(), 10.0);
    let stream: Vec<Message> = clean
        .iter()
        .map(|m| restamped(m, m.t().as_ns().saturating_add(shift_ns)))
        .collect();
    let (errors, out, stats) = run(&stream, EngineConfig::default(), None);
    assert!(stats.num_windows < 100, "{} windows", stats.num_windows);
    let back: Vec<Message> = out
        .iter()
        .map(|m| restamped_identified(m, -shift_ns))
        .collect();
    (errors, num_decided(&out), accuracy(&people(), &back, 4.0))
}

#[test]
fn stamps_far_from_the_origin_are_taken_and_stamps_at_the_clocks_ends_refused_by_name() {
    let num_clean = num_skeletons(&recording(&people(), 10.0));
    // Unix-epoch nanoseconds (56 years), or 140 years either way: every skeleton decided.
    for years in [56, 140, -140] {
        let (errors, decided, named) = run_shifted(years * YEAR_NS);
        assert!(errors.is_empty(), "{years} years: {errors:?}");
        assert_eq!(decided, num_clean, "{years} years");
        assert!(
            named > 0.95,
            "{years} years: {named:.3} of frames named right"
        );
    }
    // At the ends of the nanosecond clock (±292 years) the engine's window and reorder
    // arithmetic would leave it: a source's frontier (its time less the reorder window) used to
    // wrap from `i64::MIN` to the far end, and the window after `i64::MAX` to the near one, so
    // that every later message was late or the engine looped for ever. Refused instead, each
    // message by name.
    for shift in [i64::MIN, i64::MAX - 10_000_000_000] {
        let (errors, decided, _) = run_shifted(shift);
        assert_eq!(decided, 0);
        assert_eq!(errors.len(), recording(&people(), 10.0).len());
        let text = errors[0].to_string();
        assert!(
            matches!(errors[0], EngineError::InvalidMessage { .. })
                && text.contains("t = ")
                && text.contains("plausible range"),
            "{text}"
        );
    }
}

#[test]
fn a_first_message_a_year_before_the_rest_costs_no_stepping_through_the_year() {
    let clean = recording(&people(), 10.0);
    let first_imu = clean
        .iter()
        .position(|m| matches!(m, Message::Imu(_)))
        .unwrap();
    let mut stream = vec![restamped(&clean[first_imu], -YEAR_NS)];
    stream.extend(clean.iter().cloned());
    let (errors, out, stats) = run(&stream, EngineConfig::default(), None);
    // The session starts a year back; each source's first message after the year is refused
    // as a jump (one per source: the camera's first frame, each band's first sample), and
    // every other skeleton is decided and named.
    assert!(
        errors
            .iter()
            .all(|e| matches!(e, EngineError::TimeJump { .. })),
        "{errors:?}"
    );
    assert!(errors.len() <= 4, "{} refusals", errors.len());
    assert!(num_decided(&out) + 2 >= num_skeletons(&clean));
    assert!(accuracy(&people(), &out, 4.0) > 0.95);
    // The year between was jumped over, not stepped through (63 million windows).
    assert!(stats.num_windows < 200, "{} windows", stats.num_windows);
    assert!(stats.num_windows_skipped > 60_000_000, "{stats:?}");
}

#[test]
fn two_camera_frames_stamped_a_year_ahead_are_refused_and_the_camera_goes_on() {
    let clean = recording(&people(), 12.0);
    // The camera's two frames after 6 s (both tracks of each), stamped a year later; the
    // bands' samples between them are at the stream's own time.
    let frames: Vec<i64> = {
        let mut times: Vec<i64> = clean
            .iter()
            .filter(|m| matches!(m, Message::Skeleton(_)) && m.t().as_ns() > 6_000_000_000)
            .map(|m| m.t().as_ns())
            .collect();
        times.dedup();
        times.truncate(2);
        times
    };
    let stream: Vec<Message> = clean
        .iter()
        .map(|m| match m {
            Message::Skeleton(_) if frames.contains(&m.t().as_ns()) => {
                restamped(m, m.t().as_ns() + YEAR_NS)
            }
            _ => m.clone(),
        })
        .collect();
    // Two frames of two people each.
    let num_spoiled = stream.iter().filter(|m| m.t().as_ns() > YEAR_NS).count();
    assert_eq!(num_spoiled, 4);
    let (errors, out, stats) = run(&stream, EngineConfig::default(), None);
    // The second frame used to confirm the first: the camera's clock taken to have jumped a
    // year, every later frame refused as late, and the engine stepping through the year
    // while the year-ahead frames waited to be sent.
    assert_eq!(errors.len(), 4, "{errors:?}");
    assert!(
        errors
            .iter()
            .all(|e| matches!(e, EngineError::TimeJump { .. })),
        "{errors:?}"
    );
    assert_eq!(num_decided(&out), num_skeletons(&clean) - 4);
    assert!(accuracy(&people(), &out, 4.0) > 0.95);
    assert!(accuracy(&people(), &out, 8.0) > 0.95);
    assert!(stats.num_windows < 100, "{} windows", stats.num_windows);
}

#[test]
fn a_decision_delay_of_a_day_jumps_to_the_decisions() {
    let clean = recording(&people(), 10.0);
    let config = EngineConfig {
        decision_delay_s: 86_400.0,
        ..EngineConfig::default()
    };
    let (errors, out, stats) = run(&clean, config, None);
    assert!(errors.is_empty(), "{errors:?}");
    // Every skeleton decided a day after its frame (in the stream, not on the clock), and
    // named right.
    assert_eq!(num_decided(&out), num_skeletons(&clean));
    assert!(out.iter().all(|m| m.t().as_ns() < 10_000_000_000));
    assert!(accuracy(&people(), &out, 4.0) > 0.95);
    // 172,800 windows of a day between the last frame and the decisions, jumped over.
    assert!(stats.num_windows < 1_000, "{} windows", stats.num_windows);
    assert!(stats.num_windows_skipped > 170_000, "{stats:?}");
}

#[test]
fn a_frame_of_thousands_of_new_tracks_is_decided_whole_and_the_people_keep_their_names() {
    let clean = recording(&people(), 10.0);
    // At 4 s, 3,000 more tracks in one frame: copies of a person, 1 cm apart.
    let Some(Message::Skeleton(person)) = clean
        .iter()
        .find(|m| matches!(m, Message::Skeleton(_)) && m.t().as_ns() >= 4_000_000_000)
    else {
        panic!("the recording has frames after 4 s");
    };
    const FIRST_COPY: u64 = 1_000;
    let copies = (0..3_000u64).map(|k| {
        let mut copy = person.clone();
        copy.track = TrackId(FIRST_COPY + k);
        for j in nomen_core::Joint::ALL {
            if let Some(o) = copy.joints.get_mut(j) {
                o.position_m.x += 0.01 * (k + 1) as f64;
            }
        }
        Message::Skeleton(copy)
    });
    let mut stream: Vec<Message> = clean.iter().cloned().chain(copies).collect();
    stream.sort_by_key(|m| m.t());
    let (errors, out, _) = run(&stream, EngineConfig::default(), None);
    assert!(errors.is_empty(), "{errors:?}");
    assert_eq!(num_decided(&out), num_skeletons(&clean) + 3_000);
    // Each copy was seen once, which names nobody.
    let named_copies = out.iter().filter(|m| {
        matches!(m, Message::Identified(id)
            if id.track.0 >= FIRST_COPY && id.identity.subject().is_some())
    });
    assert_eq!(named_copies.count(), 0);
    assert!(accuracy(&people(), &out, 4.0) > 0.95);
    assert!(accuracy(&people(), &out, 6.0) > 0.95);
}
