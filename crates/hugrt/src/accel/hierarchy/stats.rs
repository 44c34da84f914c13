//! SCG97 §3's statistics of a grid hierarchy, per level or per nesting depth.

use super::header::GridHeader;
use super::{GRID_TAG, GridHierarchy};
use crate::geometry::Aabb;
use serde::Serialize;

impl GridHierarchy {
    /// The statistics of SCG97 §3 for each level of the hierarchy (level 0 = the top), the
    /// levels being the grids' [`GridPlan::level`] (a HUG's filter levels, as SCG97's tables
    /// report them) or their nesting depths.
    ///
    /// An object is counted once, at the level that stores it (SCG97 §3: "the percentages of
    /// polygons stored at that level"): a HUG stores each object in one grid; a recursive
    /// grid's object that lies both in a cut cell and in one that was not cut is stored at
    /// two levels, and counts at the deeper one, where it was handed down. So `%obj` sums to
    /// 100 over the levels.
    pub fn level_stats(&self, view: LevelView) -> Vec<GridLevelStats> {
        let key = |h: &GridHeader| match view {
            LevelView::Level => h.level as usize,
            LevelView::Depth => h.depth as usize,
        };
        let levels = self.grids.iter().map(|h| key(h) + 1).max().unwrap_or(0);
        let mut out: Vec<GridLevelStats> = (0..levels)
            .map(|level| GridLevelStats {
                level,
                ..GridLevelStats::default()
            })
            .collect();
        // Per level, over its cells: objects and grids per cell, their squares, and the
        // number of cells holding any.
        let mut objects_per_cell = vec![Moments::default(); levels];
        let mut grids_per_cell = vec![Moments::default(); levels];
        // The deepest level storing each store entry, plus one (0: stored nowhere).
        let mut stored_at = vec![0u8; self.store.len()];
        for h in &self.grids {
            let d = key(h);
            let l = &mut out[d];
            l.grids += 1;
            l.cells += h.cells();
            l.volume += volume(h);
            let cell_volume = volume(h) / h.cells().max(1) as f64;
            l.memory_bytes += std::mem::size_of::<GridHeader>() + h.cells().div_ceil(64) * 12;
            let first = h.first_cell as usize;
            for c in first..first + h.cells() {
                let refs = self
                    .cells
                    .range(c)
                    .map_or(&[][..], |(s, e, _)| &self.refs[s..e]);
                let g = refs.iter().filter(|&&r| r & GRID_TAG != 0).count();
                l.memory_bytes += 4 * !refs.is_empty() as usize;
                l.object_refs += refs.len() - g;
                l.grid_refs += g;
                if refs.len() > g {
                    l.object_cells += 1;
                    l.object_cell_volume += cell_volume;
                } else if g > 0 {
                    l.grid_only_cells += 1;
                }
                for &r in &refs[..refs.len() - g] {
                    let at = &mut stored_at[r as usize];
                    *at = (*at).max(d.min(254) as u8 + 1);
                }
                objects_per_cell[d].add((refs.len() - g) as f64);
                l.max_o_v = l.max_o_v.max(refs.len() - g);
                grids_per_cell[d].add(g as f64);
            }
        }
        for &at in &stored_at {
            if at > 0 {
                out[at as usize - 1].objects += 1;
            }
        }
        // The volume the top grids cover (one root, or an adaptive grid's clusters).
        let root_volume = self
            .grids
            .iter()
            .filter(|h| h.depth == 0)
            .fold(Aabb::EMPTY, |a, h| a.union(&Aabb::new(h.min, h.max)));
        let root_volume = if root_volume.is_empty() {
            0.0
        } else {
            root_volume.extent().as_dvec3().element_product()
        };
        let total = |f: fn(&GridLevelStats) -> usize| out.iter().map(f).sum::<usize>().max(1);
        let (to, tg, tc, tp) = (
            total(|l| l.objects),
            total(|l| l.grids),
            total(|l| l.cells),
            total(|l| l.object_refs + l.grid_refs),
        );
        let pct = |x: usize, t: usize| 100.0 * x as f64 / t as f64;
        for ((l, o), g) in out.iter_mut().zip(&objects_per_cell).zip(&grids_per_cell) {
            l.memory_bytes += 4 * (l.object_refs + l.grid_refs);
            l.pct_obj = pct(l.objects, to);
            l.pct_grids = pct(l.grids, tg);
            l.pct_voxels = pct(l.cells, tc);
            l.pct_ptrs = pct(l.object_refs + l.grid_refs, tp);
            l.pct_vol = if root_volume > 0.0 {
                100.0 * l.volume / root_volume
            } else {
                100.0
            };
            l.mu_o_g = if l.pct_grids > 0.0 {
                l.pct_obj / l.pct_grids
            } else {
                0.0
            };
            l.mu_o_g_raw = l.objects as f64 / l.grids.max(1) as f64;
            l.pct_o = pct(o.nonzero, l.cells.max(1));
            (l.mu_o_v, l.sigma_o_v) = o.mean_sd(false);
            (l.mu_o_v_nonempty, l.sigma_o_v_nonempty) = o.mean_sd(true);
            l.pct_g = pct(g.nonzero, l.cells.max(1));
            (l.mu_g_v, l.sigma_g_v) = g.mean_sd(false);
            (l.mu_g_v_nonempty, l.sigma_g_v_nonempty) = g.mean_sd(true);
        }
        out
    }
}

/// Which levels the statistics of a grid hierarchy group its grids by.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LevelView {
    /// The grids' levels: a HUG's filter levels (SCG97's tables), the depth elsewhere.
    Level,
    /// Nesting depth: which grids lie inside how many others.
    Depth,
}

fn volume(h: &GridHeader) -> f64 {
    let e = (h.max - h.min).as_dvec3();
    e.x * e.y * e.z
}

/// Count, sum and sum of squares of a sample, and how many of its values are not zero. Zeros
/// add nothing to the sums, so the moments over the non-zero values come from the same sums.
#[derive(Clone, Copy, Default)]
struct Moments {
    n: usize,
    nonzero: usize,
    sum: f64,
    sum2: f64,
}

impl Moments {
    fn add(&mut self, x: f64) {
        self.n += 1;
        self.nonzero += (x != 0.0) as usize;
        self.sum += x;
        self.sum2 += x * x;
    }

    /// Mean and standard deviation over all values, or over the non-zero ones.
    fn mean_sd(&self, nonzero_only: bool) -> (f64, f64) {
        let n = if nonzero_only { self.nonzero } else { self.n } as f64;
        if n == 0.0 {
            return (0.0, 0.0);
        }
        let m = self.sum / n;
        (m, (self.sum2 / n - m * m).max(0.0).sqrt())
    }
}

/// The statistics of one hierarchy level (SCG97 §3; level 0 is the top here, where the paper
/// numbers levels from the smallest objects up).
///
/// * Resource repartition: `pct_obj`, `pct_grids`, `pct_voxels`, `pct_ptrs` are the level's
///   shares of objects stored (each object once, at the level that stores it), grids,
///   cells and references (to objects and to grids); `pct_vol` the summed volume of its grids
///   as built (their boxes with the margin and any shifted planes) over the root's (over 100%
///   in total as soon as two levels are used; SCG97 §7.1 reads a sum far above, say 120%, as
///   clusters too loose).
/// * Occupancy: `mu_o_g` as SCG97's figure tables give it, the level's share of objects over
///   its share of grids (Fig. 14: 82.6 / 70 = 1.18), and `mu_o_g_raw` the plain mean, objects
///   per grid; `pct_o` the share of cells holding objects;
///   `mu_o_v`, `sigma_o_v` objects per cell, and `mu_o_v_nonempty`, `sigma_o_v_nonempty` per
///   cell holding objects (the paper's μo'_v, σo'_v); the same for grids referenced per cell
///   (`pct_g`, `mu_g_v`, `sigma_g_v`, `mu_g_v_nonempty`, `sigma_g_v_nonempty`).
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct GridLevelStats {
    pub level: usize,
    pub grids: usize,
    pub objects: usize,
    pub cells: usize,
    pub object_refs: usize,
    pub grid_refs: usize,
    /// Cells holding at least one object reference, and their summed volume.
    pub object_cells: usize,
    /// Cells holding sub-grids and no object: inner cells of the hierarchy, not elementary
    /// ones (Havran's septet counts only elementary cells).
    pub grid_only_cells: usize,
    pub object_cell_volume: f64,
    /// Summed volume of the level's grids.
    pub volume: f64,
    /// Bytes of the level's grid headers, offsets, occupancy bits and references.
    pub memory_bytes: usize,
    pub pct_obj: f64,
    pub pct_grids: f64,
    pub pct_voxels: f64,
    pub pct_ptrs: f64,
    pub pct_vol: f64,
    pub mu_o_g: f64,
    pub mu_o_g_raw: f64,
    pub pct_o: f64,
    pub mu_o_v: f64,
    pub sigma_o_v: f64,
    pub mu_o_v_nonempty: f64,
    pub sigma_o_v_nonempty: f64,
    /// The most objects any cell of the level references.
    pub max_o_v: usize,
    pub pct_g: f64,
    pub mu_g_v: f64,
    pub sigma_g_v: f64,
    pub mu_g_v_nonempty: f64,
    pub sigma_g_v_nonempty: f64,
}
