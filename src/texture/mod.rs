//! Textures: bitmaps (PNG, EXR) with wrap modes and bilinear filtering, and the
//! checkerboard, looked up by a surface point's UV as Mitsuba 3 defines them.

use glam::{Affine2, Vec3};

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
    /// Two colours alternating on the unit square's 2×2 checks.
    Checkerboard {
        /// Where floor(2u) + floor(2v) is even.
        color0: Vec3,
        /// Where it is odd.
        color1: Vec3,
        /// Applied to the UV before the lookup.
        to_uv: Affine2,
    },
}
