//! Bounding volume hierarchy, four children per node (Havran §3.4 names the BVH; its modern
//! form is the one Embree and every production renderer use):
//!
//! * Build: a binary tree by binned surface-area heuristic (Wald, "On fast construction of
//!   SAH-based bounding volume hierarchies", 2007) over the primitives' box centres, `bins`
//!   bins per axis, subtrees built in parallel, on 32-byte items and four-lane boxes (as
//!   Embree's `PrimRef`); then collapsed to four children per node by opening, again and
//!   again, the child of largest surface area, large subtrees flattened side by side into
//!   lists made at their final size. A leaf's cost is its number
//!   of blocks of four, full or not (as Embree counts its four-triangle leaves), so leaves
//!   fill their blocks where the areas allow. With `spatial` above 0, nodes may instead cut
//!   space and share a straddling triangle between both sides (SBVH, [`spatial`]).
//! * Nodes hold their four children's boxes as six rows of four lanes, so one ray meets all
//!   four boxes in one pass of lane-wise arithmetic that the compiler turns into SIMD on every
//!   target (no `unsafe`); leaves hold up to `leaf` primitives as [`Block`]s of four
//!   triangles, side by side, tested together (SSE), in the leaves' order in memory: no
//!   reference to follow and no store entry to fetch. Spheres, cones and other primitives
//!   sit in the blocks' last lanes by store entry and are tested through the store
//!   ([`PrimStore`]), which gives up its own triangles once the blocks hold them.
//! * Traversal: children nearest first on an explicit stack that remembers each entry's
//!   distance, so that entries beyond the nearest hit found are dropped unopened; any-hit
//!   returns at the first hit.
//!
//! Exactness: a primitive lies in one leaf, whose box holds its box widened by [`MARGIN`], an
//! absolute slack of 64 ulps of the scene's magnitude that covers the slab test's rounding
//! (Ize's `1 + 2γ₃` on far distances, "Robust BVH Ray Traversal", JCGT 2013, is then needed by
//! no test and left out) and the triangle test's. The slab test picks each axis's near and far
//! planes from the direction's sign bit; a ray lying in a box's face plane (0·∞ = NaN on that
//! axis) leaves the interval as it was, so it counts as inside.

mod spatial;

use super::block::{self, Block, BlockRay, EMPTY_LANE, LANES};
use super::settings::{Key, Settings, key};
use super::store::{PrimStore, finite};
use super::{Accel, CellCensus, Counters, HitSink, Primitives, SpecError, StructureStats};
use crate::geometry::{Aabb, PreparedRay, Ray, Vec3, intersect_triangle};
use glam::Vec4;
use spatial::SpatialContext;

/// Every primitive's box is widened by this fraction of the scene's magnitude (64 ulps of
/// it), as the grids' cells are (`hierarchy`): a box's entry distance then lies before any hit
/// inside it despite the rounding of both, so a box is never skipped for lying beyond a hit
/// at the same distance. `tests/agree.rs` (coplanar, axis-aligned triangles) fails without.
const MARGIN: f32 = 1.0 / (1 << 17) as f32;

/// Set in a block lane's id when the lane holds no triangle but the store entry (the other
/// bits) of a sphere, cone or opaque primitive, tested through the store.
const OTHER_LANE: u32 = 1 << 31;

/// Children per node.
const WIDTH: usize = 4;

/// Binary-tree depth after which splits are at the object median: the depth of the tree stays
/// below `MEDIAN_DEPTH + log2(n)` whatever the scene, which bounds the traversal stack.
const MEDIAN_DEPTH: usize = 48;

/// Stack entries a query can need: at most `WIDTH − 1` pushed per level and a level per
/// binary level, `MEDIAN_DEPTH + 32` for `n < 2^32`.
const STACK: usize = (WIDTH - 1) * (MEDIAN_DEPTH + 33) + 1;

/// Child reference: a node index, or with `LEAF` set a leaf (its first [`Block`] in the low
/// 27 bits, its number of blocks `− 1` in the next 4).
const LEAF: u32 = 1 << 31;
const LEAF_START_BITS: u32 = 27;
const MAX_LEAF: usize = 16;
/// An unused child slot; its box is empty, so no ray reaches it.
const NO_CHILD: u32 = u32::MAX;

/// Four children: their boxes as rows `min x, min y, min z, max x, max y, max z` of four lanes.
#[derive(Clone, Copy)]
#[repr(C, align(16))]
struct Node {
    bounds: [[f32; WIDTH]; 6],
    children: [u32; WIDTH],
}

impl Node {
    /// No children: every box empty, so no ray reaches a slot.
    const EMPTY: Node = Node {
        bounds: [
            [f32::INFINITY; WIDTH],
            [f32::INFINITY; WIDTH],
            [f32::INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
        ],
        children: [NO_CHILD; WIDTH],
    };
}

/// The bvh's settings (`bvh:leaf=..,bins=..,traversal=..,spatial=..`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BvhSettings {
    /// Most primitives a leaf holds when the SAH does not split it (at most 16).
    pub leaf: usize,
    /// SAH bins per axis (2 to 32).
    pub bins: usize,
    /// Cost of a traversal step relative to a block test, for the SAH.
    pub traversal: f32,
    /// Spatial splits (SBVH): extra references allowed, as a fraction of the primitives;
    /// 0 for none.
    pub spatial: f32,
}

impl Default for BvhSettings {
    fn default() -> Self {
        BvhSettings {
            leaf: 8,
            bins: 16,
            traversal: 1.0,
            spatial: 0.0,
        }
    }
}

impl Settings for BvhSettings {
    const KEYS: &'static [Key<Self>] = &[
        key!("leaf", leaf: usize, 1..=MAX_LEAF, "most primitives a leaf holds when the SAH does not split it"),
        key!("bins", bins: usize, 2..=MAX_BINS, "SAH bins per axis"),
        key!("traversal", traversal: f32, 0.0..=100.0, "cost of a traversal step relative to a block test, for the SAH"),
        key!("spatial", spatial: f32, 0.0..=4.0, "spatial splits (SBVH): extra references allowed, as a fraction of the primitives (0: none)"),
    ];
}

pub struct Bvh {
    nodes: Vec<Node>,
    /// The leaves' primitives, leaf after leaf, in blocks of [`LANES`]; a leaf's triangles
    /// first.
    blocks: Vec<Block>,
    /// Primitives in the blocks (lanes not empty).
    filled: usize,
    /// The primitives that are not triangles, which blocks name by store entry (the store's
    /// own triangles are released once the blocks hold them).
    store: PrimStore,
    /// Whether there are any such primitives.
    others: bool,
    leaf_size: usize,
    bins: usize,
    spatial: f32,
    stats: TreeStats,
}

#[derive(Clone, Copy, Default)]
struct TreeStats {
    leaves: usize,
    max_depth: usize,
    /// Sum of the leaves' depths (for the mean).
    depth_sum: usize,
    leaf_volume: f64,
}

impl TreeStats {
    /// Adds the statistics of other leaves.
    fn add(&mut self, o: &TreeStats) {
        self.leaves += o.leaves;
        self.max_depth = self.max_depth.max(o.max_depth);
        self.depth_sum += o.depth_sum;
        self.leaf_volume += o.leaf_volume;
    }
}

/// The binary tree of the build.
enum BuildNode {
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
struct Size {
    nodes: usize,
    blocks: usize,
}

impl BuildNode {
    /// A leaf of `items`, the `first`-th and on of the whole list, which it sorts by store
    /// entry: triangles first (other kinds go in the last lanes), each kind in space order.
    /// Sorted here, where the work is shared between threads, rather than in [`flatten`].
    fn leaf(items: &mut [Item], bounds: Aabb, first: usize) -> Self {
        items.sort_unstable_by_key(Item::slot);
        BuildNode::Leaf {
            bounds,
            start: first,
            count: items.len(),
        }
    }

    /// An inner node over `left` and `right`.
    fn inner(bounds: Aabb, left: BuildNode, right: BuildNode) -> Self {
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

    /// Frees the subtree, large subtrees side by side (one small allocation a node).
    fn drop_in_parallel(self) {
        if let BuildNode::Inner { children, size, .. } = self
            && size.blocks > PARALLEL_FLATTEN
        {
            let [l, r] = *children;
            rayon::join(|| l.drop_in_parallel(), || r.drop_in_parallel());
        }
    }

    fn size(&self) -> Size {
        match self {
            BuildNode::Leaf { count, .. } => Size {
                nodes: 0,
                blocks: count.div_ceil(LANES),
            },
            BuildNode::Inner { size, .. } => *size,
        }
    }

    fn bounds(&self) -> &Aabb {
        match self {
            BuildNode::Leaf { bounds, .. } | BuildNode::Inner { bounds, .. } => bounds,
        }
    }
}

/// The children of a node of four made from a binary node: its two children, then again and
/// again the inner one of largest area (the last of equals) opened, until there are four or
/// only leaves. Returns them and their number. The one opened gives its lane to the last
/// child and its own two take the last lanes: the traversal visits children whose entry
/// distances tie from the last lane down, and this order measured faster than putting the
/// two in the opened one's place (×0.84–0.99 there: bunny, gen-kitchen, gen-building).
fn four(children: &[BuildNode; 2]) -> ([&BuildNode; WIDTH], usize) {
    let mut kids = [&children[0]; WIDTH];
    kids[1] = &children[1];
    let mut n = 2;
    while n < WIDTH {
        let mut open = None;
        let mut widest = f32::NEG_INFINITY;
        for (i, k) in kids[..n].iter().enumerate() {
            if let BuildNode::Inner { bounds, .. } = k {
                let area = bounds.surface_area();
                if open.is_none() || area >= widest {
                    (open, widest) = (Some(i), area);
                }
            }
        }
        let Some(i) = open else { break };
        let BuildNode::Inner { children, .. } = kids[i] else {
            unreachable!("only inner nodes are opened")
        };
        kids[i] = kids[n - 1];
        kids[n - 1] = &children[0];
        kids[n] = &children[1];
        n += 1;
    }
    (kids, n)
}

/// One primitive during the build: its box, with its store entry in the spare lane (32
/// bytes, as Embree's `PrimRef`: a partition moves 32 bytes an item, and its centre is one
/// addition and one halving away).
#[derive(Clone, Copy)]
struct Item {
    /// `x, y, z` the box's minimum, `w` the store entry's bits under [`SLOT_EXPONENT`].
    lo: Vec4,
    /// `x, y, z` the box's maximum.
    hi: Vec4,
}

impl Item {
    fn new(slot: u32, b: &Aabb) -> Self {
        Item {
            lo: b.min.extend(f32::from_bits(SLOT_EXPONENT | slot)),
            hi: b.max.extend(0.0),
        }
    }

    fn slot(&self) -> u32 {
        self.lo.w.to_bits() & !SLOT_EXPONENT
    }

    fn bounds(&self) -> Bounds {
        Bounds {
            lo: self.lo,
            hi: self.hi,
        }
    }

    fn aabb(&self) -> Aabb {
        self.bounds().aabb()
    }

    /// The box's centre (`w` meaningless).
    fn centre(&self) -> Vec4 {
        (self.lo + self.hi) * 0.5
    }
}

/// Set in an [`Item`]'s spare lane above its store entry (below 2^27, as
/// [`LEAF_START_BITS`] has it), so that the lane holds a normal float: arithmetic on the bits
/// of a small integer, a subnormal float, made the build four times slower.
const SLOT_EXPONENT: u32 = 1 << 30;

/// A box during the build as two four-lane vectors, `w` lanes ignored: a union is one
/// `minps` and one `maxps` where [`Aabb`]'s three-lane vectors compile to a compare and a
/// blend per lane (an eighth of a build's time went to those).
#[derive(Clone, Copy)]
struct Bounds {
    lo: Vec4,
    hi: Vec4,
}

impl Bounds {
    const EMPTY: Bounds = Bounds {
        lo: Vec4::INFINITY,
        hi: Vec4::NEG_INFINITY,
    };

    fn from_aabb(b: &Aabb) -> Self {
        Bounds {
            lo: b.min.extend(0.0),
            hi: b.max.extend(0.0),
        }
    }

    fn aabb(&self) -> Aabb {
        Aabb::new(self.lo.truncate(), self.hi.truncate())
    }

    #[must_use]
    fn union(&self, o: &Bounds) -> Bounds {
        Bounds {
            lo: self.lo.min(o.lo),
            hi: self.hi.max(o.hi),
        }
    }

    #[must_use]
    fn grow(&self, p: Vec4) -> Bounds {
        Bounds {
            lo: self.lo.min(p),
            hi: self.hi.max(p),
        }
    }

    fn is_empty(&self) -> bool {
        self.lo.cmple(self.hi).bitmask() & 0b111 != 0b111
    }

    /// As [`Aabb::surface_area`], for a box that is not empty.
    fn surface_area(&self) -> f32 {
        let e = self.hi - self.lo;
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }
}

struct Builder {
    leaf_size: usize,
    bins: usize,
    /// Cost of a traversal step relative to one primitive test.
    traversal_cost: f32,
}

/// Below this many items, subtrees are built on the current thread.
const PARALLEL_ITEMS: usize = 4096;

impl Builder {
    /// Builds the subtree of `items` (the `first`-th and on of the whole array), whose box
    /// and box of centres are `ext` ([`extents`]).
    fn build(&self, items: &mut [Item], first: usize, depth: usize, ext: Extents) -> BuildNode {
        let (bounds, centres) = ext;
        let n = items.len();
        let leaf = |items: &mut [Item]| BuildNode::leaf(items, bounds, first);
        // No split costs less than its traversal step: where that alone is as dear as the
        // leaf (four items or fewer at the default costs), the SAH is not asked (same tree).
        if n <= 1 || n <= self.leaf_size && blocks(n as u32) <= self.traversal_cost {
            return leaf(items);
        }
        let plane = if depth < MEDIAN_DEPTH {
            self.sah_split(items, &bounds, &centres)
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
        let (mid, left_ext, right_ext) = split.unwrap_or_else(|| {
            let mid = median(items, &centres);
            (mid, extents(&items[..mid]), extents(&items[mid..]))
        });
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

    /// The binned SAH's best plane: its cost (in primitive tests, traversal step included),
    /// axis and position; `None` when the centres do not spread.
    fn sah_split(
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
        // No more bins than items: small nodes, which are most nodes, bin cheaply.
        let nb = self.bins.min(items.len()).max(2);
        let scale = Vec3::splat(nb as f32) / extent;
        // One pass over the items fills the bins of all three axes; large nodes bin in
        // parallel chunks whose bins are then merged.
        let (low, scale) = (centres.min.extend(0.0), scale.extend(0.0));
        let last = Vec4::splat((nb - 1) as f32);
        let put = |bins: &mut Bins, it: &Item| {
            // NaN (an axis of no extent: 0·∞) and overflow clamp into the bins (`maxps`
            // answers its second operand for a NaN).
            let k = ((it.centre() - low) * scale).max(Vec4::ZERO).min(last);
            let b = it.bounds();
            for (axis, x) in k.to_array().into_iter().take(3).enumerate() {
                let k = axis * nb + x as i32 as usize;
                bins.boxes[k] = bins.boxes[k].union(&b);
                bins.counts[k] += 1;
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

/// The SAH's cheapest plane between bins (sum of each side's area times its [`blocks`]) and
/// the first bin right of it. `entries[b]` counts the references whose first bin is `b`,
/// `exits[b]` those whose last is: for an object split both are the bins' counts.
fn cheapest_plane(boxes: &[Bounds], entries: &[u32], exits: &[u32]) -> Option<(f32, usize)> {
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
fn blocks(n: u32) -> f32 {
    n.div_ceil(LANES as u32) as f32
}

/// The box of some items and the box of their centres.
type Extents = (Aabb, Aabb);

/// The [`Extents`] of the items (in parallel for large nodes).
fn extents(items: &[Item]) -> Extents {
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
const MAX_BINS: usize = 32;

/// Nodes of fewer items bin in one set of bins (see `sah_split`).
const PAIRED_BINNING: usize = 64;

/// Nodes of more items bin in parallel.
const PARALLEL_BINNING: usize = 1 << 16;

/// The boxes and counts of the bins of the three axes, axis after axis.
struct Bins {
    boxes: Vec<Bounds>,
    counts: Vec<u32>,
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
    const EMPTY: Bins = Bins {
        boxes: Vec::new(),
        counts: Vec::new(),
    };

    fn new(bins: usize) -> Self {
        Bins {
            boxes: vec![Bounds::EMPTY; 3 * bins],
            counts: vec![0; 3 * bins],
        }
    }

    /// Empty bins, `bins` per axis, in the space these had.
    fn reset(&mut self, bins: usize) {
        self.boxes.clear();
        self.boxes.resize(3 * bins, Bounds::EMPTY);
        self.counts.clear();
        self.counts.resize(3 * bins, 0);
    }

    fn merge(mut self, o: &Bins) -> Bins {
        self.absorb(o);
        self
    }

    fn absorb(&mut self, o: &Bins) {
        for (a, b) in self.boxes.iter_mut().zip(&o.boxes) {
            *a = a.union(b);
        }
        for (a, b) in self.counts.iter_mut().zip(&o.counts) {
            *a += b;
        }
    }
}

/// Moves the items whose centre lies before `position` on `axis` to the front; returns how
/// many there are and the extents of both sides, gathered in the same pass, or `None` when a
/// side is empty.
fn partition(items: &mut [Item], axis: usize, position: f32) -> Option<(usize, Extents, Extents)> {
    let mut left = (Bounds::EMPTY, Bounds::EMPTY);
    let mut right = (Bounds::EMPTY, Bounds::EMPTY);
    let mut i = 0;
    for j in 0..items.len() {
        let it = items[j];
        let c = it.centre();
        if c[axis] < position {
            left = (left.0.union(&it.bounds()), left.1.grow(c));
            items.swap(i, j);
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
fn median(items: &mut [Item], centres: &Aabb) -> usize {
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

/// Subtrees of more blocks than this are flattened in parallel.
const PARALLEL_FLATTEN: usize = 1 << 10;

/// What flattening a subtree counted: lanes filled and the leaves' statistics.
#[derive(Default)]
struct Flattened {
    filled: usize,
    stats: TreeStats,
}

impl Flattened {
    fn add(mut self, o: Flattened) -> Flattened {
        self.filled += o.filled;
        self.stats.add(&o.stats);
        self
    }
}

/// A node's part of the lists: its own nodes and blocks, and where they start in the whole.
struct Part<'a> {
    nodes: &'a mut [Node],
    node_base: usize,
    blocks: &'a mut [Block],
    block_base: usize,
}

/// Flattens `node` into `part` (of exactly its [`BuildNode::size`]): nodes of four, depth first
/// (a node, then each child's subtree in turn), the leaves' blocks in the same order; returns
/// its child reference. Children whose subtrees are large are flattened side by side, each in
/// its own part: the layout is the one flattening them in turn would give.
fn flatten(
    store: &PrimStore,
    node: &BuildNode,
    items: &[Item],
    depth: usize,
    part: Part,
) -> (u32, Flattened) {
    match node {
        BuildNode::Leaf { count: 0, .. } => (NO_CHILD, Flattened::default()),
        &BuildNode::Leaf {
            bounds,
            start,
            count,
        } => {
            // In store order ([`BuildNode::leaf`]).
            for (block, lanes) in part
                .blocks
                .iter_mut()
                .zip(items[start..start + count].chunks(LANES))
            {
                for (l, it) in lanes.iter().enumerate() {
                    let s = it.slot();
                    match store.triangle(s) {
                        Some(t) => block.set(l, t, store.id(s)),
                        None => block.ids[l] = OTHER_LANE | s,
                    }
                }
            }
            let stats = TreeStats {
                leaves: 1,
                max_depth: depth,
                depth_sum: depth,
                leaf_volume: if bounds.is_empty() {
                    0.0
                } else {
                    bounds.volume() as f64
                },
            };
            let blocks = count.div_ceil(LANES) as u32;
            let r = LEAF | ((blocks - 1) << LEAF_START_BITS) | part.block_base as u32;
            (
                r,
                Flattened {
                    filled: count,
                    stats,
                },
            )
        }
        BuildNode::Inner { children, size, .. } => {
            let (kids, n) = four(children);
            let (own, mut nodes) = part.nodes.split_first_mut().expect("sized for its node");
            let mut blocks = part.blocks;
            let (mut node_base, mut block_base) = (part.node_base + 1, part.block_base);
            let mut parts: [Option<(&BuildNode, Part)>; WIDTH] = Default::default();
            for (slot, k) in parts.iter_mut().zip(&kids[..n]) {
                let s = k.size();
                let (kn, rest) = std::mem::take(&mut nodes).split_at_mut(s.nodes);
                let (kb, rest_b) = std::mem::take(&mut blocks).split_at_mut(s.blocks);
                (nodes, blocks) = (rest, rest_b);
                *slot = Some((
                    *k,
                    Part {
                        nodes: kn,
                        node_base,
                        blocks: kb,
                        block_base,
                    },
                ));
                node_base += s.nodes;
                block_base += s.blocks;
            }
            let mut refs: [(u32, Flattened); WIDTH] = Default::default();
            let parts = parts.into_iter().flatten();
            if size.blocks > PARALLEL_FLATTEN {
                rayon::scope(|scope| {
                    for (r, (k, p)) in refs.iter_mut().zip(parts) {
                        scope.spawn(move |_| *r = flatten(store, k, items, depth + 1, p));
                    }
                });
            } else {
                for (r, (k, p)) in refs.iter_mut().zip(parts) {
                    *r = flatten(store, k, items, depth + 1, p);
                }
            }
            let mut counted = Flattened::default();
            for (lane, (k, (r, f))) in kids[..n].iter().zip(refs).enumerate() {
                counted = counted.add(f);
                if r == NO_CHILD {
                    continue;
                }
                let b = k.bounds();
                for a in 0..3 {
                    own.bounds[a][lane] = b.min[a];
                    own.bounds[3 + a][lane] = b.max[a];
                }
                own.children[lane] = r;
            }
            (part.node_base as u32, counted)
        }
    }
}

impl Bvh {
    /// Bytes of the nodes and leaf references, without the store.
    fn structure_bytes(&self) -> usize {
        self.nodes.capacity() * std::mem::size_of::<Node>()
            + self.blocks.capacity() * std::mem::size_of::<Block>()
    }

    /// Tests the four primitives of `b`: the triangles together ([`block::lanes`], the scalar
    /// test's bits lane by lane), the lanes it hands back and the lanes of other primitives
    /// one at a time. Returns `true` when the sink stops the walk.
    ///
    /// Lanes pass or fail against the nearest hit as it was when the block began, then offer
    /// their hits in lane order: the nearest of them is the one a test one at a time would
    /// keep, and a tie goes to the lower index either way.
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
        let lanes = block::lanes(b, bray, tmin, sink.tmax());
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
        // Lanes of other primitives have NaN vertices: they neither pass nor need redoing.
        let (pass, t) = (lanes.pass, lanes.t);
        let mut todo = pass | lanes.redo | others;
        while todo != 0 {
            let l = todo.trailing_zeros() as usize;
            todo &= todo - 1;
            let id = b.ids[l];
            let (hit, prim) = if pass >> l & 1 != 0 {
                (Some(t[l]), id)
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
}

impl Accel for Bvh {
    const NAME: &'static str = "bvh";
    type Settings = BvhSettings;

    fn build_checked<P: Primitives>(prims: &P, settings: &BvhSettings) -> Result<Self, SpecError> {
        let BvhSettings {
            leaf: leaf_size,
            bins,
            traversal: traversal_cost,
            spatial,
        } = *settings;
        let n = prims.len();
        let budget = (spatial as f64 * n as f64) as usize;
        if n + budget >= 1 << LEAF_START_BITS {
            return Err(SpecError::Build(format!(
                "{n} primitives and {budget} extra references: the bvh holds at most 2^27-1"
            )));
        }
        let store = PrimStore::build(prims);
        use rayon::prelude::*;
        let mut items: Vec<Item> = (0..store.len() as u32)
            .into_par_iter()
            .map(|s| Item::new(s, &store.bounds(prims, s)))
            .collect();
        // Primitives with a NaN or infinite coordinate are in no leaf: no finite ray hits them.
        if !items.par_iter().all(|it| finite(&it.aabb())) {
            items.retain(|it| finite(&it.aabb()));
        }
        let scene = extents(&items).0;
        let margin = if scene.is_empty() {
            0.0
        } else {
            scene.magnitude().max(scene.extent().max_element()) * MARGIN
        };
        let widen = Vec4::new(margin, margin, margin, 0.0);
        items.par_iter_mut().for_each(|it| {
            it.lo -= widen;
            it.hi += widen;
        });
        let builder = Builder {
            leaf_size,
            bins,
            traversal_cost,
        };
        let ext = extents(&items);
        let (root, items) = if budget > 0 {
            let ctx = SpatialContext {
                tris: store.triangles(),
                margin,
                root_area: ext.0.surface_area(),
            };
            builder.build_spatial(&ctx, items, 0, budget)
        } else {
            (builder.build(&mut items, 0, 0, ext), items)
        };
        // The root is always a node: a lone leaf gets a node of one child.
        let root = match root {
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
        };
        let size = root.size();
        // Made in parallel: the pages are first touched on both threads.
        let mut nodes: Vec<Node> = (0..size.nodes)
            .into_par_iter()
            .map(|_| Node::EMPTY)
            .collect();
        let mut blocks: Vec<Block> = (0..size.blocks)
            .into_par_iter()
            .map(|_| Block::EMPTY)
            .collect();
        let part = Part {
            nodes: &mut nodes,
            node_base: 0,
            blocks: &mut blocks,
            block_base: 0,
        };
        let (_, Flattened { filled, stats }) = flatten(&store, &root, &items, 0, part);
        root.drop_in_parallel();
        let mut bvh = Bvh {
            nodes,
            blocks,
            filled,
            others: store.triangles().len() < store.len(),
            store,
            leaf_size,
            bins,
            spatial,
            stats,
        };
        // The blocks hold the triangles now; the store keeps the other kinds.
        bvh.store.release_triangles();
        Ok(bvh)
    }

    fn query<P: Primitives, C: Counters, S: HitSink>(
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
        let o = ray.origin.to_array();
        // As `PreparedRay::inv_dir` computes it.
        let inv = (Vec3::ONE / ray.dir).to_array();
        // Rows of the near and far planes per axis, from the sign bit (so −0 counts as
        // negative and its infinite inverse has the right sign).
        let neg = [
            ray.dir.x.is_sign_negative(),
            ray.dir.y.is_sign_negative(),
            ray.dir.z.is_sign_negative(),
        ];
        // Spelled out: `[0, 1, 2].map(..)` was left as a call per ray (8% of a camera frame).
        let near_row = [
            3 * neg[0] as usize,
            1 + 3 * neg[1] as usize,
            2 + 3 * neg[2] as usize,
        ];
        let far_row = [
            3 * !neg[0] as usize,
            1 + 3 * !neg[1] as usize,
            2 + 3 * !neg[2] as usize,
        ];
        let tmin = ray.tmin;
        // Left uninitialised: zeroing its 2 KB was 14–17% of a camera frame's time.
        let mut stack = [const { std::mem::MaybeUninit::<(f32, u32)>::uninit() }; STACK];
        let mut top = 0;
        // The entry being opened: its entry distance and child reference. One child hit is
        // opened at once; of several, the nearest is, and the others wait on the stack,
        // farthest deepest.
        let mut current = (tmin, 0u32);
        loop {
            let (dist, child) = current;
            if dist <= sink.tmax() {
                counters.cell_visit(0);
                if child & LEAF != 0 {
                    let start = (child & ((1 << LEAF_START_BITS) - 1)) as usize;
                    let count = ((child & !LEAF) >> LEAF_START_BITS) as usize + 1;
                    let prepared = prepared.get_or_insert_with(|| {
                        let pr = PreparedRay::new(ray);
                        (pr, BlockRay::new(&pr))
                    });
                    for b in &self.blocks[start..start + count] {
                        if self.test_block(b, prims, prepared, tmin, sink, counters) {
                            return;
                        }
                    }
                } else {
                    let node = &self.nodes[child as usize];
                    let mut t0 = [tmin; WIDTH];
                    let mut t1 = [sink.tmax(); WIDTH];
                    for a in 0..3 {
                        let (lo, hi) = (&node.bounds[near_row[a]], &node.bounds[far_row[a]]);
                        for k in 0..WIDTH {
                            // A NaN (0·∞: the ray lies in this face's plane) fails both
                            // comparisons and leaves the interval as it was.
                            let tn = (lo[k] - o[a]) * inv[a];
                            let tf = (hi[k] - o[a]) * inv[a];
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
                            current = (t0[k], node.children[k]);
                            continue;
                        }
                        // Several: sorted by entry distance, farthest first, by insertion.
                        let mut hits = [(0f32, 0u32); WIDTH];
                        hits[0] = (t0[k], node.children[k]);
                        let mut n = 1;
                        while mask != 0 {
                            let k = mask.trailing_zeros() as usize;
                            mask &= mask - 1;
                            let mut i = n;
                            while i > 0 && hits[i - 1].0 < t0[k] {
                                hits[i] = hits[i - 1];
                                i -= 1;
                            }
                            hits[i] = (t0[k], node.children[k]);
                            n += 1;
                        }
                        for &h in &hits[..n - 1] {
                            stack[top].write(h);
                            top += 1;
                        }
                        current = hits[n - 1];
                        continue;
                    }
                }
            }
            if top == 0 {
                break;
            }
            top -= 1;
            // SAFETY: every entry below `top` has been written: `top` grows only by one, right
            // after `stack[top].write` (a bounds-checked index, so no write lands outside; the
            // depth bound behind `STACK` keeps it from panicking).
            current = unsafe { stack[top].assume_init() };
        }
    }

    fn memory_bytes(&self) -> usize {
        std::mem::size_of::<Self>() + self.structure_bytes() + self.store.memory_bytes()
    }

    fn stats(&self) -> StructureStats {
        let n = self.store.len().max(1) as f64;
        let leaves = self.stats.leaves;
        let mut s = StructureStats::default();
        s.push("leaf", self.leaf_size as f64);
        s.push("bins", self.bins as f64);
        s.push("spatial", self.spatial as f64);
        s.push("nodes", self.nodes.len() as f64);
        s.push("leaves", leaves as f64);
        // Every leaf holds at least one primitive: the build never makes an empty one.
        s.push("empty_leaves", 0.0);
        s.push("max_depth", self.stats.max_depth as f64);
        s.push(
            "mean_leaf_depth",
            self.stats.depth_sum as f64 / leaves.max(1) as f64,
        );
        s.push("references_per_object", self.filled as f64 / n);
        s.push(
            "primitives_per_leaf",
            self.filled as f64 / leaves.max(1) as f64,
        );
        s.push("blocks", self.blocks.len() as f64);
        s.push(
            "lanes_filled",
            self.filled as f64 / (LANES * self.blocks.len()).max(1) as f64,
        );
        s.push_memory(
            self.structure_bytes(),
            self.memory_bytes(),
            self.store.len(),
        );
        s.census = CellCensus {
            cells: leaves,
            full_cells: leaves,
            object_refs: self.filled,
            full_volume: self.stats.leaf_volume,
        };
        s
    }
}
