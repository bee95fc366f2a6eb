//! Location tags in the engine: people walking back and forth under one camera, some wearing a
//! UWB tag at the right wrist that reports noisy fixes at 10 Hz.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use nalgebra::{Point3, Vector3};
use nomen_core::skeleton::Joints;
use nomen_core::{
    Anchor, AnchorId, Camera, CameraId, ClockModel, DeviceId, DeviceKind, Identity, Joint,
    JointObservation, Message, Registry, RigidTransform, RtlsFix, SessionTime, SkeletonObservation,
    Subject, SubjectId, TagCorrection, TrackId, UwbRange, Wearable,
};
use nomen_engine::{EngineConfig, EngineError, run_batch};

const CAMERA: &str = "cam";

/// One walker: along x between 1 and 7 m at `speed`, at lateral position `y_m`.
#[derive(Clone)]
struct Walker {
    subject: Option<&'static str>,
    y_m: f64,
    speed_mps: f64,
    track: u64,
    /// `(time, new id)`: the camera re-labels the walker.
    relabel: Option<(f64, u64)>,
    /// Tags worn: `(device suffix, site)`.
    tags: Vec<(&'static str, Joint)>,
    /// No fixes in this time range, s.
    silent: Option<(f64, f64)>,
}

impl Walker {
    fn new(subject: Option<&'static str>, y_m: f64, speed_mps: f64, track: u64) -> Self {
        Walker {
            subject,
            y_m,
            speed_mps,
            track,
            relabel: None,
            tags: subject
                .map(|_| vec![("tag", Joint::RightWrist)])
                .unwrap_or_default(),
            silent: None,
        }
    }

    fn pelvis(&self, t: f64) -> Point3<f64> {
        // A triangle wave between 1 and 7 m.
        let s = (self.speed_mps * t) % 12.0;
        let x = if s < 6.0 { 1.0 + s } else { 13.0 - s };
        Point3::new(x, self.y_m, 0.95)
    }

    fn joint(&self, t: f64, j: Joint) -> Point3<f64> {
        let p = self.pelvis(t);
        let swing = 0.2 * (2.0 * std::f64::consts::PI * 0.9 * t + self.y_m).sin();
        let offset = match j {
            Joint::Chest => Vector3::new(0.0, 0.0, 0.45),
            Joint::RightShoulder => Vector3::new(0.0, -0.2, 0.5),
            Joint::RightElbow => Vector3::new(0.5 * swing, -0.22, 0.2),
            Joint::RightWrist => Vector3::new(swing, -0.24, -0.05),
            Joint::LeftShoulder => Vector3::new(0.0, 0.2, 0.5),
            Joint::LeftElbow => Vector3::new(-0.5 * swing, 0.22, 0.2),
            Joint::LeftWrist => Vector3::new(-swing, 0.24, -0.05),
            _ => Vector3::zeros(),
        };
        p + offset
    }

    fn track_at(&self, t: f64) -> TrackId {
        match self.relabel {
            Some((at, id)) if t >= at => TrackId(id),
            _ => TrackId(self.track),
        }
    }
}

fn registry(walkers: &[Walker]) -> Registry {
    Registry {
        subjects: walkers
            .iter()
            .filter_map(|w| w.subject.map(|s| (s, w)))
            .map(|(s, w)| Subject {
                id: SubjectId::new(s),
                name: None,
                wears: w
                    .tags
                    .iter()
                    .map(|(suffix, site)| Wearable {
                        device: DeviceId::new(format!("{s}_{suffix}")),
                        kind: DeviceKind::UwbTag,
                        site: *site,
                        either_side: false,
                        clock: ClockModel::default(),
                    })
                    .collect(),
            })
            .collect(),
        cameras: vec![Camera {
            id: CameraId::new(CAMERA),
            world_from_camera: RigidTransform::default(),
            scale: 1.0,
            intrinsics: None,
            fps_hz: Some(30.0),
            clock: ClockModel::default(),
        }],
        ..Default::default()
    }
}

fn ns(t: f64) -> SessionTime {
    SessionTime::from_secs_f64(t).unwrap()
}

/// Deterministic noise in about ±`amp` (a fixed quasi-random sequence, no RNG needed).
fn noise(k: usize, axis: usize, amp: f64) -> f64 {
    let x = ((k * 7919 + axis * 104_729) as f64 * 0.618_033_988_75).fract();
    amp * (2.0 * x - 1.0)
}

fn recording(walkers: &[Walker], duration_s: f64) -> Vec<Message> {
    let mut msgs = Vec::new();
    let joints = [
        Joint::Pelvis,
        Joint::Chest,
        Joint::RightShoulder,
        Joint::RightElbow,
        Joint::RightWrist,
        Joint::LeftShoulder,
        Joint::LeftElbow,
        Joint::LeftWrist,
    ];
    for k in 0..(duration_s * 30.0) as usize {
        let t = k as f64 / 30.0;
        for w in walkers {
            let mut obs = Joints::new();
            for j in joints {
                obs.insert(j, JointObservation::tracked(w.joint(t, j)));
            }
            msgs.push(Message::Skeleton(Box::new(SkeletonObservation {
                t: ns(t),
                camera: CameraId::new(CAMERA),
                track: w.track_at(t),
                joints: obs,
            })));
        }
    }
    for (i, w) in walkers.iter().enumerate() {
        let Some(s) = w.subject else { continue };
        for (suffix, site) in &w.tags {
            for k in 0..(duration_s * 10.0) as usize {
                let t = k as f64 / 10.0 + 0.013 * (i + 1) as f64;
                if w.silent.is_some_and(|(a, b)| (a..b).contains(&t)) {
                    continue;
                }
                let truth = w.joint(t, *site);
                let p = truth + Vector3::new(noise(k, 0, 0.4), noise(k, 1, 0.4), noise(k, 2, 0.5));
                msgs.push(Message::RtlsFix(RtlsFix {
                    t: ns(t),
                    tag: DeviceId::new(format!("{s}_{suffix}")),
                    position_m: p,
                    quality: None,
                    covariance_m2: None,
                }));
            }
        }
    }
    msgs.sort_by_key(|m| m.t());
    msgs
}

/// Fraction of the walkers' identified frames after `from_s` that carry their subject (or
/// `Anonymous` for walkers without one).
fn accuracy(walkers: &[Walker], out: &[Message], from_s: f64) -> f64 {
    let (mut n, mut right) = (0, 0);
    for m in out {
        let Message::Identified(id) = m else { continue };
        let t = id.t.as_secs_f64();
        let Some(w) = walkers.iter().find(|w| w.track_at(t) == id.track) else {
            continue;
        };
        if t < from_s {
            continue;
        }
        n += 1;
        if id.identity.subject().map(|s| s.as_str()) == w.subject {
            right += 1;
        }
    }
    assert!(n > 0, "no frames after {from_s} s");
    right as f64 / n as f64
}

/// The walker of [`three_walkers`] who wears the corrected tag: ana's tag, else ben's.
fn wearer<'a>(walkers: &'a [Walker], c: &TagCorrection) -> &'a Walker {
    if c.tag.as_str() == "ana_tag" {
        &walkers[0]
    } else {
        &walkers[1]
    }
}

fn three_walkers() -> Vec<Walker> {
    vec![
        Walker::new(Some("ana"), 1.0, 1.2, 1),
        Walker::new(Some("ben"), 2.2, 0.9, 2),
        Walker::new(None, 3.4, 1.1, 3),
    ]
}

#[test]
fn tagged_walkers_are_named_the_untagged_one_stays_anonymous_and_fixes_are_corrected() {
    let walkers = three_walkers();
    let msgs = recording(&walkers, 20.0);
    let (out, stats) = run_batch(&registry(&walkers), &msgs, &EngineConfig::default()).unwrap();
    assert!(accuracy(&walkers, &out, 1.0) > 0.99, "{stats:?}");
    assert!(accuracy(&walkers[2..], &out, 0.0) == 1.0);
    // Every fix comes back once, and the corrected ones are far closer to the wrist.
    let corrections: Vec<_> = out
        .iter()
        .filter_map(|m| match m {
            Message::TagCorrection(c) => Some(c),
            _ => None,
        })
        .collect();
    let num_fixes = msgs
        .iter()
        .filter(|m| matches!(m, Message::RtlsFix(_)))
        .count();
    assert_eq!(corrections.len(), num_fixes);
    let (mut raw, mut corrected) = (0.0, 0.0);
    for c in &corrections {
        let truth = wearer(&walkers, c).joint(c.t.as_secs_f64(), Joint::RightWrist);
        raw += (c.raw_position_m - truth).norm_squared();
        corrected += (c.corrected_position_m - truth).norm_squared();
    }
    assert!(corrected < 0.1 * raw, "raw {raw}, corrected {corrected}");
}

#[test]
fn a_fix_jumping_30_m_changes_nothing() {
    let walkers = three_walkers();
    let mut msgs = recording(&walkers, 20.0);
    let mut jumped = 0;
    for m in &mut msgs {
        if let Message::RtlsFix(f) = m
            && f.tag.as_str() == "ana_tag"
            && (10.0..10.5).contains(&f.t.as_secs_f64())
        {
            f.position_m.x += 30.0;
            jumped += 1;
        }
    }
    assert!(jumped >= 4);
    let (out, _) = run_batch(&registry(&walkers), &msgs, &EngineConfig::default()).unwrap();
    assert!(accuracy(&walkers, &out, 1.0) > 0.99);
}

#[test]
fn a_tag_silent_for_10_s_neither_blocks_nor_names_anyone_else() {
    let mut walkers = three_walkers();
    walkers[0].silent = Some((5.0, 15.0));
    let msgs = recording(&walkers, 20.0);
    let num_skeletons = msgs
        .iter()
        .filter(|m| matches!(m, Message::Skeleton(_)))
        .count();
    let (out, _) = run_batch(&registry(&walkers), &msgs, &EngineConfig::default()).unwrap();
    let ids: Vec<_> = out
        .iter()
        .filter_map(|m| match m {
            Message::Identified(id) => Some(id),
            _ => None,
        })
        .collect();
    assert_eq!(ids.len(), num_skeletons);
    // Nobody but Ana's track is ever called Ana.
    assert!(
        ids.iter()
            .filter(|id| id.identity == Identity::Subject(SubjectId::new("ana")))
            .all(|id| id.track == TrackId(1))
    );
    // Ben and the untagged walker are unaffected.
    assert!(accuracy(&walkers[1..], &out, 1.0) > 0.99);
}

#[test]
fn two_tags_on_one_person_both_count() {
    let mut walkers = three_walkers();
    walkers[0].tags = vec![("right", Joint::RightWrist), ("left", Joint::LeftWrist)];
    let msgs = recording(&walkers, 20.0);
    let (out, _) = run_batch(&registry(&walkers), &msgs, &EngineConfig::default()).unwrap();
    assert!(accuracy(&walkers, &out, 1.0) > 0.99);
    let corrected_left = out.iter().any(|m| {
        matches!(m, Message::TagCorrection(c) if c.tag.as_str() == "ana_left"
            && (c.corrected_position_m - c.raw_position_m).norm() > 0.0)
    });
    assert!(corrected_left);
}

#[test]
fn an_unknown_tag_is_rejected_by_name_and_the_rest_goes_on() {
    let walkers = three_walkers();
    let mut msgs = recording(&walkers, 12.0);
    let stranger = Message::RtlsFix(RtlsFix {
        t: ns(3.0),
        tag: DeviceId::new("stranger"),
        position_m: Point3::new(2.0, 1.0, 1.0),
        quality: None,
        covariance_m2: None,
    });
    msgs.push(stranger.clone());
    msgs.sort_by_key(|m| m.t());
    let mut engine =
        nomen_engine::Engine::new(registry(&walkers), EngineConfig::default()).unwrap();
    let err = engine.push(&stranger).unwrap_err();
    assert!(matches!(err, EngineError::UnknownDevice { .. }), "{err}");
    assert!(err.to_string().contains("stranger"), "{err}");
    let (out, stats) = run_batch(&registry(&walkers), &msgs, &EngineConfig::default()).unwrap();
    assert_eq!(stats.rejected.num_unknown_device, 1);
    assert!(accuracy(&walkers, &out, 1.0) > 0.99);
}

#[test]
fn a_walker_relabelled_by_the_camera_is_named_again_within_a_second() {
    let mut walkers = three_walkers();
    walkers[0].relabel = Some((9.0, 11));
    let msgs = recording(&walkers, 20.0);
    // Whatever share of the ended track's tag evidence the new track inherits, none at all
    // included: its own fixes name it.
    for weight in [0.0, 0.5, 1.0] {
        let config = EngineConfig {
            stitch_tag_evidence_weight: weight,
            ..EngineConfig::default()
        };
        let (out, _) = run_batch(&registry(&walkers), &msgs, &config).unwrap();
        assert_named_again_within_a_second(&walkers, &out);
    }
}

fn assert_named_again_within_a_second(walkers: &[Walker], out: &[Message]) {
    let after: Vec<_> = out
        .iter()
        .filter_map(|m| match m {
            Message::Identified(id) if id.track == TrackId(11) => Some(id),
            _ => None,
        })
        .collect();
    assert!(!after.is_empty());
    let named_from = after
        .iter()
        .filter(|id| id.identity == Identity::Subject(SubjectId::new("ana")))
        .map(|id| id.t.as_secs_f64())
        .fold(f64::INFINITY, f64::min);
    assert!(named_from <= 10.0, "named from {named_from} s");
    assert!(accuracy(walkers, out, 10.0) > 0.99);
}

#[test]
fn rssi_reads_are_checked_and_taken_without_a_calibrated_model() {
    let walkers = three_walkers();
    let mut registry = registry(&walkers);
    registry.antennas.push(nomen_core::Antenna {
        id: nomen_core::AntennaId::new("door"),
        position_m: Point3::new(0.0, 0.0, 2.0),
        boresight: None,
    });
    registry.subjects[0].wears.push(Wearable {
        device: DeviceId::new("ana_rfid"),
        kind: DeviceKind::RfidTag,
        site: Joint::Chest,
        either_side: false,
        clock: ClockModel::default(),
    });
    let mut engine = nomen_engine::Engine::new(registry, EngineConfig::default()).unwrap();
    let read = |antenna: &str, tag: &str, rssi_dbm: f64| {
        Message::Rssi(nomen_core::RssiRead {
            t: ns(1.0),
            tag: DeviceId::new(tag),
            antenna: nomen_core::AntennaId::new(antenna),
            rssi_dbm,
            phase_rad: None,
        })
    };
    let err = engine.push(&read("window", "ana_rfid", -60.0)).unwrap_err();
    assert!(matches!(err, EngineError::UnknownAntenna { .. }), "{err}");
    assert!(err.to_string().contains("window"), "{err}");
    let err = engine.push(&read("door", "ana_tag", -60.0)).unwrap_err();
    assert!(matches!(err, EngineError::WrongDeviceKind { .. }), "{err}");
    let err = engine.push(&read("door", "ana_rfid", -6000.0)).unwrap_err();
    assert!(matches!(err, EngineError::InvalidMessage { .. }), "{err}");
    engine.push(&read("door", "ana_rfid", -60.0)).unwrap();
    // The session's first message is taken when the next one comes.
    let mut later = read("door", "ana_rfid", -61.0);
    if let Message::Rssi(r) = &mut later {
        r.t = ns(1.1);
    }
    engine.push(&later).unwrap();
    assert_eq!(engine.stats().num_rssi_reads, 2);
    // The unknown antenna and the tag of the wrong kind.
    assert_eq!(engine.stats().rejected.num_unknown_device, 2);
}

#[test]
fn two_tagged_walkers_who_pass_a_fifth_of_a_metre_apart_keep_their_names() {
    // Ana and Ben walk lines 0.2 m apart, Ben a little slower: Ana catches up with him and the
    // two walk side by side for seconds, their fixes fitting both alike, before she leaves him
    // behind. Each track keeps the name it carried with a clear lead, however thin the lead
    // becomes.
    let mut walkers = three_walkers();
    walkers[1].y_m = 1.2;
    walkers[1].speed_mps = 1.1;
    let msgs = recording(&walkers, 30.0);
    let (out, stats) = run_batch(&registry(&walkers), &msgs, &EngineConfig::default()).unwrap();
    let acc = accuracy(&walkers, &out, 1.0);
    assert!(acc > 0.98, "accuracy {acc}, stats {stats:?}");
}

#[test]
fn a_tag_name_is_sent_only_once_it_has_led_clearly() {
    // Where no lead is clear enough (a minimum probability of 1), no track ever confirms a tag
    // name, and the tagged walkers the default names stay anonymous: a name the tags alone give
    // is sent only after it has led with the probability the configuration asks for.
    let walkers = three_walkers();
    let msgs = recording(&walkers, 20.0);
    let (out, _) = run_batch(&registry(&walkers), &msgs, &EngineConfig::default()).unwrap();
    assert!(accuracy(&walkers[..2], &out, 1.0) > 0.99);
    let strict = EngineConfig {
        tag_min_name_probability: 1.0,
        ..EngineConfig::default()
    };
    let (out, _) = run_batch(&registry(&walkers), &msgs, &strict).unwrap();
    let named = out
        .iter()
        .filter(|m| matches!(m, Message::Identified(id) if id.identity.subject().is_some()))
        .count();
    assert_eq!(named, 0);
}

/// Outputs as comparable values: identified frames (time, track, identity, confidence) and
/// tag corrections (time, tag, corrected position), each sorted.
#[allow(clippy::type_complexity)]
fn outcome(out: &[Message]) -> (Vec<(i64, u64, Identity, f64)>, Vec<(i64, String, [f64; 3])>) {
    let mut named = Vec::new();
    let mut corrected = Vec::new();
    for m in out {
        match m {
            Message::Identified(id) => {
                named.push((id.t.as_ns(), id.track.0, id.identity.clone(), id.confidence));
            }
            Message::TagCorrection(c) => corrected.push((
                c.t.as_ns(),
                c.tag.to_string(),
                c.corrected_position_m.coords.into(),
            )),
            _ => {}
        }
    }
    named.sort_by_key(|a| (a.0, a.1));
    corrected.sort_by(|a, b| (a.0, &a.1).cmp(&(b.0, &b.1)));
    (named, corrected)
}

#[test]
fn a_tag_on_its_own_clock_gives_the_same_names_once_its_offset_is_registered() {
    let walkers = three_walkers();
    let msgs = recording(&walkers, 20.0);
    let (plain, _) = run_batch(&registry(&walkers), &msgs, &EngineConfig::default()).unwrap();
    // Ana's tag stamps 0.7 s behind the session (device = session − 0.7 s), as a logger on its
    // own clock would: the registry says so (session = device + offset).
    let offset_ns = 700_000_000;
    let mut shifted: Vec<Message> = msgs
        .iter()
        .map(|m| match m {
            Message::RtlsFix(f) if f.tag.as_str() == "ana_tag" => {
                let mut f = f.clone();
                f.t = SessionTime::from_ns(f.t.as_ns() - offset_ns);
                Message::RtlsFix(f)
            }
            m => m.clone(),
        })
        .collect();
    shifted.sort_by_key(|m| m.t());
    let mut reg = registry(&walkers);
    reg.subjects[0].wears[0].clock.offset_ns = offset_ns;
    let (out, _) = run_batch(&reg, &shifted, &EngineConfig::default()).unwrap();
    // Every output is the unshifted scene's, at session times.
    assert_eq!(outcome(&out), outcome(&plain));
    // Without the offset, Ana's fixes lag her wrist by 0.7 s (0.84 m at her 1.2 m/s) and her
    // corrections are stamped at device times.
    let (ignored, _) = run_batch(&registry(&walkers), &shifted, &EngineConfig::default()).unwrap();
    assert_ne!(outcome(&ignored).1, outcome(&plain).1);
}

#[test]
fn a_camera_in_centimetres_names_the_tag_wearers_once_its_scale_is_registered() {
    let walkers = three_walkers();
    let msgs = recording(&walkers, 20.0);
    let (plain, _) = run_batch(&registry(&walkers), &msgs, &EngineConfig::default()).unwrap();
    // A tracker that reports centimetres: 0.01 m per unit.
    let scale = 0.01;
    let in_cm: Vec<Message> = msgs
        .iter()
        .map(|m| match m {
            Message::Skeleton(s) => {
                let mut s = s.clone();
                s.joints = s.joints.map(|_, j| JointObservation {
                    position_m: Point3::from(j.position_m.coords / scale),
                    ..*j
                });
                Message::Skeleton(s)
            }
            m => m.clone(),
        })
        .collect();
    let mut reg = registry(&walkers);
    reg.cameras[0].scale = scale;
    let (out, _) = run_batch(&reg, &in_cm, &EngineConfig::default()).unwrap();
    let (named, corrected) = outcome(&out);
    let (named_plain, corrected_plain) = outcome(&plain);
    // The same names; confidences and corrected fixes equal up to the rounding of p / 0.01 · 0.01.
    assert_eq!(named.len(), named_plain.len());
    for (a, b) in named.iter().zip(&named_plain) {
        assert_eq!((a.0, a.1, &a.2), (b.0, b.1, &b.2));
        assert!((a.3 - b.3).abs() < 1e-9, "{a:?} {b:?}");
    }
    assert_eq!(corrected.len(), corrected_plain.len());
    for (a, b) in corrected.iter().zip(&corrected_plain) {
        assert!(
            (0..3).all(|i| (a.2[i] - b.2[i]).abs() < 1e-9),
            "{a:?} {b:?}"
        );
    }
    // Read as metres, the skeletons are 100 times too far: no tag is near any of them.
    let (unscaled, _) = run_batch(&registry(&walkers), &in_cm, &EngineConfig::default()).unwrap();
    assert!(accuracy(&walkers[..2], &unscaled, 1.0) < 0.05);
}

#[test]
fn with_location_tags_only_the_first_names_come_from_the_first_decisions() {
    // No IMU clock to find and no window to fill: no warm-up holds the session's first frames.
    // Each tagged walker's first correctly named frame carries a decision made within the
    // decision delay and two hops of the walker's first frame (`decided_at`), not after a
    // warm-up of seconds.
    let walkers = three_walkers();
    let msgs = recording(&walkers, 10.0);
    let config = EngineConfig::default();
    let (out, _) = run_batch(&registry(&walkers), &msgs, &config).unwrap();
    let first_t = |track: TrackId| {
        msgs.iter()
            .filter_map(|m| match m {
                Message::Skeleton(s) if s.track == track => Some(s.t.as_secs_f64()),
                _ => None,
            })
            .fold(f64::INFINITY, f64::min)
    };
    let bound_s = config.decision_delay_s + 2.0 * config.hop_s;
    for w in walkers.iter().filter(|w| w.subject.is_some()) {
        let track = TrackId(w.track);
        let named_at = out
            .iter()
            .filter_map(|m| match m {
                Message::Identified(id)
                    if id.track == track
                        && id.identity.subject().map(|s| s.as_str()) == w.subject =>
                {
                    id.decision
                        .as_ref()
                        .map(|d| d.decided_at.as_secs_f64().max(id.t.as_secs_f64()))
                }
                _ => None,
            })
            .fold(f64::INFINITY, f64::min);
        let waited_s = named_at - first_t(track);
        assert!(
            waited_s <= bound_s,
            "{:?} named {waited_s:.2} s after its first frame (bound {bound_s:.2} s)",
            w.subject
        );
    }
    // The untagged walker stays anonymous throughout.
    assert!(accuracy(&walkers[2..], &out, 0.0) == 1.0);
}

/// Ceiling anchors of the walkers' room.
fn anchors() -> Vec<Anchor> {
    [
        [0.0, 0.0, 2.6],
        [8.0, 0.0, 2.5],
        [8.0, 5.0, 2.7],
        [0.0, 5.0, 2.4],
        [4.0, 2.5, 2.9],
    ]
    .iter()
    .enumerate()
    .map(|(i, p)| Anchor {
        id: AnchorId::new(format!("a{i}")),
        position_m: Point3::new(p[0], p[1], p[2]),
    })
    .collect()
}

/// The recording with every tag fix replaced by one ranging cycle from that (noisy) position to
/// each anchor, 4 ms apart, each range 0.15 m long plus a few centimetres of noise (raw ranges
/// are biased long).
fn as_ranges(msgs: &[Message], anchors: &[Anchor]) -> Vec<Message> {
    let mut out = Vec::new();
    for (k, m) in msgs.iter().enumerate() {
        match m {
            Message::RtlsFix(f) => {
                for (i, a) in anchors.iter().enumerate() {
                    out.push(Message::UwbRange(UwbRange {
                        t: SessionTime::from_ns(f.t.as_ns() + 4_000_000 * i as i64),
                        tag: f.tag.clone(),
                        anchor: a.id.clone(),
                        range_m: (f.position_m - a.position_m).norm() + 0.15 + noise(k, i, 0.05),
                    }));
                }
            }
            other => out.push(other.clone()),
        }
    }
    out.sort_by_key(|m| m.t());
    out
}

#[test]
fn raw_uwb_ranges_alone_name_the_tag_wearers_as_their_fixes_do() {
    let walkers = three_walkers();
    let anchors = anchors();
    let registry = Registry {
        anchors: anchors.clone(),
        ..registry(&walkers)
    };
    let fixes = recording(&walkers, 20.0);
    let ranges = as_ranges(&fixes, &anchors);
    assert!(!ranges.iter().any(|m| matches!(m, Message::RtlsFix(_))));
    let config = EngineConfig::default();
    let (from_fixes, _) = run_batch(&registry, &fixes, &config).unwrap();
    let (from_ranges, stats) = run_batch(&registry, &ranges, &config).unwrap();
    // One fix per ranging cycle, all taken.
    let num_cycles = fixes
        .iter()
        .filter(|m| matches!(m, Message::RtlsFix(_)))
        .count() as u64;
    assert_eq!(stats.num_fixes_from_ranges, num_cycles, "{stats:?}");
    assert_eq!(stats.num_tag_fixes, num_cycles);
    let with_fixes = accuracy(&walkers, &from_fixes, 1.0);
    let with_ranges = accuracy(&walkers, &from_ranges, 1.0);
    assert!(
        with_ranges > 0.99,
        "ranges {with_ranges}, fixes {with_fixes}"
    );
    assert!(accuracy(&walkers[2..], &from_ranges, 0.0) == 1.0);
    // Both sent: the tag's own fixes are used and its ranges ignored.
    let mut both = fixes.clone();
    both.extend(
        ranges
            .iter()
            .filter(|m| matches!(m, Message::UwbRange(_)))
            .cloned(),
    );
    both.sort_by_key(|m| m.t());
    let (_, stats) = run_batch(&registry, &both, &config).unwrap();
    assert_eq!(stats.num_fixes_from_ranges, 0);
    assert_eq!(stats.num_tag_fixes, num_cycles);
}

#[test]
fn fixes_of_a_2d_location_system_at_z_0_name_their_wearers() {
    // A location system that solves x and y only reports z = 0: a metre below the wrist, which
    // in 3D would fit nobody.
    let walkers = three_walkers();
    let mut msgs = recording(&walkers, 20.0);
    for m in &mut msgs {
        if let Message::RtlsFix(f) = m {
            f.position_m.z = 0.0;
        }
    }
    let (out, stats) = run_batch(&registry(&walkers), &msgs, &EngineConfig::default()).unwrap();
    assert_eq!(stats.planar_tags.len(), 2, "{stats:?}");
    assert!(accuracy(&walkers, &out, 2.0) > 0.99);
    assert!(accuracy(&walkers[2..], &out, 0.0) == 1.0);
    // Corrections take the joint's height.
    let max_z_error = out
        .iter()
        .filter_map(|m| match m {
            Message::TagCorrection(c) if c.t.as_secs_f64() > 3.0 => Some(c),
            _ => None,
        })
        .map(|c| {
            let truth = wearer(&walkers, c).joint(c.t.as_secs_f64(), Joint::RightWrist);
            (c.corrected_position_m.z - truth.z).abs()
        })
        .fold(0.0, f64::max);
    assert!(max_z_error < 0.1, "{max_z_error}");
    // Fixes whose heights differ are 3D: the same recording with its heights is not planar.
    let (_, stats) = run_batch(
        &registry(&walkers),
        &recording(&walkers, 20.0),
        &EngineConfig::default(),
    )
    .unwrap();
    assert!(stats.planar_tags.is_empty());
}

#[test]
fn fixes_in_another_frame_are_reported_as_never_near_a_skeleton() {
    // The location system's frame is 10 m off the cameras' world frame: every fix lies far from
    // every skeleton, the run names nobody, and the stats say which tags were never near.
    let walkers = three_walkers();
    let mut msgs = recording(&walkers, 20.0);
    for m in &mut msgs {
        if let Message::RtlsFix(f) = m {
            f.position_m.x += 10.0;
        }
    }
    let (_, stats) = run_batch(&registry(&walkers), &msgs, &EngineConfig::default()).unwrap();
    let far: Vec<&str> = stats
        .tags_far_from_skeletons()
        .map(|(tag, _)| tag.as_str())
        .collect();
    assert_eq!(far, ["ana_tag", "ben_tag"], "{stats:?}");
    // In the cameras' frame, neither is.
    let (_, stats) = run_batch(
        &registry(&walkers),
        &recording(&walkers, 20.0),
        &EngineConfig::default(),
    )
    .unwrap();
    assert_eq!(stats.tags_far_from_skeletons().count(), 0, "{stats:?}");
    assert!(
        stats
            .tag_fixes_near
            .values()
            .all(|c| c.num_compared >= nomen_engine::FAR_TAG_MIN_COMPARED)
    );
}
