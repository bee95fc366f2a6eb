//! Point-pair files (`nomen calibrate frames --points`).
#![no_main]

use libfuzzer_sys::fuzz_target;
use nomen_calib::points::parse_point_pairs;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let _ = parse_point_pairs(text, "fuzz.csv");
});
