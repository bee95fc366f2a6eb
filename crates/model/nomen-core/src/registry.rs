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
    /// The camera's pose: maps camera-frame points into the world frame.
    #[serde(default)]
    pub world_from_camera: RigidTransform,
    /// Pinhole intrinsics, if known.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub intrinsics: Option<CameraIntrinsics>,
    /// Nominal skeleton rate, Hz, if known.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fps_hz: Option<f64>,
    /// How the camera clock maps to the session clock.
    #[serde(default)]
    pub clock: ClockModel,
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

/// Largest clock offset a registry may give, ns: 2⁶² ns, about 146 years, so a device that
/// stamps Unix-epoch time still fits, and sums of an offset with a session time or a lag cannot
/// overflow.
const MAX_CLOCK_OFFSET_NS: i64 = 1 << 62;

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
