//! `wavetrace compare`: the error of an image against a reference, as text or JSON.

use clap::Args;
use std::path::PathBuf;

use wavetrace::tools::compare::{load_linear, metrics};
use wavetrace::{Error, Result};

use super::say;

#[derive(Args, Debug)]
pub struct CompareArgs {
    /// The image to judge (PNG or EXR).
    test: PathBuf,
    /// The reference image (PNG or EXR), same size.
    reference: PathBuf,
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
}

/// Prints the metrics. Built without the `flip` feature, the FLIP error is `n/a` in the
/// text and `null` in the JSON, and a note on stderr says why.
pub fn run(args: CompareArgs) -> Result<()> {
    let test = load_linear(&args.test)?;
    let reference = load_linear(&args.reference)?;
    let m = metrics(&test, &reference)
        .map_err(|e| Error::input(format!("`{}` vs `{}`: {e}", args.test.display(), args.reference.display())))?;
    if !cfg!(feature = "flip") {
        eprintln!("note: no FLIP error: wavetrace was built without the `flip` feature (cargo build --features flip)");
    }
    if args.json {
        say(&serde_json::to_string_pretty(&m).map_err(|e| Error::Internal(e.to_string()))?);
    } else {
        let flip = if cfg!(feature = "flip") { format!("{:.6}", m.flip) } else { "n/a".into() };
        say(&format!("rmse {:.6}\nrel_mse {:.6}\npsnr {:.3} dB\nflip {flip}", m.rmse, m.rel_mse, m.psnr));
    }
    Ok(())
}
