//! Queries: what a structure's walk does with the hits it finds.
//!
//! A structure walks its cells or nodes and tests primitives; a [`HitSink`] decides what to
//! keep and how far along the ray the walk must still go. Three sinks make the three queries:
//!
//! * [`Closest`]: the nearest hit; the searched interval shrinks to it as hits are found.
//! * [`AnyHit`]: the first hit found; the walk stops there, and may go from the far end of
//!   the ray's segment back towards its start ([`HitSink::walked_back`]).
//! * [`EveryHit`]: every hit in the ray's `[tmin, tmax]`, each primitive once, handed to a
//!   callback that may stop the walk; the interval never shrinks.
//!
//! The sink is a type parameter of [`super::Accel::query`], so each query is compiled on its
//! own and the closest-hit walk is the walk it was before the other queries existed (the same
//! instructions: `docs/measurements.md`, "queries").
//!
//! Every hit offered is in the ray's `[tmin, tmax()]`, found by the primitive's own test with
//! the ray's `tmin`, so one primitive gives one `t` wherever a structure tests it: a primitive
//! referenced by several cells or leaves, and tested again there, offers the same hit again,
//! which [`EveryHit`] drops.

use crate::geometry::{Aabb, Ray};
use std::collections::HashSet;
use std::ops::ControlFlow;

/// Whether `ray`'s segment ends outside `bounds` (or has no end): where an occlusion query is
/// walked from the far end of its segment ([`HitSink::walked_back`]).
///
/// A shadow ray leaves a surface through the cells or nodes around its origin, whose
/// triangles it tests and misses, while what blocks it lies farther on: on the meshes, the
/// part of the surface facing a light outside them; in a closed room, the wall between it and
/// a light outside. Where the segment ends inside the scene (a light in the room), the
/// blockers are the furniture near the surfaces, and the walk from the start finds them
/// sooner. Only a matter of speed: every structure tests the same primitives for a ray either
/// way, and an occlusion query's answer does not depend on their order (docs/measurements.md,
/// "Occlusion walked from the far end").
#[inline(always)]
pub(crate) fn ends_outside(ray: &Ray, bounds: &Aabb) -> bool {
    let end = ray.origin + ray.dir * ray.tmax;
    // A NaN or infinite end (no end) is outside.
    !(end.cmpge(bounds.min).all() && end.cmple(bounds.max).all())
}

/// Where an occlusion query ([`super::Accel::any_hit`], [`super::Accel::any_hits`]) walks a
/// ray's segment from: every structure's `occlusion` key. A matter of speed and of the
/// counters: whether a ray is blocked is the same either way, though which blocker an
/// occlusion query reports may differ.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Occlusion {
    /// hugrt's: from the far end of the segment where it ends outside the scene (a light
    /// outside it, or no end) and, in a batch, while blocked rays are not rare; else from the
    /// start (docs/measurements.md, "Occlusion walked from the far end").
    #[default]
    Auto,
    /// From the ray's start, as the papers walk every ray (EG95 §2.3.2 "visit the next voxel
    /// along the ray path", which SCG97 §1.3 builds on; Havran §4.2.2, Sung and Shirley's
    /// walk): their presets' order, so that the counters (tests and cells a ray) are counted
    /// as theirs were.
    Start,
}

crate::accel::settings::choice_value!(Occlusion { Occlusion::Auto => "auto", Occlusion::Start => "start" });

/// The `occlusion` key's help, the same for every structure.
pub(crate) const OCCLUSION_HELP: &str = "where an occlusion (any-hit) query walks a ray from: auto (hugrt's) from the far end of a segment that ends outside the scene, start from its origin (the papers)";

/// A hit: parameter `t` along the ray and the primitive's index.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f32,
    pub prim: u32,
}

impl Hit {
    /// Whether a hit of `prim` at `t` should replace `best`: the nearer one, and of two at the
    /// same `t` the lower index, so that every structure reports the same primitive (and
    /// renders the same image) whatever order it tests candidates in. [`Closest`] keeps the
    /// same rule.
    #[inline]
    pub fn improves(best: &Option<Hit>, t: f32, prim: u32) -> bool {
        match best {
            None => true,
            Some(b) => t < b.t || (t == b.t && prim < b.prim),
        }
    }

    /// The order of [`super::Accel::all_hits`]: by `t`, then by index.
    pub fn order(a: &Hit, b: &Hit) -> std::cmp::Ordering {
        a.t.total_cmp(&b.t).then(a.prim.cmp(&b.prim))
    }
}

/// What a query keeps of the hits a structure's walk finds.
pub trait HitSink {
    /// Whether the first hit offered ends the walk (occlusion): the order in which the walk
    /// visits cells and nodes then does not change the answer, only how soon it is found.
    const FIRST_ENDS: bool = false;

    /// Whether the walk goes from the far end of the ray's segment back towards its start
    /// ([`HitSink::walked_back`]).
    #[inline(always)]
    fn walks_back(&self) -> bool {
        false
    }

    /// This sink, walked from the far end of the ray's segment back towards its start where
    /// `far` and the first hit ends the walk ([`HitSink::FIRST_ENDS`]): what blocks a shadow
    /// ray from a surface to a light outside the scene lies away from its origin, past the
    /// triangles around the origin that it tests and misses. The answer is the same either
    /// way; which primitive an occlusion query reports may differ. Other sinks ignore it.
    #[inline(always)]
    fn walked_back(self, far: bool) -> Self
    where
        Self: Sized,
    {
        let _ = far;
        self
    }

    /// The far end of the part of the ray still worth searching: hits beyond it change
    /// nothing, and cells or nodes that begin beyond it need not be visited.
    fn tmax(&self) -> f32;

    /// Offers a hit at `t`, which lies in the ray's `[tmin, tmax()]`, of the primitive whose
    /// index `prim` gives (asked only when the sink needs it: a structure may have to look it
    /// up). Returns `true` when the walk should stop.
    fn offer(&mut self, t: f32, prim: impl FnOnce() -> u32) -> bool;
}

/// The nearest hit, ties to the lower index as [`Hit::improves`] has it.
#[derive(Clone, Copy, Debug)]
pub struct Closest {
    t: f32,
    /// `u32::MAX` while nothing is hit, so that "nothing nearer than `t`" is one comparison
    /// whether or not anything was.
    prim: u32,
}

impl Closest {
    #[inline]
    pub fn new(tmax: f32) -> Self {
        Closest {
            t: tmax,
            prim: u32::MAX,
        }
    }

    #[inline]
    pub fn hit(&self) -> Option<Hit> {
        (self.prim != u32::MAX).then_some(Hit {
            t: self.t,
            prim: self.prim,
        })
    }
}

impl HitSink for Closest {
    #[inline(always)]
    fn tmax(&self) -> f32 {
        self.t
    }

    #[inline(always)]
    fn offer(&mut self, t: f32, prim: impl FnOnce() -> u32) -> bool {
        if t < self.t || self.prim == u32::MAX {
            self.t = t;
            self.prim = prim();
        } else if t == self.t {
            self.prim = self.prim.min(prim());
        }
        false
    }
}

/// Some hit, the first one found: occlusion.
#[derive(Clone, Copy, Debug)]
pub struct AnyHit {
    tmax: f32,
    hit: Option<Hit>,
    /// Whether the walk goes from the far end ([`HitSink::walked_back`]).
    far: bool,
}

impl AnyHit {
    /// A ray's occlusion query, walked from the ray's start.
    #[inline]
    pub fn new(tmax: f32) -> Self {
        AnyHit {
            tmax,
            hit: None,
            far: false,
        }
    }

    #[inline]
    pub fn hit(&self) -> Option<Hit> {
        self.hit
    }
}

impl HitSink for AnyHit {
    const FIRST_ENDS: bool = true;

    #[inline(always)]
    fn walks_back(&self) -> bool {
        self.far
    }

    #[inline(always)]
    fn walked_back(self, far: bool) -> Self {
        AnyHit { far, ..self }
    }

    #[inline(always)]
    fn tmax(&self) -> f32 {
        self.tmax
    }

    #[inline(always)]
    fn offer(&mut self, t: f32, prim: impl FnOnce() -> u32) -> bool {
        self.hit = Some(Hit { t, prim: prim() });
        true
    }
}

/// Every hit in the ray's `[tmin, tmax]`, each primitive once, handed to `f` in the order the
/// walk finds them (roughly by `t`, not exactly: cells and leaves are visited front to back,
/// the primitives within one in any order). `f` returns [`ControlFlow::Break`] to stop the
/// walk.
pub struct EveryHit<F> {
    tmax: f32,
    seen: Seen,
    f: F,
}

impl<F: FnMut(Hit) -> ControlFlow<()>> EveryHit<F> {
    pub fn new(tmax: f32, f: F) -> Self {
        EveryHit {
            tmax,
            seen: Seen::default(),
            f,
        }
    }
}

impl<F: FnMut(Hit) -> ControlFlow<()>> HitSink for EveryHit<F> {
    #[inline(always)]
    fn tmax(&self) -> f32 {
        self.tmax
    }

    #[inline]
    fn offer(&mut self, t: f32, prim: impl FnOnce() -> u32) -> bool {
        let prim = prim();
        self.seen.insert(prim) && (self.f)(Hit { t, prim }).is_break()
    }
}

/// The primitives already reported along one ray: a short list searched in place while it is
/// short (most rays cross few surfaces), a hash set once it is not.
#[derive(Default)]
struct Seen {
    few: Vec<u32>,
    many: Option<HashSet<u32>>,
}

impl Seen {
    const FEW: usize = 32;

    /// Records `prim`; `false` when it was recorded before.
    fn insert(&mut self, prim: u32) -> bool {
        if let Some(many) = &mut self.many {
            return many.insert(prim);
        }
        if self.few.contains(&prim) {
            return false;
        }
        if self.few.len() < Self::FEW {
            self.few.push(prim);
        } else {
            let mut many: HashSet<u32> = self.few.drain(..).collect();
            many.insert(prim);
            self.many = Some(many);
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closest_keeps_the_nearest_and_ties_to_the_lower_index() {
        let mut c = Closest::new(10.0);
        assert_eq!(c.hit(), None);
        assert!(!c.offer(5.0, || 7));
        assert!(!c.offer(5.0, || 9));
        assert_eq!(c.hit(), Some(Hit { t: 5.0, prim: 7 }));
        c.offer(5.0, || 3);
        assert_eq!(c.hit(), Some(Hit { t: 5.0, prim: 3 }));
        c.offer(2.0, || 8);
        assert_eq!(c.hit(), Some(Hit { t: 2.0, prim: 8 }));
        assert_eq!(c.tmax(), 2.0);
    }

    #[test]
    fn a_hit_at_tmax_is_kept_when_it_is_the_first() {
        let mut c = Closest::new(4.0);
        c.offer(4.0, || 6);
        assert_eq!(c.hit(), Some(Hit { t: 4.0, prim: 6 }));
    }

    #[test]
    fn any_hit_stops_at_the_first() {
        let mut a = AnyHit::new(1.0);
        assert!(a.offer(0.5, || 2));
        assert_eq!(a.hit(), Some(Hit { t: 0.5, prim: 2 }));
    }

    #[test]
    fn every_hit_reports_each_primitive_once_and_can_stop() {
        let mut got = Vec::new();
        let mut e = EveryHit::new(9.0, |h: Hit| {
            got.push(h.prim);
            if h.prim == 1000 {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        });
        // Past the short list, into the hash set, with repeats on both sides of the switch.
        for p in (0..100).chain(0..100) {
            assert!(!e.offer(1.0, || p));
        }
        assert_eq!(e.tmax(), 9.0, "the interval never shrinks");
        assert!(e.offer(2.0, || 1000));
        drop(e);
        assert_eq!(got, (0..100).chain([1000]).collect::<Vec<_>>());
    }
}
