//! kd-tree: an axis-aligned BSP tree (Havran §3.5.1–3.5.2).
//!
//! * `split=sah` (default): the plane minimising Havran's cost (eq. 3),
//!   `C = T_P + T_T + (S_L/S)·n_L + (S_R/S)·n_R` in units of one intersection test (`traversal`
//!   is `T_P + T_T`), searched over the key positions of §4.2 (every primitive box's min and
//!   max, clipped to the node, on all three axes) by a sweep over the sorted events (Wald and
//!   Havran, "On building fast kd-trees for ray tracing", 2006: ends before planars before
//!   starts at one position, and a planar primitive on whichever side is cheaper). A node
//!   becomes a leaf when no plane costs less than testing its primitives. Events are sorted at
//!   each node, by a linear-time radix sort of their integer keys in nodes of 1024 events or
//!   more, so each level of the tree costs `O(n)` and the build `O(n log n)` (depth bounded by
//!   `O(log n)`). hugrt's departure, on by default (`bonus`, 1 in the `havran` preset): a
//!   plane that leaves a side empty has its object terms scaled by 0.8, the usual reward for
//!   cutting off empty space.
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
//! Layouts (`layout`, Havran §4.3): [`layout`].
//!
//! Cutting off empty space (`cut=true`, Havran §4.2.2): a plane that leaves one side empty is
//! costed by eq. 7, `T_P + ((S_L + S_R)/S)·T_T + (S_full/S)·n`, the step into each child
//! weighed by the probability of entering it (`step` is `T_T`), at every node: Havran's
//! "early" cutting of inner nodes (Fig. 10, his method *newsf*) as well as of leaves; and a
//! node of one primitive is split too when eq. 8 says it pays (with the `havran` preset's
//! costs, when the primitive's side holds under 47% of a cubical node's surface; Havran finds
//! the break-even at 25% for spheres and 40% for triangles). Off by default: cutting single
//! primitives measured ×0.93–1.12 by the earlier, eq. 3 form, within the noise, as Havran found
//! (1–7%).
//!
//! `preset=havran` is Havran's method (2) of Tables 5–6: [`HAVRAN`].
//!
//! Havran's way to `O(n log n)`, events sorted once and kept sorted through the splits, was
//! built and gave the same tree 2× slower on two cores (`docs/measurements.md`); the radix
//! sort per node gives the bound with the same tree and build time as the comparison sort
//! (bunny 368–380 against 368–440 ms, spd-mount-big 1.85–2.00 against 1.84–1.94 s, 3 runs
//! each).

mod layout;

use super::margin::margin_for;
use super::settings::{Key, Settings, key};
use super::sort::radix_sort_keys;
use super::store::{PrimStore, finite};
use super::{
    Accel, CellCensus, Counters, HitSink, Mailbox, Preset, Primitives, SpecError, StructureStats,
};
use crate::geometry::{Aabb, PreparedRay, Ray};
pub use layout::Layout;
use layout::{Lines, Logical, NodeStore, Nodes, Visit};
use std::sync::atomic::{AtomicUsize, Ordering};

/// Nodes of at least this many events sort them by radix ([`radix_sort_keys`]).
const RADIX_EVENTS: usize = 1024;

/// Deepest tree allowed by the `depth` key.
const MAX_DEPTH: usize = 64;

/// Where a node is cut.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SplitRule {
    /// Havran's cost (eq. 3) at the key positions.
    Sah,
    /// The mid-point, axes in turn.
    Mid,
}

crate::accel::settings::choice_value!(SplitRule { SplitRule::Sah => "sah", SplitRule::Mid => "mid" });

/// The kd-tree's settings (`kdtree:split=..,leaf=..`, ...).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KdTreeSettings {
    pub split: SplitRule,
    /// `split=mid`: most primitives a leaf holds (with the SAH, the cost decides).
    pub leaf: usize,
    /// Deepest level; `None`: 8 + 1.3·log2 n with the SAH (Havran's), 30 at the mid-point.
    pub depth: Option<usize>,
    /// SAH: cost of a traversal step relative to a primitive test (eq. 3's `T_P + T_T`).
    pub traversal: f32,
    /// SAH: the part of `traversal` that is the step into a child (`T_T`), weighed by the
    /// child's probability in eq. 7.
    pub step: f32,
    /// SAH: hugrt's factor on the object terms of a plane leaving a side empty (1 is eq. 3).
    pub bonus: f32,
    /// SAH: cost planes leaving a side empty by eq. 7 at every node, nodes of one object too
    /// (Havran §4.2.2).
    pub cut: bool,
    /// The nodes in memory (Havran §4.3).
    pub layout: Layout,
}

impl Default for KdTreeSettings {
    fn default() -> Self {
        KdTreeSettings {
            split: SplitRule::Sah,
            leaf: 3,
            depth: None,
            traversal: 0.75,
            step: 0.15,
            bonus: EMPTY_BONUS,
            cut: false,
            layout: Layout::DepthFirst,
        }
    }
}

impl Settings for KdTreeSettings {
    const KEYS: &'static [Key<Self>] = &[
        key!("split", split: SplitRule, (), "sah: Havran's cost at the key positions; mid: mid-point, cyclic axes"),
        key!("leaf", leaf: usize, 1..=1000, "mid: most primitives a leaf holds; sah: leaves are as the cost decides"),
        key!("depth", depth: Option<usize>, (1..=MAX_DEPTH, "auto"), "deepest level (auto: sah 8 + 1.3 log2 n, mid 30)"),
        key!("traversal", traversal: f32, 0.0..=100.0, "sah: cost of a traversal step relative to a primitive test"),
        key!("step", step: f32, 0.0..=100.0, "sah: the part of traversal that is the step into a child (T_T), weighed by the child's probability in eq. 7"),
        key!("bonus", bonus: f32, 0.0..=1.0, "sah: factor on the object terms of a plane leaving a side empty (hugrt's; 1 is eq. 3)"),
        key!("cut", cut: bool, (), "sah: true costs planes leaving a side empty by eq. 7 at every node and considers nodes of one object too (Havran 4.2.2)"),
        key!("layout", layout: Layout, (), "nodes in memory (Havran 4.3): depth-first, breadth-first, scattered (nodes at random), subtrees (ordinary, in 64-byte lines), compact (pointer-free subtrees of 7 nodes a line)"),
    ];
    const PRESETS: &'static [Preset] = &[HAVRAN];
}

pub struct KdTree {
    nodes: Nodes,
    /// Nodes in the tree (a layout may hold unused slots).
    node_count: usize,
    layout: Layout,
    /// The leaves' references (for the compact layout, each leaf's count before them).
    refs: Vec<u32>,
    /// Object references from the leaves (Havran's `N_RO`).
    references: usize,
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
    /// Eq. 3's `T_P + T_T`, in units of one object test.
    traversal_cost: f32,
    /// Its `T_T` part, which eq. 7 weighs by each child's probability.
    step_cost: f32,
    /// hugrt's factor on the object terms of a plane that leaves a side empty (1: eq. 3).
    empty_bonus: f32,
    /// Havran's cutting off empty space (§4.2.2, eq. 7–8).
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

/// hugrt's default `bonus`, the usual reward for cutting off empty space (Wald and Havran
/// 2006), not in Havran's eq. 3.
const EMPTY_BONUS: f32 = 0.8;

/// Havran's kd-tree (§3.5.2, §4.2): method (2) of his Tables 5–6.
pub const HAVRAN: Preset = Preset {
    name: "havran",
    pairs: &[
        (
            "split",
            "sah",
            "Havran §4.2: eq. 3 minimised over the key positions of all three axes",
        ),
        ("bonus", "1", "Havran eq. 3 has no reward for an empty side"),
        (
            "cut",
            "true",
            "Havran §4.2.2–4.2.3: method (2) cuts off empty space, eq. 7–8",
        ),
        (
            "traversal",
            "0.57",
            "T_P + T_T: Havran gives no values; these make eq. 8 pay below 40% of a cube's area, his break-even for triangles",
        ),
        (
            "step",
            "0.095",
            "T_T = T_P / 5: Havran §4.2.2, the pop much cheaper than the decision",
        ),
        (
            "layout",
            "depth-first",
            "Havran §4.3.2: the DFS representation, his usual one",
        ),
    ],
};

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
                        let objects = (sl * l as f32 + sr * r as f32) / area;
                        let empty = l == 0 || r == 0;
                        let cost = if empty && self.cut {
                            // Eq. 7: the step into each child weighed by its probability.
                            self.traversal_cost - self.step_cost
                                + (sl + sr) / area * self.step_cost
                                + objects
                        } else if empty {
                            self.traversal_cost + self.empty_bonus * objects
                        } else {
                            self.traversal_cost + objects
                        };
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

    /// The near/far descent (module documentation) over one of the layouts.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn walk<N: NodeStore, P: Primitives, C: Counters, S: HitSink>(
        &self,
        nodes: &N,
        prims: &P,
        ray: &Ray,
        pr: &PreparedRay,
        (t0, t1): (f32, f32),
        sink: &mut S,
        counters: &mut C,
    ) {
        let pr = *pr;
        let o = ray.origin.to_array();
        let d = ray.dir.to_array();
        let inv = pr.inv_dir.to_array();
        let mut mail = Mailbox::default();
        // Left uninitialised, as the bvh's: zeroing 1.5 KB a ray costs more than a short walk.
        let mut stack =
            [const { std::mem::MaybeUninit::<(u32, f32, f32)>::uninit() }; 2 * MAX_DEPTH + 2];
        let mut top = 0;
        let (mut node, mut tn, mut tf) = (nodes.root(), t0, t1);
        loop {
            if tn <= sink.tmax() {
                counters.cell_visit(0);
                let (start, count) = match nodes.visit(node, &self.refs) {
                    Visit::Leaf { start, count } => (start, count),
                    Visit::Inner {
                        axis,
                        split,
                        below,
                        above,
                    } => {
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
                };
                for &r in &self.refs[start..start + count] {
                    if !mail.first_visit(r) {
                        continue;
                    }
                    counters.prim_test(0);
                    if let Some(t) = self.store.intersect(prims, r, &pr, ray.tmin, sink.tmax()) {
                        counters.prim_hit(0);
                        if sink.offer(t, || self.store.id(r)) {
                            return;
                        }
                    }
                }
                if sink.tmax() <= tf {
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
    }

    /// Bytes of the nodes and leaf references, without the store.
    fn structure_bytes(&self) -> usize {
        self.nodes.bytes() + self.refs.capacity() * 4
    }
}

impl Accel for KdTree {
    const NAME: &'static str = "kdtree";
    type Settings = KdTreeSettings;

    fn build_checked<P: Primitives>(
        prims: &P,
        settings: &KdTreeSettings,
    ) -> Result<Self, SpecError> {
        let KdTreeSettings {
            split: rule,
            leaf: leaf_size,
            depth,
            traversal: traversal_cost,
            step,
            bonus: empty_bonus,
            cut,
            layout,
        } = *settings;
        let n = prims.len();
        let default_depth = match rule {
            SplitRule::Sah => (8.0 + 1.3 * (n.max(1) as f64).log2()).round() as usize,
            SplitRule::Mid => 30,
        };
        let max_depth = depth.unwrap_or(default_depth.min(MAX_DEPTH));
        let step_cost = step.min(traversal_cost);
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
        let margin = margin_for(&scene);
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
            step_cost,
            empty_bonus,
            cut,
            budget: AtomicUsize::new(63 * items.len() + 4096),
        };
        let root = builder.build(items, bounds, 0);
        let mut tree = KdTree {
            nodes: Nodes::Lines(Lines::default()),
            node_count: 0,
            layout,
            refs: Vec::new(),
            references: 0,
            store,
            bounds,
            rule,
            stats: TreeStats::default(),
        };
        let mut logical = Vec::new();
        tree.flatten(root, bounds, 0, &mut logical);
        tree.references = tree.refs.len();
        tree.nodes = Nodes::lay_out(&logical, layout, &mut tree.refs).ok_or_else(|| {
            SpecError::Build(format!(
                "{} references: the compact layout holds at most 2^31-2",
                tree.references
            ))
        })?;
        tree.node_count = logical.len();
        tree.refs.shrink_to_fit();
        Ok(tree)
    }

    fn query<P: Primitives, C: Counters, S: HitSink>(
        &self,
        prims: &P,
        ray: &Ray,
        sink: &mut S,
        counters: &mut C,
    ) {
        if self.refs.is_empty() {
            return;
        }
        let pr = PreparedRay::new(ray);
        counters.box_test(0);
        let Some(span) = self.bounds.intersect(&pr, ray.tmin, ray.tmax) else {
            return;
        };
        match &self.nodes {
            Nodes::Lines(n) => self.walk(n, prims, ray, &pr, span, sink, counters),
            Nodes::Scattered(n) => self.walk(n, prims, ray, &pr, span, sink, counters),
            Nodes::Compact(n) => self.walk(n, prims, ray, &pr, span, sink, counters),
        }
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
        s.push("cache_lines", self.nodes.cache_lines() as f64);
        s.push("nodes", self.node_count as f64);
        s.push("leaves", t.leaves as f64);
        s.push("empty_leaves", t.empty_leaves as f64);
        s.push("max_depth", t.max_depth as f64);
        s.push(
            "mean_leaf_depth",
            t.depth_sum as f64 / t.leaves.max(1) as f64,
        );
        s.push("references", self.references as f64);
        s.push("references_per_object", self.references as f64 / n);
        s.push_memory(
            self.structure_bytes(),
            self.memory_bytes(),
            self.store.len(),
        );
        s.census = CellCensus {
            cells: t.leaves,
            full_cells: t.leaves - t.empty_leaves,
            object_refs: self.references,
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
