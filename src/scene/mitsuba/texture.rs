//! Textures in a colour's place: `bitmap` (an image file) and `checkerboard`.

use super::xml::{self, El};
use super::{unsupported, Converter, Params, TEXTURES};
use crate::scene::format::*;
use crate::Result;

/// Mitsuba's bitmap wrap modes (it compares them case-sensitively).
const WRAP_MODES: [&str; 3] = ["repeat", "mirror", "clamp"];
/// Mitsuba's bitmap filters.
const FILTERS: [&str; 2] = ["bilinear", "nearest"];

impl Converter<'_> {
    /// A `<texture>` element as a texture description, once per id.
    pub(super) fn texture(&mut self, t: &El) -> Result<TextureDesc> {
        let id = t.attr("id");
        if let Some(done) = id.and_then(|id| self.textures.get(id)) {
            // A failed texture has reported its error already; any value stands in.
            return Ok(done.clone().unwrap_or(TextureDesc::Checkerboard {
                color0: [0.0; 3],
                color1: [0.0; 3],
                to_uv: None,
            }));
        }
        let r = match t.attr("type").unwrap_or("") {
            "bitmap" => self.bitmap(t),
            "checkerboard" => checkerboard(t),
            _ => Err(unsupported(t, "texture", TEXTURES)),
        };
        if let Some(id) = id {
            self.textures.insert(id.to_string(), r.as_ref().ok().cloned());
        }
        r
    }

    /// `bitmap`: the file found as meshes are (the including file's folder, then the
    /// `<path>` folders) and given to the loader as an absolute path.
    fn bitmap(&mut self, t: &El) -> Result<TextureDesc> {
        let p = Params::of(t, &["filename", "raw", "filter_type", "wrap_mode", "to_uv"], &[])?;
        let (file, fel) = p.string("filename")?.ok_or_else(|| t.loc.err(format!("{}: lacks `filename`", t.what())))?;
        let path = xml::resolve(&file, &t.dir, &self.search, &fel.loc)?;
        // Absolute, so that it does not depend on the folder the loader starts from.
        let path = std::fs::canonicalize(&path).unwrap_or(path);
        Ok(TextureDesc::Bitmap {
            file: path.display().to_string(),
            raw: p.boolean("raw")?.unwrap_or(false),
            wrap: choice(&p, "wrap_mode", &WRAP_MODES)?,
            filter: choice(&p, "filter_type", &FILTERS)?,
            to_uv: to_uv(&p)?,
        })
    }
}

/// `checkerboard`: two colours (Mitsuba's defaults 0.4 and 0.2) on the unit UV square.
fn checkerboard(t: &El) -> Result<TextureDesc> {
    let p = Params::of(t, &["color0", "color1", "to_uv"], &[])?;
    Ok(TextureDesc::Checkerboard {
        color0: p.color("color0")?.unwrap_or([0.4; 3]),
        color1: p.color("color1")?.unwrap_or([0.2; 3]),
        to_uv: to_uv(&p)?,
    })
}

/// The `to_uv` transform's steps, none when absent or empty (the identity either way).
fn to_uv(p: &Params) -> Result<Option<Vec<TransformOp>>> {
    let ops = p.transform("to_uv")?;
    Ok((!ops.is_empty()).then_some(ops))
}

/// A string parameter that must be one of `options`, as Mitsuba checks it.
fn choice(p: &Params, name: &str, options: &[&str]) -> Result<Option<String>> {
    match p.string(name)? {
        Some((v, k)) if !options.contains(&v.as_str()) => Err(k.loc.err(format!(
            "{}: {name} `{v}` is not one of {} (Mitsuba's values)",
            p.el.what(),
            options.join(", ")
        ))),
        v => Ok(v.map(|(v, _)| v)),
    }
}
