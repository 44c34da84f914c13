//! Packets: rays walked through a structure together, for the rays a renderer shoots in bulk
//! (a camera's neighbouring pixels, shadow rays from neighbouring points to one light).
//!
//! A packet is up to [`PACKET`] rays. A structure with a packet walk ([`super::Accel::query_packet`])
//! fetches each node or cell once for all the rays that reach it, and meets it with all of them
//! in one pass of lane-wise arithmetic; a structure without one walks the rays one at a time.
//! Either way each ray gets exactly the answer it gets alone: the packet may test a ray against
//! more primitives than its own walk would (a node reached by the packet in another order, when
//! the ray's nearest hit so far is farther), never fewer, and the closest hit does not depend on
//! the order of the tests ([`super::Hit::improves`]).
//!
//! [`Packets`] says when to use them: `auto` walks together the rays of a group of
//! [`PACKET`] neighbours that look coherent ([`coherent`]), so that a camera's rays or a
//! light's, written by any tool, qualify, through the structures whose packet walk measures
//! faster than one ray at a time ([`super::Accel::PACKETS_PAY`]); `on` walks every group as a
//! packet; `off` walks every ray alone. Neighbours are found by `accel::order` (a camera's
//! rays in tiles, rays to a light by direction) where the rays allow, else taken in the
//! caller's order.

use super::Ray;

/// Rays a packet of the bvh holds, and the group of the packet kernels: eight lanes, one AVX
/// register of `f32`.
pub const PACKET: usize = 8;

/// Rays a packet holds at most ([`super::Accel::PACKET_RAYS`]): the grids' packets are four
/// groups of [`PACKET`], so that the work of each slice is shared by more rays.
pub const MAX_PACKET: usize = 32;

/// The lanes of a packet's mask (bit `l` for ray `l`), lowest first.
#[inline(always)]
pub(crate) fn each_lane(mut mask: u32) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        (mask != 0).then(|| {
            let l = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            l
        })
    })
}

/// When batch queries walk rays as packets.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Packets {
    /// Groups of [`PACKET`] neighbouring rays that look coherent ([`coherent`]) as packets, the
    /// others one at a time, with structures whose packet walk is faster than their walk of
    /// one ray ([`super::Accel::PACKETS_PAY`]); every ray alone with the others.
    #[default]
    Auto,
    /// Every group of [`PACKET`] neighbouring rays as a packet, coherent or not.
    On,
    /// Every ray on its own: walked alone, and any-hit rays not first tried against what
    /// blocked their neighbours ([`super::Accel::any_hits`]' shadow cache).
    Off,
}

impl Packets {
    /// Every value's name, as `str::parse` reads it.
    pub const NAMES: &[&str] = &["auto", "on", "off"];

    /// Whether some groups may be walked as packets by a structure whose packet walk pays or
    /// not (`pays`): what [`Packets::walk_together`] asks before looking at the rays.
    #[inline]
    pub fn may_walk(self, pays: bool) -> bool {
        match self {
            Packets::Auto => pays,
            Packets::On => true,
            Packets::Off => false,
        }
    }

    /// Whether the group `rays` is walked as a packet by a structure whose packet walk pays
    /// or not (`pays`).
    #[inline]
    pub fn walk_together(self, rays: &[Ray], pays: bool) -> bool {
        self.may_walk(pays)
            && match self {
                Packets::Auto => coherent(rays),
                _ => rays.len() > 1,
            }
    }
}

impl std::str::FromStr for Packets {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "auto" => Ok(Packets::Auto),
            "on" => Ok(Packets::On),
            "off" => Ok(Packets::Off),
            _ => Err(format!(
                "unknown packets mode `{s}`: expected one of {}",
                Self::NAMES.join(", ")
            )),
        }
    }
}

impl std::fmt::Display for Packets {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Packets::Auto => "auto",
            Packets::On => "on",
            Packets::Off => "off",
        })
    }
}

/// Whether neighbouring rays are worth walking together: at least two, every direction in
/// the same octant as the first and within [`COHERENT_COS`] of it. Rays from one point through
/// neighbouring pixels qualify, and so do rays from neighbouring points to one light; rays in
/// random directions do not. Only a matter of speed: packets give every ray its own answer.
///
/// Eight rays at once in AVX2 where the processor has it (the same tests on the same numbers:
/// one ray at a time they were about 34 instructions a ray of a camera's frame).
#[inline]
pub fn coherent(rays: &[Ray]) -> bool {
    #[cfg(target_arch = "x86_64")]
    if rays.len() > 1 && super::simd::available() {
        // SAFETY: the processor has AVX2.
        return unsafe { coherent_avx2(rays) };
    }
    coherent_one_by_one(rays)
}

/// [`coherent`] ray by ray.
#[inline]
fn coherent_one_by_one(rays: &[Ray]) -> bool {
    let Some(first) = rays.first() else {
        return false;
    };
    let d0 = first.dir;
    let sign = d0.is_negative_bitmask();
    // cos ≥ c as dot > 0 and dot² ≥ c²·|d|²·|d0|²: no square root nor division per ray,
    // which made the check cost up to a tenth of a camera frame with packets. A zero direction
    // is never coherent.
    let c2 = COHERENT_COS * COHERENT_COS * d0.length_squared();
    rays.len() > 1
        && c2 > 0.0
        && rays[1..].iter().all(|r| {
            let dot = r.dir.dot(d0);
            r.dir.is_negative_bitmask() == sign
                && dot > 0.0
                && dot * dot >= c2 * r.dir.length_squared()
        })
}

/// [`coherent`] in AVX2, on [`super::simd::ray_rows_avx2`]'s rows: each lane makes the
/// single test's products and sums in its order (glam's `dot` and `length_squared` add `x`,
/// then `y`, then `z`), and the octant is the three sign bits.
///
/// # Safety
/// The processor must support AVX2; `rays` holds at least two rays.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn coherent_avx2(rays: &[Ray]) -> bool {
    use std::arch::x86_64::*;
    let d0 = rays[0].dir;
    let c2 = COHERENT_COS * COHERENT_COS * d0.length_squared();
    if c2.is_nan() || c2 <= 0.0 {
        return false;
    }
    let n = rays.len();
    let (x0, y0, z0) = (
        _mm256_set1_ps(d0.x),
        _mm256_set1_ps(d0.y),
        _mm256_set1_ps(d0.z),
    );
    let (c2, zero) = (_mm256_set1_ps(c2), _mm256_setzero_ps());
    let sign = _mm256_set1_ps(-0.0);
    let mut k = 1;
    while k < n {
        // Lanes past the last ray repeat it.
        // SAFETY: the caller's processor has AVX2.
        let c = unsafe { super::simd::ray_rows_avx2(rays, |l| (k + l).min(n - 1)) };
        let (x, y, z) = (c[3], c[4], c[5]);
        let dot = _mm256_add_ps(
            _mm256_add_ps(_mm256_mul_ps(x, x0), _mm256_mul_ps(y, y0)),
            _mm256_mul_ps(z, z0),
        );
        let length = _mm256_add_ps(
            _mm256_add_ps(_mm256_mul_ps(x, x), _mm256_mul_ps(y, y)),
            _mm256_mul_ps(z, z),
        );
        // A sign differs from the first direction's where the exclusive or keeps it.
        let flips = _mm256_or_ps(
            _mm256_or_ps(_mm256_xor_ps(x, x0), _mm256_xor_ps(y, y0)),
            _mm256_xor_ps(z, z0),
        );
        let octant = _mm256_castsi256_ps(_mm256_cmpeq_epi32(
            _mm256_castps_si256(_mm256_and_ps(flips, sign)),
            _mm256_setzero_si256(),
        ));
        let near = _mm256_and_ps(
            _mm256_cmp_ps::<_CMP_GT_OQ>(dot, zero),
            _mm256_cmp_ps::<_CMP_GE_OQ>(_mm256_mul_ps(dot, dot), _mm256_mul_ps(c2, length)),
        );
        if _mm256_movemask_ps(_mm256_and_ps(octant, near)) != 0xff {
            return false;
        }
        k += 8;
    }
    true
}

/// The cosine of the widest angle [`coherent`] allows between a group's first direction and
/// another's: 0.98, about 11°, several times a 1024-pixel camera's group of eight (a
/// 45° field of view spreads eight neighbouring pixels over 0.35°) or a light's from points a
/// tenth of its distance apart.
pub const COHERENT_COS: f32 = 0.98;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Vec3;

    fn ray(d: Vec3) -> Ray {
        Ray::new(Vec3::ZERO, d, 0.0, f32::INFINITY)
    }

    /// [`coherent`]'s AVX2 path answers as the one ray at a time, on groups of one to 32 rays
    /// that share an octant and a cone or leave it by one ray, a sign of zero or a NaN.
    #[test]
    fn coherent_answers_alike_on_every_path() {
        if !crate::accel::simd::available() {
            eprintln!("no AVX2 here: only the portable path runs");
            return;
        }
        let base = Vec3::new(0.3, -0.5, 0.8);
        let odd = [
            Vec3::new(0.3, -0.5, -0.8),
            Vec3::new(-0.0, -0.5, 0.8),
            Vec3::new(0.3, -0.5, 0.0),
            Vec3::new(0.3, 0.5, 0.8),
            Vec3::new(f32::NAN, -0.5, 0.8),
            Vec3::new(0.6, -0.5, 0.8),
            Vec3::new(0.3, -0.56, 0.8),
            Vec3::ZERO,
            Vec3::new(1e30, -1e30, 1e30),
        ];
        let (mut yes, mut no) = (0, 0);
        for n in 1..=32usize {
            for (j, &d) in odd.iter().enumerate() {
                for at in [0, n / 2, n - 1] {
                    let rays: Vec<Ray> = (0..n)
                        .map(|i| {
                            let spread = Vec3::new(0.001 * i as f32, 0.0005 * (j as f32), 0.0);
                            ray(if i == at { d } else { base + spread })
                        })
                        .collect();
                    let one = coherent_one_by_one(&rays);
                    assert_eq!(coherent(&rays), one, "{rays:?}");
                    if n > 1 {
                        // SAFETY: the processor has AVX2.
                        assert_eq!(unsafe { coherent_avx2(&rays) }, one, "{rays:?}");
                    }
                    (yes, no) = if one { (yes + 1, no) } else { (yes, no + 1) };
                }
            }
        }
        assert!(yes > 100 && no > 100, "both answers tested: {yes}, {no}");
    }

    #[test]
    fn neighbouring_pixels_are_coherent_and_random_directions_are_not() {
        let pixels: Vec<Ray> = (0..8)
            .map(|i| ray(Vec3::new(0.01 * i as f32, 0.3, 1.0)))
            .collect();
        assert!(coherent(&pixels));
        let mut spread = pixels.clone();
        spread[5] = ray(Vec3::new(1.0, 0.3, 1.0));
        assert!(!coherent(&spread), "45° apart");
        let mut flipped = pixels.clone();
        flipped[3] = ray(Vec3::new(0.01, -1e-3, 1.0));
        assert!(!coherent(&flipped), "another octant");
        assert!(!coherent(&pixels[..1]));
        let mut stopped = pixels.clone();
        stopped[0] = ray(Vec3::ZERO);
        assert!(!coherent(&stopped), "a zero direction first");
        stopped.swap(0, 4);
        assert!(!coherent(&stopped), "a zero direction later");
        // Just inside and just outside the widest angle.
        let at = |cos: f32| ray(Vec3::new((1.0 - cos * cos).sqrt(), 0.0, cos));
        assert!(coherent(&[ray(Vec3::Z), at(0.981)]));
        assert!(!coherent(&[ray(Vec3::Z), at(0.979)]));
        assert!(!coherent(&[]));
    }

    #[test]
    fn each_lane_lists_a_masks_bits() {
        assert_eq!(each_lane(0b1010_0110).collect::<Vec<_>>(), [1, 2, 5, 7]);
        assert_eq!(each_lane(0).count(), 0);
    }

    #[test]
    fn modes_parse_and_print() {
        for n in Packets::NAMES {
            assert_eq!(n.parse::<Packets>().unwrap().to_string(), *n);
        }
        assert!("sometimes".parse::<Packets>().is_err());
    }
}
