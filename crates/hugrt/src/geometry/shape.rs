use super::{Aabb, Cone, PreparedRay, Sphere, barycentric, greater, intersect_triangle, lesser};
use glam::{DVec3, Vec3};

/// One primitive of a scene. Polygons are stored as the triangles of their triangulation;
/// patches are triangles whose per-vertex normals live in the scene's normal table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    Triangle([Vec3; 3]),
    /// A triangle with interpolated shading normals, at `normals` in the scene's patch table.
    Patch {
        v: [Vec3; 3],
        normals: u32,
    },
    Sphere(Sphere),
    Cone(Cone),
}

/// What shading needs at a hit point.
#[derive(Clone, Copy, Debug)]
pub struct SurfacePoint {
    pub point: Vec3,
    /// Unit normal of the surface's front (outside) side.
    pub geometric_normal: Vec3,
    /// Unit shading normal, on the same side as the geometric normal.
    pub shading_normal: Vec3,
}

/// Coordinates smaller than this in magnitude (2^-100, about 7.9·10^-31) are read as zero by
/// [`Shape::with_tiny_coordinates_zeroed`].
pub const TINY_COORDINATE: f32 = 7.888_609e-31;

/// `p` with every coordinate below [`TINY_COORDINATE`] in magnitude made zero (see
/// [`Shape::with_tiny_coordinates_zeroed`]).
pub fn tiny_coordinates_zeroed(p: Vec3) -> Vec3 {
    Vec3::select(p.abs().cmplt(Vec3::splat(TINY_COORDINATE)), Vec3::ZERO, p)
}

impl Shape {
    /// The shape with every coordinate of its points below [`TINY_COORDINATE`] in magnitude
    /// made zero (radii and normals are kept), as the loaders take them.
    ///
    /// Two coordinates each zero or at least 2^-100 in magnitude differ by zero or by at least 2^-123,
    /// a normal float, so every vertex-minus-vertex and vertex-minus-origin difference of such
    /// a scene keeps single precision's 24 bits. Below that, differences are subnormal and
    /// lose bits one by one: the glTF fuzz target found scenes of triangles 10^-45 thick whose
    /// sheared edge functions, all rounding, reported crossings far outside the scene's box
    /// (brute force "hit" them; every structure's box test rightly did not).
    pub fn with_tiny_coordinates_zeroed(&self) -> Shape {
        let zeroed = tiny_coordinates_zeroed;
        match *self {
            Shape::Triangle(v) => Shape::Triangle(v.map(zeroed)),
            Shape::Patch { v, normals } => Shape::Patch {
                v: v.map(zeroed),
                normals,
            },
            Shape::Sphere(s) => Shape::Sphere(Sphere {
                center: zeroed(s.center),
                ..s
            }),
            Shape::Cone(c) => Shape::Cone(Cone {
                base: zeroed(c.base),
                apex: zeroed(c.apex),
                ..c
            }),
        }
    }

    pub fn bounds(&self) -> Aabb {
        match self {
            Shape::Triangle(v) | Shape::Patch { v, .. } => Aabb::from_points(v),
            Shape::Sphere(s) => s.bounds(),
            Shape::Cone(c) => c.bounds(),
        }
    }

    #[inline]
    pub fn intersect(&self, r: &PreparedRay, tmin: f32, tmax: f32) -> Option<f32> {
        match self {
            Shape::Triangle(v) | Shape::Patch { v, .. } => intersect_triangle(r, v, tmin, tmax),
            Shape::Sphere(s) => s.intersect(r, tmin, tmax),
            Shape::Cone(c) => c.intersect(r, tmin, tmax),
        }
    }

    /// Exact "does the primitive touch this box" test for the grids' optional pruning
    /// (EG95 §1.2.1): separating axes for triangles (Akenine-Möller 2001), the box–sphere
    /// distance for spheres, the bounding box for cones. Conservative: the box is widened by a
    /// relative epsilon so rounding never drops a true overlap.
    pub fn overlaps_box(&self, b: &Aabb) -> bool {
        match self {
            Shape::Triangle(v) | Shape::Patch { v, .. } => TriangleBoxTest::new(v).overlaps(b),
            Shape::Sphere(s) => {
                let b = widened(b);
                let q = s.center.clamp(b.min, b.max);
                q.distance_squared(s.center) <= s.radius * s.radius
            }
            Shape::Cone(c) => c.bounds().overlaps(&widened(b)),
        }
    }

    /// Hit point and normals for shading, recomputed once per hit from `t`.
    pub fn surface(&self, ray: &PreparedRay, t: f32, patch_normals: &[[Vec3; 3]]) -> SurfacePoint {
        let p = ray.ray.at(t);
        let (ng, ns) = match self {
            Shape::Triangle(v) => {
                let n = (v[1] - v[0]).cross(v[2] - v[0]).normalize_or_zero();
                (n, n)
            }
            Shape::Patch { v, normals } => {
                let ng = (v[1] - v[0]).cross(v[2] - v[0]).normalize_or_zero();
                let b = barycentric(v, p);
                let vn = patch_normals[*normals as usize];
                let mut ns = (vn[0] * b.x + vn[1] * b.y + vn[2] * b.z).normalize_or_zero();
                if ns == Vec3::ZERO {
                    ns = ng;
                } else if ns.dot(ng) < 0.0 {
                    // Vertex normals given against the winding: the winding decides the front.
                    ns = -ns;
                }
                (ng, ns)
            }
            Shape::Sphere(s) => {
                let n = ((p - s.center) / s.radius).normalize_or_zero();
                (n, n)
            }
            Shape::Cone(c) => {
                let mut n = c.normal(p);
                if c.base_radius < 0.0 && c.apex_radius < 0.0 {
                    n = -n;
                }
                (n, n)
            }
        };
        SurfacePoint {
            point: p,
            geometric_normal: ng,
            shading_normal: ns,
        }
    }
}

/// The separating-axis test of a triangle against boxes (Akenine-Möller 2001), prepared once
/// for the many cells of a grid a triangle's box holds: the thirteen axes (the plane's
/// normal, the nine products of an edge and a box axis, the box axes) and the triangle's
/// interval on each, so that a box costs a projection of its centre and its half extent per
/// axis (the grids' pruning test per cell was 39% of the HUG's build of the four kitchens
/// when each cell recomputed the axes).
///
/// In double precision: the axes are products of two edges and the projections products of
/// three coordinates, which overflow single precision for a triangle 10^13 across (the stl
/// fuzz target's scene of a triangle 3·10^19 wide: its infinite projections pruned it from
/// the very cells the HUG's rays met it in).
pub struct TriangleBoxTest {
    axes: [DVec3; 13],
    lo: [f64; 13],
    hi: [f64; 13],
}

impl TriangleBoxTest {
    pub fn new(v: &[Vec3; 3]) -> TriangleBoxTest {
        let p = v.map(|x| x.as_dvec3());
        let e = [p[1] - p[0], p[2] - p[1], p[0] - p[2]];
        let mut axes = [DVec3::ZERO; 13];
        let mut lo = [0.0; 13];
        let mut hi = [0.0; 13];
        let mut interval = |k: usize, axis: DVec3, q: [f64; 3]| {
            axes[k] = axis;
            (lo[k], hi[k]) = (
                lesser(lesser(q[0], q[1]), q[2]),
                greater(greater(q[0], q[1]), q[2]),
            );
        };
        // The plane first: among the cells of a large triangle's box it separates most.
        let normal = e[0].cross(e[1]);
        interval(0, normal, p.map(|x| x.dot(normal)));
        // Each edge crossed with the box axes, `X × e = (0, -e.z, e.y)` and so on, projected
        // without the zero component (which only adds a zero to the sum): the general cross
        // and dot products' multiplications by zero made this set-up 710 instructions a
        // triangle on the kitchen, 366 so.
        for (k, ei) in e.iter().enumerate() {
            let k = 1 + 3 * k;
            interval(
                k,
                DVec3::new(0.0, -ei.z, ei.y),
                p.map(|x| x.y * -ei.z + x.z * ei.y),
            );
            interval(
                k + 1,
                DVec3::new(ei.z, 0.0, -ei.x),
                p.map(|x| x.x * ei.z + x.z * -ei.x),
            );
            interval(
                k + 2,
                DVec3::new(-ei.y, ei.x, 0.0),
                p.map(|x| x.x * -ei.y + x.y * ei.x),
            );
        }
        for (j, axis) in [DVec3::X, DVec3::Y, DVec3::Z].into_iter().enumerate() {
            interval(10 + j, axis, p.map(|x| x[j]));
        }
        TriangleBoxTest { axes, lo, hi }
    }

    /// Whether the triangle meets `b` widened by [`Shape::overlaps_box`]'s relative epsilon
    /// (conservative: rounding never drops a true overlap). A zero axis (two edges parallel,
    /// or an edge along a box axis) separates nothing and is skipped.
    #[inline]
    pub fn overlaps(&self, b: &Aabb) -> bool {
        let b = widened(b);
        let c = b.center().as_dvec3();
        let h = b.extent().as_dvec3() * 0.5;
        for k in 0..13 {
            let a = self.axes[k];
            if a == DVec3::ZERO {
                continue;
            }
            let centre = c.dot(a);
            let r = h.dot(a.abs());
            if self.lo[k] - centre > r || self.hi[k] - centre < -r {
                return false;
            }
        }
        true
    }
}

/// `b` widened by a relative epsilon, so that rounding in the overlap tests never drops a
/// true overlap.
fn widened(b: &Aabb) -> Aabb {
    b.expand(1e-5 * (b.extent().max_element() + b.magnitude() * 1e-2))
}

impl TriangleBoxTest {
    /// The test against the cells of a uniform grid: cell `c` spans `min + c·size` to
    /// `min + (c + 1)·size`, widened by `margin`, and `magnitude` bounds the largest
    /// coordinate of the grid's box so widened. The cells all have one size, so each axis's
    /// interval is widened once by their radius, and along a row of cells the centres'
    /// projections are linear in the cell's index: a row's cells that pass all thirteen axes
    /// are one interval, found at once ([`TriangleCellTest::cells`]).
    ///
    /// It keeps every cell that [`TriangleBoxTest::overlaps`] keeps of the single-precision
    /// cell boxes (`min + c·size` rounded, widened by `margin`): the epsilon is that of the
    /// grid's magnitude, at least each cell's, plus four units in the last place of it, more
    /// than the rounding of those boxes' corners and of their centre and extent, and far more
    /// than the double-precision rounding of the rows' intervals.
    pub fn on_cells(&self, min: Vec3, size: Vec3, margin: f32, magnitude: f32) -> TriangleCellTest {
        let (size, margin, magnitude) = (size.as_dvec3(), margin as f64, magnitude as f64);
        let epsilon = 1e-5 * (size.max_element() + 2.0 * margin + magnitude * 1e-2)
            + 4.0 * f32::EPSILON as f64 * magnitude;
        let half = size * 0.5 + DVec3::splat(margin + epsilon);
        let first = min.as_dvec3() + size * 0.5;
        let mut t = TriangleCellTest {
            lo: [f64::NEG_INFINITY; 13],
            hi: [f64::INFINITY; 13],
            first: [0.0; 13],
            step: [[0.0; 13]; 3],
        };
        for k in 0..13 {
            let a = self.axes[k];
            // A zero axis separates nothing: its interval is the whole line.
            if a != DVec3::ZERO {
                let r = half.dot(a.abs());
                t.lo[k] = self.lo[k] - r;
                t.hi[k] = self.hi[k] + r;
                t.first[k] = first.dot(a);
                for j in 0..3 {
                    t.step[j][k] = size[j] * a[j];
                }
            }
        }
        t
    }
}

/// [`TriangleBoxTest::on_cells`]: a triangle against the cells of one grid.
pub struct TriangleCellTest {
    lo: [f64; 13],
    hi: [f64; 13],
    /// The projection of cell (0, 0, 0)'s centre on each axis.
    first: [f64; 13],
    /// What one cell's step along each grid axis adds to it.
    step: [[f64; 13]; 3],
}

impl TriangleCellTest {
    /// Calls `f` with every cell from `lo` to `hi` (inclusive) that the triangle meets, row
    /// by row along the axis of most cells: on each axis a row's centres project to
    /// `base + x·step`, so the cells passing it are those with `x` in one interval, and the
    /// row's cells are the intersection of the thirteen (the four kitchens' HUG built in
    /// 37.5 ms with each cell's box tested alone, 33.5 with each cell's projections stepped,
    /// 30.3 row by row).
    pub fn cells(&self, lo: [u32; 3], hi: [u32; 3], mut f: impl FnMut([u32; 3])) {
        let a = (0..3).max_by_key(|&a| hi[a] - lo[a]).unwrap_or(0);
        let (b, c) = ((a + 1) % 3, (a + 2) % 3);
        // The inverse of each axis's step along the rows (0 for none), for this row axis only.
        let inverse: [f64; 13] = std::array::from_fn(|k| {
            let step = self.step[a][k];
            if step != 0.0 { 1.0 / step } else { 0.0 }
        });
        for v in lo[c]..=hi[c] {
            for u in lo[b]..=hi[b] {
                let (mut from, mut to) = (lo[a] as f64, hi[a] as f64);
                // By index rather than over `inverse`'s items: the loop reads six rows by
                // one index, and the indexed form took about 10% fewer of the kitchen's binning
                // instructions.
                #[allow(clippy::needless_range_loop)]
                for k in 0..13 {
                    let inverse = inverse[k];
                    let base =
                        self.first[k] + u as f64 * self.step[b][k] + v as f64 * self.step[c][k];
                    if inverse == 0.0 {
                        if base < self.lo[k] || base > self.hi[k] {
                            to = f64::NEG_INFINITY;
                        }
                        continue;
                    }
                    // Finite (the triangle's coordinates and the grid's are): no NaN for
                    // `f64::max`'s care.
                    let (x0, x1) = ((self.lo[k] - base) * inverse, (self.hi[k] - base) * inverse);
                    from = greater(from, lesser(x0, x1));
                    to = lesser(to, greater(x0, x1));
                }
                if from <= to {
                    // `from` and `to` lie in `lo[a]..=hi[a]`, not negative: truncation is their
                    // floor. `f64::ceil` and `floor` are calls to software routines without
                    // SSE4.1 (the baseline); with them and `f64::max`, the rows took 4.4 M more
                    // of the kitchen's 34.6 M binning instructions.
                    let (first, last) = (from as u32, to as u32);
                    let first = first + ((first as f64) < from) as u32;
                    for x in first..=last {
                        let mut cell = [0; 3];
                        (cell[a], cell[b], cell[c]) = (x, u, v);
                        f(cell);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Ray;

    #[test]
    fn tiny_coordinates_are_zeroed_and_others_kept() {
        assert_eq!(TINY_COORDINATE, 2f32.powi(-100));
        let t = Shape::Triangle([
            Vec3::new(1e-45, -3e-40, TINY_COORDINATE),
            Vec3::new(-TINY_COORDINATE * 0.99, 1.0, -2e-31),
            Vec3::new(f32::MIN_POSITIVE, 1e-30, 0.0),
        ]);
        assert_eq!(
            t.with_tiny_coordinates_zeroed(),
            Shape::Triangle([
                Vec3::new(0.0, 0.0, TINY_COORDINATE),
                Vec3::new(0.0, 1.0, 0.0),
                Vec3::new(0.0, 1e-30, 0.0),
            ])
        );
        let s = Shape::Sphere(Sphere {
            center: Vec3::new(1e-35, 2.0, 3.0),
            radius: 1e-35,
        });
        assert_eq!(
            s.with_tiny_coordinates_zeroed(),
            Shape::Sphere(Sphere {
                center: Vec3::new(0.0, 2.0, 3.0),
                radius: 1e-35,
            })
        );
    }

    fn prep(o: Vec3, d: Vec3) -> PreparedRay {
        PreparedRay::new(&Ray::new(o, d, 0.0, f32::INFINITY))
    }

    #[test]
    fn triangle_hit_both_sides_and_degenerate_never() {
        let tri = Shape::Triangle([Vec3::ZERO, Vec3::X, Vec3::Y]);
        let t = tri.intersect(&prep(Vec3::new(0.2, 0.2, 1.0), -Vec3::Z), 0.0, 10.0);
        assert_eq!(t, Some(1.0));
        let t = tri.intersect(&prep(Vec3::new(0.2, 0.2, -2.0), Vec3::Z * 2.0), 0.0, 10.0);
        assert_eq!(t, Some(1.0));
        let deg = Shape::Triangle([Vec3::ZERO, Vec3::X, Vec3::X * 2.0]);
        assert_eq!(
            deg.intersect(&prep(Vec3::new(0.5, 0.0, 1.0), -Vec3::Z), 0.0, 9.0),
            None
        );
        let point = Shape::Triangle([Vec3::ONE; 3]);
        assert_eq!(
            point.intersect(&prep(Vec3::new(1., 1., 0.), Vec3::Z), 0.0, 9.0),
            None
        );
    }

    #[test]
    fn shared_edge_is_watertight() {
        // Two triangles sharing the diagonal of the unit square; rays exactly on the diagonal.
        let a = Shape::Triangle([Vec3::ZERO, Vec3::X, Vec3::ONE.with_z(0.0)]);
        let b = Shape::Triangle([Vec3::ZERO, Vec3::ONE.with_z(0.0), Vec3::Y]);
        for i in 0..=100 {
            let s = i as f32 / 100.0;
            let r = prep(Vec3::new(s, s, 1.0), Vec3::new(0.0, 0.0, -1.0));
            let hit = a.intersect(&r, 0.0, 9.0).or(b.intersect(&r, 0.0, 9.0));
            assert!(
                hit.is_some(),
                "ray through the shared edge at {s} slipped through"
            );
        }
    }

    #[test]
    fn sphere_and_cylinder() {
        let s = Shape::Sphere(Sphere {
            center: Vec3::ZERO,
            radius: 1.0,
        });
        let t = s
            .intersect(&prep(Vec3::new(0., 0., 5.), -Vec3::Z), 0.0, 100.0)
            .unwrap();
        assert!((t - 4.0).abs() < 1e-6);
        let inside = s.intersect(&prep(Vec3::ZERO, Vec3::X), 0.0, 100.0).unwrap();
        assert!((inside - 1.0).abs() < 1e-6);
        let c = Shape::Cone(Cone {
            base: Vec3::ZERO,
            base_radius: 1.0,
            apex: Vec3::Z * 2.0,
            apex_radius: 1.0,
        });
        let t = c
            .intersect(&prep(Vec3::new(5., 0., 1.), -Vec3::X), 0.0, 100.0)
            .unwrap();
        assert!((t - 4.0).abs() < 1e-5);
        // Open cylinder: a ray along the axis passes through.
        assert_eq!(
            c.intersect(&prep(Vec3::new(0., 0., -5.), Vec3::Z), 0.0, 100.0),
            None
        );
        // Cone to a point: radius 0.5 at mid height.
        let k = Shape::Cone(Cone {
            base: Vec3::ZERO,
            base_radius: 1.0,
            apex: Vec3::Z * 2.0,
            apex_radius: 0.0,
        });
        let t = k
            .intersect(&prep(Vec3::new(5., 0., 1.), -Vec3::X), 0.0, 100.0)
            .unwrap();
        assert!((t - 4.5).abs() < 1e-5);
        let n = k
            .surface(&prep(Vec3::new(5., 0., 1.), -Vec3::X), t, &[])
            .geometric_normal;
        assert!(n.x > 0.0 && n.z > 0.0);
        let bb = k.bounds();
        assert!((bb.min - Vec3::new(-1., -1., 0.)).length() < 1e-6);
    }

    proptest::proptest! {
        /// A grid's prepared test keeps every cell the per-box test keeps, and only cells the
        /// per-box test keeps once they are widened by a thousandth of a cell: on lattice
        /// coordinates (faces and edges on cell planes) and far from the origin.
        #[test]
        fn the_cells_test_keeps_what_the_box_test_keeps(
            v in proptest::array::uniform3(proptest::array::uniform3(-8i32..=8)),
            jitter in -1.0f32..1.0,
            offset in proptest::prop_oneof![proptest::strategy::Just(0.0f32), -1e6f32..1e6, -1e12f32..1e12],
            size in proptest::array::uniform3(0.25f32..3.0),
            margin in proptest::prop_oneof![proptest::strategy::Just(0.0f32), 1e-6f32..1e-2],
        ) {
            let v = v.map(|p| Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32 + jitter * 0.5) + Vec3::splat(offset));
            let (min, size) = (Vec3::splat(offset - 9.0), Vec3::from_array(size));
            let res = ((Vec3::splat(18.0) / size).ceil()).as_uvec3();
            let max = min + size * res.as_vec3();
            let magnitude = Aabb::new(min, max).expand(margin).magnitude();
            let test = TriangleBoxTest::new(&v);
            let mut kept = std::collections::HashSet::new();
            test.on_cells(min, size, margin, magnitude).cells(
                [0; 3],
                (res - 1).to_array(),
                |c| assert!(kept.insert(c), "cell {c:?} twice"),
            );
            for z in 0..res.z {
                for y in 0..res.y {
                    for x in 0..res.x {
                        let lo = min + Vec3::new(x as f32, y as f32, z as f32) * size;
                        let cell = Aabb::new(lo, lo + size).expand(margin);
                        let kept = kept.contains(&[x, y, z]);
                        proptest::prop_assert!(kept || !test.overlaps(&cell), "cell {x} {y} {z}");
                        let loose = cell.expand(1e-3 * size.max_element() + 1e-6 * magnitude);
                        proptest::prop_assert!(!kept || test.overlaps(&loose), "cell {x} {y} {z}");
                    }
                }
            }
        }
    }

    #[test]
    fn triangle_box_overlap() {
        let b = Aabb::new(Vec3::ZERO, Vec3::ONE);
        let inside = [Vec3::splat(0.2), Vec3::splat(0.3), Vec3::new(0.2, 0.5, 0.3)];
        assert!(TriangleBoxTest::new(&inside).overlaps(&b));
        // Big triangle whose plane cuts the box corner.
        let cut = [
            Vec3::new(-5., 0.5, 0.5),
            Vec3::new(5., 0.5, 0.5),
            Vec3::new(0., 5., 0.5),
        ];
        assert!(TriangleBoxTest::new(&cut).overlaps(&b));
        // Bounding boxes overlap, but the triangle passes beside the box.
        let beside = [
            Vec3::new(3., 0., 0.5),
            Vec3::new(0., 3., 0.5),
            Vec3::new(3., 3., 0.5),
        ];
        assert!(!TriangleBoxTest::new(&beside).overlaps(&b));
    }
}
