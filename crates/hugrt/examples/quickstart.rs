//! Build a structure over triangles and shoot rays at it: `cargo run --release --example quickstart`.

use hugrt::accel::{Accel, AnyAccel, Bvh, BvhSettings, NoCounters};
use hugrt::geometry::{Ray, Vec3};
use hugrt::scene::Scene;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // Two triangles making a unit square at z = 0 (or `Scene::open("bunny.ply")?`).
    let (a, b, c, d) = (Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y);
    let scene = Scene::from_triangles(vec![[a, b, c], [a, c, d]]);
    // Any structure by its spec: "hug", "bvh", "grid:density=4", "hug:preset=eg95", ...
    let accel = AnyAccel::build(&scene, "hug")?;
    let ray = Ray::new(Vec3::new(0.25, 0.75, 1.0), -Vec3::Z, 0.0, f32::INFINITY);
    if let Some(hit) = accel.closest_hit(&scene, &ray, &mut NoCounters) {
        let d = hit.details(&scene, &ray);
        println!(
            "triangle {} at t = {}, u = {}, v = {}, normal {}",
            hit.prim, hit.t, d.u, d.v, d.normal
        );
    }
    let blocked = accel.any_hit(&scene, &ray, &mut NoCounters).is_some();
    println!("blocked: {blocked}");
    // Every hit in order of t, each primitive once: through the shared diagonal, both triangles.
    let down = Ray::new(Vec3::new(0.5, 0.5, 1.0), -Vec3::Z, 0.0, f32::INFINITY);
    for hit in accel.all_hits(&scene, &down, &mut NoCounters) {
        println!(
            "through the diagonal: triangle {} at t = {}",
            hit.prim, hit.t
        );
    }
    // Typed settings, no spec string: the defaults are `Default`'s.
    let bvh = Bvh::with_settings(
        &scene,
        &BvhSettings {
            leaf: 4,
            ..Default::default()
        },
    )?;
    println!("bvh: {:?}", bvh.closest_hit(&scene, &ray, &mut NoCounters));
    Ok(())
}
