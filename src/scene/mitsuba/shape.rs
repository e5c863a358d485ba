//! Shapes and emitters: meshes, rectangles, cubes, spheres, flattened instances, and the
//! lights they carry (area emitters nested in a shape or referenced by id), point lights
//! and the constant background.

use super::xml::{self, El};
use super::{compose, unsupported, Converter, Params, EMITTERS, SHAPES};
use crate::scene::format::*;
use crate::Result;

/// Plugin elements a shape may hold.
const SHAPE_NESTED: [&str; 3] = ["bsdf", "ref", "emitter"];

/// A cube's faces [-1, 1]³ as (corner, u, v), u × v outwards (Mitsuba's cube).
const CUBE: [([f32; 3], [f32; 3], [f32; 3]); 6] = [
    ([1.0, -1.0, -1.0], [0.0, 2.0, 0.0], [0.0, 0.0, 2.0]),
    ([-1.0, -1.0, -1.0], [0.0, 0.0, 2.0], [0.0, 2.0, 0.0]),
    ([-1.0, 1.0, -1.0], [0.0, 0.0, 2.0], [2.0, 0.0, 0.0]),
    ([-1.0, -1.0, -1.0], [2.0, 0.0, 0.0], [0.0, 0.0, 2.0]),
    ([-1.0, -1.0, 1.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]),
    ([-1.0, -1.0, -1.0], [0.0, 2.0, 0.0], [2.0, 0.0, 0.0]),
];

/// Mitsuba's UVs of the [`CUBE`] faces at corner, corner + u and corner + v (read from
/// Mitsuba 3.9.1: per face, (a, b) maps to +x (a, 1−b), −x (b, a), +y (1−b, 1−a),
/// −y (b, a), +z (b, a), −z (1−a, b)).
const CUBE_UV: [[[f32; 2]; 3]; 6] = [
    [[0.0, 1.0], [1.0, 1.0], [0.0, 0.0]],
    [[0.0, 0.0], [0.0, 1.0], [1.0, 0.0]],
    [[1.0, 1.0], [1.0, 0.0], [0.0, 1.0]],
    [[0.0, 0.0], [0.0, 1.0], [1.0, 0.0]],
    [[0.0, 0.0], [0.0, 1.0], [1.0, 0.0]],
    [[1.0, 0.0], [0.0, 0.0], [1.0, 1.0]],
];

/// The rectangle's UVs at its corner, corner + u and corner + v: the quad's own (a, b).
const RECTANGLE_UV: [[f32; 2]; 3] = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]];

/// Mitsuba's rectangle [-1, 1]² at z = 0 as (corner, u, v): the quad's (a, b) at
/// corner + a·u + b·v is Mitsuba's UV ((x + 1) / 2, (y + 1) / 2), and u × v is +z.
const RECTANGLE: [([f32; 3], [f32; 3], [f32; 3]); 1] = [([-1.0, -1.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0])];

/// What a shape carries: its BSDFs and emitters, nested or referenced.
struct Attached<'e> {
    bsdfs: Vec<&'e El>,
    emitters: Vec<&'e El>,
}

impl<'a> Converter<'a> {
    /// Converts a shape; `outer` are the transform steps of enclosing instances, applied
    /// after the shape's own.
    pub(super) fn shape(&mut self, el: &El, outer: &[TransformOp]) -> Result<()> {
        let ty = el.need("type")?;
        match ty {
            "obj" | "ply" => self.mesh(el, outer),
            "rectangle" | "cube" => self.quads(el, ty == "rectangle", outer),
            "sphere" => self.sphere(el, outer),
            "instance" => self.instance(el, outer),
            "shapegroup" => Err(el.loc.err("<shape type=\"shapegroup\"> must be at the top level with an id")),
            _ => Err(unsupported(el, "shape", SHAPES)),
        }
    }

    /// `obj` and `ply`: a mesh file, every triangle a light under an area emitter.
    fn mesh(&mut self, el: &El, outer: &[TransformOp]) -> Result<()> {
        let idx = self.out.file.objects.len();
        let p = Params::of(
            el,
            &["filename", "to_world", "face_normals", "flip_normals", "flip_tex_coords"],
            &SHAPE_NESTED,
        )?;
        let (file, fel) =
            p.string("filename")?.ok_or_else(|| el.loc.err(format!("{}: lacks `filename`", el.what())))?;
        let path = xml::resolve(&file, &el.dir, &self.search, &fel.loc)?;
        // Absolute, so that it does not depend on the folder meshes start from.
        let path = std::fs::canonicalize(&path).unwrap_or(path);
        let mut ops = p.transform("to_world")?;
        ops.extend_from_slice(outer);
        compose(el, &ops)?;
        let emission = self.area_emitter(el)?;
        let material = if emission.is_some() { String::new() } else { self.shape_material(el)? };
        let smooth = !p.boolean("face_normals")?.unwrap_or(false);
        let obj = ObjectDesc::Mesh {
            file: path.display().to_string(),
            material,
            scale: 1.0,
            rotate_y: 0.0,
            translate: [0.0; 3],
            transform: Some(ops),
            transform_end: None,
            smooth,
            emission,
            flip_normals: p.boolean("flip_normals")?.unwrap_or(false),
        };
        self.out.file.objects.push(obj);
        self.place(format!("objects.{idx}"), el);
        Ok(())
    }

    /// `rectangle` (one quad) and `cube` (six): objects, or quad lights under an area
    /// emitter.
    fn quads(&mut self, el: &El, rectangle: bool, outer: &[TransformOp]) -> Result<()> {
        let p = Params::of(el, &["to_world", "flip_normals"], &SHAPE_NESTED)?;
        let mut ops = p.transform("to_world")?;
        ops.extend_from_slice(outer);
        let t = compose(el, &ops)?;
        // Mitsuba's normal is the transformed +z normal (inverse transpose): a
        // mirroring transform turns u × v against it, so the edges swap.
        let swap = t.mirrors() ^ p.boolean("flip_normals")?.unwrap_or(false);
        let emission = self.area_emitter(el)?;
        let material = if emission.is_some() { String::new() } else { self.shape_material(el)? };
        let faces: &[([f32; 3], [f32; 3], [f32; 3])] = if rectangle { &RECTANGLE } else { &CUBE };
        for (k, &(corner, u, v)) in faces.iter().enumerate() {
            let (edge_u, edge_v) = if swap { (v, u) } else { (u, v) };
            // Mitsuba's UVs at corner, corner + edge_u and corner + edge_v.
            let at = if rectangle { RECTANGLE_UV } else { CUBE_UV[k] };
            let uv = Some(if swap { [at[0], at[2], at[1]] } else { at }).filter(|c| *c != RECTANGLE_UV);
            let transform = Some(ops.clone());
            if let Some(radiance) = emission {
                let li = self.out.file.lights.len();
                self.out.file.lights.push(LightDesc::Quad {
                    corner,
                    edge_u,
                    edge_v,
                    radiance,
                    transform,
                    transform_end: None,
                });
                self.place(format!("lights.{li}"), el);
            } else {
                let i = self.out.file.objects.len();
                let material = material.clone();
                self.out.file.objects.push(ObjectDesc::Quad {
                    corner,
                    edge_u,
                    edge_v,
                    material,
                    transform,
                    transform_end: None,
                    uv,
                });
                self.place(format!("objects.{i}"), el);
            }
        }
        Ok(())
    }

    /// `sphere`: centre and radius, placed by a uniformly scaling `to_world`.
    fn sphere(&mut self, el: &El, outer: &[TransformOp]) -> Result<()> {
        let idx = self.out.file.objects.len();
        let p = Params::of(el, &["center", "radius", "to_world", "flip_normals"], &SHAPE_NESTED)?;
        let emission = self.area_emitter(el)?;
        if p.boolean("flip_normals")? == Some(true) {
            return Err(el.loc.err("<shape type=\"sphere\">: flip_normals is not supported"));
        }
        let mut ops = p.transform("to_world")?;
        ops.extend_from_slice(outer);
        let t = compose(el, &ops)?;
        if t.uniform_scale().is_none() {
            return Err(el
                .loc
                .err("<shape type=\"sphere\">: to_world must be a uniform scale with rotations and translations"));
        }
        let center = p.point("center")?.unwrap_or([0.0; 3]);
        let radius = p.num("radius")?.unwrap_or(1.0) as f32;
        if let Some(radiance) = emission {
            // A sphere light: its centre and radius through to_world (a uniform scale).
            let center = t.point(glam::Vec3::from_array(center)).to_array();
            let radius = radius * t.uniform_scale().unwrap_or(1.0);
            let li = self.out.file.lights.len();
            self.out.file.lights.push(LightDesc::Sphere { center, radius, radiance });
            self.place(format!("lights.{li}"), el);
            return Ok(());
        }
        let material = self.shape_material(el)?;
        let transform = (!ops.is_empty()).then_some(ops);
        self.out.file.objects.push(ObjectDesc::Sphere { center, radius, material, transform, transform_end: None });
        self.place(format!("objects.{idx}"), el);
        Ok(())
    }

    /// `instance`: the referenced shape group's shapes, flattened under the instance's
    /// `to_world`.
    fn instance(&mut self, el: &El, outer: &[TransformOp]) -> Result<()> {
        let p = Params::of(el, &["to_world"], &["ref"])?;
        let r = el
            .kids
            .iter()
            .find(|k| k.tag == "ref")
            .ok_or_else(|| el.loc.err("<shape type=\"instance\"> lacks a <ref id=...> to a shapegroup"))?;
        let group = self.referenced(r, "an instance takes a <shape type=\"shapegroup\">", |d| {
            d.tag == "shape" && d.attr("type") == Some("shapegroup")
        })?;
        if outer.len() > 256 {
            return Err(el.loc.err("instances nest too deeply"));
        }
        let mut ops = p.transform("to_world")?;
        ops.extend_from_slice(outer);
        for k in group.kids.iter().filter(|k| k.tag == "shape") {
            if k.attr("type") == Some("instance") || k.attr("type") == Some("shapegroup") {
                return Err(k.loc.err("a shapegroup holding instances or shapegroups is not supported"));
            }
            self.shape(k, &ops)?;
        }
        Ok(())
    }

    /// The BSDFs and emitters of a shape, nested or referenced by id (declared anywhere,
    /// before or after the shape).
    fn attached<'e>(&mut self, el: &'e El) -> Result<Attached<'e>>
    where
        'a: 'e,
    {
        let mut a = Attached { bsdfs: Vec::new(), emitters: Vec::new() };
        for k in &el.kids {
            let k = match k.tag.as_str() {
                "ref" => self.referenced(k, "a shape takes a <bsdf> or an <emitter type=\"area\">", |d| {
                    d.tag == "bsdf" || (d.tag == "emitter" && d.attr("type") == Some("area"))
                })?,
                "bsdf" | "emitter" => k,
                _ => continue,
            };
            if k.tag == "bsdf" {
                a.bsdfs.push(k);
            } else {
                a.emitters.push(k);
            }
        }
        Ok(a)
    }

    /// The material of a shape: its nested or referenced BSDF, or Mitsuba's default (a
    /// diffuse of reflectance 0.5).
    fn shape_material(&mut self, el: &El) -> Result<String> {
        let a = self.attached(el)?;
        match a.bsdfs[..] {
            [] => {
                let name = "mitsuba-default-diffuse".to_string();
                if !self.out.file.materials.contains_key(&name) {
                    // One-sided, as Mitsuba's.
                    let d = MaterialDesc::Diffuse {
                        color: ColorDesc::Rgb([0.5; 3]),
                        specular: [0.0; 3],
                        shininess: 0.0,
                        two_sided: false,
                    };
                    self.out.file.materials.insert(name.clone(), d);
                }
                Ok(name)
            }
            [b] => self.bsdf(b),
            _ => Err(el.loc.err(format!("{}: more than one BSDF", el.what()))),
        }
    }

    /// The radiance of a shape's area emitter, nested or referenced, if it has one.
    fn area_emitter(&mut self, el: &El) -> Result<Option<[f32; 3]>> {
        let a = self.attached(el)?;
        let e = match a.emitters[..] {
            [] => return Ok(None),
            [e] => e,
            _ => return Err(el.loc.err(format!("{}: more than one emitter", el.what()))),
        };
        if e.attr("type") != Some("area") {
            return Err(e.loc.err(format!("{} on a shape: only type=\"area\" emitters attach to shapes", e.what())));
        }
        let Some(id) = e.attr("id") else { return self.area_radiance(e).map(Some) };
        // Mitsuba attaches an emitter to one shape ("an endpoint can be only be attached
        // to a single shape"); an instanced shape is the same element each time.
        match self.emitter_shapes.get(id) {
            Some(first) if !same_place(first, &el.loc) => {
                return Err(el.loc.err(format!(
                    "{}: <emitter type=\"area\" id=\"{id}\"> is already attached to the shape at {}:{}:{}; an area \
                     emitter lights one shape (Mitsuba refuses a second one too)",
                    el.what(),
                    first.file,
                    first.line,
                    first.col
                )))
            }
            Some(_) => {}
            None => {
                self.emitter_shapes.insert(id.to_string(), el.loc.clone());
            }
        }
        if let Some(r) = self.emitters.get(id) {
            // A failed emitter has reported its error already; any value stands in.
            return Ok(Some(r.unwrap_or([0.0; 3])));
        }
        let r = self.area_radiance(e);
        self.emitters.insert(id.to_string(), r.as_ref().ok().copied());
        r.map(Some)
    }

    /// The `radiance` of an `<emitter type="area">`.
    pub(super) fn area_radiance(&mut self, e: &El) -> Result<[f32; 3]> {
        let p = Params::of(e, &["radiance"], &[])?;
        p.color("radiance")?.ok_or_else(|| e.loc.err("<emitter type=\"area\"> lacks `radiance`"))
    }

    /// `constant` (its radiance) or `envmap` (its file, found as meshes are, `scale` and a
    /// rotation `to_world`) as the background, which the path transport samples as a light.
    fn environment(&mut self, el: &El) -> Result<BackgroundDesc> {
        if el.attr("type") == Some("constant") {
            let p = Params::of(el, &["radiance"], &[])?;
            return Ok(BackgroundDesc { color: Some(p.color("radiance")?.unwrap_or([1.0; 3])), ..Default::default() });
        }
        let p = Params::of(el, &["filename", "scale", "to_world"], &[])?;
        let (file, fel) =
            p.string("filename")?.ok_or_else(|| el.loc.err(format!("{}: lacks `filename`", el.what())))?;
        let path = xml::resolve(&file, &el.dir, &self.search, &fel.loc)?;
        // Absolute, so that it does not depend on the folder the loader starts from.
        let path = std::fs::canonicalize(&path).unwrap_or(path);
        let ops = p.transform("to_world")?;
        Ok(BackgroundDesc {
            color: None,
            map: Some(path.display().to_string()),
            scale: p.num("scale")?.map(|s| s as f32),
            transform: (!ops.is_empty()).then_some(ops),
        })
    }

    /// A top-level emitter: a point light or the background. An area emitter there must
    /// have an id (shapes reference it); the first pass has read it.
    pub(super) fn emitter(&mut self, el: &El) -> Result<()> {
        match el.attr("type").unwrap_or("") {
            "point" => {
                let p = Params::of(el, &["intensity", "position", "to_world"], &[])?;
                let intensity = p.color("intensity")?.unwrap_or([1.0; 3]);
                let ops = p.transform("to_world")?;
                let t = compose(el, &ops)?;
                let local = p.point("position")?.unwrap_or([0.0; 3]);
                let position = t.point(glam::Vec3::from_array(local)).to_array();
                let li = self.out.file.lights.len();
                self.out.file.lights.push(LightDesc::Point { position, intensity, transform_end: None });
                self.place(format!("lights.{li}"), el);
            }
            "directional" => {
                let p = Params::of(el, &["irradiance", "direction", "to_world"], &[])?;
                let irradiance = p.color("irradiance")?.unwrap_or([1.0; 3]);
                let t = compose(el, &p.transform("to_world")?)?;
                // Mitsuba: `direction`, or the local +z through `to_world`.
                let local = p.point("direction")?.unwrap_or([0.0, 0.0, 1.0]);
                let direction = t.vector(glam::Vec3::from_array(local)).to_array();
                let li = self.out.file.lights.len();
                self.out.file.lights.push(LightDesc::Directional { direction, irradiance });
                self.place(format!("lights.{li}"), el);
            }
            "constant" | "envmap" => {
                if self.environment_seen {
                    return Err(el.loc.err(format!("{}: a second environment; wavetrace takes one", el.what())));
                }
                self.environment_seen = true;
                self.out.file.background = self.environment(el)?;
                self.place("background".into(), el);
            }
            "area" if el.attr("id").is_some() => {}
            "area" => {
                return Err(el
                    .loc
                    .err("<emitter type=\"area\"> must be inside a <shape>, or have an id that a shape's <ref> names"))
            }
            _ => return Err(unsupported(el, "emitter", EMITTERS)),
        }
        Ok(())
    }
}

/// True when two places are the same file, line and column.
fn same_place(a: &xml::Loc, b: &xml::Loc) -> bool {
    a.file == b.file && a.line == b.line && a.col == b.col
}
