//! Quad-light sampling shared by the stages that light a diffuse point: the stratified
//! samples of uniform mode and of the penumbra, the exact irradiance of the adaptive
//! test's lit points, and where shadow rays stop.

use glam::Vec3;

use crate::sampling::{cmj_grid, dim, hash_lanes, sobol_owen_lanes};
use crate::scene::{Light, Scene};
use crate::simd::{Real, Word, V3};
use crate::surface::{diffuse_brdf, Surface};

/// Shadow rays stop this fraction short of the light, so a surface the light lies on
/// (a lamp flush with a ceiling) does not shadow it.
pub const SHADOW_TMAX_SCALE: f32 = 1.0 - 1e-4;

/// The seed of quad light `li`'s sample sequence seen from the points named by `key`.
#[inline]
pub fn light_seed(key: u32, li: usize) -> u32 {
    light_seed_lanes(key, li as u32)
}

/// [`light_seed`] on lanes of keys and light indices.
#[inline(always)]
pub fn light_seed_lanes<W: Word>(key: W, li: W) -> W {
    hash_lanes([key, li, W::splat(dim::LIGHT)])
}

/// The grid of `n` light samples early stopping orders them on ([`quad_light_samples`]'s
/// cells): for n = 2^k a 2^⌈k/2⌉ × 2^⌊k/2⌋ grid, in which a point's samples (a (0, k, 2)-net)
/// hold one cell each; else the [`cmj_grid`] of n, whose first n cells they are given in
/// sample order.
pub fn sample_grid(n: u32) -> (u32, u32) {
    if n.is_power_of_two() {
        let k = n.trailing_zeros();
        (1 << k.div_ceil(2), 1 << (k / 2))
    } else {
        cmj_grid(n)
    }
}

/// Visits the stratified samples of quad light `li` seen from `surf` that can contribute
/// (both cosines positive), calling `f(cell, direction, distance, contribution)`, where
/// `cell` is the sample's row-major cell in the [`sample_grid`] of `shadows.samples`:
/// distinct for the samples of one point (the order early stopping walks them in).
/// Contributions are already divided by the sample count, so unoccluded ones sum to the
/// estimate.
///
/// Shadow sample j of the path's camera sample i is sample i·n + j of an Owen-scrambled
/// Sobol sequence seeded by the path's point and light ([`sobol_owen`]): the light
/// samples of all a pixel's paths are stratified together, and each path's n samples
/// among themselves when n is a power of two.
#[inline]
pub fn quad_light_samples(scene: &Scene, surf: &Surface, li: usize, mut f: impl FnMut(u32, Vec3, f32, Vec3)) {
    let Light::Quad { corner, u, v, normal, area, radiance } = scene.lights[li] else { return };
    let count = scene.settings.shadow_samples;
    let seed = light_seed(surf.key, li);
    let first = surf.sample.wrapping_mul(count);
    let (cols, rows) = sample_grid(count);
    let net = count.is_power_of_two();
    let scale = area / count as f32;
    let quad = QuadLanes::<f32>::splat(corner, u, v, normal);
    let (o, n) = (V3::splat(surf.o), V3::splat(surf.n));
    for j in 0..count {
        // Past 2^32 samples of a point the indices wrap: each sample stays uniform over
        // the light (unbiased), only the stratification between the wrapped ones is lost.
        let index = first.wrapping_add(j);
        let q = quad_sample(&quad, o, n, index, seed);
        if q.cos_x <= 0.0 || q.cos_y <= 0.0 {
            continue;
        }
        // Scaling by a power of two and truncating reads the fraction's top bits exactly,
        // so the net's points land in distinct cells.
        let cell = if net { (q.uv.1 * rows as f32) as u32 * cols + (q.uv.0 * cols as f32) as u32 } else { j };
        let wi = q.wi.vec();
        let brdf = diffuse_brdf(surf.color, surf.specular, surf.shininess, surf.n, wi, surf.wo);
        f(cell, wi, q.dist, surf.w * brdf * radiance * (q.cos_x * q.cos_y * scale / q.dist2));
    }
}

/// A quad light's corner, edges and normal on lanes: one light on every lane, or a light
/// per lane.
#[derive(Clone, Copy, Debug)]
pub struct QuadLanes<R> {
    /// Corner.
    pub corner: V3<R>,
    /// First edge.
    pub u: V3<R>,
    /// Second edge.
    pub v: V3<R>,
    /// Unit normal of the emitting side.
    pub normal: V3<R>,
}

impl<R: Real> QuadLanes<R> {
    /// The same light on every lane.
    #[inline(always)]
    pub fn splat(corner: Vec3, u: Vec3, v: Vec3, normal: Vec3) -> Self {
        QuadLanes { corner: V3::splat(corner), u: V3::splat(u), v: V3::splat(v), normal: V3::splat(normal) }
    }
}

/// One light sample of a quad, on lanes: what [`quad_sample`] computes.
#[derive(Clone, Copy, Debug)]
pub struct QuadSample<R> {
    /// The sample's position in [0,1)² over the quad.
    pub uv: (R, R),
    /// Unit direction from the shading point to the sample.
    pub wi: V3<R>,
    /// Distance to the sample.
    pub dist: R,
    /// Its square.
    pub dist2: R,
    /// Cosine at the shading point (n · wi).
    pub cos_x: R,
    /// Cosine at the light (−normal · wi).
    pub cos_y: R,
}

/// Sample `index` of the Owen-scrambled Sobol sequence `seed` on `quad`, seen from origin
/// `o` with normal `n`: the one formula behind every quad-light sample, for one ray
/// ([`quad_light_samples`]) and for 16 (the shade stage's lanes), with the same bits.
#[inline(always)]
pub fn quad_sample<W: Word>(
    quad: &QuadLanes<W::Real>,
    o: V3<W::Real>,
    n: V3<W::Real>,
    index: W,
    seed: W,
) -> QuadSample<W::Real> {
    let (x, y) = sobol_owen_lanes(index, seed);
    let to = quad.corner + quad.u.scale(x) + quad.v.scale(y) - o;
    let dist2 = to.dot(to);
    let dist = dist2.sqrt();
    let wi = to.over(dist);
    QuadSample { uv: (x, y), wi, dist, dist2, cos_x: n.dot(wi), cos_y: -quad.normal.dot(wi) }
}

/// Irradiance at `o` (unit normal `n`) from a parallelogram of unit radiance with
/// corners `c, c+u, c+u+v, c+v`, by Lambert's polygon formula
/// E = ½ Σ θ_k (n · γ_k), with the polygon first clipped to the hemisphere above `o`.
/// Angles come from atan2, which keeps its precision for small, distant lights.
pub fn quad_irradiance(o: Vec3, n: Vec3, c: Vec3, u: Vec3, v: Vec3) -> f32 {
    let quad = [c - o, c + u - o, c + u + v - o, c + v - o];
    // Sutherland–Hodgman against the tangent plane: at most 5 vertices remain.
    let mut poly = [Vec3::ZERO; 5];
    let mut len = 0;
    for k in 0..4 {
        let (a, b) = (quad[k], quad[(k + 1) % 4]);
        let (da, db) = (n.dot(a), n.dot(b));
        if da > 0.0 {
            poly[len] = a;
            len += 1;
        }
        if (da > 0.0) != (db > 0.0) {
            poly[len] = a + (b - a) * (da / (da - db));
            len += 1;
        }
    }
    let mut sum = 0.0;
    for k in 0..len {
        let (a, b) = (poly[k].normalize(), poly[(k + 1) % len].normalize());
        let cross = a.cross(b);
        let sin = cross.length();
        if sin > 0.0 {
            sum += sin.atan2(a.dot(b)) * n.dot(cross / sin);
        }
    }
    0.5 * sum.abs()
}

/// Visits the shadow rays uniform mode casts from `surf` to light `li`: one to a point
/// light, `shadows.samples` stratified ones to a quad light (those that can contribute),
/// none to a dark light. Calls `f(direction, tmax, contribution)`.
#[inline]
pub fn uniform_shadow_rays(scene: &Scene, surf: &Surface, li: usize, mut f: impl FnMut(Vec3, f32, Vec3)) {
    match scene.lights[li] {
        // A dark light adds nothing: it costs no shadow rays either.
        Light::Point { intensity, .. } | Light::Quad { radiance: intensity, .. } if intensity == Vec3::ZERO => {}
        Light::Point { position, intensity } => {
            let to = position - surf.o;
            let dist2 = to.length_squared();
            let dist = dist2.sqrt();
            let wi = to / dist;
            let cos = surf.n.dot(wi);
            if cos <= 0.0 || dist2 == 0.0 {
                return;
            }
            let brdf = diffuse_brdf(surf.color, surf.specular, surf.shininess, surf.n, wi, surf.wo);
            f(wi, dist * SHADOW_TMAX_SCALE, surf.w * brdf * intensity * (cos / dist2));
        }
        Light::Quad { .. } => quad_light_samples(scene, surf, li, |_, wi, dist, l| f(wi, dist * SHADOW_TMAX_SCALE, l)),
    }
}
