//! MOTChallenge text (`nomen eval mot`).
#![no_main]

use libfuzzer_sys::fuzz_target;
use nomen_eval::mot::{MotChallengeConfig, parse_motchallenge};

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let _ = parse_motchallenge(text, "fuzz.txt", &MotChallengeConfig::default());
});
