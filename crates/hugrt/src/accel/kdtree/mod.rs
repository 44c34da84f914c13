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
//! Layouts (`layout`, Havran §4.3): [`layout`]. The build is in `build.rs`, the descent in
//! `traverse.rs`.
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

mod build;
mod layout;
mod traverse;

use build::Builder;

use super::margin::margin_for;
use super::query::{OCCLUSION_HELP, Occlusion};
use super::settings::{Key, Settings, key};
use super::store::{PrimStore, finite};
use super::{Accel, CellCensus, Counters, HitSink, Preset, Primitives, SpecError, StructureStats};
use crate::geometry::{Aabb, PreparedRay, Ray};
pub use layout::Layout;
use layout::{Lines, Nodes};
use std::sync::atomic::AtomicUsize;

/// Nodes of at least this many events sort them by radix
/// ([`super::sort::radix_sort_keys`]).
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
    /// Where occlusion queries walk a ray from ([`Occlusion`]): from the far end, the child
    /// met last is taken first.
    pub occlusion: Occlusion,
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
            occlusion: Occlusion::Auto,
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
        key!("occlusion", occlusion: Occlusion, (), OCCLUSION_HELP),
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
    occlusion: Occlusion,
    stats: TreeStats,
}

#[derive(Clone, Copy, Default)]
struct TreeStats {
    leaves: usize,
    empty_leaves: usize,
    max_depth: usize,
    depth_sum: usize,
    full_volume: f64,
    /// SAH planes, and those outside the median interval (Havran §4.2, Table 4).
    sah_planes: usize,
    planes_outside_median: usize,
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
        (
            "occlusion",
            "start",
            "Havran §4.2.2: the walk of Sung and Shirley, from the root along the ray",
        ),
    ],
};

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
            occlusion,
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
            planes: AtomicUsize::new(0),
            outside_median: AtomicUsize::new(0),
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
            occlusion,
            stats: TreeStats::default(),
        };
        let mut logical = Vec::new();
        tree.flatten(root, bounds, 0, &mut logical);
        tree.stats.sah_planes = builder.planes.into_inner();
        tree.stats.planes_outside_median = builder.outside_median.into_inner();
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

    fn reach(&self) -> &crate::accel::Reach {
        self.store.reach()
    }

    fn occlusion(&self) -> Occlusion {
        self.occlusion
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
        s.push("sah_planes", t.sah_planes as f64);
        s.push("planes_outside_median", t.planes_outside_median as f64);
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
