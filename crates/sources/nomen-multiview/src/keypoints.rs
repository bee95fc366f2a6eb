//! 2D keypoints per view: the detection type, and readers of the JSON that common 2D pose
//! estimators write.
//!
//! Formats, recognised from the document's shape ([`parse_keypoints`]):
//!
//! - **OpenPose** `--write_json`, one file per frame: `{"version":1.3,"people":[{"pose_keypoints_2d":
//!   [x0,y0,c0,x1,y1,c1,...]}, ...]}`, `c` a confidence in `0..=1` and `0,0,0` for a part not
//!   found; the older `pose_keypoints` key is read too. Coordinates must be pixels
//!   (`--keypoint_scale 0`, the default). Described in OpenPose's `doc/02_output.md`
//!   (<https://github.com/CMU-Perceptual-Computing-Lab/openpose/blob/master/doc/02_output.md>).
//! - **COCO annotations** (`person_keypoints_*.json`): `{"annotations":[{"image_id":..,
//!   "keypoints":[x,y,v,...]}, ...]}` with visibility `v` 0 (not labelled), 1 (labelled, not
//!   visible) or 2 (visible): <https://cocodataset.org/#format-data>.
//! - **COCO results** (what COCO evaluation reads, and AlphaPose's default output): a list of
//!   `{"image_id":..,"category_id":1,"keypoints":[x,y,score,...],"score":..}`.
//! - **MMPose** `MMPoseInferencer(..., pred_out_dir=...)`: per image a list of instances
//!   `{"keypoints":[[x,y],...],"keypoint_scores":[...],"bbox":...}`; its video demo writes
//!   `{"meta_info":..,"instance_info":[{"frame_id":1,"instances":[...]}, ...]}`
//!   (<https://mmpose.readthedocs.io/en/latest/user_guides/inference.html>).
//!
//! The layout comes from the number of keypoints per person: 25 is OpenPose BODY_25, 18
//! OpenPose's COCO-18, 17 COCO-17, 133 COCO-WholeBody (its first 17 are COCO-17's body). Each is
//! mapped onto nomen's canonical joints ([`nomen_core::skeleton::sets`]); points the canonical
//! set has no place for (eyes, ears, toes but the big one) are dropped, and so are points whose
//! confidence is 0 or less. A confidence above 1 (AlphaPose's COCO scores reach 6) counts as 1.
//!
//! The readers are bounded ([`KeypointLimits`]) and never panic on data: a wrong count, a
//! non-number or an unknown shape is an error naming the file, and the JSON path or the line
//! and column.

use crate::error::{MultiviewError, Result, invalid};
use nalgebra::Point2;
use nomen_core::Joint;
use nomen_core::skeleton::Joints;
use nomen_core::skeleton::sets::JointSet;
use serde_json::Value;
use std::collections::BTreeMap;

/// One 2D keypoint: a pixel (distorted, as the image shows it) and the estimator's confidence.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Keypoint {
    /// Pixel coordinates (x right, y down, origin at the top-left pixel's centre).
    pub pixel_px: Point2<f64>,
    /// Confidence in `0..=1` (greater than 0: a point of confidence 0 is absent).
    pub confidence: f64,
}

/// One person detected in one view: keypoints on the canonical joints.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Detection {
    /// The keypoints, absent where the estimator found nothing.
    pub joints: Joints<Keypoint>,
}

/// The detections of one view at one frame.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct KeypointFrame {
    /// The frame number (from the document, or the caller's for one-frame documents).
    pub frame: u64,
    /// The people detected, in the document's order.
    pub detections: Vec<Detection>,
}

/// Which format a document was read as.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum KeypointFormat {
    /// OpenPose `--write_json`.
    OpenPose,
    /// COCO keypoint annotations (`annotations` with visibility flags).
    CocoAnnotations,
    /// COCO keypoint results (a list with `image_id` and scores).
    CocoResults,
    /// MMPose predictions of one image (a list of instances).
    MmposeImage,
    /// MMPose predictions of a video (`instance_info` per frame).
    MmposeVideo,
}

/// Limits on what a keypoint reader takes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KeypointLimits {
    /// Largest document, bytes.
    pub max_bytes: usize,
    /// Most people in one frame of one view.
    pub max_people_per_frame: usize,
    /// Most frames in one document.
    pub max_frames: usize,
}

impl Default for KeypointLimits {
    fn default() -> Self {
        Self {
            max_bytes: 256 << 20,
            max_people_per_frame: 1000,
            max_frames: 10_000_000,
        }
    }
}

/// A parsed keypoint document.
#[derive(Debug, Clone, PartialEq)]
pub struct KeypointDocument {
    /// The format it was read as.
    pub format: KeypointFormat,
    /// Frames in increasing frame order.
    pub frames: Vec<KeypointFrame>,
}

/// OpenPose's COCO-18 order (`POSE_COCO_BODY_PARTS`): nose, neck, right arm, left arm, right
/// leg, left leg, eyes and ears.
const OPENPOSE_COCO_18: [Option<Joint>; 18] = [
    Some(Joint::Head),
    Some(Joint::Neck),
    Some(Joint::RightShoulder),
    Some(Joint::RightElbow),
    Some(Joint::RightWrist),
    Some(Joint::LeftShoulder),
    Some(Joint::LeftElbow),
    Some(Joint::LeftWrist),
    Some(Joint::RightHip),
    Some(Joint::RightKnee),
    Some(Joint::RightAnkle),
    Some(Joint::LeftHip),
    Some(Joint::LeftKnee),
    Some(Joint::LeftAnkle),
    None,
    None,
    None,
    None,
];

/// The canonical joint of keypoint `index` in a layout of `num_keypoints`, or an error for an
/// unknown layout.
fn canonical_of(num_keypoints: usize, index: usize) -> Option<Joint> {
    match num_keypoints {
        25 => JointSet::Body25.canonical(index),
        18 => OPENPOSE_COCO_18.get(index).copied().flatten(),
        17 | 133 => (index < 17)
            .then(|| JointSet::Coco17.canonical(index))
            .flatten(),
        _ => None,
    }
}

fn check_layout(source: &str, path: &str, num_keypoints: usize) -> Result<()> {
    if matches!(num_keypoints, 17 | 18 | 25 | 133) {
        Ok(())
    } else {
        Err(invalid(
            source,
            path,
            format!(
                "{num_keypoints} keypoints per person: not a known layout (17 COCO, 18 OpenPose \
                 COCO-18, 25 OpenPose BODY_25, 133 COCO-WholeBody)"
            ),
        ))
    }
}

/// Parses one keypoint document in any of the formats of the module docs. `frame_of_file` is
/// the frame number of a document that holds one frame without naming it (OpenPose, MMPose per
/// image).
pub fn parse_keypoints(
    text: &str,
    source_name: &str,
    frame_of_file: u64,
    limits: &KeypointLimits,
) -> Result<KeypointDocument> {
    if text.len() > limits.max_bytes {
        return Err(MultiviewError::TooLarge {
            source_name: source_name.to_owned(),
            detail: format!(
                "{} bytes, more than the {} a keypoint file may have",
                text.len(),
                limits.max_bytes
            ),
        });
    }
    let doc: Value = serde_json::from_str(text).map_err(|e| MultiviewError::Syntax {
        source_name: source_name.to_owned(),
        detail: format!("not JSON: {e}"),
    })?;
    let reader = Reader {
        source: source_name,
        limits,
    };
    match &doc {
        Value::Object(map) if map.contains_key("people") => Ok(KeypointDocument {
            format: KeypointFormat::OpenPose,
            frames: vec![reader.openpose(&doc, frame_of_file)?],
        }),
        Value::Object(map) if map.contains_key("instance_info") => Ok(KeypointDocument {
            format: KeypointFormat::MmposeVideo,
            frames: reader.mmpose_video(&doc)?,
        }),
        Value::Object(map) if map.contains_key("annotations") => Ok(KeypointDocument {
            format: KeypointFormat::CocoAnnotations,
            frames: reader.coco_list(&map["annotations"], "annotations", true)?,
        }),
        Value::Array(items) => {
            let is_mmpose = items.first().is_some_and(|first| {
                first
                    .get("keypoints")
                    .and_then(Value::as_array)
                    .and_then(|k| k.first())
                    .is_some_and(Value::is_array)
            });
            if is_mmpose {
                Ok(KeypointDocument {
                    format: KeypointFormat::MmposeImage,
                    frames: vec![KeypointFrame {
                        frame: frame_of_file,
                        detections: reader.mmpose_instances(&doc, "")?,
                    }],
                })
            } else {
                let mut frames = reader.coco_list(&doc, "", false)?;
                // A list without detections is one empty frame of this file.
                if items.is_empty() {
                    frames.push(KeypointFrame {
                        frame: frame_of_file,
                        detections: Vec::new(),
                    });
                }
                Ok(KeypointDocument {
                    format: KeypointFormat::CocoResults,
                    frames,
                })
            }
        }
        _ => Err(invalid(
            source_name,
            "(top level)",
            "not a keypoint document: expected OpenPose (`people`), COCO (`annotations`, or a \
             list with `keypoints`) or MMPose (`instance_info`, or a list of instances)",
        )),
    }
}

struct Reader<'a> {
    source: &'a str,
    limits: &'a KeypointLimits,
}

fn join(path: &str, key: &str) -> String {
    if path.is_empty() {
        key.to_owned()
    } else {
        format!("{path}.{key}")
    }
}

impl Reader<'_> {
    fn array<'v>(&self, v: &'v Value, path: &str) -> Result<&'v Vec<Value>> {
        v.as_array().ok_or_else(|| {
            invalid(
                self.source,
                path,
                format!("expected a list, found {}", kind(v)),
            )
        })
    }

    fn number(&self, v: &Value, path: &str) -> Result<f64> {
        match v.as_f64() {
            Some(x) if x.is_finite() => Ok(x),
            _ => Err(invalid(
                self.source,
                path,
                format!("expected a number, found {}", kind(v)),
            )),
        }
    }

    fn check_people(&self, n: usize, path: &str) -> Result<()> {
        if n > self.limits.max_people_per_frame {
            return Err(MultiviewError::TooLarge {
                source_name: self.source.to_owned(),
                detail: format!(
                    "{path}: {n} people in one frame, more than the {} taken",
                    self.limits.max_people_per_frame
                ),
            });
        }
        Ok(())
    }

    /// A flat `x, y, c` list into a detection; `is_visibility`: the third value is COCO's
    /// visibility flag (0, 1, 2) rather than a score.
    fn triples(&self, v: &Value, path: &str, is_visibility: bool) -> Result<Detection> {
        let values = self.array(v, path)?;
        if values.len() % 3 != 0 {
            return Err(invalid(
                self.source,
                path,
                format!("{} values, not x, y, c triples", values.len()),
            ));
        }
        let num_keypoints = values.len() / 3;
        check_layout(self.source, path, num_keypoints)?;
        let mut detection = Detection::default();
        for (i, triple) in values.chunks_exact(3).enumerate() {
            let at = |k: usize| format!("{path}[{}]", 3 * i + k);
            let x = self.number(&triple[0], &at(0))?;
            let y = self.number(&triple[1], &at(1))?;
            let c = self.number(&triple[2], &at(2))?;
            let confidence = if is_visibility {
                if !matches!(c, 0.0 | 1.0 | 2.0) {
                    return Err(invalid(
                        self.source,
                        at(2),
                        format!("visibility {c} is not 0, 1 or 2"),
                    ));
                }
                if c > 0.0 { 1.0 } else { 0.0 }
            } else {
                c.min(1.0)
            };
            if let Some(joint) = canonical_of(num_keypoints, i)
                && confidence > 0.0
            {
                detection.joints.insert(
                    joint,
                    Keypoint {
                        pixel_px: Point2::new(x, y),
                        confidence,
                    },
                );
            }
        }
        Ok(detection)
    }

    fn openpose(&self, doc: &Value, frame: u64) -> Result<KeypointFrame> {
        let people = self.array(&doc["people"], "people")?;
        self.check_people(people.len(), "people")?;
        let mut detections = Vec::with_capacity(people.len());
        for (i, person) in people.iter().enumerate() {
            let path = format!("people[{i}]");
            let (key, values) = match (
                person.get("pose_keypoints_2d"),
                person.get("pose_keypoints"),
            ) {
                (Some(v), _) => ("pose_keypoints_2d", v),
                (None, Some(v)) => ("pose_keypoints", v),
                (None, None) => {
                    return Err(invalid(
                        self.source,
                        path,
                        "no pose_keypoints_2d (nor the older pose_keypoints)",
                    ));
                }
            };
            // OpenPose writes an empty list when the body was not run (face or hands only).
            if values.as_array().is_some_and(Vec::is_empty) {
                continue;
            }
            detections.push(self.triples(values, &join(&path, key), false)?);
        }
        Ok(KeypointFrame { frame, detections })
    }

    fn frame_number(&self, v: Option<&Value>, path: &str) -> Result<u64> {
        match v {
            Some(Value::Number(n)) => n.as_u64().ok_or_else(|| {
                invalid(
                    self.source,
                    path,
                    format!("{n} is not a frame number (0 or more)"),
                )
            }),
            // Image ids written as file names: the last run of digits (`000123.jpg` → 123).
            Some(Value::String(s)) => last_number(s)
                .ok_or_else(|| invalid(self.source, path, format!("'{s}' holds no frame number"))),
            Some(other) => Err(invalid(
                self.source,
                path,
                format!("expected a frame number, found {}", kind(other)),
            )),
            None => Err(invalid(self.source, path, "missing")),
        }
    }

    fn collect(&self, by_frame: BTreeMap<u64, Vec<Detection>>) -> Result<Vec<KeypointFrame>> {
        if by_frame.len() > self.limits.max_frames {
            return Err(MultiviewError::TooLarge {
                source_name: self.source.to_owned(),
                detail: format!(
                    "{} frames, more than the {} taken",
                    by_frame.len(),
                    self.limits.max_frames
                ),
            });
        }
        Ok(by_frame
            .into_iter()
            .map(|(frame, detections)| KeypointFrame { frame, detections })
            .collect())
    }

    fn coco_list(&self, v: &Value, path: &str, is_visibility: bool) -> Result<Vec<KeypointFrame>> {
        let items = self.array(v, if path.is_empty() { "(top level)" } else { path })?;
        let mut by_frame: BTreeMap<u64, Vec<Detection>> = BTreeMap::new();
        for (i, item) in items.iter().enumerate() {
            let at = format!("{path}[{i}]");
            if item
                .get("category_id")
                .and_then(Value::as_u64)
                .is_some_and(|c| c != 1)
            {
                continue; // not a person
            }
            let frame = self.frame_number(item.get("image_id"), &join(&at, "image_id"))?;
            let keypoints = item
                .get("keypoints")
                .ok_or_else(|| invalid(self.source, &at, "no keypoints"))?;
            let detection = self.triples(keypoints, &join(&at, "keypoints"), is_visibility)?;
            let frame_detections = by_frame.entry(frame).or_default();
            frame_detections.push(detection);
            self.check_people(frame_detections.len(), &format!("image {frame}"))?;
        }
        self.collect(by_frame)
    }

    fn mmpose_instances(&self, v: &Value, path: &str) -> Result<Vec<Detection>> {
        let instances = self.array(v, if path.is_empty() { "(top level)" } else { path })?;
        self.check_people(instances.len(), path)?;
        let mut detections = Vec::with_capacity(instances.len());
        for (i, instance) in instances.iter().enumerate() {
            let at = format!("{path}[{i}]");
            let kp_path = join(&at, "keypoints");
            let points = self.array(
                instance
                    .get("keypoints")
                    .ok_or_else(|| invalid(self.source, &at, "no keypoints"))?,
                &kp_path,
            )?;
            let score_path = join(&at, "keypoint_scores");
            let scores = self.array(
                instance
                    .get("keypoint_scores")
                    .ok_or_else(|| invalid(self.source, &at, "no keypoint_scores"))?,
                &score_path,
            )?;
            if scores.len() != points.len() {
                return Err(invalid(
                    self.source,
                    &score_path,
                    format!("{} scores for {} keypoints", scores.len(), points.len()),
                ));
            }
            check_layout(self.source, &kp_path, points.len())?;
            let mut detection = Detection::default();
            for (k, (point, score)) in points.iter().zip(scores).enumerate() {
                let p_path = format!("{kp_path}[{k}]");
                let xy = self.array(point, &p_path)?;
                if xy.len() != 2 {
                    return Err(invalid(
                        self.source,
                        &p_path,
                        format!("{} values, expected [x, y]", xy.len()),
                    ));
                }
                let x = self.number(&xy[0], &format!("{p_path}[0]"))?;
                let y = self.number(&xy[1], &format!("{p_path}[1]"))?;
                let c = self.number(score, &format!("{score_path}[{k}]"))?.min(1.0);
                if let Some(joint) = canonical_of(points.len(), k)
                    && c > 0.0
                {
                    detection.joints.insert(
                        joint,
                        Keypoint {
                            pixel_px: Point2::new(x, y),
                            confidence: c,
                        },
                    );
                }
            }
            detections.push(detection);
        }
        Ok(detections)
    }

    fn mmpose_video(&self, doc: &Value) -> Result<Vec<KeypointFrame>> {
        let frames = self.array(&doc["instance_info"], "instance_info")?;
        let mut by_frame: BTreeMap<u64, Vec<Detection>> = BTreeMap::new();
        for (i, frame) in frames.iter().enumerate() {
            let at = format!("instance_info[{i}]");
            let number = self.frame_number(frame.get("frame_id"), &join(&at, "frame_id"))?;
            let instances = frame
                .get("instances")
                .ok_or_else(|| invalid(self.source, &at, "no instances"))?;
            let detections = self.mmpose_instances(instances, &join(&at, "instances"))?;
            if by_frame.insert(number, detections).is_some() {
                return Err(invalid(
                    self.source,
                    join(&at, "frame_id"),
                    format!("frame {number} appears twice"),
                ));
            }
        }
        self.collect(by_frame)
    }
}

/// The last run of ASCII digits in `s` (`cam1_000000000042_keypoints.json` → 42), if any fits
/// a `u64`.
pub fn last_number(s: &str) -> Option<u64> {
    let end = s.rfind(|c: char| c.is_ascii_digit())? + 1;
    let start = s[..end]
        .rfind(|c: char| !c.is_ascii_digit())
        .map_or(0, |i| i + 1);
    s[start..end].parse().ok()
}

fn kind(v: &Value) -> &'static str {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Array(_) => "a list",
        Value::Object(_) => "an object",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn body25_flat(missing: usize) -> String {
        (0..25)
            .map(|i| {
                if i == missing {
                    "0,0,0".to_owned()
                } else {
                    format!("{}.5,{}.25,0.9", 100 + i, 200 + i)
                }
            })
            .collect::<Vec<_>>()
            .join(",")
    }

    #[test]
    fn openpose_body25_maps_onto_canonical_joints_and_drops_undetected_parts() {
        let text = format!(
            r#"{{"version":1.3,"people":[{{"person_id":[-1],"pose_keypoints_2d":[{}],"face_keypoints_2d":[]}},{{"pose_keypoints_2d":[]}}]}}"#,
            body25_flat(4)
        );
        let doc = parse_keypoints(&text, "f.json", 7, &KeypointLimits::default()).unwrap();
        assert_eq!(doc.format, KeypointFormat::OpenPose);
        assert_eq!(doc.frames.len(), 1);
        assert_eq!(doc.frames[0].frame, 7);
        let d = &doc.frames[0].detections;
        assert_eq!(d.len(), 1, "the face-only person has no body");
        // BODY_25 index 8 is MidHip → pelvis; index 4 (RWrist) was 0,0,0.
        let pelvis = d[0].joints.get(Joint::Pelvis).unwrap();
        assert_eq!(pelvis.pixel_px, Point2::new(108.5, 208.25));
        assert_eq!(pelvis.confidence, 0.9);
        assert!(d[0].joints.get(Joint::RightWrist).is_none());
        assert!(d[0].joints.get(Joint::LeftFoot).is_some());
        assert!(d[0].joints.get(Joint::Chest).is_none());
    }

    #[test]
    fn coco_annotations_and_results_group_by_image() {
        let kp = |v: f64| {
            (0..17)
                .map(|i| format!("{i},{},{v}", 2 * i))
                .collect::<Vec<_>>()
                .join(",")
        };
        let ann = format!(
            r#"{{"images":[],"annotations":[{{"image_id":3,"keypoints":[{}]}},{{"image_id":1,"keypoints":[{}]}},{{"image_id":3,"keypoints":[{}]}}]}}"#,
            kp(2.0),
            kp(1.0),
            kp(0.0)
        );
        let doc = parse_keypoints(&ann, "a.json", 0, &KeypointLimits::default()).unwrap();
        assert_eq!(doc.format, KeypointFormat::CocoAnnotations);
        assert_eq!(
            doc.frames.iter().map(|f| f.frame).collect::<Vec<_>>(),
            [1, 3]
        );
        assert_eq!(doc.frames[1].detections.len(), 2);
        assert_eq!(doc.frames[1].detections[0].joints.len(), 13);
        assert!(doc.frames[1].detections[1].joints.is_empty());
        let res = format!(
            r#"[{{"image_id":"frame_000012.jpg","category_id":1,"keypoints":[{}],"score":0.8}}]"#,
            kp(3.5)
        );
        let doc = parse_keypoints(&res, "r.json", 0, &KeypointLimits::default()).unwrap();
        assert_eq!(doc.format, KeypointFormat::CocoResults);
        assert_eq!(doc.frames[0].frame, 12);
        let nose = doc.frames[0].detections[0].joints.get(Joint::Head).unwrap();
        assert_eq!(nose.confidence, 1.0, "scores above 1 count as 1");
    }

    #[test]
    fn mmpose_image_and_video_predictions_are_read() {
        let inst = |s: f64| {
            let points = (0..17)
                .map(|i| format!("[{i}.0,{i}.5]"))
                .collect::<Vec<_>>()
                .join(",");
            let scores = vec![format!("{s}"); 17].join(",");
            format!(
                r#"{{"keypoints":[{points}],"keypoint_scores":[{scores}],"bbox":[[0,0,1,1]],"bbox_score":0.9}}"#
            )
        };
        let image = format!("[{},{}]", inst(0.7), inst(0.2));
        let doc = parse_keypoints(&image, "i.json", 5, &KeypointLimits::default()).unwrap();
        assert_eq!(doc.format, KeypointFormat::MmposeImage);
        assert_eq!(doc.frames[0].frame, 5);
        assert_eq!(doc.frames[0].detections.len(), 2);
        let ls = doc.frames[0].detections[0]
            .joints
            .get(Joint::LeftShoulder)
            .unwrap();
        assert_eq!(ls.pixel_px, Point2::new(5.0, 5.5));
        assert_eq!(ls.confidence, 0.7);
        let video = format!(
            r#"{{"meta_info":{{}},"instance_info":[{{"frame_id":2,"instances":[{}]}},{{"frame_id":1,"instances":[]}}]}}"#,
            inst(0.5)
        );
        let doc = parse_keypoints(&video, "v.json", 0, &KeypointLimits::default()).unwrap();
        assert_eq!(doc.format, KeypointFormat::MmposeVideo);
        assert_eq!(
            doc.frames
                .iter()
                .map(|f| (f.frame, f.detections.len()))
                .collect::<Vec<_>>(),
            [(1, 0), (2, 1)]
        );
    }

    #[test]
    fn malformed_documents_are_refused_with_their_position() {
        let limits = KeypointLimits::default();
        let cases: [(&str, &str); 8] = [
            (
                r#"{"people":[{"pose_keypoints_2d":[1,2]}]}"#,
                "people[0].pose_keypoints_2d: 2 values",
            ),
            (
                r#"{"people":[{"pose_keypoints_2d":[1,2,3,4,5,6]}]}"#,
                "2 keypoints per person",
            ),
            (
                r#"{"people":[{"face":[]}]}"#,
                "people[0]: no pose_keypoints_2d",
            ),
            (
                r#"{"people":[{"pose_keypoints_2d":"x"}]}"#,
                "expected a list, found a string",
            ),
            (r#"{"people": [ {"pose_keypoints_2d":[1,2"#, "line 1 column"),
            (
                r#"{"annotations":[{"image_id":-1,"keypoints":[]}]}"#,
                "annotations[0].image_id: -1",
            ),
            (
                r#"{"instance_info":[{"frame_id":1,"instances":[{"keypoints":[[1,2]],"keypoint_scores":[]}]}]}"#,
                "instance_info[0].instances[0].keypoint_scores: 0 scores for 1 keypoints",
            ),
            (r#"{"x":1}"#, "not a keypoint document"),
        ];
        for (text, expected) in cases {
            let e = parse_keypoints(text, "bad.json", 0, &limits)
                .unwrap_err()
                .to_string();
            assert!(e.starts_with("bad.json: "), "{e}");
            assert!(e.contains(expected), "{text}: {e}");
        }
        let flat = vec!["1"; 17 * 3].join(",");
        let null_in = format!(
            r#"{{"people":[{{"pose_keypoints_2d":[null,{}]}}]}}"#,
            &flat[2..]
        );
        let e = parse_keypoints(&null_in, "n.json", 0, &limits)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("pose_keypoints_2d[0]: expected a number, found null"),
            "{e}"
        );
        let tiny = KeypointLimits {
            max_bytes: 10,
            ..limits
        };
        let e = parse_keypoints(r#"{"people":[]}"#, "big.json", 0, &tiny).unwrap_err();
        assert!(e.to_string().contains("more than the 10"), "{e}");
        let one = KeypointLimits {
            max_people_per_frame: 1,
            ..limits
        };
        let two = format!(
            r#"{{"people":[{{"pose_keypoints_2d":[{0}]}},{{"pose_keypoints_2d":[{0}]}}]}}"#,
            body25_flat(99)
        );
        assert!(parse_keypoints(&two, "p.json", 0, &one).is_err());
    }

    #[test]
    fn frame_numbers_come_from_the_last_digits_of_a_name() {
        assert_eq!(last_number("cam1_000000000042_keypoints.json"), Some(42));
        assert_eq!(last_number("000123.jpg"), Some(123));
        assert_eq!(last_number("keypoints.json"), None);
        assert_eq!(last_number("99999999999999999999999"), None);
    }
}
