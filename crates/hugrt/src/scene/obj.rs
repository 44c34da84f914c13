//! Wavefront OBJ meshes, read with `tobj`. Polygons are fanned in order by tobj, so triangle
//! `i` is the `i`-th triangle in file order. Materials (`.mtl`) are not read: the mesh gets the
//! default material. tobj's errors carry no line number; hugrt finds the offending line itself.

use super::{Scene, SceneError, finite};
use crate::geometry::Vec3;

pub fn parse(path: &str, data: &[u8]) -> Result<Scene, SceneError> {
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let mut reader = std::io::BufReader::new(data);
    let (models, _materials) =
        tobj::load_obj_buf(&mut reader, &opts, |_| Err(tobj::LoadError::OpenFileFailed))
            .map_err(|e| locate(path, data, e))?;
    let mut triangles = Vec::new();
    let mut vertex_base = 0usize;
    for m in &models {
        let pos = &m.mesh.positions;
        let points: Vec<Vec3> = pos
            .chunks_exact(3)
            .enumerate()
            .map(
                |(i, c)| match c.iter().map(|&x| finite(x)).collect::<Result<Vec<_>, _>>() {
                    Ok(v) => Ok(Vec3::new(v[0], v[1], v[2])),
                    Err(reason) => Err(vertex_error(path, data, vertex_base + i, &reason)),
                },
            )
            .collect::<Result<_, _>>()?;
        for t in m.mesh.indices.chunks_exact(3) {
            let mut v = [Vec3::ZERO; 3];
            for (k, &i) in t.iter().enumerate() {
                v[k] = *points.get(i as usize).ok_or_else(|| {
                    SceneError::invalid(
                        path,
                        format!("OBJ: vertex index {} out of range", i as u64 + 1),
                    )
                })?;
            }
            triangles.push(v);
        }
        vertex_base += points.len();
    }
    Ok(Scene::from_triangles(triangles))
}

fn vertex_error(path: &str, data: &[u8], vertex: usize, reason: &str) -> SceneError {
    let text = String::from_utf8_lossy(data);
    let line = text
        .lines()
        .enumerate()
        .filter(|(_, l)| l.trim_start().starts_with("v "))
        .nth(vertex)
        .map_or(0, |(i, _)| i + 1);
    SceneError::parse(path, line, format!("vertex {}: {reason}", vertex + 1))
}

/// Turns a tobj error into one with the first line that shows the problem.
fn locate(path: &str, data: &[u8], e: tobj::LoadError) -> SceneError {
    use tobj::LoadError as E;
    let text = String::from_utf8_lossy(data);
    let numbers_ok = |rest: &str, min: usize| {
        let w: Vec<&str> = rest.split_whitespace().collect();
        w.len() >= min && w.iter().all(|x| x.parse::<f32>().is_ok())
    };
    let mut vertices = 0i64;
    for (i, l) in text.lines().enumerate() {
        let l = l.trim();
        let (kw, rest) = l.split_once(char::is_whitespace).unwrap_or((l, ""));
        let bad = match (kw, &e) {
            ("v", E::PositionParseError) => !numbers_ok(rest, 3),
            ("vn", E::NormalParseError) => !numbers_ok(rest, 3),
            ("vt", E::TexcoordParseError) => !numbers_ok(rest, 1),
            ("f", E::FaceParseError | E::InvalidPolygon | E::FaceVertexOutOfBounds) => {
                let refs: Vec<&str> = rest.split_whitespace().collect();
                refs.len() < 3
                    || refs
                        .iter()
                        .any(|r| match r.split('/').next().unwrap_or("").parse::<i64>() {
                            Ok(k) => k == 0 || k > vertices || -k > vertices,
                            Err(_) => true,
                        })
            }
            _ => false,
        };
        if kw == "v" {
            vertices += 1;
        }
        if bad {
            return SceneError::parse(path, i + 1, format!("OBJ: {e}"));
        }
    }
    SceneError::invalid(path, format!("OBJ: {e}"))
}
