//! STL meshes, ASCII and binary. Written by hand rather than with a crate: STL is a list of
//! triangles, and the crate there is (`stl_io`) gives its errors without a line, tells binary
//! from ASCII by a leading `solid` (which many binary files' headers also start with), and
//! reads a binary file's declared triangle count without holding it to the file's size.
//!
//! A file is binary when its size is exactly 84 + 50 × the count in bytes 80..84, ASCII when
//! it starts with `solid` and holds no zero byte, and otherwise an error naming both readings. Triangle `i` is the
//! `i`-th facet in file order (an ASCII facet of more vertices is fanned in order); the normals
//! the file gives are not read (hugrt's come from the winding).

use super::{Scene, SceneError, finite};
use crate::geometry::Vec3;

pub fn parse(path: &str, data: &[u8]) -> Result<Scene, SceneError> {
    if let Some(count) = binary_count(data) {
        return binary(path, data, count);
    }
    let text = data.trim_ascii_start();
    let solid = text.len() >= 5 && text[..5].eq_ignore_ascii_case(b"solid");
    // A binary file's records hold zero bytes (a float's, the attribute count); text has none.
    if solid && !data.contains(&0) {
        return ascii(path, data);
    }
    let reason = if data.len() >= 84 {
        let count = u32::from_le_bytes(data[80..84].try_into().unwrap()) as u64;
        format!(
            "STL: not ASCII (no 'solid' at the start, or zero bytes in it) and not binary (its header declares {count} triangles, {} bytes, but the file is {} bytes)",
            84 + 50 * count,
            data.len()
        )
    } else {
        format!(
            "STL: not ASCII (no 'solid' at the start) and, at {} bytes, shorter than a binary header (84 bytes)",
            data.len()
        )
    };
    Err(SceneError::invalid(path, reason))
}

/// The triangle count of a binary file whose size matches it exactly.
fn binary_count(data: &[u8]) -> Option<usize> {
    let count = u32::from_le_bytes(data.get(80..84)?.try_into().ok()?) as usize;
    (data.len() as u64 == 84 + 50 * count as u64).then_some(count)
}

fn binary(path: &str, data: &[u8], count: usize) -> Result<Scene, SceneError> {
    let mut triangles = Vec::with_capacity(count);
    for (i, record) in data[84..].chunks_exact(50).enumerate() {
        let f = |k: usize| f32::from_le_bytes(record[4 * k..4 * k + 4].try_into().unwrap());
        let mut t = [Vec3::ZERO; 3];
        for (v, p) in t.iter_mut().enumerate() {
            let c = [f(3 + 3 * v), f(4 + 3 * v), f(5 + 3 * v)].map(finite);
            *p = match c {
                [Ok(x), Ok(y), Ok(z)] => Vec3::new(x, y, z),
                _ => {
                    return Err(SceneError::invalid(
                        path,
                        format!("STL: triangle {i}: vertex {v}: coordinate is NaN or infinite"),
                    ));
                }
            };
        }
        triangles.push(t);
    }
    Ok(Scene::from_triangles(triangles))
}

fn ascii(path: &str, data: &[u8]) -> Result<Scene, SceneError> {
    let mut triangles = Vec::new();
    let mut polygon: Option<Vec<Vec3>> = None;
    for (n, line) in data.split(|&b| b == b'\n').enumerate() {
        let line = String::from_utf8_lossy(line);
        let err = |reason: String| SceneError::parse(path, n + 1, format!("STL: {reason}"));
        let mut words = line.split_ascii_whitespace();
        let Some(word) = words.next() else {
            continue;
        };
        match word.to_ascii_lowercase().as_str() {
            "outer" => {
                if polygon.is_some() {
                    return Err(err("'outer loop' inside a loop".into()));
                }
                polygon = Some(Vec::new());
            }
            "vertex" => {
                let Some(p) = polygon.as_mut() else {
                    return Err(err("'vertex' outside 'outer loop'".into()));
                };
                let c: Vec<&str> = words.collect();
                if c.len() != 3 {
                    return Err(err(format!("'vertex' with {} numbers, need 3", c.len())));
                }
                let mut xyz = [0f32; 3];
                for (k, w) in c.iter().enumerate() {
                    let x: f32 = w
                        .parse()
                        .map_err(|_| err(format!("'{w}' is not a number")))?;
                    xyz[k] = finite(x).map_err(err)?;
                }
                p.push(Vec3::from_array(xyz));
            }
            "endloop" => {
                let Some(p) = polygon.take() else {
                    return Err(err("'endloop' without 'outer loop'".into()));
                };
                if p.len() < 3 {
                    return Err(err(format!("a facet of {} vertices, need 3", p.len())));
                }
                for k in 1..p.len() - 1 {
                    triangles.push([p[0], p[k], p[k + 1]]);
                }
            }
            "solid" | "facet" | "endfacet" | "endsolid" => {}
            other => return Err(err(format!("unknown keyword '{other}'"))),
        }
    }
    if polygon.is_some() {
        return Err(SceneError::invalid(
            path,
            "STL: the file ends inside a loop",
        ));
    }
    Ok(Scene::from_triangles(triangles))
}
