//! The bodies of the fuzz targets in `fuzz/` (cargo-fuzz, libFuzzer), kept in the library so
//! that `tests/fuzz_corpus.rs` replays the kept corpus and every crash found on the stable
//! toolchain, through the same code; and their oracle, [`assert_all_agree`], which the tests
//! use too. Each function panics only where hugrt is wrong: a loader
//! that panics, a loaded scene with a non-finite coordinate, or a structure whose closest
//! hits differ from brute force's.

use crate::accel::{AnyAccel, Hit, NoCounters, PACKET, Packets, Primitives};
use crate::batch::{camera_rays, decode_rays, incoherent_rays};
use crate::geometry::{Ray, Shape, Vec3};
use crate::scene::Scene;

/// Structures a loaded scene is built into and checked against brute force: the HUG (the
/// product), the bvh (the fastest) and the uniform grid (the simplest walk).
const CHECKED: &[&str] = &["hug", "bvh", "grid"];

/// Scenes larger than this are only loaded, not built: the fuzzer's time goes to the parsers.
const MAX_CHECKED_PRIMITIVES: usize = 2_000;

/// Loads `data` as the file `name` (its extension picks the format) and, when it loads,
/// checks the scene and the structures built over it.
pub fn scene_file(name: &str, data: &[u8]) {
    let Ok(scene) = Scene::from_bytes(name, data) else {
        return;
    };
    for (i, s) in scene.primitives().enumerate() {
        let b = s.bounds();
        assert!(
            b.is_empty() || (b.min.is_finite() && b.max.is_finite()),
            "primitive {i} has a non-finite bound: {s:?}"
        );
    }
    if scene.len() > MAX_CHECKED_PRIMITIVES {
        return;
    }
    let b = scene.bounds();
    if b.is_empty() {
        return;
    }
    let mut rays = camera_rays(&b, 8, 8);
    rays.extend(incoherent_rays(&b, 64, 1));
    check_structures(&scene, &rays);
}

/// Decodes `data` as a rays file and traces it through every checked structure of a small
/// fixed scene, comparing with brute force: rays of any bit pattern (NaN, infinite, zero
/// directions, reversed intervals) must be answered, never panic or hang.
pub fn rays_file(data: &[u8]) {
    let Ok(rays) = decode_rays(data) else {
        return;
    };
    check_structures(&fixture(), &rays);
}

/// Twelve triangles of a unit cube with a sphere and a sliver inside: shared edges, a curved
/// primitive and a needle.
fn fixture() -> Scene {
    let corner = |i: u32| Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, (i >> 2) as f32);
    let faces = [
        [0, 2, 6, 4],
        [1, 3, 7, 5],
        [0, 1, 5, 4],
        [2, 3, 7, 6],
        [0, 1, 3, 2],
        [4, 5, 7, 6],
    ];
    let mut tris = Vec::new();
    for q in faces.map(|q| q.map(corner)) {
        tris.push([q[0], q[1], q[2]]);
        tris.push([q[0], q[2], q[3]]);
    }
    tris.push([
        Vec3::new(0.1, 0.5, 0.5),
        Vec3::new(0.9, 0.5, 0.5),
        Vec3::new(0.9, 0.5000001, 0.5),
    ]);
    let mut shapes: Vec<Shape> = tris.into_iter().map(Shape::Triangle).collect();
    shapes.push(Shape::Sphere(crate::geometry::Sphere {
        center: Vec3::splat(0.5),
        radius: 0.25,
    }));
    Scene {
        shapes,
        ..Scene::default()
    }
}

fn check_structures(scene: &Scene, rays: &[Ray]) {
    assert_all_agree(scene, CHECKED, rays);
}

/// Asserts that every structure `specs` names answers every ray like brute force: the same
/// primitive or the same `t` (a tie), and any-hit finds a hit exactly when closest-hit does.
/// The oracle of the fuzz targets and of the tests (`tests/common`), kept here once.
pub fn assert_all_agree<P: Primitives, S: AsRef<str>>(prims: &P, specs: &[S], rays: &[Ray]) {
    let brute = AnyAccel::build(prims, "brute").expect("brute force builds");
    let want: Vec<Option<Hit>> = rays
        .iter()
        .map(|r| brute.closest_hit(prims, r, &mut NoCounters))
        .collect();
    for spec in specs {
        let spec = spec.as_ref();
        let accel = AnyAccel::build(prims, spec).unwrap_or_else(|e| panic!("{spec}: {e}"));
        for (k, (ray, want)) in rays.iter().zip(&want).enumerate() {
            let got = accel.closest_hit(prims, ray, &mut NoCounters);
            let same = match (want, got) {
                (None, None) => true,
                (Some(w), Some(g)) => w.prim == g.prim || w.t == g.t,
                _ => false,
            };
            assert!(
                same,
                "{spec}: ray {k} {ray:?}: brute force {want:?}, {spec} {got:?}"
            );
            let any = accel.any_hit(prims, ray, &mut NoCounters).is_some();
            assert_eq!(any, want.is_some(), "{spec}: any-hit of ray {k} {ray:?}");
        }
        assert_packets_agree(prims, &accel, spec, rays);
    }
}

/// Asserts that the batch queries give every ray the answer it gets alone, bit for bit, with
/// every group of [`PACKET`] rays walked as a packet (`Packets::On`), coherent or not, with
/// the groups that look coherent walked as packets (`Packets::Auto`, where a group is judged on
/// the rays it walks: its rays that cannot be walked together are answered alone), and with no
/// packets (`Packets::Off`: every group through [`crate::accel::Accel::query_each`], which
/// the bvh interleaves).
pub fn assert_packets_agree<P: Primitives>(prims: &P, accel: &AnyAccel, spec: &str, rays: &[Ray]) {
    let alone: Vec<Option<Hit>> = rays
        .iter()
        .map(|r| accel.closest_hit(prims, r, &mut NoCounters))
        .collect();
    for packets in [Packets::On, Packets::Auto, Packets::Off] {
        let mut got = vec![None; rays.len()];
        accel.closest_hits(prims, rays, packets, &mut got, &mut NoCounters);
        let mut any = vec![None; rays.len()];
        accel.any_hits(prims, rays, packets, &mut any, &mut NoCounters);
        for (k, (ray, alone)) in rays.iter().zip(&alone).enumerate() {
            assert_eq!(
                got[k],
                *alone,
                "{spec} ({packets}): ray {k} {ray:?} in packet {}: alone {alone:?}, in the \
                 packet {:?}",
                k / PACKET,
                got[k]
            );
            assert_eq!(
                any[k].is_some(),
                alone.is_some(),
                "{spec} ({packets}): any-hit of ray {k} {ray:?} in packet {}",
                k / PACKET
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Aabb;

    /// Every ray from inside the fixture's cube hits it: the cube is closed, so the rays-file
    /// target's misses come from the rays, not from a gap.
    #[test]
    fn the_fixture_is_a_closed_cube() {
        let scene = fixture();
        assert_eq!(scene.shapes.len(), 14);
        let b = scene.bounds();
        assert_eq!((b.min, b.max), (Vec3::ZERO, Vec3::ONE));
        let brute = AnyAccel::build(&scene, "brute").unwrap();
        let inside = Aabb::new(Vec3::splat(0.01), Vec3::splat(0.99));
        for ray in incoherent_rays(&inside, 1000, 3) {
            assert!(brute.closest_hit(&scene, &ray, &mut NoCounters).is_some());
        }
    }
}
