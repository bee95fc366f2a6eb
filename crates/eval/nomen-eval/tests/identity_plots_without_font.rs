//! Without a readable font the plots are still drawn, without text. (A test binary of its own:
//! the font is chosen once per process.)

// Helpers outside #[test] functions unwrap too: a failure there is a test failure.
#![allow(clippy::unwrap_used)]

use nomen_core::skeleton::Joints;
use nomen_core::{CameraId, IdentifiedSkeleton, Identity, Message, SessionTime, SubjectId};
use nomen_core::{TrackId, TruthSkeleton};
use nomen_eval::identity::{EvalConfig, SceneData, evaluate};
use nomen_eval::plots::{PlotConfig, render_plots};

#[test]
fn plots_without_a_font_are_still_png() {
    let (mut truth, mut result) = (Vec::new(), Vec::new());
    for k in 0..20 {
        let t = SessionTime(k * 33_333_333);
        truth.push(Message::TruthSkeleton(Box::new(TruthSkeleton {
            t,
            camera: CameraId::new("cam"),
            track: TrackId(1),
            person: "ana".into(),
            subject: Some(SubjectId::new("ana")),
            joints_world_m: Joints::new(),
        })));
        result.push(Message::Identified(Box::new(IdentifiedSkeleton {
            t,
            camera: CameraId::new("cam"),
            track: TrackId(1),
            identity: if k < 5 {
                Identity::Anonymous
            } else {
                Identity::Subject(SubjectId::new("ana"))
            },
            confidence: 1.0,
            evidence: vec![],
            decision: None,
            joints: Joints::new(),
        })));
    }
    let scene = SceneData::from_messages("s", &truth, &result);
    let report = evaluate(&[scene], &EvalConfig::default()).unwrap();
    let config = PlotConfig {
        font_paths: vec!["/nonexistent/font.ttf".into()],
        ..PlotConfig::default()
    };
    let plots = render_plots(&report, &config).unwrap();
    // Timeline, accuracy over time, confidence reliability, time to identify (no tags in this
    // scene).
    assert_eq!(plots.len(), 4);
    for plot in plots {
        assert!(
            plot.png.starts_with(&[0x89, b'P', b'N', b'G']),
            "{}",
            plot.file_name
        );
    }
}
