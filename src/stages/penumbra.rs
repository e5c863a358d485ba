//! The penumbra stage: for each point the shadow-corner test could not decide, the
//! `shadows.samples` stratified shadow rays of uniform mode (the same rays, so the two
//! modes agree wherever the test is right). Writes a shadow queue for the occlusion stage.
//!
//! With early stopping (`render.shadows.tolerance` > 0, the paper's §5 future work) a
//! point's rays are traced in batches, in a progressive (Owen-scrambled radical-inverse)
//! order of their light cells, and
//! the point stops once the 95% Wilson score interval of its visible fraction is
//! narrower than ± tolerance. The contributions are held back until every point has
//! stopped, then sent to the film in the fixed-n order, scaled by n / (rays traced): a
//! point that never stops early gives the fixed-n sums bit for bit.
//!
//! The stage owns the whole loop (generate → batch → occlusion → record → resolve); it
//! traces through the shadow stage's kernel, the tracer.

use crate::accel::tracer::Tracer;
use crate::light::lanes::pair_shadow_lanes;
use crate::light::sample_grid;
use crate::queue::{FilmQueue, IndexQueue, PenumbraQueues, ShadowPointQueue, ShadowPoints, SurfaceQueue};
use crate::sampling::{dim, hash, morton_levels, progressive_cell, progressive_order, Progressive};
use crate::scene::{PenumbraStop, Scene};

/// Two-sided 95% normal quantile of the Wilson interval.
const Z95: f32 = 1.959_964;

/// Points a batch takes rays from: the first this many still active. A point stays in
/// this window from its first batch until it stops, so its rays are reread while they
/// are still in cache (a wave's whole penumbra queue is megabytes).
const WINDOW: usize = 64;

/// What the penumbra stage did in one call.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PenumbraCounts {
    /// Shadow rays traced (with early stopping, fewer than generated).
    pub traced: u64,
    /// Shadow rays generated but not traced: the points stopped early.
    pub saved: u64,
    /// Points that stopped before all their rays.
    pub stopped: u64,
    /// Contributions sent to the film.
    pub lit: usize,
}

/// Generates the shadow rays of every penumbra point (`penumbra`: indices into
/// `points`), the ones uniform mode would cast, traces them and appends the unblocked
/// ones' contributions to `film`: all at once, or with early stopping
/// (`render.shadows.tolerance`) in batches until every point has stopped. `q.points`
/// tells, per penumbra point, its range in `q.rays` and the rays it traced.
pub fn penumbra(
    scene: &Scene,
    tracer: &mut Tracer,
    shading: ShadowPoints,
    penumbra: &IndexQueue,
    q: &mut PenumbraQueues,
    film: &mut FilmQueue,
) -> PenumbraCounts {
    let ShadowPoints { surfaces, points } = shading;
    let stop = scene.settings.penumbra_stop;
    generate(scene, surfaces, points, penumbra, q);
    let Some(stop) = stop else {
        for p in 0..q.points.len() {
            q.points.taken[p] = q.points.end[p] - q.points.start[p];
        }
        let lit = tracer.unblocked(&q.rays, film);
        return PenumbraCounts { traced: q.rays.len() as u64, lit, ..Default::default() };
    };
    let mut counts = PenumbraCounts::default();
    loop {
        next_batch(q, stop.batch);
        if q.batch.is_empty() {
            break;
        }
        q.through.clear();
        tracer.unblocked(&q.batch, &mut q.through);
        counts.stopped += record(q, stop);
        counts.traced += q.batch.len() as u64;
    }
    counts.saved = q.rays.len() as u64 - counts.traced;
    counts.lit = resolve(q, film);
    counts
}

/// Writes every penumbra point's rays to `q.rays` and its range to `q.points` (both
/// cleared first). With early stopping, also each ray's point and the order batches will
/// take the rays in, and the active list.
fn generate(
    scene: &Scene,
    surfaces: &SurfaceQueue,
    points: &ShadowPointQueue,
    penumbra: &IndexQueue,
    q: &mut PenumbraQueues,
) {
    let progressive = scene.settings.penumbra_stop.is_some();
    q.rays.clear();
    q.points.clear();
    q.per_ray.clear();
    q.active.clear();
    // Every ray at once: the lanes cast them in the scalar loop's order and bits, with
    // their light cells when the batches need them.
    let pairs = penumbra.index.iter().map(|&k| (points.surface[k as usize], points.light[k as usize]));
    let cells = progressive.then_some(&mut q.ray_cells);
    pair_shadow_lanes(scene, surfaces, pairs, &mut q.rays, &mut q.counts, cells);
    let mut start = 0;
    for &n in &q.counts {
        q.points.push(start, start + n, 0, 0);
        start += n;
    }
    if !progressive || penumbra.is_empty() {
        return;
    }
    let (cols, rows) = sample_grid(scene.settings.shadow_samples);
    let levels = morton_levels(cols, rows);
    // Each light cell's place on the progressive grid, once a wave, not a division a ray.
    let grid: Vec<(u32, u32)> =
        (0..cols * rows).map(|cell| progressive_cell(cell % cols, cell / cols, cols, rows, levels)).collect();
    for (i, &k) in penumbra.index.iter().enumerate() {
        let (s, li) = (points.surface[k as usize] as usize, points.light[k as usize]);
        let (start, end) = (q.points.start[i], q.points.end[i]);
        q.cells.clear();
        for item in start..end {
            let (x, y) = grid[q.ray_cells[item as usize] as usize];
            q.cells.push(Progressive { x, y, item, morton: 0 });
        }
        let scramble = hash(&[surfaces.key[s], surfaces.sample[s], li, dim::STOP_ORDER]);
        progressive_order(&mut q.cells, levels, scramble, &mut q.merge);
        for c in &q.cells {
            q.per_ray.push(i as u32, false, c.item);
        }
        if !q.cells.is_empty() {
            q.active.push(i as u32);
        }
    }
}

/// Writes the next batch: up to `size` more rays of each of the first [`WINDOW`] active
/// points, in progressive order, copied from the full queue with their slot replaced by
/// their index in it (so the occlusion stage's film entries name the rays that got
/// through). Empty when every point has stopped.
fn next_batch(q: &mut PenumbraQueues, size: u32) {
    q.batch.clear();
    for &p in q.active.index.iter().take(WINDOW) {
        let p = p as usize;
        let pts = &mut q.points;
        let take = size.min(pts.end[p] - pts.start[p] - pts.taken[p]);
        let from = (pts.start[p] + pts.taken[p]) as usize;
        let ids = &q.per_ray.order[from..from + take as usize];
        let at = q.batch.len();
        q.batch.gather(&q.rays, ids);
        q.batch.slot[at..].copy_from_slice(ids);
        pts.taken[p] += take;
    }
}

/// Records a traced batch (`q.through`: the occlusion stage's film entries, slots naming
/// rays of the full queue) and stops the points that are done: all rays traced, or the
/// Wilson interval narrower than ± `stop.tolerance`. Returns the points stopped early.
fn record(q: &mut PenumbraQueues, stop: PenumbraStop) -> u64 {
    for &r in &q.through.slot {
        q.per_ray.lit[r as usize] = true;
        q.points.visible[q.per_ray.point[r as usize] as usize] += 1;
    }
    // Only the window's points took rays; the others wait their turn.
    let active = &mut q.active.index;
    let window = active.len().min(WINDOW);
    let (mut early, mut kept) = (0, 0);
    for i in 0..window {
        let p = active[i] as usize;
        let (n, m) = (q.points.end[p] - q.points.start[p], q.points.taken[p]);
        let settled = m < n && wilson_half_width(q.points.visible[p], m) < stop.tolerance;
        early += settled as u64;
        if m < n && !settled {
            active[kept] = p as u32;
            kept += 1;
        }
    }
    active.drain(kept..window);
    early
}

/// Sends every point's unblocked rays to the film, in the order of the full queue (the
/// fixed-n order). A point that stopped after m of its n rays has each contribution
/// scaled by n / m, so its estimate stays the mean over the light. Returns the
/// contributions sent.
fn resolve(q: &PenumbraQueues, film: &mut FilmQueue) -> usize {
    let mut sent = 0;
    for p in 0..q.points.len() {
        let (start, end) = (q.points.start[p] as usize, q.points.end[p] as usize);
        let (n, m) = ((end - start) as u32, q.points.taken[p]);
        // n == m multiplies by nothing, so the bits are those of the fixed-n path.
        let scale = (m < n).then(|| n as f32 / m as f32);
        for r in start..end {
            if q.per_ray.lit[r] {
                let l = q.rays.radiance(r);
                film.push(q.rays.slot[r], scale.map_or(l, |s| l * s));
                sent += 1;
            }
        }
    }
    sent
}

/// Half-width of the 95% Wilson score interval of a proportion after `visible` successes
/// in `n` trials. Unlike the normal (Wald) interval it does not collapse to zero when
/// every ray so far agreed (visible = 0 or n), which is the common case at a penumbra's
/// edges: there it is z²/(2(n + z²)), 0.097 after 16 rays and 0.028 after 64.
pub fn wilson_half_width(visible: u32, n: u32) -> f32 {
    let (v, n) = (visible as f32, n as f32);
    let z2 = Z95 * Z95;
    let p = v / n;
    Z95 / (1.0 + z2 / n) * (p * (1.0 - p) / n + z2 / (4.0 * n * n)).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wilson_known_values() {
        // 0 of 16: z²/(2(16 + z²)).
        let z2 = Z95 * Z95;
        assert!((wilson_half_width(0, 16) - z2 / (2.0 * (16.0 + z2))).abs() < 1e-6);
        assert_eq!(wilson_half_width(0, 16), wilson_half_width(16, 16));
        // 50 of 100: close to the Wald value 1.96 · 0.05 for a large n.
        assert!((wilson_half_width(50, 100) - 0.0962).abs() < 2e-3);
        assert!(wilson_half_width(32, 64) > wilson_half_width(0, 64));
    }
}
