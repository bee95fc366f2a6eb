//! Fits every sensor model to the shared recordings and prints the markdown report; with
//! `--json PATH` also writes the `FittedModels` as JSON.
//!
//! `cargo run -p nomen-fit --example fit_all --release -- ../shared/data [--json fitted.json]`

use nomen_fit::{FitAllConfig, fit_all};
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let data_dir = PathBuf::from(args.next().unwrap_or_else(|| "../shared/data".into()));
    let json_path = match (args.next().as_deref(), args.next()) {
        (Some("--json"), Some(p)) => Some(PathBuf::from(p)),
        (None, _) => None,
        _ => return Err("usage: fit_all [DATA_DIR] [--json PATH]".into()),
    };
    let models = fit_all(&data_dir, &FitAllConfig::default())?;
    #[allow(clippy::print_stdout)]
    {
        println!("{models}");
    }
    if let Some(p) = json_path {
        std::fs::write(&p, serde_json::to_string_pretty(&models)?)?;
    }
    Ok(())
}
