//! The values every scene loader shares (as psychopath's `parse/basics` or Mitsuba's
//! `Properties`): where a scene's text came from, error context that turns a dotted field
//! path into the file, line and column (or the `--set` flag, or the imported element) a
//! message names, and the checked values (coordinates within [`MAX_COORD`], colours,
//! parallelogram edges, transforms, finite numbers). A leaf: the TOML loader (`load/`) and
//! the Mitsuba importer (`mitsuba/`) use it, and it uses neither.

use glam::Vec3;
use std::path::{Path, PathBuf};
use std::rc::Rc;

use super::format::TransformOp;
use super::text::{line_col, read_text};
use super::transform::Transform;
use crate::{Error, Result};

/// Most bounces a scene may ask for (`render.max_depth`): each bounce level keeps a queue.
pub const MAX_DEPTH: u32 = 64;

/// Largest coordinate, edge or radius magnitude: the squared length of a cross product of
/// two edges, (4e9)⁴ = 2.6e38, must stay below f32::MAX (3.4e38), or normals and
/// directions turn to NaN.
pub const MAX_COORD: f32 = 4e9;

/// True when every component is finite and within ±MAX_COORD.
pub(super) fn in_range(v: Vec3) -> bool {
    v.is_finite() && v.abs().max_element() <= MAX_COORD
}

/// Where an element of an imported file starts.
#[derive(Clone, Debug)]
pub struct Loc {
    /// File, as named in messages.
    pub file: Rc<String>,
    /// 1-based line.
    pub line: u32,
    /// 1-based column.
    pub col: u32,
}

impl Loc {
    /// A bad-input error at this place.
    pub fn err(&self, msg: impl std::fmt::Display) -> Error {
        Error::input(format!("{}:{}:{}: {msg}", self.file, self.line, self.col))
    }
}

/// Where a scene's text came from: mesh paths are relative to `dir`.
#[derive(Clone, Debug)]
pub struct SceneSource {
    /// Name used in messages (the file path, or `<default scene>`).
    pub name: String,
    /// The TOML text.
    pub text: String,
    /// Folder that relative mesh paths start from.
    pub dir: PathBuf,
    /// A Mitsuba XML scene to import (by the file's `.xml` extension) instead of `text`.
    pub xml: Option<PathBuf>,
    /// `-D name=value` parameters of a Mitsuba XML scene.
    pub defines: Vec<(String, String)>,
}

impl SceneSource {
    /// Reads a scene file.
    pub fn from_file(path: &Path) -> Result<SceneSource> {
        let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("xml")) {
            let name = path.display().to_string();
            return Ok(SceneSource { name, text: String::new(), dir, xml: Some(path.into()), defines: Vec::new() });
        }
        let text = read_text(path)?;
        Ok(SceneSource { name: path.display().to_string(), text, dir, xml: None, defines: Vec::new() })
    }

    /// The embedded default scene.
    pub fn default_scene() -> SceneSource {
        SceneSource {
            name: "<default scene>".into(),
            text: super::DEFAULT_SCENE.into(),
            dir: PathBuf::from("."),
            xml: None,
            defines: Vec::new(),
        }
    }

    /// A scene given as text, with meshes relative to `dir`.
    pub fn from_text(name: &str, text: &str, dir: &Path) -> SceneSource {
        SceneSource { name: name.into(), text: text.into(), dir: dir.into(), xml: None, defines: Vec::new() }
    }
}

/// Error context: maps a dotted field path back to the file position or `--set` flag.
pub(super) struct Ctx<'a> {
    /// The scene's text and where it came from.
    pub(super) src: &'a SceneSource,
    /// The TOML text's document with its spans, parsed on the first error that needs a
    /// position (most loads meet none, and the parse costs what the load's own does).
    doc: std::sync::OnceLock<Option<toml_edit::ImDocument<&'a str>>>,
    /// Whether `src.text` is the scene's TOML (an imported scene's positions are in `places`).
    toml: bool,
    /// The `--set KEY=VALUE` overrides, in order.
    pub(super) sets: &'a [String],
    /// For an imported scene: field prefix → the element it came from.
    places: &'a [(String, Loc)],
}

impl<'a> Ctx<'a> {
    /// The context of `src` (`toml`: its text is the scene's TOML, whose positions errors
    /// give), with its `--set` overrides and, for an imported scene, each field prefix's
    /// element.
    pub(super) fn new(src: &'a SceneSource, toml: bool, sets: &'a [String], places: &'a [(String, Loc)]) -> Ctx<'a> {
        Ctx { src, doc: std::sync::OnceLock::new(), toml, sets, places }
    }

    /// The TOML document, parsed on first use; `None` for an imported scene or a text
    /// that does not parse.
    fn doc(&self) -> Option<&toml_edit::ImDocument<&'a str>> {
        let text: &'a str = self.src.text.as_str();
        self.doc.get_or_init(|| self.toml.then(|| toml_edit::ImDocument::parse(text).ok()).flatten()).as_ref()
    }

    /// A bad-input error about field `path`, placed at the `--set` that gave it, the
    /// imported element it came from, or its line and column in the file.
    pub(super) fn fail(&self, path: &str, msg: impl std::fmt::Display) -> Error {
        if let Some(set) = self.sets.iter().find(|s| {
            let key = s.split('=').next().unwrap_or("");
            key == path || path.starts_with(&format!("{key}.")) || key.starts_with(&format!("{path}."))
        }) {
            return Error::input(format!("{} (--set {set}): field `{path}`: {msg}", self.src.name));
        }
        // An imported scene: the element the field came from (the longest prefix).
        let place = self
            .places
            .iter()
            .filter(|(p, _)| path == p || path.starts_with(&format!("{p}.")))
            .max_by_key(|(p, _)| p.len());
        if let Some((_, loc)) = place {
            return Error::at(&loc.file, Some((loc.line as usize, loc.col as usize)), path, msg);
        }
        Error::at(&self.src.name, self.locate(path), path, msg)
    }

    fn locate(&self, path: &str) -> Option<(usize, usize)> {
        let doc = self.doc()?;
        let mut item = doc.as_item();
        let mut span = None;
        for seg in path.split('.') {
            let next = match seg.parse::<usize>() {
                Ok(i) => item.get(i),
                Err(_) => item.get(seg),
            };
            match next {
                Some(it) => {
                    item = it;
                    span = it.span().or(span);
                }
                None => break,
            }
        }
        span.map(|s| line_col(&self.src.text, s.start))
    }

    /// The dotted path of the innermost value in the file whose text holds byte `offset`:
    /// the field a serde error (an unknown `mode`, a string for a number) points at.
    /// `None` when the offset is outside every value (a table header, a key).
    pub(super) fn field_at(&self, offset: usize) -> Option<String> {
        fn in_value(v: &toml_edit::Value, offset: usize, path: &mut Vec<String>) -> Option<String> {
            if !v.span()?.contains(&offset) {
                return None;
            }
            let inner = match v {
                toml_edit::Value::Array(a) => a.iter().enumerate().find_map(|(i, e)| {
                    path.push(i.to_string());
                    let found = in_value(e, offset, path);
                    path.pop();
                    found
                }),
                toml_edit::Value::InlineTable(t) => t.iter().find_map(|(k, e)| {
                    path.push(k.to_string());
                    let found = in_value(e, offset, path);
                    path.pop();
                    found
                }),
                _ => None,
            };
            inner.or_else(|| Some(path.join(".")))
        }
        fn in_table(t: &toml_edit::Table, offset: usize, path: &mut Vec<String>) -> Option<String> {
            t.iter().find_map(|(k, item)| {
                path.push(k.to_string());
                let found = match item {
                    toml_edit::Item::Value(v) => in_value(v, offset, path),
                    toml_edit::Item::Table(t) => in_table(t, offset, path),
                    toml_edit::Item::ArrayOfTables(a) => a.iter().enumerate().find_map(|(i, t)| {
                        path.push(i.to_string());
                        let found = in_table(t, offset, path);
                        path.pop();
                        found
                    }),
                    toml_edit::Item::None => None,
                };
                path.pop();
                found
            })
        }
        in_table(self.doc()?.as_table(), offset, &mut Vec::new())
    }
}

/// Refuses a non-finite number (or one beyond f32's range) anywhere in `v`, naming its
/// field.
pub(super) fn check_finite(v: &toml::Value, path: &str, ctx: &Ctx) -> Result<()> {
    let join = |k: &str| if path.is_empty() { k.to_string() } else { format!("{path}.{k}") };
    match v {
        toml::Value::Float(f) if !f.is_finite() || f.abs() > f32::MAX as f64 => {
            Err(ctx.fail(path, format!("{f} is not a finite number")))
        }
        toml::Value::Table(t) => t.iter().try_for_each(|(k, v)| check_finite(v, &join(k), ctx)),
        toml::Value::Array(a) => {
            a.iter().enumerate().try_for_each(|(i, v)| check_finite(v, &join(&i.to_string()), ctx))
        }
        _ => Ok(()),
    }
}

/// A `transform` list composed; errors name the step.
pub(super) fn transform(ctx: &Ctx, path: &str, ops: &[TransformOp]) -> Result<Transform> {
    Transform::from_ops(ops).map_err(|(i, e)| ctx.fail(&format!("{path}.{i}"), e))
}

/// A TOML triple as a vector.
pub(super) fn vec3(a: [f32; 3]) -> Vec3 {
    Vec3::from_array(a)
}

/// A colour: every component at least 0.
pub(super) fn color(ctx: &Ctx, path: &str, c: [f32; 3]) -> Result<Vec3> {
    if c.iter().any(|&x| x < 0.0) {
        return Err(ctx.fail(path, "components must be >= 0"));
    }
    Ok(vec3(c))
}

/// A position or extent, refused beyond ±MAX_COORD.
pub(super) fn coord(ctx: &Ctx, path: &str, v: Vec3) -> Result<Vec3> {
    if in_range(v) {
        Ok(v)
    } else {
        Err(ctx.fail(path, format!("beyond ±{MAX_COORD:e} scene units")))
    }
}

/// A parallelogram's edges `{path}.edge_u` and `{path}.edge_v`: within ±MAX_COORD, not
/// zero, not parallel.
pub(super) fn edges(ctx: &Ctx, path: &str, u: [f32; 3], v: [f32; 3]) -> Result<(Vec3, Vec3)> {
    let u = coord(ctx, &format!("{path}.edge_u"), vec3(u))?;
    let v = coord(ctx, &format!("{path}.edge_v"), vec3(v))?;
    if u.length_squared() == 0.0 {
        return Err(ctx.fail(&format!("{path}.edge_u"), "zero-length edge"));
    }
    if v.length_squared() == 0.0 {
        return Err(ctx.fail(&format!("{path}.edge_v"), "zero-length edge"));
    }
    let n = u.cross(v);
    if n.length() <= 1e-12 * u.length() * v.length() || !n.is_finite() {
        return Err(ctx.fail(&format!("{path}.edge_v"), "edges are parallel: the parallelogram has zero area"));
    }
    Ok((u, v))
}
