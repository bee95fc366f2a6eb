//! Malformed input: every loader names the source and line of the first bad row.

use nomen_fit::load::{
    ImuCsvFormat, RssiCsvFormat, UwbCsvFormat, parse_anchors_csv, parse_imu_csv, parse_mocap_csv,
    parse_rssi_csv, parse_uwb_csv,
};

const BROAD_HEADER: &str = "t_s,acc_x,acc_y,acc_z,gyr_x,gyr_y,gyr_z,mag_x,mag_y,mag_z,gt_qw,gt_qx,gt_qy,gt_qz,gt_px,gt_py,gt_pz,movement";
const BROAD_ROW: &str =
    "0,0.11,0.007,9.86,0.0074,0.0010,-0.0053,0.63,15.0,-40.2,nan,nan,nan,nan,0.09,-0.56,1.22,0";

/// [`BROAD_ROW`] at time `t_s`.
fn broad_row_at(t_s: &str) -> String {
    BROAD_ROW.replacen("0,", &format!("{t_s},"), 1)
}

/// The error a loader gives, as text (a loader that succeeds fails the test).
fn err_text<T>(result: Result<T, nomen_fit::FitError>) -> String {
    match result {
        Ok(_) => panic!("parsed"),
        Err(e) => e.to_string(),
    }
}

fn imu_err(text: &str) -> String {
    match parse_imu_csv(text, "broad.csv", &ImuCsvFormat::broad()) {
        Ok(_) => String::from("(parsed)"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn broad_truncated_row_names_line_and_field_count() {
    let text = format!("{BROAD_HEADER}\n{BROAD_ROW}\n0.0035,0.1,0.2,9.8,0.01\n");
    assert_eq!(
        imu_err(&text),
        "broad.csv:3: expected 18 fields, found 5 (truncated or malformed row)"
    );
}

#[test]
fn broad_non_numeric_gyro_names_column() {
    let bad = broad_row_at("0.007").replace("0.0074", "0.0O74");
    let text = format!(
        "{BROAD_HEADER}\n{BROAD_ROW}\n{}\n{bad}\n",
        broad_row_at("0.0035")
    );
    assert_eq!(
        imu_err(&text),
        "broad.csv:4: column 'gyr_x': '0.0O74' is not a number"
    );
}

#[test]
fn broad_nan_accelerometer_is_rejected_but_nan_truth_is_not() {
    let bad = broad_row_at("0.0035").replace("9.86", "nan");
    let text = format!("{BROAD_HEADER}\n{BROAD_ROW}\n{bad}\n");
    assert_eq!(
        imu_err(&text),
        "broad.csv:3: column 'acc_z': NaN where a finite value is required"
    );
}

#[test]
fn broad_duplicate_time_is_named() {
    let text = format!("{BROAD_HEADER}\n{BROAD_ROW}\n{BROAD_ROW}\n");
    assert_eq!(
        imu_err(&text),
        "broad.csv:3: duplicate time 0 s (the row before has it too)"
    );
}

#[test]
fn broad_missing_column_is_a_header_error() {
    let header = BROAD_HEADER.replace("gyr_y", "gyro_y");
    let text = format!("{header}\n{BROAD_ROW}\n");
    assert_eq!(
        imu_err(&text),
        "broad.csv:1: missing column 'gyr_y' in header"
    );
}

#[test]
fn xio_gyro_beyond_sensor_bounds_is_rejected() {
    let text = "Time (s),Gyroscope X (deg/s),Gyroscope Y (deg/s),Gyroscope Z (deg/s),Accelerometer X (g),Accelerometer Y (g),Accelerometer Z (g),Magnetometer X (uT),Magnetometer Y (uT),Magnetometer Z (uT)\n0,0.01,-0.15,0.1,0.001,-0.02,0.997,15.3,0.43,-41.1\n0.01,9000,-0.15,0.1,0.001,-0.02,0.997,15.3,0.43,-41.1\n";
    let err = err_text(parse_imu_csv(text, "xio.csv", &ImuCsvFormat::xio()));
    assert!(
        err.starts_with("xio.csv:3: column 'Gyroscope X (deg/s)': 157.07"),
        "{err}"
    );
}

#[test]
fn lias_uwb_bad_time_and_short_row() {
    let ranges = vec!["4.0"; 24].join(",");
    let good = format!("2022-08-15 9:42:24.766,{ranges}");
    let text = format!("{good}\n{good}\n2022-08-15 25:00:00.000,{ranges}\n");
    let err = err_text(parse_uwb_csv(&text, "uwb.csv", &UwbCsvFormat::lias()));
    assert_eq!(
        err,
        "uwb.csv:3: column 'time': '2022-08-15 25:00:00.000' is not a time"
    );
    let text = format!("{good}\n2022-08-15 9:42:24.776,4.0,4.1\n");
    let err = err_text(parse_uwb_csv(&text, "uwb.csv", &UwbCsvFormat::lias()));
    assert_eq!(
        err,
        "uwb.csv:2: expected 25 fields, found 3 (truncated or malformed row)"
    );
    // Rows swapped: the one that goes back is named (equal times occur in the real logs).
    let text = format!("{good}\n{good}\n2022-08-15 9:42:24.700,{ranges}\n");
    let err = err_text(parse_uwb_csv(&text, "uwb.csv", &UwbCsvFormat::lias()));
    assert_eq!(
        err,
        "uwb.csv:3: column 'time': 2022-08-15 9:42:24.700 is before the row before (out of order)"
    );
}

#[test]
fn lias_uwb_negative_range_names_anchor_and_tag() {
    let mut fields = vec!["4.0"; 24];
    fields[7] = "-1.5"; // a2-t1
    let text = format!("2022-08-15 9:42:24.766,{}\n", fields.join(","));
    let err = err_text(parse_uwb_csv(&text, "uwb.csv", &UwbCsvFormat::lias()));
    assert_eq!(
        err,
        "uwb.csv:1: column 'a2-t1': range -1.5 m is outside 0..=1000 m"
    );
}

#[test]
fn lias_mocap_non_unit_quaternion_and_nan_position() {
    let header = "time,x,y,z,rotation,,,";
    let good = "2022-08-15 9:42:22.968,0.206,1.962,0.964,0.0035,0.99984,0.01716,-0.00289";
    let text =
        format!("{header}\n{good}\n2022-08-15 9:42:22.977,0.206,1.962,0.964,0.5,0.5,0.0,0.0\n");
    let err = err_text(parse_mocap_csv(&text, "mocap.csv"));
    assert_eq!(
        err,
        "mocap.csv:3: quaternion has norm 0.7071, expected a unit quaternion"
    );
    let text = format!(
        "{header}\n{good}\n2022-08-15 9:42:22.977,NaN,1.962,0.964,0.0035,0.99984,0.01716,-0.00289\n"
    );
    let err = err_text(parse_mocap_csv(&text, "mocap.csv"));
    assert_eq!(
        err,
        "mocap.csv:3: column 'x': NaN where a finite value is required"
    );
}

#[test]
fn kolakowski_nan_rssi_is_not_an_empty_read() {
    let text = ",ts,x,heading,y,rssi_1,rssi_2,rssi_3,rssi_4,rssi_5,rssi_6\n0,1.6e18,4.2,4.19,3.64,-52,,-57,-49,-60,-61\n1,1.6e18,4.2,4.19,3.64,-52,nan,-57,-49,-60,-61\n";
    let err = err_text(parse_rssi_csv(
        text,
        "calib.csv",
        &RssiCsvFormat::kolakowski(),
    ));
    assert_eq!(
        err,
        "calib.csv:3: column 'rssi_2': NaN where a finite value is required"
    );
    // A tag position beyond any room is named at its row, not fitted.
    let text = ",ts,x,heading,y,rssi_1,rssi_2,rssi_3,rssi_4,rssi_5,rssi_6\n0,1.6e18,4.2,4.19,3.64,-52,,-57,-49,-60,-61\n1,1.6e18,1e30,4.19,3.64,-52,-50,-57,-49,-60,-61\n";
    let err = err_text(parse_rssi_csv(
        text,
        "calib.csv",
        &RssiCsvFormat::kolakowski(),
    ));
    assert!(
        err.starts_with("calib.csv:3: column 'x': 1e30 m is beyond any room"),
        "{err}"
    );
}

#[test]
fn anchors_with_missing_coordinate() {
    let err = err_text(parse_anchors_csv(
        "id,x,y,z\n1,5.48,2.41,2.08\n2,0.79,,2.62\n",
        "anchors.csv",
    ));
    assert_eq!(err, "anchors.csv:3: column 'y': '' is not a number");
}
