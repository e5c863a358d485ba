//! The checks a sweep makes before its first render: the params, every point's settings,
//! and where the reference comes from with its size, so a bad value costs no render time.

use std::path::{Path, PathBuf};

use super::{cross_product, describe, fnv1a64, overrides, reference_overrides, Reference, SweepOptions};
use crate::film::Image;
use crate::scene::{load, SceneSource, Settings};
use crate::tools::compare::load_linear;
use crate::{Error, Result};

/// Rejects a key given twice and a key without values, before the scene is read.
fn check_params(params: &[(String, Vec<String>)]) -> Result<()> {
    let mut seen = std::collections::HashSet::new();
    for (key, values) in params {
        if !seen.insert(key.as_str()) {
            return Err(Error::input(format!("--param `{key}` is given twice")));
        }
        if values.is_empty() {
            return Err(Error::input(format!("--param `{key}` has no values")));
        }
    }
    Ok(())
}

/// Loads every point's settings. A failing point is retried one assignment at a time so
/// the message can name the value that is wrong by itself.
fn load_points(src: &SceneSource, sets: &[String], points: &[Vec<(String, String)>]) -> Result<Vec<Settings>> {
    let mut settings = Vec::with_capacity(points.len());
    for point in points {
        match load(src, &overrides(sets, point)) {
            Ok(scene) => settings.push(scene.settings),
            Err(e) => {
                let culprit = point.iter().find(|a| load(src, &overrides(sets, std::slice::from_ref(a))).is_err());
                return Err(match culprit {
                    Some((k, v)) => Error::input(format!("--param {k}={v}: {e}")),
                    None => Error::input(format!("sweep point {}: {e}", describe(point))),
                });
            }
        }
    }
    Ok(settings)
}

/// The cache file of a rendered reference in `out_dir`: named by a hash of everything
/// that determines it (version, scene text and folder, sets, reference overrides), so
/// the sweep and the study share a cached reference of the same scene and settings. An
/// imported XML scene has no TOML text: its path, its bytes and its `-D` defines stand in
/// (the files it includes are not read; without them every XML scene of a folder shared
/// one cache file).
pub(crate) fn reference_cache_path(
    out_dir: &Path,
    src: &SceneSource,
    sets: &[String],
    ref_overrides: &[String],
) -> PathBuf {
    let mut key = format!("wavetrace sweep reference\0{}\0", env!("CARGO_PKG_VERSION")).into_bytes();
    if let Some(xml) = &src.xml {
        key.extend_from_slice(xml.display().to_string().as_bytes());
        key.push(0);
        key.extend(std::fs::read(xml).unwrap_or_default());
        key.push(0);
        for (k, v) in &src.defines {
            key.extend_from_slice(format!("{k}={v}").as_bytes());
            key.push(0);
        }
    }
    for part in [src.text.as_str(), &src.dir.display().to_string()]
        .into_iter()
        .chain(sets.iter().map(String::as_str))
        .chain(ref_overrides.iter().map(String::as_str))
    {
        key.extend_from_slice(part.as_bytes());
        key.push(0);
    }
    out_dir.join(format!("reference-{:016x}.exr", fnv1a64(&key)))
}

/// The cached reference at `path` when it can be read back and is `size`; `None` (render
/// it anew) otherwise.
pub(crate) fn cached_reference(path: &Path, size: (u32, u32)) -> Option<Image> {
    if !path.is_file() {
        return None;
    }
    load_linear(path).ok().filter(|i| (i.width, i.height) == size)
}

/// A sweep whose every point has loaded: what the later steps render from.
pub(super) struct Plan<'a> {
    /// What was asked.
    pub(super) opts: &'a SweepOptions,
    /// The scene every point and the reference load.
    pub(super) src: SceneSource,
    /// The scene's settings with the sets applied: what the reference is made from.
    pub(super) base: Settings,
    /// The points, in cross-product order.
    pub(super) points: Vec<Vec<(String, String)>>,
    /// Each point's settings, for the size check.
    pub(super) settings: Vec<Settings>,
}

/// Where the reference comes from, known before anything is rendered.
pub(super) struct ReferenceSource {
    /// The given file, or the cache path of the rendered one.
    pub(super) path: PathBuf,
    /// The image when it is at hand: the given file, or a usable cached render; `None`
    /// when it must be rendered.
    pub(super) image: Option<Image>,
    /// `Reference::Spp`'s samples; `None` for a given file.
    pub(super) spp: Option<u32>,
    /// The overrides a rendered reference uses after the sets (empty for a given file).
    pub(super) overrides: Vec<String>,
    /// Width and height every point must match.
    pub(super) size: (u32, u32),
}

impl ReferenceSource {
    /// Takes the cached render when it can be read back and has the right size; otherwise
    /// the reference is rendered anew.
    pub(super) fn load_cached(&mut self) {
        if self.image.is_none() && self.spp.is_some() {
            self.image = cached_reference(&self.path, self.size);
        }
    }
}

impl<'a> Plan<'a> {
    /// Checks the params, loads the scene with the sets, and loads every point, so that a
    /// bad key or value costs no render time.
    pub(super) fn new(opts: &'a SweepOptions) -> Result<Plan<'a>> {
        check_params(&opts.params)?;
        let src = match &opts.scene {
            Some(p) => SceneSource::from_file(p)?,
            None => SceneSource::default_scene(),
        };
        let base = load(&src, &opts.sets)?.settings;
        let points = cross_product(&opts.params);
        let settings = load_points(&src, &opts.sets, &points)?;
        Ok(Plan { opts, src, base, points, settings })
    }

    /// The sets followed by the reference's overrides: what `load` gets for the reference.
    pub(super) fn reference_sets(&self, overrides: &[String]) -> Vec<String> {
        self.opts.sets.iter().chain(overrides).cloned().collect()
    }

    /// The cache file of a rendered reference; see [`reference_cache_path`].
    fn cache_path(&self, ref_overrides: &[String]) -> PathBuf {
        reference_cache_path(&self.opts.out_dir, &self.src, &self.opts.sets, ref_overrides)
    }

    /// Where the reference comes from and its size, found without rendering: the given
    /// file (read now), or the cache path and settings of a rendered one.
    pub(super) fn reference_source(&self) -> Result<ReferenceSource> {
        let (path, image, spp, overrides) = match &self.opts.reference {
            Reference::File(p) => {
                if !p.is_file() {
                    return Err(Error::input(format!("--reference `{}`: no such file", p.display())));
                }
                (p.clone(), Some(load_linear(p)?), None, Vec::new())
            }
            Reference::Spp(0) => return Err(Error::input("--reference-spp must be at least 1")),
            Reference::Spp(_) if !cfg!(feature = "exr") => {
                return Err(Error::input(format!(
                    "the sweep's rendered reference is cached as EXR: {}; or give a PNG --reference",
                    crate::tools::output::NEEDS_EXR
                )))
            }
            Reference::Spp(spp) => {
                let ov = reference_overrides(&self.base, &self.opts.params, *spp);
                (self.cache_path(&ov), None, Some(*spp), ov)
            }
        };
        let size = match &image {
            Some(img) => (img.width, img.height),
            None => {
                let s = load(&self.src, &self.reference_sets(&overrides))
                    .map_err(|e| Error::input(format!("reference ({}): {e}", overrides.join(", "))))?
                    .settings;
                (s.width, s.height)
            }
        };
        Ok(ReferenceSource { path, image, spp, overrides, size })
    }

    /// Checks that every point renders at the reference's size.
    pub(super) fn check_sizes(&self, reference: &ReferenceSource) -> Result<()> {
        let (w, h) = reference.size;
        for (point, s) in self.points.iter().zip(&self.settings) {
            if (s.width, s.height) != (w, h) {
                return Err(Error::input(format!(
                    "reference `{}` is {w}×{h} but sweep point {} renders {}×{}",
                    reference.path.display(),
                    describe(point),
                    s.width,
                    s.height
                )));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn xml_scenes_of_one_folder_get_their_own_cache_file() {
        let dir = tempfile::tempdir().expect("tempdir");
        let (a, b) = (dir.path().join("a.xml"), dir.path().join("b.xml"));
        std::fs::write(&a, "<scene version=\"3.0.0\"/>").expect("write");
        std::fs::write(&b, "<scene version=\"3.0.0\"><!-- b --></scene>").expect("write");
        let path = |p: &Path| {
            let src = SceneSource::from_file(p).expect("source");
            reference_cache_path(dir.path(), &src, &[], &["render.aa.samples=64".into()])
        };
        assert_ne!(path(&a), path(&b));
        assert_eq!(path(&a), path(&a));
    }
}
