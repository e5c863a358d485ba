//! Numerical stability at the extremes (issue 6), one module per concern: scale and
//! distance from the origin (`scale`), self-intersection of shadow and secondary rays
//! (`offsets`), grazing rays (`grazing`), watertight closed meshes (`watertight`),
//! degenerate but valid input (`degenerate`), and finite pixels for every scene file
//! (`finite`). Dielectric corner cases live with the other dielectric tests in
//! tests/refraction.rs. Every test states its tolerance in a comment next to the
//! assertion.
//!
//! Renders are tiny (at most 48×48, a few samples) so the whole crate stays fast.

#[path = "../support/mod.rs"]
mod support;

mod degenerate;
mod finite;
mod grazing;
mod offsets;
mod scale;
mod watertight;

use crate::support::{rmse, scene_in};
use std::path::Path;
use wavetrace::film::Image;
use wavetrace::{render, RenderOptions, RenderOutput, Scene};

fn render_scene(scene: &Scene) -> RenderOutput {
    render(scene, &RenderOptions { threads: Some(2), ..Default::default() }).expect("render")
}

/// Loads and renders (meshes relative to `dir`), and checks that every pixel is finite
/// and non-negative (part 6).
fn render_in(dir: &Path, text: &str, sets: &[&str]) -> RenderOutput {
    let out = render_scene(&scene_in(dir, text, sets));
    assert_finite(&out, &format!("{sets:?}"));
    out
}

/// Every pixel finite and non-negative (radiance can't be negative), and no non-finite
/// contribution was produced at all: the film stage drops and counts those, so a finite
/// image alone would hide them. Exact.
fn assert_finite(out: &RenderOutput, what: &str) {
    for (i, p) in out.image.pixels.iter().enumerate() {
        assert!(p.is_finite() && p.min_element() >= 0.0, "{what}: pixel {i} is {p}");
    }
    assert_eq!(out.stats.nonfinite, 0, "{what}: non-finite contributions were dropped");
}

/// RMSE of `a` against `b`, relative to the RMS of `b`.
fn rel_rmse(a: &Image, b: &Image) -> f32 {
    let rms = (b.pixels.iter().map(|p| p.length_squared()).sum::<f32>() / (3 * b.pixels.len()) as f32).sqrt();
    rmse(a, b) / rms
}

/// A folder with the test meshes: a cube (12 triangles, 6 fan-triangulated quads) and an
/// octahedron (8 triangles), both outward-wound around the origin.
fn mesh_dir() -> tempfile::TempDir {
    let dir = tempfile::tempdir().expect("tempdir");
    let cube = "\
v -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\nv -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1\n\
f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 4 8 7 3\nf 1 5 8 4\nf 2 3 7 6\n";
    std::fs::write(dir.path().join("cube.obj"), cube).unwrap();
    let mut octa = String::from("v 1 0 0\nv -1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nv 0 0 -1\n");
    for sx in [1, 2] {
        for sy in [3, 4] {
            for sz in [5, 6] {
                // (+x, +y, +z) is counter-clockwise from outside; each sign flip mirrors it.
                let flips = (sx == 2) as u32 + (sy == 4) as u32 + (sz == 6) as u32;
                if flips & 1 == 0 {
                    octa += &format!("f {sx} {sy} {sz}\n");
                } else {
                    octa += &format!("f {sx} {sz} {sy}\n");
                }
            }
        }
    }
    std::fs::write(dir.path().join("octa.obj"), octa).unwrap();
    dir
}
