//! RSSI model files (`nomen run --rssi-model`, written by `calibrate rssi`).
#![no_main]

use libfuzzer_sys::fuzz_target;
use nomen_rssi::RssiModel;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let _ = RssiModel::from_json(text, "fuzz.json");
});
