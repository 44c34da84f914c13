//! What a hit carries besides `t` and the primitive ([`hugrt::accel::Hit::details`]): the
//! barycentrics rebuild the hit point, and the normal is the surface's.

mod common;

use common::*;
use hugrt::accel::{AnyAccel, NoCounters, PrimitiveKind, Primitives};

#[test]
fn barycentrics_rebuild_the_hit_point_and_normals_are_the_surfaces() {
    for scene in [triangle_soup(3, 300), mixed(4, 120), axis_aligned(5, 200)] {
        let accel = AnyAccel::build(&scene, "bvh").unwrap();
        let scale = scene.bounds().extent().max_element().max(1.0);
        let mut checked = 0;
        for ray in rays_for(&scene.bounds(), 9, 2000) {
            let Some(hit) = accel.closest_hit(&scene, &ray, &mut NoCounters) else {
                continue;
            };
            let d = hit.details(&scene, &ray);
            assert_eq!((d.t, d.prim), (hit.t, hit.prim));
            let p = ray.at(hit.t);
            match scene.kind(hit.prim as usize) {
                PrimitiveKind::Triangle(v) => {
                    let eps = 1e-4;
                    assert!(
                        d.u >= -eps && d.v >= -eps && d.u + d.v <= 1.0 + eps,
                        "{d:?}"
                    );
                    let q = v[0] * (1.0 - d.u - d.v) + v[1] * d.u + v[2] * d.v;
                    assert!(
                        (q - p).length() <= 1e-3 * scale,
                        "{ray:?}: hit at {p}, barycentrics give {q}"
                    );
                    assert!((d.normal.length() - 1.0).abs() < 1e-4, "{d:?}");
                    for e in [v[1] - v[0], v[2] - v[0]] {
                        assert!(d.normal.dot(e).abs() <= 1e-3 * e.length(), "{d:?}");
                    }
                }
                PrimitiveKind::Sphere(s) => {
                    let n = (p - s.center) / s.radius;
                    assert!((d.normal - n).length() < 1e-3, "{d:?} against {n}");
                }
                _ => assert!((d.normal.length() - 1.0).abs() < 1e-3, "{d:?}"),
            }
            checked += 1;
        }
        assert!(checked > 100, "{checked} hits checked");
    }
}
