//! The box of what each occupied cell holds, so that a ray crossing the cell away from its
//! objects skips their tests.
//!
//! A cell of a uniform grid is a cube, and the objects referenced there rarely fill it: a
//! patch of a mesh is a thin sheet across it, a small object a corner of it. A ray that
//! crosses the cell tests them all the same. Here every occupied cell also keeps the box of
//! its objects' boxes clipped to the cell, and the walks test a ray against that box first,
//! as a bvh tests a node: on incoherent rays this leaves out a fifth (the bunny) to two fifths
//! (the kitchen) of the triangle tests. A hugrt addition, not the papers': EG95 and SCG97
//! test a cell's objects whenever the ray enters the cell. The grids a cell references are
//! walked either way (they have their own boxes).
//!
//! The box is stored as two bytes a side, the cell's side cut in [`STEPS`], rounded outwards:
//! 12 bytes an occupied cell, where four floats a side would take 24. A byte a side was too
//! coarse: a step of 1/255 of a world grid's large cell is thicker than the gap between a
//! shadow ray's start and the floor it leaves, and the city's shadow rays kept testing the
//! floor (docs/measurements.md, "The box of what each cell holds").
//!
//! Decoded, the box is widened by the hierarchy's margin (the module documentation of
//! [`super`]): a point of an object that the walk may place in the cell, up to the rounding
//! of the cell's planes, lies inside the decoded box by more than the rounding of the ray's
//! slab test, so no hit is lost. An object that only its margin brought into the cell is
//! found in the cells it lies in, which the walk visits. A cell holding only grids has an
//! empty box.

use super::cells::CellIndex;
use super::header::GridHeader;
use super::{GRID_TAG, NO_FRAME};
use crate::accel::Primitives;
use crate::accel::store::EntryBoxes;
use crate::geometry::{Aabb, Vec3};
use rayon::prelude::*;

/// Parts a cell's side is cut into: the box's sides fall on these steps.
const STEPS: f32 = u16::MAX as f32;

/// Occupancy words handed to one task of the build: 4,096 cells. At 65,536 cells a task, a
/// scene of one or two grids (the stadium's 49,446 cells, the kitchen's 76,855) was one or
/// two tasks on two threads, and the boxes took 0.9 and 1.4 ms of their builds; now 0.5 and
/// 1.0 (docs/measurements.md, "The cells' boxes in smaller tasks").
const WORDS_PER_TASK: usize = 64;

/// The box every cell of a grid in a frame of its own gets (the whole cell): its objects'
/// boxes would have to be turned into the frame, and such grids (`hug:pca=true`) are few.
const WHOLE: [u16; 6] = [0, 0, 0, u16::MAX, u16::MAX, u16::MAX];

/// The boxes of the occupied cells of every grid, in the order of their ranks
/// ([`CellIndex`]).
pub(super) struct CellBounds {
    boxes: Vec<[u16; 6]>,
}

impl CellBounds {
    /// The boxes of the occupied cells of `grids`: for each, the union of its objects' boxes
    /// (store entries of `refs`, their boxes read from `entries`), each clipped to the cell,
    /// rounded outwards to [`STEPS`].
    pub(super) fn build<P: Primitives>(
        entries: &EntryBoxes<'_, P>,
        grids: &[GridHeader],
        cells: &CellIndex,
        refs: &[u32],
    ) -> CellBounds {
        let firsts: Vec<usize> = grids.iter().map(|h| h.first_cell as usize).collect();
        debug_assert!(firsts.is_sorted(), "grids' cells lie in grid order");
        let words = cells.occupied.len();
        let mut boxes = vec![[0u16; 6]; cells.starts.len() - 1];
        // Each task's words and its share of the boxes, from the ranks of its first word.
        let mut tasks = Vec::new();
        let mut rest = &mut boxes[..];
        for first_word in (0..words).step_by(WORDS_PER_TASK) {
            let last_word = (first_word + WORDS_PER_TASK).min(words);
            let held = match cells.rank.get(last_word) {
                Some(&r) => r as usize - cells.rank[first_word] as usize,
                None => rest.len(),
            };
            let (mine, others) = std::mem::take(&mut rest).split_at_mut(held);
            rest = others;
            tasks.push((first_word..last_word, mine));
        }
        tasks.into_par_iter().for_each(|(words, out)| {
            let mut g = firsts.partition_point(|&f| f <= words.start * 64).max(1) - 1;
            let mut at = 0;
            for w in words {
                let mut bits = cells.occupied[w];
                while bits != 0 {
                    let idx = w * 64 + bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    while g + 1 < firsts.len() && firsts[g + 1] <= idx {
                        g += 1;
                    }
                    let (s, e, _) = cells.range(idx).expect("an occupied cell");
                    out[at] = cell_box(entries, &grids[g], idx, &refs[s..e]);
                    at += 1;
                }
            }
        });
        CellBounds { boxes }
    }

    /// The box of the occupied cell of rank `rank`, `(cell, cell + 1)` of grid `h` (integer
    /// coordinates), widened by `margin`: `(min, max)`.
    #[inline(always)]
    pub(super) fn get(
        &self,
        h: &GridHeader,
        rank: usize,
        cell: [i32; 3],
        margin: f32,
    ) -> (Vec3, Vec3) {
        let q = self.boxes[rank];
        let c = Vec3::new(cell[0] as f32, cell[1] as f32, cell[2] as f32);
        let step = h.size * (1.0 / STEPS);
        let corner = h.min + c * h.size;
        let lo = Vec3::new(q[0] as f32, q[1] as f32, q[2] as f32);
        let hi = Vec3::new(q[3] as f32, q[4] as f32, q[5] as f32);
        (
            corner + lo * step - Vec3::splat(margin),
            corner + hi * step + Vec3::splat(margin),
        )
    }

    pub(super) fn memory_bytes(&self) -> usize {
        12 * self.boxes.capacity()
    }
}

/// The quantised box of cell `idx` (among all grids' cells) of grid `h`, which references
/// `refs`.
fn cell_box<P: Primitives>(
    entries: &EntryBoxes<'_, P>,
    h: &GridHeader,
    idx: usize,
    refs: &[u32],
) -> [u16; 6] {
    if h.frame != NO_FRAME {
        return WHOLE;
    }
    // A grid has fewer than 2^28 cells (`MAX_CELLS`): 32-bit divisions.
    let local = (idx - h.first_cell as usize) as u32;
    let (rx, rxy) = (h.res[0], h.res[0] * h.res[1]);
    let (z, in_layer) = (local / rxy, local % rxy);
    let c = [in_layer % rx, in_layer / rx, z];
    let cell = h.cell_box(c);
    let mut held = Aabb::EMPTY;
    for &r in refs {
        if r & GRID_TAG != 0 {
            continue;
        }
        // Only objects with a finite box are binned.
        held = held.union(&entries.get(r));
    }
    let lo = held.min.max(cell.min);
    let hi = held.max.min(cell.max);
    if held.is_empty() || lo.cmpgt(hi).any() {
        // Only grids, or objects that the binning's margin alone brought here.
        return [u16::MAX, u16::MAX, u16::MAX, 0, 0, 0];
    }
    let scale = Vec3::splat(STEPS) / h.size;
    let qlo = (lo - cell.min) * scale;
    let qhi = (hi - cell.min) * scale;
    // The steps' floor and ceiling, clamped to the cell, and outwards where a step is not a
    // number. The values are not negative (`lo` and `hi` lie above the cell's corner), so the
    // truncating casts are the floor: `f32::floor` and `ceil` are calls to software routines
    // without SSE4.1 (the baseline).
    let low = |x: f32| if x > 0.0 { x.min(STEPS) as u16 } else { 0 };
    let high = |x: f32| {
        if x < STEPS {
            let t = x.max(0.0) as u16;
            t + ((t as f32) < x) as u16
        } else {
            u16::MAX
        }
    };
    [
        low(qlo.x),
        low(qlo.y),
        low(qlo.z),
        high(qhi.x),
        high(qhi.y),
        high(qhi.z),
    ]
}
