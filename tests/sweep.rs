//! `wavetrace::sweep`: the files a sweep writes, the reference cache, parameter parsing
//! and the errors for bad input. Every scene here is 16×16, so the file runs in well
//! under a second in release.
#![cfg(all(feature = "plot", feature = "exr"))]

mod support;

use std::path::{Path, PathBuf};
use support::FloorScene;
use wavetrace::tools::sweep::{self, parse_param, Reference, SweepOptions};
use wavetrace::Error;

/// A quad light over a floor with a sphere: soft shadows, and edges for AA.
fn tiny() -> String {
    FloorScene::tiny(
        "[render]\nwidth = 16\nheight = 16\nmax_depth = 0\n[render.aa]\nsamples = 2\n[render.shadows]\nsamples = 4\n",
    )
    .toml()
}

/// Writes the tiny scene into a fresh temporary folder.
fn scene_dir() -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().expect("tempdir");
    let scene = dir.path().join("tiny.toml");
    std::fs::write(&scene, tiny()).expect("write scene");
    (dir, scene)
}

fn opts(scene: &Path, out: &Path, params: &[&str]) -> SweepOptions {
    SweepOptions {
        scene: Some(scene.to_path_buf()),
        params: params.iter().map(|p| parse_param(p).expect("param")).collect(),
        sets: Vec::new(),
        reference: Reference::Spp(64),
        out_dir: out.to_path_buf(),
        threads: Some(2),
        progress: false,
    }
}

fn input_error(r: wavetrace::Result<sweep::SweepResult>) -> String {
    match r {
        Err(Error::Input(msg)) => msg,
        Err(e) => panic!("expected an input error, got {e}"),
        Ok(_) => panic!("expected an input error, got success"),
    }
}

#[test]
fn sweep_writes_rows_json_and_plots_and_reuses_the_reference() {
    let (dir, scene) = scene_dir();
    let out = dir.path().join("out");
    let o = opts(&scene, &out, &["render.shadows.mode=uniform,adaptive", "render.shadows.samples=4,16"]);
    let first = sweep::run(&o).expect("sweep");
    assert!(first.reference.rendered);
    assert_eq!(first.points.len(), 4);
    // The reference converges shadows only: AA is not swept, so the points share its camera rays.
    assert_eq!(first.reference.overrides, ["render.shadows.mode=uniform", "render.shadows.samples=64"]);

    let csv = std::fs::read_to_string(out.join("sweep.csv")).expect("csv");
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 5, "header + one row per point:\n{csv}");
    let header: Vec<&str> = lines[0].split(',').collect();
    assert_eq!(&header[..4], ["render.shadows.mode", "render.shadows.samples", "mode", "total_rays"]);
    assert_eq!(&header[header.len() - 5..], ["seconds", "rmse", "rel_mse", "psnr", "flip"]);
    assert!(header.contains(&"rays_penumbra") && header.contains(&"rays_shadow"));
    for l in &lines[1..] {
        assert_eq!(l.split(',').count(), header.len(), "{l}");
    }
    assert!(lines[1].starts_with("uniform,4,uniform,"), "{}", lines[1]);
    assert!(lines[3].starts_with("adaptive,4,adaptive,"), "{}", lines[3]);

    let text = std::fs::read_to_string(out.join("sweep.json")).expect("json");
    let json: serde_json::Value = serde_json::from_str(&text).expect("parses");
    assert_eq!(json["version"], 1);
    // Params keep the swept order (serde_json's Value would sort them; the file must not).
    let in_points = &text[text.find("\"points\"").unwrap()..];
    assert!(in_points.find("\"render.shadows.mode\"").unwrap() < in_points.find("\"render.shadows.samples\"").unwrap());
    assert!(in_points.find("\"camera\"").unwrap() < in_points.find("\"aa_corner\"").unwrap());
    let points = json["points"].as_array().expect("points");
    assert_eq!(points.len(), 4);
    assert_eq!(json["reference"]["spp"], 64);
    assert_eq!(json["reference"]["rendered"], true);
    assert_eq!(points[2]["params"]["render.shadows.mode"], "adaptive");
    assert_eq!(points[2]["mode"], "adaptive");
    assert!(points[0]["rays"]["shadow"].as_u64().unwrap() > 0);
    // Adaptive with 4 samples samples the light as uniform mode (9 probes would cost more);
    // with 16 it probes, and casts no uniform shadow rays.
    assert_eq!(points[2]["rays"]["shadow"], points[0]["rays"]["shadow"]);
    assert_eq!(points[3]["rays"]["shadow"], 0);
    for p in points {
        let sum: u64 = p["rays"].as_object().unwrap().values().map(|v| v.as_u64().unwrap()).sum();
        assert_eq!(p["total_rays"].as_u64(), Some(sum));
        assert!(p["rmse"].as_f64().unwrap() > 0.0);
    }
    // More shadow samples, less error (uniform mode, same camera rays as the reference).
    assert!(first.points[1].metrics.rmse < first.points[0].metrics.rmse);

    for plot in ["error_vs_rays.png", "error_vs_seconds.png"] {
        let img = image::open(out.join(plot)).unwrap_or_else(|e| panic!("{plot}: {e}"));
        assert_eq!((img.width(), img.height()), (wavetrace::tools::plot::WIDTH, wavetrace::tools::plot::HEIGHT));
        // Something was drawn: not a blank page.
        let rgb = img.to_rgb8();
        assert!(rgb.pixels().filter(|p| p.0 != [255, 255, 255]).count() > 1000, "{plot} is blank");
    }

    let ref_path = first.reference.path.clone();
    assert!(ref_path.starts_with(&out) && ref_path.is_file());
    let mtime = std::fs::metadata(&ref_path).unwrap().modified().unwrap();
    let second = sweep::run(&o).expect("second sweep");
    assert!(!second.reference.rendered, "the cached reference is reused");
    assert_eq!(second.reference.path, ref_path);
    assert_eq!(std::fs::metadata(&ref_path).unwrap().modified().unwrap(), mtime);
    let rmse = |r: &sweep::SweepResult| r.points.iter().map(|p| p.metrics.rmse).collect::<Vec<_>>();
    assert_eq!(rmse(&first), rmse(&second));

    // Another --set is another reference.
    let mut o3 = o.clone();
    o3.sets.push("render.seed=7".into());
    o3.params.truncate(1);
    let third = sweep::run(&o3).expect("third sweep");
    assert!(third.reference.rendered);
    assert_ne!(third.reference.path, ref_path);
}

#[test]
fn aa_sweeps_converge_the_pixel() {
    let (dir, scene) = scene_dir();
    let out = dir.path().join("aa");
    let mut o = opts(&scene, &out, &["render.aa.mode=uniform,adaptive", "render.aa.samples=1,8"]);
    o.reference = Reference::Spp(32);
    let r = sweep::run(&o).expect("sweep");
    assert_eq!(
        r.reference.overrides,
        ["render.aa.mode=uniform", "render.aa.samples=32", "render.shadows.mode=uniform", "render.shadows.samples=4"]
    );
    let uniform: Vec<f64> = r.points.iter().filter(|p| p.mode.label() == "uniform").map(|p| p.metrics.rmse).collect();
    assert!(uniform[1] < uniform[0], "8 spp beats 1 spp: {uniform:?}");
}

#[test]
fn parse_param_splits_values() {
    assert_eq!(
        parse_param("render.aa.eps=0.001,0.01").unwrap(),
        ("render.aa.eps".into(), vec!["0.001".into(), "0.01".into()])
    );
    assert_eq!(
        parse_param("camera.position=[0,1,5],[0,2,5]").unwrap(),
        ("camera.position".into(), vec!["[0,1,5]".into(), "[0,2,5]".into()])
    );
    assert_eq!(parse_param("render.aa.mode=adaptive").unwrap().1, ["adaptive"]);
    assert_eq!(parse_param("k = \"a,b\" , 'c'").unwrap().1, ["\"a,b\"", "'c'"]);
    for bad in ["render.aa.eps", "=1", "k=", "k=1,", "k=[1,2", "k=1]", "k=\"x"] {
        assert!(matches!(parse_param(bad), Err(Error::Input(_))), "{bad}");
    }
}

#[test]
fn a_bad_value_names_the_param_and_renders_nothing() {
    let (dir, scene) = scene_dir();
    let out = dir.path().join("bad");
    let msg = input_error(sweep::run(&opts(&scene, &out, &["render.aa.samples=1,2", "render.width=16,0"])));
    assert!(msg.contains("render.width=0"), "{msg}");
    assert!(!out.exists(), "validation comes before any output");

    let msg = input_error(sweep::run(&opts(&scene, &out, &["render.aa.mode=uniform,bogus"])));
    assert!(msg.contains("render.aa.mode=bogus"), "{msg}");

    // Values valid alone but not together name the point.
    let msg = input_error(sweep::run(&opts(
        &scene,
        &out,
        &["render.aa.mode=adaptive", "render.aa.min_level=5", "render.aa.max_level=4"],
    )));
    assert!(msg.contains("render.aa.min_level=5") && msg.contains("render.aa.max_level=4"), "{msg}");

    let mut o = opts(&scene, &out, &["render.aa.samples=1"]);
    o.params.push(o.params[0].clone());
    assert!(input_error(sweep::run(&o)).contains("twice"));
}

#[test]
fn reference_problems_are_input_errors() {
    let (dir, scene) = scene_dir();
    let out = dir.path().join("ref");
    let mut o = opts(&scene, &out, &["render.aa.samples=1,2"]);

    o.reference = Reference::File(dir.path().join("missing.exr"));
    assert!(input_error(sweep::run(&o)).contains("missing.exr"));

    let small = dir.path().join("small.exr");
    let img = wavetrace::film::Image { width: 8, height: 8, pixels: vec![glam::Vec3::ONE; 64] };
    wavetrace::tools::output::write_image(&small, &img).unwrap();
    o.reference = Reference::File(small);
    let msg = input_error(sweep::run(&o));
    assert!(msg.contains("8×8") && msg.contains("16×16"), "{msg}");

    // A param that changes the size cannot be compared with one reference.
    let mut o = opts(&scene, &out, &["render.width=16,8"]);
    let msg = input_error(sweep::run(&o));
    assert!(msg.contains("render.width=8"), "{msg}");

    o.params.clear();
    o.reference = Reference::Spp(0);
    assert!(matches!(sweep::run(&o), Err(Error::Input(_))));

    o.reference = Reference::Spp(4);
    o.out_dir = dir.path().join("no").join("such");
    let msg = input_error(sweep::run(&o));
    assert!(msg.contains("does not exist"), "{msg}");
}

#[test]
fn an_exact_match_has_zero_error_and_null_psnr() {
    let (dir, scene) = scene_dir();
    // The reference is the scene's own render, so the point equal to it has no error.
    let src = wavetrace::scene::SceneSource::from_file(&scene).unwrap();
    let img = wavetrace::render(
        &wavetrace::scene::load(&src, &[]).unwrap(),
        &wavetrace::RenderOptions { threads: Some(1), ..Default::default() },
    )
    .unwrap()
    .image;
    let ref_path = dir.path().join("same.exr");
    wavetrace::tools::output::write_image(&ref_path, &img).unwrap();
    let out = dir.path().join("exact");
    let mut o = opts(&scene, &out, &["render.aa.samples=2,1"]);
    o.reference = Reference::File(ref_path.clone());
    let r = sweep::run(&o).expect("sweep");
    assert!(!r.reference.rendered && r.reference.spp.is_none() && r.reference.path == ref_path);
    assert_eq!(r.points[0].metrics.rmse, 0.0);
    assert!(r.points[1].metrics.rmse > 0.0);
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("sweep.json")).unwrap()).unwrap();
    assert!(json["points"][0]["psnr"].is_null());
    let csv = std::fs::read_to_string(out.join("sweep.csv")).unwrap();
    assert!(csv.lines().nth(1).unwrap().contains(",inf,"), "{csv}");
    // No cache file when the reference is given.
    let cached = std::fs::read_dir(&out)
        .unwrap()
        .filter(|e| e.as_ref().unwrap().file_name().to_string_lossy().starts_with("reference-"));
    assert_eq!(cached.count(), 0);
}
