//! Adaptive anti-aliasing and adaptive soft shadows: where they refine, what they
//! cost, and that they converge to the uniform reference.

mod support;

use glam::Vec3;
use support::toml::{background, camera, diffuse, point_light, quad, quad_light, render_block, wall};
use support::*;
use wavetrace::film::Image;
use wavetrace::{render, RenderOptions};

/// A plane under a small, distant quad light, seen at an angle: smooth, unoccluded.
fn flat() -> String {
    [
        render_block(&["width=24", "height=16", "aa.mode=adaptive", "shadows.mode=adaptive", "shadows.samples=16"]),
        camera([0.0, 2.0, 4.0], [0.0; 3], &["fov_y=30.0"]),
        diffuse("white", [0.5; 3]),
        quad_light([-0.1, 20.0, -0.1], [0.2, 0.0, 0.0], [0.0, 0.0, 0.2], 2000.0),
        quad([-50.0, 0.0, -50.0], [0.0, 0.0, 100.0], [100.0, 0.0, 0.0], "white"),
    ]
    .concat()
}

#[test]
fn flat_lit_scene_casts_only_the_minimum() {
    let out = render_text(&flat(), &[], 2);
    let s = &out.stats;
    assert_eq!(s.aa_refined_pixels, 0, "no pixel of a flat scene needs refinement");
    assert_eq!(s.aa_refine_rays, 0);
    assert_eq!(s.camera_rays, 24 * 16, "one centre ray per pixel");
    assert_eq!(s.aa_corner_rays, 25 * 17, "the shared corner grid, traced once");
    assert_eq!(s.shadow_points, 24 * 16 + 25 * 17, "every camera hit is tested");
    assert_eq!(s.penumbra_points, 0, "no occluder: nothing in the penumbra");
    assert_eq!(s.penumbra_rays, 0);
    assert_eq!(s.shadow_corner_rays, 9 * s.shadow_points, "the default probe is the 3×3 grid");
    assert!(out.heat.level.iter().all(|&l| l == 0));
}

#[test]
fn unshared_corners_cost_four_per_pixel_and_give_the_same_image() {
    let shared = render_text(&flat(), &["render.aa.eps=0.001"], 2);
    let own = render_text(&flat(), &["render.aa.eps=0.001", "render.aa.share_corners=false"], 2);
    assert_eq!(own.stats.aa_corner_rays, 4 * 24 * 16, "the paper's 5 rays per pixel");
    assert_eq!(shared.image, own.image, "a corner's radiance depends only on the corner");
}

/// A lit plane that ends mid-image: above it, the constant background.
fn horizon() -> String {
    [
        render_block(&["width=20", "height=20", "aa.mode=adaptive", "aa.max_level=4"]),
        camera([0.0, 1.0, 4.0], [0.0, 1.0, 0.0], &["fov_y=40.0"]),
        background([0.2, 0.3, 0.4]),
        diffuse("white", [0.7; 3]),
        point_light([0.0, 3.0, 1.0], 5.0),
        quad([-3.0, 0.0, -3.0], [0.0, 0.0, 6.0], [6.0, 0.0, 0.0], "white"),
    ]
    .concat()
}

#[test]
fn eps_zero_refines_every_varying_pixel_to_the_last_level() {
    let out = render_text(&horizon(), &["render.aa.eps=0"], 2);
    let bg = Vec3::new(0.2, 0.3, 0.4);
    let (mut constant, mut refined) = (0, 0);
    for (i, &l) in out.heat.level.iter().enumerate() {
        if l == 0 {
            // Not refined: only pixels that see nothing but the background.
            assert!((out.image.pixels[i] - bg).abs().max_element() < 1e-6, "pixel {i} varies but was not refined");
            assert_eq!(out.heat.points[i], 0.0);
            constant += 1;
        } else {
            assert_eq!(l, 4, "pixel {i} stopped at level {l} with eps = 0");
            refined += 1;
        }
    }
    assert!(constant > 20 && refined > 100, "{constant} constant, {refined} refined");
}

#[test]
fn huge_eps_refines_nothing() {
    let out = render_text(&horizon(), &["render.aa.eps=1e9"], 2);
    assert_eq!(out.stats.aa_refined_pixels, 0);
    assert_eq!(out.stats.aa_refine_rays, 0);
}

/// An emitter facing the camera whose right edge (x = 0.3) falls inside pixel column 19
/// of 32.
fn edge() -> String {
    render_block(&["width=32", "height=8", "aa.mode=adaptive"]) + &wall(5.3, &["fov_y=7.5"])
}

#[test]
fn a_vertical_edge_refines_only_the_pixels_on_it() {
    let scene = scene(&edge(), &[]);
    // Find the column the edge x = 0.3 projects into, from the camera itself.
    let cam = &scene.camera;
    let half_w = cam.tan_half_fov * cam.aspect * 5.0;
    let col = ((0.3 + half_w) / (2.0 * half_w) * 32.0) as usize;
    assert!(col > 0 && col < 31);
    let out = render(&scene, &RenderOptions { threads: Some(2), ..Default::default() }).unwrap();
    for y in 0..8 {
        for x in 0..32 {
            let refined = out.heat.level[y * 32 + x] > 0;
            assert_eq!(refined, x == col, "pixel ({x}, {y}): refined = {refined}, edge column {col}");
        }
    }
}

/// Occluders wider than the spread of the corner rays at their height, so the corner
/// test is never fooled here (a small one is tested below).
fn blocks() -> String {
    let spheres = vec![Sphere::white([-1.0, 0.6, 0.3], 0.6), Sphere::white([1.0, 0.5, -0.5], 0.5)];
    let floor = FloorScene { spheres, ..FloorScene::overhead() };
    render_block(&["width=48", "height=36", "aa.samples=2", "shadows.samples=64"]) + &floor.toml()
}

fn penumbra_scene(sets: &[&str]) -> wavetrace::RenderOutput {
    render_text(&blocks(), sets, 2)
}

#[test]
fn adaptive_shadows_trace_the_uniform_rays_where_the_corners_disagree() {
    // A Phong highlight makes lit points use the sampled (not the analytic) unoccluded
    // value, so lit and penumbra points alike must reproduce uniform mode.
    let phong = ["materials.white.specular=[0.1, 0.1, 0.1]", "materials.white.shininess=8"];
    let uniform = penumbra_scene(&phong);
    let adaptive = penumbra_scene(&[phong[0], phong[1], "render.shadows.mode=adaptive"]);
    // Penumbra points trace exactly the uniform rays; lit points add the same samples
    // unoccluded. Only points where the corner test is fooled may differ, and with
    // occluders this large there are none: the images agree up to summation order.
    for (i, (a, b)) in uniform.image.pixels.iter().zip(&adaptive.image.pixels).enumerate() {
        assert!((*a - *b).abs().max_element() <= 1e-5 * a.max_element().max(1.0), "pixel {i}: {a} vs {b}");
    }
    let s = &adaptive.stats;
    assert!(s.penumbra_points > 0 && s.penumbra_points < s.shadow_points);
    assert_eq!(s.penumbra_rays, {
        // Every penumbra point casts at most `samples` rays.
        let r = s.penumbra_rays;
        assert!(r <= s.penumbra_points * 64);
        r
    });
    assert!(s.shadow_corner_rays + s.penumbra_rays < uniform.stats.shadow_rays, "adaptive must cast fewer shadow rays");
    assert_eq!(s.shadow_uniform_rays, uniform.stats.shadow_rays, "the uniform-equivalent count is exact");
    // Lambert: lit points use the exact polygon irradiance, so adaptive is closer to a
    // converged reference than uniform with the same sample count.
    let reference = penumbra_scene(&["render.shadows.samples=1024"]);
    let lambert_uniform = penumbra_scene(&[]);
    let lambert_adaptive = penumbra_scene(&["render.shadows.mode=adaptive"]);
    let (eu, ea) = (rmse(&lambert_uniform.image, &reference.image), rmse(&lambert_adaptive.image, &reference.image));
    assert!(ea < eu, "adaptive RMSE {ea} vs uniform {eu}");
    assert_eq!(lambert_adaptive.stats.shadow_uniform_rays, lambert_uniform.stats.shadow_rays);
}

#[test]
fn adaptive_aa_converges_to_the_uniform_reference() {
    // Errors in display values (clamped sRGB, as the PNG and eps see them).
    let go = |extra: &[&str]| -> Image {
        let mut sets = vec!["render.shadows.samples=4"];
        sets.extend_from_slice(extra);
        let mut img = render_text(&blocks(), &sets, 2).image;
        for p in &mut img.pixels {
            *p = Vec3::from_array(p.to_array().map(wavetrace::color::srgb_encode));
        }
        img
    };
    let reference = go(&["render.aa.samples=1024"]);
    let errs: Vec<f32> = [2, 4, 6]
        .iter()
        .map(|l| {
            let max = format!("render.aa.max_level={l}");
            rmse(&go(&["render.aa.mode=adaptive", "render.aa.eps=0", "render.aa.min_level=2", &max]), &reference)
        })
        .collect();
    // eps = 0 refines every varying pixel until two levels agree exactly: up to 4, 28
    // and 124 samples. The error must fall with the level.
    assert!(errs[1] < 0.8 * errs[0] && errs[2] < 0.8 * errs[1], "RMSE by level 2, 4, 6: {errs:?}");
    // The paper's setting beats a uniform 4-sample image.
    let paper = rmse(&go(&["render.aa.mode=adaptive", "render.aa.eps=0.01"]), &reference);
    let uniform4 = rmse(&go(&["render.aa.samples=4"]), &reference);
    assert!(paper < uniform4, "adaptive eps 0.01 RMSE {paper} vs uniform 4 spp {uniform4}");
}

#[test]
fn adaptive_and_variance_modes_are_bit_identical_across_thread_counts() {
    let size = ["render.width=40", "render.height=30"];
    let adaptive = ["render.aa.mode=adaptive", "render.shadows.mode=adaptive"];
    let variance =
        ["render.aa.mode=variance", "render.aa.samples=24", "render.aa.min_samples=6", "render.aa.threshold=0.02"];
    for mode in [&adaptive[..], &variance[..]] {
        let sets = [&size[..], mode].concat();
        let a = render_text(wavetrace::DEFAULT_SCENE, &sets, 1);
        let b = render_text(wavetrace::DEFAULT_SCENE, &sets, 2);
        let bits = |i: &Image| i.pixels.iter().flat_map(|p| p.to_array()).map(f32::to_bits).collect::<Vec<_>>();
        assert!(bits(&a.image) == bits(&b.image), "{mode:?}");
        assert_eq!(a.heat, b.heat);
        assert_eq!(a.stats.total_rays(), b.stats.total_rays());
        if mode == variance {
            // Some pixels stop after the first round and some go on: the test decides.
            assert!(a.heat.level.contains(&1) && a.heat.level.iter().any(|&r| r > 1), "{:?}", a.heat.level);
        }
    }
}

#[test]
fn variance_aa_stops_noiseless_pixels_at_the_first_round_and_threshold_zero_samples_all() {
    // The flat scene's lit Lambert points carry no noise (exact irradiance, no edge).
    let variance = ["render.aa.mode=variance", "render.aa.samples=32", "render.aa.min_samples=4"];
    let out = render_text(&flat(), &[&variance[..], &["render.shadows.mode=uniform"]].concat(), 2);
    assert_eq!(out.stats.camera_rays, 24 * 16 * 4, "one round of 4 in every pixel");
    assert!(out.heat.level.iter().all(|&r| r == 1));
    let all = render_text(&flat(), &[&variance[..], &["render.aa.threshold=0"]].concat(), 2);
    assert_eq!(all.stats.camera_rays, 24 * 16 * 32, "no pixel's error is below 0");
    assert!(all.heat.level.iter().all(|&r| r == 8), "rounds of 4 up to 32");
}

#[test]
fn auto_aa_renders_uniform_at_the_pilots_count_where_it_finds_no_noise_pinhole_or_lens() {
    let sets =
        ["render.aa.mode=auto", "render.aa.samples=32", "render.aa.min_samples=4", "render.shadows.mode=uniform"];
    let out = render_text(&flat(), &sets, 2);
    let c = out.auto.expect("auto mode reports its choice");
    // One pilot pixel per 8×8 block: the centres (4, 4), (12, 4), (20, 4), (4, 12), ...
    assert_eq!(c.pilot_pixels, 3 * 2);
    assert_eq!((c.chose, c.max, c.threshold), ("uniform", 4, 0.0), "{c:?}");
    assert_eq!(out.stats.camera_rays, 24 * 16 * 4 + 6 * 4, "the render and its pilot");
    let one = render_text(&flat(), &sets, 1);
    assert_eq!((&one.image, one.auto), (&out.image, Some(c)));
    // Uniform's own tiles: uniform mode's image at the chosen count, bit for bit.
    let uniform = render_text(&flat(), &["render.aa.mode=uniform", "render.aa.samples=4", sets[3]], 2);
    assert_eq!((uniform.image, uniform.heat.level), (out.image, out.heat.level));
    // A lens: the pilot decides there too (its rays go through the lens), and the flat
    // floor in focus has no noise to adapt to.
    let lens = ["camera.aperture=0.05", "camera.focus_distance=4"];
    let lens = render_text(&flat(), &[&sets[..], &lens].concat(), 2);
    let c = lens.auto.expect("auto mode reports its choice");
    assert_eq!((c.chose, c.pilot_pixels), ("uniform", 6), "{c:?}");
    assert_eq!(lens.stats.camera_rays, 24 * 16 * c.max as u64 + 6 * 4);
}

#[test]
fn auto_aa_at_samples_up_to_min_samples_is_uniform_without_a_pilot() {
    // No pilot could choose otherwise: uniform at `samples`, no pilot ray. One sample
    // under a min_samples of 2 once panicked in the pilot's arithmetic; auto's samples
    // may be below its pilot's (variance's may not).
    for (samples, min) in [(4, 4), (2, 2), (1, 2), (3, 4)] {
        let sets = [
            "render.aa.mode=auto".to_string(),
            format!("render.aa.samples={samples}"),
            format!("render.aa.min_samples={min}"),
            "render.shadows.mode=uniform".to_string(),
        ];
        let sets: Vec<&str> = sets.iter().map(|s| s.as_str()).collect();
        let out = render_text(&blocks(), &sets, 2);
        let c = out.auto.expect("auto mode reports its choice");
        assert_eq!((c.chose, c.max, c.pilot_pixels), ("uniform", samples, 0), "{c:?}");
        assert_eq!(out.stats.camera_rays, 48 * 36 * samples as u64, "no pilot rays");
        let uniform = format!("render.aa.samples={samples}");
        let uniform = render_text(&blocks(), &["render.aa.mode=uniform", &uniform, sets[3]], 2);
        assert_eq!(uniform.image, out.image, "{samples} samples");
    }
    // One sample more than min_samples leaves a choice: the pilot runs.
    let sets = ["render.aa.mode=auto", "render.aa.samples=5", "render.aa.min_samples=4", "render.shadows.mode=uniform"];
    let c = render_text(&blocks(), &sets, 2).auto.expect("auto mode reports its choice");
    assert!(c.pilot_pixels > 0, "{c:?}");
}

#[test]
fn auto_aa_renders_the_corner_method_where_a_lens_blurs_most_pixels_at_few_samples() {
    let lens = ["camera.aperture=0.5", "camera.focus_distance=100", "render.dof.samples=8"];
    let shadows = ["render.shadows.mode=uniform", "render.shadows.samples=4"];
    let auto = [&shadows[..], &["render.aa.mode=auto", "render.aa.samples=4", "render.aa.threshold=0.02"]].concat();
    let out = render_text(&blocks(), &[&auto[..], &lens].concat(), 2);
    let c = out.auto.expect("auto mode reports its choice");
    assert_eq!((c.chose, c.threshold, c.min_samples, c.max), ("corners", 0.02, 4, 4), "{c:?}");
    assert!(c.blurred >= 0.5, "{c:?}");
    // The corner method's image and rays, bit for bit: eps = threshold, the paper's
    // first stopping level 2, the last level log2(samples), shared corners.
    let corners = [&shadows[..], &["render.aa.mode=adaptive", "render.aa.eps=0.02", "render.aa.min_level=2"]].concat();
    let corners = render_text(&blocks(), &[&corners[..], &["render.aa.max_level=2"], &lens].concat(), 2);
    assert_eq!((&corners.image, corners.stats.camera_rays), (&out.image, out.stats.camera_rays));
    assert!(corners.stats.aa_refined_pixels > 0 && corners.stats.aa_refined_pixels < 48 * 36);
    let one = render_text(&blocks(), &[&auto[..], &lens].concat(), 1);
    assert_eq!((&one.image, one.auto), (&out.image, Some(c)));
    // Through a pinhole, at threshold 0 (samples everywhere), or with more samples than
    // the corner method wins at: no corners.
    let pinhole = render_text(&blocks(), &auto, 2).auto.expect("a choice");
    assert_eq!((pinhole.chose, pinhole.blurred), ("uniform", 0.0), "{pinhole:?}");
    let zero = render_text(&blocks(), &[&auto[..], &lens, &["render.aa.threshold=0"]].concat(), 2);
    assert_eq!(zero.auto.map(|c| c.chose), Some("uniform"));
    // Fewer lens samples a point than CORNER_LENS_SAMPLES: lens noise would decide the
    // corner test; uniform.
    let noisy = render_text(&blocks(), &[&auto[..], &lens, &["render.dof.samples=4"]].concat(), 2);
    assert_eq!(noisy.auto.map(|c| c.chose), Some("uniform"));
    let many = ["render.aa.samples=32", "render.aa.min_samples=16", "render.aa.threshold=0.0001"];
    let many = render_text(&blocks(), &[&auto[..], &lens, &many].concat(), 2).auto.expect("a choice");
    assert!(many.max > 4 && many.chose != "corners", "{many:?}");
}

#[test]
fn auto_aa_dithers_its_uniform_pass_only_at_few_samples() {
    let sets = ["render.aa.mode=auto", "render.aa.min_samples=4", "render.aa.threshold=0", "render.blue_noise=true"];
    let shadows = ["render.shadows.mode=uniform", "render.shadows.samples=4"];
    for (samples, dithered) in [(4, true), (8, false)] {
        let n = format!("render.aa.samples={samples}");
        let out = render_text(&blocks(), &[&sets[..], &shadows, &[&n]].concat(), 2);
        let c = out.auto.expect("auto mode reports its choice");
        assert_eq!((c.chose, c.max, c.dithered), ("uniform", samples, dithered), "{c:?}");
        assert_eq!(c.pilot_pixels, 0, "threshold 0 asks for samples everywhere: no pilot");
        let blue = format!("render.blue_noise={dithered}");
        let uniform = render_text(&blocks(), &[&shadows[..], &["render.aa.mode=uniform", &n, &blue]].concat(), 2);
        assert_eq!(uniform.image, out.image, "{samples} samples");
    }
}

#[test]
fn auto_aa_through_a_pinhole_renders_variance_where_the_pilot_finds_uneven_noise() {
    // Edges and 4-sample penumbrae over a flat floor: a few pixels hold the noise.
    let sets =
        ["render.aa.samples=64", "render.aa.min_samples=4", "render.aa.threshold=0.05", "render.shadows.samples=4"];
    let auto = render_text(&blocks(), &[&sets[..], &["render.aa.mode=auto"]].concat(), 2);
    let c = auto.auto.expect("auto mode reports its choice");
    assert_eq!(c.chose, "variance", "{c:?}");
    assert!(c.pilot_pixels > 0 && c.variance_spp <= 0.8 * c.uniform_spp.ceil(), "{c:?}");
    // 64 samples leave four rounds of 8: variance mode's rounds of 8 at the same
    // settings, bit for bit, beside the pilot's rays (4 samples a pilot pixel).
    assert_eq!(c.min_samples, 8, "{c:?}");
    let variance = ["render.aa.mode=variance", "render.aa.min_samples=8"];
    let variance = render_text(&blocks(), &[&sets[..], &variance].concat(), 2);
    assert_eq!(auto.image, variance.image);
    assert!(auto.stats.camera_rays > variance.stats.camera_rays);
}

#[test]
fn variance_aa_beats_uniform_at_equal_camera_rays_on_edges_and_penumbrae() {
    // Edges and 4-sample penumbrae: noise that is uneven across the image. With the
    // default 16-sample rounds, measured 0.63-0.78 of uniform's RMSE at thresholds
    // 0.01-0.1.
    fn sets<'a>(extra: &[&'a str]) -> Vec<&'a str> {
        [&["render.shadows.samples=4"][..], extra].concat()
    }
    let reference = render_text(&blocks(), &sets(&["render.aa.samples=1024"]), 2).image;
    let variance = render_text(
        &blocks(),
        &sets(&["render.aa.mode=variance", "render.aa.samples=256", "render.aa.threshold=0.05"]),
        2,
    );
    let camera = variance.stats.camera_rays;
    assert!(camera < 48 * 36 * 64, "variance spent {camera} camera rays, as much as uniform 64");
    let spp = (camera as f64 / (48.0 * 36.0)).ceil() as u32;
    let uniform = render_text(&blocks(), &sets(&[&format!("render.aa.samples={spp}")]), 2);
    let (ev, eu) = (rmse(&variance.image, &reference), rmse(&uniform.image, &reference));
    assert!(ev < eu, "variance RMSE {ev} vs uniform {spp} spp {eu} at more camera rays");
}

#[test]
fn variance_rounds_extend_one_stratified_sequence() {
    // Every pixel sampled to the end (threshold 0) in four rounds of 4: its 16 samples are
    // one stratified pattern, as uniform mode's 16 are, so the error is uniform's. With a
    // new 4-sample pattern per round it was 1.6x uniform's RMSE (fig02 at 128x96).
    let sets = |extra: &[&'static str]| [&["render.shadows.samples=4"][..], extra].concat();
    let reference = render_text(&blocks(), &sets(&["render.aa.samples=1024"]), 2).image;
    let rounds =
        ["render.aa.mode=variance", "render.aa.samples=16", "render.aa.min_samples=4", "render.aa.threshold=0"];
    let variance = render_text(&blocks(), &sets(&rounds), 2);
    assert!(variance.heat.level.iter().all(|&r| r == 4), "four rounds in every pixel");
    let uniform = render_text(&blocks(), &sets(&["render.aa.samples=16"]), 2);
    assert_eq!(variance.stats.camera_rays, uniform.stats.camera_rays);
    let (ev, eu) = (rmse(&variance.image, &reference), rmse(&uniform.image, &reference));
    assert!(ev < 1.15 * eu, "variance in rounds RMSE {ev} against uniform's {eu} at the same samples");
}

/// The paper's §5 failure: a small occluder straight between the floor and the middle
/// of a large light, that no ray to the light's corners passes near.
fn fooled_scene() -> String {
    let floor = FloorScene {
        position: [0.0, 2.5, 3.0],
        look_at: [0.0, 0.0, 0.0],
        fov_y: Some(20.0),
        spheres: vec![Sphere::white([0.0, 1.5, 0.0], 0.12)],
        ..FloorScene::default()
    };
    render_block(&["width=40", "height=40", "aa.samples=1", "shadows.mode=adaptive", "shadows.samples=64"])
        + &floor.toml()
}

#[test]
fn corner_test_is_fooled_by_a_small_occluder_and_the_options_catch_it() {
    let uniform = render_text(&fooled_scene(), &["render.shadows.mode=uniform"], 2);
    let fooled = |probe: &str| {
        let out = render_text(&fooled_scene(), &[&format!("render.shadows.probe={probe}")], 2);
        let n = out
            .image
            .pixels
            .iter()
            .zip(&uniform.image.pixels)
            .filter(|(a, b)| (**a - **b).abs().max_element() > 1e-4)
            .count();
        (n, out.stats)
    };
    let (corners, _) = fooled("corners");
    let (center, stats_center) = fooled("corners+center");
    let (jittered, _) = fooled("jittered");
    let (grid, stats_grid) = fooled("3x3");
    // The sphere's soft shadow covers most of the view, and four corner rays see it
    // almost nowhere: the plain test is fooled in most pixels.
    assert!(corners > 800, "the plain corner test should miss the occluder's soft shadow: {corners} of 1600");
    // The centre ray catches the points whose line to the light's centre meets the
    // sphere; jittered probes catch a random share of the rest.
    assert!(center < corners, "a fifth ray to the centre catches some: {center} vs {corners}");
    assert!(jittered < corners, "jittered probes catch some: {jittered} vs {corners}");
    assert!(grid < corners, "the 3×3 grid catches some: {grid} vs {corners}");
    assert_eq!(stats_grid.shadow_corner_rays, 9 * stats_grid.shadow_points);
    assert_eq!(stats_center.shadow_corner_rays, 5 * stats_center.shadow_points);
}

#[test]
fn a_light_probed_with_as_many_rays_as_samples_renders_as_uniform_mode() {
    // 4 samples against the 4 corner probes: adaptive mode samples the light as uniform
    // mode does, so the two images are the same bits, the rays the same, and the stats
    // count every (point, light) pair as sampled uniformly.
    let sets = ["render.shadows.samples=4", "render.shadows.probe=\"corners\""];
    let adaptive = render_text(&flat(), &sets, 2);
    let uniform = render_text(&flat(), &[sets[0], sets[1], "render.shadows.mode=uniform"], 2);
    let bits =
        |o: &wavetrace::RenderOutput| o.image.pixels.iter().map(|p| p.to_array().map(f32::to_bits)).collect::<Vec<_>>();
    assert_eq!(bits(&adaptive), bits(&uniform));
    assert_eq!(adaptive.stats.shadow_rays, uniform.stats.shadow_rays);
    assert_eq!((adaptive.stats.shadow_points, adaptive.stats.shadow_corner_rays), (0, 0));
    assert!(adaptive.stats.shadow_uniform_fallback > 0);
    // Five samples: the light is probed again.
    let probed = render_text(&flat(), &["render.shadows.samples=5", sets[1]], 2);
    assert!(probed.stats.shadow_points > 0 && probed.stats.shadow_uniform_fallback == 0);
}

#[test]
fn auto_shadows_are_adaptive_only_where_the_pilots_probes_save_rays() {
    use wavetrace::render::SHADOW_MARGIN;
    let mode = |m: &str, n: u32| {
        penumbra_scene(&[&format!("render.shadows.mode={m}"), &format!("render.shadows.samples={n}")])
    };
    // 64 samples a penumbra point against 9 probes: adaptive, with adaptive mode's image.
    let auto = mode("auto", 64);
    let c = auto.auto_shadows.clone().expect("auto shadows report their choice");
    assert_eq!(c.chose, "adaptive", "{c:?}");
    assert!(c.pilot_points > 0 && c.adaptive_rays as f64 <= SHADOW_MARGIN * c.uniform_rays as f64, "{c:?}");
    assert!(c.penumbra_fraction > 0.0 && c.penumbra_fraction < 1.0, "{c:?}");
    assert_eq!(auto.image, mode("adaptive", 64).image);
    assert_eq!(auto.image, penumbra_scene(&["render.shadows.mode=auto", "render.shadows.samples=64"]).image);
    // 12 samples: 9 probes save rays only below a penumbra fraction of 0.9 - 9/12 = 0.15,
    // which this scene's shadows exceed: uniform, with uniform mode's image.
    let auto = mode("auto", 12);
    let c = auto.auto_shadows.clone().expect("auto shadows report their choice");
    assert!(c.penumbra_fraction > 0.15, "{c:?}");
    assert_eq!(c.chose, "uniform", "{c:?}");
    assert!(c.adaptive_rays as f64 > SHADOW_MARGIN * c.uniform_rays as f64, "{c:?}");
    assert_eq!(auto.image, mode("uniform", 12).image);
    // 4 samples: fewer than the probes, so no pilot; uniform's image and rays.
    let (auto, uniform) = (mode("auto", 4), mode("uniform", 4));
    let c = auto.auto_shadows.clone().expect("auto shadows report their choice");
    assert_eq!((c.chose, c.pilot_points), ("uniform", 0), "{c:?}");
    assert_eq!((auto.image, auto.stats.total_rays()), (uniform.image, uniform.stats.total_rays()));
}

/// Root-mean-square error of the 2×2 block means of `a` against `b`'s (whole blocks).
fn block_rmse(a: &Image, b: &Image) -> f32 {
    let (w, h) = (a.width as usize, a.height as usize);
    let mut sum = 0.0;
    for by in 0..h / 2 {
        for bx in 0..w / 2 {
            let at = |img: &Image| {
                let p = |x: usize, y: usize| img.pixels[y * w + x];
                (p(2 * bx, 2 * by) + p(2 * bx + 1, 2 * by) + p(2 * bx, 2 * by + 1) + p(2 * bx + 1, 2 * by + 1)) / 4.0
            };
            sum += (at(a) - at(b)).length_squared();
        }
    }
    (sum / (3 * (w / 2) * (h / 2)) as f32).sqrt()
}

#[test]
fn blue_noise_keeps_each_pixels_error_and_cancels_it_within_blocks() {
    // The floor in a sphere's penumbra, seen from above (no edge in view), at 4 samples
    // a pixel and 4 shadow rays each: with `render.blue_noise` the four pixels of a 2×2
    // block draw complementary points of one sequence, so a pixel's error is what it was
    // (its own points are as stratified) but the block's mean error is smaller (the
    // errors are negatively correlated).
    let floor = FloorScene {
        position: [1.0, 2.5, 0.0],
        look_at: [1.0, 0.0, 0.001],
        fov_y: Some(18.0),
        spheres: vec![Sphere::white([0.0, 0.6, 0.0], 0.5)],
        ..FloorScene::default()
    };
    let scene = render_block(&["width=64", "height=64", "shadows.samples=4"]) + &floor.toml();
    let reference = render_text(&scene, &["render.aa.samples=1024"], 2).image;
    let (mut pixel, mut block) = ([0.0f32; 2], [0.0f32; 2]);
    for seed in 1..=4 {
        for (k, blue) in ["false", "true"].into_iter().enumerate() {
            let sets =
                [&format!("render.seed={seed}")[..], "render.aa.samples=4", &format!("render.blue_noise={blue}")];
            let image = render_text(&scene, &sets, 2).image;
            pixel[k] += rmse(&image, &reference);
            block[k] += block_rmse(&image, &reference);
        }
    }
    assert!(pixel[1] < 1.1 * pixel[0] && pixel[0] < 1.1 * pixel[1], "per-pixel RMSE {pixel:?} (plain, blue)");
    assert!(block[1] < 0.8 * block[0], "2×2 block means' RMSE {block:?} (plain, blue)");
}
