//! Mailboxing (Amanatides & Woo 1987; EG95 §2.3.2): a primitive referenced by several cells
//! is tested once per ray.
//!
//! The classic mailbox stores a ray id in every primitive, which a structure shared by threads
//! cannot do without per-thread copies of `4·n` bytes. hugrt keeps instead a small
//! direct-mapped table per query, on the stack: a slot remembers the last id hashed to it.
//! A collision only evicts an id, so a primitive may occasionally be tested twice but is never
//! skipped wrongly; the closest hit found so far is kept across cells, so skipping a retest
//! loses nothing. Sub-grids of a hierarchy use the same table with their own id space.

const SLOTS: usize = 32;

pub struct Mailbox {
    slots: [u32; SLOTS],
}

impl Default for Mailbox {
    fn default() -> Self {
        Mailbox {
            slots: [u32::MAX; SLOTS],
        }
    }
}

impl Mailbox {
    /// Records `id`; returns `false` when it was already recorded (test it no more).
    #[inline(always)]
    pub fn first_visit(&mut self, id: u32) -> bool {
        let slot = (id.wrapping_mul(0x9E37_79B1) >> (32 - SLOTS.trailing_zeros())) as usize;
        if self.slots[slot] == id {
            false
        } else {
            self.slots[slot] = id;
            true
        }
    }
}
