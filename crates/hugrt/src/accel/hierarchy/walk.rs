//! The walk (EG95 §2.3.2): the 3D-DDA of Amanatides and Woo through one grid, each cell's
//! objects tested (eight triangles at a time where AVX2 allows) where the ray meets the box of
//! what the cell holds ([`super::bounds`]), and each grid it references walked with the same
//! ray state; see the module documentation for when it stops.

use super::header::slab;
use super::{GRID_TAG, GridHierarchy, NO_FRAME};
use crate::accel::HitSink;
use crate::accel::{Counters, Mailbox, Primitives};
use crate::geometry::{PreparedRay, Vec3};

/// The 3D-DDA's state along one axis: the parameter of the next cell boundary ahead and how to
/// cross it.
///
/// A walk from the far end of the segment back towards its start (`BACK`,
/// [`GridHierarchy::walk_grid`]) keeps the planes behind it the same way, each plane's
/// parameter by the same formula but negated, so that the next plane is still the least and
/// `first + j·delta` still counts them: the walk back is the walk ahead along the negated
/// parameter. Along an axis where the direction's component is tiny beside the others, the
/// ray stays within rounding of its origin's coordinate: the plane behind lies before the
/// origin (never crossed) or, where the origin lies within rounding of a plane, may come out
/// after the far end and be crossed first, into neighbouring cells that the margin makes hold
/// what the ray can meet, as with the planes ahead of a walk from the start.
#[derive(Clone, Copy)]
struct Axis {
    /// Parameter at which the ray meets the next plane ahead.
    next: f32,
    /// The plane `j` cells beyond the first plane ahead of the entry point is met at
    /// `first + j·delta`: computed afresh at every step rather than accumulated, so that
    /// rounding does not grow with the length of the walk.
    ///
    /// Counted from the first plane ahead rather than from the grid's `min` plane, whose
    /// parameter `(min − o)·inv` overflows to ±∞ for a small direction component (10^-36
    /// against a scene of 10^3) while the planes the ray crosses are well within range:
    /// `∞ + k·delta` was then `∞ − ∞`, a NaN that no comparison chose, and the walk never
    /// stepped along the other axes either. From the first plane ahead every term is
    /// non-negative, so a plane's parameter is ∞ only when it is out of `f32`'s range.
    first: f32,
    delta: f32,
    /// How many planes ahead the next one is, and how many lie ahead before the grid's boundary
    /// plane: small integers, exact as floats, kept as floats so that a step converts nothing.
    j: f32,
    last: f32,
    /// Change of the cell index when this plane is crossed.
    jump: isize,
    /// The cell's coordinate along this axis, and its change when a plane is crossed.
    cell: i32,
    step: i32,
}

impl Axis {
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn new<const BACK: bool>(
        min: f32,
        size: f32,
        res: i32,
        o: f32,
        d: f32,
        inv: f32,
        cell: i32,
        stride: isize,
    ) -> Axis {
        // Towards the axis's higher cells where the walk goes with a positive component, or
        // back against a negative one.
        let (up, down) = ((cell + 1, 1, res - 1 - cell), (cell, -1, cell));
        let (k, step, last) = if d > 0.0 {
            if BACK { down } else { up }
        } else if d < 0.0 {
            if BACK { up } else { down }
        } else {
            return Axis {
                next: f32::INFINITY,
                first: f32::INFINITY,
                delta: 0.0,
                j: 0.0,
                last: 0.0,
                jump: 0,
                cell,
                step: 0,
            };
        };
        let first = ((min - o) + k as f32 * size) * inv;
        let first = if BACK { -first } else { first };
        Axis {
            next: first,
            first,
            delta: size * inv.abs(),
            j: 0.0,
            last: last as f32,
            jump: step as isize * stride,
            cell,
            step,
        }
    }

    /// Crosses the plane ahead into the next cell, moving `idx`; `false` when that plane is
    /// the grid's boundary.
    #[inline(always)]
    fn cross(&mut self, idx: &mut isize) -> bool {
        if self.j == self.last {
            return false;
        }
        *idx += self.jump;
        self.cell += self.step;
        self.j += 1.0;
        self.next = self.first + self.j * self.delta;
        true
    }
}

impl GridHierarchy {
    /// Walks grid `g` along `ray` from `tmin`, offering hits to `sink`; the grid's
    /// `GridPlan::level` is where the counters count. Returns `true` when the sink stops the
    /// whole query. The ray must be traceable ([`crate::geometry::Ray::is_traceable`]).
    /// Compiled for AVX-512 where the packet walk is ([`crate::accel::Simd`]), for AVX2 where
    /// the cells test their triangles eight at a time.
    #[allow(clippy::too_many_arguments)]
    pub fn walk<P: Primitives, C: Counters, S: HitSink>(
        &self,
        g: u32,
        prims: &P,
        ray: &PreparedRay,
        tmin: f32,
        sink: &mut S,
        mail: &mut Mailbox,
        counters: &mut C,
    ) -> bool {
        #[cfg(target_arch = "x86_64")]
        if self.avx512 {
            // SAFETY: `avx512` is set only where the processor has every feature the
            // function's attribute enables (`build`, `simd::avx512_available`).
            return unsafe { self.walk_avx512(g, prims, ray, tmin, sink, mail, counters) };
        }
        #[cfg(target_arch = "x86_64")]
        if self.simd {
            // SAFETY: `simd` is set only where the processor has AVX2 (`build`), and
            // `simd::available` asks for POPCNT, BMI1 and LZCNT with it.
            return unsafe { self.walk_avx2(g, prims, ray, tmin, sink, mail, counters) };
        }
        self.walk_grid(g, prims, ray, tmin, sink, mail, counters)
    }

    /// [`Self::walk_grid`] compiled for AVX2, with POPCNT for the occupied cells' ranks:
    /// where AVX-512 is absent.
    ///
    /// # Safety
    /// The processor must support AVX2, POPCNT, BMI1 and LZCNT.
    #[cfg(target_arch = "x86_64")]
    #[allow(clippy::too_many_arguments)]
    #[target_feature(enable = "avx2,popcnt,bmi1,lzcnt")]
    unsafe fn walk_avx2<P: Primitives, C: Counters, S: HitSink>(
        &self,
        g: u32,
        prims: &P,
        ray: &PreparedRay,
        tmin: f32,
        sink: &mut S,
        mail: &mut Mailbox,
        counters: &mut C,
    ) -> bool {
        self.walk_grid(g, prims, ray, tmin, sink, mail, counters)
    }

    /// [`Self::walk_grid`] compiled for AVX-512: twice the vector registers, and POPCNT for
    /// the occupied cells' ranks.
    ///
    /// # Safety
    /// The processor must support AVX-512 F, VL, BW and DQ, AVX2, POPCNT, BMI1, BMI2 and
    /// LZCNT.
    #[cfg(target_arch = "x86_64")]
    #[allow(clippy::too_many_arguments)]
    #[target_feature(enable = "avx2,avx512f,avx512vl,avx512bw,avx512dq,popcnt,bmi1,bmi2,lzcnt")]
    unsafe fn walk_avx512<P: Primitives, C: Counters, S: HitSink>(
        &self,
        g: u32,
        prims: &P,
        ray: &PreparedRay,
        tmin: f32,
        sink: &mut S,
        mail: &mut Mailbox,
        counters: &mut C,
    ) -> bool {
        self.walk_grid(g, prims, ray, tmin, sink, mail, counters)
    }

    /// [`Self::walk`] in the instructions of its caller: from the ray's start, or from the
    /// far end of its segment in the grid where the sink says so ([`HitSink::walks_back`]).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn walk_grid<P: Primitives, C: Counters, S: HitSink>(
        &self,
        g: u32,
        prims: &P,
        ray: &PreparedRay,
        tmin: f32,
        sink: &mut S,
        mail: &mut Mailbox,
        counters: &mut C,
    ) -> bool {
        if S::FIRST_ENDS && sink.walks_back() && self.grids[g as usize].frame == NO_FRAME {
            return self.walk_cells::<P, C, S, true>(g, prims, ray, tmin, sink, mail, counters);
        }
        self.walk_cells::<P, C, S, false>(g, prims, ray, tmin, sink, mail, counters)
    }

    /// [`Self::walk_grid`] from the ray's start, or with `BACK` from the far end of its
    /// segment in the grid back to its start, for a sink that the first hit ends and that
    /// asks for it ([`HitSink::walked_back`]), so that what lies far from the origin is
    /// tested first. The walk back crosses the cells the walk from the start crosses (each
    /// plane's parameter by the same formula, each cell's objects by the same tests), in the
    /// other order, so the margin's argument (the module documentation of [`super`]) holds as
    /// it does there; an occlusion query's answer does not depend on the order
    /// (docs/measurements.md, "Occlusion walked from the far end").
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn walk_cells<P: Primitives, C: Counters, S: HitSink, const BACK: bool>(
        &self,
        g: u32,
        prims: &P,
        ray: &PreparedRay,
        tmin: f32,
        sink: &mut S,
        mail: &mut Mailbox,
        counters: &mut C,
    ) -> bool {
        let h = &self.grids[g as usize];
        let level = h.level as usize;
        counters.box_test(level);
        let (o, d, inv) = if h.frame == NO_FRAME {
            (ray.ray.origin, ray.ray.dir, ray.inv_dir)
        } else {
            let f = &self.frames[h.frame as usize];
            let d = f.dir(ray.ray.dir);
            (f.point(ray.ray.origin), d, Vec3::ONE / d)
        };
        let (t0, t1) = h.interval(o, inv, tmin, sink.tmax());
        let entered = t0 <= t1;
        if !entered {
            return false;
        }
        // The walk back starts at the far end (finite: a ray with a small direction is
        // scaled before any walk, `Reach`, so the box's far side is met at a finite `t`).
        let p = o + d * if BACK { t1 } else { t0 };
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
            Axis::new::<BACK>(
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
        // A grid in a frame of its own keeps whole cells as boxes (`bounds`): nothing to skip.
        let cull = h.frame == NO_FRAME;
        let mut far = sink.tmax();
        loop {
            counters.cell_visit(level);
            if let Some((s, e, rank)) = self.cells.range(idx as usize) {
                let refs = &self.refs[s..e];
                let objects = !cull || {
                    let (lo, hi) =
                        self.bounds
                            .get(h, rank, [ax.cell, ay.cell, az.cell], self.margin);
                    let (t0, t1) = slab(lo, hi, o, inv, tmin, far);
                    t0 <= t1
                };
                if self.test_cell::<P, C, S>(
                    refs, prims, ray, tmin, sink, mail, counters, level, objects,
                ) {
                    return true;
                }
                far = sink.tmax();
            }
            // The next cell is across the nearest of the three planes ahead; the walk stops
            // when the nearest hit lies before it (the walk back: when the segment starts
            // after it, its negated parameter below the plane's), or when it is the grid's
            // boundary. (One branch per axis, rather than a reference to the chosen axis,
            // which would put the three in memory.)
            let stop = if BACK { -t0 } else { far };
            macro_rules! step {
                ($axis:ident) => {
                    if stop <= $axis.next || !$axis.cross(&mut idx) {
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

    /// Tests the references of one cell: its objects ([`Self::test_objects`]) if `objects`
    /// (the ray meets the box of what the cell holds), then walks the grids it references.
    /// Returns `true` when the sink stops the walk.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(super) fn test_cell<P: Primitives, C: Counters, S: HitSink>(
        &self,
        refs: &[u32],
        prims: &P,
        ray: &PreparedRay,
        tmin: f32,
        sink: &mut S,
        mail: &mut Mailbox,
        counters: &mut C,
        level: usize,
        objects: bool,
    ) -> bool {
        let (held, grids) = split_grids(refs);
        if objects && self.test_held::<P, C, S>(held, prims, ray, tmin, sink, mail, counters, level)
        {
            return true;
        }
        for &r in grids {
            let sub = r & !GRID_TAG;
            if mail.first_grid_visit(sub)
                && self.walk::<P, C, S>(sub, prims, ray, tmin, sink, mail, counters)
            {
                return true;
            }
        }
        false
    }

    /// [`Self::test_objects`], their store entries prefetched first, out of the walk's loop:
    /// most occupied cells a ray crosses are skipped by their box (93% of those the city's
    /// shadow rays cross), and with the tests inlined the loop's state did not fit the
    /// registers. Out of line, the single walk ran with 2–8% fewer instructions, and
    /// 1.04–1.2× faster (docs/measurements.md, "A cell's tests out of the walk's loop").
    #[allow(clippy::too_many_arguments)]
    #[inline(never)]
    fn test_held<P: Primitives, C: Counters, S: HitSink>(
        &self,
        held: &[u32],
        prims: &P,
        ray: &PreparedRay,
        tmin: f32,
        sink: &mut S,
        mail: &mut Mailbox,
        counters: &mut C,
        level: usize,
    ) -> bool {
        for &r in held {
            self.store.prefetch(r);
        }
        self.test_objects::<P, C, S>(held, prims, ray, tmin, sink, mail, counters, level)
    }

    /// Tests the objects `refs` of one cell (store entries, without the grids it references:
    /// [`split_grids`]): triangles first, eight at a time when [`Self::simd`] allows, in store
    /// order either way, each object once per ray (`mail`). Returns `true` when the sink stops
    /// the walk.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(super) fn test_objects<P: Primitives, C: Counters, S: HitSink>(
        &self,
        refs: &[u32],
        prims: &P,
        ray: &PreparedRay,
        tmin: f32,
        sink: &mut S,
        mail: &mut Mailbox,
        counters: &mut C,
        level: usize,
    ) -> bool {
        let mut rest = refs;
        #[cfg(target_arch = "x86_64")]
        if self.simd && refs.len() >= 2 {
            let triangles = self.store.triangle_count();
            let tri_count = refs.partition_point(|&r| (r as usize) < triangles);
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
                    // SAFETY: `simd` is set only when AVX2 is present and the store's offsets
                    // fit (`build`, `PrimStore::simd_fits`); every batched index is a
                    // triangle's (below `triangles`, by the partition), the padding repeats
                    // one of them.
                    if unsafe {
                        self.store.offer_triangles8::<P, C, S>(
                            prims, &batch, n, ray, tmin, sink, counters, level,
                        )
                    } {
                        return true;
                    }
                    n = 0;
                }
            }
        }
        for &r in rest {
            if !mail.first_visit(r) {
                continue;
            }
            counters.prim_test(level);
            if let Some(t) = self.store.intersect(prims, r, ray, tmin, sink.tmax()) {
                counters.prim_hit(level);
                if sink.offer(t, || self.store.id(r)) {
                    return true;
                }
            }
        }
        false
    }

    /// The query of a traceable ray ([`crate::accel::Accel::query`]).
    #[inline]
    pub fn query<P: Primitives, C: Counters, S: HitSink>(
        &self,
        prims: &P,
        ray: &crate::geometry::Ray,
        sink: &mut S,
        counters: &mut C,
    ) {
        if self.store.is_empty() {
            return;
        }
        let pr = PreparedRay::new(ray);
        self.walk::<P, C, S>(
            0,
            prims,
            &pr,
            ray.tmin,
            sink,
            &mut Mailbox::default(),
            counters,
        );
    }
}

/// A cell's references split into its objects and the grids it references, which come last
/// (the module documentation of [`super`]): the walks go over each part alone, and a ray that
/// misses the box of what the cell holds reads no object's reference. Counted from the end,
/// where a cell holds few grids or none.
#[inline(always)]
pub(super) fn split_grids(refs: &[u32]) -> (&[u32], &[u32]) {
    let mut k = refs.len();
    while k > 0 && refs[k - 1] & GRID_TAG != 0 {
        k -= 1;
    }
    debug_assert!(
        refs[..k].iter().all(|&r| r & GRID_TAG == 0),
        "grids come last"
    );
    refs.split_at(k)
}
