//! A fractal terrain: a square heightfield of shared vertices, the scale test's mesh.
//!
//! Every height is a function of its grid position and the seed (fractional Brownian motion
//! over hashed value noise, no random state), so a terrain of 10^9 triangles can be written to
//! a PLY file row by row without ever being held ([`Terrain::write_ply`]), and read back as the
//! same mesh that [`Terrain::mesh`] builds in memory. Its triangles all have about the same
//! size, so that a structure's build time per triangle can be compared across sizes: the
//! count of references per triangle stays the same as the cells shrink (the clustered room's
//! does not, see `docs/measurements.md`).

use super::{Camera, Light, MAX_PRIMITIVES, Mesh, Scene};
use crate::geometry::{Aabb, Vec3};
use rayon::prelude::*;
use std::io::{self, Write};

/// A terrain of `side × side` squares, two triangles each, over the unit square in x and z.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Terrain {
    side: u32,
    seed: u64,
}

/// Relief: the height range is about this share of the terrain's width.
const RELIEF: f32 = 0.25;

fn splitmix(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9e37_79b9_7f4a_7c15);
    x = (x ^ (x >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    x ^ (x >> 31)
}

impl Terrain {
    /// The terrain of at least `triangles` triangles (and at most 2^32-2), from `seed`.
    pub fn with_triangles(triangles: u64, seed: u64) -> Terrain {
        let triangles = triangles.clamp(2, MAX_PRIMITIVES as u64);
        let mut side = ((triangles as f64 / 2.0).sqrt().ceil() as u64).max(1);
        while 2 * side * side > MAX_PRIMITIVES as u64 {
            side -= 1;
        }
        Terrain {
            side: side as u32,
            seed,
        }
    }

    pub fn triangle_count(&self) -> usize {
        2 * (self.side as usize).pow(2)
    }

    pub fn vertex_count(&self) -> usize {
        (self.side as usize + 1).pow(2)
    }

    /// Value noise on the lattice of `period` vertices: a hashed value per lattice point,
    /// interpolated with a smoothstep, in [-1, 1].
    fn noise(&self, octave: u32, period: u32, i: u32, j: u32) -> f32 {
        let at = |a: u32, b: u32| {
            let h =
                splitmix(self.seed ^ splitmix((octave as u64) << 48 | (a as u64) << 24 | b as u64));
            (h >> 40) as f32 / (1u64 << 23) as f32 - 1.0
        };
        let (a, b) = (i / period, j / period);
        let s = |r: u32| {
            let f = r as f32 / period as f32;
            f * f * (3.0 - 2.0 * f)
        };
        let (u, v) = (s(i % period), s(j % period));
        let top = at(a, b) * (1.0 - u) + at(a + 1, b) * u;
        let bottom = at(a, b + 1) * (1.0 - u) + at(a + 1, b + 1) * u;
        top * (1.0 - v) + bottom * v
    }

    /// The vertex at grid position `(i, j)`, `0 ≤ i, j ≤ side`.
    pub fn vertex(&self, i: u32, j: u32) -> Vec3 {
        let mut height = 0.0;
        let mut amplitude = RELIEF / 2.0;
        let mut period = (self.side / 2).max(1);
        let mut octave = 0;
        loop {
            height += amplitude * self.noise(octave, period, i, j);
            if period <= 2 {
                break;
            }
            period /= 2;
            amplitude *= 0.5;
            octave += 1;
        }
        let n = self.side as f32;
        Vec3::new(i as f32 / n, height, j as f32 / n)
    }

    /// Square `(i, j)`'s two triangles, as indices of vertices numbered row by row.
    fn square(&self, i: u32, j: u32) -> [[u32; 3]; 2] {
        let row = self.side + 1;
        let (a, b) = (j * row + i, j * row + i + 1);
        let (c, d) = (a + row, b + row);
        // Alternate diagonals, so that no direction of the grid is favoured.
        if (i + j).is_multiple_of(2) {
            [[a, c, b], [b, c, d]]
        } else {
            [[a, c, d], [a, d, b]]
        }
    }

    /// The terrain as a mesh, vertices row by row (z), triangles square by square.
    pub fn mesh(&self) -> Mesh {
        let row = self.side + 1;
        let vertices = (0..row * row)
            .into_par_iter()
            .map(|k| self.vertex(k % row, k / row))
            .collect();
        let triangles = (0..self.side * self.side)
            .into_par_iter()
            .flat_map_iter(|k| self.square(k % self.side, k / self.side))
            .collect();
        Mesh::new(vertices, triangles).expect("indices in range, heights finite")
    }

    /// The terrain as a scene: the mesh, seen from above one corner, lit from two sides.
    pub fn scene(&self) -> Scene {
        let mut scene = Scene::from_mesh(self.mesh());
        let b = Aabb::new(Vec3::new(0.0, -RELIEF, 0.0), Vec3::new(1.0, RELIEF, 1.0));
        scene.camera = Camera {
            from: Vec3::new(-0.2, 0.6, -0.2),
            at: b.center(),
            fov_deg: 55.0,
            ..Camera::framing(&b)
        };
        scene.lights = vec![
            Light {
                position: Vec3::new(-1.0, 3.0, 0.5),
                color: Vec3::splat(0.8),
            },
            Light {
                position: Vec3::new(2.0, 2.0, -1.0),
                color: Vec3::splat(0.4),
            },
        ];
        scene
    }

    /// Writes the terrain as binary little-endian PLY, as [`write_ply`](super::write::write_ply)
    /// would write [`Terrain::mesh`], a row at a time: memory stays a few rows whatever the size.
    pub fn write_ply(&self, out: &mut impl Write) -> io::Result<()> {
        let (row, side) = (self.side + 1, self.side);
        // Each row's heights computed in parallel as the writer asks for it.
        let points = (0..row).flat_map(|j| {
            (0..row)
                .into_par_iter()
                .map(|i| self.vertex(i, j))
                .collect::<Vec<_>>()
        });
        let faces = (0..side).flat_map(|j| (0..side).flat_map(move |i| self.square(i, j)));
        super::write::write_ply_mesh(
            out,
            &format!("hugrt terrain, {side} squares a side, seed {}", self.seed),
            (self.vertex_count(), points),
            (self.triangle_count(), faces),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_streamed_file_is_the_mesh() {
        let t = Terrain::with_triangles(1000, 3);
        assert!(t.triangle_count() >= 1000 && t.triangle_count() < 1200);
        let mut bytes = Vec::new();
        t.write_ply(&mut bytes).unwrap();
        let back = Scene::from_bytes("t.ply", &bytes).unwrap();
        assert_eq!(back.mesh, t.mesh());
        assert_ne!(
            t.mesh(),
            Terrain::with_triangles(1000, 4).mesh(),
            "the seed counts"
        );
    }

    #[test]
    fn heights_vary_and_stay_in_the_relief() {
        let m = Terrain::with_triangles(20_000, 1).mesh();
        let ys: Vec<f32> = m.vertices().iter().map(|v| v.y).collect();
        let (lo, hi) = ys
            .iter()
            .fold((f32::MAX, f32::MIN), |(a, b), &y| (a.min(y), b.max(y)));
        assert!(
            lo >= -RELIEF && hi <= RELIEF && hi - lo > RELIEF / 4.0,
            "{lo} {hi}"
        );
    }
}
