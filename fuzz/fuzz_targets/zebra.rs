//! Zebra RFID JSON: the file reader (`nomen import zebra`) and the MQTT payload decoder.
#![no_main]

use libfuzzer_sys::fuzz_target;
use nomen_adapters::{RfidConfig, decode_zebra, read_zebra};

fuzz_target!(|data: &[u8]| {
    let config = RfidConfig {
        reader: "reader-1".to_owned(),
        time_offset_ns: 0,
    };
    let _ = read_zebra(data, "fuzz.jsonl", &config);
    let _ = decode_zebra(data, &config);
});
