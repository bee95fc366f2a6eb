//! `nomen import`: CSV files and vendor formats → a nomen recording. CSV units come from the
//! column names or a units file, the dialect is detected, rows are sorted within a window and
//! repeated times merged (`nomen_recording::csv`); vendor formats are read by `nomen_adapters`
//! (`docs/adapters.md`).

use super::mocap::write_recording;
use anyhow::{Context, Result, bail};
use clap::{Args, Subcommand, ValueEnum};
use nomen_adapters::{
    AzureKinectConfig, Decoded, RfidConfig, RtlsConfig, TrackerConfig, read_azure_kinect,
    read_impinj, read_pozyx, read_sewio, read_tracker, read_zebra,
};
use nomen_core::skeleton::sets::JointSet;
use nomen_core::{CameraId, DeviceId, Joint, Message, Registry};
use nomen_recording::csv::{
    AccelUnit, BatchPolicy, ColumnUnits, CsvImport, CsvOptions, DecimalSeparator, Duplicates,
    FixCsvSpec, ImuCsvSpec, ImuQuantity, OrderPolicy, STANDARD_GRAVITY_MPS2, SkeletonCsvSpec,
    SkeletonLayout, TimeFormat, TimeUnit, import_fixes, import_imu_auto, import_skeletons,
    parse_utc_offset,
};
use nomen_recording::plausibility::{Finding, Plausibility};
use nomen_recording::{Header, sort_for_writing};
use std::path::{Path, PathBuf};

/// `nomen import ...`
#[derive(Debug, Subcommand)]
pub enum ImportCommand {
    /// An IMU CSV: a time column and accel/gyro (/mag) columns whose names carry units, e.g.
    /// `t (s), acc_x (g), gyr_x (deg/s)` or `time_ms, accel_x_mps2, gyro_x_radps`.
    Imu(ImuArgs),
    /// RTLS tag fixes: `t, tag, x, y, z [, quality]` (units in the names, e.g. `x_m`, `t_ms`).
    Fixes(FixesArgs),
    /// Camera skeletons, one joint per row (`t, camera, track, joint, x, y, z [, confidence,
    /// state]`) or one skeleton per row (`t, camera, track, <joint>_x, ...`).
    Skeletons(SkeletonArgs),
    /// Azure Kinect Body Tracking JSON as Microsoft's offline processor writes it: skeletons in
    /// millimetres in the depth camera's frame, at device time.
    AzureKinect(KinectArgs),
    /// A position-only tracker (an overhead people counter): CSV or JSON lines with `t`
    /// (`t_ms`, ...), `track`, `x`, `y` [, `z`, `confidence`] in the tracker's units; each
    /// point becomes a one-joint skeleton.
    Tracker(TrackerArgs),
    /// Pozyx MQTT positioning stream, one payload per line (millimetres, epoch seconds).
    Pozyx(RtlsArgs),
    /// Sewio RTLS WebSocket or UDP feed, one message per line (metres, UTC date-times).
    Sewio(RtlsArgs),
    /// Impinj Speedway Connect JSON tag reports, one per line: RSSI per reader port.
    Impinj(RfidArgs),
    /// Zebra FX IoT Connector tag data events, one per line: RSSI (and phase) per reader port.
    Zebra(RfidArgs),
}

/// Options shared by every import.
#[derive(Debug, Args)]
pub struct CommonArgs {
    /// The input file: CSV, or the vendor's format.
    pub file: PathBuf,
    /// Output recording (`-` for stdout).
    #[arg(long)]
    pub out: PathBuf,
    /// A registry (JSON, as in a recording header) to check ids against; without it the
    /// recording carries no registry and ids are not checked.
    #[arg(long)]
    pub registry: Option<PathBuf>,
}

/// How a CSV file is read: its dialect, time, order and units (`docs/import.md`).
#[derive(Debug, Args)]
pub struct CsvArgs {
    /// The column delimiter: `,`, `;` or `tab` (default: detected from the first rows).
    #[arg(long, value_parser = parse_delimiter)]
    delimiter: Option<u8>,
    /// The decimal separator: `.` or `,` (default: detected; `,` only between columns separated
    /// by `;` or tabs).
    #[arg(long, value_parser = parse_decimal)]
    decimal: Option<DecimalSeparator>,
    /// The unit of a numeric time column whose name carries none, e.g. Unix-epoch
    /// milliseconds in a column named `timestamp` (a unit in the name wins).
    #[arg(long, value_enum)]
    time_unit: Option<TimeUnitName>,
    /// The UTC offset of date-times that name no zone, e.g. `+02:00` or `-0530`.
    #[arg(long, default_value = "UTC", value_parser = parse_timezone)]
    timezone: i64,
    /// Added to every time to give session time, ns (a watch's Unix-epoch times onto a
    /// camera's clock).
    #[arg(long, default_value_t = 0, allow_negative_numbers = true)]
    time_offset_ns: i64,
    /// Rows of one source up to this much earlier than an earlier row are sorted into place;
    /// a row further back is an error naming its line, s.
    #[arg(long, default_value_t = 1.0)]
    reorder_window_s: f64,
    /// Rows of one source at one time: `average` keeps their mean (skeletons the first),
    /// `drop` keeps the first.
    #[arg(long, value_enum, default_value_t = DuplicatesName::Average)]
    duplicates: DuplicatesName,
    /// An IMU found to deliver its samples in batches (median interval a quarter of the mean
    /// or less): `retime` spaces them at the rate fitted to the batches, `keep` keeps the
    /// file's times; reported either way.
    #[arg(long, value_enum, default_value_t = BatchedName::Retime)]
    batched: BatchedName,
    /// Units of columns whose names carry none, or the wrong one: a TOML file of
    /// `"column" = "unit"` lines (`"acc_*" = "m/s^2"` for every column starting `acc_`).
    #[arg(long)]
    units: Option<PathBuf>,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum DuplicatesName {
    Average,
    Drop,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum BatchedName {
    Retime,
    Keep,
}

fn parse_delimiter(text: &str) -> std::result::Result<u8, String> {
    match text {
        "," | "comma" => Ok(b','),
        ";" | "semicolon" => Ok(b';'),
        "tab" | "\\t" | "\t" => Ok(b'\t'),
        other => Err(format!("'{other}': expected ',', ';' or tab")),
    }
}

fn parse_decimal(text: &str) -> std::result::Result<DecimalSeparator, String> {
    match text {
        "." | "point" => Ok(DecimalSeparator::Point),
        "," | "comma" => Ok(DecimalSeparator::Comma),
        other => Err(format!("'{other}': expected '.' or ','")),
    }
}

fn parse_timezone(text: &str) -> std::result::Result<i64, String> {
    parse_utc_offset(text).ok_or_else(|| {
        format!("'{text}': expected a UTC offset such as +02:00, -0530 or UTC (no zone names)")
    })
}

impl CsvArgs {
    /// The options these flags give.
    fn options(&self) -> Result<CsvOptions> {
        if !(self.reorder_window_s.is_finite() && self.reorder_window_s >= 0.0) {
            bail!(
                "--reorder-window-s {}: expected seconds, 0 or more",
                self.reorder_window_s
            );
        }
        let units = match &self.units {
            Some(path) => read_units(path)?,
            None => ColumnUnits::default(),
        };
        Ok(CsvOptions {
            delimiter: self.delimiter,
            decimal: self.decimal,
            time_unit: self.time_unit.map(time_unit),
            utc_offset_s: self.timezone,
            time_offset_ns: self.time_offset_ns,
            order: OrderPolicy {
                window_ns: (self.reorder_window_s * 1e9).round().min(9e18) as i64,
                duplicates: match self.duplicates {
                    DuplicatesName::Average => Duplicates::Average,
                    DuplicatesName::Drop => Duplicates::Drop,
                },
                batches: match self.batched {
                    BatchedName::Retime => BatchPolicy::Retime,
                    BatchedName::Keep => BatchPolicy::Keep,
                },
            },
            units,
        })
    }
}

/// A units file: `"column" = "unit"` pairs, TOML.
fn read_units(path: &Path) -> Result<ColumnUnits> {
    let text = crate::io::read_settings(path)?;
    let table: std::collections::BTreeMap<String, String> =
        toml::from_str(&text).with_context(|| {
            format!(
                "{}: not a units file (TOML lines such as \"acc_x\" = \"m/s^2\")",
                path.display()
            )
        })?;
    Ok(ColumnUnits::new(table))
}

fn time_unit(unit: TimeUnitName) -> TimeUnit {
    match unit {
        TimeUnitName::S => TimeUnit::Seconds,
        TimeUnitName::Ms => TimeUnit::Milliseconds,
        TimeUnitName::Us => TimeUnit::Microseconds,
        TimeUnitName::Ns => TimeUnit::Nanoseconds,
    }
}

/// Arguments of `nomen import imu`.
#[derive(Debug, Args)]
pub struct ImuArgs {
    #[command(flatten)]
    common: CommonArgs,
    #[command(flatten)]
    csv: CsvArgs,
    /// The IMU's device id.
    #[arg(long)]
    device: String,
}

/// Arguments of `nomen import fixes`.
#[derive(Debug, Args)]
pub struct FixesArgs {
    #[command(flatten)]
    common: CommonArgs,
    #[command(flatten)]
    csv: CsvArgs,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum Layout {
    JointPerRow,
    SkeletonPerRow,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum SetName {
    KinectV2,
    AzureKinect,
    Coco17,
    Body25,
}

/// Arguments of `nomen import skeletons`.
#[derive(Debug, Args)]
pub struct SkeletonArgs {
    #[command(flatten)]
    common: CommonArgs,
    #[command(flatten)]
    csv: CsvArgs,
    /// Row layout.
    #[arg(long, value_enum, default_value_t = Layout::JointPerRow)]
    layout: Layout,
    /// The estimator whose joint names the file uses (default: nomen's canonical names).
    #[arg(long, value_enum)]
    joint_set: Option<SetName>,
}

/// Arguments of `nomen import azure-kinect`.
#[derive(Debug, Args)]
pub struct KinectArgs {
    #[command(flatten)]
    common: CommonArgs,
    /// The camera's id (as in the registry).
    #[arg(long)]
    camera: String,
    /// Added to every device time to give session time, ns.
    #[arg(long, default_value_t = 0, allow_negative_numbers = true)]
    time_offset_ns: i64,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum TimeUnitName {
    S,
    Ms,
    Us,
    Ns,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum PointJoint {
    /// A head tracker (overhead people counters).
    Head,
    /// A centroid tracker.
    Pelvis,
}

/// Arguments of `nomen import tracker`.
#[derive(Debug, Args)]
pub struct TrackerArgs {
    #[command(flatten)]
    common: CommonArgs,
    /// The tracker's id (a camera of the registry).
    #[arg(long)]
    camera: String,
    /// Metres per tracker unit: 1 for metres, 0.001 for millimetres, or a fitted scale.
    #[arg(long)]
    scale: f64,
    /// Unit of a time column named plain `t` (a named unit, `t_ms`, wins).
    #[arg(long, value_enum)]
    time_unit: Option<TimeUnitName>,
    /// The joint the point stands for.
    #[arg(long, value_enum, default_value_t = PointJoint::Head)]
    joint: PointJoint,
    /// z of 2D points in the tracker's frame, m.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    z_m: f64,
    /// Added to every time to give session time, ns.
    #[arg(long, default_value_t = 0, allow_negative_numbers = true)]
    time_offset_ns: i64,
}

/// Arguments of `nomen import pozyx` and `nomen import sewio`.
#[derive(Debug, Args)]
pub struct RtlsArgs {
    #[command(flatten)]
    common: CommonArgs,
    /// z of fixes the system gives in 2D, m.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    z_m: f64,
    /// Added to every Unix-epoch time to give session time, ns.
    #[arg(long, default_value_t = 0, allow_negative_numbers = true)]
    time_offset_ns: i64,
}

/// Arguments of `nomen import impinj` and `nomen import zebra`.
#[derive(Debug, Args)]
pub struct RfidArgs {
    #[command(flatten)]
    common: CommonArgs,
    /// The reader's name: antennas are `<reader>/<port>` (as in the registry).
    #[arg(long)]
    reader: String,
    /// Added to every Unix-epoch time to give session time, ns.
    #[arg(long, default_value_t = 0, allow_negative_numbers = true)]
    time_offset_ns: i64,
}

/// Runs `nomen import ...`.
pub fn run(command: ImportCommand) -> Result<()> {
    let common = match &command {
        ImportCommand::Imu(a) => &a.common,
        ImportCommand::Fixes(a) => &a.common,
        ImportCommand::Skeletons(a) => &a.common,
        ImportCommand::AzureKinect(a) => &a.common,
        ImportCommand::Tracker(a) => &a.common,
        ImportCommand::Pozyx(a) | ImportCommand::Sewio(a) => &a.common,
        ImportCommand::Impinj(a) | ImportCommand::Zebra(a) => &a.common,
    };
    crate::io::check_distinct(
        &[Some(&common.file), common.registry.as_deref()],
        &[Some(&common.out)],
    )?;
    let is_pozyx = matches!(command, ImportCommand::Pozyx(_));
    let is_impinj = matches!(command, ImportCommand::Impinj(_));
    let device = match &command {
        ImportCommand::Imu(a) => Some(DeviceId::new(a.device.clone())),
        _ => None,
    };
    let mut imu_spec = None;
    let (common, mut messages) = match command {
        ImportCommand::Imu(a) => {
            let (spec, imported) = import_imu_auto(
                open(&a.common.file)?,
                &name(&a.common.file),
                DeviceId::new(a.device),
                &a.csv.options()?,
            )?;
            eprintln!(
                "{}: {} columns mapped",
                name(&a.common.file),
                spec.columns.len()
            );
            imu_spec = Some(spec);
            let msgs = summarise(imported, &a.common.file);
            (a.common, msgs)
        }
        ImportCommand::Fixes(a) => {
            let file = &a.common.file;
            let imported = import_fixes(
                open(file)?,
                &name(file),
                &FixCsvSpec::default(),
                &a.csv.options()?,
            )?;
            let msgs = summarise(imported, file);
            (a.common, msgs)
        }
        ImportCommand::Skeletons(a) => {
            let spec = SkeletonCsvSpec {
                layout: match a.layout {
                    Layout::JointPerRow => SkeletonLayout::JointPerRow,
                    Layout::SkeletonPerRow => SkeletonLayout::SkeletonPerRow,
                },
                joint_set: a.joint_set.map(|s| match s {
                    SetName::KinectV2 => JointSet::KinectV2,
                    SetName::AzureKinect => JointSet::AzureKinect,
                    SetName::Coco17 => JointSet::Coco17,
                    SetName::Body25 => JointSet::Body25,
                }),
                ..Default::default()
            };
            let file = &a.common.file;
            let imported = import_skeletons(open(file)?, &name(file), &spec, &a.csv.options()?)?;
            let msgs = summarise(imported, file);
            (a.common, msgs)
        }
        ImportCommand::AzureKinect(a) => {
            let config = AzureKinectConfig {
                camera: CameraId::new(a.camera),
                time_offset_ns: a.time_offset_ns,
            };
            let file = &a.common.file;
            let decoded = read_azure_kinect(reader(file)?, &name(file), &config)?;
            let msgs = report(decoded, file);
            (a.common, msgs)
        }
        ImportCommand::Tracker(a) => {
            let config = TrackerConfig {
                camera: CameraId::new(a.camera),
                scale_m_per_unit: a.scale,
                time_unit: a.time_unit.map(time_unit),
                joint: match a.joint {
                    PointJoint::Head => Joint::Head,
                    PointJoint::Pelvis => Joint::Pelvis,
                },
                z_m: a.z_m,
                time_offset_ns: a.time_offset_ns,
            };
            let file = &a.common.file;
            let decoded = read_tracker(reader(file)?, &name(file), &config)?;
            let msgs = report(decoded, file);
            (a.common, msgs)
        }
        ImportCommand::Pozyx(a) | ImportCommand::Sewio(a) => {
            let config = RtlsConfig {
                time_offset_ns: a.time_offset_ns,
                z_m: a.z_m,
            };
            let file = &a.common.file;
            let decoded = if is_pozyx {
                read_pozyx(reader(file)?, &name(file), &config)?
            } else {
                read_sewio(reader(file)?, &name(file), &config)?
            };
            let msgs = report(decoded, file);
            (a.common, msgs)
        }
        ImportCommand::Impinj(a) | ImportCommand::Zebra(a) => {
            let config = RfidConfig {
                reader: a.reader,
                time_offset_ns: a.time_offset_ns,
            };
            let file = &a.common.file;
            let decoded = if is_impinj {
                read_impinj(reader(file)?, &name(file), &config)?
            } else {
                read_zebra(reader(file)?, &name(file), &config)?
            };
            let msgs = report(decoded, file);
            (a.common, msgs)
        }
    };
    let header = match &common.registry {
        Some(path) => {
            let registry: Registry = serde_json::from_str(&crate::io::read_settings(path)?)
                .with_context(|| format!("{}: not a registry", path.display()))?;
            // The one id an IMU import takes from the command line, named as such.
            if let Some(device) = &device
                && registry.wearer(device).is_none()
            {
                bail!(
                    "--device {device} is not worn by anyone in the registry {}",
                    path.display()
                );
            }
            Header::new(registry)
        }
        None => Header::without_registry(),
    }
    .with_meta("generator", "nomen import")
    .with_meta("source", name(&common.file));
    sort_for_writing(&mut messages);
    check_plausible(
        &messages,
        header.registry.as_ref(),
        imu_spec.as_ref(),
        &name(&common.file),
    )?;
    write_recording(&common.out, &header, &messages).with_context(|| match &common.registry {
        Some(path) => format!(
            "checking the ids of {} against the registry {}",
            name(&common.file),
            path.display()
        ),
        None => format!("converting {}", name(&common.file)),
    })?;
    eprintln!(
        "wrote {} messages to {}",
        messages.len(),
        crate::io::sink_name(&common.out)
    );
    Ok(())
}

fn open(path: &Path) -> Result<std::fs::File> {
    std::fs::File::open(path).with_context(|| format!("cannot open {}", path.display()))
}

/// The most a vendor file may hold, bytes: 256 MiB, as a CSV file (`docs/limits.md`).
const MAX_VENDOR_FILE_BYTES: u64 = 256 * nomen_core::bounded::MIB_BYTES;

/// A vendor file read as a stream of at most [`MAX_VENDOR_FILE_BYTES`] (whatever size the file
/// system reports); each reader also bounds its lines.
fn reader(
    path: &Path,
) -> Result<std::io::BufReader<nomen_core::bounded::BoundedReader<std::fs::File>>> {
    let limits = nomen_core::bounded::Limits::text(
        "a vendor file",
        MAX_VENDOR_FILE_BYTES,
        MAX_VENDOR_FILE_BYTES,
    );
    open(path).map(|file| {
        std::io::BufReader::new(nomen_core::bounded::BoundedReader::new(
            file,
            &name(path),
            limits,
        ))
    })
}

/// The messages of a CSV import, after saying on stderr how the file was read, what was sorted
/// and merged, and warning of batched delivery with its numbers.
fn summarise(imported: CsvImport, file: &Path) -> Vec<Message> {
    eprintln!("{}: {}", name(file), imported.report);
    for batching in &imported.report.batching {
        eprintln!("warning: {}: {batching}", name(file));
    }
    imported.messages
}

/// The messages of a vendor import, after saying on stderr what was skipped on purpose.
fn report(decoded: Decoded, file: &Path) -> Vec<Message> {
    if decoded.skipped.total() > 0 {
        eprintln!("{}: {}", name(file), decoded.skipped);
    }
    decoded.messages
}

fn name(path: &Path) -> String {
    path.display().to_string()
}

/// Refuses an import whose time stamps or accelerations contradict their labels or the
/// registry's rates ([`Plausibility`]): a camera ten times off its declared rate, an IMU at
/// 100 kHz or below 1 Hz, gravity of 1 in a column labelled m/s². For an IMU CSV file the error
/// names the column and the unit its values are probably in.
fn check_plausible(
    messages: &[Message],
    registry: Option<&Registry>,
    imu_spec: Option<&ImuCsvSpec>,
    file: &str,
) -> Result<()> {
    let mut plausibility = Plausibility::new(registry);
    let mut findings: Vec<Finding> = messages
        .iter()
        .filter_map(|m| plausibility.push(m))
        .collect();
    findings.extend(plausibility.finish());
    let Some(finding) = findings.into_iter().next() else {
        return Ok(());
    };
    let Some(spec) = imu_spec else {
        bail!("{file}: {finding}");
    };
    match &finding {
        Finding::Rate {
            observed_hz,
            factor: Some(k),
            ..
        } => {
            let TimeFormat::Epoch(labelled) = spec.time_format else {
                bail!("{file}: {finding}");
            };
            let meant_ns = labelled.ns_per_unit() * k;
            let meant = [(1.0, "ns"), (1e3, "us"), (1e6, "ms"), (1e9, "s")]
                .into_iter()
                .find(|(ns, _)| (meant_ns / ns - 1.0).abs() < 1e-6)
                .map(|(_, unit)| unit);
            match meant {
                Some(unit) => bail!(
                    "{file}: the time column '{}' read as {} gives an IMU at {:.3} Hz: its values \
                     are probably in {unit}; name the unit in the column, e.g. 't ({unit})'",
                    spec.time_column,
                    time_unit_name(labelled),
                    observed_hz
                ),
                None => bail!("{file}: {finding}"),
            }
        }
        Finding::Gravity { median_mps2, .. } => {
            let Some(column) = spec
                .columns
                .iter()
                .find(|c| matches!(c.quantity, ImuQuantity::Accel(_)))
            else {
                bail!("{file}: {finding}");
            };
            let ImuQuantity::Accel(labelled) = column.quantity else {
                bail!("{file}: {finding}");
            };
            let raw = median_mps2 / labelled.to_mps2();
            let meant = [
                ("m/s^2", 1.0),
                ("g", STANDARD_GRAVITY_MPS2),
                ("mg", STANDARD_GRAVITY_MPS2 * 1e-3),
            ]
            .into_iter()
            .find(|(_, to_mps2)| (3.0..=30.0).contains(&(raw * to_mps2)));
            let hint = match meant {
                Some((unit, _)) => format!(
                    ": its values are probably in {unit}; name that unit in the accelerometer \
                     columns, e.g. 'acc_x ({unit})'"
                ),
                None => String::new(),
            };
            bail!(
                "{file}: the accelerometer column '{}' read as {} gives a median magnitude of \
                 {:.3} m/s², where gravity alone gives 9.81{hint}",
                column.column,
                if labelled == AccelUnit::StandardGravity {
                    "g"
                } else {
                    "m/s^2"
                },
                median_mps2
            )
        }
        Finding::Rate { .. } => bail!("{file}: {finding}"),
    }
}

fn time_unit_name(unit: TimeUnit) -> &'static str {
    match unit {
        TimeUnit::Seconds => "seconds",
        TimeUnit::Milliseconds => "milliseconds",
        TimeUnit::Microseconds => "microseconds",
        TimeUnit::Nanoseconds => "nanoseconds",
    }
}
