//! EG95's "simulated octree" (§1.2.3, §4): the recursive grid with every grid, the root
//! included, cut 2×2×2, a cell referencing more than `maxp` objects cut again down to a depth
//! limit. It is walked as the recursive grid is, cell by cell with the 3D-DDA at every level,
//! which is how EG95 ran it (a subclass of their grid). The papers give no depth limit;
//! hugrt's default is its largest, 16 levels below the root: cells are cut only where
//! crowded, and a scene spanning 10^5 scales (a teapot in a stadium) needs them all. At
//! depth 10 the stadium's teapot stays in a few cells of thousands of triangles (0.05 Mrays/s
//! rendering, like the uniform grid).
//! Termination and memory are those of the recursive grid ([`super::RecursiveGrid`]): the
//! depth limit and the reference budget, `guard=true` for hugrt's extra stop.
//!
//! `preset=eg95` is EG95's simulated octree: [`EG95`]. The defaults are the same, so the
//! preset only pins them.

use super::Preset;
use super::grid::{PRUNE_HELP, SIMD_HELP};
use super::hierarchy::{Prune, Resolution, Subdivision};
use super::query::{OCCLUSION_HELP, Occlusion};
use super::rgrid::{CutGrids, GUARD_HELP, MAX_DEPTH};
use super::settings::{Key, Settings, key};
use super::simd::Simd;
use super::{Accel, Counters, HitSink, Primitives, SpecError, StructureStats};
use crate::geometry::Ray;

/// EG95's simulated octree (§1.2.3, §3).
pub const EG95: Preset = Preset {
    name: "eg95",
    pairs: &[
        (
            "maxp",
            "50",
            "EG95 §3: MAXP 50, 100 and 150 were measured; 50 the fastest",
        ),
        (
            "depth",
            "16",
            "EG95 §3 gives no limit and saw 10 levels on one kitchen, 15 to 20 on many: hugrt's deepest",
        ),
        (
            "guard",
            "false",
            "EG95 §1.2.2: cells are cut by MAXP and depth only",
        ),
        ("prune", "false", "EG95 bins objects by their boxes"),
        (
            "occlusion",
            "start",
            "EG95 §2.3.2: every ray is walked from its origin",
        ),
    ],
};

/// The octree's settings (`octree:maxp=..,depth=..,guard=..,prune=..,simd=..`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OctreeSettings {
    /// A cell referencing more objects is cut in eight (EG95 used 50, 100, 150).
    pub maxp: usize,
    /// Deepest level, the root being 0 (at most 16).
    pub depth: usize,
    /// A cell holding every object of its grid is not cut again (hugrt's).
    pub guard: bool,
    pub prune: Prune,
    /// Which vector instructions the walks and the triangle tests may use ([`Simd`]).
    pub simd: Simd,
    /// Where occlusion queries walk a ray from ([`Occlusion`]).
    pub occlusion: Occlusion,
}

impl Default for OctreeSettings {
    fn default() -> Self {
        OctreeSettings {
            maxp: 50,
            depth: MAX_DEPTH,
            guard: false,
            prune: Prune::None,
            simd: Simd::Widest,
            occlusion: Occlusion::Auto,
        }
    }
}

impl Settings for OctreeSettings {
    const KEYS: &'static [Key<Self>] = &[
        key!("maxp", maxp: usize, 1..=1_000_000, "a cell referencing more objects is cut in eight (EG95 used 50, 100, 150)"),
        key!("depth", depth: usize, 0..=MAX_DEPTH, "deepest level, the root being 0"),
        key!("guard", guard: bool, (), GUARD_HELP),
        key!("prune", prune: Prune, (), PRUNE_HELP),
        key!("simd", simd: Simd, (), SIMD_HELP),
        key!("occlusion", occlusion: Occlusion, (), OCCLUSION_HELP),
    ];
    const PRESETS: &'static [Preset] = &[EG95];
}

pub struct Octree {
    cut: CutGrids,
    occlusion: Occlusion,
}

impl Accel for Octree {
    const NAME: &'static str = "octree";
    const PACKET_RAYS: usize = crate::accel::hierarchy::GRID_PACKET;
    type Settings = OctreeSettings;

    fn build_checked<P: Primitives>(
        prims: &P,
        settings: &OctreeSettings,
    ) -> Result<Self, SpecError> {
        let sub = Subdivision {
            maxp: settings.maxp,
            max_depth: settings.depth as u32,
            guard: settings.guard,
            cells: Resolution::Fixed([2; 3]),
        };
        Ok(Octree {
            // A 2×2×2 grid never shifts its planes (axes of fewer than 4 cells).
            cut: CutGrids::build(prims, sub, settings.prune, false, settings.simd)?,
            occlusion: settings.occlusion,
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
        self.cut.stats(self.memory_bytes())
    }
}
