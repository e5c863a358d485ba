//! The film: the rendered image, the per-pixel heat behind the heatmaps, and how a
//! finished tile's pixels are placed in them.

use glam::Vec3;

/// A linear RGB image.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Radiance per pixel, row-major from the top-left.
    pub pixels: Vec<Vec3>,
}

/// Where the rays went, per pixel: the data behind the heatmaps.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Heat {
    /// Rays of every kind whose radiance went to the pixel (a shared corner's rays are
    /// split evenly between the pixels that share it).
    pub rays: Vec<f32>,
    /// Last adaptive refinement level cast in the pixel; 0 when never refined.
    pub level: Vec<u8>,
    /// Shading points × quad lights that entered the shadow-corner queue.
    pub points: Vec<f32>,
    /// Of those, the ones that entered the penumbra queue.
    pub penumbra: Vec<f32>,
}

/// Tile edge in pixels: small enough to balance load, large enough for coherent waves.
pub const TILE: u32 = 16;
/// A rectangle of pixels `[x0, x1) × [y0, y1)` rendered by one worker.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct Tile {
    /// Left column.
    pub x0: u32,
    /// Top row.
    pub y0: u32,
    /// One past the right column.
    pub x1: u32,
    /// One past the bottom row.
    pub y1: u32,
}

impl Tile {
    /// Number of pixels.
    pub fn pixels(&self) -> usize {
        ((self.x1 - self.x0) * (self.y1 - self.y0)) as usize
    }

    /// True when the two rectangles share a pixel.
    pub fn overlaps(&self, other: &Tile) -> bool {
        self.x0 < other.x1 && other.x0 < self.x1 && self.y0 < other.y1 && other.y0 < self.y1
    }

    /// The rectangle grown by one pixel right and down: the pixel corners this
    /// rectangle's pixels use, in the (W+1)×(H+1) corner grid.
    pub fn corners(&self) -> Tile {
        Tile { x1: self.x1 + 1, y1: self.y1 + 1, ..*self }
    }
}

impl std::fmt::Display for Tile {
    /// `x0,x1,y0,y1`: the `--crop` syntax (pbrt's pixel bounds).
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        write!(f, "{},{},{},{}", self.x0, self.x1, self.y0, self.y1)
    }
}

/// Part of the frame a render is asked for (`--crop`, `--crop-window`, `--tile`),
/// before the image size is known.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Crop {
    /// Pixel bounds `x0,x1,y0,y1`, half-open, in the full image's raster.
    Pixels(Tile),
    /// Fractions of the frame `x0,x1,y0,y1` in [0, 1] (pbrt's crop window): the pixels
    /// from ceil(W·x0) to ceil(W·x1), likewise in y.
    Window([f32; 4]),
    /// Task `k` of `n`: the k-th of [`split`]'s rectangles.
    Task {
        /// Task index, from 0.
        k: u32,
        /// Number of tasks.
        n: u32,
    },
}

impl Crop {
    /// The pixel rectangle of this crop in a `width`×`height` frame; a message when it
    /// is empty, reversed or outside the frame.
    pub fn resolve(&self, width: u32, height: u32) -> std::result::Result<Tile, String> {
        let t = match *self {
            Crop::Pixels(t) => t,
            Crop::Window(f) => {
                if f.iter().any(|v| !(0.0..=1.0).contains(v)) {
                    return Err(format!("--crop-window {f:?}: every value must be in [0, 1]"));
                }
                let px = |v: f32, size: u32| (size as f32 * v).ceil() as u32;
                Tile { x0: px(f[0], width), x1: px(f[1], width), y0: px(f[2], height), y1: px(f[3], height) }
            }
            Crop::Task { k, n } => {
                if n == 0 || k >= n {
                    return Err(format!("--tile {k}/{n}: need N ≥ 1 and 0 ≤ K < N"));
                }
                let parts = split(width, height, n).ok_or_else(|| {
                    let have = width.div_ceil(TILE) * height.div_ceil(TILE);
                    format!("--tile {k}/{n}: a {width}×{height} image has {have} tiles of {TILE}×{TILE}, fewer than {n} tasks")
                })?;
                return Ok(parts[k as usize]);
            }
        };
        if t.x0 >= t.x1 || t.y0 >= t.y1 {
            return Err(format!("crop {t} (x0,x1,y0,y1) is empty or reversed"));
        }
        if t.x1 > width || t.y1 > height {
            return Err(format!("crop {t} (x0,x1,y0,y1) is outside the {width}×{height} image"));
        }
        Ok(t)
    }
}

/// Cuts a `width`×`height` frame into `n` near-equal rectangles aligned to the render's
/// [`TILE`] grid, row-major: bands of tile rows, each cut into tile columns. Of every
/// band count, and task counts per band even or in proportion to the band's rows, it
/// keeps the layout whose costliest task is cheapest (the array job's longest task),
/// then the one with the fewest pixel tiles in its largest task, then the smallest
/// spread. A task of c×r tiles costs c·r pixel tiles plus the (c+1)·(r+1) corner-grid
/// tiles that adaptive AA traces for it (whole grid tiles, so that the corners are
/// exact): thin strips would trace twice the corner grid. `None` when the frame has
/// fewer tiles than `n`.
pub fn split(width: u32, height: u32, n: u32) -> Option<Vec<Tile>> {
    let (tw, th) = (width.div_ceil(TILE), height.div_ceil(TILE));
    if n == 0 || n as u64 > tw as u64 * th as u64 {
        return None;
    }
    // (costliest task, most pixel tiles, spread) of the best layout so far.
    let mut best: Option<(Score, Layout)> = None;
    for bands in 1..=n.min(th) {
        for proportional in [false, true] {
            let Some(rects) = bands_layout(tw, th, n, bands, proportional) else { continue };
            let size = |r: &[u32; 4]| (r[1] - r[0], r[3] - r[2]);
            let cost = rects.iter().map(size).map(|(c, r)| c * r + (c + 1) * (r + 1)).max().unwrap_or(0);
            let tiles = rects.iter().map(|r| size(r).0 * size(r).1);
            let (lo, hi) = tiles.fold((u32::MAX, 0), |(lo, hi), t| (lo.min(t), hi.max(t)));
            let score = (cost, hi, hi - lo);
            if best.as_ref().is_none_or(|(b, _)| score < *b) {
                best = Some((score, rects));
            }
        }
    }
    let px = |t: u32, end: u32| (t * TILE).min(end);
    let rects = best?.1;
    Some(
        rects
            .iter()
            .map(|r| Tile { x0: px(r[0], width), x1: px(r[1], width), y0: px(r[2], height), y1: px(r[3], height) })
            .collect(),
    )
}

/// Task rectangles `[c0, c1, r0, r1]` in tiles of the render's grid.
type Layout = Vec<[u32; 4]>;

/// How [`split`] ranks layouts, lowest first.
type Score = (u32, u32, u32);

/// `n` rectangles `[c0, c1, r0, r1]` in tiles: `bands` even bands of the `th` tile rows,
/// band b holding an even share of the tasks, or (`proportional`) a share in proportion
/// to its rows; each band's tasks cut its `tw` columns evenly. `None` when a band would
/// get no task, or more tasks than columns.
fn bands_layout(tw: u32, th: u32, n: u32, bands: u32, proportional: bool) -> Option<Layout> {
    let cut = |total: u32, parts: u32, i: u32| (total as u64 * i as u64 / parts as u64) as u32;
    let task_cut = |b: u32| if proportional { cut(n, th, cut(th, bands, b)) } else { cut(n, bands, b) };
    let mut out = Vec::with_capacity(n as usize);
    for b in 0..bands {
        let (r0, r1) = (cut(th, bands, b), cut(th, bands, b + 1));
        let tasks = task_cut(b + 1) - task_cut(b);
        if tasks == 0 || tasks > tw {
            return None;
        }
        out.extend((0..tasks).map(|j| [cut(tw, tasks, j), cut(tw, tasks, j + 1), r0, r1]));
    }
    Some(out)
}

/// The tiles of a `width`×`height` raster, row-major. The tiling never depends on the
/// thread count, and each tile sums its samples in a fixed order, so the image is
/// bit-identical for any number of threads.
pub fn tiles(width: u32, height: u32) -> Vec<Tile> {
    let mut out = Vec::new();
    for y0 in (0..height).step_by(TILE as usize) {
        for x0 in (0..width).step_by(TILE as usize) {
            out.push(Tile { x0, y0, x1: (x0 + TILE).min(width), y1: (y0 + TILE).min(height) });
        }
    }
    out
}

/// Copies a tile's rows from `src` (tile-local, row-major) into `dst` (raster of width `width`).
pub fn copy_tile<T: Copy>(dst: &mut [T], width: u32, tile: &Tile, src: &[T]) {
    let tw = (tile.x1 - tile.x0) as usize;
    for (row, y) in (tile.y0..tile.y1).enumerate() {
        let at = y as usize * width as usize + tile.x0 as usize;
        dst[at..at + tw].copy_from_slice(&src[row * tw..(row + 1) * tw]);
    }
}

/// The rows of `src` (a raster of width `width`) inside `t`, row-major.
fn crop_rows<T: Copy>(src: &[T], width: u32, t: &Tile) -> Vec<T> {
    let mut out = Vec::with_capacity(t.pixels());
    for y in t.y0..t.y1 {
        let row = y as usize * width as usize;
        out.extend_from_slice(&src[row + t.x0 as usize..row + t.x1 as usize]);
    }
    out
}

impl Image {
    /// The pixels inside `t` (which must lie in the image) as an image of their own.
    pub fn crop(&self, t: &Tile) -> Image {
        Image { width: t.x1 - t.x0, height: t.y1 - t.y0, pixels: crop_rows(&self.pixels, self.width, t) }
    }
}

/// Per-slot counters of one pass (the heatmap data before slots are mapped to pixels).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SlotHeat {
    /// Rays of every kind per slot.
    pub rays: Vec<f32>,
    /// Shading points × quad lights that entered the shadow-corner queue.
    pub points: Vec<f32>,
    /// Of those, the ones that entered the penumbra queue.
    pub penumbra: Vec<f32>,
}

/// What a pass accumulates: radiance and heat per slot (a pixel, a corner or an
/// estimate, as the pass's camera generator numbers them).
#[derive(Clone, Debug, Default)]
pub struct Accumulator {
    /// Radiance per slot.
    pub sums: Vec<Vec3>,
    /// Heat per slot.
    pub heat: SlotHeat,
}

impl Accumulator {
    /// Starts a pass with `slots` zeroed slots.
    pub fn begin(&mut self, slots: usize) {
        self.sums.clear();
        self.sums.resize(slots, Vec3::ZERO);
        for v in [&mut self.heat.rays, &mut self.heat.points, &mut self.heat.penumbra] {
            v.clear();
            v.resize(slots, 0.0);
        }
    }

    /// Bytes held (capacity).
    pub fn bytes(&self) -> usize {
        let h = &self.heat;
        std::mem::size_of::<Vec3>() * self.sums.capacity()
            + 4 * (h.rays.capacity() + h.points.capacity() + h.penumbra.capacity())
    }
}

/// A tile's results: final radiance and heat per tile pixel, row-major.
#[derive(Clone, Debug, Default)]
pub struct TileFilm {
    /// Final radiance.
    pub out: Vec<Vec3>,
    /// Heat.
    pub heat: Heat,
}

impl TileFilm {
    /// Starts a tile of `n` pixels, all black and cold.
    pub fn begin(&mut self, n: usize) {
        self.out.clear();
        self.out.resize(n, Vec3::ZERO);
        let h = &mut self.heat;
        for v in [&mut h.rays, &mut h.points, &mut h.penumbra] {
            v.clear();
            v.resize(n, 0.0);
        }
        h.level.clear();
        h.level.resize(n, 0);
    }

    /// Adds a pass's slot heat to the tile pixels; slot s belongs to pixel s / `group`.
    pub fn collect_heat(&mut self, pass: &SlotHeat, group: usize) {
        let h = &mut self.heat;
        for (dst, src) in [(&mut h.rays, &pass.rays), (&mut h.points, &pass.points), (&mut h.penumbra, &pass.penumbra)]
        {
            if group == 1 {
                // A slot per pixel (uniform AA): sums on vector lanes.
                dst.iter_mut().zip(src).for_each(|(d, &x)| *d += x);
                continue;
            }
            for (d, slots) in dst.iter_mut().zip(src.chunks(group)) {
                for &x in slots {
                    *d += x;
                }
            }
        }
    }

    /// Bytes held (capacity).
    pub fn bytes(&self) -> usize {
        let h = &self.heat;
        std::mem::size_of::<Vec3>() * self.out.capacity()
            + 4 * (h.rays.capacity() + h.points.capacity() + h.penumbra.capacity())
            + h.level.capacity()
    }
}

impl Heat {
    /// A cold heat map of `n` pixels.
    pub fn zeroed(n: usize) -> Heat {
        Heat { rays: vec![0.0; n], level: vec![0; n], points: vec![0.0; n], penumbra: vec![0.0; n] }
    }

    /// The heat inside `t` of this raster of width `width`.
    pub fn crop(&self, width: u32, t: &Tile) -> Heat {
        Heat {
            rays: crop_rows(&self.rays, width, t),
            level: crop_rows(&self.level, width, t),
            points: crop_rows(&self.points, width, t),
            penumbra: crop_rows(&self.penumbra, width, t),
        }
    }

    /// Copies a finished tile's heat (tile-local) into this raster of width `width`.
    pub fn copy_tile(&mut self, width: u32, tile: &Tile, src: &Heat) {
        copy_tile(&mut self.rays, width, tile, &src.rays);
        copy_tile(&mut self.points, width, tile, &src.points);
        copy_tile(&mut self.penumbra, width, tile, &src.penumbra);
        copy_tile(&mut self.level, width, tile, &src.level);
    }
}

impl SlotHeat {
    /// Cold counters for `n` slots.
    pub fn zeroed(n: usize) -> SlotHeat {
        SlotHeat { rays: vec![0.0; n], points: vec![0.0; n], penumbra: vec![0.0; n] }
    }

    /// Copies a finished tile's slot heat (tile-local) into this raster of width `width`.
    pub fn copy_tile(&mut self, width: u32, tile: &Tile, src: &SlotHeat) {
        copy_tile(&mut self.rays, width, tile, &src.rays);
        copy_tile(&mut self.points, width, tile, &src.points);
        copy_tile(&mut self.penumbra, width, tile, &src.penumbra);
    }
}
