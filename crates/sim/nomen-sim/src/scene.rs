//! Running a scenario: people, cameras and wearables over the scene's duration, with ground truth.

use crate::body::{BodyMotion, Handover, LyingStill, Mount};
use crate::camera::{CameraModel, PersonInScene, is_limb, to_position_only};
use crate::clips::ClipDef;
use crate::error::{Result, SimError};
use crate::geometry::{
    BodyCapsules, BodyRadii, count_blocking_bodies, obstacles_block_segment, obstacles_to_obj,
};
use crate::motion::{
    AvoidingMotion, ClipUse, PersonMotion, WhenAbsent, is_in_spans, plan_avoidance,
};
use crate::rng::stream;
use crate::scenario::{Scenario, WearChange, WearDef};
use crate::sensors::DeviceDraw;
use crate::sensors::imu::simulate_imu;
use crate::sensors::rssi::simulate_rssi;
use crate::sensors::uwb::{BlockedLines, simulate_rtls_blocked, simulate_uwb_ranges_blocked};
use nalgebra::{Point3, UnitQuaternion, Vector3};
use nomen_core::registry::{Anchor, Antenna, DeviceKind, Registry, Subject, Wearable};
use nomen_core::{AnchorId, AntennaId, DeviceId, Joint, Message, SubjectId};
use nomen_mocap::{ConvertOptions, MocapClip, convert, parse_amc, parse_asf, parse_bvh};
use serde::Serialize;
use std::collections::BTreeMap;

/// Parses and converts one clip of the library (sans-IO: the caller reads the files): `text` is
/// the BVH or AMC file, `skeleton_text` the ASF file of an AMC clip ([`ClipDef::skeleton`]).
pub fn load_clip(
    def: &ClipDef,
    text: &str,
    skeleton_text: Option<&str>,
    source: &str,
) -> Result<MocapClip> {
    let bvh = match (&def.skeleton, skeleton_text) {
        (None, _) => parse_bvh(text, source)?,
        (Some(skeleton), Some(asf_text)) => {
            let asf = parse_asf(asf_text, skeleton)?;
            parse_amc(text, &asf, source)?
        }
        (Some(skeleton), None) => {
            return Err(SimError::InvalidScenario(format!(
                "clip {source}: the skeleton file {skeleton} was not given"
            )));
        }
    };
    let options = ConvertOptions {
        scale: Some(def.scale),
        fps_hz: Some(def.fps_hz),
        ..Default::default()
    };
    Ok(convert(&bvh, &options)?)
}

/// Loads every clip the scenario's people use. `read_file(path)` returns the text of a file
/// given its path relative to the data folder (`ClipDef::file`, `ClipDef::skeleton`); the caller
/// decides where that is, so this stays free of I/O. Errors name the clip and the file.
pub fn load_scenario_clips(
    scenario: &Scenario,
    read_file: &mut dyn FnMut(&str) -> std::result::Result<String, String>,
) -> Result<BTreeMap<String, MocapClip>> {
    let library = scenario.clip_library();
    let mut clips = BTreeMap::new();
    for p in &scenario.people {
        for name in p.motion.clip_names() {
            if clips.contains_key(name) {
                continue;
            }
            let Some(def) = library.get(name) else {
                return Err(SimError::InvalidScenario(format!(
                    "person '{}': unknown clip '{name}'",
                    p.id
                )));
            };
            let mut read = |file: &str| {
                read_file(file).map_err(|why| {
                    SimError::InvalidScenario(format!("clip '{name}': cannot read {file}: {why}"))
                })
            };
            let text = read(&def.file)?;
            let skeleton_text = def.skeleton.as_deref().map(&mut read).transpose()?;
            clips.insert(
                name.to_owned(),
                load_clip(def, &text, skeleton_text.as_deref(), &def.file)?,
            );
        }
    }
    Ok(clips)
}

/// What one simulated device drew: the hidden truth behind its messages.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DeviceTruth {
    /// The device.
    pub device: String,
    /// Its kind.
    pub kind: DeviceKind,
    /// The person wearing it.
    pub person: String,
    /// `session − device` clock offset at device time 0, s (IMUs, and location tags with a
    /// clock of their own, `rtls.clock`; 0 otherwise).
    pub clock_offset_s: f64,
    /// Device clock rate error, ppm (as `clock_offset_s`; 0 otherwise).
    pub clock_drift_ppm: f64,
    /// `segment_from_sensor` actually used, `[w, x, y, z]` (IMUs).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub segment_from_sensor_wxyz: Option<[f64; 4]>,
    /// Turn-on gyroscope bias, sensor frame, rad/s (IMUs).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gyro_bias_radps: Option<[f64; 3]>,
    /// Turn-on accelerometer bias, sensor frame, m/s² (IMUs).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub accel_bias_mps2: Option<[f64; 3]>,
    /// Messages emitted.
    pub num_messages: usize,
    /// Samples, fixes, cycles or polls lost.
    pub num_lost: usize,
    /// IMU samples whose accelerometer / gyroscope reading hit the sensor's range (clipped).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub num_saturated: Option<[usize; 2]>,
    /// Multiplier of the model's noise this device drew (scene `noise_scale` × its own draw,
    /// see [`DeviceDraw`]); absent when the device uses the model exactly.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub noise_multiplier: Option<f64>,
    /// Multiplier of the model's turn-on bias bounds this IMU drew; absent when exactly the
    /// model.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bias_multiplier: Option<f64>,
    /// Long-run loss fraction this device drew from its model's `loss.loss_fraction_range`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub loss_fraction: Option<f64>,
    /// Loss fraction of raw ranging cycles this UWB tag drew from
    /// `uwb_range.loss.loss_fraction_range`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub range_loss_fraction: Option<f64>,
}

/// The resolved scene, written as `scene.json` beside the recording.
#[derive(Debug, Clone, Serialize)]
pub struct SceneDescription {
    /// Always `nomen-scene`.
    pub format: &'static str,
    /// Version of this description.
    pub version: u32,
    /// The seed the scene was simulated with.
    pub seed: u64,
    /// The scenario with every default filled in.
    pub scenario: Scenario,
    /// The registry the recording carries.
    pub registry: Registry,
    /// Per-device hidden truth (clock offsets, mounting rotations, biases).
    pub devices: Vec<DeviceTruth>,
    /// Time span in which each person is in the scene, s.
    pub people_span_s: BTreeMap<String, (f64, f64)>,
}

impl SceneDescription {
    /// The registry with each worn device's prior clock offset replaced by the true one drawn
    /// by the simulator (devices without a truth keep their prior): what the engine would be
    /// given if clock offsets were known, the ablation of its offset search.
    pub fn registry_with_true_offsets(&self) -> Registry {
        let mut registry = self.registry.clone();
        for wearable in registry
            .subjects
            .iter_mut()
            .flat_map(|s| s.wears.iter_mut())
        {
            if let Some(truth) = self
                .devices
                .iter()
                .find(|d| d.device == wearable.device.as_str())
            {
                wearable.clock.offset_ns = (truth.clock_offset_s * 1e9).round() as i64;
            }
        }
        registry
    }
}

/// Everything a simulation produces.
#[derive(Debug, Clone)]
pub struct SimOutput {
    /// Sensor messages (skeletons, IMU samples, fixes, ranges, reads), unsorted.
    pub recording: Vec<Message>,
    /// Ground truth (`truth_skeleton`, `truth_tag`), unsorted.
    pub truth: Vec<Message>,
    /// The resolved scene.
    pub scene: SceneDescription,
    /// The static obstacles as a Wavefront OBJ mesh.
    pub obstacles_obj: String,
}

/// Simulates `scenario` with `seed`. `clips` holds every clip the people use, by library name.
/// `progress(stage, done_fraction)` is called as the work advances.
pub fn simulate(
    scenario: &Scenario,
    clips: &BTreeMap<String, MocapClip>,
    seed: u64,
    progress: &mut dyn FnMut(&str, f64),
) -> Result<SimOutput> {
    scenario.validate()?;
    check_scene_size(scenario)?;
    let library = scenario.clip_library();
    let duration_s = scenario.duration_s;

    // People.
    let mut motions: Vec<PersonMotion> = Vec::with_capacity(scenario.people.len());
    for p in &scenario.people {
        let clip_name = &p.motion.clip;
        let (Some(def), Some(clip)) = (library.get(clip_name), clips.get(clip_name)) else {
            return Err(SimError::InvalidScenario(format!(
                "person '{}': clip '{clip_name}' was not loaded",
                p.id
            )));
        };
        let source = ClipUse {
            clip,
            skip_frames: def.skip_frames,
            travels: Some(def.travels),
        };
        let motion = PersonMotion::new(&p.motion, source).map_err(|e| match e {
            SimError::InvalidScenario(why) => {
                SimError::InvalidScenario(format!("person '{}': {why}", p.id))
            }
            other => other,
        })?;
        motions.push(motion);
    }
    // Side-steps, when people avoid each other; without, every motion is exactly its clip's.
    let shifts = if scenario.avoidance.enabled {
        let planned: Vec<&dyn BodyMotion> = motions.iter().map(|m| m as &dyn BodyMotion).collect();
        plan_avoidance(&planned, 0.0, duration_s, &scenario.avoidance)
    } else {
        vec![None; motions.len()]
    };
    let motions: Vec<AvoidingMotion<'_>> = motions
        .iter()
        .zip(shifts)
        .map(|(m, shift)| AvoidingMotion::new(m, shift))
        .collect();
    let spans: Vec<Option<(f64, f64)>> = motions
        .iter()
        .map(|m| {
            let (a, b) = m.span_s();
            let (a, b) = (a.max(0.0), b.min(duration_s));
            (a < b).then_some((a, b))
        })
        .collect();
    progress("people", 1.0);

    let registry = build_registry(scenario)?;
    let mut recording = Vec::new();
    let mut truth = Vec::new();
    let mut held = HeldBytes::default();

    // Cameras.
    let people: Vec<PersonInScene<'_>> = scenario
        .people
        .iter()
        .zip(&motions)
        .map(|(p, m)| {
            PersonInScene::new(
                p.id.clone(),
                p.subject.as_ref().map(|s| SubjectId::new(s.clone())),
                m as &dyn BodyMotion,
            )
        })
        .collect();
    let num_cameras = scenario.cameras.len().max(1);
    for (i, cam) in scenario.cameras.iter().enumerate() {
        let model = CameraModel::new(cam.clone())?;
        let mut rng = stream(seed, &format!("camera/{}", cam.id));
        let relabel_rng = stream(seed, &format!("camera/{}/relabel", cam.id));
        let out = model.simulate_with_relabel_rng(
            &people,
            &scenario.room.obstacles,
            0.0,
            duration_s,
            &mut rng,
            relabel_rng,
        )?;
        let out = match &cam.position_only {
            Some(config) => {
                let mut point_rng = stream(seed, &format!("camera/{}/point", cam.id));
                to_position_only(out, &model, config, &mut point_rng)
            }
            None => out,
        };
        held.add_skeletons(out.observations.len(), out.truths.len());
        recording.extend(out.observations.into_iter().map(Message::from));
        truth.extend(out.truths.into_iter().map(Message::from));
        held.check(scenario, &recording, &truth)?;
        progress("cameras", (i + 1) as f64 / num_cameras as f64);
    }

    // Wearables.
    let anchors = registry.anchors.clone();
    let antennas = registry.antennas.clone();
    let radii = BodyRadii::default();
    let blocking =
        |t_s: f64, tag_position: Point3<f64>, antenna: &Point3<f64>, wearer: Option<usize>| {
            let bodies: Vec<BodyCapsules> = motions
                .iter()
                .zip(&spans)
                .map(|(m, span)| match span {
                    Some((a, b)) if (*a..=*b).contains(&t_s) && m.is_present_at(t_s) => {
                        BodyCapsules::from_pose(&m.pose_at(t_s), &radii)
                    }
                    // Someone not in the room blocks nothing: a capsule far below the floor.
                    _ => BodyCapsules::from_pose(&far_away_pose(), &radii),
                })
                .collect();
            count_blocking_bodies(&bodies, &tag_position, antenna, wearer)
        };
    // Whether the line from a tag at `site` of `carrier`, worn by person `wearer` (or by nobody),
    // to an anchor is blocked: by an obstacle, another person in the room, or the wearer's own
    // trunk for a tag on a limb (the camera's coarse self-occlusion).
    let line_is_blocked = |t_s: f64,
                           carrier: &dyn BodyMotion,
                           site: Joint,
                           wearer: Option<usize>,
                           anchor: &Point3<f64>| {
        let tag = carrier.joint_at(t_s, site).position_m;
        if obstacles_block_segment(&scenario.room.obstacles, &tag, anchor) {
            return true;
        }
        motions
            .iter()
            .zip(&spans)
            .enumerate()
            .any(|(k, (m, span))| {
                let is_in_room = matches!(span, Some((a, b)) if (*a..=*b).contains(&t_s))
                    && m.is_present_at(t_s);
                if !is_in_room {
                    return false;
                }
                let body = BodyCapsules::from_pose(&m.pose_at(t_s), &radii);
                if Some(k) == wearer {
                    is_limb(site)
                        && [Joint::Chest, Joint::Neck].iter().any(|b| {
                            body.bone(*b)
                                .is_some_and(|c| c.intersects_segment(&tag, anchor))
                        })
                } else {
                    body.intersects_segment(&tag, anchor)
                }
            })
    };
    let mut devices = Vec::new();
    let num_wear: usize = scenario
        .people
        .iter()
        .map(|p| p.wears.len())
        .sum::<usize>()
        .max(1);
    let mut done = 0usize;
    for (pi, p) in scenario.people.iter().enumerate() {
        let Some(own_span) = spans[pi] else { continue };
        for w in &p.wears {
            // What carries the device: its wearer, and after a change another person or a table.
            let carried = Carried::new(scenario, pi, w, &motions, &spans, own_span)?;
            let motion: &dyn BodyMotion = &carried.handover();
            let span = carried.span_s;
            let wearer_at = |t_s: f64| carried.wearer_at(t_s);
            // The spans during which the device is away with its wearer (silent or out of
            // coverage), as the wearer at each instant says.
            let is_away = |t_s: f64, only_if_silent: bool| {
                wearer_at(t_s).is_some_and(|k| {
                    scenario.people.get(k).is_some_and(|q| {
                        (!only_if_silent || q.motion.wearables_when_absent == WhenAbsent::Silent)
                            && is_in_spans(&q.motion.absent_s, t_s)
                    })
                })
            };
            let device = DeviceId::new(w.device.clone());
            let draw = device_draw(scenario, w, seed);
            let mut dt = DeviceTruth {
                device: w.device.clone(),
                kind: w.kind,
                person: p.id.clone(),
                clock_offset_s: 0.0,
                clock_drift_ppm: 0.0,
                segment_from_sensor_wxyz: None,
                gyro_bias_radps: None,
                accel_bias_mps2: None,
                num_messages: 0,
                num_lost: 0,
                num_saturated: None,
                noise_multiplier: None,
                bias_multiplier: None,
                loss_fraction: draw.loss_fraction,
                range_loss_fraction: draw.range_loss_fraction,
            };
            if !draw.is_identity() {
                dt.noise_multiplier = Some(draw.noise_multiplier);
                if w.kind == DeviceKind::Imu {
                    dt.bias_multiplier = Some(draw.bias_multiplier);
                }
            }
            match w.kind {
                DeviceKind::Imu => {
                    let mut rng = stream(seed, &format!("imu/{}", w.device));
                    let mount = Mount::at(w.site, UnitQuaternion::identity());
                    let mut config = scenario.sensors.imu.for_device(&draw);
                    config.rate_hz = w.rate_hz.unwrap_or(config.rate_hz);
                    config.gyro = w.gyro.unwrap_or(config.gyro);
                    let mut run = simulate_imu(motion, &device, &mount, span, &config, &mut rng)?;
                    if carried.may_be_away {
                        // Stamps are device time; the true clock says when each was taken.
                        let clock = run.truth.clock;
                        run.samples.retain(|sample| {
                            !is_away(clock.to_session_s(sample.t.as_secs_f64()), true)
                        });
                    }
                    let q = run.truth.mount.segment_from_sensor.quaternion();
                    dt.clock_offset_s = run.truth.clock.offset_s;
                    dt.clock_drift_ppm = run.truth.clock.drift_ppm;
                    dt.segment_from_sensor_wxyz = Some([q.w, q.i, q.j, q.k]);
                    dt.gyro_bias_radps = config.gyro.then(|| vec3(&run.truth.gyro_bias_radps));
                    dt.accel_bias_mps2 = Some(vec3(&run.truth.accel_bias_mps2));
                    dt.num_messages = run.samples.len();
                    dt.num_lost = run.truth.num_lost;
                    dt.num_saturated =
                        Some([run.truth.num_accel_saturated, run.truth.num_gyro_saturated]);
                    recording.extend(run.samples.into_iter().map(Message::Imu));
                }
                DeviceKind::UwbTag => {
                    let mut rng = stream(seed, &format!("rtls/{}", w.device));
                    let config = scenario.sensors.rtls.for_device(&draw);
                    let is_blocked = |t_s: f64, i: usize| {
                        anchors.get(i).is_some_and(|a| {
                            line_is_blocked(t_s, motion, w.site, wearer_at(t_s), &a.position_m)
                        })
                    };
                    let mut blocked_rng = stream(seed, &format!("rtls/{}/blocked", w.device));
                    let blocked = config.blocked_nlos_probability.map(|_| BlockedLines {
                        is_blocked: &is_blocked,
                        num_anchors: anchors.len(),
                        rng: &mut blocked_rng,
                    });
                    let mut run = simulate_rtls_blocked(
                        motion, w.site, &device, span, &config, &mut rng, blocked,
                    )?;
                    if carried.may_be_away {
                        // Away, the tag is out of the anchors' coverage: no fix describes an
                        // instant of absence.
                        let (fixes, truths) = run
                            .fixes
                            .into_iter()
                            .zip(run.truth)
                            .filter(|(fix, _)| {
                                !is_away(fix.t.as_secs_f64() - config.latency_s, false)
                            })
                            .unzip();
                        (run.fixes, run.truth) = (fixes, truths);
                    }
                    if config.planar {
                        for fix in &mut run.fixes {
                            fix.position_m.z = 0.0;
                        }
                    }
                    // The tag's own clock: its fixes (and their truth, which the evaluation
                    // pairs with them by stamp) carry its readings.
                    let tag_clock = config.clock.map(|c| {
                        let clock = c.draw(&mut stream(seed, &format!("rtls/{}/clock", w.device)));
                        dt.clock_offset_s = clock.offset_s;
                        dt.clock_drift_ppm = clock.drift_ppm;
                        clock
                    });
                    let restamp = |t: nomen_core::SessionTime| {
                        tag_clock
                            .and_then(|c| {
                                nomen_core::SessionTime::from_secs_f64(
                                    c.to_device_s(t.as_secs_f64()),
                                )
                            })
                            .unwrap_or(t)
                    };
                    if tag_clock.is_some() {
                        for fix in &mut run.fixes {
                            fix.t = restamp(fix.t);
                        }
                        for t in &mut run.truth {
                            t.t = restamp(t.t);
                        }
                    }
                    dt.num_messages = run.fixes.len();
                    dt.num_lost = run.num_lost;
                    recording.extend(run.fixes.into_iter().map(Message::RtlsFix));
                    truth.extend(run.truth.into_iter().map(Message::TruthTag));
                    if let Some(cfg) = &scenario.sensors.uwb_range {
                        let cfg = cfg.for_device(&draw);
                        let mut rng = stream(seed, &format!("uwb_range/{}", w.device));
                        let mut blocked_rng =
                            stream(seed, &format!("uwb_range/{}/blocked", w.device));
                        let blocked = cfg.blocked.as_ref().map(|_| BlockedLines {
                            is_blocked: &is_blocked,
                            num_anchors: anchors.len(),
                            rng: &mut blocked_rng,
                        });
                        let mut run = simulate_uwb_ranges_blocked(
                            motion, w.site, &device, &anchors, span, &cfg, &mut rng, blocked,
                        )?;
                        if carried.may_be_away {
                            run.ranges.retain(|r| !is_away(r.t.as_secs_f64(), false));
                        }
                        if tag_clock.is_some() {
                            for r in &mut run.ranges {
                                r.t = restamp(r.t);
                            }
                        }
                        dt.num_messages += run.ranges.len();
                        recording.extend(run.ranges.into_iter().map(Message::UwbRange));
                    }
                }
                DeviceKind::RfidTag | DeviceKind::BleTag => {
                    let mut rng = stream(seed, &format!("rssi/{}", w.device));
                    let site = w.site;
                    let count = |t_s: f64, antenna: usize| -> usize {
                        let tag = motion.joint_at(t_s, site).position_m;
                        antennas
                            .get(antenna)
                            .map_or(0, |a| blocking(t_s, tag, &a.position_m, wearer_at(t_s)))
                    };
                    let config = scenario.sensors.rssi.for_device(&draw);
                    let mut run = simulate_rssi(
                        motion, w.site, &device, &antennas, span, &count, &config, &mut rng,
                    )?;
                    if carried.may_be_away {
                        // Away, the tag is out of the antennas' range.
                        run.reads.retain(|r| !is_away(r.t.as_secs_f64(), false));
                    }
                    dt.num_messages = run.reads.len();
                    dt.num_lost = run.num_missed;
                    recording.extend(run.reads.into_iter().map(Message::Rssi));
                }
            }
            devices.push(dt);
            held.check(scenario, &recording, &truth)?;
            done += 1;
            progress("wearables", done as f64 / num_wear as f64);
        }
    }

    if scenario.has_wear_changes() {
        // Who is whom follows the devices: the truth of every frame after a change says so.
        for m in &mut truth {
            if let Message::TruthSkeleton(ts) = m {
                ts.subject = scenario
                    .subject_of_person_at(&ts.person, ts.t.as_secs_f64())
                    .map(SubjectId::new);
            }
        }
    }

    let people_span_s = scenario
        .people
        .iter()
        .zip(&spans)
        .filter_map(|(p, s)| s.map(|s| (p.id.clone(), s)))
        .collect();
    let scene = SceneDescription {
        format: "nomen-scene",
        version: 1,
        seed,
        scenario: scenario.clone(),
        registry,
        devices,
        people_span_s,
    };
    Ok(SimOutput {
        recording,
        truth,
        obstacles_obj: obstacles_to_obj(&scenario.room.obstacles),
        scene,
    })
}

/// What carries one worn device over the scene: its wearer, then, after a [`WearChange`],
/// another person or a table.
struct Carried<'m> {
    /// Index of the first wearer.
    wearer: usize,
    /// The change, with the new wearer's index for a move.
    change: Option<(f64, Option<usize>)>,
    before: &'m dyn BodyMotion,
    after: Option<&'m dyn BodyMotion>,
    still: Option<LyingStill>,
    /// Span over which the device sends, session s.
    span_s: (f64, f64),
    /// Whether some wearer of the device leaves the room at times.
    may_be_away: bool,
}

impl<'m> Carried<'m> {
    fn new<M: BodyMotion>(
        scenario: &Scenario,
        wearer: usize,
        w: &WearDef,
        motions: &'m [M],
        spans: &[Option<(f64, f64)>],
        own_span: (f64, f64),
    ) -> Result<Self> {
        let Some(before) = motions.get(wearer) else {
            return Err(SimError::InvalidScenario(format!(
                "device '{}': its wearer has no motion",
                w.device
            )));
        };
        let is_away_at_times = |k: usize| {
            scenario
                .people
                .get(k)
                .is_some_and(|p| !p.motion.absent_s.is_empty())
        };
        let mut carried = Self {
            wearer,
            change: None,
            before,
            after: None,
            still: None,
            span_s: own_span,
            may_be_away: is_away_at_times(wearer),
        };
        match &w.change {
            None => {}
            Some(WearChange::MovedTo { person, at_s }) => {
                let target = scenario
                    .people
                    .iter()
                    .position(|q| &q.id == person)
                    .and_then(|k| Some((k, motions.get(k)?)));
                let Some((k, motion)) = target else {
                    return Err(SimError::InvalidScenario(format!(
                        "device '{}': change.person '{person}' is not in the scene",
                        w.device
                    )));
                };
                carried.change = Some((*at_s, Some(k)));
                carried.after = Some(motion as &dyn BodyMotion);
                let end_s = spans.get(k).copied().flatten().map_or(own_span.1, |s| s.1);
                carried.span_s = (own_span.0, end_s.max(*at_s));
                carried.may_be_away |= is_away_at_times(k);
            }
            Some(WearChange::LeftAt { position_m, at_s }) => {
                carried.change = Some((*at_s, None));
                carried.span_s = (own_span.0, scenario.duration_s);
                carried.still = Some(LyingStill {
                    position_m: Point3::from(*position_m),
                    span_s: (*at_s, scenario.duration_s),
                });
            }
        }
        Ok(carried)
    }

    /// The carrier's motion over the whole span.
    fn handover(&self) -> Handover<'_> {
        match (self.change, self.after, &self.still) {
            (Some((at_s, _)), Some(after), _) => Handover {
                before: self.before,
                after,
                at_s,
            },
            (Some((at_s, _)), None, Some(still)) => Handover {
                before: self.before,
                after: still,
                at_s,
            },
            _ => Handover {
                before: self.before,
                after: self.before,
                at_s: f64::INFINITY,
            },
        }
    }

    /// Index of the person wearing the device at `t_s` (`None`: it lies on a table).
    fn wearer_at(&self, t_s: f64) -> Option<usize> {
        match self.change {
            Some((at_s, then)) if t_s >= at_s => then,
            _ => Some(self.wearer),
        }
    }
}

/// The most memory the messages of one simulated scene may take, bytes: 2 GiB, what the
/// commands that read a recording whole hold (a 60-s crowd of 128 people with one wrist IMU each
/// passes 1 GiB). [`simulate`] holds a whole scene (recording and truth) before it is
/// sorted and written. It refuses a
/// scene up front when one camera's skeletons, or the wearables' messages, are estimated past
/// this ([`CameraBytes`], [`wearable_message_bytes`]), and stops with the same error as soon as
/// the messages it holds pass it (counted after each camera and each wearable). Its peak memory
/// is this bound, plus one camera's skeletons or one wearable's messages, plus what the vectors
/// that hold them reserve beyond their length (at most as much again).
pub const MAX_SCENE_MESSAGE_BYTES: u64 = 2 << 30;

/// An upper estimate of the bytes one camera's skeletons and their truth take for `scenario`:
/// a skeleton message and its truth for every person at every frame.
pub struct CameraBytes;

impl CameraBytes {
    /// The bytes of one skeleton and its truth: two messages and the boxed skeletons.
    pub fn per_skeleton_pair() -> f64 {
        (2 * std::mem::size_of::<Message>()
            + std::mem::size_of::<nomen_core::SkeletonObservation>()
            + std::mem::size_of::<nomen_core::TruthSkeleton>()) as f64
    }

    /// The estimate for the camera running at `fps_hz`.
    pub fn estimate(scenario: &Scenario, fps_hz: f64) -> f64 {
        scenario.duration_s * fps_hz * scenario.people.len() as f64 * Self::per_skeleton_pair()
    }
}

/// An estimate of the bytes every wearable's messages take for `scenario`, at their rates
/// over the whole duration: an IMU sample, a tag's fix and its truth and a raw range to every
/// anchor, an RSSI read per antenna.
pub fn wearable_message_bytes(scenario: &Scenario) -> f64 {
    let s = &scenario.sensors;
    let messages_hz: f64 = scenario
        .people
        .iter()
        .flat_map(|p| &p.wears)
        .map(|w| match w.kind {
            DeviceKind::Imu => w.rate_hz.unwrap_or(s.imu.rate_hz),
            DeviceKind::UwbTag => {
                2.0 * s.rtls.rate_hz
                    + s.uwb_range
                        .as_ref()
                        .map_or(0.0, |r| r.rate_hz * scenario.anchors.len() as f64)
            }
            DeviceKind::RfidTag | DeviceKind::BleTag => {
                s.rssi.read_rate_hz * scenario.antennas.len() as f64
            }
        })
        .sum();
    scenario.duration_s * messages_hz * std::mem::size_of::<Message>() as f64
}

/// Refuses, before anything is simulated, a scene of which one camera's skeletons or the
/// wearables' messages are estimated past [`MAX_SCENE_MESSAGE_BYTES`].
fn check_scene_size(scenario: &Scenario) -> Result<()> {
    let largest_camera = scenario
        .cameras
        .iter()
        .map(|c| CameraBytes::estimate(scenario, c.fps_hz))
        .fold(0.0, f64::max);
    let estimate = largest_camera.max(wearable_message_bytes(scenario));
    if estimate <= MAX_SCENE_MESSAGE_BYTES as f64 {
        return Ok(());
    }
    let what = if largest_camera >= estimate {
        "one camera's skeletons"
    } else {
        "the wearables' messages"
    };
    Err(too_large(scenario, what, estimate))
}

/// The bytes of the messages a simulation holds so far.
#[derive(Default)]
struct HeldBytes {
    num_skeletons: usize,
    num_truth_skeletons: usize,
}

impl HeldBytes {
    fn add_skeletons(&mut self, num_skeletons: usize, num_truth_skeletons: usize) {
        self.num_skeletons += num_skeletons;
        self.num_truth_skeletons += num_truth_skeletons;
    }

    /// Refuses the scene once `recording` and `truth` pass [`MAX_SCENE_MESSAGE_BYTES`].
    fn check(&self, scenario: &Scenario, recording: &[Message], truth: &[Message]) -> Result<()> {
        let bytes = ((recording.len() + truth.len()) * std::mem::size_of::<Message>()
            + self.num_skeletons * std::mem::size_of::<nomen_core::SkeletonObservation>()
            + self.num_truth_skeletons * std::mem::size_of::<nomen_core::TruthSkeleton>())
            as f64;
        if bytes <= MAX_SCENE_MESSAGE_BYTES as f64 {
            return Ok(());
        }
        Err(too_large(scenario, "its messages so far", bytes))
    }
}

/// [`SimError::TooLarge`]: `what` takes `bytes`. The duration that surely fits is the one at
/// which every camera's estimate and the wearables' together are within the bound.
fn too_large(scenario: &Scenario, what: &str, bytes: f64) -> SimError {
    let num_wearables: usize = scenario.people.iter().map(|p| p.wears.len()).sum();
    let max = MAX_SCENE_MESSAGE_BYTES as f64;
    let upper: f64 = scenario
        .cameras
        .iter()
        .map(|c| CameraBytes::estimate(scenario, c.fps_hz))
        .sum::<f64>()
        + wearable_message_bytes(scenario);
    SimError::TooLarge {
        what: what.to_owned(),
        estimate_mib: bytes / (1 << 20) as f64,
        max_mib: MAX_SCENE_MESSAGE_BYTES >> 20,
        detail: format!(
            "{} people for {} s, {} cameras, {num_wearables} wearables",
            scenario.people.len(),
            scenario.duration_s,
            scenario.cameras.len(),
        ),
        max_duration_s: (scenario.duration_s * max / upper.max(bytes)).floor(),
    }
}

/// What device `w` draws around its kind's model (see [`DeviceDraw`]), from its stream
/// `spread/<device>`; the identity, without touching any stream, when nothing is spread.
fn device_draw(scenario: &Scenario, w: &WearDef, seed: u64) -> DeviceDraw {
    let s = &scenario.sensors;
    let (spread, loss_range, range_loss_range) = match w.kind {
        DeviceKind::Imu => (s.imu.device_spread, s.imu.loss.loss_fraction_range, None),
        DeviceKind::UwbTag => (
            s.rtls.device_spread,
            s.rtls.loss.loss_fraction_range,
            s.uwb_range
                .as_ref()
                .and_then(|r| r.loss.loss_fraction_range),
        ),
        DeviceKind::RfidTag | DeviceKind::BleTag => (s.rssi.device_spread, None, None),
    };
    if spread == 1.0 && s.noise_scale == 1.0 && loss_range.is_none() && range_loss_range.is_none() {
        return DeviceDraw::IDENTITY;
    }
    let mut rng = stream(seed, &format!("spread/{}", w.device));
    DeviceDraw::draw(
        s.noise_scale,
        spread,
        loss_range,
        range_loss_range,
        &mut rng,
    )
}

fn vec3(v: &Vector3<f64>) -> [f64; 3] {
    [v.x, v.y, v.z]
}

/// A pose far below the floor, for people outside their span (they block nothing).
fn far_away_pose() -> crate::body::BodyPose {
    let mut pose = crate::body::BodyPose::new();
    for (i, j) in nomen_core::Joint::ALL.into_iter().enumerate() {
        pose.insert(
            j,
            crate::body::JointPose {
                position_m: Point3::new(0.0, 0.0, -1000.0 - i as f64 * 0.01),
                world_from_joint: UnitQuaternion::identity(),
            },
        );
    }
    pose
}

/// The registry the engine is told about: subjects and what they wear where, cameras, anchors,
/// antennas. Device clocks are unknown to the engine (zero), as in a real deployment.
pub fn build_registry(scenario: &Scenario) -> Result<Registry> {
    let subjects = scenario
        .people
        .iter()
        .filter_map(|p| {
            p.subject.as_ref().map(|s| Subject {
                id: SubjectId::new(s.clone()),
                name: None,
                wears: p
                    .wears
                    .iter()
                    .map(|w| Wearable {
                        device: DeviceId::new(w.device.clone()),
                        kind: w.kind,
                        site: w.site,
                        either_side: w.either_side,
                        clock: Default::default(),
                    })
                    .collect(),
            })
        })
        .collect();
    let cameras = scenario
        .cameras
        .iter()
        .map(|c| CameraModel::new(c.clone()).map(|m| m.registry_camera()))
        .collect::<Result<Vec<_>>>()?;
    let anchors = scenario
        .anchors
        .iter()
        .map(|a| Anchor {
            id: AnchorId::new(a.id.clone()),
            position_m: Point3::from(a.position_m),
        })
        .collect();
    let antennas = scenario
        .antennas
        .iter()
        .map(|a| Antenna {
            id: AntennaId::new(a.id.clone()),
            position_m: Point3::from(a.position_m),
            boresight: a.boresight.map(Vector3::from),
        })
        .collect();
    let registry = Registry {
        subjects,
        cameras,
        anchors,
        antennas,
    };
    registry
        .validate()
        .map_err(|e| SimError::InvalidScenario(format!("registry: {e}")))?;
    Ok(registry)
}
