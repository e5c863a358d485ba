//! FLIP's per-image results: the colour, feature and combined error maps of a
//! reference/test pair of sRGB images, and their mean.

use glam::Vec3;

use super::color::{color_error, combine_errors, feature_error, max_color_distance, srgb_to_ycxcz};
use super::filter::{check_dims, csf_filter, feature_filters, feature_magnitudes, spatial_filters};

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
/// per degree, usually [`ppd_default`](super::ppd_default).
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
