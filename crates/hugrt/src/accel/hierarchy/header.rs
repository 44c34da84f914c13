//! One grid of the hierarchy as the build and the walk see it: its box, resolution and where
//! its cells start among all grids' cells.

use super::NO_FRAME;
use crate::accel::{Frame, simd};
use crate::geometry::{Aabb, Ray, Vec3, greater, lesser};
use glam::Vec4;

/// `1 + 2·gamma(3)` of Ize ("Robust BVH Ray Traversal", JCGT 2013): scaling the far slab
/// distance by it makes the slab test conservative under rounding.
const ROBUST_FAR: f32 = 1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// The interval `[t0, t1]` of the ray `o + t·d` (`inv = 1/d`) in the box `(min, max)`, within
/// `[tmin, tmax]`, its far end widened by [`ROBUST_FAR`]; empty when `t0 > t1`. A grid's box
/// ([`GridHeader::interval`]) and the box of what a cell holds (`bounds`) are met by it.
#[inline(always)]
pub(super) fn slab(min: Vec3, max: Vec3, o: Vec3, inv: Vec3, tmin: f32, tmax: f32) -> (f32, f32) {
    let ta = (min - o) * inv;
    let tb = (max - o) * inv;
    (
        tmin.max(ta.min(tb).max_element()),
        tmax.min(ta.max(tb).min_element() * ROBUST_FAR),
    )
}

/// Whether some ray of `rays` meets the box `(min, max)` by [`slab`], ray `i` within its
/// `[tmin, far(i)]` and with its inverse direction by division (`Vec3::ONE / dir`), as the
/// walks make it. A packet that misses the world grid asks this of every ray: one ray at a
/// time it was 53 instructions a ray, a sixteenth of the kitchen's and the city's camera
/// frames. Eight rays a step: in AVX2 registers where `avx2` (the processor has it and the
/// structure may use it, [`simd::available`]), else in rows the compiler keeps in SSE2
/// registers. Either way each lane makes [`slab`]'s operations in [`slab`]'s order (glam's
/// `min`, `max` and their reductions are [`lesser`] and [`greater`], as `minps` and `maxps`
/// are; the ends `f32::max` and `f32::min`), so its answer is [`slab`]'s (tested on zeros,
/// infinities and NaN).
pub(super) fn any_meets(
    min: Vec3,
    max: Vec3,
    rays: &[Ray],
    far: impl Fn(usize) -> f32,
    avx2: bool,
) -> bool {
    #[cfg(target_arch = "x86_64")]
    if avx2 {
        // SAFETY: `avx2` holds only where the processor has AVX2 ([`simd::available`]), all
        // the function's attribute enables.
        return unsafe { any_meets_avx2(min, max, rays, far) };
    }
    let _ = avx2;
    any_meets_lanes(min, max, rays, far)
}

/// [`any_meets`] in rows of eight lanes, which the compiler vectorizes for the baseline.
fn any_meets_lanes(min: Vec3, max: Vec3, rays: &[Ray], far: impl Fn(usize) -> f32) -> bool {
    (0..rays.len())
        .step_by(8)
        .any(|start| meets8_lanes(min, max, rays, start, &far) != 0)
}

/// The rays `start..start + 8` of `rays` that meet the box (a bit each, lane `l` for ray
/// `start + l`; the lanes past the last ray repeat it), as [`any_meets`] asks.
#[inline(always)]
fn meets8_lanes(
    min: Vec3,
    max: Vec3,
    rays: &[Ray],
    start: usize,
    far: &impl Fn(usize) -> f32,
) -> u32 {
    const L: usize = 8;
    let n = rays.len();
    let mut o = [[0f32; L]; 3];
    let mut d = [[0f32; L]; 3];
    let (mut near, mut far_end) = ([0f32; L], [0f32; L]);
    for l in 0..L {
        let i = (start + l).min(n - 1);
        let r = &rays[i];
        for a in 0..3 {
            (o[a][l], d[a][l]) = (r.origin[a], r.dir[a]);
        }
        (near[l], far_end[l]) = (r.tmin, far(i));
    }
    let inv: [[f32; L]; 3] = std::array::from_fn(|a| std::array::from_fn(|l| 1.0 / d[a][l]));
    let (t0, t1) = slab_lanes(min, max, &o, &inv, &near, &far_end);
    let mut meets = 0u32;
    for l in 0..L {
        meets |= ((t0[l] <= t1[l]) as u32) << l;
    }
    meets
}

/// [`slab`] of `L` rays at once, given lane by lane (`o[a][l]` is ray `l`'s origin along axis
/// `a`, `inv` its inverse direction, `near` and `far` its interval): each lane makes
/// [`slab`]'s operations in [`slab`]'s order (glam's `min`, `max` and their reductions are
/// [`lesser`] and [`greater`]; the ends `f32::max` and `f32::min`), so its numbers are
/// [`slab`]'s (tested), in a loop the compiler vectorizes.
#[inline(always)]
pub(super) fn slab_lanes<const L: usize>(
    min: Vec3,
    max: Vec3,
    o: &[[f32; L]; 3],
    inv: &[[f32; L]; 3],
    near: &[f32; L],
    far: &[f32; L],
) -> ([f32; L], [f32; L]) {
    let (mut t0, mut t1) = ([0f32; L], [0f32; L]);
    for l in 0..L {
        let slabs = |a: usize| {
            let (ta, tb) = (
                (min[a] - o[a][l]) * inv[a][l],
                (max[a] - o[a][l]) * inv[a][l],
            );
            (lesser(ta, tb), greater(ta, tb))
        };
        let ((x0, x1), (y0, y1), (z0, z1)) = (slabs(0), slabs(1), slabs(2));
        t0[l] = near[l].max(greater(greater(x0, y0), z0));
        t1[l] = far[l].min(lesser(lesser(x1, y1), z1) * ROBUST_FAR);
    }
    (t0, t1)
}

/// [`any_meets`] in AVX2 ([`meets8_avx2`]).
///
/// # Safety
/// The processor must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn any_meets_avx2(min: Vec3, max: Vec3, rays: &[Ray], far: impl Fn(usize) -> f32) -> bool {
    // SAFETY: the caller's processor has AVX2.
    (0..rays.len())
        .step_by(8)
        .any(|start| unsafe { meets8_avx2(min, max, rays, start, &far) } != 0)
}

/// [`meets8_lanes`] in AVX2, the rays turned into rows by [`simd::ray_rows_avx2`].
///
/// # Safety
/// The processor must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn meets8_avx2(
    min: Vec3,
    max: Vec3,
    rays: &[Ray],
    start: usize,
    far: &impl Fn(usize) -> f32,
) -> u32 {
    use std::arch::x86_64::*;
    let n = rays.len();
    let at = |l: usize| (start + l).min(n - 1);
    // Number `k` of each ray in `c[k]`; the rays' own `tmax` gives way to `far`.
    // SAFETY: the caller's processor has AVX2.
    let c = unsafe { simd::ray_rows_avx2(rays, at) };
    let far_end: [f32; 8] = std::array::from_fn(|l| far(at(l)));
    // SAFETY: reads the eight `f32` of `far_end`, unaligned.
    let far_end = unsafe { _mm256_loadu_ps(far_end.as_ptr()) };
    let slabs = |a: usize| {
        let inv = _mm256_div_ps(_mm256_set1_ps(1.0), c[3 + a]);
        let ta = _mm256_mul_ps(_mm256_sub_ps(_mm256_set1_ps(min[a]), c[a]), inv);
        let tb = _mm256_mul_ps(_mm256_sub_ps(_mm256_set1_ps(max[a]), c[a]), inv);
        (_mm256_min_ps(ta, tb), _mm256_max_ps(ta, tb))
    };
    let ((x0, x1), (y0, y1), (z0, z1)) = (slabs(0), slabs(1), slabs(2));
    let nan = |x: __m256| _mm256_cmp_ps::<_CMP_UNORD_Q>(x, x);
    // `f32::max(tmin, m)` and `f32::min(far, m)`: `maxps` and `minps` give their second
    // operand where either is NaN, the bound, which is `f32`'s answer unless the bound itself
    // is NaN.
    let m0 = _mm256_max_ps(_mm256_max_ps(x0, y0), z0);
    let t0 = _mm256_blendv_ps(_mm256_max_ps(m0, c[6]), m0, nan(c[6]));
    let m1 = _mm256_mul_ps(
        _mm256_min_ps(_mm256_min_ps(x1, y1), z1),
        _mm256_set1_ps(ROBUST_FAR),
    );
    let t1 = _mm256_blendv_ps(_mm256_min_ps(m1, far_end), m1, nan(far_end));
    _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(t0, t1)) as u32
}

#[derive(Clone, Copy, Debug)]
pub(super) struct GridHeader {
    /// The grid's box, in its own frame.
    pub(super) min: Vec3,
    pub(super) max: Vec3,
    pub(super) size: Vec3,
    pub(super) inv_size: Vec3,
    pub(super) res: [u32; 3],
    /// Index of cell (0, 0, 0) among all grids' cells.
    pub(super) first_cell: u32,
    pub(super) frame: u32,
    pub(super) depth: u32,
    /// [`GridPlan::level`].
    pub(super) level: u32,
    pub(super) objects: u32,
}

impl GridHeader {
    /// A grid over `bounds` (in no frame of its own) with `res` cells per axis, standing
    /// alone (its cells first among all grids'): what a planner asks of a grid before the
    /// build.
    pub(super) fn over(bounds: &Aabb, res: [u32; 3]) -> GridHeader {
        let mut h = GridHeader {
            min: bounds.min,
            max: bounds.max,
            size: Vec3::ONE,
            inv_size: Vec3::ONE,
            res: [1, 1, 1],
            first_cell: 0,
            frame: NO_FRAME,
            depth: 0,
            level: 0,
            objects: 0,
        };
        h.set_resolution(res);
        h
    }

    pub(super) fn cells(&self) -> usize {
        self.res.iter().map(|&r| r as usize).product()
    }

    /// The interval `[t0, t1]` of the ray `o + t·d` (`inv = 1/d`) in the grid's box, within
    /// `[tmin, tmax]`: the slab test, its far end widened by [`ROBUST_FAR`]; empty when
    /// `t0 > t1`. `min` and `max` return the non-NaN operand, so a 0·inf slab is ignored. The
    /// single walk and the packet walk both enter a grid by it.
    #[inline(always)]
    pub(super) fn interval(&self, o: Vec3, inv: Vec3, tmin: f32, tmax: f32) -> (f32, f32) {
        slab(self.min, self.max, o, inv, tmin, tmax)
    }

    #[inline(always)]
    pub(super) fn coord(&self, a: usize, x: f32) -> u32 {
        // Truncation is the floor for the non-negative values that survive the clamp (and NaN
        // becomes 0); `floor` itself is a library call without SSE4.1.
        let c = (x - self.min[a]) * self.inv_size[a];
        (c.max(0.0) as u32).min(self.res[a] - 1)
    }

    /// The cells `b` meets, from its low corner's to its high corner's: each coordinate as
    /// [`GridHeader::coord`] makes it, the three axes converted at once
    /// ([`simd::truncate_lanes`]).
    #[inline(always)]
    pub(super) fn cell_range(&self, b: &Aabb) -> ([u32; 3], [u32; 3]) {
        // The grid's lanes made once for both corners, each corner's subtraction and product
        // in one register (the same operations as one coordinate at a time).
        let (min, inv) = (
            Vec4::from((self.min, 0.0)),
            Vec4::from((self.inv_size, 0.0)),
        );
        let cells = |p: Vec3| -> [u32; 3] {
            let c = ((Vec4::from((p, 0.0)) - min) * inv).max(Vec4::ZERO);
            let c = simd::truncate_lanes(c);
            std::array::from_fn(|a| (c[a] as u32).min(self.res[a] - 1))
        };
        (cells(b.min), cells(b.max))
    }

    pub(super) fn cell_box(&self, c: [u32; 3]) -> Aabb {
        let lo = self.min + Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32) * self.size;
        Aabb::new(lo, lo + self.size)
    }

    pub(super) fn set_resolution(&mut self, res: [u32; 3]) {
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
    pub(super) fn shift_planes(&mut self) {
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

    pub(super) fn world_box(&self, frames: &[Frame]) -> Aabb {
        let b = Aabb::new(self.min, self.max);
        if self.frame == NO_FRAME {
            b
        } else {
            frames[self.frame as usize].world_box(&b)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The paths of [`any_meets`] this processor runs: the portable one, and AVX2 where it
    /// has it.
    fn paths() -> Vec<bool> {
        let mut paths = vec![false];
        if simd::available() {
            paths.push(true);
        } else {
            eprintln!("no AVX2 here: only the portable path is tested");
        }
        paths
    }

    /// [`any_meets`] of one ray and of several is [`slab`]'s answer, on origins in the box's
    /// planes, zero, tiny and huge direction components, infinite and NaN ends.
    #[test]
    fn any_meets_answers_as_the_slab_test() {
        let (min, max) = (Vec3::new(-1.0, 0.0, 2.0), Vec3::new(1.0, 0.5, 2.0));
        let coords = [
            -1.0,
            0.0,
            -0.0,
            0.5,
            1.0,
            2.0,
            3.0,
            -7.25,
            1e-30,
            1e30,
            f32::INFINITY,
        ];
        let dirs = [0.0, -0.0, 1.0, -1.0, 1e-40, -1e-38, 3.0, 1e30, f32::NAN];
        let ends = [
            (0.0, f32::INFINITY),
            (0.0, 0.0),
            (2.0, 1.0),
            (-f32::INFINITY, 5.0),
            (f32::NAN, 4.0),
            (0.0, f32::NAN),
            (1.5, 1e30),
        ];
        let mut k = 0usize;
        let mut rays = Vec::new();
        let mut met = 0;
        for &ox in &coords {
            for &dx in &dirs {
                for &(tmin, tmax) in &ends {
                    // Each value on x, the others drawn from the lists in turn.
                    let pick = |list: &[f32], j: usize| list[(k * 7 + j * 3) % list.len()];
                    let o = Vec3::new(ox, pick(&coords, 1), pick(&coords, 2));
                    let d = Vec3::new(dx, pick(&dirs, 3), pick(&dirs, 4));
                    k += 1;
                    let turned = Ray::new(
                        Vec3::new(o.z, o.x, o.y),
                        Vec3::new(d.y, d.z, d.x),
                        tmin,
                        tmax,
                    );
                    for r in [Ray::new(o, d, tmin, tmax), turned] {
                        let (t0, t1) = slab(min, max, r.origin, Vec3::ONE / r.dir, tmin, tmax);
                        met += (t0 <= t1) as usize;
                        for avx2 in paths() {
                            assert_eq!(
                                any_meets(min, max, &[r], |_| tmax, avx2),
                                t0 <= t1,
                                "{r:?}"
                            );
                        }
                        rays.push(r);
                    }
                }
            }
        }
        assert!(
            met > 50 && met < rays.len() - 50,
            "both answers tested: {met}"
        );
        // Runs of rays, the last short: one meets exactly when some does.
        // `slab_lanes`' numbers, bit for bit, eight lanes of different rays.
        for run in rays.chunks_exact(8) {
            let row = |f: &dyn Fn(&Ray) -> Vec3| -> [[f32; 8]; 3] {
                std::array::from_fn(|a| std::array::from_fn(|l| f(&run[l])[a]))
            };
            let (o, inv) = (row(&|r| r.origin), row(&|r| Vec3::ONE / r.dir));
            let near = std::array::from_fn(|l| run[l].tmin);
            let far = std::array::from_fn(|l| run[l].tmax);
            let (t0, t1) = slab_lanes(min, max, &o, &inv, &near, &far);
            for (l, r) in run.iter().enumerate() {
                let (a, b) = slab(min, max, r.origin, Vec3::ONE / r.dir, r.tmin, r.tmax);
                let same = |x: f32, y: f32| x.to_bits() == y.to_bits() || x.is_nan() && y.is_nan();
                assert!(
                    same(t0[l], a) && same(t1[l], b),
                    "{r:?}: {:?}",
                    (t0[l], t1[l], a, b)
                );
            }
        }
        // Lane by lane, on runs of different rays (the last run short).
        let answer = |r: &Ray| {
            let (t0, t1) = slab(min, max, r.origin, Vec3::ONE / r.dir, r.tmin, r.tmax);
            t0 <= t1
        };
        for run in rays.chunks(13) {
            let far = |i: usize| run[i].tmax;
            for start in [0, 8] {
                let want = (0..8)
                    .map(|l| (answer(&run[(start + l).min(run.len() - 1)]) as u32) << l)
                    .sum::<u32>();
                assert_eq!(meets8_lanes(min, max, run, start, &far), want);
                #[cfg(target_arch = "x86_64")]
                if simd::available() {
                    // SAFETY: the processor has AVX2.
                    assert_eq!(unsafe { meets8_avx2(min, max, run, start, &far) }, want);
                }
            }
        }
        for avx2 in paths() {
            for run in rays.chunks(13) {
                let alone = run
                    .iter()
                    .any(|r| any_meets(min, max, &[*r], |_| r.tmax, avx2));
                assert_eq!(any_meets(min, max, run, |i| run[i].tmax, avx2), alone);
            }
            assert!(!any_meets(min, max, &[], |_| 0.0, avx2));
        }
    }
}
