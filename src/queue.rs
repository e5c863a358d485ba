//! Structure-of-arrays queues: plain data that stages read and write.
//!
//! Every queue is declared once with [`soa!`]: one `Vec` per field, and the generated
//! `push`, `len`, `is_empty`, `clear`, `bytes`, `append_range` and `gather`. A queue
//! holds no logic beyond keeping its fields the same length. Workers own their queues
//! and reuse them across waves, so steady-state rendering allocates nothing per ray.
//!
//! **Who clears a queue.** A stage clears each queue it fills before it writes, so its
//! output never depends on what an earlier wave left there. The one exception is the
//! film queue, which collects the contributions of several stages of one wave (shade,
//! shadow, shadow corners, penumbra): the driver clears it when a wave begins, and those
//! stages only append to it.

use glam::Vec3;

use crate::sampling::Progressive;
use crate::simd::{push_lanes, LANES};

/// Declares a structure-of-arrays queue: the struct with one public `Vec` per field,
/// and its methods. `push(...)` lists the pushed values: `name: T => field` stores one
/// field, `name: Vec3 => x, y, z` stores a vector in three `f32` fields; `get(...)`
/// lists the `Vec3` fields read back as one value by `name(i)`; `sparse(...)` lists
/// columns that a scene may not use: each is empty or as long as the others. Every push
/// takes them last, as `Option`s (`None` where the scene does not use them, so a scene
/// without them writes nothing there); they are read with [`sparse`] and carried from
/// entry to entry with [`sparse_opt`]. Like the item lists of pbrt-v4's `soa`
/// definitions, the field list is the only place a queue's layout is written: no stage
/// grows a column by hand (`scripts/modules.py` checks).
macro_rules! soa {
    (
        $(#[$meta:meta])*
        pub struct $name:ident {
            $( $(#[$fmeta:meta])* $field:ident : $ty:ty, )+
        }
        push( $( $arg:ident : $aty:ty => $($col:ident),+ );+ $(;)? )
        $( get( $( $get:ident => $gx:ident, $gy:ident, $gz:ident );+ $(;)? ) )?
        $( sparse( $( $(#[$smeta:meta])* $sfield:ident : $sty:ty ),+ $(,)? ) )?
    ) => {
        $(#[$meta])*
        #[derive(Default, Debug, Clone, PartialEq)]
        pub struct $name {
            $( $(#[$fmeta])* pub $field: Vec<$ty>, )+
            $($( $(#[$smeta])* pub $sfield: Vec<$sty>, )+)?
        }

        impl $name {
            /// Appends one entry.
            #[inline]
            #[allow(clippy::too_many_arguments)] // one argument per value of the entry
            pub fn push(&mut self, $( $arg: $aty, )+ $($( $sfield: Option<$sty>, )+)?) {
                $( soa!(@put self, $arg, $($col),+); )+
                $($( if let Some(v) = $sfield {
                    self.$sfield.push(v);
                } )+)?
            }

            /// Number of entries.
            #[inline]
            pub fn len(&self) -> usize {
                soa!(@first self, $($field),+).len()
            }

            /// True when the queue holds no entry.
            #[inline]
            pub fn is_empty(&self) -> bool {
                self.len() == 0
            }

            /// Removes every entry, keeping the capacity.
            pub fn clear(&mut self) {
                $( self.$field.clear(); )+
                $($( self.$sfield.clear(); )+)?
            }

            /// Bytes held by the queue's buffers (capacity, not length).
            pub fn bytes(&self) -> usize {
                0 $( + self.$field.capacity() * std::mem::size_of::<$ty>() )+
                  $($( + self.$sfield.capacity() * std::mem::size_of::<$sty>() )+)?
            }

            /// Appends the first `count` lanes of 16 entries given as lanes: per pushed value
            /// an array of its 16 lane values (a vector as its x, y and z lane arrays).
            /// Every column is written here, so none can be left short.
            #[inline]
            #[allow(clippy::too_many_arguments)] // one argument per value of the entry
            pub fn push_lanes(
                &mut self,
                $( $arg: soa!(@lanes $aty; $($col),+), )+
                $($( $sfield: Option<&[$sty; LANES]>, )+)?
                count: usize,
            ) {
                $( soa!(@put_lanes self, $arg, count, $($col),+); )+
                $($( if let Some(v) = $sfield {
                    push_lanes(&mut self.$sfield, *v, count);
                } )+)?
            }

            /// Appends the lanes `picks` (in that order) of 16 entries given as lanes, as
            /// [`push_lanes`](Self::push_lanes) takes them.
            #[inline]
            #[allow(clippy::too_many_arguments)] // one argument per value of the entry
            pub fn push_picked(
                &mut self,
                $( $arg: soa!(@lanes $aty; $($col),+), )+
                $($( $sfield: Option<&[$sty; LANES]>, )+)?
                picks: &[usize],
            ) {
                $( soa!(@put_picked self, $arg, picks, $($col),+); )+
                $($( if let Some(v) = $sfield {
                    self.$sfield.extend(picks.iter().map(|&k| v[k]));
                } )+)?
            }

            /// Empties the queue and refills it with `n` entries of the given values
            /// (sparse columns stay empty).
            #[allow(clippy::too_many_arguments)] // one argument per value of the entry
            pub fn reset(&mut self, n: usize, $( $arg: $aty ),+) {
                self.clear();
                $( soa!(@resize self, n, $arg, $($col),+); )+
            }

            /// Appends entries `range` of `src` (sparse columns where `src` has them).
            pub fn append_range(&mut self, src: &$name, range: std::ops::Range<usize>) {
                $( self.$field.extend_from_slice(&src.$field[range.clone()]); )+
                $($( if !src.$sfield.is_empty() {
                    self.$sfield.extend_from_slice(&src.$sfield[range.clone()]);
                } )+)?
            }

            /// Appends entries `ids` of `src`, in that order (sparse columns where `src`
            /// has them).
            pub fn gather(&mut self, src: &$name, ids: &[u32]) {
                $( self.$field.extend(ids.iter().map(|&i| src.$field[i as usize])); )+
                $($( if !src.$sfield.is_empty() {
                    self.$sfield.extend(ids.iter().map(|&i| src.$sfield[i as usize]));
                } )+)?
            }

            $(
                /// Sizes every sparse column to the queue's length, the entries it adds
                /// set to the given values (a pass that gives each entry its value after
                /// pushing them all).
                pub fn fill_sparse(&mut self, $( $sfield: $sty ),+) {
                    let n = self.len();
                    $( self.$sfield.resize(n, $sfield); )+
                }
            )?

            $($(
                /// Field group of entry `i` as a vector.
                #[inline]
                pub fn $get(&self, i: usize) -> Vec3 {
                    Vec3::new(self.$gx[i], self.$gy[i], self.$gz[i])
                }
            )+)?
        }
    };
    (@put $s:ident, $v:ident, $c:ident) => { $s.$c.push($v) };
    (@put $s:ident, $v:ident, $x:ident, $y:ident, $z:ident) => {{
        $s.$x.push($v.x);
        $s.$y.push($v.y);
        $s.$z.push($v.z);
    }};
    (@resize $s:ident, $n:ident, $v:ident, $c:ident) => { $s.$c.resize($n, $v) };
    (@resize $s:ident, $n:ident, $v:ident, $x:ident, $y:ident, $z:ident) => {{
        $s.$x.resize($n, $v.x);
        $s.$y.resize($n, $v.y);
        $s.$z.resize($n, $v.z);
    }};
    (@first $s:ident, $f:ident $(, $rest:ident)*) => { $s.$f };
    (@lanes $t:ty; $c:ident) => { [$t; LANES] };
    (@lanes $t:ty; $x:ident, $y:ident, $z:ident) => { [[f32; LANES]; 3] };
    (@put_lanes $s:ident, $v:ident, $n:ident, $c:ident) => { push_lanes(&mut $s.$c, $v, $n) };
    (@put_lanes $s:ident, $v:ident, $n:ident, $x:ident, $y:ident, $z:ident) => {{
        push_lanes(&mut $s.$x, $v[0], $n);
        push_lanes(&mut $s.$y, $v[1], $n);
        push_lanes(&mut $s.$z, $v[2], $n);
    }};
    (@put_picked $s:ident, $v:ident, $p:ident, $c:ident) => { $s.$c.extend($p.iter().map(|&k| $v[k])) };
    (@put_picked $s:ident, $v:ident, $p:ident, $x:ident, $y:ident, $z:ident) => {{
        $s.$x.extend($p.iter().map(|&k| $v[0][k]));
        $s.$y.extend($p.iter().map(|&k| $v[1][k]));
        $s.$z.extend($p.iter().map(|&k| $v[2][k]));
    }};
}

soa! {
    /// Rays to be intersected with the scene (camera rays and reflection/refraction rays).
    pub struct RayQueue {
        /// Origin x.
        ox: f32,
        /// Origin y.
        oy: f32,
        /// Origin z.
        oz: f32,
        /// Direction x (unit length).
        dx: f32,
        /// Direction y.
        dy: f32,
        /// Direction z.
        dz: f32,
        /// Accumulation slot the ray's radiance goes to (a pixel, a pixel corner or a
        /// refinement estimate, depending on the pass that started the path).
        slot: u32,
        /// Path throughput red: the weight of this ray's radiance in the pixel estimate.
        wr: f32,
        /// Path throughput green.
        wg: f32,
        /// Path throughput blue.
        wb: f32,
        /// Number of reflection/refraction bounces before this ray (0 for camera rays).
        depth: u32,
        /// Point key: a hash naming the point the path started from (a pixel, a corner,
        /// a refinement estimate) and the branches it took at dielectrics; the seed of the
        /// point's sample sequences, shared by all its samples.
        key: u32,
        /// Index of the path's camera sample among its point's samples: with `key`, it
        /// names the path, and it indexes the point's stratified sequences (the light
        /// samples of all the point's paths are stratified together).
        sample: u32,
        /// Density (solid angle) with which a surface's BSDF sampled this ray's
        /// direction, when the surface also sampled the lights (multiple importance
        /// sampling: weights the emitter the ray hits), divided by the surface's light
        /// samples; negative when the surface's light samples took the emitters' whole
        /// weight (the emitter the ray hits counts 0); 0 for every other ray.
        pdf: f32,
    }
    push(o: Vec3 => ox, oy, oz; d: Vec3 => dx, dy, dz; slot: u32 => slot; w: Vec3 => wr, wg, wb;
         depth: u32 => depth; key: u32 => key; sample: u32 => sample; pdf: f32 => pdf)
    get(origin => ox, oy, oz; dir => dx, dy, dz; weight => wr, wg, wb)
    sparse(
        /// The path's time in the shutter: only under motion blur
        /// ([`Scene::motion_blur`](crate::scene::Scene::motion_blur)).
        time: f32,
    )
}

soa! {
    /// Closest hits of a [`RayQueue`], one entry per ray, in the same order.
    pub struct HitQueue {
        /// Distance along the ray; infinite for a miss.
        t: f32,
        /// Index of the primitive hit (in the scene's primitive order), or [`MISS`].
        prim: u32,
    }
    push(t: f32 => t; prim: u32 => prim)
}

/// Primitive index of a ray that hit nothing.
pub const MISS: u32 = u32::MAX;

soa! {
    /// Shadow rays: segments towards a light, each carrying the radiance it adds to its
    /// pixel if nothing blocks it.
    pub struct ShadowQueue {
        /// Origin x.
        ox: f32,
        /// Origin y.
        oy: f32,
        /// Origin z.
        oz: f32,
        /// Direction x (unit length).
        dx: f32,
        /// Direction y.
        dy: f32,
        /// Direction z.
        dz: f32,
        /// Segment length: occluders beyond it do not count.
        tmax: f32,
        /// Accumulation slot the contribution goes to.
        slot: u32,
        /// Unoccluded contribution red (already weighted by path throughput and sample count).
        lr: f32,
        /// Contribution green.
        lg: f32,
        /// Contribution blue.
        lb: f32,
    }
    push(o: Vec3 => ox, oy, oz; d: Vec3 => dx, dy, dz; tmax: f32 => tmax; slot: u32 => slot; l: Vec3 => lr, lg, lb)
    get(origin => ox, oy, oz; dir => dx, dy, dz; radiance => lr, lg, lb)
    sparse(
        /// The time of the path the ray belongs to: only under motion blur.
        time: f32,
    )
}

soa! {
    /// Radiance ready to be added to pixels: background, emitters seen directly or through
    /// mirrors, and unoccluded shadow contributions.
    pub struct FilmQueue {
        /// Accumulation slot.
        slot: u32,
        /// Radiance red.
        r: f32,
        /// Radiance green.
        g: f32,
        /// Radiance blue.
        b: f32,
    }
    push(slot: u32 => slot; l: Vec3 => r, g, b)
    get(radiance => r, g, b)
}

soa! {
    /// Shading points waiting for the adaptive shadow test of one area light (the shadow
    /// corner queue): each names a shading point of the current wave (an entry of its
    /// [`SurfaceQueue`]) and a light, with the light's contribution if nothing blocked it.
    pub struct ShadowPointQueue {
        /// Index of the shading point in the wave's surface queue.
        surface: u32,
        /// Index of the area light.
        light: u32,
        /// Accumulation slot of the ray.
        slot: u32,
        /// Unoccluded contribution red.
        ur: f32,
        /// Unoccluded contribution green.
        ug: f32,
        /// Unoccluded contribution blue.
        ub: f32,
    }
    push(surface: u32 => surface; light: u32 => light; slot: u32 => slot; unoccluded: Vec3 => ur, ug, ub)
    get(unoccluded => ur, ug, ub)
}

soa! {
    /// Indices into another queue, ascending: the specular hits of a wave (rays), the
    /// penumbra points (entries of the shadow-point queue), the pixels still refined
    /// (tile pixels), the penumbra points still sampling.
    pub struct IndexQueue {
        /// The index.
        index: u32,
    }
    push(index: u32 => index)
}

impl IndexQueue {
    /// Empties the queue and refills it with `indices` (ascending, as every index queue).
    pub fn refill(&mut self, indices: impl IntoIterator<Item = u32>) {
        self.index.clear();
        self.index.extend(indices);
    }
}

soa! {
    /// Adaptive AA: per-pixel state of one tile, one entry per tile pixel.
    pub struct RefineQueue {
        /// The estimate the next level is compared with.
        prev: Vec3,
        /// Sum of refinement samples' radiance (each level's mean times its sample count).
        sum: Vec3,
        /// Refinement samples cast so far.
        count: u32,
        /// Last refinement level cast; 0 for a pixel never refined.
        level: u8,
    }
    push(prev: Vec3 => prev; sum: Vec3 => sum; count: u32 => count; level: u8 => level)
}

soa! {
    /// Variance-driven AA: per-pixel state of one tile, one entry per tile pixel. Sample
    /// g of a pixel (counted over all its rounds) goes to half `g & 1`.
    pub struct HalfBufferQueue {
        /// Sum of the radiance of the pixel's even samples.
        even: Vec3,
        /// Sum of the radiance of its odd samples.
        odd: Vec3,
        /// Samples cast so far.
        count: u32,
        /// Rounds cast so far.
        rounds: u8,
    }
    push(even: Vec3 => even; odd: Vec3 => odd; count: u32 => count; rounds: u8 => rounds)
}

/// Variance-driven AA's queues of one tile: every pixel's half-buffers and the pixels
/// still sampled. Grouped because the converge stage owns both.
#[derive(Default, Debug, Clone)]
pub struct VarianceQueues {
    /// Per tile pixel: its half-buffers.
    pub state: HalfBufferQueue,
    /// The pixels still sampled (tile pixel indices, ascending).
    pub active: IndexQueue,
}

impl VarianceQueues {
    /// Bytes held by the buffers (capacity, not length).
    pub fn bytes(&self) -> usize {
        self.state.bytes() + self.active.bytes()
    }
}

/// Adaptive AA's queues of one tile: every pixel's refinement state and the pixels still
/// refined. Grouped because the refine stage owns both.
#[derive(Default, Debug, Clone)]
pub struct RefineQueues {
    /// Per tile pixel: its refinement state.
    pub state: RefineQueue,
    /// The pixels still refined (tile pixel indices, ascending).
    pub active: IndexQueue,
}

impl RefineQueues {
    /// Bytes held by the buffers (capacity, not length).
    pub fn bytes(&self) -> usize {
        self.state.bytes() + self.active.bytes()
    }
}

soa! {
    /// The penumbra points of one wave, in penumbra-list order: where each one's rays
    /// lie in the penumbra ray queue, and (with early stopping) how far it got.
    pub struct PenumbraPointQueue {
        /// First ray of the point in the penumbra ray queue (and in the batch order).
        start: u32,
        /// One past its last ray.
        end: u32,
        /// Rays traced so far.
        taken: u32,
        /// Of those, rays that reached the light.
        visible: u32,
    }
    push(start: u32 => start; end: u32 => end; taken: u32 => taken; visible: u32 => visible)
}

soa! {
    /// Penumbra early stopping, per ray of the penumbra ray queue.
    pub struct PenumbraRayQueue {
        /// The point (index in [`PenumbraPointQueue`]) the ray belongs to.
        point: u32,
        /// Traced and unblocked.
        lit: bool,
        /// The ray traced in this position: each point's range holds its rays sorted by
        /// the progressive key of their light cells, the order batches take them in.
        order: u32,
    }
    push(point: u32 => point; lit: bool => lit; order: u32 => order)
}

/// The penumbra stage's queues: its full ray queue and, with early stopping, the batch
/// being traced and its state. Grouped because the stage owns all of them.
#[derive(Default, Debug, Clone)]
pub struct PenumbraQueues {
    /// Every penumbra point's stratified shadow rays, in uniform mode's order.
    pub rays: ShadowQueue,
    /// Per point: its range of `rays` and its early-stopping counts.
    pub points: PenumbraPointQueue,
    /// Per ray: early-stopping state.
    pub per_ray: PenumbraRayQueue,
    /// Points still sampling.
    pub active: IndexQueue,
    /// The batch being traced (slots name rays of `rays`).
    pub batch: ShadowQueue,
    /// The occlusion stage's output for the batch.
    pub through: FilmQueue,
    /// Scratch for the progressive order: one point's rays with their light cells.
    pub cells: Vec<Progressive>,
    /// Scratch for the progressive order's merge.
    pub merge: Vec<Progressive>,
    /// Scratch: each point's number of rays as the lanes cast them.
    pub counts: Vec<u32>,
    /// Scratch with early stopping: each ray's light cell, as the lanes cast them.
    pub ray_cells: Vec<u32>,
}

impl PenumbraQueues {
    /// Bytes held by the buffers (capacity, not length).
    pub fn bytes(&self) -> usize {
        let scratch = (self.cells.capacity() + self.merge.capacity()) * std::mem::size_of::<Progressive>()
            + (self.counts.capacity() + self.ray_cells.capacity()) * std::mem::size_of::<u32>();
        self.rays.bytes()
            + self.points.bytes()
            + self.per_ray.bytes()
            + self.active.bytes()
            + self.batch.bytes()
            + self.through.bytes()
            + scratch
    }
}

soa! {
    /// Diffuse shading points the shade stage lights lane by lane (a
    /// [`Surface`](crate::surface::Surface) per entry).
    pub struct SurfaceQueue {
        /// Shadow-ray origin x.
        ox: f32,
        /// Shadow-ray origin y.
        oy: f32,
        /// Shadow-ray origin z.
        oz: f32,
        /// Unit normal x, on the side the ray arrived from.
        nx: f32,
        /// Normal y.
        ny: f32,
        /// Normal z.
        nz: f32,
        /// Direction back along the incoming ray, x.
        wox: f32,
        /// Back direction y.
        woy: f32,
        /// Back direction z.
        woz: f32,
        /// Albedo red.
        cr: f32,
        /// Albedo green.
        cg: f32,
        /// Albedo blue.
        cb: f32,
        /// Phong reflectance red.
        sr: f32,
        /// Phong reflectance green.
        sg: f32,
        /// Phong reflectance blue.
        sb: f32,
        /// Phong exponent.
        shininess: f32,
        /// Path throughput red.
        wr: f32,
        /// Path throughput green.
        wg: f32,
        /// Path throughput blue.
        wb: f32,
        /// Accumulation slot.
        slot: u32,
        /// Path key.
        key: u32,
        /// Camera sample index of the path.
        sample: u32,
        /// Index of the ray that hit the point, in the shaded ray queue.
        ray: u32,
    }
    push(o: Vec3 => ox, oy, oz; n: Vec3 => nx, ny, nz; wo: Vec3 => wox, woy, woz; color: Vec3 => cr, cg, cb;
         specular: Vec3 => sr, sg, sb; shininess: f32 => shininess; w: Vec3 => wr, wg, wb; slot: u32 => slot;
         key: u32 => key; sample: u32 => sample; ray: u32 => ray)
    get(origin => ox, oy, oz; normal => nx, ny, nz; wo => wox, woy, woz; color => cr, cg, cb;
        specular => sr, sg, sb; weight => wr, wg, wb)
    sparse(
        /// The path's time: only under motion blur.
        time: f32,
    )
}

/// The shading points waiting for the adaptive shadow test of a wave: the shadow-corner
/// queue and the surface queue its entries point into. What the shadow-corner and
/// penumbra stages read.
#[derive(Clone, Copy, Debug)]
pub struct ShadowPoints<'a> {
    /// The wave's diffuse shading points.
    pub surfaces: &'a SurfaceQueue,
    /// (point, area light) pairs, with the light's unoccluded contribution.
    pub points: &'a ShadowPointQueue,
}

/// Entry `i` of a sparse column ([`soa!`]'s `sparse`): its value, or the default where
/// the scene does not use the column and it is empty.
#[inline(always)]
pub fn sparse<T: Copy + Default>(column: &[T], i: usize) -> T {
    column.get(i).copied().unwrap_or_default()
}

/// Entry `i` of a sparse column ([`soa!`]'s `sparse`) where the queue has the column:
/// what an entry derived from entry `i` (a bounce, a shadow ray) is pushed with.
#[inline(always)]
pub fn sparse_opt<T: Copy>(column: &[T], i: usize) -> Option<T> {
    column.get(i).copied()
}

/// The queues of one wave, owned by a worker and reused from wave to wave.
#[derive(Default, Debug, Clone)]
pub struct WaveQueues {
    /// The rays being traced (camera rays, or a bounce level's).
    pub rays: RayQueue,
    /// Their closest hits.
    pub hits: HitQueue,
    /// Shadow rays of point lights and of uniform-mode quad lights.
    pub shadow: ShadowQueue,
    /// The diffuse points the shade stage lights.
    pub surfaces: SurfaceQueue,
    /// Adaptive shadows: the shadow-corner queue.
    pub points: ShadowPointQueue,
    /// Adaptive shadows: the shadow-corner test's probe rays (slot: the point).
    pub probes: ShadowQueue,
    /// Adaptive shadows: the points the corner test could not decide.
    pub penumbra: IndexQueue,
    /// Adaptive shadows: the penumbra stage's queues.
    pub penumbra_rays: PenumbraQueues,
    /// Rays that hit a mirror or dielectric.
    pub specular: IndexQueue,
    /// Reflection and refraction rays: the next bounce level.
    pub next: RayQueue,
    /// Contributions for the film.
    pub film: FilmQueue,
}

impl WaveQueues {
    /// Bytes held by the buffers (capacity, not length).
    pub fn bytes(&self) -> usize {
        self.rays.bytes()
            + self.hits.bytes()
            + self.shadow.bytes()
            + self.surfaces.bytes()
            + self.points.bytes()
            + self.probes.bytes()
            + self.penumbra.bytes()
            + self.penumbra_rays.bytes()
            + self.specular.bytes()
            + self.next.bytes()
            + self.film.bytes()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn vec3() -> impl Strategy<Value = Vec3> {
        (-1e6f32..1e6, -1e6f32..1e6, -1e6f32..1e6).prop_map(|(x, y, z)| Vec3::new(x, y, z))
    }

    proptest! {
        /// Every field a ray is pushed with comes back unchanged, at its index, after
        /// `append_range` and `gather` too; `clear` empties every field.
        #[test]
        fn ray_queue_round_trips(rays in prop::collection::vec((vec3(), vec3(), any::<u32>(), vec3(), any::<u32>(), any::<(u32, u32)>()), 1..40)) {
            let mut q = RayQueue::default();
            for &(o, d, slot, w, depth, (key, sample)) in &rays {
                q.push(o, d, slot, w, depth, key, sample, slot as f32, Some(key as f32));
            }
            prop_assert_eq!(q.len(), rays.len());
            for (i, &(o, d, slot, w, depth, (key, sample))) in rays.iter().enumerate() {
                prop_assert_eq!((q.origin(i), q.dir(i), q.weight(i)), (o, d, w));
                prop_assert_eq!((q.slot[i], q.depth[i], q.key[i], q.sample[i]), (slot, depth, key, sample));
                prop_assert_eq!((q.pdf[i], q.time[i]), (slot as f32, key as f32));
            }
            let mut tail = RayQueue::default();
            tail.append_range(&q, 1..q.len());
            prop_assert_eq!(tail.len(), q.len() - 1);
            for i in 0..tail.len() {
                prop_assert_eq!((tail.origin(i), tail.key[i], tail.time[i]), (q.origin(i + 1), q.key[i + 1], q.time[i + 1]));
            }
            let ids: Vec<u32> = (0..q.len() as u32).rev().collect();
            let mut rev = RayQueue::default();
            rev.gather(&q, &ids);
            for (j, &i) in ids.iter().enumerate() {
                let i = i as usize;
                prop_assert_eq!((rev.dir(j), rev.weight(j), rev.slot[j], rev.time[j]), (q.dir(i), q.weight(i), q.slot[i], q.time[i]));
            }
            prop_assert!(q.bytes() >= 15 * 4 * q.len());
            q.clear();
            prop_assert!(q.is_empty());
            prop_assert!(q.ox.is_empty() && q.dz.is_empty() && q.wb.is_empty() && q.key.is_empty() && q.sample.is_empty());
        }

        /// The same for a shadow queue, whose fields differ in kind and order.
        #[test]
        fn shadow_queue_round_trips(rays in prop::collection::vec((vec3(), vec3(), 0f32..1e6, any::<u32>(), vec3()), 1..40)) {
            let mut q = ShadowQueue::default();
            for &(o, d, t, slot, l) in &rays {
                q.push(o, d, t, slot, l, None);
            }
            for (i, &(o, d, t, slot, l)) in rays.iter().enumerate() {
                prop_assert_eq!((q.origin(i), q.dir(i), q.radiance(i)), (o, d, l));
                prop_assert_eq!((q.tmax[i], q.slot[i]), (t, slot));
            }
            prop_assert_eq!(q.bytes(), q.ox.capacity() * 4 * 11);
            prop_assert!(q.time.is_empty(), "a sparse column nobody pushed stays empty");
        }
    }
}
