//! The scene features that should decide which sampler wins, measured per scene: most
//! from counters of renders the study makes anyway, the rest from one pinhole ray per
//! pixel through the scene's BVH (no shading, a few milliseconds).

use serde::Serialize;

use super::Row;
use crate::accel::{Traversal, NO_LIGHT};
use crate::scene::Scene;
use crate::stages::focus::{coc_pixels, pinhole_depth};

/// The features of one scene. `None` where the renders it is read from were not made
/// (the method was skipped or not asked for).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Features {
    /// Edge density: the fraction of pixels adaptive AA's corner test refined
    /// (`aa_refined_pixels / aa_pixels`), from adaptive-aa's render with the smallest eps
    /// (the most sensitive test; the first such render of the grid).
    pub edge_density: Option<f64>,
    /// Penumbra fraction: of the (shading point, area light) pairs the shadow-corner test
    /// decided, the share it sent to the penumbra queue (`penumbra_points /
    /// shadow_points`), from adaptive-shadows' render with the most shadow samples (the
    /// first such). 0 when the scene has no area light.
    pub penumbra_fraction: Option<f64>,
    /// Circle-of-confusion spread: the fraction of pixels whose centre's first hit is
    /// blurred over a radius above one pixel (`stages::focus::coc_pixels`; a miss counts
    /// at infinite depth). 0 for a pinhole camera.
    pub coc_spread: f64,
    /// The mean circle-of-confusion radius in pixels over the same pixels.
    pub coc_mean_px: f64,
    /// Glossy fraction: the fraction of pixels whose centre's first hit is a rough
    /// material (a microfacet conductor, dielectric or plastic), whose light samples are
    /// the noisy part of a Whitted render.
    pub glossy_fraction: f64,
    /// Noise: the relative MSE of uniform's render at the first target's camera samples
    /// and its fewest shadow rays: how far from converged a cheap render is.
    pub noise: Option<f64>,
    /// Noise unevenness: the share of that render's squared error held by its worst 10%
    /// of pixels (0.1: even; near 1: in a few pixels, where a variance-driven sampler
    /// should gain most).
    pub noise_unevenness: Option<f64>,
    /// The scene is path traced (`render.transport` path or direct).
    pub path: bool,
}

/// The features read from the scene's geometry alone: (glossy fraction, CoC spread,
/// mean CoC radius), from one pinhole ray through each pixel centre.
pub fn probe(scene: &Scene) -> (f64, f64, f64) {
    let (w, h) = (scene.settings.width, scene.settings.height);
    let cam = &scene.camera;
    let mut trav = Traversal::default();
    let (mut glossy, mut blurred, mut coc_sum) = (0u64, 0u64, 0.0f64);
    for y in 0..h {
        for x in 0..w {
            let (depth, hit) = pinhole_depth(scene, x, y, &mut trav);
            if let Some(id) = hit {
                let rough = scene.accel.light(id) == NO_LIGHT
                    && scene.materials.get(scene.accel.material(id) as usize).is_some_and(|m| m.roughness().is_some());
                glossy += rough as u64;
            }
            if cam.aperture > 0.0 {
                let r = coc_pixels::<f32>(scene, depth);
                if r.is_finite() {
                    blurred += (r > 1.0) as u64;
                    coc_sum += r as f64;
                }
            }
        }
    }
    let n = (w as f64 * h as f64).max(1.0);
    (glossy as f64 / n, blurred as f64 / n, coc_sum / n)
}

/// Fills the features read from the study's renders of one scene: `rows` are the
/// scene's rows, `first_target_spp` the camera samples of its first target (None when
/// the targets were given: the noise is then read at uniform's fewest samples).
pub fn from_rows(f: &mut Features, rows: &[Row], first_target_spp: Option<u32>) {
    let of = |name: &'static str| rows.iter().filter(move |r| r.method == name);
    let eps = |r: &Row| r.param("render.aa.eps").and_then(|v| v.parse::<f64>().ok()).unwrap_or(f64::INFINITY);
    let sharpest = of("adaptive-aa").fold(None::<&Row>, |best, r| match best {
        Some(b) if eps(b) <= eps(r) => Some(b),
        _ => Some(r),
    });
    f.edge_density = sharpest.map(|r| ratio(r.counters.aa_refined_pixels, r.counters.aa_pixels));
    let spp = |r: &Row| r.param("render.aa.samples").and_then(|v| v.parse::<u32>().ok()).unwrap_or(u32::MAX);
    let shadow = |r: &Row| r.param("render.shadows.samples").and_then(|v| v.parse::<u32>().ok()).unwrap_or(u32::MAX);
    // The most shadow samples: with few, probing costs more than sampling and the test
    // falls back to uniform sampling, deciding nothing.
    let most = of("adaptive-shadows").fold(None::<&Row>, |best, r| match best {
        Some(b) if shadow(b) >= shadow(r) => Some(b),
        _ => Some(r),
    });
    f.penumbra_fraction = most.map(|r| ratio(r.counters.penumbra_points, r.counters.shadow_points));
    let wanted = first_target_spp.or_else(|| of("uniform").map(spp).min());
    let cheap = of("uniform").filter(|r| Some(spp(r)) == wanted).min_by_key(|r| shadow(r));
    f.noise = cheap.map(|r| r.metrics.rel_mse);
    f.noise_unevenness = cheap.map(|r| r.worst10_share);
}

/// a / b, 0 when b is 0.
fn ratio(a: u64, b: u64) -> f64 {
    if b == 0 {
        0.0
    } else {
        a as f64 / b as f64
    }
}
