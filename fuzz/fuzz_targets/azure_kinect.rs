//! Azure Kinect offline-processor JSON: the file reader (`nomen import azure-kinect`) and the
//! one-frame payload decoder (`serve`).
#![no_main]

use libfuzzer_sys::fuzz_target;
use nomen_adapters::{AzureKinectConfig, decode_azure_kinect_frame, read_azure_kinect};
use nomen_core::CameraId;

fuzz_target!(|data: &[u8]| {
    let config = AzureKinectConfig {
        camera: CameraId::new("kinect"),
        time_offset_ns: 1_000_000_000,
    };
    let _ = read_azure_kinect(data, "fuzz.json", &config);
    let _ = decode_azure_kinect_frame(data, &config);
});
