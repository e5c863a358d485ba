//! Writing results: PNG (8-bit sRGB, clamped) and EXR (linear 32-bit float RGB), and
//! text files. Every file is written to a temporary file in the same folder and
//! renamed, so an error never leaves a partial file or clobbers an earlier one.
//! Without the `exr` feature an `.exr` path is refused before any work, with a message
//! that names the feature.

use std::io::Write;
use std::path::{Path, PathBuf};

use crate::color::to_display8;
use crate::film::{Image, Tile};
use crate::{Error, Result};

/// Image file formats, picked by the output's extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// `.png`: 8-bit sRGB, values clamped to [0, 1].
    Png,
    /// `.exr`: linear 32-bit float RGB.
    Exr,
}

/// What an EXR read or write says when the crate is built without the `exr` feature.
pub const NEEDS_EXR: &str = "EXR needs the `exr` feature (cargo build --features exr)";

/// Checks an output path before any work starts: a known extension (EXR only with the
/// `exr` feature) and an existing folder.
pub fn check_image_path(path: &Path) -> Result<Format> {
    let format = match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
        Some("png") => Format::Png,
        Some("exr") if cfg!(feature = "exr") => Format::Exr,
        Some("exr") => return Err(Error::output(path, NEEDS_EXR)),
        Some(e) => return Err(Error::output(path, format!("unknown extension `.{e}` (expected .png or .exr)"))),
        None => return Err(Error::output(path, "no extension (expected .png or .exr)")),
    };
    check_folder(path)?;
    Ok(format)
}

/// Checks that the folder an output goes to exists and that the name is not a folder.
pub fn check_folder(path: &Path) -> Result<()> {
    let dir = parent(path);
    if !dir.is_dir() {
        return Err(Error::output(path, format!("folder `{}` does not exist", dir.display())));
    }
    if path.is_dir() {
        return Err(Error::output(path, "is a folder"));
    }
    Ok(())
}

fn parent(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// 8-bit sRGB bytes of an image, RGB interleaved.
pub fn to_srgb8(image: &Image) -> Vec<u8> {
    image.pixels.iter().flat_map(|p| [to_display8(p.x), to_display8(p.y), to_display8(p.z)]).collect()
}

/// Writes `image` to `path` in the format its extension names, atomically.
pub fn write_image(path: &Path, image: &Image) -> Result<()> {
    let format = check_image_path(path)?;
    atomic_write(path, |tmp| match format {
        Format::Png => save_png(tmp, image.width, image.height, &to_srgb8(image)),
        Format::Exr => save_exr(tmp, image),
    })
}

#[cfg(feature = "exr")]
fn save_exr(path: &Path, image: &Image) -> std::result::Result<(), String> {
    let w = image.width as usize;
    let px = |x: usize, y: usize| {
        let p = image.pixels[y * w + x];
        (p.x, p.y, p.z)
    };
    exr::prelude::write_rgb_file(path, w, image.height as usize, px).map_err(|e| e.to_string())
}

/// Writes a crop of a `width`×`height` frame: an EXR stores `image` (the pixels of
/// `crop`) as its data window inside the full display window, with `attributes` as
/// text header attributes; a PNG (a preview) is just the crop. Atomic.
pub fn write_crop(
    path: &Path,
    image: &Image,
    (width, height): (u32, u32),
    crop: &Tile,
    attributes: &[(String, String)],
) -> Result<()> {
    let format = check_image_path(path)?;
    atomic_write(path, |tmp| match format {
        Format::Png => save_png(tmp, image.width, image.height, &to_srgb8(image)),
        Format::Exr => save_exr_crop(tmp, image, (width, height), crop, attributes),
    })
}

#[cfg(feature = "exr")]
fn save_exr_crop(
    path: &Path,
    image: &Image,
    (width, height): (u32, u32),
    crop: &Tile,
    attributes: &[(String, String)],
) -> std::result::Result<(), String> {
    use exr::prelude::*;
    let w = image.width as usize;
    let channels = SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| {
        let p = image.pixels[y * w + x];
        (p.x, p.y, p.z)
    });
    let mut exr = Image::from_channels((w, image.height as usize), channels);
    exr.attributes.display_window = IntegerBounds::new((0, 0), (width as usize, height as usize));
    exr.layer_data.attributes.layer_position = Vec2(crop.x0 as i32, crop.y0 as i32);
    for (k, v) in attributes {
        let text = |t: &str| Text::new_or_none(t).ok_or_else(|| format!("header attribute `{k}` is not plain text"));
        exr.attributes.other.insert(text(k)?, AttributeValue::Text(text(v)?));
    }
    exr.write().to_file(path).map_err(|e| e.to_string())
}

#[cfg(not(feature = "exr"))]
fn save_exr_crop(
    _: &Path,
    _: &Image,
    _: (u32, u32),
    _: &Tile,
    _: &[(String, String)],
) -> std::result::Result<(), String> {
    Err(NEEDS_EXR.into())
}

/// Without the `exr` feature: the error that says so ([`check_image_path`] refuses
/// `.exr` first, so this is not reached from [`write_image`]).
#[cfg(not(feature = "exr"))]
fn save_exr(_: &Path, _: &Image) -> std::result::Result<(), String> {
    Err(NEEDS_EXR.into())
}

fn save_png(path: &Path, width: u32, height: u32, rgb: &[u8]) -> std::result::Result<(), String> {
    image::save_buffer_with_format(path, rgb, width, height, image::ExtendedColorType::Rgb8, image::ImageFormat::Png)
        .map_err(|e| e.to_string())
}

/// Checks a path for a PNG-only output (heatmaps).
pub fn check_png_path(path: &Path) -> Result<()> {
    match check_image_path(path)? {
        Format::Png => Ok(()),
        Format::Exr => Err(Error::output(path, "heatmaps are PNG only (use a .png extension)")),
    }
}

/// Writes 8-bit RGB bytes to a PNG atomically.
pub fn write_png(path: &Path, width: u32, height: u32, rgb: &[u8]) -> Result<()> {
    check_png_path(path)?;
    atomic_write(path, |tmp| save_png(tmp, width, height, rgb))
}

/// Writes text to `path` atomically.
pub fn write_text(path: &Path, text: &str) -> Result<()> {
    check_folder(path)?;
    atomic_write(path, |tmp| {
        let mut f = std::fs::File::create(tmp).map_err(|e| e.to_string())?;
        f.write_all(text.as_bytes()).and_then(|_| f.sync_all()).map_err(|e| e.to_string())
    })
}

/// Runs `write` on a temporary path beside `path`, then renames it into place; on any
/// failure the temporary file is removed and `path` is left as it was.
fn atomic_write(path: &Path, write: impl FnOnce(&Path) -> std::result::Result<(), String>) -> Result<()> {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let ext = path.extension().map(|e| e.to_string_lossy().into_owned()).unwrap_or_default();
    // Keep the real extension last: encoders that look at it must see the right one.
    let tmp = parent(path).join(format!(".{name}.{}.tmp.{ext}", std::process::id()));
    let result = write(&tmp).and_then(|_| std::fs::rename(&tmp, path).map_err(|e| e.to_string()));
    if let Err(e) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(Error::output(path, format!("cannot write: {e}")));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_known_values() {
        assert_eq!(to_display8(0.0), 0);
        assert_eq!(to_display8(1.0), 255);
        assert_eq!(to_display8(7.0), 255);
        assert_eq!(to_display8(-1.0), 0);
        // Linear 0.5 is sRGB 0.7354, 187.52 of 255.
        assert_eq!(to_display8(0.5), 188);
        // The linear segment: 0.002 * 12.92 * 255 = 6.59.
        assert_eq!(to_display8(0.002), 7);
    }
}
