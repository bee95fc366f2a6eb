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
use nomen_core::{CameraId, DeviceKind, Joint, Message, Registry, TagId};
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
