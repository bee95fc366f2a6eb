//! `nomen import skeletons`: both layouts, canonical joint names and every estimator's set
//! (the first byte chooses the set).
#![no_main]

use libfuzzer_sys::fuzz_target;
use nomen_core::skeleton::sets::JointSet;
use nomen_recording::csv::{CsvOptions, SkeletonCsvSpec, SkeletonLayout, import_skeletons};

fuzz_target!(|data: &[u8]| {
    let Some((&choice, text)) = data.split_first() else {
        return;
    };
    let joint_set = match choice % 5 {
        0 => None,
        1 => Some(JointSet::KinectV2),
        2 => Some(JointSet::AzureKinect),
        3 => Some(JointSet::Coco17),
        _ => Some(JointSet::Body25),
    };
    for layout in [SkeletonLayout::JointPerRow, SkeletonLayout::SkeletonPerRow] {
        let spec = SkeletonCsvSpec {
            layout,
            joint_set,
            ..SkeletonCsvSpec::default()
        };
        let _ = import_skeletons(text, "fuzz.csv", &spec, &CsvOptions::default());
    }
});
