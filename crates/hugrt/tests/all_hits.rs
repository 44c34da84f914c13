//! The all-hits query ([`hugrt::accel::Accel::all_hits`]) of every structure against brute
//! force: every primitive hit in `[tmin, tmax]`, once, at the `t` its own test gives, in order;
//! on meshes whose shared edges and vertices rays cross exactly, and on the random scenes.

mod common;

use common::*;
use hugrt::accel::{AnyAccel, Hit, NoCounters, Primitives, Reach};
use hugrt::geometry::{PreparedRay, Ray, Shape, Vec3};
use hugrt::scene::Scene;
use std::ops::ControlFlow;

/// Every hit of every primitive, straight from the primitives' own tests, sorted; a ray from
/// far away is first moved to the scene, as the structures move it ([`Reach`]).
fn brute_all_hits<P: Primitives>(prims: &P, ray: &Ray) -> Vec<Hit> {
    if !ray.is_traceable() {
        return Vec::new();
    }
    let reach = Reach::of(prims);
    if !reach.walks_as_given(ray) {
        let Some(m) = reach.moved(ray) else {
            return Vec::new();
        };
        let mut hits: Vec<Hit> = brute_all_hits(prims, &m.ray)
            .into_iter()
            .map(|h| m.hit(h))
            .collect();
        hits.sort_by(Hit::order);
        return hits;
    }
    let ray = &ray.without_subnormal_direction();
    let pr = PreparedRay::new(ray);
    let mut hits: Vec<Hit> = (0..prims.len())
        .filter_map(|i| {
            prims
                .intersect(i, &pr, ray.tmin, ray.tmax)
                .map(|t| Hit { t, prim: i as u32 })
        })
        .collect();
    hits.sort_by(Hit::order);
    hits
}

fn assert_all_hits_agree<P: Primitives>(prims: &P, specs: &[String], rays: &[Ray]) -> usize {
    let want: Vec<Vec<Hit>> = rays.iter().map(|r| brute_all_hits(prims, r)).collect();
    for spec in specs.iter().map(String::as_str).chain(["brute"]) {
        let accel = AnyAccel::build(prims, spec).unwrap_or_else(|e| panic!("{spec}: {e}"));
        for (i, (ray, want)) in rays.iter().zip(&want).enumerate() {
            let got = accel.all_hits(prims, ray, &mut NoCounters);
            assert_eq!(&got, want, "{spec}: ray {i} {ray:?}");
        }
    }
    want.iter().map(Vec::len).sum()
}

/// Layers of `n × n` unit squares, each cut along a diagonal, at heights `0, 1, …`: every
/// inner vertex is shared by six triangles, every inner edge by two, all at integer
/// coordinates, so rays aimed at them cross them exactly.
fn layered_grid(n: usize, layers: usize) -> Scene {
    let mut shapes = Vec::new();
    for z in 0..layers {
        let z = z as f32;
        for i in 0..n {
            for j in 0..n {
                let p = |di: usize, dj: usize| Vec3::new((i + di) as f32, (j + dj) as f32, z);
                shapes.push(Shape::Triangle([p(0, 0), p(1, 0), p(1, 1)]));
                shapes.push(Shape::Triangle([p(0, 0), p(1, 1), p(0, 1)]));
            }
        }
    }
    scene_of(shapes)
}

/// Rays down through the layers at vertices, edge midpoints and diagonals, straight and
/// slanted, some ending between layers.
fn rays_through_vertices_and_edges(n: usize, layers: usize) -> Vec<Ray> {
    let top = layers as f32 + 0.5;
    let mut rays = Vec::new();
    for i in 0..=n {
        for j in 0..=n {
            let v = Vec3::new(i as f32, j as f32, 0.0);
            for target in [
                v,
                v + Vec3::new(0.5, 0.0, 0.0),
                v + Vec3::new(0.5, 0.5, 0.0),
            ] {
                for lean in [
                    Vec3::ZERO,
                    Vec3::new(0.25, 0.0, 0.0),
                    Vec3::new(-0.5, 0.25, 0.0),
                ] {
                    let origin = target + lean * top + Vec3::new(0.0, 0.0, top);
                    let dir = target - origin;
                    rays.push(Ray::new(origin, dir / top, 0.0, f32::INFINITY));
                    // Ending exactly on the middle layer: `tmax` is inclusive.
                    rays.push(Ray::new(origin, dir / top, 0.0, 0.5 + (layers / 2) as f32));
                }
            }
        }
    }
    rays
}

/// A subdivided octahedron of radius ~1: a closed mesh whose vertices and edges are shared.
fn closed_mesh(subdivisions: usize) -> Vec<[Vec3; 3]> {
    let (x, y, z) = (Vec3::X, Vec3::Y, Vec3::Z);
    let mut tris = Vec::new();
    for sx in [-1.0f32, 1.0] {
        for sy in [-1.0f32, 1.0] {
            for sz in [-1.0f32, 1.0] {
                tris.push([x * sx, y * sy, z * sz]);
            }
        }
    }
    for _ in 0..subdivisions {
        tris = tris
            .iter()
            .flat_map(|&[a, b, c]| {
                let m = |p: Vec3, q: Vec3| ((p + q) * 0.5).normalize();
                let (ab, bc, ca) = (m(a, b), m(b, c), m(c, a));
                [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]
            })
            .collect();
    }
    tris
}

#[test]
fn every_structure_finds_every_hit_through_shared_vertices_and_edges() {
    let (n, layers) = (6, 4);
    let scene = layered_grid(n, layers);
    let rays = rays_through_vertices_and_edges(n, layers);
    let hits = assert_all_hits_agree(&scene, &specs(), &rays);
    // Every straight ray through an inner vertex hits its six triangles on every layer.
    assert!(hits > rays.len() * 4, "{hits} hits for {} rays", rays.len());
}

#[test]
fn a_vertex_hit_straight_on_reports_each_triangle_around_it_once() {
    let scene = layered_grid(4, 3);
    let ray = Ray::new(Vec3::new(2.0, 2.0, 5.0), -Vec3::Z, 0.0, f32::INFINITY);
    for spec in specs() {
        let accel = AnyAccel::build(&scene, &spec).unwrap();
        let hits = accel.all_hits(&scene, &ray, &mut NoCounters);
        // Six triangles meet at (2, 2) on each of the three layers (the diagonals run one way).
        assert_eq!(hits.len(), 18, "{spec}: {hits:?}");
        for (k, layer) in hits.chunks(6).enumerate() {
            assert!(
                layer.iter().all(|h| h.t == 5.0 - (2 - k) as f32),
                "{spec}: {hits:?}"
            );
        }
    }
}

#[test]
fn rays_from_inside_a_closed_mesh_through_its_vertices_and_edges_never_escape() {
    let tris = closed_mesh(3);
    let scene = Scene::from_triangles(tris.clone());
    let mut r = rng(21);
    let mut rays = Vec::new();
    for t in &tris {
        let origin = v3(&mut r, -0.3, 0.3);
        for target in [t[0], (t[0] + t[1]) * 0.5] {
            rays.push(Ray::new(origin, target - origin, 0.0, f32::INFINITY));
        }
    }
    assert_all_hits_agree(&scene, &specs(), &rays);
    for spec in specs() {
        let accel = AnyAccel::build(&scene, &spec).unwrap();
        for ray in &rays {
            assert!(
                !accel.all_hits(&scene, ray, &mut NoCounters).is_empty(),
                "{spec}: {ray:?} left the closed mesh through a crack"
            );
        }
    }
}

#[test]
fn all_hits_agree_with_brute_force_on_random_scenes() {
    let scenes = [
        triangle_soup(31, 400),
        clustered_soup(32, 400),
        mixed(33, 150),
        axis_aligned(34, 300),
        turned_clusters(35, 300),
    ];
    for scene in &scenes {
        let rays = rays_for(&scene.bounds(), 36, 300);
        assert_all_hits_agree(scene, &specs(), &rays);
    }
}

#[test]
fn the_callback_stops_the_walk_and_sees_what_all_hits_sorts() {
    let scene = layered_grid(5, 6);
    let rays = rays_through_vertices_and_edges(5, 6);
    for spec in specs() {
        let accel = AnyAccel::build(&scene, &spec).unwrap();
        for ray in &rays {
            let all = accel.all_hits(&scene, ray, &mut NoCounters);
            let mut seen = Vec::new();
            accel.for_each_hit(&scene, ray, &mut NoCounters, |h| {
                seen.push(h);
                ControlFlow::Continue(())
            });
            seen.sort_by(Hit::order);
            assert_eq!(seen, all, "{spec}: {ray:?}");
            let mut calls = 0;
            accel.for_each_hit(&scene, ray, &mut NoCounters, |_| {
                calls += 1;
                if calls == 2 {
                    ControlFlow::Break(())
                } else {
                    ControlFlow::Continue(())
                }
            });
            assert_eq!(calls, all.len().min(2), "{spec}: {ray:?}");
        }
    }
}

#[test]
fn untraceable_rays_and_empty_scenes_have_no_hits() {
    let scene = layered_grid(2, 2);
    let empty = Scene::from_triangles(Vec::new());
    for spec in specs() {
        let accel = AnyAccel::build(&scene, &spec).unwrap();
        let nan = Ray::new(Vec3::new(1.0, 1.0, 3.0), Vec3::NAN, 0.0, f32::INFINITY);
        assert!(
            accel.all_hits(&scene, &nan, &mut NoCounters).is_empty(),
            "{spec}"
        );
        let backwards = Ray::new(Vec3::new(1.0, 1.0, 3.0), -Vec3::Z, 2.0, 1.0);
        assert!(
            accel
                .all_hits(&scene, &backwards, &mut NoCounters)
                .is_empty(),
            "{spec}"
        );
        let none = AnyAccel::build(&empty, &spec).unwrap();
        let down = Ray::new(Vec3::new(1.0, 1.0, 3.0), -Vec3::Z, 0.0, f32::INFINITY);
        assert!(
            none.all_hits(&empty, &down, &mut NoCounters).is_empty(),
            "{spec}"
        );
    }
}
