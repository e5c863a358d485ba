//! Loading a scene: TOML parsing, `--set` overrides, validation with file/line/field
//! in every message, mesh loading, and the BVH build. The objects and lights of a scene
//! description become primitives in `objects`.

mod materials;
mod meshes;
mod motion;
mod objects;

use glam::{Mat3, Vec3};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::Path;

use super::format::*;
use super::text::line_col;
use super::values::{check_finite, color, in_range, transform, vec3, Ctx, SceneSource, MAX_COORD, MAX_DEPTH};
use super::{
    AaMode, AreaLights, Camera, Light, Material, PenumbraStop, Probe, Scene, SceneInfo, Settings, ShadowMode, Transport,
};
use crate::accel::BvhQuality;
use crate::accel::NO_LIGHT;
use crate::emitter::environment::{Environment, LatLong};
use crate::texture::{Bitmap, Filter, Wrap};
use crate::{Error, Result};

/// Highest adaptive refinement level: 2^16 samples per pixel.
pub const MAX_LEVEL: u32 = 16;

/// Bytes each pixel costs while rendering and writing: film sum, output buffers, the
/// shared corner grid with its heat counters, the per-pixel heat counters, and the two
/// blur radii per corner of DOF-aware anti-aliasing.
pub const BYTES_PER_PIXEL: u64 = 12 + 12 + 4 + 24 + 16 + 8;

/// Parses, overrides, validates and builds a scene. `sets` are `KEY=VALUE` overrides
/// with dotted keys (array elements by index: `objects.0.radius=2`).
pub fn load(src: &SceneSource, sets: &[String]) -> Result<Scene> {
    if let Some(path) = &src.xml {
        return load_xml(src, path, sets);
    }
    let ctx = Ctx::new(src, true, sets, &[]);
    // A serde error in the file: located, with the field it is about when it points at a
    // value (a bad `mode` or `probe`, a wrong type).
    let toml_err = |e: toml::de::Error| {
        let loc = e.span().map(|s| line_col(&src.text, s.start));
        let field = e.span().and_then(|s| ctx.field_at(s.start)).unwrap_or_default();
        let line_text = loc.and_then(|(l, _)| src.text.lines().nth(l - 1)).unwrap_or("").trim();
        let mut msg = e.message().trim().to_string();
        if !line_text.is_empty() {
            msg = format!("{msg} (in `{line_text}`)");
        }
        Error::at(&src.name, loc, &field, msg)
    };
    let mut value: toml::Value = toml::from_str::<toml::Table>(&src.text).map(toml::Value::Table).map_err(toml_err)?;
    check_finite(&value, "", &ctx)?;
    // The file alone first, so its errors carry line and column: from the parsed value,
    // and only on an error again from the text, whose error has the position.
    let mut file = match SceneFile::deserialize(value.clone()) {
        Ok(file) => file,
        Err(e) => {
            return Err(match toml::from_str::<SceneFile>(&src.text) {
                Err(located) => toml_err(located),
                Ok(_) => Error::input(format!("{}: {}", src.name, e.message().trim())),
            })
        }
    };
    // Overrides are applied one at a time and the result read once: on an error they are
    // read again one at a time, so it names the --set that caused it.
    let with_file = value.clone();
    for set in sets {
        apply_set(&mut value, set, &src.name)?;
        check_finite(&value, "", &ctx)?;
    }
    if !sets.is_empty() {
        file = match SceneFile::deserialize(value) {
            Ok(file) => file,
            Err(_) => return Err(first_bad_set(with_file, sets, &src.name)),
        };
    }
    build(&file, &ctx)
}

/// The error of the first of `sets` (each of which applies) after which the scene
/// `value` no longer reads, naming it and its key.
fn first_bad_set(mut value: toml::Value, sets: &[String], name: &str) -> Error {
    for set in sets {
        if let Err(e) = apply_set(&mut value, set, name) {
            return e;
        }
        if let Err(e) = SceneFile::deserialize(value.clone()) {
            // The file alone read, so the error is this override's: name its key.
            let key = set.split_once('=').map_or(set.as_str(), |(k, _)| k).trim();
            return Error::input(format!("{name} (--set {set}): field `{key}`: {}", e.message().trim()));
        }
    }
    Error::Internal(format!("{name}: the overrides together do not read, but each one does"))
}

/// Imports a Mitsuba XML scene, applies `--set` overrides to the scene it maps to (same
/// dotted paths as the TOML format), and builds it.
fn load_xml(src: &SceneSource, path: &Path, sets: &[String]) -> Result<Scene> {
    let imported = super::mitsuba::import(path, &src.defines)?;
    let ctx = Ctx::new(src, false, sets, &imported.places);
    let mut file = imported.file;
    if !sets.is_empty() {
        let mut value = toml::Value::try_from(&file).map_err(|e| Error::Internal(format!("imported scene: {e}")))?;
        for set in sets {
            apply_set(&mut value, set, &src.name)?;
            check_finite(&value, "", &ctx)?;
            let key = set.split_once('=').map_or(set.as_str(), |(k, _)| k).trim();
            file = SceneFile::deserialize(value.clone()).map_err(|e| {
                Error::input(format!("{} (--set {set}): field `{key}`: {}", src.name, e.message().trim()))
            })?;
        }
    }
    let mut scene = build(&file, &ctx)?;
    scene.info.notes = imported.notes;
    scene.info.inputs.extend(imported.includes.into_iter().map(|p| ("a file the scene includes".to_string(), p)));
    Ok(scene)
}

/// Applies one `--set`; an error names the scene it was given with and the string.
fn apply_set(root: &mut toml::Value, set: &str, scene: &str) -> Result<()> {
    let bad = |msg: &str| Error::input(format!("{scene} (--set `{set}`): {msg}"));
    let (key, raw) = set.split_once('=').ok_or_else(|| bad("expected KEY=VALUE"))?;
    let segs: Vec<&str> = key.trim().split('.').collect();
    if segs.iter().any(|s| s.is_empty()) {
        return Err(bad("empty key segment"));
    }
    // A TOML literal if it parses as one (numbers, arrays, booleans, quoted strings), else a bare string.
    let value = toml::from_str::<toml::Table>(&format!("v = {raw}"))
        .ok()
        .and_then(|mut t| t.remove("v"))
        .unwrap_or_else(|| toml::Value::String(raw.to_string()));
    let mut cur = root;
    for (i, seg) in segs.iter().enumerate() {
        let last = i + 1 == segs.len();
        cur = match cur {
            toml::Value::Table(t) => {
                if last {
                    t.insert(seg.to_string(), value);
                    return Ok(());
                }
                t.entry(seg.to_string()).or_insert_with(|| toml::Value::Table(toml::Table::new()))
            }
            toml::Value::Array(a) => {
                let idx: usize = seg.parse().map_err(|_| bad(&format!("`{seg}` is not an array index")))?;
                let len = a.len();
                let slot = a.get_mut(idx).ok_or_else(|| bad(&format!("index {idx} out of range (length {len})")))?;
                if last {
                    *slot = value;
                    return Ok(());
                }
                slot
            }
            _ => return Err(bad(&format!("`{}` is not a table", segs[..i].join(".")))),
        };
    }
    Ok(())
}

/// The image size: at least one pixel, at most 2^32, and within half the memory.
fn image_size(r: &RenderDesc, ctx: &Ctx) -> Result<()> {
    if r.width == 0 {
        return Err(ctx.fail("render.width", "must be at least 1"));
    }
    if r.height == 0 {
        return Err(ctx.fail("render.height", "must be at least 1"));
    }
    if r.max_depth > MAX_DEPTH {
        // Each bounce level keeps a queue; past this, contributions are below f32 noise.
        return Err(ctx.fail("render.max_depth", format!("{} is more than {MAX_DEPTH}", r.max_depth)));
    }
    let pixels = r.width as u64 * r.height as u64;
    let need = pixels.saturating_mul(BYTES_PER_PIXEL);
    let have = crate::system::available_memory();
    // Blame the dimension a --set changed, if one did.
    let dim_path =
        if ctx.sets.iter().any(|s| s.starts_with("render.height=")) { "render.height" } else { "render.width" };
    if need > have / 2 {
        return Err(ctx.fail(
            dim_path,
            format!(
                "{}×{} pixels would need {:.1} GiB of memory; {:.1} GiB is available (at most half of it may be used)",
                r.width,
                r.height,
                need as f64 / (1u64 << 30) as f64,
                have as f64 / (1u64 << 30) as f64
            ),
        ));
    }
    // Pixel indices are u32 in the queues.
    if pixels > u32::MAX as u64 {
        return Err(
            ctx.fail(dim_path, format!("{}×{} pixels: more than 2^32 pixels are not supported", r.width, r.height))
        );
    }
    Ok(())
}

/// Anti-aliasing: uniform, or the paper's adaptive corners with its levels checked.
fn aa_mode(aa: &AaDesc, ctx: &Ctx) -> Result<AaMode> {
    Ok(match aa.mode {
        SamplingDesc::Uniform => AaMode::Uniform,
        SamplingDesc::Variance | SamplingDesc::Auto => {
            if !(aa.threshold >= 0.0 && aa.threshold.is_finite()) {
                return Err(ctx.fail("render.aa.threshold", format!("{} must be finite and >= 0", aa.threshold)));
            }
            // Two samples at least: one in each half-buffer. Auto may cap its samples
            // below its pilot's: it then renders uniform at `samples`, with no pilot.
            let max = if aa.mode == SamplingDesc::Auto { u32::MAX } else { aa.samples.max(2) };
            if !(2..=max).contains(&aa.min_samples) {
                let path = if ctx.sets.iter().any(|s| s.starts_with("render.aa.samples=")) {
                    "render.aa.samples"
                } else {
                    "render.aa.min_samples"
                };
                let range = if max == u32::MAX { "2..".to_string() } else { format!("2..=samples ({})", aa.samples) };
                return Err(ctx.fail(path, format!("min_samples ({}) must be in {range}", aa.min_samples)));
            }
            let (threshold, min_samples) = (aa.threshold, aa.min_samples);
            if aa.mode == SamplingDesc::Auto {
                AaMode::Auto { threshold, min_samples }
            } else {
                AaMode::Variance { threshold, min_samples }
            }
        }
        SamplingDesc::Adaptive => {
            if aa.eps < 0.0 {
                return Err(ctx.fail("render.aa.eps", "must be >= 0"));
            }
            if !(2..=MAX_LEVEL).contains(&aa.max_level) {
                return Err(ctx.fail("render.aa.max_level", format!("{} is not in 2..={MAX_LEVEL}", aa.max_level)));
            }
            if !(2..=aa.max_level).contains(&aa.min_level) {
                // Blame the one a --set changed, if either was.
                let path = if ctx.sets.iter().any(|s| s.starts_with("render.aa.max_level=")) {
                    "render.aa.max_level"
                } else {
                    "render.aa.min_level"
                };
                return Err(
                    ctx.fail(path, format!("min_level ({}) must be in 2..=max_level ({})", aa.min_level, aa.max_level))
                );
            }
            if aa.dof_radius <= 0.0 {
                return Err(ctx.fail("render.aa.dof_radius", format!("{} must be > 0", aa.dof_radius)));
            }
            AaMode::Adaptive {
                eps: aa.eps,
                min_level: aa.min_level,
                max_level: aa.max_level,
                share_corners: aa.share_corners,
            }
        }
    })
}

fn settings(r: &RenderDesc, cam: &CameraDesc, ctx: &Ctx) -> Result<Settings> {
    image_size(r, ctx)?;
    let aa_mode = aa_mode(&r.aa, ctx)?;
    let probe = match r.shadows.probe {
        ProbeDesc::Corners => Probe::Corners,
        ProbeDesc::CornersCenter => Probe::CornersCenter,
        ProbeDesc::Jittered => Probe::Jittered,
        ProbeDesc::Grid3 => Probe::Grid3,
    };
    let shadow_mode = match r.shadows.mode {
        SamplingDesc::Uniform => ShadowMode::Uniform,
        SamplingDesc::Adaptive => ShadowMode::Adaptive(probe),
        SamplingDesc::Auto => ShadowMode::Auto(probe),
        SamplingDesc::Variance => {
            return Err(ctx.fail(
                "render.shadows.mode",
                "\"variance\" is an anti-aliasing mode; shadows are \"uniform\", \"adaptive\" or \"auto\"",
            ))
        }
    };
    if !(0.0..=1.0).contains(&r.shadows.tolerance) {
        return Err(ctx.fail("render.shadows.tolerance", format!("{} is not in [0, 1]", r.shadows.tolerance)));
    }
    for (path, n) in [
        ("render.shadows.batch", r.shadows.batch),
        ("render.aa.samples", r.aa.samples),
        ("render.shadows.samples", r.shadows.samples),
        ("render.dof.samples", r.dof.samples),
    ] {
        if n == 0 {
            return Err(ctx.fail(path, "must be at least 1"));
        }
    }
    let dof_samples = if cam.aperture > 0.0 { r.dof.samples } else { 1 };
    let per_pixel = match aa_mode {
        AaMode::Uniform | AaMode::Variance { .. } | AaMode::Auto { .. } => r.aa.samples as u64,
        AaMode::Adaptive { max_level, .. } => 1u64 << max_level,
    };
    if per_pixel * dof_samples as u64 > u32::MAX as u64 {
        return Err(ctx.fail("render.dof.samples", "samples per pixel × render.dof.samples exceeds 2^32"));
    }
    // A dithered 2×2 block's four pixels index one sequence.
    if r.blue_noise && 4 * per_pixel * dof_samples as u64 > u32::MAX as u64 {
        let why = "4 × samples per pixel × render.dof.samples exceeds 2^32 (a 2×2 block's pixels share sequences)";
        return Err(ctx.fail("render.blue_noise", why));
    }
    let adaptive_aa = matches!(aa_mode, AaMode::Adaptive { .. });
    let dof_radius = (adaptive_aa && r.aa.dof_aware && cam.aperture > 0.0).then_some(r.aa.dof_radius);
    let penumbra_stop = (matches!(shadow_mode, ShadowMode::Adaptive(_) | ShadowMode::Auto(_))
        && r.shadows.tolerance > 0.0)
        .then_some(PenumbraStop { tolerance: r.shadows.tolerance, batch: r.shadows.batch });
    Ok(Settings {
        width: r.width,
        height: r.height,
        // Direct light is the path transport with one bounce.
        max_depth: if r.transport == TransportDesc::Direct { 1 } else { r.max_depth },
        seed: r.seed,
        aa_mode,
        aa_samples: r.aa.samples,
        shadow_mode,
        shadow_samples: r.shadows.samples,
        dof_samples,
        packets: r.packets,
        blue_noise: r.blue_noise,
        bvh: match r.bvh {
            // Settled by the ray budget once the primitives are known (`scene`).
            BvhDesc::Auto | BvhDesc::High => BvhQuality::High,
            BvhDesc::Low => BvhQuality::Low,
            BvhDesc::Medium => BvhQuality::Medium,
        },
        dof_radius,
        penumbra_stop,
        gloss_mis: r.gloss.mis,
        shutter: motion::shutter(cam, ctx)?,
        transport: match r.transport {
            TransportDesc::Whitted => Transport::Whitted,
            TransportDesc::Path => Transport::Path { rr_depth: r.path.rr_depth, hide_emitters: r.path.hide_emitters },
            // Mitsuba's `direct`: one bounce, never cut short.
            TransportDesc::Direct => Transport::Path { rr_depth: u32::MAX, hide_emitters: r.path.hide_emitters },
        },
    })
}

/// Roughly the rays a render with settings `s` and `lights` lights traces: every camera
/// sample, and at each hit one shadow ray per light sample (what `render.bvh = "auto"`
/// weighs the build against).
fn ray_budget(s: &Settings, lights: usize) -> f64 {
    let samples = s.width as f64 * s.height as f64 * s.aa_samples as f64 * s.dof_samples as f64;
    samples * (1.0 + lights as f64 * s.shadow_samples as f64)
}

/// Where the camera is and looks: (position, unit forward, up hint, default focus
/// distance, and with a transform the frame's image-right direction (-x), so that a
/// mirroring transform flips the image).
#[allow(clippy::type_complexity)] // one tuple, named where it is taken apart
fn camera_frame(c: &CameraDesc, ctx: &Ctx) -> Result<(Vec3, Vec3, Vec3, f32, Option<Vec3>)> {
    Ok(match (&c.transform, c.position, c.look_at) {
        (Some(ops), None, None) => {
            let t = transform(ctx, "camera.transform", ops)?;
            let (p, fwd, up, left) = t.frame();
            if !in_range(p) {
                return Err(ctx.fail("camera.transform", format!("puts the camera beyond ±{MAX_COORD:e} scene units")));
            }
            let f = fwd.normalize_or_zero();
            if f == Vec3::ZERO || !f.is_finite() {
                return Err(ctx.fail("camera.transform", "maps +z to no direction"));
            }
            (p, f, up, 1.0, Some(-left))
        }
        (Some(_), _, _) => {
            return Err(ctx.fail("camera.transform", "replaces position and look_at: give one or the other"))
        }
        (None, Some(p), Some(l)) => {
            let position = vec3(p);
            if !in_range(position) {
                return Err(ctx.fail("camera.position", format!("beyond ±{MAX_COORD:e} scene units")));
            }
            if !in_range(vec3(l)) {
                return Err(ctx.fail("camera.look_at", format!("beyond ±{MAX_COORD:e} scene units")));
            }
            let to = vec3(l) - position;
            if to.length_squared() == 0.0 {
                return Err(ctx.fail("camera.look_at", "equals camera.position: no view direction"));
            }
            (position, to.normalize(), vec3(c.up), to.length(), None)
        }
        (None, None, _) => return Err(ctx.fail("camera", "missing field `position` (or a `transform`)")),
        (None, Some(_), None) => return Err(ctx.fail("camera", "missing field `look_at`")),
    })
}

fn camera(c: &CameraDesc, width: u32, height: u32, ctx: &Ctx) -> Result<Camera> {
    let (position, forward, up_hint, default_focus, frame_right) = camera_frame(c, ctx)?;
    let right = forward.cross(up_hint);
    if up_hint.length_squared() == 0.0 || right.length() < 1e-6 * up_hint.length() {
        let field = if c.transform.is_some() { "camera.transform" } else { "camera.up" };
        return Err(ctx.fail(field, "up is zero or parallel to the view direction"));
    }
    let right = right.normalize();
    let up = right.cross(forward);
    let right = match frame_right {
        Some(r) if r.dot(right) < 0.0 => -right,
        _ => right,
    };
    if !(c.fov_y > 0.0 && c.fov_y < 180.0) {
        return Err(ctx.fail("camera.fov_y", format!("{} is not in (0, 180) degrees", c.fov_y)));
    }
    if c.aperture < 0.0 {
        return Err(ctx.fail("camera.aperture", "must be >= 0"));
    }
    let focus_distance = c.focus_distance.unwrap_or(default_focus);
    if focus_distance <= 0.0 {
        return Err(ctx.fail("camera.focus_distance", "must be > 0"));
    }
    // A lens ray aims from the lens at position + forward × focus_distance; a focus
    // distance that rounds away against the position (or underflows) leaves it no
    // direction (NaN), found by fuzzing (tests/fuzz/found/scene_values/).
    let min_focus = (position.abs().max_element() * 1e-5).max(1e-12);
    if c.aperture > 0.0 && focus_distance < min_focus {
        let field = if c.focus_distance.is_some() { "camera.focus_distance" } else { "camera.look_at" };
        return Err(ctx.fail(
            field,
            format!(
                "a focus distance of {focus_distance:e} is too small for a lens camera at {position}: at least {min_focus:e} \
                 (1e-5 of its largest coordinate, and 1e-12), or the focus point rounds onto the lens"
            ),
        ));
    }
    Ok(Camera {
        position,
        forward,
        right,
        up,
        tan_half_fov: (c.fov_y.to_radians() * 0.5).tan(),
        aspect: width as f32 / height as f32,
        aperture: c.aperture,
        focus_distance,
        motion: None,
    })
}

fn build(f: &SceneFile, ctx: &Ctx) -> Result<Scene> {
    let mut settings = settings(&f.render, &f.camera, ctx)?;
    let mut info = SceneInfo::default();
    let mut camera = camera(&f.camera, settings.width, settings.height, ctx)?;
    motion::camera(&f.camera, &mut camera, settings.shutter, ctx)?;
    let background = background(ctx, &f.background, &mut info)?;
    let mut names: BTreeMap<&str, u32> = BTreeMap::new();
    let (mut materials, mut textures) = (Vec::new(), materials::Textures::default());
    for (name, m) in &f.materials {
        names.insert(name.as_str(), materials.len() as u32);
        materials.push(materials::material(name, m, ctx, &mut textures)?);
    }
    info.inputs.append(&mut textures.files);
    // The rough coatings' tables (tens of milliseconds each) while the meshes are read,
    // where the threads asked for (rayon's pool: `--threads`) allow a second one.
    let beside = !textures.coatings.is_empty() && rayon::current_num_threads() > 1;
    let (built, tables) = std::thread::scope(|s| {
        let tables = beside.then(|| s.spawn(|| materials::coating_tables(&textures.coatings)));
        let built = objects::objects(f, ctx, &names, &materials, &mut info);
        (built, tables.map(|t| t.join().unwrap_or_else(|e| std::panic::resume_unwind(e))))
    });
    let built = built?;
    let tables = tables.unwrap_or_else(|| materials::coating_tables(&textures.coatings));
    materials::set_internal(&mut materials, &tables);
    // Only specular materials that some object uses give the scatter stage work.
    let has_specular = built
        .prims
        .iter()
        .any(|p| p.light == NO_LIGHT && !matches!(materials[p.material as usize], Material::Diffuse { .. }));
    info.primitives = built.prims.len();
    let lights = built.lights.clone();
    let rough = built.prims.iter().any(|p| p.light == NO_LIGHT && materials[p.material as usize].samples_lights());
    // The path transport weighs every surface's light samples against its BSDF's rays.
    let sampled = (settings.gloss_mis && rough) || settings.path();
    let (gloss_lights, sphere_lights) = match sampled {
        true => (
            (0..lights.len() as u32).filter(|&li| lights[li as usize].lit_area()).collect(),
            (0..lights.len() as u32).filter(|&li| lights[li as usize].lit_sphere()).collect(),
        ),
        false => (Vec::new(), Vec::new()),
    };
    let (light_pick, light_cdf) = match settings.path() {
        true => light_choice(&lights, &gloss_lights),
        false => (Vec::new(), Vec::new()),
    };
    let area_lights = AreaLights::new(&lights, &gloss_lights, &light_pick);
    let delta_lights = (0..lights.len() as u32)
        .filter(|&li| matches!(lights[li as usize], Light::Point { .. } | Light::Directional { .. }))
        .collect();
    if f.render.bvh == BvhDesc::Auto {
        settings.bvh = BvhQuality::for_budget(ray_budget(&settings, lights.len()), built.prims.len());
    }
    let (accel, objects::CornerTables { normals, uvs, frames }) =
        objects::build_accel(built, settings.bvh, settings.shutter);
    info.bvh_seconds = accel.build_seconds;
    Ok(Scene {
        settings,
        camera,
        background,
        materials,
        lights,
        accel,
        normals,
        textures: textures.list,
        uvs,
        uv_frames: frames,
        has_specular,
        area_lights,
        transmittance: tables.iter().map(|t| t.0).collect(),
        delta_lights,
        sphere_lights,
        light_pick,
        light_cdf,
        gloss_lights,
        info,
    })
}

/// `[background]`: a constant, or a lat-long map (scaled by `color` and `scale`) turned by
/// a rotation.
fn background(ctx: &Ctx, b: &BackgroundDesc, info: &mut SceneInfo) -> Result<Environment> {
    let Some(file) = &b.map else {
        for (field, given) in [("scale", b.scale.is_some()), ("transform", b.transform.is_some())] {
            if given {
                return Err(ctx.fail(&format!("background.{field}"), "applies to a `map`: give one, or leave it out"));
            }
        }
        return Ok(Environment::constant(color(ctx, "background.color", b.color.unwrap_or([0.0; 3]))?));
    };
    let scale = b.scale.unwrap_or(1.0);
    if !(scale >= 0.0 && scale.is_finite()) {
        return Err(ctx.fail("background.scale", format!("{scale} must be a number >= 0")));
    }
    let tint = color(ctx, "background.color", b.color.unwrap_or([1.0; 3]))?;
    let path = ctx.src.dir.join(file);
    let bitmap = Bitmap::load(&path, false, Wrap::Repeat, Filter::Bilinear)
        .map_err(|e| ctx.fail("background.map", format!("{}: {e}", path.display())))?;
    info.inputs.push(("the environment map `background.map`".to_string(), path));
    let map = LatLong::new(bitmap.width as usize, bitmap.height as usize, bitmap.texels)
        .ok_or_else(|| ctx.fail("background.map", "the image is empty"))?;
    let to_world = match &b.transform {
        None => Mat3::IDENTITY,
        Some(ops) => {
            let t = transform(ctx, "background.transform", ops)?;
            let m = Mat3::from_mat4(t.m.as_mat4());
            let rotation = (m.transpose() * m - Mat3::IDENTITY).to_cols_array().iter().all(|e| e.abs() < 1e-4)
                && (m.determinant() - 1.0).abs() < 1e-4;
            if !rotation {
                return Err(ctx.fail("background.transform", "must be a rotation (no scale, mirror or shear)"));
            }
            m
        }
    };
    Ok(Environment { radiance: tint * scale, map: Some(map), to_local: to_world.transpose(), to_world })
}

/// The path transport's choice among `gloss` (indices into `lights`) by power: each
/// light's probability (indexed like `lights`) and their running sums over `gloss` (the
/// last exactly 1). Uniform when no light has power.
fn light_choice(lights: &[Light], gloss: &[u32]) -> (Vec<f32>, Vec<f32>) {
    let power = |li: u32| lights[li as usize].power() as f64;
    let total: f64 = gloss.iter().map(|&li| power(li)).sum();
    let share = |li: u32| if total > 0.0 { power(li) / total } else { 1.0 / gloss.len() as f64 };
    let mut pick = vec![0.0f32; lights.len()];
    let (mut cdf, mut sum) = (Vec::with_capacity(gloss.len()), 0.0f64);
    for &li in gloss {
        pick[li as usize] = share(li) as f32;
        sum += share(li);
        cdf.push(sum as f32);
    }
    if let Some(last) = cdf.last_mut() {
        *last = 1.0;
    }
    (pick, cdf)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::ReflectRatio;

    const SCENE: &str = "[render]\nwidth = 4\nheight = 4\n[render.aa]\nsamples = 1\n[render.shadows]\nsamples = 1\n\n[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n";

    fn error(text: &str, sets: &[&str]) -> String {
        let src = SceneSource::from_text("s.toml", text, Path::new("."));
        let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
        match load(&src, &sets) {
            Err(Error::Input(msg)) => msg,
            Err(e) => panic!("not an input error: {e}"),
            Ok(_) => panic!("loaded"),
        }
    }

    #[test]
    fn modes_and_probes_parse() {
        let src = |t: String| SceneSource::from_text("s.toml", &t, Path::new("."));
        for (probe, want) in [
            ("corners", Probe::Corners),
            ("corners+center", Probe::CornersCenter),
            ("jittered", Probe::Jittered),
            ("3x3", Probe::Grid3),
        ] {
            let text = SCENE.replace(
                "[render.shadows]\n",
                &format!("[render.shadows]\nmode = \"adaptive\"\nprobe = \"{probe}\"\n"),
            );
            assert_eq!(load(&src(text), &[]).unwrap().settings.shadow_mode, ShadowMode::Adaptive(want));
        }
        let text = SCENE.replace("[render.aa]\n", "[render.aa]\nmode = \"adaptive\"\n");
        assert!(matches!(load(&src(text), &[]).unwrap().settings.aa_mode, AaMode::Adaptive { .. }));
        let s = load(&src(SCENE.into()), &[]).unwrap().settings;
        assert_eq!((s.aa_mode, s.shadow_mode), (AaMode::Uniform, ShadowMode::Uniform));
    }

    #[test]
    fn a_bad_choice_names_the_file_position_field_and_value() {
        let text = SCENE.replace("[render.aa]\n", "[render.aa]\nmode = \"fancy\"\n");
        let msg = error(&text, &[]);
        assert!(msg.starts_with("s.toml:5:8: field `render.aa.mode`: unknown variant `fancy`"), "{msg}");
        let text = SCENE.replace("[render.shadows]\n", "[render.shadows]\nprobe = \"4x4\"\n");
        let msg = error(&text, &[]);
        assert!(msg.starts_with("s.toml:7:9: field `render.shadows.probe`: unknown variant `4x4`"), "{msg}");
        // Inline tables and arrays are walked too.
        let text =
            SCENE.replace("[render.aa]\nsamples = 1\n", "").replace("height = 4\n", "height = 4\naa = { mode = 3 }\n");
        let msg = error(&text, &[]);
        assert!(msg.starts_with("s.toml:4:15: field `render.aa.mode`: "), "{msg}");
        let text = SCENE.replace("position = [0, 0, 5]", "position = [0, \"x\", 5]");
        assert!(error(&text, &[]).contains("field `camera.position.1`"));
        // Through --set, the override and its key are named.
        let msg = error(SCENE, &["render.shadows.mode=fancy"]);
        assert!(
            msg.contains("(--set render.shadows.mode=fancy): field `render.shadows.mode`: unknown variant `fancy`"),
            "{msg}"
        );
    }

    #[test]
    fn reflect_ratio_is_a_number_or_fresnel() {
        let glass =
            |ratio: &str| format!("{SCENE}[materials.g]\ntype = \"dielectric\"\nior = 1.5\nreflect_ratio = {ratio}\n");
        let src = |t: String| SceneSource::from_text("s.toml", &t, Path::new("."));
        let ratio = |r: &str| match load(&src(glass(r)), &[]).unwrap().materials[0] {
            Material::Dielectric { ratio, .. } => ratio,
            _ => unreachable!(),
        };
        assert_eq!(ratio("\"fresnel\""), ReflectRatio::Fresnel);
        assert_eq!(ratio("0.25"), ReflectRatio::Fixed(0.25));
        assert_eq!(ratio("1"), ReflectRatio::Fixed(1.0));
        let msg = error(&glass("\"gold\""), &[]);
        assert!(
            msg.contains("field `materials.g.reflect_ratio`: \"gold\" is neither a number in [0, 1] nor \"fresnel\""),
            "{msg}"
        );
        assert!(error(&glass("2"), &[]).contains("field `materials.g.reflect_ratio`: 2 is not in [0, 1]"));
    }
}
