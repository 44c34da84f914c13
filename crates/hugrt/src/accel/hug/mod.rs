//! The Hierarchy of Uniform Grids (Cazals, Drettakis and Puech, EG95; Cazals and Puech,
//! SCG97): built bottom-up by
//!
//! 1. **filtering** the objects by size ([`filter`]: EG95's `k` levels of equal counts, or
//!    SCG97's two levels split at a fraction of the largest length);
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
//! each departure a key: the graph clustering with δ = 0.5·(the level's mean length) and
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

pub use build::{CellShape, Clustering, Insertion, Settings, WorldCells};
pub use filter::Filter;

use super::grid::{SHIFT_KEY, SIMD_KEY, store_with_boxes};
use super::hierarchy::{GridHierarchy, LevelView, Prune};
use super::{
    Accel, CellCensus, Counters, HitSink, Preset, Primitives, Spec, SpecError, StructureStats,
};
use crate::geometry::Ray;

/// The defaults of `hug` with no keys, chosen by measurement: every variant rendered (SPD
/// procedure, 2 threads, best of 3 at 512² or of 5 at 1024² where two were within noise)
/// over the 11 SPD scenes, the 5 yardstick meshes and the 7 generated scenes, against the
/// uniform grid at densities 1, 2, 4, 8, 16 and 20 (`docs/measurements.md` has every column).
/// Render time over the best grid density of each scene:
///
/// | scene | best grid (D) | hug | EG95 | SCG97 |
/// | --- | --- | --- | --- | --- |
/// | balls | 0.544 s (20) | 0.45 | 2.86 | 0.48 |
/// | gears | 3.571 s (8)* | 0.96 | 1.31 | 1.28 |
/// | mount | 0.825 s (2)* | 1.05 | 1.00 | 1.00 |
/// | rings | 1.985 s (20)* | 1.06 | 1.49 | 1.23 |
/// | teapot | 0.698 s (4)* | 1.00 | 1.04 | 1.04 |
/// | tetra | 0.136 s (8)* | 1.00 (the same grid) | 1.03 | 1.01 |
/// | tree | 2.578 s (20) | 0.08 | 2.98 | 0.09 |
/// | lattice | 1.054 s (20)* | 1.07 | 1.70 | 1.23 |
/// | shells | 1.365 s (4) | 0.98 | 1.02 | 1.09 |
/// | sombrero | 0.141 s (8)* | 0.97 | 1.39 | 1.00 |
/// | stanford-bunny | 0.137 s (4)* | 1.06 | 1.15 | 1.33 |
/// | nefertiti | 0.145 s (16)* | 0.97 | 1.47 | 1.22 |
/// | spd-tetra-big | 0.159 s (4)* | 1.08 | 1.32 | 1.08 |
/// | spd-teapot-big | 0.145 s (4)* | 1.00 | 1.09 | 1.22 |
/// | spd-mount-big | 0.268 s (20)* | 0.96 | 1.76 | 1.13 |
/// | kitchen | 0.408 s (2) | 0.72 | 1.06 | 0.79 |
/// | building | 0.040 s (4) | 0.75 | 0.98 | 0.87 |
/// | city | 0.664 s (16)* | 1.08 | 1.53 | 1.46 |
/// | garden | 0.171 s (8) | 0.71 | 1.04 | 0.84 |
/// | sphereflake | 0.648 s (20) | 0.80 | 2.64 | 0.77 |
/// | stadium | 34 s (20) | 0.012 | 0.40 | 1.14 |
/// | room | 0.316 s (4) | 0.44 | 0.86 | 0.39 |
///
/// (* grid and `hug` at 1024², best of 5, where the 512² figures were within noise of each
/// other; the EG95 and SCG97 columns are from the 512² sweep. They are not the papers'
/// algorithms, which [`EG95`] and [`SCG97`] now are, but these approximations with hugrt's
/// give-back, cubical cells and shifted planes: EG95 =
/// `filter=levels,cluster=cluster3d,alpha=0.01,world=2n,density=1,prune=false`, SCG97 =
/// `filter=two,cluster=cluster3d,alpha=0.01,world=sqrt2,density=1,prune=false`. The stadium's
/// grid figure is from an earlier 512² sweep, the grid taking 34 to 79 s at every density.) The defaults are
/// never more than 8% behind the best density, which differs from scene to scene (2 to 20), and
/// are 1.4 to 80 times faster where objects cluster. One key at a time, over all scenes
/// (worst ratio to the best grid; geometric mean at 512²):
///
/// * `filter`: SCG97's two levels at 5% of the longest object. EG95's three equal-count
///   levels (`filter=levels`: worst 1.89, mean 1.17) cut a scene's detail across sizes, so
///   the tree of SPD tree and the sphereflake of balls fall apart into tiny clusters.
/// * `cluster`: the components of boxes closer than δ = 0.5·(the level's mean length).
///   Cluster3d's projections join a ring of stadium tiers with the objects it encloses
///   (stadium 28 s with `cluster=cluster3d`, 0.4 s with the graph); joining boxes only when
///   they touch (α = 0) splits heaps of separate small objects into hundreds of grids (balls,
///   room 1.5–2× slower at 512² in an earlier sweep); α from 0.1 to 1 performed alike.
/// * `world`: 8 cells per item, `density`: 2 per item in clusters. The papers' 2N (EG95) and
///   2.83N (SCG97) and one cell per cluster item were chosen when a cell step cost more
///   relative to a triangle test; with the walk here (DDA state in registers, eight triangles
///   tested at once) finer grids pay: `world=4` worst 1.23 (lattice), `world=16` 1.24 (gears),
///   `density=1` 1.29 (city). With offsets kept for occupied cells only, the finer grids cost
///   about 10 bytes per primitive more than the papers' settings.
/// * `prune`: large objects only (box over 16 cells or more); `prune=false` worst 1.27 (gears'
///   slivers), and testing every object costs build time for nothing on meshes.
/// * `min_cluster` 16 and `loose` 0.25: `min_cluster=1` worst 1.39, `min_cluster=64` 1.43,
///   `loose=1e30` 1.38 (nefertiti, city, rings: single-level scenes where a loose cluster only
///   adds a walk).
/// * `pca` and `hetero` off: as SCG97 reports, neither pays (worst 1.26 and, on SPD shells,
///   1.55).
pub const DEFAULTS: Settings = Settings {
    filter: Filter::Two(0.05),
    clustering: Clustering::Graph {
        alpha: 0.5,
        crowd: Some(cluster::CROWD),
    },
    world: WorldCells::Density(8.0),
    density: 2.0,
    cells: CellShape::Cubical,
    shift: true,
    give_back: true,
    min_cluster: 16,
    loose: 0.25,
    pca: false,
    hetero: false,
    insertion: Insertion::Contained,
};

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
    ],
};

pub struct Hug {
    grids: GridHierarchy,
    report: build::Report,
    prims: usize,
    prune: Prune,
    settings: Settings,
}

impl Hug {
    /// The settings a spec asks for, on top of its preset's and of [`DEFAULTS`].
    pub fn settings(spec: &Spec) -> Result<Settings, SpecError> {
        let spec = &spec.with_preset(&[EG95, SCG97])?;
        let d = DEFAULTS;
        let levels = spec.usize_in(
            "levels",
            match d.filter {
                Filter::Levels(k) => k,
                Filter::Two(_) => 3,
            },
            1,
            16,
        )?;
        let fraction = spec.f32_in(
            "fraction",
            match d.filter {
                Filter::Two(f) => f,
                Filter::Levels(_) => 0.05,
            },
            1e-6,
            1.0,
        )?;
        let default_filter = match d.filter {
            Filter::Levels(_) => "levels",
            Filter::Two(_) => "two",
        };
        let filter = match spec.choice("filter", &["levels", "two"], default_filter)? {
            "levels" => Filter::Levels(levels),
            _ => Filter::Two(fraction),
        };
        let (default_alpha, default_crowd) = match d.clustering {
            Clustering::Cluster3d { alpha } => (alpha, Some(cluster::CROWD)),
            Clustering::Graph { alpha, crowd } => (alpha, crowd),
        };
        let alpha = spec.f32_in("alpha", default_alpha, 0.0, 100.0)?;
        let crowd =
            match spec.value("crowd") {
                None => default_crowd,
                Some("off") => None,
                Some(_) => Some(spec.usize_in("crowd", 0, 1, 1 << 30).map_err(|_| {
                    SpecError::BadValue {
                        key: "crowd".into(),
                        value: spec.value("crowd").unwrap_or_default().into(),
                        reason: "expected off or a count of objects (1..2^30)".into(),
                    }
                })?),
            };
        let default_cluster = match d.clustering {
            Clustering::Cluster3d { .. } => "cluster3d",
            Clustering::Graph { .. } => "graph",
        };
        let clustering = match spec.choice("cluster", &["cluster3d", "graph"], default_cluster)? {
            "cluster3d" => Clustering::Cluster3d { alpha },
            _ => Clustering::Graph { alpha, crowd },
        };
        let world = match spec.value("world") {
            None => d.world,
            Some("2n") => WorldCells::TwoN,
            Some("sqrt2") => WorldCells::Sqrt2,
            Some(_) => {
                WorldCells::Density(spec.f32_in("world", 2.0, 0.001, 1000.0).map_err(|_| {
                    SpecError::BadValue {
                        key: "world".into(),
                        value: spec.value("world").unwrap_or_default().into(),
                        reason: "expected 2n, sqrt2 or cells per item (0.001..1000)".into(),
                    }
                })?)
            }
        };
        let insertion = match spec.choice(
            "insert",
            &["contained", "fig9"],
            match d.insertion {
                Insertion::Contained => "contained",
                Insertion::Fig9 => "fig9",
            },
        )? {
            "fig9" => Insertion::Fig9,
            _ => Insertion::Contained,
        };
        let cells = match spec.choice(
            "cells",
            &["cubical", "cube-root"],
            match d.cells {
                CellShape::Cubical => "cubical",
                CellShape::CubeRoot => "cube-root",
            },
        )? {
            "cube-root" => CellShape::CubeRoot,
            _ => CellShape::Cubical,
        };
        Ok(Settings {
            filter,
            clustering,
            world,
            density: spec.f32_in("density", d.density, 0.001, 1000.0)?,
            cells,
            shift: spec.bool("shift", d.shift)?,
            give_back: spec.bool("giveback", d.give_back)?,
            min_cluster: spec.usize_in("min_cluster", d.min_cluster, 1, 1 << 30)?,
            loose: spec.f32_in("loose", d.loose, 0.0, 1e30)?,
            pca: spec.bool("pca", d.pca)?,
            hetero: spec.bool("hetero", d.hetero)?,
            insertion,
        })
    }

    /// The settings this HUG was built with.
    pub fn built_settings(&self) -> &Settings {
        &self.settings
    }
}

impl Accel for Hug {
    const NAME: &'static str = "hug";
    const KEYS: &'static [(&'static str, &'static str)] = &[
        (
            "filter",
            "levels (EG95: equal-count size levels) or two (SCG97: split at a fraction of the largest)",
        ),
        (
            "levels",
            "number of size levels for filter=levels (EG95: 3)",
        ),
        (
            "fraction",
            "filter=two: objects under this fraction of the largest length form the lower level (SCG97: 0.05)",
        ),
        (
            "cluster",
            "cluster3d (EG95: Isolate/Cluster3d on projections) or graph (SCG97: box-intersection components)",
        ),
        (
            "alpha",
            "delta = alpha * the level's mean length; projections (cluster3d) or boxes (graph) closer than delta join (EG95: 0.01)",
        ),
        (
            "world",
            "cells of the world grid: 2n (EG95), sqrt2 (SCG97) or cells per item",
        ),
        (
            "crowd",
            "cluster=graph: objects sharing a binning cell with more than this many are joined untested (hugrt's, default 64), or off: every pair tested (SCG97)",
        ),
        ("density", "cells per item of a cluster grid (EG95: 1)"),
        (
            "cells",
            "cubical: cells as cubical as possible (hugrt's, default); cube-root: as many on every axis (EG95, SCG97)",
        ),
        (
            "giveback",
            "true: small (min_cluster) and loose clusters go back to the enclosing grid (hugrt's, default); false: every cluster is gridded (the papers)",
        ),
        (
            "min_cluster",
            "giveback: clusters of fewer objects are given back to the enclosing grid (default 16)",
        ),
        (
            "loose",
            "giveback: clusters filling more than this share of the enclosing grid's volume are given back to it (default 0.25)",
        ),
        (
            "pca",
            "true: grid a cluster in the frame of its principal axes when that box is smaller (SCG97 7.2)",
        ),
        (
            "hetero",
            "true: cells per axis from the overlap numbers of the projections (SCG97 7.3)",
        ),
        (
            "insert",
            "contained (reference a grid below the deepest grid containing it) or fig9 (also in grids it overlaps)",
        ),
        (
            "prune",
            "true: reference a cell only if the primitive itself touches it; large: only for objects whose box spans 16 cells or more (default large)",
        ),
        SHIFT_KEY,
        SIMD_KEY,
        (
            "preset",
            "eg95 or scg97: the paper's algorithm, step for step (other keys override it)",
        ),
    ];

    fn build<P: Primitives>(prims: &P, spec: &Spec) -> Result<Self, SpecError> {
        let settings = Hug::settings(spec)?;
        let spec = &spec.with_preset(&[EG95, SCG97])?;
        let prune = Prune::from_spec(spec, Prune::Large)?;
        let n = prims.len();
        let (store, boxes) = store_with_boxes(prims)?;
        let (plans, report) = build::plan(&store, &boxes, &settings);
        drop(boxes);
        let simd = spec.bool("simd", true)?;
        let grids = GridHierarchy::build(prims, store, &plans, prune, None, simd)?;
        Ok(Hug {
            grids,
            report,
            prims: n,
            prune,
            settings,
        })
    }

    fn query<P: Primitives, C: Counters, S: HitSink>(
        &self,
        prims: &P,
        ray: &Ray,
        sink: &mut S,
        counters: &mut C,
    ) {
        self.grids.query(prims, ray, sink, counters);
    }

    fn memory_bytes(&self) -> usize {
        std::mem::size_of::<Self>() + self.grids.memory_bytes()
    }

    fn stats(&self) -> StructureStats {
        let levels = self.grids.level_stats(LevelView::Level);
        let depths = self.grids.level_stats(LevelView::Depth);
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
        s.push("sum_pct_vol", levels.iter().map(|l| l.pct_vol).sum::<f64>());
        s.push("prune", self.prune.stat_value());
        s.push_memory(
            self.grids.grid_memory_bytes(),
            self.memory_bytes(),
            self.prims,
        );
        s.census = CellCensus::of_levels(&levels);
        s.levels = levels;
        s.depths = depths;
        s
    }
}
