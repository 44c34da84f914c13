//! Sorting keys of the builds: 64-bit values ordered by their upper 32 bits (a key above an
//! index or a reference), least significant digit first in as few passes of at most 12 bits
//! as the largest key needs. Linear where a comparison sort of millions of keys takes several times longer, and
//! stable, so values with equal keys keep their order (the builds rely on it: a cell lists its
//! objects in store order).

use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};

/// Below this many values one thread sorts: splitting costs more than it saves.
const PARALLEL_FROM: usize = 1 << 16;

/// Sorts `v` by the upper 32 bits of each value, stably.
pub(crate) fn radix_sort_high32(v: &mut Vec<u64>) {
    let top = v.iter().fold(0u64, |a, &x| a.max(x >> 32));
    let passes = passes(64 - top.leading_zeros());
    if v.len() < PARALLEL_FROM || rayon::current_num_threads() == 1 {
        serial(v, &passes);
    } else {
        *v = parallel(std::mem::take(v), &passes);
    }
}

/// The digits (shift, width) of keys of `bits` bits above bit 32: the fewest passes of at
/// most 12 bits (4096 counters stay in the first-level cache), as wide as each other.
fn passes(bits: u32) -> Vec<(u32, u32)> {
    passes_from(32, bits)
}

fn passes_from(base: u32, bits: u32) -> Vec<(u32, u32)> {
    let n = bits.div_ceil(12).max(1);
    let width = bits.div_ceil(n).max(1);
    (0..n).map(|k| (base + k * width, width)).collect()
}

/// Sorts keys below `2^bits` ascending (on one thread): linear time, where a comparison sort
/// takes `O(n log n)` (the kd-tree's events, sorted at every node).
pub(crate) fn radix_sort_keys(v: &mut Vec<u64>, bits: u32) {
    serial(v, &passes_from(0, bits));
}

fn digit(x: u64, shift: u32, bits: u32) -> usize {
    ((x >> shift) & ((1 << bits) - 1)) as usize
}

fn serial(v: &mut Vec<u64>, passes: &[(u32, u32)]) {
    let mut tmp = vec![0u64; v.len()];
    for &(shift, bits) in passes {
        let mut count = vec![0usize; (1 << bits) + 1];
        for &x in v.iter() {
            count[digit(x, shift, bits) + 1] += 1;
        }
        for d in 0..1 << bits {
            count[d + 1] += count[d];
        }
        for &x in v.iter() {
            let d = digit(x, shift, bits);
            tmp[count[d]] = x;
            count[d] += 1;
        }
        std::mem::swap(v, &mut tmp);
    }
}

/// Each pass: every thread counts the digits of its chunk; chunk `c` then places its values
/// with digit `d` after all values of smaller digits and after those of digit `d` in chunks
/// before it. The slots of the chunks are disjoint, so the relaxed atomic stores never meet
/// (on x86 they are plain stores), and the order within a digit is the order before the pass.
fn parallel(v: Vec<u64>, passes: &[(u32, u32)]) -> Vec<u64> {
    let n = v.len();
    let chunks = rayon::current_num_threads().clamp(2, 16);
    let range = |c: usize| c * n / chunks..(c + 1) * n / chunks;
    let mut src: Vec<AtomicU64> = v.into_iter().map(AtomicU64::new).collect();
    let mut dst: Vec<AtomicU64> = std::iter::repeat_with(|| AtomicU64::new(0))
        .take(n)
        .collect();
    for &(shift, bits) in passes {
        let digits = 1usize << bits;
        let counts: Vec<Vec<usize>> = (0..chunks)
            .into_par_iter()
            .map(|c| {
                let mut count = vec![0usize; digits];
                for x in &src[range(c)] {
                    count[digit(x.load(Ordering::Relaxed), shift, bits)] += 1;
                }
                count
            })
            .collect();
        let mut starts = vec![vec![0usize; digits]; chunks];
        let mut at = 0;
        for d in 0..digits {
            for c in 0..chunks {
                starts[c][d] = at;
                at += counts[c][d];
            }
        }
        starts
            .into_par_iter()
            .enumerate()
            .for_each(|(c, mut next)| {
                for x in &src[range(c)] {
                    let x = x.load(Ordering::Relaxed);
                    let d = digit(x, shift, bits);
                    dst[next[d]].store(x, Ordering::Relaxed);
                    next[d] += 1;
                }
            });
        std::mem::swap(&mut src, &mut dst);
    }
    src.into_iter().map(AtomicU64::into_inner).collect()
}

/// Sorts store indices ascending: radix passes for long lists, a comparison sort for short.
pub(crate) fn sort_indices(v: &mut [u32]) {
    if v.is_sorted() {
        return;
    }
    if v.len() < 4096 {
        v.sort_unstable();
        return;
    }
    let mut wide: Vec<u64> = v.iter().map(|&x| (x as u64) << 32).collect();
    radix_sort_high32(&mut wide);
    for (o, w) in v.iter_mut().zip(&wide) {
        *o = (w >> 32) as u32;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn keys(n: u64) -> Vec<u64> {
        (0..n)
            .map(|i| (i.wrapping_mul(2654435761) % 100_000) << 32 | i)
            .collect()
    }

    #[test]
    fn sorts_by_the_high_half_stably() {
        for n in [0, 1, 5000, 200_000] {
            let mut want = keys(n);
            want.sort_by_key(|&x| x >> 32);
            let mut s = keys(n);
            serial(&mut s, &passes(32));
            assert_eq!(s, want, "serial, {n}");
            assert_eq!(parallel(keys(n), &passes(32)), want, "parallel, {n}");
            let mut r = keys(n);
            radix_sort_high32(&mut r);
            assert_eq!(r, want, "{n}");
        }
        assert_eq!(passes(23), vec![(32, 12), (44, 12)]);
        let mut k: Vec<u64> = keys(50_000).iter().map(|x| x % (1 << 34)).collect();
        let mut want = k.clone();
        want.sort_unstable();
        radix_sort_keys(&mut k, 34);
        assert_eq!(k, want);
        assert_eq!(passes(32), vec![(32, 11), (43, 11), (54, 11)]);
        // Small keys take fewer passes and sort the same.
        let mut small: Vec<u64> = (0..100_000u64)
            .map(|i| (i * 7919 % 1000) << 32 | i)
            .collect();
        let mut want = small.clone();
        want.sort_by_key(|&x| x >> 32);
        radix_sort_high32(&mut small);
        assert_eq!(small, want);
    }
}
