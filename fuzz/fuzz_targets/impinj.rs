//! Impinj RFID JSON: the file reader (`nomen import impinj`) and the MQTT payload decoder.
#![no_main]

use libfuzzer_sys::fuzz_target;
use nomen_adapters::{RfidConfig, decode_impinj, read_impinj};

fuzz_target!(|data: &[u8]| {
    let config = RfidConfig {
        reader: "reader-1".to_owned(),
        time_offset_ns: 0,
    };
    let _ = read_impinj(data, "fuzz.jsonl", &config);
    let _ = decode_impinj(data, &config);
});
