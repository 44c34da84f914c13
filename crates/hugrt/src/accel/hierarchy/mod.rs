//! Nested uniform grids: the data and the walk that the uniform grid, the HUG and the other
//! grid hierarchies share.
//!
//! A [`GridHierarchy`] is a list of uniform grids over one [`PrimStore`]: grid 0 is the
//! root of the uniform grid, the HUG, the recursive grid and the octree; an adaptive grid's
//! top grids (its clusters') are walked from its own BVH. A cell references store entries and,
//! like objects, other grids (EG95 §2.3: "a grid is inserted into the cells of the grid above
//! it, like an object"). Grids come from a plan built bottom-up (the HUG's), and cells that
//! are still crowded may then be cut top-down ([`Subdivision`]: the recursive grid's). Everything is
//! flat: the cells of every grid lie consecutively in one offsets array, their references in
//! one array, sorted per cell (objects in store order, then grids), built in two passes
//! (count, prefix sum, fill: RTNews "Quicker grid generation"), with no allocation per grid
//! or per cell. A grid may carry its own orthonormal frame (SCG97 §7.2's oriented cluster
//! boxes): its cells are then laid out in that frame and the ray is turned into it.
//!
//! # The walk (EG95 §2.3.2)
//! The 3D-DDA of Amanatides and Woo. In each cell: the objects are tested (where the ray meets
//! the box of what the cell holds, [`bounds`]: hugrt's, not the papers'), then each grid
//! referenced there is walked with the same ray state (the hit sink, mailbox), which is what
//! carries one query through every level; then the walk stops if the nearest hit lies before
//! the cell's exit. A sub-grid is walked once per ray, over its whole extent, the first time a
//! cell references it (its own mailbox), so its answer is complete when the walk returns; the
//! grid above stops only when its own cell's exit lies beyond the hit. So the query stops when
//! the hit lies before the exit of the current cell at every level being walked.
//!
//! # Exactness
//! Every box (object or grid) is widened by `margin` before it is binned, and every grid's box
//! by the same margin. The margin bounds three rounding errors at once, each a few ulps of the
//! coordinate magnitude `M` (largest absolute coordinate or extent of the root box):
//! * the DDA's plane distances `first + j·delta`: the true ray at a parameter `t` inside the
//!   interval the walk gives a cell lies within that error of the cell, so it reaches every
//!   cell the true ray crosses, corners included, up to the margin;
//! * the stop test `nearest ≤ exit`: a nearer hit just beyond the exit plane lies within the
//!   same error of the current cell, hence is referenced by it;
//! * the watertight triangle test's own rounding (its effective ray is off by a few ulps);
//! * the slab test of a ray against the box of what a cell holds ([`bounds`]), which the walk
//!   widens by the margin once more.
//!
//! With `margin = M·2^-17` (64 ulps of `M`), hits are those of brute force for ray origins
//! within a few times `M` of the origin; rays from farther away are first moved to the
//! scene ([`crate::accel::Reach`]). The property tests (`tests/agree.rs`) fail without the margin.
//!
//! # Files
//! `plan` (what a grid is built from), `header` (one grid), `cells` (the occupied cells'
//! index), `bounds` (the box of what each occupied cell holds), `build` (binning a plan),
//! `subdivide` (cutting crowded cells), `walk` (the DDA and the nested walk), `stats` (SCG97
//! §3's statistics).

mod bounds;
mod build;
mod cells;
mod header;
mod packet;
pub(crate) use packet::GRID_PACKET;
mod plan;
mod stats;
mod subdivide;
mod walk;

pub(crate) use plan::{GridPlan, Resolution, Subdivision, filled_density, mostly_empty};
pub use plan::{Prune, cubical_resolution};
pub use stats::{GridLevelStats, LevelView};

use super::Frame;
use super::store::PrimStore;
use crate::geometry::Aabb;
use bounds::CellBounds;
use cells::{BlockIndex, CellIndex};
use header::GridHeader;

/// A reference with this bit set names a grid, not a store entry.
pub(crate) const GRID_TAG: u32 = 1 << 31;

/// Upper bound on cells in one grid: offsets for 2^28 cells take 1 GiB.
pub(crate) const MAX_CELLS: f64 = (1u64 << 28) as f64;

/// Reference budget per grid: when bounding-box binning would store more than
/// `64·items + 4096` references (big overlapping objects, coplanar stacks), the grid's
/// resolution is halved per axis until it fits, so memory stays `O(n)` on adversarial scenes:
/// at most `64·(n + g) + 4096·g` references in all for `n` objects in `g` grids.
pub(crate) const MAX_REFS_PER_ITEM: u64 = 64;
pub(crate) const MIN_REF_BUDGET: u64 = 4096;

/// A grid without a frame of its own.
const NO_FRAME: u32 = u32::MAX;

/// Nested uniform grids over a primitive store; see the module documentation.
pub(crate) struct GridHierarchy {
    pub store: PrimStore,
    grids: Vec<GridHeader>,
    frames: Vec<Frame>,
    cells: CellIndex,
    /// Which blocks of cells hold any, for the packet walk.
    blocks: BlockIndex,
    refs: Vec<u32>,
    /// The box of what each occupied cell holds ([`bounds`]).
    bounds: CellBounds,
    /// The margin every box was widened by (the module documentation).
    margin: f32,
    /// Whether cells test their triangles eight at a time (`accel::simd`): the processor has AVX2,
    /// the store's offsets fit the gathers, and the spec did not turn it off.
    simd: bool,
    /// Whether the walks are the ones compiled for AVX-512 (`Simd::Widest` where the
    /// processor has it).
    avx512: bool,
    /// Crowded cells [`Subdivision`] left uncut because the budgets would overflow.
    uncut: usize,
}

impl GridHierarchy {
    /// The box of grid `g` (in its frame, if it has one).
    pub fn grid_box(&self, g: usize) -> Aabb {
        Aabb::new(self.grids[g].min, self.grids[g].max)
    }

    /// Crowded cells left uncut by the reference and cell budgets ([`Subdivision`]).
    pub fn uncut_by_budget(&self) -> usize {
        self.uncut
    }

    /// The references, the occupied cells' bits and their starts: what two builds of the
    /// same grids must agree on.
    #[cfg(test)]
    pub(crate) fn layout(&self) -> (&[u32], &[u64], &[u32]) {
        (&self.refs, &self.cells.occupied, &self.cells.starts)
    }

    /// Each occupied cell of the grids without a frame: its box, the box of what it holds
    /// as the walks decode it ([`bounds`]), and its objects.
    #[cfg(test)]
    pub(crate) fn cell_boxes(&self) -> Vec<(Aabb, Aabb, Vec<u32>)> {
        let mut out = Vec::new();
        for h in self.grids.iter().filter(|h| h.frame == NO_FRAME) {
            let [rx, ry, rz] = h.res;
            for c in
                (0..rz).flat_map(|z| (0..ry).flat_map(move |y| (0..rx).map(move |x| [x, y, z])))
            {
                let idx = h.first_cell as usize
                    + c[0] as usize
                    + c[1] as usize * rx as usize
                    + c[2] as usize * (rx * ry) as usize;
                if let Some((s, e, rank)) = self.cells.range(idx) {
                    let (lo, hi) = self.bounds.get(h, rank, c.map(|x| x as i32), self.margin);
                    let objects = self.refs[s..e].iter().filter(|&&r| r & GRID_TAG == 0);
                    out.push((h.cell_box(c), Aabb::new(lo, hi), objects.copied().collect()));
                }
            }
        }
        out
    }

    pub fn grid_count(&self) -> usize {
        self.grids.len()
    }

    pub fn cell_count(&self) -> usize {
        self.cells.cells
    }

    pub fn reference_count(&self) -> usize {
        self.refs.len()
    }

    /// Cells per axis of grid `g`.
    pub fn resolution(&self, g: usize) -> [u32; 3] {
        self.grids[g].res
    }

    /// Bytes of the grids (headers, frames, offsets, references, occupancy), without the store.
    pub fn grid_memory_bytes(&self) -> usize {
        self.grids.capacity() * std::mem::size_of::<GridHeader>()
            + self.frames.capacity() * std::mem::size_of::<Frame>()
            + self.cells.memory_bytes()
            + self.blocks.memory_bytes()
            + self.bounds.memory_bytes()
            + 4 * self.refs.capacity()
    }

    /// Bytes of the whole structure: grids and store.
    pub fn memory_bytes(&self) -> usize {
        self.grid_memory_bytes() + self.store.memory_bytes()
    }
}
