//! Scene and ray generators shared by the integration tests, and the comparison against
//! brute force that every structure must pass.
#![allow(dead_code)]

use hugrt::accel::{Primitives, STRUCTURES};
use hugrt::geometry::{Aabb, Cone, Ray, Shape, Sphere, Vec3};
use hugrt::scene::Scene;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;

/// Every structure with its default parameters, plus parameter settings that take other
/// code paths. A new structure is tested by adding it to `accel::structures!`.
pub fn specs() -> Vec<String> {
    let mut v: Vec<String> = STRUCTURES
        .iter()
        .filter(|&&s| s != "brute")
        .map(|s| s.to_string())
        .collect();
    v.extend(
        [
            "grid:density=1",
            "grid:density=20",
            "grid:density=0.01",
            "grid:prune=true",
            "grid:density=3,prune=true",
            // Every cluster kept as a grid, however small or loose: deep hierarchies.
            "hug:filter=levels,min_cluster=1,loose=1e30",
            "hug:filter=levels,min_cluster=1,loose=1e30,cluster=graph,alpha=0,insert=fig9",
            "hug:filter=levels,min_cluster=2,loose=1e30,levels=6,world=sqrt2,density=4",
            "hug:min_cluster=1,loose=1e30,filter=two,fraction=0.3,pca=true",
            "hug:filter=levels,min_cluster=1,loose=1e30,levels=4,hetero=true,prune=true",
            "hug:min_cluster=3,loose=0.5,pca=true,hetero=true,cluster=cluster3d,alpha=0.5",
            // The papers' algorithms, and hugrt's keys on top of them.
            "hug:preset=eg95",
            "hug:preset=scg97",
            "hug:preset=eg95,insert=contained,shift=true,cells=cubical",
            "hug:cluster=graph,crowd=off,alpha=0,cells=cube-root,giveback=false",
            // Recursive grids and octrees cut down to a few objects per cell, deep.
            "rgrid:maxp=4",
            "rgrid:maxp=2,depth=6,hetero=false,density=2",
            "rgrid:maxp=8,prune=true,density=0.2",
            "rgrid:preset=eg95",
            "rgrid:preset=eg95,maxp=2,shift=true",
            "rgrid:guard=true,maxp=2,depth=6",
            "octree:maxp=2",
            "octree:maxp=8,depth=3,prune=true",
            "octree:preset=eg95,maxp=4,guard=true",
            // Adaptive grids: every cluster gridded, however small, with deep sub-voxel grids;
            // everything in the orphan grid; one cluster for everything.
            "agrid:orphans=1,maxp=2,depth=3",
            "agrid:f=1.5,m=0.3,prune=true,maxp=4",
            "agrid:f=0,orphans=1000000",
            "agrid:f=1000,m=1,density=4",
            // Trees: leaves of one primitive, of sixteen with two bins, no SAH traversal cost.
            "bvh:leaf=1",
            "bvh:leaf=16,bins=2,traversal=0",
            // Spatial splits: as many as the budget allows, leaves of one; and a small budget.
            "bvh:spatial=4,leaf=1",
            "bvh:spatial=0.3,bins=4",
            "kdtree:split=mid,layout=subtrees",
            "kdtree:layout=breadth-first",
            "kdtree:layout=scattered",
            "kdtree:layout=subtrees",
            "kdtree:cut=true",
            "kdtree:preset=havran",
            "kdtree:preset=havran,layout=compact",
            "kdtree:layout=compact",
            "kdtree:split=mid,leaf=1,layout=compact",
            "kdtree:bonus=1,traversal=0.2,step=0.2,cut=true,layout=scattered",
            "kdtree:split=mid,leaf=1,depth=20",
            "kdtree:traversal=0,depth=40",
            // The portable path, where the others test triangles eight at a time.
            "grid:simd=false",
            "hug:simd=false,filter=levels,min_cluster=1,loose=1e30",
            "rgrid:simd=false,maxp=4",
            // AVX2 at most: where the processor has AVX-512 the others walk packets with it.
            "grid:simd=avx2",
            "hug:simd=avx2,filter=levels,min_cluster=1,loose=1e30",
            "rgrid:simd=avx2,maxp=4",
            // Triangles tested through their mesh's indices (where the scene is a mesh), by
            // eight and one at a time.
            "grid:store=index",
            "hug:store=index,filter=levels,min_cluster=1,loose=1e30,pca=true",
            "grid:store=index,simd=false,density=8",
            "hug:store=index,simd=false",
            "bvh:store=index",
            "bvh:store=index,simd=false,leaf=16,bins=2",
            "bvh:store=index,leaf=1,traversal=0",
        ]
        .map(String::from),
    );
    v
}

pub fn rng(seed: u64) -> Pcg64Mcg {
    Pcg64Mcg::seed_from_u64(seed)
}

pub fn v3(r: &mut Pcg64Mcg, lo: f32, hi: f32) -> Vec3 {
    Vec3::new(
        r.random_range(lo..hi),
        r.random_range(lo..hi),
        r.random_range(lo..hi),
    )
}

/// A scene of `shapes`: an indexed mesh when they are all plain triangles (as a loaded mesh
/// is, so that `store=index` is tested), shapes otherwise.
pub fn scene_of(shapes: Vec<Shape>) -> Scene {
    let tris: Option<Vec<[Vec3; 3]>> = shapes
        .iter()
        .map(|s| match s {
            Shape::Triangle(v) => Some(*v),
            _ => None,
        })
        .collect();
    if let Some(tris) = tris {
        return Scene::from_triangles(tris);
    }
    let mut s = Scene::from_triangles(Vec::new());
    s.shapes = shapes;
    s
}

/// Random triangles of mixed sizes in a unit-ish box.
pub fn triangle_soup(seed: u64, n: usize) -> Scene {
    let mut r = rng(seed);
    let shapes = (0..n)
        .map(|_| {
            let c = v3(&mut r, -1.0, 1.0);
            let s = 10f32.powf(r.random_range(-2.5..-0.3));
            Shape::Triangle([
                c + v3(&mut r, -s, s),
                c + v3(&mut r, -s, s),
                c + v3(&mut r, -s, s),
            ])
        })
        .collect();
    scene_of(shapes)
}

/// Tiny dense clusters in a huge empty box (the HUG's case), plus two huge triangles.
pub fn clustered_soup(seed: u64, n: usize) -> Scene {
    let mut r = rng(seed);
    let centres: Vec<Vec3> = (0..4).map(|_| v3(&mut r, -1000.0, 1000.0)).collect();
    let mut shapes: Vec<Shape> = (0..n)
        .map(|i| {
            let c = centres[i % centres.len()] + v3(&mut r, -1.0, 1.0);
            let s = 0.05;
            Shape::Triangle([
                c + v3(&mut r, -s, s),
                c + v3(&mut r, -s, s),
                c + v3(&mut r, -s, s),
            ])
        })
        .collect();
    shapes.push(Shape::Triangle([
        Vec3::new(-1000., -1000., -1000.),
        Vec3::new(1000., -1000., -1000.),
        Vec3::new(0., 1000., 1000.),
    ]));
    shapes.push(Shape::Triangle([
        Vec3::new(-1000., 1000., -1000.),
        Vec3::new(1000., 1000., 500.),
        Vec3::new(0., -1000., 1000.),
    ]));
    scene_of(shapes)
}

/// Clusters of small triangles each spread over a thin slab turned at random (what SCG97
/// §7.2's oriented boxes fit better than axis-aligned ones), over one large ground triangle.
pub fn turned_clusters(seed: u64, n: usize) -> Scene {
    let mut r = rng(seed);
    let clusters = 1 + n / 60;
    let frames: Vec<(Vec3, [Vec3; 3])> = (0..clusters)
        .map(|_| {
            let c = v3(&mut r, -20.0, 20.0);
            let a = v3(&mut r, -1.0, 1.0).normalize_or(Vec3::X);
            let b = a.any_orthonormal_vector();
            (c, [a, b, a.cross(b)])
        })
        .collect();
    let mut shapes: Vec<Shape> = (0..n)
        .map(|i| {
            let (c, [a, b, w]) = frames[i % clusters];
            let p = c
                + a * r.random_range(-4.0..4.0)
                + b * r.random_range(-1.0..1.0)
                + w * r.random_range(-0.05..0.05);
            Shape::Triangle([p, p + a * 0.15, p + b * 0.15 + w * 0.02])
        })
        .collect();
    shapes.push(Shape::Triangle([
        Vec3::new(-40., -25., -40.),
        Vec3::new(40., -25., -40.),
        Vec3::new(0., -25., 40.),
    ]));
    scene_of(shapes)
}

/// Axis-aligned triangles on a lattice of planes, many coplanar and overlapping, with
/// vertices on the planes the grids are likely to cut at; plus degenerate ones.
pub fn axis_aligned(seed: u64, n: usize) -> Scene {
    let mut r = rng(seed);
    let q = |r: &mut Pcg64Mcg| r.random_range(0..9) as f32 * 0.25;
    let shapes = (0..n)
        .map(|i| {
            let axis = i % 3;
            let k = q(&mut r);
            let mut p = [Vec3::ZERO; 3];
            for v in &mut p {
                let (a, b) = (q(&mut r), q(&mut r));
                *v = match axis {
                    0 => Vec3::new(k, a, b),
                    1 => Vec3::new(a, k, b),
                    _ => Vec3::new(a, b, k),
                };
            }
            if i % 17 == 0 {
                p[2] = p[1]; // degenerate: kept, never hit
            }
            Shape::Triangle(p)
        })
        .collect();
    scene_of(shapes)
}

/// Spheres, cones, cylinders and triangulated concave polygons together.
pub fn mixed(seed: u64, n: usize) -> Scene {
    let mut r = rng(seed);
    let mut shapes = Vec::new();
    for i in 0..n {
        let c = v3(&mut r, -2.0, 2.0);
        let s = r.random_range(0.02..0.4);
        match i % 4 {
            0 => shapes.push(Shape::Sphere(Sphere {
                center: c,
                radius: s,
            })),
            1 => shapes.push(Shape::Cone(Cone {
                base: c,
                base_radius: s * 0.5,
                apex: c + v3(&mut r, -s * 3.0, s * 3.0),
                apex_radius: if i % 8 == 1 { s * 0.5 } else { 0.0 },
            })),
            _ => {
                // A comb-shaped concave polygon in a random plane.
                let (u, v) = (
                    v3(&mut r, -1.0, 1.0).normalize() * s,
                    v3(&mut r, -1.0, 1.0).normalize() * s,
                );
                let mut pts = vec![c, c + u * 4.0, c + u * 4.0 + v];
                for k in (0..2).rev() {
                    let x = 2.0 * k as f32;
                    pts.extend([
                        c + u * (x + 1.0) + v,
                        c + u * (x + 1.0) + v * 3.0,
                        c + u * x + v * 3.0,
                        c + u * x + v,
                    ]);
                }
                for t in hugrt::geometry::triangulate_polygon(&pts) {
                    shapes.push(Shape::Triangle(t.map(|k| pts[k])));
                }
            }
        }
    }
    scene_of(shapes)
}

/// Rays of every awkward kind for a scene box: random, from outside, starting inside or on the
/// boundary, parallel to axes, lying in planes at the quarter marks of the box (where grids of
/// many resolutions put cell boundaries), with random `[tmin, tmax]` windows, windows that begin
/// behind the origin, and rays from 10³ to 10¹² scene sizes away aimed into the box.
pub fn rays_for(b: &Aabb, seed: u64, n: usize) -> Vec<Ray> {
    let mut r = rng(seed);
    let e = b.extent().max(Vec3::splat(1e-3));
    let lerp = |t: Vec3| b.min + e * t;
    let unit = |r: &mut Pcg64Mcg| loop {
        let v = v3(r, -1.0, 1.0);
        if v.length_squared() > 1e-4 {
            break v;
        }
    };
    let axes = [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X, -Vec3::Y, -Vec3::Z];
    let quarter = |r: &mut Pcg64Mcg| r.random_range(0..=8) as f32 / 8.0;
    (0..n)
        .map(|i| {
            let inside = lerp(v3(&mut r, 0.0, 1.0));
            match i % 10 {
                0 => Ray::new(inside, unit(&mut r), 0.0, f32::INFINITY),
                1 => {
                    let o = b.center() + unit(&mut r).normalize() * e.length() * 2.0;
                    Ray::new(o, lerp(v3(&mut r, 0.0, 1.0)) - o, 0.0, f32::INFINITY)
                }
                2 => {
                    // Parallel to an axis, through quarter-mark lines.
                    let d = axes[r.random_range(0..6)];
                    let o = lerp(Vec3::new(quarter(&mut r), quarter(&mut r), quarter(&mut r)))
                        - d * e * 1.5;
                    Ray::new(o, d * r.random_range(0.1..10.0), 0.0, f32::INFINITY)
                }
                3 => {
                    // In an axis plane at a quarter mark, oblique within it.
                    let a = r.random_range(0..3);
                    let mut o = inside;
                    o[a] = lerp(Vec3::splat(quarter(&mut r)))[a];
                    let mut d = unit(&mut r);
                    d[a] = 0.0;
                    Ray::new(
                        o,
                        if d == Vec3::ZERO { Vec3::X } else { d },
                        0.0,
                        f32::INFINITY,
                    )
                }
                4 => {
                    // Starting on the box boundary.
                    let mut o = inside;
                    let a = r.random_range(0..3);
                    o[a] = if r.random() { b.min[a] } else { b.max[a] };
                    Ray::new(o, unit(&mut r), 0.0, f32::INFINITY)
                }
                5 => {
                    let t0 = r.random_range(0.0..0.5);
                    Ray::new(
                        inside,
                        unit(&mut r) * e.length(),
                        t0,
                        t0 + r.random_range(0.0..0.6),
                    )
                }
                6 => Ray::new(inside, unit(&mut r) * 1e-3, 0.0, f32::INFINITY),
                7 => {
                    // A window that begins behind the origin.
                    let t0 = -r.random_range(0.0..2.0);
                    Ray::new(inside, unit(&mut r), t0, t0 + r.random_range(0.0..4.0))
                }
                8 => {
                    // From far away, through a point of the box (`t = 1` there).
                    let far = e.length() * 10f32.powi(r.random_range(3..=12));
                    let o = b.center() + unit(&mut r).normalize() * far;
                    Ray::new(o, lerp(v3(&mut r, 0.0, 1.0)) - o, 0.0, f32::INFINITY)
                }
                _ => {
                    // Through a primitive-rich point: two random points inside.
                    let p = lerp(v3(&mut r, 0.0, 1.0));
                    Ray::new(inside, p - inside, 0.0, f32::INFINITY)
                }
            }
        })
        .collect()
}

/// Coherent groups of eight rays, as packets meet them: a camera's neighbouring pixels from
/// outside or inside the box, shadow rays from neighbouring points to one point (`tmax` 1, as
/// the renderer's), and groups that share an origin but point into one octant only roughly.
/// Some groups straddle an axis (directions of both signs), some lie in an axis plane.
pub fn bundles_for(b: &Aabb, seed: u64, groups: usize) -> Vec<Ray> {
    let mut r = rng(seed);
    let e = b.extent().max(Vec3::splat(1e-3));
    let lerp = |t: Vec3| b.min + e * t;
    let mut rays = Vec::with_capacity(8 * groups);
    for g in 0..groups {
        let spread = e.length() * 10f32.powi(-r.random_range(1..=4));
        let target = lerp(v3(&mut r, 0.0, 1.0));
        match g % 4 {
            0 => {
                let o = b.center() + v3(&mut r, -1.0, 1.0).normalize_or(Vec3::X) * e.length();
                for k in 0..8 {
                    let p = target + Vec3::new(k as f32, 0.0, (k % 2) as f32) * spread * 0.1;
                    rays.push(Ray::new(o, p - o, 0.0, f32::INFINITY));
                }
            }
            1 => {
                let o = lerp(v3(&mut r, 0.0, 1.0));
                let d = v3(&mut r, -1.0, 1.0);
                for _ in 0..8 {
                    let jitter = v3(&mut r, -0.05, 0.05);
                    rays.push(Ray::new(o, d + jitter, 0.0, f32::INFINITY));
                }
            }
            2 => {
                let light = lerp(v3(&mut r, -0.5, 1.5));
                for _ in 0..8 {
                    let p = target + v3(&mut r, -1.0, 1.0) * spread;
                    rays.push(Ray::new(p, light - p, 1e-4, 1.0));
                }
            }
            _ => {
                // In an axis plane through quarter marks, some directions along the axis.
                let a = r.random_range(0..3);
                let mut o = lerp(v3(&mut r, 0.0, 1.0));
                o[a] = lerp(Vec3::splat(r.random_range(0..=4) as f32 / 4.0))[a];
                for k in 0..8 {
                    let mut d = v3(&mut r, -1.0, 1.0);
                    d[a] = 0.0;
                    if k % 3 == 0 {
                        d[(a + 1) % 3] = 0.0;
                    }
                    rays.push(Ray::new(
                        o,
                        if d == Vec3::ZERO { Vec3::X } else { d },
                        0.0,
                        1e30,
                    ));
                }
            }
        }
    }
    rays
}

/// Asserts that the structure built from `spec` answers every ray like brute force: the same
/// primitive at the same `t` (ties go to the lower index in every structure), and any-hit
/// finds a hit exactly when closest-hit does.
pub fn assert_agrees<P: Primitives>(prims: &P, spec: &str, rays: &[Ray]) {
    assert_all_agree(prims, &[spec.to_string()], rays);
}

/// [`assert_agrees`] for several structures, with brute force's answers computed once (the
/// library's oracle, which the fuzz targets use too).
pub fn assert_all_agree<P: Primitives>(prims: &P, specs: &[String], rays: &[Ray]) {
    hugrt::fuzzing::assert_all_agree(prims, specs, rays);
}
