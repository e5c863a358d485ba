//! Degenerate but valid input: zero-area triangles and lights, a pinhole with DOF
//! samples, max_depth 0, adaptive AA at eps 0 and eps huge, a 1×1 image, no lights, no
//! objects.

use super::{assert_finite, rel_rmse, render_in, render_scene};
use crate::support::toml::{
    background, camera, dielectric, diffuse, material, mesh, mirror, point_light, quad, quad_light, render_block,
    sphere, V3,
};
use crate::support::{only_pixel, scene_in, try_scene_in, FloorScene, Sphere};
use glam::Vec3;
use std::path::Path;

#[test]
fn zero_area_triangles_are_skipped_and_counted() {
    let dir = tempfile::tempdir().unwrap();
    // A tetrahedron (4 good triangles), a thin but valid needle, and zero-area triangles:
    // a repeated vertex, three collinear vertices, one vertex three times, and one whose
    // area (1e-50) underflows to 0 in f32.
    let obj = "\
v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nv 2 2 2\nv 3 3 3\nv 1 1e-7 0\nv 1e-25 0 0\nv 0 1e-25 0\n\
f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n\
f 1 2 7\n\
f 1 1 2\nf 1 5 6\nf 3 3 3\nf 1 8 9\n";
    std::fs::write(dir.path().join("degen.obj"), obj).unwrap();
    let scene_text = |material: String, mesh_keys: &[&str]| {
        [
            render_block(&["width=24", "height=24", "aa.samples=2", "shadows.samples=2"]),
            camera([1.5, 1.2, 2.5], [0.3; 3], &[]),
            background([0.1; 3]),
            material,
            point_light([2.0, 3.0, 2.0], 5.0),
            quad_light([-1.0, 3.0, -1.0], [2.0, 0.0, 0.0], [0.0, 0.0, 2.0], 3.0),
            mesh("degen.obj", "m", mesh_keys),
        ]
        .concat()
    };
    for (ty, material) in
        [("diffuse", diffuse("m", [0.8; 3])), ("dielectric", dielectric("m", 1.5)), ("mirror", mirror("m", [0.9; 3]))]
    {
        let text = scene_text(material, &[]);
        let scene = scene_in(dir.path(), &text, &[]);
        // Exact counts.
        assert_eq!(scene.info.degenerate_triangles, 4, "{ty}");
        assert_eq!(scene.info.triangles, 5, "{ty}");
        assert_eq!(scene.accel.len(), 5 + 1, "{ty}: triangles and the quad light");
        for mode in ["render.shadows.mode=uniform", "render.shadows.mode=adaptive"] {
            let out = render_in(dir.path(), &text, &[mode]);
            assert!(out.image.pixels.iter().any(|p| *p != out.image.pixels[0]), "{ty}: the mesh is visible");
        }
    }
    // Zero area only after the transform: a scale of 1e-30 underflows every triangle.
    let text = scene_text(diffuse("m", [1.0; 3]), &["scale=1e-30"]);
    let scene = scene_in(dir.path(), &text, &[]);
    assert_eq!(scene.info.triangles, 0);
    assert_eq!(scene.info.degenerate_triangles, 9);
    assert_finite(&render_scene(&scene), "all triangles degenerate");
}

#[test]
fn zero_area_quad_light_is_rejected_naming_the_field() {
    let light = |u: V3, v: V3| camera([0.0, 0.0, 5.0], [0.0; 3], &[]) + &quad_light([0.0, 1.0, 0.0], u, v, 1.0);
    // Exact: load fails with an input error that names the file, line and field.
    for (u, v, field, why) in [
        ([1.0, 0.0, 0.0], [2.0, 0.0, 0.0], "lights.0.edge_v", "zero area"),
        ([1.0, 2.0, 3.0], [-2.0, -4.0, -6.0], "lights.0.edge_v", "zero area"),
        ([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], "lights.0.edge_u", "zero-length"),
        ([1.0, 0.0, 0.0], [0.0, 0.0, 0.0], "lights.0.edge_v", "zero-length"),
    ] {
        let err = match try_scene_in(Path::new("."), &light(u, v), &[]) {
            Ok(_) => panic!("a zero-area light {u:?} × {v:?} was accepted"),
            Err(e) => e,
        };
        let msg = err.to_string();
        assert_eq!(err.exit_code(), 2, "{msg}");
        assert!(msg.contains(&format!("field `{field}`")) && msg.contains(why), "{u:?} × {v:?}: {msg}");
        assert!(msg.starts_with("<test>:"), "{msg}");
    }
    // A small light is not a zero-area one: 1e-3 × 1e-3 loads.
    assert!(try_scene_in(Path::new("."), &light([1e-3, 0.0, 0.0], [0.0, 0.0, 1e-3]), &[]).is_ok());
}

#[test]
fn pinhole_ignores_dof_samples() {
    let text = [
        render_block(&["width=16", "height=16", "aa.samples=3"]),
        camera([0.0, 1.0, 4.0], [0.0, 0.5, 0.0], &["aperture=0"]),
        diffuse("white", [0.8; 3]),
        point_light([1.0, 3.0, 2.0], 5.0),
        sphere([0.0, 0.5, 0.0], 0.5, "white"),
    ]
    .concat();
    for aa in ["render.aa.mode=uniform", "render.aa.mode=adaptive"] {
        let one = render_in(Path::new("."), &text, &[aa, "render.dof.samples=1"]);
        let many = render_in(Path::new("."), &text, &[aa, "render.dof.samples=16"]);
        // Exact: the same image bit for bit and the same number of camera rays.
        assert_eq!(one.image, many.image, "{aa}");
        assert_eq!(one.stats.camera_rays, many.stats.camera_rays, "{aa}");
        assert_eq!(one.stats.aa_corner_rays, many.stats.aa_corner_rays, "{aa}");
        assert_eq!(one.stats.aa_refine_rays, many.stats.aa_refine_rays, "{aa}");
        if aa.ends_with("uniform") {
            assert_eq!(many.stats.camera_rays, 16 * 16 * 3, "no extra camera rays");
        }
    }
}

#[test]
fn max_depth_zero_renders_mirrors_black_with_no_secondary_rays() {
    // A mirror filling the view and a glass sphere in front of it; the only light is
    // behind the camera, facing the mirror, so it is seen only by reflection.
    let text = [
        render_block(&["width=16", "height=16", "aa.samples=2"]),
        camera([0.0, 0.0, 5.0], [0.0; 3], &[]),
        mirror("mirror", [0.9; 3]),
        dielectric("glass", 1.5),
        quad_light([-3.0, -3.0, 6.0], [0.0, 6.0, 0.0], [6.0, 0.0, 0.0], 2.0),
        quad([-10.0, -10.0, 0.0], [20.0, 0.0, 0.0], [0.0, 20.0, 0.0], "mirror"),
        sphere([0.5, 0.3, 1.0], 0.4, "glass"),
    ]
    .concat();
    let zero = render_in(Path::new("."), &text, &["render.max_depth=0"]);
    // Exact: every pixel is 0 and no secondary ray is traced.
    assert!(zero.image.pixels.iter().all(|p| *p == Vec3::ZERO), "max_depth 0: mirrors must be black");
    assert_eq!(zero.stats.secondary_rays, 0);
    assert_eq!(zero.stats.camera_rays, 16 * 16 * 2);
    // The same scene with one bounce shows the light in the mirror (the test can fail).
    let one = render_in(Path::new("."), &text, &["render.max_depth=1"]);
    assert!(one.image.pixels.iter().filter(|p| p.x > 0.5).count() > 100, "max_depth 1 sees the light");
    assert!(one.stats.secondary_rays > 0);
}

/// The canonical floor scene with a red sphere, adaptive AA levels 2 to 4.
fn aa_scene() -> String {
    let floor = FloorScene {
        materials: vec![FloorScene::diffuse("white", [0.8; 3]), FloorScene::diffuse("red", [0.8, 0.1, 0.1])],
        spheres: vec![Sphere { center: [0.0, 0.5, 0.0], radius: 0.5, material: "red" }],
        ..FloorScene::default()
    };
    render_block(&["width=24", "height=24", "aa.max_level=4", "aa.min_level=2", "shadows.samples=4"]) + &floor.toml()
}

#[test]
fn adaptive_aa_with_eps_zero_and_eps_huge() {
    let dir = Path::new(".");
    let reference = render_in(dir, &aa_scene(), &["render.aa.samples=64"]);
    let huge = render_in(dir, &aa_scene(), &["render.aa.mode=adaptive", "render.aa.eps=1e9"]);
    // Exact: eps = 1e9 refines nothing.
    assert_eq!(huge.stats.aa_refine_rays, 0);
    assert_eq!(huge.stats.aa_refined_pixels, 0);
    let zero = render_in(dir, &aa_scene(), &["render.aa.mode=adaptive", "render.aa.eps=0"]);
    let pixels = 24 * 24u64;
    // Exact bounds: eps = 0 refines some pixels, each at most up to max_level (4 + 8 + 16).
    assert!(zero.stats.aa_refined_pixels > 0);
    assert!(zero.stats.aa_refine_rays <= zero.stats.aa_refined_pixels * 28);
    assert!(zero.stats.aa_refined_pixels <= pixels);
    // Tolerance: against 64 uniform samples, relative RMSE < 0.1 for eps = 1e9 (centre and
    // corners only: edge pixels are off by up to their contrast) and < 0.05 for eps = 0
    // (at least 28 stratified samples in every pixel that varies at all).
    let (eh, ez) = (rel_rmse(&huge.image, &reference.image), rel_rmse(&zero.image, &reference.image));
    eprintln!("eps 1e9: {eh:.3e}, eps 0: {ez:.3e}");
    assert!(eh < 0.1 && ez < 0.05, "eps 1e9: {eh}, eps 0: {ez}");
    assert!(ez < eh, "eps = 0 is at least as close to the reference as eps = 1e9");
}

#[test]
fn one_by_one_image_in_every_mode() {
    let dir = Path::new(".");
    // A 1° view of a fully lit patch of the floor, so every mode sees the same thing.
    let base = ["render.width=1", "render.height=1", "camera.fov_y=1", "camera.look_at=[2.5, 0, 2]"];
    let mut values = Vec::new();
    for extra in [
        vec!["render.aa.samples=16"],
        vec!["render.aa.mode=adaptive", "render.aa.eps=0"],
        vec!["render.aa.mode=adaptive", "render.aa.share_corners=false"],
        vec!["render.shadows.mode=adaptive", "render.shadows.probe=corners"],
        vec!["camera.aperture=0.1", "render.dof.samples=4"],
    ] {
        let sets: Vec<&str> = base.iter().copied().chain(extra.iter().copied()).collect();
        let out = render_in(dir, &aa_scene(), &sets);
        let p = only_pixel(&out);
        values.push(p);
        assert!(p.max_element() > 0.0, "{extra:?}: the pixel sees the lit floor");
    }
    // Tolerance: all modes agree within 5% (a 1° patch of a fully lit floor: what is left
    // is the error of 4 stratified quad-light samples per path against the exact value).
    for v in &values {
        assert!((v.x - values[0].x).abs() < 0.05 * values[0].x, "{values:?}");
    }
}

#[test]
fn no_lights_gives_only_background_and_no_shadow_rays() {
    let text = [
        render_block(&["width=24", "height=24", "aa.samples=3"]),
        camera([0.0, 1.0, 4.0], [0.0, 0.4, 0.0], &[]),
        background([0.2, 0.4, 0.8]),
        diffuse("white", [0.8; 3]),
        mirror("mirror", [1.0; 3]),
        material("glass", "dielectric", &["ior=1.5", "reflect_ratio=0.3"]),
        quad([-5.0, 0.0, -5.0], [10.0, 0.0, 0.0], [0.0, 0.0, 10.0], "white"),
        sphere([-0.6, 0.5, 0.0], 0.5, "mirror"),
        sphere([0.6, 0.5, 0.0], 0.5, "glass"),
    ]
    .concat();
    for mode in ["render.shadows.mode=uniform", "render.shadows.mode=adaptive"] {
        let out = render_in(Path::new("."), &text, &[mode]);
        let s = &out.stats;
        // Exact: no shadow, probe or penumbra rays without lights.
        assert_eq!((s.shadow_rays, s.shadow_corner_rays, s.penumbra_rays), (0, 0, 0), "{mode}");
        // Every pixel is k × background with 0 ≤ k ≤ 1 (white mirror and glass weights sum
        // to at most 1): tolerance 1e-6 relative on the channel ratios, 1e-6 on k.
        let bg = Vec3::new(0.2, 0.4, 0.8);
        let mut dark = 0;
        for p in &out.image.pixels {
            let k = p.z / bg.z;
            assert!((0.0..=1.0 + 1e-6).contains(&k), "{mode}: pixel {p}");
            assert!((*p - bg * k).abs().max_element() <= 1e-6 * bg.z, "{mode}: pixel {p} is not a multiple of {bg}");
            dark += (k == 0.0) as usize;
        }
        assert!(dark > 0, "{mode}: the diffuse floor is black");
    }
}

#[test]
fn no_objects_gives_only_background() {
    let text = [
        render_block(&["width=16", "height=12", "aa.samples=3", "dof.samples=2"]),
        camera([0.0, 1.0, 4.0], [0.0, 0.4, 0.0], &["aperture=0.1"]),
        background([0.1, 0.2, 0.3]),
    ]
    .concat();
    let bg = Vec3::new(0.1, 0.2, 0.3);
    for extra in [vec![], vec!["render.aa.mode=adaptive", "render.aa.eps=0"], vec!["render.shadows.mode=adaptive"]] {
        let out = render_in(Path::new("."), &text, &extra);
        let s = &out.stats;
        // Exact: nothing but camera rays.
        assert_eq!((s.shadow_rays, s.shadow_corner_rays, s.penumbra_rays, s.secondary_rays), (0, 0, 0, 0));
        assert_eq!(s.aa_refine_rays, 0, "{extra:?}: a uniform image needs no refinement");
        // Tolerance: every pixel is the background within 1e-6 relative (the weights
        // 1/samples are rounded; the sum of 6 of them is 1 within a few ulps).
        for p in &out.image.pixels {
            assert!((*p - bg).abs().max_element() <= 1e-6 * bg.max_element(), "{extra:?}: pixel {p}");
        }
    }
    // A point light alone adds nothing either (it is invisible and lights nothing).
    let out = render_in(Path::new("."), &(text + &point_light([0.0, 2.0, 0.0], 9.0)), &[]);
    assert!(out.image.pixels.iter().all(|p| (*p - bg).abs().max_element() <= 1e-6 * bg.max_element()));
}
