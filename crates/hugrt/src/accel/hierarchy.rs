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
//! The 3D-DDA of Amanatides and Woo. In each cell: the objects are tested, then each grid
//! referenced there is walked with the same ray state (nearest hit, mailbox), which is what
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
//! * the DDA's plane distances `base + k·delta`: the true ray at a parameter `t` inside the
//!   interval the walk gives a cell lies within that error of the cell, so it reaches every
//!   cell the true ray crosses, corners included, up to the margin;
//! * the stop test `nearest ≤ exit`: a nearer hit just beyond the exit plane lies within the
//!   same error of the current cell, hence is referenced by it;
//! * the watertight triangle test's own rounding (its effective ray is off by a few ulps).
//!
//! With `margin = M·2^-17` (64 ulps of `M`), hits are those of brute force for ray origins
//! within a few times `M` of the origin; rays from much farther away should be clipped to the
//! scene's box by the caller. The property tests (`tests/agree.rs`) fail without the margin.

use super::simd;
use super::sort::radix_sort_high32;
use super::store::{Nearest, PrimStore, finite};
use super::{Counters, Mailbox, Primitives, SpecError};
use crate::geometry::{Aabb, PreparedRay, Vec3};
use rayon::prelude::*;
use serde::Serialize;

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

const NO_FRAME: u32 = u32::MAX;

/// `1 + 2·gamma(3)` of Ize ("Robust BVH Ray Traversal", JCGT 2013): scaling the far slab
/// distance by it makes the slab test conservative under rounding.
const ROBUST_FAR: f32 = 1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

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

/// An orthonormal frame: `local = axes · (p − origin)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Frame {
    pub origin: Vec3,
    pub axes: [Vec3; 3],
}

impl Frame {
    #[inline(always)]
    pub fn dir(&self, d: Vec3) -> Vec3 {
        Vec3::new(
            self.axes[0].dot(d),
            self.axes[1].dot(d),
            self.axes[2].dot(d),
        )
    }

    #[inline(always)]
    pub fn point(&self, p: Vec3) -> Vec3 {
        self.dir(p - self.origin)
    }

    fn world_point(&self, l: Vec3) -> Vec3 {
        self.origin + self.axes[0] * l.x + self.axes[1] * l.y + self.axes[2] * l.z
    }

    fn corners(b: &Aabb) -> [Vec3; 8] {
        std::array::from_fn(|k| {
            Vec3::new(
                if k & 1 == 0 { b.min.x } else { b.max.x },
                if k & 2 == 0 { b.min.y } else { b.max.y },
                if k & 4 == 0 { b.min.z } else { b.max.z },
            )
        })
    }

    /// Box in this frame around a world-space box.
    pub fn local_box(&self, b: &Aabb) -> Aabb {
        if b.is_empty() {
            return *b;
        }
        Frame::corners(b)
            .iter()
            .fold(Aabb::EMPTY, |a, &c| a.grow(self.point(c)))
    }

    /// World-space box around a box of this frame.
    pub fn world_box(&self, b: &Aabb) -> Aabb {
        if b.is_empty() {
            return *b;
        }
        Frame::corners(b)
            .iter()
            .fold(Aabb::EMPTY, |a, &c| a.grow(self.world_point(c)))
    }
}

/// Which objects are referenced only from the cells their surface meets (EG95 §1.2.1's
/// pruning; RTNews found it worth 10% at most on the SPD scenes) rather than from every cell
/// their box meets.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Prune {
    None,
    All,
    /// Objects whose box spans at least [`Prune::LARGE`] cells: long thin triangles (the
    /// slivers of SPD gears' concave outlines) are where box binning references many cells
    /// the object never meets, and where the exact test pays for itself; for an object within
    /// a few cells it costs more build time than it saves.
    Large,
}

impl Prune {
    pub const LARGE: u64 = 16;

    /// The setting as `hugrt stats` reports it: 0 (false), 1 (true) or the `LARGE` threshold.
    pub(crate) fn stat_value(self) -> f64 {
        match self {
            Prune::None => 0.0,
            Prune::All => 1.0,
            Prune::Large => Prune::LARGE as f64,
        }
    }

    pub(crate) fn from_spec(spec: &super::Spec, default: Prune) -> Result<Prune, SpecError> {
        let name = match default {
            Prune::None => "false",
            Prune::All => "true",
            Prune::Large => "large",
        };
        Ok(
            match spec.choice("prune", &["false", "true", "large"], name)? {
                "true" => Prune::All,
                "large" => Prune::Large,
                _ => Prune::None,
            },
        )
    }
}

/// How many cells a planned grid gets.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Resolution {
    /// About this many cells, as cubical as possible.
    Cubical(f64),
    /// About this many cells, as many on every axis: EG95 §1.2.2's `∛` criterion,
    /// `n_x = n_y = n_z = ∛cells` (RTNews' "regular" grids, against its heterogeneous ones
    /// whose cells are cubes).
    Regular(f64),
    /// Exactly these cells per axis.
    Fixed([u32; 3]),
}

impl Resolution {
    /// The resolution for `k` objects when `self` counts cells per object (`Cubical` and
    /// `Regular`: RTNews' heterogeneous grids and EG95's `∛` criterion at `d·k` cells);
    /// `Fixed` is the same for any `k` (the octree's 2×2×2).
    pub(crate) fn for_objects(self, k: usize) -> Resolution {
        match self {
            Resolution::Cubical(d) => Resolution::Cubical(d * k as f64),
            Resolution::Regular(d) => Resolution::Regular(d * k as f64),
            fixed @ Resolution::Fixed(_) => fixed,
        }
    }

    fn cells_per_axis(self, extent: Vec3) -> [u32; 3] {
        match self {
            Resolution::Cubical(cells) => cubical_resolution(extent, cells),
            Resolution::Regular(cells) => {
                let k = cells.clamp(1.0, MAX_CELLS).cbrt().round().max(1.0) as u32;
                [k; 3]
            }
            Resolution::Fixed(r) => r.map(|x| x.max(1)),
        }
    }
}

/// How crowded cells are gridded again, top-down: Jevans and Wyvill's recursive grid (EG95
/// §1.2.2), EG95's simulated octree, the adaptive grid's sub-voxel grids. A cell referencing
/// more than `maxp` objects gets a grid over its own box (the cell widened by the margin),
/// holding those objects; the cell then references that grid instead of them, so cells of
/// different grids never overlap and each sub-grid is walked from one cell only. (Skipping
/// the grid mailbox for such grids was measured and dropped: ×0.98–1.05 on rgrid and octree,
/// kitchen, stadium and bunny, paired.)
///
/// Termination (EG95 §1.2.2: `maxp` coplanar triangles sharing a point would recurse
/// forever): as in Jevans and Wyvill and EG95, no grid deeper than `max_depth`; and the
/// references and cells of all grids stay within `2·(64·n + 4096)` and the root's cells plus
/// `64·n + 4096`: sub-grids are made level by level and, within a level, in cell order until
/// the next would overflow either budget. Coplanar stacks therefore grow as the papers say
/// they do, explosively, up to that bound. hugrt's own guard (`guard`, not the papers'), off
/// unless asked for: a cell holding every object of its grid is not cut again, since its
/// grid would only repeat the one above; it stops the coplanar case at once, but it also
/// leaves uncut a crowded cell that happens to hold its grid's every object (a cluster
/// beside one large triangle that crosses its cell).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Subdivision {
    pub maxp: usize,
    pub max_depth: u32,
    /// hugrt's guard: a cell holding every object of its grid is not cut again.
    pub guard: bool,
    /// Cells of a cut cell's grid, per object it holds ([`Resolution::for_objects`]).
    pub cells: Resolution,
}

/// One grid to build: what it holds and how finely it is cut.
pub(crate) struct GridPlan {
    /// Store entries binned in the grid, in ascending order.
    pub objects: Vec<u32>,
    /// Grids referenced from its cells (indices in the plan list, each after this one).
    pub children: Vec<u32>,
    pub resolution: Resolution,
    pub frame: Option<Frame>,
    /// Nesting depth in the hierarchy (0 = the root).
    pub depth: u32,
    /// The level the statistics and counters report it under: the filter level of a HUG's
    /// grid (0 = the world's, the largest objects), the depth for the other structures.
    pub level: u32,
    /// Whether the grid's box is the whole scene's (a root) rather than its items'.
    pub scene_box: bool,
    /// Whether its cell planes are moved off the box's round fractions
    /// ([`GridHeader::shift_planes`]: one more cell along axes of 4 or more).
    pub shift: bool,
}

#[derive(Clone, Copy, Debug)]
struct GridHeader {
    /// The grid's box, in its own frame.
    min: Vec3,
    max: Vec3,
    size: Vec3,
    inv_size: Vec3,
    res: [u32; 3],
    /// Index of cell (0, 0, 0) among all grids' cells.
    first_cell: u32,
    frame: u32,
    depth: u32,
    /// [`GridPlan::level`].
    level: u32,
    objects: u32,
}

impl GridHeader {
    fn cells(&self) -> usize {
        self.res.iter().map(|&r| r as usize).product()
    }

    #[inline(always)]
    fn coord(&self, a: usize, x: f32) -> u32 {
        // Truncation is the floor for the non-negative values that survive the clamp (and NaN
        // becomes 0); `floor` itself is a library call without SSE4.1.
        let c = (x - self.min[a]) * self.inv_size[a];
        (c.max(0.0) as u32).min(self.res[a] - 1)
    }

    fn cell_range(&self, b: &Aabb) -> ([u32; 3], [u32; 3]) {
        (
            [0, 1, 2].map(|a| self.coord(a, b.min[a])),
            [0, 1, 2].map(|a| self.coord(a, b.max[a])),
        )
    }

    fn cell_box(&self, c: [u32; 3]) -> Aabb {
        let lo = self.min + Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32) * self.size;
        Aabb::new(lo, lo + self.size)
    }

    fn set_resolution(&mut self, res: [u32; 3]) {
        self.res = res;
        let r = Vec3::new(res[0] as f32, res[1] as f32, res[2] as f32);
        let e = self.max - self.min;
        self.size = e / r;
        self.inv_size = r / e;
    }

    /// Moves the cell planes off the box's own round fractions. Models with coordinates on
    /// round values (SPD tetra's dyadic vertices, axis-aligned architecture) put box faces
    /// exactly on the planes of a grid cut in simple fractions of their box, and the margin
    /// then references such an object from every cell whose plane it touches: 7.3 references
    /// per triangle on SPD tetra at density 1, where 3 suffice. Along every axis of at least
    /// 4 cells the grid gets one more cell and starts `1/φ²` (0.382) of a cell before the
    /// box, far from every simple fraction; its cell size stays the same.
    fn shift_planes(&mut self) {
        const SHIFT: f32 = 0.381_966;
        let (mut res, size) = (self.res, self.size);
        for a in 0..3 {
            if res[a] >= 4 {
                self.min[a] -= SHIFT * size[a];
                self.max[a] += (1.0 - SHIFT) * size[a];
                res[a] += 1;
            }
        }
        self.set_resolution(res);
    }

    fn world_box(&self, frames: &[Frame]) -> Aabb {
        let b = Aabb::new(self.min, self.max);
        if self.frame == NO_FRAME {
            b
        } else {
            frames[self.frame as usize].world_box(&b)
        }
    }
}

/// The 3D-DDA's state along one axis: the parameter of the next cell boundary ahead and how to
/// cross it.
#[derive(Clone, Copy)]
struct Axis {
    /// Parameter at which the ray meets the next plane ahead.
    next: f32,
    /// Plane `k` is met at `base + k·delta`: computed afresh at every step rather than
    /// accumulated, so that rounding does not grow with the length of the walk.
    base: f32,
    delta: f32,
    /// Index of the next plane ahead, the step to the one after it, and the index of the
    /// grid's boundary plane on this side.
    k: i32,
    step: i32,
    boundary: i32,
    /// Change of the cell index when this plane is crossed.
    jump: isize,
}

impl Axis {
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn new(
        min: f32,
        size: f32,
        res: i32,
        o: f32,
        d: f32,
        inv: f32,
        cell: i32,
        stride: isize,
    ) -> Axis {
        let base = (min - o) * inv;
        let delta = size * inv;
        let (k, step, boundary) = if d > 0.0 {
            (cell + 1, 1, res)
        } else if d < 0.0 {
            (cell, -1, 0)
        } else {
            return Axis {
                next: f32::INFINITY,
                base,
                delta,
                k: 0,
                step: 0,
                boundary: 0,
                jump: 0,
            };
        };
        Axis {
            next: base + k as f32 * delta,
            base,
            delta,
            k,
            step,
            boundary,
            jump: step as isize * stride,
        }
    }

    /// Crosses the plane ahead into the next cell, moving `idx`; `false` when that plane is
    /// the grid's boundary.
    #[inline(always)]
    fn cross(&mut self, idx: &mut isize) -> bool {
        if self.k == self.boundary {
            return false;
        }
        *idx += self.jump;
        self.k += self.step;
        self.next = self.base + self.k as f32 * self.delta;
        true
    }
}

/// Where each cell's references lie, kept for the occupied cells only: most cells of most
/// scenes are empty (90% on a mesh at 2 cells per triangle, more in finer grids), and four
/// bytes of offset for each would dominate a fine grid's memory. One bit per cell says whether
/// it is occupied; the occupied cells before each 64-cell word (`rank`) plus the bits below
/// the cell in its word give its place among the occupied ones (a rank query on a bit
/// vector). About 0.2 bytes per cell plus 4 per occupied cell, where plain offsets take 4 per
/// cell; the walk reads the bits, which stay in cache, and touches the rest only for occupied
/// cells.
struct CellIndex {
    occupied: Vec<u64>,
    rank: Vec<u32>,
    /// Start of each occupied cell's references in cell order, then the end of the last.
    starts: Vec<u32>,
    cells: usize,
}

impl CellIndex {
    /// From `(cell, reference)` pairs sorted by cell (cells in the upper 32 bits).
    fn from_sorted(pairs: &[u64], cells: usize) -> CellIndex {
        let mut occupied = vec![0u64; cells.div_ceil(64)];
        let mut starts = Vec::new();
        let mut last = u64::MAX;
        for (k, &p) in pairs.iter().enumerate() {
            let c = p >> 32;
            if c != last {
                starts.push(k as u32);
                occupied[c as usize / 64] |= 1 << (c % 64);
                last = c;
            }
        }
        starts.push(pairs.len() as u32);
        let mut rank = Vec::with_capacity(occupied.len());
        let mut before = 0u32;
        for w in &occupied {
            rank.push(before);
            before += w.count_ones();
        }
        CellIndex {
            occupied,
            rank,
            starts,
            cells,
        }
    }

    /// The references of cell `i`, or `None` when it has none.
    #[inline(always)]
    fn range(&self, i: usize) -> Option<(usize, usize)> {
        let w = self.occupied[i / 64];
        let bit = 1u64 << (i % 64);
        if w & bit == 0 {
            return None;
        }
        let r = self.rank[i / 64] as usize + (w & (bit - 1)).count_ones() as usize;
        Some((self.starts[r] as usize, self.starts[r + 1] as usize))
    }

    fn memory_bytes(&self) -> usize {
        8 * self.occupied.capacity() + 4 * (self.rank.capacity() + self.starts.capacity())
    }
}

/// Nested uniform grids over a primitive store; see the module documentation.
pub(crate) struct GridHierarchy {
    pub store: PrimStore,
    grids: Vec<GridHeader>,
    frames: Vec<Frame>,
    cells: CellIndex,
    refs: Vec<u32>,
    /// Whether cells test their triangles eight at a time ([`simd`]): the processor has AVX2,
    /// the store's offsets fit the gathers, and the spec did not turn it off.
    simd: bool,
    /// Crowded cells [`Subdivision`] left uncut because the budgets would overflow.
    uncut: usize,
}

/// How the items of a grid become `(cell, reference)` pairs.
struct Binner<'a, P> {
    prims: &'a P,
    store: &'a PrimStore,
    margin: f32,
    /// Objects of a grid without frame spanning at least this many cells are referenced only
    /// by the cells they meet ([`Prune`]).
    prune_span: u64,
}

impl<P: Primitives> Binner<'_, P> {
    /// Appends the pairs of items `range` of grid `h`, cells numbered from `h.first_cell`.
    fn bin(
        &self,
        h: &GridHeader,
        it: &Items<P>,
        range: std::ops::Range<usize>,
        out: &mut Vec<u64>,
    ) {
        for (r, b) in range.filter_map(|k| it.get(k)) {
            let test = r & GRID_TAG == 0 && h.frame == NO_FRAME && {
                let (lo, hi) = h.cell_range(&b);
                (0..3).map(|a| (hi[a] - lo[a] + 1) as u64).product::<u64>() >= self.prune_span
            };
            // A cell is kept when the object meets it widened by the margin, which is what
            // the exactness argument asks of the references (module documentation).
            GridHierarchy::for_each_cell(h, &b, |cell, i| {
                if !test
                    || self.prims.overlaps_box(
                        self.store.id(r) as usize,
                        &h.cell_box(cell).expand(self.margin),
                    )
                {
                    out.push(((h.first_cell as usize + i) as u64) << 32 | r as u64);
                }
            });
        }
    }
}

/// What one grid bins: its objects (store entries) then its children (tagged grid indices),
/// each with its box in the grid's frame widened by the margin. Objects without a finite box
/// are never binned.
struct Items<'a, P> {
    objects: &'a [u32],
    store: &'a PrimStore,
    prims: &'a P,
    /// Boxes of `objects` in the grid's frame, when it has one.
    turned: Option<Vec<Aabb>>,
    children: Vec<(u32, Aabb)>,
    margin: f32,
}

impl<P: Primitives> Items<'_, P> {
    fn len(&self) -> usize {
        self.objects.len() + self.children.len()
    }

    /// Item `k`: its reference and widened box, or `None` if it is not binned.
    #[inline]
    fn get(&self, k: usize) -> Option<(u32, Aabb)> {
        if let Some(&s) = self.objects.get(k) {
            let b = match &self.turned {
                Some(t) => t[k],
                None => self.store.bounds(self.prims, s),
            };
            finite(&b).then(|| (s, b.expand(self.margin)))
        } else {
            Some(self.children[k - self.objects.len()])
        }
    }

    fn bounds(&self) -> Aabb {
        (0..self.len())
            .into_par_iter()
            .filter_map(|k| self.get(k))
            .fold(|| Aabb::EMPTY, |a, (_, b)| a.union(&b))
            .reduce(|| Aabb::EMPTY, |a, b| a.union(&b))
    }
}

impl GridHierarchy {
    /// The margin of the module documentation for a scene whose finite boxes span `bounds`.
    fn margin_for(bounds: &Aabb) -> f32 {
        let m = if bounds.is_empty() {
            0.0
        } else {
            bounds.magnitude().max(bounds.extent().max_element())
        };
        (m * 2f32.powi(-17)).max(1e-30)
    }

    /// Builds the grids of `plans` (a grid's children come after it) over `store` (entries
    /// without a finite box are never binned). With `prune`, an object is referenced only by
    /// the cells its own surface meets ([`Primitives::overlaps_box`]) rather than every cell
    /// its box meets. With `subdivision`, crowded cells are then gridded again, top-down.
    pub fn build<P: Primitives>(
        prims: &P,
        store: PrimStore,
        plans: &[GridPlan],
        prune: Prune,
        subdivision: Option<Subdivision>,
        simd: bool,
    ) -> Result<GridHierarchy, SpecError> {
        let scene = (0..store.len() as u32)
            .into_par_iter()
            .map(|s| store.bounds(prims, s))
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
            let it = Self::items(prims, &store, &frames, &grids, &plans[g], g, margin);
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
            Self::fit_budget(h, &it);
            if plans[g].shift {
                h.shift_planes();
            }
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
        let pairs: Vec<Vec<u64>> = tasks
            .par_iter()
            .map(|(g, range)| {
                let mut out = Vec::new();
                binner.bin(&grids[*g], &items[*g], range.clone(), &mut out);
                out
            })
            .collect();
        let mut pairs = pairs.concat();
        drop(items);
        if pairs.len() >= u32::MAX as usize {
            return Err(SpecError::Build(format!(
                "{} references: more than one hierarchy can address",
                pairs.len()
            )));
        }
        // Pass 2: a stable sort by cell keeps each cell's objects in store order, then its
        // grids; the cell index and the references come straight from the sorted pairs.
        radix_sort_high32(&mut pairs);
        let mut uncut = 0;
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
        let refs: Vec<u32> = pairs.par_iter().map(|&p| p as u32).collect();
        drop(pairs);
        let simd = simd && simd::available() && store.triangles().len() * 9 < i32::MAX as usize;
        Ok(GridHierarchy {
            store,
            grids,
            frames,
            cells,
            refs,
            simd,
            uncut,
        })
    }

    /// Halves the resolution of `h` until box binning its items stays within the reference
    /// budget ([`MAX_REFS_PER_ITEM`]).
    fn fit_budget<P: Primitives>(h: &mut GridHeader, it: &Items<P>) {
        let budget = (MAX_REFS_PER_ITEM * it.len() as u64)
            .max(MIN_REF_BUDGET)
            .min(u32::MAX as u64 / 2);
        // A sample tells most grids that they are far within the budget; the others count
        // exactly.
        let step = (it.len() / 1024).max(1);
        let sampled = Self::box_reference_count(h, it, step) * step as u64;
        while sampled > budget / 4
            && Self::box_reference_count(h, it, 1) > budget
            && h.res != [1, 1, 1]
        {
            h.set_resolution(h.res.map(|r| (r / 2).max(1)));
        }
    }

    /// Grids again every crowded cell ([`Subdivision`]), level by level: the sorted `pairs`
    /// of the grids built so far in, the sorted pairs of all grids out. A cut cell's object
    /// pairs give way to one pair naming its sub-grid, whose cells come after all others, so
    /// that the pairs stay sorted by cell.
    fn subdivide<P: Primitives>(
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
            let made: Vec<(GridHeader, Vec<u64>)> = runs
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
                        min: b.min,
                        max: b.max,
                        size: Vec3::ONE,
                        inv_size: Vec3::ONE,
                        res: [1, 1, 1],
                        first_cell: 0,
                        frame: NO_FRAME,
                        depth: parent.depth + 1,
                        level: parent.level + 1,
                        objects: objects.len() as u32,
                    };
                    h.set_resolution(
                        sub.cells
                            .for_objects(objects.len())
                            .cells_per_axis(b.extent()),
                    );
                    let it = Items {
                        objects: &objects,
                        store: binner.store,
                        prims: binner.prims,
                        turned: None,
                        children: Vec::new(),
                        margin: binner.margin,
                    };
                    Self::fit_budget(&mut h, &it);
                    let mut out = Vec::new();
                    binner.bin(&h, &it, 0..it.len(), &mut out);
                    out.sort_by_key(|&p| p >> 32);
                    (h, out)
                })
                .collect();
            let mut refs = pairs.len() as u64;
            let mut cut = Vec::new();
            let mut appended = Vec::new();
            for (&(k, e, _, objects), (mut h, out)) in runs.iter().zip(made) {
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

    /// The items grid `g` bins (four margins in a turned frame: the turn rounds too).
    fn items<'a, P: Primitives>(
        prims: &'a P,
        store: &'a PrimStore,
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
                .map(|&s| store.local_bounds(s, &f, &store.bounds(prims, s)))
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
            store,
            prims,
            turned,
            children,
            margin: m,
        }
    }

    /// The number of references box binning makes in `h` for every `step`-th item, without
    /// touching cells.
    fn box_reference_count<P: Primitives>(h: &GridHeader, items: &Items<P>, step: usize) -> u64 {
        (0..items.len().div_ceil(step))
            .into_par_iter()
            .filter_map(|k| items.get(k * step))
            .map(|(_, b)| {
                let (lo, hi) = h.cell_range(&b);
                (0..3).map(|a| (hi[a] - lo[a] + 1) as u64).product::<u64>()
            })
            .sum()
    }

    /// Visits every cell of `h` a box meets: its coordinates and its index within the grid.
    fn for_each_cell(h: &GridHeader, b: &Aabb, mut f: impl FnMut([u32; 3], usize)) {
        let (lo, hi) = h.cell_range(b);
        let (rx, ry) = (h.res[0] as usize, h.res[1] as usize);
        for z in lo[2]..=hi[2] {
            for y in lo[1]..=hi[1] {
                for x in lo[0]..=hi[0] {
                    f([x, y, z], (z as usize * ry + y as usize) * rx + x as usize);
                }
            }
        }
    }

    /// Walks grid `g` along `ray` from `tmin`, improving `near`; the grid's
    /// [`GridPlan::level`] is where the counters count. Returns `true` when `ANY_HIT` found a hit and the whole query may
    /// stop. The ray must be traceable ([`crate::geometry::Ray::is_traceable`]).
    #[allow(clippy::too_many_arguments)]
    pub fn walk<P: Primitives, C: Counters, const ANY_HIT: bool>(
        &self,
        g: u32,
        prims: &P,
        ray: &PreparedRay,
        tmin: f32,
        near: &mut Nearest,
        mail: &mut Mailbox,
        counters: &mut C,
    ) -> bool {
        let h = &self.grids[g as usize];
        let depth = h.level as usize;
        counters.box_test(depth);
        let (o, d, inv) = if h.frame == NO_FRAME {
            (ray.ray.origin, ray.ray.dir, ray.inv_dir)
        } else {
            let f = &self.frames[h.frame as usize];
            let d = f.dir(ray.ray.dir);
            (f.point(ray.ray.origin), d, Vec3::ONE / d)
        };
        // Slab test; `min`/`max` return the non-NaN operand, so a 0·inf slab is ignored.
        let ta = (h.min - o) * inv;
        let tb = (h.max - o) * inv;
        let t0 = tmin.max(ta.min(tb).max_element());
        let t1 = near.t.min(ta.max(tb).min_element() * ROBUST_FAR);
        let entered = t0 <= t1;
        if !entered {
            return false;
        }
        let p = o + d * t0;
        let res = h.res;
        let stride = [1, res[0] as isize, res[0] as isize * res[1] as isize];
        // Spelled out rather than `std::array::from_fn`, which the compiler left as calls
        // (the bvh's lesson, `docs/measurements.md`).
        let cell = [
            h.coord(0, p.x) as i32,
            h.coord(1, p.y) as i32,
            h.coord(2, p.z) as i32,
        ];
        let mut idx = h.first_cell as isize
            + cell[0] as isize
            + cell[1] as isize * stride[1]
            + cell[2] as isize * stride[2];
        // Each axis's state lives in its own variables, so that a step touches registers
        // only: indexing arrays by the axis of the step costs a store and a reload.
        let axis = |a: usize| {
            Axis::new(
                h.min[a],
                h.size[a],
                res[a] as i32,
                o[a],
                d[a],
                inv[a],
                cell[a],
                stride[a],
            )
        };
        let (mut ax, mut ay, mut az) = (axis(0), axis(1), axis(2));
        let mut far = near.t;
        loop {
            counters.cell_visit(depth);
            if let Some((s, e)) = self.cells.range(idx as usize) {
                let refs = &self.refs[s..e];
                for &r in refs {
                    self.store.prefetch(r);
                }
                if self
                    .test_cell::<P, C, ANY_HIT>(refs, prims, ray, tmin, near, mail, counters, depth)
                {
                    return true;
                }
                far = near.t;
            }
            // The next cell is across the nearest of the three planes ahead; the walk stops
            // when the nearest hit lies before it, or when it is the grid's boundary.
            // (One branch per axis, rather than a reference to the chosen axis, which would
            // put the three in memory.)
            macro_rules! step {
                ($axis:ident) => {
                    if far <= $axis.next || !$axis.cross(&mut idx) {
                        break;
                    }
                };
            }
            if ax.next < ay.next {
                if ax.next < az.next {
                    step!(ax)
                } else {
                    step!(az)
                }
            } else if ay.next < az.next {
                step!(ay)
            } else {
                step!(az)
            }
        }
        false
    }

    /// Tests the references of one cell: its objects (triangles first, eight at a time when
    /// [`Self::simd`] allows, in store order either way), then walks the grids it references.
    /// Returns `true` when `ANY_HIT` found a hit.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn test_cell<P: Primitives, C: Counters, const ANY_HIT: bool>(
        &self,
        refs: &[u32],
        prims: &P,
        ray: &PreparedRay,
        tmin: f32,
        near: &mut Nearest,
        mail: &mut Mailbox,
        counters: &mut C,
        depth: usize,
    ) -> bool {
        let mut rest = refs;
        #[cfg(target_arch = "x86_64")]
        if self.simd && refs.len() >= 2 {
            let triangles = self.store.triangles();
            let tri_count = refs.partition_point(|&r| (r as usize) < triangles.len());
            rest = &refs[tri_count..];
            let mut batch = [0u32; 8];
            let mut n = 0;
            for (k, &r) in refs[..tri_count].iter().enumerate() {
                if mail.first_visit(r) {
                    batch[n] = r;
                    n += 1;
                }
                if n == 8 || (k + 1 == tri_count && n > 0) {
                    for b in n..8 {
                        batch[b] = batch[0];
                    }
                    // SAFETY: `simd` is set only when AVX2 is present and `9·len` fits an
                    // i32 (`build`); every batched index is a triangle's (below
                    // `triangles.len()`, by the partition), the padding repeats one of them.
                    if unsafe {
                        self.store.offer_triangles8::<P, C, ANY_HIT>(
                            prims, &batch, n, ray, tmin, near, counters, depth,
                        )
                    } {
                        return true;
                    }
                    n = 0;
                }
            }
        }
        for &r in rest {
            if r & GRID_TAG != 0 {
                let sub = r & !GRID_TAG;
                if mail.first_grid_visit(sub)
                    && self.walk::<P, C, ANY_HIT>(sub, prims, ray, tmin, near, mail, counters)
                {
                    return true;
                }
                continue;
            }
            if !mail.first_visit(r) {
                continue;
            }
            counters.prim_test(depth);
            if let Some(t) = self.store.intersect(prims, r, ray, tmin, near.t) {
                counters.prim_hit(depth);
                if near.offer(&self.store, t, r) && ANY_HIT {
                    return true;
                }
            }
        }
        false
    }

    /// Closest or any hit of a traceable ray.
    #[inline]
    pub fn query<P: Primitives, C: Counters, const ANY_HIT: bool>(
        &self,
        prims: &P,
        ray: &crate::geometry::Ray,
        counters: &mut C,
    ) -> Option<super::Hit> {
        if self.store.is_empty() {
            return None;
        }
        let pr = PreparedRay::new(ray);
        let mut near = Nearest::new(ray.tmax);
        self.walk::<P, C, ANY_HIT>(
            0,
            prims,
            &pr,
            ray.tmin,
            &mut near,
            &mut Mailbox::default(),
            counters,
        );
        near.hit(&self.store)
    }

    /// The box of grid `g` (in its frame, if it has one).
    pub fn grid_box(&self, g: usize) -> Aabb {
        Aabb::new(self.grids[g].min, self.grids[g].max)
    }

    /// Crowded cells left uncut by the reference and cell budgets ([`Subdivision`]).
    pub fn uncut_by_budget(&self) -> usize {
        self.uncut
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
            + 4 * self.refs.capacity()
    }

    /// Bytes of the whole structure: grids and store.
    pub fn memory_bytes(&self) -> usize {
        self.grid_memory_bytes() + self.store.memory_bytes()
    }

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
                    .map_or(&[][..], |(s, e)| &self.refs[s..e]);
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
