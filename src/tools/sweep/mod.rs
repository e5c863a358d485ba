//! `wavetrace sweep`: renders the cross product of parameter values, measures each render
//! against one converged reference, and writes the rows (`sweep.csv`, `sweep.json`) and
//! two plots (error against rays, error against seconds, with Pareto fronts per mode).
//!
//! Every point is validated before anything is rendered, so a bad value costs no render
//! time. The reference is rendered once and cached in the output folder under a hash of
//! everything that determines it, so a second sweep of the same scene reuses it.
//!
//! The reference converges what the sweep varies (see [`reference_overrides`]):
//! - When no swept key touches the camera samples (`render.aa.*`, `render.dof.*`,
//!   `render.seed`) and the scene's AA is uniform, every point traces exactly the
//!   reference's camera rays (they depend only on the AA settings and the seed). The
//!   reference keeps them and converges the shadows alone: uniform shadows with
//!   `render.shadows.samples` = spp. Anti-aliasing error then cancels, and the sweep
//!   measures the shadow error of each point.
//! - Otherwise the reference converges the pixel integral: uniform AA with spp samples,
//!   uniform shadows with the largest `render.shadows.samples` of the scene and the sweep
//!   for each camera sample, so that each of its spp shadow estimates is at least as good
//!   as any point's.
//!
//! Features: without `plot` the sweep writes the CSV and the JSON but no plots; without
//! `exr` it cannot cache a rendered reference (the cache is an EXR), so it needs a
//! `Reference::File` in PNG; without `flip` the `flip` column is NaN (`null` in JSON).

use serde::ser::{SerializeMap, Serializer};
use serde::Serialize;
use std::path::{Path, PathBuf};

use crate::scene::{AaMode, Settings, ShadowMode};
use crate::tools::compare::Metrics;
use crate::tools::output::{check_output, write_text};
#[cfg(feature = "plot")]
use crate::tools::plot::{scatter_plot, Axis, Series};
use crate::{Error, RenderOptions, Result};
use plan::Plan;

/// Default `--reference-spp`.
pub const DEFAULT_REFERENCE_SPP: u32 = 1024;

/// Schema version of `sweep.json`.
pub const JSON_VERSION: u32 = 1;

/// Where the error of each point is measured against.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Reference {
    /// An image file (PNG or EXR) of the same size as the points.
    File(PathBuf),
    /// Render one (or reuse the cached one) with this many samples; see the module docs
    /// for which samples.
    Spp(u32),
}

impl Default for Reference {
    fn default() -> Self {
        Reference::Spp(DEFAULT_REFERENCE_SPP)
    }
}

/// What to sweep.
#[derive(Clone, Debug)]
pub struct SweepOptions {
    /// Scene file; `None` is the embedded default scene.
    pub scene: Option<PathBuf>,
    /// Swept keys with their values, as parsed by [`parse_param`]. Points are the cross
    /// product, the first key varying slowest. No params: one point, the scene as it is.
    pub params: Vec<(String, Vec<String>)>,
    /// `KEY=VALUE` overrides applied to every point and to the reference, before the
    /// point's own values.
    pub sets: Vec<String>,
    /// The reference.
    pub reference: Reference,
    /// Output folder, created if missing (its parent must exist).
    pub out_dir: PathBuf,
    /// Worker threads per render; `None` uses every core.
    pub threads: Option<usize>,
    /// Show a progress bar over the points on stderr. The caller decides: the CLI sets it
    /// when stderr is a terminal and `--quiet` is not given.
    pub progress: bool,
}

impl Default for SweepOptions {
    fn default() -> Self {
        SweepOptions {
            scene: None,
            params: Vec::new(),
            sets: Vec::new(),
            reference: Reference::default(),
            out_dir: PathBuf::from("sweep"),
            threads: None,
            progress: false,
        }
    }
}

/// A point's sampling modes, for grouping: adaptive when AA or shadows are adaptive, and
/// the paper's §5 extensions apart, so that each gets its own series and Pareto front.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize)]
pub enum Mode {
    /// Uniform AA and uniform shadows.
    #[serde(rename = "uniform")]
    Uniform,
    /// Adaptive AA, adaptive shadows, or both, without the extensions below.
    #[serde(rename = "adaptive")]
    Adaptive,
    /// Adaptive AA with `dof_aware` in effect (an open aperture).
    #[serde(rename = "dof-aware")]
    DofAware,
    /// Adaptive shadows with penumbra early stopping (`tolerance` > 0).
    #[serde(rename = "early-stop")]
    EarlyStop,
    /// Both extensions.
    #[serde(rename = "dof-aware+early-stop")]
    DofAwareEarlyStop,
}

impl Mode {
    /// Every mode, in series (colour) order.
    pub const ALL: [Mode; 5] =
        [Mode::Uniform, Mode::Adaptive, Mode::DofAware, Mode::EarlyStop, Mode::DofAwareEarlyStop];

    /// The label in the CSV, the JSON and the plots.
    pub fn label(self) -> &'static str {
        match self {
            Mode::Uniform => "uniform",
            Mode::Adaptive => "adaptive",
            Mode::DofAware => "dof-aware",
            Mode::EarlyStop => "early-stop",
            Mode::DofAwareEarlyStop => "dof-aware+early-stop",
        }
    }

    /// The mode of a loaded scene's settings.
    pub fn of(s: &Settings) -> Mode {
        match (s.dof_radius.is_some(), s.penumbra_stop.is_some()) {
            (true, true) => Mode::DofAwareEarlyStop,
            (true, false) => Mode::DofAware,
            (false, true) => Mode::EarlyStop,
            _ if matches!(s.aa_mode, AaMode::Adaptive { .. }) || matches!(s.shadow_mode, ShadowMode::Adaptive(_)) => {
                Mode::Adaptive
            }
            _ => Mode::Uniform,
        }
    }
}

/// One rendered point of the sweep.
#[derive(Clone, Debug, Serialize)]
pub struct Point {
    /// The point's values, in the order of the params.
    #[serde(serialize_with = "ordered_map")]
    pub params: Vec<(String, String)>,
    /// Uniform or adaptive.
    pub mode: Mode,
    /// Rays of all kinds.
    pub total_rays: u64,
    /// Rays by kind, in the order of [`crate::stats::Stats::kinds`].
    #[serde(serialize_with = "ordered_map")]
    pub rays: Vec<(String, u64)>,
    /// Wall-clock render seconds (scene loading excluded, as in the stats).
    pub seconds: f64,
    /// total_rays / seconds / 10⁶.
    pub mrays_per_s: f64,
    /// Error against the reference.
    #[serde(flatten)]
    pub metrics: Metrics,
    /// On the Pareto front of its mode in (total_rays, rmse).
    pub pareto_rays: bool,
    /// On the Pareto front of its mode in (seconds, rmse).
    pub pareto_seconds: bool,
}

/// The reference a sweep measured against.
#[derive(Clone, Debug, Serialize)]
pub struct ReferenceInfo {
    /// The image: the given file, or the cached render in the output folder.
    pub path: PathBuf,
    /// `Reference::Spp`'s samples; `None` for a given file.
    pub spp: Option<u32>,
    /// True when this sweep rendered it; false when it was given or found in the cache.
    pub rendered: bool,
    /// The overrides the reference was rendered with, after the sweep's sets (empty for a
    /// given file).
    pub overrides: Vec<String>,
    /// Render seconds, when this sweep rendered it.
    pub seconds: Option<f64>,
    /// Rays traced, when this sweep rendered it.
    pub total_rays: Option<u64>,
}

/// What a sweep produced.
#[derive(Clone, Debug, Serialize)]
pub struct SweepResult {
    /// The scene's name (its path, or `<default scene>`).
    pub scene: String,
    /// Overrides applied to every point and the reference.
    pub sets: Vec<String>,
    /// The swept keys, in order.
    pub keys: Vec<String>,
    /// Worker threads of each render.
    pub threads: usize,
    /// The reference.
    pub reference: ReferenceInfo,
    /// One row per point, in cross-product order.
    pub points: Vec<Point>,
    /// The files written: the CSV, the JSON and the two plots (no plots without the
    /// `plot` feature).
    #[serde(skip)]
    pub files: Vec<PathBuf>,
}

/// File names in the output folder.
pub const CSV_FILE: &str = "sweep.csv";
/// The JSON rows.
pub const JSON_FILE: &str = "sweep.json";
/// RMSE against total rays, log-log.
pub const RAYS_PLOT: &str = "error_vs_rays.png";
/// RMSE against render seconds, log-log.
pub const SECONDS_PLOT: &str = "error_vs_seconds.png";

/// Parses `KEY=V1,V2,...`. Values are split on commas outside brackets, braces and
/// quotes, so TOML arrays and strings stay whole: `camera.position=[0,1,5],[0,2,5]` has
/// two values. Each value is what `--set KEY=VALUE` takes.
pub fn parse_param(s: &str) -> Result<(String, Vec<String>)> {
    let bad = |msg: &str| Error::input(format!("--param `{s}`: {msg}"));
    let (key, list) = s.split_once('=').ok_or_else(|| bad("expected KEY=V1,V2,..."))?;
    let key = key.trim();
    if key.is_empty() || key.split('.').any(|seg| seg.trim().is_empty()) {
        return Err(bad("empty key segment"));
    }
    if key.chars().any(char::is_whitespace) {
        return Err(bad("the key contains a space"));
    }
    let mut values = Vec::new();
    let (mut depth, mut quote, mut escaped) = (0i32, None::<char>, false);
    let mut cur = String::new();
    for c in list.chars() {
        match quote {
            Some(q) => {
                // Inside a basic string a backslash escapes the next character; literal
                // ('...') strings have no escapes.
                if escaped {
                    escaped = false;
                } else if c == '\\' && q == '"' {
                    escaped = true;
                } else if c == q {
                    quote = None;
                }
            }
            None => match c {
                '"' | '\'' => quote = Some(c),
                '[' | '{' => depth += 1,
                ']' | '}' => {
                    depth -= 1;
                    if depth < 0 {
                        return Err(bad(&format!("unmatched `{c}`")));
                    }
                }
                ',' if depth == 0 => {
                    values.push(std::mem::take(&mut cur));
                    continue;
                }
                _ => {}
            },
        }
        cur.push(c);
    }
    if quote.is_some() {
        return Err(bad("unterminated string"));
    }
    if depth != 0 {
        return Err(bad("unclosed `[` or `{`"));
    }
    values.push(cur);
    let values: Vec<String> = values.into_iter().map(|v| v.trim().to_string()).collect();
    if let Some(i) = values.iter().position(String::is_empty) {
        return Err(bad(&format!("value {} is empty", i + 1)));
    }
    Ok((key.to_string(), values))
}

/// 64-bit FNV-1a: a stable hash (unlike std's hasher, the same on every build and
/// platform), enough to name a cache file.
pub fn fnv1a64(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// True when a swept key can change the camera rays (their count, film positions or lens
/// samples), so the points cannot share the reference's camera samples: any `render.*`
/// key but the shadow settings and `max_depth`, and any `camera.*` key.
fn moves_camera_samples(key: &str) -> bool {
    let under = |p: &str| key == p || key.starts_with(&format!("{p}."));
    (under("render") || under("camera")) && !under("render.shadows") && !under("render.max_depth")
}

/// The overrides that make the reference from the sweep's scene (after its sets), as
/// described in the module docs. `base` is the scene with the sets applied.
pub fn reference_overrides(base: &Settings, params: &[(String, Vec<String>)], spp: u32) -> Vec<String> {
    let keep_camera = base.aa_mode == AaMode::Uniform && !params.iter().any(|(k, _)| moves_camera_samples(k));
    if keep_camera {
        return vec!["render.shadows.mode=uniform".into(), format!("render.shadows.samples={spp}")];
    }
    let swept_shadow = params
        .iter()
        .filter(|(k, _)| k == "render.shadows.samples")
        .flat_map(|(_, vs)| vs.iter().filter_map(|v| v.parse::<u32>().ok()))
        .max()
        .unwrap_or(0);
    vec![
        "render.aa.mode=uniform".into(),
        format!("render.aa.samples={spp}"),
        "render.shadows.mode=uniform".into(),
        format!("render.shadows.samples={}", base.shadow_samples.max(swept_shadow)),
    ]
}

/// The cross product of the params' values, the first key varying slowest.
pub(crate) fn cross_product(params: &[(String, Vec<String>)]) -> Vec<Vec<(String, String)>> {
    let mut points = vec![Vec::new()];
    for (key, values) in params {
        points = points
            .iter()
            .flat_map(|p| {
                values.iter().map(move |v| {
                    let mut q: Vec<(String, String)> = p.clone();
                    q.push((key.clone(), v.clone()));
                    q
                })
            })
            .collect();
    }
    points
}

/// `k=v, k=v` for messages.
fn describe(point: &[(String, String)]) -> String {
    if point.is_empty() {
        return "the scene as given".into();
    }
    point.iter().map(|(k, v)| format!("{k}={v}")).collect::<Vec<_>>().join(", ")
}

/// Sets plus the point's assignments: what `load` gets for a point.
fn overrides(sets: &[String], point: &[(String, String)]) -> Vec<String> {
    sets.iter().cloned().chain(point.iter().map(|(k, v)| format!("{k}={v}"))).collect()
}

/// Creates the output folder if missing; its parent must exist.
pub(crate) fn prepare_dir(dir: &Path) -> Result<()> {
    if dir.is_dir() {
        return Ok(());
    }
    if dir.exists() {
        return Err(Error::output(dir, "exists and is not a folder"));
    }
    let parent = match dir.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    if !parent.is_dir() {
        return Err(Error::output(dir, format!("folder `{}` does not exist", parent.display())));
    }
    std::fs::create_dir(dir).map_err(|e| Error::output(dir, format!("cannot create the folder: {e}")))
}

/// Serializes pairs as a JSON object, keeping their order.
pub(crate) fn ordered_map<S: Serializer, K: AsRef<str>, V: Serialize>(
    pairs: &[(K, V)],
    ser: S,
) -> std::result::Result<S::Ok, S::Error> {
    let mut m = ser.serialize_map(Some(pairs.len()))?;
    for (k, v) in pairs {
        m.serialize_entry(k.as_ref(), v)?;
    }
    m.end()
}

/// Runs the sweep: validates every point, gets the reference, renders each point,
/// measures it, and writes `sweep.csv`, `sweep.json`, `error_vs_rays.png` and
/// `error_vs_seconds.png` (the plots with the `plot` feature) into the output folder.
pub fn run(opts: &SweepOptions) -> Result<SweepResult> {
    // Everything a user can get wrong is checked before the first render.
    let plan = Plan::new(opts)?;
    let mut source = plan.reference_source()?;
    plan.check_sizes(&source)?;
    let files = output_files(&opts.out_dir)?;

    let render_opts = RenderOptions { threads: opts.threads, ..Default::default() };
    source.load_cached();
    let progress = Progress::new(opts.progress, plan.points.len() as u64 + source.image.is_none() as u64);
    let (reference, info) = plan.reference(source, &render_opts, &progress)?;
    let (mut rows, threads) = plan.measure(&reference, &info.path, &render_opts, &progress)?;
    progress.finish();
    mark_pareto(&mut rows);

    let result = SweepResult {
        scene: plan.src.name.clone(),
        sets: opts.sets.clone(),
        keys: opts.params.iter().map(|(k, _)| k.clone()).collect(),
        threads,
        reference: info,
        points: rows,
        files,
    };
    write_outputs(&result)?;
    Ok(result)
}

/// Creates the output folder and checks that each file the sweep writes can be written
/// there: the CSV, the JSON and, with the `plot` feature, the two plots, in that order.
fn output_files(dir: &Path) -> Result<Vec<PathBuf>> {
    prepare_dir(dir)?;
    let names: &[&str] =
        if cfg!(feature = "plot") { &[CSV_FILE, JSON_FILE, RAYS_PLOT, SECONDS_PLOT] } else { &[CSV_FILE, JSON_FILE] };
    let files: Vec<PathBuf> = names.iter().map(|f| dir.join(f)).collect();
    for f in &files {
        check_output(f)?;
    }
    Ok(files)
}

/// Writes the result's files: the CSV, the JSON and (with `plot`) the two plots.
fn write_outputs(result: &SweepResult) -> Result<()> {
    write_text(&result.files[0], &result.csv())?;
    write_text(&result.files[1], &(result.json()? + "\n"))?;
    #[cfg(feature = "plot")]
    {
        result.plot(&result.files[2], |p| p.total_rays as f64, "rays traced (all kinds)")?;
        result.plot(&result.files[3], |p| p.seconds, "render seconds (wall clock)")?;
    }
    Ok(())
}

/// Marks the Pareto front of `points` when both coordinates are to be minimised: a point
/// is on the front unless another has x ≤ and y ≤ with at least one strictly less.
/// Identical points do not dominate each other, so duplicates share their fate. Points
/// with a NaN coordinate are never on the front and never dominate.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<bool> {
    let valid = |p: &(f64, f64)| !p.0.is_nan() && !p.1.is_nan();
    points
        .iter()
        .map(|p| valid(p) && !points.iter().any(|q| valid(q) && q.0 <= p.0 && q.1 <= p.1 && (q.0 < p.0 || q.1 < p.1)))
        .collect()
}

/// Marks each point's place on its mode's Pareto fronts.
fn mark_pareto(rows: &mut [Point]) {
    for mode in Mode::ALL {
        let idx: Vec<usize> = (0..rows.len()).filter(|&i| rows[i].mode == mode).collect();
        let by_rays =
            pareto_front(&idx.iter().map(|&i| (rows[i].total_rays as f64, rows[i].metrics.rmse)).collect::<Vec<_>>());
        let by_secs = pareto_front(&idx.iter().map(|&i| (rows[i].seconds, rows[i].metrics.rmse)).collect::<Vec<_>>());
        for (k, &i) in idx.iter().enumerate() {
            rows[i].pareto_rays = by_rays[k];
            rows[i].pareto_seconds = by_secs[k];
        }
    }
}

mod measure;
mod plan;
mod report;

pub(crate) use measure::{render_reference, Progress};
pub(crate) use plan::{cached_reference, reference_cache_path};
pub(crate) use report::{csv_field, versioned_json};

#[cfg(test)]
mod tests {
    use super::report::csv_field;
    use super::*;

    #[test]
    fn pareto_marks_non_dominated_points() {
        let pts = [(1.0, 5.0), (2.0, 2.0), (3.0, 3.0), (4.0, 1.0), (2.0, 2.0), (5.0, 1.0), (f64::NAN, 0.0)];
        assert_eq!(pareto_front(&pts), [true, true, false, true, true, false, false]);
    }

    #[test]
    fn fnv1a_known_values() {
        // Published FNV-1a 64 test vectors.
        assert_eq!(fnv1a64(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a64(b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(fnv1a64(b"foobar"), 0x8594_4171_f739_67e8);
    }

    #[test]
    fn cross_product_order() {
        let p =
            cross_product(&[("a".into(), vec!["1".into(), "2".into()]), ("b".into(), vec!["x".into(), "y".into()])]);
        let d: Vec<String> = p.iter().map(|q| describe(q)).collect();
        assert_eq!(d, ["a=1, b=x", "a=1, b=y", "a=2, b=x", "a=2, b=y"]);
        assert_eq!(cross_product(&[]).len(), 1);
    }

    #[test]
    fn parse_param_splits_outside_brackets_and_quotes() {
        let (k, v) = parse_param("objects.0.name=\"a,b\",'c,d',[1,[2,3]],{x=1,y=2}").unwrap();
        assert_eq!(k, "objects.0.name");
        assert_eq!(v, ["\"a,b\"", "'c,d'", "[1,[2,3]]", "{x=1,y=2}"]);
        assert!(parse_param("k=[1,2").is_err());
        assert!(parse_param("k=1]").is_err());
        assert!(parse_param("k=1,,2").is_err());
        assert!(parse_param("k=\"open").is_err());
        assert!(parse_param("=1").is_err());
        assert!(parse_param("a..b=1").is_err());
        assert!(parse_param("novalue").is_err());
    }

    #[test]
    fn csv_quotes_fields_with_commas() {
        assert_eq!(csv_field("[0,1,5]"), "\"[0,1,5]\"");
        assert_eq!(csv_field("\"a\""), "\"\"\"a\"\"\"");
        assert_eq!(csv_field("0.01"), "0.01");
    }

    #[test]
    fn camera_keys() {
        for k in ["render.aa.samples", "render.aa.mode", "render.dof.samples", "render.seed", "render.width"] {
            assert!(moves_camera_samples(k), "{k}");
        }
        for k in ["render.shadows.samples", "render.shadows.mode", "render.max_depth", "objects.0.radius"] {
            assert!(!moves_camera_samples(k), "{k}");
        }
    }
}
