//! Flattening: the build's binary tree as nodes of four and leaf blocks (the bvh's blocks of
//! triangles, [`super::BoxTree`]'s of box entries), depth first, large subtrees side by side.

use super::build::{BuildNode, Item};
use super::{LANES, LEAF, LEAF_START_BITS, NO_CHILD, Node, TreeStats, WIDTH};
/// The children of a node of four made from a binary node: its two children, then again and
/// again the inner one of largest area (the last of equals) opened, until there are four or
/// only leaves. Returns them and their number. The one opened gives its lane to the last
/// child and its own two take the last lanes: the traversal visits children whose entry
/// distances tie from the last lane down, and this order measured faster than putting the
/// two in the opened one's place (×0.84–0.99 there: bunny, gen-kitchen, gen-building).
pub(super) fn four(children: &[BuildNode; 2]) -> ([&BuildNode; WIDTH], usize) {
    let mut kids = [&children[0]; WIDTH];
    kids[1] = &children[1];
    let mut n = 2;
    while n < WIDTH {
        let mut open = None;
        let mut widest = f32::NEG_INFINITY;
        for (i, k) in kids[..n].iter().enumerate() {
            if let BuildNode::Inner { bounds, .. } = k {
                let area = bounds.surface_area();
                if open.is_none() || area >= widest {
                    (open, widest) = (Some(i), area);
                }
            }
        }
        let Some(i) = open else { break };
        let BuildNode::Inner { children, .. } = kids[i] else {
            unreachable!("only inner nodes are opened")
        };
        kids[i] = kids[n - 1];
        kids[n - 1] = &children[0];
        kids[n] = &children[1];
        n += 1;
    }
    (kids, n)
}

/// Subtrees of more blocks than this are flattened in parallel.
pub(super) const PARALLEL_FLATTEN: usize = 1 << 10;

/// What flattening a subtree counted: lanes filled and the leaves' statistics.
#[derive(Default)]
pub(super) struct Flattened {
    pub(super) filled: usize,
    pub(super) stats: TreeStats,
}

impl Flattened {
    pub(super) fn add(mut self, o: Flattened) -> Flattened {
        self.filled += o.filled;
        self.stats.add(&o.stats);
        self
    }
}

/// A node's part of the lists: its own nodes and leaf blocks (the bvh's [`Block`]s of
/// triangles, or another tree's blocks of four leaf entries), and where they start in the
/// whole.
pub(super) struct Part<'a, L> {
    pub(super) nodes: &'a mut [Node],
    pub(super) node_base: usize,
    pub(super) blocks: &'a mut [L],
    pub(super) block_base: usize,
}

/// Flattens `node` into `part` (of exactly its [`BuildNode::size`]): nodes of four, depth first
/// (a node, then each child's subtree in turn), the leaves' blocks in the same order; returns
/// its child reference. Children whose subtrees are large are flattened side by side, each in
/// its own part: the layout is the one flattening them in turn would give. A leaf's blocks
/// are filled by `fill(blocks, items)`, its items in [`BuildNode::leaf`]'s order, four to a
/// block.
pub(super) fn flatten<L: Send, F: Fn(&mut [L], &[Item]) + Sync>(
    fill: &F,
    node: &BuildNode,
    items: &[Item],
    depth: usize,
    part: Part<L>,
) -> (u32, Flattened) {
    match node {
        BuildNode::Leaf { count: 0, .. } => (NO_CHILD, Flattened::default()),
        &BuildNode::Leaf {
            bounds,
            start,
            count,
        } => {
            fill(part.blocks, &items[start..start + count]);
            let stats = TreeStats {
                leaves: 1,
                max_depth: depth,
                depth_sum: depth,
                leaf_volume: if bounds.is_empty() {
                    0.0
                } else {
                    bounds.volume() as f64
                },
            };
            let blocks = count.div_ceil(LANES) as u32;
            let r = LEAF | ((blocks - 1) << LEAF_START_BITS) | part.block_base as u32;
            (
                r,
                Flattened {
                    filled: count,
                    stats,
                },
            )
        }
        BuildNode::Inner { children, size, .. } => {
            let (kids, n) = four(children);
            let (own, mut nodes) = part.nodes.split_first_mut().expect("sized for its node");
            let mut blocks = part.blocks;
            let (mut node_base, mut block_base) = (part.node_base + 1, part.block_base);
            let mut parts: [Option<(&BuildNode, Part<L>)>; WIDTH] = Default::default();
            for (slot, k) in parts.iter_mut().zip(&kids[..n]) {
                let s = k.size();
                let (kn, rest) = std::mem::take(&mut nodes).split_at_mut(s.nodes);
                let (kb, rest_b) = std::mem::take(&mut blocks).split_at_mut(s.blocks);
                (nodes, blocks) = (rest, rest_b);
                *slot = Some((
                    *k,
                    Part {
                        nodes: kn,
                        node_base,
                        blocks: kb,
                        block_base,
                    },
                ));
                node_base += s.nodes;
                block_base += s.blocks;
            }
            let mut refs: [(u32, Flattened); WIDTH] = Default::default();
            let parts = parts.into_iter().flatten();
            if size.blocks > PARALLEL_FLATTEN {
                rayon::scope(|scope| {
                    for (r, (k, p)) in refs.iter_mut().zip(parts) {
                        scope.spawn(move |_| *r = flatten(fill, k, items, depth + 1, p));
                    }
                });
            } else {
                for (r, (k, p)) in refs.iter_mut().zip(parts) {
                    *r = flatten(fill, k, items, depth + 1, p);
                }
            }
            let mut counted = Flattened::default();
            for (lane, (k, (r, f))) in kids[..n].iter().zip(refs).enumerate() {
                counted = counted.add(f);
                if r == NO_CHILD {
                    continue;
                }
                let b = k.bounds();
                for a in 0..3 {
                    own.bounds[a][lane] = b.min[a];
                    own.bounds[3 + a][lane] = b.max[a];
                }
                own.children[lane] = r;
            }
            (part.node_base as u32, counted)
        }
    }
}
