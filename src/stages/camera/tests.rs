//! The camera stage's rays against their scalar formulas.

use super::*;

/// Ray `i` of `q`, every field as bits.
#[allow(clippy::type_complexity)]
fn ray_bits(q: &RayQueue, i: usize) -> ([[u32; 3]; 3], u32, u32, u32, u32) {
    let v = [q.origin(i), q.dir(i), q.weight(i)].map(|v| v.to_array().map(f32::to_bits));
    (v, q.slot[i], q.key[i], q.sample[i], q.depth[i])
}

#[test]
fn lanes_give_the_rays_of_the_scalar_formulas() {
    use crate::scene::{load, SceneSource};
    let cases = [
        (37, 1, 0.0),
        (64, 1, 0.0),
        (5, 3, 0.0),
        (16, 1, 0.1),
        (6, 4, 0.1),
        (4, 1, 0.0),
        (1, 1, 0.1),
        (3, 1, 0.1),
        (2, 3, 0.1),
    ];
    for (aa, dof, aperture) in cases {
        let sets = [
            "render.width=13".to_string(),
            "render.height=7".to_string(),
            format!("render.aa.samples={aa}"),
            format!("render.dof.samples={dof}"),
            format!("camera.aperture={aperture}"),
        ];
        let scene = load(&SceneSource::default_scene(), &sets).unwrap();
        let s = &scene.settings;
        let tile = Tile { x0: 2, y0: 1, x1: 11, y1: 6 };
        let dof = s.dof_samples; // a pinhole takes one lens ray whatever is asked
        let spp = (aa * dof) as u64;
        let total = 45 * spp;
        // Ranges that start and end inside pixels and inside a 16-lane group.
        for ks in [0..total, 3..total - 5, spp + 17..3 * spp + 40] {
            let mut rays = RayQueue::default();
            generate(&scene, &tile, UniformPass::of(s), ks.clone(), &mut rays);
            assert_eq!(rays.len() as u64, ks.end - ks.start);
            for (i, k) in ks.enumerate() {
                let slot = block_slot(&tile, (k / spp) as u32);
                let j = (k % spp) as u32;
                let (x, y) = (tile.x0 + slot % 9, tile.y0 + slot / 9);
                let pixel = y * s.width + x;
                let film = Vec2::new(x as f32, y as f32) + cmj(j / dof, aa, hash(&[s.seed, pixel, dim::PIXEL]));
                let mut d = scene.camera.pinhole_dir(film, s.width, s.height);
                let mut o = scene.camera.position;
                if aperture > 0.0 {
                    let lens = lens_sample(&scene, pixel, j / dof, j % dof, j, hash(&[s.seed, pixel, dim::LENS]));
                    (o, d) = thin_lens(&scene, d, lens);
                }
                let bits = |v: Vec3| v.to_array().map(f32::to_bits);
                assert_eq!((bits(rays.origin(i)), bits(rays.dir(i))), (bits(o), bits(d)), "{sets:?} ray {k}");
                assert_eq!((rays.slot[i], rays.sample[i], rays.depth[i]), (slot, j, 0));
                assert_eq!(rays.key[i], hash(&[s.seed, pixel, dim::PATH]));
                assert_eq!(rays.weight(i), Vec3::splat(1.0 / spp as f32));
            }
        }
    }
}

#[test]
fn lens_rays_on_lanes_give_the_rays_of_the_scalar_formulas() {
    use crate::scene::{load, SceneSource};
    let sets = ["render.width=13", "render.height=7", "camera.aperture=0.1"].map(String::from);
    let scene = load(&SceneSource::default_scene(), &sets).unwrap();
    let s = &scene.settings;
    let tile = Tile { x0: 2, y0: 1, x1: 11, y1: 6 };
    let starts = [0u64, 1, 4, 4 + 70, 4 + 70 + 17, 4 + 70 + 17 + 33];
    let check = |name: &str, total: u64, gen: &dyn Fn(Range<u64>, &mut RayQueue), want: &dyn Fn(u64, &mut RayQueue)| {
        // Ranges that start and end inside points and inside a 16-lane group.
        for ks in [0..total, 3..total - 5, 17..total / 2 + 9] {
            let (mut got, mut expect) = (RayQueue::default(), RayQueue::default());
            gen(ks.clone(), &mut got);
            for k in ks.clone() {
                want(k, &mut expect);
            }
            assert_eq!(got.len(), expect.len(), "{name} {ks:?}");
            for i in 0..got.len() {
                assert_eq!(ray_bits(&got, i), ray_bits(&expect, i), "{name} {ks:?} ray {i}");
            }
        }
    };
    let grid = Tile { x0: 1, y0: 0, x1: 6, y1: 3 };
    for lens in [Lens::Fixed(70), Lens::Fixed(5), Lens::PerPoint(&starts)] {
        let corner = |ci: u32, l: u32, count: u32, slot: u32, q: &mut RayQueue| {
            let (cx, cy) = (ci % (s.width + 1), ci / (s.width + 1));
            let pattern = hash(&[s.seed, ci, dim::CORNER]);
            let w = Vec3::splat(1.0 / count as f32);
            push(&scene, Vec2::new(cx as f32, cy as f32), || cmj(l, count, pattern), slot, w, (pattern, l), q);
        };
        let points = 5;
        check("corner grid", lens.total(points), &|ks, q| generate_corner_grid(&scene, &grid, lens, ks, q), &|k, q| {
            let (slot, l, count) = lens.split(k);
            corner(corner_index(&scene, grid.x0 + slot % 5, grid.y0 + slot / 5), l, count, slot, q);
        });
        check(
            "pixel corners",
            lens.total(points),
            &|ks, q| generate_pixel_corners(&scene, &tile, lens, ks, q),
            &|k, q| {
                let (slot, l, count) = lens.split(k);
                let (p, c) = (slot / 4, slot % 4);
                let (x, y) = (tile.x0 + p % 9 + (c & 1), tile.y0 + p / 9 + (c >> 1));
                corner(corner_index(&scene, x, y), l, count, slot, q);
            },
        );
        check("centres", lens.total(points), &|ks, q| generate_centres(&scene, &tile, lens, ks, q), &|k, q| {
            let (slot, l, count) = lens.split(k);
            let (x, y) = (tile.x0 + slot % 9, tile.y0 + slot / 9);
            let pattern = hash(&[s.seed, y * s.width + x, dim::CENTRE]);
            let film = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
            push(&scene, film, || cmj(l, count, pattern), slot, Vec3::splat(1.0 / count as f32), (pattern, l), q);
        });
    }
    // Refinement: 2^level samples per pixel, each with its lens rays.
    let pixels = [0u32, 3, 4, 20, 44];
    for (level, per) in [(1u32, 5u64), (2, 70), (3, 3)] {
        let lens = Lens::Fixed(per << level);
        let n = 1u32 << level;
        check(
            "refine",
            lens.total(pixels.len()),
            &|ks, q| generate_refine(&scene, RefinePass { tile: &tile, pixels: &pixels, level }, lens, ks, q),
            &|k, q| {
                let (i, j, all) = lens.split(k);
                let (slot, count) = (pixels[i as usize], all >> level);
                let (sample, l) = (j / count, j % count);
                let (x, y) = (tile.x0 + slot % 9, tile.y0 + slot / 9);
                let pixel = y * s.width + x;
                let key = hash(&[s.seed, pixel, level, dim::REFINE]);
                let film = Vec2::new(x as f32, y as f32) + cmj(sample, n, key);
                let lens = || cmj(l, count, hash(&[s.seed, pixel, level, sample, dim::LENS]));
                push(&scene, film, lens, slot, Vec3::splat(1.0 / (n * count) as f32), (key, j), q);
            },
        );
    }
}

#[test]
fn variance_rounds_on_lanes_give_the_rays_of_the_scalar_formulas() {
    use crate::scene::{load, SceneSource};
    let tile = Tile { x0: 2, y0: 1, x1: 11, y1: 6 };
    let pixels = [0u32, 3, 4, 20, 44];
    let mut state = HalfBufferQueue::default();
    for p in 0..45u32 {
        state.push(Vec3::ZERO, Vec3::ZERO, 3 * p % 7, (p % 3) as u8);
    }
    for (aperture, dof) in [(0.0, 1), (0.1, 1), (0.1, 3)] {
        let sets = ["render.width=13", "render.height=7"].map(String::from);
        let sets = [&sets[..], &[format!("camera.aperture={aperture}"), format!("render.dof.samples={dof}")]].concat();
        let scene = load(&SceneSource::default_scene(), &sets).unwrap();
        let s = &scene.settings;
        let count = s.dof_samples;
        // Pixels with 1, 16, 37, 5 and 2 samples this round.
        let starts: Vec<u64> = [0u64, 1, 17, 54, 59, 61].map(|k| k * count as u64).to_vec();
        let lens = Lens::PerPoint(&starts);
        let total = lens.total(pixels.len());
        for ks in [0..total, 3..total - 5, 17..total / 2 + 9] {
            let mut got = RayQueue::default();
            let pass = VariancePass { tile: &tile, pixels: &pixels, state: &state };
            generate_variance(&scene, pass, lens, ks.clone(), &mut got);
            let mut want = RayQueue::default();
            for k in ks.clone() {
                let (i, j, _) = lens.split(k);
                let p = pixels[i as usize];
                let (before, round) = (state.count[p as usize], state.rounds[p as usize] as u32);
                let (sample, l) = (j / count, j % count);
                let (x, y) = (tile.x0 + p % 9, tile.y0 + p / 9);
                let pixel = y * s.width + x;
                // The pixel's sample g, of one key and one film sequence over its rounds.
                let (key, g) = (hash(&[s.seed, pixel, dim::VARIANCE]), before + sample);
                let film_seed = hash(&[s.seed, pixel, dim::PIXEL, dim::VARIANCE]);
                let film = Vec2::new(x as f32, y as f32) + sobol_owen(g, film_seed);
                let lens = || match count {
                    1 => sobol_owen(g, hash(&[s.seed, pixel, dim::LENS])),
                    _ => cmj(l, count, hash(&[s.seed, pixel, round, sample, dim::LENS])),
                };
                let (slot, w) = (2 * p + (g & 1), Vec3::splat(1.0 / count as f32));
                push(&scene, film, lens, slot, w, (key, g * count + l), &mut want);
            }
            assert_eq!(got.len(), want.len(), "{sets:?} {ks:?}");
            for i in 0..got.len() {
                assert_eq!(ray_bits(&got, i), ray_bits(&want, i), "{sets:?} {ks:?} ray {i}");
            }
        }
    }
}

#[test]
fn pinhole_refinement_on_lanes_gives_the_rays_of_the_scalar_formulas() {
    use crate::scene::{load, SceneSource};
    let sets = ["render.width=13", "render.height=7", "camera.aperture=0"].map(String::from);
    let scene = load(&SceneSource::default_scene(), &sets).unwrap();
    let s = &scene.settings;
    let tile = Tile { x0: 2, y0: 1, x1: 11, y1: 6 };
    let pixels = [0u32, 3, 4, 20, 44];
    for level in [1u32, 2, 5] {
        let n = 1u32 << level;
        let lens = Lens::Fixed(n as u64);
        let total = lens.total(pixels.len());
        for ks in [0..total, 3..total - 5, 17..total / 2 + 9] {
            let (mut got, mut want) = (RayQueue::default(), RayQueue::default());
            generate_refine(&scene, RefinePass { tile: &tile, pixels: &pixels, level }, lens, ks.clone(), &mut got);
            for k in ks.clone() {
                let (i, j, _) = lens.split(k);
                let slot = pixels[i as usize];
                let (x, y) = (tile.x0 + slot % 9, tile.y0 + slot / 9);
                let key = hash(&[s.seed, y * s.width + x, level, dim::REFINE]);
                let film = Vec2::new(x as f32, y as f32) + cmj(j, n, key);
                push(&scene, film, || unreachable!(), slot, Vec3::splat(1.0 / n as f32), (key, j), &mut want);
            }
            assert_eq!(got.len(), want.len());
            for i in 0..got.len() {
                assert_eq!(ray_bits(&got, i), ray_bits(&want, i), "level {level} {ks:?} ray {i}");
            }
        }
    }
}

#[test]
fn lens_runs_walk_as_split_says() {
    // A point with no ray (the fourth) is skipped.
    let starts = [0u64, 1, 4, 4 + 70, 4 + 70, 4 + 70 + 2];
    for lens in [Lens::Fixed(3), Lens::Fixed(1), Lens::PerPoint(&starts)] {
        let total = lens.total(5);
        for a in 0..total {
            for b in a..=total.min(a + 9) {
                let split: Vec<_> = (a..b).map(|k| lens.split(k)).collect();
                let runs: Vec<_> = lens.runs(a..b).flat_map(|(p, rs, n)| rs.map(move |r| (p, r, n))).collect();
                assert_eq!(runs, split, "{lens:?} {a}..{b} in runs");
            }
        }
    }
    assert_eq!(Lens::PerPoint(&starts).split(3), (1, 2, 3));
    assert_eq!(Lens::PerPoint(&starts).split(4), (2, 0, 70));
}

#[test]
fn block_order_visits_every_pixel_once_in_squares() {
    for tw in 1..=16 {
        for th in 1..=16 {
            let tile = Tile { x0: 32, y0: 16, x1: 32 + tw, y1: 16 + th };
            let mut seen = vec![false; (tw * th) as usize];
            for q in 0..tw * th {
                let s = block_slot(&tile, q) as usize;
                assert!(!seen[s], "{tw}x{th}: slot {s} twice");
                seen[s] = true;
            }
        }
    }
    // A full tile: each run of 16 is one 4×4 square.
    let tile = Tile { x0: 0, y0: 0, x1: 16, y1: 16 };
    for run in 0..16 {
        let xy: Vec<(u32, u32)> =
            (run * 16..run * 16 + 16).map(|q| block_slot(&tile, q)).map(|s| (s % 16, s / 16)).collect();
        let (x0, y0) = xy[0];
        assert!(xy.iter().all(|&(x, y)| x - x0 < 4 && y - y0 < 4), "{xy:?}");
    }
}
