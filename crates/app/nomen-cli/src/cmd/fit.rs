//! `nomen fit`: sensor noise models from real recordings.

use anyhow::Result;
use clap::Subcommand;

/// `nomen fit ...`
#[derive(Debug, Subcommand)]
pub enum FitCommand {}

/// Runs `nomen fit ...`.
pub fn run(command: FitCommand) -> Result<()> {
    match command {}
}
