//! Eight triangles against one ray at once (AVX2, chosen at run time), for the cells of the
//! grid hierarchies, which hold a dozen triangles where a mesh crosses them.
//!
//! The lanes compute exactly what the scalar test ([`intersect_triangle`]) computes before its
//! `t`, operation for operation and in the same order (no fused multiply-add), so each lane's
//! numbers are the scalar test's bits: the translated and sheared vertices, the edge functions
//! `u, v, w` and the determinant. The caller takes a crossed lane's `t` from the scalar test's
//! own [`crossing_t`], with the running nearest hit (`tmax`) of the moment, lane by lane in
//! order as the scalar loop would; lanes where an edge function is exactly zero, which the
//! scalar test redoes in double precision, go to the scalar test. So a hit found eight at a
//! time is the hit found one at a time.
//!
//! [`intersect_triangle`]: crate::geometry::intersect_triangle
//! [`crossing_t`]: crate::geometry::crossing_t

use crate::geometry::{PreparedRay, Ray, Vec3};

/// From eight lanes' edge functions `u, v, w` (AVX registers, the scalar test's numbers):
/// `(crossed, zero)`, the lanes whose triangle is crossed (no two signs differ, no edge
/// function zero, `0 < |u + v + w| < inf`, false for NaN) and the lanes with an edge function
/// exactly zero, which the scalar test decides. Shared by the kernels of eight triangles
/// against one ray ([`triangles8`]) and one triangle against eight rays
/// ([`crate::accel::block::packet_lanes_avx2`]), so that both classify a lane alike; a macro,
/// so that each AVX2 function inlines the intrinsics.
#[cfg(target_arch = "x86_64")]
macro_rules! edge_masks {
    ($u:expr, $v:expr, $w:expr) => {{
        use std::arch::x86_64::*;
        let (u, v, w) = ($u, $v, $w);
        let zero = _mm256_setzero_ps();
        macro_rules! any {
            ($cmp:ident) => {
                _mm256_or_ps(
                    _mm256_or_ps(
                        _mm256_cmp_ps::<$cmp>(u, zero),
                        _mm256_cmp_ps::<$cmp>(v, zero),
                    ),
                    _mm256_cmp_ps::<$cmp>(w, zero),
                )
            };
        }
        let eq_zero = any!(_CMP_EQ_OQ);
        let mixed = _mm256_and_ps(any!(_CMP_LT_OQ), any!(_CMP_GT_OQ));
        let det_abs = _mm256_andnot_ps(_mm256_set1_ps(-0.0), _mm256_add_ps(_mm256_add_ps(u, v), w));
        let det_ok = _mm256_and_ps(
            _mm256_cmp_ps::<_CMP_LT_OQ>(det_abs, _mm256_set1_ps(f32::INFINITY)),
            _mm256_cmp_ps::<_CMP_GT_OQ>(det_abs, zero),
        );
        let crossed = _mm256_andnot_ps(eq_zero, _mm256_andnot_ps(mixed, det_ok));
        (
            _mm256_movemask_ps(crossed) as u32,
            _mm256_movemask_ps(eq_zero) as u32,
        )
    }};
}
#[cfg(target_arch = "x86_64")]
pub(crate) use edge_masks;

/// The lanes of one batch: which the ray crosses, and which need the scalar test.
pub struct Lanes {
    /// Lanes whose triangle the ray crosses (signs of `u, v, w` agree, determinant finite and
    /// not zero).
    pub crossed: u32,
    /// Lanes with an edge function exactly zero: the scalar test decides those.
    pub scalar: u32,
}

/// Which of the processor's vector instructions the grids may use (the `simd` key of the grid
/// structures), each chosen at run time where the processor has it and the portable code
/// otherwise.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Simd {
    /// The widest the processor has: the packet walk and the single walk compiled for AVX-512
    /// where it is present (32 rays in two registers a row, and twice the registers: the
    /// HUG's camera rays 1.03–1.08× faster than with AVX2, its shadow rays 1.05–1.12×, its
    /// incoherent rays 1.08–1.12×; docs/measurements.md), AVX2 otherwise.
    Widest,
    /// AVX2 at most, even where AVX-512 is present (what tests use to run the AVX2 path there).
    Avx2,
    /// The portable code only: a cell's triangles one at a time.
    Off,
}

crate::accel::settings::choice_value!(Simd {
    Simd::Widest => "true",
    Simd::Avx2 => "avx2",
    Simd::Off => "false",
});

/// The four lanes of `v` truncated towards zero, for lanes already clamped to `i32`'s range
/// (NaN excluded): what `x as i32` gives each of them, in one SSE2 conversion (`cvttps2dq`)
/// where `as i32` tests each lane for NaN and overflow apart (six instructions a lane). The
/// bvh's binning converts three lanes an item a level (the bunny's bvh build took 174.9 M →
/// 157.7 M instructions with it), and the grids' binning and the HUG's clustering find a
/// box's cells with it (the city's HUG build about 35 M instructions fewer;
/// `docs/measurements.md`).
#[inline(always)]
pub(crate) fn truncate_lanes(v: glam::Vec4) -> [i32; 4] {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_cvttps_epi32, _mm_storeu_si128};
        let mut out = [0i32; 4];
        // SAFETY: both intrinsics need SSE2, part of every x86_64 target's baseline; the
        // store writes 16 bytes, without alignment, to `out`, which is 16 bytes long.
        unsafe { _mm_storeu_si128(out.as_mut_ptr().cast(), _mm_cvttps_epi32(v.into())) };
        out
    }
    #[cfg(not(target_arch = "x86_64"))]
    v.to_array().map(|x| x as i32)
}

/// Eight rays as rows of an AVX2 register each: `rows[k]` holds number `k` of rays
/// `rays[at(0)]` to `rays[at(7)]`, in a [`Ray`]'s field order (origin x, y, z, direction x, y,
/// z, `tmin`, `tmax`). Each ray is read whole into a register and the eight are transposed by
/// shuffles (24), where gathering the rows number by number took more instructions than the
/// tests that read them ([`crate::accel::Reach::route8`], the grids' world-box check).
///
/// # Safety
/// The processor must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) unsafe fn ray_rows_avx2(
    rays: &[Ray],
    at: impl Fn(usize) -> usize,
) -> [std::arch::x86_64::__m256; 8] {
    use std::arch::x86_64::*;
    const { assert!(size_of::<Ray>() == 8 * size_of::<f32>()) };
    // SAFETY: a `Ray` is `repr(C)`, three `f32` of origin (glam's `Vec3` is `repr(C)`), three
    // of direction, `tmin` and `tmax`: 32 bytes (asserted above), read unaligned from a
    // reference to one.
    let row = |l: usize| unsafe { _mm256_loadu_ps((&rays[at(l)] as *const Ray).cast()) };
    let r: [__m256; 8] = std::array::from_fn(row);
    // Pairs of rays interleaved, then fours, then the two halves of each row joined.
    let pairs: [__m256; 8] = std::array::from_fn(|k| {
        let (a, b) = (r[k / 2 * 2], r[k / 2 * 2 + 1]);
        if k % 2 == 0 {
            _mm256_unpacklo_ps(a, b)
        } else {
            _mm256_unpackhi_ps(a, b)
        }
    });
    let quads: [__m256; 8] = std::array::from_fn(|k| {
        let (a, b) = (
            pairs[k / 4 * 4 + k % 4 / 2],
            pairs[k / 4 * 4 + 2 + k % 4 / 2],
        );
        if k % 2 == 0 {
            _mm256_shuffle_ps::<0x44>(a, b)
        } else {
            _mm256_shuffle_ps::<0xee>(a, b)
        }
    });
    std::array::from_fn(|k| {
        let (a, b) = (quads[k % 4], quads[4 + k % 4]);
        if k < 4 {
            _mm256_permute2f128_ps::<0x20>(a, b)
        } else {
            _mm256_permute2f128_ps::<0x31>(a, b)
        }
    })
}

/// Asks the cache for the line holding `p`, a hint that never faults whatever the address
/// (so `p` may come from `wrapping_add` past an end), and does nothing off x86-64.
#[inline(always)]
pub(crate) fn prefetch_line(p: *const i8) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        // SAFETY: `_mm_prefetch` needs SSE, part of every x86_64 target's baseline; a
        // prefetch is a hint to the cache that never faults, whatever the address, and
        // changes nothing the program can observe.
        unsafe { _mm_prefetch::<_MM_HINT_T0>(p) };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = p;
}

/// Whether the running processor has what the AVX-512 walks are compiled for, beside AVX2
/// ([`available`]).
pub(crate) fn avx512_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        available()
            && std::arch::is_x86_feature_detected!("avx512f")
            && std::arch::is_x86_feature_detected!("avx512vl")
            && std::arch::is_x86_feature_detected!("avx512bw")
            && std::arch::is_x86_feature_detected!("avx512dq")
            && std::arch::is_x86_feature_detected!("popcnt")
            && std::arch::is_x86_feature_detected!("bmi1")
            && std::arch::is_x86_feature_detected!("bmi2")
            && std::arch::is_x86_feature_detected!("lzcnt")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Whether the running processor has what [`triangles8`] needs, and what the grids' single
/// walk is compiled for beside it (POPCNT, BMI1 and LZCNT, which every processor with AVX2
/// has).
pub fn available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2")
            && std::arch::is_x86_feature_detected!("popcnt")
            && std::arch::is_x86_feature_detected!("bmi1")
            && std::arch::is_x86_feature_detected!("lzcnt")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Where the kernel reads the triangles.
pub enum Source<'a> {
    /// Triangle `i` is `tris[i]`.
    Copied(&'a [[Vec3; 3]]),
    /// Triangle `i` is `indices[i].map(|k| vertices[k])`.
    Indexed {
        indices: &'a [[u32; 3]],
        vertices: &'a [Vec3],
    },
}

/// Tests the triangles `idx[k]`, `k < 8`, of `source` against `ray`.
///
/// # Safety
/// The processor must support AVX2 ([`available`]), and every `idx[k]` must be a triangle of
/// `source`; indexed, whose gathers take 32-bit offsets, `3 · indices.len()` and
/// `3 · vertices.len()` must be below `i32::MAX` and every index of `indices` below
/// `vertices.len()`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub unsafe fn triangles8(source: Source<'_>, idx: &[u32; 8], ray: &PreparedRay) -> Lanes {
    use std::arch::x86_64::*;
    // Each lane's triangle as it is stored, `raw[v][c]`: coordinate `c` of vertex `v`.
    let raw: [[__m256; 3]; 3] = match source {
        Source::Copied(tris) => {
            // The nine floats of each triangle read as two rows of four and one float, and
            // turned into columns with in-lane shuffles rather than gathered: nine eight-lane
            // gathers were three quarters of this kernel on AMD Zen 1, where a gather is
            // microcoded (there the HUG's and the grid's incoherent rays 1.08-1.25x faster;
            // docs/measurements.md). The
            // columns hold the gathers' bits.
            let at: [*const f32; 8] = std::array::from_fn(|k| {
                debug_assert!((idx[k] as usize) < tris.len());
                // SAFETY: `idx[k]` is a triangle of `tris` by the contract.
                unsafe { tris.as_ptr().add(idx[k] as usize).cast::<f32>() }
            });
            // Lane `k` of row `j` of the first half holds float `j` (second half: `4 + j`) of
            // triangle `k`: triangles 0-3 in the low 128 bits, 4-7 in the high.
            macro_rules! columns {
                ($first:expr) => {{
                    macro_rules! row {
                        ($j:expr) => {
                            // SAFETY: floats `first..first + 4`, `first ≤ 4`, of a triangle's
                            // nine.
                            unsafe {
                                _mm256_insertf128_ps::<1>(
                                    _mm256_castps128_ps256(_mm_loadu_ps(at[$j].add($first))),
                                    _mm_loadu_ps(at[$j + 4].add($first)),
                                )
                            }
                        };
                    }
                    let (r0, r1, r2, r3) = (row!(0), row!(1), row!(2), row!(3));
                    let (lo01, lo23) = (_mm256_unpacklo_ps(r0, r1), _mm256_unpacklo_ps(r2, r3));
                    let (hi01, hi23) = (_mm256_unpackhi_ps(r0, r1), _mm256_unpackhi_ps(r2, r3));
                    [
                        _mm256_shuffle_ps::<0x44>(lo01, lo23),
                        _mm256_shuffle_ps::<0xEE>(lo01, lo23),
                        _mm256_shuffle_ps::<0x44>(hi01, hi23),
                        _mm256_shuffle_ps::<0xEE>(hi01, hi23),
                    ]
                }};
            }
            let [x0, y0, z0, x1] = columns!(0);
            let [y1, z1, x2, y2] = columns!(4);
            // SAFETY: float 8, the last of each triangle.
            let z2 = unsafe {
                _mm256_setr_ps(
                    *at[0].add(8),
                    *at[1].add(8),
                    *at[2].add(8),
                    *at[3].add(8),
                    *at[4].add(8),
                    *at[5].add(8),
                    *at[6].add(8),
                    *at[7].add(8),
                )
            };
            [[x0, y0, z0], [x1, y1, z1], [x2, y2, z2]]
        }
        Source::Indexed { indices, vertices } => {
            // SAFETY: `idx` is eight u32, read unaligned.
            let idx = unsafe { _mm256_loadu_si256(idx.as_ptr().cast()) };
            // (Macros rather than closures: the intrinsics must be inlined into this AVX2
            // function.)
            macro_rules! plus {
                ($v:expr, $j:expr) => {
                    _mm256_add_epi32($v, _mm256_set1_epi32($j))
                };
            }
            debug_assert!(indices.len() * 3 < i32::MAX as usize);
            debug_assert!(vertices.len() * 3 < i32::MAX as usize);
            let at = _mm256_mullo_epi32(idx, _mm256_set1_epi32(3));
            let ibase = indices.as_ptr().cast::<i32>();
            let base = vertices.as_ptr().cast::<f32>();
            macro_rules! vertex {
                ($v:expr) => {{
                    let first = _mm256_mullo_epi32(
                        // SAFETY: lane `k` reads index `3·idx[k] + v`, `v < 3`, of a live
                        // triangle's indices, in bounds by the contract.
                        unsafe { _mm256_i32gather_epi32::<4>(ibase, plus!(at, $v)) },
                        _mm256_set1_epi32(3),
                    );
                    // SAFETY: lane `k` reads float `3·indices[idx[k]][v] + c`, `c < 3`, in
                    // bounds by the contract (a vertex the mesh's indices name). Gathered:
                    // a row of four from a vertex could read past the last one.
                    unsafe {
                        [
                            _mm256_i32gather_ps::<4>(base, first),
                            _mm256_i32gather_ps::<4>(base, plus!(first, 1)),
                            _mm256_i32gather_ps::<4>(base, plus!(first, 2)),
                        ]
                    }
                }};
            }
            [vertex!(0), vertex!(1), vertex!(2)]
        }
    };
    macro_rules! s {
        ($x:expr) => {
            _mm256_set1_ps($x)
        };
    }
    // `r·p` as glam computes it: `(r.x·p.x + r.y·p.y) + r.z·p.z`.
    macro_rules! dot {
        ($r:expr, $p:expr) => {
            _mm256_add_ps(
                _mm256_add_ps(
                    _mm256_mul_ps(s!($r.x), $p[0]),
                    _mm256_mul_ps(s!($r.y), $p[1]),
                ),
                _mm256_mul_ps(s!($r.z), $p[2]),
            )
        };
    }
    let o = ray.ray.origin;
    let [rx, ry] = ray.rows;
    macro_rules! vertex {
        ($v:expr) => {
            [
                _mm256_sub_ps(raw[$v][0], s!(o.x)),
                _mm256_sub_ps(raw[$v][1], s!(o.y)),
                _mm256_sub_ps(raw[$v][2], s!(o.z)),
            ]
        };
    }
    let (a, b, c) = (vertex!(0), vertex!(1), vertex!(2));
    let (ax, ay) = (dot!(rx, a), dot!(ry, a));
    let (bx, by) = (dot!(rx, b), dot!(ry, b));
    let (cx, cy) = (dot!(rx, c), dot!(ry, c));
    let u = _mm256_sub_ps(_mm256_mul_ps(cx, by), _mm256_mul_ps(cy, bx));
    let v = _mm256_sub_ps(_mm256_mul_ps(ax, cy), _mm256_mul_ps(ay, cx));
    let w = _mm256_sub_ps(_mm256_mul_ps(bx, ay), _mm256_mul_ps(by, ax));
    let (crossed, scalar) = edge_masks!(u, v, w);
    Lanes { crossed, scalar }
}

#[cfg(test)]
mod tests {
    use super::truncate_lanes;
    use glam::Vec4;

    #[test]
    fn truncated_lanes_are_what_as_i32_gives() {
        let values = [
            0.0, -0.0, 0.49, 0.5, 0.99, 1.0, 1.5, 15.999, 31.0, 31.99, -1.5, 1e9,
        ];
        for w in values.windows(4) {
            let v = Vec4::new(w[0], w[1], w[2], w[3]);
            assert_eq!(truncate_lanes(v), v.to_array().map(|x| x as i32), "{v}");
        }
    }
}
