//! Uniform grid (EG95 §1.2.1; RTNews "Comparison of Hierarchical Grids" and "Quicker Grid
//! Generation via Memory Allocation").
//!
//! * Resolution: about `density · n` cells, as cubical as possible ([`cubical_resolution`]).
//!   `density = 1` is the cube-root rule; RTNews found `D = 20` faster on the SPD scenes.
//! * Build in two passes: count the references of every cell, prefix-sum the counts into
//!   offsets, fill one flat array. No linked lists, no allocation per cell.
//! * References by bounding-box overlap, or with `prune=true` by an exact primitive/cell test.
//! * Traversal: the 3D-DDA of Amanatides and Woo with the exit cell precomputed per axis, so a
//!   step costs two comparisons for the axis choice and one for the exit test; mailboxing; a
//!   hit ends the walk only once it lies inside the current cell.
//!
//! Robustness: each primitive's box is widened by a tiny margin relative to the grid's
//! coordinate magnitude before it is binned, and the walk stops only when the best hit lies
//! before the cell's exit by a per-ray tolerance that bounds the rounding of the DDA's plane
//! distances. Together they keep a hit close to a cell boundary from being missed when rounding
//! puts it on the other side. Both bounds assume ray origins within a few orders of magnitude
//! of the scene's own size; rays from much farther away should be clipped by the caller.

use super::{Accel, Counters, Hit, Mailbox, Primitives, Spec, SpecError, StructureStats};
use crate::geometry::{Aabb, PreparedRay, Ray, Vec3};
use rayon::prelude::*;

/// Default cells per primitive, chosen by measurement (`docs/measurements.md`): over two
/// meshes, the generated clustered room and four SPD scenes, `D = 2` has the best geometric
/// mean of throughput relative to each scene's best density (0.82; 0.78 at `D = 4`, 0.73 at
/// `D = 1`), a worst case as good as any (0.48, on SPD balls), and 36% fewer bytes than `D = 4`.
/// No density is best everywhere: meshes and the room prefer 1–2, objects clustered on a huge
/// floor (balls, tree) 16 and more, which is the case the HUG is built for.
pub const DEFAULT_DENSITY: f32 = 2.0;

/// Upper bound on cells in one grid: offsets for 2^28 cells take 1 GiB.
const MAX_CELLS: f64 = (1u64 << 28) as f64;

/// Reference budget: when bounding-box binning would store more than this many references per
/// primitive (big overlapping objects, coplanar stacks), the resolution is halved per axis until
/// it fits, so memory stays `O(n)` on adversarial scenes.
const MAX_REFS_PER_PRIM: u64 = 64;
const MIN_REF_BUDGET: u64 = 1 << 20;

pub struct Grid {
    bounds: Aabb,
    res: [u32; 3],
    cell_size: Vec3,
    inv_cell_size: Vec3,
    /// `cell_start[c]..cell_start[c + 1]` are cell `c`'s references in `refs`.
    cell_start: Vec<u32>,
    refs: Vec<u32>,
    /// One bit per cell, set when the cell holds references. Most cells of most scenes are
    /// empty (92% on the bunny at the default density); the walk reads this 1/32-size array,
    /// which stays in cache, and touches `cell_start` only for occupied cells.
    occupied: Vec<u64>,
    /// Coordinate magnitude of the grid: scale of its rounding errors.
    magnitude: f32,
    prims: usize,
    density: f32,
    prune: bool,
}

/// Cells per axis for a box of side lengths `extent` holding about `cells` cells that are as
/// cubical as possible (Woo, GI'92): side `s = (V / cells)^(1/k)` over the `k` axes of non-zero
/// extent, then `round(extent_i / s)` cells on axis `i`, at least 1.
pub fn cubical_resolution(extent: Vec3, cells: f64) -> [u32; 3] {
    let cells = cells.clamp(1.0, MAX_CELLS);
    let e = extent.as_dvec3();
    let emax = e.max_element();
    if emax.is_nan() || emax <= 0.0 {
        return [1, 1, 1];
    }
    let active: Vec<f64> = e
        .to_array()
        .into_iter()
        .filter(|&x| x > emax * 1e-6)
        .collect();
    let measure: f64 = active.iter().product();
    let side = (measure / cells).powf(1.0 / active.len() as f64);
    let per_axis = (cells.powf(1.0 / active.len() as f64) * 4.0).min(MAX_CELLS);
    e.to_array().map(|x| {
        if x > emax * 1e-6 {
            (x / side).round().clamp(1.0, per_axis) as u32
        } else {
            1
        }
    })
}

impl Grid {
    /// Cell coordinate of `x` on axis `a`, clamped into the grid.
    #[inline(always)]
    fn cell_coord(&self, a: usize, x: f32) -> u32 {
        // Truncation is the floor for the non-negative values that survive the clamp (and NaN
        // becomes 0); `floor` itself is a library call without SSE4.1.
        let c = (x - self.bounds.min[a]) * self.inv_cell_size[a];
        (c.max(0.0) as u32).min(self.res[a] - 1)
    }

    /// Inclusive cell range covered by a box.
    fn cell_range(&self, b: &Aabb) -> ([u32; 3], [u32; 3]) {
        let lo = [0, 1, 2].map(|a| self.cell_coord(a, b.min[a]));
        let hi = [0, 1, 2].map(|a| self.cell_coord(a, b.max[a]));
        (lo, hi)
    }

    fn cell_box(&self, c: [u32; 3]) -> Aabb {
        let lo =
            self.bounds.min + Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32) * self.cell_size;
        Aabb::new(lo, lo + self.cell_size)
    }

    #[inline(always)]
    fn cell_index(&self, c: [u32; 3]) -> usize {
        (c[2] as usize * self.res[1] as usize + c[1] as usize) * self.res[0] as usize
            + c[0] as usize
    }

    fn num_cells(&self) -> usize {
        self.res.iter().map(|&r| r as usize).product()
    }

    fn set_resolution(&mut self, res: [u32; 3]) {
        self.res = res;
        let r = Vec3::new(res[0] as f32, res[1] as f32, res[2] as f32);
        self.cell_size = self.bounds.extent() / r;
        self.inv_cell_size = r / self.bounds.extent();
    }

    /// Visits every cell a primitive is referenced from.
    fn for_each_cell<P: Primitives>(
        &self,
        prims: &P,
        i: usize,
        b: &Aabb,
        mut f: impl FnMut(usize),
    ) {
        let (lo, hi) = self.cell_range(b);
        for z in lo[2]..=hi[2] {
            for y in lo[1]..=hi[1] {
                for x in lo[0]..=hi[0] {
                    let c = [x, y, z];
                    if !self.prune || prims.overlaps_box(i, &self.cell_box(c)) {
                        f(self.cell_index(c));
                    }
                }
            }
        }
    }

    /// Pass 0: the number of references box binning would make, without touching cells.
    fn box_reference_count(&self, boxes: &[Aabb]) -> u64 {
        boxes
            .par_iter()
            .filter(|b| !b.is_empty())
            .map(|b| {
                let (lo, hi) = self.cell_range(b);
                (0..3).map(|a| (hi[a] - lo[a] + 1) as u64).product::<u64>()
            })
            .sum()
    }

    /// Passes 1–3 of RTNews's two-pass build: count per cell, prefix sum, fill.
    fn bin<P: Primitives>(&mut self, prims: &P, boxes: &[Aabb]) {
        let ncells = self.num_cells();
        let mut start = vec![0u32; ncells + 1];
        for (i, b) in boxes.iter().enumerate().filter(|(_, b)| !b.is_empty()) {
            self.for_each_cell(prims, i, b, |c| start[c + 1] += 1);
        }
        for c in 0..ncells {
            start[c + 1] += start[c];
        }
        let mut refs = vec![0u32; start[ncells] as usize];
        let mut cursor = start.clone();
        for (i, b) in boxes.iter().enumerate().filter(|(_, b)| !b.is_empty()) {
            self.for_each_cell(prims, i, b, |c| {
                refs[cursor[c] as usize] = i as u32;
                cursor[c] += 1;
            });
        }
        let mut occupied = vec![0u64; ncells.div_ceil(64)];
        for c in 0..ncells {
            if start[c] != start[c + 1] {
                occupied[c / 64] |= 1 << (c % 64);
            }
        }
        self.cell_start = start;
        self.refs = refs;
        self.occupied = occupied;
    }

    /// Walks the grid along `pr` over `[tmin, tmax]`, improving `best`. The parts a hierarchy
    /// needs are explicit: `level` for the counters, and a `mailbox` and running `best` owned
    /// by the caller, so that a structure of nested grids (HUG, recursive grid) walks a
    /// sub-grid with the same ray state as its parent. Returns `true` when `ANY_HIT` found a
    /// hit and the whole query may stop. The ray must be traceable ([`Ray::is_traceable`]):
    /// a NaN origin would step along an axis that never moves.
    #[allow(clippy::too_many_arguments)]
    pub fn walk<P: Primitives, C: Counters, const ANY_HIT: bool>(
        &self,
        prims: &P,
        pr: &PreparedRay,
        tmin: f32,
        tmax: f32,
        level: usize,
        mailbox: &mut Mailbox,
        best: &mut Option<Hit>,
        counters: &mut C,
    ) -> bool {
        let ray = &pr.ray;
        let d = ray.dir;
        counters.box_test(level);
        let Some((t0, t1)) = self.bounds.intersect(pr, tmin, best.map_or(tmax, |b| b.t)) else {
            return false;
        };
        if self.refs.is_empty() {
            return false;
        }
        let o = ray.origin;
        let inv = pr.inv_dir;
        let p = o + d * t0;
        let mut cell = [0i32; 3];
        let mut step = [0i32; 3];
        let mut out = [0i32; 3];
        // Distance to the plane `k` of axis `a`, recomputed at every step rather than
        // accumulated, so rounding does not grow with the length of the walk.
        // Plain arrays: indexing a `Vec3` by a run-time axis is a branch per access.
        let (lo, size) = (self.bounds.min.to_array(), self.cell_size.to_array());
        let (oa, inva) = (o.to_array(), inv.to_array());
        let plane_t = |a: usize, k: i32| ((lo[a] + k as f32 * size[a]) - oa[a]) * inva[a];
        // `ahead[a]` is 1 when the next plane on axis `a` is the cell's upper one.
        let mut ahead = [0i32; 3];
        let mut t_next = [f32::INFINITY; 3];
        for a in 0..3 {
            cell[a] = self.cell_coord(a, p[a]) as i32;
            if d[a] > 0.0 {
                (step[a], out[a], ahead[a]) = (1, self.res[a] as i32, 1);
            } else if d[a] < 0.0 {
                (step[a], out[a], ahead[a]) = (-1, -1, 0);
            } else {
                out[a] = i32::MIN;
                continue;
            }
            t_next[a] = plane_t(a, cell[a] + ahead[a]);
        }
        // Rounding bound on the plane distances and hit parameters, in units of t.
        let tol = 2f32.powi(-19) * (o.abs().max_element() + self.magnitude) / d.length();
        let res_x = self.res[0] as usize;
        let res_xy = res_x * self.res[1] as usize;
        loop {
            counters.cell_visit(level);
            let idx = cell[2] as usize * res_xy + cell[1] as usize * res_x + cell[0] as usize;
            let (s, e) = if self.occupied[idx / 64] & (1 << (idx % 64)) != 0 {
                (
                    self.cell_start[idx] as usize,
                    self.cell_start[idx + 1] as usize,
                )
            } else {
                (0, 0)
            };
            for &prim in &self.refs[s..e] {
                if !mailbox.first_visit(prim) {
                    continue;
                }
                counters.prim_test(level);
                let t_far = best.map_or(tmax, |b| b.t);
                if let Some(t) = prims.intersect(prim as usize, pr, tmin, t_far) {
                    counters.prim_hit(level);
                    if Hit::improves(best, t, prim) {
                        *best = Some(Hit { t, prim });
                        if ANY_HIT {
                            return true;
                        }
                    }
                }
            }
            let t_exit = t_next[0].min(t_next[1]).min(t_next[2]);
            if best.is_some_and(|b| b.t + tol <= t_exit) || t_exit > t1 {
                break;
            }
            let a = if t_next[0] < t_next[1] {
                if t_next[0] < t_next[2] { 0 } else { 2 }
            } else if t_next[1] < t_next[2] {
                1
            } else {
                2
            };
            cell[a] += step[a];
            if cell[a] == out[a] {
                break;
            }
            t_next[a] = plane_t(a, cell[a] + ahead[a]);
        }
        false
    }
}

impl Accel for Grid {
    const NAME: &'static str = "grid";
    const KEYS: &'static [(&'static str, &'static str)] = &[
        (
            "density",
            "cells per primitive, 0.001..1000 (default 2; RTNews used 1 and 20)",
        ),
        (
            "prune",
            "true: reference a cell only if the primitive itself touches it (default false)",
        ),
    ];

    fn build<P: Primitives>(prims: &P, spec: &Spec) -> Result<Self, SpecError> {
        let density = spec.f32_in("density", DEFAULT_DENSITY, 0.001, 1000.0)?;
        let prune = spec.bool("prune", false)?;
        let n = prims.len();
        if n >= u32::MAX as usize {
            return Err(SpecError::Build(format!(
                "{n} primitives: at most 2^32-2 are supported"
            )));
        }
        let raw: Vec<Aabb> = (0..n).into_par_iter().map(|i| prims.bounds(i)).collect();
        let finite = |b: &Aabb| !b.is_empty() && b.min.is_finite() && b.max.is_finite();
        let mut bounds = raw
            .iter()
            .filter(|b| finite(b))
            .fold(Aabb::EMPTY, |a, b| a.union(b));
        if bounds.is_empty() {
            bounds = Aabb::new(Vec3::ZERO, Vec3::ZERO);
        }
        let magnitude = bounds.magnitude().max(bounds.extent().max_element());
        let margin = (magnitude * 2f32.powi(-17)).max(1e-30);
        // Flat axes get a thickness so that every cell has a positive size.
        let bounds = bounds.expand(margin);
        let boxes: Vec<Aabb> = raw
            .iter()
            .map(|b| {
                if finite(b) {
                    b.expand(margin)
                } else {
                    Aabb::EMPTY
                }
            })
            .collect();
        let mut grid = Grid {
            bounds,
            res: [1, 1, 1],
            cell_size: Vec3::ONE,
            inv_cell_size: Vec3::ONE,
            cell_start: Vec::new(),
            refs: Vec::new(),
            occupied: Vec::new(),
            magnitude,
            prims: n,
            density,
            prune,
        };
        grid.set_resolution(cubical_resolution(
            bounds.extent(),
            density as f64 * n as f64,
        ));
        let budget = (MAX_REFS_PER_PRIM * n as u64)
            .max(MIN_REF_BUDGET)
            .min(u32::MAX as u64 - 1);
        while grid.box_reference_count(&boxes) > budget && grid.res != [1, 1, 1] {
            grid.set_resolution(grid.res.map(|r| (r / 2).max(1)));
        }
        if grid.box_reference_count(&boxes) > u32::MAX as u64 - 1 {
            return Err(SpecError::Build("too many references for one grid".into()));
        }
        grid.bin(prims, &boxes);
        Ok(grid)
    }

    fn query<P: Primitives, C: Counters, const ANY_HIT: bool>(
        &self,
        prims: &P,
        ray: &Ray,
        counters: &mut C,
    ) -> Option<Hit> {
        let pr = PreparedRay::new(ray);
        let mut best = None;
        self.walk::<P, C, ANY_HIT>(
            prims,
            &pr,
            ray.tmin,
            ray.tmax,
            0,
            &mut Mailbox::default(),
            &mut best,
            counters,
        );
        best
    }

    fn memory_bytes(&self) -> usize {
        std::mem::size_of::<Self>()
            + 4 * (self.cell_start.capacity() + self.refs.capacity())
            + 8 * self.occupied.capacity()
    }

    fn stats(&self) -> StructureStats {
        let cells = self.num_cells();
        let empty = (0..cells)
            .filter(|&c| self.cell_start[c] == self.cell_start[c + 1])
            .count();
        let mut s = StructureStats::default();
        s.push("density", self.density as f64);
        s.push("prune", self.prune as u8 as f64);
        s.push("res_x", self.res[0] as f64);
        s.push("res_y", self.res[1] as f64);
        s.push("res_z", self.res[2] as f64);
        s.push("cells", cells as f64);
        s.push("empty_cell_ratio", empty as f64 / cells.max(1) as f64);
        s.push("references", self.refs.len() as f64);
        s.push(
            "references_per_object",
            self.refs.len() as f64 / self.prims.max(1) as f64,
        );
        s.push("memory_bytes", self.memory_bytes() as f64);
        s.push(
            "bytes_per_primitive",
            self.memory_bytes() as f64 / self.prims.max(1) as f64,
        );
        s
    }
}
