//! The shade and shadow-corner stages on hand-made waves: what each sends to which queue,
//! with which slot, ray index and value. Hits come straight from the BVH, so only the
//! stage under test runs.
//!
//! Each stage is called from one helper ([`shade`], [`shadow_corners`]), so a change of
//! a stage's signature is a one-line change here.

mod support;

use glam::Vec3;
use std::f32::consts::FRAC_1_PI;
use support::{closest, polygon_irradiance, FloorScene};
use wavetrace::accel::tracer::{Kernel, Tracer};
use wavetrace::light::probe_targets;
use wavetrace::light::SHADOW_TMAX_SCALE;
use wavetrace::queue::{
    FilmQueue, HitQueue, IndexQueue, RayQueue, ShadowPointQueue, ShadowPoints, ShadowQueue, SurfaceQueue, MISS,
};
use wavetrace::scene::{Light, Probe, ShadowMode};
use wavetrace::stages::camera::UniformPass;
use wavetrace::stages::shade::ShadeCounts;
use wavetrace::stages::{shade as shade_stage, shadow_corner};
use wavetrace::Scene;

// ---------------------------------------------------------------------------------------
// The stages, one helper each

/// What the shade stage wrote.
struct Shaded {
    shadow: ShadowQueue,
    points: ShadowPointQueue,
    surfaces: SurfaceQueue,
    specular: Vec<u32>,
    film: FilmQueue,
    /// The stage's return value: uniform-mode shadow rays of the queued points, and the
    /// points sampled uniformly instead.
    counts: ShadeCounts,
}

/// The shade stage on one wave (the only call of `shade::shade` in this file).
fn shade(scene: &Scene, rays: &RayQueue, hits: &HitQueue) -> Shaded {
    let (mut shadow, mut points, mut specular, mut film) =
        (ShadowQueue::default(), ShadowPointQueue::default(), IndexQueue::default(), FilmQueue::default());
    let mut surfaces = SurfaceQueue::default();
    let out = shade_stage::Shaded {
        shadow: &mut shadow,
        points: &mut points,
        surfaces: &mut surfaces,
        specular: &mut specular,
        film: &mut film,
    };
    let counts = shade_stage::shade(scene, scene.settings.shadow_mode, rays, hits, out);
    Shaded { shadow, points, surfaces, specular: specular.index, film, counts }
}

/// What the shadow-corner stage wrote.
struct Cornered {
    film: FilmQueue,
    penumbra: Vec<u32>,
    /// The stage's return value: probe rays cast.
    cast: usize,
}

/// The shadow-corner stage (the only call of `shadow_corner::shadow_corners` here).
fn shadow_corners(scene: &mut Scene, probe: Probe, surfaces: &SurfaceQueue, points: &ShadowPointQueue) -> Cornered {
    scene.settings.shadow_mode = ShadowMode::Adaptive(probe);
    let (mut film, mut penumbra, mut probes) = (FilmQueue::default(), IndexQueue::default(), ShadowQueue::default());
    let mut tracer = Tracer::new(&scene.accel, Kernel::render(scene.settings.packets), false);
    let shading = ShadowPoints { surfaces, points };
    let cast =
        shadow_corner::shadow_corners((scene, probe), &mut tracer, shading, &mut probes, &mut film, &mut penumbra);
    Cornered { film, penumbra: penumbra.index, cast }
}

// ---------------------------------------------------------------------------------------
// Waves and scenes

/// A wave of rays `(origin, direction, slot, weight, depth)`; path key 7 + index.
fn wave(rays: &[(Vec3, Vec3, u32, Vec3, u32)]) -> RayQueue {
    let mut q = RayQueue::default();
    for (i, &(o, d, slot, w, depth)) in rays.iter().enumerate() {
        q.push(o, d.normalize(), slot, w, depth, 7 + i as u32, 0, 0.0, None);
    }
    q
}

/// Closest hits of a wave, straight from the BVH.
fn trace(scene: &Scene, rays: &RayQueue) -> HitQueue {
    let mut hits = HitQueue::default();
    for i in 0..rays.len() {
        match closest(scene, rays.origin(i), rays.dir(i)) {
            Some((t, prim)) => hits.push(t, prim),
            None => hits.push(f32::INFINITY, MISS),
        }
    }
    hits
}

const BACKGROUND: Vec3 = Vec3::new(0.2, 0.4, 0.8);
const ALBEDO: Vec3 = Vec3::new(0.5, 0.6, 0.7);
const POINT: Vec3 = Vec3::new(0.3, 2.0, -0.2);
const INTENSITY: Vec3 = Vec3::new(4.0, 5.0, 6.0);

/// A diffuse floor (y = 0, x and z in [-5, 5]) beside a mirror floor (x in [10, 20]), under
/// one point light at `light`; a blue background.
fn point_lit(light: Vec3, sets: &[&str]) -> Scene {
    let text = format!(
        "[camera]\nposition = [0, 1, 4]\nlook_at = [0, 0, 0]\n[background]\ncolor = [0.2, 0.4, 0.8]\n\
         [materials.white]\ntype = \"diffuse\"\ncolor = [0.5, 0.6, 0.7]\n\
         [materials.mirror]\ntype = \"mirror\"\ncolor = [0.9, 0.9, 0.9]\n\
         [[lights]]\ntype = \"point\"\nposition = [{}, {}, {}]\nintensity = [4, 5, 6]\n\
         [[objects]]\ntype = \"quad\"\ncorner = [-5, 0, -5]\nedge_u = [0, 0, 10]\nedge_v = [10, 0, 0]\nmaterial = \"white\"\n\
         [[objects]]\ntype = \"quad\"\ncorner = [10, 0, -5]\nedge_u = [0, 0, 10]\nedge_v = [10, 0, 0]\nmaterial = \"mirror\"\n",
        light.x, light.y, light.z
    );
    support::scene(&text, sets)
}

/// The canonical floor scene without its sphere: a 10×10 floor of albedo 0.8 under a 2×2
/// quad light of radiance 3 at height 3 (facing down), 16 shadow samples, a blue
/// background; `extra` TOML is appended (occluders, more lights).
fn quad_lit(extra: &str, sets: &[&str]) -> Scene {
    let text = FloorScene {
        render: "[render.shadows]\nsamples = 16\n",
        background: Some(BACKGROUND.to_array()),
        spheres: Vec::new(),
        ..FloorScene::default()
    }
    .toml();
    support::scene(&(text + extra), sets)
}

const ADAPTIVE: &str = "render.shadows.mode=adaptive";

/// The quad light of `scene` (light 0): corner, edges, radiance.
fn quad(scene: &Scene) -> (Vec3, Vec3, Vec3, Vec3) {
    match scene.lights[0] {
        Light::Quad { corner, u, v, radiance, .. } => (corner, u, v, radiance),
        _ => panic!("light 0 is not a quad"),
    }
}

/// The exact (polygon) irradiance at `p` on the floor from the quad light of `scene`.
fn floor_irradiance(scene: &Scene, p: Vec3) -> f32 {
    let (c, u, v, _) = quad(scene);
    polygon_irradiance(p, Vec3::Y, &[c, c + u, c + u + v, c + v], 1.0)
}

/// The box around every primitive of `scene`.
fn scene_bounds(scene: &Scene) -> (Vec3, Vec3) {
    let boxes = scene.accel.prims().map(|p| p.shape.bounds());
    boxes.fold((Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)), |(lo, hi), (a, b)| (lo.min(a), hi.max(b)))
}

/// Relative difference per channel.
fn rel(a: Vec3, b: Vec3) -> f32 {
    ((a - b).abs() / b.abs()).max_element()
}

const DOWN: Vec3 = Vec3::NEG_Y;

// ---------------------------------------------------------------------------------------
// Camera

/// The lanes' dithering and CMJ keys are the scalar ones, lane by lane.
#[test]
fn dither_and_cmj_keys_on_lanes_are_the_scalar_ones() {
    use wavetrace::sampling::{dither, dither_lanes, CmjKey};
    use wavetrace::simd::LANES;
    use wide::u32x16;
    let mut next = 0x9e37_79b9u32;
    let mut draw = |m: u32| {
        next = next.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (next >> 8) % m
    };
    for round in 0..200 {
        let (width, n, seed) = (1 + draw(5000), 1 + draw(64), draw(1 << 24));
        let x: [u32; LANES] = std::array::from_fn(|_| draw(width));
        let y: [u32; LANES] = std::array::from_fn(|_| draw(4000));
        let (block, first) = dither_lanes(seed, width, u32x16::from(x), u32x16::from(y), n);
        let (block, first) = (block.to_array(), first.to_array());
        for k in 0..LANES {
            assert_eq!((block[k], first[k]), dither(seed, width, x[k], y[k], n), "round {round} lane {k}");
        }
        let pattern: [u32; LANES] = std::array::from_fn(|_| draw(1 << 24) ^ (draw(256) << 24));
        let samples = [1, 1, 2, 3, 4, 7, 16][round % 7];
        let keys = CmjKey::sixteen(u32x16::from(pattern), samples);
        for k in 0..LANES {
            assert_eq!(keys[k], CmjKey::new(pattern[k], samples), "round {round} lane {k}");
        }
    }
}

// ---------------------------------------------------------------------------------------
// Shade

/// Units in the last place of `x` between `x` and `exact`.
fn ulps(x: f32, exact: f64) -> f64 {
    let x64 = x as f64;
    let ulp = (f32::from_bits((x.abs()).to_bits() + 1) - x.abs()) as f64;
    (x64 - exact).abs() / ulp
}

/// The irradiance's arctangent is within 3 ulp of f64's `atan2` over every octant and
/// over angles from 1e-30 to π, and gives the same bits on lanes as in scalar code.
#[test]
fn edge_angle_is_within_three_ulp_and_the_same_on_lanes() {
    use wavetrace::emitter::area::edge_angle;
    use wide::f32x16;
    let mut next = 0x2545_f491u32;
    let mut unit = || {
        next = next.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (next >> 8) as f32 / (1u32 << 24) as f32
    };
    for round in 0..20_000 {
        // Half the pairs on the unit circle, half at random scales and tiny angles.
        let sin: [f32; 16] = std::array::from_fn(|_| {
            let s = unit();
            if round % 2 == 0 {
                s.max(1e-7)
            } else {
                s * 10f32.powi(-(unit() * 30.0) as i32) + f32::MIN_POSITIVE
            }
        });
        let cos: [f32; 16] = std::array::from_fn(|_| (unit() - 0.5) * 10f32.powi((unit() * 6.0) as i32 - 3));
        let lanes = edge_angle(f32x16::from(sin), f32x16::from(cos)).to_array();
        for k in 0..16 {
            let a = edge_angle(sin[k], cos[k]);
            assert_eq!(a.to_bits(), lanes[k].to_bits(), "lane {k}: {} {}", sin[k], cos[k]);
            let u = ulps(a, (sin[k] as f64).atan2(cos[k] as f64));
            assert!(u <= 3.0, "atan2({}, {}) = {a}: {u} ulp", sin[k], cos[k]);
        }
    }
    // Exact quadrant values.
    assert_eq!(edge_angle(1.0f32, 0.0), std::f32::consts::FRAC_PI_2);
    assert_eq!(edge_angle(1.0f32, 1.0), std::f32::consts::FRAC_PI_4);
}

#[test]
fn diffuse_surfaces_on_lanes_are_diffuse_surface_bit_for_bit() {
    // Spheres, parallelograms and meshes, hit by camera rays and by rays from inside
    // the scene in every direction, in groups of 1 to 16.
    let dir = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes"));
    let mut rng = support::Lcg(3);
    let mut shapes = [0usize; 3];
    let smooth = ["objects.0.smooth=true"];
    for (name, sets) in [("default", &[][..]), ("cornell", &[]), ("bunny", &[]), ("penumbra", &[]), ("bunny", &smooth)]
    {
        let text = std::fs::read_to_string(dir.join(format!("{name}.toml"))).unwrap();
        let scene = support::scene_in(dir, &text, sets);
        assert_eq!(scene.normals.is_empty(), sets.is_empty(), "{name} {sets:?}");
        let mut rays = RayQueue::default();
        let tile = wavetrace::film::Tile { x0: 0, y0: 0, x1: 16, y1: 12 };
        let small = support::scene_in(dir, &text, &["render.width=16", "render.height=12", "render.aa.samples=4"]);
        wavetrace::stages::camera::generate(&small, &tile, UniformPass::of(&small.settings), 0..16 * 12 * 4, &mut rays);
        let (lo, hi) = scene_bounds(&scene);
        for k in 0..3000 {
            let o = Vec3::new(rng.range(lo.x, hi.x), rng.range(lo.y, hi.y), rng.range(lo.z, hi.z));
            rays.push(o, rng.unit(), k, Vec3::new(0.5, 1.0, 0.25), 0, k, k, 0.0, None);
        }
        // And at the middle of diffuse primitives, so every shape gets hit.
        let diffuse = |p: usize| wavetrace::surface::diffuse_material(&scene, p as u32).is_some();
        let prims: Vec<usize> = (0..scene.accel.len()).filter(|&p| diffuse(p)).collect();
        for k in 0..3000u32 {
            let (a, b) = scene.accel.prim(prims[(k as usize * 7919) % prims.len()] as u32).shape.bounds();
            let o = Vec3::new(rng.range(lo.x, hi.x), rng.range(lo.y, hi.y), rng.range(lo.z, hi.z));
            rays.push(o, (0.5 * (a + b) - o).normalize(), k, Vec3::ONE, 0, k, k, 0.0, None);
        }
        let hits = trace(&scene, &rays);
        let ids: Vec<u32> = (0..rays.len() as u32)
            .filter(|&i| wavetrace::surface::diffuse_material(&scene, hits.prim[i as usize]).is_some())
            .collect();
        let mut lanes = SurfaceQueue::default();
        let mut at = 0;
        while at < ids.len() {
            let len = (1 + at % 16).min(ids.len() - at);
            wavetrace::surface::diffuse_surfaces(&scene, &rays, &hits, &ids[at..at + len], &mut lanes);
            at += len;
        }
        assert_eq!(lanes.len(), ids.len());
        for (p, &i) in ids.iter().enumerate() {
            let want = wavetrace::surface::diffuse_surface(&scene, &rays, &hits, i as usize).unwrap();
            let got = wavetrace::surface::queued_surface(&lanes, p);
            let bits = |s: &wavetrace::surface::Surface| {
                [s.o, s.n, s.wo, s.color, s.specular, s.w].map(|v| v.to_array().map(f32::to_bits))
            };
            assert_eq!(bits(&got), bits(&want), "{name}: ray {i}");
            assert_eq!(
                (got.shininess.to_bits(), got.slot, got.key, got.sample),
                (want.shininess.to_bits(), want.slot, want.key, want.sample)
            );
            assert_eq!(lanes.ray[p], i);
            shapes[match scene.accel.prim(hits.prim[i as usize]).shape {
                wavetrace::accel::shapes::Shape::Sphere { .. } => 0,
                wavetrace::accel::shapes::Shape::Quad { .. } => 1,
                wavetrace::accel::shapes::Shape::Triangle { .. } => 2,
            }] += 1;
        }
    }
    assert!(shapes.iter().all(|&n| n > 500), "too few hits of some shape: {shapes:?}");
}

/// A shadow queue's rays as bits: origin, direction, tmax and contribution, with the slot.
fn shadow_bits(q: &ShadowQueue) -> Vec<([u32; 10], u32)> {
    (0..q.len())
        .map(|i| {
            [q.ox[i], q.oy[i], q.oz[i], q.dx[i], q.dy[i], q.dz[i], q.tmax[i], q.lr[i], q.lg[i], q.lb[i]]
                .map(f32::to_bits)
        })
        .zip(q.slot.iter().copied())
        .collect()
}

/// The diffuse shading points that `count` rays from random points of `scene`'s bounds
/// in random directions hit, computed on lanes 16 at a time.
fn random_surfaces(scene: &Scene, rng: &mut support::Lcg, count: u32) -> SurfaceQueue {
    let (lo, hi) = scene_bounds(scene);
    let mut rays = RayQueue::default();
    for k in 0..count {
        let o = Vec3::new(rng.range(lo.x, hi.x), rng.range(lo.y, hi.y), rng.range(lo.z, hi.z));
        rays.push(o, rng.unit(), k, Vec3::new(0.5, 1.0, 0.25), 0, k, k, 0.0, None);
    }
    let hits = trace(scene, &rays);
    let ids: Vec<u32> = (0..rays.len() as u32)
        .filter(|&i| wavetrace::surface::diffuse_material(scene, hits.prim[i as usize]).is_some())
        .collect();
    let mut surfaces = SurfaceQueue::default();
    for group in ids.chunks(wavetrace::simd::LANES) {
        wavetrace::surface::diffuse_surfaces(scene, &rays, &hits, group, &mut surfaces);
    }
    surfaces
}

/// The adaptive shadow test's unoccluded light on lanes is the scalar function's, bit for
/// bit, for points on lanes (Lambertian, in front, the light above the horizon) and for
/// the others (Phong, behind the light, the light partly below the horizon), under
/// parallelogram and triangle lights, in groups of 1 to 16.
#[test]
fn unoccluded_light_on_lanes_is_the_scalar_functions() {
    use wavetrace::light::{unoccluded, unoccluded_lanes};
    use wavetrace::simd::LANES;
    let dir = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes"));
    let mut rng = support::Lcg(11);
    // On lanes, Phong, behind, partly below the horizon.
    let mut kinds = [0usize; 4];
    for name in ["penumbra", "import/penumbra-triangle", "cornell", "bunny"] {
        let text = std::fs::read_to_string(dir.join(format!("{name}.toml"))).unwrap();
        let scene = support::scene_in(dir.join(name).parent().unwrap(), &text, &[]);
        let surfaces = random_surfaces(&scene, &mut rng, 10_000);
        let area: Vec<usize> = (0..scene.lights.len()).filter(|&li| scene.lights[li].planar().is_some()).collect();
        assert!(!area.is_empty(), "{name}");
        let mut first = 0;
        while first < surfaces.len() {
            let count = (1 + first % 16).min(surfaces.len() - first);
            let ids: [u32; LANES] = std::array::from_fn(|k| (first + k.min(count - 1)) as u32);
            for &li in &area {
                let mut got = [Some((Vec3::NAN, 7)); LANES];
                unoccluded_lanes(&scene, &surfaces, (&ids, count), li, &mut got);
                for (k, &got) in got[..count].iter().enumerate() {
                    let surf = wavetrace::surface::queued_surface(&surfaces, first + k);
                    let want = unoccluded(&scene, &surf, li);
                    let bits = |v: Option<(Vec3, u64)>| v.map(|(l, n)| (l.to_array().map(f32::to_bits), n));
                    assert_eq!(bits(got), bits(want), "{name}: point {} light {li}", first + k);
                    let (corner, u, v, normal, ..) = scene.lights[li].planar().unwrap();
                    let above =
                        [corner, corner + u, corner + v, corner + u + v].iter().all(|&p| surf.n.dot(p - surf.o) > 0.0);
                    kinds[if normal.dot(surf.o - corner) <= 0.0 {
                        2
                    } else if surf.specular != Vec3::ZERO {
                        1
                    } else if above {
                        0
                    } else {
                        3
                    }] += 1;
                }
                assert!(
                    got[count..].iter().all(|g| g.is_some_and(|(l, n)| l.is_nan() && n == 7)),
                    "lanes past count written"
                );
            }
            first += count;
        }
    }
    assert!(kinds.iter().all(|&n| n > 100), "too few points of some kind: {kinds:?}");
}

/// The scatter stage's rays, as the scalar functions give them: the reference the
/// stage's lanes must equal bit for bit.
fn scatter_reference(scene: &Scene, rays: &RayQueue, hits: &HitQueue, ids: &[u32]) -> RayQueue {
    use wavetrace::accel::offset::offset_ray_origin;
    use wavetrace::scene::{Material, ReflectRatio};
    use wavetrace::stages::scatter::{fresnel, interface, reflect, refract};
    let mut next = RayQueue::default();
    for &i in ids {
        let i = i as usize;
        let prim = scene.accel.prim(hits.prim[i]);
        let (d, w) = (rays.dir(i), rays.weight(i));
        let (x, err) = prim.shape.surface_point(rays.origin(i), d, hits.t[i]);
        let ng = prim.shape.normal(x).normalize();
        let (slot, depth, key, sample) = (rays.slot[i], rays.depth[i] + 1, rays.key[i], rays.sample[i]);
        let (k1, k2) = (wavetrace::sampling::hash(&[key, 1]), wavetrace::sampling::hash(&[key, 2]));
        // Directions use the shading normal (smooth meshes), origins the geometric one.
        let shading = |n: Vec3| wavetrace::surface::shading_normal(scene, hits.prim[i] as usize, 0.0, x, n);
        match scene.materials[prim.material as usize] {
            Material::Mirror { color } => {
                let n = if d.dot(ng) < 0.0 { ng } else { -ng };
                next.push(
                    offset_ray_origin(x, err, n),
                    reflect(d, shading(n)),
                    slot,
                    w * color,
                    depth,
                    k1,
                    sample,
                    0.0,
                    None,
                );
            }
            Material::Dielectric { ior, ratio, tint, .. } => {
                let side = interface(d, ng, ior);
                let n = side.normal;
                let ns = shading(n);
                let refracted = refract(d, ns, side.eta);
                let c = match (refracted, ratio) {
                    (None, _) => 1.0,
                    (Some(_), ReflectRatio::Fixed(c)) => c,
                    (Some(_), ReflectRatio::Fresnel) => fresnel(-d.dot(ns), side.eta),
                };
                if c > 0.0 {
                    next.push(offset_ray_origin(x, err, n), reflect(d, ns), slot, w * c, depth, k1, sample, 0.0, None);
                }
                if let Some(t) = refracted.filter(|_| c < 1.0) {
                    next.push(
                        offset_ray_origin(x, err, -n),
                        t,
                        slot,
                        w * tint * (1.0 - c),
                        depth,
                        k2,
                        sample,
                        0.0,
                        None,
                    );
                }
            }
            Material::Diffuse { .. } | Material::Conductor { .. } | Material::Plastic { .. } => {
                unreachable!("only smooth mirrors and glass here")
            }
        }
    }
    next
}

/// The penumbra stage's rays with early stopping: each (point, area light) pair's rays
/// on lanes, and each ray's light cell, are `area_light_samples`' bit for bit, under
/// parallelogram and triangle lights, with counts whose grid is a net (16, 32, 64: the
/// cell from the sample's position) and not (3, 9: its index), pairs split across lane
/// groups and sharing them.
#[test]
fn penumbra_rays_and_cells_on_lanes_are_area_light_samples() {
    use wavetrace::light::area_light_samples;
    use wavetrace::light::lanes::pair_shadow_lanes;
    let dir = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes"));
    let mut rng = support::Lcg(5);
    for name in ["penumbra", "import/penumbra-triangle", "cornell"] {
        for n in [3, 9, 16, 32, 64] {
            let text = std::fs::read_to_string(dir.join(format!("{name}.toml"))).unwrap();
            let samples = format!("render.shadows.samples={n}");
            let scene = support::scene_in(dir.join(name).parent().unwrap(), &text, &[&samples]);
            let surfaces = random_surfaces(&scene, &mut rng, 600);
            let area: Vec<u32> =
                (0..scene.lights.len() as u32).filter(|&li| scene.lights[li as usize].planar().is_some()).collect();
            let pairs: Vec<(u32, u32)> =
                (0..surfaces.len() as u32).flat_map(|p| area.iter().map(move |&li| (p, li))).collect();
            let (mut got, mut counts, mut cells) = (ShadowQueue::default(), Vec::new(), vec![7u32]);
            pair_shadow_lanes(&scene, &surfaces, pairs.iter().copied(), &mut got, &mut counts, Some(&mut cells));
            let (mut want, mut want_cells, mut want_counts) = (ShadowQueue::default(), Vec::new(), Vec::new());
            for &(p, li) in &pairs {
                let surf = wavetrace::surface::queued_surface(&surfaces, p as usize);
                let before = want.len();
                area_light_samples(&scene, &surf, li as usize, |cell, wi, dist, l| {
                    want_cells.push(cell);
                    want.push(surf.o, wi, dist * SHADOW_TMAX_SCALE, surf.slot, l, None);
                });
                want_counts.push((want.len() - before) as u32);
            }
            assert!(want.len() > 20 * n as usize, "{name}, {n} samples: only {} rays", want.len());
            assert!(shadow_bits(&got) == shadow_bits(&want), "{name}, {n} samples: the rays differ");
            assert_eq!(counts, want_counts, "{name}, {n} samples: rays per pair");
            assert_eq!(cells, want_cells, "{name}, {n} samples: light cells");
            // Other counts number a pair's cells by sample, in order; a net's come from
            // the samples' positions, out of order somewhere.
            let (mut at, mut unordered) = (0, 0);
            for &c in &counts {
                let pair = &cells[at..at + c as usize];
                unordered += pair.windows(2).any(|w| w[1] <= w[0]) as u32;
                at += c as usize;
            }
            let net = (n as u32).is_power_of_two();
            assert_eq!(unordered > 0, net, "{name}, {n} samples: {unordered} pairs out of sample order");
        }
    }
}

#[test]
fn scatter_on_lanes_gives_the_scalar_functions_rays_bit_for_bit() {
    // Mirrors and dielectrics (Fresnel and a fixed ratio), hit from outside and inside,
    // with total internal reflection, in lists of every length up to 40.
    let dir = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes"));
    let mut rng = support::Lcg(11);
    let mut spawned = 0;
    // The bunny as a smooth mirror: reflections about interpolated vertex normals.
    let smooth_mirror = vec!["objects.0.smooth=true", "objects.0.material=mirror"];
    for (name, sets) in [
        ("default", vec![]),
        ("cornell", vec![]),
        ("default", vec!["materials.glass.reflect_ratio=0.3"]),
        ("bunny", smooth_mirror),
    ] {
        let text = std::fs::read_to_string(dir.join(format!("{name}.toml"))).unwrap();
        let scene = support::scene_in(dir, &text, &sets);
        let specular = |p: u32| {
            let prim = scene.accel.prim(p);
            prim.light == wavetrace::accel::NO_LIGHT && wavetrace::surface::diffuse_material(&scene, p).is_none()
        };
        let prims: Vec<usize> = (0..scene.accel.len()).filter(|&p| specular(p as u32)).collect();
        let mut rays = RayQueue::default();
        for k in 0..4000u32 {
            let (a, b) = scene.accel.prim(prims[k as usize % prims.len()] as u32).shape.bounds();
            let target = a + (b - a) * Vec3::new(rng.range(0.2, 0.8), rng.range(0.2, 0.8), rng.range(0.2, 0.8));
            // From afar, or from inside the object's bounds (leaving a sphere from within).
            let o = if k % 3 == 0 { 0.5 * (a + b) + 0.01 * rng.unit() } else { target + 5.0 * rng.unit() };
            let d = if k % 3 == 0 { rng.unit() } else { (target - o).normalize() };
            rays.push(o, d, k, Vec3::new(0.5, 1.0, 0.25), k % 4, k.wrapping_mul(2_654_435_761), k, 0.0, None);
        }
        let hits = trace(&scene, &rays);
        let ids: Vec<u32> = (0..rays.len() as u32)
            .filter(|&i| hits.prim[i as usize] != MISS && specular(hits.prim[i as usize]))
            .collect();
        let mut at = 0;
        while at < ids.len() {
            let len = (1 + at % 40).min(ids.len() - at);
            let list = IndexQueue { index: ids[at..at + len].to_vec() };
            let mut next = RayQueue::default();
            wavetrace::stages::scatter::scatter(&scene, &rays, &hits, &list, &mut next, &mut Default::default());
            let want = scatter_reference(&scene, &rays, &hits, &list.index);
            let bits = |q: &RayQueue| {
                (0..q.len())
                    .map(|i| {
                        (
                            [q.origin(i), q.dir(i), q.weight(i)].map(|v| v.to_array().map(f32::to_bits)),
                            q.slot[i],
                            q.depth[i],
                            q.key[i],
                            q.sample[i],
                        )
                    })
                    .collect::<Vec<_>>()
            };
            assert!(bits(&next) == bits(&want), "{name} {sets:?}: hits {at}..{}", at + len);
            spawned += next.len();
            at += len;
        }
    }
    assert!(spawned > 5000, "only {spawned} rays spawned");
}

#[test]
fn uniform_shadow_rays_on_lanes_are_the_scalar_functions_rays_bit_for_bit() {
    // Cornell with two more quad lights, one dark; Lambert and Phong walls; 1, 3 and 16
    // samples a light, so lanes hold one point, several, and parts of one. Then the same
    // with a triangle, a point (and a dark one) and a directional light beside them, so
    // lanes mix every kind the lanes take.
    let cornell = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell.toml")).unwrap();
    let mut text = cornell.clone();
    text += "\n[[lights]]\ntype = \"quad\"\ncorner = [0.9, 0.5, -0.3]\nedge_u = [0, 0.6, 0]\nedge_v = [0, 0, 0.6]\nradiance = [0, 0, 0]\n";
    text += "\n[[lights]]\ntype = \"quad\"\ncorner = [-0.95, 1.2, -0.2]\nedge_u = [0, 0, 0.4]\nedge_v = [0, 0.4, 0]\nradiance = [3, 3, 3]\n";
    let mut mixed = text.clone();
    mixed += "\n[[lights]]\ntype = \"triangle\"\nv0 = [0.9, 0.4, -0.5]\nv1 = [0.9, 0.4, 0.1]\nv2 = [0.9, 1.0, -0.2]\nradiance = [2, 1, 1]\n";
    mixed += "\n[[lights]]\ntype = \"point\"\nposition = [0.2, 1.5, 0.4]\nintensity = [0.5, 0.6, 0.7]\n";
    mixed += "\n[[lights]]\ntype = \"point\"\nposition = [-0.2, 1.5, 0.4]\nintensity = [0, 0, 0]\n";
    mixed += "\n[[lights]]\ntype = \"directional\"\ndirection = [0.3, -1, -0.4]\nirradiance = [0.4, 0.4, 0.3]\n";
    // Cornell's light made a point light: one ray a point, the single-light fast path.
    let quad = "type = \"quad\"\ncorner = [-0.3, 1.995, -0.3]\nedge_u = [0.6, 0, 0]\nedge_v = [0, 0, 0.6]\nradiance = [15, 14, 12]";
    assert!(cornell.contains(quad));
    let point = cornell.replace(quad, "type = \"point\"\nposition = [0, 1.9, 0]\nintensity = [2, 2, 1.8]");
    let cases = [(&text, 3), (&mixed, 7), (&point, 1)];
    for ((text, lights), n) in cases.iter().flat_map(|c| [1, 3, 16].map(|n| (*c, n))) {
        let scene = support::scene_in(
            std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes")),
            text,
            &[&format!("render.shadows.samples={n}"), "render.width=24", "render.height=18"],
        );
        let tile = wavetrace::film::Tile { x0: 0, y0: 0, x1: 24, y1: 18 };
        let mut rays = RayQueue::default();
        let spp = scene.settings.aa_samples as u64 * scene.settings.dof_samples as u64;
        wavetrace::stages::camera::generate(
            &scene,
            &tile,
            UniformPass::of(&scene.settings),
            0..24 * 18 * spp,
            &mut rays,
        );
        let hits = trace(&scene, &rays);
        let out = shade(&scene, &rays, &hits);
        let mut want = ShadowQueue::default();
        for i in 0..rays.len() {
            let Some(surf) = wavetrace::surface::diffuse_surface(&scene, &rays, &hits, i) else { continue };
            for li in 0..scene.lights.len() {
                wavetrace::light::uniform_shadow_rays(&scene, &surf, li, |wi, tmax, l| {
                    want.push(surf.o, wi, tmax, surf.slot, l, None)
                });
            }
        }
        assert_eq!(scene.lights.len(), lights);
        assert!(want.len() > 1000, "{n} samples: only {} shadow rays", want.len());
        assert!(
            shadow_bits(&out.shadow) == shadow_bits(&want),
            "{n} samples: the lanes' shadow queue differs from the scalar one"
        );
    }
}

#[test]
fn a_miss_sends_the_background_to_the_film_in_its_slot() {
    let scene = point_lit(POINT, &[]);
    let w = Vec3::new(0.5, 1.0, 0.25);
    let rays = wave(&[(Vec3::new(0.0, 1.0, 0.0), Vec3::Y, 42, w, 0)]);
    let hits = trace(&scene, &rays);
    assert_eq!(hits.prim[0], MISS);
    let out = shade(&scene, &rays, &hits);
    // Exact: one contribution, the ray's weight times the background, in its slot.
    assert_eq!(out.film.len(), 1);
    assert_eq!(out.film.slot[0], 42);
    assert_eq!(Vec3::new(out.film.r[0], out.film.g[0], out.film.b[0]), w * BACKGROUND);
    assert!(out.shadow.is_empty() && out.points.is_empty() && out.specular.is_empty());
    // A black background adds nothing: no film entry at all.
    let black = point_lit(POINT, &["background.color=[0, 0, 0]"]);
    let out = shade(&black, &rays, &trace(&black, &rays));
    assert!(out.film.is_empty() && out.shadow.is_empty());
}

#[test]
fn a_diffuse_hit_under_a_point_light_casts_one_shadow_ray_just_short_of_it() {
    let scene = point_lit(POINT, &[]);
    let w = Vec3::new(1.0, 0.5, 0.25);
    let rays = wave(&[(Vec3::new(0.0, 1.0, 0.0), DOWN, 5, w, 0)]);
    let hits = trace(&scene, &rays);
    let out = shade(&scene, &rays, &hits);
    assert!(out.film.is_empty() && out.points.is_empty() && out.specular.is_empty());
    assert_eq!(out.counts.uniform_equivalent, 0);
    // Exact: one shadow ray, in the ray's slot.
    assert_eq!(out.shadow.len(), 1);
    assert_eq!(out.shadow.slot[0], 5);
    // Its origin is the hit point (0, 0, 0) pushed off the floor on the lit side, by
    // less than 1e-4.
    let o = out.shadow.origin(0);
    assert!(o.y > 0.0 && o.length() < 1e-4, "origin {o}");
    // Tolerance 1e-6: aimed at the light.
    let to = POINT - o;
    let dist = to.length();
    assert!(out.shadow.dir(0).abs_diff_eq(to / dist, 1e-6), "direction {}", out.shadow.dir(0));
    // The segment ends just short of the light: nothing at the light counts, nothing
    // before it (within 1e-3 relative) is missed; it is the distance scaled by
    // SHADOW_TMAX_SCALE (1e-6 relative).
    let tmax = out.shadow.tmax[0];
    assert!(tmax < dist && tmax > dist * (1.0 - 1e-3), "tmax {tmax}, light at {dist}");
    assert!((tmax - dist * SHADOW_TMAX_SCALE).abs() <= 1e-6 * dist, "tmax {tmax}, light at {dist}");
    // Tolerance 1e-5 relative: weight × Lambert × intensity × cos / r².
    let cos = to.y / dist;
    let expect = w * ALBEDO * FRAC_1_PI * INTENSITY * (cos / (dist * dist));
    let got = out.shadow.radiance(0);
    assert!(rel(got, expect) < 1e-5, "{got} vs {expect}");
}

#[test]
fn a_point_light_lights_the_side_of_the_floor_it_is_on() {
    let below = POINT * Vec3::new(1.0, -1.0, 1.0);
    let scene = point_lit(below, &[]);
    // From above, the light is behind the surface: no shadow ray (exact).
    let from_above = wave(&[(Vec3::new(0.0, 1.0, 0.0), DOWN, 0, Vec3::ONE, 0)]);
    let out = shade(&scene, &from_above, &trace(&scene, &from_above));
    assert!(out.shadow.is_empty() && out.film.is_empty());
    // From below, the two-sided floor is lit: one shadow ray starting below it.
    let from_below = wave(&[(Vec3::new(0.0, -1.0, 0.0), Vec3::Y, 0, Vec3::ONE, 0)]);
    let out = shade(&scene, &from_below, &trace(&scene, &from_below));
    assert_eq!(out.shadow.len(), 1);
    assert!(out.shadow.origin(0).y < 0.0 && out.shadow.dir(0).y < 0.0);
}

#[test]
fn uniform_shadows_cast_at_most_samples_rays_per_quad_light() {
    let scene = quad_lit("", &[]);
    let adaptive = quad_lit("", &[ADAPTIVE]);
    let (c, u, v, _) = quad(&scene);
    // Under the light every sample faces the point: exactly `samples` rays.
    let rays = wave(&[(Vec3::new(0.2, 1.0, 0.1), DOWN, 9, Vec3::ONE, 0)]);
    let hits = trace(&scene, &rays);
    let out = shade(&scene, &rays, &hits);
    assert!(out.points.is_empty() && out.film.is_empty() && out.specular.is_empty());
    assert_eq!(out.shadow.len(), 16);
    let mut sum = Vec3::ZERO;
    for i in 0..out.shadow.len() {
        assert_eq!(out.shadow.slot[i], 9);
        assert_eq!(out.shadow.origin(i), out.shadow.origin(0), "one shading point");
        // Each ray ends just short of a point on the light (tolerance 1e-3 on the plane
        // y = 3 and on the light's extent).
        let end = out.shadow.origin(i) + out.shadow.dir(i) * (out.shadow.tmax[i] / SHADOW_TMAX_SCALE);
        assert!((end.y - c.y).abs() < 1e-3, "ray {i} ends at {end}");
        let (a, b) = ((end - c).dot(u) / u.length_squared(), (end - c).dot(v) / v.length_squared());
        assert!((-1e-3..=1.0 + 1e-3).contains(&a) && (-1e-3..=1.0 + 1e-3).contains(&b), "ray {i} ends at {end}");
        sum += out.shadow.radiance(i);
    }
    // Tolerance 1%: the 16 stratified samples estimate what adaptive mode computes exactly
    // (measured: 0.1%).
    let exact = shade(&adaptive, &rays, &trace(&adaptive, &rays)).points.unoccluded(0);
    assert!(rel(sum, exact) < 0.01, "uniform {sum} vs exact {exact}");
    // On the side of a sphere, part of the light is below the horizon: fewer rays.
    let side =
        quad_lit("[[objects]]\ntype = \"sphere\"\ncenter = [0, 0.5, 0]\nradius = 0.5\nmaterial = \"white\"\n", &[]);
    let rays = wave(&[(Vec3::new(2.0, 0.5, 0.0), Vec3::NEG_X, 0, Vec3::ONE, 0)]);
    let out = shade(&side, &rays, &trace(&side, &rays));
    assert!(!out.shadow.is_empty() && out.shadow.len() < 16, "{} rays", out.shadow.len());
}

#[test]
fn adaptive_shadows_queue_the_point_instead_of_casting_rays() {
    let scene = quad_lit("", &[ADAPTIVE]);
    let (_, _, _, radiance) = quad(&scene);
    let w = Vec3::new(0.5, 0.25, 1.0);
    // A miss first, so the point's ray index is 1.
    let rays = wave(&[(Vec3::new(0.0, 4.0, 0.0), Vec3::Y, 3, Vec3::ONE, 0), (Vec3::new(0.2, 1.0, 0.1), DOWN, 4, w, 0)]);
    let hits = trace(&scene, &rays);
    let out = shade(&scene, &rays, &hits);
    assert!(out.shadow.is_empty(), "no shadow rays in adaptive mode");
    assert_eq!((out.film.len(), out.film.slot[0]), (1, 3), "the miss");
    assert_eq!((out.points.surface.clone(), out.points.light.clone()), (vec![0], vec![0]));
    assert_eq!(out.surfaces.ray, vec![1]);
    // Exact count: uniform mode would have cast all 16 samples here.
    assert_eq!(out.counts, ShadeCounts { uniform_equivalent: 16, uniform_fallback: 0 });
    // Tolerance 1e-4 relative: Lambert's exact polygon irradiance, times the weight.
    let x = rays.origin(1) + hits.t[1] * DOWN;
    let expect = w * Vec3::splat(0.8) * FRAC_1_PI * radiance * floor_irradiance(&scene, x);
    assert!(rel(out.points.unoccluded(0), expect) < 1e-4, "{} vs {expect}", out.points.unoccluded(0));
    // A point light still casts its shadow ray in adaptive mode.
    let both = quad_lit("[[lights]]\ntype = \"point\"\nposition = [0, 2, 0]\nintensity = [1, 1, 1]\n", &[ADAPTIVE]);
    let out = shade(&both, &rays, &trace(&both, &rays));
    assert_eq!((out.shadow.len(), out.points.len()), (1, 1));
    assert_eq!(out.shadow.slot[0], 4);
}

#[test]
fn mirror_hits_go_to_the_specular_list_until_max_depth() {
    let scene = point_lit(POINT, &["render.max_depth=2"]);
    let mirror = Vec3::new(15.0, 1.0, 0.0);
    let rays = wave(&[
        (Vec3::new(0.0, 1.0, 0.0), DOWN, 0, Vec3::ONE, 0),
        (mirror, DOWN, 1, Vec3::ONE, 1),
        (Vec3::new(0.0, 1.0, 0.0), Vec3::Y, 2, Vec3::ONE, 0),
    ]);
    let out = shade(&scene, &rays, &trace(&scene, &rays));
    // Exact: the mirror hit (ray 1) is listed; the diffuse hit casts its shadow ray and
    // the miss goes to the film.
    assert_eq!(out.specular, vec![1]);
    assert_eq!(out.shadow.slot, vec![0]);
    assert_eq!(out.film.slot, vec![2]);
    // At max_depth the path ends: nothing anywhere.
    let deep = wave(&[(mirror, DOWN, 1, Vec3::ONE, 2)]);
    let out = shade(&scene, &deep, &trace(&scene, &deep));
    assert!(out.specular.is_empty() && out.shadow.is_empty() && out.film.is_empty() && out.points.is_empty());
}

#[test]
fn an_emitter_adds_its_radiance_from_the_front_only() {
    let scene = quad_lit("", &[]);
    let (_, _, _, radiance) = quad(&scene);
    let w = Vec3::new(0.5, 1.0, 0.75);
    // From below (the light faces down): its radiance times the weight, in the slot.
    let front = wave(&[(Vec3::new(0.1, 1.0, 0.0), Vec3::Y, 6, w, 0)]);
    let out = shade(&scene, &front, &trace(&scene, &front));
    assert_eq!(out.film.slot, vec![6]);
    assert_eq!(Vec3::new(out.film.r[0], out.film.g[0], out.film.b[0]), w * radiance);
    assert!(out.shadow.is_empty() && out.specular.is_empty());
    // From above: black, and not a mirror either.
    let back = wave(&[(Vec3::new(0.1, 5.0, 0.0), DOWN, 6, w, 0)]);
    let hits = trace(&scene, &back);
    assert_ne!(hits.prim[0], MISS);
    let out = shade(&scene, &back, &hits);
    assert!(out.film.is_empty() && out.shadow.is_empty() && out.specular.is_empty());
}

// ---------------------------------------------------------------------------------------
// Shadow corner

const PROBES: [Probe; 4] = [Probe::Corners, Probe::CornersCenter, Probe::Jittered, Probe::Grid3];

/// A quad occluder at height 1.5 over x in [x0, x1], z in [-5, 5].
fn occluder(x0: f32, x1: f32) -> String {
    format!(
        "[[objects]]\ntype = \"quad\"\ncorner = [{x0}, 1.5, -5]\nedge_u = [0, 0, 10]\nedge_v = [{}, 0, 0]\n\
         material = \"white\"\n",
        x1 - x0
    )
}

/// Rays straight down onto the floor at `xs` (z = 0) from below the occluders, slot
/// 10 + index; shaded in adaptive mode: (rays, hits, queued points).
fn points_at(scene: &Scene, xs: &[f32]) -> (SurfaceQueue, ShadowPointQueue) {
    let list: Vec<_> =
        xs.iter().enumerate().map(|(i, &x)| (Vec3::new(x, 1.0, 0.0), DOWN, 10 + i as u32, Vec3::ONE, 0)).collect();
    let rays = wave(&list);
    let hits = trace(scene, &rays);
    let out = shade(scene, &rays, &hits);
    assert_eq!(out.points.len(), xs.len(), "every point is queued");
    (out.surfaces, out.points)
}

#[test]
fn an_unoccluded_point_sends_its_unoccluded_value_to_the_film() {
    let mut scene = quad_lit("", &[ADAPTIVE]);
    let (surfaces, points) = points_at(&scene, &[0.3]);
    for probe in PROBES {
        let out = shadow_corners(&mut scene, probe, &surfaces, &points);
        // Exact: every probe cast, the unoccluded value in the point's slot, no penumbra.
        assert_eq!(out.cast, probe.rays() as usize, "{probe:?}");
        assert_eq!(out.film.slot, vec![10], "{probe:?}");
        assert_eq!(Vec3::new(out.film.r[0], out.film.g[0], out.film.b[0]), points.unoccluded(0), "{probe:?}");
        assert!(out.penumbra.is_empty(), "{probe:?}");
    }
}

#[test]
fn a_fully_occluded_point_sends_nothing() {
    let mut scene = quad_lit(&occluder(-5.0, 5.0), &[ADAPTIVE]);
    let (surfaces, points) = points_at(&scene, &[0.3]);
    for probe in PROBES {
        let out = shadow_corners(&mut scene, probe, &surfaces, &points);
        assert_eq!(out.cast, probe.rays() as usize, "{probe:?}");
        assert!(out.film.is_empty() && out.penumbra.is_empty(), "{probe:?}");
    }
}

#[test]
fn a_half_occluded_point_lands_in_the_penumbra_list() {
    // The occluder covers x ≤ -0.2 at height 1.5, halfway to the light (x in [-1, 1]):
    // seen from x = 0, the probes to x = -1 are blocked and those to x ≥ 0 are not; from
    // x = 3 none is, from x = -3 all are.
    let mut scene = quad_lit(&occluder(-5.0, -0.2), &[ADAPTIVE]);
    let (surfaces, points) = points_at(&scene, &[3.0, -3.0, 0.0]);
    // Jittered probes are random within each quarter of the light: left out.
    for probe in [Probe::Corners, Probe::CornersCenter, Probe::Grid3] {
        let out = shadow_corners(&mut scene, probe, &surfaces, &points);
        // Exact: the lit point's value in its slot, the dark one nowhere, the half-lit
        // one (point 2) in the penumbra list.
        assert_eq!(out.cast, 3 * probe.rays() as usize, "{probe:?}");
        assert_eq!(out.film.slot, vec![10], "{probe:?}");
        assert_eq!(out.penumbra, vec![2], "{probe:?}");
    }
}

#[test]
fn probes_traced_as_a_queue_give_the_single_ray_answers() {
    // Occluders of several widths and heights, and 300 points over the floor: lit, dark
    // and penumbra points of every kind. The stage traces all probes as one queue (in
    // packets or one by one, the tracer's choice); each point's verdict must be what
    // tracing each of its probes alone gives.
    let extra = [occluder(-5.0, -0.2), occluder(0.4, 0.5), occluder(1.1, 3.0)].concat();
    let mut scene = quad_lit(&extra, &[ADAPTIVE]);
    let mut rng = support::Lcg(11);
    let xs: Vec<f32> = (0..300).map(|_| rng.next() * 8.0 - 4.0).collect();
    let (surfaces, points) = points_at(&scene, &xs);
    for probe in PROBES {
        let out = shadow_corners(&mut scene, probe, &surfaces, &points);
        let mut tracer = Tracer::new(&scene.accel, Kernel::Wide, false);
        let (mut film, mut penumbra, mut cast) = (Vec::new(), Vec::new(), 0);
        for k in 0..points.len() {
            let s = points.surface[k] as usize;
            let o = surfaces.origin(s);
            let key = wavetrace::sampling::hash(&[surfaces.key[s], surfaces.sample[s]]);
            let n = probe.rays() as usize;
            let visible = probe_targets(&scene, probe, 0, key)[..n]
                .iter()
                .filter(|&&target| {
                    let (to, dist) = (target - o, (target - o).length());
                    !tracer.occluded_one(o, to / dist, dist * SHADOW_TMAX_SCALE)
                })
                .count();
            cast += n;
            if visible == n {
                film.push(points.slot[k]);
            } else if visible > 0 {
                penumbra.push(k as u32);
            }
        }
        assert_eq!(out.cast, cast, "{probe:?}");
        assert_eq!(out.film.slot, film, "{probe:?}");
        assert_eq!(out.penumbra, penumbra, "{probe:?}");
        assert!(!film.is_empty() && !penumbra.is_empty() && film.len() + penumbra.len() < xs.len(), "{probe:?}");
    }
}

#[test]
fn a_light_whose_probes_cost_its_samples_is_sampled_as_in_uniform_mode() {
    // Probes P against samples N: the light is probed only when P <= 0.8 N. 4 corner
    // probes against 4 samples, and the 9 of the 3x3 grid against 9 and 10: the shade
    // stage queues no point and casts uniform mode's rays, bit for bit; the stats count
    // the points. 4 against 5 and 9 against 12: probed.
    let extra = occluder(-5.0, -0.2);
    let xs = [3.0, -3.0, 0.0, 0.7];
    let list: Vec<_> =
        xs.iter().enumerate().map(|(i, &x)| (Vec3::new(x, 1.0, 0.0), DOWN, 10 + i as u32, Vec3::ONE, 0)).collect();
    let rays = wave(&list);
    let cases = [(4, "corners", false), (9, "3x3", false), (10, "3x3", false), (5, "corners", true), (12, "3x3", true)];
    for (samples, probe, probed) in cases {
        let sets = [format!("render.shadows.samples={samples}"), format!("render.shadows.probe=\"{probe}\"")];
        let uniform = quad_lit(&extra, &[&sets[0], &sets[1]]);
        let adaptive = quad_lit(&extra, &[&sets[0], &sets[1], ADAPTIVE]);
        let hits = trace(&uniform, &rays);
        let (u, a) = (shade(&uniform, &rays, &hits), shade(&adaptive, &rays, &hits));
        if probed {
            assert_eq!((a.points.len(), a.shadow.len(), a.counts.uniform_fallback), (xs.len(), 0, 0));
        } else {
            assert!(a.points.is_empty(), "{samples} {probe}");
            assert_eq!(a.shadow, u.shadow, "{samples} {probe}");
            assert_eq!(a.counts, ShadeCounts { uniform_equivalent: 0, uniform_fallback: xs.len() as u64 });
        }
    }
}

#[test]
fn probe_targets_are_the_corners_centre_grid_or_one_per_quarter() {
    let scene = quad_lit("", &[ADAPTIVE]);
    let (c, u, v, _) = quad(&scene);
    let at = |a: f32, b: f32| c + a * u + b * v;
    // Grid3: the 3×3 grid, row by row along u (exact), whatever the path key.
    let grid = probe_targets(&scene, Probe::Grid3, 0, 1);
    for (i, p) in grid.iter().enumerate() {
        assert_eq!(*p, at(0.5 * (i % 3) as f32, 0.5 * (i / 3) as f32), "grid point {i}");
    }
    assert_eq!(grid, probe_targets(&scene, Probe::Grid3, 0, 2));
    // Corners, then the centre (exact).
    let corners = [at(0.0, 0.0), at(1.0, 0.0), at(0.0, 1.0), at(1.0, 1.0)];
    assert_eq!(probe_targets(&scene, Probe::Corners, 0, 1)[..4], corners);
    let five = probe_targets(&scene, Probe::CornersCenter, 0, 1);
    assert_eq!((five[..4].to_vec(), five[4]), (corners.to_vec(), at(0.5, 0.5)));
    // Jittered: one point in each quarter, the same for the same key, new for another.
    let j1 = probe_targets(&scene, Probe::Jittered, 0, 1);
    for (i, p) in j1[..4].iter().enumerate() {
        let (a, b) = ((*p - c).dot(u) / u.length_squared(), (*p - c).dot(v) / v.length_squared());
        let (qa, qb) = (0.5 * (i & 1) as f32, 0.5 * (i >> 1) as f32);
        assert!((qa..=qa + 0.5).contains(&a) && (qb..=qb + 0.5).contains(&b), "probe {i} at ({a}, {b})");
        assert!((p.y - c.y).abs() < 1e-6, "probe {i} off the light");
    }
    assert_eq!(j1, probe_targets(&scene, Probe::Jittered, 0, 1));
    assert_ne!(j1[..4], probe_targets(&scene, Probe::Jittered, 0, 2)[..4]);
}

/// Where a shadow ray from `o` along `d` crosses the quad light, in its (u, v) coordinates.
fn light_uv(scene: &Scene, o: Vec3, d: Vec3) -> (f32, f32) {
    let (corner, u, v, _) = quad(scene);
    let n = u.cross(v);
    let p = o + d * ((corner - o).dot(n) / d.dot(n)) - corner;
    (p.dot(u) / u.length_squared(), p.dot(v) / v.length_squared())
}

#[test]
fn a_pixels_shadow_rays_are_stratified_over_all_its_camera_samples() {
    // One shading point seen by 16 camera samples of one point (same key, samples 0..16),
    // 16 shadow rays each: the 256 rays hit the light once in each of every 2^a × 2^(8-a)
    // grid's cells, and each camera sample's 16 once in each cell of every 16-cell grid.
    let scene = quad_lit("", &["render.shadows.samples=16"]);
    let mut rays = RayQueue::default();
    for sample in 0..16 {
        rays.push(Vec3::new(0.1, 1.0, 0.2), DOWN, 0, Vec3::ONE, 0, 0x5eed, sample, 0.0, None);
    }
    let hits = trace(&scene, &rays);
    let out = shade(&scene, &rays, &hits);
    assert_eq!(out.shadow.len(), 256, "every sample of the light faces the point");
    let uv: Vec<(f32, f32)> = (0..256).map(|i| light_uv(&scene, out.shadow.origin(i), out.shadow.dir(i))).collect();
    let stratified = |points: &[(f32, f32)], k: u32| {
        (0..=k).all(|a| {
            let (cols, rows) = (1u32 << a, 1u32 << (k - a));
            let mut cells = vec![0; 1 << k];
            for &(x, y) in points {
                let (c, r) = (((x * cols as f32) as u32).min(cols - 1), ((y * rows as f32) as u32).min(rows - 1));
                cells[(r * cols + c) as usize] += 1;
            }
            cells.iter().all(|&n| n == 1)
        })
    };
    assert!(stratified(&uv, 8), "the pixel's 256 light samples form a (0, 8, 2)-net");
    for s in 0..16 {
        assert!(stratified(&uv[s * 16..(s + 1) * 16], 4), "camera sample {s}'s 16 light samples form a net");
    }
    // A different point key draws a different (scrambled) pattern.
    let mut other = RayQueue::default();
    other.push(Vec3::new(0.1, 1.0, 0.2), DOWN, 0, Vec3::ONE, 0, 0x5eee, 0, 0.0, None);
    let o = shade(&scene, &other, &trace(&scene, &other));
    assert_ne!(light_uv(&scene, o.shadow.origin(0), o.shadow.dir(0)), uv[0]);
}

#[test]
fn focus_probes_on_lanes_equal_the_scalar_formulas() {
    use glam::Vec2;
    use wavetrace::stages::focus;
    let scene = support::scene(wavetrace::DEFAULT_SCENE, &["camera.aperture=0.2", "camera.focus_distance=4.0"]);
    let (w, h) = (scene.settings.width, scene.settings.height);
    // Scattered over the frame: some probes hit, some see the sky.
    let film = |i: u32| Vec2::new(((i * 53) % w) as f32 + 0.25, ((i * 29) % h) as f32 + 0.5);
    // 37 probes from point 5: two full lane groups and a partial one.
    let mut rays = RayQueue::default();
    focus::generate(&scene, 5..42, film, &mut rays);
    assert_eq!(rays.len(), 37);
    let (s, cam) = (&scene.settings, &scene.camera);
    for i in 0..rays.len() {
        let d = cam.pinhole_dir(film(5 + i as u32), s.width, s.height);
        assert_eq!(rays.dir(i).to_array().map(f32::to_bits), d.to_array().map(f32::to_bits), "probe {i}");
        assert_eq!((rays.origin(i), rays.slot[i]), (cam.position, i as u32));
    }
    let (_, hits) = support::step(&scene, &rays);
    let (mut sharp, mut lens) = (vec![0.0; 40], vec![0.0; 40]);
    focus::blur(&scene, &rays, &hits, 2, &mut sharp, &mut lens);
    for i in 0..rays.len() {
        let r = focus::coc_pixels::<f32>(&scene, hits.t[i] * rays.dir(i).dot(cam.forward));
        assert_eq!(sharp[2 + i].to_bits(), r.to_bits(), "probe {i}");
        assert!(lens[2 + i].to_bits() == r.to_bits() || lens[2 + i] == f32::INFINITY, "probe {i}");
    }
    assert!(hits.t.iter().any(|t| t.is_finite()) && hits.t.iter().any(|t| t.is_infinite()), "hits and misses both");
}
