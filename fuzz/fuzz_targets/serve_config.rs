//! `nomen serve`'s settings TOML.
#![no_main]

use libfuzzer_sys::fuzz_target;
use nomen_live::ServeConfig;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let _ = ServeConfig::from_toml(text, "fuzz.toml");
});
