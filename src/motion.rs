//! Motion blur's transforms: a transform at time 0 and one at time 1, interpolated in
//! between as pbrt's `AnimatedTransform` does (translation, rotation and scale decomposed
//! and interpolated separately: the rotation by quaternion slerp), with a conservative
//! bound of everything a box sweeps over a shutter interval.
//!
//! Everything is computed in f64 from the two matrices; [`Motion::at`] is a pure function
//! of the time, so a ray and the shading of its hit see the same transform, bit for bit.

use glam::{DAffine3, DMat3, DMat4, DQuat, DVec3, Vec3};

/// An affine transform moving from `start` (time 0) to `end` (time 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Motion {
    /// The transform at time 0, returned exactly there.
    start: DAffine3,
    /// The transform at time 1, returned exactly there.
    end: DAffine3,
    /// Translations at 0 and 1.
    t: [DVec3; 2],
    /// Rotations at 0 and 1 (the second on the first's side, so slerp turns the short way).
    r: [DQuat; 2],
    /// Scales (symmetric, the polar decomposition's stretch; negative for a mirror) at 0
    /// and 1.
    s: [DMat3; 2],
    /// The slerp's angle between the rotations and 1 / its sine, as glam's
    /// `DQuat::slerp` computes them on every call; `None` where it lerps instead (the
    /// rotations within a rounding step of each other). [`Motion::at`] runs per ray.
    arc: Option<(f64, f64)>,
}

/// The polar decomposition `m = R · S` of a linear map, R a rotation (the mirror, if
/// any, goes into S, which is then negative definite), by Higham's iteration
/// `R ← (R + R⁻ᵀ) / 2` as pbrt's `Decompose`.
fn polar(m: DMat3) -> Result<(DQuat, DMat3), String> {
    let det = m.determinant();
    if !(det.is_finite() && det.abs() > 1e-30) {
        return Err("the transform is singular or not finite".into());
    }
    let mut r = m;
    for _ in 0..100 {
        let next = (r + r.inverse().transpose()) * 0.5;
        let change = (next - r).to_cols_array().iter().fold(0.0f64, |a, x| a.max(x.abs()));
        r = next;
        if change < 1e-15 * (1.0 + r.to_cols_array().iter().fold(0.0f64, |a, x| a.max(x.abs()))) {
            break;
        }
    }
    if det < 0.0 {
        r = -r;
    }
    let s = r.transpose() * m;
    Ok((DQuat::from_mat3(&r).normalize(), s))
}

impl Motion {
    /// The motion from `start` to `end` (affine: the last rows 0 0 0 1), decomposed; an
    /// error says what is wrong with either.
    pub fn new(start: DMat4, end: DMat4) -> Result<Motion, String> {
        let (s0, s1) = (DAffine3::from_mat4(start), DAffine3::from_mat4(end));
        let (r0, m0) = polar(s0.matrix3).map_err(|e| format!("at time 0: {e}"))?;
        let (mut r1, m1) = polar(s1.matrix3).map_err(|e| format!("at time 1: {e}"))?;
        if r0.dot(r1) < 0.0 {
            r1 = -r1;
        }
        // glam's test and formulas: slerp takes the angle from the dot product, clamped.
        let dot = r0.dot(r1);
        let arc = (dot <= 1.0 - f64::EPSILON).then(|| {
            let theta = dot.clamp(-1.0, 1.0).acos();
            (theta, 1.0 / theta.sin())
        });
        Ok(Motion { start: s0, end: s1, t: [s0.translation, s1.translation], r: [r0, r1], s: [m0, m1], arc })
    }

    /// True when the transform is the same at 0 and 1.
    pub fn is_static(&self) -> bool {
        self.start == self.end
    }

    /// The transform at `time` in [0, 1]: exactly `start` at 0 (and before) and `end` at
    /// 1 (and after); in between, the translations and scales lerped and the rotations
    /// slerped, composed as translation · rotation · scale.
    #[inline]
    pub fn at(&self, time: f32) -> DAffine3 {
        if time <= 0.0 {
            return self.start;
        }
        if time >= 1.0 {
            return self.end;
        }
        let u = time as f64;
        let t = self.t[0].lerp(self.t[1], u);
        let r = self.slerp(u);
        let s = self.s[0] * (1.0 - u) + self.s[1] * u;
        DAffine3::from_mat3_translation(DMat3::from_quat(r) * s, t)
    }

    /// The rotation at `u`: glam's `DQuat::slerp(r₀, r₁, u)` bit for bit (a unit test
    /// checks), with its angle and sine computed once in [`Motion::new`].
    #[inline]
    fn slerp(&self, u: f64) -> DQuat {
        let [r0, r1] = self.r;
        match self.arc {
            Some((theta, inv_sin)) => (r0 * (theta * (1.0 - u)).sin() + r1 * (theta * u).sin()) * inv_sin,
            None => (r0 * (1.0 - u) + r1 * u).normalize(),
        }
    }

    /// The angle (radians) the rotation turns through from time 0 to time 1.
    fn angle(&self) -> f64 {
        2.0 * self.r[0].dot(self.r[1]).abs().min(1.0).acos()
    }

    /// A box holding every point of the box `lo..hi` under the transform at every time of
    /// `shutter` (⊂ [0, 1]), rounded outward to f32. A point p moves at most
    /// `|ΔT| + θ·max(|S₀p|, |S₁p|) + |(S₁ − S₀)p|` per unit time (θ the rotation's angle),
    /// so the box of the corners at 65 evenly spaced times, grown by that speed times half
    /// the spacing, holds their paths; a convex box's points stay inside its corners' hull
    /// under an affine map.
    pub fn bound(&self, lo: Vec3, hi: Vec3, shutter: [f32; 2]) -> (Vec3, Vec3) {
        const STEPS: u32 = 64;
        let (t0, t1) = (shutter[0], shutter[1]);
        let (lo, hi) = (lo.as_dvec3(), hi.as_dvec3());
        let dt = self.t[1] - self.t[0];
        let (theta, ds) = (self.angle(), self.s[1] - self.s[0]);
        let (mut blo, mut bhi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        let mut pad = 0.0f64;
        let moving = t1 > t0 && !self.is_static();
        let steps = if moving { STEPS } else { 0 };
        for k in 0..8 {
            let c = DVec3::new(
                if k & 1 == 0 { lo.x } else { hi.x },
                if k & 2 == 0 { lo.y } else { hi.y },
                if k & 4 == 0 { lo.z } else { hi.z },
            );
            let speed =
                dt.length() + theta * (self.s[0] * c).length().max((self.s[1] * c).length()) + (ds * c).length();
            pad = pad.max(speed * (t1 - t0) as f64 / STEPS as f64 * 0.5);
            for j in 0..=steps {
                let time = if j == steps { t1 } else { t0 + (t1 - t0) * (j as f32 / STEPS as f32) };
                let p = self.at(time).transform_point3(c);
                blo = blo.min(p);
                bhi = bhi.max(p);
            }
        }
        if !moving {
            pad = 0.0;
        }
        // The f64 arithmetic's own error, far below an f32 step, then outward to f32.
        let slack = pad + 1e-12 * blo.abs().max(bhi.abs()).max_element();
        let down = |x: f64| {
            let f = x as f32;
            if f as f64 > x {
                f.next_down()
            } else {
                f
            }
        };
        let up = |x: f64| {
            let f = x as f32;
            if (f as f64) < x {
                f.next_up()
            } else {
                f
            }
        };
        let (a, b) = (blo - DVec3::splat(slack), bhi + DVec3::splat(slack));
        (Vec3::new(down(a.x), down(a.y), down(a.z)), Vec3::new(up(b.x), up(b.y), up(b.z)))
    }

    /// Checks that the transform stays invertible over `shutter`: the determinant of the
    /// interpolated scale, a cubic in time, keeps its sign and stays away from zero
    /// (checked at the interval's ends and at the cubic's turning points inside it).
    /// The error names the time where it fails.
    pub fn check_invertible(&self, shutter: [f32; 2]) -> Result<(), String> {
        let singular = |u: f64| {
            format!("the transform interpolated from `transform` to `transform_end` is singular at time {u:.4} (its scale passes through zero)")
        };
        let det = |u: f64| (self.s[0] * (1.0 - u) + self.s[1] * u).determinant();
        let (d0, d1) = (det(0.0), det(1.0));
        let tiny = 1e-9 * d0.abs().max(d1.abs());
        // The cubic's coefficients from its values at 0, 1/3, 2/3, 1.
        let (a, b, c, d) = (d0, det(1.0 / 3.0), det(2.0 / 3.0), d1);
        let c3 = 4.5 * (-a + 3.0 * b - 3.0 * c + d);
        let c2 = 9.0 * (a - 2.5 * b + 2.0 * c - 0.5 * d);
        let c1 = -5.5 * a + 9.0 * b - 4.5 * c + d;
        // Turning points: roots of 3·c3·u² + 2·c2·u + c1.
        let (qa, qb, qc) = (3.0 * c3, 2.0 * c2, c1);
        let mut times = vec![shutter[1] as f64];
        if qa.abs() > 0.0 {
            let disc = qb * qb - 4.0 * qa * qc;
            if disc >= 0.0 {
                times.push((-qb + disc.sqrt()) / (2.0 * qa));
                times.push((-qb - disc.sqrt()) / (2.0 * qa));
            }
        } else if qb != 0.0 {
            times.push(-qc / qb);
        }
        let (lo, hi) = (shutter[0] as f64, shutter[1] as f64);
        times.retain(|u| (lo..=hi).contains(u));
        times.sort_by(f64::total_cmp);
        let sign = det(lo).signum();
        // NaN counts as bad.
        let bad = |u: f64| (det(u) * sign).partial_cmp(&tiny) != Some(std::cmp::Ordering::Greater);
        if bad(lo) {
            return Err(singular(lo));
        }
        // Between turning points the cubic is monotone: the first bad one has the first
        // zero below it, found by bisection.
        let mut good = lo;
        for u in times {
            if bad(u) {
                let mut b = u;
                for _ in 0..60 {
                    let mid = 0.5 * (good + b);
                    if bad(mid) {
                        b = mid;
                    } else {
                        good = mid;
                    }
                }
                return Err(singular(b));
            }
            good = u;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn rotation(axis: DVec3, deg: f64) -> DMat4 {
        DMat4::from_axis_angle(axis.normalize(), deg.to_radians())
    }

    /// The slerp with its angle kept is glam's, bit for bit, from a tiny turn (glam's
    /// lerp) to a half turn.
    #[test]
    fn slerp_with_its_angle_kept_is_glams() {
        let mut seed = 11u64;
        let mut next = move || {
            seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut slerped = 0;
        for k in 0..400 {
            let axis = DVec3::new(next() - 0.5, next() - 0.5, next() - 0.5);
            let turn = [1e-9, 1e-4, 0.3, 90.0, 179.9][k % 5] * (0.5 + next());
            let start = rotation(DVec3::new(next(), next() - 0.5, 0.3), next() * 360.0);
            let m = Motion::new(start, rotation(axis, turn) * start).unwrap();
            slerped += m.arc.is_some() as u32;
            for u in (0..=64).map(|i| i as f64 / 64.0).chain([next(), 1e-7, 1.0 - 1e-7]) {
                let (ours, glams) = (m.slerp(u), m.r[0].slerp(m.r[1], u));
                assert_eq!(ours.to_array().map(f64::to_bits), glams.to_array().map(f64::to_bits), "{k}, u {u}");
            }
        }
        assert!(slerped > 200 && slerped < 400, "both paths taken: {slerped} of 400 slerp");
    }

    #[test]
    fn ends_are_exact_and_the_middle_is_decomposed() {
        let a = DMat4::from_translation(DVec3::new(1.0, 2.0, 3.0)) * rotation(DVec3::Z, 10.0);
        let b = DMat4::from_translation(DVec3::new(3.0, 2.0, 1.0))
            * rotation(DVec3::Z, 100.0)
            * DMat4::from_scale(DVec3::splat(3.0));
        let m = Motion::new(a, b).unwrap();
        assert_eq!(m.at(0.0), DAffine3::from_mat4(a));
        assert_eq!(m.at(1.0), DAffine3::from_mat4(b));
        assert_eq!(m.at(-1.0), DAffine3::from_mat4(a));
        // Halfway: translation (2, 2, 2), rotation 55° about z, scale 2. A matrix lerp
        // would shrink the rotated x axis instead.
        let half = m.at(0.5);
        let want = DMat4::from_translation(DVec3::splat(2.0))
            * rotation(DVec3::Z, 55.0)
            * DMat4::from_scale(DVec3::splat(2.0));
        assert!(DMat4::from(half).abs_diff_eq(want, 1e-9), "{half:?}");
        assert!(!m.is_static());
        assert!(Motion::new(a, a).unwrap().is_static());
    }

    #[test]
    fn a_mirror_at_both_ends_interpolates_and_a_flip_is_singular() {
        let mirror = DMat4::from_scale(DVec3::new(-1.0, 1.0, 1.0));
        let m = Motion::new(mirror, DMat4::from_translation(DVec3::X) * mirror).unwrap();
        assert!(DMat4::from(m.at(0.5)).abs_diff_eq(DMat4::from_translation(DVec3::X * 0.5) * mirror, 1e-12));
        assert!(m.check_invertible([0.0, 1.0]).is_ok());
        let flip = Motion::new(DMat4::IDENTITY, mirror).unwrap();
        let err = flip.check_invertible([0.0, 1.0]).unwrap_err();
        // det S(u) = (1 − 2u)³: refused where it falls below 10⁻⁹ of the ends', 0.0005 early.
        assert!(err.contains("at time 0.4995"), "{err}");
        // Outside the shutter the singular time does not matter.
        assert!(flip.check_invertible([0.0, 0.4]).is_ok());
        // Ends of one handedness never pass through a singular scale: the stretch of
        // either is definite with the same sign, and so is every mix of the two.
        let turned = Motion::new(DMat4::IDENTITY, DMat4::from_scale(DVec3::new(-1.0, -1.0, 1.0))).unwrap();
        assert!(turned.check_invertible([0.0, 1.0]).is_ok(), "a 180° turn about z, decomposed");
    }

    fn affine() -> impl Strategy<Value = DMat4> {
        (
            prop::array::uniform3(-5.0f64..5.0),
            prop::array::uniform3(-1.0f64..1.0),
            -360.0f64..360.0,
            prop::array::uniform3(0.2f64..3.0),
        )
            .prop_map(|(t, axis, deg, s)| {
                let axis = DVec3::from(axis);
                let axis = if axis.length() < 1e-3 { DVec3::Y } else { axis };
                DMat4::from_translation(t.into()) * rotation(axis, deg) * DMat4::from_scale(s.into())
            })
    }

    proptest! {
        /// Every point of a box, at every time of the shutter, lies inside the box's
        /// motion bound: the transform the tracer uses at that time, rounded to f32 as a
        /// moved vertex is.
        #[test]
        fn motion_bounds_hold_every_point_at_every_time(
            a in affine(), b in affine(),
            lo in prop::array::uniform3(-2.0f32..0.0), size in prop::array::uniform3(0.0f32..3.0),
            shutter in (0.0f32..1.0, 0.0f32..1.0),
            points in prop::collection::vec((prop::array::uniform3(0.0f32..=1.0), 0.0f32..=1.0), 64),
        ) {
            let m = Motion::new(a, b).unwrap();
            let (lo, size) = (Vec3::from(lo), Vec3::from(size));
            let hi = lo + size;
            let shutter = [shutter.0.min(shutter.1), shutter.0.max(shutter.1)];
            let (blo, bhi) = m.bound(lo, hi, shutter);
            for (f, u) in points {
                let p = lo + Vec3::from(f) * size;
                let time = shutter[0] + (shutter[1] - shutter[0]) * u;
                let w = m.at(time).transform_point3(p.as_dvec3()).as_vec3();
                prop_assert!(w.cmpge(blo).all() && w.cmple(bhi).all(), "{w} at {time} outside {blo}..{bhi}");
            }
        }

        /// Interpolated transforms of invertible ends of one handedness are invertible,
        /// and the halfway transform maps the origin halfway between the ends' images.
        #[test]
        fn interpolation_keeps_translations_linear(a in affine(), b in affine(), u in 0.0f32..1.0) {
            let m = Motion::new(a, b).unwrap();
            prop_assert!(m.check_invertible([0.0, 1.0]).is_ok());
            let o = m.at(u).translation;
            let want = a.w_axis.truncate().lerp(b.w_axis.truncate(), u as f64);
            prop_assert!(o.abs_diff_eq(want, 1e-9));
        }
    }
}
