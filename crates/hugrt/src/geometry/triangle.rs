use super::{PreparedRay, Ray};
use glam::{DVec3, Vec3};

/// Watertight, two-sided ray/triangle test of Woop, Benthin and Wald (JCGT 2013), §3:
/// the vertices are translated to the ray origin and sheared so that the ray becomes the +z
/// axis; the 2D edge functions are then exact in sign, falling back to double precision when
/// one of them rounds to zero, so a ray through a shared edge or vertex hits at least one of
/// the triangles that share it.
///
/// Where the ray crosses is [`crossing_t`]'s, in double precision: a departure from the
/// paper, whose single-precision `t` is wrong on far slivers (see there).
///
/// Returns the hit parameter `t` in `[tmin, tmax]`. A degenerate triangle (zero area seen along
/// the ray) never reports a hit.
#[inline]
pub fn intersect_triangle(r: &PreparedRay, v: &[Vec3; 3], tmin: f32, tmax: f32) -> Option<f32> {
    let [rx, ry] = r.rows;
    let o = r.ray.origin;
    let a = v[0] - o;
    let b = v[1] - o;
    let c = v[2] - o;
    let ax = rx.dot(a);
    let ay = ry.dot(a);
    let bx = rx.dot(b);
    let by = ry.dot(b);
    let cx = rx.dot(c);
    let cy = ry.dot(c);
    let mut u = cx * by - cy * bx;
    let mut vv = ax * cy - ay * cx;
    let mut w = bx * ay - by * ax;
    if u == 0.0 || vv == 0.0 || w == 0.0 {
        let (ax, ay, bx, by, cx, cy) = (
            ax as f64, ay as f64, bx as f64, by as f64, cx as f64, cy as f64,
        );
        u = (cx * by - cy * bx) as f32;
        vv = (ax * cy - ay * cx) as f32;
        w = (bx * ay - by * ax) as f32;
    }
    if (u < 0.0 || vv < 0.0 || w < 0.0) && (u > 0.0 || vv > 0.0 || w > 0.0) {
        return None;
    }
    let det = u + vv + w;
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    crossing_t(v, &r.ray, tmin, tmax)
}

/// Where a ray that the edge functions found crossing triangle `v` meets its plane, if that
/// is in `[tmin, tmax]`: `n·(v0 − o) / n·d` for the normal `n = (v1 − v0) × (v2 − v0)`, in
/// double precision, rounded once to single.
///
/// Woop et al. take `t` from the same sheared coordinates as the edge functions,
/// `(u·az + v·bz + w·cz) / det` in single precision. On a long sliver far from the origin (a
/// vertex at 10^4 beside two near 1, the ray starting at 10^3) the sum cancels: fuzzing
/// found it giving `t > 0` for a crossing behind the origin, and `t` ten times too small, at
/// points outside the triangle's box, which brute force reports and no structure reaches.
/// Here the differences of single-precision vertices are exact in double precision and
/// their products nearly so, so `t` keeps its sign and its digits unless the ray runs
/// within rounding of the plane.
///
/// Every kernel (the scalar test, the bvh's blocks, the grids' eight lanes) calls this one
/// function for the lanes it finds crossed, so a hit has the same bits whichever finds it.
///
/// A crossing whose `t` rounds past `f32::MAX` (a tiny direction far from the plane) is no
/// hit, even when `tmax` is infinite: `t = ∞` names no point on the ray, and the structures,
/// whose cells and nodes end at finite `t`, could never reach it.
#[inline]
pub fn crossing_t(v: &[Vec3; 3], ray: &Ray, tmin: f32, tmax: f32) -> Option<f32> {
    let [a, b, c] = v.map(|x| x.as_dvec3());
    let n = (b - a).cross(c - a);
    let t = (n.dot(a - ray.origin.as_dvec3()) / n.dot(ray.dir.as_dvec3())) as f32;
    (t >= tmin && t <= tmax.min(f32::MAX)).then_some(t)
}

/// Barycentric coordinates `(b0, b1, b2)` of point `p` with respect to triangle `v`, computed in
/// double precision from sub-triangle areas; used for shading only, after the hit is known.
pub fn barycentric(v: &[Vec3; 3], p: Vec3) -> Vec3 {
    let [a, b, c] = v.map(|x| x.as_dvec3());
    let p = p.as_dvec3();
    let n = (b - a).cross(c - a);
    let nn = n.length_squared();
    if nn == 0.0 {
        return Vec3::new(1.0, 0.0, 0.0);
    }
    let area = |x: DVec3, y: DVec3, z: DVec3| (y - x).cross(z - x).dot(n) / nn;
    let b0 = area(p, b, c);
    let b1 = area(a, p, c);
    Vec3::new(b0 as f32, b1 as f32, (1.0 - b0 - b1) as f32)
}
