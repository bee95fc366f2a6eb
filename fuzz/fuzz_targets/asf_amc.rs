//! ASF skeletons and AMC motions (CMU): the input is an ASF file, a line `%%AMC%%`, then an
//! AMC file; both are parsed and the motion converted.
#![no_main]

use libfuzzer_sys::fuzz_target;
use nomen_mocap::{ConvertOptions, convert, parse_amc, parse_asf, read_mocap_stream};

const SEPARATOR: &[u8] = b"\n%%AMC%%\n";

fuzz_target!(|data: &[u8]| {
    let (asf, amc) = match data.windows(SEPARATOR.len()).position(|w| w == SEPARATOR) {
        Some(at) => (&data[..at], &data[at + SEPARATOR.len()..]),
        None => (data, &b""[..]),
    };
    let Ok(asf_text) = read_mocap_stream(asf, "fuzz.asf") else {
        return;
    };
    let Ok(asf) = parse_asf(&asf_text, "fuzz.asf") else {
        return;
    };
    let Ok(amc_text) = read_mocap_stream(amc, "fuzz.amc") else {
        return;
    };
    let Ok(bvh) = parse_amc(&amc_text, &asf, "fuzz.amc") else {
        return;
    };
    let _ = convert(&bvh, &ConvertOptions::default());
});
