//! The progressive order early stopping walks a point's light samples in: one in each
//! quarter of the light first, then one in each sixteenth, and so on, so every prefix is
//! spread over the whole light.

use super::mix;

/// Base-4 digits (Morton levels) needed for a grid of `cols`×`rows` cells.
pub fn morton_levels(cols: u32, rows: u32) -> u32 {
    32 - (cols.max(rows).max(1) - 1).leading_zeros()
}

/// The cell of a `cols`×`rows` grid over the unit square that contains the centre of
/// cell (`col`, `row`) of a 2^`levels` × 2^`levels` grid over the same square, with
/// `levels` = [`morton_levels`]: distinct cells land in distinct cells, and the halves,
/// quarters, … of this grid are those of the square, whatever `cols` and `rows` are
/// (11×12 cells for 128 samples).
pub fn progressive_cell(col: u32, row: u32, cols: u32, rows: u32, levels: u32) -> (u32, u32) {
    let side = 1u64 << levels;
    let at = |i: u32, n: u32| ((2 * i as u64 + 1) * side / (2 * n as u64)) as u32;
    (at(col, cols), at(row, rows))
}

/// One item of [`progressive_order`]: its cell on the 2^levels grid and what it stands
/// for.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Progressive {
    /// Cell column on the 2^levels grid ([`progressive_cell`]).
    pub x: u32,
    /// Cell row.
    pub y: u32,
    /// The caller's index.
    pub item: u32,
    /// The cell's Morton code (filled in by [`progressive_order`]).
    pub morton: u32,
}

/// Sorts `items` (distinct cells of a 2^`levels` grid) into a progressive order: one in
/// each quarter of the square first, then one in each sixteenth, and so on, so every
/// prefix is spread over the whole square. `scratch` is reused memory.
///
/// From the finest level up, the four sub-blocks of each block are merged round-robin:
/// the first item of each (in a sub-block order scrambled by a hash of `scramble` and the
/// block: Owen's nested scrambling, so each block draws its own), then the second of
/// each, and so on. On a full 2^L×2^L grid this is the scrambled radical-inverse order,
/// where each position is a uniformly random cell, so a prefix of any fixed length is an
/// unbiased sample. On a sparse one (the cells of an 11×12 grid among 16×16) a sub-block
/// that runs out is skipped, so the quarters still alternate. Items start in Morton
/// order, which keeps every block contiguous; each merge is linear. Items must have
/// distinct cells and an `item` other than `u32::MAX`.
pub fn progressive_order(items: &mut [Progressive], levels: u32, scramble: u32, scratch: &mut Vec<Progressive>) {
    // Spreads the low 16 bits of v to the even bits (the classic magic-number interleave).
    let spread = |v: u32| {
        let mut v = v & 0xffff;
        v = (v | v << 8) & 0x00ff_00ff;
        v = (v | v << 4) & 0x0f0f_0f0f;
        v = (v | v << 2) & 0x3333_3333;
        (v | v << 1) & 0x5555_5555
    };
    for it in items.iter_mut() {
        it.morton = spread(it.x) | spread(it.y) << 1;
    }
    let n = items.len();
    let cells = 1usize << (2 * levels);
    if n == cells && n > 1 && levels <= 16 {
        full_grid_order(items, levels, scramble, scratch);
        return;
    }
    merge_order(items, levels, scramble, scratch);
}

/// The sub-block order of a block of [`progressive_order`]: the quarter taken first is
/// the one whose digit is 0 after an exclusive or with this (Owen's nested scrambling:
/// a hash of the scramble, the block and its level).
#[inline(always)]
fn block_flip(scramble: u32, block: u32, level: u32) -> u32 {
    mix(scramble ^ block.wrapping_mul(0x9e37_79b9) ^ level) & 3
}

/// [`progressive_order`] of a full grid (every one of the 4^`levels` cells holds an
/// item): every sub-block has as many items as its siblings, so the round-robin merges
/// put an item at the scrambled radical inverse of its Morton code, built digit by digit
/// from the finest level as the merges build it (position ← 4 · position + scrambled
/// digit), and each item goes straight to its place. The merges' order, bit for bit (a
/// unit test compares them). Items are walked in Morton order, so a block's scramble is
/// hashed once, when the walk enters it.
fn full_grid_order(items: &mut [Progressive], levels: u32, scramble: u32, scratch: &mut Vec<Progressive>) {
    scratch.clear();
    scratch.resize(items.len(), Progressive::default());
    for it in items.iter() {
        scratch[it.morton as usize] = *it;
    }
    let mut flips = [0u32; 16];
    for (m, it) in scratch.iter().enumerate() {
        let m = m as u32;
        let mut pos = 0;
        for level in 0..levels {
            let block = m >> (2 * (level + 1));
            if m & ((1 << (2 * (level + 1))) - 1) == 0 {
                flips[level as usize] = block_flip(scramble, block, level);
            }
            let digit = (m >> (2 * level)) & 3;
            pos += (digit ^ flips[level as usize]) << (2 * (levels - 1 - level));
        }
        items[pos as usize] = *it;
    }
}

/// [`progressive_order`] by its definition: items into Morton order, then the
/// round-robin merges from the finest level up.
fn merge_order(items: &mut [Progressive], levels: u32, scramble: u32, scratch: &mut Vec<Progressive>) {
    let n = items.len();
    let cells = 1usize << (2 * levels);
    if cells <= 8 * n {
        // Dense enough to place each item at its Morton code instead of sorting.
        let empty = Progressive { item: u32::MAX, ..Progressive::default() };
        scratch.clear();
        scratch.resize(cells, empty);
        for it in items.iter() {
            scratch[it.morton as usize] = *it;
        }
        for (k, it) in scratch.iter().filter(|it| it.item != u32::MAX).enumerate() {
            items[k] = *it;
        }
    } else {
        items.sort_unstable_by_key(|it| it.morton);
    }
    for level in 0..levels {
        let (shift, digit) = (2 * (level + 1), 2 * level);
        let mut a = 0;
        while a < n {
            let block = items[a].morton >> shift;
            let mut b = a + 1;
            while b < n && items[b].morton >> shift == block {
                b += 1;
            }
            // The block's four sub-blocks are contiguous runs, in quarter order.
            let mut bounds = [a; 5];
            let mut i = a;
            for q in 0..4 {
                while i < b && (items[i].morton >> digit) & 3 == q as u32 {
                    i += 1;
                }
                bounds[q + 1] = i;
            }
            if b - a > 1 {
                let flip = block_flip(scramble, block, level) as usize;
                let longest = (0..4).map(|q| bounds[q + 1] - bounds[q]).max().unwrap_or(0);
                scratch.clear();
                for t in 0..longest {
                    for q in 0..4 {
                        let at = bounds[q ^ flip] + t;
                        if at < bounds[(q ^ flip) + 1] {
                            scratch.push(items[at]);
                        }
                    }
                }
                items[a..b].copy_from_slice(scratch);
            }
            a = b;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The progressive order of a `cols`×`rows` grid: (col, row) per position.
    fn order(cols: u32, rows: u32, scramble: u32) -> Vec<(u32, u32)> {
        let levels = morton_levels(cols, rows);
        let mut items: Vec<Progressive> = (0..cols * rows)
            .map(|i| {
                let (x, y) = progressive_cell(i % cols, i / cols, cols, rows, levels);
                Progressive { x, y, item: i, morton: 0 }
            })
            .collect();
        progressive_order(&mut items, levels, scramble, &mut Vec::new());
        items.iter().map(|it| (it.item % cols, it.item / cols)).collect()
    }

    /// A full grid's direct placement is the merges' order: 2×2 to 32×32 cells, many
    /// scrambles, items given in shuffled order.
    #[test]
    fn a_full_grid_is_placed_where_the_merges_put_it() {
        for levels in 1..=5u32 {
            let side = 1u32 << levels;
            for scramble in (0..40u32).map(mix) {
                let mut items: Vec<Progressive> =
                    (0..side * side).map(|i| Progressive { x: i % side, y: i / side, item: i, morton: 0 }).collect();
                // Any starting order: a shuffle by the scramble.
                items.sort_by_key(|it| mix(it.item ^ scramble));
                let (mut direct, mut merged) = (items.clone(), items.clone());
                progressive_order(&mut direct, levels, scramble, &mut Vec::new());
                for it in merged.iter_mut() {
                    it.morton = direct.iter().find(|d| d.item == it.item).unwrap().morton;
                }
                merge_order(&mut merged, levels, scramble, &mut Vec::new());
                assert_eq!(direct, merged, "{side}×{side}, scramble {scramble}");
            }
        }
    }

    #[test]
    fn progressive_prefixes_are_stratified() {
        assert_eq!(morton_levels(8, 8), 3);
        assert_eq!(morton_levels(11, 12), 4);
        assert_eq!(morton_levels(1, 1), 0);
        type Cell = (u32, u32);
        let distinct = |cells: &[Cell], f: &dyn Fn(&Cell) -> Cell| {
            cells.iter().map(f).collect::<std::collections::HashSet<_>>().len()
        };
        for scramble in 0..50u32 {
            // 8×8: the first 4 lie one per quarter, the first 16 one per 2×2 block.
            let o = order(8, 8, mix(scramble));
            assert_eq!(distinct(&o, &|c| *c), 64, "a permutation");
            assert_eq!(distinct(&o[..4], &|c| (c.0 / 4, c.1 / 4)), 4);
            assert_eq!(distinct(&o[..16], &|c| (c.0 / 2, c.1 / 2)), 16);
            // 11×12 (128 samples' grid): the first 4 lie one per quarter of the square
            // (by cell centre), and the first 16 four per quarter.
            let o = order(11, 12, mix(scramble));
            assert_eq!(distinct(&o, &|c| *c), 132);
            let quarter = |c: &(u32, u32)| ((2 * c.0 + 1) / 11, (2 * c.1 + 1) / 12);
            assert_eq!(distinct(&o[..4], &quarter), 4, "scramble {scramble}");
            for q in 0..4 {
                let n = o[..16].iter().filter(|c| quarter(c) == (q % 2, q / 2)).count();
                assert_eq!(n, 4, "scramble {scramble}: quarter {q} has {n} of the first 16");
            }
        }
        // The scramble moves the first cell around: each of the 64 cells comes first
        // about equally often over many scrambles.
        let mut first = [0u32; 64];
        for scramble in 0..6400u32 {
            let c = order(8, 8, mix(scramble))[0];
            first[(c.1 * 8 + c.0) as usize] += 1;
        }
        assert!(first.iter().all(|&c| (60..=140).contains(&c)), "{first:?}");
        // Each 2×2 block draws its own first cell: the first 16 do not all sit at the same
        // offset in their blocks (which a single digital shift would give).
        let same = (0..200u32)
            .filter(|&scramble| {
                let o = order(8, 8, mix(scramble));
                o[..16].iter().all(|c| (c.0 % 2, c.1 % 2) == (o[0].0 % 2, o[0].1 % 2))
            })
            .count();
        assert!(same < 5, "{same} of 200 scrambles put the first 16 at one offset");
    }
}
