//! Building the hierarchy: filter → cluster → grid → insert (EG95 §2.1–2.3, SCG97 §7).

use super::cluster::{Item, cluster3d, graph_components};
use super::filter::{Filter, LengthCensus, Level};
use crate::accel::Frame;
use crate::accel::PrimStore;
use crate::accel::hierarchy::{GridPlan, MAX_CELLS, Resolution, filled_density, mostly_empty};
use crate::accel::sort::sort_distinct_indices;
use crate::accel::store::finite;
use crate::geometry::{Aabb, Vec3};
use glam::DMat3;
use rayon::prelude::*;

/// How a level's objects are clustered.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Clustering {
    /// EG95 §2.2: `Isolate` and `Cluster3d` on the projections, δ = α·(level's mean length).
    Cluster3d { alpha: f32 },
    /// SCG97 §7.4: connected components of the box-intersection graph, boxes joined when
    /// less than δ = α·(level's mean length) apart (α = 0: when they intersect). `crowd`:
    /// hugrt's shortcut, objects sharing a binning cell with more than this many others are
    /// joined without a test ([`super::cluster::graph_components`]); `None` tests every pair,
    /// as the paper does.
    Graph { alpha: f32, crowd: Option<usize> },
}

/// The shape of a grid's cells for a given count.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CellShape {
    /// As cubical as possible: cells per axis in proportion to the box's sides (Woo; RTNews'
    /// finding). hugrt's.
    Cubical,
    /// The papers' cube-root criterion: `n_x = n_y = n_z = ∛cells` (EG95 §2.2.3, SCG97 §1.3).
    CubeRoot,
}

/// How many cells the world grid gets for its `N` items.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum WorldCells {
    /// EG95 §2.2.3: `2N` cells.
    TwoN,
    /// SCG97 §1.3: `√2·∛N` cells per axis, `2^1.5·N` in all.
    Sqrt2,
    /// `D·N` cells (the uniform grid's density rule).
    Density(f32),
    /// hugrt's default: 4 cells an item, except where the world grid holds nine tenths of the
    /// objects or more: one cell an item when more than half of its cells would hold nothing
    /// at one cell an item (`mostly_empty`, from the objects' boxes), else the density of
    /// `filled_density`'s estimate. A scene of one size class with no cluster kept is one
    /// uniform grid, and the best density of a uniform grid depends on the scene: surfaces
    /// (the bunny, nefertiti, the big SPD terrain, teapot and tetra, the generated terrain,
    /// SPD mount, sombrero, teapot and tetra, which this rule finds) render as fast or faster
    /// at one cell an item and build in 0.6–0.8 of the time, while for objects filling their
    /// box what a test costs decides: random triangles want one, SPD lattice's cylinders and
    /// spheres eight or more (docs/measurements.md, "The world grid's density on scenes of one
    /// level", "The packets' triangle tests, and a surface beside a small cluster" and "The
    /// world grid of objects that fill their box").
    Auto,
}

/// The share of the objects the world grid must hold itself for [`WorldCells::Auto`] to
/// weigh one cell an item: it is then as good as the only grid. Nefertiti's world grid holds
/// all but a cluster of 16 triangles, the big SPD teapot's all but 202; the kitchen's holds
/// 2% of its objects, the rest in 87 cluster grids.
const ALONE: f64 = 0.9;

/// The world grid's cells an item under [`WorldCells::Auto`] where it holds less than
/// [`ALONE`] of the objects.
pub const WORLD_DENSITY: f64 = 4.0;

/// The cost of testing a triangle, in steps of the walk from one cell to the next, as
/// [`filled_density`] weighs it: a step costs a few tens of instructions, and the eight-lane
/// kernel about as many for eight triangles.
const TRIANGLE_TEST: f64 = 0.3;

/// The same for every other primitive (spheres, cylinders, cones, the scene's own), tested
/// one at a time by its own test.
const OTHER_TEST: f64 = 3.0;

impl WorldCells {
    fn factor(self) -> f64 {
        match self {
            WorldCells::TwoN => 2.0,
            WorldCells::Sqrt2 => 2f64.powf(1.5),
            WorldCells::Density(d) => d as f64,
            WorldCells::Auto => WORLD_DENSITY,
        }
    }
}

/// Where a cluster's grid is referenced (EG95 §2.3.1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Insertion {
    /// Into the cells of the deepest grid that contains it, only.
    Contained,
    /// As EG95 Fig. 9 draws it: also into the cells of every grid it overlaps without being
    /// contained in it (grid 1b in grid 2). The walk reaches it from the enclosing grid
    /// anyway; the extra references only let a ray meet it earlier.
    Fig9,
}

/// Everything that shapes a HUG, as the build reads it: [`super::HugSettings::recipe`] of the
/// settings, whose filter and clustering carry their parameters here.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Recipe {
    pub filter: Filter,
    pub clustering: Clustering,
    pub world: WorldCells,
    /// Cells per item of a cluster grid (EG95: 1, the cube-root rule).
    pub density: f32,
    /// Whether a cluster grid of objects other than triangles may get more cells than
    /// `density`, by the estimate of a ray's cost (`cluster_density`).
    pub refine: bool,
    pub cells: CellShape,
    /// Whether cell planes are moved off the box's round fractions (hugrt's, one more cell
    /// along axes of 4 cells or more: `GridHeader::shift_planes`).
    pub shift: bool,
    /// Whether small and loose clusters are given back to the enclosing grid (hugrt's; the
    /// papers keep every cluster): `min_cluster` and `loose` apply only when it is set.
    pub give_back: bool,
    /// Clusters of fewer objects are given back to the grid they would be inserted into.
    pub min_cluster: usize,
    /// Clusters whose box fills more than this share of the grid they would be inserted into
    /// are given back to it (SCG97 §7.1: a loose cluster only adds a walk).
    pub loose: f32,
    pub pca: bool,
    pub hetero: bool,
    pub insertion: Insertion,
}

/// What the build found, for `hugrt stats`.
#[derive(Clone, Debug, Default)]
pub struct Report {
    pub levels: usize,
    pub clusters: usize,
    pub given_back_small: usize,
    pub given_back_loose: usize,
    pub turned: usize,
    /// Grids referenced by a grid that does not contain them (EG95 Fig. 9's insertion).
    pub partial_insertions: usize,
    /// Crowded binning cells whose objects the graph clustering joined without testing
    /// their boxes (its shortcut, or past its work budget).
    pub crowded_cells: usize,
}

/// A grid being planned: its plan and where it stands in space.
struct Planned {
    plan: GridPlan,
    /// Box of its content in its own frame, and that box's world-space box.
    local: Aabb,
    world: Aabb,
}

impl Planned {
    fn contains(&self, b: &Aabb) -> bool {
        let l = match &self.plan.frame {
            Some(f) => f.local_box(b),
            None => *b,
        };
        self.local.min.cmple(l.min).all() && l.max.cmple(self.local.max).all()
    }

    fn overlaps(&self, b: &Aabb) -> bool {
        let l = match &self.plan.frame {
            Some(f) => f.local_box(b),
            None => *b,
        };
        self.local.overlaps(&l)
    }

    fn volume(&self) -> f64 {
        let e = self.local.extent().as_dvec3();
        e.x * e.y * e.z
    }
}

/// Plans the grids of a HUG over the store entries whose boxes are `boxes` (store order).
/// Grid 0 is the world; every grid comes after the grids that reference it.
///
/// What it holds beside the boxes is kept to 4 bytes an object where it can be, since on a
/// mesh of 10^8 triangles the planning is the build's peak: the list of objects with a finite
/// box is made only when some box is not finite, the lengths go once filtered, and the
/// world's objects are the filter's own list, not a copy.
pub fn plan(store: &PrimStore, boxes: &[Aabb], s: &Recipe) -> (Vec<GridPlan>, Report) {
    // One pass over the boxes: whether every box is finite, the union of the finite ones (the
    // world's box) and the census of their lengths. Where the census shows every object in
    // one level (a mesh of one size class), that level is the world's and no list of lengths
    // is made: on the big SPD terrain, the finiteness, the lengths, the world's box and the
    // filter had been four passes, 4.8-5.3 ms of a 46 ms build at two threads.
    let (all_finite, world_box, census) = boxes
        .par_chunks(1 << 14)
        .map(|chunk| {
            let (mut all, mut union, mut census) = (true, Aabb::EMPTY, LengthCensus::default());
            for b in chunk {
                if finite(b) {
                    union = union.union(b);
                    census.add(b.diagonal());
                } else {
                    all = false;
                }
            }
            (all, union, census)
        })
        .reduce(
            || (true, Aabb::EMPTY, LengthCensus::default()),
            |(a, u, c), (b, v, d)| (a && b, u.union(&v), c.merge(&d)),
        );
    let binned: Vec<u32> = if all_finite {
        Vec::new()
    } else {
        (0..boxes.len() as u32)
            .into_par_iter()
            .filter(|&i| finite(&boxes[i as usize]))
            .collect()
    };
    // Store entry of the `k`-th object with a finite box.
    let entry = |k: u32| if all_finite { k } else { binned[k as usize] };
    let finite_count = if all_finite {
        boxes.len()
    } else {
        binned.len()
    };
    let mut levels = match s.filter.one_level_mean(&census) {
        Some(mean_length) => vec![Level {
            objects: (0..finite_count as u32).into_par_iter().collect(),
            mean_length,
        }],
        None => {
            let lengths: Vec<f32> = (0..finite_count as u32)
                .into_par_iter()
                .map(|k| boxes[entry(k) as usize].diagonal())
                .collect();
            s.filter.apply_counted(&census, &lengths)
        }
    };
    let mut report = Report {
        levels: levels.len(),
        ..Report::default()
    };
    // The world: the largest objects (and, if they are all one level, everything).
    let world_objects: Vec<u32> = levels
        .last_mut()
        .map(|l| {
            let mut objects = std::mem::take(&mut l.objects);
            objects.iter_mut().for_each(|k| *k = entry(*k));
            objects
        })
        .unwrap_or_default();
    let mut grids = vec![Planned {
        plan: GridPlan {
            objects: world_objects,
            children: Vec::new(),
            resolution: Resolution::Cubical(1.0),
            frame: None,
            depth: 0,
            level: 0,
            scene_box: true,
            shift: s.shift,
        },
        local: world_box,
        world: world_box,
    }];
    // EG95 §2.3.1: the other levels in decreasing order of size, each cluster's grid
    // inserted below the deepest grid that contains it.
    // The levels are clustered independently of each other, so all at once; only the
    // insertion below depends on the order of the levels.
    let clustered: Vec<(Vec<Item>, Vec<std::ops::Range<usize>>, usize)> = levels
        .par_iter()
        .rev()
        .skip(1)
        .map(|level| {
            let mut items: Vec<Item> = level
                .objects
                .iter()
                .map(|&k| {
                    let i = entry(k);
                    let b = &boxes[i as usize];
                    Item {
                        lo: b.min.to_array(),
                        hi: b.max.to_array(),
                        id: i,
                    }
                })
                .collect();
            let mut crowded = 0;
            let clusters = match s.clustering {
                Clustering::Cluster3d { alpha } => cluster3d(&mut items, alpha * level.mean_length),
                Clustering::Graph { alpha, crowd } => {
                    graph_components(&mut items, alpha * level.mean_length, crowd, &mut crowded)
                }
            };
            (items, clusters, crowded)
        })
        .collect();
    let mut marks = Vec::new();
    for (from_top, (items, clusters, crowded)) in clustered.into_iter().enumerate() {
        report.clusters += clusters.len();
        report.crowded_cells += crowded;
        let index = ContainerIndex::new(&grids);
        for range in clusters {
            let objects: Vec<u32> = items[range].iter().map(|it| it.id).collect();
            let world = objects
                .iter()
                .fold(Aabb::EMPTY, |a, &i| a.union(&boxes[i as usize]));
            let parent = index.deepest_container(&grids, &world);
            let frame = if s.pca {
                pca_frame(store, boxes, &objects)
            } else {
                None
            };
            let local = match &frame {
                Some(f) => objects.iter().fold(Aabb::EMPTY, |a, &i| {
                    a.union(&store.local_bounds(i, f, &boxes[i as usize]))
                }),
                None => world,
            };
            let candidate = Planned {
                plan: GridPlan {
                    objects,
                    children: Vec::new(),
                    resolution: Resolution::Cubical(1.0),
                    frame,
                    depth: grids[parent].plan.depth + 1,
                    level: from_top as u32 + 1,
                    scene_box: false,
                    shift: s.shift,
                },
                local,
                world: frame.map_or(world, |f| f.world_box(&local)),
            };
            let small = s.give_back && candidate.plan.objects.len() < s.min_cluster;
            let loose = s.give_back && candidate.volume() > s.loose as f64 * grids[parent].volume();
            if small || loose {
                report.given_back_small += small as usize;
                report.given_back_loose += (loose && !small) as usize;
                let objects = candidate.plan.objects;
                grids[parent].plan.objects.extend(objects);
                continue;
            }
            report.turned += candidate.plan.frame.is_some() as usize;
            let g = grids.len() as u32;
            grids[parent].plan.children.push(g);
            if s.insertion == Insertion::Fig9 {
                report.partial_insertions +=
                    partial_insert(&mut grids, &mut marks, parent, g, &candidate.world);
            }
            grids.push(candidate);
        }
    }
    let world_factor = match s.world {
        WorldCells::Auto if grids[0].plan.objects.len() as f64 >= ALONE * finite_count as f64 => {
            let (objects, world) = (&grids[0].plan.objects, &grids[0].world);
            if mostly_empty(boxes, objects, world, 1.0) {
                1.0
            } else {
                let triangles = store.triangle_count() as u32;
                filled_density(boxes, objects, world, |i| {
                    if i < triangles {
                        TRIANGLE_TEST
                    } else {
                        OTHER_TEST
                    }
                })
            }
        }
        w => w.factor(),
    };
    let plans = grids
        .into_iter()
        .enumerate()
        .map(|(g, mut p)| {
            sort_distinct_indices(&mut p.plan.objects, boxes.len());
            let items = (p.plan.objects.len() + p.plan.children.len()) as f64;
            let cells = items
                * if g == 0 {
                    world_factor
                } else {
                    cluster_density(store, boxes, &p, s)
                };
            p.plan.resolution = if s.hetero {
                Resolution::Fixed(heterogeneous_resolution(
                    store,
                    boxes,
                    &p.plan.objects,
                    p.plan.frame.as_ref(),
                    cells,
                ))
            } else {
                match s.cells {
                    CellShape::Cubical => Resolution::Cubical(cells),
                    CellShape::CubeRoot => Resolution::Regular(cells),
                }
            };
            p.plan
        })
        .collect();
    (plans, report)
}

/// The cells an item of a cluster's grid: `density`, or with `refine` more where the cluster
/// holds objects other than triangles and [`filled_density`]'s estimate of a ray's cost in a
/// grid over the cluster's box says that fewer tests repay more cells: the rule of the world
/// grid of one size class (`WorldCells::Auto`), which the papers' presets do not apply.
///
/// Spheres and cylinders, each tested on its own, cost about three steps of the walk
/// ([`OTHER_TEST`]; a fit of the uniform grid's time a ray to its counters gave 2.8 on SPD
/// jacks and 3.4 on lattice), and their clusters render faster in finer grids: SPD tree's,
/// balls' and rings' clusters get 8 cells an item (tree's and balls' renders 0.82–0.88 and
/// 0.86–0.94 of the time at 2, when balls' got 4 by an estimate that counted cells rather
/// than areas). A cluster of triangles alone keeps `density`: tested eight at a time, the
/// estimate never gave one more cells on the scenes measured, and asking it of every
/// cluster took the four kitchens' build (113,000 clustered triangles) from 32–33 to 36–41
/// ms. A grid in a frame of its own keeps it too (the estimate reads world boxes). Measured in
/// docs/measurements.md, "Cluster grids of dear objects cut finer".
fn cluster_density(store: &PrimStore, boxes: &[Aabb], p: &Planned, s: &Recipe) -> f64 {
    let density = s.density as f64;
    let triangles = store.triangle_count() as u32;
    // The objects are sorted, and a store lists its triangles first.
    let others = p.plan.objects.last().is_some_and(|&i| i >= triangles);
    if !s.refine || !others || p.plan.frame.is_some() {
        return density;
    }
    let cost = |i: u32| {
        if i < triangles {
            TRIANGLE_TEST
        } else {
            OTHER_TEST
        }
    };
    filled_density(boxes, &p.plan.objects, &p.world, cost).max(density)
}

/// EG95 Fig. 9's extra references: grid `g` (box `b`), inserted below `parent`, is also
/// referenced by the parent's other children that it overlaps without being inside, and so on
/// down. Grids can be reached along several paths of such references; `marks` (one stamp per
/// grid, `g` marking the grids already done for `g`) keeps each visited once.
fn partial_insert(
    grids: &mut [Planned],
    marks: &mut Vec<u32>,
    parent: usize,
    g: u32,
    b: &Aabb,
) -> usize {
    let mut inserted = 0;
    marks.resize(grids.len(), u32::MAX);
    let mut stack = vec![parent];
    while let Some(p) = stack.pop() {
        for k in 0..grids[p].plan.children.len() {
            let c = grids[p].plan.children[k] as usize;
            if c as u32 == g || marks[c] == g {
                continue;
            }
            marks[c] = g;
            if grids[c].overlaps(b) && !grids[c].contains(b) {
                grids[c].plan.children.push(g);
                stack.push(c);
                inserted += 1;
            }
        }
    }
    inserted
}

/// Finds, for a box, the smallest grid planned so far that contains it: the deepest one,
/// since a grid lies inside every grid above it. A uniform grid over the planned grids' boxes
/// answers it from the cell of the box's centre, so that a scene of many clusters is not
/// quadratic.
struct ContainerIndex {
    bounds: Aabb,
    res: [u32; 3],
    inv: Vec3,
    start: Vec<u32>,
    ids: Vec<u32>,
}

impl ContainerIndex {
    fn new(grids: &[Planned]) -> Self {
        let bounds = grids[0].world;
        let extent = bounds.extent().max(Vec3::splat(f32::MIN_POSITIVE));
        let mut res = crate::accel::cubical_resolution(extent, grids.len() as f64);
        let range = |res: [u32; 3], b: &Aabb| {
            let r = Vec3::new(res[0] as f32, res[1] as f32, res[2] as f32);
            let inv = r / extent;
            let c = |x: Vec3, a: usize| {
                (((x[a] - bounds.min[a]) * inv[a]).max(0.0) as u32).min(res[a] - 1)
            };
            (
                [0, 1, 2].map(|a| c(b.min, a)),
                [0, 1, 2].map(|a| c(b.max, a)),
            )
        };
        let count = |res: [u32; 3]| -> u64 {
            grids
                .iter()
                .map(|g| {
                    let (lo, hi) = range(res, &g.world);
                    (0..3).map(|a| (hi[a] - lo[a] + 1) as u64).product::<u64>()
                })
                .sum()
        };
        while count(res) > 64 * grids.len() as u64 + 4096 && res != [1, 1, 1] {
            res = res.map(|r| (r / 2).max(1));
        }
        let cells = res.iter().map(|&r| r as usize).product::<usize>();
        let index = |c: [u32; 3]| ((c[2] * res[1] + c[1]) * res[0] + c[0]) as usize;
        let mut start = vec![0u32; cells + 1];
        let each = |f: &mut dyn FnMut(usize, u32)| {
            for (g, p) in grids.iter().enumerate() {
                let (lo, hi) = range(res, &p.world);
                for z in lo[2]..=hi[2] {
                    for y in lo[1]..=hi[1] {
                        for x in lo[0]..=hi[0] {
                            f(index([x, y, z]), g as u32);
                        }
                    }
                }
            }
        };
        each(&mut |c, _| start[c + 1] += 1);
        for c in 0..cells {
            start[c + 1] += start[c];
        }
        let mut ids = vec![0u32; start[cells] as usize];
        let mut cursor = start.clone();
        each(&mut |c, g| {
            ids[cursor[c] as usize] = g;
            cursor[c] += 1;
        });
        let r = Vec3::new(res[0] as f32, res[1] as f32, res[2] as f32);
        ContainerIndex {
            bounds,
            res,
            inv: r / extent,
            start,
            ids,
        }
    }

    fn deepest_container(&self, grids: &[Planned], b: &Aabb) -> usize {
        let p = b.center();
        let c: [u32; 3] = [0, 1, 2].map(|a| {
            (((p[a] - self.bounds.min[a]) * self.inv[a]).max(0.0) as u32).min(self.res[a] - 1)
        });
        let cell = ((c[2] * self.res[1] + c[1]) * self.res[0] + c[0]) as usize;
        self.ids[self.start[cell] as usize..self.start[cell + 1] as usize]
            .iter()
            .map(|&g| g as usize)
            .filter(|&g| grids[g].contains(b))
            .min_by(|&a, &b| grids[a].volume().total_cmp(&grids[b].volume()))
            .unwrap_or(0)
    }
}

/// Points that stand for an object when fitting a frame: a triangle's vertices, the corners
/// of anything else's box.
fn object_points(store: &PrimStore, boxes: &[Aabb], s: u32, out: &mut Vec<Vec3>) {
    if let Some(v) = store.triangle(s) {
        out.extend_from_slice(&v);
    } else {
        let b = &boxes[s as usize];
        for k in 0..8 {
            out.push(Vec3::new(
                if k & 1 == 0 { b.min.x } else { b.max.x },
                if k & 2 == 0 { b.min.y } else { b.max.y },
                if k & 4 == 0 { b.min.z } else { b.max.z },
            ));
        }
    }
}

/// SCG97 §7.2: the frame of the principal axes of the cluster's points (eigenvectors of their
/// covariance matrix), centred on the cluster's box. The paper found such boxes often no
/// tighter than the axis-aligned one (interior points pull the axes); hugrt keeps the turned
/// frame only when the cluster's box in it has the smaller surface area, the quantity that
/// decides how many rays enter it.
fn pca_frame(store: &PrimStore, boxes: &[Aabb], objects: &[u32]) -> Option<Frame> {
    let mut pts = Vec::new();
    for &s in objects {
        object_points(store, boxes, s, &mut pts);
    }
    if pts.len() < 4 {
        return None;
    }
    let n = pts.len() as f64;
    let mean = pts.iter().fold(glam::DVec3::ZERO, |a, p| a + p.as_dvec3()) / n;
    let mut cov = DMat3::ZERO;
    for p in &pts {
        let d = p.as_dvec3() - mean;
        cov += DMat3::from_cols(d * d.x, d * d.y, d * d.z);
    }
    let axes = symmetric_eigenvectors(cov / n)?;
    let aabb = objects
        .iter()
        .fold(Aabb::EMPTY, |a, &i| a.union(&boxes[i as usize]));
    let frame = Frame {
        origin: aabb.center(),
        axes: axes.map(|a| a.as_vec3()),
    };
    let local = objects.iter().fold(Aabb::EMPTY, |a, &i| {
        a.union(&store.local_bounds(i, &frame, &boxes[i as usize]))
    });
    (local.surface_area() < aabb.surface_area()).then_some(frame)
}

/// Orthonormal eigenvectors of a symmetric 3×3 matrix by cyclic Jacobi rotations; `None` for a
/// matrix with non-finite entries.
fn symmetric_eigenvectors(m: DMat3) -> Option<[glam::DVec3; 3]> {
    let mut a = m.to_cols_array_2d();
    if a.iter().flatten().any(|x| !x.is_finite()) {
        return None;
    }
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0f64]];
    for _ in 0..32 {
        let off = a[0][1].abs() + a[0][2].abs() + a[1][2].abs();
        if off <= 1e-15 * (a[0][0].abs() + a[1][1].abs() + a[2][2].abs()) {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if a[p][q] == 0.0 {
                continue;
            }
            let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let t = if theta == 0.0 { 1.0 } else { t };
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            for row in &mut a {
                let (akp, akq) = (row[p], row[q]);
                row[p] = c * akp - s * akq;
                row[q] = s * akp + c * akq;
            }
            let (rp, rq) = (a[p], a[q]);
            a[p] = std::array::from_fn(|k| c * rp[k] - s * rq[k]);
            a[q] = std::array::from_fn(|k| s * rp[k] + c * rq[k]);
            for row in &mut v {
                let (vp, vq) = (row[p], row[q]);
                row[p] = c * vp - s * vq;
                row[q] = s * vp + c * vq;
            }
        }
    }
    let cols = [0, 1, 2].map(|j| glam::DVec3::new(v[0][j], v[1][j], v[2][j]).normalize());
    // Re-orthonormalise against rounding: e0, e1 ⟂ e0, e2 = e0 × e1.
    let e0 = cols[0];
    let e1 = (cols[1] - e0 * e0.dot(cols[1])).normalize();
    let e2 = e0.cross(e1);
    [e0, e1, e2]
        .iter()
        .all(|e| e.is_finite())
        .then_some([e0, e1, e2])
}

/// SCG97 Def. 4: the overlap number of a set of intervals, the sum over all endpoints of the
/// number of other intervals whose interior contains it.
fn overlap_number(mut intervals: Vec<(f32, f32)>) -> f64 {
    // Each interval contains the endpoints that come after its start and before its end: by
    // sweeping sorted endpoints, an endpoint meets the intervals open at that moment.
    let mut events: Vec<(f32, bool)> = Vec::with_capacity(2 * intervals.len());
    for (lo, hi) in intervals.drain(..) {
        events.push((lo, true));
        events.push((hi, false));
    }
    events.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(b.1.cmp(&a.1)));
    let (mut open, mut sum) = (0i64, 0f64);
    for (_, start) in events {
        if start {
            sum += open as f64;
            open += 1;
        } else {
            open -= 1;
            sum += open as f64;
        }
    }
    sum
}

/// SCG97 §7.3, heterogeneous gridding: `n_i = N^β_i` cells along axis `i`, `Σβ_i = 1`, with
/// `β_i` decreasing in the axis's overlap number `o_i`. The paper leaves the function open (and
/// found none that paid). hugrt takes the overlap ratio `r_i = o_i / o_max` (`o_max = m(m−1)`,
/// the overlap number of `m` nested intervals) and `β_i ∝ 2 − r_i`, so `β_i` stays within
/// `[1/5, 1/2]`: an axis along which the objects are spread out gets more cells, one along
/// which they all overlap fewer, and no axis all of them (a first choice, `β_i ∝ 1 − r_i`,
/// gave SPD shells, where every axis overlaps, a slab grid 45 times slower). The factor
/// `N^(β_i − 1/3)` is applied to the cubical counts, which keeps the total and the box's shape
/// (the paper's bare `N^β_i` ignores it); flat axes keep one cell.
fn heterogeneous_resolution(
    store: &PrimStore,
    boxes: &[Aabb],
    objects: &[u32],
    frame: Option<&Frame>,
    cells: f64,
) -> [u32; 3] {
    let local: Vec<Aabb> = objects
        .iter()
        .map(|&s| match frame {
            Some(f) => store.local_bounds(s, f, &boxes[s as usize]),
            None => boxes[s as usize],
        })
        .collect();
    let m = local.len() as f64;
    let bounds = local.iter().fold(Aabb::EMPTY, |a, b| a.union(b));
    let extent = bounds.extent();
    let cubical = crate::accel::cubical_resolution(extent, cells);
    let o_max = (m * (m - 1.0)).max(1.0);
    let w: [f64; 3] = std::array::from_fn(|a| {
        let o = overlap_number(local.iter().map(|b| (b.min[a], b.max[a])).collect());
        2.0 - (o / o_max).min(1.0)
    });
    let total: f64 = w.iter().sum();
    let n = cells.clamp(1.0, MAX_CELLS);
    std::array::from_fn(|a| {
        if cubical[a] <= 1 {
            return 1;
        }
        let beta = w[a] / total;
        ((cubical[a] as f64 * n.powf(beta - 1.0 / 3.0)).round() as u32).max(1)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn overlap_number_of_the_papers_example() {
        // SCG97 Fig. 26(b): three intervals whose six endpoints lie in 0, 1, 2, 2, 1, 0
        // interiors of the others.
        let o = overlap_number(vec![(0.0, 4.0), (1.0, 5.0), (2.0, 3.0)]);
        assert_eq!(o, 6.0);
        assert_eq!(overlap_number(vec![(0.0, 1.0), (2.0, 3.0)]), 0.0);
    }

    #[test]
    fn jacobi_finds_the_axes_of_a_turned_ellipsoid() {
        let r = DMat3::from_rotation_z(0.5) * DMat3::from_rotation_x(0.3);
        let d = DMat3::from_diagonal(glam::DVec3::new(9.0, 4.0, 1.0));
        let m = r * d * r.transpose();
        let e = symmetric_eigenvectors(m).unwrap();
        for v in e {
            let mv = m * v;
            let lambda = v.dot(mv);
            assert!(
                (mv - v * lambda).length() < 1e-9,
                "{v} is not an eigenvector"
            );
        }
        assert!((e[0].cross(e[1]) - e[2]).length() < 1e-12);
    }
}
