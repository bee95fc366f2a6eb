//! Azure Kinect Body Tracking JSON, as Microsoft's offline processor writes it
//! (<https://github.com/microsoft/Azure-Kinect-Samples/tree/master/body-tracking-samples/offline_processor>)
//! → `skeleton` messages.
//!
//! The file is one JSON document:
//! `{"k4abt_sdk_version", "source_file", "joint_names": [32 names], "bone_list": [...],
//! "frames": [{"frame_id", "num_bodies", "timestamp_usec", "bodies": [{"body_id",
//! "joint_positions": [[x, y, z] × 32], "joint_orientations": [[w, x, y, z] × 32]}]}]}`.
//!
//! - Positions are millimetres in the depth camera's frame (+X right, +Y down, +Z forward;
//!   <https://learn.microsoft.com/en-us/azure/kinect-dk/body-joints>), which is nomen's camera
//!   frame: they are only scaled to metres.
//! - Joints are mapped by their names in `joint_names` (the SDK's `k4abt_joint_id_t` order when
//!   the file has none) onto nomen's joints with [`JointSet::AzureKinect`]; the navel, clavicles,
//!   hand tips, thumbs, nose, eyes and ears have no nomen joint and are left out. The offline
//!   processor writes no per-joint confidence: every joint is `tracked` with confidence 1. A
//!   coordinate written as `null` (the JSON library's NaN) leaves its joint out, counted.
//! - `timestamp_usec` is the device timestamp (µs since the device started); `t` is it in ns
//!   plus [`AzureKinectConfig::time_offset_ns`]. `body_id` is the track.
//! - `joint_orientations`, `bone_list`, `frame_id` and the version fields are not read.
//!   `num_bodies`, where present, must match `bodies`.

use crate::decoded::{Collector, Decoded, check_payload_size, payload_place, shift};
use crate::error::{AdapterError, Place, Result};
use nalgebra::Point3;
use nomen_core::skeleton::Joints;
use nomen_core::skeleton::sets::JointSet;
use nomen_core::{CameraId, Joint, JointObservation, Message, SkeletonObservation, TrackId};
use serde::Deserialize;
use std::io::Read;
use std::sync::Arc;

/// The largest document [`read_azure_kinect`] takes, bytes: the offline processor writes about
/// 6 kB per body and frame (indented JSON), so 2 GiB is about 90 minutes of two people at
/// 30 Hz.
pub const MAX_DOCUMENT_BYTES: u64 = 2 << 30;

/// Reason counted for a joint left out because a coordinate is null.
pub const SKIP_NULL_JOINT: &str = "joints with a null coordinate";

/// How a body-tracking file maps onto the session.
#[derive(Debug, Clone, PartialEq)]
pub struct AzureKinectConfig {
    /// The camera the skeletons are from (a camera of the registry).
    pub camera: CameraId,
    /// Added to every `timestamp_usec` (as ns) to give session time, ns.
    pub time_offset_ns: i64,
}

#[derive(Deserialize)]
struct Document {
    #[serde(default)]
    joint_names: Option<Vec<String>>,
    frames: Vec<Frame>,
}

#[derive(Deserialize)]
struct Frame {
    timestamp_usec: i64,
    #[serde(default)]
    num_bodies: Option<u64>,
    bodies: Vec<Body>,
}

#[derive(Deserialize)]
struct Body {
    body_id: u64,
    joint_positions: Vec<[Option<f64>; 3]>,
}

/// Reads an offline-processor JSON file.
pub fn read_azure_kinect(
    input: impl Read,
    source: &str,
    config: &AzureKinectConfig,
) -> Result<Decoded> {
    let source: Arc<str> = Arc::from(source);
    let at = Place::new(&source);
    // serde_json reads byte by byte: buffered here, whatever the caller passes.
    let mut limited = std::io::BufReader::new(input.take(MAX_DOCUMENT_BYTES + 1));
    let document: Document = serde_json::from_reader(&mut limited).map_err(|e| {
        if limited.get_ref().limit() == 0 {
            AdapterError::TooLarge {
                at: at.clone(),
                what: "document",
                limit: MAX_DOCUMENT_BYTES,
            }
        } else {
            AdapterError::from_json(&at, &e)
        }
    })?;
    let joints = joint_map(document.joint_names.as_deref(), &at)?;
    let mut out = Collector::default();
    for (i, frame) in document.frames.iter().enumerate() {
        convert_frame(
            frame,
            &at.at(format!("frames[{i}]")),
            &joints,
            config,
            &mut out,
        )?;
    }
    out.into_file()
}

/// Decodes one frame object (`{"timestamp_usec", "bodies": [...]}`, joints in the SDK's
/// order), as a live publisher would send each frame of the offline processor's `frames`.
pub fn decode_azure_kinect_frame(payload: &[u8], config: &AzureKinectConfig) -> Result<Decoded> {
    let at = payload_place();
    check_payload_size(payload, &at)?;
    let frame: Frame =
        serde_json::from_slice(payload).map_err(|e| AdapterError::from_json(&at, &e))?;
    let joints = joint_map(None, &at)?;
    let mut out = Collector::default();
    convert_frame(&frame, &at, &joints, config, &mut out)?;
    Ok(out.into_payload())
}

/// The nomen joint of each position index (`None`: a joint nomen has no place for).
fn joint_map(names: Option<&[String]>, at: &Place) -> Result<Vec<Option<Joint>>> {
    let set = JointSet::AzureKinect;
    let Some(names) = names else {
        return Ok((0..set.len()).map(|i| set.canonical(i)).collect());
    };
    names
        .iter()
        .enumerate()
        .map(|(i, name)| {
            set.index_of(name).map(|k| set.canonical(k)).ok_or_else(|| {
                AdapterError::shape(
                    &at.at(format!("joint_names[{i}]")),
                    format!("unknown joint '{name}' (the SDK names them PELVIS, SPINE_NAVEL, ...)"),
                )
            })
        })
        .collect()
}

fn convert_frame(
    frame: &Frame,
    at: &Place,
    joint_of: &[Option<Joint>],
    config: &AzureKinectConfig,
    out: &mut Collector,
) -> Result<()> {
    if let Some(n) = frame.num_bodies
        && n != frame.bodies.len() as u64
    {
        return Err(AdapterError::shape(
            at,
            format!(
                "num_bodies is {n} but bodies has {} entries",
                frame.bodies.len()
            ),
        ));
    }
    let t_at = at.at("timestamp_usec");
    let ns = frame
        .timestamp_usec
        .checked_mul(1000)
        .ok_or_else(|| AdapterError::shape(&t_at, "time out of range"))?;
    let t = shift(ns, config.time_offset_ns, &t_at)?;
    for (j, body) in frame.bodies.iter().enumerate() {
        let at = at.at(format!("bodies[{j}]"));
        if body.joint_positions.len() != joint_of.len() {
            return Err(AdapterError::shape(
                &at.at("joint_positions"),
                format!(
                    "{} joints, expected {} (one per joint name)",
                    body.joint_positions.len(),
                    joint_of.len()
                ),
            ));
        }
        let mut joints = Joints::new();
        for (p, joint) in body.joint_positions.iter().zip(joint_of) {
            let Some(joint) = joint else { continue };
            let [Some(x), Some(y), Some(z)] = *p else {
                out.skipped.add(SKIP_NULL_JOINT);
                continue;
            };
            // Millimetres in the depth camera frame; nomen's camera frame has the same axes.
            let position_m = Point3::new(x, y, z) / 1000.0;
            joints.insert(*joint, JointObservation::tracked(position_m));
        }
        let skeleton = SkeletonObservation {
            t,
            camera: config.camera.clone(),
            track: TrackId(body.body_id),
            joints,
        };
        out.push(Message::Skeleton(Box::new(skeleton)), &at)?;
    }
    Ok(())
}
