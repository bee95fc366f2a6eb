//! Configuration of a simulated body-tracking camera, as written in the scenario TOML.

use crate::error::{Result, SimError};
use serde::{Deserialize, Serialize};

/// A simulated body-tracking depth camera (Kinect v2 / Azure Kinect class).
///
/// Defaults describe a Kinect v2 on a tripod; every default is either a data-sheet value or a
/// literature value named in its field's documentation, or says that it is a modelling choice.
/// **No default is fitted**: we have no camera recording yet.
///
/// ```toml
/// [[cameras]]
/// id = "cam0"
/// position_m = [0.0, 0.0, 1.2]
/// look_at_m = [3.0, 0.0, 1.0]
/// [cameras.noise]
/// sigma_base_m = 0.008
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CameraModelConfig {
    /// Camera id used in skeleton messages.
    pub id: String,
    /// Optical centre in the world frame (Z up), m.
    pub position_m: [f64; 3],
    /// A world point on the optical axis; the camera has no roll (its +X stays horizontal).
    /// Must not be straight above or below `position_m`.
    pub look_at_m: [f64; 3],
    /// Full horizontal field of view, rad. Default 70.6° (Kinect v2 depth camera data sheet;
    /// Azure Kinect NFOV unbinned: 75°).
    pub horizontal_fov_rad: f64,
    /// Full vertical field of view, rad. Default 60° (Kinect v2 depth; Azure Kinect NFOV: 65°).
    pub vertical_fov_rad: f64,
    /// Image width used to derive pinhole intrinsics for the registry, px. Default 512 (Kinect
    /// v2 depth image).
    pub image_width_px: u32,
    /// Image height, px. Default 424 (Kinect v2 depth image).
    pub image_height_px: u32,
    /// Nearest depth (camera Z) at which bodies are tracked, m. Default 0.5 (Kinect v2 spec).
    pub min_range_m: f64,
    /// Farthest depth at which bodies are tracked, m. Default 4.5 (Kinect v2 spec; Azure Kinect
    /// NFOV unbinned: 3.86).
    pub max_range_m: f64,
    /// Skeleton rate, Hz. Default 30 (both Kinects).
    pub fps_hz: f64,
    /// Joint position noise.
    pub noise: JointNoiseConfig,
    /// When joints and bodies are hidden.
    pub occlusion: OcclusionConfig,
    /// Track-id behaviour of the SDK.
    pub tracking: TrackingConfig,
    /// A position-only tracker (an overhead people counter) instead of a body-tracking
    /// camera: one point per track, in the tracker's own frame and units. Default absent.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub position_only: Option<PositionOnlyConfig>,
}

/// A position-only tracker: an overhead people counter or centroid tracker that reports one
/// point per track (the top of the head, or the body's centroid) in its own frame and units.
///
/// The sensor sees people as the body-tracking camera does (field of view from `position_m`
/// towards `look_at_m`, occlusion, track ids; an overhead sensor looks almost straight down),
/// then reports only [`PositionOnlyConfig::joint`]'s position, moved into its own frame,
/// `p_tracker = tracker_from_world · p_world`, with `tracker_from_world` the inverse of the
/// similarity `world_from_tracker`: rotate by `rotation_deg_xyz` (about x, then y, then z),
/// scale by `m_per_unit`, move by `origin_m`. The registry knows nothing of this frame (the
/// tracker is registered at the identity, scale 1): finding it is the calibration's work.
///
/// ```toml
/// [cameras.position_only]
/// m_per_unit = 0.0153
/// origin_m = [4.0, 3.0, 3.5]
/// rotation_deg_xyz = [180.0, 0.0, 35.0]
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PositionOnlyConfig {
    /// The joint whose position is reported: `head` (overhead head trackers) or `pelvis`
    /// (centroid trackers). Default `head`.
    pub joint: nomen_core::Joint,
    /// Metres per tracker unit. Default 0.0153 (an overhead people counter in its own units,
    /// as `nomen calibrate frames --similarity` fitted one, issue 66).
    pub m_per_unit: f64,
    /// The tracker frame's origin in the world, m. Default `[0, 0, 0]`.
    pub origin_m: [f64; 3],
    /// The tracker frame's rotation in the world: about x, then y, then z (extrinsic), degrees.
    /// Default `[180, 0, 0]` (a ceiling sensor: z pointing down, away from it).
    pub rotation_deg_xyz: [f64; 3],
    /// Extra error of the reported point per horizontal world axis, m: where the tracker puts
    /// the head or centroid in the blob it segments, on top of the camera's joint noise.
    /// Default 0.03 m: **an assumption** (counter vendors give counting accuracy, not
    /// positional error; a head blob is ~0.2 m across).
    pub point_sigma_m: f64,
    /// Whether the tracker reports a height; without, it reports z = 0 in its frame (a 2D
    /// tracker). Default true.
    pub reports_height: bool,
}

impl Default for PositionOnlyConfig {
    fn default() -> Self {
        Self {
            joint: nomen_core::Joint::Head,
            m_per_unit: 0.0153,
            origin_m: [0.0; 3],
            rotation_deg_xyz: [180.0, 0.0, 0.0],
            point_sigma_m: 0.03,
            reports_height: true,
        }
    }
}

impl PositionOnlyConfig {
    /// `world_from_tracker` as (scale, rotation, translation): `p_world = R · (s · p) + t`.
    pub fn world_from_tracker(&self) -> (f64, nalgebra::Isometry3<f64>) {
        let [rx, ry, rz] = self.rotation_deg_xyz.map(f64::to_radians);
        let rotation = nalgebra::UnitQuaternion::from_euler_angles(rx, ry, rz);
        (
            self.m_per_unit,
            nalgebra::Isometry3::from_parts(
                nalgebra::Translation3::from(nalgebra::Vector3::from(self.origin_m)),
                rotation,
            ),
        )
    }

    /// The world point `p_world` as the tracker reports it (before noise).
    pub fn to_tracker(&self, p_world: &nalgebra::Point3<f64>) -> nalgebra::Point3<f64> {
        let (scale, iso) = self.world_from_tracker();
        let mut p = nalgebra::Point3::from((iso.inverse() * p_world).coords / scale);
        if !self.reports_height {
            p.z = 0.0;
        }
        p
    }

    fn validate(&self) -> std::result::Result<(), String> {
        if !(self.m_per_unit.is_finite() && self.m_per_unit >= 1e-6 && self.m_per_unit <= 1e3) {
            return Err(format!(
                "position_only.m_per_unit must be in [1e-6, 1e3], got {}",
                self.m_per_unit
            ));
        }
        if !self
            .origin_m
            .iter()
            .chain(&self.rotation_deg_xyz)
            .all(|v| v.is_finite())
        {
            return Err("position_only.origin_m/rotation_deg_xyz must be finite".to_owned());
        }
        if !(self.point_sigma_m.is_finite() && (0.0..=10.0).contains(&self.point_sigma_m)) {
            return Err(format!(
                "position_only.point_sigma_m must be in [0, 10] m, got {}",
                self.point_sigma_m
            ));
        }
        Ok(())
    }
}

impl Default for CameraModelConfig {
    fn default() -> Self {
        Self {
            id: "cam0".to_owned(),
            position_m: [0.0, 0.0, 1.2],
            look_at_m: [3.0, 0.0, 1.0],
            horizontal_fov_rad: 70.6_f64.to_radians(),
            vertical_fov_rad: 60.0_f64.to_radians(),
            image_width_px: 512,
            image_height_px: 424,
            min_range_m: 0.5,
            max_range_m: 4.5,
            fps_hz: 30.0,
            noise: JointNoiseConfig::default(),
            occlusion: OcclusionConfig::default(),
            tracking: TrackingConfig::default(),
            position_only: None,
        }
    }
}

/// Joint position error: isotropic Gaussian in the camera frame with standard deviation per
/// axis `σ(z) = sigma_base_m + sigma_per_depth2_m · (z / 1 m)²`, z the joint's depth.
///
/// The quadratic growth follows depth-sensor noise (Khoshelham & Elberink, *Sensors* 12(2), 2012,
/// for structured light; time-of-flight grows more slowly). The magnitudes are **literature
/// order-of-magnitude values, not fitted**: Kinect v2 / Azure Kinect joint positions scatter by
/// about 1 cm near the camera and a few cm at 4 m (Wang et al., "Evaluation of pose tracking
/// accuracy in the first and second generations of Microsoft Kinect", ICHI 2015; Tölgyessy et
/// al., "Evaluation of the Azure Kinect and its comparison to Kinect V1 and Kinect V2",
/// *Sensors* 21(2):413, 2021; Otte et al., *PLoS ONE* 11(11), 2016). The defaults give 0.95 cm at
/// 1 m, 1.4 cm at 2 m, 3.2 cm at 4 m.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct JointNoiseConfig {
    /// σ at zero depth, m. Default 0.008.
    pub sigma_base_m: f64,
    /// Growth of σ with squared depth, m per m². Default 0.0015.
    pub sigma_per_depth2_m: f64,
    /// Correlation time of the noise, s (first-order Gauss–Markov per joint; 0 = white). SDK
    /// skeletons jitter smoothly rather than independently per frame. Default 0 (modelling
    /// choice until a recording is fitted).
    pub correlation_time_s: f64,
    /// σ of an inferred joint relative to a tracked one at the same depth. Default 4 (modelling
    /// choice: Kinect v2 inferred joints are off by several cm, Wang et al. 2015).
    pub inferred_sigma_factor: f64,
    /// Confidence reported for a tracked joint. Default 1 (Kinect `Tracked`).
    pub tracked_confidence: f64,
    /// Confidence reported for an inferred joint. Default 0.5 (Kinect `Inferred`; Azure
    /// `K4ABT_JOINT_CONFIDENCE_LOW` would be 1/3).
    pub inferred_confidence: f64,
}

impl Default for JointNoiseConfig {
    fn default() -> Self {
        Self {
            sigma_base_m: 0.008,
            sigma_per_depth2_m: 0.0015,
            correlation_time_s: 0.0,
            inferred_sigma_factor: 4.0,
            tracked_confidence: 1.0,
            inferred_confidence: 0.5,
        }
    }
}

impl JointNoiseConfig {
    /// σ per axis of a tracked joint at depth `depth_m`, m.
    pub fn sigma_m(&self, depth_m: f64) -> f64 {
        self.sigma_base_m + self.sigma_per_depth2_m * depth_m * depth_m
    }
}

/// When a joint counts as hidden, how long it stays `Inferred`, and when the whole body is lost.
///
/// A joint is *visible* when it is inside the field of view and depth range and the ray from the
/// optical centre to it touches no other person's capsules and no obstacle (and, with
/// `self_occlusion`, not the person's own trunk). All defaults are modelling choices.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OcclusionConfig {
    /// A hidden joint is reported `Inferred` (held in its last seen place relative to the
    /// pelvis, with larger noise) for this long, then `Missing`, s. Default 1.0.
    pub max_inferred_s: f64,
    /// The body is reported only while at least this fraction of its joints is visible and its
    /// pelvis is in the field of view and range. Default 0.5.
    pub min_visible_fraction: f64,
    /// Coarse self-occlusion: the person's own trunk capsules (pelvis → chest → neck) hide
    /// their limb joints (elbows, wrists, hands, knees, ankles, feet), e.g. the far arm of a
    /// person seen in profile. Trunk and head joints are never self-occluded. Default true.
    pub self_occlusion: bool,
}

impl Default for OcclusionConfig {
    fn default() -> Self {
        Self {
            max_inferred_s: 1.0,
            min_visible_fraction: 0.5,
            self_occlusion: true,
        }
    }
}

/// Track-id behaviour of body-tracking SDKs.
///
/// A body must be visible for `new_body_delay_frames` consecutive frames before it is reported
/// with a fresh id. A tracked body lost for at most `keep_id_max_gap_s` (occlusion) keeps its id;
/// a longer loss, or leaving the field of view or range, drops the track, and the body comes
/// back with a new id. Ids start at a random base in `1..=track_id_base_max` and increase by one
/// per new track, in order of depth when several start together, so they never reveal who is
/// who. With `relabel_rate_hz`, a body that stays visible is also dropped now and then and
/// re-detected under a fresh id. Rates are modelling choices: SDKs do not document them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TrackingConfig {
    /// Consecutive visible frames before a new body is reported. Default 5 (SDKs need a few
    /// frames to lock on).
    pub new_body_delay_frames: u32,
    /// Longest occlusion after which a body keeps its id, s. Default 0.5.
    pub keep_id_max_gap_s: f64,
    /// Two tracked bodies are in a close encounter while their pelvises are closer than this
    /// across the line of sight (lateral distance at the nearer one's depth), m. Default 0.4.
    pub swap_distance_m: f64,
    /// Probability that two bodies leave a close encounter with their ids swapped. Default 0.05.
    pub swap_probability: f64,
    /// A person faces away when the angle between their facing direction and the line of sight
    /// from the camera is below this, rad. Default 60°.
    pub facing_away_max_angle_rad: f64,
    /// Rate of left/right flips (joint labels mirrored) of a person facing away, per second of
    /// facing away. Default 0.05 /s.
    pub flip_rate_hz: f64,
    /// Duration of one flip, s (it also ends when the person stops facing away). Default 1.0.
    pub flip_duration_s: f64,
    /// Largest first track id. Default 1000.
    pub track_id_base_max: u64,
    /// Rate at which the SDK drops a tracked, visible body and re-detects it, per second of
    /// tracking (a Poisson process per body): the track ends, the body goes through the
    /// acquisition of a new body (unreported for `new_body_delay_frames` frames) and comes back
    /// under a fresh id from the same counter as every new track. Azure Kinect Body Tracking and
    /// ZED re-identify bodies this way after tracking glitches. Default 0 (never); at most 10 /s.
    /// Drawn from the camera's own stream `camera/<id>/relabel`.
    #[serde(skip_serializing_if = "is_zero")]
    pub relabel_rate_hz: f64,
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

impl Default for TrackingConfig {
    fn default() -> Self {
        Self {
            new_body_delay_frames: 5,
            keep_id_max_gap_s: 0.5,
            swap_distance_m: 0.4,
            swap_probability: 0.05,
            facing_away_max_angle_rad: 60.0_f64.to_radians(),
            flip_rate_hz: 0.05,
            flip_duration_s: 1.0,
            track_id_base_max: 1000,
            relabel_rate_hz: 0.0,
        }
    }
}

impl CameraModelConfig {
    /// Checks every field; the error names the camera and the field.
    pub fn validate(&self) -> Result<()> {
        let bad = |field: &str, why: &str| {
            Err(SimError::InvalidScenario(format!(
                "camera '{}': {field} {why}",
                self.id
            )))
        };
        if self.id.is_empty() {
            return bad("id", "must not be empty");
        }
        if !self
            .position_m
            .iter()
            .chain(&self.look_at_m)
            .all(|v| v.is_finite())
        {
            return bad("position_m/look_at_m", "must be finite");
        }
        let fov_ok = |v: f64| v.is_finite() && v > 0.0 && v < std::f64::consts::PI;
        if !fov_ok(self.horizontal_fov_rad) {
            return bad("horizontal_fov_rad", "must be in (0, π)");
        }
        if !fov_ok(self.vertical_fov_rad) {
            return bad("vertical_fov_rad", "must be in (0, π)");
        }
        if self.image_width_px == 0 || self.image_height_px == 0 {
            return bad("image_width_px/image_height_px", "must be positive");
        }
        if !(self.min_range_m.is_finite()
            && self.min_range_m > 0.0
            && self.max_range_m.is_finite()
            && self.max_range_m > self.min_range_m)
        {
            return bad("min_range_m/max_range_m", "must satisfy 0 < min < max");
        }
        if !(self.fps_hz.is_finite() && self.fps_hz > 0.0 && self.fps_hz <= 1000.0) {
            return bad("fps_hz", "must be in (0, 1000]");
        }
        let n = &self.noise;
        let nonneg = |v: f64| v.is_finite() && v >= 0.0;
        let unit = |v: f64| (0.0..=1.0).contains(&v);
        if !(nonneg(n.sigma_base_m)
            && nonneg(n.sigma_per_depth2_m)
            && nonneg(n.correlation_time_s)
            && nonneg(n.inferred_sigma_factor))
        {
            return bad(
                "noise.*",
                "sigmas, factor and correlation time must be finite and >= 0",
            );
        }
        if !(unit(n.tracked_confidence) && unit(n.inferred_confidence)) {
            return bad("noise.*_confidence", "must be in [0, 1]");
        }
        let o = &self.occlusion;
        if !nonneg(o.max_inferred_s) {
            return bad("occlusion.max_inferred_s", "must be finite and >= 0");
        }
        if !unit(o.min_visible_fraction) {
            return bad("occlusion.min_visible_fraction", "must be in [0, 1]");
        }
        let t = &self.tracking;
        if !(nonneg(t.keep_id_max_gap_s)
            && nonneg(t.swap_distance_m)
            && nonneg(t.flip_rate_hz)
            && nonneg(t.flip_duration_s)
            && nonneg(t.facing_away_max_angle_rad))
        {
            return bad(
                "tracking.*",
                "durations, distances, rates and angles must be >= 0",
            );
        }
        if !unit(t.swap_probability) {
            return bad("tracking.swap_probability", "must be in [0, 1]");
        }
        if !(t.relabel_rate_hz.is_finite() && (0.0..=10.0).contains(&t.relabel_rate_hz)) {
            return bad(
                "tracking.relabel_rate_hz",
                &format!("must be in [0, 10] /s, got {}", t.relabel_rate_hz),
            );
        }
        if t.track_id_base_max == 0 || t.track_id_base_max > u64::MAX / 2 {
            return bad("tracking.track_id_base_max", "must be in [1, 2^63)");
        }
        if let Some(p) = &self.position_only
            && let Err(why) = p.validate()
        {
            return Err(SimError::InvalidScenario(format!(
                "camera '{}': {why}",
                self.id
            )));
        }
        Ok(())
    }
}
