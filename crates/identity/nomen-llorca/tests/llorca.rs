//! Llorca's association and the calibration on small synthetic scenes (no shared data): two
//! people crossing in front of two antennas, one of them tagged; reads drawn from a known
//! standard model with Gaussian shadowing.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod common;

use common::{
    K_DB, P1_DBM, SIGMA_DB, SceneSpec, calibrated_model, crossing_scene, fraction, labels,
    position, registry, skeleton,
};
use nomen_core::{AntennaId, DeviceId, Identity, Message, RssiRead, SessionTime, SubjectId};
use nomen_llorca::{Llorca, LlorcaConfig, run_llorca, run_llorca_with};
use nomen_rssi::{CalibrationConfig, ModelKind, RssiError, RssiUnit, TagPlacement, calibrate};

#[test]
fn calibration_recovers_the_model_that_drew_the_reads() {
    let reg = registry(1);
    let model = calibrated_model(&reg);
    for a in &model.antennas {
        assert!(
            (a.p1_dbm - P1_DBM).abs() < 1.0,
            "{}: P1 {}",
            a.antenna,
            a.p1_dbm
        );
        assert!(
            (a.k_db_per_decade - K_DB).abs() < 1.5,
            "{}: K {}",
            a.antenna,
            a.k_db_per_decade
        );
        let s = a.noise.variance_db2(3.0, 0.0).sqrt();
        assert!((s / SIGMA_DB - 1.0).abs() < 0.15, "{}: σ {s}", a.antenna);
    }
}

#[test]
fn the_tagged_person_is_named_and_the_other_stays_anonymous() {
    let (reg, model, msgs) = crossing_scene(&SceneSpec::crossing(vec![0], vec![0, 1], 1));
    let out = run_llorca(&reg, &model, &msgs).unwrap();
    let s0 = Identity::Subject(SubjectId::new("s0"));
    let tagged = labels(&out, 10);
    let untagged = labels(&out, 11);
    assert_eq!(tagged.len(), 200);
    assert!(fraction(&tagged, &s0) > 0.9, "{}", fraction(&tagged, &s0));
    assert_eq!(fraction(&untagged, &s0), 0.0);
    // Exactly one output per skeleton, in time order.
    assert_eq!(out.len(), 400);
    assert!(out.windows(2).all(|w| w[0].t() <= w[1].t()));
}

#[test]
fn two_tags_on_two_people_are_told_apart() {
    let (reg, model, msgs) = crossing_scene(&SceneSpec::crossing(vec![1, 0], vec![0, 1], 2));
    let out = run_llorca(&reg, &model, &msgs).unwrap();
    let p0 = labels(&out, 10);
    let p1 = labels(&out, 11);
    assert!(fraction(&p0, &Identity::Subject(SubjectId::new("s1"))) > 0.8);
    assert!(fraction(&p1, &Identity::Subject(SubjectId::new("s0"))) > 0.8);
}

#[test]
fn a_tag_heard_on_only_one_antenna_is_still_associated() {
    let (reg, model, msgs) = crossing_scene(&SceneSpec::crossing(vec![0], vec![0], 3));
    let out = run_llorca(&reg, &model, &msgs).unwrap();
    let s0 = Identity::Subject(SubjectId::new("s0"));
    // ant1 is silent, which is evidence too (censored): whoever is labelled, it must mostly be
    // the wearer, and the other person must not carry the tag most of the time.
    let tagged = fraction(&labels(&out, 10), &s0);
    let untagged = fraction(&labels(&out, 11), &s0);
    assert!(tagged > untagged, "{tagged} vs {untagged}");
    assert!(untagged < 0.1, "{untagged}");
}

#[test]
fn a_tag_never_heard_again_releases_its_lock() {
    let (reg, model, msgs) = crossing_scene(&SceneSpec {
        reads_until_s: 3.0,
        ..SceneSpec::crossing(vec![0], vec![0, 1], 4)
    });
    let (out, stats) = run_llorca_with(&reg, &model, &LlorcaConfig::default(), &msgs).unwrap();
    let s0 = Identity::Subject(SubjectId::new("s0"));
    let tagged = labels(&out, 10);
    // Named while heard (frames 25..75 = 1–3 s) ...
    assert!(fraction(&tagged[25..75], &s0) > 0.9);
    // ... anonymous once the tag has been silent for longer than the timeout (2 s): t > 5.2 s.
    assert_eq!(fraction(&tagged[130..], &s0), 0.0);
    assert!(stats.num_locks >= 1 && stats.num_unlocks >= 1, "{stats:?}");
}

#[test]
fn bad_reads_are_rejected_with_their_source_and_the_stream_goes_on() {
    let reg = registry(1);
    let model = calibrated_model(&reg);
    let mut llorca = Llorca::new(reg.clone(), &model, LlorcaConfig::default()).unwrap();
    let mut out = Vec::new();
    let read = |t_s: f64, antenna: &str, v: f64| {
        Message::Rssi(RssiRead {
            t: SessionTime::from_secs_f64(t_s).unwrap(),
            tag: DeviceId::new("tag0"),
            antenna: AntennaId::new(antenna),
            rssi_dbm: v,
            phase_rad: None,
        })
    };
    // NaN.
    let e = llorca
        .push(&read(0.1, "ant0", f64::NAN), &mut out)
        .unwrap_err();
    assert!(matches!(e, RssiError::NonFiniteRssi { .. }), "{e}");
    // An antenna the registry does not know.
    let e = llorca
        .push(&read(0.2, "ant9", -60.0), &mut out)
        .unwrap_err();
    assert!(
        e.to_string().contains("ant9") && e.to_string().contains("registry"),
        "{e}"
    );
    // dBm×100 without the unit declared.
    let e = llorca
        .push(&read(0.3, "ant0", -6000.0), &mut out)
        .unwrap_err();
    assert!(e.to_string().contains("dBm×100"), "{e}");
    // A good read and a skeleton go through; then something older than a decided frame is out
    // of order.
    llorca.push(&read(0.4, "ant0", -60.0), &mut out).unwrap();
    llorca
        .push(&skeleton(0.5, 1, position(0, 0.5)), &mut out)
        .unwrap();
    llorca.push(&read(0.6, "ant1", -60.0), &mut out).unwrap();
    assert_eq!(out.len(), 1);
    let e = llorca
        .push(&read(0.45, "ant0", -60.0), &mut out)
        .unwrap_err();
    assert!(matches!(e, RssiError::OutOfOrder { .. }), "{e}");
    // Reads of a tag nobody wears are counted, not errors.
    let stray = Message::Rssi(RssiRead {
        t: SessionTime::from_secs_f64(0.7).unwrap(),
        tag: DeviceId::new("stranger"),
        antenna: AntennaId::new("ant0"),
        rssi_dbm: -70.0,
        phase_rad: None,
    });
    llorca.push(&stray, &mut out).unwrap();
    llorca.finish(&mut out);
    let s = llorca.stats();
    assert_eq!(s.num_rejected, 4);
    assert_eq!(s.num_reads, 2);
    assert_eq!(s.num_unknown_tag_reads, 1);
}

#[test]
fn centi_dbm_reads_associate_when_the_unit_is_declared() {
    let (reg, model, msgs) = crossing_scene(&SceneSpec {
        duration_s: 6.0,
        ..SceneSpec::crossing(vec![0], vec![0, 1], 5)
    });
    let centi: Vec<Message> = msgs
        .into_iter()
        .map(|m| match m {
            Message::Rssi(mut r) => {
                r.rssi_dbm *= 100.0;
                Message::Rssi(r)
            }
            other => other,
        })
        .collect();
    let s0 = Identity::Subject(SubjectId::new("s0"));
    // Undeclared: every read is rejected, nobody is named.
    let (out, stats) = run_llorca_with(&reg, &model, &LlorcaConfig::default(), &centi).unwrap();
    assert_eq!(stats.num_reads, 0);
    assert_eq!(fraction(&labels(&out, 10), &s0), 0.0);
    // Declared: converted, and the wearer is named.
    let config = LlorcaConfig {
        rssi_unit: RssiUnit::CentiDbm,
        ..LlorcaConfig::default()
    };
    let (out, _) = run_llorca_with(&reg, &model, &config, &centi).unwrap();
    assert!(fraction(&labels(&out, 10), &s0) > 0.85);
}

#[test]
fn a_model_missing_a_registry_antenna_is_refused() {
    let reg = registry(1);
    let mut model = calibrated_model(&reg);
    model.antennas.pop();
    let err = Llorca::new(reg.clone(), &model, LlorcaConfig::default())
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(err.contains("ant1"), "{err}");
    assert_eq!(model.kind, ModelKind::Standard);
}

#[test]
fn empty_input_gives_empty_output() {
    let reg = registry(1);
    let model = calibrated_model(&reg);
    assert!(run_llorca(&reg, &model, &[]).unwrap().is_empty());
    let err = calibrate(&reg, &[], &CalibrationConfig::default(), "empty.jsonl")
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(err.contains("empty.jsonl"), "{err}");
    // A fixed tag height below the floor, absurdly high or not a number is refused by name.
    for h in [-1.0, 1e9, f64::NAN] {
        let config = CalibrationConfig {
            placement: TagPlacement::FixedHeight(h),
            ..CalibrationConfig::default()
        };
        let err = calibrate(&reg, &[], &config, "empty.jsonl")
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(err.contains("tag height"), "{h}: {err}");
    }
}
