//! What a grid hierarchy is built from: each grid's plan (its items, resolution rule, frame,
//! depth and level), the rule for cutting crowded cells again ([`Subdivision`]), and which
//! objects are referenced by the exact overlap test ([`Prune`]).

use super::MAX_CELLS;
use super::header::GridHeader;
use crate::accel::Frame;
use crate::geometry::{Aabb, Vec3};
use rayon::prelude::*;

/// Cells per axis for a box of side lengths `extent` holding about `cells` cells that are as
/// cubical as possible (Woo, GI'92): side `s = (V / cells)^(1/k)` over the `k` axes of non-zero
/// extent, then `round(extent_i / s)` cells on axis `i`, at least 1.
pub fn cubical_resolution(extent: Vec3, cells: f64) -> [u32; 3] {
    let cells = cells.clamp(1.0, MAX_CELLS);
    let e = extent.as_dvec3();
    let emax = e.max_element();
    if emax.is_nan() || emax <= 0.0 {
        return [1, 1, 1];
    }
    let active: Vec<f64> = e
        .to_array()
        .into_iter()
        .filter(|&x| x > emax * 1e-6)
        .collect();
    let measure: f64 = active.iter().product();
    let side = (measure / cells).powf(1.0 / active.len() as f64);
    let per_axis = (cells.powf(1.0 / active.len() as f64) * 4.0).min(MAX_CELLS);
    e.to_array().map(|x| {
        if x > emax * 1e-6 {
            (x / side).round().clamp(1.0, per_axis) as u32
        } else {
            1
        }
    })
}

/// Cells an item beyond which [`mostly_empty`] stops marking: such boxes are no thin surface
/// (a surface's triangles meet about three cells each at 4 cells an item).
const MARKS_PER_ITEM: u64 = 16;

/// Whether more than half of the cells of a grid over `bounds` with `factor` cells an item
/// (cubical cells, [`cubical_resolution`]) would hold none of `objects`' boxes (`boxes`
/// indexed by object): the cells each box meets ([`GridHeader::cell_range`], as the binning
/// finds them) marked in a bit table, in parallel over chunks of the objects. A chunk that
/// would mark more than [`MARKS_PER_ITEM`] cells for each item a chunk holds stops, and the
/// answer is no: such boxes are no thin surface, and marking them all could take `n²`. The
/// HUG's `world=auto` asks it ([`crate::accel::hug::WorldCells::Auto`]).
pub(crate) fn mostly_empty(boxes: &[Aabb], objects: &[u32], bounds: &Aabb, factor: f64) -> bool {
    if objects.is_empty() || bounds.is_empty() {
        return false;
    }
    let res = cubical_resolution(bounds.extent(), objects.len() as f64 * factor);
    let grid = GridHeader::over(bounds, res);
    occupied_cells(boxes, objects, &grid).is_some_and(|count| 2 * count < grid.cells())
}

/// The densities, in cells an item, that [`filled_density`] chooses among.
const FILLED_DENSITIES: [f64; 6] = [1.0, 2.0, 4.0, 8.0, 16.0, 32.0];

/// The cells an item of a uniform grid over `bounds` for `objects` whose boxes fill it (where
/// [`mostly_empty`] says no): the candidate of [`FILLED_DENSITIES`] whose estimated cost of a
/// ray's walk per unit of length is least. `test` is the cost of testing an object, in units
/// of the walk's step from one cell to the next.
///
/// A random line crosses cells of side `s` at `1.5/s` a unit of length (a cube's mean chord
/// is `2s/3`), each a step. It tests an object once (the walk's mailbox) when it enters the
/// block of cells the object's box meets (box binning, counted without marking), and it
/// enters a convex body in proportion to its surface (Cauchy: a body's mean shadow is a
/// quarter of its area): a block of `a × b × c` cells, area `2s²(ab + bc + ca)`, is met
/// `s²(ab + bc + ca)/2V` a unit of length in a grid of volume `V = cells·s³`. So the cost is
/// proportional to `∛cells·(1 + Σ test·(ab + bc + ca)/3 / cells)` (one cell a box counting
/// 1), and the length a ray walks before its hit, a property of the scene, divides out.
///
/// What decides is how dear a test is: SPD lattice's cylinders and spheres, each tested on its
/// own, render fastest at 8 to 32 cells an object, random triangles, tested eight at a time,
/// at one (docs/measurements.md, "The world grid of objects that fill their box"). Counting
/// every cell a box meets instead, as the estimate first did, counted a long cylinder once
/// for each of its cells a ray crosses: the estimate ran flat from 2 to 32 cells an object
/// on lattice and picked 4, 1.12× behind the best uniform grid; by area it picks 16, and
/// rings' and balls' clusters 8 (renders 0.92, 0.96 and 0.98 of the time). It also gives
/// SPD jacks' nine objects 8 rather than 2, a render of 12 ms that 2 or 4 made up to 1.1×
/// faster: the estimate's lines are random, and nine objects are few to average over
/// (docs/measurements.md, "The estimate of a ray's tests by the area of a box's cells").
pub(crate) fn filled_density(
    boxes: &[Aabb],
    objects: &[u32],
    bounds: &Aabb,
    test: impl Fn(u32) -> f64 + Sync,
) -> f64 {
    if objects.is_empty() || bounds.is_empty() {
        return 1.0;
    }
    let grids = FILLED_DENSITIES.map(|d| {
        GridHeader::over(
            bounds,
            cubical_resolution(bounds.extent(), objects.len() as f64 * d),
        )
    });
    let met = objects
        .par_chunks(1 << 12)
        .map(|part| {
            let mut met = [0.0f64; FILLED_DENSITIES.len()];
            for &i in part {
                let (b, w) = (&boxes[i as usize], test(i));
                for (m, g) in met.iter_mut().zip(&grids) {
                    let (l, h) = g.cell_range(b);
                    let [x, y, z] = [0, 1, 2].map(|a| (h[a] - l[a] + 1) as f64);
                    *m += w * (x * y + y * z + z * x) / 3.0;
                }
            }
            met
        })
        .reduce(
            || [0.0; FILLED_DENSITIES.len()],
            |a, b| std::array::from_fn(|k| a[k] + b[k]),
        );
    let cost = |k: usize| {
        let cells = grids[k].cells() as f64;
        cells.cbrt() * (1.0 + met[k] / cells)
    };
    (0..FILLED_DENSITIES.len())
        .min_by(|&a, &b| cost(a).total_cmp(&cost(b)))
        .map_or(1.0, |k| FILLED_DENSITIES[k])
}

/// How many cells of `grid` the boxes of `objects` meet, or `None` where a chunk of the
/// objects would mark more than [`MARKS_PER_ITEM`] cells an object ([`mostly_empty`]).
fn occupied_cells(boxes: &[Aabb], objects: &[u32], grid: &GridHeader) -> Option<usize> {
    let (res, cells) = (grid.res, grid.cells());
    // A chunk of the objects a task, each with a table of its own: few tables to merge.
    let chunk = objects
        .len()
        .div_ceil(2 * rayon::current_num_threads())
        .max(1 << 12);
    let words = cells.div_ceil(64);
    let (rx, rxy) = (res[0] as usize, res[0] as usize * res[1] as usize);
    let marked = objects
        .par_chunks(chunk)
        .map(|part| {
            let mut bits = vec![0u64; words];
            // The budget of a whole chunk, the last one's too: the last few objects of a
            // list in store order are the other primitives (SPD mount's four spheres after
            // its 8192 triangles), whose few boxes would overdraw a budget of their own.
            let mut budget = MARKS_PER_ITEM * chunk as u64;
            for &i in part {
                let (l, h) = grid.cell_range(&boxes[i as usize]);
                let volume = (0..3).map(|a| (h[a] - l[a] + 1) as u64).product::<u64>();
                budget = budget.checked_sub(volume)?;
                if (h[0] - l[0]) | (h[1] - l[1]) | (h[2] - l[2]) <= 1 {
                    // At most two cells on every axis (nearly every box of a surface at one
                    // cell an item): four rows, each its one or two cells' bits at once, a
                    // row marked twice where an axis has one cell, rather than the loops
                    // below, whose one or two steps an axis vary from box to box (the big
                    // SPD terrain's marking 3.7-4.1 -> 3.0-3.4 ms at two threads).
                    let pair = 1u64 | ((h[0] - l[0]) as u64) << 1;
                    for z in [l[2], h[2]] {
                        for y in [l[1], h[1]] {
                            let c = z as usize * rxy + y as usize * rx + l[0] as usize;
                            bits[c / 64] |= pair << (c % 64);
                            if c % 64 == 63 && pair == 3 {
                                // The second cell opens the next word.
                                bits[c / 64 + 1] |= 1;
                            }
                        }
                    }
                    continue;
                }
                for z in l[2] as usize..=h[2] as usize {
                    for y in l[1] as usize..=h[1] as usize {
                        let row = z * rxy + y * rx;
                        for c in row + l[0] as usize..=row + h[0] as usize {
                            bits[c / 64] |= 1 << (c % 64);
                        }
                    }
                }
            }
            Some(bits)
        })
        .try_reduce(
            || vec![0u64; words],
            |mut a, b| {
                a.iter_mut().zip(&b).for_each(|(x, y)| *x |= y);
                Some(a)
            },
        );
    Some(marked?.iter().map(|w| w.count_ones() as usize).sum())
}

/// Which objects are referenced only from the cells their surface meets (EG95 §1.2.1's
/// pruning; RTNews found it worth 10% at most on the SPD scenes) rather than from every cell
/// their box meets.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Prune {
    /// Every cell the object's box meets (`prune=false`).
    None,
    /// Only the cells its surface meets (`prune=true`).
    All,
    /// Objects whose box spans at least [`Prune::LARGE`] cells: long thin triangles (the
    /// slivers of SPD gears' concave outlines) are where box binning references many cells
    /// the object never meets, and where the exact test pays for itself; for an object within
    /// a few cells it costs more build time than it saves.
    Large,
}

impl Prune {
    pub const LARGE: u64 = 16;

    /// The setting as `hugrt stats` reports it: 0 (false), 1 (true) or the `LARGE` threshold.
    pub(crate) fn stat_value(self) -> f64 {
        match self {
            Prune::None => 0.0,
            Prune::All => 1.0,
            Prune::Large => Prune::LARGE as f64,
        }
    }
}

crate::accel::settings::choice_value!(Prune {
    Prune::None => "false",
    Prune::All => "true",
    Prune::Large => "large",
});

/// How many cells a planned grid gets.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Resolution {
    /// About this many cells, as cubical as possible.
    Cubical(f64),
    /// About this many cells, as many on every axis: EG95 §1.2.2's `∛` criterion,
    /// `n_x = n_y = n_z = ∛cells` (RTNews' "regular" grids, against its heterogeneous ones
    /// whose cells are cubes).
    Regular(f64),
    /// Exactly these cells per axis.
    Fixed([u32; 3]),
}

impl Resolution {
    /// The resolution for `k` objects when `self` counts cells per object (`Cubical` and
    /// `Regular`: RTNews' heterogeneous grids and EG95's `∛` criterion at `d·k` cells);
    /// `Fixed` is the same for any `k` (the octree's 2×2×2).
    pub(crate) fn for_objects(self, k: usize) -> Resolution {
        match self {
            Resolution::Cubical(d) => Resolution::Cubical(d * k as f64),
            Resolution::Regular(d) => Resolution::Regular(d * k as f64),
            fixed @ Resolution::Fixed(_) => fixed,
        }
    }

    pub(super) fn cells_per_axis(self, extent: Vec3) -> [u32; 3] {
        match self {
            Resolution::Cubical(cells) => cubical_resolution(extent, cells),
            Resolution::Regular(cells) => {
                let k = cells.clamp(1.0, MAX_CELLS).cbrt().round().max(1.0) as u32;
                [k; 3]
            }
            Resolution::Fixed(r) => r.map(|x| x.max(1)),
        }
    }
}

/// How crowded cells are gridded again, top-down: Jevans and Wyvill's recursive grid (EG95
/// §1.2.2), EG95's simulated octree, the adaptive grid's sub-voxel grids. A cell referencing
/// more than `maxp` objects gets a grid over its own box (the cell widened by the margin),
/// holding those objects; the cell then references that grid instead of them, so cells of
/// different grids never overlap and each sub-grid is walked from one cell only. (Skipping
/// the grid mailbox for such grids was measured and dropped: ×0.98–1.05 on rgrid and octree,
/// kitchen, stadium and bunny, paired.)
///
/// Termination (EG95 §1.2.2: `maxp` coplanar triangles sharing a point would recurse
/// forever): as in Jevans and Wyvill and EG95, no grid deeper than `max_depth`; and the
/// references and cells of all grids stay within `2·(64·n + 4096)` and the root's cells plus
/// `64·n + 4096`: sub-grids are made level by level and, within a level, in cell order until
/// the next would overflow either budget. Coplanar stacks therefore grow as the papers say
/// they do, explosively, up to that bound. hugrt's own guard (`guard`, not the papers'), off
/// unless asked for: a cell holding every object of its grid is not cut again, since its
/// grid would only repeat the one above; it stops the coplanar case at once, but it also
/// leaves uncut a crowded cell that happens to hold its grid's every object (a cluster
/// beside one large triangle that crosses its cell).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Subdivision {
    pub maxp: usize,
    pub max_depth: u32,
    /// hugrt's guard: a cell holding every object of its grid is not cut again.
    pub guard: bool,
    /// Cells of a cut cell's grid, per object it holds ([`Resolution::for_objects`]).
    pub cells: Resolution,
}

/// One grid to build: what it holds and how finely it is cut.
pub(crate) struct GridPlan {
    /// Store entries binned in the grid, in ascending order.
    pub objects: Vec<u32>,
    /// Grids referenced from its cells (indices in the plan list, each after this one).
    pub children: Vec<u32>,
    pub resolution: Resolution,
    pub frame: Option<Frame>,
    /// Nesting depth in the hierarchy (0 = the root).
    pub depth: u32,
    /// The level the statistics and counters report it under: the filter level of a HUG's
    /// grid (0 = the world's, the largest objects), the depth for the other structures.
    pub level: u32,
    /// Whether the grid's box is the whole scene's (a root) rather than its items'.
    pub scene_box: bool,
    /// Whether its cell planes are moved off the box's round fractions
    /// ([`GridHeader::shift_planes`]: one more cell along axes of 4 or more).
    pub shift: bool,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sphere's surface of small boxes leaves most cells of its box empty; small cubes
    /// filling their box, boxes that overlap everywhere and a lattice of long bars do not.
    #[test]
    fn a_surface_is_mostly_empty_and_filled_volumes_are_not() {
        let cube = |c: Vec3, r: f32| Aabb::new(c - Vec3::splat(r), c + Vec3::splat(r));
        let ids = |n: usize| (0..n as u32).collect::<Vec<u32>>();
        let bounds = |b: &[Aabb]| b.iter().fold(Aabb::EMPTY, |a, x| a.union(x));
        // 40,000 patches on a unit sphere, each about the spacing between them.
        let sphere: Vec<Aabb> = (0..40_000)
            .map(|k| {
                let (u, v) = ((k % 200) as f32 / 200.0, (k / 200) as f32 / 200.0);
                let (theta, phi) = (std::f32::consts::TAU * u, (2.0 * v - 1.0).acos());
                let p = Vec3::new(phi.sin() * theta.cos(), phi.sin() * theta.sin(), phi.cos());
                cube(p, 0.01)
            })
            .collect();
        assert!(mostly_empty(
            &sphere,
            &ids(sphere.len()),
            &bounds(&sphere),
            4.0
        ));
        // 20³ cubes, each filling its share of the box.
        let solid: Vec<Aabb> = (0..8000)
            .map(|k| {
                let c = Vec3::new((k % 20) as f32, (k / 20 % 20) as f32, (k / 400) as f32);
                cube(c, 0.5)
            })
            .collect();
        assert!(!mostly_empty(
            &solid,
            &ids(solid.len()),
            &bounds(&solid),
            4.0
        ));
        // Bars along the three axes through a 10³ lattice of points (SPD lattice's kind).
        let mut bars = Vec::new();
        for a in 0..10 {
            for b in 0..10 {
                let (a, b) = (a as f32, b as f32);
                bars.push(Aabb::new(
                    Vec3::new(0.0, a, b),
                    Vec3::new(9.0, a + 0.1, b + 0.1),
                ));
                bars.push(Aabb::new(
                    Vec3::new(a, 0.0, b),
                    Vec3::new(a + 0.1, 9.0, b + 0.1),
                ));
                bars.push(Aabb::new(
                    Vec3::new(a, b, 0.0),
                    Vec3::new(a + 0.1, b + 0.1, 9.0),
                ));
            }
        }
        assert!(!mostly_empty(&bars, &ids(bars.len()), &bounds(&bars), 4.0));
        // Every box the whole scene: no marking at all (the budget), and not empty.
        let pile = vec![cube(Vec3::ZERO, 1.0); 100_000];
        assert!(!mostly_empty(&pile, &ids(pile.len()), &bounds(&pile), 4.0));
        assert!(!mostly_empty(&pile, &[], &bounds(&pile), 4.0));
    }

    /// Numbers in `[0, 1)` from a xorshift generator seeded with `state`.
    fn uniform(mut state: u64) -> impl FnMut() -> f32 {
        move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 40) as f32 / (1u64 << 24) as f32
        }
    }

    /// The marking counts the cells a brute-force count over every box's cells finds: boxes of
    /// one or two cells an axis (the rows' two bits at once, across the words' ends, the rows
    /// of 67 cells beginning anywhere in a word) and larger ones (the loops).
    #[test]
    fn the_occupied_cells_are_counted_exactly() {
        let grid = GridHeader::over(
            &Aabb::new(Vec3::ZERO, Vec3::new(67.0, 5.0, 3.0)),
            [67, 5, 3],
        );
        let mut next = uniform(0x9e37_79b9_7f4a_7c15);
        let boxes: Vec<Aabb> = (0..300)
            .map(|k| {
                let lo = Vec3::new(67.0 * next(), 5.0 * next(), 3.0 * next());
                // Mostly within a cell or across one plane; every fifth box larger.
                let size = if k % 5 == 0 { 3.0 } else { 0.9 };
                Aabb::new(lo, lo + Vec3::new(next(), next(), next()) * size)
            })
            .collect();
        for n in [1, 7, 40, 300] {
            let ids: Vec<u32> = (0..n).collect();
            let mut expected = std::collections::HashSet::new();
            for b in &boxes[..n as usize] {
                let (l, h) = grid.cell_range(b);
                for z in l[2]..=h[2] {
                    for y in l[1]..=h[1] {
                        for x in l[0]..=h[0] {
                            expected.insert((x, y, z));
                        }
                    }
                }
            }
            assert_eq!(occupied_cells(&boxes, &ids, &grid), Some(expected.len()));
            // Not every cell, so that a lost mark shows.
            assert!(expected.len() < grid.cells());
        }
    }

    /// Random small boxes filling a cube (a soup of triangles, or of spheres): the walk's
    /// steps decide where tests are cheap, the tests where they are dear.
    #[test]
    fn a_filled_box_is_cut_finer_where_tests_are_dear() {
        let mut next = uniform(0x2545_f491_4f6c_dd1d);
        let boxes: Vec<Aabb> = (0..20_000)
            .map(|_| {
                let lo = Vec3::new(next(), next(), next());
                Aabb::new(lo, lo + Vec3::splat(0.03))
            })
            .collect();
        let bounds = boxes.iter().fold(Aabb::EMPTY, |a, b| a.union(b));
        let ids: Vec<u32> = (0..boxes.len() as u32).collect();
        assert!(!mostly_empty(&boxes, &ids, &bounds, 1.0));
        assert_eq!(filled_density(&boxes, &ids, &bounds, |_| 0.3), 1.0);
        assert!(filled_density(&boxes, &ids, &bounds, |_| 3.0) >= 4.0);
    }

    /// Rods across a cube, twelve by twelve along each axis, as SPD lattice's cylinders: a
    /// ray tests a rod once however many of its cells it crosses, so the estimate counts the
    /// area of the block of cells each box meets. Counting the cells, it picked 4 cells an
    /// item here, where lattice renders fastest at 8 to 32.
    #[test]
    fn a_long_object_counts_once_a_ray() {
        let (k, w) = (12, 0.01);
        let mut boxes = Vec::new();
        for i in 0..k {
            for j in 0..k {
                let (a, b) = ((i as f32 + 0.5) / k as f32, (j as f32 + 0.5) / k as f32);
                for axis in 0..3 {
                    let (mut lo, mut hi) = (Vec3::ZERO, Vec3::ONE);
                    let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
                    (lo[u], hi[u], lo[v], hi[v]) = (a - w, a + w, b - w, b + w);
                    boxes.push(Aabb::new(lo, hi));
                }
            }
        }
        let bounds = boxes.iter().fold(Aabb::EMPTY, |a, b| a.union(b));
        let ids: Vec<u32> = (0..boxes.len() as u32).collect();
        assert!(filled_density(&boxes, &ids, &bounds, |_| 3.0) >= 8.0);
    }

    /// A surface of 4096 small boxes, then four cubes of a few cells a side, as a mesh's
    /// triangles come before a few spheres in store order: the surface leaves most cells
    /// empty. The last chunk of the marking holds only the cubes (every chunk holds at least
    /// 4096 objects, whatever the threads), and fails on a budget counted by its own length.
    #[test]
    fn a_few_large_boxes_last_do_not_overdraw_the_budget() {
        let mut boxes: Vec<Aabb> = (0..4096)
            .map(|k| {
                let lo = Vec3::new((k % 64) as f32, (k / 64) as f32, 0.0) / 64.0;
                Aabb::new(lo, lo + Vec3::new(0.01, 0.01, 0.001))
            })
            .collect();
        for c in [0.1, 0.3, 0.5, 0.7] {
            boxes.push(Aabb::new(
                Vec3::new(c, c, 0.0),
                Vec3::new(c + 0.2, c + 0.2, 0.2),
            ));
        }
        let bounds = boxes.iter().fold(Aabb::EMPTY, |a, b| a.union(b));
        let ids: Vec<u32> = (0..boxes.len() as u32).collect();
        assert!(mostly_empty(&boxes, &ids, &bounds, 1.0));
    }
}
