use super::PreparedRay;
use glam::Vec3;

/// An axis-aligned box. The empty box has `min = +inf`, `max = -inf` so that a union with it
/// is the identity.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Default for Aabb {
    fn default() -> Self {
        Self::EMPTY
    }
}

/// `1 + 2·gamma(3)` of Ize ("Robust BVH Ray Traversal", JCGT 2013): scaling the far slab
/// distance by it makes the slab test conservative under rounding.
const ROBUST_FAR: f32 = 1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

impl Aabb {
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    pub fn new(min: Vec3, max: Vec3) -> Self {
        Aabb { min, max }
    }

    #[inline]
    pub fn from_points(points: &[Vec3]) -> Self {
        points.iter().fold(Self::EMPTY, |b, &p| b.grow(p))
    }

    pub fn is_empty(&self) -> bool {
        !(self.min.x <= self.max.x && self.min.y <= self.max.y && self.min.z <= self.max.z)
    }

    #[must_use]
    pub fn grow(&self, p: Vec3) -> Aabb {
        Aabb::new(self.min.min(p), self.max.max(p))
    }

    #[must_use]
    pub fn union(&self, o: &Aabb) -> Aabb {
        Aabb::new(self.min.min(o.min), self.max.max(o.max))
    }

    /// The box widened by `e` on every side.
    #[must_use]
    pub fn expand(&self, e: f32) -> Aabb {
        Aabb::new(self.min - Vec3::splat(e), self.max + Vec3::splat(e))
    }

    pub fn extent(&self) -> Vec3 {
        if self.is_empty() {
            Vec3::ZERO
        } else {
            self.max - self.min
        }
    }

    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    /// Length of the diagonal: the "length" of an object in EG95 §2.1.
    pub fn diagonal(&self) -> f32 {
        self.extent().length()
    }

    pub fn volume(&self) -> f32 {
        let e = self.extent();
        e.x * e.y * e.z
    }

    pub fn surface_area(&self) -> f32 {
        let e = self.extent();
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }

    /// Closed-box overlap (touching boxes overlap).
    pub fn overlaps(&self, o: &Aabb) -> bool {
        self.min.cmple(o.max).all() && o.min.cmple(self.max).all()
    }

    pub fn contains(&self, p: Vec3) -> bool {
        self.min.cmple(p).all() && p.cmple(self.max).all()
    }

    /// Largest absolute coordinate of the box: the scale against which rounding errors of
    /// points inside it are measured.
    pub fn magnitude(&self) -> f32 {
        self.min.abs().max(self.max.abs()).max_element()
    }

    /// Slab test: the parameter interval where the ray is inside the box, clipped to
    /// `[tmin, tmax]`, or `None`. Conservative under rounding (see `ROBUST_FAR`); a ray lying
    /// in a face plane with a zero direction component counts as inside on that axis.
    #[inline]
    pub fn intersect(&self, r: &PreparedRay, tmin: f32, tmax: f32) -> Option<(f32, f32)> {
        let t1 = (self.min - r.ray.origin) * r.inv_dir;
        let t2 = (self.max - r.ray.origin) * r.inv_dir;
        // `min`/`max` return the non-NaN operand, so a 0·inf slab is ignored.
        let tnear = t1.min(t2);
        let tfar = t1.max(t2);
        let t0 = tmin.max(tnear.x).max(tnear.y).max(tnear.z);
        let t1 = tmax
            .min(tfar.x * ROBUST_FAR)
            .min(tfar.y * ROBUST_FAR)
            .min(tfar.z * ROBUST_FAR);
        (t0 <= t1).then_some((t0, t1))
    }
}
