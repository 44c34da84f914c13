use super::{Aabb, PreparedRay};
use glam::Vec3;

/// NFF sphere `s cx cy cz r`. A negative radius means only the inside is visible; the
/// intersection is the same, only the outward normal flips (see [`super::Shape`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    pub center: Vec3,
    pub radius: f32,
}

impl Sphere {
    pub fn bounds(&self) -> Aabb {
        let r = Vec3::splat(self.radius.abs());
        Aabb::new(self.center - r, self.center + r)
    }

    /// Nearest root in `[tmin, tmax]`, computed in double precision with the stable form of
    /// the quadratic (Haines et al., "Precision Improvements for Ray/Sphere Intersection",
    /// Ray Tracing Gems ch. 7), so grazing and distant rays keep their accuracy.
    pub fn intersect(&self, r: &PreparedRay, tmin: f32, tmax: f32) -> Option<f32> {
        let d = r.ray.dir.as_dvec3();
        let f = (r.ray.origin - self.center).as_dvec3();
        let rad = self.radius as f64;
        let a = d.dot(d);
        let b = -f.dot(d);
        let l = f + (b / a) * d;
        let disc = a * (rad * rad - l.dot(l));
        if disc < 0.0 || a == 0.0 {
            return None;
        }
        let c = f.dot(f) - rad * rad;
        let q = b + b.signum() * disc.sqrt();
        let (mut t0, mut t1) = if q == 0.0 { (0.0, 0.0) } else { (c / q, q / a) };
        if t0 > t1 {
            std::mem::swap(&mut t0, &mut t1);
        }
        pick_root(t0, t1, tmin, tmax)
    }
}

/// The smaller root inside `[tmin, tmax]`, as `f32`; a root that rounds past `f32::MAX` is
/// none, as in [`super::crossing_t`].
pub(super) fn pick_root(t0: f64, t1: f64, tmin: f32, tmax: f32) -> Option<f32> {
    let tmax = tmax.min(f32::MAX);
    [t0, t1]
        .into_iter()
        .map(|t| t as f32)
        .find(|&t| t >= tmin && t <= tmax)
}
