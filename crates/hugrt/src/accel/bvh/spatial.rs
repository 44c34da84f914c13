//! Spatial splits (Stich, Friedrich and Dietrich, "Spatial Splits in Bounding Volume
//! Hierarchies", HPG 2009): where the two boxes of the best object split overlap, a node may
//! instead cut space at a plane and send a triangle that straddles it to both sides, each
//! side's reference boxed by the part of the triangle on that side. The SAH chooses between
//! the two kinds of split; the references this adds are bounded by a budget.
//!
//! Choices where the paper leaves room: spatial splits are tried where the object split's
//! children overlap by more than `1e-5` of the root's area (the paper's α) or where the
//! centres do not spread at all; the budget of extra references (`spatial` × n) is shared
//! between the children of a split in proportion to their references, so the build is the
//! same on any number of threads; no reference unsplitting. Spheres, cones and other
//! primitives are never cut: their piece is their box cut by the plane.

use super::MEDIAN_DEPTH;
use super::build::{Bounds, BuildNode, Builder, Item, PARALLEL_ITEMS, blocks, extents};
use super::build::{cheapest_plane, median, partition};
use crate::geometry::{Aabb, Vec3};

/// Overlap of the object split's children, as a fraction of the root's surface area, above
/// which spatial splits are tried (Stich et al.'s α).
const ALPHA: f32 = 1e-5;

/// What the spatial build needs beside the items: the triangles (store entries below
/// `tris.len()`), the margin every reference box is widened by, and the root's area.
pub(super) struct SpatialContext<'a> {
    pub tris: &'a [[Vec3; 3]],
    pub margin: f32,
    pub root_area: f32,
}

impl Builder {
    /// Builds the subtree of `items` with spatial splits allowed for up to `budget` extra
    /// references. Returns the subtree and its leaves' items, leaf after leaf (the leaves'
    /// `start`s index that list).
    pub(super) fn build_spatial(
        &self,
        ctx: &SpatialContext,
        mut items: Vec<Item>,
        depth: usize,
        budget: usize,
    ) -> (BuildNode, Vec<Item>) {
        let (bounds, centres) = extents(&items);
        let n = items.len();
        let leaf = |mut items: Vec<Item>| {
            items.sort_unstable_by_key(Item::slot);
            (BuildNode::leaf(&items, bounds, 0), items)
        };
        if n <= 1 || n <= self.leaf_size && blocks(n as u32) <= self.traversal_cost {
            return leaf(items);
        }
        let object = if depth < MEDIAN_DEPTH {
            self.sah_split(&items, &bounds, &centres)
        } else {
            None
        };
        let try_spatial = budget > 0
            && depth < MEDIAN_DEPTH
            && match object {
                Some((_, axis, position)) => {
                    overlap(&items, axis, position) > ALPHA * ctx.root_area
                }
                None => true,
            };
        let spatial = if try_spatial {
            self.spatial_split(ctx, &items, &bounds)
        } else {
            None
        };
        let spatial_wins = spatial.is_some_and(|s| object.is_none_or(|o| s.0 < o.0));
        let leaf_cost = blocks(n as u32);
        // The spatial split when it is the cheaper, keeps to the budget and makes progress.
        let mut sides = None;
        if let Some((cost, axis, position)) = spatial.filter(|_| spatial_wins)
            && !(n <= self.leaf_size && cost >= leaf_cost)
        {
            let (left, right) = chop(ctx, &items, axis, position);
            let extra = (left.len() + right.len()).saturating_sub(n);
            if extra <= budget
                && !left.is_empty()
                && !right.is_empty()
                && left.len() < n
                && right.len() < n
            {
                let rest = budget - extra;
                let left_budget = rest * left.len() / (left.len() + right.len());
                sides = Some((left, right, left_budget, rest - left_budget));
            }
        }
        // Otherwise the object split, when it beats the leaf.
        if sides.is_none()
            && n <= self.leaf_size
            && object.is_none_or(|(cost, _, _)| cost >= leaf_cost)
        {
            return leaf(items);
        }
        let (left, right, left_budget, right_budget) = sides.unwrap_or_else(|| {
            let mid = match object
                .and_then(|(_, axis, position)| partition(&mut items, axis, position))
            {
                Some((mid, _, _)) => mid,
                None => median(&mut items, &centres),
            };
            let right = items.split_off(mid);
            let left_budget = budget * mid / n;
            (items, right, left_budget, budget - left_budget)
        });
        let ((l, mut l_items), (mut r, r_items)) = if n > PARALLEL_ITEMS {
            rayon::join(
                || self.build_spatial(ctx, left, depth + 1, left_budget),
                || self.build_spatial(ctx, right, depth + 1, right_budget),
            )
        } else {
            (
                self.build_spatial(ctx, left, depth + 1, left_budget),
                self.build_spatial(ctx, right, depth + 1, right_budget),
            )
        };
        shift(&mut r, l_items.len());
        l_items.extend(r_items);
        let node = BuildNode::inner(bounds, l, r);
        (node, l_items)
    }

    /// The best spatial split by binning the references' pieces over the node's box: its
    /// cost (as [`Builder::sah_split`] counts), axis and plane.
    fn spatial_split(
        &self,
        ctx: &SpatialContext,
        items: &[Item],
        bounds: &Aabb,
    ) -> Option<(f32, usize, f32)> {
        let area = bounds.surface_area();
        if area.is_nan() || area <= 0.0 {
            return None;
        }
        let nb = self.bins;
        let mut best: Option<(f32, usize, f32)> = None;
        for axis in 0..3 {
            let (lo, hi) = (bounds.min[axis], bounds.max[axis]);
            let width = (hi - lo) / nb as f32;
            if width.is_nan() || width <= 0.0 {
                continue;
            }
            let bin = |x: f32| (((x - lo) / width) as usize).min(nb - 1);
            let plane = |b: usize| lo + b as f32 * width;
            let mut boxes = vec![Bounds::EMPTY; nb];
            let mut entries = vec![0u32; nb];
            let mut exits = vec![0u32; nb];
            for it in items {
                let (first, last) = (bin(it.lo[axis]), bin(it.hi[axis]));
                entries[first] += 1;
                exits[last] += 1;
                if first == last {
                    boxes[first] = boxes[first].union(&it.bounds());
                    continue;
                }
                for (b, bin_box) in boxes.iter_mut().enumerate().take(last + 1).skip(first) {
                    let lo = if b == first {
                        f32::NEG_INFINITY
                    } else {
                        plane(b)
                    };
                    let hi = if b == last {
                        f32::INFINITY
                    } else {
                        plane(b + 1)
                    };
                    *bin_box = bin_box.union(&Bounds::from_aabb(&piece(ctx, it, axis, lo, hi)));
                }
            }
            if let Some((cost, b)) = cheapest_plane(&boxes, &entries, &exits)
                && best.is_none_or(|(c, _, _)| cost < c)
            {
                best = Some((cost, axis, plane(b)));
            }
        }
        best.map(|(cost, axis, position)| (self.traversal_cost + cost / area, axis, position))
    }
}

/// Surface area of the overlap of the two boxes an object split at `position` makes.
fn overlap(items: &[Item], axis: usize, position: f32) -> f32 {
    let (mut left, mut right) = (Bounds::EMPTY, Bounds::EMPTY);
    for it in items {
        if it.centre()[axis] < position {
            left = left.union(&it.bounds());
        } else {
            right = right.union(&it.bounds());
        }
    }
    let both = Bounds {
        lo: left.lo.max(right.lo),
        hi: left.hi.min(right.hi),
    };
    if both.is_empty() {
        0.0
    } else {
        both.surface_area()
    }
}

/// The references of each side of the plane `position` on `axis`: a reference wholly on
/// one side goes there; one that straddles the plane goes to each side its piece reaches.
fn chop(
    ctx: &SpatialContext,
    items: &[Item],
    axis: usize,
    position: f32,
) -> (Vec<Item>, Vec<Item>) {
    let (mut left, mut right) = (Vec::new(), Vec::new());
    for it in items {
        if it.hi[axis] <= position {
            left.push(*it);
        } else if it.lo[axis] >= position {
            right.push(*it);
        } else {
            for (side, lo, hi) in [
                (&mut left, f32::NEG_INFINITY, position),
                (&mut right, position, f32::INFINITY),
            ] {
                let b = piece(ctx, it, axis, lo, hi);
                if !b.is_empty() {
                    side.push(Item::new(it.slot(), &b));
                }
            }
        }
    }
    (left, right)
}

/// The box of the part of reference `it` between `lo` and `hi` on `axis`: for a triangle,
/// the box of the triangle cut to that slab, widened by the margin (which covers the
/// rounding of the cut points) and kept inside the reference's own box; for other
/// primitives, the reference's box cut to the slab widened by the margin. Empty when the
/// part is.
fn piece(ctx: &SpatialContext, it: &Item, axis: usize, lo: f32, hi: f32) -> Aabb {
    let own = it.aabb();
    let cut = match ctx.tris.get(it.slot() as usize) {
        Some(t) => slab_box(t, axis, lo, hi),
        None => {
            let mut b = own;
            b.min[axis] = b.min[axis].max(lo);
            b.max[axis] = b.max[axis].min(hi);
            b
        }
    };
    if cut.is_empty() {
        return Aabb::EMPTY;
    }
    let cut = cut.expand(ctx.margin);
    let b = Aabb::new(cut.min.max(own.min), cut.max.min(own.max));
    if b.is_empty() { Aabb::EMPTY } else { b }
}

/// The box of triangle `t`'s points whose `axis` coordinate lies in `[lo, hi]`: its corners
/// inside the slab and its edges' crossings of the slab's planes.
fn slab_box(t: &[Vec3; 3], axis: usize, lo: f32, hi: f32) -> Aabb {
    let mut b = Aabb::EMPTY;
    for i in 0..3 {
        let (p, q) = (t[i], t[(i + 1) % 3]);
        if lo <= p[axis] && p[axis] <= hi {
            b = b.grow(p);
        }
        for plane in [lo, hi] {
            if plane.is_finite()
                && (p[axis] < plane) != (q[axis] < plane)
                && p[axis] != plane
                && q[axis] != plane
            {
                let s = (plane - p[axis]) / (q[axis] - p[axis]);
                let mut x = p + (q - p) * s;
                x[axis] = plane;
                b = b.grow(x);
            }
        }
    }
    b
}

/// Moves the leaves of `node` by `by` places in their items' list.
fn shift(node: &mut BuildNode, by: usize) {
    match node {
        BuildNode::Leaf { start, .. } => *start += by,
        BuildNode::Inner { children, .. } => {
            for c in children.iter_mut() {
                shift(c, by);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slab_box_cuts_a_triangle() {
        let t = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(4.0, 0.0, 0.0),
            Vec3::new(0.0, 4.0, 0.0),
        ];
        let b = slab_box(&t, 0, 1.0, 2.0);
        assert_eq!(
            b,
            Aabb::new(Vec3::new(1.0, 0.0, 0.0), Vec3::new(2.0, 3.0, 0.0))
        );
        assert!(slab_box(&t, 0, 5.0, 6.0).is_empty());
        assert_eq!(
            slab_box(&t, 1, f32::NEG_INFINITY, f32::INFINITY),
            Aabb::from_points(&t)
        );
    }
}
