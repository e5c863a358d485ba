//! The packet kernels give the same renders as single rays: same ray counts and the same
//! image bit for bit (the shadow stage reorders rays into packets but writes the film in
//! queue order).

mod support;

use support::*;

fn same_render(text: &str, sets: &[&str]) {
    let mut without: Vec<&str> = sets.to_vec();
    without.push("render.packets=false");
    let off = render_text(text, &without, 2);
    let mut with: Vec<&str> = sets.to_vec();
    with.push("render.packets=true");
    let on = render_text(text, &with, 2);
    assert_eq!(on.stats.kinds(), off.stats.kinds(), "same rays of every kind");
    // The same hits, and the film sums in queue order either way: the same bits.
    assert_eq!(on.image, off.image);
    // The packet kernel ran with packets on, and only then.
    let packet_rays = |o: &wavetrace::RenderOutput| o.stats.stages.iter().map(|c| c.packet_rays).sum::<u64>();
    assert!(packet_rays(&on) > 0 && packet_rays(&off) == 0);
}

#[test]
fn default_scene_with_packets() {
    same_render(wavetrace::DEFAULT_SCENE, &["render.width=40", "render.height=30", "render.aa.samples=4"]);
    same_render(
        wavetrace::DEFAULT_SCENE,
        &["render.width=40", "render.height=30", "render.aa.mode=adaptive", "render.shadows.mode=adaptive"],
    );
}

#[test]
fn bunny_with_packets() {
    let text =
        std::fs::read_to_string(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/bunny.toml")).unwrap();
    same_render(&text, &["render.width=32", "render.height=24", "render.aa.samples=2", "render.shadows.samples=2"]);
}

/// The BVH's build quality changes the tree, never a hit: the same rays of every kind and
/// the same image, with packets (the hybrid: packets and the wide BVH) and without (the
/// wide BVH one ray at a time).
#[test]
fn bvh_quality_changes_no_bit() {
    let text =
        std::fs::read_to_string(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/bunny.toml")).unwrap();
    for packets in ["render.packets=true", "render.packets=false"] {
        let sets = ["render.width=32", "render.height=24", "render.aa.samples=2", "render.shadows.samples=2", packets];
        let high = render_text(&text, &[&sets[..], &["render.bvh=high"]].concat(), 2);
        let nodes = |o: &wavetrace::RenderOutput| o.stats.stages.iter().map(|c| c.nodes).sum::<u64>();
        for other in ["render.bvh=medium", "render.bvh=low"] {
            let o = render_text(&text, &[&sets[..], &[other]].concat(), 2);
            assert_eq!(high.stats.kinds(), o.stats.kinds(), "same rays of every kind ({packets}, {other})");
            assert_eq!(high.image, o.image, "same image ({packets}, {other})");
            // Different trees: the traversal counters say so (else the test compares nothing).
            assert_ne!(nodes(&high), nodes(&o), "the two builds made the same tree ({packets}, {other})");
        }
    }
}

/// `render.bvh = "auto"` (the default) builds fast for a render that traces few rays per
/// primitive and well for one that traces many; a named quality is kept whatever the budget.
#[test]
fn auto_bvh_quality_follows_the_ray_budget() {
    use wavetrace::accel::BvhQuality;
    let text =
        std::fs::read_to_string(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/bunny.toml")).unwrap();
    let quality = |sets: &[&str]| scene(&text, sets).settings.bvh;
    // 8×8 pixels, one sample, 1 + 2 shadow rays: under 0.01 rays per triangle.
    let small = ["render.width=8", "render.height=8", "render.aa.samples=1", "render.shadows.samples=1"];
    assert_eq!(quality(&small), BvhQuality::Low);
    // The scene as it is: 320×240, 8 samples, 8 shadow samples of 2 lights: ~150 per triangle.
    assert_eq!(quality(&[]), BvhQuality::High);
    assert_eq!(quality(&[&small[..], &["render.bvh=high"]].concat()), BvhQuality::High);
    assert_eq!(BvhQuality::for_budget(1e6, 0), BvhQuality::High, "an empty scene");
}

// ---------------------------------------------------------------------------------------
// Kernel equivalence on random rays, and closed meshes shot from inside.

use glam::Vec3;
use wavetrace::accel::packet::{PacketConfig, PacketWork};
use wavetrace::accel::{Accel, Primitive, Ray, Shape, Traversal, NO_LIGHT};
use wavetrace::simd::{Vector, LANES};
use wavetrace::tools::bench_mesh::icosphere;
use wavetrace::tools::kernels;
use wide::{f32x16, f32x4, f32x8};

/// A deterministic uniform stream in [0, 1).
struct Rng(u32);

impl Rng {
    fn next(&mut self) -> f32 {
        self.0 = wavetrace::sampling::mix(self.0.wrapping_add(0x9e37_79b9));
        wavetrace::sampling::to_unit(self.0)
    }
    fn dir(&mut self) -> Vec3 {
        let z = 1.0 - 2.0 * self.next();
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = std::f32::consts::TAU * self.next();
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }
}

/// `n` rays: coherent ones (a pinhole grid looking at the bounds, row by row) or
/// incoherent ones (origins in the bounds, uniform directions).
fn rays(accel: &Accel, n: usize, coherent: bool, seed: u32) -> (Vec<Vec3>, Vec<Vec3>) {
    let (lo, hi) = accel.bounds();
    let (c, diag) = ((lo + hi) * 0.5, (hi - lo).length().max(1e-3));
    let mut rng = Rng(seed);
    let side = (n as f32).sqrt().ceil() as usize;
    let eye = c + Vec3::new(0.3, 0.4, 1.0).normalize() * diag * 1.5;
    let fwd = (c - eye).normalize();
    let right = fwd.cross(Vec3::Y).normalize();
    let up = right.cross(fwd);
    (0..n)
        .map(|i| {
            if coherent {
                let (x, y) = ((i % side) as f32 / side as f32 - 0.5, (i / side) as f32 / side as f32 - 0.5);
                (eye, (fwd + 0.8 * (x * right + y * up)).normalize())
            } else {
                let o = lo + (hi - lo) * Vec3::new(rng.next(), rng.next(), rng.next());
                (o, rng.dir())
            }
        })
        .unzip()
}

/// Every packet answer equals the scalar one: the same hit or miss, the same distance
/// (bit for bit: the kernels compute the same operations), the same primitive (on an
/// exact tie in t, the lowest id: `nearer`); any-hit answers the same for segments ending
/// around the closest hit.
fn check_width<S: Vector>(accel: &Accel, o: &[Vec3], d: &[Vec3], cfg: PacketConfig, label: &str) {
    let mut work = PacketWork::default();
    let mut out = [(0.0f32, 0u32); LANES];
    let mut occ = [false; LANES];
    let mut rng = Rng(99);
    let mut wrong = Vec::new();
    for (chunk, (o, d)) in o.chunks(S::WIDTH).zip(d.chunks(S::WIDTH)).enumerate() {
        kernels::packet_closest::<S>(accel, o, d, 0.0, &mut out, &mut work);
        let mut tmax = [0.0f32; LANES];
        let mut single = [None; LANES];
        for l in 0..o.len() {
            single[l] = kernels::binary_closest::<false>(
                accel,
                Ray::new(o[l], d[l], 0.0, f32::INFINITY),
                &mut Traversal::default(),
            );
            tmax[l] = match single[l] {
                Some((t, _)) => t * (0.5 + rng.next()),
                None => 1e3,
            };
        }
        kernels::packet_occluded::<S>(accel, o, d, &tmax[..o.len()], &mut occ, &mut work);
        for l in 0..o.len() {
            let ray = chunk * S::WIDTH + l;
            let same = match single[l] {
                Some((t, p)) => {
                    let q = out[l].1 as usize;
                    out[l].0.to_bits() == t.to_bits() && q == p as usize
                }
                None => out[l] == (f32::INFINITY, u32::MAX),
            };
            if !same {
                wrong.push(format!("ray {ray}: packet {:?} scalar {:?}", out[l], single[l]));
            }
            let blocked =
                kernels::binary_occluded::<false>(accel, Ray::new(o[l], d[l], 0.0, tmax[l]), &mut Traversal::default());
            if occ[l] != blocked {
                wrong.push(format!("ray {ray}: any-hit packet {} scalar {blocked}", occ[l]));
            }
        }
    }
    let n = o.len();
    assert!(
        wrong.is_empty(),
        "{label}, {} lanes, {cfg:?}: {} of {n} rays differ: {:?}",
        S::WIDTH,
        wrong.len(),
        &wrong[..wrong.len().min(5)]
    );
}

/// The wide BVH's single-ray kernel against the binary one: the same closest distance
/// bit for bit, the same primitive (the tie rule), the same any-hit
/// answer for segments ending before, around and after the closest hit.
fn check_wide(accel: &Accel, o: &[Vec3], d: &[Vec3], label: &str) {
    let mut rng = Rng(5);
    let mut wrong = Vec::new();
    let (mut cw, mut cs) = (Traversal::default(), Traversal::default());
    for (i, (&o, &d)) in o.iter().zip(d).enumerate() {
        let single = kernels::binary_closest::<true>(accel, Ray::new(o, d, 0.0, f32::INFINITY), &mut cs);
        let wide = accel.closest::<true>(Ray::new(o, d, 0.0, f32::INFINITY), &mut cw);
        let same = match (single, wide) {
            (Some((t, p)), Some((tw, q))) => tw.to_bits() == t.to_bits() && q == p,
            (None, None) => true,
            _ => false,
        };
        if !same {
            wrong.push(format!("ray {i}: wide {wide:?} scalar {single:?}"));
        }
        let tmax = single.map_or(1e3, |(t, _)| t * (0.5 + rng.next()));
        let (a, b) = (
            kernels::binary_occluded::<false>(accel, Ray::new(o, d, 0.0, tmax), &mut cs),
            accel.occluded::<false>(Ray::new(o, d, 0.0, tmax), &mut cw),
        );
        if a != b {
            wrong.push(format!("ray {i}: any-hit wide {b} scalar {a}"));
        }
    }
    assert!(
        wrong.is_empty(),
        "{label}, wide: {} of {} rays differ: {:?}",
        wrong.len(),
        o.len(),
        &wrong[..wrong.len().min(5)]
    );
    assert!(o.is_empty() || cw.nodes > 0, "{label}: the wide kernel ran");
    check_interleaved(accel, o, d, label);
    check_stream(accel, o, d, label);
}

/// The stream kernel against the wide kernel one ray at a time, in queues of a render
/// wave's length and of odd lengths (a stream splits by octant, thins below
/// `MIN_STREAM` and runs in slices of `MAX_STREAM`): the same hits and blockers, bit for
/// bit, every ray answered once, in index order.
fn check_stream(accel: &Accel, o: &[Vec3], d: &[Vec3], label: &str) {
    let n = o.len();
    let mut wrong = Vec::new();
    let (mut cs, mut cw) = (Traversal::default(), Traversal::default());
    let mut base = 0;
    for (k, len) in [4096, 777, 10_000, 1, 4096].into_iter().cycle().enumerate() {
        if base >= n {
            break;
        }
        let len = len.min(n - base);
        let (o, d) = (&o[base..base + len], &d[base..base + len]);
        let mut hits = Vec::new();
        kernels::stream_closest::<true>(
            accel,
            len,
            |i| Ray::new(o[i], d[i], 0.0, f32::INFINITY),
            |i, h| {
                assert_eq!(i, hits.len(), "{label}: stream answers in index order");
                hits.push(h);
            },
            &mut cs,
        );
        let tmax: Vec<f32> = (0..len)
            .map(|i| hits[i].map_or(1e3, |(t, _): (f32, u32)| t * (0.25 + ((i + k) % 7) as f32 * 0.15)))
            .collect();
        let mut blocked = Vec::new();
        kernels::stream_occluded::<true>(
            accel,
            len,
            |i| Ray::new(o[i], d[i], 0.0, tmax[i]),
            |i, b| {
                assert_eq!(i, blocked.len(), "{label}: stream answers in index order");
                blocked.push(b);
            },
            &mut cs,
        );
        assert_eq!((hits.len(), blocked.len()), (len, len), "{label}: every ray answered");
        for i in 0..len {
            let single = accel.closest::<false>(Ray::new(o[i], d[i], 0.0, f32::INFINITY), &mut cw);
            let occluded = accel.occluded::<false>(Ray::new(o[i], d[i], 0.0, tmax[i]), &mut cw);
            let same = match (single, hits[i]) {
                (Some((t, p)), Some((u, q))) => t.to_bits() == u.to_bits() && p == q,
                (None, None) => true,
                _ => false,
            };
            if !same || occluded != blocked[i] {
                wrong.push(format!("ray {}: stream {:?} {} wide {single:?} {occluded}", base + i, hits[i], blocked[i]));
            }
        }
        base += len;
    }
    assert!(
        wrong.is_empty(),
        "{label}, stream: {} of {n} rays differ: {:?}",
        wrong.len(),
        &wrong[..wrong.len().min(5)]
    );
    assert!(n == 0 || cs.nodes > 0, "{label}: the stream kernel ran");
}

/// The interleaved kernel (rays walked `accel::wbvh::INTERLEAVE` at a time, finishing out of order)
/// against the wide kernel one ray at a time: the same hits and blockers, bit for bit,
/// and the same work counted.
fn check_interleaved(accel: &Accel, o: &[Vec3], d: &[Vec3], label: &str) {
    let n = o.len();
    let (mut ci, mut cw) = (Traversal::default(), Traversal::default());
    let mut hits = vec![None; n];
    let mut seen = vec![0u32; n];
    let ray = |i: usize| Ray::new(o[i], d[i], 0.0, f32::INFINITY);
    kernels::interleaved_closest::<true>(accel, n, ray, |i, h| (hits[i], seen[i]) = (h, seen[i] + 1), &mut ci);
    let tmax: Vec<f32> =
        (0..n).map(|i| hits[i].map_or(1e3, |(t, _): (f32, u32)| t * (0.25 + (i % 7) as f32 * 0.15))).collect();
    let mut blocked = vec![false; n];
    kernels::interleaved_occluded::<true>(
        accel,
        n,
        |i| Ray::new(o[i], d[i], 0.0, tmax[i]),
        |i, b| (blocked[i], seen[i]) = (b, seen[i] + 2),
        &mut ci,
    );
    let mut wrong = Vec::new();
    for i in 0..n {
        let single = accel.closest::<true>(ray(i), &mut cw);
        let occluded = accel.occluded::<true>(Ray::new(o[i], d[i], 0.0, tmax[i]), &mut cw);
        let same = match (single, hits[i]) {
            (Some((t, p)), Some((u, q))) => t.to_bits() == u.to_bits() && p == q,
            (None, None) => true,
            _ => false,
        };
        if !same || occluded != blocked[i] || seen[i] != 3 {
            wrong.push(format!(
                "ray {i}: interleaved {:?} {} (answered {}) wide {single:?} {occluded}",
                hits[i], blocked[i], seen[i]
            ));
        }
    }
    assert!(
        wrong.is_empty(),
        "{label}, interleaved: {} of {n} rays differ: {:?}",
        wrong.len(),
        &wrong[..wrong.len().min(5)]
    );
    assert_eq!((ci.nodes, ci.prims), (cw.nodes, cw.prims), "{label}: the interleaved walks do the single walks' work");
}

fn check_accel(accel: &Accel, n: usize, label: &str) {
    for coherent in [true, false] {
        let (o, d) = rays(accel, n, coherent, 7);
        let label = format!("{label}, {}", if coherent { "coherent" } else { "incoherent" });
        check_wide(accel, &o, &d, &label);
        let cfg = PacketConfig::RENDER;
        check_width::<f32x4>(accel, &o, &d, cfg, &label);
        check_width::<f32x8>(accel, &o, &d, cfg, &label);
        check_width::<f32x16>(accel, &o, &d, cfg, &label);
    }
}

fn mesh_accel(path: &std::path::Path) -> Accel {
    let tris = wavetrace::scene::mesh::load_obj(path).unwrap_or_else(|e| panic!("{e}"));
    Accel::build_reference(
        tris.into_iter()
            .map(|[v0, v1, v2]| Primitive { shape: Shape::Triangle { v0, v1, v2 }, material: 0, light: NO_LIGHT })
            .collect(),
    )
}

#[test]
fn packet_kernels_equal_scalar_on_the_bunny_and_the_default_scene() {
    let bunny = mesh_accel(&std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/meshes/stanford-bunny.obj"));
    check_accel(&bunny, 20_000, "bunny");
    // Spheres and parallelograms (and an emitter, which never blocks).
    let default = Accel::build_reference(scene(wavetrace::DEFAULT_SCENE, &[]).accel.prims().collect());
    check_accel(&default, 20_000, "default scene");
}

/// The full run the issue asks for: 10⁶ rays of each kind against every mesh in a folder
/// (default ../shared/meshes; WAVETRACE_MESHES overrides it, WAVETRACE_EQUIV_RAYS the
/// count) and the default scene's spheres and quads. Minutes long, so run on demand:
/// `cargo test --release --test packets -- --ignored`.
#[test]
#[ignore]
fn packet_kernels_equal_scalar_on_every_mesh_full() {
    let n = std::env::var("WAVETRACE_EQUIV_RAYS").ok().and_then(|v| v.parse().ok()).unwrap_or(1_000_000);
    let dir = std::env::var("WAVETRACE_MESHES")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|_| std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/meshes"));
    let mut meshes: Vec<_> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "obj"))
        .collect();
    meshes.sort();
    assert!(!meshes.is_empty(), "no .obj in {}", dir.display());
    for path in meshes {
        let accel = mesh_accel(&path);
        eprintln!("{}: {} triangles, {n} rays per kind", path.display(), accel.len());
        check_accel(&accel, n, &path.display().to_string());
    }
    check_accel(
        &Accel::build_reference(scene(wavetrace::DEFAULT_SCENE, &[]).accel.prims().collect()),
        n,
        "default scene",
    );
}

#[test]
fn closed_mesh_shot_from_inside_lets_no_ray_escape_the_packet_wide_interleaved_or_stream_kernel() {
    let (c, r) = (Vec3::new(0.3, -0.2, 0.1), 1.7);
    let (unit, f) = icosphere(4);
    let v: Vec<Vec3> = unit.into_iter().map(|p| c + p * r).collect();
    let accel = Accel::build_reference(
        f.iter()
            .map(|&[a, b, cc]| Primitive {
                shape: Shape::Triangle { v0: v[a], v1: v[b], v2: v[cc] },
                material: 0,
                light: NO_LIGHT,
            })
            .collect(),
    );
    let mut rng = Rng(3);
    let n = 100_000;
    let (mut o, mut d) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for i in 0..n {
        // Half the rays start at the centre and aim exactly at vertices and edge midpoints
        // (where a non-watertight test leaks); the rest start anywhere inside.
        if i % 2 == 0 {
            let tri = f[(i / 2) % f.len()];
            let target = match (i / 2) % 3 {
                0 => v[tri[0]],
                1 => (v[tri[0]] + v[tri[1]]) * 0.5,
                _ => (v[tri[0]] + v[tri[1]] + v[tri[2]]) / 3.0,
            };
            o.push(c);
            d.push((target - c).normalize());
        } else {
            o.push(c + rng.dir() * (r * 0.9 * rng.next()));
            d.push(rng.dir());
        }
    }
    // Packets of one direction octant, as the tracer cuts them, so that they walk as beams.
    let octant = |d: Vec3| (d.x < 0.0) as u8 | ((d.y < 0.0) as u8) << 1 | ((d.z < 0.0) as u8) << 2;
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by_key(|&i| octant(d[i]));
    let (o, d): (Vec<Vec3>, Vec<Vec3>) = order.iter().map(|&i| (o[i], d[i])).unzip();
    let mut work = PacketWork::default();
    let (mut escaped, mut unblocked) = (0, 0);
    let mut out = [(0.0f32, 0u32); LANES];
    let mut occ = [false; LANES];
    for (o, d) in o.chunks(LANES).zip(d.chunks(LANES)) {
        kernels::packet_closest::<f32x16>(&accel, o, d, 0.0, &mut out, &mut work);
        escaped += out[..o.len()].iter().filter(|h| h.1 == u32::MAX).count();
        let far = [4.0 * r; LANES];
        kernels::packet_occluded::<f32x16>(&accel, o, d, &far[..o.len()], &mut occ, &mut work);
        unblocked += occ[..o.len()].iter().filter(|&&b| !b).count();
    }
    assert_eq!((escaped, unblocked), (0, 0), "of {n} rays from inside a closed mesh of {} triangles", f.len());
    assert!(work.steps > 0);
    // The wide BVH's single-ray kernel, on the same rays.
    let mut c = Traversal::default();
    let escaped =
        (0..n).filter(|&i| accel.closest::<true>(Ray::new(o[i], d[i], 0.0, f32::INFINITY), &mut c).is_none()).count();
    let unblocked = (0..n).filter(|&i| !accel.occluded::<true>(Ray::new(o[i], d[i], 0.0, 4.0 * r), &mut c)).count();
    assert_eq!((escaped, unblocked), (0, 0), "wide kernel: of {n} rays from inside a closed mesh");
    let (mut escaped, mut unblocked) = (0, 0);
    kernels::interleaved_closest::<false>(
        &accel,
        n,
        |i| Ray::new(o[i], d[i], 0.0, f32::INFINITY),
        |_, h| escaped += h.is_none() as usize,
        &mut c,
    );
    kernels::interleaved_occluded::<false>(
        &accel,
        n,
        |i| Ray::new(o[i], d[i], 0.0, 4.0 * r),
        |_, b| unblocked += !b as usize,
        &mut c,
    );
    assert_eq!((escaped, unblocked), (0, 0), "interleaved kernel: of {n} rays from inside a closed mesh");
    let (mut escaped, mut unblocked) = (0, 0);
    kernels::stream_closest::<false>(
        &accel,
        n,
        |i| Ray::new(o[i], d[i], 0.0, f32::INFINITY),
        |_, h| escaped += h.is_none() as usize,
        &mut c,
    );
    kernels::stream_occluded::<false>(
        &accel,
        n,
        |i| Ray::new(o[i], d[i], 0.0, 4.0 * r),
        |_, b| unblocked += !b as usize,
        &mut c,
    );
    assert_eq!((escaped, unblocked), (0, 0), "stream kernel: of {n} rays from inside a closed mesh");
    assert!(c.nodes > 0);
}

/// Rays parallel to two axes, passing just inside or on the shared edge of two triangles
/// of a wall at distance 10: every kernel finds the wall, and the primitive a brute-force
/// search finds. (obvhs's `Ray::new` clamps a zero direction component's reciprocal at
/// 1/ε, and the slab test then skipped the box of a triangle the ray passes 10⁻⁶ inside
/// of: the ray went through the wall. A ray exactly on the edge runs in a face of each
/// triangle's box: see `slab_origin`.)
#[test]
fn axis_parallel_rays_along_a_shared_edge_hit_the_wall_in_every_kernel() {
    let tri = |a: Vec3, b: Vec3, c: Vec3| Primitive {
        shape: Shape::Triangle { v0: a, v1: b, v2: c },
        material: 0,
        light: NO_LIGHT,
    };
    let v = |x: f32, y: f32| Vec3::new(x, y, 0.0);
    let accel = Accel::build_reference(vec![
        tri(v(0.0, -1.0), v(1.0, -1.0), v(1.0, 2.0)),
        tri(v(1.0, -1.0), v(2.0, -1.0), v(1.0, 2.0)),
    ]);
    let (mut o, mut d) = (Vec::new(), Vec::new());
    for k in -40i32..=40 {
        for dir in [Vec3::new(0.0, 0.0, -1.0), Vec3::new(-0.0, -0.0, -1.0)] {
            o.push(Vec3::new(1.0 + k as f32 * 2.5e-8, 0.0, 10.0));
            d.push(dir);
        }
    }
    for (&o, &d) in o.iter().zip(&d) {
        let hit =
            kernels::binary_closest::<false>(&accel, Ray::new(o, d, 0.0, f32::INFINITY), &mut Traversal::default());
        assert!(hit.is_some_and(|h| (h.0 - 10.0).abs() < 1e-5), "ray from {o:?} along {d:?} missed the wall: {hit:?}");
        // Every primitive the triangle test says is hit was met, whichever box it sits in
        // (a ray along the shared edge runs in a face of both boxes): the answer is the
        // brute-force one, the nearest and on a tie the lowest id.
        let brute = (0..accel.len() as u32)
            .map(|id| (accel.prim(id).shape.intersect(o, d, 0.0, f32::INFINITY), id))
            .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        assert_eq!(hit, brute, "ray from {o:?} along {d:?}");
        assert!(
            kernels::binary_occluded::<false>(&accel, Ray::new(o, d, 0.0, 20.0), &mut Traversal::default()),
            "ray from {o:?} unblocked"
        );
    }
    check_wide(&accel, &o, &d, "wall");
    let cfg = PacketConfig::RENDER;
    check_width::<f32x4>(&accel, &o, &d, cfg, "wall");
    check_width::<f32x8>(&accel, &o, &d, cfg, "wall");
    check_width::<f32x16>(&accel, &o, &d, cfg, "wall");
}

/// The renderer's hybrid kernel on incoherent queues, with the interleaved walk forced on
/// (the tree is small, so the cache rule alone would not take it) and off: the same hits
/// and blockers as the wide kernel one ray at a time.
#[test]
fn hybrid_tracer_with_and_without_interleaving_equals_the_wide_kernel() {
    use wavetrace::accel::tracer::{Coherence, Kernel, Tracer};
    use wavetrace::queue::{HitQueue, RayQueue, ShadowQueue};
    let mut accel =
        mesh_accel(&std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/meshes/stanford-bunny.obj"));
    let (o, d) = rays(&accel, 5000, false, 11);
    let mut rays_q = RayQueue::default();
    let mut shadow = ShadowQueue::default();
    for (i, (&o, &d)) in o.iter().zip(&d).enumerate() {
        rays_q.push(o, d, i as u32, Vec3::ONE, 1, 0, 0, 0.0, None);
        shadow.push(o, d, 0.05 + (i % 13) as f32 * 0.02, i as u32, Vec3::ONE, None);
    }
    let answers = |accel: &Accel, kernel: Kernel| {
        let mut tracer = Tracer::new(accel, kernel, true);
        let mut hits = HitQueue::default();
        tracer.closest(&rays_q, Coherence::Bounce, &mut hits);
        let blocked = tracer.occluded(&shadow).to_vec();
        (hits.t.iter().map(|t| t.to_bits()).collect::<Vec<_>>(), hits.prim.clone(), blocked)
    };
    let expect = answers(&accel, Kernel::Wide);
    assert!(expect.2.iter().any(|&b| b) && expect.2.iter().any(|&b| !b), "some shadow rays blocked, some not");
    for interleave in [false, true] {
        accel.interleave = interleave;
        assert!(answers(&accel, Kernel::HYBRID) == expect, "hybrid, interleave {interleave}");
        assert!(answers(&accel, Kernel::Interleaved) == expect, "interleaved kernel");
        assert!(answers(&accel, Kernel::Stream) == expect, "stream kernel");
    }
}

/// The hybrid's choice per queue: a coherent bounce queue (a pinhole grid, whose beams
/// reach far fewer leaves than they have rays) stays in packets; an incoherent one leaves
/// packets after the probe. Closest hits and shadow rays alike.
#[test]
fn hybrid_keeps_coherent_queues_in_packets_and_leaves_incoherent_ones() {
    use wavetrace::accel::tracer::{Coherence, Kernel, Tracer, PROBE_PACKETS};
    use wavetrace::queue::{HitQueue, RayQueue, ShadowQueue};
    let accel = mesh_accel(&std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/meshes/stanford-bunny.obj"));
    let n = 4096;
    let packet_rays = |coherent: bool| {
        let (o, d) = rays(&accel, n, coherent, 5);
        let (mut q, mut shadow) = (RayQueue::default(), ShadowQueue::default());
        for (i, (&o, &d)) in o.iter().zip(&d).enumerate() {
            q.push(o, d, i as u32, Vec3::ONE, 1, 0, 0, 0.0, None);
            shadow.push(o, d, f32::INFINITY, i as u32, Vec3::ONE, None);
        }
        let mut tracer = Tracer::new(&accel, Kernel::HYBRID, true);
        tracer.closest(&q, Coherence::Bounce, &mut HitQueue::default());
        let closest = tracer.take_work().packet_rays as usize;
        tracer.occluded(&shadow);
        (closest, tracer.take_work().packet_rays as usize)
    };
    let (closest, shadow) = packet_rays(true);
    assert!(closest > n * 9 / 10 && shadow > n * 9 / 10, "coherent: {closest} and {shadow} of {n} in packets");
    let (closest, shadow) = packet_rays(false);
    let probe = PROBE_PACKETS * LANES;
    assert!(closest <= probe && shadow <= probe, "incoherent: {closest} and {shadow} in packets, probe {probe}");
}
