//! Gloss, translucency, conductors and textures (issue 29): the scene fields and their
//! errors, energy in a white furnace, textures seen through a render, determinism, and
//! renders of the glossy test scenes against Mitsuba 3 references
//! (scenes/gloss/refs/, rendered by ../shared/peers/mitsuba/render_xml.py).

mod support;

use glam::Vec3;
use std::path::Path;
use support::*;
use wavetrace::bsdf::microfacet::Distribution;
use wavetrace::scene::{Color, Material};
use wavetrace::tools::compare;
use wavetrace::{render, RenderOptions};

/// A small scene around `materials` and `objects` (TOML text), lit by one quad light.
fn scene_text(materials: &str, objects: &str) -> String {
    format!(
        "[render]\nwidth = 8\nheight = 8\n[camera]\nposition = [0, 0, 4]\nlook_at = [0, 0, 0]\n\
         [[lights]]\ntype = \"quad\"\ncorner = [-1, 3, -1]\nedge_u = [2, 0, 0]\nedge_v = [0, 0, 2]\nradiance = [5, 5, 5]\n\
         {materials}\n{objects}"
    )
}

const SPHERE: &str = "[[objects]]\ntype = \"sphere\"\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"m\"\n";

fn material(text: &str) -> Material {
    scene(&scene_text(&format!("[materials.m]\n{text}"), SPHERE), &[]).materials[0]
}

fn error(text: &str) -> String {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    match try_scene_in(&dir, &scene_text(&format!("[materials.m]\n{text}"), SPHERE), &[]) {
        Err(e) => e.to_string(),
        Ok(_) => panic!("loaded: {text}"),
    }
}

#[test]
fn conductors_and_rough_glass_parse() {
    let Material::Conductor { eta, k, color, roughness: Some(mf) } =
        material("type = \"conductor\"\nmaterial = \"Au\"\nalpha = 0.2\ndistribution = \"ggx\"")
    else {
        panic!("not a rough conductor")
    };
    assert!(eta.x < eta.z && k.x > 0.0, "gold: eta {eta}, k {k}");
    assert_eq!(color, Color::Rgb(Vec3::ONE));
    assert_eq!((mf.distribution, mf.alpha_u, mf.alpha_v), (Distribution::Ggx, 0.2, 0.2));
    let m = material("type = \"conductor\"\neta = [0.2, 0.4, 1.4]\nk = [3.9, 2.4, 1.6]\nalpha_u = 0.1\nalpha_v = 0.3");
    assert!(matches!(m, Material::Conductor { roughness: Some(mf), .. }
        if mf.distribution == Distribution::Beckmann && mf.alpha_u == 0.1 && mf.alpha_v == 0.3));
    // A smooth conductor of Mitsuba's "none" is exactly the mirror.
    assert_eq!(material("type = \"conductor\"\ncolor = [0.5, 0.5, 0.5]"), Material::Mirror { color: Vec3::splat(0.5) });
    // Below Mitsuba's clamp, alpha is raised to it.
    let m = material("type = \"dielectric\"\nior = 1.5\nalpha = 0");
    assert!(matches!(m, Material::Dielectric { roughness: Some(mf), .. } if mf.alpha_u == 1e-4));
}

#[test]
fn bad_gloss_fields_name_the_field() {
    for (text, field, says) in [
        ("type = \"conductor\"\nmaterial = \"Unobtainium\"", "materials.m.material", "unknown conductor"),
        ("type = \"conductor\"\nmaterial = \"Au\"\neta = [1, 1, 1]\nk = [1, 1, 1]", "materials.m.material", "not both"),
        ("type = \"conductor\"\neta = [1, 1, 1]", "materials.m.eta", "needs `k`"),
        ("type = \"conductor\"\neta = [1, -1, 1]\nk = [1, 1, 1]", "materials.m.eta", ">= 0"),
        ("type = \"conductor\"\nalpha = -0.1", "materials.m.alpha", "not in [0, 1000]"),
        ("type = \"conductor\"\nalpha = 0.1\nalpha_u = 0.2\nalpha_v = 0.2", "materials.m.alpha", "not both"),
        ("type = \"conductor\"\nalpha_u = 0.2", "materials.m.alpha_u", "needs `alpha_v`"),
        ("type = \"conductor\"\nalpha = 0.1\ndistribution = \"phong\"", "materials.m.distribution", "\"phong\""),
        ("type = \"dielectric\"\nior = 1.5\ndistribution = \"ggx\"", "materials.m.distribution", "needs a roughness"),
        ("type = \"dielectric\"\nior = 1.5\nalpha = 0.1\nreflect_ratio = 0.3", "materials.m.reflect_ratio", "Fresnel"),
        (
            "type = \"diffuse\"\ncolor = { type = \"bitmap\", file = \"missing.png\" }",
            "materials.m.color.file",
            "missing.png",
        ),
        (
            "type = \"diffuse\"\ncolor = { type = \"bitmap\", file = \"gloss/textures/pattern.png\", wrap = \"tile\" }",
            "materials.m.color.wrap",
            "\"tile\"",
        ),
    ] {
        let msg = error(text);
        assert!(msg.contains(&format!("field `{field}`")) && msg.contains(says), "{text}: {msg}");
    }
}

#[test]
fn a_corrupt_texture_is_an_error_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("bad.png"), b"\x89PNG\r\n\x1a\nnot really").unwrap();
    let text =
        scene_text("[materials.m]\ntype = \"diffuse\"\ncolor = { type = \"bitmap\", file = \"bad.png\" }", SPHERE);
    let msg = try_scene_in(dir.path(), &text, &[]).err().expect("a corrupt PNG loaded").to_string();
    assert!(msg.contains("materials.m.color.file") && msg.contains("bad.png"), "{msg}");
}

/// A white furnace: a sphere under a uniform white background, no lights. Whatever a
/// lossless material does with the light, a pixel can see at most 1; a perfect rough
/// reflector loses only what masking and shadowing (and the bounce limit) take.
fn furnace(material: &str, spp: u32) -> Vec<f32> {
    let text = format!(
        "[render]\nwidth = 16\nheight = 16\nmax_depth = 12\n[render.aa]\nsamples = {spp}\n\
         [camera]\nposition = [0, 0, 3]\nlook_at = [0, 0, 0]\nfov_y = 45\n[background]\ncolor = [1, 1, 1]\n\
         [materials.m]\n{material}\n{SPHERE}"
    );
    let out = render_text(&text, &[], 2);
    out.image.pixels.iter().map(|p| p.x).collect()
}

#[test]
fn rough_perfect_reflectors_and_rough_glass_keep_at_most_the_furnace_light() {
    for (m, least) in [
        ("type = \"conductor\"\nalpha = 0.05\ndistribution = \"ggx\"", 0.97),
        ("type = \"conductor\"\nalpha = 0.5\ndistribution = \"beckmann\"", 0.75),
        ("type = \"dielectric\"\nior = 1.5\nalpha = 0.1\ndistribution = \"ggx\"", 0.9),
    ] {
        let px = furnace(m, 64);
        let (lo, hi) = px.iter().fold((f32::MAX, f32::MIN), |(a, b), &x| (a.min(x), b.max(x)));
        // 64 samples of a weight ≤ 1 each: no pixel above 1 (plus rounding).
        assert!(hi <= 1.0 + 1e-5, "{m}: a pixel at {hi}");
        let mean = px.iter().sum::<f32>() / px.len() as f32;
        assert!(mean >= least, "{m}: mean {mean} (min {lo})");
    }
}

#[test]
fn gloss_is_deterministic_across_threads() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/gloss");
    for name in ["gold.xml", "frosted.xml"] {
        let scene = wavetrace::scene::load(
            &wavetrace::scene::SceneSource::from_file(&dir.join(name)).unwrap(),
            &["render.width=24".into(), "render.height=24".into(), "render.aa.samples=4".into()],
        )
        .unwrap();
        let one = render(&scene, &RenderOptions { threads: Some(1), ..Default::default() }).unwrap();
        let two = render(&scene, &RenderOptions { threads: Some(2), ..Default::default() }).unwrap();
        assert_eq!(one.image.pixels, two.image.pixels, "{name}");
    }
}

/// A checkerboard quad facing the camera under a distant point light: neighbouring
/// pixels on the two colours differ by the colours' ratio.
#[test]
fn a_checkerboard_quad_shows_its_two_colours() {
    let text = "[render]\nwidth = 4\nheight = 4\n[camera]\nposition = [0.5, 0.5, 2]\nlook_at = [0.5, 0.5, 0]\nfov_y = 20\n\
        [[lights]]\ntype = \"point\"\nposition = [0.5, 0.5, 1000]\nintensity = [1000000, 1000000, 1000000]\n\
        [materials.m]\ntype = \"diffuse\"\ncolor = { type = \"checkerboard\", color0 = [0.8, 0.8, 0.8], color1 = [0.2, 0.2, 0.2] }\n\
        [[objects]]\ntype = \"quad\"\ncorner = [0, 0, 0]\nedge_u = [1, 0, 0]\nedge_v = [0, 1, 0]\nmaterial = \"m\"\n";
    let out = render_text(text, &[], 1);
    let px = |x: usize, y: usize| out.image.pixels[y * 4 + x].x;
    // The view spans about 0.35 units around the centre: 4 pixels over the four checks
    // meeting at (0.5, 0.5); rows run down the image, v up the quad.
    let (bright, dark) = if px(0, 0) > px(1, 0) { (px(0, 0), px(3, 0)) } else { (px(3, 0), px(0, 0)) };
    assert!((bright / dark - 4.0).abs() < 0.05, "{bright} / {dark}");
    // (u < 0.5, v < 0.5) is check (0, 0): color0, bottom left of the image.
    assert!(px(0, 3) > px(3, 3), "bottom left {} vs bottom right {}", px(0, 3), px(3, 3));
}

/// The glossy test scenes against Mitsuba 3 references of the same transport: FLIP at a
/// moderate sample count (the high-count figures are in docs/gloss.md).
#[test]
fn glossy_scenes_match_mitsuba() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/gloss");
    for (name, spp, bound) in [("gold", 256, 0.03), ("frosted", 256, 0.03)] {
        let sets = [format!("render.aa.samples={spp}")];
        let scene = wavetrace::scene::load(
            &wavetrace::scene::SceneSource::from_file(&dir.join(format!("{name}.xml"))).unwrap(),
            &sets,
        )
        .unwrap();
        let out = render(&scene, &RenderOptions { threads: Some(2), ..Default::default() }).unwrap();
        let reference = compare::load_linear(&dir.join(format!("refs/{name}.exr"))).unwrap();
        let m = compare::metrics(&out.image, &reference).unwrap();
        let flip = m.flip;
        assert!(flip <= bound, "{name}: FLIP {flip} at {spp} spp (bound {bound})");
    }
}

/// A rotated sphere's texture coordinates turn with it: points on a sphere placed by
/// translate(1, 2, 3) · rotate(x, 90°) · scale(0.5), against the UVs Mitsuba 3.9.1 gives
/// the same hits (`mi.load_dict({'type': 'sphere', 'to_world': ...}).ray_intersect`).
#[test]
fn a_rotated_textured_sphere_has_mitsubas_uvs() {
    let text = scene_text(
        "[materials.m]\ntype = \"diffuse\"\ncolor = { type = \"checkerboard\" }",
        "[[objects]]\ntype = \"sphere\"\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"m\"\n\
         transform = [{ scale = [0.5, 0.5, 0.5] }, { rotate = { axis = [1, 0, 0], angle = 90 } }, { translate = [1, 2, 3] }]\n",
    );
    let scene = scene(&text, &[]);
    let prim = scene.accel.prims().position(|p| p.light == wavetrace::accel::NO_LIGHT).unwrap();
    for (p, want) in [
        (Vec3::new(1.0, 2.5, 3.0), glam::Vec2::new(0.25, 1.0)),
        (Vec3::new(1.5, 2.0, 3.0), glam::Vec2::new(0.0, 0.5)),
        (Vec3::new(1.3, 2.2, 3.346_410_3), glam::Vec2::new(0.136_407_26, 0.630_989_8)),
    ] {
        let uv = wavetrace::surface::uv_at(&scene, prim, 0.0, p);
        // u wraps at 0 / 1.
        let du = (uv.x - want.x).abs().min(1.0 - (uv.x - want.x).abs());
        assert!(du < 1e-4 && (uv.y - want.y).abs() < 1e-4, "at {p}: {uv} against Mitsuba's {want}");
    }
}

/// Three area lights (two quads, one triangle, one of them dark) and a point light around
/// a rough gold sphere that fills the view, on black: the image is the sphere's glossy
/// reflection of the lights and nothing else.
fn mis_scene(alpha: f32) -> String {
    format!(
        "[render]\nwidth = 12\nheight = 12\n[camera]\nposition = [0, 0, 3]\nlook_at = [0, 0, 0]\nfov_y = 30\n\
         [[lights]]\ntype = \"quad\"\ncorner = [-2, 2, 1]\nedge_u = [1.5, 0, 0]\nedge_v = [0, 0, 1.5]\nradiance = [4, 3, 2]\n\
         [[lights]]\ntype = \"quad\"\ncorner = [1, -2, 0]\nedge_u = [0, 0, 1]\nedge_v = [1, 0, 0]\nradiance = [1, 2, 6]\n\
         [[lights]]\ntype = \"quad\"\ncorner = [0, 0, 5]\nedge_u = [0, 1, 0]\nedge_v = [1, 0, 0]\nradiance = [0, 0, 0]\n\
         [[lights]]\ntype = \"triangle\"\nv0 = [2, 0, 2]\nv1 = [2, 1, 2]\nv2 = [2, 0, 3]\nradiance = [6, 6, 6]\n\
         [[lights]]\ntype = \"point\"\nposition = [0, 3, 3]\nintensity = [10, 10, 10]\n\
         [materials.m]\ntype = \"conductor\"\nmaterial = \"Au\"\nalpha = {alpha}\ndistribution = \"ggx\"\n{SPHERE}"
    )
}

/// Each rough hit's light sample has the density `gloss_light_pdf` gives a ray that
/// reaches its point, and the samples integrate the lights: E[cos / pdf] over them is
/// the sum of each lit light's ∫cos dω (its polygon irradiance at unit radiance).
#[test]
fn gloss_light_samples_have_the_density_they_claim() {
    use wavetrace::emitter::area::polygon_irradiance;
    use wavetrace::light::{gloss_light_pdf, gloss_light_sample};
    use wavetrace::scene::Light;
    let scene = scene(&mis_scene(0.3), &[]);
    // The lit area lights, the dark quad and the point light left out.
    assert_eq!(scene.gloss_lights, vec![0, 1, 3]);
    let (x, n) = (Vec3::new(0.3, 0.2, 0.9).normalize(), Vec3::new(0.3, 0.2, 0.9).normalize());
    let expected: f32 = scene
        .gloss_lights
        .iter()
        .map(|&li| match scene.lights[li as usize] {
            // One-sided: a light x sees from behind sends nothing.
            Light::Quad { normal, corner, .. } | Light::Triangle { normal, v0: corner, .. }
                if normal.dot(x - corner) <= 0.0 =>
            {
                0.0
            }
            Light::Quad { corner, u, v, .. } => {
                polygon_irradiance(x, n, &[corner, corner + u, corner + u + v, corner + v])
            }
            Light::Triangle { v0, e1, e2, .. } => polygon_irradiance(x, n, &[v0, v0 + e1, v0 + e2]),
            Light::Point { .. } | Light::Directional { .. } | Light::Sphere { .. } => unreachable!(),
        })
        .sum();
    let count = 1 << 16;
    let mut sum = 0.0f64;
    for s in 0..count {
        let Some(l) = gloss_light_sample(&scene, x, 77, s) else { continue };
        // Which light the sample lies on: the one whose density for the ray matches.
        let li = scene.gloss_lights.iter().copied().find(|&li| {
            let p = gloss_light_pdf(&scene, li, l.wi, l.dist);
            p > 0.0 && (p - l.pdf).abs() <= 1e-3 * l.pdf && on_light(&scene.lights[li as usize], x + l.wi * l.dist)
        });
        assert!(li.is_some(), "sample {s}: no light has density {} for it", l.pdf);
        sum += (n.dot(l.wi).max(0.0) / l.pdf) as f64;
    }
    let estimate = (sum / count as f64) as f32;
    assert!((estimate / expected - 1.0).abs() < 0.01, "E[cos/pdf] {estimate}, lights' ∫cos dω {expected}");
}

/// True when `p` lies on the plane of area light `light`, inside it.
fn on_light(light: &wavetrace::scene::Light, p: Vec3) -> bool {
    use wavetrace::scene::Light;
    let (o, u, v, tri) = match *light {
        Light::Quad { corner, u, v, .. } => (corner, u, v, false),
        Light::Triangle { v0, e1, e2, .. } => (v0, e1, e2, true),
        Light::Point { .. } | Light::Directional { .. } | Light::Sphere { .. } => return false,
    };
    let q = p - o;
    let n = u.cross(v);
    let (a, b) = (q.cross(v).dot(n) / n.length_squared(), u.cross(q).dot(n) / n.length_squared());
    let eps = 1e-4;
    q.dot(n).abs() <= 1e-4 * n.length() * q.length().max(1.0)
        && a >= -eps
        && b >= -eps
        && if tri { a + b <= 1.0 + eps } else { a <= 1.0 + eps && b <= 1.0 + eps }
}

/// Multiple importance sampling at rough hits converges to the image of the BSDF's rays
/// alone (several lights, a triangle among them, a dark one, a point light that glossy
/// hits never see either way), with less noise where the lobe is wide and no more where
/// it is narrow (the BSDF's rays then carry nearly all the weight).
#[test]
fn mis_at_rough_hits_converges_to_the_bsdf_alone() {
    for (alpha, most) in [(0.05, 1.1), (0.3, 0.7)] {
        let text = mis_scene(alpha);
        let run = |mis: bool, spp: u32, seed: u32| {
            let sets = [
                format!("render.gloss.mis={mis}").leak() as &str,
                format!("render.aa.samples={spp}").leak(),
                format!("render.seed={seed}").leak(),
            ];
            render_text(&text, &sets, 2).image
        };
        let mean = |im: &wavetrace::film::Image| {
            im.pixels.iter().map(|p| p.x + p.y + p.z).sum::<f32>() / im.pixels.len() as f32
        };
        let (bsdf, mis) = (run(false, 4096, 1), run(true, 1024, 1));
        let (a, b) = (mean(&bsdf), mean(&mis));
        assert!((a / b - 1.0).abs() < 0.01, "alpha {alpha}: mean {a} (BSDF alone) vs {b} (MIS)");
        // Noise: two seeds' images differ less with MIS at a quarter of the samples.
        let noise = |mis: bool, spp: u32| rmse(&run(mis, spp, 2), &run(mis, spp, 3));
        let (nb, nm) = (noise(false, 64), noise(true, 64));
        assert!(nm < most * nb, "alpha {alpha}: noise {nm} with MIS, {nb} without");
    }
}

/// On the Mitsuba test scenes at equal samples, MIS lowers the error against the
/// reference (and its mean stays the reference's).
#[test]
fn mis_lowers_the_error_on_the_glossy_scenes() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/gloss");
    for name in ["gold", "frosted"] {
        let run = |mis: bool| {
            let sets =
                [format!("render.gloss.mis={mis}"), "render.aa.samples=64".into(), "render.shadows.samples=1".into()];
            let source = wavetrace::scene::SceneSource::from_file(&dir.join(format!("{name}.xml"))).unwrap();
            let scene = wavetrace::scene::load(&source, &sets).unwrap();
            render(&scene, &RenderOptions { threads: Some(2), ..Default::default() }).unwrap().image
        };
        let reference = compare::load_linear(&dir.join(format!("refs/{name}.exr"))).unwrap();
        let (bsdf, mis) = (run(false), run(true));
        let (eb, em) = (rmse(&bsdf, &reference), rmse(&mis, &reference));
        assert!(em < 0.6 * eb, "{name}: RMSE {em} with MIS, {eb} without");
        let mean = |im: &wavetrace::film::Image| im.pixels.iter().map(|p| p.x + p.y + p.z).sum::<f32>();
        let (m, r) = (mean(&mis), mean(&reference));
        assert!((m / r - 1.0).abs() < 0.005, "{name}: mean {m} with MIS, reference {r}");
    }
}
