//! The primitive store: a structure's own compact copy of the primitives, laid out for ray
//! shooting.
//!
//! A structure built over [`Primitives`] only knows "bounds of i" and "intersect i"; going
//! through a scene's general `Shape` enum costs a ~44-byte load and a dispatch per test, and
//! the primitives of one cell lie wherever the file put them. The store instead keeps
//!
//! * triangles (and patches, which intersect as triangles) as three plain vertices, 36 bytes,
//!   then spheres, then cones, each kind contiguous so that the dispatch is a range check that
//!   a triangle-only scene always predicts;
//! * every kind sorted by the Morton code of its box centre, so that the primitives one cell
//!   or leaf references lie close together in memory;
//! * `ids`, the permutation back to the primitive's own index, which is what hits report.
//!
//! Primitives of no kind the store knows ([`PrimitiveKind::Opaque`]) are kept by index after
//! the others and intersected through [`Primitives::intersect`].
//!
//! The store calls the same intersection functions as the scene's shapes
//! ([`intersect_triangle`], [`Sphere::intersect`], [`Cone::intersect`]) on the same numbers, so
//! a hit found through the store is bit for bit the hit brute force finds.

use super::Frame;
use super::sort::radix_sort_high32;
use super::{Counters, HitSink, PrimitiveKind, Primitives, Reach, simd};
use crate::geometry::{Aabb, Cone, PreparedRay, Sphere, Vec3, crossing_t, intersect_triangle};
use rayon::prelude::*;

pub struct PrimStore {
    tris: Vec<[Vec3; 3]>,
    spheres: Vec<Sphere>,
    cones: Vec<Cone>,
    /// First store index of spheres, cones and opaque primitives.
    sphere_start: u32,
    cone_start: u32,
    opaque_start: u32,
    /// Store index → primitive index.
    ids: Vec<u32>,
    /// Where the primitives lie, for far rays ([`Reach`]).
    reach: Reach,
}

/// Whether a box can be binned: not empty and finite.
pub(crate) fn finite(b: &Aabb) -> bool {
    !b.is_empty() && b.min.is_finite() && b.max.is_finite()
}

/// Spreads the low 10 bits of `x` to every third bit.
fn spread3(x: u32) -> u32 {
    let mut x = x & 0x3ff;
    x = (x | x << 16) & 0x0300_00ff;
    x = (x | x << 8) & 0x0300_f00f;
    x = (x | x << 4) & 0x030c_30c3;
    x = (x | x << 2) & 0x0924_9249;
    x
}

/// 30-bit Morton code of `p` inside `b` (10 bits per axis, clamped to the box).
fn morton(p: Vec3, b: &Aabb) -> u32 {
    let e = b.extent();
    let scale = |a: usize| {
        if e[a] > 0.0 {
            (((p[a] - b.min[a]) / e[a]).clamp(0.0, 1.0) * 1023.0) as u32
        } else {
            0
        }
    };
    spread3(scale(0)) | spread3(scale(1)) << 1 | spread3(scale(2)) << 2
}

impl PrimStore {
    /// Copies the primitives into store order: by kind, then by the Morton code of the box
    /// centre. The codes are taken inside the box of a sample of the primitives (clamped at
    /// its sides): an order, not a bound, so it needs no exact box.
    pub fn build<P: Primitives>(prims: &P) -> PrimStore {
        let n = prims.len();
        assert!(n < u32::MAX as usize, "at most 2^32-2 primitives");
        let step = (n / 4096).max(1);
        let sample = (0..n.div_ceil(step))
            .into_par_iter()
            .map(|k| prims.bounds(k * step))
            .filter(finite)
            .reduce(|| Aabb::EMPTY, |a, b| a.union(&b));
        let rank = |k: PrimitiveKind| -> u64 {
            match k {
                PrimitiveKind::Triangle(_) => 0,
                PrimitiveKind::Sphere(_) => 1,
                PrimitiveKind::Cone(_) => 2,
                PrimitiveKind::Opaque => 3,
            }
        };
        // Key: kind (2 bits), Morton code (30 bits), primitive index (32 bits).
        let mut keys: Vec<u64> = (0..n)
            .into_par_iter()
            .map(|i| {
                let b = &prims.bounds(i);
                let code = if finite(b) {
                    morton(b.center(), &sample)
                } else {
                    (1 << 30) - 1
                };
                (rank(prims.kind(i)) << 30 | code as u64) << 32 | i as u64
            })
            .collect();
        radix_sort_high32(&mut keys);
        let id = |k: u64| (k & 0xffff_ffff) as usize;
        let start = |r: u64| keys.partition_point(|&k| k >> 62 < r);
        let (sphere_start, cone_start, opaque_start) = (start(1), start(2), start(3));
        let tris = keys[..sphere_start]
            .par_iter()
            .map(|&k| match prims.kind(id(k)) {
                PrimitiveKind::Triangle(v) => v,
                _ => unreachable!("sorted by kind"),
            })
            .collect();
        let spheres = keys[sphere_start..cone_start]
            .par_iter()
            .map(|&k| match prims.kind(id(k)) {
                PrimitiveKind::Sphere(s) => s,
                _ => unreachable!("sorted by kind"),
            })
            .collect();
        let cones = keys[cone_start..opaque_start]
            .par_iter()
            .map(|&k| match prims.kind(id(k)) {
                PrimitiveKind::Cone(c) => c,
                _ => unreachable!("sorted by kind"),
            })
            .collect();
        PrimStore {
            reach: Reach::of(prims),
            tris,
            spheres,
            cones,
            sphere_start: sphere_start as u32,
            cone_start: cone_start as u32,
            opaque_start: opaque_start as u32,
            ids: keys.par_iter().map(|&k| id(k) as u32).collect(),
        }
    }

    /// Where the primitives lie, for far rays.
    pub fn reach(&self) -> &Reach {
        &self.reach
    }

    pub fn len(&self) -> usize {
        self.ids.len()
    }

    pub fn is_empty(&self) -> bool {
        self.ids.is_empty()
    }

    /// The triangles, store entries `0..triangle_count()`.
    pub(crate) fn triangles(&self) -> &[[Vec3; 3]] {
        &self.tris
    }

    /// Frees the triangles, for a structure that keeps its own copy: triangle entries can then
    /// no longer be intersected or bounded through the store (their indices panic).
    pub(crate) fn release_triangles(&mut self) {
        self.tris = Vec::new();
    }

    /// The primitive's own index (what hits report) of store entry `s`.
    #[inline(always)]
    pub fn id(&self, s: u32) -> u32 {
        self.ids[s as usize]
    }

    /// Asks the cache for store entry `s`'s triangle, so that the loads of a cell's triangles
    /// overlap instead of waiting for each other (a cell's references are known at once).
    #[inline(always)]
    pub fn prefetch(&self, s: u32) {
        #[cfg(target_arch = "x86_64")]
        if let Some(t) = self.tris.get(s as usize) {
            use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
            // SAFETY: `_mm_prefetch` needs SSE, which is part of every x86_64 target's
            // baseline; a prefetch is a hint to the cache that never faults and changes
            // nothing the program can observe, and the address is that of a live element.
            unsafe { _mm_prefetch::<_MM_HINT_T0>((t as *const [Vec3; 3]).cast::<i8>()) };
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = s;
    }

    /// Hit parameter of store entry `s` in `[tmin, tmax]`, exactly as
    /// `prims.intersect(self.id(s), ..)` computes it.
    #[inline(always)]
    pub fn intersect<P: Primitives>(
        &self,
        prims: &P,
        s: u32,
        ray: &PreparedRay,
        tmin: f32,
        tmax: f32,
    ) -> Option<f32> {
        if s < self.sphere_start {
            intersect_triangle(ray, &self.tris[s as usize], tmin, tmax)
        } else {
            self.intersect_other(prims, s, ray, tmin, tmax)
        }
    }

    #[inline(never)]
    fn intersect_other<P: Primitives>(
        &self,
        prims: &P,
        s: u32,
        ray: &PreparedRay,
        tmin: f32,
        tmax: f32,
    ) -> Option<f32> {
        if s < self.cone_start {
            self.spheres[(s - self.sphere_start) as usize].intersect(ray, tmin, tmax)
        } else if s < self.opaque_start {
            self.cones[(s - self.cone_start) as usize].intersect(ray, tmin, tmax)
        } else {
            prims.intersect(self.id(s) as usize, ray, tmin, tmax)
        }
    }

    /// Tests the triangles `batch[..n]` (`n ≤ 8`, the rest of `batch` repeating one of them)
    /// eight at a time and offers their hits to `sink` in lane order, as testing them one at
    /// a time would (lanes the kernel leaves to the scalar test get it). Counts `n` tests at
    /// `level`. Returns `true` when the sink stops the walk.
    ///
    /// # Safety
    /// The processor must support AVX2 ([`simd::available`]), `9 · triangles().len()` must be
    /// below `i32::MAX`, and every entry of `batch` must be a triangle's (below
    /// `triangles().len()`).
    #[cfg(target_arch = "x86_64")]
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(crate) unsafe fn offer_triangles8<P: Primitives, C: Counters, S: HitSink>(
        &self,
        prims: &P,
        batch: &[u32; 8],
        n: usize,
        ray: &PreparedRay,
        tmin: f32,
        sink: &mut S,
        counters: &mut C,
        level: usize,
    ) -> bool {
        // SAFETY: the caller's contract is the kernel's.
        let lanes = unsafe { simd::triangles8(&self.tris, batch, ray) };
        for _ in 0..n {
            counters.prim_test(level);
        }
        let mut todo = (lanes.crossed | lanes.scalar) & ((1 << n) - 1);
        while todo != 0 {
            let l = todo.trailing_zeros() as usize;
            todo &= todo - 1;
            let t = if lanes.scalar >> l & 1 != 0 {
                self.intersect(prims, batch[l], ray, tmin, sink.tmax())
            } else {
                crossing_t(&self.tris[batch[l] as usize], &ray.ray, tmin, sink.tmax())
            };
            if let Some(t) = t {
                counters.prim_hit(level);
                if sink.offer(t, || self.id(batch[l])) {
                    return true;
                }
            }
        }
        false
    }

    /// The box of store entry `s`: what `prims.bounds(self.id(s))` gives, recomputed from the
    /// compact copy (the same arithmetic as the scene's shapes) rather than stored.
    #[inline]
    pub fn bounds<P: Primitives>(&self, prims: &P, s: u32) -> Aabb {
        if s < self.sphere_start {
            Aabb::from_points(&self.tris[s as usize])
        } else if s < self.cone_start {
            self.spheres[(s - self.sphere_start) as usize].bounds()
        } else if s < self.opaque_start {
            self.cones[(s - self.cone_start) as usize].bounds()
        } else {
            prims.bounds(self.id(s) as usize)
        }
    }

    /// The vertices of store entry `s`, if it is a triangle.
    pub fn triangle(&self, s: u32) -> Option<&[Vec3; 3]> {
        self.tris.get(s as usize)
    }

    /// Box of store entry `s` in frame `f` (`world` is its world-space box): tight for
    /// triangles, spheres and cones, the turned world box otherwise.
    pub(crate) fn local_bounds(&self, s: u32, f: &Frame, world: &Aabb) -> Aabb {
        if s < self.sphere_start {
            Aabb::from_points(&self.tris[s as usize].map(|v| f.point(v)))
        } else if s < self.cone_start {
            let sp = &self.spheres[(s - self.sphere_start) as usize];
            Sphere {
                center: f.point(sp.center),
                radius: sp.radius,
            }
            .bounds()
        } else if s < self.opaque_start {
            let c = &self.cones[(s - self.cone_start) as usize];
            Cone {
                base: f.point(c.base),
                apex: f.point(c.apex),
                ..*c
            }
            .bounds()
        } else {
            f.local_box(world)
        }
    }

    /// Bytes held by the store.
    pub fn memory_bytes(&self) -> usize {
        self.tris.capacity() * std::mem::size_of::<[Vec3; 3]>()
            + self.spheres.capacity() * std::mem::size_of::<Sphere>()
            + self.cones.capacity() * std::mem::size_of::<Cone>()
            + self.ids.capacity() * 4
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn morton_interleaves_axes() {
        assert_eq!(spread3(0b11), 0b1001);
        assert_eq!(spread3(0x3ff), 0x0924_9249);
        let b = Aabb::new(Vec3::ZERO, Vec3::ONE);
        assert_eq!(morton(Vec3::ZERO, &b), 0);
        assert!(morton(Vec3::new(1.0, 0.0, 0.0), &b) < morton(Vec3::new(0.0, 1.0, 0.0), &b));
        assert!(morton(Vec3::new(0.0, 1.0, 0.0), &b) < morton(Vec3::new(0.0, 0.0, 1.0), &b));
        assert_eq!(morton(Vec3::ONE, &b), (1 << 30) - 1);
        assert_eq!(morton(Vec3::splat(7.0), &b), (1 << 30) - 1, "clamped");
    }
}
