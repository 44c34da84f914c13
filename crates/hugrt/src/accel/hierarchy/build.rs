//! Building the grids of a plan: boxes and resolutions bottom-up within the reference budget,
//! then every item binned into `(cell, reference)` pairs in parallel and sorted by cell (two
//! passes, no allocation per cell: RTNews "Quicker grid generation"), by a counting sort within
//! each grid ([`sort_into_cells`]), or a radix sort of all the pairs where cells are then
//! subdivided or the pairs are taken in slices. Every box is widened by the margin of the
//! module documentation before it is binned.

use super::bounds::CellBounds;
use super::cells::{BlockIndex, CellIndex};
use super::header::GridHeader;
use super::plan::{GridPlan, Prune, Subdivision};
use super::{GRID_TAG, GridHierarchy, MAX_REFS_PER_ITEM, MIN_REF_BUDGET, NO_FRAME};
use crate::accel::simd::{self, Simd};
use crate::accel::sort::radix_sort_high32_parts;
use crate::accel::store::{EntryBoxes, PrimStore, finite};
use crate::accel::{Frame, Primitives, SpecError};
use crate::geometry::{Aabb, TriangleBoxTest, Vec3};
use rayon::prelude::*;

/// Pairs binned and sorted at once, at most (about): 2^26, 512 MB of pairs and as much for the
/// sort's second buffer. Past that, the cells are taken in slices
/// ([`GridHierarchy::build_in_slices`]).
const SLICE_PAIRS: u64 = 1 << 26;

/// How the items of a grid become `(cell, reference)` pairs.
pub(super) struct Binner<'a, P> {
    pub(super) prims: &'a P,
    pub(super) store: &'a PrimStore,
    pub(super) boxes: &'a EntryBoxes<'a, P>,
    pub(super) margin: f32,
    /// Objects of a grid without frame spanning at least this many cells are referenced only
    /// by the cells they meet ([`Prune`]).
    pub(super) prune_span: u64,
}

impl<P: Primitives> Binner<'_, P> {
    /// Appends the pairs of items `range` of grid `h`, cells numbered from `h.first_cell`,
    /// whose cell lies in `keep`.
    pub(super) fn bin(
        &self,
        h: &GridHeader,
        it: &Items<P>,
        range: std::ops::Range<usize>,
        keep: &std::ops::Range<u64>,
        out: &mut Vec<u64>,
    ) {
        let index = |c: [u32; 3]| {
            h.first_cell as u64
                + (c[2] as u64 * h.res[1] as u64 + c[1] as u64) * h.res[0] as u64
                + c[0] as u64
        };
        let magnitude = Aabb::new(h.min, h.max).expand(self.margin).magnitude();
        for (r, b) in range.filter_map(|k| it.get(k)) {
            let (lo, hi) = h.cell_range(&b);
            if index(hi) < keep.start || index(lo) >= keep.end {
                continue;
            }
            let test = r & GRID_TAG == 0
                && h.frame == NO_FRAME
                && (0..3).map(|a| (hi[a] - lo[a] + 1) as u64).product::<u64>() >= self.prune_span;
            // A triangle's test is prepared once for all its cells, from the store's copy
            // (the geometry the grid's rays are tested against); other primitives ask theirs.
            let triangle = test
                .then(|| self.store.triangle(r))
                .flatten()
                .map(|v| TriangleBoxTest::new(&v).on_cells(h.min, h.size, self.margin, magnitude));
            // A cell is kept when the object meets it widened by the margin, which is what
            // the exactness argument asks of the references (module documentation).
            let mut keep_cell = |global: u64| {
                if keep.contains(&global) {
                    out.push(global << 32 | r as u64);
                }
            };
            match &triangle {
                Some(t) => t.cells(lo, hi, |cell| keep_cell(index(cell))),
                None => GridHierarchy::for_each_cell_of(h, lo, hi, |cell, i| {
                    if !test || {
                        let cell = h.cell_box(cell).expand(self.margin);
                        self.prims.overlaps_box(self.store.id(r) as usize, &cell)
                    } {
                        keep_cell(h.first_cell as u64 + i as u64);
                    }
                }),
            }
        }
    }
}

/// What one grid bins: its objects (store entries) then its children (tagged grid indices),
/// each with its box in the grid's frame widened by the margin. Objects without a finite box
/// are never binned.
pub(super) struct Items<'a, P> {
    pub(super) objects: &'a [u32],
    pub(super) boxes: &'a EntryBoxes<'a, P>,
    /// Boxes of `objects` in the grid's frame, when it has one.
    pub(super) turned: Option<Vec<Aabb>>,
    pub(super) children: Vec<(u32, Aabb)>,
    pub(super) margin: f32,
}

impl<P: Primitives> Items<'_, P> {
    pub(super) fn len(&self) -> usize {
        self.objects.len() + self.children.len()
    }

    /// Item `k`: its reference and widened box, or `None` if it is not binned.
    #[inline]
    pub(super) fn get(&self, k: usize) -> Option<(u32, Aabb)> {
        if let Some(&s) = self.objects.get(k) {
            let b = match &self.turned {
                Some(t) => t[k],
                None => self.boxes.get(s),
            };
            finite(&b).then(|| (s, b.expand(self.margin)))
        } else {
            Some(self.children[k - self.objects.len()])
        }
    }

    pub(super) fn bounds(&self) -> Aabb {
        (0..self.len())
            .into_par_iter()
            .filter_map(|k| self.get(k))
            .fold(|| Aabb::EMPTY, |a, (_, b)| a.union(&b))
            .reduce(|| Aabb::EMPTY, |a, b| a.union(&b))
    }
}

/// The references of `parts` (the binned lists of `tasks`, one each) in cell order, and their
/// cell index: a counting sort within each grid's cells, which come one grid after another.
/// A grid's lists are its tasks', in task order, and each list keeps its order within a cell,
/// so every cell lists its references as the stable radix sort of all the pairs did (a test
/// checks, against the sliced build). One pass counts and one places, with counters per grid
/// (a HUG's many small grids' stay in cache), where the radix sort went over every pair two or
/// three times and the cell index and the references took two more: the four kitchens' HUG
/// built 1.23× faster with it on one thread, the meshes' 1.06–1.13×, the uniform grid's
/// 1.03–1.13×.
fn sort_into_cells(
    parts: Vec<Vec<u64>>,
    tasks: &[(usize, std::ops::Range<usize>)],
    grids: &[GridHeader],
) -> (CellIndex, Vec<u32>) {
    use std::sync::atomic::{AtomicU32, Ordering::Relaxed};
    let first_cell = |t: usize| grids[tasks[t].0].first_cell as usize;
    // Each list's count of references per cell of its grid.
    let mut counts: Vec<Vec<u32>> = parts
        .par_iter()
        .enumerate()
        .map(|(t, part)| {
            let (mut count, first) = (vec![0u32; grids[tasks[t].0].cells()], first_cell(t));
            for &p in part {
                count[(p >> 32) as usize - first] += 1;
            }
            count
        })
        .collect();
    // The lists of each grid (consecutive tasks) and where its references begin.
    let mut groups: Vec<(usize, std::ops::Range<usize>, usize)> = Vec::new();
    let mut first = 0;
    for (t, (g, _)) in tasks.iter().enumerate() {
        match groups.last_mut() {
            Some((last, range, _)) if *last == *g => range.end = t + 1,
            _ => groups.push((*g, t..t + 1, first)),
        }
        first += parts[t].len();
    }
    let total = first;
    // Each list's counts become its cursors, cell by cell and list by list; each grid reports
    // its occupied cells (local index) and where their references start.
    let mut rest: &mut [Vec<u32>] = &mut counts;
    let mut jobs = Vec::with_capacity(groups.len());
    for (g, range, first) in &groups {
        let (mine, tail) = std::mem::take(&mut rest).split_at_mut(range.len());
        rest = tail;
        jobs.push((*g, mine, *first));
    }
    let occupied: Vec<Vec<(u32, u32)>> = jobs
        .into_par_iter()
        .map(|(g, lists, first)| {
            let mut at = first as u32;
            let mut out = Vec::new();
            for c in 0..grids[g].cells() {
                let start = at;
                for list in lists.iter_mut() {
                    (list[c], at) = (at, at + list[c]);
                }
                if at > start {
                    out.push((c as u32, start));
                }
            }
            out
        })
        .collect();
    // Atomic only so that the lists write their own, interleaved places from safe code: a
    // relaxed store is a plain store.
    let refs: Vec<AtomicU32> = (0..total).map(|_| AtomicU32::new(0)).collect();
    parts
        .par_iter()
        .zip(counts.par_iter_mut())
        .enumerate()
        .for_each(|(t, (part, cursor))| {
            let first = first_cell(t);
            for &p in part {
                let c = &mut cursor[(p >> 32) as usize - first];
                refs[*c as usize].store(p as u32, Relaxed);
                *c += 1;
            }
        });
    let cell_count = grids
        .last()
        .map_or(0, |h| h.first_cell as usize + h.cells());
    let mut index = CellIndex::empty(cell_count);
    for ((g, _, _), cells) in groups.iter().zip(&occupied) {
        index.extend_occupied(grids[*g].first_cell as usize, cells);
    }
    let refs: Vec<u32> = refs.into_iter().map(AtomicU32::into_inner).collect();
    (index.finish(total), refs)
}

impl GridHierarchy {
    /// The margin of the module documentation ([`crate::accel::margin`]) for a scene whose
    /// finite boxes span `bounds`, at least 10⁻³⁰ so that a scene of one point still gets
    /// cells that meet it.
    pub(super) fn margin_for(bounds: &Aabb) -> f32 {
        crate::accel::margin::margin_for(bounds).max(1e-30)
    }

    /// Builds the grids of `plans` (a grid's children come after it) over `store` (entries
    /// without a finite box are never binned). With `prune`, an object is referenced only by
    /// the cells its own surface meets ([`Primitives::overlaps_box`]) rather than every cell
    /// its box meets. With `subdivision`, crowded cells are then gridded again, top-down.
    ///
    /// `boxes`, when the caller has them, are the store's entries' boxes in store order
    /// ([`EntryBoxes`]).
    pub fn build<P: Primitives>(
        prims: &P,
        store: PrimStore,
        boxes: Option<Vec<Aabb>>,
        plans: &[GridPlan],
        prune: Prune,
        subdivision: Option<Subdivision>,
        simd: Simd,
    ) -> Result<GridHierarchy, SpecError> {
        Self::build_in_slices(
            prims,
            store,
            boxes,
            plans,
            prune,
            subdivision,
            simd,
            SLICE_PAIRS,
        )
    }

    /// [`GridHierarchy::build`], binning and sorting at most about `slice_pairs` pairs at
    /// once where no cell is subdivided: beyond that the cells are taken in slices, the
    /// items binned again for each (keeping only the pairs of the slice's cells) and each
    /// slice's pairs sorted alone, into references and cell starts made at their final
    /// size. The grids are the same, reference for reference (a test checks); the pairs,
    /// 16 bytes a reference while they are sorted where a reference takes 4, never exist all
    /// at once.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn build_in_slices<P: Primitives>(
        prims: &P,
        store: PrimStore,
        boxes: Option<Vec<Aabb>>,
        plans: &[GridPlan],
        prune: Prune,
        subdivision: Option<Subdivision>,
        simd: Simd,
        slice_pairs: u64,
    ) -> Result<GridHierarchy, SpecError> {
        let boxes = EntryBoxes::new(prims, &store, boxes);
        let scene = (0..store.len() as u32)
            .into_par_iter()
            .map(|s| boxes.get(s))
            .filter(finite)
            .reduce(|| Aabb::EMPTY, |a, b| a.union(&b));
        let margin = Self::margin_for(&scene);
        let mut frames = Vec::new();
        let mut grids: Vec<GridHeader> = plans
            .iter()
            .map(|p| {
                let frame = match p.frame {
                    Some(f) => {
                        frames.push(f);
                        frames.len() as u32 - 1
                    }
                    None => NO_FRAME,
                };
                GridHeader {
                    min: Vec3::ZERO,
                    max: Vec3::ZERO,
                    size: Vec3::ONE,
                    inv_size: Vec3::ONE,
                    res: [1, 1, 1],
                    first_cell: 0,
                    frame,
                    depth: p.depth,
                    level: p.level,
                    objects: p.objects.len() as u32,
                }
            })
            .collect();
        // Boxes and resolutions bottom-up: a grid's box covers its children's.
        let mut items: Vec<Option<Items<P>>> = (0..plans.len()).map(|_| None).collect();
        for g in (0..plans.len()).rev() {
            let it = Self::items(&boxes, &store, &frames, &grids, &plans[g], g, margin);
            // A root covers the whole scene: its box is the scene's, already known.
            let bounds = if plans[g].scene_box && plans[g].frame.is_none() {
                scene
            } else {
                it.bounds()
            };
            let bounds = if bounds.is_empty() {
                Aabb::new(Vec3::ZERO, Vec3::ZERO)
            } else {
                bounds
            };
            let h = &mut grids[g];
            // Flat axes get a thickness so that every cell has a positive size.
            let b = bounds.expand(margin);
            (h.min, h.max) = (b.min, b.max);
            h.set_resolution(plans[g].resolution.cells_per_axis(b.extent()));
            Self::fit_budget(h, &it, plans[g].shift);
            items[g] = Some(it);
        }
        let items: Vec<Items<P>> = items.into_iter().flatten().collect();
        let mut total_cells = 0u64;
        for h in &mut grids {
            h.first_cell = total_cells as u32;
            total_cells += h.cells() as u64;
        }
        if total_cells >= u32::MAX as u64 {
            return Err(SpecError::Build(format!(
                "{total_cells} cells: more than one hierarchy can address"
            )));
        }
        let binner = Binner {
            prims,
            store: &store,
            boxes: &boxes,
            margin,
            prune_span: match prune {
                Prune::None => u64::MAX,
                Prune::All => 1,
                Prune::Large => Prune::LARGE,
            },
        };
        // Pass 1: every reference as (cell among all grids' cells, reference), grid by grid
        // and item by item; a grid of many items in chunks, in parallel.
        let threads = rayon::current_num_threads().clamp(1, 16);
        let tasks: Vec<(usize, std::ops::Range<usize>)> = items
            .iter()
            .enumerate()
            .flat_map(|(g, it)| {
                let (n, k) = (it.len(), if it.len() >= 1 << 15 { threads } else { 1 });
                (0..k).map(move |c| (g, c * n / k..(c + 1) * n / k))
            })
            .collect();
        let avx512 = simd == Simd::Widest && simd::avx512_available() && store.simd_fits();
        let simd = simd != Simd::Off && simd::available() && store.simd_fits();
        // The pairs of the cells in `keep`, a list per task. Pass 2 sorts them stably by cell,
        // the lists as they are, in task order: each cell keeps its objects in store order,
        // then its grids.
        let binned = |keep: std::ops::Range<u64>| -> Vec<Vec<u64>> {
            tasks
                .par_iter()
                .map(|(g, range)| {
                    let mut out = Vec::new();
                    binner.bin(&grids[*g], &items[*g], range.clone(), &keep, &mut out);
                    out
                })
                .collect()
        };
        // A sample of every grid's box references (an upper bound where pruned) says whether
        // the pairs fit at once; builds of fewer items than that can make are not sampled.
        let item_count: u64 = items.iter().map(|it| it.len() as u64).sum();
        let estimate: u64 =
            if subdivision.is_some() || item_count * MAX_REFS_PER_ITEM <= slice_pairs {
                0
            } else {
                grids
                    .iter()
                    .zip(&items)
                    .map(|(h, it)| {
                        let step = (it.len() / 1024).max(1);
                        Self::box_reference_count(h, it, step) * step as u64
                    })
                    .sum()
            };
        let slices = estimate.div_ceil(slice_pairs.max(1)).max(1);
        if slices > 1 {
            let bound: u64 = grids
                .iter()
                .zip(&items)
                .map(|(h, it)| Self::box_reference_count(h, it, 1))
                .sum();
            if bound >= u32::MAX as u64 {
                return Err(SpecError::Build(format!(
                    "{bound} references: more than one hierarchy can address"
                )));
            }
            let mut refs: Vec<u32> = Vec::with_capacity(bound as usize);
            let mut cells = CellIndex::empty(total_cells as usize);
            for k in 0..slices {
                let keep = k * total_cells / slices..(k + 1) * total_cells / slices;
                let pairs = radix_sort_high32_parts(binned(keep));
                cells.extend_sorted(&pairs, refs.len());
                refs.par_extend(pairs.par_iter().map(|&p| p as u32));
            }
            refs.shrink_to_fit();
            let cells = cells.finish(refs.len());
            let bounds = CellBounds::build(&boxes, &grids, &cells, &refs);
            drop(boxes);
            return Ok(GridHierarchy {
                blocks: BlockIndex::new(&grids, &cells),
                bounds,
                margin,
                cells,
                refs,
                store,
                grids,
                frames,
                simd,
                avx512,
                uncut: 0,
            });
        }
        let pairs = binned(0..u64::MAX);
        drop(items);
        let count: usize = pairs.iter().map(Vec::len).sum();
        if count >= u32::MAX as usize {
            return Err(SpecError::Build(format!(
                "{count} references: more than one hierarchy can address"
            )));
        }
        // Pass 2: the cell index and the references, from the pairs sorted by cell. The
        // counting sort's counters (a grid's cells for each of its lists) may take twice the
        // memory of the radix sort's second buffer of pairs, no more: a fine grid binned in
        // many lists on a machine of many threads takes the radix sort.
        let mut uncut = 0;
        let counters: usize = tasks.iter().map(|(g, _)| grids[*g].cells()).sum();
        let (cells, refs) = match subdivision {
            None if counters <= 4 * count => sort_into_cells(pairs, &tasks, &grids),
            _ => {
                let mut pairs = radix_sort_high32_parts(pairs);
                if let Some(sub) = subdivision {
                    pairs = Self::subdivide(
                        &binner,
                        &mut grids,
                        pairs,
                        &mut total_cells,
                        &sub,
                        &mut uncut,
                    );
                }
                let cells = CellIndex::from_sorted(&pairs, total_cells as usize);
                (cells, pairs.par_iter().map(|&p| p as u32).collect())
            }
        };
        let bounds = CellBounds::build(&boxes, &grids, &cells, &refs);
        drop(boxes);
        Ok(GridHierarchy {
            blocks: BlockIndex::new(&grids, &cells),
            bounds,
            margin,
            store,
            grids,
            frames,
            cells,
            refs,
            simd,
            avx512,
            uncut,
        })
    }

    /// Coarsens `h` until box binning its items stays within the reference budget
    /// ([`MAX_REFS_PER_ITEM`]), with its planes shifted when `shift`
    /// ([`GridHeader::shift_planes`], applied here): the budget holds for the grid as binned,
    /// whose shift adds a cell along axes of 4 or more (64 cells of 100,000 overlapping
    /// objects, exactly the budget, became 125 and twice it once shifted).
    ///
    /// Each step keeps 79% of the cells along each axis, about half the cells: halving every
    /// axis (an eighth of the cells a step) left the nested spheres of SPD shells, whose HUG
    /// grids are at the budget, with 1,280 cells where this finds 2,619, and their 512² render
    /// took 1.7 times as long (1,253 against 739 ms).
    pub(super) fn fit_budget<P: Primitives>(h: &mut GridHeader, it: &Items<P>, shift: bool) {
        let budget = (MAX_REFS_PER_ITEM * it.len() as u64)
            .max(MIN_REF_BUDGET)
            .min(u32::MAX as u64 / 2);
        // A sample tells most grids that they are far within the budget; the others count
        // exactly.
        let step = (it.len() / 1024).max(1);
        loop {
            let mut binned = *h;
            if shift {
                binned.shift_planes();
            }
            let sampled = Self::box_reference_count(&binned, it, step) * step as u64;
            if sampled <= budget / 4
                || Self::box_reference_count(&binned, it, 1) <= budget
                || h.res == [1, 1, 1]
            {
                *h = binned;
                return;
            }
            h.set_resolution(h.res.map(|r| ((r as f32 * 0.79) as u32).max(1)));
        }
    }

    /// The items grid `g` bins (four margins in a turned frame: the turn rounds too).
    pub(super) fn items<'a, P: Primitives>(
        boxes: &'a EntryBoxes<'a, P>,
        store: &PrimStore,
        frames: &[Frame],
        grids: &[GridHeader],
        plan: &'a GridPlan,
        g: usize,
        margin: f32,
    ) -> Items<'a, P> {
        let frame = plan.frame;
        let turned = frame.map(|f| {
            plan.objects
                .par_iter()
                .map(|&s| store.local_bounds(s, &f, &boxes.get(s)))
                .collect()
        });
        let m = if frame.is_some() {
            4.0 * margin
        } else {
            margin
        };
        let children = plan
            .children
            .iter()
            .map(|&c| {
                debug_assert!(c as usize > g, "a grid's children come after it");
                let cb = grids[c as usize].world_box(frames);
                let b = match &frame {
                    Some(f) => f.local_box(&cb),
                    None => cb,
                };
                (c | GRID_TAG, b.expand(m))
            })
            .collect();
        Items {
            objects: &plan.objects,
            boxes,
            turned,
            children,
            margin: m,
        }
    }

    /// The number of references box binning makes in `h` for every `step`-th item, without
    /// touching cells.
    pub(super) fn box_reference_count<P: Primitives>(
        h: &GridHeader,
        items: &Items<P>,
        step: usize,
    ) -> u64 {
        (0..items.len().div_ceil(step))
            .into_par_iter()
            .filter_map(|k| items.get(k * step))
            .map(|(_, b)| {
                let (lo, hi) = h.cell_range(&b);
                (0..3).map(|a| (hi[a] - lo[a] + 1) as u64).product::<u64>()
            })
            .sum()
    }

    /// Visits the cells of `h` from `lo` to `hi` (the cells a box meets, its
    /// [`GridHeader::cell_range`]): their coordinates and their indices within the grid.
    pub(super) fn for_each_cell_of(
        h: &GridHeader,
        lo: [u32; 3],
        hi: [u32; 3],
        mut f: impl FnMut([u32; 3], usize),
    ) {
        let (rx, ry) = (h.res[0] as usize, h.res[1] as usize);
        for z in lo[2]..=hi[2] {
            for y in lo[1]..=hi[1] {
                for x in lo[0]..=hi[0] {
                    f([x, y, z], (z as usize * ry + y as usize) * rx + x as usize);
                }
            }
        }
    }
}
