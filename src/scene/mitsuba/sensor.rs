//! The sensor (camera, film, sampler) and the integrator: image size, samples, field of
//! view, the camera frame and the bounce limit.

use super::xml::{El, Value};
use super::{compose, unsupported, Converter, Params, SENSORS};
use crate::scene::format::{PathDesc, TransportDesc};
use crate::scene::values::MAX_DEPTH;
use crate::Result;

/// The parameters of `<film type="hdrfilm">` read or accepted.
const FILM_PARAMS: [&str; 7] =
    ["width", "height", "pixel_format", "component_format", "file_format", "banner", "sample_border"];

impl Converter<'_> {
    /// Converts the first `<sensor>`; a second one is ignored with a note.
    pub(super) fn sensor(&mut self, el: &El) -> Result<()> {
        if self.sensor {
            self.note(format!("{}:{}: a second <sensor> is ignored (the first one renders)", el.loc.file, el.loc.line));
            return Ok(());
        }
        self.sensor = true;
        let ty = el.need("type")?;
        let thin = match ty {
            "perspective" => false,
            "thinlens" => true,
            _ => return Err(unsupported(el, "sensor", SENSORS)),
        };
        // A perspective sensor has no lens: Mitsuba ignores a focus_distance on it (its own
        // Cornell box sets one), and so does this.
        let mut allowed =
            vec!["fov", "fov_axis", "focal_length", "to_world", "near_clip", "far_clip", "focus_distance"];
        if thin {
            allowed.push("aperture_radius");
        }
        let p = Params::of(el, &allowed, &["film", "sampler"])?;
        let (mut width, mut height) = (768u32, 576u32);
        let mut spp = 4u32;
        for k in &el.kids {
            match k.tag.as_str() {
                "film" => (width, height) = self.film(k, (width, height))?,
                "sampler" => spp = self.sampler(k, spp)?,
                _ => {}
            }
        }
        let aspect = width as f64 / height as f64;
        let fov_y = x_to_fov_y(sensor_fov_x(el, &p, aspect)?, aspect);
        let ops = p.transform("to_world")?;
        let t = compose(el, &ops)?;
        let l = glam::DMat3::from_mat4(t.m);
        let scaled = (0..3).any(|i| (l.col(i).length() - 1.0).abs() > 1e-4);
        if scaled {
            return Err(el.loc.err(format!(
                "{}: the camera's to_world scales (Mitsuba refuses scale factors in a camera transform too)",
                el.what()
            )));
        }
        let cam = &mut self.out.file.camera;
        cam.transform = Some(ops);
        cam.fov_y = fov_y as f32;
        if thin {
            cam.aperture = p.num("aperture_radius")?.unwrap_or(0.0) as f32;
            cam.focus_distance = Some(p.num("focus_distance")?.unwrap_or(0.0) as f32);
            if cam.focus_distance == Some(0.0) {
                return Err(el.loc.err(format!("{}: give a focus_distance > 0", el.what())));
            }
        }
        let r = &mut self.out.file.render;
        (r.width, r.height, r.aa.samples) = (width, height, spp);
        self.place("camera".into(), el);
        Ok(())
    }

    /// The image size of a `<film>`, `size` where it gives none.
    fn film(&mut self, k: &El, size: (u32, u32)) -> Result<(u32, u32)> {
        if k.attr("type") != Some("hdrfilm") {
            return Err(unsupported(k, "film", "hdrfilm"));
        }
        let f = Params::of(k, &FILM_PARAMS, &["rfilter"])?;
        let dim = |name: &str, d: u32| -> Result<u32> {
            match f.num(name)? {
                None => Ok(d),
                Some(x) if x >= 1.0 && x.fract() == 0.0 && x <= u32::MAX as f64 => Ok(x as u32),
                Some(x) => Err(k.loc.err(format!("<film>: `{name}` = {x} is not a positive integer"))),
            }
        };
        let size = (dim("width", size.0)?, dim("height", size.1)?);
        if k.kids.iter().any(|r| r.tag == "rfilter" && r.attr("type") != Some("box")) {
            self.note(
                "the film's reconstruction filter is replaced by a box filter (a sample counts only in its own pixel)"
                    .into(),
            );
        }
        self.place("render".into(), k);
        Ok(size)
    }

    /// The samples per pixel of a `<sampler>` (any type), `spp` where it gives none.
    fn sampler(&mut self, k: &El, spp: u32) -> Result<u32> {
        let s = Params::of(k, &["sample_count", "seed", "jitter", "scramble", "dimension"], &[])?;
        let mut spp = spp;
        if let Some(n) = s.num("sample_count")? {
            if !(n >= 1.0 && n.fract() == 0.0 && n <= u32::MAX as f64) {
                return Err(k.loc.err(format!("<sampler>: sample_count {n} is not a positive integer")));
            }
            spp = n as u32;
        }
        self.place("render.aa".into(), k);
        Ok(spp)
    }

    /// Reads the integrator: Mitsuba's `path` (`max_depth`, `rr_depth`, `hide_emitters`)
    /// becomes the path transport, `direct` the path transport with one bounce, and
    /// both sample one light point per surface hit, as Mitsuba does (unless
    /// `render.shadows.samples` says otherwise); the peer harness's `whitted` is the
    /// paper's transport; any other type is refused.
    pub(super) fn integrator(&mut self, el: &El) -> Result<()> {
        let ty = el.attr("type").unwrap_or("?");
        let render = &mut self.out.file.render;
        match ty {
            "path" => {
                let p = Params::of(el, &["max_depth", "rr_depth", "hide_emitters"], &[])?;
                render.transport = TransportDesc::Path;
                render.max_depth = match p.num("max_depth")? {
                    None | Some(-1.0) => MAX_DEPTH,
                    Some(d) if d >= 1.0 && d.fract() == 0.0 => {
                        // Mitsuba counts the camera ray as a segment.
                        (d as u32 - 1).min(MAX_DEPTH)
                    }
                    Some(d) => {
                        return Err(el.loc.err(format!("<integrator>: max_depth {d} is not -1 or a positive integer")))
                    }
                };
                render.path.rr_depth = match p.num("rr_depth")? {
                    None => 5,
                    Some(d) if d >= 1.0 && d.fract() == 0.0 && d <= u32::MAX as f64 => d as u32,
                    Some(d) => return Err(el.loc.err(format!("<integrator>: rr_depth {d} is not a positive integer"))),
                };
                render.path.hide_emitters = p.boolean("hide_emitters")?.unwrap_or(false);
            }
            // The peer harness's Whitted integrator (../shared/peers/mitsuba/common.py),
            // which Mitsuba reads once the harness registers it: the paper's transport.
            "whitted" => {
                let p = Params::of(el, &["max_depth"], &[])?;
                render.transport = TransportDesc::Whitted;
                render.max_depth = match p.num("max_depth")? {
                    None => 5,
                    Some(d) if d >= 1.0 && d.fract() == 0.0 => (d as u32 - 1).min(MAX_DEPTH),
                    Some(d) => {
                        return Err(el.loc.err(format!("<integrator>: max_depth {d} is not a positive integer")))
                    }
                };
                self.place("render.max_depth".into(), el);
                return Ok(());
            }
            "direct" => {
                let p = Params::of(el, &["emitter_samples", "bsdf_samples", "shading_samples", "hide_emitters"], &[])?;
                for k in ["emitter_samples", "bsdf_samples", "shading_samples"] {
                    if p.num(k)?.is_some_and(|n| n != 1.0) {
                        return Err(el.loc.err(format!(
                            "<integrator type=\"direct\">: `{k}` other than 1 is not supported; use \
                             render.shadows.samples and render.aa.samples"
                        )));
                    }
                }
                render.transport = TransportDesc::Direct;
                render.path.hide_emitters = p.boolean("hide_emitters")?.unwrap_or(false);
            }
            other => {
                return Err(el.loc.err(format!(
                    "<integrator type=\"{other}\">: not supported; wavetrace imports integrator types path, \
                     direct and whitted (docs/import.md)"
                )))
            }
        }
        // One light sample per hit, as Mitsuba takes.
        render.shadows.samples = 1;
        self.place("render.max_depth".into(), el);
        self.place("render.transport".into(), el);
        Ok(())
    }

    /// A scene without an `<integrator>` is rendered by Mitsuba's default, `path` with
    /// unbounded depth: so it is here.
    pub(super) fn default_integrator(&mut self) {
        let render = &mut self.out.file.render;
        render.transport = TransportDesc::Path;
        render.max_depth = MAX_DEPTH;
        render.path = PathDesc::default();
        render.shadows.samples = 1;
    }
}

/// The horizontal field of view (degrees) of a sensor: from `fov` and `fov_axis`, or from
/// `focal_length` (default 50 mm).
fn sensor_fov_x(el: &El, p: &Params, aspect: f64) -> Result<f64> {
    Ok(match (p.num("fov")?, p.get("focal_length")?) {
        (Some(_), Some((_, k))) => return Err(k.loc.err("<sensor>: give `fov` or `focal_length`, not both")),
        (Some(fov), None) => {
            let axis = p.string("fov_axis")?.map_or("x".to_string(), |(s, _)| s);
            fov_to_x(fov, &axis, aspect).map_err(|e| el.loc.err(format!("{}: {e}", el.what())))?
        }
        (None, f) => {
            let mm = match f {
                None => 50.0,
                Some((Value::Num(x), _)) => x,
                Some((Value::Str(s), k)) => s
                    .trim()
                    .trim_end_matches("mm")
                    .parse::<f64>()
                    .map_err(|_| k.loc.err(format!("<sensor>: focal_length `{s}` is not <number>mm")))?,
                Some((_, k)) => return Err(k.loc.err("<sensor>: focal_length must be a string such as \"50mm\"")),
            };
            if mm.is_nan() || mm <= 0.0 {
                return Err(el.loc.err(format!("{}: focal_length {mm} must be > 0", el.what())));
            }
            fov_to_x(focal_length_to_fov(mm), "diagonal", aspect).map_err(|e| el.loc.err(e))?
        }
    })
}

/// The diagonal field of view (degrees) of a lens of focal length `mm` on Mitsuba's
/// 36 × 24 mm film.
pub fn focal_length_to_fov(mm: f64) -> f64 {
    2.0 * ((36.0f64 * 36.0 + 24.0 * 24.0).sqrt() / (2.0 * mm)).atan().to_degrees()
}

/// Mitsuba's `parse_fov`: the horizontal field of view (degrees) of `fov` measured along
/// `axis` (x, y, diagonal, smaller, larger) for an image of aspect `w / h`.
pub fn fov_to_x(fov: f64, axis: &str, aspect: f64) -> std::result::Result<f64, String> {
    let axis = match axis {
        "smaller" => {
            if aspect > 1.0 {
                "y"
            } else {
                "x"
            }
        }
        "larger" => {
            if aspect > 1.0 {
                "x"
            } else {
                "y"
            }
        }
        a => a,
    };
    let half = |a: f64| (0.5 * a).to_radians().tan();
    let x = match axis {
        "x" => fov,
        "y" => (2.0 * (half(fov) * aspect).atan()).to_degrees(),
        "diagonal" => {
            let width = 2.0 * half(fov) / (1.0 + 1.0 / (aspect * aspect)).sqrt();
            (2.0 * (0.5 * width).atan()).to_degrees()
        }
        other => return Err(format!("fov_axis `{other}` is not x, y, diagonal, smaller or larger")),
    };
    if !(x > 0.0 && x < 180.0) {
        return Err(format!("the horizontal field of view {x}° is not in (0, 180)"));
    }
    Ok(x)
}

/// The vertical field of view (degrees) of a horizontal one for aspect `w / h`.
pub fn x_to_fov_y(fov_x: f64, aspect: f64) -> f64 {
    (2.0 * ((0.5 * fov_x).to_radians().tan() / aspect).atan()).to_degrees()
}
