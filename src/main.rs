//! The `wavetrace` command line.

use clap::{Args, Parser, Subcommand};
use std::io::IsTerminal;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Instant;

use wavetrace::geometry::order::Order;
use wavetrace::geometry::packet::PacketConfig;
use wavetrace::heatmap::{self, HeatmapKind};
use wavetrace::output::{check_folder, check_image_path, check_png_path, write_image, write_png, write_text};
use wavetrace::scene::{load, SceneSource};
use wavetrace::stats::{Report, SceneReport};
use wavetrace::{render, Error, RenderOptions, Result};

/// A wavefront CPU ray tracer with adaptive sampling, soft shadows, refraction and depth of field.
#[derive(Parser, Debug)]
#[command(name = "wavetrace", version, args_conflicts_with_subcommands = true)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
    /// With no subcommand, `wavetrace` renders.
    #[command(flatten)]
    render: RenderArgs,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Render a scene to an image (the default command).
    Render(RenderArgs),
    /// Compare an image with a reference: RMSE, relative MSE, PSNR (linear) and mean LDR-FLIP.
    Compare(CompareArgs),
    /// Render the cross product of parameter values and measure each against a reference:
    /// DIR/sweep.csv, DIR/sweep.json and error-vs-rays / error-vs-seconds plots.
    Sweep(SweepArgs),
    /// Trace fixed ray sets from a scene (primary, shadow, secondary) with the scalar and
    /// the packet kernel; print Mrays/s per set and kernel (median of --reps runs).
    Bench(BenchArgs),
}

#[derive(Args, Debug)]
struct BenchArgs {
    /// Scene file (TOML). Omitted: the embedded default scene.
    scene: Option<PathBuf>,
    /// Override a scene value by its dotted path (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    sets: Vec<String>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Timed repetitions per set and kernel; the median is reported.
    #[arg(long, default_value_t = 5)]
    reps: usize,
    /// Most rays per set (larger sets keep every k-th ray).
    #[arg(long, default_value_t = 1 << 20)]
    max_rays: usize,
    /// Lanes per packet of the packet kernel: 4, 8 or 16.
    #[arg(long, default_value_t = wavetrace::geometry::packet::LANES)]
    lanes: usize,
    /// Packet kernel: lanes entering a node pair below which each finishes it alone.
    #[arg(long, default_value_t = PacketConfig::RENDER.min_active)]
    min_active: u32,
    /// Packet kernel: how bounce rays are ordered before packets are cut: keep, octant
    /// or morton (octant, then the origin's Morton code).
    #[arg(long, value_parser = order, default_value_t = PacketConfig::RENDER.bounce_order)]
    bounce_order: Order,
    /// Packet kernel: how shadow rays are ordered: keep, octant or morton.
    #[arg(long, value_parser = order, default_value_t = PacketConfig::RENDER.shadow_order)]
    shadow_order: Order,
    /// Packet kernel: trace packets that mix direction octants one ray at a time (on|off).
    #[arg(long, default_value_t = PacketConfig::RENDER.split_mixed, value_parser = on_off, action = clap::ArgAction::Set)]
    split_mixed: bool,
    /// Print JSON: {"bvh_build_seconds", "threads", "sets": [{"set", "kernel", "rays", "mrays_per_s"}]}.
    #[arg(long)]
    json: bool,
}

fn order(s: &str) -> std::result::Result<Order, String> {
    Order::parse(s).ok_or_else(|| format!("`{s}`: expected keep, octant or morton"))
}

fn on_off(s: &str) -> std::result::Result<bool, String> {
    match s {
        "on" | "true" => Ok(true),
        "off" | "false" => Ok(false),
        _ => Err(format!("`{s}`: expected on or off")),
    }
}

#[derive(Args, Debug)]
struct SweepArgs {
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
    #[arg(long, value_name = "N")]
    reference_spp: Option<u32>,
    /// Output folder (created if missing; its parent must exist).
    #[arg(short, long, default_value = "sweep")]
    output: PathBuf,
    /// Worker threads per render (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Print nothing but errors.
    #[arg(short, long)]
    quiet: bool,
}

#[derive(Args, Debug)]
struct CompareArgs {
    /// The image to judge (PNG or EXR).
    test: PathBuf,
    /// The reference image (PNG or EXR), same size.
    reference: PathBuf,
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
}

#[derive(Args, Debug, Default)]
struct RenderArgs {
    /// Scene file (TOML). Omitted: the embedded default scene.
    scene: Option<PathBuf>,
    /// Output image; the extension picks the format: .png (8-bit sRGB) or .exr (linear float).
    #[arg(short, long, default_value = "render.png")]
    output: PathBuf,
    /// Override a scene value by its dotted path, e.g. render.width=64 or objects.0.radius=2.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    sets: Vec<String>,
    /// Worker threads (default: all cores).
    #[arg(long)]
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
    #[arg(long = "heatmap", value_name = "KIND=PATH")]
    heatmaps: Vec<String>,
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

fn main() {
    let cli = Cli::parse();
    let result = match cli.command {
        Some(Command::Render(a)) => run_render(a),
        Some(Command::Compare(a)) => run_compare(a).map(|_| 0),
        Some(Command::Sweep(a)) => run_sweep(a).map(|_| 0),
        Some(Command::Bench(a)) => run_bench(a).map(|_| 0),
        None => run_render(cli.render),
    };
    match result {
        Ok(0) => {}
        Ok(code) => std::process::exit(code),
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(e.exit_code());
        }
    }
}

/// Prints a line to stdout; a closed pipe (`| head`) is not an error worth a panic.
fn say(text: &str) {
    use std::io::Write;
    let _ = writeln!(std::io::stdout().lock(), "{text}");
}

fn run_sweep(args: SweepArgs) -> Result<()> {
    use wavetrace::sweep::{self, Reference, SweepOptions};
    if args.threads == Some(0) {
        return Err(Error::input("--threads must be at least 1"));
    }
    let params = args.params.iter().map(|p| sweep::parse_param(p)).collect::<Result<Vec<_>>>()?;
    let reference = match (&args.reference, args.reference_spp) {
        (Some(path), _) => Reference::File(path.clone()),
        (None, Some(0)) => return Err(Error::input("--reference-spp must be at least 1")),
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
    }
    Ok(())
}

fn run_bench(args: BenchArgs) -> Result<()> {
    use wavetrace::bench::{self, BenchOptions};
    let threads = match args.threads {
        Some(0) => return Err(Error::input("--threads must be at least 1")),
        Some(t) => t,
        None => std::thread::available_parallelism().map_or(1, |n| n.get()),
    };
    if args.reps == 0 {
        return Err(Error::input("--reps must be at least 1"));
    }
    if args.max_rays == 0 {
        return Err(Error::input("--max-rays must be at least 1"));
    }
    if ![4, 8, 16].contains(&args.lanes) {
        return Err(Error::input(format!("--lanes {}: expected 4, 8 or 16", args.lanes)));
    }
    let source = match &args.scene {
        Some(path) => SceneSource::from_file(path)?,
        None => SceneSource::default_scene(),
    };
    let scene = load(&source, &args.sets)?;
    let packet = PacketConfig {
        min_active: args.min_active,
        bounce_order: args.bounce_order,
        shadow_order: args.shadow_order,
        split_mixed: args.split_mixed,
    };
    let opts = BenchOptions { threads, reps: args.reps, max_rays: args.max_rays, lanes: args.lanes, packet };
    let report = bench::run(&scene, &opts)?;
    if args.json {
        say(&serde_json::to_string(&report).map_err(|e| Error::Internal(e.to_string()))?);
    } else {
        say(report.table().trim_end());
    }
    Ok(())
}

fn run_compare(args: CompareArgs) -> Result<()> {
    let test = wavetrace::compare::load_linear(&args.test)?;
    let reference = wavetrace::compare::load_linear(&args.reference)?;
    let m = wavetrace::compare::metrics(&test, &reference)
        .map_err(|e| Error::input(format!("`{}` vs `{}`: {e}", args.test.display(), args.reference.display())))?;
    if args.json {
        say(&serde_json::to_string_pretty(&m).map_err(|e| Error::Internal(e.to_string()))?);
    } else {
        say(&format!("rmse {:.6}\nrel_mse {:.6}\npsnr {:.3} dB\nflip {:.6}", m.rmse, m.rel_mse, m.psnr, m.flip));
    }
    Ok(())
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
fn run_render(args: RenderArgs) -> Result<i32> {
    // Every output is checked before any work, so bad paths cost nothing.
    check_image_path(&args.output)?;
    for p in args.stats_json.iter().chain(args.trace.iter()) {
        check_folder(p)?;
    }
    let mut heatmaps = Vec::new();
    for spec in &args.heatmaps {
        let (kind, path) = spec.split_once('=').ok_or_else(|| {
            Error::input(format!("--heatmap `{spec}`: expected KIND=PATH (KIND: aa, penumbra, rays)"))
        })?;
        let kind = HeatmapKind::parse(kind).ok_or_else(|| {
            Error::input(format!("--heatmap `{spec}`: unknown kind `{kind}` (expected aa, penumbra or rays)"))
        })?;
        let path = PathBuf::from(path);
        check_png_path(&path)?;
        heatmaps.push((kind, path));
    }
    if args.threads == Some(0) {
        return Err(Error::input("--threads must be at least 1"));
    }
    let load_start = Instant::now();
    let source = match &args.scene {
        Some(path) => SceneSource::from_file(path)?,
        None => SceneSource::default_scene(),
    };
    let mut sets = args.sets.clone();
    if let Some(seed) = args.seed {
        sets.push(format!("render.seed={seed}"));
    }
    let scene = load(&source, &sets)?;
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
    for (kind, path) in &heatmaps {
        let pic = heatmap::draw(*kind, &out.image, &out.heat);
        write_png(path, pic.width, pic.height, &pic.rgb)?;
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
    let report = wavetrace::stats::Report { partial: out.partial, ..report };
    if let Some(p) = &args.trace {
        write_text(p, &wavetrace::stats::chrome_trace(&out.spans))?;
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
