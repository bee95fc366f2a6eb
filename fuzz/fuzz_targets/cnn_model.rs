//! CNN model files (`nomen run --cnn`). First byte even: the input is the metadata JSON.
//! First byte odd: the input is the weights (safetensors), read with the shipped model's
//! metadata whose digest is made to match, so that the tensors are read and checked.
#![no_main]

use libfuzzer_sys::fuzz_target;
use nomen_cnn::CnnModel;
use nomen_cnn::model::sha256_hex;

const META: &str = include_str!("../../models/cnn_small.json");
const SHIPPED_DIGEST: &str = "213acb7cda1436e98cf136e23783588e5b4d8c1eba9e78598481e55fd6a1223f";

fuzz_target!(|data: &[u8]| {
    let Some((&choice, data)) = data.split_first() else {
        return;
    };
    if choice & 1 == 0 {
        let Ok(meta) = std::str::from_utf8(data) else {
            return;
        };
        let _ = CnnModel::from_bytes(&[], "fuzz.safetensors", meta, "fuzz.json");
    } else {
        let meta = META.replace(SHIPPED_DIGEST, &sha256_hex(data));
        let _ = CnnModel::from_bytes(data, "fuzz.safetensors", &meta, "cnn_small.json");
    }
});
