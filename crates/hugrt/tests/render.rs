//! Images: every structure renders the same image as brute force, pixel for pixel, with the
//! same ray counts; and the image does not depend on the number of threads.

mod common;

use hugrt::accel::AnyAccel;
use hugrt::render::{RenderSettings, Rendered, render};
use hugrt::scene::{Scene, procedural::clustered_room};

fn fixture() -> Scene {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/features.nff");
    Scene::load(path).unwrap()
}

fn draw(scene: &Scene, spec: &str, width: u32, height: u32) -> Rendered {
    let accel = AnyAccel::build(scene, spec).unwrap();
    let settings = RenderSettings {
        width,
        height,
        depth: 4,
        counters: false,
    };
    render(scene, &accel, &settings, &|_| {})
}

fn assert_same_image(scene: &Scene, what: &str, width: u32, height: u32) {
    let reference = draw(scene, "brute", width, height);
    assert!(
        reference.counts.eye_hits > 0,
        "{what}: the camera sees nothing"
    );
    let distinct: std::collections::HashSet<_> = reference.image.pixels().map(|p| p.0).collect();
    assert!(
        distinct.len() > 8,
        "{what}: a flat image cannot show a difference"
    );
    for spec in common::specs() {
        let r = draw(scene, &spec, width, height);
        assert_eq!(
            r.counts, reference.counts,
            "{what}: ray counts differ for {spec}"
        );
        let differing = r
            .image
            .pixels()
            .zip(reference.image.pixels())
            .filter(|(a, b)| a != b)
            .count();
        assert_eq!(differing, 0, "{what}: {differing} pixels differ for {spec}");
    }
}

#[test]
fn fixture_renders_identically_with_every_structure() {
    let s = fixture();
    assert!(
        s.shapes
            .iter()
            .any(|x| matches!(x, hugrt::geometry::Shape::Sphere(_)))
    );
    let r = draw(&s, "brute", s.camera.width, s.camera.height);
    assert!(r.counts.refracted_rays > 0 && r.counts.reflected_rays > 0 && r.counts.shadow_hits > 0);
    assert_same_image(&s, "features.nff", s.camera.width, s.camera.height);
}

#[test]
fn clustered_room_renders_identically_with_every_structure() {
    assert_same_image(&clustered_room(4000, 3), "room", 72, 48);
}

#[test]
fn image_does_not_depend_on_thread_count() {
    let s = clustered_room(4000, 4);
    let on = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| draw(&s, "grid", 96, 64))
    };
    let (one, three) = (on(1), on(3));
    assert_eq!(one.counts, three.counts);
    assert!(
        one.image == three.image,
        "images differ between 1 and 3 threads"
    );
}
