//! `wavetrace study`: where adaptive sampling pays. Renders every scene of a manifest with
//! every method's grid of settings, against a converged reference, and writes the tables
//! (`study.md`), the rows (`study.csv`, `study.json`) and a plot per scene.

use clap::Args;
use std::io::IsTerminal;
use std::path::PathBuf;

use wavetrace::tools::output::watch_signals;
use wavetrace::tools::study::{self, StudyOptions};
use wavetrace::Result;

use super::{at_least_one, say};

#[derive(Args, Debug)]
pub struct StudyArgs {
    /// The study manifest (TOML): scenes, methods, grids (see `wavetrace::tools::study::manifest`).
    #[arg(default_value = "benches/study.toml")]
    manifest: PathBuf,
    /// Output folder (created if missing; its parent must exist). The references are
    /// cached there, so a rerun renders only the grids.
    #[arg(short, long, visible_alias = "output", default_value = "study")]
    out: PathBuf,
    /// Tiny images, each method's quick grid and a 64-spp reference: a run of seconds, for tests.
    #[arg(long)]
    quick: bool,
    /// Only this scene, by its manifest name (repeatable).
    #[arg(long = "scene", value_name = "NAME")]
    scenes: Vec<String>,
    /// Renders per setting; the seconds are their median (rays are exact).
    #[arg(long, value_name = "N", default_value = "1", value_parser = at_least_one::<u32>())]
    runs: u32,
    /// Seeds per setting (1 to 16): the scene's `render.seed` and the next ones; each
    /// setting's FLIP and other errors, rays and seconds are their means.
    #[arg(long, value_name = "N", default_value = "1", value_parser = clap::value_parser!(u32).range(1..=study::MAX_SEEDS as i64))]
    seeds: u32,
    /// Camera samples of every scene's reference, over the manifest's.
    #[arg(long, value_name = "N", value_parser = at_least_one::<u32>())]
    reference_spp: Option<u32>,
    /// Worker threads per render (default: all cores).
    #[arg(long, allow_negative_numbers = true, value_parser = super::thread_count)]
    threads: Option<usize>,
    /// Print nothing but errors.
    #[arg(short, long)]
    quiet: bool,
}

/// Runs the study and prints where its files went and the winners.
pub fn run(args: StudyArgs) -> Result<()> {
    watch_signals(None, &[]);
    let opts = StudyOptions {
        manifest: args.manifest.clone(),
        out_dir: args.out.clone(),
        quick: args.quick,
        only: args.scenes.clone(),
        runs: args.runs,
        seeds: args.seeds,
        reference_spp: args.reference_spp,
        threads: args.threads,
        progress: !args.quiet && std::io::stderr().is_terminal(),
    };
    let result = study::run(&opts)?;
    if !args.quiet {
        for s in &result.scenes {
            let wins: Vec<String> =
                s.targets.iter().map(|t| format!("{} {}", t.label, t.winner_seconds.unwrap_or("none"))).collect();
            say(&format!("{}: {}", s.name, wins.join(", ")));
        }
        say(&format!(
            "{} scenes, {} renders in {:.0} s -> {}",
            result.scenes.len(),
            result.scenes.iter().map(|s| s.rows.len()).sum::<usize>(),
            result.seconds,
            args.out.join(study::MD_FILE).display()
        ));
    }
    Ok(())
}
