//! LDR-FLIP: NVIDIA's perceptual difference evaluator for alternating images.
//!
//! Follows "FLIP: A Difference Evaluator for Alternating Images" (Andersson,
//! Nilsson, Akenine-Möller, Oskarsson, Åström, Fairchild; HPG 2020) as
//! implemented in NVIDIA's reference code (github.com/NVlabs/flip, the
//! single-header `cpp/FLIP.h`, v1.3 and later). Where the paper and the code
//! differ in detail (separable filters, normalisations, constants) this module
//! follows the code, so that values agree with `flip-evaluator` to float
//! rounding.
//!
//! The pipeline, per pixel of a reference/test pair of sRGB images:
//! 1. sRGB → linear RGB → XYZ (D65) → YCxCz, a linearised CIELab opponent space.
//! 2. Colour: each YCxCz channel is blurred by a contrast-sensitivity (CSF)
//!    filter, the result is clamped to the linear-RGB unit cube, taken to
//!    Hunt-adjusted CIELab and compared with the HyAB distance, which is then
//!    compressed (`^0.7`) and redistributed into [0, 1].
//! 3. Features: edges and points are detected on the normalised achromatic
//!    channel with first and second Gaussian derivatives; the larger of the two
//!    response differences gives the feature error.
//! 4. FLIP = colour error ^ (1 − feature error).
//!
//! Filters are applied separably, with borders padded by clamping to the edge,
//! as the reference does.
//!
//! Files: `color.rs` (colour spaces and the per-pixel error formulas),
//! `filter.rs` (CSF and feature filters), `map.rs` (error maps and the mean),
//! `tests.rs`.

use glam::Vec3;
use std::f32::consts::PI;

mod color;
mod filter;
mod map;
#[cfg(test)]
mod tests;

pub use color::*;
pub use filter::*;
pub use map::*;

/// Exponent compressing the HyAB colour difference (`q_c` in the paper).
pub const QC: f32 = 0.7;
/// Fraction of the maximum colour error below which errors map to `[0, PT]`.
pub const PC: f32 = 0.4;
/// Error level that `PC · cmax` maps to in the redistribution.
pub const PT: f32 = 0.95;
/// Peak-to-trough width, in degrees, of the human edge detector; the feature
/// filters' standard deviation is half of it.
pub const FEATURE_WIDTH_DEG: f32 = 0.082;
/// Exponent applied to the normalised feature difference (`q_f` in the paper).
pub const QF: f32 = 0.5;

/// D65 white point in XYZ, with the reference implementation's digits.
// Digits kept as the reference writes them (here and below), so they can be
// checked against it; the extra ones round away in f32.
#[allow(clippy::excessive_precision)]
pub const D65_WHITE: Vec3 = Vec3::new(0.950428545, 1.0, 1.088900371);

/// Pixels per degree of visual angle for an observer `distance_m` metres from a
/// monitor `monitor_width_m` metres wide showing `resolution_x` pixels across.
pub fn pixels_per_degree(distance_m: f32, resolution_x: f32, monitor_width_m: f32) -> f32 {
    distance_m * (resolution_x / monitor_width_m) * (PI / 180.0)
}

/// FLIP's default viewing condition: 0.7 m from a 0.7 m wide, 3840-pixel-wide
/// monitor, which is 3840·π/180 ≈ 67.02 pixels per degree (usually quoted as
/// "67 PPD"; the reference uses the unrounded value).
pub fn ppd_default() -> f32 {
    pixels_per_degree(0.7, 3840.0, 0.7)
}
