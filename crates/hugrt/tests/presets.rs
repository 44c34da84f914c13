//! The papers' presets build the papers' algorithms: each is checked for the property that
//! defines it on a small scene made for it, and the statistics for their definitions (SCG97
//! §3, Havran Table 2). Agreement with brute force and the same image: `agree.rs` and
//! `render.rs` run every preset (`common::specs`).

mod common;

use common::*;
use hugrt::accel::{AnyAccel, StructureStats};
use hugrt::geometry::{Shape, Vec3};
use hugrt::scene::Scene;

fn stat(st: &StructureStats, key: &str) -> f64 {
    st.entries
        .iter()
        .find(|(k, _)| k == key)
        .unwrap_or_else(|| panic!("no {key}"))
        .1
}

fn stats(scene: &Scene, spec: &str) -> StructureStats {
    AnyAccel::build(scene, spec)
        .unwrap_or_else(|e| panic!("{spec}: {e}"))
        .stats()
}

fn tiny(c: Vec3, s: f32) -> Shape {
    Shape::Triangle([c, c + Vec3::new(s, 0.0, 0.0), c + Vec3::new(0.0, s, s)])
}

/// `k` clusters of 60 equal small triangles, 100 apart along x, over a floor of 180 large
/// triangles of different sizes: with EG95's three equal-count levels the small ones fill the
/// middle level and the large ones the world's.
fn separated_clusters(k: usize) -> Scene {
    let mut r = rng(21);
    let mut shapes = Vec::new();
    for c in 0..k {
        let centre = Vec3::new(100.0 * c as f32, 5.0, 0.0);
        for _ in 0..60 {
            shapes.push(tiny(centre + v3(&mut r, 0.0, 0.6), 0.3));
        }
    }
    for i in 0..(30 * k) {
        let x = -50.0 + (100 * k) as f32 * i as f32 / (30 * k) as f32;
        let s = 20.0 + i as f32;
        shapes.push(Shape::Triangle([
            Vec3::new(x, -10.0, -s),
            Vec3::new(x + s, -10.0, -s),
            Vec3::new(x, -10.0, s),
        ]));
    }
    scene_of(shapes)
}

#[test]
fn eg95_grids_every_separated_cluster() {
    for k in [1, 3, 6] {
        let s = separated_clusters(k);
        let st = stats(&s, "hug:preset=eg95");
        assert_eq!(stat(&st, "clusters_found"), k as f64, "k = {k}");
        assert_eq!(stat(&st, "grids"), k as f64 + 1.0, "k = {k}");
        assert_eq!(stat(&st, "given_back_small"), 0.0);
        // The world grid's cells: the cube-root criterion for 2N, the same count on each axis.
        let world = &st.levels[0];
        let per_axis = (world.cells as f64).cbrt().round();
        assert_eq!(per_axis.powi(3), world.cells as f64, "k = {k}");
    }
}

#[test]
fn eg95_keeps_the_clusters_hugrt_gives_back() {
    // EG95 §4.1's failure case: tiny far-apart objects among huge ones. The paper grids each
    // as a cluster; hugrt's give-back returns them to the world grid.
    let mut r = rng(3);
    let mut shapes: Vec<Shape> = (0..300).map(|_| tiny(v3(&mut r, -1e3, 1e3), 0.5)).collect();
    for i in 0..150 {
        let s = 500.0 + i as f32;
        shapes.push(Shape::Triangle([
            Vec3::new(-s, -1e3, -s),
            Vec3::new(s, -1e3, -s),
            Vec3::new(0.0, -1e3, s),
        ]));
    }
    let s = scene_of(shapes);
    let paper = stats(&s, "hug:preset=eg95");
    assert!(stat(&paper, "grids") > 250.0, "{}", stat(&paper, "grids"));
    assert_eq!(
        stat(&stats(&s, "hug:preset=eg95,giveback=true"), "grids"),
        1.0
    );
}

/// Two piles of 100 small triangles 0.1 apart, ten small ones spread along x up to 1000, and
/// one huge triangle: SCG97's two-level filter puts the small ones in the lower level, where
/// the two piles share one cell of the clustering's grid.
fn adjacent_piles() -> Scene {
    let mut r = rng(8);
    let mut shapes: Vec<Shape> = (0..100).map(|_| tiny(v3(&mut r, 0.0, 0.5), 0.5)).collect();
    shapes.extend((0..100).map(|_| tiny(Vec3::new(1.1, 0.0, 0.0) + v3(&mut r, 0.0, 0.5), 0.5)));
    shapes.extend((1..=10).map(|i| tiny(Vec3::new(100.0 * i as f32, 0.0, 0.0), 0.2)));
    shapes.push(Shape::Triangle([
        Vec3::new(-1000.0, -50.0, -1000.0),
        Vec3::new(2000.0, -50.0, -1000.0),
        Vec3::new(0.0, -50.0, 1000.0),
    ]));
    scene_of(shapes)
}

#[test]
fn scg97_clusters_are_the_components_of_the_box_intersection_graph() {
    let s = adjacent_piles();
    let paper = stats(&s, "hug:preset=scg97");
    assert_eq!(stat(&paper, "clusters_found"), 12.0);
    assert_eq!(stat(&paper, "grids"), 13.0);
    assert_eq!(stat(&paper, "crowded_cells_joined"), 0.0);
    // hugrt's shortcut joins the crowded cell's two piles untested.
    let shortcut = stats(&s, "hug:preset=scg97,crowd=64");
    assert_eq!(stat(&shortcut, "clusters_found"), 11.0);
    assert!(stat(&shortcut, "crowded_cells_joined") >= 1.0);
    assert_agrees(&s, "hug:preset=scg97", &rays_for(&s.bounds(), 4, 400));
}

#[test]
fn scg97_world_grid_has_the_sqrt2_criterion() {
    let s = adjacent_piles();
    let st = stats(&s, "hug:preset=scg97");
    // One large object in the world, 12 grids: sqrt(2)·cbrt(13) = 3.3 cells per axis.
    let world = &st.levels[0];
    assert_eq!(world.cells, 27, "{world:?}");
}

/// A speck of 3,000 tiny triangles inside the box of one large triangle: binned by boxes,
/// every cell round the speck holds every object of its grid.
fn speck_under_a_large_triangle() -> Scene {
    let mut r = rng(12);
    let mut shapes: Vec<Shape> = (0..3000)
        .map(|_| {
            let c = Vec3::new(0.0123, 0.0123, 0.005) + v3(&mut r, 0.0, 1e-3);
            Shape::Triangle([c, c + v3(&mut r, 0.0, 1e-6), c + v3(&mut r, 0.0, 1e-6)])
        })
        .collect();
    shapes.push(Shape::Triangle([
        Vec3::new(-1.0, -1.0, -1.0),
        Vec3::new(1.0, -1.0, 1.0),
        Vec3::new(0.0, 1.0, 0.0),
    ]));
    scene_of(shapes)
}

#[test]
fn a_crowded_cell_is_cut_down_to_the_depth_limit() {
    let s = speck_under_a_large_triangle();
    for (spec, guarded, limit) in [
        ("rgrid", Some("rgrid:guard=true"), 3.0),
        (
            "rgrid:preset=eg95",
            Some("rgrid:preset=eg95,guard=true"),
            5.0,
        ),
        ("octree", Some("octree:guard=true"), 16.0),
    ] {
        let st = stats(&s, spec);
        let levels = stat(&st, "depth");
        assert!(
            levels >= 3.0 && levels <= limit + 1.0,
            "{spec}: {levels} levels"
        );
        // No cell above the depth limit keeps more than MAXP objects: it was cut, the
        // budgets never binding here.
        assert_eq!(stat(&st, "left_uncut_by_budget"), 0.0, "{spec}");
        for l in &st.levels {
            if (l.level as f64) < limit {
                assert!(l.max_o_v <= 50, "{spec}: level {}: {l:?}", l.level);
            }
        }
        // hugrt's guard leaves the speck in one cell.
        if let Some(guarded) = guarded {
            assert_eq!(stat(&stats(&s, guarded), "depth"), 1.0, "{guarded}");
        }
    }
    // With a shallower limit the cutting stops there, the speck's cells still crowded.
    for (spec, limit) in [("rgrid:depth=1", 1), ("octree:depth=6", 6)] {
        let st = stats(&s, spec);
        assert_eq!(st.levels.len(), limit + 1, "{spec}");
        assert!(
            st.levels[limit].max_o_v > 50,
            "{spec}: {:?}",
            st.levels[limit]
        );
    }
    let specs: Vec<String> = ["rgrid", "rgrid:preset=eg95", "octree", "octree:guard=true"]
        .map(String::from)
        .to_vec();
    assert_all_agree(&s, &specs, &rays_for(&s.bounds(), 6, 400));
}

#[test]
fn papers_statistics_follow_their_definitions() {
    let room = hugrt::scene::procedural::clustered_room(12_000, 2);
    for spec in [
        "hug",
        "hug:preset=eg95",
        "hug:preset=scg97",
        "rgrid",
        "rgrid:preset=eg95,maxp=8",
        "octree:maxp=8",
        "grid",
    ] {
        let st = stats(&room, spec);
        for view in [&st.levels, &st.depths] {
            if view.is_empty() {
                continue;
            }
            // SCG97 §3: each object counted once, at the level that stores it.
            let pct_obj: f64 = view.iter().map(|l| l.pct_obj).sum();
            assert!((pct_obj - 100.0).abs() < 1e-9, "{spec}: Σ%obj = {pct_obj}");
            let objects: usize = view.iter().map(|l| l.objects).sum();
            assert_eq!(objects, room.len(), "{spec}");
            for l in view.iter() {
                // The figure tables' μo_g: the share of objects over the share of grids.
                assert!(
                    (l.mu_o_g * l.pct_grids - l.pct_obj).abs() < 1e-9,
                    "{spec}: level {}: {l:?}",
                    l.level
                );
                // (A filter level whose clusters all went back holds no grid.)
                let raw = l.objects as f64 / l.grids.max(1) as f64;
                assert!((l.mu_o_g_raw - raw).abs() < 1e-9, "{spec}: {l:?}");
            }
        }
        // Havran's septet over elementary cells.
        let c = st.census;
        assert!(c.full_cells <= c.cells, "{spec}: {c:?}");
    }
    // The HUG's levels are its filter levels: EG95's three, while the depth view holds the
    // nesting.
    let eg95 = stats(&room, "hug:preset=eg95");
    assert_eq!(eg95.levels.len(), 3);
    assert_eq!(
        eg95.depths.iter().map(|l| l.grids).sum::<usize>(),
        stat(&eg95, "grids") as usize
    );
}

#[test]
fn kdtree_census_counts_leaves() {
    let s = triangle_soup(5, 2000);
    for spec in ["kdtree", "kdtree:preset=havran", "kdtree:split=mid"] {
        let st = stats(&s, spec);
        let (leaves, empty) = (stat(&st, "leaves"), stat(&st, "empty_leaves"));
        assert_eq!(st.census.cells as f64, leaves, "{spec}");
        assert_eq!(st.census.full_cells as f64, leaves - empty, "{spec}");
        assert!(stat(&st, "nodes") > leaves, "{spec}");
    }
}

#[test]
fn havran_cutting_off_empty_space_splits_single_objects_by_eq8() {
    // One small triangle in a large box (held open by a far one): eq. 8 pays, so the tree
    // cuts the empty space around it; without cutting, a node of one object is a leaf.
    let mut r = rng(2);
    let mut shapes: Vec<Shape> = (0..40)
        .map(|i| {
            tiny(
                Vec3::new(10.0 * i as f32, 0.0, 0.0) + v3(&mut r, 0.0, 1.0),
                0.2,
            )
        })
        .collect();
    shapes.push(tiny(Vec3::new(0.0, 300.0, 300.0), 0.2));
    let s = scene_of(shapes);
    let cut = stats(&s, "kdtree:preset=havran");
    let plain = stats(&s, "kdtree:preset=havran,cut=false");
    assert!(
        stat(&cut, "empty_leaves") > stat(&plain, "empty_leaves"),
        "cut {} plain {}",
        stat(&cut, "empty_leaves"),
        stat(&plain, "empty_leaves")
    );
    // Eq. 3 without the bonus builds another tree than with it.
    let bonus = stats(&triangle_soup(9, 3000), "kdtree");
    let eq3 = stats(&triangle_soup(9, 3000), "kdtree:bonus=1");
    assert_ne!(stat(&bonus, "nodes"), stat(&eq3, "nodes"));
    let specs: Vec<String> = [
        "kdtree:preset=havran",
        "kdtree:preset=havran,layout=compact",
    ]
    .map(String::from)
    .to_vec();
    assert_all_agree(&s, &specs, &rays_for(&s.bounds(), 3, 400));
}

#[test]
fn presets_are_overridden_by_keys_and_reject_unknown_names() {
    let s = separated_clusters(3);
    let st = stats(&s, "hug:preset=eg95,world=8");
    assert!(st.levels[0].cells > stats(&s, "hug:preset=eg95").levels[0].cells);
    for spec in [
        "hug:preset=eg96",
        "rgrid:preset=scg97",
        "kdtree:preset=eg95",
    ] {
        let e = AnyAccel::build(&s, spec).err().expect(spec).to_string();
        assert!(e.contains("preset"), "{spec}: {e}");
    }
}

#[test]
fn every_preset_sets_keys_its_structure_has() {
    // A misspelt key in a preset's table would fail every build that names the preset; this
    // says which key, and that each pair cites its paper.
    for (structure, preset) in hugrt::accel::presets::ALL {
        let keys = AnyAccel::keys(structure).unwrap();
        for (key, value, why) in preset.pairs {
            assert!(
                keys.iter().any(|k| k.name == *key),
                "{structure}:preset={}: no key {key}",
                preset.name
            );
            assert!(!why.is_empty(), "{key}={value} cites nothing");
        }
        // Its pairs written out are the preset itself.
        let s = separated_clusters(2);
        let by_name = stats(&s, &format!("{structure}:preset={}", preset.name));
        let by_keys = stats(&s, &format!("{structure}:{}", preset.keys()));
        assert_eq!(
            by_name.entries, by_keys.entries,
            "{structure}:preset={}",
            preset.name
        );
    }
}

/// 2,000 small objects filling a cube, all spheres or all triangles, over a floor of two large
/// triangles: one cluster whose grid holds what it is made of.
fn cube_over_floor(spheres: bool) -> Scene {
    let mut r = rng(5);
    let mut shapes = vec![
        Shape::Triangle([
            Vec3::new(-50.0, -1.0, -50.0),
            Vec3::new(50.0, -1.0, -50.0),
            Vec3::new(-50.0, -1.0, 50.0),
        ]),
        Shape::Triangle([
            Vec3::new(50.0, -1.0, 50.0),
            Vec3::new(-50.0, -1.0, 50.0),
            Vec3::new(50.0, -1.0, -50.0),
        ]),
    ];
    for _ in 0..2000 {
        let c = v3(&mut r, 0.0, 4.0);
        shapes.push(if spheres {
            Shape::Sphere(hugrt::geometry::Sphere {
                center: c,
                radius: 0.1,
            })
        } else {
            Shape::Triangle([c, c + v3(&mut r, -0.2, 0.2), c + v3(&mut r, -0.2, 0.2)])
        });
    }
    scene_of(shapes)
}

/// hugrt's `refine`: a cluster grid of spheres, each tested on its own, gets more cells than
/// `density` gives it; a cluster of triangles keeps `density`, and so does every cluster of the
/// papers' presets.
#[test]
fn a_cluster_of_dear_objects_is_gridded_finer() {
    let cells = |scene: &Scene, spec: &str| {
        let st = stats(scene, spec);
        assert_eq!(
            stat(&st, "grids"),
            2.0,
            "{spec}: the floor's grid and the cube's"
        );
        stat(&st, "cells")
    };
    let spheres = cube_over_floor(true);
    let (finer, as_given) = (cells(&spheres, "hug"), cells(&spheres, "hug:refine=false"));
    assert!(
        finer >= 1.5 * as_given,
        "{finer} cells, {as_given} at density 2"
    );
    let triangles = cube_over_floor(false);
    assert_eq!(
        cells(&triangles, "hug"),
        cells(&triangles, "hug:refine=false")
    );
    for paper in ["hug:preset=eg95", "hug:preset=scg97"] {
        let keys = AnyAccel::resolve(paper).unwrap();
        assert!(keys.contains(&("refine", "false".to_string())), "{paper}");
    }
}
