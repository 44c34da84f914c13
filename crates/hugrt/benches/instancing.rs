//! What instancing costs and saves: one tower of 64 kitchens (`builtin:town:1`), built and
//! traced as a world of instances (the kitchen's structure once, the tower's over 64
//! instances) and flattened into 1.8M triangles, with the HUG and the bvh, in one run.

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use hugrt::accel::{AnyAccel, NoCounters, Packets};
use hugrt::batch;
use hugrt::scene::InstancedScene;
use hugrt::world::World;
use std::hint::black_box;

const SPECS: &[&str] = &["hug", "bvh"];

fn tower() -> InstancedScene {
    InstancedScene::open("builtin:town:1").expect("a built-in scene")
}

fn build(c: &mut Criterion) {
    let scene = tower();
    let flat = scene.flattened().unwrap();
    let mut g = c.benchmark_group("instancing_build");
    g.throughput(Throughput::Elements(flat.len() as u64));
    for spec in SPECS {
        g.bench_function(BenchmarkId::new(*spec, "instanced"), |b| {
            b.iter(|| black_box(World::build(scene.clone(), spec).unwrap()))
        });
        g.bench_function(BenchmarkId::new(*spec, "flattened"), |b| {
            b.iter(|| black_box(AnyAccel::build(&flat, spec).unwrap()))
        });
    }
    g.finish();
}

fn closest_hit(c: &mut Criterion) {
    use rayon::prelude::*;
    let scene = tower();
    let flat = scene.flattened().unwrap();
    let bounds = flat.bounds();
    let sets = [
        ("incoherent", batch::incoherent_rays(&bounds, 20_000, 7)),
        ("camera", batch::camera_rays(&bounds, 160, 120)),
    ];
    let mut g = c.benchmark_group("instancing_closest_hit");
    for spec in SPECS {
        let world = World::build(scene.clone(), spec).unwrap();
        let accel = AnyAccel::build(&flat, spec).unwrap();
        for (name, rays) in &sets {
            g.throughput(Throughput::Elements(rays.len() as u64));
            let mut out = vec![None; rays.len()];
            g.bench_function(BenchmarkId::new(format!("{spec}/flattened"), name), |b| {
                b.iter(|| {
                    batch::trace_into(&flat, &accel, rays, false, Packets::Auto, &mut out);
                    black_box(&out);
                })
            });
            let mut hits = vec![None; rays.len()];
            g.bench_function(BenchmarkId::new(format!("{spec}/instanced"), name), |b| {
                b.iter(|| {
                    hits.par_iter_mut()
                        .zip(rays.par_iter())
                        .with_min_len(256)
                        .for_each(|(o, r)| *o = world.closest_hit(r, &mut NoCounters));
                    black_box(&hits);
                })
            });
        }
    }
    g.finish();
}

criterion_group! {
    name = benches;
    // Without plots: criterion's plotting needs fonts this machine may not have.
    config = Criterion::default().sample_size(10).without_plots();
    targets = build, closest_hit
}
criterion_main!(benches);
