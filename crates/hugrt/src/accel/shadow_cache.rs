//! The shadow cache of Haines and Greenberg ("The Light Buffer: A Shadow-Testing Accelerator",
//! IEEE CG&A 1986): the object that last blocked a shadow ray is tried first on the next one,
//! since neighbouring rays to one light are often blocked by the same object (a ceiling
//! between a room and a light above it, a wall, a roof).
//!
//! Here it serves the batch any-hit queries ([`super::Accel::any_hits`]): each group of
//! neighbouring rays is first tested against the primitive that last blocked a ray of the
//! groups before it, and only the rays it does not block are walked through the structure.
//! The answer does not change: an any-hit query asks whether anything is hit in the ray's
//! `[tmin, tmax]`, and a hit the cache finds is one, found by the primitive's own test
//! ([`Primitives::intersect`], the test every structure applies to it, bit for bit); a ray it
//! does not block is walked as before. Only which primitive is reported may differ, which an
//! any-hit query leaves open.
//!
//! Departures from the paper, each measured (`docs/measurements.md`, "Shadow rays: the
//! blocker cached"): the blocker is tried on a group's first ray, and on the others only if it
//! blocks that one; after a failure, the next blocker is cached only after a wait that
//! doubles with each failure, so that a scene whose blockers do not repeat (a terrain's rays,
//! each blocked by a triangle near its start) reads a blocker's geometry from the scene, a
//! cache miss, a few groups in a hundred rather than every group. The blocker's geometry is
//! copied into the cache when it is recorded: tested through the scene, which the structures'
//! walks never read, each test was a cache miss. Keeping the two last blockers, or dropping
//! the blocker when it blocks fewer than half of a group, measured no faster.

use super::block::{Block, BlockRay, BlockRays};
use super::packet::PACKET as KERNEL_RAYS;
use super::{Counters, Hit, PrimitiveKind, Primitives};
use crate::geometry::{PreparedRay, Ray, crossing_t, intersect_triangle};

/// The longest wait between blockers cached, in groups that found a new one.
const MAX_WAIT: u32 = 64;

/// The primitive that last blocked a ray of a batch, with its geometry
/// ([`Primitives::kind`]), and the wait before caching another after a failure.
#[derive(Clone, Copy)]
pub(crate) struct ShadowCache {
    blocker: Option<(u32, PrimitiveKind)>,
    /// A triangle blocker in the packet kernel's first lane, the others empty.
    block: Block,
    /// The wait after the last failure, in groups: 1, 3, 7, … up to [`MAX_WAIT`].
    wait: u32,
    /// Groups still to let pass.
    idle: u32,
}

impl Default for ShadowCache {
    fn default() -> Self {
        ShadowCache {
            blocker: None,
            block: Block::EMPTY,
            wait: 0,
            idle: 0,
        }
    }
}

impl ShadowCache {
    /// Whether a blocker is cached.
    #[inline]
    pub(crate) fn is_empty(&self) -> bool {
        self.blocker.is_none()
    }

    /// Whether `prim` is the cached blocker.
    #[inline]
    pub(crate) fn holds(&self, prim: u32) -> bool {
        self.blocker.is_some_and(|(p, _)| p == prim)
    }

    /// The cached blocker's hit on `ray`, if it blocks it, counted as a primitive test at
    /// level 0.
    #[inline]
    pub(crate) fn test<P: Primitives, C: Counters>(
        &self,
        prims: &P,
        ray: &Ray,
        counters: &mut C,
    ) -> Option<Hit> {
        let (p, kind) = self.blocker?;
        let r = PreparedRay::new(ray);
        let (tmin, tmax) = (ray.tmin, ray.tmax);
        counters.prim_test(0);
        // `Primitives::kind`'s contract: the primitive's own test is the geometry's.
        let t = match kind {
            PrimitiveKind::Triangle(v) => intersect_triangle(&r, &v, tmin, tmax),
            PrimitiveKind::Sphere(s) => s.intersect(&r, tmin, tmax),
            PrimitiveKind::Cone(c) => c.intersect(&r, tmin, tmax),
            PrimitiveKind::Opaque => prims.intersect(p as usize, &r, tmin, tmax),
        }?;
        counters.prim_hit(0);
        Some(Hit { t, prim: p })
    }

    /// The cached blocker did not block a group's first ray: it is dropped, and the next is
    /// cached only after a wait.
    #[inline]
    pub(crate) fn failed(&mut self) {
        self.blocker = None;
        self.wait = (2 * self.wait + 1).min(MAX_WAIT);
        self.idle = self.wait;
    }

    /// The cached blocker blocked a group's first ray: no wait after the next failure but one.
    #[inline]
    pub(crate) fn paid(&mut self) {
        self.wait = 0;
    }

    /// Whether a new blocker found in a group should be cached now (`false` while waiting).
    #[inline]
    pub(crate) fn may_record(&mut self) -> bool {
        if self.idle > 0 {
            self.idle -= 1;
            return false;
        }
        true
    }

    /// Calls `blocked(j, hit)` for each ray `rays[j]` the cached blocker blocks, counting a
    /// primitive test at level 0 for each ray. With `avx2`, where the processor has it, a
    /// triangle is met by eight rays at a time with the packet kernel ([`super::block::packet_rays_avx2`], bit for bit the
    /// triangle's own test: a crossed lane's `t` is [`crossing_t`]'s, a lane it hands back
    /// gets [`intersect_triangle`]), which needs of each ray only its shear rather than the
    /// whole preparation [`ShadowCache::test`] makes: on the kitchen, whose shadow rays are
    /// nearly all blocked by its ceiling, the cache's tests took 40% of the trace's
    /// instructions one ray at a time.
    #[inline]
    pub(crate) fn test_many<P: Primitives, C: Counters>(
        &self,
        prims: &P,
        rays: &[Ray],
        avx2: bool,
        counters: &mut C,
        mut blocked: impl FnMut(usize, Hit),
    ) {
        let Some((p, kind)) = self.blocker else {
            return;
        };
        #[cfg(target_arch = "x86_64")]
        if let (true, PrimitiveKind::Triangle(v)) = (avx2 && super::simd::available(), kind) {
            for (c, chunk) in rays.chunks(KERNEL_RAYS).enumerate() {
                let last = chunk.len() - 1;
                let lanes = BlockRays::new(&std::array::from_fn(|l| {
                    BlockRay::of_ray(&chunk[l.min(last)])
                }));
                // SAFETY: AVX2 is present (`simd::available()`, asked just above).
                let [found, ..] = unsafe { super::block::packet_rays_avx2(&self.block, &lanes) };
                for (l, ray) in chunk.iter().enumerate() {
                    counters.prim_test(0);
                    let t = if found.crossed >> l & 1 != 0 {
                        crossing_t(&v, ray, ray.tmin, ray.tmax)
                    } else if found.redo >> l & 1 != 0 {
                        intersect_triangle(&PreparedRay::new(ray), &v, ray.tmin, ray.tmax)
                    } else {
                        None
                    };
                    if let Some(t) = t {
                        counters.prim_hit(0);
                        blocked(c * KERNEL_RAYS + l, Hit { t, prim: p });
                    }
                }
            }
            return;
        }
        let _ = avx2;
        for (j, ray) in rays.iter().enumerate() {
            if let Some(h) = self.test(prims, ray, counters) {
                blocked(j, h);
            }
        }
    }

    /// Caches `prim`, of geometry `kind`, which blocked a ray.
    #[inline]
    pub(crate) fn record(&mut self, prim: u32, kind: PrimitiveKind) {
        self.blocker = Some((prim, kind));
        if let PrimitiveKind::Triangle(v) = kind {
            self.block = Block::EMPTY;
            self.block.set(0, &v, prim);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::NoCounters;
    use crate::geometry::Vec3;

    #[test]
    fn the_blocker_is_tested_from_its_copy_in_the_rays_interval() {
        let mut c = ShadowCache::default();
        let ray = Ray::new(Vec3::ZERO, Vec3::Z, 0.0, 2.0);
        // No primitives: the test must not read the scene.
        let none = crate::scene::Scene::from_triangles(Vec::new());
        assert!(c.is_empty() && c.test(&none, &ray, &mut NoCounters).is_none());
        let wall = [
            Vec3::new(-1.0, -1.0, 1.0),
            Vec3::new(1.0, -1.0, 1.0),
            Vec3::new(0.0, 1.0, 1.0),
        ];
        c.record(7, PrimitiveKind::Triangle(wall));
        assert!(c.holds(7) && !c.holds(8));
        assert_eq!(
            c.test(&none, &ray, &mut NoCounters),
            Some(Hit { t: 1.0, prim: 7 })
        );
        let short = Ray::new(Vec3::ZERO, Vec3::Z, 0.0, 0.5);
        assert_eq!(c.test(&none, &short, &mut NoCounters), None);
    }

    #[test]
    fn eight_rays_at_a_time_block_exactly_the_rays_one_at_a_time_does() {
        let none = crate::scene::Scene::from_triangles(Vec::new());
        let v = [
            Vec3::new(-1.0, -1.0, 1.0),
            Vec3::new(1.0, -1.0, 1.5),
            Vec3::new(0.0, 1.0, 1.0),
        ];
        let mut c = ShadowCache::default();
        c.record(3, PrimitiveKind::Triangle(v));
        // Rays at the vertices, at points of the edges (where the kernel hands lanes back to
        // the scalar test) and across the triangle, from origins above and below its plane,
        // some stopping short of it or starting past it; 0 to 40 rays a call.
        let mut rays = Vec::new();
        for (k, o) in [
            Vec3::ZERO,
            Vec3::new(0.3, -0.2, 3.0),
            Vec3::new(5.0, 1.0, -2.0),
        ]
        .into_iter()
        .enumerate()
        {
            let mut targets: Vec<Vec3> = v.to_vec();
            for (a, b) in [(0, 1), (1, 2), (2, 0)] {
                targets.push(0.5 * (v[a] + v[b]));
                targets.push(v[a] + 0.25 * (v[b] - v[a]));
            }
            for i in 0..9 {
                let (x, y) = (i as f32 / 4.0 - 1.0, 1.0 - i as f32 / 5.0);
                targets.push(Vec3::new(x, y, 1.2));
            }
            for (i, p) in targets.into_iter().enumerate() {
                let (tmin, tmax) = match (i + k) % 4 {
                    1 => (0.0, 0.5),
                    2 => (1.5, 4.0),
                    _ => (0.0, 4.0),
                };
                rays.push(Ray::new(o, p - o, tmin, tmax));
            }
        }
        let alone: Vec<Option<Hit>> = rays
            .iter()
            .map(|r| c.test(&none, r, &mut NoCounters))
            .collect();
        assert!(alone.iter().filter(|h| h.is_some()).count() > 10);
        assert!(alone.iter().filter(|h| h.is_none()).count() > 10);
        let mut paths = vec![false];
        if crate::accel::simd::available() {
            paths.push(true);
        }
        for avx2 in paths {
            for n in 0..=rays.len().min(40) {
                for start in [0, rays.len() - n] {
                    let mut got = vec![None; n];
                    c.test_many(
                        &none,
                        &rays[start..start + n],
                        avx2,
                        &mut NoCounters,
                        |j, h| got[j] = Some(h),
                    );
                    assert_eq!(
                        got,
                        alone[start..start + n],
                        "avx2 {avx2}, {n} rays from {start}"
                    );
                }
            }
        }
    }

    #[test]
    fn failures_wait_longer_each_time_until_one_pays() {
        let mut c = ShadowCache::default();
        assert!(c.may_record());
        let mut waits = Vec::new();
        for _ in 0..9 {
            c.record(3, PrimitiveKind::Opaque);
            c.failed();
            assert!(c.is_empty());
            let mut n = 0;
            while !c.may_record() {
                n += 1;
            }
            waits.push(n);
        }
        assert_eq!(waits, [1, 3, 7, 15, 31, 63, 64, 64, 64]);
        c.failed();
        c.paid();
        c.failed();
        assert!(
            !c.may_record() && c.may_record(),
            "a wait of one group after a success"
        );
    }
}
