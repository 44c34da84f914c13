//! Four triangles side by side, one ray against all four at once: the leaves of the bvh.
//!
//! A [`Block`] holds its triangles' vertices as rows of four lanes (`v[vertex][axis][lane]`),
//! so the test is lane-wise arithmetic over whole rows: SSE on x86_64 (part of every x86_64
//! target's baseline, so it needs no run-time detection), plain lane loops elsewhere
//! ([`lanes_portable`], which the tests hold bit for bit to the SSE kernel).
//!
//! Both compute the edge functions as the scalar test ([`intersect_triangle`]) computes them,
//! operation for operation and in the same order (no fused multiply-add), so a lane's signs
//! are the scalar test's; the caller takes a crossed lane's `t` from the scalar test's own
//! [`crossing_t`], so a lane's hit is the scalar test's bits. Lanes where an edge function is
//! exactly zero, which the scalar test redoes in double precision, are handed back to it
//! ([`Lanes::redo`]).
//!
//! [`intersect_triangle`]: crate::geometry::intersect_triangle
//! [`crossing_t`]: crate::geometry::crossing_t

use crate::geometry::{PreparedRay, Ray, Vec3};

/// Triangles in a block.
pub const LANES: usize = 4;

/// A lane's id when it holds nothing.
pub const EMPTY_LANE: u32 = u32::MAX;

/// Four triangles' vertices as lanes of rows, and what each lane stands for (`ids`, which the
/// block's owner defines, [`EMPTY_LANE`] for none). Lanes of no triangle hold NaN vertices,
/// which no ray crosses.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
pub struct Block {
    pub v: [[[f32; LANES]; 3]; 3],
    pub ids: [u32; LANES],
}

impl Block {
    pub const EMPTY: Block = Block {
        v: [[[f32::NAN; LANES]; 3]; 3],
        ids: [EMPTY_LANE; LANES],
    };

    /// Puts triangle `t` in lane `l`.
    pub fn set(&mut self, l: usize, t: &[Vec3; 3], id: u32) {
        for (k, v) in t.iter().enumerate() {
            for a in 0..3 {
                self.v[k][a][l] = v[a];
            }
        }
        self.ids[l] = id;
    }

    /// Lane `l`'s triangle.
    pub fn triangle(&self, l: usize) -> [Vec3; 3] {
        [0, 1, 2].map(|k| Vec3::new(self.v[k][0][l], self.v[k][1][l], self.v[k][2][l]))
    }
}

/// What a block's test found, lane by lane (bit `l` of a mask is lane `l`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lanes {
    /// Lanes whose triangle the ray crosses, as the scalar test finds before its `t`.
    pub crossed: u32,
    /// Lanes with an edge function exactly zero: the scalar test decides those.
    pub redo: u32,
}

/// The ray's numbers the test uses: origin and the shear rows of [`PreparedRay::rows`].
#[derive(Clone, Copy)]
pub struct BlockRay {
    o: [f32; 3],
    rows: [[f32; 3]; 2],
}

impl BlockRay {
    #[inline]
    pub fn new(ray: &PreparedRay) -> Self {
        BlockRay {
            o: ray.ray.origin.to_array(),
            rows: ray.rows.map(|r| r.to_array()),
        }
    }

    /// [`BlockRay::new`] of `ray` prepared, without the rest of the preparation (the inverse
    /// direction's three divisions): the same numbers.
    #[inline]
    pub fn of_ray(ray: &Ray) -> Self {
        BlockRay {
            o: ray.origin.to_array(),
            rows: crate::geometry::shear_rows(ray.dir, |kz| 1.0 / ray.dir[kz])
                .map(|r| r.to_array()),
        }
    }
}

/// Eight rays as [`packet_lanes_avx2`] reads them: each ray's [`BlockRay`] numbers, lane by
/// lane.
#[derive(Clone, Copy)]
pub struct BlockRays {
    o: [[f32; 8]; 3],
    rows: [[[f32; 8]; 3]; 2],
}

impl BlockRays {
    /// The rays `rays` in lanes 0 to 7.
    #[inline]
    pub fn new(rays: &[BlockRay; 8]) -> Self {
        BlockRays {
            o: std::array::from_fn(|a| std::array::from_fn(|l| rays[l].o[a])),
            rows: std::array::from_fn(|r| {
                std::array::from_fn(|a| std::array::from_fn(|l| rays[l].rows[r][a]))
            }),
        }
    }
}

/// The packet kernel's body, shared by [`packet_lanes_avx2`] and [`packet_rays_avx2`]: for
/// each lane `t` of block `b`, the masks of the eight `rays` that cross it and that need the
/// scalar test, handed to `emit` (a macro, so that both AVX2 functions inline the
/// intrinsics).
#[cfg(target_arch = "x86_64")]
macro_rules! packet_kernel {
    ($b:expr, $rays:expr, |$t:ident, $crossed:ident, $redo:ident| $emit:block) => {{
        use std::arch::x86_64::*;
        // SAFETY (the loads): each reads the eight `f32` of one `[f32; 8]`, unaligned.
        let load = |x: &[f32; 8]| unsafe { _mm256_loadu_ps(x.as_ptr()) };
        let o = [load(&$rays.o[0]), load(&$rays.o[1]), load(&$rays.o[2])];
        let row = |r: usize| {
            [
                load(&$rays.rows[r][0]),
                load(&$rays.rows[r][1]),
                load(&$rays.rows[r][2]),
            ]
        };
        let (rx, ry) = (row(0), row(1));
        let s = |x: f32| _mm256_set1_ps(x);
        // `r·p` as glam's `dot` sums it: `(r.x·p.x + r.y·p.y) + r.z·p.z`.
        let dot = |r: &[__m256; 3], p: &[__m256; 3]| {
            _mm256_add_ps(
                _mm256_add_ps(_mm256_mul_ps(r[0], p[0]), _mm256_mul_ps(r[1], p[1])),
                _mm256_mul_ps(r[2], p[2]),
            )
        };
        for $t in 0..LANES {
            let t = $t;
            let vertex = |k: usize| {
                [
                    _mm256_sub_ps(s($b.v[k][0][t]), o[0]),
                    _mm256_sub_ps(s($b.v[k][1][t]), o[1]),
                    _mm256_sub_ps(s($b.v[k][2][t]), o[2]),
                ]
            };
            let p = [vertex(0), vertex(1), vertex(2)];
            let (ax, ay) = (dot(&rx, &p[0]), dot(&ry, &p[0]));
            let (bx, by) = (dot(&rx, &p[1]), dot(&ry, &p[1]));
            let (cx, cy) = (dot(&rx, &p[2]), dot(&ry, &p[2]));
            let u = _mm256_sub_ps(_mm256_mul_ps(cx, by), _mm256_mul_ps(cy, bx));
            let v = _mm256_sub_ps(_mm256_mul_ps(ax, cy), _mm256_mul_ps(ay, cx));
            let w = _mm256_sub_ps(_mm256_mul_ps(bx, ay), _mm256_mul_ps(by, ax));
            let ($crossed, $redo) = $crate::accel::simd::edge_masks!(u, v, w);
            $emit
        }
    }};
}

/// [`lanes`] of each of eight rays: entry `r` is what `lanes(b, ray r)` finds, bit for bit.
/// The block's triangles are met one at a time by the eight rays at once (AVX, a ray a lane),
/// with the kernel's arithmetic in the kernel's order: the packet walk of the bvh tests a
/// leaf's blocks this way for all the rays that reach it.
///
/// # Safety
/// The processor must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
pub unsafe fn packet_lanes_avx2(b: &Block, rays: &BlockRays) -> [Lanes; 8] {
    let mut out = [Lanes {
        crossed: 0,
        redo: 0,
    }; 8];
    packet_kernel!(b, rays, |t, crossed, redo| {
        for (r, lanes) in out.iter_mut().enumerate() {
            lanes.crossed |= (crossed >> r & 1) << t;
            lanes.redo |= (redo >> r & 1) << t;
        }
    });
    out
}

/// What [`packet_lanes_avx2`] finds, by triangle: entry `t` has bit `r` set where ray `r`
/// crosses the block's lane `t` (or needs the scalar test there). The grids' packet walk
/// reads it so, the rays that cross one triangle at a time.
///
/// # Safety
/// The processor must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
pub unsafe fn packet_rays_avx2(b: &Block, rays: &BlockRays) -> [Lanes; LANES] {
    let mut out = [Lanes {
        crossed: 0,
        redo: 0,
    }; LANES];
    packet_kernel!(b, rays, |t, crossed, redo| {
        out[t] = Lanes { crossed, redo };
    });
    out
}

/// Rays a [`RayRows`] holds: a grid packet's ([`crate::accel::packet::MAX_PACKET`]).
pub const ROW_RAYS: usize = 32;

/// Up to [`ROW_RAYS`] rays as the AVX-512 packet kernel (`triangle_rays_avx512`) reads them:
/// each ray's [`BlockRay`] numbers, lane by lane.
#[derive(Clone, Copy)]
pub struct RayRows {
    o: [[f32; ROW_RAYS]; 3],
    rows: [[[f32; ROW_RAYS]; 3]; 2],
}

impl RayRows {
    /// The rays `rays` in lanes `0..rays.len()` (at most [`ROW_RAYS`]); the lanes beyond
    /// repeat the last ray.
    #[inline]
    pub fn new(rays: &[BlockRay]) -> Self {
        let last = rays.len().min(ROW_RAYS) - 1;
        let ray = |l: usize| &rays[l.min(last)];
        RayRows {
            o: std::array::from_fn(|a| std::array::from_fn(|l| ray(l).o[a])),
            rows: std::array::from_fn(|r| {
                std::array::from_fn(|a| std::array::from_fn(|l| ray(l).rows[r][a]))
            }),
        }
    }
}

/// One triangle against the rays of `wanted` among a [`RayRows`]' (sixteen at a time, AVX-512):
/// bit `r` of [`Lanes::crossed`] where ray `r` crosses it, of [`Lanes::redo`] where the scalar
/// test decides, for the rays of `wanted`'s halves (others' bits are left clear). What
/// [`lanes`] finds for each ray with the triangle in a lane, bit for bit: the same arithmetic
/// in the same order, the masks straight from the comparisons. The grids' packet walk
/// compiled for AVX-512 tests a cell's triangles so, where the AVX2 kernel
/// ([`packet_rays_avx2`]) takes four triangles against eight rays a call.
///
/// # Safety
/// The processor must support AVX-512 F.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
pub unsafe fn triangle_rays_avx512(tri: &[Vec3; 3], rays: &RayRows, wanted: u32) -> Lanes {
    use std::arch::x86_64::*;
    let (mut crossed, mut redo) = (0u32, 0u32);
    for half in 0..ROW_RAYS / 16 {
        let at = 16 * half;
        if (wanted >> at) & 0xffff == 0 {
            continue;
        }
        // SAFETY: each reads sixteen `f32` of one `[f32; ROW_RAYS]` from `at`, within it
        // (`at + 16 <= ROW_RAYS`), unaligned.
        let load = |x: &[f32; ROW_RAYS]| unsafe { _mm512_loadu_ps(x.as_ptr().add(at)) };
        let o = [load(&rays.o[0]), load(&rays.o[1]), load(&rays.o[2])];
        let row = |r: usize| {
            [
                load(&rays.rows[r][0]),
                load(&rays.rows[r][1]),
                load(&rays.rows[r][2]),
            ]
        };
        let (rx, ry) = (row(0), row(1));
        let s = |x: f32| _mm512_set1_ps(x);
        let vertex = |k: usize| {
            [
                _mm512_sub_ps(s(tri[k].x), o[0]),
                _mm512_sub_ps(s(tri[k].y), o[1]),
                _mm512_sub_ps(s(tri[k].z), o[2]),
            ]
        };
        let p = [vertex(0), vertex(1), vertex(2)];
        // `r·p` as glam's `dot` sums it: `(r.x·p.x + r.y·p.y) + r.z·p.z`.
        let dot = |r: &[__m512; 3], p: &[__m512; 3]| {
            _mm512_add_ps(
                _mm512_add_ps(_mm512_mul_ps(r[0], p[0]), _mm512_mul_ps(r[1], p[1])),
                _mm512_mul_ps(r[2], p[2]),
            )
        };
        let (ax, ay) = (dot(&rx, &p[0]), dot(&ry, &p[0]));
        let (bx, by) = (dot(&rx, &p[1]), dot(&ry, &p[1]));
        let (cx, cy) = (dot(&rx, &p[2]), dot(&ry, &p[2]));
        let u = _mm512_sub_ps(_mm512_mul_ps(cx, by), _mm512_mul_ps(cy, bx));
        let v = _mm512_sub_ps(_mm512_mul_ps(ax, cy), _mm512_mul_ps(ay, cx));
        let w = _mm512_sub_ps(_mm512_mul_ps(bx, ay), _mm512_mul_ps(by, ax));
        let zero = _mm512_setzero_ps();
        macro_rules! any {
            ($cmp:ident) => {
                _mm512_cmp_ps_mask::<$cmp>(u, zero)
                    | _mm512_cmp_ps_mask::<$cmp>(v, zero)
                    | _mm512_cmp_ps_mask::<$cmp>(w, zero)
            };
        }
        let eq_zero = any!(_CMP_EQ_OQ);
        let mixed = any!(_CMP_LT_OQ) & any!(_CMP_GT_OQ);
        // `|det|` by clearing the sign bit, as the other kernels' `andnot` with -0.
        let det_abs = _mm512_abs_ps(_mm512_add_ps(_mm512_add_ps(u, v), w));
        let det_ok = _mm512_cmp_ps_mask::<_CMP_LT_OQ>(det_abs, s(f32::INFINITY))
            & _mm512_cmp_ps_mask::<_CMP_GT_OQ>(det_abs, zero);
        crossed |= ((!eq_zero & !mixed & det_ok) as u32) << at;
        redo |= (eq_zero as u32) << at;
    }
    Lanes { crossed, redo }
}

/// Tests the block's four lanes against the ray, with the arithmetic of the target's fastest
/// kernel.
#[inline(always)]
pub fn lanes(b: &Block, ray: &BlockRay) -> Lanes {
    #[cfg(target_arch = "x86_64")]
    {
        lanes_sse(b, ray)
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        lanes_portable(b, ray)
    }
}

/// The SSE kernel: the edge functions of four lanes at a time.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn lanes_sse(b: &Block, ray: &BlockRay) -> Lanes {
    use std::arch::x86_64::*;
    // SAFETY: SSE is part of every x86_64 target's baseline, so its intrinsics run on any
    // processor this code runs on. The loads read a block row, four f32 (16 bytes) at an
    // address aligned to 16 (`Block` is `align(16)` and its rows lie at multiples of 16 from
    // its start).
    unsafe {
        let load = |row: &[f32; LANES]| _mm_load_ps(row.as_ptr());
        let s = |x: f32| _mm_set1_ps(x);
        let o = [s(ray.o[0]), s(ray.o[1]), s(ray.o[2])];
        // Spelled out: the compiler may leave `array::map`'s closures as calls (the bvh's
        // lesson; a few percent of a query's instructions when it did).
        let vertex = |k: usize| {
            [
                _mm_sub_ps(load(&b.v[k][0]), o[0]),
                _mm_sub_ps(load(&b.v[k][1]), o[1]),
                _mm_sub_ps(load(&b.v[k][2]), o[2]),
            ]
        };
        let p = [vertex(0), vertex(1), vertex(2)];
        // `r·p` as glam's `dot` sums it: `(r.x·p.x + r.y·p.y) + r.z·p.z`.
        let dot = |r: &[f32; 3], p: &[__m128; 3]| {
            _mm_add_ps(
                _mm_add_ps(_mm_mul_ps(s(r[0]), p[0]), _mm_mul_ps(s(r[1]), p[1])),
                _mm_mul_ps(s(r[2]), p[2]),
            )
        };
        let [rx, ry] = &ray.rows;
        let (ax, ay) = (dot(rx, &p[0]), dot(ry, &p[0]));
        let (bx, by) = (dot(rx, &p[1]), dot(ry, &p[1]));
        let (cx, cy) = (dot(rx, &p[2]), dot(ry, &p[2]));
        let u = _mm_sub_ps(_mm_mul_ps(cx, by), _mm_mul_ps(cy, bx));
        let v = _mm_sub_ps(_mm_mul_ps(ax, cy), _mm_mul_ps(ay, cx));
        let w = _mm_sub_ps(_mm_mul_ps(bx, ay), _mm_mul_ps(by, ax));
        let zero = _mm_setzero_ps();
        macro_rules! any {
            ($cmp:ident) => {
                _mm_or_ps(_mm_or_ps($cmp(u, zero), $cmp(v, zero)), $cmp(w, zero))
            };
        }
        let redo = _mm_movemask_ps(any!(_mm_cmpeq_ps)) as u32;
        let mixed = _mm_and_ps(any!(_mm_cmplt_ps), any!(_mm_cmpgt_ps));
        let det = _mm_add_ps(_mm_add_ps(u, v), w);
        let det_abs = _mm_andnot_ps(s(-0.0), det);
        // Neither zero nor infinite nor NaN (a lane of no triangle).
        let det_ok = _mm_and_ps(
            _mm_cmplt_ps(det_abs, s(f32::INFINITY)),
            _mm_cmpgt_ps(det_abs, zero),
        );
        let crossed = _mm_movemask_ps(_mm_andnot_ps(mixed, det_ok)) as u32 & !redo;
        Lanes { crossed, redo }
    }
}

/// The portable kernel: the same arithmetic, lane by lane.
#[cfg_attr(target_arch = "x86_64", allow(dead_code))]
pub fn lanes_portable(b: &Block, ray: &BlockRay) -> Lanes {
    let mut out = Lanes {
        crossed: 0,
        redo: 0,
    };
    let [rx, ry] = &ray.rows;
    let o = ray.o;
    for l in 0..LANES {
        let p = [0, 1, 2].map(|k| [0, 1, 2].map(|a| b.v[k][a][l] - o[a]));
        let dot = |r: &[f32; 3], p: &[f32; 3]| r[0] * p[0] + r[1] * p[1] + r[2] * p[2];
        let (ax, ay) = (dot(rx, &p[0]), dot(ry, &p[0]));
        let (bx, by) = (dot(rx, &p[1]), dot(ry, &p[1]));
        let (cx, cy) = (dot(rx, &p[2]), dot(ry, &p[2]));
        let u = cx * by - cy * bx;
        let v = ax * cy - ay * cx;
        let w = bx * ay - by * ax;
        if u == 0.0 || v == 0.0 || w == 0.0 {
            out.redo |= 1 << l;
            continue;
        }
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            continue;
        }
        let det = u + v + w;
        if det != 0.0 && det.is_finite() {
            out.crossed |= 1 << l;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Ray, crossing_t, intersect_triangle};
    use proptest::prelude::*;

    /// Coordinates on a coarse lattice, so that edge functions are often exactly zero and
    /// rays often pass through vertices and along edges.
    fn coord() -> impl Strategy<Value = f32> {
        prop_oneof![(-4i32..=4).prop_map(|x| x as f32 * 0.5), -4.0f32..4.0]
    }

    fn point() -> impl Strategy<Value = Vec3> {
        (coord(), coord(), coord()).prop_map(|(x, y, z)| Vec3::new(x, y, z))
    }

    proptest! {
        /// A ray's shear alone is its prepared shear, bit for bit (the cache of blockers
        /// makes it so, `accel::shadow_cache`).
        #[test]
        fn a_rays_shear_alone_is_its_prepared_shear(origin in point(), dir in point()) {
            let ray = Ray::new(origin, dir, 0.0, f32::INFINITY);
            let (a, b) = (BlockRay::of_ray(&ray), BlockRay::new(&PreparedRay::new(&ray)));
            prop_assert_eq!(a.o.map(f32::to_bits), b.o.map(f32::to_bits));
            prop_assert_eq!(
                a.rows.map(|r| r.map(f32::to_bits)),
                b.rows.map(|r| r.map(f32::to_bits))
            );
        }

        /// Every kernel agrees with the scalar test lane by lane: the same lanes pass at the
        /// same bits of `t`, and the lanes handed back are exactly those with a zero edge
        /// function (where the scalar test is the answer).
        #[test]
        fn kernels_equal_the_scalar_test(
            tris in prop::collection::vec((point(), point(), point()), 0..=LANES),
            origin in point(),
            dir in point(),
            tmin in prop_oneof![Just(0.0f32), 0.0f32..1.0],
            tmax in prop_oneof![Just(f32::INFINITY), 0.5f32..10.0],
        ) {
            prop_assume!(dir != Vec3::ZERO);
            let mut b = Block::EMPTY;
            for (l, &(p, q, r)) in tris.iter().enumerate() {
                b.set(l, &[p, q, r], l as u32);
            }
            let ray = PreparedRay::new(&Ray::new(origin, dir, tmin, tmax));
            let br = BlockRay::new(&ray);
            let portable = lanes_portable(&b, &br);
            for l in 0..LANES {
                let scalar = if l < tris.len() {
                    intersect_triangle(&ray, &b.triangle(l), tmin, tmax)
                } else {
                    None
                };
                if portable.redo >> l & 1 == 0 {
                    let got = (portable.crossed >> l & 1 != 0)
                        .then(|| crossing_t(&b.triangle(l), &ray.ray, tmin, tmax))
                        .flatten();
                    prop_assert_eq!(got.map(f32::to_bits), scalar.map(f32::to_bits));
                }
            }
            prop_assert_eq!(lanes(&b, &br), portable);
        }

        /// The AVX-512 kernel finds for each ray of the halves wanted what the kernel finds
        /// for it alone, and leaves the other halves' bits clear.
        #[test]
        fn the_sixteen_ray_kernel_equals_the_kernel_ray_by_ray(
            (p, q, r) in (point(), point(), point()),
            unbounded in prop::bool::weighted(0.1),
            rays in prop::collection::vec((point(), point()), 1..=ROW_RAYS),
            wanted in prop_oneof![Just(u32::MAX), Just(0xffff), Just(0xffff_0000), any::<u32>()],
        ) {
            let tri = [p, if unbounded { Vec3::new(f32::NAN, q.y, q.z) } else { q }, r];
            let each: Vec<BlockRay> = rays
                .iter()
                .map(|&(o, d)| {
                    let d = if d == Vec3::ZERO { Vec3::X } else { d };
                    BlockRay::new(&PreparedRay::new(&Ray::new(o, d, 0.0, f32::INFINITY)))
                })
                .collect();
            #[cfg(target_arch = "x86_64")]
            if crate::accel::simd::avx512_available() {
                let mut b = Block::EMPTY;
                b.set(0, &tri, 0);
                // SAFETY: AVX-512 F is present.
                let got = unsafe { triangle_rays_avx512(&tri, &RayRows::new(&each), wanted) };
                for l in 0..ROW_RAYS {
                    let half = 0xffffu32 << (l / 16 * 16);
                    let want = if wanted & half != 0 {
                        lanes(&b, &each[l.min(each.len() - 1)])
                    } else {
                        Lanes { crossed: 0, redo: 0 }
                    };
                    prop_assert_eq!(got.crossed >> l & 1, want.crossed & 1, "ray {}", l);
                    prop_assert_eq!(got.redo >> l & 1, want.redo & 1, "ray {}", l);
                }
            }
        }

        /// The packet kernel finds for each of its eight rays what the kernel finds for it
        /// alone.
        #[test]
        fn the_packet_kernel_equals_the_kernel_ray_by_ray(
            tris in prop::collection::vec((point(), point(), point()), 0..=LANES),
            rays in prop::collection::vec((point(), point()), 8),
        ) {
            let mut b = Block::EMPTY;
            for (l, &(p, q, r)) in tris.iter().enumerate() {
                b.set(l, &[p, q, r], l as u32);
            }
            let block_rays: [BlockRay; 8] = std::array::from_fn(|l| {
                let (o, d) = rays[l];
                let d = if d == Vec3::ZERO { Vec3::X } else { d };
                BlockRay::new(&PreparedRay::new(&Ray::new(o, d, 0.0, f32::INFINITY)))
            });
            #[cfg(target_arch = "x86_64")]
            if crate::accel::simd::available() {
                // SAFETY: AVX2 is present.
                let packed = BlockRays::new(&block_rays);
                let got = unsafe { packet_lanes_avx2(&b, &packed) };
                // SAFETY: as above.
                let by_triangle = unsafe { packet_rays_avx2(&b, &packed) };
                for (r, ray) in block_rays.iter().enumerate() {
                    let want = lanes(&b, ray);
                    prop_assert_eq!(got[r], want);
                    for (t, m) in by_triangle.iter().enumerate() {
                        prop_assert_eq!(m.crossed >> r & 1, want.crossed >> t & 1);
                        prop_assert_eq!(m.redo >> r & 1, want.redo >> t & 1);
                    }
                }
            }
        }
    }
}
