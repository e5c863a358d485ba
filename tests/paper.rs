//! The paper's future work (§5), as options: DOF-aware adaptive anti-aliasing
//! (`render.aa.dof_aware`) and early stopping of penumbra points
//! (`render.shadows.tolerance`). Every scene here is tiny, so the file runs in a few
//! seconds in release.

mod support;

use support::toml::{camera, diffuse, mirror, quad, quad_light, render_block, wall};
use support::*;
use wavetrace::film::Image;
use wavetrace::stats::{Report, SceneReport};
use wavetrace::tools::sweep::Mode;

fn bits(i: &Image) -> Vec<u32> {
    i.pixels.iter().flat_map(|p| p.to_array()).map(f32::to_bits).collect()
}

/// Two emitters facing the camera, both with a vertical edge: the left one on the focus
/// plane (5 units away, sharp), the right one 25 units away (blurred over 2.4
/// pixels with the aperture below). Pixel columns 0..16 see only the near one or black.
fn two_edges() -> String {
    [
        render_block(&["width=32", "height=16", "aa.mode=adaptive", "aa.eps=0.01", "aa.max_level=4", "dof.samples=8"]),
        wall(4.2, &["fov_y=30.0", "aperture=0.5"]),
        quad_light([5.5, -20.0, -20.0], [20.0, 0.0, 0.0], [0.0, 40.0, 0.0], 0.8),
    ]
    .concat()
}

/// Refined pixels in columns `cols` of a 32-wide image.
fn refined(out: &wavetrace::RenderOutput, cols: std::ops::Range<usize>) -> usize {
    out.heat.level.iter().enumerate().filter(|&(i, &l)| l > 0 && cols.contains(&(i % 32))).count()
}

#[test]
fn dof_aware_changes_nothing_with_a_pinhole() {
    let plain = render_text(&two_edges(), &["camera.aperture=0"], 2);
    let aware = render_text(&two_edges(), &["camera.aperture=0", "render.aa.dof_aware=true"], 2);
    assert!(bits(&plain.image) == bits(&aware.image), "a pinhole has no blur: the image must not change");
    assert_eq!(plain.stats.kinds(), aware.stats.kinds(), "no depth probes, no other rays");
    assert_eq!(aware.stats.dof_probe_rays, 0);
    assert_eq!(plain.heat, aware.heat);
}

#[test]
fn dof_aware_refines_the_sharp_edge_and_not_the_blurred_one() {
    let plain = render_text(&two_edges(), &[], 2);
    let aware = render_text(&two_edges(), &["render.aa.dof_aware=true"], 2);
    // The sharp edge: every lens ray of an in-focus film point meets the same point of
    // the emitter, so one lens ray decides exactly as eight do.
    let (sharp_plain, sharp_aware) = (refined(&plain, 0..16), refined(&aware, 0..16));
    assert!(sharp_plain >= 16, "the in-focus edge is refined in every row: {sharp_plain}");
    assert_eq!(sharp_aware, sharp_plain, "DOF-aware keeps the in-focus edge's refinement");
    // The blurred edge: 2.4 pixels of blur, past dof_radius = 2, so never refined.
    let (blur_plain, blur_aware) = (refined(&plain, 16..32), refined(&aware, 16..32));
    assert!(blur_plain > 16, "plain adaptive refines the blurred edge too: {blur_plain}");
    assert_eq!(blur_aware, 0, "DOF-aware leaves blurred pixels alone");
    // Fewer rays in total, depth probes included (one per corner and centre).
    assert_eq!(aware.stats.dof_probe_rays, 33 * 17 + 32 * 16);
    assert!(
        aware.stats.total_rays() * 2 < plain.stats.total_rays(),
        "{} vs {}",
        aware.stats.total_rays(),
        plain.stats.total_rays()
    );
    // Fewer lens rays where in focus: the centres of the left half need one each.
    assert!(aware.stats.camera_rays < plain.stats.camera_rays);
}

#[test]
fn dof_aware_error_stays_close_to_plain_adaptive() {
    let reference = render_text(&two_edges(), &["render.aa.mode=uniform", "render.aa.samples=256"], 2);
    let plain = render_text(&two_edges(), &[], 2);
    let aware = render_text(&two_edges(), &["render.aa.dof_aware=true"], 2);
    let few = render_text(&two_edges(), &["render.aa.mode=uniform", "render.aa.samples=1"], 2);
    let (ep, ea, ef) = (
        rmse(&plain.image, &reference.image),
        rmse(&aware.image, &reference.image),
        rmse(&few.image, &reference.image),
    );
    // Blurred pixels keep their centre and corner estimate (8 lens rays each), so the
    // error grows, but stays well below that of one uniform sample per pixel.
    assert!(ea < 2.0 * ep + 0.002, "DOF-aware RMSE {ea} vs plain adaptive {ep}");
    assert!(ea < 0.5 * ef, "DOF-aware RMSE {ea} vs uniform 1 spp {ef}");
}

#[test]
fn dof_aware_gives_mirrors_and_glass_every_lens_sample() {
    // A mirror in focus shows the blurred scene behind the camera's focus plane: its
    // first hit is sharp, what it reflects is not. It must keep all lens samples.
    let wall = |material: String| {
        [
            render_block(&["width=8", "height=8", "aa.mode=adaptive", "aa.eps=1e9", "dof.samples=6"]),
            camera([0.0, 0.0, 5.0], [0.0; 3], &["fov_y=5.0", "aperture=0.2"]),
            material,
            quad([-5.0, -5.0, 0.0], [10.0, 0.0, 0.0], [0.0, 10.0, 0.0], "m"),
        ]
        .concat()
    };
    let out = render_text(&wall(mirror("m", [1.0; 3])), &["render.aa.dof_aware=true"], 1);
    assert_eq!(out.stats.camera_rays, 64 * 6, "every centre on the mirror keeps its 6 lens rays");
    let out = render_text(&wall(diffuse("m", [1.0; 3])), &["render.aa.dof_aware=true"], 1);
    assert_eq!(out.stats.camera_rays, 64, "a diffuse surface in focus needs one lens ray per centre");
}

#[test]
fn dof_aware_and_early_stopping_are_bit_identical_across_threads() {
    let sets = [
        "render.width=40",
        "render.height=30",
        "render.aa.mode=adaptive",
        "render.aa.dof_aware=true",
        "render.shadows.mode=adaptive",
        "render.shadows.samples=64",
        "render.shadows.tolerance=0.1",
        "render.shadows.batch=4",
        "camera.aperture=0.15",
        "render.dof.samples=6",
    ];
    let a = render_text(wavetrace::DEFAULT_SCENE, &sets, 1);
    let b = render_text(wavetrace::DEFAULT_SCENE, &sets, 2);
    assert!(bits(&a.image) == bits(&b.image));
    assert_eq!(a.heat, b.heat);
    assert_eq!(a.stats.kinds(), b.stats.kinds());
    assert_eq!(a.stats.penumbra_stopped, b.stats.penumbra_stopped);
    assert!(a.stats.dof_probe_rays > 0 && a.stats.penumbra_stopped > 0, "both options were in effect");
}

/// A floor under a quad light with two occluders: wide penumbrae.
fn shadows() -> String {
    let spheres = vec![Sphere::white([-0.8, 0.9, 0.3], 0.5), Sphere::white([0.9, 0.5, -0.4], 0.4)];
    let floor = FloorScene { spheres, ..FloorScene::overhead() };
    render_block(&["width=40", "height=30", "aa.samples=2", "shadows.mode=adaptive", "shadows.samples=64"])
        + &floor.toml()
}

#[test]
fn early_stopping_that_never_stops_is_the_fixed_n_image() {
    let fixed = render_text(&shadows(), &[], 2);
    for batch in ["render.shadows.batch=16", "render.shadows.batch=5", "render.shadows.batch=64"] {
        // No Wilson interval after at most 64 rays is narrower than ±1e-6.
        let never = render_text(&shadows(), &["render.shadows.tolerance=1e-6", batch], 2);
        assert!(bits(&fixed.image) == bits(&never.image), "{batch}: the image must be the fixed-n one, bit for bit");
        assert_eq!(fixed.stats.kinds(), never.stats.kinds(), "{batch}");
        assert_eq!(never.stats.penumbra_stopped, 0);
        assert_eq!(never.stats.penumbra_saved_rays, 0);
    }
}

#[test]
fn early_stopping_saves_rays_at_a_bounded_error() {
    let reference = render_text(&shadows(), &["render.shadows.mode=uniform", "render.shadows.samples=1024"], 2);
    let fixed = render_text(&shadows(), &[], 2);
    let early = render_text(&shadows(), &["render.shadows.tolerance=0.1"], 2);
    let (f, e) = (&fixed.stats, &early.stats);
    assert!(e.penumbra_stopped > 0 && e.penumbra_stopped <= e.penumbra_points);
    assert_eq!(e.penumbra_points, f.penumbra_points, "the probes decide the same points");
    assert_eq!(e.penumbra_rays + e.penumbra_saved_rays, f.penumbra_rays, "traced + saved = the fixed-n rays");
    assert!(
        e.penumbra_rays * 10 < f.penumbra_rays * 9,
        "at least 10% saved: {} of {}",
        e.penumbra_rays,
        f.penumbra_rays
    );
    let (ef, ee) = (rmse(&fixed.image, &reference.image), rmse(&early.image, &reference.image));
    let uniform4 = render_text(&shadows(), &["render.shadows.mode=uniform", "render.shadows.samples=4"], 2);
    let e4 = rmse(&uniform4.image, &reference.image);
    assert!(ee < 3.0 * ef, "early stopping RMSE {ee} vs fixed n {ef}");
    assert!(ee < 0.5 * e4, "early stopping RMSE {ee} vs uniform 4 samples {e4}");
    // The report carries the counts.
    let s = load_default_settings(&["render.shadows.tolerance=0.1"]);
    let report = Report::new(&s, 1.0, e, std::slice::from_ref(e), scene_report());
    let stop = report.penumbra_early_stop.expect("reported when the tolerance is on");
    assert_eq!(
        (stop.points, stop.stopped, stop.rays, stop.saved),
        (e.penumbra_points, e.penumbra_stopped, e.penumbra_rays, e.penumbra_saved_rays)
    );
    let off = Report::new(&load_default_settings(&[]), 1.0, f, std::slice::from_ref(f), scene_report());
    assert!(off.penumbra_early_stop.is_none());
}

fn load_default_settings(sets: &[&str]) -> wavetrace::scene::Settings {
    scene(&shadows(), sets).settings
}

fn scene_report() -> SceneReport {
    SceneReport {
        primitives: 0,
        triangles: 0,
        degenerate_triangles: 0,
        bvh_seconds: 0.0,
        load_seconds: 0.0,
        outside_paths: Vec::new(),
        notes: Vec::new(),
    }
}

#[test]
fn options_only_take_effect_where_they_mean_something() {
    let s = |sets: &[&str]| scene(&two_edges(), sets).settings;
    assert_eq!(s(&["render.aa.dof_aware=true"]).dof_radius, Some(2.0));
    assert_eq!(s(&["render.aa.dof_aware=true", "camera.aperture=0"]).dof_radius, None, "a pinhole");
    assert_eq!(s(&["render.aa.dof_aware=true", "render.aa.mode=uniform"]).dof_radius, None, "uniform AA");
    assert!(s(&["render.shadows.tolerance=0.1"]).penumbra_stop.is_none(), "uniform shadows");
    let stop = s(&["render.shadows.mode=adaptive", "render.shadows.tolerance=0.1", "render.shadows.batch=8"]);
    assert_eq!(stop.penumbra_stop.map(|p| (p.tolerance, p.batch)), Some((0.1, 8)));
    // Sweeps give each extension its own series.
    assert_eq!(Mode::of(&s(&[])), Mode::Adaptive);
    assert_eq!(Mode::of(&s(&["render.aa.dof_aware=true"])), Mode::DofAware);
    assert_eq!(Mode::of(&s(&["render.shadows.mode=adaptive", "render.shadows.tolerance=0.1"])), Mode::EarlyStop);
    assert_eq!(
        Mode::of(&s(&["render.aa.dof_aware=true", "render.shadows.mode=adaptive", "render.shadows.tolerance=0.1"])),
        Mode::DofAwareEarlyStop
    );
    assert_eq!(Mode::of(&s(&["render.aa.mode=uniform"])), Mode::Uniform);
}

#[test]
fn early_stopping_orders_any_sample_count() {
    // Counts that are powers of two (a net: one sample per cell of a 2^a × 2^b grid) and
    // counts that are not (cells in sample order): each point's cells must be distinct
    // for the progressive order, at every count.
    for n in ["1", "3", "8", "12", "128"] {
        let samples = format!("render.shadows.samples={n}");
        let fixed = render_text(&shadows(), &[samples.as_str()], 2);
        let early =
            render_text(&shadows(), &[samples.as_str(), "render.shadows.tolerance=0.2", "render.shadows.batch=2"], 2);
        let (f, e) = (&fixed.stats, &early.stats);
        assert_eq!(e.penumbra_rays + e.penumbra_saved_rays, f.penumbra_rays, "{n}: traced + saved = the fixed-n rays");
        assert!(early.image.pixels.iter().all(|p| p.is_finite()), "{n}");
    }
}
