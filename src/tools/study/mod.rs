//! `wavetrace study`: where adaptive sampling pays. For each scene of a manifest it
//! renders one converged reference and every method's grid of settings, finds each
//! method's cheapest setting (in seconds, and in rays) that reaches each target FLIP,
//! measures the scene features that should decide the winner, and writes `study.json`,
//! `study.csv`, `study.md` and one FLIP-against-seconds plot per scene.
//!
//! - [`methods`]: the samplers compared, as a data table (one entry per method);
//! - [`manifest`]: the TOML manifest, checked before the first render;
//! - [`search`]: the cheapest-setting search and the winner rule, pure functions;
//! - [`features`]: the scene features (edge density, penumbra, blur, gloss, noise);
//! - [`map`]: which method wins which target, against the features;
//! - `measure`: the renders; `report`: the files.
//!
//! The reference converges everything a method varies: uniform AA with `reference_spp`
//! camera samples (each with the scene's lens samples) and uniform shadows with
//! `reference_shadow_samples` rays per sample, so a pixel averages spp × shadow rays per
//! area light. It is cached in the output folder under the same hash as `wavetrace
//! sweep`'s, so a rerun renders only the grids. Its own noise is a floor under every
//! FLIP; the manifest sizes it above the grids' best settings.
//!
//! With `seeds` above 1, each setting is also rendered at the next `seeds - 1` values of
//! `render.seed`, and its errors (FLIP among them), rays and seconds are the means over
//! the seeds: FLIP moves about ±3% from seed to seed at equal settings, enough to put a
//! setting on either side of a target, and an adaptive method's rays, and auto's plan,
//! move with the seed too.
//!
//! Seconds are the median of `runs` renders (scene loading excluded), and of up to 5
//! for a setting whose renders take under 0.1 s together (`measure::SHORT`); each
//! method's cheapest setting within 1.5× of a target's fastest is then timed again, in
//! turns with the other contenders, to a median of 5 (`measure::confirm`). Rays are
//! exact, since a render is deterministic for any thread count.

use serde::Serialize;
use std::path::{Path, PathBuf};

use crate::stats::Stats;
use crate::tools::compare::Metrics;
use crate::tools::output::{check_output, write_text};
use crate::tools::sweep::{ordered_map, prepare_dir, ReferenceInfo};
use crate::{Error, Result};

pub mod features;
pub mod manifest;
pub mod map;
mod measure;
pub mod methods;
mod report;
pub mod search;

pub use features::Features;
pub use search::{cheapest, Cost, Measure};

/// Schema version of `study.json`.
pub const JSON_VERSION: u32 = 2;
/// Every render's row.
pub const CSV_FILE: &str = "study.csv";
/// Everything.
pub const JSON_FILE: &str = "study.json";
/// The tables.
pub const MD_FILE: &str = "study.md";
/// Each scene's plot: `<scene>` followed by this.
pub const PLOT_SUFFIX: &str = "_flip_vs_seconds.png";

/// What to run.
#[derive(Clone, Debug)]
pub struct StudyOptions {
    /// The manifest.
    pub manifest: PathBuf,
    /// Output folder, created if missing (its parent must exist); the references are
    /// cached here too.
    pub out_dir: PathBuf,
    /// Tiny images, the methods' quick grids, a 64-spp reference: seconds, for tests.
    pub quick: bool,
    /// Only these scenes, by name (empty: all).
    pub only: Vec<String>,
    /// Renders per setting; the seconds are their median.
    pub runs: u32,
    /// Seeds per setting (`render.seed` = the scene's, then the next ones): a setting's
    /// errors, rays and seconds are their means.
    pub seeds: u32,
    /// Replaces every scene's `reference_spp`.
    pub reference_spp: Option<u32>,
    /// Worker threads per render; `None` uses every core.
    pub threads: Option<usize>,
    /// A progress bar on stderr.
    pub progress: bool,
}

impl Default for StudyOptions {
    fn default() -> Self {
        StudyOptions {
            manifest: PathBuf::from("benches/study.toml"),
            out_dir: PathBuf::from("study"),
            quick: false,
            only: Vec::new(),
            runs: 1,
            seeds: 1,
            reference_spp: None,
            threads: None,
            progress: false,
        }
    }
}

/// The counters of a render the features and the report read.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Counters {
    /// Adaptive AA: pixels decided.
    pub aa_pixels: u64,
    /// Adaptive AA: pixels refined.
    pub aa_refined_pixels: u64,
    /// Adaptive shadows: (point, light) pairs tested.
    pub shadow_points: u64,
    /// Adaptive shadows: pairs sent to the penumbra queue.
    pub penumbra_points: u64,
    /// Adaptive shadows: pairs sampled uniformly because probing would cost more.
    pub shadow_uniform_fallback: u64,
    /// Early stopping: penumbra points that stopped early.
    pub penumbra_stopped: u64,
}

impl Counters {
    fn of(s: &Stats) -> Counters {
        Counters {
            aa_pixels: s.aa_pixels,
            aa_refined_pixels: s.aa_refined_pixels,
            shadow_points: s.shadow_points,
            penumbra_points: s.penumbra_points,
            shadow_uniform_fallback: s.shadow_uniform_fallback,
            penumbra_stopped: s.penumbra_stopped,
        }
    }
}

/// One rendered setting of one method.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    /// The method's name.
    pub method: &'static str,
    /// The grid point's values, in grid order.
    #[serde(serialize_with = "ordered_map")]
    pub params: Vec<(String, String)>,
    /// Rays of all kinds.
    pub total_rays: u64,
    /// Rays by kind, in the order of [`Stats::kinds`].
    #[serde(serialize_with = "ordered_map")]
    pub rays: Vec<(String, u64)>,
    /// Median render seconds over the runs.
    pub seconds: f64,
    /// Each run's seconds.
    pub runs: Vec<f64>,
    /// Error against the reference.
    #[serde(flatten)]
    pub metrics: Metrics,
    /// Share of the squared error (display values: clamped, sRGB) in the worst 10% of pixels.
    pub worst10_share: f64,
    /// Adaptive counters.
    pub counters: Counters,
    /// On its method's Pareto front in (seconds, FLIP).
    pub pareto_seconds: bool,
    /// On its method's Pareto front in (rays, FLIP).
    pub pareto_rays: bool,
}

impl Row {
    /// The value of a grid key, if the row's grid has it.
    pub fn param(&self, key: &str) -> Option<&str> {
        self.params.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str())
    }

    /// The row's error and costs, for the search.
    pub fn measure(&self) -> Measure {
        Measure { error: self.metrics.flip, seconds: self.seconds, rays: self.total_rays }
    }

    /// `key=value` pairs without the `render.` prefix (`aa.samples=4 shadows.samples=1`),
    /// for tables and plot labels.
    pub fn setting(&self) -> String {
        self.params
            .iter()
            .map(|(k, v)| format!("{}={v}", k.strip_prefix("render.").unwrap_or(k)))
            .collect::<Vec<_>>()
            .join(" ")
    }
}

/// A method's cheapest setting for a target under one cost.
#[derive(Clone, Debug, Serialize)]
pub struct Pick {
    /// Index into the scene's rows.
    pub row: usize,
    /// The setting, as [`Row::setting`] writes it.
    pub setting: String,
    /// Its seconds.
    pub seconds: f64,
    /// Its rays.
    pub rays: u64,
    /// Its FLIP.
    pub flip: f64,
}

/// One method's answer for one target.
#[derive(Clone, Debug, Serialize)]
pub struct Choice {
    /// The method.
    pub method: &'static str,
    /// Cheapest in seconds; `None`: no setting reaches the target.
    pub by_seconds: Option<Pick>,
    /// Cheapest in rays.
    pub by_rays: Option<Pick>,
}

/// One target of a scene, with every method's cheapest setting and the winners.
#[derive(Clone, Debug, Serialize)]
pub struct TargetResult {
    /// Where the target comes from: `uniform 16 spp`, or `given`.
    pub label: String,
    /// The FLIP to reach (at most).
    pub flip: f64,
    /// Per method, in the study's order.
    pub choices: Vec<Choice>,
    /// The method whose cheapest setting takes the least seconds.
    pub winner_seconds: Option<&'static str>,
    /// The method whose cheapest setting traces the fewest rays.
    pub winner_rays: Option<&'static str>,
    /// The winner in seconds among the methods that do not pick ([`Method::picks`]):
    /// the map's.
    pub fixed_seconds: Option<&'static str>,
    /// The winner in rays among them.
    pub fixed_rays: Option<&'static str>,
}

/// Everything about one scene.
#[derive(Clone, Debug, Serialize)]
pub struct SceneResult {
    /// The manifest's name.
    pub name: String,
    /// The scene file.
    pub file: PathBuf,
    /// Kept out of fitting the map.
    pub held_out: bool,
    /// Overrides applied to every render of the scene.
    pub sets: Vec<String>,
    /// Image size.
    pub size: (u32, u32),
    /// The reference.
    pub reference: ReferenceInfo,
    /// The features.
    pub features: Features,
    /// The targets and their answers.
    pub targets: Vec<TargetResult>,
    /// Methods skipped, with why.
    pub skipped: Vec<(String, String)>,
    /// Settings that failed to render, with why.
    pub notes: Vec<String>,
    /// Every rendered setting, method by method in grid order.
    pub rows: Vec<Row>,
}

/// The most seeds per setting (`--seeds`): each multiplies the grid's renders.
pub const MAX_SEEDS: u32 = 16;

/// What a study produced.
#[derive(Clone, Debug, Serialize)]
pub struct StudyResult {
    /// The manifest.
    pub manifest: PathBuf,
    /// `--quick`.
    pub quick: bool,
    /// Renders per setting.
    pub runs: u32,
    /// Seeds per setting, whose errors, rays and seconds are averaged.
    pub seeds: u32,
    /// Worker threads per render.
    pub threads: usize,
    /// Wall-clock seconds of the whole study, loads and references included.
    pub seconds: f64,
    /// The scenes.
    pub scenes: Vec<SceneResult>,
    /// The map across scenes.
    pub map: map::Map,
    /// The files written.
    #[serde(skip)]
    pub files: Vec<PathBuf>,
}

/// Runs the study: reads and checks the manifest (every scene and setting), checks the
/// output files, then renders scene by scene and writes the files at the end.
pub fn run(opts: &StudyOptions) -> Result<StudyResult> {
    let start = std::time::Instant::now();
    if !cfg!(feature = "flip") || !cfg!(feature = "exr") {
        return Err(Error::input(
            "the study measures FLIP and caches its references as EXR: build with the `flip` and `exr` features",
        ));
    }
    if opts.runs == 0 {
        return Err(Error::input("--runs must be at least 1"));
    }
    if !(1..=MAX_SEEDS).contains(&opts.seeds) {
        return Err(Error::input(format!("--seeds must be 1 to {MAX_SEEDS}")));
    }
    let read = manifest::ReadOptions { quick: opts.quick, only: &opts.only, reference_spp: opts.reference_spp };
    let plan = manifest::read(&opts.manifest, &read)?;
    let files = output_files(&opts.out_dir, &plan)?;
    let renders: usize = plan.scenes.iter().map(|s| s.methods.iter().map(|m| m.points.len()).sum::<usize>() + 1).sum();
    let progress = crate::tools::sweep::Progress::new(opts.progress, renders as u64);
    let mut scenes = Vec::with_capacity(plan.scenes.len());
    let mut threads = opts.threads.unwrap_or(0);
    for scene in &plan.scenes {
        let (result, t) = measure::scene(scene, opts, &progress)?;
        threads = t;
        scenes.push(result);
    }
    progress.finish();
    let map = map::Map::new(&scenes);
    let result = StudyResult {
        manifest: opts.manifest.clone(),
        quick: opts.quick,
        runs: opts.runs,
        seeds: opts.seeds,
        threads,
        seconds: start.elapsed().as_secs_f64(),
        scenes,
        map,
        files,
    };
    report::write(&result)?;
    Ok(result)
}

/// Creates the output folder and checks every file the study writes there.
fn output_files(dir: &Path, plan: &manifest::Plan) -> Result<Vec<PathBuf>> {
    prepare_dir(dir)?;
    let mut files: Vec<PathBuf> = [CSV_FILE, JSON_FILE, MD_FILE].iter().map(|f| dir.join(f)).collect();
    if cfg!(feature = "plot") {
        files.extend(plan.scenes.iter().map(|s| dir.join(format!("{}{PLOT_SUFFIX}", s.name))));
    }
    for f in &files {
        check_output(f)?;
    }
    Ok(files)
}

/// Writes `text` to the study's file `name` (one of `files`).
fn write_file(files: &[PathBuf], name: &str, text: &str) -> Result<()> {
    match files.iter().find(|f| f.file_name().is_some_and(|n| n == name)) {
        Some(path) => write_text(path, text),
        None => Err(Error::Internal(format!("study output `{name}` was not planned"))),
    }
}
