//! The same scene and seed give the same bits whatever the thread count.

mod support;

use wavetrace::scene::{load, SceneSource};
use wavetrace::tools::output::to_srgb8;
use wavetrace::{render, RenderOptions};

fn render_default(threads: usize, sets: &[String]) -> wavetrace::RenderOutput {
    let scene = load(&SceneSource::default_scene(), sets).expect("default scene loads");
    render(&scene, &RenderOptions { threads: Some(threads), ..Default::default() }).expect("render")
}

#[test]
fn default_scene_is_bit_identical_on_one_and_two_threads() {
    let a = render_default(1, &[]);
    let b = render_default(2, &[]);
    let bits = |o: &wavetrace::RenderOutput| {
        o.image.pixels.iter().flat_map(|p| p.to_array()).map(f32::to_bits).collect::<Vec<_>>()
    };
    assert!(bits(&a) == bits(&b), "linear radiance differs between 1 and 2 threads");
    assert_eq!(to_srgb8(&a.image), to_srgb8(&b.image));
    assert_eq!(a.stats.total_rays(), b.stats.total_rays());
    assert_eq!(a.per_thread.len(), 1);
    assert_eq!(b.per_thread.len(), 2);
}

#[test]
fn the_seed_changes_the_noise() {
    let small = |seed: u32| {
        let sets = vec!["render.width=32".into(), "render.height=24".into(), format!("render.seed={seed}")];
        render_default(2, &sets).image
    };
    assert_eq!(small(3), small(3));
    assert_ne!(small(3), small(4));
}

/// Leaving the heat out changes no pixel and no counter, whole or cropped, with uniform
/// and adaptive AA (whose shared corners' heat is split among pixels).
#[test]
fn leaving_the_heat_out_changes_nothing_else() {
    let scene = |mode: &str| {
        let sets = ["render.width=40", "render.height=30", &format!("render.aa.mode={mode}")];
        load(&SceneSource::default_scene(), &sets.map(String::from)).expect("default scene loads")
    };
    for mode in ["uniform", "adaptive"] {
        let scene = scene(mode);
        for crop in [None, Some(wavetrace::film::Tile { x0: 5, y0: 3, x1: 29, y1: 21 })] {
            let with = RenderOptions { threads: Some(2), crop, ..Default::default() };
            let (a, b) = (render(&scene, &with), render(&scene, &RenderOptions { no_heat: true, ..with.clone() }));
            let (a, b) = (a.expect("render"), b.expect("render"));
            assert_eq!(a.image, b.image, "{mode} {crop:?}");
            assert_eq!(a.stats.total_rays(), b.stats.total_rays(), "{mode} {crop:?}");
            assert_eq!(a.heat.rays.len(), a.image.pixels.len(), "{mode} {crop:?}");
            assert!(a.heat.rays.iter().all(|&r| r > 0.0), "{mode} {crop:?}: every pixel has rays");
            assert!(b.heat.rays.is_empty() && b.heat.level.is_empty(), "{mode} {crop:?}: no heat");
        }
    }
}
