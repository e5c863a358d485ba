//! Rendered radiance against closed forms: a diffuse plane under a quad light (the
//! analytic irradiance of a polygon) and under a point light (cosine and 1/r²).

mod support;

use glam::Vec3;
use std::f32::consts::PI;
use support::*;

fn measure_mode(lights: &str, p: Vec3, shadow_samples: u32, mode: &str) -> Vec3 {
    measure_plane(lights, p, shadow_samples, mode)
}

fn measure(lights: &str, p: Vec3, shadow_samples: u32) -> Vec3 {
    measure_mode(lights, p, shadow_samples, "uniform")
}

#[test]
fn quad_light_matches_analytic_polygon_irradiance() {
    let corner = Vec3::new(-0.4, 1.5, -0.3);
    let (u, v) = (Vec3::new(0.8, 0.0, 0.0), Vec3::new(0.0, 0.0, 0.6));
    let light = format!(
        "[[lights]]\ntype = \"quad\"\ncorner = [{}, {}, {}]\nedge_u = [{}, {}, {}]\nedge_v = [{}, {}, {}]\nradiance = [4, 4, 4]\n",
        corner.x, corner.y, corner.z, u.x, u.y, u.z, v.x, v.y, v.z
    );
    let verts = [corner, corner + u, corner + u + v, corner + v];
    for p in [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.2, 0.0, -0.7), Vec3::new(-2.0, 0.0, 1.5)] {
        let e = polygon_irradiance(p, Vec3::Y, &verts, 4.0);
        let expected = 0.5 / PI * e;
        let got = measure(&light, p, 4096);
        // 4096 stratified samples of a smooth integrand: well under 0.5% error.
        let rel = (got.x - expected).abs() / expected;
        assert!(rel < 5e-3, "at {p}: rendered {} vs analytic {expected} (rel {rel})", got.x);
        assert!(got.x == got.y && got.y == got.z, "grey light on grey plane must stay grey");
        // Adaptive shadows on a lit Lambert point use the closed form itself, whatever the
        // samples (16: more than the 9 probes, so the light is probed, not sampled).
        let exact = measure_mode(&light, p, 16, "adaptive");
        let rel = (exact.x - expected).abs() / expected;
        assert!(rel < 1e-4, "adaptive at {p}: {} vs analytic {expected} (rel {rel})", exact.x);
    }
}

#[test]
fn analytic_irradiance_clips_at_the_horizon() {
    // A light standing vertically on the plane's horizon: half of it is below any point
    // on the plane beside it... here, a quad crossing the tangent plane of the point.
    let (o, n) = (Vec3::ZERO, Vec3::Y);
    let (c, u, v) = (Vec3::new(-0.5, -1.0, -2.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 2.0, 0.0));
    let clipped = wavetrace::emitter::area::quad_irradiance(o, n, c, u, v);
    let upper =
        wavetrace::emitter::area::quad_irradiance(o, n, Vec3::new(-0.5, 0.0, -2.0), u, Vec3::new(0.0, 1.0, 0.0));
    assert!((clipped - upper).abs() < 1e-6 * upper, "{clipped} vs {upper}");
    let verts =
        [Vec3::new(-0.5, 0.0, -2.0), Vec3::new(0.5, 0.0, -2.0), Vec3::new(0.5, 1.0, -2.0), Vec3::new(-0.5, 1.0, -2.0)];
    let reference = polygon_irradiance(o, n, &verts, 1.0);
    assert!((upper - reference).abs() < 1e-4 * reference, "{upper} vs {reference}");
}

#[test]
fn quad_light_is_one_sided() {
    // The same quad with its edges swapped faces up, away from the plane: no light.
    let light = "[[lights]]\ntype = \"quad\"\ncorner = [-0.4, 1.5, -0.3]\nedge_u = [0, 0, 0.6]\nedge_v = [0.8, 0, 0]\nradiance = [4, 4, 4]\n";
    assert_eq!(measure(light, Vec3::ZERO, 64), Vec3::ZERO);
}

#[test]
fn point_light_has_exact_cosine_and_inverse_square_falloff() {
    let pos = Vec3::new(0.3, 2.0, -0.2);
    let light =
        format!("[[lights]]\ntype = \"point\"\nposition = [{}, {}, {}]\nintensity = [5, 5, 5]\n", pos.x, pos.y, pos.z);
    for p in [Vec3::new(0.3, 0.0, -0.2), Vec3::new(1.0, 0.0, 0.5), Vec3::new(-3.0, 0.0, 2.0)] {
        let to = pos - p;
        let expected = 0.5 / PI * 5.0 * (to.y / to.length()) / to.length_squared();
        let got = measure(&light, p, 16);
        let rel = (got.x - expected).abs() / expected;
        assert!(rel < 1e-4, "at {p}: rendered {} vs exact {expected}", got.x);
    }
}

#[test]
fn point_light_costs_one_shadow_ray_per_shading_point() {
    let text = format!(
        "{}{PLANE}[[lights]]\ntype = \"point\"\nposition = [0, 2, 0]\nintensity = [1, 1, 1]\n",
        probe_camera(Vec3::new(0.0, 3.0, 4.0), Vec3::ZERO)
    );
    let out = render_text(
        &text,
        &["render.width=4", "render.height=4", "render.aa.samples=3", "render.shadows.samples=64"],
        1,
    );
    assert_eq!(out.stats.camera_rays, 48);
    assert_eq!(out.stats.shadow_rays, 48, "one shadow ray per hit, whatever shadows.samples says");
    assert_eq!(out.stats.secondary_rays, 0);
}
