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
    s.shapes
        .iter()
        .map(|sh| match sh {
            Shape::Triangle(v) => *v,
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
        ];
        for (name, data) in files {
            for (name, data) in [
                (name.to_string(), data.clone()),
                (format!("{name}.gz"), gzip(&data)),
            ] {
                let s = Scene::from_bytes(&name, &data).unwrap_or_else(|e| panic!("{e}"));
                assert_eq!(triangles(&s), want, "{name}");
                assert_eq!(s.materials.len(), 1, "{name}: one default material");
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
    assert_eq!(s.shapes.len(), 4);
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
    assert_eq!(z.shapes.len(), s.shapes.len());
}

/// Loads `data` as `name` and returns the error text, failing if it loaded.
fn error_of(name: &str, data: &[u8]) -> String {
    match Scene::from_bytes(name, data) {
        Ok(s) => panic!(
            "{name}: loaded {} shapes from malformed input",
            s.shapes.len()
        ),
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
    assert_eq!(s.shapes.len(), 1);
}

#[test]
fn malformed_meshes_are_errors_not_panics() {
    let (verts, faces) = random_mesh(5);
    let good_ply = ply_binary(&verts, &faces, false);
    let mut cases: Vec<(&str, Vec<u8>, &str)> = vec![
        (
            "t.ply",
            good_ply[..good_ply.len() - 3].to_vec(),
            "t.ply: PLY",
        ),
        ("t.ply", good_ply[..40].to_vec(), "t.ply: PLY"),
        ("t.ply", b"not a ply file\n".to_vec(), "t.ply: PLY"),
        ("t.ply", Vec::new(), "t.ply: PLY"),
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
        ("t.stl", b"solid\n".to_vec(), "t.stl: unknown scene format"),
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
    }
}

#[test]
fn missing_file_is_an_io_error_naming_it() {
    let e = Scene::load("/nonexistent/hugrt/scene.nff")
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("/nonexistent/hugrt/scene.nff:"), "{e}");
}
