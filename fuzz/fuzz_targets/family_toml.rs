//! Scene families (`nomen scenes --family`): parsed and checked.
#![no_main]

use libfuzzer_sys::fuzz_target;
use nomen_sim::family::FamilyDef;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let _ = FamilyDef::from_toml(text, "fuzz.toml");
});
