//! The registry: who exists, what they wear and where, and where the fixed infrastructure is.

use crate::error::{CoreError, Result, check_finite_all_lazy, check_range_lazy};
use crate::frame::RigidTransform;
use crate::ids::{AnchorId, AntennaId, CameraId, DeviceId, SubjectId};
use crate::skeleton::Joint;
use crate::time::ClockModel;
use nalgebra::{Point3, Vector3};
use serde::{Deserialize, Serialize};
use std::collections::BTreeSet;

/// What kind of wearable a device is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DeviceKind {
    /// An inertial measurement unit (band, watch, body-area-network node).
    Imu,
    /// A UWB (or other RTLS) location tag that yields position fixes or ranges.
    UwbTag,
    /// A passive UHF RFID tag read by reader antennas.
    RfidTag,
    /// A BLE beacon heard by BLE anchors (RSSI).
    BleTag,
}

/// A device worn by a subject at a body site.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Wearable {
    /// The device.
    pub device: DeviceId,
    /// Its kind.
    pub kind: DeviceKind,
    /// The canonical joint nearest to where it is worn (the *key joint* for a location tag).
    pub site: Joint,
    /// The IMU may be worn on `site`'s mirror image instead: a watch or band on a wrist
    /// nobody noted. The engine then compares it with both sides and keeps the one that fits.
    /// Only for an IMU at a joint with a left and a right (`left_wrist`, `right_ankle`, …).
    /// Default false.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub either_side: bool,
    /// How the device clock maps to the session clock (estimated; zero if unknown).
    #[serde(default)]
    pub clock: ClockModel,
}

/// A person known to the system.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Subject {
    /// Stable id (what nomen names skeletons with).
    pub id: SubjectId,
    /// Human-readable name, optional.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Devices the subject wears; may be empty (a known person without wearables).
    #[serde(default)]
    pub wears: Vec<Wearable>,
}

/// Pinhole intrinsics of a camera.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CameraIntrinsics {
    /// Image width, pixels.
    pub width_px: u32,
    /// Image height, pixels.
    pub height_px: u32,
    /// Focal length along x, pixels.
    pub fx_px: f64,
    /// Focal length along y, pixels.
    pub fy_px: f64,
    /// Principal point x, pixels.
    pub cx_px: f64,
    /// Principal point y, pixels.
    pub cy_px: f64,
}

/// A camera (or a calibrated multi-camera system) that reports skeletons.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Camera {
    /// The camera id used by skeleton messages.
    pub id: CameraId,
    /// The camera's pose: maps camera-frame points, once multiplied by `scale`, into the world
    /// frame.
    #[serde(default)]
    pub world_from_camera: RigidTransform,
    /// Metres per camera-frame unit: a camera point `p` is `world_from_camera * (scale · p)` in
    /// the world (a similarity; a tracker reporting in its own units, such as an overhead people
    /// counter, has the scale `nomen calibrate frames --similarity` finds). Default 1; within
    /// [`CAMERA_SCALE_RANGE`].
    #[serde(default = "unit_scale", skip_serializing_if = "is_unit_scale")]
    pub scale: f64,
    /// Pinhole intrinsics, if known.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub intrinsics: Option<CameraIntrinsics>,
    /// Nominal skeleton rate, Hz, if known.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fps_hz: Option<f64>,
    /// How the camera clock maps to the session clock: its messages' `t` is camera time,
    /// `session = t + offset_ns` (plus drift).
    #[serde(default)]
    pub clock: ClockModel,
}

/// The default [`Camera::scale`]: camera frames in metres.
fn unit_scale() -> f64 {
    1.0
}

fn is_unit_scale(scale: &f64) -> bool {
    *scale == 1.0
}

impl Camera {
    /// A camera at `world_from_camera`, in metres (scale 1), on the session clock.
    pub fn new(id: impl Into<CameraId>, world_from_camera: RigidTransform) -> Self {
        Camera {
            id: id.into(),
            world_from_camera,
            scale: 1.0,
            intrinsics: None,
            fps_hz: None,
            clock: ClockModel::default(),
        }
    }

    /// A camera-frame point in the world frame: `world_from_camera * (scale · p)`.
    pub fn to_world(&self, p_camera: &Point3<f64>) -> Point3<f64> {
        self.world_from_camera.to_isometry() * Point3::from(p_camera.coords * self.scale)
    }
}

/// A fixed UWB anchor.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Anchor {
    /// Anchor id used by range messages.
    pub id: AnchorId,
    /// Position in the world frame, metres.
    pub position_m: Point3<f64>,
}

/// A fixed RSSI antenna.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Antenna {
    /// Antenna id used by RSSI messages.
    pub id: AntennaId,
    /// Position in the world frame, metres.
    pub position_m: Point3<f64>,
    /// Boresight direction in the world frame (need not be normalised); `None` for an
    /// omnidirectional antenna.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub boresight: Option<Vector3<f64>>,
}

/// Everything static a session knows: subjects and their wearables, cameras, anchors, antennas.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Registry {
    /// Known people.
    #[serde(default)]
    pub subjects: Vec<Subject>,
    /// Cameras.
    #[serde(default)]
    pub cameras: Vec<Camera>,
    /// UWB anchors.
    #[serde(default)]
    pub anchors: Vec<Anchor>,
    /// RSSI antennas.
    #[serde(default)]
    pub antennas: Vec<Antenna>,
}

impl Registry {
    /// Checks ids are unique, numbers finite, and every device is worn by one subject only.
    pub fn validate(&self) -> Result<()> {
        let mut subjects = BTreeSet::new();
        let mut devices = BTreeSet::new();
        for s in &self.subjects {
            check_id("subject", s.id.as_str())?;
            if !subjects.insert(&s.id) {
                return Err(CoreError::Invalid(format!(
                    "subject '{}' is listed twice",
                    s.id
                )));
            }
            for w in &s.wears {
                check_id("device", w.device.as_str())?;
                if !devices.insert(&w.device) {
                    return Err(CoreError::Invalid(format!(
                        "device '{}' is worn twice (second time by subject '{}')",
                        w.device, s.id
                    )));
                }
                check_clock(&w.clock, || format!("device '{}'", w.device))?;
                if w.either_side && w.kind != DeviceKind::Imu {
                    return Err(CoreError::Invalid(format!(
                        "device '{}': either_side is for IMUs only",
                        w.device
                    )));
                }
                if w.either_side && w.site.mirrored() == w.site {
                    return Err(CoreError::Invalid(format!(
                        "device '{}': either_side needs a site with a left and a right (such as left_wrist), not '{}'",
                        w.device, w.site
                    )));
                }
            }
        }
        let mut cameras = BTreeSet::new();
        for c in &self.cameras {
            check_id("camera", c.id.as_str())?;
            if !cameras.insert(&c.id) {
                return Err(CoreError::Invalid(format!(
                    "camera '{}' is listed twice",
                    c.id
                )));
            }
            c.world_from_camera
                .validate(&format!("camera '{}'.world_from_camera", c.id))?;
            let (lo, hi) = CAMERA_SCALE_RANGE;
            check_range_lazy(
                || format!("camera '{}'.scale", c.id),
                c.scale,
                lo,
                hi,
                "m per unit",
            )?;
            check_clock(&c.clock, || format!("camera '{}'", c.id))?;
            if let Some(fps) = c.fps_hz {
                let (lo, hi) = CAMERA_FPS_RANGE_HZ;
                check_range_lazy(|| format!("camera '{}'.fps_hz", c.id), fps, lo, hi, "Hz")?;
            }
            if let Some(k) = &c.intrinsics {
                check_finite_all_lazy(
                    || format!("camera '{}'.intrinsics", c.id),
                    &[k.fx_px, k.fy_px, k.cx_px, k.cy_px],
                )?;
                if k.fx_px <= 0.0 || k.fy_px <= 0.0 {
                    return Err(CoreError::Invalid(format!(
                        "camera '{}' has a non-positive focal length",
                        c.id
                    )));
                }
            }
        }
        let mut anchors = BTreeSet::new();
        for a in &self.anchors {
            check_id("anchor", a.id.as_str())?;
            if !anchors.insert(&a.id) {
                return Err(CoreError::Invalid(format!(
                    "anchor '{}' is listed twice",
                    a.id
                )));
            }
            check_finite_all_lazy(
                || format!("anchor '{}'.position_m", a.id),
                a.position_m.coords.as_slice(),
            )?;
        }
        let mut antennas = BTreeSet::new();
        for a in &self.antennas {
            check_id("antenna", a.id.as_str())?;
            if !antennas.insert(&a.id) {
                return Err(CoreError::Invalid(format!(
                    "antenna '{}' is listed twice",
                    a.id
                )));
            }
            check_finite_all_lazy(
                || format!("antenna '{}'.position_m", a.id),
                a.position_m.coords.as_slice(),
            )?;
            if let Some(b) = &a.boresight {
                check_finite_all_lazy(|| format!("antenna '{}'.boresight", a.id), b.as_slice())?;
                if b.norm() < 1e-9 {
                    return Err(CoreError::Invalid(format!(
                        "antenna '{}' has a zero boresight",
                        a.id
                    )));
                }
            }
        }
        Ok(())
    }

    /// The subject wearing `device`, and how.
    pub fn wearer(&self, device: &DeviceId) -> Option<(&Subject, &Wearable)> {
        self.subjects
            .iter()
            .find_map(|s| s.wears.iter().find(|w| &w.device == device).map(|w| (s, w)))
    }

    /// The subject with id `id`.
    pub fn subject(&self, id: &SubjectId) -> Option<&Subject> {
        self.subjects.iter().find(|s| &s.id == id)
    }

    /// The camera with id `id`.
    pub fn camera(&self, id: &CameraId) -> Option<&Camera> {
        self.cameras.iter().find(|c| &c.id == id)
    }

    /// Whether an anchor with this id is registered.
    pub fn has_anchor(&self, id: &AnchorId) -> bool {
        self.anchors.iter().any(|a| &a.id == id)
    }

    /// Whether an antenna with this id is registered.
    pub fn has_antenna(&self, id: &AntennaId) -> bool {
        self.antennas.iter().any(|a| &a.id == id)
    }
}

/// What a calibration found, laid over a registry ([`Registry::apply_calibration`]): camera
/// poses, scales and clocks, and device clocks. Each field given replaces the registry's; a
/// field left out keeps it. `nomen calibrate frames --out` writes one and `nomen run
/// --calibration` applies it.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Calibration {
    /// Cameras, by id.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub cameras: Vec<CameraCalibration>,
    /// Worn devices (IMUs, tags), by id.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub devices: Vec<DeviceCalibration>,
}

/// A camera's part of a [`Calibration`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraCalibration {
    /// The registered camera.
    pub id: CameraId,
    /// Replaces [`Camera::world_from_camera`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub world_from_camera: Option<RigidTransform>,
    /// Replaces [`Camera::scale`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scale: Option<f64>,
    /// Replaces [`Camera::clock`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub clock: Option<ClockModel>,
}

/// A worn device's part of a [`Calibration`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DeviceCalibration {
    /// The registered device.
    pub device: DeviceId,
    /// Replaces [`Wearable::clock`].
    pub clock: ClockModel,
}

impl Registry {
    /// Lays `calibration` over the registry: every camera and device it names must be
    /// registered, and the result must validate ([`Registry::validate`]); on an error the
    /// registry is left as it was.
    pub fn apply_calibration(&mut self, calibration: &Calibration) -> Result<()> {
        let mut out = self.clone();
        for c in &calibration.cameras {
            let Some(camera) = out.cameras.iter_mut().find(|k| k.id == c.id) else {
                return Err(CoreError::Invalid(format!(
                    "the calibration has camera '{}', which the registry does not list",
                    c.id
                )));
            };
            if let Some(t) = c.world_from_camera {
                camera.world_from_camera = t;
            }
            if let Some(scale) = c.scale {
                camera.scale = scale;
            }
            if let Some(clock) = c.clock {
                camera.clock = clock;
            }
        }
        for d in &calibration.devices {
            let Some(w) = out
                .subjects
                .iter_mut()
                .flat_map(|s| s.wears.iter_mut())
                .find(|w| w.device == d.device)
            else {
                return Err(CoreError::Invalid(format!(
                    "the calibration has device '{}', which no subject of the registry wears",
                    d.device
                )));
            };
            w.clock = d.clock;
        }
        out.validate()?;
        *self = out;
        Ok(())
    }
}

/// Largest clock offset a registry may give, ns: 2⁶² ns, about 146 years, so a device that
/// stamps Unix-epoch time still fits, and sums of an offset with a session time or a lag cannot
/// overflow.
const MAX_CLOCK_OFFSET_NS: i64 = 1 << 62;

/// The scales a camera may have, metres per camera-frame unit (inclusive): from micrometres to
/// kilometres per unit. Zero or a negative scale is no similarity.
pub const CAMERA_SCALE_RANGE: (f64, f64) = (1e-6, 1e3);

/// The frame rates a camera may have, Hz (inclusive).
pub const CAMERA_FPS_RANGE_HZ: (f64, f64) = (0.1, 10_000.0);

/// Refuses a clock offset beyond [`MAX_CLOCK_OFFSET_NS`], naming its owner.
fn check_clock(clock: &ClockModel, owner: impl Fn() -> String) -> Result<()> {
    if clock.offset_ns.unsigned_abs() > MAX_CLOCK_OFFSET_NS.unsigned_abs() {
        return Err(CoreError::Invalid(format!(
            "clock of {}: offset_ns = {} is beyond ±2^62 ns (146 years)",
            owner(),
            clock.offset_ns
        )));
    }
    check_range_lazy(
        || format!("clock of {}: drift_ppm", owner()),
        clock.drift_ppm,
        -MAX_DRIFT_PPM,
        MAX_DRIFT_PPM,
        "ppm",
    )
}

/// Largest clock drift accepted, ppm: 1 %, a hundred times a cheap crystal's.
const MAX_DRIFT_PPM: f64 = 10_000.0;

/// An id must name something: an empty one cannot be told apart in a log or a table.
fn check_id(kind: &str, id: &str) -> Result<()> {
    if id.trim().is_empty() {
        return Err(CoreError::Invalid(format!(
            "a {kind} id is empty (or only spaces)"
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wearable(id: &str) -> Wearable {
        Wearable {
            device: DeviceId::new(id),
            kind: DeviceKind::Imu,
            site: Joint::LeftWrist,
            either_side: false,
            clock: ClockModel::default(),
        }
    }

    #[test]
    fn an_absurd_clock_offset_is_refused_by_name() {
        let mut imu = wearable("imu1");
        imu.clock.offset_ns = i64::MIN;
        let reg = Registry {
            subjects: vec![Subject {
                id: "ana".into(),
                name: None,
                wears: vec![imu.clone()],
            }],
            ..Default::default()
        };
        let err = reg.validate().unwrap_err().to_string();
        assert!(err.contains("imu1") && err.contains("offset_ns"), "{err}");
        // A Unix-epoch device clock (about −1.8e18 ns from a session starting now) is fine.
        imu.clock.offset_ns = -1_800_000_000_000_000_000;
        let reg = Registry {
            subjects: vec![Subject {
                id: "ana".into(),
                name: None,
                wears: vec![imu],
            }],
            ..Default::default()
        };
        assert!(reg.validate().is_ok());
    }

    #[test]
    fn an_empty_id_and_an_absurd_drift_are_refused_by_name() {
        let reg = |device: &str, drift_ppm: f64| {
            let mut imu = wearable(device);
            imu.clock.drift_ppm = drift_ppm;
            Registry {
                subjects: vec![Subject {
                    id: "ana".into(),
                    name: None,
                    wears: vec![imu],
                }],
                ..Default::default()
            }
        };
        assert!(reg("imu1", 50.0).validate().is_ok());
        let err = reg("", 0.0).validate().unwrap_err().to_string();
        assert!(err.contains("device id is empty"), "{err}");
        let err = reg("imu1", 1e300).validate().unwrap_err().to_string();
        assert!(err.contains("imu1") && err.contains("drift_ppm"), "{err}");
        let err = reg("imu1", f64::NAN).validate().unwrap_err().to_string();
        assert!(err.contains("drift_ppm"), "{err}");
    }

    #[test]
    fn either_side_is_for_an_imu_at_a_joint_with_a_left_and_a_right() {
        let reg = |w: Wearable| Registry {
            subjects: vec![Subject {
                id: "ana".into(),
                name: None,
                wears: vec![w],
            }],
            ..Default::default()
        };
        let mut watch = wearable("watch");
        watch.either_side = true;
        assert!(reg(watch.clone()).validate().is_ok());
        // Written only when set, and read back.
        let text = serde_json::to_string(&watch).unwrap();
        assert!(text.contains("\"either_side\":true"), "{text}");
        assert_eq!(serde_json::from_str::<Wearable>(&text).unwrap(), watch);
        let plain = wearable("band");
        let text = serde_json::to_string(&plain).unwrap();
        assert!(!text.contains("either_side"), "{text}");
        assert!(!serde_json::from_str::<Wearable>(&text).unwrap().either_side);
        // Not at a midline joint, and not for a location tag.
        let mut belt = watch.clone();
        belt.site = Joint::Pelvis;
        let err = reg(belt).validate().unwrap_err().to_string();
        assert!(err.contains("'watch'") && err.contains("pelvis"), "{err}");
        let mut tag = watch;
        tag.kind = DeviceKind::UwbTag;
        let err = reg(tag).validate().unwrap_err().to_string();
        assert!(
            err.contains("'watch'") && err.contains("IMUs only"),
            "{err}"
        );
    }

    #[test]
    fn a_camera_scale_defaults_to_one_and_must_be_positive() {
        let camera: Camera = serde_json::from_str(r#"{"id":"counter"}"#).unwrap();
        assert_eq!(camera.scale, 1.0);
        // Written only when it is not 1, so registries without one keep their bytes.
        assert!(!serde_json::to_string(&camera).unwrap().contains("scale"));
        let reg = |scale: f64| Registry {
            cameras: vec![Camera {
                scale,
                ..Camera::new("counter", RigidTransform::IDENTITY)
            }],
            ..Default::default()
        };
        assert!(reg(0.0153).validate().is_ok());
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let err = reg(bad).validate().unwrap_err().to_string();
            assert!(err.contains("camera 'counter'.scale"), "{err}");
        }
    }

    #[test]
    fn a_scaled_camera_point_is_scaled_then_moved() {
        let mut camera = Camera::new(
            "counter",
            RigidTransform {
                // 90° about z.
                rotation_wxyz: [
                    std::f64::consts::FRAC_1_SQRT_2,
                    0.0,
                    0.0,
                    std::f64::consts::FRAC_1_SQRT_2,
                ],
                translation_m: [1.0, 2.0, 0.0],
            },
        );
        camera.scale = 0.01;
        let p = camera.to_world(&Point3::new(100.0, 0.0, 170.0));
        assert!((p - Point3::new(1.0, 3.0, 1.7)).norm() < 1e-12, "{p}");
    }

    #[test]
    fn a_calibration_replaces_only_what_it_gives_and_names_what_is_unknown() {
        let mut reg = Registry {
            subjects: vec![Subject {
                id: "ana".into(),
                name: None,
                wears: vec![wearable("tag1")],
            }],
            cameras: vec![Camera {
                fps_hz: Some(4.0),
                ..Camera::new("counter", RigidTransform::IDENTITY)
            }],
            ..Default::default()
        };
        let cal: Calibration = serde_json::from_str(
            r#"{"cameras":[{"id":"counter","scale":0.0153,"clock":{"offset_ns":-700000000}}],
                "devices":[{"device":"tag1","clock":{"offset_ns":5}}]}"#,
        )
        .unwrap();
        reg.apply_calibration(&cal).unwrap();
        let camera = &reg.cameras[0];
        assert_eq!(camera.scale, 0.0153);
        assert_eq!(camera.clock.offset_ns, -700_000_000);
        assert_eq!(camera.world_from_camera, RigidTransform::IDENTITY);
        assert_eq!(camera.fps_hz, Some(4.0));
        assert_eq!(reg.subjects[0].wears[0].clock.offset_ns, 5);
        let before = reg.clone();
        let unknown: Calibration =
            serde_json::from_str(r#"{"cameras":[{"id":"door","scale":2.0}]}"#).unwrap();
        let err = reg.apply_calibration(&unknown).unwrap_err().to_string();
        assert!(err.contains("camera 'door'"), "{err}");
        let bad: Calibration =
            serde_json::from_str(r#"{"cameras":[{"id":"counter","scale":-2.0}]}"#).unwrap();
        assert!(reg.apply_calibration(&bad).is_err());
        assert_eq!(reg, before);
    }

    #[test]
    fn a_device_worn_by_two_subjects_is_rejected() {
        let reg = Registry {
            subjects: vec![
                Subject {
                    id: "ana".into(),
                    name: None,
                    wears: vec![wearable("imu1")],
                },
                Subject {
                    id: "ben".into(),
                    name: None,
                    wears: vec![wearable("imu1")],
                },
            ],
            ..Default::default()
        };
        let err = reg.validate().unwrap_err().to_string();
        assert!(err.contains("imu1") && err.contains("ben"), "{err}");
    }

    #[test]
    fn wearer_is_found_by_device() {
        let reg = Registry {
            subjects: vec![Subject {
                id: "ana".into(),
                name: None,
                wears: vec![wearable("imu1")],
            }],
            ..Default::default()
        };
        assert!(reg.validate().is_ok());
        assert_eq!(
            reg.wearer(&DeviceId::new("imu1")).unwrap().0.id.as_str(),
            "ana"
        );
        assert!(reg.wearer(&DeviceId::new("imu2")).is_none());
    }
}
