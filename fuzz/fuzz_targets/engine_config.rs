//! Engine configuration TOML (`nomen run --config`, `serve`): parsed as the CLI parses it,
//! then checked as the engine checks it.
#![no_main]

use libfuzzer_sys::fuzz_target;
use nomen_engine::EngineConfig;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(config) = toml::from_str::<EngineConfig>(text) else {
        return;
    };
    if config.validate().is_ok() {
        let _ = config.latency_s();
        let _ = config.max_latency_s();
    }
});
