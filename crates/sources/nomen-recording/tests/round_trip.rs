//! Writing then reading gives back the same messages and the same bytes.
// Test helpers outside #[test] functions unwrap too: a failure is a test failure.
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use common::*;
use nomen_core::{Message, SessionTime};
use nomen_recording::{
    Header, IdCheck, RecordingReader, RecordingWriter, WriteOptions, read_file, sort_for_writing,
};

fn write_all(header: &Header, messages: &[Message]) -> Vec<u8> {
    let mut w = RecordingWriter::new(Vec::new(), header).unwrap();
    for m in messages {
        w.write(m).unwrap();
    }
    w.finish().unwrap()
}

#[test]
fn written_recording_reads_back_equal_and_rewrites_byte_identical() {
    let mut messages = every_kind();
    sort_for_writing(&mut messages);
    let bytes = write_all(&header(), &messages);

    let mut reader = RecordingReader::new(bytes.as_slice(), "mem.jsonl").unwrap();
    let back: Vec<Message> = reader.by_ref().collect::<Result<_, _>>().unwrap();
    assert_eq!(back, messages);
    assert_eq!(reader.header(), &header());
    let stats = reader.into_stats();
    assert_eq!(stats.num_lines, 1 + messages.len() as u64);
    assert_eq!(stats.num_accepted, messages.len() as u64);
    assert_eq!(stats.num_bytes, bytes.len() as u64);

    let again = write_all(&header(), &back);
    assert_eq!(
        again, bytes,
        "re-writing what was read must give the same bytes"
    );
}

#[test]
fn header_is_the_first_line_with_fields_in_spec_order() {
    let bytes = write_all(&header(), &[]);
    let text = String::from_utf8(bytes).unwrap();
    assert!(
        text.starts_with(r#"{"type":"header","format":"nomen-recording","version":1,"registry":{"subjects":[{"id":"ana""#),
        "{text}"
    );
    assert!(
        text.ends_with("\"meta\":{\"generator\":\"nomen-recording tests\",\"seed\":42}}\n"),
        "{text}"
    );
    assert_eq!(text.lines().count(), 1);
}

#[test]
fn floats_use_the_shortest_round_trip_representation() {
    let msg = imu(1, "band1");
    let bytes = write_all(&header(), &[msg]);
    let text = String::from_utf8(bytes).unwrap();
    let second = text.lines().nth(1).unwrap();
    assert_eq!(
        second,
        r#"{"type":"imu","t":1,"device":"band1","accel_mps2":[0.1,-0.2,9.81],"gyro_radps":[0.01,0.0,-0.3],"mag_ut":[15.3,0.4,-41.1]}"#
    );
}

#[test]
fn sort_for_writing_orders_by_time_then_type_then_source() {
    let mut messages = every_kind();
    messages.reverse();
    sort_for_writing(&mut messages);
    let keys: Vec<(i64, &str)> = messages
        .iter()
        .map(|m| (m.t().as_ns(), m.type_name()))
        .collect();
    assert_eq!(
        keys,
        vec![
            (0, "skeleton"),
            (0, "imu"),
            (5_000_000, "imu"),
            (10_000_000, "imu"),
            (20_000_000, "rtls_fix"),
            (20_000_000, "uwb_range"),
            (20_000_000, "rssi"),
            (20_000_000, "tag_correction"),
            (20_000_000, "truth_tag"),
            (33_000_000, "skeleton"),
            (33_000_000, "skeleton"),
            (33_000_000, "identified"),
            (33_000_000, "truth_skeleton"),
        ]
    );
    // Same time and type: ordered by track.
    let tracks: Vec<u64> = messages
        .iter()
        .filter_map(|m| match m {
            Message::Skeleton(s) if s.t == SessionTime(33_000_000) => Some(s.track.0),
            _ => None,
        })
        .collect();
    assert_eq!(tracks, vec![1, 2]);
}

#[test]
fn writer_refuses_out_of_order_and_duplicates_and_stays_usable() {
    let mut w = RecordingWriter::new(Vec::new(), &header()).unwrap();
    w.write(&imu(2 * S, "band1")).unwrap();
    let err = w.write(&imu(2 * S, "band1")).unwrap_err().to_string();
    assert_eq!(
        err,
        "output:3: time 2.000000 s is not after the previous imu sample of 'band1' at 2.000000 s (duplicate timestamp)"
    );
    // The writer is strict about global order by default.
    let err = w.write(&imu(2 * S - 1, "band2")).unwrap_err().to_string();
    assert_eq!(
        err,
        "output:3: time 2.000000 s is 0.000000001 s before the latest message at 2.000000 s, more than the global order tolerance of 0.000000 s"
    );
    let err = w.write(&imu(3 * S, "band9")).unwrap_err().to_string();
    assert_eq!(err, "output:3: imu device 'band9' is not in the registry");
    w.write(&imu(3 * S, "band1")).unwrap();
    assert_eq!(w.num_lines(), 3);
    let bytes = w.finish().unwrap();
    let (good, error) = read_stop(std::str::from_utf8(&bytes).unwrap());
    assert_eq!(error, None);
    assert_eq!(good, vec![imu(2 * S, "band1"), imu(3 * S, "band1")]);
}

#[test]
fn writer_with_tolerance_writes_what_the_default_reader_accepts() {
    let options = WriteOptions {
        id_check: IdCheck::Header,
        global_tolerance_ns: nomen_recording::DEFAULT_GLOBAL_TOLERANCE_NS,
    };
    let mut w = RecordingWriter::with_options(Vec::new(), "out.jsonl", &header(), options).unwrap();
    w.write(&imu(2 * S, "band1")).unwrap();
    w.write(&imu(2 * S - 50_000_000, "band2")).unwrap();
    let bytes = w.finish().unwrap();
    let (good, error) = read_stop(std::str::from_utf8(&bytes).unwrap());
    assert_eq!((good.len(), error), (2, None));
}

#[test]
fn files_round_trip_through_the_file_system() {
    let dir = std::env::temp_dir().join(format!("nomen-recording-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("rec.jsonl");
    let mut messages = every_kind();
    sort_for_writing(&mut messages);
    let mut w = RecordingWriter::create(&path, &header()).unwrap();
    for m in &messages {
        w.write(m).unwrap();
    }
    w.finish().unwrap();
    let rec = read_file(&path).unwrap();
    assert_eq!(rec.messages, messages);
    assert_eq!(rec.header, header());
    let missing = read_file(dir.join("nope.jsonl")).unwrap_err().to_string();
    assert!(
        missing.starts_with(&format!(
            "{}:1: i/o error:",
            dir.join("nope.jsonl").display()
        )),
        "{missing}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The reader parses the commonest lines (`{"type":"imu",…` and `{"type":"skeleton",…`) on a
/// shorter path than serde's tagged-enum one; on every line, odd or not, it must agree with
/// parsing the line as a [`Message`] the plain way.
#[test]
fn the_reader_parses_every_line_as_a_plain_message_parse_would() {
    let imu_line = line(&imu(S, "band1"));
    let skeleton_line = line(&skeleton(S, 3));
    assert!(imu_line.starts_with(r#"{"type":"imu","#), "{imu_line}");
    assert!(
        skeleton_line.starts_with(r#"{"type":"skeleton","#),
        "{skeleton_line}"
    );
    // The `type` key moved to the end: the generic path.
    let body = imu_line.replacen(r#""type":"imu","#, "", 1);
    let type_last = format!(r#"{},"type":"imu"}}"#, body.trim_end_matches('}'));
    let cases = [
        imu_line.clone(),
        skeleton_line.clone(),
        type_last,
        // A field the struct does not know.
        imu_line.replacen(r#""t":"#, r#""note":"x","t":"#, 1),
        // A second `type` key naming another kind.
        imu_line.replacen(r#""t":"#, r#""type":"skeleton","t":"#, 1),
        // The tag says imu, the fields are a skeleton's.
        skeleton_line.replacen(r#"{"type":"skeleton","#, r#"{"type":"imu","#, 1),
        // A required field missing.
        imu_line.replacen(r#""device":"band1","#, "", 1),
    ];
    let mut num_accepted = 0;
    for l in &cases {
        let plain = serde_json::from_str::<Message>(l);
        let (good, error) = read_stop(&file(std::slice::from_ref(l)));
        match plain {
            Ok(msg) => {
                assert_eq!((good, error), (vec![msg], None), "{l}");
                num_accepted += 1;
            }
            Err(_) => assert!(good.is_empty() && error.is_some(), "{l}: {good:?}"),
        }
    }
    // Both paths and both outcomes were exercised.
    assert_eq!(num_accepted, 4);
    // A line the fast path refuses is reported by the generic path: file, line and serde's
    // reason.
    let wrong_fields = &cases[5];
    let err = error_of(&file(std::slice::from_ref(wrong_fields)));
    assert!(err.starts_with("rec.jsonl:2: "), "{err}");
    assert!(err.contains("missing field"), "{err}");
}
