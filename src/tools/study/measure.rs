//! The renders of one scene: its reference (cached, shared with the sweep), every
//! method's grid, each measured against the reference; then the scene's targets, picks,
//! winners and features.

use super::features::{self, Features};
use super::manifest::{ScenePlan, Targets};
use super::methods::{Method, Needs};
use super::search::{cheapest, contenders, targets_from_uniform, winner, worst_share, Cost, Entry};
use super::{Choice, Counters, Pick, Row, SceneResult, StudyOptions, TargetResult};
use crate::color::srgb_encode;
use crate::film::Image;
use crate::scene::load;
use crate::tools::compare::{metrics, Metrics};
use crate::tools::sweep::{
    cached_reference, pareto_front, reference_cache_path, render_reference, Progress, ReferenceInfo,
};
use crate::{RenderOptions, Result};

/// Renders and measures one scene. Also returns the worker threads of its renders.
pub(super) fn scene(plan: &ScenePlan, opts: &StudyOptions, progress: &Progress) -> Result<(SceneResult, usize)> {
    let render_opts = RenderOptions { threads: opts.threads, ..Default::default() };
    let base = load(&plan.src, &plan.sets)?;
    let size = (base.settings.width, base.settings.height);
    let (reference, info) = reference(plan, size, &opts.out_dir, &render_opts, progress)?;
    let (mut rows, mut notes, mut threads) = (Vec::new(), Vec::new(), opts.threads.unwrap_or(0));
    for m in &plan.methods {
        for point in &m.points {
            progress.say(format!("{} {}", plan.name, m.method.name));
            match render_row(m.method, point, plan, &reference, &render_opts, (opts.runs, opts.seeds)) {
                Ok((row, t)) => {
                    rows.push(row);
                    threads = t;
                }
                // A combination the per-value check could not see (or a size mismatch):
                // reported, not fatal, so one bad point costs no finished renders.
                Err(e) => notes.push(format!("{} {}: skipped: {e}", m.method.name, describe(point))),
            }
            progress.step();
        }
    }
    let targets = targets(plan, &rows);
    confirm(&mut rows, &targets, plan, (&render_opts, opts.seeds), progress)?;
    mark_pareto(&mut rows);
    let mut feats = Features { path: base.settings.path(), ..Features::default() };
    (feats.glossy_fraction, feats.coc_spread, feats.coc_mean_px) = features::probe(&base);
    let first_spp = match &plan.targets {
        Targets::UniformSpp(spp) => spp.first().copied(),
        Targets::Flip(_) => None,
    };
    features::from_rows(&mut feats, &rows, first_spp);
    // No area light, no penumbra: known without the adaptive-shadow renders it skipped.
    if feats.penumbra_fraction.is_none() && Needs::AreaLight.unmet(&base).is_some() {
        feats.penumbra_fraction = Some(0.0);
    }
    let result = SceneResult {
        name: plan.name.clone(),
        file: plan.file.clone(),
        held_out: plan.held_out,
        sets: plan.sets.clone(),
        size,
        reference: info,
        features: feats,
        targets: targets.iter().map(|(label, flip)| answer(label, *flip, plan, &rows)).collect(),
        skipped: plan.skipped.clone(),
        notes,
        rows,
    };
    Ok((result, threads))
}

/// `k=v k=v` for notes.
fn describe(point: &[(String, String)]) -> String {
    point.iter().map(|(k, v)| format!("{k}={v}")).collect::<Vec<_>>().join(" ")
}

/// The scene's reference: the cached render when it is there and the right size, else a
/// new render written to the cache.
fn reference(
    plan: &ScenePlan,
    size: (u32, u32),
    out_dir: &std::path::Path,
    render_opts: &RenderOptions,
    progress: &Progress,
) -> Result<(Image, ReferenceInfo)> {
    let overrides = vec![
        "render.aa.mode=uniform".to_string(),
        format!("render.aa.samples={}", plan.reference_spp),
        "render.shadows.mode=uniform".to_string(),
        format!("render.shadows.samples={}", plan.reference_shadow_samples),
    ];
    let path = reference_cache_path(out_dir, &plan.src, &plan.sets, &overrides);
    let mut info = ReferenceInfo {
        path: path.clone(),
        spp: Some(plan.reference_spp),
        rendered: false,
        overrides: overrides.clone(),
        seconds: None,
        total_rays: None,
    };
    if let Some(image) = cached_reference(&path, size) {
        progress.step();
        return Ok((image, info));
    }
    progress.say(format!("{} reference", plan.name));
    let sets: Vec<String> = plan.sets.iter().chain(&overrides).cloned().collect();
    let out = render_reference(&plan.src, &sets, &path, render_opts)?;
    progress.step();
    info.rendered = true;
    info.seconds = Some(out.seconds);
    info.total_rays = Some(out.stats.total_rays());
    Ok((out.image, info))
}

/// A setting whose renders add up to less than this many seconds is rendered again (up
/// to [`SHORT_RUNS`] times): seven runs of one 0.05 s render (cbox at 80², auto) spread
/// over 0.84–1.44× their median on the 2-core machine, enough to decide a 10%
/// comparison either way; repeating it costs at most this much.
pub const SHORT: f64 = 0.1;

/// The most runs of a short setting.
pub const SHORT_RUNS: u32 = 5;

/// Renders one setting of `method` `runs` times, and more while its renders add up to
/// less than [`SHORT`] seconds (at most [`SHORT_RUNS`] in all), and measures the first
/// run's image (every run's image is the same: renders are deterministic). With `seeds`
/// above 1 a run renders the setting at each seed ([`seed_scenes`]): its seconds, rays
/// and errors are the seeds' means, its counters and worst-pixel share the first's.
fn render_row(
    method: &'static Method,
    point: &[(String, String)],
    plan: &ScenePlan,
    reference: &Image,
    render_opts: &RenderOptions,
    (runs, seeds): (u32, u32),
) -> Result<(Row, usize)> {
    let scenes = seed_scenes(plan, &row_sets(method, point, plan), seeds)?;
    let mut secs = Vec::with_capacity(runs as usize);
    let mut first = None;
    let short = |secs: &[f64]| secs.len() < SHORT_RUNS as usize && secs.iter().sum::<f64>() < SHORT;
    while secs.len() < runs as usize || short(&secs) {
        let (seconds, outs) = render_seeds(&scenes, render_opts)?;
        secs.push(seconds);
        first.get_or_insert(outs);
    }
    let outs = first.expect("runs >= 1");
    let mut sum = [0.0; 4];
    for out in &outs {
        let m = metrics(&out.image, reference)?;
        for (s, v) in sum.iter_mut().zip([m.rmse, m.rel_mse, m.psnr, m.flip]) {
            *s += v;
        }
    }
    let [rmse, rel_mse, psnr, flip] = sum.map(|s| s / outs.len() as f64);
    let out = &outs[0];
    // Display values (clamped, sRGB), as FLIP sees them: in linear values a few bright
    // pixels (a light's edge, a firefly) held nearly all the error of every scene.
    let display = |v: f32| srgb_encode(v.clamp(0.0, 1.0)) as f64;
    let errors: Vec<f64> = out
        .image
        .pixels
        .iter()
        .zip(&reference.pixels)
        .map(|(t, r)| (0..3).map(|c| (display(t[c]) - display(r[c])).powi(2)).sum())
        .collect();
    let mean = |rays: &dyn Fn(&crate::RenderOutput) -> u64| outs.iter().map(rays).sum::<u64>() / outs.len() as u64;
    let kinds = out.stats.kinds();
    let row = Row {
        method: method.name,
        params: point.to_vec(),
        total_rays: mean(&|o| o.stats.total_rays()),
        rays: kinds.iter().enumerate().map(|(j, &(k, _))| (k.to_string(), mean(&|o| o.stats.kinds()[j].1))).collect(),
        seconds: median(&secs),
        runs: secs,
        metrics: Metrics { rmse, rel_mse, psnr, flip },
        worst10_share: worst_share(&errors, 0.1),
        counters: Counters::of(&out.stats),
        pareto_seconds: false,
        pareto_rays: false,
    };
    Ok((row, out.per_thread.len()))
}

/// A setting's scene at each of `seeds` seeds: as its `sets` give it, then with
/// `render.seed` at the next `seeds - 1` values. An adaptive method's rays and time,
/// and auto's plan, change with the seed as its errors do.
fn seed_scenes(plan: &ScenePlan, sets: &[String], seeds: u32) -> Result<Vec<crate::Scene>> {
    let first = load(&plan.src, sets)?;
    let seed = first.settings.seed;
    let mut scenes = vec![first];
    for k in 1..seeds {
        let next = [sets, &[format!("render.seed={}", seed.wrapping_add(k))]].concat();
        scenes.push(load(&plan.src, &next)?);
    }
    Ok(scenes)
}

/// Renders each of `scenes` once: the mean of their seconds, and the renders.
fn render_seeds(scenes: &[crate::Scene], render_opts: &RenderOptions) -> Result<(f64, Vec<crate::RenderOutput>)> {
    let outs = scenes.iter().map(|s| crate::render(s, render_opts)).collect::<Result<Vec<_>>>()?;
    Ok((outs.iter().map(|o| o.seconds).sum::<f64>() / outs.len() as f64, outs))
}

/// A setting's `--set`s: the scene's, then the method's, then the point's (later ones win).
fn row_sets(method: &Method, point: &[(String, String)], plan: &ScenePlan) -> Vec<String> {
    plan.sets
        .iter()
        .cloned()
        .chain(method.fixed.iter().map(|f| f.to_string()))
        .chain(point.iter().map(|(k, v)| format!("{k}={v}")))
        .collect()
}

/// Each method's cheapest setting within this factor of a target's fastest is timed
/// again ([`confirm`]): one run of a render lands anywhere in 0.84–1.44× its median
/// ([`SHORT`]), so a setting up to about 1.5× the fastest single run may be the faster.
/// With 1.3, one of auto's picks at 1.41× (one run) went unconfirmed while the fixed
/// method it was measured against had five.
pub const CONTEST: f64 = 1.5;

/// Runs of a contending setting: their median decides the target.
pub const CONFIRM_RUNS: usize = 5;

/// The single-run seconds of a grid decide which settings are cheapest, but not which of
/// the near-equal ones wins: for each target, every method's cheapest setting within
/// [`CONTEST`] of the fastest is rendered [`CONFIRM_RUNS`] times more, the contenders of
/// the scene in turns (so a slow spell of the machine falls on all of them), and its
/// seconds become the median of those runs alone (a short setting's earlier runs came one
/// after another). A setting whose new seconds make another of its method's the cheapest
/// brings that one into the next round (at most three).
fn confirm(
    rows: &mut [Row],
    targets: &[(String, f64)],
    plan: &ScenePlan,
    (render_opts, seeds): (&RenderOptions, u32),
    progress: &Progress,
) -> Result<()> {
    // Rows whose runs are the interleaved ones.
    let mut confirmed = vec![false; rows.len()];
    for _ in 0..3 {
        let mut todo: Vec<usize> = targets
            .iter()
            .flat_map(|&(_, flip)| {
                let picks = fastest_picks(rows, plan, flip);
                let measures: Vec<_> = picks.iter().map(|&i| rows[i].measure()).collect();
                contenders(&measures, CONTEST).into_iter().map(move |k| picks[k])
            })
            .filter(|&i| !confirmed[i])
            .collect();
        todo.sort_unstable();
        todo.dedup();
        if todo.is_empty() {
            break;
        }
        // A short setting's grid runs (SHORT) came one after another, in whatever spell
        // the machine was in then: a contender's seconds are its interleaved runs only.
        for &i in &todo {
            rows[i].runs.clear();
            confirmed[i] = true;
        }
        progress.say(format!("{} confirming {} settings", plan.name, todo.len()));
        let scenes = todo
            .iter()
            .map(|&i| {
                let method = plan.methods.iter().find(|m| m.method.name == rows[i].method).map(|m| m.method);
                let method = method.ok_or_else(|| crate::Error::Internal(format!("no method {}", rows[i].method)))?;
                seed_scenes(plan, &row_sets(method, &rows[i].params, plan), seeds)
            })
            .collect::<Result<Vec<_>>>()?;
        while todo.iter().any(|&i| rows[i].runs.len() < CONFIRM_RUNS) {
            for (&i, scenes) in todo.iter().zip(&scenes) {
                if rows[i].runs.len() < CONFIRM_RUNS {
                    rows[i].runs.push(render_seeds(scenes, render_opts)?.0);
                }
            }
        }
        for &i in &todo {
            rows[i].seconds = median(&rows[i].runs);
        }
    }
    Ok(())
}

/// Each method's cheapest setting in seconds that reaches `flip`, as row indices.
fn fastest_picks(rows: &[Row], plan: &ScenePlan, flip: f64) -> Vec<usize> {
    plan.methods.iter().filter_map(|m| cheapest_row(rows, m.method.name, flip, Cost::Seconds)).collect()
}

/// The row of `method`'s cheapest setting under `cost` that reaches `flip`, if any.
fn cheapest_row(rows: &[Row], method: &str, flip: f64, cost: Cost) -> Option<usize> {
    let idx: Vec<usize> = (0..rows.len()).filter(|&i| rows[i].method == method).collect();
    let measures: Vec<_> = idx.iter().map(|&i| rows[i].measure()).collect();
    cheapest(&measures, flip, cost).map(|k| idx[k])
}

/// The median (the mean of the middle two for an even count); NaN for none.
pub(super) fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    match s.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => s[n / 2],
        n => (s[n / 2 - 1] + s[n / 2]) / 2.0,
    }
}

/// Marks each row's place on its method's Pareto fronts in FLIP.
fn mark_pareto(rows: &mut [Row]) {
    let mut methods: Vec<&'static str> = rows.iter().map(|r| r.method).collect();
    methods.dedup();
    for name in methods {
        let idx: Vec<usize> = (0..rows.len()).filter(|&i| rows[i].method == name).collect();
        let secs = pareto_front(&idx.iter().map(|&i| (rows[i].seconds, rows[i].metrics.flip)).collect::<Vec<_>>());
        let rays =
            pareto_front(&idx.iter().map(|&i| (rows[i].total_rays as f64, rows[i].metrics.flip)).collect::<Vec<_>>());
        for (k, &i) in idx.iter().enumerate() {
            rows[i].pareto_seconds = secs[k];
            rows[i].pareto_rays = rays[k];
        }
    }
}

/// The scene's targets, each with where it comes from.
fn targets(plan: &ScenePlan, rows: &[Row]) -> Vec<(String, f64)> {
    match &plan.targets {
        Targets::Flip(t) => t.iter().map(|&f| ("given".to_string(), f)).collect(),
        Targets::UniformSpp(spp) => {
            let uniform: Vec<(u32, f64)> = rows
                .iter()
                .filter(|r| r.method == "uniform")
                .filter_map(|r| Some((r.param("render.aa.samples")?.parse().ok()?, r.metrics.flip)))
                .collect();
            targets_from_uniform(&uniform, spp).into_iter().map(|(n, f)| (format!("uniform {n} spp"), f)).collect()
        }
    }
}

/// Every method's cheapest settings for one target, and the winners.
fn answer(label: &str, flip: f64, plan: &ScenePlan, rows: &[Row]) -> TargetResult {
    let pick = |method: &str, cost: Cost| {
        cheapest_row(rows, method, flip, cost).map(|i| {
            let r = &rows[i];
            Pick { row: i, setting: r.setting(), seconds: r.seconds, rays: r.total_rays, flip: r.metrics.flip }
        })
    };
    let choices: Vec<Choice> = plan
        .methods
        .iter()
        .map(|m| {
            let name = m.method.name;
            Choice { method: name, by_seconds: pick(name, Cost::Seconds), by_rays: pick(name, Cost::Rays) }
        })
        .collect();
    // The winner under `cost` among every method, or among those that do not pick.
    let win = |cost: Cost, fixed: bool| {
        let entries: Vec<Entry> = choices
            .iter()
            .enumerate()
            .filter(|(i, _)| !(fixed && plan.methods[*i].method.picks))
            .filter_map(|(i, c)| {
                let p = if cost == Cost::Seconds { c.by_seconds.as_ref() } else { c.by_rays.as_ref() }?;
                Some(Entry { method: i, measure: rows[p.row].measure() })
            })
            .collect();
        winner(&entries, cost).map(|i| choices[i].method)
    };
    TargetResult {
        label: label.to_string(),
        flip,
        winner_seconds: win(Cost::Seconds, false),
        winner_rays: win(Cost::Rays, false),
        fixed_seconds: win(Cost::Seconds, true),
        fixed_rays: win(Cost::Rays, true),
        choices,
    }
}
