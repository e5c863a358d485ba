//! `wavetrace merge`: the tiles of one render into the full image, or (`--missing`) the
//! tasks still to render.

use clap::Args;
use std::path::PathBuf;

use wavetrace::tools::merge::{assemble, coverage, read_tiles, stats};
use wavetrace::tools::output::{check_distinct, check_image_path, check_output, is_stdout, watch_signals, Batch};
use wavetrace::{Error, Result};

use super::say;

#[derive(Args, Debug)]
pub struct MergeArgs {
    /// Tile EXRs written by `wavetrace render --crop/--crop-window/--tile`.
    #[arg(required = true, value_name = "TILE")]
    tiles: Vec<PathBuf>,
    /// The full image; the extension picks the format (.png or .exr).
    #[arg(short, long, required_unless_present = "missing")]
    output: Option<PathBuf>,
    /// Print the `--tile` task indices no tile holds, one per line, and write nothing.
    #[arg(long, conflicts_with_all = ["output", "allow_missing", "stats_json"])]
    missing: bool,
    /// Write the image even when pixels are missing (they are black; the stats say which).
    #[arg(long)]
    allow_missing: bool,
    /// Write the merged stats (rays and seconds summed, a row per tile) as JSON (`-`:
    /// standard output).
    #[arg(long, value_name = "PATH")]
    stats_json: Option<PathBuf>,
    /// Print nothing but errors.
    #[arg(short, long)]
    quiet: bool,
}

/// Merges; exit status 0, or an input error (exit 2) naming the tiles concerned.
pub fn run(args: MergeArgs) -> Result<i32> {
    if let Some(out) = &args.output {
        check_image_path(out)?;
    }
    if let Some(p) = &args.stats_json {
        check_output(p)?;
    }
    // An output naming a tile would destroy the input it is made from; two outputs
    // naming one file would keep only the last.
    let mut outputs: Vec<(&str, &std::path::Path)> = Vec::new();
    outputs.extend(args.output.iter().map(|p| ("-o", p.as_path())));
    outputs.extend(args.stats_json.iter().map(|p| ("--stats-json", p.as_path())));
    let inputs: Vec<(&str, &std::path::Path)> = args.tiles.iter().map(|p| ("the input tile", p.as_path())).collect();
    check_distinct(&outputs, &inputs)?;
    let tiles = read_tiles(&args.tiles)?;
    let cov = coverage(&tiles)?;
    if args.missing {
        let tasks = cov.missing_tasks.as_ref().ok_or_else(|| {
            Error::input("merge --missing: the tiles are not all `--tile K/N` tasks of one N, so there are no task indices to list")
        })?;
        for k in tasks {
            say(&k.to_string());
        }
        return Ok(0);
    }
    if cov.missing_pixels > 0 && !args.allow_missing {
        return Err(Error::input(format!(
            "merge: {}; nothing written (--allow-missing writes them black)",
            cov.describe()
        )));
    }
    let out = args.output.as_ref().ok_or_else(|| Error::input("merge: no output (-o OUT)"))?;
    let image = assemble(&tiles);
    let merged = stats(&tiles, &cov);
    // All or nothing: a stats file that cannot be written leaves the image unwritten too.
    watch_signals(None, &outputs.iter().map(|(_, p)| *p).collect::<Vec<_>>());
    let mut batch = Batch::new();
    batch.image(out, &image)?;
    if let Some(p) = &args.stats_json {
        let json = serde_json::to_string_pretty(&merged).map_err(|e| Error::Internal(e.to_string()))?;
        batch.text(p, &(json + "\n"))?;
    }
    batch.commit()?;
    if cov.missing_pixels > 0 {
        eprintln!("warning: {} (written black)", cov.describe());
    }
    if !args.quiet {
        // With the stats JSON on stdout, the summary goes to stderr so the JSON stays whole.
        let line = |t: &str| if args.stats_json.as_deref().is_some_and(is_stdout) { eprintln!("{t}") } else { say(t) };
        line(&format!(
            "{} tiles, {} rays, {:.3} s summed -> {}",
            tiles.len(),
            merged.rays,
            merged.seconds,
            out.display()
        ));
    }
    Ok(0)
}
