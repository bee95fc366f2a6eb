//! Calibration from a session's own data (`nomen run --calibrate auto`): each camera's
//! transform into the location system's frame (rigid, or a similarity when the rigid fit does
//! not explain the data) and each location tag's clock offset, from the tracks and the fixes
//! of the first minute, refined as data arrives.
//!
//! [`AutoCalibrator`] is a stage: [`AutoCalibrator::push`] takes messages (skeletons and
//! location fixes; others are ignored) and [`AutoCalibrator::poll`] returns an estimate when
//! one is due: the first after [`AutoCalibrationConfig::min_window_s`] of data, again every
//! [`AutoCalibrationConfig::retry_every_s`] until one calibrates everything or
//! [`AutoCalibrationConfig::window_s`] has passed, then every
//! [`AutoCalibrationConfig::refine_every_s`] over everything kept so far (the last
//! [`AutoCalibrationConfig::max_history_s`]).
//!
//! **Estimate of one (camera, tag).** The tag must have moved (its fixes' horizontal RMS
//! distance from their mean at least [`AutoCalibrationConfig::min_tag_motion_m`]). Every track
//! of the camera with enough points of the tag's key joint is a candidate wearer: its clock
//! offset to the tag is searched ([`estimate_clock_offset`]) with a transform refitted at each
//! offset; a track whose curve has no clear minimum (contrast below
//! [`AutoCalibrationConfig::min_contrast`]: someone who does not move, or not with the tag) is
//! not the wearer. The best track's transform then sorts every track: those whose points lie
//! within the RANSAC threshold of the fixes (median) are the wearer's; their points, pooled and
//! paired with the fixes at the best track's offset, give the RANSAC fit ([`fit_ransac`]),
//! judged by the poor-fit rule
//! ([`FitQualityConfig::for_location_fixes`]). A rigid fit comes first; a poor one is replaced
//! by a similarity (a tracker that does not report metres).
//!
//! **Clocks.** Cameras keep the registry's clocks: they define the session clock. A tag's
//! offset comes from the camera that fits it best: `session = tag stamp + offset`, with
//! `offset = (camera stamp − tag stamp of the same instant) + camera offset`. The fixes'
//! latency is part of what is found: a fix stamped when it is reported is put at the instant it
//! describes.
//!
//! **Limits.** Offsets between cameras are not estimated (they are taken to share the session
//! clock); drift is the registry's; the transform of a 2D tag's camera puts the key joint at
//! the fixes' height.

use crate::clock::{ClockSearchConfig, TimedPoint, estimate_clock_offset, pairs_at_offset};
use crate::error::{CalibError, Result};
use crate::fit::{
    FitKind, FitQualityConfig, ResidualReport, SimilarityTransform, percentile_sorted,
};
use crate::ransac::{RansacConfig, fit_ransac};
use nalgebra::Point3;
use nomen_core::{
    Calibration, CameraCalibration, CameraId, ClockModel, DeviceCalibration, DeviceKind, Joint,
    JointState, Message, Registry, SessionTime, TagId, TrackId,
};
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, BTreeSet};

/// Settings of [`AutoCalibrator`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AutoCalibrationConfig {
    /// Data the first estimate waits for, s (from the first skeleton or fix). Default 20 s:
    /// two or three laps of a room at walking pace.
    pub min_window_s: f64,
    /// Until an estimate calibrates every camera and tag that sent data, another is tried
    /// after this much more data, s. Default 10 s.
    pub retry_every_s: f64,
    /// Data after which the first estimate is final, whatever it calibrated, s. Default 60 s
    /// (issue 66: "from the first minute").
    pub window_s: f64,
    /// After the first complete (or final) estimate, a refined one every this much data, s.
    /// Default 30 s.
    pub refine_every_s: f64,
    /// Data kept for the estimates, s: older points are dropped. Default 600 s.
    pub max_history_s: f64,
    /// A tag whose fixes lie closer to their mean than this (horizontal RMS) has not moved
    /// enough to calibrate with, m. Default 0.5 m (three times the fixes' horizontal σ).
    pub min_tag_motion_m: f64,
    /// A track whose clock-offset curve's contrast ([`crate::clock::ClockOffsetFit::contrast`])
    /// is below this is not the tag's wearer. Default 1.3: over the ±2 s search a walker's
    /// curve gives 1.5–2 against 2D fixes from a 4-Hz counter, someone sitting about 1.
    pub min_contrast: f64,
    /// Fewest points of its key joint a track needs to be a candidate. Default 20.
    pub min_track_points: usize,
    /// Clock search (its `kind` is set by the estimate). `max_gap_s` 0.6 s by default here:
    /// a 4-Hz tracker that drops a frame is still interpolated.
    pub clock: ClockSearchConfig,
    /// RANSAC of the final fit.
    pub ransac: RansacConfig,
    /// The poor-fit rule. Default [`FitQualityConfig::for_location_fixes`].
    pub quality: FitQualityConfig,
}

impl Default for AutoCalibrationConfig {
    fn default() -> Self {
        Self {
            min_window_s: 20.0,
            retry_every_s: 10.0,
            window_s: 60.0,
            refine_every_s: 30.0,
            max_history_s: 600.0,
            min_tag_motion_m: 0.5,
            min_contrast: 1.3,
            min_track_points: 20,
            clock: ClockSearchConfig {
                max_gap_s: 0.6,
                ..ClockSearchConfig::default()
            },
            ransac: RansacConfig::default(),
            quality: FitQualityConfig::for_location_fixes(),
        }
    }
}

impl AutoCalibrationConfig {
    /// Checks the durations and counts.
    pub fn validate(&self) -> Result<()> {
        for (name, v) in [
            ("min_window_s", self.min_window_s),
            ("retry_every_s", self.retry_every_s),
            ("window_s", self.window_s),
            ("refine_every_s", self.refine_every_s),
            ("max_history_s", self.max_history_s),
            ("min_tag_motion_m", self.min_tag_motion_m),
            ("min_contrast", self.min_contrast),
        ] {
            crate::error::check_positive(name, v)?;
        }
        if self.window_s < self.min_window_s || self.max_history_s < self.window_s {
            return Err(CalibError::InvalidParameter {
                name: "window_s",
                reason: format!(
                    "need min_window_s <= window_s <= max_history_s, got {} / {} / {}",
                    self.min_window_s, self.window_s, self.max_history_s
                ),
            });
        }
        self.quality.validate()
    }
}

/// What one camera's estimate found, or why it failed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CameraEstimate {
    /// The camera.
    pub camera: CameraId,
    /// The fit, when one explains the data; else why none does.
    pub outcome: std::result::Result<CameraFit, String>,
}

/// A camera's transform into the location frame, from one tag.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CameraFit {
    /// The tag it was fitted against.
    pub tag: TagId,
    /// Rigid, or similarity when the rigid fit was poor.
    pub kind: FitKind,
    /// `world_from_camera` (the location frame is the world).
    pub world_from_camera: SimilarityTransform,
    /// Camera stamp minus tag stamp of the same instant, ns.
    pub clock_offset_ns: i64,
    /// Contrast of the best track's clock-offset curve (near 1: not observable).
    pub contrast: f64,
    /// Residuals of the final fit, over the wearer's pairs.
    pub report: ResidualReport,
    /// Tracks taken for the tag's wearer, and candidate tracks looked at.
    pub num_wearer_tracks: usize,
    /// Candidate tracks (enough points of the key joint).
    pub num_candidate_tracks: usize,
}

/// A tag's clock, from the camera that fits it best.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TagEstimate {
    /// The tag.
    pub tag: TagId,
    /// Its clock (`session = stamp + offset`), when a camera fitted it; else why not.
    pub outcome: std::result::Result<(CameraId, ClockModel), String>,
}

/// One estimate of [`AutoCalibrator`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AutoCalibration {
    /// Session time (newest stamp pushed) when it was made, and the span of data it used, s.
    pub t: SessionTime,
    /// Seconds of data it used.
    pub span_s: f64,
    /// Per camera that sent skeletons.
    pub cameras: Vec<CameraEstimate>,
    /// Per location tag that sent fixes.
    pub tags: Vec<TagEstimate>,
    /// What it found, for [`Registry::apply_calibration`]: the fitted cameras' poses and
    /// scales, and the fitted tags' clocks.
    pub calibration: Calibration,
    /// Whether it is the final try of the first window (made at `window_s` without calibrating
    /// everything), so the caller goes on with what it has.
    pub is_final_try: bool,
}

impl AutoCalibration {
    /// Whether every camera and tag that sent data is calibrated.
    pub fn is_complete(&self) -> bool {
        !self.cameras.is_empty()
            && self.cameras.iter().all(|c| c.outcome.is_ok())
            && self.tags.iter().all(|t| t.outcome.is_ok())
    }

    /// Whether it calibrated anything.
    pub fn is_empty(&self) -> bool {
        self.calibration.cameras.is_empty() && self.calibration.devices.is_empty()
    }
}

/// A registered location tag.
#[derive(Debug, Clone)]
struct TagInfo {
    key_joint: Joint,
    clock: ClockModel,
}

/// The calibration stage (see the module docs).
#[derive(Debug, Clone)]
pub struct AutoCalibrator {
    config: AutoCalibrationConfig,
    camera_clocks: BTreeMap<CameraId, ClockModel>,
    tags: BTreeMap<TagId, TagInfo>,
    key_joints: BTreeSet<Joint>,
    /// `(camera, track, key joint)` → points, camera stamps, time order.
    tracks: BTreeMap<(CameraId, TrackId, Joint), Vec<TimedPoint>>,
    /// Tag → fixes, tag stamps, time order.
    fixes: BTreeMap<TagId, Vec<TimedPoint>>,
    first_ns: Option<i64>,
    newest_ns: Option<i64>,
    /// Session time at which the next estimate is due.
    next_due_ns: Option<i64>,
    /// Whether the first window has given its estimate (complete or final).
    is_settled: bool,
}

fn ns(s: f64) -> i64 {
    (s * 1e9).round() as i64
}

impl AutoCalibrator {
    /// A calibrator for the cameras and location tags of `registry`.
    pub fn new(registry: &Registry, config: AutoCalibrationConfig) -> Result<Self> {
        config.validate()?;
        let tags: BTreeMap<TagId, TagInfo> = registry
            .subjects
            .iter()
            .flat_map(|s| &s.wears)
            .filter(|w| w.kind == DeviceKind::UwbTag)
            .map(|w| {
                (
                    w.device.clone(),
                    TagInfo {
                        key_joint: w.site,
                        clock: w.clock,
                    },
                )
            })
            .collect();
        Ok(Self {
            config,
            camera_clocks: registry
                .cameras
                .iter()
                .map(|c| (c.id.clone(), c.clock))
                .collect(),
            key_joints: tags.values().map(|t| t.key_joint).collect(),
            tags,
            tracks: BTreeMap::new(),
            fixes: BTreeMap::new(),
            first_ns: None,
            newest_ns: None,
            next_due_ns: None,
            is_settled: false,
        })
    }

    /// Takes a skeleton of a registered camera or a fix of a registered location tag (times
    /// as stamped); other messages, unknown sources and non-finite points are ignored.
    pub fn push(&mut self, message: &Message) {
        let t_ns = match message {
            Message::Skeleton(s) => {
                let Some(clock) = self.camera_clocks.get(&s.camera) else {
                    return;
                };
                for &joint in &self.key_joints {
                    let Some(j) = s.joints.get(joint) else {
                        continue;
                    };
                    if j.state == JointState::Missing || !j.position_m.iter().all(|v| v.is_finite())
                    {
                        continue;
                    }
                    self.tracks
                        .entry((s.camera.clone(), s.track, joint))
                        .or_default()
                        .push(TimedPoint {
                            t: s.t,
                            position_m: j.position_m,
                        });
                }
                clock.to_session(s.t.as_ns()).as_ns()
            }
            Message::RtlsFix(f) => {
                let Some(tag) = self.tags.get(&f.tag) else {
                    return;
                };
                if !f.position_m.iter().all(|v| v.is_finite()) {
                    return;
                }
                self.fixes
                    .entry(f.tag.clone())
                    .or_default()
                    .push(TimedPoint {
                        t: f.t,
                        position_m: f.position_m,
                    });
                tag.clock.to_session(f.t.as_ns()).as_ns()
            }
            _ => return,
        };
        let first = *self.first_ns.get_or_insert(t_ns);
        if self.newest_ns.is_none_or(|n| t_ns > n) {
            self.newest_ns = Some(t_ns);
        }
        self.next_due_ns
            .get_or_insert(first.saturating_add(ns(self.config.min_window_s)));
    }

    /// Seconds of data pushed so far (newest − first, session time).
    pub fn span_s(&self) -> f64 {
        match (self.first_ns, self.newest_ns) {
            (Some(a), Some(b)) => (b - a) as f64 * 1e-9,
            _ => 0.0,
        }
    }

    /// Whether the first window has given its estimate (complete, or final at `window_s`).
    pub fn is_settled(&self) -> bool {
        self.is_settled
    }

    /// An estimate, when one is due (see the module docs); `None` otherwise.
    pub fn poll(&mut self) -> Option<AutoCalibration> {
        let (Some(first), Some(newest), Some(due)) =
            (self.first_ns, self.newest_ns, self.next_due_ns)
        else {
            return None;
        };
        if newest < due {
            return None;
        }
        self.drop_old(newest);
        let window_end = first.saturating_add(ns(self.config.window_s));
        let mut estimate = self.estimate();
        if self.is_settled {
            self.next_due_ns = Some(newest.saturating_add(ns(self.config.refine_every_s)));
            return Some(estimate);
        }
        if estimate.is_complete() || newest >= window_end {
            estimate.is_final_try = !estimate.is_complete();
            self.is_settled = true;
            self.next_due_ns = Some(newest.saturating_add(ns(self.config.refine_every_s)));
        } else {
            self.next_due_ns =
                Some(window_end.min(newest.saturating_add(ns(self.config.retry_every_s))));
        }
        Some(estimate)
    }

    /// The estimate at the end of the data (for a run whose input ended before one was due):
    /// final, whatever it calibrated.
    pub fn finish(&mut self) -> Option<AutoCalibration> {
        self.newest_ns?;
        let mut estimate = self.estimate();
        estimate.is_final_try = !self.is_settled && !estimate.is_complete();
        self.is_settled = true;
        Some(estimate)
    }

    fn drop_old(&mut self, newest_ns: i64) {
        let keep_from = newest_ns.saturating_sub(ns(self.config.max_history_s));
        // Stamps are each source's own; a few seconds of offset do not matter at this scale.
        for points in self.tracks.values_mut().chain(self.fixes.values_mut()) {
            let cut = points.partition_point(|p| p.t.as_ns() < keep_from);
            points.drain(..cut);
        }
        self.tracks.retain(|_, v| !v.is_empty());
    }

    /// An estimate from everything kept (see the module docs).
    pub fn estimate(&self) -> AutoCalibration {
        let newest = self.newest_ns.unwrap_or(0);
        let mut cameras_seen: BTreeSet<&CameraId> = self.tracks.keys().map(|(c, _, _)| c).collect();
        // A registered camera that sent nothing is not estimated.
        cameras_seen.retain(|c| self.camera_clocks.contains_key(*c));
        let mut camera_estimates = Vec::new();
        // (tag → best (residual, camera, offset_ns)).
        let mut tag_best: BTreeMap<&TagId, (f64, &CameraId, i64)> = BTreeMap::new();
        let mut tag_failures: BTreeMap<&TagId, String> = BTreeMap::new();
        for camera in cameras_seen {
            let mut best: Option<CameraFit> = None;
            let mut why = Vec::new();
            for (tag, fixes) in &self.fixes {
                let Some(info) = self.tags.get(tag) else {
                    continue;
                };
                match self.fit_camera_tag(camera, tag, info.key_joint, fixes) {
                    Ok(fit) => {
                        let r = fit.report.rmse_inliers_m;
                        if tag_best.get(tag).is_none_or(|b| r < b.0) {
                            tag_best.insert(tag, (r, camera, fit.clock_offset_ns));
                        }
                        if best.as_ref().is_none_or(|b| r < b.report.rmse_inliers_m) {
                            best = Some(fit);
                        }
                    }
                    Err(e) => {
                        tag_failures.entry(tag).or_insert_with(|| e.clone());
                        why.push(format!("with tag {tag}: {e}"));
                    }
                }
            }
            if self.fixes.is_empty() {
                why.push("no location tag sent fixes".to_owned());
            }
            camera_estimates.push(CameraEstimate {
                camera: camera.clone(),
                outcome: best.ok_or_else(|| why.join("; ")),
            });
        }
        let mut tag_estimates = Vec::new();
        let mut calibration = Calibration::default();
        for tag in self.fixes.keys() {
            let Some(info) = self.tags.get(tag) else {
                continue;
            };
            let outcome = match tag_best.get(tag) {
                Some(&(_, camera, offset_ns)) => {
                    let camera_offset_ns =
                        self.camera_clocks.get(camera).map_or(0, |c| c.offset_ns);
                    let clock = ClockModel {
                        offset_ns: offset_ns.saturating_add(camera_offset_ns),
                        drift_ppm: info.clock.drift_ppm,
                    };
                    calibration.devices.push(DeviceCalibration {
                        device: tag.clone(),
                        clock,
                    });
                    Ok((camera.clone(), clock))
                }
                None => Err(tag_failures
                    .get(tag)
                    .cloned()
                    .unwrap_or_else(|| "no camera sent skeletons".to_owned())),
            };
            tag_estimates.push(TagEstimate {
                tag: tag.clone(),
                outcome,
            });
        }
        for c in &camera_estimates {
            if let Ok(fit) = &c.outcome {
                calibration.cameras.push(CameraCalibration {
                    id: c.camera.clone(),
                    world_from_camera: Some(fit.world_from_camera.to_rigid_transform()),
                    scale: Some(fit.world_from_camera.scale),
                    clock: None,
                });
            }
        }
        AutoCalibration {
            t: SessionTime::from_ns(newest),
            span_s: self.span_s(),
            cameras: camera_estimates,
            tags: tag_estimates,
            calibration,
            is_final_try: false,
        }
    }

    /// The fit of `camera` against `tag`: rigid, else similarity (see the module docs).
    fn fit_camera_tag(
        &self,
        camera: &CameraId,
        tag: &TagId,
        key_joint: Joint,
        fixes: &[TimedPoint],
    ) -> std::result::Result<CameraFit, String> {
        let motion_m = horizontal_rms_spread_m(fixes);
        if motion_m.is_nan() || motion_m < self.config.min_tag_motion_m {
            return Err(format!(
                "the tag's {} fixes lie within {motion_m:.2} m (horizontal RMS) of their mean: \
                 too little motion to calibrate with (at least {} m)",
                fixes.len(),
                self.config.min_tag_motion_m
            ));
        }
        let tracks: Vec<(&TrackId, &Vec<TimedPoint>)> = self
            .tracks
            .iter()
            .filter(|((c, _, j), points)| {
                c == camera && *j == key_joint && points.len() >= self.config.min_track_points
            })
            .map(|((_, k, _), points)| (k, points))
            .collect();
        if tracks.is_empty() {
            return Err(format!(
                "no track of the camera has {} points of the tag's key joint ({key_joint})",
                self.config.min_track_points
            ));
        }
        let named = |fit: CameraFit| CameraFit {
            tag: tag.clone(),
            ..fit
        };
        match self.fit_kind(&tracks, fixes, FitKind::Rigid) {
            Ok(fit) if !fit.report.is_disqualified() => Ok(named(fit)),
            _ => match self.fit_kind(&tracks, fixes, FitKind::Similarity) {
                Ok(fit) if !fit.report.is_disqualified() => Ok(named(fit)),
                Ok(fit) => Err(format!(
                    "neither a rigid nor a similarity fit explains the data: {}",
                    fit.report
                        .warnings
                        .iter()
                        .map(ToString::to_string)
                        .collect::<Vec<_>>()
                        .join("; ")
                )),
                Err(e) => Err(e),
            },
        }
    }

    fn fit_kind(
        &self,
        tracks: &[(&TrackId, &Vec<TimedPoint>)],
        fixes: &[TimedPoint],
        kind: FitKind,
    ) -> std::result::Result<CameraFit, String> {
        let clock = ClockSearchConfig {
            kind,
            ..self.config.clock
        };
        // The best candidate: lowest residual among clear curves.
        let mut best = None;
        for (track, points) in tracks {
            let Ok(fit) = estimate_clock_offset(points, fixes, &clock) else {
                continue;
            };
            if fit.contrast() < self.config.min_contrast {
                continue;
            }
            if best
                .as_ref()
                .is_none_or(|(_, b): &(&TrackId, crate::clock::ClockOffsetFit)| {
                    fit.residual_m < b.residual_m
                })
            {
                best = Some((*track, fit));
            }
        }
        let Some((_, seed)) = best else {
            return Err(format!(
                "none of the camera's {} tracks moves with the tag (no clock-offset curve with a \
                 clear minimum, contrast >= {})",
                tracks.len(),
                self.config.min_contrast
            ));
        };
        // The wearer's tracks: those the seed transform puts on the fixes.
        let threshold = self.config.ransac.inlier_threshold_m;
        let mut pooled: Vec<TimedPoint> = Vec::new();
        let mut num_wearer_tracks = 0;
        for (_, points) in tracks {
            let pairs = pairs_at_offset(points, fixes, seed.offset_ns, clock.max_gap_s);
            if pairs.len() < clock.min_pairs {
                continue;
            }
            let mut r: Vec<f64> = pairs
                .iter()
                .map(|(s, t)| (t - seed.target_from_source.apply(s)).norm())
                .collect();
            r.sort_by(f64::total_cmp);
            if percentile_sorted(&r, 0.5) <= threshold {
                num_wearer_tracks += 1;
                pooled.extend(points.iter().copied());
            }
        }
        pooled.sort_by_key(|p| p.t);
        if pooled.is_empty() {
            return Err("the best track's own points do not fit the tag".to_owned());
        }
        let pairs = pairs_at_offset(&pooled, fixes, seed.offset_ns, clock.max_gap_s);
        let (source, target): (Vec<Point3<f64>>, Vec<Point3<f64>>) = pairs.into_iter().unzip();
        let ransac =
            fit_ransac(&source, &target, kind, &self.config.ransac).map_err(|e| e.to_string())?;
        let report = ResidualReport::new(
            &ransac.transform,
            kind,
            &source,
            &target,
            &ransac.inliers,
            &self.config.quality,
        );
        Ok(CameraFit {
            tag: TagId::new(""),
            kind,
            world_from_camera: ransac.transform,
            clock_offset_ns: seed.offset_ns,
            contrast: seed.contrast(),
            report,
            num_wearer_tracks,
            num_candidate_tracks: tracks.len(),
        })
    }
}

/// Horizontal RMS distance of `points` from their mean, m (0 for none).
fn horizontal_rms_spread_m(points: &[TimedPoint]) -> f64 {
    if points.is_empty() {
        return 0.0;
    }
    let n = points.len() as f64;
    let (sx, sy) = points.iter().fold((0.0, 0.0), |(x, y), p| {
        (x + p.position_m.x, y + p.position_m.y)
    });
    let (mx, my) = (sx / n, sy / n);
    let ss: f64 = points
        .iter()
        .map(|p| (p.position_m.x - mx).powi(2) + (p.position_m.y - my).powi(2))
        .sum();
    (ss / n).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
    use nomen_core::skeleton::Joints;
    use nomen_core::{
        Camera, JointObservation, RigidTransform, RtlsFix, SkeletonObservation, Subject, Wearable,
    };
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use rand_distr::StandardNormal;

    const TAG_BEHIND_S: f64 = 0.7;

    fn registry() -> Registry {
        Registry {
            subjects: vec![Subject {
                id: "ana".into(),
                name: None,
                wears: vec![Wearable {
                    device: "tag".into(),
                    kind: DeviceKind::UwbTag,
                    site: Joint::Head,
                    either_side: false,
                    clock: ClockModel::default(),
                }],
            }],
            cameras: vec![Camera::new("counter", RigidTransform::IDENTITY)],
            ..Default::default()
        }
    }

    /// A ceiling counter in 0.0153-m units, z pointing down, turned 35°, moved.
    fn world_from_counter() -> SimilarityTransform {
        SimilarityTransform {
            scale: 0.0153,
            isometry: Isometry3::from_parts(
                Translation3::new(1.2, -0.8, 3.5),
                UnitQuaternion::from_euler_angles(std::f64::consts::PI, 0.0, 35f64.to_radians()),
            ),
        }
    }

    fn head(track: u64, t_s: f64, p_counter: Point3<f64>) -> Message {
        let mut joints = Joints::new();
        joints.insert(Joint::Head, JointObservation::tracked(p_counter));
        Message::from(SkeletonObservation {
            t: SessionTime::from_secs_f64(t_s).unwrap(),
            camera: CameraId::new("counter"),
            track: TrackId(track),
            joints,
        })
    }

    /// `duration_s` of a walker on a 2.5 × 3 m figure of eight (or standing, `walks` false) wearing the tag
    /// (2D fixes at 10 Hz, σ 0.15 m, 5 % NLOS-like outliers, stamped 0.7 s behind) and a
    /// neighbour sitting 3 m away, seen by the counter at 4 Hz (σ 3 cm), in time order.
    fn session(seed: u64, duration_s: f64, walks: bool) -> Vec<Message> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut normal = move || rng.sample::<f64, _>(StandardNormal);
        let counter_from_world = world_from_counter().inverse();
        let walker = |t: f64| {
            if !walks {
                return Point3::new(2.7, 3.0, 1.7);
            }
            // A figure of eight: a time shift is no rotation of the path.
            let a = std::f64::consts::TAU * t / 12.0;
            Point3::new(2.75 + 1.25 * a.cos(), 3.0 + 1.5 * (2.0 * a).sin(), 1.7)
        };
        let mut messages = Vec::new();
        for k in 0..(duration_s * 4.0) as usize {
            let t = k as f64 * 0.25;
            let jitter = |n: &mut dyn FnMut() -> f64| Vector3::new(n(), n(), n()) * 0.03;
            let p = walker(t) + jitter(&mut normal);
            messages.push(head(7, t, counter_from_world.apply(&p)));
            let q = Point3::new(7.0, 3.0, 1.22) + jitter(&mut normal);
            messages.push(head(8, t, counter_from_world.apply(&q)));
        }
        for k in 0..(duration_s * 10.0) as usize {
            let t = 0.05 + k as f64 * 0.1;
            let mut p = walker(t) + Vector3::new(normal(), normal(), 0.0) * 0.15;
            if k % 20 == 3 {
                p.x += 1.0;
            }
            p.z = 0.0;
            messages.push(Message::RtlsFix(RtlsFix {
                t: SessionTime::from_secs_f64(t - TAG_BEHIND_S).unwrap(),
                tag: TagId::new("tag"),
                position_m: p,
                quality: None,
                covariance_m2: None,
            }));
        }
        messages.sort_by_key(Message::t);
        messages
    }

    /// Feeds `messages` and returns the first settled estimate.
    fn first_estimate(messages: &[Message]) -> AutoCalibration {
        let mut c = AutoCalibrator::new(&registry(), AutoCalibrationConfig::default()).unwrap();
        for m in messages {
            c.push(m);
            if let Some(e) = c.poll()
                && c.is_settled()
            {
                return e;
            }
        }
        c.finish().unwrap()
    }

    #[test]
    fn a_counter_in_its_own_units_and_a_2d_tag_on_its_own_clock_are_found_beside_a_sitter() {
        let truth = world_from_counter();
        for seed in 0..3 {
            let e = first_estimate(&session(seed, 70.0, true));
            assert!(e.is_complete(), "seed {seed}: {e:?}");
            // Complete from the first window's first try.
            assert!(e.span_s < 25.0, "seed {seed}: {}", e.span_s);
            let Ok(fit) = &e.cameras[0].outcome else {
                panic!("seed {seed}: {e:?}")
            };
            assert_eq!(fit.kind, FitKind::Similarity);
            assert!(
                (fit.world_from_camera.scale / truth.scale - 1.0).abs() < 0.02,
                "seed {seed}: {}",
                fit.world_from_camera.scale
            );
            let angle = fit.world_from_camera.rotation().angle_to(&truth.rotation());
            assert!(angle < 2f64.to_radians(), "seed {seed}: {angle}");
            // Only the walker's track carries the tag.
            assert_eq!((fit.num_wearer_tracks, fit.num_candidate_tracks), (1, 2));
            // The tag's stamps are 0.7 s behind: session = stamp + 0.7 s (within a frame's
            // interpolation error).
            let Ok((_, clock)) = &e.tags[0].outcome else {
                panic!("seed {seed}: {e:?}")
            };
            let offset_s = clock.offset_ns as f64 * 1e-9;
            assert!(
                (offset_s - TAG_BEHIND_S).abs() < 0.04,
                "seed {seed}: {offset_s}"
            );
            // Horizontal positions are the world's; heights follow the 2D fixes (z = 0).
            let mut calibrated = registry();
            calibrated.apply_calibration(&e.calibration).unwrap();
            let camera = &calibrated.cameras[0];
            let p_world = Point3::new(3.0, 2.0, 1.7);
            let found = camera.to_world(&truth.inverse().apply(&p_world));
            let horizontal = ((found.x - p_world.x).powi(2) + (found.y - p_world.y).powi(2)).sqrt();
            assert!(horizontal < 0.1, "seed {seed}: {found}");
        }
    }

    #[test]
    fn a_tag_that_does_not_move_is_reported_as_too_little_motion() {
        let e = first_estimate(&session(1, 70.0, false));
        assert!(!e.is_complete());
        assert!(e.is_final_try);
        assert!(e.calibration.cameras.is_empty() && e.calibration.devices.is_empty());
        // Final at the end of the first minute.
        assert!((59.0..=61.0).contains(&e.span_s), "{}", e.span_s);
        let Err(why) = &e.cameras[0].outcome else {
            panic!("{e:?}")
        };
        assert!(why.contains("too little motion"), "{why}");
        let Err(why) = &e.tags[0].outcome else {
            panic!("{e:?}")
        };
        assert!(why.contains("too little motion"), "{why}");
    }

    #[test]
    fn refinements_follow_every_30_s_of_data() {
        let messages = session(2, 125.0, true);
        let mut c = AutoCalibrator::new(&registry(), AutoCalibrationConfig::default()).unwrap();
        let mut spans = Vec::new();
        for m in &messages {
            c.push(m);
            if let Some(e) = c.poll() {
                assert!(e.is_complete(), "{e:?}");
                spans.push(e.span_s);
            }
        }
        // 20 s, then 50, 80, 110 s.
        assert_eq!(spans.len(), 4, "{spans:?}");
        for (s, want) in spans.iter().zip([20.0, 50.0, 80.0, 110.0]) {
            assert!((s - want).abs() < 0.5, "{spans:?}");
        }
    }
}
