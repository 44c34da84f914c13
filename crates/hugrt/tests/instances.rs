//! Instanced scenes: every structure against brute force through instances, and instances
//! against the same scene flattened into copies (same hits, same normals).

mod common;

use common::*;
use glam::{Affine3A, Mat3, Quat};
use hugrt::accel::{NoCounters, STRUCTURES};
use hugrt::geometry::{Ray, Vec3};
use hugrt::scene::{Instance, InstanceError, InstancedScene, Model, Scene};
use hugrt::world::World;
use rand::Rng;

/// A transform whose products and sums are exact on the tests' coordinates: a signed
/// permutation of the axes (turns by right angles, mirrors), a power-of-two scale and an
/// integer translation.
fn exact(perm: [usize; 3], signs: [f32; 3], scale: f32, t: Vec3) -> Affine3A {
    let cols: [Vec3; 3] = std::array::from_fn(|c| Vec3::AXES[perm[c]] * signs[c] * scale);
    Affine3A::from_mat3_translation(Mat3::from_cols(cols[0], cols[1], cols[2]), t)
}

/// Any invertible transform: a turn, a scale of each axis (a mirror when `mirror`) and a
/// translation.
fn general(r: &mut rand_pcg::Pcg64Mcg, mirror: bool) -> Affine3A {
    let turn = Quat::from_axis_angle(v3(r, -1.0, 1.0).normalize(), r.random_range(0.0..6.3));
    let mut scale = v3(r, 0.3, 2.0);
    if mirror {
        scale.y = -scale.y;
    }
    Affine3A::from_scale_rotation_translation(scale, turn, v3(r, -6.0, 6.0))
}

fn model(name: &str, scene: Scene, instances: Vec<Instance>) -> Model {
    Model {
        name: name.into(),
        scene,
        instances,
    }
}

/// Three levels: `part` (spheres, cones, polygons when `shapes`, else triangles), `group`
/// (parts placed five times, with a soup of its own), the world (groups and parts placed,
/// with triangles of its own).
fn three_levels(
    seed: u64,
    shapes: bool,
    place: &mut dyn FnMut(usize) -> Affine3A,
) -> InstancedScene {
    let part = if shapes {
        mixed(seed, 24)
    } else {
        clustered_soup(seed, 150)
    };
    let group_own = triangle_soup(seed ^ 7, 40);
    let world_own = axis_aligned(seed ^ 9, 30);
    let group = (0..5)
        .map(|k| Instance {
            model: 0,
            transform: place(k),
        })
        .collect();
    let mut world: Vec<Instance> = (0..3)
        .map(|k| Instance {
            model: 1,
            transform: place(10 + k),
        })
        .collect();
    world.extend((0..2).map(|k| Instance {
        model: 0,
        transform: place(20 + k),
    }));
    InstancedScene {
        models: vec![
            model("part", part, Vec::new()),
            model("group", group_own, group),
            model("world", world_own, world),
        ],
    }
}

fn exact_three_levels(seed: u64, shapes: bool) -> InstancedScene {
    let mut r = rng(seed ^ 0x51);
    let perms = [
        [0, 1, 2],
        [1, 2, 0],
        [2, 0, 1],
        [0, 2, 1],
        [2, 1, 0],
        [1, 0, 2],
    ];
    three_levels(seed, shapes, &mut |_| {
        let sign = |r: &mut rand_pcg::Pcg64Mcg| if r.random() { 1.0 } else { -1.0 };
        exact(
            perms[r.random_range(0..6)],
            [sign(&mut r), sign(&mut r), sign(&mut r)],
            [0.5, 1.0, 2.0][r.random_range(0..3)],
            Vec3::new(
                r.random_range(-6..=6) as f32,
                r.random_range(-6..=6) as f32,
                r.random_range(-6..=6) as f32,
            ),
        )
    })
}

/// Rays on a grid of eighths, so that a translation by whole units changes no bit.
fn dyadic_rays(b: &hugrt::geometry::Aabb, seed: u64, n: usize) -> Vec<Ray> {
    let mut r = rng(seed);
    let snap = |v: Vec3| (v * 8.0).round() / 8.0;
    (0..n)
        .map(|_| {
            let o = snap(b.center() + v3(&mut r, -1.0, 1.0) * b.extent() * 0.9);
            let at = snap(b.center() + v3(&mut r, -0.5, 0.5) * b.extent());
            let d = if at == o { Vec3::X } else { at - o };
            Ray::new(o, d, 0.0, f32::INFINITY)
        })
        .collect()
}

#[test]
fn every_structure_finds_through_instances_what_brute_force_finds() {
    for (seed, shapes) in [(1, true), (2, false), (3, true)] {
        let scene = exact_three_levels(seed, shapes);
        let mut r = rng(seed);
        let general_scene = three_levels(seed ^ 0x77, shapes, &mut |k| general(&mut r, k % 3 == 1));
        for scene in [scene, general_scene] {
            let brute = World::build(scene.clone(), "brute").unwrap();
            let mut rays = rays_for(&brute.bounds(), seed ^ 5, 300);
            rays.extend(dyadic_rays(&brute.bounds(), seed ^ 6, 300));
            let expected: Vec<_> = rays
                .iter()
                .map(|ray| brute.closest_hit(ray, &mut NoCounters))
                .collect();
            let mut specs: Vec<String> = STRUCTURES.iter().map(|s| s.to_string()).collect();
            specs.extend(
                [
                    "hug:store=index",
                    "hug:filter=levels,min_cluster=1,loose=1e30",
                    "bvh:spatial=1",
                    "grid:prune=true",
                ]
                .map(String::from),
            );
            for spec in &specs {
                let world = World::build(scene.clone(), spec).unwrap();
                assert_agrees(&world.top().1, spec, &rays);
                for (ray, want) in rays.iter().zip(&expected) {
                    let got = world.closest_hit(ray, &mut NoCounters);
                    match (want, got) {
                        (None, None) => {}
                        // The same primitive, or (a tie) another at the same `t`.
                        (Some(w), Some(g)) => {
                            assert_eq!(w.t, g.t, "{spec}, seed {seed}: t of {ray:?}")
                        }
                        _ => panic!("{spec}, seed {seed}: {ray:?}: brute {want:?}, got {got:?}"),
                    }
                    assert_eq!(
                        want.is_some(),
                        world.any_hit(ray, &mut NoCounters),
                        "{spec}: any-hit of {ray:?}"
                    );
                }
            }
        }
    }
}

/// The flattened scene's hit for each ray, by brute force.
fn flat_hits(scene: &InstancedScene, rays: &[Ray]) -> Vec<Option<hugrt::accel::Hit>> {
    let flat = scene.flattened().unwrap();
    let brute = hugrt::accel::AnyAccel::build(&flat, "brute").unwrap();
    rays.iter()
        .map(|r| brute.closest_hit(&flat, r, &mut NoCounters))
        .collect()
}

#[test]
fn instances_placed_exactly_hit_what_their_flattened_copies_hit() {
    for (seed, shapes) in [(11, false), (12, true), (13, false)] {
        let scene = exact_three_levels(seed, shapes);
        assert_eq!(
            scene.flattened_counts()[2] as usize,
            scene.flattened().unwrap().len()
        );
        let world = World::build(scene.clone(), "hug").unwrap();
        let rays = dyadic_rays(&world.bounds(), seed, 2000);
        let want = flat_hits(&scene, &rays);
        let (mut hits, mut placed) = (0, 0);
        for (ray, w) in rays.iter().zip(&want) {
            let got = world.closest_hit(ray, &mut NoCounters);
            match (w, got) {
                (None, None) => {}
                (Some(w), Some(g)) => {
                    hits += 1;
                    placed += usize::from(g.instances.top().is_some());
                    // Triangles' watertight test commutes with the transforms bit for bit;
                    // spheres' and cones' dot products sum the axes in another order.
                    let ulps = if shapes { 4e-7 * w.t.abs() } else { 0.0 };
                    assert!(
                        (w.t - g.t).abs() <= ulps,
                        "seed {seed}: {ray:?}: {w:?} {g:?}"
                    );
                    assert_eq!(w.prim as u64, g.flat_prim, "seed {seed}: {ray:?}");
                }
                _ => panic!("seed {seed}: {ray:?}: flattened {w:?}, instanced {got:?}"),
            }
        }
        assert!(
            hits > 100 && placed + 2 >= hits,
            "seed {seed}: {hits} hits, {placed} in instances"
        );
    }
}

#[test]
fn turned_scaled_and_mirrored_instances_hit_what_their_flattened_copies_hit() {
    for seed in [21, 22] {
        let mut r = rng(seed);
        let scene = three_levels(seed, false, &mut |k| general(&mut r, k % 2 == 0));
        let world = World::build(scene.clone(), "bvh").unwrap();
        let flat = scene.flattened().unwrap();
        let rays = rays_for(&world.bounds(), seed, 3000);
        let want = flat_hits(&scene, &rays);
        let (mut same, mut hits) = (0, 0);
        for (ray, w) in rays.iter().zip(&want) {
            let got = world.closest_hit(ray, &mut NoCounters);
            match (w, got) {
                (None, None) => same += 1,
                (Some(w), Some(g)) => {
                    hits += 1;
                    // The copies' vertices are rounded once more than the instances' rays:
                    // `t` agrees to a few ulps of the scene, and a ray through an edge may
                    // take the neighbour.
                    let scale = ray.dir.length() * w.t.abs().max(1.0);
                    assert!(
                        (w.t - g.t).abs() * ray.dir.length() <= 1e-4 * scale,
                        "seed {seed}: {ray:?}: t {} against {}",
                        w.t,
                        g.t
                    );
                    if w.prim as u64 == g.flat_prim {
                        same += 1;
                        let d = hugrt::accel::Hit {
                            t: g.t,
                            prim: w.prim,
                        }
                        .details(&flat, ray);
                        let n = world.details(&g, ray).normal;
                        assert!(
                            d.normal.dot(n) > 0.999,
                            "seed {seed}: normals {} and {n}",
                            d.normal
                        );
                    }
                }
                _ => {}
            }
        }
        assert!(hits > 500, "seed {seed}: only {hits} hits");
        assert!(
            same as f64 >= 0.995 * rays.len() as f64,
            "seed {seed}: {same} of {} rays agree",
            rays.len()
        );
    }
}

#[test]
fn bad_instanced_scenes_are_named() {
    let part = model("part", triangle_soup(1, 5), Vec::new());
    let place = |model, transform| Instance { model, transform };
    let with = |instances| InstancedScene {
        models: vec![part.clone(), model("world", Scene::default(), instances)],
    };
    assert!(matches!(
        with(vec![place(1, Affine3A::IDENTITY)]).check(),
        Err(InstanceError::NotBefore { target: 1, .. })
    ));
    let flat = Affine3A::from_scale(Vec3::new(1.0, 0.0, 1.0));
    assert!(matches!(
        with(vec![place(0, flat)]).check(),
        Err(InstanceError::Transform { .. })
    ));
    let nan = Affine3A::from_translation(Vec3::new(f32::NAN, 0.0, 0.0));
    let e = World::build(with(vec![place(0, nan)]), "hug")
        .err()
        .unwrap();
    assert!(e.to_string().contains("NaN"), "{e}");
    assert!(matches!(
        InstancedScene::default().check(),
        Err(InstanceError::NoModels)
    ));
    let deep = InstancedScene {
        models: std::iter::once(part.clone())
            .chain((1..=hugrt::scene::MAX_NESTING as u32).map(|k| {
                model(
                    "level",
                    Scene::default(),
                    vec![place(k - 1, Affine3A::IDENTITY)],
                )
            }))
            .collect(),
    };
    assert!(matches!(deep.check(), Err(InstanceError::TooDeep { .. })));
    let sheared = InstancedScene {
        models: vec![
            model("ball", mixed(1, 1), Vec::new()),
            model(
                "world",
                Scene::default(),
                vec![place(0, Affine3A::from_scale(Vec3::new(1.0, 2.0, 1.0)))],
            ),
        ],
    };
    assert!(matches!(
        sheared.flattened(),
        Err(InstanceError::NotSimilar { what: "sphere", .. })
    ));
}

/// 10^5 instances of a small model over one spot: each structure's references stay within a
/// small multiple of the instances (the grids' cells are made for their objects, not for
/// one cell), and the nearest one is found.
#[test]
fn many_instances_over_one_cell_keep_references_bounded() {
    let n = 100_000;
    let mut r = rng(5);
    let part = model("part", triangle_soup(3, 8), Vec::new());
    let instances = (0..n)
        .map(|_| Instance {
            model: 0,
            transform: Affine3A::from_translation(v3(&mut r, -1e-3, 1e-3)),
        })
        .collect();
    let scene = InstancedScene {
        models: vec![part, model("world", Scene::default(), instances)],
    };
    for spec in ["hug", "grid", "bvh"] {
        let world = World::build(scene.clone(), spec).unwrap();
        let stats = world.stats();
        let refs = stats.census.object_refs;
        // The promise of `tests/bounds.rs`: at most `64·n + 4096` references a grid, one
        // reference an object in a bvh without spatial splits.
        let bound = if spec == "bvh" { n } else { 64 * n + 4096 };
        assert!(refs <= bound, "{spec}: {refs} references to {n} instances");
        assert_eq!(world.instances(), n as u64);
        assert_eq!(world.flattened_primitives(), 8 * n as u64);
        let ray = Ray::new(Vec3::new(-5.0, 0.1, 0.2), Vec3::X, 0.0, f32::INFINITY);
        let (accel, prims) = world.top();
        let brute = hugrt::accel::AnyAccel::build(&prims, "brute").unwrap();
        assert_eq!(
            accel
                .closest_hit(&prims, &ray, &mut NoCounters)
                .map(|h| h.t),
            brute
                .closest_hit(&prims, &ray, &mut NoCounters)
                .map(|h| h.t),
            "{spec}"
        );
    }
}

/// The world rendered through its instances is the flattened world's image: the renderer
/// shades an instance's hit by its model's material and the transformed normals.
#[test]
fn an_instanced_world_renders_as_its_flattened_copies() {
    use hugrt::render::{RenderSettings, render, render_world};
    for (seed, shapes) in [(31, false), (32, true)] {
        let mut scene = exact_three_levels(seed, shapes);
        let b = scene.flattened().unwrap().bounds();
        let world_scene = &mut scene.models.last_mut().unwrap().scene;
        world_scene.camera = hugrt::scene::Camera::framing(&b);
        world_scene.lights[0].position = world_scene.camera.from + Vec3::Y * b.diagonal();
        // Mirror and glass, so that reflected and refracted rays cross instances too.
        for m in &mut scene.models {
            m.scene.materials[0].ks = 0.3;
            m.scene.materials[0].transmittance = 0.2;
            m.scene.materials[0].ior = 1.3;
        }
        let flat = scene.flattened().unwrap();
        let settings = RenderSettings {
            width: 64,
            height: 64,
            depth: 3,
            counters: false,
            packets: Default::default(),
        };
        for spec in ["hug", "bvh"] {
            let world = World::build(scene.clone(), spec).unwrap();
            let accel = hugrt::accel::AnyAccel::build(&flat, spec).unwrap();
            let want = render(&flat, &accel, &settings, &|_| {});
            let got = render_world(&world, &settings, &|_| {});
            assert_eq!(want.counts, got.counts, "{spec}, seed {seed}");
            assert!(
                want.counts.eye_hits > 100,
                "{spec}, seed {seed}: {:?}",
                want.counts
            );
            let differ = want
                .image
                .pixels()
                .zip(got.image.pixels())
                .filter(|(a, b)| a != b)
                .count();
            assert_eq!(differ, 0, "{spec}, seed {seed}: {differ} pixels differ");
        }
    }
}

/// `hugrt gen building --instanced` as NFF, read back model for model: the same
/// primitives, instances and transforms.
#[test]
fn instanced_nff_reads_back_what_was_written() {
    use hugrt::scene::generate;
    let scene = generate::instanced("building", 3, 7).unwrap();
    let mut bytes = Vec::new();
    hugrt::scene::write::write_instanced_nff(&scene, &mut bytes).unwrap();
    let text = String::from_utf8(bytes.clone()).unwrap();
    assert_eq!(text.matches("\ninstance kitchen ").count(), 3);
    let path = std::env::temp_dir().join(format!("hugrt-instanced-{}.nff", std::process::id()));
    std::fs::write(&path, &bytes).unwrap();
    let back = InstancedScene::open(path.to_str().unwrap()).unwrap();
    assert_eq!(back.models.len(), 2);
    for (a, b) in scene.models.iter().zip(&back.models) {
        assert_eq!(a.instances, b.instances, "{}", a.name);
        assert_eq!(a.scene.len(), b.scene.len(), "{}", a.name);
        assert!(a.scene.primitives().eq(b.scene.primitives()), "{}", a.name);
        for p in 0..a.scene.len() as u32 {
            assert_eq!(a.scene.material(p), b.scene.material(p));
        }
    }
    assert_eq!(
        back.world().unwrap().scene.camera,
        scene.world().unwrap().scene.camera
    );
    // Asked for flat, the same file comes flattened into copies.
    let flat = Scene::load(&path).unwrap();
    assert_eq!(flat.len() as u64, scene.flattened_counts()[1]);
    // Names that the format would read as one are written apart.
    let place = |model| Instance {
        model,
        transform: Affine3A::IDENTITY,
    };
    let clash = InstancedScene {
        models: vec![
            model("a b", triangle_soup(1, 2), Vec::new()),
            model("a_b", triangle_soup(2, 2), Vec::new()),
            model("", triangle_soup(3, 2), Vec::new()),
            model(
                "world",
                Scene::default(),
                vec![place(0), place(1), place(2)],
            ),
        ],
    };
    let mut bytes = Vec::new();
    hugrt::scene::write::write_instanced_nff(&clash, &mut bytes).unwrap();
    std::fs::write(&path, &bytes).unwrap();
    let back = InstancedScene::open(path.to_str().unwrap()).unwrap();
    assert_eq!(back.models.len(), 4);
    assert_eq!(back.models[3].instances, clash.models[3].instances);
    std::fs::remove_file(&path).ok();
}

#[test]
fn instance_lines_take_matrices_and_steps() {
    let nff = |body: &str| {
        let text = format!("define box\np 3\n0 0 0\n1 0 0\n0 1 0\nend\n{body}\n");
        Scene::from_bytes("t.nff", text.as_bytes()).map(|s| s.shapes)
    };
    let moved = nff("instance box translate 1 2 3 rotate 0 0 1 90 scale 2").unwrap();
    let want = Affine3A::from_scale(Vec3::splat(2.0))
        * Affine3A::from_rotation_z(90f32.to_radians())
        * Affine3A::from_translation(Vec3::new(1.0, 2.0, 3.0));
    let hugrt::geometry::Shape::Triangle(v) = moved[0] else {
        panic!("{moved:?}")
    };
    assert!(
        v[1].distance(want.transform_point3(Vec3::X)) < 1e-5,
        "{v:?}"
    );
    let matrix = nff("instance box 0 -1 0 5  1 0 0 6  0 0 -1 7").unwrap();
    let hugrt::geometry::Shape::Triangle(v) = matrix[0] else {
        panic!()
    };
    assert_eq!(
        v,
        [
            Vec3::new(5.0, 6.0, 7.0),
            Vec3::new(5.0, 7.0, 7.0),
            Vec3::new(4.0, 6.0, 7.0)
        ]
    );
    for (body, says) in [
        ("instance cup translate 0 0 0", "no model 'cup'"),
        ("instance box spin 3", "'spin' is not a transform step"),
        (
            "instance box translate 1 2",
            "'translate' expects 3 numbers",
        ),
        ("instance box scale 1 0 1", "singular"),
        ("instance box rotate 0 0 0 30", "axis is zero"),
        ("end", "end without a definition"),
        ("define box\nend", "already defined"),
        ("define cup\nl 0 0 0\nend", "lights belong to the world"),
        ("define cup\ndefine mug", "inside a definition"),
        (
            "define cup\ninstance box translate 0 0 0",
            "'cup' not ended",
        ),
    ] {
        let e = nff(body).unwrap_err().to_string();
        assert!(e.contains(says), "{body}: {e}");
        assert!(e.contains("t.nff:"), "{body}: names no line: {e}");
    }
}

/// `hugrt render` of a built-in instanced building: its world built through instances
/// renders as the building flattened into copies (quarter turns round their sines, so the
/// copies' vertices move by an ulp: a few pixels on edges may differ).
#[test]
fn a_render_job_renders_instances_as_their_copies() {
    use hugrt::render::{RenderJob, RenderSettings, render};
    let name = "builtin:building:2:instanced";
    let job = RenderJob {
        width: Some(96),
        height: Some(96),
        ..RenderJob::new(name, "hug")
    };
    let (got, report) = job.run(&|_, _| {}).unwrap();
    assert_eq!(report.instances, Some(2));
    let flat = Scene::open(name).unwrap();
    assert_eq!(report.primitives, flat.len());
    let accel = hugrt::accel::AnyAccel::build(&flat, "hug").unwrap();
    let settings = RenderSettings {
        width: 96,
        height: 96,
        depth: 4,
        counters: false,
        packets: Default::default(),
    };
    let want = render(&flat, &accel, &settings, &|_| {});
    let differ = want
        .image
        .pixels()
        .zip(got.image.pixels())
        .filter(|(a, b)| a != b)
        .count();
    assert!(differ * 200 <= 96 * 96, "{differ} pixels differ");
    assert!(want.counts.eye_hits > 1000, "{:?}", want.counts);
}

/// Memory by the structures' own accounting: a town's models are built once, so its bytes
/// grow with its instances, not with its flattened primitives (item 6 of the scale issue).
#[test]
fn a_world_s_memory_grows_with_its_instances_not_its_copies() {
    for spec in ["hug", "bvh"] {
        let small = World::build(InstancedScene::open("builtin:town:2").unwrap(), spec).unwrap();
        let large = World::build(InstancedScene::open("builtin:town:8").unwrap(), spec).unwrap();
        assert_eq!(large.instances() - small.instances(), 60);
        // 16 times the towers; the ground (two triangles) once.
        assert_eq!(
            large.flattened_primitives(),
            16 * small.flattened_primitives() - 30
        );
        let per_instance = (large.memory_bytes() - small.memory_bytes()) as f64 / 60.0;
        assert!(
            per_instance < 1024.0,
            "{spec}: {per_instance} bytes an added tower"
        );
        let per_flat = large.memory_bytes() as f64 / large.flattened_primitives() as f64;
        assert!(
            per_flat < 0.1,
            "{spec}: {per_flat} bytes a flattened primitive"
        );
    }
}
