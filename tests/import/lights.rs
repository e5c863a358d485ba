//! Lights on triangles and rectangles against Lambert's polygon formula, one-sided
//! emission by winding, and the adaptive shadow test on triangle lights.

use glam::Vec3;
use std::f32::consts::PI;
use wavetrace::{render, RenderOptions};

use crate::support::{measure_plane, only_pixel, polygon_irradiance, render_text, rmse, PLANE};
use crate::{try_load, Files};

/// A triangle light (counter-clockwise as seen from below: it faces down).
const TRI: [Vec3; 3] = [Vec3::new(-0.6, 1.5, -0.4), Vec3::new(0.6, 1.5, -0.5), Vec3::new(0.7, 1.5, 0.5)];

fn triangle_light(v: [Vec3; 3], radiance: f32) -> String {
    let p = |v: Vec3| format!("[{}, {}, {}]", v.x, v.y, v.z);
    format!(
        "[[lights]]\ntype = \"triangle\"\nv0 = {}\nv1 = {}\nv2 = {}\nradiance = [{radiance}, {radiance}, {radiance}]\n",
        p(v[0]),
        p(v[1]),
        p(v[2])
    )
}

#[test]
fn triangle_light_matches_lambert_polygon_formula() {
    let light = triangle_light(TRI, 4.0);
    for p in [Vec3::ZERO, Vec3::new(1.2, 0.0, -0.7), Vec3::new(-2.0, 0.0, 1.5)] {
        let expected = 0.5 / PI * polygon_irradiance(p, Vec3::Y, &TRI, 4.0);
        let got = measure_plane(&light, p, 4096, "uniform");
        // 4096 stratified area samples of a smooth integrand: well under 0.5% error.
        let rel = (got.x - expected).abs() / expected;
        assert!(rel < 5e-3, "at {p}: rendered {} vs analytic {expected} (rel {rel})", got.x);
        // Adaptive shadows on a lit Lambert point use the closed form: exact to rounding
        // (16 samples: more than the triangle's 7 probes, so the light is probed).
        let exact = measure_plane(&light, p, 16, "adaptive");
        let rel = (exact.x - expected).abs() / expected;
        assert!(rel < 1e-4, "adaptive at {p}: {} vs analytic {expected} (rel {rel})", exact.x);
    }
}

#[test]
fn triangle_light_is_one_sided_by_winding() {
    let p = Vec3::new(0.2, 0.0, 0.1);
    assert!(measure_plane(&triangle_light(TRI, 4.0), p, 16, "uniform").x > 0.0);
    let up = [TRI[0], TRI[2], TRI[1]];
    assert_eq!(measure_plane(&triangle_light(up, 4.0), p, 16, "uniform"), Vec3::ZERO);
    assert_eq!(measure_plane(&triangle_light(up, 4.0), p, 16, "adaptive"), Vec3::ZERO);
}

#[test]
fn rectangle_light_from_xml_matches_lambert_polygon_formula() {
    // A 0.6×0.4 rectangle light at height 1.5 facing down (+z turned to -y by 90° about x), over a
    // twosided diffuse plane of albedo 0.5; a probe camera looks at one point.
    let f = Files::temp();
    let p = Vec3::new(0.3, 0.0, -0.2);
    let xml = format!(
        "<scene version=\"3.0.0\"><sensor type=\"perspective\"><float name=\"fov\" value=\"0.001\"/>\
         <transform name=\"to_world\"><lookat origin=\"{}, 3, {}\" target=\"{}, 0, {}\" up=\"0, 0, 1\"/></transform>\
         <sampler type=\"independent\"><integer name=\"sample_count\" value=\"1\"/></sampler>\
         <film type=\"hdrfilm\"><integer name=\"width\" value=\"1\"/><integer name=\"height\" value=\"1\"/></film></sensor>\
         <shape type=\"rectangle\"><transform name=\"to_world\"><scale value=\"50\"/><rotate x=\"1\" angle=\"-90\"/></transform>\
         <bsdf type=\"twosided\"><bsdf type=\"diffuse\"/></bsdf></shape>\
         <shape type=\"rectangle\"><transform name=\"to_world\"><scale x=\"0.3\" y=\"0.2\"/><rotate x=\"1\" angle=\"90\"/><translate y=\"1.5\"/></transform>\
         <emitter type=\"area\"><rgb name=\"radiance\" value=\"4\"/></emitter></shape></scene>",
        p.x, p.z + 4.0, p.x, p.z
    );
    let path = f.write("r.xml", xml);
    let verts =
        [Vec3::new(-0.3, 1.5, -0.2), Vec3::new(0.3, 1.5, -0.2), Vec3::new(0.3, 1.5, 0.2), Vec3::new(-0.3, 1.5, 0.2)];
    let expected = 0.5 / PI * polygon_irradiance(p, Vec3::Y, &verts, 4.0);
    // Adaptive with 16 samples (more than the 9 probes): the lit point's closed form.
    for (mode, samples, tol) in [("uniform", "4096", 5e-3), ("adaptive", "16", 1e-4)] {
        let (m, n) = (format!("render.shadows.mode={mode}"), format!("render.shadows.samples={samples}"));
        let sets = [m.as_str(), n.as_str()];
        let scene = try_load(&path, &[], &sets).unwrap();
        let out = render(&scene, &RenderOptions { threads: Some(1), ..Default::default() }).unwrap();
        let got = only_pixel(&out).x;
        let rel = (got - expected).abs() / expected;
        assert!(rel < tol, "{mode}: rendered {got} vs analytic {expected} (rel {rel})");
    }
}

#[test]
fn adaptive_shadows_on_a_triangle_light_agree_with_uniform() {
    // A sphere between a triangle light and the floor: lit, penumbra and umbra points.
    // Adaptive mode casts the same penumbra rays as uniform mode and the closed form on
    // lit points, so the images differ only where the probes misjudge a point (rare).
    let scene = format!(
        "[render]\nwidth = 24\nheight = 24\n[render.aa]\nsamples = 1\n[render.shadows]\nsamples = 64\n\
         [camera]\nposition = [0, 4, 3]\nlook_at = [0, 0, 0]\n{PLANE}{}\
         [[objects]]\ntype = \"sphere\"\ncenter = [0.1, 0.6, 0]\nradius = 0.3\nmaterial = \"white\"\n",
        triangle_light(TRI, 4.0)
    );
    let uniform = render_text(&scene, &[], 2).image;
    for probe in ["corners", "corners+center", "jittered", "3x3"] {
        let probe_set = format!("render.shadows.probe={probe}");
        let sets = ["render.shadows.mode=adaptive", probe_set.as_str()];
        let adaptive = render_text(&scene, &sets, 2).image;
        let e = rmse(&adaptive, &uniform);
        // Typical pixel values are 0.05–0.2; a misjudged penumbra point would cost ~0.1.
        assert!(e < 4e-3, "probe {probe}: rmse {e} against uniform");
    }
}
