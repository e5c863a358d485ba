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

use glam::Vec3;
use std::f32::consts::PI;

use crate::color::srgb_decode;

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
// Written out rather than computed as 1 / D65_WHITE so that rounding matches
// the reference implementation.
#[allow(clippy::excessive_precision)]
const D65_WHITE_INV: Vec3 = Vec3::new(1.052156925, 1.0, 0.918357670);

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

// ---------------------------------------------------------------------------
// Colour transforms
// ---------------------------------------------------------------------------

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
/// reference and test at one pixel (see [`feature_magnitudes`]).
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

// ---------------------------------------------------------------------------
// Filters
// ---------------------------------------------------------------------------

/// Parameters of one channel's contrast sensitivity function, a sum of two
/// Gaussians `a1·√(π/b1)·exp(−π²r²/b1) + a2·√(π/b2)·exp(−π²r²/b2)` with `r` in
/// degrees.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CsfParams {
    /// Amplitude of the first Gaussian.
    pub a1: f32,
    /// Scale (variance-like) parameter of the first Gaussian, degrees².
    pub b1: f32,
    /// Amplitude of the second Gaussian.
    pub a2: f32,
    /// Scale parameter of the second Gaussian, degrees²; non-zero even when
    /// `a2` is zero, to keep the formula finite.
    pub b2: f32,
}

/// CSF of the achromatic (Y) channel.
pub const CSF_ACHROMATIC: CsfParams = CsfParams { a1: 1.0, b1: 0.0047, a2: 0.0, b2: 1.0e-5 };
/// CSF of the red-green (Cx) channel.
pub const CSF_RED_GREEN: CsfParams = CsfParams { a1: 1.0, b1: 0.0053, a2: 0.0, b2: 1.0e-5 };
/// CSF of the blue-yellow (Cz) channel.
pub const CSF_BLUE_YELLOW: CsfParams = CsfParams { a1: 34.1, b1: 0.04, a2: 13.5, b2: 0.025 };

/// Radius in pixels shared by all three CSF filters: three standard deviations
/// of the widest Gaussian (the blue-yellow `b1`).
pub fn spatial_filter_radius(ppd: f32) -> usize {
    let max_b =
        [CSF_ACHROMATIC, CSF_RED_GREEN, CSF_BLUE_YELLOW].iter().flat_map(|p| [p.b1, p.b2]).fold(0.0f32, f32::max);
    (3.0 * (max_b / (2.0 * PI * PI)).sqrt() * ppd).ceil() as usize
}

/// Separable 1D factors of the three CSF filters, all `2·radius + 1` taps.
///
/// The 2D achromatic filter is `achromatic ⊗ achromatic`, likewise red-green.
/// The blue-yellow CSF is a sum of two Gaussians, which is not separable as a
/// whole, so its 2D filter is `blue_yellow[0] ⊗ blue_yellow[0] +
/// blue_yellow[1] ⊗ blue_yellow[1]`. Every 2D filter sums to 1.
#[derive(Clone, Debug, PartialEq)]
pub struct SpatialFilters {
    /// 1D factor of the Y filter; sums to 1.
    pub achromatic: Vec<f32>,
    /// 1D factor of the Cx filter; sums to 1.
    pub red_green: Vec<f32>,
    /// The two 1D factors of the Cz filter; the squares of their sums add to 1.
    pub blue_yellow: [Vec<f32>; 2],
}

/// Builds the CSF filters for `ppd` pixels per degree, sampled every 1/ppd
/// degrees and normalised as the reference implementation does.
pub fn spatial_filters(ppd: f32) -> SpatialFilters {
    let radius = spatial_filter_radius(ppd) as i32;
    let dx = 1.0 / ppd;
    let pi_sq = PI * PI;
    // One Gaussian of the sum-of-Gaussians CSF; normalisation removes its
    // amplitude for single-Gaussian channels.
    let gaussian = |x2: f32, a: f32, b: f32| a * (PI / b).sqrt() * (-pi_sq * x2 / b).exp();
    // Square root of the amplitude so that the outer product of two 1D
    // factors carries the full amplitude of its 2D Gaussian.
    let gaussian_sqrt = |x2: f32, a: f32, b: f32| (a * (PI / b).sqrt()).sqrt() * (-pi_sq * x2 / b).exp();
    let x2s: Vec<f32> = (-radius..=radius).map(|i| (i as f32 * dx) * (i as f32 * dx)).collect();

    let normalised = |mut v: Vec<f32>| {
        let sum: f32 = v.iter().sum();
        v.iter_mut().for_each(|w| *w /= sum);
        v
    };
    let achromatic = normalised(x2s.iter().map(|&x2| gaussian(x2, CSF_ACHROMATIC.a1, CSF_ACHROMATIC.b1)).collect());
    let red_green = normalised(x2s.iter().map(|&x2| gaussian(x2, CSF_RED_GREEN.a1, CSF_RED_GREEN.b1)).collect());

    let by = CSF_BLUE_YELLOW;
    let mut by1: Vec<f32> = x2s.iter().map(|&x2| gaussian_sqrt(x2, by.a1, by.b1)).collect();
    let mut by2: Vec<f32> = x2s.iter().map(|&x2| gaussian_sqrt(x2, by.a2, by.b2)).collect();
    // The 2D sum is sum1² + sum2², so one common factor normalises both.
    let (s1, s2): (f32, f32) = (by1.iter().sum(), by2.iter().sum());
    let norm = 1.0 / (s1 * s1 + s2 * s2).sqrt();
    by1.iter_mut().chain(by2.iter_mut()).for_each(|w| *w *= norm);

    SpatialFilters { achromatic, red_green, blue_yellow: [by1, by2] }
}

/// Standard deviation in pixels of the feature-detection Gaussian.
pub fn feature_filter_std_dev(ppd: f32) -> f32 {
    0.5 * FEATURE_WIDTH_DEG * ppd
}

/// Radius in pixels of the feature-detection filters (three standard deviations).
pub fn feature_filter_radius(ppd: f32) -> usize {
    (3.0 * feature_filter_std_dev(ppd)).ceil() as usize
}

/// Separable 1D factors of the feature detectors, all `2·radius + 1` taps.
///
/// The 2D edge detector in x is `edge(x) · gaussian(y)` and the point detector
/// `point(x) · gaussian(y)`; the y detectors are their transposes.
#[derive(Clone, Debug, PartialEq)]
pub struct FeatureFilters {
    /// Gaussian, normalised to sum to 1.
    pub gaussian: Vec<f32>,
    /// First derivative of the Gaussian (negated, as in the reference), with
    /// positive taps summing to 1 and negative taps to −1.
    pub edge: Vec<f32>,
    /// Second derivative of the Gaussian, with positive taps summing to 1 and
    /// negative taps to −1.
    pub point: Vec<f32>,
}

/// Builds the feature-detection filters for `ppd` pixels per degree.
pub fn feature_filters(ppd: f32) -> FeatureFilters {
    let sd = feature_filter_std_dev(ppd);
    let radius = feature_filter_radius(ppd) as i32;
    let mut gaussian = Vec::new();
    let mut edge = Vec::new();
    let mut point = Vec::new();
    for i in -radius..=radius {
        let x = i as f32;
        let g = (-(x * x) / (2.0 * sd * sd)).exp();
        gaussian.push(g);
        edge.push(-x * g);
        point.push((x * x / (sd * sd) - 1.0) * g);
    }
    let gsum: f32 = gaussian.iter().sum();
    gaussian.iter_mut().for_each(|w| *w /= gsum);
    // Normalising each sign to unit mass makes the response to a unit step (or
    // unit blob) independent of ppd, so feature differences stay in [0, 1].
    let balance = |v: &mut Vec<f32>| {
        let pos: f32 = v.iter().filter(|&&w| w > 0.0).sum();
        let neg: f32 = -v.iter().filter(|&&w| w < 0.0).sum::<f32>();
        v.iter_mut().for_each(|w| *w /= if *w > 0.0 { pos } else { neg });
    };
    balance(&mut edge);
    balance(&mut point);
    FeatureFilters { gaussian, edge, point }
}

/// Correlates every row of the `width`-wide plane `src` with each of `kernels`
/// (all the same odd length), padding by clamping to the row's ends.
fn filter_rows<const N: usize>(src: &[f32], width: usize, kernels: [&[f32]; N]) -> [Vec<f32>; N] {
    let taps = kernels[0].len();
    let r = taps / 2;
    let mut out: [Vec<f32>; N] = std::array::from_fn(|_| vec![0.0; src.len()]);
    let mut padded = vec![0.0f32; width + 2 * r];
    for (row_index, row) in src.chunks_exact(width).enumerate() {
        for (i, p) in padded.iter_mut().enumerate() {
            *p = row[i.saturating_sub(r).min(width - 1)];
        }
        let span = row_index * width..(row_index + 1) * width;
        for (kernel, plane) in kernels.iter().zip(out.iter_mut()) {
            let dst = &mut plane[span.clone()];
            // Tap-outer, pixel-inner keeps each pixel's sum in the reference's
            // tap order while letting the inner loop vectorise.
            for (t, &w) in kernel.iter().enumerate() {
                for (d, &s) in dst.iter_mut().zip(&padded[t..t + width]) {
                    *d += w * s;
                }
            }
        }
    }
    out
}

/// Correlates every column of the `width`-wide plane `src` with `kernel` (odd
/// length), padding by clamping to the top and bottom rows.
fn filter_columns(src: &[f32], width: usize, kernel: &[f32]) -> Vec<f32> {
    let height = src.len() / width;
    let r = kernel.len() / 2;
    let mut out = vec![0.0f32; src.len()];
    for (y, dst) in out.chunks_exact_mut(width).enumerate() {
        for (t, &w) in kernel.iter().enumerate() {
            let sy = (y + t).saturating_sub(r).min(height - 1);
            for (d, &s) in dst.iter_mut().zip(&src[sy * width..(sy + 1) * width]) {
                *d += w * s;
            }
        }
    }
    out
}

fn check_dims(len: usize, width: usize, height: usize) {
    assert_eq!(len, width * height, "image has {len} pixels, expected {width}×{height}");
}

/// Blurs a YCxCz image with the CSF filters (clamp-to-edge borders) and returns
/// the filtered YCxCz image. Row-major, `width × height`.
pub fn csf_filter(ycxcz: &[Vec3], width: usize, height: usize, filters: &SpatialFilters) -> Vec<Vec3> {
    check_dims(ycxcz.len(), width, height);
    if ycxcz.is_empty() {
        return Vec::new();
    }
    let plane = |c: usize| ycxcz.iter().map(|p| p[c]).collect::<Vec<f32>>();
    let [y] = filter_rows(&plane(0), width, [&filters.achromatic]);
    let [cx] = filter_rows(&plane(1), width, [&filters.red_green]);
    let [cz1, cz2] = filter_rows(&plane(2), width, [&filters.blue_yellow[0], &filters.blue_yellow[1]]);
    let y = filter_columns(&y, width, &filters.achromatic);
    let cx = filter_columns(&cx, width, &filters.red_green);
    let cz1 = filter_columns(&cz1, width, &filters.blue_yellow[0]);
    let cz2 = filter_columns(&cz2, width, &filters.blue_yellow[1]);
    (0..ycxcz.len()).map(|i| Vec3::new(y[i], cx[i], cz1[i] + cz2[i])).collect()
}

/// Per-pixel `[edge, point]` response magnitudes of a YCxCz image: the length
/// of the (x, y) gradient of the first- and second-derivative detectors applied
/// to the achromatic channel normalised to [0, 1]. Clamp-to-edge borders.
pub fn feature_magnitudes(ycxcz: &[Vec3], width: usize, height: usize, filters: &FeatureFilters) -> Vec<[f32; 2]> {
    check_dims(ycxcz.len(), width, height);
    if ycxcz.is_empty() {
        return Vec::new();
    }
    let luma: Vec<f32> = ycxcz.iter().map(|p| p.x * (1.0 / 116.0) + 16.0 / 116.0).collect();
    let [dx, ddx, g] = filter_rows(&luma, width, [&filters.edge, &filters.point, &filters.gaussian]);
    let dx = filter_columns(&dx, width, &filters.gaussian);
    let ddx = filter_columns(&ddx, width, &filters.gaussian);
    let dy = filter_columns(&g, width, &filters.edge);
    let ddy = filter_columns(&g, width, &filters.point);
    (0..luma.len())
        .map(|i| [(dx[i] * dx[i] + dy[i] * dy[i]).sqrt(), (ddx[i] * ddx[i] + ddy[i] * ddy[i]).sqrt()])
        .collect()
}

fn to_ycxcz(srgb: &[[f32; 3]]) -> Vec<Vec3> {
    srgb.iter().map(|&c| srgb_to_ycxcz(Vec3::from_array(c))).collect()
}

fn check_pair(reference: &[[f32; 3]], test: &[[f32; 3]], width: usize, height: usize, ppd: f32) {
    check_dims(reference.len(), width, height);
    check_dims(test.len(), width, height);
    assert!(ppd > 0.0 && ppd.is_finite(), "pixels per degree must be positive, got {ppd}");
}

/// Per-pixel colour error (the colour pipeline alone, in [0, 1]) between two
/// sRGB-encoded images. Row-major, `width × height`.
pub fn color_error_map(reference: &[[f32; 3]], test: &[[f32; 3]], width: usize, height: usize, ppd: f32) -> Vec<f32> {
    check_pair(reference, test, width, height, ppd);
    color_errors(&to_ycxcz(reference), &to_ycxcz(test), width, height, ppd)
}

fn color_errors(reference: &[Vec3], test: &[Vec3], width: usize, height: usize, ppd: f32) -> Vec<f32> {
    let filters = spatial_filters(ppd);
    let cmax = max_color_distance();
    let r = csf_filter(reference, width, height, &filters);
    let t = csf_filter(test, width, height, &filters);
    r.iter().zip(&t).map(|(&r, &t)| color_error(r, t, cmax)).collect()
}

/// Per-pixel feature error (the feature pipeline alone, in [0, 1]) between two
/// sRGB-encoded images. Row-major, `width × height`.
pub fn feature_error_map(reference: &[[f32; 3]], test: &[[f32; 3]], width: usize, height: usize, ppd: f32) -> Vec<f32> {
    check_pair(reference, test, width, height, ppd);
    feature_errors(&to_ycxcz(reference), &to_ycxcz(test), width, height, ppd)
}

fn feature_errors(reference: &[Vec3], test: &[Vec3], width: usize, height: usize, ppd: f32) -> Vec<f32> {
    let filters = feature_filters(ppd);
    let r = feature_magnitudes(reference, width, height, &filters);
    let t = feature_magnitudes(test, width, height, &filters);
    r.iter().zip(&t).map(|(&r, &t)| feature_error(r, t)).collect()
}

/// Per-pixel LDR-FLIP error in [0, 1] between a reference and a test image.
///
/// Both images are row-major `width × height` arrays of sRGB-encoded colours
/// in [0, 1] (the caller clamps and encodes); `ppd` is the observer's pixels
/// per degree, usually [`ppd_default`].
///
/// # Panics
/// If either slice does not hold `width · height` pixels or `ppd` is not a
/// positive finite number.
pub fn flip_error_map(reference: &[[f32; 3]], test: &[[f32; 3]], width: usize, height: usize, ppd: f32) -> Vec<f32> {
    check_pair(reference, test, width, height, ppd);
    let r = to_ycxcz(reference);
    let t = to_ycxcz(test);
    let color = color_errors(&r, &t, width, height, ppd);
    let feature = feature_errors(&r, &t, width, height, ppd);
    color.iter().zip(&feature).map(|(&c, &f)| combine_errors(c, f)).collect()
}

/// Mean of [`flip_error_map`] over all pixels; 0 for an empty image.
///
/// The sum is taken in f64. NVIDIA's tool sums in f32, so on megapixel images
/// the mean it prints can differ from this one in the fourth decimal even
/// though the per-pixel maps agree to about 1e-6.
///
/// # Panics
/// As [`flip_error_map`].
pub fn mean_flip(reference: &[[f32; 3]], test: &[[f32; 3]], width: usize, height: usize, ppd: f32) -> f32 {
    let map = flip_error_map(reference, test, width, height, ppd);
    if map.is_empty() {
        return 0.0;
    }
    (map.iter().map(|&e| f64::from(e)).sum::<f64>() / map.len() as f64) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    fn assert_close(actual: f32, expected: f32, tol: f32, what: &str) {
        assert!((actual - expected).abs() <= tol, "{what}: got {actual}, expected {expected} ± {tol}");
    }

    fn assert_vec_close(actual: Vec3, expected: Vec3, tol: f32, what: &str) {
        assert!(actual.abs_diff_eq(expected, tol), "{what}: got {actual}, expected {expected} ± {tol}");
    }

    fn uniform(width: usize, height: usize, c: [f32; 3]) -> Vec<[f32; 3]> {
        vec![c; width * height]
    }

    // Integer patterns, so that the Python script that produced the reference
    // values below builds bit-identical inputs.
    fn noise(width: usize, height: usize, seed: usize) -> Vec<[f32; 3]> {
        let mut img = Vec::with_capacity(width * height);
        for y in 0..height {
            for x in 0..width {
                img.push(std::array::from_fn(|c| ((x * 7 + y * 13 + c * 5 + seed * (x * y % 3)) % 17) as f32 / 16.0));
            }
        }
        img
    }

    fn gradient(width: usize, height: usize, square: bool) -> Vec<[f32; 3]> {
        let mut img = Vec::with_capacity(width * height);
        for y in 0..height {
            for x in 0..width {
                let inside = (width / 3..2 * width / 3).contains(&x) && (height / 3..2 * height / 3).contains(&y);
                img.push(if square && inside {
                    [0.75; 3]
                } else {
                    [x as f32 / (width - 1) as f32, y as f32 / (height - 1) as f32, 0.25]
                });
            }
        }
        img
    }

    fn mirror_x<T: Copy>(img: &[T], width: usize) -> Vec<T> {
        img.chunks_exact(width).flat_map(|row| row.iter().rev().copied()).collect()
    }

    fn transpose<T: Copy>(img: &[T], width: usize, height: usize) -> Vec<T> {
        (0..width).flat_map(|x| (0..height).map(move |y| img[y * width + x])).collect()
    }

    #[test]
    fn default_ppd_is_a_4k_monitor_at_arms_length() {
        // 3840·π/180; the reference tool reports it as 67.0206 and names it "67 PPD".
        assert_close(ppd_default(), 67.020_65, 1e-4, "ppd_default");
        assert_eq!(ppd_default().round(), 67.0);
    }

    #[test]
    fn srgb_decoding_matches_known_values() {
        assert_close(srgb_decode(0.5), 0.214_041, 1e-5, "sRGB 0.5");
        assert_eq!(srgb_decode(0.0), 0.0);
        assert_close(srgb_decode(1.0), 1.0, 1e-6, "sRGB 1");
        // Linear toe below the 0.04045 threshold.
        assert_close(srgb_decode(0.04), 0.04 / 12.92, 1e-9, "sRGB 0.04");
        // The two branches meet at the threshold.
        assert_close(srgb_decode(0.040_451), srgb_decode(0.04045), 1e-6, "continuity");
    }

    #[test]
    fn linear_white_maps_to_d65_in_xyz() {
        let white = linear_rgb_to_xyz(Vec3::ONE);
        assert_vec_close(white, Vec3::new(0.9505, 1.0, 1.089), 1e-4, "XYZ of white");
        assert_vec_close(white, D65_WHITE, 1e-6, "XYZ of white vs D65_WHITE");
        // Y of the primaries are the Rec. 709 luma weights.
        assert_close(linear_rgb_to_xyz(Vec3::X).y, 0.2126, 1e-4, "Y of red");
        assert_close(linear_rgb_to_xyz(Vec3::Y).y, 0.7152, 1e-4, "Y of green");
        assert_close(linear_rgb_to_xyz(Vec3::Z).y, 0.0722, 1e-4, "Y of blue");
    }

    #[test]
    fn xyz_and_linear_rgb_round_trip() {
        for rgb in [Vec3::new(0.2, 0.5, 0.9), Vec3::new(1.0, 0.0, 0.3), Vec3::splat(0.18)] {
            assert_vec_close(xyz_to_linear_rgb(linear_rgb_to_xyz(rgb)), rgb, 1e-5, "RGB→XYZ→RGB");
        }
    }

    #[test]
    fn lab_of_known_colours() {
        assert_vec_close(xyz_to_lab(D65_WHITE), Vec3::new(100.0, 0.0, 0.0), 1e-3, "Lab of white");
        assert_vec_close(xyz_to_lab(Vec3::ZERO), Vec3::ZERO, 1e-3, "Lab of black");
        // Standard CIELab (D65) values of the sRGB primaries.
        let lab = |rgb: Vec3| xyz_to_lab(linear_rgb_to_xyz(rgb));
        assert_vec_close(lab(Vec3::X), Vec3::new(53.24, 80.09, 67.20), 0.05, "Lab of red");
        assert_vec_close(lab(Vec3::Y), Vec3::new(87.73, -86.18, 83.18), 0.05, "Lab of green");
        assert_vec_close(lab(Vec3::Z), Vec3::new(32.30, 79.19, -107.86), 0.05, "Lab of blue");
        // 18% grey is L* ≈ 49.5, achromatic.
        assert_vec_close(lab(Vec3::splat(0.18)), Vec3::new(49.50, 0.0, 0.0), 0.01, "Lab of 18% grey");
    }

    #[test]
    fn ycxcz_round_trips_and_agrees_with_lab_at_white() {
        assert_vec_close(xyz_to_ycxcz(D65_WHITE), Vec3::new(100.0, 0.0, 0.0), 1e-3, "YCxCz of white");
        assert_vec_close(xyz_to_ycxcz(Vec3::ZERO), Vec3::new(-16.0, 0.0, 0.0), 1e-6, "YCxCz of black");
        for xyz in [Vec3::new(0.3, 0.4, 0.5), Vec3::new(0.9, 0.1, 0.05), D65_WHITE] {
            assert_vec_close(ycxcz_to_xyz(xyz_to_ycxcz(xyz)), xyz, 1e-5, "XYZ→YCxCz→XYZ");
        }
        assert_vec_close(srgb_to_ycxcz(Vec3::ONE), Vec3::new(100.0, 0.0, 0.0), 1e-3, "sRGB white → YCxCz");
    }

    #[test]
    fn hunt_adjustment_scales_chroma_by_lightness() {
        assert_eq!(hunt_adjust(Vec3::new(50.0, 20.0, -40.0)), Vec3::new(50.0, 10.0, -20.0));
        assert_eq!(hunt_adjust(Vec3::new(100.0, 20.0, -40.0)), Vec3::new(100.0, 20.0, -40.0));
        assert_eq!(hunt_adjust(Vec3::new(0.0, 20.0, -40.0)), Vec3::ZERO);
    }

    #[test]
    fn hyab_is_city_block_in_l_plus_euclidean_in_ab() {
        let a = Vec3::new(60.0, 10.0, 10.0);
        let b = Vec3::new(50.0, 13.0, 14.0);
        assert_close(hyab(a, b), 10.0 + 5.0, 1e-5, "HyAB");
        assert_eq!(hyab(a, b), hyab(b, a));
        assert_eq!(hyab(a, a), 0.0);
    }

    #[test]
    fn cmax_is_compressed_green_blue_distance() {
        // Hunt-adjusted Lab of green (87.73, −75.61, 72.97) and blue
        // (32.30, 25.58, −34.84): HyAB ≈ 55.43 + 147.8 ≈ 203.3, and 203.3^0.7 ≈ 41.3.
        let cmax = max_color_distance();
        assert_close(cmax.powf(1.0 / QC), 203.3, 0.2, "HyAB(green, blue)");
        assert_close(cmax, 203.3f32.powf(0.7), 0.05, "cmax");
    }

    #[test]
    fn redistribution_maps_breakpoints_and_is_monotone() {
        let cmax = max_color_distance();
        assert_eq!(redistribute_color_error(0.0, cmax), 0.0);
        assert_close(redistribute_color_error(PC * cmax, cmax), PT, 1e-6, "at pc·cmax");
        assert_close(redistribute_color_error(cmax, cmax), 1.0, 1e-6, "at cmax");
        assert_close(redistribute_color_error(0.5 * PC * cmax, cmax), 0.5 * PT, 1e-6, "halfway below knee");
        let mut last = -1.0;
        for i in 0..=100 {
            let e = redistribute_color_error(cmax * i as f32 / 100.0, cmax);
            assert!(e > last, "not increasing at step {i}: {e} <= {last}");
            last = e;
        }
    }

    #[test]
    fn feature_error_and_combination() {
        assert_eq!(feature_error([0.3, 0.2], [0.3, 0.2]), 0.0);
        // Larger of the two differences, scaled by 1/√2, square-rooted.
        assert_close(feature_error([0.5, 0.1], [0.1, 0.2]), (0.4f32 / 2f32.sqrt()).sqrt(), 1e-6, "edge dominates");
        assert_close(feature_error([0.0, 2f32.sqrt()], [0.0, 0.0]), 1.0, 1e-6, "maximal difference");
        assert_eq!(combine_errors(0.25, 0.0), 0.25);
        assert_close(combine_errors(0.25, 0.5), 0.5, 1e-6, "0.25^0.5");
        assert_eq!(combine_errors(0.25, 1.0), 1.0);
        assert_eq!(combine_errors(0.0, 0.5), 0.0);
    }

    #[test]
    fn csf_filters_are_normalised_and_sized() {
        let ppd = ppd_default();
        let f = spatial_filters(ppd);
        let r = spatial_filter_radius(ppd);
        // ceil(3·√(0.04 / 2π²)·67.02) = ceil(9.05).
        assert_eq!(r, 10);
        for k in [&f.achromatic, &f.red_green, &f.blue_yellow[0], &f.blue_yellow[1]] {
            assert_eq!(k.len(), 2 * r + 1);
            assert!(k.iter().zip(k.iter().rev()).all(|(a, b)| a == b), "CSF factor not symmetric");
        }
        let sum = |k: &[f32]| k.iter().sum::<f32>();
        assert_close(sum(&f.achromatic), 1.0, 1e-5, "achromatic sum");
        assert_close(sum(&f.red_green), 1.0, 1e-5, "red-green sum");
        let by = sum(&f.blue_yellow[0]).powi(2) + sum(&f.blue_yellow[1]).powi(2);
        assert_close(by, 1.0, 1e-5, "2D blue-yellow sum");
    }

    #[test]
    fn separable_csf_equals_the_2d_sum_of_gaussians() {
        // The 2D kernel as the paper and the reference's Python code define it.
        let ppd = 40.0;
        let f = spatial_filters(ppd);
        let r = spatial_filter_radius(ppd) as i32;
        let channels: [(CsfParams, Vec<&[f32]>); 3] = [
            (CSF_ACHROMATIC, vec![&f.achromatic]),
            (CSF_RED_GREEN, vec![&f.red_green]),
            (CSF_BLUE_YELLOW, vec![&f.blue_yellow[0], &f.blue_yellow[1]]),
        ];
        for (p, factors) in channels {
            let full = |x: i32, y: i32| {
                let z = ((x * x + y * y) as f64) / f64::from(ppd * ppd);
                let pi = std::f64::consts::PI;
                let g =
                    |a: f32, b: f32| f64::from(a) * (pi / f64::from(b)).sqrt() * (-pi * pi * z / f64::from(b)).exp();
                g(p.a1, p.b1) + g(p.a2, p.b2)
            };
            let total: f64 = (-r..=r).flat_map(|y| (-r..=r).map(move |x| (x, y))).map(|(x, y)| full(x, y)).sum();
            for y in -r..=r {
                for x in -r..=r {
                    let expected = (full(x, y) / total) as f32;
                    let (i, j) = ((x + r) as usize, (y + r) as usize);
                    let got: f32 = factors.iter().map(|k| k[i] * k[j]).sum();
                    assert_close(got, expected, 1e-6, &format!("{p:?} at ({x}, {y})"));
                }
            }
        }
    }

    #[test]
    fn feature_filters_are_normalised_and_sized() {
        let ppd = ppd_default();
        let f = feature_filters(ppd);
        // σ = 0.5·0.082·67.02 ≈ 2.748 px, radius ceil(3σ) = 9.
        assert_close(feature_filter_std_dev(ppd), 2.7478, 1e-3, "σ");
        assert_eq!(feature_filter_radius(ppd), 9);
        let n = 2 * 9 + 1;
        assert!(f.gaussian.len() == n && f.edge.len() == n && f.point.len() == n);
        let sum = |k: &[f32]| k.iter().sum::<f32>();
        let pos = |k: &[f32]| k.iter().filter(|&&w| w > 0.0).sum::<f32>();
        assert_close(sum(&f.gaussian), 1.0, 1e-6, "gaussian sum");
        assert_close(sum(&f.edge), 0.0, 1e-6, "edge sum");
        assert_close(sum(&f.point), 0.0, 1e-6, "point sum");
        assert_close(pos(&f.edge), 1.0, 1e-6, "edge positive mass");
        assert_close(pos(&f.point), 1.0, 1e-6, "point positive mass");
        for i in 0..n {
            // Up to rounding: each sign is divided by its own (float) sum.
            assert_close(f.edge[i], -f.edge[n - 1 - i], 1e-7, "edge filter odd");
            assert_close(f.point[i], f.point[n - 1 - i], 1e-7, "point filter even");
        }
        // Negated derivative, as in the reference: positive taps on the left.
        assert!(f.edge[0] > 0.0 && f.edge[n - 1] < 0.0);
        // Second derivative is negative at the centre.
        assert!(f.point[9] < 0.0);
    }

    #[test]
    fn csf_filter_preserves_uniform_images_and_clamps_borders() {
        let (w, h) = (7, 5);
        let img = vec![Vec3::new(40.0, -12.0, 30.0); w * h];
        let f = spatial_filters(ppd_default());
        // Kernel (21 taps) wider than the image: only clamp-to-edge keeps it uniform.
        for p in csf_filter(&img, w, h, &f) {
            assert_vec_close(p, Vec3::new(40.0, -12.0, 30.0), 1e-3, "filtered uniform image");
        }
        let mags = feature_magnitudes(&img, w, h, &feature_filters(ppd_default()));
        assert!(mags.iter().all(|m| m[0].abs() < 1e-6 && m[1].abs() < 1e-6), "features in a uniform image");
    }

    #[test]
    fn edge_detector_responds_to_a_step_and_point_detector_to_a_dot() {
        let (w, h) = (41, 41);
        let ppd = ppd_default();
        let f = feature_filters(ppd);
        let step: Vec<Vec3> =
            (0..w * h).map(|i| Vec3::new(if i % w < w / 2 { -16.0 } else { 100.0 }, 0.0, 0.0)).collect();
        let m = feature_magnitudes(&step, w, h, &f);
        let at = |x: usize, y: usize| m[y * w + x];
        // A unit step (normalised Y 0 → 1) gives an edge response near the
        // positive mass of the edge filter, 1, straddling the step.
        assert!(at(w / 2, h / 2)[0] > 0.3, "edge at step: {:?}", at(w / 2, h / 2));
        assert!(at(2, h / 2)[0] < 1e-6, "edge far from step: {:?}", at(2, h / 2));
        let mut dot = vec![Vec3::new(-16.0, 0.0, 0.0); w * h];
        dot[(h / 2) * w + w / 2] = Vec3::new(100.0, 0.0, 0.0);
        let m = feature_magnitudes(&dot, w, h, &f);
        assert!(m[(h / 2) * w + w / 2][1] > m[(h / 2) * w + w / 2][0], "point beats edge at a dot");
    }

    #[test]
    fn identical_images_have_exactly_zero_error() {
        for (w, h) in [(23, 17), (1, 1), (3, 40)] {
            let img = noise(w, h, 2);
            let map = flip_error_map(&img, &img, w, h, ppd_default());
            assert!(map.iter().all(|&e| e == 0.0), "nonzero error for identical {w}×{h} images");
            assert_eq!(mean_flip(&img, &img, w, h, ppd_default()), 0.0);
        }
    }

    #[test]
    fn black_versus_white_is_close_to_one() {
        // Uniform images have no features, so this is the colour term alone:
        // HyAB(black, white) = 100, 100^0.7 = 25.12 is above pc·cmax ≈ 16.5, so
        // the error lands in (pt, 1]. The reference (flip-evaluator 1.7 from
        // PyPI) gives 0.967388 at every pixel, either way round.
        let (w, h) = (16, 12);
        let black = uniform(w, h, [0.0; 3]);
        let white = uniform(w, h, [1.0; 3]);
        for map in
            [flip_error_map(&black, &white, w, h, ppd_default()), flip_error_map(&white, &black, w, h, ppd_default())]
        {
            for e in map {
                assert_close(e, 0.967_388, 2e-5, "black vs white");
            }
        }
        // Zero up to the rounding of the filters' zero sums (amplified by the square root).
        assert!(feature_error_map(&black, &white, w, h, ppd_default()).iter().all(|&f| f < 1e-3));
    }

    #[test]
    fn error_is_symmetric_in_reference_and_test() {
        let (w, h) = (23, 17);
        let (a, b) = (noise(w, h, 0), gradient(w, h, true));
        assert_eq!(flip_error_map(&a, &b, w, h, 30.0), flip_error_map(&b, &a, w, h, 30.0));
    }

    #[test]
    fn error_map_mirrors_and_transposes_with_the_images() {
        let (w, h) = (23, 17);
        let ppd = ppd_default();
        let (a, b) = (noise(w, h, 0), noise(w, h, 1));
        let base = flip_error_map(&a, &b, w, h, ppd);
        let mirrored = flip_error_map(&mirror_x(&a, w), &mirror_x(&b, w), w, h, ppd);
        let transposed = flip_error_map(&transpose(&a, w, h), &transpose(&b, w, h), h, w, ppd);
        // Filters are symmetric, so only summation order differs.
        for (x, y) in mirror_x(&base, w).iter().zip(&mirrored) {
            assert_close(*y, *x, 1e-4, "mirrored map");
        }
        for (x, y) in transpose(&base, w, h).iter().zip(&transposed) {
            assert_close(*y, *x, 1e-4, "transposed map");
        }
    }

    #[test]
    fn error_grows_with_a_growing_offset() {
        let (w, h) = (32, 24);
        let ppd = ppd_default();
        // Mid-range texture, so that offsets up to 0.3 stay inside [0, 1].
        let reference: Vec<[f32; 3]> = noise(w, h, 1).iter().map(|c| c.map(|v| 0.3 + 0.4 * v)).collect();
        let mut last = 0.0;
        for step in 1..=6 {
            let offset = 0.05 * step as f32;
            let test: Vec<[f32; 3]> = reference.iter().map(|c| c.map(|v| v + offset)).collect();
            let mean = mean_flip(&reference, &test, w, h, ppd);
            assert!(mean > last, "mean FLIP did not grow at offset {offset}: {mean} <= {last}");
            last = mean;
        }
        // Same for a flat grey image, pixel by pixel.
        let grey = uniform(4, 4, [0.2; 3]);
        let mut last = 0.0;
        for step in 1..=8 {
            let test = uniform(4, 4, [0.2 + 0.1 * step as f32; 3]);
            let e = flip_error_map(&grey, &test, 4, 4, ppd)[5];
            assert!(e > last, "error did not grow at step {step}: {e} <= {last}");
            last = e;
        }
    }

    #[test]
    fn errors_stay_in_unit_interval() {
        let (w, h) = (23, 17);
        for (a, b) in [(noise(w, h, 0), noise(w, h, 3)), (noise(w, h, 1), gradient(w, h, true))] {
            for ppd in [5.0, 20.0, ppd_default()] {
                assert!(flip_error_map(&a, &b, w, h, ppd).iter().all(|e| (0.0..=1.0).contains(e)));
            }
        }
    }

    /// Per-pixel values and means computed by NVIDIA's own implementation
    /// (`flip_evaluator.evaluate(ref, test, "LDR")` from the `flip-evaluator`
    /// 1.7 package on PyPI, i.e. the C++ code of NVlabs/flip) on the same
    /// integer-built images. They are not published values: NVlabs/flip
    /// publishes a mean of 0.159691 only for its own example PNGs.
    #[test]
    fn matches_reference_implementation_on_synthetic_images() {
        type Case =
            (&'static str, usize, usize, Vec<[f32; 3]>, Vec<[f32; 3]>, Option<f32>, f32, [(usize, usize, f32); 7]);
        let cases: [Case; 4] = [
            (
                "noise 23×17",
                23,
                17,
                noise(23, 17, 0),
                noise(23, 17, 1),
                None,
                0.263_065_6,
                [
                    (0, 0, 0.100_499_6),
                    (22, 0, 0.273_201_3),
                    (0, 16, 0.561_724_1),
                    (22, 16, 0.235_834_4),
                    (11, 8, 0.443_351_5),
                    (7, 8, 0.224_048_1),
                    (11, 1, 0.146_315),
                ],
            ),
            (
                "noise 23×17, 20 ppd",
                23,
                17,
                noise(23, 17, 0),
                noise(23, 17, 1),
                Some(20.0),
                0.348_601_2,
                [
                    (0, 0, 0.065_015_1),
                    (22, 0, 0.092_819_9),
                    (0, 16, 0.329_406_7),
                    (22, 16, 0.259_369_3),
                    (11, 8, 0.983_664_9),
                    (7, 8, 0.491_344_8),
                    (11, 1, 0.819_814_5),
                ],
            ),
            (
                "gradient with square 40×30",
                40,
                30,
                gradient(40, 30, false),
                gradient(40, 30, true),
                None,
                0.168_578_7,
                [
                    (0, 0, 0.0),
                    (39, 0, 0.0),
                    (0, 29, 0.0),
                    (39, 29, 0.0),
                    (20, 15, 0.864_608_2),
                    (13, 15, 0.801_864),
                    (20, 1, 0.004_344),
                ],
            ),
            (
                "noise 4×3 (smaller than the filters)",
                4,
                3,
                noise(4, 3, 0),
                noise(4, 3, 1),
                None,
                0.323_910_8,
                [
                    (0, 0, 0.114_761_5),
                    (3, 0, 0.278_595_6),
                    (0, 2, 0.383_074_7),
                    (3, 2, 0.313_302_7),
                    (2, 1, 0.375_435_6),
                    (1, 1, 0.295_914_9),
                    (2, 1, 0.375_435_6),
                ],
            ),
        ];
        for (name, w, h, reference, test, ppd, mean, pixels) in cases {
            let ppd = ppd.unwrap_or_else(ppd_default);
            let map = flip_error_map(&reference, &test, w, h, ppd);
            for (x, y, expected) in pixels {
                assert_close(map[y * w + x], expected, 2e-5, &format!("{name} at ({x}, {y})"));
            }
            assert_close(mean_flip(&reference, &test, w, h, ppd), mean, 2e-6, &format!("{name} mean"));
        }
    }

    #[test]
    #[should_panic(expected = "expected 4×4")]
    fn mismatched_dimensions_panic() {
        flip_error_map(&uniform(4, 4, [0.0; 3]), &uniform(4, 3, [0.0; 3]), 4, 4, 67.0);
    }
}
