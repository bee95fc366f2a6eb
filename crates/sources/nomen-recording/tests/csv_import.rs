//! CSV import: the real x-io IMU export, tag fixes and skeletons in both layouts.
// Test helpers outside #[test] functions unwrap too: a failure is a test failure.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use nomen_core::skeleton::sets::JointSet;
use nomen_core::{DeviceId, Joint, JointState, Message};
use nomen_recording::csv::{
    AccelUnit, CsvImport, CsvOptions, FixCsvSpec, GyroUnit, ImuColumn, ImuCsvSpec, ImuQuantity,
    LengthUnit, SkeletonCsvSpec, SkeletonLayout, TimeFormat, TimeUnit, import_fixes, import_imu,
    import_imu_auto, import_skeletons,
};

/// Imports an IMU file named `imu.csv` of device `d` with the default options.
fn imu_csv(input: impl std::io::Read) -> nomen_recording::Result<(ImuCsvSpec, CsvImport)> {
    import_imu_auto(input, "imu.csv", DeviceId::new("d"), &CsvOptions::default())
}

const XIO_CSV: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../../../shared/data/imu/xio/sensor_data.csv"
);

#[test]
fn xio_export_is_still_at_the_start_and_sampled_at_100_hz() {
    let Ok(file) = std::fs::File::open(XIO_CSV) else {
        println!("skipping: {XIO_CSV} not found");
        return;
    };
    let (spec, imported) = import_imu_auto(
        std::io::BufReader::new(file),
        XIO_CSV,
        DeviceId::new("xio"),
        &CsvOptions::default(),
    )
    .unwrap();
    let messages = imported.messages;
    assert_eq!(spec.time_format, TimeFormat::Epoch(TimeUnit::Seconds));
    assert_eq!(spec.columns.len(), 9);
    assert!(spec.columns.contains(&ImuColumn {
        column: "Accelerometer Z (g)".into(),
        quantity: ImuQuantity::Accel(AccelUnit::StandardGravity),
        axis: 2,
    }));
    let samples: Vec<_> = messages
        .iter()
        .map(|m| match m {
            Message::Imu(s) => s,
            other => panic!("not an imu sample: {other:?}"),
        })
        .collect();
    // One sample per data row (the file has 13515 lines: header + 13514 rows).
    assert_eq!(samples.len(), 13_514);
    // Times strictly increase at about 100 Hz.
    let dts: Vec<f64> = samples
        .windows(2)
        .map(|w| w[1].t.secs_since(w[0].t))
        .collect();
    assert!(dts.iter().all(|&dt| dt > 0.0));
    let mean_dt = samples.last().unwrap().t.secs_since(samples[0].t) / dts.len() as f64;
    assert!((mean_dt - 0.01).abs() < 0.0005, "mean dt {mean_dt} s");
    // The first second is still: |a| is gravity within 2 %, |ω| is small.
    for s in samples.iter().take(100) {
        let a = s.accel_mps2.norm();
        assert!((a - 9.81).abs() < 0.02 * 9.81, "|a| = {a} at {}", s.t);
        assert!(
            s.gyro_radps.unwrap().norm() < 0.05,
            "|w| = {} at {}",
            s.gyro_radps.unwrap().norm(),
            s.t
        );
        let m = s.mag_ut.unwrap().norm();
        assert!(
            (20.0..=70.0).contains(&m),
            "|m| = {m} µT is not an Earth-like field"
        );
    }
    // Somewhere later the sensor moves: the gyro sees more than 1 rad/s.
    assert!(samples.iter().any(|s| s.gyro_radps.unwrap().norm() > 1.0));
}

#[test]
fn explicit_spec_converts_units_and_offsets_time() {
    let text = "stamp,ax,ay,az,wx,wy,wz\n1000,0,0,1,0,0,90\n1010,0,0,1,0,0,-180\n";
    let col = |name: &str, quantity, axis| ImuColumn {
        column: name.into(),
        quantity,
        axis,
    };
    let g = ImuQuantity::Accel(AccelUnit::StandardGravity);
    let dps = ImuQuantity::Gyro(GyroUnit::DegreesPerSecond);
    let spec = ImuCsvSpec {
        device: DeviceId::new("band1"),
        time_column: "stamp".into(),
        time_format: TimeFormat::Epoch(TimeUnit::Milliseconds),
        time_offset_ns: -1_000_000_000,
        columns: vec![
            col("ax", g, 0),
            col("ay", g, 1),
            col("az", g, 2),
            col("wx", dps, 0),
            col("wy", dps, 1),
            col("wz", dps, 2),
        ],
    };
    let messages = import_imu(text.as_bytes(), "band.csv", &spec, &CsvOptions::default())
        .unwrap()
        .messages;
    let Message::Imu(second) = &messages[1] else {
        panic!()
    };
    assert_eq!(second.t.as_ns(), 10_000_000);
    assert_eq!(second.accel_mps2.z, 9.806_65);
    assert!((second.gyro_radps.unwrap().z + std::f64::consts::PI).abs() < 1e-12);
    assert!(second.mag_ut.is_none());
}

#[test]
fn imu_csv_errors_name_file_line_and_column() {
    let head = "t_s,accel_x_g,accel_y_g,accel_z_g,gyro_x_dps,gyro_y_dps,gyro_z_dps\n";
    let text = format!("{head}0.00,0,0,1,0,0,0\n0.01,0,0,abc,0,0,0\n");
    let err = imu_csv(text.as_bytes()).unwrap_err();
    assert_eq!(
        err.to_string(),
        "imu.csv:3: column 'accel_z_g': cannot read 'abc' as a number"
    );

    // A header of a hundred thousand columns (the importers sought each column among all of
    // them); a million would pass the longest line before the column count.
    let wide = format!(
        "{}{}\n0.00,0,0,1,0,0,0\n",
        head.trim_end(),
        ",x".repeat(100_000)
    );
    let err = imu_csv(wide.as_bytes()).unwrap_err();
    assert_eq!(
        err.to_string(),
        "imu.csv:1: 100007 columns, more than the 4096 a table of samples may have"
    );

    // A row whose time jumped ahead is named, not the good row after it.
    let text =
        format!("{head}0.00,0,0,1,0,0,0\n0.01,0,0,1,0,0,0\n999,0,0,1,0,0,0\n0.03,0,0,1,0,0,0\n");
    let err = imu_csv(text.as_bytes()).unwrap_err();
    assert_eq!(
        err.to_string(),
        "imu.csv:4: time 999.000000 s is after both the row before it (0.010000 s, line 3) and \
         the row after it (0.030000 s, line 5): a corrupt time or a row out of place"
    );
    // A row that goes back in time by more than the reorder window, with no jump before it,
    // is the row named.
    let text =
        format!("{head}0.00,0,0,1,0,0,0\n1.00,0,0,1,0,0,0\n2.00,0,0,1,0,0,0\n0.50,0,0,1,0,0,0\n");
    let err = imu_csv(text.as_bytes()).unwrap_err();
    assert_eq!(
        err.to_string(),
        "imu.csv:5: time 0.500000 s is 1.500 s before time 2.000000 s of line 4 of the same \
         source, more than the 1 s within which rows are sorted (--reorder-window-s): a corrupt \
         time or rows out of place"
    );

    // 100 g is beyond any wearable: probably m/s² labelled as g.
    let text = format!("{head}0.00,0,0,100,0,0,0\n");
    let err = imu_csv(text.as_bytes()).unwrap_err();
    assert!(
        err.to_string()
            .starts_with("imu.csv:2: accel_mps2[2] = 980.665 is outside"),
        "{err}"
    );

    let text = "t_s,accel_x,accel_y,accel_z\n0,0,0,1\n";
    let err = imu_csv(text.as_bytes()).unwrap_err();
    assert!(
        err.to_string()
            .starts_with("imu.csv:1: column 'accel_x' has no unit"),
        "{err}"
    );

    let text = format!("{head}0.00,0,0,1,0,0\n");
    let err = imu_csv(text.as_bytes()).unwrap_err();
    assert_eq!(err.to_string(), "imu.csv:2: row has 6 fields, expected 7");

    let err = imu_csv("".as_bytes()).unwrap_err();
    assert_eq!(
        err.to_string(),
        "imu.csv:1: empty csv file: expected a row of column names"
    );
}

#[test]
fn tag_fixes_take_units_from_names_or_spec() {
    let text = "t_ms,tag,x_mm,y_mm,z_mm,quality\n100,tag1,1000,2000,1300,0.9\n100,tag2,0,0,0,\n";
    let messages = import_fixes(
        text.as_bytes(),
        "fixes.csv",
        &FixCsvSpec::default(),
        &CsvOptions::default(),
    )
    .unwrap()
    .messages;
    assert_eq!(messages.len(), 2);
    let Message::RtlsFix(f) = &messages[0] else {
        panic!()
    };
    assert_eq!(f.t.as_ns(), 100_000_000);
    assert_eq!(f.position_m.coords.as_slice(), &[1.0, 2.0, 1.3]);
    assert_eq!(f.quality, Some(0.9));
    let Message::RtlsFix(f) = &messages[1] else {
        panic!()
    };
    assert_eq!(f.quality, None);

    let bare = "t,tag,x,y,z\n0.5,tag1,1,2,1.3\n";
    let err = import_fixes(
        bare.as_bytes(),
        "fixes.csv",
        &FixCsvSpec::default(),
        &CsvOptions::default(),
    )
    .unwrap_err();
    assert_eq!(
        err.to_string(),
        "fixes.csv:1: column 't' has no unit: rename it like 't (s)' (the unit after an \
         underscore or in brackets), give it in a units file or as the time unit (nomen import \
         --units, --time-unit), or, from the library, in the import spec; date-times are read \
         as such"
    );
    let spec = FixCsvSpec {
        time_unit: Some(TimeUnit::Seconds),
        length_unit: Some(LengthUnit::Metres),
        time_offset_ns: 0,
    };
    let messages = import_fixes(bare.as_bytes(), "fixes.csv", &spec, &CsvOptions::default())
        .unwrap()
        .messages;
    assert_eq!(messages[0].t().as_ns(), 500_000_000);

    // A unit the importer does not know is named as such, not as a missing column.
    let feet = "t_s,tag,x_ft,y_m,z_m\n0.5,tag1,1,2,1.3\n";
    let err = import_fixes(
        feet.as_bytes(),
        "fixes.csv",
        &FixCsvSpec::default(),
        &CsvOptions::default(),
    )
    .unwrap_err();
    assert_eq!(
        err.to_string(),
        "fixes.csv:1: column 'x_ft': unknown unit 'ft' for 'x'"
    );
    // A delimiter given that is not the file's is named.
    let semicolons = "t_s;tag;x_m;y_m;z_m\n0.5;tag1;1;2;1.3\n";
    let err = import_fixes(
        semicolons.as_bytes(),
        "fixes.csv",
        &FixCsvSpec::default(),
        &CsvOptions {
            delimiter: Some(b','),
            ..CsvOptions::default()
        },
    )
    .unwrap_err();
    assert!(
        err.to_string()
            .starts_with("fixes.csv:1: the columns are separated by ';', not by ','"),
        "{err}"
    );

    let missing = "t (s),x (m),y (m),z (m)\n0,1,2,3\n";
    let err = import_fixes(
        missing.as_bytes(),
        "fixes.csv",
        &spec,
        &CsvOptions::default(),
    )
    .unwrap_err();
    assert_eq!(
        err.to_string(),
        "fixes.csv:1: missing column 'tag' (columns are: t (s), x (m), y (m), z (m))"
    );
}

#[test]
fn a_file_that_is_no_table_of_samples_is_refused_without_its_first_row() {
    let passwd = "root:x:0:0:secret-token:/root:/bin/bash\nbin:x:1:1:bin:/bin:/sbin/nologin\n";
    let spec = SkeletonCsvSpec::default();
    let errors = [
        import_fixes(
            passwd.as_bytes(),
            "passwd",
            &FixCsvSpec::default(),
            &CsvOptions::default(),
        )
        .unwrap_err(),
        import_skeletons(passwd.as_bytes(), "passwd", &spec, &CsvOptions::default()).unwrap_err(),
        import_imu_auto(
            passwd.as_bytes(),
            "passwd",
            DeviceId::new("d"),
            &CsvOptions::default(),
        )
        .unwrap_err(),
        import_imu(
            passwd.as_bytes(),
            "passwd",
            &ImuCsvSpec {
                device: DeviceId::new("d"),
                time_column: "t (s)".into(),
                time_format: TimeFormat::Epoch(TimeUnit::Seconds),
                time_offset_ns: 0,
                columns: Vec::new(),
            },
            &CsvOptions::default(),
        )
        .unwrap_err(),
    ];
    for err in errors {
        let err = err.to_string();
        assert!(err.starts_with("passwd:1: "), "{err}");
        assert!(!err.contains("secret-token"), "{err}");
        assert!(!err.contains("root:x"), "{err}");
    }
    let err = import_fixes(
        passwd.as_bytes(),
        "passwd",
        &FixCsvSpec::default(),
        &CsvOptions::default(),
    )
    .unwrap_err();
    assert_eq!(
        err.to_string(),
        "passwd:1: missing column 't' (the first row has 1 column(s) and none is a time column \
         't', 'time' or 'timestamp': not a table of samples? (its content is not shown))"
    );
}

#[test]
fn joint_per_row_skeletons_group_consecutive_rows() {
    let text = "\
t (s),camera,track,joint,x (m),y (m),z (m),confidence,state
0.000,kinect,1,head,0.0,1.7,2.5,0.9,tracked
0.000,kinect,1,left_wrist,0.3,1.0,2.4,,inferred
0.000,kinect,2,head,1.0,1.6,3.0,,
0.033,kinect,1,head,0.0,1.7,2.5,1,tracked
";
    let spec = SkeletonCsvSpec::default();
    let messages = import_skeletons(text.as_bytes(), "sk.csv", &spec, &CsvOptions::default())
        .unwrap()
        .messages;
    assert_eq!(messages.len(), 3);
    let Message::Skeleton(first) = &messages[0] else {
        panic!()
    };
    assert_eq!(first.track.0, 1);
    assert_eq!(first.joints.len(), 2);
    assert_eq!(first.joints.get(Joint::Head).unwrap().confidence, 0.9);
    let wrist = first.joints.get(Joint::LeftWrist).unwrap();
    assert_eq!((wrist.confidence, wrist.state), (1.0, JointState::Inferred));
    assert_eq!(messages[2].t().as_ns(), 33_000_000);

    // A bad value on a skeleton's second row is named on that row, not the skeleton's first.
    let bad = text.replace("0.3,1.0,2.4,,inferred", "0.3,1.0,2.4,5,inferred");
    let err =
        import_skeletons(bad.as_bytes(), "sk.csv", &spec, &CsvOptions::default()).unwrap_err();
    assert!(
        err.to_string()
            .starts_with("sk.csv:3: joints.left_wrist.confidence = 5"),
        "{err}"
    );

    let bad = text.replace("left_wrist", "left_pinky");
    let err =
        import_skeletons(bad.as_bytes(), "sk.csv", &spec, &CsvOptions::default()).unwrap_err();
    assert!(
        err.to_string()
            .starts_with("sk.csv:3: unknown joint 'left_pinky'"),
        "{err}"
    );
}

#[test]
fn kinect_joint_names_map_to_canonical_joints_in_millimetres() {
    let text = "\
t_ms,camera,track,joint,x_mm,y_mm,z_mm
0,kinect,7,ShoulderLeft,-200,1400,2500
0,kinect,7,ShoulderRight,200,1400,2500
0,kinect,7,HandTipLeft,-300,900,2400
0,kinect,7,WristLeft,-250,1000,2400
";
    let spec = SkeletonCsvSpec {
        joint_set: Some(JointSet::KinectV2),
        ..SkeletonCsvSpec::default()
    };
    let messages = import_skeletons(text.as_bytes(), "k.csv", &spec, &CsvOptions::default())
        .unwrap()
        .messages;
    let Message::Skeleton(s) = &messages[0] else {
        panic!()
    };
    // HandTipLeft has no canonical joint; Kinect v2 reports a neck, so none is derived.
    let joints: Vec<Joint> = s.joints.iter().map(|(j, _)| j).collect();
    assert_eq!(
        joints,
        vec![Joint::LeftShoulder, Joint::LeftWrist, Joint::RightShoulder]
    );
    assert_eq!(
        s.position(Joint::LeftWrist).unwrap().coords.as_slice(),
        &[-0.25, 1.0, 2.4]
    );
}

#[test]
fn skeleton_per_row_with_coco_names_derives_the_neck() {
    let text = "\
t (s),camera,track,left_shoulder_x (m),left_shoulder_y (m),left_shoulder_z (m),right_shoulder_x (m),right_shoulder_y (m),right_shoulder_z (m),nose_x (m),nose_y (m),nose_z (m)
0.0,cam,1,-0.2,1.4,2.5,0.2,1.4,2.5,,,
0.1,cam,1,-0.2,1.4,2.5,0.2,1.5,2.5,0,1.7,2.5
";
    let spec = SkeletonCsvSpec {
        layout: SkeletonLayout::SkeletonPerRow,
        joint_set: Some(JointSet::Coco17),
        ..SkeletonCsvSpec::default()
    };
    let messages = import_skeletons(text.as_bytes(), "wide.csv", &spec, &CsvOptions::default())
        .unwrap()
        .messages;
    assert_eq!(messages.len(), 2);
    let Message::Skeleton(first) = &messages[0] else {
        panic!()
    };
    assert!(first.joints.get(Joint::Head).is_none());
    let neck = first.joints.get(Joint::Neck).unwrap();
    assert_eq!(neck.state, JointState::Inferred);
    assert_eq!(neck.position_m.coords.as_slice(), &[0.0, 1.4, 2.5]);
    let Message::Skeleton(second) = &messages[1] else {
        panic!()
    };
    assert_eq!(second.position(Joint::Head).unwrap().y, 1.7);
}

/// `head` once, then `pattern` repeated for ever: an import without bounds never ends on it.
struct Endless {
    head: &'static [u8],
    pattern: &'static [u8],
    at: usize,
}

impl std::io::Read for Endless {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        for b in buf.iter_mut() {
            *b = match self.head.get(self.at) {
                Some(h) => *h,
                None => self.pattern[(self.at - self.head.len()) % self.pattern.len()],
            };
            self.at += 1;
        }
        Ok(buf.len())
    }
}

const IMU_HEAD: &[u8] = b"t_s,accel_x_g,accel_y_g,accel_z_g,gyro_x_dps,gyro_y_dps,gyro_z_dps\n";

fn endless(pattern: &'static [u8]) -> Endless {
    Endless {
        head: IMU_HEAD,
        pattern,
        at: 0,
    }
}

#[test]
fn an_endless_row_is_refused_at_the_row_limit() {
    let err = imu_csv(endless(b"0")).unwrap_err();
    assert_eq!(
        err.to_string(),
        "imu.csv:2: the line is longer than 1 MiB, the longest line a CSV file may have"
    );
    // Without a header line either.
    let zeros = Endless {
        head: b"",
        pattern: b"\0",
        at: 0,
    };
    let err = import_fixes(
        zeros,
        "z.csv",
        &FixCsvSpec::default(),
        &CsvOptions::default(),
    )
    .unwrap_err();
    assert_eq!(
        err.to_string(),
        "z.csv:1: the line is longer than 1 MiB, the longest line a CSV file may have"
    );
}

#[test]
fn an_endless_file_is_refused_at_the_file_limit() {
    // Blank lines make no rows: the file limit stops them.
    let err = imu_csv(endless(b"\n")).unwrap_err();
    assert!(
        err.to_string()
            .ends_with(": the file holds more than 256 MiB, the most a CSV file may have"),
        "{err}"
    );
}

/// An IMU table of endless good rows, 1 ms apart.
struct EndlessRows {
    pending: Vec<u8>,
    row: u64,
}

impl std::io::Read for EndlessRows {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        while self.pending.len() < buf.len() {
            let row = format!("{}.{:03},0,0,1,0,0,0\n", self.row / 1000, self.row % 1000);
            self.pending.extend_from_slice(row.as_bytes());
            self.row += 1;
        }
        let n = buf.len();
        buf.copy_from_slice(&self.pending[..n]);
        self.pending.drain(..n);
        Ok(n)
    }
}

#[test]
fn endless_good_rows_are_refused_when_their_messages_pass_the_memory_limit() {
    let rows = EndlessRows {
        pending: IMU_HEAD.to_vec(),
        row: 0,
    };
    let err = imu_csv(rows).unwrap_err();
    let message_bytes = std::mem::size_of::<Message>() as u64;
    // The first row past the limit: the header is line 1.
    let line = nomen_recording::csv::MAX_CSV_MESSAGE_BYTES / message_bytes + 2;
    assert_eq!(
        err.to_string(),
        format!(
            "imu.csv:{line}: the rows so far make more than 512 MiB of messages, the most a CSV \
             import may hold: split the file"
        )
    );
}

#[test]
fn a_file_without_gyroscope_columns_is_an_accelerometer_only_device() {
    // A watch at 12.5 Hz that has only an accelerometer, in g.
    let text = "t_s,accel_x_g,accel_y_g,accel_z_g\n0.00,0,0,1\n0.08,0.1,0,0.98\n0.16,0,0.2,1.01\n";
    let (spec, imported) = imu_csv(text.as_bytes()).unwrap();
    assert_eq!(spec.columns.len(), 3);
    let samples: Vec<_> = imported
        .messages
        .iter()
        .map(|m| match m {
            Message::Imu(s) => s,
            other => panic!("not an imu sample: {other:?}"),
        })
        .collect();
    assert_eq!(samples.len(), 3);
    assert!(samples.iter().all(|s| s.gyro_radps.is_none()));
    assert!((samples[1].accel_mps2.x - 0.980_665).abs() < 1e-12);
    // Two of the three gyroscope axes is still an error: all three or none.
    let partial = "t_s,accel_x_g,accel_y_g,accel_z_g,gyro_x_dps,gyro_y_dps\n0.00,0,0,1,0,0\n";
    let err = imu_csv(partial.as_bytes()).unwrap_err().to_string();
    assert!(
        err.contains("the gyroscope needs x, y and z columns, found 2"),
        "{err}"
    );
}
