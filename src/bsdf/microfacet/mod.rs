//! Microfacet reflection and transmission: the GGX and Beckmann normal distributions with
//! visible-normal sampling, Smith shadowing, Fresnel for conductors (complex index of
//! refraction), and the rough conductor and rough dielectric BSDFs built on them, as
//! Mitsuba 3 defines them (`microfacet.h`, `roughconductor.cpp`, `roughdielectric.cpp`).
//!
//! Directions are in the local shading frame: +z is the shading normal.
//!
//! Transmission convention: wavetrace does **not** scale radiance by 1/η² when it crosses
//! a dielectric boundary (its smooth glass does not either; on closed objects the factors
//! of entering and leaving cancel). The rough dielectric here is therefore Mitsuba's in
//! `TransportMode::Importance`: no `eta_ti²` in the refraction weight, no `inv_eta²` in
//! `eval`. It obeys the generalised reciprocity f(wi, wo) / η_o² = f(wo, wi) / η_i².
//!
//! Everything is written after Mitsuba 3.9.1's scalar code, branch for branch, so that a
//! scene renders the same BSDF in both; the unit tests (`tests.rs`) check densities with
//! Mitsuba's χ² procedure and values against numbers read off Mitsuba's Python module.

mod conductors;
mod lanes;
mod rough_lanes;
#[cfg(test)]
pub(crate) mod tests;

pub use conductors::{named_conductor, CONDUCTORS};
pub(crate) use lanes::fresnel_dielectric_lanes;
pub use lanes::tangents_lanes;
pub use rough_lanes::{RoughConductor, RoughDielectric, SplitLanes};

use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_2_SQRT_PI, PI};

/// A microfacet normal distribution.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Distribution {
    /// Trowbridge–Reitz (GGX): long tails.
    Ggx,
    /// Beckmann: a Gaussian of slopes, Mitsuba's default for rough plugins.
    Beckmann,
}

/// A microfacet distribution with its roughness along the frame's two tangents.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Microfacet {
    /// Which distribution.
    pub distribution: Distribution,
    /// Roughness along the frame's first tangent (x).
    pub alpha_u: f32,
    /// Roughness along the second tangent (y); equal to `alpha_u` when isotropic.
    pub alpha_v: f32,
}

/// Mitsuba clamps roughness to this (`MicrofacetDistribution::configure`): α = 0 would
/// make D a delta, which the smooth plugins handle instead; below it the distribution's
/// sampling loses its precision. The scene loaders clamp roughness to it too.
pub const MIN_ALPHA: f32 = 1e-4;

impl Microfacet {
    /// The roughness pair as Mitsuba uses it, clamped to [`MIN_ALPHA`].
    fn alphas(&self) -> (f32, f32) {
        (self.alpha_u.max(MIN_ALPHA), self.alpha_v.max(MIN_ALPHA))
    }

    /// D(m), the density of microfacet normals per projected area (integrates to 1 against
    /// m.z over the hemisphere); 0 where D·cos θ underflows, as Mitsuba, so that later
    /// divisions stay finite.
    pub fn eval(&self, m: Vec3) -> f32 {
        let (au, av) = self.alphas();
        let cos2 = m.z * m.z;
        let (x, y) = (m.x / au, m.y / av);
        let d = match self.distribution {
            Distribution::Beckmann => (-(x * x + y * y) / cos2).exp() / (PI * au * av * cos2 * cos2),
            Distribution::Ggx => {
                let t = x * x + y * y + cos2;
                1.0 / (PI * au * av * t * t)
            }
        };
        if d * m.z > 1e-20 {
            d
        } else {
            0.0
        }
    }

    /// Smith's G1(v, m), 0 when v and m are on opposite sides as Mitsuba (one cannot see
    /// the back of a microfacet from the front). Beckmann uses Mitsuba's rational
    /// approximation (< 0.35 % relative error), not the erf form.
    pub fn smith_g1(&self, v: Vec3, m: Vec3) -> f32 {
        let (au, av) = self.alphas();
        let xy_alpha2 = (au * v.x) * (au * v.x) + (av * v.y) * (av * v.y);
        if v.dot(m) * v.z <= 0.0 {
            return 0.0;
        }
        if xy_alpha2 == 0.0 {
            // Perpendicular incidence: no shadowing.
            return 1.0;
        }
        let tan_alpha2 = xy_alpha2 / (v.z * v.z);
        match self.distribution {
            Distribution::Beckmann => {
                let a = 1.0 / tan_alpha2.sqrt();
                if a >= 1.6 {
                    1.0
                } else {
                    let a2 = a * a;
                    (3.535 * a + 2.181 * a2) / (1.0 + 2.276 * a + 2.577 * a2)
                }
            }
            Distribution::Ggx => 2.0 / (1.0 + (1.0 + tan_alpha2).sqrt()),
        }
    }

    /// G(wi, wo, m) = G1(wi, m) G1(wo, m): Smith's separable shadowing-masking.
    pub fn g(&self, wi: Vec3, wo: Vec3, m: Vec3) -> f32 {
        self.smith_g1(wi, m) * self.smith_g1(wo, m)
    }

    /// A visible normal for `wi` (wi.z > 0; the dielectric flips it first): stretch wi to
    /// the α = 1 configuration, sample slopes there, rotate and unstretch (Heitz and
    /// d'Eon 2014). The α = 1 step is Heitz 2018's exact hemisphere method for GGX and
    /// Jakob's Newton inversion for Beckmann, exactly as Mitsuba's `sample_visible_11`.
    /// Returns m with m.z > 0; its density is [`Microfacet::pdf`].
    pub fn sample(&self, wi: Vec3, u: Vec2) -> Vec3 {
        let (au, av) = self.alphas();
        let wi_p = Vec3::new(au * wi.x, av * wi.y, wi.z).normalize();
        let (sin_phi, cos_phi) = sincos_phi(wi_p);
        let slope = self.sample_visible_11(wi_p.z, u);
        let sx = (cos_phi * slope.x - sin_phi * slope.y) * au;
        let sy = (sin_phi * slope.x + cos_phi * slope.y) * av;
        Vec3::new(-sx, -sy, 1.0).normalize()
    }

    /// The density of [`Microfacet::sample`] over m (solid angle):
    /// G1(wi, m) max(0, wi·m) D(m) / wi.z.
    pub fn pdf(&self, wi: Vec3, m: Vec3) -> f32 {
        // G1 is 0 when wi·m < 0, so Mitsuba's |wi·m| and max(0, wi·m) agree.
        self.eval(m) * self.smith_g1(wi, m) * wi.dot(m).abs() / wi.z
    }

    /// Slopes of a visible normal for α = 1 and an incident cosine `cos_i` (Mitsuba's
    /// `sample_visible_11`).
    fn sample_visible_11(&self, cos_i: f32, u: Vec2) -> Vec2 {
        match self.distribution {
            Distribution::Beckmann => {
                // Mitsuba replaced the paper's inversion (discontinuous, bad for QMC) by
                // a Newton solve in the erf domain.
                let tan_i = (1.0 - cos_i * cos_i).max(0.0).sqrt() / cos_i;
                let cot_i = 1.0 / tan_i;
                let maxval = erf(cot_i);
                let u = u.clamp(Vec2::splat(1e-6), Vec2::splat(1.0 - 1e-6));
                // The analytic solution for θi = π/2 (the most nonlinear case) as the guess.
                let mut x = maxval - (maxval + 1.0) * erf((-u.x.ln()).sqrt());
                let target = u.x * (1.0 + maxval + FRAC_1_SQRT_PI * tan_i * (-cot_i * cot_i).exp());
                for _ in 0..3 {
                    let slope = erfinv(x);
                    let value = 1.0 + x + FRAC_1_SQRT_PI * tan_i * (-slope * slope).exp() - target;
                    let derivative = 1.0 - slope * tan_i;
                    x -= value / derivative;
                }
                Vec2::new(erfinv(x), erfinv(2.0 * u.y - 1.0))
            }
            Distribution::Ggx => {
                // Heitz 2018: a disk sample, squeezed onto the visible part of the
                // projected hemisphere, lifted to it, and turned into a slope.
                let mut p = square_to_uniform_disk_concentric(u);
                let s = 0.5 * (1.0 + cos_i);
                let a = (1.0 - p.x * p.x).max(0.0).sqrt();
                p.y = a + (p.y - a) * s;
                let z = (1.0 - p.length_squared()).max(0.0).sqrt();
                let sin_i = (1.0 - cos_i * cos_i).max(0.0).sqrt();
                let norm = 1.0 / (sin_i * p.y + cos_i * z);
                Vec2::new((cos_i * p.y - sin_i * z) * norm, p.x * norm)
            }
        }
    }
}

/// 1/√π.
const FRAC_1_SQRT_PI: f32 = 0.564_189_6;

/// sin φ and cos φ of a direction (Mitsuba's `Frame3f::sincos_phi`), (0, 1) along the
/// normal where φ is undefined.
fn sincos_phi(v: Vec3) -> (f32, f32) {
    let sin2 = v.x * v.x + v.y * v.y;
    // Mitsuba's bound is 4 Epsilon with Dr.Jit's Epsilon = 2^-24, half of f32::EPSILON.
    if sin2 <= 2.0 * f32::EPSILON {
        return (0.0, 1.0);
    }
    let inv = 1.0 / sin2.sqrt();
    ((v.y * inv).clamp(-1.0, 1.0), (v.x * inv).clamp(-1.0, 1.0))
}

/// Shirley and Chiu's concentric square-to-disk map in Dave Cline's form, as Mitsuba.
fn square_to_uniform_disk_concentric(u: Vec2) -> Vec2 {
    let x = 2.0 * u.x - 1.0;
    let y = 2.0 * u.y - 1.0;
    if x == 0.0 && y == 0.0 {
        return Vec2::ZERO;
    }
    let q13 = x.abs() < y.abs();
    let (r, rp) = if q13 { (y, x) } else { (x, y) };
    let mut phi = 0.25 * PI * rp / r;
    if q13 {
        phi = 0.5 * PI - phi;
    }
    let (s, c) = phi.sin_cos();
    Vec2::new(r * c, r * s)
}

/// A polynomial c[0] + c[1] x + … by Horner's rule.
fn poly(x: f32, c: &[f32]) -> f32 {
    c.iter().rev().fold(0.0, |acc, &ci| acc * x + ci)
}

/// The error function in single precision, Dr.Jit's minimax fits (max 3.8 ulp on
/// [-6, 6]); Rust's std has none, and Beckmann sampling needs the same function Mitsuba
/// inverts.
fn erf(x: f32) -> f32 {
    let xa = x.abs();
    if xa < 1.0 {
        x * poly(x * x, &ERF_SMALL)
    } else {
        let xb = 1.0 - (poly(xa, &ERF_LARGE) * xa).exp2();
        let xb = if xb.is_finite() { xb } else { 1.0 };
        xb.copysign(x)
    }
}

/// [`erf`]'s fit for |x| < 1, a polynomial in x².
const ERF_SMALL: [f32; 6] =
    [FRAC_2_SQRT_PI, -0.376_123_22, 0.112_801_746, -0.026_711_274, 0.004_917_544_3, -0.000_563_142_24];

/// [`erf`]'s fit for |x| ≥ 1: 1 − 2^(x·p(x)).
const ERF_LARGE: [f32; 7] =
    [-1.628_282_2, -0.916_246_24, -0.153_595_54, 0.034_695_32, -0.005_498_334_3, 0.000_534_170_25, -2.364_301_1e-5];

/// The inverse error function, Giles' approximation as Dr.Jit implements it.
fn erfinv(x: f32) -> f32 {
    let w = -((1.0 - x) * (1.0 + x)).ln();
    let p = if w < 5.0 { poly(w - 2.5, &ERFINV_CENTRAL) } else { poly(w.sqrt() - 3.0, &ERFINV_TAIL) };
    p * x
}

/// [`erfinv`]'s fit for w = −ln(1 − x²) < 5, a polynomial in w − 2.5.
const ERFINV_CENTRAL: [f32; 9] = [
    1.501_409_4,
    0.246_640_73,
    -0.004_177_681_6,
    -0.001_253_725,
    0.000_218_580_87,
    -4.391_506_5e-6,
    -3.523_387_7e-6,
    3.432_739_4e-7,
    2.810_226_4e-8,
];

/// [`erfinv`]'s fit for w ≥ 5, a polynomial in √w − 3.
const ERFINV_TAIL: [f32; 9] = [
    2.832_976_8,
    1.001_674,
    0.009_438_870_5,
    -0.007_622_461_3,
    0.005_739_507_7,
    -0.003_673_428_4,
    0.001_349_343_2,
    0.000_100_950_56,
    -0.000_200_214_26,
];

/// An orthonormal tangent pair (s, t) for a unit normal n, with s × t = n (Mitsuba's
/// `coordinate_system`, Duff et al. 2017), so anisotropic roughness has the same axes as
/// in Mitsuba on meshes without UVs. There Mitsuba takes dp/du = `tangents(face normal).0`
/// and builds the shading frame from it by Gram–Schmidt against the shading normal
/// (`initialize_sh_frame`: s = normalize(dp_du − n (n·dp_du)), t = n × s), so with vertex
/// normals the frame is not `tangents(shading normal)`.
pub fn tangents(n: Vec3) -> (Vec3, Vec3) {
    // copysign rather than signum's sign test: -0.0 gives -1 as Dr.Jit's `sign`.
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (Vec3::new(n.x * n.x * a * sign + 1.0, b * sign, -n.x * sign), Vec3::new(b, n.y * n.y * a + sign, -n.y))
}

/// Unpolarised Fresnel reflectance of a conductor with complex index of refraction
/// η + i k per channel (Mitsuba's `fresnel_conductor`, after Moeller's *Optics*),
/// `cos_i` in [0, 1]: light arrives from outside the conductor. A channel where η = k = 0
/// reflects everything: that is Mitsuba's "none", a perfect reflector, and what Mitsuba's
/// gamut clamp leaves of some named metals' channels (AlSb's red), where the formula is
/// 0/0 at normal incidence.
pub fn fresnel_conductor(cos_i: f32, eta: Vec3, k: Vec3) -> Vec3 {
    let one = |eta: f32, k: f32| {
        let cos2 = cos_i * cos_i;
        let sin2 = 1.0 - cos2;
        let sin4 = sin2 * sin2;
        let temp1 = eta * eta - k * k - sin2;
        let a2pb2 = (temp1 * temp1 + 4.0 * k * k * eta * eta).max(0.0).sqrt();
        let a = (0.5 * (a2pb2 + temp1)).max(0.0).sqrt();
        let term1 = a2pb2 + cos2;
        let term2 = 2.0 * cos_i * a;
        let rs = (term1 - term2) / (term1 + term2);
        let term3 = a2pb2 * cos2 + sin4;
        let term4 = term2 * sin2;
        let rp = rs * (term3 - term4) / (term3 + term4);
        0.5 * (rs + rp)
    };
    let f = Vec3::new(one(eta.x, k.x), one(eta.y, k.y), one(eta.z, k.z));
    Vec3::select(eta.cmpeq(Vec3::ZERO) & k.cmpeq(Vec3::ZERO), Vec3::ONE, f)
}

/// Mitsuba's dielectric `fresnel(cos_i, eta)`: the reflectance F, the signed cosine of
/// the transmitted direction, and η_ti, the ratio of the incident side's index to the
/// transmitted side's (the factor on the tangential part of the refracted direction).
/// `cos_i` < 0 means wi is inside (below the normal). F = 1 under total internal
/// reflection, 0 for η = 1.
pub(crate) fn fresnel_dielectric(cos_i: f32, eta: f32) -> (f32, f32, f32) {
    let (eta_it, eta_ti) = if cos_i >= 0.0 { (eta, 1.0 / eta) } else { (1.0 / eta, eta) };
    let cos_t2 = 1.0 - (1.0 - cos_i * cos_i) * eta_ti * eta_ti;
    let ci = cos_i.abs();
    let ct = cos_t2.max(0.0).sqrt();
    let f = if eta == 1.0 {
        0.0
    } else if ci == 0.0 {
        1.0
    } else {
        let a_s = (ci - eta_it * ct) / (ci + eta_it * ct);
        let a_p = (ct - eta_it * ci) / (ct + eta_it * ci);
        0.5 * (a_s * a_s + a_p * a_p)
    };
    // The transmitted direction is on the other side: the opposite sign of cos_i.
    let cos_t = if cos_i >= 0.0 { -ct } else { ct };
    (f, cos_t, eta_ti)
}

/// Mirror `wi` about `m` (both pointing away from the surface).
pub(crate) fn reflect(wi: Vec3, m: Vec3) -> Vec3 {
    2.0 * wi.dot(m) * m - wi
}

/// Refract `wi` through `m` given [`fresnel_dielectric`]'s cos θt and η_ti (Mitsuba's
/// `refract`).
pub(crate) fn refract(wi: Vec3, m: Vec3, cos_t: f32, eta_ti: f32) -> Vec3 {
    m * (wi.dot(m) * eta_ti + cos_t) - wi * eta_ti
}

/// Rough conductor, one sample: wi.z > 0 (the caller turns the frame to the incoming
/// side). Returns (wo, weight) with weight = F(wi·m)·G1(wo, m) per channel, the sample's
/// f·cos θo / pdf, or None when wo goes below the surface (or wi is not above it).
pub fn rough_conductor_sample(mf: &Microfacet, eta: Vec3, k: Vec3, wi: Vec3, u: Vec2) -> Option<(Vec3, Vec3)> {
    if wi.z <= 0.0 {
        return None;
    }
    let m = mf.sample(wi, u);
    let wo = reflect(wi, m);
    // Mitsuba refuses samples whose density is 0 (D underflowed, or m not visible).
    if wo.z <= 0.0 || mf.pdf(wi, m) == 0.0 {
        return None;
    }
    let weight = mf.smith_g1(wo, m) * fresnel_conductor(wi.dot(m), eta, k);
    Some((wo, weight))
}

/// The rough conductor's f(wi, wo)·cos θo (Mitsuba's `eval`): F D G / (4 cos θi);
/// zero unless both directions are above the surface.
pub fn rough_conductor_eval(mf: &Microfacet, eta: Vec3, k: Vec3, wi: Vec3, wo: Vec3) -> Vec3 {
    if wi.z <= 0.0 || wo.z <= 0.0 {
        return Vec3::ZERO;
    }
    let h = (wi + wo).normalize();
    let d = mf.eval(h);
    if d == 0.0 {
        return Vec3::ZERO;
    }
    let value = d * mf.g(wi, wo, h) / (4.0 * wi.z);
    value * fresnel_conductor(wi.dot(h), eta, k)
}

/// The density over wo of [`rough_conductor_sample`]: D(h) G1(wi, h) / (4 cos θi), the
/// visible-normal density times the reflection Jacobian 1 / (4 wo·h).
pub fn rough_conductor_pdf(mf: &Microfacet, wi: Vec3, wo: Vec3) -> f32 {
    let h = (wi + wo).normalize();
    // The side checks smith_g1 makes in eval and sample, repeated as Mitsuba does.
    if wi.z <= 0.0 || wo.z <= 0.0 || wi.dot(h) <= 0.0 || wo.dot(h) <= 0.0 {
        return 0.0;
    }
    mf.eval(h) * mf.smith_g1(wi, h) / (4.0 * wi.z)
}

/// Both branches of one rough dielectric sample: each is (wo, weight) or None.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Split {
    /// Reflection about the sampled m, weight F(wi·m)·G1(wo, m).
    pub reflect: Option<(Vec3, f32)>,
    /// Refraction through m, weight (1 − F)·G1(wo, m) (no 1/η² radiance scale: see the
    /// module docs).
    pub refract: Option<(Vec3, f32)>,
    /// F(wi·m), the Fresnel reflectance at the sampled normal (0 when nothing was
    /// sampled): the probability with which Mitsuba picks the reflection.
    pub f: f32,
}

/// The shared first step of the dielectric sample: a visible normal for wi's side and
/// the Fresnel terms at it, or None where Mitsuba's sample would be inactive.
struct DielectricMicro {
    m: Vec3,
    f: f32,
    cos_t: f32,
    eta_ti: f32,
}

/// A visible normal m for `wi` on either side (sampled for wi mirrored to the top, as
/// Mitsuba's `mulsign(wi, cos_theta_i)`) and Fresnel at wi·m; None for grazing wi or a
/// zero-density m.
fn dielectric_micro(mf: &Microfacet, eta: f32, wi: Vec3, u: Vec2) -> Option<DielectricMicro> {
    if wi.z == 0.0 {
        return None;
    }
    let wi_up = if wi.z > 0.0 { wi } else { -wi };
    let m = mf.sample(wi_up, u);
    if mf.pdf(wi_up, m) == 0.0 {
        return None;
    }
    let (f, cos_t, eta_ti) = fresnel_dielectric(wi.dot(m), eta);
    Some(DielectricMicro { m, f, cos_t, eta_ti })
}

/// Rough dielectric: one visible-normal sample m for wi on either side (`eta` is
/// n_inside / n_outside, Mitsuba's int_ior / ext_ior; +z points outside), and both
/// branches: reflection with weight F(wi·m)·G1(wo_r, m), refraction with weight
/// (1 − F)·G1(wo_t, m). A branch is None when its direction is on the wrong side of the
/// surface, its weight is 0 (total internal reflection leaves no refraction), or wi is
/// grazing. Tracing both branches has the expectation of Mitsuba's stochastic choice,
/// where branch b has probability P_b and weight eval/pdf = weight_b / P_b.
pub fn rough_dielectric_split(mf: &Microfacet, eta: f32, wi: Vec3, u: Vec2) -> Split {
    let Some(s) = dielectric_micro(mf, eta, wi, u) else {
        return Split { reflect: None, refract: None, f: 0.0 };
    };
    let wo_r = reflect(wi, s.m);
    let w_r = s.f * mf.smith_g1(wo_r, s.m);
    let wo_t = refract(wi, s.m, s.cos_t, s.eta_ti);
    let w_t = (1.0 - s.f) * mf.smith_g1(wo_t, s.m);
    Split {
        reflect: (w_r > 0.0 && wo_r.z * wi.z > 0.0).then_some((wo_r, w_r)),
        refract: (w_t > 0.0 && wo_t.z * wi.z < 0.0).then_some((wo_t, w_t)),
        f: s.f,
    }
}

/// The generalised half vector of wi and wo (Walter et al. 2007), turned to +z, the
/// relative index η_o/η_i for wi's side, and whether wo is a reflection. None where the
/// half vector is undefined (η = 1 and wo = −wi, a delta), where Mitsuba would return NaN.
fn dielectric_half(eta: f32, wi: Vec3, wo: Vec3) -> Option<(Vec3, f32, bool)> {
    let reflect = wi.z * wo.z > 0.0;
    let eta_r = if wi.z > 0.0 { eta } else { 1.0 / eta };
    let m = (wi + wo * if reflect { 1.0 } else { eta_r }).try_normalize()?;
    // Mitsuba's mulsign: flips on the sign bit, so -0.0 flips too.
    let m = if m.z.is_sign_negative() { -m } else { m };
    Some((m, eta_r, reflect))
}

/// The rough dielectric's f(wi, wo)·|cos θo| (Mitsuba's `eval` in importance mode, i.e.
/// without the 1/η² radiance scale on transmission: see the module docs).
pub fn rough_dielectric_eval(mf: &Microfacet, eta: f32, wi: Vec3, wo: Vec3) -> f32 {
    if wi.z == 0.0 {
        return 0.0;
    }
    let Some((m, eta_r, reflect)) = dielectric_half(eta, wi, wo) else {
        return 0.0;
    };
    let d = mf.eval(m);
    let f = fresnel_dielectric(wi.dot(m), eta).0;
    let g = mf.g(wi, wo, m);
    if reflect {
        f * d * g / (4.0 * wi.z.abs())
    } else {
        let (dim, dom) = (wi.dot(m), wo.dot(m));
        let den = dim + eta_r * dom;
        ((1.0 - f) * d * g * eta_r * eta_r * dim * dom / (wi.z * den * den)).abs()
    }
}

/// The density over wo of choosing a branch with probability F (reflection) or 1 − F
/// (refraction) after [`rough_dielectric_split`]'s m, as Mitsuba's `pdf`; so each split
/// weight equals eval / pdf × that branch's probability.
pub fn rough_dielectric_pdf(mf: &Microfacet, eta: f32, wi: Vec3, wo: Vec3) -> f32 {
    if wi.z == 0.0 {
        return 0.0;
    }
    let Some((m, eta_r, reflect)) = dielectric_half(eta, wi, wo) else {
        return 0.0;
    };
    let (dim, dom) = (wi.dot(m), wo.dot(m));
    // The side checks smith_g1 makes in eval and sample, repeated as Mitsuba does.
    if dim * wi.z <= 0.0 || dom * wo.z <= 0.0 {
        return 0.0;
    }
    let dwh_dwo = if reflect {
        1.0 / (4.0 * dom)
    } else {
        let den = dim + eta_r * dom;
        eta_r * eta_r * dom / (den * den)
    };
    let wi_up = if wi.z > 0.0 { wi } else { -wi };
    let f = fresnel_dielectric(dim, eta).0;
    let choice = if reflect { f } else { 1.0 - f };
    mf.pdf(wi_up, m) * choice * dwh_dwo.abs()
}
