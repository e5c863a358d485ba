//! The packet kernels give the same renders as single rays: same ray counts, and the
//! same radiance up to the order of floating-point sums (shadow rays are reordered).

mod support;

use support::*;

fn same_render(text: &str, sets: &[&str]) {
    let off = render_text(text, sets, 2);
    let mut with: Vec<&str> = sets.to_vec();
    with.push("render.packets=true");
    let on = render_text(text, &with, 2);
    assert_eq!(on.stats.kinds(), off.stats.kinds(), "same rays of every kind");
    for (a, b) in on.image.pixels.iter().zip(&off.image.pixels) {
        // Only summation order differs: relative 1e-5 is hundreds of ulps of slack.
        assert!((*a - *b).abs().max_element() <= 1e-5 * b.max_element().max(1e-3), "{a} vs {b}");
    }
    // The packet kernel did run.
    assert!(on.stats.stages.iter().all(|c| c.nodes == 0 || c.prims > 0));
}

#[test]
fn default_scene_with_packets() {
    same_render(wavetrace::DEFAULT_SCENE, &["render.width=40", "render.height=30", "render.aa.samples=4"]);
    same_render(
        wavetrace::DEFAULT_SCENE,
        &["render.width=40", "render.height=30", "render.aa.mode=adaptive", "render.shadows.mode=adaptive"],
    );
}

#[test]
fn bunny_with_packets() {
    let text =
        std::fs::read_to_string(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/bunny.toml")).unwrap();
    same_render(&text, &["render.width=32", "render.height=24", "render.aa.samples=2", "render.shadows.samples=2"]);
}
