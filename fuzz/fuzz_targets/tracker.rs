//! Position-only trackers, CSV or JSON lines: the file reader (`nomen import tracker`) and the
//! payload decoder; the first byte chooses the configuration.
#![no_main]

use libfuzzer_sys::fuzz_target;
use nomen_adapters::{TrackerConfig, decode_tracker, read_tracker};
use nomen_core::{CameraId, Joint};
use nomen_recording::csv::TimeUnit;

fuzz_target!(|data: &[u8]| {
    let Some((&choice, data)) = data.split_first() else {
        return;
    };
    let config = TrackerConfig {
        camera: CameraId::new("tracker"),
        scale_m_per_unit: if choice & 1 == 0 { 1.0 } else { 0.001 },
        time_unit: [None, Some(TimeUnit::Seconds), Some(TimeUnit::Milliseconds)]
            [usize::from(choice >> 1) % 3],
        joint: if choice & 8 == 0 {
            Joint::Head
        } else {
            Joint::Pelvis
        },
        z_m: 1.6,
        time_offset_ns: 0,
    };
    let _ = read_tracker(data, "fuzz.csv", &config);
    let _ = decode_tracker(data, &config);
});
