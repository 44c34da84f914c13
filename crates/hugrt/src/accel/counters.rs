//! Per-query counters of the papers' cost model (EG95 §3, SCG97 §3): ray–primitive tests
//! (#pit), successful ones (#pi), ray–box tests (#bbi) and cells visited (#vt), kept per
//! hierarchy level. Structures call them unconditionally; with [`NoCounters`] every call is
//! an empty inline function, so the fast path pays nothing.

use serde::Serialize;

/// Levels counted separately (an octree's 16 below its root); deeper ones are added to the last.
pub const MAX_LEVELS: usize = 17;

pub trait Counters {
    fn prim_test(&mut self, level: usize);
    fn prim_hit(&mut self, level: usize);
    fn box_test(&mut self, level: usize);
    fn cell_visit(&mut self, level: usize);
}

/// Counting switched off.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoCounters;

impl Counters for NoCounters {
    #[inline(always)]
    fn prim_test(&mut self, _: usize) {}
    #[inline(always)]
    fn prim_hit(&mut self, _: usize) {}
    #[inline(always)]
    fn box_test(&mut self, _: usize) {}
    #[inline(always)]
    fn cell_visit(&mut self, _: usize) {}
}

/// The four counts of one hierarchy level.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct LevelCounts {
    pub pit: u64,
    pub pi: u64,
    pub bbi: u64,
    pub vt: u64,
}

/// Counting switched on: totals per level, summable across threads.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayCounters {
    pub levels: [LevelCounts; MAX_LEVELS],
}

impl RayCounters {
    pub fn total(&self) -> LevelCounts {
        self.levels
            .iter()
            .fold(LevelCounts::default(), |a, l| LevelCounts {
                pit: a.pit + l.pit,
                pi: a.pi + l.pi,
                bbi: a.bbi + l.bbi,
                vt: a.vt + l.vt,
            })
    }

    pub fn add(&mut self, o: &RayCounters) {
        for (a, b) in self.levels.iter_mut().zip(&o.levels) {
            a.pit += b.pit;
            a.pi += b.pi;
            a.bbi += b.bbi;
            a.vt += b.vt;
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

    #[inline]
    fn level(&mut self, level: usize) -> &mut LevelCounts {
        &mut self.levels[level.min(MAX_LEVELS - 1)]
    }
}

impl Counters for RayCounters {
    #[inline]
    fn prim_test(&mut self, l: usize) {
        self.level(l).pit += 1;
    }
    #[inline]
    fn prim_hit(&mut self, l: usize) {
        self.level(l).pi += 1;
    }
    #[inline]
    fn box_test(&mut self, l: usize) {
        self.level(l).bbi += 1;
    }
    #[inline]
    fn cell_visit(&mut self, l: usize) {
        self.level(l).vt += 1;
    }
}
