//! `nomen fit`'s sensor tables: IMU CSV (BROAD, x-io), UWB ranges and motion capture (LIAS),
//! RSSI and anchors (Kolakowski); the first byte chooses the reader.
#![no_main]

use libfuzzer_sys::fuzz_target;
use nomen_fit::load::{
    ImuCsvFormat, RssiCsvFormat, UwbCsvFormat, parse_anchors_csv, parse_imu_csv, parse_mocap_csv,
    parse_rssi_csv, parse_uwb_csv,
};

fuzz_target!(|data: &[u8]| {
    let Some((&choice, data)) = data.split_first() else {
        return;
    };
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    match choice % 7 {
        0 => drop(parse_imu_csv(text, "fuzz.csv", &ImuCsvFormat::broad())),
        1 => drop(parse_imu_csv(text, "fuzz.csv", &ImuCsvFormat::xio())),
        2 => drop(parse_uwb_csv(text, "fuzz.csv", &UwbCsvFormat::lias())),
        3 => drop(parse_mocap_csv(text, "fuzz.csv")),
        4 => drop(parse_rssi_csv(
            text,
            "fuzz.csv",
            &RssiCsvFormat::kolakowski(),
        )),
        5 => drop(parse_anchors_csv(text, "fuzz.csv")),
        _ => {
            let format = UwbCsvFormat {
                has_header: true,
                ..UwbCsvFormat::lias()
            };
            drop(parse_uwb_csv(text, "fuzz.csv", &format));
        }
    }
});
