//! The batch any-hit queries' shadow cache (`accel::shadow_cache`): a primitive that blocked rays
//! of one group is tried first on the next, and must block only the rays it blocks in their
//! own `[tmin, tmax]`.

mod common;

use common::*;
use hugrt::accel::{AnyAccel, NoCounters, Packets};
use hugrt::geometry::{Ray, Shape, Sphere, Vec3};
use hugrt::scene::Scene;
use rand::Rng;

/// A wall of two triangles across `z = 5` (`|x|, |y| ≤ 10`), some small triangles below it,
/// and, where `sphere`, a ball above it.
fn walled(sphere: bool) -> Scene {
    let (a, b, c, d) = (
        Vec3::new(-10.0, -10.0, 5.0),
        Vec3::new(10.0, -10.0, 5.0),
        Vec3::new(10.0, 10.0, 5.0),
        Vec3::new(-10.0, 10.0, 5.0),
    );
    let mut shapes = vec![Shape::Triangle([a, b, c]), Shape::Triangle([a, c, d])];
    let mut r = rng(7);
    for _ in 0..200 {
        let p = v3(&mut r, -8.0, 8.0) * Vec3::new(1.0, 1.0, 0.2) + Vec3::Z * 2.0;
        shapes.push(Shape::Triangle([
            p,
            p + v3(&mut r, -0.3, 0.3),
            p + v3(&mut r, -0.3, 0.3),
        ]));
    }
    if sphere {
        // Tessellated scenes have no spheres: this one makes the cache hold a sphere.
        shapes.insert(
            0,
            Shape::Sphere(Sphere {
                center: Vec3::new(0.0, 0.0, 8.0),
                radius: 1.5,
            }),
        );
    }
    scene_of(shapes)
}

/// Groups of 32 rays from neighbouring points of the floor `z = 0` to a light above the wall,
/// as a renderer's shadow rays: most end past the wall, but in each group some stop short of
/// it (`tmax`), some start past it (`tmin`), and some groups lie beside the wall, or start
/// blocked and then pass beside it, or the reverse.
fn shadow_groups(groups: usize) -> Vec<Ray> {
    let light = Vec3::new(0.0, 0.0, 10.0);
    let mut r = rng(11);
    let mut rays = Vec::new();
    for g in 0..groups {
        let centre = match g % 5 {
            // Beside the wall: at z = 5 the rays are at x ≈ 15.
            3 => Vec3::new(30.0, 0.0, 0.0),
            _ => Vec3::new(r.random_range(-9.0..9.0), r.random_range(-9.0..9.0), 0.0),
        };
        for k in 0..32 {
            let mut o = centre + Vec3::new((k % 8) as f32, (k / 8) as f32, 0.0) * 0.05;
            // Groups whose first rays are blocked and the rest pass beside the wall, and the
            // reverse.
            if (g % 5 == 4 && k >= 4) || (g % 5 == 2 && k < 4) {
                o.x += 30.0;
            }
            let (tmin, tmax) = match k % 4 {
                1 => (1e-4, 0.45),
                2 => (0.55, 1.0),
                _ => (1e-4, 1.0),
            };
            rays.push(Ray::new(o, light - o, tmin, tmax));
        }
    }
    rays
}

#[test]
fn cached_blockers_block_only_the_rays_they_block() {
    let rays = shadow_groups(40);
    for sphere in [false, true] {
        let scene = walled(sphere);
        let brute = AnyAccel::build(&scene, "brute").unwrap();
        let want: Vec<bool> = rays
            .iter()
            .map(|r| brute.any_hit(&scene, r, &mut NoCounters).is_some())
            .collect();
        // The cases the cache must tell apart are there: blocked rays, and unblocked ones
        // among rays of the same group (those that stop short of the wall, start past it, or
        // pass beside it).
        let blocked = want.iter().filter(|&&w| w).count();
        assert!(
            blocked > rays.len() / 5 && blocked < rays.len() * 4 / 5,
            "{blocked}"
        );
        for spec in specs() {
            let accel = AnyAccel::build(&scene, &spec).unwrap();
            for packets in [Packets::Auto, Packets::On, Packets::Off] {
                let mut got = vec![None; rays.len()];
                accel.any_hits(&scene, &rays, packets, &mut got, &mut NoCounters);
                for (k, (g, &w)) in got.iter().zip(&want).enumerate() {
                    assert_eq!(
                        g.is_some(),
                        w,
                        "{spec} ({packets}, sphere {sphere}): ray {k} {:?}",
                        rays[k]
                    );
                    if let Some(h) = g {
                        let r = &rays[k];
                        assert!(h.t >= r.tmin && h.t <= r.tmax, "{spec}: ray {k}: {h:?}");
                    }
                }
            }
        }
    }
}
