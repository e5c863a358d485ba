//! Mitsuba 3 XML scenes: [`xml`] reads the files (includes, defaults, values) and this
//! module maps the supported plugins onto wavetrace's own scene description
//! ([`SceneFile`]), so an imported scene goes through the same validation, `--set`
//! overrides and rendering as a TOML one. Anything outside the subset is an error that
//! names the file, line, column, the plugin and what is supported (docs/import.md).
//!
//! One file per kind of plugin: `sensor` (camera, film, sampler, integrator), `shape`
//! (shapes and emitters), `bsdf` (materials), `texture` (textured colours); this file
//! holds the two passes over the scene, `<ref>` resolution and parameter reading.

mod bsdf;
mod sensor;
mod shape;
mod texture;
pub mod xml;

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

use super::format::*;
use super::transform::Transform;
use crate::Result;
use xml::{value, El, Loc, Value};

pub use sensor::{focal_length_to_fov, fov_to_x, x_to_fov_y};

/// Shape types imported.
pub const SHAPES: &str = "obj, ply, rectangle, cube, sphere, shapegroup, instance";
/// BSDF types imported.
pub const BSDFS: &str =
    "diffuse, twosided, conductor, roughconductor, dielectric, roughdielectric, thindielectric, plastic, roughplastic";
/// Texture types imported.
pub const TEXTURES: &str = "bitmap, checkerboard (as a diffuse `reflectance`, a plastic's `diffuse_reflectance` or a \
                             conductor's `specular_reflectance`)";
/// Emitter types imported.
pub const EMITTERS: &str = "area (on a rectangle, cube, sphere, obj or ply), point, directional, constant, envmap";
/// Sensor types imported.
pub const SENSORS: &str = "perspective, thinlens";

/// A scene read from Mitsuba XML.
pub struct Imported {
    /// The scene in wavetrace's terms.
    pub file: SceneFile,
    /// Where each part came from: dotted field prefix (`objects.3`, `materials.wall`,
    /// `camera`) → element position, for the messages of later validation.
    pub places: Vec<(String, Loc)>,
    /// What was read but differs from Mitsuba, or was ignored (printed as notes).
    pub notes: Vec<String>,
    /// The files `<include>`d, as read: inputs that no output may overwrite.
    pub includes: Vec<std::path::PathBuf>,
}

/// Reads a Mitsuba XML scene with `-D name=value` parameters.
pub fn import(path: &Path, defines: &[(String, String)]) -> Result<Imported> {
    let xml::Tree { root, search, includes } = xml::read(path, defines)?;
    let mut c = Converter::new(search, &root);
    c.out.includes = includes;
    // Every top-level element is converted even after one fails, and the failures are
    // reported together: a scene with five unsupported plugins takes one run to list
    // them, not five edit-and-rerun rounds. Each element reports its first problem.
    let mut errors = Vec::new();
    // Declarations first (named BSDFs, textures, area emitters, shape groups), so each
    // reports its own problem once, at its own place, before any reference to it.
    for el in &root.kids {
        if let Err(e) = c.declaration(el) {
            errors.push(e);
        }
    }
    for el in &root.kids {
        if let Err(e) = c.top_level(el) {
            errors.push(e);
        }
    }
    if !errors.is_empty() {
        return Err(collected(errors));
    }
    if !c.sensor {
        return Err(root.loc.err("the scene has no <sensor>"));
    }
    if !root.kids.iter().any(|k| k.tag == "integrator") {
        c.default_integrator();
    }
    c.note_unreferenced(&root);
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

/// The conversion's state; `'a` is the element tree's lifetime.
struct Converter<'a> {
    search: Vec<std::path::PathBuf>,
    out: Imported,
    /// Every element with an `id`, in any file and at any depth: what a `<ref id>` names,
    /// whether it comes before or after the reference (Mitsuba resolves both).
    decls: BTreeMap<&'a str, &'a El>,
    /// Ids some `<ref>` named (a declared texture or area emitter that none names gets a
    /// note).
    used: BTreeSet<String>,
    /// BSDF id → material name (each BSDF converts once).
    named: BTreeMap<String, String>,
    /// Texture id → its description; `None` when it failed (its error is reported once).
    textures: BTreeMap<String, Option<TextureDesc>>,
    /// Area emitter id → its radiance; `None` when it failed.
    emitters: BTreeMap<String, Option<[f32; 3]>>,
    /// Area emitter id → the shape it is attached to (Mitsuba allows one).
    emitter_shapes: BTreeMap<String, Loc>,
    /// Twosided BSDFs being converted, one inside the other (references can loop).
    twosided_depth: usize,
    sensor: bool,
    /// A `constant` or `envmap` emitter has been read (one is taken).
    environment_seen: bool,
}

/// Every element with an `id` below `el` (a `<ref id>` or `<alias id>` names one; it
/// defines none). The reader has refused duplicates.
fn collect_ids<'a>(el: &'a El, out: &mut BTreeMap<&'a str, &'a El>) {
    for k in &el.kids {
        if let Some(id) = k.attr("id").filter(|_| k.tag != "ref" && k.tag != "alias") {
            out.insert(id, k);
        }
        collect_ids(k, out);
    }
}

impl<'a> Converter<'a> {
    fn new(search: Vec<std::path::PathBuf>, root: &'a El) -> Converter<'a> {
        let mut decls = BTreeMap::new();
        collect_ids(root, &mut decls);
        Converter {
            search,
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
                        shutter: [0.0, 0.0],
                        transform_end: None,
                    },
                    background: BackgroundDesc::default(),
                    materials: BTreeMap::new(),
                    lights: Vec::new(),
                    objects: Vec::new(),
                },
                places: Vec::new(),
                notes: Vec::new(),
                includes: Vec::new(),
            },
            decls,
            used: BTreeSet::new(),
            named: BTreeMap::new(),
            textures: BTreeMap::new(),
            emitters: BTreeMap::new(),
            emitter_shapes: BTreeMap::new(),
            twosided_depth: 0,
            sensor: false,
            environment_seen: false,
        }
    }

    /// First pass over a top-level element: converts the named BSDFs, textures and area
    /// emitters (a failed one still answers its references, which then add no second,
    /// misleading error) and checks that shape groups have ids.
    fn declaration(&mut self, el: &El) -> Result<()> {
        match el.tag.as_str() {
            "bsdf" => {
                el.need("id")?;
                self.bsdf(el).map(|_| ())
            }
            "texture" if el.attr("id").is_some() => self.texture(el).map(|_| ()),
            "emitter" if el.attr("type") == Some("area") => {
                let Some(id) = el.attr("id") else { return Ok(()) };
                if self.emitters.contains_key(id) {
                    return Ok(());
                }
                let r = self.area_radiance(el);
                self.emitters.insert(id.to_string(), r.as_ref().ok().copied());
                r.map(|_| ())
            }
            "shape" if el.attr("type") == Some("shapegroup") => el.need("id").map(|_| ()),
            _ => Ok(()),
        }
    }

    /// Second pass over a top-level element: everything but the declarations.
    fn top_level(&mut self, el: &El) -> Result<()> {
        match el.tag.as_str() {
            "bsdf" => Ok(()),
            "shape" if el.attr("type") == Some("shapegroup") => Ok(()),
            "texture" if el.attr("id").is_some() => Ok(()),
            "texture" => Err(el.loc.err(format!(
                "{}: a texture at the top level needs an id (a BSDF's <ref name=\"reflectance\" id=...> names it)",
                el.what()
            ))),
            "sensor" => self.sensor(el),
            "shape" => self.shape(el, &[]),
            "emitter" => self.emitter(el),
            "integrator" => self.integrator(el),
            "medium" | "volume" | "phase" | "film" | "sampler" | "rfilter" => Err(el.loc.err(format!(
                "{}: not supported at the top level (media and volumes are outside the imported subset)",
                el.what()
            ))),
            other => Err(el.loc.err(format!(
                "<{other}>: unknown element; expected sensor, shape, bsdf, texture, emitter, integrator, default, \
                 include or path"
            ))),
        }
    }

    /// The element a `<ref id>` names, wherever it is declared (before or after, in any
    /// file), if `fits` accepts it. `needs` says what fits here, for the messages, which
    /// name the reference's place and, for a wrong kind, the declaration's.
    fn referenced(&mut self, r: &El, needs: &str, fits: impl Fn(&El) -> bool) -> Result<&'a El> {
        let id = r.need("id")?;
        let Some(&d) = self.decls.get(id) else {
            return Err(r.loc.err(format!("<ref id=\"{id}\">: no element has id \"{id}\" ({needs})")));
        };
        if !fits(d) {
            return Err(r.loc.err(format!(
                "<ref id=\"{id}\">: \"{id}\" is the {} declared at {}:{}:{}, and {needs}",
                d.what(),
                d.loc.file,
                d.loc.line,
                d.loc.col
            )));
        }
        self.used.insert(id.to_string());
        Ok(d)
    }

    /// Notes the top-level textures and area emitters that no `<ref>` names: Mitsuba
    /// loads them and uses them nowhere, and so does this.
    fn note_unreferenced(&mut self, root: &El) {
        for el in &root.kids {
            let declared = el.tag == "texture" || (el.tag == "emitter" && el.attr("type") == Some("area"));
            match el.attr("id") {
                Some(id) if declared && !self.used.contains(id) => self.note(format!(
                    "{}:{}: {} id=\"{id}\" is named by no <ref>: it is unused (as in Mitsuba)",
                    el.loc.file,
                    el.loc.line,
                    el.what()
                )),
                _ => {}
            }
        }
    }

    fn place(&mut self, path: String, el: &El) {
        self.out.places.push((path, el.loc.clone()));
    }

    fn note(&mut self, msg: String) {
        if !self.out.notes.contains(&msg) {
            self.out.notes.push(msg);
        }
    }
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
