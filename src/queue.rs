//! Structure-of-arrays ray queues: plain data that stages read and write.
//!
//! A queue is one `Vec` per field with `push`, `len`, `clear`; it holds no logic
//! beyond keeping its fields the same length. Workers own their queues and reuse
//! them across waves, so steady-state rendering allocates nothing per ray.

use glam::Vec3;

/// Rays to be intersected with the scene (camera rays and reflection/refraction rays).
#[derive(Default, Debug, Clone)]
pub struct RayQueue {
    /// Origin x.
    pub ox: Vec<f32>,
    /// Origin y.
    pub oy: Vec<f32>,
    /// Origin z.
    pub oz: Vec<f32>,
    /// Direction x (unit length).
    pub dx: Vec<f32>,
    /// Direction y.
    pub dy: Vec<f32>,
    /// Direction z.
    pub dz: Vec<f32>,
    /// Accumulation slot the ray's radiance goes to (a pixel, a pixel corner or a
    /// refinement estimate, depending on the pass that started the path).
    pub slot: Vec<u32>,
    /// Path throughput red: the weight of this ray's radiance in the pixel estimate.
    pub wr: Vec<f32>,
    /// Path throughput green.
    pub wg: Vec<f32>,
    /// Path throughput blue.
    pub wb: Vec<f32>,
    /// Number of reflection/refraction bounces before this ray (0 for camera rays).
    pub depth: Vec<u32>,
    /// Path key: a hash naming this path uniquely within the pixel, for sampling.
    pub key: Vec<u32>,
}

impl RayQueue {
    /// Appends a ray.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub fn push(&mut self, o: Vec3, d: Vec3, slot: u32, w: Vec3, depth: u32, key: u32) {
        self.ox.push(o.x);
        self.oy.push(o.y);
        self.oz.push(o.z);
        self.dx.push(d.x);
        self.dy.push(d.y);
        self.dz.push(d.z);
        self.slot.push(slot);
        self.wr.push(w.x);
        self.wg.push(w.y);
        self.wb.push(w.z);
        self.depth.push(depth);
        self.key.push(key);
    }

    /// Number of rays.
    #[inline]
    pub fn len(&self) -> usize {
        self.ox.len()
    }

    /// True when the queue holds no ray.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.ox.is_empty()
    }

    /// Removes all rays, keeping the capacity.
    pub fn clear(&mut self) {
        self.ox.clear();
        self.oy.clear();
        self.oz.clear();
        self.dx.clear();
        self.dy.clear();
        self.dz.clear();
        self.slot.clear();
        self.wr.clear();
        self.wg.clear();
        self.wb.clear();
        self.depth.clear();
        self.key.clear();
    }

    /// Appends rays `range` of `src`.
    pub fn append_range(&mut self, src: &RayQueue, range: std::ops::Range<usize>) {
        self.ox.extend_from_slice(&src.ox[range.clone()]);
        self.oy.extend_from_slice(&src.oy[range.clone()]);
        self.oz.extend_from_slice(&src.oz[range.clone()]);
        self.dx.extend_from_slice(&src.dx[range.clone()]);
        self.dy.extend_from_slice(&src.dy[range.clone()]);
        self.dz.extend_from_slice(&src.dz[range.clone()]);
        self.slot.extend_from_slice(&src.slot[range.clone()]);
        self.wr.extend_from_slice(&src.wr[range.clone()]);
        self.wg.extend_from_slice(&src.wg[range.clone()]);
        self.wb.extend_from_slice(&src.wb[range.clone()]);
        self.depth.extend_from_slice(&src.depth[range.clone()]);
        self.key.extend_from_slice(&src.key[range]);
    }

    /// Origin of ray `i`.
    #[inline]
    pub fn origin(&self, i: usize) -> Vec3 {
        Vec3::new(self.ox[i], self.oy[i], self.oz[i])
    }

    /// Direction of ray `i`.
    #[inline]
    pub fn dir(&self, i: usize) -> Vec3 {
        Vec3::new(self.dx[i], self.dy[i], self.dz[i])
    }

    /// Throughput of ray `i`.
    #[inline]
    pub fn weight(&self, i: usize) -> Vec3 {
        Vec3::new(self.wr[i], self.wg[i], self.wb[i])
    }

    /// Bytes held by the queue's buffers (capacity, not length).
    pub fn bytes(&self) -> usize {
        // Twelve 4-byte fields that grow together.
        12 * 4 * self.ox.capacity()
    }
}

/// Closest hits of a [`RayQueue`], one entry per ray, in the same order.
#[derive(Default, Debug, Clone)]
pub struct HitQueue {
    /// Distance along the ray; infinite for a miss.
    pub t: Vec<f32>,
    /// Index of the primitive hit (in the scene's primitive order), or [`MISS`].
    pub prim: Vec<u32>,
}

/// Primitive index of a ray that hit nothing.
pub const MISS: u32 = u32::MAX;

impl HitQueue {
    /// Appends a hit (or a miss with `prim == MISS`).
    #[inline]
    pub fn push(&mut self, t: f32, prim: u32) {
        self.t.push(t);
        self.prim.push(prim);
    }

    /// Number of entries.
    #[inline]
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// True when empty.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// Removes all entries, keeping the capacity.
    pub fn clear(&mut self) {
        self.t.clear();
        self.prim.clear();
    }
}

/// Shadow rays: segments towards a light, each carrying the radiance it adds to its
/// pixel if nothing blocks it.
#[derive(Default, Debug, Clone)]
pub struct ShadowQueue {
    /// Origin x.
    pub ox: Vec<f32>,
    /// Origin y.
    pub oy: Vec<f32>,
    /// Origin z.
    pub oz: Vec<f32>,
    /// Direction x (unit length).
    pub dx: Vec<f32>,
    /// Direction y.
    pub dy: Vec<f32>,
    /// Direction z.
    pub dz: Vec<f32>,
    /// Segment length: occluders beyond it do not count.
    pub tmax: Vec<f32>,
    /// Accumulation slot the contribution goes to.
    pub slot: Vec<u32>,
    /// Unoccluded contribution red (already weighted by path throughput and sample count).
    pub lr: Vec<f32>,
    /// Contribution green.
    pub lg: Vec<f32>,
    /// Contribution blue.
    pub lb: Vec<f32>,
}

impl ShadowQueue {
    /// Appends a shadow ray.
    #[inline]
    pub fn push(&mut self, o: Vec3, d: Vec3, tmax: f32, slot: u32, l: Vec3) {
        self.ox.push(o.x);
        self.oy.push(o.y);
        self.oz.push(o.z);
        self.dx.push(d.x);
        self.dy.push(d.y);
        self.dz.push(d.z);
        self.tmax.push(tmax);
        self.slot.push(slot);
        self.lr.push(l.x);
        self.lg.push(l.y);
        self.lb.push(l.z);
    }

    /// Number of shadow rays.
    #[inline]
    pub fn len(&self) -> usize {
        self.ox.len()
    }

    /// True when empty.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.ox.is_empty()
    }

    /// Removes all rays, keeping the capacity.
    pub fn clear(&mut self) {
        self.ox.clear();
        self.oy.clear();
        self.oz.clear();
        self.dx.clear();
        self.dy.clear();
        self.dz.clear();
        self.tmax.clear();
        self.slot.clear();
        self.lr.clear();
        self.lg.clear();
        self.lb.clear();
    }

    /// Origin of ray `i`.
    #[inline]
    pub fn origin(&self, i: usize) -> Vec3 {
        Vec3::new(self.ox[i], self.oy[i], self.oz[i])
    }

    /// Direction of ray `i`.
    #[inline]
    pub fn dir(&self, i: usize) -> Vec3 {
        Vec3::new(self.dx[i], self.dy[i], self.dz[i])
    }

    /// Contribution of ray `i`.
    #[inline]
    pub fn radiance(&self, i: usize) -> Vec3 {
        Vec3::new(self.lr[i], self.lg[i], self.lb[i])
    }
}

/// Radiance ready to be added to pixels: background, emitters seen directly or through
/// mirrors, and unoccluded shadow contributions.
#[derive(Default, Debug, Clone)]
pub struct FilmQueue {
    /// Accumulation slot.
    pub slot: Vec<u32>,
    /// Radiance red.
    pub r: Vec<f32>,
    /// Radiance green.
    pub g: Vec<f32>,
    /// Radiance blue.
    pub b: Vec<f32>,
}

impl FilmQueue {
    /// Appends a contribution.
    #[inline]
    pub fn push(&mut self, slot: u32, l: Vec3) {
        self.slot.push(slot);
        self.r.push(l.x);
        self.g.push(l.y);
        self.b.push(l.z);
    }

    /// Number of contributions.
    #[inline]
    pub fn len(&self) -> usize {
        self.slot.len()
    }

    /// True when empty.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.slot.is_empty()
    }

    /// Removes all entries, keeping the capacity.
    pub fn clear(&mut self) {
        self.slot.clear();
        self.r.clear();
        self.g.clear();
        self.b.clear();
    }
}

/// Shading points waiting for the adaptive shadow test of one quad light (the shadow
/// corner queue): each names a ray of the current wave (whose hit is the point) and a
/// light, with the light's contribution if nothing blocked it.
#[derive(Default, Debug, Clone)]
pub struct ShadowPointQueue {
    /// Index of the ray (and hit) in the current wave.
    pub ray: Vec<u32>,
    /// Index of the quad light.
    pub light: Vec<u32>,
    /// Unoccluded contribution red.
    pub ur: Vec<f32>,
    /// Unoccluded contribution green.
    pub ug: Vec<f32>,
    /// Unoccluded contribution blue.
    pub ub: Vec<f32>,
}

impl ShadowPointQueue {
    /// Appends a point.
    #[inline]
    pub fn push(&mut self, ray: u32, light: u32, unoccluded: Vec3) {
        self.ray.push(ray);
        self.light.push(light);
        self.ur.push(unoccluded.x);
        self.ug.push(unoccluded.y);
        self.ub.push(unoccluded.z);
    }

    /// Number of points.
    #[inline]
    pub fn len(&self) -> usize {
        self.ray.len()
    }

    /// True when empty.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.ray.is_empty()
    }

    /// Removes all points, keeping the capacity.
    pub fn clear(&mut self) {
        self.ray.clear();
        self.light.clear();
        self.ur.clear();
        self.ug.clear();
        self.ub.clear();
    }

    /// Unoccluded contribution of point `i`.
    #[inline]
    pub fn unoccluded(&self, i: usize) -> Vec3 {
        Vec3::new(self.ur[i], self.ug[i], self.ub[i])
    }
}
