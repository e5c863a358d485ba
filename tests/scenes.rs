//! Every scene in scenes/ (and its subfolders, such as scenes/paper/) loads and renders
//! (tiny), and each pays only for what it uses.

mod support;

use std::path::Path;
use wavetrace::scene::{load, SceneSource};
use wavetrace::stats::Stage;
use wavetrace::{render, RenderOptions};

fn tiny(name: &str) -> wavetrace::RenderOutput {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name);
    let src = SceneSource::from_file(&path).expect("readable");
    let sets: Vec<String> = ["render.width=12", "render.height=9", "render.aa.samples=2", "render.shadows.samples=2"]
        .map(String::from)
        .to_vec();
    let scene = load(&src, &sets).unwrap_or_else(|e| panic!("{name}: {e}"));
    render(&scene, &RenderOptions { threads: Some(2), ..Default::default() }).expect("render")
}

/// The .toml files under `dir` (relative to scenes/), subfolders included.
fn scene_files(dir: &Path, out: &mut Vec<String>) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    for e in std::fs::read_dir(root.join(dir)).unwrap() {
        let path = dir.join(e.unwrap().file_name());
        if root.join(&path).is_dir() {
            scene_files(&path, out);
        } else if path.extension().is_some_and(|x| x == "toml") {
            out.push(path.to_string_lossy().into_owned());
        }
    }
}

#[test]
fn every_scene_renders_something() {
    let mut names = Vec::new();
    scene_files(Path::new(""), &mut names);
    names.sort();
    assert!(names.len() >= 5, "{names:?}");
    assert!(names.iter().filter(|n| n.starts_with("paper")).count() >= 7, "the paper's scenes: {names:?}");
    for name in names {
        let out = tiny(&name);
        assert!(out.image.pixels.iter().all(|p| p.is_finite()), "{name}: non-finite pixel");
        assert_eq!(out.stats.nonfinite, 0, "{name}: the film dropped non-finite samples");
        assert!(out.image.pixels.iter().any(|p| p.max_element() > 0.0), "{name}: black image");
        // Counters from the stages agree with the counts by kind.
        let s = &out.stats;
        let traced = s.camera_rays + s.aa_corner_rays + s.aa_refine_rays + s.secondary_rays;
        assert_eq!(s.stage(Stage::Intersect).rays_in, traced, "{name}");
        assert_eq!(s.stage(Stage::Shadow).rays_in, s.shadow_rays, "{name}");
        assert_eq!(s.stage(Stage::ShadowCorner).rays_in, s.shadow_points, "{name}");
        assert_eq!(s.stage(Stage::Penumbra).rays_in, s.penumbra_points, "{name}");
    }
}

#[test]
fn scenes_pay_only_for_what_they_use() {
    // No mirrors or dielectrics: nothing enters the scatter stage.
    let pen = tiny("penumbra.toml");
    assert_eq!(pen.stats.secondary_rays, 0);
    assert_eq!(pen.stats.stage(wavetrace::stats::Stage::Scatter).rays_in, 0);
    // Pinhole camera: exactly aa.samples camera rays per pixel.
    assert_eq!(pen.stats.camera_rays, 12 * 9 * 2);
    // The DOF scene opens the aperture: 16 lens samples per AA sample.
    let dof = tiny("dof.toml");
    assert_eq!(dof.stats.camera_rays, 12 * 9 * 2 * 16);
    // The default scene has both a mirror and glass.
    let def = tiny("default.toml");
    assert!(def.stats.secondary_rays > 0);
}

#[test]
fn embedded_default_is_the_file_in_scenes() {
    let file = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/default.toml")).unwrap();
    assert_eq!(file, wavetrace::DEFAULT_SCENE);
    let _ = SceneSource::default_scene();
}

#[test]
fn adaptive_shadows_never_cast_more_rays_than_uniform_on_the_project_scenes() {
    // Each scene with its own samples and probe set, shadows adaptive: probes plus
    // penumbra rays never exceed what uniform sampling casts for the same points (a light
    // whose probes would cost over 0.8 of its samples is sampled uniformly and counts in neither).
    let mut names = Vec::new();
    scene_files(Path::new(""), &mut names);
    names.sort();
    let mut probed = 0;
    for name in names {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(&name);
        let src = SceneSource::from_file(&path).expect("readable");
        let sets = ["render.width=40", "render.height=30", "render.shadows.mode=adaptive"].map(String::from);
        let scene = load(&src, &sets).unwrap_or_else(|e| panic!("{name}: {e}"));
        let s = render(&scene, &RenderOptions { threads: Some(2), ..Default::default() }).expect("render").stats;
        let cast = s.shadow_corner_rays + s.penumbra_rays;
        assert!(cast <= s.shadow_uniform_rays, "{name}: {cast} adaptive rays vs {} uniform", s.shadow_uniform_rays);
        probed += (s.shadow_points > 0) as usize;
    }
    assert!(probed >= 5, "only {probed} scenes probe a light");
}
