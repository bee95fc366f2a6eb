//! `nomen run`: a recording through the engine, identified skeletons out (streaming; `-` works
//! for stdin and stdout, so a live pipe works).
//!
//! `--method` picks the identity method: `nomen` (the streaming engine), or one of the published
//! baselines kept for comparison, `baptizo` (Bazo 2019, UWB tags, `nomen_rtls`) and `llorca`
//! (Llorca et al., RSSI tags, `nomen_rssi`; needs `--rssi-model`). The baselines are batch: the
//! whole recording is read first, then decided, then written in time order.

use crate::refine::Refinement;
use crate::skip::{SkipLimit, read_policy};
use anyhow::{Context, Result, bail};
use clap::{Args, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use nomen_calib::auto::{AutoCalibration, AutoCalibrationConfig, AutoCalibrator};
use nomen_core::{Calibration, CameraId, ClockModel, Message, Registry};
use nomen_engine::{Engine, EngineConfig, Retracker};
use nomen_recording::plausibility::{Finding, Plausibility};
use nomen_recording::{
    DEFAULT_GLOBAL_TOLERANCE_NS, Header, IdCheck, ReadOptions, ReadStats, RecordingReader,
    RecordingWriter, WriteOptions,
};
use std::collections::BTreeMap;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// Arguments of `nomen run`.
#[derive(Debug, Args)]
pub struct RunArgs {
    /// The recording (`-` for stdin): JSON lines whose header carries the registry, or an MCAP
    /// file (`nomen serve --record`) whose `nomen/in/registry` channel does, read in log-time
    /// order.
    pub recording: PathBuf,
    /// Engine configuration (TOML); defaults documented in `nomen-engine`.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Where to write the result (`-` for stdout). When reading stdin or writing stdout (a live
    /// pipe, or `--live`), each batch of decisions is flushed as soon as the engine makes it,
    /// under OUT's own name. Otherwise a file is written as `OUT.partial` and renamed to OUT
    /// once the run has written its last decision (also when it stops at a bad line, with the
    /// decisions on what came before it): a run killed or stopped by an error before then
    /// leaves OUT.partial and any previous OUT as it was.
    #[arg(long)]
    pub out: PathBuf,
    /// Skip malformed input lines (counted, and listed with file and line) instead of stopping.
    /// A bad line includes a time jump: one more than 0.1 s after every earlier line that the
    /// next two lines do not both follow on from (a corrupt timestamp, a line out of place).
    /// Stopping still decides and writes everything before the bad line.
    #[arg(long)]
    pub skip_bad: bool,
    /// With `--skip-bad`: the most lines it may skip, a number (`10`) or a percentage of the
    /// message lines read (`1%`). Beyond it the run still decides and writes everything it read,
    /// then fails, saying how many lines were skipped.
    #[arg(long, value_name = "N|P%", default_value = crate::skip::DEFAULT_SKIP_LIMIT, requires = "skip_bad")]
    pub max_skipped: SkipLimit,
    /// Identity method: the nomen engine, or a published baseline.
    #[arg(long, value_enum, default_value_t = Method::Nomen)]
    pub method: Method,
    /// RSSI model (JSON, as written by `nomen calibrate rssi RECORDING --out MODEL.json`);
    /// required by `llorca`; the engine (`nomen`) uses it instead of its fitted default model.
    #[arg(long, value_name = "MODEL.json")]
    pub rssi_model: Option<PathBuf>,
    /// Pose refinement (engine only): fill the joints of every identified skeleton, with elbows
    /// and wrists the camera lost estimated by the occluded-joint particle filter
    /// (`state: estimated`, with covariance).
    #[arg(long)]
    pub refine_joints: bool,
    /// Environment mesh (OBJ or PLY, world frame) whose surfaces estimated joints may not pass
    /// through, e.g. the `obstacles.obj` that `nomen simulate` writes. Needs `--refine-joints`.
    #[arg(long, value_name = "MESH")]
    pub environment: Option<PathBuf>,
    /// A model from `nomen train cnn` (e.g. `models/cnn_small`): the engine adds its score as
    /// one more model of every (IMU, track) window (engine only).
    #[arg(long, value_name = "MODEL")]
    pub cnn: Option<PathBuf>,
    /// The input is a live stream (stdin or a named pipe) whose session clock runs with the wall
    /// clock: while no line arrives, the engine is told that time passes
    /// (`Engine::advance_to`), so when every source falls silent the last decisions still come
    /// out, a few seconds later (`latency_s` + `silence_timeout_s`), instead of at the end of
    /// the input; and a line that leads the others after a pause is taken when it comes, not
    /// held until the next two lines confirm it (the pause is vouched for by the wall clock,
    /// `ReadOptions::wall_clock`). Output then depends on when lines arrive; without it a run
    /// is reproducible.
    #[arg(long)]
    pub live: bool,
    /// The skeletons' track ids follow nobody (a pose estimator without a tracker, numbering a
    /// frame's people by detection order): number them anew per camera by chaining each
    /// frame's detections to the last frame's (`nomen_engine::Retracker`; engine only). The
    /// decisions keep the ids the skeletons came with. Each camera's skeletons wait for its
    /// next frame.
    #[arg(long)]
    pub retrack: bool,
    /// A calibration (TOML or JSON, as `nomen calibrate frames --out` writes): camera poses,
    /// scales and clock offsets, and device clock offsets, laid over the recording's registry
    /// before the run (`nomen_core::Calibration`). The result's header carries the calibrated
    /// registry.
    #[arg(long, value_name = "FILE")]
    pub calibration: Option<PathBuf>,
    /// `auto`: estimate each camera's transform to the location tags' frame (rigid, or a
    /// similarity when the rigid fit is poor) and each location tag's clock offset from the
    /// recording itself (`nomen_calib::auto`; engine only, from a file). A first pass reads the
    /// recording until the estimate is complete (from 20 s of data on) or the first 60 s are
    /// read, and the run then starts from the beginning with it; during the run the estimate is
    /// refined every 30 s of data and laid over the engine. The summary starts with what was
    /// estimated, and warns when a camera or tag could not be calibrated.
    #[arg(long, value_enum, value_name = "MODE", conflicts_with = "calibration")]
    pub calibrate: Option<CalibrateMode>,
}

/// How `nomen run` calibrates cameras and tags beyond the registry.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum CalibrateMode {
    /// From the recording's own tracks and fixes (`nomen_calib::auto`).
    Auto,
}

/// What the engine path of `nomen run` adds to the engine itself.
#[derive(Debug, Default)]
pub struct EngineExtras {
    /// RSSI model for RSSI evidence.
    pub rssi_model: Option<nomen_rssi::RssiModel>,
    /// Run the pose-refinement stage.
    pub refine_joints: bool,
    /// Environment mesh for the refinement.
    pub environment: Option<PathBuf>,
    /// CNN model for the engine's learned voter.
    pub cnn: Option<PathBuf>,
    /// Treat the input as live (`--live`).
    pub live: bool,
    /// Number the skeletons' tracks anew (`--retrack`).
    pub retrack: bool,
    /// Laid over the input's registry (`--calibration`).
    pub calibration: Option<Calibration>,
    /// Estimate the calibration from the input (`--calibrate auto`).
    pub calibrate_auto: Option<AutoCalibrationConfig>,
}

/// A calibration file: TOML (`.toml`) or JSON (`nomen_core::Calibration`).
pub fn load_calibration(path: &Path) -> Result<Calibration> {
    let text = crate::io::read_settings(path)?;
    if path.extension().is_some_and(|e| e == "toml") {
        toml::from_str(&text)
            .with_context(|| format!("{}: not a calibration (TOML)", path.display()))
    } else {
        serde_json::from_str(&text)
            .with_context(|| format!("{}: not a calibration (JSON)", path.display()))
    }
}

/// `registry` with `calibration` laid over it, if any; `source` names the input in errors.
pub fn calibrated(
    mut registry: Registry,
    calibration: Option<&Calibration>,
    source: &str,
) -> Result<Registry> {
    if let Some(c) = calibration {
        registry
            .apply_calibration(c)
            .with_context(|| format!("{source}: the calibration does not fit its registry"))?;
    }
    Ok(registry)
}

pub fn load_rssi_model(path: &Path) -> Result<nomen_rssi::RssiModel> {
    let text = crate::io::read_settings(path)?;
    Ok(nomen_rssi::RssiModel::from_json(
        &text,
        &path.display().to_string(),
    )?)
}

/// The identity methods `nomen run` can use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Method {
    /// nomen's streaming engine (every modality; `--config` applies).
    Nomen,
    /// Bazo's Baptizo on UWB tag fixes, as published (`nomen_rtls::run_baptizo`).
    Baptizo,
    /// Llorca's RSSI association (`nomen_llorca::run_llorca`); needs `--rssi-model`.
    Llorca,
}

/// Runs `nomen run`.
pub fn run(args: RunArgs) -> Result<()> {
    crate::io::check_distinct(
        &[
            Some(&args.recording),
            args.config.as_deref(),
            args.rssi_model.as_deref(),
            args.environment.as_deref(),
            args.calibration.as_deref(),
        ],
        &[Some(&args.out), Some(&crate::io::partial_path(&args.out))],
    )?;
    let calibration = args
        .calibration
        .as_deref()
        .map(load_calibration)
        .transpose()?;
    // Without `--skip-bad` the reading stops at the first bad line.
    let skip = args.skip_bad.then_some(args.max_skipped);
    let summary = match args.method {
        Method::Nomen => {
            if args.environment.is_some() && !args.refine_joints {
                bail!("--environment is used by the pose refinement: add --refine-joints");
            }
            let config = load_config(args.config.as_deref())?;
            let extras = EngineExtras {
                rssi_model: args
                    .rssi_model
                    .as_deref()
                    .map(load_rssi_model)
                    .transpose()?,
                refine_joints: args.refine_joints,
                environment: args.environment.clone(),
                cnn: args.cnn.clone(),
                live: args.live,
                retrack: args.retrack,
                calibration,
                calibrate_auto: args
                    .calibrate
                    .map(|CalibrateMode::Auto| AutoCalibrationConfig::default()),
            };
            run_file(&args.recording, &args.out, config, skip, &extras)?
        }
        Method::Baptizo | Method::Llorca => {
            if args.refine_joints
                || args.environment.is_some()
                || args.cnn.is_some()
                || args.live
                || args.retrack
                || args.calibrate.is_some()
            {
                bail!(
                    "--refine-joints, --environment, --cnn, --live, --retrack and --calibrate work with the engine (--method nomen) only"
                );
            }
            if args.config.is_some() {
                bail!(
                    "--config configures the nomen engine; --method baptizo and --method llorca use their published settings"
                );
            }
            let baseline = match (args.method, &args.rssi_model) {
                (Method::Llorca, None) => {
                    bail!(
                        "--method llorca needs --rssi-model MODEL.json (fit one with `nomen calibrate rssi RECORDING --out MODEL.json`)"
                    )
                }
                (Method::Llorca, Some(path)) => Baseline::Llorca(load_rssi_model(path)?),
                (_, Some(_)) => {
                    bail!("--rssi-model is used by --method llorca and --method nomen only")
                }
                (_, None) => Baseline::Baptizo,
            };
            run_baseline_file(
                &args.recording,
                &args.out,
                &baseline,
                skip,
                calibration.as_ref(),
            )?
        }
    };
    eprintln!("{summary}");
    Ok(())
}

/// A published method run as a batch over the whole recording.
#[derive(Debug)]
pub enum Baseline {
    /// Baptizo with its default settings.
    Baptizo,
    /// Llorca's association with this RSSI model.
    Llorca(nomen_rssi::RssiModel),
}

impl Baseline {
    fn name(&self) -> &'static str {
        match self {
            Baseline::Baptizo => "baptizo",
            Baseline::Llorca(_) => "llorca",
        }
    }
}

/// `summary`, or (printed first) the error of a reading that skipped more lines than `skip`
/// allows.
fn within_skip_limit(
    summary: String,
    skip: Option<SkipLimit>,
    stats: &ReadStats,
    recording: &Path,
) -> Result<String> {
    if let Some(limit) = skip
        && let Err(e) = limit.check(stats, &crate::io::source_name(recording))
    {
        eprintln!("{summary}");
        return Err(e);
    }
    Ok(summary)
}

fn open_writer(
    out: &Path,
    recording: &Path,
    registry: Registry,
    generator: &str,
    is_followed: bool,
) -> Result<RecordingWriter<crate::io::OutFile>> {
    let header = Header::new(registry)
        .with_meta("generator", generator)
        .with_meta("input", crate::io::source_name(recording));
    let sink = if is_followed {
        crate::io::OutFile::Direct(crate::io::create_write(out)?)
    } else {
        crate::io::create_write_renamed(out)?
    };
    Ok(RecordingWriter::with_options(
        sink,
        &crate::io::sink_name(out),
        &header,
        WriteOptions {
            id_check: IdCheck::Header,
            global_tolerance_ns: DEFAULT_GLOBAL_TOLERANCE_NS,
        },
    )?)
}

/// The error of a run that stopped at the bad line `e`, after writing the `num_decisions`
/// decisions on what came before it to `out`.
fn stopped_reading(
    e: nomen_recording::RecordingError,
    num_decisions: impl std::fmt::Display,
    out: &Path,
) -> anyhow::Error {
    // A line past the limit ends the reading under either policy: no hint to skip it.
    let hint = if matches!(e, nomen_recording::RecordingError::LineTooLong { .. }) {
        ""
    } else {
        " (--skip-bad skips bad lines instead)"
    };
    anyhow::Error::from(e).context(format!(
        "stopped reading; the {num_decisions} decisions on what came before are in {}{hint}",
        crate::io::sink_name(out)
    ))
}

/// Reads the whole of `recording`, decides it with `baseline` and writes the decisions to `out`
/// in time order; returns a summary line. `skip`: skip bad lines, up to this limit (`None`:
/// stop at the first).
pub fn run_baseline_file(
    recording: &Path,
    out: &Path,
    baseline: &Baseline,
    skip: Option<SkipLimit>,
    calibration: Option<&Calibration>,
) -> Result<String> {
    let mut reader = nomen_mcap::open_recording(
        recording,
        ReadOptions::with_policy(read_policy(skip)).holding_all(),
    )?;
    let Some(registry) = reader.header().registry.clone() else {
        bail!(
            "{}: the header carries no registry, so {} does not know who wears what",
            crate::io::source_name(recording),
            baseline.name()
        );
    };
    let registry = calibrated(registry, calibration, &crate::io::source_name(recording))?;
    // A bad line stops the reading (without `--skip-bad`); what came before is still decided
    // and written.
    let mut messages = Vec::new();
    let mut read_error = None;
    for m in reader.by_ref() {
        match m {
            Ok(m) => messages.push(m),
            Err(e) => {
                read_error = Some(e);
                break;
            }
        }
    }
    // The evidence the method reads: without it every skeleton stays anonymous.
    let (evidence, what) = match baseline {
        Baseline::Baptizo => (
            messages
                .iter()
                .filter(|m| matches!(m, Message::RtlsFix(_)))
                .count(),
            "location-tag fixes",
        ),
        Baseline::Llorca(_) => (
            messages
                .iter()
                .filter(|m| matches!(m, Message::Rssi(_)))
                .count(),
            "RSSI reads",
        ),
    };
    if evidence == 0 {
        eprintln!(
            "warning: {} has no {what}: {} names nobody, every skeleton stays anonymous",
            crate::io::source_name(recording),
            baseline.name()
        );
    }
    let mut decided = match baseline {
        Baseline::Baptizo => nomen_rtls::run_baptizo(&registry, &messages)
            .with_context(|| format!("{}: baptizo", crate::io::source_name(recording)))?,
        Baseline::Llorca(model) => nomen_llorca::run_llorca(&registry, model, &messages)
            .with_context(|| format!("{}: llorca", crate::io::source_name(recording)))?,
    };
    // The writer wants time order; a stable sort keeps each time's messages in decision order.
    decided.sort_by_key(Message::t);
    let mut writer = open_writer(
        out,
        recording,
        registry,
        &format!("nomen run --method {}", baseline.name()),
        false,
    )?;
    for m in &decided {
        writer.write(m)?;
    }
    writer.finish()?.commit()?;
    if let Some(e) = read_error {
        return Err(stopped_reading(e, decided.len(), out));
    }
    let stats = reader.into_stats();
    let num_identified = decided
        .iter()
        .filter(|m| matches!(m, Message::Identified(_)))
        .count();
    let summary = format!(
        "{}: {stats}; {} wrote {num_identified} decisions and {} other messages to {}{}",
        crate::io::source_name(recording),
        baseline.name(),
        decided.len() - num_identified,
        crate::io::sink_name(out),
        skipped_lines(&stats)
    );
    within_skip_limit(summary, skip, &stats, recording)
}

/// The lines `--skip-bad` skipped, each with its file, line and reason (the first few, as
/// `nomen validate --skip-bad` lists them), one per line; empty when none was skipped.
fn skipped_lines(stats: &ReadStats) -> String {
    let mut text: String = stats
        .first_errors
        .iter()
        .map(|e| format!("\n  skipped: {e}"))
        .collect();
    let more = stats
        .num_skipped()
        .saturating_sub(stats.first_errors.len() as u64);
    if more > 0 {
        text.push_str(&format!("\n  ... and {more} more skipped lines"));
    }
    text
}

/// Where [`run_file`] takes its messages from.
enum Input {
    /// The reader, on this thread (boxed: the larger variant, and one per run).
    Reader(Box<RecordingReader<Box<dyn std::io::BufRead>>>),
    /// `--live`: a thread reads and hands each message over, so that a pause in the input can
    /// be noticed (and the engine told that time passes) while the thread waits for a line.
    Live {
        header: Header,
        received: mpsc::Receiver<nomen_recording::Result<Message>>,
        reading: std::thread::JoinHandle<ReadStats>,
        /// The newest stamp received and when it came.
        newest: Option<(nomen_core::SessionTime, Instant)>,
    },
}

/// What [`Input::next_event`] gives.
enum Event {
    /// A message, or the read error that ends the input.
    Message(nomen_recording::Result<Message>),
    /// `--live`: nothing arrived for a tick; `idle` since the message stamped `newest` (the
    /// newest so far) came.
    Idle {
        newest: nomen_core::SessionTime,
        idle: Duration,
    },
}

/// How long `--live` waits for a line before it tells the engine that time passes.
const LIVE_TICK: Duration = Duration::from_millis(100);

impl Input {
    /// Starts a thread that reads `recording` and returns once its header is read.
    fn live(recording: &Path, options: ReadOptions) -> Result<Self> {
        let (header_sender, header_received) = mpsc::channel();
        // Bounded: while the engine is busy, the reading waits instead of buffering the input.
        let (sender, received) = mpsc::sync_channel(4096);
        let path = recording.to_path_buf();
        let reading = std::thread::spawn(move || {
            let mut reader = match nomen_mcap::open_recording(&path, options) {
                Ok(reader) => reader,
                Err(e) => {
                    let _ = header_sender.send(Err(e));
                    return ReadStats::default();
                }
            };
            if header_sender.send(Ok(reader.header().clone())).is_err() {
                return reader.into_stats();
            }
            for m in reader.by_ref() {
                let is_last = m.is_err();
                if sender.send(m).is_err() || is_last {
                    break;
                }
            }
            reader.into_stats()
        });
        let header = match header_received.recv() {
            Ok(header) => header?,
            Err(_) => bail!(
                "{}: the reading thread stopped before the header",
                crate::io::source_name(recording)
            ),
        };
        Ok(Input::Live {
            header,
            received,
            reading,
            newest: None,
        })
    }

    fn header(&self) -> &Header {
        match self {
            Input::Reader(reader) => reader.header(),
            Input::Live { header, .. } => header,
        }
    }

    /// The next message, or (live) a tick without one; `None` at the end of the input.
    fn next_event(&mut self) -> Option<Event> {
        let (received, newest) = match self {
            Input::Reader(reader) => return reader.next().map(Event::Message),
            Input::Live {
                received, newest, ..
            } => (received, newest),
        };
        loop {
            match received.recv_timeout(LIVE_TICK) {
                Ok(m) => {
                    if let Ok(m) = &m
                        && newest.is_none_or(|(t, _)| m.t() > t)
                    {
                        *newest = Some((m.t(), Instant::now()));
                    }
                    return Some(Event::Message(m));
                }
                Err(mpsc::RecvTimeoutError::Timeout) => {
                    // Before the first message there is no time to run on from: wait on.
                    if let Some((t, at)) = newest {
                        return Some(Event::Idle {
                            newest: *t,
                            idle: at.elapsed(),
                        });
                    }
                }
                Err(mpsc::RecvTimeoutError::Disconnected) => return None,
            }
        }
    }

    fn into_stats(self) -> ReadStats {
        match self {
            Input::Reader(reader) => (*reader).into_stats(),
            // A reading thread that panicked has no counts to give.
            Input::Live { reading, .. } => reading.join().unwrap_or_default(),
        }
    }
}

/// Messages between two updates of [`progress_bar`]'s position.
const PROGRESS_EVERY: u64 = 4096;

/// A bar of the bytes of `recording` read, on stderr when it is a terminal and the recording
/// a file read to its end (not stdin, not `--live`); hidden otherwise, so pipes and logs get
/// the summary line alone.
fn progress_bar(recording: &Path, live: bool) -> ProgressBar {
    let size = (!live && !crate::io::is_std_stream(recording) && std::io::stderr().is_terminal())
        .then(|| std::fs::metadata(recording).ok())
        .flatten()
        .filter(|m| m.is_file())
        // An MCAP file's bytes are compressed: its lines' count says nothing of its size.
        .filter(|_| !nomen_mcap::is_mcap_file(recording))
        .map(|m| m.len());
    let Some(size) = size else {
        return ProgressBar::hidden();
    };
    let bar = ProgressBar::new(size);
    bar.set_style(
        ProgressStyle::with_template("running [{bar:40}] {percent:>3}% ({eta} left)").map_or_else(
            |_| ProgressStyle::default_bar(),
            |s| s.progress_chars("=> "),
        ),
    );
    bar
}

/// Loads an engine configuration file, or the defaults.
pub fn load_config(path: Option<&Path>) -> Result<EngineConfig> {
    match path {
        None => Ok(EngineConfig::default()),
        Some(p) => {
            let text = crate::io::read_settings(p)?;
            toml::from_str(&text)
                .with_context(|| format!("{}: invalid engine configuration", p.display()))
        }
    }
}

/// The engine of `nomen run` and `nomen serve`: `config` on `registry`, with the RSSI model and
/// the CNN of `extras` when given; `source` names the input in errors.
pub fn build_engine(
    registry: Registry,
    config: EngineConfig,
    extras: &EngineExtras,
    source: &str,
) -> Result<Engine> {
    let mut engine = Engine::new(registry, config)?;
    if let Some(model) = &extras.rssi_model {
        engine = engine
            .with_rssi_model(model)
            .with_context(|| format!("{source}: the RSSI model"))?;
    }
    if let Some(path) = &extras.cnn {
        engine = engine.with_pair_scorer(Box::new(super::train::load_scorer(path)?));
    }
    Ok(engine)
}

/// How far past the newest message a live input's idle tick may move the session clock: far
/// enough for every decision to come out, never a time jump (`nomen run --live`, `nomen serve`).
pub fn max_idle_ns(config: &EngineConfig) -> i64 {
    ((config.max_latency_s() + config.silence_timeout_s + config.hop_s).min(config.max_time_jump_s)
        * 1e9) as i64
}

/// Streams `recording` through the engine into `out`; returns a summary line. `skip`: skip bad
/// lines, up to this limit (`None`: stop at the first).
pub fn run_file(
    recording: &Path,
    out: &Path,
    config: EngineConfig,
    skip: Option<SkipLimit>,
    extras: &EngineExtras,
) -> Result<String> {
    let max_clock_offset_s = config.max_clock_offset_s;
    // Live, the wall clock vouches for a pause: a line after one is not held for the two lines
    // that would otherwise confirm it (while the engine's clock runs on without it).
    let options = ReadOptions {
        wall_clock: extras.live,
        ..ReadOptions::with_policy(read_policy(skip))
    };
    let mut input = if extras.live {
        Input::live(recording, options.clone())?
    } else {
        Input::Reader(Box::new(nomen_mcap::open_recording(
            recording,
            options.clone(),
        )?))
    };
    let Some(registry) = input.header().registry.clone() else {
        bail!(
            "{}: the header carries no registry, so the engine does not know who wears what",
            crate::io::source_name(recording)
        );
    };
    let registry = calibrated(
        registry,
        extras.calibration.as_ref(),
        &crate::io::source_name(recording),
    )?;
    // `--calibrate auto`: a first pass to the first estimate, a calibrator that refines it.
    let mut auto = match &extras.calibrate_auto {
        Some(config) => Some(AutoRun::start(
            recording, options, &registry, *config, extras,
        )?),
        None => None,
    };
    let registry = match &auto {
        Some(a) => {
            let mut calibrated = registry;
            calibrated
                .apply_calibration(&a.first.calibration)
                .with_context(|| {
                    format!(
                        "{}: the estimated calibration does not fit the registry",
                        crate::io::source_name(recording)
                    )
                })?;
            calibrated
        }
        None => registry,
    };
    let mut engine = build_engine(
        registry.clone(),
        config,
        extras,
        &crate::io::source_name(recording),
    )?;
    let mut refinement = if extras.refine_joints {
        Some(Refinement::new(&registry, extras.environment.as_deref())?)
    } else {
        None
    };
    let mut retracker = if extras.retrack {
        Some(Retracker::new(config.retrack)?)
    } else {
        None
    };
    let camera_clocks: BTreeMap<CameraId, ClockModel> = registry
        .cameras
        .iter()
        .map(|c| (c.id.clone(), c.clock))
        .collect();
    // A live session's file is followed as it grows: it is written under its own name.
    let is_followed = extras.live || crate::io::is_std_stream(recording);
    // Time stamps whose rate contradicts the declared one (every t in milliseconds) would make
    // every decision anonymous: the run stops as soon as a source shows it.
    let mut plausibility = Plausibility::new(Some(&registry));
    let mut rate_warnings: Vec<String> = Vec::new();
    let mut writer = open_writer(out, recording, registry, "nomen run", is_followed)?;
    // Live (reading stdin or writing stdout): each batch of decisions goes out as soon as it is
    // decided, instead of when the output buffer fills, so a consumer's wait is the engine's
    // latency alone, also while the input pauses.
    let is_live =
        extras.live || crate::io::is_std_stream(recording) || crate::io::is_std_stream(out);
    if is_live {
        writer.flush()?;
    }
    let mut batch: Vec<Message> = Vec::new();
    let mut num_rejected = 0u64;
    let mut first_rejection = None;
    let mut num_out = 0u64;
    let mut write_batch = |batch: &mut Vec<Message>,
                           writer: &mut RecordingWriter<_>,
                           refinement: &mut Option<Refinement>,
                           retracker: &mut Option<Retracker>|
     -> Result<()> {
        batch.sort_by_key(|m| m.t());
        for mut m in batch.drain(..) {
            if let (Some(r), Message::Identified(id)) = (refinement.as_mut(), &mut m) {
                r.refine(id)?;
            }
            // Decided under the new ids, reported under those the skeletons came with (the
            // retracker knows them by the camera's stamp, the decision by session time).
            if let (Some(r), Message::Identified(id)) = (retracker.as_mut(), &mut m) {
                let stamp = camera_clocks
                    .get(&id.camera)
                    .map_or(id.t.as_ns(), |c| c.to_device(id.t));
                if let Some(track) = r.original_track(stamp, &id.camera, id.track) {
                    id.track = track;
                }
            }
            writer.write(&m)?;
            num_out += 1;
        }
        if is_live {
            writer.flush()?;
        }
        Ok(())
    };
    // A bad line stops the reading (without `--skip-bad`), not the engine: what it accepted
    // before is still decided and written.
    let mut read_error = None;
    // Before each idle tick's heartbeat, what the clock may run to: far enough for every
    // decision to come out, never a time jump.
    let max_idle_ns = max_idle_ns(&config);
    // Whether the engine accepted the message.
    let mut push = |m: &Message, engine: &mut Engine, refinement: &mut Option<Refinement>| {
        if let (Some(r), Message::Skeleton(s)) = (refinement.as_mut(), m) {
            r.observe(s);
        }
        match engine.push(m) {
            Ok(()) => true,
            Err(e) => {
                num_rejected += 1;
                first_rejection.get_or_insert_with(|| e.to_string());
                false
            }
        }
    };
    // A message (if any) to the engine, through the retracker when there is one: then what
    // it has ready, in input order.
    let mut ready: Vec<Message> = Vec::new();
    let mut feed = |m: Option<Message>,
                    retracker: &mut Option<Retracker>,
                    engine: &mut Engine,
                    refinement: &mut Option<Refinement>| match retracker {
        Some(r) => {
            if let Some(m) = m {
                r.push(m);
            }
            r.pop_ready(&mut ready);
            for m in ready.drain(..) {
                // A refused skeleton gets no decision: its original id is not asked for.
                if !push(&m, engine, refinement)
                    && let Message::Skeleton(s) = &m
                {
                    r.original_track(s.t.as_ns(), &s.camera, s.track);
                }
            }
        }
        None => {
            if let Some(m) = m {
                push(&m, engine, refinement);
            }
        }
    };
    // Progress on a terminal, for a file read here (stdin and live input have no known end).
    let bar = progress_bar(recording, extras.live);
    let mut num_events = 0u64;
    while let Some(event) = input.next_event() {
        num_events += 1;
        if num_events.is_multiple_of(PROGRESS_EVERY)
            && let Input::Reader(reader) = &input
        {
            bar.set_position(reader.stats().num_bytes);
        }
        match event {
            Event::Message(Ok(m)) => {
                // Gravity in g is the engine's warning (`gravity_warnings`), not a stop; so is
                // an IMU whose rate no unit mistake explains (a slow device's evidence is weak,
                // the others' is not).
                let finding = plausibility.push(&m);
                if let Some(
                    finding @ Finding::Rate {
                        kind: "imu",
                        factor: None,
                        ..
                    },
                ) = &finding
                {
                    bar.suspend(|| eprintln!("warning: {finding}"));
                    rate_warnings.push(finding.to_string());
                } else if let Some(finding @ Finding::Rate { .. }) = finding {
                    bar.finish_and_clear();
                    bail!(
                        "{}: {finding}; stopped with no result (the time stamps, or the \
                         registry's rates, need fixing first)",
                        crate::io::source_name(recording)
                    );
                }
                if let Some(a) = auto.as_mut() {
                    a.push(&m, &mut engine);
                }
                feed(Some(m), &mut retracker, &mut engine, &mut refinement);
            }
            Event::Message(Err(e)) => {
                read_error = Some(e);
                break;
            }
            Event::Idle { newest, idle } => {
                // A pause: the frames held are as complete as they will be.
                if let Some(r) = retracker.as_mut() {
                    r.close_frames();
                }
                feed(None, &mut retracker, &mut engine, &mut refinement);
                let idle_ns = i64::try_from(idle.as_nanos()).unwrap_or(i64::MAX);
                let now = newest.as_ns().saturating_add(idle_ns.min(max_idle_ns));
                // Within the time-jump bound by construction; a refusal changes nothing.
                let _ = engine.advance_to(nomen_core::SessionTime::from_ns(now));
            }
        }
        engine.poll(&mut batch);
        if !batch.is_empty() {
            write_batch(&mut batch, &mut writer, &mut refinement, &mut retracker)?;
        }
    }
    if let Some(r) = retracker.as_mut() {
        r.close_frames();
    }
    feed(None, &mut retracker, &mut engine, &mut refinement);
    bar.finish_and_clear();
    engine.finish(&mut batch);
    write_batch(&mut batch, &mut writer, &mut refinement, &mut retracker)?;
    writer.finish()?.commit()?;
    // The session's first message, dropped once the next showed its stamp was far ahead.
    if let Some(why) = &engine.stats().first_message_dropped {
        num_rejected += 1;
        first_rejection = Some(why.clone());
    }
    if let Some(e) = read_error {
        return Err(stopped_reading(e, num_out, out));
    }
    let stats = input.into_stats();
    let mut summary = auto.as_ref().map_or_else(String::new, AutoRun::summary);
    summary.push_str(&format!(
        "{}: {stats}; engine rejected {num_rejected} messages, stitched {} tracks ({} of them seen again), undid {} id swaps, estimated {} clock offsets (moved {}, withdrawn {}, settled {}); wrote {num_out} decisions to {}",
        crate::io::source_name(recording),
        engine.stats().num_stitched,
        engine.stats().num_stitches_undone,
        engine.stats().num_swaps,
        engine.stats().clock_offsets.len(),
        engine.stats().num_offsets_moved,
        engine.stats().num_offsets_withdrawn,
        engine.stats().num_offsets_settled,
        crate::io::sink_name(out)
    ));
    if let Some(first) = first_rejection {
        summary.push_str(&format!(" (first rejection: {first})"));
    }
    if let Some(release_s) = engine.stats().warmup_release_s {
        summary.push_str(&format!(
            "; the warm-up's first decisions were sent {release_s:.1} s after the first skeleton"
        ));
    }
    let num_behind = engine.stats().num_frames_behind_history;
    if num_behind > 0 {
        summary.push_str(&format!(
            "; left {num_behind} skeleton observations out of track histories that had passed their time"
        ));
    }
    if let Some(r) = &refinement {
        summary.push_str(&format!("; estimated {} occluded joints", r.num_estimated));
    }
    summary.push_str(&skipped_lines(&stats));
    for (device, est) in &engine.stats().clock_offsets {
        summary.push_str(&format!(
            "\n  clock offset {device}: {:+.3} s (peak correlation {:.2}, {} updates)",
            est.offset_ns as f64 * 1e-9,
            est.correlation,
            est.num_updates
        ));
    }
    for (device, est) in &engine.stats().imu_headings {
        summary.push_str(&format!(
            "\n  heading {device}: {:+.0}° from the room (coherence {:.2})",
            est.room_from_imu_yaw_rad.to_degrees(),
            est.coherence
        ));
    }
    for (device, site) in &engine.stats().imu_sides {
        summary.push_str(&format!("\n  side {device}: found at {site}"));
    }
    summary.push_str(&gravity_warnings(engine.stats()));
    summary.push_str(&device_notes(engine.stats(), max_clock_offset_s));
    for warning in &rate_warnings {
        summary.push_str(&format!("\n  warning: {warning}"));
    }
    for (tag, share) in engine.stats().tags_far_from_skeletons() {
        summary.push_str(&format!(
            "\n  warning: tag {tag}: its fixes were near a skeleton in {:.1} % of the times they \
             were compared with the tracks in view: are they in the cameras' world frame, in \
             metres, on the session clock (nomen calibrate frames; the registry's clock), and is \
             its wearer ever in view?",
            100.0 * share
        ));
    }
    for tag in &engine.stats().planar_tags {
        summary.push_str(&format!(
            "\n  tag {tag}: its fixes are 2D (every one at the same height), compared with the \
             joints horizontally"
        ));
    }
    let (from_ranges, refused, ranges_unused) = (
        engine.stats().num_fixes_from_ranges,
        engine.stats().num_range_fixes_refused,
        engine.stats().num_ranges_unused,
    );
    if from_ranges > 0 || refused > 0 || ranges_unused > 0 {
        summary.push_str(&format!(
            "\n  uwb ranges: {from_ranges} fixes multilaterated and taken, {refused} refused (late \
             or duplicate), {ranges_unused} ranges unused (their tag sends fixes, or their \
             ranging cycle gave no fix)"
        ));
    }
    within_skip_limit(summary, skip, &stats, recording)
}

/// A line per accelerometer-only IMU saying which evidence it gives
/// ([`nomen_engine::ACCEL_ONLY_EVIDENCE`]), and a warning per IMU whose clock offset peaked at
/// an end of the engine's search ([`nomen_engine::EngineStats::offsets_at_search_edge`]).
fn device_notes(stats: &nomen_engine::EngineStats, max_clock_offset_s: f64) -> String {
    let mut notes = String::new();
    for device in &stats.accel_only_imus {
        notes.push_str(&format!(
            "\n  imu {device}: accelerometer only (no gyro_radps), evidence: {}",
            nomen_engine::ACCEL_ONLY_EVIDENCE
        ));
    }
    for (device, edge_s) in &stats.offsets_at_search_edge {
        notes.push_str(&format!(
            "\n  warning: offset of {device} at the edge of the ±{max_clock_offset_s:.1} s search \
             ({edge_s:+.2} s from the registry's): probably larger; raise max_clock_offset_s \
             (nomen run --config) or put the device's clock offset in the registry"
        ));
    }
    notes
}

/// A warning line per IMU whose accelerations do not look like m/s²
/// ([`nomen_engine::EngineStats::implausible_gravity`]).
fn gravity_warnings(stats: &nomen_engine::EngineStats) -> String {
    stats
        .implausible_gravity()
        .map(|(device, g)| {
            format!(
                "\n  warning: imu {device} started from {g:.3} m/s² of gravity (about 9.81 expected): \
                 are its accelerations in g or milli-g? The recording format wants m/s², and \
                 this IMU's evidence is wrong until they are"
            )
        })
        .collect()
}

/// `--calibrate auto` in a run: the first estimate (from a first pass over the recording) and
/// the calibrator that refines it as the run reads on.
struct AutoRun {
    /// The estimate the run started with.
    first: AutoCalibration,
    /// Refines it; fed every message of the run.
    calibrator: AutoCalibrator,
    /// The last refined estimate laid over the engine, and how many were.
    last_applied: Option<AutoCalibration>,
    num_applied: usize,
    /// Refined estimates that were not complete, or that the engine refused (the first
    /// reason).
    num_not_applied: usize,
    first_refusal: Option<String>,
}

impl AutoRun {
    /// Reads `recording` until the calibrator's first estimate is complete, or final at its
    /// window, or the recording ends (a bad line ends it too: the run proper reports it).
    fn start(
        recording: &Path,
        options: ReadOptions,
        registry: &Registry,
        config: AutoCalibrationConfig,
        extras: &EngineExtras,
    ) -> Result<Self> {
        if extras.live || crate::io::is_std_stream(recording) {
            bail!(
                "--calibrate auto reads the recording twice (its first minute, then all of it): \
                 give a file, not stdin or --live"
            );
        }
        let mut calibrator = AutoCalibrator::new(registry, config)?;
        let mut reader = nomen_mcap::open_recording(recording, options)?;
        let mut first = None;
        for m in reader.by_ref() {
            let Ok(m) = m else { break };
            calibrator.push(&m);
            if let Some(estimate) = calibrator.poll()
                && calibrator.is_settled()
            {
                first = Some(estimate);
                break;
            }
        }
        let first = match first {
            Some(e) => e,
            None => calibrator.finish().with_context(|| {
                format!(
                    "{}: --calibrate auto found no skeleton or location fix to calibrate with",
                    crate::io::source_name(recording)
                )
            })?,
        };
        if !first.is_complete() {
            eprintln!(
                "nomen run: warning: --calibrate auto could not calibrate everything from the \
                 first {:.0} s (details at the start of the summary)",
                first.span_s
            );
        }
        Ok(Self {
            calibrator: AutoCalibrator::new(registry, config)?,
            first,
            last_applied: None,
            num_applied: 0,
            num_not_applied: 0,
            first_refusal: None,
        })
    }

    /// A message of the run: to the calibrator, and a refined estimate, once one uses more data
    /// than the estimate in force and calibrates everything, to the engine.
    fn push(&mut self, m: &Message, engine: &mut Engine) {
        self.calibrator.push(m);
        let Some(estimate) = self.calibrator.poll() else {
            return;
        };
        let span_in_force_s = self
            .last_applied
            .as_ref()
            .map_or(self.first.span_s, |e| e.span_s);
        if estimate.span_s <= span_in_force_s {
            return;
        }
        if !estimate.is_complete() {
            self.num_not_applied += 1;
            return;
        }
        match engine.update_calibration(&estimate.calibration) {
            Ok(()) => {
                self.num_applied += 1;
                self.last_applied = Some(estimate);
            }
            Err(e) => {
                self.num_not_applied += 1;
                self.first_refusal.get_or_insert_with(|| e.to_string());
            }
        }
    }

    /// What was estimated: the first estimate, the last refinement, and the warnings.
    fn summary(&self) -> String {
        let mut text = format!(
            "calibrate auto: first estimate from the first {:.1} s of data:\n",
            self.first.span_s
        );
        text.push_str(&describe(&self.first));
        match &self.last_applied {
            Some(last) => {
                text.push_str(&format!(
                    "calibrate auto: refined {} times as the run read on ({} refinements not \
                     applied); the last, from {:.1} s of data:\n",
                    self.num_applied, self.num_not_applied, last.span_s
                ));
                text.push_str(&describe(last));
            }
            None => text.push_str(&format!(
                "calibrate auto: no refinement applied ({} not applied: incomplete{})\n",
                self.num_not_applied,
                if self.first_refusal.is_some() {
                    " or refused"
                } else {
                    ""
                }
            )),
        }
        if let Some(why) = &self.first_refusal {
            text.push_str(&format!(
                "  warning: the engine refused a refined calibration: {why}\n"
            ));
        }
        text
    }
}

/// An estimate, a few lines per camera and tag, with a warning for each that failed.
fn describe(estimate: &AutoCalibration) -> String {
    let mut text = String::new();
    for c in &estimate.cameras {
        match &c.outcome {
            Ok(fit) => {
                let t = &fit.world_from_camera;
                let (axis, angle) = t
                    .rotation()
                    .axis_angle()
                    .map_or(([0.0, 0.0, 1.0], 0.0), |(a, ang)| ([a.x, a.y, a.z], ang));
                let tr = t.translation_m();
                let r = &fit.report;
                text.push_str(&format!(
                    "  camera {}: {} fit against tag {}: scale {:.5} m per unit, rotation {:.1}° \
                     about [{:.3}, {:.3}, {:.3}], translation [{:.2}, {:.2}, {:.2}] m; clock \
                     offset camera − tag {:+.3} s (contrast {:.1}); {} pairs, {} inliers, inlier \
                     RMS {:.2} m, median {:.2} m; wearer in {} of {} tracks\n",
                    c.camera,
                    match fit.kind {
                        nomen_calib::FitKind::Rigid => "rigid",
                        nomen_calib::FitKind::Similarity => "similarity",
                    },
                    fit.tag,
                    t.scale,
                    angle.to_degrees(),
                    axis[0],
                    axis[1],
                    axis[2],
                    tr.x,
                    tr.y,
                    tr.z,
                    fit.clock_offset_ns as f64 * 1e-9,
                    fit.contrast,
                    r.num_points,
                    r.num_inliers,
                    r.rmse_inliers_m,
                    r.median_m,
                    fit.num_wearer_tracks,
                    fit.num_candidate_tracks,
                ));
            }
            Err(why) => text.push_str(&format!(
                "  warning: camera {} not calibrated (its registry pose is used): {why}\n",
                c.camera
            )),
        }
    }
    for t in &estimate.tags {
        match &t.outcome {
            Ok((camera, clock)) => text.push_str(&format!(
                "  tag {}: clock offset {:+.3} s (session = stamp + offset; from camera {camera})\n",
                t.tag,
                clock.offset_ns as f64 * 1e-9
            )),
            Err(why) => text.push_str(&format!(
                "  warning: tag {} clock not estimated (its registry clock is used): {why}\n",
                t.tag
            )),
        }
    }
    if estimate.cameras.is_empty() {
        text.push_str("  warning: no camera sent skeletons: nothing to calibrate\n");
    }
    text
}
