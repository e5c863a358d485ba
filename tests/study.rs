//! `wavetrace study`: the cheapest-setting search on a scene whose answer is known, a
//! `--quick` study of a small scene end to end, and the errors for bad manifests. Every
//! scene is tiny (`--quick`: 32×24), so the file runs in seconds in release.
#![cfg(all(feature = "plot", feature = "exr", feature = "flip"))]

mod support;

use std::path::{Path, PathBuf};
use std::process::Command;
use support::FloorScene;
use wavetrace::tools::study::{self, StudyOptions, StudyResult};

const BIN: &str = env!("CARGO_BIN_EXE_wavetrace");

/// Nothing in view but a constant background, and a quad light behind the camera facing
/// away: every camera ray misses, so every pixel of every setting is the background,
/// exactly (0.5, 0.25 and 0.75 are sums of powers of two, so any average of them is
/// exact), and every FLIP is 0. The light makes the adaptive-shadow methods run; it
/// casts no shadow ray, as nothing is hit.
const FLAT: &str = r#"
[render]
width = 8
height = 6
max_depth = 0
[camera]
position = [0, 0, 0]
look_at = [0, 0, -1]
fov_y = 40.0
[background]
color = [0.5, 0.25, 0.75]
[[lights]]
type = "quad"
corner = [-1, -1, 5]
edge_u = [2, 0, 0]
edge_v = [0, 2, 0]
radiance = [4, 4, 4]
"#;

/// A quad light over a floor with a sphere: edges and a penumbra.
fn tiny() -> String {
    FloorScene::tiny("[render]\nwidth = 16\nheight = 16\nmax_depth = 0\n").toml()
}

/// Writes `files` (name, text) into a fresh temporary folder.
fn folder(files: &[(&str, &str)]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().expect("tempdir");
    for (name, text) in files {
        std::fs::write(dir.path().join(name), text).expect("write");
    }
    dir
}

fn quick(manifest: &Path, out: &Path) -> StudyOptions {
    StudyOptions {
        manifest: manifest.to_path_buf(),
        out_dir: out.to_path_buf(),
        quick: true,
        threads: Some(2),
        ..StudyOptions::default()
    }
}

/// The pick of `method` for target `t` of the only scene, by rays and by seconds.
fn picks(r: &StudyResult, t: usize, method: &str) -> (String, u64, usize) {
    let c = r.scenes[0].targets[t].choices.iter().find(|c| c.method == method).expect("method in the study");
    let p = c.by_rays.as_ref().expect("a pick by rays");
    let s = c.by_seconds.as_ref().expect("a pick by seconds");
    (p.setting.clone(), p.rays, s.row)
}

#[test]
fn flat_scene_cheapest_settings_are_known() {
    let manifest = "[study]\nmethods = [\"uniform\", \"adaptive-aa\", \"adaptive-shadows\", \"early-stop\"]\n\
                    [[scene]]\nfile = \"flat.toml\"\n";
    let dir = folder(&[("flat.toml", FLAT), ("study.toml", manifest)]);
    let out = dir.path().join("out");
    let r = study::run(&quick(&dir.path().join("study.toml"), &out)).expect("study");
    let s = &r.scenes[0];
    assert_eq!(s.size, (32, 24), "--quick renders at 32×24");
    let n = 32 * 24u64;
    assert!(s.rows.iter().all(|row| row.metrics.flip == 0.0), "a flat scene has no error");
    // The quick grids: uniform 3×2, adaptive-aa 2×2×2, adaptive-shadows 3×2, early-stop 3.
    let count = |m: &str| s.rows.iter().filter(|row| row.method == m).count();
    assert_eq!([count("uniform"), count("adaptive-aa"), count("adaptive-shadows"), count("early-stop")], [6, 8, 6, 3]);
    assert_eq!(s.targets.len(), 2);
    for (t, target) in s.targets.iter().enumerate() {
        assert_eq!(target.flip, 0.0);
        // By hand: uniform traces spp camera rays per pixel and nothing else, so the
        // fewest is 1 spp; its two shadow settings tie and the first in grid order wins.
        assert_eq!(picks(&r, t, "uniform").0, "aa.samples=1 shadows.samples=1");
        assert_eq!(picks(&r, t, "uniform").1, n);
        // Adaptive AA: a centre per pixel and the shared corner grid, never refined, the
        // same for every setting: all eight tie, and the first wins.
        assert_eq!(picks(&r, t, "adaptive-aa").0, "aa.eps=0.1 aa.max_level=2 shadows.samples=1");
        assert_eq!(picks(&r, t, "adaptive-aa").1, n + 33 * 25);
        assert_eq!(picks(&r, t, "adaptive-shadows").0, "aa.samples=1 shadows.samples=4");
        assert_eq!(picks(&r, t, "adaptive-shadows").1, n);
        assert_eq!(picks(&r, t, "early-stop").0, "aa.samples=1 shadows.samples=16 shadows.tolerance=0.1");
        // Uniform and adaptive shadows tie in rays at n; the tie goes to uniform, listed first.
        assert_eq!(target.winner_rays, Some("uniform"));
        // By seconds: every row reaches a target of 0, so each pick is its method's
        // fastest render.
        for c in &target.choices {
            let fastest =
                s.rows.iter().filter(|row| row.method == c.method).map(|row| row.seconds).fold(f64::INFINITY, f64::min);
            let row = picks(&r, t, c.method).2;
            assert_eq!(s.rows[row].seconds, fastest, "{}", c.method);
        }
    }
    let f = &s.features;
    assert_eq!(
        (f.edge_density, f.penumbra_fraction, f.noise, f.noise_unevenness),
        (Some(0.0), Some(0.0), Some(0.0), Some(0.0))
    );
    assert_eq!((f.glossy_fraction, f.coc_spread, f.path), (0.0, 0.0, false));
    for name in ["study.csv", "study.json", "study.md", "flat_flip_vs_seconds.png"] {
        assert!(out.join(name).is_file(), "{name}");
    }
}

#[test]
fn quick_study_of_a_small_scene_writes_everything_and_reuses_its_reference() {
    let manifest =
        "[study]\nmethods = [\"uniform\", \"adaptive-aa\", \"dof-aware\", \"adaptive-shadows\", \"variance\", \"auto\"]\n\
                    [[scene]]\nfile = \"tiny.toml\"\nheld_out = true\n\
                    [[scene]]\nfile = \"tiny.toml\"\nname = \"tiny-b\"\nsets = [\"render.seed=7\"]\n";
    let dir = folder(&[("tiny.toml", &tiny()), ("study.toml", manifest)]);
    let out = dir.path().join("out");
    let opts = quick(&dir.path().join("study.toml"), &out);
    let r = study::run(&opts).expect("study");
    assert_eq!(r.scenes.len(), 2);
    for s in &r.scenes {
        assert!(s.reference.rendered);
        assert!(s.skipped.iter().any(|(m, why)| m == "dof-aware" && why.contains("aperture")), "{:?}", s.skipped);
        // This build may not know the variance sampler yet: then it is skipped with the
        // load error, never a failure.
        let variance_rows = s.rows.iter().any(|row| row.method == "variance");
        assert!(variance_rows || s.skipped.iter().any(|(m, _)| m == "variance"));
        assert!(s.features.edge_density.is_some_and(|e| e > 0.0 && e < 1.0), "{:?}", s.features);
        assert!(s.features.penumbra_fraction.is_some_and(|p| p > 0.0 && p < 1.0), "{:?}", s.features);
        // One run a setting (`quick` asks for 1), more while they add up to under 0.1 s.
        for row in &s.rows {
            let (n, sum) = (row.runs.len(), row.runs.iter().sum::<f64>());
            assert!(n == 5 || (n >= 1 && sum - row.runs[n - 1] < 0.1 && sum >= 0.1), "{:?}", row.runs);
        }
        for t in &s.targets {
            // Targets come from uniform's own renders, so uniform always reaches them.
            assert!(t.choices[0].by_seconds.is_some() && t.winner_seconds.is_some(), "{t:?}");
            // The map's winners leave auto, which picks among the others, out: the same
            // winner unless auto won, else the fastest of the rest.
            assert!(t.fixed_seconds.is_some() && t.fixed_seconds != Some("auto") && t.fixed_rays != Some("auto"));
            if t.winner_seconds != Some("auto") {
                assert_eq!(t.fixed_seconds, t.winner_seconds);
            }
            let rest = t
                .choices
                .iter()
                .filter(|c| c.method != "auto")
                .filter_map(|c| Some((c.method, c.by_seconds.as_ref()?)));
            let fastest = rest.min_by(|a, b| a.1.seconds.total_cmp(&b.1.seconds)).map(|c| c.1.seconds);
            let fixed =
                t.choices.iter().find(|c| Some(c.method) == t.fixed_seconds).and_then(|c| c.by_seconds.as_ref());
            assert_eq!(fixed.map(|p| p.seconds), fastest, "{t:?}");
            // Every method's pick within 1.5× of the fastest has five runs, and its
            // seconds are their median.
            let picks: Vec<_> = t.choices.iter().filter_map(|c| c.by_seconds.as_ref()).collect();
            let fastest = picks.iter().map(|p| p.seconds).fold(f64::INFINITY, f64::min);
            for p in picks.iter().filter(|p| p.seconds <= 1.5 * fastest) {
                let mut runs = s.rows[p.row].runs.clone();
                runs.sort_by(f64::total_cmp);
                assert!(runs.len() >= 5 && p.seconds == runs[runs.len() / 2], "{} {:?}", p.setting, runs);
            }
            for c in &t.choices {
                let Some(p) = &c.by_rays else { continue };
                assert!(p.flip <= t.flip);
                let cheaper = s
                    .rows
                    .iter()
                    .any(|row| row.method == c.method && row.metrics.flip <= t.flip && row.total_rays < p.rays);
                assert!(!cheaper, "{} has a cheaper setting for {}", c.method, t.label);
            }
        }
    }
    assert_eq!(r.map.rows.len(), 2);
    for (row, scene) in r.map.rows.iter().zip(&r.scenes) {
        let fixed: Vec<_> = scene.targets.iter().map(|t| (t.fixed_seconds, t.fixed_rays)).collect();
        assert_eq!(row.winners.iter().map(|w| (w.1, w.2)).collect::<Vec<_>>(), fixed);
    }
    assert_eq!(r.map.predictions.len(), 1, "one held-out scene");
    assert_eq!(r.map.predictions[0].nearest.as_deref(), Some("tiny-b"));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("study.json")).expect("json")).expect("parse");
    assert_eq!(json["scenes"][1]["name"], "tiny-b");
    let csv = std::fs::read_to_string(out.join("study.csv")).expect("csv");
    assert_eq!(csv.lines().count(), 1 + r.scenes.iter().map(|s| s.rows.len()).sum::<usize>());
    let md = std::fs::read_to_string(out.join("study.md")).expect("md");
    assert!(md.contains("## tiny-b") && md.contains("(held out)"), "{md}");
    assert!(out.join("tiny_flip_vs_seconds.png").is_file());
    // A second run finds both references in the cache.
    let again = study::run(&opts).expect("study again");
    assert!(again.scenes.iter().all(|s| !s.reference.rendered));
}

/// Runs the binary; returns (exit code, stderr).
fn wavetrace(args: &[&str]) -> (i32, String) {
    let out = Command::new(BIN).args(args).output().expect("run wavetrace");
    (out.status.code().unwrap_or(-1), String::from_utf8_lossy(&out.stderr).into_owned())
}

/// Without `--quick`, so the manifest's own grids and targets are read; each case fails
/// its check before the first render.
#[test]
fn bad_manifests_exit_2_before_any_output() {
    let cases: [(&str, &str); 5] = [
        ("[[scene]]\nfile = \"missing.toml\"\n", "no such file"),
        ("[study]\nmethods = [\"uniform\", \"magic\"]\n[[scene]]\nfile = \"tiny.toml\"\n", "unknown method `magic`"),
        (
            "[[scene]]\nfile = \"tiny.toml\"\n[scene.grids.uniform]\n\"render.aa.samples\" = [0]\n",
            "render.aa.samples=0",
        ),
        ("[[scene]]\nfile = \"tiny.toml\"\ntarget_spp = [3]\n", "target_spp 3"),
        ("[[scene]]\nfile = \"tiny.toml\"\n[[scene]]\nfile = \"tiny.toml\"\n", "used twice"),
    ];
    for (manifest, message) in cases {
        let dir = folder(&[("tiny.toml", &tiny()), ("study.toml", manifest)]);
        let out: PathBuf = dir.path().join("out");
        let (code, err) =
            wavetrace(&["study", &dir.path().join("study.toml").to_string_lossy(), "--out", &out.to_string_lossy()]);
        assert_eq!(code, 2, "{manifest}: {err}");
        assert!(err.contains(message), "{manifest}: expected `{message}` in: {err}");
        assert!(!out.exists(), "{manifest}: nothing may be written");
    }
    let dir = folder(&[]);
    let (code, err) = wavetrace(&[
        "study",
        &dir.path().join("none.toml").to_string_lossy(),
        "--out",
        &dir.path().join("o").to_string_lossy(),
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("cannot read"), "{err}");
}

#[test]
fn seeds_average_each_settings_errors() {
    // The same scene and reference twice: once with the seed as a grid value, once with
    // `seeds = 2` over the scene's own seed (5) and the next.
    let manifest = |seed_grid: &str| {
        format!(
            "[study]\nmethods = [\"uniform\"]\nreference_spp = 16\ntarget_spp = [1]\n\
             [[scene]]\nfile = \"tiny.toml\"\nsets = [\"render.seed=5\"]\n\
             [scene.grids.uniform]\n\"render.aa.samples\" = [1, 4]\n\"render.shadows.samples\" = [1]\n{seed_grid}"
        )
    };
    let (by_grid, by_seeds) = (manifest("\"render.seed\" = [5, 6]\n"), manifest(""));
    let dir = folder(&[("tiny.toml", &tiny()), ("grid.toml", &by_grid), ("seeds.toml", &by_seeds)]);
    let opts = |m: &str, out: &str, seeds: u32| StudyOptions {
        manifest: dir.path().join(m),
        out_dir: dir.path().join(out),
        threads: Some(2),
        seeds,
        ..StudyOptions::default()
    };
    let grid = study::run(&opts("grid.toml", "a", 1)).expect("study");
    let seeds = study::run(&opts("seeds.toml", "b", 2)).expect("study");
    assert_eq!(seeds.seeds, 2);
    let row = |r: &StudyResult, params: &[&str]| {
        let want: Vec<String> = params.iter().map(|p| p.to_string()).collect();
        let found = r.scenes[0]
            .rows
            .iter()
            .find(|row| row.params.iter().map(|(k, v)| format!("{k}={v}")).collect::<Vec<_>>() == want);
        found.cloned().unwrap_or_else(|| panic!("no row {want:?}"))
    };
    for spp in ["1", "4"] {
        let aa = format!("render.aa.samples={spp}");
        let at = |seed: &str| row(&grid, &[&aa, "render.shadows.samples=1", seed]);
        let (a, b) = (at("render.seed=5"), at("render.seed=6"));
        let mean = row(&seeds, &[&aa, "render.shadows.samples=1"]);
        assert!(a.metrics.flip > 0.0 && a.metrics.flip != b.metrics.flip, "{spp}: two seeds, two errors");
        assert_eq!(mean.metrics.flip, (a.metrics.flip + b.metrics.flip) / 2.0, "{spp} spp");
        assert_eq!(mean.metrics.rmse, (a.metrics.rmse + b.metrics.rmse) / 2.0, "{spp} spp");
        assert_eq!(mean.total_rays, (a.total_rays + b.total_rays) / 2);
        let shadow = |r: &study::Row| r.rays.iter().find(|(k, _)| k == "shadow").map(|&(_, n)| n).expect("shadow rays");
        assert_eq!(shadow(&mean), (shadow(&a) + shadow(&b)) / 2);
    }
    // Out of range: refused before any work.
    let e = study::run(&opts("seeds.toml", "c", 17)).expect_err("17 seeds");
    assert!(e.to_string().contains("--seeds must be 1 to 16"), "{e}");
    assert!(!dir.path().join("c").exists());
}
