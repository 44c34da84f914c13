//! Images: every structure renders the same image as brute force, pixel for pixel, with the
//! same ray counts; and the image does not depend on the number of threads.

mod common;

use hugrt::accel::{AnyAccel, Packets};
use hugrt::render::{
    RenderSettings, Rendered, SoftShadows, render, render_recorded, render_replayed, render_rows,
    render_soft,
};
use hugrt::scene::{Scene, procedural::clustered_room};

fn fixture() -> Scene {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/features.nff");
    Scene::load(path).unwrap()
}

fn draw(scene: &Scene, spec: &str, width: u32, height: u32) -> Rendered {
    draw_with(scene, spec, None, width, height)
}

/// Renders at depth 4, with soft shadows of that light radius when one is given. Brute force
/// traces ray by ray; every other structure walks every group of eye and shadow rays as a
/// packet (`Packets::On`), so that its image, compared with brute force's, checks both.
fn draw_with(scene: &Scene, spec: &str, radius: Option<f32>, width: u32, height: u32) -> Rendered {
    let accel = AnyAccel::build(scene, spec).unwrap();
    let settings = RenderSettings {
        width,
        height,
        depth: 4,
        counters: false,
        packets: if spec == "brute" {
            Packets::Off
        } else {
            Packets::On
        },
    };
    match radius {
        None => render(scene, &accel, &settings, &|_| {}),
        Some(r) => {
            let soft = SoftShadows::build(scene, spec, r).unwrap();
            render_soft(scene, &accel, &soft, &settings, &|_| {})
        }
    }
}

fn assert_same_image(scene: &Scene, what: &str, width: u32, height: u32) {
    assert_same_image_with(scene, what, None, width, height)
}

/// Every structure's image, with soft shadows of that light radius if one is given, is brute
/// force's, with the same ray counts.
fn assert_same_image_with(scene: &Scene, what: &str, radius: Option<f32>, width: u32, height: u32) {
    let reference = draw_with(scene, "brute", radius, width, height);
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
        let r = draw_with(scene, &spec, radius, width, height);
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

fn draw_soft(scene: &Scene, spec: &str, radius: f32, width: u32, height: u32) -> Rendered {
    draw_with(scene, spec, Some(radius), width, height)
}

/// Soft shadows give brute force's image with every structure. Brute force tests every
/// primitive whatever its box, so a structure whose boxes did not reach as far as the
/// fringes would lose penumbrae here.
#[test]
fn soft_shadows_render_identically_with_every_structure() {
    for (what, scene, w, h, radius) in [
        ("features.nff", fixture(), 48, 32, 0.1),
        ("room", clustered_room(3000, 5), 64, 40, 0.05),
    ] {
        let reference = draw_soft(&scene, "brute", radius, w, h);
        let hard = draw(&scene, "brute", w, h);
        assert!(
            reference.counts.penumbra_rays > 0,
            "{what}: no shadow ray in a penumbra"
        );
        let softened = reference
            .image
            .pixels()
            .zip(hard.image.pixels())
            .filter(|(a, b)| a != b)
            .count();
        assert!(softened > 0, "{what}: soft and hard shadows look the same");
        assert_same_image_with(&scene, what, Some(radius), w, h);
    }
}

/// A light of radius 0 casts hard shadows.
#[test]
fn soft_shadows_of_a_point_light_are_hard() {
    let s = fixture();
    let hard = draw(&s, "grid", 48, 32);
    let soft = draw_soft(&s, "grid", 0.0, 48, 32);
    assert_eq!(soft.counts, hard.counts);
    assert!(soft.image == hard.image);
}

/// Rendering again from a recording of the structure's answers gives the same image: what
/// `bench` subtracts to find the time spent in the structure is the same rendering.
#[test]
fn replayed_rendering_is_the_same_image() {
    let s = clustered_room(3000, 6);
    let accel = AnyAccel::build(&s, "hug").unwrap();
    let settings = RenderSettings {
        width: 48,
        height: 32,
        depth: 4,
        counters: false,
        packets: Default::default(),
    };
    let (recorded, recording) = render_recorded(&s, &accel, None, &settings);
    let replayed = render_replayed(&s, &recording, &settings);
    assert!(recording.queries() as u64 >= recorded.counts.total_rays());
    assert_eq!(replayed.counts, recorded.counts);
    assert!(replayed.image == recorded.image);
    assert!(replayed.image == draw(&s, "hug", 48, 32).image);
}

/// Bands of rows rendered apart ([`render_rows`]) are those rows of the whole image, pixel for
/// pixel and in radiance, and the radiance quantised is the image.
#[test]
fn bands_of_rows_are_the_whole_images_rows() {
    let scene = fixture();
    let accel = AnyAccel::build(&scene, "hug").unwrap();
    let settings = RenderSettings {
        width: 37,
        height: 29,
        depth: 4,
        counters: false,
        packets: Default::default(),
    };
    let whole = render(&scene, &accel, &settings, &|_| {});
    assert_eq!(whole.radiance.len(), 37 * 29);
    let mut radiance = Vec::new();
    let mut pixels = Vec::new();
    for y in (0..29).step_by(6) {
        let band = render_rows(&scene, &accel, &settings, y..(y + 6).min(29), &|_| {});
        assert_eq!(band.image.height(), (y + 6).min(29) - y);
        radiance.extend(band.radiance);
        pixels.extend_from_slice(band.image.as_raw());
    }
    assert_eq!(radiance, whole.radiance);
    assert_eq!(pixels, whole.image.as_raw().to_vec());
    let q = |v: f32| (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8;
    let c = whole.radiance[5 * 37 + 11];
    assert_eq!(whole.image.get_pixel(11, 5).0, [q(c.x), q(c.y), q(c.z)]);
}
