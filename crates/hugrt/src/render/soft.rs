//! Single-sample soft shadows (S. Parker, P. Shirley and B. Smits, "Single Sample Soft
//! Shadows", University of Utah technical report, 1998), as Eric Haines's "Great Shadow Hack"
//! in the Ray Tracing News (the issue after RTNv10n3, beside the hierarchical-grids
//! comparison) summarises them.
//!
//! One shadow ray per light, as for hard shadows. Each occluder is widened by a fringe whose
//! width grows linearly with its distance from the shaded point; a ray through the occluder
//! itself is blocked, a ray through the fringe is dimmed by how deep it goes in, and a ray
//! through several fringes keeps the darkest one ("thresholding", the variant the authors found
//! best).
//!
//! Choices where the summary leaves room, made here:
//! - The fringe is the cone from the shaded point to a spherical light of radius `R`: at the
//!   fraction `t` of the way to the light its half-width is `R·t`, so it is at most `R` wide and
//!   a structure finds every fringe a ray meets when its boxes are the occluders' boxes grown
//!   by `R` (the summary's "the efficiency structure ... has to take into account the maximum
//!   increased size"). Those grown boxes live in a second structure of the same spec, built for
//!   shadow rays only, so eye and reflected rays keep the tight one.
//! - Triangles (and patches) are widened in their plane: the ray meets the plane at `t`, and
//!   the distance `e` from that point to the triangle, over `R·t`, is how deep into the fringe
//!   it goes; corners are rounded (distance to the nearest edge or vertex, the summary's
//!   "circle around each vertex"). Spheres: `e` is the
//!   distance from the sphere to the ray's point of closest approach to its centre. Cones keep
//!   hard shadows (the summary: "other primitives are trickier").
//! - The falloff is the S-curve `f = 3a² − 2a³` of the summary, `a = e / (R·t)`, so the
//!   penumbra has no sharp slope change at either side.
//! - The umbra is the occluder itself, as in the paper.
//!
//! The result does not depend on the structure: every structure tests every primitive whose
//! grown box the ray crosses in `[0, 1]` (no hit shortens the ray: a full block ends the query
//! as an any-hit), and the minimum over the primitives is the same whatever their order.

use crate::accel::{AnyAccel, Counters, Primitives, SpecError};
use crate::geometry::{Aabb, PreparedRay, Ray, Shape, Vec3};
use crate::scene::Scene;
use std::sync::atomic::{AtomicU32, Ordering};

/// Default light radius, as a fraction of the scene box's diagonal.
pub const DEFAULT_LIGHT_RADIUS: f32 = 0.002;

/// The structure that answers soft shadow rays, and the light radius it was built for.
pub struct SoftShadows {
    accel: AnyAccel,
    radius: f32,
}

impl SoftShadows {
    /// Builds the shadow rays' structure of `spec` over `scene`'s occluders grown by the light
    /// radius `fraction × diagonal`.
    pub fn build(scene: &Scene, spec: &str, fraction: f32) -> Result<Self, SpecError> {
        let b = scene.bounds();
        let radius = if b.is_empty() {
            0.0
        } else {
            fraction.max(0.0) * b.diagonal()
        };
        let occluders = Occluders::new(scene, radius);
        Ok(SoftShadows {
            accel: AnyAccel::build(&occluders, spec)?,
            radius,
        })
    }

    /// The light radius in scene units.
    pub fn radius(&self) -> f32 {
        self.radius
    }

    /// How much of a light at `from + to_light` reaches `from`: 0 behind an occluder, 1 in full
    /// light, in between in a penumbra.
    pub fn visibility<C: Counters>(
        &self,
        scene: &Scene,
        from: Vec3,
        to_light: Vec3,
        counters: &mut C,
    ) -> f32 {
        let occluders = Occluders::new(scene, self.radius);
        let ray = Ray::new(from, to_light, 0.0, 1.0);
        if self.accel.any_hit(&occluders, &ray, counters).is_some() {
            0.0
        } else {
            f32::from_bits(occluders.visibility.load(Ordering::Relaxed))
        }
    }

    pub fn memory_bytes(&self) -> usize {
        self.accel.memory_bytes()
    }
}

/// The scene's primitives as shadow rays see them: boxes grown by the light radius, and an
/// intersection that reports a full block as a hit and keeps the darkest fringe it crossed.
/// One per shadow ray: `visibility` is that ray's running minimum.
struct Occluders<'a> {
    scene: &'a Scene,
    radius: f32,
    /// `f32` bits of the running minimum of the visibility.
    visibility: AtomicU32,
}

impl<'a> Occluders<'a> {
    fn new(scene: &'a Scene, radius: f32) -> Self {
        Occluders {
            scene,
            radius,
            visibility: AtomicU32::new(1f32.to_bits()),
        }
    }

    fn dim(&self, v: f32) {
        // One ray is traced by one thread: the atomic is for `Sync`, not for contention.
        let cur = f32::from_bits(self.visibility.load(Ordering::Relaxed));
        if v < cur {
            self.visibility.store(v.to_bits(), Ordering::Relaxed);
        }
    }

    /// Visibility through the fringe at distance `e` from the occluder, `t` of the way to the
    /// light.
    fn falloff(&self, e: f32, t: f32) -> f32 {
        let w = self.radius * t;
        if w <= 0.0 || w.is_nan() || e >= w {
            return 1.0;
        }
        let a = (e / w).max(0.0);
        a * a * (3.0 - 2.0 * a)
    }
}

impl Primitives for Occluders<'_> {
    fn len(&self) -> usize {
        self.scene.len()
    }

    fn bounds(&self, i: usize) -> Aabb {
        self.scene.shape(i).bounds().expand(self.radius)
    }

    fn intersect(&self, i: usize, r: &PreparedRay, tmin: f32, tmax: f32) -> Option<f32> {
        let shape = self.scene.shape(i);
        if self.radius <= 0.0 {
            return shape.intersect(r, tmin, tmax);
        }
        let (o, d) = (r.ray.origin, r.ray.dir);
        let v = match shape {
            Shape::Triangle(v) | Shape::Patch { v, .. } => {
                // Most candidates are far from the ray: the point where it meets the plane lies
                // outside the triangle's box grown by the fringe's width there, which rejects
                // them before the exact test.
                let n = (v[1] - v[0]).cross(v[2] - v[0]);
                let dn = n.dot(d);
                let t = n.dot(v[0] - o) / dn;
                if dn != 0.0 && t >= tmin && t <= tmax {
                    let p = o + d * t;
                    let w = self.radius * t;
                    let lo = v[0].min(v[1]).min(v[2]) - Vec3::splat(w);
                    let hi = v[0].max(v[1]).max(v[2]) + Vec3::splat(w);
                    if p.cmplt(lo).any() || p.cmpgt(hi).any() {
                        return None;
                    }
                }
                if let Some(t) = shape.intersect(r, tmin, tmax) {
                    return Some(t);
                }
                if dn == 0.0 || !(t >= tmin && t <= tmax) {
                    return None;
                }
                self.falloff(distance_to_edges(&v, o + d * t), t)
            }
            Shape::Sphere(s) => {
                let t = ((s.center - o).dot(d) / d.length_squared()).clamp(tmin, tmax);
                // The same early rejection: the ray's closest approach to the centre is
                // farther than the radius and the fringe's widest reach.
                let reach = s.radius.abs() + self.radius;
                if (o + d * t - s.center).length_squared() > reach * reach {
                    return None;
                }
                if let Some(t) = shape.intersect(r, tmin, tmax) {
                    return Some(t);
                }
                if !t.is_finite() {
                    return None;
                }
                let e = (o + d * t - s.center).length() - s.radius.abs();
                self.falloff(e, t)
            }
            Shape::Cone(_) => return shape.intersect(r, tmin, tmax),
        };
        self.dim(v);
        None
    }
}

/// Distance from a point of a triangle's plane to the triangle's edges (and vertices, which
/// rounds the corners). Called only where the exact test missed, so the point is outside the
/// triangle (up to rounding, where the distance is then about 0 and the ray is in the umbra).
fn distance_to_edges(v: &[Vec3; 3], p: Vec3) -> f32 {
    (0..3)
        .map(|k| {
            let (a, b) = (v[k], v[(k + 1) % 3]);
            let ab = b - a;
            let l2 = ab.length_squared();
            let s = if l2 > 0.0 {
                ((p - a).dot(ab) / l2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            (a + ab * s - p).length_squared()
        })
        .fold(f32::INFINITY, f32::min)
        .sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distance_to_edges_is_euclidean_with_rounded_corners() {
        let v = [Vec3::ZERO, Vec3::X, Vec3::Y];
        assert!((distance_to_edges(&v, Vec3::new(0.5, -0.5, 0.0)) - 0.5).abs() < 1e-6);
        // Past a corner: the distance to the vertex.
        assert!((distance_to_edges(&v, Vec3::new(-3.0, -4.0, 0.0)) - 5.0).abs() < 1e-5);
        assert!(distance_to_edges(&v, Vec3::new(0.5, 0.5, 0.0)) < 1e-6);
    }

    #[test]
    fn falloff_is_an_s_curve_from_umbra_to_light() {
        let scene = Scene::from_triangles(vec![[Vec3::ZERO, Vec3::X, Vec3::Y]]);
        let o = Occluders::new(&scene, 2.0);
        assert_eq!(o.falloff(0.0, 0.5), 0.0);
        assert_eq!(o.falloff(1.0, 0.5), 1.0);
        assert!((o.falloff(0.5, 0.5) - 0.5).abs() < 1e-6);
        assert_eq!(o.falloff(0.1, 0.0), 1.0);
    }
}
