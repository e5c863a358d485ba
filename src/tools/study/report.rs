//! What a study writes: `study.csv` (every render), `study.json` (everything),
//! `study.md` (the tables) and one FLIP-against-seconds plot per scene.

use super::map::Map;
use super::*;
use crate::tools::sweep::{csv_field, versioned_json};

/// Writes every file of the study.
pub(super) fn write(result: &StudyResult) -> Result<()> {
    write_file(&result.files, CSV_FILE, &result.csv())?;
    write_file(&result.files, JSON_FILE, &(result.json()? + "\n"))?;
    write_file(&result.files, MD_FILE, &result.markdown())?;
    #[cfg(feature = "plot")]
    for s in &result.scenes {
        let path = result.files.iter().find(|f| f.ends_with(format!("{}{PLOT_SUFFIX}", s.name)));
        if let Some(path) = path {
            plot(s, path)?;
        }
    }
    Ok(())
}

/// A number for the tables: three significant digits, `–` for NaN.
fn num(v: f64) -> String {
    if v.is_nan() {
        "–".into()
    } else if v == 0.0 {
        "0".into()
    } else if (1e-3..1e4).contains(&v.abs()) {
        let digits = (2 - v.abs().log10().floor() as i32).clamp(0, 6) as usize;
        format!("{v:.digits$}")
    } else {
        format!("{v:.2e}")
    }
}

/// A ray count as `1.23M`.
fn rays(n: u64) -> String {
    match n {
        n if n >= 1_000_000 => format!("{:.2}M", n as f64 / 1e6),
        n if n >= 1_000 => format!("{:.1}k", n as f64 / 1e3),
        n => n.to_string(),
    }
}

impl StudyResult {
    /// The CSV: one row per render: scene, method, setting, rays, seconds, errors and the
    /// adaptive counters.
    pub fn csv(&self) -> String {
        let mut out = String::from(
            "scene,held_out,method,setting,total_rays,seconds,rmse,rel_mse,psnr,flip,worst10_share,\
             aa_pixels,aa_refined_pixels,shadow_points,penumbra_points,shadow_uniform_fallback,\
             penumbra_stopped,pareto_seconds,pareto_rays\n",
        );
        for s in &self.scenes {
            for r in &s.rows {
                let (m, c) = (&r.metrics, &r.counters);
                let fields: Vec<String> = vec![
                    csv_field(&s.name),
                    s.held_out.to_string(),
                    r.method.into(),
                    csv_field(&r.setting()),
                    r.total_rays.to_string(),
                    r.seconds.to_string(),
                    m.rmse.to_string(),
                    m.rel_mse.to_string(),
                    m.psnr.to_string(),
                    m.flip.to_string(),
                    r.worst10_share.to_string(),
                    c.aa_pixels.to_string(),
                    c.aa_refined_pixels.to_string(),
                    c.shadow_points.to_string(),
                    c.penumbra_points.to_string(),
                    c.shadow_uniform_fallback.to_string(),
                    c.penumbra_stopped.to_string(),
                    r.pareto_seconds.to_string(),
                    r.pareto_rays.to_string(),
                ];
                out += &(fields.join(",") + "\n");
            }
        }
        out
    }

    /// The text of `study.json`: `version`, then the fields of [`StudyResult`]. NaN and
    /// infinite numbers become `null`.
    pub fn json(&self) -> Result<String> {
        versioned_json(JSON_VERSION, self)
    }

    /// The markdown report: how it was made, the map, the features, then per scene the
    /// cheapest setting of each method for each target.
    pub fn markdown(&self) -> String {
        let mut out = String::from("# Where adaptive sampling pays\n\n");
        out += &format!(
            "Made by `wavetrace study {}{}{}` in {:.0} s ({} thread(s) per render, median of {} run(s) per setting, of up to {} where they take under {} s, and of {} interleaved for each method's cheapest setting within {}× of a target's fastest). \
             Each cell is a method's cheapest setting whose mean FLIP{} against the scene's reference is at most the \
             target: by seconds (ties: lower FLIP, then grid order), with its rays; **bold** is the winner in seconds \
             (ties go to the method listed first), † the winner in rays where another. `–`: no setting reaches it.\n\n",
            self.manifest.display(),
            if self.quick { " --quick" } else { "" },
            if self.seeds > 1 { format!(" --seeds {}", self.seeds) } else { String::new() },
            self.seconds,
            self.threads,
            self.runs,
            super::measure::SHORT_RUNS,
            super::measure::SHORT,
            super::measure::CONFIRM_RUNS,
            super::measure::CONTEST,
            if self.seeds > 1 { format!(" (the mean over {} seeds, as are its rays and seconds)", self.seeds) } else { String::new() },
        );
        out += &map_tables(&self.map);
        out += &ratio_table(&self.scenes);
        out += &features_table(&self.scenes);
        for s in &self.scenes {
            out += &scene_section(s);
        }
        out
    }
}

/// Seconds of a method's cheapest setting for a target, if it reaches it.
fn seconds_of(t: &TargetResult, method: &str) -> Option<f64> {
    t.choices.iter().find(|c| c.method == method).and_then(|c| c.by_seconds.as_ref()).map(|p| p.seconds)
}

/// The two ratios the study's targets are stated in, per scene and target: variance
/// against uniform, and auto against the best fixed method (every other method).
fn ratio_table(scenes: &[SceneResult]) -> String {
    let mut out = String::from(
        "## Ratios: variance ÷ uniform, auto ÷ best fixed method\n\nSeconds of each method's cheapest setting \
         that reaches the target, divided; `–` where either reaches none.\n\n\
         | scene | target | variance ÷ uniform | auto ÷ best fixed (which) |\n|---|---|---|---|\n",
    );
    let ratio = |a: Option<f64>, b: Option<f64>| match (a, b) {
        (Some(a), Some(b)) if b > 0.0 => num(a / b),
        _ => "–".into(),
    };
    for s in scenes {
        for t in &s.targets {
            let best = t
                .choices
                .iter()
                .filter(|c| c.method != "auto")
                .filter_map(|c| c.by_seconds.as_ref().map(|p| (p.seconds, c.method)))
                .min_by(|a, b| a.0.total_cmp(&b.0));
            let auto = ratio(seconds_of(t, "auto"), best.map(|b| b.0));
            let which = best.map_or(String::new(), |b| format!(" ({})", b.1));
            let variance = ratio(seconds_of(t, "variance"), seconds_of(t, "uniform"));
            out += &format!("| {} | {} | {variance} | {auto}{which} |\n", s.name, t.label);
        }
    }
    out + "\n"
}

/// The map: per scene, its features and winners; per method, where it wins; held-out
/// predictions.
fn map_tables(map: &Map) -> String {
    let mut out = String::from(
        "## Map: the winner per target against the features\n\nThe winning method among those that do not pick \
         (auto, which picks among them from its pilot, is left out: its standing is the ratios table's), in seconds \
         († in rays where another).\n\n",
    );
    let targets = map.rows.iter().map(|r| r.winners.len()).max().unwrap_or(0);
    out += &format!(
        "| scene | {} | {} |\n",
        map.features.join(" | "),
        (1..=targets).map(|i| format!("target {i}")).collect::<Vec<_>>().join(" | ")
    );
    out += &format!("|{}\n", "---|".repeat(1 + map.features.len() + targets));
    for r in &map.rows {
        let name = if r.held_out { format!("{} (held out)", r.scene) } else { r.scene.clone() };
        let feats: Vec<String> = r.features.iter().map(|&v| num(v)).collect();
        let wins: Vec<String> = (0..targets)
            .map(|i| match r.winners.get(i) {
                Some((_, s, ra)) if s == ra => s.unwrap_or("–").to_string(),
                Some((_, s, ra)) => format!("{} († {})", s.unwrap_or("–"), ra.unwrap_or("–")),
                None => String::new(),
            })
            .collect();
        out += &format!("| {name} | {} | {} |\n", feats.join(" | "), wins.join(" | "));
    }
    out += "\nWhere each method wins (fitted scenes; feature ranges over the scenes it wins in seconds):\n\n";
    out += &format!(
        "| method | wins (s) | wins (rays) | {} |\n|{}\n",
        map.features.join(" | "),
        "---|".repeat(3 + map.features.len())
    );
    for w in &map.wins {
        let ranges: Vec<String> = w
            .ranges
            .iter()
            .map(|r| {
                r.map_or("–".into(), |(lo, hi)| if lo == hi { num(lo) } else { format!("{}–{}", num(lo), num(hi)) })
            })
            .collect();
        out += &format!("| {} | {} | {} | {} |\n", w.method, w.wins_seconds, w.wins_rays, ranges.join(" | "));
    }
    if !map.predictions.is_empty() {
        out += &format!(
            "\nHeld-out scenes, winners (seconds) predicted by the nearest fitted scene in feature space; near: the \
             predicted method takes at most {}× the winner's seconds:\n\n",
            super::map::NEAR
        );
        out += "| scene | nearest | predicted → actual per target | right | near |\n|---|---|---|---|---|\n";
        for p in &map.predictions {
            let t: Vec<String> =
                p.targets.iter().map(|(pr, ac)| format!("{} → {}", pr.unwrap_or("–"), ac.unwrap_or("–"))).collect();
            out += &format!(
                "| {} | {} | {} | {}/{} | {}/{} |\n",
                p.scene,
                p.nearest.as_deref().unwrap_or("–"),
                t.join("; "),
                p.hits,
                p.targets.len(),
                p.near,
                p.targets.len()
            );
        }
    }
    out + "\n"
}

/// The features of every scene.
fn features_table(scenes: &[SceneResult]) -> String {
    let mut out = String::from(
        "## Scene features\n\nedge density: pixels adaptive AA's corner test refines (smallest eps); penumbra: \
         shadow-tested points sent to the penumbra queue; CoC spread: pixels blurred over more than 1 px (mean radius \
         in px); glossy: pixels whose first hit is rough; noise: relative MSE of uniform at the first target's spp; \
         unevenness: its squared error's share in the worst 10% of pixels.\n\n",
    );
    out +=
        "| scene | size | edge density | penumbra | CoC spread | CoC mean px | glossy | noise | unevenness | path |\n";
    out += "|---|---|---|---|---|---|---|---|---|---|\n";
    let opt = |v: Option<f64>| v.map_or("–".into(), num);
    for s in scenes {
        let f = &s.features;
        out += &format!(
            "| {} | {}×{} | {} | {} | {} | {} | {} | {} | {} | {} |\n",
            s.name,
            s.size.0,
            s.size.1,
            opt(f.edge_density),
            opt(f.penumbra_fraction),
            num(f.coc_spread),
            num(f.coc_mean_px),
            num(f.glossy_fraction),
            opt(f.noise),
            opt(f.noise_unevenness),
            if f.path { "yes" } else { "no" }
        );
    }
    out + "\n"
}

/// One scene's table: a row per target, a column per method.
fn scene_section(s: &SceneResult) -> String {
    let mut out = format!("## {}\n\n`{}`", s.name, s.file.display());
    if !s.sets.is_empty() {
        out += &format!(" with `{}`", s.sets.join(" "));
    }
    let r = &s.reference;
    out += &format!(
        "; reference: {} ({}), {} renders.\n\n",
        r.overrides.join(" "),
        if r.rendered { format!("rendered in {:.1} s", r.seconds.unwrap_or(0.0)) } else { "cached".into() },
        s.rows.len()
    );
    let methods: Vec<&str> =
        s.targets.first().map(|t| t.choices.iter().map(|c| c.method).collect()).unwrap_or_default();
    out += &format!("| target FLIP | {} |\n|{}\n", methods.join(" | "), "---|".repeat(1 + methods.len()));
    for t in &s.targets {
        let cells: Vec<String> = t
            .choices
            .iter()
            .map(|c| match &c.by_seconds {
                None => "–".into(),
                Some(p) => {
                    let text =
                        format!("{} — {} s, {} rays (FLIP {})", p.setting, num(p.seconds), rays(p.rays), num(p.flip));
                    let dagger =
                        if t.winner_rays == Some(c.method) && t.winner_seconds != Some(c.method) { " †" } else { "" };
                    if t.winner_seconds == Some(c.method) {
                        format!("**{text}**{dagger}")
                    } else {
                        format!("{text}{dagger}")
                    }
                }
            })
            .collect();
        out += &format!("| {} ({}) | {} |\n", num(t.flip), t.label, cells.join(" | "));
    }
    for (m, why) in &s.skipped {
        out += &format!("\n- {m}: skipped: {why}");
    }
    for n in &s.notes {
        out += &format!("\n- {n}");
    }
    out + "\n\n"
}

/// FLIP against seconds of every render of the scene, one series per method, log-log.
#[cfg(feature = "plot")]
fn plot(s: &SceneResult, path: &std::path::Path) -> Result<()> {
    use crate::tools::plot::{scatter_plot, Axis, Series};
    // A series for every method up to the last one rendered, empty where a method has no
    // rows: the plot gives colours by position, so each method keeps its colour in every
    // scene's plot (an empty series has no legend entry).
    let last = super::methods::METHODS.iter().rposition(|m| s.rows.iter().any(|r| r.method == m.name)).unwrap_or(0);
    let series: Vec<Series> = super::methods::METHODS[..=last]
        .iter()
        .map(|m| m.name)
        .map(|m| {
            let rows: Vec<&Row> = s.rows.iter().filter(|r| r.method == m).collect();
            Series {
                name: m.into(),
                points: rows.iter().map(|r| (r.seconds, r.metrics.flip)).collect(),
                pareto: rows.iter().map(|r| r.pareto_seconds).collect(),
                labels: rows.iter().map(|r| r.setting()).collect(),
            }
        })
        .collect();
    let title = format!("{}: mean FLIP vs seconds (filled and joined: each method's Pareto front)", s.name);
    let x = Axis { label: "render seconds (wall clock, median)", log: true };
    let y = Axis { label: "mean FLIP against the reference", log: true };
    scatter_plot(path, &title, x, y, &series)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_read_well() {
        assert_eq!(num(0.012345), "0.0123");
        assert_eq!(num(12.345), "12.3");
        assert_eq!(num(0.0), "0");
        assert_eq!(num(f64::NAN), "–");
        assert_eq!(num(1.5e-5), "1.50e-5");
        assert_eq!(rays(1_234_567), "1.23M");
        assert_eq!(rays(999), "999");
    }
}
