//! Indexed triangle meshes: each vertex stored once, each triangle three `u32` indices.
//!
//! A scan or a CAD export shares every vertex among about six triangles, so a mesh of `T`
//! triangles has about `T / 2` vertices: 12 bytes of indices and about 6 of vertices per
//! triangle, where a [`Shape`](crate::geometry::Shape) per triangle takes 44.
//! [`Primitives`](crate::accel::Primitives) hands the structures a mesh triangle as its three
//! vertices, which they copy (the bvh's leaf blocks, [`crate::accel::PrimStore`] by default),
//! or as its indices into the shared vertices, which they read through (`store=index`).

use crate::geometry::{Vec3, tiny_coordinates_zeroed as zeroed};
use rustc_hash::FxHashMap;
use std::sync::Arc;

/// A triangle mesh: shared vertices and triangles as index triples into them. Every index is
/// in range, so that a triangle can be looked up without a check that could fail; every
/// coordinate is finite in a mesh from [`Mesh::new`] (which checks), while [`Mesh::welded`]
/// keeps a soup's as they are.
///
/// The vertices are shared ([`Arc`]) with the structures that test rays against the mesh's
/// triangles by index instead of copying them (`store=index`): cloning a mesh or building
/// such a structure copies no vertex.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    vertices: Arc<Vec<Vec3>>,
    triangles: Vec<[u32; 3]>,
}

/// Why index triples and vertices do not make a mesh.
#[derive(Clone, Debug, thiserror::Error, PartialEq)]
pub enum MeshError {
    #[error("triangle {triangle}: vertex index {index} out of range ({vertices} vertices)")]
    IndexOutOfRange {
        triangle: usize,
        index: u32,
        vertices: usize,
    },
    #[error("vertex {0}: coordinate is NaN or infinite")]
    NotFinite(usize),
    #[error("{0} triangles: at most 2^32-2 primitives")]
    TooManyTriangles(usize),
}

/// Most primitives a scene numbers with `u32` (`u32::MAX` means "no primitive" in hits files).
pub const MAX_PRIMITIVES: usize = u32::MAX as usize - 1;

impl Mesh {
    /// A mesh of `triangles` over `vertices`, checked: indices in range, coordinates finite,
    /// at most [`MAX_PRIMITIVES`] triangles. Coordinates below
    /// [`TINY_COORDINATE`](crate::geometry::TINY_COORDINATE) are made zero, as the loaders
    /// take every shape's.
    pub fn new(mut vertices: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Result<Mesh, MeshError> {
        if triangles.len() > MAX_PRIMITIVES {
            return Err(MeshError::TooManyTriangles(triangles.len()));
        }
        if let Some(i) = vertices.iter().position(|v| !v.is_finite()) {
            return Err(MeshError::NotFinite(i));
        }
        let n = vertices.len();
        if let Some((t, &index)) = triangles
            .iter()
            .enumerate()
            .find_map(|(t, tri)| tri.iter().find(|&&i| i as usize >= n).map(|i| (t, i)))
        {
            return Err(MeshError::IndexOutOfRange {
                triangle: t,
                index,
                vertices: n,
            });
        }
        for v in &mut vertices {
            *v = zeroed(*v);
        }
        Ok(Mesh {
            vertices: Arc::new(vertices),
            triangles,
        })
    }

    /// The mesh of a triangle soup, equal vertices shared (equal bit for bit, so no
    /// coordinate changes): a file that repeats each vertex per triangle, as STL does, keeps
    /// each once. Non-finite coordinates are kept as they are (such triangles never hit).
    ///
    /// # Panics
    /// With more than [`MAX_PRIMITIVES`] triangles.
    pub fn welded(soup: &[[Vec3; 3]]) -> Mesh {
        assert!(soup.len() <= MAX_PRIMITIVES, "at most 2^32-2 triangles");
        let (vertices, number) = distinct(soup.iter().flatten().map(|&v| zeroed(v)));
        Mesh {
            vertices: Arc::new(vertices),
            triangles: number.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect(),
        }
    }

    /// The same triangles over each distinct vertex once (equal bit for bit), when the mesh
    /// has more vertices than triangles: a file that writes three vertices per triangle (a
    /// soup, as the SPD meshes and STL's are) then takes about 18 bytes a triangle instead of
    /// 48. A mesh that already shares its vertices is left as it is.
    pub fn shared(mut self) -> Mesh {
        if self.vertices.len() <= self.triangles.len() {
            return self;
        }
        let (vertices, number) = distinct(self.vertices.iter().copied());
        for t in &mut self.triangles {
            *t = t.map(|k| number[k as usize]);
        }
        self.vertices = Arc::new(vertices);
        self
    }

    pub fn vertices(&self) -> &[Vec3] {
        &self.vertices
    }

    /// The vertices, shared: what a structure that tests the triangles by index keeps.
    pub fn shared_vertices(&self) -> Arc<Vec<Vec3>> {
        Arc::clone(&self.vertices)
    }

    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    pub fn len(&self) -> usize {
        self.triangles.len()
    }

    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    /// The vertices of triangle `i`.
    #[inline]
    pub fn triangle(&self, i: usize) -> [Vec3; 3] {
        self.triangles[i].map(|k| self.vertices[k as usize])
    }

    /// Bytes held by the vertices and indices.
    pub fn memory_bytes(&self) -> usize {
        self.vertices.capacity() * 12 + self.triangles.capacity() * 12
    }
}

/// The distinct points of `points` (equal bit for bit), in order of first appearance, and the
/// number each point of `points` has among them.
fn distinct(points: impl Iterator<Item = Vec3>) -> (Vec<Vec3>, Vec<u32>) {
    let mut index: FxHashMap<[u32; 3], u32> = FxHashMap::default();
    let mut vertices = Vec::new();
    let number = points
        .map(|v| {
            *index
                .entry(v.to_array().map(f32::to_bits))
                .or_insert_with(|| {
                    vertices.push(v);
                    vertices.len() as u32 - 1
                })
        })
        .collect();
    vertices.shrink_to_fit();
    (vertices, number)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn welding_shares_equal_vertices_and_keeps_the_triangles() {
        let (a, b, c, d) = (Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ONE);
        let soup = [[a, b, c], [c, b, d], [a, b, c]];
        let m = Mesh::welded(&soup);
        assert_eq!(m.vertices().len(), 4);
        assert_eq!(m.len(), 3);
        for (i, t) in soup.iter().enumerate() {
            assert_eq!(&m.triangle(i), t);
        }
        // Tiny coordinates are zero before welding (-0.0 among them), as the loaders take them.
        let m = Mesh::welded(&[[Vec3::new(-0.0, 1e-35, 0.0), b, c], [a, b, c]]);
        assert_eq!(m.vertices().len(), 3);
        assert_eq!(m.triangle(0)[0].to_array().map(f32::to_bits), [0; 3]);
    }

    #[test]
    fn sharing_keeps_every_triangle() {
        let (a, b, c, d) = (Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ONE);
        let soup = vec![a, b, c, c, b, d, d, a, b];
        let m = Mesh::new(soup.clone(), vec![[0, 1, 2], [3, 4, 5], [6, 7, 8]]).unwrap();
        let shared = m.clone().shared();
        assert_eq!(shared.vertices().len(), 4);
        for i in 0..3 {
            assert_eq!(shared.triangle(i), m.triangle(i));
        }
        // Vertices already shared: nothing to do.
        let two = Mesh::new(
            vec![a, b, c, d],
            vec![[0, 1, 2], [2, 1, 3], [0, 1, 3], [0, 2, 3]],
        )
        .unwrap();
        assert_eq!(two.clone().shared(), two);
    }

    #[test]
    fn new_checks_indices_and_coordinates() {
        let v = vec![Vec3::ZERO, Vec3::X, Vec3::Y];
        assert!(Mesh::new(v.clone(), vec![[0, 1, 2]]).is_ok());
        assert_eq!(
            Mesh::new(v.clone(), vec![[0, 1, 2], [0, 3, 1]]),
            Err(MeshError::IndexOutOfRange {
                triangle: 1,
                index: 3,
                vertices: 3
            })
        );
        let mut bad = v.clone();
        bad[2].y = f32::NAN;
        assert_eq!(Mesh::new(bad, vec![]), Err(MeshError::NotFinite(2)));
        let tiny = Mesh::new(vec![Vec3::splat(1e-35), Vec3::X, Vec3::Y], vec![[0, 1, 2]]);
        assert_eq!(tiny.unwrap().vertices()[0], Vec3::ZERO);
    }
}
