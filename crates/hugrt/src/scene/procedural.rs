//! Scenes generated in code, so that hugrt runs and tests without any file.
//!
//! [`clustered_room`] is the case the HUG was made for (EG95 §1.1, §4): a large, mostly empty
//! room whose detail is concentrated in a few small, dense clusters of small objects (the
//! kitchen of EG95 stands behind it). It is deterministic for a given size and seed.

use super::{Camera, Light, Material, Scene};
use crate::geometry::{Cone, Shape, Sphere, Vec3};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;

/// Triangles of one tessellated ball with `seg` segments around and `seg / 2` rings.
fn ball_triangles(seg: usize) -> usize {
    2 * seg * (seg / 2 - 1)
}

fn push_ball(out: &mut Vec<[Vec3; 3]>, c: Vec3, r: Vec3, seg: usize) {
    let rings = seg / 2;
    let p = |i: usize, j: usize| {
        let th = std::f32::consts::PI * i as f32 / rings as f32;
        let ph = std::f32::consts::TAU * j as f32 / seg as f32;
        c + r * Vec3::new(th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin())
    };
    for i in 0..rings {
        for j in 0..seg {
            let (a, b, cc, d) = (p(i, j), p(i, j + 1), p(i + 1, j + 1), p(i + 1, j));
            if i != 0 {
                out.push([a, cc, b]);
            }
            if i != rings - 1 {
                out.push([a, d, cc]);
            }
        }
    }
}

fn push_quad(out: &mut Vec<[Vec3; 3]>, a: Vec3, b: Vec3, c: Vec3, d: Vec3) {
    out.push([a, b, c]);
    out.push([a, c, d]);
}

fn push_box(out: &mut Vec<[Vec3; 3]>, lo: Vec3, hi: Vec3) {
    let v =
        |x: usize, y: usize, z: usize| Vec3::new([lo.x, hi.x][x], [lo.y, hi.y][y], [lo.z, hi.z][z]);
    push_quad(out, v(0, 1, 0), v(0, 1, 1), v(1, 1, 1), v(1, 1, 0));
    push_quad(out, v(0, 0, 0), v(1, 0, 0), v(1, 0, 1), v(0, 0, 1));
    push_quad(out, v(0, 0, 0), v(0, 1, 0), v(1, 1, 0), v(1, 0, 0));
    push_quad(out, v(0, 0, 1), v(1, 0, 1), v(1, 1, 1), v(0, 1, 1));
    push_quad(out, v(0, 0, 0), v(0, 0, 1), v(0, 1, 1), v(0, 1, 0));
    push_quad(out, v(1, 0, 0), v(1, 1, 0), v(1, 1, 1), v(1, 0, 1));
}

/// A 60 × 20 × 60 room with about `target_triangles` triangles, most of them in small balls
/// heaped on a few tables (each heap about 2 units wide), plus a few glass and mirror spheres
/// and cylinders standing in the open. `clustered_room(60_000, 1)` is the default scene of
/// `hugrt render`.
pub fn clustered_room(target_triangles: usize, seed: u64) -> Scene {
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let seg = 12;
    let per_ball = ball_triangles(seg);
    let balls = (target_triangles / per_ball).max(1);
    let clusters = ((balls as f64).sqrt() / 8.0).ceil().clamp(1.0, 64.0) as usize;
    let mut scene = Scene {
        shapes: Vec::new(),
        mesh: Default::default(),
        material_runs: Vec::new(),
        materials: vec![
            Material {
                color: Vec3::new(0.7, 0.7, 0.65),
                kd: 0.7,
                ks: 0.3,
                shine: 20.0,
                transmittance: 0.0,
                ior: 1.0,
            },
            Material {
                color: Vec3::new(0.8, 0.75, 0.6),
                kd: 0.9,
                ..Material::default()
            },
            Material {
                color: Vec3::new(0.55, 0.35, 0.2),
                kd: 0.9,
                ks: 0.1,
                shine: 10.0,
                ..Material::default()
            },
            Material {
                color: Vec3::new(0.9, 0.3, 0.2),
                kd: 0.7,
                ks: 0.3,
                shine: 30.0,
                ..Material::default()
            },
            Material {
                color: Vec3::new(0.2, 0.5, 0.9),
                kd: 0.7,
                ks: 0.3,
                shine: 30.0,
                ..Material::default()
            },
            Material {
                color: Vec3::new(0.9, 0.9, 1.0),
                kd: 0.1,
                ks: 0.2,
                shine: 60.0,
                transmittance: 0.8,
                ior: 1.5,
            },
            Material {
                color: Vec3::splat(0.9),
                kd: 0.1,
                ks: 0.9,
                shine: 100.0,
                ..Material::default()
            },
        ],
        patch_normals: Vec::new(),
        lights: vec![
            Light {
                position: Vec3::new(-10.0, 18.0, -5.0),
                color: Vec3::splat(0.7),
            },
            Light {
                position: Vec3::new(15.0, 15.0, -20.0),
                color: Vec3::splat(0.7),
            },
        ],
        camera: Camera {
            from: Vec3::new(-27.0, 11.0, -28.0),
            at: Vec3::new(4.0, 1.5, 4.0),
            up: Vec3::Y,
            fov_deg: 55.0,
            width: 512,
            height: 512,
        },
        background: Vec3::new(0.1, 0.1, 0.15),
    };
    let group = |scene: &mut Scene, material: u32, tris: Vec<[Vec3; 3]>| {
        scene
            .material_runs
            .push((scene.shapes.len() as u32, material));
        scene.shapes.extend(tris.into_iter().map(Shape::Triangle));
    };
    // Floor and two walls.
    let (w, h) = (30.0, 20.0);
    let mut room = Vec::new();
    push_quad(
        &mut room,
        Vec3::new(-w, 0., -w),
        Vec3::new(-w, 0., w),
        Vec3::new(w, 0., w),
        Vec3::new(w, 0., -w),
    );
    group(&mut scene, 0, room);
    let mut walls = Vec::new();
    push_quad(
        &mut walls,
        Vec3::new(-w, 0., w),
        Vec3::new(-w, h, w),
        Vec3::new(w, h, w),
        Vec3::new(w, 0., w),
    );
    push_quad(
        &mut walls,
        Vec3::new(w, 0., -w),
        Vec3::new(w, 0., w),
        Vec3::new(w, h, w),
        Vec3::new(w, h, -w),
    );
    group(&mut scene, 1, walls);
    // Tables, each carrying one heap of small balls.
    let mut left = balls;
    for k in 0..clusters {
        let centre = Vec3::new(
            rng.random_range(-22.0..22.0),
            0.0,
            rng.random_range(-22.0..22.0),
        );
        let top = 1.0;
        let mut table = Vec::new();
        push_box(
            &mut table,
            centre + Vec3::new(-1.5, top - 0.1, -1.5),
            centre + Vec3::new(1.5, top, 1.5),
        );
        push_box(
            &mut table,
            centre + Vec3::new(-0.1, 0.0, -0.1),
            centre + Vec3::new(0.1, top - 0.1, 0.1),
        );
        group(&mut scene, 2, table);
        let here = left / (clusters - k);
        left -= here;
        let mut heap = Vec::with_capacity(here * per_ball);
        for _ in 0..here {
            let r = rng.random_range(0.04..0.12);
            let c = centre
                + Vec3::new(
                    rng.random_range(-1.2..1.2),
                    top + r + rng.random_range(0.0..1.0f32).powi(2) * 1.5,
                    rng.random_range(-1.2..1.2),
                );
            let squash = Vec3::new(1.0, rng.random_range(0.6..1.2), 1.0);
            push_ball(&mut heap, c, squash * r, seg);
        }
        group(&mut scene, 3 + (k % 2) as u32, heap);
    }
    // A few large curved primitives in the open: glass and mirror spheres, a pillar.
    scene.material_runs.push((scene.shapes.len() as u32, 5));
    scene.shapes.push(Shape::Sphere(Sphere {
        center: Vec3::new(-8.0, 2.5, -6.0),
        radius: 2.5,
    }));
    scene.material_runs.push((scene.shapes.len() as u32, 6));
    scene.shapes.push(Shape::Sphere(Sphere {
        center: Vec3::new(6.0, 4.0, 12.0),
        radius: 4.0,
    }));
    scene.material_runs.push((scene.shapes.len() as u32, 1));
    scene.shapes.push(Shape::Cone(Cone {
        base: Vec3::new(12.0, 0.0, -10.0),
        base_radius: 1.0,
        apex: Vec3::new(12.0, h, -10.0),
        apex_radius: 1.0,
    }));
    scene
}
