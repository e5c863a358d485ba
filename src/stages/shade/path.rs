//! Next-event estimation of the path transport, 16 (point, light sample) pairs at a time:
//! the light picked and the point on it sampled as [`gloss_light_sample`] does, weighted
//! by the power heuristic against the cosine density of the point's bounce ray.

use glam::Vec3;
use std::f32::consts::FRAC_1_PI;
use wide::{f32x16, u32x16};

use crate::light::{quad_sample, uniform_shadow_rays, QuadLanes, SHADOW_TMAX_SCALE};
use crate::queue::{sparse_opt, ShadowQueue, SurfaceQueue};
use crate::sampling::{dim, hash_lanes, sobol_owen_lanes};
use crate::scene::{Light, Scene};
use crate::simd::{LaneIds, Real, Word, LANES, V3};
use crate::surface::{diffuse_brdf, queued_surface};

/// Next-event estimation at every point of `surfaces`: a ray to each point light, and
/// `shadows.samples` points on the area lights (light sample j of the path's camera
/// sample i is sample i·n + j of its sequences, so a pixel's samples are stratified
/// together), each light chosen uniformly and the point uniformly over its area,
/// weighted by the power heuristic against the density with which the point's bounce
/// ray (stage `bounce`) could have found the same point.
pub(super) fn path_lights(scene: &Scene, surfaces: &SurfaceQueue, shadow: &mut ShadowQueue) {
    let points = (0..scene.lights.len()).filter(|&li| matches!(scene.lights[li], Light::Point { .. }));
    for li in points {
        for p in 0..surfaces.len() {
            let (surf, time) = (queued_surface(surfaces, p), sparse_opt(&surfaces.time, p));
            uniform_shadow_rays(scene, &surf, li, |wi, tmax, l| shadow.push(surf.o, wi, tmax, surf.slot, l, time));
        }
    }
    if scene.gloss_lights.is_empty() {
        return;
    }
    let table = Table::new(scene);
    let n = scene.settings.shadow_samples as usize;
    let total = surfaces.len() * n;
    let mut start = 0;
    while start < total {
        let count = (total - start).min(LANES);
        // Lanes past the last pair repeat it and are not written.
        let pair = |k: usize| start + k.min(count - 1);
        let point: [u32; LANES] = std::array::from_fn(|k| (pair(k) / n) as u32);
        let sample: [u32; LANES] = std::array::from_fn(|k| (pair(k) % n) as u32);
        area_lanes(scene, &table, surfaces, (&point, &sample, count), shadow);
        start += count;
    }
}

/// The scene's area lights (its `gloss_lights`) as columns, gathered per lane by the
/// light's position in that list.
struct Table {
    c: [Vec<f32>; 15],
    /// The light's area times the number of lights (the pick's probability inverted).
    area: Vec<f32>,
    triangle: Vec<bool>,
}

impl Table {
    fn new(scene: &Scene) -> Table {
        let count = scene.gloss_lights.len() as f32;
        let mut t = Table { c: Default::default(), area: Vec::new(), triangle: Vec::new() };
        for &li in &scene.gloss_lights {
            let (o, u, v, normal, area, radiance, tri) = match scene.lights[li as usize] {
                Light::Quad { corner, u, v, normal, area, radiance } => (corner, u, v, normal, area, radiance, false),
                Light::Triangle { v0, e1, e2, normal, area, radiance } => (v0, e1, e2, normal, area, radiance, true),
                // Not among the scene's area lights.
                Light::Point { .. } => (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, 0.0, Vec3::ZERO, false),
            };
            for (col, x) in t.c.iter_mut().zip([o, u, v, normal, radiance].iter().flat_map(|v| v.to_array())) {
                col.push(x);
            }
            t.area.push(area * count);
            t.triangle.push(tri);
        }
        t
    }
}

/// The area lights' parameters per lane.
struct Lights {
    quad: QuadLanes<f32x16>,
    area: f32x16,
    radiance: V3<f32x16>,
    /// Lanes on a triangle light (bit k).
    triangles: u32,
}

impl Lights {
    /// Lane k on light `pick[k]` of the table.
    fn of(t: &Table, pick: &[u32; LANES]) -> Lights {
        let lanes = LaneIds::new(pick);
        let v = |i: usize| V3 { x: lanes.gather(&t.c[i]), y: lanes.gather(&t.c[i + 1]), z: lanes.gather(&t.c[i + 2]) };
        let quad = QuadLanes { corner: v(0), u: v(3), v: v(6), normal: v(9) };
        let triangles = (0..LANES).filter(|&k| t.triangle[pick[k] as usize]).fold(0, |m, k| m | 1 << k);
        Lights { quad, area: lanes.gather(&t.area), radiance: v(12), triangles }
    }
}

/// The light samples of one lane group: pair k is sample `sample[k]` of point
/// `point[k]`, the first `count` real; `table` holds the area lights.
fn area_lanes(
    scene: &Scene,
    table: &Table,
    q: &SurfaceQueue,
    (point, sample, count): (&[u32; LANES], &[u32; LANES], usize),
    shadow: &mut ShadowQueue,
) {
    let lanes = LaneIds::new(point);
    let f = |v: &[f32]| lanes.gather(v);
    let v3 = |x: &[f32], y: &[f32], z: &[f32]| V3 { x: f(x), y: f(y), z: f(z) };
    let (o, normal) = (v3(&q.ox, &q.oy, &q.oz), v3(&q.nx, &q.ny, &q.nz));
    let n = scene.settings.shadow_samples;
    let key = lanes.gather_words(&q.key);
    let index = lanes.gather_words(&q.sample).wmul(u32x16::splat(n)).wadd(u32x16::from(*sample));
    // The light: one, or picked by the path's sequence.
    let lights = &scene.gloss_lights;
    let pick: [u32; LANES] = if lights.len() == 1 {
        [0; LANES]
    } else {
        let (u, _) = sobol_owen_lanes(index, hash_lanes([key, u32x16::splat(dim::GLOSS_LIGHT_PICK)]));
        let m = lights.len();
        u.to_array().map(|u| ((u * m as f32) as usize).min(m - 1) as u32)
    };
    let l = Lights::of(table, &pick);
    let li = pick.map(|j| lights[j as usize]);
    let seed = hash_lanes([key, u32x16::from(li), u32x16::splat(dim::GLOSS_LIGHT)]);
    // Quads and triangles differ only in the fold of the unit square: a mixed group
    // samples both and picks per lane.
    let s = match l.triangles {
        0 => quad_sample(&l.quad, o, normal, index, seed, false),
        t if t == (1 << LANES) - 1 => quad_sample(&l.quad, o, normal, index, seed, true),
        t => {
            let (a, b) = (
                quad_sample(&l.quad, o, normal, index, seed, false),
                quad_sample(&l.quad, o, normal, index, seed, true),
            );
            let m = f32x16::from(std::array::from_fn::<f32, LANES, _>(|k| if t & (1 << k) != 0 { -1.0 } else { 1.0 }));
            let pick = |x: f32x16, y: f32x16| f32x16::if_negative(m, y, x);
            crate::light::QuadSample {
                uv: a.uv,
                wi: V3::if_negative(m, b.wi, a.wi),
                dist: pick(a.dist, b.dist),
                dist2: pick(a.dist2, b.dist2),
                cos_x: pick(a.cos_x, b.cos_x),
                cos_y: pick(a.cos_y, b.cos_y),
            }
        }
    };
    // Density of the point per solid angle (n samples), and the bounce ray's for it.
    let zero = f32x16::ZERO;
    let live = s.cos_x.simd_gt(zero) & s.cos_y.simd_gt(zero) & s.dist2.simd_gt(zero);
    let light_pdf = s.dist2 / (s.cos_y * l.area) * f32x16::splat(n as f32);
    let bsdf_pdf = s.cos_x * f32x16::splat(FRAC_1_PI);
    let r = bsdf_pdf / light_pdf;
    // Power heuristic over the light density, cos_x / light_pdf folded in.
    let factor = s.cos_x / (light_pdf * (f32x16::ONE + r * r));
    let factor = live.select(factor, zero);
    let w = v3(&q.wr, &q.wg, &q.wb);
    let brdf = v3(&q.cr, &q.cg, &q.cb).scale(f32x16::splat(FRAC_1_PI));
    let c = |w: f32x16, b: f32x16, r: f32x16| (w * b * r * factor).to_array();
    let (mut lr, mut lg, mut lb) =
        (c(w.x, brdf.x, l.radiance.x), c(w.y, brdf.y, l.radiance.y), c(w.z, brdf.z, l.radiance.z));
    let spec = v3(&q.sr, &q.sg, &q.sb);
    let phong = !(spec.x.simd_eq(zero) & spec.y.simd_eq(zero) & spec.z.simd_eq(zero)).to_bitmask();
    let (wx, wy, wz) = (s.wi.x.to_array(), s.wi.y.to_array(), s.wi.z.to_array());
    let (live, fa) = (live.to_bitmask(), factor.to_array());
    let (rx, ry, rz) = (l.radiance.x.to_array(), l.radiance.y.to_array(), l.radiance.z.to_array());
    let (mut keep, mut m) = ([0usize; LANES], 0);
    for k in (0..count).filter(|&k| live & (1 << k) != 0) {
        if phong & (1 << k) != 0 {
            let p = point[k] as usize;
            let wi = Vec3::new(wx[k], wy[k], wz[k]);
            let brdf = diffuse_brdf(q.color(p), q.specular(p), q.shininess[p], q.normal(p), wi, q.wo(p));
            let v = q.weight(p) * brdf * Vec3::new(rx[k], ry[k], rz[k]) * fa[k];
            (lr[k], lg[k], lb[k]) = (v.x, v.y, v.z);
        }
        if lr[k] != 0.0 || lg[k] != 0.0 || lb[k] != 0.0 {
            keep[m] = k;
            m += 1;
        }
    }
    let tmax = (s.dist * f32x16::splat(SHADOW_TMAX_SCALE)).to_array();
    let slot = point.map(|p| q.slot[p as usize]);
    let time = (!q.time.is_empty()).then(|| point.map(|p| q.time[p as usize]));
    shadow.push_picked(o.lanes(), [wx, wy, wz], tmax, slot, [lr, lg, lb], time.as_ref(), &keep[..m]);
}
