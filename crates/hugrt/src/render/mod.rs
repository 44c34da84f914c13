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
//! The image does not depend on the number of threads: every corner is computed on its own
//! and counts are sums of integers.

use crate::accel::{AnyAccel, Counters, NoCounters, RayCounters};
use crate::geometry::{PreparedRay, Ray, Vec3};
use crate::scene::Scene;
use rayon::prelude::*;
use serde::Serialize;

#[derive(Clone, Copy, Debug)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    /// Bounces after the eye ray (SPD: 4).
    pub depth: u32,
    /// Gather #pit/#pi/#bbi/#vt per level (slower).
    pub counters: bool,
}

/// Ray counts of a rendering, as the SPD notes tabulate them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct RayCounts {
    pub eye_rays: u64,
    pub eye_hits: u64,
    pub shadow_rays: u64,
    /// Shadow rays that were blocked.
    pub shadow_hits: u64,
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
        self.reflected_rays += o.reflected_rays;
        self.refracted_rays += o.refracted_rays;
        self.secondary_hits += o.secondary_hits;
    }

    pub fn total_rays(&self) -> u64 {
        self.eye_rays + self.shadow_rays + self.reflected_rays + self.refracted_rays
    }
}

pub struct Rendered {
    pub image: image::RgbImage,
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
    if settings.counters {
        let (image, counts, c) = render_with::<RayCounters>(scene, accel, settings, progress);
        Rendered {
            image,
            counts,
            counters: Some(c),
        }
    } else {
        let (image, counts, _) = render_with::<NoCounters>(scene, accel, settings, progress);
        Rendered {
            image,
            counts,
            counters: None,
        }
    }
}

trait Summable: Counters + Default + Send + Copy {
    fn sum(&mut self, o: &Self);
}
impl Summable for NoCounters {
    fn sum(&mut self, _: &Self) {}
}
impl Summable for RayCounters {
    fn sum(&mut self, o: &Self) {
        self.add(o)
    }
}

struct Tracer<'a, C> {
    scene: &'a Scene,
    accel: &'a AnyAccel,
    max_depth: u32,
    offset_scale: f32,
    counts: RayCounts,
    counters: C,
}

fn render_with<C: Summable>(
    scene: &Scene,
    accel: &AnyAccel,
    s: &RenderSettings,
    progress: &(dyn Fn(u64) + Sync),
) -> (image::RgbImage, RayCounts, C) {
    let (w, h) = (s.width.max(1), s.height.max(1));
    let cam = &scene.camera;
    let dir = (cam.at - cam.from).normalize();
    let right = dir.cross(cam.up).normalize();
    let up = right.cross(dir);
    let half = (cam.fov_deg.to_radians() * 0.5).tan();
    let aspect = w as f32 / h as f32;
    let b = scene.bounds();
    let offset_scale = if b.is_empty() {
        1e-4
    } else {
        1e-5 * b.diagonal().max(1e-6)
    };
    let rows: Vec<(Vec<Vec3>, RayCounts, C)> = (0..=h)
        .into_par_iter()
        .map(|j| {
            let mut t = Tracer {
                scene,
                accel,
                max_depth: s.depth + 1,
                offset_scale,
                counts: RayCounts::default(),
                counters: C::default(),
            };
            let v = (1.0 - 2.0 * j as f32 / h as f32) * half;
            let row = (0..=w)
                .map(|i| {
                    let u = (2.0 * i as f32 / w as f32 - 1.0) * half * aspect;
                    let ray = Ray::new(cam.from, dir + right * u + up * v, 0.0, f32::INFINITY);
                    t.counts.eye_rays += 1;
                    t.trace(&ray, 1)
                })
                .collect();
            progress(1);
            (row, t.counts, t.counters)
        })
        .collect();
    let mut counts = RayCounts::default();
    let mut counters = C::default();
    for (_, c, k) in &rows {
        counts.add(c);
        counters.sum(k);
    }
    let img = image::RgbImage::from_fn(w, h, |x, y| {
        let (x, y) = (x as usize, y as usize);
        let c = (rows[y].0[x] + rows[y].0[x + 1] + rows[y + 1].0[x] + rows[y + 1].0[x + 1]) * 0.25;
        let q = |v: f32| (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8;
        image::Rgb([q(c.x), q(c.y), q(c.z)])
    });
    (img, counts, counters)
}

impl<C: Counters> Tracer<'_, C> {
    fn trace(&mut self, ray: &Ray, depth: u32) -> Vec3 {
        let Some(hit) = self.accel.closest_hit(self.scene, ray, &mut self.counters) else {
            return self.scene.background;
        };
        if depth == 1 {
            self.counts.eye_hits += 1;
        } else {
            self.counts.secondary_hits += 1;
        }
        let shape = &self.scene.shapes[hit.prim as usize];
        let m = *self.scene.material(hit.prim);
        let sp = shape.surface(&PreparedRay::new(ray), hit.t, &self.scene.patch_normals);
        let d = ray.dir.normalize();
        let entering = d.dot(sp.geometric_normal) < 0.0;
        let (ng, ns) = if entering {
            (sp.geometric_normal, sp.shading_normal)
        } else {
            (-sp.geometric_normal, -sp.shading_normal)
        };
        let p = sp.point;
        let eps = self.offset_scale + 2e-6 * p.abs().max_element();
        let above = p + ng * eps;
        let mut color = Vec3::ZERO;
        for light in &self.scene.lights {
            let to_light = light.position - above;
            if ns.dot(to_light) <= 0.0 {
                continue;
            }
            self.counts.shadow_rays += 1;
            let shadow = Ray::new(above, to_light, 0.0, 1.0);
            if self
                .accel
                .any_hit(self.scene, &shadow, &mut self.counters)
                .is_some()
            {
                self.counts.shadow_hits += 1;
                continue;
            }
            let l = to_light.normalize();
            color += m.color * light.color * (m.kd * ns.dot(l));
            if m.ks > 0.0 && m.shine > 0.0 {
                let r = (2.0 * ns.dot(l)) * ns - l;
                let rv = r.dot(-d);
                if rv > 0.0 {
                    color += light.color * (m.ks * rv.powf(m.shine));
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
