//! The build straight to nodes of four, without the binary tree: each node's binary cuts are
//! decided ([`Builder::decide`]) and opened as [`four`](super::flatten::four) opens a binary
//! tree's nodes, largest area first, so the tree is the one building the binary tree and
//! collapsing it gives. A leaf is a range of the items, which the build leaves in leaf order;
//! a node names it by its number in [`Wide::leaves`], depth first in lane order, which the
//! bvh then replaces by what its leaves hold ([`relabel_leaves`]).
//!
//! The binary tree costs a small allocation a node, about 25 bytes a triangle at the build's
//! peak; built this way, the peak holds only the items and the nodes. Subtrees of many items
//! are built side by side, each into a list of its own that its parent then appends to its
//! own, so a node is copied once per such subtree above it (a handful on 10^8 triangles).

use super::build::{Builder, Extents, Item, PARALLEL_ITEMS, extents};
use super::{LEAF, LEAF_START_BITS, NO_CHILD, Node, TreeStats, WIDTH};
use crate::geometry::Aabb;

/// A built tree: nodes of four, the root first and each node's subtrees after it in lane
/// order; a leaf reference holds its number of items and its number in `leaves`.
pub(super) struct Wide {
    pub(super) nodes: Vec<Node>,
    /// The leaves' ranges of items, depth first in lane order.
    pub(super) leaves: Vec<Leaf>,
    pub(super) stats: TreeStats,
}

/// A leaf of a built tree: its range of the items.
#[derive(Clone, Copy)]
pub(super) struct Leaf {
    pub(super) start: u32,
    pub(super) count: u32,
}

impl Wide {
    fn new() -> Wide {
        Wide {
            nodes: Vec::new(),
            leaves: Vec::new(),
            stats: TreeStats::default(),
        }
    }
}

/// The low bits of a leaf reference: its start or number.
pub(super) const LEAF_MASK: u32 = (1 << LEAF_START_BITS) - 1;

/// A node of the binary build whose fate is decided: a leaf, or cut in two with its items
/// partitioned.
struct Decided<'a> {
    items: &'a mut [Item],
    /// Where `items` starts in the whole list.
    first: usize,
    /// Binary depth (for the median fallback).
    depth: usize,
    bounds: Aabb,
    cut: Option<(usize, Extents, Extents)>,
}

impl Builder {
    /// The tree over `items`, which it reorders into leaf order.
    pub(super) fn build_wide(&self, items: &mut [Item]) -> Wide {
        let mut wide = Wide::new();
        let ext = extents(items);
        let root = self.decided(items, 0, 0, ext);
        if root.cut.is_some() {
            self.node(root, 0, &mut wide);
            return wide;
        }
        // A lone leaf, or none: a node of one child.
        let mut node = Node::EMPTY;
        if !root.items.is_empty() {
            node.children[0] = self.leaf(&root, 1, &mut wide);
            set_bounds(&mut node, 0, &root.bounds);
        }
        wide.nodes.push(node);
        wide
    }

    fn decided<'a>(
        &self,
        items: &'a mut [Item],
        first: usize,
        depth: usize,
        ext: Extents,
    ) -> Decided<'a> {
        let cut = self.decide(items, depth, &ext);
        Decided {
            items,
            first,
            depth,
            bounds: ext.0,
            cut,
        }
    }

    /// The two sides of a cut node, decided (side by side when large).
    fn halves<'a>(&self, d: Decided<'a>) -> [Decided<'a>; 2] {
        let (mid, left_ext, right_ext) = d.cut.expect("only cut nodes are opened");
        let large = d.items.len() > PARALLEL_ITEMS;
        let (left, right) = d.items.split_at_mut(mid);
        let (first, depth) = (d.first, d.depth + 1);
        let (l, r) = if large {
            rayon::join(
                || self.decided(left, first, depth, left_ext),
                || self.decided(right, first + mid, depth, right_ext),
            )
        } else {
            (
                self.decided(left, first, depth, left_ext),
                self.decided(right, first + mid, depth, right_ext),
            )
        };
        [l, r]
    }

    /// A leaf's reference, its range added to `out`'s leaves and counted in its statistics
    /// at four-wide depth `level`.
    fn leaf(&self, d: &Decided, level: usize, out: &mut Wide) -> u32 {
        out.stats.add(&TreeStats {
            leaves: 1,
            max_depth: level,
            depth_sum: level,
            leaf_volume: if d.bounds.is_empty() {
                0.0
            } else {
                d.bounds.volume() as f64
            },
        });
        out.leaves.push(Leaf {
            start: d.first as u32,
            count: d.items.len() as u32,
        });
        // The number wraps past 2^27, which the bvh checks once built.
        leaf_reference(
            d.items.len() as u32,
            (out.leaves.len() - 1) as u32 & LEAF_MASK,
        )
    }

    /// Appends the node of four made from cut node `d`, at four-wide depth `level`, then its
    /// children's subtrees, to `out`.
    fn node(&self, d: Decided, level: usize, out: &mut Wide) {
        let large = d.items.len() > PARALLEL_ITEMS;
        let [l, r] = self.halves(d);
        let mut kids: [Option<Decided>; WIDTH] = [Some(l), Some(r), None, None];
        let mut n = 2;
        while n < WIDTH {
            let mut open = None;
            let mut widest = f32::NEG_INFINITY;
            for (i, k) in kids[..n].iter().enumerate() {
                let k = k.as_ref().expect("the first n lanes are filled");
                if k.cut.is_some() {
                    let area = k.bounds.surface_area();
                    if open.is_none() || area >= widest {
                        (open, widest) = (Some(i), area);
                    }
                }
            }
            let Some(i) = open else { break };
            let opened = kids[i].take().expect("filled");
            let [a, b] = self.halves(opened);
            kids[i] = kids[n - 1].take();
            kids[n - 1] = Some(a);
            kids[n] = Some(b);
            n += 1;
        }
        let me = out.nodes.len();
        out.nodes.push(Node::EMPTY);
        let mut node = Node::EMPTY;
        for (lane, kid) in kids[..n].iter().enumerate() {
            set_bounds(&mut node, lane, &kid.as_ref().expect("filled").bounds);
        }
        if large {
            // Each inner child's subtree in a list of its own, side by side.
            let mut parts: [Option<Wide>; WIDTH] = Default::default();
            rayon::scope(|scope| {
                for (part, kid) in parts.iter_mut().zip(&mut kids) {
                    if let Some(k) = kid.take_if(|k| k.cut.is_some()) {
                        scope.spawn(move |_| {
                            let mut w = Wide::new();
                            self.node(k, level + 1, &mut w);
                            *part = Some(w);
                        });
                    }
                }
            });
            // Room for all of them at once: growing by doubling left up to twice their size
            // allocated.
            out.nodes
                .reserve_exact(parts.iter().flatten().map(|p| p.nodes.len()).sum());
            for (lane, (kid, part)) in kids.iter().zip(parts).enumerate().take(n) {
                node.children[lane] = match (kid, part) {
                    (Some(leaf), _) => self.leaf(leaf, level + 1, out),
                    (None, Some(part)) => {
                        let base = out.nodes.len() as u32;
                        let leaf_base = out.leaves.len() as u32;
                        out.nodes.extend(part.nodes.iter().map(|p| {
                            let mut p = *p;
                            for c in &mut p.children {
                                if *c == NO_CHILD {
                                    continue;
                                }
                                *c = if *c & LEAF == 0 {
                                    *c + base
                                } else {
                                    *c & !LEAF_MASK | (*c).wrapping_add(leaf_base) & LEAF_MASK
                                };
                            }
                            p
                        }));
                        out.leaves.extend_from_slice(&part.leaves);
                        out.stats.add(&part.stats);
                        base
                    }
                    (None, None) => unreachable!("every lane below n is a leaf or a subtree"),
                };
            }
        } else {
            for (lane, kid) in kids.into_iter().take(n).enumerate() {
                let kid = kid.expect("the first n lanes are filled");
                node.children[lane] = if kid.cut.is_some() {
                    let at = out.nodes.len() as u32;
                    self.node(kid, level + 1, out);
                    at
                } else {
                    self.leaf(&kid, level + 1, out)
                };
            }
        }
        out.nodes[me] = node;
    }
}

fn set_bounds(node: &mut Node, lane: usize, b: &Aabb) {
    for a in 0..3 {
        node.bounds[a][lane] = b.min[a];
        node.bounds[3 + a][lane] = b.max[a];
    }
}

/// Replaces each leaf reference by `by(number)`, the reference the structure's leaves need.
pub(super) fn relabel_leaves(nodes: &mut [Node], by: impl Fn(usize) -> u32 + Sync) {
    use rayon::prelude::*;
    nodes.par_iter_mut().for_each(|n| {
        for c in &mut n.children {
            if *c != NO_CHILD && *c & LEAF != 0 {
                *c = by((*c & LEAF_MASK) as usize);
            }
        }
    });
}

/// A leaf reference: `LEAF`, `count − 1` (1 to 16) and `low` (a start or a number, below
/// 2^27).
pub(super) fn leaf_reference(count: u32, low: u32) -> u32 {
    debug_assert!((1..=16).contains(&count) && low <= LEAF_MASK);
    LEAF | ((count - 1) << LEAF_START_BITS) | low
}
