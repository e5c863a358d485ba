//! The study manifest (TOML): which scenes, with which overrides, which methods and grids,
//! and how the reference and the targets are made. Read and checked here, before any
//! render, into a [`Plan`]; every mistake is an input error naming the manifest.
//!
//! ```toml
//! [study]
//! methods = ["uniform", "adaptive-aa"]   # default: every method (methods::METHODS)
//! sets = ["render.width=160"]            # before every scene's own sets
//! reference_spp = 1024                   # uniform camera samples of the reference
//! reference_shadow_samples = 4           # uniform shadow rays per reference sample
//! target_spp = [4, 16, 64]               # targets: the FLIP uniform reaches at these spp
//! quick_size = [32, 24]                  # --quick: every scene at this size
//! [study.grids.adaptive-aa]              # replaces these keys' values of a default grid
//! "render.aa.eps" = [0.05, 0.01]
//!
//! [[scene]]
//! file = "paper/fig02-aa.toml"           # relative to the manifest
//! name = "fig02-aa"                      # default: the file's stem
//! sets = ["render.width=160", "render.height=160"]
//! held_out = true                        # kept out of fitting the map; reported apart
//! methods = ["uniform", "adaptive-aa"]   # default: the study's
//! targets = [0.05, 0.02]                 # FLIP targets given, instead of target_spp
//! [scene.grids."*"]                     # every method whose grid has the key
//! "render.shadows.samples" = [1]         # per scene, after the study's grids
//! ```

use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::methods::{self, Method};
use crate::scene::{load, SceneSource};
use crate::tools::sweep::cross_product;
use crate::{Error, Result};

/// Default `reference_spp`.
pub const REFERENCE_SPP: u32 = 1024;
/// Default `reference_shadow_samples`.
pub const REFERENCE_SHADOW_SAMPLES: u32 = 4;
/// Default `target_spp`.
pub const TARGET_SPP: [u32; 3] = [4, 16, 64];
/// `--quick`'s reference samples.
pub const QUICK_REFERENCE_SPP: u32 = 64;
/// `--quick`'s target counts (in every method's quick uniform grid).
pub const QUICK_TARGET_SPP: [u32; 2] = [4, 16];
/// Default `quick_size`.
pub const QUICK_SIZE: [u32; 2] = [32, 24];

/// Grid overrides: method name → key → values (TOML scalars, turned into `--set` text).
type GridsDesc = BTreeMap<String, BTreeMap<String, Vec<toml::Value>>>;

/// The file.
#[derive(Deserialize, Debug, Default)]
#[serde(deny_unknown_fields)]
struct ManifestDesc {
    #[serde(default)]
    study: StudyDesc,
    #[serde(default)]
    scene: Vec<SceneDesc>,
}

/// `[study]`: defaults for every scene.
#[derive(Deserialize, Debug, Default)]
#[serde(deny_unknown_fields, default)]
struct StudyDesc {
    methods: Option<Vec<String>>,
    sets: Vec<String>,
    reference_spp: Option<u32>,
    reference_shadow_samples: Option<u32>,
    target_spp: Option<Vec<u32>>,
    quick_size: Option<[u32; 2]>,
    grids: GridsDesc,
}

/// One `[[scene]]`.
#[derive(Deserialize, Debug, Default)]
#[serde(deny_unknown_fields, default)]
struct SceneDesc {
    file: PathBuf,
    name: Option<String>,
    sets: Vec<String>,
    held_out: bool,
    methods: Option<Vec<String>>,
    reference_spp: Option<u32>,
    reference_shadow_samples: Option<u32>,
    target_spp: Option<Vec<u32>>,
    targets: Option<Vec<f64>>,
    grids: GridsDesc,
}

/// How a scene's target errors are found.
#[derive(Clone, Debug, PartialEq)]
pub enum Targets {
    /// The best FLIP of uniform's renders with each of these camera samples per pixel.
    UniformSpp(Vec<u32>),
    /// FLIP values given in the manifest.
    Flip(Vec<f64>),
}

/// One method of one scene: its points, each a list of assignments.
#[derive(Clone, Debug)]
pub struct MethodPlan {
    /// The method.
    pub method: &'static Method,
    /// The grid's keys, in order.
    pub keys: Vec<String>,
    /// The cross product of the grid, the first key varying slowest.
    pub points: Vec<Vec<(String, String)>>,
}

/// One scene of the study, checked.
pub struct ScenePlan {
    /// Unique name: file names and table rows.
    pub name: String,
    /// The scene file.
    pub file: PathBuf,
    /// The scene, read.
    pub src: SceneSource,
    /// The study's sets, the scene's, and `--quick`'s size, in that order.
    pub sets: Vec<String>,
    /// Kept out of fitting the map.
    pub held_out: bool,
    /// Uniform camera samples of the reference.
    pub reference_spp: u32,
    /// Uniform shadow rays per reference sample.
    pub reference_shadow_samples: u32,
    /// How the targets are found.
    pub targets: Targets,
    /// The methods that run.
    pub methods: Vec<MethodPlan>,
    /// Methods left out, with why.
    pub skipped: Vec<(String, String)>,
}

/// The checked manifest.
pub struct Plan {
    /// The manifest file.
    pub manifest: PathBuf,
    /// The scenes, in manifest order.
    pub scenes: Vec<ScenePlan>,
}

/// `KEY=VALUE` from a grid value: strings as they are (what `--set` takes), other
/// scalars in TOML's spelling.
fn set_text(v: &toml::Value) -> Option<String> {
    match v {
        toml::Value::String(s) => Some(s.clone()),
        toml::Value::Integer(_) | toml::Value::Float(_) | toml::Value::Boolean(_) => Some(v.to_string()),
        _ => None,
    }
}

/// A method's grid: its default (or quick) one, with the study's then the scene's
/// overrides applied key by key (a new key goes last).
fn grid_of(
    method: &Method,
    quick: bool,
    layers: &[&GridsDesc],
    bad: &dyn Fn(String) -> Error,
) -> Result<Vec<(String, Vec<String>)>> {
    let base = if quick { method.quick } else { method.grid };
    let mut grid: Vec<(String, Vec<String>)> =
        base.iter().map(|(k, vs)| (k.to_string(), vs.iter().map(|v| v.to_string()).collect())).collect();
    if quick {
        // --quick is for speed: the manifest's (larger) grids do not apply.
        return Ok(grid);
    }
    for layer in layers {
        // `"*"` first, and only for keys the grid has: a shared setting such as one shadow
        // sample for a scene without area lights, without naming every method.
        let shared = layer.get("*").into_iter().flatten().filter(|(k, _)| grid.iter().any(|(g, _)| g == *k));
        let shared: Vec<_> = shared.collect();
        for (key, values) in shared.into_iter().chain(layer.get(method.name).into_iter().flatten()) {
            let texts: Option<Vec<String>> = values.iter().map(set_text).collect();
            let texts = texts.ok_or_else(|| {
                bad(format!("grids.{}.\"{key}\": values must be numbers, strings or booleans", method.name))
            })?;
            if texts.is_empty() {
                return Err(bad(format!("grids.{}.\"{key}\" has no values", method.name)));
            }
            match grid.iter_mut().find(|(k, _)| k == key) {
                Some(slot) => slot.1 = texts,
                None => grid.push((key.clone(), texts)),
            }
        }
    }
    Ok(grid)
}

/// The methods a name list selects, each checked.
fn select(names: Option<&Vec<String>>, bad: &dyn Fn(String) -> Error) -> Result<Vec<&'static Method>> {
    match names {
        None => Ok(methods::METHODS.iter().collect()),
        Some(list) => list
            .iter()
            .map(|n| {
                methods::by_name(n).ok_or_else(|| bad(format!("unknown method `{n}` (known: {})", methods::names())))
            })
            .collect(),
    }
}

/// A scene's name: given, or the file's stem; letters, digits, `-`, `_` and `.` only, as
/// it names files.
fn scene_name(desc: &SceneDesc, bad: &dyn Fn(String) -> Error) -> Result<String> {
    let name = match &desc.name {
        Some(n) => n.clone(),
        None => desc.file.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default(),
    };
    let ok = |c: char| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.');
    if name.is_empty() || !name.chars().all(ok) || name.starts_with('.') {
        return Err(bad(format!(
            "scene name `{name}`: use letters, digits, `-`, `_` and `.` (it names the plot files)"
        )));
    }
    Ok(name)
}

/// What reading the manifest needs besides the file.
pub struct ReadOptions<'a> {
    /// `--quick`.
    pub quick: bool,
    /// Only these scene names (empty: all).
    pub only: &'a [String],
    /// `--reference-spp`, over the manifest's.
    pub reference_spp: Option<u32>,
}

/// Reads and checks the manifest: every scene loads with its sets, every method with its
/// fixed sets (else it is skipped with the error as the note), and every grid value on
/// its own (else an input error naming it). Values are checked one at a time, not the
/// whole cross product, since a load builds the scene's BVH; a combination that fails
/// at render time is skipped with a note.
pub fn read(path: &Path, opts: &ReadOptions) -> Result<Plan> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| Error::input(format!("study manifest `{}`: cannot read: {e}", path.display())))?;
    let shown = path.display().to_string();
    let bad = |msg: String| Error::input(format!("study manifest `{shown}`: {msg}"));
    let desc: ManifestDesc = toml::from_str(&text).map_err(|e| bad(e.to_string().trim().to_string()))?;
    if desc.scene.is_empty() {
        return Err(bad("no [[scene]] entries".into()));
    }
    let study = &desc.study;
    select(study.methods.as_ref(), &bad)?;
    for grids in std::iter::once(&study.grids).chain(desc.scene.iter().map(|s| &s.grids)) {
        if let Some(m) = grids.keys().find(|m| *m != "*" && methods::by_name(m).is_none()) {
            return Err(bad(format!("grids.{m}: unknown method (known: {}, or \"*\" for all)", methods::names())));
        }
    }
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut names = std::collections::HashSet::new();
    let mut scenes = Vec::new();
    for (i, s) in desc.scene.iter().enumerate() {
        let name = scene_name(s, &|m| bad(format!("scene {}: {m}", i + 1)))?;
        if !names.insert(name.clone()) {
            return Err(bad(format!("scene name `{name}` is used twice (give one a `name`)")));
        }
        if !opts.only.is_empty() && !opts.only.contains(&name) {
            continue;
        }
        scenes.push(read_scene(s, name, &dir, study, opts, &bad)?);
    }
    if let Some(missing) = opts.only.iter().find(|n| !names.contains(*n)) {
        return Err(bad(format!("--scene `{missing}`: no such scene (names: {})", names_in(&desc.scene))));
    }
    Ok(Plan { manifest: path.to_path_buf(), scenes })
}

/// The scene names of a manifest, for messages.
fn names_in(scenes: &[SceneDesc]) -> String {
    let bad = |m: String| Error::input(m);
    scenes.iter().filter_map(|s| scene_name(s, &bad).ok()).collect::<Vec<_>>().join(", ")
}

/// Checks one scene and builds its plan.
fn read_scene(
    s: &SceneDesc,
    name: String,
    dir: &Path,
    study: &StudyDesc,
    opts: &ReadOptions,
    bad: &dyn Fn(String) -> Error,
) -> Result<ScenePlan> {
    let bad = |m: String| bad(format!("scene `{name}`: {m}"));
    let file = if s.file.is_absolute() { s.file.clone() } else { dir.join(&s.file) };
    if s.file.as_os_str().is_empty() || !file.is_file() {
        return Err(bad(format!("file `{}`: no such file", file.display())));
    }
    let src = SceneSource::from_file(&file)?;
    let mut sets: Vec<String> = study.sets.iter().chain(&s.sets).cloned().collect();
    if opts.quick {
        let [w, h] = study.quick_size.unwrap_or(QUICK_SIZE);
        sets.extend([format!("render.width={w}"), format!("render.height={h}")]);
    }
    let base = load(&src, &sets).map_err(|e| bad(e.to_string()))?;
    let reference_spp = match (opts.quick, opts.reference_spp) {
        (_, Some(n)) => n,
        (true, None) => QUICK_REFERENCE_SPP,
        (false, None) => s.reference_spp.or(study.reference_spp).unwrap_or(REFERENCE_SPP),
    };
    let reference_shadow_samples =
        s.reference_shadow_samples.or(study.reference_shadow_samples).unwrap_or(REFERENCE_SHADOW_SAMPLES);
    if reference_spp == 0 || reference_shadow_samples == 0 {
        return Err(bad("reference_spp and reference_shadow_samples must be at least 1".into()));
    }
    let chosen = select(s.methods.as_ref().or(study.methods.as_ref()), &bad)?;
    let targets = match (&s.targets, opts.quick) {
        (Some(t), _) if t.is_empty() || t.iter().any(|v| !(v.is_finite() && *v > 0.0)) => {
            return Err(bad("targets must be FLIP values above 0".into()))
        }
        (Some(t), _) => Targets::Flip(t.clone()),
        (None, true) => Targets::UniformSpp(QUICK_TARGET_SPP.to_vec()),
        (None, false) => {
            Targets::UniformSpp(s.target_spp.clone().or(study.target_spp.clone()).unwrap_or(TARGET_SPP.to_vec()))
        }
    };
    let (mut methods, mut skipped) = (Vec::new(), Vec::new());
    for method in chosen {
        if let Some(why) = method.needs.unmet(&base) {
            skipped.push((method.name.to_string(), why.to_string()));
            continue;
        }
        let fixed: Vec<String> = sets.iter().cloned().chain(method.fixed.iter().map(|f| f.to_string())).collect();
        if let Err(e) = load(&src, &fixed) {
            skipped.push((method.name.to_string(), format!("does not load in this build: {e}")));
            continue;
        }
        let grid = grid_of(method, opts.quick, &[&study.grids, &s.grids], &bad)?;
        for (key, values) in &grid {
            for v in values {
                let one: Vec<String> = fixed.iter().cloned().chain([format!("{key}={v}")]).collect();
                load(&src, &one).map_err(|e| bad(format!("method {}: {key}={v}: {e}", method.name)))?;
            }
        }
        let keys = grid.iter().map(|(k, _)| k.clone()).collect();
        methods.push(MethodPlan { method, keys, points: cross_product(&grid) });
    }
    if let Targets::UniformSpp(spp) = &targets {
        check_target_spp(spp, &methods, &bad)?;
    }
    Ok(ScenePlan {
        name,
        file,
        src,
        sets,
        held_out: s.held_out,
        reference_spp,
        reference_shadow_samples,
        targets,
        methods,
        skipped,
    })
}

/// Targets from uniform need uniform in the study with each count in its grid.
fn check_target_spp(spp: &[u32], methods: &[MethodPlan], bad: &dyn Fn(String) -> Error) -> Result<()> {
    let uniform = methods.iter().find(|m| m.method.name == "uniform").ok_or_else(|| {
        bad("the targets come from uniform's renders (target_spp), so `uniform` must be among the methods; or give `targets`".into())
    })?;
    for n in spp {
        let has = uniform.points.iter().any(|p| p.iter().any(|(k, v)| k == "render.aa.samples" && v.parse() == Ok(*n)));
        if !has {
            return Err(bad(format!("target_spp {n} is not a render.aa.samples value of uniform's grid")));
        }
    }
    if spp.is_empty() {
        return Err(bad("target_spp is empty".into()));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grids_are_overridden_key_by_key() {
        let bad = |m: String| Error::input(m);
        let m = methods::by_name("uniform").expect("uniform");
        let study: GridsDesc = toml::from_str("[uniform]\n\"render.aa.samples\" = [2, 8]\n").expect("toml");
        let scene: GridsDesc = toml::from_str(
            "[uniform]\n\"render.seed\" = [1]\n[\"*\"]\n\"render.shadows.samples\" = [2]\n\"render.aa.eps\" = [0.5]\n",
        )
        .expect("toml");
        let g = grid_of(m, false, &[&study, &scene], &bad).expect("grid");
        assert_eq!(g[0], ("render.aa.samples".to_string(), vec!["2".to_string(), "8".to_string()]));
        // "*" replaced the shadow samples and added no eps to uniform.
        assert_eq!(g[1], ("render.shadows.samples".to_string(), vec!["2".to_string()]));
        assert_eq!(g[2], ("render.seed".to_string(), vec!["1".to_string()]));
        assert_eq!(g.len(), 3);
        // --quick keeps the quick grid.
        assert_eq!(grid_of(m, true, &[&study], &bad).expect("grid").len(), m.quick.len());
        let empty: GridsDesc = toml::from_str("[uniform]\n\"render.seed\" = []\n").expect("toml");
        assert!(grid_of(m, false, &[&empty], &bad).is_err());
    }
}
