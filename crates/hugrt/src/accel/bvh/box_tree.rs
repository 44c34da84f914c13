//! A four-wide tree over boxes whose leaves are not triangles but entries of another
//! structure (the adaptive grid's grids; a top level over instances could be one): the bvh's
//! build, nodes and traversal ([`walk_tree`]) with one entry per leaf.

use super::build::{Builder, Item, extents};
use super::flatten::{Part, flatten};
use super::{LANES, Node, walk_tree};
use crate::accel::store::finite;
use crate::accel::{Counters, HitSink};
use crate::geometry::{Aabb, Ray};

/// An unused lane of a leaf block.
const NO_ENTRY: u32 = u32::MAX;

/// The tree: nodes of four children and, per leaf, a block naming its entry.
pub(crate) struct BoxTree {
    nodes: Vec<Node>,
    blocks: Vec<[u32; LANES]>,
}

impl BoxTree {
    /// A tree over `boxes`, entry `e` in the box `boxes[e]`: binned SAH (16 bins, a
    /// traversal step as dear as an entry's test), one entry per leaf. Boxes that are empty
    /// or not finite are in no leaf.
    ///
    /// The boxes are taken as they are: each must hold its entry's contents widened by the
    /// margin of [`crate::accel::margin`], as the grids' boxes do, so that the slab test's
    /// rounding never drops a box before a hit inside it.
    pub(crate) fn build(boxes: &[Aabb]) -> BoxTree {
        let mut items: Vec<Item> = boxes
            .iter()
            .enumerate()
            .filter(|(_, b)| finite(b))
            .map(|(e, b)| Item::new(e as u32, b))
            .collect();
        let builder = Builder {
            leaf_size: 1,
            bins: 16,
            traversal_cost: 1.0,
        };
        let ext = extents(&items);
        let root = builder.build(&mut items, 0, 0, ext).rooted();
        let size = root.size();
        let mut nodes = vec![Node::EMPTY; size.nodes];
        let mut blocks = vec![[NO_ENTRY; LANES]; size.blocks];
        let part = Part {
            nodes: &mut nodes,
            node_base: 0,
            blocks: &mut blocks,
            block_base: 0,
        };
        let fill = |blocks: &mut [[u32; LANES]], items: &[Item]| {
            for (block, lanes) in blocks.iter_mut().zip(items.chunks(LANES)) {
                for (l, it) in lanes.iter().enumerate() {
                    block[l] = it.slot();
                }
            }
        };
        flatten(&fill, &root, &items, 0, part);
        BoxTree { nodes, blocks }
    }

    /// Offers the ray every entry whose box it crosses before the sink's `tmax`, nearest box
    /// first: `entry(e, sink, counters)` tests entry `e` and returns `true` to stop the walk.
    /// Each box met counts as a box test; nodes do not count as cell visits.
    #[inline(always)]
    pub(crate) fn walk<S: HitSink, C: Counters>(
        &self,
        ray: &Ray,
        sink: &mut S,
        counters: &mut C,
        mut entry: impl FnMut(u32, &mut S, &mut C) -> bool,
    ) {
        walk_tree::<S, C, false>(&self.nodes, ray, sink, counters, |start, count, sink, c| {
            self.blocks[start..start + count]
                .iter()
                .flatten()
                .any(|&e| e != NO_ENTRY && entry(e, sink, c))
        });
    }

    /// Nodes of four children.
    pub(crate) fn node_count(&self) -> usize {
        self.nodes.len()
    }

    pub(crate) fn memory_bytes(&self) -> usize {
        self.nodes.capacity() * std::mem::size_of::<Node>()
            + self.blocks.capacity() * std::mem::size_of::<[u32; LANES]>()
    }
}
