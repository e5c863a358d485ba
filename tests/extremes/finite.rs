//! Every pixel finite, for every scene file, in uniform and adaptive modes.

use super::{assert_finite, render_scene};
use std::path::Path;
use wavetrace::scene::{load, SceneSource};

#[test]
fn every_scene_file_renders_finite_pixels_in_every_mode() {
    let scenes = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut names: Vec<_> = std::fs::read_dir(&scenes)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    names.sort();
    assert!(names.len() >= 5);
    let tiny = ["render.width=16", "render.height=12", "render.aa.samples=2", "render.shadows.samples=2"];
    for path in names {
        let src = SceneSource::from_file(&path).unwrap();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        // Exact: every pixel finite and non-negative, in uniform and adaptive AA and shadows.
        for extra in [
            vec![],
            vec![
                "render.aa.mode=adaptive",
                "render.aa.max_level=3",
                "render.aa.min_level=2",
                "render.shadows.mode=adaptive",
            ],
        ] {
            let sets: Vec<String> = tiny.iter().chain(extra.iter()).map(|s| s.to_string()).collect();
            let scene = load(&src, &sets).unwrap_or_else(|e| panic!("{name}: {e}"));
            let out = render_scene(&scene);
            assert_finite(&out, &format!("{name} {extra:?}"));
        }
    }
}
