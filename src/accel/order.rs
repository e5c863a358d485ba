//! The order a queue's rays are cut into packets in: coherent rays next to each other,
//! by a stable sort, so the order (and every result) is deterministic.

use glam::Vec3;

use super::Accel;

/// How a queue's rays are ordered before they are cut into packets.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Order {
    /// Generation order.
    Keep,
    /// Grouped by direction octant (a stable counting sort: generation order within an
    /// octant, linear time).
    Octant,
    /// By direction octant, then the Morton code of the origin (a stable sort).
    Morton,
}

impl std::fmt::Display for Order {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str(match self {
            Order::Keep => "keep",
            Order::Octant => "octant",
            Order::Morton => "morton",
        })
    }
}

impl Order {
    /// Parses `keep`, `octant` or `morton`.
    pub fn parse(s: &str) -> Option<Order> {
        match s {
            "keep" => Some(Order::Keep),
            "octant" => Some(Order::Octant),
            "morton" => Some(Order::Morton),
            _ => None,
        }
    }
}

/// Where each direction octant's run starts when `n` rays (directions `d(i)`) are
/// sorted stably by octant: octant k's rays take places `starts[k]..starts[k + 1]`.
pub(crate) fn octant_starts(n: usize, d: impl Fn(usize) -> Vec3) -> [usize; 9] {
    let mut start = [0usize; 9];
    for i in 0..n {
        start[octant(d(i)) as usize + 1] += 1;
    }
    for k in 1..9 {
        start[k] += start[k - 1];
    }
    start
}

/// The stable counting sort's second pass: `place(at, i, k)` puts ray `i` (octant `k`) at
/// place `at`, from [`octant_starts`]'s `start`.
pub(crate) fn by_octant(
    n: usize,
    d: impl Fn(usize) -> Vec3,
    mut start: [usize; 9],
    mut place: impl FnMut(usize, usize, usize),
) {
    for i in 0..n {
        let k = octant(d(i)) as usize;
        place(start[k], i, k);
        start[k] += 1;
    }
}

/// Direction octant: the three sign bits.
#[inline]
pub fn octant(d: Vec3) -> u32 {
    (d.x < 0.0) as u32 | ((d.y < 0.0) as u32) << 1 | ((d.z < 0.0) as u32) << 2
}

/// Spreads the low 10 bits of `v` to every third bit (for a 30-bit Morton code).
#[inline]
fn spread(mut v: u32) -> u32 {
    v &= 0x3ff;
    v = (v | (v << 16)) & 0x0300_00ff;
    v = (v | (v << 8)) & 0x0300_f00f;
    v = (v | (v << 4)) & 0x030c_30c3;
    (v | (v << 2)) & 0x0924_9249
}

/// Sort key that puts coherent rays next to each other: direction octant first, then the
/// Morton code of the origin on a 1024³ grid over `(lo, hi)`.
#[inline]
pub fn coherence_key(o: Vec3, d: Vec3, lo: Vec3, hi: Vec3) -> u64 {
    let q = ((o - lo) / (hi - lo).max(Vec3::splat(1e-30)) * 1023.0).clamp(Vec3::ZERO, Vec3::splat(1023.0));
    let m = spread(q.x as u32) | spread(q.y as u32) << 1 | spread(q.z as u32) << 2;
    (octant(d) as u64) << 32 | m as u64
}

/// The order packets are formed in: `order` receives the ray indices 0..n as `how` says
/// (every sort is stable, so the order is deterministic).
pub fn packet_order(
    accel: &Accel,
    n: usize,
    o: impl Fn(usize) -> Vec3,
    d: impl Fn(usize) -> Vec3,
    how: Order,
    order: &mut Vec<(u64, u32)>,
) {
    order.clear();
    match how {
        Order::Keep => order.extend((0..n as u32).map(|i| (0, i))),
        Order::Octant => {
            // Counting sort on the 8 octants.
            let start = octant_starts(n, &d);
            if let Some(k) = (0..8).find(|&k| start[k + 1] - start[k] == n).filter(|_| n > 0) {
                // One octant (a shadow queue to one light above the scene): the order
                // stays the queue's, without a second pass.
                order.extend((0..n as u32).map(|i| (k as u64, i)));
                return;
            }
            order.resize(n, (0, 0));
            by_octant(n, &d, start, |at, i, k| order[at] = (k as u64, i as u32));
        }
        Order::Morton => {
            let (lo, hi) = accel.bounds();
            order.extend((0..n).map(|i| (coherence_key(o(i), d(i), lo, hi), i as u32)));
            order.sort_by_key(|e| e.0);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::shapes::{Shape, NO_LIGHT};
    use crate::accel::Primitive;

    #[test]
    fn octant_order_is_a_stable_sort_by_octant() {
        let sphere =
            Primitive { shape: Shape::Sphere { center: Vec3::ZERO, radius: 1.0 }, material: 0, light: NO_LIGHT };
        let accel = Accel::build(vec![sphere]);
        let mut h = 7u32;
        let mut rnd = || {
            h = crate::sampling::mix(h);
            crate::sampling::to_unit(h) - 0.5
        };
        // Mixed octants; one octant (the shortcut); empty.
        let mixed: Vec<Vec3> = (0..300).map(|_| Vec3::new(rnd(), rnd(), rnd())).collect();
        let one: Vec<Vec3> = (0..50).map(|_| Vec3::new(rnd().abs(), -rnd().abs() - 0.1, rnd().abs())).collect();
        for dirs in [mixed, one, Vec::new()] {
            let mut order = Vec::new();
            packet_order(&accel, dirs.len(), |_| Vec3::ZERO, |i| dirs[i], Order::Octant, &mut order);
            let mut want: Vec<(u64, u32)> =
                (0..dirs.len() as u32).map(|i| (octant(dirs[i as usize]) as u64, i)).collect();
            want.sort_by_key(|e| e.0);
            assert_eq!(order, want);
        }
    }
}
