//! Scale and distance from the origin: the same world at 1e-4 … 1e6 times its size or
//! translated by 1e5 renders the same image.

use super::{mesh_dir, rel_rmse, render_in};
use crate::support::toml::{
    background, camera, dielectric, diffuse, material, mirror, place, placed_mesh, point_light, quad, quad_light,
    render_block, sphere, V3,
};

/// The test world: floor and back wall quads, a diffuse, a mirror and a glass sphere, a
/// Phong cube mesh, a quad light and a point light, and a camera. Every position is
/// `s·p + t`, every length `s·l`; the point light's intensity is scaled by s² so its
/// irradiance is unchanged, and the quad light's radiance is unchanged, so the image is
/// the same at every scale and offset. The floor lies in the plane y = t.y.
fn world(s: f64, t: [f64; 3]) -> String {
    let p = |v: V3| place(v, s, t);
    [
        render_block(&["width=32", "height=32", "max_depth=4", "aa.samples=4", "shadows.samples=4"]),
        camera(p([0.0, 1.2, 4.0]), p([0.0, 0.4, 0.0]), &["fov_y=45"]),
        background([0.05, 0.07, 0.1]),
        diffuse("white", [0.7; 3]),
        material("red", "diffuse", &["color=[0.7, 0.2, 0.15]", "specular=[0.3, 0.3, 0.3]", "shininess=20"]),
        mirror("mirror", [0.9; 3]),
        dielectric("glass", 1.5),
        quad_light(p([-0.5, 2.5, -0.5]), [s, 0.0, 0.0], [0.0, 0.0, s], 5.0),
        point_light(p([1.5, 2.0, 2.0]), 2.0 * s * s),
        quad(p([-3.0, 0.0, -3.0]), [6.0 * s, 0.0, 0.0], [0.0, 0.0, 6.0 * s], "white"),
        quad(p([-3.0, 0.0, -2.0]), [6.0 * s, 0.0, 0.0], [0.0, 3.0 * s, 0.0], "white"),
        sphere(p([-0.9, 0.5, -0.5]), 0.5 * s, "white"),
        sphere(p([0.9, 0.45, -0.4]), 0.45 * s, "mirror"),
        sphere(p([0.55, 0.25, 1.1]), 0.25 * s, "glass"),
        placed_mesh("cube.obj", "red", 0.3 * s, 30.0, p([0.1, 0.35, 0.9])),
    ]
    .concat()
}

/// The world with its mirror and glass spheres made diffuse.
fn diffuse_world(s: f64, t: [f64; 3]) -> String {
    world(s, t)
        .replace("material = \"mirror\"", "material = \"white\"")
        .replace("material = \"glass\"", "material = \"white\"")
}

/// Renders the world at scale `s` and offset `t` and at scale 1 without offset, in both
/// shadow modes; returns the larger relative RMSE and the larger fraction of "acne"
/// pixels (well lit in the reference, above 0.1, and at most half as bright).
fn world_error(s: f64, t: [f64; 3]) -> (f32, f32) {
    world_error_of(world, s, t)
}

fn world_error_of(world: fn(f64, [f64; 3]) -> String, s: f64, t: [f64; 3]) -> (f32, f32) {
    let dir = mesh_dir();
    let (mut worst, mut worst_acne) = (0.0f32, 0.0f32);
    for mode in ["render.shadows.mode=uniform", "render.shadows.mode=adaptive"] {
        let reference = render_in(dir.path(), &world(1.0, [0.0; 3]), &[mode]);
        let moved = render_in(dir.path(), &world(s, t), &[mode]);
        let e = rel_rmse(&moved.image, &reference.image);
        let acne = moved
            .image
            .pixels
            .iter()
            .zip(&reference.image.pixels)
            .filter(|(m, r)| r.max_element() > 0.1 && m.max_element() < 0.5 * r.max_element())
            .count() as f32
            / moved.image.pixels.len() as f32;
        eprintln!("scale {s:e}, offset {t:?}, {mode}: relative RMSE {e:.3e}, acne pixels {acne:.3}");
        worst = worst.max(e);
        worst_acne = worst_acne.max(acne);
    }
    (worst, worst_acne)
}

// Tolerance for the scale tests: relative RMSE < 1e-2 against the s = 1 image, and no
// pixel at most half as bright as the reference. Camera rays, light samples and seeds are
// the same at every scale, so only rounding differs; 1e-2 is about what one silhouette
// sample flipping by rounding costs in a 32×32 image at 4 samples per pixel. (With
// scale-invariant ray offsets the measured error is about 5e-7.)
const SCALE_TOL: f32 = 1e-2;

#[test]
fn scale_1_matches_itself() {
    // Sanity of the harness: the same scene gives the same image (RMSE exactly 0).
    let (e, acne) = world_error(1.0, [0.0; 3]);
    assert_eq!((e, acne), (0.0, 0.0));
}

#[test]
fn scale_1e_minus_4_renders_the_same_image() {
    let (e, acne) = world_error(1e-4, [0.0; 3]);
    assert!(e < SCALE_TOL && acne == 0.0, "relative RMSE {e} (tolerance {SCALE_TOL}), acne fraction {acne}");
}

#[test]
fn scale_1e4_renders_the_same_image() {
    let (e, acne) = world_error(1e4, [0.0; 3]);
    assert!(e < SCALE_TOL && acne == 0.0, "relative RMSE {e} (tolerance {SCALE_TOL}), acne fraction {acne}");
}

#[test]
fn scale_1e6_renders_the_same_image() {
    let (e, acne) = world_error(1e6, [0.0; 3]);
    assert!(e < SCALE_TOL && acne == 0.0, "relative RMSE {e} (tolerance {SCALE_TOL}), acne fraction {acne}");
}

// Tolerances for the world translated by 1e5: a float's spacing there is 2^-7 ≈ 0.008
// scene units, so every input coordinate moves by up to 0.004 when it is stored, and a
// robust ray offset must be a few spacings (0.01 to 0.03): shading points move by that
// much against lights 2 to 4 units away (about 1%), silhouettes by a few hundredths of a
// pixel. Diffuse and Phong world (no mirror or glass): relative RMSE < 0.1. The full world
// adds a glass sphere of radius 0.25, a strong lens that magnifies those shifts (a 0.02
// offset is 8% of its radius): relative RMSE < 0.3. No acne pixel in either. (With
// error-bounded offsets the measured errors are 0.04 and 0.18; with the 256-ulp offsets,
// 1.6 and 1.25.)
#[test]
fn translated_by_1e5_renders_the_same_image() {
    let (e, acne) = world_error_of(diffuse_world, 1.0, [1e5; 3]);
    assert!(e < 0.1 && acne == 0.0, "diffuse world: relative RMSE {e} (tolerance 0.1), acne fraction {acne}");
    let (e, acne) = world_error(1.0, [1e5; 3]);
    assert!(e < 0.3 && acne == 0.0, "full world: relative RMSE {e} (tolerance 0.3), acne fraction {acne}");
}

/// A large diffuse plane y = t.y under a distant point light, seen at grazing angles
/// (0.15° to 2.2° below the horizon): every pixel hits the plane, and each must match the
/// untranslated image.
fn lit_plane(t: [f64; 3]) -> String {
    let p = |v: V3| place(v, 1.0, t);
    [
        render_block(&["width=24", "height=24", "aa.samples=1"]),
        camera(p([0.0, 0.2, 0.0]), p([0.0, 0.0, -10.0]), &["fov_y=2"]),
        diffuse("white", [0.8; 3]),
        point_light(p([0.0, 1000.0, 0.0]), 4e6),
        quad(p([-1e4, 0.0, -1e4]), [2e4, 0.0, 0.0], [0.0, 0.0, 2e4], "white"),
    ]
    .concat()
}

#[test]
fn lit_plane_far_from_origin_stays_uniformly_lit() {
    let dir = mesh_dir();
    let reference = render_in(dir.path(), &lit_plane([0.0; 3]), &[]);
    let moved = render_in(dir.path(), &lit_plane([1e5; 3]), &[]);
    // Tolerance: every pixel within 1% of the untranslated one. The light is 1000 units
    // up, so moving a shading point by a float spacing at 1e5 (0.008) or along the plane by
    // the camera's rounding at grazing angles (about 1.5 units) changes its irradiance by
    // under 0.1%. Shadow acne (a shading point that shadows itself) makes a pixel black.
    for (i, (m, r)) in moved.image.pixels.iter().zip(&reference.image.pixels).enumerate() {
        assert!(r.x > 0.0, "reference pixel {i} is dark: the plane must fill the view");
        let rel = (m.x - r.x).abs() / r.x;
        assert!(rel < 1e-2, "pixel {i}: {} translated vs {} at the origin (rel {rel})", m.x, r.x);
    }
}
