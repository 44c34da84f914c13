//! Uniform grid (EG95 §1.2.1; RTNews "Comparison of Hierarchical Grids" and "Quicker Grid
//! Generation via Memory Allocation"): one grid of a [`GridHierarchy`].
//!
//! * Resolution: about `density · n` cells, as cubical as possible
//!   ([`super::cubical_resolution`]). `density = 1` is the cube-root rule; RTNews found
//!   `D = 20` faster on the SPD scenes.
//! * Build in two passes: count the references of every cell, prefix-sum the counts into
//!   offsets, fill one flat array. No linked lists, no allocation per cell.
//! * References by bounding-box overlap, or with `prune=true` by an exact primitive/cell test.
//! * Traversal: the 3D-DDA of Amanatides and Woo, mailboxing, and a hit ends the walk only
//!   once it lies inside the current cell (see [`GridHierarchy::walk`]).

use super::hierarchy::{GridHierarchy, GridPlan, LevelView, Prune, Resolution};
use super::query::{OCCLUSION_HELP, Occlusion};
use super::settings::{Key, Settings, key};
use super::simd::Simd;
use super::store::{STORAGE_HELP, TriangleStorage};
use super::{
    Accel, CellCensus, Counters, HitSink, PrimStore, Primitives, SpecError, StructureStats,
};
use crate::geometry::{Aabb, Ray};

/// Default cells per primitive, chosen by measurement (`docs/measurements.md`): over two
/// meshes, the generated clustered room and four SPD scenes, `D = 2` has the best geometric
/// mean of throughput relative to each scene's best density (0.82; 0.78 at `D = 4`, 0.73 at
/// `D = 1`), a worst case as good as any (0.48, on SPD balls), and 36% fewer bytes than `D = 4`.
/// No density is best everywhere: meshes and the room prefer 1–2, objects clustered on a huge
/// floor (balls, tree) 16 and more, which is the case the HUG is built for.
pub const DEFAULT_DENSITY: f32 = 2.0;

/// The uniform grid's settings (`grid:density=..,prune=..,shift=..,simd=..`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridSettings {
    /// Cells per primitive (default 2, chosen by measurement; RTNews used 1 and 20).
    pub density: f32,
    /// Which objects are referenced only from the cells they touch.
    pub prune: Prune,
    /// Cell planes moved off the box's round fractions (hugrt's, not the papers').
    pub shift: bool,
    /// Which vector instructions the walks and the triangle tests may use ([`Simd`]).
    pub simd: Simd,
    /// How the store holds an indexed mesh's triangles.
    pub store: TriangleStorage,
    /// Where occlusion queries walk a ray from ([`Occlusion`]).
    pub occlusion: Occlusion,
}

impl Default for GridSettings {
    fn default() -> Self {
        GridSettings {
            density: DEFAULT_DENSITY,
            prune: Prune::None,
            shift: true,
            simd: Simd::Widest,
            store: TriangleStorage::Auto,
            occlusion: Occlusion::Auto,
        }
    }
}

/// The help of the keys that several grid structures share.
pub(crate) const PRUNE_HELP: &str = "true: reference a cell only if the primitive itself touches it; large: only for objects whose box spans 16 cells or more";
pub(crate) const SHIFT_HELP: &str = "true: cell planes moved off the box's round fractions, one more cell along axes of 4 or more (hugrt's, not the papers')";
pub(crate) const SIMD_HELP: &str = "true: AVX-512 or AVX2 where the processor has them; avx2: AVX2 at most; false: the portable code (a cell's triangles one at a time)";

impl Settings for GridSettings {
    const KEYS: &'static [Key<Self>] = &[
        key!("density", density: f32, 0.001..=1000.0, "cells per primitive (RTNews used 1 and 20)"),
        key!("prune", prune: Prune, (), PRUNE_HELP),
        key!("shift", shift: bool, (), SHIFT_HELP),
        key!("simd", simd: Simd, (), SIMD_HELP),
        key!("store", store: TriangleStorage, (), STORAGE_HELP),
        key!("occlusion", occlusion: Occlusion, (), OCCLUSION_HELP),
    ];
}

pub struct Grid {
    grids: GridHierarchy,
    prims: usize,
    density: f32,
    prune: Prune,
    occlusion: Occlusion,
}

/// The store of `prims` and the box of each of its entries, for the builds that plan from
/// boxes; fails for scenes too large ([`check_size`]).
pub(crate) fn store_with_boxes<P: Primitives>(
    prims: &P,
    storage: TriangleStorage,
) -> Result<(PrimStore, Vec<Aabb>), SpecError> {
    check_size(prims.len())?;
    Ok(PrimStore::build_with_boxes(prims, storage))
}

/// Fails for scenes too large for 32-bit references (one bit marks sub-grids).
pub(crate) fn check_size(n: usize) -> Result<(), SpecError> {
    if n >= (super::hierarchy::GRID_TAG - 1) as usize {
        return Err(SpecError::Build(format!(
            "{n} primitives: at most 2^31-2 are supported"
        )));
    }
    Ok(())
}

impl Accel for Grid {
    const NAME: &'static str = "grid";
    const PACKET_RAYS: usize = crate::accel::hierarchy::GRID_PACKET;
    const PACKETS_PAY: bool = true;
    const ORDER_PAYS: bool = true;
    type Settings = GridSettings;

    fn build_checked<P: Primitives>(prims: &P, settings: &GridSettings) -> Result<Self, SpecError> {
        let GridSettings {
            density,
            prune,
            shift,
            simd,
            store,
            occlusion,
        } = *settings;
        let n = prims.len();
        check_size(n)?;
        let store = PrimStore::build_with(prims, store);
        let plan = GridPlan {
            objects: (0..n as u32).collect(),
            children: Vec::new(),
            resolution: Resolution::Cubical(density as f64 * n as f64),
            frame: None,
            depth: 0,
            level: 0,
            scene_box: true,
            shift,
        };
        let grids = GridHierarchy::build(prims, store, None, &[plan], prune, None, simd)?;
        Ok(Grid {
            grids,
            prims: n,
            density,
            prune,
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
        self.occlusion
    }

    fn memory_bytes(&self) -> usize {
        std::mem::size_of::<Self>() + self.grids.memory_bytes()
    }

    fn stats(&self) -> StructureStats {
        let levels = self.grids.level_stats(LevelView::Level);
        let root = &levels[0];
        let res = self.grids.resolution(0);
        let mut s = StructureStats::default();
        s.push("density", self.density as f64);
        s.push("prune", self.prune.stat_value());
        s.push("res_x", res[0] as f64);
        s.push("res_y", res[1] as f64);
        s.push("res_z", res[2] as f64);
        s.push("cells", root.cells as f64);
        s.push("empty_cell_ratio", 1.0 - root.pct_o / 100.0);
        s.push("references", root.object_refs as f64);
        s.push(
            "references_per_object",
            root.object_refs as f64 / self.prims.max(1) as f64,
        );
        s.push_memory(
            self.grids.grid_memory_bytes(),
            self.memory_bytes(),
            self.prims,
        );
        s.census = CellCensus::of_levels(&levels);
        s.levels = levels;
        s
    }
}
