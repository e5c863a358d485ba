//! Reflection and refraction: reads the specular list (indices of rays that hit a
//! mirror or dielectric) and writes the next wave's rays.
//!
//! Dielectrics follow the paper (§3): inside an object the normal is flipped and eta
//! inverted, both decided here from the geometric normal alone, so the errors of the
//! paper's Figure 5 cannot occur. Reflection and refraction are both traced, weighted
//! C and 1 - C (or by exact Fresnel); total internal reflection sends all the weight
//! to reflection.

use glam::Vec3;

use wide::{f32x16, u32x16};

use crate::accel::offset::{offset_lanes, offset_ray_origin};
use crate::bsdf::microfacet::fresnel_conductor;
use crate::queue::{sparse_opt, HitQueue, IndexQueue, RayQueue, ShadowQueue};
use crate::sampling::{dim, hash, hash_lanes, sobol_owen};
use crate::scene::{Color, Material, ReflectRatio, Scene};
use crate::simd::{Real, LANES, V3};
use crate::surface::{color_at, hit_lanes, hit_point, shading_lanes, shading_normal, HitLanes};

mod lanes;

/// Mirror direction of `d` about the unit normal `n`.
#[inline]
pub fn reflect(d: Vec3, n: Vec3) -> Vec3 {
    reflect_lanes(V3::from_vec(d), V3::from_vec(n)).vec()
}

/// [`reflect`] on lanes.
#[inline(always)]
fn reflect_lanes<R: Real>(d: V3<R>, n: V3<R>) -> V3<R> {
    d - n.scale(R::splat(2.0) * d.dot(n))
}

/// The side of a dielectric boundary a ray is on, and the quantities that depend on it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Interface {
    /// Unit normal facing the incoming ray (flipped when the ray is inside).
    pub normal: Vec3,
    /// n_incident / n_transmitted: 1/ior entering, ior leaving.
    pub eta: f32,
    /// True when the ray travels from outside to inside.
    pub entering: bool,
}

/// Orients a dielectric boundary for a ray with direction `d` hitting a surface with
/// outward geometric normal `ng` (unit) of relative index `ior`.
#[inline]
pub fn interface(d: Vec3, ng: Vec3, ior: f32) -> Interface {
    let entering = d.dot(ng) < 0.0;
    if entering {
        Interface { normal: ng, eta: 1.0 / ior, entering }
    } else {
        Interface { normal: -ng, eta: ior, entering }
    }
}

/// cos²θt = 1 − η²(1 − cos²θi), evaluated as cos²θi − (η − 1)(η + 1)(1 − cos²θi): exact
/// for η = 1 and free of the cancellation in 1 − sin²θt at grazing incidence when η ≈ 1.
#[inline(always)]
pub fn cos2_transmitted<R: Real>(cos_i: R, eta: R) -> R {
    let (one, c2) = (R::splat(1.0), cos_i * cos_i);
    c2 - (eta - one) * (eta + one) * (one - c2)
}

/// Snell refraction of unit `d` through a boundary with unit normal `n` facing `d`'s
/// origin side and eta = n_i / n_t. `None` on total internal reflection.
#[inline]
pub fn refract(d: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
    let (t, cos2_t) = refract_lanes(V3::from_vec(d), V3::from_vec(n), eta);
    if cos2_t <= 0.0 {
        None
    } else {
        Some(t.vec())
    }
}

/// [`refract`] on lanes: the refracted directions, valid where the returned cos²θt is
/// positive (total internal reflection elsewhere).
#[inline(always)]
fn refract_lanes<R: Real>(d: V3<R>, n: V3<R>, eta: R) -> (V3<R>, R) {
    let cos_i = (-d.dot(n)).min(R::splat(1.0));
    let cos2_t = cos2_transmitted(cos_i, eta);
    let cos_t = cos2_t.sqrt();
    ((d.scale(eta) + n.scale(eta * cos_i - cos_t)).normalize(), cos2_t)
}

/// Unpolarised Fresnel reflectance of a smooth dielectric boundary for incidence cosine
/// `cos_i` and eta = n_i / n_t; 1 under total internal reflection.
#[inline]
pub fn fresnel(cos_i: f32, eta: f32) -> f32 {
    let (r, cos2_t) = fresnel_lanes(cos_i.clamp(0.0, 1.0), eta);
    if cos2_t <= 0.0 {
        1.0
    } else {
        r
    }
}

/// [`fresnel`] on lanes, for `cos_i` already clamped to [0, 1]: the reflectance, valid
/// where the returned cos²θt is positive (1 elsewhere).
#[inline(always)]
fn fresnel_lanes<R: Real>(cos_i: R, eta: R) -> (R, R) {
    let cos2_t = cos2_transmitted(cos_i, eta);
    let cos_t = cos2_t.sqrt();
    let rs = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let rp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    (R::splat(0.5) * (rs * rs + rp * rp), cos2_t)
}

/// Spawns the reflection and refraction rays of every listed hit into `next`, and the
/// light samples of rough hits under multiple importance sampling into `shadow` (both cleared
/// first). Smooth mirrors and glass go 16 hits at a time on lanes, in list order: a
/// hit's reflection ray, then its refraction ray; a smooth conductor's ray comes first in
/// its group of 16 listed hits ([`smooth_conductor`]). Rough conductors, rough glass and
/// plastics ([`is_glossy`]) go last, with their light samples, 16 hits of one material at
/// a time on lanes, material by material (`lanes.rs`).
pub fn scatter(
    scene: &Scene,
    rays: &RayQueue,
    hits: &HitQueue,
    specular: &IndexQueue,
    next: &mut RayQueue,
    shadow: &mut ShadowQueue,
) {
    next.clear();
    shadow.clear();
    // A scene without glossy materials never looks at the material twice.
    if !scene.materials.iter().any(is_glossy) {
        for ids in specular.index.chunks(LANES) {
            scatter_lanes(scene, rays, hits, ids, next);
        }
        return;
    }
    // Rough and plastic hits (material, ray), gathered to go 16 of one material at a
    // time.
    let mut on_lanes = Vec::new();
    for ids in specular.index.chunks(LANES) {
        let (mut smooth, mut n) = ([0u32; LANES], 0);
        for &i in ids {
            let id = scene.accel.material(hits.prim[i as usize]);
            let material = &scene.materials[id as usize];
            if lanes::on_lanes(material) {
                on_lanes.push((id, i));
            } else if let Material::Conductor { eta, k, color, .. } = *material {
                smooth_conductor(scene, rays, hits, i as usize, (eta, k, color), next);
            } else {
                smooth[n] = i;
                n += 1;
            }
        }
        if n > 0 {
            scatter_lanes(scene, rays, hits, &smooth[..n], next);
        }
    }
    // Stable: each material's hits stay in queue order.
    on_lanes.sort_by_key(|&(id, _)| id);
    for same in on_lanes.chunk_by(|a, b| a.0 == b.0) {
        let material = &scene.materials[same[0].0 as usize];
        for group in same.chunks(LANES) {
            let ids: [u32; LANES] = std::array::from_fn(|k| group[k.min(group.len() - 1)].1);
            lanes::glossy_lanes(scene, rays, hits, &ids[..group.len()], material, Scattered { next, shadow });
        }
    }
}

/// True for the materials the scatter stage reads beyond the smooth mirror and glass:
/// conductors (smooth ones too, for their Fresnel reflectance and textures), rough glass
/// and plastic.
pub fn is_glossy(m: &Material) -> bool {
    matches!(m, Material::Conductor { .. } | Material::Dielectric { roughness: Some(_), .. } | Material::Plastic { .. })
}

/// A conductor's Fresnel reflectance ([`fresnel_conductor`]) for a cosine that may
/// round past 1.
#[inline]
fn conductor_fresnel(cos_i: f32, eta: Vec3, k: Vec3) -> Vec3 {
    fresnel_conductor(cos_i.clamp(0.0, 1.0), eta, k)
}

/// The ray of hit `i` on a smooth conductor (`(eta, k, color)`: its optical constants
/// and colour): the reflection about the shading normal on the side the ray arrived on
/// (conductors are two-sided, like the mirror), weighted by the Fresnel reflectance and
/// the colour at the hit.
fn smooth_conductor(
    scene: &Scene,
    rays: &RayQueue,
    hits: &HitQueue,
    i: usize,
    (eta, k, color): (Vec3, Vec3, Color),
    next: &mut RayQueue,
) {
    let (x, err, ng) = hit_point(scene, rays, hits, i);
    // The path's time, carried by the rays it goes on with.
    let carried = sparse_opt(&rays.time, i);
    let (prim, time, d) = (hits.prim[i] as usize, carried.unwrap_or_default(), rays.dir(i));
    let n = if d.dot(ng) < 0.0 { ng } else { -ng };
    let ns = shading_normal(scene, prim, time, x, n);
    let tint = rays.weight(i) * color_at(scene, color, prim, time, x);
    let f = conductor_fresnel(-d.dot(ns), eta, k);
    let (key1, o) = (hash(&[rays.key[i], 1]), offset_ray_origin(x, err, n));
    next.push(o, reflect(d, ns), rays.slot[i], tint * f, rays.depth[i] + 1, key1, rays.sample[i], 0.0, carried);
}

/// The queues a glossy hit writes: its bounce ray, and its light sample's shadow ray.
struct Scattered<'a> {
    next: &'a mut RayQueue,
    shadow: &'a mut ShadowQueue,
}

/// The rays [`scatter`] spawns from hits `ids` (1 to 16), on lanes. Mirrors reflect;
/// dielectrics are oriented by the geometric normal ([`interface`]) and split between
/// reflection (C, Fresnel, or all of it under total internal reflection) and refraction.
fn scatter_lanes(scene: &Scene, rays: &RayQueue, hits: &HitQueue, ids: &[u32], next: &mut RayQueue) {
    let HitLanes { d, p, err, ng } = hit_lanes(scene, rays, hits, ids);
    // Per lane: the material's ior (1 for a mirror), its split (reflection weight for a
    // fixed ratio, NaN for Fresnel), its colour (mirror colour or dielectric tint) and
    // whether it is a mirror (None: not a specular material, nothing to spawn).
    let mut mat = [(1.0f32, 1.0f32, Vec3::ONE, None); LANES];
    // Thin sheets (bit k), finished lane by lane after the others.
    let mut thin = 0u32;
    for (k, &i) in ids.iter().enumerate() {
        let m = scene.materials[scene.accel.material(hits.prim[i as usize]) as usize];
        if let Material::Dielectric { thin: true, .. } = m {
            thin |= 1 << k;
        }
        mat[k] = match m {
            Material::Mirror { color } => (1.0, 1.0, color, Some(true)),
            Material::Dielectric { ior, ratio: ReflectRatio::Fixed(c), tint, .. } => (ior, c, tint, Some(false)),
            Material::Dielectric { ior, ratio: ReflectRatio::Fresnel, tint, .. } => (ior, f32::NAN, tint, Some(false)),
            Material::Diffuse { .. } | Material::Conductor { .. } | Material::Plastic { .. } => {
                debug_assert!(false, "not a smooth mirror or glass");
                (1.0, 1.0, Vec3::ZERO, None)
            }
        };
    }
    let ior = f32x16::from(mat.map(|m| m.0));
    // interface(): entering when d·ng < 0; then the normal faces the ray and eta = 1/ior.
    let side = d.dot(ng);
    let n = V3::if_negative(side, ng, -ng);
    let eta = f32x16::if_negative(side, f32x16::ONE / ior, ior);
    // Directions use the shading normal (smooth meshes), origins the geometric one.
    let ns = shading_lanes(scene, rays, hits, ids, p, n);
    let (t, cos2_t) = refract_lanes(d, ns, eta);
    let cos_i = -d.dot(ns);
    let (r, fresnel_cos2_t) = fresnel_lanes(
        cos_i.simd_lt(f32x16::ZERO).select(f32x16::ZERO, cos_i.simd_gt(f32x16::ONE).select(f32x16::ONE, cos_i)),
        eta,
    );
    let fresnel_r = fresnel_cos2_t.simd_le(f32x16::ZERO).select(f32x16::ONE, r).to_array();
    let arr = |v: V3<f32x16>| [v.x.to_array(), v.y.to_array(), v.z.to_array()];
    let (refl_o, refl_d) = (arr(offset_lanes(p, err, n)), arr(reflect_lanes(d, ns)));
    let (refr_o, refr_d) = (arr(offset_lanes(p, err, -n)), arr(t));
    let one_branch = scene.settings.path();
    // The shading normals, for thin sheets' Fresnel.
    let ns_arr = if thin != 0 { arr(ns) } else { [[0.0; LANES]; 3] };
    // As refract(): no refraction where cos²θt ≤ 0 (a NaN refracts, as there).
    let refracts = !cos2_t.simd_le(f32x16::ZERO).to_bitmask();
    let keys = |branch: u32| {
        let key = u32x16::from(std::array::from_fn::<u32, LANES, _>(|k| {
            rays.key[ids.get(k).copied().unwrap_or(ids[0]) as usize]
        }));
        hash_lanes([key, u32x16::splat(branch)]).to_array()
    };
    let (key1, key2) = (keys(1), keys(2));
    let at = |v: &[[f32; LANES]; 3], k: usize| Vec3::new(v[0][k], v[1][k], v[2][k]);
    let mut out = Spawned::default();
    for (k, &i) in ids.iter().enumerate() {
        let i = i as usize;
        let (w, slot, depth, sample) = (rays.weight(i), rays.slot[i], rays.depth[i] + 1, rays.sample[i]);
        let time = sparse_opt(&rays.time, i);
        let (_, fixed, color, mirror) = mat[k];
        let Some(mirror) = mirror else { continue };
        if mirror {
            out.add(at(&refl_o, k), at(&refl_d, k), slot, w * color, depth, key1[k], sample, time);
            continue;
        }
        if thin & (1 << k) != 0 {
            // A thin sheet: no bending, no total internal reflection; the light bounced
            // between its faces adds to its reflection (Mitsuba's thindielectric).
            let (d, n) = (rays.dir(i), at(&ns_arr, k));
            let r = fresnel(-d.dot(n), 1.0 / mat[k].0);
            let c = if fixed.is_nan() { 2.0 * r / (1.0 + r) } else { fixed };
            if c > 0.0 {
                out.add(at(&refl_o, k), at(&refl_d, k), slot, w * c, depth, key1[k], sample, time);
            }
            if c < 1.0 {
                out.add(at(&refr_o, k), d, slot, w * color * (1.0 - c), depth, key2[k], sample, time);
            }
            continue;
        }
        let refracted = refracts & (1 << k) != 0;
        let c = match (refracted, fixed.is_nan()) {
            (false, _) => 1.0,
            (true, false) => fixed,
            (true, true) => fresnel_r[k],
        };
        if one_branch && refracted && c > 0.0 && c < 1.0 {
            // The path transport follows one branch, reflection with probability c, as
            // Mitsuba does: the same expectation, one ray instead of two.
            let pick = sobol_owen(sample, hash(&[rays.key[i], dim::GLOSS_BRANCH])).x;
            match pick < c {
                true => out.add(at(&refl_o, k), at(&refl_d, k), slot, w, depth, key1[k], sample, time),
                false => out.add(at(&refr_o, k), at(&refr_d, k), slot, w * color, depth, key2[k], sample, time),
            }
            continue;
        }
        if c > 0.0 {
            out.add(at(&refl_o, k), at(&refl_d, k), slot, w * c, depth, key1[k], sample, time);
        }
        if refracted && c < 1.0 {
            out.add(at(&refr_o, k), at(&refr_d, k), slot, w * color * (1.0 - c), depth, key2[k], sample, time);
        }
    }
    out.flush(next, !rays.time.is_empty());
}

/// The rays of one lane group of hits (at most two a hit), in spawn order, for the
/// queue 16 at a time: whole columns copied instead of a value pushed per column per ray.
struct Spawned {
    o: [[f32; 2 * LANES]; 3],
    d: [[f32; 2 * LANES]; 3],
    slot: [u32; 2 * LANES],
    w: [[f32; 2 * LANES]; 3],
    depth: [u32; 2 * LANES],
    key: [u32; 2 * LANES],
    sample: [u32; 2 * LANES],
    time: [f32; 2 * LANES],
    n: usize,
}

impl Default for Spawned {
    fn default() -> Spawned {
        let (v, u) = ([[0.0; 2 * LANES]; 3], [0; 2 * LANES]);
        Spawned { o: v, d: v, slot: u, w: v, depth: u, key: u, sample: u, time: [0.0; 2 * LANES], n: 0 }
    }
}

impl Spawned {
    /// Appends one ray, with [`RayQueue::push`]'s arguments but the density (0).
    #[allow(clippy::too_many_arguments)] // one argument per value of the ray
    #[inline(always)]
    fn add(&mut self, o: Vec3, d: Vec3, slot: u32, w: Vec3, depth: u32, key: u32, sample: u32, time: Option<f32>) {
        let k = self.n;
        for (c, v) in [(&mut self.o, o), (&mut self.d, d), (&mut self.w, w)] {
            (c[0][k], c[1][k], c[2][k]) = (v.x, v.y, v.z);
        }
        (self.slot[k], self.depth[k], self.key[k], self.sample[k]) = (slot, depth, key, sample);
        self.time[k] = time.unwrap_or_default();
        self.n += 1;
    }

    /// Pushes the rays to `next` in order; `timed`: the queue carries times.
    fn flush(&self, next: &mut RayQueue, timed: bool) {
        for h in 0..2 {
            let count = self.n.saturating_sub(h * LANES).min(LANES);
            if count == 0 {
                break;
            }
            let half = |v: &[f32; 2 * LANES]| -> [f32; LANES] { std::array::from_fn(|k| v[h * LANES + k]) };
            let words = |v: &[u32; 2 * LANES]| -> [u32; LANES] { std::array::from_fn(|k| v[h * LANES + k]) };
            let v3 = |v: &[[f32; 2 * LANES]; 3]| [half(&v[0]), half(&v[1]), half(&v[2])];
            let time = half(&self.time);
            next.push_lanes(
                v3(&self.o),
                v3(&self.d),
                words(&self.slot),
                v3(&self.w),
                words(&self.depth),
                words(&self.key),
                words(&self.sample),
                [0.0; LANES],
                timed.then_some(&time),
                count,
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interface_flips_normal_and_eta_inside() {
        let ng = Vec3::Y;
        let outside = interface(Vec3::new(0.0, -1.0, 0.0), ng, 1.5);
        assert!(outside.entering && outside.normal == Vec3::Y && (outside.eta - 1.0 / 1.5).abs() < 1e-7);
        let inside = interface(Vec3::new(0.0, 1.0, 0.0), ng, 1.5);
        assert!(!inside.entering && inside.normal == Vec3::NEG_Y && inside.eta == 1.5);
    }

    #[test]
    fn snell_law_holds_and_tir_beyond_critical_angle() {
        let n = Vec3::Y;
        for deg in [0.0f32, 10.0, 30.0, 60.0, 85.0] {
            let th = deg.to_radians();
            let d = Vec3::new(th.sin(), -th.cos(), 0.0);
            let t = refract(d, n, 1.0 / 1.5).unwrap();
            assert!((th.sin() - 1.5 * t.x).abs() < 1e-6, "snell at {deg}");
            assert!(t.y < 0.0);
        }
        // From glass (eta 1.5) the critical angle is asin(1/1.5) = 41.81°.
        let crit = (1.0f32 / 1.5).asin();
        let below = crit - 1e-3;
        assert!(refract(Vec3::new(below.sin(), -below.cos(), 0.0), n, 1.5).is_some());
        let beyond = crit + 1e-3;
        assert!(refract(Vec3::new(beyond.sin(), -beyond.cos(), 0.0), n, 1.5).is_none());
        assert_eq!(fresnel(beyond.cos(), 1.5), 1.0);
    }

    #[test]
    fn fresnel_known_values() {
        // Normal incidence on glass: ((1.5 - 1) / (1.5 + 1))^2 = 0.04.
        assert!((fresnel(1.0, 1.0 / 1.5) - 0.04).abs() < 1e-6);
        // Same from inside.
        assert!((fresnel(1.0, 1.5) - 0.04).abs() < 1e-6);
        // Matched media reflect nothing.
        assert!(fresnel(0.3, 1.0).abs() < 1e-6);
        // Grazing incidence reflects everything.
        assert!(fresnel(0.0, 1.0 / 1.5) > 0.999);
    }

    #[test]
    fn ior_one_leaves_direction_unchanged() {
        let d = Vec3::new(0.3, -0.8, 0.1).normalize();
        let t = refract(d, Vec3::Y, 1.0).unwrap();
        assert!(t.abs_diff_eq(d, 1e-6), "{t} vs {d}");
    }
}
