//! Shared fixtures for the integration tests.
#![allow(dead_code)]

use glam::Vec3;
use std::path::Path;
use wavetrace::film::Image;
use wavetrace::scene::{load, SceneSource};
use wavetrace::{render, RenderOptions, RenderOutput, Scene};

/// Loads scene text (meshes relative to the crate's scenes/ folder).
pub fn scene(text: &str, sets: &[&str]) -> Scene {
    let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    load(&SceneSource::from_text("<test>", text, &dir), &sets).unwrap_or_else(|e| panic!("scene failed to load: {e}"))
}

/// Renders scene text with overrides on `threads` threads.
pub fn render_text(text: &str, sets: &[&str], threads: usize) -> RenderOutput {
    render(&scene(text, sets), &RenderOptions { threads: Some(threads), ..Default::default() }).expect("render")
}

/// Root-mean-square difference over all pixels and channels.
pub fn rmse(a: &Image, b: &Image) -> f32 {
    assert_eq!((a.width, a.height), (b.width, b.height));
    let sum: f32 = a.pixels.iter().zip(&b.pixels).map(|(p, q)| (*p - *q).length_squared()).sum();
    (sum / (3 * a.pixels.len()) as f32).sqrt()
}

/// The single pixel of a 1×1 render.
pub fn only_pixel(out: &RenderOutput) -> Vec3 {
    assert_eq!(out.image.pixels.len(), 1);
    out.image.pixels[0]
}

/// A camera that sees only a tiny patch around `p` from `from`, for point measurements.
pub fn probe_camera(from: Vec3, p: Vec3) -> String {
    format!(
        "[camera]\nposition = [{}, {}, {}]\nlook_at = [{}, {}, {}]\nup = [0, 0, 1]\nfov_y = 0.001\n",
        from.x, from.y, from.z, p.x, p.y, p.z
    )
}
