//! Mitsuba 3 XML scenes: [`xml`] reads the files (includes, defaults, values) and this
//! module maps the supported plugins onto wavetrace's own scene description
//! ([`SceneFile`]), so an imported scene goes through the same validation, `--set`
//! overrides and rendering as a TOML one. Anything outside the subset is an error that
//! names the file, line, column, the plugin and what is supported (docs/import.md).

pub mod xml;

use std::collections::BTreeMap;
use std::path::Path;

use super::format::*;
use super::transform::Transform;
use crate::Result;
use xml::{value, El, Loc, Value};

/// Shape types imported.
pub const SHAPES: &str = "obj, ply, rectangle, cube, sphere, shapegroup, instance";
/// BSDF types imported.
pub const BSDFS: &str = "diffuse, twosided, conductor (material=\"none\": a perfect mirror), dielectric";
/// Emitter types imported.
pub const EMITTERS: &str = "area (on a rectangle, cube, obj or ply), point, constant (background only)";
/// Sensor types imported.
pub const SENSORS: &str = "perspective, thinlens";

/// Mitsuba's named indices of refraction (its `ior.h` table).
const IORS: [(&str, f32); 23] = [
    ("vacuum", 1.0),
    ("helium", 1.00004),
    ("hydrogen", 1.00013),
    ("air", 1.00028),
    ("carbon dioxide", 1.00045),
    ("water", 1.333),
    ("acetone", 1.36),
    ("ethanol", 1.361),
    ("carbon tetrachloride", 1.461),
    ("glycerol", 1.4729),
    ("benzene", 1.501),
    ("silicone oil", 1.52045),
    ("bromine", 1.661),
    ("water ice", 1.31),
    ("fused quartz", 1.458),
    ("pyrex", 1.47),
    ("acrylic glass", 1.49),
    ("polypropylene", 1.49),
    ("bk7", 1.5046),
    ("sodium chloride", 1.544),
    ("amber", 1.55),
    ("pet", 1.575),
    ("diamond", 2.419),
];

/// A scene read from Mitsuba XML.
pub struct Imported {
    /// The scene in wavetrace's terms.
    pub file: SceneFile,
    /// Where each part came from: dotted field prefix (`objects.3`, `materials.wall`,
    /// `camera`) → element position, for the messages of later validation.
    pub places: Vec<(String, Loc)>,
    /// What was read but differs from Mitsuba, or was ignored (printed as notes).
    pub notes: Vec<String>,
}

/// Reads a Mitsuba XML scene with `-D name=value` parameters.
pub fn import(path: &Path, defines: &[(String, String)]) -> Result<Imported> {
    let tree = xml::read(path, defines)?;
    let mut c = Converter {
        search: tree.search,
        out: Imported {
            file: SceneFile {
                render: RenderDesc { max_depth: 5, ..RenderDesc::default() },
                camera: CameraDesc {
                    position: None,
                    look_at: None,
                    up: [0.0, 1.0, 0.0],
                    transform: Some(Vec::new()),
                    fov_y: 40.0,
                    aperture: 0.0,
                    focus_distance: None,
                },
                background: BackgroundDesc::default(),
                materials: BTreeMap::new(),
                lights: Vec::new(),
                objects: Vec::new(),
            },
            places: Vec::new(),
            notes: Vec::new(),
        },
        named: BTreeMap::new(),
        groups: BTreeMap::new(),
        sensor: false,
        one_sided_noted: false,
    };
    let root = tree.root;
    // Every top-level element is converted even after one fails, and the failures are
    // reported together: a scene with five unsupported plugins takes one run to list
    // them, not five edit-and-rerun rounds. Each element reports its first problem.
    let mut errors = Vec::new();
    // Named BSDFs and shape groups first: Mitsuba resolves references to ids anywhere in
    // the file.
    for el in &root.kids {
        match el.tag.as_str() {
            "bsdf" => match el.need("id") {
                Ok(id) => {
                    let id = id.to_string();
                    // A BSDF that failed still answers its references, so they do not
                    // add a second, misleading error.
                    let name = c.bsdf(el, Some(&id)).unwrap_or_else(|e| {
                        errors.push(e);
                        id.clone()
                    });
                    c.named.insert(id, name);
                }
                Err(e) => errors.push(e),
            },
            "shape" if el.attr("type") == Some("shapegroup") => match el.need("id") {
                Ok(id) => {
                    c.groups.insert(id.to_string(), el.clone());
                }
                Err(e) => errors.push(e),
            },
            _ => {}
        }
    }
    for el in &root.kids {
        let done = match el.tag.as_str() {
            "bsdf" => Ok(()),
            "shape" if el.attr("type") == Some("shapegroup") => Ok(()),
            "sensor" => c.sensor(el),
            "shape" => c.shape(el, &[]),
            "emitter" => c.emitter(el),
            "integrator" => c.integrator(el),
            "texture" | "medium" | "volume" | "phase" | "film" | "sampler" | "rfilter" => Err(el.loc.err(format!(
                "{}: not supported at the top level (textures, media and volumes are outside the imported subset)",
                el.what()
            ))),
            other => Err(el.loc.err(format!(
                "<{other}>: unknown element; expected sensor, shape, bsdf, emitter, integrator, default, include or path"
            ))),
        };
        if let Err(e) = done {
            errors.push(e);
        }
    }
    if !errors.is_empty() {
        return Err(collected(errors));
    }
    if !c.sensor {
        return Err(root.loc.err("the scene has no <sensor>"));
    }
    Ok(c.out)
}

/// Problems listed in one error, at most this many; the rest are counted.
pub const MAX_LISTED_ERRORS: usize = 20;

/// One error from several: a single one as it is; more as a count and one line each
/// (each with its FILE:LINE:COL), up to [`MAX_LISTED_ERRORS`], then "and N more".
fn collected(errors: Vec<crate::Error>) -> crate::Error {
    if errors.len() == 1 {
        return errors.into_iter().next().unwrap_or_else(|| crate::Error::input("no error"));
    }
    let mut msg = format!("{} problems in the scene:", errors.len());
    for e in errors.iter().take(MAX_LISTED_ERRORS) {
        msg.push_str(&format!("\n  {e}"));
    }
    if errors.len() > MAX_LISTED_ERRORS {
        msg.push_str(&format!("\n  and {} more", errors.len() - MAX_LISTED_ERRORS));
    }
    crate::Error::input(msg)
}

struct Converter {
    search: Vec<std::path::PathBuf>,
    out: Imported,
    /// BSDF id → material name.
    named: BTreeMap<String, String>,
    /// Shape group id → its element.
    groups: BTreeMap<String, El>,
    sensor: bool,
    one_sided_noted: bool,
}

/// The parameters of a plugin element: name → value element; nested plugins apart.
struct Params<'a> {
    el: &'a El,
    values: Vec<(&'a str, &'a El)>,
}

impl<'a> Params<'a> {
    /// Reads `el`'s parameters, refusing any not in `allowed` (and nested plugin elements
    /// other than `nested`).
    fn of(el: &'a El, allowed: &[&str], nested: &[&str]) -> Result<Params<'a>> {
        let mut values = Vec::new();
        for k in &el.kids {
            if xml::VALUE_TAGS.contains(&k.tag.as_str()) || k.tag == "transform" {
                let name = k.need("name")?;
                if !allowed.contains(&name) {
                    return Err(k.loc.err(format!(
                        "{}: parameter `{name}` is not supported (supported: {})",
                        el.what(),
                        if allowed.is_empty() { "none".to_string() } else { allowed.join(", ") }
                    )));
                }
                if values.iter().any(|(n, _)| *n == name) {
                    return Err(k.loc.err(format!("{}: parameter `{name}` given twice", el.what())));
                }
                values.push((name, k));
            } else if !nested.contains(&k.tag.as_str()) {
                return Err(k.loc.err(format!(
                    "<{}> inside {}: not supported here{}",
                    k.tag,
                    el.what(),
                    if nested.is_empty() { String::new() } else { format!(" (accepted: {})", nested.join(", ")) }
                )));
            }
        }
        Ok(Params { el, values })
    }

    fn get(&self, name: &str) -> Result<Option<(Value, &'a El)>> {
        match self.values.iter().find(|(n, _)| *n == name) {
            Some((_, el)) => Ok(Some((value(el)?, el))),
            None => Ok(None),
        }
    }

    fn num(&self, name: &str) -> Result<Option<f64>> {
        match self.get(name)? {
            None => Ok(None),
            Some((Value::Num(x), _)) => Ok(Some(x)),
            Some((_, el)) => Err(el.loc.err(format!("{}: `{name}` must be a number", self.el.what()))),
        }
    }

    fn color(&self, name: &str) -> Result<Option<[f32; 3]>> {
        match self.get(name)? {
            None => Ok(None),
            Some((Value::Num(x), _)) => Ok(Some([x as f32; 3])),
            Some((Value::Rgb(c), _)) => Ok(Some(c.map(|x| x as f32))),
            Some((_, el)) => Err(el.loc.err(format!("{}: `{name}` must be an <rgb> or a number", self.el.what()))),
        }
    }

    fn boolean(&self, name: &str) -> Result<Option<bool>> {
        match self.get(name)? {
            None => Ok(None),
            Some((Value::Bool(b), _)) => Ok(Some(b)),
            Some((_, el)) => Err(el.loc.err(format!("{}: `{name}` must be a <boolean>", self.el.what()))),
        }
    }

    fn string(&self, name: &str) -> Result<Option<(String, &'a El)>> {
        match self.get(name)? {
            None => Ok(None),
            Some((Value::Str(s), el)) => Ok(Some((s, el))),
            Some((_, el)) => Err(el.loc.err(format!("{}: `{name}` must be a <string>", self.el.what()))),
        }
    }

    fn point(&self, name: &str) -> Result<Option<[f32; 3]>> {
        match self.get(name)? {
            None => Ok(None),
            Some((Value::Vec(v), _)) => Ok(Some(v.map(|x| x as f32))),
            Some((_, el)) => Err(el.loc.err(format!("{}: `{name}` must be a <point>", self.el.what()))),
        }
    }

    fn transform(&self, name: &str) -> Result<Vec<TransformOp>> {
        match self.get(name)? {
            None => Ok(Vec::new()),
            Some((Value::Transform(t), _)) => Ok(t),
            Some((_, el)) => Err(el.loc.err(format!("{}: `{name}` must be a <transform>", self.el.what()))),
        }
    }
}

fn unsupported(el: &El, kind: &str, list: &str) -> crate::Error {
    el.loc.err(format!("{}: not supported; wavetrace imports {kind} types {list} (docs/import.md)", el.what()))
}

/// A composed transform, its errors placed at `el`.
fn compose(el: &El, ops: &[TransformOp]) -> Result<Transform> {
    Transform::from_ops(ops).map_err(|(i, e)| el.loc.err(format!("{}: to_world step {}: {e}", el.what(), i + 1)))
}

impl Converter {
    fn place(&mut self, path: String, el: &El) {
        self.out.places.push((path, el.loc.clone()));
    }

    fn note(&mut self, msg: String) {
        if !self.out.notes.contains(&msg) {
            self.out.notes.push(msg);
        }
    }

    fn sensor(&mut self, el: &El) -> Result<()> {
        if self.sensor {
            self.note(format!("{}:{}: a second <sensor> is ignored (the first one renders)", el.loc.file, el.loc.line));
            return Ok(());
        }
        self.sensor = true;
        let ty = el.need("type")?;
        let thin = match ty {
            "perspective" => false,
            "thinlens" => true,
            _ => return Err(unsupported(el, "sensor", SENSORS)),
        };
        // A perspective sensor has no lens: Mitsuba ignores a focus_distance on it (its own
        // Cornell box sets one), and so does this.
        let mut allowed =
            vec!["fov", "fov_axis", "focal_length", "to_world", "near_clip", "far_clip", "focus_distance"];
        if thin {
            allowed.push("aperture_radius");
        }
        let p = Params::of(el, &allowed, &["film", "sampler"])?;
        let (mut width, mut height) = (768u32, 576u32);
        let mut spp = 4u32;
        for k in &el.kids {
            match k.tag.as_str() {
                "film" => {
                    if k.attr("type") != Some("hdrfilm") {
                        return Err(unsupported(k, "film", "hdrfilm"));
                    }
                    let f = Params::of(
                        k,
                        &[
                            "width",
                            "height",
                            "pixel_format",
                            "component_format",
                            "file_format",
                            "banner",
                            "sample_border",
                        ],
                        &["rfilter"],
                    )?;
                    let dim = |name: &str, d: u32| -> Result<u32> {
                        match f.num(name)? {
                            None => Ok(d),
                            Some(x) if x >= 1.0 && x.fract() == 0.0 && x <= u32::MAX as f64 => Ok(x as u32),
                            Some(x) => Err(k.loc.err(format!("<film>: `{name}` = {x} is not a positive integer"))),
                        }
                    };
                    (width, height) = (dim("width", width)?, dim("height", height)?);
                    if k.kids.iter().any(|r| r.tag == "rfilter" && r.attr("type") != Some("box")) {
                        self.note("the film's reconstruction filter is replaced by a box filter (a sample counts only in its own pixel)".into());
                    }
                    self.place("render".into(), k);
                }
                "sampler" => {
                    let s = Params::of(k, &["sample_count", "seed", "jitter", "scramble", "dimension"], &[])?;
                    if let Some(n) = s.num("sample_count")? {
                        if !(n >= 1.0 && n.fract() == 0.0 && n <= u32::MAX as f64) {
                            return Err(k.loc.err(format!("<sampler>: sample_count {n} is not a positive integer")));
                        }
                        spp = n as u32;
                    }
                    self.place("render.aa".into(), k);
                }
                _ => {}
            }
        }
        let aspect = width as f64 / height as f64;
        let fov_x = match (p.num("fov")?, p.get("focal_length")?) {
            (Some(_), Some((_, k))) => return Err(k.loc.err("<sensor>: give `fov` or `focal_length`, not both")),
            (Some(fov), None) => {
                let axis = p.string("fov_axis")?.map_or("x".to_string(), |(s, _)| s);
                fov_to_x(fov, &axis, aspect).map_err(|e| el.loc.err(format!("{}: {e}", el.what())))?
            }
            (None, f) => {
                let mm = match f {
                    None => 50.0,
                    Some((Value::Num(x), _)) => x,
                    Some((Value::Str(s), k)) => s
                        .trim()
                        .trim_end_matches("mm")
                        .parse::<f64>()
                        .map_err(|_| k.loc.err(format!("<sensor>: focal_length `{s}` is not <number>mm")))?,
                    Some((_, k)) => return Err(k.loc.err("<sensor>: focal_length must be a string such as \"50mm\"")),
                };
                if mm.is_nan() || mm <= 0.0 {
                    return Err(el.loc.err(format!("{}: focal_length {mm} must be > 0", el.what())));
                }
                fov_to_x(focal_length_to_fov(mm), "diagonal", aspect).map_err(|e| el.loc.err(e))?
            }
        };
        let fov_y = x_to_fov_y(fov_x, aspect);
        let ops = p.transform("to_world")?;
        let t = compose(el, &ops)?;
        let l = glam::DMat3::from_mat4(t.m);
        let scaled = (0..3).any(|i| (l.col(i).length() - 1.0).abs() > 1e-4);
        if scaled {
            return Err(el.loc.err(format!(
                "{}: the camera's to_world scales (Mitsuba refuses scale factors in a camera transform too)",
                el.what()
            )));
        }
        let cam = &mut self.out.file.camera;
        cam.transform = Some(ops);
        cam.fov_y = fov_y as f32;
        if thin {
            cam.aperture = p.num("aperture_radius")?.unwrap_or(0.0) as f32;
            cam.focus_distance = Some(p.num("focus_distance")?.unwrap_or(0.0) as f32);
            if cam.focus_distance == Some(0.0) {
                return Err(el.loc.err(format!("{}: give a focus_distance > 0", el.what())));
            }
        }
        let r = &mut self.out.file.render;
        (r.width, r.height, r.aa.samples) = (width, height, spp);
        self.place("camera".into(), el);
        Ok(())
    }

    fn integrator(&mut self, el: &El) -> Result<()> {
        let depth = el.kids.iter().find(|k| k.attr("name") == Some("max_depth")).map(value).transpose()?;
        let ty = el.attr("type").unwrap_or("?");
        let d = match depth {
            Some(Value::Num(d)) => d,
            _ => -1.0,
        };
        self.out.file.render.max_depth = if d < 0.0 {
            self.note(format!(
                "integrator `{ty}`: unbounded max_depth; wavetrace traces at most 5 specular bounces (render.max_depth)"
            ));
            5
        } else {
            // Mitsuba counts the camera ray as a segment.
            (d as u32).saturating_sub(1)
        };
        self.note(format!(
            "integrator `{ty}` is read for max_depth only: wavetrace's transport is Whitted (direct light at diffuse \
             surfaces, perfect mirror and glass chains)"
        ));
        self.place("render.max_depth".into(), el);
        Ok(())
    }

    /// Converts a BSDF element to a material, returning its name.
    fn bsdf(&mut self, el: &El, id: Option<&str>) -> Result<String> {
        if el.tag == "ref" {
            let id = el.need("id")?;
            return self.named.get(id).cloned().ok_or_else(|| {
                el.loc.err(format!("<ref id=\"{id}\">: no <bsdf id=\"{id}\"> at the top level of the scene"))
            });
        }
        let name = match id {
            Some(id) => id.to_string(),
            None => format!("{}:{}:{}", el.loc.file, el.loc.line, el.loc.col),
        };
        let (desc, two_sided) = self.material(el)?;
        if !two_sided && matches!(desc, MaterialDesc::Diffuse { .. }) {
            self.note_one_sided(el);
        }
        self.out.file.materials.insert(name.clone(), desc);
        self.place(format!("materials.{name}"), el);
        Ok(name)
    }

    /// Notes once that Mitsuba's diffuse BSDF is one-sided.
    fn note_one_sided(&mut self, el: &El) {
        if !self.one_sided_noted {
            self.one_sided_noted = true;
            self.note(format!(
                "{}:{}: a diffuse BSDF without <bsdf type=\"twosided\"> (or a shape's default BSDF) is black from \
                 behind in Mitsuba; wavetrace's diffuse surfaces reflect on both sides",
                el.loc.file, el.loc.line
            ));
        }
    }

    fn material(&mut self, el: &El) -> Result<(MaterialDesc, bool)> {
        match el.attr("type").unwrap_or("") {
            "diffuse" => {
                let p = Params::of(el, &["reflectance"], &[])?;
                if let Some(t) = el.kids.iter().find(|k| k.tag == "texture") {
                    return Err(t.loc.err("<texture>: textures are not supported; give an <rgb> reflectance"));
                }
                let color = p.color("reflectance")?.unwrap_or([0.5; 3]);
                Ok((MaterialDesc::Diffuse { color: ColorDesc::Rgb(color), specular: [0.0; 3], shininess: 0.0 }, false))
            }
            "twosided" => {
                let inner: Vec<&El> = el.kids.iter().filter(|k| k.tag == "bsdf").collect();
                Params::of(el, &[], &["bsdf"])?;
                match inner[..] {
                    [b] => {
                        let (m, _) = self.material(b)?;
                        Ok((m, true))
                    }
                    _ => Err(el.loc.err(format!(
                        "<bsdf type=\"twosided\">: needs exactly one nested <bsdf> (two different sides are not supported); has {}",
                        inner.len()
                    ))),
                }
            }
            "conductor" => {
                let p = Params::of(el, &["material", "specular_reflectance"], &[])?;
                if let Some((m, k)) = p.string("material")? {
                    if m != "none" {
                        return Err(k.loc.err(format!(
                            "<bsdf type=\"conductor\">: material `{m}`: only material=\"none\" (a perfect mirror) is supported"
                        )));
                    }
                }
                let color = p.color("specular_reflectance")?.unwrap_or([1.0; 3]);
                Ok((MaterialDesc::Mirror { color }, false))
            }
            "dielectric" => {
                let p = Params::of(el, &["int_ior", "ext_ior", "specular_transmittance", "specular_reflectance"], &[])?;
                let ior = |name: &str, default: f32| -> Result<f32> {
                    match p.get(name)? {
                        None => Ok(default),
                        Some((Value::Num(x), _)) if x > 0.0 => Ok(x as f32),
                        Some((Value::Str(s), k)) => {
                            IORS.iter().find(|(n, _)| n.eq_ignore_ascii_case(s.trim())).map(|(_, v)| *v).ok_or_else(
                                || {
                                    let names: Vec<&str> = IORS.iter().map(|(n, _)| *n).collect();
                                    k.loc.err(format!(
                                        "<bsdf type=\"dielectric\">: unknown medium `{s}` (known: {})",
                                        names.join(", ")
                                    ))
                                },
                            )
                        }
                        Some((_, k)) => Err(k.loc.err(format!(
                            "<bsdf type=\"dielectric\">: `{name}` must be a number > 0 or a medium name"
                        ))),
                    }
                };
                let (int, ext) = (ior("int_ior", 1.5046)?, ior("ext_ior", 1.00028)?);
                if let Some(r) = p.color("specular_reflectance")? {
                    if r != [1.0; 3] {
                        let k = p.get("specular_reflectance")?.map(|(_, k)| k.loc.clone()).unwrap_or(el.loc.clone());
                        return Err(
                            k.err("<bsdf type=\"dielectric\">: specular_reflectance other than 1 is not supported")
                        );
                    }
                }
                let color = p.color("specular_transmittance")?.unwrap_or([1.0; 3]);
                Ok((
                    MaterialDesc::Dielectric {
                        ior: int / ext,
                        reflect_ratio: None,
                        color,
                        distribution: None,
                        alpha: None,
                        alpha_u: None,
                        alpha_v: None,
                    },
                    false,
                ))
            }
            _ => Err(unsupported(el, "bsdf", BSDFS)),
        }
    }

    /// The material of a shape: its nested or referenced BSDF, or Mitsuba's default (a
    /// diffuse of reflectance 0.5).
    fn shape_material(&mut self, el: &El) -> Result<String> {
        let bsdfs: Vec<&El> =
            el.kids.iter().filter(|k| k.tag == "bsdf" || (k.tag == "ref" && k.attr("name") != Some("shape"))).collect();
        match bsdfs[..] {
            [] => {
                self.note_one_sided(el);
                let name = "mitsuba-default-diffuse".to_string();
                if !self.out.file.materials.contains_key(&name) {
                    let d =
                        MaterialDesc::Diffuse { color: ColorDesc::Rgb([0.5; 3]), specular: [0.0; 3], shininess: 0.0 };
                    self.out.file.materials.insert(name.clone(), d);
                }
                Ok(name)
            }
            [b] => self.bsdf(b, b.attr("id")),
            _ => Err(el.loc.err(format!("{}: more than one BSDF", el.what()))),
        }
    }

    /// The radiance of a shape's area emitter, if it has one.
    fn area_emitter(&mut self, el: &El) -> Result<Option<[f32; 3]>> {
        let Some(e) = el.kids.iter().find(|k| k.tag == "emitter") else { return Ok(None) };
        if e.attr("type") != Some("area") {
            return Err(e.loc.err(format!("{} on a shape: only type=\"area\" emitters attach to shapes", e.what())));
        }
        let p = Params::of(e, &["radiance"], &[])?;
        let r = p.color("radiance")?.ok_or_else(|| e.loc.err("<emitter type=\"area\"> lacks `radiance`"))?;
        Ok(Some(r))
    }

    /// Converts a shape; `outer` are the transform steps of enclosing instances, applied
    /// after the shape's own.
    fn shape(&mut self, el: &El, outer: &[TransformOp]) -> Result<()> {
        let ty = el.need("type")?;
        let nested = ["bsdf", "ref", "emitter"];
        let idx = self.out.file.objects.len();
        match ty {
            "obj" | "ply" => {
                let p = Params::of(
                    el,
                    &["filename", "to_world", "face_normals", "flip_normals", "flip_tex_coords"],
                    &nested,
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
                    smooth,
                    emission,
                    flip_normals: p.boolean("flip_normals")?.unwrap_or(false),
                };
                self.out.file.objects.push(obj);
                self.place(format!("objects.{idx}"), el);
            }
            "rectangle" | "cube" => {
                let p = Params::of(el, &["to_world", "flip_normals"], &nested)?;
                let mut ops = p.transform("to_world")?;
                ops.extend_from_slice(outer);
                let t = compose(el, &ops)?;
                // Mitsuba's normal is the transformed +z normal (inverse transpose): a
                // mirroring transform turns u × v against it, so the edges swap.
                let swap = t.mirrors() ^ p.boolean("flip_normals")?.unwrap_or(false);
                let emission = self.area_emitter(el)?;
                let material = if emission.is_some() { String::new() } else { self.shape_material(el)? };
                let faces: &[([f32; 3], [f32; 3], [f32; 3])] =
                    if ty == "rectangle" { &[([-1.0, -1.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0])] } else { &CUBE };
                for &(corner, u, v) in faces {
                    let (edge_u, edge_v) = if swap { (v, u) } else { (u, v) };
                    let transform = Some(ops.clone());
                    if let Some(radiance) = emission {
                        let li = self.out.file.lights.len();
                        self.out.file.lights.push(LightDesc::Quad { corner, edge_u, edge_v, radiance, transform });
                        self.place(format!("lights.{li}"), el);
                    } else {
                        let i = self.out.file.objects.len();
                        let material = material.clone();
                        self.out.file.objects.push(ObjectDesc::Quad { corner, edge_u, edge_v, material, transform });
                        self.place(format!("objects.{i}"), el);
                    }
                }
            }
            "sphere" => {
                let p = Params::of(el, &["center", "radius", "to_world", "flip_normals"], &nested)?;
                if self.area_emitter(el)?.is_some() {
                    return Err(el.loc.err(
                        "<shape type=\"sphere\"> with an area emitter: wavetrace lights are planar (rectangle, cube, or mesh triangles)",
                    ));
                }
                if p.boolean("flip_normals")? == Some(true) {
                    return Err(el.loc.err("<shape type=\"sphere\">: flip_normals is not supported"));
                }
                let mut ops = p.transform("to_world")?;
                ops.extend_from_slice(outer);
                let t = compose(el, &ops)?;
                if t.uniform_scale().is_none() {
                    return Err(el.loc.err(
                        "<shape type=\"sphere\">: to_world must be a uniform scale with rotations and translations",
                    ));
                }
                let material = self.shape_material(el)?;
                let center = p.point("center")?.unwrap_or([0.0; 3]);
                let radius = p.num("radius")?.unwrap_or(1.0) as f32;
                let transform = (!ops.is_empty()).then_some(ops);
                self.out.file.objects.push(ObjectDesc::Sphere { center, radius, material, transform });
                self.place(format!("objects.{idx}"), el);
            }
            "instance" => {
                let p = Params::of(el, &["to_world"], &["ref"])?;
                let r = el
                    .kids
                    .iter()
                    .find(|k| k.tag == "ref")
                    .ok_or_else(|| el.loc.err("<shape type=\"instance\"> lacks a <ref id=...> to a shapegroup"))?;
                let id = r.need("id")?;
                let group = self.groups.get(id).cloned().ok_or_else(|| {
                    r.loc.err(format!("<ref id=\"{id}\">: no <shape type=\"shapegroup\" id=\"{id}\">"))
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
            }
            "shapegroup" => return Err(el.loc.err("<shape type=\"shapegroup\"> must be at the top level with an id")),
            _ => return Err(unsupported(el, "shape", SHAPES)),
        }
        Ok(())
    }

    fn emitter(&mut self, el: &El) -> Result<()> {
        match el.attr("type").unwrap_or("") {
            "point" => {
                let p = Params::of(el, &["intensity", "position", "to_world"], &[])?;
                let intensity = p.color("intensity")?.unwrap_or([1.0; 3]);
                let ops = p.transform("to_world")?;
                let t = compose(el, &ops)?;
                let local = p.point("position")?.unwrap_or([0.0; 3]);
                let position = t.point(glam::Vec3::from_array(local)).to_array();
                let li = self.out.file.lights.len();
                self.out.file.lights.push(LightDesc::Point { position, intensity });
                self.place(format!("lights.{li}"), el);
            }
            "constant" => {
                let p = Params::of(el, &["radiance"], &[])?;
                let r = p.color("radiance")?.unwrap_or([1.0; 3]);
                self.out.file.background.color = r;
                self.place("background".into(), el);
                self.note(format!(
                    "{}:{}: <emitter type=\"constant\"> becomes the background colour: rays that escape see it, but \
                     unlike in Mitsuba it lights nothing",
                    el.loc.file, el.loc.line
                ));
            }
            "area" => return Err(el.loc.err("<emitter type=\"area\"> must be inside a <shape>")),
            _ => return Err(unsupported(el, "emitter", EMITTERS)),
        }
        Ok(())
    }
}

/// A cube's faces [-1, 1]³ as (corner, u, v), u × v outwards (Mitsuba's cube).
const CUBE: [([f32; 3], [f32; 3], [f32; 3]); 6] = [
    ([1.0, -1.0, -1.0], [0.0, 2.0, 0.0], [0.0, 0.0, 2.0]),
    ([-1.0, -1.0, -1.0], [0.0, 0.0, 2.0], [0.0, 2.0, 0.0]),
    ([-1.0, 1.0, -1.0], [0.0, 0.0, 2.0], [2.0, 0.0, 0.0]),
    ([-1.0, -1.0, -1.0], [2.0, 0.0, 0.0], [0.0, 0.0, 2.0]),
    ([-1.0, -1.0, 1.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]),
    ([-1.0, -1.0, -1.0], [0.0, 2.0, 0.0], [2.0, 0.0, 0.0]),
];

/// The diagonal field of view (degrees) of a lens of focal length `mm` on Mitsuba's
/// 36 × 24 mm film.
pub fn focal_length_to_fov(mm: f64) -> f64 {
    2.0 * ((36.0f64 * 36.0 + 24.0 * 24.0).sqrt() / (2.0 * mm)).atan().to_degrees()
}

/// Mitsuba's `parse_fov`: the horizontal field of view (degrees) of `fov` measured along
/// `axis` (x, y, diagonal, smaller, larger) for an image of aspect `w / h`.
pub fn fov_to_x(fov: f64, axis: &str, aspect: f64) -> std::result::Result<f64, String> {
    let axis = match axis {
        "smaller" => {
            if aspect > 1.0 {
                "y"
            } else {
                "x"
            }
        }
        "larger" => {
            if aspect > 1.0 {
                "x"
            } else {
                "y"
            }
        }
        a => a,
    };
    let half = |a: f64| (0.5 * a).to_radians().tan();
    let x = match axis {
        "x" => fov,
        "y" => (2.0 * (half(fov) * aspect).atan()).to_degrees(),
        "diagonal" => {
            let width = 2.0 * half(fov) / (1.0 + 1.0 / (aspect * aspect)).sqrt();
            (2.0 * (0.5 * width).atan()).to_degrees()
        }
        other => return Err(format!("fov_axis `{other}` is not x, y, diagonal, smaller or larger")),
    };
    if !(x > 0.0 && x < 180.0) {
        return Err(format!("the horizontal field of view {x}° is not in (0, 180)"));
    }
    Ok(x)
}

/// The vertical field of view (degrees) of a horizontal one for aspect `w / h`.
pub fn x_to_fov_y(fov_x: f64, aspect: f64) -> f64 {
    (2.0 * ((0.5 * fov_x).to_radians().tan() / aspect).atan()).to_degrees()
}
