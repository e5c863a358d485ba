//! The path transport against closed forms: inside a diffuse sphere lit by a point light
//! at its centre every wall point sees the same radiance, so each bounce adds exactly one
//! term of a geometric series; a convex sphere under a constant background reflects its
//! albedo times the background; next-event estimation with multiple importance sampling
//! integrates a quad light exactly; and the path transport keeps its bits across threads
//! and crops.

mod support;

use glam::Vec3;
use std::f32::consts::PI;
use support::toml::{background, camera, diffuse, point_light, quad_light, render_block, sphere};
use support::*;
use wavetrace::{render, RenderOptions};

/// The one pixel a narrow camera at `from` sees of the point `at`, under `sets`.
fn pixel(text: &str, from: [f64; 3], at: [f64; 3], sets: &[&str]) -> Vec3 {
    let text = [render_block(&["width=1", "height=1"]), camera(from, at, &["fov_y=0.001"]), text.to_string()].concat();
    only_pixel(&render_text(&text, sets, 2))
}

/// A sphere of radius 1 and albedo `rho` around a point light of intensity 2 at its
/// centre: the direct radiance of every wall point is rho·I / (π R²).
fn closed_sphere(rho: f64) -> (String, f32) {
    let text = [diffuse("wall", [rho; 3]), sphere([0.0; 3], 1.0, "wall"), point_light([0.0; 3], 2.0)].concat();
    (text, rho as f32 * 2.0 / PI)
}

#[test]
fn each_bounce_adds_one_term_of_the_series_inside_a_sphere() {
    let rho = 0.8f32;
    let (text, direct) = closed_sphere(rho as f64);
    // Without Russian roulette the estimate is exact: every wall point's light sample is
    // the same, and every bounce ray carries exactly the albedo. max_depth counts bounces
    // after the camera ray (Mitsuba's max_depth - 1): k bounces add k terms.
    for k in 1..=4u32 {
        let depth = format!("render.max_depth={k}");
        let got = pixel(
            &text,
            [0.0, 0.0, 0.3],
            [0.0, 0.0, -1.0],
            &["render.transport=path", "render.path.rr_depth=64", &depth],
        );
        let expected = direct * (1.0 - rho.powi(k as i32)) / (1.0 - rho);
        let rel = (got.x - expected).abs() / expected;
        assert!(rel < 1e-4, "max_depth {k}: {} vs {expected} (rel {rel})", got.x);
    }
    // The paper's transport takes the direct light only, as path with one bounce does.
    let whitted = pixel(&text, [0.0, 0.0, 0.3], [0.0, 0.0, -1.0], &[]);
    assert!((whitted.x - direct).abs() < 1e-4 * direct, "{} vs {direct}", whitted.x);
}

#[test]
fn russian_roulette_converges_to_the_whole_series() {
    let rho = 0.8f32;
    let (text, direct) = closed_sphere(rho as f64);
    let expected = direct / (1.0 - rho);
    // Every pixel sees a wall of the same radiance: the pixels are independent estimates
    // of it, and their spread gives the standard error of their mean.
    let text =
        [render_block(&["width=16", "height=16"]), camera([0.0, 0.0, 0.3], [0.0, 0.0, -1.0], &["fov_y=60"]), text]
            .concat();
    for rr in ["1", "5"] {
        let sets = [
            "render.transport=path",
            "render.max_depth=64",
            "render.aa.samples=256",
            &format!("render.path.rr_depth={rr}"),
        ];
        let px: Vec<f64> = render_text(&text, &sets, 2).image.pixels.iter().map(|p| p.x as f64).collect();
        let n = px.len() as f64;
        let mean = px.iter().sum::<f64>() / n;
        let se = (px.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0) / n).sqrt();
        // 64 bounces leave 0.8^64 ≈ 6e-7 of the series out; the rest is noise (4.5 sigma).
        let err = (mean - expected as f64).abs();
        assert!(err < 4.5 * se && se < 0.01 * mean, "rr_depth {rr}: {mean} ± {se} vs {expected}");
    }
}

#[test]
fn a_convex_sphere_reflects_its_albedo_of_a_constant_background() {
    let text = [background([1.5; 3]), diffuse("grey", [0.6; 3]), sphere([0.0; 3], 1.0, "grey")].concat();
    // Light samples of the background and escaping bounce rays share it by MIS: each
    // sample is an unbiased estimate of the albedo times it; 4096 bring the noise under
    // 0.3 %.
    let got = pixel(&text, [0.0, 0.0, 5.0], [0.0, 0.0, 1.0], &["render.transport=path", "render.aa.samples=4096"]);
    assert!((got - Vec3::splat(0.9)).abs().max_element() < 0.01 * 0.9, "{got}");
    // Hidden emitters hide the background behind the sphere, not the light it reflects.
    let hidden = ["render.transport=path", "render.path.hide_emitters=true"];
    assert_eq!(pixel(&text, [0.0, 0.0, 5.0], [0.0, 3.0, 0.0], &hidden), Vec3::ZERO);
    let hidden = [hidden[0], hidden[1], "render.aa.samples=4096"];
    let got = pixel(&text, [0.0, 0.0, 5.0], [0.0, 0.0, 1.0], &hidden);
    assert!((got - Vec3::splat(0.9)).abs().max_element() < 0.01 * 0.9, "{got}");
}

/// A 32 × 16 lat-long map with a bright spot, a dark band and colour everywhere, as an
/// 8-bit sRGB PNG in `dir`.
fn write_map(dir: &std::path::Path) -> std::path::PathBuf {
    let img = image::RgbImage::from_fn(32, 16, |i, j| {
        let spot = (i as i32 - 20).abs() <= 1 && (j as i32 - 5).abs() <= 1;
        match (spot, j) {
            (true, _) => image::Rgb([255, 250, 230]),
            (false, 10..=11) => image::Rgb([0, 0, 0]),
            _ => image::Rgb([(40 + i * 6) as u8, (30 + j * 12) as u8, 140]),
        }
    });
    let path = dir.join("sky.png");
    img.save(&path).unwrap();
    path
}

#[test]
fn a_convex_sphere_reflects_the_irradiance_of_an_environment_map() {
    // Each point of a diffuse sphere sees the whole hemisphere over it: its radiance is
    // ρ/π ∫ L(ω) max(0, n·ω) dω, whatever the map. The map's light samples, the bounce
    // rays that escape, and their MIS weights must add up to that integral.
    let dir = tempfile::tempdir().unwrap();
    write_map(dir.path());
    let text = [
        "[background]\nmap = \"sky.png\"\nscale = 2\ntransform = [{ rotate = { axis = [0, 1, 0], angle = 40 } }]\n",
        &diffuse("grey", [0.5; 3]),
        &sphere([0.0; 3], 1.0, "grey"),
    ]
    .concat();
    for (from, n) in [([0.0, 0.0, 5.0], Vec3::Z), ([3.0, 3.0, 0.5], Vec3::new(1.0, 1.0, 0.0).normalize())] {
        let at = n.to_array().map(f64::from);
        let head = [render_block(&["width=1", "height=1"]), camera(from, at, &["fov_y=0.001"])].concat();
        let scene = support::scene_in(dir.path(), &[head.as_str(), text.as_str()].concat(), &[]);
        // The irradiance by the midpoint rule over (φ, cos θ) about n: 800 × 400 cells of
        // equal solid angle.
        let (t, b) = tangents(n);
        let (n_phi, n_cos) = (800, 400);
        let mut e = glam::DVec3::ZERO;
        for a in 0..n_phi {
            let phi = (a as f32 + 0.5) / n_phi as f32 * 2.0 * PI;
            for c in 0..n_cos {
                let z = (c as f32 + 0.5) / n_cos as f32;
                let r = (1.0 - z * z).sqrt();
                let w = (t * (r * phi.cos()) + b * (r * phi.sin()) + n * z).normalize();
                e += (scene.background.eval(w) * z).as_dvec3();
            }
        }
        let expected = (e * (2.0 * std::f64::consts::PI / (n_phi * n_cos) as f64)).as_vec3() * (0.5 / PI);
        for transport in ["path", "direct"] {
            let sets = [&format!("render.transport={transport}"), "render.aa.samples=8192"];
            let scene = support::scene_in(dir.path(), &[&head, text.as_str()].concat(), &sets);
            let out = render(&scene, &RenderOptions { threads: Some(2), ..Default::default() }).unwrap();
            let got = only_pixel(&out);
            let rel = ((got - expected).abs() / expected).max_element();
            assert!(rel < 0.01, "{transport}, normal {n}: {got} vs {expected} (rel {rel})");
        }
    }
}

/// Two unit vectors orthogonal to unit `n` and to each other.
fn tangents(n: Vec3) -> (Vec3, Vec3) {
    let t = if n.x.abs() < 0.9 { Vec3::X } else { Vec3::Y }.cross(n).normalize();
    (t, n.cross(t))
}

#[test]
fn light_samples_and_bounce_rays_share_a_quad_light_by_mis() {
    // A large light low over the plane, so the bounce rays find it often and the two
    // strategies' weights both matter.
    let (corner, u, v) = (Vec3::new(-1.0, 0.5, -1.0), Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 2.0));
    let light =
        quad_light(corner.to_array().map(f64::from), u.to_array().map(f64::from), v.to_array().map(f64::from), 3.0);
    let verts = [corner, corner + u, corner + u + v, corner + v];
    let text = format!("{PLANE}{light}");
    for p in [Vec3::ZERO, Vec3::new(0.8, 0.0, 0.3), Vec3::new(1.5, 0.0, -1.2)] {
        let expected = 0.5 / PI * polygon_irradiance(p, Vec3::Y, &verts, 3.0);
        let from = (p + Vec3::new(0.0, 0.3, 0.4)).to_array().map(f64::from);
        for n in ["1", "4"] {
            let sets = ["render.transport=direct", "render.aa.samples=4096", &format!("render.shadows.samples={n}")];
            let got = pixel(&text, from, p.to_array().map(f64::from), &sets);
            let rel = (got.x - expected).abs() / expected;
            assert!(rel < 0.01, "at {p}, {n} light samples: {} vs {expected} (rel {rel})", got.x);
        }
    }
}

#[test]
fn adaptive_shadows_agree_with_uniform_under_path() {
    // A lit room: a quad light under the top of a diffuse sphere; the adaptive test probes
    // it at every vertex of every path.
    let text = [
        render_block(&["width=8", "height=8", "transport=\"path\"", "aa.samples=256"]),
        camera([0.0, 0.0, 0.6], [0.0, -0.5, -1.0], &["fov_y=60"]),
        diffuse("wall", [0.7, 0.5, 0.3]),
        sphere([0.0; 3], 1.0, "wall"),
        quad_light([-0.3, 0.8, -0.3], [0.0, 0.0, 0.6], [0.6, 0.0, 0.0], 5.0),
        diffuse("red", [0.8, 0.1, 0.1]),
        sphere([0.2, -0.6, -0.3], 0.25, "red"),
    ]
    .concat();
    let mean = |mode: &str| {
        let out = render_text(&text, &[&format!("render.shadows.mode={mode}")], 2);
        out.image.pixels.iter().copied().sum::<Vec3>() / out.image.pixels.len() as f32
    };
    let (uniform, adaptive) = (mean("uniform"), mean("adaptive"));
    let rel = ((uniform - adaptive).abs() / uniform).max_element();
    assert!(rel < 0.02, "uniform {uniform} vs adaptive {adaptive}");
}

#[test]
fn path_bits_hold_across_threads_and_crops() {
    let text = [
        render_block(&["width=24", "height=16", "transport=\"path\"", "aa.samples=4", "path.rr_depth=1"]),
        camera([0.0, 1.0, 4.0], [0.0, 0.5, 0.0], &[]),
        diffuse("white", [0.8; 3]),
        support::toml::quad([-3.0, 0.0, 3.0], [6.0, 0.0, 0.0], [0.0, 0.0, -6.0], "white"),
        support::toml::dielectric("glass", 1.5),
        sphere([0.0, 0.6, 0.0], 0.6, "glass"),
        quad_light([-0.5, 3.0, -0.5], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0], 10.0),
    ]
    .concat();
    let scene = support::scene(&text, &[]);
    let at =
        |threads, crop| render(&scene, &RenderOptions { threads: Some(threads), crop, ..Default::default() }).unwrap();
    let one = at(1, None);
    assert!(one.image.pixels.iter().any(|p| p.x > 0.0));
    let bits =
        |i: &wavetrace::film::Image| i.pixels.iter().flat_map(|p| p.to_array().map(f32::to_bits)).collect::<Vec<_>>();
    assert_eq!(bits(&one.image), bits(&at(2, None).image));
    let crop = wavetrace::film::Tile { x0: 5, y0: 3, x1: 19, y1: 11 };
    let part = at(2, Some(crop));
    for y in crop.y0..crop.y1 {
        for x in crop.x0..crop.x1 {
            let (a, b) = (
                one.image.pixels[(y * 24 + x) as usize],
                part.image.pixels[((y - crop.y0) * 14 + x - crop.x0) as usize],
            );
            assert_eq!(a.to_array().map(f32::to_bits), b.to_array().map(f32::to_bits), "pixel ({x}, {y})");
        }
    }
}

#[test]
fn a_one_sided_surface_is_black_from_behind() {
    // A floor facing up under a point light, seen from above and from below.
    let text = |two_sided: bool| {
        [
            support::toml::material("floor", "diffuse", &["color=[0.5, 0.5, 0.5]", &format!("two_sided={two_sided}")]),
            support::toml::quad([-5.0, 0.0, 5.0], [10.0, 0.0, 0.0], [0.0, 0.0, -10.0], "floor"),
            point_light([0.0, 2.0, 0.0], 4.0),
            point_light([0.0, -2.0, 0.0], 4.0),
        ]
        .concat()
    };
    for transport in ["whitted", "path"] {
        let sets = [&format!("render.transport={transport}")[..]];
        let above = pixel(&text(false), [0.5, 3.0, 0.0], [0.0; 3], &sets);
        let below = pixel(&text(false), [0.5, -3.0, 0.0], [0.0; 3], &sets);
        assert!(above.x > 0.0 && below == Vec3::ZERO, "{transport}: {above} above, {below} below");
        // Two-sided (the TOML default), the back is lit by the light below it.
        let back = pixel(&text(true), [0.5, -3.0, 0.0], [0.0; 3], &sets);
        assert!((back.x - above.x).abs() < 1e-5 * above.x, "{transport}: {back} vs {above}");
    }
}

/// Imported path-traced scenes against Mitsuba 3.9.1's own `path` integrator
/// (`scenes/import/refs/`, 8192 to 16384 spp, box filter): at 256 spp wavetrace is within
/// Mitsuba's own 256-spp FLIP against the same reference (docs/transport.md),
/// and its mean within 0.5% of the reference's (no bias).
#[cfg(all(feature = "exr", feature = "flip"))]
#[test]
fn imported_path_scenes_match_mitsubas_own_integrator() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/import");
    for (name, bound) in
        [("cbox", 0.044), ("room", 0.029), ("plastic", 0.0212), ("envmap", 0.0229), ("spheres", 0.0303)]
    {
        let source = wavetrace::scene::SceneSource::from_file(&dir.join(format!("{name}.xml"))).unwrap();
        let scene = wavetrace::scene::load(&source, &["render.aa.samples=256".into()]).unwrap();
        let out = render(&scene, &RenderOptions { threads: Some(2), ..Default::default() }).unwrap();
        let reference = wavetrace::tools::compare::load_linear(&dir.join(format!("refs/{name}-path.exr"))).unwrap();
        let m = wavetrace::tools::compare::metrics(&out.image, &reference).unwrap();
        assert!(m.flip <= bound, "{name}: FLIP {} at 256 spp (Mitsuba's own: {bound})", m.flip);
        let mean = |im: &wavetrace::film::Image| im.pixels.iter().copied().sum::<Vec3>() / im.pixels.len() as f32;
        let (a, b) = (mean(&out.image), mean(&reference));
        assert!(((a - b).abs() / b).max_element() < 0.005, "{name}: mean {a} vs reference {b}");
    }
}

#[test]
fn light_samples_pick_lights_by_power_and_stay_unbiased() {
    // A bright small light and a dim large one over the plane: the path transport picks
    // them by area times luminance, and the direct light is still the two integrals.
    let bright = ([-1.2, 0.8, -0.2], [0.4, 0.0, 0.0], [0.0, 0.0, 0.4], 20.0);
    let dim = ([0.2, 1.5, -1.0], [2.0, 0.0, 0.0], [0.0, 0.0, 2.0], 0.5);
    let text = format!(
        "{PLANE}{}{}",
        quad_light(bright.0, bright.1, bright.2, bright.3),
        quad_light(dim.0, dim.1, dim.2, dim.3)
    );
    let scene = support::scene(
        &[render_block(&["transport=\"path\""]), camera([0.0, 3.0, 4.0], [0.0; 3], &[]), text.clone()].concat(),
        &[],
    );
    // Powers 0.16 · 20 = 3.2 and 4 · 0.5 = 2 (grey radiance: luminance = radiance).
    let (p0, p1) = (scene.light_pick[0], scene.light_pick[1]);
    assert!((p0 - 3.2 / 5.2).abs() < 1e-6 && (p1 - 2.0 / 5.2).abs() < 1e-6, "{p0} {p1}");
    assert_eq!(*scene.light_cdf.last().unwrap(), 1.0);
    let v = |c: [f64; 3], u: [f64; 3], w: [f64; 3]| {
        let (c, u, w) = (
            Vec3::from_array(c.map(|x| x as f32)),
            Vec3::from_array(u.map(|x| x as f32)),
            Vec3::from_array(w.map(|x| x as f32)),
        );
        [c, c + u, c + u + w, c + w]
    };
    for p in [Vec3::ZERO, Vec3::new(-1.0, 0.0, 0.3), Vec3::new(1.2, 0.0, -0.5)] {
        let e = polygon_irradiance(p, Vec3::Y, &v(bright.0, bright.1, bright.2), 20.0)
            + polygon_irradiance(p, Vec3::Y, &v(dim.0, dim.1, dim.2), 0.5);
        let expected = 0.5 / PI * e;
        let from = (p + Vec3::new(0.0, 0.3, 0.4)).to_array().map(f64::from);
        let sets = ["render.transport=direct", "render.aa.samples=65536", "render.shadows.samples=2"];
        let got = pixel(&text, from, p.to_array().map(f64::from), &sets);
        let rel = (got.x - expected).abs() / expected;
        // 65536 samples: measured 0.04-0.13%.
        assert!(rel < 0.005, "at {p}: {} vs {expected} (rel {rel})", got.x);
    }
}

#[test]
fn a_directional_light_lights_diffuse_and_plastic_surfaces() {
    // Irradiance E along d on the plane y = 0: a Lambert point returns ρ/π·E·cos θ, a
    // plastic its BSDF's f·cos θ times E, under every transport (plastic: path and
    // direct, where glossy vertices sample delta lights).
    let d = Vec3::new(0.3, -1.0, 0.2).normalize();
    let light = format!("[[lights]]\ntype = \"directional\"\ndirection = {:?}\nirradiance = [2, 2, 2]\n", d.to_array());
    let from = [0.4, 1.0, 0.9];
    let expected = 0.5 / PI * 2.0 * -d.y;
    for transport in ["whitted", "path", "direct"] {
        let got = pixel(&format!("{PLANE}{light}"), from, [0.0; 3], &[&format!("render.transport={transport}")]);
        assert!((got - Vec3::splat(expected)).abs().max_element() < 1e-5, "{transport}: {got} vs {expected}");
    }
    let plastic = PLANE.replace("type = \"diffuse\"", "type = \"plastic\"\nior = 1.5");
    let text = format!("{plastic}{light}");
    let scene = support::scene(&[render_block(&[]), camera(from, [0.0; 3], &[]), text.clone()].concat(), &[]);
    let wavetrace::scene::Material::Plastic { specular, eta, internal, specular_weight, nonlinear, .. } =
        scene.materials[0]
    else {
        panic!("not a plastic")
    };
    let bsdf = wavetrace::bsdf::plastic::Plastic {
        diffuse: Vec3::splat(0.5),
        specular,
        eta,
        roughness: None,
        table: &[0.0; wavetrace::bsdf::plastic::TABLE_RES],
        internal,
        nonlinear,
        specular_weight,
    };
    // The plane's shading frame: +z is +y. wi towards the camera, wo towards the light.
    let local = |v: Vec3| Vec3::new(v.x, v.z, v.y);
    let wi = local(Vec3::from(from.map(|x| x as f32)).normalize());
    let expected = bsdf.eval_pdf(wi, local(-d)).0 * 2.0;
    for transport in ["path", "direct"] {
        let got = pixel(&text, from, [0.0; 3], &[&format!("render.transport={transport}")]);
        // The smooth coating's mirror reflects the black sky: the base alone is seen.
        assert!(
            (got - expected).abs().max_element() < 1e-4 * expected.max_element(),
            "{transport}: {got} vs {expected}"
        );
    }
}

#[test]
fn a_sphere_light_gives_its_closed_form_irradiance() {
    // A sphere of radius R and radiance L at distance d from a point, its centre at angle α
    // from the normal and the whole cone above the horizon: E = π L (R/d)² cos α. Light
    // samples (uniform in the cone) and, under path and direct, bounce rays by MIS.
    let (c, r, l) = (Vec3::new(0.6, 2.0, 0.3), 0.5f32, 3.0f32);
    let light = format!(
        "[[lights]]\ntype = \"sphere\"\ncenter = {:?}\nradius = {r}\nradiance = [{l}, {l}, {l}]\n",
        c.to_array()
    );
    let text = format!("{PLANE}{light}");
    for p in [Vec3::ZERO, Vec3::new(-0.8, 0.0, 0.5)] {
        let to = c - p;
        let e = PI * l * r * r / to.length_squared() * (to.normalize().y);
        let expected = 0.5 / PI * e;
        let from = (p + Vec3::new(0.1, 0.3, -0.4)).to_array().map(f64::from);
        for transport in ["whitted", "path", "direct"] {
            let sets = [&format!("render.transport={transport}"), "render.aa.samples=2048", "render.path.rr_depth=64"];
            let got = pixel(&text, from, p.to_array().map(f64::from), &sets);
            // Path adds the light the plane sends back up to the sphere... which emits
            // only: nothing returns, so every transport sees the direct light alone.
            let rel = (got.x - expected).abs() / expected;
            assert!(rel < 0.01, "{transport} at {p}: {} vs {expected} (rel {rel})", got.x);
        }
    }
    // Seen directly: its radiance.
    let seen = pixel(&text, [0.6, 2.0, -3.0], c.to_array().map(f64::from), &["render.transport=path"]);
    assert!((seen - Vec3::splat(l)).abs().max_element() < 1e-6, "{seen}");
}
