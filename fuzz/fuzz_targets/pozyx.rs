//! Pozyx RTLS JSON: the file reader (`nomen import pozyx`) and the MQTT payload decoder; the first
//! byte chooses the configuration.
#![no_main]

use libfuzzer_sys::fuzz_target;
use nomen_adapters::{RtlsConfig, decode_pozyx, read_pozyx};

fuzz_target!(|data: &[u8]| {
    let Some((&choice, data)) = data.split_first() else {
        return;
    };
    let mut config = RtlsConfig::default();
    if choice & 1 == 1 {
        config.time_offset_ns = -1_600_000_000_000_000_000;
    }
    let _ = read_pozyx(data, "fuzz.jsonl", &config);
    let _ = decode_pozyx(data, &config);
});
