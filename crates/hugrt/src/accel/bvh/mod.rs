//! Bounding volume hierarchy, four children per node (Havran §3.4 names the BVH; its modern
//! form is the one Embree and every production renderer use):
//!
//! * Build: binary cuts by binned surface-area heuristic (Wald, "On fast construction of
//!   SAH-based bounding volume hierarchies", 2007) over the primitives' box centres, at most
//!   `bins` bins per axis (`4 + n/20` for a node of `n` items), subtrees built in parallel,
//!   on 32-byte items and four-lane boxes (as Embree's `PrimRef`), gathered four children to
//!   a node by opening, again and again, the child of largest surface area. The nodes of
//!   four are made as the cuts are decided ([`wide`]), without a binary tree between them.
//!   A leaf's cost is its number of blocks of four, full or not (as Embree counts its
//!   four-triangle leaves), so leaves fill their blocks where the areas allow. With
//!   `spatial` above 0, nodes may instead cut space and share a straddling triangle between
//!   both sides (SBVH, [`spatial`]); that build makes a binary tree and collapses it
//!   ([`flatten`]).
//! * Nodes hold their four children's boxes as six rows of four lanes, so one ray meets all
//!   four boxes in one pass of lane-wise arithmetic that the compiler turns into SIMD on every
//!   target (no `unsafe`); leaves hold up to `leaf` primitives as [`Block`]s of four
//!   triangles, side by side, tested together (SSE), in the leaves' order in memory: no
//!   reference to follow and no store entry to fetch. Spheres, cones and other primitives
//!   sit in the blocks' last lanes by store entry and are tested through the store
//!   ([`PrimStore`]), which gives up its own triangles once the blocks hold them.
//! * `store=index` (and `store=auto` from 2^24 triangles, as the grids): an indexed mesh's
//!   leaves are instead ranges of an indexed store laid out in leaf order, three vertex
//!   indices and an id a triangle (16 bytes, against a block lane's 40), tested eight at a
//!   time where AVX2 is present. Measured on the bunny and a 1M terrain, it keeps 0.68–0.83
//!   of the blocks' speed (`docs/measurements.md`); memory is what limits a scene of 10^8
//!   triangles. Up to 2^30 − 1 of them: past 2^27 entries, which a child reference cannot
//!   name, a leaf names its number in a table of starts (`Bvh::leaf_starts`).
//! * Traversal: children nearest first on an explicit stack that remembers each entry's
//!   distance, so that entries beyond the nearest hit found are dropped unopened; any-hit
//!   returns at the first hit. The walk is generic over what a leaf holds
//!   ([`traverse::walk_tree`]): [`BoxTree`], the same tree over boxes whose leaves name
//!   entries of another structure, is the adaptive grid's tree over its grids.
//!
//! Exactness: a primitive lies in one leaf, whose box holds its box widened by the margin of
//! [`super::margin`], an absolute slack of 64 ulps of the scene's magnitude that covers the
//! slab test's rounding and the triangle test's. The slab test picks each axis's near and far
//! planes from the direction's sign bit; a ray lying in a box's face plane (0·∞ = NaN on that
//! axis) leaves the interval as it was, so it counts as inside.

mod box_tree;
mod build;
mod flatten;
mod packet;
mod spatial;
mod traverse;
mod wide;

pub(crate) use box_tree::BoxTree;
use traverse::walk_tree;

use build::{Builder, Item, MAX_BINS, extents};
use flatten::{Flattened, Part, flatten};

use super::block::{self, Block, LANES};
use super::margin::margin_for;
use super::query::{OCCLUSION_HELP, Occlusion};
use super::settings::{Key, Settings, key};
use super::store::{INDEX_FROM, PrimStore, STORAGE_HELP, TriangleStorage, finite, indexed_mesh};
use super::{Accel, CellCensus, Counters, HitSink, Primitives, SpecError, StructureStats};
use crate::geometry::Ray;
use glam::Vec4;
use spatial::SpatialContext;

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

/// The bvh's settings (`bvh:leaf=..,bins=..,traversal=..,spatial=..,store=..,simd=..`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BvhSettings {
    /// Most primitives a leaf holds when the SAH does not split it (at most 16).
    pub leaf: usize,
    /// SAH bins per axis (2 to 32), at most: a node of `n` items takes `4 + n/20` when fewer
    /// (`build::bins_for`).
    pub bins: usize,
    /// Cost of a traversal step relative to a block test, for the SAH.
    pub traversal: f32,
    /// Spatial splits (SBVH): extra references allowed, as a fraction of the primitives;
    /// 0 for none.
    pub spatial: f32,
    /// How the leaves hold an indexed mesh's triangles: copied into blocks of four, or as
    /// ranges of an indexed store in leaf order ([`TriangleStorage`]).
    pub store: TriangleStorage,
    /// Indexed leaves' triangles tested eight at a time where AVX2 is present.
    pub simd: bool,
    /// Where occlusion queries walk a ray from ([`Occlusion`]): from the far end, the
    /// children met are taken farthest first.
    pub occlusion: Occlusion,
}

impl Default for BvhSettings {
    fn default() -> Self {
        BvhSettings {
            leaf: 8,
            bins: 16,
            traversal: 1.0,
            spatial: 0.0,
            store: TriangleStorage::Auto,
            simd: true,
            occlusion: Occlusion::Auto,
        }
    }
}

impl Settings for BvhSettings {
    const KEYS: &'static [Key<Self>] = &[
        key!("leaf", leaf: usize, 1..=MAX_LEAF, "most primitives a leaf holds when the SAH does not split it"),
        key!("bins", bins: usize, 2..=MAX_BINS, "SAH bins per axis, at most (a node of n items takes 4 + n/20 when fewer)"),
        key!("traversal", traversal: f32, 0.0..=100.0, "cost of a traversal step relative to a block test, for the SAH"),
        key!("spatial", spatial: f32, 0.0..=4.0, "spatial splits (SBVH): extra references allowed, as a fraction of the primitives (0: none)"),
        key!("store", store: TriangleStorage, (), STORAGE_HELP),
        key!("simd", simd: bool, (), "false: test an indexed leaf's triangles one at a time even where AVX2 is present (store=index)"),
        key!("occlusion", occlusion: Occlusion, (), OCCLUSION_HELP),
    ];
}

pub struct Bvh {
    nodes: Vec<Node>,
    /// The leaves' primitives, leaf after leaf, in blocks of [`LANES`]; a leaf's triangles
    /// first. Empty when the leaves are ranges of the store's entries (`indexed`).
    blocks: Vec<Block>,
    /// The leaves name ranges of store entries, the store an indexed mesh's triangles in
    /// leaf order (`store=index`), rather than ranges of blocks.
    indexed: bool,
    /// Indexed leaves are tested eight triangles at a time (AVX2).
    simd: bool,
    /// An indexed leaf's first entry by its number, when the entries are too many for a
    /// reference to name (2^27 or more); empty when leaf references name it themselves.
    leaf_starts: Vec<u32>,
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
    occlusion: Occlusion,
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

/// One build item per primitive whose box is finite (`bounds(s)` the box of the `s`-th of
/// `n`), widened by the scene's margin, and that margin. Primitives with a NaN or infinite
/// coordinate are in no leaf: no finite ray hits them.
fn items_of(n: usize, bounds: impl Fn(u32) -> crate::geometry::Aabb + Sync) -> (Vec<Item>, f32) {
    use rayon::prelude::*;
    let mut items: Vec<Item> = (0..n as u32)
        .into_par_iter()
        .map(|s| Item::new(s, &bounds(s)))
        .collect();
    if !items.par_iter().all(|it| finite(&it.aabb())) {
        items.retain(|it| finite(&it.aabb()));
    }
    let scene = extents(&items).0;
    let margin = margin_for(&scene);
    let widen = Vec4::new(margin, margin, margin, 0.0);
    items.par_iter_mut().for_each(|it| {
        it.lo -= widen;
        it.hi += widen;
    });
    (items, margin)
}

/// `n` empty blocks, made in parallel: the pages are first touched on both threads.
fn empty_blocks(n: usize) -> Vec<Block> {
    use rayon::prelude::*;
    (0..n).into_par_iter().map(|_| Block::EMPTY).collect()
}

impl Bvh {
    /// The bvh of an indexed mesh with leaves as ranges of an indexed store
    /// (`store=index`): built straight to nodes of four ([`wide`]) over items that name the
    /// primitives, whose order once built is the store's. At the build's peak it holds the
    /// items (32 bytes a triangle) and the nodes; once built, the nodes and 16 bytes a
    /// triangle (three vertex indices and the primitive's id), against the blocks' 40.
    fn build_indexed<P: Primitives>(
        prims: &P,
        settings: &BvhSettings,
        builder: &Builder,
        vertices: std::sync::Arc<Vec<crate::geometry::Vec3>>,
        simd: bool,
        table_from: usize,
    ) -> Result<Bvh, SpecError> {
        use rayon::prelude::*;
        let (mut items, _) = items_of(prims.len(), |i| prims.bounds(i as usize));
        let wide::Wide {
            mut nodes,
            leaves,
            stats,
        } = builder.build_wide(&mut items);
        if leaves.len() >= 1 << LEAF_START_BITS {
            return Err(SpecError::Build(format!(
                "{} leaves: the bvh names at most 2^27-1; a larger `leaf` makes fewer",
                leaves.len()
            )));
        }
        // A leaf names its first entry where every start fits a reference (below
        // `table_from`, 2^27 but in a test), and its number in a table of starts beyond
        // (0.8 bytes a triangle at the default leaf size).
        let leaf_starts = if items.len() < table_from {
            wide::relabel_leaves(&mut nodes, |k| {
                wide::leaf_reference(leaves[k].count, leaves[k].start)
            });
            Vec::new()
        } else {
            leaves.iter().map(|l| l.start).collect()
        };
        drop(leaves);
        let order: Vec<u32> = items.par_iter().map(Item::slot).collect();
        drop(items);
        let filled = order.len();
        let store = PrimStore::indexed_in_order(prims, vertices, order);
        Ok(Bvh {
            nodes,
            blocks: Vec::new(),
            leaf_starts,
            indexed: true,
            simd: simd && super::simd::available() && store.simd_fits(),
            filled,
            store,
            others: false,
            leaf_size: settings.leaf,
            bins: settings.bins,
            spatial: settings.spatial,
            occlusion: settings.occlusion,
            stats,
        })
    }
}

impl Accel for Bvh {
    const NAME: &'static str = "bvh";
    const PACKETS_PAY: bool = true;
    const INTERLEAVES: bool = true;
    type Settings = BvhSettings;

    fn build_checked<P: Primitives>(prims: &P, settings: &BvhSettings) -> Result<Self, SpecError> {
        let BvhSettings {
            leaf: leaf_size,
            bins,
            traversal: traversal_cost,
            spatial,
            store: triangles,
            simd,
            occlusion,
        } = *settings;
        let n = prims.len();
        let budget = (spatial as f64 * n as f64) as usize;
        if budget > 0 && triangles == TriangleStorage::Index {
            return Err(SpecError::Build(
                "spatial splits clip copies of the triangles: store=index needs spatial=0".into(),
            ));
        }
        let builder = Builder {
            leaf_size,
            bins,
            traversal_cost,
        };
        let index = match triangles {
            TriangleStorage::Index => true,
            TriangleStorage::Copy => false,
            TriangleStorage::Auto => n >= INDEX_FROM && budget == 0,
        };
        // An item's store entry shares its spare lane with an exponent bit
        // ([`build::SLOT_EXPONENT`]).
        if n >= 1 << 30 {
            return Err(SpecError::Build(format!(
                "{n} primitives: the bvh holds at most 2^30-1"
            )));
        }
        if let Some(vertices) = index.then(|| indexed_mesh(prims)).flatten() {
            return Bvh::build_indexed(
                prims,
                settings,
                &builder,
                vertices,
                simd,
                1 << LEAF_START_BITS,
            );
        }
        // Blocks are named by a reference's 27 bits.
        if n + budget >= 1 << LEAF_START_BITS {
            return Err(SpecError::Build(format!(
                "{n} primitives and {budget} extra references: the bvh's blocks of copies hold \
                 at most 2^27-1 (an indexed mesh's leaves hold more, with store=index)"
            )));
        }
        // The blocks copy the triangles, so the store needs none of its own while the tree is
        // built: an indexed mesh's are read through its indices (24 bytes a triangle less at
        // the build's peak). Spatial splits clip the triangles from copies.
        let storage = if budget > 0 {
            TriangleStorage::Copy
        } else {
            TriangleStorage::Index
        };
        let store = PrimStore::build_with(prims, storage);
        use rayon::prelude::*;
        let (mut items, margin) = items_of(store.len(), |s| store.bounds(prims, s));
        let ext = extents(&items);
        // A leaf's items in store order ([`Builder::decide`]).
        let fill = |blocks: &mut [Block], items: &[Item]| {
            for (block, lanes) in blocks.iter_mut().zip(items.chunks(LANES)) {
                for (l, it) in lanes.iter().enumerate() {
                    let s = it.slot();
                    match store.triangle(s) {
                        Some(t) => block.set(l, &t, store.id(s)),
                        None => block.ids[l] = OTHER_LANE | s,
                    }
                }
            }
        };
        let (nodes, blocks, filled, stats) = if budget > 0 {
            let ctx = SpatialContext {
                tris: store.copied_triangles(),
                margin,
                root_area: ext.0.surface_area(),
            };
            let (root, items) = builder.build_spatial(&ctx, items, 0, budget);
            let root = root.rooted();
            let size = root.size();
            // Made in parallel: the pages are first touched on both threads.
            let mut nodes: Vec<Node> = (0..size.nodes)
                .into_par_iter()
                .map(|_| Node::EMPTY)
                .collect();
            let mut blocks = empty_blocks(size.blocks);
            let part = Part {
                nodes: &mut nodes,
                node_base: 0,
                blocks: &mut blocks,
                block_base: 0,
            };
            let (_, Flattened { filled, stats }) = flatten(&fill, &root, &items, 0, part);
            root.drop_in_parallel();
            (nodes, blocks, filled, stats)
        } else {
            let wide::Wide {
                mut nodes,
                leaves,
                stats,
            } = builder.build_wide(&mut items);
            // Each leaf's blocks, in the order of the leaves' numbers.
            let mut first_block = Vec::with_capacity(leaves.len());
            let mut total = 0u32;
            for l in &leaves {
                first_block.push(total);
                total += l.count.div_ceil(LANES as u32);
            }
            wide::relabel_leaves(&mut nodes, |k| {
                wide::leaf_reference(leaves[k].count.div_ceil(LANES as u32), first_block[k])
            });
            drop(first_block);
            let mut blocks = empty_blocks(total as usize);
            // Each leaf's blocks, in the order the leaves were numbered, filled side by side.
            let mut rest = blocks.as_mut_slice();
            let mut parts = Vec::with_capacity(leaves.len());
            for l in &leaves {
                let (start, count) = (l.start as usize, l.count as usize);
                let (mine, more) = std::mem::take(&mut rest).split_at_mut(count.div_ceil(LANES));
                parts.push((mine, &items[start..start + count]));
                rest = more;
            }
            parts.into_par_iter().for_each(|(b, it)| fill(b, it));
            (nodes, blocks, items.len(), stats)
        };
        let mut bvh = Bvh {
            nodes,
            blocks,
            filled,
            others: store.triangle_count() < store.len(),
            store,
            indexed: false,
            simd: false,
            leaf_starts: Vec::new(),
            leaf_size,
            bins,
            spatial,
            occlusion,
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
        self.walk(prims, ray, sink, counters);
    }

    fn query_packet<P: Primitives, C: Counters, S: HitSink>(
        &self,
        prims: &P,
        rays: &[Ray],
        sinks: &mut [S],
        counters: &mut C,
    ) {
        self.walk_packet(prims, rays, sinks, counters);
    }

    fn query_each<P: Primitives, C: Counters, S: HitSink>(
        &self,
        prims: &P,
        rays: &[Ray],
        sinks: &mut [S],
        counters: &mut C,
    ) {
        self.walk_stream(prims, rays, sinks, counters);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::NoCounters;
    use crate::geometry::{Ray, Vec3};
    use crate::scene::{Mesh, Scene};
    use rand::{Rng, SeedableRng};

    /// Past 2^27 entries an indexed leaf names its start through a table; forced here on a
    /// small mesh, the table gives every ray the hit the references themselves give.
    #[test]
    fn indexed_leaves_by_number_hit_as_by_start() {
        let mut r = rand_pcg::Pcg64Mcg::seed_from_u64(3);
        let mut p = |s: f32| Vec3::new(r.random(), r.random(), r.random()) * s;
        let vertices: Vec<Vec3> = (0..3000).map(|_| p(10.0)).collect();
        let triangles: Vec<[u32; 3]> = (0..1000u32)
            .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
            .collect();
        let scene = Scene::from_mesh(Mesh::new(vertices, triangles).unwrap());
        let settings = BvhSettings::default();
        let builder = Builder {
            leaf_size: settings.leaf,
            bins: settings.bins,
            traversal_cost: settings.traversal,
        };
        let build = |table_from| {
            let v = indexed_mesh(&scene).expect("an indexed mesh");
            Bvh::build_indexed(&scene, &settings, &builder, v, true, table_from).unwrap()
        };
        let (direct, table) = (build(1 << LEAF_START_BITS), build(0));
        assert!(direct.leaf_starts.is_empty());
        assert_eq!(table.leaf_starts.len(), table.stats.leaves);
        let mut hits = 0;
        for _ in 0..5000 {
            let ray = Ray::new(p(10.0), p(2.0) - Vec3::ONE, 0.0, f32::INFINITY);
            let want = direct.closest_hit(&scene, &ray, &mut NoCounters);
            assert_eq!(table.closest_hit(&scene, &ray, &mut NoCounters), want);
            hits += want.is_some() as usize;
        }
        assert!(hits > 1000, "{hits} hits");
    }
}
