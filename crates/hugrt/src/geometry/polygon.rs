use glam::{DVec2, DVec3, Vec3};

/// Newell's normal of a polygon (not normalised): robust for non-convex and slightly
/// non-planar outlines. The NFF notes say the first three vertices fix the normal; for a convex
/// polygon that is the same direction, and for a concave one whose first corner is reflex it is
/// the true front side, so hugrt uses Newell's.
pub fn newell_normal(pts: &[Vec3]) -> Vec3 {
    let mut n = DVec3::ZERO;
    for (i, a) in pts.iter().enumerate() {
        let (a, b) = (a.as_dvec3(), pts[(i + 1) % pts.len()].as_dvec3());
        n += DVec3::new(
            (a.y - b.y) * (a.z + b.z),
            (a.z - b.z) * (a.x + b.x),
            (a.x - b.x) * (a.y + b.y),
        );
    }
    n.as_vec3()
}

/// Splits a planar polygon, convex or not, into triangles by ear clipping, returning triples
/// of indices into `pts` wound like the polygon (so each triangle's normal points to the
/// polygon's front). Consecutive duplicate vertices are dropped. If no ear can be found (a
/// self-intersecting outline) the rest is fanned, so every polygon yields `n - 2` triangles or
/// fewer and none is lost silently.
pub fn triangulate_polygon(pts: &[Vec3]) -> Vec<[usize; 3]> {
    let mut idx: Vec<usize> = Vec::with_capacity(pts.len());
    for i in 0..pts.len() {
        if idx.last().is_none_or(|&j| pts[j] != pts[i]) {
            idx.push(i);
        }
    }
    while idx.len() > 1 && pts[idx[0]] == pts[*idx.last().unwrap()] {
        idx.pop();
    }
    if idx.len() < 3 {
        return Vec::new();
    }
    if idx.len() == 3 {
        return vec![[idx[0], idx[1], idx[2]]];
    }
    let n = newell_normal(pts).as_dvec3();
    // Project onto the plane that drops the dominant normal axis, keeping orientation.
    let a = n.abs();
    let drop = if a.x >= a.y && a.x >= a.z {
        0
    } else if a.y >= a.z {
        1
    } else {
        2
    };
    let (u, v) = [(1, 2), (2, 0), (0, 1)][drop];
    let flip = n[drop] < 0.0;
    let p2: Vec<DVec2> = pts
        .iter()
        .map(|p| {
            let p = p.as_dvec3();
            if flip {
                DVec2::new(p[v], p[u])
            } else {
                DVec2::new(p[u], p[v])
            }
        })
        .collect();
    let cross = |o: DVec2, a: DVec2, b: DVec2| (a - o).perp_dot(b - o);

    let mut tris = Vec::with_capacity(idx.len() - 2);
    let mut guard = 0;
    while idx.len() > 3 {
        let m = idx.len();
        let mut clipped = false;
        for i in 0..m {
            let (ia, ib, ic) = (idx[(i + m - 1) % m], idx[i], idx[(i + 1) % m]);
            let (pa, pb, pc) = (p2[ia], p2[ib], p2[ic]);
            if cross(pa, pb, pc) <= 0.0 {
                continue; // reflex or flat corner
            }
            let blocked = idx.iter().any(|&j| {
                if j == ia || j == ib || j == ic || p2[j] == pa || p2[j] == pb || p2[j] == pc {
                    return false;
                }
                let q = p2[j];
                cross(pa, pb, q) >= 0.0 && cross(pb, pc, q) >= 0.0 && cross(pc, pa, q) >= 0.0
            });
            if !blocked {
                tris.push([ia, ib, ic]);
                idx.remove(i);
                clipped = true;
                break;
            }
        }
        if !clipped {
            guard += 1;
            // No ear: drop a flat corner if there is one, else fan what remains.
            if let Some(i) = (0..idx.len()).find(|&i| {
                let m = idx.len();
                cross(p2[idx[(i + m - 1) % m]], p2[idx[i]], p2[idx[(i + 1) % m]]) == 0.0
            }) && guard < pts.len()
            {
                idx.remove(i);
                continue;
            }
            for k in 1..idx.len() - 1 {
                tris.push([idx[0], idx[k], idx[k + 1]]);
            }
            return tris;
        }
    }
    tris.push([idx[0], idx[1], idx[2]]);
    tris
}

#[cfg(test)]
mod tests {
    use super::*;

    fn area(pts: &[Vec3], tris: &[[usize; 3]]) -> f32 {
        tris.iter()
            .map(|t| (pts[t[1]] - pts[t[0]]).cross(pts[t[2]] - pts[t[0]]).z * 0.5)
            .sum()
    }

    #[test]
    fn concave_l_shape_keeps_its_area_and_winding() {
        let pts: Vec<Vec3> = [(0., 0.), (2., 0.), (2., 1.), (1., 1.), (1., 2.), (0., 2.)]
            .iter()
            .map(|&(x, y)| Vec3::new(x, y, 0.0))
            .collect();
        let tris = triangulate_polygon(&pts);
        assert_eq!(tris.len(), 4);
        assert!((area(&pts, &tris) - 3.0).abs() < 1e-6);
        for t in &tris {
            let n = (pts[t[1]] - pts[t[0]]).cross(pts[t[2]] - pts[t[0]]);
            assert!(n.z > 0.0, "triangle {t:?} flipped");
        }
    }

    #[test]
    fn clockwise_comb_outline() {
        // A comb (gear-like) outline with a collinear vertex, given clockwise seen from +z.
        let mut xy = vec![(0., 0.), (10., 0.), (10., 1.)];
        for i in (0..5).rev() {
            let x = 2.0 * i as f32;
            xy.extend([(x + 1., 1.), (x + 1., 3.), (x, 3.), (x, 1.)]);
        }
        let mut pts: Vec<Vec3> = xy.iter().map(|&(x, y)| Vec3::new(x, y, 0.0)).collect();
        pts.reverse();
        let tris = triangulate_polygon(&pts);
        // 10x1 base + 5 teeth of 1x2, every triangle wound clockwise like the outline.
        assert!(
            (area(&pts, &tris) + 20.0).abs() < 1e-4,
            "{}",
            area(&pts, &tris)
        );
        for t in &tris {
            let n = (pts[t[1]] - pts[t[0]]).cross(pts[t[2]] - pts[t[0]]);
            assert!(n.z <= 0.0, "triangle {t:?} flipped");
        }
    }

    #[test]
    fn degenerate_polygons_give_no_triangles() {
        let p = Vec3::ONE;
        assert!(triangulate_polygon(&[p, p, p]).is_empty());
        assert!(triangulate_polygon(&[p, Vec3::ZERO]).is_empty());
    }
}
