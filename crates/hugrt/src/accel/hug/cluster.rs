//! Clustering objects of one size level (EG95 §2.2, SCG97 §7.4).
//!
//! Both algorithms permute one array of [`Item`]s in place and return the clusters as
//! consecutive ranges of it. Any partition into clusters gives a correct hierarchy (a cluster
//! is only a grid's content); what clustering decides is speed. So where an adversarial input
//! would make an algorithm quadratic, a work budget stops the refinement and keeps coarser
//! clusters, and the build stays `O(n log n)`.

use crate::accel::simd;
use crate::accel::sort::radix_sort_high32;
use glam::Vec4;
use rayon::prelude::*;
use std::ops::Range;
use std::sync::atomic::AtomicU32;
use std::sync::atomic::Ordering::Relaxed;

/// An object as clustering sees it: its box and an index the caller gives it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Item {
    pub lo: [f32; 3],
    pub hi: [f32; 3],
    pub id: u32,
}

/// Work allowed per object, in objects sorted by Cluster3d: EG95
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

/// The root of `i`'s tree, halving the path on the way. Shared between threads: a link only
/// ever points from an object to one of smaller index in its component (`union`), so every
/// value a parent ever holds is an ancestor, and a stale read or a lost halving store leaves
/// a valid forest.
fn find(parent: &[AtomicU32], mut i: u32) -> u32 {
    loop {
        let p = parent[i as usize].load(Relaxed);
        if p == i {
            return i;
        }
        let g = parent[p as usize].load(Relaxed);
        if g != p {
            parent[i as usize].store(g, Relaxed);
        }
        i = g;
    }
}

/// Joins the trees of `a` and `b`, the larger root linked below the smaller; a root another
/// thread linked meanwhile fails the exchange, and the roots are found again.
fn union(parent: &[AtomicU32], a: u32, b: u32) {
    loop {
        let (ra, rb) = (find(parent, a), find(parent, b));
        if ra == rb {
            return;
        }
        let (hi, lo) = (ra.max(rb), ra.min(rb));
        if parent[hi as usize]
            .compare_exchange(hi, lo, Relaxed, Relaxed)
            .is_ok()
        {
            return;
        }
    }
}

/// No cell, no object.
const NONE: u32 = u32::MAX;

/// hugrt's default for `crowd`: objects sharing a cell beyond this count are joined without
/// testing their boxes.
pub const CROWD: usize = 64;

/// Pair tests allowed per object in cells of more than [`CROWD`] objects when every pair is
/// to be tested (`crowd = None`), beyond which such cells are joined untested.
const PAIRS_PER_OBJECT: u64 = 512;

/// SCG97 §7.4: the clusters are the connected components of the graph joining objects whose
/// (closed) boxes intersect, found with union-find. With `delta > 0` the edges join boxes at
/// most `delta` apart along every axis instead, which is EG95 Def. 2's δ-connectivity measured
/// on the boxes themselves rather than on their projections (the distance is the largest gap
/// along an axis; EG95 does not say which distance). The paper sweeps a plane; here the
/// candidate pairs come from a uniform grid of about `2n` cells over the level, each box binned
/// into the cells it meets (the resolution halved while that makes more than `8n` references,
/// so that a few long objects do not fill the grid): only boxes sharing a cell are compared,
/// each pair in one cell only. The cells are compared in parallel, into one union-find shared
/// by the threads; the components do not depend on the order in which pairs join.
///
/// With `crowd = Some(c)` (hugrt's default, 64), a cell holding more than `c` objects (a pile,
/// or a dense patch of objects much smaller than the cells) joins them all without comparing
/// them: objects crowding one cell are as good as connected for a grid, and the comparisons
/// stay within `c·8n`. That is not SCG97's graph: two piles side by side in one cell become
/// one cluster. With `crowd = None` every pair sharing a cell is tested, as the paper's graph
/// asks, within a budget of `512·n + 2^20` tests in cells of more than 64 objects: past it
/// (all `n` objects in one cell would take `n²/2`), the remaining crowded cells are joined
/// untested, so the build cannot hang. `crowded` counts the cells joined untested either way.
pub fn graph_components(
    items: &mut [Item],
    delta: f32,
    crowd: Option<usize>,
    crowded: &mut usize,
) -> Vec<Range<usize>> {
    let n = items.len();
    if n == 0 {
        return Vec::new();
    }
    let parent: Vec<AtomicU32> = (0..n as u32).map(AtomicU32::new).collect();
    // The grid is freed before the items are regrouped (the build's peak memory).
    {
        // Boxes grown by half of δ on every side meet exactly when they were at most δ apart.
        let h = 0.5 * delta.max(0.0);
        // Grown where used rather than copied: a copy of every box was the largest part of
        // the build's peak.
        let grown = |it: &Item| Item {
            lo: it.lo.map(|x| x - h),
            hi: it.hi.map(|x| x + h),
            id: it.id,
        };
        let boxes = &*items;
        let (lo, hi) = boxes
            .par_iter()
            .fold(
                || ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]),
                |(lo, hi), it| {
                    let it = grown(it);
                    (
                        std::array::from_fn(|a| lo[a].min(it.lo[a])),
                        std::array::from_fn(|a| hi[a].max(it.hi[a])),
                    )
                },
            )
            .reduce(
                || ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]),
                |(l0, h0), (l1, h1)| {
                    (
                        std::array::from_fn(|a| l0[a].min(l1[a])),
                        std::array::from_fn(|a| h0[a].max(h1[a])),
                    )
                },
            );
        let extent = glam::Vec3::from_array(std::array::from_fn(|a| hi[a] - lo[a]));
        let mut res = crate::accel::cubical_resolution(extent, 2.0 * n as f64);
        // The cells of a grown box along each axis. Monotone in the coordinate, so the cell
        // of the larger of two coordinates is the larger of their cells.
        let (low, e) = (
            Vec4::new(lo[0], lo[1], lo[2], 0.0),
            Vec4::from((extent, 1.0)),
        );
        let grow = Vec4::new(h, h, h, 0.0);
        let range = |res: [u32; 3], it: &Item| -> ([u32; 3], [u32; 3]) {
            // The three axes at once, each lane `((x ∓ h - lo) / e · res)` clamped to the grid
            // as one axis at a time would make it (the box grown, as `grown` grows it): an
            // axis of no extent gives 0/0, a NaN that `max` turns into 0 (its second
            // operand), where it was tested for apart. One axis at a time, this was nearly a
            // third of the clustering's instructions.
            let r = Vec4::new(res[0] as f32, res[1] as f32, res[2] as f32, 0.0);
            let cell = |x: Vec4| -> [u32; 3] {
                let c = simd::truncate_lanes(((x - low) / e * r).max(Vec4::ZERO));
                std::array::from_fn(|a| (c[a] as u32).min(res[a] - 1))
            };
            let corner = |x: [f32; 3]| Vec4::new(x[0], x[1], x[2], 0.0);
            (cell(corner(it.lo) - grow), cell(corner(it.hi) + grow))
        };
        let volume = |(l, h): ([u32; 3], [u32; 3])| -> u64 {
            (0..3).map(|a| (h[a] - l[a] + 1) as u64).product()
        };
        let refs =
            |res: [u32; 3]| -> u64 { boxes.par_iter().map(|it| volume(range(res, it))).sum() };
        while refs(res) > 8 * n as u64 && res != [1, 1, 1] {
            res = res.map(|r| (r / 2).max(1));
        }
        let cells = res.iter().map(|&r| r as usize).product::<usize>();
        // The cells' objects in object order, as one thread would list them: `k` chunks of
        // the objects each count their cells in a table of their own (a shared table's atomic
        // increments were slower than one thread), then write at their own offsets.
        let k = if n >= 1 << 14 {
            rayon::current_num_threads().clamp(1, 4)
        } else {
            1
        };
        let chunk = |j: usize| &boxes[j * n / k..(j + 1) * n / k];
        let each = |j: usize, f: &mut dyn FnMut(usize, u32)| {
            let first = j * n / k;
            for (i, it) in chunk(j).iter().enumerate() {
                let (l, h) = range(res, it);
                for z in l[2]..=h[2] {
                    for y in l[1]..=h[1] {
                        for x in l[0]..=h[0] {
                            f(((z * res[1] + y) * res[0] + x) as usize, (first + i) as u32);
                        }
                    }
                }
            }
        };
        let mut counts: Vec<Vec<u32>> = (0..k)
            .into_par_iter()
            .map(|j| {
                let mut count = vec![0u32; cells];
                each(j, &mut |c, _| count[c] += 1);
                count
            })
            .collect();
        let size = |c: usize| counts.iter().map(|count| count[c] as usize).sum::<usize>();
        // Which crowded cells are joined untested, decided in cell order so that the budget
        // of `crowd = None` is spent alike on every run.
        let joined: Vec<bool> = match crowd {
            Some(limit) => (0..cells)
                .into_par_iter()
                .map(|c| size(c) > limit)
                .collect(),
            None => {
                let mut budget = PAIRS_PER_OBJECT * n as u64 + (1 << 20);
                (0..cells)
                    .map(|c| {
                        let m = size(c) as u64;
                        m as usize > CROWD
                            && match budget.checked_sub(m * m.saturating_sub(1) / 2) {
                                Some(left) => {
                                    budget = left;
                                    false
                                }
                                None => true,
                            }
                    })
                    .collect()
            }
        };
        *crowded += joined.par_iter().filter(|&&j| j).count();
        // `start[c]`: where cell `c`'s objects begin, none for a cell joined untested; each
        // chunk's count becomes its cursor.
        let mut start = vec![0u32; cells + 1];
        for c in 0..cells {
            let mut at = start[c];
            if !joined[c] {
                for count in &mut counts {
                    (count[c], at) = (at, at + count[c]);
                }
            }
            start[c + 1] = at;
        }
        // The cells joined untested are never listed: they held 777,484 of the four
        // kitchens' 823,107 references and 271,838 of the city's 277,062, listed only to be
        // joined member by member. Instead the cells an object spans are joined to its first
        // such cell (a union-find over the cells, whose joined ones are few and stay in the
        // cache), and then each object to one object of its first cell's component: the same
        // components as joining every member of every such cell, with one union of objects
        // an object rather than one a reference.
        let cell_parent: Vec<AtomicU32> = (0..cells as u32).map(AtomicU32::new).collect();
        let first_joined: Vec<AtomicU32> = (0..n).map(|_| AtomicU32::new(NONE)).collect();
        // Atomic only so that the chunks write their own, interleaved places from safe code:
        // a relaxed store is a plain store.
        let members: Vec<AtomicU32> = (0..start[cells]).map(|_| AtomicU32::new(0)).collect();
        // Each chunk's pairs of cells to join, joined after the fill on one thread: the two
        // threads' unions on the few joined cells' parents contended for their lines.
        let pairs: Vec<Vec<(u32, u32)>> = counts
            .into_par_iter()
            .enumerate()
            .map(|(j, mut cursor)| {
                let (mut object, mut first) = (NONE, NONE);
                // The pairs of cells met lately: neighbouring objects span the same cells.
                let mut recent = [(NONE, NONE); 256];
                let mut pairs = Vec::new();
                each(j, &mut |c, i| {
                    if joined[c] {
                        if object != i {
                            (object, first) = (i, c as u32);
                            first_joined[i as usize].store(first, Relaxed);
                        } else {
                            let slot = &mut recent[(c ^ (first as usize * 7)) & 255];
                            if *slot != (first, c as u32) {
                                *slot = (first, c as u32);
                                pairs.push(*slot);
                            }
                        }
                    } else {
                        members[cursor[c] as usize].store(i, Relaxed);
                        cursor[c] += 1;
                    }
                });
                pairs
            })
            .collect();
        for &(a, b) in pairs.iter().flatten() {
            union(&cell_parent, a, b);
        }
        let representative: Vec<AtomicU32> = (0..cells).map(|_| AtomicU32::new(NONE)).collect();
        (0..n).into_par_iter().with_min_len(1024).for_each(|i| {
            let c = first_joined[i].load(Relaxed);
            if c != NONE {
                let r = &representative[find(&cell_parent, c) as usize];
                // Read before the exchange: a failed exchange still takes the line from the
                // other thread, for every object of a component.
                let other = match r.load(Relaxed) {
                    NONE => match r.compare_exchange(NONE, i as u32, Relaxed, Relaxed) {
                        Ok(_) => return,
                        Err(other) => other,
                    },
                    other => other,
                };
                union(&parent, i as u32, other);
            }
        });
        let touch = |a: &Item, b: &Item| (0..3).all(|k| a.lo[k] <= b.hi[k] && b.lo[k] <= a.hi[k]);
        (0..cells).into_par_iter().with_min_len(1024).for_each_init(
            Vec::new,
            |local: &mut Vec<(Item, [u32; 3])>, c| {
                let m = &members[start[c] as usize..start[c + 1] as usize];
                if m.len() < 2 {
                    return;
                }
                let r = [res[0] as usize, res[1] as usize];
                let here = [c % r[0], c / r[0] % r[1], c / (r[0] * r[1])].map(|x| x as u32);
                local.clear();
                local.extend(m.iter().map(|j| {
                    let it = &boxes[j.load(Relaxed) as usize];
                    (
                        Item {
                            id: j.load(Relaxed),
                            ..grown(it)
                        },
                        range(res, it).0,
                    )
                }));
                // A pair is tested in one of the cells it shares: the one holding the low
                // corner of the boxes' intersection, which lies in both boxes when they meet.
                for (k, (a, ca)) in local.iter().enumerate() {
                    for (b, cb) in &local[k + 1..] {
                        if (0..3).all(|x| ca[x].max(cb[x]) == here[x]) && touch(a, b) {
                            union(&parent, a.id, b.id);
                        }
                    }
                }
            },
        );
    }
    // The clusters in the order of their least object (its root), objects in their order.
    // Every link points to a smaller index (`union`; `find` halves paths to ancestors), so
    // one pass in index order finds each object's root from its parent's, found before it:
    // no `find`, whose halving stores from two threads contended for the same lines (the
    // four kitchens' regrouping took longer on two threads than on one). Then a counting
    // sort by root, which lists each cluster's objects in their order.
    let mut root = Vec::with_capacity(n);
    for (i, p) in parent.into_iter().enumerate() {
        let p = p.into_inner() as usize;
        root.push(if p == i { i as u32 } else { root[p] });
    }
    let mut start = vec![0u32; n + 1];
    for &r in &root {
        start[r as usize + 1] += 1;
    }
    for r in 0..n {
        start[r + 1] += start[r];
    }
    let copy = items.to_vec();
    let mut at = start.clone();
    for (it, &r) in copy.iter().zip(&root) {
        items[at[r as usize] as usize] = *it;
        at[r as usize] += 1;
    }
    (0..n)
        .filter(|&r| start[r + 1] > start[r])
        .map(|r| start[r] as usize..start[r + 1] as usize)
        .collect()
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
        let c = graph_components(&mut items, 0.0, Some(CROWD), &mut 0);
        assert_eq!(ids(&items, &c), vec![vec![0, 1], vec![2], vec![3]]);
        // Within δ of the L along every axis, the lone box joins it.
        let mut near = items.clone();
        assert_eq!(
            graph_components(&mut near, 4.1, Some(CROWD), &mut 0).len(),
            2
        );
        let mut again = items.clone();
        assert_eq!(cluster3d(&mut again, 0.01).len(), 2);
    }

    /// The components of every pair of boxes at most `delta` apart (the largest gap along an
    /// axis, each box grown by half of it as `graph_components` does), by testing all pairs.
    fn brute_components(items: &[Item], delta: f32) -> Vec<Vec<u32>> {
        let mut parent: Vec<usize> = (0..items.len()).collect();
        fn root(p: &mut [usize], mut i: usize) -> usize {
            while p[i] != i {
                i = p[i];
            }
            i
        }
        for i in 0..items.len() {
            for j in i + 1..items.len() {
                let (a, b) = (&items[i], &items[j]);
                let h = 0.5 * delta;
                if (0..3).all(|k| a.lo[k] - h <= b.hi[k] + h && b.lo[k] - h <= a.hi[k] + h) {
                    let (ri, rj) = (root(&mut parent, i), root(&mut parent, j));
                    parent[ri.max(rj)] = ri.min(rj);
                }
            }
        }
        let mut groups = std::collections::BTreeMap::<usize, Vec<u32>>::new();
        for (i, it) in items.iter().enumerate() {
            groups.entry(root(&mut parent, i)).or_default().push(it.id);
        }
        let mut v: Vec<Vec<u32>> = groups.into_values().collect();
        v.sort();
        v
    }

    #[test]
    fn graph_components_are_the_brute_force_components() {
        // Boxes of many sizes (points to a tenth of the scene), in clumps and alone, on a
        // lattice so that faces touch exactly: every pair is tested in one shared cell only,
        // whichever threads run the cells.
        let mut seed = 0x9e37_79b9u32;
        let mut next = |m: u32| {
            seed ^= seed << 13;
            seed ^= seed >> 17;
            seed ^= seed << 5;
            seed % m
        };
        for round in 0..6 {
            let items: Vec<Item> = (0..1500u32)
                .map(|i| {
                    let clump = next(12) as f32 * 8.0;
                    let lo = [0, 1, 2].map(|_| clump + next(64) as f32 * 0.25);
                    let size = match next(10) {
                        0 => next(40) as f32,
                        1 => 0.0,
                        _ => next(4) as f32 * 0.25,
                    };
                    let hi = [0, 1, 2].map(|a| lo[a] + size * (1 + (a as u32 + i) % 2) as f32);
                    item(lo, hi, i)
                })
                .collect();
            for delta in [0.0, 0.3, 2.0] {
                let mut clustered = items.clone();
                let c = graph_components(&mut clustered, delta, None, &mut 0);
                assert_eq!(
                    ids(&clustered, &c),
                    brute_components(&items, delta),
                    "round {round}, delta {delta}"
                );
            }
        }
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
    fn every_pair_is_tested_without_the_crowd_shortcut() {
        // Two piles of 100 boxes, 0.1 apart, share one binning cell (the level spans 1000
        // along x): the shortcut joins them, the paper's graph does not.
        let mut items: Vec<Item> = (0..100).map(|i| cube([0.5; 3], 0.5, i)).collect();
        items.extend((100..200).map(|i| cube([1.6, 0.5, 0.5], 0.5, i)));
        items.extend((200..210).map(|i| cube([100.0 * (i - 199) as f32, 0.5, 0.5], 0.1, i)));
        let mut crowded = 0;
        let shortcut = graph_components(&mut items.clone(), 0.0, Some(CROWD), &mut crowded);
        assert_eq!(shortcut.len(), 11);
        assert!(crowded >= 1);
        let mut crowded = 0;
        let exact = graph_components(&mut items, 0.0, None, &mut crowded);
        assert_eq!(exact.len(), 12);
        assert_eq!(crowded, 0);
    }

    #[test]
    fn budgets_keep_piles_of_overlaps_linear() {
        // 5000 identical boxes: every pair overlaps. Both algorithms finish with one cluster.
        let mut items: Vec<Item> = (0..5000).map(|i| cube([0.0; 3], 1.0, i)).collect();
        assert_eq!(
            graph_components(&mut items, 0.0, Some(CROWD), &mut 0).len(),
            1
        );
        // Testing every pair: 12.5 million pairs in each of the cells the pile fills, past
        // the budget of 3.6 million, so the pile is joined untested.
        let mut crowded = 0;
        assert_eq!(
            graph_components(&mut items, 0.0, None, &mut crowded).len(),
            1
        );
        assert!(crowded >= 1);
        assert_eq!(cluster3d(&mut items, 0.01).len(), 1);
    }
}
