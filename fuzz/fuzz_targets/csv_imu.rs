//! `nomen import imu`: an IMU CSV file whose column names carry their units.
#![no_main]

use libfuzzer_sys::fuzz_target;
use nomen_core::DeviceId;
use nomen_recording::csv::{CsvOptions, import_imu_auto};

fuzz_target!(|data: &[u8]| {
    let _ = import_imu_auto(
        data,
        "fuzz.csv",
        DeviceId::new("imu"),
        &CsvOptions::default(),
    );
});
