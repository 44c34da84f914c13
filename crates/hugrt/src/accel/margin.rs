//! The margin every structure widens boxes by, defined once.
//!
//! A primitive's box (or a grid cell's, for the exact overlap test) is widened by 64 ulps of
//! the scene's magnitude, `M·2⁻¹⁷`, with `M` the largest of the scene box's coordinates and
//! extent: a box's entry distance then lies before any hit inside it despite the rounding of
//! both, so that no box or cell is skipped for lying beyond a hit at the same distance, and
//! a primitive touching a cell's face is binned in that cell. The slab test's own rounding
//! (Ize's `1 + 2γ₃` on far distances, "Robust BVH Ray Traversal", JCGT 2013) is covered by it.
//! `tests/agree.rs` (coplanar, axis-aligned triangles) fails without it; the proof for the
//! grids is in [`super::hierarchy`]'s module documentation.

use crate::geometry::Aabb;

/// The margin's fraction of the scene's magnitude.
pub(crate) const MARGIN: f32 = 1.0 / (1 << 17) as f32;

/// The margin for a scene whose finite boxes span `bounds`; 0 for an empty scene.
pub(crate) fn margin_for(bounds: &Aabb) -> f32 {
    if bounds.is_empty() {
        0.0
    } else {
        bounds.magnitude().max(bounds.extent().max_element()) * MARGIN
    }
}
