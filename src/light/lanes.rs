//! Uniform shadow rays on lanes: 16 (point, light, sample) triples at a time, for
//! parallelograms, triangles, points and directions (a sphere light keeps the scalar
//! loop). Each lane computes its light's formula of
//! [`uniform_shadow_rays`](crate::light::uniform_shadow_rays) with the same operations,
//! so the queue keeps the scalar loop's order and bits. The shade stage casts every
//! point's rays this way ([`shadow_lanes`]), the penumbra stage its points' rays to their
//! lights ([`pair_shadow_lanes`]).

use glam::Vec3;
use std::f32::consts::FRAC_1_PI;
use wide::{f32x16, u32x16};

use super::{light_cell, light_seed_lanes, sample_grid, SHADOW_TMAX_SCALE};
use crate::accel::lanes_of;
use crate::emitter::area::{quad_sample, QuadLanes, QuadSample};
use crate::queue::{ShadowQueue, SurfaceQueue};
use crate::scene::{Light, Scene};
use crate::simd::{LaneIds, Word, LANES, V3};
use crate::surface::diffuse_brdf;

/// What a lane's light is, for its formula.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    /// A parallelogram: `shadows.samples` stratified samples.
    Quad,
    /// A triangle: the same samples, the unit square folded onto it.
    Triangle,
    /// A point light: one ray to it.
    Point,
    /// A directional light: one ray against its direction, to infinity.
    Directional,
}

impl Kind {
    /// The kind of `light`, `None` for the lights the lanes leave to the scalar loop.
    fn of(light: &Light) -> Option<Kind> {
        match light {
            Light::Quad { .. } => Some(Kind::Quad),
            Light::Triangle { .. } => Some(Kind::Triangle),
            Light::Point { .. } => Some(Kind::Point),
            Light::Directional { .. } => Some(Kind::Directional),
            Light::Sphere { .. } => None,
        }
    }

    /// The lane mask of this kind's lanes in `kinds`.
    #[inline(always)]
    fn mask(self, kinds: &[Kind; LANES]) -> f32x16 {
        f32x16::from(kinds.map(|k| if k == self { f32::from_bits(!0) } else { 0.0 }))
    }
}

/// True when the lanes can cast uniform shadow rays to `light`.
pub fn on_lanes(light: &Light) -> bool {
    Kind::of(light).is_some()
}

/// Uniform shadow rays from every point of `surfaces` to every lit light (all
/// [`on_lanes`]), 16 (point, light, sample) triples at a time, in the scalar loop's
/// order (point, then light, then sample): the queue, and every sum taken over it later,
/// keeps its bits.
pub fn shadow_lanes(scene: &Scene, surfaces: &SurfaceQueue, shadow: &mut ShadowQueue) {
    let lit: Vec<u32> =
        (0..scene.lights.len() as u32).filter(|&li| scene.lights[li as usize].emission() != Vec3::ZERO).collect();
    let Some(&first) = lit.first() else { return };
    let mut s = 0;
    // One lit light whose count divides 16 (the usual case): whole groups of 16 / count
    // points, the same triples without the lane-by-lane walk.
    let c = rays_to(scene, first as usize);
    if lit.len() == 1 && c.is_power_of_two() && c as usize <= LANES {
        let table = light_table(scene);
        let mut lanes = Triples { point: [0; LANES], light: [0; LANES], sample: [0; LANES], count: 0 };
        let per = LANES / c as usize;
        let shift = c.trailing_zeros();
        lanes.light = [first; LANES];
        lanes.sample = std::array::from_fn(|k| k as u32 & (c - 1));
        lanes.count = LANES;
        while s + per <= surfaces.len() {
            lanes.point = std::array::from_fn(|k| s as u32 + (k as u32 >> shift));
            light_lanes::<false>(scene, &table, surfaces, &lanes, shadow, &mut Vec::new());
            s += per;
        }
    }
    // The rest, and every point of any other scene: pair by pair.
    let pairs = (s as u32..surfaces.len() as u32).flat_map(|p| lit.iter().map(move |&li| (p, li)));
    pair_shadow_lanes(scene, surfaces, pairs, shadow, &mut Vec::new(), None);
}

/// The uniform shadow rays of each (point of `surfaces`, lit light, both [`on_lanes`])
/// pair of `pairs`, pair by pair in the scalar loop's order, appended to `shadow`;
/// `counts` (cleared first) gets each pair's number of rays (its samples that face the
/// point and the light), and `cells` (cleared first), when given, each ray's light cell
/// ([`light_cell`]; 0 for a point or directional light's one ray), as
/// [`area_light_samples`](crate::light::area_light_samples) numbers them.
pub fn pair_shadow_lanes(
    scene: &Scene,
    surfaces: &SurfaceQueue,
    pairs: impl Iterator<Item = (u32, u32)>,
    shadow: &mut ShadowQueue,
    counts: &mut Vec<u32>,
    mut cells: Option<&mut Vec<u32>>,
) {
    counts.clear();
    if let Some(cells) = cells.as_deref_mut() {
        cells.clear();
    }
    let table = light_table(scene);
    let mut lanes = Triples { point: [0; LANES], light: [0; LANES], sample: [0; LANES], count: 0 };
    // Each lane's pair, to count its ray.
    let mut owner = [0u32; LANES];
    let mut flush = |lanes: &mut Triples, owner: &[u32; LANES], counts: &mut Vec<u32>| {
        for k in lanes.count..LANES {
            (lanes.point[k], lanes.light[k], lanes.sample[k]) = (lanes.point[0], lanes.light[0], lanes.sample[0]);
        }
        let cast = match cells.as_deref_mut() {
            Some(cells) => light_lanes::<true>(scene, &table, surfaces, lanes, shadow, cells),
            None => light_lanes::<false>(scene, &table, surfaces, lanes, shadow, &mut Vec::new()),
        };
        for k in lanes_of(cast) {
            counts[owner[k] as usize] += 1;
        }
        lanes.count = 0;
    };
    for (p, li) in pairs {
        owner[lanes.count] = counts.len() as u32;
        counts.push(0);
        for j in 0..rays_to(scene, li as usize) {
            let k = lanes.count;
            (lanes.point[k], lanes.light[k], lanes.sample[k], owner[k]) = (p, li, j, counts.len() as u32 - 1);
            lanes.count += 1;
            if lanes.count == LANES {
                flush(&mut lanes, &owner, counts);
            }
        }
    }
    if lanes.count > 0 {
        flush(&mut lanes, &owner, counts);
    }
}

/// The rays a point casts to light `li` in uniform mode: `shadows.samples` to an area
/// light, one to a point or a direction.
fn rays_to(scene: &Scene, li: usize) -> u32 {
    match Kind::of(&scene.lights[li]) {
        Some(Kind::Quad | Kind::Triangle) => scene.settings.shadow_samples,
        Some(Kind::Point | Kind::Directional) | None => 1,
    }
}

/// One lane group of (point, light, sample) triples, the first `count` real.
struct Triples {
    point: [u32; LANES],
    light: [u32; LANES],
    sample: [u32; LANES],
    count: usize,
}

/// The lights of a lane group: their kinds, geometry (a point light's position and a
/// directional light's direction to it in `quad.corner`), area / n and emission per lane.
struct LightLanes {
    kind: [Kind; LANES],
    quad: QuadLanes<f32x16>,
    scale: f32x16,
    radiance: V3<f32x16>,
}

/// A light's parameters as [`LightLanes`] holds them: corner (a point light's position,
/// a directional light's direction to it), edges, normal and emission by component, then
/// area / n; and its kind.
type Params = ([f32; 16], Kind);

/// The [`Params`] of every light of `scene` (a sphere light's are not used).
fn light_table(scene: &Scene) -> Vec<Params> {
    let n = scene.settings.shadow_samples as f32;
    let params = |light: &Light| {
        let e = light.emission();
        let at = |p: Vec3| (p, Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, 0.0, e);
        let (corner, u, v, normal, scale, radiance) = match (light.planar(), *light) {
            (Some((corner, u, v, normal, area, radiance, _)), _) => (corner, u, v, normal, area / n, radiance),
            (None, Light::Directional { direction, .. }) => at(-direction),
            (None, Light::Point { position, .. }) => at(position),
            (None, Light::Sphere { center, .. }) => at(center),
            (None, Light::Quad { .. } | Light::Triangle { .. }) => at(Vec3::ZERO),
        };
        let [c, u, v, n, r] = [corner, u, v, normal, radiance].map(|v| v.to_array());
        let values = [c[0], c[1], c[2], u[0], u[1], u[2], v[0], v[1], v[2], n[0], n[1], n[2], r[0], r[1], r[2], scale];
        (values, Kind::of(light).unwrap_or(Kind::Point))
    };
    scene.lights.iter().map(params).collect()
}

impl LightLanes {
    /// The lights of `lights` (indices into `table`): splat when all lanes share one.
    fn new(table: &[Params], lights: &[u32; LANES]) -> LightLanes {
        let v3 = |a: &[f32]| Vec3::new(a[0], a[1], a[2]);
        if lights.iter().all(|&l| l == lights[0]) {
            let (p, kind) = &table[lights[0] as usize];
            let quad = QuadLanes::splat(v3(&p[0..]), v3(&p[3..]), v3(&p[6..]), v3(&p[9..]));
            let (scale, radiance) = (f32x16::splat(p[15]), V3::splat(v3(&p[12..])));
            return LightLanes { kind: [*kind; LANES], quad, scale, radiance };
        }
        let (mut col, mut kind) = ([[0.0f32; LANES]; 16], [Kind::Quad; LANES]);
        for (k, &li) in lights.iter().enumerate() {
            let (values, kd) = &table[li as usize];
            for (c, &x) in col.iter_mut().zip(values) {
                c[k] = x;
            }
            kind[k] = *kd;
        }
        let v = |j: usize| V3 { x: f32x16::from(col[j]), y: f32x16::from(col[j + 1]), z: f32x16::from(col[j + 2]) };
        let quad = QuadLanes { corner: v(0), u: v(3), v: v(6), normal: v(9) };
        LightLanes { kind, quad, scale: f32x16::from(col[15]), radiance: v(12) }
    }

    /// Whether some lane's light is of kind `kind`.
    fn has(&self, kind: Kind) -> bool {
        self.kind.contains(&kind)
    }
}

/// Per lane of a group: the ray's direction, its `tmax`, the factor its contribution
/// takes after weight × BRDF × emission, and whether it is cast.
struct Rays {
    wi: V3<f32x16>,
    tmax: f32x16,
    factor: f32x16,
    dark: f32x16,
}

/// Where `mask` is set, `a`'s fields, else `b`'s.
#[inline(always)]
fn pick(mask: f32x16, a: Rays, b: Rays) -> Rays {
    let sel = |x: f32x16, y: f32x16| mask.select(x, y);
    Rays {
        wi: V3 { x: sel(a.wi.x, b.wi.x), y: sel(a.wi.y, b.wi.y), z: sel(a.wi.z, b.wi.z) },
        tmax: sel(a.tmax, b.tmax),
        factor: sel(a.factor, b.factor),
        dark: sel(a.dark, b.dark),
    }
}

/// An area light's rays: [`quad_sample`]'s, as in
/// [`area_light_samples`](crate::light::area_light_samples).
#[inline(always)]
fn area_rays(s: QuadSample<f32x16>, scale: f32x16) -> Rays {
    let zero = f32x16::ZERO;
    Rays {
        factor: s.cos_x * s.cos_y * scale / s.dist2,
        tmax: s.dist * f32x16::splat(SHADOW_TMAX_SCALE),
        dark: s.cos_x.simd_le(zero) | s.cos_y.simd_le(zero),
        wi: s.wi,
    }
}

/// The shadow rays of one lane group of `triples`: each lane its light's formula (the
/// scalar ones of [`uniform_shadow_rays`](crate::light::uniform_shadow_rays)), Lambert
/// on the lanes and a Phong point's BRDF by the scalar function. Returns the lanes that
/// cast a ray; with `CELLS`, appends their light cells to `cells` ([`pair_shadow_lanes`];
/// a constant, so the shade stage's calls compile without them).
fn light_lanes<const CELLS: bool>(
    scene: &Scene,
    table: &[Params],
    q: &SurfaceQueue,
    triples: &Triples,
    shadow: &mut ShadowQueue,
    cells: &mut Vec<u32>,
) -> u32 {
    let n = scene.settings.shadow_samples;
    let mut cell = [0u32; LANES];
    let si = triples.point;
    let lanes = LaneIds::new(&si);
    // Straight calls, not closures: a closure over the loads was kept out of line.
    let lights = LightLanes::new(table, &triples.light);
    let (o, normal) = (lanes.gather3(&q.ox, &q.oy, &q.oz), lanes.gather3(&q.nx, &q.ny, &q.nz));
    let zero = f32x16::ZERO;
    // Each kind's formula only where a lane has it, picked lane by lane after.
    let mut rays: Option<Rays> = None;
    let mut add = |kind: Kind, r: Rays| {
        rays = Some(match rays.take() {
            Some(prev) => pick(kind.mask(&lights.kind), r, prev),
            None => r,
        })
    };
    let (quads, triangles) = (lights.has(Kind::Quad), lights.has(Kind::Triangle));
    if quads || triangles {
        let index = lanes.gather_words(&q.sample).wmul(u32x16::splat(n)).wadd(u32x16::from(triples.sample));
        let seed = light_seed_lanes(lanes.gather_words(&q.key), u32x16::from(triples.light));
        for (kind, present) in [(Kind::Quad, quads), (Kind::Triangle, triangles)] {
            if present {
                let s = quad_sample(&lights.quad, o, normal, index, seed, kind == Kind::Triangle);
                if CELLS {
                    let j = u32x16::from(triples.sample);
                    let c = light_cell(s.uv, j, n.is_power_of_two(), sample_grid(n)).to_array();
                    for k in (0..LANES).filter(|&k| lights.kind[k] == kind) {
                        cell[k] = c[k];
                    }
                }
                add(kind, area_rays(s, lights.scale));
            }
        }
    }
    if lights.has(Kind::Point) {
        // As the scalar loop: to the position, cos / dist².
        let to = lights.quad.corner - o;
        let dist2 = to.dot(to);
        let dist = dist2.sqrt();
        let wi = to.over(dist);
        let cos = normal.dot(wi);
        let dark = cos.simd_le(zero) | dist2.simd_eq(zero);
        add(Kind::Point, Rays { wi, tmax: dist * f32x16::splat(SHADOW_TMAX_SCALE), factor: cos / dist2, dark });
    }
    if lights.has(Kind::Directional) {
        let wi = lights.quad.corner;
        let cos = normal.dot(wi);
        add(Kind::Directional, Rays { wi, tmax: f32x16::splat(f32::MAX), factor: cos, dark: cos.simd_le(zero) });
    }
    let Some(Rays { wi, tmax, factor, dark }) = rays else { return 0 };
    let w = lanes.gather3(&q.wr, &q.wg, &q.wb);
    let brdf = lanes.gather3(&q.cr, &q.cg, &q.cb).scale(f32x16::splat(FRAC_1_PI));
    let r = lights.radiance;
    let l = |w: f32x16, b: f32x16, r: f32x16| (w * b * r * factor).to_array();
    let (mut lr, mut lg, mut lb) = (l(w.x, brdf.x, r.x), l(w.y, brdf.y, r.y), l(w.z, brdf.z, r.z));
    let (wx, wy, wz) = (wi.x.to_array(), wi.y.to_array(), wi.z.to_array());
    let (tmax, dark) = (tmax.to_array(), dark.to_bitmask());
    let spec = lanes.gather3(&q.sr, &q.sg, &q.sb);
    let phong = !(spec.x.simd_eq(zero) & spec.y.simd_eq(zero) & spec.z.simd_eq(zero)).to_bitmask();
    let (factor, (rx, ry, rz)) = (factor.to_array(), (r.x.to_array(), r.y.to_array(), r.z.to_array()));
    // The lanes that cast a ray, then whole columns at once.
    let (mut keep, mut m, mut cast) = ([0usize; LANES], 0, 0u32);
    for k in (0..triples.count).filter(|&k| dark & (1 << k) == 0) {
        keep[m] = k;
        m += 1;
        cast |= 1 << k;
        let p = si[k] as usize;
        if phong & (1 << k) != 0 {
            let wi = Vec3::new(wx[k], wy[k], wz[k]);
            let brdf = diffuse_brdf(q.color(p), q.specular(p), q.shininess[p], q.normal(p), wi, q.wo(p));
            let l = q.weight(p) * brdf * Vec3::new(rx[k], ry[k], rz[k]) * factor[k];
            (lr[k], lg[k], lb[k]) = (l.x, l.y, l.z);
        }
    }
    if CELLS {
        cells.extend(lanes_of(cast).map(|k| cell[k]));
    }
    let (o, wi, slot) = (o.lanes(), [wx, wy, wz], si.map(|p| q.slot[p as usize]));
    // Each ray carries its point's path time.
    let time = (!q.time.is_empty()).then(|| si.map(|p| q.time[p as usize]));
    // Every lane kept (the usual group): whole vectors, no per-value push.
    if m == LANES {
        shadow.push_lanes(o, wi, tmax, slot, [lr, lg, lb], time.as_ref(), LANES);
    } else {
        shadow.push_picked(o, wi, tmax, slot, [lr, lg, lb], time.as_ref(), &keep[..m]);
    }
    cast
}
