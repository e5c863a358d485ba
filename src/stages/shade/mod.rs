//! Shading: reads the ray and hit queues; sends escaped rays and visible emitters to
//! the film queue, mirror or dielectric hits to the specular list for the scatter
//! stage, and diffuse hits' direct lighting to the shadow queue (one ray per point
//! light; per area light `shadows.samples` stratified rays in uniform mode, or one entry
//! in the shadow-corner queue in adaptive mode when the light's probes cost at most 0.8
//! of its samples, else the uniform rays). Uniform shadow rays to quad lights are
//! computed on 16 lanes at a time, in the order and with the bits of the scalar loop.

use glam::Vec3;
use std::f32::consts::FRAC_1_PI;
use wide::{f32x16, u32x16};

mod path;
use path::path_lights;

use crate::accel::NO_LIGHT;
use crate::emitter::area::{quad_sample, QuadLanes};
use crate::light::{
    emitted, hit_light_pdf, light_seed_lanes, probes_light, uniform_shadow_rays, unoccluded, SHADOW_TMAX_SCALE,
};
use crate::queue::{
    sparse_opt, FilmQueue, HitQueue, IndexQueue, RayQueue, ShadowPointQueue, ShadowQueue, SurfaceQueue, MISS,
};
use crate::sampling::power_heuristic;
use crate::scene::{Light, Scene, ShadowMode, Transport};
use crate::simd::{LaneIds, Word, LANES, V3};
use crate::surface::{diffuse_brdf, diffuse_material, diffuse_surfaces, queued_surface};

/// What the shade stage counted for the adaptive shadow test's stats.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ShadeCounts {
    /// Shadow rays uniform mode would have cast for the points put in the shadow-corner
    /// queue.
    pub uniform_equivalent: u64,
    /// (point, area light) pairs of adaptive mode sampled uniformly because the light's
    /// probes would cost more than 0.8 of its samples ([`probes_light`]).
    pub uniform_fallback: u64,
}

/// The queues the shade stage writes: every one cleared first but `film`, which collects
/// the wave's contributions and is appended to.
pub struct Shaded<'a> {
    /// Uniform shadow rays (point lights, quad lights not probed).
    pub shadow: &'a mut ShadowQueue,
    /// (point, area light) pairs for the adaptive shadow test.
    pub points: &'a mut ShadowPointQueue,
    /// The diffuse shading points.
    pub surfaces: &'a mut SurfaceQueue,
    /// Rays that hit a mirror or a dielectric (indices into the ray queue).
    pub specular: &'a mut IndexQueue,
    /// Background and emitters seen.
    pub film: &'a mut FilmQueue,
}

/// Shades every ray of `rays` at its hit in `hits`: sorts the hits ([`sort_hits`]), then
/// casts the diffuse points' shadow rays or queues them for the adaptive test
/// ([`light_points`]) as `shadows` (the render's mode, never `Auto`) says.
pub fn shade(scene: &Scene, shadows: ShadowMode, rays: &RayQueue, hits: &HitQueue, out: Shaded) -> ShadeCounts {
    let Shaded { shadow, points, surfaces, specular, film } = out;
    shadow.clear();
    points.clear();
    surfaces.clear();
    specular.clear();
    sort_hits(scene, rays, hits, surfaces, specular, film);
    light_points(scene, shadows, surfaces, shadow, points)
}

/// Settles every hit that needs no shadow ray (the background of a miss, an emitter seen,
/// into `film`), queues mirrors and dielectrics in `specular`, and fills `surfaces` with
/// the diffuse hits, 16 at a time in ray order.
fn sort_hits(
    scene: &Scene,
    rays: &RayQueue,
    hits: &HitQueue,
    surfaces: &mut SurfaceQueue,
    specular: &mut IndexQueue,
    film: &mut FilmQueue,
) {
    let (mut group, mut len) = ([0u32; LANES], 0);
    let s = &scene.settings;
    // The path transport: `hide_emitters` blacks out what camera rays see of emitters and
    // the background, and a diffuse hit past the last bounce only adds what it emits
    // (nothing).
    let (path, hide) = match s.transport {
        Transport::Path { hide_emitters, .. } => (true, hide_emitters),
        Transport::Whitted => (false, false),
    };
    let hidden = |i: usize| hide && rays.depth[i] == 0;
    let (environment, sampled) = (!scene.background.is_black(), scene.samples_environment());
    // Rays that escape and share the environment with their light samples, 16 at a time.
    let (mut escaped, mut escapes) = ([0u32; LANES], 0);
    for i in 0..rays.len() {
        if hits.prim[i] == MISS {
            if environment && !hidden(i) {
                // A surface's ray shares the environment with its light samples (MIS); an
                // adaptive-shadow bounce (negative density) has no environment sample
                // beside it, and takes all.
                if sampled && rays.pdf[i] > 0.0 {
                    escaped[escapes] = i as u32;
                    escapes += 1;
                    if escapes == LANES {
                        shared_environment(scene, rays, &escaped, film);
                        escapes = 0;
                    }
                } else {
                    film.push(rays.slot[i], rays.weight(i) * scene.background.eval(rays.dir(i)));
                }
            }
            continue;
        }
        if diffuse_material(scene, hits.prim[i]).is_some() {
            if path && rays.depth[i] >= s.max_depth {
                continue;
            }
            group[len] = i as u32;
            len += 1;
            if len == LANES {
                diffuse_surfaces(scene, rays, hits, &group, surfaces);
                len = 0;
            }
            continue;
        }
        let light = scene.accel.light(hits.prim[i]);
        if light != NO_LIGHT {
            if hidden(i) {
                continue;
            }
            if let Some(radiance) = emitted(&scene.lights[light as usize], rays.origin(i), rays.dir(i)) {
                // A surface's ray shares this light with its light samples (MIS), or
                // leaves it to them (a negative density: weight 0).
                let pdf = rays.pdf[i];
                let mis = if pdf != 0.0 {
                    power_heuristic(pdf, hit_light_pdf(scene, light, rays.origin(i), rays.dir(i), hits.t[i]))
                } else {
                    1.0
                };
                film.push(rays.slot[i], rays.weight(i) * radiance * mis);
            }
        } else if rays.depth[i] < s.max_depth {
            specular.push(i as u32);
        }
    }
    diffuse_surfaces(scene, rays, hits, &group[..len], surfaces);
    if escapes > 0 {
        shared_environment(scene, rays, &escaped[..escapes], film);
    }
}

/// The environment seen by rays `ids` (1 to 16, escaped), each weighted by the power
/// heuristic against the density with which its surface's light samples draw it.
fn shared_environment(scene: &Scene, rays: &RayQueue, ids: &[u32], film: &mut FilmQueue) {
    let lanes = LaneIds::new(ids);
    let d = V3 { x: lanes.gather(&rays.dx), y: lanes.gather(&rays.dy), z: lanes.gather(&rays.dz) };
    let (radiance, env_pdf) = scene.background.eval_pdf_lanes(d, ids.len());
    let (radiance, env_pdf) = (radiance.lanes(), env_pdf.to_array());
    for (k, &i) in ids.iter().enumerate() {
        let i = i as usize;
        let l = Vec3::new(radiance[0][k], radiance[1][k], radiance[2][k]);
        film.push(rays.slot[i], rays.weight(i) * l * power_heuristic(rays.pdf[i], env_pdf[k]));
    }
}

/// The lights of every point of `surfaces`: uniform shadow rays into `shadow`, or, for an
/// area light the adaptive test probes, the (point, light) pair into `points` (its
/// unoccluded contribution costs no ray; the shadow-corner stage decides whether it
/// reaches the film).
fn light_points(
    scene: &Scene,
    shadows: ShadowMode,
    surfaces: &SurfaceQueue,
    shadow: &mut ShadowQueue,
    points: &mut ShadowPointQueue,
) -> ShadeCounts {
    let s = &scene.settings;
    // The lights the adaptive test probes; the others are sampled as in uniform mode.
    let probed = |li: usize| match shadows {
        ShadowMode::Adaptive(probe) => probes_light(&scene.lights[li], probe, s.shadow_samples),
        ShadowMode::Uniform | ShadowMode::Auto(_) => false,
    };
    let mut counts = ShadeCounts::default();
    if s.path() && shadows == ShadowMode::Uniform {
        path_lights(scene, surfaces, shadow);
        return counts;
    }
    if let ShadowMode::Adaptive(probe) = shadows {
        let fallback = scene.lights.iter().filter(|l| l.lit_area() && !probes_light(l, probe, s.shadow_samples));
        counts.uniform_fallback = fallback.count() as u64 * surfaces.len() as u64;
    }
    // Uniform shadows go on lanes when every light is a quad (a point light's one ray
    // would interleave with them, and keeps the scalar loop).
    let any_probed = (0..scene.lights.len()).any(probed);
    if !any_probed && scene.lights.iter().all(|l| matches!(l, Light::Quad { .. })) {
        quad_shadow_lanes(scene, surfaces, shadow);
        return counts;
    }
    for p in 0..surfaces.len() {
        let surf = queued_surface(surfaces, p);
        // The point's rays carry its path's time.
        let time = sparse_opt(&surfaces.time, p);
        for li in 0..scene.lights.len() {
            // Count the rays uniform mode would have cast for a probed light, for the stats.
            match probed(li).then(|| unoccluded(scene, &surf, li)).flatten() {
                Some((_, 0)) => {}
                Some((sum, n)) => {
                    points.push(p as u32, li as u32, surf.slot, sum);
                    counts.uniform_equivalent += n;
                }
                None => {
                    uniform_shadow_rays(scene, &surf, li, |wi, tmax, l| {
                        shadow.push(surf.o, wi, tmax, surf.slot, l, time);
                    });
                }
            }
        }
    }
    counts
}

/// Uniform shadow rays from every point of `surfaces` to every lit quad light, 16
/// (point, light, sample) triples at a time, in the scalar loop's order (point, then
/// light, then sample): the queue, and every sum taken over it later, keeps its bits.
fn quad_shadow_lanes(scene: &Scene, surfaces: &SurfaceQueue, shadow: &mut ShadowQueue) {
    let n = scene.settings.shadow_samples;
    let lit = |li: usize| matches!(scene.lights[li], Light::Quad { radiance, .. } if radiance != Vec3::ZERO);
    let next_lit = |from: usize| (from..scene.lights.len()).find(|&li| lit(li));
    let Some(first) = next_lit(0) else { return };
    // The usual scene has one lit light: no search per point then.
    let single = next_lit(first + 1).is_none();
    let (mut s, mut li, mut j) = (0, first, 0);
    let mut lanes = Triples { point: [0; LANES], light: [0; LANES], sample: [0; LANES], count: 0 };
    // One light and n dividing 16 (the usual case): whole groups of 16 / n points, the
    // same triples without the lane-by-lane walk.
    if single && n.is_power_of_two() && n as usize <= LANES {
        let per = LANES / n as usize;
        let shift = n.trailing_zeros();
        lanes.light = [first as u32; LANES];
        lanes.sample = std::array::from_fn(|k| k as u32 & (n - 1));
        lanes.count = LANES;
        while s + per <= surfaces.len() {
            lanes.point = std::array::from_fn(|k| s as u32 + (k as u32 >> shift));
            quad_lanes(scene, surfaces, &lanes, shadow);
            s += per;
        }
    }
    while s < surfaces.len() {
        let mut count = 0;
        while count < LANES && s < surfaces.len() {
            (lanes.point[count], lanes.light[count], lanes.sample[count]) = (s as u32, li as u32, j);
            count += 1;
            j += 1;
            if j == n {
                j = 0;
                if single {
                    s += 1;
                } else {
                    li = next_lit(li + 1).unwrap_or_else(|| {
                        s += 1;
                        first
                    });
                }
            }
        }
        // Lanes past the last triple repeat it and are not written.
        for k in count..LANES {
            (lanes.point[k], lanes.light[k], lanes.sample[k]) =
                (lanes.point[k - 1], lanes.light[k - 1], lanes.sample[k - 1]);
        }
        lanes.count = count;
        quad_lanes(scene, surfaces, &lanes, shadow);
    }
}

/// One lane group of (point, light, sample) triples, the first `count` real.
struct Triples {
    point: [u32; LANES],
    light: [u32; LANES],
    sample: [u32; LANES],
    count: usize,
}

/// The quad lights of a lane group: their geometry, area / n and radiance per lane.
struct LightLanes {
    quad: QuadLanes<f32x16>,
    scale: f32x16,
    radiance: V3<f32x16>,
}

impl LightLanes {
    /// The lights of `lights` (indices in the scene): splat when all lanes share one.
    fn new(scene: &Scene, lights: &[u32; LANES]) -> LightLanes {
        let n = scene.settings.shadow_samples as f32;
        let params = |li: u32| match scene.lights[li as usize] {
            Light::Quad { corner, u, v, normal, area, radiance } => (corner, u, v, normal, area / n, radiance),
            // Not reached: lanes run only when every light is a quad.
            Light::Point { .. } | Light::Directional { .. } | Light::Sphere { .. } | Light::Triangle { .. } => {
                (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, 0.0, Vec3::ZERO)
            }
        };
        if lights.iter().all(|&l| l == lights[0]) {
            let (corner, u, v, normal, scale, radiance) = params(lights[0]);
            let quad = QuadLanes::splat(corner, u, v, normal);
            return LightLanes { quad, scale: f32x16::splat(scale), radiance: V3::splat(radiance) };
        }
        let p: [_; LANES] = std::array::from_fn(|k| params(lights[k]));
        let f = |g: &dyn Fn(usize) -> f32| f32x16::from(std::array::from_fn::<f32, LANES, _>(g));
        let v = |g: &dyn Fn(usize) -> Vec3| V3 { x: f(&|k| g(k).x), y: f(&|k| g(k).y), z: f(&|k| g(k).z) };
        let quad = QuadLanes { corner: v(&|k| p[k].0), u: v(&|k| p[k].1), v: v(&|k| p[k].2), normal: v(&|k| p[k].3) };
        LightLanes { quad, scale: f(&|k| p[k].4), radiance: v(&|k| p[k].5) }
    }
}

/// The shadow rays of one lane group of `triples`: the scalar formulas of
/// [`area_light_samples`](crate::light::area_light_samples) (through [`quad_sample`]), Lambert on the lanes and a Phong
/// point's BRDF by the scalar function.
fn quad_lanes(scene: &Scene, q: &SurfaceQueue, triples: &Triples, shadow: &mut ShadowQueue) {
    let n = scene.settings.shadow_samples;
    let si = triples.point;
    // A run of consecutive points (one sample, one light) loads straight from the queue.
    let lanes = LaneIds::new(&si);
    // Straight calls, not closures: a closure over the loads was kept out of line.
    let lights = LightLanes::new(scene, &triples.light);
    let (o, normal) = (lanes.gather3(&q.ox, &q.oy, &q.oz), lanes.gather3(&q.nx, &q.ny, &q.nz));
    let index = lanes.gather_words(&q.sample).wmul(u32x16::splat(n)).wadd(u32x16::from(triples.sample));
    let seed = light_seed_lanes(lanes.gather_words(&q.key), u32x16::from(triples.light));
    let s = quad_sample(&lights.quad, o, normal, index, seed, false);
    let factor = s.cos_x * s.cos_y * lights.scale / s.dist2;
    let w = lanes.gather3(&q.wr, &q.wg, &q.wb);
    let brdf = lanes.gather3(&q.cr, &q.cg, &q.cb).scale(f32x16::splat(FRAC_1_PI));
    let r = lights.radiance;
    let l = |w: f32x16, b: f32x16, r: f32x16| (w * b * r * factor).to_array();
    let (mut lr, mut lg, mut lb) = (l(w.x, brdf.x, r.x), l(w.y, brdf.y, r.y), l(w.z, brdf.z, r.z));
    let (wx, wy, wz) = (s.wi.x.to_array(), s.wi.y.to_array(), s.wi.z.to_array());
    let tmax = (s.dist * f32x16::splat(SHADOW_TMAX_SCALE)).to_array();
    let dark = (s.cos_x.simd_le(f32x16::ZERO) | s.cos_y.simd_le(f32x16::ZERO)).to_bitmask();
    let spec = lanes.gather3(&q.sr, &q.sg, &q.sb);
    let phong =
        !(spec.x.simd_eq(f32x16::ZERO) & spec.y.simd_eq(f32x16::ZERO) & spec.z.simd_eq(f32x16::ZERO)).to_bitmask();
    let (factor, (rx, ry, rz)) = (factor.to_array(), (r.x.to_array(), r.y.to_array(), r.z.to_array()));
    // The lanes that cast a ray, then whole columns at once.
    let (mut keep, mut m) = ([0usize; LANES], 0);
    for k in (0..triples.count).filter(|&k| dark & (1 << k) == 0) {
        keep[m] = k;
        m += 1;
        let p = si[k] as usize;
        if phong & (1 << k) != 0 {
            let wi = Vec3::new(wx[k], wy[k], wz[k]);
            let brdf = diffuse_brdf(q.color(p), q.specular(p), q.shininess[p], q.normal(p), wi, q.wo(p));
            let l = q.weight(p) * brdf * Vec3::new(rx[k], ry[k], rz[k]) * factor[k];
            (lr[k], lg[k], lb[k]) = (l.x, l.y, l.z);
        }
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
}
