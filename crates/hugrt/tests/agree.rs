//! Every structure against brute force, on random and adversarial scenes and rays.

mod common;

use common::*;
use proptest::prelude::*;
use rand::Rng;

/// Every structure against brute force on `n_rays` awkward rays and an eighth as many in
/// coherent groups of eight, alone and in packets ([`hugrt::fuzzing::assert_packets_agree`]).
fn check_all(scene: &hugrt::scene::Scene, ray_seed: u64, n_rays: usize) {
    let mut rays = rays_for(&scene.bounds(), ray_seed, n_rays);
    rays.extend(bundles_for(&scene.bounds(), ray_seed ^ 7, n_rays / 64 + 1));
    assert_all_agree(scene, &specs(), &rays);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    #[test]
    fn random_triangle_soups(seed in any::<u64>(), n in 1usize..400) {
        check_all(&triangle_soup(seed, n), seed ^ 1, 400);
    }

    #[test]
    fn clustered_soups(seed in any::<u64>(), n in 1usize..600) {
        check_all(&clustered_soup(seed, n), seed ^ 2, 400);
    }

    #[test]
    fn axis_aligned_and_coplanar(seed in any::<u64>(), n in 1usize..300) {
        check_all(&axis_aligned(seed, n), seed ^ 3, 600);
    }

    #[test]
    fn turned_clusters_of_thin_slabs(seed in any::<u64>(), n in 1usize..500) {
        check_all(&turned_clusters(seed, n), seed ^ 5, 400);
    }

    #[test]
    fn spheres_cones_polygons(seed in any::<u64>(), n in 1usize..200) {
        check_all(&mixed(seed, n), seed ^ 4, 400);
    }
}

#[test]
fn empty_and_single_primitive_scenes() {
    for n in [0, 1] {
        let s = triangle_soup(7, n);
        check_all(&s, 5, 200);
        assert_eq!(s.len(), n);
    }
}

/// Over 4,096 triangles: the bvh flattens its larger subtrees side by side, each into its own
/// part of the lists (the property tests' scenes are too small for that).
#[test]
fn a_scene_large_enough_to_flatten_in_parallel() {
    let s = triangle_soup(11, 12_000);
    check_all(&s, 13, 2_000);
}

/// A camera `at` the given offset from the scene's centre (in scene sizes), looking at the
/// centre: its eye and the unnormalised directions of a `w × h` image spanning `spread`.
fn camera(
    scene: &hugrt::scene::Scene,
    at: hugrt::geometry::Vec3,
    (w, h): (usize, usize),
    spread: (f32, f32),
) -> (hugrt::geometry::Vec3, Vec<hugrt::geometry::Vec3>) {
    use hugrt::geometry::Vec3;
    let b = scene.bounds();
    let (c, size) = (b.center(), b.diagonal().max(1e-3));
    let eye = c + at * size;
    let forward = (c - eye).normalize();
    let right = forward.cross(Vec3::Y).normalize();
    let up = right.cross(forward);
    let dirs = (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f32 / w as f32, (i / w) as f32 / h as f32);
            forward + right * (x - 0.5) * spread.0 + up * (0.5 - y) * spread.1
        })
        .collect();
    (eye, dirs)
}

/// A camera's rays row by row, and rays from points in the scene to a far light, each list
/// as a batch: the batch queries walk the first in tiles and the second sorted by direction
/// (`accel::order`), and every ray gets brute force's answer, and alone the same as in its
/// packet.
#[test]
fn camera_and_light_rays_in_the_orders_packets_take() {
    use hugrt::geometry::{Ray, Vec3};
    let scenes = [
        triangle_soup(21, 300),
        clustered_soup(22, 400),
        axis_aligned(23, 200),
        mixed(24, 150),
    ];
    for (k, scene) in scenes.iter().enumerate() {
        let b = scene.bounds();
        let (c, size) = (b.center(), b.diagonal().max(1e-3));
        // Odd sizes, so that tiles are cut at the right and the bottom.
        let (eye, dirs) = camera(scene, Vec3::new(0.3, 0.4, -1.5), (37, 21), (0.8, 0.5));
        let camera: Vec<Ray> = dirs
            .into_iter()
            .map(|d| Ray::new(eye, d, 0.0, f32::INFINITY))
            .collect();
        assert_all_agree(scene, &specs(), &camera);
        let light = c + Vec3::new(7.0, 11.0, 9.0) * size;
        let mut r = rng(k as u64);
        let shadow: Vec<Ray> = (0..700)
            .map(|_| {
                let o = b.min + b.extent() * v3(&mut r, 0.0, 1.0);
                Ray::new(o, light - o, 1e-4, 1.0)
            })
            .collect();
        assert_all_agree(scene, &specs(), &shadow);
    }
}

/// A camera's rays with rays that cannot be walked in a packet among them (no direction, a NaN,
/// an origin far outside the scene, subnormal direction components): with `auto` the group is
/// judged coherent on the rays the packet walks, and every ray still gets brute force's answer
/// and, in its packet, its answer alone ([`hugrt::fuzzing::assert_packets_agree`]).
#[test]
fn camera_groups_with_rays_that_walk_alone() {
    use hugrt::accel::{AnyAccel, NoCounters};
    use hugrt::geometry::{Ray, Vec3};
    let scene = clustered_soup(31, 500);
    let c = scene.bounds().center();
    let (eye, dirs) = camera(&scene, Vec3::new(0.2, -0.3, -1.4), (40, 24), (0.6, 0.4));
    let mut rays: Vec<Ray> = dirs
        .into_iter()
        .map(|d| Ray::new(eye, d, 0.0, f32::INFINITY))
        .collect();
    for (k, ray) in rays.iter_mut().enumerate().skip(3).step_by(11) {
        *ray = match k % 4 {
            0 => Ray::new(eye, Vec3::ZERO, 0.0, f32::INFINITY),
            1 => Ray::new(eye, Vec3::new(f32::NAN, 1.0, 0.0), 0.0, f32::INFINITY),
            2 => Ray::new(c - ray.dir.normalize() * 1e12, ray.dir, 0.0, f32::INFINITY),
            _ => Ray::new(eye, Vec3::new(ray.dir.x, 1e-41, ray.dir.z), 0.0, 1e30),
        };
    }
    assert_all_agree(&scene, &specs(), &rays);
    let brute = AnyAccel::build(&scene, "brute").unwrap();
    let hits = rays
        .iter()
        .filter(|r| brute.any_hit(&scene, r, &mut NoCounters).is_some())
        .count();
    assert!(
        hits > rays.len() / 4,
        "the camera sees the scene: {hits} hits"
    );
}

/// A camera's rays with their directions scaled down towards the least normal `f32`, and with
/// one component made tiny: `t` grows as the direction shrinks, and where the crossing's `t`
/// is past `f32::MAX` it is no hit (a `t` of infinity is not a point on the ray). Brute force
/// once reported such crossings at `t = ∞` while every structure, whose cells end at finite
/// `t`, found nothing; and the grids' walks missed hits at finite `t` where a plane's
/// parameter, counted from the grid's corner, overflowed (`hierarchy::walk`'s `Axis`).
#[test]
fn tiny_directions_hit_at_a_finite_t_or_not_at_all() {
    use hugrt::accel::{AnyAccel, NoCounters};
    use hugrt::geometry::{Ray, Vec3};
    for scene in [clustered_soup(41, 400), mixed(42, 120)] {
        let (eye, camera) = camera(&scene, Vec3::new(0.3, -0.2, -1.5), (24, 16), (0.5, 0.3));
        let brute = AnyAccel::build(&scene, "brute").unwrap();
        let mut seen = Vec::new();
        for scale in [1e-30, 1e-35, 3e-37, 2e-38, f32::MIN_POSITIVE] {
            let rays: Vec<Ray> = camera
                .iter()
                .map(|&d| Ray::new(eye, d * scale, 0.0, f32::INFINITY))
                .collect();
            assert_all_agree(&scene, &specs(), &rays);
            let hits: Vec<_> = rays
                .iter()
                .filter_map(|r| brute.closest_hit(&scene, r, &mut NoCounters))
                .collect();
            assert!(hits.iter().all(|h| h.t.is_finite()), "{scale}: {hits:?}");
            seen.push(hits.len());
        }
        assert!(
            seen[0] > 0 && seen[seen.len() - 1] == 0,
            "hits at each scale, the last past f32::MAX: {seen:?}"
        );
        // Unit directions with a normal but tiny vertical component.
        let flat: Vec<Ray> = camera
            .iter()
            .enumerate()
            .map(|(k, &d)| {
                let y = if k % 2 == 0 { 1e-37 } else { -1e-37 };
                Ray::new(eye, Vec3::new(d.x, y, d.z), 0.0, f32::INFINITY)
            })
            .collect();
        assert_all_agree(&scene, &specs(), &flat);
    }
}

/// Rays at random through random scenes with directions of 10^-38 to 10^-33: every structure,
/// the turned grids of `hug:pca=true` among them, walks them scaled by a power of two
/// ([`hugrt::accel::Reach::moved`]). Walked as given, the turned grids' frames gave
/// components whose inverses overflowed, and the HUG missed hits or found farther ones.
#[test]
fn random_rays_with_small_directions() {
    use hugrt::geometry::Ray;
    for seed in 0..6u64 {
        let scene = if seed % 2 == 0 {
            clustered_soup(seed, 300)
        } else {
            mixed(seed, 150)
        };
        let b = scene.bounds();
        let mut r = rng(seed ^ 99);
        let rays: Vec<Ray> = (0..2_000)
            .map(|_| {
                let o = b.min - b.extent() * 0.2 + b.extent() * 1.4 * v3(&mut r, 0.0, 1.0);
                let target = b.min + b.extent() * v3(&mut r, 0.0, 1.0);
                let scale = 10f32.powf(r.random_range(-38.0..-33.0));
                Ray::new(o, (target - o).normalize() * scale, 0.0, f32::INFINITY)
            })
            .collect();
        assert_all_agree(&scene, &specs(), &rays);
    }
}

#[test]
fn degenerate_rays_give_no_hit_and_no_hang() {
    use hugrt::accel::{AnyAccel, NoCounters};
    use hugrt::geometry::{Ray, Vec3};
    let s = triangle_soup(3, 200);
    for spec in specs() {
        let a = AnyAccel::build(&s, &spec).unwrap();
        for r in [
            Ray::new(Vec3::ZERO, Vec3::ZERO, 0.0, f32::INFINITY),
            Ray::new(
                Vec3::ZERO,
                Vec3::new(f32::NAN, 1.0, 0.0),
                0.0,
                f32::INFINITY,
            ),
            Ray::new(Vec3::splat(f32::NAN), Vec3::X, 0.0, f32::INFINITY),
            Ray::new(Vec3::ZERO, Vec3::X, f32::NAN, f32::NAN),
            Ray::new(Vec3::ZERO, Vec3::X, 1.0, 0.0),
        ] {
            assert_eq!(a.closest_hit(&s, &r, &mut NoCounters), None, "{spec} {r:?}");
            assert_eq!(a.any_hit(&s, &r, &mut NoCounters), None, "{spec} {r:?}");
        }
    }
}

#[test]
fn all_objects_in_one_cell_and_huge_overlaps_stay_bounded() {
    use hugrt::accel::AnyAccel;
    use hugrt::geometry::{Shape, Vec3};
    // 3000 long thin triangles crossing the whole box: box binning would store ~n² references.
    let mut r = rng(9);
    let shapes: Vec<Shape> = (0..3000)
        .map(|_| {
            let a = v3(&mut r, -1.0, 1.0);
            Shape::Triangle([a * 100.0, -a * 100.0, a * 100.0 + Vec3::splat(0.01)])
        })
        .collect();
    let s = scene_of(shapes);
    let g = AnyAccel::build(&s, "grid").unwrap();
    assert!(
        g.memory_bytes() < 64 * 4 * 3000 + (8 << 20),
        "{} bytes",
        g.memory_bytes()
    );
    assert_agrees(&s, "grid", &rays_for(&s.bounds(), 1, 200));
    // Scales 10^10 apart: one huge triangle and a swarm of tiny ones.
    let mut shapes = vec![Shape::Triangle([
        Vec3::new(-1e5, -1e5, 0.0),
        Vec3::new(1e5, -1e5, 0.0),
        Vec3::new(0.0, 1e5, 0.0),
    ])];
    for _ in 0..500 {
        let c = v3(&mut r, -1.0, 1.0);
        shapes.push(Shape::Triangle([
            c,
            c + Vec3::new(1e-5, 0.0, 0.0),
            c + Vec3::new(0.0, 1e-5, 1e-5),
        ]));
    }
    let s = scene_of(shapes);
    check_all(&s, 11, 300);
}

/// The variants the property tests run build the structures they are meant to test: nested
/// grids several levels deep, turned grids, Fig. 9's extra references. (A variant that
/// silently built a single grid would make its agreement with brute force prove nothing.)
#[test]
fn hug_variants_build_what_they_name() {
    use hugrt::accel::AnyAccel;
    let stat = |scene: &hugrt::scene::Scene, spec: &str, key: &str| -> f64 {
        let a = AnyAccel::build(scene, spec).unwrap();
        let st = a.stats();
        st.entries
            .iter()
            .find(|(k, _)| k == key)
            .unwrap_or_else(|| panic!("{spec}: no {key}"))
            .1
    };
    let room = hugrt::scene::procedural::clustered_room(20_000, 2);
    assert!(stat(&room, "hug:filter=levels,min_cluster=1,loose=1e30", "depth") >= 3.0);
    assert!(stat(&room, "hug:filter=levels,min_cluster=1,loose=1e30", "grids") >= 100.0);
    let slabs = turned_clusters(3, 2000);
    assert!(
        stat(
            &slabs,
            "hug:min_cluster=1,loose=1e30,filter=two,fraction=0.3,pca=true",
            "turned_grids"
        ) >= 10.0
    );
    assert_eq!(
        stat(
            &slabs,
            "hug:min_cluster=1,loose=1e30,filter=two,fraction=0.3",
            "turned_grids"
        ),
        0.0
    );
    let fig9 = "hug:filter=levels,min_cluster=1,loose=1e30,cluster=graph,alpha=0,insert=fig9";
    assert!(stat(&room, fig9, "partial_insertions") >= 10.0);
    let contained = "hug:filter=levels,min_cluster=1,loose=1e30,cluster=graph,alpha=0";
    assert_eq!(stat(&room, contained, "partial_insertions"), 0.0);
}

/// Packets whose rays' slopes along the packet's major axis are steep, over a scene a
/// thousand times its size from the world origin. A grid's packet walk finds a steep ray's
/// cells from the major axis' coordinates, whose rounding (an ulp of the offset) the slope
/// multiplies, past the scene's margin: each ray's rectangle of cells must be widened by that
/// much, or cells on its path go untested.
#[test]
fn steep_rays_in_packets_far_from_the_world_origin() {
    let offset = hugrt::geometry::Vec3::splat(1000.0);
    let mut r = rng(17);
    let shapes: Vec<hugrt::geometry::Shape> = (0..3000)
        .map(|_| {
            let c = offset + v3(&mut r, 0.0, 1.0);
            let s = 0.02;
            hugrt::geometry::Shape::Triangle([
                c + v3(&mut r, -s, s),
                c + v3(&mut r, -s, s),
                c + v3(&mut r, -s, s),
            ])
        })
        .collect();
    let scene = scene_of(shapes);
    let mut rays = Vec::new();
    for _ in 0..400 {
        // The first ray along x, from outside the box; seven steep along y through it.
        let through = offset + v3(&mut r, 0.0, 1.0);
        let d0 = hugrt::geometry::Vec3::new(1.0, 0.01, 0.01);
        rays.push(hugrt::geometry::Ray::new(
            through - d0 * 2.0,
            d0,
            0.0,
            f32::INFINITY,
        ));
        for _ in 0..7 {
            let p = offset + v3(&mut r, 0.0, 1.0);
            let d = hugrt::geometry::Vec3::new(
                r.random_range(1e-4..1e-3),
                1.0,
                r.random_range(1e-4..1e-3),
            );
            rays.push(hugrt::geometry::Ray::new(
                p - d * 2.0,
                d,
                0.0,
                f32::INFINITY,
            ));
        }
    }
    let specs: Vec<String> = ["grid", "grid:density=20", "hug", "rgrid:maxp=2", "octree"]
        .map(String::from)
        .to_vec();
    assert_all_agree(&scene, &specs, &rays);
}

/// Packets of rays through the triangles' shared edges and corners, where an edge function is
/// exactly zero and the packet kernels hand the lane to the scalar test: every ray hits the
/// closed floor, alone and in a packet (the grids' packet walk misses them without it).
#[test]
fn packets_through_shared_edges() {
    use hugrt::geometry::{Ray, Vec3};
    use hugrt::scene::{Mesh, Scene};
    let n = 8u32;
    let vertices: Vec<Vec3> = (0..=n)
        .flat_map(|j| (0..=n).map(move |i| Vec3::new(i as f32, j as f32, 0.0)))
        .collect();
    let at = |i: u32, j: u32| j * (n + 1) + i;
    let triangles: Vec<[u32; 3]> = (0..n)
        .flat_map(|j| (0..n).map(move |i| (i, j)))
        .flat_map(|(i, j)| {
            [
                [at(i, j), at(i + 1, j), at(i + 1, j + 1)],
                [at(i, j), at(i + 1, j + 1), at(i, j + 1)],
            ]
        })
        .collect();
    let scene = Scene::from_mesh(Mesh::new(vertices, triangles).unwrap());
    let mut rays = Vec::new();
    for k in 0..64 {
        let x = (k as f32 + 0.5) / 8.0;
        // Down a diagonal, along an edge between squares and through corners.
        for p in [
            Vec3::new(x, x, 0.0),
            Vec3::new(x, 3.0, 0.0),
            Vec3::new((k / 8) as f32, (k % 8) as f32, 0.0),
        ] {
            rays.push(Ray::new(p + Vec3::Z, -Vec3::Z, 0.0, f32::INFINITY));
        }
    }
    let brute = hugrt::accel::AnyAccel::build(&scene, "brute").unwrap();
    for ray in &rays {
        let hit = brute.closest_hit(&scene, ray, &mut hugrt::accel::NoCounters);
        assert!(hit.is_some(), "{ray:?}");
    }
    assert_all_agree(&scene, &specs(), &rays);
}
