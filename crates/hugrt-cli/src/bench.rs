//! `hugrt bench`: build time, throughput and memory of structures, as ratios are quoted in the
//! README and closing notes. Timings are medians of `repeat` runs, every figure of a table
//! measured in the same process, one right after the other.

use crate::load_scene;
use anyhow::Result;
use hugrt::accel::AnyAccel;
use hugrt::batch::{camera_rays, incoherent_rays, trace};
use hugrt::geometry::Ray;
use hugrt::scene::Scene;
use std::path::Path;
use std::time::Instant;

/// What `hugrt bench` measures when no scene is named: built in, so that it runs anywhere.
const DEFAULT_SCENES: &[&str] = &[
    "builtin:kitchen",
    "builtin:building",
    "builtin:stadium",
    "builtin:room:1000000",
];

/// Median of timings (the upper one of an even count).
pub(crate) fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn pool(n: usize) -> Result<rayon::ThreadPool> {
    Ok(rayon::ThreadPoolBuilder::new().num_threads(n).build()?)
}

fn mrays(
    scene: &Scene,
    accel: &AnyAccel,
    rays: &[Ray],
    threads: usize,
    repeat: usize,
) -> Result<f64> {
    let p = pool(threads)?;
    let secs: Vec<f64> = (0..repeat)
        .map(|_| {
            p.install(|| {
                let t = Instant::now();
                std::hint::black_box(trace(scene, accel, rays, false));
                t.elapsed().as_secs_f64()
            })
        })
        .collect();
    Ok(rays.len() as f64 / median(secs) / 1e6)
}

pub fn run(
    scenes: &[String],
    accels: &[String],
    n_rays: usize,
    cam: u32,
    repeat: usize,
) -> Result<()> {
    let mut scenes = scenes.to_vec();
    if scenes.is_empty() {
        scenes.extend(DEFAULT_SCENES.iter().map(|s| s.to_string()));
    }
    println!(
        "| scene | prims | structure | build ms 1T / 2T | B/prim | incoherent Mrays/s 1T / 2T | camera Mrays/s 1T / 2T |"
    );
    println!("| --- | --- | --- | --- | --- | --- | --- |");
    for name in &scenes {
        let scene = load_scene(name)?;
        let b = scene.bounds();
        let inc = incoherent_rays(&b, n_rays, 1);
        let camr = camera_rays(&b, cam, cam);
        for spec in accels {
            let mut build_ms = [0.0; 2];
            let mut accel = None;
            for (k, threads) in [1, 2].into_iter().enumerate() {
                let p = pool(threads)?;
                let mut times = Vec::new();
                for _ in 0..repeat {
                    let t = Instant::now();
                    let a = p.install(|| AnyAccel::build(&scene, spec))?;
                    times.push(t.elapsed().as_secs_f64() * 1e3);
                    accel = Some(a);
                }
                build_ms[k] = median(times);
            }
            let accel = accel.expect("repeat >= 1");
            let bpp = accel.memory_bytes() as f64 / scene.shapes.len().max(1) as f64;
            let i1 = mrays(&scene, &accel, &inc, 1, repeat)?;
            let i2 = mrays(&scene, &accel, &inc, 2, repeat)?;
            let c1 = mrays(&scene, &accel, &camr, 1, repeat)?;
            let c2 = mrays(&scene, &accel, &camr, 2, repeat)?;
            let short = Path::new(name)
                .file_name()
                .map_or(name.clone(), |f| f.to_string_lossy().into_owned());
            println!(
                "| {short} | {} | {spec} | {:.0} / {:.0} | {bpp:.1} | {i1:.2} / {i2:.2} | {c1:.2} / {c2:.2} |",
                scene.shapes.len(),
                build_ms[0],
                build_ms[1]
            );
        }
    }
    Ok(())
}
