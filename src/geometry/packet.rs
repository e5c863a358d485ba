//! Packet traversal of the obvhs `Bvh2`: a packet of rays (4, 8 or 16 lanes of `wide`)
//! walks the tree together; each node pair's boxes are slab-tested for all lanes at once
//! under an active-lane mask, and a leaf's primitives (watertight triangles after Woop,
//! Benthin and Wald; spheres; parallelograms) are tested for all its lanes at once. When
//! fewer than `min_active` lanes still enter a node pair, those lanes may finish its
//! subtree one ray at a time (the scalar traversal; off in the renderer, measured).
//!
//! Exactness: every lane computes the same floating-point operations in the same order as
//! the scalar kernels (slab test, shear, edge functions, the f64 recomputation of edge
//! functions that round to zero, the distance), so a packet finds exactly the scalar
//! traversal's closest distance and blockers; only on exact ties in t may it report
//! another primitive.

use glam::Vec3;
use obvhs::bvh2::node::Bvh2Node;
use obvhs::ray::Ray;
use std::ops::{Add, BitAnd, BitOr, Div, Mul, Neg, Sub};
use wide::{f32x16, f32x4, f32x8};

use super::bvh::{subtree, Accel, NodeStack, Traversal, CULL, STACK};
use super::order::Order;
use super::shapes::{intersect_triangle, shear_axes, Shape, NO_LIGHT};

/// The SIMD type the renderer's packets use (chosen by measurement: docs/performance.md).
pub type Packet = f32x16;

/// Rays per packet in the renderer.
pub const LANES: usize = <Packet as Simd>::LANES;

/// How a stage forms and traces packets; [`PacketConfig::RENDER`] is the renderer's
/// choice, the other values exist to be measured (`wavetrace bench`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PacketConfig {
    /// Below this many lanes entering a node pair, each of them finishes the pair's
    /// subtree alone (the scalar traversal).
    pub min_active: u32,
    /// How bounce rays are ordered before they are cut into packets (camera rays always
    /// keep their generation order).
    pub bounce_order: Order,
    /// How shadow rays are ordered before they are cut into packets.
    pub shadow_order: Order,
    /// Trace a packet whose rays do not share a direction octant one ray at a time.
    pub split_mixed: bool,
}

impl PacketConfig {
    /// The renderer's settings (chosen by measurement: docs/performance.md).
    pub const RENDER: PacketConfig =
        PacketConfig { min_active: 0, bounce_order: Order::Octant, shadow_order: Order::Octant, split_mixed: true };
}

/// Most lanes of any supported packet width (arrays are sized for it).
pub const MAX: usize = 16;

/// The lane-wise operations the packet kernels need, over `wide`'s f32 vectors.
pub trait Simd:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + BitAnd<Output = Self>
    + BitOr<Output = Self>
{
    /// Number of lanes.
    const LANES: usize;
    /// Every lane `x`.
    fn splat(x: f32) -> Self;
    /// The first `LANES` values of `a`.
    fn load(a: &[f32; MAX]) -> Self;
    /// Writes the lanes to the front of `a`.
    fn store(self, a: &mut [f32; MAX]);
    /// Lane-wise minimum (no NaN handling: the kernels never produce NaN here).
    fn min(self, o: Self) -> Self;
    /// Lane-wise maximum (no NaN handling).
    fn max(self, o: Self) -> Self;
    /// Mask of `self >= o`.
    fn ge(self, o: Self) -> Self;
    /// Mask of `self > o`.
    fn gt(self, o: Self) -> Self;
    /// Mask of `self < o`.
    fn lt(self, o: Self) -> Self;
    /// Mask of `self <= o`.
    fn le(self, o: Self) -> Self;
    /// Mask of `self == o`.
    fn eq(self, o: Self) -> Self;
    /// Mask of finite lanes.
    fn finite(self) -> Self;
    /// Mask of lanes with the sign bit set.
    fn negative(self) -> Self;
    /// Mask of NaN lanes.
    fn nan(self) -> Self;
    /// Lane-wise square root.
    fn sqrt(self) -> Self;
    /// One bit per lane of a mask (lane 0 = bit 0).
    fn bits(self) -> u32;
    /// Lane-wise `mask ? t : f`.
    fn select(mask: Self, t: Self, f: Self) -> Self;
}

macro_rules! simd {
    ($t:ty, $n:expr) => {
        impl Simd for $t {
            const LANES: usize = $n;
            #[inline(always)]
            fn splat(x: f32) -> Self {
                <$t>::splat(x)
            }
            #[inline(always)]
            fn load(a: &[f32; MAX]) -> Self {
                let mut v = [0.0f32; $n];
                v.copy_from_slice(&a[..$n]);
                <$t>::from(v)
            }
            #[inline(always)]
            fn store(self, a: &mut [f32; MAX]) {
                a[..$n].copy_from_slice(&self.to_array());
            }
            #[inline(always)]
            fn min(self, o: Self) -> Self {
                self.fast_min(o)
            }
            #[inline(always)]
            fn max(self, o: Self) -> Self {
                self.fast_max(o)
            }
            #[inline(always)]
            fn ge(self, o: Self) -> Self {
                self.simd_ge(o)
            }
            #[inline(always)]
            fn gt(self, o: Self) -> Self {
                self.simd_gt(o)
            }
            #[inline(always)]
            fn lt(self, o: Self) -> Self {
                self.simd_lt(o)
            }
            #[inline(always)]
            fn le(self, o: Self) -> Self {
                self.simd_le(o)
            }
            #[inline(always)]
            fn eq(self, o: Self) -> Self {
                self.simd_eq(o)
            }
            #[inline(always)]
            fn finite(self) -> Self {
                self.is_finite()
            }
            #[inline(always)]
            fn negative(self) -> Self {
                self.is_sign_negative()
            }
            #[inline(always)]
            fn nan(self) -> Self {
                self.is_nan()
            }
            #[inline(always)]
            fn sqrt(self) -> Self {
                <$t>::sqrt(self)
            }
            #[inline(always)]
            fn bits(self) -> u32 {
                self.to_bitmask() as u32
            }
            #[inline(always)]
            fn select(mask: Self, t: Self, f: Self) -> Self {
                mask.select(t, f)
            }
        }
    };
}
simd!(f32x4, 4);
simd!(f32x8, 8);
simd!(f32x16, 16);

/// Work counters of packet traversals.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PacketWork {
    /// Node pairs whose boxes were tested for a whole packet (one SIMD test per box).
    pub steps: u64,
    /// Active lanes summed over those tests: `lanes / (LANES · steps)` is the utilisation.
    pub lanes: u64,
    /// Lane subtrees finished one ray at a time after the packet thinned out.
    pub fallbacks: u64,
    /// Box tests per lane: each SIMD box test counts once for every lane that entered the
    /// parent node (comparable with the scalar traversal's node count).
    pub nodes: u64,
    /// Primitive tests per lane.
    pub prims: u64,
}

/// obvhs's `safe_inverse`, so lanes divide exactly as the scalar rays do.
#[inline]
fn safe_inverse(x: f32) -> f32 {
    if x.abs() <= f32::EPSILON {
        x.signum() / f32::EPSILON
    } else {
        1.0 / x
    }
}

/// How a triangle's vertex components are permuted into each lane's sheared frame.
enum Axes<S> {
    /// Every lane uses the same permutation (the usual case for a coherent packet).
    Same([usize; 3]),
    /// Per lane: masks of "axis j of the frame is x" and "… is y" (else z).
    Mixed([S; 3], [S; 3]),
}

/// A packet's rays in SIMD form.
struct Lanes<'a, S> {
    o: &'a [Vec3],
    d: &'a [Vec3],
    origin: [S; 3],
    dir: [S; 3],
    inv: [S; 3],
    /// Origin components in each lane's sheared frame (kx, ky, kz).
    sheared_origin: [S; 3],
    /// The shear: d[kx]/d[kz], d[ky]/d[kz], 1/d[kz].
    shear: [S; 3],
    axes: Axes<S>,
    /// The tree's absolute culling slack.
    slack: S,
}

impl<'a, S: Simd> Lanes<'a, S> {
    fn new(o: &'a [Vec3], d: &'a [Vec3], slack: f32) -> Self {
        let mut oa = [[0.0f32; MAX]; 3];
        let mut ia = [[1.0f32; MAX]; 3];
        let mut da = [[0.0f32; MAX]; 3];
        let mut so = [[0.0f32; MAX]; 3];
        let mut sh = [[1.0f32; MAX]; 3];
        let mut is = [[[0.0f32; MAX]; 3]; 2];
        let first = d.first().map_or([0, 1, 2], |&d| shear_axes(d));
        let mut same = true;
        let on = f32::from_bits(u32::MAX);
        for (l, (o, d)) in o.iter().zip(d).enumerate() {
            let k = shear_axes(*d);
            same &= k == first;
            for j in 0..3 {
                oa[j][l] = o[j];
                da[j][l] = d[j];
                ia[j][l] = safe_inverse(d[j]);
                so[j][l] = o[k[j]];
                is[0][j][l] = if k[j] == 0 { on } else { 0.0 };
                is[1][j][l] = if k[j] == 1 { on } else { 0.0 };
            }
            sh[0][l] = d[k[0]] / d[k[2]];
            sh[1][l] = d[k[1]] / d[k[2]];
            sh[2][l] = 1.0 / d[k[2]];
        }
        let load3 = |a: &[[f32; MAX]; 3]| [S::load(&a[0]), S::load(&a[1]), S::load(&a[2])];
        let axes = if same { Axes::Same(first) } else { Axes::Mixed(load3(&is[0]), load3(&is[1])) };
        Lanes {
            o,
            d,
            origin: load3(&oa),
            dir: load3(&da),
            inv: load3(&ia),
            sheared_origin: load3(&so),
            shear: load3(&sh),
            axes,
            slack: S::splat(slack),
        }
    }

    /// Lanes (bitmask) whose ray enters the box before their `tmax` (with the culling
    /// slack of [`CULL`]), with the entry distances. Same arithmetic as the scalar traversal's test.
    #[inline(always)]
    fn slab(&self, node: &Bvh2Node, tmax: S) -> (u32, S) {
        const WIDEN: f32 = 1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);
        let b = node.aabb();
        let (min, max): (Vec3, Vec3) = (b.min.into(), b.max.into());
        let mut near = S::splat(f32::NEG_INFINITY);
        let mut far = S::splat(f32::INFINITY);
        for k in 0..3 {
            let t1 = (S::splat(min[k]) - self.origin[k]) * self.inv[k];
            let t2 = (S::splat(max[k]) - self.origin[k]) * self.inv[k];
            near = near.max(t1.min(t2));
            far = far.min(t1.max(t2));
        }
        let far = far * S::splat(WIDEN);
        let hit = far.ge(near) & far.ge(S::splat(0.0)) & near.lt(tmax * S::splat(CULL) + self.slack);
        (hit.bits(), near)
    }

    /// A vertex's components in each lane's sheared frame, minus the lane's origin.
    #[inline(always)]
    fn relative(&self, v: Vec3) -> [S; 3] {
        let p = match &self.axes {
            Axes::Same(k) => [S::splat(v[k[0]]), S::splat(v[k[1]]), S::splat(v[k[2]])],
            Axes::Mixed(is_x, is_y) => {
                let (x, y, z) = (S::splat(v.x), S::splat(v.y), S::splat(v.z));
                [0, 1, 2].map(|j| S::select(is_x[j], x, S::select(is_y[j], y, z)))
            }
        };
        [p[0] - self.sheared_origin[0], p[1] - self.sheared_origin[1], p[2] - self.sheared_origin[2]]
    }

    /// The watertight triangle test: each lane's distance exactly as [`intersect_triangle`]
    /// computes it (infinity for a miss); exact for the lanes in `mask`.
    #[inline(always)]
    fn triangle(&self, v0: Vec3, v1: Vec3, v2: Vec3, mask: u32) -> S {
        let (a, b, c) = (self.relative(v0), self.relative(v1), self.relative(v2));
        let [sx, sy, sz] = self.shear;
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
        let t = S::select(outside | det.eq(zero), inf, S::select(det.finite() & dist.finite(), dist, inf));
        // An edge function that rounds to zero is recomputed in f64 by the scalar kernel;
        // those (rare) lanes take the scalar kernel whole.
        let mut edge = mask & (u.eq(zero) | v.eq(zero) | w.eq(zero)).bits();
        if edge == 0 {
            return t;
        }
        let mut a = [0.0; MAX];
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

    /// The sphere test for every lane: exactly [`intersect_sphere`](super::shapes::intersect_sphere)'s
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

    /// The parallelogram test for every lane: exactly [`intersect_quad`](super::shapes::intersect_quad)'s
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
    fn shape(&self, shape: &Shape, mask: u32, tmin: S, tmax: S) -> S {
        match *shape {
            Shape::Triangle { v0, v1, v2 } => self.triangle(v0, v1, v2, mask),
            Shape::Sphere { center, radius } => self.sphere(center, radius, tmin, tmax),
            Shape::Quad { corner, u, v } => self.quad(corner, u, v),
        }
    }
}

/// Iterates over the set bits of a lane mask, lowest first.
#[inline(always)]
fn lanes_of(mut mask: u32) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        (mask != 0).then(|| {
            let l = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            l
        })
    })
}

impl Accel {
    /// Bounds of everything in the tree (zero-size at the origin when empty).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        match self.bvh.as_ref().and_then(|b| b.nodes.first()) {
            Some(root) => (root.aabb().min.into(), root.aabb().max.into()),
            None => (Vec3::ZERO, Vec3::ZERO),
        }
    }

    /// Walks the tree for a packet; `leaf(lanes, mask, prims, tmax)` tests a leaf's
    /// primitives for the lanes in `mask`, may lower their `tmax`, and returns false to stop
    /// all lanes. Node pairs entered by fewer than `min_active` lanes are finished by each
    /// of those lanes alone.
    #[inline(always)]
    fn walk<S: Simd>(
        &self,
        lanes: &Lanes<S>,
        tmax: &mut [f32; MAX],
        min_active: u32,
        work: &mut PacketWork,
        mut leaf: impl FnMut(&Lanes<S>, u32, std::ops::Range<usize>, &mut [f32; MAX]) -> bool,
    ) {
        let Some(bvh) = self.bvh.as_ref() else { return };
        let nodes = &bvh.nodes;
        let root = &nodes[0];
        let (mask, _) = lanes.slab(root, S::load(tmax));
        work.steps += 1;
        work.lanes += mask.count_ones() as u64;
        work.nodes += lanes.o.len() as u64;
        if mask == 0 {
            return;
        }
        if root.is_leaf() {
            let first = root.first_index as usize;
            leaf(lanes, mask, first..first + root.prim_count as usize, tmax);
            return;
        }
        let mut stack = NodeStack::new();
        // The lanes that entered each saved node, and the node pair's parent.
        let mut saved = [0u32; STACK];
        let mut parent = mask;
        let mut current = root.first_index as usize;
        loop {
            let t = S::load(tmax);
            let (a, b) = (&nodes[current], &nodes[current + 1]);
            let (ma, ta) = lanes.slab(a, t);
            let (mb, tb) = lanes.slab(b, t);
            let active = ma | mb;
            work.steps += 1;
            work.lanes += active.count_ones() as u64;
            work.nodes += 2 * parent.count_ones() as u64;
            if active != 0 && active.count_ones() < min_active {
                if !self.alone(nodes, current, lanes, active, tmax, work, &mut leaf) {
                    return;
                }
                let Some(next) = stack.next([false, false], a, b) else { return };
                parent = saved[stack.len()];
                current = next;
                continue;
            }
            // Nearer child first, judged by the first lane that enters both.
            let both = ma & mb;
            let a_first = both == 0 || tb.lt(ta).bits() & (1 << both.trailing_zeros()) == 0;
            let ((near, mn), (far, mf)) = if a_first { ((a, ma), (b, mb)) } else { ((b, mb), (a, ma)) };
            let mut descend = [false; 2];
            for (k, (node, m)) in [(near, mn), (far, mf)].into_iter().enumerate() {
                if m == 0 {
                    continue;
                }
                if node.is_leaf() {
                    let first = node.first_index as usize;
                    if !leaf(lanes, m, first..first + node.prim_count as usize, tmax) {
                        return;
                    }
                } else {
                    descend[k] = true;
                }
            }
            let depth = stack.len();
            let Some(next) = stack.next(descend, near, far) else { return };
            parent = match descend {
                [true, true] => {
                    saved[depth] = mf;
                    mn
                }
                [true, false] => mn,
                [false, true] => mf,
                [false, false] => saved[stack.len()],
            };
            current = next;
        }
    }

    /// The fallback of a thinned-out packet: each lane in `active` walks the subtree of the
    /// node pair at `first` alone (the scalar traversal), with the packet's leaf test.
    /// Returns false when the leaf test stopped the packet.
    #[allow(clippy::too_many_arguments)]
    #[inline(never)]
    fn alone<S: Simd>(
        &self,
        nodes: &[Bvh2Node],
        first: usize,
        lanes: &Lanes<S>,
        active: u32,
        tmax: &mut [f32; MAX],
        work: &mut PacketWork,
        leaf: &mut impl FnMut(&Lanes<S>, u32, std::ops::Range<usize>, &mut [f32; MAX]) -> bool,
    ) -> bool {
        for l in lanes_of(active) {
            work.fallbacks += 1;
            let ray = Ray::new(lanes.o[l].into(), lanes.d[l].into(), 0.0, tmax[l]);
            let mut go = true;
            let mut count = Traversal::default();
            subtree::<true>(nodes, first, self.slack, ray, &mut count, |r, range, _| {
                go = leaf(lanes, 1 << l, range, tmax);
                r.tmax = tmax[l];
                // A blocked any-hit lane has tmax = -∞: nothing more to find.
                go && tmax[l] != f32::NEG_INFINITY
            });
            work.nodes += count.nodes;
            if !go {
                return false;
            }
        }
        true
    }

    /// Closest hits of a packet of up to `S::LANES` rays (`o`, `d` of equal length) within
    /// `(tmin, ∞)`: `out[l]` is `(t, primitive)` or `(∞, u32::MAX)`. The same hits as
    /// [`Accel::closest`] (on exact ties in t, possibly another primitive). `min_active`:
    /// see [`PacketConfig::min_active`].
    pub fn closest_packet<S: Simd>(
        &self,
        o: &[Vec3],
        d: &[Vec3],
        tmin: f32,
        min_active: u32,
        out: &mut [(f32, u32)],
        work: &mut PacketWork,
    ) {
        let n = o.len();
        debug_assert!(n == d.len() && n <= S::LANES && out.len() >= n);
        if self.depth >= STACK {
            for l in 0..n {
                out[l] = self
                    .closest::<false>(o[l], d[l], tmin, f32::INFINITY, &mut Traversal::default())
                    .unwrap_or((f32::INFINITY, u32::MAX));
            }
            return;
        }
        let lanes = Lanes::<S>::new(o, d, self.slack);
        let mut tmax = [f32::NEG_INFINITY; MAX];
        tmax[..n].fill(f32::INFINITY);
        let mut best = [(f32::INFINITY, u32::MAX); MAX];
        let prims = &self.prims;
        let tmin_s = S::splat(tmin);
        let mut tests = 0u64;
        self.walk(&lanes, &mut tmax, min_active, work, |lanes, mask, range, tmax| {
            tests += mask.count_ones() as u64 * range.len() as u64;
            if mask & (mask - 1) == 0 {
                // One lane: the scalar kernels.
                let l = mask.trailing_zeros() as usize;
                for id in range {
                    let t = prims[id].shape.intersect(o[l], d[l], tmin, tmax[l]);
                    if t < tmax[l] {
                        tmax[l] = t;
                        best[l] = (t, id as u32);
                    }
                }
                return true;
            }
            for id in range {
                let tm = S::load(tmax);
                let t = lanes.shape(&prims[id].shape, mask, tmin_s, tm);
                let hits = (t.gt(tmin_s) & t.lt(tm)).bits() & mask;
                if hits != 0 {
                    let mut a = [0.0; MAX];
                    t.store(&mut a);
                    for l in lanes_of(hits) {
                        tmax[l] = a[l];
                        best[l] = (a[l], id as u32);
                    }
                }
            }
            true
        });
        work.prims += tests;
        out[..n].copy_from_slice(&best[..n]);
    }

    /// Any-hit tests of a packet of up to `S::LANES` shadow segments `(0, tmax[l])`:
    /// `out[l]` is true when a non-emitting primitive blocks lane l. Lanes stop as soon as
    /// they are blocked, and the packet when all are. The same answers as
    /// [`Accel::occluded`].
    pub fn occluded_packet<S: Simd>(
        &self,
        o: &[Vec3],
        d: &[Vec3],
        tmax: &[f32],
        min_active: u32,
        out: &mut [bool],
        work: &mut PacketWork,
    ) {
        let n = o.len();
        debug_assert!(n == d.len() && n == tmax.len() && n <= S::LANES && out.len() >= n);
        if self.depth >= STACK {
            for l in 0..n {
                out[l] = self.occluded::<false>(o[l], d[l], 0.0, tmax[l], &mut Traversal::default());
            }
            return;
        }
        let lanes = Lanes::<S>::new(o, d, self.slack);
        let mut t = [f32::NEG_INFINITY; MAX];
        t[..n].copy_from_slice(tmax);
        let mut blocked = [false; MAX];
        let mut open = (1u32 << n) - 1;
        let prims = &self.prims;
        let zero = S::splat(0.0);
        let mut tests = 0u64;
        self.walk(&lanes, &mut t, min_active, work, |lanes, mask, range, t| {
            let mut mask = mask & open;
            for id in range {
                if mask == 0 {
                    break;
                }
                tests += mask.count_ones() as u64;
                let p = &prims[id];
                if p.light != NO_LIGHT {
                    continue;
                }
                let hits = if mask & (mask - 1) == 0 {
                    let l = mask.trailing_zeros() as usize;
                    ((p.shape.intersect(o[l], d[l], 0.0, t[l]) < t[l]) as u32) << l
                } else {
                    let tm = S::load(t);
                    let th = lanes.shape(&p.shape, mask, zero, tm);
                    (th.gt(zero) & th.lt(tm)).bits() & mask
                };
                for l in lanes_of(hits) {
                    blocked[l] = true;
                    // A blocked lane drops out of every later box test.
                    t[l] = f32::NEG_INFINITY;
                }
                mask &= !hits;
                open &= !hits;
            }
            open != 0
        });
        work.prims += tests;
        out[..n].copy_from_slice(&blocked[..n]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Primitive, Shape};

    /// A grid of small triangles (some sharing edges) and spheres.
    fn scene() -> Accel {
        let mut prims = Vec::new();
        for i in 0..20 {
            for j in 0..20 {
                let c = Vec3::new(i as f32 * 0.3, j as f32 * 0.3, ((i * 7 + j * 3) % 5) as f32 * 0.2);
                let (e1, e2) = (Vec3::new(0.25, 0.0, 0.05), Vec3::new(0.0, 0.25, -0.05));
                if (i + j) % 3 == 0 {
                    prims.push(Primitive {
                        shape: Shape::Sphere { center: c, radius: 0.12 },
                        material: 0,
                        light: NO_LIGHT,
                    });
                } else {
                    // Two triangles sharing the edge v1–v2.
                    prims.push(Primitive {
                        shape: Shape::Triangle { v0: c, v1: c + e1, v2: c + e2 },
                        material: 0,
                        light: NO_LIGHT,
                    });
                    prims.push(Primitive {
                        shape: Shape::Triangle { v0: c + e1, v1: c + e1 + e2, v2: c + e2 },
                        material: 0,
                        light: NO_LIGHT,
                    });
                }
            }
        }
        Accel::build(prims)
    }

    fn check<S: Simd>(accel: &Accel, min_active: u32) -> PacketWork {
        let mut h = 12345u32;
        let mut rnd = || {
            h = crate::sampling::mix(h);
            crate::sampling::to_unit(h)
        };
        let mut work = PacketWork::default();
        for round in 0..400 {
            let n = 1 + (rnd() * S::LANES as f32) as usize % S::LANES;
            let (mut o, mut d) = (Vec::new(), Vec::new());
            for _ in 0..n {
                let orig = Vec3::new(rnd() * 6.0, rnd() * 6.0, 3.0 + rnd());
                // Every fourth packet aims at grid vertices (shared edges and corners).
                let dir = if round % 4 == 0 {
                    let v = Vec3::new((rnd() * 20.0).floor() * 0.3, (rnd() * 20.0).floor() * 0.3, 0.4);
                    v - orig
                } else if round % 4 == 1 {
                    // Incoherent: any direction.
                    Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5)
                } else {
                    Vec3::new(rnd() - 0.5, rnd() - 0.5, -1.0)
                };
                o.push(orig);
                d.push(dir.normalize());
            }
            let mut out = [(0.0, 0); MAX];
            accel.closest_packet::<S>(&o, &d, 0.0, min_active, &mut out, &mut work);
            let tmax: Vec<f32> = (0..n).map(|_| 1.0 + rnd() * 4.0).collect();
            let mut occ = [false; MAX];
            accel.occluded_packet::<S>(&o, &d, &tmax, min_active, &mut occ, &mut work);
            for l in 0..n {
                let single = accel.closest::<false>(o[l], d[l], 0.0, f32::INFINITY, &mut Traversal::default());
                match single {
                    Some((t, p)) => {
                        assert_eq!(out[l].0, t, "lane {l}");
                        // Another primitive only on an exact tie in t.
                        let q = out[l].1 as usize;
                        assert!(q == p as usize || accel.prims[q].shape.intersect(o[l], d[l], 0.0, f32::INFINITY) == t);
                    }
                    None => assert_eq!(out[l].1, u32::MAX),
                }
                let blocked = accel.occluded::<false>(o[l], d[l], 0.0, tmax[l], &mut Traversal::default());
                assert_eq!(occ[l], blocked, "lane {l}");
            }
        }
        assert!(work.lanes > 0 && work.lanes <= S::LANES as u64 * work.steps);
        work
    }

    #[test]
    fn packets_match_single_rays_at_every_width() {
        let accel = scene();
        for min_active in [0, 2, 4] {
            check::<f32x4>(&accel, min_active);
            check::<f32x8>(&accel, min_active);
            check::<f32x16>(&accel, min_active);
        }
        // The fallback runs only when asked for.
        assert_eq!(check::<f32x8>(&accel, 0).fallbacks, 0);
        assert!(check::<f32x8>(&accel, 8).fallbacks > 0);
    }

    #[test]
    fn simd_kernels_equal_scalar_kernels_bit_for_bit() {
        // Mixed dominant axes in one packet, rays through vertices and edges.
        let (v0, v1, v2) = (Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0));
        let o = [
            Vec3::new(0.2, 0.2, 1.0),
            Vec3::new(0.0, 0.0, 2.0),
            Vec3::new(3.0, 0.5, 0.1),
            Vec3::new(0.5, 0.5, -1.0),
            Vec3::new(-1.0, 0.3, 0.5),
            Vec3::new(0.5, -2.0, 0.3),
            Vec3::new(1.0, 0.0, 1.0),
            Vec3::new(0.25, 0.25, 1e-3),
        ];
        let d = [
            Vec3::new(0.0, 0.0, -1.0),
            Vec3::new(0.0, 0.0, -1.0),
            Vec3::new(-1.0, 0.0, -0.03).normalize(),
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(1.0, 0.0, -0.4).normalize(),
            Vec3::new(0.0, 1.0, -0.1).normalize(),
            Vec3::new(0.0, 0.0, -1.0),
            Vec3::new(0.3, -0.2, -1.0).normalize(),
        ];
        let lanes = Lanes::<f32x8>::new(&o, &d, 0.0);
        let mut t = [0.0; MAX];
        lanes.triangle(v0, v1, v2, 0xff).store(&mut t);
        for l in 0..8 {
            assert_eq!(t[l].to_bits(), intersect_triangle(v0, v1, v2, o[l], d[l]).to_bits(), "lane {l}");
        }
        assert!(matches!(lanes.axes, Axes::Mixed(..)));
        // Spheres (from inside, tangent from the centre plane, behind) and parallelograms
        // (edge-on, through a corner, from behind) against the same lanes.
        let shapes = [
            Shape::Sphere { center: Vec3::new(0.2, 0.2, 0.0), radius: 0.5 },
            Shape::Sphere { center: Vec3::new(1.0, 0.0, 0.5), radius: 1.0 },
            Shape::Sphere { center: Vec3::new(0.0, 0.0, -2.0), radius: 0.25 },
            Shape::Quad { corner: Vec3::new(0.0, 0.0, 0.0), u: Vec3::new(1.0, 0.0, 0.0), v: Vec3::new(0.0, 1.0, 0.0) },
            Shape::Quad {
                corner: Vec3::new(-1.0, -1.0, 0.5),
                u: Vec3::new(2.0, 0.0, 0.0),
                v: Vec3::new(0.0, 0.0, 1.0),
            },
        ];
        for shape in &shapes {
            for (tmin, tmax) in [(0.0, f32::INFINITY), (0.1, 1.5)] {
                lanes.shape(shape, 0xff, f32x8::splat(tmin), f32x8::splat(tmax)).store(&mut t);
                for l in 0..8 {
                    let t = if t[l] > tmin && t[l] < tmax { t[l] } else { f32::INFINITY };
                    assert_eq!(t.to_bits(), shape.intersect(o[l], d[l], tmin, tmax).to_bits(), "{shape:?} lane {l}");
                }
            }
        }
    }
}
