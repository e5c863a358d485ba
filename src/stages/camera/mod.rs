//! Camera generation: writes camera rays for uniform pixel samples, for the adaptive
//! method's pixel corners and centres, for refinement levels, and for the rounds of
//! variance-driven AA. Thin-lens sampling only when the aperture is open. Reads nothing
//! but the scene.
//!
//! Every generator takes a range of a flattened (point, sample) index, so the driver can
//! cut any amount of work into waves of bounded size.

use glam::{Vec2, Vec3};
use std::ops::Range;
use wide::{f32x16, u32x16};

use super::Tile;
use crate::queue::{HalfBufferQueue, RayQueue};
use crate::sampling::{
    cmj, cmj_keyed, cmj_lanes, concentric_disk_lanes, dim, dither_lanes, hash, hash_lanes, sobol_owen,
    sobol_owen_lanes, CmjKey, CMJ_LANES_MAX,
};
use crate::scene::{Scene, Settings};
use crate::simd::{iota, words, LaneIds, Real, Word, LANES, V3};

/// How many lens rays each point of a pass gets, and how a flattened ray index splits
/// into (point, ray of the point).
#[derive(Clone, Copy, Debug)]
pub enum Lens<'a> {
    /// Every point gets this many rays.
    Fixed(u64),
    /// Point i gets rays `starts[i]..starts[i + 1]` of the pass (prefix sums, one more
    /// entry than points): DOF-aware AA, where each point has its own lens count.
    PerPoint(&'a [u64]),
}

impl<'a> Lens<'a> {
    /// Rays of a pass over `points` points.
    pub fn total(&self, points: usize) -> u64 {
        match *self {
            Lens::Fixed(n) => points as u64 * n,
            Lens::PerPoint(starts) => starts[points],
        }
    }

    /// The point of flattened ray `k`, the ray's index within the point, and the
    /// point's ray count.
    #[inline]
    pub fn split(&self, k: u64) -> (u32, u32, u32) {
        match *self {
            Lens::Fixed(n) => ((k / n) as u32, (k % n) as u32, n as u32),
            Lens::PerPoint(starts) => {
                let p = starts.partition_point(|&s| s <= k) - 1;
                ((p as u32), (k - starts[p]) as u32, (starts[p + 1] - starts[p]) as u32)
            }
        }
    }

    /// Rays `ks` as runs of one point each: (point, its rays in the run, the point's ray
    /// count), in order; ray by ray, what [`Lens::split`] gives.
    pub fn runs(self, ks: Range<u64>) -> impl Iterator<Item = (u32, Range<u32>, u32)> + 'a {
        // One search for the first ray, then a walk (no division per run: a pinhole's
        // runs are single rays).
        let (mut point, mut ray, mut count) = if ks.is_empty() { (0, 0, 0) } else { self.split(ks.start) };
        let mut left = ks.end.saturating_sub(ks.start);
        std::iter::from_fn(move || {
            if left == 0 {
                return None;
            }
            let n = ((count - ray) as u64).min(left) as u32;
            let run = (point, ray..ray + n, count);
            left -= n as u64;
            if let Lens::PerPoint(starts) = self {
                // The next point with rays (there is one while rays are left).
                if left > 0 {
                    loop {
                        point += 1;
                        count = (starts[point as usize + 1] - starts[point as usize]) as u32;
                        if count > 0 {
                            break;
                        }
                    }
                }
            } else {
                point += 1;
            }
            ray = 0;
            Some(run)
        })
    }
}

/// Motion blur: gives each camera ray of `rays` its time, `open + (close − open)·u` with
/// u point `sample` of the Owen-scrambled Sobol sequence of its path's `key` and
/// [`dim::TIME`], so a point's times are stratified over its samples as its film and
/// lens positions are; a moving camera then carries each ray to where it is at its
/// time. Without motion blur nothing is drawn and the rays stay as generated.
pub fn shutter_times(scene: &Scene, rays: &mut RayQueue) {
    if !scene.motion_blur() {
        return;
    }
    let [open, close] = scene.settings.shutter;
    rays.fill_sparse(open);
    let n = rays.len();
    // 16 rays at a time on lanes: the scalar formula's operations, so its bits.
    for base in (0..n).step_by(LANES) {
        let m = (n - base).min(LANES);
        let lanes = |col: &[u32]| {
            let mut a = [0u32; LANES];
            a[..m].copy_from_slice(&col[base..base + m]);
            u32x16::from(a)
        };
        let seed = hash_lanes([lanes(&rays.key), u32x16::splat(dim::TIME)]);
        let (u, _) = sobol_owen_lanes(lanes(&rays.sample), seed);
        let time = f32x16::splat(open) + f32x16::splat(close - open) * u;
        rays.time[base..base + m].copy_from_slice(&time.to_array()[..m]);
    }
    if let Some(m) = &scene.camera.motion {
        for i in 0..n {
            let (o, d) = m.ray(rays.time[i], rays.origin(i), rays.dir(i));
            (rays.ox[i], rays.oy[i], rays.oz[i]) = (o.x, o.y, o.z);
            (rays.dx[i], rays.dy[i], rays.dz[i]) = (d.x, d.y, d.z);
        }
    }
}

/// Pushes one camera ray through film position `film` (pixels), through lens position
/// `lens()` in [0,1)² (not evaluated for a pinhole), named by its point `key` and
/// `sample` index.
#[inline]
fn push(
    scene: &Scene,
    film: Vec2,
    lens: impl FnOnce() -> Vec2,
    slot: u32,
    w: Vec3,
    (key, sample): (u32, u32),
    rays: &mut RayQueue,
) {
    let s = &scene.settings;
    let cam = &scene.camera;
    let d = cam.pinhole_dir(film, s.width, s.height);
    if cam.aperture > 0.0 {
        let (o, d) = thin_lens(scene, d, lens());
        rays.push(o, d, slot, w, 0, key, sample, 0.0, None);
    } else {
        rays.push(cam.position, d, slot, w, 0, key, sample, 0.0, None);
    }
}

/// The thin-lens ray whose pinhole direction is `d`, through lens position `lens` in
/// [0,1)²: every ray through the same film point meets on the focus plane.
#[inline]
fn thin_lens(scene: &Scene, d: Vec3, lens: Vec2) -> (Vec3, Vec3) {
    // The disk on lanes, lane 0 kept: a lens ray has the same bits on either path.
    let (x, y) = concentric_disk_lanes(f32x16::splat(lens.x), f32x16::splat(lens.y));
    let (o, d) = thin_lens_lanes(scene, V3::from_vec(d), x.to_array()[0], y.to_array()[0]);
    (o.vec(), d.vec())
}

/// [`thin_lens`] on lanes, from lens positions already mapped to the unit disk.
#[inline(always)]
fn thin_lens_lanes<R: Real>(scene: &Scene, d: V3<R>, disk_x: R, disk_y: R) -> (V3<R>, V3<R>) {
    let cam = &scene.camera;
    let position = V3::splat(cam.position);
    let focus = position + d.scale(R::splat(cam.focus_distance) / d.dot(V3::splat(cam.forward)));
    let (lx, ly) = (R::splat(cam.aperture) * disk_x, R::splat(cam.aperture) * disk_y);
    let o = position + V3::splat(cam.right).scale(lx) + V3::splat(cam.up).scale(ly);
    (o, (focus - o).normalize())
}

/// Lens rays `ls` of the `count` through film position `film`: ray l through lens
/// position `cmj(l, count, pattern)`, with path `(key, base + l)`. What [`push`] gives
/// ray by ray, 16 at a time on lanes (the CMJ pattern, the disk mapping and the thin lens).
fn lens_rays(
    scene: &Scene,
    film: Vec2,
    (ls, count, pattern): (Range<u32>, u32, u32),
    (slot, w): (u32, Vec3),
    (key, base): (u32, u32),
    rays: &mut RayQueue,
) {
    let cam = &scene.camera;
    if cam.aperture <= 0.0 || count > CMJ_LANES_MAX {
        for l in ls {
            push(scene, film, || cmj(l, count, pattern), slot, w, (key, base + l), rays);
        }
        return;
    }
    let s = &scene.settings;
    let d = V3::<f32x16>::splat(cam.pinhole_dir(film, s.width, s.height));
    let w = w.to_array().map(|x| [x; LANES]);
    for l0 in ls.clone().step_by(LANES) {
        let n = (ls.end - l0).min(LANES as u32) as usize;
        // Lanes past the last ray repeat it (a valid index) and are not written.
        let l = iota(l0).min(u32x16::splat(ls.end - 1));
        let (x, y, _) = cmj_lanes(l, count, pattern);
        let (disk_x, disk_y) = concentric_disk_lanes(x, y);
        let (o, dir) = thin_lens_lanes(scene, d, disk_x, disk_y);
        let sample = words(l + u32x16::splat(base));
        rays.push_lanes(
            o.lanes(),
            dir.lanes(),
            [slot; LANES],
            w,
            [0; LANES],
            [key; LANES],
            sample,
            [0.0; LANES],
            None,
            n,
        );
    }
}

/// A uniform pass's camera samples: how many in every pixel, and whether the pixels of
/// each 2×2 block share their paths' sequences ([`dither`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct UniformPass {
    /// Camera samples a pixel (each with the scene's lens samples).
    pub samples: u32,
    /// Blue-noise dithering.
    pub dither: bool,
}

impl UniformPass {
    /// Uniform mode's pass: `render.aa.samples`, dithered with `render.blue_noise`.
    pub fn of(s: &Settings) -> UniformPass {
        UniformPass { samples: s.aa_samples, dither: s.blue_noise }
    }
}

/// Uniform mode: camera rays for the flattened (pixel, sample) indices `ks` of `tile`:
/// k is pixel k / spp of the tile in [`block_slot`] order and per-pixel sample j = k % spp, which is
/// AA sample j / dof_samples and lens sample j % dof_samples. Film positions are a CMJ
/// pattern of the pixel's AA samples; lens positions a CMJ pattern of each AA sample's
/// lens rays, or, with one lens ray per AA sample, sample j of an Owen-scrambled Sobol
/// sequence of the pixel (stratified over the pixel's AA samples). Slot: the pixel's index
/// in the tile. Each ray carries weight 1 / spp, so a pixel's sum is its mean.
pub fn generate(scene: &Scene, tile: &Tile, pass: UniformPass, ks: Range<u64>, rays: &mut RayQueue) {
    rays.clear();
    if ks.is_empty() {
        return;
    }
    let aa = pass.samples;
    let s = &scene.settings;
    let spp = aa as u64 * s.dof_samples as u64;
    // A pixel with at least as many samples as lanes fills them alone; fewer share them.
    if spp >= LANES as u64 {
        let mut k = ks.start;
        while k < ks.end {
            let q = k / spp;
            let end = (ks.end - q * spp).min(spp);
            pixel_samples(scene, tile, pass, q as u32, (k - q * spp) as u32..end as u32, rays);
            k = q * spp + end;
        }
        return;
    }
    let cam = &scene.camera;
    let dof = s.dof_samples;
    let w = Vec3::splat(1.0 / spp as f32).to_array().map(|x| [x; LANES]);
    // 16 (pixel, sample) indices at a time, consecutive pixels sharing the lanes where a
    // pixel has fewer samples than lanes; each lane has its pixel's keys, read from the
    // keys of 16 pixels made at a time.
    let spp = spp as u32;
    let mut pixels = Pixels::sixteen(scene, tile, pass, ks.start as u32 / spp);
    for k0 in ks.clone().step_by(LANES) {
        let count = (ks.end - k0).min(LANES as u64) as usize;
        // Lanes past the last sample repeat it (a valid index) and are not written.
        let last = k0 as u32 + count as u32 - 1;
        let (q, j) = iota(k0 as u32).min(u32x16::splat(last)).div_rem(spp);
        if last / spp >= pixels.q0 + LANES as u32 {
            pixels = Pixels::sixteen(scene, tile, pass, k0 as u32 / spp);
        }
        let lane = pixels.lanes(q, j);
        let sample = if dof == 1 { lane.j } else { lane.j.div_rem(dof).0 };
        let (cx, cy, _) = cmj_keyed(sample, aa, lane.cmj);
        let (fx, fy) = (lane.x + cx, lane.y + cy);
        let d = cam.pinhole_dirs(fx, fy, s.width, s.height);
        if cam.aperture > 0.0 {
            // One lens ray per AA sample: each pixel's Sobol points on lanes (what
            // `lens_sample` gives, bit for bit); several: each AA sample's CMJ pattern,
            // lane by lane. The disk mapping and the thin-lens rays on lanes.
            let (x, y) = if dof == 1 {
                sobol_owen_lanes(lane.index, lane.lens_seed)
            } else {
                let (aw, jw, seed, mut lens) = (words(sample), words(lane.j), words(lane.lens_seed), [[0.0; LANES]; 2]);
                for k in 0..LANES {
                    (lens[0][k], lens[1][k]) =
                        lens_sample(scene, lane.pixel[k], aw[k], jw[k] % dof, jw[k], seed[k]).into();
                }
                (f32x16::from(lens[0]), f32x16::from(lens[1]))
            };
            push_lanes(scene, d, Some((x, y)), (lane.slot, lane.path, words(lane.index)), w, count, rays);
        } else {
            push_lanes(scene, d, None, (lane.slot, lane.path, words(lane.index)), w, count, rays);
        }
    }
}

/// What 16 consecutive pixels' camera rays draw on: their places and their keys (see
/// [`generate`]), a column each.
struct Pixels {
    /// The first one's place in [`block_slot`] order.
    q0: u32,
    /// Their indices in the tile.
    slot: [u32; LANES],
    x: [f32; LANES],
    y: [f32; LANES],
    /// Their indices in the image.
    pixel: [u32; LANES],
    /// Their AA samples' CMJ patterns, word by word.
    cmj: [[u32; LANES]; 8],
    /// The keys of their rays' paths.
    path: [u32; LANES],
    /// The seeds of their lens samples.
    lens_seed: [u32; LANES],
    /// Their first indices in the sequences of `path` and `lens_seed` (0 unless dithered).
    first: [u32; LANES],
}

/// Pixel (`x`, `y`)'s path key, lens seed and first index in their sequences, for `n`
/// samples: its own, or when `dithered` its 2×2 block's ([`dither_lanes`]). One pixel's
/// (`u32`) or 16 pixels' on lanes.
#[inline(always)]
fn pixel_keys<W: Word>(s: &Settings, dithered: bool, x: W, y: W, n: u32) -> (W, W, W) {
    let (owner, first) = match dithered {
        true => dither_lanes(s.seed, s.width, x, y, n),
        false => (y.wmul(W::splat(s.width)).wadd(x), W::splat(0)),
    };
    let key = |d: u32| hash_lanes([W::splat(s.seed), owner, W::splat(d)]);
    (key(dim::PATH), key(dim::LENS), first)
}

impl Pixels {
    /// The `q0`-th to `q0 + 15`-th pixels of `tile` in [`block_slot`] order (past its
    /// last, the last again), their keys hashed on lanes ([`pixel_keys`], and the CMJ
    /// pattern of [`pixel_samples`]).
    fn sixteen(scene: &Scene, tile: &Tile, pass: UniformPass, q0: u32) -> Pixels {
        let (s, aa) = (&scene.settings, pass.samples);
        let (tw, last) = (tile.x1 - tile.x0, tile.pixels() as u32 - 1);
        let slot: [u32; LANES] = std::array::from_fn(|k| block_slot(tile, (q0 + k as u32).min(last)));
        let (row, col) = u32x16::from(slot).div_rem(tw);
        let (x, y) = (col + u32x16::splat(tile.x0), row + u32x16::splat(tile.y0));
        let pixel = y * u32x16::splat(s.width) + x;
        let (path, lens_seed, first) = pixel_keys(s, pass.dither, x, y, aa * s.dof_samples);
        let keys = CmjKey::sixteen(hash_lanes([u32x16::splat(s.seed), pixel, u32x16::splat(dim::PIXEL)]), aa);
        let [x, y] = [x, y].map(|v| words(v).map(|c| c as f32));
        let cmj = std::array::from_fn(|w| std::array::from_fn(|k| keys[k].0[w]));
        let [path, lens_seed, first] = [path, lens_seed, first].map(words);
        Pixels { q0, slot, x, y, pixel: words(pixel), cmj, path, lens_seed, first }
    }

    /// Lane k: sample `j[k]` of pixel `q[k]` (each one of these 16).
    #[inline(always)]
    fn lanes(&self, q: u32x16, j: u32x16) -> Lanes {
        // Consecutive samples: a pixel's `spp` lanes side by side, which `LaneIds` loads
        // as a few values and a shuffle.
        let ids = LaneIds::new(&words(q - u32x16::splat(self.q0)));
        let index = j + ids.gather_words(&self.first);
        Lanes {
            slot: words(ids.gather_words(&self.slot)),
            x: ids.gather(&self.x),
            y: ids.gather(&self.y),
            pixel: words(ids.gather_words(&self.pixel)),
            cmj: self.cmj.each_ref().map(|c| ids.gather_words(c)),
            path: words(ids.gather_words(&self.path)),
            lens_seed: ids.gather_words(&self.lens_seed),
            j,
            index,
        }
    }
}

/// 16 camera samples' pixels and sample indices, lane by lane.
struct Lanes {
    slot: [u32; LANES],
    x: f32x16,
    y: f32x16,
    pixel: [u32; LANES],
    cmj: [u32x16; 8],
    path: [u32; LANES],
    lens_seed: u32x16,
    j: u32x16,
    /// Each lane's sample index in its path's sequences: `j` past its pixel's first.
    index: u32x16,
}

/// Samples `js` of the `q`-th pixel of `tile` (see [`generate`]), a pixel with at least
/// as many samples as lanes: 16 at a time on SIMD lanes (film position, pinhole
/// direction, lens), or one at a time past the lanes' CMJ pattern.
fn pixel_samples(scene: &Scene, tile: &Tile, pass: UniformPass, q: u32, js: Range<u32>, rays: &mut RayQueue) {
    let (s, n) = (&scene.settings, pass.samples);
    let cam = &scene.camera;
    let dof = s.dof_samples;
    let spp = n * dof;
    let weight = Vec3::splat(1.0 / spp as f32);
    let w = weight.to_array().map(|x| [x; LANES]);
    let slot = block_slot(tile, q);
    let tw = tile.x1 - tile.x0;
    let (x, y) = (tile.x0 + slot % tw, tile.y0 + slot / tw);
    let pixel = y * s.width + x;
    let pattern = hash(&[s.seed, pixel, dim::PIXEL]);
    let (key, lens_seed, first) = pixel_keys(s, pass.dither, x, y, spp);
    if spp > CMJ_LANES_MAX {
        for j in js {
            let (aa, l) = (j / dof, j % dof);
            let film = Vec2::new(x as f32, y as f32) + cmj(aa, n, pattern);
            let lens = || lens_sample(scene, pixel, aa, l, first + j, lens_seed);
            push(scene, film, lens, slot, weight, (key, first + j), rays);
        }
        return;
    }
    let (fx0, fy0) = (f32x16::splat(x as f32), f32x16::splat(y as f32));
    for j0 in js.clone().step_by(LANES) {
        let count = (js.end - j0).min(LANES as u32) as usize;
        // Lanes past the last sample repeat it (a valid index) and are not written.
        let j = iota(j0).min(u32x16::splat(js.end - 1));
        let aa = if dof == 1 { j } else { j.div_rem(dof).0 };
        let (cx, cy, _) = cmj_lanes(aa, n, pattern);
        let (fx, fy) = (fx0 + cx, fy0 + cy);
        let d = cam.pinhole_dirs(fx, fy, s.width, s.height);
        let index = j + u32x16::splat(first);
        let jw = words(index);
        if cam.aperture > 0.0 {
            // One lens ray per AA sample: the pixel's Sobol points on lanes (what
            // `lens_sample` gives, bit for bit); several: each AA sample's CMJ pattern,
            // lane by lane. The disk mapping and the thin-lens rays on lanes.
            let (x, y) = if dof == 1 {
                sobol_owen_lanes(index, u32x16::splat(lens_seed))
            } else {
                let (aw, mut lens) = (words(aa), [[0.0; LANES]; 2]);
                for k in 0..LANES {
                    (lens[0][k], lens[1][k]) = lens_sample(scene, pixel, aw[k], jw[k] % dof, jw[k], lens_seed).into();
                }
                (f32x16::from(lens[0]), f32x16::from(lens[1]))
            };
            push_lanes(scene, d, Some((x, y)), ([slot; LANES], [key; LANES], jw), w, count, rays);
        } else {
            push_lanes(scene, d, None, ([slot; LANES], [key; LANES], jw), w, count, rays);
        }
    }
}

/// Pushes the first `count` of 16 camera rays with pinhole directions `d`: through lens
/// positions `lens` in [0,1)² (the disk mapping and the thin lens on lanes), or from
/// the pinhole; each with its (slot, path key, sample index).
#[allow(clippy::too_many_arguments)] // the rays' columns, as `RayQueue::push_lanes` takes them
fn push_lanes(
    scene: &Scene,
    d: V3<f32x16>,
    lens: Option<(f32x16, f32x16)>,
    (slot, key, sample): ([u32; LANES], [u32; LANES], [u32; LANES]),
    w: [[f32; LANES]; 3],
    count: usize,
    rays: &mut RayQueue,
) {
    let (o, d) = match lens {
        Some((x, y)) => {
            let (disk_x, disk_y) = concentric_disk_lanes(x, y);
            let (o, d) = thin_lens_lanes(scene, d, disk_x, disk_y);
            (o.lanes(), d.lanes())
        }
        None => (scene.camera.position.to_array().map(|x| [x; LANES]), d.lanes()),
    };
    rays.push_lanes(o, d, slot, w, [0; LANES], key, sample, [0.0; LANES], None, count);
}

/// Lens position of AA sample `aa`'s lens ray `l` (per-pixel sample `j`) in `pixel`.
/// Each AA sample's lens rays are a CMJ pattern of their own, so every film position gets
/// a stratified set of lens positions (measured better on the DOF scenes than one
/// sequence over the pixel); with one lens ray per AA sample that pattern is a single
/// random point, so the lens then follows the pixel's sequence (`lens_seed`).
#[inline]
fn lens_sample(scene: &Scene, pixel: u32, aa: u32, l: u32, j: u32, lens_seed: u32) -> Vec2 {
    let s = &scene.settings;
    match s.dof_samples {
        1 => sobol_owen(j, lens_seed),
        dof => cmj(l, dof, hash(&[s.seed, pixel, aa, dim::LENS])),
    }
}

/// Side of the screen blocks camera rays are generated in.
const BLOCK: u32 = 4;

/// The slot (row-major index in `tile`) of the `q`-th pixel when the tile is walked in 4×4
/// blocks: blocks row by row, pixels row by row inside a block (edge blocks are smaller).
/// Consecutive pixels then stay close on screen, so the packets the intersect stage cuts
/// from camera rays in generation order start coherent (16 consecutive pixels form a
/// square, not a strip); each pixel's samples stay in sample order, so the image does not
/// change.
pub fn block_slot(tile: &Tile, q: u32) -> u32 {
    let (tw, th) = (tile.x1 - tile.x0, tile.y1 - tile.y0);
    let band = tw * BLOCK;
    let (row, h, rest) = if q < (th / BLOCK) * band {
        (q / band, BLOCK, q % band)
    } else {
        (th / BLOCK, th % BLOCK, q - (th / BLOCK) * band)
    };
    let full = tw / BLOCK;
    let (col, bw, inner) = if rest < full * BLOCK * h {
        (rest / (BLOCK * h), BLOCK, rest % (BLOCK * h))
    } else {
        (full, tw % BLOCK, rest - full * BLOCK * h)
    };
    let (x, y) = (col * BLOCK + inner % bw, row * BLOCK + inner / bw);
    y * tw + x
}

/// Index of pixel corner (cx, cy) in the (W+1)×(H+1) corner grid.
#[inline]
pub fn corner_index(scene: &Scene, cx: u32, cy: u32) -> u32 {
    cy * (scene.settings.width + 1) + cx
}

/// Pushes lens rays `ls` of `count` through grid corner `ci`. A corner's rays depend
/// only on its index (and its lens count, which depends only on the corner too), so a
/// shared corner and a per-pixel copy of it give the same radiance.
#[inline]
fn corner_rays(scene: &Scene, ci: u32, ls: Range<u32>, count: u32, slot: u32, rays: &mut RayQueue) {
    let s = &scene.settings;
    let (cx, cy) = (ci % (s.width + 1), ci / (s.width + 1));
    let w = Vec3::splat(1.0 / count as f32);
    let film = Vec2::new(cx as f32, cy as f32);
    let pattern = hash(&[s.seed, ci, dim::CORNER]);
    lens_rays(scene, film, (ls, count, pattern), (slot, w), (pattern, 0), rays);
}

/// Adaptive AA, shared corners: rays through the corners of `grid`, a rectangle of the
/// corner grid. Flattened index k: corner and lens sample by `lens` (corners row-major in
/// the rectangle). Slot: the corner's index in the rectangle.
pub fn generate_corner_grid(scene: &Scene, grid: &Tile, lens: Lens, ks: Range<u64>, rays: &mut RayQueue) {
    rays.clear();
    let gw = grid.x1 - grid.x0;
    for (slot, ls, count) in lens.runs(ks) {
        let (cx, cy) = (grid.x0 + slot % gw, grid.y0 + slot / gw);
        corner_rays(scene, corner_index(scene, cx, cy), ls, count, slot, rays);
    }
}

/// Adaptive AA, unshared corners (the paper's 5 rays per pixel): the four corners of
/// every pixel of `tile`. Points are 4 × pixel + corner (0 top-left, 1 top-right,
/// 2 bottom-left, 3 bottom-right), each with its lens rays by `lens`. Slot: the point.
pub fn generate_pixel_corners(scene: &Scene, tile: &Tile, lens: Lens, ks: Range<u64>, rays: &mut RayQueue) {
    rays.clear();
    let tw = tile.x1 - tile.x0;
    for (slot, ls, count) in lens.runs(ks) {
        let (p, c) = (slot / 4, slot % 4);
        let (x, y) = (tile.x0 + p % tw + (c & 1), tile.y0 + p / tw + (c >> 1));
        corner_rays(scene, corner_index(scene, x, y), ls, count, slot, rays);
    }
}

/// Adaptive AA: rays through the centre of every pixel of `tile`, each pixel's lens rays
/// by `lens`. Slot: the pixel's index in the tile.
pub fn generate_centres(scene: &Scene, tile: &Tile, lens: Lens, ks: Range<u64>, rays: &mut RayQueue) {
    rays.clear();
    let s = &scene.settings;
    let tw = tile.x1 - tile.x0;
    for (slot, ls, count) in lens.runs(ks) {
        let w = Vec3::splat(1.0 / count as f32);
        let (x, y) = (tile.x0 + slot % tw, tile.y0 + slot / tw);
        let pixel = y * s.width + x;
        let pattern = hash(&[s.seed, pixel, dim::CENTRE]);
        let film = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
        lens_rays(scene, film, (ls, count, pattern), (slot, w), (pattern, 0), rays);
    }
}

/// A refinement pass of adaptive AA: its tile, the pixels it refines (indices in the
/// tile) and its level.
#[derive(Clone, Copy, Debug)]
pub struct RefinePass<'a> {
    /// The tile.
    pub tile: &'a Tile,
    /// The pixels still refined.
    pub pixels: &'a [u32],
    /// The refinement level: 2^level points per pixel.
    pub level: u32,
}

/// Adaptive AA, refinement level `level`: 2^level stratified points in each listed pixel
/// (`pixels` are indices in the tile). `lens` splits the flattened index into listed
/// pixel i and its ray j, of 2^level × (its lens count) rays: sample j / lens count, lens
/// ray j % lens count. Slot: the pixel's index in the tile; weight
/// 1 / (2^level · lens count), so a slot sums to the level's estimate.
pub fn generate_refine(scene: &Scene, pass: RefinePass, lens: Lens, ks: Range<u64>, rays: &mut RayQueue) {
    let RefinePass { tile, pixels, level } = pass;
    rays.clear();
    let s = &scene.settings;
    let n = 1u32 << level;
    let tw = tile.x1 - tile.x0;
    for (i, js, per) in lens.runs(ks) {
        let slot = pixels[i as usize];
        let count = per >> level;
        let w = Vec3::splat(1.0 / (n as f32 * count as f32));
        let (x, y) = (tile.x0 + slot % tw, tile.y0 + slot / tw);
        let pixel = y * s.width + x;
        let key = hash(&[s.seed, pixel, level, dim::REFINE]);
        if count == 1 && scene.camera.aperture <= 0.0 && n <= CMJ_LANES_MAX {
            // A pinhole: the lens position is never asked for.
            let no_lens = |_| (f32x16::ZERO, f32x16::ZERO);
            let ck = CmjKey::new(key, n).0.map(u32x16::splat);
            let film = |g: u32x16| {
                let (cx, cy, _) = cmj_keyed(g, n, ck);
                (cx, cy)
            };
            film_samples(scene, (x, y, key, 0), js, (|_| [slot; LANES], film, no_lens, w), rays);
            continue;
        }
        let film = |g| cmj(g, n, key);
        sample_lens_rays(scene, (x, y, pixel, level), (key, 0, count), js, (|_| slot, film, w), rays);
    }
}

/// One pixel's rays `js` of a pass whose first sample is the pixel's sample `first`, when
/// each sample has `count` lens rays: ray j is lens ray j % count of the pixel's sample
/// g = `first` + j / count, through film position `film(g)` in the pixel and a CMJ
/// pattern of lens positions keyed by the pixel, its `pass` (refinement level or
/// variance round) and g − `first`; slot `slot(g)`, weight `w`, path `(key, g · count +
/// lens ray)`. One sample's lens rays at a time, on lanes ([`lens_rays`]).
fn sample_lens_rays(
    scene: &Scene,
    (x, y, pixel, pass): (u32, u32, u32, u32),
    (key, first, count): (u32, u32, u32),
    js: Range<u32>,
    (slot, film, w): (impl Fn(u32) -> u32, impl Fn(u32) -> Vec2, Vec3),
    rays: &mut RayQueue,
) {
    let s = &scene.settings;
    let mut j = js.start;
    while j < js.end {
        let (sample, l0) = (j / count, j % count);
        let l1 = count.min(l0 + (js.end - j));
        let g = first + sample;
        let at = Vec2::new(x as f32, y as f32) + film(g);
        let pattern = hash(&[s.seed, pixel, pass, sample, dim::LENS]);
        lens_rays(scene, at, (l0..l1, count, pattern), (slot(g), w), (key, g * count), rays);
        j += l1 - l0;
    }
}

/// A round of variance-driven AA: its tile, the pixels it samples (indices in the tile)
/// and every tile pixel's half-buffers (their sample and round counts place the round).
#[derive(Clone, Copy, Debug)]
pub struct VariancePass<'a> {
    /// The tile.
    pub tile: &'a Tile,
    /// The pixels still sampled.
    pub pixels: &'a [u32],
    /// Per tile pixel: samples and rounds cast before this round.
    pub state: &'a HalfBufferQueue,
}

/// Variance-driven AA, one round: in each listed pixel, its next samples. `lens` splits
/// the flattened index into listed pixel i and its ray j, of (its samples this round) ×
/// `dof_samples` rays: sample j / dof_samples, lens ray j % dof_samples. A pixel's
/// sample g (counted over its rounds) lies at point g of the pixel's Owen-scrambled Sobol
/// sequence of film positions, so every round extends one stratified sequence; it goes to
/// slot 2·(its index in the tile) + g % 2, its half-buffer; weight 1 / dof_samples, so a
/// slot sums its samples' estimates. Lens positions: with one lens ray per sample, point
/// g of the pixel's Sobol sequence of lens positions (uniform mode's); with several, a
/// CMJ pattern per sample.
pub fn generate_variance(scene: &Scene, pass: VariancePass, lens: Lens, ks: Range<u64>, rays: &mut RayQueue) {
    let VariancePass { tile, pixels, state } = pass;
    rays.clear();
    let s = &scene.settings;
    let count = s.dof_samples;
    let w = Vec3::splat(1.0 / count as f32);
    let tw = tile.x1 - tile.x0;
    for (i, js, _) in lens.runs(ks) {
        let p = pixels[i as usize];
        let (before, round) = (state.count[p as usize], state.rounds[p as usize] as u32);
        let (x, y) = (tile.x0 + p % tw, tile.y0 + p / tw);
        let pixel = y * s.width + x;
        // One key and one film sequence for all of the pixel's rounds: its samples so far
        // are always a prefix of one stratified sequence, as uniform mode's N are one
        // pattern (a CMJ pattern per round left two rounds of 8 with 35% more error
        // than 16 uniform samples, fig07 at 96², 8 lens rays a sample).
        let key = hash(&[s.seed, pixel, dim::VARIANCE]);
        let film_seed = hash(&[s.seed, pixel, dim::PIXEL, dim::VARIANCE]);
        if count == 1 {
            let lens_seed = hash(&[s.seed, pixel, dim::LENS]);
            variance_samples(scene, (x, y, 2 * p), (key, before, lens_seed, film_seed), js, rays);
            continue;
        }
        let slot = |g: u32| 2 * p + (g & 1);
        let film = |g| sobol_owen(g, film_seed);
        sample_lens_rays(scene, (x, y, pixel, round), (key, before, count), js, (slot, film, w), rays);
    }
}

/// [`generate_variance`]'s samples `js` of this round in one pixel at (`x`, `y`) with its
/// half-buffers at `slot0`, one ray each: the pixel's sample g = `before` + j at Sobol
/// point g of `film_seed` in the pixel and of `lens_seed` on the lens, in half-buffer
/// g % 2, path `(key, g)`.
fn variance_samples(
    scene: &Scene,
    (x, y, slot0): (u32, u32, u32),
    (key, before, lens_seed, film_seed): (u32, u32, u32, u32),
    js: Range<u32>,
    rays: &mut RayQueue,
) {
    let one = u32x16::splat(1);
    let slot = |g: u32x16| words(u32x16::splat(slot0) + (g & one));
    let film = |g: u32x16| sobol_owen_lanes(g, u32x16::splat(film_seed));
    let lens = |g: u32x16| sobol_owen_lanes(g, u32x16::splat(lens_seed));
    film_samples(scene, (x, y, key, before), js, (slot, film, lens, Vec3::ONE), rays);
}

/// One pixel's samples `js` of a pass whose first sample is the pixel's sample `first`,
/// one ray each, 16 at a time on lanes: sample g = `first` + j at film position
/// `film(g)` in pixel (`x`, `y`), slot `slot(g)`, lens position `lens(g)` (not evaluated
/// for a pinhole), weight `w`, path `(key, g)`.
fn film_samples(
    scene: &Scene,
    (x, y, key, first): (u32, u32, u32, u32),
    js: Range<u32>,
    (slot, film, lens, w): (
        impl Fn(u32x16) -> [u32; LANES],
        impl Fn(u32x16) -> (f32x16, f32x16),
        impl Fn(u32x16) -> (f32x16, f32x16),
        Vec3,
    ),
    rays: &mut RayQueue,
) {
    let (s, cam) = (&scene.settings, &scene.camera);
    let w = w.to_array().map(|x| [x; LANES]);
    let (fx0, fy0) = (f32x16::splat(x as f32), f32x16::splat(y as f32));
    for j0 in js.clone().step_by(LANES) {
        let m = (js.end - j0).min(LANES as u32) as usize;
        // Lanes past the last sample repeat it (a valid index) and are not written.
        let g = iota(j0).min(u32x16::splat(js.end - 1)) + u32x16::splat(first);
        let (cx, cy) = film(g);
        let d = cam.pinhole_dirs(fx0 + cx, fy0 + cy, s.width, s.height);
        let lens = (cam.aperture > 0.0).then(|| lens(g));
        push_lanes(scene, d, lens, (slot(g), [key; LANES], words(g)), w, m, rays);
    }
}

#[cfg(test)]
mod tests;
