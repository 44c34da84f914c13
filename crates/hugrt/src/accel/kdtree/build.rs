//! The build: the SAH's sweep over sorted events (or the mid-point split) down to the
//! leaves, under the depth limit and the reference budget, and the tree flattened into
//! logical nodes for a layout.

use super::layout::Logical;
use super::{KdTree, RADIX_EVENTS, SplitRule};
use crate::accel::sort::radix_sort_keys;
use crate::geometry::Aabb;
use std::sync::atomic::{AtomicUsize, Ordering};

pub(super) enum BuildNode {
    Leaf(Vec<u32>),
    Inner {
        axis: usize,
        split: f32,
        children: Box<[BuildNode; 2]>,
    },
}

pub(super) struct Builder<'a> {
    pub(super) boxes: &'a [Aabb],
    pub(super) rule: SplitRule,
    pub(super) leaf_size: usize,
    pub(super) max_depth: usize,
    /// Eq. 3's `T_P + T_T`, in units of one object test.
    pub(super) traversal_cost: f32,
    /// Its `T_T` part, which eq. 7 weighs by each child's probability.
    pub(super) step_cost: f32,
    /// hugrt's factor on the object terms of a plane that leaves a side empty (1: eq. 3).
    pub(super) empty_bonus: f32,
    /// Havran's cutting off empty space (§4.2.2, eq. 7–8).
    pub(super) cut: bool,
    /// References still allowed beyond one per primitive.
    pub(super) budget: AtomicUsize,
}

/// A plane and which side gets the primitives lying in it.
struct Plane {
    axis: usize,
    pos: f32,
    planar_left: bool,
    cost: f32,
}

/// Event kinds in sweep order at one position: ends, planars, starts.
const END: u8 = 0;
const PLANAR: u8 = 1;
const START: u8 = 2;

/// The bits of `x` as an integer in the order of the floats (negative ones flipped).
fn monotonic(x: f32) -> u32 {
    let b = x.to_bits();
    if b >> 31 != 0 { !b } else { b | 1 << 31 }
}

fn from_monotonic(m: u32) -> f32 {
    f32::from_bits(if m >> 31 != 0 { m & !(1 << 31) } else { !m })
}

fn clip(b: &Aabb, node: &Aabb, axis: usize) -> (f32, f32) {
    (
        b.min[axis].max(node.min[axis]),
        b.max[axis].min(node.max[axis]),
    )
}

impl Builder<'_> {
    pub(super) fn build(&self, items: Vec<u32>, node: Aabb, depth: usize) -> BuildNode {
        let n = items.len();
        // One primitive is a leaf, unless cutting off empty space may pay (`cut`).
        let single_cut = n == 1 && self.cut && self.rule == SplitRule::Sah;
        if (n <= 1 && !single_cut) || depth >= self.max_depth {
            return BuildNode::Leaf(items);
        }
        let plane = match self.rule {
            SplitRule::Sah => self.sah(&items, &node),
            SplitRule::Mid => {
                if n <= self.leaf_size {
                    return BuildNode::Leaf(items);
                }
                let axis = depth % 3;
                Some(Plane {
                    axis,
                    pos: 0.5 * (node.min[axis] + node.max[axis]),
                    planar_left: true,
                    cost: 0.0,
                })
            }
        };
        let Some(p) = plane else {
            return BuildNode::Leaf(items);
        };
        if self.rule == SplitRule::Sah && p.cost >= n as f32 {
            return BuildNode::Leaf(items);
        }
        let (mut left, mut right) = (Vec::new(), Vec::new());
        for &i in &items {
            let (lo, hi) = clip(&self.boxes[i as usize], &node, p.axis);
            if lo == p.pos && hi == p.pos {
                if p.planar_left {
                    left.push(i)
                } else {
                    right.push(i)
                }
            } else {
                if lo < p.pos {
                    left.push(i);
                }
                if hi > p.pos {
                    right.push(i);
                }
            }
        }
        // Nothing gained when every primitive lands on both sides; and the reference budget
        // bounds memory whatever the scene.
        let added = (left.len() + right.len()).saturating_sub(n);
        if (left.len() == n && right.len() == n)
            || self
                .budget
                .fetch_update(Ordering::Relaxed, Ordering::Relaxed, |b| {
                    b.checked_sub(added)
                })
                .is_err()
        {
            return BuildNode::Leaf(items);
        }
        drop(items);
        let (mut below, mut above) = (node, node);
        below.max[p.axis] = p.pos;
        above.min[p.axis] = p.pos;
        let (l, r) = if n > 4096 {
            rayon::join(
                || self.build(left, below, depth + 1),
                || self.build(right, above, depth + 1),
            )
        } else {
            (
                self.build(left, below, depth + 1),
                self.build(right, above, depth + 1),
            )
        };
        BuildNode::Inner {
            axis: p.axis,
            split: p.pos,
            children: Box::new([l, r]),
        }
    }

    /// The cheapest plane over the key positions of all three axes (see the module doc).
    fn sah(&self, items: &[u32], node: &Aabb) -> Option<Plane> {
        let area = node.surface_area();
        if area.is_nan() || area <= 0.0 {
            return None;
        }
        let n = items.len();
        let e = node.extent();
        let mut best: Option<Plane> = None;
        // Events as integer keys: the position's bits made monotonic, then the kind, so that
        // one integer sort orders them by position and, at one position, ends before planars
        // before starts.
        // (`+ 0.0` makes −0 the same position as +0.)
        let key = |pos: f32, kind: u8| (monotonic(pos + 0.0) as u64) << 2 | kind as u64;
        let mut events: Vec<u64> = Vec::with_capacity(2 * n);
        for axis in 0..3 {
            if e[axis].is_nan() || e[axis] <= 0.0 {
                continue;
            }
            events.clear();
            for &i in items {
                let (lo, hi) = clip(&self.boxes[i as usize], node, axis);
                if lo == hi {
                    events.push(key(lo, PLANAR));
                } else {
                    events.push(key(lo, START));
                    events.push(key(hi, END));
                }
            }
            // Large nodes sort in linear time, which makes the build `O(n log n)`.
            if events.len() >= RADIX_EVENTS {
                radix_sort_keys(&mut events, 34);
            } else {
                events.sort_unstable();
            }
            let (a1, a2) = ((axis + 1) % 3, (axis + 2) % 3);
            let cap = e[a1] * e[a2];
            let ring = e[a1] + e[a2];
            let (mut nl, mut nr) = (0usize, n);
            let mut k = 0;
            while k < events.len() {
                let bits = events[k] >> 2;
                let pos = from_monotonic(bits as u32);
                let mut count = [0usize; 3];
                while k < events.len() && events[k] >> 2 == bits {
                    count[(events[k] & 3) as usize] += 1;
                    k += 1;
                }
                let [ends, planars, starts] = [
                    count[END as usize],
                    count[PLANAR as usize],
                    count[START as usize],
                ];
                nr -= ends + planars;
                if pos > node.min[axis] && pos < node.max[axis] {
                    let below = pos - node.min[axis];
                    let above = node.max[axis] - pos;
                    let sl = 2.0 * (cap + below * ring);
                    let sr = 2.0 * (cap + above * ring);
                    for planar_left in [true, false] {
                        let (l, r) = if planar_left {
                            (nl + planars, nr)
                        } else {
                            (nl, nr + planars)
                        };
                        let objects = (sl * l as f32 + sr * r as f32) / area;
                        let empty = l == 0 || r == 0;
                        let cost = if empty && self.cut {
                            // Eq. 7: the step into each child weighed by its probability.
                            self.traversal_cost - self.step_cost
                                + (sl + sr) / area * self.step_cost
                                + objects
                        } else if empty {
                            self.traversal_cost + self.empty_bonus * objects
                        } else {
                            self.traversal_cost + objects
                        };
                        if best.as_ref().is_none_or(|b| cost < b.cost) {
                            best = Some(Plane {
                                axis,
                                pos,
                                planar_left,
                                cost,
                            });
                        }
                    }
                }
                nl += starts + planars;
            }
        }
        best
    }
}

impl KdTree {
    /// The build's tree as logical nodes (index 0 the root); leaves' references appended.
    pub(super) fn flatten(
        &mut self,
        node: BuildNode,
        cell: Aabb,
        depth: usize,
        out: &mut Vec<Logical>,
    ) -> usize {
        let id = out.len();
        match node {
            BuildNode::Leaf(mut items) => {
                items.sort_unstable();
                out.push(Logical::Leaf {
                    start: self.refs.len() as u32,
                    count: items.len() as u32,
                });
                self.stats.leaves += 1;
                self.stats.max_depth = self.stats.max_depth.max(depth);
                self.stats.depth_sum += depth;
                if items.is_empty() {
                    self.stats.empty_leaves += 1;
                } else {
                    self.stats.full_volume += cell.volume() as f64;
                }
                self.refs.extend(items);
            }
            BuildNode::Inner {
                axis,
                split,
                children,
            } => {
                out.push(Logical::Leaf { start: 0, count: 0 });
                let [below, above] = *children;
                let (mut lo, mut hi) = (cell, cell);
                lo.max[axis] = split;
                hi.min[axis] = split;
                let b = self.flatten(below, lo, depth + 1, out);
                let a = self.flatten(above, hi, depth + 1, out);
                out[id] = Logical::Inner {
                    axis: axis as u32,
                    split,
                    below: b,
                    above: a,
                };
            }
        }
        id
    }
}

#[cfg(test)]
mod tests {
    use super::{from_monotonic, monotonic};

    #[test]
    fn monotonic_keys_order_floats_and_come_back() {
        let xs = [-1e30f32, -2.5, -1.0, -1e-30, 0.0, 1e-30, 1.0, 2.5, 1e30];
        for w in xs.windows(2) {
            assert!(monotonic(w[0]) < monotonic(w[1]), "{} < {}", w[0], w[1]);
        }
        for x in xs {
            assert_eq!(from_monotonic(monotonic(x)), x);
        }
        assert_eq!(monotonic(-0.0 + 0.0), monotonic(0.0));
    }
}
