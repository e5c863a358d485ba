//! A packet's rays in SIMD form (`Lanes`) and its per-lane kernels: slab test, triangle, sphere, parallelogram.

use glam::Vec3;
use std::cell::OnceCell;

use super::Columns;
use crate::accel::shapes::{intersect_triangle, shear_axes, triangle_t_error, Shape};
use crate::accel::wbvh::Beam;
use crate::accel::{inv_dir_lanes, CULL, WIDEN};
use crate::simd::{Vector, LANES};

/// How a triangle's vertex components are permuted into each lane's sheared frame.
pub(super) enum Axes<S> {
    /// Every lane uses the same permutation (the usual case for a coherent packet).
    Same([usize; 3]),
    /// Per lane: masks of "axis j of the frame is x" and "… is y" (else z).
    Mixed([S; 3], [S; 3]),
}

/// A packet's rays in SIMD form.
pub(super) struct Lanes<'a, S> {
    pub(super) o: &'a [Vec3],
    pub(super) d: &'a [Vec3],
    origin: [S; 3],
    dir: [S; 3],
    inv: [S; 3],
    /// The used lanes (all bits set), for the frame.
    used: S,
    /// The lanes' sheared frames, made at the first triangle (a tree of spheres and
    /// parallelograms never pays for them).
    frame: OnceCell<Frame<S>>,
    /// The tree's absolute culling slack.
    slack: S,
}

/// The lanes' sheared frames for the watertight triangle test.
pub(super) struct Frame<S> {
    /// Origin components in each lane's sheared frame (kx, ky, kz).
    sheared_origin: [S; 3],
    /// The shear: d[kx]/d[kz], d[ky]/d[kz], 1/d[kz].
    shear: [S; 3],
    pub(super) axes: Axes<S>,
}

impl<S: Vector> Frame<S> {
    /// The frames of the rays `d` (their lanes: `origin`, `dir`; `used`: all bits set on
    /// the used lanes). Scalar work is only the transpose; the shear axes (as masks), the
    /// permuted components and every division run on lanes. Selects copy bits and the
    /// divisions are correctly rounded, so the lanes hold the scalar rays' values.
    #[inline(always)]
    fn new(d: &[Vec3], origin: &[S; 3], dir: &[S; 3], used: S) -> Frame<S> {
        let (zero, one, on) = (S::splat(0.0), S::splat(1.0), S::splat(f32::from_bits(u32::MAX)));
        // `shear_axes` on lanes: kz is the axis of largest |d| (x over y over z on ties as
        // its comparisons decide); kx, ky follow it cyclically.
        let ad = dir.map(|x| S::fast_max(x, -x));
        let x_over_y = ad[0].gt(ad[1]);
        let kz_x = x_over_y & ad[0].gt(ad[2]);
        let kz_y = S::select(x_over_y, zero, ad[1].gt(ad[2]));
        let kz_z = S::select(kz_x | kz_y, zero, on);
        let pick = |is_x: S, is_y: S, v: &[S; 3]| S::select(is_x, v[0], S::select(is_y, v[1], v[2]));
        // Per frame axis j: "is x" and "is y" (else z), only on used lanes.
        let is_x = [kz_z, kz_y, kz_x].map(|m| m & used);
        let is_y = [kz_x, kz_z, kz_y].map(|m| m & used);
        let sheared_origin = [0, 1, 2].map(|j| pick(is_x[j], is_y[j], origin));
        // d[kx], d[ky], d[kz]: unused lanes divide 1 by 1.
        let [dx, dy, dz] = [0, 1, 2].map(|j| S::select(used, pick(is_x[j], is_y[j], dir), one));
        let mask = (1u32 << d.len()) - 1;
        let uniform = |m: S| {
            let b = m.bits() & mask;
            b == 0 || b == mask
        };
        let axes = if is_x.iter().chain(&is_y).all(|&m| uniform(m)) {
            Axes::Same(d.first().map_or([0, 1, 2], |&d| shear_axes(d)))
        } else {
            Axes::Mixed(is_x, is_y)
        };
        Frame { sheared_origin, shear: [dx / dz, dy / dz, one / dz], axes }
    }
}

impl<S: Vector> Lanes<'_, S> {
    /// The packet's rays as one beam for the wide tree's packet walk.
    #[inline(always)]
    pub(super) fn beam(&self) -> Option<Beam> {
        let axes = |v: &[S; 3]| {
            let mut a = [[0.0; LANES]; 3];
            for k in 0..3 {
                v[k].store(&mut a[k]);
            }
            a
        };
        Beam::new(&axes(&self.origin), &axes(&self.inv), self.o.len())
    }
}

impl<'a, S: Vector> Lanes<'a, S> {
    /// The lanes of rays `o`, `d`; `cols`: the same rays as queue columns, for a full
    /// packet of consecutive rays.
    pub(super) fn new(o: &'a [Vec3], d: &'a [Vec3], cols: Option<Columns>, slack: f32) -> Self {
        // Scalar work is only the transpose (none from columns).
        let (origin, dir) = match cols {
            Some(Columns([ox, oy, oz, dx, dy, dz])) if o.len() == S::WIDTH => {
                let load3 = |a: [&[f32]; 3]| a.map(S::load_lanes);
                (load3([ox, oy, oz]), load3([dx, dy, dz]))
            }
            _ => {
                let mut oa = [[0.0f32; LANES]; 3];
                let mut da = [[0.0f32; LANES]; 3];
                for (l, (o, d)) in o.iter().zip(d).enumerate() {
                    for j in 0..3 {
                        oa[j][l] = o[j];
                        da[j][l] = d[j];
                    }
                }
                let load3 = |a: &[[f32; LANES]; 3]| [S::load(&a[0]), S::load(&a[1]), S::load(&a[2])];
                (load3(&oa), load3(&da))
            }
        };
        let one = S::splat(1.0);
        let mut used = [0.0f32; LANES];
        used[..d.len()].fill(f32::from_bits(u32::MAX));
        let used = S::load(&used);
        // `inv_dir` on lanes (1/x clamped to ±MAX); unused lanes get 1.
        let inv = dir.map(|x| S::select(used, inv_dir_lanes(x), one));
        Lanes { o, d, origin, dir, inv, used, frame: OnceCell::new(), slack: S::splat(slack) }
    }

    /// Lanes (bitmask) whose ray enters the box `min`–`max` before their `tmax` (with the
    /// culling slack of [`CULL`]), with the entry distances. Same arithmetic as the
    /// single-ray traversals' test.
    #[inline(always)]
    pub(super) fn slab_box(&self, min: [f32; 3], max: [f32; 3], tmax: S) -> (u32, S) {
        let mut near = S::splat(f32::NEG_INFINITY);
        let mut far = S::splat(f32::INFINITY);
        for k in 0..3 {
            let t1 = (S::splat(min[k]) - self.origin[k]) * self.inv[k];
            let t2 = (S::splat(max[k]) - self.origin[k]) * self.inv[k];
            near = near.fast_max(t1.fast_min(t2));
            far = far.fast_min(t1.fast_max(t2));
        }
        let far = far * S::splat(WIDEN);
        let hit = far.ge(near) & far.ge(S::splat(0.0)) & near.lt(tmax * S::splat(CULL) + self.slack);
        (hit.bits(), near)
    }

    /// The lanes' sheared frames, made on the first call.
    #[inline(always)]
    pub(super) fn frame(&self) -> &Frame<S> {
        self.frame.get_or_init(|| Frame::new(self.d, &self.origin, &self.dir, self.used))
    }

    /// A vertex's components in each lane's sheared frame, minus the lane's origin.
    #[inline(always)]
    fn relative(&self, frame: &Frame<S>, v: Vec3) -> [S; 3] {
        let p = match &frame.axes {
            Axes::Same(k) => [S::splat(v[k[0]]), S::splat(v[k[1]]), S::splat(v[k[2]])],
            Axes::Mixed(is_x, is_y) => {
                let (x, y, z) = (S::splat(v.x), S::splat(v.y), S::splat(v.z));
                [0, 1, 2].map(|j| S::select(is_x[j], x, S::select(is_y[j], y, z)))
            }
        };
        let o = &frame.sheared_origin;
        [p[0] - o[0], p[1] - o[1], p[2] - o[2]]
    }

    /// The watertight triangle test: each lane's distance exactly as [`intersect_triangle`]
    /// computes it (infinity for a miss); exact for the lanes in `mask`.
    #[inline(always)]
    pub(super) fn triangle(&self, v0: Vec3, v1: Vec3, v2: Vec3, mask: u32) -> S {
        let frame = self.frame();
        let (a, b, c) = (self.relative(frame, v0), self.relative(frame, v1), self.relative(frame, v2));
        let [sx, sy, sz] = frame.shear;
        let (ax, ay) = (a[0] - sx * a[2], a[1] - sy * a[2]);
        let (bx, by) = (b[0] - sx * b[2], b[1] - sy * b[2]);
        let (cx, cy) = (c[0] - sx * c[2], c[1] - sy * c[2]);
        let u = cx * by - cy * bx;
        let v = ax * cy - ay * cx;
        let w = bx * ay - by * ax;
        let (zero, inf) = (S::splat(0.0), S::splat(f32::INFINITY));
        let outside = (u.lt(zero) | v.lt(zero) | w.lt(zero)) & (u.gt(zero) | v.gt(zero) | w.gt(zero));
        let det = u + v + w;
        let dist = (u * sz * a[2] + v * sz * b[2] + w * sz * c[2]) / det;
        let error = triangle_t_error([ax, bx, cx], [ay, by, cy], [a[2], b[2], c[2]], sz, [u, v, w], det);
        let kept = det.finite() & dist.finite() & dist.gt(error);
        let t = S::select(outside | det.eq(zero), inf, S::select(kept, dist, inf));
        // An edge function that rounds to zero is recomputed in f64 by the scalar kernel;
        // those (rare) lanes take the scalar kernel whole.
        let mut edge = mask & (u.eq(zero) | v.eq(zero) | w.eq(zero)).bits();
        if edge == 0 {
            return t;
        }
        let mut a = [0.0; LANES];
        t.store(&mut a);
        while edge != 0 {
            let l = edge.trailing_zeros() as usize;
            edge &= edge - 1;
            a[l] = intersect_triangle(v0, v1, v2, self.o[l], self.d[l]);
        }
        S::load(&a)
    }

    /// `a · b` for a splatted `a`, in glam's order of operations.
    #[inline(always)]
    fn dot(a: Vec3, b: &[S; 3]) -> S {
        S::splat(a.x) * b[0] + S::splat(a.y) * b[1] + S::splat(a.z) * b[2]
    }

    /// The sphere test for every lane: exactly [`intersect_sphere`](crate::accel::shapes::intersect_sphere)'s
    /// operations, so each lane's distance (infinity for a miss) is the scalar one.
    #[inline(always)]
    fn sphere(&self, center: Vec3, radius: f32, tmin: S, tmax: S) -> S {
        let [dx, dy, dz] = self.dir;
        let f = [
            self.origin[0] - S::splat(center.x),
            self.origin[1] - S::splat(center.y),
            self.origin[2] - S::splat(center.z),
        ];
        let b = -(f[0] * dx + f[1] * dy + f[2] * dz);
        let l = [f[0] + b * dx, f[1] + b * dy, f[2] + b * dz];
        let r2 = S::splat(radius * radius);
        let disc = r2 - (l[0] * l[0] + l[1] * l[1] + l[2] * l[2]);
        let c = (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]) - r2;
        // f32::signum: ±1 by the sign bit, NaN stays NaN.
        let sign = S::select(b.nan(), b, S::select(b.negative(), S::splat(-1.0), S::splat(1.0)));
        let q = b + sign * disc.sqrt();
        let zero = S::splat(0.0);
        let tangent = q.eq(zero);
        let (t0, t1) = (S::select(tangent, zero, c / q), S::select(tangent, zero, q));
        let order = t0.lt(t1);
        let (near, far) = (S::select(order, t0, t1), S::select(order, t1, t0));
        let inf = S::splat(f32::INFINITY);
        let t = S::select(near.gt(tmin) & near.lt(tmax), near, S::select(far.gt(tmin) & far.lt(tmax), far, inf));
        S::select(disc.lt(zero), inf, t)
    }

    /// The parallelogram test for every lane: exactly [`intersect_quad`](crate::accel::shapes::intersect_quad)'s
    /// operations.
    #[inline(always)]
    fn quad(&self, corner: Vec3, u: Vec3, v: Vec3) -> S {
        let [dx, dy, dz] = self.dir;
        let [ox, oy, oz] = self.origin;
        let n = u.cross(v);
        let denom = Self::dot(n, &self.dir);
        let co = [S::splat(corner.x) - ox, S::splat(corner.y) - oy, S::splat(corner.z) - oz];
        let t = Self::dot(n, &co) / denom;
        let p = [
            (ox + t * dx) - S::splat(corner.x),
            (oy + t * dy) - S::splat(corner.y),
            (oz + t * dz) - S::splat(corner.z),
        ];
        let w = n / n.length_squared();
        let (vx, vy, vz) = (S::splat(v.x), S::splat(v.y), S::splat(v.z));
        let (ux, uy, uz) = (S::splat(u.x), S::splat(u.y), S::splat(u.z));
        let pv = [p[1] * vz - vy * p[2], p[2] * vx - vz * p[0], p[0] * vy - vx * p[1]];
        let up = [uy * p[2] - p[1] * uz, uz * p[0] - p[2] * ux, ux * p[1] - p[0] * uy];
        let (a, b) = (Self::dot(w, &pv), Self::dot(w, &up));
        let (zero, one) = (S::splat(0.0), S::splat(1.0));
        let inside = a.ge(zero) & a.le(one) & b.ge(zero) & b.le(one);
        let inf = S::splat(f32::INFINITY);
        S::select(denom.eq(zero), inf, S::select(inside & denom.finite(), t, inf))
    }

    /// Each lane's distance to `shape` (infinity for a miss) exactly as the scalar kernel
    /// computes it; exact for the lanes in `mask`.
    #[inline(always)]
    pub(super) fn shape(&self, shape: &Shape, mask: u32, tmin: S, tmax: S) -> S {
        match *shape {
            Shape::Triangle { v0, v1, v2 } => self.triangle(v0, v1, v2, mask),
            Shape::Sphere { center, radius } => self.sphere(center, radius, tmin, tmax),
            Shape::Quad { corner, u, v } => self.quad(corner, u, v),
        }
    }
}
