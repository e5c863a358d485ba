//! The plastic 16 shading points at a time: [`Plastic::eval_pdf`] and
//! [`Plastic::sample`] on lanes, for points of one material whose base reflectance may
//! differ per lane (a texture). The formulas are the scalar ones, operation for
//! operation; only the exponential of Beckmann's D and the functions of the
//! visible-normal sampler are `wide`'s polynomials ([`Microfacet::sample_visible_lanes`]),
//! so results agree with the scalar code to a few units in the last place (tested).

use std::f32::consts::FRAC_1_PI;
use wide::f32x16;

use super::{lerp_table, Plastic};
use crate::bsdf::microfacet::fresnel_dielectric_lanes;
use crate::sampling::concentric_disk_lanes;
use crate::simd::V3;

type F = f32x16;

/// Sampled directions of 16 points.
#[derive(Clone, Copy, Debug)]
pub struct SampleLanes {
    /// The directions, local, above the surface.
    pub wo: V3<F>,
    /// f·cos θo / density.
    pub weight: V3<F>,
    /// The densities over solid angle; 0 for the smooth coating's mirror (a delta).
    pub pdf: F,
    /// Bit k set where lane k has a sample ([`Plastic::sample`] is `Some`).
    pub valid: u32,
}

impl Plastic<'_> {
    /// [`Plastic::transmittance`] on lanes.
    fn transmittance_lanes(&self, cos: F) -> F {
        match self.roughness {
            None => F::splat(1.0) - fresnel_dielectric_lanes(cos, self.eta).0,
            Some(_) => F::from(cos.to_array().map(|c| lerp_table(self.table, c))),
        }
    }

    /// [`Plastic::prob_specular`] on lanes.
    fn prob_specular_lanes(&self, cos_i: F) -> F {
        let t = self.transmittance_lanes(cos_i);
        let s = (F::splat(1.0) - t) * F::splat(self.specular_weight);
        let d = t * F::splat(1.0 - self.specular_weight);
        s / (s + d)
    }

    /// [`Plastic::base`] with each lane's base reflectance `diffuse`.
    fn base_lanes(&self, diffuse: V3<F>) -> V3<F> {
        let eta2 = F::splat(self.eta * self.eta);
        let one = F::splat(1.0);
        let over = |c: F| {
            let denominator = match self.nonlinear {
                true => one - c * F::splat(self.internal),
                false => F::splat(1.0 - self.internal),
            };
            c / denominator / eta2
        };
        V3 { x: over(diffuse.x), y: over(diffuse.y), z: over(diffuse.z) }
    }

    /// [`Plastic::eval_pdf`] on lanes, each lane with its base reflectance `diffuse`
    /// (which replaces `self.diffuse`).
    pub fn eval_pdf_lanes(&self, diffuse: V3<F>, wi: V3<F>, wo: V3<F>) -> (V3<F>, F) {
        let above = wi.z.simd_gt(F::ZERO) & wo.z.simd_gt(F::ZERO);
        let (t_i, t_o) = (self.transmittance_lanes(wi.z), self.transmittance_lanes(wo.z));
        let diffuse = self.base_lanes(diffuse).scale(F::splat(FRAC_1_PI) * wo.z * t_i * t_o);
        let p_spec = self.prob_specular_lanes(wi.z);
        let pdf_diffuse = (F::splat(1.0) - p_spec) * wo.z * F::splat(FRAC_1_PI);
        let (f, pdf) = match self.roughness {
            None => (diffuse, pdf_diffuse),
            Some(mf) => {
                let h = (wo + wi).normalize();
                let d = mf.eval_lanes(h);
                let fr = fresnel_dielectric_lanes(wi.dot(h), self.eta).0;
                let g1_i = mf.smith_g1_lanes(wi, h);
                let four_cos = F::splat(4.0) * wi.z;
                let s = fr * d * g1_i * mf.smith_g1_lanes(wo, h) / four_cos;
                let specular = V3::splat(self.specular).scale(s);
                (specular + diffuse, p_spec * d * g1_i / four_cos + pdf_diffuse)
            }
        };
        let zero = V3 { x: F::ZERO, y: F::ZERO, z: F::ZERO };
        (V3::select(above, f, zero), above.select(pdf, F::ZERO))
    }

    /// [`Plastic::sample`] on lanes: for each lane's `wi` the specular lobe where `u1` is
    /// below its probability, else the cosine-weighted base, from `u2`.
    pub fn sample_lanes(&self, diffuse: V3<F>, wi: V3<F>, u1: F, u2: [F; 2]) -> SampleLanes {
        let one = F::splat(1.0);
        let p_spec = self.prob_specular_lanes(wi.z);
        let specular = u1.simd_lt(p_spec);
        let (dx, dy) = concentric_disk_lanes(u2[0], u2[1]);
        let cosine = V3 { x: dx, y: dy, z: (one - (dx * dx + dy * dy)).max(F::ZERO).sqrt() };
        let above = wi.z.simd_gt(F::ZERO);
        let Some(mf) = self.roughness else {
            // The smooth coating: Mitsuba's weights, term for term.
            let f_i = one - self.transmittance_lanes(wi.z);
            let mirror = V3 { x: -wi.x, y: -wi.y, z: wi.z };
            let s = f_i / p_spec;
            let mirror_weight = V3::splat(self.specular).scale(s);
            let p_diffuse = one - p_spec;
            let f_o = one - self.transmittance_lanes(cosine.z);
            let base_weight = self.base_lanes(diffuse).scale((one - f_i) * (one - f_o) / p_diffuse);
            let pdf = p_diffuse * cosine.z * F::splat(FRAC_1_PI);
            let valid = above & (specular | pdf.simd_gt(F::ZERO));
            return SampleLanes {
                wo: V3::select(specular, mirror, cosine),
                weight: V3::select(specular, mirror_weight, base_weight),
                pdf: specular.select(F::ZERO, pdf),
                valid: valid.to_bitmask(),
            };
        };
        let wo = V3::select(specular, reflect_lanes(wi, mf.sample_visible_lanes(wi, u2)), cosine);
        let (f, pdf) = self.eval_pdf_lanes(diffuse, wi, wo);
        let valid = above & pdf.simd_gt(F::ZERO);
        SampleLanes { wo, weight: f.over(pdf), pdf, valid: valid.to_bitmask() }
    }
}

/// [`reflect`](crate::bsdf::microfacet::reflect) on lanes.
fn reflect_lanes(wi: V3<F>, m: V3<F>) -> V3<F> {
    m.scale(F::splat(2.0) * wi.dot(m)) - wi
}
