//! `nomen replay`: a recording published to an MQTT broker with its timing, as live sources
//! would publish it (`docs/live.md`), e.g. into `nomen serve`.

use super::serve::{MqttTlsArgs, with_tls};
use anyhow::Result;
use clap::Args;
use nomen_live::broker::BrokerAddr;
use nomen_live::replay::{ReplayOptions, Speed, replay};
use std::path::PathBuf;
use std::time::Duration;

/// Arguments of `nomen replay`.
#[derive(Debug, Args)]
pub struct ReplayArgs {
    /// The recording. Its header's registry is published first, retained.
    pub recording: PathBuf,
    /// The broker, `mqtt://[user:password@]host:port`, or `mqtts://...` for MQTT over TLS.
    #[arg(long, value_name = "URL", default_value = "mqtt://127.0.0.1:1883")]
    pub mqtt: String,
    #[command(flatten)]
    pub tls: MqttTlsArgs,
    /// Seconds of recording per second: 1 is real time, 10 ten times faster, `max` as fast as
    /// the broker acknowledges.
    #[arg(long, default_value = "1", value_name = "1|N|max")]
    pub speed: Speed,
}

/// Runs `nomen replay`.
pub fn run(args: ReplayArgs) -> Result<()> {
    let options = ReplayOptions {
        broker: with_tls(
            BrokerAddr::parse(&args.mqtt)?,
            args.tls.mqtt_ca.clone(),
            args.tls.client_cert(),
        )?,
        client_id: format!("nomen-replay-{}", std::process::id()),
        speed: args.speed,
        connect_timeout: Duration::from_secs(10),
    };
    let s = replay(&args.recording, &options)?;
    eprintln!(
        "{}: published {} messages to {} in {:.2} s ({:.0} messages/s){}{}{}",
        crate::io::source_name(&args.recording),
        s.num_published,
        options.broker,
        s.elapsed_s,
        s.num_published as f64 / s.elapsed_s.max(1e-9),
        if s.has_registry {
            ", the registry retained on nomen/in/registry"
        } else {
            ", no registry in the header"
        },
        if s.num_published_again > 0 {
            format!(
                "; published {} again after the broker came back",
                s.num_published_again
            )
        } else {
            String::new()
        },
        if s.num_not_inputs > 0 {
            format!(
                "; left out {} outputs and ground-truth lines",
                s.num_not_inputs
            )
        } else {
            String::new()
        }
    );
    Ok(())
}
