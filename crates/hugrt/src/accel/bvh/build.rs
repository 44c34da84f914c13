//! The build: a binary tree by binned SAH (or the median where the SAH gives up), its
//! items 32-byte boxes moved in place, large nodes split on both threads.

use super::flatten::{PARALLEL_FLATTEN, four};
use super::{LANES, MEDIAN_DEPTH};
use crate::accel::simd;
use crate::geometry::{Aabb, Vec3};
use glam::Vec4;
/// The binary tree of the build.
pub(super) enum BuildNode {
    Leaf {
        bounds: Aabb,
        start: usize,
        count: usize,
    },
    Inner {
        bounds: Aabb,
        children: Box<[BuildNode; 2]>,
        /// What its flattening takes: so that subtrees can be flattened side by side, each
        /// into its own part of lists made at their final size.
        size: Size,
    },
}

/// Nodes of four and blocks of a flattened subtree.
#[derive(Clone, Copy, Default)]
pub(super) struct Size {
    pub(super) nodes: usize,
    pub(super) blocks: usize,
}

impl BuildNode {
    /// A leaf of `items`, the `first`-th and on of the whole list, sorted by store entry
    /// ([`Builder::decide`]).
    pub(super) fn leaf(items: &[Item], bounds: Aabb, first: usize) -> Self {
        BuildNode::Leaf {
            bounds,
            start: first,
            count: items.len(),
        }
    }

    /// An inner node over `left` and `right`.
    pub(super) fn inner(bounds: Aabb, left: BuildNode, right: BuildNode) -> Self {
        let children = Box::new([left, right]);
        let (kids, n) = four(&children);
        let size = kids[..n].iter().fold(
            Size {
                nodes: 1,
                blocks: 0,
            },
            |a, k| {
                let s = k.size();
                Size {
                    nodes: a.nodes + s.nodes,
                    blocks: a.blocks + s.blocks,
                }
            },
        );
        BuildNode::Inner {
            bounds,
            children,
            size,
        }
    }

    /// The tree's root as a node, which the traversal starts from: a lone leaf gets a node
    /// of one child.
    pub(super) fn rooted(self) -> BuildNode {
        match self {
            leaf @ BuildNode::Leaf { .. } => BuildNode::inner(
                *leaf.bounds(),
                leaf,
                BuildNode::Leaf {
                    bounds: Aabb::EMPTY,
                    start: 0,
                    count: 0,
                },
            ),
            inner => inner,
        }
    }

    /// Frees the subtree, large subtrees side by side (one small allocation a node).
    pub(super) fn drop_in_parallel(self) {
        if let BuildNode::Inner { children, size, .. } = self
            && size.blocks > PARALLEL_FLATTEN
        {
            let [l, r] = *children;
            rayon::join(|| l.drop_in_parallel(), || r.drop_in_parallel());
        }
    }

    pub(super) fn size(&self) -> Size {
        match self {
            BuildNode::Leaf { count, .. } => Size {
                nodes: 0,
                blocks: count.div_ceil(LANES),
            },
            BuildNode::Inner { size, .. } => *size,
        }
    }

    pub(super) fn bounds(&self) -> &Aabb {
        match self {
            BuildNode::Leaf { bounds, .. } | BuildNode::Inner { bounds, .. } => bounds,
        }
    }
}

/// One primitive during the build: its box, with its store entry in the spare lane (32
/// bytes, as Embree's `PrimRef`: a partition moves 32 bytes an item, and its centre is one
/// addition and one halving away).
#[derive(Clone, Copy)]
pub(super) struct Item {
    /// `x, y, z` the box's minimum, `w` the store entry's bits under [`SLOT_EXPONENT`].
    pub(super) lo: Vec4,
    /// `x, y, z` the box's maximum.
    pub(super) hi: Vec4,
}

impl Item {
    pub(super) fn new(slot: u32, b: &Aabb) -> Self {
        Item {
            lo: b.min.extend(f32::from_bits(SLOT_EXPONENT | slot)),
            hi: b.max.extend(0.0),
        }
    }

    pub(super) fn slot(&self) -> u32 {
        self.lo.w.to_bits() & !SLOT_EXPONENT
    }

    pub(super) fn bounds(&self) -> Bounds {
        Bounds {
            lo: self.lo,
            hi: self.hi,
        }
    }

    pub(super) fn aabb(&self) -> Aabb {
        self.bounds().aabb()
    }

    /// The box's centre (`w` meaningless).
    pub(super) fn centre(&self) -> Vec4 {
        (self.lo + self.hi) * 0.5
    }
}

/// Set in an [`Item`]'s spare lane above its store entry (below 2^27, as
/// [`LEAF_START_BITS`] has it), so that the lane holds a normal float: arithmetic on the bits
/// of a small integer, a subnormal float, made the build four times slower.
pub(super) const SLOT_EXPONENT: u32 = 1 << 30;

/// A box during the build as two four-lane vectors, `w` lanes ignored: a union is one
/// `minps` and one `maxps` where [`Aabb`]'s three-lane vectors compile to a compare and a
/// blend per lane (an eighth of a build's time went to those).
#[derive(Clone, Copy)]
pub(super) struct Bounds {
    pub(super) lo: Vec4,
    pub(super) hi: Vec4,
}

impl Bounds {
    pub(super) const EMPTY: Bounds = Bounds {
        lo: Vec4::INFINITY,
        hi: Vec4::NEG_INFINITY,
    };

    pub(super) fn from_aabb(b: &Aabb) -> Self {
        Bounds {
            lo: b.min.extend(0.0),
            hi: b.max.extend(0.0),
        }
    }

    pub(super) fn aabb(&self) -> Aabb {
        Aabb::new(self.lo.truncate(), self.hi.truncate())
    }

    #[must_use]
    pub(super) fn union(&self, o: &Bounds) -> Bounds {
        Bounds {
            lo: self.lo.min(o.lo),
            hi: self.hi.max(o.hi),
        }
    }

    #[must_use]
    pub(super) fn grow(&self, p: Vec4) -> Bounds {
        Bounds {
            lo: self.lo.min(p),
            hi: self.hi.max(p),
        }
    }

    pub(super) fn is_empty(&self) -> bool {
        self.lo.cmple(self.hi).bitmask() & 0b111 != 0b111
    }

    /// As [`Aabb::surface_area`], for a box that is not empty.
    pub(super) fn surface_area(&self) -> f32 {
        let e = self.hi - self.lo;
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }
}

pub(super) struct Builder {
    pub(super) leaf_size: usize,
    pub(super) bins: usize,
    /// Cost of a traversal step relative to one primitive test.
    pub(super) traversal_cost: f32,
}

/// Below this many items, subtrees are built on the current thread.
pub(super) const PARALLEL_ITEMS: usize = 4096;

impl Builder {
    /// Builds the subtree of `items` (the `first`-th and on of the whole array), whose box
    /// and box of centres are `ext` ([`extents`]).
    pub(super) fn build(
        &self,
        items: &mut [Item],
        first: usize,
        depth: usize,
        ext: Extents,
    ) -> BuildNode {
        let bounds = ext.0;
        let Some((mid, left_ext, right_ext)) = self.decide(items, depth, &ext) else {
            return BuildNode::leaf(items, bounds, first);
        };
        let n = items.len();
        let (left, right) = items.split_at_mut(mid);
        let (l, r) = if n > PARALLEL_ITEMS {
            rayon::join(
                || self.build(left, first, depth + 1, left_ext),
                || self.build(right, first + mid, depth + 1, right_ext),
            )
        } else {
            (
                self.build(left, first, depth + 1, left_ext),
                self.build(right, first + mid, depth + 1, right_ext),
            )
        };
        BuildNode::inner(bounds, l, r)
    }

    /// What becomes of a node of `items` at binary depth `depth`, whose [`Extents`] are
    /// `ext`: `None` for a leaf, whose items it sorts by store entry (triangles first, other
    /// kinds in the last lanes, each kind in space order); otherwise the cut, the items
    /// partitioned: how many go left and the extents of both sides.
    pub(super) fn decide(
        &self,
        items: &mut [Item],
        depth: usize,
        ext: &Extents,
    ) -> Option<(usize, Extents, Extents)> {
        let (bounds, centres) = ext;
        let n = items.len();
        let leaf = |items: &mut [Item]| {
            items.sort_unstable_by_key(Item::slot);
            None
        };
        // No split costs less than its traversal step: where that alone is as dear as the
        // leaf (four items or fewer at the default costs), the SAH is not asked (same tree).
        if n <= 1 || n <= self.leaf_size && blocks(n as u32) <= self.traversal_cost {
            return leaf(items);
        }
        let plane = if depth < MEDIAN_DEPTH {
            self.sah_split(items, bounds, centres)
        } else {
            None
        };
        // A leaf when it is small enough and no plane costs less than testing everything
        // (SAH: a test costs 1, a traversal step `traversal_cost`).
        let split = match plane {
            Some((cost, _, _)) if n <= self.leaf_size && cost >= blocks(n as u32) => {
                return leaf(items);
            }
            None if n <= self.leaf_size => return leaf(items),
            Some((_, axis, position)) => partition(items, axis, position),
            None => None,
        };
        Some(split.unwrap_or_else(|| {
            let mid = median(items, centres);
            (mid, extents(&items[..mid]), extents(&items[mid..]))
        }))
    }

    /// The binned SAH's best plane: its cost (in primitive tests, traversal step included),
    /// axis and position; `None` when the centres do not spread.
    pub(super) fn sah_split(
        &self,
        items: &[Item],
        bounds: &Aabb,
        centres: &Aabb,
    ) -> Option<(f32, usize, f32)> {
        let extent = centres.extent();
        let area = bounds.surface_area();
        if area.is_nan() || area <= 0.0 {
            return None;
        }
        let nb = bins_for(self.bins, items.len());
        let scale = Vec3::splat(nb as f32) / extent;
        // One pass over the items fills the bins of all three axes; large nodes bin in
        // parallel chunks whose bins are then merged.
        let (low, scale) = (centres.min.extend(0.0), scale.extend(0.0));
        let last = Vec4::splat((nb - 1) as f32);
        let put = |bins: &mut Bins, it: &Item| {
            // NaN (an axis of no extent: 0·∞) and overflow clamp into the bins (`maxps`
            // answers its second operand for a NaN).
            let k = ((it.centre() - low) * scale).max(Vec4::ZERO).min(last);
            let k = simd::truncate_lanes(k);
            let b = it.bounds();
            for (axis, &x) in k.iter().take(3).enumerate() {
                bins.add(axis * nb + x as usize, &b);
            }
        };
        // Neighbouring items tend to fall in the same bins (the store is in Morton order), so
        // each would wait for the last one's stores to its bin: even and odd items fill
        // separate bins, merged at the end, which halves those chains of waiting.
        let fill = |bins: &mut Bins, odd: &mut Bins, chunk: &[Item]| {
            if chunk.len() < PAIRED_BINNING {
                chunk.iter().for_each(|it| put(bins, it));
                return;
            }
            odd.reset(nb);
            let pairs = chunk.chunks_exact(2);
            if let [last] = pairs.remainder() {
                put(bins, last);
            }
            for pair in pairs {
                put(bins, &pair[0]);
                put(odd, &pair[1]);
            }
            bins.absorb(odd);
        };
        let choose = |bins: &Bins| {
            let mut best: Option<(f32, usize, f32)> = None;
            for axis in 0..3 {
                if extent[axis].is_nan() || extent[axis] <= 0.0 {
                    continue;
                }
                let boxes = &bins.boxes[axis * nb..(axis + 1) * nb];
                let counts = &bins.counts[axis * nb..(axis + 1) * nb];
                if let Some((cost, b)) = cheapest_plane(boxes, counts, counts)
                    && best.is_none_or(|(c, _, _)| cost < c)
                {
                    best = Some((cost, axis, centres.min[axis] + b as f32 / scale[axis]));
                }
            }
            best
        };
        let best = if items.len() > PARALLEL_BINNING {
            use rayon::prelude::*;
            let bins = items
                .par_chunks(PARALLEL_BINNING / 4)
                .map(|chunk| {
                    let (mut bins, mut odd) = (Bins::new(nb), Bins::new(nb));
                    fill(&mut bins, &mut odd, chunk);
                    bins
                })
                .reduce(|| Bins::new(nb), |a, b| a.merge(&b));
            choose(&bins)
        } else {
            // No rayon call inside, so no other node's binning runs on this thread meanwhile.
            SCRATCH.with_borrow_mut(|[bins, odd]| {
                bins.reset(nb);
                fill(bins, odd, items);
                choose(bins)
            })
        };
        best.map(|(cost, axis, position)| (self.traversal_cost + cost / area, axis, position))
    }
}

/// Bins per axis for a node of `n` items: `4 + n/20`, at most `bins`. Most nodes are small,
/// and a node's cost beside its items' is its bins (reset, swept and costed on three axes):
/// with `min(bins, n)`, sweeping them (`cheapest_plane`) was 15% of the terrain's build. The
/// rule is Embree's binned builder's. The trees came out no worse: the same hits, and on 1M
/// incoherent rays 0.95–1.0× the triangle tests a ray on the bunny, nefertiti, the city, the
/// terrain and the stadium, 0.8× on the kitchen, the same box tests ±1%
/// (`docs/measurements.md`).
pub(super) fn bins_for(bins: usize, n: usize) -> usize {
    bins.min(4 + n / 20).max(2)
}

/// The SAH's cheapest plane between bins (sum of each side's area times its [`blocks`]) and
/// the first bin right of it. `entries[b]` counts the references whose first bin is `b`,
/// `exits[b]` those whose last is: for an object split both are the bins' counts.
pub(super) fn cheapest_plane(
    boxes: &[Bounds],
    entries: &[u32],
    exits: &[u32],
) -> Option<(f32, usize)> {
    let nb = boxes.len();
    // Area and count of the bins right of each plane, swept from the right.
    let mut right_area = [0f32; MAX_BINS];
    let mut right_count = [0u32; MAX_BINS];
    let (mut acc, mut cnt) = (Bounds::EMPTY, 0);
    for b in (1..nb).rev() {
        acc = acc.union(&boxes[b]);
        cnt += exits[b];
        right_area[b] = if acc.is_empty() {
            0.0
        } else {
            acc.surface_area()
        };
        right_count[b] = cnt;
    }
    let mut best: Option<(f32, usize)> = None;
    let (mut acc, mut cnt) = (Bounds::EMPTY, 0);
    for b in 1..nb {
        acc = acc.union(&boxes[b - 1]);
        cnt += entries[b - 1];
        // (A cut reference may leave a bin with a count and no piece.)
        if cnt == 0 || right_count[b] == 0 || acc.is_empty() {
            continue;
        }
        let cost = acc.surface_area() * blocks(cnt) + right_area[b] * blocks(right_count[b]);
        if best.is_none_or(|(c, _)| cost < c) {
            best = Some((cost, b));
        }
    }
    best
}

/// The SAH's cost of testing `n` primitives: a block of [`LANES`] costs one test, whether full
/// or not, so leaves fill their blocks where the surface areas allow.
pub(super) fn blocks(n: u32) -> f32 {
    n.div_ceil(LANES as u32) as f32
}

/// The box of some items and the box of their centres.
pub(super) type Extents = (Aabb, Aabb);

/// The [`Extents`] of the items (in parallel for large nodes).
pub(super) fn extents(items: &[Item]) -> Extents {
    let fold = |(b, c): (Bounds, Bounds), it: &Item| (b.union(&it.bounds()), c.grow(it.centre()));
    let empty = (Bounds::EMPTY, Bounds::EMPTY);
    let (b, c) = if items.len() > PARALLEL_BINNING {
        use rayon::prelude::*;
        items
            .par_iter()
            .fold(|| empty, fold)
            .reduce(|| empty, |a, b| (a.0.union(&b.0), a.1.union(&b.1)))
    } else {
        items.iter().fold(empty, fold)
    };
    (b.aabb(), c.aabb())
}

/// Most bins per axis (the `bins` key's upper bound).
pub(super) const MAX_BINS: usize = 32;

/// Nodes of fewer items bin in one set of bins (see `sah_split`).
pub(super) const PAIRED_BINNING: usize = 64;

/// Nodes of more items bin in parallel.
pub(super) const PARALLEL_BINNING: usize = 1 << 16;

/// Slots of [`Bins`]: a power of two of at least `3 · MAX_BINS`, so that a bin's index masked
/// by `BIN_SLOTS - 1` needs no bounds check in the binning's inner loop (the checks were a
/// sixth of the binning's instructions).
const BIN_SLOTS: usize = 128;
const _: () = assert!(BIN_SLOTS.is_power_of_two() && BIN_SLOTS >= 3 * MAX_BINS);

/// The boxes and counts of the bins of the three axes, axis after axis: the first `3 · len`
/// slots.
pub(super) struct Bins {
    pub(super) boxes: [Bounds; BIN_SLOTS],
    pub(super) counts: [u32; BIN_SLOTS],
    len: usize,
}

thread_local! {
    /// Each thread's bins (and odd items' bins) for the nodes it bins alone: a node's binning
    /// allocated them afresh, and most nodes are small, so the allocations took a twentieth
    /// of a build.
    static SCRATCH: std::cell::RefCell<[Bins; 2]> = const {
        std::cell::RefCell::new([Bins::EMPTY, Bins::EMPTY])
    };
}

impl Bins {
    pub(super) const EMPTY: Bins = Bins {
        boxes: [Bounds::EMPTY; BIN_SLOTS],
        counts: [0; BIN_SLOTS],
        len: 0,
    };

    pub(super) fn new(bins: usize) -> Self {
        let mut b = Bins::EMPTY;
        b.len = bins;
        b
    }

    /// Empty bins, `bins` per axis.
    pub(super) fn reset(&mut self, bins: usize) {
        self.len = bins;
        self.boxes[..3 * bins].fill(Bounds::EMPTY);
        self.counts[..3 * bins].fill(0);
    }

    /// Adds `b` to slot `k` (`axis · bins + bin`).
    #[inline(always)]
    pub(super) fn add(&mut self, k: usize, b: &Bounds) {
        let k = k & (BIN_SLOTS - 1);
        self.boxes[k] = self.boxes[k].union(b);
        self.counts[k] += 1;
    }

    pub(super) fn merge(mut self, o: &Bins) -> Bins {
        self.absorb(o);
        self
    }

    pub(super) fn absorb(&mut self, o: &Bins) {
        let n = 3 * self.len;
        for (a, b) in self.boxes[..n].iter_mut().zip(&o.boxes[..n]) {
            *a = a.union(b);
        }
        for (a, b) in self.counts[..n].iter_mut().zip(&o.counts[..n]) {
            *a += b;
        }
    }
}

/// Moves the items whose centre lies before `position` on `axis` to the front; returns how
/// many there are and the extents of both sides, gathered in the same pass, or `None` when a
/// side is empty.
pub(super) fn partition(
    items: &mut [Item],
    axis: usize,
    position: f32,
) -> Option<(usize, Extents, Extents)> {
    // One loop per axis: the axis chosen inside the loop was a branch per item.
    match axis {
        0 => partition_on::<0>(items, position),
        1 => partition_on::<1>(items, position),
        _ => partition_on::<2>(items, position),
    }
}

/// [`partition`] on axis `AXIS`.
fn partition_on<const AXIS: usize>(
    items: &mut [Item],
    position: f32,
) -> Option<(usize, Extents, Extents)> {
    let mut left = (Bounds::EMPTY, Bounds::EMPTY);
    let mut right = (Bounds::EMPTY, Bounds::EMPTY);
    let mut i = 0;
    for j in 0..items.len() {
        let it = items[j];
        let c = it.centre();
        if c[AXIS] < position {
            left = (left.0.union(&it.bounds()), left.1.grow(c));
            // The swap of `i` and `j`, with item `j` already at hand.
            items[j] = items[i];
            items[i] = it;
            i += 1;
        } else {
            right = (right.0.union(&it.bounds()), right.1.grow(c));
        }
    }
    let aabbs = |(b, c): (Bounds, Bounds)| (b.aabb(), c.aabb());
    (i > 0 && i < items.len()).then_some((i, aabbs(left), aabbs(right)))
}

/// Splits at the median of the centres along their widest axis (ties by store entry, so the
/// result does not depend on the order the items arrived in).
pub(super) fn median(items: &mut [Item], centres: &Aabb) -> usize {
    let e = centres.extent();
    let axis = if e.x >= e.y && e.x >= e.z {
        0
    } else if e.y >= e.z {
        1
    } else {
        2
    };
    let mid = items.len() / 2;
    items.select_nth_unstable_by(mid, |a, b| {
        a.centre()[axis]
            .total_cmp(&b.centre()[axis])
            .then(a.slot().cmp(&b.slot()))
    });
    mid
}
