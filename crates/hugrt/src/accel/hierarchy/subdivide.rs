//! Cutting crowded cells again, top-down ([`Subdivision`]): the recursive grid's, the octree's
//! and the adaptive grid's sub-grids, level by level within the reference and cell budgets.

use super::build::{Binner, Items};
use super::header::GridHeader;
use super::plan::Subdivision;
use super::{GRID_TAG, GridHierarchy, MAX_REFS_PER_ITEM, MIN_REF_BUDGET, NO_FRAME};
use crate::accel::Primitives;
use rayon::prelude::*;

/// Objects of crowded cells binned together before the budgets decide which cells are cut:
/// at most `64·` this many pairs (8 bytes each) wait at once.
const CHUNK_OBJECTS: usize = 1 << 18;

impl GridHierarchy {
    /// Grids again every crowded cell ([`Subdivision`]), level by level: the sorted `pairs`
    /// of the grids built so far in, the sorted pairs of all grids out. A cut cell's object
    /// pairs give way to one pair naming its sub-grid, whose cells come after all others, so
    /// that the pairs stay sorted by cell.
    pub(super) fn subdivide<P: Primitives>(
        binner: &Binner<P>,
        grids: &mut Vec<GridHeader>,
        mut pairs: Vec<u64>,
        total_cells: &mut u64,
        sub: &Subdivision,
        uncut: &mut usize,
    ) -> Vec<u64> {
        let n = binner.store.len() as u64;
        let ref_budget = 2 * (MAX_REFS_PER_ITEM * n + MIN_REF_BUDGET);
        let cell_budget =
            (*total_cells + MAX_REFS_PER_ITEM * n + MIN_REF_BUDGET).min(u32::MAX as u64 - 1);
        let mut first_grid = 0;
        while first_grid < grids.len() {
            let last_grid = grids.len();
            // The crowded cells of this level's grids: (first pair, end, grid, objects).
            let mut runs = Vec::new();
            let first_cell = grids[first_grid].first_cell as u64;
            let mut k = pairs.partition_point(|&p| p >> 32 < first_cell);
            let mut g = first_grid;
            while k < pairs.len() {
                let c = pairs[k] >> 32;
                let e = k + pairs[k..].partition_point(|&p| p >> 32 == c);
                while g + 1 < last_grid && grids[g + 1].first_cell as u64 <= c {
                    g += 1;
                }
                let h = &grids[g];
                let objects = pairs[k..e]
                    .iter()
                    .take_while(|&&p| p as u32 & GRID_TAG == 0)
                    .count();
                if objects > sub.maxp
                    && h.depth < sub.max_depth
                    && h.frame == NO_FRAME
                    && (!sub.guard || objects < h.objects as usize)
                {
                    runs.push((k, e, g, objects));
                }
                k = e;
            }
            let mut refs = pairs.len() as u64;
            let mut cut = Vec::new();
            let mut appended = Vec::new();
            // The candidates are binned a chunk at a time and kept or dropped in order, so that
            // only one chunk's pairs wait for the budgets' verdict: binned all at once, a
            // level of many crowded cells held them all (7.3 GB to build a 159 MB recursive
            // grid of 277k polygons), most of them to be dropped.
            let mut start = 0;
            while start < runs.len() {
                let mut end = start;
                let mut objects_in_chunk = 0;
                while end < runs.len() && (end == start || objects_in_chunk < CHUNK_OBJECTS) {
                    objects_in_chunk += runs[end].3;
                    end += 1;
                }
                let made: Vec<(GridHeader, Vec<u64>)> = runs[start..end]
                    .par_iter()
                    .map(|&(k, _, g, objects)| {
                        let parent = &grids[g];
                        let c = ((pairs[k] >> 32) - parent.first_cell as u64) as u32;
                        let (rx, ry) = (parent.res[0], parent.res[1]);
                        let b = parent
                            .cell_box([c % rx, c / rx % ry, c / (rx * ry)])
                            .expand(binner.margin);
                        let objects: Vec<u32> =
                            pairs[k..k + objects].iter().map(|&p| p as u32).collect();
                        let mut h = GridHeader {
                            depth: parent.depth + 1,
                            level: parent.level + 1,
                            objects: objects.len() as u32,
                            ..GridHeader::over(
                                &b,
                                sub.cells
                                    .for_objects(objects.len())
                                    .cells_per_axis(b.extent()),
                            )
                        };
                        let it = Items {
                            objects: &objects,
                            boxes: binner.boxes,
                            turned: None,
                            children: Vec::new(),
                            margin: binner.margin,
                        };
                        Self::fit_budget(&mut h, &it, false);
                        let mut out = Vec::new();
                        binner.bin(&h, &it, 0..it.len(), &(0..u64::MAX), &mut out);
                        out.sort_by_key(|&p| p >> 32);
                        (h, out)
                    })
                    .collect();
                for (&(k, e, _, objects), (mut h, out)) in runs[start..end].iter().zip(made) {
                    let cells = h.cells() as u64;
                    let after = refs + out.len() as u64 + 1 - objects as u64;
                    if after > ref_budget || *total_cells + cells > cell_budget {
                        *uncut += 1;
                        continue;
                    }
                    refs = after;
                    h.first_cell = *total_cells as u32;
                    *total_cells += cells;
                    let offset = (h.first_cell as u64) << 32;
                    appended.extend(out.iter().map(|&p| p + offset));
                    cut.push((k, e, objects, grids.len() as u32));
                    grids.push(h);
                }
                start = end;
            }
            if cut.is_empty() {
                break;
            }
            let mut next = Vec::with_capacity(refs as usize);
            let mut at = 0;
            for (k, e, objects, child) in cut {
                next.extend_from_slice(&pairs[at..k]);
                next.extend_from_slice(&pairs[k + objects..e]);
                next.push((pairs[k] >> 32) << 32 | (child | GRID_TAG) as u64);
                at = e;
            }
            next.extend_from_slice(&pairs[at..]);
            next.extend(appended);
            pairs = next;
            first_grid = last_grid;
        }
        pairs
    }
}
