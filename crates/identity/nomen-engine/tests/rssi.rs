//! RSSI evidence on simulated crosswalks (Llorca's scenes; needs the motion capture in
//! `../shared/data`, skipped with a message without it): a tag unlike the calibrated one, a
//! person walking abreast of the tagged one, and a run without a calibrated model. Each holds
//! for every seed tried.
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod shared_data;

use nomen_core::{DeviceId, Message};
use nomen_engine::{EngineConfig, run_batch_with_rssi};
use nomen_rssi::{CalibrationConfig, ModelKind, RssiModel, calibrate};
use nomen_sim::SimOutput;
use shared_data::{accuracy, simulated};

const SEEDS: [u64; 3] = [1, 2, 3];

/// The directional model calibrated on the calibration sequence at `seed` (from its recording).
fn calibrated(seed: u64) -> Option<RssiModel> {
    let sim = simulated("scenarios/crosswalk_calibration.toml", seed)?;
    let config = CalibrationConfig {
        model: ModelKind::Directional,
        ..CalibrationConfig::default()
    };
    Some(
        calibrate(&sim.scene.registry, &sim.recording, &config, "calibration")
            .unwrap()
            .model,
    )
}

/// The engine's accuracy on `sim` with its default configuration and `model` (the fitted
/// default without one).
fn engine_accuracy(sim: &SimOutput, model: Option<&RssiModel>) -> f64 {
    let (out, _) = run_batch_with_rssi(
        &sim.scene.registry,
        &sim.recording,
        &EngineConfig::default(),
        model,
    )
    .unwrap();
    accuracy(sim, &out)
}

#[test]
fn a_tag_whose_gain_differs_from_the_calibrated_tags_is_still_named() {
    for seed in SEEDS {
        let Some(model) = calibrated(seed) else {
            return;
        };
        let mut sim = simulated("scenarios/crosswalk_1t1u_opposite.toml", seed).unwrap();
        // Another tag: 8 dB stronger at one antenna and 6 dB weaker at the other than the
        // calibrated one.
        let tag = DeviceId::new("epc_0001");
        for m in &mut sim.recording {
            if let Message::Rssi(r) = m
                && r.tag == tag
            {
                r.rssi_dbm += if r.antenna.to_string() == "ant0" {
                    8.0
                } else {
                    -6.0
                };
            }
        }
        let acc = engine_accuracy(&sim, Some(&model));
        assert!(acc > 0.9, "seed {seed}: accuracy {acc}");
    }
}

#[test]
fn the_person_walking_abreast_of_the_tagged_one_keeps_no_name() {
    for seed in SEEDS {
        let Some(model) = calibrated(seed) else {
            return;
        };
        let sim = simulated("scenarios/crosswalk_1t1u_abreast.toml", seed).unwrap();
        let acc = engine_accuracy(&sim, Some(&model));
        assert!(acc > 0.9, "seed {seed}: accuracy {acc}");
    }
}

#[test]
fn without_a_calibrated_model_the_fitted_default_names_a_lone_tagged_pedestrian() {
    for seed in SEEDS {
        let Some(sim) = simulated("scenarios/crosswalk_1t.toml", seed) else {
            return;
        };
        let acc = engine_accuracy(&sim, None);
        assert!(acc > 0.9, "seed {seed}: accuracy {acc}");
    }
}
