//! `nomen serve`'s payload decoder: the input's first line is the topic, the rest the payload
//! (nomen's own topics, the registry, and every vendor topic).
#![no_main]

use libfuzzer_sys::fuzz_target;
use nomen_live::decode::decode_all;

fuzz_target!(|data: &[u8]| {
    let (topic, payload) = match data.iter().position(|&b| b == b'\n') {
        Some(at) => (&data[..at], &data[at + 1..]),
        None => (&b"nomen/in/imu/imu-1"[..], data),
    };
    let Ok(topic) = std::str::from_utf8(topic) else {
        return;
    };
    let _ = decode_all(topic, payload);
});
