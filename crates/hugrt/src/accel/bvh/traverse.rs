//! The query: children nearest first on an explicit stack, leaves' blocks of four triangles
//! tested together.

use super::block::{self, Block, BlockRay, EMPTY_LANE};
use super::{Bvh, LEAF, LEAF_START_BITS, NO_CHILD, Node, OTHER_LANE, STACK, WIDTH};
use crate::accel::{Counters, HitSink, Primitives};
use crate::geometry::{PreparedRay, Ray, Vec3, crossing_t, intersect_triangle};

impl Bvh {
    /// Bytes of the nodes and leaf references, without the store.
    pub(super) fn structure_bytes(&self) -> usize {
        self.nodes.capacity() * std::mem::size_of::<Node>()
            + self.blocks.capacity() * std::mem::size_of::<Block>()
            + self.leaf_starts.capacity() * 4
    }

    /// Tests the four primitives of `b`: the triangles' edge functions together
    /// ([`block::lanes`], the scalar test's bits lane by lane), then in lane order the `t` of
    /// each lane crossed ([`crossing_t`], with the nearest hit of the moment), the lanes it
    /// hands back and the lanes of other primitives, one at a time, as a test one at a time
    /// would. Returns `true` when the sink stops the walk.
    #[inline(always)]
    fn test_block<P: Primitives, C: Counters, S: HitSink>(
        &self,
        b: &Block,
        prims: &P,
        (ray, bray): &(PreparedRay, BlockRay),
        tmin: f32,
        sink: &mut S,
        counters: &mut C,
    ) -> bool {
        self.finish_block(b, block::lanes(b, bray), prims, ray, tmin, sink, counters)
    }

    /// [`Bvh::test_block`] after its edge functions: `lanes` is what [`block::lanes`] finds
    /// for `ray` (or the packet kernel, bit for bit the same).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(super) fn finish_block<P: Primitives, C: Counters, S: HitSink>(
        &self,
        b: &Block,
        lanes: block::Lanes,
        prims: &P,
        ray: &PreparedRay,
        tmin: f32,
        sink: &mut S,
        counters: &mut C,
    ) -> bool {
        for &id in &b.ids {
            if id != EMPTY_LANE {
                counters.prim_test(0);
            }
        }
        let mut others = 0u32;
        if self.others {
            for (l, &id) in b.ids.iter().enumerate() {
                others |= ((id != EMPTY_LANE && id & OTHER_LANE != 0) as u32) << l;
            }
        }
        // Lanes of other primitives have NaN vertices: they are never crossed nor need redoing.
        let crossed = lanes.crossed;
        let mut todo = crossed | lanes.redo | others;
        while todo != 0 {
            let l = todo.trailing_zeros() as usize;
            todo &= todo - 1;
            let id = b.ids[l];
            let (hit, prim) = if crossed >> l & 1 != 0 {
                (crossing_t(&b.triangle(l), &ray.ray, tmin, sink.tmax()), id)
            } else if others >> l & 1 != 0 {
                let s = id & !OTHER_LANE;
                (
                    self.store.intersect(prims, s, ray, tmin, sink.tmax()),
                    self.store.id(s),
                )
            } else {
                (
                    intersect_triangle(ray, &b.triangle(l), tmin, sink.tmax()),
                    id,
                )
            };
            if let Some(t) = hit {
                counters.prim_hit(0);
                if sink.offer(t, || prim) {
                    return true;
                }
            }
        }
        false
    }

    /// Tests store entries `start..start + count` (an indexed leaf, every entry a triangle):
    /// eight at a time where [`Bvh::simd`] allows, one at a time otherwise, in entry order
    /// either way. Returns `true` when the sink stops the walk.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn test_entries<P: Primitives, C: Counters, S: HitSink>(
        &self,
        start: usize,
        count: usize,
        prims: &P,
        ray: &PreparedRay,
        tmin: f32,
        sink: &mut S,
        counters: &mut C,
    ) -> bool {
        let end = (start + count) as u32;
        #[cfg(target_arch = "x86_64")]
        if self.simd {
            let mut s = start as u32;
            while s < end {
                let n = (end - s).min(8) as usize;
                let mut batch = [s; 8];
                for (k, b) in batch.iter_mut().enumerate().take(n) {
                    *b = s + k as u32;
                }
                // SAFETY: `simd` is set only when AVX2 is present and the store's offsets fit
                // (`build_indexed`); every entry of an indexed bvh's store is a triangle's,
                // and the padding repeats the first.
                if unsafe {
                    self.store
                        .offer_triangles8(prims, &batch, n, ray, tmin, sink, counters, 0)
                } {
                    return true;
                }
                s += n as u32;
            }
            return false;
        }
        for s in start as u32..end {
            counters.prim_test(0);
            if let Some(t) = self.store.intersect(prims, s, ray, tmin, sink.tmax()) {
                counters.prim_hit(0);
                if sink.offer(t, || self.store.id(s)) {
                    return true;
                }
            }
        }
        false
    }

    /// Tests leaf `count` slots from `start` of the leaf list: an indexed leaf's store
    /// entries, or its blocks. Returns `true` when the sink stops the walk.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(super) fn test_leaf<P: Primitives, C: Counters, S: HitSink>(
        &self,
        start: usize,
        count: usize,
        prims: &P,
        prepared: &(PreparedRay, BlockRay),
        tmin: f32,
        sink: &mut S,
        counters: &mut C,
    ) -> bool {
        if self.indexed {
            let start = match self.leaf_starts.get(start) {
                Some(&s) => s as usize,
                None => start,
            };
            return self.test_entries(start, count, prims, &prepared.0, tmin, sink, counters);
        }
        self.blocks[start..start + count]
            .iter()
            .any(|b| self.test_block(b, prims, prepared, tmin, sink, counters))
    }

    /// [`Accel::query`] of the bvh.
    #[inline(always)]
    pub(super) fn walk<P: Primitives, C: Counters, S: HitSink>(
        &self,
        prims: &P,
        ray: &Ray,
        sink: &mut S,
        counters: &mut C,
    ) {
        // The triangle test's set-up (axis permutation and shear) waits for the first leaf:
        // most camera rays of a sparse scene reach none, and for them it was a fifth of the
        // time.
        let mut prepared: Option<(PreparedRay, BlockRay)> = None;
        let tmin = ray.tmin;
        walk_tree::<S, C, true>(
            &self.nodes,
            ray,
            sink,
            counters,
            |start, count, sink, counters| {
                let prepared = prepared.get_or_insert_with(|| {
                    let pr = PreparedRay::new(ray);
                    (pr, BlockRay::new(&pr))
                });
                self.test_leaf(start, count, prims, prepared, tmin, sink, counters)
            },
        );
    }

    /// [`Bvh::walk`] of each ray of `rays`, `rays[r]` offering its hits to `sinks[r]`, two
    /// walks interleaved ([`walk_tree_stream`]).
    #[inline(always)]
    pub(super) fn walk_stream<P: Primitives, C: Counters, S: HitSink>(
        &self,
        prims: &P,
        rays: &[Ray],
        sinks: &mut [S],
        counters: &mut C,
    ) {
        // Each walk's ray set up for the triangle tests at its first leaf, as in `walk`.
        let mut prepared: [Option<(PreparedRay, BlockRay)>; 2] = [None; 2];
        let mut prepared_for = [usize::MAX; 2];
        // Where a leaf's slot lies: its first block, or for an indexed leaf its first entry
        // where the leaf names it, else its line of the table of starts (the entries are
        // known only once that is read).
        let (leaves, leaf_bytes): (*const i8, usize) = if !self.indexed {
            (self.blocks.as_ptr().cast(), std::mem::size_of::<Block>())
        } else if self.leaf_starts.is_empty() {
            (self.store.entry_address(0), self.store.entry_bytes())
        } else {
            (self.leaf_starts.as_ptr().cast(), 4)
        };
        walk_tree_stream::<S, C, true>(
            &self.nodes,
            rays,
            sinks,
            counters,
            |w, r, start, count, sink, counters| {
                if prepared_for[w] != r {
                    (prepared_for[w], prepared[w]) = (r, None);
                }
                let p = prepared[w].get_or_insert_with(|| {
                    let pr = PreparedRay::new(&rays[r]);
                    (pr, BlockRay::new(&pr))
                });
                self.test_leaf(start, count, prims, p, rays[r].tmin, sink, counters)
            },
            |start| leaves.wrapping_add(start as usize * leaf_bytes),
        );
    }
}

/// Walks the four-wide tree `nodes` (its root at 0) along `ray`: children nearest first on an
/// explicit stack that remembers each entry's distance, so that entries beyond the sink's
/// `tmax` are dropped unopened. At a leaf, `leaf(start, count, sink, counters)` tests the
/// leaf's `count` slots from `start` of the tree's leaf list and returns `true` to stop the
/// walk. With `VISITS`, every node and leaf opened counts as a cell visit (the bvh's `#vt`);
/// every child box met counts as a box test.
///
/// The bvh's query and the adaptive grid's tree over its grids ([`super::BoxTree`]) are
/// this walk with their own leaves.
#[inline(always)]
pub(crate) fn walk_tree<S: HitSink, C: Counters, const VISITS: bool>(
    nodes: &[Node],
    ray: &Ray,
    sink: &mut S,
    counters: &mut C,
    mut leaf: impl FnMut(usize, usize, &mut S, &mut C) -> bool,
) {
    // Left uninitialised: zeroing its 2 KB was 14–17% of a camera frame's time.
    let mut stack = [const { std::mem::MaybeUninit::uninit() }; STACK];
    let far_first = S::FIRST_ENDS && sink.walks_back();
    let mut walk = TreeWalk::new(ray, far_first, &mut stack);
    while walk.step::<S, C, VISITS>(nodes, sink, counters, &mut leaf, &|_| {}) {}
}

/// [`walk_tree`] of every ray of `rays` (`rays[r]` offering its hits to `sinks[r]`), two
/// walks interleaved step by step, a walk that ends handing its place to the next ray; at a
/// leaf, `leaf(walk, r, start, count, sink, counters)`, `walk` being 0 or 1.
/// `leaf_address(start)` is where the leaf list's slot `start` lies, for the prefetch.
///
/// One ray's walk waits on a dependent load at every step: the node or block it opens next is
/// known only once the step before is done. Two walks depend on no common load, and each
/// step asks the cache for the lines of the entry it opens next ([`fetch_lines`]) before the
/// other walk's step runs, so that one walk's loads are on their way while the other works
/// (software pipelining of a pointer chase). It costs about 17 instructions a step, the two
/// walks' state in memory rather than in registers: incoherent rays 1.1–1.3× faster on the
/// meshes, 1.1× slower on the kitchen, whose nodes stay in the cache (`docs/measurements.md`,
/// "The bvh's walks interleaved").
#[inline(always)]
pub(crate) fn walk_tree_stream<S: HitSink, C: Counters, const VISITS: bool>(
    nodes: &[Node],
    rays: &[Ray],
    sinks: &mut [S],
    counters: &mut C,
    mut leaf: impl FnMut(usize, usize, usize, usize, &mut S, &mut C) -> bool,
    leaf_address: impl Fn(u32) -> *const i8,
) {
    let n = rays.len().min(sinks.len());
    if n < 2 {
        if n == 1 {
            walk_tree::<S, C, VISITS>(nodes, &rays[0], &mut sinks[0], counters, |s, c, sk, ct| {
                leaf(0, 0, s, c, sk, ct)
            });
        }
        return;
    }
    let fetch = |child: u32| {
        let node = nodes.as_ptr().wrapping_add(child as usize).cast::<i8>();
        let leaf = leaf_address(child & ((1 << LEAF_START_BITS) - 1));
        fetch_lines(if child & LEAF != 0 { leaf } else { node });
    };
    let far_first = |sink: &S| S::FIRST_ENDS && sink.walks_back();
    // Left uninitialised, as `walk_tree`'s.
    let mut stacks = [const { std::mem::MaybeUninit::uninit() }; 2 * STACK];
    let (stack_a, stack_b) = stacks.split_at_mut(STACK);
    let (mut a, mut b) = (
        TreeWalk::new(&rays[0], far_first(&sinks[0]), stack_a),
        TreeWalk::new(&rays[1], far_first(&sinks[1]), stack_b),
    );
    let (mut ra, mut rb) = (0, 1);
    let mut next = 2;
    // A step of walk `$walk` (number `$w`, ray `$r`). Spelled out for each walk rather than
    // looped over an array of two: indexed, the walks' state went through memory at every
    // use (twice the instructions this costs).
    macro_rules! step {
        ($walk:ident, $w:literal, $r:ident, $fetch:expr) => {
            $walk.step::<S, C, VISITS>(
                nodes,
                &mut sinks[$r],
                counters,
                &mut |s, c, sk: &mut S, ct: &mut C| leaf($w, $r, s, c, sk, ct),
                $fetch,
            )
        };
    }
    // A step of walk `$walk`; if it ends, the next ray takes its place, or with none left
    // the other walk ends alone, without asking for lines it reads at once.
    macro_rules! turn {
        ($walk:ident, $w:literal, $r:ident, $other:ident, $o:literal, $ro:ident) => {
            if !step!($walk, $w, $r, &fetch) {
                if next == n {
                    while step!($other, $o, $ro, &|_| {}) {}
                    return;
                }
                $r = next;
                next += 1;
                $walk.restart(&rays[$r], far_first(&sinks[$r]));
            }
        };
    }
    loop {
        turn!(a, 0, ra, b, 1, rb);
        turn!(b, 1, rb, a, 0, ra);
    }
}

/// One ray's walk of a four-wide tree ([`walk_tree`]), taken a step at a time.
struct TreeWalk<'s> {
    /// The origin and the inverse direction, each coordinate in every lane of a node's test.
    o: [[f32; WIDTH]; 3],
    inv: [[f32; WIDTH]; 3],
    near_row: [usize; 3],
    far_row: [usize; 3],
    tmin: f32,
    /// Whether the children met are taken farthest first ([`HitSink::walks_back`]).
    far_first: bool,
    stack: &'s mut [std::mem::MaybeUninit<(f32, u32)>],
    top: usize,
    /// The entry being opened: its entry distance and child reference. One child hit is
    /// opened at once; of several, the nearest is, and the others wait on the stack,
    /// farthest deepest.
    current: (f32, u32),
}

impl<'s> TreeWalk<'s> {
    /// The walk's set-up for `ray`, children farthest first if `far_first`, its stack
    /// `stack` (at least [`STACK`] entries).
    #[inline(always)]
    fn new(ray: &Ray, far_first: bool, stack: &'s mut [std::mem::MaybeUninit<(f32, u32)>]) -> Self {
        // Rows of the near and far planes per axis, from the sign bit (so −0 counts as
        // negative and its infinite inverse has the right sign).
        let neg = [
            ray.dir.x.is_sign_negative(),
            ray.dir.y.is_sign_negative(),
            ray.dir.z.is_sign_negative(),
        ];
        TreeWalk {
            o: ray.origin.to_array().map(|x| [x; WIDTH]),
            // As `PreparedRay::inv_dir` computes it.
            inv: (Vec3::ONE / ray.dir).to_array().map(|x| [x; WIDTH]),
            // Spelled out: `[0, 1, 2].map(..)` was left as a call per ray (8% of a camera
            // frame).
            near_row: [
                3 * neg[0] as usize,
                1 + 3 * neg[1] as usize,
                2 + 3 * neg[2] as usize,
            ],
            far_row: [
                3 * !neg[0] as usize,
                1 + 3 * !neg[1] as usize,
                2 + 3 * !neg[2] as usize,
            ],
            tmin: ray.tmin,
            far_first,
            stack,
            top: 0,
            current: (ray.tmin, 0),
        }
    }

    /// The walk of `ray` from the root, on the same stack.
    #[inline(always)]
    fn restart(&mut self, ray: &Ray, far_first: bool) {
        let stack = std::mem::take(&mut self.stack);
        *self = TreeWalk::new(ray, far_first, stack);
    }

    /// Opens the current entry (a node's children hit, a leaf tested, or an entry beyond the
    /// sink's `tmax` dropped) and takes the next one, handing its child reference to `fetch`
    /// (a prefetch, or nothing): `false` when the walk is over, the stack empty or the sink
    /// stopped by a leaf.
    #[inline(always)]
    fn step<S: HitSink, C: Counters, const VISITS: bool>(
        &mut self,
        nodes: &[Node],
        sink: &mut S,
        counters: &mut C,
        leaf: &mut impl FnMut(usize, usize, &mut S, &mut C) -> bool,
        fetch: &impl Fn(u32),
    ) -> bool {
        let (dist, child) = self.current;
        if dist <= sink.tmax() {
            if VISITS {
                counters.cell_visit(0);
            }
            if child & LEAF != 0 {
                let start = (child & ((1 << LEAF_START_BITS) - 1)) as usize;
                let count = ((child & !LEAF) >> LEAF_START_BITS) as usize + 1;
                if leaf(start, count, sink, counters) {
                    return false;
                }
            } else {
                let node = &nodes[child as usize];
                let mut t0 = [self.tmin; WIDTH];
                let mut t1 = [sink.tmax(); WIDTH];
                for a in 0..3 {
                    let (lo, hi) = (
                        &node.bounds[self.near_row[a]],
                        &node.bounds[self.far_row[a]],
                    );
                    for k in 0..WIDTH {
                        // A NaN (0·∞: the ray lies in this face's plane) fails both
                        // comparisons and leaves the interval as it was.
                        let tn = (lo[k] - self.o[a][k]) * self.inv[a][k];
                        let tf = (hi[k] - self.o[a][k]) * self.inv[a][k];
                        t0[k] = if tn > t0[k] { tn } else { t0[k] };
                        t1[k] = if tf < t1[k] { tf } else { t1[k] };
                    }
                }
                // Unused slots have empty boxes and are never hit.
                let mut mask = 0u32;
                for k in 0..WIDTH {
                    mask |= ((t0[k] <= t1[k]) as u32) << k;
                    if node.children[k] != NO_CHILD {
                        counters.box_test(0);
                    }
                }
                if mask != 0 {
                    let k = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    if mask == 0 {
                        self.current = (t0[k], node.children[k]);
                        fetch(self.current.1);
                        return true;
                    }
                    // Several: sorted by entry distance by insertion, the nearest taken first
                    // and the others pushed farthest first; the other way round where
                    // `far_first`.
                    let mut hits = [(0f32, 0u32); WIDTH];
                    hits[0] = (t0[k], node.children[k]);
                    let mut n = 1;
                    while mask != 0 {
                        let k = mask.trailing_zeros() as usize;
                        mask &= mask - 1;
                        let mut i = n;
                        while i > 0
                            && if S::FIRST_ENDS && self.far_first {
                                hits[i - 1].0 > t0[k]
                            } else {
                                hits[i - 1].0 < t0[k]
                            }
                        {
                            hits[i] = hits[i - 1];
                            i -= 1;
                        }
                        hits[i] = (t0[k], node.children[k]);
                        n += 1;
                    }
                    for &h in &hits[..n - 1] {
                        self.stack[self.top].write(h);
                        self.top += 1;
                    }
                    self.current = hits[n - 1];
                    fetch(self.current.1);
                    return true;
                }
            }
        }
        if self.top == 0 {
            return false;
        }
        self.top -= 1;
        // SAFETY: every entry below `top` has been written: `top` grows only by one, right
        // after `stack[top].write` (a bounds-checked index, so no write lands outside; the
        // depth bound behind `STACK` keeps it from panicking).
        self.current = unsafe { self.stack[self.top].assume_init() };
        fetch(self.current.1);
        true
    }
}

/// Asks the cache for the three lines from `p`, so that their loads are on their way while
/// other work runs: they hold a node's 112 bytes, and a block's 160 but for at most 16.
#[inline(always)]
pub(super) fn fetch_lines(p: *const i8) {
    for at in [0, 64, 128] {
        crate::accel::simd::prefetch_line(p.wrapping_add(at));
    }
}
