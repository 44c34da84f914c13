//! PLY meshes (ascii and binary, either endianness), read with the `ply-rs-bw` crate: vertices
//! `x y z` (float or double), faces `vertex_indices` (or `vertex_index`) of any integer type;
//! other elements and properties are skipped. Faces with more than three vertices are fanned in
//! order, so triangle `i` is the `i`-th triangle in file order.

use super::{MAX_PRIMITIVES, Mesh, Scene, SceneError, finite};
use crate::geometry::Vec3;
use ply_rs_bw::parser::{Parser, Reader};
use ply_rs_bw::ply::{Property, PropertyAccess};

#[derive(Default)]
struct Vertex([f64; 3]);

impl PropertyAccess for Vertex {
    fn new() -> Self {
        Vertex::default()
    }
    fn set_property(&mut self, name: &str, p: Property) -> ply_rs_bw::ply::PropertyAccessResult {
        let axis = match name {
            "x" => 0,
            "y" => 1,
            "z" => 2,
            _ => return ply_rs_bw::ply::PropertyAccessResult::Ignored,
        };
        self.0[axis] = match p {
            Property::Float(x) => x as f64,
            Property::Double(x) => x,
            Property::Char(x) => x as f64,
            Property::UChar(x) => x as f64,
            Property::Short(x) => x as f64,
            Property::UShort(x) => x as f64,
            Property::Int(x) => x as f64,
            Property::UInt(x) => x as f64,
            _ => return ply_rs_bw::ply::PropertyAccessResult::UnsupportedType,
        };
        ply_rs_bw::ply::PropertyAccessResult::Set
    }
}

#[derive(Default)]
struct Face(Vec<i64>);

impl PropertyAccess for Face {
    fn new() -> Self {
        Face::default()
    }
    fn set_property(&mut self, name: &str, p: Property) -> ply_rs_bw::ply::PropertyAccessResult {
        if name != "vertex_indices" && name != "vertex_index" {
            return ply_rs_bw::ply::PropertyAccessResult::Ignored;
        }
        fn widen<T: Into<i64>>(v: Vec<T>) -> Vec<i64> {
            v.into_iter().map(Into::into).collect()
        }
        self.0 = match p {
            Property::ListChar(v) => widen(v),
            Property::ListUChar(v) => widen(v),
            Property::ListShort(v) => widen(v),
            Property::ListUShort(v) => widen(v),
            Property::ListInt(v) => widen(v),
            Property::ListUInt(v) => widen(v),
            _ => return ply_rs_bw::ply::PropertyAccessResult::UnsupportedType,
        };
        ply_rs_bw::ply::PropertyAccessResult::Set
    }
}

/// Any other element: read and dropped.
struct Skip;

impl PropertyAccess for Skip {
    fn new() -> Self {
        Skip
    }
}

pub fn parse(path: &str, data: &[u8]) -> Result<Scene, SceneError> {
    let mut reader = Reader::new(std::io::BufReader::new(data));
    let header = Parser::<Skip>::new()
        .read_header(&mut reader)
        .map_err(|e| ply_error(path, &e, None))?;
    check_counts(path, data, &header)?;
    let mut points: Option<Vec<Vec3>> = None;
    let mut triangles: Option<Vec<[u32; 3]>> = None;
    for (name, def) in header.elements.iter() {
        match name.as_str() {
            "vertex" => {
                let mut p = Vec::with_capacity(def.count);
                for_each_element(path, &mut reader, def, &header, |i, v: Vertex| {
                    match v.0.map(|x| finite(x as f32)) {
                        [Ok(x), Ok(y), Ok(z)] => {
                            p.push(Vec3::new(x, y, z));
                            Ok(())
                        }
                        _ => Err(SceneError::invalid(
                            path,
                            format!(
                                "PLY: vertex {i}: coordinate is NaN or infinite (or beyond f32)"
                            ),
                        )),
                    }
                })?;
                points = Some(p);
            }
            "face" => {
                // Faces before vertices (legal, if rare) are checked by `Mesh::new` instead.
                let count = points.as_ref().map_or(u32::MAX as usize, Vec::len);
                let mut t: Vec<[u32; 3]> = Vec::with_capacity(def.count);
                for_each_element(path, &mut reader, def, &header, |f, face: Face| {
                    let idx = &face.0;
                    if let Some(i) = idx.iter().find(|&&i| i < 0 || i as u64 >= count as u64) {
                        let range = match &points {
                            Some(_) => format!("{count} vertices"),
                            None => "the faces come before the vertices, and indices must be below 2^32 - 1".into(),
                        };
                        return Err(SceneError::invalid(
                            path,
                            format!("PLY: face {f}: vertex index {i} out of range ({range})"),
                        ));
                    }
                    if idx.len() < 3 {
                        return Err(SceneError::invalid(
                            path,
                            format!("PLY: face {f}: {} vertices, need 3 or more", idx.len()),
                        ));
                    }
                    if t.len() + idx.len() - 2 > MAX_PRIMITIVES {
                        return Err(SceneError::invalid(path, "PLY: more than 2^32-2 triangles"));
                    }
                    t.extend(
                        (1..idx.len() - 1).map(|k| [idx[0], idx[k], idx[k + 1]].map(|i| i as u32)),
                    );
                    Ok(())
                })?;
                triangles = Some(t);
            }
            _ => for_each_element(path, &mut reader, def, &header, |_, _: Skip| Ok(()))?,
        }
    }
    let points = points.ok_or_else(|| SceneError::invalid(path, "PLY: no 'vertex' element"))?;
    let triangles = triangles.ok_or_else(|| SceneError::invalid(path, "PLY: no 'face' element"))?;
    let mesh =
        Mesh::new(points, triangles).map_err(|e| SceneError::invalid(path, format!("PLY: {e}")))?;
    Ok(Scene::from_mesh(mesh.shared()))
}

/// Reads `def`'s elements one at a time and hands each to `take` with its index, so that a
/// mesh of 10^8 faces is never held as ply-rs's elements (a heap list per face) beside the
/// mesh made of them.
fn for_each_element<E: PropertyAccess>(
    path: &str,
    reader: &mut Reader<std::io::BufReader<&[u8]>>,
    def: &ply_rs_bw::ply::ElementDef,
    header: &ply_rs_bw::ply::Header,
    mut take: impl FnMut(usize, E) -> Result<(), SceneError>,
) -> Result<(), SceneError> {
    use ply_rs_bw::ply::Encoding;
    use std::io::BufRead;
    let parser = Parser::<E>::new();
    let name = def.name.as_str();
    let little = match header.encoding {
        // Text files are small: read as the crate reads them, which counts their lines.
        Encoding::Ascii => {
            let all = parser
                .read_payload_for_element(reader, def, header)
                .map_err(|e| ply_error(path, &e, Some((name, false))))?;
            for (i, e) in all.into_iter().enumerate() {
                take(i, e)?;
            }
            return Ok(());
        }
        Encoding::BinaryLittleEndian => true,
        Encoding::BinaryBigEndian => false,
    };
    for i in 0..def.count {
        let read = if little {
            parser.read_little_endian_element(reader.get_mut(), def)
        } else {
            parser.read_big_endian_element(reader.get_mut(), def)
        };
        match read {
            Ok(e) => take(i, e)?,
            // The crate names what it missed ("a list element at index 2"); the reader's
            // own words are that the file ended.
            Err(_) if reader.get_mut().fill_buf().is_ok_and(|b| b.is_empty()) => {
                return Err(SceneError::invalid(
                    path,
                    format!(
                        "PLY: Unexpected end of file while reading binary element '{name}' {i} of {}",
                        def.count
                    ),
                ));
            }
            Err(e) => return Err(ply_error(path, &e, Some((name, true)))),
        }
    }
    Ok(())
}

/// Refuses a header whose element counts the data cannot hold, before the parser reads them:
/// each element takes at least its scalars' bytes (binary) or two characters a property (text),
/// and at least one byte however empty it is declared. Without this, `element vertex 10^11`
/// over a few bytes of payload had the parser collect elements until memory ran out (found by
/// the ply fuzz target).
fn check_counts(
    path: &str,
    data: &[u8],
    header: &ply_rs_bw::ply::Header,
) -> Result<(), SceneError> {
    use ply_rs_bw::ply::{Encoding, PropertyType, ScalarType};
    let size = |t: &ScalarType| match t {
        ScalarType::Char | ScalarType::UChar => 1u64,
        ScalarType::Short | ScalarType::UShort => 2,
        ScalarType::Int | ScalarType::UInt | ScalarType::Float => 4,
        ScalarType::Double => 8,
    };
    let end = data
        .windows(10)
        .position(|w| w == b"end_header")
        .map_or(0, |p| p + 10);
    let payload = (data.len() - end) as u64;
    let mut need = 0u64;
    for (name, def) in header.elements.iter() {
        let per = match header.encoding {
            Encoding::Ascii => 2 * def.properties.len() as u64,
            _ => def
                .properties
                .values()
                .map(|p| match &p.data_type {
                    PropertyType::Scalar(t) => size(t),
                    PropertyType::List(count, _) => size(count),
                })
                .sum(),
        };
        need = need.saturating_add((def.count as u64).saturating_mul(per.max(1)));
        if need > payload {
            return Err(SceneError::invalid(
                path,
                format!(
                    "PLY: element '{name}' declares {} elements, more than the {payload} bytes after the header can hold",
                    def.count
                ),
            ));
        }
    }
    Ok(())
}

/// One line for a ply-rs error: its first line (the rest repeats it from inner parsers), at the
/// file's line for the header and ASCII payloads, at the element for binary ones (where the
/// parser's "Line" counts nothing a reader can find).
fn ply_error(
    path: &str,
    e: &ply_rs_bw::parser::ParseError,
    element: Option<(&str, bool)>,
) -> SceneError {
    let text = e.to_string();
    let first = text.lines().next().unwrap_or("").trim();
    let (line, message) = match first.strip_prefix("Line ").and_then(|r| r.split_once(": ")) {
        Some((n, m)) => (n.parse::<usize>().ok(), m),
        None => (None, first),
    };
    let message = message.trim_end_matches('.');
    match (element, line) {
        (Some((name, true)), _) if message.contains(&format!("'{name}'")) => {
            SceneError::invalid(path, format!("PLY: {message}"))
        }
        (Some((name, true)), _) => {
            SceneError::invalid(path, format!("PLY: binary element '{name}': {message}"))
        }
        (_, Some(n)) => SceneError::parse(path, n, format!("PLY: {message}")),
        _ => SceneError::invalid(path, format!("PLY: {message}")),
    }
}
