//! Writing results: PNG (8-bit sRGB, clamped) and EXR (linear 32-bit float RGB), and
//! text files. Where a result goes depends on what its path names ([`Target`]): a
//! regular file (or a new name) is written to a temporary file in the same folder and
//! renamed over it, so an error never leaves a partial file or clobbers an earlier one; a
//! symlink is followed and its target written that way (the link stays); a character
//! device or a FIFO is written in place (renaming would replace the node with a plain
//! file); `-` is standard output, for text. Anything else (a folder, a socket, a block
//! device) is refused before any work, as are two outputs naming one file
//! ([`check_distinct`]). Without the `exr` feature an `.exr` path is refused before any
//! work, with a message that names the feature.

use std::io::Write;
use std::path::{Path, PathBuf};

use crate::color::to_display8;
use crate::film::{Image, Tile};
use crate::{Error, Result};

/// Where one output's bytes go, decided from what its path names before any work.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Target {
    /// A regular file or a new name (a symlink's target, resolved): written to a
    /// temporary file beside it, then renamed over it.
    File(PathBuf),
    /// A character device or a FIFO: opened and written in place, never replaced.
    Stream(PathBuf),
    /// `-`: standard output (text outputs only).
    Stdout,
}

/// Symlinks followed from one output path before giving up (the kernel's own limit).
const MAX_LINKS: usize = 40;

/// True when `path` is `-`, standard output.
pub fn is_stdout(path: &Path) -> bool {
    path.as_os_str() == "-"
}

/// Classifies an output path before any work: a new name in an existing folder or a
/// regular file is a [`Target::File`], a symlink is followed (a dangling one names the
/// file to create), a character device or FIFO is a [`Target::Stream`], `-` is
/// [`Target::Stdout`]; a folder, socket or block device, or a missing folder, is an input
/// error naming the path.
pub fn check_output(path: &Path) -> Result<Target> {
    use std::os::unix::fs::FileTypeExt;
    if is_stdout(path) {
        return Ok(Target::Stdout);
    }
    let mut p = path.to_path_buf();
    for _ in 0..MAX_LINKS {
        let meta = match std::fs::symlink_metadata(&p) {
            Ok(m) => m,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                let dir = parent(&p);
                if !dir.is_dir() {
                    return Err(Error::output(path, format!("folder `{}` does not exist", dir.display())));
                }
                return Ok(Target::File(p));
            }
            Err(e) => return Err(Error::output(path, format!("cannot look at it: {e}"))),
        };
        let kind = meta.file_type();
        if kind.is_symlink() {
            let to = std::fs::read_link(&p).map_err(|e| Error::output(path, format!("cannot read the link: {e}")))?;
            // A relative link target is relative to the link's own folder.
            p = parent(&p).join(to);
            continue;
        }
        let what = if kind.is_file() {
            return Ok(Target::File(p));
        } else if kind.is_char_device() || kind.is_fifo() {
            return Ok(Target::Stream(p));
        } else if kind.is_dir() {
            "a folder"
        } else if kind.is_socket() {
            "a socket"
        } else if kind.is_block_device() {
            "a block device"
        } else {
            "not a regular file"
        };
        let through = if p != path { format!(" (through a symlink, `{}`)", p.display()) } else { String::new() };
        return Err(Error::output(
            path,
            format!("is {what}{through}; outputs go to regular files, new names, character devices, FIFOs or `-`"),
        ));
    }
    Err(Error::output(path, format!("more than {MAX_LINKS} symlinks in a row")))
}

/// What identifies the file an output path ends at: the device and inode of an existing
/// one, else the canonical folder and the name.
#[derive(Clone, Debug, PartialEq, Eq)]
enum Identity {
    Node(u64, u64),
    Name(PathBuf),
    Stdout,
}

fn identity(path: &Path) -> Option<Identity> {
    use std::os::unix::fs::MetadataExt;
    if is_stdout(path) {
        return Some(Identity::Stdout);
    }
    if let Ok(m) = std::fs::metadata(path) {
        // Character devices (`/dev/null`) take any number of writers: never a clash.
        use std::os::unix::fs::FileTypeExt;
        if m.file_type().is_char_device() {
            return None;
        }
        return Some(Identity::Node(m.dev(), m.ino()));
    }
    let target = match check_output(path) {
        Ok(Target::File(p)) | Ok(Target::Stream(p)) => p,
        _ => path.to_path_buf(),
    };
    let dir = std::fs::canonicalize(parent(&target)).unwrap_or_else(|_| parent(&target));
    Some(Identity::Name(dir.join(target.file_name().unwrap_or_default())))
}

/// Refuses, before any work, two outputs of one command that end at the same file (by
/// device and inode where it exists, by canonical folder and name where it does not,
/// through symlinks too; `-` twice is stdout twice), and an output that is one of the
/// command's `inputs`. `outputs` pairs each path with the flag that named it, for the
/// message. Character devices are exempt: writing twice to `/dev/null` loses nothing.
pub fn check_distinct(outputs: &[(&str, &Path)], inputs: &[(&str, &Path)]) -> Result<()> {
    let ids: Vec<Option<Identity>> = outputs.iter().map(|(_, p)| identity(p)).collect();
    for (i, (flag, path)) in outputs.iter().enumerate() {
        let Some(id) = &ids[i] else { continue };
        if let Some(j) = ids[..i].iter().position(|o| o.as_ref() == Some(id)) {
            let (first, first_path) = outputs[j];
            return Err(Error::output(
                path,
                format!(
                    "{flag} and {first} (`{}`) name the same file; one would overwrite the other. Nothing written",
                    first_path.display()
                ),
            ));
        }
        for (what, input) in inputs {
            if identity(input).as_ref() == Some(id) {
                return Err(Error::output(
                    path,
                    format!("{flag} names {what} `{}`, which it would overwrite. Nothing written", input.display()),
                ));
            }
        }
    }
    Ok(())
}

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

/// Checks an image output path before any work starts: a known extension (EXR only with
/// the `exr` feature) and a place [`check_output`] accepts, other than stdout.
pub fn check_image_path(path: &Path) -> Result<Format> {
    let format = match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
        Some("png") => Format::Png,
        Some("exr") if cfg!(feature = "exr") => Format::Exr,
        Some("exr") => return Err(Error::output(path, NEEDS_EXR)),
        Some(e) => return Err(Error::output(path, format!("unknown extension `.{e}` (expected .png or .exr)"))),
        None => return Err(Error::output(path, "no extension (expected .png or .exr)")),
    };
    if check_output(path)? == Target::Stdout {
        return Err(Error::output(path, "images are not written to standard output"));
    }
    Ok(format)
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

/// Writes `image` to `path` in the format its extension names ([`Target`] says how).
pub fn write_image(path: &Path, image: &Image) -> Result<()> {
    let bytes = match check_image_path(path)? {
        Format::Png => encode_png(image.width, image.height, &to_srgb8(image)),
        Format::Exr => encode_exr(image),
    };
    put(path, bytes)
}

#[cfg(feature = "exr")]
fn encode_exr(image: &Image) -> std::result::Result<Vec<u8>, String> {
    use exr::prelude::*;
    let w = image.width as usize;
    let channels = SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| {
        let p = image.pixels[y * w + x];
        (p.x, p.y, p.z)
    });
    let mut out = std::io::Cursor::new(Vec::new());
    Image::from_channels((w, image.height as usize), channels)
        .write()
        .to_buffered(&mut out)
        .map_err(|e| e.to_string())?;
    Ok(out.into_inner())
}

/// Writes a crop of a `width`×`height` frame: an EXR stores `image` (the pixels of
/// `crop`) as its data window inside the full display window, with `attributes` as
/// text header attributes; a PNG (a preview) is just the crop.
pub fn write_crop(
    path: &Path,
    image: &Image,
    (width, height): (u32, u32),
    crop: &Tile,
    attributes: &[(String, String)],
) -> Result<()> {
    let bytes = match check_image_path(path)? {
        Format::Png => encode_png(image.width, image.height, &to_srgb8(image)),
        Format::Exr => encode_exr_crop(image, (width, height), crop, attributes),
    };
    put(path, bytes)
}

#[cfg(feature = "exr")]
fn encode_exr_crop(
    image: &Image,
    (width, height): (u32, u32),
    crop: &Tile,
    attributes: &[(String, String)],
) -> std::result::Result<Vec<u8>, String> {
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
    let mut out = std::io::Cursor::new(Vec::new());
    exr.write().to_buffered(&mut out).map_err(|e| e.to_string())?;
    Ok(out.into_inner())
}

#[cfg(not(feature = "exr"))]
fn encode_exr_crop(_: &Image, _: (u32, u32), _: &Tile, _: &[(String, String)]) -> std::result::Result<Vec<u8>, String> {
    Err(NEEDS_EXR.into())
}

/// Without the `exr` feature: the error that says so ([`check_image_path`] refuses
/// `.exr` first, so this is not reached from [`write_image`]).
#[cfg(not(feature = "exr"))]
fn encode_exr(_: &Image) -> std::result::Result<Vec<u8>, String> {
    Err(NEEDS_EXR.into())
}

fn encode_png(width: u32, height: u32, rgb: &[u8]) -> std::result::Result<Vec<u8>, String> {
    use image::ImageEncoder;
    let mut out = Vec::new();
    image::codecs::png::PngEncoder::new(&mut out)
        .write_image(rgb, width, height, image::ExtendedColorType::Rgb8)
        .map_err(|e| e.to_string())?;
    Ok(out)
}

/// Checks a path for a PNG-only output (heatmaps).
pub fn check_png_path(path: &Path) -> Result<()> {
    match check_image_path(path)? {
        Format::Png => Ok(()),
        Format::Exr => Err(Error::output(path, "heatmaps are PNG only (use a .png extension)")),
    }
}

/// Writes 8-bit RGB bytes to a PNG.
pub fn write_png(path: &Path, width: u32, height: u32, rgb: &[u8]) -> Result<()> {
    check_png_path(path)?;
    put(path, encode_png(width, height, rgb))
}

/// Writes text to `path` (`-`: standard output).
pub fn write_text(path: &Path, text: &str) -> Result<()> {
    put(path, Ok(text.as_bytes().to_vec()))
}

/// Writes encoded bytes where `path` leads ([`check_output`]): a file through a
/// temporary file and a rename, a device or FIFO in place, `-` to standard output. An
/// encoding error is reported as a write error of `path`, and nothing is written.
fn put(path: &Path, bytes: std::result::Result<Vec<u8>, String>) -> Result<()> {
    let fail = |e: String| Error::output(path, format!("cannot write: {e}"));
    let target = check_output(path)?;
    let bytes = bytes.map_err(fail)?;
    match target {
        Target::File(file) => atomic_write(&file, &bytes).map_err(fail),
        Target::Stream(node) => {
            // No create, no truncate: the node is written as it is, never replaced.
            let mut f = std::fs::OpenOptions::new().write(true).open(&node).map_err(|e| fail(e.to_string()))?;
            f.write_all(&bytes).and_then(|_| f.flush()).map_err(|e| fail(e.to_string()))
        }
        Target::Stdout => {
            let mut out = std::io::stdout().lock();
            out.write_all(&bytes).and_then(|_| out.flush()).map_err(|e| fail(e.to_string()))
        }
    }
}

/// Writes `bytes` to a temporary file beside `path`, then renames it into place; on any
/// failure the temporary file is removed and `path` is left as it was.
fn atomic_write(path: &Path, bytes: &[u8]) -> std::result::Result<(), String> {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let tmp = parent(path).join(format!(".{name}.{}.tmp", std::process::id()));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if let Err(e) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(e.to_string());
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
