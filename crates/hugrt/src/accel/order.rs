//! The order in which a batch's rays are grouped into packets ([`super::packet`]).
//!
//! A packet pays by the cells and nodes its rays share, so its rays should be close in the
//! scene, not only in the caller's list. A camera's rays come row by row, and a packet of 32
//! neighbours in a row is a 32 × 1 strip of pixels; a 4 × 8 tile of the same 32 pixels meets
//! fewer cells a ray. Shadow rays come in the order of the pixels that hit, so neighbours in
//! the list may be far apart on screen. The batch queries ([`super::Accel::closest_hits`],
//! [`super::Accel::any_hits`]) therefore group the rays they are given, where packets may be
//! walked, in one of two orders, each found from the rays themselves:
//!
//! - **tiles of a raster** ([`Raster`]): rays whose points `origin + dir` step evenly along
//!   rows and jump back at the start of each row of a fixed width (a pinhole or orthographic
//!   camera's rays, row by row, from any tool) are grouped by tiles of [`TILE_COLUMNS`] ×
//!   [`TILE_ROWS`] pixels, as Wald et al. 2006 trace their packets;
//! - **by direction** ([`by_direction`]): otherwise, where most groups of the given order look
//!   coherent ([`super::packet::coherent`]: shadow rays to one light), the rays are sorted by
//!   the Morton code of their direction's slopes across its major axis, so that a group holds
//!   rays of nearly the same direction, from wherever they start.
//!
//! Every ray gets the same answer in any order; only the speed differs (`docs/measurements.md`,
//! "Packets": the HUG's camera rays 1.1–1.3× faster in tiles, its shadow rays 1.1–1.4×
//! sorted). Rays of no such order (random directions) keep the caller's. Only the grids group
//! rays so ([`super::Accel::ORDER_PAYS`]).

use super::Ray;
use super::packet::coherent;
use crate::geometry::{Vec3, greater, lesser};

/// Columns of a camera's tile: four, so that each group of eight rays of the packet kernels
/// is a 4 × 2 block. Measured against 8 × 4 and 16 × 2 tiles (`docs/measurements.md`).
pub(crate) const TILE_COLUMNS: usize = 4;

/// Rows of a camera's tile ([`TILE_COLUMNS`]): 4 × 8 = 32 rays, a grid packet.
pub(crate) const TILE_ROWS: usize = 8;

/// Rays a batch query is handed at a time by [`crate::batch`]'s parallel loop where it finds
/// no raster: enough for shadow rays from several rows of pixels to sort into packets of
/// neighbours, small enough to stay in the cache while sorted.
pub(crate) const WINDOW: usize = 8192;

/// How much longer than the step before it (squared) the step from one ray's point to the
/// next's must be to start a row: twice as long. A pinhole camera's steps along a row change
/// by a fraction of a percent from pixel to pixel; a row's start steps back by the row's
/// width, at least [`TILE_COLUMNS`] − 1 = 3 steps.
const JUMP: f32 = 4.0;

/// Bits of each slope's cell in [`by_direction`]'s Morton code: 64 × 64 cells, two rays a
/// cell in a window; 11 bits a side sorted shadow rays no better (`docs/measurements.md`).
const SLOPE_BITS: u32 = 6;

/// The order in which `rays` are grouped into packets of `group` rays: indices into `rays`,
/// each once, or `None` to keep the given order.
pub(crate) fn packet_order(rays: &[Ray], group: usize) -> Option<Vec<u32>> {
    if rays.len() <= group || u32::try_from(rays.len()).is_err() {
        return None;
    }
    match Raster::find(rays) {
        Some(raster) => Some(raster.tiles(rays.len())),
        None => by_direction(rays, group),
    }
}

/// How many rays [`crate::batch`] hands a batch query at a time: whole bands of [`TILE_ROWS`]
/// rows of a raster that starts at the first ray (about [`WINDOW`] rays), so that no tile is
/// cut between two calls; [`WINDOW`] rays otherwise.
pub(crate) fn window(rays: &[Ray]) -> usize {
    let head = &rays[..rays.len().min(4 * WINDOW)];
    match Raster::find(head) {
        Some(r) if r.first == 0 => {
            let band = r.width * TILE_ROWS;
            band * (WINDOW / band).max(1)
        }
        _ => WINDOW,
    }
}

/// Rays in rows of `width`, the first full row starting at ray `first < width` (the rays
/// before it end a row).
#[derive(Debug, PartialEq, Eq)]
struct Raster {
    first: usize,
    width: usize,
}

impl Raster {
    /// The raster `rays` lie in, if any. The step from one ray's point `origin + dir` to the
    /// next's starts a row where it is longer than [`JUMP`] times the step before it; the
    /// first two starts found give the width (at least [`TILE_COLUMNS`]), and every later row
    /// must start where the width says, and only there: the steps at the rows' starts and
    /// after them are checked, not every step, since a wrong raster costs only speed. Points
    /// that repeat before the second row's start mean no raster (shadow rays to one light,
    /// whose points are all the light).
    fn find(rays: &[Ray]) -> Option<Raster> {
        let n = rays.len();
        let point = |i: usize| rays[i].origin + rays[i].dir;
        let step = |i: usize| (point(i) - point(i - 1)).length_squared();
        // Whether ray `i ≥ 2` starts a row; `None` where it and the one before are one point.
        let starts = |i: usize| {
            let (before, at) = (step(i - 1), step(i));
            (before > 0.0).then_some(at.is_finite() && at > JUMP * before)
        };
        let mut found = [0; 2];
        let mut k = 0;
        for i in 2..n {
            if starts(i)? {
                found[k] = i;
                k += 1;
                if k == 2 {
                    break;
                }
            }
        }
        let [first, second] = found;
        let width = second.checked_sub(first)?;
        if k < 2 || width < TILE_COLUMNS {
            return None;
        }
        let mut at = second + width;
        while at < n {
            if starts(at) != Some(true) || (at + 1 < n && starts(at + 1) != Some(false)) {
                return None;
            }
            at += width;
        }
        // The first ray may itself start a row: the step before it is not known.
        Some(Raster {
            first: first % width,
            width,
        })
    }

    /// The indices of `n` rays by tiles: bands of [`TILE_ROWS`] rows, each band's tiles of
    /// [`TILE_COLUMNS`] columns left to right, each tile row by row. The rows cut by the ends
    /// of the list make smaller tiles.
    fn tiles(&self, n: usize) -> Vec<u32> {
        let w = self.width;
        // The (partial) row before the first full one starts at `start` ≤ 0.
        let start = self.first as isize - if self.first > 0 { w as isize } else { 0 };
        let rows = (n as isize - start) as usize;
        let rows = rows.div_ceil(w);
        let mut order = Vec::with_capacity(n);
        for band in (0..rows).step_by(TILE_ROWS) {
            for c0 in (0..w).step_by(TILE_COLUMNS) {
                for row in band..(band + TILE_ROWS).min(rows) {
                    let at = start + (row * w) as isize;
                    for c in c0..(c0 + TILE_COLUMNS).min(w) {
                        let i = at + c as isize;
                        if (0..n as isize).contains(&i) {
                            order.push(i as u32);
                        }
                    }
                }
            }
        }
        order
    }
}

/// `rays` sorted by direction: where at least half of every fourth group of `group` rays in
/// the given order are coherent, by the Morton code of each direction's two slopes across the
/// major axis of their sum, on one scale for both (a square cell of slopes, [`SLOPE_BITS`]
/// bits a side over the wider extent; one scale for each measured slower on shadow rays), rays
/// of a cell in the given order: a counting sort, one pass. `None` where the rays are not
/// coherent, or all parallel: rays to a light far away would need their origins sorted, which
/// this does not do.
fn by_direction(rays: &[Ray], group: usize) -> Option<Vec<u32>> {
    by_direction_with(rays, group, crate::accel::simd::available())
}

/// [`by_direction`], its per-ray passes eight rays at a time in AVX2 when `avx2` (which the
/// processor must then have), one at a time otherwise: the same numbers either way, so the
/// same order (a test compares them). One at a time, the order was about 100 instructions a
/// shadow ray, a fifth of the kitchen's with the HUG; eight at a time, 64: the kitchen's
/// shadow rays 161.3 → 149.2 M instructions and 7.4 → 6.6 ms at two threads
/// (docs/measurements.md, "The cells' boxes in smaller tasks, shadow rays ordered eight at a
/// time").
fn by_direction_with(rays: &[Ray], group: usize, avx2: bool) -> Option<Vec<u32>> {
    let sampled = rays.len().div_ceil(group).div_ceil(4);
    if 2 * rays
        .chunks(group)
        .step_by(4)
        .filter(|g| coherent(g))
        .count()
        < sampled
    {
        return None;
    }
    let major = rays
        .iter()
        .fold(Vec3::ZERO, |s, r| s + r.dir)
        .abs()
        .max_position();
    let slopes = Slopes::of(rays, major, avx2);
    let (lo, hi) = (slopes.lo, slopes.hi);
    let extent = (hi[0] - lo[0]).max(hi[1] - lo[1]);
    if !(extent > 0.0 && extent.is_finite()) {
        return None;
    }
    let cells = slopes.cells(extent, avx2);
    let mut next = vec![0u32; 1 << (2 * SLOPE_BITS)];
    for &c in &cells {
        next[c as usize] += 1;
    }
    let mut at = 0;
    for n in next.iter_mut() {
        (*n, at) = (at, at + *n);
    }
    let mut order = vec![0u32; rays.len()];
    for (i, &c) in cells.iter().enumerate() {
        order[next[c as usize] as usize] = i as u32;
        next[c as usize] += 1;
    }
    Some(order)
}

/// Each ray's two slopes across the major axis, and their least and greatest.
///
/// A slope that is not finite (a direction across the major axis) is NaN, which the extent
/// ignores and the cell's cast makes 0. `lo` and `hi` are folded with `lesser` and `greater`
/// (and `_mm256_min_ps` and `max_ps`, which return their second operand where either is
/// NaN, as those do): a NaN slope, their first operand, is left out, and `lo` and `hi` are
/// never NaN.
struct Slopes {
    across: [Vec<f32>; 2],
    lo: [f32; 2],
    hi: [f32; 2],
}

impl Slopes {
    fn of(rays: &[Ray], major: usize, avx2: bool) -> Slopes {
        #[cfg(target_arch = "x86_64")]
        if avx2 && !rays.is_empty() {
            // SAFETY: the caller found AVX2 (`by_direction_with`).
            return unsafe { Slopes::of_avx2(rays, major) };
        }
        let _ = avx2;
        // Each direction turned so that the major axis comes first (one branch, the same for
        // the whole window) rather than indexed by the axis: indexed, the loop kept its state
        // on the stack, 60 instructions a ray.
        let turn = |d: Vec3| match major {
            0 => d,
            1 => Vec3::new(d.y, d.z, d.x),
            _ => Vec3::new(d.z, d.x, d.y),
        };
        let mut across = [
            Vec::with_capacity(rays.len()),
            Vec::with_capacity(rays.len()),
        ];
        let (mut lo, mut hi) = ([f32::INFINITY; 2], [f32::NEG_INFINITY; 2]);
        for r in rays {
            let d = turn(r.dir);
            let inv = 1.0 / d.x;
            let s = [d.y * inv, d.z * inv].map(|x| if x.is_finite() { x } else { f32::NAN });
            for k in 0..2 {
                across[k].push(s[k]);
                lo[k] = lesser(s[k], lo[k]);
                hi[k] = greater(s[k], hi[k]);
            }
        }
        Slopes { across, lo, hi }
    }

    /// [`Slopes::of`] eight rays at a time ([`crate::accel::simd::ray_rows_avx2`]'s rows),
    /// each lane the same operations on the same numbers; the lanes past the last ray repeat
    /// it, which changes neither `lo` nor `hi`.
    ///
    /// # Safety
    /// The processor must support AVX2; `rays` is not empty.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn of_avx2(rays: &[Ray], major: usize) -> Slopes {
        use std::arch::x86_64::*;
        let n = rays.len();
        let padded = n.next_multiple_of(8);
        let mut across = [vec![0f32; padded], vec![0f32; padded]];
        let (infinity, nan) = (_mm256_set1_ps(f32::INFINITY), _mm256_set1_ps(f32::NAN));
        let (mut lo, mut hi) = ([infinity; 2], [_mm256_set1_ps(f32::NEG_INFINITY); 2]);
        let magnitude = _mm256_set1_ps(-0.0);
        for k in (0..n).step_by(8) {
            // SAFETY: the processor has AVX2 (this function's contract).
            let r = unsafe { crate::accel::simd::ray_rows_avx2(rays, |l| (k + l).min(n - 1)) };
            let (x, y, z) = match major {
                0 => (r[3], r[4], r[5]),
                1 => (r[4], r[5], r[3]),
                _ => (r[5], r[3], r[4]),
            };
            let inv = _mm256_div_ps(_mm256_set1_ps(1.0), x);
            for (j, d) in [y, z].into_iter().enumerate() {
                let s = _mm256_mul_ps(d, inv);
                let finite = _mm256_cmp_ps::<_CMP_LT_OQ>(_mm256_andnot_ps(magnitude, s), infinity);
                let s = _mm256_blendv_ps(nan, s, finite);
                lo[j] = _mm256_min_ps(s, lo[j]);
                hi[j] = _mm256_max_ps(s, hi[j]);
                // SAFETY: `k + 8 ≤ padded`, the vector's length.
                unsafe { _mm256_storeu_ps(across[j].as_mut_ptr().add(k), s) };
            }
        }
        for a in &mut across {
            a.truncate(n);
        }
        let lanes = |v: __m256| {
            let mut out = [0f32; 8];
            // SAFETY: eight `f32` written to an array of eight.
            unsafe { _mm256_storeu_ps(out.as_mut_ptr(), v) };
            out
        };
        let fold = |v: __m256, f: fn(f32, f32) -> f32, start: f32| {
            lanes(v).into_iter().fold(start, |a, x| f(x, a))
        };
        Slopes {
            across,
            lo: [0, 1].map(|j| fold(lo[j], lesser, f32::INFINITY)),
            hi: [0, 1].map(|j| fold(hi[j], greater, f32::NEG_INFINITY)),
        }
    }

    /// Each ray's cell of slopes, [`SLOPE_BITS`] bits a side over `extent` from `lo`, as a
    /// Morton code.
    fn cells(&self, extent: f32, avx2: bool) -> Vec<u32> {
        let top = ((1u32 << SLOPE_BITS) - 1) as f32;
        let scale = top / extent;
        #[cfg(target_arch = "x86_64")]
        if avx2 {
            // SAFETY: the caller found AVX2 (`by_direction_with`).
            return unsafe { self.cells_avx2(scale, top) };
        }
        let _ = avx2;
        let lo = self.lo;
        let cell = |x: f32, k: usize| ((x - lo[k]) * scale).clamp(0.0, top) as u32;
        self.across[0]
            .iter()
            .zip(&self.across[1])
            .map(|(&a, &b)| morton2(cell(a, 0), cell(b, 1)))
            .collect()
    }

    /// [`Slopes::cells`] eight rays at a time: `max(t, 0)` returns its second operand, 0, for
    /// a NaN `t`, where `clamp` keeps the NaN and the cast makes it 0; the lanes in `[0, top]`
    /// truncate as the cast does; the Morton code's spreading shifts of a number below 2^8.
    ///
    /// # Safety
    /// The processor must support AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn cells_avx2(&self, scale: f32, top: f32) -> Vec<u32> {
        use std::arch::x86_64::*;
        const { assert!(SLOPE_BITS <= 8) };
        let n = self.across[0].len();
        let mut out = vec![0u32; n.next_multiple_of(8)];
        let (scale, top, zero) = (
            _mm256_set1_ps(scale),
            _mm256_set1_ps(top),
            _mm256_setzero_ps(),
        );
        let spread = |a: __m256i| {
            let a = _mm256_and_si256(
                _mm256_or_si256(a, _mm256_slli_epi32::<4>(a)),
                _mm256_set1_epi32(0x0F0F_0F0F),
            );
            let a = _mm256_and_si256(
                _mm256_or_si256(a, _mm256_slli_epi32::<2>(a)),
                _mm256_set1_epi32(0x3333_3333),
            );
            _mm256_and_si256(
                _mm256_or_si256(a, _mm256_slli_epi32::<1>(a)),
                _mm256_set1_epi32(0x5555_5555),
            )
        };
        let mut k = 0;
        while k < n {
            let cell = |j: usize| {
                let x = if k + 8 <= n {
                    // SAFETY: eight `f32` read from `k < k + 8 ≤ n`, the slice's length.
                    unsafe { _mm256_loadu_ps(self.across[j].as_ptr().add(k)) }
                } else {
                    let mut x = [0f32; 8];
                    x[..n - k].copy_from_slice(&self.across[j][k..]);
                    // SAFETY: eight `f32` read from an array of eight.
                    unsafe { _mm256_loadu_ps(x.as_ptr()) }
                };
                let t = _mm256_mul_ps(_mm256_sub_ps(x, _mm256_set1_ps(self.lo[j])), scale);
                spread(_mm256_cvttps_epi32(_mm256_min_ps(
                    _mm256_max_ps(t, zero),
                    top,
                )))
            };
            let code = _mm256_or_si256(cell(0), _mm256_slli_epi32::<1>(cell(1)));
            // SAFETY: `k + 8 ≤ out.len()`.
            unsafe { _mm256_storeu_si256(out.as_mut_ptr().add(k).cast(), code) };
            k += 8;
        }
        out.truncate(n);
        out
    }
}

/// The Morton code of two 16-bit coordinates: their bits interleaved, `x`'s lowest first.
fn morton2(x: u32, y: u32) -> u32 {
    fn spread(mut a: u32) -> u32 {
        a &= 0xFFFF;
        a = (a | (a << 8)) & 0x00FF_00FF;
        a = (a | (a << 4)) & 0x0F0F_0F0F;
        a = (a | (a << 2)) & 0x3333_3333;
        (a | (a << 1)) & 0x5555_5555
    }
    spread(x) | (spread(y) << 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pinhole camera's rays, `w` × `h` pixels row by row, looking down +z.
    fn camera(w: usize, h: usize) -> Vec<Ray> {
        (0..w * h)
            .map(|k| {
                let (x, y) = ((k % w) as f32, (k / w) as f32);
                let d = Vec3::new(x / w as f32 - 0.5, 0.5 - y / h as f32, 1.0);
                Ray::new(Vec3::new(1.0, 2.0, -5.0), d, 0.0, f32::INFINITY)
            })
            .collect()
    }

    fn is_permutation(order: &[u32], n: usize) -> bool {
        let mut seen = vec![false; n];
        order.len() == n
            && order
                .iter()
                .all(|&i| (i as usize) < n && !std::mem::replace(&mut seen[i as usize], true))
    }

    #[test]
    fn a_cameras_rows_are_found_from_any_first_ray() {
        let rays = camera(37, 20);
        assert_eq!(
            Raster::find(&rays),
            Some(Raster {
                first: 0,
                width: 37
            })
        );
        // Starting mid-row, ending mid-row.
        assert_eq!(
            Raster::find(&rays[10..600]),
            Some(Raster {
                first: 27,
                width: 37
            })
        );
        // Too narrow for a tile; one row start only; a repeated ray.
        assert_eq!(Raster::find(&camera(3, 20)), None);
        assert_eq!(Raster::find(&rays[..60]), None);
        let mut twice = rays.clone();
        twice[10] = twice[9];
        assert_eq!(
            Raster::find(&twice),
            None,
            "a point repeated before the second row"
        );
        // A row of another width among them.
        let mut odd = camera(37, 10);
        odd.extend(camera(36, 10));
        assert_eq!(Raster::find(&odd), None);
    }

    #[test]
    fn tiles_hold_neighbouring_pixels_and_every_ray_once() {
        for (w, h, from, to) in [(32, 16, 0, 512), (37, 20, 10, 600), (4, 9, 0, 36)] {
            let rays = camera(w, h);
            let order = packet_order(&rays[from..to], 32).expect("a raster");
            assert!(is_permutation(&order, to - from));
            if from == 0 && w.is_multiple_of(TILE_COLUMNS) && h.is_multiple_of(TILE_ROWS) {
                // Every group of 32 is one 4 × 8 tile.
                for g in order.chunks(32) {
                    let xs = g.iter().map(|&i| i as usize % w);
                    let ys = g.iter().map(|&i| i as usize / w);
                    assert_eq!(xs.clone().max().unwrap() - xs.min().unwrap(), 3);
                    assert_eq!(ys.clone().max().unwrap() - ys.min().unwrap(), 7);
                }
            }
        }
    }

    #[test]
    fn rays_to_a_light_sort_by_direction_and_random_rays_keep_their_order() {
        // Points on a floor, in an order unrelated to where they are, to a light above: in one
        // octant and within 11° of each other, so coherent.
        let light = Vec3::new(5.0, 30.0, 4.0);
        let mut state = 12345u32;
        let mut random = || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state as f32 / u32::MAX as f32
        };
        let shadow: Vec<Ray> = (0..4096)
            .map(|_| {
                let o = Vec3::new(random() * 2.0 - 1.0, 0.0, random() * 2.0 - 1.0);
                Ray::new(o, light - o, 1e-4, 1.0)
            })
            .collect();
        let order = packet_order(&shadow, 32).expect("coherent rays sorted");
        assert!(is_permutation(&order, shadow.len()));
        // Groups of the sorted order span a small fraction of the floor.
        let spread = |g: &mut dyn Iterator<Item = Vec3>| {
            let (lo, hi) = g.fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(l, h), p| {
                (l.min(p), h.max(p))
            });
            (hi - lo).x * (hi - lo).z
        };
        let mean = |groups: &mut dyn Iterator<Item = f32>| {
            let (s, n) = groups.fold((0.0, 0), |(s, n), a| (s + a, n + 1));
            s / n as f32
        };
        let sorted = mean(
            &mut order
                .chunks(32)
                .map(|g| spread(&mut g.iter().map(|&i| shadow[i as usize].origin))),
        );
        let given = mean(
            &mut shadow
                .chunks(32)
                .map(|g| spread(&mut g.iter().map(|r| r.origin))),
        );
        assert!(sorted * 20.0 < given, "{sorted} against {given}");
        // Random directions: no order.
        let random_rays: Vec<Ray> = (0..4096)
            .map(|_| {
                let d = Vec3::new(random() - 0.5, random() - 0.5, random() - 0.5);
                Ray::new(Vec3::ZERO, d, 0.0, f32::INFINITY)
            })
            .collect();
        assert_eq!(packet_order(&random_rays, 32), None);
        // Parallel rays: nothing to sort by.
        let parallel: Vec<Ray> = shadow
            .iter()
            .map(|r| Ray::new(r.origin, Vec3::Y, 0.0, 1.0))
            .collect();
        assert_eq!(packet_order(&parallel, 32), None);
    }

    /// The slopes, their bounds, the cells and the order are the same eight rays at a time as
    /// one at a time, on directions with zero, tiny, huge and infinite coordinates (slopes that
    /// are NaN), for every major axis and every count of rays past a multiple of eight.
    #[test]
    fn slopes_and_cells_are_the_same_eight_at_a_time() {
        if !crate::accel::simd::available() {
            eprintln!("skipped: no AVX2 here, only the one-at-a-time path runs");
            return;
        }
        let mut state = 987654321u32;
        let mut random = || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state
        };
        let special = [0.0, -0.0, 1e-30, -1e30, f32::INFINITY, f32::MIN_POSITIVE];
        let mut coordinate = || match random() % 8 {
            0 => special[random() as usize % special.len()],
            _ => (random() as f32 / u32::MAX as f32 - 0.3) * 4.0,
        };
        for n in [1, 7, 8, 9, 61, 1000] {
            let rays: Vec<Ray> = (0..n)
                .map(|_| {
                    let d = Vec3::new(coordinate(), coordinate(), coordinate());
                    Ray::new(Vec3::ZERO, d, 0.0, 1.0)
                })
                .collect();
            for major in 0..3 {
                let (one, eight) = (
                    Slopes::of(&rays, major, false),
                    Slopes::of(&rays, major, true),
                );
                for k in 0..2 {
                    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                    assert_eq!(
                        bits(&one.across[k]),
                        bits(&eight.across[k]),
                        "n {n}, axis {major}"
                    );
                    assert_eq!(one.lo[k], eight.lo[k]);
                    assert_eq!(one.hi[k], eight.hi[k]);
                }
                for extent in [1e-3, 0.7, 3.0, 1e20] {
                    assert_eq!(one.cells(extent, false), eight.cells(extent, true));
                }
            }
        }
        // Whole orders, on shadow rays to a light from a floor.
        let light = Vec3::new(5.0, 30.0, 4.0);
        let shadow: Vec<Ray> = (0..5000)
            .map(|i| {
                let at = |p: usize| (i * p % 1000) as f32 / 500.0 - 1.0;
                let o = Vec3::new(at(7919), 0.0, at(104_729));
                Ray::new(o, light - o, 1e-4, 1.0)
            })
            .collect();
        let order = by_direction_with(&shadow, 32, true);
        assert!(order.is_some());
        assert_eq!(order, by_direction_with(&shadow, 32, false));
    }

    #[test]
    fn windows_are_whole_bands_of_a_raster_from_the_first_ray() {
        assert_eq!(window(&camera(1024, 64)), 8192);
        assert_eq!(window(&camera(1000, 64)), 8000);
        assert_eq!(window(&camera(3000, 30)), 24000);
        assert_eq!(window(&camera(1024, 64)[5..]), WINDOW);
        assert_eq!(morton2(0b11, 0b01), 0b0111);
    }
}
