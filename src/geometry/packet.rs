//! 8-wide packet traversal of the obvhs `Bvh2` with `wide::f32x8`: eight rays walk the
//! tree together, each node's two boxes are slab-tested for all lanes at once under an
//! active-lane mask, and a leaf's primitives are tested (with the scalar kernels) only
//! for the lanes whose box test passed. Each lane's box decisions are computed with the
//! same operations as the scalar [`slab`](super::bvh) test, so a lane tests a superset of
//! nothing it should miss and finds the same closest hit as the scalar traversal.

use glam::Vec3;
use wide::f32x8;

use super::bvh::{Accel, NodeStack, Traversal, STACK};
use super::shapes::NO_LIGHT;

/// Rays per packet.
pub const LANES: usize = 8;

/// Work counters of packet traversals.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PacketWork {
    /// Node pairs whose boxes were tested (one 8-lane test each).
    pub steps: u64,
    /// Active lanes summed over those tests: `lanes / (8 · steps)` is the utilisation.
    pub lanes: u64,
}

/// Direction octant: the three sign bits.
#[inline]
pub fn octant(d: Vec3) -> u32 {
    (d.x < 0.0) as u32 | ((d.y < 0.0) as u32) << 1 | ((d.z < 0.0) as u32) << 2
}

/// Spreads the low 10 bits of `v` to every third bit (for a 30-bit Morton code).
#[inline]
fn spread(mut v: u32) -> u32 {
    v &= 0x3ff;
    v = (v | (v << 16)) & 0x0300_00ff;
    v = (v | (v << 8)) & 0x0300_f00f;
    v = (v | (v << 4)) & 0x030c_30c3;
    (v | (v << 2)) & 0x0924_9249
}

/// Sort key that puts coherent rays next to each other: direction octant first, then the
/// Morton code of the origin on a 1024³ grid over `(lo, hi)`.
#[inline]
pub fn coherence_key(o: Vec3, d: Vec3, lo: Vec3, hi: Vec3) -> u64 {
    let q = ((o - lo) / (hi - lo).max(Vec3::splat(1e-30)) * 1023.0).clamp(Vec3::ZERO, Vec3::splat(1023.0));
    let m = spread(q.x as u32) | spread(q.y as u32) << 1 | spread(q.z as u32) << 2;
    (octant(d) as u64) << 32 | m as u64
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

/// A packet's rays in SIMD form.
struct Lanes {
    o: [f32x8; 3],
    inv: [f32x8; 3],
}

impl Lanes {
    fn new(o: &[Vec3], d: &[Vec3]) -> Lanes {
        let mut oa = [[0.0f32; LANES]; 3];
        let mut ia = [[1.0f32; LANES]; 3];
        for (l, (o, d)) in o.iter().zip(d).enumerate() {
            for k in 0..3 {
                oa[k][l] = o[k];
                ia[k][l] = safe_inverse(d[k]);
            }
        }
        Lanes { o: oa.map(f32x8::from), inv: ia.map(f32x8::from) }
    }

    /// Lanes (bitmask) whose ray enters the box before their `tmax`, with the entry
    /// distances. Same arithmetic as the scalar conservative slab test.
    #[inline(always)]
    fn slab(&self, min: Vec3, max: Vec3, tmax: f32x8) -> (u32, f32x8) {
        const WIDEN: f32 = 1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);
        let mut near = f32x8::splat(f32::NEG_INFINITY);
        let mut far = f32x8::splat(f32::INFINITY);
        for k in 0..3 {
            let t1 = (f32x8::splat(min[k]) - self.o[k]) * self.inv[k];
            let t2 = (f32x8::splat(max[k]) - self.o[k]) * self.inv[k];
            near = near.max(t1.min(t2));
            far = far.min(t1.max(t2));
        }
        let far = far * f32x8::splat(WIDEN);
        let hit = far.simd_ge(near) & far.simd_ge(f32x8::ZERO) & near.simd_lt(tmax);
        (hit.to_bitmask(), near)
    }
}

/// Smallest entry distance among the lanes in `mask`.
#[inline(always)]
fn min_in(t: f32x8, mask: u32) -> f32 {
    let a = t.to_array();
    (0..LANES).filter(|&l| mask & (1 << l) != 0).map(|l| a[l]).fold(f32::INFINITY, f32::min)
}

impl Accel {
    /// Bounds of everything in the tree (zero-size at the origin when empty).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        match self.bvh.as_ref().and_then(|b| b.nodes.first()) {
            Some(root) => (root.aabb().min.into(), root.aabb().max.into()),
            None => (Vec3::ZERO, Vec3::ZERO),
        }
    }

    /// Walks the tree for up to 8 rays; `leaf(mask, prims, tmax)` tests a leaf's primitives
    /// for the lanes in `mask`, may lower their `tmax`, and returns false to stop all lanes.
    #[inline(always)]
    fn walk8(
        &self,
        lanes: &Lanes,
        tmax: &mut [f32; LANES],
        work: &mut PacketWork,
        mut leaf: impl FnMut(u32, std::ops::Range<usize>, &mut [f32; LANES]) -> bool,
    ) {
        let Some(bvh) = self.bvh.as_ref() else { return };
        let nodes = &bvh.nodes;
        let root = &nodes[0];
        let (mask, _) = lanes.slab(root.aabb().min.into(), root.aabb().max.into(), f32x8::from(*tmax));
        work.steps += 1;
        work.lanes += mask.count_ones() as u64;
        if mask == 0 {
            return;
        }
        if root.is_leaf() {
            let first = root.first_index as usize;
            leaf(mask, first..first + root.prim_count as usize, tmax);
            return;
        }
        let mut stack = NodeStack::new();
        let mut current = root.first_index as usize;
        loop {
            let t = f32x8::from(*tmax);
            let (a, b) = (&nodes[current], &nodes[current + 1]);
            let (ma, ta) = lanes.slab(a.aabb().min.into(), a.aabb().max.into(), t);
            let (mb, tb) = lanes.slab(b.aabb().min.into(), b.aabb().max.into(), t);
            work.steps += 1;
            work.lanes += (ma | mb).count_ones() as u64;
            // Nearer child first, judged by the nearest lane that enters it.
            let ((near, mn), (far, mf)) =
                if min_in(ta, ma) <= min_in(tb, mb) { ((a, ma), (b, mb)) } else { ((b, mb), (a, ma)) };
            let mut descend = [false; 2];
            for (k, (node, m)) in [(near, mn), (far, mf)].into_iter().enumerate() {
                if m == 0 {
                    continue;
                }
                if node.is_leaf() {
                    let first = node.first_index as usize;
                    if !leaf(m, first..first + node.prim_count as usize, tmax) {
                        return;
                    }
                } else {
                    descend[k] = true;
                }
            }
            let Some(next) = stack.next(descend, near, far) else { return };
            current = next;
        }
    }

    /// Closest hits of up to 8 rays (`o`, `d` of equal length ≤ 8) within `(tmin, ∞)`:
    /// `out[l]` is `(t, primitive)` or `(∞, u32::MAX)`. The same hits as
    /// [`Accel::closest`] (on exact ties in t, possibly another primitive).
    pub fn closest8(&self, o: &[Vec3], d: &[Vec3], tmin: f32, out: &mut [(f32, u32)], work: &mut PacketWork) {
        debug_assert!(o.len() == d.len() && o.len() <= LANES && out.len() >= o.len());
        if self.depth >= STACK {
            for l in 0..o.len() {
                out[l] = self
                    .closest::<false>(o[l], d[l], tmin, f32::INFINITY, &mut Traversal::default())
                    .unwrap_or((f32::INFINITY, u32::MAX));
            }
            return;
        }
        let lanes = Lanes::new(o, d);
        let mut tmax = [f32::NEG_INFINITY; LANES];
        tmax[..o.len()].fill(f32::INFINITY);
        let mut best = [(f32::INFINITY, u32::MAX); LANES];
        let prims = &self.prims;
        self.walk8(&lanes, &mut tmax, work, |mask, range, tmax| {
            let mut m = mask;
            while m != 0 {
                let l = m.trailing_zeros() as usize;
                m &= m - 1;
                for id in range.clone() {
                    let t = prims[id].shape.intersect(o[l], d[l], tmin, tmax[l]);
                    if t < tmax[l] {
                        tmax[l] = t;
                        best[l] = (t, id as u32);
                    }
                }
            }
            true
        });
        out[..o.len()].copy_from_slice(&best[..o.len()]);
    }

    /// Any-hit tests of up to 8 shadow segments `(0, tmax[l])`: `out[l]` is true when a
    /// non-emitting primitive blocks lane l. Lanes stop as soon as they are blocked, and
    /// the packet when all are.
    pub fn occluded8(&self, o: &[Vec3], d: &[Vec3], tmax: &[f32], out: &mut [bool], work: &mut PacketWork) {
        debug_assert!(o.len() == d.len() && o.len() == tmax.len() && o.len() <= LANES);
        if self.depth >= STACK {
            for l in 0..o.len() {
                out[l] = self.occluded::<false>(o[l], d[l], 0.0, tmax[l], &mut Traversal::default());
            }
            return;
        }
        let lanes = Lanes::new(o, d);
        let mut t = [f32::NEG_INFINITY; LANES];
        t[..o.len()].copy_from_slice(tmax);
        let mut blocked = [false; LANES];
        let mut open = (1u32 << o.len()) - 1;
        let prims = &self.prims;
        self.walk8(&lanes, &mut t, work, |mask, range, t| {
            let mut m = mask;
            while m != 0 {
                let l = m.trailing_zeros() as usize;
                m &= m - 1;
                for id in range.clone() {
                    let p = &prims[id];
                    if p.light == NO_LIGHT && p.shape.intersect(o[l], d[l], 0.0, t[l]) < t[l] {
                        blocked[l] = true;
                        // A blocked lane drops out of every later box test.
                        t[l] = f32::NEG_INFINITY;
                        open &= !(1 << l);
                        break;
                    }
                }
            }
            open != 0
        });
        out[..o.len()].copy_from_slice(&blocked[..o.len()]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Primitive, Shape};

    #[test]
    fn packets_match_single_rays() {
        // A grid of small triangles and spheres, rays from many directions.
        let mut prims = Vec::new();
        for i in 0..20 {
            for j in 0..20 {
                let c = Vec3::new(i as f32 * 0.3, j as f32 * 0.3, ((i * 7 + j * 3) % 5) as f32 * 0.2);
                let shape = if (i + j) % 3 == 0 {
                    Shape::Sphere { center: c, radius: 0.12 }
                } else {
                    Shape::Triangle { v0: c, v1: c + Vec3::new(0.25, 0.0, 0.05), v2: c + Vec3::new(0.0, 0.25, -0.05) }
                };
                prims.push(Primitive { shape, material: 0, light: NO_LIGHT });
            }
        }
        let accel = Accel::build(prims);
        let mut h = 12345u32;
        let mut rnd = || {
            h = crate::sampling::mix(h);
            crate::sampling::to_unit(h)
        };
        let mut work = PacketWork::default();
        for _ in 0..500 {
            let n = 1 + (rnd() * 8.0) as usize % 8;
            let (mut o, mut d) = (Vec::new(), Vec::new());
            for _ in 0..n {
                o.push(Vec3::new(rnd() * 6.0, rnd() * 6.0, 3.0 + rnd()));
                d.push(Vec3::new(rnd() - 0.5, rnd() - 0.5, -1.0).normalize());
            }
            let mut out = [(0.0, 0); LANES];
            accel.closest8(&o, &d, 0.0, &mut out, &mut work);
            let tmax: Vec<f32> = (0..n).map(|_| 1.0 + rnd() * 4.0).collect();
            let mut occ = [false; LANES];
            accel.occluded8(&o, &d, &tmax, &mut occ, &mut work);
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
        assert!(work.lanes > 0 && work.lanes <= 8 * work.steps);
    }
}
