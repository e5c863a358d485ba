//! Stage-level profiling: the counters add up, per-thread counters sum to the totals,
//! traversal work is counted (and not when switched off), and the trace is valid.

mod support;

use support::*;
use wavetrace::render::WAVE_RAYS;
use wavetrace::stats::{chrome_trace, Stage};
use wavetrace::{render, RenderOptions};

#[test]
fn stage_counts_chain_and_sum() {
    for sets in [
        &["render.width=40", "render.height=30"][..],
        &["render.width=40", "render.height=30", "render.aa.mode=adaptive", "render.shadows.mode=adaptive"],
    ] {
        let out = render_text(wavetrace::DEFAULT_SCENE, sets, 2);
        let s = &out.stats;
        let st = |x: Stage| *s.stage(x);
        // Kinds are disjoint and make up the total.
        assert_eq!(s.kinds().iter().map(|k| k.1).sum::<u64>(), s.total_rays());
        // 1:1 queues: everything generated is intersected, every hit is shaded.
        assert_eq!(st(Stage::Camera).rays_out, s.camera_rays + s.aa_corner_rays + s.aa_refine_rays);
        assert_eq!(st(Stage::Intersect).rays_in, st(Stage::Camera).rays_out + st(Stage::Scatter).rays_out);
        assert_eq!(st(Stage::Intersect).rays_out, st(Stage::Shade).rays_in);
        assert_eq!(st(Stage::Shadow).rays_in, s.shadow_rays);
        assert_eq!(st(Stage::Scatter).rays_out, s.secondary_rays);
        assert_eq!(st(Stage::ShadowCorner).rays_out, st(Stage::Penumbra).rays_in);
        // Film adds exactly what the stages sent it.
        assert_eq!(st(Stage::Film).rays_in, st(Stage::Film).rays_out);
        // Per-thread counters sum to the totals.
        let mut sum = wavetrace::stats::Stats::default();
        out.per_thread.iter().for_each(|t| sum.merge(t));
        assert_eq!(sum.total_rays(), s.total_rays());
        assert_eq!(sum.stages.map(|c| c.nodes), s.stages.map(|c| c.nodes));
        // Traversal work is counted: at least the root per ray.
        assert!(st(Stage::Intersect).nodes >= st(Stage::Intersect).rays_in, "{:?}", st(Stage::Intersect));
        assert!(st(Stage::Shadow).nodes >= st(Stage::Shadow).rays_in);
        // Queues stay bounded: one wave starts at most WAVE_RAYS camera rays.
        assert!(s.peak.rays > 0 && s.peak.rays <= WAVE_RAYS * (1 << 6), "{:?}", s.peak);
        assert!(s.queue_bytes > 0);
    }
}

#[test]
fn counters_can_be_switched_off_without_changing_the_image() {
    let scene = scene(wavetrace::DEFAULT_SCENE, &["render.width=40", "render.height=30"]);
    let on = render(&scene, &RenderOptions { threads: Some(2), ..Default::default() }).unwrap();
    let off = render(&scene, &RenderOptions { threads: Some(2), no_counters: true, ..Default::default() }).unwrap();
    assert_eq!(on.image, off.image);
    assert_eq!(off.stats.stages.iter().map(|c| c.nodes + c.prims).sum::<u64>(), 0);
    assert!(on.stats.stages.iter().map(|c| c.nodes).sum::<u64>() > 0);
}

#[test]
fn trace_has_one_span_per_stage_call_per_thread() {
    let scene = scene(wavetrace::DEFAULT_SCENE, &["render.width=40", "render.height=30"]);
    let out = render(&scene, &RenderOptions { threads: Some(2), trace: true, ..Default::default() }).unwrap();
    assert_eq!(out.spans.len(), 2);
    let json: serde_json::Value = serde_json::from_str(&chrome_trace(&out.spans)).unwrap();
    let events = json["traceEvents"].as_array().unwrap();
    let count = |name: &str| events.iter().filter(|e| e["name"] == name).count();
    // Intersect runs once per wave; shade once per wave too.
    assert!(count("intersect") > 0);
    assert_eq!(count("intersect"), count("shade"));
    for e in events {
        assert_eq!(e["ph"], "X");
        assert!(e["dur"].as_f64().unwrap() >= 0.0 && e["ts"].as_f64().unwrap() >= 0.0);
        assert!(e["tid"].as_u64().unwrap() < 2);
    }
    let none = render(&scene, &RenderOptions { threads: Some(2), ..Default::default() }).unwrap();
    assert!(none.spans.iter().all(|s| s.is_empty()), "no spans unless asked");
}

#[test]
fn queues_stay_bounded_however_deep_the_glass() {
    // Every dielectric hit splits a path in two; with 24 bounces a breadth-first wave
    // could hold millions of rays. Depth-first draining keeps one level of at most two
    // waves per bounce.
    let sets = ["render.width=24", "render.height=16", "render.max_depth=24", "render.aa.samples=64"];
    let out = render_text(wavetrace::DEFAULT_SCENE, &sets, 2);
    let s = &out.stats;
    assert!(s.secondary_rays > s.camera_rays, "the scene must actually split rays: {s:?}");
    assert!(s.peak.rays <= WAVE_RAYS, "one wave at a time: {}", s.peak.rays);
    let bound = 2 * (24 + 2) * 2 * WAVE_RAYS * 48 + (64 << 20);
    assert!(s.queue_bytes < bound, "{} bytes held, bound {bound}", s.queue_bytes);
    assert!(out.image.pixels.iter().all(|p| p.is_finite()));
}
