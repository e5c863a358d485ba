//! The rough conductor and the rough dielectric 16 points at a time:
//! [`rough_conductor_eval`], [`rough_conductor_pdf`], [`rough_dielectric_eval`],
//! [`rough_dielectric_pdf`], [`rough_dielectric_split`] and the scatter stage's conductor
//! sample on lanes, for one material. The
//! formulas are the scalar ones, operation for operation, on [`Microfacet::eval_lanes`]
//! and [`Microfacet::sample_visible_lanes`] (whose polynomials differ from libm's in the
//! last places; tested).

use glam::Vec3;
use wide::f32x16;

use super::lanes::fresnel_dielectric_lanes;
use super::Microfacet;
#[cfg(doc)]
use super::{
    fresnel_conductor, rough_conductor_eval, rough_conductor_pdf, rough_dielectric_eval, rough_dielectric_pdf,
    rough_dielectric_split,
};
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

/// A rough dielectric's lobe: its roughness and relative index (inside over outside; +z
/// points outside).
#[derive(Clone, Copy, Debug)]
pub struct RoughDielectric {
    /// The roughness.
    pub mf: Microfacet,
    /// n_inside / n_outside.
    pub eta: f32,
}

/// [`rough_dielectric_split`] of 16 lanes: each branch's direction, weight and whether
/// the lane has it, and F at the sampled normal (0 where nothing was sampled).
#[derive(Clone, Copy, Debug)]
pub struct SplitLanes {
    /// Reflection: direction, weight F·G1, live lanes (all ones).
    pub reflect: (V3<F>, F, F),
    /// Refraction: direction, weight (1 − F)·G1, live lanes.
    pub refract: (V3<F>, F, F),
    /// F(wi·m).
    pub f: F,
}

impl RoughDielectric {
    /// [`rough_dielectric_eval`] and [`rough_dielectric_pdf`] of each lane's directions.
    pub fn eval_pdf_lanes(&self, wi: V3<F>, wo: V3<F>) -> (F, F) {
        let (mf, one) = (&self.mf, F::splat(1.0));
        let reflect = (wi.z * wo.z).simd_gt(F::ZERO);
        let eta_r = wi.z.simd_gt(F::ZERO).select(F::splat(self.eta), F::splat(1.0 / self.eta));
        // The generalised half vector, turned to +z (Mitsuba's mulsign flips -0.0 too);
        // undefined where glam's try_normalize fails.
        let half = wi + wo.scale(reflect.select(one, eta_r));
        let rcp = one / half.dot(half).sqrt();
        let defined = rcp.is_finite() & rcp.simd_gt(F::ZERO) & wi.z.simd_ne(F::ZERO);
        let m = half.scale(rcp);
        let m = V3::select(m.z.is_sign_negative(), -m, m);
        let d = mf.eval_lanes(m);
        let (dim, dom) = (wi.dot(m), wo.dot(m));
        let f = fresnel_dielectric_lanes(dim, self.eta).0;
        let g = mf.smith_g1_lanes(wi, m) * mf.smith_g1_lanes(wo, m);
        let den = dim + eta_r * dom;
        let value = reflect.select(
            f * d * g / (F::splat(4.0) * wi.z.abs()),
            ((one - f) * d * g * eta_r * eta_r * dim * dom / (wi.z * den * den)).abs(),
        );
        let sides = (dim * wi.z).simd_gt(F::ZERO) & (dom * wo.z).simd_gt(F::ZERO);
        let dwh_dwo = reflect.select(one / (F::splat(4.0) * dom), eta_r * eta_r * dom / (den * den));
        let wi_up = V3::select(wi.z.simd_gt(F::ZERO), wi, -wi);
        let visible = mf.pdf_lanes(wi_up, m, d);
        let pdf = visible * reflect.select(f, one - f) * dwh_dwo.abs();
        (defined.select(value, F::ZERO), (defined & sides).select(pdf, F::ZERO))
    }

    /// [`rough_dielectric_split`] for each lane's `wi` and square sample `u`.
    pub fn split_lanes(&self, wi: V3<F>, u: [F; 2]) -> SplitLanes {
        let (mf, one) = (&self.mf, F::splat(1.0));
        let wi_up = V3::select(wi.z.simd_gt(F::ZERO), wi, -wi);
        let m = mf.sample_visible_lanes(wi_up, u);
        let density = mf.pdf_lanes(wi_up, m, mf.eval_lanes(m));
        let sampled = wi.z.simd_ne(F::ZERO) & density.simd_ne(F::ZERO);
        let (f, cos_t, eta_ti) = fresnel_dielectric_lanes(wi.dot(m), self.eta);
        let wo_r = m.scale(F::splat(2.0) * wi.dot(m)) - wi;
        let w_r = f * mf.smith_g1_lanes(wo_r, m);
        let wo_t = m.scale(wi.dot(m) * eta_ti + cos_t) - wi.scale(eta_ti);
        let w_t = (one - f) * mf.smith_g1_lanes(wo_t, m);
        let live_r = sampled & w_r.simd_gt(F::ZERO) & (wo_r.z * wi.z).simd_gt(F::ZERO);
        let live_t = sampled & w_t.simd_gt(F::ZERO) & (wo_t.z * wi.z).simd_lt(F::ZERO);
        SplitLanes { reflect: (wo_r, w_r, live_r), refract: (wo_t, w_t, live_t), f: sampled.select(f, F::ZERO) }
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::Pcg32;
    use super::super::{
        fresnel_conductor, rough_conductor_eval, rough_conductor_pdf, rough_dielectric_eval, rough_dielectric_pdf,
        rough_dielectric_split, Distribution,
    };
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

    #[test]
    fn dielectric_lanes_agree_with_the_scalar_code() {
        let mut rng = Pcg32::new(4, 40);
        for distribution in [Distribution::Beckmann, Distribution::Ggx] {
            for (alpha, eta) in [(0.02, 1.5), (0.3, 1.33), (0.6, 1.0 / 1.5)] {
                let g = RoughDielectric { mf: Microfacet { distribution, alpha_u: alpha, alpha_v: alpha }, eta };
                for _ in 0..32 {
                    let wis: [Vec3; LANES] = std::array::from_fn(|_| sphere(&mut rng));
                    let wos: [Vec3; LANES] = std::array::from_fn(|_| sphere(&mut rng));
                    let us: [glam::Vec2; LANES] = std::array::from_fn(|_| rng.next_vec2());
                    let (wi, wo) = (V3::from_fn(|j| wis[j]), V3::from_fn(|j| wos[j]));
                    let (f, pdf) = g.eval_pdf_lanes(wi, wo);
                    let split = g.split_lanes(wi, [F::from(us.map(|u| u.x)), F::from(us.map(|u| u.y))]);
                    for j in 0..LANES {
                        let (fs, ps) = (
                            rough_dielectric_eval(&g.mf, eta, wis[j], wos[j]),
                            rough_dielectric_pdf(&g.mf, eta, wis[j], wos[j]),
                        );
                        assert!((fs - f.to_array()[j]).abs() <= 1e-4 * fs.max(1.0), "f {fs} vs {}", f.to_array()[j]);
                        assert!(
                            (ps - pdf.to_array()[j]).abs() <= 1e-4 * ps.max(1.0),
                            "pdf {ps} vs {}",
                            pdf.to_array()[j]
                        );
                        let s = rough_dielectric_split(&g.mf, eta, wis[j], us[j]);
                        assert!((s.f - split.f.to_array()[j]).abs() < 1e-4, "F {} vs {}", s.f, split.f.to_array()[j]);
                        for (scalar, (dir, w, live)) in [(s.reflect, split.reflect), (s.refract, split.refract)] {
                            // A lane may fall on the other side of a branch's bound only
                            // where the scalar weight is at it.
                            match (scalar, live.to_array()[j] != 0.0) {
                                (Some((d, ws)), true) => {
                                    assert!(
                                        (d - lane(&dir, j)).abs().max_element() < 1e-3,
                                        "wo {d} vs {}",
                                        lane(&dir, j)
                                    );
                                    assert!((ws - w.to_array()[j]).abs() < 1e-3, "weight {ws} vs {}", w.to_array()[j]);
                                }
                                (None, false) => {}
                                (Some((d, ws)), false) => assert!(ws < 1e-4 || d.z.abs() < 1e-4, "lost {d} {ws}"),
                                (None, true) => assert!(w.to_array()[j] < 1e-4, "gained {}", w.to_array()[j]),
                            }
                        }
                    }
                }
            }
        }
    }
}
