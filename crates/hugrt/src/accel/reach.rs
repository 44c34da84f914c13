//! Rays from far away, moved to the scene before any structure walks them.
//!
//! Every test of a query measures from the ray's origin: the triangle test translates the
//! vertices by it (Woop et al. 2013, §3), the slab tests and the grids' 3D-DDA take distances
//! from it. In single precision each of these is exact to a few ulps of the origin's distance
//! from the scene, not of the scene's size, and a grid's or kd-tree's walk stops being exact
//! once that distance outgrows the margin ([`super::margin`]): from 4·10⁶ away, the DDA's cell
//! boundaries on a unit cube lay 0.4 apart in `t`, and the HUG, the grids, the octree and the
//! kd-tree missed a hit on the cube's corner that brute force and the bvh found (the rays
//! fuzz target's find, `fuzz/regressions/rays/far-origin-*`).
//!
//! So a ray whose origin lies farther than [`FAR`] times the scene's magnitude from the world
//! origin is first moved along itself, in double precision, to where it enters the scene's
//! box (or to its `tmin`, if that lies inside): a new origin that is a point of the ray to
//! within an ulp of the scene's magnitude. Every structure, brute force included, then walks
//! that ray, so they all test the same ray and agree as they do on near rays, and its hits
//! are more accurate than the far origin's single precision allowed. A hit's `t` is mapped
//! back to the caller's ray, rounded once and clamped to its `[tmin, tmax]`.
//!
//! A ray whose direction is small ([`Ray::has_small_direction`], below 2⁻⁶³) is walked the
//! same way, its direction first scaled by a power of two ([`scaled`]): its hits lie at `t`
//! so large that the walks' plane and box distances left `f32`'s range.
//!
//! The move is exact to within the margin for origins up to about 2⁸⁰ times the scene's
//! magnitude away (each step's new origin is off the ray by an ulp of its own distance from
//! the scene, in double precision); with origins bounded by [`crate::geometry::Ray::MAX_COMPONENT`]
//! (2⁶⁴), that is every scene larger than 2⁻¹⁶.

use super::simd;
use super::store::finite;
use super::{Hit, Primitives};
use crate::geometry::{Aabb, Ray};
use glam::DVec3;
use rayon::prelude::*;

/// How far, in multiples of the scene's magnitude, an origin may lie before its ray is moved.
/// Within it the walks' rounding is a few ulps of 16 times the magnitude, which the margin
/// (64 ulps of the magnitude) covers; cameras a few scene sizes away stay unmoved.
pub const FAR: f32 = 16.0;

/// Steps of the move: each brings the origin to within 2⁻⁴⁸ of its distance from the box.
const MAX_STEPS: usize = 8;

/// The slab distances' relative widening: double precision rounds each to 2⁻⁵³.
const PAD: f64 = 1.0 / (1u64 << 48) as f64;

/// Where a structure's primitives lie, for moving far rays to them: the union of their
/// finite boxes, computed by every structure the same way from the same primitives (so that
/// they all walk the same moved ray).
#[derive(Clone, Copy, Debug)]
pub struct Reach {
    bounds: Aabb,
    /// Origins with a component beyond this are moved: [`FAR`] times the scene's magnitude;
    /// infinite for a scene with nothing to hit.
    far: f32,
}

/// A far ray moved to the scene: the ray a query walks, and how its hits map back to the
/// caller's ray.
#[derive(Clone, Copy, Debug)]
pub struct Moved {
    pub ray: Ray,
    /// The walked ray's `t` of the new origin.
    shift: f64,
    /// The caller's `t` per unit of the walked ray's `t`: a power of two ([`scaled`]).
    scale: f64,
    /// The caller's interval.
    tmin: f32,
    tmax: f32,
}

impl Moved {
    /// A hit of the walked ray as a hit of the caller's.
    pub fn hit(&self, h: Hit) -> Hit {
        Hit {
            t: (((self.shift + h.t as f64) * self.scale) as f32).clamp(self.tmin, self.tmax),
            prim: h.prim,
        }
    }
}

impl Reach {
    /// The reach of `prims`, as every structure built over them has it ([`super::Accel::reach`]).
    pub fn of<P: Primitives>(prims: &P) -> Reach {
        Reach::from_bounds(
            (0..prims.len())
                .into_par_iter()
                .map(|i| prims.bounds(i))
                .filter(finite)
                .reduce(|| Aabb::EMPTY, |a, b| a.union(&b)),
        )
    }

    /// The reach of primitives whose finite boxes' union is `bounds` (a union does not depend
    /// on the order it is taken in, so a build that already visits every box gets the same
    /// reach as [`Reach::of`]).
    pub fn from_bounds(bounds: Aabb) -> Reach {
        let far = if bounds.is_empty() {
            f32::INFINITY
        } else {
            FAR * bounds.magnitude().max(bounds.extent().max_element())
        };
        Reach { bounds, far }
    }

    /// The union of the primitives' finite boxes.
    pub fn bounds(&self) -> &Aabb {
        &self.bounds
    }

    /// Whether a traceable `ray` is walked as given (its subnormal direction components
    /// flushed): its origin is near the primitives, and its direction not small
    /// ([`Ray::has_small_direction`]). The queries ask this on the hot path, together with
    /// [`Ray::is_traceable`] from one reading of the ray's bits, and leave [`Reach::moved`] to
    /// a separate, cold function: building a moved-or-not ray on the stack for every query
    /// cost the bvh 30% of its camera rays' speed (stores and loads of different widths that
    /// the CPU cannot forward).
    #[inline(always)]
    pub fn walks_as_given(&self, ray: &Ray) -> bool {
        self.near(ray) & !ray.has_small_direction()
    }

    /// What a query does with `ray`: [`Ray::is_traceable`] and [`Reach::walks_as_given`]
    /// together, the direction's bits read once.
    #[inline(always)]
    pub(crate) fn route(&self, ray: &Ray) -> Route {
        let (traceable, small) = ray.traceable_and_small();
        if !traceable {
            Route::Skip
        } else if self.near(ray) & !small {
            Route::AsGiven
        } else {
            Route::Moved
        }
    }

    /// [`Reach::route`] of the rays `rays[at[k]]` for each `k` (at most eight), bit `k` of each
    /// mask, and which of them have a subnormal direction component. In AVX2 where `avx2`
    /// (the processor has it, [`simd::available`]): the same tests on the same bits, eight
    /// rays at once (ray by ray, reading a ray's bits and branching on them took about 75
    /// instructions a ray, an eighth of a camera frame's). Ray by ray otherwise: the same
    /// tests in rows, gathered number by number, took as many.
    #[inline(always)]
    pub(crate) fn route8(&self, rays: &[Ray], at: &[u32], avx2: bool) -> Routes {
        debug_assert!(at.len() <= 8);
        #[cfg(target_arch = "x86_64")]
        if avx2 && !at.is_empty() {
            // SAFETY: `avx2` holds only where the processor has AVX2.
            return unsafe { self.route8_avx2(rays, at) };
        }
        let _ = avx2;
        let mut routes = Routes {
            as_given: 0,
            moved: 0,
            subnormal: 0,
        };
        for (k, &i) in at.iter().enumerate() {
            let ray = &rays[i as usize];
            match self.route(ray) {
                Route::Skip => {}
                Route::AsGiven => routes.as_given |= 1 << k,
                Route::Moved => routes.moved |= 1 << k,
            }
            routes.subnormal |= (ray.has_subnormal_direction() as u32) << k;
        }
        routes
    }

    /// [`Reach::route8`] in AVX2, on [`simd::ray_rows_avx2`]'s rows. A component's magnitude
    /// bits are below 2^31, so the signed comparisons of 32-bit lanes order them; for a
    /// traceable ray, whose components are finite, an origin is near when each component's
    /// magnitude bits are at most `far`'s, since non-negative floats are ordered as their bits.
    ///
    /// # Safety
    /// The processor must support AVX2; `at` is not empty.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn route8_avx2(&self, rays: &[Ray], at: &[u32]) -> Routes {
        use std::arch::x86_64::*;
        let n = at.len();
        // Lanes past `at` repeat its last ray, and are masked off below.
        // SAFETY: the caller's processor has AVX2.
        let c = unsafe { simd::ray_rows_avx2(rays, |l| at[l.min(n - 1)] as usize) };
        let magnitude =
            |x: __m256| _mm256_and_si256(_mm256_castps_si256(x), _mm256_set1_epi32(0x7fff_ffff));
        let (o, d) = (
            [magnitude(c[0]), magnitude(c[1]), magnitude(c[2])],
            [magnitude(c[3]), magnitude(c[4]), magnitude(c[5])],
        );
        let splat = |x: f32| _mm256_set1_epi32(x.to_bits() as i32);
        let above = |v: &[__m256i; 3], bound: __m256i| {
            _mm256_or_si256(
                _mm256_or_si256(
                    _mm256_cmpgt_epi32(v[0], bound),
                    _mm256_cmpgt_epi32(v[1], bound),
                ),
                _mm256_cmpgt_epi32(v[2], bound),
            )
        };
        let bound = splat(Ray::MAX_COMPONENT);
        let direction = _mm256_or_si256(_mm256_or_si256(d[0], d[1]), d[2]);
        let zero = _mm256_setzero_si256();
        let bad = _mm256_or_si256(
            _mm256_or_si256(above(&o, bound), above(&d, bound)),
            _mm256_cmpeq_epi32(direction, zero),
        );
        let interval = _mm256_castps_si256(_mm256_and_ps(
            _mm256_cmp_ps::<_CMP_LE_OQ>(c[6], c[7]),
            _mm256_cmp_ps::<_CMP_LT_OQ>(c[6], _mm256_set1_ps(f32::INFINITY)),
        ));
        let traceable = _mm256_andnot_si256(bad, interval);
        let small = _mm256_cmpgt_epi32(splat(Ray::SMALL_DIRECTION), direction);
        let given = _mm256_andnot_si256(
            _mm256_or_si256(small, above(&o, splat(self.far))),
            traceable,
        );
        let moved = _mm256_andnot_si256(given, traceable);
        // Subnormal: magnitude bits from 1 to 2^23 − 1.
        let top = _mm256_set1_epi32(1 << 23);
        let subnormal = (0..3).fold(zero, |s, a| {
            _mm256_or_si256(
                s,
                _mm256_and_si256(
                    _mm256_cmpgt_epi32(d[a], zero),
                    _mm256_cmpgt_epi32(top, d[a]),
                ),
            )
        });
        let lanes =
            |m: __m256i| _mm256_movemask_ps(_mm256_castsi256_ps(m)) as u32 & (u32::MAX >> (32 - n));
        Routes {
            as_given: lanes(given),
            moved: lanes(moved),
            subnormal: lanes(subnormal),
        }
    }

    /// Whether the ray's origin is near enough to the primitives to be walked from.
    #[inline(always)]
    fn near(&self, ray: &Ray) -> bool {
        ray.origin.abs().max_element() <= self.far
    }

    /// The ray to walk for a traceable ray that is not walked as given
    /// ([`Reach::walks_as_given`]): a small direction scaled by a power of two, exactly,
    /// its subnormal components then flushed ([`Ray::without_subnormal_direction`]), and a far
    /// origin moved; `None` when it cannot meet the scene's box in its interval.
    pub fn moved(&self, ray: &Ray) -> Option<Moved> {
        let (caller, (ray, scale)) = (ray, scaled(ray));
        let ray = &ray;
        let d = ray.dir.as_dvec3();
        let (lo, hi) = (self.bounds.min.as_dvec3(), self.bounds.max.as_dvec3());
        let (tmin, tmax) = (ray.tmin as f64, ray.tmax as f64);
        let mut o = ray.origin.as_dvec3();
        let mut shift = 0.0f64;
        for _ in 0..MAX_STEPS {
            if o.abs().max_element() <= self.far as f64 {
                break;
            }
            let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
            for a in 0..3 {
                if d[a] == 0.0 {
                    if o[a] < lo[a] || o[a] > hi[a] {
                        return None;
                    }
                } else {
                    let (ta, tb) = ((lo[a] - o[a]) / d[a], (hi[a] - o[a]) / d[a]);
                    t0 = t0.max(ta.min(tb));
                    t1 = t1.min(ta.max(tb));
                }
            }
            let pad = t0.abs().max(t1.abs()) * PAD;
            let (t0, t1) = (t0 - pad, t1 + pad);
            let (from, to) = (tmin - shift, tmax - shift);
            if t0 > t1 || t1 < from || t0 > to {
                return None;
            }
            let s = t0.max(from);
            // One rounding: the new origin is the ray's point at `s` to an ulp of itself.
            o = d.mul_add(DVec3::splat(s), o);
            shift += s;
        }
        Some(Moved {
            ray: Ray {
                origin: o.as_vec3(),
                dir: ray.dir,
                tmin: (tmin - shift) as f32,
                tmax: (tmax - shift) as f32,
            },
            shift,
            scale,
            tmin: caller.tmin,
            tmax: caller.tmax,
        })
    }
}

/// What the batch queries do with up to eight rays ([`Reach::route8`]), a bit a ray.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Routes {
    /// The rays [`Reach::route`] walks as given ([`Route::AsGiven`]).
    pub(crate) as_given: u32,
    /// The rays it moves ([`Route::Moved`]); the others are skipped.
    pub(crate) moved: u32,
    /// The rays with a subnormal direction component, which
    /// [`Ray::without_subnormal_direction`] flushes.
    pub(crate) subnormal: u32,
}

/// What a query does with a ray ([`Reach::route`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Route {
    /// Not traceable: no hit.
    Skip,
    /// Walked as given, its subnormal direction components flushed.
    AsGiven,
    /// Walked as [`Reach::moved`] gives it.
    Moved,
}

/// `ray` with a small direction ([`Ray::has_small_direction`]) scaled by the power of two `s`
/// that brings its largest component into `[1, 2)`, its interval divided by `s` (`tmax` first
/// bounded by `f32::MAX`, so that no hit maps back past it), and its subnormal components then
/// flushed; with `s`, the factor from the scaled ray's `t` to the caller's. Scaling by a power
/// of two is exact, so the scaled ray is the caller's ray, and a hit's `t` on it maps back to
/// the `t` the caller's ray would give, bit for bit, unless it falls below the least normal
/// `f32` (a hit within 10^-19 of an origin that is on the surface). Components that were
/// subnormal become normal and keep their say in where the ray goes. Any other ray comes back
/// flushed, with `s = 1`.
fn scaled(ray: &Ray) -> (Ray, f64) {
    if !ray.has_small_direction() {
        return (ray.without_subnormal_direction(), 1.0);
    }
    let largest = ray.dir.abs().max_element() as f64;
    // `largest` is normal as an `f64`: `s` is 2 to minus its exponent.
    let exponent = ((largest.to_bits() >> 52) & 0x7ff) as i64 - 1023;
    let s = f64::from_bits(((1023 - exponent) as u64) << 52);
    let scaled = Ray {
        origin: ray.origin,
        dir: (ray.dir.as_dvec3() * s).as_vec3(),
        tmin: (ray.tmin as f64 / s) as f32,
        tmax: (ray.tmax.min(f32::MAX) as f64 / s) as f32,
    };
    (scaled.without_subnormal_direction(), s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Vec3;
    use crate::scene::Scene;

    /// [`Reach::route8`] routes each ray as [`Reach::route`] does, and finds the rays that
    /// [`Ray::without_subnormal_direction`] changes, on every mix of zeros, subnormals, the
    /// small-direction, far and component bounds, infinities and NaN.
    #[test]
    fn route8_routes_as_route() {
        let reach = Reach::of(&unit_cube());
        let far = reach.far;
        let up = |x: f32| f32::from_bits(x.to_bits() + 1);
        let down = |x: f32| f32::from_bits(x.to_bits() - 1);
        let values = [
            0.0,
            -0.0,
            f32::from_bits(1),
            -f32::from_bits(0x7f_ffff),
            f32::MIN_POSITIVE,
            down(Ray::SMALL_DIRECTION),
            Ray::SMALL_DIRECTION,
            -up(Ray::SMALL_DIRECTION),
            0.5,
            -1.0,
            far,
            up(far),
            -down(far),
            Ray::MAX_COMPONENT,
            up(Ray::MAX_COMPONENT),
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
        ];
        let ends = [
            (0.0, f32::INFINITY),
            (1.0, 1.0),
            (2.0, 1.0),
            (f32::NEG_INFINITY, 0.0),
            (f32::INFINITY, f32::INFINITY),
            (f32::NAN, 1.0),
            (0.0, f32::NAN),
        ];
        let mut rays = Vec::new();
        let mut k = 0usize;
        for &a in &values {
            for &b in &values {
                for &(tmin, tmax) in &ends {
                    let c = k;
                    let pick = |j: usize| values[(c * 5 + j * 7) % values.len()];
                    k += 1;
                    let small = Vec3::new(pick(3), pick(4), b);
                    rays.push(Ray::new(Vec3::new(a, pick(1), 0.25), small, tmin, tmax));
                    rays.push(Ray::new(
                        Vec3::new(0.5, b, pick(2)),
                        Vec3::new(a, 1.0, pick(5)),
                        tmin,
                        tmax,
                    ));
                }
            }
        }
        let mut seen = [0usize; 3];
        let at: Vec<u32> = (0..rays.len() as u32).rev().collect();
        let mut paths = vec![false];
        if simd::available() {
            paths.push(true);
        } else {
            eprintln!("no AVX2 here: only the portable path is tested");
        }
        for (group, &avx2) in at.chunks(8).flat_map(|g| paths.iter().map(move |p| (g, p))) {
            let routes = reach.route8(&rays, group, avx2);
            for (l, &i) in group.iter().enumerate() {
                let ray = &rays[i as usize];
                let route = match (routes.as_given >> l & 1, routes.moved >> l & 1) {
                    (1, 0) => Route::AsGiven,
                    (0, 1) => Route::Moved,
                    (0, 0) => Route::Skip,
                    _ => panic!("two routes for {ray:?}"),
                };
                assert_eq!(route, reach.route(ray), "{ray:?}");
                seen[route as usize] += 1;
                let flushed = ray.without_subnormal_direction();
                let changed = flushed.dir.to_array().map(f32::to_bits)
                    != ray.dir.to_array().map(f32::to_bits);
                assert_eq!(routes.subnormal >> l & 1 != 0, changed, "{ray:?}");
            }
            assert_eq!(
                (routes.as_given | routes.moved | routes.subnormal) >> group.len(),
                0
            );
        }
        assert!(
            seen.iter().all(|&n| n > 50 * paths.len()),
            "every route tested: {seen:?}"
        );
    }

    fn unit_cube() -> Scene {
        Scene::from_triangles(vec![
            [Vec3::ZERO, Vec3::X, Vec3::Y],
            [Vec3::ONE, Vec3::ONE - Vec3::X, Vec3::ONE - Vec3::Y],
        ])
    }

    #[test]
    fn near_rays_are_walked_as_given() {
        let reach = Reach::of(&unit_cube());
        let ray = Ray::new(Vec3::splat(15.0), -Vec3::ONE, -3.0, 40.0);
        assert!(reach.walks_as_given(&ray));
        assert!(!reach.walks_as_given(&Ray::new(Vec3::splat(17.0), -Vec3::ONE, -3.0, 40.0)));
    }

    /// The queries' one reading of a ray's bits ([`Reach::route`]) says what
    /// [`Ray::is_traceable`] and [`Reach::walks_as_given`] say, on rays near the bounds of
    /// each: the direction at and below [`Ray::SMALL_DIRECTION`], the origin at and past the
    /// reach, components past [`Ray::MAX_COMPONENT`], NaN, a zero direction, empty intervals.
    #[test]
    fn the_route_is_the_two_checks() {
        let reach = Reach::of(&unit_cube());
        let small = Ray::SMALL_DIRECTION;
        let past = Ray::MAX_COMPONENT * 2.0;
        let origins = [
            Vec3::splat(0.5),
            Vec3::splat(15.0),
            Vec3::splat(17.0),
            Vec3::new(-past, 0.0, 0.0),
            Vec3::new(0.0, f32::NAN, 0.0),
        ];
        let directions = [
            Vec3::new(1.0, -0.5, 0.25),
            Vec3::new(0.0, 0.0, -small),
            Vec3::new(small * 0.75, -small * 0.5, 0.0),
            Vec3::splat(f32::MIN_POSITIVE * 0.5),
            Vec3::ZERO,
            Vec3::new(0.0, past, 0.0),
            Vec3::new(f32::INFINITY, 0.0, 0.0),
        ];
        let intervals = [
            (0.0, f32::INFINITY),
            (2.0, 1.0),
            (f32::INFINITY, f32::INFINITY),
        ];
        let mut seen = [0; 3];
        for o in origins {
            for d in directions {
                for (tmin, tmax) in intervals {
                    let ray = Ray::new(o, d, tmin, tmax);
                    let expected = if !ray.is_traceable() {
                        Route::Skip
                    } else if reach.walks_as_given(&ray) {
                        Route::AsGiven
                    } else {
                        Route::Moved
                    };
                    assert_eq!(reach.route(&ray), expected, "{ray:?}");
                    seen[expected as usize] += 1;
                }
            }
        }
        assert!(seen.iter().all(|&n| n > 0), "{seen:?}");
    }

    /// A ray from 10¹⁸ away is moved to just before the box, on the ray to within an ulp of the
    /// box, and its hits' `t` map back to the caller's parameter.
    #[test]
    fn far_rays_are_moved_to_the_box() {
        let reach = Reach::of(&unit_cube());
        let far = 1.0e18f32;
        let ray = Ray::new(
            Vec3::new(0.25, 0.5, far),
            Vec3::new(0.0, 0.0, -far),
            0.0,
            2.0,
        );
        let a = reach.moved(&ray).unwrap();
        let o = a.ray.origin;
        assert_eq!((o.x, o.y), (0.25, 0.5));
        assert!(o.z >= 1.0 && o.z < 1.0 + 1e-6, "{o}");
        // The face z = 1 at t = 1 − 1e-18 along the caller's ray: 1.0 in single precision.
        let walked = (o.z - 1.0) / far;
        assert_eq!(a.hit(Hit { t: walked, prim: 1 }).t, 1.0);
        // Hits map into the caller's interval, even where rounding would leave it.
        assert_eq!(a.hit(Hit { t: 5.0, prim: 1 }).t, 2.0);
    }

    /// A direction of subnormal components is scaled, exactly, to one whose largest component
    /// is in `[1, 2)`, keeping the components that a flush would have zeroed; the interval
    /// is scaled the other way, with an infinite `tmax` bounded first; a hit maps back exactly.
    #[test]
    fn small_directions_are_scaled_by_a_power_of_two() {
        let reach = Reach::of(&unit_cube());
        let tiny = 2.0f32.powi(-140);
        let ray = Ray::new(
            Vec3::new(0.25, 0.5, 2.0),
            Vec3::new(0.5, 0.25, -1.5) * tiny,
            tiny,
            f32::INFINITY,
        );
        assert!(ray.has_small_direction() && !reach.walks_as_given(&ray));
        let a = reach.moved(&ray).unwrap();
        assert_eq!(a.ray.origin, ray.origin);
        assert_eq!(a.ray.dir, Vec3::new(0.5, 0.25, -1.5));
        // 2^-140 / 2^140 is below the least subnormal `f32`.
        assert_eq!(a.ray.tmin, 0.0);
        assert_eq!(a.ray.tmax, (f32::MAX as f64 / 2f64.powi(140)) as f32);
        let t = 0.75 * 2.0f32.powi(-20);
        assert_eq!(a.hit(Hit { t, prim: 0 }).t, 0.75 * 2.0f32.powi(120));
        // A direction of exactly the bound is not small: walked as given.
        let normal = Ray::new(Vec3::ZERO, Vec3::X * Ray::SMALL_DIRECTION, 0.0, 1.0);
        assert!(!normal.has_small_direction() && reach.walks_as_given(&normal));
        let below = Ray::new(Vec3::ZERO, Vec3::X * Ray::SMALL_DIRECTION * 0.75, 0.0, 1.0);
        assert!(below.has_small_direction());
    }

    #[test]
    fn far_rays_that_miss_the_box_are_not_walked() {
        let reach = Reach::of(&unit_cube());
        let o = Vec3::new(3.0e9, 0.5, 0.5);
        assert!(
            reach
                .moved(&Ray::new(o, Vec3::X, 0.0, f32::INFINITY))
                .is_none()
        );
        assert!(
            reach
                .moved(&Ray::new(o, Vec3::Y, 0.0, f32::INFINITY))
                .is_none()
        );
        assert!(reach.moved(&Ray::new(o, -Vec3::X, 0.0, 1.0e9)).is_none());
        assert!(reach.moved(&Ray::new(o, -Vec3::X, 0.0, 3.1e9)).is_some());
    }

    #[test]
    fn a_far_tmin_inside_the_box_becomes_the_origin() {
        let reach = Reach::of(&unit_cube());
        let ray = Ray::new(Vec3::new(-1.0e12, 0.5, 0.5), Vec3::X, 1.0e12, f32::INFINITY);
        let a = reach.moved(&ray).unwrap();
        assert_eq!(a.ray.origin, Vec3::new(0.0, 0.5, 0.5));
        assert_eq!(a.ray.tmin, 0.0);
    }
}
