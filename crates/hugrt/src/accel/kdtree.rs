//! kd-tree: an axis-aligned BSP tree (Havran §3.5.1–3.5.2).
//!
//! * `split=sah` (default): the plane minimising Havran's cost (eq. 3),
//!   `C = T_T + (S_L/S)·n_L + (S_R/S)·n_R` in units of one intersection test, searched over
//!   the key positions of §4.2 (every primitive box's min and max, clipped to the node, on all
//!   three axes) by a sweep over the sorted events (Wald and Havran, "On building fast
//!   kd-trees for ray tracing", 2006: ends before planars before starts at one position, and a
//!   planar primitive on whichever side is cheaper); a side left empty has its cost scaled by
//!   0.8, the usual reward for cutting off empty space. A node becomes a leaf when no plane
//!   costs less than testing its primitives. Events are sorted at each node, by a
//!   linear-time radix sort of their integer keys in nodes of 1024 events or more, so each
//!   level of the tree costs `O(n)` and the build `O(n log n)` (depth bounded by `O(log n)`).
//! * `split=mid`: Sung and Shirley's mid-point split on cyclic axes, until a leaf holds `leaf`
//!   primitives (default 3) or the depth reaches `depth` (default 30).
//! * Both stop at the depth limit (`depth`; for the SAH `8 + 1.3·log2 n` unless given), and a
//!   split that would leave every primitive on both sides is not made. References are bounded
//!   by a budget of `64·n + 4096` (a node that would exceed it stays a leaf).
//! * Traversal: the classic near/far descent with an explicit stack of `(node, t_near,
//!   t_far)`; a leaf's hit ends the query once it lies before the leaf's exit, and a mailbox
//!   keeps a primitive referenced by several leaves from being tested twice.
//!
//! Exactness: primitives are binned with their boxes widened by 64 ulps of the scene's
//! magnitude, as in the grids (`hierarchy`), so a primitive whose hit lies within rounding of
//! a leaf's interval is referenced by that leaf, and stopping at the leaf's exit never misses
//! a nearer hit beyond it. A ray lying in a splitting plane (0·∞) visits one side, which holds
//! everything on the plane.
//!
//! Layouts (`layout`, Havran §4.3): the same tree with its nodes placed depth first (default),
//! breadth first, scattered (pairs shuffled, as individually allocated nodes would lie) or as
//! compact subtrees packed into 64-byte cache lines. Children are always stored in pairs, so
//! an inner node holds one child index.
//!
//! Cutting off empty space (`cut=true`, Havran §4.2.2, eq. 7–8): a node of one primitive is
//! split too when a plane at the primitive's box, leaving the other side empty, costs less
//! than the test by the cost above (with the traversal cost 0.75 and the empty side's 0.8,
//! when the primitive's slab holds under ~31% of the node's surface: Havran finds it pays
//! under 25–40%). Off by default: it measured ×0.93–1.12, within the noise, as Havran found
//! (1–7%).
//!
//! Havran's way to `O(n log n)`, events sorted once and kept sorted through the splits, was
//! built and gave the same tree 2× slower on two cores (`docs/measurements.md`); the radix
//! sort per node gives the bound with the same tree and build time as the comparison sort
//! (bunny 368–380 against 368–440 ms, spd-mount-big 1.85–2.00 against 1.84–1.94 s, 3 runs
//! each).

use super::sort::radix_sort_keys;
use super::store::{Nearest, PrimStore, finite};
use super::{
    Accel, CellCensus, Counters, Hit, Mailbox, Primitives, Spec, SpecError, StructureStats,
};
use crate::geometry::{Aabb, PreparedRay, Ray};
use std::sync::atomic::{AtomicUsize, Ordering};

/// See [`super::bvh`]: the same widening, for the same reason.
const MARGIN: f32 = 1.0 / (1 << 17) as f32;

/// Nodes of at least this many events sort them by radix ([`radix_sort_keys`]).
const RADIX_EVENTS: usize = 1024;

/// Deepest tree allowed by the `depth` key.
const MAX_DEPTH: usize = 64;

/// Leaf marker in [`KdNode::a`]'s two low bits.
const LEAF: u32 = 3;

/// Eight bytes. Inner: `a` = axis | a child's index << 2, `b` = the plane's `f32` bits: in
/// the depth-first layout the child below the plane follows its parent and the index is the
/// child above; in the others children are stored in pairs and the index is the child below,
/// the child above the next one. Leaf: `a` = 3 | count << 2, `b` = first reference.
#[derive(Clone, Copy, Default)]
struct KdNode {
    a: u32,
    b: u32,
}

/// Eight nodes in one 64-byte cache line: the nodes are stored line by line, so that a layout
/// can place a subtree in one line (Havran §4.3).
#[derive(Clone, Copy, Default)]
#[repr(C, align(64))]
struct Line([KdNode; 8]);

/// Where the nodes lie in memory (Havran §4.3).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Layout {
    /// Depth first: a node, its subtree below the plane, then its subtree above.
    DepthFirst,
    /// Breadth first, level after level.
    BreadthFirst,
    /// Pairs scattered at random, as individually allocated nodes would be.
    Scattered,
    /// Compact subtrees: from a root at the start of a cache line, its descendants breadth
    /// first in the same line while a pair fits; the pairs that do not start lines of their
    /// own.
    Subtrees,
}

/// The tree before it is laid out: children explicit.
enum Logical {
    Leaf {
        start: u32,
        count: u32,
    },
    Inner {
        axis: u32,
        split: f32,
        below: usize,
        above: usize,
    },
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum SplitRule {
    Sah,
    Mid,
}

pub struct KdTree {
    lines: Vec<Line>,
    /// Nodes in the tree (the lines may hold unused slots).
    nodes: usize,
    layout: Layout,
    refs: Vec<u32>,
    store: PrimStore,
    bounds: Aabb,
    rule: SplitRule,
    stats: TreeStats,
}

#[derive(Clone, Copy, Default)]
struct TreeStats {
    leaves: usize,
    empty_leaves: usize,
    max_depth: usize,
    depth_sum: usize,
    full_volume: f64,
}

enum BuildNode {
    Leaf(Vec<u32>),
    Inner {
        axis: usize,
        split: f32,
        children: Box<[BuildNode; 2]>,
    },
}

struct Builder<'a> {
    boxes: &'a [Aabb],
    rule: SplitRule,
    leaf_size: usize,
    max_depth: usize,
    traversal_cost: f32,
    /// Havran's cutting off empty space around single primitives (§4.2.2).
    cut: bool,
    /// References still allowed beyond one per primitive.
    budget: AtomicUsize,
}

/// A plane and which side gets the primitives lying in it.
struct Plane {
    axis: usize,
    pos: f32,
    planar_left: bool,
    cost: f32,
}

const EMPTY_BONUS: f32 = 0.8;

/// Event kinds in sweep order at one position: ends, planars, starts.
const END: u8 = 0;
const PLANAR: u8 = 1;
const START: u8 = 2;

/// The bits of `x` as an integer in the order of the floats (negative ones flipped).
fn monotonic(x: f32) -> u32 {
    let b = x.to_bits();
    if b >> 31 != 0 { !b } else { b | 1 << 31 }
}

fn from_monotonic(m: u32) -> f32 {
    f32::from_bits(if m >> 31 != 0 { m & !(1 << 31) } else { !m })
}

fn clip(b: &Aabb, node: &Aabb, axis: usize) -> (f32, f32) {
    (
        b.min[axis].max(node.min[axis]),
        b.max[axis].min(node.max[axis]),
    )
}

impl Builder<'_> {
    fn build(&self, items: Vec<u32>, node: Aabb, depth: usize) -> BuildNode {
        let n = items.len();
        // One primitive is a leaf, unless cutting off empty space may pay (`cut`).
        let single_cut = n == 1 && self.cut && self.rule == SplitRule::Sah;
        if (n <= 1 && !single_cut) || depth >= self.max_depth {
            return BuildNode::Leaf(items);
        }
        let plane = match self.rule {
            SplitRule::Sah => self.sah(&items, &node),
            SplitRule::Mid => {
                if n <= self.leaf_size {
                    return BuildNode::Leaf(items);
                }
                let axis = depth % 3;
                Some(Plane {
                    axis,
                    pos: 0.5 * (node.min[axis] + node.max[axis]),
                    planar_left: true,
                    cost: 0.0,
                })
            }
        };
        let Some(p) = plane else {
            return BuildNode::Leaf(items);
        };
        if self.rule == SplitRule::Sah && p.cost >= n as f32 {
            return BuildNode::Leaf(items);
        }
        let (mut left, mut right) = (Vec::new(), Vec::new());
        for &i in &items {
            let (lo, hi) = clip(&self.boxes[i as usize], &node, p.axis);
            if lo == p.pos && hi == p.pos {
                if p.planar_left {
                    left.push(i)
                } else {
                    right.push(i)
                }
            } else {
                if lo < p.pos {
                    left.push(i);
                }
                if hi > p.pos {
                    right.push(i);
                }
            }
        }
        // Nothing gained when every primitive lands on both sides; and the reference budget
        // bounds memory whatever the scene.
        let added = (left.len() + right.len()).saturating_sub(n);
        if (left.len() == n && right.len() == n)
            || self
                .budget
                .fetch_update(Ordering::Relaxed, Ordering::Relaxed, |b| {
                    b.checked_sub(added)
                })
                .is_err()
        {
            return BuildNode::Leaf(items);
        }
        drop(items);
        let (mut below, mut above) = (node, node);
        below.max[p.axis] = p.pos;
        above.min[p.axis] = p.pos;
        let (l, r) = if n > 4096 {
            rayon::join(
                || self.build(left, below, depth + 1),
                || self.build(right, above, depth + 1),
            )
        } else {
            (
                self.build(left, below, depth + 1),
                self.build(right, above, depth + 1),
            )
        };
        BuildNode::Inner {
            axis: p.axis,
            split: p.pos,
            children: Box::new([l, r]),
        }
    }

    /// The cheapest plane over the key positions of all three axes (see the module doc).
    fn sah(&self, items: &[u32], node: &Aabb) -> Option<Plane> {
        let area = node.surface_area();
        if area.is_nan() || area <= 0.0 {
            return None;
        }
        let n = items.len();
        let e = node.extent();
        let mut best: Option<Plane> = None;
        // Events as integer keys: the position's bits made monotonic, then the kind, so that
        // one integer sort orders them by position and, at one position, ends before planars
        // before starts.
        // (`+ 0.0` makes −0 the same position as +0.)
        let key = |pos: f32, kind: u8| (monotonic(pos + 0.0) as u64) << 2 | kind as u64;
        let mut events: Vec<u64> = Vec::with_capacity(2 * n);
        for axis in 0..3 {
            if e[axis].is_nan() || e[axis] <= 0.0 {
                continue;
            }
            events.clear();
            for &i in items {
                let (lo, hi) = clip(&self.boxes[i as usize], node, axis);
                if lo == hi {
                    events.push(key(lo, PLANAR));
                } else {
                    events.push(key(lo, START));
                    events.push(key(hi, END));
                }
            }
            // Large nodes sort in linear time, which makes the build `O(n log n)`.
            if events.len() >= RADIX_EVENTS {
                radix_sort_keys(&mut events, 34);
            } else {
                events.sort_unstable();
            }
            let (a1, a2) = ((axis + 1) % 3, (axis + 2) % 3);
            let cap = e[a1] * e[a2];
            let ring = e[a1] + e[a2];
            let (mut nl, mut nr) = (0usize, n);
            let mut k = 0;
            while k < events.len() {
                let bits = events[k] >> 2;
                let pos = from_monotonic(bits as u32);
                let mut count = [0usize; 3];
                while k < events.len() && events[k] >> 2 == bits {
                    count[(events[k] & 3) as usize] += 1;
                    k += 1;
                }
                let [ends, planars, starts] = [
                    count[END as usize],
                    count[PLANAR as usize],
                    count[START as usize],
                ];
                nr -= ends + planars;
                if pos > node.min[axis] && pos < node.max[axis] {
                    let below = pos - node.min[axis];
                    let above = node.max[axis] - pos;
                    let sl = 2.0 * (cap + below * ring);
                    let sr = 2.0 * (cap + above * ring);
                    for planar_left in [true, false] {
                        let (l, r) = if planar_left {
                            (nl + planars, nr)
                        } else {
                            (nl, nr + planars)
                        };
                        let bonus = if l == 0 || r == 0 { EMPTY_BONUS } else { 1.0 };
                        let cost =
                            self.traversal_cost + bonus * (sl * l as f32 + sr * r as f32) / area;
                        if best.as_ref().is_none_or(|b| cost < b.cost) {
                            best = Some(Plane {
                                axis,
                                pos,
                                planar_left,
                                cost,
                            });
                        }
                    }
                }
                nl += starts + planars;
            }
        }
        best
    }
}

impl KdTree {
    /// The build's tree as logical nodes (index 0 the root); leaves' references appended.
    fn flatten(
        &mut self,
        node: BuildNode,
        cell: Aabb,
        depth: usize,
        out: &mut Vec<Logical>,
    ) -> usize {
        let id = out.len();
        match node {
            BuildNode::Leaf(mut items) => {
                items.sort_unstable();
                out.push(Logical::Leaf {
                    start: self.refs.len() as u32,
                    count: items.len() as u32,
                });
                self.stats.leaves += 1;
                self.stats.max_depth = self.stats.max_depth.max(depth);
                self.stats.depth_sum += depth;
                if items.is_empty() {
                    self.stats.empty_leaves += 1;
                } else {
                    self.stats.full_volume += cell.volume() as f64;
                }
                self.refs.extend(items);
            }
            BuildNode::Inner {
                axis,
                split,
                children,
            } => {
                out.push(Logical::Leaf { start: 0, count: 0 });
                let [below, above] = *children;
                let (mut lo, mut hi) = (cell, cell);
                lo.max[axis] = split;
                hi.min[axis] = split;
                let b = self.flatten(below, lo, depth + 1, out);
                let a = self.flatten(above, hi, depth + 1, out);
                out[id] = Logical::Inner {
                    axis: axis as u32,
                    split,
                    below: b,
                    above: a,
                };
            }
        }
        id
    }

    /// Places the logical nodes in memory by `layout` and writes them.
    fn lay_out(&mut self, tree: &[Logical]) {
        let n = tree.len();
        let mut slot = vec![u32::MAX; n];
        let mut next = 1u32;
        slot[0] = 0;
        let children = |id: usize| match tree[id] {
            Logical::Inner { below, above, .. } => Some((below, above)),
            Logical::Leaf { .. } => None,
        };
        match self.layout {
            Layout::DepthFirst => {
                let mut stack = vec![0usize];
                next = 0;
                while let Some(id) = stack.pop() {
                    slot[id] = next;
                    next += 1;
                    if let Some((b, a)) = children(id) {
                        stack.push(a);
                        stack.push(b);
                    }
                }
            }
            Layout::Scattered => {
                let mut stack = vec![0usize];
                while let Some(id) = stack.pop() {
                    if let Some((b, a)) = children(id) {
                        slot[b] = next;
                        slot[a] = next + 1;
                        next += 2;
                        stack.push(a);
                        stack.push(b);
                    }
                }
            }
            Layout::BreadthFirst => {
                let mut queue = std::collections::VecDeque::from([0usize]);
                while let Some(id) = queue.pop_front() {
                    if let Some((b, a)) = children(id) {
                        slot[b] = next;
                        slot[a] = next + 1;
                        next += 2;
                        queue.push_back(b);
                        queue.push_back(a);
                    }
                }
            }
            Layout::Subtrees => {
                // Lines are filled from subtree roots; a pair that does not fit in the line
                // of its parent starts a new line, whose subtree is laid out later.
                let mut lines = std::collections::VecDeque::from([vec![0usize]]);
                next = 0;
                while let Some(roots) = lines.pop_front() {
                    let line_start = next.next_multiple_of(8);
                    next = line_start;
                    for &r in &roots {
                        slot[r] = next;
                        next += 1;
                    }
                    let mut queue: std::collections::VecDeque<usize> = roots.into();
                    while let Some(id) = queue.pop_front() {
                        if let Some((b, a)) = children(id) {
                            if next + 2 <= line_start + 8 {
                                slot[b] = next;
                                slot[a] = next + 1;
                                next += 2;
                                queue.push_back(b);
                                queue.push_back(a);
                            } else {
                                lines.push_back(vec![b, a]);
                            }
                        }
                    }
                }
            }
        }
        if self.layout == Layout::Scattered {
            // Pairs (slots 2k+1, 2k+2) shuffled with a fixed seed; the root stays first.
            use rand::{SeedableRng, seq::SliceRandom};
            let pairs = (next as usize - 1) / 2;
            let mut order: Vec<u32> = (0..pairs as u32).collect();
            order.shuffle(&mut rand_pcg::Pcg64Mcg::seed_from_u64(7));
            for s in slot.iter_mut().skip(1) {
                let k = (*s - 1) / 2;
                *s = 1 + 2 * order[k as usize] + (*s - 1) % 2;
            }
        }
        let total = slot.iter().map(|&s| s as usize + 1).max().unwrap_or(1);
        self.lines = vec![Line::default(); total.div_ceil(8)];
        for (id, node) in tree.iter().enumerate() {
            let s = slot[id] as usize;
            self.lines[s / 8].0[s % 8] = match *node {
                Logical::Leaf { start, count } => KdNode {
                    a: LEAF | count << 2,
                    b: start,
                },
                Logical::Inner {
                    axis,
                    split,
                    below,
                    above,
                } => KdNode {
                    a: axis
                        | if self.layout == Layout::DepthFirst {
                            slot[above]
                        } else {
                            slot[below]
                        } << 2,
                    b: split.to_bits(),
                },
            };
        }
        self.nodes = n;
    }

    /// Bytes of the nodes and leaf references, without the store.
    fn structure_bytes(&self) -> usize {
        self.lines.capacity() * std::mem::size_of::<Line>() + self.refs.capacity() * 4
    }

    #[inline(always)]
    fn node(&self, i: u32) -> KdNode {
        self.lines[(i >> 3) as usize].0[(i & 7) as usize]
    }
}

impl Accel for KdTree {
    const NAME: &'static str = "kdtree";
    const KEYS: &'static [(&'static str, &'static str)] = &[
        (
            "split",
            "sah: Havran's cost at the key positions (default); mid: mid-point, cyclic axes",
        ),
        (
            "leaf",
            "mid: most primitives a leaf holds, 1..1000 (default 3); sah: leaves are as the cost decides",
        ),
        (
            "depth",
            "deepest level, 1..64 (default: sah 8 + 1.3 log2 n, mid 30)",
        ),
        (
            "traversal",
            "sah: cost of a traversal step relative to a primitive test, 0..100 (default 0.75)",
        ),
        (
            "cut",
            "sah: true cuts off the empty space around single primitives when eq. 3 says it pays (Havran 4.2.2; default false)",
        ),
        (
            "layout",
            "nodes in memory (Havran 4.3): depth-first (default), breadth-first, scattered, subtrees (packed in 64-byte lines)",
        ),
    ];

    fn build<P: Primitives>(prims: &P, spec: &Spec) -> Result<Self, SpecError> {
        let rule = match spec.choice("split", &["sah", "mid"], "sah")? {
            "mid" => SplitRule::Mid,
            _ => SplitRule::Sah,
        };
        let leaf_size = spec.usize_in("leaf", 3, 1, 1000)?;
        let n = prims.len();
        let default_depth = match rule {
            SplitRule::Sah => (8.0 + 1.3 * (n.max(1) as f64).log2()).round() as usize,
            SplitRule::Mid => 30,
        };
        let max_depth = spec.usize_in("depth", default_depth.min(MAX_DEPTH), 1, MAX_DEPTH)?;
        let traversal_cost = spec.f32_in("traversal", 0.75, 0.0, 100.0)?;
        let cut = spec.bool("cut", false)?;
        if n >= 1 << 30 {
            return Err(SpecError::Build(format!(
                "{n} primitives: the kdtree holds at most 2^30-1"
            )));
        }
        let store = PrimStore::build(prims);
        let raw: Vec<Aabb> = (0..store.len() as u32)
            .map(|s| store.bounds(prims, s))
            .collect();
        let scene = raw
            .iter()
            .filter(|b| finite(b))
            .fold(Aabb::EMPTY, |a, b| a.union(b));
        let margin = if scene.is_empty() {
            0.0
        } else {
            scene.magnitude().max(scene.extent().max_element()) * MARGIN
        };
        let boxes: Vec<Aabb> = raw.iter().map(|b| b.expand(margin)).collect();
        let items: Vec<u32> = (0..store.len() as u32)
            .filter(|&s| finite(&raw[s as usize]))
            .collect();
        let bounds = scene.expand(margin);
        let builder = Builder {
            boxes: &boxes,
            rule,
            leaf_size: if rule == SplitRule::Mid { leaf_size } else { 1 },
            max_depth,
            traversal_cost,
            cut,
            budget: AtomicUsize::new(63 * items.len() + 4096),
        };
        let root = builder.build(items, bounds, 0);
        let layout = match spec.choice(
            "layout",
            &["depth-first", "breadth-first", "scattered", "subtrees"],
            "depth-first",
        )? {
            "breadth-first" => Layout::BreadthFirst,
            "scattered" => Layout::Scattered,
            "subtrees" => Layout::Subtrees,
            _ => Layout::DepthFirst,
        };
        let mut tree = KdTree {
            lines: Vec::new(),
            nodes: 0,
            layout,
            refs: Vec::new(),
            store,
            bounds,
            rule,
            stats: TreeStats::default(),
        };
        let mut logical = Vec::new();
        tree.flatten(root, bounds, 0, &mut logical);
        tree.lay_out(&logical);
        tree.refs.shrink_to_fit();
        Ok(tree)
    }

    fn query<P: Primitives, C: Counters, const ANY_HIT: bool>(
        &self,
        prims: &P,
        ray: &Ray,
        counters: &mut C,
    ) -> Option<Hit> {
        if self.refs.is_empty() {
            return None;
        }
        let pr = PreparedRay::new(ray);
        let mut near = Nearest::new(ray.tmax);
        counters.box_test(0);
        let (t0, t1) = self.bounds.intersect(&pr, ray.tmin, ray.tmax)?;
        let o = ray.origin.to_array();
        let d = ray.dir.to_array();
        let inv = pr.inv_dir.to_array();
        let mut mail = Mailbox::default();
        let pairs = self.layout != Layout::DepthFirst;
        // Left uninitialised, as the bvh's: zeroing 1.5 KB a ray costs more than a short walk.
        let mut stack =
            [const { std::mem::MaybeUninit::<(u32, f32, f32)>::uninit() }; 2 * MAX_DEPTH + 2];
        let mut top = 0;
        let (mut node, mut tn, mut tf) = (0u32, t0, t1);
        loop {
            if tn <= near.t {
                counters.cell_visit(0);
                let kd = self.node(node);
                if kd.a & 3 != LEAF {
                    let axis = (kd.a & 3) as usize;
                    let split = f32::from_bits(kd.b);
                    let (below, above) = if pairs {
                        (kd.a >> 2, (kd.a >> 2) + 1)
                    } else {
                        (node + 1, kd.a >> 2)
                    };
                    let below_first = o[axis] < split || (o[axis] == split && d[axis] <= 0.0);
                    let (first, second) = if below_first {
                        (below, above)
                    } else {
                        (above, below)
                    };
                    let ts = (split - o[axis]) * inv[axis];
                    // NaN (the ray lies in the plane) visits the first side only.
                    if ts > tf || ts <= 0.0 || ts.is_nan() {
                        node = first;
                    } else if ts < tn {
                        node = second;
                    } else {
                        stack[top].write((second, ts, tf));
                        top += 1;
                        node = first;
                        tf = ts;
                    }
                    continue;
                }
                let start = kd.b as usize;
                let count = (kd.a >> 2) as usize;
                for &r in &self.refs[start..start + count] {
                    if !mail.first_visit(r) {
                        continue;
                    }
                    counters.prim_test(0);
                    if let Some(t) = self.store.intersect(prims, r, &pr, ray.tmin, near.t) {
                        counters.prim_hit(0);
                        if near.offer(&self.store, t, r) && ANY_HIT {
                            return near.hit(&self.store);
                        }
                    }
                }
                if near.t <= tf {
                    break;
                }
            }
            if top == 0 {
                break;
            }
            top -= 1;
            // SAFETY: every entry below `top` has been written: `top` grows only by one, right
            // after `stack[top].write` (a bounds-checked index; one entry per inner node on the
            // way down of a tree at most `MAX_DEPTH` deep keeps it from panicking).
            (node, tn, tf) = unsafe { stack[top].assume_init() };
        }
        near.hit(&self.store)
    }

    fn memory_bytes(&self) -> usize {
        std::mem::size_of::<Self>() + self.structure_bytes() + self.store.memory_bytes()
    }

    fn stats(&self) -> StructureStats {
        let n = self.store.len().max(1) as f64;
        let t = &self.stats;
        let mut s = StructureStats::default();
        s.push("split_mid", (self.rule == SplitRule::Mid) as u8 as f64);
        s.push("layout", self.layout as u8 as f64);
        s.push("cache_lines", self.lines.len() as f64);
        s.push("nodes", self.nodes as f64);
        s.push("leaves", t.leaves as f64);
        s.push("empty_leaves", t.empty_leaves as f64);
        s.push("max_depth", t.max_depth as f64);
        s.push(
            "mean_leaf_depth",
            t.depth_sum as f64 / t.leaves.max(1) as f64,
        );
        s.push("references", self.refs.len() as f64);
        s.push("references_per_object", self.refs.len() as f64 / n);
        s.push_memory(
            self.structure_bytes(),
            self.memory_bytes(),
            self.store.len(),
        );
        s.census = CellCensus {
            cells: self.nodes,
            full_cells: t.leaves - t.empty_leaves,
            object_refs: self.refs.len(),
            full_volume: t.full_volume,
        };
        s
    }
}

#[cfg(test)]
mod tests {
    use super::{from_monotonic, monotonic};

    #[test]
    fn monotonic_keys_order_floats_and_come_back() {
        let xs = [-1e30f32, -2.5, -1.0, -1e-30, 0.0, 1e-30, 1.0, 2.5, 1e30];
        for w in xs.windows(2) {
            assert!(monotonic(w[0]) < monotonic(w[1]), "{} < {}", w[0], w[1]);
        }
        for x in xs {
            assert_eq!(from_monotonic(monotonic(x)), x);
        }
        assert_eq!(monotonic(-0.0 + 0.0), monotonic(0.0));
    }
}
