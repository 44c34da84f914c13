//! Clustering objects of one size level (EG95 §2.2, SCG97 §7.4).
//!
//! Both algorithms permute one array of [`Item`]s in place and return the clusters as
//! consecutive ranges of it. Any partition into clusters gives a correct hierarchy (a cluster
//! is only a grid's content); what clustering decides is speed. So where an adversarial input
//! would make an algorithm quadratic, a work budget stops the refinement and keeps coarser
//! clusters, and the build stays `O(n log n)`.

use crate::accel::store::radix_sort_high32;
use std::ops::Range;

/// An object as clustering sees it: its box and an index the caller gives it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Item {
    pub lo: [f32; 3],
    pub hi: [f32; 3],
    pub id: u32,
}

/// Work allowed per object, in objects sorted (Cluster3d) or pairs looked at (graph): EG95
/// reports `Σ N_i log N_i / n log n` between 3 and 5 on its scenes, far below this.
const WORK_PER_OBJECT: usize = 32;

/// A `u32` whose order is the total order of the `f32` `x`.
fn ordered_bits(x: f32) -> u32 {
    let b = x.to_bits();
    if b >> 31 == 0 { b | 1 << 31 } else { !b }
}

/// Scratch space for sorting, allocated once per clustering.
#[derive(Default)]
struct Scratch {
    keys: Vec<u64>,
    items: Vec<Item>,
}

/// Sorts `items` by the left end of their projections on `axis`: a comparison sort for short
/// ranges, a radix sort of (key, position) pairs and one gather for long ones.
fn sort_by_left_end(items: &mut [Item], axis: usize, scratch: &mut Scratch) {
    if items.len() < 512 {
        items.sort_unstable_by(|a, b| a.lo[axis].total_cmp(&b.lo[axis]));
        return;
    }
    scratch.keys.clear();
    scratch.keys.extend(
        items
            .iter()
            .enumerate()
            .map(|(k, it)| (ordered_bits(it.lo[axis]) as u64) << 32 | k as u64),
    );
    radix_sort_high32(&mut scratch.keys);
    scratch.items.clear();
    scratch.items.extend(
        scratch
            .keys
            .iter()
            .map(|&k| items[(k & 0xffff_ffff) as usize]),
    );
    items.copy_from_slice(&scratch.items);
}

/// EG95 §2.2.2, `Isolate`: sorts `items` by the left end of their projections on `axis`,
/// sweeps keeping the rightmost end seen so far, and cuts wherever the next left end lies `δ`
/// or more beyond it (so that the objects on each side are not δ-connected along `axis`).
/// Calls `piece` with each resulting range (relative to `items`), in order.
fn isolate(
    items: &mut [Item],
    axis: usize,
    delta: f32,
    scratch: &mut Scratch,
    mut piece: impl FnMut(Range<usize>),
) {
    sort_by_left_end(items, axis, scratch);
    let mut start = 0;
    let mut right = f32::NEG_INFINITY;
    for (i, it) in items.iter().enumerate() {
        if i > start && it.lo[axis] - right >= delta {
            piece(start..i);
            start = i;
        }
        right = right.max(it.hi[axis]);
    }
    if !items.is_empty() {
        piece(start..items.len());
    }
}

/// A cluster or potential cluster (EG95's CPC): a range of the item array, the last axis
/// `Isolate` was applied along, and along how many axes in a row it left the range whole.
#[derive(Clone, Copy, Debug, Default)]
struct Cpc {
    start: u32,
    end: u32,
    axis: u8,
    stable: u8,
}

/// EG95 §2.2.2, `Cluster3d`: `Isolate` along x, y, z in turn on every potential cluster until
/// a range comes out whole along all three axes. Two objects end in the same cluster only if
/// their projections are δ-connected along every axis (EG95 Def. 3). As in the paper, the
/// potential clusters and the final ones share one array of `n` records used as a double
/// stack (potential clusters grow from the bottom, final ones from the top: at most `n`
/// clusters exist at any time), and the items are permuted in place.
///
/// The paper bounds the worst case by `O(n² log n)` (one object split off per pass); past a
/// budget of `32·n` objects sorted, the potential clusters left are kept as clusters.
pub fn cluster3d(items: &mut [Item], delta: f32) -> Vec<Range<usize>> {
    let n = items.len();
    if n == 0 {
        return Vec::new();
    }
    let mut stack = vec![Cpc::default(); n];
    let (mut bottom, mut top) = (0usize, n);
    stack[0] = Cpc {
        start: 0,
        end: n as u32,
        axis: 2,
        stable: 0,
    };
    bottom += 1;
    let mut work = 0usize;
    let budget = WORK_PER_OBJECT * n;
    let mut scratch = Scratch::default();
    while bottom > 0 {
        bottom -= 1;
        let pc = stack[bottom];
        let range = pc.start as usize..pc.end as usize;
        if range.len() == 1 || work > budget {
            top -= 1;
            stack[top] = pc;
            continue;
        }
        work += range.len();
        let axis = (pc.axis as usize + 1) % 3;
        let mut pieces = 0;
        let start = range.start;
        isolate(&mut items[range.clone()], axis, delta, &mut scratch, |r| {
            pieces += 1;
            // The pieces replace `pc` on the bottom stack; there are never more records than
            // objects, so the two stacks cannot meet.
            debug_assert!(bottom < top);
            stack[bottom] = Cpc {
                start: (start + r.start) as u32,
                end: (start + r.end) as u32,
                axis: axis as u8,
                stable: 1,
            };
            bottom += 1;
        });
        if pieces == 1 {
            bottom -= 1;
            let stable = pc.stable + 1;
            if stable == 3 {
                top -= 1;
                stack[top] = Cpc { stable, ..pc };
            } else {
                stack[bottom] = Cpc {
                    axis: axis as u8,
                    stable,
                    ..pc
                };
                bottom += 1;
            }
        }
    }
    stack[top..]
        .iter()
        .map(|c| c.start as usize..c.end as usize)
        .collect()
}

fn find(parent: &mut [u32], mut i: u32) -> u32 {
    while parent[i as usize] != i {
        let p = parent[parent[i as usize] as usize];
        parent[i as usize] = p;
        i = p;
    }
    i
}

fn union(parent: &mut [u32], a: u32, b: u32) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    if ra != rb {
        parent[ra.max(rb) as usize] = ra.min(rb);
    }
}

/// SCG97 §7.4: the clusters are the connected components of the graph joining objects whose
/// (closed) boxes intersect. Found by a sweep along the axis of largest extent, confirming
/// each pair whose intervals overlap there on the other two axes, with union-find.
///
/// Past a budget of `32·n` pairs looked at (piles of mutually overlapping boxes), each new
/// object is joined to the previous one in sweep order when their intervals overlap along the
/// sweep axis: coarser clusters, in linear time.
pub fn graph_components(items: &mut [Item]) -> Vec<Range<usize>> {
    let n = items.len();
    if n == 0 {
        return Vec::new();
    }
    let (lo, hi) = items.iter().fold(
        ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]),
        |(lo, hi), it| {
            (
                std::array::from_fn(|a| lo[a].min(it.lo[a])),
                std::array::from_fn(|a| hi[a].max(it.hi[a])),
            )
        },
    );
    let axis = (0..3)
        .max_by(|&a, &b| (hi[a] - lo[a]).total_cmp(&(hi[b] - lo[b])))
        .unwrap_or(0);
    let (o1, o2) = ((axis + 1) % 3, (axis + 2) % 3);
    sort_by_left_end(items, axis, &mut Scratch::default());
    let mut parent: Vec<u32> = (0..n as u32).collect();
    let mut active: Vec<u32> = Vec::new();
    let mut work = 0usize;
    let budget = WORK_PER_OBJECT * n;
    for i in 0..n {
        let it = items[i];
        if work > budget {
            if i > 0 && items[i - 1].hi[axis] >= it.lo[axis] {
                union(&mut parent, i as u32 - 1, i as u32);
            }
            continue;
        }
        work += active.len();
        active.retain(|&j| items[j as usize].hi[axis] >= it.lo[axis]);
        for &j in &active {
            let o = &items[j as usize];
            if o.lo[o1] <= it.hi[o1]
                && it.lo[o1] <= o.hi[o1]
                && o.lo[o2] <= it.hi[o2]
                && it.lo[o2] <= o.hi[o2]
            {
                union(&mut parent, j, i as u32);
            }
        }
        active.push(i as u32);
    }
    let roots: Vec<u32> = (0..n as u32).map(|i| find(&mut parent, i)).collect();
    let mut keyed: Vec<(u32, Item)> = roots.into_iter().zip(items.iter().copied()).collect();
    keyed.sort_unstable_by_key(|&(r, _)| r);
    let mut out = Vec::new();
    let mut start = 0;
    for i in 0..n {
        items[i] = keyed[i].1;
        if i + 1 == n || keyed[i + 1].0 != keyed[i].0 {
            out.push(start..i + 1);
            start = i + 1;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn item(lo: [f32; 3], hi: [f32; 3], id: u32) -> Item {
        Item { lo, hi, id }
    }

    fn cube(c: [f32; 3], r: f32, id: u32) -> Item {
        item(c.map(|x| x - r), c.map(|x| x + r), id)
    }

    fn ids(items: &[Item], clusters: &[Range<usize>]) -> Vec<Vec<u32>> {
        let mut v: Vec<Vec<u32>> = clusters
            .iter()
            .map(|r| {
                let mut c: Vec<u32> = items[r.clone()].iter().map(|i| i.id).collect();
                c.sort();
                c
            })
            .collect();
        v.sort();
        v
    }

    #[test]
    fn isolate_cuts_at_gaps_of_delta() {
        let mut items = vec![
            item([0.0; 3], [1.0; 3], 0),
            item([0.5; 3], [3.0; 3], 1),
            item([2.0; 3], [2.5; 3], 2),
            item([3.05; 3], [4.0; 3], 3),
            item([4.2; 3], [5.0; 3], 4),
        ];
        let mut pieces = Vec::new();
        isolate(&mut items, 0, 0.1, &mut Scratch::default(), |r| {
            pieces.push(r)
        });
        // 3.05 is within 0.1 of 3.0 (the rightmost end so far, not 2.5): no cut there.
        assert_eq!(pieces, vec![0..4, 4..5]);
    }

    #[test]
    fn cluster3d_separates_what_one_projection_joins() {
        // EG95 Fig. 4's situation: A and B overlap along x, A and C along y, yet A, B, C are
        // three clusters.
        let mut items = vec![
            cube([0.0, 0.0, 0.0], 1.0, 0),
            cube([0.5, 0.0, 0.0], 1.0, 1),
            cube([0.0, 10.0, 0.0], 1.0, 2),
            cube([10.0, 0.5, 0.0], 1.0, 3),
            cube([10.5, 0.4, 0.0], 1.0, 4),
        ];
        let c = cluster3d(&mut items, 0.01);
        assert_eq!(ids(&items, &c), vec![vec![0, 1], vec![2], vec![3, 4]]);
        let total: usize = c.iter().map(|r| r.len()).sum();
        assert_eq!(total, 5);
    }

    #[test]
    fn cluster3d_needs_connection_on_every_axis() {
        // Connected along x and y, but 5 apart along z.
        let mut items = vec![cube([0.0; 3], 1.0, 0), cube([0.0, 0.0, 7.0], 1.0, 1)];
        assert_eq!(cluster3d(&mut items, 0.5).len(), 2);
        let mut items = vec![cube([0.0; 3], 1.0, 0), cube([0.0, 0.0, 2.3], 1.0, 1)];
        assert_eq!(cluster3d(&mut items, 0.5).len(), 1);
    }

    #[test]
    fn graph_components_join_only_intersecting_boxes() {
        // An L of touching boxes is one component; a box inside the L's bounding box but
        // touching nothing is another (Cluster3d would merge it: SCG97 Fig. 27).
        let mut items = vec![
            item([0.0, 0.0, 0.0], [10.0, 1.0, 1.0], 0),
            item([9.0, 0.0, 0.0], [10.0, 10.0, 1.0], 1),
            item([2.0, 5.0, 0.0], [3.0, 6.0, 1.0], 2),
            item([20.0, 0.0, 0.0], [21.0, 1.0, 1.0], 3),
        ];
        let c = graph_components(&mut items);
        assert_eq!(ids(&items, &c), vec![vec![0, 1], vec![2], vec![3]]);
        let mut again = items.clone();
        assert_eq!(cluster3d(&mut again, 0.01).len(), 2);
    }

    #[test]
    fn long_ranges_sort_like_short_ones() {
        let mut items: Vec<Item> = (0..3000u32)
            .map(|i| {
                let x = ((i.wrapping_mul(2654435761) % 1000) as f32 - 500.0) * 0.37;
                item([x, 0.0, 0.0], [x + 1.0, 1.0, 1.0], i)
            })
            .collect();
        let mut want = items.clone();
        want.sort_by(|a, b| a.lo[0].total_cmp(&b.lo[0]));
        sort_by_left_end(&mut items, 0, &mut Scratch::default());
        let lo = |v: &[Item]| v.iter().map(|i| i.lo[0]).collect::<Vec<_>>();
        assert_eq!(lo(&items), lo(&want));
        assert!(ordered_bits(-0.5) < ordered_bits(-0.0) && ordered_bits(0.0) < ordered_bits(1e-30));
    }

    #[test]
    fn budgets_keep_piles_of_overlaps_linear() {
        // 5000 identical boxes: every pair overlaps. Both algorithms finish with one cluster.
        let mut items: Vec<Item> = (0..5000).map(|i| cube([0.0; 3], 1.0, i)).collect();
        assert_eq!(graph_components(&mut items).len(), 1);
        assert_eq!(cluster3d(&mut items, 0.01).len(), 1);
    }
}
