//! Light sampling shared by the stages that light a diffuse point, for every light shape
//! (parallelogram, triangle, point): the stratified samples of uniform mode and of the
//! penumbra, the exact irradiance of the adaptive test's lit points, its probe rays, what
//! a ray that hits an emitter sees, and where shadow rays stop. Stages call these and
//! never match on a light's shape themselves. The geometry of each shape (a sample,
//! its density, the exact irradiance) is in the emitter module (`emitter/area.rs`,
//! `emitter/sphere.rs`). [`lanes`] casts uniform shadow rays 16 at a time.

pub mod lanes;

use glam::Vec3;
use std::f32::consts::FRAC_1_PI;

use crate::emitter::area::{
    polygon_irradiance, quad_irradiance, quad_sample, unclipped_irradiance, QuadLanes, QuadSample,
};
use crate::emitter::sphere::{sphere_pdf, sphere_sample};
use crate::queue::SurfaceQueue;
use crate::sampling::{cmj_grid, dim, hash, hash_lanes, sobol_owen, to_unit};
use crate::scene::{AreaLights, Light, Probe, Scene};
use crate::simd::{LaneIds, Real, Word, LANES, V3};
use crate::surface::{diffuse_brdf, queued_surface, Surface};
use wide::{f32x16, u32x16};

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

/// The grid of `n` light samples early stopping orders them on ([`area_light_samples`]'s
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

/// Visits the stratified samples of area light `li` seen from `surf` that can contribute
/// (both cosines positive), calling `f(cell, direction, distance, contribution)`, where
/// `cell` is the sample's row-major cell in the [`sample_grid`] of `shadows.samples`:
/// distinct for the samples of one point (the order early stopping walks them in).
/// Contributions are already divided by the sample count, so unoccluded ones sum to the
/// estimate.
///
/// Shadow sample j of the path's camera sample i is sample i·n + j of an Owen-scrambled
/// Sobol sequence seeded by the path's point and light
/// ([`sobol_owen`](crate::sampling::sobol_owen)): the light
/// samples of all a pixel's paths are stratified together, and each path's n samples
/// among themselves when n is a power of two.
/// A triangle folds the unit square onto itself along its diagonal (uniform by area; the
/// cells stay those of the square).
#[inline]
pub fn area_light_samples(scene: &Scene, surf: &Surface, li: usize, mut f: impl FnMut(u32, Vec3, f32, Vec3)) {
    let Some((corner, u, v, normal, area, radiance, triangle)) = scene.lights[li].planar() else { return };
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
        let q = quad_sample(&quad, o, n, index, seed, triangle);
        if q.cos_x <= 0.0 || q.cos_y <= 0.0 {
            continue;
        }
        let cell = light_cell(q.uv, j, net, (cols, rows));
        let wi = q.wi.vec();
        let brdf = diffuse_brdf(surf.color, surf.specular, surf.shininess, surf.n, wi, surf.wo);
        f(cell, wi, q.dist, surf.w * brdf * radiance * (q.cos_x * q.cos_y * scale / q.dist2));
    }
}

/// The light cell of sample `j` of a point, at `uv` on the light, in the [`sample_grid`]
/// `grid` of its count (`net`: a power of two, whose points land one a cell): the order
/// early stopping walks a point's samples in. Scaling by a power of two and truncating
/// reads the fraction's top bits exactly, so the net's points land in distinct cells;
/// other counts take the sample's index. The same values on 16 lanes as for one sample.
#[inline(always)]
pub fn light_cell<W: Word>(uv: (W::Real, W::Real), j: W, net: bool, grid: (u32, u32)) -> W {
    let (cols, rows) = grid;
    if net {
        let (x, y) = (uv.0 * W::Real::splat(cols as f32), uv.1 * W::Real::splat(rows as f32));
        W::trunc(y).wmul(W::splat(cols)).wadd(W::trunc(x))
    } else {
        j
    }
}

/// A light sample of a rough surface's hit ([`gloss_light_sample`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GlossLightSample {
    /// Unit direction from the hit to the point on the light.
    pub wi: Vec3,
    /// Distance to that point.
    pub dist: f32,
    /// The light's radiance.
    pub radiance: Vec3,
    /// Density of the sample per unit solid angle at the hit, the light's choice
    /// included: what [`gloss_light_pdf`] gives a ray that reaches that point.
    pub pdf: f32,
}

/// The position in the scene's `gloss_lights` of the light a sample `u` in [0, 1) picks:
/// uniformly, or by the scene's `light_cdf` (the path transport's pick by power).
#[inline]
pub fn pick_light(scene: &Scene, u: f32) -> usize {
    let n = scene.gloss_lights.len();
    if scene.light_cdf.is_empty() {
        return ((u * n as f32) as usize).min(n - 1);
    }
    scene.light_cdf.partition_point(|&c| c <= u).min(n - 1)
}

/// A point on one of the scene's `gloss_lights` seen from `x`, for multiple importance
/// sampling at the rough-surface hit of the path (`key`, `sample`): the light chosen
/// by [`pick_light`], the point uniform over its area, each from point `sample` of an
/// Owen-scrambled Sobol sequence keyed by the path ([`dim::GLOSS_LIGHT_PICK`],
/// [`dim::GLOSS_LIGHT`]), so stratified over the pixel's samples. `None` when the scene
/// has no such light or the point sees the light's back.
#[inline]
pub fn gloss_light_sample(scene: &Scene, x: Vec3, key: u32, sample: u32) -> Option<GlossLightSample> {
    let lights = &scene.gloss_lights;
    let li = match lights.len() {
        0 => return None,
        1 => lights[0],
        n => {
            let u = sobol_owen(sample, hash(&[key, dim::GLOSS_LIGHT_PICK])).x;
            lights[pick_light(scene, u).min(n - 1)]
        }
    };
    let (corner, u, v, normal, area, radiance, triangle) = scene.lights[li as usize].planar()?;
    let quad = QuadLanes::<f32>::splat(corner, u, v, normal);
    let seed = hash(&[key, li, dim::GLOSS_LIGHT]);
    // The cosine at x is the BSDF's business: any normal will do for quad_sample's.
    let q = quad_sample(&quad, V3::splat(x), V3::splat(normal), sample, seed, triangle);
    if q.cos_y <= 0.0 || q.dist2 == 0.0 {
        return None;
    }
    // Uniform over the light's area, the light chosen with probability 1 / n (uniform), or
    // by power.
    let pdf = match scene.light_pick.is_empty() {
        true => q.dist2 / (q.cos_y * area * lights.len() as f32),
        false => q.dist2 / (q.cos_y * area) * scene.light_pick[li as usize],
    };
    Some(GlossLightSample { wi: q.wi.vec(), dist: q.dist, radiance, pdf })
}

/// The density per unit solid angle with which [`gloss_light_sample`] draws the point of
/// light `li` that a ray along unit `d` meets at distance `t`: 0 for a point light. Every
/// emitting area light is among the scene's `gloss_lights` when any is, so this is also
/// its density for a light the sampler has (a dark light emits nothing to weight).
#[inline]
pub fn gloss_light_pdf(scene: &Scene, li: u32, d: Vec3, t: f32) -> f32 {
    let Some((_, _, _, normal, area, _, _)) = scene.lights[li as usize].planar() else { return 0.0 };
    let cos = -normal.dot(d);
    if cos <= 0.0 {
        return 0.0;
    }
    match scene.light_pick.is_empty() {
        true => t * t / (cos * area * scene.gloss_lights.len() as f32),
        false => t * t / (cos * area) * scene.light_pick[li as usize],
    }
}

/// What [`AreaLights::sample`] gives per lane besides the sample: the picked light's area
/// over its pick probability, and its radiance.
pub struct PickedLights {
    /// Area over the light's pick probability.
    pub area: f32x16,
    /// Radiance.
    pub radiance: V3<f32x16>,
}

impl AreaLights {
    /// Sample `index` of the sequence `seed` on light `pick[k]` of the table, per lane k,
    /// seen from `o` with normal `n` ([`quad_sample`]); quads and triangles differ only in
    /// the fold of the unit square, so a group with both samples both and picks per lane.
    #[inline]
    pub fn sample(
        &self,
        pick: &[u32; LANES],
        o: V3<f32x16>,
        n: V3<f32x16>,
        index: u32x16,
        seed: u32x16,
    ) -> (QuadSample<f32x16>, PickedLights) {
        let lanes = LaneIds::new(pick);
        let v = |i: usize| V3 {
            x: lanes.gather(&self.c[i]),
            y: lanes.gather(&self.c[i + 1]),
            z: lanes.gather(&self.c[i + 2]),
        };
        let quad = QuadLanes { corner: v(0), u: v(3), v: v(6), normal: v(9) };
        let picked = PickedLights { area: lanes.gather(&self.area), radiance: v(12) };
        let triangles = (0..LANES).filter(|&k| self.triangle[pick[k] as usize]).fold(0u32, |m, k| m | 1 << k);
        let s = match triangles {
            0 => quad_sample(&quad, o, n, index, seed, false),
            t if t == u32::MAX >> (32 - LANES) => quad_sample(&quad, o, n, index, seed, true),
            t => {
                let (a, b) =
                    (quad_sample(&quad, o, n, index, seed, false), quad_sample(&quad, o, n, index, seed, true));
                let m =
                    f32x16::from(std::array::from_fn::<f32, LANES, _>(|k| if t & (1 << k) != 0 { -1.0 } else { 1.0 }));
                let pick = |x: f32x16, y: f32x16| f32x16::if_negative(m, y, x);
                QuadSample {
                    uv: a.uv,
                    wi: V3::if_negative(m, b.wi, a.wi),
                    dist: pick(a.dist, b.dist),
                    dist2: pick(a.dist2, b.dist2),
                    cos_x: pick(a.cos_x, b.cos_x),
                    cos_y: pick(a.cos_y, b.cos_y),
                }
            }
        };
        (s, picked)
    }
}

/// The unoccluded direct light at `surf` from area light `li`, which the adaptive shadow
/// test sends to the film for a lit point: `Some((contribution, rays))`, where `rays` is
/// what uniform mode would have cast (the samples facing both ways; 0: nothing to do, the
/// point is behind the one-sided emitter or the light below its horizon). Exact for
/// Lambert (the polygon irradiance), else the penumbra stage's own samples without
/// occlusion tests. `None` for a point light or a dark light, which take the uniform path.
#[inline]
pub fn unoccluded(scene: &Scene, surf: &Surface, li: usize) -> Option<(Vec3, u64)> {
    let (corner, u, v, normal, _, radiance, triangle) = scene.lights[li].planar()?;
    if radiance == Vec3::ZERO {
        return None;
    }
    if normal.dot(surf.o - corner) <= 0.0 {
        return Some((Vec3::ZERO, 0)); // behind the one-sided emitter
    }
    let quad = [corner, corner + u, corner + v, corner + u + v];
    let verts = if triangle { &quad[..3] } else { &quad[..] };
    let (mut sum, mut n) = (Vec3::ZERO, 0u64);
    let above = verts.iter().all(|&p| surf.n.dot(p - surf.o) > 0.0);
    if surf.specular == Vec3::ZERO && above {
        n = scene.settings.shadow_samples as u64;
    } else {
        area_light_samples(scene, surf, li, |_, _, _, l| {
            sum += l;
            n += 1;
        });
    }
    if n > 0 && surf.specular == Vec3::ZERO {
        let e = if triangle {
            polygon_irradiance(surf.o, surf.n, &[corner, corner + u, corner + v])
        } else {
            quad_irradiance(surf.o, surf.n, corner, u, v)
        };
        sum = surf.w * surf.color * FRAC_1_PI * radiance * e;
    }
    Some((sum, n))
}

/// [`unoccluded`] for 16 points of `surfaces` (`ids`; lanes from `count` on are not
/// written) and area light `li`, into `out`: on lanes where a point is Lambertian, in
/// front of the light and has all its corners above its horizon (the irradiance's
/// polygon unclipped), by the scalar function elsewhere. The same values, bit for bit.
pub fn unoccluded_lanes(
    scene: &Scene,
    surfaces: &SurfaceQueue,
    (ids, count): (&[u32; LANES], usize),
    li: usize,
    out: &mut [Option<(Vec3, u64)>; LANES],
) {
    let scalar = |k: usize| unoccluded(scene, &queued_surface(surfaces, ids[k] as usize), li);
    let Some((corner, u, v, normal, _, radiance, triangle)) = scene.lights[li].planar() else {
        out[..count].fill(None);
        return;
    };
    let lanes = LaneIds::new(ids);
    let o = lanes.gather3(&surfaces.ox, &surfaces.oy, &surfaces.oz);
    let n = lanes.gather3(&surfaces.nx, &surfaces.ny, &surfaces.nz);
    let spec = lanes.gather3(&surfaces.sr, &surfaces.sg, &surfaces.sb);
    let zero = f32x16::ZERO;
    // As `quad_irradiance` and `polygon_irradiance` order the corners.
    let corners = [corner, corner + u, corner + u + v, corner + v];
    let verts: &[Vec3] = if triangle { &[corner, corner + u, corner + v] } else { &corners };
    let rel: [V3<f32x16>; 4] = std::array::from_fn(|k| V3::splat(verts[k.min(verts.len() - 1)]) - o);
    let rel = &rel[..verts.len()];
    let mut simple = V3::splat(normal).dot(o - V3::splat(corner)).simd_gt(zero)
        & spec.x.simd_eq(zero)
        & spec.y.simd_eq(zero)
        & spec.z.simd_eq(zero);
    for r in rel {
        simple &= n.dot(*r).simd_gt(zero);
    }
    let simple = simple.to_bitmask();
    if radiance == Vec3::ZERO || simple == 0 {
        for (k, o) in out.iter_mut().enumerate().take(count) {
            *o = scalar(k);
        }
        return;
    }
    let e = unclipped_irradiance(n, rel);
    let w = lanes.gather3(&surfaces.wr, &surfaces.wg, &surfaces.wb);
    let c = lanes.gather3(&surfaces.cr, &surfaces.cg, &surfaces.cb);
    let f = |w: f32x16, c: f32x16, r: f32| (w * c * f32x16::splat(FRAC_1_PI) * f32x16::splat(r) * e).to_array();
    let (r, g, b) = (f(w.x, c.x, radiance.x), f(w.y, c.y, radiance.y), f(w.z, c.z, radiance.z));
    let samples = scene.settings.shadow_samples as u64;
    for (k, o) in out.iter_mut().enumerate().take(count) {
        *o = if simple & (1 << k) != 0 { Some((Vec3::new(r[k], g[k], b[k]), samples)) } else { scalar(k) };
    }
}

/// The radiance a ray from `origin` with direction `d` sees on emitter `light`:
/// one-sided, radiance on the front (a sphere's outside) and black from behind.
#[inline]
pub fn emitted(light: &Light, origin: Vec3, d: Vec3) -> Option<Vec3> {
    if let Light::Sphere { center, radius, radiance } = *light {
        return ((origin - center).length_squared() > radius * radius).then_some(radiance);
    }
    let (_, _, _, normal, _, radiance, _) = light.planar()?;
    (normal.dot(d) < 0.0).then_some(radiance)
}

/// The density with which the light samples would have drawn the point of light `li`
/// that a ray from `origin` along unit `d` meets at distance `t`: a planar light's
/// [`gloss_light_pdf`], a sampled sphere's cone density; 0 for a light not sampled.
#[inline]
pub fn hit_light_pdf(scene: &Scene, li: u32, origin: Vec3, d: Vec3, t: f32) -> f32 {
    match scene.lights[li as usize] {
        Light::Sphere { center, radius, .. } if scene.sphere_lights.contains(&li) => sphere_pdf(center, radius, origin),
        Light::Sphere { .. } => 0.0,
        _ => gloss_light_pdf(scene, li, d, t),
    }
}

/// Probe rays per shading point of the adaptive shadow test on `light` with `probe`
/// (0 for a point light).
pub fn probe_count(light: &Light, probe: Probe) -> u32 {
    match light {
        Light::Point { .. } | Light::Directional { .. } | Light::Sphere { .. } => 0,
        Light::Quad { .. } => probe.rays(),
        Light::Triangle { .. } => match probe {
            Probe::Corners => 3,
            Probe::CornersCenter | Probe::Jittered => 4,
            Probe::Grid3 => 7,
        },
    }
}

/// Whether the adaptive shadow test probes `light` when uniform mode casts `samples`
/// rays to it. A probed point costs P probes, plus the N samples when it lands in the
/// penumbra, so probing saves rays while the penumbra fraction f < 1 − P/N; with P ≥ N it
/// never can. The light is probed when P ≤ 0.8 N, which pays up to f = 0.2: the largest
/// penumbra fraction measured on the project's scenes is 0.20 (`benches/shadow_breakeven.py`,
/// docs/performance.md). Otherwise it is sampled as in uniform mode, with uniform mode's
/// rays and image.
pub fn probes_light(light: &Light, probe: Probe, samples: u32) -> bool {
    let probes = probe_count(light, probe);
    probes > 0 && 5 * probes as u64 <= 4 * samples as u64
}

/// The probe targets on area light `li` for a shading point whose path is named by `key`
/// (its point key hashed with its sample index); the first [`probe_count`] are used.
/// A parallelogram's are its corners (and centre), a jittered point in each quarter, or
/// its 3×3 grid; a triangle's are its vertices (and centroid), a jittered point in each
/// of its four midpoint sub-triangles, or its vertices, edge midpoints and centroid.
#[inline]
pub fn probe_targets(scene: &Scene, probe: Probe, li: usize, key: u32) -> [Vec3; 9] {
    let mut t = [Vec3::ZERO; 9];
    let Some((corner, u, v, _, _, _, triangle)) = scene.lights[li].planar() else { return t };
    let at = |a: f32, b: f32| corner + a * u + b * v;
    let h = |q: u32, d: u32| to_unit(hash(&[key, li as u32, q, d, dim::PROBE]));
    if triangle {
        let third = 1.0 / 3.0;
        match probe {
            Probe::Corners | Probe::CornersCenter | Probe::Grid3 => {
                t[..4].copy_from_slice(&[at(0.0, 0.0), at(1.0, 0.0), at(0.0, 1.0), at(third, third)]);
                t[4..7].copy_from_slice(&[at(0.5, 0.0), at(0.5, 0.5), at(0.0, 0.5)]);
            }
            Probe::Jittered => {
                // The midpoint subdivision: three corner triangles (a, b) = o + ½(x, y),
                // and the middle one, (½, ½) − ½(x, y); (x, y) uniform in the unit triangle.
                for i in 0..4u32 {
                    let (mut x, mut y) = (h(i, 0), h(i, 1));
                    if x + y > 1.0 {
                        (x, y) = (1.0 - x, 1.0 - y);
                    }
                    let (a, b) = match i {
                        0 => (0.5 * x, 0.5 * y),
                        1 => (0.5 + 0.5 * x, 0.5 * y),
                        2 => (0.5 * x, 0.5 + 0.5 * y),
                        _ => (0.5 - 0.5 * x, 0.5 - 0.5 * y),
                    };
                    t[i as usize] = at(a, b);
                }
            }
        }
        return t;
    }
    match probe {
        Probe::Corners | Probe::CornersCenter => {
            t[..5].copy_from_slice(&[at(0.0, 0.0), at(1.0, 0.0), at(0.0, 1.0), at(1.0, 1.0), at(0.5, 0.5)]);
        }
        Probe::Jittered => {
            for i in 0..4u32 {
                t[i as usize] = at(0.5 * ((i & 1) as f32 + h(i, 0)), 0.5 * ((i >> 1) as f32 + h(i, 1)));
            }
        }
        Probe::Grid3 => {
            for (i, p) in t.iter_mut().enumerate() {
                *p = at(0.5 * (i % 3) as f32, 0.5 * (i / 3) as f32);
            }
        }
    }
    t
}

/// Visits the shadow rays uniform mode casts from `surf` to light `li`: one to a point
/// or directional light (that one reaching to infinity), `shadows.samples` stratified ones to an area light (those that can contribute),
/// none to a dark light. Calls `f(direction, tmax, contribution)`.
#[inline]
pub fn uniform_shadow_rays(scene: &Scene, surf: &Surface, li: usize, mut f: impl FnMut(Vec3, f32, Vec3)) {
    match scene.lights[li] {
        // A dark light adds nothing: it costs no shadow rays either.
        ref light if light.emission() == Vec3::ZERO => {}
        Light::Directional { direction, irradiance } => {
            let wi = -direction;
            let cos = surf.n.dot(wi);
            if cos <= 0.0 {
                return;
            }
            let brdf = diffuse_brdf(surf.color, surf.specular, surf.shininess, surf.n, wi, surf.wo);
            f(wi, f32::MAX, surf.w * brdf * irradiance * cos);
        }
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
        Light::Quad { .. } | Light::Triangle { .. } => {
            area_light_samples(scene, surf, li, |_, wi, dist, l| f(wi, dist * SHADOW_TMAX_SCALE, l))
        }
        Light::Sphere { center, radius, radiance } => {
            // `shadows.samples` stratified directions in the cone the sphere subtends.
            let count = scene.settings.shadow_samples;
            let seed = light_seed(surf.key, li);
            for j in 0..count {
                let u = sobol_owen(surf.sample.wrapping_mul(count).wrapping_add(j), seed);
                let Some(s) = sphere_sample(center, radius, surf.o, u) else { return };
                let cos = surf.n.dot(s.wi);
                if cos > 0.0 {
                    let brdf = diffuse_brdf(surf.color, surf.specular, surf.shininess, surf.n, s.wi, surf.wo);
                    let l = surf.w * brdf * radiance * (cos / (s.pdf * count as f32));
                    f(s.wi, s.dist * SHADOW_TMAX_SCALE, l);
                }
            }
        }
    }
}
