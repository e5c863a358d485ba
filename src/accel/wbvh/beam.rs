//! The packet walk of the wide tree: a packet's rays bounded as one beam (an interval of
//! origins and one of reciprocal directions per axis), each node's children tested for
//! the whole beam with one SIMD test, as one ray's are (interval traversal: Wald, Boulos
//! and Shirley, "Ray Tracing Deformable Scenes Using Dynamic Bounding Volume
//! Hierarchies", 2007; Reshetov et al.'s multi-level ray tracing). A node costs a packet
//! about what it costs one ray, where a per-lane test of every child (Embree's packets
//! over its BVH8) costs sixteen rays' worth. Leaves are handed to the caller with their
//! box, to test each lane exactly.
//!
//! Exactness: the beam test is conservative bit for bit. Every lane's slab distances are
//! `fl(fl(bound − o) · inv)`; rounding is monotone in each operand, so with the signs of
//! `inv` fixed per axis, each lane's entry distance is at least the beam's lower bound
//! and its exit distance at most the beam's upper bound, both computed from the
//! intervals' ends. A child that some lane's own test (`slab`) enters is therefore always
//! entered by the beam, and the caller's per-lane leaf test and tie rule do the rest.

use super::{LeafRef, WideBvh, LEAF_FLAG};
use crate::accel::WIDEN;
use crate::simd::{Vector, LANES};

/// A packet's rays as one beam: per axis, the origins' interval and the reciprocal
/// directions' interval, the latter of one sign, or no bound on an axis whose directions'
/// signs differ.
pub(crate) struct Beam {
    /// Per axis: 0 when the rays go towards +axis (they enter a box through its minimum),
    /// 1 towards −axis.
    near: [usize; 3],
    /// Per axis: the directions' signs differ, so the axis bounds no lane's distances
    /// from one side (a box's slab on it is (−∞, ∞) for the beam).
    free: [bool; 3],
    /// Per axis: the origin coordinate that gives the lowest entry distance (the highest
    /// origin for a positive direction) and the one that gives the highest exit distance.
    o_near: [f32; 3],
    o_far: [f32; 3],
    /// Per axis: the reciprocal directions' lowest and highest value.
    inv: [[f32; 2]; 3],
}

/// The least and the greatest of `v` (no NaN among them). A full packet's halves are
/// folded onto each other, four vector steps instead of a chain of sixteen (of equal
/// values it may keep the other zero's sign, which no comparison of the walk sees).
#[inline(always)]
fn range(v: &[f32]) -> (f32, f32) {
    if let Ok(v) = <&[f32; LANES]>::try_from(v) {
        let (mut lo, mut hi) = (*v, *v);
        let mut w = LANES / 2;
        while w > 0 {
            for i in 0..w {
                lo[i] = if lo[i + w] < lo[i] { lo[i + w] } else { lo[i] };
                hi[i] = if hi[i + w] > hi[i] { hi[i + w] } else { hi[i] };
            }
            w /= 2;
        }
        return (lo[0], hi[0]);
    }
    v.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &x| {
        (if x < lo { x } else { lo }, if x > hi { x } else { hi })
    })
}

impl Beam {
    /// The beam of `n` rays given by axis: `origin[k][l]` is lane l's origin on axis k,
    /// `inv[k][l]` its reciprocal direction ([`inv_dir`](crate::accel::inv_dir), never
    /// zero or NaN); `None` when an origin is not finite or no axis bounds the beam.
    /// Always inlined: out of line, its 64 bytes, stored field by field, went back to
    /// the caller through memory and a vector load of them waited on those stores.
    #[inline(always)]
    pub(crate) fn new(origin: &[[f32; LANES]; 3], inv: &[[f32; LANES]; 3], n: usize) -> Option<Beam> {
        let mut beam = Beam { near: [0; 3], free: [false; 3], o_near: [0.0; 3], o_far: [0.0; 3], inv: [[0.0; 2]; 3] };
        for k in 0..3 {
            let (olo, ohi) = range(&origin[k][..n]);
            let (ilo, ihi) = range(&inv[k][..n]);
            if !(olo.is_finite() && ohi.is_finite()) {
                return None;
            }
            // `inv_dir` is never zero, so one sign means both ends on one side of it.
            beam.free[k] = (ilo < 0.0) != (ihi < 0.0);
            let down = ihi < 0.0;
            beam.near[k] = down as usize;
            (beam.o_near[k], beam.o_far[k]) = if down { (olo, ohi) } else { (ohi, olo) };
            beam.inv[k] = [ilo, ihi];
        }
        (!beam.free.iter().all(|&f| f)).then_some(beam)
    }
}

/// What a beam walk's leaf test tells it.
pub(crate) enum BeamLeaf {
    /// Keep walking, skipping boxes entered past this distance (the lanes' largest
    /// culling distance, `tmax · CULL + slack`, now).
    Go(f32),
    /// Stop: every lane has its answer, or the packet gives up.
    Stop,
}

thread_local! {
    /// The beam walk's stack, kept per thread so a packet neither allocates nor zeroes one.
    static BEAM_STACK: std::cell::RefCell<Vec<(u32, f32, u32, u32)>> = const { std::cell::RefCell::new(Vec::new()) };
}

impl<S: Vector> WideBvh<S> {
    /// Children of node `n` that some ray of `beam` may enter before `cull`, as a slot
    /// mask, with lower bounds of their entry distances (see the module docs).
    #[inline(always)]
    fn beam_test(&self, n: u32, beam: &Beam, cull: f32) -> (u32, S) {
        let node = &self.nodes[n as usize];
        let mut near = S::splat(f32::NEG_INFINITY);
        let mut far = S::splat(f32::INFINITY);
        for k in 0..3 {
            if beam.free[k] {
                continue;
            }
            let [ilo, ihi] = beam.inv[k].map(S::splat);
            let x = node.bounds[beam.near[k]][k] - S::splat(beam.o_near[k]);
            let y = node.bounds[1 - beam.near[k]][k] - S::splat(beam.o_far[k]);
            near = near.fast_max((x * ilo).fast_min(x * ihi));
            far = far.fast_min((y * ilo).fast_max(y * ihi));
        }
        let far = far * S::splat(WIDEN);
        let zero = S::splat(0.0);
        let hit = far.ge(near) & far.ge(zero) & near.lt(S::splat(cull));
        (hit.bits() & node.valid, near)
    }

    /// The box of child `slot` of node `n`: minima and maxima.
    #[inline(always)]
    fn child_box(&self, n: u32, slot: usize) -> ([f32; 3], [f32; 3]) {
        let node = &self.nodes[n as usize];
        (node.bounds[0].map(|v| v.lane(slot)), node.bounds[1].map(|v| v.lane(slot)))
    }

    /// Walks the tree for the rays of `beam` whose culling distances are at most `cull`
    /// (`tmax · CULL + slack` of the farthest lane): every child the beam enters is
    /// visited, nearest lower bound first when `ORDER` (closest hit; slot order for any
    /// hit), and each leaf is handed to `leaf(min, max, leaf)` with its box
    /// ([`WideBvh::leaf_prims`] gives its primitives). `nodes`
    /// counts the child boxes tested.
    pub(crate) fn walk_beam<const ORDER: bool>(
        &self,
        beam: &Beam,
        mut cull: f32,
        nodes: &mut u64,
        mut leaf: impl FnMut([f32; 3], [f32; 3], LeafRef) -> BeamLeaf,
    ) {
        BEAM_STACK.with_borrow_mut(|stack| {
            stack.clear();
            // (child, lower bound of its entry distance, parent node, slot in it).
            stack.push((0, f32::NEG_INFINITY, u32::MAX, 0));
            while let Some((child, t, parent, slot)) = stack.pop() {
                if t >= cull {
                    continue;
                }
                if child & LEAF_FLAG != 0 {
                    let (min, max) = self.child_box(parent, slot as usize);
                    match leaf(min, max, LeafRef::of(child)) {
                        BeamLeaf::Go(c) => cull = c,
                        BeamLeaf::Stop => return,
                    }
                    continue;
                }
                let (mut bits, near) = self.beam_test(child, beam, cull);
                let node = &self.nodes[child as usize];
                *nodes += node.valid.count_ones() as u64;
                let mut t = [0.0f32; LANES];
                near.store(&mut t);
                // Pushed farthest first, so the nearest is visited next (ties keep slot
                // order: deterministic).
                let base = stack.len();
                while bits != 0 {
                    let i = bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    let e = (node.child[i], t[i], child, i as u32);
                    stack.push(e);
                    if ORDER {
                        let mut j = stack.len() - 1;
                        while j > base && stack[j - 1].1 < e.1 {
                            stack[j] = stack[j - 1];
                            j -= 1;
                        }
                        stack[j] = e;
                    }
                }
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::shapes::{Primitive, Shape, NO_LIGHT};
    use crate::accel::{cull_at, inv_dir, slab, Accel, Ray};
    use glam::Vec3;

    /// The beam test never drops a child box that one of its rays enters (by the scalar
    /// slab test every kernel shares) before that ray's own culling distance: on every node
    /// of a tree, for coherent and scattered packets, directions with zero, tiny and huge
    /// components, origins on box faces and far away.
    #[test]
    fn beam_test_keeps_every_box_a_lane_enters() {
        const ROUNDS: usize = 600;
        let mut h = 99u32;
        let mut rnd = || {
            h = crate::sampling::mix(h);
            crate::sampling::to_unit(h)
        };
        let mut prims = Vec::new();
        for k in 0..600 {
            let c = Vec3::new(rnd(), rnd(), rnd()) * 8.0 - 4.0;
            let (a, b) = (Vec3::new(rnd(), rnd(), rnd()) - 0.5, Vec3::new(rnd(), rnd(), rnd()) - 0.5);
            // Every third triangle lies in an axis plane (boxes of zero thickness).
            let (a, b) = if k % 3 == 0 { (a * Vec3::new(1.0, 1.0, 0.0), b * Vec3::new(1.0, 1.0, 0.0)) } else { (a, b) };
            prims.push(Primitive {
                shape: Shape::Triangle { v0: c, v1: c + a, v2: c + b },
                material: 0,
                light: NO_LIGHT,
            });
        }
        let accel = Accel::build(prims);
        let tree = accel.wide.as_ref().expect("a wide tree");
        let (mut checked, mut kept) = (0u64, 0u64);
        for round in 0..ROUNDS {
            let n = 1 + round % LANES;
            let base = Vec3::new(rnd(), rnd(), rnd()) * 12.0 - 6.0;
            let sign = Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5).signum();
            let mut rays = Vec::new();
            for l in 0..n {
                let spread = [0.0, 1e-3, 0.3, 3.0][round % 4];
                let mut o = base + (Vec3::new(rnd(), rnd(), rnd()) - 0.5) * spread;
                let mut d = (Vec3::new(rnd(), rnd(), rnd()) + 0.01) * sign;
                match (round + l) % 7 {
                    0 => d.x = 0.0 * sign.x,
                    1 => d.y = 1e-30 * sign.y,
                    2 => d *= 1e20,
                    3 => o.z = 4.0, // near the scene's bounds, where boxes have faces
                    4 => o *= 1e4,
                    _ => {}
                }
                let tmax = if round % 2 == 0 { f32::INFINITY } else { rnd() * 10.0 };
                rays.push(Ray::new(o, d, 0.0, tmax));
            }
            let mut origin = [[0.0; LANES]; 3];
            let mut inv = [[0.0; LANES]; 3];
            for (l, r) in rays.iter().enumerate() {
                for k in 0..3 {
                    origin[k][l] = r.origin[k];
                    inv[k][l] = inv_dir(r.dir[k]);
                }
            }
            let Some(beam) = Beam::new(&origin, &inv, n) else { continue };
            let cull = rays.iter().map(|r| cull_at(r.tmax, accel.slack)).fold(f32::NEG_INFINITY, f32::max);
            for j in 0..tree.nodes.len() as u32 {
                let (mask, _) = tree.beam_test(j, &beam, cull);
                let valid = tree.nodes[j as usize].valid;
                for slot in (0..8).filter(|&i| valid & (1 << i) != 0) {
                    let (min, max) = tree.child_box(j, slot);
                    let b = obvhs::aabb::Aabb { min: min.into(), max: max.into() };
                    for r in &rays {
                        if slab(&b, &r.slab()) < cull_at(r.tmax, accel.slack) {
                            checked += 1;
                            assert!(mask & (1 << slot) != 0, "node {j} slot {slot} dropped, ray {r:?}");
                        }
                    }
                    kept += (mask >> slot & 1) as u64;
                }
            }
        }
        // Both sides were exercised: boxes lanes enter, and boxes the beam could cull.
        let total: u64 = tree.nodes.iter().map(|n| n.valid.count_ones() as u64).sum::<u64>() * ROUNDS as u64;
        assert!(checked > 10_000 && kept < total, "{checked} lane entries checked, {kept} of {total} kept");
    }
}
