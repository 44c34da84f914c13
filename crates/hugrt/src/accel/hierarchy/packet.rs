//! The packet walk of a grid hierarchy ([`crate::accel::packet`]): the coherent grid
//! traversal of Wald, Ize, Kensler, Knoll and Parker ("Ray tracing animated scenes using
//! coherent grid traversal", SIGGRAPH 2006), on every grid of the hierarchy.
//!
//! A packet of up to [`GRID_PACKET`] rays (32: a camera's tile of 4 × 8 pixels, as the batch
//! queries group them, `accel::order`) crosses a grid slice by slice along the major axis of
//! its first ray. In each slice every ray's segment is bounded by the slice's two planes and by
//! the ray's own interval in the grid, `[t0, nearest hit so far]`; the segment's two ends give
//! the rectangle of cells it can cross in that slice. The packet looks up the cells of the
//! union of the rectangles (the occupancy bits only, for most); at the slice's first occupied
//! cell each ray's own rectangle is found. Each occupied cell's objects are tested for the rays
//! whose rectangle holds it and that meet the box of what the cell holds ([`super::bounds`]):
//! the cell is fetched once for all of them, and its triangles are met four at a time by
//! eight rays at a time with the packet kernel ([`crate::accel::block::packet_rays_avx2`]),
//! or one at a time by sixteen rays where AVX-512 allows
//! ([`crate::accel::block::triangle_rays_avx512`]), bit for bit the single walk's test either
//! way; a cell met by a few rays of the packet only has them test its triangles each alone
//! ([`FEW`]). A grid a cell references is entered by the packet,
//! with every live ray that has not walked that grid yet (each ray walks a grid once, as
//! alone: [`Mailbox`]), not only the rays whose rectangle holds the cell: the others would
//! enter it from cells of their own, each part of the packet setting the grid up again.
//!
//! Where the packet does not pay, its rays walk alone: a packet that misses the world grid
//! stops before any set-up, and rays whose union spans more than [`SPREAD`] cells a ray in a
//! slice (rays from far-apart points to one light) finish the grid with the single walk.
//! Wald et al. go further, testing a cell's triangles for every ray of the packet after a
//! frustum cull; the rays' own rectangles test fewer, which measured faster here.
//!
//! Each ray thus tests every cell its own 3D-DDA would visit where a hit could still be
//! nearer, and perhaps a few more. The rectangles are widened by [`WIDEN`] of the magnitudes
//! involved, far more than the rounding of a segment's ends, so no cell of the exact path is
//! missed; the cells' objects were inserted with the scene's margin, which covers the single
//! walk's own rounding. The nearest hit does not depend on which cells are tested beyond the
//! needed ones, nor on their order ([`crate::accel::Hit::improves`]).
//!
//! The slice walk needs every ray's direction in one octant and not parallel to the major
//! axis; a grid where the packet's rays do not agree so (in a sub-grid's turned frame they
//! may not) is walked ray by ray.

use super::cells::BLOCK;
use super::header::{any_meets, slab_lanes};
use super::walk::split_grids;
use super::{Frame, GRID_TAG, GridHierarchy, NO_FRAME};
#[cfg(target_arch = "x86_64")]
use crate::accel::block::triangle_rays_avx512;
use crate::accel::block::{Block, BlockRay, BlockRays, LANES, Lanes as Lanes8, RayRows};
use crate::accel::packet::{MAX_PACKET, PACKET, each_lane};
use crate::accel::{Counters, HitSink, Mailbox, Primitives};
// The lanes' lesser and greater without `f32::min`'s care for NaN (`min` and `max` were 17%
// of the bunny's packet walk): the lanes they compare are never NaN, since a ray's segment
// ends are finite where it walks the grid, and the lanes of rays outside a slice, where they
// may not be, are replaced after.
use crate::geometry::{PreparedRay, Ray, Vec3, crossing_t, greater, intersect_triangle, lesser};

/// How far each ray's rectangle of cells is widened in a slice: this fraction of the largest
/// magnitude among its origin, the grid's box and its travel `|t|·|d|` (16 ulps of it, where
/// a segment end's rounding is a few).
const WIDEN: f32 = 1.0 / (1 << 19) as f32;

/// Rays a grid packet holds: four groups of the kernel's [`PACKET`]. A camera's tile of 32
/// neighbouring pixels shares a slice's cells; a packet of 8 paid for its slices' bookkeeping
/// no better than the single walk (measured in `docs/measurements.md`).
pub(crate) const GRID_PACKET: usize = MAX_PACKET;

/// How many cells a slice's union of the rays' rectangles may span per ray in it before the
/// rays finish the grid alone (the single walk from the grid's entry, which tests again the
/// cells the packet has met): rays from far-apart points to one light share a direction but
/// few cells, and the union's empty cells then cost more than the rays' own walks. 2 lost on
/// camera rays; 8 kept less of the shadow rays' gain (4: kitchen, nefertiti and mount shadow
/// rays 1.05-1.1x faster than without the check).
const SPREAD: u64 = 4;

/// Rays of a packet in one cell at most which test its triangles each alone, eight triangles
/// at a time ([`GridHierarchy::test_objects`], the single walk's test), rather than with the
/// packet kernel, whose steps take eight or sixteen rays: half the cells the packets of the
/// meshes' camera and shadow rays test are tested by one or two of their rays, and the big
/// terrain's camera and shadow rays ran 1.03 and 1.10× faster so (3 to 8 measured alike; 2
/// gained less, 12 lost on the terrain's camera rays; docs/measurements.md, "The packets'
/// triangle tests").
const FEW: u32 = 5;

/// The rays (a bit each) whose segment `[t0, t1]` meets the box `(lo, hi)` of what a cell holds
/// ([`super::bounds`]): the slab test lane by lane, with [`lesser`] and [`greater`]; a NaN slab
/// (a ray in the plane of a face of the box, widened by the margin beyond any object) may go
/// either way.
#[inline(always)]
fn meets_lanes(
    lo: Vec3,
    hi: Vec3,
    o: &[Lanes; 3],
    inv: &[Lanes; 3],
    t0: &Lanes,
    t1: &Lanes,
) -> u32 {
    let mut near = 0u32;
    for l in 0..GRID_PACKET {
        let (mut a, mut b) = (t0[l], t1[l]);
        for axis in 0..3 {
            let ta = (lo[axis] - o[axis][l]) * inv[axis][l];
            let tb = (hi[axis] - o[axis][l]) * inv[axis][l];
            a = greater(a, lesser(ta, tb));
            b = lesser(b, greater(ta, tb));
        }
        near |= ((a <= b) as u32) << l;
    }
    near
}

/// Groups of [`PACKET`] rays in a grid packet.
const GROUPS: usize = GRID_PACKET / PACKET;

type Lanes = [f32; GRID_PACKET];

/// A row of lanes reduced by `pick` (the lesser or the greater): eight columns first,
/// lane-wise (a register at a time), then the eight; folded one lane after another, the chain
/// of 32 comparisons was 10% of a walk.
#[inline(always)]
fn reduce(x: &Lanes, pick: impl Fn(f32, f32) -> f32 + Copy) -> f32 {
    let mut m: [f32; PACKET] = std::array::from_fn(|i| x[i]);
    for group in x.chunks_exact(PACKET).skip(1) {
        for (m, &g) in m.iter_mut().zip(group) {
            *m = pick(*m, g);
        }
    }
    m.into_iter().reduce(pick).expect("eight columns")
}

/// The least of a row of lanes.
fn min_of(x: &Lanes) -> f32 {
    reduce(x, lesser)
}

/// The greatest of a row of lanes.
fn max_of(x: &Lanes) -> f32 {
    reduce(x, greater)
}

/// A packet's rays lane by lane, axis by axis (`o[a][l]` is ray `l`'s origin along axis `a`),
/// in the world's frame or a grid's: the rows the slice walk reads, made once per packet for
/// every grid without a frame of its own rather than once per grid (a grid of the city's
/// camera packets is walked for 2.5 slices, and its set-up was most of the walk).
pub(super) struct RayLanes {
    o: [Lanes; 3],
    d: [Lanes; 3],
    /// The inverse directions as the single walk's slab test takes them (`Vec3::ONE / d`):
    /// the prepared rays' own in the world's frame.
    inv: [Lanes; 3],
    /// The rays' `tmin`.
    tmin: Lanes,
}

impl RayLanes {
    /// The rays of `rays` in `frame` (the world's where `None`).
    fn new(rays: &[PreparedRay; GRID_PACKET], frame: Option<&Frame>) -> RayLanes {
        let mut lanes = RayLanes {
            o: [[0.0; GRID_PACKET]; 3],
            d: [[0.0; GRID_PACKET]; 3],
            inv: [[0.0; GRID_PACKET]; 3],
            tmin: [0.0; GRID_PACKET],
        };
        for (l, r) in rays.iter().enumerate() {
            let (o, d, inv) = match frame {
                None => (r.ray.origin, r.ray.dir, r.inv_dir),
                Some(f) => {
                    let d = f.dir(r.ray.dir);
                    (f.point(r.ray.origin), d, Vec3::ONE / d)
                }
            };
            for a in 0..3 {
                (lanes.o[a][l], lanes.d[a][l], lanes.inv[a][l]) = (o[a], d[a], inv[a]);
            }
            lanes.tmin[l] = r.ray.tmin;
        }
        lanes
    }

    #[inline(always)]
    fn origin(&self, l: usize) -> Vec3 {
        Vec3::new(self.o[0][l], self.o[1][l], self.o[2][l])
    }

    #[inline(always)]
    fn dir(&self, l: usize) -> Vec3 {
        Vec3::new(self.d[0][l], self.d[1][l], self.d[2][l])
    }
}

/// What a packet carries from grid to grid: its prepared rays and, per ray, its sink, its
/// mailbox and whether its sink has stopped the walk.
pub(super) struct Packet<'a, S> {
    rays: &'a [PreparedRay; GRID_PACKET],
    /// The rays lane by lane, as a grid without a frame of its own reads them.
    lanes: &'a RayLanes,
    /// The rays as the triangle kernel of the walk's instructions reads them.
    kernel: Kernel<'a>,
    sinks: &'a mut [S],
    mail: &'a mut [Mailbox; GRID_PACKET],
    /// Rays whose sink has not stopped the walk.
    live: u32,
}

/// A packet's rays as the triangle test of a cell reads them
/// ([`GridHierarchy::test_triangles_packet`]).
#[derive(Clone, Copy)]
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
enum Kernel<'a> {
    /// AVX2: four triangles against eight rays a call
    /// ([`crate::accel::block::packet_rays_avx2`]), the rays by group of [`PACKET`].
    Eight(&'a [BlockRays; GROUPS]),
    /// AVX-512: one triangle against sixteen rays a step, the halves of the packet that hold
    /// rays wanted (`block::triangle_rays_avx512`). The packets' triangle tests were about a
    /// third of the big terrain's camera frame; the meshes' camera and shadow rays ran
    /// 1.03–1.12× faster with it (docs/measurements.md, "The packets' triangle tests").
    Sixteen(&'a RayRows),
}

impl GridHierarchy {
    /// The query of a packet ([`crate::accel::Accel::query_packet`]): up to [`GRID_PACKET`]
    /// traceable, near rays, each with its own sink.
    pub fn query_packet<P: Primitives, C: Counters, S: HitSink>(
        &self,
        prims: &P,
        rays: &[Ray],
        sinks: &mut [S],
        counters: &mut C,
    ) {
        let n = rays.len().min(sinks.len()).min(GRID_PACKET);
        if n == 0 || self.store.is_empty() {
            return;
        }
        // A packet that misses the world grid needs none of the set-up below (rays, kernels'
        // lanes, mailboxes), which is most of such a packet's cost.
        let world = &self.grids[0];
        if world.frame == NO_FRAME
            && !any_meets(
                world.min,
                world.max,
                &rays[..n],
                |i| sinks[i].tmax(),
                self.simd,
            )
        {
            return;
        }
        let prepared: [PreparedRay; GRID_PACKET] =
            std::array::from_fn(|l| PreparedRay::new(&rays[l.min(n - 1)]));
        let mut mail: [Mailbox; GRID_PACKET] = std::array::from_fn(|_| Mailbox::default());
        let each: [BlockRay; GRID_PACKET] = std::array::from_fn(|l| BlockRay::new(&prepared[l]));
        let (groups, rows);
        let kernel = if self.avx512 {
            rows = RayRows::new(&each);
            Kernel::Sixteen(&rows)
        } else {
            groups = std::array::from_fn(|g| {
                BlockRays::new(&std::array::from_fn(|l| each[g * PACKET + l]))
            });
            Kernel::Eight(&groups)
        };
        let lanes = RayLanes::new(&prepared, None);
        let mut packet = Packet {
            rays: &prepared,
            lanes: &lanes,
            kernel,
            sinks: &mut sinks[..n],
            mail: &mut mail,
            live: u32::MAX >> (32 - n),
        };
        self.walk_packet(0, prims, &mut packet, u32::MAX >> (32 - n), counters);
    }

    /// Walks grid `g` with the rays of `mask` (and still live): compiled for AVX-512 or AVX2
    /// where the processor has them and the spec allows (`Simd`), so that the lane loops of
    /// [`Self::slices`] are one or two registers each.
    fn walk_packet<P: Primitives, C: Counters, S: HitSink>(
        &self,
        g: u32,
        prims: &P,
        packet: &mut Packet<'_, S>,
        mask: u32,
        counters: &mut C,
    ) {
        #[cfg(target_arch = "x86_64")]
        if self.avx512 {
            // SAFETY: `avx512` is set only where AVX-512 (F, VL, BW, DQ) and AVX2 are present
            // (`build`, `simd::avx512_available`), all the function's attribute enables.
            unsafe { self.walk_packet_avx512(g, prims, packet, mask, counters) };
            return;
        }
        #[cfg(target_arch = "x86_64")]
        if self.simd {
            // SAFETY: `simd` is set only where AVX2 is present (`build`), all the function's
            // attribute enables.
            unsafe { self.walk_packet_avx2(g, prims, packet, mask, counters) };
            return;
        }
        self.slices(g, prims, packet, mask, counters);
    }

    /// [`Self::slices`] compiled for AVX-512: the lane loops of 32 rays two registers each,
    /// and 32 vector registers rather than 16, where the walk's state no longer spills.
    ///
    /// # Safety
    /// The processor must support AVX-512 F, VL, BW and DQ, and AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,avx512f,avx512vl,avx512bw,avx512dq")]
    unsafe fn walk_packet_avx512<P: Primitives, C: Counters, S: HitSink>(
        &self,
        g: u32,
        prims: &P,
        packet: &mut Packet<'_, S>,
        mask: u32,
        counters: &mut C,
    ) {
        self.slices(g, prims, packet, mask, counters);
    }

    /// [`Self::slices`] compiled for AVX2.
    ///
    /// # Safety
    /// The processor must support AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn walk_packet_avx2<P: Primitives, C: Counters, S: HitSink>(
        &self,
        g: u32,
        prims: &P,
        packet: &mut Packet<'_, S>,
        mask: u32,
        counters: &mut C,
    ) {
        self.slices(g, prims, packet, mask, counters);
    }

    /// The slice walk of grid `g` (module documentation), or the rays of `mask` one at a time
    /// where they do not share an octant and a major axis.
    // Lane loops read several rows by one index, as the compiler vectorizes them.
    #[allow(clippy::needless_range_loop)]
    #[inline(always)]
    fn slices<P: Primitives, C: Counters, S: HitSink>(
        &self,
        g: u32,
        prims: &P,
        packet: &mut Packet<'_, S>,
        mask: u32,
        counters: &mut C,
    ) {
        let h = &self.grids[g as usize];
        let level = h.level as usize;
        let mask = mask & packet.live;
        if mask == 0 {
            return;
        }
        // The rays in the grid's frame, lane by lane: the packet's own where the grid has no
        // frame. Lanes outside `mask` hold other rays of the packet (finite, traceable), whose
        // empty segments keep them out of every rectangle, union and cell below.
        let first = mask.trailing_zeros() as usize;
        let turned;
        let lanes: &RayLanes = match h.frame {
            NO_FRAME => packet.lanes,
            f => {
                turned = RayLanes::new(packet.rays, Some(&self.frames[f as usize]));
                &turned
            }
        };
        let d0 = lanes.dir(first);
        let k = d0.abs().max_position();
        let octant = d0.is_negative_bitmask();
        let agree = each_lane(mask).all(|l| {
            let d = lanes.dir(l);
            d.is_negative_bitmask() == octant && d[k] != 0.0
        });
        if !agree || mask.count_ones() == 1 {
            self.walk_alone(g, prims, packet, mask, counters);
            return;
        }
        let (u, v) = ((k + 1) % 3, (k + 2) % 3);
        let row = |f: &dyn Fn(usize) -> f32| -> Lanes { std::array::from_fn(f) };
        let (ok, ou, ov, dk) = (&lanes.o[k], &lanes.o[u], &lanes.o[v], &lanes.d[k]);
        // For the boxes of what cells hold (`bounds`); a grid in a frame of its own keeps
        // whole cells, nothing to skip.
        let cull = h.frame == NO_FRAME;
        // The slopes by division, not by the inverse: in a grid's frame a ray's component
        // along the axis may be subnormal, whose infinite inverse would make a slope NaN.
        let su = row(&|l| lanes.d[u][l] / lanes.d[k][l]);
        let sv = row(&|l| lanes.d[v][l] / lanes.d[k][l]);
        // Each ray's interval in the grid, by the single walk's slab test, every lane's at
        // once (ray by ray it was about 45 instructions a ray a grid); `[0, 0]` for the rays
        // outside `mask`.
        let mut far = [f32::NEG_INFINITY; GRID_PACKET];
        for l in each_lane(mask) {
            counters.box_test(level);
            far[l] = packet.sinks[l].tmax();
        }
        let (mut t0, mut t1) = slab_lanes(h.min, h.max, &lanes.o, &lanes.inv, &lanes.tmin, &far);
        let mut rays = 0u32;
        for l in 0..GRID_PACKET {
            let walks = mask >> l & 1 != 0;
            (t0[l], t1[l]) = if walks { (t0[l], t1[l]) } else { (0.0, 0.0) };
            rays |= ((walks & (t0[l] <= t1[l])) as u32) << l;
        }
        if rays == 0 {
            return;
        }
        let magnitude = h.min.abs().max(h.max.abs()).max_element();
        let widen = row(&|l| {
            let travel = t0[l].abs().max(t1[l].abs()) * lanes.dir(l).abs().max_element();
            WIDEN
                * lanes
                    .origin(l)
                    .abs()
                    .max_element()
                    .max(magnitude)
                    .max(travel)
        });
        // The direction of the sweep: the rays' own, or against it where the sinks ask for the
        // walk from the far end, as the single walk goes then
        // ([`crate::accel::HitSink::walked_back`]).
        let back = S::FIRST_ENDS && cull && packet.sinks[first].walks_back();
        let forward = (d0[k] > 0.0) != back;
        let (min_u, min_v) = (h.min[u], h.min[v]);
        let (inv_u, inv_v) = (h.inv_size[u], h.inv_size[v]);
        let (top_u, top_v) = ((h.res[u] - 1) as f32, (h.res[v] - 1) as f32);
        let stride = [
            1usize,
            h.res[0] as usize,
            h.res[0] as usize * h.res[1] as usize,
        ];
        let (stride_u, stride_v) = (stride[u], stride[v]);
        // A coordinate's cell, clamped to the grid, as `GridHeader::coord` finds it
        // (truncation is the floor of the non-negative values that survive the clamp).
        let cell = |x: f32, min: f32, inv: f32, top: f32| {
            let c = (x - min) * inv;
            let c = if c > 0.0 { c } else { 0.0 };
            let c = if c < top { c } else { top };
            // SAFETY: `c` lies in `[0, top]`, finite and below 2^31 (a grid has fewer cells a
            // side): a NaN fails the first comparison and becomes 0, the two clamp the rest.
            // The saturating `as` cast was 6% of a packet walk's time.
            unsafe { c.to_int_unchecked::<i32>() }
        };
        // The cells of the union of rectangles `f` (rows `rects` makes), `[u_lo, v_lo, u_hi,
        // v_hi]`: a cell is monotone in its coordinate, so the union's are the least and the
        // greatest of the rays' cells. Only where some ray is in the rows' slices.
        let union_cells = |f: &[Lanes; 4]| {
            [
                cell(min_of(&f[0]), min_u, inv_u, top_u) as u32,
                cell(min_of(&f[1]), min_v, inv_v, top_v) as u32,
                cell(max_of(&f[2]), min_u, inv_u, top_u) as u32,
                cell(max_of(&f[3]), min_v, inv_v, top_v) as u32,
            ]
        };
        // Each ray's interval ends at its nearest hit so far: `-inf` for rays not walking
        // this grid, whose segments are then empty.
        let mut end = [f32::NEG_INFINITY; GRID_PACKET];
        for (l, e) in end.iter_mut().enumerate() {
            if rays >> l & 1 != 0 {
                *e = t1[l];
            }
        }
        // The segments along the major axis, `[t0, end]`, widened: `[+inf, -inf]` where empty.
        let segments = |end: &Lanes| -> (Lanes, Lanes) {
            let mut lo = [0f32; GRID_PACKET];
            let mut hi = [0f32; GRID_PACKET];
            for l in 0..GRID_PACKET {
                let a = ok[l] + t0[l] * dk[l];
                let b = ok[l] + end[l] * dk[l];
                let keep = end[l] >= t0[l];
                lo[l] = if keep {
                    lesser(a, b) - widen[l]
                } else {
                    f32::INFINITY
                };
                hi[l] = if keep {
                    greater(a, b) + widen[l]
                } else {
                    f32::NEG_INFINITY
                };
            }
            (lo, hi)
        };
        let (lo, hi) = segments(&end);
        // Each ray's rectangle between planes `plane_lo` and `plane_hi` along the major axis,
        // widened, in the grid's coordinates: empty (`+inf` to `-inf`) where the ray's segment
        // `lo..hi` does not reach between them; the rays in between, and those whose segments
        // go on past `plane_hi` (`plane_lo` backwards).
        let rects = |plane_lo: f32, plane_hi: f32, lo: &Lanes, hi: &Lanes| {
            let mut f = [[0f32; GRID_PACKET]; 4];
            let mut in_slice = 0u32;
            let mut beyond = 0u32;
            for l in 0..GRID_PACKET {
                let (c0, c1) = (greater(lo[l], plane_lo), lesser(hi[l], plane_hi));
                let (u0, u1) = (ou[l] + (c0 - ok[l]) * su[l], ou[l] + (c1 - ok[l]) * su[l]);
                let (v0, v1) = (ov[l] + (c0 - ok[l]) * sv[l], ov[l] + (c1 - ok[l]) * sv[l]);
                let inside = c0 <= c1;
                let (inf, ninf) = (f32::INFINITY, f32::NEG_INFINITY);
                f[0][l] = if inside {
                    lesser(u0, u1) - widen[l]
                } else {
                    inf
                };
                f[1][l] = if inside {
                    lesser(v0, v1) - widen[l]
                } else {
                    inf
                };
                f[2][l] = if inside {
                    greater(u0, u1) + widen[l]
                } else {
                    ninf
                };
                f[3][l] = if inside {
                    greater(v0, v1) + widen[l]
                } else {
                    ninf
                };
                in_slice |= (inside as u32) << l;
                let ahead = if forward {
                    hi[l] > plane_hi
                } else {
                    lo[l] < plane_lo
                };
                beyond |= (ahead as u32) << l;
            }
            (f, in_slice, beyond)
        };
        // Fine grids only: a grid of few slices gains nothing.
        let use_blocks = h.res[k] >= 2 * BLOCK;
        let mut checked = u32::MAX;
        // Whether the last slice walked held an occupied cell: in the thick of the objects
        // the block index is not looked up (the kitchen's packets lost 4% to it).
        let mut occupied = false;
        let first_slice = h.coord(k, if forward { min_of(&lo) } else { max_of(&hi) });
        let last_slice = h.coord(k, if forward { max_of(&hi) } else { min_of(&lo) });
        let mut slice = first_slice;
        loop {
            let plane_lo = h.min[k] + slice as f32 * h.size[k];
            let plane_hi = plane_lo + h.size[k];
            let (lo, hi) = segments(&end);
            // Where the walk enters a block of slices from an empty slice, the union over the
            // whole block is looked up in the block index first: a block whose blocks of cells
            // are all empty is crossed at once.
            if use_blocks && !occupied && checked != slice / BLOCK {
                checked = slice / BLOCK;
                let s0 = checked * BLOCK;
                let s1 = (s0 + BLOCK - 1).min(h.res[k] - 1);
                let (plane_a, plane_b) = (
                    h.min[k] + s0 as f32 * h.size[k],
                    h.min[k] + s1 as f32 * h.size[k] + h.size[k],
                );
                let (f, in_slab, past) = rects(plane_a, plane_b, &lo, &hi);
                let empty = in_slab == 0 || {
                    let [u_lo, v_lo, u_hi, v_hi] = union_cells(&f).map(|c| c / BLOCK);
                    let (mut b_lo, mut b_hi) = ([checked; 3], [checked; 3]);
                    (b_lo[u], b_lo[v], b_hi[u], b_hi[v]) = (u_lo, v_lo, u_hi, v_hi);
                    !self.blocks.any(g as usize, b_lo, b_hi)
                };
                if empty {
                    let far = if forward { s1 } else { s0 };
                    let done = if forward {
                        far >= last_slice
                    } else {
                        far <= last_slice
                    };
                    if past == 0 || done {
                        break;
                    }
                    slice = if forward { far + 1 } else { far - 1 };
                    continue;
                }
            }
            let (f, in_slice, beyond) = rects(plane_lo, plane_hi, &lo, &hi);
            if in_slice != 0 {
                let slice_first = h.first_cell as usize + slice as usize * stride[k];
                let [u_lo, v_lo, u_hi, v_hi] = union_cells(&f);
                let spread = (u_hi - u_lo + 1) as u64 * (v_hi - v_lo + 1) as u64;
                if spread > SPREAD * (in_slice & packet.live).count_ones() as u64 {
                    self.walk_alone(g, prims, packet, rays & packet.live, counters);
                    return;
                }
                // Each ray's own cells, found at the slice's first occupied cell: most
                // slices of most packets hold none.
                let mut r: Option<[[i32; GRID_PACKET]; 4]> = None;
                for cv in v_lo..=v_hi {
                    for cu in u_lo..=u_hi {
                        let idx = slice_first + cu as usize * stride_u + cv as usize * stride_v;
                        // Most cells are empty: their rays are not worth finding.
                        let Some((start, stop, rank)) = self.cells.range(idx) else {
                            continue;
                        };
                        let r = r.get_or_insert_with(|| {
                            let mut r = [[0i32; GRID_PACKET]; 4];
                            for l in 0..GRID_PACKET {
                                let inside = in_slice >> l & 1 != 0;
                                r[0][l] = if inside {
                                    cell(f[0][l], min_u, inv_u, top_u)
                                } else {
                                    i32::MAX
                                };
                                r[1][l] = if inside {
                                    cell(f[1][l], min_v, inv_v, top_v)
                                } else {
                                    i32::MAX
                                };
                                r[2][l] = if inside {
                                    cell(f[2][l], min_u, inv_u, top_u)
                                } else {
                                    -1
                                };
                                r[3][l] = if inside {
                                    cell(f[3][l], min_v, inv_v, top_v)
                                } else {
                                    -1
                                };
                            }
                            r
                        });
                        let (fu, fv) = (cu as i32, cv as i32);
                        let mut here = 0u32;
                        for l in 0..GRID_PACKET {
                            let inside =
                                r[0][l] <= fu && fu <= r[2][l] && r[1][l] <= fv && fv <= r[3][l];
                            here |= (inside as u32) << l;
                        }
                        here &= packet.live;
                        if here == 0 {
                            continue;
                        }
                        for _ in 0..here.count_ones() {
                            counters.cell_visit(level);
                        }
                        let mut cell = [0i32; 3];
                        (cell[k], cell[u], cell[v]) = (slice as i32, fu, fv);
                        let near = if cull {
                            let (lo, hi) = self.bounds.get(h, rank, cell, self.margin);
                            meets_lanes(lo, hi, &lanes.o, &lanes.inv, &t0, &end)
                        } else {
                            u32::MAX
                        };
                        self.test_cell_packet(
                            prims,
                            packet,
                            here & near,
                            start,
                            stop,
                            level,
                            counters,
                        );
                        for l in each_lane(here) {
                            end[l] = if packet.live >> l & 1 != 0 {
                                end[l].min(packet.sinks[l].tmax())
                            } else {
                                f32::NEG_INFINITY
                            };
                        }
                    }
                }
                occupied = r.is_some();
            } else {
                occupied = false;
            }
            if beyond == 0 || slice == last_slice {
                break;
            }
            slice = if forward { slice + 1 } else { slice - 1 };
        }
    }

    /// Tests the references `start..end` of one cell: its objects for the rays of `here`
    /// (those that meet the box of what the cell holds; its triangles with the packet kernel
    /// where more than [`FEW`] rays of `here` are live, each ray alone otherwise), then the
    /// grids it references with every live ray of the packet that has not walked them.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn test_cell_packet<P: Primitives, C: Counters, S: HitSink>(
        &self,
        prims: &P,
        packet: &mut Packet<'_, S>,
        here: u32,
        start: usize,
        end: usize,
        level: usize,
        counters: &mut C,
    ) {
        let (mut refs, grids) = split_grids(&self.refs[start..end]);
        #[cfg(target_arch = "x86_64")]
        if self.simd && (here & packet.live).count_ones() > FEW {
            let triangles = self.store.triangle_count();
            let tri_count = refs.partition_point(|&r| (r as usize) < triangles);
            self.test_triangles_packet(&refs[..tri_count], packet, here, level, counters);
            refs = &refs[tri_count..];
        }
        for l in each_lane(here & packet.live) {
            let ray = &packet.rays[l];
            if self.test_objects::<P, C, S>(
                refs,
                prims,
                ray,
                ray.ray.tmin,
                &mut packet.sinks[l],
                &mut packet.mail[l],
                counters,
                level,
            ) {
                packet.live &= !(1 << l);
            }
        }
        for &r in grids {
            let sub = r & !GRID_TAG;
            // The packet's other rays enter the grid too, now rather than from cells of their
            // own (the walk drops those that miss its box): a grid entered by part of a
            // packet at a time was set up again for each part. Nothing is lost: a ray that
            // misses the grid's box now misses it with any nearer hit, and a grid's walk keeps
            // the nearest hit whatever the order ([`crate::accel::Hit::improves`]).
            let mut enter = 0u32;
            for l in each_lane(packet.live) {
                enter |= (packet.mail[l].first_grid_visit(sub) as u32) << l;
            }
            if enter != 0 {
                self.walk_packet(sub, prims, packet, enter, counters);
            }
        }
    }

    /// Tests triangles `tris` (store entries) for the rays of `here` still live with the
    /// packet's [`Kernel`] (four triangles at a time against eight rays, or one against
    /// sixteen), whose bits are the scalar test's, then in each ray's lane order the `t` of a
    /// crossed lane, as the single walk finds it. A ray's mailbox records only the triangles
    /// it crosses: a triangle it misses misses again, and only a hit must not be offered
    /// twice.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn test_triangles_packet<C: Counters, S: HitSink>(
        &self,
        tris: &[u32],
        packet: &mut Packet<'_, S>,
        here: u32,
        level: usize,
        counters: &mut C,
    ) {
        let groups = match packet.kernel {
            Kernel::Eight(groups) => groups,
            Kernel::Sixteen(rows) => {
                // Four triangles read before any is tested: one at a time, each test waited
                // for its triangle's load (the big terrain's camera rays 1.3x slower).
                for chunk in tris.chunks(LANES) {
                    let mut held = [[Vec3::ZERO; 3]; LANES];
                    for (t, &r) in chunk.iter().enumerate() {
                        held[t] = self
                            .store
                            .triangle(r)
                            .expect("the cell's first entries are triangles");
                    }
                    for (&r, tri) in chunk.iter().zip(&held) {
                        // SAFETY: `Sixteen` is made only where `avx512` is set, which is
                        // only where AVX-512 F is present (`build`).
                        let lanes = unsafe { triangle_rays_avx512(tri, rows, here & packet.live) };
                        for _ in 0..(here & packet.live).count_ones() {
                            counters.prim_test(level);
                        }
                        self.offer_crossed(packet, r, tri, lanes, here, level, counters);
                    }
                }
                return;
            }
        };
        for chunk in tris.chunks(LANES) {
            let mut block = Block::EMPTY;
            for (t, &r) in chunk.iter().enumerate() {
                let tri = self
                    .store
                    .triangle(r)
                    .expect("the cell's first entries are triangles");
                block.set(t, &tri, r);
            }
            // Each triangle's rays (bit `r` for ray `r`), a group of eight rays at a time.
            let mut found = [Lanes8 {
                crossed: 0,
                redo: 0,
            }; LANES];
            for (g, rays) in groups.iter().enumerate() {
                if (here & packet.live) >> (g * PACKET) & 0xff == 0 {
                    continue;
                }
                // SAFETY: `simd` is set only where AVX2 is present (`build`).
                let group = unsafe { crate::accel::block::packet_rays_avx2(&block, rays) };
                for (all, m) in found.iter_mut().zip(&group) {
                    all.crossed |= m.crossed << (g * PACKET);
                    all.redo |= m.redo << (g * PACKET);
                }
            }
            for _ in 0..chunk.len() * (here & packet.live).count_ones() as usize {
                counters.prim_test(level);
            }
            // Triangle by triangle, in store order, as each ray's own walk meets them.
            for (t, (&r, lanes)) in chunk.iter().zip(&found).enumerate() {
                self.offer_crossed(packet, r, &block.triangle(t), *lanes, here, level, counters);
            }
        }
    }

    /// Offers triangle `r` (vertices `tri`) to the rays of `here` still live that `lanes`
    /// finds crossing it (their `t` from the scalar test's [`crossing_t`]) or leaves to the
    /// scalar test, each ray once ([`Mailbox`]).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn offer_crossed<C: Counters, S: HitSink>(
        &self,
        packet: &mut Packet<'_, S>,
        r: u32,
        tri: &[Vec3; 3],
        lanes: Lanes8,
        here: u32,
        level: usize,
        counters: &mut C,
    ) {
        let todo = (lanes.crossed | lanes.redo) & here & packet.live;
        for l in each_lane(todo) {
            if !packet.mail[l].first_visit(r) {
                continue;
            }
            let ray = &packet.rays[l];
            let sink = &mut packet.sinks[l];
            let hit = if lanes.crossed >> l & 1 != 0 {
                crossing_t(tri, &ray.ray, ray.ray.tmin, sink.tmax())
            } else {
                intersect_triangle(ray, tri, ray.ray.tmin, sink.tmax())
            };
            if let Some(t) = hit {
                counters.prim_hit(level);
                if sink.offer(t, || self.store.id(r)) {
                    packet.live &= !(1 << l);
                }
            }
        }
    }

    /// Grid `g` walked by each ray of `mask` on its own (the single walk).
    fn walk_alone<P: Primitives, C: Counters, S: HitSink>(
        &self,
        g: u32,
        prims: &P,
        packet: &mut Packet<'_, S>,
        mask: u32,
        counters: &mut C,
    ) {
        for l in each_lane(mask & packet.live) {
            let ray = &packet.rays[l];
            if self.walk::<P, C, S>(
                g,
                prims,
                ray,
                ray.ray.tmin,
                &mut packet.sinks[l],
                &mut packet.mail[l],
                counters,
            ) {
                packet.live &= !(1 << l);
            }
        }
    }
}
