//! `nomen import fixes`: tag fixes as CSV, units from the column names or the spec.
#![no_main]

use libfuzzer_sys::fuzz_target;
use nomen_recording::csv::{CsvOptions, FixCsvSpec, LengthUnit, TimeUnit, import_fixes};

fuzz_target!(|data: &[u8]| {
    let _ = import_fixes(
        data,
        "fuzz.csv",
        &FixCsvSpec::default(),
        &CsvOptions::default(),
    );
    let spec = FixCsvSpec {
        time_unit: Some(TimeUnit::Milliseconds),
        length_unit: Some(LengthUnit::Millimetres),
        time_offset_ns: 0,
    };
    let _ = import_fixes(data, "fuzz.csv", &spec, &CsvOptions::default());
});
