//! Rays, boxes and the primitives of the SPD scenes, with their intersection tests.
//!
//! Spatial structures never look inside a primitive: they see its bounding box and call
//! "intersect primitive i" (see [`crate::accel::Primitives`]), so every structure works for
//! every primitive kind defined here.

mod aabb;
mod cone;
mod polygon;
mod ray;
mod shape;
mod sphere;
mod triangle;

pub use aabb::Aabb;
pub use cone::Cone;
pub use polygon::{newell_normal, triangulate_polygon};
pub(crate) use ray::shear_rows;
pub use ray::{PreparedRay, Ray};
pub use shape::{
    Shape, SurfacePoint, TINY_COORDINATE, TriangleBoxTest, TriangleCellTest,
    tiny_coordinates_zeroed,
};
pub use sphere::Sphere;
pub use triangle::{barycentric, crossing_t, intersect_triangle};

pub use glam::Vec3;

/// The lesser of two numbers, without `f32::min`'s (or `f64::min`'s) care for NaN, which
/// costs a comparison and a blend more: for values that are never NaN (a NaN gives the
/// second operand).
#[inline(always)]
pub(crate) fn lesser<T: PartialOrd>(a: T, b: T) -> T {
    if a < b { a } else { b }
}

/// The greater of two numbers, as [`lesser`].
#[inline(always)]
pub(crate) fn greater<T: PartialOrd>(a: T, b: T) -> T {
    if a > b { a } else { b }
}
