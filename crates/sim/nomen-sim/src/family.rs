//! Scene families: randomized scenarios drawn from one definition, so that accuracy is measured on
//! scenes nobody tuned the engine on.
//!
//! A [`FamilyDef`] (TOML, `scenarios/families/`) gives ranges instead of values: crowd size, the
//! fraction of people who wear nothing, the mix of wearables and motions, noise and loss
//! multipliers of the fitted sensor models, clock offsets, camera re-labelling, obstacles and
//! people who leave and come back. [`generate`] draws one scenario from it, as scenario TOML
//! text that [`Scenario::from_toml`](crate::Scenario::from_toml) reads, from a seed and a
//! [`ClipPools`] (the clips a benchmark split may use): the same inputs give the same text.
//!
//! The room is a grid of 8 × 6 m tiles, each watched by its own cameras (the library's
//! `imu_wrist_8` layout); each person has a slot in a tile: walkers loop around the slot's
//! rectangle (slots are concentric, so loops do not cross), people with an in-place motion
//! stand on it.

use crate::error::{Result, SimError};
use crate::rng::{SimRng, stream};
use crate::sensors::imu::ImuConfig;
use rand::Rng;
use serde::{Deserialize, Serialize};
use toml::{Table, Value};

/// Side lengths of one tile of the room, metres (x, y): the area two Kinect-class cameras cover.
pub const TILE_M: [f64; 2] = [8.0, 6.0];

/// Room height, metres.
const ROOM_HEIGHT_M: f64 = 3.0;

/// The body-area network of the `ban` wearable kind: De Marchi et al.'s sites.
const BAN_SITES: [&str; 5] = [
    "left_wrist",
    "right_wrist",
    "left_ankle",
    "right_ankle",
    "pelvis",
];

/// Where a location tag is worn: a badge on the chest or a band on a wrist.
const TAG_SITES: [&str; 3] = ["chest", "left_wrist", "right_wrist"];

/// A family of randomized scenes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FamilyDef {
    /// Family name (letters, digits, `_`); scenes are named `<name>_<index>`.
    pub name: String,
    /// What the family is for.
    #[serde(default)]
    pub description: String,
    /// Scene length, s. Default 60.
    #[serde(default = "default_duration_s")]
    pub duration_s: f64,
    /// Number of people, `[min, max]` inclusive.
    pub people: [u32; 2],
    /// Fraction of the people who wear nothing (and are nobody registered), `[min, max]`,
    /// rounded to a count. Default none.
    #[serde(default)]
    pub wearing_nothing: [f64; 2],
    /// At least this many people wear nothing (fewer only if nobody would be left to wear
    /// something). Default 0.
    #[serde(default)]
    pub min_wearing_nothing: u32,
    /// What the people who wear something wear.
    pub wearables: WearableMix,
    /// How the people move.
    #[serde(default)]
    pub motion: MotionMix,
    /// Sensor noise, loss and clocks.
    #[serde(default)]
    pub devices: DeviceMix,
    /// Cameras and room.
    #[serde(default)]
    pub room: RoomMix,
    /// People who leave the cameras' view and come back (absent: nobody leaves).
    #[serde(default)]
    pub leave_and_return: Option<LeaveAndReturn>,
}

/// Relative weights of what a wearer wears (each wearer draws one kind).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WearableMix {
    /// A full body-area network: IMUs on both wrists, both ankles and the pelvis.
    pub ban: f64,
    /// One IMU on the left or right wrist.
    pub wrist_imu: f64,
    /// Of the wrist IMUs, the fraction registered without a side (`either_side`). Default 0.
    pub wrist_side_unknown: f64,
    /// Of the wrist IMUs, the fraction without a gyroscope (accelerometer-only watches,
    /// `gyro = false`). Default 0.
    pub wrist_accel_only: f64,
    /// A UWB location tag (chest badge or wrist band), position fixes from the RTLS.
    pub uwb_tag: f64,
    /// A wrist IMU and a UWB tag.
    pub wrist_imu_and_uwb_tag: f64,
}

/// How the people move.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MotionMix {
    /// Relative weight of walking loops (clips of the pool's `walk`).
    pub walk: f64,
    /// Relative weight of running loops (the pool's `run`).
    pub run: f64,
    /// Relative weight of motion in place (the pool's `in_place`: waves, hops, dances, sword
    /// play), standing at a point of the person's slot.
    pub in_place: f64,
    /// Every walker walks the same clip (drawn once per scene) at a random phase: the crowd
    /// whose motions look alike. Default false.
    pub same_clip: bool,
    /// Playback-rate factor range. Default `[0.9, 1.1]`.
    pub time_warp: [f64; 2],
    /// Stature range, m. Default `[1.55, 1.95]`.
    pub height_m: [f64; 2],
}

impl Default for MotionMix {
    fn default() -> Self {
        Self {
            walk: 1.0,
            run: 0.0,
            in_place: 0.0,
            same_clip: false,
            time_warp: [0.9, 1.1],
            height_m: [1.55, 1.95],
        }
    }
}

/// Sensor noise, loss and clock ranges.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DeviceMix {
    /// Multiplier of the fitted noise (the scenario's `sensors.noise_scale`), `[min, max]`
    /// within 1–3; each scene draws one. Default `[1, 1]`.
    pub noise_scale: [f64; 2],
    /// Spread of noise and bias between devices (the sensor models' `device_spread`: each IMU
    /// and tag draws its own multiplier, log-uniform in `[1/k, k]`), 1–10. Default 1.
    pub device_spread: f64,
    /// Fraction of IMU samples and RTLS fixes lost (in bursts), `[min, max]`: each device draws
    /// its own. Default the fitted models' own (1 %).
    pub loss_fraction: [f64; 2],
    /// Mean length of a loss burst, samples. Default 3 (the IMU model's).
    pub loss_burst_len: f64,
    /// Largest IMU clock offset, s (each device draws one within ±). Default 0.5
    /// (Belmonte-Hernández et al. measured offsets up to 0.5 s).
    pub clock_offset_max_s: f64,
    /// Largest IMU clock drift, ppm. Default 50.
    pub clock_drift_max_ppm: f64,
    /// Probability that a UWB fix whose line to most anchors is blocked (by bodies or
    /// furniture) is an outlier (the RTLS model's `blocked_nlos_probability`). Default 0.
    pub uwb_blocked_nlos_probability: f64,
}

impl Default for DeviceMix {
    fn default() -> Self {
        let imu = ImuConfig::default();
        Self {
            noise_scale: [1.0, 1.0],
            device_spread: 1.0,
            loss_fraction: [imu.loss.loss_fraction, imu.loss.loss_fraction],
            loss_burst_len: imu.loss.mean_burst_len,
            clock_offset_max_s: imu.clock.max_offset_s,
            clock_drift_max_ppm: imu.clock.max_drift_ppm,
            uwb_blocked_nlos_probability: 0.0,
        }
    }
}

/// Cameras and room.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RoomMix {
    /// People per 8 × 6 m tile (the room grows by tiles with the crowd). Default 8.
    pub people_per_tile: u32,
    /// Cameras per tile: 1 (front) or 2 (front and back). Default 2.
    pub cameras_per_tile: u32,
    /// Box obstacles per tile (cabinets, beds, screens between a camera and the people),
    /// `[min, max]`. Default none.
    pub obstacles_per_tile: [u32; 2],
    /// Rate at which a camera re-labels a body that stays visible, Hz, `[min, max]` (each camera
    /// draws one; see the camera model's `tracking.relabel_rate_hz`). Default none.
    pub relabel_rate_hz: [f64; 2],
}

impl Default for RoomMix {
    fn default() -> Self {
        Self {
            people_per_tile: 8,
            cameras_per_tile: 2,
            obstacles_per_tile: [0, 0],
            relabel_rate_hz: [0.0, 0.0],
        }
    }
}

/// People who leave and come back.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LeaveAndReturn {
    /// Probability that a person leaves once during the scene.
    pub probability: f64,
    /// How long the person stays away, `[min, max]` s.
    pub away_s: [f64; 2],
}

/// The clips a benchmark split may use, by kind of motion (names of the simulator's clip
/// library).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ClipPools {
    /// Travelling walks.
    pub walk: Vec<String>,
    /// Runs and jogs.
    pub run: Vec<String>,
    /// Motions in place.
    pub in_place: Vec<String>,
}

/// One split of the benchmark: its seeds and its clips.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BenchSplit {
    /// Scene `k` of a family is drawn and simulated with seed `seed_base + k`.
    pub seed_base: u64,
    /// The clips the split's scenes use.
    pub clips: ClipPools,
}

fn default_duration_s() -> f64 {
    60.0
}

impl FamilyDef {
    /// Parses a family from TOML text; `source` names it in errors.
    pub fn from_toml(text: &str, source: &str) -> Result<Self> {
        let family: FamilyDef = toml::from_str(text)
            .map_err(|e| SimError::InvalidScenario(format!("{source}: {e}")))?;
        family
            .validate()
            .map_err(|m| SimError::InvalidScenario(format!("{source}: {m}")))?;
        Ok(family)
    }

    /// Checks names and ranges; the message names the field.
    pub fn validate(&self) -> std::result::Result<(), String> {
        if self.name.is_empty()
            || !self
                .name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_')
        {
            return Err(format!(
                "name must be letters, digits and '_', got '{}'",
                self.name
            ));
        }
        if !(self.duration_s.is_finite() && (10.0..=3600.0).contains(&self.duration_s)) {
            return Err(format!(
                "duration_s must be in [10, 3600], got {}",
                self.duration_s
            ));
        }
        let [lo, hi] = self.people;
        if lo == 0 || lo > hi || hi > 256 {
            return Err(format!(
                "people must be [min, max] with 1 <= min <= max <= 256, got [{lo}, {hi}]"
            ));
        }
        check_range("wearing_nothing", self.wearing_nothing, 0.0, 1.0)?;
        let w = &self.wearables;
        let weights = [
            ("wearables.ban", w.ban),
            ("wearables.wrist_imu", w.wrist_imu),
            ("wearables.uwb_tag", w.uwb_tag),
            ("wearables.wrist_imu_and_uwb_tag", w.wrist_imu_and_uwb_tag),
        ];
        check_weights(&weights)?;
        check_range(
            "wearables.wrist_side_unknown",
            [w.wrist_side_unknown; 2],
            0.0,
            1.0,
        )?;
        check_range(
            "wearables.wrist_accel_only",
            [w.wrist_accel_only; 2],
            0.0,
            1.0,
        )?;
        let m = &self.motion;
        check_weights(&[
            ("motion.walk", m.walk),
            ("motion.run", m.run),
            ("motion.in_place", m.in_place),
        ])?;
        check_range("motion.time_warp", m.time_warp, 0.85, 1.15)?;
        check_range("motion.height_m", m.height_m, 0.5, 2.5)?;
        let d = &self.devices;
        check_range("devices.noise_scale", d.noise_scale, 1.0, 3.0)?;
        check_range("devices.device_spread", [d.device_spread; 2], 1.0, 10.0)?;
        check_range("devices.loss_fraction", d.loss_fraction, 0.0, 0.5)?;
        check_range(
            "devices.uwb_blocked_nlos_probability",
            [d.uwb_blocked_nlos_probability; 2],
            0.0,
            1.0,
        )?;
        check_range("devices.loss_burst_len", [d.loss_burst_len; 2], 1.0, 100.0)?;
        check_range(
            "devices.clock_offset_max_s",
            [d.clock_offset_max_s; 2],
            0.0,
            5.0,
        )?;
        check_range(
            "devices.clock_drift_max_ppm",
            [d.clock_drift_max_ppm; 2],
            0.0,
            1000.0,
        )?;
        let r = &self.room;
        if !(1..=16).contains(&r.people_per_tile) {
            return Err(format!(
                "room.people_per_tile must be in 1..=16, got {}",
                r.people_per_tile
            ));
        }
        if !(1..=2).contains(&r.cameras_per_tile) {
            return Err(format!(
                "room.cameras_per_tile must be 1 or 2, got {}",
                r.cameras_per_tile
            ));
        }
        let [olo, ohi] = r.obstacles_per_tile;
        if olo > ohi || ohi > 4 {
            return Err(format!(
                "room.obstacles_per_tile must be [min, max] with min <= max <= 4, got [{olo}, {ohi}]"
            ));
        }
        check_range("room.relabel_rate_hz", r.relabel_rate_hz, 0.0, 1.0)?;
        if let Some(l) = &self.leave_and_return {
            check_range("leave_and_return.probability", [l.probability; 2], 0.0, 1.0)?;
            check_range(
                "leave_and_return.away_s",
                l.away_s,
                1.0,
                self.duration_s / 3.0,
            )?;
        }
        Ok(())
    }
}

fn check_range(
    field: &str,
    [lo, hi]: [f64; 2],
    min: f64,
    max: f64,
) -> std::result::Result<(), String> {
    if lo.is_finite() && hi.is_finite() && min <= lo && lo <= hi && hi <= max {
        Ok(())
    } else {
        Err(format!(
            "{field} must be [min, max] with {min} <= min <= max <= {max}, got [{lo}, {hi}]"
        ))
    }
}

fn check_weights(weights: &[(&str, f64)]) -> std::result::Result<(), String> {
    for (field, w) in weights {
        if !(w.is_finite() && *w >= 0.0) {
            return Err(format!("{field} must be a weight >= 0, got {w}"));
        }
    }
    if weights.iter().map(|(_, w)| w).sum::<f64>() <= 0.0 {
        let names: Vec<&str> = weights.iter().map(|(f, _)| *f).collect();
        return Err(format!("one of {} must be positive", names.join(", ")));
    }
    Ok(())
}

/// What kind of motion a person draws.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum MotionKind {
    Walk,
    Run,
    InPlace,
}

/// What a wearer wears.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum WearKind {
    Ban,
    WristImu,
    UwbTag,
    WristImuAndUwbTag,
}

/// Draws scenario `index` of a family: TOML text for [`crate::Scenario::from_toml`], named
/// `<family>_<index>` (three digits), whose own `seed` is `seed` (so `nomen simulate` on the
/// file reproduces the scene). The draw reads the stream `family/<name>` of `seed`; `pools`
/// gives the clips (a pool the family needs and `pools` leaves empty is an error).
pub fn generate(family: &FamilyDef, pools: &ClipPools, index: usize, seed: u64) -> Result<String> {
    family
        .validate()
        .map_err(|m| SimError::InvalidScenario(format!("family '{}': {m}", family.name)))?;
    let bad = |m: String| SimError::InvalidScenario(format!("family '{}': {m}", family.name));
    let mut rng = stream(seed, &format!("family/{}", family.name));
    let num_people = rng.random_range(family.people[0]..=family.people[1]) as usize;
    let fraction = uniform(&mut rng, family.wearing_nothing);
    let num_nothing = ((fraction * num_people as f64).round() as usize)
        .max(family.min_wearing_nothing as usize)
        .min(num_people.saturating_sub(1));
    let per_tile = family.room.people_per_tile as usize;
    let num_tiles = num_people.div_ceil(per_tile).max(1);
    let cols = (num_tiles as f64).sqrt().ceil() as usize;
    let rows = num_tiles.div_ceil(cols);

    let mut scenario = Table::new();
    scenario.insert("name".into(), format!("{}_{index:03}", family.name).into());
    scenario.insert(
        "description".into(),
        format!(
            "Scene {index} of family '{}' (seed {seed}): {num_people} people, {num_nothing} wearing nothing. {}",
            family.name, family.description
        )
        .into(),
    );
    scenario.insert("duration_s".into(), family.duration_s.into());
    scenario.insert("seed".into(), int(seed)?);

    // The room and its cameras, tile by tile.
    let mut room = Table::new();
    room.insert(
        "size_m".into(),
        floats(&[
            cols as f64 * TILE_M[0],
            rows as f64 * TILE_M[1],
            ROOM_HEIGHT_M,
        ]),
    );
    let mut obstacles = Vec::new();
    let mut cameras = Vec::new();
    for tile in 0..num_tiles {
        let [ox, oy] = tile_origin(tile, cols);
        cameras.push(camera(
            &mut rng,
            family,
            &format!("cam{tile}_front"),
            [ox + 4.0, oy + 0.2, 1.6],
            [ox + 4.0, oy + 3.5, 1.0],
        ));
        if family.room.cameras_per_tile == 2 {
            cameras.push(camera(
                &mut rng,
                family,
                &format!("cam{tile}_back"),
                [ox + 4.0, oy + 5.8, 1.6],
                [ox + 4.0, oy + 2.5, 1.0],
            ));
        }
        let [olo, ohi] = family.room.obstacles_per_tile;
        for k in 0..rng.random_range(olo..=ohi) {
            // Between a camera and the walkers' loops: occludes legs and lower bodies.
            let front = k % 2 == 0;
            let mut o = Table::new();
            o.insert("name".into(), format!("tile{tile}_box{k}").into());
            let height = rng.random_range(0.6..1.3);
            let y = if front { 1.0 } else { 5.0 };
            o.insert(
                "centre_m".into(),
                floats(&[
                    ox + rng.random_range(2.5..5.5),
                    oy + y + rng.random_range(-0.1..0.1),
                    height / 2.0,
                ]),
            );
            o.insert(
                "size_m".into(),
                floats(&[rng.random_range(0.6..1.4), 0.4, height]),
            );
            obstacles.push(Value::Table(o));
        }
    }
    if !obstacles.is_empty() {
        room.insert("obstacles".into(), Value::Array(obstacles));
    }
    scenario.insert("room".into(), Value::Table(room));
    scenario.insert("cameras".into(), Value::Array(cameras));

    // Who wears what, and how everyone moves.
    let wear_weights = [
        (WearKind::Ban, family.wearables.ban),
        (WearKind::WristImu, family.wearables.wrist_imu),
        (WearKind::UwbTag, family.wearables.uwb_tag),
        (
            WearKind::WristImuAndUwbTag,
            family.wearables.wrist_imu_and_uwb_tag,
        ),
    ];
    let motion_weights = [
        (MotionKind::Walk, family.motion.walk),
        (MotionKind::Run, family.motion.run),
        (MotionKind::InPlace, family.motion.in_place),
    ];
    let shared_walk = if family.motion.same_clip {
        Some(pick(&mut rng, &pools.walk).ok_or_else(|| bad("the split has no walk clips".into()))?)
    } else {
        None
    };
    // Who wears nothing: a random subset, so intruders are spread over slots and tiles.
    let mut is_intruder = vec![false; num_people];
    for i in rand::seq::index::sample(&mut rng, num_people, num_nothing) {
        if let Some(x) = is_intruder.get_mut(i) {
            *x = true;
        }
    }
    let mut people = Vec::new();
    let mut has_uwb = false;
    for (i, intruder) in is_intruder.iter().enumerate() {
        let tile = i % num_tiles;
        let slot = i / num_tiles;
        let [ox, oy] = tile_origin(tile, cols);
        let loop_rect = slot_rectangle(&mut rng, slot, [ox, oy]);
        let kind = choose(&mut rng, &motion_weights).unwrap_or(MotionKind::Walk);
        let pool = match kind {
            MotionKind::Walk => &pools.walk,
            MotionKind::Run => &pools.run,
            MotionKind::InPlace => &pools.in_place,
        };
        let clip = match (kind, &shared_walk) {
            (MotionKind::Walk, Some(clip)) => clip.clone(),
            _ => pick(&mut rng, pool)
                .ok_or_else(|| bad(format!("the split has no {kind:?} clips")))?,
        };
        let mut motion = Table::new();
        motion.insert("clip".into(), clip.into());
        motion.insert("phase_s".into(), round3(rng.random_range(0.0..4.0)).into());
        motion.insert(
            "time_warp".into(),
            round3(uniform(&mut rng, family.motion.time_warp)).into(),
        );
        motion.insert("mirror".into(), rng.random_bool(0.5).into());
        motion.insert(
            "height_m".into(),
            round3(uniform(&mut rng, family.motion.height_m)).into(),
        );
        if kind == MotionKind::InPlace {
            let [x, y] = point_on_rectangle(&mut rng, &loop_rect);
            motion.insert("position".into(), floats(&[x, y]));
            motion.insert(
                "heading_rad".into(),
                round3(rng.random_range(-std::f64::consts::PI..std::f64::consts::PI)).into(),
            );
            motion.insert("lowpass_hz".into(), 10.0.into());
        } else {
            // Enough laps for the fastest runner over the whole scene.
            let perimeter = 2.0 * (loop_rect.half[0] + loop_rect.half[1]) * 2.0;
            let laps = (family.duration_s * 3.5 / perimeter).ceil() as usize + 1;
            let corners = loop_rect.corners(rng.random_bool(0.5), rng.random_range(0..4));
            let mut path = Vec::with_capacity(laps * 4 + 1);
            for _ in 0..laps {
                path.extend(corners.iter().map(|c| floats(c)));
            }
            path.push(floats(&corners[0]));
            motion.insert("path".into(), Value::Array(path));
        }
        let mut person = Table::new();
        person.insert("id".into(), format!("p{:02}", i + 1).into());
        if !intruder {
            let subject = format!("s{:02}", i + 1);
            let wear = choose(&mut rng, &wear_weights).unwrap_or(WearKind::WristImu);
            let mut wears = Vec::new();
            let imu = |site: &str, either_side: bool, accel_only: bool| {
                let mut w = Table::new();
                w.insert("device".into(), format!("{subject}_{site}").into());
                w.insert("kind".into(), "imu".into());
                w.insert("site".into(), site.into());
                if either_side {
                    w.insert("either_side".into(), true.into());
                }
                if accel_only {
                    w.insert("gyro".into(), false.into());
                }
                Value::Table(w)
            };
            let wrist = if rng.random_bool(0.5) {
                "left_wrist"
            } else {
                "right_wrist"
            };
            let either = rng.random_bool(family.wearables.wrist_side_unknown);
            // Drawn only where the family has such watches, so other families' scenes stay
            // as they are.
            let accel_only = family.wearables.wrist_accel_only > 0.0
                && rng.random_bool(family.wearables.wrist_accel_only);
            match wear {
                WearKind::Ban => wears.extend(BAN_SITES.iter().map(|s| imu(s, false, false))),
                WearKind::WristImu | WearKind::WristImuAndUwbTag => {
                    wears.push(imu(wrist, either, accel_only))
                }
                WearKind::UwbTag => {}
            }
            if matches!(wear, WearKind::UwbTag | WearKind::WristImuAndUwbTag) {
                let site = TAG_SITES[rng.random_range(0..TAG_SITES.len())];
                let mut w = Table::new();
                w.insert("device".into(), format!("{subject}_tag").into());
                w.insert("kind".into(), "uwb_tag".into());
                w.insert("site".into(), site.into());
                wears.push(Value::Table(w));
                has_uwb = true;
            }
            person.insert("subject".into(), subject.into());
            person.insert("wears".into(), Value::Array(wears));
        }
        if let Some(leave) = &family.leave_and_return
            && rng.random_bool(leave.probability)
        {
            let away = uniform(&mut rng, leave.away_s);
            let latest = family.duration_s - away - 10.0;
            if latest > 10.0 {
                let from = round3(rng.random_range(10.0..latest));
                motion.insert(
                    "absent_s".into(),
                    Value::Array(vec![floats(&[from, round3(from + away)])]),
                );
            }
        }
        person.insert("motion".into(), Value::Table(motion));
        people.push(Value::Table(person));
    }
    if has_uwb {
        let mut anchors = Vec::new();
        for tile in 0..num_tiles {
            let [ox, oy] = tile_origin(tile, cols);
            for (k, [x, y]) in [[0.2, 0.2], [7.8, 0.2], [7.8, 5.8], [0.2, 5.8]]
                .into_iter()
                .enumerate()
            {
                let mut a = Table::new();
                a.insert("id".into(), format!("a{tile}_{k}").into());
                a.insert("position_m".into(), floats(&[ox + x, oy + y, 2.6]));
                anchors.push(Value::Table(a));
            }
        }
        scenario.insert("anchors".into(), Value::Array(anchors));
    }
    scenario.insert(
        "sensors".into(),
        Value::Table(sensors(&mut rng, family, has_uwb)),
    );
    scenario.insert("people".into(), Value::Array(people));
    toml::to_string(&scenario).map_err(|e| bad(format!("cannot write the scenario: {e}")))
}

/// The sensor models of one scene: the fitted defaults under this scene's noise scale, each
/// device drawing its own spread and loss in the simulator.
fn sensors(rng: &mut SimRng, family: &FamilyDef, has_anchors: bool) -> Table {
    let d = &family.devices;
    let loss = || {
        let mut t = Table::new();
        t.insert("loss_fraction".into(), round6(d.loss_fraction[0]).into());
        t.insert("mean_burst_len".into(), d.loss_burst_len.into());
        if d.loss_fraction[1] > d.loss_fraction[0] {
            t.insert("loss_fraction_range".into(), floats(&d.loss_fraction));
        }
        Value::Table(t)
    };
    let mut imu = Table::new();
    imu.insert("device_spread".into(), d.device_spread.into());
    imu.insert("loss".into(), loss());
    let mut clock = Table::new();
    clock.insert("max_offset_s".into(), d.clock_offset_max_s.into());
    clock.insert("max_drift_ppm".into(), d.clock_drift_max_ppm.into());
    imu.insert("clock".into(), Value::Table(clock));
    let mut rtls = Table::new();
    rtls.insert("device_spread".into(), d.device_spread.into());
    rtls.insert("loss".into(), loss());
    if has_anchors && d.uwb_blocked_nlos_probability > 0.0 {
        rtls.insert(
            "blocked_nlos_probability".into(),
            d.uwb_blocked_nlos_probability.into(),
        );
    }
    let mut sensors = Table::new();
    sensors.insert(
        "noise_scale".into(),
        round3(uniform(rng, d.noise_scale)).into(),
    );
    sensors.insert("imu".into(), Value::Table(imu));
    sensors.insert("rtls".into(), Value::Table(rtls));
    sensors
}

/// A rectangle a person loops around: centre and half sides, metres.
#[derive(Debug, Clone, Copy)]
struct Rectangle {
    centre: [f64; 2],
    half: [f64; 2],
}

impl Rectangle {
    /// The four corners, counter-clockwise (or clockwise when `reverse`), from corner `start`.
    fn corners(&self, reverse: bool, start: usize) -> [[f64; 2]; 4] {
        let [cx, cy] = self.centre;
        let [hx, hy] = self.half;
        let mut c = [
            [round3(cx - hx), round3(cy - hy)],
            [round3(cx + hx), round3(cy - hy)],
            [round3(cx + hx), round3(cy + hy)],
            [round3(cx - hx), round3(cy + hy)],
        ];
        if reverse {
            c.reverse();
        }
        c.rotate_left(start % 4);
        c
    }
}

/// Slot `slot` of a tile: concentric rectangles around the tile's centre, growing by 0.35 m in
/// x per slot and 0.25 m in y every second slot (the library's loops), with a few centimetres of
/// jitter. Slots past the eighth start again from the smallest with a shifted centre.
fn slot_rectangle(rng: &mut SimRng, slot: usize, [ox, oy]: [f64; 2]) -> Rectangle {
    let ring = slot % 8;
    let shift = (slot / 8) as f64 * 0.2;
    Rectangle {
        centre: [
            ox + 4.0 + shift + rng.random_range(-0.05..0.05),
            oy + 2.8 + rng.random_range(-0.05..0.05),
        ],
        half: [
            0.9 + 0.35 * (ring % 4) as f64 + rng.random_range(-0.05..0.05),
            0.6 + 0.25 * ((ring / 2) % 3) as f64 + rng.random_range(-0.05..0.05),
        ],
    }
}

/// A random point on a rectangle's edge.
fn point_on_rectangle(rng: &mut SimRng, r: &Rectangle) -> [f64; 2] {
    let corners = r.corners(false, 0);
    let edge = rng.random_range(0..4);
    let [a, b] = [corners[edge], corners[(edge + 1) % 4]];
    let u = rng.random_range(0.0..1.0);
    [
        round3(a[0] + u * (b[0] - a[0])),
        round3(a[1] + u * (b[1] - a[1])),
    ]
}

fn tile_origin(tile: usize, cols: usize) -> [f64; 2] {
    [
        (tile % cols) as f64 * TILE_M[0],
        (tile / cols) as f64 * TILE_M[1],
    ]
}

fn camera(
    rng: &mut SimRng,
    family: &FamilyDef,
    id: &str,
    position_m: [f64; 3],
    look_at_m: [f64; 3],
) -> Value {
    let mut c = Table::new();
    c.insert("id".into(), id.into());
    c.insert("position_m".into(), floats(&position_m));
    c.insert("look_at_m".into(), floats(&look_at_m));
    let relabel_rate_hz = uniform(rng, family.room.relabel_rate_hz);
    if relabel_rate_hz > 0.0 {
        let mut tracking = Table::new();
        tracking.insert("relabel_rate_hz".into(), round6(relabel_rate_hz).into());
        c.insert("tracking".into(), Value::Table(tracking));
    }
    Value::Table(c)
}

fn uniform(rng: &mut SimRng, [lo, hi]: [f64; 2]) -> f64 {
    if hi > lo {
        rng.random_range(lo..=hi)
    } else {
        lo
    }
}

fn choose<T: Copy>(rng: &mut SimRng, weights: &[(T, f64)]) -> Option<T> {
    let total: f64 = weights.iter().map(|(_, w)| w).sum();
    if total <= 0.0 {
        return None;
    }
    let mut u = rng.random_range(0.0..total);
    for (item, w) in weights {
        if u < *w {
            return Some(*item);
        }
        u -= w;
    }
    weights
        .iter()
        .rev()
        .find(|(_, w)| *w > 0.0)
        .map(|(t, _)| *t)
}

fn pick(rng: &mut SimRng, pool: &[String]) -> Option<String> {
    if pool.is_empty() {
        None
    } else {
        pool.get(rng.random_range(0..pool.len())).cloned()
    }
}

fn floats(values: &[f64]) -> Value {
    Value::Array(values.iter().map(|v| Value::Float(*v)).collect())
}

fn int(v: u64) -> Result<Value> {
    i64::try_from(v)
        .map(Value::Integer)
        .map_err(|_| SimError::InvalidScenario(format!("seed {v} does not fit in TOML")))
}

fn round3(v: f64) -> f64 {
    (v * 1e3).round() / 1e3
}

fn round6(v: f64) -> f64 {
    (v * 1e6).round() / 1e6
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Scenario;

    fn pools() -> ClipPools {
        ClipPools {
            walk: vec!["walk_02_01".into(), "walk_131_01".into()],
            run: vec!["run_02_03".into()],
            in_place: vec!["wave_141_16".into(), "hop_131_03".into()],
        }
    }

    fn family(text: &str) -> FamilyDef {
        FamilyDef::from_toml(text, "test.toml").unwrap()
    }

    const MIXED: &str = r#"
        name = "mixed"
        people = [3, 20]
        wearing_nothing = [0.1, 0.5]
        min_wearing_nothing = 1
        [wearables]
        ban = 1.0
        wrist_imu = 1.0
        wrist_side_unknown = 0.5
        uwb_tag = 1.0
        wrist_imu_and_uwb_tag = 1.0
        [motion]
        walk = 1.0
        run = 1.0
        in_place = 1.0
        [devices]
        noise_scale = [1.0, 3.0]
        loss_fraction = [0.0, 0.3]
        [room]
        obstacles_per_tile = [0, 2]
    "#;

    #[test]
    fn every_drawn_scene_is_a_valid_scenario_within_the_family_ranges() {
        let f = family(MIXED);
        for seed in 0..40 {
            let text = generate(&f, &pools(), 7, seed).unwrap();
            let scenario = Scenario::from_toml(&text, "drawn").unwrap();
            let n = scenario.people.len();
            assert!((3..=20).contains(&n), "{n} people");
            let nothing: Vec<_> = scenario
                .people
                .iter()
                .filter(|p| p.subject.is_none())
                .collect();
            assert!(!nothing.is_empty() && nothing.len() < n);
            assert!(nothing.iter().all(|p| p.wears.is_empty()));
            // Every wearer wears something, and every clip comes from the pools.
            let pools = pools();
            let all: Vec<&String> = pools
                .walk
                .iter()
                .chain(&pools.run)
                .chain(&pools.in_place)
                .collect();
            for p in &scenario.people {
                assert!(p.subject.is_none() || !p.wears.is_empty());
                assert!(all.contains(&&p.motion.clip), "{}", p.motion.clip);
            }
            let scale = scenario.sensors.noise_scale;
            assert!((1.0..=3.0).contains(&scale), "{scale}");
            let loss = scenario.sensors.imu.loss.loss_fraction_range;
            assert_eq!(loss, Some([0.0, 0.3]));
            assert_eq!(scenario.seed, seed);
            assert_eq!(scenario.name, "mixed_007");
        }
    }

    #[test]
    fn people_stay_inside_the_room_and_in_view_of_their_tile() {
        let f = family(MIXED);
        for seed in 0..20 {
            let scenario =
                Scenario::from_toml(&generate(&f, &pools(), 0, seed).unwrap(), "drawn").unwrap();
            let [sx, sy, _] = scenario.room.size_m;
            for p in &scenario.people {
                let points: Vec<[f64; 2]> = match (&p.motion.path, p.motion.position) {
                    (Some(path), _) => path.clone(),
                    (None, Some(at)) => vec![at],
                    (None, None) => panic!("person {} has no placement", p.id),
                };
                for [x, y] in points {
                    assert!(
                        x > 0.5 && x < sx - 0.5 && y > 0.5 && y < sy - 0.5,
                        "({x}, {y})"
                    );
                    // Within 2.5 m of its tile's centre: inside both cameras' range.
                    let cx = (x / TILE_M[0]).floor() * TILE_M[0] + 4.0;
                    let cy = (y / TILE_M[1]).floor() * TILE_M[1] + 2.8;
                    assert!((x - cx).abs() < 2.5 && (y - cy).abs() < 1.6, "({x}, {y})");
                }
            }
        }
    }

    #[test]
    fn the_same_seed_draws_the_same_scene_and_another_seed_another() {
        let f = family(MIXED);
        let a = generate(&f, &pools(), 1, 5).unwrap();
        assert_eq!(a, generate(&f, &pools(), 1, 5).unwrap());
        assert_ne!(a, generate(&f, &pools(), 1, 6).unwrap());
    }

    #[test]
    fn a_same_clip_crowd_walks_one_clip() {
        let f = family(
            r#"
            name = "same"
            people = [8, 8]
            [wearables]
            wrist_imu = 1.0
            [motion]
            same_clip = true
        "#,
        );
        for seed in 0..10 {
            let s =
                Scenario::from_toml(&generate(&f, &pools(), 0, seed).unwrap(), "drawn").unwrap();
            let first = &s.people[0].motion.clip;
            assert!(s.people.iter().all(|p| &p.motion.clip == first));
        }
    }

    #[test]
    fn a_pool_the_family_needs_must_not_be_empty() {
        let f = family(
            r#"
            name = "runners"
            people = [2, 2]
            [wearables]
            wrist_imu = 1.0
            [motion]
            walk = 0.0
            run = 1.0
        "#,
        );
        let empty = ClipPools {
            run: Vec::new(),
            ..pools()
        };
        let err = generate(&f, &empty, 0, 1).unwrap_err().to_string();
        assert!(err.contains("no Run clips"), "{err}");
    }

    #[test]
    fn bad_families_are_refused_with_the_field_named() {
        for (text, field) in [
            (
                "name = \"a b\"\npeople = [1, 2]\n[wearables]\nban = 1.0",
                "name",
            ),
            (
                "name = \"a\"\npeople = [3, 2]\n[wearables]\nban = 1.0",
                "people",
            ),
            (
                "name = \"a\"\npeople = [0, 2]\n[wearables]\nban = 1.0",
                "people",
            ),
            (
                "name = \"a\"\npeople = [1, 2]\n[wearables]\nban = 0.0",
                "wearables",
            ),
            (
                "name = \"a\"\npeople = [1, 2]\n[wearables]\nban = -1.0",
                "wearables.ban",
            ),
            (
                "name = \"a\"\npeople = [1, 2]\nwearing_nothing = [0.5, 0.2]\n[wearables]\nban = 1.0",
                "wearing_nothing",
            ),
            (
                "name = \"a\"\npeople = [1, 2]\n[wearables]\nban = 1.0\n[devices]\nnoise_scale = [0.5, 1.0]",
                "devices.noise_scale",
            ),
            (
                "name = \"a\"\npeople = [1, 2]\n[wearables]\nban = 1.0\n[motion]\ntime_warp = [0.9, nan]",
                "motion.time_warp",
            ),
            (
                "name = \"a\"\npeople = [1, 2]\n[wearables]\nbanana = 1.0",
                "banana",
            ),
        ] {
            let err = FamilyDef::from_toml(text, "f.toml")
                .unwrap_err()
                .to_string();
            assert!(err.contains("f.toml") && err.contains(field), "{err}");
        }
    }
}
