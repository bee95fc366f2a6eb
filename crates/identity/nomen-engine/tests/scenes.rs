//! Identification accuracy on simulated scenes (ignored: needs `nomen simulate` output).
//!
//! ```text
//! for s in imu_wrist_2 imu_wrist_4 imu_wrist_8 imu_ban_2 imu_ban_8; do
//!   cargo run --release -p nomen-cli -- simulate scenarios/$s.toml --out /tmp/sims/$s; done
//! NOMEN_SCENES=/tmp/sims cargo test --release -p nomen-engine --test scenes -- --ignored --nocapture
//! ```
//! Accuracy = fraction of truth skeleton frames whose output label is right (the subject for a
//! registered person, anonymous for an intruder).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use nomen_core::{Identity, Message, Registry, SubjectId, TrackId};
use nomen_engine::{EngineConfig, run_batch};
use std::collections::BTreeMap;

fn read_jsonl(path: &std::path::Path) -> (Registry, Vec<Message>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: serde_json::Value = serde_json::from_str(lines.next().unwrap()).unwrap();
    let registry: Registry = serde_json::from_value(header["registry"].clone()).unwrap();
    let msgs = lines.map(|l| serde_json::from_str(l).unwrap()).collect();
    (registry, msgs)
}

#[test]
#[ignore = "needs simulated scenes; see the module docs"]
fn accuracy_on_simulated_scenes() {
    let dir = std::env::var("NOMEN_SCENES").unwrap_or_else(|_| "/tmp/sims".into());
    let config: EngineConfig = match std::env::var("NOMEN_ENGINE_CONFIG") {
        Ok(s) => serde_json::from_str(&s).unwrap(),
        Err(_) => EngineConfig::default(),
    };
    for scene in [
        "imu_wrist_2",
        "imu_wrist_4",
        "imu_wrist_8",
        "imu_ban_2",
        "imu_ban_8",
    ] {
        let base = std::path::Path::new(&dir).join(scene);
        if !base.exists() {
            eprintln!("skipping {scene}: {} not found", base.display());
            continue;
        }
        let (registry, msgs) = read_jsonl(&base.join("recording.jsonl"));
        let (_, truth) = read_jsonl(&base.join("truth.jsonl"));
        let (out, stats) = run_batch(&registry, &msgs, &config).unwrap();
        let mut labels: BTreeMap<(i64, String, TrackId), Identity> = BTreeMap::new();
        for m in &out {
            if let Message::Identified(id) = m {
                labels.insert(
                    (id.t.as_ns(), id.camera.to_string(), id.track),
                    id.identity.clone(),
                );
            }
        }
        let (mut n, mut right, mut n_late, mut right_late) = (0usize, 0usize, 0usize, 0usize);
        let mut missing = 0usize;
        for m in &truth {
            let Message::TruthSkeleton(ts) = m else {
                continue;
            };
            let want = ts
                .subject
                .clone()
                .map_or(Identity::Anonymous, Identity::Subject);
            let Some(got) = labels.get(&(ts.t.as_ns(), ts.camera.to_string(), ts.track)) else {
                missing += 1;
                continue;
            };
            n += 1;
            right += usize::from(*got == want);
            if ts.t.as_secs_f64() >= 10.0 {
                n_late += 1;
                right_late += usize::from(*got == want);
            }
        }
        // Ground truth offsets, used only to check the estimates.
        let scene_json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(base.join("scene.json")).unwrap())
                .unwrap();
        let truth_offset: BTreeMap<String, f64> = scene_json["devices"]
            .as_array()
            .into_iter()
            .flatten()
            .filter_map(|d| {
                Some((
                    d["device"].as_str()?.to_string(),
                    d["clock_offset_s"].as_f64()?,
                ))
            })
            .collect();
        let mut num_within = 0usize;
        let offsets: Vec<String> = stats
            .clock_offsets
            .iter()
            .map(|(d, e)| {
                let est = e.offset_ns as f64 * 1e-9;
                let err = truth_offset.get(d.as_str()).map_or(f64::NAN, |t| est - t);
                num_within += usize::from(err.abs() <= 0.05);
                format!("{d}:{est:+.3}({err:+.3})")
            })
            .collect();
        let _ = SubjectId::new("");
        eprintln!(
            "{scene}: accuracy {:.3} ({right}/{n}), after 10 s {:.3}, missing {missing}, switches {}, windows {}, offsets within 50 ms {num_within}/{} estimated of {}",
            right as f64 / n.max(1) as f64,
            right_late as f64 / n_late.max(1) as f64,
            stats.num_label_switches,
            stats.num_windows,
            stats.clock_offsets.len(),
            truth_offset.len(),
        );
        eprintln!("  offsets est(est-true) [{}]", offsets.join(" "));
    }
}
