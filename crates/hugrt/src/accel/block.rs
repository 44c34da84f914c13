//! Four triangles side by side, one ray against all four at once: the leaves of the bvh.
//!
//! A [`Block`] holds its triangles' vertices as rows of four lanes (`v[vertex][axis][lane]`),
//! so the test is lane-wise arithmetic over whole rows: SSE on x86_64 (part of every x86_64
//! target's baseline, so it needs no run-time detection), plain lane loops elsewhere
//! ([`lanes_portable`], which the tests hold bit for bit to the SSE kernel).
//!
//! Both compute what the scalar test ([`intersect_triangle`]) computes, operation for
//! operation and in the same order (no fused multiply-add), so a lane's numbers are the scalar
//! test's bits. Lanes where an edge function is exactly zero, which the scalar test redoes in
//! double precision, are handed back to it ([`Lanes::redo`]).
//!
//! [`intersect_triangle`]: crate::geometry::intersect_triangle

use crate::geometry::{PreparedRay, Vec3};

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
    /// Lanes hit at `t[l]` within `[tmin, tmax]`, as the scalar test would report.
    pub pass: u32,
    /// Lanes with an edge function exactly zero: the scalar test decides those.
    pub redo: u32,
    pub t: [f32; LANES],
}

/// The ray's numbers the test uses: origin and the shear rows of [`PreparedRay::rows`].
#[derive(Clone, Copy)]
pub struct BlockRay {
    o: [f32; 3],
    rows: [[f32; 3]; 3],
}

impl BlockRay {
    #[inline]
    pub fn new(ray: &PreparedRay) -> Self {
        BlockRay {
            o: ray.ray.origin.to_array(),
            rows: ray.rows.map(|r| r.to_array()),
        }
    }
}

/// Tests the block's four lanes against the ray, with the arithmetic of the target's fastest
/// kernel.
#[inline(always)]
pub fn lanes(b: &Block, ray: &BlockRay, tmin: f32, tmax: f32) -> Lanes {
    #[cfg(target_arch = "x86_64")]
    {
        lanes_sse(b, ray, tmin, tmax)
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        lanes_portable(b, ray, tmin, tmax)
    }
}

/// The SSE kernel. It returns early, before the third row of the shear and the division,
/// when no lane is crossed: the common case.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn lanes_sse(b: &Block, ray: &BlockRay, tmin: f32, tmax: f32) -> Lanes {
    use std::arch::x86_64::*;
    // SAFETY: SSE is part of every x86_64 target's baseline, so its intrinsics run on any
    // processor this code runs on. The loads read a block row, four f32 (16 bytes) at an
    // address aligned to 16 (`Block` is `align(16)` and its rows lie at multiples of 16 from
    // its start); the store writes `out.t`, four f32, unaligned.
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
        let [rx, ry, rz] = &ray.rows;
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
        let crossed = _mm_andnot_ps(mixed, det_ok);
        let mut out = Lanes {
            pass: 0,
            redo,
            t: [0.0; LANES],
        };
        if _mm_movemask_ps(crossed) as u32 & !redo == 0 {
            return out;
        }
        let (az, bz, cz) = (dot(rz, &p[0]), dot(rz, &p[1]), dot(rz, &p[2]));
        let t_scaled = _mm_add_ps(
            _mm_add_ps(_mm_mul_ps(u, az), _mm_mul_ps(v, bz)),
            _mm_mul_ps(w, cz),
        );
        // Two-sided: in the sign of the determinant, as the scalar test flips it.
        let sign = _mm_and_ps(det, s(-0.0));
        let t_scaled = _mm_xor_ps(t_scaled, sign);
        let t = _mm_div_ps(t_scaled, det_abs);
        let (tmin, tmax) = (s(tmin), s(tmax));
        let in_range = _mm_and_ps(
            _mm_and_ps(
                _mm_cmpge_ps(t_scaled, _mm_mul_ps(tmin, det_abs)),
                _mm_cmple_ps(t_scaled, _mm_mul_ps(tmax, det_abs)),
            ),
            _mm_and_ps(_mm_cmpge_ps(t, tmin), _mm_cmple_ps(t, tmax)),
        );
        out.pass = _mm_movemask_ps(_mm_and_ps(crossed, in_range)) as u32 & !redo;
        _mm_storeu_ps(out.t.as_mut_ptr(), t);
        out
    }
}

/// The portable kernel: the same arithmetic, lane by lane.
#[cfg_attr(target_arch = "x86_64", allow(dead_code))]
pub fn lanes_portable(b: &Block, ray: &BlockRay, tmin: f32, tmax: f32) -> Lanes {
    let mut out = Lanes {
        pass: 0,
        redo: 0,
        t: [0.0; LANES],
    };
    let [rx, ry, rz] = &ray.rows;
    for l in 0..LANES {
        let p = [0, 1, 2].map(|k| [0, 1, 2].map(|a| b.v[k][a][l] - ray.o[a]));
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
        if det == 0.0 || !det.is_finite() {
            continue;
        }
        let t_scaled = u * dot(rz, &p[0]) + v * dot(rz, &p[1]) + w * dot(rz, &p[2]);
        let (t_scaled, det_abs) = if det < 0.0 {
            (-t_scaled, -det)
        } else {
            (t_scaled, det)
        };
        if t_scaled < tmin * det_abs || t_scaled > tmax * det_abs {
            continue;
        }
        let t = t_scaled / det_abs;
        if t >= tmin && t <= tmax {
            out.pass |= 1 << l;
            out.t[l] = t;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Ray, intersect_triangle};
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
            let portable = lanes_portable(&b, &br, tmin, tmax);
            for l in 0..LANES {
                let scalar = if l < tris.len() {
                    intersect_triangle(&ray, &b.triangle(l), tmin, tmax)
                } else {
                    None
                };
                if portable.redo >> l & 1 == 0 {
                    let got = (portable.pass >> l & 1 != 0).then_some(portable.t[l]);
                    prop_assert_eq!(got.map(f32::to_bits), scalar.map(f32::to_bits));
                }
            }
            let fast = lanes(&b, &br, tmin, tmax);
            prop_assert_eq!(fast.pass, portable.pass);
            prop_assert_eq!(fast.redo, portable.redo);
            for l in 0..LANES {
                if fast.pass >> l & 1 != 0 {
                    prop_assert_eq!(fast.t[l].to_bits(), portable.t[l].to_bits());
                }
            }
        }
    }
}
