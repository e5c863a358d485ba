//! The rough conductor 16 points at a time: [`rough_conductor_eval`],
//! [`rough_conductor_pdf`] and the scatter stage's sample on lanes, for one material. The
//! formulas are the scalar ones, operation for operation, on [`Microfacet::eval_lanes`]
//! and [`Microfacet::sample_visible_lanes`] (whose polynomials differ from libm's in the
//! last places; tested).

use glam::Vec3;
use wide::f32x16;

use super::Microfacet;
#[cfg(doc)]
use super::{fresnel_conductor, rough_conductor_eval, rough_conductor_pdf};
use crate::simd::V3;

type F = f32x16;

/// [`fresnel_conductor`] on lanes (`cos_i` in [0, 1]).
pub fn fresnel_conductor_lanes(cos_i: F, eta: Vec3, k: Vec3) -> V3<F> {
    let one = |eta: f32, k: f32| {
        if eta == 0.0 && k == 0.0 {
            return F::splat(1.0);
        }
        let cos2 = cos_i * cos_i;
        let sin2 = F::splat(1.0) - cos2;
        let sin4 = sin2 * sin2;
        let temp1 = F::splat(eta * eta - k * k) - sin2;
        let a2pb2 = (temp1 * temp1 + F::splat(4.0 * k * k * eta * eta)).max(F::ZERO).sqrt();
        let a = (F::splat(0.5) * (a2pb2 + temp1)).max(F::ZERO).sqrt();
        let term1 = a2pb2 + cos2;
        let term2 = F::splat(2.0) * cos_i * a;
        let rs = (term1 - term2) / (term1 + term2);
        let term3 = a2pb2 * cos2 + sin4;
        let term4 = term2 * sin2;
        let rp = rs * (term3 - term4) / (term3 + term4);
        F::splat(0.5) * (rs + rp)
    };
    V3 { x: one(eta.x, k.x), y: one(eta.y, k.y), z: one(eta.z, k.z) }
}

/// A rough conductor's lobe: its roughness and complex index η + i k.
#[derive(Clone, Copy, Debug)]
pub struct RoughConductor {
    /// The roughness.
    pub mf: Microfacet,
    /// Real part of the index, per channel.
    pub eta: Vec3,
    /// Imaginary part, per channel.
    pub k: Vec3,
}

impl RoughConductor {
    /// [`rough_conductor_eval`] and [`rough_conductor_pdf`] of each lane's directions.
    pub fn eval_pdf_lanes(&self, wi: V3<F>, wo: V3<F>) -> (V3<F>, F) {
        let mf = &self.mf;
        let above = wi.z.simd_gt(F::ZERO) & wo.z.simd_gt(F::ZERO);
        let h = (wi + wo).normalize();
        let d = mf.eval_lanes(h);
        let g1_i = mf.smith_g1_lanes(wi, h);
        let four_cos = F::splat(4.0) * wi.z;
        let value = d * (g1_i * mf.smith_g1_lanes(wo, h)) / four_cos;
        let f = fresnel_conductor_lanes(wi.dot(h), self.eta, self.k).scale(value);
        let f_live = above & d.simd_ne(F::ZERO);
        let zero = V3 { x: F::ZERO, y: F::ZERO, z: F::ZERO };
        let visible = above & wi.dot(h).simd_gt(F::ZERO) & wo.dot(h).simd_gt(F::ZERO);
        (V3::select(f_live, f, zero), visible.select(d * g1_i / four_cos, F::ZERO))
    }

    /// The scatter stage's sample for each lane's `wi` (wi.z > 0) and square sample `u`:
    /// the reflection about a visible normal, its weight F·G1, and whether it is above
    /// the surface.
    pub fn sample_lanes(&self, wi: V3<F>, u: [F; 2]) -> (V3<F>, V3<F>, F) {
        let m = self.mf.sample_visible_lanes(wi, u);
        // As the stage's reflect(−wi, m): d − 2 (d·m) m.
        let d = -wi;
        let wo = d - m.scale(F::splat(2.0) * d.dot(m));
        let cos = wi.dot(m).max(F::ZERO).min(F::splat(1.0));
        let weight = fresnel_conductor_lanes(cos, self.eta, self.k).scale(self.mf.smith_g1_lanes(wo, m));
        (wo, weight, wo.z.simd_gt(F::ZERO))
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::Pcg32;
    use super::super::{fresnel_conductor, rough_conductor_eval, rough_conductor_pdf, Distribution};
    use super::*;
    use crate::simd::LANES;

    fn lane(v: &V3<F>, k: usize) -> Vec3 {
        Vec3::new(v.x.to_array()[k], v.y.to_array()[k], v.z.to_array()[k])
    }

    fn sphere(rng: &mut Pcg32) -> Vec3 {
        let u = rng.next_vec2();
        let z = 1.0 - 2.0 * u.y;
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = std::f32::consts::TAU * u.x;
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }

    #[test]
    fn lanes_agree_with_the_scalar_code() {
        let mut rng = Pcg32::new(21, 8);
        // Gold, and Mitsuba's "none" in one channel.
        let (eta, k) = (Vec3::new(0.0, 0.42, 1.37), Vec3::new(0.0, 2.35, 1.77));
        for distribution in [Distribution::Beckmann, Distribution::Ggx] {
            for alpha in [0.01, 0.2, 0.7] {
                let c = RoughConductor { mf: Microfacet { distribution, alpha_u: alpha, alpha_v: alpha }, eta, k };
                for _ in 0..32 {
                    let wis: [Vec3; LANES] = std::array::from_fn(|_| sphere(&mut rng));
                    let wos: [Vec3; LANES] = std::array::from_fn(|_| sphere(&mut rng));
                    let us: [glam::Vec2; LANES] = std::array::from_fn(|_| rng.next_vec2());
                    let (wi, wo) = (V3::from_fn(|j| wis[j]), V3::from_fn(|j| wos[j]));
                    let (f, pdf) = c.eval_pdf_lanes(wi, wo);
                    let up = V3::from_fn(|j| Vec3::new(wis[j].x, wis[j].y, wis[j].z.abs().max(1e-3)).normalize());
                    let u = [F::from(us.map(|u| u.x)), F::from(us.map(|u| u.y))];
                    let (so, sw, above) = c.sample_lanes(up, u);
                    for j in 0..LANES {
                        let fs = rough_conductor_eval(&c.mf, eta, k, wis[j], wos[j]);
                        let tol = 1e-4 * fs.max_element().max(1.0);
                        assert!((fs - lane(&f, j)).abs().max_element() <= tol, "f {fs} vs {}", lane(&f, j));
                        let ps = rough_conductor_pdf(&c.mf, wis[j], wos[j]);
                        assert!((ps - pdf.to_array()[j]).abs() <= 1e-4 * ps.max(1.0), "pdf {ps}");
                        let wi = lane(&up, j);
                        let m = c.mf.sample(wi, us[j]);
                        let wo = -wi - m * (2.0 * (-wi).dot(m));
                        assert!((wo - lane(&so, j)).abs().max_element() < 1e-4, "wo {wo} vs {}", lane(&so, j));
                        assert_eq!(wo.z > 0.0, above.to_array()[j] != 0.0, "side of {wo}");
                        let w = fresnel_conductor(wi.dot(m).clamp(0.0, 1.0), eta, k) * c.mf.smith_g1(wo, m);
                        assert!((w - lane(&sw, j)).abs().max_element() < 1e-3, "weight {w} vs {}", lane(&sw, j));
                    }
                }
            }
        }
    }
}
