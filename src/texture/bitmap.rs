//! Reading image files into a [`Bitmap`] and its texel lookup, as Mitsuba 3.9.1's `bitmap`
//! texture does (Dr.Jit's `Texture::eval`: texel centres at (i + 0.5) / width, the image's
//! first row at v = 0, wrap modes applied to integer texel indices).

use glam::{Vec2, Vec3};
use std::io::{BufReader, Read};
use std::path::Path;

use super::{Bitmap, Filter, Wrap};
use crate::color::srgb_decode;

/// The most texels an image may have (2^28: 3 GiB of linear RGB); a larger one, or a
/// corrupt header that claims one, is refused before anything is decoded.
pub const MAX_TEXELS: u64 = 1 << 28;

/// The first bytes of a PNG file.
const PNG_MAGIC: &[u8] = b"\x89PNG\r\n\x1a\n";
/// The first bytes of an OpenEXR file.
const EXR_MAGIC: &[u8] = &[0x76, 0x2f, 0x31, 0x01];

impl Bitmap {
    /// Reads a PNG (through the `image` crate) or, with the `exr` cargo feature, an EXR;
    /// the format is told by the file's first bytes, not its name. 8-bit and 16-bit images
    /// are sRGB-decoded to linear unless `raw` (Mitsuba treats every PNG as sRGB); EXR is
    /// linear. Grey and grey+alpha images become RGB; alpha is ignored (not premultiplied),
    /// as in Mitsuba. Errors are a message saying what is wrong with the file (the caller
    /// prefixes the path and the field); an image of more than [`MAX_TEXELS`] texels is
    /// refused from its header.
    pub fn load(path: &Path, raw: bool, wrap: Wrap, filter: Filter) -> Result<Bitmap, String> {
        // A device or a pipe would be read without end or block for ever.
        match std::fs::metadata(path) {
            Ok(m) if !m.is_file() => return Err("not a regular file".into()),
            Ok(_) => {}
            Err(e) => return Err(format!("cannot open: {e}")),
        }
        let mut magic = Vec::with_capacity(8);
        let file = std::fs::File::open(path).map_err(|e| format!("cannot open: {e}"))?;
        file.take(8).read_to_end(&mut magic).map_err(|e| format!("cannot read: {e}"))?;
        let (width, height, texels) = if magic.starts_with(PNG_MAGIC) {
            read_png(path, raw)?
        } else if magic.starts_with(EXR_MAGIC) {
            read_exr(path)?
        } else {
            return Err("not a PNG or EXR image".into());
        };
        debug_assert_eq!(texels.len() as u64, width as u64 * height as u64);
        Ok(Bitmap { width, height, texels, wrap, filter })
    }

    /// The texel lookup, as Mitsuba's bitmap `eval`: texel centres at (i + 0.5) / width
    /// and (j + 0.5) / height, v = 0 at the image's first (top) row, the wrap mode applied
    /// to integer texel indices (repeat: modulo; mirror: modulo twice the size, reflected
    /// in the second half; clamp: to the edge), and bilinear weights between the four
    /// texel centres around `uv` (or, nearest, the texel containing it). Any `uv` is
    /// accepted: a non-finite one reads texel 0.
    pub fn lookup(&self, uv: Vec2) -> Vec3 {
        debug_assert_eq!(self.texels.len() as u64, self.width as u64 * self.height as u64);
        if self.texels.is_empty() {
            return Vec3::ZERO;
        }
        let size = Vec2::new(self.width as f32, self.height as f32);
        // Wrapped indices, each axis's once: a wrap is an integer division.
        let at = |x: usize, y: usize| self.texels[y * self.width as usize + x];
        let wrap = |x: i64, y: i64| (self.wrap(x, self.width), self.wrap(y, self.height));
        match self.filter {
            Filter::Nearest => {
                let p = uv * size;
                let (x, y) = wrap(floor(p.x), floor(p.y));
                at(x, y)
            }
            Filter::Bilinear => {
                // Dr.Jit's tex_eval: position in texel units relative to the centres. A
                // position that is not finite reads as 0; the weights come from the float
                // floor, so that beyond ±2^31 (no fraction left, the index clamped) they
                // stay 1 and 0 (found by fuzzing: NaN at u = 1e30).
                let p = uv * size - 0.5;
                let p = Vec2::select(p.is_finite_mask(), p, Vec2::ZERO);
                let (x, y) = (floor(p.x), floor(p.y));
                let ((x0, y0), (x1, y1)) = (wrap(x, y), wrap(x + 1, y + 1));
                let w1 = p - p.floor();
                let w0 = 1.0 - w1;
                at(x0, y0) * (w0.x * w0.y)
                    + at(x1, y0) * (w1.x * w0.y)
                    + at(x0, y1) * (w0.x * w1.y)
                    + at(x1, y1) * (w1.x * w1.y)
            }
        }
    }

    /// A texel index along an axis of `n` texels brought into [0, n) by the wrap mode
    /// (Dr.Jit's `tex_wrap`).
    #[inline]
    fn wrap(&self, i: i64, n: u32) -> usize {
        let n = n as i64;
        // Every mode keeps an index inside the image, which most are: no division.
        if (0..n).contains(&i) {
            return i as usize;
        }
        (match self.wrap {
            Wrap::Repeat => i.rem_euclid(n),
            Wrap::Mirror => {
                let m = i.rem_euclid(2 * n);
                if m < n {
                    m
                } else {
                    2 * n - 1 - m
                }
            }
            Wrap::Clamp => i.clamp(0, n - 1),
        }) as usize
    }
}

/// `x.floor()` as an integer. Bounded to ±2^31 (where an f32 has no fraction left) so
/// that the neighbour index `+ 1` cannot overflow; NaN becomes 0.
fn floor(x: f32) -> i64 {
    const BOUND: f32 = 2_147_483_648.0;
    x.floor().clamp(-BOUND, BOUND) as i64
}

/// A decoded image: width, height, linear texels row by row from the top.
type Texels = (u32, u32, Vec<Vec3>);

/// Refuses a size over [`MAX_TEXELS`] (or an empty image).
fn check_size(width: u64, height: u64) -> Result<(), String> {
    if width == 0 || height == 0 {
        return Err(format!("the image is empty ({width}×{height} texels)"));
    }
    if width.saturating_mul(height) > MAX_TEXELS {
        return Err(format!("its {width}×{height} texels are more than the {MAX_TEXELS} a texture may have"));
    }
    Ok(())
}

/// Decodes a PNG, 8 or 16 bits per channel, grey or RGB, with or without alpha.
fn read_png(path: &Path, raw: bool) -> Result<Texels, String> {
    use image::codecs::png::PngDecoder;
    use image::{DynamicImage, ImageDecoder, Limits};
    let file = std::fs::File::open(path).map_err(|e| format!("cannot open: {e}"))?;
    let mut limits = Limits::default();
    // The decoder's own buffer: at most four 16-bit channels per texel. The size check
    // below refuses larger images first; this bounds what a lying header can allocate.
    limits.max_alloc = Some(MAX_TEXELS * 8);
    let decoder = PngDecoder::with_limits(BufReader::new(file), limits).map_err(|e| format!("not a valid PNG: {e}"))?;
    let (width, height) = decoder.dimensions();
    check_size(width as u64, height as u64)?;
    let image = DynamicImage::from_decoder(decoder).map_err(|e| format!("not a valid PNG: {e}"))?;
    // Mitsuba decodes each texel (not the interpolated value) from sRGB, with no regard
    // to the file's gAMA or iCCP chunks.
    let decode = |v: f32| if raw { v } else { srgb_decode(v) };
    let texels: Vec<Vec3> = match image.color().bytes_per_pixel() / image.color().channel_count() {
        1 => image.to_rgb8().pixels().map(|p| Vec3::from_array(p.0.map(|c| decode(c as f32 / 255.0)))).collect(),
        // 16-bit: Mitsuba stores these as half floats; here they keep f32 precision.
        _ => image.to_rgb16().pixels().map(|p| Vec3::from_array(p.0.map(|c| decode(c as f32 / 65535.0)))).collect(),
    };
    Ok((width, height, texels))
}

/// Decodes an EXR's first RGB(A) layer (linear values, alpha ignored).
#[cfg(feature = "exr")]
fn read_exr(path: &Path) -> Result<Texels, String> {
    let meta = exr::meta::MetaData::read_from_file(path, false).map_err(|e| format!("not a readable EXR: {e}"))?;
    for h in meta.headers.iter() {
        check_size(h.layer_size.width() as u64, h.layer_size.height() as u64)?;
    }
    let read = exr::prelude::read_first_rgba_layer_from_file(
        path,
        |res, _| (res.width(), vec![Vec3::ZERO; res.width() * res.height()]),
        |(w, px): &mut (usize, Vec<Vec3>), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            px[pos.y() * *w + pos.x()] = Vec3::new(r, g, b)
        },
    )
    .map_err(|e| format!("not a readable RGB EXR: {e}"))?;
    let size = read.layer_data.size;
    let (_, texels) = read.layer_data.channel_data.pixels;
    // A colour is finite and not negative, as the scene's own colours must be: a NaN or
    // negative texel would reach the image through every path that sees it.
    if let Some(i) = texels.iter().position(|t| !t.is_finite() || t.min_element() < 0.0) {
        let (x, y) = (i % size.width(), i / size.width());
        return Err(format!("texel ({x}, {y}) is {}: texels must be finite and >= 0", texels[i]));
    }
    Ok((size.width() as u32, size.height() as u32, texels))
}

/// Without the `exr` feature: the error that says so.
#[cfg(not(feature = "exr"))]
fn read_exr(_: &Path) -> Result<Texels, String> {
    Err("an EXR texture needs the `exr` feature (cargo build --features exr)".into())
}
