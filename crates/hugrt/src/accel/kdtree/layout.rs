//! Where a kd-tree's nodes lie in memory (Havran §4.3): the same tree, node for node, in five
//! representations, each read by the one traversal through [`NodeStore`].
//!
//! * `depth-first` (Havran's DFS representation, Fig. 11b): a node, its subtree below the
//!   plane, then its subtree above; an inner node holds the index of the child above, the
//!   child below follows it. Eight bytes a node, eight nodes to a 64-byte line.
//! * `breadth-first`: level after level, children in pairs (an inner node holds the index of
//!   the pair).
//! * `subtrees` (Havran's ordinary subtrees, Fig. 12a): from a root at the start of a 64-byte
//!   line, its descendants breadth first in the same line while a pair fits; the pairs that do
//!   not fit start lines of their own. Nodes as in the pair layouts, pointers included.
//! * `compact` (Havran's compact subtrees, Fig. 12b): one complete subtree of three levels
//!   (seven nodes) per 64-byte line, with no pointers inside it: node `k`'s children are
//!   `2k + 1` and `2k + 2` of the same line, and only the four nodes of its last level hold
//!   their children's addresses (a line, or a leaf). Two bits per node say its axis or that it
//!   is a leaf (Havran's "special data variable"). A leaf is one word: where its references
//!   start in a reference list that holds each leaf's count before its references, so that
//!   the count comes with the first references' cache line (an index into a separate table of
//!   `(start, count)` cost a miss per leaf: 16.3 first-level misses per incoherent ray on the
//!   bunny against 14.1 for ordinary subtrees).
//! * `scattered` (Havran's random representation, Fig. 11a): every node placed at random
//!   (a fixed seed), each inner node holding both children's indices, as nodes allocated one
//!   by one would lie.

/// The tree before it is laid out: children explicit.
pub(super) enum Logical {
    Leaf {
        start: u32,
        count: u32,
    },
    Inner {
        axis: u32,
        split: f32,
        below: usize,
        above: usize,
    },
}

/// The memory layouts of the module documentation.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Layout {
    /// Depth-first, each inner node followed by its first child (the default).
    DepthFirst,
    /// Level by level.
    BreadthFirst,
    /// Every node at a random place, each inner node holding both children's.
    Scattered,
    /// Ordinary nodes in subtrees of 64-byte lines.
    Subtrees,
    /// Havran's pointer-free subtrees, seven nodes a line.
    Compact,
}

crate::accel::settings::choice_value!(Layout {
    Layout::DepthFirst => "depth-first",
    Layout::BreadthFirst => "breadth-first",
    Layout::Scattered => "scattered",
    Layout::Subtrees => "subtrees",
    Layout::Compact => "compact",
});

/// A node as the traversal reads it.
pub(super) enum Visit {
    Inner {
        axis: usize,
        split: f32,
        below: u32,
        above: u32,
    },
    Leaf {
        start: usize,
        count: usize,
    },
}

/// A representation of the tree: where the walk starts and what a node reference names.
pub(super) trait NodeStore {
    fn root(&self) -> u32;
    /// The node `node` names; `refs` is the tree's reference list.
    fn visit(&self, node: u32, refs: &[u32]) -> Visit;
}

/// Leaf marker in [`KdNode::a`]'s two low bits.
const LEAF: u32 = 3;

/// Eight bytes. Inner: `a` = axis | a child's index << 2, `b` = the plane's `f32` bits: in
/// the depth-first layout the child below the plane follows its parent and the index is the
/// child above; in the pair layouts the index is the child below, the child above the next
/// one. Leaf: `a` = 3 | count << 2, `b` = first reference.
#[derive(Clone, Copy, Default)]
struct KdNode {
    a: u32,
    b: u32,
}

/// Eight nodes in one 64-byte cache line.
#[derive(Clone, Copy, Default)]
#[repr(C, align(64))]
struct Line([KdNode; 8]);

/// The depth-first, breadth-first and ordinary-subtree layouts.
#[derive(Default)]
pub(super) struct Lines {
    lines: Vec<Line>,
    /// Children in pairs (the index names the child below) rather than depth first.
    pairs: bool,
}

impl NodeStore for Lines {
    #[inline(always)]
    fn root(&self) -> u32 {
        0
    }

    #[inline(always)]
    fn visit(&self, i: u32, _: &[u32]) -> Visit {
        let kd = self.lines[(i >> 3) as usize].0[(i & 7) as usize];
        if kd.a & 3 == LEAF {
            return Visit::Leaf {
                start: kd.b as usize,
                count: (kd.a >> 2) as usize,
            };
        }
        let (below, above) = if self.pairs {
            (kd.a >> 2, (kd.a >> 2) + 1)
        } else {
            (i + 1, kd.a >> 2)
        };
        Visit::Inner {
            axis: (kd.a & 3) as usize,
            split: f32::from_bits(kd.b),
            below,
            above,
        }
    }
}

/// A node of the scattered layout: [`KdNode`] and the index of the child above.
#[derive(Clone, Copy, Default)]
struct LooseNode {
    node: KdNode,
    above: u32,
}

/// The scattered layout.
pub(super) struct Scattered {
    nodes: Vec<LooseNode>,
    root: u32,
}

impl NodeStore for Scattered {
    #[inline(always)]
    fn root(&self) -> u32 {
        self.root
    }

    #[inline(always)]
    fn visit(&self, i: u32, _: &[u32]) -> Visit {
        let LooseNode { node: kd, above } = self.nodes[i as usize];
        if kd.a & 3 == LEAF {
            return Visit::Leaf {
                start: kd.b as usize,
                count: (kd.a >> 2) as usize,
            };
        }
        Visit::Inner {
            axis: (kd.a & 3) as usize,
            split: f32::from_bits(kd.b),
            below: kd.a >> 2,
            above,
        }
    }
}

/// A reference with this bit names a leaf (the position of its count in the reference list);
/// otherwise it is `line << 3 | node`.
const LEAF_TAG: u32 = 1 << 31;

/// A compact leaf holding nothing: no count to read.
const EMPTY_LEAF: u32 = !LEAF_TAG;

/// One compact subtree: seven nodes in heap order, 64 bytes.
#[derive(Clone, Copy, Default)]
#[repr(C, align(64))]
struct CompactLine {
    /// A plane's `f32` bits (inner node) or where the leaf's count lies (leaf).
    value: [u32; 7],
    /// Two bits per node: its axis, or 3 for a leaf.
    kinds: u16,
    _pad: u16,
    /// The children of nodes 3 to 6: a line's index (its node 0), or `LEAF_TAG | leaf`.
    child: [u32; 8],
}

/// The compact-subtree layout.
pub(super) struct Compact {
    lines: Vec<CompactLine>,
}

impl NodeStore for Compact {
    #[inline(always)]
    fn root(&self) -> u32 {
        0
    }

    #[inline(always)]
    fn visit(&self, r: u32, refs: &[u32]) -> Visit {
        let leaf = |i: u32| {
            if i == EMPTY_LEAF {
                return Visit::Leaf { start: 0, count: 0 };
            }
            Visit::Leaf {
                start: i as usize + 1,
                count: refs[i as usize] as usize,
            }
        };
        if r & LEAF_TAG != 0 {
            return leaf(r & !LEAF_TAG);
        }
        let (line, k) = (r >> 3, r & 7);
        let l = &self.lines[line as usize];
        let kind = (l.kinds >> (2 * k)) & 3;
        let value = l.value[k as usize];
        if kind == LEAF as u16 {
            return leaf(value);
        }
        let (below, above) = if k < 3 {
            (line << 3 | (2 * k + 1), line << 3 | (2 * k + 2))
        } else {
            let out = |c: u32| if c & LEAF_TAG != 0 { c } else { c << 3 };
            let j = 2 * (k - 3) as usize;
            (out(l.child[j]), out(l.child[j + 1]))
        };
        Visit::Inner {
            axis: kind as usize,
            split: f32::from_bits(value),
            below,
            above,
        }
    }
}

/// A laid-out tree.
pub(super) enum Nodes {
    Lines(Lines),
    Scattered(Scattered),
    Compact(Compact),
}

impl Nodes {
    pub fn bytes(&self) -> usize {
        match self {
            Nodes::Lines(l) => l.lines.capacity() * std::mem::size_of::<Line>(),
            Nodes::Scattered(s) => s.nodes.capacity() * std::mem::size_of::<LooseNode>(),
            Nodes::Compact(c) => c.lines.capacity() * std::mem::size_of::<CompactLine>(),
        }
    }

    /// 64-byte lines the nodes take (rounded up for the scattered layout).
    pub fn cache_lines(&self) -> usize {
        match self {
            Nodes::Lines(l) => l.lines.len(),
            Nodes::Scattered(s) => (s.nodes.len() * std::mem::size_of::<LooseNode>()).div_ceil(64),
            Nodes::Compact(c) => c.lines.len(),
        }
    }

    /// Places the logical nodes (index 0 the root) in memory by `layout`. The compact layout
    /// rewrites `refs` with each leaf's count before its references; `None` when that list
    /// would not fit its 31-bit positions.
    pub fn lay_out(tree: &[Logical], layout: Layout, refs: &mut Vec<u32>) -> Option<Nodes> {
        Some(match layout {
            Layout::Scattered => Nodes::Scattered(scattered(tree)),
            Layout::Compact => Nodes::Compact(compact(tree, refs)?),
            _ => Nodes::Lines(lines(tree, layout)),
        })
    }
}

fn children(tree: &[Logical], id: usize) -> Option<(usize, usize)> {
    match tree[id] {
        Logical::Inner { below, above, .. } => Some((below, above)),
        Logical::Leaf { .. } => None,
    }
}

fn kd_leaf(start: u32, count: u32) -> KdNode {
    KdNode {
        a: LEAF | count << 2,
        b: start,
    }
}

fn lines(tree: &[Logical], layout: Layout) -> Lines {
    let n = tree.len();
    let mut slot = vec![u32::MAX; n];
    let mut next = 1u32;
    slot[0] = 0;
    match layout {
        Layout::DepthFirst => {
            let mut stack = vec![0usize];
            next = 0;
            while let Some(id) = stack.pop() {
                slot[id] = next;
                next += 1;
                if let Some((b, a)) = children(tree, id) {
                    stack.push(a);
                    stack.push(b);
                }
            }
        }
        Layout::BreadthFirst => {
            let mut queue = std::collections::VecDeque::from([0usize]);
            while let Some(id) = queue.pop_front() {
                if let Some((b, a)) = children(tree, id) {
                    slot[b] = next;
                    slot[a] = next + 1;
                    next += 2;
                    queue.push_back(b);
                    queue.push_back(a);
                }
            }
        }
        _ => {
            // Lines are filled from subtree roots; a pair that does not fit in the line of its
            // parent starts a new line, whose subtree is laid out later.
            let mut pending = std::collections::VecDeque::from([vec![0usize]]);
            next = 0;
            while let Some(roots) = pending.pop_front() {
                let line_start = next.next_multiple_of(8);
                next = line_start;
                for &r in &roots {
                    slot[r] = next;
                    next += 1;
                }
                let mut queue: std::collections::VecDeque<usize> = roots.into();
                while let Some(id) = queue.pop_front() {
                    if let Some((b, a)) = children(tree, id) {
                        if next + 2 <= line_start + 8 {
                            slot[b] = next;
                            slot[a] = next + 1;
                            next += 2;
                            queue.push_back(b);
                            queue.push_back(a);
                        } else {
                            pending.push_back(vec![b, a]);
                        }
                    }
                }
            }
        }
    }
    let pairs = layout != Layout::DepthFirst;
    let total = slot.iter().map(|&s| s as usize + 1).max().unwrap_or(1);
    let mut lines = vec![Line::default(); total.div_ceil(8)];
    for (id, node) in tree.iter().enumerate() {
        let s = slot[id] as usize;
        lines[s / 8].0[s % 8] = match *node {
            Logical::Leaf { start, count } => kd_leaf(start, count),
            Logical::Inner {
                axis,
                split,
                below,
                above,
            } => KdNode {
                a: axis | if pairs { slot[below] } else { slot[above] } << 2,
                b: split.to_bits(),
            },
        };
    }
    Lines { lines, pairs }
}

fn scattered(tree: &[Logical]) -> Scattered {
    use rand::{SeedableRng, seq::SliceRandom};
    let mut slot: Vec<u32> = (0..tree.len() as u32).collect();
    slot.shuffle(&mut rand_pcg::Pcg64Mcg::seed_from_u64(7));
    let mut nodes = vec![LooseNode::default(); tree.len()];
    for (id, node) in tree.iter().enumerate() {
        nodes[slot[id] as usize] = match *node {
            Logical::Leaf { start, count } => LooseNode {
                node: kd_leaf(start, count),
                above: 0,
            },
            Logical::Inner {
                axis,
                split,
                below,
                above,
            } => LooseNode {
                node: KdNode {
                    a: axis | slot[below] << 2,
                    b: split.to_bits(),
                },
                above: slot[above],
            },
        };
    }
    Scattered {
        nodes,
        root: slot.first().copied().unwrap_or(0),
    }
}

fn compact(tree: &[Logical], refs: &mut Vec<u32>) -> Option<Compact> {
    let leaves = tree
        .iter()
        .filter(|n| matches!(n, Logical::Leaf { count, .. } if *count > 0))
        .count();
    if refs.len() + leaves >= EMPTY_LEAF as usize {
        return None;
    }
    let mut counted: Vec<u32> = Vec::with_capacity(refs.len() + leaves);
    let mut leaf = |start: u32, count: u32| {
        if count == 0 {
            return EMPTY_LEAF;
        }
        let at = counted.len() as u32;
        counted.push(count);
        counted.extend_from_slice(&refs[start as usize..(start + count) as usize]);
        at
    };
    let mut lines: Vec<CompactLine> = Vec::new();
    // Subtree roots waiting for their line, in the order their lines were numbered.
    let mut pending = std::collections::VecDeque::from([0usize]);
    let mut numbered = 1u32;
    while let Some(root) = pending.pop_front() {
        let mut line = CompactLine::default();
        let mut slot = [usize::MAX; 7];
        slot[0] = root;
        for k in 0..7 {
            let id = slot[k];
            if id == usize::MAX {
                continue;
            }
            match tree[id] {
                Logical::Leaf { start, count } => {
                    line.kinds |= (LEAF as u16) << (2 * k);
                    line.value[k] = leaf(start, count);
                }
                Logical::Inner {
                    axis,
                    split,
                    below,
                    above,
                } => {
                    line.kinds |= (axis as u16) << (2 * k);
                    line.value[k] = split.to_bits();
                    if k < 3 {
                        slot[2 * k + 1] = below;
                        slot[2 * k + 2] = above;
                    } else {
                        for (j, c) in [below, above].into_iter().enumerate() {
                            line.child[2 * (k - 3) + j] = match tree[c] {
                                Logical::Leaf { start, count } => LEAF_TAG | leaf(start, count),
                                Logical::Inner { .. } => {
                                    pending.push_back(c);
                                    numbered += 1;
                                    numbered - 1
                                }
                            };
                        }
                    }
                }
            }
        }
        lines.push(line);
    }
    debug_assert_eq!(lines.len() as u32, numbered);
    *refs = counted;
    Some(Compact { lines })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A complete tree of `depth` levels of inner nodes over leaves numbered left to right.
    fn complete(depth: u32) -> Vec<Logical> {
        fn add(out: &mut Vec<Logical>, depth: u32, leaf: &mut u32) -> usize {
            let id = out.len();
            if depth == 0 {
                out.push(Logical::Leaf {
                    start: *leaf,
                    count: (*leaf % 3 != 2) as u32,
                });
                *leaf += 1;
                return id;
            }
            out.push(Logical::Leaf { start: 0, count: 0 });
            let below = add(out, depth - 1, leaf);
            let above = add(out, depth - 1, leaf);
            out[id] = Logical::Inner {
                axis: depth % 3,
                split: depth as f32,
                below,
                above,
            };
            id
        }
        let mut out = Vec::new();
        add(&mut out, depth, &mut 0);
        out
    }

    /// The leaves' references in order, by walking below-first from the root.
    fn leaves_in_order<N: NodeStore>(n: &N, refs: &[u32]) -> Vec<u32> {
        let mut out = Vec::new();
        let mut stack = vec![n.root()];
        while let Some(r) = stack.pop() {
            match n.visit(r, refs) {
                Visit::Leaf { start, count } => out.extend_from_slice(&refs[start..start + count]),
                Visit::Inner { below, above, .. } => {
                    stack.push(above);
                    stack.push(below);
                }
            }
        }
        out
    }

    #[test]
    fn every_layout_holds_the_same_tree() {
        for depth in [0, 1, 2, 3, 4, 7] {
            let tree = complete(depth);
            // Leaf `i` holds reference `10 + i`, every third leaf none.
            let want: Vec<u32> = (0..1u32 << depth)
                .filter(|i| i % 3 != 2)
                .map(|i| 10 + i)
                .collect();
            for layout in [
                Layout::DepthFirst,
                Layout::BreadthFirst,
                Layout::Scattered,
                Layout::Subtrees,
                Layout::Compact,
            ] {
                let mut refs = (0..1u32 << depth).map(|i| 10 + i).collect();
                let got = match Nodes::lay_out(&tree, layout, &mut refs).unwrap() {
                    Nodes::Lines(l) => leaves_in_order(&l, &refs),
                    Nodes::Scattered(s) => leaves_in_order(&s, &refs),
                    Nodes::Compact(c) => leaves_in_order(&c, &refs),
                };
                assert_eq!(got, want, "{layout:?}, depth {depth}");
            }
        }
    }

    #[test]
    fn compact_subtrees_fill_lines_of_seven_nodes() {
        // 2^7 − 1 inner nodes: the root's line holds 7, then 8 lines of subtrees of 7 each
        // under it, then leaves as references from the last lines.
        let tree = complete(6);
        let mut refs = (0..64).collect();
        let Some(Nodes::Compact(c)) = Nodes::lay_out(&tree, Layout::Compact, &mut refs) else {
            unreachable!()
        };
        assert_eq!(std::mem::size_of::<CompactLine>(), 64);
        assert_eq!(c.lines.len(), 9);
        // 43 leaves hold one reference each, after its count; 21 are empty.
        assert_eq!(refs.len(), 2 * 43);
    }

    #[test]
    fn scattered_nodes_are_not_in_build_order() {
        let tree = complete(6);
        let Some(Nodes::Scattered(s)) = Nodes::lay_out(&tree, Layout::Scattered, &mut Vec::new())
        else {
            unreachable!()
        };
        // The root's children, adjacent in every other layout, lie apart.
        let Visit::Inner { below, above, .. } = s.visit(s.root, &[]) else {
            unreachable!()
        };
        assert_ne!(below.abs_diff(above), 1);
    }
}
