//! BSDFs as materials: diffuse, twosided, smooth and rough conductors and dielectrics,
//! with a texture in a colour's place where wavetrace has one.

use super::xml::{El, Value};
use super::{unsupported, Converter, Params, BSDFS, TEXTURES};
use crate::scene::format::*;
use crate::Result;

/// Mitsuba's named indices of refraction (its `ior.h` table).
const IORS: [(&str, f32); 23] = [
    ("vacuum", 1.0),
    ("helium", 1.00004),
    ("hydrogen", 1.00013),
    ("air", 1.00028),
    ("carbon dioxide", 1.00045),
    ("water", 1.333),
    ("acetone", 1.36),
    ("ethanol", 1.361),
    ("carbon tetrachloride", 1.461),
    ("glycerol", 1.4729),
    ("benzene", 1.501),
    ("silicone oil", 1.52045),
    ("bromine", 1.661),
    ("water ice", 1.31),
    ("fused quartz", 1.458),
    ("pyrex", 1.47),
    ("acrylic glass", 1.49),
    ("polypropylene", 1.49),
    ("bk7", 1.5046),
    ("sodium chloride", 1.544),
    ("amber", 1.55),
    ("pet", 1.575),
    ("diamond", 2.419),
];

/// The parameters of Mitsuba's microfacet BSDFs (`roughconductor`, `roughdielectric`).
const ROUGH_PARAMS: [&str; 5] = ["distribution", "alpha", "alpha_u", "alpha_v", "sample_visible"];

/// Mitsuba's microfacet distributions (it reads the name case-insensitively).
const DISTRIBUTIONS: [&str; 2] = ["beckmann", "ggx"];

/// Deepest chain of twosided BSDFs: they may nest and reference each other, so a
/// reference loop must end somewhere.
const MAX_TWOSIDED: usize = 16;

/// The microfacet fields of a material; all `None` for a smooth one.
#[derive(Default)]
struct Rough {
    distribution: Option<String>,
    alpha: Option<f32>,
    alpha_u: Option<f32>,
    alpha_v: Option<f32>,
}

impl<'a> Converter<'a> {
    /// Converts a BSDF element to a material, once per id, returning its name (the id, or
    /// the element's place for an anonymous one).
    pub(super) fn bsdf(&mut self, el: &El) -> Result<String> {
        let id = el.attr("id");
        if let Some(name) = id.and_then(|id| self.named.get(id)) {
            return Ok(name.clone());
        }
        // An anonymous one is named by its line and column, without the file (whose name
        // has dots, and which messages print before the field already), and numbered on
        // from there should another file have one at the same place.
        let name = match id {
            Some(id) => id.to_string(),
            None => {
                let at = format!("bsdf@{}:{}", el.loc.line, el.loc.col);
                let taken = |n: &String| self.out.file.materials.contains_key(n);
                std::iter::once(at.clone()).chain((2..).map(|k| format!("{at}~{k}"))).find(|n| !taken(n)).unwrap_or(at)
            }
        };
        // Named before converting: a BSDF that fails still answers its references, so they
        // add no second, misleading error.
        if let Some(id) = id {
            self.named.insert(id.to_string(), name.clone());
        }
        let (desc, _) = self.material(el)?;
        self.out.file.materials.insert(name.clone(), desc);
        self.place(format!("materials.{name}"), el);
        Ok(name)
    }

    /// The material of a BSDF element, and whether it is wrapped in a twosided.
    fn material(&mut self, el: &El) -> Result<(MaterialDesc, bool)> {
        match el.attr("type").unwrap_or("") {
            "diffuse" => {
                let p = Params::of(el, &["reflectance"], &["texture", "ref"])?;
                textured_only(el, &["reflectance"])?;
                let color = self.color_param(&p, "reflectance", [0.5; 3])?;
                // One-sided, as Mitsuba's: `twosided` turns the back on.
                Ok((MaterialDesc::Diffuse { color, specular: [0.0; 3], shininess: 0.0, two_sided: false }, false))
            }
            "twosided" => self.twosided(el),
            "conductor" => Ok((self.conductor(el, false)?, false)),
            "roughconductor" => Ok((self.conductor(el, true)?, false)),
            "dielectric" => Ok((self.dielectric(el, false, false)?, false)),
            "roughdielectric" => Ok((self.dielectric(el, true, false)?, false)),
            "thindielectric" => Ok((self.dielectric(el, false, true)?, false)),
            "plastic" => Ok((self.plastic(el, false)?, false)),
            "roughplastic" => Ok((self.plastic(el, true)?, false)),
            _ => Err(unsupported(el, "bsdf", BSDFS)),
        }
    }

    /// `twosided` around one BSDF, nested or referenced: its material, two-sided.
    fn twosided(&mut self, el: &El) -> Result<(MaterialDesc, bool)> {
        Params::of(el, &[], &["bsdf", "ref"])?;
        let mut inner = Vec::new();
        for k in &el.kids {
            match k.tag.as_str() {
                "bsdf" => inner.push(k),
                "ref" => inner.push(self.referenced(k, "a twosided BSDF takes a <bsdf>", |d| d.tag == "bsdf")?),
                _ => {}
            }
        }
        let [b] = inner[..] else {
            return Err(el.loc.err(format!(
                "<bsdf type=\"twosided\">: needs exactly one nested <bsdf> (two different sides are not supported); has {}",
                inner.len()
            )));
        };
        if self.twosided_depth >= MAX_TWOSIDED {
            return Err(el.loc.err(format!(
                "<bsdf type=\"twosided\">: twosided BSDFs nest deeper than {MAX_TWOSIDED} (through references, maybe \
                 a loop)"
            )));
        }
        self.twosided_depth += 1;
        let m = self.material(b);
        self.twosided_depth -= 1;
        let mut m = m?.0;
        if let MaterialDesc::Diffuse { two_sided, .. } | MaterialDesc::Plastic { two_sided, .. } = &mut m {
            *two_sided = true;
        }
        Ok((m, true))
    }

    /// `conductor` and `roughconductor`: a named metal, or eta and k, or Mitsuba's default
    /// perfect reflector; smooth with an RGB reflectance and no index, a mirror.
    fn conductor(&mut self, el: &El, rough: bool) -> Result<MaterialDesc> {
        let mut allowed = vec!["material", "eta", "k", "specular_reflectance"];
        if rough {
            allowed.extend(ROUGH_PARAMS);
        }
        let p = Params::of(el, &allowed, &["texture", "ref"])?;
        textured_only(el, &["specular_reflectance"])?;
        let named = p.string("material")?.map(|(m, _)| m);
        let (eta, k) = (p.color("eta")?, p.color("k")?);
        if let Some(m) = named.as_deref().filter(|m| *m != "none") {
            if let Some((_, given)) = p.get("eta")?.or(p.get("k")?) {
                return Err(given.loc.err(format!(
                    "{}: material `{m}` with `eta`/`k`: give a named material or eta and k, not both (Mitsuba \
                     refuses both too)",
                    el.what()
                )));
            }
        }
        let color = self.color_param(&p, "specular_reflectance", [1.0; 3])?;
        let r = if rough { self.roughness(&p)? } else { Rough::default() };
        let indexed = eta.is_some() || k.is_some();
        if let (false, false, ColorDesc::Rgb(c)) = (rough, indexed, &color) {
            if named.as_deref().unwrap_or("none") == "none" {
                return Ok(MaterialDesc::Mirror { color: *c });
            }
        }
        // Mitsuba's defaults with an index: eta 0, k 1 (the perfect reflector).
        let (material, eta, k) = if indexed {
            (None, Some(eta.unwrap_or([0.0; 3])), Some(k.unwrap_or([1.0; 3])))
        } else {
            (Some(named.unwrap_or_else(|| "none".to_string())), None, None)
        };
        let Rough { distribution, alpha, alpha_u, alpha_v } = r;
        Ok(MaterialDesc::Conductor { material, eta, k, color, distribution, alpha, alpha_u, alpha_v })
    }

    /// `dielectric`, `roughdielectric` and `thindielectric`: glass of ior = int_ior /
    /// ext_ior (numbers or Mitsuba's named media); `rough` and `thin` exclude each other.
    fn dielectric(&mut self, el: &El, rough: bool, thin: bool) -> Result<MaterialDesc> {
        let mut allowed = vec!["int_ior", "ext_ior", "specular_transmittance", "specular_reflectance"];
        if rough {
            allowed.extend(ROUGH_PARAMS);
        }
        let p = Params::of(el, &allowed, &[])?;
        let (int, ext) = (ior(&p, "int_ior", 1.5046)?, ior(&p, "ext_ior", 1.00028)?);
        if let Some(r) = p.color("specular_reflectance")? {
            if r != [1.0; 3] {
                let k = p.get("specular_reflectance")?.map(|(_, k)| k.loc.clone()).unwrap_or(el.loc.clone());
                return Err(k.err(format!("{}: specular_reflectance other than 1 is not supported", el.what())));
            }
        }
        let color = p.color("specular_transmittance")?.unwrap_or([1.0; 3]);
        let Rough { distribution, alpha, alpha_u, alpha_v } =
            if rough { self.roughness(&p)? } else { Rough::default() };
        Ok(MaterialDesc::Dielectric {
            ior: int / ext,
            reflect_ratio: None,
            color,
            thin,
            distribution,
            alpha,
            alpha_u,
            alpha_v,
        })
    }

    /// `plastic` and `roughplastic`: a diffuse base (`diffuse_reflectance`, maybe a
    /// texture) under a coating of index int_ior / ext_ior, one-sided as Mitsuba's (a
    /// `twosided` turns the back on); the rough coating is isotropic, as Mitsuba requires.
    fn plastic(&mut self, el: &El, rough: bool) -> Result<MaterialDesc> {
        let mut allowed = vec!["diffuse_reflectance", "specular_reflectance", "int_ior", "ext_ior", "nonlinear"];
        if rough {
            allowed.extend(ROUGH_PARAMS);
        }
        let p = Params::of(el, &allowed, &["texture", "ref"])?;
        textured_only(el, &["diffuse_reflectance"])?;
        let (int, ext) = (ior(&p, "int_ior", 1.49)?, ior(&p, "ext_ior", 1.00028)?);
        if rough && int == ext {
            return Err(el.loc.err(format!("{}: int_ior and ext_ior must differ (as Mitsuba)", el.what())));
        }
        let color = self.color_param(&p, "diffuse_reflectance", [0.5; 3])?;
        let specular = p.color("specular_reflectance")?.unwrap_or([1.0; 3]);
        let nonlinear = p.boolean("nonlinear")?.unwrap_or(false);
        let Rough { distribution, alpha, alpha_u, alpha_v } =
            if rough { self.roughness(&p)? } else { Rough::default() };
        if alpha_u.is_some() || alpha_v.is_some() {
            return Err(el.loc.err(format!(
                "{}: anisotropic roughness (alpha_u, alpha_v) is not supported, as in Mitsuba: give `alpha`",
                el.what()
            )));
        }
        Ok(MaterialDesc::Plastic { color, specular, ior: int / ext, nonlinear, two_sided: false, distribution, alpha })
    }

    /// The microfacet parameters, with Mitsuba's defaults (beckmann, alpha 0.1) and its
    /// rules (`alpha`, or both `alpha_u` and `alpha_v`). Numbers pass as given: the loader
    /// checks their range, and its message points back at the BSDF.
    fn roughness(&mut self, p: &Params) -> Result<Rough> {
        let el = p.el;
        let distribution = match p.string("distribution")? {
            None => "beckmann".to_string(),
            Some((d, k)) => {
                let lower = d.to_ascii_lowercase();
                if !DISTRIBUTIONS.contains(&lower.as_str()) {
                    return Err(k.loc.err(format!(
                        "{}: distribution `{d}` is not beckmann or ggx (Mitsuba's microfacet distributions)",
                        el.what()
                    )));
                }
                lower
            }
        };
        if p.boolean("sample_visible")? == Some(false) {
            self.note(format!(
                "{}:{}: {}: sample_visible=false is ignored: it changes how Mitsuba samples the microfacet normals, \
                 not the image it converges to",
                el.loc.file,
                el.loc.line,
                el.what()
            ));
        }
        let (alpha, u, v) = (p.num("alpha")?, p.num("alpha_u")?, p.num("alpha_v")?);
        let mut r = Rough { distribution: Some(distribution), ..Rough::default() };
        match (alpha, u, v) {
            (Some(_), Some(_), _) | (Some(_), _, Some(_)) => {
                let at = p.get("alpha")?.map_or(el.loc.clone(), |(_, k)| k.loc.clone());
                return Err(
                    at.err(format!("{}: give `alpha` or `alpha_u` and `alpha_v`, not both (as Mitsuba)", el.what()))
                );
            }
            (None, Some(u), Some(v)) => (r.alpha_u, r.alpha_v) = (Some(u as f32), Some(v as f32)),
            (None, Some(_), None) | (None, None, Some(_)) => {
                return Err(el.loc.err(format!("{}: give both `alpha_u` and `alpha_v` (as Mitsuba)", el.what())))
            }
            (a, None, None) => r.alpha = Some(a.unwrap_or(0.1) as f32),
        }
        Ok(r)
    }

    /// A colour parameter that may be a texture: an `<rgb>`/`<spectrum>`/number, a nested
    /// `<texture name=...>`, or a `<ref name=... id=...>` to a texture declared anywhere.
    fn color_param(&mut self, p: &Params, name: &str, default: [f32; 3]) -> Result<ColorDesc> {
        let el = p.el;
        let tex: Vec<&El> =
            el.kids.iter().filter(|k| (k.tag == "texture" || k.tag == "ref") && k.attr("name") == Some(name)).collect();
        let value = p.get(name)?.map(|(_, k)| k);
        if let Some(second) = tex.iter().copied().chain(value).nth(1) {
            return Err(second.loc.err(format!("{}: parameter `{name}` given twice", el.what())));
        }
        let Some(&t) = tex.first() else { return Ok(ColorDesc::Rgb(p.color(name)?.unwrap_or(default))) };
        let t = if t.tag == "ref" {
            self.referenced(t, &format!("`{name}` takes a <texture> ({TEXTURES})"), |d| d.tag == "texture")?
        } else {
            t
        };
        Ok(ColorDesc::Texture(self.texture(t)?))
    }
}

/// Refuses a `<texture>` or `<ref>` inside BSDF `el` for any parameter but `colors`:
/// roughness and the other parameters take plain values.
fn textured_only(el: &El, colors: &[&str]) -> Result<()> {
    for k in el.kids.iter().filter(|k| k.tag == "texture" || k.tag == "ref") {
        match k.attr("name") {
            Some(n) if colors.contains(&n) => {}
            n => {
                return Err(k.loc.err(format!(
                    "<{}{}> inside {}: not supported; wavetrace takes a texture ({TEXTURES}) for {} only",
                    k.tag,
                    n.map(|n| format!(" name=\"{n}\"")).unwrap_or_default(),
                    el.what(),
                    colors.join(", ")
                )))
            }
        }
    }
    Ok(())
}

/// An index of refraction parameter: a number > 0 or one of Mitsuba's named media.
fn ior(p: &Params, name: &str, default: f32) -> Result<f32> {
    match p.get(name)? {
        None => Ok(default),
        Some((Value::Num(x), _)) if x > 0.0 => Ok(x as f32),
        Some((Value::Str(s), k)) => {
            IORS.iter().find(|(n, _)| n.eq_ignore_ascii_case(s.trim())).map(|(_, v)| *v).ok_or_else(|| {
                let names: Vec<&str> = IORS.iter().map(|(n, _)| *n).collect();
                k.loc.err(format!("{}: unknown medium `{s}` (known: {})", p.el.what(), names.join(", ")))
            })
        }
        Some((_, k)) => Err(k.loc.err(format!("{}: `{name}` must be a number > 0 or a medium name", p.el.what()))),
    }
}
