//! Sorting keys of the builds: 64-bit values ordered by their upper 32 bits (a key above an
//! index or a reference), least significant digit first in as few passes of at most 12 bits
//! as the largest key needs. Linear where a comparison sort of millions of keys takes several times longer, and
//! stable, so values with equal keys keep their order (the builds rely on it: a cell lists its
//! objects in store order).

use rayon::prelude::*;

/// Below this many values one thread sorts: splitting costs more than it saves.
const PARALLEL_FROM: usize = 1 << 16;

/// Sorts `v` by the upper 32 bits of each value, stably.
pub(crate) fn radix_sort_high32(v: &mut Vec<u64>) {
    *v = radix_sort_high32_parts(vec![std::mem::take(v)]);
}

/// The values of `parts`, one after another, sorted by their upper 32 bits, stably: the
/// parallel sort's first pass reads the parts where they are, so that a build's lists of
/// pairs made in parallel are never copied into one (on a 16M-triangle HUG, a 750 MB copy
/// into memory the kernel had to zero first).
pub(crate) fn radix_sort_high32_parts(mut parts: Vec<Vec<u64>>) -> Vec<u64> {
    let n: usize = parts.iter().map(Vec::len).sum();
    let top = parts.iter().flatten().fold(0u64, |a, &x| a.max(x >> 32));
    let passes = passes(64 - top.leading_zeros());
    if n < PARALLEL_FROM || rayon::current_num_threads() == 1 {
        let mut v = if parts.len() == 1 {
            parts.pop().unwrap_or_default()
        } else {
            parts.concat()
        };
        serial(&mut v, &passes);
        v
    } else {
        parallel(parts, &passes)
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
/// before it, into its own slices of the destination (split off in that order, so each chunk
/// writes only its own), and the order within a digit is the order before the pass. The
/// first pass's chunks are runs of whole parts; the later ones' equal ranges.
fn parallel(parts: Vec<Vec<u64>>, passes: &[(u32, u32)]) -> Vec<u64> {
    let n: usize = parts.iter().map(Vec::len).sum();
    let chunks = rayon::current_num_threads().clamp(2, 16);
    let Some((&(shift, bits), later)) = passes.split_first() else {
        return parts.concat();
    };
    // Runs of whole parts of about `n / chunks` values each.
    let mut runs: Vec<Vec<&[u64]>> = vec![Vec::new()];
    let mut filled = 0;
    for part in &parts {
        if filled >= (n / chunks).max(1) {
            runs.push(Vec::new());
            filled = 0;
        }
        runs.last_mut().unwrap().push(part.as_slice());
        filled += part.len();
    }
    // Zeroed by the allocator (pages the kernel zeroes on first touch, in the scatter's
    // threads), not by a fill on one thread.
    let mut src = vec![0u64; n];
    scatter(&runs, &mut src, shift, bits);
    drop(runs);
    // One part's memory is the next destination; several are freed before it is made.
    let mut dst = match <[Vec<u64>; 1]>::try_from(parts) {
        Ok([only]) => only,
        Err(parts) => {
            drop(parts);
            vec![0u64; n]
        }
    };
    for &(shift, bits) in later {
        let input: Vec<Vec<&[u64]>> = (0..chunks)
            .map(|c| vec![&src[c * n / chunks..(c + 1) * n / chunks]])
            .collect();
        scatter(&input, &mut dst, shift, bits);
        std::mem::swap(&mut src, &mut dst);
    }
    src
}

/// One pass of [`parallel`]: the values of `input`'s chunks, each a list of slices read in
/// order, placed into `dst` by their digit `(x >> shift) & (2^bits − 1)`, stably.
fn scatter(input: &[Vec<&[u64]>], dst: &mut [u64], shift: u32, bits: u32) {
    let digits = 1usize << bits;
    let counts: Vec<Vec<usize>> = input
        .par_iter()
        .map(|chunk| {
            let mut count = vec![0usize; digits];
            for x in chunk.iter().flat_map(|s| s.iter()) {
                count[digit(*x, shift, bits)] += 1;
            }
            count
        })
        .collect();
    let mut outs: Vec<Vec<&mut [u64]>> = (0..input.len())
        .map(|_| Vec::with_capacity(digits))
        .collect();
    let mut rest = dst;
    // Digit-major, chunk-minor: the digit indexes every chunk's counts.
    #[allow(clippy::needless_range_loop)]
    for d in 0..digits {
        for (out, count) in outs.iter_mut().zip(&counts) {
            let (mine, after) = rest.split_at_mut(count[d]);
            out.push(mine);
            rest = after;
        }
    }
    input.par_iter().zip(outs).for_each(|(chunk, mut out)| {
        let mut next = vec![0usize; digits];
        for &x in chunk.iter().flat_map(|s| s.iter()) {
            let d = digit(x, shift, bits);
            out[d][next[d]] = x;
            next[d] += 1;
        }
    });
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

/// Sorts distinct indices below `bound` ascending: where they are at least a 32nd of the
/// indices below `bound`, by setting a bit for each and reading the bits in order (the HUG's
/// world grid on a scanned mesh holds nearly every object, 100,000 of them sorted in 0.8 ms
/// by radix passes), else as [`sort_indices`] does.
pub(crate) fn sort_distinct_indices(v: &mut [u32], bound: usize) {
    if v.len() < 4096 || v.len() * 32 < bound || v.is_sorted() {
        return sort_indices(v);
    }
    let mut bits = vec![0u64; bound.div_ceil(64)];
    for &x in v.iter() {
        bits[x as usize / 64] |= 1 << (x % 64);
    }
    let mut k = 0;
    for (w, &word) in bits.iter().enumerate() {
        let mut word = word;
        while word != 0 {
            v[k] = (w * 64) as u32 + word.trailing_zeros();
            k += 1;
            word &= word - 1;
        }
    }
    assert_eq!(k, v.len(), "indices to sort are distinct");
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
    fn distinct_indices_sort_as_a_comparison_sort_does() {
        for (n, bound) in [
            (0, 10),
            (5000, 5000),
            (5000, 9000),
            (5000, 1 << 20),
            (70_000, 100_001),
        ] {
            let mut v: Vec<u32> = (0..bound as u64)
                .map(|i| (i.wrapping_mul(2654435761) % bound as u64) as u32)
                .take(n)
                .collect();
            let mut want = v.clone();
            want.sort_unstable();
            sort_distinct_indices(&mut v, bound);
            assert_eq!(v, want, "{n} of {bound}");
        }
    }

    #[test]
    fn sorts_by_the_high_half_stably() {
        for n in [0, 1, 5000, 200_000] {
            let mut want = keys(n);
            want.sort_by_key(|&x| x >> 32);
            let mut s = keys(n);
            serial(&mut s, &passes(32));
            assert_eq!(s, want, "serial, {n}");
            assert_eq!(parallel(vec![keys(n)], &passes(32)), want, "parallel, {n}");
            // In uneven parts, the first pass reading them where they are.
            let k = keys(n);
            let mut cuts = [0, n / 7, (n / 7 + 1).min(n), n / 2, n];
            cuts.sort_unstable();
            let parts: Vec<Vec<u64>> = cuts
                .windows(2)
                .map(|w| k[w[0] as usize..w[1] as usize].to_vec())
                .collect();
            assert_eq!(parallel(parts.clone(), &passes(32)), want, "parts, {n}");
            assert_eq!(radix_sort_high32_parts(parts), want, "parts, {n}");
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
