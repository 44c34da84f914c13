//! hugrt: a ray-shooting engine and a laboratory for spatial data structures, built around the
//! Hierarchy of Uniform Grids of Cazals, Drettakis and Puech (Eurographics 1995).
//!
//! * [`geometry`]: rays, boxes, primitives and their intersection tests.
//! * [`scene`]: the scene model, the NFF/PLY/OBJ/STL/glTF readers and procedural scenes.
//! * [`accel`]: the spatial structures, all behind [`accel::Accel`], chosen by spec strings.
//! * [`render`]: the Whitted renderer of the SPD test procedure.
//! * [`stats`]: scene statistics (SCG97 Fig. 4).
//! * [`reproduce`]: the papers' experiments regenerated, published beside measured.
//! * [`batch`]: batch ray queries in the `hugrt trace` file format.
//! * [`world`]: instanced scenes built for ray shooting, each model's structure once.
//! * [`Error`]: what the whole jobs (a rendering, statistics, a written scene) fail with.
//! * [`mod@bench`]: structures measured on the same work: times, Havran's septet and triplet,
//!   counters, and the same-answers check.

pub mod accel;
pub mod batch;
pub mod bench;
mod error;
#[doc(hidden)]
pub mod fuzzing;
pub mod geometry;
pub mod render;
pub mod reproduce;
pub mod scene;
pub mod stats;
pub mod world;

pub use error::Error;
