//! Shared fixtures for the integration tests: scene loading, renders, error metrics,
//! single rays through the stages, a seeded generator, the floor scene builder
//! ([`FloorScene`]), and scene text written table by table ([`toml`]).
//!
//! A single-file test reaches it with `mod support;`, a folder test crate with
//! `#[path = "../support/mod.rs"] mod support;`.
#![allow(dead_code)]

mod floor;
pub mod toml;

// Not every test crate uses every part of the builder.
#[allow(unused_imports)]
pub use floor::{FloorScene, Quad, QuadLight, Sphere};

use glam::Vec3;
use std::path::Path;
use wavetrace::accel::tracer::{Coherence, Kernel, Tracer};
use wavetrace::accel::{Ray, Traversal};
use wavetrace::film::Image;
use wavetrace::queue::{FilmQueue, HitQueue, IndexQueue, RayQueue, ShadowPointQueue, ShadowQueue, SurfaceQueue};
use wavetrace::scene::{load, SceneSource};
use wavetrace::stages::{intersect, scatter, shade};
use wavetrace::{render, RenderOptions, RenderOutput, Scene};

/// Loads scene text with meshes relative to `dir`.
pub fn try_scene_in(dir: &Path, text: &str, sets: &[&str]) -> wavetrace::Result<Scene> {
    let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
    load(&SceneSource::from_text("<test>", text, dir), &sets)
}

/// Loads scene text with meshes relative to `dir`; panics with the text if it fails.
pub fn scene_in(dir: &Path, text: &str, sets: &[&str]) -> Scene {
    try_scene_in(dir, text, sets).unwrap_or_else(|e| panic!("scene failed to load: {e}\n{text}"))
}

/// Loads scene text (meshes relative to the crate's scenes/ folder).
pub fn scene(text: &str, sets: &[&str]) -> Scene {
    scene_in(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes"), text, sets)
}

/// Renders scene text with overrides on `threads` threads.
pub fn render_text(text: &str, sets: &[&str], threads: usize) -> RenderOutput {
    render(&scene(text, sets), &RenderOptions { threads: Some(threads), ..Default::default() }).expect("render")
}

/// Root-mean-square difference over all pixels and channels.
pub fn rmse(a: &Image, b: &Image) -> f32 {
    assert_eq!((a.width, a.height), (b.width, b.height));
    let sum: f32 = a.pixels.iter().zip(&b.pixels).map(|(p, q)| (*p - *q).length_squared()).sum();
    (sum / (3 * a.pixels.len()) as f32).sqrt()
}

/// The single pixel of a 1×1 render.
pub fn only_pixel(out: &RenderOutput) -> Vec3 {
    assert_eq!(out.image.pixels.len(), 1);
    out.image.pixels[0]
}

/// Irradiance at `p` (normal `n`) from a uniform polygon of radiance `l`, by Lambert's
/// formula: E = L/2 Σ acos(v_i·v_j) (n · normalize(v_i × v_j)), v unit vectors to vertices.
pub fn polygon_irradiance(p: Vec3, n: Vec3, verts: &[Vec3], l: f32) -> f32 {
    let mut sum = 0.0f64;
    for i in 0..verts.len() {
        let a = (verts[i] - p).normalize().as_dvec3();
        let b = (verts[(i + 1) % verts.len()] - p).normalize().as_dvec3();
        let c = a.cross(b);
        sum += a.dot(b).clamp(-1.0, 1.0).acos() * n.as_dvec3().dot(c.normalize());
    }
    (0.5 * l as f64 * sum.abs()) as f32
}

/// A diffuse plane y = 0 of albedo 0.5, 100 units wide: a floor for point measurements.
pub const PLANE: &str = r#"
[materials.white]
type = "diffuse"
color = [0.5, 0.5, 0.5]
[[objects]]
type = "quad"
corner = [-50, 0, -50]
edge_u = [100, 0, 0]
edge_v = [0, 0, 100]
material = "white"
"#;

/// The radiance a probe camera sees at `p` on [`PLANE`] under `lights` (TOML), one
/// pixel, one camera sample, `shadow_samples` shadow rays per light in shadow `mode`.
pub fn measure_plane(lights: &str, p: Vec3, shadow_samples: u32, mode: &str) -> Vec3 {
    let text = format!("{}{PLANE}{lights}", probe_camera(p + Vec3::new(0.0, 3.0, 4.0), p));
    let samples = format!("render.shadows.samples={shadow_samples}");
    let mode = format!("render.shadows.mode={mode}");
    let out = render_text(&text, &["render.width=1", "render.height=1", "render.aa.samples=1", &samples, &mode], 1);
    only_pixel(&out)
}

/// A camera that sees only a tiny patch around `p` from `from`, for point measurements.
pub fn probe_camera(from: Vec3, p: Vec3) -> String {
    format!(
        "[camera]\nposition = [{}, {}, {}]\nlook_at = [{}, {}, {}]\nup = [0, 0, 1]\nfov_y = 0.001\n",
        from.x, from.y, from.z, p.x, p.y, p.z
    )
}

// ---------------------------------------------------------------------------------------
// Single rays through the stages

/// A queue of one ray from `o` along `d` (normalised), slot 0, weight 1, depth 0.
pub fn one_ray(o: Vec3, d: Vec3) -> RayQueue {
    let mut q = RayQueue::default();
    q.push(o, d.normalize(), 0, Vec3::ONE, 0, 7, 0, 0.0, None);
    q
}

/// Pushes rays through intersect → shade → scatter: returns the next wave, the hits,
/// and the shade stage's shadow queue and film queue.
pub fn step_all(scene: &Scene, rays: &RayQueue) -> (RayQueue, HitQueue, ShadowQueue, FilmQueue) {
    let mut hits = HitQueue::default();
    let (mut shadow, mut spec, mut film) = (ShadowQueue::default(), IndexQueue::default(), FilmQueue::default());
    let mut tracer = Tracer::new(&scene.accel, Kernel::render(scene.settings.packets), false);
    intersect::intersect(&mut tracer, rays, Coherence::Camera, &mut hits);
    let (mut points, mut surfaces) = (ShadowPointQueue::default(), SurfaceQueue::default());
    let out = shade::Shaded {
        shadow: &mut shadow,
        points: &mut points,
        surfaces: &mut surfaces,
        specular: &mut spec,
        film: &mut film,
    };
    shade::shade(scene, scene.settings.shadow_mode, rays, &hits, out);
    let mut next = RayQueue::default();
    scatter::scatter(scene, rays, &hits, &spec, &mut next, &mut ShadowQueue::default());
    (next, hits, shadow, film)
}

/// Pushes rays through intersect → shade → scatter: returns the next wave and the hits.
pub fn step(scene: &Scene, rays: &RayQueue) -> (RayQueue, HitQueue) {
    let (next, hits, _, _) = step_all(scene, rays);
    (next, hits)
}

/// The closest hit `(t, primitive)` of one ray, straight from the BVH.
pub fn closest(scene: &Scene, o: Vec3, d: Vec3) -> Option<(f32, u32)> {
    scene.accel.closest::<false>(Ray::new(o, d, 0.0, f32::INFINITY), &mut Traversal::default())
}

/// A tiny deterministic generator for test directions and points.
pub struct Lcg(pub u64);

impl Lcg {
    /// Uniform in [0, 1).
    pub fn next(&mut self) -> f32 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((self.0 >> 40) as f32) / (1u64 << 24) as f32
    }

    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.next()
    }

    /// A uniform unit vector.
    pub fn unit(&mut self) -> Vec3 {
        loop {
            let v = Vec3::new(self.range(-1.0, 1.0), self.range(-1.0, 1.0), self.range(-1.0, 1.0));
            let l = v.length_squared();
            if l > 1e-4 && l <= 1.0 {
                return v / l.sqrt();
            }
        }
    }
}
