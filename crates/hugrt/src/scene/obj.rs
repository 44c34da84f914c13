//! Wavefront OBJ meshes, read with `tobj`. Polygons are fanned in order by tobj, so triangle
//! `i` is the `i`-th triangle in file order. tobj's errors carry no line number; hugrt finds the
//! offending line itself.
//!
//! Materials come from the `.mtl` files the OBJ names (`mtllib`, beside it), mapped onto NFF's
//! model: `Kd` is the colour (with `Kd = 1`), the largest component of `Ks` the specular share
//! `Ks` (which in NFF also reflects), `Ns` the shine, `1 − d` (or `Tr`) the transmittance and `Ni`
//! the index of refraction. Faces before any `usemtl`, under an unknown name or under a bare
//! `usemtl`, and every face when the `.mtl` cannot be read, get the default grey.
//!
//! Files written by other tools are taken as they are: a `usemtl` without a name (which tobj
//! refuses) means the default material, and bytes that are not UTF-8 (a Latin-1 name) are
//! replaced in names, where they do not matter, rather than refusing the file.

use super::{MAX_PRIMITIVES, Material, Mesh, Scene, SceneError, finite};
use crate::geometry::Vec3;
use std::borrow::Cow;
use std::path::Path;

pub fn parse(path: &str, data: &[u8]) -> Result<Scene, SceneError> {
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let text = readable(data);
    let data = &text[..];
    let dir = Path::new(path)
        .parent()
        .unwrap_or(Path::new("."))
        .to_path_buf();
    let mut reader = std::io::BufReader::new(data);
    let (models, materials) = tobj::load_obj_buf(&mut reader, &opts, |mtl| {
        let file =
            std::fs::File::open(dir.join(mtl)).map_err(|_| tobj::LoadError::OpenFileFailed)?;
        tobj::load_mtl_buf(&mut std::io::BufReader::new(file))
    })
    .map_err(|e| locate(path, data, e))?;
    let materials: Vec<Material> = materials
        .map(|m| m.iter().map(material).collect())
        .unwrap_or_default();
    let mut vertices: Vec<Vec3> = Vec::new();
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    let mut runs: Vec<(u32, u32)> = Vec::new();
    for m in &models {
        let id = m
            .mesh
            .material_id
            .filter(|&i| i < materials.len())
            .map_or(0, |i| i as u32 + 1);
        if runs.last().is_none_or(|r| r.1 != id) {
            runs.push((triangles.len() as u32, id));
        }
        let base = vertices.len();
        for (i, c) in m.mesh.positions.chunks_exact(3).enumerate() {
            match [c[0], c[1], c[2]].map(finite) {
                [Ok(x), Ok(y), Ok(z)] => vertices.push(Vec3::new(x, y, z)),
                [Err(reason), ..] | [_, Err(reason), _] | [.., Err(reason)] => {
                    return Err(vertex_error(path, data, base + i, &reason));
                }
            }
        }
        let count = vertices.len() - base;
        for t in m.mesh.indices.chunks_exact(3) {
            if let Some(&i) = t.iter().find(|&&i| i as usize >= count) {
                return Err(SceneError::invalid(
                    path,
                    format!("OBJ: vertex index {} out of range", i as u64 + 1),
                ));
            }
            triangles.push([t[0], t[1], t[2]].map(|i| (base + i as usize) as u32));
        }
        if triangles.len() > MAX_PRIMITIVES || vertices.len() > u32::MAX as usize {
            return Err(SceneError::invalid(
                path,
                "OBJ: more than 2^32-2 triangles or vertices",
            ));
        }
    }
    let mesh = Mesh::new(vertices, triangles)
        .map_err(|e| SceneError::invalid(path, format!("OBJ: {e}")))?;
    let mut scene = Scene::from_mesh(mesh);
    if !materials.is_empty() {
        scene.materials.extend(materials);
        scene.material_runs = runs;
    }
    Ok(scene)
}

/// The OBJ text as tobj can read it: not-UTF-8 bytes replaced (tobj refuses the file), and a
/// bare `usemtl` line blanked (tobj refuses it), keeping every line where it was.
fn readable(data: &[u8]) -> Cow<'_, [u8]> {
    let bare_usemtl = |l: &[u8]| l.trim_ascii() == b"usemtl";
    let has_bare = data.split(|&b| b == b'\n').any(bare_usemtl);
    let text = String::from_utf8_lossy(data);
    if !has_bare {
        return match text {
            Cow::Borrowed(_) => Cow::Borrowed(data),
            Cow::Owned(s) => Cow::Owned(s.into_bytes()),
        };
    }
    let lines: Vec<&str> = text
        .split('\n')
        .map(|l| if bare_usemtl(l.as_bytes()) { "" } else { l })
        .collect();
    Cow::Owned(lines.join("\n").into_bytes())
}

fn material(m: &tobj::Material) -> Material {
    let default = Material::default();
    let max = |c: [f32; 3]| c[0].max(c[1]).max(c[2]);
    let transmittance = m
        .dissolve
        .map(|d| 1.0 - d)
        .or_else(|| m.unknown_param.get("Tr").and_then(|t| t.parse().ok()))
        .unwrap_or(0.0);
    let fix = |x: f32, lo: f32, hi: f32, or: f32| if x.is_finite() { x.clamp(lo, hi) } else { or };
    Material {
        color: m
            .diffuse
            .map(Vec3::from_array)
            .filter(|c| c.is_finite())
            .map_or(default.color, |c| c.clamp(Vec3::ZERO, Vec3::ONE)),
        kd: default.kd,
        ks: m.specular.map_or(0.0, |s| fix(max(s), 0.0, 1.0, 0.0)),
        shine: m.shininess.map_or(0.0, |n| fix(n, 0.0, 1e4, 0.0)),
        transmittance: fix(transmittance, 0.0, 1.0, 0.0),
        ior: m.optical_density.map_or(1.0, |n| fix(n, 0.01, 10.0, 1.0)),
    }
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
