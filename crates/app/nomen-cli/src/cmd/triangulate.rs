//! `nomen triangulate`: 2D keypoints of calibrated cameras → a recording of world-frame
//! skeletons with track ids; and `nomen experiment triangulation`, its accuracy on motion
//! capture projected into virtual cameras.

use super::mocap::write_recording;
use anyhow::{Context, Result, bail};
use clap::Args;
use nalgebra::Point3;
use nomen_core::bounded::Limits;
use nomen_core::skeleton::Joints;
use nomen_core::{Camera, CameraId, Message, Registry, RigidTransform, SessionTime};
use nomen_multiview::keypoints::last_number;
use nomen_multiview::synth::{
    DetectionNoise, JointErrors, detect, measure, room_camera_intrinsics, room_rig, walkers_scene,
};
use nomen_multiview::{
    CameraFile, Detection, KeypointLimits, ReconstructionConfig, Tracker, TrackerConfig,
    parse_camera_file, parse_keypoints, reconstruct_frame,
};
use nomen_recording::{Header, sort_for_writing};
use rand::SeedableRng;
use serde::Serialize;
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Arguments of `nomen triangulate`.
#[derive(Debug, Args)]
pub struct TriangulateArgs {
    /// The rig: intrinsics, distortion and pose of every camera, the frame rate of the keypoint
    /// files, and optionally where each camera's keypoints are (docs/multiview.md).
    #[arg(long)]
    cameras: PathBuf,
    /// Keypoints per view: `CAMERA=PATH`, or a PATH whose file or folder name (without
    /// extension) is a camera id. A folder holds one JSON file per frame (OpenPose, MMPose per
    /// image; the frame number is the last number in the file name), a file holds one frame or
    /// many (COCO, MMPose video). Without any, the cameras file's `keypoints` entries are used.
    views: Vec<String>,
    /// Output recording (`-` for stdout).
    #[arg(long)]
    out: PathBuf,
    /// A registry (JSON, as in a recording header) to put in the output's header, e.g. the
    /// subjects and their wearables; the triangulated camera is added to it.
    #[arg(long)]
    registry: Option<PathBuf>,
    /// The camera id of the output skeletons (a registry camera whose frame is the world).
    #[arg(long, default_value = "multiview")]
    camera_id: String,
    /// Largest mean ray-to-ray distance between two detections of one person, metres.
    #[arg(long)]
    max_ray_distance_m: Option<f64>,
    /// A view whose reprojection error exceeds this is left out of a joint, pixels.
    #[arg(long)]
    reprojection_gate_px: Option<f64>,
}

/// Runs `nomen triangulate`.
pub fn run(args: TriangulateArgs) -> Result<()> {
    crate::io::check_distinct(
        &[Some(&args.cameras), args.registry.as_deref()],
        &[Some(&args.out)],
    )?;
    let rig = parse_camera_file(
        &crate::io::read_settings(&args.cameras)?,
        &args.cameras.display().to_string(),
    )?;
    let mut config = ReconstructionConfig::default();
    if let Some(d) = args.max_ray_distance_m {
        config.association.max_ray_distance_m = d;
    }
    if let Some(g) = args.reprojection_gate_px {
        config.triangulation.reprojection_gate_px = g;
    }
    config.validate()?;
    let sources = view_sources(&rig, &args.cameras, &args.views)?;
    let limits = KeypointLimits::default();
    // frames[frame][view]: the detections of every view at every frame number.
    let mut frames: BTreeMap<u64, Vec<Vec<Detection>>> = BTreeMap::new();
    let num_views = rig.cameras.len();
    for (view, path) in &sources {
        for (frame, detections) in read_view(path, &limits)? {
            let slot = frames
                .entry(frame)
                .or_insert_with(|| vec![Vec::new(); num_views]);
            slot[*view] = detections;
        }
    }
    let camera_id = CameraId::new(args.camera_id.clone());
    let mut tracker = Tracker::new(camera_id.clone(), TrackerConfig::default())?;
    let mut messages: Vec<Message> = Vec::new();
    let (mut num_detections, mut num_unassociated, mut num_skeletons) = (0, 0, 0);
    let mut reprojection_px: Vec<f64> = Vec::new();
    for (frame, views) in &frames {
        let t_s = rig.start_s + *frame as f64 / rig.fps_hz;
        let Some(t) = SessionTime::from_secs_f64(t_s) else {
            bail!("frame {frame} is at {t_s} s, beyond the session clock");
        };
        let out = reconstruct_frame(&rig.cameras, views, &config);
        num_detections += out.num_detections;
        num_unassociated += out.num_unassociated;
        num_skeletons += out.skeletons.len();
        for s in &out.skeletons {
            reprojection_px.extend(s.joints.iter().map(|(_, j)| j.rms_reprojection_px));
        }
        messages.extend(
            tracker
                .push(t, &out.skeletons)
                .into_iter()
                .map(|o| Message::Skeleton(Box::new(o))),
        );
    }
    let mut registry = match &args.registry {
        Some(path) => serde_json::from_str::<Registry>(&crate::io::read_settings(path)?)
            .with_context(|| format!("{}: not a registry", path.display()))?,
        None => Registry::default(),
    };
    if registry.camera(&camera_id).is_some() {
        bail!(
            "the registry already has a camera '{camera_id}': pass another --camera-id for the \
             triangulated skeletons"
        );
    }
    registry.cameras.push(Camera {
        id: camera_id.clone(),
        world_from_camera: RigidTransform::IDENTITY,
        scale: 1.0,
        intrinsics: None,
        fps_hz: Some(rig.fps_hz),
        clock: Default::default(),
    });
    let header = Header::new(registry)
        .with_meta("generator", "nomen triangulate")
        .with_meta("cameras", args.cameras.display().to_string());
    sort_for_writing(&mut messages);
    write_recording(&args.out, &header, &messages)?;
    reprojection_px.sort_by(f64::total_cmp);
    let median_px = reprojection_px
        .get(reprojection_px.len() / 2)
        .copied()
        .unwrap_or(f64::NAN);
    eprintln!(
        "{} frames from {} views: {num_detections} detections, {num_unassociated} in no \
         multi-view person; {num_skeletons} skeletons triangulated (median joint reprojection \
         error {median_px:.2} px); wrote {} skeletons of {} tracks to {}",
        frames.len(),
        sources.len(),
        messages.len(),
        messages
            .iter()
            .filter_map(|m| match m {
                Message::Skeleton(s) => Some(s.track),
                _ => None,
            })
            .collect::<std::collections::BTreeSet<_>>()
            .len(),
        crate::io::sink_name(&args.out)
    );
    Ok(())
}

/// Each view's keypoint path, by camera index: from the command line, else the cameras file.
fn view_sources(
    rig: &CameraFile,
    cameras_path: &Path,
    views: &[String],
) -> Result<Vec<(usize, PathBuf)>> {
    let index_of = |id: &str| rig.cameras.iter().position(|c| c.id.as_str() == id);
    let mut out: Vec<(usize, PathBuf)> = Vec::new();
    if views.is_empty() {
        let base = cameras_path.parent().unwrap_or(Path::new("."));
        for (i, k) in rig.keypoints.iter().enumerate() {
            if let Some(k) = k {
                out.push((i, base.join(k)));
            }
        }
        if out.is_empty() {
            bail!(
                "no keypoints given: name them on the command line (CAMERA=PATH) or in {} \
                 (`keypoints = \"...\"` per camera)",
                cameras_path.display()
            );
        }
    } else {
        for v in views {
            let (id, path) = match v.split_once('=') {
                Some((id, path)) => (id.to_owned(), PathBuf::from(path)),
                None => {
                    let path = PathBuf::from(v);
                    let stem = path
                        .file_stem()
                        .map(|s| s.to_string_lossy().into_owned())
                        .unwrap_or_default();
                    (stem, path)
                }
            };
            let Some(i) = index_of(&id) else {
                let known: Vec<&str> = rig.cameras.iter().map(|c| c.id.as_str()).collect();
                bail!(
                    "'{v}': no camera '{id}' in {} (cameras: {}); write CAMERA=PATH",
                    cameras_path.display(),
                    known.join(", ")
                );
            };
            out.push((i, path));
        }
    }
    for (k, (i, _)) in out.iter().enumerate() {
        if out[..k].iter().any(|(j, _)| j == i) {
            bail!("camera '{}' is given keypoints twice", rig.cameras[*i].id);
        }
    }
    Ok(out)
}

/// One view's detections per frame number, from a folder of per-frame files or one file.
fn read_view(path: &Path, limits: &KeypointLimits) -> Result<BTreeMap<u64, Vec<Detection>>> {
    let files: Vec<PathBuf> = if path.is_dir() {
        let mut files: Vec<PathBuf> = std::fs::read_dir(path)
            .with_context(|| format!("cannot read the folder {}", path.display()))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| {
                p.extension()
                    .is_some_and(|e| e.eq_ignore_ascii_case("json"))
            })
            .collect();
        files.sort();
        if files.is_empty() {
            bail!("{}: no .json keypoint files in the folder", path.display());
        }
        files
    } else {
        vec![path.to_owned()]
    };
    let mut out: BTreeMap<u64, Vec<Detection>> = BTreeMap::new();
    for (position, file) in files.iter().enumerate() {
        let name = file.display().to_string();
        let frame_of_file = file
            .file_name()
            .and_then(|n| last_number(&n.to_string_lossy()))
            .unwrap_or(position as u64);
        // Read as a stream within the document limit, whatever size the file system reports.
        let text = crate::io::read_text(
            file,
            Limits::text(
                "a keypoint file",
                limits.max_bytes as u64,
                limits.max_bytes as u64,
            ),
        )?;
        let doc = parse_keypoints(&text, &name, frame_of_file, limits)?;
        for frame in doc.frames {
            if out.insert(frame.frame, frame.detections).is_some() {
                bail!(
                    "{name}: frame {} of this view is given twice (in {})",
                    frame.frame,
                    path.display()
                );
            }
        }
    }
    Ok(out)
}

/// Arguments of `nomen experiment triangulation`.
#[derive(Debug, Args)]
pub struct TriangulationExperimentArgs {
    /// Print one JSON object instead of the table.
    #[arg(long)]
    json: bool,
    /// Seeds 1..=N, pooled.
    #[arg(long, default_value_t = 3)]
    seeds: u64,
    /// Probability that a visible joint is not detected.
    #[arg(long, default_value_t = 0.1)]
    miss_rate: f64,
    /// Probability that a detected joint is put at a random pixel.
    #[arg(long, default_value_t = 0.02)]
    false_joint_rate: f64,
    /// Mean number of false people per view and frame.
    #[arg(long, default_value_t = 0.5)]
    false_people: f64,
    /// Folder with the shared real recordings (default: $NOMEN_DATA, else ../shared/data);
    /// without it, synthetic walkers stand in for the motion capture.
    #[arg(long)]
    data: Option<PathBuf>,
    /// Also compare the engine's identification accuracy on a simulated scene (imu_wrist_3)
    /// with its 3D skeletons and with skeletons triangulated from three cameras at 1 px (needs
    /// the shared data).
    #[arg(long)]
    identity: bool,
}

/// Virtual room: cameras 2.8 m high in the corners of an 8 m × 8 m room.
const ROOM_HALF_SIDE_M: f64 = 4.0;
const CAMERA_HEIGHT_M: f64 = 2.8;
const VIEW_COUNTS: [usize; 3] = [2, 3, 4];
const PIXEL_NOISES_PX: [f64; 3] = [1.0, 2.0, 4.0];

#[derive(Debug, Serialize)]
struct Cell {
    num_views: usize,
    pixel_noise_px: f64,
    median_error_m: Option<f64>,
    p95_error_m: Option<f64>,
    people_found: f64,
    false_skeletons_per_frame: f64,
}

#[derive(Debug, Serialize)]
struct Table {
    motion: String,
    num_frames: usize,
    seeds: u64,
    miss_rate: f64,
    false_joint_rate: f64,
    false_people_per_view: f64,
    cells: Vec<Cell>,
}

/// The true joints of every person, per frame.
type Frames = Vec<Vec<Joints<Point3<f64>>>>;

/// CMU 18_01 + 19_01 (two people walk up and shake hands) at 60 Hz after the T-pose, and the
/// middle of where they stand; `None` without the shared data.
fn handshake(data: Option<&Path>) -> Result<Option<(Frames, Point3<f64>)>> {
    let Ok(data) = crate::io::find_data(data) else {
        return Ok(None);
    };
    let dir = data.join("mocap/cmu");
    let options = nomen_mocap::ConvertOptions {
        scale: Some(0.056_444_4),
        grounding: nomen_mocap::Grounding::LowestFootToZero,
        ..Default::default()
    };
    let (a, b) = nomen_mocap::convert_pair(
        &nomen_mocap::read_bvh_file(&dir.join("18_01.bvh"))?,
        &nomen_mocap::read_bvh_file(&dir.join("19_01.bvh"))?,
        &options,
    )?;
    let frames: Frames = a
        .frames
        .iter()
        .zip(&b.frames)
        .skip(1)
        .step_by(2)
        .map(|(fa, fb)| vec![fa.map(|_, p| p.position_m), fb.map(|_, p| p.position_m)])
        .collect();
    let pelvises: Vec<Point3<f64>> = frames
        .iter()
        .flatten()
        .filter_map(|p| p.get(nomen_core::Joint::Pelvis).copied())
        .collect();
    if pelvises.is_empty() {
        bail!("18_01/19_01: no frames");
    }
    let mean = pelvises
        .iter()
        .map(|p| p.coords)
        .sum::<nalgebra::Vector3<f64>>()
        / pelvises.len() as f64;
    Ok(Some((frames, Point3::new(mean.x, mean.y, 0.0))))
}

/// Runs `nomen experiment triangulation`.
pub fn run_experiment(args: TriangulationExperimentArgs) -> Result<()> {
    let (motion, frames, centre) = match handshake(args.data.as_deref())? {
        Some((frames, centre)) => (
            "CMU 18_01 + 19_01 (handshake, 60 Hz)".to_owned(),
            frames,
            centre,
        ),
        None => {
            eprintln!("shared data not found: synthetic walkers stand in for the motion capture");
            (
                "three synthetic walkers (10 Hz)".to_owned(),
                walkers_scene(Point3::origin(), 60, 10.0),
                Point3::origin(),
            )
        }
    };
    let mut cells = Vec::new();
    for num_views in VIEW_COUNTS {
        let Some(cameras) = room_rig(
            num_views,
            centre,
            ROOM_HALF_SIDE_M,
            CAMERA_HEIGHT_M,
            room_camera_intrinsics(),
        ) else {
            bail!("no rig of {num_views} views");
        };
        for pixel_noise_px in PIXEL_NOISES_PX {
            let noise = DetectionNoise {
                pixel_noise_px,
                miss_rate: args.miss_rate,
                false_joint_rate: args.false_joint_rate,
                false_people_per_view: args.false_people,
            };
            let mut pooled = JointErrors::default();
            for seed in 1..=args.seeds {
                let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
                let e = measure(
                    &cameras,
                    &frames,
                    &noise,
                    ROOM_HALF_SIDE_M,
                    &ReconstructionConfig::default(),
                    &mut rng,
                );
                pooled.errors_m.extend(e.errors_m);
                pooled.num_true += e.num_true;
                pooled.num_matched += e.num_matched;
                pooled.num_false += e.num_false;
            }
            let num_frames = (frames.len() as u64 * args.seeds).max(1) as f64;
            cells.push(Cell {
                num_views,
                pixel_noise_px,
                median_error_m: pooled.quantile_m(0.5),
                p95_error_m: pooled.quantile_m(0.95),
                people_found: pooled.num_matched as f64 / pooled.num_true.max(1) as f64,
                false_skeletons_per_frame: pooled.num_false as f64 / num_frames,
            });
        }
    }
    let table = Table {
        motion,
        num_frames: frames.len(),
        seeds: args.seeds,
        miss_rate: args.miss_rate,
        false_joint_rate: args.false_joint_rate,
        false_people_per_view: args.false_people,
        cells,
    };
    let identity = if args.identity {
        let noise = DetectionNoise {
            pixel_noise_px: 1.0,
            miss_rate: args.miss_rate,
            false_joint_rate: args.false_joint_rate,
            false_people_per_view: args.false_people,
        };
        Some(identity_comparison(&args, &noise)?)
    } else {
        None
    };
    let mut out = std::io::stdout().lock();
    if args.json {
        let both = serde_json::json!({ "accuracy": table, "identity": identity });
        writeln!(out, "{}", serde_json::to_string_pretty(&both)?)?;
        return Ok(());
    }
    writeln!(
        out,
        "{}: {} frames x {} seeds; cameras 2.8 m high in the corners of an 8 m room, 1920x1080, \
         90 deg, barrel distortion\nmissed joints {:.0} %, random joints {:.0} %, false people \
         {} per view and frame\n",
        table.motion,
        table.num_frames,
        table.seeds,
        100.0 * table.miss_rate,
        100.0 * table.false_joint_rate,
        table.false_people_per_view
    )?;
    writeln!(
        out,
        "{:>5} {:>6} {:>11} {:>8} {:>7} {:>12}",
        "views", "noise", "median", "p95", "found", "false/frame"
    )?;
    let mm = |v: Option<f64>| v.map_or("-".to_owned(), |v| format!("{:.1} mm", 1e3 * v));
    for c in &table.cells {
        writeln!(
            out,
            "{:>5} {:>3} px {:>11} {:>8} {:>6.1}% {:>12.3}",
            c.num_views,
            c.pixel_noise_px,
            mm(c.median_error_m),
            mm(c.p95_error_m),
            100.0 * c.people_found,
            c.false_skeletons_per_frame
        )?;
    }
    if let Some(c) = identity {
        writeln!(
            out,
            "\nidentification accuracy, {} (seed {}): {} with its 3D skeletons, {} with skeletons \
             triangulated from 3 views at {} px ({} skeletons, {} tracks)",
            c.scenario,
            c.seed,
            super::experiment::fmt_pct(c.accuracy_3d),
            super::experiment::fmt_pct(c.accuracy_triangulated),
            c.pixel_noise_px,
            c.num_triangulated_skeletons,
            c.num_triangulated_tracks
        )?;
    }
    Ok(())
}

/// The scene of the identity comparison: three people walking loops, one wrist IMU each.
const IDENTITY_SCENE: (&str, &str) = (
    "imu_wrist_3.toml",
    include_str!("../../../../../scenarios/imu_wrist_3.toml"),
);

/// Identification accuracy of the engine on a simulated scene's own 3D skeletons and on
/// skeletons triangulated from 2D keypoints of its people in three corner cameras.
#[derive(Debug, Serialize)]
struct IdentityComparison {
    scenario: String,
    seed: u64,
    pixel_noise_px: f64,
    accuracy_3d: Option<f64>,
    accuracy_triangulated: Option<f64>,
    num_triangulated_skeletons: usize,
    num_triangulated_tracks: usize,
}

/// Simulates `IDENTITY_SCENE`, runs the engine on it, then replaces its skeletons by ones
/// triangulated from the true joints projected into three cameras around the room (with
/// `noise`), gives them the truth of the nearest true person, and runs the engine again.
fn identity_comparison(
    args: &TriangulationExperimentArgs,
    noise: &DetectionNoise,
) -> Result<IdentityComparison> {
    let (name, text) = IDENTITY_SCENE;
    let (scenario, sim, seed) =
        super::experiment::simulate_for_experiment(text, name, 1, args.data.as_deref())?;
    let config = nomen_engine::EngineConfig::default();
    let eval = nomen_eval::identity::EvalConfig::default();
    let (result, _) = nomen_engine::run_batch(&sim.scene.registry, &sim.recording, &config)?;
    let scene = nomen_eval::identity::SceneData::from_messages(&scenario.name, &sim.truth, &result);
    let accuracy_3d = nomen_eval::identity::evaluate(&[scene], &eval)?
        .overall
        .id_accuracy;

    // The true people at every instant a camera saw someone, by person.
    type Person = (Option<nomen_core::SubjectId>, Joints<Point3<f64>>);
    let mut truth_frames: BTreeMap<SessionTime, BTreeMap<String, Person>> = BTreeMap::new();
    for m in &sim.truth {
        if let Message::TruthSkeleton(s) = m
            && !s.joints_world_m.is_empty()
        {
            truth_frames.entry(s.t).or_default().insert(
                s.person.clone(),
                (s.subject.clone(), s.joints_world_m.clone()),
            );
        }
    }
    let pelvises: Vec<Point3<f64>> = truth_frames
        .values()
        .flat_map(|people| people.values())
        .filter_map(|(_, joints)| joints.get(nomen_core::Joint::Pelvis).copied())
        .collect();
    if pelvises.is_empty() {
        bail!("{name}: the truth has no joints");
    }
    let mean = pelvises
        .iter()
        .map(|p| p.coords)
        .sum::<nalgebra::Vector3<f64>>()
        / pelvises.len() as f64;
    let centre = Point3::new(mean.x, mean.y, 0.0);
    let half_side_m = pelvises
        .iter()
        .map(|p| (p.x - centre.x).abs().max((p.y - centre.y).abs()))
        .fold(0.0, f64::max)
        + 2.0;
    let Some(cameras) = room_rig(
        3,
        centre,
        half_side_m,
        CAMERA_HEIGHT_M,
        room_camera_intrinsics(),
    ) else {
        bail!("no rig");
    };
    let camera_id = CameraId::new("multiview");
    let mut tracker = Tracker::new(camera_id.clone(), TrackerConfig::default())?;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut skeletons: Vec<Message> = Vec::new();
    let mut truth: Vec<Message> = sim
        .truth
        .iter()
        .filter(|m| !matches!(m, Message::TruthSkeleton(_)))
        .cloned()
        .collect();
    for (t, people) in &truth_frames {
        let joints: Vec<Joints<Point3<f64>>> = people.values().map(|(_, j)| j.clone()).collect();
        let views = detect(&cameras, &joints, noise, half_side_m, &mut rng);
        let frame = reconstruct_frame(&cameras, &views, &ReconstructionConfig::default());
        for s in tracker.push(*t, &frame.skeletons) {
            let Some(at) = s
                .position(nomen_core::Joint::Pelvis)
                .or_else(|| s.joint_centroid_m())
            else {
                continue;
            };
            let nearest = people
                .iter()
                .filter_map(|(person, (subject, j))| {
                    let d = (j.get(nomen_core::Joint::Pelvis)? - at).norm();
                    Some((d, person, subject, j))
                })
                .min_by(|a, b| a.0.total_cmp(&b.0));
            if let Some((d, person, subject, j)) = nearest
                && d <= nomen_multiview::synth::MATCH_DISTANCE_M
            {
                truth.push(Message::TruthSkeleton(Box::new(
                    nomen_core::TruthSkeleton {
                        t: *t,
                        camera: camera_id.clone(),
                        track: s.track,
                        person: person.clone(),
                        subject: subject.clone(),
                        joints_world_m: j.clone(),
                    },
                )));
            }
            skeletons.push(Message::Skeleton(Box::new(s)));
        }
    }
    let num_triangulated_skeletons = skeletons.len();
    let num_triangulated_tracks = skeletons
        .iter()
        .filter_map(|m| match m {
            Message::Skeleton(s) => Some(s.track),
            _ => None,
        })
        .collect::<std::collections::BTreeSet<_>>()
        .len();
    let mut recording: Vec<Message> = sim
        .recording
        .iter()
        .filter(|m| !matches!(m, Message::Skeleton(_)))
        .cloned()
        .chain(skeletons)
        .collect();
    sort_for_writing(&mut recording);
    sort_for_writing(&mut truth);
    let mut registry = sim.scene.registry.clone();
    registry.cameras.push(Camera {
        id: camera_id,
        world_from_camera: RigidTransform::IDENTITY,
        scale: 1.0,
        intrinsics: None,
        fps_hz: None,
        clock: Default::default(),
    });
    let (result, _) = nomen_engine::run_batch(&registry, &recording, &config)?;
    let scene = nomen_eval::identity::SceneData::from_messages(&scenario.name, &truth, &result);
    let accuracy_triangulated = nomen_eval::identity::evaluate(&[scene], &eval)?
        .overall
        .id_accuracy;
    Ok(IdentityComparison {
        scenario: scenario.name,
        seed,
        pixel_noise_px: noise.pixel_noise_px,
        accuracy_3d,
        accuracy_triangulated,
        num_triangulated_skeletons,
        num_triangulated_tracks,
    })
}
