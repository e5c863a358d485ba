//! Plastic: a diffuse base under a dielectric coating, smooth (Mitsuba 3's `plastic`) or
//! rough (`roughplastic`), branch for branch as Mitsuba 3.9.1 writes them.
//!
//! Light reflects off the coating (a mirror weighted by Fresnel, or a microfacet lobe),
//! or enters it, scatters in the base and leaves: the diffuse part, scaled by the
//! coating's transmittance both ways, by 1/η² (radiance spreading into the wider cone
//! outside), and by 1 / (1 − r·ρ) (nonlinear) or 1 / (1 − r) for the light the coating
//! turns back inside (r its internal diffuse reflectance). Both sides of a plastic are
//! its front: the caller turns the frame to the incoming side, or returns black for a
//! one-sided plastic seen from behind.
//!
//! Which lobe a sample follows is chosen by `specular_sampling_weight` (the specular
//! reflectance's mean over the sum of both means) times the coating's reflectance at the
//! incident angle, as Mitsuba does.

use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::f32::consts::FRAC_1_PI;

use super::microfacet::{fresnel_dielectric, fresnel_dielectric_lanes, reflect, Microfacet};
use crate::sampling::cosine_hemisphere;
use crate::simd::{LANES, V3};
use wide::f32x16;

/// Entries of a rough coating's transmittance table over cos θ in [0, 1] (Mitsuba's
/// `MI_ROUGH_TRANSMITTANCE_RES`).
pub const TABLE_RES: usize = 64;

/// A rough coating's external transmittance at `TABLE_RES` cosines evenly spaced over
/// [0, 1], linearly interpolated between them.
pub type Transmittance = [f32; TABLE_RES];

/// A plastic at one shading point: its parameters, with its textures looked up.
#[derive(Clone, Copy, Debug)]
pub struct Plastic<'a> {
    /// Reflectance of the diffuse base.
    pub diffuse: Vec3,
    /// Multiplies the coating's reflection.
    pub specular: Vec3,
    /// Index of refraction of the coating over the outside's (int_ior / ext_ior).
    pub eta: f32,
    /// The coating's roughness; `None`: smooth.
    pub roughness: Option<&'a Microfacet>,
    /// The rough coating's transmittance table (unused when smooth).
    pub table: &'a Transmittance,
    /// The coating's internal diffuse reflectance r ([`smooth_internal`] or
    /// [`rough_internal`]).
    pub internal: f32,
    /// Scale the base by 1 / (1 − r·ρ) rather than 1 / (1 − r) (Mitsuba's `nonlinear`).
    pub nonlinear: bool,
    /// Mitsuba's `specular_sampling_weight`: the specular mean over both means.
    pub specular_weight: f32,
}

/// One sampled direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// The direction, local, above the surface.
    pub wo: Vec3,
    /// f·cos θo / density (the throughput's factor).
    pub weight: Vec3,
    /// The density over solid angle; 0 for the smooth coating's mirror (a delta).
    pub pdf: f32,
}

impl Plastic<'_> {
    /// The coating's transmittance at incidence cosine `cos` from outside: 1 − F for a
    /// smooth coating, the table's value for a rough one.
    fn transmittance(&self, cos: f32) -> f32 {
        match self.roughness {
            None => 1.0 - fresnel_dielectric(cos, self.eta).0,
            Some(_) => lerp_table(self.table, cos),
        }
    }

    /// The probability of sampling the specular lobe at incidence cosine `cos_i`.
    fn prob_specular(&self, cos_i: f32) -> f32 {
        let t = self.transmittance(cos_i);
        let s = (1.0 - t) * self.specular_weight;
        let d = t * (1.0 - self.specular_weight);
        s / (s + d)
    }

    /// The diffuse base's reflectance seen through the coating, before the
    /// transmittances: ρ / (1 − r·ρ) or ρ / (1 − r), over η².
    fn base(&self) -> Vec3 {
        let denominator = match self.nonlinear {
            true => Vec3::ONE - self.diffuse * self.internal,
            false => Vec3::splat(1.0 - self.internal),
        };
        self.diffuse / denominator / (self.eta * self.eta)
    }

    /// f(wi, wo)·cos θo and the density of [`Plastic::sample`] for wo (both 0 below the
    /// surface; the smooth coating's mirror is a delta, in neither).
    pub fn eval_pdf(&self, wi: Vec3, wo: Vec3) -> (Vec3, f32) {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return (Vec3::ZERO, 0.0);
        }
        let (t_i, t_o) = (self.transmittance(wi.z), self.transmittance(wo.z));
        let diffuse = self.base() * (FRAC_1_PI * wo.z * t_i * t_o);
        let p_spec = self.prob_specular(wi.z);
        let pdf_diffuse = (1.0 - p_spec) * wo.z * FRAC_1_PI;
        let Some(mf) = self.roughness else { return (diffuse, pdf_diffuse) };
        let h = (wo + wi).normalize();
        let d = mf.eval(h);
        let f = fresnel_dielectric(wi.dot(h), self.eta).0;
        let g1_i = mf.smith_g1(wi, h);
        let specular = self.specular * (f * d * g1_i * mf.smith_g1(wo, h) / (4.0 * wi.z));
        let pdf = p_spec * d * g1_i / (4.0 * wi.z) + pdf_diffuse;
        (specular + diffuse, pdf)
    }

    /// A direction for `wi` (above the surface): the specular lobe when `u1` is below its
    /// probability, else the cosine-weighted base, from `u2`. `None` below the surface or
    /// where the density vanishes.
    pub fn sample(&self, wi: Vec3, u1: f32, u2: Vec2) -> Option<Sample> {
        if wi.z <= 0.0 {
            return None;
        }
        let p_spec = self.prob_specular(wi.z);
        let specular = u1 < p_spec;
        let Some(mf) = self.roughness else {
            // The smooth coating: Mitsuba's weights, term for term.
            let f_i = 1.0 - self.transmittance(wi.z);
            if specular {
                let wo = Vec3::new(-wi.x, -wi.y, wi.z);
                return Some(Sample { wo, weight: self.specular * (f_i / p_spec), pdf: 0.0 });
            }
            let wo = cosine_hemisphere(u2);
            let p_diffuse = 1.0 - p_spec;
            let f_o = 1.0 - self.transmittance(wo.z);
            let weight = self.base() * ((1.0 - f_i) * (1.0 - f_o) / p_diffuse);
            let pdf = p_diffuse * wo.z * FRAC_1_PI;
            return (pdf > 0.0).then_some(Sample { wo, weight, pdf });
        };
        let wo = if specular { reflect(wi, mf.sample(wi, u2)) } else { cosine_hemisphere(u2) };
        let (f, pdf) = self.eval_pdf(wi, wo);
        (pdf > 0.0).then(|| Sample { wo, weight: f / pdf, pdf })
    }
}

/// Mitsuba's `lerp_gather`: the table linearly interpolated at `x` in [0, 1].
fn lerp_table(table: &Transmittance, x: f32) -> f32 {
    let x = x * (TABLE_RES - 1) as f32;
    let i = (x as usize).min(TABLE_RES - 2);
    let (v0, v1) = (table[i], table[i + 1]);
    v0 + (v1 - v0) * (x - i as f32)
}

/// Mitsuba's `specular_sampling_weight` for the means of the specular and diffuse
/// reflectances; one half where both are 0 (Mitsuba divides 0 by 0 there).
pub fn specular_weight(specular_mean: f32, diffuse_mean: f32) -> f32 {
    let sum = specular_mean + diffuse_mean;
    if sum > 0.0 {
        specular_mean / sum
    } else {
        0.5
    }
}

/// The smooth coating's internal diffuse reflectance: Mitsuba's
/// `fresnel_diffuse_reflectance(1 / eta)` (Egan and Hilgeman's fit for a relative index
/// below 1, d'Eon and Irving's above).
pub fn smooth_internal(eta: f32) -> f32 {
    let eta = 1.0 / eta;
    let inv = 1.0 / eta;
    if eta < 1.0 {
        0.0636 * inv + eta * (eta * -1.4399 + 0.7099) + 0.6681
    } else {
        let c = [0.919317f32, -3.4793, 6.75335, -7.80989, 4.98554, -1.36881];
        c.iter().rev().fold(0.0, |acc, &ci| acc * inv + ci)
    }
}

/// The rough coating's external transmittance table: at each cosine μ (at least 1e-6),
/// the mean over visible normals m of (1 − F(wi·m))·G1(wo, m) for the refracted wo, by
/// Gauss–Legendre quadrature on 32² points (Mitsuba's `eval_transmittance`).
pub fn rough_transmittance(mf: &Microfacet, eta: f32) -> Transmittance {
    let quad = Quadrature::new(if eta > 1.0 { 32 } else { 128 });
    let rows: Vec<f32> = (0..TABLE_RES)
        .into_par_iter()
        .map(|i| {
            let wi = table_direction(i);
            let w = V3::splat(wi);
            quad.integrate(|u| {
                let m = mf.sample_lanes(wi, u);
                let (f, cos_t, eta_ti) = fresnel_dielectric_lanes(w.dot(m), eta);
                // Mitsuba's `refract`.
                let wo = m.scale(w.dot(m) * eta_ti + cos_t) - w.scale(eta_ti);
                let g = mf.smith_g1_lanes(wo, m) * (f32x16::splat(1.0) - f);
                (wo.z * w.z).simd_ge(f32x16::ZERO).select(f32x16::ZERO, g)
            }) as f32
        })
        .collect();
    std::array::from_fn(|i| rows[i])
}

/// The rough coating's internal diffuse reflectance: twice the mean over the table's
/// cosines μ of μ times the reflectance seen from inside (Mitsuba's `eval_reflectance`
/// with η inverted), on 64² points per cosine where Mitsuba takes 128² (for η > 1): a
/// quarter of the work, within 10⁻⁴ of Mitsuba's value (tested), which moves the base's
/// brightness by less than 0.04 %.
pub fn rough_internal(mf: &Microfacet, eta: f32) -> f32 {
    internal_reflectance(mf, eta, if eta < 1.0 { 32 } else { INTERNAL_POINTS })
}

/// Gauss–Legendre points per axis of [`rough_internal`] for a coating denser than the
/// outside.
const INTERNAL_POINTS: usize = 64;

/// [`rough_internal`] on `n`² points per cosine.
fn internal_reflectance(mf: &Microfacet, eta: f32, n: usize) -> f32 {
    let eta = 1.0 / eta;
    let quad = Quadrature::new(n);
    // The rows in parallel, summed in order.
    let rows: Vec<f64> = (0..TABLE_RES)
        .into_par_iter()
        .map(|i| {
            let wi = table_direction(i);
            let w = V3::splat(wi);
            let r = quad.integrate(|u| {
                let m = mf.sample_lanes(wi, u);
                let wo = m.scale(f32x16::splat(2.0) * w.dot(m)) - w;
                let r = mf.smith_g1_lanes(wo, m) * fresnel_dielectric_lanes(w.dot(m), eta).0;
                (wo.z.simd_le(f32x16::ZERO) | w.z.simd_le(f32x16::ZERO)).select(f32x16::ZERO, r)
            });
            r as f32 as f64 * f64::from(wi.z)
        })
        .collect();
    let sum: f64 = rows.iter().sum();
    (2.0 * sum / TABLE_RES as f64) as f32
}

/// The table's i-th incident direction: cosine i / (TABLE_RES − 1), at least 1e-6.
fn table_direction(i: usize) -> Vec3 {
    let mu = (i as f32 / (TABLE_RES - 1) as f32).max(1e-6);
    Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu)
}

/// Gauss–Legendre nodes and weights on [−1, 1], used on the unit square as a product
/// rule (Mitsuba's `quad::gauss_legendre` with `meshgrid`).
struct Quadrature {
    nodes: Vec<f64>,
    weights: Vec<f64>,
}

impl Quadrature {
    /// The `n`-point rule: the roots of the Legendre polynomial P_n by Newton's method
    /// from Tricomi's estimates, in double precision.
    fn new(n: usize) -> Quadrature {
        let (mut nodes, mut weights) = (vec![0.0; n], vec![0.0; n]);
        for i in 0..n {
            let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            for _ in 0..100 {
                let (p, d) = legendre(n, x);
                let step = p / d;
                x -= step;
                if step.abs() < 1e-15 {
                    break;
                }
            }
            let dp = legendre(n, x).1;
            nodes[i] = -x;
            weights[i] = 2.0 / ((1.0 - x * x) * dp * dp);
        }
        Quadrature { nodes, weights }
    }

    /// The mean of `f` over the unit square (the product rule, each node mapped from
    /// [−1, 1] to [0, 1], each weight halved), points in single precision as Mitsuba's,
    /// `f` taking 16 of a row's points at a time (the rules used have 32 to 128 nodes).
    fn integrate(&self, mut f: impl FnMut([f32x16; 2]) -> f32x16) -> f64 {
        debug_assert!(self.nodes.len().is_multiple_of(LANES));
        let points: Vec<f32> = self.nodes.iter().map(|x| (x * 0.5 + 0.5) as f32).collect();
        let mut sum = 0.0;
        for (&y, wy) in points.iter().zip(&self.weights) {
            for (xs, wxs) in points.chunks_exact(LANES).zip(self.weights.chunks_exact(LANES)) {
                let xs: [f32; LANES] = std::array::from_fn(|k| xs[k]);
                let values = f([f32x16::from(xs), f32x16::splat(y)]).to_array();
                for (v, wx) in values.iter().zip(wxs) {
                    sum += f64::from(*v) * wx * wy * 0.25;
                }
            }
        }
        sum
    }
}

/// P_n(x) and its derivative, by the three-term recurrence.
fn legendre(n: usize, x: f64) -> (f64, f64) {
    let (mut p0, mut p1) = (1.0, x);
    for k in 2..=n {
        let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
        (p0, p1) = (p1, p2);
    }
    (p1, n as f64 * (x * p1 - p0) / (x * x - 1.0))
}

mod lanes;
#[cfg(test)]
mod tests;

pub use lanes::SampleLanes;
