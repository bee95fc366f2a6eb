//! An MCAP file written by `McapWriter` reads back, through `open_recording`, as the recording
//! of its inputs; a damaged file ends the reading with an error, never a panic.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use nomen_core::{Message, Registry};
use nomen_mcap::{Channel, McapLines, McapWriter, open_recording};
use nomen_recording::{ReadOptions, RecordingReader};
use std::io::Cursor;

const REGISTRY: &str = r#"{"subjects":[{"id":"ana","wears":[{"device":"w1","kind":"imu","site":"left_wrist"}]}],"cameras":[{"id":"cam"}]}"#;

const EVENT: Channel = Channel {
    topic: "nomen/out/event",
    schema_name: "test.event",
    schema: r#"{"type":"object"}"#,
};

fn imu(t_ns: i64) -> Message {
    serde_json::from_str(&format!(
        r#"{{"type":"imu","t":{t_ns},"device":"w1","accel_mps2":[0.1,0.2,9.8],"gyro_radps":[0.0,0.1,0.0]}}"#
    ))
    .unwrap()
}

fn identified(t_ns: i64) -> Message {
    serde_json::from_str(&format!(
        r#"{{"type":"identified","t":{t_ns},"camera":"cam","track":1,"identity":{{"subject":"ana"}},"confidence":0.9}}"#
    ))
    .unwrap()
}

/// A file of a registry, `num_inputs` IMU samples 10 ms apart with an output and an event
/// between them, flushed every 50 messages (several chunks).
fn write_file(num_inputs: i64) -> (Vec<u8>, Vec<Message>) {
    let registry: Registry = serde_json::from_str(REGISTRY).unwrap();
    let mut w = McapWriter::new(Cursor::new(Vec::new()), "test.mcap", &[EVENT]).unwrap();
    let unix_ns = 1_700_000_000_000_000_000u64;
    w.write_registry(&registry, unix_ns).unwrap();
    let mut inputs = Vec::new();
    for k in 0..num_inputs {
        let log = unix_ns + 1_000 + k as u64 * 10_000_000;
        let m = imu(k * 10_000_000);
        assert!(w.write_message(&m, log).unwrap());
        inputs.push(m);
        if k % 7 == 0 {
            w.write_message(&identified(k * 10_000_000), log).unwrap();
            w.write_json(EVENT.topic, br#"{"kind":"named"}"#, log)
                .unwrap();
        }
        if k % 50 == 49 {
            w.flush().unwrap();
        }
    }
    assert!(w.num_bytes() > 0);
    (w.finish().unwrap().into_inner(), inputs)
}

fn read_all(bytes: Vec<u8>) -> (Option<Registry>, Vec<Message>, Option<String>) {
    let lines = McapLines::new(Cursor::new(bytes), nomen_recording::DEFAULT_MAX_LINE_BYTES);
    let mut reader = match RecordingReader::with_options(lines, "test.mcap", ReadOptions::default())
    {
        Ok(r) => r,
        Err(e) => return (None, Vec::new(), Some(e.to_string())),
    };
    let registry = reader.header().registry.clone();
    let mut messages = Vec::new();
    for m in reader.by_ref() {
        match m {
            Ok(m) => messages.push(m),
            Err(e) => return (registry, messages, Some(e.to_string())),
        }
    }
    (registry, messages, None)
}

#[test]
fn the_inputs_come_back_in_order_with_the_registry() {
    let (bytes, inputs) = write_file(300);
    let (registry, messages, error) = read_all(bytes);
    assert_eq!(error, None);
    assert_eq!(registry, Some(serde_json::from_str(REGISTRY).unwrap()));
    assert_eq!(messages, inputs);
}

#[test]
fn open_recording_tells_mcap_from_json_lines() {
    let dir = tempfile::tempdir().unwrap();
    let (bytes, inputs) = write_file(20);
    let mcap = dir.path().join("rec.mcap");
    std::fs::write(&mcap, bytes).unwrap();
    let read: Vec<Message> = open_recording(&mcap, ReadOptions::default())
        .unwrap()
        .map(Result::unwrap)
        .collect();
    assert_eq!(read, inputs);
    assert!(nomen_mcap::is_mcap_file(&mcap));
    let jsonl = dir.path().join("rec.jsonl");
    let mut text = format!(
        r#"{{"type":"header","format":"nomen-recording","version":1,"registry":{REGISTRY}}}"#
    );
    for m in &inputs {
        text.push('\n');
        text.push_str(&serde_json::to_string(m).unwrap());
    }
    std::fs::write(&jsonl, text).unwrap();
    let read: Vec<Message> = open_recording(&jsonl, ReadOptions::default())
        .unwrap()
        .map(Result::unwrap)
        .collect();
    assert_eq!(read, inputs);
    assert!(!nomen_mcap::is_mcap_file(&jsonl));
}

#[test]
fn a_file_cut_anywhere_ends_in_an_error_after_the_messages_before_the_cut() {
    let (bytes, inputs) = write_file(200);
    // Every cut in the first kilobytes, then every 97th byte: never a panic; the messages
    // read are a prefix of the inputs; a cut before the end is an error naming it.
    let cuts = (0..2048).chain((2048..bytes.len()).step_by(97));
    for cut in cuts {
        let (_, messages, error) = read_all(bytes[..cut].to_vec());
        assert!(messages.len() <= inputs.len());
        assert_eq!(messages, inputs[..messages.len()], "cut at {cut}");
        let error = error.unwrap_or_else(|| panic!("no error for a cut at {cut}"));
        assert!(
            error.contains("invalid MCAP file") || error.contains("empty file"),
            "cut at {cut}: {error}"
        );
    }
}

#[test]
fn a_cut_file_names_the_cause() {
    let (bytes, _) = write_file(200);
    let (_, messages, error) = read_all(bytes[..bytes.len() / 2].to_vec());
    assert!(!messages.is_empty());
    let error = error.unwrap();
    assert!(error.contains("the file ends in the middle"), "{error}");
    assert!(error.starts_with("test.mcap:"), "{error}");
}

#[test]
fn damaged_bytes_give_errors_not_panics() {
    let (bytes, _) = write_file(100);
    // A deterministic walk over single-byte changes (xorshift).
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    for _ in 0..400 {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        let mut damaged = bytes.clone();
        let at = (state % damaged.len() as u64) as usize;
        damaged[at] ^= (state >> 32) as u8 | 1;
        let _ = read_all(damaged);
    }
    let (_, _, error) = read_all(b"\x89MCAP0\r\nthis is not mcap".to_vec());
    assert!(error.unwrap().contains("invalid MCAP file"));
}

#[test]
fn messages_out_of_log_time_order_are_refused() {
    let registry: Registry = serde_json::from_str(REGISTRY).unwrap();
    let mut w = McapWriter::new(Cursor::new(Vec::new()), "test.mcap", &[]).unwrap();
    w.write_registry(&registry, 100).unwrap();
    w.write_message(&imu(0), 200).unwrap();
    w.write_message(&imu(10_000_000), 150).unwrap();
    let (_, messages, error) = read_all(w.finish().unwrap().into_inner());
    assert_eq!(messages.len(), 1);
    assert!(error.unwrap().contains("log-time order"));
}

#[test]
fn a_registry_update_is_a_new_version_and_ends_the_recording_with_a_reason() {
    let registry: Registry = serde_json::from_str(REGISTRY).unwrap();
    let mut w = McapWriter::new(Cursor::new(Vec::new()), "test.mcap", &[]).unwrap();
    w.write_registry(&registry, 100).unwrap();
    w.write_message(&imu(0), 200).unwrap();
    // The same registry again is no new version (and is not written again).
    w.write_registry(&registry, 300).unwrap();
    assert_eq!(w.num_registry_versions(), 1);
    w.write_message(&imu(10_000_000), 400).unwrap();
    let mut other = registry.clone();
    other.cameras.clear();
    w.write_registry(&other, 500).unwrap();
    assert_eq!(w.num_registry_versions(), 2);
    w.write_message(&imu(20_000_000), 600).unwrap();
    let (header, messages, error) = read_all(w.finish().unwrap().into_inner());
    assert_eq!(header, Some(registry));
    assert_eq!(messages.len(), 2, "the inputs before the update");
    let error = error.unwrap();
    assert!(
        error.contains("registry update (a new registry version, logged at 500 ns)"),
        "{error}"
    );
}

#[test]
fn a_registry_after_inputs_without_one_is_told_as_such() {
    let registry: Registry = serde_json::from_str(REGISTRY).unwrap();
    let mut w = McapWriter::new(Cursor::new(Vec::new()), "test.mcap", &[]).unwrap();
    w.write_message(&imu(0), 200).unwrap();
    w.write_registry(&registry, 300).unwrap();
    w.write_message(&imu(10_000_000), 400).unwrap();
    let (header, messages, error) = read_all(w.finish().unwrap().into_inner());
    assert_eq!(header, None);
    assert_eq!(messages.len(), 1);
    let error = error.unwrap();
    assert!(
        error.contains("a registry logged at 300 ns after inputs that came without one"),
        "{error}"
    );
    assert!(!error.contains("second"), "{error}");
}
