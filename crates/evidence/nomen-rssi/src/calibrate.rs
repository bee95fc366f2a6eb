//! Llorca's automatic calibration: while one tagged person is the only person the cameras
//! track, every RSSI read of the tag is paired with that person's position at the read time,
//! and every antenna's model is fitted to the pairs.
//!
//! - The person's position at a read is interpolated linearly between the two camera frames
//!   around it (at most [`CalibrationConfig::max_frame_gap_s`] apart); reads outside the
//!   tracked spans are left out and counted.
//! - Frames with more than one skeleton are ambiguous (whose tag is it?) and are not used; the
//!   report counts them and warns.
//! - The tag's position on the person follows [`TagPlacement`]: the pelvis x, y at a fixed
//!   height (Llorca), or the joint the registry names as the tag's site.
//! - When the recording has reads from several tags, the most-read tag is calibrated (or the one
//!   named in the configuration) and the others are counted.

use crate::error::{Result, RssiError};
use crate::fit::{AntennaFit, FitConfig, Sample, fit_antenna};
use crate::model::{ModelKind, RssiModel, TagPlacement};
use crate::read::{RssiUnit, checked_rssi_dbm};
use nalgebra::Point3;
use nomen_core::{
    CameraId, Joint, JointState, Message, Registry, SessionTime, SkeletonObservation, TagId,
};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Settings of [`calibrate`]. Plain data, loadable from TOML.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CalibrationConfig {
    /// The model to fit.
    pub model: ModelKind,
    /// Where the tag is on the person.
    pub placement: TagPlacement,
    /// The tag to calibrate; `None`: the most-read tag.
    pub tag: Option<TagId>,
    /// Longest gap between the two frames a read is interpolated between, s. Default 0.2 s
    /// (five frames at 25 Hz).
    pub max_frame_gap_s: f64,
    /// Unit of the RSSI values in the recording.
    pub rssi_unit: RssiUnit,
    /// The per-antenna fit.
    pub fit: FitConfig,
}

impl Default for CalibrationConfig {
    fn default() -> Self {
        Self {
            model: ModelKind::Standard,
            placement: TagPlacement::default(),
            tag: None,
            max_frame_gap_s: 0.2,
            rssi_unit: RssiUnit::Dbm,
            fit: FitConfig::default(),
        }
    }
}

/// A read paired with the tagged person's position.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CalibrationPair {
    /// Read time.
    pub t: SessionTime,
    /// Index of the antenna in the registry.
    pub antenna_index: usize,
    /// The sample (position and dBm).
    pub sample: Sample,
}

/// What calibration produced: the model, per-antenna fits and what it could not use.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CalibrationReport {
    /// The model to save and load for association.
    pub model: RssiModel,
    /// The tag that was calibrated.
    pub tag: TagId,
    /// One fit per registry antenna that heard the tag, in registry order.
    pub per_antenna: Vec<AntennaFit>,
    /// Reads of the calibrated tag.
    pub num_reads: usize,
    /// Reads paired with a position.
    pub num_paired: usize,
    /// Reads with no bracketing frames (the person was not tracked then).
    pub num_unpaired: usize,
    /// Reads rejected as invalid (NaN, implausible dBm, unknown antenna).
    pub num_invalid: usize,
    /// Reads of other tags, ignored.
    pub num_other_tag_reads: usize,
    /// Camera frames with more than one skeleton (not used).
    pub num_ambiguous_frames: usize,
    /// Camera frames with exactly one skeleton.
    pub num_single_frames: usize,
    /// Everything the data do not constrain or that was left out, in words.
    pub warnings: Vec<String>,
}

/// The reference point of a skeleton in the world frame under `placement`: the pelvis (else the
/// centroid of the observed joints) at a fixed height, or the site joint (else that fallback).
pub fn tag_position(
    registry: &Registry,
    skeleton: &SkeletonObservation,
    placement: TagPlacement,
    site: Option<Joint>,
) -> Option<Point3<f64>> {
    let camera = registry.camera(&skeleton.camera)?;
    let world = |j: Joint| {
        skeleton
            .joints
            .get(j)
            .filter(|o| {
                o.state != JointState::Missing && o.position_m.iter().all(|v| v.is_finite())
            })
            .map(|o| camera.world_from_camera.apply(&o.position_m))
    };
    let centroid = || {
        let mut sum = nalgebra::Vector3::zeros();
        let mut n = 0usize;
        for (_, o) in skeleton.joints.iter() {
            if o.state != JointState::Missing && o.position_m.iter().all(|v| v.is_finite()) {
                sum += camera.world_from_camera.apply(&o.position_m).coords;
                n += 1;
            }
        }
        (n > 0).then(|| Point3::from(sum / n as f64))
    };
    let ground = || world(Joint::Pelvis).or_else(centroid);
    match placement {
        TagPlacement::FixedHeight(h) => ground().map(|p| Point3::new(p.x, p.y, h)),
        TagPlacement::RegistrySite => site.and_then(world).or_else(ground),
    }
}

/// The site joint of `tag` in the registry, if registered.
pub fn tag_site(registry: &Registry, tag: &TagId) -> Option<Joint> {
    registry.wearer(tag).map(|(_, w)| w.site)
}

/// Highest fixed tag height accepted, m (a tag on a person, or on a pole near one).
const MAX_TAG_HEIGHT_M: f64 = 5.0;

/// Pairs reads with the single tracked person's position and fits every antenna.
///
/// `messages` in time order (per camera at least); `source_name` names the recording in errors.
pub fn calibrate(
    registry: &Registry,
    messages: &[Message],
    config: &CalibrationConfig,
    source_name: &str,
) -> Result<CalibrationReport> {
    config.fit.validate()?;
    if let TagPlacement::FixedHeight(h) = config.placement
        && !(h.is_finite() && (0.0..=MAX_TAG_HEIGHT_M).contains(&h))
    {
        return Err(RssiError::InvalidConfig(format!(
            "tag height {h} m: a height above the floor, 0 to {MAX_TAG_HEIGHT_M} m"
        )));
    }
    if !(config.max_frame_gap_s.is_finite() && config.max_frame_gap_s > 0.0) {
        return Err(RssiError::InvalidConfig(format!(
            "max_frame_gap_s = {} must be positive",
            config.max_frame_gap_s
        )));
    }
    if registry.antennas.is_empty() {
        return Err(RssiError::InsufficientData {
            source_name: source_name.to_owned(),
            reason: "the registry lists no antenna".into(),
        });
    }
    // Which tag: the configured one, else the most-read one.
    let mut counts: BTreeMap<&TagId, usize> = BTreeMap::new();
    for m in messages {
        if let Message::Rssi(r) = m {
            *counts.entry(&r.tag).or_default() += 1;
        }
    }
    let tag = match &config.tag {
        Some(t) => t.clone(),
        None => counts
            .iter()
            .max_by_key(|(t, n)| (**n, std::cmp::Reverse(**t)))
            .map(|(t, _)| (*t).clone())
            .ok_or_else(|| RssiError::InsufficientData {
                source_name: source_name.to_owned(),
                reason: "no rssi reads".into(),
            })?,
    };
    let site = tag_site(registry, &tag);
    let mut warnings = Vec::new();
    if counts.len() > 1 {
        warnings.push(format!(
            "{} tags were heard; calibrated {tag} and ignored the others",
            counts.len()
        ));
    }

    // Frames per camera: (t, Some(position)) for single-skeleton frames, (t, None) otherwise.
    let mut frames: BTreeMap<&CameraId, BTreeMap<SessionTime, Vec<&SkeletonObservation>>> =
        BTreeMap::new();
    for m in messages {
        if let Message::Skeleton(s) = m {
            frames
                .entry(&s.camera)
                .or_default()
                .entry(s.t)
                .or_default()
                .push(s);
        }
    }
    let mut num_single = 0usize;
    let mut num_ambiguous = 0usize;
    let mut tracks: Vec<Vec<(SessionTime, Option<Point3<f64>>)>> = Vec::new();
    for per_t in frames.values() {
        let mut seq = Vec::with_capacity(per_t.len());
        for (t, skels) in per_t {
            if skels.len() == 1 {
                num_single += 1;
                let p = skels
                    .first()
                    .and_then(|s| tag_position(registry, s, config.placement, site));
                seq.push((*t, p));
            } else {
                num_ambiguous += 1;
                seq.push((*t, None));
            }
        }
        tracks.push(seq);
    }
    if num_ambiguous > 0 {
        warnings.push(format!(
            "{num_ambiguous} camera frames show more than one person and were not used (calibration needs the tagged person alone)"
        ));
    }
    let max_gap_ns = (config.max_frame_gap_s * 1e9) as i64;
    let position_at = |t: SessionTime| -> Option<Point3<f64>> {
        let mut sum = nalgebra::Vector3::zeros();
        let mut n = 0usize;
        for seq in &tracks {
            let i = seq.partition_point(|(ft, _)| *ft <= t);
            let Some(&(ta, Some(pa))) = i.checked_sub(1).and_then(|k| seq.get(k)) else {
                continue;
            };
            let (pb, w) = if ta == t {
                (pa, 0.0)
            } else {
                let Some(&(tb, Some(pb))) = seq.get(i) else {
                    continue;
                };
                let gap = tb - ta;
                if gap > max_gap_ns || gap <= 0 {
                    continue;
                }
                (pb, (t - ta) as f64 / gap as f64)
            };
            sum += pa.coords + (pb.coords - pa.coords) * w;
            n += 1;
        }
        (n > 0).then(|| Point3::from(sum / n as f64))
    };

    let mut per_antenna: Vec<Vec<Sample>> = vec![Vec::new(); registry.antennas.len()];
    let mut num_reads = 0usize;
    let mut num_paired = 0usize;
    let mut num_unpaired = 0usize;
    let mut num_invalid = 0usize;
    let mut num_other = 0usize;
    let mut first_invalid: Option<String> = None;
    for m in messages {
        let Message::Rssi(r) = m else { continue };
        if r.tag != tag {
            num_other += 1;
            continue;
        }
        num_reads += 1;
        let rssi = match checked_rssi_dbm(r, config.rssi_unit) {
            Ok(v) => v,
            Err(e) => {
                num_invalid += 1;
                first_invalid.get_or_insert_with(|| e.to_string());
                continue;
            }
        };
        let Some(k) = registry.antennas.iter().position(|a| a.id == r.antenna) else {
            num_invalid += 1;
            first_invalid.get_or_insert_with(|| {
                RssiError::UnknownAntenna {
                    tag: r.tag.to_string(),
                    antenna: r.antenna.to_string(),
                    t_s: r.t.as_secs_f64(),
                    what: "registry",
                }
                .to_string()
            });
            continue;
        };
        match position_at(r.t) {
            Some(p) => {
                num_paired += 1;
                if let Some(v) = per_antenna.get_mut(k) {
                    v.push(Sample {
                        tag_position_m: p,
                        rssi_dbm: rssi,
                    });
                }
            }
            None => num_unpaired += 1,
        }
    }
    if let Some(first) = first_invalid {
        warnings.push(format!(
            "{num_invalid} invalid reads skipped (first: {first})"
        ));
    }
    if num_unpaired > 0 {
        warnings.push(format!(
            "{num_unpaired} of {num_reads} reads fell outside the spans where exactly one person was tracked"
        ));
    }
    let mut fits = Vec::new();
    for (antenna, samples) in registry.antennas.iter().zip(&per_antenna) {
        match fit_antenna(antenna, config.model, samples, &config.fit) {
            Ok(f) => {
                warnings.extend(f.warnings.iter().cloned());
                fits.push(f);
            }
            Err(e) => {
                return Err(RssiError::InsufficientData {
                    source_name: source_name.to_owned(),
                    reason: format!("tag {tag}: {e}"),
                });
            }
        }
    }
    let model = RssiModel {
        kind: config.model,
        placement: config.placement,
        antennas: fits.iter().map(|f| f.model.clone()).collect(),
    };
    model.validate()?;
    Ok(CalibrationReport {
        model,
        tag,
        per_antenna: fits,
        num_reads,
        num_paired,
        num_unpaired,
        num_invalid,
        num_other_tag_reads: num_other,
        num_ambiguous_frames: num_ambiguous,
        num_single_frames: num_single,
        warnings,
    })
}

impl std::fmt::Display for CalibrationReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "rssi calibration of tag {} ({} model): {} reads, {} paired with the tracked person, {} unpaired, {} invalid; {} single-person frames, {} ambiguous",
            self.tag,
            self.model.kind,
            self.num_reads,
            self.num_paired,
            self.num_unpaired,
            self.num_invalid,
            self.num_single_frames,
            self.num_ambiguous_frames
        )?;
        writeln!(
            f,
            "{:<10} {:>6} {:>15} {:>17} {:>14} {:>9} {:>13} {:>13} {:>10}",
            "antenna",
            "reads",
            "P1 dBm",
            "K dB/decade",
            "K2 dB/rad",
            "σ dB",
            "σ(D,θ) dB",
            "D m",
            "|ΔD| m"
        )?;
        for a in &self.per_antenna {
            let m = &a.model;
            let k2 = match a.k2_std_err_db_per_rad {
                Some(se) => format!("{:.2} ± {:.2}", m.k2_db_per_rad, se),
                None => "-".into(),
            };
            writeln!(
                f,
                "{:<10} {:>6} {:>15} {:>17} {:>14} {:>9} {:>13} {:>13} {:>10.2}",
                m.antenna.to_string(),
                a.num_reads,
                format!("{:.1} ± {:.1}", m.p1_dbm, a.p1_std_err_db),
                format!(
                    "{:.1} ± {:.1}",
                    m.k_db_per_decade, a.k_std_err_db_per_decade
                ),
                k2,
                format!("{:.2}", a.residual_std_db),
                format!("{:.1}–{:.1}", m.noise.sigma_min_db, m.noise.sigma_max_db),
                format!("{:.1}–{:.1}", a.distance_range_m[0], a.distance_range_m[1]),
                a.median_distance_error_m
            )?;
        }
        for w in &self.warnings {
            writeln!(f, "warning: {w}")?;
        }
        Ok(())
    }
}
