//! `nomen import`: CSV files → a nomen recording, with units read from the column names.

use super::mocap::write_recording;
use anyhow::{Context, Result, bail};
use clap::{Args, Subcommand, ValueEnum};
use nomen_core::skeleton::sets::JointSet;
use nomen_core::{DeviceId, Registry};
use nomen_recording::csv::{
    FixCsvSpec, SkeletonCsvSpec, SkeletonLayout, import_fixes, import_imu_auto, import_skeletons,
};
use nomen_recording::{Header, sort_for_writing};
use std::path::{Path, PathBuf};

/// `nomen import ...`
#[derive(Debug, Subcommand)]
pub enum ImportCommand {
    /// An IMU CSV: a time column and accel/gyro (/mag) columns whose names carry units, e.g.
    /// `t (s), acc_x (g), gyr_x (deg/s)` or `time_ms, accel_x_mps2, gyro_x_radps`.
    Imu(ImuArgs),
    /// RTLS tag fixes: `t, tag, x, y, z [, quality]` (units in the names, e.g. `x_m`, `t_ms`).
    Fixes(CommonArgs),
    /// Camera skeletons, one joint per row (`t, camera, track, joint, x, y, z [, confidence,
    /// state]`) or one skeleton per row (`t, camera, track, <joint>_x, ...`).
    Skeletons(SkeletonArgs),
}

/// Options shared by every import.
#[derive(Debug, Args)]
pub struct CommonArgs {
    /// The CSV file.
    pub file: PathBuf,
    /// Output recording (`-` for stdout).
    #[arg(long)]
    pub out: PathBuf,
    /// A registry (JSON, as in a recording header) to check ids against; without it the
    /// recording carries no registry and ids are not checked.
    #[arg(long)]
    pub registry: Option<PathBuf>,
}

/// Arguments of `nomen import imu`.
#[derive(Debug, Args)]
pub struct ImuArgs {
    #[command(flatten)]
    common: CommonArgs,
    /// The IMU's device id.
    #[arg(long)]
    device: String,
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
    /// Row layout.
    #[arg(long, value_enum, default_value_t = Layout::JointPerRow)]
    layout: Layout,
    /// The estimator whose joint names the file uses (default: nomen's canonical names).
    #[arg(long, value_enum)]
    joint_set: Option<SetName>,
}

/// Runs `nomen import ...`.
pub fn run(command: ImportCommand) -> Result<()> {
    let common = match &command {
        ImportCommand::Imu(a) => &a.common,
        ImportCommand::Fixes(c) => c,
        ImportCommand::Skeletons(a) => &a.common,
    };
    crate::io::check_distinct(
        &[Some(&common.file), common.registry.as_deref()],
        &[Some(&common.out)],
    )?;
    let device = match &command {
        ImportCommand::Imu(a) => Some(DeviceId::new(a.device.clone())),
        _ => None,
    };
    let (common, mut messages) = match command {
        ImportCommand::Imu(a) => {
            let (spec, msgs) = import_imu_auto(
                open(&a.common.file)?,
                &name(&a.common.file),
                DeviceId::new(a.device),
            )?;
            eprintln!(
                "{}: {} columns mapped",
                name(&a.common.file),
                spec.columns.len()
            );
            (a.common, msgs)
        }
        ImportCommand::Fixes(c) => {
            let msgs = import_fixes(open(&c.file)?, &name(&c.file), &FixCsvSpec::default())?;
            (c, msgs)
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
            let msgs = import_skeletons(open(&a.common.file)?, &name(&a.common.file), &spec)?;
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

fn name(path: &Path) -> String {
    path.display().to_string()
}
