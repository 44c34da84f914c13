//! The library's whole jobs, which the CLI only calls: a rendering, statistics, a timed
//! batch, output formats chosen by file name, and their checks before any work.

use hugrt::accel::{AnyAccel, Packets};
use hugrt::batch::{self, HitFormat, Query};
use hugrt::render::{ImageFormat, RenderJob, RenderSettings, render};
use hugrt::scene::write::SceneFormat;
use hugrt::scene::{Scene, View, ViewError, generate};
use hugrt::stats::StatsReport;
use std::path::Path;

#[test]
fn a_render_job_is_the_rendering_of_its_parts() {
    let job = RenderJob {
        width: Some(40),
        height: Some(30),
        ..RenderJob::new("builtin:kitchen:1", "grid")
    };
    let (out, report) = job.run(&|_, _| {}).unwrap();
    let scene = Scene::open("builtin:kitchen:1").unwrap();
    let accel = AnyAccel::build(&scene, "grid").unwrap();
    let settings = RenderSettings {
        width: 40,
        height: 30,
        depth: 4,
        counters: false,
        packets: Default::default(),
    };
    let direct = render(&scene, &accel, &settings, &|_| {});
    assert_eq!(out.image, direct.image);
    assert_eq!(report.counts, direct.counts);
    assert_eq!(
        (report.primitives, report.lights, report.structure),
        (scene.len(), scene.lights.len(), "grid")
    );
}

#[test]
fn a_render_job_checks_before_work() {
    let bad = [
        RenderJob::new("builtin:kitchen:1", "grid:dens=2"),
        RenderJob {
            width: Some(0),
            ..RenderJob::new("builtin:kitchen:1", "grid")
        },
        RenderJob {
            soft_shadows: Some(f32::NAN),
            ..RenderJob::new("builtin:kitchen:1", "grid")
        },
        RenderJob {
            depth: 1000,
            ..RenderJob::new("builtin:kitchen:1", "grid")
        },
    ];
    for job in bad {
        assert!(job.check().is_err(), "{job:?}");
    }
    let empty = RenderJob::new("builtin:room:1", "grid");
    assert!(empty.check().is_ok());
}

#[test]
fn views_that_cannot_be_are_named() {
    let c = Scene::open("builtin:kitchen:1").unwrap().camera;
    assert_eq!(c.viewed(&View::default()), Ok(c));
    let fov = View {
        fov: Some(180.0),
        ..View::default()
    };
    assert_eq!(c.viewed(&fov), Err(ViewError::Fov(180.0)));
    let same = View {
        eye: Some(c.at),
        ..View::default()
    };
    assert_eq!(c.viewed(&same), Err(ViewError::SamePoint));
    let up = View {
        up: Some(c.at - c.from),
        ..View::default()
    };
    assert!(matches!(c.viewed(&up), Err(ViewError::UpParallel(_))));
}

#[test]
fn output_formats_follow_the_file_name() {
    assert_eq!(
        ImageFormat::for_path(Path::new("a.PNG")).unwrap(),
        ImageFormat::Png
    );
    assert_eq!(
        ImageFormat::for_path(Path::new("a.exr")).unwrap(),
        ImageFormat::Exr
    );
    assert!(ImageFormat::for_path(Path::new("a.jpg")).is_err());
    assert!(ImageFormat::for_path(&std::env::temp_dir()).is_err());
    assert_eq!(
        SceneFormat::for_path(Path::new("a.nff")).unwrap(),
        SceneFormat::Nff
    );
    assert_eq!(
        SceneFormat::for_path(Path::new("a.Ply")).unwrap(),
        SceneFormat::Ply
    );
    assert!(SceneFormat::for_path(Path::new("a.obj")).is_err());
    assert_eq!(generate::resolve_size("kitchen", 0).unwrap(), 2);
    assert_eq!(generate::resolve_size("kitchen", 3).unwrap(), 3);
    assert!(generate::resolve_size("kitchen", 65).is_err());
    assert!(generate::resolve_size("octopus", 1).is_err());
}

#[test]
fn a_timed_batch_writes_what_the_untimed_one_finds() {
    let scene = Scene::open("builtin:kitchen:1").unwrap();
    let accel = AnyAccel::build(&scene, "bvh").unwrap();
    let mut rays = batch::incoherent_rays(&Scene::bounds(&scene), 500, 3);
    rays.extend(batch::camera_rays(&Scene::bounds(&scene), 32, 16));
    let closest = batch::trace(&scene, &accel, &rays, false, Packets::Off);
    let timed = |query, format, repeat| {
        batch::trace_timed(&scene, &accel, &rays, query, format, repeat, Packets::On)
    };
    let t = timed(Query::Closest, HitFormat::Basic, 2).unwrap();
    assert_eq!(t.bytes, batch::encode_hits(&closest), "packets or not");
    assert_eq!(t.hits, closest.iter().flatten().count());
    let all = timed(Query::All, HitFormat::Basic, 1).unwrap();
    assert_eq!(
        all.bytes,
        batch::encode_all_hits(&batch::trace_all(&scene, &accel, &rays))
    );
    assert!(timed(Query::Any, HitFormat::Full, 1).is_err());
}

#[test]
fn statistics_and_names_come_from_the_library() {
    let r = StatsReport::measure("builtin:kitchen:1", "hug").unwrap();
    let j = serde_json::to_value(&r).unwrap();
    for key in [
        "scene",
        "accel",
        "scene_stats",
        "build_seconds",
        "scene_memory_bytes",
        "structure",
        "levels",
        "depths",
    ] {
        assert!(j.get(key).is_some(), "{key}");
    }
    assert!(j["structure"]["memory_bytes"].as_f64().unwrap() > 0.0);
    assert!(StatsReport::measure("builtin:kitchen:1", "hug:nope=1").is_err());
    assert_eq!(
        AnyAccel::describe(None).unwrap().len(),
        hugrt::accel::STRUCTURES.len()
    );
    assert!(AnyAccel::describe(Some("octopus")).is_err());
    let names: Vec<&str> = hugrt::reproduce::resolve(&["all"])
        .unwrap()
        .iter()
        .map(|t| t.name)
        .collect();
    assert_eq!(names.len(), hugrt::reproduce::TARGETS.len());
    assert!(hugrt::reproduce::resolve(&["octopus"]).is_err());
}

#[test]
fn a_reproduction_says_why_it_skipped_a_scene() {
    let dir = std::env::temp_dir().join(format!("hugrt-jobs-{}", std::process::id()));
    let spd = dir.join("spd");
    std::fs::create_dir_all(&spd).unwrap();
    // Not gzipped: the loader reads by content, whatever the name says.
    let view = "v\nfrom 0 0 oops\nat 0 0 1\nup 0 1 0\nangle 45\nhither 1\nresolution 8 8\n";
    std::fs::write(spd.join("balls.nff.gz"), view).unwrap();
    let options = hugrt::reproduce::Options {
        quick: true,
        spd_dir: spd.clone(),
        ..Default::default()
    };
    let out = hugrt::reproduce::run("rtnews-spd", &options, &dir).unwrap();
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    // The file and the line of the bad number, not "not found".
    let malformed = format!(
        "{}:2: from: 'oops' is not a number",
        spd.join("balls.nff.gz").display()
    );
    assert!(report.contains(&malformed), "{report}");
    assert!(report.contains("gears.nff.gz"), "{report}");
}

#[test]
fn eg95_kitchens_quick_writes_consistent_data_and_plots() {
    let dir = std::env::temp_dir().join(format!("hugrt-eg95-{}", std::process::id()));
    let options = hugrt::reproduce::Options {
        quick: true,
        spd_dir: dir.join("none"),
        ..Default::default()
    };
    let out = hugrt::reproduce::run("eg95-kitchens", &options, &dir).unwrap();
    let read = |f: &str| std::fs::read_to_string(out.join(f)).unwrap();
    let (report, csv) = (read("report.md"), read("rows.csv"));
    let json: serde_json::Value = serde_json::from_str(&read("data.json")).unwrap();
    let rows: Vec<&str> = csv.lines().skip(1).collect();
    assert_eq!(rows.len(), json["rows"].as_array().unwrap().len());
    // Eight structures on each of the quick run's two scenes.
    assert_eq!(rows.len(), 16, "{csv}");
    for set in ["one kitchen", "many kitchens"] {
        let n = rows.iter().filter(|r| r.starts_with(set)).count();
        let file = if set == "one kitchen" {
            "fig11a-time-one-kitchen.svg"
        } else {
            "fig11b-time-many-kitchens.svg"
        };
        // A point per row of the set, and nothing else drawn as a circle.
        assert_eq!(read(file).matches("<circle").count(), n, "{file}");
    }
    for r in json["rows"].as_array().unwrap() {
        let nu1 = r["voxels"].as_f64().unwrap() / r["polygons"].as_f64().unwrap();
        assert!((r["nu1"].as_f64().unwrap() - nu1).abs() < 1e-9);
        assert!(r["memory_mb"].as_f64().unwrap() > 0.0);
    }
    // Five statements, each with a computed verdict.
    let verdicts = report.split("## Verdicts").nth(1).unwrap();
    let judged = verdicts
        .lines()
        .filter(|l| {
            l.starts_with("- ")
                && ["holds", "is a tie here", "does not hold"]
                    .iter()
                    .any(|w| l.contains(w))
        })
        .count();
    assert_eq!(judged, 5, "{verdicts}");
    // The index shows every plot the folder holds, and nothing it does not.
    let index = std::fs::read_to_string(hugrt::reproduce::write_index(&dir).unwrap()).unwrap();
    let images: Vec<&str> = index
        .split("<img src=\"")
        .skip(1)
        .map(|s| s.split('"').next().unwrap())
        .collect();
    assert_eq!(images.len(), 6, "{index}");
    for img in images {
        assert!(dir.join(img).is_file(), "{img}");
    }
    assert!(index.contains("eg95-kitchens/report.md") && !index.contains("rtnews-spd"));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// An EXR file holds the rendering's radiance unclamped, pixel for pixel; the PNG of the same
/// rendering holds it clamped and quantised.
#[test]
fn exr_keeps_the_radiance_and_png_the_image() {
    let mut scene = Scene::open("builtin:kitchen").unwrap();
    for light in &mut scene.lights {
        light.color *= 4.0;
    }
    let accel = AnyAccel::build(&scene, "bvh").unwrap();
    let settings = RenderSettings {
        width: 24,
        height: 16,
        depth: 2,
        counters: false,
        packets: Default::default(),
    };
    let rendered = render(&scene, &accel, &settings, &|_| {});
    let dir = std::env::temp_dir().join(format!("hugrt-exr-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let exr_path = dir.join("k.exr");
    hugrt::render::save_image(&rendered, &exr_path).unwrap();
    let image = exr::prelude::read_first_rgba_layer_from_file(
        &exr_path,
        |size, _| vec![[0f32; 3]; size.0 * size.1],
        |pixels: &mut Vec<[f32; 3]>, p, (r, g, b, _): (f32, f32, f32, f32)| {
            pixels[p.1 * 24 + p.0] = [r, g, b]
        },
    )
    .unwrap();
    let read = &image.layer_data.channel_data.pixels;
    let want: Vec<[f32; 3]> = rendered.radiance.iter().map(|c| c.to_array()).collect();
    assert_eq!(read, &want);
    assert!(
        want.iter().any(|c| c.iter().any(|&v| v > 1.0)),
        "some radiance above 1 to keep"
    );
    let png_path = dir.join("k.png");
    hugrt::render::save_image(&rendered, &png_path).unwrap();
    let png = image::open(&png_path).unwrap().to_rgb8();
    assert_eq!(png, rendered.image);
    std::fs::remove_dir_all(&dir).unwrap();
}
