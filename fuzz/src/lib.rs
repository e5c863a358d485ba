//! The input promise, checked one input at a time: what the libFuzzer targets of
//! `fuzz/fuzz_targets/` run, and what `cargo test` runs over the committed corpus
//! (`tests/fuzz/corpus.rs`, which includes this file), so a fuzzer finding and its
//! regression test check exactly the same rules.
//!
//! The promise (README, "Bad input"): every input ends in an accepted scene or image, or in
//! an `Error::Input` (exit code 2) whose message names a file and says where in it. An
//! accepted scene has a finite camera and renders at 4×4 to finite pixels; an accepted
//! image has as many finite-or-not pixels as its size says and compares with itself. No
//! panic anywhere; time and memory per input are bounded by the fuzzer's `-timeout`,
//! `-rss_limit_mb` (fuzz/run.sh; `-malloc_limit_mb` needs a sanitizer) and, in the replay, by the test
//! harness's watchdog and allocation guard.
//!
//! Inputs with several files (a scene and its meshes or includes) are written to a fresh
//! folder per input, the fake file system ([`Sandbox`]); [`Bundle`] is their text form.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

use arbitrary::Arbitrary;
use wavetrace::scene::{load, AaMode, SceneSource};
use wavetrace::tools::{compare, merge};
use wavetrace::{render, Error, RenderOptions, Scene};

/// How an input ended when it broke no rule.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Refused with `Error::Input`, a message naming a file and a place in it.
    Rejected,
    /// Loaded, but too big to render here even with the [`TINY`] overrides.
    Loaded,
    /// Loaded, and a 4×4 render of it has finite pixels.
    Rendered,
    /// An image read, with the pixels its size says.
    Read,
}

/// A broken rule, said in words.
pub type Broken = String;

/// What checking one input gives.
pub type Outcome = Result<Verdict, Broken>;

/// Overrides that make a loaded scene a 4×4 render.
pub const TINY: [&str; 8] = [
    "render.width=4",
    "render.height=4",
    "render.aa.samples=1",
    "render.aa.min_level=2",
    "render.aa.max_level=4",
    "render.shadows.samples=1",
    "render.dof.samples=1",
    "render.max_depth=8",
];

/// Largest scene a check renders: primitives (a BVH build per input) and lights.
const MAX_RENDER_PRIMITIVES: u64 = 20_000;

// ---------------------------------------------------------------------------------------
// The fake file system.

/// Folder the sandboxes live in: `WAVETRACE_FUZZ_DIR`, else /dev/shm (memory), else the
/// system's temporary folder.
fn sandbox_root() -> PathBuf {
    if let Some(dir) = std::env::var_os("WAVETRACE_FUZZ_DIR") {
        return dir.into();
    }
    let shm = Path::new("/dev/shm");
    if shm.is_dir() {
        return shm.into();
    }
    std::env::temp_dir()
}

/// A fresh folder holding one input's files, removed when dropped.
pub struct Sandbox {
    dir: PathBuf,
}

impl Sandbox {
    /// An empty folder, unique to this process and call.
    pub fn new() -> Sandbox {
        static NEXT: AtomicUsize = AtomicUsize::new(0);
        let n = NEXT.fetch_add(1, Ordering::Relaxed);
        let dir = sandbox_root().join(format!("wavetrace-fuzz-{}-{n}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("cannot make the sandbox {}: {e}", dir.display()));
        Sandbox { dir }
    }

    /// The folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Writes `bytes` to the relative `name`, making its folders.
    pub fn write(&self, name: &str, bytes: &[u8]) -> PathBuf {
        let path = self.dir.join(name);
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent).unwrap_or_else(|e| panic!("sandbox folder {}: {e}", parent.display()));
        }
        std::fs::write(&path, bytes).unwrap_or_else(|e| panic!("sandbox file {}: {e}", path.display()));
        path
    }
}

impl Default for Sandbox {
    fn default() -> Self {
        Sandbox::new()
    }
}

impl Drop for Sandbox {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// Several files and some command-line strings in one byte string, so that a byte-level
/// fuzzer can mutate a scene together with its meshes and includes:
///
/// ```text
/// <the main file>
/// === file meshes/a.obj
/// <that file>
/// === args
/// render.width=4
/// ```
///
/// `=== args` lines are `--set` strings for a TOML scene and `-D NAME=VALUE` strings for
/// an XML scene. A file name must be relative, without `..`, of letters, digits and
/// `._-/`; other names are dropped, as are files past [`Bundle::MAX_FILES`].
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Bundle {
    /// The main file.
    pub main: Vec<u8>,
    /// Further files: (relative name, contents).
    pub files: Vec<(String, Vec<u8>)>,
    /// Command-line strings.
    pub args: Vec<String>,
}

impl Bundle {
    /// Most files besides the main one.
    pub const MAX_FILES: usize = 8;
    /// Most command-line strings.
    pub const MAX_ARGS: usize = 16;

    /// Splits `data` at its `\n=== ` lines.
    pub fn parse(data: &[u8]) -> Bundle {
        const MARK: &[u8] = b"\n=== ";
        let mut parts = Vec::new();
        let mut rest = data;
        while let Some(at) = find(rest, MARK) {
            parts.push(&rest[..at]);
            rest = &rest[at + MARK.len()..];
        }
        parts.push(rest);
        let mut bundle = Bundle { main: parts[0].to_vec(), ..Bundle::default() };
        for part in &parts[1..] {
            let (head, body) = match find(part, b"\n") {
                Some(at) => (&part[..at], &part[at + 1..]),
                None => (*part, &[][..]),
            };
            let head = String::from_utf8_lossy(head);
            if head.trim() == "args" {
                let text = String::from_utf8_lossy(body);
                bundle.args.extend(text.lines().take(Bundle::MAX_ARGS).map(String::from));
            } else if let Some(name) = head.strip_prefix("file ") {
                if ok_name(name) && bundle.files.len() < Bundle::MAX_FILES {
                    bundle.files.push((name.to_string(), body.to_vec()));
                }
            }
        }
        bundle.args.truncate(Bundle::MAX_ARGS);
        bundle
    }

    /// The byte string that [`Bundle::parse`] reads back as this bundle (for seeds).
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = self.main.clone();
        for (name, body) in &self.files {
            out.extend_from_slice(format!("\n=== file {name}\n").as_bytes());
            out.extend_from_slice(body);
        }
        if !self.args.is_empty() {
            out.extend_from_slice(b"\n=== args\n");
            out.extend_from_slice(self.args.join("\n").as_bytes());
        }
        out
    }

    /// Writes the files (not the main one) into `sandbox`.
    fn write_files(&self, sandbox: &Sandbox) {
        for (name, body) in &self.files {
            // A name already written, or under a file, is skipped (the file system refuses
            // it, not the renderer).
            let path = sandbox.dir().join(name);
            if path.exists() || path.ancestors().skip(1).any(|a| a.is_file()) {
                continue;
            }
            sandbox.write(name, body);
        }
    }

    /// The names a message may cite: the main file's and every other file's.
    fn names<'a>(&'a self, main: &'a str) -> Vec<&'a str> {
        std::iter::once(main).chain(self.files.iter().map(|(n, _)| n.as_str())).collect()
    }
}

fn find(hay: &[u8], needle: &[u8]) -> Option<usize> {
    hay.windows(needle.len()).position(|w| w == needle)
}

/// A file name the sandbox may hold.
fn ok_name(name: &str) -> bool {
    (1..=64).contains(&name.len())
        && name.bytes().all(|b| b.is_ascii_alphanumeric() || b"._-/".contains(&b))
        && !name.starts_with('/')
        && !name.ends_with('/')
        && name.split('/').all(|c| !c.is_empty() && c != "." && c != "..")
}

// ---------------------------------------------------------------------------------------
// The rules.

/// A refusal keeps the promise: an input error, not an internal one, with a message that
/// names one of `files` and a place (a line, a field, a flag, an element or a byte).
fn refusal(e: &Error, files: &[&str]) -> Outcome {
    let msg = match e {
        Error::Input(msg) => msg,
        Error::Internal(_) => return Err(format!("not an input error (exit code {}): {e}", e.exit_code())),
    };
    if e.exit_code() != 2 {
        return Err(format!("input error with exit code {}: {msg}", e.exit_code()));
    }
    if msg.trim().is_empty() {
        return Err("Error::Input with an empty message".into());
    }
    if !files.iter().any(|f| names_file(msg, f)) {
        return Err(format!("the message names none of the files {files:?}: {msg}"));
    }
    if !has_place(msg) {
        return Err(format!("the message does not say where: {msg}"));
    }
    Ok(Verdict::Rejected)
}

/// True when `msg` names the file `name` as a whole path component (not a one-letter
/// name found inside another word).
fn names_file(msg: &str, name: &str) -> bool {
    msg.match_indices(name).any(|(i, _)| {
        let before = msg[..i].chars().next_back();
        let after = msg[i + name.len()..].chars().next();
        let edge = |c: Option<char>| c.is_none_or(|c| !(c.is_ascii_alphanumeric() || "._-".contains(c)));
        edge(before) && edge(after)
    })
}

/// True when `msg` says where the problem is: `file:LINE`, a field, a `--set`/`-D`
/// string, a line, an element, a byte or a vertex.
fn has_place(msg: &str) -> bool {
    let line_number = msg.match_indices(':').any(|(i, _)| msg[i + 1..].starts_with(|c: char| c.is_ascii_digit()));
    let words = ["field `", "--set ", "-D ", "line ", "element", "byte", "vertex", "face", "header", "<"];
    line_number || words.iter().any(|w| msg.contains(w))
}

/// The rules a loaded scene keeps: a finite camera, and when it is small (with [`TINY`]
/// applied when it was not), a 4×4 render with finite pixels.
fn loaded(scene: Scene, src: &SceneSource, sets: &[String]) -> Outcome {
    let c = &scene.camera;
    let finite = [c.position, c.forward, c.right, c.up].iter().all(|v| v.is_finite())
        && c.tan_half_fov.is_finite()
        && c.focus_distance.is_finite();
    if !finite {
        return Err(format!("camera basis is not finite: {c:?}"));
    }
    let scene = if small(&scene) {
        scene
    } else {
        let tiny: Vec<String> = sets.iter().cloned().chain(TINY.map(String::from)).collect();
        match load(src, &tiny) {
            Ok(s) if small(&s) => s,
            // The overrides cannot shrink it (a huge level, a huge mesh): it stays loaded.
            _ => return Ok(Verdict::Loaded),
        }
    };
    let s = &scene.settings;
    let out = render(&scene, &RenderOptions { threads: Some(1), ..Default::default() })
        .map_err(|e| format!("a loaded scene does not render: {e}"))?;
    let n = (s.width * s.height) as usize;
    if out.image.pixels.len() != n {
        return Err(format!("{} pixels, expected {n}", out.image.pixels.len()));
    }
    if let Some(p) = out.image.pixels.iter().find(|p| !p.is_finite()) {
        return Err(format!("non-finite pixel {p}"));
    }
    Ok(Verdict::Rendered)
}

/// A scene this check renders: at most 16 pixels, 16 samples and 4 shadow or lens rays
/// each, depth 8, 16 lights and [`MAX_RENDER_PRIMITIVES`].
pub fn small(scene: &Scene) -> bool {
    let s = &scene.settings;
    let per_pixel = match s.aa_mode {
        AaMode::Uniform | AaMode::Variance { .. } | AaMode::Auto { .. } => s.aa_samples as u64,
        AaMode::Adaptive { max_level, .. } => 1 << max_level.min(63),
    };
    s.width as u64 * s.height as u64 <= 16
        && per_pixel <= 16
        && s.dof_samples <= 4
        && s.shadow_samples <= 4
        && s.max_depth <= 8
        && scene.lights.len() <= 16
        && scene.info.primitives as u64 <= MAX_RENDER_PRIMITIVES
}

/// Loads `src` with `sets` and applies the rules; `files` are the names a refusal may cite.
pub fn check_source(src: &SceneSource, sets: &[String], files: &[&str]) -> Outcome {
    match load(src, sets) {
        Err(e) => refusal(&e, files),
        Ok(scene) => loaded(scene, src, sets),
    }
}

// ---------------------------------------------------------------------------------------
// The targets: one function per input path.

/// A TOML scene (the bundle's main file, `scene.toml`) with its meshes and `--set` strings.
pub fn scene_toml(data: &[u8]) -> Outcome {
    scene_file(data, "scene.toml")
}

/// A Mitsuba XML scene (the bundle's main file, `scene.xml`) with its includes, meshes and
/// `-D NAME=VALUE` strings.
pub fn mitsuba_xml(data: &[u8]) -> Outcome {
    scene_file(data, "scene.xml")
}

/// A scene file as the command line reads it: [`SceneSource::from_file`], then `load`.
fn scene_file(data: &[u8], main: &str) -> Outcome {
    let bundle = Bundle::parse(data);
    let sandbox = Sandbox::new();
    // The main file first: a bundle file named like it, or under it, is skipped.
    let path = sandbox.write(main, &bundle.main);
    bundle.write_files(&sandbox);
    let files = bundle.names(main);
    let mut src = match SceneSource::from_file(&path) {
        Ok(src) => src,
        Err(e) => return refusal(&e, &files),
    };
    let mut sets = Vec::new();
    if src.xml.is_some() {
        src.defines = bundle
            .args
            .iter()
            .map(|d| d.split_once('=').unwrap_or((d, "")))
            .map(|(k, v)| (k.into(), v.into()))
            .collect();
    } else {
        sets = bundle.args.clone();
    }
    check_source(&src, &sets, &files)
}

/// A small scene that names `mesh.obj` or `mesh.ply`: what a mesh input is loaded by.
fn mesh_scene(file: &str, smooth: bool) -> String {
    format!(
        "[render]\nwidth = 4\nheight = 4\n[render.aa]\nsamples = 1\n[render.shadows]\nsamples = 1\n\
         [camera]\nposition = [0, 1, 4]\nlook_at = [0, 0, 0]\n\
         [materials.m]\ntype = \"diffuse\"\ncolor = [0.5, 0.5, 0.5]\n\
         [[lights]]\ntype = \"quad\"\ncorner = [-1, 3, -1]\nedge_u = [2, 0, 0]\nedge_v = [0, 0, 2]\nradiance = [5, 5, 5]\n\
         [[objects]]\ntype = \"mesh\"\nfile = \"{file}\"\nmaterial = \"m\"\nsmooth = {smooth}\n"
    )
}

/// An OBJ mesh, named by a scene; flat or smooth by the first byte's low bit.
pub fn obj(data: &[u8]) -> Outcome {
    mesh(data, "mesh.obj")
}

/// A PLY mesh, named by a scene; flat or smooth by the first byte's low bit.
pub fn ply(data: &[u8]) -> Outcome {
    mesh(data, "mesh.ply")
}

fn mesh(data: &[u8], file: &str) -> Outcome {
    let Some((&first, body)) = data.split_first() else { return Ok(Verdict::Rejected) };
    let sandbox = Sandbox::new();
    sandbox.write(file, body);
    let text = mesh_scene(file, first & 1 == 1);
    let src = SceneSource::from_text("scene.toml", &text, sandbox.dir());
    match load(&src, &[]) {
        Err(e) => refusal(&e, &["scene.toml", file]).and_then(|v| mesh_place(&e, file).map(|()| v)),
        Ok(scene) => loaded(scene, &src, &[]),
    }
}

/// A mesh refusal says where in the mesh: the scene's own place (the `file` field that
/// names it) comes first in the message, so the text after the mesh's name must give a
/// line, an element, a vertex, a face, a byte or the header; or the whole file is at
/// fault (empty, too big, no triangles), which has no place to give.
fn mesh_place(e: &Error, file: &str) -> Result<(), Broken> {
    let msg = e.to_string();
    let Some(i) = msg.rfind(file) else { return Ok(()) };
    let rest = &msg[i + file.len()..];
    let numbered =
        |w: &str| rest.match_indices(w).any(|(j, _)| rest[j + w.len()..].starts_with(|c: char| c.is_ascii_digit()));
    let places = ["element", "header", "byte", "property", "first line"];
    let whole = ["no triangles", "no faces", "empty", "too big", "bytes, more than"];
    let numbers = ["line ", "vertex ", "normal ", "face "];
    if numbers.iter().any(|w| numbered(w)) || places.iter().any(|w| rest.contains(w)) {
        return Ok(());
    }
    if whole.iter().any(|w| rest.contains(w)) {
        return Ok(());
    }
    Err(format!("a mesh refusal does not say where in {file}: {msg}"))
}

/// What the first byte of an [`image`] input picks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageUse {
    /// A PNG given to `compare`.
    Png,
    /// An EXR given to `compare`.
    Exr,
    /// A tile EXR given to `merge`.
    Tile,
    /// A PNG or EXR read as a texture.
    Texture,
}

impl ImageUse {
    /// The use picked by a first byte.
    pub fn of(byte: u8) -> ImageUse {
        match byte % 4 {
            0 => ImageUse::Png,
            1 => ImageUse::Exr,
            2 => ImageUse::Tile,
            _ => ImageUse::Texture,
        }
    }

    /// The first byte that picks this use.
    pub fn byte(self) -> u8 {
        self as u8
    }
}

/// An image file as `compare` (PNG or EXR) or `merge` (a tile EXR) reads it; the first
/// byte picks which ([`ImageUse`]). A read image must have its size's pixels and compare
/// with itself; a read tile must merge alone into a full-frame image or be refused.
pub fn image(data: &[u8]) -> Outcome {
    let Some((&first, body)) = data.split_first() else { return Ok(Verdict::Rejected) };
    let sandbox = Sandbox::new();
    let usage = ImageUse::of(first);
    let name = if usage == ImageUse::Png { "image.png" } else { "image.exr" };
    let path = sandbox.write(name, body);
    let files = [name];
    match usage {
        ImageUse::Png | ImageUse::Exr => {
            let img = match compare::load_linear(&path) {
                Err(e) => return image_refusal(&e, &files),
                Ok(img) => img,
            };
            let n = img.width as u64 * img.height as u64;
            if img.pixels.len() as u64 != n {
                return Err(format!("{}×{} image with {} pixels", img.width, img.height, img.pixels.len()));
            }
            match compare::metrics(&img, &img) {
                Err(e) => image_refusal(&e, &files),
                Ok(m) if img.pixels.iter().all(|p| p.is_finite()) && m.rmse != 0.0 => {
                    Err(format!("an image differs from itself: rmse {}", m.rmse))
                }
                Ok(_) => Ok(Verdict::Read),
            }
        }
        ImageUse::Tile => {
            // What `merge` does with one tile (`--allow-missing` assembles a partial frame).
            let tiles = match merge::read_tiles(&[path]).and_then(|t| merge::coverage(&t).map(|_| t)) {
                Err(e) => return image_refusal(&e, &files),
                Ok(t) => t,
            };
            let img = &tiles[0].image;
            if img.pixels.len() as u64 != img.width as u64 * img.height as u64 {
                return Err(format!("tile of {}×{} with {} pixels", img.width, img.height, img.pixels.len()));
            }
            let full = merge::assemble(&tiles);
            let h = &tiles[0].header;
            if full.pixels.len() as u64 != h.width as u64 * h.height as u64 {
                return Err(format!("merged {} pixels for a {}×{} frame", full.pixels.len(), h.width, h.height));
            }
            Ok(Verdict::Read)
        }
        ImageUse::Texture => texture(&path),
    }
}

/// A file read as a texture: refused with a message, or texels that are all finite and
/// not negative, with every lookup (any UV, NaN and ±∞ included, every wrap mode and
/// filter) finite and not negative.
fn texture(path: &Path) -> Outcome {
    use wavetrace::texture::{Bitmap, Filter, Wrap};
    for (wrap, filter) in
        [(Wrap::Repeat, Filter::Bilinear), (Wrap::Mirror, Filter::Nearest), (Wrap::Clamp, Filter::Bilinear)]
    {
        let bitmap = match Bitmap::load(path, false, wrap, filter) {
            Err(msg) if msg.trim().is_empty() => return Err("a texture refused without a message".into()),
            Err(_) => return Ok(Verdict::Rejected),
            Ok(b) => b,
        };
        if bitmap.texels.len() as u64 != bitmap.width as u64 * bitmap.height as u64 {
            return Err(format!("{}×{} texture with {} texels", bitmap.width, bitmap.height, bitmap.texels.len()));
        }
        let bad = |v: glam::Vec3| !v.is_finite() || v.min_element() < 0.0;
        if let Some(t) = bitmap.texels.iter().find(|t| bad(**t)) {
            return Err(format!("a texel of {t}"));
        }
        for uv in [(0.0, 0.0), (0.5, 0.5), (-3.7, 12.2), (1e30, -1e30), (f32::NAN, 0.3), (f32::INFINITY, 0.0)] {
            let v = bitmap.lookup(glam::Vec2::new(uv.0, uv.1));
            if bad(v) {
                return Err(format!("lookup at {uv:?} gives {v}"));
            }
        }
    }
    Ok(Verdict::Read)
}

/// An image refusal names the file; a decoder rarely knows a line, so no place is asked.
fn image_refusal(e: &Error, files: &[&str]) -> Outcome {
    match e {
        Error::Input(msg) if !msg.trim().is_empty() && files.iter().any(|f| names_file(msg, f)) => {
            Ok(Verdict::Rejected)
        }
        _ => Err(format!("not an input error naming {files:?} (exit code {}): {e}", e.exit_code())),
    }
}

// ---------------------------------------------------------------------------------------
// Structure-aware scenes: values drawn by `arbitrary`, written as TOML or Mitsuba XML.

/// A number: usually a small multiple of 1/8, sometimes any f32 (NaN, infinities, 1e38).
#[derive(Arbitrary, Clone, Copy, Debug)]
pub enum Real {
    /// `n / 8`.
    Eighths(i8),
    /// Exactly this f32.
    Raw(f32),
}

impl Real {
    /// The value.
    pub fn get(self) -> f32 {
        match self {
            Real::Eighths(n) => n as f32 / 8.0,
            Real::Raw(x) => x,
        }
    }

    /// As TOML writes it (`nan`, `inf`, `-inf` included).
    fn toml(self) -> String {
        let x = self.get();
        if x.is_nan() {
            "nan".into()
        } else if x.is_infinite() {
            if x > 0.0 { "inf" } else { "-inf" }.into()
        } else {
            format!("{x:?}")
        }
    }

    /// As Mitsuba writes it.
    fn xml(self) -> String {
        format!("{}", self.get())
    }
}

/// A count: usually 1 to 4, sometimes any u16.
#[derive(Arbitrary, Clone, Copy, Debug)]
pub enum Count {
    /// `1 + n % 4`.
    Small(u8),
    /// Exactly this.
    Raw(u16),
}

impl Count {
    /// The value.
    pub fn get(self) -> u32 {
        match self {
            Count::Small(n) => 1 + (n % 4) as u32,
            Count::Raw(n) => n as u32,
        }
    }
}

/// Three numbers.
pub type Triple = [Real; 3];

fn toml3(v: &Triple) -> String {
    format!("[{}, {}, {}]", v[0].toml(), v[1].toml(), v[2].toml())
}

/// A `to_world` matrix taking Mitsuba's rectangle ([-1, 1]² at z = 0) to the
/// parallelogram with centre `c` and half-edges `u`, `v` (z goes along `u`).
fn xml_frame(c: &Triple, u: &Triple, v: &Triple) -> String {
    let row = |k: usize| format!("{} {} {} {}", u[k].xml(), v[k].xml(), u[k].xml(), c[k].xml());
    format!("<transform name=\"to_world\"><matrix value=\"{} {} {} 0 0 0 1\"/></transform>", row(0), row(1), row(2))
}

fn xml3(v: &Triple) -> String {
    format!("{}, {}, {}", v[0].xml(), v[1].xml(), v[2].xml())
}

/// A material.
#[derive(Arbitrary, Clone, Debug)]
pub enum MaterialValues {
    /// Lambert with an optional Phong lobe.
    Diffuse {
        /// Albedo.
        color: Triple,
        /// Phong reflectance.
        specular: Option<(Triple, Real)>,
    },
    /// A mirror.
    Mirror(Triple),
    /// Glass: ior and a fixed ratio or Fresnel.
    Dielectric {
        /// Index of refraction.
        ior: Real,
        /// The paper's C; Fresnel when absent.
        ratio: Option<Real>,
    },
    /// A conductor: a named metal (an index into [`METALS`], past its end an unknown
    /// name) or eta and k, a roughness, and a texture for its reflectance.
    Conductor {
        /// Which metal, or eta and k.
        metal: Result<u8, (Triple, Triple)>,
        /// Roughness, smooth when absent.
        roughness: Option<Roughness>,
        /// Reflectance texture.
        texture: Option<TextureValues>,
    },
    /// Rough glass.
    RoughDielectric {
        /// Index of refraction.
        ior: Real,
        /// Roughness.
        roughness: Roughness,
    },
    /// Lambert with a textured albedo.
    Textured(TextureValues),
}

/// Named metals the structured scenes draw from (the last is not one).
const METALS: [&str; 5] = ["Au", "Cu", "Al", "none", "Unobtainium"];

/// A microfacet roughness: alpha (or alpha_u with alpha_v), GGX or Beckmann.
#[derive(Arbitrary, Clone, Copy, Debug)]
pub struct Roughness {
    /// alpha, or alpha_u.
    pub alpha: Real,
    /// alpha_v: anisotropic when present.
    pub alpha_v: Option<Real>,
    /// GGX rather than Beckmann.
    pub ggx: bool,
}

impl Roughness {
    fn toml(&self) -> String {
        let d = if self.ggx { "ggx" } else { "beckmann" };
        match self.alpha_v {
            None => format!("distribution = \"{d}\"\nalpha = {}\n", self.alpha.toml()),
            Some(v) => format!("distribution = \"{d}\"\nalpha_u = {}\nalpha_v = {}\n", self.alpha.toml(), v.toml()),
        }
    }

    fn xml(&self) -> String {
        let d = if self.ggx { "ggx" } else { "beckmann" };
        let a = match self.alpha_v {
            None => format!("<float name=\"alpha\" value=\"{}\"/>", self.alpha.xml()),
            Some(v) => {
                format!(
                    "<float name=\"alpha_u\" value=\"{}\"/><float name=\"alpha_v\" value=\"{}\"/>",
                    self.alpha.xml(),
                    v.xml()
                )
            }
        };
        format!("<string name=\"distribution\" value=\"{d}\"/>{a}")
    }
}

/// A texture in a colour's place.
#[derive(Arbitrary, Clone, Debug)]
pub enum TextureValues {
    /// Two colours and a `to_uv` scale.
    Checkerboard(Triple, Triple, Real),
    /// A bitmap file in the sandbox: a PNG of `width` columns of these bytes as RGB
    /// texels when `png`, else the bytes themselves as the file; wrap mode (modulo 4:
    /// one is not a mode), nearest filtering, raw values.
    Bitmap {
        /// Texel bytes, or the whole file.
        bytes: Vec<u8>,
        /// Columns of the PNG.
        width: u8,
        /// Encode a PNG from the bytes.
        png: bool,
        /// Wrap mode.
        wrap: u8,
        /// Nearest filtering.
        nearest: bool,
        /// Raw values.
        raw: bool,
    },
}

/// Wrap modes as the scene formats spell them; the last is not one.
const WRAPS: [&str; 4] = ["repeat", "mirror", "clamp", "tile"];

impl TextureValues {
    /// The TOML inline table of texture `k` (its file, if any, is `tex{k}.png`).
    fn toml(&self, k: usize) -> String {
        match self {
            TextureValues::Checkerboard(a, b, s) => format!(
                "{{ type = \"checkerboard\", color0 = {}, color1 = {}, to_uv = [{{ scale = [{s}, {s}, 1] }}] }}",
                toml3(a),
                toml3(b),
                s = s.toml()
            ),
            TextureValues::Bitmap { wrap, nearest, raw, .. } => format!(
                "{{ type = \"bitmap\", file = \"tex{k}.png\", wrap = \"{}\", filter = \"{}\", raw = {raw} }}",
                WRAPS[*wrap as usize % 4],
                if *nearest { "nearest" } else { "bilinear" }
            ),
        }
    }

    /// The XML `<texture>` of texture `k` in a colour named `name`.
    fn xml(&self, k: usize, name: &str) -> String {
        match self {
            TextureValues::Checkerboard(a, b, s) => format!(
                "<texture type=\"checkerboard\" name=\"{name}\"><rgb name=\"color0\" value=\"{}\"/><rgb name=\"color1\" value=\"{}\"/>\
                 <transform name=\"to_uv\"><scale value=\"{}\"/></transform></texture>",
                xml3(a),
                xml3(b),
                s.xml()
            ),
            TextureValues::Bitmap { wrap, nearest, raw, .. } => format!(
                "<texture type=\"bitmap\" name=\"{name}\"><string name=\"filename\" value=\"tex{k}.png\"/>\
                 <string name=\"wrap_mode\" value=\"{}\"/><string name=\"filter_type\" value=\"{}\"/><boolean name=\"raw\" value=\"{raw}\"/></texture>",
                WRAPS[*wrap as usize % 4],
                if *nearest { "nearest" } else { "bilinear" }
            ),
        }
    }

    /// The file of a bitmap: a PNG encoded from the bytes, or the bytes.
    fn file(&self) -> Option<Vec<u8>> {
        let TextureValues::Bitmap { bytes, width, png, .. } = self else { return None };
        if !*png {
            return Some(bytes.clone());
        }
        let w = (*width as usize).clamp(1, 64);
        let h = (bytes.len() / 3 / w).clamp(1, 64);
        let mut rgb = bytes.clone();
        rgb.resize(w * h * 3, 0);
        Some(png_bytes(w as u32, h as u32, &rgb))
    }
}

/// An 8-bit RGB PNG of these texels, written by the renderer's own PNG writer.
fn png_bytes(width: u32, height: u32, rgb: &[u8]) -> Vec<u8> {
    let sandbox = Sandbox::new();
    let path = sandbox.dir().join("t.png");
    wavetrace::tools::output::write_png(&path, width, height, rgb).expect("encoding a PNG in the sandbox");
    std::fs::read(&path).expect("reading the PNG back")
}

/// A light.
#[derive(Arbitrary, Clone, Debug)]
pub enum LightValues {
    /// A parallelogram: corner, two edges, radiance.
    Quad(Triple, Triple, Triple, Triple),
    /// A triangle: three vertices, radiance.
    Triangle(Triple, Triple, Triple, Triple),
    /// A point: position, intensity.
    Point(Triple, Triple),
}

/// An object; the `u8` picks a material (modulo their number; a missing one is an error).
#[derive(Arbitrary, Clone, Debug)]
pub enum ObjectValues {
    /// Centre, radius.
    Sphere(Triple, Real, u8),
    /// Corner, two edges.
    Quad(Triple, Triple, Triple, u8),
    /// A mesh written to the sandbox as OBJ or PLY.
    Mesh {
        /// Its triangles (at most 64 are written).
        triangles: Vec<[Triple; 3]>,
        /// PLY (binary little-endian) rather than OBJ.
        ply: bool,
        /// Interpolated normals.
        smooth: bool,
        /// Uniform scale.
        scale: Real,
        /// Emission instead of a material.
        emission: Option<Triple>,
        /// Material.
        material: u8,
    },
}

/// A whole scene's values.
#[derive(Arbitrary, Clone, Debug)]
pub struct SceneValues {
    /// Written as Mitsuba XML rather than TOML.
    pub xml: bool,
    /// Film size.
    pub size: (Count, Count),
    /// Depth of the specular tree.
    pub max_depth: u8,
    /// Seed.
    pub seed: u32,
    /// Camera samples per pixel, or adaptive (eps, min level, max level).
    pub aa: Result<Count, (Real, u8, u8)>,
    /// Shadow rays per point, adaptive with a probe kind (0..4).
    pub shadows: (Count, Option<u8>),
    /// Lens samples.
    pub dof_samples: Count,
    /// Multiple importance sampling at rough hits (`render.gloss.mis`, TOML only).
    pub gloss_mis: bool,
    /// Position, look-at, up, fov_y, aperture and focus distance.
    pub camera: (Triple, Triple, Triple, Real, Option<(Real, Real)>),
    /// Background colour.
    pub background: Triple,
    /// Materials (at most 4 written).
    pub materials: Vec<MaterialValues>,
    /// Lights (at most 4 written).
    pub lights: Vec<LightValues>,
    /// Objects (at most 8 written).
    pub objects: Vec<ObjectValues>,
}

/// A mesh file's bytes: OBJ text, or binary little-endian PLY.
fn mesh_bytes(triangles: &[[Triple; 3]], ply: bool) -> Vec<u8> {
    let tris = &triangles[..triangles.len().min(64)];
    if !ply {
        let mut s = String::new();
        for t in tris {
            for v in t {
                s += &format!("v {} {} {}\n", v[0].get(), v[1].get(), v[2].get());
            }
        }
        for i in 0..tris.len() {
            s += &format!("f {} {} {}\n", 3 * i + 1, 3 * i + 2, 3 * i + 3);
        }
        return s.into_bytes();
    }
    let mut out = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\nproperty float y\n\
         property float z\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
        3 * tris.len(),
        tris.len()
    )
    .into_bytes();
    for t in tris {
        for v in t {
            for c in v {
                out.extend_from_slice(&c.get().to_le_bytes());
            }
        }
    }
    for i in 0..tris.len() as i32 {
        out.push(3);
        for k in 0..3 {
            out.extend_from_slice(&(3 * i + k).to_le_bytes());
        }
    }
    out
}

impl SceneValues {
    fn materials(&self) -> &[MaterialValues] {
        &self.materials[..self.materials.len().min(4)]
    }

    fn lights(&self) -> &[LightValues] {
        &self.lights[..self.lights.len().min(4)]
    }

    fn objects(&self) -> &[ObjectValues] {
        &self.objects[..self.objects.len().min(8)]
    }

    /// The material name object `k`'s byte picks: `m0`.. (or `none` with no materials).
    fn material(&self, k: u8) -> String {
        match self.materials().len() {
            0 => "none".into(),
            n => format!("m{}", k as usize % n),
        }
    }

    /// The files (name, bytes) the objects and materials name: meshes and textures.
    pub fn mesh_files(&self) -> Vec<(String, Vec<u8>)> {
        let mut out = Vec::new();
        for (i, o) in self.objects().iter().enumerate() {
            if let ObjectValues::Mesh { triangles, ply, .. } = o {
                let name = format!("mesh{i}.{}", if *ply { "ply" } else { "obj" });
                out.push((name, mesh_bytes(triangles, *ply)));
            }
        }
        for (i, m) in self.materials().iter().enumerate() {
            let texture = match m {
                MaterialValues::Textured(x) | MaterialValues::Conductor { texture: Some(x), .. } => x,
                _ => continue,
            };
            if let Some(bytes) = texture.file() {
                out.push((format!("tex{i}.png"), bytes));
            }
        }
        out
    }

    /// The scene as wavetrace's TOML.
    pub fn to_toml(&self) -> String {
        let mut s = format!(
            "[render]\nwidth = {}\nheight = {}\nmax_depth = {}\nseed = {}\n",
            self.size.0.get(),
            self.size.1.get(),
            self.max_depth,
            self.seed
        );
        match self.aa {
            Ok(n) => s += &format!("[render.aa]\nmode = \"uniform\"\nsamples = {}\n", n.get()),
            Err((eps, lo, hi)) => {
                s += &format!(
                    "[render.aa]\nmode = \"adaptive\"\neps = {}\nmin_level = {lo}\nmax_level = {hi}\n",
                    eps.toml()
                )
            }
        }
        let (n, adaptive) = self.shadows;
        s += &format!("[render.shadows]\nsamples = {}\n", n.get());
        if let Some(p) = adaptive {
            let probe = ["corners", "corners+center", "jittered", "3x3"][p as usize % 4];
            s += &format!("mode = \"adaptive\"\nprobe = \"{probe}\"\n");
        }
        s += &format!("[render.dof]\nsamples = {}\n", self.dof_samples.get());
        s += &format!("[render.gloss]\nmis = {}\n", self.gloss_mis);
        let (pos, at, up, fov, lens) = &self.camera;
        s += &format!(
            "[camera]\nposition = {}\nlook_at = {}\nup = {}\nfov_y = {}\n",
            toml3(pos),
            toml3(at),
            toml3(up),
            fov.toml()
        );
        if let Some((aperture, focus)) = lens {
            s += &format!("aperture = {}\nfocus_distance = {}\n", aperture.toml(), focus.toml());
        }
        s += &format!("[background]\ncolor = {}\n", toml3(&self.background));
        for (i, m) in self.materials().iter().enumerate() {
            s += &format!("[materials.m{i}]\n");
            s += &match m {
                MaterialValues::Diffuse { color, specular: None } => {
                    format!("type = \"diffuse\"\ncolor = {}\n", toml3(color))
                }
                MaterialValues::Diffuse { color, specular: Some((sp, sh)) } => format!(
                    "type = \"diffuse\"\ncolor = {}\nspecular = {}\nshininess = {}\n",
                    toml3(color),
                    toml3(sp),
                    sh.toml()
                ),
                MaterialValues::Mirror(c) => format!("type = \"mirror\"\ncolor = {}\n", toml3(c)),
                MaterialValues::Dielectric { ior, ratio } => {
                    let ratio = ratio.map_or("\"fresnel\"".into(), |r| r.toml());
                    format!("type = \"dielectric\"\nior = {}\nreflect_ratio = {ratio}\n", ior.toml())
                }
                MaterialValues::Conductor { metal, roughness, texture } => {
                    let mut t = "type = \"conductor\"\n".to_string();
                    t += &match metal {
                        Ok(k) => format!("material = \"{}\"\n", METALS[*k as usize % METALS.len()]),
                        Err((eta, k)) => format!("eta = {}\nk = {}\n", toml3(eta), toml3(k)),
                    };
                    t += &roughness.map_or(String::new(), |r| r.toml());
                    t + &texture.as_ref().map_or(String::new(), |x| format!("color = {}\n", x.toml(i)))
                }
                MaterialValues::RoughDielectric { ior, roughness } => {
                    format!("type = \"dielectric\"\nior = {}\n{}", ior.toml(), roughness.toml())
                }
                MaterialValues::Textured(x) => format!("type = \"diffuse\"\ncolor = {}\n", x.toml(i)),
            };
        }
        for l in self.lights() {
            s += &match l {
                LightValues::Quad(c, u, v, r) => format!(
                    "[[lights]]\ntype = \"quad\"\ncorner = {}\nedge_u = {}\nedge_v = {}\nradiance = {}\n",
                    toml3(c),
                    toml3(u),
                    toml3(v),
                    toml3(r)
                ),
                LightValues::Triangle(a, b, c, r) => format!(
                    "[[lights]]\ntype = \"triangle\"\nv0 = {}\nv1 = {}\nv2 = {}\nradiance = {}\n",
                    toml3(a),
                    toml3(b),
                    toml3(c),
                    toml3(r)
                ),
                LightValues::Point(p, i) => {
                    format!("[[lights]]\ntype = \"point\"\nposition = {}\nintensity = {}\n", toml3(p), toml3(i))
                }
            };
        }
        for (i, o) in self.objects().iter().enumerate() {
            s += &match o {
                ObjectValues::Sphere(c, r, m) => format!(
                    "[[objects]]\ntype = \"sphere\"\ncenter = {}\nradius = {}\nmaterial = \"{}\"\n",
                    toml3(c),
                    r.toml(),
                    self.material(*m)
                ),
                ObjectValues::Quad(c, u, v, m) => format!(
                    "[[objects]]\ntype = \"quad\"\ncorner = {}\nedge_u = {}\nedge_v = {}\nmaterial = \"{}\"\n",
                    toml3(c),
                    toml3(u),
                    toml3(v),
                    self.material(*m)
                ),
                ObjectValues::Mesh { ply, smooth, scale, emission, material, .. } => {
                    let file = format!("mesh{i}.{}", if *ply { "ply" } else { "obj" });
                    let look = match emission {
                        Some(e) => format!("emission = {}\n", toml3(e)),
                        None => format!("material = \"{}\"\n", self.material(*material)),
                    };
                    format!(
                        "[[objects]]\ntype = \"mesh\"\nfile = \"{file}\"\nsmooth = {smooth}\nscale = {}\n{look}",
                        scale.toml()
                    )
                }
            };
        }
        s
    }

    /// The scene as Mitsuba 3 XML (the subset wavetrace imports).
    pub fn to_xml(&self) -> String {
        let (pos, at, up, fov, lens) = &self.camera;
        let spp = match self.aa {
            Ok(n) => n.get(),
            Err(_) => 4,
        };
        let sensor = match lens {
            None => "perspective".to_string(),
            Some(_) => "thinlens".to_string(),
        };
        let mut s = format!("<scene version=\"3.0.0\">\n<integrator type=\"path\"><integer name=\"max_depth\" value=\"{}\"/></integrator>\n", self.max_depth);
        s += &format!(
            "<sensor type=\"{sensor}\">\n<float name=\"fov\" value=\"{}\"/>\n<string name=\"fov_axis\" value=\"y\"/>\n",
            fov.xml()
        );
        if let Some((aperture, focus)) = lens {
            s += &format!(
                "<float name=\"aperture_radius\" value=\"{}\"/>\n<float name=\"focus_distance\" value=\"{}\"/>\n",
                aperture.xml(),
                focus.xml()
            );
        }
        s += &format!(
            "<transform name=\"to_world\"><lookat origin=\"{}\" target=\"{}\" up=\"{}\"/></transform>\n",
            xml3(pos),
            xml3(at),
            xml3(up)
        );
        s += &format!(
            "<sampler type=\"independent\"><integer name=\"sample_count\" value=\"{spp}\"/></sampler>\n\
             <film type=\"hdrfilm\"><integer name=\"width\" value=\"{}\"/><integer name=\"height\" value=\"{}\"/></film>\n</sensor>\n",
            self.size.0.get(),
            self.size.1.get()
        );
        for (i, m) in self.materials().iter().enumerate() {
            s += &match m {
                MaterialValues::Diffuse { color, .. } => format!(
                    "<bsdf type=\"diffuse\" id=\"m{i}\"><rgb name=\"reflectance\" value=\"{}\"/></bsdf>\n",
                    xml3(color)
                ),
                MaterialValues::Mirror(c) => format!(
                    "<bsdf type=\"conductor\" id=\"m{i}\"><string name=\"material\" value=\"none\"/><rgb name=\"specular_reflectance\" value=\"{}\"/></bsdf>\n",
                    xml3(c)
                ),
                MaterialValues::Dielectric { ior, .. } => format!(
                    "<bsdf type=\"dielectric\" id=\"m{i}\"><float name=\"int_ior\" value=\"{}\"/></bsdf>\n",
                    ior.xml()
                ),
                MaterialValues::Conductor { metal, roughness, texture } => {
                    let kind = if roughness.is_some() { "roughconductor" } else { "conductor" };
                    let metal = match metal {
                        Ok(k) => format!("<string name=\"material\" value=\"{}\"/>", METALS[*k as usize % METALS.len()]),
                        Err((eta, k)) => {
                            format!("<rgb name=\"eta\" value=\"{}\"/><rgb name=\"k\" value=\"{}\"/>", xml3(eta), xml3(k))
                        }
                    };
                    let rough = roughness.map_or(String::new(), |r| r.xml());
                    let tex = texture.as_ref().map_or(String::new(), |x| x.xml(i, "specular_reflectance"));
                    format!("<bsdf type=\"{kind}\" id=\"m{i}\">{metal}{rough}{tex}</bsdf>\n")
                }
                MaterialValues::RoughDielectric { ior, roughness } => format!(
                    "<bsdf type=\"roughdielectric\" id=\"m{i}\"><float name=\"int_ior\" value=\"{}\"/>{}</bsdf>\n",
                    ior.xml(),
                    roughness.xml()
                ),
                MaterialValues::Textured(x) => {
                    format!("<bsdf type=\"diffuse\" id=\"m{i}\">{}</bsdf>\n", x.xml(i, "reflectance"))
                }
            };
        }
        s += &format!(
            "<emitter type=\"constant\"><rgb name=\"radiance\" value=\"{}\"/></emitter>\n",
            xml3(&self.background)
        );
        for l in self.lights() {
            s += &match l {
                LightValues::Quad(c, u, v, r) | LightValues::Triangle(c, u, v, r) => format!(
                    "<shape type=\"rectangle\">{}<emitter type=\"area\"><rgb name=\"radiance\" value=\"{}\"/></emitter></shape>\n",
                    xml_frame(c, u, v),
                    xml3(r)
                ),
                LightValues::Point(p, i) => format!(
                    "<emitter type=\"point\"><point name=\"position\" value=\"{}\"/><rgb name=\"intensity\" value=\"{}\"/></emitter>\n",
                    xml3(p),
                    xml3(i)
                ),
            };
        }
        for (i, o) in self.objects().iter().enumerate() {
            s += &match o {
                ObjectValues::Sphere(c, r, m) => format!(
                    "<shape type=\"sphere\"><point name=\"center\" value=\"{}\"/><float name=\"radius\" value=\"{}\"/><ref id=\"{}\"/></shape>\n",
                    xml3(c),
                    r.xml(),
                    self.material(*m)
                ),
                ObjectValues::Quad(c, u, v, m) => format!(
                    "<shape type=\"rectangle\">{}<ref id=\"{}\"/></shape>\n",
                    xml_frame(c, u, v),
                    self.material(*m)
                ),
                ObjectValues::Mesh { ply, smooth, scale, emission, material, .. } => {
                    let kind = if *ply { "ply" } else { "obj" };
                    let look = match emission {
                        Some(e) => format!("<emitter type=\"area\"><rgb name=\"radiance\" value=\"{}\"/></emitter>", xml3(e)),
                        None => format!("<ref id=\"{}\"/>", self.material(*material)),
                    };
                    format!(
                        "<shape type=\"{kind}\"><string name=\"filename\" value=\"mesh{i}.{kind}\"/><boolean name=\"face_normals\" value=\"{}\"/>\
                         <transform name=\"to_world\"><scale value=\"{}\"/></transform>{look}</shape>\n",
                        !smooth,
                        scale.xml()
                    )
                }
            };
        }
        s + "</scene>\n"
    }
}

/// A structure-aware scene: the values written as TOML or XML with their mesh files, then
/// loaded and checked as [`scene_toml`] and [`mitsuba_xml`] check theirs.
pub fn scene_values(values: &SceneValues) -> Outcome {
    let sandbox = Sandbox::new();
    let meshes = values.mesh_files();
    for (name, bytes) in &meshes {
        sandbox.write(name, bytes);
    }
    let main = if values.xml { "scene.xml" } else { "scene.toml" };
    let text = if values.xml { values.to_xml() } else { values.to_toml() };
    let path = sandbox.write(main, text.as_bytes());
    let mut files = vec![main];
    files.extend(meshes.iter().map(|(n, _)| n.as_str()));
    match SceneSource::from_file(&path) {
        Ok(src) => check_source(&src, &[], &files),
        Err(e) => refusal(&e, &files),
    }
}

/// [`scene_values`] from raw fuzzer bytes, decoded as libfuzzer-sys decodes a typed
/// target's input (`arbitrary_take_rest` after its size check), so the replay checks the
/// scenes the fuzzer checked; bytes too short for a value are no input.
pub fn scene_values_bytes(data: &[u8]) -> Outcome {
    if data.len() < SceneValues::size_hint(0).0 {
        return Ok(Verdict::Rejected);
    }
    match SceneValues::arbitrary_take_rest(arbitrary::Unstructured::new(data)) {
        Ok(values) => scene_values(&values),
        Err(_) => Ok(Verdict::Rejected),
    }
}

/// A target's check of one input.
pub type Target = fn(&[u8]) -> Outcome;

/// Every target by name: the corpus folder names of `fuzz/corpus/`.
pub const TARGETS: [(&str, Target); 6] = [
    ("scene_toml", scene_toml),
    ("obj", obj),
    ("ply", ply),
    ("mitsuba_xml", mitsuba_xml),
    ("image", image),
    ("scene_values", scene_values_bytes),
];
