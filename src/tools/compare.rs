//! Image comparison: RMSE, relative MSE and PSNR on linear values, and the mean
//! LDR-FLIP error on clamped sRGB values (what `wavetrace compare` prints), and reading
//! PNG or EXR images as linear RGB. Without the `flip` feature the FLIP error is NaN;
//! without `exr`, reading an EXR is an input error that names the feature.

use glam::Vec3;
use serde::Serialize;
use std::path::Path;

use crate::color::srgb_decode;
use crate::film::Image;
use crate::{Error, Result};

/// Reads a PNG (decoded from sRGB) or an EXR (already linear) as linear RGB.
pub fn load_linear(path: &Path) -> Result<Image> {
    let bad = |msg: String| Error::input(format!("image `{}`: {msg}", path.display()));
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("png") => {
            let img = image::open(path).map_err(|e| bad(e.to_string()))?.to_rgb8();
            let (width, height) = img.dimensions();
            let pixels = img.pixels().map(|p| Vec3::from_array(p.0.map(|c| srgb_decode(c as f32 / 255.0)))).collect();
            Ok(Image { width, height, pixels })
        }
        Some("exr") => read_exr(path).map_err(bad),
        _ => Err(bad("unknown extension (expected .png or .exr)".into())),
    }
}

/// Refuses an EXR whose pixels would not fit in half the available memory, from its
/// headers alone: a few bytes of header can declare a 2^31-pixel window, and decoding
/// allocates the window before it reads a pixel. `frame_bytes` is what the caller holds
/// per pixel of the display window besides the decoded layer (a merge's frame).
#[cfg(feature = "exr")]
pub fn check_exr_fits(path: &Path, frame_bytes: u64) -> std::result::Result<(), String> {
    let meta = exr::meta::MetaData::read_from_file(path, false).map_err(|e| format!("not a readable EXR: {e}"))?;
    let have = crate::system::available_memory() / 2;
    for h in meta.headers.iter() {
        let (layer, frame) = (h.layer_size, h.shared_attributes.display_window.size);
        let need = (layer.area() as u64)
            .saturating_mul(std::mem::size_of::<Vec3>() as u64)
            .saturating_add((frame.area() as u64).saturating_mul(frame_bytes));
        if need > have {
            return Err(format!(
                "its {}×{} pixels (display window {}×{}) need {need} bytes, more than half the available memory ({have} bytes)",
                layer.width(),
                layer.height(),
                frame.width(),
                frame.height()
            ));
        }
    }
    Ok(())
}

/// Reads an EXR's first RGBA layer as linear RGB.
#[cfg(feature = "exr")]
fn read_exr(path: &Path) -> std::result::Result<Image, String> {
    check_exr_fits(path, 0)?;
    let read = exr::prelude::read_first_rgba_layer_from_file(
        path,
        |res, _| (res.width(), vec![Vec3::ZERO; res.width() * res.height()]),
        |(w, px): &mut (usize, Vec<Vec3>), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            px[pos.y() * *w + pos.x()] = Vec3::new(r, g, b)
        },
    )
    .map_err(|e| e.to_string())?;
    let size = read.layer_data.size;
    let (_, pixels) = read.layer_data.channel_data.pixels;
    Ok(Image { width: size.width() as u32, height: size.height() as u32, pixels })
}

/// Without the `exr` feature: the error that says so.
#[cfg(not(feature = "exr"))]
fn read_exr(_: &Path) -> std::result::Result<Image, String> {
    Err(crate::tools::output::NEEDS_EXR.into())
}

/// Differences between a test image and a reference.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Metrics {
    /// Root-mean-square difference over all pixels and channels, linear values.
    pub rmse: f64,
    /// Mean over pixels and channels of (test - ref)² / (ref² + 0.01), linear values.
    pub rel_mse: f64,
    /// 10·log10(1 / MSE), linear values with peak 1; infinite for identical images.
    pub psnr: f64,
    /// Mean LDR-FLIP error (NVIDIA, Andersson et al. 2020) at FLIP's default 67 pixels
    /// per degree, both images clamped to [0, 1] and sRGB-encoded first. NaN (`null` in
    /// JSON) when built without the `flip` feature.
    pub flip: f64,
}

/// Compares `test` against `reference`; they must have the same size.
pub fn metrics(test: &Image, reference: &Image) -> Result<Metrics> {
    if (test.width, test.height) != (reference.width, reference.height) {
        return Err(Error::input(format!(
            "images differ in size: {}×{} vs {}×{}",
            test.width, test.height, reference.width, reference.height
        )));
    }
    let (mut se, mut rel) = (0.0f64, 0.0f64);
    for (t, r) in test.pixels.iter().zip(&reference.pixels) {
        for c in 0..3 {
            let (t, r) = (t[c] as f64, r[c] as f64);
            se += (t - r) * (t - r);
            rel += (t - r) * (t - r) / (r * r + 0.01);
        }
    }
    let n = (3 * test.pixels.len()).max(1) as f64;
    let mse = se / n;
    Ok(Metrics {
        rmse: mse.sqrt(),
        rel_mse: rel / n,
        psnr: 10.0 * (1.0 / mse).log10(),
        flip: mean_flip(test, reference),
    })
}

/// The mean LDR-FLIP error of `test` against `reference` (same size), both clamped to
/// [0, 1] and sRGB-encoded.
#[cfg(feature = "flip")]
fn mean_flip(test: &Image, reference: &Image) -> f64 {
    use crate::color::srgb_encode;
    use crate::tools::flip;
    let ldr = |img: &Image| -> Vec<[f32; 3]> { img.pixels.iter().map(|p| p.to_array().map(srgb_encode)).collect() };
    let (w, h) = (test.width as usize, test.height as usize);
    flip::mean_flip(&ldr(reference), &ldr(test), w, h, flip::ppd_default()) as f64
}

/// Without the `flip` feature: NaN.
#[cfg(not(feature = "flip"))]
fn mean_flip(_: &Image, _: &Image) -> f64 {
    f64::NAN
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::color::srgb_encode;

    fn img(px: &[f32]) -> Image {
        Image { width: px.len() as u32, height: 1, pixels: px.iter().map(|&v| Vec3::splat(v)).collect() }
    }

    #[test]
    fn identical_images_have_zero_error() {
        let m = metrics(&img(&[0.1, 0.5, 2.0]), &img(&[0.1, 0.5, 2.0])).unwrap();
        assert_eq!(m.rmse, 0.0);
        assert_eq!(m.rel_mse, 0.0);
        assert!(m.psnr.is_infinite());
        #[cfg(feature = "flip")]
        assert_eq!(m.flip, 0.0);
    }

    #[test]
    #[cfg(feature = "flip")]
    fn flip_of_black_against_white() {
        // FLIP's colour term alone (no edges): 0.967388 per pixel, from NVIDIA's code.
        let black = Image { width: 8, height: 8, pixels: vec![Vec3::ZERO; 64] };
        let white = Image { width: 8, height: 8, pixels: vec![Vec3::ONE; 64] };
        assert!((metrics(&black, &white).unwrap().flip - 0.967388).abs() < 1e-4);
        // HDR values clamp: 5.0 reads as white.
        let bright = Image { width: 8, height: 8, pixels: vec![Vec3::splat(5.0); 64] };
        assert_eq!(metrics(&bright, &white).unwrap().flip, 0.0);
    }

    #[test]
    fn known_values() {
        // Differences 0.1 and 0.3 on every channel: MSE = (0.01 + 0.09) / 2 = 0.05.
        let m = metrics(&img(&[0.6, 0.3]), &img(&[0.5, 0.0])).unwrap();
        assert!((m.rmse - 0.05f64.sqrt()).abs() < 1e-6);
        assert!((m.psnr - 10.0 * 20.0f64.log10()).abs() < 1e-4);
        let rel = (0.01 / (0.25 + 0.01) + 0.09 / 0.01) / 2.0;
        assert!((m.rel_mse - rel).abs() < 1e-5);
    }

    #[test]
    fn size_mismatch_is_an_error() {
        assert!(metrics(&img(&[0.0]), &img(&[0.0, 0.0])).is_err());
    }

    #[test]
    fn srgb_round_trip() {
        for v in [0.0f32, 0.001, 0.2, 0.5, 1.0] {
            assert!((srgb_decode(srgb_encode(v)) - v).abs() < 1e-5);
        }
    }
}
