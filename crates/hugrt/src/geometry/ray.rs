use glam::Vec3;

/// A ray `origin + t * dir` for `t` in `[tmin, tmax]`. The direction need not be unit length:
/// every `t` reported by hugrt is in units of `dir`. Laid out as eight `f32` in field order
/// (`repr(C)`), so that a packet reads a ray whole into a register.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct Ray {
    pub origin: Vec3,
    pub dir: Vec3,
    pub tmin: f32,
    pub tmax: f32,
}

impl Ray {
    #[inline]
    pub fn new(origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Self {
        Ray {
            origin,
            dir,
            tmin,
            tmax,
        }
    }

    /// Whether the ray can hit anything: origin and non-zero direction with every component at
    /// most [`Ray::MAX_COMPONENT`] in magnitude, and an interval `[tmin, tmax]` that is not
    /// empty or NaN (`tmax` may be infinite). Every query returns no hit for other rays,
    /// rather than a garbage hit or a walk that never ends.
    #[inline]
    pub fn is_traceable(&self) -> bool {
        self.traceable_and_small().0
    }

    /// [`Ray::is_traceable`] and [`Ray::has_small_direction`] from one pass over the
    /// components' bits: every query asks both of every ray, and the compiler did not share
    /// the union of the direction's bits between the two (four instructions a ray).
    #[inline(always)]
    pub(crate) fn traceable_and_small(&self) -> (bool, bool) {
        // Magnitudes compared by their bits, in which non-negative floats are ordered as their
        // values, and NaN and ±∞ lie above `MAX_COMPONENT`: one integer comparison a component
        // is `is_finite` and the bound together, without a branch (a camera ray's checks
        // before its walk were a fifth of the instructions of a city's frame).
        let (o, d) = (self.origin, self.dir);
        let largest = magnitude_bits(o.x)
            .max(magnitude_bits(o.y))
            .max(magnitude_bits(o.z))
            .max(magnitude_bits(d.x))
            .max(magnitude_bits(d.y))
            .max(magnitude_bits(d.z));
        let direction = magnitude_bits(d.x) | magnitude_bits(d.y) | magnitude_bits(d.z);
        let traceable = (largest <= Self::MAX_COMPONENT.to_bits())
            & (direction != 0)
            & (self.tmin <= self.tmax)
            & (self.tmin < f32::INFINITY);
        // The bound's bits are a power of two (2^29), so the components all lie below it
        // exactly when the union of their bits does.
        (traceable, direction < Self::SMALL_DIRECTION.to_bits())
    }

    /// The largest origin or direction component a query takes: 2^64, about 1.8·10^19.
    ///
    /// Every triangle test first subtracts the origin from the vertices; from an origin at
    /// 10^34 (the rays fuzz target's find) a unit cube's vertices all round to the same
    /// point, and whether a grazing ray "hits" is decided by that rounding: brute force
    /// reported a crossing at z = −2·10^−17, outside the cube, that the structures' box and
    /// cell tests rightly did not. No single bound makes every scale exact (a ray from 10^19
    /// at a unit cube has the same trouble), but past this one nothing is left of any scene a
    /// renderer meets.
    pub const MAX_COMPONENT: f32 = 18_446_744_073_709_551_616.0;

    /// The least that a direction's largest component may be for a query to walk the ray as
    /// given: 2^-63, about 1.1·10^-19. The `t` of a hit grows as the direction shrinks, and
    /// from directions near 10^-35 the walks' plane and box distances reach `f32`'s range
    /// while the hits do not: a turned grid's frame (`hug:pca=true`) then gave components whose
    /// inverses overflowed, and its walk missed hits brute force found. A smaller direction is
    /// first scaled by a power of two, exactly, and its hits scaled back
    /// ([`crate::accel::Reach::moved`]).
    pub const SMALL_DIRECTION: f32 = f32::from_bits(64 << 23);

    /// Whether every direction component is below [`Ray::SMALL_DIRECTION`] in magnitude.
    #[inline(always)]
    pub fn has_small_direction(&self) -> bool {
        self.traceable_and_small().1
    }

    /// The ray with each subnormal direction component (below 2^-126 in magnitude) made a
    /// zero of its sign, as every query takes it. Such a component's inverse overflows to
    /// infinity while the component itself is not zero, a combination the grid walks did not
    /// expect: the rays-file fuzz target found the HUG missing hits brute force found, for rays
    /// like `dir = (0.45, 6.7e-43, 0)`. The component moves a point of the ray by less than
    /// 1.2e-38 · t, which no float coordinate shows for any `t` below 10^30.
    ///
    /// A ray without such components is returned as it is, copied whole from where it lies:
    /// one built field by field and then copied whole, as the batch queries copy it, is read
    /// back before its narrow stores have reached the cache (a failed store forwarding, a
    /// third of the batch's own time on a camera's rays that miss the scene).
    #[inline]
    pub fn without_subnormal_direction(&self) -> Ray {
        if !self.has_subnormal_direction() {
            return *self;
        }
        let flush = |x: f32| {
            if is_subnormal(x) {
                0.0f32.copysign(x)
            } else {
                x
            }
        };
        Ray {
            dir: Vec3::new(flush(self.dir.x), flush(self.dir.y), flush(self.dir.z)),
            ..*self
        }
    }

    /// Whether a direction component is subnormal, which
    /// [`Ray::without_subnormal_direction`] flushes.
    #[inline(always)]
    pub(crate) fn has_subnormal_direction(&self) -> bool {
        is_subnormal(self.dir.x) | is_subnormal(self.dir.y) | is_subnormal(self.dir.z)
    }

    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.dir * t
    }
}

/// Whether `x` is subnormal: magnitude bits from 1 to 2^23 − 1 (zero wraps past them).
#[inline(always)]
fn is_subnormal(x: f32) -> bool {
    magnitude_bits(x).wrapping_sub(1) < (1 << 23) - 1
}

/// The bits of `|x|`.
#[inline(always)]
fn magnitude_bits(x: f32) -> u32 {
    x.to_bits() & 0x7fff_ffff
}

/// A ray with the per-ray constants that every box and triangle test would otherwise recompute:
/// the inverse direction (slab tests, 3D-DDA) and the shear of Woop, Benthin and Wald (2013,
/// "Watertight Ray/Triangle Intersection", §3) that maps the ray onto the +z axis.
#[derive(Clone, Copy, Debug)]
pub struct PreparedRay {
    pub ray: Ray,
    pub inv_dir: Vec3,
    /// The axis permutation and shear as the rows of one matrix, without its third row (the
    /// hit's `t` is [`crossing_t`](super::crossing_t)'s, not the sheared `z`'s). `kz` is the
    /// axis where `|dir|` is largest, `kx` and `ky` follow it cyclically (swapped when `dir[kz] < 0`, to
    /// keep the winding), and `(Sx, Sy) = (dir[kx]/dir[kz], dir[ky]/dir[kz])`:
    /// `rows[0] = e_kx − Sx·e_kz`, `rows[1] = e_ky − Sy·e_kz`.
    /// `rows[i].dot(p)` gives the same bits as the paper's `p[kx] − Sx·p[kz]` (the other
    /// products are by exact 1s and 0s, and the one rounded product and one rounded sum are
    /// the same), without indexing by a run-time axis, which costs a branch per component.
    pub rows: [Vec3; 2],
}

impl PreparedRay {
    #[inline]
    pub fn new(ray: &Ray) -> Self {
        let inv_dir = Vec3::ONE / ray.dir;
        PreparedRay {
            ray: *ray,
            inv_dir,
            // `1 / d[kz]` is the inverse direction's component: one division fewer.
            rows: shear_rows(ray.dir, |kz| inv_dir[kz]),
        }
    }
}

/// [`PreparedRay::rows`] of direction `d`, where `inv(kz)` is `1 / d[kz]` (a lane of the
/// inverse direction, or the one division: the same bits either way).
#[inline(always)]
pub(crate) fn shear_rows(d: Vec3, inv: impl FnOnce(usize) -> f32) -> [Vec3; 2] {
    let a = d.abs();
    let kz = if a.x >= a.y && a.x >= a.z {
        0
    } else if a.y >= a.z {
        1
    } else {
        2
    };
    let mut kx = (kz + 1) % 3;
    let mut ky = (kx + 1) % 3;
    if d[kz] < 0.0 {
        std::mem::swap(&mut kx, &mut ky);
    }
    let sz = inv(kz);
    let (sx, sy) = (d[kx] * sz, d[ky] * sz);
    let e = |k: usize| Vec3::AXES[k];
    [e(kx) - sx * e(kz), e(ky) - sy * e(kz)]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn traceable_rays_have_components_within_the_bound() {
        let ray = |o: Vec3, d: Vec3| Ray::new(o, d, 0.0, f32::INFINITY);
        let max = Ray::MAX_COMPONENT;
        assert!(ray(Vec3::splat(-max), Vec3::splat(max)).is_traceable());
        let past = max * 2.0;
        assert!(!ray(Vec3::new(0.0, past, 0.0), Vec3::X).is_traceable());
        assert!(!ray(Vec3::ZERO, Vec3::new(0.0, 0.0, -past)).is_traceable());
        for bad in [f32::NAN, f32::INFINITY] {
            assert!(!ray(Vec3::new(bad, 0.0, 0.0), Vec3::X).is_traceable());
            assert!(!ray(Vec3::ZERO, Vec3::new(1.0, bad, 0.0)).is_traceable());
        }
        assert!(!ray(Vec3::ZERO, Vec3::ZERO).is_traceable());
        assert!(!Ray::new(Vec3::ZERO, Vec3::X, 2.0, 1.0).is_traceable());
        assert!(!Ray::new(Vec3::ZERO, Vec3::X, f32::INFINITY, f32::INFINITY).is_traceable());
        // The bound is tight, on every component, whatever the sign; NaN and -inf anywhere.
        let above = max.next_up();
        for a in 0..3 {
            for sign in [1.0, -1.0] {
                let mut v = Vec3::ONE;
                v[a] = sign * above;
                assert!(!ray(v, Vec3::X).is_traceable(), "origin {v}");
                assert!(!ray(Vec3::ZERO, v).is_traceable(), "direction {v}");
                v[a] = sign * max;
                assert!(ray(v, v).is_traceable(), "{v}");
                v[a] = -f32::NAN;
                assert!(!ray(v, Vec3::X).is_traceable(), "origin {v}");
                v[a] = f32::NEG_INFINITY;
                assert!(!ray(Vec3::ZERO, v).is_traceable(), "direction {v}");
            }
        }
        // A direction of negative zeros is no direction; one subnormal component is one.
        assert!(!ray(Vec3::ZERO, Vec3::splat(-0.0)).is_traceable());
        assert!(ray(Vec3::ZERO, Vec3::new(-0.0, 0.0, 1e-41)).is_traceable());
        for bad in [f32::NAN, -f32::NAN] {
            assert!(!Ray::new(Vec3::ZERO, Vec3::X, bad, 1.0).is_traceable());
            assert!(!Ray::new(Vec3::ZERO, Vec3::X, 0.0, bad).is_traceable());
        }
    }

    #[test]
    fn subnormal_direction_components_become_zeros_of_their_sign() {
        let smallest_normal = f32::MIN_POSITIVE;
        let largest_subnormal = f32::from_bits(smallest_normal.to_bits() - 1);
        let tiny = f32::from_bits(1);
        let ray = Ray::new(
            Vec3::ONE,
            Vec3::new(-largest_subnormal, tiny, 0.5),
            0.0,
            1.0,
        );
        let flushed = ray.without_subnormal_direction();
        assert_eq!(flushed.dir.x.to_bits(), (-0.0f32).to_bits());
        assert_eq!(flushed.dir.y.to_bits(), 0.0f32.to_bits());
        assert_eq!(flushed.dir.z, 0.5);
        assert_eq!(
            (flushed.origin, flushed.tmin, flushed.tmax),
            (ray.origin, 0.0, 1.0)
        );
        // Normal components, zeros of either sign and the smallest normal stay as they are.
        let kept = Ray::new(
            Vec3::ONE,
            Vec3::new(smallest_normal, -0.0, -smallest_normal),
            0.0,
            1.0,
        );
        let same = kept.without_subnormal_direction();
        assert_eq!(
            same.dir.to_array().map(f32::to_bits),
            kept.dir.to_array().map(f32::to_bits)
        );
    }
}
