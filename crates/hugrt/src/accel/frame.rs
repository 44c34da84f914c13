//! An orthonormal frame: the turned boxes of SCG97 §7.2's oriented clusters, which the
//! primitive store bounds in (`PrimStore::local_bounds`) and the grid hierarchy lays cells out
//! in.

use crate::geometry::{Aabb, Vec3};

/// An orthonormal frame: `local = axes · (p − origin)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Frame {
    pub origin: Vec3,
    pub axes: [Vec3; 3],
}

impl Frame {
    #[inline(always)]
    pub fn dir(&self, d: Vec3) -> Vec3 {
        Vec3::new(
            self.axes[0].dot(d),
            self.axes[1].dot(d),
            self.axes[2].dot(d),
        )
    }

    #[inline(always)]
    pub fn point(&self, p: Vec3) -> Vec3 {
        self.dir(p - self.origin)
    }

    fn world_point(&self, l: Vec3) -> Vec3 {
        self.origin + self.axes[0] * l.x + self.axes[1] * l.y + self.axes[2] * l.z
    }

    fn corners(b: &Aabb) -> [Vec3; 8] {
        std::array::from_fn(|k| {
            Vec3::new(
                if k & 1 == 0 { b.min.x } else { b.max.x },
                if k & 2 == 0 { b.min.y } else { b.max.y },
                if k & 4 == 0 { b.min.z } else { b.max.z },
            )
        })
    }

    /// Box in this frame around a world-space box.
    pub fn local_box(&self, b: &Aabb) -> Aabb {
        if b.is_empty() {
            return *b;
        }
        Frame::corners(b)
            .iter()
            .fold(Aabb::EMPTY, |a, &c| a.grow(self.point(c)))
    }

    /// World-space box around a box of this frame.
    pub fn world_box(&self, b: &Aabb) -> Aabb {
        if b.is_empty() {
            return *b;
        }
        Frame::corners(b)
            .iter()
            .fold(Aabb::EMPTY, |a, &c| a.grow(self.world_point(c)))
    }
}
