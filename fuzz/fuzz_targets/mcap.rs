//! MCAP recordings (`nomen-mcap`): an MCAP file read as the lines of a recording, under both
//! error policies, as `run`, `validate` and `replay` read it.
#![no_main]

use libfuzzer_sys::fuzz_target;
use nomen_mcap::McapLines;
use nomen_recording::{DEFAULT_MAX_LINE_BYTES, ErrorPolicy, ReadOptions, RecordingReader};

fuzz_target!(|data: &[u8]| {
    for policy in [ErrorPolicy::Stop, ErrorPolicy::SkipAndCount] {
        let lines = McapLines::new(data, DEFAULT_MAX_LINE_BYTES);
        let options = ReadOptions::with_policy(policy);
        let Ok(mut reader) = RecordingReader::with_options(lines, "fuzz.mcap", options) else {
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
