//! The film: the rendered image, the per-pixel heat behind the heatmaps, and how a
//! finished tile's pixels are placed in them.

use glam::Vec3;

use crate::stages::Tile;

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

/// Copies a tile's rows from `src` (tile-local, row-major) into `dst` (raster of width `width`).
pub fn copy_tile<T: Copy>(dst: &mut [T], width: u32, tile: &Tile, src: &[T]) {
    let tw = (tile.x1 - tile.x0) as usize;
    for (row, y) in (tile.y0..tile.y1).enumerate() {
        let at = (y * width + tile.x0) as usize;
        dst[at..at + tw].copy_from_slice(&src[row * tw..(row + 1) * tw]);
    }
}
