//! The shadow cache of Haines and Greenberg ("The Light Buffer: A Shadow-Testing Accelerator",
//! IEEE CG&A 1986, §"Shadow caching"): the primitive that last blocked a shadow ray is tried
//! first on the next one, since neighbouring rays to one light are often blocked by the same
//! object (a ceiling between a room and a light above it, a wall, a roof).
//!
//! Here it serves the batch any-hit queries ([`super::Accel::any_hits`]): each group of
//! neighbouring rays is first tested against the few primitives that blocked a ray of the
//! groups before it, and only the rays none of them blocks are walked through the structure.
//! The answer does not change: an any-hit query asks whether anything is hit in the ray's
//! `[tmin, tmax]`, and a hit the cache finds is one, found by the primitive's own test
//! ([`Primitives::intersect`], the test every structure applies to it, bit for bit); a ray it
//! does not block is walked as before. Only which primitive is reported may differ, which an
//! any-hit query leaves open.
//!
//! Departures from the paper, where a light keeps one object: a few primitives are kept, most
//! recent first, and one that blocks no ray of a group is dropped, so that a scene whose
//! blockers do not repeat (rays that mostly reach the light) pays for a cached primitive on
//! one group only.

use super::{Counters, Hit, PrimitiveKind, Primitives};
use crate::geometry::{PreparedRay, Ray, intersect_triangle};

/// How many primitives the cache keeps.
const KEPT: usize = 2;

/// The primitives that last blocked a ray of a batch, most recent first, each with its
/// geometry ([`Primitives::kind`]): tested from the cache's own copy, not through the scene,
/// whose primitives a structure's walk does not read and which were a cache miss a test.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Occluders {
    prims: [(u32, PrimitiveKind); KEPT],
    len: usize,
    /// Groups to let pass without caching a blocker, after cached ones failed: doubled at each
    /// failure up to [`MAX_WAIT`], so that a scene whose blockers do not repeat (a terrain's
    /// rays blocked each by a triangle near its origin) reads a blocker's geometry from the
    /// scene, a cache miss, for a few groups in a hundred rather than for every group.
    wait: u32,
    /// Groups still to let pass.
    idle: u32,
}

/// The longest wait between blockers cached, in groups.
const MAX_WAIT: u32 = 64;

impl Default for Occluders {
    fn default() -> Self {
        Occluders {
            prims: [(u32::MAX, PrimitiveKind::Opaque); KEPT],
            len: 0,
            wait: 0,
            idle: 0,
        }
    }
}

impl Occluders {
    #[inline]
    pub(crate) fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Whether `prim` is cached.
    #[inline]
    pub(crate) fn holds(&self, prim: u32) -> bool {
        self.prims[..self.len].iter().any(|&(p, _)| p == prim)
    }

    /// A hit of `ray` on a cached primitive, if any blocks it, counted as primitive tests at
    /// level 0; `used` records which did.
    #[inline]
    pub(crate) fn test<P: Primitives, C: Counters>(
        &self,
        prims: &P,
        ray: &Ray,
        used: &mut [bool; KEPT],
        counters: &mut C,
    ) -> Option<Hit> {
        let r = PreparedRay::new(ray);
        let (tmin, tmax) = (ray.tmin, ray.tmax);
        for (k, &(p, kind)) in self.prims[..self.len].iter().enumerate() {
            counters.prim_test(0);
            // `Primitives::kind`'s contract: the primitive's own test is the geometry's.
            let t = match kind {
                PrimitiveKind::Triangle(v) => intersect_triangle(&r, &v, tmin, tmax),
                PrimitiveKind::Sphere(s) => s.intersect(&r, tmin, tmax),
                PrimitiveKind::Cone(c) => c.intersect(&r, tmin, tmax),
                PrimitiveKind::Opaque => prims.intersect(p as usize, &r, tmin, tmax),
            };
            if let Some(t) = t {
                counters.prim_hit(0);
                used[k] = true;
                return Some(Hit { t, prim: p });
            }
        }
        None
    }

    /// The cached primitives did not pay for a group: they are dropped, and the next blocker
    /// is cached only after a wait.
    #[inline]
    pub(crate) fn failed(&mut self) {
        self.len = 0;
        self.wait = (2 * self.wait + 1).min(MAX_WAIT);
        self.idle = self.wait;
    }

    /// The cached primitives paid for a group: no wait.
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

    /// Drops the primitives `used` says blocked no ray of the group just tested.
    #[inline]
    pub(crate) fn keep_used(&mut self, used: &[bool; KEPT]) {
        let mut len = 0;
        for k in (0..self.len).filter(|&k| used[k]) {
            self.prims[len] = self.prims[k];
            len += 1;
        }
        self.len = len;
    }

    /// Records that `prim`, of geometry `kind`, blocked a ray: it comes first, the oldest goes
    /// where the cache is full.
    #[inline]
    pub(crate) fn record(&mut self, prim: u32, kind: PrimitiveKind) {
        let at = match self.prims[..self.len].iter().position(|&(p, _)| p == prim) {
            Some(at) => at,
            None => {
                self.len = (self.len + 1).min(KEPT);
                self.len - 1
            }
        };
        self.prims.copy_within(0..at, 1);
        self.prims[0] = (prim, kind);
    }

    /// A fresh record of which cached primitives blocked a ray of a group.
    #[inline]
    pub(crate) fn unused() -> [bool; KEPT] {
        [false; KEPT]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ids(c: &Occluders) -> Vec<u32> {
        c.prims[..c.len].iter().map(|&(p, _)| p).collect()
    }

    #[test]
    fn record_keeps_the_most_recent_first_without_repeats() {
        let mut c = Occluders::default();
        assert!(c.is_empty());
        let o = PrimitiveKind::Opaque;
        c.record(5, o);
        assert_eq!(ids(&c), [5]);
        c.record(7, o);
        assert_eq!(ids(&c), [7, 5]);
        c.record(7, o);
        assert_eq!(ids(&c), [7, 5]);
        c.record(5, o);
        assert_eq!(ids(&c), [5, 7]);
        assert!(c.holds(7) && !c.holds(9));
        c.record(9, o);
        assert_eq!(ids(&c), [9, 5]);
    }

    #[test]
    fn keep_used_drops_the_others_in_order() {
        let mut c = Occluders::default();
        c.record(1, PrimitiveKind::Opaque);
        c.record(2, PrimitiveKind::Opaque);
        c.keep_used(&[false, true]);
        assert_eq!(ids(&c), [1]);
        c.keep_used(&[false, false]);
        assert!(c.is_empty());
    }

    #[test]
    fn failures_wait_longer_each_time_until_one_pays() {
        let mut c = Occluders::default();
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
