//! A camera on its own clock: the registry's clock offset of a camera puts its frames on the
//! session clock (`session = device + offset`), as an IMU's offset does for its samples.
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use common::{Person, accuracy, recording, registry};
use nomen_core::{DeviceId, Identity, Message, SessionTime};
use nomen_engine::{EngineConfig, EngineStats, run_batch};

/// A band wearer and an intruder, the wearer's band 0.4 s behind the session.
fn people() -> Vec<Person> {
    let mut ana = Person::new(Some("ana"), 0.8, 0.0, 1);
    ana.imu_offset_s = 0.4;
    let ben = Person::new(Some("ben"), 1.1, 1.0, 2);
    let intruder = Person::new(None, 0.95, 2.0, 3);
    vec![ana, ben, intruder]
}

/// The identified frames as (session time, track, identity, confidence), sorted.
fn named(out: &[Message]) -> Vec<(i64, u64, Identity, f64)> {
    let mut v: Vec<_> = out
        .iter()
        .filter_map(|m| match m {
            Message::Identified(id) => {
                Some((id.t.as_ns(), id.track.0, id.identity.clone(), id.confidence))
            }
            _ => None,
        })
        .collect();
    v.sort_by_key(|a| (a.0, a.1));
    v
}

fn offset_s(stats: &EngineStats, device: &str) -> f64 {
    stats.clock_offsets[&DeviceId::new(device)].offset_ns as f64 * 1e-9
}

/// The recording with every skeleton stamped `offset_ns` earlier (the camera's clock is behind
/// the session's by that much), re-sorted by stamp as a recording on disk is.
fn camera_behind(msgs: &[Message], offset_ns: i64) -> Vec<Message> {
    let mut out: Vec<Message> = msgs
        .iter()
        .map(|m| match m {
            Message::Skeleton(s) => {
                let mut s = s.clone();
                s.t = SessionTime::from_ns(s.t.as_ns() - offset_ns);
                Message::Skeleton(s)
            }
            m => m.clone(),
        })
        .collect();
    out.sort_by_key(|m| m.t());
    out
}

#[test]
fn a_camera_on_its_own_clock_gives_the_same_names_once_its_offset_is_registered() {
    let people = people();
    let msgs = recording(&people, 20.0);
    let config = EngineConfig::default();
    let (plain, plain_stats) = run_batch(&registry(&people), &msgs, &config).unwrap();
    let offset_ns = 300_000_000;
    let shifted = camera_behind(&msgs, offset_ns);
    let mut reg = registry(&people);
    reg.cameras[0].clock.offset_ns = offset_ns;
    let (out, stats) = run_batch(&reg, &shifted, &config).unwrap();
    // The same decisions at the same session times, and the band's offset found where it is
    // against the session clock.
    assert_eq!(named(&out), named(&plain));
    assert_eq!(
        offset_s(&stats, "ana_imu"),
        offset_s(&plain_stats, "ana_imu")
    );
    assert!((offset_s(&stats, "ana_imu") - 0.4).abs() < 0.015);
    // Unregistered, the camera's frames come out at camera times, and the band's offset is
    // found against the camera's clock instead (0.4 − 0.3 s).
    let (unregistered, stats) = run_batch(&registry(&people), &shifted, &config).unwrap();
    assert_ne!(named(&unregistered), named(&plain));
    assert!((offset_s(&stats, "ana_imu") - 0.1).abs() < 0.015);
    assert!(accuracy(&people, &plain, 8.0) > 0.98);
}
