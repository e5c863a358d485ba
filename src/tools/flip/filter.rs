//! FLIP's filters: the contrast sensitivity (CSF) filters of the colour pipeline and
//! the edge and point detectors of the feature pipeline, applied separably with
//! clamp-to-edge borders.

use glam::Vec3;
use std::f32::consts::PI;

use super::FEATURE_WIDTH_DEG;

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

pub(super) fn check_dims(len: usize, width: usize, height: usize) {
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
