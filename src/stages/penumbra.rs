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

use crate::light::{quad_light_samples, SHADOW_TMAX_SCALE};
use crate::queue::{FilmQueue, HitQueue, RayQueue, ShadowPointQueue, ShadowQueue};
use crate::sampling::{cmj_grid, dim, hash, morton_levels, progressive_cell, progressive_order, Progressive};
use crate::scene::{PenumbraStop, Scene};
use crate::surface::diffuse_surface;

/// Two-sided 95% normal quantile of the Wilson interval.
const Z95: f32 = 1.959_964;

/// Points a batch takes rays from: the first this many still active. A point stays in
/// this window from its first batch until it stops, so its rays are reread while they
/// are still in cache (a wave's whole penumbra queue is megabytes).
const WINDOW: usize = 64;

/// Early-stopping state of one wave's penumbra points: plain data, one entry per point
/// (in penumbra-list order) or per ray of the wave's full penumbra ray queue.
#[derive(Default, Debug, Clone)]
pub struct Batches {
    /// Per point, then one more: where its rays start in the full queue (and in `order`).
    pub start: Vec<u32>,
    /// Per point: rays handed to a batch so far.
    pub taken: Vec<u32>,
    /// Per point: of those, rays that reached the light.
    pub visible: Vec<u32>,
    /// Points still sampling, ascending.
    pub active: Vec<u32>,
    /// Per ray of the full queue: the point it belongs to.
    pub point: Vec<u32>,
    /// Per ray of the full queue: traced and unblocked.
    pub lit: Vec<bool>,
    /// The full queue's rays in the order batches take them: each point's range sorted
    /// by the progressive key of the ray's light cell.
    pub order: Vec<u32>,
    /// Scratch for the order: one point's rays with their light cells, and the merge
    /// buffer.
    cells: Vec<Progressive>,
    merge: Vec<Progressive>,
}

/// Generates the shadow rays of every penumbra point (indices into `points`), in the
/// order uniform mode would. With `batches`, also records each point's range and the
/// progressive order its rays will be traced in.
pub fn penumbra(
    scene: &Scene,
    rays: &RayQueue,
    hits: &HitQueue,
    points: &ShadowPointQueue,
    penumbra: &[u32],
    shadow: &mut ShadowQueue,
    mut batches: Option<&mut Batches>,
) {
    shadow.clear();
    if let Some(b) = batches.as_deref_mut() {
        for v in [&mut b.start, &mut b.taken, &mut b.visible, &mut b.active, &mut b.point, &mut b.order] {
            v.clear();
        }
        b.lit.clear();
    }
    let (cols, rows) = cmj_grid(scene.settings.shadow_samples);
    let levels = morton_levels(cols, rows);
    for (i, &k) in penumbra.iter().enumerate() {
        let k = k as usize;
        if let Some(b) = batches.as_deref_mut() {
            b.start.push(shadow.len() as u32);
        }
        let Some(surf) = diffuse_surface(scene, rays, hits, points.ray[k] as usize) else { continue };
        let li = points.light[k] as usize;
        let scramble = hash(&[surf.key, li as u32, dim::STOP_ORDER]);
        if let Some(b) = batches.as_deref_mut() {
            b.cells.clear();
        }
        quad_light_samples(scene, &surf, li, |cell, wi, dist, l| {
            if let Some(b) = batches.as_deref_mut() {
                let (x, y) = progressive_cell(cell % cols, cell / cols, cols, rows, levels);
                b.cells.push(Progressive { x, y, item: shadow.len() as u32, morton: 0 });
                b.point.push(i as u32);
            }
            shadow.push(surf.o, wi, dist * SHADOW_TMAX_SCALE, surf.slot, l);
        });
        if let Some(b) = batches.as_deref_mut() {
            progressive_order(&mut b.cells, levels, scramble, &mut b.merge);
            b.order.extend(b.cells.iter().map(|c| c.item));
            if !b.cells.is_empty() {
                b.active.push(i as u32);
            }
        }
    }
    if let Some(b) = batches {
        b.start.push(shadow.len() as u32);
        b.taken.resize(penumbra.len(), 0);
        b.visible.resize(penumbra.len(), 0);
        b.lit.resize(shadow.len(), false);
    }
}

/// Writes the next batch: up to `size` more rays of each of the first [`WINDOW`] active
/// points, in progressive order, copied from `full` with their slot replaced by their
/// index in `full` (so the occlusion stage's film entries name the rays that got
/// through). Empty when every point has stopped.
pub fn next_batch(b: &mut Batches, size: u32, full: &ShadowQueue, batch: &mut ShadowQueue) {
    batch.clear();
    for &p in b.active.iter().take(WINDOW) {
        let p = p as usize;
        let (start, len) = (b.start[p], b.start[p + 1] - b.start[p]);
        let take = size.min(len - b.taken[p]);
        let from = (start + b.taken[p]) as usize;
        gather(full, &b.order[from..from + take as usize], batch);
        b.taken[p] += take;
    }
}

/// Appends rays `ids` of `full` to `batch`, field by field, each with its index in
/// `full` as its slot.
fn gather(full: &ShadowQueue, ids: &[u32], batch: &mut ShadowQueue) {
    let field = |dst: &mut Vec<f32>, src: &[f32]| dst.extend(ids.iter().map(|&r| src[r as usize]));
    field(&mut batch.ox, &full.ox);
    field(&mut batch.oy, &full.oy);
    field(&mut batch.oz, &full.oz);
    field(&mut batch.dx, &full.dx);
    field(&mut batch.dy, &full.dy);
    field(&mut batch.dz, &full.dz);
    field(&mut batch.tmax, &full.tmax);
    field(&mut batch.lr, &full.lr);
    field(&mut batch.lg, &full.lg);
    field(&mut batch.lb, &full.lb);
    batch.slot.extend_from_slice(ids);
}

/// Records a traced batch (`through`: the occlusion stage's film entries, slots naming
/// rays of the full queue) and stops the points that are done: all rays traced, or the
/// Wilson interval narrower than ± `stop.tolerance`. Returns the points stopped early.
pub fn record(b: &mut Batches, through: &FilmQueue, stop: PenumbraStop) -> u64 {
    for &r in &through.slot {
        b.lit[r as usize] = true;
        b.visible[b.point[r as usize] as usize] += 1;
    }
    // Only the window's points took rays; the others wait their turn.
    let window = b.active.len().min(WINDOW);
    let (mut early, mut kept) = (0, 0);
    for i in 0..window {
        let p = b.active[i] as usize;
        let (n, m) = (b.start[p + 1] - b.start[p], b.taken[p]);
        let settled = m < n && wilson_half_width(b.visible[p], m) < stop.tolerance;
        early += settled as u64;
        if m < n && !settled {
            b.active[kept] = p as u32;
            kept += 1;
        }
    }
    b.active.drain(kept..window);
    early
}

/// Sends every point's unblocked rays to the film, in the order of the full queue (the
/// fixed-n order). A point that stopped after m of its n rays has each contribution
/// scaled by n / m, so its estimate stays the mean over the light. Returns the
/// contributions sent.
pub fn resolve(b: &Batches, full: &ShadowQueue, film: &mut FilmQueue) -> usize {
    let mut sent = 0;
    for p in 0..b.taken.len() {
        let (start, end) = (b.start[p] as usize, b.start[p + 1] as usize);
        let (n, m) = ((end - start) as u32, b.taken[p]);
        // n == m multiplies by nothing, so the bits are those of the fixed-n path.
        let scale = (m < n).then(|| n as f32 / m as f32);
        for r in start..end {
            if b.lit[r] {
                let l = full.radiance(r);
                film.push(full.slot[r], scale.map_or(l, |s| l * s));
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
