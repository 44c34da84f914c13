//! Criterion benchmarks of build and traversal on the built-in clustered room. They measure
//! one structure against another in the same run; absolute figures depend on the machine.
//! The scene-file comparison (SPD scenes, meshes, Embree ratios) is `hugrt bench`.

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use hugrt::accel::{AnyAccel, Packets};
use hugrt::batch;
use hugrt::scene::procedural::clustered_room;
use std::hint::black_box;

const SPECS: &[&str] = &[
    "grid",
    "grid:density=16",
    "hug",
    "hug:filter=levels,cluster=cluster3d,alpha=0.01,world=2n,density=1,prune=false",
    "bvh",
    "kdtree",
];

fn build(c: &mut Criterion) {
    let scene = clustered_room(100_000, 1);
    let mut g = c.benchmark_group("build");
    g.throughput(Throughput::Elements(scene.len() as u64));
    for spec in SPECS {
        g.bench_with_input(BenchmarkId::from_parameter(spec), spec, |b, spec| {
            b.iter(|| black_box(AnyAccel::build(&scene, spec).unwrap()))
        });
    }
    g.finish();
}

fn closest_hit(c: &mut Criterion) {
    let scene = clustered_room(100_000, 1);
    let bounds = scene.bounds();
    let sets = [
        ("incoherent", batch::incoherent_rays(&bounds, 20_000, 7)),
        ("camera", batch::camera_rays(&bounds, 160, 120)),
    ];
    let mut g = c.benchmark_group("closest_hit");
    for spec in SPECS {
        let accel = AnyAccel::build(&scene, spec).unwrap();
        for (name, rays) in &sets {
            g.throughput(Throughput::Elements(rays.len() as u64));
            let mut out = vec![None; rays.len()];
            g.bench_function(BenchmarkId::new(*spec, name), |b| {
                b.iter(|| {
                    batch::trace_into(&scene, &accel, rays, false, Packets::Auto, &mut out);
                    black_box(&out);
                })
            });
        }
    }
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10);
    targets = build, closest_hit
}
criterion_main!(benches);
