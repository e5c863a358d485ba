//! `wavetrace sweep`: renders the cross product of `--param` values, measures each render
//! against a reference, and writes the CSV, the JSON and the plots.

use clap::Args;
use std::io::IsTerminal;
use std::path::PathBuf;

use wavetrace::tools::output::watch_signals;
use wavetrace::tools::sweep::{self, Reference, SweepOptions};
use wavetrace::Result;

use super::{at_least_one, say};

#[derive(Args, Debug)]
pub struct SweepArgs {
    /// Scene file (TOML). Omitted: the embedded default scene.
    scene: Option<PathBuf>,
    /// A swept value list, KEY=V1,V2,... (repeatable; points are the cross product).
    #[arg(long = "param", value_name = "KEY=V1,V2,...")]
    params: Vec<String>,
    /// Override applied to every point and to the reference (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    sets: Vec<String>,
    /// Reference image (PNG or EXR, same size) instead of rendering one.
    #[arg(long, value_name = "REF", conflicts_with = "reference_spp")]
    reference: Option<PathBuf>,
    /// Samples per pixel of the rendered (and cached) uniform reference.
    #[arg(long, value_name = "N", value_parser = at_least_one::<u32>())]
    reference_spp: Option<u32>,
    /// Output folder (created if missing; its parent must exist).
    #[arg(short, long, default_value = "sweep")]
    output: PathBuf,
    /// Worker threads per render (default: all cores); at most 4 per CPU (a limit of at
    /// least 64 and at most 1024).
    #[arg(long, allow_negative_numbers = true, value_parser = super::thread_count)]
    threads: Option<usize>,
    /// Print nothing but errors.
    #[arg(short, long)]
    quiet: bool,
}

/// Runs the sweep and prints where its files went. Built without the `plot` feature the
/// sweep writes the CSV and the JSON only, and a note on stderr says why.
pub fn run(args: SweepArgs) -> Result<()> {
    // A signal ends the sweep, removing the temporary file of what was being written.
    watch_signals(None, &[]);
    let params = args.params.iter().map(|p| sweep::parse_param(p)).collect::<Result<Vec<_>>>()?;
    let reference = match (&args.reference, args.reference_spp) {
        (Some(path), _) => Reference::File(path.clone()),
        (None, Some(n)) => Reference::Spp(n),
        (None, None) => Reference::default(),
    };
    let opts = SweepOptions {
        scene: args.scene.clone(),
        params,
        sets: args.sets.clone(),
        reference,
        out_dir: args.output.clone(),
        threads: args.threads,
        progress: !args.quiet && std::io::stderr().is_terminal(),
    };
    let result = sweep::run(&opts)?;
    if !args.quiet {
        say(&format!(
            "{} points -> {} (reference {}{})",
            result.points.len(),
            args.output.display(),
            result.reference.path.display(),
            match (result.reference.spp, result.reference.rendered) {
                (None, _) => "",
                (Some(_), true) => ", rendered",
                (Some(_), false) => ", cached",
            }
        ));
        if !cfg!(feature = "plot") {
            eprintln!("note: no plots: wavetrace was built without the `plot` feature (cargo build --features plot)");
        }
    }
    Ok(())
}
