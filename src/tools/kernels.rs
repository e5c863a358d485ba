//! The traversal kernels kept to be measured, beside the renderer's two questions
//! ([`Accel::closest`] and [`Accel::occluded`] of one ray; `Tracer::closest` and
//! `Tracer::occluded` of a queue, which pick the kernel): the binary reference walk, the
//! interleaved walk and packets. `wavetrace bench` and the kernel tests reach them here,
//! so the renderer's API holds only what it uses. Every one gives the renderer's answers,
//! bit for bit.

use glam::Vec3;

use crate::accel::packet::{self, PacketWork};
use crate::accel::{Accel, Ray, Traversal, Walk};
use crate::simd::Vector;

/// [`Accel::closest`] through the binary tree where the accel keeps one
/// ([`Accel::build_reference`]): the independent reference of the tests.
pub fn binary_closest<const COUNT: bool>(accel: &Accel, ray: Ray, c: &mut Traversal) -> Option<(f32, u32)> {
    accel.closest_binary::<COUNT>(ray, c)
}

/// [`Accel::occluded`] through the binary tree where the accel keeps one.
pub fn binary_occluded<const COUNT: bool>(accel: &Accel, ray: Ray, c: &mut Traversal) -> bool {
    accel.occluded_binary::<COUNT>(ray, c)
}

/// [`Accel::closest`] of `n` rays (`ray(i)`), walked interleaved through the wide tree:
/// `out(i, hit)` for every ray, in the order they finish.
pub fn interleaved_closest<const COUNT: bool>(
    accel: &Accel,
    n: usize,
    ray: impl Fn(usize) -> Ray,
    out: impl FnMut(usize, Option<(f32, u32)>),
    c: &mut Traversal,
) {
    accel.closest_many::<COUNT>(Walk::Interleaved, n, ray, out, c)
}

/// [`Accel::occluded`] of `n` rays, interleaved: `out(i, blocked)` for every ray, in the
/// order they finish.
pub fn interleaved_occluded<const COUNT: bool>(
    accel: &Accel,
    n: usize,
    ray: impl Fn(usize) -> Ray,
    out: impl FnMut(usize, bool),
    c: &mut Traversal,
) {
    accel.occluded_many::<COUNT>(Walk::Interleaved, n, ray, out, c)
}

/// [`Accel::closest`] of `n` rays (`ray(i)`) traced as one ray stream through the wide
/// tree: `out(i, hit)` for every ray, in index order.
pub fn stream_closest<const COUNT: bool>(
    accel: &Accel,
    n: usize,
    ray: impl Fn(usize) -> Ray,
    out: impl FnMut(usize, Option<(f32, u32)>),
    c: &mut Traversal,
) {
    accel.closest_many::<COUNT>(Walk::Stream, n, ray, out, c)
}

/// [`Accel::occluded`] of `n` rays traced as one ray stream: `out(i, blocked)` for every
/// ray, in index order.
pub fn stream_occluded<const COUNT: bool>(
    accel: &Accel,
    n: usize,
    ray: impl Fn(usize) -> Ray,
    out: impl FnMut(usize, bool),
    c: &mut Traversal,
) {
    accel.occluded_many::<COUNT>(Walk::Stream, n, ray, out, c)
}

/// Closest hits of a packet of up to `S::WIDTH` rays (`o`, `d` of equal length) within
/// `(tmin, ∞)`, walked together: `out[l]` is `(t, primitive)` or `(∞, u32::MAX)`.
pub fn packet_closest<S: Vector>(
    accel: &Accel,
    o: &[Vec3],
    d: &[Vec3],
    tmin: f32,
    out: &mut [(f32, u32)],
    work: &mut PacketWork,
) {
    packet::closest::<S>(accel, o, d, None, tmin, out, work)
}

/// Any-hit tests of a packet of up to `S::WIDTH` shadow segments `(0, tmax[l])`: `out[l]`
/// is true when a non-emitting primitive blocks lane l.
pub fn packet_occluded<S: Vector>(
    accel: &Accel,
    o: &[Vec3],
    d: &[Vec3],
    tmax: &[f32],
    out: &mut [bool],
    work: &mut PacketWork,
) {
    packet::occluded::<S>(accel, o, d, None, tmax, out, work)
}
