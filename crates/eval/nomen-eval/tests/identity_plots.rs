//! Plots of an identity evaluation are valid PNG files (with text, when a font is installed).
//!
//! Set `NOMEN_EVAL_KEEP_PLOTS=DIR` to also write them to `DIR` for a look.

// Helpers outside #[test] functions unwrap too: a failure there is a test failure.
#![allow(clippy::unwrap_used)]

use nalgebra::Point3;
use nomen_core::skeleton::Joints;
use nomen_core::{
    CameraId, IdentifiedSkeleton, Identity, Joint, Message, SessionTime, SubjectId, TagCorrection,
    TagId, TrackId, TruthSkeleton, TruthTag,
};
use nomen_eval::identity::{EvalConfig, EvalReport, SceneData, evaluate};
use nomen_eval::plots::{PlotConfig, write_plots};

const PNG_SIGNATURE: [u8; 8] = [0x89, b'P', b'N', b'G', 0x0D, 0x0A, 0x1A, 0x0A];

fn t(k: u32) -> SessionTime {
    SessionTime::from_secs_f64(f64::from(k) / 30.0).unwrap()
}

/// Two wearers swapped half-way, one intruder sometimes named, a wearer who leaves and comes
/// back, and two tags with raw errors larger than the corrected ones.
fn report() -> EvalReport {
    let (mut truth, mut result) = (Vec::new(), Vec::new());
    let mut push =
        |k: u32, track: u64, person: &str, subject: Option<&str>, label: Option<&str>| {
            let mut joints = Joints::new();
            joints.insert(Joint::Pelvis, Point3::new(track as f64, 0.0, 1.0));
            truth.push(Message::TruthSkeleton(Box::new(TruthSkeleton {
                t: t(k),
                camera: CameraId::new("cam"),
                track: TrackId(track),
                person: person.into(),
                subject: subject.map(SubjectId::new),
                joints_world_m: joints,
            })));
            result.push(Message::Identified(Box::new(IdentifiedSkeleton {
                t: t(k),
                camera: CameraId::new("cam"),
                track: TrackId(track),
                identity: label.map_or(Identity::Anonymous, |s| {
                    Identity::Subject(SubjectId::new(s))
                }),
                confidence: 1.0,
                evidence: vec![],
                decision: None,
                joints: Joints::new(),
            })));
        };
    for k in 0..300 {
        let swapped = k >= 200;
        push(
            k,
            1,
            "ana",
            Some("ana"),
            (k >= 12).then_some(if swapped { "bob" } else { "ana" }),
        );
        push(
            k,
            2,
            "bob",
            Some("bob"),
            Some(if swapped { "ana" } else { "bob" }),
        );
        push(k, 3, "eve", None, (100..130).contains(&k).then_some("cid"));
        if !(90..180).contains(&k) {
            push(
                k,
                4,
                "cid",
                Some("cid"),
                ((30..90).contains(&k) || k >= 200).then_some("cid"),
            );
        }
    }
    for k in 0..300 {
        for (i, tag) in ["band-ana", "band-bob"].into_iter().enumerate() {
            let p = Point3::new(0.01 * f64::from(k), i as f64, 1.0);
            let wobble = 0.05 * f64::from(k % 7);
            truth.push(Message::TruthTag(TruthTag {
                t: t(k),
                tag: TagId::new(tag),
                position_m: p,
            }));
            result.push(Message::TagCorrection(TagCorrection {
                t: t(k),
                tag: TagId::new(tag),
                raw_position_m: p + nalgebra::Vector3::new(0.2 + wobble, 0.1, 0.0),
                corrected_position_m: p + nalgebra::Vector3::new(0.05 + 0.2 * wobble, 0.0, 0.0),
            }));
        }
    }
    let scene = SceneData::from_messages("lab day 1", &truth, &result);
    evaluate(&[scene], &EvalConfig::default()).unwrap()
}

#[test]
fn plots_are_written_as_png_files() {
    let report = report();
    let dir = tempfile::tempdir().unwrap();
    let paths = write_plots(&report, dir.path(), &PlotConfig::default()).unwrap();
    let names: Vec<String> = paths
        .iter()
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    assert_eq!(
        names,
        [
            "identity_timeline_lab_day_1.png",
            "accuracy_over_time.png",
            "confidence_reliability.png",
            "tag_error_boxplot.png",
            "time_to_identify_boxplot.png",
        ]
    );
    for path in &paths {
        let bytes = std::fs::read(path).unwrap();
        assert!(bytes.len() > PNG_SIGNATURE.len(), "{}", path.display());
        assert_eq!(bytes[..8], PNG_SIGNATURE, "{}", path.display());
    }
    if let Ok(keep) = std::env::var("NOMEN_EVAL_KEEP_PLOTS") {
        write_plots(&report, std::path::Path::new(&keep), &PlotConfig::default()).unwrap();
    }
}

#[test]
fn curves_against_a_level_are_a_png_of_the_configured_size() {
    use nomen_eval::plots::{Curve, CurvePanel, render_curves};
    let curve = |name: &str, ys: &[f64]| Curve {
        name: name.into(),
        points: ys
            .iter()
            .enumerate()
            .map(|(i, y)| (10.0 * i as f64, *y))
            .collect(),
    };
    let panels = [
        CurvePanel {
            y_desc: "frames correct (%)".into(),
            curves: vec![
                curve("random", &[99.0, 98.0, 90.0]),
                curve("bursty", &[99.0, 97.0, 80.0]),
            ],
        },
        // A panel of zeros and one with a non-finite point still draw.
        CurvePanel {
            y_desc: "wrong name (%)".into(),
            curves: vec![
                curve("random", &[0.0, 0.0, 0.0]),
                curve("bursty", &[0.1, f64::NAN, 2.0]),
            ],
        },
    ];
    let config = PlotConfig::default();
    let plot = render_curves("imu_loss.png", "IMU loss", "loss (%)", &panels, &config).unwrap();
    assert_eq!(plot.file_name, "imu_loss.png");
    assert_eq!(plot.png[..8], PNG_SIGNATURE);
    // Width and height sit in the IHDR chunk, right after the signature and chunk header.
    let be = |b: &[u8]| u32::from_be_bytes([b[0], b[1], b[2], b[3]]);
    assert_eq!(be(&plot.png[16..20]), config.width_px);
    assert_eq!(be(&plot.png[20..24]), config.height_px);
    let empty = render_curves("none.png", "nothing", "level", &[], &config).unwrap();
    assert_eq!(empty.png[..8], PNG_SIGNATURE);
    if let Ok(keep) = std::env::var("NOMEN_EVAL_KEEP_PLOTS") {
        std::fs::write(std::path::Path::new(&keep).join(&plot.file_name), &plot.png).unwrap();
    }
}
