//! `nomen fit`: sensor noise models from real recordings, so integrators can characterise their
//! own IMUs, UWB systems and RSSI readers (and the simulator gets defaults fitted to real data).

use anyhow::{Context, Result};
use clap::{Args, Subcommand, ValueEnum};
use nomen_fit::dataset::{
    FitAllConfig, fit_all, fit_imu_file, fit_rssi_files, fit_uwb_mocap_files,
};
use nomen_fit::load::{ImuCsvFormat, RssiCsvFormat, UwbCsvFormat};
use nomen_fit::uwb::UwbSetup;
use nomen_fit::{ImuFitConfig, PathLossConfig};
use serde::Serialize;
use std::io::Write;
use std::path::PathBuf;

/// `nomen fit ...`
#[derive(Debug, Subcommand)]
pub enum FitCommand {
    /// Every fit on the shared data folder (BROAD + x-io IMU, LIAS UWB, Kolakowski BLE).
    All(AllArgs),
    /// IMU white noise, bias and Allan deviation from the still segments of a CSV recording.
    Imu(ImuArgs),
    /// UWB two-way-ranging error (bias, spread, heavy tail, outliers) against motion capture.
    Uwb(UwbArgs),
    /// RSSI log-distance path loss and shadowing per anchor.
    Rssi(RssiArgs),
}

/// Arguments of `nomen fit all`.
#[derive(Debug, Args)]
pub struct AllArgs {
    /// The shared data folder (default: `$NOMEN_DATA`, else `../shared/data`, else the one
    /// beside the source checkout, as for `nomen simulate`).
    data: Option<PathBuf>,
    /// Print JSON instead of the markdown report.
    #[arg(long)]
    json: bool,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum ImuFormat {
    /// BROAD benchmark CSV (m/s², rad/s, µT, `movement` flags the moving phase).
    Broad,
    /// x-io Technologies CSV (g, deg/s, µT).
    Xio,
}

/// Arguments of `nomen fit imu`.
#[derive(Debug, Args)]
pub struct ImuArgs {
    /// The CSV file.
    file: PathBuf,
    /// Column layout and units.
    #[arg(long, value_enum)]
    format: ImuFormat,
}

/// Arguments of `nomen fit uwb`.
#[derive(Debug, Args)]
pub struct UwbArgs {
    /// Range table (LIAS layout: time, then anchor-major tag ranges in metres, 0 = missing).
    #[arg(long)]
    ranges: PathBuf,
    /// Motion-capture table of the rigid body carrying the tags (same clock).
    #[arg(long)]
    mocap: PathBuf,
}

/// Arguments of `nomen fit rssi`.
#[derive(Debug, Args)]
pub struct RssiArgs {
    /// Calibration table with tag positions and one RSSI column per anchor (Kolakowski layout).
    #[arg(long)]
    calibration: PathBuf,
    /// Anchor positions (`id,x,y,z`, metres).
    #[arg(long)]
    anchors: PathBuf,
    /// A second table to validate the fitted model on.
    #[arg(long)]
    validate: Option<PathBuf>,
}

/// Runs `nomen fit ...`.
pub fn run(command: FitCommand) -> Result<()> {
    match command {
        FitCommand::All(a) => {
            let data = crate::io::find_data(a.data.as_deref())?;
            eprintln!("fitting the recordings in {} ...", data.display());
            let models = fit_all(&data, &FitAllConfig::default())
                .with_context(|| format!("fitting the recordings in {}", data.display()))?;
            if a.json {
                print_json(&models)
            } else {
                let mut stdout = crate::io::stdout();
                write!(stdout, "{}", models.to_markdown())?;
                Ok(())
            }
        }
        FitCommand::Imu(a) => {
            let format = match a.format {
                ImuFormat::Broad => ImuCsvFormat::broad(),
                ImuFormat::Xio => ImuCsvFormat::xio(),
            };
            print_json(&fit_imu_file(&a.file, &format, &ImuFitConfig::default())?)
        }
        FitCommand::Uwb(a) => {
            let (fit, convention, _) = fit_uwb_mocap_files(
                &a.ranges,
                &a.mocap,
                &UwbCsvFormat::lias(),
                &UwbSetup::lias_2022_08_14(),
                None,
                &FitAllConfig::default(),
            )?;
            eprintln!(
                "quaternion convention chosen from the data: {:?}",
                convention.chosen
            );
            print_json(&fit)
        }
        FitCommand::Rssi(a) => print_json(&fit_rssi_files(
            &a.calibration,
            &a.anchors,
            a.validate.as_deref(),
            &RssiCsvFormat::kolakowski(),
            &PathLossConfig::default(),
        )?),
    }
}

fn print_json(value: &impl Serialize) -> Result<()> {
    let mut stdout = crate::io::stdout();
    writeln!(stdout, "{}", serde_json::to_string_pretty(value)?)?;
    Ok(())
}
