//! `wavetrace render` (and `wavetrace` with no subcommand): renders a scene to an image,
//! with the stats table, stats JSON, trace and heatmaps on request; Ctrl-C writes what
//! is finished and exits 130.

use clap::{Args, ValueEnum};
use std::io::IsTerminal;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Instant;

use wavetrace::scene::load;
use wavetrace::stats::{chrome_trace, Report, SceneReport};
use wavetrace::tools::heatmap::{self, HeatmapKind};
use wavetrace::tools::output::{check_folder, check_image_path, check_png_path, write_image, write_png, write_text};
use wavetrace::{render, Error, RenderOptions, Result};

use super::{at_least_one, say, scene_source};

#[derive(Args, Debug, Default)]
pub struct RenderArgs {
    /// Scene file: TOML, or Mitsuba 3 XML by the `.xml` extension. Omitted: the embedded
    /// default scene.
    scene: Option<PathBuf>,
    /// Set a Mitsuba XML parameter (`$name`), as `mitsuba -D name=value` does; wins over
    /// the file's `<default name=...>`. Repeatable.
    #[arg(short = 'D', value_name = "NAME=VALUE")]
    defines: Vec<String>,
    /// Output image; the extension picks the format: .png (8-bit sRGB) or .exr (linear float).
    #[arg(short, long, default_value = "render.png")]
    output: PathBuf,
    /// Override a scene value by its dotted path, e.g. render.width=64 or objects.0.radius=2.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    sets: Vec<String>,
    /// Worker threads (default: all cores).
    #[arg(long, value_parser = at_least_one::<usize>())]
    threads: Option<usize>,
    /// Seed of every random decision (overrides render.seed).
    #[arg(long)]
    seed: Option<u32>,
    /// Print the per-stage statistics table.
    #[arg(long)]
    stats: bool,
    /// Write the statistics as JSON to this path.
    #[arg(long, value_name = "PATH")]
    stats_json: Option<PathBuf>,
    /// Write a debug image: aa=PATH (refined pixels green), penumbra=PATH (penumbra
    /// points blue) or rays=PATH (rays per pixel with a legend). PNG. Repeatable.
    #[arg(long = "heatmap", value_name = "KIND=PATH", value_parser = heatmap_spec)]
    heatmaps: Vec<HeatmapSpec>,
    /// Write a Chrome trace-event JSON (chrome://tracing, Perfetto): one span per stage
    /// per wave per thread.
    #[arg(long, value_name = "PATH")]
    trace: Option<PathBuf>,
    /// Leave out the BVH node/primitive counters (to measure their overhead).
    #[arg(long, hide = true)]
    no_counters: bool,
    /// Print nothing but errors.
    #[arg(short, long)]
    quiet: bool,
}

/// One `--heatmap KIND=PATH`.
#[derive(Clone, Debug)]
pub struct HeatmapSpec {
    kind: HeatmapKind,
    path: PathBuf,
}

/// The names of the heatmap kinds, as clap knows them (`aa`, `penumbra`, `rays`).
fn heatmap_kinds() -> Vec<String> {
    HeatmapKind::value_variants()
        .iter()
        .filter_map(|k| k.to_possible_value())
        .map(|v| v.get_name().to_string())
        .collect()
}

/// Parses `KIND=PATH`, the kind by [`HeatmapKind`]'s value names.
fn heatmap_spec(spec: &str) -> std::result::Result<HeatmapSpec, String> {
    let kinds = heatmap_kinds();
    let (kind, path) =
        spec.split_once('=').ok_or_else(|| format!("expected KIND=PATH (KIND: {})", kinds.join(", ")))?;
    let kind = HeatmapKind::from_str(kind, false).map_err(|_| {
        let (last, rest) = kinds.split_last().map_or(("", &[][..]), |(l, r)| (l.as_str(), r));
        format!("unknown kind `{kind}` (expected {} or {last})", rest.join(", "))
    })?;
    Ok(HeatmapSpec { kind, path: PathBuf::from(path) })
}

/// The exit status of a render stopped by Ctrl-C (128 + SIGINT), as shells report it.
const EXIT_INTERRUPTED: i32 = 130;

/// Installs the Ctrl-C handler: the first press asks the render to stop after the tiles
/// in progress (what is finished is then written), a second press exits at once.
fn cancel_on_ctrl_c() -> Arc<AtomicBool> {
    let flag = Arc::new(AtomicBool::new(false));
    let seen = flag.clone();
    // Without a handler (already installed in this process) Ctrl-C keeps its default.
    let _ = ctrlc::set_handler(move || {
        if seen.swap(true, Ordering::SeqCst) {
            std::process::exit(EXIT_INTERRUPTED);
        }
    });
    flag
}

/// Renders; returns the exit status (0, or 130 when Ctrl-C cut the render short).
pub fn run(args: RenderArgs) -> Result<i32> {
    // Every output is checked before any work, so bad paths cost nothing.
    check_image_path(&args.output)?;
    for p in args.stats_json.iter().chain(args.trace.iter()) {
        check_folder(p)?;
    }
    for h in &args.heatmaps {
        check_png_path(&h.path)?;
    }
    let load_start = Instant::now();
    let mut source = scene_source(args.scene.as_ref())?;
    for d in &args.defines {
        let (name, value) = d
            .split_once('=')
            .filter(|(n, _)| !n.trim().is_empty())
            .ok_or_else(|| Error::input(format!("-D `{d}`: expected NAME=VALUE")))?;
        if source.xml.is_none() {
            return Err(Error::input(format!(
                "-D `{d}`: -D sets parameters of Mitsuba XML scenes; use --set for TOML"
            )));
        }
        source.defines.push((name.trim().to_string(), value.to_string()));
    }
    let mut sets = args.sets.clone();
    if let Some(seed) = args.seed {
        sets.push(format!("render.seed={seed}"));
    }
    let scene = load(&source, &sets)?;
    if !args.quiet {
        for note in &scene.info.notes {
            eprintln!("note: {note}");
        }
    }
    let load_seconds = load_start.elapsed().as_secs_f64();

    let progress = (!args.quiet && std::io::stderr().is_terminal()).then(|| {
        let pb = indicatif::ProgressBar::new(0);
        pb.set_style(
            indicatif::ProgressStyle::with_template(
                "{spinner} [{elapsed_precise}] {wide_bar} {pos}/{len} tiles, {msg}, ETA {eta}",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        pb
    });
    let opts = RenderOptions {
        threads: args.threads,
        progress: progress.clone(),
        no_counters: args.no_counters,
        trace: args.trace.is_some(),
        cancel: Some(cancel_on_ctrl_c()),
    };
    let out = render(&scene, &opts)?;
    if let Some(pb) = progress {
        pb.finish_and_clear();
    }
    write_image(&args.output, &out.image)?;
    for h in &args.heatmaps {
        let pic = heatmap::draw(h.kind, &out.image, &out.heat);
        write_png(&h.path, pic.width, pic.height, &pic.rgb)?;
    }

    let info = &scene.info;
    let report = Report::new(
        &scene.settings,
        out.seconds,
        &out.stats,
        &out.per_thread,
        SceneReport {
            primitives: info.primitives,
            triangles: info.triangles,
            degenerate_triangles: info.degenerate_triangles,
            bvh_seconds: info.bvh_seconds,
            load_seconds,
            outside_paths: info.outside_paths.clone(),
        },
    );
    let report = Report { partial: out.partial, ..report };
    if let Some(p) = &args.trace {
        write_text(p, &chrome_trace(&out.spans))?;
    }
    if let Some(p) = &args.stats_json {
        let json = serde_json::to_string_pretty(&report).map_err(|e| Error::Internal(e.to_string()))?;
        write_text(p, &(json + "\n"))?;
    }
    if !args.quiet {
        if args.stats {
            say(&report.table());
        }
        say(&format!("{} -> {}", report.summary(), args.output.display()));
    }
    if out.partial {
        eprintln!("interrupted: wrote the {} finished tiles to {}", out.stats.tiles, args.output.display());
        return Ok(EXIT_INTERRUPTED);
    }
    Ok(0)
}
