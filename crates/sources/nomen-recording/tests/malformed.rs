//! Bad input: every error names file and line precisely, and nothing panics.
// Test helpers outside #[test] functions unwrap too: a failure is a test failure.
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use common::*;
use nomen_core::Message;
use nomen_recording::{ErrorKind, ErrorPolicy, Header, IdCheck, ReadOptions, RecordingReader};

/// A line of `msg` with one JSON fragment replaced.
fn edited(msg: &Message, from: &str, to: &str) -> String {
    let l = line(msg);
    assert!(l.contains(from), "{l} does not contain {from}");
    l.replacen(from, to, 1)
}

#[test]
fn truncated_last_line_is_reported_after_the_good_messages() {
    let full = line(&imu(2 * S, "band1"));
    let mut text = file(&[line(&imu(S, "band1"))]);
    text.push_str(&full[..full.len() - 10]); // cut off mid-number, no newline
    let (good, err) = read_stop(&text);
    assert_eq!(good, vec![imu(S, "band1")]);
    assert_eq!(
        err.unwrap(),
        "rec.jsonl:3: truncated line (no closing brace / unexpected end of file)"
    );
}

#[test]
fn nan_token_is_invalid_json_with_its_column() {
    let l = edited(&imu(S, "band1"), "[0.1,", "[NaN,");
    let column = l.find("NaN").unwrap() + 1;
    assert_eq!(
        error_of(&file(&[l])),
        format!("rec.jsonl:2: invalid json: expected value (column {column})")
    );
}

#[test]
fn number_beyond_f64_is_invalid_json() {
    let l = edited(&imu(S, "band1"), "9.81", "1e400");
    let err = error_of(&file(&[l]));
    assert!(
        err.starts_with("rec.jsonl:2: invalid json: number out of range (column "),
        "{err}"
    );
}

#[test]
fn implausible_value_names_the_field_and_unit() {
    // cm/s² written where m/s² belongs.
    let l = edited(&imu(S, "band1"), "9.81", "981.0");
    assert_eq!(
        error_of(&file(&[l])),
        "rec.jsonl:2: accel_mps2[2] = 981 is outside the plausible range -313.92..=313.92 m/s²"
    );
}

#[test]
fn unknown_message_type_is_named() {
    let text = file(&[r#"{"type":"lidar","t":1,"points":[]}"#.to_owned()]);
    assert_eq!(error_of(&text), "rec.jsonl:2: unknown message type 'lidar'");
    let text = file(&[r#"{"t":1}"#.to_owned()]);
    assert_eq!(
        error_of(&text),
        "rec.jsonl:2: message has no string 'type' field"
    );
}

#[test]
fn missing_field_and_wrong_type_carry_serde_detail() {
    let l = edited(&imu(S, "band1"), r#""device":"band1","#, "");
    let err = error_of(&file(&[l]));
    assert!(
        err.starts_with("rec.jsonl:2: bad imu message: missing field `device`"),
        "{err}"
    );
    let l = edited(&imu(S, "band1"), r#""t":1000000000"#, r#""t":"soon""#);
    let err = error_of(&file(&[l]));
    assert!(
        err.starts_with(
            r#"rec.jsonl:2: bad imu message: invalid type: string "soon", expected i64"#
        ),
        "{err}"
    );
}

#[test]
fn out_of_order_time_for_one_device_is_refused() {
    // Within the global tolerance, but before the device's previous sample.
    let text = file(&[
        line(&imu(2 * S, "band1")),
        line(&imu(2 * S + 10_000_000, "band2")),
        line(&imu(2 * S - 20_000_000, "band1")),
    ]);
    assert_eq!(
        error_of(&text),
        "rec.jsonl:4: time 1.980000 s is not after the previous imu sample of 'band1' at 2.000000 s (out of order)"
    );
}

#[test]
fn duplicate_timestamp_for_one_source_is_refused() {
    let text = file(&[
        line(&imu(S, "band1")),
        line(&imu(S, "band2")), // another device at the same time is fine
        line(&imu(S, "band1")),
    ]);
    assert_eq!(
        error_of(&text),
        "rec.jsonl:4: time 1.000000 s is not after the previous imu sample of 'band1' at 1.000000 s (duplicate timestamp)"
    );
    let text = file(&[line(&range(S, "a1")), line(&range(S, "a1"))]);
    assert_eq!(
        error_of(&text),
        "rec.jsonl:3: time 1.000000 s is not after the previous uwb range of tag 'tag1' to anchor 'a1' at 1.000000 s (duplicate timestamp)"
    );
    let text = file(&[line(&skeleton(S, 4)), line(&skeleton(S, 4))]);
    assert_eq!(
        error_of(&text),
        "rec.jsonl:3: time 1.000000 s is not after the previous skeleton of camera 'kinect' track 4 at 1.000000 s (duplicate timestamp)"
    );
}

#[test]
fn one_camera_frame_may_hold_several_tracks_but_camera_time_never_goes_back() {
    let (good, err) = read_stop(&file(&[line(&skeleton(S, 1)), line(&skeleton(S, 2))]));
    assert_eq!((good.len(), err), (2, None));
    let text = file(&[line(&skeleton(S, 1)), line(&skeleton(S - 10_000_000, 2))]);
    assert_eq!(
        error_of(&text),
        "rec.jsonl:3: time 0.990000 s is before the previous skeleton of camera 'kinect' at 1.000000 s (camera time went backwards)"
    );
}

#[test]
fn global_order_allows_the_tolerance_and_no_more() {
    let lag_ok = 2 * S - 100_000_000;
    // A first sample, then one 50 ms later that leads the rest (by less than a time jump).
    let lead = [
        line(&imu(2 * S - 50_000_000, "band1")),
        line(&imu(2 * S, "band2")),
    ];
    let (good, err) = read_stop(&file(
        &[lead.to_vec(), vec![line(&skeleton(lag_ok, 4))]].concat(),
    ));
    assert_eq!((good.len(), err), (3, None));
    let text = file(&[lead.to_vec(), vec![line(&skeleton(lag_ok - 1, 4))]].concat());
    assert_eq!(
        error_of(&text),
        "rec.jsonl:4: time 1.900000 s is 0.100000001 s before the latest message at 2.000000 s, more than the global order tolerance of 0.100000 s"
    );
    let strict = ReadOptions {
        global_tolerance_ns: 0,
        ..ReadOptions::default()
    };
    let (_, err) = read_with(
        &file(&[lead.to_vec(), vec![line(&skeleton(lag_ok, 4))]].concat()),
        strict,
    );
    assert!(
        err.unwrap()
            .contains("global order tolerance of 0.000000 s")
    );
}

#[test]
fn unknown_ids_are_refused_per_kind() {
    let cases = [
        (
            line(&imu(S, "band9")),
            "imu device 'band9' is not in the registry",
        ),
        (
            edited(&skeleton(S, 1), "kinect", "zed"),
            "camera 'zed' is not in the registry",
        ),
        (
            line(&range(S, "a9")),
            "uwb anchor 'a9' is not in the registry",
        ),
        (
            line(&rssi(S, "ant9", -60.0)),
            "rssi antenna 'ant9' is not in the registry",
        ),
        (
            line(&fix(S, "tag9")),
            "rtls tag 'tag9' is not in the registry",
        ),
        (
            line(&imu(S, "tag1")),
            "imu device 'tag1' is registered as a uwb_tag device, expected imu",
        ),
        (
            line(&fix(S, "rfid1")),
            "rtls tag 'rfid1' is registered as a rfid_tag device, expected uwb_tag",
        ),
    ];
    for (l, expected) in cases {
        assert_eq!(error_of(&file(&[l])), format!("rec.jsonl:2: {expected}"));
    }
    let identified = every_kind()
        .into_iter()
        .find(|m| m.type_name() == "identified")
        .unwrap();
    let l = edited(&identified, r#"{"subject":"ana"}"#, r#"{"subject":"zoe"}"#);
    assert_eq!(
        error_of(&file(&[l])),
        "rec.jsonl:2: subject 'zoe' is not in the registry"
    );
    // A decision trace names registered subjects only.
    let mut traced: serde_json::Value = serde_json::from_str(&line(&identified)).unwrap();
    traced["decision"] = serde_json::json!({
        "rule": "below_threshold",
        "decided_at": 2,
        "runner_up": {"subject": "zoe", "score": 0.1},
    });
    assert_eq!(
        error_of(&file(&[traced.to_string()])),
        "rec.jsonl:2: decision subject 'zoe' is not in the registry"
    );
    // An unknown rule is a malformed message, named as such.
    traced["decision"]["rule"] = "guessed".into();
    assert!(
        error_of(&file(&[traced.to_string()])).contains("unknown variant `guessed`"),
        "{}",
        error_of(&file(&[traced.to_string()]))
    );
}

#[test]
fn rssi_in_centi_dbm_is_out_of_range() {
    let text = file(&[line(&rssi(S, "ant1", -6500.0))]);
    assert_eq!(
        error_of(&text),
        "rec.jsonl:2: rssi_dbm = -6500 is outside the plausible range -150..=30 dBm"
    );
}

#[test]
fn missing_header_is_an_error_on_line_1() {
    let text = format!("{}\n", line(&imu(S, "band1")));
    let err = error_of(&text);
    assert!(
        err.starts_with(
            "rec.jsonl:1: missing header: line 1 is a 'imu' message; expected a header line"
        ),
        "{err}"
    );
    let err = error_of("hello\n");
    assert!(
        err.starts_with("rec.jsonl:1: missing header: line 1 is not json"),
        "{err}"
    );
    // Another file's JSON: its type is not repeated.
    let err = error_of(r#"{"type":"secret-token-4242","key":"value"}"#);
    assert!(
        err.starts_with(
            "rec.jsonl:1: missing header: line 1's 'type' is not one of a recording; expected a \
             header line"
        ),
        "{err}"
    );
    assert!(!err.contains("secret-token"), "{err}");
    let err = error_of(r#"{"type":"header","format":"csv","version":1}"#);
    assert_eq!(
        err,
        r#"rec.jsonl:1: not a nomen recording: header format is "csv", expected "nomen-recording""#
    );
}

#[test]
fn wrong_format_version_is_refused() {
    let text = header_line().replace(r#""version":1"#, r#""version":2"#);
    assert_eq!(
        error_of(&text),
        "rec.jsonl:1: unsupported format version 2 (this reader reads version 1)"
    );
}

#[test]
fn invalid_registry_in_header_is_refused() {
    let text = header_line().replace(r#""id":"ben""#, r#""id":"ana""#);
    assert_eq!(
        error_of(&text),
        "rec.jsonl:1: invalid registry in header: subject 'ana' is listed twice"
    );
}

#[test]
fn empty_file_is_an_error_on_line_1() {
    assert_eq!(
        error_of(""),
        "rec.jsonl:1: empty file: expected a header line"
    );
}

#[test]
fn a_byte_order_mark_before_the_header_is_skipped() {
    let text = format!("\u{feff}{}", file(&[line(&imu(S, "band1"))]));
    let mut reader = RecordingReader::new(text.as_bytes(), "rec.jsonl").unwrap();
    assert_eq!(reader.header(), &header());
    assert_eq!(reader.by_ref().count(), 1);
    // Only before the header: elsewhere it is a malformed line.
    let text = file(&[format!("\u{feff}{}", line(&imu(S, "band1")))]);
    let mut reader = RecordingReader::new(text.as_bytes(), "rec.jsonl").unwrap();
    let err = reader.next().unwrap().unwrap_err().to_string();
    assert!(err.starts_with("rec.jsonl:2:"), "{err}");
}

#[test]
fn blank_lines_are_skipped_and_counted_as_lines() {
    let text = file(&[
        String::new(),
        line(&imu(S, "band1")),
        "   \r".to_owned(),
        line(&imu(2 * S, "band1")),
    ]);
    let mut reader = RecordingReader::new(text.as_bytes(), "rec.jsonl").unwrap();
    assert_eq!(reader.by_ref().count(), 2);
    assert_eq!(reader.stats().num_lines, 5);
}

#[test]
fn stop_yields_every_good_message_before_the_bad_line_then_ends() {
    let text = file(&[
        line(&imu(S, "band1")),
        line(&skeleton(S, 1)),
        line(&imu(2 * S, "band9")),
        line(&imu(3 * S, "band1")),
    ]);
    let mut reader = RecordingReader::new(text.as_bytes(), "rec.jsonl").unwrap();
    assert_eq!(reader.next().unwrap().unwrap(), imu(S, "band1"));
    assert_eq!(reader.next().unwrap().unwrap(), skeleton(S, 1));
    let err = reader.next().unwrap().unwrap_err();
    assert_eq!(err.kind(), ErrorKind::UnknownId);
    assert_eq!(err.pos().line, 4);
    assert!(reader.next().is_none());
    assert!(reader.next().is_none());
}

#[test]
fn skip_and_count_keeps_going_and_counts_per_kind() {
    let mut truncated = line(&imu(9 * S, "band1"));
    truncated.truncate(30);
    let text = file(&[
        line(&imu(S, "band1")),                 // 2 ok
        line(&imu(S, "band1")),                 // 3 duplicate
        "{not json".to_owned(),                 // 4 json
        line(&rssi(S, "ant1", -6500.0)),        // 5 invalid
        line(&imu(2 * S, "band9")),             // 6 unknown id
        r#"{"type":"lidar","t":1}"#.to_owned(), // 7 unknown type
        line(&imu(2 * S, "band1")),             // 8 ok
        line(&rssi(2 * S, "ant1", -70.0)),      // 9 ok
        line(&imu(2 * S, "band9")),             // 10 unknown id
        truncated,                              // 11 truncated
    ]);
    let mut reader = RecordingReader::with_options(
        text.as_bytes(),
        "rec.jsonl",
        ReadOptions {
            max_errors_kept: 3,
            ..skip_options()
        },
    )
    .unwrap();
    let good: Vec<Message> = reader.by_ref().map(Result::unwrap).collect();
    assert_eq!(
        good,
        vec![
            imu(S, "band1"),
            imu(2 * S, "band1"),
            rssi(2 * S, "ant1", -70.0)
        ]
    );
    let stats = reader.into_stats();
    assert_eq!(stats.num_lines, 11);
    assert_eq!(stats.num_accepted, 3);
    assert_eq!(stats.num_skipped(), 7);
    let counts: Vec<(ErrorKind, u64)> = stats.skipped.iter().map(|(k, n)| (*k, *n)).collect();
    assert_eq!(
        counts,
        vec![
            (ErrorKind::Json, 1),
            (ErrorKind::Truncated, 1),
            (ErrorKind::UnknownType, 1),
            (ErrorKind::Invalid, 1),
            (ErrorKind::UnknownId, 2),
            (ErrorKind::SourceOrder, 1),
        ]
    );
    let lines: Vec<u64> = stats.first_errors.iter().map(|e| e.pos().line).collect();
    assert_eq!(lines, vec![3, 4, 5]);
    assert_eq!(
        stats.to_string(),
        "11 lines, 3 messages accepted, 7 skipped (invalid json: 1, truncated: 1, unknown type: 1, invalid value: 1, unknown id: 2, source time order: 1); \
         line 8, at 2.000000 s, is 1.000 s after every line before it, with no line after it to \
         confirm its time (taken)"
    );
}

#[test]
fn skip_and_count_still_fails_on_a_bad_header() {
    let (good, err) = read_with("{}\n", skip_options());
    assert!(good.is_empty());
    assert!(err.unwrap().starts_with("rec.jsonl:1: missing header"));
}

#[test]
fn a_header_without_registry_turns_id_checks_off() {
    let header = Header::without_registry().with_meta("kind", "result");
    let text = format!(
        "{}\n{}\n{}\n",
        header.to_json_line(),
        line(&imu(S, "anything")),
        line(&imu(S, "anything"))
    );
    assert!(header.to_json_line().contains(r#""registry":null"#));
    let (good, err) = read_stop(&text);
    assert_eq!(good.len(), 1);
    // Order is still checked.
    assert!(err.unwrap().ends_with("(duplicate timestamp)"));
}

#[test]
fn id_checks_can_be_switched_off_or_pointed_at_another_registry() {
    let text = file(&[line(&imu(S, "band9"))]);
    let off = ReadOptions {
        id_check: IdCheck::Off,
        ..ReadOptions::default()
    };
    assert_eq!(read_with(&text, off).0.len(), 1);

    let bare = format!(
        "{}\n{}\n",
        Header::without_registry().to_json_line(),
        line(&imu(S, "band9"))
    );
    let against = ReadOptions {
        id_check: IdCheck::Registry(registry()),
        policy: ErrorPolicy::Stop,
        ..ReadOptions::default()
    };
    assert_eq!(
        read_with(&bare, against).1.unwrap(),
        "rec.jsonl:2: imu device 'band9' is not in the registry"
    );
}

#[test]
fn garbage_bytes_never_panic() {
    let header = header_line();
    let samples: [&[u8]; 8] = [
        b"\xff\xfe\x00",
        b"[1,2,3]",
        b"\"type\"",
        b"{\"type\":42}",
        b"{\"type\":\"imu\"}",
        b"{\"type\":\"skeleton\",\"t\":1,\"camera\":\"kinect\",\"track\":-1,\"joints\":{}}",
        b"{\"type\":\"skeleton\",\"t\":1,\"camera\":\"kinect\",\"track\":1,\"joints\":{\"tail\":{}}}",
        b"{\"type\":\"imu\",\"t\":99999999999999999999}",
    ];
    for s in samples {
        let mut text = header.clone().into_bytes();
        text.push(b'\n');
        text.extend_from_slice(s);
        let reader = RecordingReader::new(text.as_slice(), "rec.jsonl").unwrap();
        let items: Vec<_> = reader.collect();
        assert_eq!(items.len(), 1);
        let err = items.into_iter().next().unwrap().unwrap_err().to_string();
        assert!(err.starts_with("rec.jsonl:2: "), "{err}");
    }
}

/// `n` IMU samples of `band1` every 10 ms from `from_ns`.
fn imus(from_ns: i64, n: i64) -> Vec<Message> {
    (0..n)
        .map(|k| imu(from_ns + k * S / 100, "band1"))
        .collect()
}

fn lines(msgs: &[Message]) -> Vec<String> {
    msgs.iter().map(line).collect()
}

#[test]
fn one_timestamp_an_hour_ahead_costs_its_own_line_and_not_the_lines_after_it() {
    let before = imus(S, 5);
    let after = imus(S + 5 * S / 100, 5);
    let hour = 3_600 * S;
    let mut all = lines(&before);
    all.push(line(&imu(S + hour, "band2")));
    all.extend(lines(&after));
    let text = file(&all);
    // Stopping: every line before it, then the error at its line.
    let (good, err) = read_stop(&text);
    assert_eq!(good, before);
    assert_eq!(
        err.unwrap(),
        "rec.jsonl:7: time 3601.000000 s is 3599.960 s after the latest message at 1.040000 s, \
         more than the 0.1 s a message may lead unconfirmed, and the next message, at 1.050000 \
         s, does not follow on from it (a corrupt timestamp, or a line out of place?)"
    );
    // Skipping: only that line goes.
    let mut reader =
        RecordingReader::with_options(text.as_bytes(), "rec.jsonl", skip_options()).unwrap();
    let good: Vec<Message> = reader.by_ref().map(Result::unwrap).collect();
    let mut expected = before.clone();
    expected.extend(after.iter().cloned());
    assert_eq!(good, expected);
    let stats = reader.into_stats();
    assert_eq!(stats.skipped.get(&ErrorKind::TimeJump), Some(&1));
    assert_eq!(stats.num_skipped(), 1);
    // Without the check, the corrupt line is taken and every line after it is out of order.
    let off = ReadOptions {
        max_time_jump_ns: i64::MAX,
        ..skip_options()
    };
    let mut reader = RecordingReader::with_options(text.as_bytes(), "rec.jsonl", off).unwrap();
    assert_eq!(reader.by_ref().count(), before.len() + 1);
    assert_eq!(
        reader.into_stats().skipped.get(&ErrorKind::GlobalOrder),
        Some(&5)
    );
}

#[test]
fn a_first_line_an_hour_ahead_is_refused_and_the_rest_read() {
    let rest = imus(S, 5);
    let mut all = vec![line(&imu(3_600 * S, "band2"))];
    all.extend(lines(&rest));
    let text = file(&all);
    assert_eq!(
        error_of(&text),
        "rec.jsonl:2: time 3600.000000 s of the first message is 3599.000 s after the next \
         message, at 1.000000 s, more than the 0.1 s a message may lead unconfirmed (a corrupt \
         timestamp, or a line out of place?)"
    );
    let (good, err) = read_with(&text, skip_options());
    assert_eq!((good, err), (rest, None));
    // A first line a second after the second is refused the same way; within the global
    // tolerance both are taken.
    let (good, err) = read_stop(&file(&[line(&imu(2 * S, "band2")), line(&imu(S, "band1"))]));
    assert!(good.is_empty());
    assert!(
        err.unwrap()
            .starts_with("rec.jsonl:2: time 2.000000 s of the first message is 1.000 s after")
    );
    let near = [imu(S + S / 20, "band2"), imu(S, "band1")];
    assert_eq!(read_stop(&file(&lines(&near))), (near.to_vec(), None));
}

#[test]
fn a_line_after_a_waiting_line_is_ordered_after_it() {
    // band1 leads by 0.14 s and waits; the next line follows on from it (within the global
    // tolerance) and leads nothing itself, but is band1's again, earlier: out of order once
    // the waiting line is taken.
    let text = file(&[
        line(&imu(S, "band1")),
        line(&imu(S + 10_000_000, "band2")),
        line(&imu(S + 150_000_000, "band1")),
        line(&imu(S + 100_000_000, "band1")),
    ]);
    let (good, err) = read_stop(&text);
    assert_eq!(
        good,
        vec![
            imu(S, "band1"),
            imu(S + 10_000_000, "band2"),
            imu(S + 150_000_000, "band1")
        ]
    );
    assert_eq!(
        err.unwrap(),
        "rec.jsonl:5: time 1.100000 s is not after the previous imu sample of 'band1' at \
         1.150000 s (out of order)"
    );
}

#[test]
fn two_corrupt_timestamps_in_a_row_cost_their_own_lines_only() {
    // Two IMUs at 100 Hz; two consecutive lines (one of each) stamped 1000 s late.
    let band1 = imus(S, 50);
    let band2: Vec<Message> = (0..50)
        .map(|k| imu(S + k * S / 100 + S / 200, "band2"))
        .collect();
    let mut sorted: Vec<Message> = band1.iter().chain(&band2).cloned().collect();
    sorted.sort_by_key(Message::t);
    let mut corrupt = sorted.clone();
    for k in [20, 21] {
        let t = corrupt[k].t().as_ns() + 1000 * S;
        corrupt[k] = match &corrupt[k] {
            Message::Imu(s) => imu(t, s.device.as_str()),
            _ => unreachable!(),
        };
    }
    let text = file(&lines(&corrupt));
    // Skipping: the two lines are refused, every other line read.
    let mut reader =
        RecordingReader::with_options(text.as_bytes(), "rec.jsonl", skip_options()).unwrap();
    let good: Vec<Message> = reader.by_ref().map(Result::unwrap).collect();
    let mut expected = sorted.clone();
    expected.drain(20..22);
    assert_eq!(good, expected);
    let stats = reader.into_stats();
    assert_eq!(stats.skipped.get(&ErrorKind::TimeJump), Some(&2));
    let at: Vec<u64> = stats.first_errors.iter().map(|e| e.pos().line).collect();
    assert_eq!(at, vec![22, 23]);
    // Stopping: the stream ends at the first of them, with everything before it read.
    let (good, err) = read_stop(&text);
    assert_eq!(good, sorted[..20].to_vec());
    assert!(err.unwrap().starts_with("rec.jsonl:22: time 1001.10"));

    // A jump followed by a line that jumps further: the first is taken (the second confirms
    // it), the second waits, and is refused when the stream comes back to the first's time.
    let mut msgs = imus(S, 3);
    msgs.push(imu(300 * S, "band1"));
    msgs.push(imu(900 * S, "band2"));
    msgs.extend((1..4).map(|k| imu(300 * S + k * S / 100, "band1")));
    let text = file(&lines(&msgs));
    let (good, err) = read_with(&text, skip_options());
    assert_eq!(err, None);
    let mut expected = msgs.clone();
    expected.remove(4);
    assert_eq!(good, expected);

    // A follower that is out of order is named at its own line, in file order.
    let mut msgs = imus(S, 3);
    msgs.push(imu(300 * S, "band1"));
    msgs.push(imu(300 * S, "band1"));
    let (good, err) = read_stop(&file(&lines(&msgs)));
    assert_eq!(good.len(), 4);
    assert!(
        err.unwrap()
            .starts_with("rec.jsonl:6: time 300.000000 s is not after")
    );
}

#[test]
fn a_line_moved_earlier_costs_its_own_line_and_not_the_lines_it_jumped_over() {
    // Two IMUs at 100 Hz; one sample of band1 half a second early in the file (as if swapped
    // with an earlier line, or stamped wrong).
    let band1 = imus(S, 100);
    let band2: Vec<Message> = (0..100)
        .map(|k| imu(S + k * S / 100 + S / 200, "band2"))
        .collect();
    let mut sorted: Vec<Message> = band1.iter().chain(&band2).cloned().collect();
    sorted.sort_by_key(Message::t);
    let moved = imu(S + 80 * S / 100, "band1");
    let at = sorted.iter().position(|m| *m == moved).unwrap();
    let mut shuffled = sorted.clone();
    shuffled.remove(at);
    shuffled.insert(30, moved.clone());
    let text = file(&lines(&shuffled));
    let (good, err) = read_with(&text, skip_options());
    assert_eq!(err, None);
    let mut expected = sorted.clone();
    expected.remove(at);
    assert_eq!(good, expected, "only the moved line is lost");
    let mut reader =
        RecordingReader::with_options(text.as_bytes(), "rec.jsonl", skip_options()).unwrap();
    assert_eq!(reader.by_ref().count(), sorted.len() - 1);
    assert_eq!(
        reader.into_stats().skipped.get(&ErrorKind::TimeJump),
        Some(&1)
    );
    // Taken at once (the rule before), it cost every line of band1 it jumped over and every
    // line of band2 more than the global tolerance before it.
    let old = ReadOptions {
        max_time_jump_ns: 60 * S,
        ..skip_options()
    };
    let mut reader = RecordingReader::with_options(text.as_bytes(), "rec.jsonl", old).unwrap();
    assert!(reader.by_ref().count() < sorted.len() - 60);
}

#[test]
fn a_recording_that_pauses_for_minutes_is_read_whole() {
    let pause = 300 * S;
    for (num_after, tail) in [
        (5, "lines after the pause"),
        (1, "one line after the pause"),
    ] {
        let mut msgs = imus(S, 5);
        msgs.extend(imus(2 * S + pause, num_after));
        let (good, err) = read_stop(&file(&lines(&msgs)));
        assert_eq!(err, None, "{tail}");
        assert_eq!(good, msgs, "{tail}");
    }
    // Two jumps in a row, each confirmed by the line after it.
    let mut msgs = imus(S, 3);
    msgs.extend(imus(2 * S + pause, 2));
    msgs.extend(imus(3 * S + 2 * pause, 2));
    let (good, err) = read_stop(&file(&lines(&msgs)));
    assert_eq!((good, err), (msgs, None));
}

#[test]
fn a_last_line_after_a_jump_is_taken_and_reported_as_unconfirmed() {
    let mut msgs = imus(S, 3);
    let last = imu(2 * S + 300 * S, "band1");
    msgs.push(last.clone());
    let text = file(&lines(&msgs));
    let mut reader = RecordingReader::new(text.as_bytes(), "rec.jsonl").unwrap();
    assert_eq!(reader.by_ref().count(), 4);
    let stats = reader.into_stats();
    assert_eq!(stats.unconfirmed_jump, Some((5, last.t(), msgs[2].t())));
    assert!(
        stats.to_string().ends_with(
            "; line 5, at 302.000000 s, is 300.980 s after every line before it, with no line \
             after it to confirm its time (taken)"
        ),
        "{stats}"
    );
    // One line after it is not enough to confirm it; two are, and there is nothing to report.
    msgs.push(imu(2 * S + 300 * S + S / 100, "band1"));
    let text = file(&lines(&msgs));
    let mut reader = RecordingReader::new(text.as_bytes(), "rec.jsonl").unwrap();
    assert_eq!(reader.by_ref().count(), 5);
    assert!(reader.into_stats().unconfirmed_jump.is_some());
    msgs.push(imu(2 * S + 300 * S + 2 * S / 100, "band1"));
    let text = file(&lines(&msgs));
    let mut reader = RecordingReader::new(text.as_bytes(), "rec.jsonl").unwrap();
    assert_eq!(reader.by_ref().count(), 6);
    assert_eq!(reader.into_stats().unconfirmed_jump, None);
}

#[test]
fn a_line_after_a_jump_that_is_bad_for_another_reason_leaves_the_jump_standing() {
    let mut all = lines(&imus(S, 3));
    let jump = imu(2 * S + 300 * S, "band1");
    all.push(line(&jump));
    all.push("{\"type\":\"imu\",".to_owned());
    all.extend(lines(&imus(2 * S + 300 * S + S / 100, 2)));
    let text = file(&all);
    let (good, err) = read_stop(&text);
    assert_eq!(good.len(), 4);
    assert_eq!(good.last(), Some(&jump));
    assert!(err.unwrap().starts_with("rec.jsonl:6: "));
    let (good, err) = read_with(&text, skip_options());
    assert_eq!((good.len(), err), (6, None));
}

/// An input that hands out one line per read, each after a pause, and counts the lines handed
/// out: a live stream, as a pipe delivers it.
struct SlowLines {
    lines: std::collections::VecDeque<Vec<u8>>,
    pause: std::time::Duration,
    num_read: std::rc::Rc<std::cell::Cell<usize>>,
    current: Vec<u8>,
    at: usize,
}

impl std::io::Read for SlowLines {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        use std::io::BufRead;
        let available = self.fill_buf()?;
        let n = available.len().min(buf.len());
        buf[..n].copy_from_slice(&available[..n]);
        self.consume(n);
        Ok(n)
    }
}

impl std::io::BufRead for SlowLines {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        if self.at == self.current.len()
            && let Some(next) = self.lines.pop_front()
        {
            // The header comes at once; every message line after a pause.
            if self.num_read.get() > 0 {
                std::thread::sleep(self.pause);
            }
            self.current = next;
            self.at = 0;
            self.num_read.set(self.num_read.get() + 1);
        }
        Ok(&self.current[self.at..])
    }

    fn consume(&mut self, n: usize) {
        self.at = (self.at + n).min(self.current.len());
    }
}

#[test]
fn live_a_pause_the_wall_clock_vouches_for_is_taken_at_once_and_a_corrupt_jump_still_waits() {
    // One IMU sending a sample every 0.3 s (sparser than the 0.1-s jump threshold), read live:
    // each line arrives 0.35 s after the one before it.
    let mut msgs: Vec<Message> = (0..4).map(|k| imu(S + k * 3 * S / 10, "band1")).collect();
    // Then one stamped an hour ahead: not vouched for by 0.35 s, it waits and is refused when
    // the next line comes back to the stream's time.
    msgs.push(imu(3600 * S, "band1"));
    msgs.extend((4..6).map(|k| imu(S + k * 3 * S / 10, "band1")));
    let text = file(&lines(&msgs));
    let read = |wall_clock: bool| {
        let num_read = std::rc::Rc::new(std::cell::Cell::new(0));
        let input = SlowLines {
            lines: text
                .lines()
                .map(|l| format!("{l}\n").into_bytes())
                .collect(),
            pause: std::time::Duration::from_millis(350),
            num_read: num_read.clone(),
            current: Vec::new(),
            at: 0,
        };
        let options = ReadOptions {
            wall_clock,
            ..skip_options()
        };
        let mut reader = RecordingReader::with_options(input, "live", options).unwrap();
        // Per message taken, how many message lines had been read when it came out.
        let mut taken = Vec::new();
        while let Some(m) = reader.next_message() {
            taken.push((m.unwrap(), num_read.get() - 1));
        }
        (taken, reader.into_stats())
    };
    let mut expected = msgs.clone();
    expected.remove(4);
    // With the wall clock, each sample comes out as soon as its line is read, but the first,
    // which has no earlier line to measure a pause from and waits for the next one. Without
    // it, each sample waits for the next line (which, 0.3 s later, confirms it and waits in
    // turn), and the last one for the end of the input. The message lines read when each
    // sample came out:
    for (wall_clock, when) in [(true, [2, 2, 3, 4, 6, 7]), (false, [2, 3, 4, 5, 7, 7])] {
        let (taken, stats) = read(wall_clock);
        let got: Vec<Message> = taken.iter().map(|(m, _)| m.clone()).collect();
        assert_eq!(got, expected);
        let lines_read: Vec<usize> = taken.iter().map(|(_, n)| *n).collect();
        assert_eq!(lines_read, when, "wall clock {wall_clock}");
        assert_eq!(stats.skipped.get(&ErrorKind::TimeJump), Some(&1));
    }
}

/// `input` read with lines capped at `max_line_bytes` under `policy`, through a 64-byte
/// buffer (so a long line spans many refills): the good messages, the error that ended the
/// stream and the counts.
fn read_capped(
    input: impl std::io::Read,
    max_line_bytes: usize,
    policy: ErrorPolicy,
) -> (Vec<Message>, Option<String>, nomen_recording::ReadStats) {
    let options = ReadOptions {
        max_line_bytes,
        policy,
        ..ReadOptions::default()
    };
    let input = std::io::BufReader::with_capacity(64, input);
    let mut reader = RecordingReader::with_options(input, "rec.jsonl", options).unwrap();
    let mut good = Vec::new();
    let mut err = None;
    for item in reader.by_ref() {
        match item {
            Ok(msg) => good.push(msg),
            Err(e) => err = Some(e.to_string()),
        }
    }
    (good, err, reader.into_stats())
}

/// Endless bytes, none a newline: a reader that looks for the end of a line never finishes.
struct Endless(u8);

impl std::io::Read for Endless {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        buf.fill(self.0);
        Ok(buf.len())
    }
}

#[test]
fn a_line_longer_than_the_cap_ends_the_stream_under_either_policy() {
    let fits = line(&imu(2 * S, "band1"));
    // The longest good line, the header, exactly at the cap.
    let cap = header_line().len().max(fits.len());
    // A 10-kB line of one JSON string: valid, but past the cap.
    let long = format!("\"{}\"", "x".repeat(10_000));
    let text = file(&[
        line(&imu(S, "band1")),
        long.clone(),
        fits,
        line(&imu(3 * S, "band1")),
    ]);
    let expected = format!(
        "rec.jsonl:3: the line is longer than {cap} bytes, the longest line a recording may \
         have (not a recording, or its newlines are missing)"
    );
    for policy in [ErrorPolicy::Stop, ErrorPolicy::SkipAndCount] {
        let (good, err, stats) = read_capped(text.as_bytes(), cap, policy);
        assert_eq!(good, vec![imu(S, "band1")], "{policy:?}");
        assert_eq!(err.as_deref(), Some(expected.as_str()), "{policy:?}");
        assert_eq!(stats.num_lines, 3, "{policy:?}");
        assert_eq!(stats.num_skipped(), 0, "{policy:?}");
    }
}

#[test]
fn an_endless_line_ends_the_stream_and_a_long_first_line_is_no_header() {
    // A header, a good line, then bytes without a newline for ever: refused at the cap (the
    // test would never end if the reader looked for the line's end).
    let text = file(&[line(&imu(S, "band1"))]).into_bytes();
    for policy in [ErrorPolicy::Stop, ErrorPolicy::SkipAndCount] {
        let input = std::io::Read::chain(&text[..], Endless(b'7'));
        let (good, err, _) = read_capped(input, 1024, policy);
        assert_eq!(good, vec![imu(S, "band1")]);
        assert_eq!(
            err.as_deref(),
            Some(
                "rec.jsonl:3: the line is longer than 1 KiB, the longest line a recording may \
                 have (not a recording, or its newlines are missing)"
            )
        );
    }
    // As the first line, endless zeros are no header.
    let options = ReadOptions {
        max_line_bytes: 1024,
        ..ReadOptions::default()
    };
    let input = std::io::BufReader::new(Endless(0));
    let Err(e) = RecordingReader::with_options(input, "zeros.bin", options) else {
        panic!("endless zeros taken for a header");
    };
    assert_eq!(
        e.to_string(),
        "zeros.bin:1: the first line is longer than 1 KiB, the longest line a recording may \
         have: not a nomen recording"
    );
}

/// A recording of endless good IMU lines, 10 ms apart.
struct EndlessImu {
    pending: Vec<u8>,
    num_lines: i64,
}

impl std::io::Read for EndlessImu {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        while self.pending.len() < buf.len() {
            let msg = imu(S + self.num_lines * (S / 100), "band1");
            self.pending
                .extend_from_slice(format!("{}\n", line(&msg)).as_bytes());
            self.num_lines += 1;
        }
        let n = buf.len();
        buf.copy_from_slice(&self.pending[..n]);
        self.pending.drain(..n);
        Ok(n)
    }
}

#[test]
fn a_reader_that_keeps_every_message_stops_at_its_memory_limit() {
    let endless = || EndlessImu {
        pending: format!("{}\n", header_line()).into_bytes(),
        num_lines: 0,
    };
    let per_message = nomen_recording::held_bytes(&imu(S, "band1"));
    let options = ReadOptions {
        max_held_bytes: 1000 * per_message,
        ..ReadOptions::default()
    };
    let reader =
        RecordingReader::with_options(std::io::BufReader::new(endless()), "rec.jsonl", options)
            .unwrap();
    let items: Vec<_> = reader.collect();
    // 1000 messages fit; the next, on line 1002, is refused and ends the stream.
    assert_eq!(items.len(), 1001);
    assert!(items[..1000].iter().all(Result::is_ok));
    let Some(Err(e)) = items.last() else {
        panic!("the stream did not end in an error");
    };
    let expected = format!(
        "rec.jsonl:1002: the messages up to here take more than {} bytes in memory, the most a \
         recording read whole may hold (nomen run with the engine and nomen validate stream it)",
        1000 * per_message
    );
    assert_eq!(e.to_string(), expected);
    // The default is a streaming reader's: no limit.
    assert_eq!(ReadOptions::default().max_held_bytes, u64::MAX);
    assert_eq!(
        ReadOptions::default().holding_all().max_held_bytes,
        nomen_recording::MAX_HELD_MESSAGE_BYTES
    );
}
