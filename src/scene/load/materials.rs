//! The `[materials.NAME]` tables validated into [`Material`]s, with their textures
//! loaded (each distinct texture once) and their roughness checked.

use glam::{Affine2, Vec2, Vec3};
use std::path::{Path, PathBuf};

use crate::bsdf::microfacet::MIN_ALPHA;
use crate::bsdf::microfacet::{named_conductor, Distribution, Microfacet, CONDUCTORS};
use crate::bsdf::plastic::{self, Transmittance};
use crate::scene::format::*;
use crate::scene::values::{color, transform, Ctx};
use crate::scene::{Color, Material, ReflectRatio};
use crate::texture::{Bitmap, Filter, Texture, Wrap};
use crate::Result;

/// Largest roughness accepted: far beyond any measured surface (alpha ≈ 1 is already
/// close to diffuse), and small enough that the distributions stay finite.
pub const MAX_ALPHA: f32 = 1e3;

/// The textures and tables of a scene's materials, each distinct one loaded once.
#[derive(Default)]
pub(super) struct Textures {
    /// Loaded textures, indexed by [`Color::Texture`].
    pub(super) list: Vec<Texture>,
    descs: Vec<TextureDesc>,
    /// The image files read, each with the field that names it.
    pub(super) files: Vec<(String, PathBuf)>,
    /// Rough plastics' coatings (roughness, index), indexed by their `table`. Their
    /// tables are computed by [`coating_tables`] while the objects load.
    pub(super) coatings: Vec<(Microfacet, f32)>,
}

/// Each rough coating's transmittance table and internal reflectance, in `coatings` order.
pub(super) fn coating_tables(coatings: &[(Microfacet, f32)]) -> Vec<(Transmittance, f32)> {
    coatings
        .iter()
        .map(|(mf, eta)| (plastic::rough_transmittance(mf, *eta), plastic::rough_internal(mf, *eta)))
        .collect()
}

/// Gives each rough plastic the internal reflectance of its coating's table.
pub(super) fn set_internal(materials: &mut [Material], tables: &[(Transmittance, f32)]) {
    for m in materials {
        if let Material::Plastic { roughness: Some(_), internal, table, .. } = m {
            *internal = tables[*table as usize].1;
        }
    }
}

/// Material `name` validated; its textures are added to `textures`.
pub(super) fn material(name: &str, m: &MaterialDesc, ctx: &Ctx, textures: &mut Textures) -> Result<Material> {
    let p = |f: &str| format!("materials.{name}.{f}");
    Ok(match m {
        MaterialDesc::Diffuse { color: c, specular, shininess, two_sided } => {
            if *shininess < 0.0 {
                return Err(ctx.fail(&p("shininess"), "must be >= 0"));
            }
            Material::Diffuse {
                color: color_or_texture(ctx, &p("color"), c, textures)?,
                specular: color(ctx, &p("specular"), *specular)?,
                shininess: *shininess,
                two_sided: *two_sided,
            }
        }
        MaterialDesc::Mirror { color: c } => Material::Mirror { color: color(ctx, &p("color"), *c)? },
        MaterialDesc::Dielectric { ior, reflect_ratio, color: c, thin, distribution, alpha, alpha_u, alpha_v } => {
            if *ior <= 0.0 {
                return Err(ctx.fail(&p("ior"), format!("{ior} must be > 0")));
            }
            let roughness = roughness(ctx, name, distribution, (*alpha, *alpha_u, *alpha_v))?;
            let ratio = reflect_ratio_of(ctx, &p("reflect_ratio"), reflect_ratio)?;
            if roughness.is_some() && ratio != ReflectRatio::Fresnel {
                return Err(
                    ctx.fail(&p("reflect_ratio"), "rough glass splits by Fresnel at each microfacet: leave it out")
                );
            }
            if roughness.is_some() && *thin {
                return Err(ctx.fail(&p("thin"), "a thin sheet is smooth: leave out the roughness"));
            }
            Material::Dielectric { ior: *ior, ratio, tint: color(ctx, &p("color"), *c)?, roughness, thin: *thin }
        }
        MaterialDesc::Conductor { material, eta, k, color: c, distribution, alpha, alpha_u, alpha_v } => {
            let roughness = roughness(ctx, name, distribution, (*alpha, *alpha_u, *alpha_v))?;
            let color = color_or_texture(ctx, &p("color"), c, textures)?;
            match (conductor_ior(ctx, name, material, *eta, *k)?, color, roughness) {
                // Mitsuba's "none", smooth and untextured: exactly the mirror.
                (None, Color::Rgb(color), None) => Material::Mirror { color },
                (None, color, roughness) => Material::Conductor { eta: Vec3::ZERO, k: Vec3::ZERO, color, roughness },
                (Some((eta, k)), color, roughness) => Material::Conductor { eta, k, color, roughness },
            }
        }
        MaterialDesc::Plastic { color: c, specular, ior, nonlinear, two_sided, distribution, alpha } => {
            plastic(ctx, name, (c, *specular, *ior, *nonlinear, *two_sided), (distribution, *alpha), textures)?
        }
    })
}

/// A plastic: its colours, and the coating's internal reflectance and sampling weight
/// (rough: its coating, whose table and internal reflectance come later, once per
/// coating).
fn plastic(
    ctx: &Ctx,
    name: &str,
    (c, specular, ior, nonlinear, two_sided): (&ColorDesc, [f32; 3], f32, bool, bool),
    (distribution, alpha): (&Option<String>, Option<f32>),
    textures: &mut Textures,
) -> Result<Material> {
    let p = |f: &str| format!("materials.{name}.{f}");
    if !(ior > 0.0 && ior.is_finite()) {
        return Err(ctx.fail(&p("ior"), format!("{ior} must be > 0")));
    }
    let roughness = roughness(ctx, name, distribution, (alpha, None, None))?;
    if roughness.is_some() && ior == 1.0 {
        return Err(ctx.fail(&p("ior"), "a rough coating needs an index other than 1 (as Mitsuba)"));
    }
    let base = color_or_texture(ctx, &p("color"), c, textures)?;
    let specular = color(ctx, &p("specular"), specular)?;
    let diffuse_mean = match base {
        Color::Rgb(c) => c.element_sum() / 3.0,
        Color::Texture(t) => textures.list[t as usize].mean(),
    };
    let specular_weight = plastic::specular_weight(specular.element_sum() / 3.0, diffuse_mean);
    let (internal, table) = match &roughness {
        None => (plastic::smooth_internal(ior), 0),
        Some(mf) => {
            let known = textures.coatings.iter().position(|(m, eta)| m == mf && *eta == ior);
            let i = known.unwrap_or_else(|| {
                textures.coatings.push((*mf, ior));
                textures.coatings.len() - 1
            });
            // Set with the table ([`set_internal`]).
            (f32::NAN, i as u32)
        }
    };
    Ok(Material::Plastic {
        color: base,
        specular,
        eta: ior,
        roughness,
        nonlinear,
        two_sided,
        internal,
        specular_weight,
        table,
    })
}

/// `reflect_ratio`: C in [0, 1] or "fresnel" (the default).
fn reflect_ratio_of(ctx: &Ctx, path: &str, r: &Option<RatioDesc>) -> Result<ReflectRatio> {
    match r {
        None => Ok(ReflectRatio::Fresnel),
        Some(RatioDesc::Name(s)) if s == "fresnel" => Ok(ReflectRatio::Fresnel),
        Some(RatioDesc::Name(s)) => {
            Err(ctx.fail(path, format!("\"{s}\" is neither a number in [0, 1] nor \"fresnel\"")))
        }
        Some(RatioDesc::Value(c)) if (0.0..=1.0).contains(c) => Ok(ReflectRatio::Fixed(*c)),
        Some(RatioDesc::Value(c)) => Err(ctx.fail(path, format!("{c} is not in [0, 1]"))),
    }
}

/// The microfacet distribution of material `name`: `None` (smooth) when no alpha is
/// given; `alpha`, or both `alpha_u` and `alpha_v`, otherwise.
fn roughness(
    ctx: &Ctx,
    name: &str,
    distribution: &Option<String>,
    (alpha, alpha_u, alpha_v): (Option<f32>, Option<f32>, Option<f32>),
) -> Result<Option<Microfacet>> {
    let p = |f: &str| format!("materials.{name}.{f}");
    let check = |field: &str, a: f32| {
        if (0.0..=MAX_ALPHA).contains(&a) {
            Ok(a.max(MIN_ALPHA))
        } else {
            Err(ctx.fail(&p(field), format!("{a} is not in [0, {MAX_ALPHA}]")))
        }
    };
    let (alpha_u, alpha_v) = match (alpha, alpha_u, alpha_v) {
        (None, None, None) => {
            if distribution.is_some() {
                return Err(ctx.fail(&p("distribution"), "needs a roughness: `alpha`, or `alpha_u` and `alpha_v`"));
            }
            return Ok(None);
        }
        (Some(a), None, None) => (check("alpha", a)?, check("alpha", a)?),
        (None, Some(u), Some(v)) => (check("alpha_u", u)?, check("alpha_v", v)?),
        (Some(_), _, _) => return Err(ctx.fail(&p("alpha"), "give `alpha`, or `alpha_u` and `alpha_v`, not both")),
        (None, Some(_), None) => return Err(ctx.fail(&p("alpha_u"), "needs `alpha_v` too")),
        (None, None, Some(_)) => return Err(ctx.fail(&p("alpha_v"), "needs `alpha_u` too")),
    };
    let distribution = match distribution.as_deref() {
        None | Some("beckmann") => Distribution::Beckmann,
        Some("ggx") => Distribution::Ggx,
        Some(other) => {
            return Err(ctx.fail(&p("distribution"), format!("\"{other}\" is neither \"ggx\" nor \"beckmann\"")))
        }
    };
    Ok(Some(Microfacet { distribution, alpha_u, alpha_v }))
}

/// A conductor's complex index of refraction: `Some((eta, k))`, or `None` for Mitsuba's
/// "none" (a perfect reflector, the default without `eta` and `k`).
fn conductor_ior(
    ctx: &Ctx,
    name: &str,
    material: &Option<String>,
    eta: Option<[f32; 3]>,
    k: Option<[f32; 3]>,
) -> Result<Option<(Vec3, Vec3)>> {
    let p = |f: &str| format!("materials.{name}.{f}");
    match (material, eta, k) {
        (Some(_), Some(_), _) | (Some(_), _, Some(_)) => {
            Err(ctx.fail(&p("material"), "give `material`, or `eta` and `k`, not both"))
        }
        (None, Some(eta), Some(k)) => Ok(Some((color(ctx, &p("eta"), eta)?, color(ctx, &p("k"), k)?))),
        (None, Some(_), None) => Err(ctx.fail(&p("eta"), "needs `k` too")),
        (None, None, Some(_)) => Err(ctx.fail(&p("k"), "needs `eta` too")),
        (None, None, None) => Ok(None),
        (Some(m), None, None) if m == "none" => Ok(None),
        (Some(m), None, None) => named_conductor(m).map(Some).ok_or_else(|| {
            ctx.fail(&p("material"), format!("unknown conductor \"{m}\"; known: none, {}", CONDUCTORS.join(", ")))
        }),
    }
}

/// A colour field: an RGB triple, or a texture (loaded, or found among those loaded).
fn color_or_texture(ctx: &Ctx, path: &str, c: &ColorDesc, textures: &mut Textures) -> Result<Color> {
    let desc = match c {
        ColorDesc::Rgb(c) => return Ok(Color::Rgb(color(ctx, path, *c)?)),
        ColorDesc::Texture(t) => t,
    };
    if let Some(i) = textures.descs.iter().position(|d| d == desc) {
        return Ok(Color::Texture(i as u32));
    }
    let texture = texture(ctx, path, desc)?;
    if let TextureDesc::Bitmap { file, .. } = desc {
        textures.files.push((format!("the texture of `{path}`"), ctx.src.dir.join(file)));
    }
    textures.list.push(texture);
    textures.descs.push(desc.clone());
    Ok(Color::Texture(textures.list.len() as u32 - 1))
}

/// A texture description validated and, for a bitmap, its file read.
fn texture(ctx: &Ctx, path: &str, t: &TextureDesc) -> Result<Texture> {
    match t {
        TextureDesc::Bitmap { file, raw, wrap, filter, to_uv: ops } => {
            let wrap = match wrap.as_deref() {
                None | Some("repeat") => Wrap::Repeat,
                Some("mirror") => Wrap::Mirror,
                Some("clamp") => Wrap::Clamp,
                Some(w) => {
                    let msg = format!("\"{w}\" is not one of \"repeat\", \"mirror\", \"clamp\"");
                    return Err(ctx.fail(&format!("{path}.wrap"), msg));
                }
            };
            let filter = match filter.as_deref() {
                None | Some("bilinear") => Filter::Bilinear,
                Some("nearest") => Filter::Nearest,
                Some(f) => {
                    let msg = format!("\"{f}\" is neither \"bilinear\" nor \"nearest\"");
                    return Err(ctx.fail(&format!("{path}.filter"), msg));
                }
            };
            let file_path = ctx.src.dir.join(file);
            let bitmap = Bitmap::load(&file_path, *raw, wrap, filter)
                .map_err(|e| ctx.fail(&format!("{path}.file"), format!("{}: {e}", shown(&file_path))))?;
            Ok(Texture::Bitmap { bitmap, to_uv: to_uv(ctx, path, ops)? })
        }
        TextureDesc::Checkerboard { color0, color1, to_uv: ops } => Ok(Texture::Checkerboard {
            color0: color(ctx, &format!("{path}.color0"), *color0)?,
            color1: color(ctx, &format!("{path}.color1"), *color1)?,
            to_uv: to_uv(ctx, path, ops)?,
        }),
    }
}

/// A path as messages show it.
fn shown(path: &Path) -> String {
    path.display().to_string()
}

/// `to_uv`: the transform list acting on (u, v, 0), kept as its action on the plane.
fn to_uv(ctx: &Ctx, path: &str, ops: &Option<Vec<TransformOp>>) -> Result<Affine2> {
    let Some(ops) = ops else { return Ok(Affine2::IDENTITY) };
    let field = format!("{path}.to_uv");
    let t = transform(ctx, &field, ops)?;
    let at = |p: Vec3| t.point(p);
    let (o, x, y) = (at(Vec3::ZERO), at(Vec3::X), at(Vec3::Y));
    let affine = Affine2::from_cols(Vec2::new(x.x - o.x, x.y - o.y), Vec2::new(y.x - o.x, y.y - o.y), o.truncate());
    if !affine.is_finite() {
        return Err(ctx.fail(&field, "the transform is not finite on the UV plane"));
    }
    Ok(affine)
}
