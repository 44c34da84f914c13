//! The papers' kinds of scene, generated: stand-ins for EG95's kitchen and building, SCG97's
//! city and garden, Haines's sphereflake (SPD balls) and the "teapot in a stadium" (RTNews),
//! whose original models are not available. Each is deterministic for a size and a seed and
//! comes with a camera and lights that show it.
//!
//! Statistics at the default size and seed 1 (`hugrt stats builtin:KIND`, SCG97 Fig. 4;
//! lengths are bounding-box diagonals, `%.2` the share of objects shorter than 20% of the
//! longest):
//!
//! | kind | objects | min/max | min/diag | %.2 |
//! | --- | --- | --- | --- | --- |
//! | kitchen | 30,014 | 2.5e-4 | 2.3e-4 | 99.86 |
//! | building (4 kitchens) | 115,284 | 2.5e-4 | 1.3e-4 | 99.85 |
//! | city | 61,034 | 6.6e-4 | 6.5e-4 | 100.00 |
//! | garden | 33,538 | 9.4e-4 | 9.4e-4 | 99.99 |
//! | sphereflake | 7,383 | 1.3e-3 | 1.3e-3 | 99.97 |
//! | stadium | 18,466 | 8.1e-6 | 3.4e-6 | 99.99 |
//! | terrain | 100,352 | 0.42 | 4.4e-3 | 0.00 |
//! | soup | 50,000 | 8.8e-2 | 2.4e-3 | 0.30 |
//!
//! The kitchen's distribution is SCG97 Fig. 4's (21k polygons, min/max 9e-4, min/diag 6.5e-4,
//! 99.3% under a fifth of the largest): thousands of small tessellated objects, cutlery a
//! couple of millimetres thick, in a room whose floor and walls are the few long objects.
//! The terrain is the opposite case, on purpose: one mesh of triangles of one size
//! ([`super::Terrain`]), for measuring how builds and memory grow with the count alone. The
//! soup fills a volume with triangles of one size, where the terrain is a surface.

use super::{Camera, Light, Material, Scene};
use crate::geometry::{Shape, Sphere, Vec3};
use glam::{Affine3A, Quat};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use std::f32::consts::{FRAC_PI_2, PI, TAU};

/// The kinds `hugrt gen` and `builtin:KIND` know, with what `--size` means for each.
pub const KINDS: &[(&str, &str, u32)] = &[
    (
        "kitchen",
        "EG95's case: a room with furniture and dense clusters of small tessellated objects; size = detail",
        2,
    ),
    (
        "building",
        "EG95 Figs. 12-13: size kitchens replicated and rotated on floors",
        4,
    ),
    (
        "city",
        "a 2.5D city: blocks, towers with roof detail, a large ground; size = blocks per side / 4",
        2,
    ),
    (
        "garden",
        "scattered plants of thin stems and many leaves over a ground; size = plants / 16",
        2,
    ),
    (
        "sphereflake",
        "Haines's recursive spheres (SPD balls) over a floor; size = recursion depth",
        4,
    ),
    (
        "stadium",
        "a few dense detailed objects in a huge sparse enclosure; size = detail",
        2,
    ),
    (
        "terrain",
        "a fractal heightfield mesh of shared vertices, triangles of one size (the scale test); size = thousands of triangles, written to .ply a row at a time",
        100,
    ),
    (
        "soup",
        "random triangles of one size filling a cube (the random-triangle scene of the bvh literature); size = thousands of triangles",
        50,
    ),
];

/// The kinds with an instanced form ([`instanced`]), with what `--size` means for each.
pub const INSTANCED_KINDS: &[&str] = &["building", "town"];

/// What the instanced kinds are, for `hugrt gen --help`.
pub const INSTANCED_HELP: &str = "building: one kitchen placed size times (EG95's replicated kitchens, the kitchen's structure built once); town: size × size towers of 64 kitchens each, kitchen and tower each a model (64·size² kitchens, 1.92M triangles each tower)";

/// The largest size of an instanced kind: a building of 256 kitchens, a town of 256 × 256
/// towers (1.2·10^11 primitives once flattened, 65,536 instances).
pub const MAX_INSTANCED_SIZE: u32 = 256;

/// Kitchens in a tower of the town: 32 floors of two.
const TOWER_KITCHENS: u32 = 64;

/// Generates instanced scene `kind` ([`INSTANCED_KINDS`]) at `size` (0: the default) from
/// `seed`: models built once and placed by transforms.
///
/// * `building`: the building of [`generate`]'s kind, every kitchen one model placed `size`
///   times (the flat kind draws each kitchen's tableware anew).
/// * `town`: a square of `size × size` towers over a ground; a tower is the building of 64
///   kitchens as a model of its own, so the town is three models: a kitchen, a tower, the
///   town. At size 75, 3.6·10^5 kitchens, 1.08·10^10 triangles once flattened.
pub fn instanced(kind: &str, size: u32, seed: u64) -> Option<super::InstancedScene> {
    use super::{Instance, InstancedScene, Model};
    let model = |name: &str, scene: Scene, instances: Vec<Instance>| Model {
        name: name.into(),
        scene,
        instances,
    };
    let mut kitchen_builder = Builder::new(seed);
    kitchen(&mut kitchen_builder, 2, Affine3A::IDENTITY);
    let kitchen_model = model("kitchen", kitchen_builder.scene, Vec::new());
    let placed = |k: u32| -> Vec<Instance> {
        (0..k)
            .map(|i| Instance {
                model: 0,
                transform: building_place(i),
            })
            .collect()
    };
    match kind {
        "building" => {
            let k = if size == 0 { 4 } else { size };
            let mut world = Builder::new(seed);
            building_view(&mut world, k);
            Some(InstancedScene {
                models: vec![kitchen_model, model("world", world.scene, placed(k))],
            })
        }
        "town" => {
            let n = if size == 0 { 4 } else { size };
            let tower = model("tower", Builder::new(seed).scene, placed(TOWER_KITCHENS));
            let mut town = Builder::new(seed);
            let (dx, dz) = (20.0, 12.0);
            let (w, d) = (n as f32 * dx, n as f32 * dz);
            town.with(STONE).quad(
                Vec3::new(-10.0, 0.0, -10.0),
                Vec3::new(-10.0, 0.0, d + 10.0),
                Vec3::new(w + 10.0, 0.0, d + 10.0),
                Vec3::new(w + 10.0, 0.0, -10.0),
            );
            let towers = (0..n * n)
                .map(|i| Instance {
                    model: 1,
                    transform: at((i % n) as f32 * dx, 0.0, (i / n) as f32 * dz),
                })
                .collect();
            let height = TOWER_KITCHENS.div_ceil(2) as f32 * 3.4;
            // From above a corner, down the diagonal: near towers in full, the far ones
            // to the horizon.
            town.scene.camera = Camera {
                from: Vec3::new(
                    -0.04 * w - 30.0,
                    1.5 * height + 0.03 * w,
                    d + 0.04 * w + 30.0,
                ),
                at: Vec3::new(0.5 * w, 0.0, 0.35 * d),
                up: Vec3::Y,
                fov_deg: 55.0,
                width: 1024,
                height: 1024,
            };
            town.light(Vec3::new(-w, 4.0 * height + w, 2.0 * d + 100.0), 0.9);
            town.light(Vec3::new(2.0 * w, 2.0 * height, -d), 0.4);
            Some(InstancedScene {
                models: vec![kitchen_model, tower, model("town", town.scene, towers)],
            })
        }
        _ => None,
    }
}

/// Generates scene `kind` at `size` (0: the kind's default) from `seed`.
pub fn generate(kind: &str, size: u32, seed: u64) -> Option<Scene> {
    let (_, _, default) = KINDS.iter().find(|(k, _, _)| *k == kind)?;
    let size = if size == 0 { *default } else { size };
    if kind == "terrain" {
        return Some(super::Terrain::with_triangles(size as u64 * 1000, seed).scene());
    }
    let mut b = Builder::new(seed);
    match kind {
        "kitchen" => {
            kitchen(&mut b, size, Affine3A::IDENTITY);
            kitchen_view(&mut b.scene);
        }
        "building" => building(&mut b, size),
        "city" => city(&mut b, size),
        "garden" => garden(&mut b, size),
        "sphereflake" => sphereflake(&mut b, size),
        "stadium" => stadium(&mut b, size),
        "soup" => soup(&mut b, size),
        _ => return None,
    }
    Some(b.scene)
}

/// The size [`generate`] gives `kind` for `size`: the kind's default for 0; an error for an
/// unknown kind or a size past [`max_size`].
pub fn resolve_size(kind: &str, size: u32) -> Result<u32, crate::Error> {
    if !KINDS.iter().any(|k| k.0 == kind) {
        let kinds: Vec<&str> = KINDS.iter().map(|k| k.0).collect();
        return Err(crate::Error::Invalid(format!(
            "unknown kind '{kind}' (there are: {})",
            kinds.join(", ")
        )));
    }
    let max = max_size(kind);
    match size {
        0 => Ok(default_size(kind)),
        s if s > max => Err(crate::Error::Invalid(format!(
            "size {s} for {kind}: at most {max}"
        ))),
        s => Ok(s),
    }
}

/// The size a kind has when none is asked for.
pub fn default_size(kind: &str) -> u32 {
    KINDS.iter().find(|(k, _, _)| *k == kind).map_or(1, |k| k.2)
}

/// Largest size accepted per kind: beyond it a scene would not fit in memory.
pub fn max_size(kind: &str) -> u32 {
    match kind {
        "sphereflake" => 8,
        "building" => 256,
        "terrain" => 1_000_000,
        "soup" => 100_000,
        _ => 64,
    }
}

/// Appends triangles and spheres to a scene, with materials by runs.
struct Builder {
    scene: Scene,
    rng: Pcg64Mcg,
    current: Option<u32>,
}

fn material(color: Vec3, kd: f32, ks: f32, shine: f32) -> Material {
    Material {
        color,
        kd,
        ks,
        shine,
        transmittance: 0.0,
        ior: 1.0,
    }
}

/// The materials every generator picks from, by index.
const WOOD: u32 = 0;
const WALL: u32 = 1;
const CERAMIC: u32 = 2;
const METAL: u32 = 3;
const RED: u32 = 4;
const GREEN: u32 = 5;
const STONE: u32 = 6;
const GLASS: u32 = 7;

impl Builder {
    fn new(seed: u64) -> Self {
        let mut glass = material(Vec3::new(0.9, 0.95, 1.0), 0.1, 0.3, 80.0);
        glass.transmittance = 0.7;
        glass.ior = 1.5;
        Builder {
            scene: Scene {
                shapes: Vec::new(),
                mesh: Default::default(),
                material_runs: Vec::new(),
                materials: vec![
                    material(Vec3::new(0.6, 0.4, 0.25), 0.8, 0.1, 10.0),
                    material(Vec3::new(0.85, 0.83, 0.78), 0.9, 0.0, 0.0),
                    material(Vec3::new(0.95, 0.95, 0.92), 0.7, 0.3, 40.0),
                    material(Vec3::splat(0.8), 0.2, 0.8, 120.0),
                    material(Vec3::new(0.85, 0.2, 0.15), 0.7, 0.2, 30.0),
                    material(Vec3::new(0.25, 0.6, 0.2), 0.8, 0.1, 10.0),
                    material(Vec3::new(0.55, 0.55, 0.58), 0.9, 0.05, 5.0),
                    glass,
                ],
                patch_normals: Vec::new(),
                lights: Vec::new(),
                camera: Camera {
                    from: Vec3::new(0.0, 0.0, 10.0),
                    at: Vec3::ZERO,
                    up: Vec3::Y,
                    fov_deg: 45.0,
                    width: 512,
                    height: 512,
                },
                background: Vec3::new(0.08, 0.1, 0.15),
            },
            rng: Pcg64Mcg::seed_from_u64(seed),
            current: None,
        }
    }

    fn with(&mut self, m: u32) -> &mut Self {
        if self.current != Some(m) {
            self.scene
                .material_runs
                .push((self.scene.shapes.len() as u32, m));
            self.current = Some(m);
        }
        self
    }

    fn tri(&mut self, a: Vec3, b: Vec3, c: Vec3) {
        self.scene.shapes.push(Shape::Triangle([a, b, c]));
    }

    fn quad(&mut self, a: Vec3, b: Vec3, c: Vec3, d: Vec3) {
        self.tri(a, b, c);
        self.tri(a, c, d);
    }

    /// A box of corners `lo`, `hi` in the frame `t`.
    fn cuboid(&mut self, t: &Affine3A, lo: Vec3, hi: Vec3) {
        let v = |x: usize, y: usize, z: usize| {
            t.transform_point3(Vec3::new([lo.x, hi.x][x], [lo.y, hi.y][y], [lo.z, hi.z][z]))
        };
        self.quad(v(0, 1, 0), v(0, 1, 1), v(1, 1, 1), v(1, 1, 0));
        self.quad(v(0, 0, 0), v(1, 0, 0), v(1, 0, 1), v(0, 0, 1));
        self.quad(v(0, 0, 0), v(0, 1, 0), v(1, 1, 0), v(1, 0, 0));
        self.quad(v(0, 0, 1), v(1, 0, 1), v(1, 1, 1), v(0, 1, 1));
        self.quad(v(0, 0, 0), v(0, 0, 1), v(0, 1, 1), v(0, 1, 0));
        self.quad(v(1, 0, 0), v(1, 1, 0), v(1, 1, 1), v(1, 0, 1));
    }

    /// The surface swept by a profile of `(radius, height)` points turned about the frame's
    /// y axis in `seg` steps; a zero radius closes the surface at a point.
    fn revolution(&mut self, t: &Affine3A, profile: &[(f32, f32)], seg: usize) {
        let p = |(r, y): (f32, f32), j: usize| {
            let a = TAU * j as f32 / seg as f32;
            t.transform_point3(Vec3::new(r * a.cos(), y, r * a.sin()))
        };
        for w in profile.windows(2) {
            for j in 0..seg {
                let (a, b, c, d) = (p(w[0], j), p(w[0], j + 1), p(w[1], j + 1), p(w[1], j));
                if w[0].0 == 0.0 {
                    self.tri(a, c, d);
                } else if w[1].0 == 0.0 {
                    self.tri(a, b, c);
                } else {
                    self.quad(a, b, c, d);
                }
            }
        }
    }

    /// A tube of radius `r` along a polyline, `seg` sides, open at both ends.
    fn tube(&mut self, path: &[Vec3], r: f32, seg: usize) {
        let rings: Vec<Vec<Vec3>> = path
            .iter()
            .enumerate()
            .map(|(i, &c)| {
                let d = (path[(i + 1).min(path.len() - 1)] - path[i.saturating_sub(1)])
                    .normalize_or(Vec3::Y);
                let u = d.any_orthonormal_vector();
                let v = d.cross(u);
                (0..seg)
                    .map(|j| {
                        let a = TAU * j as f32 / seg as f32;
                        c + (u * a.cos() + v * a.sin()) * r
                    })
                    .collect()
            })
            .collect();
        for w in rings.windows(2) {
            for j in 0..seg {
                let k = (j + 1) % seg;
                self.quad(w[0][j], w[0][k], w[1][k], w[1][j]);
            }
        }
    }

    /// A tessellated ball (for what must be triangles).
    fn ball(&mut self, c: Vec3, r: Vec3, seg: usize) {
        let rings = (seg / 2).max(2);
        let profile: Vec<(f32, f32)> = (0..=rings)
            .map(|i| {
                let th = PI * i as f32 / rings as f32;
                (
                    th.sin().max(0.0) * (i != 0 && i != rings) as u8 as f32,
                    -th.cos(),
                )
            })
            .collect();
        let t = Affine3A::from_scale_rotation_translation(r, Quat::IDENTITY, c);
        self.revolution(&t, &profile, seg);
    }

    fn sphere(&mut self, center: Vec3, radius: f32) {
        self.scene
            .shapes
            .push(Shape::Sphere(Sphere { center, radius }));
    }

    fn light(&mut self, position: Vec3, intensity: f32) {
        self.scene.lights.push(Light {
            position,
            color: Vec3::splat(intensity),
        });
    }
}

/// Points of the cubic Bézier curve `p` at `k + 1` even parameter steps.
fn bezier<T>(p: [T; 4], k: usize) -> Vec<T>
where
    T: Copy + std::ops::Mul<f32, Output = T> + std::ops::Add<Output = T>,
{
    (0..=k)
        .map(|i| {
            let t = i as f32 / k as f32;
            let s = 1.0 - t;
            p[0] * (s * s * s)
                + p[1] * (3.0 * s * s * t)
                + p[2] * (3.0 * s * t * t)
                + p[3] * (t * t * t)
        })
        .collect()
}

/// Joins Bézier segments of a profile, dropping each repeated joint.
fn profile(segments: &[[(f32, f32); 4]], k: usize) -> Vec<(f32, f32)> {
    let mut out: Vec<(f32, f32)> = Vec::new();
    for s in segments {
        let pts = bezier(s.map(|(r, y)| glam::Vec2::new(r, y)), k);
        for p in pts.into_iter().skip(if out.is_empty() { 0 } else { 1 }) {
            out.push((p.x.max(0.0), p.y));
        }
    }
    out
}

fn at(x: f32, y: f32, z: f32) -> Affine3A {
    Affine3A::from_translation(Vec3::new(x, y, z))
}

/// A teapot of height about `h`: body and lid as surfaces of revolution of Bézier profiles,
/// spout and handle as tubes along Bézier curves (after the Utah teapot's outline).
fn teapot(b: &mut Builder, t: &Affine3A, h: f32, detail: usize) {
    let s = h / 3.0;
    let k = 2 + detail;
    let seg = 8 + 4 * detail;
    let body = profile(
        &[
            [(0.0, 0.0), (1.2, 0.0), (1.6, 0.1), (1.6, 0.6)],
            [(1.6, 0.6), (1.6, 1.4), (1.5, 2.0), (1.2, 2.25)],
            [(1.2, 2.25), (0.9, 2.4), (0.3, 2.5), (0.2, 2.9)],
            [(0.2, 2.9), (0.15, 3.0), (0.05, 3.0), (0.0, 3.0)],
        ],
        k,
    );
    let scaled: Vec<(f32, f32)> = body.iter().map(|&(r, y)| (r * s, y * s)).collect();
    b.with(CERAMIC).revolution(t, &scaled, seg);
    let p = |x: f32, y: f32| t.transform_point3(Vec3::new(x * s, y * s, 0.0));
    let spout = bezier([p(1.5, 0.8), p(2.4, 0.9), p(2.3, 2.0), p(3.0, 2.4)], k + 2);
    b.tube(&spout, 0.18 * s, seg / 2);
    let handle = bezier(
        [p(-1.5, 2.0), p(-2.6, 2.3), p(-2.6, 0.8), p(-1.5, 0.7)],
        k + 2,
    );
    b.tube(&handle, 0.12 * s, seg / 2);
}

/// A stack of `n` plates of radius `r`.
fn plates(b: &mut Builder, t: &Affine3A, r: f32, n: usize, seg: usize) {
    let plate = [
        (0.0, 0.0),
        (0.6 * r, 0.0),
        (r, 0.12 * r),
        (0.97 * r, 0.13 * r),
        (0.6 * r, 0.03 * r),
        (0.0, 0.03 * r),
    ];
    b.with(CERAMIC);
    for i in 0..n {
        b.revolution(&(*t * at(0.0, i as f32 * 0.06 * r, 0.0)), &plate, seg);
    }
}

fn bowl(b: &mut Builder, t: &Affine3A, r: f32, seg: usize, k: usize) {
    let outer = profile(
        &[[(0.0, 0.0), (0.7 * r, 0.0), (r, 0.3 * r), (r, 0.6 * r)]],
        k,
    );
    let inner = profile(
        &[[
            (0.95 * r, 0.6 * r),
            (0.95 * r, 0.35 * r),
            (0.65 * r, 0.05 * r),
            (0.0, 0.05 * r),
        ]],
        k,
    );
    let mut p = outer;
    p.extend(inner);
    b.with(CERAMIC).revolution(t, &p, seg);
}

fn cup(b: &mut Builder, t: &Affine3A, r: f32, seg: usize) {
    let h = 1.6 * r;
    let p = [
        (0.0, 0.0),
        (0.8 * r, 0.0),
        (r, h),
        (0.92 * r, h),
        (0.75 * r, 0.08 * r),
        (0.0, 0.08 * r),
    ];
    b.with(CERAMIC).revolution(t, &p, seg);
    let q = |x: f32, y: f32| t.transform_point3(Vec3::new(x, y, 0.0));
    let handle = bezier(
        [
            q(0.95 * r, 1.3 * r),
            q(1.8 * r, 1.4 * r),
            q(1.8 * r, 0.3 * r),
            q(0.9 * r, 0.4 * r),
        ],
        6,
    );
    b.tube(&handle, 0.1 * r, 6);
}

/// A table (top and four legs) at the frame's origin, top at height `h`.
fn table(b: &mut Builder, t: &Affine3A, w: f32, d: f32, h: f32) {
    b.with(WOOD).cuboid(
        t,
        Vec3::new(-w / 2.0, h - 0.04, -d / 2.0),
        Vec3::new(w / 2.0, h, d / 2.0),
    );
    for (x, z) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
        let c = Vec3::new(x * (w / 2.0 - 0.06), 0.0, z * (d / 2.0 - 0.06));
        b.cuboid(
            t,
            c - Vec3::new(0.03, 0.0, 0.03),
            c + Vec3::new(0.03, h - 0.04, 0.03),
        );
    }
}

fn chair(b: &mut Builder, t: &Affine3A) {
    table(b, t, 0.42, 0.42, 0.45);
    b.cuboid(t, Vec3::new(-0.21, 0.45, 0.18), Vec3::new(0.21, 0.95, 0.21));
}

/// What stands on a surface: a random mix of the small objects of EG95's kitchen.
fn tableware(b: &mut Builder, t: &Affine3A, w: f32, d: f32, count: usize, detail: usize) {
    let seg = 8 + 4 * detail;
    for _ in 0..count {
        let x = b.rng.random_range(-w / 2.0 * 0.8..w / 2.0 * 0.8);
        let z = b.rng.random_range(-d / 2.0 * 0.8..d / 2.0 * 0.8);
        let turn = Quat::from_rotation_y(b.rng.random_range(0.0..TAU));
        let kind = b.rng.random_range(0..6);
        // The object's size, and how far it reaches from where it stands in any turn: it is
        // moved in from the surface's edges by that much, so that nothing pokes through the
        // wall behind a shelf or counter.
        let (size, reach) = match kind {
            0 => {
                let h = b.rng.random_range(0.12..0.2);
                (h, h)
            }
            1 => (b.rng.random_range(3..12) as f32, 0.11),
            2 => {
                let r = b.rng.random_range(0.06..0.1);
                (r, r)
            }
            3 => (0.035, 0.06),
            _ => (0.0, 0.12),
        };
        let inside = |v: f32, half: f32| {
            let m = (half - reach).max(0.0);
            v.clamp(-m, m)
        };
        let (x, z) = (inside(x, w / 2.0), inside(z, d / 2.0));
        let here = *t * Affine3A::from_rotation_translation(turn, Vec3::new(x, 0.0, z));
        match kind {
            0 => teapot(b, &here, size, detail),
            1 => plates(b, &here, 0.11, size as usize, seg),
            2 => bowl(b, &here, size, seg, 2 + detail),
            3 => cup(b, &here, size, seg),
            4 => {
                // A fruit bowl: a bowl heaped with small fruit.
                bowl(b, &here, 0.12, seg, 2 + detail);
                b.with(RED);
                for _ in 0..8 {
                    let c = here.transform_point3(Vec3::new(
                        b.rng.random_range(-0.06..0.06),
                        b.rng.random_range(0.06..0.12),
                        b.rng.random_range(-0.06..0.06),
                    ));
                    b.ball(c, Vec3::splat(0.03), 6 + 2 * detail);
                }
            }
            _ => {
                // Cutlery: thin bars, a millimetre or two thick.
                b.with(METAL);
                for k in 0..3 {
                    let off = Vec3::new(0.0, 0.001, k as f32 * 0.03);
                    b.cuboid(
                        &here,
                        off - Vec3::new(0.09, 0.0, 0.006),
                        off + Vec3::new(0.09, 0.002, 0.006),
                    );
                }
            }
        }
    }
}

/// One kitchen, about 6 × 3 × 5 m, in frame `t`: walls, floor and ceiling; counters with
/// doors and knobs; a table with chairs; shelves; dense clusters of tableware.
fn kitchen(b: &mut Builder, detail: u32, t: Affine3A) {
    let d = detail as usize;
    let (w, h, l) = (6.0, 3.0, 5.0);
    let p = |x: f32, y: f32, z: f32| t.transform_point3(Vec3::new(x, y, z));
    b.with(WOOD)
        .quad(p(0., 0., 0.), p(0., 0., l), p(w, 0., l), p(w, 0., 0.));
    b.with(WALL)
        .quad(p(0., h, 0.), p(w, h, 0.), p(w, h, l), p(0., h, l));
    b.quad(p(0., 0., 0.), p(w, 0., 0.), p(w, h, 0.), p(0., h, 0.));
    b.quad(p(0., 0., 0.), p(0., h, 0.), p(0., h, l), p(0., 0., l));
    b.quad(p(w, 0., 0.), p(w, 0., l), p(w, h, l), p(w, h, 0.));
    // Counters along the back wall, with doors and knobs, and what stands on them.
    let counters = 6;
    for i in 0..counters {
        let x0 = 0.3 + i as f32 * 0.9;
        let c = t * at(x0 + 0.45, 0.0, 0.35);
        b.with(WOOD)
            .cuboid(&c, Vec3::new(-0.45, 0.0, -0.3), Vec3::new(0.45, 0.9, 0.3));
        b.cuboid(&c, Vec3::new(-0.4, 0.1, 0.3), Vec3::new(-0.02, 0.8, 0.32));
        b.cuboid(&c, Vec3::new(0.02, 0.1, 0.3), Vec3::new(0.4, 0.8, 0.32));
        b.with(METAL);
        for x in [-0.06, 0.06] {
            b.ball(
                c.transform_point3(Vec3::new(x, 0.65, 0.335)),
                Vec3::splat(0.015),
                6 + 2 * d,
            );
        }
        tableware(b, &(c * at(0.0, 0.9, 0.0)), 0.9, 0.6, 2 + d, d);
    }
    // Shelves on the side wall.
    for k in 0..3 {
        // 10 cm off the wall: what stands on a shelf reaches up to 20 cm from its middle.
        let s = t * at(0.25, 1.3 + 0.4 * k as f32, 2.5) * Affine3A::from_rotation_y(FRAC_PI_2);
        b.with(WOOD)
            .cuboid(&s, Vec3::new(-1.2, -0.02, -0.15), Vec3::new(1.2, 0.0, 0.15));
        tableware(b, &s, 2.4, 0.3, 3 + d, d);
    }
    // The table and its chairs, with a dense cluster of tableware on it.
    let tb = t * at(3.2, 0.0, 3.0);
    table(b, &tb, 1.6, 0.9, 0.75);
    for (x, z, a) in [
        (-0.5, -0.7, 0.0),
        (0.5, -0.7, 0.0),
        (-0.5, 0.7, PI),
        (0.5, 0.7, PI),
    ] {
        chair(
            b,
            &(tb * Affine3A::from_rotation_translation(
                Quat::from_rotation_y(a),
                Vec3::new(x, 0.0, z),
            )),
        );
    }
    tableware(b, &(tb * at(0.0, 0.75, 0.0)), 1.6, 0.9, 6 + 3 * d, d);
}

fn kitchen_view(s: &mut Scene) {
    s.camera = Camera {
        from: Vec3::new(5.6, 2.2, 4.8),
        at: Vec3::new(2.6, 0.7, 1.6),
        up: Vec3::Y,
        fov_deg: 60.0,
        width: 512,
        height: 512,
    };
    s.lights = vec![
        Light {
            position: Vec3::new(2.0, 2.8, 2.5),
            color: Vec3::splat(0.6),
        },
        Light {
            position: Vec3::new(4.5, 2.8, 3.5),
            color: Vec3::splat(0.6),
        },
    ];
    s.background = Vec3::new(0.08, 0.1, 0.15);
}

/// Where a building puts its kitchen `i`: two to a floor, each turned a quarter more than
/// the one before about its centre.
fn building_place(i: u32) -> Affine3A {
    let (side, floor) = ((i % 2) as f32, (i / 2) as f32);
    let turn = Quat::from_rotation_y(FRAC_PI_2 * (i % 4) as f32);
    at(side * 7.0 + 3.0, floor * 3.4, 2.5) * Affine3A::from_quat(turn) * at(-3.0, 0.0, -2.5)
}

/// EG95 §3.1: `k` kitchens, replicated and turned, two to a floor.
fn building(b: &mut Builder, k: u32) {
    for i in 0..k {
        kitchen(b, 2, building_place(i));
    }
    building_view(b, k);
}

/// The camera and lights of a building of `k` kitchens.
fn building_view(b: &mut Builder, k: u32) {
    let floors = k.div_ceil(2) as f32;
    b.scene.camera = Camera {
        from: Vec3::new(22.0, floors * 3.4 + 6.0, 18.0),
        at: Vec3::new(6.5, floors * 1.7, 2.5),
        up: Vec3::Y,
        fov_deg: 45.0,
        width: 512,
        height: 512,
    };
    b.light(Vec3::new(30.0, floors * 3.4 + 20.0, 30.0), 0.8);
    b.light(Vec3::new(-10.0, floors * 3.4 + 10.0, 20.0), 0.5);
}

/// A 2.5D city: a large ground, blocks of buildings of random heights with roof detail and
/// rows of windows, and a few stepped towers.
fn city(b: &mut Builder, size: u32) {
    let blocks = 4 * size as usize;
    let pitch = 60.0;
    let half = blocks as f32 * pitch / 2.0;
    let g = half * 2.5;
    b.with(STONE).quad(
        Vec3::new(-g, 0.0, -g),
        Vec3::new(-g, 0.0, g),
        Vec3::new(g, 0.0, g),
        Vec3::new(g, 0.0, -g),
    );
    for bx in 0..blocks {
        for bz in 0..blocks {
            let o = Vec3::new(bx as f32 * pitch - half, 0.0, bz as f32 * pitch - half);
            for (i, j) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                let c = o + Vec3::new(12.0 + i as f32 * 24.0, 0.0, 12.0 + j as f32 * 24.0);
                let tower = b.rng.random_range(0.0..1.0) < 0.08;
                let height = if tower {
                    b.rng.random_range(120.0..250.0)
                } else {
                    b.rng.random_range(8.0..60.0)
                };
                let hw = b.rng.random_range(6.0..10.0);
                let t = at(c.x, 0.0, c.z);
                let steps = if tower { 3 } else { 1 };
                let mut top = 0.0;
                for s in 0..steps {
                    let w = hw * (1.0 - 0.25 * s as f32);
                    let h1 = height * (s + 1) as f32 / steps as f32;
                    b.with(WALL)
                        .cuboid(&t, Vec3::new(-w, top, -w), Vec3::new(w, h1, w));
                    // Windows on two facades, a row per 4 m.
                    b.with(GLASS);
                    let rows = ((h1 - top) / 4.0) as usize;
                    for r in 0..rows {
                        for k in 0..4 {
                            let y = top + 1.5 + r as f32 * 4.0;
                            let x = -w + (k as f32 + 0.5) * w / 2.0;
                            let z = w + 0.05;
                            b.quad(
                                t.transform_point3(Vec3::new(x - 0.8, y, z)),
                                t.transform_point3(Vec3::new(x + 0.8, y, z)),
                                t.transform_point3(Vec3::new(x + 0.8, y + 1.6, z)),
                                t.transform_point3(Vec3::new(x - 0.8, y + 1.6, z)),
                            );
                            b.quad(
                                t.transform_point3(Vec3::new(z, y, x - 0.8)),
                                t.transform_point3(Vec3::new(z, y + 1.6, x - 0.8)),
                                t.transform_point3(Vec3::new(z, y + 1.6, x + 0.8)),
                                t.transform_point3(Vec3::new(z, y, x + 0.8)),
                            );
                        }
                    }
                    top = h1;
                }
                // Roof detail: machinery boxes and an antenna.
                b.with(METAL);
                let w = hw * (1.0 - 0.25 * (steps - 1) as f32);
                for _ in 0..3 {
                    let x = b.rng.random_range(-w * 0.7..w * 0.7);
                    let z = b.rng.random_range(-w * 0.7..w * 0.7);
                    let s = b.rng.random_range(0.5..2.0);
                    b.cuboid(
                        &t,
                        Vec3::new(x - s, top, z - s),
                        Vec3::new(x + s, top + s, z + s),
                    );
                }
                let base = t.transform_point3(Vec3::new(0.0, top, 0.0));
                let top = base + Vec3::Y * b.rng.random_range(3.0..15.0);
                b.tube(&[base, top], 0.15, 4);
            }
        }
    }
    b.scene.camera = Camera {
        from: Vec3::new(-half * 1.2, half * 0.9, -half * 1.4),
        at: Vec3::new(0.0, 20.0, 0.0),
        up: Vec3::Y,
        fov_deg: 50.0,
        width: 512,
        height: 512,
    };
    b.light(Vec3::new(-half * 2.0, half * 3.0, -half), 0.8);
    b.light(Vec3::new(half, half * 2.0, -half * 2.0), 0.5);
}

/// A branch of a plant: a thin stem that forks, with leaves along its last segments.
fn branch(b: &mut Builder, base: Vec3, dir: Vec3, len: f32, depth: u32) {
    let tip = base + dir * len;
    b.with(GREEN).tube(&[base, tip], len * 0.03, 5);
    if depth == 0 {
        for _ in 0..12 {
            let p = base + (tip - base) * b.rng.random_range(0.2..1.0);
            let u = Vec3::new(
                b.rng.random_range(-1.0..1.0),
                b.rng.random_range(-1.0..1.0),
                b.rng.random_range(-1.0..1.0),
            )
            .normalize_or(Vec3::X);
            let v = u.any_orthonormal_vector();
            let s = len * 0.25;
            b.quad(p, p + u * s, p + (u + v) * s * 0.7, p + v * s * 0.4);
        }
        return;
    }
    for _ in 0..3 {
        let d = (dir
            + Vec3::new(
                b.rng.random_range(-0.8..0.8),
                b.rng.random_range(0.0..0.5),
                b.rng.random_range(-0.8..0.8),
            ))
        .normalize_or(Vec3::Y);
        branch(b, tip, d, len * 0.7, depth - 1);
    }
}

/// Plants scattered over a ground: SCG97's garden, where leaves fill the space between the
/// stems.
fn garden(b: &mut Builder, size: u32) {
    let plants = 16 * size as usize;
    let r = 6.0 * (size as f32).sqrt() * 4.0;
    b.with(STONE).quad(
        Vec3::new(-r, 0.0, -r),
        Vec3::new(-r, 0.0, r),
        Vec3::new(r, 0.0, r),
        Vec3::new(r, 0.0, -r),
    );
    for _ in 0..plants {
        let base = Vec3::new(
            b.rng.random_range(-r..r) * 0.9,
            0.0,
            b.rng.random_range(-r..r) * 0.9,
        );
        let h = b.rng.random_range(1.0..3.0);
        branch(b, base, Vec3::Y, h, 3);
    }
    b.scene.camera = Camera {
        from: Vec3::new(r * 1.1, r * 0.5, r * 1.3),
        at: Vec3::new(0.0, 1.5, 0.0),
        up: Vec3::Y,
        fov_deg: 50.0,
        width: 512,
        height: 512,
    };
    b.light(Vec3::new(r, r * 2.0, r * 0.5), 0.8);
    b.light(Vec3::new(-r, r, r), 0.4);
}

/// Haines's sphereflake (the SPD's `balls`): a sphere with nine children of a third of its
/// radius, six around its equator and three above, recursively to `depth`, over a floor.
fn sphereflake(b: &mut Builder, depth: u32) {
    fn flake(b: &mut Builder, c: Vec3, r: f32, up: Vec3, depth: u32) {
        b.sphere(c, r);
        if depth == 0 {
            return;
        }
        let u = up.any_orthonormal_vector();
        let v = up.cross(u);
        let child = r / 3.0;
        for k in 0..9 {
            let (elev, az) = if k < 6 {
                (0.0, TAU * k as f32 / 6.0)
            } else {
                (PI / 3.0, TAU * (k - 6) as f32 / 3.0 + PI / 6.0)
            };
            let d = (u * az.cos() + v * az.sin()) * elev.cos() + up * elev.sin();
            flake(b, c + d * (r + child), child, d, depth - 1);
        }
    }
    b.with(CERAMIC);
    flake(b, Vec3::ZERO, 1.0, Vec3::Y, depth);
    b.with(STONE).quad(
        Vec3::new(-12.0, -1.0, -12.0),
        Vec3::new(-12.0, -1.0, 12.0),
        Vec3::new(12.0, -1.0, 12.0),
        Vec3::new(12.0, -1.0, -12.0),
    );
    // The SPD's view and lights (`balls`) scaled to this flake, twice the size of the SPD's
    // (whose base sphere has radius 0.5), and turned so that y is up: the floor at y = −1
    // stays below every light.
    b.scene.camera = Camera {
        from: Vec3::new(4.2, 2.6, 3.4),
        at: Vec3::new(0.0, 0.0, 0.0),
        up: Vec3::Y,
        fov_deg: 45.0,
        width: 512,
        height: 512,
    };
    b.light(Vec3::new(8.0, 6.0, 4.0), 0.6);
    b.light(Vec3::new(2.0, 8.0, -8.0), 0.4);
    b.light(Vec3::new(-6.0, 2.0, 10.0), 0.4);
}

/// A stadium 300 m across, of large tiers, with a few small, very detailed objects on the
/// centre of its field: RTNews's teapot in a stadium.
fn stadium(b: &mut Builder, size: u32) {
    let (r0, tiers, seg) = (60.0, 12, 48);
    b.with(GREEN).quad(
        Vec3::new(-r0, 0.0, -r0),
        Vec3::new(-r0, 0.0, r0),
        Vec3::new(r0, 0.0, r0),
        Vec3::new(r0, 0.0, -r0),
    );
    b.with(STONE);
    for t in 0..tiers {
        let (r, y) = (r0 + 7.0 * t as f32, 2.5 * t as f32);
        let p = |r: f32, y: f32, j: usize| {
            let a = TAU * j as f32 / seg as f32;
            Vec3::new(r * a.cos(), y, r * a.sin())
        };
        for j in 0..seg {
            // Riser and step of the tier.
            b.quad(
                p(r, y, j),
                p(r, y, j + 1),
                p(r, y + 2.5, j + 1),
                p(r, y + 2.5, j),
            );
            b.quad(
                p(r, y + 2.5, j),
                p(r, y + 2.5, j + 1),
                p(r + 7.0, y + 2.5, j + 1),
                p(r + 7.0, y + 2.5, j),
            );
        }
    }
    let d = 4 * size as usize;
    let place = |b: &mut Builder, x: f32, z: f32| {
        let j = |b: &mut Builder| b.rng.random_range(-0.05..0.05);
        let (dx, dz, turn) = (j(b), j(b), b.rng.random_range(0.0..TAU));
        Affine3A::from_rotation_translation(
            Quat::from_rotation_y(turn),
            Vec3::new(x + dx, 0.0, z + dz),
        )
    };
    let t = place(b, 0.0, 0.0);
    teapot(b, &t, 0.3, d);
    let t = place(b, 0.5, 0.3);
    teapot(b, &t, 0.25, d);
    let t = place(b, -0.4, -0.2);
    plates(b, &t, 0.11, 20, 8 + 4 * d);
    let t = place(b, 0.2, -0.5);
    bowl(b, &t, 0.1, 8 + 4 * d, 2 + d);
    b.scene.camera = Camera {
        from: Vec3::new(1.6, 0.9, 1.8),
        at: Vec3::new(0.0, 0.15, 0.0),
        up: Vec3::Y,
        fov_deg: 40.0,
        width: 512,
        height: 512,
    };
    b.light(Vec3::new(5.0, 8.0, 5.0), 0.6);
    b.light(Vec3::new(-100.0, 60.0, 50.0), 0.5);
}

/// `1000·size` triangles of random shape, each within a cube a little larger than the spacing
/// of their random centres in the unit cube: a volume filled evenly with objects of one size,
/// the opposite of a surface.
fn soup(b: &mut Builder, size: u32) {
    let n = size as usize * 1000;
    let side = 1.1 / (n as f32).cbrt();
    b.with(CERAMIC);
    for _ in 0..n {
        let c = Vec3::new(b.rng.random(), b.rng.random(), b.rng.random());
        let mut corner = || {
            let r = Vec3::new(b.rng.random(), b.rng.random(), b.rng.random());
            c + (r - Vec3::splat(0.5)) * side
        };
        let (p, q, r) = (corner(), corner(), corner());
        b.tri(p, q, r);
    }
    b.scene.camera = Camera {
        from: Vec3::new(1.8, 1.4, 2.25),
        at: Vec3::splat(0.5),
        up: Vec3::Y,
        fov_deg: 40.0,
        width: 512,
        height: 512,
    };
    b.light(Vec3::new(4.0, 5.0, 3.0), 0.7);
    b.light(Vec3::new(-3.0, 2.0, 4.0), 0.4);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_kind_is_deterministic_per_seed() {
        for (kind, _, _) in KINDS {
            let a = generate(kind, 1, 7).unwrap();
            let b = generate(kind, 1, 7).unwrap();
            assert_eq!((&a.shapes, &a.mesh), (&b.shapes, &b.mesh), "{kind}");
            assert!(!a.is_empty() && !a.lights.is_empty(), "{kind}");
        }
        assert!(generate("nothing", 1, 1).is_none());
    }
}
