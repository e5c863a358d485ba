//! Diffuse shading points: the surface a ray hit and its BRDF, computed in one place for
//! the shade, shadow-corner and penumbra stages so that they agree bit for bit.

use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI};

use wide::f32x16;

use crate::accel::moving::Moving;
use crate::accel::offset::{offset_lanes, offset_ray_origin};
use crate::accel::shapes::{quad_point, sphere_point, triangle_point, Shape};
use crate::accel::NO_LIGHT;
use crate::queue::{sparse, HitQueue, RayQueue, SurfaceQueue};
use crate::scene::{Color, Material, Scene};
use crate::simd::{LaneIds, LANES, V3};
use crate::texture::uv;

/// Lambert plus normalised Phong: `color/π + specular·(n+2)/(2π)·max(0, r·wo)^n`,
/// with `r` the mirror direction of `wi` about `n`.
#[inline]
pub fn diffuse_brdf(color: Vec3, specular: Vec3, shininess: f32, n: Vec3, wi: Vec3, wo: Vec3) -> Vec3 {
    let mut f = color * FRAC_1_PI;
    if specular != Vec3::ZERO {
        let r = 2.0 * n.dot(wi) * n - wi;
        let c = r.dot(wo).max(0.0);
        f += specular * ((shininess + 2.0) / (2.0 * PI) * c.powf(shininess));
    }
    f
}

/// A diffuse shading point: what direct lighting needs, computed in one place for the
/// shade, shadow-corner and penumbra stages so they agree bit for bit.
#[derive(Clone, Copy, Debug)]
pub struct Surface {
    /// Ray origin for shadow rays: the hit point offset off the surface.
    pub o: Vec3,
    /// Unit normal on the side the ray arrived from.
    pub n: Vec3,
    /// Unit direction back along the incoming ray.
    pub wo: Vec3,
    /// Albedo.
    pub color: Vec3,
    /// Phong reflectance.
    pub specular: Vec3,
    /// Phong exponent.
    pub shininess: f32,
    /// Path throughput of the incoming ray.
    pub w: Vec3,
    /// Accumulation slot of the incoming ray.
    pub slot: u32,
    /// Path key of the incoming ray.
    pub key: u32,
    /// Camera sample index of the incoming ray's path.
    pub sample: u32,
}

/// The shading normal at point `x` of primitive `prim` at `time`, on the side of the unit
/// geometric normal `n` (the side the ray arrived on): the triangle's vertex normals
/// interpolated by `x`'s barycentric coordinates and normalised (Mitsuba's smooth
/// shading) for a smooth mesh, else `n` itself. Ray origins keep the geometric normal.
/// A moving mesh's vertex normals are in its own space and turn with it.
#[inline]
pub fn shading_normal(scene: &Scene, prim: usize, time: f32, x: Vec3, n: Vec3) -> Vec3 {
    let Some(&vn) = scene.normals.get(prim) else { return n };
    // Flat primitives (no vertex normals) need not have their shape put together.
    if vn[0] == Vec3::ZERO {
        return n;
    }
    let Shape::Triangle { v0, v1, v2 } = scene.accel.shape_at(prim as u32, time) else { return n };
    let (e1, e2) = (v1 - v0, v2 - v0);
    let c = e1.cross(e2);
    let w = c / c.length_squared();
    let q = x - v0;
    let (b1, b2) = (w.dot(q.cross(e2)), w.dot(e1.cross(q)));
    let ns = (1.0 - b1 - b2) * vn[0] + b1 * vn[1] + b2 * vn[2];
    let ns = match scene.accel.moving_of(prim as u32) {
        Some(m) => m.normal_at(prim as u32, time, ns),
        None => ns,
    }
    .normalize_or_zero();
    if ns == Vec3::ZERO {
        n
    } else if ns.dot(n) < 0.0 {
        -ns
    } else {
        ns
    }
}

/// The Lambert/Phong parameters (albedo, Phong reflectance, exponent, two-sided) of
/// primitive `prim` when it is a diffuse non-emitter, else `None`.
#[inline]
pub fn diffuse_material(scene: &Scene, prim: u32) -> Option<(Color, Vec3, f32, bool)> {
    if prim >= scene.accel.ids() as u32 || scene.accel.light(prim) != NO_LIGHT {
        return None;
    }
    match scene.materials[scene.accel.material(prim) as usize] {
        Material::Diffuse { color, specular, shininess, two_sided } => Some((color, specular, shininess, two_sided)),
        _ => None,
    }
}

/// The texture coordinates of point `x` on primitive `prim` at `time`, as Mitsuba 3
/// defines them: a sphere's (φ/2π, θ/π) about its own axes, a parallelogram's (a, b) for
/// corner + a·u + b·v (mapped through its corners' UVs when it has them), a triangle's
/// corner UVs interpolated (its barycentric (b1, b2) when its mesh has none). A moving
/// primitive's are those of the point taken back into its object's space.
pub fn uv_at(scene: &Scene, prim: usize, time: f32, x: Vec3) -> Vec2 {
    let (shape, x) = match scene.accel.moving_of(prim as u32) {
        Some(m) => (m.object_shape(prim as u32), m.to_object(prim as u32, time, x)),
        None => (scene.accel.prim(prim as u32).shape, x),
    };
    match shape {
        Shape::Sphere { center, .. } => match scene.uv_frames.get(prim) {
            Some(frame) => uv::sphere(Vec3::ZERO, *frame * (x - center)),
            None => uv::sphere(center, x),
        },
        Shape::Quad { corner, u, v } => {
            let ab = uv::quad(corner, u, v, x);
            match scene.uvs.get(prim) {
                Some(&[uv0, uv1, uv2]) => uv0 + ab.x * (uv1 - uv0) + ab.y * (uv2 - uv0),
                None => ab,
            }
        }
        Shape::Triangle { v0, v1, v2 } => {
            let corners = scene.uvs.get(prim).copied().unwrap_or(uv::DEFAULT_UVS);
            uv::triangle([v0, v1, v2], corners, x)
        }
    }
}

/// A material colour at point `x` of primitive `prim` at `time`: the constant, or the
/// texture looked up at the point's UV ([`uv_at`]).
#[inline]
pub fn color_at(scene: &Scene, color: Color, prim: usize, time: f32, x: Vec3) -> Vec3 {
    match color {
        Color::Rgb(c) => c,
        Color::Texture(t) => scene.textures[t as usize].eval(uv_at(scene, prim, time, x)),
    }
}

/// Where ray `i` hit: the point recomputed on the primitive's shape (at the ray's time),
/// a bound on its rounding error, and the unit geometric normal (outward, not yet
/// turned to the ray). A moving primitive's bound also covers the point's trip into the
/// object's space and back ([`Moving::extra_error`](crate::accel::moving::Moving::extra_error)).
#[inline]
pub fn hit_point(scene: &Scene, rays: &RayQueue, hits: &HitQueue, i: usize) -> (Vec3, Vec3, Vec3) {
    let (id, time) = (hits.prim[i], sparse(&rays.time, i));
    let shape = scene.accel.shape_at(id, time);
    let (x, mut err) = shape.surface_point(rays.origin(i), rays.dir(i), hits.t[i]);
    if let Some(m) = scene.accel.moving_of(id) {
        err += m.extra_error(id, time, x);
    }
    (x, err, shape.normal(x).normalize())
}

/// The diffuse surface that ray `i` hit, or `None` if it hit something else.
#[inline]
pub fn diffuse_surface(scene: &Scene, rays: &RayQueue, hits: &HitQueue, i: usize) -> Option<Surface> {
    let (color, specular, shininess, two_sided) = diffuse_material(scene, hits.prim[i])?;
    let d = rays.dir(i);
    let time = sparse(&rays.time, i);
    let (x, err, ng) = hit_point(scene, rays, hits, i);
    // A one-sided surface seen from behind is black.
    let (color, specular) = match two_sided || ng.dot(d) < 0.0 {
        true => (color_at(scene, color, hits.prim[i] as usize, time, x), specular),
        false => (Vec3::ZERO, Vec3::ZERO),
    };
    // Diffuse surfaces are two-sided: light the side the ray arrived on.
    let n = if ng.dot(d) < 0.0 { ng } else { -ng };
    Some(Surface {
        o: offset_ray_origin(x, err, n),
        n: shading_normal(scene, hits.prim[i] as usize, time, x, n),
        wo: -d,
        color,
        specular,
        shininess,
        w: rays.weight(i),
        slot: rays.slot[i],
        key: rays.key[i],
        sample: rays.sample[i],
    })
}

/// Where 16 rays hit, on lanes: what [`Shape::surface_point`] and [`Shape::normal`] give
/// each ray, bit for bit.
pub struct HitLanes {
    /// Ray directions.
    pub d: V3<f32x16>,
    /// Hit points, recomputed on the surfaces.
    pub p: V3<f32x16>,
    /// Bounds on the hit points' rounding errors.
    pub err: V3<f32x16>,
    /// Unit geometric normals (outward, not yet turned to the ray).
    pub ng: V3<f32x16>,
}

/// The hits of rays `ids` (1 to 16, in queue order; lanes past the last repeat it):
/// every lane runs the formulas of the shapes present and keeps its own shape's.
pub fn hit_lanes(scene: &Scene, rays: &RayQueue, hits: &HitQueue, ids: &[u32]) -> HitLanes {
    // A static scene takes the tree's shapes straight, in its own copy of the formulas.
    let Some(m) = scene.accel.moving() else {
        return shape_lanes(rays, hits, ids, true, |prim, _| scene.accel.prim(prim).shape);
    };
    let moving = ids.iter().any(|&i| scene.accel.is_moving(hits.prim[i as usize]));
    let mut h = shape_lanes(rays, hits, ids, !moving, |prim, i| scene.accel.shape_at(prim, sparse(&rays.time, i)));
    if moving {
        moving_error(m, scene, rays, hits, ids, &mut h);
    }
    h
}

/// [`hit_lanes`] with each ray's shape given by `shape(prim, ray)`; `shared`: one
/// primitive under every lane has one shape (false where shapes move with each ray's
/// time).
#[inline(always)]
fn shape_lanes(
    rays: &RayQueue,
    hits: &HitQueue,
    ids: &[u32],
    shared: bool,
    shape: impl Fn(u32, usize) -> Shape,
) -> HitLanes {
    let lanes = LaneIds::new(ids);
    let id = |k: usize| lanes.idx[k];
    let ray = |v: &[f32]| lanes.gather(v);
    let o = V3 { x: ray(&rays.ox), y: ray(&rays.oy), z: ray(&rays.oz) };
    let d = V3 { x: ray(&rays.dx), y: ray(&rays.dy), z: ray(&rays.dz) };
    // Each shape as three points: a sphere's centre and radius, a parallelogram's corner
    // and edges, a triangle's vertices.
    let points = |k: usize| match shape(hits.prim[id(k)], id(k)) {
        Shape::Sphere { center, radius } => (center, Vec3::splat(radius), Vec3::ZERO, 0),
        Shape::Quad { corner, u, v } => (corner, u, v, 1),
        Shape::Triangle { v0, v1, v2 } => (v0, v1, v2, 2),
    };
    let first = hits.prim[id(0)];
    // One primitive under all lanes (a large quad or triangle): its points once. One
    // call site, so that `points` is inlined: a call per lane returned its 40 bytes
    // through memory, and the loads after it waited on the stores.
    let one = shared && (1..LANES).all(|k| hits.prim[id(k)] == first);
    let (mut abc, mut kind, mut kinds) = ([[0.0f32; LANES]; 9], [0u32; LANES], 0u32);
    for k in 0..if one { 1 } else { LANES } {
        let (a, b, c, what) = points(k);
        for (j, x) in [a, b, c].iter().flat_map(|v| v.to_array()).enumerate() {
            abc[j][k] = x;
        }
        kind[k] = what;
        kinds |= 1 << what;
    }
    let (a, b, c, kind) = if one {
        let v3 = |j: usize| V3::splat(Vec3::new(abc[j][0], abc[j + 1][0], abc[j + 2][0]));
        (v3(0), v3(3), v3(6), [kind[0]; LANES])
    } else {
        let v3 = |j: usize| V3 { x: f32x16::from(abc[j]), y: f32x16::from(abc[j + 1]), z: f32x16::from(abc[j + 2]) };
        (v3(0), v3(3), v3(6), kind)
    };
    let x = o + d.scale(ray(&hits.t));
    // Only the formulas of the shapes present (an all-triangle mesh group skips two of
    // three); an absent shape's lanes are never picked, so zeros stand in.
    let none = (V3::splat(Vec3::ZERO), V3::splat(Vec3::ZERO));
    let sphere = if kinds & 1 != 0 { sphere_point(a, b.x, x) } else { none };
    let quad = if kinds & 2 != 0 { quad_point(a, b, c, x) } else { none };
    let triangle = if kinds & 4 != 0 { triangle_point(a, b, c, x) } else { none };
    let is = |what: u32| f32x16::from(kind.map(|k| if k == what { f32::from_bits(!0) } else { 0.0 }));
    let (is_sphere, is_quad) = (is(0), is(1));
    let pick = |s: V3<f32x16>, q: V3<f32x16>, t: V3<f32x16>| V3 {
        x: is_sphere.select(s.x, is_quad.select(q.x, t.x)),
        y: is_sphere.select(s.y, is_quad.select(q.y, t.y)),
        z: is_sphere.select(s.z, is_quad.select(q.z, t.z)),
    };
    let (p, err) = (pick(sphere.0, quad.0, triangle.0), pick(sphere.1, quad.1, triangle.1));
    // `kinds` has bit 1 << kind: 4 = triangles only, 2 = parallelograms only.
    let ng = match kinds {
        4 => (b - a).cross(c - a),
        2 => b.cross(c),
        _ => pick(sphere.0 - a, b.cross(c), (b - a).cross(c - a)),
    }
    .normalize();
    HitLanes { d, p, err, ng }
}

/// Adds to the error bounds of `h` (the hits of rays `ids`) what a moving primitive's
/// point adds ([`Moving::extra_error`]). Out of line, called last: a call among
/// [`hit_lanes`]' vectors would spill them.
#[inline(never)]
fn moving_error(m: &Moving, scene: &Scene, rays: &RayQueue, hits: &HitQueue, ids: &[u32], h: &mut HitLanes) {
    let lanes = LaneIds::new(ids);
    let (px, py, pz) = (h.p.x.to_array(), h.p.y.to_array(), h.p.z.to_array());
    let mut extra = [[0.0f32; LANES]; 3];
    for (k, &i) in lanes.idx.iter().enumerate().filter(|(_, &i)| scene.accel.is_moving(hits.prim[i])) {
        let e = m.extra_error(hits.prim[i], sparse(&rays.time, i), Vec3::new(px[k], py[k], pz[k]));
        (extra[0][k], extra[1][k], extra[2][k]) = (e.x, e.y, e.z);
    }
    h.err = h.err + V3 { x: f32x16::from(extra[0]), y: f32x16::from(extra[1]), z: f32x16::from(extra[2]) };
}

/// Appends to `out`, in order, the diffuse surfaces of rays `ids` (at most 16, each of
/// which hit a diffuse primitive), computed on lanes ([`hit_lanes`]): [`diffuse_surface`]'s
/// points bit for bit.
pub fn diffuse_surfaces(scene: &Scene, rays: &RayQueue, hits: &HitQueue, ids: &[u32], out: &mut SurfaceQueue) {
    if ids.is_empty() {
        return;
    }
    let HitLanes { d, p, err, ng } = hit_lanes(scene, rays, hits, ids);
    let lanes = LaneIds::new(ids);
    let ray = |v: &[f32]| lanes.gather(v);
    // Diffuse surfaces are two-sided: light the side the ray arrived on.
    let n = V3::if_negative(ng.dot(d), ng, -ng);
    let o = offset_lanes(p, err, n).lanes();
    let shading = shading_lanes(scene, rays, hits, ids, p, n).lanes();
    let mut w = V3 { x: ray(&rays.wr), y: ray(&rays.wg), z: ray(&rays.wb) }.lanes();
    let side = ng.dot(d).to_array();
    // Albedo, Phong reflectance and exponent: seven columns filled in one pass.
    let (mut color, mut specular, mut shininess) = ([[0.0f32; LANES]; 3], [[0.0f32; LANES]; 3], [0.0f32; LANES]);
    // The hit points as arrays, made once and only when a texture needs them.
    let mut points: Option<[[f32; LANES]; 3]> = None;
    for (k, &i) in lanes.idx.iter().enumerate() {
        let (c, sp, e, two_sided) =
            diffuse_material(scene, hits.prim[i]).unwrap_or((Color::Rgb(Vec3::ZERO), Vec3::ZERO, 0.0, true));
        // A one-sided surface seen from behind is black: nothing reflects, and its
        // zero throughput ends the path.
        if !two_sided && side[k] >= 0.0 {
            (w[0][k], w[1][k], w[2][k]) = (0.0, 0.0, 0.0);
            continue;
        }
        let c = match c {
            Color::Rgb(c) => c,
            textured => {
                let [x, y, z] = points.get_or_insert_with(|| [p.x.to_array(), p.y.to_array(), p.z.to_array()]);
                color_at(scene, textured, hits.prim[i] as usize, sparse(&rays.time, i), Vec3::new(x[k], y[k], z[k]))
            }
        };
        (color[0][k], color[1][k], color[2][k]) = (c.x, c.y, c.z);
        (specular[0][k], specular[1][k], specular[2][k]) = (sp.x, sp.y, sp.z);
        shininess[k] = e;
    }
    let words = |col: &[u32]| lanes.idx.map(|i| col[i]);
    let ray_ids = lanes.idx.map(|i| i as u32);
    let time = (!rays.time.is_empty()).then(|| lanes.idx.map(|i| rays.time[i]));
    let (slot, key, sample) = (words(&rays.slot), words(&rays.key), words(&rays.sample));
    // Whole columns at once: one capacity check per column, not per value.
    let n = ids.len();
    out.push_lanes(
        o,
        shading,
        (-d).lanes(),
        color,
        specular,
        shininess,
        w,
        slot,
        key,
        sample,
        ray_ids,
        time.as_ref(),
        n,
    );
}

/// [`shading_normal`] of every lane: `n` itself unless the scene has smooth meshes.
#[inline]
pub fn shading_lanes(
    scene: &Scene,
    rays: &RayQueue,
    hits: &HitQueue,
    ids: &[u32],
    p: V3<f32x16>,
    n: V3<f32x16>,
) -> V3<f32x16> {
    if scene.normals.is_empty() {
        return n;
    }
    let (px, py, pz) = (p.x.to_array(), p.y.to_array(), p.z.to_array());
    let (nx, ny, nz) = (n.x.to_array(), n.y.to_array(), n.z.to_array());
    let last = ids[ids.len() - 1];
    let ns: [Vec3; LANES] = std::array::from_fn(|k| {
        let i = ids.get(k).copied().unwrap_or(last) as usize;
        shading_normal(
            scene,
            hits.prim[i] as usize,
            sparse(&rays.time, i),
            Vec3::new(px[k], py[k], pz[k]),
            Vec3::new(nx[k], ny[k], nz[k]),
        )
    });
    V3 { x: f32x16::from(ns.map(|v| v.x)), y: f32x16::from(ns.map(|v| v.y)), z: f32x16::from(ns.map(|v| v.z)) }
}

/// Entry `p` of `q` as a [`Surface`].
#[inline]
pub fn queued_surface(q: &SurfaceQueue, p: usize) -> Surface {
    Surface {
        o: q.origin(p),
        n: q.normal(p),
        wo: q.wo(p),
        color: q.color(p),
        specular: q.specular(p),
        shininess: q.shininess[p],
        w: q.weight(p),
        slot: q.slot[p],
        key: q.key[p],
        sample: q.sample[p],
    }
}
