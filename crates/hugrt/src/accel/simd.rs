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

use crate::geometry::{PreparedRay, Vec3};

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

/// Whether the running processor has what [`triangles8`] needs.
pub fn available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2")
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
/// `source`, whose gathers take 32-bit offsets: for copies, `9 · tris.len()` below
/// `i32::MAX`; indexed, `3 · indices.len()` and `3 · vertices.len()` below `i32::MAX` and
/// every index of `indices` below `vertices.len()`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub unsafe fn triangles8(source: Source<'_>, idx: &[u32; 8], ray: &PreparedRay) -> Lanes {
    use std::arch::x86_64::*;
    // SAFETY: `idx` is eight u32, read unaligned.
    let idx = unsafe { _mm256_loadu_si256(idx.as_ptr().cast()) };
    // (Macros rather than closures: the intrinsics must be inlined into this AVX2 function.)
    macro_rules! plus {
        ($v:expr, $j:expr) => {
            _mm256_add_epi32($v, _mm256_set1_epi32($j))
        };
    }
    // `base` and, per vertex of the triangle, each lane's offset of its x in floats.
    let (base, offs): (*const f32, [__m256i; 3]) = match source {
        Source::Copied(tris) => {
            debug_assert!(tris.len() * 9 < i32::MAX as usize);
            let first = _mm256_mullo_epi32(idx, _mm256_set1_epi32(9));
            (
                tris.as_ptr().cast(),
                [first, plus!(first, 3), plus!(first, 6)],
            )
        }
        Source::Indexed { indices, vertices } => {
            debug_assert!(indices.len() * 3 < i32::MAX as usize);
            debug_assert!(vertices.len() * 3 < i32::MAX as usize);
            let at = _mm256_mullo_epi32(idx, _mm256_set1_epi32(3));
            let ibase = indices.as_ptr().cast::<i32>();
            macro_rules! vertex {
                ($v:expr) => {
                    _mm256_mullo_epi32(
                        // SAFETY: lane `k` reads index `3·idx[k] + v`, `v < 3`, of a live
                        // triangle's indices, in bounds by the contract.
                        unsafe { _mm256_i32gather_epi32::<4>(ibase, plus!(at, $v)) },
                        _mm256_set1_epi32(3),
                    )
                };
            }
            (
                vertices.as_ptr().cast(),
                [vertex!(0), vertex!(1), vertex!(2)],
            )
        }
    };
    macro_rules! load {
        ($v:expr, $c:expr) => {
            // SAFETY: lane `k` reads coordinate `c < 3` of vertex `v` of triangle `idx[k]`:
            // in a copy, float `9·idx[k] + 3v + c`; indexed, float `3·indices[idx[k]][v] + c`;
            // in bounds by the contract either way.
            unsafe { _mm256_i32gather_ps::<4>(base, plus!(offs[$v], $c)) }
        };
    }
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
                _mm256_sub_ps(load!($v, 0), s!(o.x)),
                _mm256_sub_ps(load!($v, 1), s!(o.y)),
                _mm256_sub_ps(load!($v, 2), s!(o.z)),
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
