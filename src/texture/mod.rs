//! Textures: bitmaps (PNG, EXR) with wrap modes and bilinear filtering, and the
//! checkerboard, looked up by a surface point's UV as Mitsuba 3 defines them.
//! [`uv`] holds the shapes' parameterisations that produce those UVs.

mod bitmap;
pub mod uv;

#[cfg(test)]
mod tests;

use glam::{Affine2, Vec2, Vec3};

pub use bitmap::MAX_TEXELS;

/// What a lookup outside [0, 1) does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wrap {
    /// Tile the image.
    Repeat,
    /// Tile it mirrored every other time.
    Mirror,
    /// Repeat the edge texels.
    Clamp,
}

/// How texels are combined.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Filter {
    /// The four nearest texel centres, bilinearly weighted.
    Bilinear,
    /// The texel containing the point.
    Nearest,
}

/// An RGB image in linear values.
#[derive(Clone, Debug, PartialEq)]
pub struct Bitmap {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// Linear RGB, row by row from the image's top row.
    pub texels: Vec<Vec3>,
    /// Outside [0, 1).
    pub wrap: Wrap,
    /// Texel combination.
    pub filter: Filter,
}

/// A texture: a colour as a function of a surface point's UV.
#[derive(Clone, Debug, PartialEq)]
pub enum Texture {
    /// An image.
    Bitmap {
        /// The texels.
        bitmap: Bitmap,
        /// Applied to the UV before the lookup (Mitsuba's `to_uv`).
        to_uv: Affine2,
    },
    /// Two colours in checks of the unit UV square, as Mitsuba's `checkerboard`.
    Checkerboard {
        /// Where the fractional parts of u and v are both above 0.5 or both not (Mitsuba's
        /// test, so a point exactly on u = 0.5 belongs to the lower half).
        color0: Vec3,
        /// Elsewhere.
        color1: Vec3,
        /// Applied to the UV before the lookup.
        to_uv: Affine2,
    },
}

impl Texture {
    /// The colour at `uv` (to_uv applied first), linear RGB.
    pub fn eval(&self, uv: Vec2) -> Vec3 {
        match self {
            Texture::Bitmap { bitmap, to_uv } => bitmap.lookup(to_uv.transform_point2(uv)),
            Texture::Checkerboard { color0, color1, to_uv } => {
                let p = to_uv.transform_point2(uv);
                // Mitsuba's checkerboard.cpp: `uv - floor(uv) > .5` per axis, color0 where
                // both agree.
                let upper = (p - p.floor()).cmpgt(Vec2::splat(0.5));
                if upper.x == upper.y {
                    *color0
                } else {
                    *color1
                }
            }
        }
    }

    /// The texture's mean as Mitsuba's `mean()` in its RGB variants: a bitmap's mean
    /// texel luminance, a checkerboard's mean of its two colours' channel means.
    pub fn mean(&self) -> f32 {
        match self {
            Texture::Bitmap { bitmap, .. } => {
                let sum: f64 = bitmap.texels.iter().map(|&t| f64::from(crate::color::luminance(t))).sum();
                (sum / bitmap.texels.len().max(1) as f64) as f32
            }
            Texture::Checkerboard { color0, color1, .. } => 0.5 * (color0.element_sum() + color1.element_sum()) / 3.0,
        }
    }
}
