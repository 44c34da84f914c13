//! Tests on the shared scene files (`../shared/scenes`, beside the repository). A user's clone
//! has none: then each test says so and passes without checking anything.

mod common;

use hugrt::accel::AnyAccel;
use hugrt::render::{RenderSettings, render};
use hugrt::scene::Scene;
use std::io::Write;
use std::path::PathBuf;

fn shared(rel: &str) -> Option<PathBuf> {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/scenes")
        .join(rel);
    if p.exists() {
        Some(p)
    } else {
        // Written to the real stderr: the test harness captures `eprintln!` of passing tests.
        let _ = writeln!(
            std::io::stderr(),
            "skipped: {} not found (the shared scenes are not beside this clone)",
            p.display()
        );
        None
    }
}

#[test]
fn spd_gears_and_bunny_agree_with_brute_force() {
    for (rel, rays) in [
        ("spd/gears.nff.gz", 1500),
        ("meshes/stanford-bunny.ply.gz", 600),
    ] {
        let Some(path) = shared(rel) else { continue };
        let s = Scene::load(&path).unwrap();
        let mut rays_ = common::rays_for(&s.bounds(), 21, rays);
        rays_.extend(hugrt::batch::camera_rays(&s.bounds(), 24, 24));
        common::assert_all_agree(&s, &common::specs(), &rays_);
    }
}

/// Published counts (`../shared/docs/nff-format.md`): eye hits, reflected, refracted, shadow.
const PUBLISHED: &[(&str, [u64; 4])] = &[
    ("balls", [263169, 175095, 0, 954368]),
    ("gears", [245086, 304643, 207564, 2246955]),
    ("mount", [173125, 354769, 354769, 412922]),
    ("rings", [263169, 315236, 0, 1085002]),
    ("teapot", [161120, 225248, 0, 407656]),
    ("tetra", [49788, 0, 0, 46112]),
    ("tree", [169836, 0, 0, 1097419]),
];

/// The SPD procedure at 512×512 lands within 5% of every published count (the SPD notes say
/// classical ray tracers agree "within about 10%"; hugrt's largest gap is gears' refracted
/// rays, 3% low).
#[test]
fn spd_ray_counts_land_near_the_published_ones() {
    for (name, want) in PUBLISHED {
        let Some(path) = shared(&format!("spd/{name}.nff.gz")) else {
            return;
        };
        let s = Scene::load(&path).unwrap();
        let accel = AnyAccel::build(&s, "grid").unwrap();
        let settings = RenderSettings {
            width: 512,
            height: 512,
            depth: 4,
            counters: false,
            packets: Default::default(),
        };
        let c = render(&s, &accel, &settings, &|_| {}).counts;
        assert_eq!(c.eye_rays, 263169);
        let got = [
            c.eye_hits,
            c.reflected_rays,
            c.refracted_rays,
            c.shadow_rays,
        ];
        for ((g, w), what) in
            got.iter()
                .zip(want)
                .zip(["eye hits", "reflected", "refracted", "shadow"])
        {
            let off = (*g as f64 - *w as f64).abs() / (*w).max(1) as f64;
            assert!(
                off <= 0.05,
                "{name}: {what} {g}, published {w} ({:.1}% off)",
                off * 100.0
            );
        }
    }
}
