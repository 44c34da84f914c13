//! EG95's "simulated octree" (§1.2.3, §4): the recursive grid with every grid, the root
//! included, cut 2×2×2, a cell referencing more than `maxp` objects cut again down to a depth
//! limit. It is walked as the recursive grid is, cell by cell with the 3D-DDA at every level,
//! which is how EG95 ran it (a subclass of their grid). The papers give no depth limit;
//! hugrt's default is its largest, 16 levels below the root: cells are cut only where
//! crowded, and a scene spanning 10^5 scales (a teapot in a stadium) needs them all. At
//! depth 10 the stadium's teapot stays in a few cells of thousands of triangles (0.05 Mrays/s
//! rendering, like the uniform grid).
//! Termination and memory are those of the recursive grid ([`super::RecursiveGrid`]).

use super::grid::{PRUNE_KEY, SIMD_KEY};
use super::hierarchy::{Prune, Resolution, Subdivision};
use super::rgrid::{CutGrids, MAX_DEPTH};
use super::{Accel, Counters, Hit, Primitives, Spec, SpecError, StructureStats};
use crate::geometry::Ray;

pub struct Octree {
    cut: CutGrids,
}

impl Accel for Octree {
    const NAME: &'static str = "octree";
    const KEYS: &'static [(&'static str, &'static str)] = &[
        (
            "maxp",
            "a cell referencing more objects is cut in eight, 1..1000000 (default 50; EG95 used 50, 100, 150)",
        ),
        (
            "depth",
            "deepest level, the root being 0, 0..16 (default 16)",
        ),
        PRUNE_KEY,
        SIMD_KEY,
    ];

    fn build<P: Primitives>(prims: &P, spec: &Spec) -> Result<Self, SpecError> {
        let sub = Subdivision {
            maxp: spec.usize_in("maxp", 50, 1, 1_000_000)?,
            max_depth: spec.usize_in("depth", MAX_DEPTH, 0, MAX_DEPTH)? as u32,
            cells: Resolution::Fixed([2; 3]),
        };
        let prune = Prune::from_spec(spec, Prune::None)?;
        Ok(Octree {
            cut: CutGrids::build(prims, spec, sub, prune)?,
        })
    }

    fn query<P: Primitives, C: Counters, const ANY_HIT: bool>(
        &self,
        prims: &P,
        ray: &Ray,
        counters: &mut C,
    ) -> Option<Hit> {
        self.cut.grids.query::<P, C, ANY_HIT>(prims, ray, counters)
    }

    fn memory_bytes(&self) -> usize {
        std::mem::size_of::<Self>() + self.cut.grids.memory_bytes()
    }

    fn stats(&self) -> StructureStats {
        self.cut.stats(self.memory_bytes())
    }
}
