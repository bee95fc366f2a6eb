//! CSV files as devices and spreadsheets write them: `;` and decimal commas, tabs, date-times
//! with a time zone, epoch stamps, unsorted rows, repeated times, batched delivery and units
//! from a units file; on fixtures written here and on the shared x-io and BROAD recordings.
// Test helpers outside #[test] functions unwrap too: a failure is a test failure.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use nomen_core::{DeviceId, ImuSample, Message, RtlsFix};
use nomen_recording::csv::{
    BatchPolicy, ColumnUnits, CsvImport, CsvOptions, DecimalSeparator, Duplicates, FixCsvSpec,
    OrderPolicy, TimeFormat, TimeUnit, import_fixes, import_imu_auto,
};

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../../shared/data");

const IMU_HEAD: &str = "t_s,accel_x_g,accel_y_g,accel_z_g,gyro_x_dps,gyro_y_dps,gyro_z_dps\n";

fn imu(text: &str, options: &CsvOptions) -> nomen_recording::Result<CsvImport> {
    import_imu_auto(text.as_bytes(), "imu.csv", DeviceId::new("watch"), options).map(|(_, i)| i)
}

fn samples(import: &CsvImport) -> Vec<&ImuSample> {
    import
        .messages
        .iter()
        .map(|m| match m {
            Message::Imu(s) => s,
            other => panic!("not an imu sample: {other:?}"),
        })
        .collect()
}

fn fixes(import: &CsvImport) -> Vec<&RtlsFix> {
    import
        .messages
        .iter()
        .map(|m| match m {
            Message::RtlsFix(f) => f,
            other => panic!("not a fix: {other:?}"),
        })
        .collect()
}

#[test]
fn a_spreadsheet_export_with_semicolons_and_decimal_commas_reads_as_its_numbers() {
    let text = "Time (s);Acc X (g);Acc Y (g);Acc Z (g);Gyro X (deg/s);Gyro Y (deg/s);Gyro Z (deg/s)\n\
                0,00;0,01;-0,02;1,0;0;0;180\n\
                0,01;0,01;-0,02;0,998;0;0;-90,5\n";
    let import = imu(text, &CsvOptions::default()).unwrap();
    assert_eq!(import.report.dialect.delimiter, b';');
    assert_eq!(import.report.dialect.decimal, DecimalSeparator::Comma);
    let s = samples(&import);
    assert_eq!(s[1].t.as_ns(), 10_000_000);
    assert!((s[1].accel_mps2.z - 0.998 * 9.806_65).abs() < 1e-12);
    assert!((s[1].gyro_radps.unwrap().z + 90.5_f64.to_radians()).abs() < 1e-12);
    // The same file with the separators given.
    let given = CsvOptions {
        delimiter: Some(b';'),
        decimal: Some(DecimalSeparator::Comma),
        ..CsvOptions::default()
    };
    assert_eq!(imu(text, &given).unwrap().messages, import.messages);
}

#[test]
fn the_real_xio_file_saved_with_semicolons_and_decimal_commas_imports_alike() {
    let path = format!("{DATA}/imu/xio/sensor_data.csv");
    let Ok(original) = std::fs::read_to_string(&path) else {
        println!("skipping: {path} not found");
        return;
    };
    // What a spreadsheet in a comma-decimal locale saves.
    let european: String = original.replace(',', ";").replace('.', ",");
    let read = |text: &str| {
        import_imu_auto(
            text.as_bytes(),
            &path,
            DeviceId::new("xio"),
            &CsvOptions::default(),
        )
        .unwrap()
        .1
    };
    let a = read(&original);
    let b = read(&european);
    assert_eq!(a.messages.len(), 13_514);
    assert_eq!(b.report.dialect.decimal, DecimalSeparator::Comma);
    assert_eq!(a.messages, b.messages);
}

#[test]
fn tab_separated_date_times_at_plus_two_hours_become_utc_instants() {
    // 2019-09-12 14:03:21.250 at +02:00 is 12:03:21.250 UTC = 1568289801.250 s since the epoch
    // (Python: datetime(2019, 9, 12, 12, 3, 21, tzinfo=timezone.utc).timestamp()).
    let text = "time\ttag\tx (m)\ty (m)\tz (m)\n\
                2019-09-12 14:03:21.250\tt1\t1,5\t2\t1\n\
                2019-09-12 14:03:21.350\tt1\t1,6\t2\t1\n\
                2019-09-12T12:03:21.450Z\tt1\t1,7\t2\t1\n";
    let options = CsvOptions {
        utc_offset_s: 7200,
        ..CsvOptions::default()
    };
    let import = import_fixes(
        text.as_bytes(),
        "fixes.tsv",
        &FixCsvSpec::default(),
        &options,
    )
    .unwrap();
    assert_eq!(
        import.report.time_format,
        Some(TimeFormat::DateTime { utc_offset_s: 7200 })
    );
    let f = fixes(&import);
    assert_eq!(f[0].t.as_ns(), 1_568_289_801_250_000_000);
    assert_eq!(f[1].t.as_ns(), 1_568_289_801_350_000_000);
    // A stamp with its own zone keeps it.
    assert_eq!(f[2].t.as_ns(), 1_568_289_801_450_000_000);
    assert_eq!(f[0].position_m.x, 1.5);
}

#[test]
fn epoch_milliseconds_in_a_column_without_unit_need_the_unit_given() {
    let text = "timestamp,tag,x_m,y_m,z_m\n1568289801250,t1,1,2,1\n1568289801350,t1,1,2,1\n";
    let err = import_fixes(
        text.as_bytes(),
        "fixes.csv",
        &FixCsvSpec::default(),
        &CsvOptions::default(),
    )
    .unwrap_err();
    assert!(
        err.to_string()
            .starts_with("fixes.csv:1: column 'timestamp' has no unit"),
        "{err}"
    );
    let options = CsvOptions {
        time_unit: Some(TimeUnit::Milliseconds),
        ..CsvOptions::default()
    };
    let import = import_fixes(
        text.as_bytes(),
        "fixes.csv",
        &FixCsvSpec::default(),
        &options,
    )
    .unwrap();
    assert_eq!(import.messages[0].t().as_ns(), 1_568_289_801_250_000_000);
    // Or from a units file.
    let options = CsvOptions {
        units: ColumnUnits::new([("timestamp".to_owned(), "ms".to_owned())]),
        ..CsvOptions::default()
    };
    let again = import_fixes(
        text.as_bytes(),
        "fixes.csv",
        &FixCsvSpec::default(),
        &options,
    )
    .unwrap();
    assert_eq!(again.messages, import.messages);
}

#[test]
fn rows_out_of_order_within_the_window_are_sorted_and_counted() {
    let rows = [0.00, 0.02, 0.01, 0.03, 0.05, 0.04, 0.06];
    let mut text = IMU_HEAD.to_owned();
    for t in rows {
        text.push_str(&format!("{t:.2},0,0,1,0,0,0\n"));
    }
    let import = imu(&text, &CsvOptions::default()).unwrap();
    assert_eq!(import.report.num_reordered, 2);
    let t: Vec<i64> = import.messages.iter().map(|m| m.t().as_ns()).collect();
    assert_eq!(t, (0..7).map(|k| k * 10_000_000).collect::<Vec<_>>());
    // A window of 5 ms is too short for a row 10 ms back; the row before it jumped 20 ms
    // ahead of its own predecessor, more than the window too: that row is named.
    let options = CsvOptions {
        order: OrderPolicy {
            window_ns: 5_000_000,
            ..OrderPolicy::default()
        },
        ..CsvOptions::default()
    };
    let err = imu(&text, &options).unwrap_err();
    assert_eq!(
        err.to_string(),
        "imu.csv:3: time 0.020000 s is after both the row before it (0.000000 s, line 2) and the \
         row after it (0.010000 s, line 4): a corrupt time or a row out of place"
    );
}

#[test]
fn repeated_times_are_averaged_by_default_or_dropped_and_counted() {
    let text = format!(
        "{IMU_HEAD}0.00,0,0,1,0,0,0\n0.01,0,0,1,0,0,10\n0.01,0,0,1.1,0,0,20\n0.01,0,0,1.2,0,0,30\n0.02,0,0,1,0,0,0\n"
    );
    let averaged = imu(&text, &CsvOptions::default()).unwrap();
    assert_eq!(averaged.report.num_read, 5);
    assert_eq!(averaged.report.num_duplicates, 2);
    let s = samples(&averaged);
    assert_eq!(s.len(), 3);
    assert!((s[1].accel_mps2.z - 1.1 * 9.806_65).abs() < 1e-12);
    assert!((s[1].gyro_radps.unwrap().z - 20_f64.to_radians()).abs() < 1e-12);
    let options = CsvOptions {
        order: OrderPolicy {
            duplicates: Duplicates::Drop,
            ..OrderPolicy::default()
        },
        ..CsvOptions::default()
    };
    let dropped = imu(&text, &options).unwrap();
    assert_eq!(dropped.report.num_duplicates, 2);
    let s = samples(&dropped);
    assert!((s[1].gyro_radps.unwrap().z - 10_f64.to_radians()).abs() < 1e-12);
    assert!(
        dropped
            .report
            .to_string()
            .contains("5 messages read, 0 sorted into place, 2 at a repeated time dropped"),
        "{}",
        dropped.report
    );
}

/// A 100-Hz watch that sends what it has every 50 ms, 3 to 6 samples at a time (its clock
/// wanders against the sending), each stamped on arrival within 3 ms: (file, true times).
fn batched_watch(num_batches: usize) -> (String, Vec<i64>) {
    let mut text = IMU_HEAD.to_owned();
    let mut truth = Vec::new();
    let mut taken = 0i64;
    for b in 1..=num_batches as i64 {
        // Batches of 5 on average, 3 to 6 at times.
        let k = [5, 5, 3, 6, 5, 6, 5, 5][b as usize % 8];
        let sent_ns = b * 50_000_000 + 7_000_000;
        for i in 0..k {
            truth.push(taken);
            taken += 10_000_000;
            let stamp_ns = sent_ns - (k - 1 - i) * 600_000;
            text.push_str(&format!(
                "{}.{:09},0,0,1,0,0,{}\n",
                stamp_ns / 1_000_000_000,
                stamp_ns % 1_000_000_000,
                i
            ));
        }
    }
    (text, truth)
}

#[test]
fn a_watch_delivering_batches_is_retimed_at_its_fitted_rate() {
    let (text, truth) = batched_watch(200);
    let import = imu(&text, &CsvOptions::default()).unwrap();
    let [batching] = import.report.batching.as_slice() else {
        panic!("not found batched: {:?}", import.report);
    };
    assert_eq!(batching.num_batches, 200);
    assert!(batching.median_interval_s <= 0.000_6 + 1e-9, "{batching}");
    assert!((batching.fitted_rate_hz - 100.0).abs() < 1.0, "{batching}");
    assert!(batching.is_retimed);
    let t: Vec<i64> = import.messages.iter().map(|m| m.t().as_ns()).collect();
    assert_eq!(t.len(), truth.len());
    // Re-timed, the samples are 10 ms apart but where a batch of 3 or 6 made up for the
    // sending's wander (6 samples in a 50-ms gap: 8.3 ms apart).
    let dts: Vec<i64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    let mut sorted = dts.clone();
    sorted.sort_unstable();
    assert!(
        (sorted[sorted.len() / 2] - 10_000_000).abs() < 100_000,
        "{:?}",
        &sorted[..10]
    );
    assert!(dts.iter().all(|&d| d > 5_000_000), "{:?}", &sorted[..10]);
    // Kept: the stamps as in the file, still reported.
    let options = CsvOptions {
        order: OrderPolicy {
            batches: BatchPolicy::Keep,
            ..OrderPolicy::default()
        },
        ..CsvOptions::default()
    };
    let kept = imu(&text, &options).unwrap();
    assert!(!kept.report.batching[0].is_retimed);
    assert!(
        kept.report.batching[0]
            .to_string()
            .starts_with("imu 'watch' arrives in batches: 1000 samples in 200 batches"),
        "{}",
        kept.report.batching[0]
    );
}

#[test]
fn broad_columns_without_units_take_them_from_a_units_file() {
    let path = format!("{DATA}/imu/broad/07_undisturbed_fast_rotation_B.csv");
    let Ok(text) = std::fs::read_to_string(&path) else {
        println!("skipping: {path} not found");
        return;
    };
    let device = || DeviceId::new("broad");
    let err =
        import_imu_auto(text.as_bytes(), &path, device(), &CsvOptions::default()).unwrap_err();
    assert_eq!(
        err.to_string(),
        format!(
            "{path}:1: column 'acc_x' has no unit: add one such as (m/s^2) or (g), or give it in \
             a units file"
        )
    );
    // The dataset's README: acc in m/s², gyr in rad/s, mag in µT.
    let options = CsvOptions {
        units: ColumnUnits::new(
            [("acc_*", "m/s^2"), ("gyr_*", "rad/s"), ("mag_*", "uT")]
                .map(|(c, u)| (c.to_owned(), u.to_owned())),
        ),
        ..CsvOptions::default()
    };
    let (spec, import) = import_imu_auto(text.as_bytes(), &path, device(), &options).unwrap();
    assert_eq!(spec.columns.len(), 9);
    let s = samples(&import);
    assert_eq!(s.len(), text.lines().count() - 1);
    // 285.714 Hz, steady: no batching, nothing merged.
    let rate_hz = (s.len() - 1) as f64 / s[s.len() - 1].t.secs_since(s[0].t);
    assert!((rate_hz - 285.714).abs() < 0.5, "{rate_hz}");
    assert!(import.report.batching.is_empty());
    assert_eq!(import.report.num_duplicates, 0);
    // At rest at the start: gravity.
    assert!((s[0].accel_mps2.norm() - 9.81).abs() < 0.2);
    // A units file naming a column the file lacks is a typo, named.
    let typo = CsvOptions {
        units: ColumnUnits::new([("accel_*".to_owned(), "g".to_owned())]),
        ..CsvOptions::default()
    };
    let err = import_imu_auto(text.as_bytes(), &path, device(), &typo).unwrap_err();
    assert_eq!(
        err.to_string(),
        format!("{path}:1: the units file names column 'accel_*', which the file does not have")
    );
}
