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
