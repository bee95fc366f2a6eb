//! Recording lines (`nomen-recording`'s FORMAT.md): the header and every message, under both
//! error policies, as `run`, `validate` and `eval` read them.
#![no_main]

use libfuzzer_sys::fuzz_target;
use nomen_recording::{ErrorPolicy, ReadOptions, RecordingReader};

fuzz_target!(|data: &[u8]| {
    for policy in [ErrorPolicy::Stop, ErrorPolicy::SkipAndCount] {
        let options = ReadOptions::with_policy(policy).holding_all();
        let Ok(mut reader) = RecordingReader::with_options(data, "fuzz.jsonl", options) else {
            continue;
        };
        while let Some(next) = reader.next_message() {
            if next.is_err() && policy == ErrorPolicy::Stop {
                break;
            }
        }
        let _ = reader.into_stats();
    }
});
