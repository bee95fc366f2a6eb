//! Scenario files: what a scene contains, as plain data loadable from TOML.
//!
//! A scenario names a room with static obstacles, cameras, UWB anchors and RSSI antennas, the
//! sensor models (each with defaults fitted to real recordings, see `docs/sensor-models.md`) and
//! the people: which motion-capture clip each performs and where, which registered subject they
//! are (or none: an *intruder* who wears nothing), and what they wear on which body site.
//! `docs/scenarios.md` documents every field; `scenarios/` holds the library.

use crate::camera::CameraModelConfig;
use crate::clips::ClipDef;
use crate::error::{Result, SimError};
use crate::geometry::BoxObstacle;
use crate::motion::{AvoidanceConfig, MotionSpec};
use crate::sensors::imu::ImuConfig;
use crate::sensors::rssi::RssiConfig;
use crate::sensors::uwb::{RtlsConfig, UwbRangeConfig};
use nomen_core::registry::DeviceKind;
use nomen_core::skeleton::Joint;
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, BTreeSet};

/// A whole scene.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// Short name, used in output metadata and evaluation tables.
    pub name: String,
    /// What the scene is for (free text).
    #[serde(default)]
    pub description: String,
    /// Length of the scene, seconds (the session clock runs from 0 to this).
    pub duration_s: f64,
    /// Default random seed (the command line's `--seed` overrides it).
    #[serde(default)]
    pub seed: u64,
    /// The room and its static obstacles.
    #[serde(default)]
    pub room: Room,
    /// Extra clips beyond the built-in library (`nomen_sim::clips::builtin_clips`), by name.
    #[serde(default)]
    pub clips: BTreeMap<String, ClipDef>,
    /// Body-tracking cameras.
    #[serde(default)]
    pub cameras: Vec<CameraModelConfig>,
    /// UWB anchors (needed for raw ranges; fixes are simulated in the world frame directly).
    #[serde(default)]
    pub anchors: Vec<AnchorDef>,
    /// RSSI antennas (RFID reader ports or BLE anchors).
    #[serde(default)]
    pub antennas: Vec<AntennaDef>,
    /// Sensor models shared by every device of a kind.
    #[serde(default)]
    pub sensors: SensorModels,
    /// The people in the scene.
    pub people: Vec<PersonDef>,
    /// Whether people step aside instead of walking through each other. Default off.
    #[serde(default, skip_serializing_if = "AvoidanceConfig::is_default")]
    pub avoidance: AvoidanceConfig,
}

/// The room: a floor rectangle from (0, 0) to `size_m` and static box obstacles.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Room {
    /// Extent along x, y and z (height), metres; the floor is z = 0.
    #[serde(default = "default_room")]
    pub size_m: [f64; 3],
    /// Static obstacles (furniture, shelves, walls of a corridor): boxes given by centre, full
    /// side lengths and a yaw about Z.
    #[serde(default)]
    pub obstacles: Vec<BoxObstacle>,
}

fn default_room() -> [f64; 3] {
    [8.0, 6.0, 3.0]
}

impl Default for Room {
    fn default() -> Self {
        Self {
            size_m: default_room(),
            obstacles: Vec::new(),
        }
    }
}

/// A UWB anchor.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AnchorDef {
    /// Anchor id.
    pub id: String,
    /// Position, metres.
    pub position_m: [f64; 3],
}

/// An RSSI antenna.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AntennaDef {
    /// Antenna id.
    pub id: String,
    /// Position, metres.
    pub position_m: [f64; 3],
    /// Boresight direction (need not be unit); omit for an omnidirectional antenna.
    #[serde(default)]
    pub boresight: Option<[f64; 3]>,
}

/// Sensor models, one per kind of device.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorModels {
    /// Inertial sensors.
    #[serde(default)]
    pub imu: ImuConfig,
    /// UWB location tags: position fixes from the RTLS.
    #[serde(default)]
    pub rtls: RtlsConfig,
    /// Raw UWB two-way ranges to the anchors; simulated only when this table is present (and
    /// the scene has anchors).
    #[serde(default)]
    pub uwb_range: Option<UwbRangeConfig>,
    /// RSSI tags (passive UHF RFID, BLE beacons).
    #[serde(default)]
    pub rssi: RssiConfig,
    /// Scene-wide multiplier, in `[1, 3]`, of every device's noise: the IMU noise densities,
    /// bias random walks and turn-on bias bounds, the RTLS core σ, the raw UWB range σ and the
    /// RSSI shadowing σ ("1–3× the fitted defaults"). Outlier rates and sizes, losses and
    /// clocks are not scaled. It multiplies each device's own draw ([`DeviceDraw`](crate::sensors::DeviceDraw)). Default 1.
    #[serde(default = "one", skip_serializing_if = "is_one")]
    pub noise_scale: f64,
}

impl Default for SensorModels {
    fn default() -> Self {
        Self {
            imu: ImuConfig::default(),
            rtls: RtlsConfig::default(),
            uwb_range: None,
            rssi: RssiConfig::default(),
            noise_scale: 1.0,
        }
    }
}

fn one() -> f64 {
    1.0
}

fn is_one(v: &f64) -> bool {
    *v == 1.0
}

/// One person.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PersonDef {
    /// Ground-truth person id (never shown to the engine).
    pub id: String,
    /// The registered subject this person is; omit for someone unknown to the system (an
    /// intruder), who must wear nothing and should stay anonymous.
    #[serde(default)]
    pub subject: Option<String>,
    /// How the person moves.
    pub motion: MotionSpec,
    /// Devices the person wears.
    #[serde(default)]
    pub wears: Vec<WearDef>,
}

/// One worn device.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WearDef {
    /// Device id (unique in the scene).
    pub device: String,
    /// `imu`, `uwb_tag`, `rfid_tag` or `ble_tag`.
    pub kind: DeviceKind,
    /// Body site (a canonical joint name such as `left_wrist`).
    pub site: Joint,
    /// Registered as worn on either side ([`nomen_core::Wearable::either_side`]): the
    /// registry does not say which wrist a watch is on. The device is simulated at `site`.
    #[serde(default)]
    pub either_side: bool,
    /// For an IMU: whether it has a gyroscope, overriding `[sensors.imu] gyro` for this
    /// device (`false`: an accelerometer-only watch). Omit to take the scene's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gyro: Option<bool>,
    /// For an IMU: its output rate, Hz, in `10..=300`, overriding `[sensors.imu] rate_hz`
    /// for this device. Omit to take the scene's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rate_hz: Option<f64>,
    /// What happens to the device during the scene; omit when it stays where it is worn.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub change: Option<WearChange>,
}

/// A worn device changing hands mid-scene. The registry still says whose it is; the truth says
/// who wears it when ([`Scenario::subject_of_person_at`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum WearChange {
    /// At `at_s` the device is put on another person, at the same body site.
    MovedTo {
        /// The person who wears it from `at_s` on.
        person: String,
        /// Session time of the change, s.
        at_s: f64,
    },
    /// At `at_s` the device is taken off and left lying still at `position_m` (on a table).
    LeftAt {
        /// Where it lies, world frame, m.
        position_m: [f64; 3],
        /// Session time of the change, s.
        at_s: f64,
    },
}

impl WearChange {
    /// Session time of the change, s.
    pub fn at_s(&self) -> f64 {
        match self {
            WearChange::MovedTo { at_s, .. } | WearChange::LeftAt { at_s, .. } => *at_s,
        }
    }
}

impl Scenario {
    /// Parses a scenario from TOML text; `source` names it in errors.
    pub fn from_toml(text: &str, source: &str) -> Result<Self> {
        let scenario: Scenario = toml::from_str(text)
            .map_err(|e| SimError::InvalidScenario(format!("{source}: {e}")))?;
        // The checks name the field; the file is named here.
        scenario.validate().map_err(|e| match e {
            SimError::InvalidScenario(m) => SimError::InvalidScenario(format!("{source}: {m}")),
            other => other,
        })?;
        Ok(scenario)
    }

    /// Every clip definition the scenario can use: the built-in library plus its own.
    pub fn clip_library(&self) -> BTreeMap<String, ClipDef> {
        let mut lib = crate::clips::builtin_clips();
        lib.extend(self.clips.clone());
        lib
    }

    /// Who wears `device` at `t_s`: its first wearer until a [`WearChange`], then the person it
    /// moved to, or nobody once it lies still. `None` also for a device no one wears.
    pub fn wearer_at(&self, device: &str, t_s: f64) -> Option<&str> {
        let (p, w) = self
            .people
            .iter()
            .find_map(|p| p.wears.iter().find(|w| w.device == device).map(|w| (p, w)))?;
        match &w.change {
            Some(change) if t_s >= change.at_s() => match change {
                WearChange::MovedTo { person, .. } => Some(person.as_str()),
                WearChange::LeftAt { .. } => None,
            },
            _ => Some(p.id.as_str()),
        }
    }

    /// The subject person `person` is at `t_s`, as the truth of a scene says: their own while they
    /// wear one of their own devices (or have none to wear); else the subject of another person
    /// whose device they wear, once that person wears none of their own; else nobody (`None`:
    /// they should stay anonymous).
    pub fn subject_of_person_at(&self, person: &str, t_s: f64) -> Option<&str> {
        let keeps_own = |p: &PersonDef| {
            p.wears.is_empty()
                || p.wears
                    .iter()
                    .any(|w| self.wearer_at(&w.device, t_s) == Some(p.id.as_str()))
        };
        let p = self.people.iter().find(|p| p.id == person)?;
        if let Some(own) = &p.subject
            && keeps_own(p)
        {
            return Some(own.as_str());
        }
        self.people.iter().find_map(|q| {
            let wears_theirs = q.id != person
                && q.wears
                    .iter()
                    .any(|w| self.wearer_at(&w.device, t_s) == Some(person));
            if wears_theirs && !keeps_own(q) {
                q.subject.as_deref()
            } else {
                None
            }
        })
    }

    /// Whether some device changes hands during the scene.
    pub fn has_wear_changes(&self) -> bool {
        self.people
            .iter()
            .any(|p| p.wears.iter().any(|w| w.change.is_some()))
    }

    /// Checks ids, ranges and references; errors name the offending field.
    pub fn validate(&self) -> Result<()> {
        let bad = |m: String| Err(SimError::InvalidScenario(m));
        if !(self.duration_s.is_finite()
            && self.duration_s > 0.0
            && self.duration_s <= 24.0 * 3600.0)
        {
            return bad(format!(
                "duration_s must be in (0, 86400], got {}",
                self.duration_s
            ));
        }
        for (i, v) in self.room.size_m.iter().enumerate() {
            if !(v.is_finite() && *v > 0.0) {
                return bad(format!("room.size_m[{i}] must be positive, got {v}"));
            }
        }
        for o in &self.room.obstacles {
            o.validate()
                .map_err(|e| SimError::InvalidScenario(format!("obstacle '{}': {e}", o.name)))?;
        }
        for (name, def) in &self.clips {
            def.validate()
                .map_err(|why| SimError::InvalidScenario(format!("clips.{name}: {why}")))?;
        }
        let library = self.clip_library();
        let mut people = BTreeSet::new();
        let mut subjects = BTreeSet::new();
        let mut devices = BTreeSet::new();
        for p in &self.people {
            if !people.insert(p.id.as_str()) {
                return bad(format!("person '{}' is listed twice", p.id));
            }
            if let Some(s) = &p.subject
                && !subjects.insert(s.as_str())
            {
                return bad(format!("subject '{s}' is given to two people"));
            }
            if p.subject.is_none() && !p.wears.is_empty() {
                return bad(format!(
                    "person '{}' wears devices but has no subject: devices belong to registered subjects",
                    p.id
                ));
            }
            crate::motion::check_absent_spans(&p.motion.absent_s, self.duration_s).map_err(
                |why| SimError::InvalidScenario(format!("person '{}': motion.{why}", p.id)),
            )?;
            for clip in p.motion.clip_names() {
                if !library.contains_key(clip) {
                    return bad(format!(
                        "person '{}': unknown clip '{clip}' (known: {})",
                        p.id,
                        library.keys().cloned().collect::<Vec<_>>().join(", ")
                    ));
                }
            }
            for w in &p.wears {
                if let Some(change) = &w.change {
                    let at_s = change.at_s();
                    if !(at_s.is_finite() && at_s > 0.0 && at_s < self.duration_s) {
                        return bad(format!(
                            "device '{}': change.at_s must be in (0, duration_s), got {at_s}",
                            w.device
                        ));
                    }
                    match change {
                        WearChange::MovedTo { person, .. } => {
                            if person == &p.id || !self.people.iter().any(|q| &q.id == person) {
                                return bad(format!(
                                    "device '{}': change.person '{person}' must be another person of the scene",
                                    w.device
                                ));
                            }
                        }
                        WearChange::LeftAt { position_m, .. } => {
                            if position_m.iter().any(|v| !v.is_finite()) {
                                return bad(format!(
                                    "device '{}': change.position_m must be finite",
                                    w.device
                                ));
                            }
                        }
                    }
                }
                if !devices.insert(w.device.as_str()) {
                    return bad(format!("device '{}' is worn twice", w.device));
                }
                if w.kind != DeviceKind::Imu && (w.gyro.is_some() || w.rate_hz.is_some()) {
                    return bad(format!(
                        "device '{}': gyro and rate_hz are for IMUs only",
                        w.device
                    ));
                }
                if let Some(rate_hz) = w.rate_hz
                    && !(rate_hz.is_finite() && (10.0..=300.0).contains(&rate_hz))
                {
                    return bad(format!(
                        "device '{}': rate_hz must be in 10..=300 Hz, got {rate_hz}",
                        w.device
                    ));
                }
                if matches!(w.kind, DeviceKind::RfidTag | DeviceKind::BleTag)
                    && self.antennas.is_empty()
                {
                    return bad(format!(
                        "device '{}' is an RSSI tag but the scene has no antennas",
                        w.device
                    ));
                }
            }
        }
        let mut cams = BTreeSet::new();
        for c in &self.cameras {
            if !cams.insert(c.id.as_str()) {
                return bad(format!("camera '{}' is listed twice", c.id));
            }
        }
        let mut ids = BTreeSet::new();
        for a in &self.anchors {
            if !ids.insert(a.id.as_str()) || a.position_m.iter().any(|v| !v.is_finite()) {
                return bad(format!(
                    "anchor '{}' is duplicated or has a non-finite position",
                    a.id
                ));
            }
        }
        ids.clear();
        for a in &self.antennas {
            if !ids.insert(a.id.as_str()) || a.position_m.iter().any(|v| !v.is_finite()) {
                return bad(format!(
                    "antenna '{}' is duplicated or has a non-finite position",
                    a.id
                ));
            }
        }
        let scale = self.sensors.noise_scale;
        if !(scale.is_finite() && (1.0..=crate::sensors::MAX_NOISE_SCALE).contains(&scale)) {
            return bad(format!(
                "sensors.noise_scale must be in [1, {}], got {scale}",
                crate::sensors::MAX_NOISE_SCALE
            ));
        }
        self.sensors.imu.validate()?;
        self.sensors.rtls.validate()?;
        if self.sensors.rtls.blocked_nlos_probability.is_some() && self.anchors.is_empty() {
            return bad(
                "sensors.rtls.blocked_nlos_probability is set but the scene has no anchors"
                    .to_owned(),
            );
        }
        if let Some(r) = &self.sensors.uwb_range {
            if self.anchors.is_empty() {
                return bad("sensors.uwb_range is set but the scene has no anchors".to_owned());
            }
            r.validate()?;
        }
        self.sensors.rssi.validate()?;
        self.avoidance
            .validate()
            .map_err(SimError::InvalidScenario)?;
        for c in &self.cameras {
            c.validate()?;
        }
        Ok(())
    }
}
