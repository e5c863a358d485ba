//! Lights and objects of a scene description: shapes with their transforms, OBJ and PLY
//! meshes with their smooth normals, UVs and emission, turned into primitives and lights;
//! and the BVH build that keeps the per-corner data in its primitive order.

use glam::{Mat3, Vec2, Vec3};
use std::collections::BTreeMap;
use std::path::Path;

use super::meshes::Meshes;
use super::motion;
use crate::accel::{Accel, Primitive, Shape, NO_LIGHT};
use crate::accel::{BvhQuality, MAX_LEAF};
use crate::motion::Motion;
use crate::scene::format::*;
use crate::scene::mesh;
use crate::scene::transform::Transform;
use crate::scene::values::{color, coord, edges, in_range, transform, vec3, Ctx, MAX_COORD};
use crate::scene::{Color, Light, Material, SceneInfo};
use crate::texture::uv;
use crate::Result;

/// The primitives and lights of a scene description, with what its triangles carry per
/// corner: vertex normals of smooth meshes and texture coordinates of textured meshes,
/// one entry per primitive (`None` where there is nothing).
#[derive(Default)]
pub(super) struct Built {
    /// Primitives, in description order.
    pub(super) prims: Vec<Primitive>,
    /// Lights.
    pub(super) lights: Vec<Light>,
    /// Per primitive: its three vertex normals, for smooth meshes.
    normals: Vec<Option<[Vec3; 3]>>,
    /// Per primitive: its three corners' UVs, for meshes with UVs under a texture.
    uvs: Vec<Option<[Vec2; 3]>>,
    /// Per primitive: the world-to-local rotation of a rotated sphere under a texture.
    frames: Vec<Option<Mat3>>,
    /// Moving objects: each one's motion and its primitives in its own space.
    pub(super) moving: Vec<(Motion, Built)>,
}

impl Built {
    /// Room for `n` more primitives, so that a large mesh is not copied as it grows.
    fn reserve(&mut self, n: usize) {
        self.prims.reserve(n);
        self.normals.reserve(n);
        self.uvs.reserve(n);
        self.frames.reserve(n);
    }

    /// Adds a primitive with its per-corner data.
    fn push(&mut self, prim: Primitive, normals: Option<[Vec3; 3]>, uvs: Option<[Vec2; 3]>) {
        self.prims.push(prim);
        self.normals.push(normals);
        self.uvs.push(uvs);
        self.frames.push(None);
    }
}

/// The primitives and lights of the scene's `[[lights]]` and `[[objects]]`; `names` maps
/// material names to indices into `materials`.
pub(super) fn objects(
    f: &SceneFile,
    ctx: &Ctx,
    names: &BTreeMap<&str, u32>,
    materials: &[Material],
    info: &mut SceneInfo,
) -> Result<Built> {
    let mut b = Built::default();
    for (i, l) in f.lights.iter().enumerate() {
        light(ctx, &format!("lights.{i}"), l, &mut b)?;
    }
    let shutter = f.camera.shutter;
    let mut meshes = Meshes::new(f.objects.iter().filter_map(|o| match o {
        ObjectDesc::Mesh { file, .. } => Some(ctx.src.dir.join(file)),
        _ => None,
    }));
    let mut out = Out { b: &mut b, info, meshes: &mut meshes };
    for (i, o) in f.objects.iter().enumerate() {
        let path = format!("objects.{i}");
        match motion::object(ctx, &path, o, shutter)? {
            motion::Placed::AsIs => object(ctx, &path, o, (names, materials), &mut out)?,
            motion::Placed::Still(o) => object(ctx, &path, &o, (names, materials), &mut out)?,
            motion::Placed::Moving(m, o) => {
                let mut own = Built::default();
                object(
                    ctx,
                    &path,
                    &o,
                    (names, materials),
                    &mut Out { b: &mut own, info: out.info, meshes: out.meshes },
                )?;
                out.b.moving.push((*m, own));
            }
        }
    }
    Ok(b)
}

/// What the objects add to: the primitives, the scene's report, and the mesh files read
/// ahead of them.
struct Out<'a> {
    b: &'a mut Built,
    info: &'a mut SceneInfo,
    meshes: &'a mut Meshes,
}

/// One `[[objects]]` entry (its `transform` already the one it is placed with) into `out`,
/// its material looked up in `names` and `materials`.
fn object(
    ctx: &Ctx,
    path: &str,
    o: &ObjectDesc,
    (names, materials): (&BTreeMap<&str, u32>, &[Material]),
    out: &mut Out,
) -> Result<()> {
    let b = &mut *out.b;
    let lookup = |name: &str| {
        names.get(name).copied().ok_or_else(|| {
            let known: Vec<&str> = names.keys().copied().collect();
            let msg = if name.is_empty() {
                format!("missing: name one of the materials ({})", known.join(", "))
            } else {
                format!("unknown material \"{name}\" (defined: {})", known.join(", "))
            };
            ctx.fail(&format!("{path}.material"), msg)
        })
    };
    match o {
        ObjectDesc::Sphere { center, radius, material, transform, .. } => {
            let (shape, frame) = sphere(ctx, path, *center, *radius, transform)?;
            let material = lookup(material)?;
            b.push(Primitive { shape, material, light: NO_LIGHT }, None, None);
            // Texture coordinates turn with the sphere, as Mitsuba's do.
            *b.frames.last_mut().unwrap_or_else(|| unreachable!()) =
                frame.filter(|f| *f != Mat3::IDENTITY && has_texture(&materials[material as usize]));
        }
        ObjectDesc::Quad { corner, edge_u, edge_v, material, transform, uv, .. } => {
            let (corner, u, v) = quad_geometry(ctx, path, *corner, *edge_u, *edge_v, transform)?;
            let material = lookup(material)?;
            // A quad's own UVs matter only under a texture.
            let uv = uv.filter(|_| has_texture(&materials[material as usize])).map(|c| c.map(Vec2::from_array));
            if let Some(c) = uv.iter().flatten().find(|c| !c.is_finite() || c.abs().max_element() > MAX_COORD) {
                return Err(ctx.fail(&format!("{path}.uv"), format!("{c} is beyond ±{MAX_COORD:e}")));
            }
            b.push(Primitive { shape: Shape::Quad { corner, u, v }, material, light: NO_LIGHT }, None, uv);
        }
        ObjectDesc::Mesh { emission, material, .. } => {
            let emission = emission.map(|e| color(ctx, &format!("{path}.emission"), e)).transpose()?;
            let material = if emission.is_some() { 0 } else { lookup(material)? };
            let textured = emission.is_none() && has_texture(&materials[material as usize]);
            mesh_object(ctx, path, o, (material, emission, textured), out)?;
        }
    }
    Ok(())
}

/// True when a material looks up a texture (so its meshes keep their UVs).
fn has_texture(m: &Material) -> bool {
    matches!(
        m,
        Material::Diffuse { color: Color::Texture(_), .. }
            | Material::Conductor { color: Color::Texture(_), .. }
            | Material::Plastic { color: Color::Texture(_), .. }
    )
}

/// One `[[lights]]` entry: its light, and for an area light its primitive.
fn light(ctx: &Ctx, path: &str, l: &LightDesc, b: &mut Built) -> Result<()> {
    let li = b.lights.len() as u32;
    if let LightDesc::Quad { transform_end: Some(_), .. }
    | LightDesc::Triangle { transform_end: Some(_), .. }
    | LightDesc::Point { transform_end: Some(_), .. } = l
    {
        return Err(ctx.fail(&format!("{path}.transform_end"), motion::LIGHTS_STILL));
    }
    match l {
        LightDesc::Quad { corner, edge_u, edge_v, radiance, transform, .. } => {
            let (corner, u, v) = quad_geometry(ctx, path, *corner, *edge_u, *edge_v, transform)?;
            let n = u.cross(v);
            b.push(Primitive { shape: Shape::Quad { corner, u, v }, material: 0, light: li }, None, None);
            b.lights.push(Light::Quad {
                corner,
                u,
                v,
                normal: n.normalize(),
                area: n.length(),
                radiance: color(ctx, &format!("{path}.radiance"), *radiance)?,
            });
        }
        LightDesc::Triangle { v0, v1, v2, radiance, transform, .. } => {
            let t = transform_opt(ctx, path, transform)?;
            let mut vs = [Vec3::ZERO; 3];
            for (k, p) in [v0, v1, v2].into_iter().enumerate() {
                let field = format!("{path}.v{k}");
                vs[k] = coord(ctx, &field, t.point(coord(ctx, &field, vec3(*p))?))?;
            }
            let radiance = color(ctx, &format!("{path}.radiance"), *radiance)?;
            let light = triangle_light(vs, radiance)
                .ok_or_else(|| ctx.fail(&format!("{path}.v2"), "the triangle has zero area"))?;
            let shape = Shape::Triangle { v0: vs[0], v1: vs[1], v2: vs[2] };
            b.push(Primitive { shape, material: 0, light: li }, None, None);
            b.lights.push(light);
        }
        LightDesc::Point { position, intensity, .. } => b.lights.push(Light::Point {
            position: coord(ctx, &format!("{path}.position"), vec3(*position))?,
            intensity: color(ctx, &format!("{path}.intensity"), *intensity)?,
        }),
        LightDesc::Sphere { center, radius, radiance } => {
            let center = coord(ctx, &format!("{path}.center"), vec3(*center))?;
            if !(*radius > 0.0 && *radius <= MAX_COORD) {
                return Err(ctx.fail(&format!("{path}.radius"), format!("{radius} must be in (0, {MAX_COORD:e}]")));
            }
            let radiance = color(ctx, &format!("{path}.radiance"), *radiance)?;
            b.push(Primitive { shape: Shape::Sphere { center, radius: *radius }, material: 0, light: li }, None, None);
            b.lights.push(Light::Sphere { center, radius: *radius, radiance });
        }
        LightDesc::Directional { direction, irradiance } => {
            let direction = vec3(*direction)
                .try_normalize()
                .filter(|d| d.is_finite())
                .ok_or_else(|| ctx.fail(&format!("{path}.direction"), "must be a non-zero direction"))?;
            let irradiance = color(ctx, &format!("{path}.irradiance"), *irradiance)?;
            b.lights.push(Light::Directional { direction, irradiance });
        }
    }
    Ok(())
}

/// A sphere's shape after its transform, checked, and with a transform the rotation that
/// takes world directions from its centre to its own axes (the transform's linear part
/// over its scale, transposed).
fn sphere(
    ctx: &Ctx,
    path: &str,
    center: [f32; 3],
    radius: f32,
    xf: &Option<Vec<TransformOp>>,
) -> Result<(Shape, Option<Mat3>)> {
    // Numbers are checked finite before this point, so `<=` catches every bad radius.
    if radius <= 0.0 {
        return Err(ctx.fail(&format!("{path}.radius"), format!("{radius} must be > 0")));
    }
    coord(ctx, &format!("{path}.radius"), Vec3::splat(radius))?;
    coord(ctx, &format!("{path}.center"), vec3(center))?;
    let (mut c, mut r, mut frame) = (vec3(center), radius, None);
    if let Some(ops) = xf {
        let tp = format!("{path}.transform");
        let t = self::transform(ctx, &tp, ops)?;
        let s = t
            .uniform_scale()
            .ok_or_else(|| ctx.fail(&tp, "a sphere takes only a uniform scale (with rotations and translations)"))?;
        c = coord(ctx, &tp, t.point(c))?;
        r = coord(ctx, &tp, Vec3::splat(r * s))?.x;
        frame = Some((glam::DMat3::from_mat4(t.m).transpose() * (1.0 / s as f64)).as_mat3());
    }
    // A sphere below its centre's rounding step has no point but the centre in f32:
    // every hit point rounds onto it and has no normal (found by fuzzing: NaN rays).
    // 2^-20 of the centre's largest coordinate is 8 of its ulps.
    let least = c.abs().max_element() / (1u32 << 20) as f32;
    if r <= least {
        let field = if xf.is_some() { "transform" } else { "radius" };
        return Err(ctx.fail(
            &format!("{path}.{field}"),
            format!(
                "radius {r:e} is below the precision of the centre {c}: it must exceed 2^-20 of the centre's largest coordinate ({least:e})"
            ),
        ));
    }
    Ok((Shape::Sphere { center: c, radius: r }, frame))
}

/// A mesh object's triangles (`material`, or one-sided emitters of `emission`), with
/// their vertex normals when smooth and their UVs when `textured` and the file has them.
fn mesh_object(
    ctx: &Ctx,
    path: &str,
    o: &ObjectDesc,
    (material, emission, textured): (u32, Option<Vec3>, bool),
    out: &mut Out,
) -> Result<()> {
    let Out { b, info, meshes } = out;
    let ObjectDesc::Mesh { file, scale, rotate_y, translate, transform, smooth, flip_normals, .. } = o else {
        unreachable!("called for meshes only")
    };
    if *scale <= 0.0 {
        return Err(ctx.fail(&format!("{path}.scale"), format!("{scale} must be > 0")));
    }
    let mesh_path = ctx.src.dir.join(file);
    info.inputs.push((format!("the mesh of `{path}`"), mesh_path.clone()));
    let loaded = meshes.take(&mesh_path);
    let mesh = loaded.as_ref().as_ref().map_err(|e| ctx.fail(&format!("{path}.file"), e))?;
    if outside_folder(&ctx.src.dir, &mesh_path) {
        info.outside_paths.push(mesh_path.display().to_string());
    }
    let rot = glam::Quat::from_rotation_y(rotate_y.to_radians());
    let t = coord(ctx, &format!("{path}.translate"), vec3(*translate))?;
    let after = transform_opt(ctx, path, transform)?;
    let xf = |p: Vec3| {
        let p = rot * (p * *scale) + t;
        if transform.is_some() {
            after.point(p)
        } else {
            p
        }
    };
    let positions: Vec<Vec3> = mesh.positions.iter().map(|&p| xf(p)).collect();
    if let Some(v) = positions.iter().find(|v| !in_range(**v)) {
        let field = if transform.is_some() { "transform" } else { "scale" };
        return Err(ctx.fail(
            &format!("{path}.{field}"),
            format!("a vertex lands at {v} after the mesh's transform: beyond ±{MAX_COORD:e}"),
        ));
    }
    let mut tris = mesh.triangles.clone();
    if *flip_normals {
        tris.iter_mut().for_each(|t| t.swap(1, 2));
    }
    let vertex_normals = smooth.then(|| {
        if mesh.normals.is_empty() {
            mesh::vertex_normals(&positions, &tris)
        } else {
            // The file's normals follow the mesh: rotated with it, and through the
            // inverse transpose of a non-uniform scale.
            let lin = Transform { m: glam::DMat4::from_quat(rot.as_dquat()) }.m;
            let whole = Transform { m: after.m * lin };
            let sign = if *flip_normals { -1.0 } else { 1.0 };
            mesh.normals.iter().map(|&n| sign * whole.normal(n)).collect()
        }
    });
    let uvs = (textured && !mesh.uvs.is_empty()).then_some(&mesh.uvs);
    b.reserve(tris.len());
    for tri in &tris {
        let [v0, v1, v2] = tri.map(|k| positions[k as usize]);
        if (v1 - v0).cross(v2 - v0).length_squared() == 0.0 {
            info.degenerate_triangles += 1;
            continue;
        }
        info.triangles += 1;
        let light = match emission {
            Some(radiance) => {
                // Non-zero area was checked just above.
                b.lights.push(triangle_light([v0, v1, v2], radiance).unwrap_or_else(|| unreachable!()));
                b.lights.len() as u32 - 1
            }
            None => NO_LIGHT,
        };
        b.push(
            Primitive { shape: Shape::Triangle { v0, v1, v2 }, material, light },
            vertex_normals.as_ref().map(|n| tri.map(|k| n[k as usize])),
            uvs.map(|uv| tri.map(|k| uv[k as usize])),
        );
    }
    Ok(())
}

/// The optional `transform` of an object or light.
fn transform_opt(ctx: &Ctx, path: &str, ops: &Option<Vec<TransformOp>>) -> Result<Transform> {
    match ops {
        Some(ops) => transform(ctx, &format!("{path}.transform"), ops),
        None => Ok(Transform::IDENTITY),
    }
}

/// Corner and edges of a parallelogram after its transform, checked.
fn quad_geometry(
    ctx: &Ctx,
    path: &str,
    corner: [f32; 3],
    u: [f32; 3],
    v: [f32; 3],
    xf: &Option<Vec<TransformOp>>,
) -> Result<(Vec3, Vec3, Vec3)> {
    let (u, v) = edges(ctx, path, u, v)?;
    let c = coord(ctx, &format!("{path}.corner"), vec3(corner))?;
    let Some(ops) = xf else { return Ok((c, u, v)) };
    let t = transform(ctx, &format!("{path}.transform"), ops)?;
    let (c, u, v) = (t.point(c), t.vector(u), t.vector(v));
    let tp = format!("{path}.transform");
    let (u, v) = edges(ctx, &tp, u.to_array(), v.to_array())?;
    Ok((coord(ctx, &tp, c)?, u, v))
}

/// True when `path` resolves (following `..` and symlinks) outside `dir`.
fn outside_folder(dir: &Path, path: &Path) -> bool {
    match (std::fs::canonicalize(dir), std::fs::canonicalize(path)) {
        (Ok(d), Ok(p)) => !p.starts_with(d),
        _ => false,
    }
}

/// A one-sided triangle light, or `None` for a zero-area triangle.
fn triangle_light([v0, v1, v2]: [Vec3; 3], radiance: Vec3) -> Option<Light> {
    let (e1, e2) = (v1 - v0, v2 - v0);
    let n = e1.cross(e2);
    let len = mesh::cross_length(n);
    (len > 0.0 && len.is_finite()).then(|| Light::Triangle { v0, e1, e2, normal: n / len, area: 0.5 * len, radiance })
}

/// The per-corner tables of a scene in the BVH's primitive order.
pub(super) struct CornerTables {
    /// Vertex normals (zero for a flat primitive); empty when no mesh is smooth.
    pub(super) normals: Vec<[Vec3; 3]>,
    /// Corner UVs ([`uv::DEFAULT_UVS`] where none); empty when no textured mesh or quad has UVs.
    pub(super) uvs: Vec<[Vec2; 3]>,
    /// World-to-local rotations of textured spheres (identity elsewhere); empty when no
    /// textured sphere is rotated.
    pub(super) frames: Vec<Mat3>,
}

/// Builds the BVH (and each moving object's, attached to it with the shutter its
/// bounds cover) and puts the per-corner tables in primitive-id order. [`Accel::build`]
/// reorders the primitives and keeps no map back, and the acceleration module does not
/// know about shading data: each primitive's position rides through the build in its
/// `material` field and is replaced by the real one afterwards. Without smooth or
/// textured meshes the tables are empty and the build is the plain one.
pub(super) fn build_accel(b: Built, quality: BvhQuality, shutter: [f32; 2]) -> (Accel, CornerTables) {
    let Built { prims, normals, uvs, frames, moving, .. } = b;
    let parts = || {
        std::iter::once((&normals, &uvs, &frames)).chain(moving.iter().map(|(_, m)| (&m.normals, &m.uvs, &m.frames)))
    };
    let smooth = parts().any(|(n, _, _)| n.iter().any(Option::is_some));
    let textured = parts().any(|(_, u, _)| u.iter().any(Option::is_some));
    let rotated = parts().any(|(_, _, f)| f.iter().any(Option::is_some));
    let mut tables = CornerTables { normals: Vec::new(), uvs: Vec::new(), frames: Vec::new() };
    let track = smooth || textured || rotated;
    let mut add =
        |order: &[usize], normals: &[Option<[Vec3; 3]>], uvs: &[Option<[Vec2; 3]>], frames: &[Option<Mat3>]| {
            for &i in order {
                if smooth {
                    tables.normals.push(normals[i].unwrap_or([Vec3::ZERO; 3]));
                }
                if textured {
                    tables.uvs.push(uvs[i].unwrap_or(uv::DEFAULT_UVS));
                }
                if rotated {
                    tables.frames.push(frames[i].unwrap_or(Mat3::IDENTITY));
                }
            }
        };
    let (mut accel, order) = build_tracked(prims, quality, track);
    add(&order, &normals, &uvs, &frames);
    if !moving.is_empty() {
        let mut objects = Vec::with_capacity(moving.len());
        for (motion, own) in moving {
            let (object, order) = build_tracked(own.prims, quality, track);
            add(&order, &own.normals, &own.uvs, &own.frames);
            objects.push((motion, object));
        }
        accel.attach_moving(objects, shutter);
    }
    (accel, tables)
}

/// The BVH over `prims` and, when `track`, the input index of each primitive id.
fn build_tracked(mut prims: Vec<Primitive>, quality: BvhQuality, track: bool) -> (Accel, Vec<usize>) {
    if !track {
        return (Accel::build_with(prims, MAX_LEAF, quality), Vec::new());
    }
    let materials: Vec<u32> = prims.iter().map(|p| p.material).collect();
    for (i, p) in prims.iter_mut().enumerate() {
        p.material = i as u32;
    }
    let mut accel = Accel::build_with(prims, MAX_LEAF, quality);
    let mut order = Vec::with_capacity(accel.len());
    for id in 0..accel.len() as u32 {
        let i = accel.material(id) as usize;
        accel.set_material(id, materials[i]);
        order.push(i);
    }
    (accel, order)
}
