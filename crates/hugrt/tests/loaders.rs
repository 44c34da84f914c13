//! Scene files: round trips through every format (plain and gzip), the NFF fixture, and
//! malformed inputs, each of which must give an error naming the file (and line where the
//! format has lines), never a panic.

mod common;

use common::{rng, v3};
use hugrt::geometry::{Shape, Vec3};
use hugrt::scene::Scene;
use std::fmt::Write as _;
use std::io::Write as _;

fn gzip(data: &[u8]) -> Vec<u8> {
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    e.write_all(data).unwrap();
    e.finish().unwrap()
}

fn triangles(s: &Scene) -> Vec<[Vec3; 3]> {
    s.primitives()
        .map(|sh| match sh {
            Shape::Triangle(v) => v,
            other => panic!("expected triangles only, got {other:?}"),
        })
        .collect()
}

/// A random indexed mesh: vertices and faces of 3 to 5 vertices (fanned on reading).
fn random_mesh(seed: u64) -> (Vec<Vec3>, Vec<Vec<usize>>) {
    use rand::Rng;
    let mut r = rng(seed);
    let verts: Vec<Vec3> = (0..50).map(|_| v3(&mut r, -1e3, 1e3)).collect();
    let faces = (0..80)
        .map(|_| {
            let n = r.random_range(3..=5);
            (0..n).map(|_| r.random_range(0..verts.len())).collect()
        })
        .collect();
    (verts, faces)
}

fn fanned(verts: &[Vec3], faces: &[Vec<usize>]) -> Vec<[Vec3; 3]> {
    let mut out = Vec::new();
    for f in faces {
        for k in 1..f.len() - 1 {
            out.push([verts[f[0]], verts[f[k]], verts[f[k + 1]]]);
        }
    }
    out
}

fn ply_header(format: &str, nv: usize, nf: usize) -> String {
    format!(
        "ply\nformat {format} 1.0\ncomment hugrt test\nelement vertex {nv}\nproperty float x\n\
         property float y\nproperty float z\nproperty uchar red\nelement face {nf}\n\
         property list uchar int vertex_indices\nend_header\n"
    )
}

fn ply_ascii(verts: &[Vec3], faces: &[Vec<usize>]) -> Vec<u8> {
    let mut s = ply_header("ascii", verts.len(), faces.len());
    for v in verts {
        // `{:?}` prints the shortest text that reads back as the same f32.
        writeln!(s, "{:?} {:?} {:?} 7", v.x, v.y, v.z).unwrap();
    }
    for f in faces {
        write!(s, "{}", f.len()).unwrap();
        for i in f {
            write!(s, " {i}").unwrap();
        }
        s.push('\n');
    }
    s.into_bytes()
}

fn ply_binary(verts: &[Vec3], faces: &[Vec<usize>], big_endian: bool) -> Vec<u8> {
    let fmt = if big_endian {
        "binary_big_endian"
    } else {
        "binary_little_endian"
    };
    let mut out = ply_header(fmt, verts.len(), faces.len()).into_bytes();
    let f32b = |x: f32| {
        if big_endian {
            x.to_be_bytes()
        } else {
            x.to_le_bytes()
        }
    };
    let i32b = |x: i32| {
        if big_endian {
            x.to_be_bytes()
        } else {
            x.to_le_bytes()
        }
    };
    for v in verts {
        for c in v.to_array() {
            out.extend(f32b(c));
        }
        out.push(7);
    }
    for f in faces {
        out.push(f.len() as u8);
        for &i in f {
            out.extend(i32b(i as i32));
        }
    }
    out
}

fn obj_text(verts: &[Vec3], faces: &[Vec<usize>]) -> Vec<u8> {
    let mut s = String::from("# hugrt test\no mesh\n");
    for v in verts {
        writeln!(s, "v {:?} {:?} {:?}", v.x, v.y, v.z).unwrap();
    }
    s.push_str("vn 0 0 1\n");
    for (k, f) in faces.iter().enumerate() {
        s.push('f');
        for &i in f {
            // Alternate absolute, relative (negative) and v//vn forms.
            match k % 3 {
                0 => write!(s, " {}", i + 1).unwrap(),
                1 => write!(s, " {}", i as i64 - verts.len() as i64).unwrap(),
                _ => write!(s, " {}//1", i + 1).unwrap(),
            }
        }
        s.push('\n');
    }
    s.into_bytes()
}

fn stl_ascii(tris: &[[Vec3; 3]]) -> Vec<u8> {
    let mut s = String::from("solid test mesh\n");
    for t in tris {
        s.push_str("  facet normal 0 0 1\n    outer loop\n");
        for v in t {
            writeln!(s, "      vertex {:e} {:e} {:e}", v.x, v.y, v.z).unwrap();
        }
        s.push_str("    endloop\n  endfacet\n");
    }
    s.push_str("endsolid test mesh\n");
    s.into_bytes()
}

/// Binary STL; the header starts with "solid", as many exporters write it.
fn stl_binary(tris: &[[Vec3; 3]]) -> Vec<u8> {
    let mut out = b"solid written by the test".to_vec();
    out.resize(80, b' ');
    out.extend_from_slice(&(tris.len() as u32).to_le_bytes());
    for t in tris {
        out.extend_from_slice(&[0u8; 12]);
        for v in t {
            for c in v.to_array() {
                out.extend_from_slice(&c.to_le_bytes());
            }
        }
        out.extend_from_slice(&[0u8; 2]);
    }
    out
}

/// A glTF document with one indexed triangle mesh in a base64 `data:` buffer, placed by
/// `nodes` (each a node's JSON), the scene's roots `roots`; `.0` is the JSON, `.1` the buffer's
/// bytes.
fn gltf_mesh(
    verts: &[Vec3],
    tris: &[[usize; 3]],
    nodes: &[&str],
    roots: &[usize],
) -> (String, Vec<u8>) {
    use base64::Engine;
    let mut bin = Vec::new();
    for v in verts {
        for c in v.to_array() {
            bin.extend_from_slice(&c.to_le_bytes());
        }
    }
    let pos_len = bin.len();
    for t in tris {
        for &i in t {
            bin.extend_from_slice(&(i as u32).to_le_bytes());
        }
    }
    let (lo, hi) = verts
        .iter()
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), v| {
            (a.min(*v), b.max(*v))
        });
    let node_json = nodes;
    let scene_nodes: Vec<String> = roots.iter().map(|i| i.to_string()).collect();
    let json = format!(
        r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [{}]}}], "nodes": [{}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1, "material": 0}}]}}],
  "materials": [{{"pbrMetallicRoughness": {{"baseColorFactor": [0.9, 0.2, 0.1, 1.0], "metallicFactor": 0.25, "roughnessFactor": 0.5}}}}],
  "buffers": [{{"byteLength": {}, "uri": "data:application/octet-stream;base64,{}"}}],
  "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": {pos_len}}}, {{"buffer": 0, "byteOffset": {pos_len}, "byteLength": {}}}],
  "accessors": [{{"bufferView": 0, "componentType": 5126, "count": {}, "type": "VEC3", "min": [{}, {}, {}], "max": [{}, {}, {}]}},
                {{"bufferView": 1, "componentType": 5125, "count": {}, "type": "SCALAR"}}]}}"#,
        scene_nodes.join(", "),
        node_json.join(", "),
        bin.len(),
        base64::engine::general_purpose::STANDARD.encode(&bin),
        bin.len() - pos_len,
        verts.len(),
        lo.x,
        lo.y,
        lo.z,
        hi.x,
        hi.y,
        hi.z,
        tris.len() * 3,
    );
    (json, bin)
}

/// The same document as GLB: its buffer moved into the binary chunk.
fn glb_of(json: &str, bin: &[u8]) -> Vec<u8> {
    let start = json.find(r#""uri": "data:"#).unwrap();
    let end = start + json[start..].find("\"}").unwrap() + 1;
    let mut json = format!(
        "{}{}",
        &json[..start].trim_end().trim_end_matches(','),
        &json[end..]
    )
    .into_bytes();
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let mut bin = bin.to_vec();
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::new();
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    out
}

/// `random_mesh`'s polygons as the triangles of a glTF mesh (fanned as the readers fan them).
fn gltf_of_random(verts: &[Vec3], faces: &[Vec<usize>]) -> (String, Vec<u8>) {
    let tris: Vec<[usize; 3]> = faces
        .iter()
        .flat_map(|f| (1..f.len() - 1).map(move |k| [f[0], f[k], f[k + 1]]))
        .collect();
    gltf_mesh(verts, &tris, &[r#"{"mesh": 0}"#], &[0])
}

#[test]
fn meshes_round_trip_through_every_format_plain_and_gzipped() {
    for seed in 0..3 {
        let (verts, faces) = random_mesh(seed);
        let want = fanned(&verts, &faces);
        let files = [
            ("m.ply", ply_ascii(&verts, &faces)),
            ("m.ply", ply_binary(&verts, &faces, false)),
            ("m.ply", ply_binary(&verts, &faces, true)),
            ("m.obj", obj_text(&verts, &faces)),
            ("m.stl", stl_ascii(&want)),
            ("m.stl", stl_binary(&want)),
            ("m.gltf", gltf_of_random(&verts, &faces).0.into_bytes()),
            ("m.glb", {
                let (json, bin) = gltf_of_random(&verts, &faces);
                glb_of(&json, &bin)
            }),
        ];
        for (name, data) in files {
            for (name, data) in [
                (name.to_string(), data.clone()),
                (format!("{name}.gz"), gzip(&data)),
            ] {
                let s = Scene::from_bytes(&name, &data).unwrap_or_else(|e| panic!("{e}"));
                assert_eq!(triangles(&s), want, "{name}");
                assert_eq!(s.materials.len(), 1, "{name}: one material");
                assert!(!s.lights.is_empty(), "{name}: a default light");
                let b = s.bounds();
                assert!(
                    s.camera.from.is_finite() && !b.contains(s.camera.from),
                    "{name}: camera outside the box"
                );
            }
        }
    }
}

#[test]
fn degenerate_faces_keep_their_index() {
    let verts = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::X * 2.0];
    // Face 1 repeats a vertex and face 2 is collinear: both are kept, so face 3 stays index 3.
    let faces = vec![vec![0, 1, 2], vec![0, 0, 1], vec![0, 1, 3], vec![1, 3, 2]];
    let s = Scene::from_bytes("d.ply", &ply_ascii(&verts, &faces)).unwrap();
    assert_eq!(s.len(), 4);
    assert_eq!(triangles(&s)[3], [Vec3::X, Vec3::X * 2.0, Vec3::Y]);
}

fn fixture(name: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name)
}

#[test]
fn nff_fixture_reads_every_keyword() {
    let s = Scene::load(fixture("features.nff")).unwrap();
    let count = |f: fn(&Shape) -> bool| s.shapes.iter().filter(|x| f(x)).count();
    assert_eq!(count(|x| matches!(x, Shape::Sphere(_))), 2);
    assert_eq!(count(|x| matches!(x, Shape::Cone(_))), 2);
    assert_eq!(count(|x| matches!(x, Shape::Patch { .. })), 1);
    // Square ground: 2 triangles; concave comb of 8 vertices: 6 triangles.
    assert_eq!(count(|x| matches!(x, Shape::Triangle(_))), 8);
    assert_eq!(s.materials.len(), 4);
    assert_eq!(s.lights.len(), 2);
    assert_eq!((s.camera.width, s.camera.height), (48, 32));
    assert_eq!(s.camera.fov_deg, 40.0);
    assert_eq!(s.background, Vec3::new(0.1, 0.2, 0.3));
    assert_eq!(s.material(3).transmittance, 0.8);
    assert_eq!(s.material(3).ior, 1.5);
    // The comb keeps its area: 2×1 minus the 1×0.5 notch.
    let comb_area: f32 = s
        .shapes
        .iter()
        .filter_map(|x| match x {
            Shape::Triangle(v) if v[0].z == 0.01 => {
                Some((v[1] - v[0]).cross(v[2] - v[0]).length() / 2.0)
            }
            _ => None,
        })
        .sum();
    assert!((comb_area - 1.5).abs() < 1e-5, "{comb_area}");
    // Gzipped, the same scene.
    let text = std::fs::read(fixture("features.nff")).unwrap();
    let z = Scene::from_bytes("features.nff.gz", &gzip(&text)).unwrap();
    assert_eq!(z.len(), s.len());
}

/// Loads `data` as `name` and returns the error text, failing if it loaded.
fn error_of(name: &str, data: &[u8]) -> String {
    match Scene::from_bytes(name, data) {
        Ok(s) => panic!("{name}: loaded {} primitives from malformed input", s.len()),
        Err(e) => e.to_string(),
    }
}

#[test]
fn malformed_nff_names_file_line_and_reason() {
    let cases: &[(&str, &str)] = &[
        ("s 0 0 0 1\nx 1 2 3\n", "bad.nff:2: unknown keyword 'x'"),
        (
            "\n# c\ns 0 0 nan 1\n",
            "bad.nff:3: sphere: coordinate is NaN",
        ),
        ("s 0 0 inf 1\n", "bad.nff:1: sphere: coordinate is infinite"),
        ("s 0 0 1e39 1\n", "bad.nff:1: sphere"),
        (
            "s 0 0 0\n",
            "bad.nff:1: sphere: expected 4 numbers, found 3",
        ),
        (
            "s 0 zero 0 1\n",
            "bad.nff:1: sphere: 'zero' is not a number",
        ),
        ("p 3\n0 0 0\n1 0 0\n", "bad.nff:4: unexpected end of file"),
        ("p 99999999999999999999\n", "bad.nff:1:"),
        ("p 4000000000\n0 0 0\n", "bad.nff:"),
        ("p -3\n", "bad.nff:1:"),
        ("c\n0 0 0 1\n", "bad.nff:3: unexpected end of file"),
        (
            "c 0 0 0 1 0 0 0 1\n",
            "bad.nff:1: cone: base and apex coincide",
        ),
        ("c 0 0 0 1 0 0\n", "bad.nff:1: cone"),
        (
            "v\nfrom 0 0 0\nat 0 0 1\nup 0 1 0\nangle 45\nhither 1\nresolution 0 10\n",
            "bad.nff:7:",
        ),
        (
            "v\nfrom 0 0 0\nat 0 0 1\nup 0 1 0\nangle 45\nhither 1\nresolution 99999999 10\n",
            "bad.nff:7:",
        ),
        ("v\nfrom 0 0 0\nat 0 0 1\n", "bad.nff:4:"),
        (
            "f 1 1 1 1 0 0 0\n",
            "bad.nff:1: material: expected 8 numbers, found 7",
        ),
        ("l 1 2\n", "bad.nff:1: light"),
        ("pp 3\n0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0\n", "bad.nff:4:"),
    ];
    for (text, want) in cases {
        let got = error_of("bad.nff", text.as_bytes());
        assert!(
            got.starts_with(want),
            "input {text:?}\n  got  {got}\n  want {want}…"
        );
    }
    assert_eq!(
        error_of("bad.nff", &[b'#', b'\n', 0xff, 0xfe, b's']),
        "bad.nff:2: bytes that are not UTF-8 text outside a comment"
    );
    // A Latin-1 comment, as files of the SPD's era have them, is no error.
    let latin1 = b"# Caf\xe9 au lait\ns 0 0 0 1\n";
    let s = Scene::from_bytes("cafe.nff", latin1).unwrap();
    assert_eq!(s.len(), 1);
}

#[test]
fn malformed_meshes_are_errors_not_panics() {
    let (verts, faces) = random_mesh(5);
    let good_ply = ply_binary(&verts, &faces, false);
    let mut cases: Vec<(&str, Vec<u8>, &str)> = vec![
        (
            "t.ply",
            good_ply[..good_ply.len() - 3].to_vec(),
            "t.ply: PLY: Unexpected end of file while reading binary element 'face'",
        ),
        // Header errors are at their line.
        ("t.ply", good_ply[..40].to_vec(), "t.ply:3: PLY"),
        ("t.ply", b"not a ply file\n".to_vec(), "t.ply:"),
        ("t.ply", Vec::new(), "t.ply:"),
        (
            "t.ply",
            ply_ascii(&verts, &[vec![0, 1, 50]]),
            "t.ply: PLY: face 0: vertex index 50 out of range",
        ),
        (
            "t.ply",
            String::from_utf8(ply_ascii(&verts, &[vec![0, 1, 2]]))
                .unwrap()
                .replace("3 0 1 2\n", "3 0 1 -1\n")
                .into_bytes(),
            "t.ply: PLY: face 0: vertex index -1",
        ),
        (
            "t.ply",
            ply_ascii(&verts, &[vec![0, 1]]),
            "t.ply: PLY: face 0: 2 vertices",
        ),
        // Faces before the vertices: an index is checked against what a u32 holds.
        (
            "t.ply",
            b"ply\nformat ascii 1.0\nelement face 1\nproperty list uchar int vertex_indices\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n3 0 1 -1\n0 0 0\n1 0 0\n0 1 0\n".to_vec(),
            "t.ply: PLY: face 0: vertex index -1 out of range (the faces come before the vertices",
        ),
        (
            "t.obj",
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n".to_vec(),
            "t.obj:4:",
        ),
        (
            "t.obj",
            b"v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n".to_vec(),
            "t.obj:2:",
        ),
        (
            "t.obj",
            b"v 0 0 0\nv 1 0 0\nv 0 1 zero\nf 1 2 3\n".to_vec(),
            "t.obj:3:",
        ),
        (
            "t.obj",
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n".to_vec(),
            "t.obj:4:",
        ),
        ("t.xyz", b"solid\n".to_vec(), "t.xyz: unknown scene format"),
        ("t.ply.gz", vec![0x1f, 0x8b, 8, 0, 0, 0], "t.ply.gz:"),
    ];
    // A NaN coordinate in binary PLY.
    let mut nan = verts.clone();
    nan[3].y = f32::NAN;
    cases.push((
        "t.ply",
        ply_binary(&nan, &faces, false),
        "t.ply: PLY: vertex 3: coordinate is NaN",
    ));
    // Absurd counts in the header with a short body: must fail on the data, not allocate.
    let mut absurd = ply_header("binary_little_endian", 4_000_000_000, 4_000_000_000).into_bytes();
    absurd.extend([0u8; 64]);
    cases.push(("t.ply", absurd, "t.ply: PLY"));
    // A face whose list claims 4·10⁹ indices.
    let mut huge_list = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uint int vertex_indices\nend_header\n".to_vec();
    huge_list.extend([0u8; 36]);
    huge_list.extend(4_000_000_000u32.to_le_bytes());
    huge_list.extend([0u8; 12]);
    cases.push(("t.ply", huge_list, "t.ply: PLY"));
    for (name, data, want) in cases {
        let got = error_of(name, &data);
        assert!(
            got.starts_with(want),
            "{name}\n  got  {got}\n  want {want}…"
        );
        assert!(!got.contains('\n'), "{name}: one line, got {got}");
    }
}

#[test]
fn missing_file_is_an_io_error_naming_it() {
    let e = Scene::load("/nonexistent/hugrt/scene.nff")
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("/nonexistent/hugrt/scene.nff:"), "{e}");
}

/// glTF nodes place meshes through their transforms (a matrix, or translation-rotation-scale),
/// children inside their parents' frames, every placement of a shared mesh in visiting order;
/// the base colour and metalness become the NFF material; an external buffer is read from
/// beside the file.
#[test]
fn gltf_nodes_place_meshes_and_materials_map() {
    let verts = [Vec3::ZERO, Vec3::X, Vec3::Y];
    // Node 1 scales x by 2 and moves by (0, 0, 5); its child, node 2, moves by (10, 0, 0) in
    // node 1's frame.
    let nodes = [
        r#"{"mesh": 0}"#,
        r#"{"mesh": 0, "children": [2], "matrix": [2,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,5,1]}"#,
        r#"{"mesh": 0, "translation": [10, 0, 0]}"#,
    ];
    let (json, bin) = gltf_mesh(&verts, &[[0, 1, 2]], &nodes, &[0, 1]);
    let s = Scene::from_bytes("n.gltf", json.as_bytes()).unwrap_or_else(|e| panic!("{e}\n{json}"));
    let want = vec![
        [Vec3::ZERO, Vec3::X, Vec3::Y],
        [
            Vec3::new(0.0, 0.0, 5.0),
            Vec3::new(2.0, 0.0, 5.0),
            Vec3::new(0.0, 1.0, 5.0),
        ],
        [
            Vec3::new(20.0, 0.0, 5.0),
            Vec3::new(22.0, 0.0, 5.0),
            Vec3::new(20.0, 1.0, 5.0),
        ],
    ];
    assert_eq!(triangles(&s), want);
    let m = s.material(2);
    assert_eq!(m.color, Vec3::new(0.9, 0.2, 0.1));
    assert_eq!((m.kd, m.ks), (0.75, 0.25));
    // The buffer as a file beside the scene.
    let dir = std::env::temp_dir().join(format!("hugrt-gltf-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("my mesh.bin"), &bin).unwrap();
    let start = json.find("data:").unwrap();
    let end = start + json[start..].find('"').unwrap();
    let external = format!("{}my%20mesh.bin{}", &json[..start], &json[end..]);
    std::fs::write(dir.join("n.gltf"), &external).unwrap();
    let loaded = Scene::load(dir.join("n.gltf")).unwrap();
    assert_eq!(triangles(&loaded), want);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Asked for instances, a glTF mesh that several nodes place is one model, each node an
/// instance by its world transform; a mesh placed once stays in the world. Flattened, the
/// instances are the flat reader's triangles.
#[test]
fn gltf_meshes_placed_by_several_nodes_are_instances() {
    use hugrt::scene::InstancedScene;
    let verts = [Vec3::ZERO, Vec3::X, Vec3::Y];
    let nodes = [
        r#"{"mesh": 0, "rotation": [0, 0.7071068, 0, 0.7071068]}"#,
        r#"{"mesh": 0, "children": [2], "matrix": [-2,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,5,1]}"#,
        r#"{"mesh": 0, "translation": [10, 0, 0], "scale": [1, 3, 1]}"#,
    ];
    let (json, _) = gltf_mesh(&verts, &[[0, 1, 2]], &nodes, &[0, 1]);
    let flat = Scene::from_bytes("n.gltf", json.as_bytes()).unwrap();
    let inst = InstancedScene::from_bytes("n.gltf", json.as_bytes()).unwrap();
    assert_eq!(inst.models.len(), 2);
    assert_eq!(inst.models[0].scene.len(), 1);
    assert_eq!(
        triangles(&inst.models[0].scene),
        vec![[Vec3::ZERO, Vec3::X, Vec3::Y]]
    );
    assert_eq!(inst.models[1].instances.len(), 3);
    assert_eq!(inst.models[1].scene.len(), 0);
    let flattened = inst.flattened().unwrap();
    assert_eq!(flattened.len(), flat.len());
    for (a, b) in triangles(&flat).iter().zip(triangles(&flattened)) {
        for k in 0..3 {
            assert!(a[k].distance(b[k]) < 1e-5, "{a:?} {b:?}");
        }
    }
    assert_eq!(flattened.material(2).color, Vec3::new(0.9, 0.2, 0.1));
    // Placed once, a mesh is read into the world.
    let (once, _) = gltf_mesh(&verts, &[[0, 1, 2]], &[nodes[2]], &[0]);
    let inst = InstancedScene::from_bytes("o.gltf", once.as_bytes()).unwrap();
    assert_eq!(inst.models.len(), 1);
    assert!(!inst.has_instances());
}

#[test]
fn malformed_stl_and_gltf_name_file_line_and_reason() {
    let tri = [[Vec3::ZERO, Vec3::X, Vec3::Y]];
    let ascii = String::from_utf8(stl_ascii(&tri)).unwrap();
    let binary = stl_binary(&tri);
    let (json, _) = gltf_mesh(
        &[Vec3::ZERO, Vec3::X, Vec3::Y],
        &[[0, 1, 2]],
        &[r#"{"mesh": 0}"#],
        &[0],
    );
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        (
            "t.stl",
            ascii.replace("vertex 1e0", "vertex one").into_bytes(),
            "t.stl:5: STL: 'one' is not a number",
        ),
        (
            "t.stl",
            ascii
                .replace("vertex 1e0 0e0 0e0", "vertex 1e0 0e0")
                .into_bytes(),
            "t.stl:5: STL: 'vertex' with 2 numbers",
        ),
        (
            "t.stl",
            ascii
                .replace("vertex 1e0 0e0 0e0", "vertex 1e0 0e0 NaN")
                .into_bytes(),
            "t.stl:5: STL: coordinate is NaN",
        ),
        (
            "t.stl",
            ascii.replace("    endloop\n", "").into_bytes(),
            "t.stl: STL: the file ends inside a loop",
        ),
        (
            "t.stl",
            binary[..binary.len() - 1].to_vec(),
            "not binary (its header declares 1 triangles, 134 bytes, but the file is 133 bytes)",
        ),
        ("t.stl", b"hello".to_vec(), "t.stl: STL: not ASCII"),
        ("t.gltf", b"{not json".to_vec(), "t.gltf: glTF:"),
        (
            "t.gltf",
            json.replace(
                r#""count": 3, "type": "SCALAR""#,
                r#""count": 3000, "type": "SCALAR""#,
            )
            .into_bytes(),
            "t.gltf: glTF:",
        ),
        (
            "t.gltf",
            json.replace("base64,", "base64,@@").into_bytes(),
            "t.gltf: glTF: buffer 0: base64",
        ),
        (
            "t.glb",
            b"glTF\x02\0\0\0\x10\0\0\0".to_vec(),
            "t.glb: glTF:",
        ),
    ];
    for (name, data, want) in cases {
        let e = error_of(name, &data);
        assert!(e.contains(want), "{name}: got '{e}', want '{want}'");
        assert!(!e.contains('\n'), "{name}: one line: {e}");
    }
}

/// Files as other tools write them load: UTF-16 of either byte order and UTF-8 with a BOM
/// (NFF, OBJ, STL), an OBJ with a bare `usemtl` or Latin-1 bytes in a name; and their errors
/// keep their lines.
#[test]
fn text_files_from_other_tools_load() {
    let obj = "# made elsewhere\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    let want = triangles(&Scene::from_bytes("a.obj", obj.as_bytes()).unwrap());
    let utf16 = |s: &str, le: bool| {
        let mut out = if le {
            vec![0xFF, 0xFE]
        } else {
            vec![0xFE, 0xFF]
        };
        for u in s.encode_utf16() {
            out.extend_from_slice(&if le { u.to_le_bytes() } else { u.to_be_bytes() });
        }
        out
    };
    let stl = String::from_utf8(stl_ascii(&want)).unwrap();
    let nff = "s 0 0 0 1\n";
    for (name, text) in [("a.obj", obj), ("a.stl", stl.as_str()), ("a.nff", nff)] {
        let plain = Scene::from_bytes(name, text.as_bytes()).unwrap();
        let mut bom = vec![0xEF, 0xBB, 0xBF];
        bom.extend_from_slice(text.as_bytes());
        for data in [utf16(text, true), utf16(text, false), bom] {
            let s = Scene::from_bytes(name, &data).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert_eq!(s.mesh, plain.mesh, "{name}");
            assert_eq!(s.shapes, plain.shapes, "{name}");
        }
    }
    let latin1 = b"o caf\xe9\ng \xfcber\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl\nf 1 2 3\n";
    assert_eq!(
        triangles(&Scene::from_bytes("b.obj", latin1).unwrap()),
        want
    );
    let e = error_of(
        "c.obj",
        &utf16("v 0 0 0\nv 1 0 zero\nv 0 1 0\nf 1 2 3\n", true),
    );
    assert!(e.starts_with("c.obj:2:"), "{e}");
    let e = error_of("d.obj", b"o caf\xe9\nv 0 0 0\nv 1 0 0\nf 1 2 9\n");
    assert!(e.starts_with("d.obj:4:"), "{e}");
}

/// An OBJ's `.mtl` materials map onto NFF's model, face by face; faces without a material,
/// or with an unknown one, are grey; an OBJ whose `.mtl` is missing still loads.
#[test]
fn obj_materials_come_from_the_mtl_beside_it() {
    let dir = std::env::temp_dir().join(format!("hugrt-mtl-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        dir.join("m.mtl"),
        "newmtl red\nKd 0.9 0.1 0.1\nKs 0.3 0.2 0.1\nNs 40\nd 0.75\nNi 1.3\nnewmtl blue\nKd 0 0 1\n",
    )
    .unwrap();
    let obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nusemtl red\nf 1 3 2\nf 2 3 1\nusemtl nope\nf 3 1 2\nusemtl blue\nf 1 2 3\n";
    std::fs::write(dir.join("m.obj"), obj).unwrap();
    let s = Scene::load(dir.join("m.obj")).unwrap();
    assert_eq!(s.len(), 5);
    let grey = hugrt::scene::Material::default();
    assert_eq!(*s.material(0), grey);
    let red = *s.material(1);
    assert_eq!(red.color, Vec3::new(0.9, 0.1, 0.1));
    assert_eq!(
        (red.kd, red.ks, red.shine, red.transmittance, red.ior),
        (1.0, 0.3, 40.0, 0.25, 1.3)
    );
    assert_eq!(*s.material(2), red);
    assert_eq!(*s.material(3), grey);
    assert_eq!(s.material(4).color, Vec3::new(0.0, 0.0, 1.0));
    std::fs::remove_file(dir.join("m.mtl")).unwrap();
    let s = Scene::load(dir.join("m.obj")).unwrap();
    assert!((0..5).all(|i| *s.material(i) == grey));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A glTF node graph walked without end is refused, not walked: a node that is its own child,
/// and 21 levels of nodes each holding the next level twice (2^21 placements); and a buffer
/// file that is not a regular file (a folder here, a device elsewhere) is refused, not read.
#[test]
fn gltf_node_cycles_shared_children_and_odd_buffer_files_are_refused() {
    let tri = [Vec3::ZERO, Vec3::X, Vec3::Y];
    let (json, _) = gltf_mesh(
        &tri,
        &[[0, 1, 2]],
        &[r#"{"mesh": 0, "children": [0]}"#],
        &[0],
    );
    let e = error_of("cycle.gltf", json.as_bytes());
    assert!(
        e.starts_with("cycle.gltf: glTF: nodes nested more than 256 deep or visited more than"),
        "{e}"
    );
    let mut nodes: Vec<String> = (0..21)
        .map(|k| format!(r#"{{"children": [{}, {}]}}"#, k + 1, k + 1))
        .collect();
    nodes.push(r#"{"mesh": 0}"#.to_string());
    let refs: Vec<&str> = nodes.iter().map(String::as_str).collect();
    let (json, _) = gltf_mesh(&tri, &[[0, 1, 2]], &refs, &[0]);
    let e = error_of("shared.gltf", json.as_bytes());
    assert!(
        e.starts_with("shared.gltf: glTF: nodes nested more than 256 deep or visited more than"),
        "{e}"
    );
    let dir = std::env::temp_dir().join(format!("hugrt-gltf-dir-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("buffer.bin")).unwrap();
    let (json, _) = gltf_mesh(&tri, &[[0, 1, 2]], &[r#"{"mesh": 0}"#], &[0]);
    let start = json.find("data:").unwrap();
    let end = start + json[start..].find('"').unwrap();
    std::fs::write(
        dir.join("d.gltf"),
        format!("{}buffer.bin{}", &json[..start], &json[end..]),
    )
    .unwrap();
    let e = Scene::load(dir.join("d.gltf")).unwrap_err().to_string();
    assert!(e.contains("not a regular file"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}
