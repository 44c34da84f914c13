//! Adaptive grid (Klimaszewski and Sederberg, IEEE CG&A 1997; RTNews "Comparison of
//! hierarchical grids", method c): objects clustered bottom-up, a BVH over the clusters, a
//! grid in every cluster, sub-voxel grids where a cell still holds too many objects.
//!
//! RTNews is the description at hand; where it is silent, hugrt chooses, as follows.
//!
//! 1. **Clustering** by a surface-area merge criterion: two candidates (objects or clusters)
//!    `A` and `B` merge when the box around both is no larger than their own boxes,
//!    `SA(A ∪ B) ≤ f · (SA(A) + SA(B))` (neighbours whose union adds little empty space), and
//!    the merged box is small beside the scene's, `diag(A ∪ B) ≤ m · diag(scene)`. The paper's
//!    nearest-candidate search is replaced by neighbours along the Morton order the primitive
//!    store already has: rounds of merging each candidate with the next one along that order
//!    (each at most once per round, so candidates of like size meet, as in a bottom-up tree),
//!    until a round merges nothing (at most 64 rounds: linear work per round).
//! 2. **Orphans**: clusters of fewer than `orphans` objects are not worth a grid; their
//!    objects share one orphan grid.
//! 3. **BVH** over the clusters' grids (and the orphan grid): the bvh's four-wide tree, build
//!    (binned SAH over the grids' boxes) and traversal ([`BoxTree`]), one grid per leaf;
//!    walked nearest child first, skipping nodes entered beyond the nearest hit. RTNews found
//!    interior nodes to have few children and gridded only the leaves; so does hugrt. (Until
//!    December 2026 the tree was binary, split at the median of the grids' centres.)
//! 4. **Grids**: each cluster gridded with `density` cells per object, cells as cubical as
//!    possible (the paper's heterogeneous local grids).
//! 5. **Sub-voxel grids**: a cell referencing more than `maxp` objects is gridded again
//!    ([`Subdivision`], the recursive grid's rule), down to `depth` levels below the
//!    clusters' grids.
//!
//! Every grid is walked with one ray state ([`GridHierarchy::walk`]: the hit sink, mailbox),
//! so an object tested in one sub-voxel grid is not tested again by its neighbour.
//!
//! Defaults, by measurement (`docs/measurements.md`, "The rival grids"): SPD rendering of
//! kitchen, garden, stadium, balls, tree, teapot, gears and lattice with ten settings; render
//! time over the best setting of each scene, geometric mean: `f = 1.5, m = 0.25` 1.66 (best),
//! `f = 1, m = 0.1` 1.77, `f = 2` 1.76, `maxp` 8 or 50 1.79/1.76, `density = 2` 1.80,
//! `orphans = 32` 2.05. No setting is best everywhere (`f = 1` on balls and tree, `orphans =
//! 32` on the kitchen). Where the adaptive grid lost to the HUG (1.7× slower, geometric
//! mean) was the binary BVH over many small clusters: 14–45 box tests per ray. The four-wide
//! SAH tree cut the bunny's incoherent rays from 4,508 to 2,825 instructions a ray (box
//! tests 21.1 to 15.2) and raised their rate 1.41×, camera rays' 1.33×
//! (docs/measurements.md, "Queries").

use super::bvh::BoxTree;
use super::grid::{PRUNE_HELP, SIMD_HELP, store_with_boxes};
use super::hierarchy::{GridHierarchy, GridPlan, LevelView, Prune, Resolution, Subdivision};
use super::query::{OCCLUSION_HELP, Occlusion};
use super::settings::{Key, Settings, key};
use super::simd::Simd;
use super::store::{TriangleStorage, finite};
use super::{Accel, CellCensus, Counters, HitSink, Mailbox, Primitives, SpecError, StructureStats};
use crate::geometry::{Aabb, PreparedRay, Ray};

/// The settings of an adaptive grid (`agrid:f=..,m=..`, ...).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdaptiveSettings {
    /// Merge two candidates when their union's box area is at most `f` times the sum of
    /// theirs.
    pub f: f32,
    /// Largest cluster diagonal as a share of the scene's.
    pub m: f32,
    /// Clusters of fewer objects go to the one orphan grid.
    pub orphans: usize,
    /// Cells per object in every grid.
    pub density: f32,
    /// A cell referencing more objects gets a sub-voxel grid.
    pub maxp: usize,
    /// Levels of sub-voxel grids below the clusters' grids (at most 15).
    pub depth: usize,
    pub prune: Prune,
    /// Which vector instructions the walks and the triangle tests may use ([`Simd`]).
    pub simd: Simd,
    /// Where occlusion queries walk a ray from ([`Occlusion`]).
    pub occlusion: Occlusion,
}

impl Settings for AdaptiveSettings {
    const KEYS: &'static [Key<Self>] = &[
        key!("f", f: f32, 0.0..=1000.0, "merge two candidates when their union's box area is at most f times the sum of theirs"),
        key!("m", m: f32, 0.0..=1.0, "largest cluster diagonal as a share of the scene's"),
        key!("orphans", orphans: usize, 1..=1 << 30, "clusters of fewer objects go to the one orphan grid"),
        key!("density", density: f32, 0.001..=1000.0, "cells per object in every grid"),
        key!("maxp", maxp: usize, 1..=1_000_000, "a cell referencing more objects gets a sub-voxel grid"),
        key!("depth", depth: usize, 0..=15, "levels of sub-voxel grids below the clusters' grids"),
        key!("prune", prune: Prune, (), PRUNE_HELP),
        key!("simd", simd: Simd, (), SIMD_HELP),
        key!("occlusion", occlusion: Occlusion, (), OCCLUSION_HELP),
    ];
}

impl Default for AdaptiveSettings {
    fn default() -> Self {
        AdaptiveSettings {
            f: 1.5,
            m: 0.25,
            orphans: 8,
            density: 1.0,
            maxp: 16,
            depth: 1,
            prune: Prune::None,
            simd: Simd::Widest,
            occlusion: Occlusion::Auto,
        }
    }
}

pub struct AdaptiveGrid {
    grids: GridHierarchy,
    /// The tree over the grids, an entry a grid.
    tree: BoxTree,
    settings: AdaptiveSettings,
    clusters: usize,
    orphans: usize,
    prims: usize,
}

impl AdaptiveGrid {
    /// Clusters the store entries with a finite box (module documentation, step 1): ranges of
    /// `order`, the finite entries in store (Morton) order.
    fn cluster(
        boxes: &[Aabb],
        order: &[u32],
        f: f32,
        max_diagonal: f32,
    ) -> Vec<std::ops::Range<usize>> {
        let mut candidates: Vec<(Aabb, std::ops::Range<usize>)> = order
            .iter()
            .enumerate()
            .map(|(k, &s)| (boxes[s as usize], k..k + 1))
            .collect();
        for _ in 0..64 {
            let mut next = Vec::with_capacity(candidates.len());
            let mut k = 0;
            while k < candidates.len() {
                if let Some((b, r)) = candidates.get(k + 1) {
                    let a = &candidates[k];
                    let u = a.0.union(b);
                    if u.surface_area() <= f * (a.0.surface_area() + b.surface_area())
                        && u.diagonal() <= max_diagonal
                    {
                        next.push((u, a.1.start..r.end));
                        k += 2;
                        continue;
                    }
                }
                next.push(candidates[k].clone());
                k += 1;
            }
            let merged = next.len() < candidates.len();
            candidates = next;
            if !merged {
                break;
            }
        }
        candidates.into_iter().map(|(_, r)| r).collect()
    }
}

impl Accel for AdaptiveGrid {
    const NAME: &'static str = "agrid";
    type Settings = AdaptiveSettings;

    fn build_checked<P: Primitives>(
        prims: &P,
        settings: &AdaptiveSettings,
    ) -> Result<Self, SpecError> {
        let settings = *settings;
        let prune = settings.prune;
        let n = prims.len();
        let (store, boxes) = store_with_boxes(prims, TriangleStorage::Copy)?;
        let order: Vec<u32> = (0..n as u32)
            .filter(|&s| finite(&boxes[s as usize]))
            .collect();
        let scene = order
            .iter()
            .fold(Aabb::EMPTY, |a, &s| a.union(&boxes[s as usize]));
        let clusters = Self::cluster(&boxes, &order, settings.f, settings.m * scene.diagonal());
        let per_object = Resolution::Cubical(settings.density as f64);
        let plan = |objects: Vec<u32>| GridPlan {
            resolution: per_object.for_objects(objects.len()),
            objects,
            children: Vec::new(),
            frame: None,
            depth: 0,
            level: 0,
            scene_box: false,
            shift: true,
        };
        let mut orphans = Vec::new();
        let mut plans = Vec::new();
        for r in clusters {
            if r.len() < settings.orphans {
                orphans.extend_from_slice(&order[r]);
            } else {
                plans.push(plan(order[r].to_vec()));
            }
        }
        let clusters = plans.len();
        let orphan_count = orphans.len();
        if !orphans.is_empty() {
            plans.push(plan(orphans));
        }
        let sub = Subdivision {
            maxp: settings.maxp,
            max_depth: settings.depth as u32,
            // The adaptive grid's sub-voxel grids keep hugrt's guard (`Subdivision`).
            guard: true,
            cells: per_object,
        };
        let grids = GridHierarchy::build(
            prims,
            store,
            Some(boxes),
            &plans,
            prune,
            Some(sub),
            settings.simd,
        )?;
        let tops: Vec<Aabb> = (0..plans.len()).map(|g| grids.grid_box(g)).collect();
        Ok(AdaptiveGrid {
            grids,
            tree: BoxTree::build(&tops),
            settings,
            clusters,
            orphans: orphan_count,
            prims: n,
        })
    }

    fn query<P: Primitives, C: Counters, S: HitSink>(
        &self,
        prims: &P,
        ray: &Ray,
        sink: &mut S,
        counters: &mut C,
    ) {
        let pr = PreparedRay::new(ray);
        let mut mail = Mailbox::default();
        self.tree.walk(ray, sink, counters, |g, sink, counters| {
            self.grids
                .walk::<P, C, S>(g, prims, &pr, ray.tmin, sink, &mut mail, counters)
        });
    }

    fn reach(&self) -> &crate::accel::Reach {
        self.grids.store.reach()
    }

    fn occlusion(&self) -> Occlusion {
        self.settings.occlusion
    }

    fn memory_bytes(&self) -> usize {
        std::mem::size_of::<Self>() + self.grids.memory_bytes() + self.tree.memory_bytes()
    }

    fn stats(&self) -> StructureStats {
        let levels = self.grids.level_stats(LevelView::Level);
        let a = &self.settings;
        let mut s = StructureStats::default();
        s.push("f", a.f as f64);
        s.push("m", a.m as f64);
        s.push("orphan_threshold", a.orphans as f64);
        s.push("density", a.density as f64);
        s.push("maxp", a.maxp as f64);
        s.push("depth_limit", a.depth as f64);
        s.push("clusters", self.clusters as f64);
        s.push("orphans", self.orphans as f64);
        s.push("bvh_nodes", self.tree.node_count() as f64);
        s.push("grids", self.grids.grid_count() as f64);
        s.push("depth", levels.len() as f64);
        s.push("cells", self.grids.cell_count() as f64);
        s.push("references", self.grids.reference_count() as f64);
        let object_refs: usize = levels.iter().map(|l| l.object_refs).sum();
        s.push(
            "references_per_object",
            object_refs as f64 / self.prims.max(1) as f64,
        );
        s.push_memory(
            self.grids.grid_memory_bytes() + self.tree.memory_bytes(),
            self.memory_bytes(),
            self.prims,
        );
        s.census = CellCensus::of_levels(&levels);
        s.levels = levels;
        s
    }
}
