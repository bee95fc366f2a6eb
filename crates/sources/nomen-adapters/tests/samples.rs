//! Each sample in `docs/adapters/` reads into the messages its vendor's documentation says it
//! holds, and a broken copy of it (truncated, a wrong type, a missing field) is refused with
//! an error that names the place.
//!
//! Expected values are derived from the samples' documented units: Kinect and Pozyx
//! millimetres / 1000, the tracker's units × its scale, Zebra's phase degrees × π/180, times
//! as Unix-epoch nanoseconds of the date-time written in the sample (2024-05-14T09:30:00Z is
//! 1 715 679 000 s).

use nomen_adapters::rfid::SKIP_HEARTBEAT;
use nomen_adapters::rtls::{SKIP_NOT_A_POSITION, SKIP_UNSUCCESSFUL};
use nomen_adapters::{
    AdapterError, AzureKinectConfig, Decoded, RfidConfig, RtlsConfig, TrackerConfig,
    decode_azure_kinect_frame, decode_pozyx, decode_sewio, decode_tracker, decode_zebra,
    read_azure_kinect, read_impinj, read_pozyx, read_sewio, read_tracker, read_zebra,
};
use nomen_core::{CameraId, Joint, JointState, Message, RssiRead, RtlsFix, SkeletonObservation};
use nomen_recording::csv::TimeUnit;
use std::path::PathBuf;

/// 2024-05-14T09:30:00Z in Unix-epoch nanoseconds.
const BASE_NS: i64 = 1_715_679_000_000_000_000;

fn sample(name: &str) -> String {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../docs/adapters")
        .join(name);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn skeletons(d: &Decoded) -> Vec<&SkeletonObservation> {
    d.messages
        .iter()
        .map(|m| match m {
            Message::Skeleton(s) => s.as_ref(),
            other => panic!("expected skeletons, got {}", other.type_name()),
        })
        .collect()
}

fn fixes(d: &Decoded) -> Vec<&RtlsFix> {
    d.messages
        .iter()
        .map(|m| match m {
            Message::RtlsFix(f) => f,
            other => panic!("expected fixes, got {}", other.type_name()),
        })
        .collect()
}

fn reads(d: &Decoded) -> Vec<&RssiRead> {
    d.messages
        .iter()
        .map(|m| match m {
            Message::Rssi(r) => r,
            other => panic!("expected rssi reads, got {}", other.type_name()),
        })
        .collect()
}

fn assert_time_ordered(d: &Decoded) {
    assert!(
        d.messages.windows(2).all(|w| w[0].t() <= w[1].t()),
        "messages out of time order"
    );
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-9
}

/// The error text, which must start with `prefix` (the place) and contain `needle`.
fn assert_error(result: nomen_adapters::Result<Decoded>, prefix: &str, needle: &str) {
    let e = match result {
        Ok(d) => panic!("expected an error, read {} messages", d.messages.len()),
        Err(e) => e.to_string(),
    };
    eprintln!("{e}");
    assert!(
        e.starts_with(prefix),
        "'{e}' does not start with '{prefix}'"
    );
    assert!(e.contains(needle), "'{e}' does not contain '{needle}'");
}

// --- Azure Kinect ---------------------------------------------------------------------------

fn kinect() -> AzureKinectConfig {
    AzureKinectConfig {
        camera: CameraId::new("kinect"),
        time_offset_ns: 0,
    }
}

fn read_kinect(text: &str) -> nomen_adapters::Result<Decoded> {
    read_azure_kinect(text.as_bytes(), "bt.json", &kinect())
}

#[test]
fn kinect_sample_reads_into_skeletons_in_metres_at_device_time() {
    let d = read_kinect(&sample("azure_kinect_offline.json")).unwrap();
    let s = skeletons(&d);
    // One body in frames 0 and 1, two in frame 2.
    assert_eq!(s.len(), 4);
    assert_time_ordered(&d);
    assert_eq!(
        s.iter().map(|s| s.t.as_ns()).collect::<Vec<_>>(),
        [1_866_666_000, 1_899_999_000, 1_933_332_000, 1_933_332_000]
    );
    assert_eq!(
        s.iter().map(|s| s.track.0).collect::<Vec<_>>(),
        [1, 1, 1, 2]
    );
    assert!(s.iter().all(|s| s.camera.as_str() == "kinect"));
    // Frame 0, body 1: pelvis at (-412.5, 180.25, 2841) mm; the head 700 mm above it (−y) and
    // 30 mm nearer the camera.
    let first = s[0];
    let pelvis = first.position(Joint::Pelvis).unwrap();
    assert!(close(pelvis.x, -0.4125) && close(pelvis.y, 0.18025) && close(pelvis.z, 2.841));
    let head = first.position(Joint::Head).unwrap();
    assert!(close(head.x, -0.4125) && close(head.y, -0.51975) && close(head.z, 2.811));
    // SHOULDER_LEFT is 180 mm to +x of the pelvis.
    let shoulder = first.position(Joint::LeftShoulder).unwrap();
    assert!(close(shoulder.x, -0.2325), "{shoulder}");
    // 32 SDK joints, 12 without a nomen joint (navel, clavicles, hand tips, thumbs, face).
    assert_eq!(first.joints.len(), 20);
    assert!(
        first
            .joints
            .iter()
            .all(|(_, j)| j.state == JointState::Tracked)
    );
    assert_eq!(d.skipped.total(), 0);
}

#[test]
fn kinect_time_offset_shifts_every_frame() {
    let config = AzureKinectConfig {
        time_offset_ns: -1_866_666_000,
        ..kinect()
    };
    let d = read_azure_kinect(
        sample("azure_kinect_offline.json").as_bytes(),
        "bt.json",
        &config,
    )
    .unwrap();
    assert_eq!(d.messages[0].t().as_ns(), 0);
    assert_eq!(d.messages[1].t().as_ns(), 33_333_000);
}

#[test]
fn kinect_truncated_file_is_refused_with_its_line() {
    let text = sample("azure_kinect_offline.json");
    let cut = &text[..text.len() / 2];
    assert_error(read_kinect(cut), "bt.json: invalid json", "truncated");
}

#[test]
fn kinect_wrong_type_is_refused_with_line_and_column() {
    let text = sample("azure_kinect_offline.json").replacen(
        "\"timestamp_usec\": 1899999",
        "\"timestamp_usec\": \"soon\"",
        1,
    );
    assert_error(
        read_kinect(&text),
        "bt.json: invalid type: string \"soon\"",
        "(line ",
    );
}

#[test]
fn kinect_missing_or_short_joint_list_names_the_body() {
    let mut doc: serde_json::Value =
        serde_json::from_str(&sample("azure_kinect_offline.json")).unwrap();
    let positions = &mut doc["frames"][1]["bodies"][0]["joint_positions"];
    positions.as_array_mut().unwrap().pop();
    assert_error(
        read_kinect(&doc.to_string()),
        "bt.json: frames[1].bodies[0].joint_positions: 31 joints, expected 32",
        "",
    );
    doc["frames"][1]["bodies"][0]
        .as_object_mut()
        .unwrap()
        .remove("joint_positions");
    assert_error(
        read_kinect(&doc.to_string()),
        "bt.json: missing field `joint_positions`",
        "",
    );
}

#[test]
fn kinect_null_coordinate_drops_only_that_joint_and_counts_it() {
    let mut doc: serde_json::Value =
        serde_json::from_str(&sample("azure_kinect_offline.json")).unwrap();
    // WRIST_LEFT is SDK joint 7.
    doc["frames"][0]["bodies"][0]["joint_positions"][7][1] = serde_json::Value::Null;
    let d = read_kinect(&doc.to_string()).unwrap();
    let s = skeletons(&d);
    assert!(s[0].joints.get(Joint::LeftWrist).is_none());
    assert_eq!(s[0].joints.len(), 19);
    assert_eq!(s[1].joints.len(), 20);
    assert_eq!(
        d.skipped
            .count(nomen_adapters::azure_kinect::SKIP_NULL_JOINT),
        1
    );
}

#[test]
fn kinect_unknown_joint_name_and_body_count_mismatch_are_refused() {
    let mut doc: serde_json::Value =
        serde_json::from_str(&sample("azure_kinect_offline.json")).unwrap();
    doc["joint_names"][1] = "SPINE_NAVAL".into();
    assert_error(
        read_kinect(&doc.to_string()),
        "bt.json: joint_names[1]: unknown joint 'SPINE_NAVAL'",
        "",
    );
    let mut doc: serde_json::Value =
        serde_json::from_str(&sample("azure_kinect_offline.json")).unwrap();
    doc["frames"][2]["num_bodies"] = 3.into();
    assert_error(
        read_kinect(&doc.to_string()),
        "bt.json: frames[2]: num_bodies is 3 but bodies has 2 entries",
        "",
    );
}

#[test]
fn kinect_frame_payload_decodes_like_the_file() {
    let doc: serde_json::Value =
        serde_json::from_str(&sample("azure_kinect_offline.json")).unwrap();
    let frame = doc["frames"][2].to_string();
    let d = decode_azure_kinect_frame(frame.as_bytes(), &kinect()).unwrap();
    let file = read_kinect(&sample("azure_kinect_offline.json")).unwrap();
    assert_eq!(d.messages, file.messages[2..]);
}

// --- Position-only tracker -------------------------------------------------------------------

fn tracker() -> TrackerConfig {
    TrackerConfig {
        camera: CameraId::new("counter"),
        scale_m_per_unit: 0.0153,
        time_unit: None,
        joint: Joint::Head,
        z_m: 1.7,
        time_offset_ns: 0,
    }
}

#[test]
fn a_file_that_is_not_a_tracker_s_is_refused_without_its_content() {
    let passwd = "root:x:0:0:secret-token:/root:/bin/bash\nbin:x:1:1:bin:/bin:/sbin/nologin\n";
    let e = read_tracker(passwd.as_bytes(), "passwd", &tracker())
        .unwrap_err()
        .to_string();
    assert!(!e.contains("secret-token") && !e.contains("root:x"), "{e}");
    assert!(
        e.contains("missing the time 't' (none of its 1 names"),
        "{e}"
    );
    // A tracker's own file with a column missing still lists its columns.
    let e = read_tracker("t_s,id,x\n0.1,1,2\n".as_bytes(), "counter.csv", &tracker())
        .unwrap_err()
        .to_string();
    assert!(e.contains("missing 'y' (found: "), "{e}");
}

#[test]
fn tracker_csv_sample_reads_into_one_joint_skeletons_scaled_to_metres() {
    let d = read_tracker(
        sample("tracker_overhead.csv").as_bytes(),
        "counter.csv",
        &tracker(),
    )
    .unwrap();
    let s = skeletons(&d);
    assert_eq!(s.len(), 6);
    assert_time_ordered(&d);
    // Sorted by time, then track: (0 ms, 7), (0 ms, 9), (250 ms, 7), ...
    assert_eq!(
        s.iter()
            .map(|s| (s.t.as_ns(), s.track.0))
            .collect::<Vec<_>>(),
        [
            (0, 7),
            (0, 9),
            (250_000_000, 7),
            (250_000_000, 9),
            (500_000_000, 7),
            (500_000_000, 9)
        ]
    );
    let first = s[0];
    assert_eq!(first.joints.len(), 1);
    let head = first.joints.get(Joint::Head).unwrap();
    assert!(close(head.position_m.x, 812.0 * 0.0153));
    assert!(close(head.position_m.y, 455.0 * 0.0153));
    assert!(
        close(head.position_m.z, 1.7),
        "2D point at the configured z"
    );
    assert!(close(head.confidence, 0.92));
}

#[test]
fn tracker_json_lines_read_the_same_as_csv() {
    let csv = read_tracker(
        sample("tracker_overhead.csv").as_bytes(),
        "c.csv",
        &tracker(),
    )
    .unwrap();
    let jsonl = read_tracker(
        sample("tracker_overhead.jsonl").as_bytes(),
        "c.jsonl",
        &tracker(),
    )
    .unwrap();
    assert_eq!(csv, jsonl);
    let one = decode_tracker(
        br#"{"t_ms":250,"track":9,"x":141,"y":612,"confidence":0.87}"#,
        &tracker(),
    )
    .unwrap();
    assert_eq!(one.messages[..], csv.messages[3..4]);
}

#[test]
fn tracker_centroids_go_to_the_pelvis_and_a_bare_t_takes_the_given_unit() {
    let config = TrackerConfig {
        joint: Joint::Pelvis,
        time_unit: Some(TimeUnit::Seconds),
        scale_m_per_unit: 1.0,
        ..tracker()
    };
    let d = read_tracker(
        "t;id;x;y;z\n1.5;3;2.0;-1.0;0.9\n".as_bytes(),
        "c.csv",
        &config,
    )
    .unwrap();
    let s = skeletons(&d);
    assert_eq!(s[0].t.as_ns(), 1_500_000_000);
    let p = s[0].position(Joint::Pelvis).unwrap();
    assert!(close(p.z, 0.9));
    assert_error(
        read_tracker("t,track,x,y\n1.5,3,2,1\n".as_bytes(), "c.csv", &tracker()),
        "c.csv:2: t: the time has no unit",
        "t_ms",
    );
}

#[test]
fn tracker_malformed_rows_name_line_and_column() {
    let text = sample("tracker_overhead.csv").replace("250,9,141,612,0.87", "250,9,abc,612,0.87");
    assert_error(
        read_tracker(text.as_bytes(), "c.csv", &tracker()),
        "c.csv:5: x: expected a finite number, found \"abc\"",
        "",
    );
    let text = sample("tracker_overhead.csv").replace("500,7,865,447,0.95", "500,7,865");
    assert_error(
        read_tracker(text.as_bytes(), "c.csv", &tracker()),
        "c.csv:6: row has 3 fields, the header 5",
        "",
    );
    let text = sample("tracker_overhead.jsonl").replace(",\"y\":451", "");
    assert_error(
        read_tracker(text.as_bytes(), "c.jsonl", &tracker()),
        "c.jsonl:3: missing 'y'",
        "",
    );
    let text = sample("tracker_overhead.jsonl");
    let cut = &text[..text.len() - 20];
    assert_error(
        read_tracker(cut.as_bytes(), "c.jsonl", &tracker()),
        "c.jsonl:6: invalid json",
        "truncated",
    );
}

#[test]
fn tracker_with_the_wrong_scale_is_refused_as_implausible() {
    // Units read as kilometres put the head 800 km away.
    let config = TrackerConfig {
        scale_m_per_unit: 1000.0,
        ..tracker()
    };
    assert_error(
        read_tracker(sample("tracker_overhead.csv").as_bytes(), "c.csv", &config),
        "c.csv:2: joints.head.position_m[0]",
        "",
    );
}

// --- Pozyx ----------------------------------------------------------------------------------

#[test]
fn pozyx_sample_reads_fixes_in_metres_and_counts_unsuccessful_updates() {
    let d = read_pozyx(
        sample("pozyx_tags.jsonl").as_bytes(),
        "tags.jsonl",
        &RtlsConfig::default(),
    )
    .unwrap();
    let f = fixes(&d);
    assert_eq!(f.len(), 4);
    assert_time_ordered(&d);
    assert_eq!(d.skipped.count(SKIP_UNSUCCESSFUL), 1);
    assert_eq!(
        f.iter().map(|f| f.tag.as_str()).collect::<Vec<_>>(),
        ["30331", "41022", "41022", "30331"]
    );
    assert!(close(f[0].position_m.x, 2.51) && close(f[0].position_m.z, 1.29));
    assert!(close(f[1].position_m.x, -0.82) && close(f[1].position_m.y, 4.102));
    // 1715679000.1002 s, within the f64 resolution of epoch seconds (< 1 µs).
    assert!(
        (f[0].t.as_ns() - (BASE_NS + 100_200_000)).abs() < 1000,
        "{}",
        f[0].t.as_ns()
    );
    // The second update of the batched last line.
    assert!((f[3].t.as_ns() - (BASE_NS + 300_100_000)).abs() < 1000);
}

#[test]
fn pozyx_malformed_updates_name_line_and_field() {
    let config = RtlsConfig::default();
    let text = sample("pozyx_tags.jsonl").replacen(",\"y\":4102", "", 1);
    assert_error(
        read_pozyx(text.as_bytes(), "tags.jsonl", &config),
        "tags.jsonl:2: [0].data.coordinates: missing field 'y'",
        "",
    );
    // A 2D setup's update without z takes the configured height.
    let text = sample("pozyx_tags.jsonl").replacen(",\"z\":1185", "", 1);
    let two_d = RtlsConfig {
        z_m: 1.5,
        ..RtlsConfig::default()
    };
    let d = read_pozyx(text.as_bytes(), "tags.jsonl", &two_d).unwrap();
    let zs: Vec<f64> = d
        .messages
        .iter()
        .filter_map(|m| match m {
            Message::RtlsFix(f) => Some(f.position_m.z),
            _ => None,
        })
        .collect();
    assert!(zs.iter().filter(|z| close(**z, 1.5)).count() == 1, "{zs:?}");
    let text = sample("pozyx_tags.jsonl").replacen("\"x\":-805", "\"x\":\"far\"", 1);
    assert_error(
        read_pozyx(text.as_bytes(), "tags.jsonl", &config),
        "tags.jsonl:4: [0].data.coordinates.x: expected a finite number",
        "",
    );
    let text = sample("pozyx_tags.jsonl").replacen("\"tagId\":\"30331\",", "", 1);
    assert_error(
        read_pozyx(text.as_bytes(), "tags.jsonl", &config),
        "tags.jsonl:1: [0]: missing field 'tagId'",
        "",
    );
    let text = sample("pozyx_tags.jsonl");
    let cut = &text[..text.len() - 40];
    assert_error(
        read_pozyx(cut.as_bytes(), "tags.jsonl", &config),
        "tags.jsonl:4: invalid json",
        "truncated",
    );
}

#[test]
fn pozyx_same_tag_twice_at_one_time_names_both_lines() {
    let first = sample("pozyx_tags.jsonl")
        .lines()
        .next()
        .unwrap()
        .to_owned();
    let text = format!("{first}\n{first}\n");
    assert_error(
        read_pozyx(text.as_bytes(), "tags.jsonl", &RtlsConfig::default()),
        "tags.jsonl:2: [0]: fix of tag '30331' at",
        "already given at tags.jsonl:1: [0]",
    );
}

#[test]
fn pozyx_payload_decodes_every_update_of_a_batch() {
    let line = sample("pozyx_tags.jsonl")
        .lines()
        .nth(3)
        .unwrap()
        .to_owned();
    let d = decode_pozyx(line.as_bytes(), &RtlsConfig::default()).unwrap();
    assert_eq!(
        fixes(&d).iter().map(|f| f.tag.as_str()).collect::<Vec<_>>(),
        ["41022", "30331"]
    );
    let e = decode_pozyx(b"[{\"tagId\":1", &RtlsConfig::default()).unwrap_err();
    assert!(matches!(e, AdapterError::Json { .. }), "{e}");
    assert!(e.to_string().starts_with("payload: invalid json"), "{e}");
}

// --- Sewio ----------------------------------------------------------------------------------

#[test]
fn sewio_sample_reads_fixes_with_clr_as_covariance_and_skips_battery_messages() {
    let config = RtlsConfig {
        time_offset_ns: 0,
        z_m: 1.3,
    };
    let d = read_sewio(sample("sewio_feed.jsonl").as_bytes(), "feed.jsonl", &config).unwrap();
    let f = fixes(&d);
    assert_eq!(f.len(), 3);
    assert_time_ordered(&d);
    assert_eq!(d.skipped.count(SKIP_NOT_A_POSITION), 1);
    assert_eq!(f[0].tag.as_str(), "30");
    assert_eq!(f[0].t.as_ns(), BASE_NS + 142_000_000);
    assert!(close(f[0].position_m.x, 4.0) && close(f[0].position_m.y, -12.3));
    assert!(close(f[0].position_m.z, 1.2));
    let cov = f[0].covariance_m2.unwrap();
    assert!(close(cov[0][0], 0.01) && close(cov[2][2], 0.01) && cov[0][1] == 0.0);
    // Tag 31 is 2D: the configured z.
    assert_eq!(f[1].tag.as_str(), "31");
    assert!(close(f[1].position_m.z, 1.3));
    assert!(close(f[1].covariance_m2.unwrap()[1][1], 0.0625));
}

#[test]
fn sewio_malformed_messages_name_line_and_stream() {
    let config = RtlsConfig::default();
    let text = sample("sewio_feed.jsonl").replacen(
        "{\"id\":\"posY\",\"current_value\":\"-12.30\",\"at\":\"2024-05-14 09:30:00.142\"},",
        "",
        1,
    );
    assert_error(
        read_sewio(text.as_bytes(), "feed.jsonl", &config),
        "feed.jsonl:1: body.datastreams: posX without posY",
        "",
    );
    let text = sample("sewio_feed.jsonl").replacen("2024-05-14 09:30:00.180", "yesterday", 1);
    assert_error(
        read_sewio(text.as_bytes(), "feed.jsonl", &config),
        "feed.jsonl:2: body.datastreams[0].at: 'yesterday' is not a date-time",
        "",
    );
    let text = sample("sewio_feed.jsonl").replacen("\" 7.25\"", "true", 1);
    assert_error(
        read_sewio(text.as_bytes(), "feed.jsonl", &config),
        "feed.jsonl:2: body.datastreams[0].current_value: expected a finite number, found true",
        "",
    );
    let line = sample("sewio_feed.jsonl")
        .lines()
        .next()
        .unwrap()
        .to_owned();
    assert!(decode_sewio(line.as_bytes(), &config).is_ok());
    assert_error(
        decode_sewio(&line.as_bytes()[..50], &config),
        "payload: invalid json",
        "truncated",
    );
}

// --- Impinj ---------------------------------------------------------------------------------

fn dock() -> RfidConfig {
    RfidConfig {
        reader: "dock".to_owned(),
        time_offset_ns: 0,
    }
}

#[test]
fn impinj_sample_reads_rssi_per_reader_port_and_skips_heartbeats() {
    let d = read_impinj(
        sample("impinj_speedway.jsonl").as_bytes(),
        "sc.jsonl",
        &dock(),
    )
    .unwrap();
    let r = reads(&d);
    assert_eq!(r.len(), 3);
    assert_time_ordered(&d);
    assert_eq!(d.skipped.count(SKIP_HEARTBEAT), 1);
    assert_eq!(r[0].tag.as_str(), "E28011606000020528F904FA");
    assert_eq!(r[0].antenna.as_str(), "dock/1");
    assert_eq!(r[1].antenna.as_str(), "dock/2");
    assert_eq!(r[0].rssi_dbm, -51.0);
    assert_eq!(r[1].rssi_dbm, -58.5);
    assert_eq!(r[0].t.as_ns(), BASE_NS + 104_511_000);
    // A lower-case EPC is the same tag in upper case.
    assert_eq!(r[2].tag.as_str(), "E28011606000020528F95002");
    assert_eq!(r[0].phase_rad, None);
}

#[test]
fn impinj_malformed_reports_name_line_and_field() {
    let text =
        sample("impinj_speedway.jsonl").replacen("\"peakRssi\":-51", "\"peakRssi\":\"strong\"", 1);
    assert_error(
        read_impinj(text.as_bytes(), "sc.jsonl", &dock()),
        "sc.jsonl:1: peakRssi: expected a finite number, found \"strong\"",
        "",
    );
    let text =
        sample("impinj_speedway.jsonl").replacen("\"epc\":\"e28011606000020528f95002\",", "", 1);
    assert_error(
        read_impinj(text.as_bytes(), "sc.jsonl", &dock()),
        "sc.jsonl:4: missing field 'epc'",
        "",
    );
    // RSSI in centi-dBm (a reader configured to report dBm × 100) is implausible.
    let text =
        sample("impinj_speedway.jsonl").replacen("\"peakRssi\":-63", "\"peakRssi\":-6300", 1);
    assert_error(
        read_impinj(text.as_bytes(), "sc.jsonl", &dock()),
        "sc.jsonl:4: rssi_dbm",
        "dBm",
    );
    let text = sample("impinj_speedway.jsonl");
    assert_error(
        read_impinj(&text.as_bytes()[..60], "sc.jsonl", &dock()),
        "sc.jsonl:1: invalid json",
        "truncated",
    );
}

// --- Zebra ----------------------------------------------------------------------------------

#[test]
fn zebra_sample_reads_rssi_and_phase_in_radians() {
    let d = read_zebra(sample("zebra_iotc.jsonl").as_bytes(), "fx.jsonl", &dock()).unwrap();
    let r = reads(&d);
    assert_eq!(r.len(), 3);
    assert_time_ordered(&d);
    assert_eq!(r[0].tag.as_str(), "E28011606000020528F904FA");
    assert_eq!(r[0].antenna.as_str(), "dock/1");
    assert_eq!(r[1].antenna.as_str(), "dock/3");
    assert_eq!(r[0].rssi_dbm, -52.0);
    assert!(close(r[0].phase_rad.unwrap(), std::f64::consts::FRAC_PI_2));
    assert!(close(r[1].phase_rad.unwrap(), -std::f64::consts::FRAC_PI_4));
    assert_eq!(r[2].phase_rad, None);
    assert_eq!(r[0].t.as_ns(), BASE_NS + 108_000_000);
    assert_eq!(d.skipped.total(), 0);
}

#[test]
fn zebra_malformed_events_name_line_and_field() {
    let text = sample("zebra_iotc.jsonl").replacen("\"antenna\":3,", "", 1);
    assert_error(
        read_zebra(text.as_bytes(), "fx.jsonl", &dock()),
        "fx.jsonl:2: data: missing field 'antenna'",
        "tagMetaData",
    );
    let text =
        sample("zebra_iotc.jsonl").replacen("2024-05-14T09:30:00.255+0000", "1715679000255", 1);
    assert_error(
        read_zebra(text.as_bytes(), "fx.jsonl", &dock()),
        "fx.jsonl:3: timestamp: '1715679000255' is not a date-time",
        "",
    );
    let text = sample("zebra_iotc.jsonl").replacen("\"data\":{", "\"data\":[{", 1);
    assert_error(
        read_zebra(text.as_bytes(), "fx.jsonl", &dock()),
        "fx.jsonl:1: invalid json",
        "",
    );
    let line = sample("zebra_iotc.jsonl")
        .lines()
        .next()
        .unwrap()
        .to_owned();
    let d = decode_zebra(line.as_bytes(), &dock()).unwrap();
    assert_eq!(reads(&d)[0].antenna.as_str(), "dock/1");
    let wrong = line.replacen("\"data\":{", "\"data\":7,\"x\":{", 1);
    assert_error(
        decode_zebra(wrong.as_bytes(), &dock()),
        "payload: data: expected an object, found a number",
        "",
    );
}

#[test]
fn tracker_date_times_need_no_unit_and_are_utc() {
    let line = br#"{"time":"2024-05-14 09:30:00.250","track":4,"x":1.0,"y":2.0,"z":1.6}"#;
    let config = TrackerConfig {
        scale_m_per_unit: 1.0,
        ..tracker()
    };
    let d = decode_tracker(line, &config).unwrap();
    let s = skeletons(&d);
    assert_eq!(s[0].t.as_ns(), BASE_NS + 250_000_000);
    assert!(close(s[0].position(Joint::Head).unwrap().z, 1.6));
}

#[test]
fn a_payload_beyond_the_limit_is_refused_naming_the_limit() {
    let mut payload = b"[".to_vec();
    payload.resize(nomen_adapters::MAX_LINE_BYTES + 1, b' ');
    assert_error(
        decode_pozyx(&payload, &RtlsConfig::default()),
        "payload: payload is longer than 1048576 bytes",
        "",
    );
}

#[test]
fn tracker_columns_are_taken_in_the_documented_order_and_a_byte_order_mark_is_skipped() {
    // `id` (a row number here) is the last of the track's names: the column named first in the
    // documented order wins, whatever order the file gives them.
    let text = "\u{feff}id,track_id,t_ms,x,y\n1,7,0,100,200\n2,9,250,110,210\n";
    let d = read_tracker(text.as_bytes(), "bom.csv", &tracker()).unwrap();
    let s = skeletons(&d);
    assert_eq!(
        s.iter()
            .map(|s| (s.t.as_ns(), s.track.0))
            .collect::<Vec<_>>(),
        [(0, 7), (250_000_000, 9)]
    );
}
