//! Writing scenes: NFF, which holds everything a [`Scene`] has, and binary PLY, which holds
//! triangles only.

use super::{InstancedScene, Scene, Terrain};
use crate::Error;
use crate::geometry::{Cone, Shape, Sphere, Vec3};
use std::io::{self, Write};
use std::path::Path;

/// The scene formats hugrt writes, chosen by a file name's extension (as [`Scene::load`]
/// reads by content).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SceneFormat {
    /// Everything a scene holds ([`write_nff`]).
    Nff,
    /// Triangles only, binary ([`write_ply`]).
    Ply,
}

impl SceneFormat {
    /// The format of `path` by its extension (`.nff` or `.ply`, any case); an error naming
    /// both for any other.
    pub fn for_path(path: &Path) -> Result<SceneFormat, Error> {
        match path.extension().map(|e| e.to_ascii_lowercase()) {
            Some(e) if e == "nff" => Ok(SceneFormat::Nff),
            Some(e) if e == "ply" => Ok(SceneFormat::Ply),
            _ => Err(Error::Format {
                path: path.to_path_buf(),
                reason: "the output must end in .nff or .ply".into(),
            }),
        }
    }
}

/// Writes `scene` to `path` in the format its name says ([`SceneFormat::for_path`]).
pub fn save(scene: &Scene, path: &Path) -> Result<(), Error> {
    let format = SceneFormat::for_path(path)?;
    let file = std::fs::File::create(path).map_err(|e| Error::write(path, e))?;
    let mut w = io::BufWriter::new(file);
    match format {
        SceneFormat::Nff => write_nff(scene, &mut w),
        SceneFormat::Ply => write_ply(scene, &mut w),
    }
    .and_then(|()| w.flush())
    .map_err(|e| Error::write(path, e))
}

/// Writes generated scene `kind` to `path` as [`save`] would write
/// [`generate`](super::generate::generate)'s scene, and returns its primitive and light
/// counts; a terrain written as PLY is streamed ([`Terrain::write_ply`]), never held whole.
pub fn save_generated(
    kind: &str,
    size: u32,
    seed: u64,
    path: &Path,
) -> Result<(usize, usize), Error> {
    let format = SceneFormat::for_path(path)?;
    if kind == "terrain" && format == SceneFormat::Ply {
        let terrain = Terrain::with_triangles(size as u64 * 1000, seed);
        let file = std::fs::File::create(path).map_err(|e| Error::write(path, e))?;
        let mut w = io::BufWriter::new(file);
        terrain
            .write_ply(&mut w)
            .and_then(|()| w.flush())
            .map_err(|e| Error::write(path, e))?;
        return Ok((terrain.triangle_count(), 0));
    }
    let scene = super::generate::generate(kind, size, seed)
        .ok_or_else(|| Error::Invalid(format!("unknown kind '{kind}'")))?;
    save(&scene, path)?;
    Ok((scene.len(), scene.lights.len()))
}

/// Writes generated scene `kind` with its instances ([`super::generate::instanced`]) to
/// `path`, which must name an NFF file (PLY holds no instances), and returns the world's
/// primitive count once flattened and its light count.
pub fn save_generated_instanced(
    kind: &str,
    size: u32,
    seed: u64,
    path: &Path,
) -> Result<(u64, usize), Error> {
    if SceneFormat::for_path(path)? != SceneFormat::Nff {
        return Err(Error::Format {
            path: path.to_path_buf(),
            reason: "instances are written as NFF only (.nff)".into(),
        });
    }
    let scene = super::generate::instanced(kind, size, seed).ok_or_else(|| {
        Error::Invalid(format!(
            "{kind} has no instanced form (there are: {})",
            super::generate::INSTANCED_KINDS.join(", ")
        ))
    })?;
    let file = std::fs::File::create(path).map_err(|e| Error::write(path, e))?;
    let mut w = io::BufWriter::new(file);
    write_instanced_nff(&scene, &mut w)
        .and_then(|()| w.flush())
        .map_err(|e| Error::write(path, e))?;
    let lights = scene.world().map_or(0, |m| m.scene.lights.len());
    Ok((
        scene.flattened_counts().last().copied().unwrap_or(0),
        lights,
    ))
}

/// Writes `scene` as NFF: the view, background, lights (with their colours), then each
/// material followed by its primitives. Numbers are written in the shortest form that reads
/// back to the same `f32`, so the scene read back is the same scene, primitive for primitive.
pub fn write_nff(scene: &Scene, out: &mut impl Write) -> io::Result<()> {
    write_nff_stage(scene, out)?;
    write_nff_primitives(scene, out)
}

/// Writes an instanced scene as NFF with hugrt's extension (`docs/nff-and-spd.md`): the
/// world's view, background and lights, each model as a `define` block, then the world's
/// primitives and instances. [`super::InstancedScene::open`] reads it back model for model.
pub fn write_instanced_nff(scene: &InstancedScene, out: &mut impl Write) -> io::Result<()> {
    let Some((world, models)) = scene.models.split_last() else {
        return Ok(());
    };
    // Names as the format reads them: one word each, and each its own (a name already
    // written gets the model's number after it, until it is free).
    let mut names: Vec<String> = Vec::with_capacity(models.len());
    for (k, m) in models.iter().enumerate() {
        let mut word: String = m
            .name
            .chars()
            .map(|c| if c.is_whitespace() { '_' } else { c })
            .collect();
        if word.is_empty() {
            word = "model".into();
        }
        while names.contains(&word) {
            word = format!("{word}{k}");
        }
        names.push(word);
    }
    let instances = |list: &[super::Instance], out: &mut dyn Write| -> io::Result<()> {
        for i in list {
            let (m, t) = (i.transform.matrix3, i.transform.translation);
            writeln!(
                out,
                "instance {} {} {} {} {} {} {} {} {} {} {} {} {}",
                names[i.model as usize],
                m.x_axis.x,
                m.y_axis.x,
                m.z_axis.x,
                t.x,
                m.x_axis.y,
                m.y_axis.y,
                m.z_axis.y,
                t.y,
                m.x_axis.z,
                m.y_axis.z,
                m.z_axis.z,
                t.z
            )?;
        }
        Ok(())
    };
    write_nff_stage(&world.scene, out)?;
    for (m, name) in models.iter().zip(&names) {
        writeln!(out, "define {name}")?;
        write_nff_primitives(&m.scene, out)?;
        instances(&m.instances, out)?;
        writeln!(out, "end")?;
    }
    write_nff_primitives(&world.scene, out)?;
    instances(&world.instances, out)
}

/// The view, background and lights.
fn write_nff_stage(scene: &Scene, out: &mut impl Write) -> io::Result<()> {
    let v = |p: Vec3| format!("{} {} {}", p.x, p.y, p.z);
    let c = &scene.camera;
    writeln!(out, "# written by hugrt")?;
    writeln!(out, "v\nfrom {}\nat {}\nup {}", v(c.from), v(c.at), v(c.up))?;
    writeln!(
        out,
        "angle {}\nhither 0.001\nresolution {} {}",
        c.fov_deg, c.width, c.height
    )?;
    writeln!(out, "b {}", v(scene.background))?;
    for l in &scene.lights {
        writeln!(out, "l {} {}", v(l.position), v(l.color))?;
    }
    Ok(())
}

/// Each material followed by its primitives.
fn write_nff_primitives(scene: &Scene, out: &mut impl Write) -> io::Result<()> {
    let v = |p: Vec3| format!("{} {} {}", p.x, p.y, p.z);
    let mut run = 0;
    for (i, shape) in scene.primitives().enumerate() {
        while run < scene.material_runs.len() && scene.material_runs[run].0 as usize <= i {
            let m = &scene.materials[scene.material_runs[run].1 as usize];
            writeln!(
                out,
                "f {} {} {} {} {} {}",
                v(m.color),
                m.kd,
                m.ks,
                m.shine,
                m.transmittance,
                m.ior
            )?;
            run += 1;
        }
        match shape {
            Shape::Triangle(t) => writeln!(out, "p 3\n{}\n{}\n{}", v(t[0]), v(t[1]), v(t[2]))?,
            Shape::Patch { v: t, normals } => {
                let n = scene.patch_normals[normals as usize];
                writeln!(out, "pp 3")?;
                for k in 0..3 {
                    writeln!(out, "{} {}", v(t[k]), v(n[k]))?;
                }
            }
            Shape::Sphere(s) => writeln!(out, "s {} {}", v(s.center), s.radius)?,
            Shape::Cone(k) => writeln!(
                out,
                "c\n{} {}\n{} {}",
                v(k.base),
                k.base_radius,
                v(k.apex),
                k.apex_radius
            )?,
        }
    }
    Ok(())
}

/// Sides of the polygonal stand-ins for spheres and cones in PLY files.
const ROUND_SIDES: usize = 16;

fn sphere_triangles(s: &Sphere, out: &mut Vec<[Vec3; 3]>) {
    let rings = ROUND_SIDES / 2;
    let p = |i: usize, j: usize| {
        let th = std::f32::consts::PI * i as f32 / rings as f32;
        let ph = std::f32::consts::TAU * j as f32 / ROUND_SIDES as f32;
        s.center + Vec3::new(th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin()) * s.radius.abs()
    };
    for i in 0..rings {
        for j in 0..ROUND_SIDES {
            let (a, b, c, d) = (p(i, j), p(i, j + 1), p(i + 1, j + 1), p(i + 1, j));
            if i != 0 {
                out.push([a, c, b]);
            }
            if i != rings - 1 {
                out.push([a, d, c]);
            }
        }
    }
}

fn cone_triangles(k: &Cone, out: &mut Vec<[Vec3; 3]>) {
    let w = (k.apex - k.base).normalize_or(Vec3::Y);
    let u = w.any_orthonormal_vector();
    let v = w.cross(u);
    let ring = |c: Vec3, r: f32, j: usize| {
        let a = std::f32::consts::TAU * j as f32 / ROUND_SIDES as f32;
        c + (u * a.cos() + v * a.sin()) * r.abs()
    };
    for j in 0..ROUND_SIDES {
        let (a, b) = (
            ring(k.base, k.base_radius, j),
            ring(k.base, k.base_radius, j + 1),
        );
        let (c, d) = (
            ring(k.apex, k.apex_radius, j + 1),
            ring(k.apex, k.apex_radius, j),
        );
        out.push([a, b, c]);
        out.push([a, c, d]);
    }
}

/// Writes `scene` as binary little-endian PLY (`float x y z`, `list uchar int` faces), the
/// format of the yardstick meshes and embree-peer, in primitive order: the shapes' triangles
/// and patches three vertices each, then the mesh with its shared vertices. Spheres and cones,
/// which PLY cannot hold, become meshes of 16 sides (so primitive indices then differ from the
/// scene's).
pub fn write_ply(scene: &Scene, out: &mut impl Write) -> io::Result<()> {
    let mut tris = Vec::with_capacity(scene.shapes.len());
    for s in &scene.shapes {
        match s {
            Shape::Triangle(t) | Shape::Patch { v: t, .. } => tris.push(*t),
            Shape::Sphere(s) => sphere_triangles(s, &mut tris),
            Shape::Cone(k) => cone_triangles(k, &mut tris),
        }
    }
    let mesh = &scene.mesh;
    let soup_vertices = 3 * tris.len();
    let points = tris
        .iter()
        .flatten()
        .copied()
        .chain(mesh.vertices().iter().copied());
    let faces = (0..tris.len() as u32)
        .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
        .chain(
            mesh.triangles()
                .iter()
                .map(|t| t.map(|k| k + soup_vertices as u32)),
        );
    write_ply_mesh(
        out,
        "written by hugrt",
        (soup_vertices + mesh.vertices().len(), points),
        (tris.len() + mesh.len(), faces),
    )
}

/// Writes a mesh as binary little-endian PLY from its `(count, points)` and `(count, faces)`,
/// in chunks of about 1 MB: a mesh of 10^9 triangles, made as it is written, is never held.
pub(crate) fn write_ply_mesh(
    out: &mut impl Write,
    comment: &str,
    (vertex_count, points): (usize, impl Iterator<Item = Vec3>),
    (face_count, faces): (usize, impl Iterator<Item = [u32; 3]>),
) -> io::Result<()> {
    if vertex_count > i32::MAX as usize {
        return Err(io::Error::other(
            "more than 2^31-1 vertices for PLY's int indices",
        ));
    }
    write!(
        out,
        "ply\nformat binary_little_endian 1.0\ncomment {comment}\n\
         element vertex {vertex_count}\nproperty float x\nproperty float y\nproperty float z\n\
         element face {face_count}\nproperty list uchar int vertex_indices\nend_header\n"
    )?;
    let mut buf = Vec::with_capacity(1 << 20);
    let flush = |buf: &mut Vec<u8>, out: &mut dyn Write| -> io::Result<()> {
        if buf.len() >= 1 << 20 {
            out.write_all(buf)?;
            buf.clear();
        }
        Ok(())
    };
    for p in points {
        for x in p.to_array() {
            buf.extend_from_slice(&x.to_le_bytes());
        }
        flush(&mut buf, out)?;
    }
    for f in faces {
        buf.push(3);
        for k in f {
            buf.extend_from_slice(&k.to_le_bytes());
        }
        flush(&mut buf, out)?;
    }
    out.write_all(&buf)
}
