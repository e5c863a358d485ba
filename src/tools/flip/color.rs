//! FLIP's colour side: sRGB → linear RGB → XYZ → YCxCz and CIELab, the Hunt
//! adjustment and HyAB distance, and the per-pixel colour, feature and combined
//! error formulas.

use glam::Vec3;

use super::{D65_WHITE, PC, PT, QC, QF};
use crate::color::srgb_decode;

// Written out rather than computed as 1 / D65_WHITE so that rounding matches
// the reference implementation.
#[allow(clippy::excessive_precision)]
const D65_WHITE_INV: Vec3 = Vec3::new(1.052156925, 1.0, 0.918357670);

/// Decodes an sRGB-encoded colour to linear RGB.
#[inline]
pub fn srgb_to_linear_rgb(srgb: Vec3) -> Vec3 {
    Vec3::new(srgb_decode(srgb.x), srgb_decode(srgb.y), srgb_decode(srgb.z))
}

/// Linear sRGB-primaries RGB to CIE XYZ, D65 white.
#[inline]
pub fn linear_rgb_to_xyz(rgb: Vec3) -> Vec3 {
    // Exact rational matrix from the reference implementation (derived from the
    // sRGB primaries and D65), so that white maps to exactly `D65_WHITE`.
    const A11: f32 = 10135552.0 / 24577794.0;
    const A12: f32 = 8788810.0 / 24577794.0;
    const A13: f32 = 4435075.0 / 24577794.0;
    const A21: f32 = 2613072.0 / 12288897.0;
    const A22: f32 = 8788810.0 / 12288897.0;
    const A23: f32 = 887015.0 / 12288897.0;
    const A31: f32 = 1425312.0 / 73733382.0;
    const A32: f32 = 8788810.0 / 73733382.0;
    const A33: f32 = 70074185.0 / 73733382.0;
    Vec3::new(
        A11 * rgb.x + A12 * rgb.y + A13 * rgb.z,
        A21 * rgb.x + A22 * rgb.y + A23 * rgb.z,
        A31 * rgb.x + A32 * rgb.y + A33 * rgb.z,
    )
}

/// CIE XYZ (D65) to linear RGB; the inverse of [`linear_rgb_to_xyz`].
#[inline]
#[allow(clippy::excessive_precision)]
pub fn xyz_to_linear_rgb(xyz: Vec3) -> Vec3 {
    const A11: f32 = 3.241003275;
    const A12: f32 = -1.537398934;
    const A13: f32 = -0.498615861;
    const A21: f32 = -0.969224334;
    const A22: f32 = 1.875930071;
    const A23: f32 = 0.041554224;
    const A31: f32 = 0.055639423;
    const A32: f32 = -0.204011202;
    const A33: f32 = 1.057148933;
    Vec3::new(
        A11 * xyz.x + A12 * xyz.y + A13 * xyz.z,
        A21 * xyz.x + A22 * xyz.y + A23 * xyz.z,
        A31 * xyz.x + A32 * xyz.y + A33 * xyz.z,
    )
}

/// CIE XYZ to CIELab relative to the D65 white; white gives L* = 100.
#[inline]
pub fn xyz_to_lab(xyz: Vec3) -> Vec3 {
    const DELTA: f32 = 6.0 / 29.0;
    const DELTA_SQ: f32 = DELTA * DELTA;
    const DELTA_CUBE: f32 = DELTA * DELTA_SQ;
    const FACTOR: f32 = 1.0 / (3.0 * DELTA_SQ);
    const TERM: f32 = 4.0 / 29.0;
    let f = |t: f32| if t > DELTA_CUBE { t.powf(1.0 / 3.0) } else { FACTOR * t + TERM };
    let n = xyz * D65_WHITE_INV;
    let (fx, fy, fz) = (f(n.x), f(n.y), f(n.z));
    Vec3::new(116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz))
}

/// CIE XYZ to YCxCz, the opponent space in which FLIP applies its CSFs. It is
/// CIELab without the cube-root compression, so it stays linear in XYZ and
/// blurring in it is meaningful.
#[inline]
pub fn xyz_to_ycxcz(xyz: Vec3) -> Vec3 {
    let n = xyz * D65_WHITE_INV;
    Vec3::new(116.0 * n.y - 16.0, 500.0 * (n.x - n.y), 200.0 * (n.y - n.z))
}

/// YCxCz back to CIE XYZ; the inverse of [`xyz_to_ycxcz`].
#[inline]
pub fn ycxcz_to_xyz(ycxcz: Vec3) -> Vec3 {
    let y = (ycxcz.x + 16.0) / 116.0;
    let cx = ycxcz.y / 500.0;
    let cz = ycxcz.z / 200.0;
    Vec3::new(y + cx, y, y - cz) * D65_WHITE
}

/// sRGB-encoded colour straight to YCxCz.
#[inline]
pub fn srgb_to_ycxcz(srgb: Vec3) -> Vec3 {
    xyz_to_ycxcz(linear_rgb_to_xyz(srgb_to_linear_rgb(srgb)))
}

/// Hunt adjustment of a CIELab colour: chroma is scaled by L*/100, modelling
/// how colourfulness drops with luminance.
#[inline]
pub fn hunt_adjust(lab: Vec3) -> Vec3 {
    let s = 0.01 * lab.x;
    Vec3::new(lab.x, s * lab.y, s * lab.z)
}

/// HyAB distance: city-block in lightness plus Euclidean in the chromatic
/// plane, which behaves better than ΔE for large differences.
#[inline]
pub fn hyab(a: Vec3, b: Vec3) -> f32 {
    let d = a - b;
    d.x.abs() + (d.y * d.y + d.z * d.z).sqrt()
}

/// `cmax`: the compressed HyAB distance between Hunt-adjusted pure green and
/// pure blue, the most distant pair of colours in the linear-RGB cube.
pub fn max_color_distance() -> f32 {
    let green = hunt_adjust(xyz_to_lab(linear_rgb_to_xyz(Vec3::Y)));
    let blue = hunt_adjust(xyz_to_lab(linear_rgb_to_xyz(Vec3::Z)));
    hyab(green, blue).powf(QC)
}

/// Maps a compressed HyAB distance `power_delta` (= HyAB^`QC`) into [0, 1]:
/// `[0, PC·cmax)` maps linearly onto `[0, PT)` and `[PC·cmax, cmax]` onto
/// `[PT, 1]`, so that most of the range goes to small, visible differences.
#[inline]
pub fn redistribute_color_error(power_delta: f32, cmax: f32) -> f32 {
    let pccmax = PC * cmax;
    if power_delta < pccmax {
        power_delta * (PT / pccmax)
    } else {
        PT + ((power_delta - pccmax) / (cmax - pccmax)) * (1.0 - PT)
    }
}

/// Colour error in [0, 1] between two CSF-filtered YCxCz colours: both are
/// clamped to the linear-RGB unit cube, taken to Hunt-adjusted CIELab and
/// compared with HyAB, compressed and redistributed. `cmax` is
/// [`max_color_distance`], passed in so it is computed once per image.
#[inline]
pub fn color_error(filtered_reference: Vec3, filtered_test: Vec3, cmax: f32) -> f32 {
    let to_lab = |ycxcz: Vec3| {
        let rgb = xyz_to_linear_rgb(ycxcz_to_xyz(ycxcz)).clamp(Vec3::ZERO, Vec3::ONE);
        hunt_adjust(xyz_to_lab(linear_rgb_to_xyz(rgb)))
    };
    let delta = hyab(to_lab(filtered_reference), to_lab(filtered_test));
    redistribute_color_error(delta.powf(QC), cmax)
}

/// Feature error in [0, 1] from the `[edge, point]` response magnitudes of the
/// reference and test at one pixel (see [`feature_magnitudes`](super::feature_magnitudes)).
#[inline]
pub fn feature_error(reference: [f32; 2], test: [f32; 2]) -> f32 {
    let edge = (reference[0] - test[0]).abs();
    let point = (reference[1] - test[1]).abs();
    // A magnitude is at most √2 (two unit-gain responses), so this lies in [0, 1].
    (std::f32::consts::FRAC_1_SQRT_2 * edge.max(point)).powf(QF)
}

/// Final per-pixel FLIP value: `color ^ (1 − feature)`. Feature differences
/// push the colour error towards 1, most strongly where features differ most.
#[inline]
pub fn combine_errors(color: f32, feature: f32) -> f32 {
    color.powf(1.0 - feature)
}
