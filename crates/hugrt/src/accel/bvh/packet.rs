//! The packet walk ([`crate::accel::packet`]): up to eight rays down the tree together.
//!
//! Each node is fetched once for every ray of the packet that reaches it, and its four boxes
//! are met by all eight lanes in one pass (four children by eight rays), the same slab test as
//! the single walk's lane by lane ([`super::traverse::walk_tree`]): the same near and far
//! planes from each direction's sign bit, the same NaN rule, so that a ray reaches a child in
//! the packet exactly when it would reach it alone with the same nearest hit. A child is
//! entered with the rays that reach it, nearest first by the least entry distance among them;
//! the others wait on the stack with each ray's entry distance, and on leaving the stack a ray
//! whose nearest hit now lies before its entry is dropped. A leaf is tested ray by ray with the
//! single walk's leaf test ([`Bvh::test_leaf`]), each ray with its own sink.
//!
//! The rays may reach nodes in another order than alone, so one of them may test primitives
//! its own walk would have passed (its nearest hit was then farther); it never skips one its
//! own walk tests, and the closest hit does not depend on the order: each ray's answer is its
//! own, bit for bit (`tests/agree.rs` checks it against brute force).
//!
//! This is the packet traversal of Wald, Slusallek, Benthin and Wagner ("Interactive rendering
//! with coherent ray tracing", 2001) on Embree's four-wide nodes, with per-ray entry distances
//! on the stack rather than one for the packet.

use super::block::{self, BlockRay, BlockRays};
use super::{Bvh, LEAF, LEAF_START_BITS, NO_CHILD, Node, STACK, WIDTH};
use crate::accel::packet::{PACKET, each_lane};
use crate::accel::{Counters, HitSink, Primitives};
use crate::geometry::{PreparedRay, Ray};

/// Most rays of a packet still active at a leaf for which its blocks are tested ray by ray
/// (the single walk's test, the same bits) rather than against eight lanes at once.
const SINGLE_LEAF_LANES: u32 = 2;

type Lanes = [f32; PACKET];

/// What a node test needs of the packet's rays: origins and inverse directions, lane by
/// lane, and the rows of each axis's near and far planes, one for every ray.
struct PacketRays {
    o: [Lanes; 3],
    inv: [Lanes; 3],
    near_row: [usize; 3],
    far_row: [usize; 3],
}

/// The rays of a packet that reach each of `node`'s children in `[tmin, far]`, as masks, and
/// their entry distances: the single walk's slab test lane by lane (a NaN, 0·∞ when a ray lies
/// in a face's plane, fails both comparisons and leaves the interval as it was). Each child's
/// lanes are kept in locals: written into arrays axis by axis, the compiler made them masked
/// stores, which made the walk slower than one ray's.
/// The third part is each child's nearest entry over the rays of `active` that reach it
/// (infinite when none does).
#[inline(always)]
fn meet(node: &Node, r: &PacketRays, tmin: &Lanes, far: &Lanes, active: u32) -> Met {
    let mut t0 = [*tmin; WIDTH];
    let mut reaches = [0u32; WIDTH];
    let mut nearest = [f32::INFINITY; WIDTH];
    for k in 0..WIDTH {
        let mut near_t = *tmin;
        let mut far_t = *far;
        for a in 0..3 {
            let (near, away) = (node.bounds[r.near_row[a]][k], node.bounds[r.far_row[a]][k]);
            for l in 0..PACKET {
                let tn = (near - r.o[a][l]) * r.inv[a][l];
                let tf = (away - r.o[a][l]) * r.inv[a][l];
                near_t[l] = if tn > near_t[l] { tn } else { near_t[l] };
                far_t[l] = if tf < far_t[l] { tf } else { far_t[l] };
            }
        }
        let mut reach = 0u32;
        for l in 0..PACKET {
            reach |= ((near_t[l] <= far_t[l]) as u32) << l;
        }
        reaches[k] = reach;
        t0[k] = near_t;
        for (l, &t) in near_t.iter().enumerate() {
            if (reach & active) >> l & 1 != 0 && t < nearest[k] {
                nearest[k] = t;
            }
        }
    }
    (reaches, t0, nearest)
}

/// What [`meet`] finds: the rays reaching each child, their entry distances and each child's
/// nearest entry among the active rays.
type Met = ([u32; WIDTH], [Lanes; WIDTH], [f32; WIDTH]);

/// [`meet`] with AVX, the eight lanes one register: `max(tn, t)` and `min(tf, t)` return their
/// second operand when the first is NaN, as the comparisons of [`meet`] do, and the masks come
/// from one ordered `<=` comparison each, false on NaN as there. The nearest entry is a
/// horizontal minimum of the lanes reached (never NaN: each starts at `tmin` and `max` keeps
/// it on a NaN), the value [`meet`]'s loop finds (a zero's sign aside, which the children's
/// order, the only use of it, does not see); found lane by lane, it made the packet walk
/// of a terrain's shadow rays slower than one ray at a time.
///
/// # Safety
/// The processor must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn meet_avx2(node: &Node, r: &PacketRays, tmin: &Lanes, far: &Lanes, active: u32) -> Met {
    use std::arch::x86_64::*;
    // SAFETY (every unaligned load and store below): each reads or writes eight `f32` of a
    // `Lanes`, which is eight `f32`.
    let load = |x: &Lanes| unsafe { _mm256_loadu_ps(x.as_ptr()) };
    let o = [load(&r.o[0]), load(&r.o[1]), load(&r.o[2])];
    let inv = [load(&r.inv[0]), load(&r.inv[1]), load(&r.inv[2])];
    let (lo, hi) = (load(tmin), load(far));
    let mut t0 = [[0f32; PACKET]; WIDTH];
    let mut reaches = [0u32; WIDTH];
    let mut nearest = [f32::INFINITY; WIDTH];
    let bits = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
    let infinity = _mm256_set1_ps(f32::INFINITY);
    for k in 0..WIDTH {
        let mut near_t = lo;
        let mut far_t = hi;
        for a in 0..3 {
            let near = _mm256_set1_ps(node.bounds[r.near_row[a]][k]);
            let away = _mm256_set1_ps(node.bounds[r.far_row[a]][k]);
            let tn = _mm256_mul_ps(_mm256_sub_ps(near, o[a]), inv[a]);
            let tf = _mm256_mul_ps(_mm256_sub_ps(away, o[a]), inv[a]);
            near_t = _mm256_max_ps(tn, near_t);
            far_t = _mm256_min_ps(tf, far_t);
        }
        let reached = _mm256_cmp_ps::<_CMP_LE_OQ>(near_t, far_t);
        reaches[k] = _mm256_movemask_ps(reached) as u32;
        unsafe { _mm256_storeu_ps(t0[k].as_mut_ptr(), near_t) };
        let of_active = _mm256_castsi256_ps(_mm256_cmpeq_epi32(
            _mm256_and_si256(_mm256_set1_epi32(active as i32), bits),
            bits,
        ));
        let t = _mm256_blendv_ps(infinity, near_t, _mm256_and_ps(reached, of_active));
        let t = _mm_min_ps(_mm256_castps256_ps128(t), _mm256_extractf128_ps::<1>(t));
        let t = _mm_min_ps(t, _mm_movehl_ps(t, t));
        let t = _mm_min_ss(t, _mm_shuffle_ps::<1>(t, t));
        nearest[k] = _mm_cvtss_f32(t);
    }
    (reaches, t0, nearest)
}

/// A child waiting on the stack: its reference, the rays that reached it and their entry
/// distances.
#[derive(Clone, Copy)]
struct Entry {
    child: u32,
    rays: u32,
    entry: Lanes,
}

impl Bvh {
    /// [`crate::accel::Accel::query_packet`] of the bvh: `rays` (at most [`PACKET`]) walked
    /// together, each offering its hits to its own sink. The packet walk wants every
    /// direction's signs alike (each axis's near plane the same for every ray, as in a
    /// coherent group); other groups are walked ray by ray.
    pub(super) fn walk_packet<P: Primitives, C: Counters, S: HitSink>(
        &self,
        prims: &P,
        rays: &[Ray],
        sinks: &mut [S],
        counters: &mut C,
    ) {
        let n = rays.len().min(sinks.len()).min(PACKET);
        if n == 0 {
            return;
        }
        let signs = |r: &Ray| {
            (r.dir.x.is_sign_negative() as u32)
                | (r.dir.y.is_sign_negative() as u32) << 1
                | (r.dir.z.is_sign_negative() as u32) << 2
        };
        let octant = signs(&rays[0]);
        if n == 1 || rays[1..n].iter().any(|r| signs(r) != octant) {
            for (ray, sink) in rays[..n].iter().zip(sinks) {
                self.walk(prims, ray, sink, counters);
            }
            return;
        }
        #[cfg(target_arch = "x86_64")]
        if crate::accel::simd::available() {
            // SAFETY: the processor has AVX2, which is all the function's attribute enables.
            unsafe { self.packet_avx2(prims, &rays[..n], octant, sinks, counters) };
            return;
        }
        self.packet::<P, C, S, false>(prims, &rays[..n], octant, sinks, counters);
    }

    /// [`Bvh::packet`] compiled for AVX2, where the lanes of eight rays are one register.
    ///
    /// # Safety
    /// The processor must support AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn packet_avx2<P: Primitives, C: Counters, S: HitSink>(
        &self,
        prims: &P,
        rays: &[Ray],
        octant: u32,
        sinks: &mut [S],
        counters: &mut C,
    ) {
        self.packet::<P, C, S, true>(prims, rays, octant, sinks, counters);
    }

    /// The packet walk of `rays` (one to [`PACKET`]), whose directions' sign bits are all
    /// `octant`'s (bit `a` for axis `a`); nodes are met by [`meet_avx2`] with `AVX2`, which
    /// only [`Bvh::packet_avx2`] sets, and by [`meet`] otherwise.
    #[inline(always)]
    fn packet<P: Primitives, C: Counters, S: HitSink, const AVX2: bool>(
        &self,
        prims: &P,
        rays: &[Ray],
        octant: u32,
        sinks: &mut [S],
        counters: &mut C,
    ) {
        let n = rays.len();
        // Children farthest first where the first ray's sink asks for the walk from the far
        // end, as the single walk takes them.
        let far_first = S::FIRST_ENDS && sinks[0].walks_back();
        // Lanes past `n` repeat the last ray; they are never in a mask.
        let lane = |l: usize| &rays[l.min(n - 1)];
        let axis = |f: fn(&Ray) -> f32| -> Lanes { std::array::from_fn(|l| f(lane(l))) };
        let o = [
            axis(|r| r.origin.x),
            axis(|r| r.origin.y),
            axis(|r| r.origin.z),
        ];
        // As `PreparedRay::inv_dir` computes it.
        let inv = [
            axis(|r| 1.0 / r.dir.x),
            axis(|r| 1.0 / r.dir.y),
            axis(|r| 1.0 / r.dir.z),
        ];
        // Rows of the near and far planes per axis, from the sign bits, as the single walk.
        let neg = |a: usize| (octant >> a & 1) as usize;
        let rays_ = PacketRays {
            o,
            inv,
            near_row: [3 * neg(0), 1 + 3 * neg(1), 2 + 3 * neg(2)],
            far_row: [3 - 3 * neg(0), 4 - 3 * neg(1), 5 - 3 * neg(2)],
        };
        let tmin = axis(|r| r.tmin);
        let mut far: Lanes = std::array::from_fn(|l| {
            if l < n {
                sinks[l].tmax()
            } else {
                f32::NEG_INFINITY
            }
        });
        // Rays whose sink has not stopped the walk.
        let mut live: u32 = (1 << n) - 1;
        let mut prepared: [Option<(PreparedRay, BlockRay)>; PACKET] = [None; PACKET];
        let mut block_rays: Option<BlockRays> = None;

        // Left uninitialised, as the single walk's.
        let mut stack = [const { std::mem::MaybeUninit::<Entry>::uninit() }; STACK];
        let mut top = 0;
        let mut current = Entry {
            child: 0,
            rays: live,
            entry: tmin,
        };
        loop {
            let mut active = 0u32;
            for (l, (e, f)) in current.entry.iter().zip(&far).enumerate() {
                active |= ((e <= f) as u32) << l;
            }
            active &= current.rays & live;
            if active != 0 {
                for _ in 0..active.count_ones() {
                    counters.cell_visit(0);
                }
                let child = current.child;
                if child & LEAF != 0 {
                    let start = (child & ((1 << LEAF_START_BITS) - 1)) as usize;
                    let count = ((child & !LEAF) >> LEAF_START_BITS) as usize + 1;
                    if AVX2 && !self.indexed && active.count_ones() > SINGLE_LEAF_LANES {
                        // Every ray's set-up at the packet's first leaf: the blocks are met by
                        // the eight lanes at once.
                        let block_rays = block_rays.get_or_insert_with(|| {
                            for (l, p) in prepared.iter_mut().enumerate().take(n) {
                                p.get_or_insert_with(|| {
                                    let pr = PreparedRay::new(&rays[l]);
                                    (pr, BlockRay::new(&pr))
                                });
                            }
                            let lanes: [BlockRay; PACKET] = std::array::from_fn(|l| {
                                prepared[l.min(n - 1)].expect("prepared above").1
                            });
                            BlockRays::new(&lanes)
                        });
                        let mut todo = active;
                        for b in &self.blocks[start..start + count] {
                            #[cfg(target_arch = "x86_64")]
                            // SAFETY: `AVX2` is set only by `packet_avx2`, run where AVX2 is.
                            let found = unsafe { block::packet_lanes_avx2(b, block_rays) };
                            #[cfg(not(target_arch = "x86_64"))]
                            let found: [block::Lanes; PACKET] = unreachable!();
                            for l in each_lane(todo) {
                                let ray = &prepared[l].as_ref().expect("prepared above").0;
                                if self.finish_block(
                                    b,
                                    found[l],
                                    prims,
                                    ray,
                                    rays[l].tmin,
                                    &mut sinks[l],
                                    counters,
                                ) {
                                    todo &= !(1 << l);
                                    live &= !(1 << l);
                                    far[l] = f32::NEG_INFINITY;
                                }
                            }
                            if todo == 0 {
                                break;
                            }
                        }
                        for l in each_lane(todo) {
                            far[l] = sinks[l].tmax();
                        }
                    } else {
                        for l in each_lane(active) {
                            let ray = &rays[l];
                            let p = prepared[l].get_or_insert_with(|| {
                                let pr = PreparedRay::new(ray);
                                (pr, BlockRay::new(&pr))
                            });
                            let sink = &mut sinks[l];
                            if self.test_leaf(start, count, prims, p, ray.tmin, sink, counters) {
                                live &= !(1 << l);
                                far[l] = f32::NEG_INFINITY;
                            } else {
                                far[l] = sink.tmax();
                            }
                        }
                    }
                    if live == 0 {
                        return;
                    }
                } else {
                    let node = &self.nodes[child as usize];
                    let (reaches, t0, nearest) = if AVX2 {
                        #[cfg(target_arch = "x86_64")]
                        // SAFETY: `AVX2` is set only by `packet_avx2`, run where AVX2 is.
                        unsafe {
                            meet_avx2(node, &rays_, &tmin, &far, active)
                        }
                        #[cfg(not(target_arch = "x86_64"))]
                        unreachable!()
                    } else {
                        meet(node, &rays_, &tmin, &far, active)
                    };
                    let mut hits = [(0f32, 0u32, 0u32, 0usize); WIDTH];
                    let mut found = 0;
                    for k in 0..WIDTH {
                        if node.children[k] == NO_CHILD {
                            continue;
                        }
                        for _ in 0..active.count_ones() {
                            counters.box_test(0);
                        }
                        let reach = reaches[k] & active;
                        if reach == 0 {
                            continue;
                        }
                        let nearest = nearest[k];
                        // Sorted by nearest entry by insertion, nearest taken first (farthest
                        // first where `far_first`).
                        let mut i = found;
                        while i > 0
                            && if S::FIRST_ENDS && far_first {
                                hits[i - 1].0 > nearest
                            } else {
                                hits[i - 1].0 < nearest
                            }
                        {
                            hits[i] = hits[i - 1];
                            i -= 1;
                        }
                        hits[i] = (nearest, node.children[k], reach, k);
                        found += 1;
                    }
                    if found > 0 {
                        for &(_, child, rays, k) in &hits[..found - 1] {
                            stack[top].write(Entry {
                                child,
                                rays,
                                entry: t0[k],
                            });
                            top += 1;
                        }
                        let (_, child, rays, k) = hits[found - 1];
                        current = Entry {
                            child,
                            rays,
                            entry: t0[k],
                        };
                        continue;
                    }
                }
            }
            if top == 0 {
                break;
            }
            top -= 1;
            // SAFETY: every entry below `top` has been written: `top` grows only by one, right
            // after `stack[top].write` (bounds-checked; the depth bound behind `STACK` holds
            // for the packet as for one ray, at most `WIDTH - 1` entries pushed a level).
            current = unsafe { stack[top].assume_init() };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// The single walk's slab test of one ray and one child ([`super::super::traverse`]).
    fn alone(node: &Node, k: usize, o: [f32; 3], d: [f32; 3], tmin: f32, far: f32) -> (bool, f32) {
        let (mut t0, mut t1) = (tmin, far);
        for a in 0..3 {
            let inv = 1.0 / d[a];
            let neg = d[a].is_sign_negative() as usize;
            let (lo, hi) = (node.bounds[a + 3 * neg][k], node.bounds[a + 3 - 3 * neg][k]);
            let tn = (lo - o[a]) * inv;
            let tf = (hi - o[a]) * inv;
            t0 = if tn > t0 { tn } else { t0 };
            t1 = if tf < t1 { tf } else { t1 };
        }
        (t0 <= t1, t0)
    }

    /// Both node tests reach a child with exactly the rays the single walk's test reaches it
    /// with, and enter it at the same distance, bit for bit: on coordinates drawn from a few
    /// values, so that rays often lie in a face's plane (0·∞) and boxes are often flat.
    #[test]
    fn both_node_tests_meet_children_as_one_ray_does() {
        let mut r = rand_pcg::Pcg64Mcg::seed_from_u64(5);
        let values = [0.0f32, 1.0, 2.0, 0.5, -1.0];
        let dirs = [0.0f32, 1.0, 0.5, 3.0];
        let mut checked = [0usize; 2];
        for _ in 0..20_000 {
            let mut node = Node::EMPTY;
            for k in 0..WIDTH {
                for a in 0..3 {
                    let (x, y) = (values[r.random_range(0..5)], values[r.random_range(0..5)]);
                    node.bounds[a][k] = x.min(y);
                    node.bounds[a + 3][k] = x.max(y);
                }
            }
            let octant: u32 = r.random_range(0..8);
            let rays: Vec<([f32; 3], [f32; 3], f32, f32)> = (0..PACKET)
                .map(|_| {
                    let o = [0; 3].map(|_| values[r.random_range(0..5)]);
                    let mut d = [0; 3].map(|_| dirs[r.random_range(0..4)]);
                    if d == [0.0; 3] {
                        d[0] = 1.0;
                    }
                    for (a, x) in d.iter_mut().enumerate() {
                        if octant >> a & 1 != 0 {
                            *x = -*x;
                        }
                    }
                    let far = if r.random() { f32::INFINITY } else { 2.0 };
                    (o, d, r.random_range(-1.0..0.5), far)
                })
                .collect();
            let neg = |a: usize| (octant >> a & 1) as usize;
            let packet = PacketRays {
                o: [0, 1, 2].map(|a| std::array::from_fn(|l| rays[l].0[a])),
                inv: [0, 1, 2].map(|a| std::array::from_fn(|l| 1.0 / rays[l].1[a])),
                near_row: [3 * neg(0), 1 + 3 * neg(1), 2 + 3 * neg(2)],
                far_row: [3 - 3 * neg(0), 4 - 3 * neg(1), 5 - 3 * neg(2)],
            };
            let tmin: Lanes = std::array::from_fn(|l| rays[l].2);
            let far: Lanes = std::array::from_fn(|l| rays[l].3);
            let active: u32 = r.random_range(0..=255);
            let mut tests = vec![meet(&node, &packet, &tmin, &far, active)];
            #[cfg(target_arch = "x86_64")]
            if crate::accel::simd::available() {
                // SAFETY: AVX2 is present.
                tests.push(unsafe { meet_avx2(&node, &packet, &tmin, &far, active) });
            }
            for (which, (reaches, t0, nearest)) in tests.iter().enumerate() {
                checked[which] += 1;
                for k in 0..WIDTH {
                    let mut least = f32::INFINITY;
                    for (l, &(o, d, lo, hi)) in rays.iter().enumerate() {
                        let (reached, entry) = alone(&node, k, o, d, lo, hi);
                        assert_eq!(reaches[k] >> l & 1 != 0, reached, "test {which}");
                        if reached {
                            assert_eq!(t0[k][l].to_bits(), entry.to_bits(), "test {which}");
                            if active >> l & 1 != 0 {
                                least = least.min(entry);
                            }
                        }
                    }
                    // Equal as numbers: the sign of a zero may differ, which the ordering of
                    // the children does not see.
                    assert_eq!(nearest[k], least, "test {which}");
                }
            }
        }
        assert!(checked[0] > 0);
        if crate::accel::simd::available() {
            assert_eq!(checked[1], checked[0], "the AVX2 test ran");
        }
    }
}
