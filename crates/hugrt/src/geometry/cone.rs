use super::{Aabb, PreparedRay, sphere::pick_root};
use glam::{DVec3, Vec3};

/// NFF cone or cylinder (`c`): the open surface between a base disc and an apex disc, each
/// with its own radius; no end caps. Equal radii give a cylinder. Negative radii (inside
/// visible) are stored as given; the surface is that of their absolute values.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cone {
    pub base: Vec3,
    pub base_radius: f32,
    pub apex: Vec3,
    pub apex_radius: f32,
}

impl Cone {
    pub fn bounds(&self) -> Aabb {
        let axis = (self.apex - self.base).normalize_or_zero();
        // A disc of radius r with normal w spans r·sqrt(1 - w_i²) along axis i.
        let span = (Vec3::ONE - axis * axis).max(Vec3::ZERO).map(f32::sqrt);
        let rb = span * self.base_radius.abs();
        let ra = span * self.apex_radius.abs();
        Aabb::new(self.base - rb, self.base + rb).union(&Aabb::new(self.apex - ra, self.apex + ra))
    }

    fn frame(&self) -> (DVec3, DVec3, f64, f64, f64) {
        let b = self.base.as_dvec3();
        let axis = self.apex.as_dvec3() - b;
        let h = axis.length();
        let w = axis / h;
        let rb = self.base_radius.abs() as f64;
        let k = (self.apex_radius.abs() as f64 - rb) / h;
        (b, w, h, rb, k)
    }

    /// Nearest hit in `[tmin, tmax]` on the lateral surface, in double precision. With `w` the
    /// unit axis, `s` the height along it and `k` the slope of the radius, a point is on the
    /// surface when its distance to the axis equals `rb + k·s` with `0 ≤ s ≤ h`.
    pub fn intersect(&self, r: &PreparedRay, tmin: f32, tmax: f32) -> Option<f32> {
        let (b, w, h, rb, k) = self.frame();
        if h.is_nan() || h <= 0.0 {
            return None;
        }
        let d = r.ray.dir.as_dvec3();
        let q = r.ray.origin.as_dvec3() - b;
        let (qw, dw) = (q.dot(w), d.dot(w));
        let (qp, dp) = (q - qw * w, d - dw * w);
        let r0 = rb + k * qw;
        let a = dp.dot(dp) - k * k * dw * dw;
        let bh = qp.dot(dp) - k * dw * r0;
        let c = qp.dot(qp) - r0 * r0;
        let roots = if a.abs() < 1e-12 * d.dot(d) {
            if bh == 0.0 {
                return None;
            }
            let t = -c / (2.0 * bh);
            (t, t)
        } else {
            let disc = bh * bh - a * c;
            if disc < 0.0 {
                return None;
            }
            let sq = disc.sqrt();
            let qq = -(bh + bh.signum() * sq);
            let (t0, t1) = if qq == 0.0 {
                (0.0, 0.0)
            } else {
                (qq / a, c / qq)
            };
            (t0.min(t1), t0.max(t1))
        };
        // A root must also lie on the surface: where the quadratic's coefficients cancel (a
        // cone nearly flat and far from the ray's origin, as a fuzzed scene had), a root can
        // be off by more than the cone's height and land in `0..=h` while its point lies far
        // outside the cone and its box, a hit no structure would find.
        let scale = 1e-12 * (q.length() + h + rb.abs());
        let valid = |t: f64| {
            let s = qw + t * dw;
            let radius = rb + k * s;
            let radial = (qp + t * dp).length();
            (0.0..=h).contains(&s)
                && radius >= 0.0
                && (radial - radius).abs() <= 1e-6 * (radial + radius) + scale
        };
        let (t0, t1) = roots;
        let t0v = if valid(t0) { t0 } else { f64::NAN };
        let t1v = if valid(t1) { t1 } else { f64::NAN };
        pick_root(t0v, t1v, tmin, tmax)
    }

    /// Outward normal at a point on the surface: the gradient of `|radial| - (rb + k·s)`.
    pub fn normal(&self, p: Vec3) -> Vec3 {
        let (b, w, _, _, k) = self.frame();
        let q = p.as_dvec3() - b;
        let radial = (q - q.dot(w) * w).normalize_or_zero();
        (radial - k * w).normalize_or_zero().as_vec3()
    }
}
