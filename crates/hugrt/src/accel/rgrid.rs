//! Recursive grid (Jevans and Wyvill, GI'89; EG95 §1.2.2; RTNews "Comparison of hierarchical
//! grids", method a): a uniform grid over the scene, and every cell referencing more than
//! `maxp` objects gridded again over its own box, down to a depth limit.
//!
//! * Cells of a sub-grid: EG95 §1.2.2 (Jansen's `∛` criterion) sets `n_x = n_y = n_z =
//!   ∛n_i` for a cell of `n_i` objects; RTNews found grids whose cells are as cubical as
//!   possible, their number proportional to the objects ("heterogeneous"), generally faster.
//!   Both are here (`hetero=false|true`), each `density · n_i` cells; the root grid follows the
//!   same rule over all `n` objects. The default, heterogeneous, is RTNews' finding; on the
//!   cells of a cubical root the two differ little.
//! * A sub-grid's box is its cell (widened by the structure's margin), not the box of the
//!   objects in it: the papers' structure, whose cells never overlap, so each sub-grid is
//!   walked from its one cell and needs no mailbox (RTNews: "each nested grid along the ray
//!   path is tested exactly once").
//! * Termination and memory: the bounds of [`Subdivision`]: the depth limit, as in the papers,
//!   and references within `2·(64·n + 4096)`. EG95 §1.2.2's non-terminating case, more than
//!   `maxp` coplanar polygons sharing a point, grows explosively up to that budget, as the
//!   paper says it does; `guard=true` (hugrt's, off by default) stops it at the first level
//!   that would only repeat itself.
//! * Traversal: the nested grids' walk ([`GridHierarchy::walk`]): a cell's sub-grid is walked
//!   with the same ray state, and the walk above stops once the nearest hit lies before the
//!   cell's exit.
//!
//! Defaults: `maxp = 50` (EG95's fastest of 50, 100, 150), depth 3 (RTNews: "usually 2 or
//! 3"; EG95 saw at most 5), `density = 1` (the cube-root rule both papers use), cells as
//! cubical as possible and shifted planes (hugrt's: [`RecursiveGridSettings`]).
//!
//! `preset=eg95` is the recursive grid EG95 measured (§1.2.2, §3): [`EG95`].

use super::grid::{PRUNE_HELP, SHIFT_HELP, SIMD_HELP, check_size};
use super::hierarchy::{GridHierarchy, GridPlan, LevelView, Prune, Resolution, Subdivision};
use super::query::{OCCLUSION_HELP, Occlusion};
use super::settings::{Key, Settings, key};
use super::simd::Simd;
use super::{
    Accel, CellCensus, Counters, HitSink, Preset, PrimStore, Primitives, SpecError, StructureStats,
};
use crate::geometry::Ray;

/// Grids nested by cutting crowded cells: what [`RecursiveGrid`] and [`super::Octree`] are.
pub(crate) struct CutGrids {
    pub grids: GridHierarchy,
    pub prims: usize,
    pub sub: Subdivision,
}

impl CutGrids {
    /// Builds the root grid over everything, its cells chosen by `sub`'s rule for all the
    /// objects (as if the scene were one crowded cell), then cuts its crowded cells.
    pub fn build<P: Primitives>(
        prims: &P,
        sub: Subdivision,
        prune: Prune,
        shift: bool,
        simd: Simd,
    ) -> Result<CutGrids, SpecError> {
        let n = prims.len();
        check_size(n)?;
        let store = PrimStore::build(prims);
        let plan = GridPlan {
            objects: (0..n as u32).collect(),
            children: Vec::new(),
            resolution: sub.cells.for_objects(n),
            frame: None,
            depth: 0,
            level: 0,
            scene_box: true,
            shift,
        };
        let grids = GridHierarchy::build(prims, store, None, &[plan], prune, Some(sub), simd)?;
        Ok(CutGrids {
            grids,
            prims: n,
            sub,
        })
    }

    /// The statistics `hugrt stats` shows for a recursive grid or an octree.
    pub fn stats(&self, memory_bytes: usize) -> StructureStats {
        let levels = self.grids.level_stats(LevelView::Level);
        let mut s = StructureStats::default();
        s.push("maxp", self.sub.maxp as f64);
        s.push("depth_limit", self.sub.max_depth as f64);
        s.push("guard", self.sub.guard as u8 as f64);
        s.push("left_uncut_by_budget", self.grids.uncut_by_budget() as f64);
        s.push("grids", self.grids.grid_count() as f64);
        s.push("depth", levels.len() as f64);
        s.push("cells", self.grids.cell_count() as f64);
        s.push("references", self.grids.reference_count() as f64);
        let object_refs: usize = levels.iter().map(|l| l.object_refs).sum();
        s.push(
            "references_per_object",
            object_refs as f64 / self.prims.max(1) as f64,
        );
        s.push(
            "cells_per_object",
            self.grids.cell_count() as f64 / self.prims.max(1) as f64,
        );
        s.push_memory(self.grids.grid_memory_bytes(), memory_bytes, self.prims);
        s.census = CellCensus::of_levels(&levels);
        s.levels = levels;
        s
    }
}

pub struct RecursiveGrid {
    cut: CutGrids,
    density: f32,
    hetero: bool,
    occlusion: Occlusion,
}

/// The deepest level (the root is 0) [`RecursiveGrid`] and [`super::Octree`] accept.
pub(crate) const MAX_DEPTH: usize = 16;

/// The help of the cut grids' `guard` key.
pub(crate) const GUARD_HELP: &str =
    "true: a cell holding every object of its grid is not cut again (hugrt's, not the papers')";

/// The recursive grid's settings (`rgrid:maxp=..,depth=..`, ...).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RecursiveGridSettings {
    /// A cell referencing more objects is gridded again (EG95 used 50, 100, 150).
    pub maxp: usize,
    /// Deepest level of sub-grids, the root being 0 (at most 16).
    pub depth: usize,
    /// Cells per object in every grid (1: the cube-root rule).
    pub density: f32,
    /// Cells as cubical as possible (RTNews) rather than the same count on every axis
    /// (EG95's cube-root criterion).
    pub hetero: bool,
    /// A cell holding every object of its grid is not cut again (hugrt's).
    pub guard: bool,
    pub prune: Prune,
    /// Cell planes moved off the box's round fractions (hugrt's).
    pub shift: bool,
    /// Which vector instructions the walks and the triangle tests may use ([`Simd`]).
    pub simd: Simd,
    /// Where occlusion queries walk a ray from ([`Occlusion`]).
    pub occlusion: Occlusion,
}

impl Default for RecursiveGridSettings {
    fn default() -> Self {
        RecursiveGridSettings {
            maxp: 50,
            depth: 3,
            density: 1.0,
            hetero: true,
            guard: false,
            prune: Prune::None,
            shift: true,
            simd: Simd::Widest,
            occlusion: Occlusion::Auto,
        }
    }
}

impl Settings for RecursiveGridSettings {
    const KEYS: &'static [Key<Self>] = &[
        key!("maxp", maxp: usize, 1..=1_000_000, "a cell referencing more objects is gridded again (EG95 used 50, 100, 150)"),
        key!("depth", depth: usize, 0..=MAX_DEPTH, "deepest level of sub-grids, the root being 0"),
        key!("density", density: f32, 0.001..=1000.0, "cells per object in every grid (1: the cube-root rule)"),
        key!("hetero", hetero: bool, (), "true: cells as cubical as possible (RTNews); false: the same count on every axis (EG95's cube-root criterion)"),
        key!("guard", guard: bool, (), GUARD_HELP),
        key!("prune", prune: Prune, (), PRUNE_HELP),
        key!("shift", shift: bool, (), SHIFT_HELP),
        key!("simd", simd: Simd, (), SIMD_HELP),
        key!("occlusion", occlusion: Occlusion, (), OCCLUSION_HELP),
    ];
    const PRESETS: &'static [Preset] = &[EG95];
}

/// EG95's recursive grid (§1.2.2 and §3), after Jevans and Wyvill with Jansen's criterion.
pub const EG95: Preset = Preset {
    name: "eg95",
    pairs: &[
        (
            "maxp",
            "50",
            "EG95 §3: MAXP 50, the fastest of 50, 100 and 150",
        ),
        (
            "hetero",
            "false",
            "EG95 §1.2.2: Jansen's cube-root criterion, n_x = n_y = n_z = cbrt(n_i)",
        ),
        (
            "density",
            "1",
            "EG95 §1.2.2: n_i cells for a cell of n_i items",
        ),
        (
            "depth",
            "5",
            "EG95 §3 gives no limit; its recursive grids were at most 5 deep",
        ),
        (
            "guard",
            "false",
            "EG95 §1.2.2: cells are cut by MAXP and depth only",
        ),
        ("shift", "false", "the papers' grids start at their box"),
        ("prune", "false", "EG95 bins objects by their boxes"),
        (
            "occlusion",
            "start",
            "EG95 §2.3.2: every ray is walked from its origin",
        ),
    ],
};

impl Accel for RecursiveGrid {
    const NAME: &'static str = "rgrid";
    const PACKET_RAYS: usize = crate::accel::hierarchy::GRID_PACKET;
    const PACKETS_PAY: bool = true;
    const ORDER_PAYS: bool = true;
    type Settings = RecursiveGridSettings;

    fn build_checked<P: Primitives>(
        prims: &P,
        settings: &RecursiveGridSettings,
    ) -> Result<Self, SpecError> {
        let RecursiveGridSettings {
            maxp,
            depth,
            density,
            hetero,
            guard,
            prune,
            shift,
            simd,
            occlusion,
        } = *settings;
        let sub = Subdivision {
            maxp,
            max_depth: depth as u32,
            guard,
            cells: if hetero {
                Resolution::Cubical(density as f64)
            } else {
                Resolution::Regular(density as f64)
            },
        };
        Ok(RecursiveGrid {
            cut: CutGrids::build(prims, sub, prune, shift, simd)?,
            density,
            hetero,
            occlusion,
        })
    }

    fn query<P: Primitives, C: Counters, S: HitSink>(
        &self,
        prims: &P,
        ray: &Ray,
        sink: &mut S,
        counters: &mut C,
    ) {
        self.cut.grids.query(prims, ray, sink, counters);
    }

    fn query_packet<P: Primitives, C: Counters, S: HitSink>(
        &self,
        prims: &P,
        rays: &[Ray],
        sinks: &mut [S],
        counters: &mut C,
    ) {
        self.cut.grids.query_packet(prims, rays, sinks, counters);
    }

    fn reach(&self) -> &crate::accel::Reach {
        self.cut.grids.store.reach()
    }

    fn occlusion(&self) -> Occlusion {
        self.occlusion
    }

    fn memory_bytes(&self) -> usize {
        std::mem::size_of::<Self>() + self.cut.grids.memory_bytes()
    }

    fn stats(&self) -> StructureStats {
        let mut s = self.cut.stats(self.memory_bytes());
        s.entries.insert(0, ("density".into(), self.density as f64));
        s.entries
            .insert(1, ("hetero".into(), self.hetero as u8 as f64));
        s
    }
}
