//! Tiles of one render and their exact merge: the header attributes that identify the
//! render a tile belongs to (written by `wavetrace render --crop/--tile` into the tile's
//! EXR), reading tiles back, and `wavetrace merge`'s checks (same render, every pixel
//! covered exactly once) and assembly.
//!
//! A tile's pixels are stored as 32-bit floats, so the merged image has the single
//! render's bits: a merged EXR or PNG is byte-identical to one `wavetrace render` writes.

use glam::Vec3;
use serde::Serialize;
use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use crate::accel::shapes::{Primitive, Shape};
use crate::film::{copy_tile, split, Image, Tile};
use crate::scene::Scene;
use crate::{Error, Result};

/// Prefix of wavetrace's EXR header attributes.
const PREFIX: &str = "wavetrace.";

/// FNV-1a (64-bit) over text, fed by `write!`: a stable hash (it never changes between
/// builds or toolchains, unlike std's `DefaultHasher`) of any value's `Debug` form,
/// without building the string. It identifies renders; it is not a cryptographic hash.
struct Fnv(u64);

impl Fnv {
    /// A fresh hash.
    fn new() -> Fnv {
        Fnv(0xcbf2_9ce4_8422_2325)
    }

    /// The hash of `value`'s `Debug` text, as 16 hex digits.
    fn of(value: &impl std::fmt::Debug) -> String {
        let mut h = Fnv::new();
        let _ = write!(h, "{value:?}");
        h.hex()
    }

    /// Adds bytes.
    fn bytes(&mut self, bytes: &[u8]) {
        for b in bytes {
            self.0 = (self.0 ^ *b as u64).wrapping_mul(0x0100_0000_01b3);
        }
    }

    /// Adds a primitive's exact bits: formatting a mesh's floats as text would cost
    /// more than loading it.
    fn primitive(&mut self, p: &Primitive) {
        let (tag, vecs): (u8, &[Vec3]) = match &p.shape {
            Shape::Sphere { center, radius } => (0, &[*center, Vec3::splat(*radius)]),
            Shape::Triangle { v0, v1, v2 } => (1, &[*v0, *v1, *v2]),
            Shape::Quad { corner, u, v } => (2, &[*corner, *u, *v]),
        };
        self.bytes(&[tag]);
        for f in vecs.iter().flat_map(|v| v.to_array()) {
            self.bytes(&f.to_bits().to_le_bytes());
        }
        self.bytes(&p.material.to_le_bytes());
        self.bytes(&p.light.to_le_bytes());
    }

    /// 16 hex digits.
    fn hex(&self) -> String {
        format!("{:016x}", self.0)
    }
}

impl std::fmt::Write for Fnv {
    fn write_str(&mut self, s: &str) -> std::fmt::Result {
        self.bytes(s.as_bytes());
        Ok(())
    }
}

/// What identifies a render: tiles merge only when all of these agree.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct RenderId {
    /// Hash of the scene's content as loaded (camera, background, materials, lights and
    /// every primitive, meshes included), after `--set` overrides.
    pub scene_hash: String,
    /// Hash of the effective sampling settings (size, modes, samples, seed, ...).
    pub settings_hash: String,
    /// The seed.
    pub seed: u32,
    /// The wavetrace version that rendered it.
    pub version: String,
}

impl RenderId {
    /// The identity of a render of `scene` by this build.
    pub fn of(scene: &Scene) -> RenderId {
        let mut scene_hash = Fnv::new();
        let _ = write!(scene_hash, "{:?}", (&scene.camera, &scene.background, &scene.materials, &scene.lights));
        scene.accel.prims().for_each(|p| scene_hash.primitive(&p));
        RenderId {
            scene_hash: scene_hash.hex(),
            settings_hash: Fnv::of(&scene.settings),
            seed: scene.settings.seed,
            version: env!("CARGO_PKG_VERSION").to_string(),
        }
    }
}

/// A tile's header: its render, the frame, its crop, its task and its stats.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TileHeader {
    /// The render it belongs to.
    pub id: RenderId,
    /// The full frame's size.
    pub width: u32,
    /// The full frame's height.
    pub height: u32,
    /// The pixels it holds (the EXR data window).
    pub crop: Tile,
    /// `(K, N)` when rendered as `--tile K/N`.
    pub task: Option<(u32, u32)>,
    /// Rays traced by the task (all kinds).
    pub rays: u64,
    /// The task's render seconds.
    pub seconds: f64,
}

impl TileHeader {
    /// The header's EXR attributes (`wavetrace.*`, text). Size and crop are the EXR's
    /// display and data windows; `wavetrace.crop` repeats the crop for readers that
    /// show only attributes.
    pub fn attributes(&self) -> Vec<(String, String)> {
        let mut a = vec![
            ("scene_hash", self.id.scene_hash.clone()),
            ("settings_hash", self.id.settings_hash.clone()),
            ("seed", self.id.seed.to_string()),
            ("version", self.id.version.clone()),
            ("crop", self.crop.to_string()),
            ("rays", self.rays.to_string()),
            ("seconds", format!("{:.6}", self.seconds)),
        ];
        if let Some((k, n)) = self.task {
            a.push(("task", format!("{k}/{n}")));
        }
        a.into_iter().map(|(k, v)| (format!("{PREFIX}{k}"), v)).collect()
    }

    /// Parses the `wavetrace.*` attributes of a tile whose windows gave `width`,
    /// `height` and `crop`.
    fn parse(
        attrs: &HashMap<String, String>,
        (width, height): (u32, u32),
        crop: Tile,
    ) -> std::result::Result<Self, String> {
        let get = |k: &str| {
            attrs.get(&format!("{PREFIX}{k}")).ok_or_else(|| {
                format!(
                    "no `{PREFIX}{k}` header attribute (not a tile of `wavetrace render --crop/--crop-window/--tile`)"
                )
            })
        };
        let num = |k: &str| get(k)?.parse::<u64>().map_err(|_| format!("bad `{PREFIX}{k}` header attribute"));
        let task = match attrs.get(&format!("{PREFIX}task")) {
            None => None,
            Some(t) => {
                let bad = || format!("bad `{PREFIX}task` header attribute `{t}`");
                let (k, n) = t.split_once('/').ok_or_else(bad)?;
                Some((k.parse().map_err(|_| bad())?, n.parse().map_err(|_| bad())?))
            }
        };
        Ok(TileHeader {
            id: RenderId {
                scene_hash: get("scene_hash")?.clone(),
                settings_hash: get("settings_hash")?.clone(),
                seed: u32::try_from(num("seed")?).map_err(|_| "bad seed".to_string())?,
                version: get("version")?.clone(),
            },
            width,
            height,
            crop,
            task,
            rays: num("rays")?,
            seconds: get("seconds")?.parse().map_err(|_| format!("bad `{PREFIX}seconds` header attribute"))?,
        })
    }
}

/// A tile read back: its file, header and pixels.
#[derive(Clone, Debug)]
pub struct TileFile {
    /// Where it was read from.
    pub path: PathBuf,
    /// Its header.
    pub header: TileHeader,
    /// Its pixels (the crop only).
    pub image: Image,
}

/// Reads a tile EXR; a corrupt, truncated or foreign file is an input error naming it.
pub fn read_tile(path: &Path) -> Result<TileFile> {
    let bad = |msg: String| Error::input(format!("tile `{}`: {msg}", path.display()));
    let (image, size, crop, attrs) = read_exr_tile(path).map_err(bad)?;
    if crop.x1 > size.0 || crop.y1 > size.1 || image.pixels.is_empty() {
        return Err(bad(format!("data window {crop} is not inside the {}×{} display window", size.0, size.1)));
    }
    let header = TileHeader::parse(&attrs, size, crop).map_err(bad)?;
    Ok(TileFile { path: path.to_path_buf(), header, image })
}

/// (pixels, display size, data window, text attributes) of an EXR.
type ExrTile = (Image, (u32, u32), Tile, HashMap<String, String>);

/// Bytes a merge holds per frame pixel: the frame's colour and the coverage flag.
#[cfg(feature = "exr")]
const FRAME_BYTES: u64 = 12 + 1;

#[cfg(feature = "exr")]
fn read_exr_tile(path: &Path) -> std::result::Result<ExrTile, String> {
    use exr::prelude::*;
    crate::tools::compare::check_exr_fits(path, FRAME_BYTES)?;
    let read = read()
        .no_deep_data()
        .largest_resolution_level()
        .rgba_channels(
            |res, _| (res.width(), vec![Vec3::ZERO; res.width() * res.height()]),
            |(w, px): &mut (usize, Vec<Vec3>), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
                px[pos.y() * *w + pos.x()] = Vec3::new(r, g, b)
            },
        )
        .first_valid_layer()
        .all_attributes()
        .pedantic()
        .from_file(path)
        .map_err(|e| format!("not a readable EXR: {e}"))?;
    let display = read.attributes.display_window;
    if display.position != Vec2(0, 0) {
        return Err("the display window does not start at 0,0".into());
    }
    let layer = &read.layer_data;
    let (pos, size) = (layer.attributes.layer_position, layer.size);
    if pos.x() < 0 || pos.y() < 0 {
        return Err("the data window starts left of or above the display window".into());
    }
    let (x0, y0) = (pos.x() as u32, pos.y() as u32);
    let crop = Tile { x0, y0, x1: x0 + size.width() as u32, y1: y0 + size.height() as u32 };
    let mut attrs = HashMap::new();
    for (k, v) in read.attributes.other.iter().chain(layer.attributes.other.iter()) {
        if let AttributeValue::Text(t) = v {
            attrs.insert(k.to_string(), t.to_string());
        }
    }
    let frame = (display.size.width() as u32, display.size.height() as u32);
    // Moved, not cloned: a merge holds every tile at once, at 12 bytes a pixel each.
    let pixels = read.layer_data.channel_data.pixels.1;
    let image = crate::film::Image { width: size.width() as u32, height: size.height() as u32, pixels };
    Ok((image, frame, crop, attrs))
}

#[cfg(not(feature = "exr"))]
fn read_exr_tile(_: &Path) -> std::result::Result<ExrTile, String> {
    Err(crate::tools::output::NEEDS_EXR.into())
}

/// The first way in which `b`'s render differs from `a`'s, if any.
fn differs(a: &TileHeader, b: &TileHeader) -> Option<String> {
    let (x, y) = (&a.id, &b.id);
    if x.version != y.version {
        return Some(format!("wavetrace version {} vs {}", y.version, x.version));
    }
    if (a.width, a.height) != (b.width, b.height) {
        return Some(format!("frame {}×{} vs {}×{}", b.width, b.height, a.width, a.height));
    }
    if x.seed != y.seed {
        return Some(format!("seed {} vs {}", y.seed, x.seed));
    }
    if x.scene_hash != y.scene_hash {
        return Some(format!("scene hash {} vs {} (a different scene)", y.scene_hash, x.scene_hash));
    }
    if x.settings_hash != y.settings_hash {
        return Some(format!("settings hash {} vs {} (different settings)", y.settings_hash, x.settings_hash));
    }
    None
}

/// Reads every tile and checks that they come from one render and that a `--tile K/N`
/// tile holds exactly task K's rectangle.
pub fn read_tiles(paths: &[PathBuf]) -> Result<Vec<TileFile>> {
    if paths.is_empty() {
        return Err(Error::input("merge: no tiles given"));
    }
    let tiles = paths.iter().map(|p| read_tile(p)).collect::<Result<Vec<_>>>()?;
    let first = &tiles[0];
    for t in &tiles[1..] {
        if let Some(why) = differs(&first.header, &t.header) {
            let (a, b) = (first.path.display(), t.path.display());
            return Err(Error::input(format!("tile `{b}` is not from the same render as `{a}`: {why}")));
        }
    }
    for t in &tiles {
        let h = &t.header;
        if let Some((k, n)) = h.task {
            let want = split(h.width, h.height, n).and_then(|s| s.get(k as usize).copied());
            if want != Some(h.crop) {
                let want = want.map_or("no such task".into(), |w| w.to_string());
                return Err(Error::input(format!(
                    "tile `{}`: task {k}/{n} should hold {want} but holds {}",
                    t.path.display(),
                    h.crop
                )));
            }
        }
    }
    Ok(tiles)
}

/// How the tiles cover the frame.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Coverage {
    /// Pixels no tile holds.
    pub missing_pixels: u64,
    /// The `--tile` task indices no tile holds, when every tile is a task of one N.
    pub missing_tasks: Option<Vec<u32>>,
    /// Smallest rectangle around the missing pixels.
    pub missing_bounds: Option<Tile>,
}

/// Checks that no two tiles overlap (an input error naming both) and finds the gaps.
pub fn coverage(tiles: &[TileFile]) -> Result<Coverage> {
    for (i, a) in tiles.iter().enumerate() {
        for b in &tiles[i + 1..] {
            if a.header.crop.overlaps(&b.header.crop) {
                return Err(Error::input(format!(
                    "tiles `{}` ({}) and `{}` ({}) overlap",
                    a.path.display(),
                    a.header.crop,
                    b.path.display(),
                    b.header.crop
                )));
            }
        }
    }
    let (w, h) = (tiles[0].header.width, tiles[0].header.height);
    let mut covered = vec![false; w as usize * h as usize];
    for t in tiles {
        let c = &t.header.crop;
        copy_tile(&mut covered, w, c, &vec![true; c.pixels()]);
    }
    let mut cov = Coverage::default();
    for (i, _) in covered.iter().enumerate().filter(|(_, c)| !**c) {
        let (x, y) = (i as u32 % w, i as u32 / w);
        cov.missing_pixels += 1;
        let b = cov.missing_bounds.get_or_insert(Tile { x0: x, x1: x + 1, y0: y, y1: y + 1 });
        *b = Tile { x0: b.x0.min(x), x1: b.x1.max(x + 1), y0: b.y0.min(y), y1: b.y1.max(y + 1) };
    }
    let ns: Vec<Option<u32>> = tiles.iter().map(|t| t.header.task.map(|(_, n)| n)).collect();
    if let Some(Some(n)) = ns.first().filter(|first| ns.iter().all(|x| x == *first)) {
        let have: std::collections::HashSet<u32> = tiles.iter().filter_map(|t| t.header.task.map(|(k, _)| k)).collect();
        cov.missing_tasks = Some((0..*n).filter(|k| !have.contains(k)).collect());
    }
    Ok(cov)
}

impl Coverage {
    /// The gap as words, for an error message.
    pub fn describe(&self) -> String {
        let mut s = format!("{} pixels are in no tile", self.missing_pixels);
        if let Some(b) = self.missing_bounds {
            s += &format!(" (within {b})");
        }
        if let Some(m) = self.missing_tasks.as_ref().filter(|m| !m.is_empty()) {
            let list: Vec<String> = m.iter().map(u32::to_string).collect();
            s += &format!("; missing tasks: {} (`wavetrace merge --missing` lists them)", list.join(" "));
        }
        s
    }
}

/// The full frame from the tiles; pixels no tile holds are black.
pub fn assemble(tiles: &[TileFile]) -> Image {
    let (w, h) = (tiles[0].header.width, tiles[0].header.height);
    let mut pixels = vec![Vec3::ZERO; w as usize * h as usize];
    for t in tiles {
        copy_tile(&mut pixels, w, &t.header.crop, &t.image.pixels);
    }
    Image { width: w, height: h, pixels }
}

/// One tile's row in the merged stats.
#[derive(Clone, Debug, Serialize)]
pub struct TileRow {
    /// The tile file.
    pub path: String,
    /// Its pixels, `x0,x1,y0,y1`.
    pub crop: String,
    /// `K/N` for a `--tile` task.
    pub task: Option<String>,
    /// Rays it traced.
    pub rays: u64,
    /// Its render seconds.
    pub seconds: f64,
}

/// `wavetrace merge --stats-json`: the render, the sums and a row per tile.
#[derive(Clone, Debug, Serialize)]
pub struct MergeStats {
    /// The render the tiles belong to.
    pub render: RenderId,
    /// Frame width.
    pub width: u32,
    /// Frame height.
    pub height: u32,
    /// Rays over all tiles.
    pub rays: u64,
    /// Render seconds summed over tiles (CPU-task time, not wall time).
    pub seconds: f64,
    /// True when pixels were missing (merged with `--allow-missing`: they are black).
    pub partial: bool,
    /// What was missing.
    pub coverage: Coverage,
    /// Per tile.
    pub tiles: Vec<TileRow>,
}

/// The merged stats of `tiles`.
pub fn stats(tiles: &[TileFile], coverage: &Coverage) -> MergeStats {
    let h = &tiles[0].header;
    let rows: Vec<TileRow> = tiles
        .iter()
        .map(|t| TileRow {
            path: t.path.display().to_string(),
            crop: t.header.crop.to_string(),
            task: t.header.task.map(|(k, n)| format!("{k}/{n}")),
            rays: t.header.rays,
            seconds: t.header.seconds,
        })
        .collect();
    MergeStats {
        render: h.id.clone(),
        width: h.width,
        height: h.height,
        rays: rows.iter().map(|r| r.rays).sum(),
        seconds: rows.iter().map(|r| r.seconds).sum(),
        partial: coverage.missing_pixels > 0,
        coverage: coverage.clone(),
        tiles: rows,
    }
}
