//! Packet traversals of the wide tree: the beam walk with its per-lane leaf test,
//! [`closest`] and [`occluded`].

use glam::Vec3;

use super::rays::Lanes;
use super::{Columns, PacketWork};
use crate::accel::wbvh::{Beam, BeamLeaf, LeafRef, Wide, WideBvh};
use crate::accel::{cull_at, lanes_of, nearer, tie_limit, Accel, Ray, Traversal};
use crate::simd::{Vector, LANES};

/// A packet's closest-hit search: per lane the best hit so far, the distance boxes are
/// culled at and the bound primitives are tested against ([`tie_limit`]).
struct Closest {
    tmax: [f32; LANES],
    best: [(f32, u32); LANES],
    limit: [f32; LANES],
    tmin: f32,
    /// Primitive tests, summed over lanes.
    tests: u64,
}

/// A packet's any-hit search: per lane the segment's end (−∞ once blocked, which drops
/// the lane out of every later box test) and whether it is blocked.
struct AnyHit {
    tmax: [f32; LANES],
    blocked: [bool; LANES],
    /// Lanes not yet blocked.
    open: u32,
    /// Primitive tests, summed over lanes.
    tests: u64,
}

/// The culling distance of a packet: its farthest lane's (see [`CULL`](crate::accel::CULL)).
#[inline(always)]
fn packet_cull(tmax: &[f32; LANES], slack: f32) -> f32 {
    cull_at(tmax.iter().copied().fold(f32::NEG_INFINITY, f32::max), slack)
}

/// A packet's search as the beam walk drives it.
trait Search {
    /// Each lane's current end of search (−∞ for lanes that take no more part).
    fn tmax(&self) -> &[f32; LANES];
    /// Tests the primitives of `leaf` for the lanes in `mask`; false when every lane has
    /// its answer.
    fn leaf<S: Vector>(&mut self, tree: &WideBvh<Wide>, leaf: LeafRef, lanes: &Lanes<S>, mask: u32) -> bool;
}

impl Search for Closest {
    fn tmax(&self) -> &[f32; LANES] {
        &self.tmax
    }

    #[inline(always)]
    fn leaf<S: Vector>(&mut self, tree: &WideBvh<Wide>, leaf: LeafRef, lanes: &Lanes<S>, mask: u32) -> bool {
        let (o, d) = (lanes.o, lanes.d);
        if mask & (mask - 1) == 0 {
            // One lane: the scalar kernels.
            let l = mask.trailing_zeros() as usize;
            tree.leaf_prims(leaf, |id, shape, _| {
                self.tests += 1;
                let t = shape.intersect(o[l], d[l], self.tmin, self.limit[l]);
                if t < self.limit[l] && nearer(t, id, self.best[l]) {
                    self.best[l] = (t, id);
                    self.tmax[l] = t;
                    self.limit[l] = tie_limit(self.best[l], t);
                }
                true
            });
            return true;
        }
        let tmin_s = S::splat(self.tmin);
        tree.leaf_prims(leaf, |id, shape, _| {
            self.tests += mask.count_ones() as u64;
            let tm = S::load(&self.limit);
            let t = lanes.shape(&shape, mask, tmin_s, tm);
            let hits = (t.gt(tmin_s) & t.lt(tm)).bits() & mask;
            if hits != 0 {
                let mut a = [0.0; LANES];
                t.store(&mut a);
                for l in lanes_of(hits) {
                    if nearer(a[l], id, self.best[l]) {
                        self.best[l] = (a[l], id);
                        self.tmax[l] = a[l];
                        self.limit[l] = tie_limit(self.best[l], a[l]);
                    }
                }
            }
            true
        });
        true
    }
}

impl Search for AnyHit {
    fn tmax(&self) -> &[f32; LANES] {
        &self.tmax
    }

    #[inline(always)]
    fn leaf<S: Vector>(&mut self, tree: &WideBvh<Wide>, leaf: LeafRef, lanes: &Lanes<S>, mask: u32) -> bool {
        let (o, d) = (lanes.o, lanes.d);
        let zero = S::splat(0.0);
        let mut mask = mask & self.open;
        tree.leaf_prims(leaf, |_, shape, blocker| {
            if mask == 0 {
                return false;
            }
            self.tests += mask.count_ones() as u64;
            if !blocker {
                return true;
            }
            let hits = if mask & (mask - 1) == 0 {
                let l = mask.trailing_zeros() as usize;
                ((shape.intersect(o[l], d[l], 0.0, self.tmax[l]) < self.tmax[l]) as u32) << l
            } else {
                let tm = S::load(&self.tmax);
                let th = lanes.shape(&shape, mask, zero, tm);
                (th.gt(zero) & th.lt(tm)).bits() & mask
            };
            for l in lanes_of(hits) {
                self.blocked[l] = true;
                self.tmax[l] = f32::NEG_INFINITY;
            }
            mask &= !hits;
            self.open &= !hits;
            true
        });
        self.open != 0
    }
}

/// Walks the wide tree for a packet as one beam (see `wbvh::beam`): each leaf the beam
/// reaches is box-tested for every lane exactly, and `search` tests its primitives for
/// the lanes that enter. False when the packet gives up: its beam reached more leaves
/// that no lane enters than leaf entries of its lanes (and over two per lane), so its
/// rays are too incoherent to share a walk; the caller then finishes each lane alone.
#[inline(always)]
fn walk_beam<S: Vector, const ORDER: bool>(
    accel: &Accel,
    tree: &WideBvh<Wide>,
    beam: &Beam,
    lanes: &Lanes<S>,
    search: &mut impl Search,
    work: &mut PacketWork,
) -> bool {
    let (mut wasted, mut useful) = (0u64, 0u64);
    let mut gave_up = false;
    let mut nodes = 0;
    let mut cull = packet_cull(search.tmax(), accel.slack);
    tree.walk_beam::<ORDER>(beam, cull, &mut nodes, |min, max, leaf| {
        let (mask, _) = lanes.slab_box(min, max, S::load(search.tmax()));
        work.steps += 1;
        work.lanes += mask.count_ones() as u64;
        if mask == 0 {
            wasted += 1;
            if wasted > useful.max(2 * S::WIDTH as u64) {
                gave_up = true;
                return BeamLeaf::Stop;
            }
            return BeamLeaf::Go(cull);
        }
        useful += mask.count_ones() as u64;
        if !search.leaf(tree, leaf, lanes, mask) {
            return BeamLeaf::Stop;
        }
        cull = packet_cull(search.tmax(), accel.slack);
        BeamLeaf::Go(cull)
    });
    work.nodes += nodes * lanes.o.len() as u64;
    !gave_up
}

/// Closest hits of a packet of up to `S::WIDTH` rays (`o`, `d` of equal length) within
/// `(tmin, ∞)`: `out[l]` is `(t, primitive)` or `(∞, u32::MAX)`. The same hits as
/// [`Accel::closest`], primitives included (the tie rule of [`nearer`]). `cols`: the
/// same rays as queue columns, when they are a full packet of consecutive entries.
#[allow(clippy::too_many_arguments)] // the rays as values and as columns, the range, the outputs
pub(crate) fn closest<S: Vector>(
    accel: &Accel,
    o: &[Vec3],
    d: &[Vec3],
    cols: Option<Columns>,
    tmin: f32,
    out: &mut [(f32, u32)],
    work: &mut PacketWork,
) {
    let n = o.len();
    debug_assert!(n == d.len() && n <= S::WIDTH && out.len() >= n);
    let lanes = Lanes::<S>::new(o, d, cols, accel.slack);
    let mut tmax = [f32::NEG_INFINITY; LANES];
    tmax[..n].fill(f32::INFINITY);
    let mut search = Closest { tmax, best: [(f32::INFINITY, u32::MAX); LANES], limit: tmax, tmin, tests: 0 };
    if let (Some(tree), Some(beam)) = (accel.wide.as_ref(), lanes.beam()) {
        if !walk_beam::<S, true>(accel, tree, &beam, &lanes, &mut search, work) {
            for l in 0..n {
                work.fallbacks += 1;
                let ray = Ray::new(o[l], d[l], tmin, search.limit[l]);
                if let Some(hit) = accel.closest::<false>(ray, &mut Traversal::default()) {
                    if nearer(hit.0, hit.1, search.best[l]) {
                        search.best[l] = hit;
                    }
                }
            }
        }
    } else {
        // No beam (mixed direction signs) or no wide tree: each lane alone.
        for l in 0..n {
            search.best[l] = accel
                .closest::<false>(Ray::new(o[l], d[l], tmin, f32::INFINITY), &mut Traversal::default())
                .unwrap_or((f32::INFINITY, u32::MAX));
        }
    }
    work.prims += search.tests;
    out[..n].copy_from_slice(&search.best[..n]);
}

/// Any-hit tests of a packet of up to `S::WIDTH` shadow segments `(0, tmax[l])`:
/// `out[l]` is true when a non-emitting primitive blocks lane l. Lanes stop as soon as
/// they are blocked, and the packet when all are. The same answers as
/// [`Accel::occluded`]. `cols` as for [`closest`].
#[allow(clippy::too_many_arguments)] // the rays as values and as columns, the range, the outputs
pub(crate) fn occluded<S: Vector>(
    accel: &Accel,
    o: &[Vec3],
    d: &[Vec3],
    cols: Option<Columns>,
    tmax: &[f32],
    out: &mut [bool],
    work: &mut PacketWork,
) {
    let n = o.len();
    debug_assert!(n == d.len() && n == tmax.len() && n <= S::WIDTH && out.len() >= n);
    let lanes = Lanes::<S>::new(o, d, cols, accel.slack);
    let mut t = [f32::NEG_INFINITY; LANES];
    t[..n].copy_from_slice(tmax);
    let mut search = AnyHit { tmax: t, blocked: [false; LANES], open: (1u32 << n) - 1, tests: 0 };
    if let (Some(tree), Some(beam)) = (accel.wide.as_ref(), lanes.beam()) {
        if !walk_beam::<S, false>(accel, tree, &beam, &lanes, &mut search, work) {
            for l in lanes_of(search.open) {
                work.fallbacks += 1;
                search.blocked[l] =
                    accel.occluded::<false>(Ray::new(o[l], d[l], 0.0, tmax[l]), &mut Traversal::default());
            }
        }
    } else {
        for l in 0..n {
            search.blocked[l] = accel.occluded::<false>(Ray::new(o[l], d[l], 0.0, tmax[l]), &mut Traversal::default());
        }
    }
    work.prims += search.tests;
    out[..n].copy_from_slice(&search.blocked[..n]);
}
