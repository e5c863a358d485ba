//! Packet traversals of the tree: the shared walk, the thinned-out fallback, [`closest`] and [`occluded`].

use glam::Vec3;
use obvhs::bvh2::node::Bvh2Node;

use super::rays::Lanes;
use super::{lanes_of, Columns, PacketWork};
use crate::accel::bvh2::{subtree, NodeStack, MAX_DEPTH};
use crate::accel::shapes::NO_LIGHT;
use crate::accel::{nearer, tie_limit, Accel, Ray, Traversal};
use crate::simd::{Vector, LANES};

/// Walks the tree for a packet; `leaf(lanes, mask, prims, tmax)` tests a leaf's
/// primitives for the lanes in `mask`, may lower their `tmax`, and returns false to stop
/// all lanes. Node pairs entered by fewer than `min_active` lanes are finished by each
/// of those lanes alone.
#[inline(always)]
fn walk<S: Vector>(
    accel: &Accel,
    lanes: &Lanes<S>,
    tmax: &mut [f32; LANES],
    min_active: u32,
    work: &mut PacketWork,
    mut leaf: impl FnMut(&Lanes<S>, u32, std::ops::Range<usize>, &mut [f32; LANES]) -> bool,
) {
    let Some(bvh) = accel.bvh.as_ref() else { return };
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
    let mut saved = [0u32; MAX_DEPTH];
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
            if !alone(accel, nodes, current, lanes, active, tmax, work, &mut leaf) {
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
#[allow(clippy::too_many_arguments)] // the tree, the subtree, the packet and its state, the leaf test
#[inline(never)]
fn alone<S: Vector>(
    accel: &Accel,
    nodes: &[Bvh2Node],
    first: usize,
    lanes: &Lanes<S>,
    active: u32,
    tmax: &mut [f32; LANES],
    work: &mut PacketWork,
    leaf: &mut impl FnMut(&Lanes<S>, u32, std::ops::Range<usize>, &mut [f32; LANES]) -> bool,
) -> bool {
    for l in lanes_of(active) {
        work.fallbacks += 1;
        let single = Ray::new(lanes.o[l], lanes.d[l], 0.0, tmax[l]).slab();
        let mut go = true;
        let mut count = Traversal::default();
        subtree::<true>(nodes, first, accel.slack, single, &mut count, |r, range, _| {
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
/// [`Accel::closest`], primitives included (the tie rule of [`nearer`]). `min_active`:
/// see [`PacketConfig::min_active`](super::PacketConfig::min_active). `cols`: the
/// same rays as queue columns, when they are a full packet of consecutive entries.
#[allow(clippy::too_many_arguments)] // the rays as values and as columns, the range, the outputs
pub fn closest<S: Vector>(
    accel: &Accel,
    o: &[Vec3],
    d: &[Vec3],
    cols: Option<Columns>,
    tmin: f32,
    min_active: u32,
    out: &mut [(f32, u32)],
    work: &mut PacketWork,
) {
    let n = o.len();
    debug_assert!(n == d.len() && n <= S::LANES && out.len() >= n);
    if accel.depth >= MAX_DEPTH {
        for l in 0..n {
            out[l] = accel
                .closest::<false>(Ray::new(o[l], d[l], tmin, f32::INFINITY), &mut Traversal::default())
                .unwrap_or((f32::INFINITY, u32::MAX));
        }
        return;
    }
    let lanes = Lanes::<S>::new(o, d, cols, accel.slack);
    let mut tmax = [f32::NEG_INFINITY; LANES];
    tmax[..n].fill(f32::INFINITY);
    let mut best = [(f32::INFINITY, u32::MAX); LANES];
    // Each lane's `tie_limit`: its tmax before a hit, just above the hit's distance after.
    let mut limit = tmax;
    let prims = &accel.prims;
    let tmin_s = S::splat(tmin);
    let mut tests = 0u64;
    walk(accel, &lanes, &mut tmax, min_active, work, |lanes, mask, range, tmax| {
        tests += mask.count_ones() as u64 * range.len() as u64;
        if mask & (mask - 1) == 0 {
            // One lane: the scalar kernels.
            let l = mask.trailing_zeros() as usize;
            for id in range {
                let t = prims[id].shape.intersect(o[l], d[l], tmin, limit[l]);
                if t < limit[l] && nearer(t, id as u32, best[l]) {
                    best[l] = (t, id as u32);
                    tmax[l] = t;
                    limit[l] = tie_limit(best[l], t);
                }
            }
            return true;
        }
        for id in range {
            let tm = S::load(&limit);
            let t = lanes.shape(&prims[id].shape, mask, tmin_s, tm);
            let hits = (t.gt(tmin_s) & t.lt(tm)).bits() & mask;
            if hits != 0 {
                let mut a = [0.0; LANES];
                t.store(&mut a);
                for l in lanes_of(hits) {
                    if nearer(a[l], id as u32, best[l]) {
                        best[l] = (a[l], id as u32);
                        tmax[l] = a[l];
                        limit[l] = tie_limit(best[l], a[l]);
                    }
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
/// [`Accel::occluded`]. `cols` as for [`Accel::closest_packet`].
#[allow(clippy::too_many_arguments)] // the rays as values and as columns, the range, the outputs
pub fn occluded<S: Vector>(
    accel: &Accel,
    o: &[Vec3],
    d: &[Vec3],
    cols: Option<Columns>,
    tmax: &[f32],
    min_active: u32,
    out: &mut [bool],
    work: &mut PacketWork,
) {
    let n = o.len();
    debug_assert!(n == d.len() && n == tmax.len() && n <= S::LANES && out.len() >= n);
    if accel.depth >= MAX_DEPTH {
        for l in 0..n {
            out[l] = accel.occluded::<false>(Ray::new(o[l], d[l], 0.0, tmax[l]), &mut Traversal::default());
        }
        return;
    }
    let lanes = Lanes::<S>::new(o, d, cols, accel.slack);
    let mut t = [f32::NEG_INFINITY; LANES];
    t[..n].copy_from_slice(tmax);
    let mut blocked = [false; LANES];
    let mut open = (1u32 << n) - 1;
    let prims = &accel.prims;
    let zero = S::splat(0.0);
    let mut tests = 0u64;
    walk(accel, &lanes, &mut t, min_active, work, |lanes, mask, range, t| {
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
