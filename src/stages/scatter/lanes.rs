//! Plastic, rough conductor and rough glass hits 16 at a time: the light samples and the
//! one ray of each, with the BSDF evaluated and sampled on lanes
//! ([`Plastic::eval_pdf_lanes`], [`RoughConductor::eval_pdf_lanes`],
//! [`RoughDielectric::eval_pdf_lanes`] and their samplers). The light samples themselves
//! are drawn point by point ([`light_samples`]).
//!
//! Each ray's microfacet sample and its branch (a plastic's lobe, rough glass's
//! reflection with probability F, else its refraction, as Mitsuba chooses) are point
//! `sample` of the path's Owen-scrambled Sobol sequences keyed by its key and
//! [`dim::GLOSS`], [`dim::GLOSS_BRANCH`]: stratified over the pixel's samples. Under
//! multiple importance sampling the light samples are weighted by the power heuristic
//! against the BSDF's density, and the ray carries its own density, which weights the
//! emitter it may hit (shade).

use glam::Vec3;
use wide::{f32x16, u32x16};

use super::Scattered;
use crate::accel::offset::offset_lanes;
use crate::bsdf::microfacet::{tangents_lanes, RoughConductor, RoughDielectric};
use crate::bsdf::plastic::{Plastic, TABLE_RES};
use crate::emitter::sphere::sphere_sample;
use crate::light::{gloss_light_sample, light_seed, SHADOW_TMAX_SCALE};
use crate::queue::{sparse_opt, HitQueue, RayQueue};
use crate::sampling::{dim, hash_lanes, power_heuristic, sobol_owen, sobol_owen_lanes};
use crate::scene::{Color, Light, Material, Scene};
use crate::simd::{LaneIds, LANES, V3};
use crate::surface::{color_at, hit_lanes, shading_lanes, HitLanes};

type F = f32x16;

/// Lane k of `v` (arrays from [`V3::lanes`]).
fn at(v: &[[f32; LANES]; 3], k: usize) -> Vec3 {
    Vec3::new(v[0][k], v[1][k], v[2][k])
}

/// True for the materials [`glossy_lanes`] takes: plastics, rough conductors and rough
/// glass.
pub(super) fn on_lanes(m: &Material) -> bool {
    matches!(
        m,
        Material::Plastic { .. }
            | Material::Conductor { roughness: Some(_), .. }
            | Material::Dielectric { roughness: Some(_), .. }
    )
}

/// The BSDF of 16 hits of one material, with each lane's texture colour.
enum Lobes<'a> {
    /// A plastic and its base reflectances.
    Plastic(Plastic<'a>, V3<F>),
    /// A rough conductor and its colours.
    Conductor(RoughConductor, V3<F>),
    /// Rough glass and the tint of light it transmits.
    Glass(RoughDielectric, Vec3),
}

/// The sampled rays of 16 hits, local.
struct Sampled {
    wo: V3<F>,
    /// f·cos / density (times the texture colour).
    weight: V3<F>,
    pdf: F,
    /// Bit k: lane k has a ray.
    valid: u32,
    /// Bit k: lane k's ray goes through the surface.
    through: u32,
}

impl Lobes<'_> {
    /// f·cos θo and the sampling density of each lane's local directions.
    fn eval_pdf(&self, wi: V3<F>, wo: V3<F>) -> (V3<F>, F) {
        match self {
            Lobes::Plastic(bsdf, diffuse) => bsdf.eval_pdf_lanes(*diffuse, wi, wo),
            Lobes::Conductor(c, color) => {
                let (f, pdf) = c.eval_pdf_lanes(wi, wo);
                (color.times(f), pdf)
            }
            Lobes::Glass(g, tint) => {
                // Transmission is tinted, as the refracted ray is.
                let (f, pdf) = g.eval_pdf_lanes(wi, wo);
                let tinted = V3::select((wi.z * wo.z).simd_gt(F::ZERO), V3::splat(Vec3::ONE), V3::splat(*tint));
                (tinted.scale(f), pdf)
            }
        }
    }

    /// One ray per lane: the lobe picked by `u1` (plastic), the direction from `u2`.
    fn sample(&self, wi: V3<F>, u1: F, u2: [F; 2]) -> Sampled {
        match self {
            Lobes::Plastic(bsdf, diffuse) => {
                let s = bsdf.sample_lanes(*diffuse, wi, u1, u2);
                Sampled { wo: s.wo, weight: s.weight, pdf: s.pdf, valid: s.valid, through: 0 }
            }
            Lobes::Conductor(c, color) => {
                let (wo, weight, above) = c.sample_lanes(wi, u2);
                let pdf = c.eval_pdf_lanes(wi, wo).1;
                Sampled { wo, weight: color.times(weight), pdf, valid: above.to_bitmask(), through: 0 }
            }
            Lobes::Glass(g, tint) => {
                // The reflection with probability F, else the refraction (Mitsuba's
                // choice), each weighted by its branch weight over its probability.
                let split = g.split_lanes(wi, u2);
                let reflect = u1.simd_lt(split.f);
                let (r, t) = (split.reflect, split.refract);
                let wo = V3::select(reflect, r.0, t.0);
                let over = reflect.select(r.1 / split.f, t.1 / (F::splat(1.0) - split.f));
                let tinted = V3::select(reflect, V3::splat(Vec3::ONE), V3::splat(*tint));
                let valid = reflect.select(r.2, t.2).to_bitmask();
                let pdf = g.eval_pdf_lanes(wi, wo).1;
                Sampled { wo, weight: tinted.scale(over), pdf, valid, through: !reflect.to_bitmask() }
            }
        }
    }
}

/// The light samples' shadow rays and the scattered rays of hits `ids` (1 to 16, in queue
/// order, all on `material`, one [`on_lanes`] takes). The side the ray arrived on is the
/// front (a one-sided plastic seen from behind is black); a plastic's lobe is picked by
/// point `sample` of the path's [`dim::GLOSS_BRANCH`] sequence and the direction drawn
/// from its [`dim::GLOSS`] one; the light samples are weighted by the power heuristic
/// against the BSDF's density, and the ray carries that density.
pub(super) fn glossy_lanes(
    scene: &Scene,
    rays: &RayQueue,
    hits: &HitQueue,
    ids: &[u32],
    material: &Material,
    out: Scattered,
) {
    let Scattered { next, shadow } = out;
    let count = ids.len();
    let lanes = LaneIds::new(ids);
    let HitLanes { d, p, err, ng } = hit_lanes(scene, rays, hits, ids);
    let front = d.dot(ng).simd_lt(F::ZERO);
    let all = (1u32 << count) - 1;
    // Rough glass is oriented by its outward normal, the others by the side the ray
    // arrived on.
    let glass = matches!(material, Material::Dielectric { .. });
    let n = shading_lanes(scene, rays, hits, ids, p, if glass { ng } else { V3::select(front, ng, -ng) });
    let (ts, tt) = tangents_lanes(n);
    let to_local = |v: V3<F>| V3 { x: v.dot(ts), y: v.dot(tt), z: v.dot(n) };
    let wi = to_local(-d);
    let points = p.lanes();
    let time = |k: usize| sparse_opt(&rays.time, lanes.idx[k]);
    let colors = |color: Color| match color {
        Color::Rgb(c) => V3::splat(c),
        Color::Texture(_) => V3::from_fn(|k| {
            color_at(scene, color, hits.prim[lanes.idx[k]] as usize, time(k).unwrap_or_default(), at(&points, k))
        }),
    };
    let (lobes, live) = match *material {
        Material::Plastic {
            color,
            specular,
            eta,
            ref roughness,
            nonlinear,
            two_sided,
            internal,
            specular_weight,
            table,
        } => {
            let bsdf = Plastic {
                diffuse: Vec3::ZERO,
                specular,
                eta,
                roughness: roughness.as_ref(),
                table: scene.transmittance.get(table as usize).unwrap_or(&[0.0; TABLE_RES]),
                internal,
                nonlinear,
                specular_weight,
            };
            // A one-sided plastic seen from behind is black.
            let live = if two_sided { all } else { front.to_bitmask() & all };
            (Lobes::Plastic(bsdf, colors(color)), live)
        }
        Material::Conductor { eta, k, color, roughness: Some(mf) } => {
            // Below the shading normal a conductor has nothing to reflect.
            let live = wi.z.simd_gt(F::ZERO).to_bitmask() & all;
            (Lobes::Conductor(RoughConductor { mf, eta, k }, colors(color)), live)
        }
        Material::Dielectric { ior, tint, roughness: Some(mf), .. } => {
            (Lobes::Glass(RoughDielectric { mf, eta: ior }, tint), all)
        }
        _ => {
            debug_assert!(false, "not a material on lanes");
            return;
        }
    };
    if live == 0 {
        return;
    }
    let (key, sample) = (lanes.gather_words(&rays.key), lanes.gather_words(&rays.sample));
    let (keys, samples) = (key.to_array(), sample.to_array());
    let w: [Vec3; LANES] = std::array::from_fn(|k| rays.weight(lanes.idx[k]));
    // The side of the surface a direction leaves on, for its origin.
    let origins = |dir: V3<F>| offset_lanes(p, err, V3::if_negative(-dir.dot(ng), ng, -ng)).lanes();

    let (mis, delta) = samples_lights(scene);
    if mis {
        // Slot by slot: each lane's sample, then the BSDF for all 16 at once.
        let slots = light_slots(scene, delta);
        let mut drawn = vec![[None::<LightSample>; LANES]; slots];
        for k in (0..count).filter(|&k| live & (1 << k) != 0) {
            light_samples(scene, at(&points, k), (keys[k], samples[k]), delta, |j, s| drawn[j][k] = Some(s));
        }
        if scene.samples_environment() {
            let u = sobol_owen_lanes(sample, hash_lanes([key, u32x16::splat(dim::ENVIRONMENT)]));
            let e = scene.background.sample_lanes([u.0, u.1], count);
            let (dir, radiance, pdf) = (e.wi.lanes(), e.radiance.lanes(), e.pdf.to_array());
            for k in (0..count).filter(|&k| live & e.valid & (1 << k) != 0) {
                let s = LightSample {
                    wi: at(&dir, k),
                    tmax: f32::MAX,
                    radiance: at(&radiance, k),
                    pdf: pdf[k],
                    delta: false,
                };
                drawn[slots - 1][k] = Some(s);
            }
        }
        let mut lit = Vec::with_capacity(slots);
        for row in &drawn {
            let dir = V3::from_fn(|k| row[k].map_or(Vec3::Z, |s| s.wi));
            let (f, pdf) = lobes.eval_pdf(wi, to_local(dir));
            lit.push((f.lanes(), pdf.to_array(), origins(dir)));
        }
        for k in 0..count {
            for (row, (f, pdf, o)) in drawn.iter().zip(&lit) {
                let Some(s) = row[k] else { continue };
                if let Some(c) = shadow_weight(w[k], at(f, k), &s, pdf[k]) {
                    shadow.push(at(o, k), s.wi, s.tmax, rays.slot[lanes.idx[k]], c, time(k));
                }
            }
        }
    }

    let u = sobol_owen_lanes(sample, hash_lanes([key, u32x16::splat(dim::GLOSS)]));
    let pick = sobol_owen_lanes(sample, hash_lanes([key, u32x16::splat(dim::GLOSS_BRANCH)])).0;
    let s = lobes.sample(wi, pick, [u.0, u.1]);
    let wo = (ts.scale(s.wo.x) + tt.scale(s.wo.y) + n.scale(s.wo.z)).normalize();
    let (o, dir, weight, pdf) = (origins(wo), wo.lanes(), s.weight.lanes(), s.pdf.to_array());
    let (key1, key2) = (hash_lanes([key, u32x16::ONE]).to_array(), hash_lanes([key, u32x16::splat(2)]).to_array());
    for k in (0..count).filter(|&k| live & s.valid & (1 << k) != 0) {
        let i = lanes.idx[k];
        let pdf = if mis { pdf[k] } else { 0.0 };
        let w = w[k] * at(&weight, k);
        let key = if s.through & (1 << k) != 0 { key2[k] } else { key1[k] };
        next.push(at(&o, k), at(&dir, k), rays.slot[i], w, rays.depth[i] + 1, key, samples[k], pdf, time(k));
    }
}

/// Whether a glossy point samples the lights under multiple importance sampling (area
/// lights, sphere lights, or the environment under the path transport), and whether it
/// samples the point and directional lights too (the path transport).
fn samples_lights(scene: &Scene) -> (bool, bool) {
    // Under the path transport, delta lights light glossy surfaces too.
    let delta = scene.settings.path() && !scene.delta_lights.is_empty();
    let mis = !scene.gloss_lights.is_empty() || !scene.sphere_lights.is_empty() || scene.samples_environment() || delta;
    (mis, delta)
}

/// One light sample of a glossy point.
#[derive(Clone, Copy, Debug)]
struct LightSample {
    /// Unit direction towards the light.
    wi: Vec3,
    /// The shadow ray's reach.
    tmax: f32,
    /// The radiance arriving (a delta light's irradiance).
    radiance: Vec3,
    /// Its density over solid angle; unused for a delta light.
    pdf: f32,
    /// A point or directional light: no BSDF ray finds it, so it is not weighted.
    delta: bool,
}

/// How many light samples a glossy point can have: one per delta light (with `delta`),
/// one for the area lights, one per sphere light ([`light_samples`]), and one for the
/// environment (under the path transport its shadow ray reaches to infinity).
fn light_slots(scene: &Scene, delta: bool) -> usize {
    (if delta { scene.delta_lights.len() } else { 0 }) + 1 + scene.sphere_lights.len() + 1
}

/// Calls `f(slot, sample)` for each light sample of point `x` of the path `(key,
/// sample)`, slots in the order [`light_slots`] counts them (a slot without a sample is
/// skipped): a ray per delta light (with `delta`: the BSDF's rays never find them), one
/// point on an area light ([`gloss_light_sample`]), one direction in the cone of each
/// sphere light; the environment's slot, last, is the caller's
/// ([`Environment::sample_lanes`](crate::emitter::environment::Environment::sample_lanes)).
fn light_samples(
    scene: &Scene,
    x: Vec3,
    (key, sample): (u32, u32),
    delta: bool,
    mut f: impl FnMut(usize, LightSample),
) {
    let deltas = if delta { scene.delta_lights.as_slice() } else { &[] };
    for (j, &li) in deltas.iter().enumerate() {
        let (wi, tmax, radiance) = match scene.lights[li as usize] {
            Light::Point { position, intensity } => {
                let to = position - x;
                let d2 = to.length_squared();
                (to / d2.sqrt(), d2.sqrt() * SHADOW_TMAX_SCALE, intensity / d2)
            }
            Light::Directional { direction, irradiance } => (-direction, f32::MAX, irradiance),
            Light::Quad { .. } | Light::Triangle { .. } | Light::Sphere { .. } => continue,
        };
        f(j, LightSample { wi, tmax, radiance, pdf: 0.0, delta: true });
    }
    let mut j = deltas.len();
    if let Some(l) = gloss_light_sample(scene, x, key, sample) {
        let s =
            LightSample { wi: l.wi, tmax: l.dist * SHADOW_TMAX_SCALE, radiance: l.radiance, pdf: l.pdf, delta: false };
        f(j, s);
    }
    j += 1;
    for &li in &scene.sphere_lights {
        if let Light::Sphere { center, radius, radiance } = scene.lights[li as usize] {
            let u = sobol_owen(sample, light_seed(key, li as usize));
            if let Some(s) = sphere_sample(center, radius, x, u) {
                f(j, LightSample { wi: s.wi, tmax: s.dist * SHADOW_TMAX_SCALE, radiance, pdf: s.pdf, delta: false });
            }
        }
        j += 1;
    }
}

/// What the shadow ray of light sample `s` carries for a path of throughput `w` at a
/// point whose BSDF gives f·cos `f` and density `pdf` for it: weighted by the power
/// heuristic against the BSDF's density (a delta light unweighted); `None` when nothing.
#[inline]
fn shadow_weight(w: Vec3, f: Vec3, s: &LightSample, pdf: f32) -> Option<Vec3> {
    if s.delta {
        let c = w * f * s.radiance;
        return (c != Vec3::ZERO && c.is_finite()).then_some(c);
    }
    let c = w * f * s.radiance * (power_heuristic(s.pdf, pdf) / s.pdf);
    (c != Vec3::ZERO).then_some(c)
}
