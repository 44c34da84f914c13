//! What a hit carries besides `t` and the primitive ([`hugrt::accel::Hit::details`]): the
//! barycentrics rebuild a point of the ray on the triangle, and the normal is the surface's,
//! for rays from far away (`rays_for`' kind 8) as for near ones.

mod common;

use common::*;
use glam::DVec3;
use hugrt::accel::{AnyAccel, NoCounters, PrimitiveKind, Primitives};
use hugrt::geometry::Ray;

/// The distance of `q` from the ray's line, in double precision.
fn off_line(ray: &Ray, q: DVec3) -> f64 {
    let d = ray.dir.as_dvec3();
    (q - ray.origin.as_dvec3()).cross(d).length() / d.length()
}

#[test]
fn barycentrics_rebuild_the_hit_point_and_normals_are_the_surfaces() {
    for scene in [triangle_soup(3, 300), mixed(4, 120), axis_aligned(5, 200)] {
        let accel = AnyAccel::build(&scene, "bvh").unwrap();
        let scale = scene.bounds().extent().max_element().max(1.0) as f64;
        let (mut checked, mut far) = (0, 0);
        for ray in rays_for(&scene.bounds(), 9, 2000) {
            let Some(hit) = accel.closest_hit(&scene, &ray, &mut NoCounters) else {
                continue;
            };
            let d = hit.details(&scene, &ray);
            assert_eq!((d.t, d.prim), (hit.t, hit.prim));
            // The point at `t`, as far off the surface as `t`'s rounding puts it.
            let dir = ray.dir.as_dvec3();
            let at_t = dir.mul_add(DVec3::splat(hit.t as f64), ray.origin.as_dvec3());
            let slack = 1e-3 * scale + 1e-6 * (at_t - ray.origin.as_dvec3()).length();
            let distance = ray.origin.as_dvec3().length() / scale;
            far += (distance > 1e3) as usize;
            let on_surface = match scene.kind(hit.prim as usize) {
                PrimitiveKind::Triangle(v) => {
                    let eps = 1e-4;
                    assert!(
                        d.u >= -eps && d.v >= -eps && d.u + d.v <= 1.0 + eps,
                        "{ray:?}: {d:?}"
                    );
                    let [a, b, c] = v.map(|x| x.as_dvec3());
                    let (u, w) = (d.u as f64, d.v as f64);
                    let q = a * (1.0 - u - w) + b * u + c * w;
                    assert!((d.normal.length() - 1.0).abs() < 1e-4, "{d:?}");
                    for e in [v[1] - v[0], v[2] - v[0]] {
                        assert!(d.normal.dot(e).abs() <= 1e-3 * e.length(), "{d:?}");
                    }
                    q
                }
                PrimitiveKind::Sphere(s) => {
                    assert!((d.normal.length() - 1.0).abs() < 1e-4, "{d:?}");
                    let c = s.center.as_dvec3();
                    if distance <= 1e3 {
                        // Near, the point at `t` is on the sphere to within far less than
                        // its radius: the normal is the one there.
                        let n = (at_t - c) / s.radius as f64;
                        assert!(
                            (d.normal.as_dvec3() - n).length() < 1e-3,
                            "{d:?} against {n}"
                        );
                    }
                    c + d.normal.as_dvec3() * s.radius as f64
                }
                _ => {
                    assert!((d.normal.length() - 1.0).abs() < 1e-3, "{d:?}");
                    checked += 1;
                    continue;
                }
            };
            assert!(
                off_line(&ray, on_surface) <= 1e-3 * scale,
                "{ray:?}: {d:?} gives {on_surface}, {} off the ray",
                off_line(&ray, on_surface)
            );
            assert!(
                (on_surface - at_t).length() <= slack,
                "{ray:?}: {d:?} gives {on_surface}, the hit's t {at_t}"
            );
            checked += 1;
        }
        assert!(checked > 100, "{checked} hits checked");
        assert!(far > 10, "{far} hits of rays from far away checked");
    }
}
