//! Writing results: PNG (8-bit sRGB, clamped) and EXR (linear 32-bit float RGB), and
//! text files. Where a result goes depends on what its path names ([`Target`]): a
//! regular file (or a new name) is written to a temporary file in the same folder and
//! renamed over it, so an error never leaves a partial file or clobbers an earlier one; a
//! symlink is followed and its target written that way (the link stays); a character
//! device or a FIFO is written in place (renaming would replace the node with a plain
//! file); `-` is standard output, for text. Anything else (a folder, a socket, a block
//! device), a read-only file or a folder that does not let it be replaced, is refused
//! before any work, as are two outputs naming one file and an output naming an input
//! ([`check_distinct`]). Without the `exr` feature an `.exr` path is refused before any
//! work, with a message that names the feature.
//!
//! The outputs of one command are written all or nothing ([`Batch`]): every file to its
//! temporary file first, then all renamed into place, then the devices and FIFOs and
//! stdout, which cannot be taken back. SIGINT, SIGTERM and SIGHUP remove the temporary
//! files at any moment and say what was and was not written ([`watch_signals`]).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, Once, PoisonError};

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
                check_folder(path, &p, None)?;
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
            check_replaceable(path, &p, &meta)?;
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
        return Err(Error::output(
            path,
            format!(
                "is {what}{}; outputs go to regular files, new names, character devices, FIFOs or `-`",
                through(path, &p)
            ),
        ));
    }
    Err(Error::output(path, format!("more than {MAX_LINKS} symlinks in a row")))
}

/// ` (through a symlink, `FILE`)` when the output path led elsewhere.
fn through(shown: &Path, file: &Path) -> String {
    if file != shown {
        format!(" (through a symlink, `{}`)", file.display())
    } else {
        String::new()
    }
}

/// The effective user id of this process.
fn euid() -> u32 {
    // SAFETY: geteuid has no preconditions and cannot fail.
    unsafe { libc::geteuid() }
}

/// True when the mode bits let this process `want` (`libc::W_OK`, `X_OK`) on `path`. For
/// root, which the kernel lets write anything, a bit of that kind must be set for someone:
/// the refusal follows the mode the file's owner gave it, as `cp` and `tar` do, not the
/// superuser's power to override it.
fn permits(path: &Path, meta: &std::fs::Metadata, want: libc::c_int) -> bool {
    use std::os::unix::ffi::OsStrExt;
    use std::os::unix::fs::MetadataExt;
    if euid() == 0 {
        let mode = meta.mode();
        return (want & libc::W_OK == 0 || mode & 0o222 != 0) && (want & libc::X_OK == 0 || mode & 0o111 != 0);
    }
    let Ok(c) = std::ffi::CString::new(path.as_os_str().as_bytes()) else { return true };
    // SAFETY: `c` is a NUL-terminated path that outlives the call; faccessat reads only it.
    unsafe { libc::faccessat(libc::AT_FDCWD, c.as_ptr(), want, libc::AT_EACCESS) == 0 }
}

/// Refuses an existing regular file that its mode keeps from being written ([`permits`]):
/// renaming a new file over it would succeed in a writable folder, and leave a file of
/// another owner and mode where a read-only one was.
fn check_replaceable(shown: &Path, file: &Path, meta: &std::fs::Metadata) -> Result<()> {
    use std::os::unix::fs::MetadataExt;
    if !permits(file, meta, libc::W_OK) {
        return Err(Error::output(
            shown,
            format!(
                "is read-only (mode {:o}){}: it is not replaced (make it writable, or write to another name). Nothing written",
                meta.mode() & 0o7777,
                through(shown, file)
            ),
        ));
    }
    check_folder(shown, file, Some(meta))
}

/// Refuses an output whose folder does not let the temporary file be made and renamed
/// into place: no write or search permission by its mode bits ([`permits`]), or a sticky
/// folder (`/tmp`) where the existing file (`existing`) belongs to another user.
fn check_folder(shown: &Path, file: &Path, existing: Option<&std::fs::Metadata>) -> Result<()> {
    use std::os::unix::fs::MetadataExt;
    let dir = parent(file);
    let Ok(meta) = std::fs::metadata(&dir) else { return Ok(()) };
    let mode = meta.mode() & 0o7777;
    if !permits(&dir, &meta, libc::W_OK | libc::X_OK) {
        return Err(Error::output(
            shown,
            format!(
                "its folder `{}` does not allow writing in it (mode {mode:o}){}: the output cannot be put in place. Nothing written",
                dir.display(),
                through(shown, file)
            ),
        ));
    }
    let me = euid();
    if let Some(f) = existing.filter(|f| mode & 0o1000 != 0 && f.uid() != me && meta.uid() != me) {
        return Err(Error::output(
            shown,
            format!(
                "belongs to user {} in the sticky folder `{}` (mode {mode:o}), which lets only its owner replace it. Nothing written",
                f.uid(),
                dir.display()
            ),
        ));
    }
    Ok(())
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
                    format!("{flag} names `{}`, {what}, which it would overwrite. Nothing written", input.display()),
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
    let mut batch = Batch::new();
    batch.image(path, image)?;
    batch.commit()
}

#[cfg(feature = "exr")]
fn encode_exr(image: &Image) -> std::result::Result<Vec<u8>, String> {
    let size = (image.width as usize, image.height as usize);
    encode_exr_lines(image, exr_header(size))
}

#[cfg(feature = "exr")]
fn encode_exr_crop(
    image: &Image,
    (width, height): (u32, u32),
    crop: &Tile,
    attributes: &[(String, String)],
) -> std::result::Result<Vec<u8>, String> {
    use exr::prelude::*;
    let mut header = exr_header((image.width as usize, image.height as usize))
        .with_display_window(IntegerBounds::new((0, 0), (width as usize, height as usize)))
        .with_position(Vec2(crop.x0 as i32, crop.y0 as i32));
    for (k, v) in attributes {
        let text = |t: &str| Text::new_or_none(t).ok_or_else(|| format!("header attribute `{k}` is not plain text"));
        header.shared_attributes.other.insert(text(k)?, AttributeValue::Text(text(v)?));
    }
    encode_exr_lines(image, header)
}

/// The header of an RGB 32-bit float EXR of `size` pixels, uncompressed scanlines, as
/// the exr crate's image writer would make it.
#[cfg(feature = "exr")]
fn exr_header(size: (usize, usize)) -> exr::meta::header::Header {
    use exr::meta::attribute::{ChannelDescription, SampleType};
    use exr::prelude::*;
    let channels = ["B", "G", "R"].map(|c| ChannelDescription::named(c, SampleType::F32));
    let mut header = exr::meta::header::Header::new(Text::from("rgb"), size, channels.into_iter().collect())
        .with_encoding(Compression::Uncompressed, exr::meta::BlockDescription::ScanLines, LineOrder::Increasing);
    header.own_attributes.layer_name = None;
    header
}

/// `image` as an EXR with `header` (channels B, G, R; uncompressed scanlines), each line
/// laid out by hand and handed to the crate as a block: 4x faster than its image writer,
/// which converts every sample through a closure (16.5 against 4.0 ms at 1280x960).
#[cfg(feature = "exr")]
fn encode_exr_lines(image: &Image, header: exr::meta::header::Header) -> std::result::Result<Vec<u8>, String> {
    use exr::block::{writer::ChunksWriter, BlockIndex, UncompressedBlock};
    use exr::prelude::Vec2;
    let (w, h) = (image.width as usize, image.height as usize);
    // The samples, the line offsets and the header: the buffer is never copied as it grows.
    let mut out = std::io::Cursor::new(Vec::with_capacity(w * h * 12 + h * 16 + 4096));
    let rows = image.pixels.chunks(w.max(1));
    exr::block::write(&mut out, std::iter::once(header).collect(), true, |meta, writer| {
        let mut lines = writer.sequential_blocks_compressor(&meta);
        for (y, row) in rows.enumerate() {
            // A line holds each channel's samples in turn, in the header's (alphabetical) order.
            let mut data = Vec::with_capacity(w * 12);
            for channel in [|p: &glam::Vec3| p.z, |p: &glam::Vec3| p.y, |p: &glam::Vec3| p.x] {
                data.extend(row.iter().flat_map(|p| channel(p).to_ne_bytes()));
            }
            let index = BlockIndex { layer: 0, pixel_position: Vec2(0, y), pixel_size: Vec2(w, 1), level: Vec2(0, 0) };
            lines.compress_block(y, UncompressedBlock { index, data })?;
        }
        Ok(())
    })
    .map_err(|e| e.to_string())?;
    Ok(out.into_inner())
}

#[cfg(not(feature = "exr"))]
fn encode_exr_crop(_: &Image, _: (u32, u32), _: &Tile, _: &[(String, String)]) -> std::result::Result<Vec<u8>, String> {
    Err(NEEDS_EXR.into())
}

/// Without the `exr` feature: the error that says so ([`check_image_path`] refuses
/// `.exr` first, so this is not reached from [`Batch::image`]).
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
    let mut batch = Batch::new();
    batch.png(path, width, height, rgb)?;
    batch.commit()
}

/// Writes text to `path` (`-`: standard output).
pub fn write_text(path: &Path, text: &str) -> Result<()> {
    let mut batch = Batch::new();
    batch.text(path, text)?;
    batch.commit()
}

/// The exit status of a command stopped by a signal (128 + SIGINT, as shells report
/// Ctrl-C; SIGTERM and SIGHUP end the same way, since the handler cannot tell them apart).
pub const EXIT_INTERRUPTED: i32 = 130;

/// The outputs of one command, written all or nothing. [`Batch::image`],
/// [`Batch::crop`], [`Batch::png`] and [`Batch::text`] each write a regular file's bytes
/// to its temporary file beside it (a device's, a FIFO's or stdout's are kept);
/// [`Batch::commit`] then renames the temporary files into place one after another, and
/// only then writes the devices, FIFOs and stdout, which cannot be taken back. An error
/// before the first rename, or a batch dropped uncommitted, removes its temporary files
/// and leaves every earlier file as it was.
#[derive(Default)]
pub struct Batch {
    staged: Vec<Staged>,
}

/// One output of a [`Batch`], ready to go in place.
enum Staged {
    /// A written and synced temporary file, to be renamed over `dest`.
    File { shown: PathBuf, tmp: PathBuf, dest: PathBuf },
    /// The bytes of a character device or FIFO, written in place.
    Stream { shown: PathBuf, node: PathBuf, bytes: Vec<u8> },
    /// The bytes of standard output.
    Stdout { bytes: Vec<u8> },
}

impl Batch {
    /// An empty batch. Its temporary files are registered for the signal handler, which
    /// a command installs with [`watch_signals`] (a library caller keeps its own).
    pub fn new() -> Batch {
        Batch::default()
    }

    /// Stages `image` in the format `path`'s extension names.
    pub fn image(&mut self, path: &Path, image: &Image) -> Result<()> {
        let bytes = match check_image_path(path)? {
            Format::Png => encode_png(image.width, image.height, &to_srgb8(image)),
            Format::Exr => encode_exr(image),
        };
        self.put(path, bytes)
    }

    /// Stages a crop of a `width`×`height` frame: an EXR stores `image` (the pixels of
    /// `crop`) as its data window inside the full display window, with `attributes` as
    /// text header attributes; a PNG (a preview) is just the crop.
    pub fn crop(
        &mut self,
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
        self.put(path, bytes)
    }

    /// Stages 8-bit RGB bytes as a PNG.
    pub fn png(&mut self, path: &Path, width: u32, height: u32, rgb: &[u8]) -> Result<()> {
        check_png_path(path)?;
        self.put(path, encode_png(width, height, rgb))
    }

    /// Stages text (`-`: standard output).
    pub fn text(&mut self, path: &Path, text: &str) -> Result<()> {
        self.put(path, Ok(text.as_bytes().to_vec()))
    }

    /// Stages encoded bytes where `path` leads ([`check_output`]). An encoding error is
    /// reported as a write error of `path`.
    fn put(&mut self, path: &Path, bytes: std::result::Result<Vec<u8>, String>) -> Result<()> {
        let fail = |e: String| Error::output(path, format!("cannot write: {e}"));
        let target = check_output(path)?;
        let bytes = bytes.map_err(fail)?;
        plan(path);
        self.staged.push(match target {
            Target::File(dest) => {
                let tmp = write_temporary(&dest, &bytes, path).map_err(|e| fail(e.to_string()))?;
                Staged::File { shown: path.to_path_buf(), tmp, dest }
            }
            Target::Stream(node) => Staged::Stream { shown: path.to_path_buf(), node, bytes },
            Target::Stdout => Staged::Stdout { bytes },
        });
        Ok(())
    }

    /// Puts every staged output in place: the files by renames, then the devices and
    /// FIFOs, then stdout. An error after the first rename says which were written.
    pub fn commit(mut self) -> Result<()> {
        // Files first (a stable sort keeps the command's order among them).
        self.staged.sort_by_key(|s| match s {
            Staged::File { .. } => 0,
            Staged::Stream { .. } => 1,
            Staged::Stdout { .. } => 2,
        });
        let mut done: Vec<PathBuf> = Vec::new();
        while !self.staged.is_empty() {
            let next = self.staged.remove(0);
            let (shown, result) = match &next {
                Staged::File { shown, tmp, dest } => {
                    let mut reg = registry();
                    let r = std::fs::rename(tmp, dest);
                    if r.is_ok() {
                        reg.temps.retain(|(t, _)| t != tmp);
                        reg.written.push(shown.clone());
                    }
                    (shown.clone(), r)
                }
                Staged::Stream { shown, node, bytes } => {
                    // No create, no truncate: the node is written as it is, never replaced.
                    let r = std::fs::OpenOptions::new()
                        .write(true)
                        .open(node)
                        .and_then(|mut f| f.write_all(bytes).and_then(|_| f.flush()));
                    (shown.clone(), r)
                }
                Staged::Stdout { bytes } => {
                    let mut out = std::io::stdout().lock();
                    (PathBuf::from("-"), out.write_all(bytes).and_then(|_| out.flush()))
                }
            };
            if let Err(e) = result {
                if let Staged::File { tmp, .. } = &next {
                    remove_temporary(tmp);
                }
                let mut msg = format!("cannot write: {e}");
                if !done.is_empty() {
                    let list: Vec<String> = done.iter().map(|p| format!("`{}`", p.display())).collect();
                    msg += &format!(" (already written: {}; the rest not written)", list.join(", "));
                }
                return Err(Error::output(&shown, msg));
            }
            registry().mark_written(&shown);
            done.push(shown);
        }
        Ok(())
    }
}

impl Drop for Batch {
    /// An uncommitted batch leaves nothing behind.
    fn drop(&mut self) {
        for s in &self.staged {
            if let Staged::File { tmp, .. } = s {
                remove_temporary(tmp);
            }
        }
    }
}

/// Writes `bytes` to a temporary file beside `dest` (`.NAME.PID.tmp`), with `dest`'s
/// permissions when it exists (a private file stays private), and syncs it. The file is
/// registered for the signal handler before it exists, so a signal at any moment
/// removes it; on failure it is removed at once.
fn write_temporary(dest: &Path, bytes: &[u8], shown: &Path) -> std::io::Result<PathBuf> {
    use std::os::unix::fs::PermissionsExt;
    let name = dest.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let tmp = parent(dest).join(format!(".{name}.{}.tmp", std::process::id()));
    let mut f = {
        // Created under the lock: the handler either removes it or runs before it exists.
        let mut reg = registry();
        let f = std::fs::File::create(&tmp)?;
        reg.temps.push((tmp.clone(), shown.to_path_buf()));
        f
    };
    let result = (|| {
        f.write_all(bytes)?;
        if let Ok(m) = std::fs::metadata(dest) {
            f.set_permissions(std::fs::Permissions::from_mode(m.permissions().mode() & 0o777))?;
        }
        f.sync_all()
    })();
    if let Err(e) = result {
        remove_temporary(&tmp);
        return Err(e);
    }
    Ok(tmp)
}

/// Removes a temporary file and forgets it.
fn remove_temporary(tmp: &Path) {
    let mut reg = registry();
    reg.temps.retain(|(t, _)| t != tmp);
    let _ = std::fs::remove_file(tmp);
}

/// What the signal handler needs to know, kept by the outputs as they go.
struct Registry {
    /// Temporary files that exist now, each with the output it is for.
    temps: Vec<(PathBuf, PathBuf)>,
    /// The command's outputs, as named, in order.
    planned: Vec<PathBuf>,
    /// The outputs in place.
    written: Vec<PathBuf>,
    /// While a render runs: its stop flag (the first signal stops it, the second ends
    /// the process).
    cancel: Option<Arc<AtomicBool>>,
}

static REGISTRY: Mutex<Registry> =
    Mutex::new(Registry { temps: Vec::new(), planned: Vec::new(), written: Vec::new(), cancel: None });

fn registry() -> MutexGuard<'static, Registry> {
    REGISTRY.lock().unwrap_or_else(PoisonError::into_inner)
}

impl Registry {
    fn mark_written(&mut self, shown: &Path) {
        if !self.written.iter().any(|w| w == shown) {
            self.written.push(shown.to_path_buf());
        }
    }

    /// What an interrupted command says: the outputs written, those not, and the
    /// temporary files removed.
    fn report(&self, removed: usize) -> String {
        let list = |v: Vec<&PathBuf>| match v.is_empty() {
            true => "nothing".to_string(),
            false => v.iter().map(|p| format!("`{}`", p.display())).collect::<Vec<_>>().join(", "),
        };
        let written: Vec<&PathBuf> = self.written.iter().collect();
        let missing: Vec<&PathBuf> = self.planned.iter().filter(|p| !self.written.contains(p)).collect();
        format!(
            "interrupted: written: {}; not written: {}; {removed} temporary file{} removed",
            list(written),
            list(missing),
            if removed == 1 { "" } else { "s" }
        )
    }
}

/// Adds an output to those an interrupted command reports.
fn plan(path: &Path) {
    let mut reg = registry();
    if !reg.planned.iter().any(|p| p == path) {
        reg.planned.push(path.to_path_buf());
    }
}

/// Handles SIGINT, SIGTERM and SIGHUP from now on (installed once per process, through
/// `ctrlc`; the command line calls it, the library never does):
/// while `cancel` is set, the first signal sets it (a render then stops after its tiles
/// in progress and writes what is finished); otherwise, and at the second signal, the
/// temporary files are removed, a line on stderr says which of `outputs` were written
/// and which not, and the process exits with [`EXIT_INTERRUPTED`]. Called again, it
/// replaces the flag (`None` once the render is over) and adds to the outputs.
pub fn watch_signals(cancel: Option<Arc<AtomicBool>>, outputs: &[&Path]) {
    registry().cancel = cancel;
    for p in outputs {
        plan(p);
    }
    install_handler();
}

static INSTALL: Once = Once::new();

fn install_handler() {
    // Without a handler (another one installed in this process) the signals keep their
    // default, which ends the process.
    INSTALL.call_once(|| {
        let _ = ctrlc::set_handler(on_signal);
    });
}

/// The signal handler (ctrlc runs it on its own thread, not in the signal's context).
fn on_signal() {
    // Held until the exit: no temporary file is created or renamed after this point.
    let mut reg = registry();
    if let Some(flag) = &reg.cancel {
        if !flag.swap(true, Ordering::SeqCst) {
            return;
        }
    }
    let temps = std::mem::take(&mut reg.temps);
    let removed = temps.iter().filter(|(tmp, _)| std::fs::remove_file(tmp).is_ok()).count();
    eprintln!("{}", reg.report(removed));
    std::process::exit(EXIT_INTERRUPTED);
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
