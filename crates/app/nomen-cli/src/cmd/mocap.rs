//! `nomen mocap convert`: BVH or ASF/AMC motion capture → a skeleton recording (and optional
//! ground truth).

use anyhow::{Context, Result, bail};
use clap::{Args, Subcommand};
use nomen_core::message::TruthSkeleton;
use nomen_core::{Camera, CameraId, Message, Registry, SessionTime, TrackId};
use nomen_mocap::{
    ConvertOptions, Grounding, MocapClip, convert, convert_pair, read_asf_amc_files, read_bvh_file,
};
use nomen_recording::{Header, RecordingWriter, sort_for_writing};
use std::path::{Path, PathBuf};

/// `nomen mocap ...`
#[derive(Debug, Subcommand)]
pub enum MocapCommand {
    /// Convert BVH files (or CMU AMC takes with `--asf`) into one skeleton recording on one
    /// clock (exact forward kinematics, Y-up → Z-up, canonical joints).
    Convert(ConvertArgs),
}

/// Arguments of `nomen mocap convert`.
#[derive(Debug, Args)]
pub struct ConvertArgs {
    /// BVH file(s), or AMC file(s) with `--asf`. Several files become several people on the
    /// same clock and in the same frame (e.g. the two halves of a two-person take such as
    /// 18_01 + 19_01).
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
    /// The ASF skeleton of the AMC files (CMU's native format: one skeleton per subject, e.g.
    /// `mocap/cmu-asfamc/02.asf` for `02_05.amc`; 120 Hz unless `--fps`).
    #[arg(long)]
    pub asf: Option<PathBuf>,
    /// File length unit → metres (BVH has no unit; CMU files are 0.0564444, centimetres 0.01).
    #[arg(long)]
    pub scale: Option<f64>,
    /// True frame rate in Hz, overriding the header's `Frame Time` (headers lie).
    #[arg(long)]
    pub fps: Option<f64>,
    /// Shift everything down so that the lowest foot point over the clip(s) touches z = 0.
    #[arg(long)]
    pub ground: bool,
    /// Camera id the skeletons are reported under (a camera at the world origin).
    #[arg(long, default_value = "mocap")]
    pub camera: String,
    /// Output recording (`-` for stdout).
    #[arg(long)]
    pub out: PathBuf,
    /// Also write ground truth (`truth_skeleton` messages: person = file stem, no subject).
    #[arg(long)]
    pub truth: Option<PathBuf>,
}

/// Runs `nomen mocap ...`.
pub fn run(command: MocapCommand) -> Result<()> {
    match command {
        MocapCommand::Convert(args) => {
            let (summary, _) = convert_files(&args)?;
            eprintln!("{summary}");
            Ok(())
        }
    }
}

/// Converts the files of `args` and writes the recording (and truth); returns a summary and the
/// converted clips.
pub fn convert_files(args: &ConvertArgs) -> Result<(String, Vec<MocapClip>)> {
    let inputs: Vec<Option<&Path>> = args.files.iter().map(|f| Some(f.as_path())).collect();
    crate::io::check_distinct(&inputs, &[Some(&args.out), args.truth.as_deref()])?;
    // The flags, named as flags (the registry's checks would name the output's header).
    if args.camera.trim().is_empty() {
        bail!("--camera: the camera id is empty");
    }
    let (lo, hi) = nomen_core::registry::CAMERA_FPS_RANGE_HZ;
    if let Some(fps) = args.fps
        && !(fps.is_finite() && (lo..=hi).contains(&fps))
    {
        bail!("--fps {fps}: a camera's frame rate, {lo} to {hi} Hz");
    }
    let options = ConvertOptions {
        scale: args.scale,
        fps_hz: args.fps,
        grounding: if args.ground {
            Grounding::LowestFootToZero
        } else {
            Grounding::Keep
        },
        ..Default::default()
    };
    let clips = load_clips(&args.files, args.asf.as_deref(), &options)?;
    let camera = CameraId::new(args.camera.clone());
    let registry = Registry {
        cameras: vec![Camera {
            id: camera.clone(),
            world_from_camera: Default::default(),
            scale: 1.0,
            intrinsics: None,
            fps_hz: clips.first().map(|c| c.rate_hz),
            clock: Default::default(),
        }],
        ..Default::default()
    };

    let mut skeletons = Vec::new();
    let mut truth = Vec::new();
    let mut summary = String::new();
    for (i, (path, clip)) in args.files.iter().zip(&clips).enumerate() {
        for w in &clip.warnings {
            eprintln!("{}: warning: {w}", path.display());
        }
        let track = TrackId(i as u64 + 1);
        let person = person_name(path);
        let obs = clip.to_skeletons(camera.clone(), track, SessionTime::ZERO);
        for o in &obs {
            truth.push(Message::TruthSkeleton(Box::new(TruthSkeleton {
                t: o.t,
                camera: o.camera.clone(),
                track: o.track,
                person: person.clone(),
                subject: None,
                joints_world_m: o.joints.map(|_, j| j.position_m),
            })));
        }
        skeletons.extend(obs.into_iter().map(Message::from));
        summary.push_str(&format!(
            "{}: {} frames at {} Hz ({:.2} s), scale {}, variant {:?} → track {}\n",
            path.display(),
            clip.num_frames,
            clip.rate_hz,
            clip.duration_s(),
            clip.scale,
            clip.mapping.variant,
            track
        ));
    }
    sort_for_writing(&mut skeletons);
    let header = Header::new(registry.clone())
        .with_meta("generator", "nomen mocap convert")
        .with_meta("sources", source_list(&args.files));
    write_recording(&args.out, &header, &skeletons)?;
    summary.push_str(&format!(
        "wrote {} skeleton messages to {}",
        skeletons.len(),
        crate::io::sink_name(&args.out)
    ));
    if let Some(truth_path) = &args.truth {
        sort_for_writing(&mut truth);
        let header = Header::new(registry)
            .with_meta("generator", "nomen mocap convert")
            .with_meta("kind", "truth");
        write_recording(truth_path, &header, &truth)?;
        summary.push_str(&format!(
            "\nwrote ground truth to {}",
            crate::io::sink_name(truth_path)
        ));
    }
    Ok((summary, clips))
}

/// Parses and converts every file with the same options (BVH files, or AMC files of the ASF
/// skeleton `asf`); two files go through `convert_pair` so they share one rate check and one
/// grounding offset.
pub fn load_clips(
    files: &[PathBuf],
    asf: Option<&Path>,
    options: &ConvertOptions,
) -> Result<Vec<MocapClip>> {
    let bvhs = files
        .iter()
        .map(|p| {
            let is_amc = p.extension().is_some_and(|e| e.eq_ignore_ascii_case("amc"));
            if asf.is_none() && is_amc {
                bail!(
                    "{}: an AMC file needs its subject's skeleton: --asf SUBJECT.asf",
                    p.display()
                );
            }
            match asf {
                Some(asf) => read_asf_amc_files(asf, p),
                None => read_bvh_file(p),
            }
            .with_context(|| format!("reading {}", p.display()))
        })
        .collect::<Result<Vec<_>>>()?;
    match bvhs.as_slice() {
        [] => bail!("no motion capture file given"),
        [a, b] => {
            let (ca, cb) = convert_pair(a, b, options).with_context(|| {
                format!(
                    "converting {} with {}",
                    files[0].display(),
                    files[1].display()
                )
            })?;
            Ok(vec![ca, cb])
        }
        _ => {
            if bvhs.len() > 2 && options.grounding != Grounding::Keep {
                bail!("--ground takes one or two files (a shared floor for more is not defined)");
            }
            bvhs.iter()
                .zip(files)
                .map(|(b, p)| {
                    convert(b, options).with_context(|| format!("converting {}", p.display()))
                })
                .collect()
        }
    }
}

/// Writes a header and messages to `path` with the validating writer.
pub fn write_recording(path: &Path, header: &Header, messages: &[Message]) -> Result<()> {
    write_recording_partial(path, header, messages)?.commit()
}

/// Writes the recording as [`write_recording`] does, under `PATH.partial`, and returns it
/// without giving it its name: [`crate::io::OutFile::commit`] does, once every file of a set
/// is whole.
pub fn write_recording_partial(
    path: &Path,
    header: &Header,
    messages: &[Message],
) -> Result<crate::io::OutFile> {
    // Written as PATH.partial and renamed once whole: an error or a kill leaves no cut file
    // under the final name, and a previous one whole.
    let out = crate::io::create_write_renamed(path)?;
    let mut writer =
        RecordingWriter::new(out, header).with_context(|| format!("writing {}", path.display()))?;
    for m in messages {
        writer
            .write(m)
            .with_context(|| format!("writing {}", path.display()))?;
    }
    writer
        .finish()
        .with_context(|| format!("writing {}", path.display()))
}

fn person_name(path: &Path) -> String {
    path.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.display().to_string())
}

fn source_list(files: &[PathBuf]) -> serde_json::Value {
    serde_json::Value::Array(
        files
            .iter()
            .map(|p| serde_json::Value::String(person_name(p)))
            .collect(),
    )
}
