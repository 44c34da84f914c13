//! glTF 2.0 scenes (`.gltf` JSON and `.glb` binary), read with the `gltf` crate: every mesh
//! primitive of triangles (lists, strips and fans) that a node of the default scene (or of
//! the first, or every mesh when there is no scene) places, in world space through the
//! nodes' transforms, flattened into triangles in the order the nodes are visited (depth
//! first, children in order) and the primitives listed. Buffers may be the GLB's binary chunk,
//! `data:` URIs (base64) or files beside the scene file. Points, lines, textures, skins and
//! morph targets are not read.
//!
//! Materials map the metallic-roughness model onto NFF's: the base colour factor is the
//! colour, `Kd = 1 − metallic`, `Ks = metallic` with `Shine = 2 + 98·(1 − roughness)²`, and an
//! alpha below 1 (blend mode) is transmittance `1 − alpha` with index 1.5 (glTF's default).

use super::{Instance, InstancedScene, Material, Model, Scene, SceneError};
use crate::geometry::Vec3;
use base64::Engine;
use glam::{Affine3A, Mat4};
use std::collections::HashMap;
use std::path::Path;

/// Most bytes a buffer may have: far above any real scene, below the machine's memory.
const MAX_BUFFER: usize = 4 << 30;
/// Deepest nesting of nodes, and most node visits: a node graph with a cycle, or with children
/// shared level after level (2^depth visits), is refused rather than walked.
const MAX_DEPTH: usize = 256;
const MAX_NODES_VISITED: usize = 1 << 20;

pub fn parse(path: &str, data: &[u8]) -> Result<Scene, SceneError> {
    let bad = |reason: String| SceneError::invalid(path, format!("glTF: {reason}"));
    let (placed, loaded) = placements(path, data)?;
    let meshes = loaded.meshes();
    let mut flat = Triangles::default();
    for (mesh, world) in &placed {
        flat.read(&meshes[*mesh], world, &loaded.buffers, &bad)?;
    }
    Ok(flat.into_scene())
}

/// The scene with its shared meshes kept once: a mesh that nodes place more than once is a
/// model ([`super::Model`], its triangles in the mesh's own frame), each placement an
/// instance by the node's transform; a mesh placed once, or by a transform that is not an
/// invertible affine map, is read into the world as [`parse`] reads it.
pub fn parse_instanced(path: &str, data: &[u8]) -> Result<InstancedScene, SceneError> {
    let bad = |reason: String| SceneError::invalid(path, format!("glTF: {reason}"));
    let (placed, loaded) = placements(path, data)?;
    let (meshes, buffers) = (loaded.meshes(), &loaded.buffers);
    let mut uses: HashMap<usize, usize> = HashMap::new();
    for (mesh, _) in &placed {
        *uses.entry(*mesh).or_default() += 1;
    }
    let mut models: Vec<Model> = Vec::new();
    let mut model_of: HashMap<usize, u32> = HashMap::new();
    let mut world = Triangles::default();
    let mut instances = Vec::new();
    for &(index, ref m) in &placed {
        let mesh = &meshes[index];
        let affine = m.row(3) == glam::Vec4::W;
        let transform = Affine3A::from_mat4(*m);
        let instance = |model| Instance { model, transform };
        if uses[&index] < 2 || !affine || instance(0).check().is_err() {
            world.read(mesh, m, buffers, &bad)?;
            continue;
        }
        let model = match model_of.get(&index) {
            Some(&k) => k,
            None => {
                let mut own = Triangles::default();
                own.read(mesh, &Mat4::IDENTITY, buffers, &bad)?;
                models.push(Model {
                    name: mesh
                        .name()
                        .map_or_else(|| format!("mesh{}", mesh.index()), str::to_string),
                    scene: own.into_scene(),
                    instances: Vec::new(),
                });
                let k = models.len() as u32 - 1;
                model_of.insert(index, k);
                k
            }
        };
        instances.push(instance(model));
    }
    models.push(Model {
        name: "world".into(),
        scene: world.into_scene(),
        instances,
    });
    let mut scene = InstancedScene { models };
    let b = scene.bounds();
    scene
        .models
        .last_mut()
        .expect("the world")
        .scene
        .frame_camera_and_light_on(&b);
    Ok(scene)
}

/// Every mesh the default scene's nodes place (or the first scene's, or every mesh when
/// there is none), with its node's world transform, in visiting order; and the buffers.
fn placements(path: &str, data: &[u8]) -> Result<(Vec<(usize, Mat4)>, Loaded), SceneError> {
    let bad = |reason: String| SceneError::invalid(path, format!("glTF: {reason}"));
    let doc = gltf::Gltf::from_slice_without_validation(data).map_err(|e| bad(e.to_string()))?;
    let json = doc.document.into_json();
    attributes_in_range(&json).map_err(bad)?;
    let doc = gltf::Gltf {
        document: gltf::Document::from_json(json).map_err(|e| bad(e.to_string()))?,
        blob: doc.blob,
    };
    let buffers = doc
        .buffers()
        .map(|b| buffer(path, &doc, &b).map_err(|r| bad(format!("buffer {}: {r}", b.index()))))
        .collect::<Result<Vec<_>, _>>()?;
    let mut placed: Vec<(usize, Mat4)> = Vec::new();
    let scene = doc.default_scene().or_else(|| doc.scenes().next());
    match scene {
        Some(s) => {
            let mut stack: Vec<(gltf::Node, Mat4, usize)> =
                s.nodes().map(|n| (n, Mat4::IDENTITY, 0)).collect();
            stack.reverse();
            let mut visited = 0usize;
            while let Some((node, parent, depth)) = stack.pop() {
                visited += 1;
                if depth > MAX_DEPTH || visited > MAX_NODES_VISITED {
                    return Err(bad(format!(
                        "nodes nested more than {MAX_DEPTH} deep or visited more than {MAX_NODES_VISITED} times (a cycle, or children shared without end)"
                    )));
                }
                let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
                if let Some(m) = node.mesh() {
                    placed.push((m.index(), world));
                }
                let first = stack.len();
                stack.extend(node.children().map(|c| (c, world, depth + 1)));
                stack[first..].reverse();
            }
        }
        None => placed.extend(doc.meshes().map(|m| (m.index(), Mat4::IDENTITY))),
    }
    Ok((placed, Loaded { doc, buffers }))
}

/// A document with its buffers read.
struct Loaded {
    doc: gltf::Gltf,
    buffers: Vec<Vec<u8>>,
}

impl Loaded {
    fn meshes(&self) -> Vec<gltf::Mesh<'_>> {
        self.doc.meshes().collect()
    }
}

/// Triangles read from placed meshes, with their materials by runs.
#[derive(Default)]
struct Triangles {
    triangles: Vec<[Vec3; 3]>,
    runs: Vec<(u32, u32)>,
    materials: Vec<Material>,
    material_of: std::collections::HashMap<Option<usize>, u32>,
}

impl Triangles {
    /// Reads `mesh`'s triangle primitives through `world`.
    fn read(
        &mut self,
        mesh: &gltf::Mesh,
        world: &Mat4,
        buffers: &[Vec<u8>],
        bad: &dyn Fn(String) -> SceneError,
    ) -> Result<(), SceneError> {
        for prim in mesh.primitives() {
            use gltf::mesh::Mode;
            let mode = prim.mode();
            if !matches!(
                mode,
                Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
            ) {
                continue;
            }
            let what = || format!("mesh {} primitive {}", mesh.index(), prim.index());
            let reader = prim.reader(|b| buffers.get(b.index()).map(|v| &v[..]));
            readable(&prim).map_err(|r| bad(format!("{}: {r}", what())))?;
            let Some(positions) = reader.read_positions() else {
                return Err(bad(format!("{}: no readable POSITION", what())));
            };
            let points: Vec<Vec3> = positions
                .map(|p| world.transform_point3(Vec3::from_array(p)))
                .collect();
            if let Some(i) = points.iter().position(|p| !p.is_finite()) {
                return Err(bad(format!(
                    "{}: vertex {i} is NaN or infinite (after its node's transform)",
                    what()
                )));
            }
            let indices: Vec<u32> = match (prim.indices(), reader.read_indices()) {
                (_, Some(i)) => i.into_u32().collect(),
                (None, None) => (0..points.len() as u32).collect(),
                (Some(a), None) => {
                    return Err(bad(format!(
                        "{}: indices (accessor {}) lie outside their buffer",
                        what(),
                        a.index()
                    )));
                }
            };
            let vertex = |i: u32| {
                points.get(i as usize).copied().ok_or_else(|| {
                    bad(format!(
                        "{}: index {i} out of range ({} vertices)",
                        what(),
                        points.len()
                    ))
                })
            };
            let first = self.triangles.len();
            let n = indices.len();
            match mode {
                Mode::Triangles => {
                    for t in indices.chunks_exact(3) {
                        self.triangles
                            .push([vertex(t[0])?, vertex(t[1])?, vertex(t[2])?]);
                    }
                }
                Mode::TriangleStrip => {
                    for k in 2..n {
                        let (a, b) = if k % 2 == 0 {
                            (k - 2, k - 1)
                        } else {
                            (k - 1, k - 2)
                        };
                        self.triangles.push([
                            vertex(indices[a])?,
                            vertex(indices[b])?,
                            vertex(indices[k])?,
                        ]);
                    }
                }
                _ => {
                    for k in 2..n {
                        self.triangles.push([
                            vertex(indices[0])?,
                            vertex(indices[k - 1])?,
                            vertex(indices[k])?,
                        ]);
                    }
                }
            }
            if self.triangles.len() > first {
                let m = prim.material();
                let next = self.materials.len() as u32;
                let id = *self.material_of.entry(m.index()).or_insert_with(|| {
                    self.materials.push(material(&m));
                    next
                });
                if self.runs.last().is_none_or(|r| r.1 != id) {
                    self.runs.push((first as u32, id));
                }
            }
            if self.triangles.len() >= u32::MAX as usize - 1 {
                return Err(bad("more than 2^32-2 triangles".into()));
            }
        }
        Ok(())
    }

    fn into_scene(self) -> Scene {
        let mut scene = Scene::from_triangles(self.triangles);
        if !self.materials.is_empty() {
            scene.materials = self.materials;
            scene.material_runs = self.runs;
        }
        scene
    }
}

/// Refuses a primitive attribute naming an accessor that does not exist. The `gltf` crate's
/// validation indexes the accessors by the POSITION attribute before it checks that index,
/// and panics on one out of range (gltf-json 1.4.1, `primitive_validate_hook`; found by the
/// gltf fuzz target), so this runs first.
fn attributes_in_range(json: &gltf::json::Root) -> Result<(), String> {
    let n = json.accessors.len();
    for (m, mesh) in json.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            if let Some(a) = prim.attributes.values().find(|a| a.value() >= n) {
                return Err(format!(
                    "mesh {m} primitive {p}: an attribute names accessor {}, but there are {n}",
                    a.value()
                ));
            }
        }
    }
    Ok(())
}

/// Refuses what the `gltf` crate's readers would panic on (the gltf fuzz target's finds): it
/// reads POSITION as three f32 whatever the accessor says and asserts when a view's stride
/// is shorter than that, and reaches `unreachable!` on indices of a float type.
fn readable(prim: &gltf::Primitive) -> Result<(), String> {
    use gltf::accessor::{DataType, Dimensions};
    let position = prim.get(&gltf::Semantic::Positions);
    if let Some(a) = &position
        && (a.data_type() != DataType::F32 || a.dimensions() != Dimensions::Vec3)
    {
        return Err(format!(
            "POSITION (accessor {}) is {:?} {:?}, not VEC3 of FLOAT",
            a.index(),
            a.dimensions(),
            a.data_type()
        ));
    }
    if let Some(a) = prim.indices()
        && !matches!(a.data_type(), DataType::U8 | DataType::U16 | DataType::U32)
    {
        return Err(format!(
            "indices (accessor {}) are {:?}, not an unsigned integer type",
            a.index(),
            a.data_type()
        ));
    }
    for a in position.into_iter().chain(prim.indices()) {
        if let Some(stride) = a.view().and_then(|v| v.stride())
            && stride < a.size()
        {
            return Err(format!(
                "accessor {} has a byte stride of {stride}, shorter than its {}-byte elements",
                a.index(),
                a.size()
            ));
        }
    }
    Ok(())
}

fn material(m: &gltf::Material) -> Material {
    let pbr = m.pbr_metallic_roughness();
    let [r, g, b, a] = pbr.base_color_factor();
    let metallic = pbr.metallic_factor().clamp(0.0, 1.0);
    let rough = pbr.roughness_factor().clamp(0.0, 1.0);
    let blended = m.alpha_mode() == gltf::material::AlphaMode::Blend;
    Material {
        color: Vec3::new(r, g, b).clamp(Vec3::ZERO, Vec3::ONE),
        kd: 1.0 - metallic,
        ks: metallic,
        shine: 2.0 + 98.0 * (1.0 - rough) * (1.0 - rough),
        transmittance: if blended {
            (1.0 - a).clamp(0.0, 1.0)
        } else {
            0.0
        },
        ior: 1.5,
    }
}

/// A buffer's bytes: the GLB's binary chunk, a `data:` URI, or a file beside the scene file.
fn buffer(path: &str, doc: &gltf::Gltf, b: &gltf::Buffer) -> Result<Vec<u8>, String> {
    if b.length() > MAX_BUFFER {
        return Err(format!("{} bytes declared, more than 4 GiB", b.length()));
    }
    let bytes = match b.source() {
        gltf::buffer::Source::Bin => doc
            .blob
            .clone()
            .ok_or("refers to the GLB binary chunk, which the file does not have")?,
        gltf::buffer::Source::Uri(uri) => {
            if let Some(rest) = uri.strip_prefix("data:") {
                let (_, payload) = rest
                    .split_once(";base64,")
                    .ok_or("a data: URI that is not base64")?;
                base64::engine::general_purpose::STANDARD
                    .decode(payload)
                    .map_err(|e| format!("base64: {e}"))?
            } else {
                let file = Path::new(path)
                    .parent()
                    .unwrap_or(Path::new("."))
                    .join(percent_decoded(uri));
                read_bounded(&file, b.length()).map_err(|e| format!("{}: {e}", file.display()))?
            }
        }
    };
    if bytes.len() < b.length() {
        return Err(format!(
            "{} bytes declared, {} present",
            b.length(),
            bytes.len()
        ));
    }
    Ok(bytes)
}

/// A relative URI's `%XX` escapes decoded (file names with spaces are written `%20`).
fn percent_decoded(uri: &str) -> String {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let hex = |c: u8| (c as char).to_digit(16);
        if bytes[i] == b'%'
            && i + 2 < bytes.len()
            && let (Some(h), Some(l)) = (hex(bytes[i + 1]), hex(bytes[i + 2]))
        {
            out.push((h * 16 + l) as u8);
            i += 3;
            continue;
        }
        out.push(bytes[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// A buffer file's bytes, read only when it is a regular file no larger than it needs to be
/// past the declared length (a URI naming a device or a huge file is refused, not read).
fn read_bounded(file: &Path, declared: usize) -> std::io::Result<Vec<u8>> {
    use std::io::Read;
    let meta = std::fs::metadata(file)?;
    if !meta.is_file() {
        return Err(std::io::Error::other("not a regular file"));
    }
    if meta.len() > MAX_BUFFER as u64 {
        return Err(std::io::Error::other("larger than 4 GiB"));
    }
    let mut out = Vec::with_capacity(declared.min(meta.len() as usize));
    std::fs::File::open(file)?
        .take(MAX_BUFFER as u64)
        .read_to_end(&mut out)?;
    Ok(out)
}
