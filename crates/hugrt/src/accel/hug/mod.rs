//! The Hierarchy of Uniform Grids (Cazals, Drettakis and Puech, EG95; Cazals and Puech,
//! SCG97): built bottom-up by
//!
//! 1. **filtering** the objects by size ([`filter`]: EG95's `k` levels of equal counts, or
//!    SCG97's two levels split at a fraction of the largest length, by default moved into a
//!    gap of the lengths above it);
//! 2. **clustering** each level's objects with their neighbours ([`cluster`]: EG95's
//!    `Isolate`/`Cluster3d` on the projections, or SCG97's components of the
//!    box-intersection graph);
//! 3. **gridding** each cluster with about one cell per item, cells as cubical as possible
//!    (or SCG97's heterogeneous gridding), the world grid with more (EG95's `2N`, SCG97's
//!    `√2` criterion);
//! 4. **inserting** each cluster's grid, largest levels first, into the cells of the deepest
//!    grid that contains it, like an object (EG95 §2.3.1).
//!
//! The result is a hierarchy of grids (`GridHierarchy`); its walk carries one ray state (the hit sink, mailboxes
//! for objects and for grids referenced from several cells) through every level (EG95
//! §2.3.2), and is the same code as the uniform grid's.
//!
//! # The papers' presets and hugrt's departures
//! `preset=eg95` and `preset=scg97` ([`EG95`], [`SCG97`]) are the papers' algorithms, each
//! setting cited. hugrt's defaults ([`DEFAULTS`]) depart from them where that measured better,
//! each departure a key: SCG97's split moved up into an empty octave of the sizes where it
//! falls among many (`filter=gap`), the graph clustering with δ = 0.5·(the level's mean length) and
//! crowded cells joined untested (`alpha`, `crowd`), finer grids (`world`, `density`), cells
//! as cubical as possible (`cells`), shifted planes (`shift`), pruning of large objects
//! (`prune`), grids referenced only below the deepest grid containing them (`insert`), and
//! small and loose clusters given back (`giveback`, below).
//!
//! # Small and loose clusters
//! SCG97 §7.5 leaves open what to do with tiny clusters ("is a cluster of 5 polygons still a
//! cluster?"), and §7.1 diagnoses loose ones by their volume. hugrt (`giveback=true`, the
//! default; the presets grid every cluster) gives both back to the grid they would have been
//! inserted into, whose objects they become: a cluster of fewer than
//! `min_cluster` objects, and a cluster whose box fills more than `loose` of that grid's
//! volume. On a scene without clusters (a scanned mesh) every level's single cluster is
//! loose, and the HUG becomes the uniform grid it should be; with one huge object among many
//! tiny far-apart ones (EG95 §4.1's failure case), the singletons go back to the world grid
//! instead of filling its cells with thousands of sub-grids.

mod build;
pub mod cluster;
pub mod filter;

pub use build::{CellShape, Clustering, Insertion, Recipe, WorldCells};
pub use filter::Filter;

use super::Prune;
use super::grid::{PRUNE_HELP, SHIFT_HELP, SIMD_HELP, store_with_boxes};
use super::hierarchy::{GridHierarchy, LevelView};
use super::query::{OCCLUSION_HELP, Occlusion};
use super::settings::{Key, Settings, key};
use super::simd::Simd;
use super::store::{STORAGE_HELP, TriangleStorage};
use super::{Accel, CellCensus, Counters, HitSink, Preset, Primitives, SpecError, StructureStats};
use crate::geometry::Ray;

/// The defaults of `hug` with no keys, chosen by measurement: every variant rendered (SPD
/// procedure) over the 11 SPD scenes, the 5 yardstick meshes and the 7 generated scenes,
/// against the uniform grid at densities 1 to 20 (`docs/measurements.md`, "The HUG's
/// defaults", has the table and how to regenerate it). The defaults were then never more
/// than 8% behind the best grid density, which differs from scene to scene (2 to 20), and
/// 1.4 to 80 times faster where objects cluster. Since packets (issue 19; "The HUG's build,
/// and the sweep again"), four scenes fall further behind at 512²: lattice 1.14, nefertiti
/// 1.12, the terrain 1.21 and the four kitchens 1.49, three of them by their build. One key
/// at a time, over all scenes (worst ratio to the best grid; geometric mean at 512²):
///
/// * `filter`: SCG97's two levels at 5% of the longest object, the split moved up into an
///   empty octave of the lengths where 5% falls among many of them (`filter=gap`, hugrt's:
///   [`Filter::Gap`]). SCG97's own split (`filter=two`) cut gears' 36,608 small polygons in
///   two and put 8,066 of them in the world grid: the gap walks gears 1.31–1.41× faster at
///   512² and balls 1.06–1.11×, and changes no other SPD scene or mesh. EG95's three
///   equal-count levels (`filter=levels`: worst 1.89, mean 1.17) cut a scene's detail across
///   sizes, so the tree of SPD tree and the sphereflake of balls fall apart into tiny
///   clusters.
/// * `cluster`: the components of boxes closer than δ = 0.5·(the level's mean length).
///   Cluster3d's projections join a ring of stadium tiers with the objects it encloses
///   (stadium 28 s with `cluster=cluster3d`, 0.4 s with the graph); joining boxes only when
///   they touch (α = 0) splits heaps of separate small objects into hundreds of grids (balls,
///   room 1.5–2× slower at 512² in an earlier sweep); α from 0.1 to 1 performed alike.
/// * `world`: 4 cells per item, `density`: 2 per item in clusters. The papers' 2N (EG95
///   §2.2.3) and 2.83N (SCG97 §1.3) and one cell per cluster item were chosen when a cell
///   step cost more relative to a triangle test; with the walk here (DDA state in
///   registers, eight triangles tested at once) finer grids pay: `world=16` 1.24 (gears),
///   `density=1` 1.29 (city). The world grid had 8 cells an item until camera and shadow
///   rays went through the grids 32 at a time (issue 19), which cross a fine grid's slices
///   one by one where single rays step cell by cell: since, `world=8` is up to 1.35 behind
///   the best grid density on the meshes (nefertiti; the build is a third of a 512²
///   render), `world=4` at most 1.14 (nefertiti) and 1.12 (lattice), `world=2` 1.49
///   (lattice); a later sweep had `world=6` at 1.00 on lattice but 1.10–1.20 on the meshes,
///   and 4 at 1.14 and 1.04–1.21 (the terrain's build, 524,288 triangles); incoherent rays
///   trace alike at 4 and 8 (bunny, nefertiti, city ±4%, kitchen 5% slower at 4). With
///   offsets kept for occupied cells only, the finer grids cost a few bytes per primitive
///   more than the papers' settings. Where the world grid holds nine tenths of the objects or
///   more (one size class, or a small cluster beside it) and their boxes leave more than half
///   of its cells empty at one cell an item (a surface: the bunny, nefertiti, the big SPD
///   terrain, teapot and tetra, the generated terrain, SPD mount, sombrero, teapot and
///   tetra), it gets one cell an item (`world=auto`, [`WorldCells::Auto`]): the bunny's and
///   the big terrain's 512² renders were 1.14 behind the best grid density by their build
///   alone, and come to 1.06 and 1.08; nefertiti's 1.13–1.15 came to 1.08–1.11; SPD mount's
///   1.06–1.11 came to 0.96–1.00. Where their boxes fill the grid instead, it gets the
///   density among 1 to 32 whose estimated cost per unit of a ray's length is least
///   (`hierarchy::plan::filled_density`): random triangles, tested eight at a time, get 1
///   (soups of 50,000 and 200,000 were 1.32–1.52 behind the best grid at 4, now 0.99–1.05);
///   SPD jacks 2; SPD lattice keeps 4 (the estimate is flat from 2 to 32 there, where the
///   renders favour 8 to 32 by up to 10%: rods aligned with the cells, whose boxes of
///   contents cull more tests than boxes counted over the cells show).
/// * `prune`: large objects only (box over 16 cells or more); `prune=false` worst 1.27 (gears'
///   slivers), and testing every object costs build time for nothing on meshes.
/// * `min_cluster` 16 and `loose` 0.25: `min_cluster=1` worst 1.39, `min_cluster=64` 1.43,
///   `loose=1e30` 1.38 (nefertiti, city, rings: single-level scenes where a loose cluster only
///   adds a walk).
/// * `pca` and `hetero` off: as SCG97 reports, neither pays (worst 1.26 and, on SPD shells,
///   1.55).
pub const DEFAULTS: HugSettings = HugSettings {
    filter: FilterRule::Gap,
    levels: 3,
    fraction: 0.05,
    cluster: ClusterRule::Graph,
    alpha: 0.5,
    crowd: Some(cluster::CROWD),
    world: WorldCells::Auto,
    density: 2.0,
    refine: true,
    cells: CellShape::Cubical,
    giveback: true,
    min_cluster: 16,
    loose: 0.25,
    pca: false,
    hetero: false,
    insert: Insertion::Contained,
    prune: Prune::Large,
    shift: true,
    simd: Simd::Widest,
    store: TriangleStorage::Auto,
    occlusion: Occlusion::Auto,
};

/// How objects are filtered by size (step 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FilterRule {
    /// EG95: `levels` levels of equal counts.
    Levels,
    /// SCG97 §7.1: two levels split at `fraction` of the longest object.
    Two,
    /// hugrt's: two levels split at `fraction` of the longest object, moved into an empty
    /// octave of the lengths where that cuts through a crowd of them ([`Filter::Gap`]).
    Gap,
}

crate::accel::settings::choice_value!(FilterRule { FilterRule::Levels => "levels", FilterRule::Two => "two", FilterRule::Gap => "gap" });

/// How each level's objects are clustered (step 2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ClusterRule {
    /// EG95: `Isolate`/`Cluster3d` on the projections.
    Cluster3d,
    /// SCG97 §7.4: components of the box-intersection graph.
    Graph,
}

crate::accel::settings::choice_value!(ClusterRule {
    ClusterRule::Cluster3d => "cluster3d",
    ClusterRule::Graph => "graph",
});
crate::accel::settings::choice_value!(CellShape { CellShape::Cubical => "cubical", CellShape::CubeRoot => "cube-root" });
crate::accel::settings::choice_value!(Insertion { Insertion::Contained => "contained", Insertion::Fig9 => "fig9" });

/// `world=auto|2n|sqrt2|D`.
impl crate::accel::settings::Value for WorldCells {
    type Range = ();
    fn parse(text: &str, _: &()) -> Result<Self, String> {
        match text {
            "auto" => Ok(WorldCells::Auto),
            "2n" => Ok(WorldCells::TwoN),
            "sqrt2" => Ok(WorldCells::Sqrt2),
            _ => f32::parse(text, &(0.001..=1000.0))
                .map(WorldCells::Density)
                .map_err(|_| "expected auto, 2n, sqrt2 or cells per item (0.001..1000)".into()),
        }
    }
    fn show(&self, _: &()) -> String {
        match self {
            WorldCells::TwoN => "2n".into(),
            WorldCells::Sqrt2 => "sqrt2".into(),
            WorldCells::Density(d) => d.to_string(),
            WorldCells::Auto => "auto".into(),
        }
    }
    fn accepts(_: &()) -> String {
        "auto|2n|sqrt2|0.001..1000".into()
    }
}

/// The HUG's settings, one field a key (`hug:filter=..,levels=..`, ...); [`DEFAULTS`] are
/// its defaults, [`EG95`] and [`SCG97`] its presets.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HugSettings {
    pub filter: FilterRule,
    /// `filter=levels`: how many (EG95: 3).
    pub levels: usize,
    /// `filter=two|gap`: objects under this fraction of the longest form the lower level
    /// (SCG97: 0.05), for `gap` unless an empty octave of the lengths lies above it.
    pub fraction: f32,
    pub cluster: ClusterRule,
    /// δ = α·(the level's mean length): projections (cluster3d) or boxes (graph) closer than
    /// δ join (EG95: 0.01).
    pub alpha: f32,
    /// `cluster=graph`: objects sharing a binning cell with more than this many are joined
    /// untested (hugrt's); `None` tests every pair (SCG97).
    pub crowd: Option<usize>,
    /// Cells of the world grid.
    pub world: WorldCells,
    /// Cells per item of a cluster grid (EG95: 1).
    pub density: f32,
    /// More cells than `density` for a cluster grid of objects whose tests are dear, where
    /// the estimate of a ray's cost says so (hugrt's; `build::plan`).
    pub refine: bool,
    pub cells: CellShape,
    /// Small (`min_cluster`) and loose clusters go back to the enclosing grid (hugrt's).
    pub giveback: bool,
    /// `giveback`: clusters of fewer objects are given back.
    pub min_cluster: usize,
    /// `giveback`: clusters filling more than this share of the enclosing grid's volume are
    /// given back.
    pub loose: f32,
    /// Grid a cluster in the frame of its principal axes when that box is smaller (SCG97
    /// §7.2).
    pub pca: bool,
    /// Cells per axis from the overlap numbers of the projections (SCG97 §7.3).
    pub hetero: bool,
    pub insert: Insertion,
    pub prune: Prune,
    /// Cell planes moved off the box's round fractions (hugrt's).
    pub shift: bool,
    /// Which vector instructions the walks and the triangle tests may use ([`Simd`]).
    pub simd: Simd,
    /// How the store holds an indexed mesh's triangles.
    pub store: TriangleStorage,
    /// Where occlusion queries walk a ray from ([`Occlusion`]).
    pub occlusion: Occlusion,
}

impl Default for HugSettings {
    fn default() -> Self {
        DEFAULTS
    }
}

impl Settings for HugSettings {
    const KEYS: &'static [Key<Self>] = &[
        key!("filter", filter: FilterRule, (), "levels (EG95: equal-count size levels), two (SCG97: split at a fraction of the largest) or gap (hugrt's: that split moved up into an empty octave of the sizes where it falls among many)"),
        key!("levels", levels: usize, 1..=16, "number of size levels for filter=levels (EG95: 3)"),
        key!("fraction", fraction: f32, 1e-6..=1.0, "filter=two|gap: objects under this fraction of the largest length form the lower level (SCG97: 0.05)"),
        key!("cluster", cluster: ClusterRule, (), "cluster3d (EG95: Isolate/Cluster3d on projections) or graph (SCG97: box-intersection components)"),
        key!("alpha", alpha: f32, 0.0..=100.0, "delta = alpha * the level's mean length; projections (cluster3d) or boxes (graph) closer than delta join (EG95: 0.01)"),
        key!("crowd", crowd: Option<usize>, (1..=1 << 30, "off"), "cluster=graph: objects sharing a binning cell with more than this many are joined untested (hugrt's), or off: every pair tested (SCG97)"),
        key!("world", world: WorldCells, (), "cells of the world grid: auto (4 per item; where it holds 90% of the objects, 1 if they leave it mostly empty, else 1 to 32 by an estimate of a ray's cost), 2n (EG95), sqrt2 (SCG97) or cells per item"),
        key!("density", density: f32, 0.001..=1000.0, "cells per item of a cluster grid (EG95: 1)"),
        key!("refine", refine: bool, (), "true: a cluster grid holding objects other than triangles gets more cells an item than density where the estimate of a ray's cost says their tests are dear (hugrt's); false: density for every cluster grid (the papers)"),
        key!("cells", cells: CellShape, (), "cubical: cells as cubical as possible (hugrt's); cube-root: as many on every axis (EG95, SCG97)"),
        key!("giveback", giveback: bool, (), "true: small (min_cluster) and loose clusters go back to the enclosing grid (hugrt's); false: every cluster is gridded (the papers)"),
        key!("min_cluster", min_cluster: usize, 1..=1 << 30, "giveback: clusters of fewer objects are given back to the enclosing grid"),
        key!("loose", loose: f32, 0.0..=1e30, "giveback: clusters filling more than this share of the enclosing grid's volume are given back to it"),
        key!("pca", pca: bool, (), "true: grid a cluster in the frame of its principal axes when that box is smaller (SCG97 7.2)"),
        key!("hetero", hetero: bool, (), "true: cells per axis from the overlap numbers of the projections (SCG97 7.3)"),
        key!("insert", insert: Insertion, (), "contained (reference a grid below the deepest grid containing it) or fig9 (also in grids it overlaps)"),
        key!("prune", prune: Prune, (), PRUNE_HELP),
        key!("shift", shift: bool, (), SHIFT_HELP),
        key!("simd", simd: Simd, (), SIMD_HELP),
        key!("store", store: TriangleStorage, (), STORAGE_HELP),
        key!("occlusion", occlusion: Occlusion, (), OCCLUSION_HELP),
    ];
    const PRESETS: &'static [Preset] = &[EG95, SCG97];
}

impl HugSettings {
    /// The build's view of these settings: the filter and the clustering with their
    /// parameters, the rest as they are.
    pub fn recipe(&self) -> Recipe {
        Recipe {
            filter: match self.filter {
                FilterRule::Levels => Filter::Levels(self.levels),
                FilterRule::Two => Filter::Two(self.fraction),
                FilterRule::Gap => Filter::Gap(self.fraction),
            },
            clustering: match self.cluster {
                ClusterRule::Cluster3d => Clustering::Cluster3d { alpha: self.alpha },
                ClusterRule::Graph => Clustering::Graph {
                    alpha: self.alpha,
                    crowd: self.crowd,
                },
            },
            world: self.world,
            density: self.density,
            refine: self.refine,
            cells: self.cells,
            shift: self.shift,
            give_back: self.giveback,
            min_cluster: self.min_cluster,
            loose: self.loose,
            pca: self.pca,
            hetero: self.hetero,
            insertion: self.insert,
        }
    }
}

/// EG95's HUG (`hug:preset=eg95`), step for step. What hugrt's defaults change, each a key:
/// the filter, the clustering and its α, the cells' shape and count, shifted planes, the
/// insertion, give-back and pruning.
pub const EG95: Preset = Preset {
    name: "eg95",
    pairs: &[
        (
            "filter",
            "levels",
            "EG95 §2.1: slices of the length histogram holding equal counts",
        ),
        ("levels", "3", "EG95 §2.1: a three-level filter"),
        (
            "cluster",
            "cluster3d",
            "EG95 §2.2.2: Isolate and Cluster3d on the projections",
        ),
        (
            "alpha",
            "0.01",
            "EG95 §2.2: delta_k = 0.01 of the level's average length",
        ),
        (
            "density",
            "1",
            "EG95 §2.2.3: a cluster of n objects gets n voxels",
        ),
        (
            "refine",
            "false",
            "EG95 §2.2.3: every cluster by the same rule",
        ),
        (
            "world",
            "2n",
            "EG95 §2.2.3: 2n voxels for the cluster of the largest objects",
        ),
        (
            "cells",
            "cube-root",
            "EG95 §2.2.3: n_x = n_y = n_z (the cube-root criterion)",
        ),
        (
            "insert",
            "fig9",
            "EG95 §2.3.1 and Fig. 9: a grid is referenced by every grid it meets",
        ),
        ("giveback", "false", "EG95 §2.3.1: every cluster is gridded"),
        ("shift", "false", "EG95's grids start at their box"),
        (
            "prune",
            "false",
            "EG95 §2: objects are their bounding boxes",
        ),
        ("pca", "false", "EG95: axis-aligned boxes"),
        ("hetero", "false", "EG95: the cube-root criterion"),
        (
            "occlusion",
            "start",
            "EG95 §2.3.2: every ray is walked from its origin",
        ),
    ],
};

/// SCG97's improved HUG (`hug:preset=scg97`), step for step: §7.1's two-level filter, §7.4's
/// clusters, §1.3's √2 world grid; the rest as EG95, which SCG97 builds on (§1.3).
pub const SCG97: Preset = Preset {
    name: "scg97",
    pairs: &[
        ("filter", "two", "SCG97 §7.1: a two-level filter"),
        (
            "fraction",
            "0.05",
            "SCG97 §7.1: objects under 5% of the biggest form the lower level",
        ),
        (
            "cluster",
            "graph",
            "SCG97 §7.4 Def. 5: components of the box-intersection graph",
        ),
        (
            "alpha",
            "0",
            "SCG97 §7.4 Def. 5: an arc where two boxes intersect",
        ),
        (
            "crowd",
            "off",
            "SCG97 §7.4: every intersecting pair is an arc",
        ),
        (
            "density",
            "1",
            "SCG97 §1.3: a cluster of N objects gets N voxels",
        ),
        (
            "refine",
            "false",
            "SCG97 §1.3: every cluster by the same rule",
        ),
        (
            "world",
            "sqrt2",
            "SCG97 §1.3: the sqrt(2) criterion, sqrt(2)*cbrt(N) per axis",
        ),
        (
            "cells",
            "cube-root",
            "SCG97 §1.3: alpha*cbrt(N) subdivisions along each axis",
        ),
        (
            "insert",
            "fig9",
            "SCG97 §1.3: every voxel a lower grid meets points to it",
        ),
        (
            "giveback",
            "false",
            "SCG97 §7.5 leaves small clusters open: each is gridded",
        ),
        ("shift", "false", "the papers' grids start at their box"),
        (
            "prune",
            "false",
            "SCG97 §1.3: objects are their bounding boxes",
        ),
        ("pca", "false", "SCG97 §7.2: PCA boxes did not pay"),
        (
            "hetero",
            "false",
            "SCG97 §7.3: no heterogeneous gridding paid",
        ),
        (
            "occlusion",
            "start",
            "SCG97 §1.3 walks as EG95 §2.3.2: every ray from its origin",
        ),
    ],
};

pub struct Hug {
    grids: GridHierarchy,
    report: build::Report,
    prims: usize,
    prune: Prune,
    settings: HugSettings,
}

impl Hug {
    /// The settings this HUG was built with.
    pub fn built_settings(&self) -> &HugSettings {
        &self.settings
    }
}

impl Accel for Hug {
    const NAME: &'static str = "hug";
    const PACKET_RAYS: usize = crate::accel::hierarchy::GRID_PACKET;
    const PACKETS_PAY: bool = true;
    const ORDER_PAYS: bool = true;
    type Settings = HugSettings;

    fn build_checked<P: Primitives>(prims: &P, settings: &HugSettings) -> Result<Self, SpecError> {
        let prune = settings.prune;
        let recipe = settings.recipe();
        let n = prims.len();
        let (store, boxes) = store_with_boxes(prims, settings.store)?;
        let (plans, report) = build::plan(&store, &boxes, &recipe);
        let grids = GridHierarchy::build(
            prims,
            store,
            Some(boxes),
            &plans,
            prune,
            None,
            settings.simd,
        )?;
        Ok(Hug {
            grids,
            report,
            prims: n,
            prune,
            settings: *settings,
        })
    }

    // Inlined into the batch's loop: left as a call per ray once the batch code around it
    // changed, +0.9% instructions a ray (cachegrind, the bunny's incoherent rays).
    #[inline]
    fn query<P: Primitives, C: Counters, S: HitSink>(
        &self,
        prims: &P,
        ray: &Ray,
        sink: &mut S,
        counters: &mut C,
    ) {
        self.grids.query(prims, ray, sink, counters);
    }

    fn query_packet<P: Primitives, C: Counters, S: HitSink>(
        &self,
        prims: &P,
        rays: &[Ray],
        sinks: &mut [S],
        counters: &mut C,
    ) {
        self.grids.query_packet(prims, rays, sinks, counters);
    }

    fn reach(&self) -> &crate::accel::Reach {
        self.grids.store.reach()
    }

    fn occlusion(&self) -> Occlusion {
        self.settings.occlusion
    }

    fn memory_bytes(&self) -> usize {
        std::mem::size_of::<Self>() + self.grids.memory_bytes()
    }

    fn stats(&self) -> StructureStats {
        let levels = self.grids.level_stats(LevelView::Level);
        let depths = self.grids.level_stats(LevelView::Depth);
        let census = CellCensus::of_levels(&levels);
        let mut s = StructureStats::default();
        s.push("filter_levels", self.report.levels as f64);
        s.push("clusters_found", self.report.clusters as f64);
        s.push("crowded_cells_joined", self.report.crowded_cells as f64);
        s.push("given_back_small", self.report.given_back_small as f64);
        s.push("given_back_loose", self.report.given_back_loose as f64);
        s.push("turned_grids", self.report.turned as f64);
        s.push("partial_insertions", self.report.partial_insertions as f64);
        s.push("grids", self.grids.grid_count() as f64);
        s.push("depth", depths.len() as f64);
        s.push("cells", self.grids.cell_count() as f64);
        s.push("references", self.grids.reference_count() as f64);
        // Object references only, as the grid's: the references above count sub-grids too.
        s.push(
            "references_per_object",
            census.object_refs as f64 / self.prims.max(1) as f64,
        );
        s.push("sum_pct_vol", levels.iter().map(|l| l.pct_vol).sum::<f64>());
        s.push("prune", self.prune.stat_value());
        s.push_memory(
            self.grids.grid_memory_bytes(),
            self.memory_bytes(),
            self.prims,
        );
        s.census = census;
        s.levels = levels;
        s.depths = depths;
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Objects without a finite box are binned nowhere and the others planned as always (the
    /// planning lists the finite ones only when there are others).
    #[test]
    fn objects_without_a_finite_box_leave_the_others_found() {
        use crate::geometry::Vec3;
        let mut tris: Vec<[Vec3; 3]> = (0..400)
            .map(|i| {
                let c = Vec3::new((i % 20) as f32, (i / 20) as f32, (i % 7) as f32 * 0.1);
                [c, c + Vec3::X * 0.8, c + Vec3::Y * 0.8]
            })
            .collect();
        for k in [0, 57, 399] {
            tris[k][1].y = if k == 57 { f32::INFINITY } else { f32::NAN };
        }
        let mut scene = crate::scene::Scene::from_triangles(tris);
        // Spheres come after every triangle in store order, the unbounded ones included: the
        // planning must map the finite objects past them to their own entries.
        scene.shapes = (0..60)
            .map(|i| {
                crate::geometry::Shape::Sphere(crate::geometry::Sphere {
                    center: Vec3::new((i % 10) as f32 * 2.0, (i / 10) as f32 * 3.0, 2.0),
                    radius: 0.7,
                })
            })
            .collect();
        let mut b = scene.bounds();
        b = crate::geometry::Aabb::new(b.min.min(Vec3::ZERO), b.max.max(Vec3::splat(20.0)));
        let rays = crate::batch::incoherent_rays(&b, 2_000, 5);
        crate::fuzzing::assert_all_agree(
            &scene,
            &[
                "hug",
                "hug:min_cluster=1,loose=1e30,filter=levels",
                "grid",
                "bvh",
            ],
            &rays,
        );
    }

    /// `world=auto` weighs one cell an item for a surface whose world grid holds nearly all
    /// the objects, even beside a small cluster grid (nefertiti's 16 triangles, the big
    /// teapot's 202), and keeps four where the clusters hold more than a tenth of them.
    #[test]
    fn a_surface_beside_a_small_cluster_gets_one_cell_an_item() {
        use crate::accel::hierarchy::Resolution;
        use crate::geometry::Vec3;
        let world_cells = |cluster: usize| {
            // A sheet of 40 × 40 squares (3,200 triangles) and, above it, a row of `cluster`
            // triangles a thousandth of their size, touching: one cluster of a lower level.
            let mut tris: Vec<[Vec3; 3]> = (0..1600)
                .flat_map(|i| {
                    let c = Vec3::new((i % 40) as f32, (i / 40) as f32, 0.0);
                    let (x, y, xy) = (c + Vec3::X, c + Vec3::Y, c + Vec3::X + Vec3::Y);
                    [[c, x, y], [x, xy, y]]
                })
                .collect();
            tris.extend((0..cluster).map(|i| {
                let c = Vec3::new(20.0 + i as f32 * 1e-3, 20.0, 5.0);
                [c, c + Vec3::X * 1e-3, c + Vec3::Y * 1e-3]
            }));
            let scene = crate::scene::Scene::from_triangles(tris);
            let (store, boxes) = store_with_boxes(&scene, TriangleStorage::Copy).unwrap();
            let (plans, report) = build::plan(&store, &boxes, &HugSettings::default().recipe());
            assert_eq!(
                plans.len(),
                2,
                "the world and the cluster's grid: {report:?}"
            );
            let items = (plans[0].objects.len() + plans[0].children.len()) as f64;
            match plans[0].resolution {
                Resolution::Cubical(cells) => cells / items,
                ref r => panic!("{r:?}"),
            }
        };
        assert_eq!(world_cells(40), 1.0);
        assert_eq!(world_cells(400), build::WORLD_DENSITY);
    }

    /// Every occupied cell's box of what it holds (`hierarchy::bounds`) holds every point of
    /// its triangles that lies in the cell, and on a terrain, a sheet across its cells, it is
    /// a fraction of the cell: what lets a ray that crosses the cell away from the sheet skip
    /// its tests.
    #[test]
    fn cell_boxes_hold_their_triangles_and_little_else() {
        use crate::geometry::Aabb;
        let terrain = crate::scene::Terrain::with_triangles(20_000, 2).scene();
        let room = crate::scene::procedural::clustered_room(5_000, 3);
        for (name, prims, most) in [("terrain", &terrain, 0.6), ("room", &room, 0.6)] {
            let (store, boxes) = store_with_boxes(prims, TriangleStorage::Copy).unwrap();
            let (plans, _) = build::plan(&store, &boxes, &HugSettings::default().recipe());
            let grids = GridHierarchy::build(
                prims,
                store,
                Some(boxes),
                &plans,
                Prune::None,
                None,
                Simd::Widest,
            )
            .unwrap();
            let cells = grids.cell_boxes();
            assert!(cells.len() > 100, "{name}: {} cells", cells.len());
            let mut share = 0f32;
            for (cell, held, objects) in &cells {
                for &r in objects {
                    let Some([a, b, c]) = grids.store.triangle(r) else {
                        continue;
                    };
                    for i in 0..=8 {
                        for j in 0..=8 - i {
                            let (u, v) = (i as f32 / 8.0, j as f32 / 8.0);
                            let p = a + (b - a) * u + (c - a) * v;
                            assert!(
                                !cell.contains(p) || held.contains(p),
                                "{name}: {p} of triangle {r} in {cell:?} outside {held:?}"
                            );
                        }
                    }
                }
                let kept = Aabb::new(held.min.max(cell.min), held.max.min(cell.max));
                share += if kept.is_empty() {
                    0.0
                } else {
                    kept.volume() / cell.volume()
                };
            }
            let share = share / cells.len() as f32;
            assert!(share < most, "{name}: boxes fill {share:.3} of their cells");
        }
    }

    /// A HUG of many grids built with its pairs in slices of 5,000 is the HUG built at once,
    /// reference for reference, pruned or not, copied or indexed: the slices are sorted by
    /// the radix sort, the whole by the counting sort within each grid. Four threads, so that
    /// the terrain's world grid (40,000 items, a cell each: few enough counters for the
    /// counting sort) is binned in four lists the counting sort merges.
    #[test]
    fn grids_built_in_slices_are_the_grids_built_at_once() {
        rayon::ThreadPoolBuilder::new()
            .num_threads(4)
            .build()
            .unwrap()
            .install(slices_and_whole_agree);
    }

    /// Every cell lists its objects in store order, then the grids it references: the walks
    /// split a cell's references there ([`crate::accel::hierarchy`]'s `split_grids`) and test
    /// the triangles, which come first in the store, by one partition. Checked on a HUG with
    /// sub-grids, with its crowded cells cut again as the recursive grid cuts them (which
    /// puts a new grid in place of a cell's objects) and without.
    #[test]
    fn cells_list_their_objects_then_their_grids() {
        use crate::accel::hierarchy::{GRID_TAG, Resolution, Subdivision};
        let scene = crate::scene::procedural::clustered_room(3_000, 5);
        let settings = HugSettings {
            min_cluster: 1,
            loose: 1e30,
            ..HugSettings::default()
        };
        let cut = Subdivision {
            maxp: 2,
            max_depth: 2,
            guard: true,
            cells: Resolution::Cubical(1.0),
        };
        for subdivision in [None, Some(cut)] {
            let (store, boxes) = store_with_boxes(&scene, TriangleStorage::Copy).unwrap();
            let (plans, _) = build::plan(&store, &boxes, &settings.recipe());
            let cutting = subdivision.is_some();
            // The boxes recomputed by the build, where the tests above hand them over.
            drop(boxes);
            let grids = GridHierarchy::build(
                &scene,
                store,
                None,
                &plans,
                Prune::None,
                subdivision,
                Simd::Widest,
            )
            .unwrap();
            assert!(
                grids.grid_count() > plans.len() || !cutting,
                "no cell was cut"
            );
            let (refs, _, starts) = grids.layout();
            let mut with_grids = 0;
            for cell in starts.windows(2) {
                let refs = &refs[cell[0] as usize..cell[1] as usize];
                let objects = refs.iter().take_while(|&&r| r & GRID_TAG == 0).count();
                assert!(
                    refs[objects..].iter().all(|&r| r & GRID_TAG != 0),
                    "{refs:?}"
                );
                assert!(refs[..objects].is_sorted_by(|a, b| a < b), "{refs:?}");
                with_grids += (objects < refs.len()) as usize;
            }
            assert!(with_grids > 0, "no cell references a grid");
        }
    }

    fn slices_and_whole_agree() {
        let scene = crate::scene::procedural::clustered_room(20_000, 3);
        let mesh = crate::scene::Terrain::with_triangles(40_000, 2).scene();
        let settings = HugSettings {
            min_cluster: 1,
            loose: 1e30,
            ..HugSettings::default()
        };
        for (prims, storage) in [
            (&scene, TriangleStorage::Copy),
            (&mesh, TriangleStorage::Index),
        ] {
            let settings = match storage {
                TriangleStorage::Index => HugSettings {
                    world: WorldCells::Density(1.0),
                    ..settings
                },
                _ => settings,
            };
            for prune in [Prune::None, Prune::All] {
                let build = |slice| {
                    let (store, boxes) = store_with_boxes(prims, storage).unwrap();
                    let (plans, _) = build::plan(&store, &boxes, &settings.recipe());
                    let grids = GridHierarchy::build_in_slices(
                        prims,
                        store,
                        Some(boxes),
                        &plans,
                        prune,
                        None,
                        Simd::Widest,
                        slice,
                    )
                    .unwrap();
                    (plans.len(), grids)
                };
                let (plans, whole) = build(u64::MAX);
                let (_, sliced) = build(5_000);
                assert!(
                    plans > 1 || storage == TriangleStorage::Index,
                    "{plans} grids"
                );
                assert!(whole.layout().0.len() > 4 * 5_000, "too few pairs to slice");
                assert!(whole.layout() == sliced.layout(), "{storage:?}, {prune:?}");
            }
        }
    }
}
