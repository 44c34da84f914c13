//! Mailboxing (Amanatides & Woo 1987; EG95 §2.3.2): a primitive referenced by several cells
//! is tested once per ray, and a sub-grid referenced by several cells is walked once per ray.
//!
//! The classic mailbox stores a ray id in every primitive, which a structure shared by threads
//! cannot do without per-thread copies of `4·n` bytes. hugrt keeps instead a small
//! direct-mapped table per query, on the stack: a slot remembers the last id hashed to it.
//! A collision only evicts an id, so a primitive may occasionally be tested twice (or a grid
//! walked twice) but is never skipped wrongly; the nearest hit found so far is kept across
//! cells and grids, so skipping a repeat loses nothing.
//!
//! Grids are remembered exactly: a lossy table would walk a sub-grid again, and everything
//! below it, each time a later cell references it, which a hierarchy whose grids overlap
//! (EG95 Fig. 9's insertion of a grid into every grid it overlaps) turns into thousands of
//! walks per ray. The first few grids are kept in a small array, more in a heap set.

use std::collections::HashSet;

const SLOTS: usize = 32;
const GRID_SLOTS: usize = 8;

pub struct Mailbox {
    slots: [u32; SLOTS],
    grids: [u32; GRID_SLOTS],
    grid_count: usize,
    more_grids: Option<HashSet<u32>>,
}

impl Default for Mailbox {
    #[inline(always)]
    fn default() -> Self {
        Mailbox {
            slots: [u32::MAX; SLOTS],
            grids: [u32::MAX; GRID_SLOTS],
            grid_count: 0,
            more_grids: None,
        }
    }
}

#[inline(always)]
fn slot(id: u32, slots: usize) -> usize {
    (id.wrapping_mul(0x9E37_79B1) >> (32 - slots.trailing_zeros())) as usize
}

impl Mailbox {
    /// Records primitive `id`; returns `false` when it was already recorded (test it no more).
    #[inline(always)]
    pub fn first_visit(&mut self, id: u32) -> bool {
        let s = &mut self.slots[slot(id, SLOTS)];
        let first = *s != id;
        *s = id;
        first
    }

    /// Records grid `id`; returns `false` when it was already walked.
    #[inline]
    pub fn first_grid_visit(&mut self, id: u32) -> bool {
        if self.grids[..self.grid_count.min(GRID_SLOTS)].contains(&id) {
            return false;
        }
        if self.grid_count < GRID_SLOTS {
            self.grids[self.grid_count] = id;
            self.grid_count += 1;
            return true;
        }
        self.more_grids.get_or_insert_with(HashSet::new).insert(id)
    }
}
