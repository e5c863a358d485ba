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
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
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
        let at = (y * width + tile.x0) as usize;
        dst[at..at + tw].copy_from_slice(&src[row * tw..(row + 1) * tw]);
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
        for s in 0..pass.rays.len() {
            let p = s / group;
            self.heat.rays[p] += pass.rays[s];
            self.heat.points[p] += pass.points[s];
            self.heat.penumbra[p] += pass.penumbra[s];
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
