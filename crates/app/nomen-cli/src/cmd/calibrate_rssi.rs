//! `nomen calibrate rssi RECORDING`: Llorca's automatic RSSI calibration — pair each read of
//! the tag with the one tracked person's position, fit every antenna's model, print the
//! parameters, residuals and warnings, and write the model file the association loads.

use anyhow::{Context, Result, bail};
use clap::{Args, ValueEnum};
use nomen_core::Message;
use nomen_recording::{ReadOptions, RecordingReader};
use nomen_rssi::{CalibrationConfig, ModelKind, RssiUnit, TagPlacement, calibrate};
use std::io::Write;
use std::path::PathBuf;

/// Which RSSI model to fit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ModelArg {
    /// `P = P1 − K·log10(D)`.
    Standard,
    /// `P = P1 − K1·log10(D) + K2·θ` (antennas with a boresight).
    Directional,
}

/// Arguments of `nomen calibrate rssi`.
#[derive(Debug, Args)]
pub struct CalibrateRssiArgs {
    /// A recording (header with the registry) in which one tagged person is tracked alone.
    pub recording: PathBuf,
    /// The model to fit.
    #[arg(long, value_enum, default_value_t = ModelArg::Standard)]
    pub model: ModelArg,
    /// Tag height above the floor, m (Llorca fixes it); the tag's x, y are the pelvis'.
    /// Default 1.3 m unless --at-site.
    #[arg(long, conflicts_with = "at_site")]
    pub tag_height: Option<f64>,
    /// Put the tag at the joint the registry names as its site instead of a fixed height.
    #[arg(long)]
    pub at_site: bool,
    /// The reader reports dBm×100: divide by 100 (otherwise such values are rejected).
    #[arg(long)]
    pub centi_dbm: bool,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
    /// Write the model file (JSON) here.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// Runs `nomen calibrate rssi`.
pub fn run(args: CalibrateRssiArgs) -> Result<()> {
    crate::io::check_distinct(&[Some(&args.recording)], &[args.out.as_deref()])?;
    let name = crate::io::source_name(&args.recording);
    let reader =
        RecordingReader::open_with_options(&args.recording, ReadOptions::default().holding_all())
            .with_context(|| format!("reading {name}"))?;
    let Some(registry) = reader.header().registry.clone() else {
        bail!("{name}: the header carries no registry (antenna positions are needed)");
    };
    let messages: Vec<Message> = reader
        .collect::<std::result::Result<_, _>>()
        .with_context(|| format!("reading {name}"))?;
    let placement = if args.at_site {
        TagPlacement::RegistrySite
    } else {
        args.tag_height
            .map_or_else(TagPlacement::default, TagPlacement::FixedHeight)
    };
    let config = CalibrationConfig {
        model: match args.model {
            ModelArg::Standard => ModelKind::Standard,
            ModelArg::Directional => ModelKind::Directional,
        },
        placement,
        rssi_unit: if args.centi_dbm {
            RssiUnit::CentiDbm
        } else {
            RssiUnit::Dbm
        },
        ..CalibrationConfig::default()
    };
    let report = calibrate(&registry, &messages, &config, &name)?;
    let mut stdout = crate::io::stdout();
    if args.json {
        writeln!(stdout, "{}", serde_json::to_string_pretty(&report)?)?;
    } else {
        write!(stdout, "{report}")?;
    }
    if let Some(out) = &args.out {
        let text = report.model.to_json()? + "\n";
        crate::io::write_renamed(out, text.as_bytes())?;
        eprintln!("model written to {}", crate::io::sink_name(out));
    }
    Ok(())
}
