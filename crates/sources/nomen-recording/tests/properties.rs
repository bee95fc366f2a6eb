//! Properties of the writer and the reader over generated recordings: what is written reads back
//! equal and re-writes to the same bytes, and any cut of a file reads as a prefix of what was
//! written.
// Test helpers outside #[test] functions unwrap too: a failure is a test failure.
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use common::header;
use nalgebra::{Point3, Vector3};
use nomen_core::skeleton::Joints;
use nomen_core::{
    AnchorId, AntennaId, CameraId, DeviceId, Joint, JointObservation, JointState, Message,
    RssiRead, RtlsFix, SessionTime, SkeletonObservation, TagId, TrackId, UwbRange,
};
use nomen_recording::{
    ErrorPolicy, Header, ReadOptions, RecordingReader, RecordingWriter, sort_for_writing,
};
use proptest::prelude::*;

/// Rounds to a millimetre (or a thousandth of the unit): decimals that every parser reads back
/// exactly.
fn milli(x: f64) -> f64 {
    (x * 1000.0).round() / 1000.0
}

/// Leaves a value at full precision (17 significant digits in JSON).
fn full(x: f64) -> f64 {
    x
}

/// One message of any input kind, with the registry's ids, at time `t_ns`, its values passed
/// through `r`.
fn message(t_ns: i64, r: fn(f64) -> f64) -> impl Strategy<Value = Message> {
    let t = SessionTime(t_ns);
    let v3 = |r: f64| (-r..r, -r..r, -r..r);
    prop_oneof![
        (
            prop::sample::select(vec!["band1", "band2"]),
            v3(200.0),
            v3(40.0),
            prop::option::of(v3(100.0)),
        )
            .prop_map(move |(device, a, g, m)| {
                Message::Imu(nomen_core::ImuSample {
                    t,
                    device: DeviceId::new(device),
                    accel_mps2: Vector3::new(r(a.0), r(a.1), r(a.2)),
                    gyro_radps: Some(Vector3::new(r(g.0), r(g.1), r(g.2))),
                    mag_ut: m.map(|m| Vector3::new(r(m.0), r(m.1), r(m.2))),
                    orientation_wxyz: None,
                })
            }),
        (
            0u64..4,
            prop::collection::vec((0usize..20, v3(50.0), 0.0..=1.0f64, 0u8..3), 0..8),
        )
            .prop_map(move |(track, joints)| {
                let mut set = Joints::new();
                for (j, p, confidence, state) in joints {
                    let joint = Joint::ALL[j % Joint::ALL.len()];
                    let state = [
                        JointState::Tracked,
                        JointState::Inferred,
                        JointState::Missing,
                    ][usize::from(state)];
                    set.insert(
                        joint,
                        JointObservation {
                            position_m: Point3::new(r(p.0), r(p.1), r(p.2)),
                            confidence: r(confidence),
                            state,
                            covariance_m2: None,
                        },
                    );
                }
                Message::Skeleton(Box::new(SkeletonObservation {
                    t,
                    camera: CameraId::new("kinect"),
                    track: TrackId(track),
                    joints: set,
                }))
            }),
        (v3(100.0), prop::option::of(0.0..=1.0f64)).prop_map(move |(p, quality)| {
            Message::RtlsFix(RtlsFix {
                t,
                tag: TagId::new("tag1"),
                position_m: Point3::new(r(p.0), r(p.1), r(p.2)),
                quality: quality.map(r),
                covariance_m2: None,
            })
        }),
        (0.0..1000.0f64).prop_map(move |range_m| Message::UwbRange(UwbRange {
            t,
            tag: TagId::new("tag1"),
            anchor: AnchorId::new("a1"),
            range_m: r(range_m),
        })),
        (
            -150.0..30.0f64,
            prop::option::of(0.0..std::f64::consts::TAU)
        )
            .prop_map(move |(rssi_dbm, phase)| {
                Message::Rssi(RssiRead {
                    t,
                    tag: TagId::new("rfid1"),
                    antenna: AntennaId::new("ant1"),
                    rssi_dbm: r(rssi_dbm),
                    phase_rad: phase.map(r),
                })
            }),
    ]
}

/// A recording's messages: times strictly increasing from a start that may be negative, so no
/// two messages of one source share a time; values passed through `r`.
fn messages(r: fn(f64) -> f64) -> impl Strategy<Value = Vec<Message>> {
    (
        -1_000_000_000_000i64..1_000_000_000_000,
        prop::collection::vec(1i64..200_000_000, 0..40),
    )
        .prop_flat_map(move |(start, gaps)| {
            let times: Vec<i64> = gaps
                .iter()
                .scan(start, |t, gap| {
                    *t += gap;
                    Some(*t)
                })
                .collect();
            times.into_iter().map(|t| message(t, r)).collect::<Vec<_>>()
        })
}

fn write_all(header: &Header, messages: &[Message]) -> Vec<u8> {
    let mut writer = RecordingWriter::new(Vec::new(), header).unwrap();
    for m in messages {
        writer.write(m).unwrap();
    }
    writer.finish().unwrap()
}

/// Every message `bytes` gives, and whether the reading ended in an error.
fn read_all(bytes: &[u8], policy: ErrorPolicy) -> (Vec<Message>, bool) {
    let Ok(mut reader) =
        RecordingReader::with_options(bytes, "mem.jsonl", ReadOptions::with_policy(policy))
    else {
        return (Vec::new(), true);
    };
    let mut read = Vec::new();
    let mut failed = false;
    while let Some(next) = reader.next_message() {
        match next {
            Ok(m) => read.push(m),
            Err(_) => failed = true,
        }
    }
    (read, failed)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn written_messages_read_back_equal_and_rewrite_to_the_same_bytes(mut msgs in messages(milli)) {
        // Sorting is a no-op on strictly increasing times; the writer needs the canonical order.
        sort_for_writing(&mut msgs);
        let bytes = write_all(&header(), &msgs);
        for policy in [ErrorPolicy::Stop, ErrorPolicy::SkipAndCount] {
            let (back, failed) = read_all(&bytes, policy);
            prop_assert!(!failed);
            prop_assert_eq!(&back, &msgs);
        }
        let (back, _) = read_all(&bytes, ErrorPolicy::Stop);
        prop_assert_eq!(write_all(&header(), &back), bytes);
    }

    #[test]
    fn a_cut_recording_reads_as_a_prefix_of_what_was_written(
        msgs in messages(milli),
        cut_fraction in 0.0..1.0f64,
    ) {
        let bytes = write_all(&header(), &msgs);
        let cut = (bytes.len() as f64 * cut_fraction) as usize;
        let (back, _) = read_all(&bytes[..cut], ErrorPolicy::Stop);
        prop_assert!(back.len() <= msgs.len());
        prop_assert_eq!(&back[..], &msgs[..back.len()]);
        // Only the cut line can be lost: every line that ended before the cut is read.
        let whole_lines = bytes[..cut].iter().filter(|&&b| b == b'\n').count();
        prop_assert!(back.len() >= whole_lines.saturating_sub(1));
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// Full-precision values: serde_json, built without its `float_roundtrip` feature, parses
    /// some 17-digit decimals one unit in the last place off (a skeleton's
    /// -13.544217826379297 reads back as -13.544217826379295), so what is written does not
    /// always read back bit for bit.
    #[test]
    #[ignore = "serde_json without float_roundtrip reads some 17-digit values 1 ULP off"]
    fn full_precision_values_read_back_bit_for_bit(mut msgs in messages(full)) {
        sort_for_writing(&mut msgs);
        let bytes = write_all(&header(), &msgs);
        let (back, failed) = read_all(&bytes, ErrorPolicy::Stop);
        prop_assert!(!failed);
        prop_assert_eq!(&back, &msgs);
    }
}
