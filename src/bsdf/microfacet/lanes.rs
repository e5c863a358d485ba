//! The normal distribution, the visible-normal sampler, Smith shadowing and dielectric
//! Fresnel 16 samples at a time: what the rough plastic's tables integrate, 32² to 64²
//! visible normals per direction (`bsdf/plastic.rs`), and what the scatter stage
//! evaluates for 16 hits at once. The formulas are the scalar
//! ones beside them, operation for operation; only the logarithms, exponentials and
//! sines are `wide`'s polynomials rather than libm's, so results agree with the scalar
//! code to a few units in the last place (tested).

use glam::Vec3;
use std::f32::consts::PI;
use wide::f32x16;

use super::{Distribution, Microfacet, ERFINV_CENTRAL, ERFINV_TAIL, ERF_LARGE, ERF_SMALL, FRAC_1_SQRT_PI};
use crate::simd::{Real, V3};

type F = f32x16;

impl Microfacet {
    /// [`Microfacet::sample`] for one `wi` (wi.z > 0) and 16 square samples `u`.
    pub fn sample_lanes(&self, wi: Vec3, u: [F; 2]) -> V3<F> {
        self.sample_visible_lanes(V3::splat(wi), u)
    }

    /// [`Microfacet::sample`] on lanes: a visible normal for each lane's `wi` (wi.z > 0)
    /// and square sample `u`.
    pub fn sample_visible_lanes(&self, wi: V3<F>, u: [F; 2]) -> V3<F> {
        let (au, av) = self.alphas();
        let (au, av) = (F::splat(au), F::splat(av));
        let wi_p = V3 { x: au * wi.x, y: av * wi.y, z: wi.z }.normalize();
        let (sin_phi, cos_phi) = sincos_phi_lanes(wi_p);
        let (sx, sy) = self.visible_11_lanes(wi_p.z, u);
        let x = (cos_phi * sx - sin_phi * sy) * au;
        let y = (sin_phi * sx + cos_phi * sy) * av;
        V3 { x: -x, y: -y, z: F::splat(1.0) }.normalize()
    }

    /// [`Microfacet::eval`] on lanes: D(m), 0 where D·cos θ underflows.
    pub fn eval_lanes(&self, m: V3<F>) -> F {
        let (au, av) = self.alphas();
        let cos2 = m.z * m.z;
        let (x, y) = (m.x / F::splat(au), m.y / F::splat(av));
        let scale = F::splat(PI * au * av);
        let d = match self.distribution {
            Distribution::Beckmann => (-(x * x + y * y) / cos2).exp() / (scale * cos2 * cos2),
            Distribution::Ggx => {
                let t = x * x + y * y + cos2;
                F::splat(1.0) / (scale * t * t)
            }
        };
        (d * m.z).simd_gt(F::splat(1e-20)).select(d, F::ZERO)
    }

    /// [`Microfacet::pdf`] on lanes, given D(m) = `d` ([`Microfacet::eval_lanes`]).
    pub fn pdf_lanes(&self, wi: V3<F>, m: V3<F>, d: F) -> F {
        d * self.smith_g1_lanes(wi, m) * wi.dot(m).abs() / wi.z
    }

    /// [`Microfacet::smith_g1`] on lanes.
    pub fn smith_g1_lanes(&self, v: V3<F>, m: V3<F>) -> F {
        let (au, av) = self.alphas();
        let (ax, ay) = (F::splat(au) * v.x, F::splat(av) * v.y);
        let xy_alpha2 = ax * ax + ay * ay;
        let tan_alpha2 = xy_alpha2 / (v.z * v.z);
        let one = F::splat(1.0);
        let g = match self.distribution {
            Distribution::Beckmann => {
                let a = one / tan_alpha2.sqrt();
                let a2 = a * a;
                let r =
                    (F::splat(3.535) * a + F::splat(2.181) * a2) / (one + F::splat(2.276) * a + F::splat(2.577) * a2);
                a.simd_ge(F::splat(1.6)).select(one, r)
            }
            Distribution::Ggx => F::splat(2.0) / (one + (one + tan_alpha2).sqrt()),
        };
        let g = xy_alpha2.simd_eq(F::ZERO).select(one, g);
        (v.dot(m) * v.z).simd_le(F::ZERO).select(F::ZERO, g)
    }

    /// The α = 1 slopes of [`Microfacet::sample`]'s `sample_visible_11` on lanes, for
    /// each lane's incident cosine.
    fn visible_11_lanes(&self, cos_i: F, u: [F; 2]) -> (F, F) {
        let one = F::splat(1.0);
        let sin_i = (one - cos_i * cos_i).max(F::ZERO).sqrt();
        match self.distribution {
            Distribution::Beckmann => {
                let tan_i = sin_i / cos_i;
                let cot_i = one / tan_i;
                let maxval = erf_lanes(cot_i);
                let (lo, hi) = (F::splat(1e-6), F::splat(1.0 - 1e-6));
                let (ux, uy) = (u[0].max(lo).min(hi), u[1].max(lo).min(hi));
                let mut x = maxval - (maxval + one) * erf_lanes((-ux.ln()).sqrt());
                // At normal incidence tan θ = 0 and cot θ = ∞: the term is 0 (0·e^−∞).
                let tail = tan_i.simd_eq(F::ZERO).select(F::ZERO, tan_i * (-cot_i * cot_i).exp());
                let c = F::splat(FRAC_1_SQRT_PI);
                let target = ux * (one + maxval + c * tail);
                for _ in 0..3 {
                    let slope = erfinv_lanes(x);
                    let value = one + x + c * tan_i * (-slope * slope).exp() - target;
                    let derivative = one - slope * tan_i;
                    x -= value / derivative;
                }
                (erfinv_lanes(x), erfinv_lanes(F::splat(2.0) * uy - one))
            }
            Distribution::Ggx => {
                let (px, py) = disk_concentric_lanes(u);
                let a = (one - px * px).max(F::ZERO).sqrt();
                let py = a + (py - a) * (F::splat(0.5) * (one + cos_i));
                let z = (one - (px * px + py * py)).max(F::ZERO).sqrt();
                let norm = one / (sin_i * py + cos_i * z);
                ((cos_i * py - sin_i * z) * norm, px * norm)
            }
        }
    }
}

/// [`sincos_phi`](super::sincos_phi) on lanes.
fn sincos_phi_lanes(v: V3<F>) -> (F, F) {
    let sin2 = v.x * v.x + v.y * v.y;
    let inv = F::splat(1.0) / sin2.sqrt();
    let (lo, hi) = (F::splat(-1.0), F::splat(1.0));
    let pole = sin2.simd_le(F::splat(2.0 * f32::EPSILON));
    (pole.select(F::ZERO, (v.y * inv).max(lo).min(hi)), pole.select(hi, (v.x * inv).max(lo).min(hi)))
}

/// The orthonormal tangents of unit normals `n` on lanes (Duff et al.'s frame, as
/// [`tangents`](super::tangents)).
#[inline(always)]
pub fn tangents_lanes(n: V3<F>) -> (V3<F>, V3<F>) {
    let sign = F::if_negative(n.z, F::splat(-1.0), F::ONE);
    let a = F::splat(-1.0) / (sign + n.z);
    let b = n.x * n.y * a;
    let s = V3 { x: n.x * n.x * a * sign + F::ONE, y: b * sign, z: -n.x * sign };
    let t = V3 { x: b, y: n.y * n.y * a + sign, z: -n.y };
    (s, t)
}

/// [`fresnel_dielectric`](super::fresnel_dielectric) on lanes, for one index `eta`.
pub(crate) fn fresnel_dielectric_lanes(cos_i: F, eta: f32) -> (F, F, F) {
    let outside = cos_i.simd_ge(F::ZERO);
    let (eta_it, eta_ti) =
        (outside.select(F::splat(eta), F::splat(1.0 / eta)), outside.select(F::splat(1.0 / eta), F::splat(eta)));
    let one = F::splat(1.0);
    let cos_t2 = one - (one - cos_i * cos_i) * eta_ti * eta_ti;
    let ci = cos_i.abs();
    let ct = cos_t2.max(F::ZERO).sqrt();
    let a_s = (ci - eta_it * ct) / (ci + eta_it * ct);
    let a_p = (ct - eta_it * ci) / (ct + eta_it * ci);
    let f = ci.simd_eq(F::ZERO).select(one, F::splat(0.5) * (a_s * a_s + a_p * a_p));
    let f = if eta == 1.0 { F::ZERO } else { f };
    (f, outside.select(-ct, ct), eta_ti)
}

/// [`poly`](super::poly) on lanes.
fn poly_lanes(x: F, c: &[f32]) -> F {
    c.iter().rev().fold(F::ZERO, |acc, &ci| acc * x + F::splat(ci))
}

/// [`erf`](super::erf) on lanes: both fits, each lane taking its own.
fn erf_lanes(x: F) -> F {
    let xa = x.abs();
    let small = x * poly_lanes(x * x, &ERF_SMALL);
    let xb = F::splat(1.0) - (poly_lanes(xa, &ERF_LARGE) * xa).exp2();
    let xb = xb.is_finite().select(xb, F::splat(1.0));
    xa.simd_lt(F::splat(1.0)).select(small, x.is_sign_negative().select(-xb, xb))
}

/// [`erfinv`](super::erfinv) on lanes.
fn erfinv_lanes(x: F) -> F {
    let one = F::splat(1.0);
    let w = -((one - x) * (one + x)).ln();
    let central = poly_lanes(w - F::splat(2.5), &ERFINV_CENTRAL);
    let tail = poly_lanes(w.sqrt() - F::splat(3.0), &ERFINV_TAIL);
    w.simd_lt(F::splat(5.0)).select(central, tail) * x
}

/// The concentric square-to-disk map of `square_to_uniform_disk_concentric` on lanes.
fn disk_concentric_lanes(u: [F; 2]) -> (F, F) {
    let one = F::splat(1.0);
    let (x, y) = (F::splat(2.0) * u[0] - one, F::splat(2.0) * u[1] - one);
    let q13 = x.abs().simd_lt(y.abs());
    let (r, rp) = (q13.select(y, x), q13.select(x, y));
    let phi = F::splat(0.25 * PI) * rp / r;
    let phi = q13.select(F::splat(0.5 * PI) - phi, phi);
    let (s, c) = phi.sin_cos();
    let centre = x.simd_eq(F::ZERO) & y.simd_eq(F::ZERO);
    (centre.select(F::ZERO, r * c), centre.select(F::ZERO, r * s))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::microfacet::tests::Pcg32;

    /// 16 random square samples, the same as scalars.
    fn squares(rng: &mut Pcg32) -> ([F; 2], [glam::Vec2; 16]) {
        let u: [glam::Vec2; 16] = std::array::from_fn(|_| rng.next_vec2());
        ([F::from(u.map(|v| v.x)), F::from(u.map(|v| v.y))], u)
    }

    fn lane(v: &V3<F>, k: usize) -> Vec3 {
        Vec3::new(v.x.to_array()[k], v.y.to_array()[k], v.z.to_array()[k])
    }

    #[test]
    fn lanes_agree_with_the_scalar_code() {
        let mut rng = Pcg32::new(7, 11);
        for distribution in [Distribution::Beckmann, Distribution::Ggx] {
            for (au, av) in [(0.05, 0.05), (0.3, 0.3), (0.8, 0.2), (1.5, 1.5)] {
                let mf = Microfacet { distribution, alpha_u: au, alpha_v: av };
                for cos in [1e-6f32, 0.05, 0.5, 0.9, 1.0] {
                    let wi = Vec3::new((1.0 - cos * cos).sqrt() * 0.6, (1.0 - cos * cos).sqrt() * 0.8, cos);
                    for _ in 0..8 {
                        let (u, us) = squares(&mut rng);
                        let m = mf.sample_lanes(wi, u);
                        let wo = V3::splat(wi).scale(F::splat(-1.0)) + m.scale(F::splat(2.0) * V3::splat(wi).dot(m));
                        let g = mf.smith_g1_lanes(wo, m).to_array();
                        let (f, ct, _) = fresnel_dielectric_lanes(V3::splat(wi).dot(m), 1.5);
                        let d = mf.eval_lanes(m).to_array();
                        for (k, &u) in us.iter().enumerate() {
                            let (ms, ml) = (mf.sample(wi, u), lane(&m, k));
                            let ds = mf.eval(ml);
                            assert!((ds - d[k]).abs() <= 1e-5 * ds.max(1.0), "{mf:?} D({ml}): {ds} vs {}", d[k]);
                            assert!((ms - ml).abs().max_element() < 2e-5, "{mf:?} wi {wi} u {u}: {ms} vs {ml}");
                            let wos = super::super::reflect(wi, ms);
                            let gs = mf.smith_g1(wos, ms);
                            assert!((gs - g[k]).abs() < 1e-4, "{mf:?} wi {wi} u {u}: G1 {gs} vs {}", g[k]);
                            let (fs, cts, _) = super::super::fresnel_dielectric(wi.dot(ml), 1.5);
                            assert!((fs - f.to_array()[k]).abs() < 1e-6 && (cts - ct.to_array()[k]).abs() < 1e-6);
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn each_lane_samples_for_its_own_direction() {
        let mut rng = Pcg32::new(3, 5);
        for distribution in [Distribution::Beckmann, Distribution::Ggx] {
            for (au, av) in [(0.02, 0.02), (0.3, 0.3), (0.8, 0.2)] {
                let mf = Microfacet { distribution, alpha_u: au, alpha_v: av };
                for _ in 0..8 {
                    let (u, us) = squares(&mut rng);
                    // Cosines from grazing to exactly normal incidence, one per lane.
                    let wis: [Vec3; 16] = std::array::from_fn(|k| {
                        let cos = if k == 15 { 1.0 } else { (k as f32 / 15.0).max(1e-6) };
                        let phi = rng.next_vec2().x * std::f32::consts::TAU;
                        let sin = (1.0 - cos * cos).sqrt();
                        Vec3::new(sin * phi.cos(), sin * phi.sin(), cos)
                    });
                    let wi =
                        V3 { x: F::from(wis.map(|v| v.x)), y: F::from(wis.map(|v| v.y)), z: F::from(wis.map(|v| v.z)) };
                    let m = mf.sample_visible_lanes(wi, u);
                    for k in 0..16 {
                        let (ms, ml) = (mf.sample(wis[k], us[k]), lane(&m, k));
                        assert!((ms - ml).abs().max_element() < 2e-5, "{mf:?} wi {} u {}: {ms} vs {ml}", wis[k], us[k]);
                    }
                }
            }
        }
    }

    #[test]
    fn special_functions_agree_with_the_scalar_ones() {
        for i in 0..=4000 {
            let x = -6.0 + 12.0 * i as f32 / 4000.0;
            let e = erf_lanes(F::splat(x)).to_array()[0];
            assert!((e - super::super::erf(x)).abs() <= 4.0 * f32::EPSILON * e.abs().max(1e-3), "erf({x})");
            let y = (x / 6.0).clamp(-0.999_999, 0.999_999);
            let (a, b) = (erfinv_lanes(F::splat(y)).to_array()[0], super::super::erfinv(y));
            assert!((a - b).abs() <= 1e-5 * b.abs().max(1e-3), "erfinv({y}): {a} vs {b}");
        }
    }
}
