use super::PreparedRay;
use glam::{DVec3, Vec3};

/// Watertight, two-sided ray/triangle test of Woop, Benthin and Wald (JCGT 2013), §3:
/// the vertices are translated to the ray origin and sheared so that the ray becomes the +z
/// axis; the 2D edge functions are then exact in sign, falling back to double precision when
/// one of them rounds to zero, so a ray through a shared edge or vertex hits at least one of
/// the triangles that share it.
///
/// Returns the hit parameter `t` in `[tmin, tmax]`. A degenerate triangle (zero area seen along
/// the ray) never reports a hit.
#[inline]
pub fn intersect_triangle(r: &PreparedRay, v: &[Vec3; 3], tmin: f32, tmax: f32) -> Option<f32> {
    let [rx, ry, rz] = r.rows;
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
    let az = rz.dot(a);
    let bz = rz.dot(b);
    let cz = rz.dot(c);
    let t_scaled = u * az + vv * bz + w * cz;
    // Two-sided: compare in the sign of `det` without dividing first.
    let (t_scaled, det_abs) = if det < 0.0 {
        (-t_scaled, -det)
    } else {
        (t_scaled, det)
    };
    if t_scaled < tmin * det_abs || t_scaled > tmax * det_abs {
        return None;
    }
    let t = t_scaled / det_abs;
    (t >= tmin && t <= tmax).then_some(t)
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
