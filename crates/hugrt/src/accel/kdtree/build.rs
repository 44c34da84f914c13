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
    /// SAH planes made, and those of them outside the median interval (Havran Table 4).
    pub(super) planes: AtomicUsize,
    pub(super) outside_median: AtomicUsize,
}

/// A plane and which side gets the primitives lying in it.
struct Plane {
    axis: usize,
    pos: f32,
    planar_left: bool,
    cost: f32,
    /// The plane's axis' object median: the first key position where the left side holds at
    /// least as many primitives as the right (Havran §4.2, Fig. 9; primitives the plane cuts
    /// count on both sides).
    object_median: f32,
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
                    object_median: f32::NAN,
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
        if self.rule == SplitRule::Sah {
            // Havran Table 4: is the plane outside the interval between the spatial median
            // and the object median?
            let spatial = 0.5 * (node.min[p.axis] + node.max[p.axis]);
            let (lo, hi) = (spatial.min(p.object_median), spatial.max(p.object_median));
            self.planes.fetch_add(1, Ordering::Relaxed);
            if p.pos < lo || p.pos > hi {
                self.outside_median.fetch_add(1, Ordering::Relaxed);
            }
        }
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
            let mut object_median = f32::NAN;
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
                if object_median.is_nan() && nl + planars >= nr {
                    object_median = pos;
                }
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
                                object_median: f32::NAN,
                            });
                        }
                    }
                }
                nl += starts + planars;
            }
            if let Some(b) = best.as_mut().filter(|b| b.axis == axis) {
                b.object_median = object_median;
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
    use super::{Builder, from_monotonic, monotonic};
    use crate::accel::kdtree::SplitRule;
    use crate::geometry::Aabb;
    use glam::Vec3;
    use rand::{Rng, SeedableRng};
    use std::sync::atomic::AtomicUsize;

    /// Havran Table 4's count, against the root's split found by brute force: every key
    /// position of every axis costed by eq. 3, then compared with the spatial median and the
    /// object median (the first key position where the left holds at least the right's
    /// count). Both outcomes must occur, or the test could not fail.
    #[test]
    fn planes_outside_the_median_interval_are_counted() {
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(7);
        let mut seen = [0usize; 2];
        for _ in 0..300 {
            let n = rng.random_range(3..12);
            let boxes: Vec<Aabb> = (0..n)
                .map(|_| {
                    let lo = Vec3::new(rng.random(), rng.random(), rng.random());
                    let size = Vec3::new(rng.random(), rng.random(), rng.random()) * 0.6;
                    Aabb::new(lo, lo + size)
                })
                .collect();
            let node = boxes.iter().fold(Aabb::EMPTY, |a, b| a.union(b));
            let builder = Builder {
                boxes: &boxes,
                rule: SplitRule::Sah,
                leaf_size: 1,
                max_depth: 1,
                traversal_cost: 0.5,
                step_cost: 0.1,
                empty_bonus: 1.0,
                cut: false,
                budget: AtomicUsize::new(1 << 20),
                planes: AtomicUsize::new(0),
                outside_median: AtomicUsize::new(0),
            };
            builder.build((0..n as u32).collect(), node, 0);
            let area = node.surface_area();
            let mut planes: Vec<(f32, usize, f32)> = Vec::new();
            for axis in 0..3 {
                let mut keys: Vec<f32> = boxes
                    .iter()
                    .flat_map(|b| [b.min[axis], b.max[axis]])
                    .collect();
                keys.sort_by(f32::total_cmp);
                for &pos in &keys {
                    if pos <= node.min[axis] || pos >= node.max[axis] {
                        continue;
                    }
                    let l = boxes.iter().filter(|b| b.min[axis] < pos).count();
                    let r = boxes.iter().filter(|b| b.max[axis] > pos).count();
                    let (mut below, mut above) = (node, node);
                    below.max[axis] = pos;
                    above.min[axis] = pos;
                    let cost = 0.5
                        + (below.surface_area() * l as f32 + above.surface_area() * r as f32)
                            / area;
                    planes.push((pos, axis, cost));
                }
            }
            planes.sort_by(|a, b| a.2.total_cmp(&b.2));
            // Planes of nearly equal cost: which one the sweep keeps is rounding.
            if planes.len() < 2 || planes[1].2 - planes[0].2 < 1e-4 {
                continue;
            }
            let (pos, axis, cost) = planes[0];
            let made = builder.planes.load(std::sync::atomic::Ordering::Relaxed);
            let outside = builder
                .outside_median
                .load(std::sync::atomic::Ordering::Relaxed);
            if cost >= n as f32 || (cost - (n as f32)).abs() < 1e-4 {
                continue;
            }
            assert_eq!(made, 1, "one plane at the root");
            let object_median = {
                let mut keys: Vec<f32> = boxes
                    .iter()
                    .flat_map(|b| [b.min[axis], b.max[axis]])
                    .collect();
                keys.sort_by(f32::total_cmp);
                *keys
                    .iter()
                    .find(|&&p| {
                        boxes.iter().filter(|b| b.min[axis] < p).count()
                            >= boxes.iter().filter(|b| b.max[axis] > p).count()
                    })
                    .unwrap()
            };
            let spatial = 0.5 * (node.min[axis] + node.max[axis]);
            let expect = pos < spatial.min(object_median) || pos > spatial.max(object_median);
            assert_eq!(outside, expect as usize, "plane {pos} on axis {axis}");
            seen[expect as usize] += 1;
        }
        assert!(seen[0] > 10 && seen[1] > 10, "both outcomes: {seen:?}");
    }

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
