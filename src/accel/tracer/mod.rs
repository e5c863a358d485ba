//! The tracer context: the acceleration structure, the kernel that traverses it (one
//! ray at a time over the binary or the wide BVH, packets of 4, 8 or 16 lanes formed in
//! a chosen order, or the hybrid that picks per queue by coherence), the
//! traversal counters and the scratch space, as one value. The stages that trace rays
//! (intersect, shadow, shadow corners, focus) take it as one `&mut`; the renderer builds
//! one per worker from the scene's settings, `wavetrace bench` one per kernel it measures.

use glam::Vec3;
use wide::{f32x16, f32x4, f32x8};

use super::order::{octant, packet_order, Order};
use super::packet::{Columns, PacketConfig, PacketWork};
use super::Ray;
use super::{Accel, Traversal, Walk};
use crate::queue::{FilmQueue, HitQueue, RayQueue, ShadowQueue, MISS};
use crate::simd::{Vector, LANES};

mod moving;

/// SIMD width of a packet kernel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Width {
    /// 4 lanes (`f32x4`).
    X4,
    /// 8 lanes (`f32x8`).
    X8,
    /// 16 lanes (`f32x16`): the renderer's (measured: docs/performance.md).
    X16,
}

impl Width {
    /// The width of `lanes` lanes: 4, 8, else 16.
    pub fn of(lanes: usize) -> Width {
        match lanes {
            4 => Width::X4,
            8 => Width::X8,
            _ => Width::X16,
        }
    }
}

/// Which traversal kernel a tracer runs: the renderer's ([`Kernel::render`]) or, for
/// `wavetrace bench` and the kernel tests, any other to measure against it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kernel {
    /// One ray at a time over the binary BVH where the accel keeps one
    /// ([`Accel::build_reference`]), else over the wide one: the tests' reference.
    Scalar,
    /// One ray at a time over the wide BVH (all of a node's children in one SIMD test).
    Wide,
    /// Rays walked [`INTERLEAVE`](super::wbvh::INTERLEAVE) at a time over the wide BVH,
    /// their memory loads overlapped ([`Accel::closest_many`]).
    Interleaved,
    /// Whole queues traced as ray streams over the wide BVH ([`Walk::Stream`]):
    /// each node tested once for all the rays that reach it.
    Stream,
    /// Packets of `width` lanes, formed and traced as `cfg` says (their lone rays over the
    /// binary BVH).
    Packet(Width, PacketConfig),
    /// Chosen per queue by measured coherence: camera rays in packets; bounce and shadow
    /// queues start with [`PROBE_PACKETS`] packets spread over the queue, and when their beams
    /// reach more than `max_leaves` leaves per 100 rays, the rest of the queue goes over
    /// the wide BVH: interleaved ([`Kernel::Interleaved`]) when the tree outgrows the
    /// last-level cache ([`Accel::interleave`]) or a closest-hit queue's walks are
    /// node-bound ([`node_bound`]), else as one ray stream ([`Kernel::Stream`]). Lone
    /// rays (and packets that mix octants) take the wide BVH one at a time.
    Hybrid {
        /// Lanes per packet.
        width: Width,
        /// How packets are formed and traced.
        cfg: PacketConfig,
        /// Leaves reached per 100 rays above which a queue leaves packets (0: after the
        /// probe always; `u32::MAX`: never).
        max_leaves: u32,
    },
}

impl Kernel {
    /// The renderer's kernel: the hybrid (`render.packets = true`, chosen by measurement:
    /// docs/performance.md), or one ray at a time over the wide BVH.
    pub fn render(packets: bool) -> Kernel {
        if packets {
            Kernel::HYBRID
        } else {
            Kernel::Wide
        }
    }

    /// The renderer's hybrid settings (measured: docs/performance.md).
    pub const HYBRID: Kernel = Kernel::Hybrid { width: Width::X16, cfg: PacketConfig::RENDER, max_leaves: 100 };

    /// The leaves per 100 rays above which a queue of rays from `coherence` leaves
    /// packets; `None`: it never does.
    fn leave_packets(self, coherence: Coherence) -> Option<u32> {
        match self {
            Kernel::Hybrid { max_leaves, .. } if coherence != Coherence::Camera => Some(max_leaves),
            _ => None,
        }
    }

    /// The walk of a kernel that traces whole queues over the wide BVH together.
    fn walk(self) -> Option<Walk> {
        match self {
            Kernel::Interleaved => Some(Walk::Interleaved),
            Kernel::Stream => Some(Walk::Stream),
            _ => None,
        }
    }

    /// Whether single rays (alone, or falling out of packets) take the wide BVH.
    fn wide_singles(self) -> bool {
        matches!(self, Kernel::Wide | Kernel::Interleaved | Kernel::Stream | Kernel::Hybrid { .. })
    }
}

/// Packets a hybrid kernel traces of a bounce or shadow queue, spread over it, before it
/// judges the queue's coherence.
pub const PROBE_PACKETS: usize = 8;

/// Where a queue's rays come from, which decides how they are ordered into packets.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Coherence {
    /// Camera rays and depth probes: generation order is already coherent (a pixel's
    /// samples, then its neighbours in screen blocks).
    Camera,
    /// Reflection and refraction rays: ordered as the packet config says.
    Bounce,
}

/// Everything a stage needs to trace rays: see the module docs.
pub struct Tracer<'a> {
    accel: &'a Accel,
    kernel: Kernel,
    count: bool,
    /// Traversal work since the last [`Tracer::take_work`].
    work: Traversal,
    /// Scratch: the order rays are cut into packets in.
    order: Vec<(u64, u32)>,
    /// Scratch: per shadow ray, whether it is blocked.
    blocked: Vec<bool>,
    /// Scratch for the moving objects' queues, made when a scene first needs it.
    moving: Option<Box<moving::Scratch>>,
}

impl<'a> Tracer<'a> {
    /// A tracer over `accel` running `kernel`. With `count`, BVH nodes and primitives
    /// tested are counted (without, the traversals compile without counting code).
    pub fn new(accel: &'a Accel, kernel: Kernel, count: bool) -> Self {
        Tracer {
            accel,
            kernel,
            count,
            work: Traversal::default(),
            order: Vec::new(),
            blocked: Vec::new(),
            moving: None,
        }
    }

    /// The traversal work counted since the last call, resetting it.
    pub fn take_work(&mut self) -> Traversal {
        std::mem::take(&mut self.work)
    }

    /// Bytes held by the scratch buffers.
    pub fn bytes(&self) -> usize {
        self.order.capacity() * std::mem::size_of::<(u64, u32)>()
            + self.blocked.capacity()
            + self.moving.as_ref().map_or(0, |m| m.bytes())
    }

    /// Finds the closest hit of every ray in `rays`, in order, into `hits` (cleared first).
    pub fn closest(&mut self, rays: &RayQueue, coherence: Coherence, hits: &mut HitQueue) {
        let packets = match self.kernel {
            Kernel::Scalar | Kernel::Wide | Kernel::Interleaved | Kernel::Stream => None,
            Kernel::Packet(w, cfg) | Kernel::Hybrid { width: w, cfg, .. } => Some((w, cfg)),
        };
        match packets {
            None if let Some(walk) = self.kernel.walk() => {
                hits.reset(rays.len(), f32::INFINITY, MISS);
                self.closest_walk(walk, rays, rays.len(), |k| k, hits);
            }
            None if self.count => self.closest_single::<true>(rays, hits),
            None => self.closest_single::<false>(rays, hits),
            Some((Width::X4, cfg)) => self.closest_packets::<f32x4>(rays, coherence, cfg, hits),
            Some((Width::X8, cfg)) => self.closest_packets::<f32x8>(rays, coherence, cfg, hits),
            Some((Width::X16, cfg)) => self.closest_packets::<f32x16>(rays, coherence, cfg, hits),
        }
        if self.accel.moving.is_some() {
            self.closest_moving(rays, coherence, hits);
        }
    }

    /// Tests every shadow ray of `shadow` for a blocker before its `tmax`; returns one
    /// flag per ray, in queue order (true: blocked).
    pub fn occluded(&mut self, shadow: &ShadowQueue) -> &[bool] {
        self.blocked.clear();
        let packets = match self.kernel {
            Kernel::Scalar | Kernel::Wide | Kernel::Interleaved | Kernel::Stream => None,
            Kernel::Packet(w, cfg) | Kernel::Hybrid { width: w, cfg, .. } => Some((w, cfg)),
        };
        match packets {
            None if let Some(walk) = self.kernel.walk() => {
                self.blocked.resize(shadow.len(), false);
                self.occluded_walk(walk, shadow, shadow.len(), |k| k);
            }
            None if self.count => self.occluded_single::<true>(shadow),
            None => self.occluded_single::<false>(shadow),
            Some((Width::X4, cfg)) => self.occluded_packets::<f32x4>(shadow, cfg),
            Some((Width::X8, cfg)) => self.occluded_packets::<f32x8>(shadow, cfg),
            Some((Width::X16, cfg)) => self.occluded_packets::<f32x16>(shadow, cfg),
        }
        if self.accel.moving.is_some() {
            self.occluded_moving(shadow);
        }
        &self.blocked
    }

    /// Traces every shadow ray of `shadow` and appends the contributions of those that
    /// reach their light to `film`, in queue order whatever the kernel (so the film sums
    /// in the same order and packets change no pixel's bits). Returns how many did.
    pub fn unblocked(&mut self, shadow: &ShadowQueue, film: &mut FilmQueue) -> usize {
        let mut lit = 0;
        // 16 flags at a time: the unblocked lanes' columns copied whole, not entry by
        // entry (most shadow rays reach their light).
        for (c, flags) in self.occluded(shadow).chunks(LANES).enumerate() {
            let (mut keep, mut m) = ([0usize; LANES], 0);
            for (k, &b) in flags.iter().enumerate() {
                keep[m] = k;
                m += usize::from(!b);
            }
            if m == 0 {
                continue;
            }
            lit += m;
            let at = c * LANES;
            let lanes = |v: &[f32]| columns(v, at, flags.len());
            let l = [lanes(&shadow.lr), lanes(&shadow.lg), lanes(&shadow.lb)];
            let slot = columns(&shadow.slot, at, flags.len());
            if m == LANES {
                film.push_lanes(slot, l, LANES);
            } else {
                film.push_picked(slot, l, &keep[..m]);
            }
        }
        lit
    }

    /// One shadow ray, alone whatever the kernel: the reference the queue kernels are
    /// tested against (stages hand whole queues to [`Tracer::occluded`]).
    pub fn occluded_one(&mut self, o: Vec3, d: Vec3, tmax: f32) -> bool {
        if self.count {
            self.one_occluded::<true>(o, d, tmax)
        } else {
            self.one_occluded::<false>(o, d, tmax)
        }
    }

    /// One shadow segment `(0, tmax)` through the kernel's single-ray traversal.
    #[inline(always)]
    fn one_occluded<const COUNT: bool>(&mut self, o: Vec3, d: Vec3, tmax: f32) -> bool {
        single_occluded::<COUNT>(self.accel, self.kernel, o, d, tmax, &mut self.work)
    }

    fn closest_single<const COUNT: bool>(&mut self, rays: &RayQueue, hits: &mut HitQueue) {
        hits.clear();
        for i in 0..rays.len() {
            let (t, prim) =
                single_closest::<COUNT>(self.accel, self.kernel, rays.origin(i), rays.dir(i), &mut self.work);
            hits.push(t, prim);
        }
    }

    fn closest_packets<S: Vector>(
        &mut self,
        rays: &RayQueue,
        coherence: Coherence,
        cfg: PacketConfig,
        hits: &mut HitQueue,
    ) {
        let n = rays.len();
        hits.reset(n, f32::INFINITY, MISS);
        let how = if coherence == Coherence::Camera { Order::Keep } else { cfg.bounce_order };
        packet_order(self.accel, n, |i| rays.origin(i), |i| rays.dir(i), how, &mut self.order);
        let mut pw = PacketWork::default();
        let (mut o, mut d, mut out) = ([Vec3::ZERO; LANES], [Vec3::ZERO; LANES], [(0.0f32, 0u32); LANES]);
        let leave = self.kernel.leave_packets(coherence);
        let mut order = std::mem::take(&mut self.order);
        if leave.is_some() {
            spread_probe(&mut order, S::WIDTH);
        }
        for (p, group) in order.chunks(S::WIDTH).enumerate() {
            if sparse(p, leave, &pw, S::WIDTH) {
                // Incoherent: the rest walks the wide tree together.
                let rest = &order[p * S::WIDTH..];
                self.closest_walk(self.leave_walk(&pw, S::WIDTH, true), rays, rest.len(), |k| rest[k].1 as usize, hits);
                break;
            }
            for (l, &(_, i)) in group.iter().enumerate() {
                o[l] = rays.origin(i as usize);
                d[l] = rays.dir(i as usize);
            }
            let k = group.len();
            if shares_octant(&d[..k], cfg) {
                let cols = consecutive(group, S::WIDTH)
                    .map(|i| Columns([&rays.ox, &rays.oy, &rays.oz, &rays.dx, &rays.dy, &rays.dz].map(|v| &v[i..])));
                super::packet::closest::<S>(self.accel, &o[..k], &d[..k], cols, 0.0, &mut out, &mut pw);
                self.work.packet_rays += k as u64;
            } else {
                // Lanes traced alone here are not counted (as before the tracer existed).
                for l in 0..k {
                    out[l] = single_closest::<false>(self.accel, self.kernel, o[l], d[l], &mut self.work);
                }
            }
            for (l, &(_, i)) in group.iter().enumerate() {
                hits.t[i as usize] = out[l].0;
                hits.prim[i as usize] = out[l].1;
            }
        }
        self.order = order;
        self.add_packet_work(pw);
    }

    /// How the rays of a queue that left packets after its probe (`pw`, packets of
    /// `lanes`) walk: interleaved when the tree outgrows the last-level cache
    /// ([`Accel::interleave`]) or, for closest hits (`closest`), the walks are node-bound
    /// ([`node_bound`]), else as a stream (measured: docs/performance.md).
    fn leave_walk(&self, pw: &PacketWork, lanes: usize, closest: bool) -> Walk {
        if self.accel.interleave || (closest && node_bound(pw, lanes)) {
            Walk::Interleaved
        } else {
            Walk::Stream
        }
    }

    /// Closest hits of `n` rays of `rays`, the k-th being entry `id(k)`, walked together
    /// as `walk` says, into their entries of `hits` (already sized).
    fn closest_walk(
        &mut self,
        walk: Walk,
        rays: &RayQueue,
        n: usize,
        id: impl Fn(usize) -> usize,
        hits: &mut HitQueue,
    ) {
        if self.count {
            closest_walk::<true>(self.accel, walk, rays, n, id, hits, &mut self.work);
        } else {
            closest_walk::<false>(self.accel, walk, rays, n, id, hits, &mut self.work);
        }
    }

    /// Any-hit tests of `n` shadow rays of `shadow`, the k-th being entry `id(k)`, walked
    /// together as `walk` says, into their entries of the blocked flags (already sized).
    fn occluded_walk(&mut self, walk: Walk, shadow: &ShadowQueue, n: usize, id: impl Fn(usize) -> usize) {
        if self.count {
            occluded_walk::<true>(self.accel, walk, shadow, n, id, &mut self.blocked, &mut self.work);
        } else {
            occluded_walk::<false>(self.accel, walk, shadow, n, id, &mut self.blocked, &mut self.work);
        }
    }

    fn occluded_single<const COUNT: bool>(&mut self, shadow: &ShadowQueue) {
        for i in 0..shadow.len() {
            let blocked = self.one_occluded::<COUNT>(shadow.origin(i), shadow.dir(i), shadow.tmax[i]);
            self.blocked.push(blocked);
        }
    }

    fn occluded_packets<S: Vector>(&mut self, shadow: &ShadowQueue, cfg: PacketConfig) {
        let accel = self.accel;
        packet_order(accel, shadow.len(), |i| shadow.origin(i), |i| shadow.dir(i), cfg.shadow_order, &mut self.order);
        self.blocked.resize(shadow.len(), false);
        let mut pw = PacketWork::default();
        let (mut o, mut d, mut t) = ([Vec3::ZERO; LANES], [Vec3::ZERO; LANES], [0.0f32; LANES]);
        let mut blocked = [false; LANES];
        let leave = self.kernel.leave_packets(Coherence::Bounce);
        let mut order = std::mem::take(&mut self.order);
        if leave.is_some() {
            spread_probe(&mut order, S::WIDTH);
        }
        for (p, group) in order.chunks(S::WIDTH).enumerate() {
            if sparse(p, leave, &pw, S::WIDTH) {
                // Incoherent: the rest walks the wide tree together.
                let rest = &order[p * S::WIDTH..];
                self.occluded_walk(self.leave_walk(&pw, S::WIDTH, false), shadow, rest.len(), |k| rest[k].1 as usize);
                break;
            }
            let k = group.len();
            for (l, &(_, i)) in group.iter().enumerate() {
                let i = i as usize;
                (o[l], d[l], t[l]) = (shadow.origin(i), shadow.dir(i), shadow.tmax[i]);
            }
            if shares_octant(&d[..k], cfg) {
                let cols = consecutive(group, S::WIDTH).map(|i| {
                    Columns([&shadow.ox, &shadow.oy, &shadow.oz, &shadow.dx, &shadow.dy, &shadow.dz].map(|v| &v[i..]))
                });
                super::packet::occluded::<S>(accel, &o[..k], &d[..k], cols, &t[..k], &mut blocked, &mut pw);
                self.work.packet_rays += k as u64;
            } else {
                for l in 0..k {
                    blocked[l] = single_occluded::<false>(accel, self.kernel, o[l], d[l], t[l], &mut self.work);
                }
            }
            for (l, &(_, i)) in group.iter().enumerate() {
                self.blocked[i as usize] = blocked[l];
            }
        }
        self.order = order;
        self.add_packet_work(pw);
    }

    fn add_packet_work(&mut self, pw: PacketWork) {
        self.work.packet_steps += pw.steps;
        self.work.packet_lanes += pw.lanes;
        if self.count {
            self.work.nodes += pw.nodes;
            self.work.prims += pw.prims;
        }
    }
}

/// Entries `at..at + n` (n ≤ 16) of the column `v` as lanes, a fixed-size copy when
/// n = 16; lanes past `n` are left at the default.
#[inline(always)]
fn columns<T: Copy + Default>(v: &[T], at: usize, n: usize) -> [T; LANES] {
    let mut a = [T::default(); LANES];
    if n == LANES {
        a.copy_from_slice(&v[at..at + LANES]);
    } else {
        a[..n].copy_from_slice(&v[at..at + n]);
    }
    a
}

/// Whether a queue leaves packets before its packet `p`: once [`PROBE_PACKETS`] packets of
/// `lanes` rays are done, when their beams (`pw`) reached more than `leave` leaves per 100
/// rays. A ray alone visits about one leaf, and a beam's leaf costs about what a ray's
/// does (one SIMD test), so past one leaf a ray packets cost more than single rays:
/// the Cornell box's shadow rays reach 0.14 (packets 1.6× as fast as single rays), a
/// mesh's bounce rays 2.3–2.7 (single rays 1.7–2.0×; docs/performance.md). Lane
/// utilisation, the rule before, misjudged beams that reach leaves no ray enters: cheap
/// for a beam, and no leaf for a ray alone.
#[inline]
fn sparse(p: usize, leave: Option<u32>, pw: &PacketWork, lanes: usize) -> bool {
    match leave {
        Some(max) if p == PROBE_PACKETS => pw.steps * 100 > max as u64 * (PROBE_PACKETS * lanes) as u64,
        _ => false,
    }
}

/// Whether the probe's rays (`pw`, [`PROBE_PACKETS`] packets of `lanes` rays) entered fewer than
/// one leaf in fifty rays: their walks are node visits, whose loads interleaving overlaps,
/// and not primitive tests, to which it only adds work. Chords through a mesh enter
/// 0.001–0.003 leaves a ray in the probe (interleaved ÷ stream 1.06–1.52); kitchen's,
/// which end on its walls at once, 0.05 (0.85); bounce rays 0.3–1.6 (0.82–0.91; one
/// terrain queue in five below the old bound of one in four: docs/performance.md).
#[inline]
fn node_bound(pw: &PacketWork, lanes: usize) -> bool {
    pw.lanes * 50 < (PROBE_PACKETS * lanes) as u64
}

/// Moves [`PROBE_PACKETS`] full packets spread evenly over `order` (cut into packets of `lanes`)
/// to its front, so the probe judges the whole queue: a queue in screen order starts in
/// one corner of the image (on the Cornell box, rays from the ceiling beside the light).
/// Packets keep their rays: only the order they are traced in changes, and no answer.
fn spread_probe(order: &mut [(u64, u32)], lanes: usize) {
    let full = order.len() / lanes;
    if full <= PROBE_PACKETS {
        return;
    }
    // k grows with j and k ≥ j, so each swap brings forward a packet no swap has moved.
    for j in 1..PROBE_PACKETS {
        let k = j * full / PROBE_PACKETS;
        if k != j {
            let (front, back) = order.split_at_mut(k * lanes);
            front[j * lanes..(j + 1) * lanes].swap_with_slice(&mut back[..lanes]);
        }
    }
}

/// The first ray of `group` when it is a full packet of `lanes` consecutive queue entries
/// (camera rays, and octant-sorted rays of a one-octant run), whose lanes then load
/// straight from the queue's columns.
#[inline]
fn consecutive(group: &[(u64, u32)], lanes: usize) -> Option<usize> {
    let first = group[0].1;
    (group.len() == lanes && group.iter().enumerate().all(|(l, &(_, i))| i == first + l as u32))
        .then_some(first as usize)
}

/// Whether a group of directions goes through the packet kernel: more than one ray, and
/// (when the config splits mixed packets) all in one octant.
#[inline]
fn shares_octant(d: &[Vec3], cfg: PacketConfig) -> bool {
    let oct = octant(d[0]);
    d.len() > 1 && !(cfg.split_mixed && d.iter().any(|&x| octant(x) != oct))
}

/// [`Tracer::closest_walk`]'s trace. The ray closure is inlined: a call returns the ray
/// through memory, and a stream's setup stalls reloading it (measured).
fn closest_walk<const COUNT: bool>(
    accel: &Accel,
    walk: Walk,
    rays: &RayQueue,
    n: usize,
    id: impl Fn(usize) -> usize,
    hits: &mut HitQueue,
    work: &mut Traversal,
) {
    let out = |k: usize, hit: Option<(f32, u32)>| {
        let (t, prim) = hit.unwrap_or((f32::INFINITY, MISS));
        hits.t[id(k)] = t;
        hits.prim[id(k)] = prim;
    };
    accel.closest_many::<COUNT>(
        walk,
        n,
        #[inline(always)]
        |k| Ray::infinite(rays.origin(id(k)), rays.dir(id(k))),
        out,
        work,
    );
}

/// [`Tracer::occluded_walk`]'s trace, as [`closest_walk`]'s.
fn occluded_walk<const COUNT: bool>(
    accel: &Accel,
    walk: Walk,
    shadow: &ShadowQueue,
    n: usize,
    id: impl Fn(usize) -> usize,
    blocked: &mut [bool],
    work: &mut Traversal,
) {
    accel.occluded_many::<COUNT>(
        walk,
        n,
        #[inline(always)]
        |k| Ray::new(shadow.origin(id(k)), shadow.dir(id(k)), 0.0, shadow.tmax[id(k)]),
        |k, b| blocked[id(k)] = b,
        work,
    );
}

/// One closest-hit ray through `kernel`'s single-ray traversal (wide or binary BVH).
#[inline(always)]
fn single_closest<const COUNT: bool>(
    accel: &Accel,
    kernel: Kernel,
    o: Vec3,
    d: Vec3,
    work: &mut Traversal,
) -> (f32, u32) {
    let hit = if kernel.wide_singles() {
        accel.closest::<COUNT>(Ray::new(o, d, 0.0, f32::INFINITY), work)
    } else {
        accel.closest_binary::<COUNT>(Ray::new(o, d, 0.0, f32::INFINITY), work)
    };
    hit.unwrap_or((f32::INFINITY, MISS))
}

/// One shadow segment `(0, tmax)` through `kernel`'s single-ray traversal.
#[inline(always)]
fn single_occluded<const COUNT: bool>(
    accel: &Accel,
    kernel: Kernel,
    o: Vec3,
    d: Vec3,
    tmax: f32,
    work: &mut Traversal,
) -> bool {
    if kernel.wide_singles() {
        accel.occluded::<COUNT>(Ray::new(o, d, 0.0, tmax), work)
    } else {
        accel.occluded_binary::<COUNT>(Ray::new(o, d, 0.0, tmax), work)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The probe's packets come from across the queue, first to last; every packet keeps
    /// its rays, and the order stays a permutation of the queue.
    #[test]
    fn spread_probe_moves_whole_packets_from_across_the_queue() {
        for (n, lanes) in [(16 * 9, 16), (16 * 9 + 5, 16), (4096, 16), (1000, 8), (4 * 8, 4), (100, 16)] {
            let mut order: Vec<(u64, u32)> = (0..n as u32).map(|i| (0, i)).collect();
            spread_probe(&mut order, lanes);
            let packets: Vec<&[(u64, u32)]> = order.chunks(lanes).collect();
            for p in &packets {
                let first = p[0].1;
                assert!((first as usize).is_multiple_of(lanes), "{n}/{lanes}: a packet split");
                assert!(p.iter().enumerate().all(|(l, x)| x.1 == first + l as u32), "{n}/{lanes}: a packet reordered");
            }
            let mut ids: Vec<u32> = order.iter().map(|x| x.1).collect();
            ids.sort_unstable();
            assert!(ids.iter().enumerate().all(|(i, &x)| x == i as u32), "{n}/{lanes}: not a permutation");
            let full = n / lanes;
            let probe: Vec<usize> =
                packets[..PROBE_PACKETS.min(full)].iter().map(|p| p[0].1 as usize / lanes).collect();
            if full > PROBE_PACKETS {
                assert_eq!(probe[0], 0);
                assert!(probe.windows(2).all(|w| w[0] < w[1]), "{n}/{lanes}: {probe:?}");
                assert!(
                    probe[PROBE_PACKETS - 1] >= full * (PROBE_PACKETS - 1) / PROBE_PACKETS,
                    "{n}/{lanes}: {probe:?} ends early"
                );
            } else {
                assert!(probe.iter().enumerate().all(|(i, &p)| p == i), "{n}/{lanes}: a short queue moved");
            }
        }
    }
}
