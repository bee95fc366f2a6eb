//! Camera-to-RTLS calibration from a recording where one tagged person walks: the tag's key
//! joint seen by the camera (camera frame) against the tag's fixes (RTLS frame).
//!
//! Steps: collect the two streams (frames with more than one skeleton are skipped: whose joint
//! would it be?), search the clock offset ([`crate::clock`]), pair the streams at that offset,
//! fit `rtls_from_camera` with RANSAC and report the residuals with the poor-fit rule.

use crate::clock::{
    ClockOffsetFit, ClockSearchConfig, TimedPoint, estimate_clock_offset, pairs_at_offset,
};
use crate::error::{CalibError, Result};
use crate::fit::{FitKind, FitQualityConfig, ResidualReport, SimilarityTransform};
use crate::ransac::{RansacConfig, fit_ransac};
use nalgebra::Point3;
use nomen_core::{
    Calibration, CameraCalibration, CameraId, ClockModel, DeviceKind, Joint, Message, Registry,
    TagId,
};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Settings of [`calibrate_from_recording`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
pub struct FramesCalibrationConfig {
    /// Clock search (its `kind` is the transform family).
    pub clock: ClockSearchConfig,
    /// RANSAC at the best offset.
    pub ransac: RansacConfig,
    /// The poor-fit rule.
    pub quality: FitQualityConfig,
}

/// The two streams of one (camera, tag).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct KeyJointStreams {
    /// The camera.
    pub camera: Option<CameraId>,
    /// The tag.
    pub tag: Option<TagId>,
    /// The key joint.
    pub key_joint: Option<Joint>,
    /// Key joint positions in the camera frame.
    pub camera_points: Vec<TimedPoint>,
    /// Tag fixes in the RTLS frame.
    pub tag_points: Vec<TimedPoint>,
    /// Camera frames skipped because they held several skeletons.
    pub num_crowded_frames: usize,
}

/// The `what` (camera or tag) to calibrate: `chosen` if the recording has it, else the only one
/// `seen` in the recording; an error that names what the recording has otherwise.
fn pick(what: &'static str, chosen: Option<String>, seen: Vec<String>) -> Result<String> {
    let reason = match (chosen, seen.as_slice()) {
        (Some(c), _) if seen.contains(&c) => return Ok(c),
        (None, [one]) => return Ok(one.clone()),
        (_, []) => format!("the recording has no {what} data"),
        (Some(c), _) => format!(
            "no {what} '{c}' in the recording (it has: {})",
            seen.join(", ")
        ),
        (None, _) => format!(
            "the recording has several; choose one of: {}",
            seen.join(", ")
        ),
    };
    Err(CalibError::InvalidParameter { name: what, reason })
}

/// Collects the key-joint stream of `camera` and the fixes of `tag` (each `None`: the only one
/// in the recording, else an error naming the choices).
pub fn key_joint_streams(
    registry: &Registry,
    messages: &[Message],
    camera: Option<&CameraId>,
    tag: Option<&TagId>,
) -> Result<KeyJointStreams> {
    let mut cameras: Vec<String> = messages
        .iter()
        .filter_map(|m| match m {
            Message::Skeleton(s) => Some(s.camera.to_string()),
            _ => None,
        })
        .collect();
    cameras.sort();
    cameras.dedup();
    let mut tags: Vec<String> = messages
        .iter()
        .filter_map(|m| match m {
            Message::RtlsFix(f) => Some(f.tag.to_string()),
            _ => None,
        })
        .collect();
    tags.sort();
    tags.dedup();
    let camera = CameraId::new(pick("camera", camera.map(|c| c.to_string()), cameras)?);
    let tag = TagId::new(pick("tag", tag.map(|t| t.to_string()), tags)?);
    let key_joint = registry
        .wearer(&tag)
        .filter(|(_, w)| w.kind == DeviceKind::UwbTag)
        .map(|(_, w)| w.site)
        .ok_or_else(|| CalibError::InvalidParameter {
            name: "tag",
            reason: format!("no subject in the registry wears uwb tag '{tag}'"),
        })?;
    let mut frames: BTreeMap<i64, Vec<Point3<f64>>> = BTreeMap::new();
    let mut tag_points = Vec::new();
    for m in messages {
        match m {
            Message::Skeleton(s) if s.camera == camera => {
                let entry = frames.entry(s.t.as_ns()).or_default();
                // A missing joint still counts the skeleton (NaN), so the frame is crowded.
                entry.push(s.position(key_joint).unwrap_or(Point3::new(
                    f64::NAN,
                    f64::NAN,
                    f64::NAN,
                )));
            }
            Message::RtlsFix(f) if f.tag == tag => tag_points.push(TimedPoint {
                t: f.t,
                position_m: f.position_m,
            }),
            _ => {}
        }
    }
    let mut num_crowded_frames = 0;
    let camera_points = frames
        .into_iter()
        .filter_map(|(t, ps)| {
            if ps.len() > 1 {
                num_crowded_frames += 1;
                return None;
            }
            let p = ps.first()?;
            p.iter().all(|v| v.is_finite()).then_some(TimedPoint {
                t: nomen_core::SessionTime(t),
                position_m: *p,
            })
        })
        .collect();
    Ok(KeyJointStreams {
        camera: Some(camera),
        tag: Some(tag),
        key_joint: Some(key_joint),
        camera_points,
        tag_points,
        num_crowded_frames,
    })
}

/// A camera-to-RTLS calibration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FramesCalibration {
    /// `rtls_from_camera`.
    pub rtls_from_camera: SimilarityTransform,
    /// The clock search (offset = camera stamp − tag stamp of the same instant).
    pub clock: ClockOffsetFit,
    /// Residuals of the RANSAC fit at the best offset.
    pub report: ResidualReport,
}

/// Clock offset, then RANSAC fit, then residual report (see the module docs).
pub fn calibrate_streams(
    streams: &KeyJointStreams,
    config: &FramesCalibrationConfig,
) -> Result<FramesCalibration> {
    let clock = estimate_clock_offset(&streams.camera_points, &streams.tag_points, &config.clock)?;
    let mut src = streams.camera_points.clone();
    src.sort_by_key(|p| p.t);
    let pairs = pairs_at_offset(
        &src,
        &streams.tag_points,
        clock.offset_ns,
        config.clock.max_gap_s,
    );
    let (source, target): (Vec<_>, Vec<_>) = pairs.into_iter().unzip();
    let kind: FitKind = config.clock.kind;
    let fit = fit_ransac(&source, &target, kind, &config.ransac)?;
    let report = ResidualReport::new(
        &fit.transform,
        kind,
        &source,
        &target,
        &fit.inliers,
        &config.quality,
    );
    Ok(FramesCalibration {
        rtls_from_camera: fit.transform,
        clock,
        report,
    })
}

/// What `calibration` found about `camera`, as a [`Calibration`] for the registry: the
/// camera's pose and scale in the RTLS frame, which the engine takes for the world frame
/// (location fixes are world positions), and its clock offset onto the session clock through
/// `tag`'s (`session = camera stamp + offset`, so the camera offset is the tag's registry
/// offset minus the searched camera − tag offset; drift as the registry has it). Errors when
/// `camera` is not registered.
pub fn camera_calibration(
    registry: &Registry,
    camera: &CameraId,
    tag: &TagId,
    calibration: &FramesCalibration,
) -> Result<Calibration> {
    let Some(registered) = registry.camera(camera) else {
        return Err(CalibError::InvalidParameter {
            name: "camera",
            reason: format!("camera '{camera}' is not in the registry"),
        });
    };
    let tag_offset_ns = registry.wearer(tag).map_or(0, |(_, w)| w.clock.offset_ns);
    let t = &calibration.rtls_from_camera;
    Ok(Calibration {
        cameras: vec![CameraCalibration {
            id: camera.clone(),
            world_from_camera: Some(t.to_rigid_transform()),
            scale: Some(t.scale),
            clock: Some(ClockModel {
                offset_ns: tag_offset_ns.saturating_sub(calibration.clock.offset_ns),
                drift_ppm: registered.clock.drift_ppm,
            }),
        }],
        devices: Vec::new(),
    })
}

/// [`key_joint_streams`] then [`calibrate_streams`].
pub fn calibrate_from_recording(
    registry: &Registry,
    messages: &[Message],
    camera: Option<&CameraId>,
    tag: Option<&TagId>,
    config: &FramesCalibrationConfig,
) -> Result<FramesCalibration> {
    let streams = key_joint_streams(registry, messages, camera, tag)?;
    calibrate_streams(&streams, config)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
    use nomen_core::{Camera, RigidTransform, SessionTime, Subject, Wearable};

    /// A people counter in its own units (0.0153 m per unit), turned and moved, stamping 0.7 s
    /// later than the tag: a walker on a 4 × 3 m loop for 60 s, the tag's fixes exact at 10 Hz.
    fn counter_walk() -> (Registry, KeyJointStreams, SimilarityTransform) {
        let world_from_counter = SimilarityTransform {
            scale: 0.0153,
            isometry: Isometry3::from_parts(
                Translation3::new(1.0, -2.0, 0.3),
                UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.6),
            ),
        };
        let counter_from_world = world_from_counter.inverse();
        let at = |t: f64| {
            let a = 2.0 * std::f64::consts::PI * t / 12.0;
            Point3::new(
                3.0 + 2.0 * a.cos(),
                2.0 + 1.5 * a.sin(),
                1.7 + 0.05 * (3.0 * a).sin(),
            )
        };
        let stamp = |t: f64| SessionTime::from_secs_f64(t).unwrap();
        let camera_points = (0..240)
            .map(|k| {
                let t = k as f64 * 0.25;
                TimedPoint {
                    t: stamp(t + 0.7),
                    position_m: counter_from_world.apply(&at(t)),
                }
            })
            .collect();
        let tag_points = (0..600)
            .map(|k| {
                let t = k as f64 * 0.1;
                TimedPoint {
                    t: stamp(t),
                    position_m: at(t),
                }
            })
            .collect();
        let registry = Registry {
            subjects: vec![Subject {
                id: "ana".into(),
                name: None,
                wears: vec![Wearable {
                    device: "tag1".into(),
                    kind: DeviceKind::UwbTag,
                    site: Joint::Head,
                    either_side: false,
                    clock: ClockModel {
                        offset_ns: 100_000_000,
                        drift_ppm: 0.0,
                    },
                }],
            }],
            cameras: vec![Camera::new("counter", RigidTransform::IDENTITY)],
            ..Default::default()
        };
        let streams = KeyJointStreams {
            camera: Some(CameraId::new("counter")),
            tag: Some(TagId::new("tag1")),
            key_joint: Some(Joint::Head),
            camera_points,
            tag_points,
            num_crowded_frames: 0,
        };
        (registry, streams, world_from_counter)
    }

    fn config(kind: FitKind) -> FramesCalibrationConfig {
        let mut config = FramesCalibrationConfig {
            quality: FitQualityConfig::for_location_fixes(),
            ..Default::default()
        };
        config.clock.kind = kind;
        config
    }

    #[test]
    fn a_rigid_fit_of_a_counter_in_its_own_units_is_disqualified() {
        let (_, streams, _) = counter_walk();
        let cal = calibrate_streams(&streams, &config(FitKind::Rigid)).unwrap();
        assert!(cal.report.is_disqualified(), "{:?}", cal.report);
        let cal = calibrate_streams(&streams, &config(FitKind::Similarity)).unwrap();
        assert!(!cal.report.is_disqualified(), "{:?}", cal.report);
    }

    #[test]
    fn a_counter_calibration_puts_it_in_the_world_and_on_the_tags_session_clock() {
        let (registry, streams, truth) = counter_walk();
        let cal = calibrate_streams(&streams, &config(FitKind::Similarity)).unwrap();
        let camera = CameraId::new("counter");
        let found = camera_calibration(&registry, &camera, &TagId::new("tag1"), &cal).unwrap();
        let mut calibrated = registry.clone();
        calibrated.apply_calibration(&found).unwrap();
        let c = calibrated.camera(&camera).unwrap();
        // The 4-Hz positions are interpolated along chords of the loop, a little inside it:
        // the scale comes out a few tenths of a percent large.
        assert!((c.scale / truth.scale - 1.0).abs() < 0.01, "{}", c.scale);
        // Counter stamps are 0.7 s after the tag's of the same instant, and the tag's session
        // time is its stamp + 0.1 s: a counter stamp + (0.1 − 0.7) s is session time.
        assert!(
            (c.clock.offset_ns + 600_000_000).abs() <= 10_000_000,
            "{:?}",
            c.clock
        );
        let p = Point3::new(300.0, -120.0, 40.0);
        assert!(
            (c.to_world(&p) - truth.apply(&p)).norm() < 0.05,
            "{}",
            c.to_world(&p)
        );
        // A camera the registry does not have is named.
        let err = camera_calibration(&registry, &CameraId::new("door"), &TagId::new("tag1"), &cal)
            .unwrap_err()
            .to_string();
        assert!(err.contains("'door'"), "{err}");
    }

    #[test]
    fn the_camera_or_tag_to_calibrate_is_chosen_or_the_choices_are_named() {
        let seen = |v: &[&str]| v.iter().map(|s| (*s).to_owned()).collect::<Vec<_>>();
        assert_eq!(pick("tag", None, seen(&["t1"])).unwrap(), "t1");
        assert_eq!(
            pick("tag", Some("t2".into()), seen(&["t1", "t2"])).unwrap(),
            "t2"
        );
        let why = |r: Result<String>| r.unwrap_err().to_string();
        assert!(why(pick("tag", None, seen(&[]))).contains("no tag data"));
        assert!(
            why(pick("camera", Some("back".into()), seen(&["front"])))
                .contains("no camera 'back' in the recording (it has: front)")
        );
        assert!(why(pick("tag", None, seen(&["t1", "t2"]))).contains("choose one of: t1, t2"));
    }
}
