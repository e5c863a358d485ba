//! `wavetrace render` (and `wavetrace` with no subcommand): renders a scene to an image,
//! with the stats table, stats JSON, trace and heatmaps on request; Ctrl-C writes what
//! is finished and exits 130.

use clap::{Args, ValueEnum};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Instant;

use wavetrace::film::{Crop, Tile};
use wavetrace::scene::load;
use wavetrace::stats::{chrome_trace, Report, SceneReport};
use wavetrace::tools::heatmap::{self, HeatmapKind};
use wavetrace::tools::merge::{RenderId, TileHeader};
use wavetrace::tools::output::{
    check_distinct, check_image_path, check_output, check_png_path, is_stdout, watch_signals, Batch, EXIT_INTERRUPTED,
};
use wavetrace::{render, Error, RenderOptions, RenderOutput, Result};

use super::{say, scene_source};

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
    /// Worker threads (default: all cores, or SLURM_CPUS_PER_TASK when set); at most 4 per
    /// CPU (a limit of at least 64 and at most 1024).
    #[arg(long, allow_negative_numbers = true, value_parser = super::thread_count)]
    threads: Option<usize>,
    /// Samples per pixel: the scene's `render.aa.samples` (uniform anti-aliasing; an
    /// imported scene's sampler count maps to it too). Adaptive mode takes its samples
    /// from its levels and ignores it. The same as --set render.aa.samples=N.
    #[arg(long, value_name = "N", allow_negative_numbers = true, value_parser = super::at_least_one::<u32>())]
    spp: Option<u32>,
    /// Image size WxH in pixels, e.g. 640x480: the same as --set render.width=W --set
    /// render.height=H.
    #[arg(long, value_name = "WxH", value_parser = resolution)]
    res: Option<(u32, u32)>,
    /// Seed of every random decision, 0 to 4294967295 (overrides render.seed).
    #[arg(long, allow_negative_numbers = true, value_parser = seed)]
    seed: Option<u32>,
    /// Print the per-stage statistics table.
    #[arg(long)]
    stats: bool,
    /// Write the statistics as JSON to this path (`-`: standard output; the summary line
    /// and table then go to stderr).
    #[arg(long, value_name = "PATH")]
    stats_json: Option<PathBuf>,
    /// Write a debug image: aa=PATH (refined pixels green), penumbra=PATH (penumbra
    /// points blue) or rays=PATH (rays per pixel with a legend). PNG. Repeatable.
    #[arg(long = "heatmap", value_name = "KIND=PATH", value_parser = heatmap_spec)]
    heatmaps: Vec<HeatmapSpec>,
    /// Write a Chrome trace-event JSON (chrome://tracing, Perfetto): one span per stage
    /// per wave per thread (`-`: standard output).
    #[arg(long, value_name = "PATH")]
    trace: Option<PathBuf>,
    /// Leave out the BVH node/primitive counters (to measure their overhead).
    #[arg(long, hide = true)]
    no_counters: bool,
    /// Print nothing but errors.
    #[arg(short, long)]
    quiet: bool,
    /// Render only the pixels x0,x1,y0,y1 (half-open, full-image raster; pbrt's
    /// --pixelbounds). An .exr output keeps the crop as its data window, with a header
    /// that `wavetrace merge` checks.
    #[arg(long, value_name = "X0,X1,Y0,Y1", value_parser = crop_pixels, conflicts_with_all = ["crop_window", "tile"])]
    crop: Option<Crop>,
    /// Render only the fractions x0,x1,y0,y1 of the frame (pbrt's --cropwindow).
    #[arg(long, value_name = "X0,X1,Y0,Y1", value_parser = crop_window, conflicts_with = "tile")]
    crop_window: Option<Crop>,
    /// Render task K of N (K from 0): the frame cut into N near-equal rectangles on the
    /// tile grid, e.g. --tile $SLURM_ARRAY_TASK_ID/$SLURM_ARRAY_TASK_COUNT.
    #[arg(long, value_name = "K/N", value_parser = crop_task)]
    tile: Option<Crop>,
}

/// `--res WxH`: two whole numbers of at least 1.
fn resolution(s: &str) -> std::result::Result<(u32, u32), String> {
    let bad = || format!("expected WxH (width x height in pixels, e.g. 640x480), got `{s}`");
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let (w, h): (u32, u32) = (w.trim().parse().map_err(|_| bad())?, h.trim().parse().map_err(|_| bad())?);
    if w == 0 || h == 0 {
        return Err(format!("`{s}`: width and height must be at least 1"));
    }
    Ok((w, h))
}

/// `--seed S`: a whole number that fits the seed's 32 bits. A negative one reaches this
/// parser (clap would otherwise take `-1` for a flag and suggest `-- -1`, which makes it
/// the scene's name).
fn seed(s: &str) -> std::result::Result<u32, String> {
    s.trim().parse().map_err(|_| format!("`{s}` is not a seed: a whole number from 0 to {}", u32::MAX))
}

/// Four comma-separated numbers `x0,x1,y0,y1`.
fn four<T: std::str::FromStr>(s: &str) -> std::result::Result<[T; 4], String> {
    let v: Vec<T> = s
        .split(',')
        .map(|p| p.trim().parse::<T>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| format!("expected four numbers x0,x1,y0,y1, got `{s}`"))?;
    v.try_into().map_err(|_| format!("expected four numbers x0,x1,y0,y1, got `{s}`"))
}

/// `--crop x0,x1,y0,y1` (pixels; checked against the image once the scene is loaded).
fn crop_pixels(s: &str) -> std::result::Result<Crop, String> {
    let [x0, x1, y0, y1] = four::<u32>(s)?;
    Ok(Crop::Pixels(Tile { x0, x1, y0, y1 }))
}

/// `--crop-window x0,x1,y0,y1` (fractions).
fn crop_window(s: &str) -> std::result::Result<Crop, String> {
    Ok(Crop::Window(four::<f32>(s)?))
}

/// `--tile K/N`.
fn crop_task(s: &str) -> std::result::Result<Crop, String> {
    let bad = || format!("expected K/N (task K of N, K from 0), got `{s}`");
    let (k, n) = s.split_once('/').ok_or_else(bad)?;
    Ok(Crop::Task { k: k.trim().parse().map_err(|_| bad())?, n: n.trim().parse().map_err(|_| bad())? })
}

/// Worker threads: `--threads`, else `SLURM_CPUS_PER_TASK` when set (SLURM without
/// cgroups does not confine a task to its CPUs), else every core (`None`).
fn threads(flag: Option<usize>) -> Result<Option<usize>> {
    if flag.is_some() {
        return Ok(flag);
    }
    match std::env::var("SLURM_CPUS_PER_TASK") {
        Err(_) => Ok(None),
        Ok(v) => match v.trim().parse::<usize>() {
            Ok(n) => super::check_threads(n)
                .map(Some)
                .map_err(|e| Error::input(format!("SLURM_CPUS_PER_TASK=`{v}`: {e} (it sets the worker threads)"))),
            _ => Err(Error::input(format!("SLURM_CPUS_PER_TASK=`{v}` is not a thread count of at least 1"))),
        },
    }
}

/// Sizes rayon's global pool, which the scene's load runs on (meshes read ahead, trees
/// built), to the worker threads asked for: `--threads 1` then loads on one thread as
/// it renders on one. The render then runs on that pool too.
fn bound_threads(threads: Option<usize>) {
    if let Some(n) = threads {
        // Fails only when the pool already exists (a second run in one process), which
        // then keeps its size.
        let _ = rayon::ThreadPoolBuilder::new().num_threads(n).build_global();
    }
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

/// A heatmap kind's name on the command line.
fn heatmap_name(kind: HeatmapKind) -> String {
    kind.to_possible_value().map_or_else(String::new, |v| v.get_name().to_string())
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

/// The flags and paths of every output of a render, for [`check_distinct`].
fn outputs(args: &RenderArgs) -> Vec<(String, &Path)> {
    let mut v = vec![("-o".to_string(), args.output.as_path())];
    v.extend(args.heatmaps.iter().map(|h| (format!("--heatmap {}", heatmap_name(h.kind)), h.path.as_path())));
    v.extend(args.stats_json.iter().map(|p| ("--stats-json".to_string(), p.as_path())));
    v.extend(args.trace.iter().map(|p| ("--trace".to_string(), p.as_path())));
    v
}

/// Prints a line where the summary goes: stdout, or stderr when a JSON output has
/// stdout, so the JSON stays whole.
fn report_line(text: &str, json_on_stdout: bool) {
    if json_on_stdout {
        eprintln!("{text}");
    } else {
        say(text);
    }
}

/// True when nothing in `scene` gives off light: no light with a non-zero emission and
/// a black background. Such a scene renders black.
fn shows_nothing(scene: &wavetrace::Scene) -> bool {
    use wavetrace::scene::Light;
    let lit = scene.lights.iter().any(|l| match l {
        Light::Quad { radiance, .. } | Light::Triangle { radiance, .. } | Light::Sphere { radiance, .. } => {
            radiance.max_element() > 0.0
        }
        Light::Point { intensity, .. } | Light::Directional { irradiance: intensity, .. } => {
            intensity.max_element() > 0.0
        }
    });
    !lit && scene.background.is_black()
}

/// Renders; returns the exit status (0, or 130 when a signal cut the render short).
pub fn run(args: RenderArgs) -> Result<i32> {
    check_outputs(&args)?;
    bound_threads(threads(args.threads)?);
    let load_start = Instant::now();
    // On a pool thread, the load's parallel steps (the BVH build's 30-odd) are joins
    // there, not each a round trip from this thread into the pool: 0.25 ms on 96 shapes.
    let scene = rayon::scope(|_| load_scene(&args))?;
    let load_seconds = load_start.elapsed().as_secs_f64();
    let crop_spec = args.crop.or(args.crop_window).or(args.tile);
    let (w, h) = (scene.settings.width, scene.settings.height);
    let crop = crop_spec.map(|c| c.resolve(w, h)).transpose().map_err(Error::input)?;
    let out = render_scene(&args, &scene, crop)?;
    let report = report(&scene, &out, load_seconds);
    let task = match crop_spec {
        Some(Crop::Task { k, n }) => Some((k, n)),
        _ => None,
    };
    let has_pixels = write_outputs(&args, &scene, &out, crop.map(|c| (c, task)), &report)?;
    Ok(summarise(&args, &report, &out, has_pixels))
}

/// Checks every output before any work, so bad paths cost nothing: formats, what each
/// path names, and that no two name one file or the scene.
fn check_outputs(args: &RenderArgs) -> Result<()> {
    check_image_path(&args.output)?;
    for p in args.stats_json.iter().chain(args.trace.iter()) {
        check_output(p)?;
    }
    for h in &args.heatmaps {
        check_png_path(&h.path)?;
    }
    let named = outputs(args);
    let named: Vec<(&str, &Path)> = named.iter().map(|(f, p)| (f.as_str(), *p)).collect();
    let inputs: Vec<(&str, &Path)> = args.scene.iter().map(|p| ("the scene", p.as_path())).collect();
    check_distinct(&named, &inputs)
}

/// The `--set` overrides of the command line: the shorthand flags first (each only when
/// no explicit `--set` gives its key, which then wins), the `--set`s, then `--seed`.
fn overrides(args: &RenderArgs) -> Vec<String> {
    let explicit = |key: &str| args.sets.iter().any(|s| s.split_once('=').is_some_and(|(k, _)| k.trim() == key));
    let mut sets = Vec::new();
    if let Some(n) = args.spp.filter(|_| !explicit("render.aa.samples")) {
        sets.push(format!("render.aa.samples={n}"));
    }
    if let Some((w, h)) = args.res {
        sets.extend((!explicit("render.width")).then(|| format!("render.width={w}")));
        sets.extend((!explicit("render.height")).then(|| format!("render.height={h}")));
    }
    sets.extend(args.sets.iter().cloned());
    if let Some(seed) = args.seed {
        sets.push(format!("render.seed={seed}"));
    }
    sets
}

/// A load error about an override that a shorthand flag made names that flag, as typed
/// (`(--res 100000x100000): field `render.height``), not a `--set` the user never gave.
fn name_the_shorthand(e: Error, args: &RenderArgs) -> Error {
    let Error::Input(mut msg) = e else { return e };
    let mut made: Vec<(String, String)> = Vec::new();
    if let Some(n) = args.spp {
        made.push((format!("render.aa.samples={n}"), format!("--spp {n}")));
    }
    if let Some((w, h)) = args.res {
        for key in [format!("render.width={w}"), format!("render.height={h}")] {
            made.push((key, format!("--res {w}x{h}")));
        }
    }
    if let Some(seed) = args.seed {
        made.push((format!("render.seed={seed}"), format!("--seed {seed}")));
    }
    for (set, flag) in made.iter().filter(|(set, _)| !args.sets.contains(set)) {
        for given in [format!("(--set {set})"), format!("(--set `{set}`)")] {
            msg = msg.replace(&given, &format!("({flag})"));
        }
    }
    Error::Input(msg)
}

/// Reads the scene with its `-D` parameters and overrides, checks that no output names
/// a file it reads, and prints its notes and warnings.
fn load_scene(args: &RenderArgs) -> Result<wavetrace::Scene> {
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
    let scene = load(&source, &overrides(args)).map_err(|e| name_the_shorthand(e, args))?;
    // Only now are the files it reads known (includes, meshes, textures): none may be
    // an output, checked before the render.
    let named = outputs(args);
    let named: Vec<(&str, &Path)> = named.iter().map(|(f, p)| (f.as_str(), *p)).collect();
    let mut inputs: Vec<(&str, &Path)> = args.scene.iter().map(|p| ("the scene", p.as_path())).collect();
    inputs.extend(scene.info.inputs.iter().map(|(what, p)| (what.as_str(), p.as_path())));
    check_distinct(&named, &inputs)?;
    if !args.quiet {
        for note in &scene.info.notes {
            eprintln!("note: {note}");
        }
    }
    if shows_nothing(&scene) {
        eprintln!(
            "warning: the scene has no light that emits and a black background: the image will be black \
             (add a light, an emissive mesh or a background colour)"
        );
    }
    warn_plain_heatmaps(args, &scene);
    Ok(scene)
}

/// Warns of a heatmap that can only repeat the render: `aa` with uniform anti-aliasing
/// (no pixel is refined) and `penumbra` with uniform shadows (no penumbra test).
fn warn_plain_heatmaps(args: &RenderArgs, scene: &wavetrace::Scene) {
    use wavetrace::scene::{AaMode, ShadowMode};
    for h in &args.heatmaps {
        let why = match h.kind {
            HeatmapKind::Aa if scene.settings.aa_mode == AaMode::Uniform => {
                "anti-aliasing is uniform (render.aa.mode), which refines no pixel"
            }
            HeatmapKind::Penumbra if scene.settings.shadow_mode == ShadowMode::Uniform => {
                "shadows are uniform (render.shadows.mode), which test no penumbra"
            }
            _ => continue,
        };
        eprintln!(
            "warning: --heatmap {}: {why}: `{}` will show the render with nothing marked",
            heatmap_name(h.kind),
            h.path.display()
        );
    }
}

/// Renders with the progress bar and the signal handler: the first SIGINT, SIGTERM or
/// SIGHUP stops the render after the tiles in progress (what is finished is then
/// written), a second ends the process at once ([`watch_signals`]).
fn render_scene(args: &RenderArgs, scene: &wavetrace::Scene, crop: Option<Tile>) -> Result<RenderOutput> {
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
    let cancel = Arc::new(AtomicBool::new(false));
    let named = outputs(args);
    watch_signals(Some(cancel.clone()), &named.iter().map(|(_, p)| *p).collect::<Vec<_>>());
    let opts = RenderOptions {
        threads: threads(args.threads)?,
        crop,
        progress: progress.clone(),
        no_counters: args.no_counters,
        trace: args.trace.is_some(),
        no_heat: args.heatmaps.is_empty(),
        cancel: Some(cancel),
    };
    let out = render(scene, &opts);
    // From here on any signal ends the process, removing what is half written.
    watch_signals(None, &[]);
    if let Some(pb) = progress {
        pb.finish_and_clear();
    }
    out
}

/// The stats report of a render.
fn report(scene: &wavetrace::Scene, out: &RenderOutput, load_seconds: f64) -> Report {
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
            notes: info.notes.clone(),
        },
    );
    Report { partial: out.partial, auto_aa: out.auto.clone(), auto_shadows: out.auto_shadows.clone(), ..report }
}

/// Writes every output all or nothing ([`Batch`]): the image and heatmaps (unless the
/// render stopped before any pixel tile finished: an earlier file of that name is worth
/// more than a black image), the trace and the stats. Returns whether the image was
/// written. `crop` is the rendered part with its `--tile` task.
fn write_outputs(
    args: &RenderArgs,
    scene: &wavetrace::Scene,
    out: &RenderOutput,
    crop: Option<(Tile, Option<(u32, u32)>)>,
    report: &Report,
) -> Result<bool> {
    let mut batch = Batch::new();
    let has_pixels = out.finished_pixels > 0;
    if has_pixels {
        match crop {
            None => batch.image(&args.output, &out.image)?,
            Some((c, task)) => {
                let (w, h) = (scene.settings.width, scene.settings.height);
                let (rays, seconds) = (out.stats.total_rays(), out.seconds);
                let header = TileHeader { id: RenderId::of(scene), width: w, height: h, crop: c, task, rays, seconds };
                batch.crop(&args.output, &out.image, (w, h), &c, &header.attributes())?
            }
        }
        for h in &args.heatmaps {
            let pic = heatmap::draw(h.kind, &out.image, &out.heat);
            batch.png(&h.path, pic.width, pic.height, &pic.rgb)?;
        }
    }
    if let Some(p) = &args.trace {
        batch.text(p, &chrome_trace(&out.spans))?;
    }
    if let Some(p) = &args.stats_json {
        let json = serde_json::to_string_pretty(report).map_err(|e| Error::Internal(e.to_string()))?;
        batch.text(p, &(json + "\n"))?;
    }
    batch.commit()?;
    Ok(has_pixels)
}

/// Prints the table, the summary line and what an interrupted render wrote; returns
/// the exit status.
fn summarise(args: &RenderArgs, report: &Report, out: &RenderOutput, has_pixels: bool) -> i32 {
    let json_on_stdout = args.stats_json.iter().chain(args.trace.iter()).any(|p| is_stdout(p));
    if !args.quiet {
        if args.stats {
            report_line(&report.table(), json_on_stdout);
        }
        if has_pixels {
            report_line(&format!("{} -> {}", report.summary(), args.output.display()), json_on_stdout);
        }
    }
    if !out.partial {
        return 0;
    }
    let total = out.image.pixels.len() as u64;
    if has_pixels {
        eprintln!(
            "interrupted: wrote the finished tiles, {} of {total} pixels ({:.1}%), to {}; the rest is black",
            out.finished_pixels,
            100.0 * out.finished_pixels as f64 / total.max(1) as f64,
            args.output.display()
        );
    } else {
        eprintln!(
            "interrupted before any pixel tile finished (0 of {total} pixels): {} not written",
            args.output.display()
        );
    }
    EXIT_INTERRUPTED
}
