//! Whitted ray tracing with the NFF/SPD shading model, following the SPD test procedure
//! (`docs/nff-and-spd.md`): rays through pixel corners ((w+1)·(h+1) eye rays, a pixel
//! is the mean of its four corners), shadow rays to every light the surface faces, a reflected
//! ray at every hit on a surface with `Ks > 0` or `T > 0`, a refracted ray by Snell's law at
//! every hit with `T > 0` (none on total internal reflection), ray-tree depth limited to
//! `1 + depth` (the eye ray plus `depth` bounces; SPD: 5, i.e. `depth = 4`).
//!
//! Shading: Phong. Diffuse `Kd · colour · light · (N·L)`, highlight `Ks · light · (R·V)^Shine`,
//! plus `Ks ·` reflected and `T ·` refracted radiance; no ambient term. All surfaces are
//! two-sided: the normal is turned to face the incoming ray (the SPD teapot must be
//! double-sided; other scenes do not show their back faces). Transmitters cast full shadows.
//!
//! Shadows are hard by default; [`render_soft`] softens them with one shadow ray per light
//! (`render::soft`).
//!
//! The image does not depend on the number of threads: every corner is computed on its own
//! and counts are sums of integers.

mod job;
mod output;
mod soft;

pub use job::{DEFAULT_SCENE, MAX_SIDE, RenderJob, check_image};
pub use output::{ImageFormat, save_image};
pub use soft::{DEFAULT_LIGHT_RADIUS, SoftShadows};

use crate::accel::order::TILE_ROWS;
use crate::accel::{AnyAccel, Counters, Hit, NoCounters, Packets, RayCounters};
use crate::geometry::{Aabb, PreparedRay, Ray, SurfacePoint, Vec3};
use crate::scene::{Material, Scene};
use crate::world::{InstanceHit, World};
use rayon::prelude::*;
use serde::Serialize;

/// The most bounces a rendering follows: each is a level of recursion on a worker thread's
/// stack, and past a few dozen a ray's contribution is below an 8-bit pixel's step anyway.
pub const MAX_BOUNCES: u32 = 64;

#[derive(Clone, Copy, Debug)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    /// Bounces after the eye ray (SPD: 4); at most [`MAX_BOUNCES`] are followed.
    pub depth: u32,
    /// Gather #pit/#pi/#bbi/#vt per level (slower).
    pub counters: bool,
    /// When eye rays and the shadow rays of their hits are walked as packets ([`Packets`]):
    /// a row's eye rays go to the structure together, and then its shadow rays light by
    /// light. The image is the same either way.
    pub packets: Packets,
}

/// What `hugrt render --stats-json` writes: the ray counts, then the run's facts; the schema
/// is in `docs/output-formats.md`, and fields are only ever added.
#[derive(Clone, Debug, Serialize)]
pub struct RenderReport {
    #[serde(flatten)]
    pub counts: RayCounts,
    pub scene: String,
    pub accel: String,
    pub primitives: usize,
    pub width: u32,
    pub height: u32,
    pub load_seconds: f64,
    pub build_seconds: f64,
    pub render_seconds: f64,
    /// The structure's bytes, and the occluders' structure's with soft shadows.
    pub accel_memory_bytes: usize,
    /// The lights' radius with soft shadows, `null` without.
    pub soft_shadow_radius: Option<f32>,
    /// The papers' counters per level, with `--counters`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub counters_per_level: Option<Vec<crate::accel::LevelCounts>>,
    /// The structure's name (`accel` is its spec).
    pub structure: &'static str,
    pub lights: usize,
    /// Instances placed, for a scene of instances (each model's structure built once;
    /// `primitives` then counts the flattened world).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub instances: Option<u64>,
}

/// Ray counts of a rendering, as the SPD notes tabulate them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct RayCounts {
    pub eye_rays: u64,
    pub eye_hits: u64,
    pub shadow_rays: u64,
    /// Shadow rays that were blocked.
    pub shadow_hits: u64,
    /// Soft shadow rays that were dimmed but not blocked (in a penumbra).
    pub penumbra_rays: u64,
    pub reflected_rays: u64,
    pub refracted_rays: u64,
    /// Reflected and refracted rays that hit something.
    pub secondary_hits: u64,
}

impl RayCounts {
    fn add(&mut self, o: &RayCounts) {
        self.eye_rays += o.eye_rays;
        self.eye_hits += o.eye_hits;
        self.shadow_rays += o.shadow_rays;
        self.shadow_hits += o.shadow_hits;
        self.penumbra_rays += o.penumbra_rays;
        self.reflected_rays += o.reflected_rays;
        self.refracted_rays += o.refracted_rays;
        self.secondary_hits += o.secondary_hits;
    }

    pub fn total_rays(&self) -> u64 {
        self.eye_rays + self.shadow_rays + self.reflected_rays + self.refracted_rays
    }
}

pub struct Rendered {
    /// The image, each channel clamped to `[0, 1]` and quantised.
    pub image: image::RgbImage,
    /// The same pixels before clamping, row by row from the top: the radiance an EXR file
    /// keeps.
    pub radiance: Vec<Vec3>,
    pub counts: RayCounts,
    /// Traversal counters, when [`RenderSettings::counters`] was set.
    pub counters: Option<RayCounters>,
}

/// Renders `scene` through `accel`. `progress` is called with the number of corner rows
/// finished since its last call.
pub fn render(
    scene: &Scene,
    accel: &AnyAccel,
    settings: &RenderSettings,
    progress: &(dyn Fn(u64) + Sync),
) -> Rendered {
    render_impl(
        scene,
        accel,
        None,
        settings,
        0..settings.height.max(1),
        progress,
    )
}

/// Renders only the pixel rows `rows` of the image [`render`] makes (its rows `rows.start`
/// to `rows.end - 1`, counted from the top), pixel for pixel the same: a tile of a large image
/// rendered apart, on another thread or machine. The image is `width × rows.len()`.
///
/// # Panics
/// When `rows` is empty or goes past the image's height.
pub fn render_rows(
    scene: &Scene,
    accel: &AnyAccel,
    settings: &RenderSettings,
    rows: std::ops::Range<u32>,
    progress: &(dyn Fn(u64) + Sync),
) -> Rendered {
    assert!(
        rows.start < rows.end && rows.end <= settings.height.max(1),
        "rows {rows:?} of an image {} high",
        settings.height.max(1)
    );
    render_impl(scene, accel, None, settings, rows, progress)
}

/// Renders `scene` through `accel` with soft shadows answered by `soft` (built for the same
/// scene).
pub fn render_soft(
    scene: &Scene,
    accel: &AnyAccel,
    soft: &SoftShadows,
    settings: &RenderSettings,
    progress: &(dyn Fn(u64) + Sync),
) -> Rendered {
    render_impl(
        scene,
        accel,
        Some(soft),
        settings,
        0..settings.height.max(1),
        progress,
    )
}

/// Renders an instanced world ([`World`]): its world model's camera, lights and background,
/// hard shadows. The same image as [`render`] of the world flattened into copies, but for
/// rounding (`tests/instances.rs` compares them).
pub fn render_world(
    world: &World,
    settings: &RenderSettings,
    progress: &(dyn Fn(u64) + Sync),
) -> Rendered {
    let live = |_| WorldLive;
    let rows = 0..settings.height.max(1);
    if settings.counters {
        render_with::<RayCounters, _, _>(world, settings, rows, &live, progress).0
    } else {
        render_with::<NoCounters, _, _>(world, settings, rows, &live, progress).0
    }
}

/// What the renderer shades: a flat scene, or an instanced world.
trait Stage: Sync {
    type Hit: Copy;
    /// The scene whose camera, lights and background are the rendering's.
    fn scene(&self) -> &Scene;
    fn bounds(&self) -> Aabb;
    /// The hit's point, its normals and its material.
    fn surface(&self, hit: &Self::Hit, ray: &Ray) -> (SurfacePoint, Material);
}

impl Stage for Scene {
    type Hit = Hit;
    fn scene(&self) -> &Scene {
        self
    }
    fn bounds(&self) -> Aabb {
        Scene::bounds(self)
    }
    fn surface(&self, hit: &Hit, ray: &Ray) -> (SurfacePoint, Material) {
        let shape = self.shape(hit.prim as usize);
        let sp = shape.surface(&PreparedRay::new(ray), hit.t, &self.patch_normals);
        (sp, *self.material(hit.prim))
    }
}

impl Stage for World {
    type Hit = InstanceHit;
    fn scene(&self) -> &Scene {
        World::scene(self)
    }
    fn bounds(&self) -> Aabb {
        World::bounds(self)
    }
    fn surface(&self, hit: &InstanceHit, ray: &Ray) -> (SurfacePoint, Material) {
        let (sp, m) = World::surface(self, hit, ray);
        (sp, *m)
    }
}

/// An instanced world's queries.
struct WorldLive;

impl Queries<World> for WorldLive {
    #[inline]
    fn closest<C: Counters>(
        &mut self,
        world: &World,
        ray: &Ray,
        counters: &mut C,
    ) -> Option<InstanceHit> {
        world.closest_hit(ray, counters)
    }

    #[inline]
    fn light<C: Counters>(
        &mut self,
        world: &World,
        from: Vec3,
        to_light: Vec3,
        counters: &mut C,
    ) -> f32 {
        let shadow = Ray::new(from, to_light, 0.0, 1.0);
        if world.any_hit(&shadow, counters) {
            0.0
        } else {
            1.0
        }
    }
}

fn render_impl(
    scene: &Scene,
    accel: &AnyAccel,
    soft: Option<&SoftShadows>,
    settings: &RenderSettings,
    rows: std::ops::Range<u32>,
    progress: &(dyn Fn(u64) + Sync),
) -> Rendered {
    let live = |_| Live {
        accel,
        soft,
        packets: settings.packets,
    };
    let (rendered, _) = if settings.counters {
        render_with::<RayCounters, _, _>(scene, settings, rows, &live, progress)
    } else {
        render_with::<NoCounters, _, _>(scene, settings, rows, &live, progress)
    };
    rendered
}

/// Every answer a structure gave during one rendering, in the order the renderer asked:
/// enough to render the same image again without the structure ([`render_replayed`]).
pub struct Recording {
    rows: Vec<Answers>,
}

impl Recording {
    /// Queries answered.
    pub fn queries(&self) -> usize {
        self.rows.iter().map(|r| r.hits.len() + r.light.len()).sum()
    }
}

#[derive(Default)]
struct Answers {
    hits: Vec<Option<Hit>>,
    light: Vec<f32>,
}

/// Renders as [`render`] (or [`render_soft`] with `soft`) and records every answer of the
/// structures. Not for timing: recording costs a store per query.
pub fn render_recorded(
    scene: &Scene,
    accel: &AnyAccel,
    soft: Option<&SoftShadows>,
    settings: &RenderSettings,
) -> (Rendered, Recording) {
    let record = |_| Recorder {
        live: Live {
            accel,
            soft,
            packets: settings.packets,
        },
        answers: Answers::default(),
    };
    let all = 0..settings.height.max(1);
    let (rendered, rows) = if settings.counters {
        render_with::<RayCounters, _, _>(scene, settings, all, &record, &|_| {})
    } else {
        render_with::<NoCounters, _, _>(scene, settings, all, &record, &|_| {})
    };
    let rows = rows.into_iter().map(|r| r.answers).collect();
    (rendered, Recording { rows })
}

/// Renders again from a [`Recording`] made with the same scene and settings, every query
/// answered from the record: everything a rendering does except asking the structure. Its
/// time, subtracted from the rendering's, is the time spent in the structure (Havran's
/// `T_TT`, see [`mod@crate::bench`]).
///
/// # Panics
/// When the recording was made with other settings or another scene (it runs out).
pub fn render_replayed(
    scene: &Scene,
    recording: &Recording,
    settings: &RenderSettings,
) -> Rendered {
    let replay = |j: usize| Replay {
        answers: &recording.rows[j],
        next_hit: 0,
        next_light: 0,
    };
    let settings = RenderSettings {
        counters: false,
        ..*settings
    };
    let all = 0..settings.height.max(1);
    render_with::<NoCounters, _, _>(scene, &settings, all, &replay, &|_| {}).0
}

trait Summable: Counters + Default + Send + Copy {
    fn sum(&mut self, o: &Self);
    fn into_option(self) -> Option<RayCounters>;
}
impl Summable for NoCounters {
    fn sum(&mut self, _: &Self) {}
    fn into_option(self) -> Option<RayCounters> {
        None
    }
}
impl Summable for RayCounters {
    fn sum(&mut self, o: &Self) {
        self.add(o)
    }
    fn into_option(self) -> Option<RayCounters> {
        Some(self)
    }
}

/// Where a rendering's queries go: the structures, the structures with a record kept, or a
/// record.
trait Queries<S: Stage>: Send {
    fn closest<C: Counters>(&mut self, stage: &S, ray: &Ray, counters: &mut C) -> Option<S::Hit>;
    /// Light reaching `from` from a light at `from + to_light`, 0 to 1.
    fn light<C: Counters>(
        &mut self,
        stage: &S,
        from: Vec3,
        to_light: Vec3,
        counters: &mut C,
    ) -> f32;
    /// [`Queries::closest`] of each ray, in order: where packets are walked, together.
    fn closest_each<C: Counters>(
        &mut self,
        stage: &S,
        rays: &[Ray],
        out: &mut [Option<S::Hit>],
        counters: &mut C,
    ) {
        for (ray, o) in rays.iter().zip(out) {
            *o = self.closest(stage, ray, counters);
        }
    }
    /// [`Queries::light`] of each shadow ray `(from, to_light)`, in order: where packets are
    /// walked, together.
    fn light_each<C: Counters>(
        &mut self,
        stage: &S,
        shadows: &[(Vec3, Vec3)],
        out: &mut [f32],
        counters: &mut C,
    ) {
        for (&(from, to_light), o) in shadows.iter().zip(out) {
            *o = self.light(stage, from, to_light, counters);
        }
    }
}

struct Live<'a> {
    accel: &'a AnyAccel,
    soft: Option<&'a SoftShadows>,
    packets: Packets,
}

impl Queries<Scene> for Live<'_> {
    #[inline]
    fn closest<C: Counters>(&mut self, scene: &Scene, ray: &Ray, counters: &mut C) -> Option<Hit> {
        self.accel.closest_hit(scene, ray, counters)
    }

    #[inline]
    fn light<C: Counters>(
        &mut self,
        scene: &Scene,
        from: Vec3,
        to_light: Vec3,
        counters: &mut C,
    ) -> f32 {
        match self.soft {
            None => {
                let shadow = Ray::new(from, to_light, 0.0, 1.0);
                if self.accel.any_hit(scene, &shadow, counters).is_some() {
                    0.0
                } else {
                    1.0
                }
            }
            Some(soft) => soft.visibility(scene, from, to_light, counters),
        }
    }

    fn closest_each<C: Counters>(
        &mut self,
        scene: &Scene,
        rays: &[Ray],
        out: &mut [Option<Hit>],
        counters: &mut C,
    ) {
        self.accel
            .closest_hits(scene, rays, self.packets, out, counters);
    }

    fn light_each<C: Counters>(
        &mut self,
        scene: &Scene,
        shadows: &[(Vec3, Vec3)],
        out: &mut [f32],
        counters: &mut C,
    ) {
        if let Some(soft) = self.soft {
            for (&(from, to_light), o) in shadows.iter().zip(out) {
                *o = soft.visibility(scene, from, to_light, counters);
            }
            return;
        }
        let rays: Vec<Ray> = shadows
            .iter()
            .map(|&(from, to_light)| Ray::new(from, to_light, 0.0, 1.0))
            .collect();
        let mut hits = vec![None; rays.len()];
        self.accel
            .any_hits(scene, &rays, self.packets, &mut hits, counters);
        for (h, o) in hits.iter().zip(out) {
            *o = if h.is_some() { 0.0 } else { 1.0 };
        }
    }
}

struct Recorder<'a> {
    live: Live<'a>,
    answers: Answers,
}

impl Queries<Scene> for Recorder<'_> {
    fn closest<C: Counters>(&mut self, scene: &Scene, ray: &Ray, counters: &mut C) -> Option<Hit> {
        let h = self.live.closest(scene, ray, counters);
        self.answers.hits.push(h);
        h
    }

    fn light<C: Counters>(
        &mut self,
        scene: &Scene,
        from: Vec3,
        to_light: Vec3,
        counters: &mut C,
    ) -> f32 {
        let v = self.live.light(scene, from, to_light, counters);
        self.answers.light.push(v);
        v
    }

    fn closest_each<C: Counters>(
        &mut self,
        scene: &Scene,
        rays: &[Ray],
        out: &mut [Option<Hit>],
        counters: &mut C,
    ) {
        self.live.closest_each(scene, rays, out, counters);
        self.answers.hits.extend_from_slice(out);
    }

    fn light_each<C: Counters>(
        &mut self,
        scene: &Scene,
        shadows: &[(Vec3, Vec3)],
        out: &mut [f32],
        counters: &mut C,
    ) {
        self.live.light_each(scene, shadows, out, counters);
        self.answers.light.extend_from_slice(out);
    }
}

struct Replay<'a> {
    answers: &'a Answers,
    next_hit: usize,
    next_light: usize,
}

impl Queries<Scene> for Replay<'_> {
    #[inline]
    fn closest<C: Counters>(&mut self, _: &Scene, _: &Ray, _: &mut C) -> Option<Hit> {
        let h = self.answers.hits[self.next_hit];
        self.next_hit += 1;
        h
    }

    #[inline]
    fn light<C: Counters>(&mut self, _: &Scene, _: Vec3, _: Vec3, _: &mut C) -> f32 {
        let v = self.answers.light[self.next_light];
        self.next_light += 1;
        v
    }
}

struct Tracer<'a, S, C, Q> {
    stage: &'a S,
    queries: Q,
    max_depth: u32,
    offset_scale: f32,
    counts: RayCounts,
    counters: C,
}

/// The rendering itself, of the pixel rows `pixel_rows`, by bands of [`TILE_ROWS`] corner rows
/// from the first; `queries(b)` makes the query source of band `b` (counted from the first),
/// and the sources come back with the image, band by band.
fn render_with<C: Summable, S: Stage, Q: Queries<S>>(
    stage: &S,
    s: &RenderSettings,
    pixel_rows: std::ops::Range<u32>,
    queries: &(dyn Fn(usize) -> Q + Sync),
    progress: &(dyn Fn(u64) + Sync),
) -> (Rendered, Vec<Q>) {
    let (w, h) = (s.width.max(1), s.height.max(1));
    let cam = &stage.scene().camera;
    let dir = (cam.at - cam.from).normalize();
    let right = dir.cross(cam.up).normalize();
    let up = right.cross(dir);
    let half = (cam.fov_deg.to_radians() * 0.5).tan();
    let aspect = w as f32 / h as f32;
    let b = stage.bounds();
    let offset_scale = if b.is_empty() {
        1e-4
    } else {
        1e-5 * b.diagonal().max(1e-6)
    };
    let (first, last) = (pixel_rows.start, pixel_rows.end);
    let bands: Vec<(Vec<Vec3>, RayCounts, C, Q)> = (first..=last)
        .step_by(TILE_ROWS)
        .enumerate()
        .collect::<Vec<_>>()
        .into_par_iter()
        .map(|(b, j0)| {
            let mut t = Tracer {
                stage,
                queries: queries(b),
                max_depth: s.depth.min(MAX_BOUNCES) + 1,
                offset_scale,
                counts: RayCounts::default(),
                counters: C::default(),
            };
            let j1 = (j0 + TILE_ROWS as u32 - 1).min(last);
            let eye: Vec<Ray> = (j0..=j1)
                .flat_map(|j| {
                    let v = (1.0 - 2.0 * j as f32 / h as f32) * half;
                    (0..=w).map(move |i| {
                        let u = (2.0 * i as f32 / w as f32 - 1.0) * half * aspect;
                        Ray::new(cam.from, dir + right * u + up * v, 0.0, f32::INFINITY)
                    })
                })
                .collect();
            let band = t.trace_eye(&eye);
            progress(u64::from(j1 - j0 + 1));
            (band, t.counts, t.counters, t.queries)
        })
        .collect();
    let corners = w as usize + 1;
    let rows: Vec<&[Vec3]> = bands
        .iter()
        .flat_map(|b| b.0.chunks_exact(corners))
        .collect();
    let mut counts = RayCounts::default();
    let mut counters = C::default();
    for (_, c, k, _) in &bands {
        counts.add(c);
        counters.sum(k);
    }
    let (w, h) = (w as usize, pixel_rows.len());
    let radiance: Vec<Vec3> = (0..w * h)
        .map(|k| {
            let (x, y) = (k % w, k / w);
            (rows[y][x] + rows[y][x + 1] + rows[y + 1][x] + rows[y + 1][x + 1]) * 0.25
        })
        .collect();
    let image = image::RgbImage::from_fn(w as u32, h as u32, |x, y| {
        let c = radiance[y as usize * w + x as usize];
        let q = |v: f32| (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8;
        image::Rgb([q(c.x), q(c.y), q(c.z)])
    });
    let rendered = Rendered {
        image,
        radiance,
        counts,
        counters: counters.into_option(),
    };
    (rendered, bands.into_iter().map(|b| b.3).collect())
}

/// What shading needs of a hit: its material, normals turned to face the ray, and the
/// points just above and below the surface where further rays start.
struct Surface {
    m: Material,
    /// The ray's unit direction.
    d: Vec3,
    entering: bool,
    ng: Vec3,
    ns: Vec3,
    p: Vec3,
    eps: f32,
    above: Vec3,
}

impl<S: Stage, C: Counters, Q: Queries<S>> Tracer<'_, S, C, Q> {
    /// The colours of eye rays (a band of [`TILE_ROWS`] rows, which the structure walks in
    /// tiles: [`crate::accel::Accel::closest_hits`]). The structure is asked for their hits
    /// all at once, then for their shadow rays all at once, light by light, so that
    /// neighbouring rays can be walked together ([`RenderSettings::packets`]); the rest of
    /// each ray tree is traced ray by ray. The same colours as [`Tracer::trace`] of each ray.
    fn trace_eye(&mut self, eye: &[Ray]) -> Vec<Vec3> {
        self.counts.eye_rays += eye.len() as u64;
        let mut hits = vec![None; eye.len()];
        self.queries
            .closest_each(self.stage, eye, &mut hits, &mut self.counters);
        let surfaces: Vec<Option<Surface>> = hits
            .iter()
            .zip(eye)
            .map(|(h, ray)| h.as_ref().map(|h| self.surface(h, ray, 1)))
            .collect();
        let scene = self.stage.scene();
        let lights = scene.lights.len();
        let mut shadows = Vec::new();
        let mut slots = Vec::new();
        for (l, light) in scene.lights.iter().enumerate() {
            for (i, s) in surfaces.iter().enumerate() {
                if let Some(s) = s {
                    let to_light = light.position - s.above;
                    if s.ns.dot(to_light) > 0.0 {
                        shadows.push((s.above, to_light));
                        slots.push(i * lights + l);
                    }
                }
            }
        }
        let mut answers = vec![0.0; shadows.len()];
        self.queries
            .light_each(self.stage, &shadows, &mut answers, &mut self.counters);
        // Lights a surface faces away from are never read.
        let mut visibility = vec![0.0; eye.len() * lights];
        for (&slot, a) in slots.iter().zip(answers) {
            visibility[slot] = a;
        }
        surfaces
            .iter()
            .enumerate()
            .map(|(i, s)| match s {
                None => scene.background,
                Some(s) => self.shade(s, 1, Some(&visibility[i * lights..(i + 1) * lights])),
            })
            .collect()
    }

    fn trace(&mut self, ray: &Ray, depth: u32) -> Vec3 {
        let Some(hit) = self.queries.closest(self.stage, ray, &mut self.counters) else {
            return self.stage.scene().background;
        };
        let s = self.surface(&hit, ray, depth);
        self.shade(&s, depth, None)
    }

    /// The surface `ray` hits at `hit`, counted as an eye or a secondary hit.
    fn surface(&mut self, hit: &S::Hit, ray: &Ray, depth: u32) -> Surface {
        if depth == 1 {
            self.counts.eye_hits += 1;
        } else {
            self.counts.secondary_hits += 1;
        }
        let (sp, m) = self.stage.surface(hit, ray);
        let d = ray.dir.normalize();
        let entering = d.dot(sp.geometric_normal) < 0.0;
        let (ng, ns) = if entering {
            (sp.geometric_normal, sp.shading_normal)
        } else {
            (-sp.geometric_normal, -sp.shading_normal)
        };
        let p = sp.point;
        let eps = self.offset_scale + 2e-6 * p.abs().max_element();
        Surface {
            m,
            d,
            entering,
            ng,
            ns,
            p,
            eps,
            above: p + ng * eps,
        }
    }

    /// The colour of a ray that hit `surface`: its lights, the shadow rays' answers given
    /// in `visibility` (one per light, read only for lights the surface faces) or asked here,
    /// and its reflected and refracted rays.
    fn shade(&mut self, surface: &Surface, depth: u32, visibility: Option<&[f32]>) -> Vec3 {
        let scene = self.stage.scene();
        let &Surface {
            m,
            d,
            entering,
            ng,
            ns,
            p,
            eps,
            above,
        } = surface;
        let mut color = Vec3::ZERO;
        for (l, light) in scene.lights.iter().enumerate() {
            let to_light = light.position - above;
            if ns.dot(to_light) <= 0.0 {
                continue;
            }
            self.counts.shadow_rays += 1;
            let visibility = match visibility {
                Some(v) => v[l],
                None => self
                    .queries
                    .light(self.stage, above, to_light, &mut self.counters),
            };
            if visibility <= 0.0 {
                self.counts.shadow_hits += 1;
                continue;
            }
            if visibility < 1.0 {
                self.counts.penumbra_rays += 1;
            }
            let light_color = light.color * visibility;
            let l = to_light.normalize();
            color += m.color * light_color * (m.kd * ns.dot(l));
            if m.ks > 0.0 && m.shine > 0.0 {
                let r = (2.0 * ns.dot(l)) * ns - l;
                let rv = r.dot(-d);
                if rv > 0.0 {
                    color += light_color * (m.ks * rv.powf(m.shine));
                }
            }
        }
        if depth < self.max_depth {
            if m.ks > 0.0 || m.transmittance > 0.0 {
                self.counts.reflected_rays += 1;
                let r = d - 2.0 * d.dot(ns) * ns;
                let r = if r.dot(ng) > 0.0 {
                    r
                } else {
                    d - 2.0 * d.dot(ng) * ng
                };
                color += m.ks * self.trace(&Ray::new(above, r, 0.0, f32::INFINITY), depth + 1);
            }
            if m.transmittance > 0.0 {
                let eta = if entering { 1.0 / m.ior } else { m.ior };
                let cos_i = -d.dot(ns);
                let k = 1.0 - eta * eta * (1.0 - cos_i * cos_i);
                if k >= 0.0 {
                    self.counts.refracted_rays += 1;
                    let t = eta * d + (eta * cos_i - k.sqrt()) * ns;
                    let below = p - ng * eps;
                    color += m.transmittance
                        * self.trace(&Ray::new(below, t, 0.0, f32::INFINITY), depth + 1);
                }
            }
        }
        color
    }
}
