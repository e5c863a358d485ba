//! The acceleration structure and the rules every kernel shares.
//!
//! [`Accel`] holds the primitives in leaf order and the wide tree over them: obvhs builds
//! a binary tree (`bvh2/`: its build, and the binary single-ray walk kept as the tests'
//! reference), collapsed into the wide tree (`wbvh/`: the collapse, the node layout, the
//! single-ray and interleaved walks, the beam walk of packets), whose packets' leaf tests
//! are in `packet/`. The renderer asks two questions, [`Accel::closest`] and
//! [`Accel::occluded`], of a ray here or of a whole queue through the tracer (which picks
//! the kernel); the kernels kept to be measured against them are reached through
//! `tools::kernels`. Every kernel follows the rules defined here (the
//! conservative box test [`slab`] with [`inv_dir`]'s reciprocals, the culling slack
//! [`CULL`], the tie rule [`nearer`] with [`tie_limit`], boxes widened by one float), so
//! all of them return the same hit, bit for bit, whatever the tree and the order they
//! walk it in. Beside them: the shapes and their intersection (`shapes`), robust ray
//! origins (`offset`), the order rays are cut into packets in (`order`) and the tracer
//! context the stages call (`tracer`).

pub mod bvh2;
pub mod moving;
pub mod offset;
pub mod order;
pub mod packet;
pub mod shapes;
pub mod tracer;
pub mod wbvh;

pub use shapes::{Primitive, Shape, NO_LIGHT};

use glam::Vec3;
use obvhs::bvh2::Bvh2;
use obvhs::BvhBuildParams;
use std::time::Instant;

use wbvh::{Wide, WideBvh};

/// Traversal work counters: what one or more traversals cost.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Traversal {
    /// BVH nodes whose bounding box was tested.
    pub nodes: u64,
    /// Primitives whose intersection test ran.
    pub prims: u64,
    /// Packet traversals: node pairs tested for a packet (one SIMD test each, 16 lanes in
    /// the renderer).
    pub packet_steps: u64,
    /// Active lanes summed over those tests (utilisation = lanes / (LANES · steps)).
    pub packet_lanes: u64,
    /// Rays traced in packets (the rest went one at a time).
    pub packet_rays: u64,
}

impl std::ops::AddAssign for Traversal {
    fn add_assign(&mut self, o: Traversal) {
        self.nodes += o.nodes;
        self.prims += o.prims;
        self.packet_steps += o.packet_steps;
        self.packet_lanes += o.packet_lanes;
        self.packet_rays += o.packet_rays;
    }
}

/// Most primitives per leaf (obvhs's collapse may make leaves smaller; measured:
/// docs/performance.md).
pub const MAX_LEAF: u32 = 8;

/// What every box test multiplies its far distance by: 1 + 2γ₃, PBRT's bound on the
/// rounding of the slab distances, so a ray through a box's edge or corner is never lost
/// to rounding.
pub(crate) const WIDEN: f32 = 1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// Conservative ray–box slab test: the far distance is widened by [`WIDEN`].
#[inline(always)]
pub(crate) fn slab(b: &obvhs::aabb::Aabb, ray: &SlabRay) -> f32 {
    let t1 = (b.min - ray.origin) * ray.inv_direction;
    let t2 = (b.max - ray.origin) * ray.inv_direction;
    let tmin = t1.min(t2).max_element();
    let tmax = t1.max(t2).min_element() * WIDEN;
    if tmax >= tmin && tmax >= 0.0 {
        tmin
    } else {
        f32::INFINITY
    }
}

/// Iterates over the set bits of a lane mask, lowest first.
#[inline(always)]
pub(crate) fn lanes_of(mut mask: u32) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        (mask != 0).then(|| {
            let l = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            l
        })
    })
}

/// The reciprocal of a ray direction's component for the slab tests: `1/x`, clamped to
/// ±`f32::MAX` (a zero component gives ±MAX by its sign). Never NaN and never zero, so
/// `(bound − origin) · inv` is never NaN (a bound on the origin's plane gives 0). obvhs's
/// `Ray::new` clamps at ±1/ε instead, which is not conservative: a ray parallel to an axis
/// passing within `t / 8.4·10⁶` inside a box's face (a camera ray exactly along −z, 10⁻⁶
/// from a triangle's edge at distance 10) gets a slab interval on that axis ending before
/// its hit, and the box is skipped; every kernel builds its rays with this instead.
#[inline(always)]
pub(crate) fn inv_dir(x: f32) -> f32 {
    (1.0 / x).clamp(-f32::MAX, f32::MAX)
}

/// [`inv_dir`] on lanes: the same division and clamp, so the same bits.
#[inline(always)]
pub(crate) fn inv_dir_lanes<S: crate::simd::Vector>(x: S) -> S {
    (S::splat(1.0) / x).fast_max(S::splat(-f32::MAX)).fast_min(S::splat(f32::MAX))
}

/// A ray segment: the distances `(tmin, tmax)` along `dir` from `origin`, both bounds
/// exclusive. What every traversal entry point takes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Where the ray starts.
    pub origin: Vec3,
    /// Its direction (any length; distances are in its units).
    pub dir: Vec3,
    /// Hits at or before this distance are ignored.
    pub tmin: f32,
    /// Hits at or past this distance are ignored.
    pub tmax: f32,
}

impl Ray {
    /// The segment `(tmin, tmax)` of the ray from `origin` along `dir`.
    #[inline(always)]
    pub fn new(origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Ray {
        Ray { origin, dir, tmin, tmax }
    }

    /// The whole ray, `(0, ∞)`: what camera and bounce rays search.
    #[inline(always)]
    pub fn infinite(origin: Vec3, dir: Vec3) -> Ray {
        Ray::new(origin, dir, 0.0, f32::INFINITY)
    }

    /// The ray with [`inv_dir`]'s reciprocals, as the slab tests and obvhs take it.
    #[inline(always)]
    pub(crate) fn slab(self) -> SlabRay {
        let d = self.dir;
        SlabRay {
            origin: self.origin.into(),
            direction: d.into(),
            inv_direction: glam::Vec3A::new(inv_dir(d.x), inv_dir(d.y), inv_dir(d.z)),
            tmin: self.tmin,
            tmax: self.tmax,
        }
    }
}

/// A ray as obvhs and the box tests take it: with its direction's reciprocals.
pub(crate) type SlabRay = obvhs::ray::Ray;

/// The bound to test a primitive against in a closest-hit search that has found `best`
/// so far (`(∞, u32::MAX)` before any hit) along a ray whose limit is now `tmax`: `tmax`
/// itself before a hit (exclusive, as callers ask); after one (`tmax` = its distance),
/// the next float up, so a primitive hit at exactly that distance is found too and
/// [`nearer`] can rule on the tie.
#[inline(always)]
pub(crate) fn tie_limit(best: (f32, u32), tmax: f32) -> f32 {
    if best.1 == u32::MAX {
        tmax
    } else {
        tmax.next_up()
    }
}

/// The closest-hit rule of every kernel: a hit at `t` (below [`tie_limit`]) by primitive
/// `id` replaces `best` when nearer, or exactly as near with a lower id. So the answer is
/// the lowest-id primitive at the closest distance whatever order a traversal (binary,
/// wide, packet; any tree) meets them in; exact ties happen where surfaces meet, on two
/// walls' shared edge, and the primitive decides the normal and material.
#[inline(always)]
pub(crate) fn nearer(t: f32, id: u32, best: (f32, u32)) -> bool {
    t < best.0 || (t == best.0 && id < best.1)
}

/// A box is skipped only when its entry distance exceeds the ray's current `tmax` by more
/// than `tmax · (CULL − 1) + Accel::slack`. The entry distance and a primitive's hit
/// distance round independently, so a primitive lying on a face of its own box (every
/// axis-aligned triangle) can have an entry distance past its hit distance: by ulps of t
/// for distant hits, by ulps of the scene's coordinates for close ones. Culling at `tmax`
/// exactly (as pbrt does) then loses that hit whenever a slightly farther one was found
/// first, and the result depends on traversal order. The slack (2⁻¹⁶ of t, plus 2⁻¹⁶ of the
/// scene's largest coordinate) costs a few extra box visits and keeps the scalar and packet
/// traversals on the same hits.
pub(crate) const CULL: f32 = 1.0 + 1.0 / 65536.0;

/// The distance past which a search ending at `tmax` skips boxes: `tmax · CULL + slack`
/// (see [`CULL`]; `slack` is the tree's absolute slack, [`Accel::slack`]).
#[inline(always)]
pub(crate) fn cull_at(tmax: f32, slack: f32) -> f32 {
    tmax * CULL + slack
}

/// How a queue of rays walks the wide BVH together ([`Accel::closest_many`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Walk {
    /// Each ray walks alone, [`INTERLEAVE`](wbvh::INTERLEAVE) walks at a time.
    Interleaved,
    /// The queue as one ray stream: each node tested once for all the rays that reach it.
    Stream,
}

/// Primitives reordered to the BVH's leaf order, with the BVH over them.
pub struct Accel {
    /// Per primitive, in BVH order (a traversal's primitive id indexes it): its material,
    /// light and where its shape is ([`Accel::prim`] puts them together).
    meta: Vec<Meta>,
    /// The shapes [`Meta::at`] indexes when there is no wide tree (which otherwise holds
    /// every shape: its leaf blocks hold the triangles' vertices).
    flat: Vec<Shape>,
    /// The binary tree (obvhs's, its leaves collapsed), walked one ray at a time by
    /// [`Accel::closest`]: kept only by [`Accel::build_reference`] (the tests' reference
    /// kernel) and where the wide tree cannot be encoded. Every other kernel walks the
    /// wide tree, so the renderer keeps one tree.
    pub(crate) bvh: Option<Bvh2>,
    /// Bounds of everything in the tree.
    bounds: (Vec3, Vec3),
    /// The same tree collapsed to [`Wide`] children per node, for single rays (`None`
    /// when empty or not encodable: the binary traversal then serves).
    pub(crate) wide: Option<WideBvh<Wide>>,
    /// Depth of the binary tree where one is kept (root = 1), which bounds its traversal
    /// stack; 0 without one.
    pub(crate) depth: usize,
    /// Absolute culling slack (see [`CULL`]).
    pub(crate) slack: f32,
    /// Seconds the BVH build took.
    pub build_seconds: f64,
    /// Where those seconds went.
    pub build_phases: BuildPhases,
    /// Whether incoherent queues walk interleaved ([`Accel::closest_many`]) rather than
    /// one ray at a time: when the wide tree is larger than the last-level cache
    /// ([`last_level_cache`]). Interleaving overlaps memory loads at the cost of more
    /// work per step, so it pays only where the walks wait on memory (measured:
    /// docs/performance.md). Either way the answers are the same.
    pub interleave: bool,
    /// The moving objects, whose primitives take the ids after the tree's (`None`
    /// without motion blur: a static scene pays nothing for it).
    moving: Option<Box<moving::Moving>>,
}

/// Seconds each phase of a BVH build took (`wavetrace bench` prints them): obvhs's PLOC
/// and reinsertion, the binary tree's leaf collapse (without a binary tree, the primitive
/// order it would give) and the primitives' ids in that order, the wide tree's SAH plan,
/// its fill and its leaf blocks, and the rest of the total (slots, metadata). With two or
/// more threads the first two of ours run beside the plan and the fill, so their sum can
/// exceed the total; the rest is then counted against the longer side.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct BuildPhases {
    /// obvhs's PLOC build of the binary tree.
    pub ploc: f64,
    /// obvhs's reinsertion optimisation.
    pub reinsertion: f64,
    /// Copying the binary tree and obvhs's leaf collapse of it where one is kept, else the
    /// primitive order the collapse would give ([`bvh2::collapsed_order`]).
    pub leaf_collapse: f64,
    /// The primitives' ids in leaf order.
    pub reorder: f64,
    /// The wide collapse's SAH plan.
    pub wide_plan: f64,
    /// Filling the wide nodes (leaves packed into blocks).
    pub wide_fill: f64,
    /// Building the leaf blocks.
    pub wide_blocks: f64,
    /// Everything else in the build's total.
    pub rest: f64,
}

/// Consecutive phase timings: each [`Lap::next`] returns the seconds since the last.
pub(crate) struct Lap(Instant);

impl Lap {
    /// Starts timing.
    pub(crate) fn start() -> Lap {
        Lap(Instant::now())
    }

    /// Seconds since the start or the last call.
    pub(crate) fn next(&mut self) -> f64 {
        let now = Instant::now();
        let s = (now - self.0).as_secs_f64();
        self.0 = now;
        s
    }
}

/// What the accelerator keeps of a primitive beside its shape (12 bytes).
#[derive(Clone, Copy, Debug)]
struct Meta {
    /// Index into the scene's materials.
    material: u32,
    /// Index into the scene's lights, or [`NO_LIGHT`].
    light: u32,
    /// The shape's slot in the wide tree ([`WideBvh::shape`]), or without one its index in
    /// [`Accel::flat`].
    at: u32,
}

/// Bytes of this machine's largest CPU cache (Linux sysfs; 32 MiB where it cannot be read),
/// read once per process (up to 16 files: 0.1 ms).
pub fn last_level_cache() -> usize {
    static BYTES: std::sync::OnceLock<usize> = std::sync::OnceLock::new();
    *BYTES.get_or_init(read_last_level_cache)
}

/// A tree this small fits any machine's last-level cache: its build need not ask.
const SMALLER_THAN_ANY_CACHE: usize = 512 << 10;

/// [`last_level_cache`] from sysfs.
fn read_last_level_cache() -> usize {
    let read =
        |k: usize, f: &str| std::fs::read_to_string(format!("/sys/devices/system/cpu/cpu0/cache/index{k}/{f}")).ok();
    let size = |s: String| {
        let s = s.trim();
        let (n, unit) = s.split_at(s.find(|c: char| !c.is_ascii_digit()).unwrap_or(s.len()));
        let n: usize = n.parse().ok()?;
        Some(
            n * match unit {
                "K" => 1 << 10,
                "M" => 1 << 20,
                _ => 1,
            },
        )
    };
    (0..8)
        .filter_map(|k| Some((read(k, "level")?.trim().parse::<u32>().ok()?, size(read(k, "size")?)?)))
        .max()
        .map_or(32 << 20, |(_, bytes)| bytes)
}

/// Starts loading the cache line at `p` (any address: nothing is read into the program).
/// A no-op off x86-64.
#[inline(always)]
pub(crate) fn prefetch_line<T>(p: *const T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch is a hint that never faults and reads nothing into the program;
    // SSE, which it needs, is part of every x86-64 target.
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(p.cast::<i8>())
    };
    #[cfg(not(target_arch = "x86_64"))]
    let _ = p;
}

/// The fewest binary nodes for which a build runs the primitive order beside the wide
/// layout ([`beside`]): starting and joining a thread takes about 23 µs, the order's side
/// about 30 ns a node (a 4 k-node side 0.12 ms), and a small scene's build should pay
/// nothing for threads.
const BESIDE_NODES: usize = 1 << 12;

/// `a()` and `b()`, on a thread of its own for `a` when `together` and rayon's pool has
/// more than one, else one after the other; and whether they ran side by side. Not
/// `rayon::join`: called from outside the pool, that runs both on pool threads, whose
/// fresh allocator arenas fault in every page the wide plan allocates (its phase took
/// twice as long on the dragon).
fn beside<A: Send, B>(together: bool, a: impl FnOnce() -> A + Send, b: impl FnOnce() -> B) -> (A, B, bool) {
    if !together || rayon::current_num_threads() < 2 {
        return (a(), b(), false);
    }
    std::thread::scope(|s| {
        let first = s.spawn(a);
        let second = b();
        (first.join().unwrap_or_else(|e| std::panic::resume_unwind(e)), second, true)
    })
}

/// `b` widened by one float outward on each side; every box of the trees the kernels
/// walk is. A ray parallel to an axis (a zero direction component, reciprocal
/// ±`f32::MAX`: [`inv_dir`]) that runs exactly in a box's face plane gets
/// `(bound − o) · inv` = 0 for that face: kept when it is the near face, skipped when it
/// is the far one. The triangle test still reports hits on that face (on an edge two
/// triangles share), so which of them a ray along a shared edge met depended on which box
/// the tree put each in. Widened, a face that primitives touch is never exactly in the
/// ray's plane on the wrong side, the box is kept, and every kernel meets every primitive
/// the ray touches, whatever the tree. Parents contain their children's widened boxes
/// (rounding outward is monotone).
pub(crate) fn widen(b: &obvhs::aabb::Aabb) -> obvhs::aabb::Aabb {
    let out = |v: glam::Vec3A, up: bool| {
        glam::Vec3A::from(v.to_array().map(|x| if up { x.next_up() } else { x.next_down() }))
    };
    obvhs::aabb::Aabb { min: out(b.min, false), max: out(b.max, true) }
}

/// Widens every node's box of `bvh` ([`widen`]).
fn widen_boxes(bvh: &mut Bvh2) {
    for node in &mut bvh.nodes {
        node.set_aabb(widen(node.aabb()));
    }
}

/// How much time the BVH build spends on the tree's quality (the names are Embree's
/// `RTC_BUILD_QUALITY_*`). Every kernel's answers are the same either way, bit for bit;
/// only the build's and the traversal's times differ (measured: docs/performance.md).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BvhQuality {
    /// obvhs's fast preset (a narrow PLOC search, little reinsertion): for renders that
    /// trace few rays per primitive.
    Low,
    /// obvhs's medium preset: the build 0.55–0.75× as long as `High`'s, incoherent rays
    /// through the wide kernel up to 11% slower on the scanned meshes.
    Medium,
    /// obvhs's slow preset (a wider PLOC search, more reinsertion).
    #[default]
    High,
}

impl BvhQuality {
    /// The quality that finishes a render soonest when it traces about `rays` rays through
    /// `prims` primitives: a better tree's faster traversal pays for its longer build only
    /// over many rays per primitive (thresholds measured: docs/performance.md).
    pub fn for_budget(rays: f64, prims: usize) -> BvhQuality {
        let per_prim = rays / prims.max(1) as f64;
        if per_prim < LOW_BELOW {
            BvhQuality::Low
        } else if per_prim < MEDIUM_BELOW {
            BvhQuality::Medium
        } else {
            BvhQuality::High
        }
    }
}

/// Rays per primitive below which [`BvhQuality::for_budget`] builds at `Low`.
const LOW_BELOW: f64 = 16.0;
/// Rays per primitive below which [`BvhQuality::for_budget`] builds at `Medium`.
const MEDIUM_BELOW: f64 = 64.0;

impl Accel {
    /// Builds the BVH over `prims` (which may be empty) with leaves of at most [`MAX_LEAF`]
    /// primitives, at [`BvhQuality::High`].
    pub fn build(prims: Vec<Primitive>) -> Accel {
        Accel::build_with(prims, MAX_LEAF, BvhQuality::High)
    }

    /// [`Accel::build`] with leaves of at most `max_leaf` primitives (1 to 64; the SAH
    /// decides below that) and the given quality.
    pub fn build_with(prims: Vec<Primitive>, max_leaf: u32, quality: BvhQuality) -> Accel {
        Accel::build_trees(prims, max_leaf, quality, false)
    }

    /// [`Accel::build`], keeping the binary tree beside the wide one, so that
    /// [`Accel::closest`] and [`Accel::occluded`] walk it: an independent reference the
    /// tests compare every other kernel with (the same primitive order and answers).
    pub fn build_reference(prims: Vec<Primitive>) -> Accel {
        Accel::build_trees(prims, MAX_LEAF, BvhQuality::High, true)
    }

    fn build_trees(prims: Vec<Primitive>, max_leaf: u32, quality: BvhQuality, keep_binary: bool) -> Accel {
        let start = Instant::now();
        if prims.is_empty() {
            return Accel {
                meta: Vec::new(),
                flat: Vec::new(),
                bvh: None,
                bounds: (Vec3::ZERO, Vec3::ZERO),
                wide: None,
                depth: 0,
                slack: 0.0,
                build_seconds: 0.0,
                build_phases: BuildPhases::default(),
                interleave: false,
                moving: None,
            };
        }
        let preset = match quality {
            BvhQuality::Low => BvhBuildParams::fast_build(),
            BvhQuality::Medium => BvhBuildParams::medium_build(),
            BvhQuality::High => BvhBuildParams::slow_build(),
        };
        // The slow preset's pre-splitting, which `build_bvh2` does not do, would duplicate
        // primitive references.
        let params = BvhBuildParams { max_prims_per_leaf: max_leaf.clamp(1, 64), pre_split: false, ..preset };
        let mut phases = BuildPhases::default();
        let fine = bvh2::build(&prims, &params, &mut phases);
        // The primitive order (obvhs's leaf collapse, which fixes the ids the tie rule
        // ranks) and the wide tree's layout both only read the binary tree: with a second
        // thread and a tree worth it they run side by side, each timing its own phases.
        let (mut left, mut right) = (phases, phases);
        let ((mut bvh, order, id_of), layout, concurrent) = beside(
            fine.nodes.len() >= BESIDE_NODES,
            || {
                let mut lap = Lap::start();
                // The binary tree only where it is kept. Without it, the same order is
                // computed.
                let bvh = keep_binary.then(|| bvh2::collapse(&fine, &params));
                let order = match &bvh {
                    Some(b) => b.primitive_indices.clone(),
                    None => bvh2::collapsed_order(&fine, &params),
                };
                left.leaf_collapse = lap.next();
                // Primitive ids are their places in `order`; the wide tree and the tables
                // below read the input through it, so the primitives are never copied in
                // that order.
                let mut id_of = vec![0u32; prims.len()];
                for (new, &old) in order.iter().enumerate() {
                    id_of[old as usize] = new as u32;
                }
                left.reorder = lap.next();
                (bvh, order, id_of)
            },
            || WideBvh::lay_out(&fine, &prims, params.max_prims_per_leaf, &mut right),
        );
        let mut phases = BuildPhases { wide_plan: right.wide_plan, wide_fill: right.wide_fill, ..left };
        let wide = layout.map(|l| l.finish(&id_of, &mut phases));
        let mut depth = 0;
        if let Some(b) = &mut bvh {
            widen_boxes(b);
            // obvhs sizes its traversal stack by `max_depth` (96 by default); a pathological
            // mesh (found by fuzzing) builds deeper trees, which take obvhs's traversal (see
            // `bvh2::STACK_DEPTH`), so give it a stack that holds them, as obvhs's own
            // insertion does.
            depth = b.depth(0);
            b.max_depth = (depth + 1).max(b.max_depth);
            #[cfg(debug_assertions)]
            b.validate(&prims, false, params.pre_split);
        }
        let input = prims;
        let root = widen(fine.nodes[0].aabb());
        let scale = Vec3::from(root.min).abs().max(Vec3::from(root.max).abs()).max_element();
        let slack = if scale.is_finite() { scale / 65536.0 } else { 0.0 };
        if wide.is_none() && bvh.is_none() {
            // Not encodable as a wide tree (over 2^25 leaf blocks): the binary tree serves,
            // so build again with it.
            return Accel::build_trees(input, max_leaf, quality, true);
        }
        let interleave =
            wide.as_ref().is_some_and(|w| w.bytes() > SMALLER_THAN_ANY_CACHE && w.bytes() > last_level_cache());
        let bounds = (root.min.into(), root.max.into());
        // The wide tree holds every shape; without one, the shapes are kept here.
        let at = match &wide {
            Some(w) => w.slots(input.len()),
            None => (0..input.len() as u32).collect(),
        };
        let flat = match wide {
            Some(_) => Vec::new(),
            None => order.iter().map(|&i| input[i as usize].shape).collect(),
        };
        let meta = order
            .iter()
            .zip(at)
            .map(|(&i, at)| {
                let p = &input[i as usize];
                Meta { material: p.material, light: p.light, at }
            })
            .collect();
        let build_seconds = start.elapsed().as_secs_f64();
        let (order_side, layout_side) = (phases.leaf_collapse + phases.reorder, phases.wide_plan + phases.wide_fill);
        let sides = if concurrent { order_side.max(layout_side) } else { order_side + layout_side };
        let named = phases.ploc + phases.reinsertion + sides + phases.wide_blocks;
        let build_phases = BuildPhases { rest: (build_seconds - named).max(0.0), ..phases };
        Accel { meta, flat, bvh, bounds, wide, depth, slack, build_seconds, build_phases, interleave, moving: None }
    }

    /// Adds moving objects: each one's motion and its primitives in object space (built
    /// like a static scene), bounded over `shutter`. Their primitives take the ids after
    /// the tree's, object after object, in each one's tree order.
    pub fn attach_moving(&mut self, objects: Vec<(crate::motion::Motion, Accel)>, shutter: [f32; 2]) {
        let mut instances = Vec::with_capacity(objects.len());
        for (motion, accel) in objects {
            let first = self.meta.len() as u32;
            self.meta.extend(accel.meta.iter().map(|m| Meta { at: u32::MAX, ..*m }));
            instances.push(moving::Instance::new(motion, accel, first, shutter));
        }
        self.moving = Some(Box::new(moving::Moving::new(instances, shutter)));
    }

    /// Every primitive id: the tree's and the moving objects'.
    pub fn ids(&self) -> usize {
        self.meta.len()
    }

    /// Primitive `id`'s shape in the world at `time`: the tree's shapes do not move.
    #[inline]
    pub fn shape_at(&self, id: u32, time: f32) -> Shape {
        match &self.moving {
            Some(m) if id as usize >= self.len() => m.shape_at(id, time),
            _ => self.prim(id).shape,
        }
    }

    /// The moving objects (`None` without motion blur).
    #[inline]
    pub fn moving(&self) -> Option<&moving::Moving> {
        self.moving.as_deref()
    }

    /// The moving objects when primitive `id` is one of theirs (`None` for the tree's).
    #[inline]
    pub fn moving_of(&self, id: u32) -> Option<&moving::Moving> {
        self.moving.as_deref().filter(|_| self.is_moving(id))
    }

    /// True when primitive `id` belongs to a moving object.
    #[inline]
    pub fn is_moving(&self, id: u32) -> bool {
        self.moving.is_some() && id as usize >= self.len() && (id as usize) < self.meta.len()
    }

    /// Bytes of the acceleration structure: the binary nodes, the wide tree (with every
    /// shape it holds) and the primitives' materials, lights and shapes kept beside it, in
    /// that order.
    pub fn bytes(&self) -> [usize; 3] {
        [
            self.bvh.as_ref().map_or(0, |b| b.nodes.len() * std::mem::size_of::<obvhs::bvh2::node::Bvh2Node>()),
            self.wide.as_ref().map_or(0, WideBvh::bytes),
            self.meta.len() * std::mem::size_of::<Meta>() + self.flat.len() * std::mem::size_of::<Shape>(),
        ]
    }

    /// Primitives in the tree (the moving objects' come after them: [`Accel::ids`]).
    pub fn len(&self) -> usize {
        match &self.moving {
            Some(m) => self.meta.len() - m.len(),
            None => self.meta.len(),
        }
    }

    /// True when the tree holds no primitive.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Primitive `id` of the tree (a traversal's primitive index: BVH order, not the
    /// scene's), put together from where the tree keeps its parts. A moving primitive's
    /// shape depends on the time: [`Accel::shape_at`]. Always inlined: out of line, its
    /// 48 bytes came back through memory, and a texture's UV (`surface::uv_at`) waited
    /// on their stores (shade 74 → 62 ns a hit on `scenes/gloss/frosted.xml`).
    #[inline(always)]
    pub fn prim(&self, id: u32) -> Primitive {
        let m = self.meta[id as usize];
        let shape = match &self.wide {
            Some(w) => w.shape(m.at),
            None => self.flat[m.at as usize],
        };
        Primitive { shape, material: m.material, light: m.light }
    }

    /// Primitive `id`'s material (an index into the scene's materials), without putting
    /// its shape together.
    #[inline]
    pub fn material(&self, id: u32) -> u32 {
        self.meta[id as usize].material
    }

    /// Primitive `id`'s light (an index into the scene's lights), or [`NO_LIGHT`].
    #[inline]
    pub fn light(&self, id: u32) -> u32 {
        self.meta[id as usize].light
    }

    /// Every primitive, by id ([`Accel::prim`]).
    pub fn prims(&self) -> impl ExactSizeIterator<Item = Primitive> + '_ {
        (0..self.len() as u32).map(|id| self.prim(id))
    }

    /// Sets primitive `id`'s material.
    pub fn set_material(&mut self, id: u32, material: u32) {
        self.meta[id as usize].material = material;
    }

    /// Bounds of everything in the tree (zero-size at the origin when empty).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.bounds
    }

    /// Closest hit along `ray`: `(t, primitive index)`, or `None`: one ray through the
    /// wide tree (all of a node's children in one SIMD test; the binary tree where no wide
    /// one could be encoded). Counts its work in `c` when `COUNT`. The renderer's queues
    /// go through [`Tracer::closest`](tracer::Tracer::closest), which picks the kernel;
    /// every kernel returns this hit, bit for bit.
    #[inline]
    pub fn closest<const COUNT: bool>(&self, ray: Ray, c: &mut Traversal) -> Option<(f32, u32)> {
        match &self.wide {
            Some(w) => w.closest::<COUNT>(self.slack, ray, c),
            None => bvh2::closest::<COUNT>(self, ray, c),
        }
    }

    /// True when some non-emitting primitive blocks `ray`'s segment; stops at the first
    /// blocker. Area lights never block shadow rays. One ray through the wide tree (the
    /// binary one where there is no wide tree); queues go through
    /// [`Tracer::occluded`](tracer::Tracer::occluded).
    #[inline]
    pub fn occluded<const COUNT: bool>(&self, ray: Ray, c: &mut Traversal) -> bool {
        match &self.wide {
            Some(w) => w.occluded::<COUNT>(self.slack, ray, c),
            None => bvh2::occluded::<COUNT>(self, ray, c),
        }
    }

    /// [`Accel::closest`] through the binary tree where it is kept
    /// ([`Accel::build_reference`]): the tests' independent reference.
    #[inline]
    pub(crate) fn closest_binary<const COUNT: bool>(&self, ray: Ray, c: &mut Traversal) -> Option<(f32, u32)> {
        match &self.bvh {
            Some(_) => bvh2::closest::<COUNT>(self, ray, c),
            None => self.closest::<COUNT>(ray, c),
        }
    }

    /// [`Accel::occluded`] through the binary tree where it is kept.
    #[inline]
    pub(crate) fn occluded_binary<const COUNT: bool>(&self, ray: Ray, c: &mut Traversal) -> bool {
        match &self.bvh {
            Some(_) => bvh2::occluded::<COUNT>(self, ray, c),
            None => self.occluded::<COUNT>(ray, c),
        }
    }

    /// [`Accel::closest`] of `n` rays (`ray(i)`) through the wide BVH as `walk` says:
    /// [`INTERLEAVE`](wbvh::INTERLEAVE) at a time so that their memory loads overlap, or
    /// as one ray stream (`wbvh`'s stream module). `out(i, hit)` for every ray, in the
    /// order they finish (index order for a stream), each the same hit as alone.
    #[inline]
    pub(crate) fn closest_many<const COUNT: bool>(
        &self,
        walk: Walk,
        n: usize,
        ray: impl Fn(usize) -> Ray,
        mut out: impl FnMut(usize, Option<(f32, u32)>),
        c: &mut Traversal,
    ) {
        match (&self.wide, walk) {
            (Some(w), Walk::Interleaved) => w.closest_many::<COUNT>(self.slack, n, ray, out, c),
            (Some(w), Walk::Stream) => w.closest_stream::<COUNT>(self.slack, n, ray, out, c),
            (None, _) => (0..n).for_each(|i| out(i, bvh2::closest::<COUNT>(self, ray(i), c))),
        }
    }

    /// [`Accel::occluded`] of `n` rays, walked as [`Accel::closest_many`] walks them:
    /// `out(i, blocked)` for every ray.
    #[inline]
    pub(crate) fn occluded_many<const COUNT: bool>(
        &self,
        walk: Walk,
        n: usize,
        ray: impl Fn(usize) -> Ray,
        mut out: impl FnMut(usize, bool),
        c: &mut Traversal,
    ) {
        match (&self.wide, walk) {
            (Some(w), Walk::Interleaved) => w.occluded_many::<COUNT>(self.slack, n, ray, out, c),
            (Some(w), Walk::Stream) => w.occluded_stream::<COUNT>(self.slack, n, ray, out, c),
            (None, _) => (0..n).for_each(|i| out(i, bvh2::occluded::<COUNT>(self, ray(i), c))),
        }
    }
}
