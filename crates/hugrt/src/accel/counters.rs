//! Per-query counters of the papers' cost model (EG95 §3, SCG97 §3), kept per hierarchy
//! level: ray–primitive tests (#pit), successful ones (#pi), ray–box tests (#bbi) and cells
//! visited (#vt).
//!
//! Every counter is one line of [`registry!`] below (its key in JSON and CSV, its column in
//! tables, what it counts) and one call where it is counted, `counters.count(PIT, level)`;
//! [`RayCounters`], [`LevelCounts`], `bench`'s per-ray figures, the tables of `hugrt stats`,
//! `trace --counters` and `bench`, and the JSON and CSV all iterate [`COUNTERS`], so nothing
//! else is written for a new one. The registry is one list rather than declarations spread
//! over the modules because the counts live in a fixed array per level, so that counting stays
//! one addition at a constant index; structures call the counters unconditionally, and with
//! [`NoCounters`] every call is an empty inline function, so the fast path pays nothing.

use serde::Serialize;

/// Levels counted separately (an octree's 16 below its root); deeper ones are added to the last.
pub const MAX_LEVELS: usize = 17;

/// A counter: an index into [`COUNTERS`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Counter(usize);

/// What a counter is called and counts.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct CounterInfo {
    /// Its key in JSON and its CSV column's stem (`pit`, `pit_per_ray`).
    pub key: &'static str,
    /// Its column in tables (`#pit`).
    pub column: &'static str,
    /// What it counts.
    pub help: &'static str,
}

impl Counter {
    pub fn info(self) -> &'static CounterInfo {
        &COUNTERS[self.0]
    }
}

/// Declares the counters: a constant [`Counter`] each, and [`COUNTERS`] in the same order.
macro_rules! registry {
    ($($id:ident: $key:literal, $column:literal, $help:literal;)*) => {
        #[allow(non_camel_case_types, clippy::upper_case_acronyms)]
        enum Slot { $($id),* }
        $(#[doc = $help] pub const $id: Counter = Counter(Slot::$id as usize);)*
        /// Every counter, in the order tables and files list them.
        pub const COUNTERS: &[CounterInfo] = &[$(CounterInfo { key: $key, column: $column, help: $help }),*];
        /// The number of counters.
        pub const COUNTER_COUNT: usize = [$($key),*].len();
    };
}

registry! {
    PIT: "pit", "#pit", "ray-primitive tests";
    PI: "pi", "#pi", "ray-primitive tests that hit";
    BBI: "bbi", "#bbi", "ray-box tests";
    VT: "vt", "#vt", "cells and nodes visited";
}

/// Something that counts; [`Counters::count`] is the one method a counter needs.
pub trait Counters {
    fn count(&mut self, counter: Counter, level: usize);

    #[inline(always)]
    fn prim_test(&mut self, level: usize) {
        self.count(PIT, level);
    }
    #[inline(always)]
    fn prim_hit(&mut self, level: usize) {
        self.count(PI, level);
    }
    #[inline(always)]
    fn box_test(&mut self, level: usize) {
        self.count(BBI, level);
    }
    #[inline(always)]
    fn cell_visit(&mut self, level: usize) {
        self.count(VT, level);
    }
}

/// Counting switched off.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoCounters;

impl Counters for NoCounters {
    #[inline(always)]
    fn count(&mut self, _: Counter, _: usize) {}
}

/// A value per counter, indexed by [`Counter`]; serialised as an object with a member per
/// counter's key (`{"pit": .., "pi": .., ...}`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Counts<T>(pub [T; COUNTER_COUNT]);

impl<T: Default + Copy> Default for Counts<T> {
    fn default() -> Self {
        Counts([T::default(); COUNTER_COUNT])
    }
}

impl<T> std::ops::Index<Counter> for Counts<T> {
    type Output = T;
    fn index(&self, c: Counter) -> &T {
        &self.0[c.0]
    }
}

impl<T> std::ops::IndexMut<Counter> for Counts<T> {
    fn index_mut(&mut self, c: Counter) -> &mut T {
        &mut self.0[c.0]
    }
}

impl<T: Copy + std::ops::AddAssign> Counts<T> {
    pub fn add(&mut self, o: &Counts<T>) {
        for (a, b) in self.0.iter_mut().zip(&o.0) {
            *a += *b;
        }
    }
}

impl<T> Counts<T> {
    /// `(counter, value)` in [`COUNTERS`]' order.
    pub fn iter(&self) -> impl Iterator<Item = (&'static CounterInfo, &T)> {
        COUNTERS.iter().zip(&self.0)
    }
}

impl Counts<u64> {
    /// Each count over `rays` (at least 1).
    pub fn per_ray(&self, rays: u64) -> Counts<f64> {
        let r = rays.max(1) as f64;
        Counts(self.0.map(|c| c as f64 / r))
    }
}

impl<T: Serialize> Serialize for Counts<T> {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_map(self.iter().map(|(c, v)| (c.key, v)))
    }
}

/// The counts of one hierarchy level.
pub type LevelCounts = Counts<u64>;

/// Counting switched on: totals per level, summable across threads.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayCounters {
    pub levels: [Counts<u64>; MAX_LEVELS],
}

impl Eq for Counts<u64> {}

impl RayCounters {
    pub fn total(&self) -> LevelCounts {
        let mut t = LevelCounts::default();
        for l in &self.levels {
            t.add(l);
        }
        t
    }

    pub fn add(&mut self, o: &RayCounters) {
        for (a, b) in self.levels.iter_mut().zip(&o.levels) {
            a.add(b);
        }
    }

    /// Levels up to the deepest one that saw any work.
    pub fn used_levels(&self) -> &[LevelCounts] {
        let n = self
            .levels
            .iter()
            .rposition(|l| *l != LevelCounts::default())
            .map_or(0, |i| i + 1);
        &self.levels[..n]
    }
}

impl Counters for RayCounters {
    #[inline]
    fn count(&mut self, c: Counter, level: usize) {
        self.levels[level.min(MAX_LEVELS - 1)][c] += 1;
    }
}
