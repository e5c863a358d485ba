//! `wavetrace bench`: fixed ray sets taken from a scene (or, with `--mesh`/`--sphere`,
//! around a bare mesh: [`bench_mesh`](super::bench_mesh)), traced by each traversal kernel
//! through the renderer's own intersect and shadow stages, timed over repetitions.
//!
//! The scene sets (all deterministic for a scene and seed):
//! - `primary`: the scene's uniform-mode camera rays, in the renderer's order (16×16
//!   tiles, a pixel's samples together);
//! - `shadow`: the shade stage's uniform-mode shadow rays from those rays' hits (every
//!   k-th one when there are more than the cap), any-hit;
//! - `secondary`: one cosine-distributed diffuse bounce from every diffuse primary hit
//!   (incoherent), closest-hit.
//!
//! Each set is cut into chunks of [`CHUNK`] rays (the size of a render wave of camera rays)
//! that threads take in turn; the packet kernel's reordering of bounce and shadow rays runs
//! inside the stage, so its cost is part of the packet kernel's time.

use glam::Vec3;
use rayon::prelude::*;
use serde::Serialize;
use std::time::Instant;

use crate::accel::packet::PacketConfig;
use crate::accel::tracer::{Coherence, Kernel, Tracer, Width};
use crate::accel::{Accel, BuildPhases};
use crate::error::{Error, Result};
use crate::film::tiles;
use crate::light::uniform_shadow_rays;
use crate::queue::{FilmQueue, HitQueue, RayQueue, ShadowQueue};
use crate::sampling::{dim, hash, to_unit};
use crate::scene::Scene;
use crate::simd::LANES;
use crate::stages::{camera, intersect, shadow};
use crate::surface::diffuse_surface;

/// Rays per chunk: one render wave of camera rays.
pub const CHUNK: usize = 4096;

/// What to measure.
#[derive(Clone, Debug)]
pub struct BenchOptions {
    /// Worker threads.
    pub threads: usize,
    /// Timed repetitions per set and kernel (the median is reported).
    pub reps: usize,
    /// Most rays per set (larger sets keep every k-th ray).
    pub max_rays: usize,
    /// Lanes per packet: 4, 8 or 16.
    pub lanes: usize,
    /// How packets are formed and traced.
    pub packet: PacketConfig,
    /// Hybrid kernel: leaves reached per 100 rays above which a queue leaves packets.
    pub max_leaves: u32,
    /// Time by the process's CPU time instead of the wall clock (on a shared machine the
    /// wall clock also counts the time other processes held the cores).
    pub cpu_time: bool,
    /// The kernels to measure, by name ([`KERNELS`]); empty: all of them.
    pub kernels: Vec<&'static str>,
}

/// The kernels `wavetrace bench` measures, by the names its table and JSON use.
pub const KERNELS: [&str; 5] = ["packet", "wide", "interleaved", "stream", "hybrid"];

/// The kernel the renderer runs (`render.packets = true`), by its name in [`KERNELS`].
pub const RENDERER_KERNEL: &str = "hybrid";

impl Default for BenchOptions {
    fn default() -> Self {
        BenchOptions {
            threads: 1,
            reps: 5,
            max_rays: 1 << 20,
            lanes: LANES,
            packet: PacketConfig::RENDER,
            max_leaves: RENDER_MAX_LEAVES,
            cpu_time: false,
            kernels: Vec::new(),
        }
    }
}

/// The renderer's hybrid threshold ([`Kernel::HYBRID`]'s `max_leaves`).
pub const RENDER_MAX_LEAVES: u32 = match Kernel::HYBRID {
    Kernel::Hybrid { max_leaves, .. } => max_leaves,
    _ => 0,
};

/// CPU seconds this process has used, all threads (the wall clock where unavailable).
fn cpu_seconds() -> Option<f64> {
    #[cfg(unix)]
    {
        let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
        // SAFETY: clock_gettime only writes the timespec it is given.
        let ok = unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut ts) } == 0;
        ok.then_some(ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9)
    }
    #[cfg(not(unix))]
    None
}

impl BenchOptions {
    /// Refuses options that measure nothing.
    pub fn check(&self) -> Result<()> {
        if self.threads == 0 || self.reps == 0 || self.max_rays == 0 {
            return Err(Error::input("--threads, --reps and --max-rays must be at least 1"));
        }
        if ![4, 8, 16].contains(&self.lanes) {
            return Err(Error::input(format!("--lanes {}: expected 4, 8 or 16", self.lanes)));
        }
        Ok(())
    }
}

/// One ray set traced with one kernel.
#[derive(Clone, Debug, Serialize)]
pub struct SetResult {
    /// The set's name (`primary`, `shadow`, `secondary`; with a mesh `camera`, `shadow`,
    /// `bounce`, `random`, `bounce-shadow`).
    pub set: &'static str,
    /// `packet`, `wide`, `interleaved`, `stream` or `hybrid`.
    pub kernel: &'static str,
    /// Rays in the set.
    pub rays: usize,
    /// Median over the repetitions of rays per second, in millions.
    pub mrays_per_s: f64,
}

/// Everything `wavetrace bench` prints.
#[derive(Clone, Debug, Serialize)]
pub struct BenchReport {
    /// Seconds the BVH build took when the scene was loaded (binary tree and its wide
    /// collapse).
    pub bvh_build_seconds: f64,
    /// Where the build's seconds went, phase by phase.
    pub bvh_build_phases: BuildPhases,
    /// Primitives in the tree.
    pub primitives: usize,
    /// Bytes per primitive of the binary nodes, the wide nodes and the primitives.
    pub bytes_per_primitive: [f64; 3],
    /// Worker threads.
    pub threads: usize,
    /// The kernel the renderer runs ([`RENDERER_KERNEL`]).
    pub renderer_kernel: &'static str,
    /// `"wall"` or `"cpu"`: which clock the Mrays/s figures divide by.
    pub clock: &'static str,
    /// One entry per set and kernel.
    pub sets: Vec<SetResult>,
}

/// A fixed set of rays: closest-hit ones in a ray queue, or any-hit shadow segments.
pub enum RaySet {
    /// Closest-hit rays (camera or bounce), and which they are (it decides the packet
    /// order, as in the renderer).
    Closest(Vec<RayQueue>, Coherence),
    /// Shadow rays.
    AnyHit(Vec<ShadowQueue>),
}

impl RaySet {
    /// Number of rays.
    pub fn len(&self) -> usize {
        match self {
            RaySet::Closest(c, _) => c.iter().map(|q| q.len()).sum(),
            RaySet::AnyHit(c) => c.iter().map(|q| q.len()).sum(),
        }
    }

    /// True when the set has no rays.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Every ray as (origin, direction, tmax), in order (tmax infinite for closest-hit sets).
    pub fn rays(&self) -> Vec<(Vec3, Vec3, f32)> {
        match self {
            RaySet::Closest(c, _) => {
                c.iter().flat_map(|q| (0..q.len()).map(move |i| (q.origin(i), q.dir(i), f32::INFINITY))).collect()
            }
            RaySet::AnyHit(c) => {
                c.iter().flat_map(|q| (0..q.len()).map(move |i| (q.origin(i), q.dir(i), q.tmax[i]))).collect()
            }
        }
    }
}

/// A closest-hit set of `items` (origin, direction) in chunks of [`CHUNK`].
pub(crate) fn closest_set(items: &[(Vec3, Vec3)], coherence: Coherence) -> RaySet {
    let chunk = |c: &[(Vec3, Vec3)]| {
        let mut q = RayQueue::default();
        for (k, &(o, d)) in c.iter().enumerate() {
            q.push(o, d, k as u32, Vec3::ONE, (coherence == Coherence::Bounce) as u32, 0, 0, 0.0, None);
        }
        q
    };
    RaySet::Closest(items.chunks(CHUNK).map(chunk).collect(), coherence)
}

/// An any-hit set of `items` (origin, direction, tmax) in chunks of [`CHUNK`].
pub(crate) fn any_hit_set(items: &[(Vec3, Vec3, f32)]) -> RaySet {
    let chunk = |c: &[(Vec3, Vec3, f32)]| {
        let mut q = ShadowQueue::default();
        for (k, &(o, d, t)) in c.iter().enumerate() {
            q.push(o, d, t, k as u32, Vec3::ONE, None);
        }
        q
    };
    RaySet::AnyHit(items.chunks(CHUNK).map(chunk).collect())
}

/// Keeps every k-th pushed item, doubling k (and dropping every other kept item) whenever
/// twice `cap` are kept: a uniform stride over a stream of unknown length.
struct Thinned<T> {
    items: Vec<T>,
    stride: usize,
    seen: usize,
    cap: usize,
}

impl<T> Thinned<T> {
    fn new(cap: usize) -> Self {
        Thinned { items: Vec::new(), stride: 1, seen: 0, cap: cap.max(1) }
    }

    fn push(&mut self, x: T) {
        if self.seen.is_multiple_of(self.stride) {
            self.items.push(x);
            if self.items.len() >= 2 * self.cap {
                let mut k = 0;
                self.items.retain(|_| {
                    k += 1;
                    k % 2 == 1
                });
                self.stride *= 2;
            }
        }
        self.seen += 1;
    }
}

/// A unit direction around `n` with density cos θ / π.
pub(crate) fn cosine_direction(n: Vec3, u1: f32, u2: f32) -> Vec3 {
    let (t, b) = n.any_orthonormal_pair();
    let r = u1.sqrt();
    let phi = std::f32::consts::TAU * u2;
    (r * phi.cos() * t + r * phi.sin() * b + (1.0 - u1).max(0.0).sqrt() * n).normalize()
}

/// Builds the three ray sets of `scene` (the shadow set is uniform mode's shadow rays
/// whatever the scene's shadow mode).
pub fn ray_sets(scene: &Scene, max_rays: usize) -> [(&'static str, RaySet); 3] {
    let s = &scene.settings;
    let spp = s.aa_samples as u64 * s.dof_samples as u64;
    let (mut primary, mut shadows, mut bounces) =
        (Thinned::new(max_rays), Thinned::new(max_rays), Thinned::new(max_rays));
    let (mut rays, mut hits, mut shadow) = (RayQueue::default(), HitQueue::default(), Vec::new());
    let mut tracer = Tracer::new(&scene.accel, Kernel::Wide, false);
    for tile in tiles(s.width, s.height) {
        camera::generate(scene, &tile, camera::UniformPass::of(s), 0..tile.pixels() as u64 * spp, &mut rays);
        intersect::intersect(&mut tracer, &rays, Coherence::Camera, &mut hits);
        shadow.clear();
        for i in 0..rays.len() {
            primary.push((rays.origin(i), rays.dir(i)));
            if let Some(surf) = diffuse_surface(scene, &rays, &hits, i) {
                let h = |d: u32| to_unit(hash(&[surf.key, surf.sample, d, dim::BENCH]));
                let (u1, u2) = (h(0), h(1));
                bounces.push((surf.o, cosine_direction(surf.n, u1, u2)));
                for li in 0..scene.lights.len() {
                    uniform_shadow_rays(scene, &surf, li, |wi, tmax, _| shadow.push((surf.o, wi, tmax)));
                }
            }
        }
        shadow.iter().for_each(|&r| shadows.push(r));
    }
    [
        ("primary", closest_set(&primary.items, Coherence::Camera)),
        ("shadow", any_hit_set(&shadows.items)),
        ("secondary", closest_set(&bounces.items, Coherence::Bounce)),
    ]
}

/// Seconds one trace took by each clock.
#[derive(Clone, Copy, Debug)]
pub struct Seconds {
    /// Wall-clock seconds.
    pub wall: f64,
    /// CPU seconds of the whole process (the wall time where the platform has no CPU clock).
    pub cpu: f64,
}

/// Traces `set` once on `pool` with `kernel`; returns the time and a checksum of the
/// results (hits with their distances, or unblocked rays) so kernels can be compared.
pub fn trace(accel: &Accel, set: &RaySet, pool: &rayon::ThreadPool, kernel: Kernel) -> (Seconds, u64) {
    let start = Instant::now();
    let cpu0 = cpu_seconds();
    // Each thread builds its own tracer (its scratch is per thread); no counters.
    let tracer = || Tracer::new(accel, kernel, false);
    let sum: u64 = pool.install(|| match set {
        RaySet::Closest(chunks, coherence) => chunks
            .par_iter()
            .map_init(
                || (tracer(), HitQueue::default()),
                |(tracer, hits), q| {
                    intersect::intersect(tracer, q, *coherence, hits);
                    hits.t.iter().filter(|t| t.is_finite()).map(|t| t.to_bits() as u64).sum::<u64>()
                },
            )
            .sum(),
        RaySet::AnyHit(chunks) => chunks
            .par_iter()
            .map_init(
                || (tracer(), FilmQueue::default()),
                |(tracer, film), q| {
                    film.clear();
                    shadow::occlusion(tracer, q, film) as u64
                },
            )
            .sum(),
    });
    let wall = start.elapsed().as_secs_f64();
    let cpu = cpu0.zip(cpu_seconds()).map_or(wall, |(a, b)| b - a);
    (Seconds { wall, cpu }, sum)
}

/// The kernels `wavetrace bench` measures, with their column names.
fn kernels(opts: &BenchOptions) -> [(&'static str, Kernel); 5] {
    [
        (KERNELS[0], Kernel::Packet(Width::of(opts.lanes), opts.packet)),
        (KERNELS[1], Kernel::Wide),
        (KERNELS[2], Kernel::Interleaved),
        (KERNELS[3], Kernel::Stream),
        (KERNELS[4], Kernel::Hybrid { width: Width::of(opts.lanes), cfg: opts.packet, max_leaves: opts.max_leaves }),
    ]
}

/// Measures every set of `sets` with every kernel, interleaved: each repetition traces
/// the set with each kernel in turn, an untimed pass then a timed one (warm caches), so
/// drifting load on the machine touches every kernel alike.
pub fn run(accel: &Accel, sets: &[(&'static str, RaySet)], opts: &BenchOptions) -> Result<BenchReport> {
    opts.check()?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.threads)
        .build()
        .map_err(|e| Error::Internal(format!("cannot start {} threads: {e}", opts.threads)))?;
    let kernels: Vec<_> =
        kernels(opts).into_iter().filter(|k| opts.kernels.is_empty() || opts.kernels.contains(&k.0)).collect();
    let mut out = Vec::new();
    for (name, set) in sets {
        let checks: Vec<u64> = kernels.iter().map(|&(_, k)| trace(accel, set, &pool, k).1).collect();
        if let Some(k) = (1..kernels.len()).find(|&k| checks[k] != checks[0]) {
            return Err(Error::Internal(format!(
                "{name} set: the {} kernel found {} where the {} kernel found {}",
                kernels[k].0, checks[k], kernels[0].0, checks[0]
            )));
        }
        let mut secs = vec![Vec::new(); kernels.len()];
        for _ in 0..opts.reps {
            for (k, &(_, kernel)) in kernels.iter().enumerate() {
                // An untimed pass first, so each kernel is timed on caches holding its own
                // structures, not the previous kernel's (as a renderer running one kernel,
                // or Embree tracing set after set in benches/embree.py, would be).
                trace(accel, set, &pool, kernel);
                let t = trace(accel, set, &pool, kernel).0;
                secs[k].push(if opts.cpu_time { t.cpu } else { t.wall });
            }
        }
        for (k, secs) in secs.iter_mut().enumerate() {
            secs.sort_by(f64::total_cmp);
            let median = secs[secs.len() / 2];
            let mrays = if median > 0.0 { set.len() as f64 / median / 1e6 } else { 0.0 };
            out.push(SetResult { set: name, kernel: kernels[k].0, rays: set.len(), mrays_per_s: mrays });
        }
    }
    let n = accel.len().max(1) as f64;
    Ok(BenchReport {
        bvh_build_seconds: accel.build_seconds,
        bvh_build_phases: accel.build_phases,
        primitives: accel.len(),
        bytes_per_primitive: accel.bytes().map(|b| b as f64 / n),
        threads: opts.threads,
        renderer_kernel: RENDERER_KERNEL,
        clock: if opts.cpu_time { "cpu" } else { "wall" },
        sets: out,
    })
}

/// [`run`] on the scene's own ray sets ([`ray_sets`]).
pub fn run_scene(scene: &Scene, opts: &BenchOptions) -> Result<BenchReport> {
    opts.check()?;
    run(&scene.accel, &ray_sets(scene, opts.max_rays), opts)
}

impl BenchReport {
    /// The human-readable table: Mrays/s per set and kernel.
    pub fn table(&self) -> String {
        let [b2, bw, bp] = self.bytes_per_primitive;
        let binary = if b2 > 0.0 { format!("binary nodes {b2:.0}, ") } else { String::new() };
        let mut t = format!(
            "BVH build {:.3} s, {} primitives, bytes/primitive: {binary}wide nodes and leaf blocks {:.0}, primitives {:.0}; {} thread{}, {} clock\n",
            self.bvh_build_seconds,
            self.primitives,
            bw,
            bp,
            self.threads,
            if self.threads == 1 { "" } else { "s" },
            self.clock,
        );
        let p = &self.bvh_build_phases;
        t += &format!(
            "build phases (s): PLOC {:.4}, reinsertion {:.4}, leaf collapse {:.4}, reorder {:.4}, wide plan {:.4}, fill {:.4}, blocks {:.4}, rest {:.4}\n",
            p.ploc, p.reinsertion, p.leaf_collapse, p.reorder, p.wide_plan, p.wide_fill, p.wide_blocks, p.rest
        );
        t += &format!("{:<14} {:>9}  Mrays/s:", "set", "rays");
        // One row per set, one column per kernel measured.
        let per = self.sets.iter().take_while(|r| r.set == self.sets[0].set).count().max(1);
        for r in self.sets.iter().take(per) {
            t += &format!(" {:>11}", r.kernel);
        }
        t += "\n";
        for row in self.sets.chunks(per) {
            t += &format!("{:<14} {:>9}          ", row[0].set, row[0].rays);
            for r in row {
                t += &format!(" {:>11.2}", r.mrays_per_s);
            }
            t += "\n";
        }
        t
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thinning_keeps_a_uniform_stride() {
        let mut t = Thinned::new(10);
        for i in 0..1000 {
            t.push(i);
        }
        assert!(t.items.len() < 20 && t.items.len() >= 10, "{}", t.items.len());
        assert!(t.items.windows(2).all(|w| w[1] - w[0] == t.stride));
        assert_eq!(t.items[0], 0);
    }

    #[test]
    fn cosine_directions_stay_in_the_hemisphere() {
        let n = Vec3::new(0.3, -0.5, 0.8).normalize();
        for i in 0..100 {
            let d = cosine_direction(n, i as f32 / 100.0, (i * 37 % 100) as f32 / 100.0);
            assert!(d.dot(n) >= 0.0 && (d.length() - 1.0).abs() < 1e-5);
        }
    }
}
