//! One grid of the hierarchy as the build and the walk see it: its box, resolution and where
//! its cells start among all grids' cells.

use super::NO_FRAME;
use crate::accel::{Frame, simd};
use crate::geometry::{Aabb, Vec3};
use glam::Vec4;

/// `1 + 2·gamma(3)` of Ize ("Robust BVH Ray Traversal", JCGT 2013): scaling the far slab
/// distance by it makes the slab test conservative under rounding.
const ROBUST_FAR: f32 = 1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// The interval `[t0, t1]` of the ray `o + t·d` (`inv = 1/d`) in the box `(min, max)`, within
/// `[tmin, tmax]`, its far end widened by [`ROBUST_FAR`]; empty when `t0 > t1`. A grid's box
/// ([`GridHeader::interval`]) and the box of what a cell holds (`bounds`) are met by it.
#[inline(always)]
pub(super) fn slab(min: Vec3, max: Vec3, o: Vec3, inv: Vec3, tmin: f32, tmax: f32) -> (f32, f32) {
    let ta = (min - o) * inv;
    let tb = (max - o) * inv;
    (
        tmin.max(ta.min(tb).max_element()),
        tmax.min(ta.max(tb).min_element() * ROBUST_FAR),
    )
}

#[derive(Clone, Copy, Debug)]
pub(super) struct GridHeader {
    /// The grid's box, in its own frame.
    pub(super) min: Vec3,
    pub(super) max: Vec3,
    pub(super) size: Vec3,
    pub(super) inv_size: Vec3,
    pub(super) res: [u32; 3],
    /// Index of cell (0, 0, 0) among all grids' cells.
    pub(super) first_cell: u32,
    pub(super) frame: u32,
    pub(super) depth: u32,
    /// [`GridPlan::level`].
    pub(super) level: u32,
    pub(super) objects: u32,
}

impl GridHeader {
    pub(super) fn cells(&self) -> usize {
        self.res.iter().map(|&r| r as usize).product()
    }

    /// The interval `[t0, t1]` of the ray `o + t·d` (`inv = 1/d`) in the grid's box, within
    /// `[tmin, tmax]`: the slab test, its far end widened by [`ROBUST_FAR`]; empty when
    /// `t0 > t1`. `min` and `max` return the non-NaN operand, so a 0·inf slab is ignored. The
    /// single walk and the packet walk both enter a grid by it.
    #[inline(always)]
    pub(super) fn interval(&self, o: Vec3, inv: Vec3, tmin: f32, tmax: f32) -> (f32, f32) {
        slab(self.min, self.max, o, inv, tmin, tmax)
    }

    #[inline(always)]
    pub(super) fn coord(&self, a: usize, x: f32) -> u32 {
        // Truncation is the floor for the non-negative values that survive the clamp (and NaN
        // becomes 0); `floor` itself is a library call without SSE4.1.
        let c = (x - self.min[a]) * self.inv_size[a];
        (c.max(0.0) as u32).min(self.res[a] - 1)
    }

    /// The cells `b` meets, from its low corner's to its high corner's: each coordinate as
    /// [`GridHeader::coord`] makes it, the three axes converted at once
    /// ([`simd::truncate_lanes`]).
    #[inline(always)]
    pub(super) fn cell_range(&self, b: &Aabb) -> ([u32; 3], [u32; 3]) {
        // The grid's lanes made once for both corners, each corner's subtraction and product
        // in one register (the same operations as one coordinate at a time).
        let (min, inv) = (
            Vec4::from((self.min, 0.0)),
            Vec4::from((self.inv_size, 0.0)),
        );
        let cells = |p: Vec3| -> [u32; 3] {
            let c = ((Vec4::from((p, 0.0)) - min) * inv).max(Vec4::ZERO);
            let c = simd::truncate_lanes(c);
            std::array::from_fn(|a| (c[a] as u32).min(self.res[a] - 1))
        };
        (cells(b.min), cells(b.max))
    }

    pub(super) fn cell_box(&self, c: [u32; 3]) -> Aabb {
        let lo = self.min + Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32) * self.size;
        Aabb::new(lo, lo + self.size)
    }

    pub(super) fn set_resolution(&mut self, res: [u32; 3]) {
        self.res = res;
        let r = Vec3::new(res[0] as f32, res[1] as f32, res[2] as f32);
        let e = self.max - self.min;
        self.size = e / r;
        self.inv_size = r / e;
    }

    /// Moves the cell planes off the box's own round fractions. Models with coordinates on
    /// round values (SPD tetra's dyadic vertices, axis-aligned architecture) put box faces
    /// exactly on the planes of a grid cut in simple fractions of their box, and the margin
    /// then references such an object from every cell whose plane it touches: 7.3 references
    /// per triangle on SPD tetra at density 1, where 3 suffice. Along every axis of at least
    /// 4 cells the grid gets one more cell and starts `1/φ²` (0.382) of a cell before the
    /// box, far from every simple fraction; its cell size stays the same.
    pub(super) fn shift_planes(&mut self) {
        const SHIFT: f32 = 0.381_966;
        let (mut res, size) = (self.res, self.size);
        for a in 0..3 {
            if res[a] >= 4 {
                self.min[a] -= SHIFT * size[a];
                self.max[a] += (1.0 - SHIFT) * size[a];
                res[a] += 1;
            }
        }
        self.set_resolution(res);
    }

    pub(super) fn world_box(&self, frames: &[Frame]) -> Aabb {
        let b = Aabb::new(self.min, self.max);
        if self.frame == NO_FRAME {
            b
        } else {
            frames[self.frame as usize].world_box(&b)
        }
    }
}
