//! Scenes: primitives, materials, lights and a camera, read from NFF, PLY, OBJ, STL or glTF
//! files (each optionally gzip-compressed) or generated in code.

mod error;
pub mod generate;
mod gltf;
mod instances;
mod mesh;
mod nff;
mod obj;
mod ply;
pub mod procedural;
mod stl;
mod terrain;
pub mod write;

pub use error::SceneError;
pub use instances::{Instance, InstanceError, InstancedScene, MAX_NESTING, Model};
pub(crate) use instances::{cofactor, transformed_box};
pub use mesh::{MAX_PRIMITIVES, Mesh, MeshError};
pub use terrain::Terrain;

use crate::accel::{PrimitiveKind, Primitives};
use crate::geometry::{Aabb, PreparedRay, Shape, Vec3};
use rayon::prelude::*;
use std::io::Read;
use std::path::Path;

/// NFF material (`f r g b Kd Ks Shine T ior`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    pub color: Vec3,
    pub kd: f32,
    pub ks: f32,
    pub shine: f32,
    pub transmittance: f32,
    pub ior: f32,
}

impl Default for Material {
    /// Matte light grey: what meshes without materials are shown with.
    fn default() -> Self {
        Material {
            color: Vec3::splat(0.8),
            kd: 1.0,
            ks: 0.0,
            shine: 0.0,
            transmittance: 0.0,
            ior: 1.0,
        }
    }
}

/// A positional light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Light {
    pub position: Vec3,
    pub color: Vec3,
}

/// NFF viewpoint. `fov_deg` is the full angle between the top and bottom (or left and right)
/// edges of the image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub from: Vec3,
    pub at: Vec3,
    pub up: Vec3,
    pub fov_deg: f32,
    pub width: u32,
    pub height: u32,
}

impl Camera {
    /// The default view of a mesh (as the yardstick meshes and embree-peer's `gen_rays.py`
    /// use it): look at the box centre from 1.5 diagonals away along (1, 0.6, 1.4), 45°.
    pub fn framing(b: &Aabb) -> Camera {
        let c = b.center();
        let diag = b.diagonal().max(1e-6);
        Camera {
            from: c + Vec3::new(1.0, 0.6, 1.4).normalize() * 1.5 * diag,
            at: c,
            up: Vec3::Y,
            fov_deg: 45.0,
            width: 512,
            height: 512,
        }
    }
}

/// Where a camera stands, overriding a scene's (a mesh's default frames its box from
/// outside): a field left `None` keeps the scene's.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct View {
    pub eye: Option<Vec3>,
    pub look_at: Option<Vec3>,
    pub up: Option<Vec3>,
    /// Vertical field of view in degrees, strictly between 0 and 180.
    pub fov: Option<f32>,
}

/// A view no camera can take.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ViewError {
    #[error("field of view {0}: must be between 0 and 180 degrees")]
    Fov(f32),
    #[error("the eye and the point looked at are the same point")]
    SamePoint,
    #[error("the up direction {0} is parallel to the view direction")]
    UpParallel(Vec3),
}

impl Camera {
    /// This camera with `view`'s fields in place of its own; an error for a view that cannot
    /// be (the frame of [`crate::render`] would be NaN).
    pub fn viewed(self, view: &View) -> Result<Camera, ViewError> {
        if *view == View::default() {
            return Ok(self);
        }
        let camera = Camera {
            from: view.eye.unwrap_or(self.from),
            at: view.look_at.unwrap_or(self.at),
            up: view.up.unwrap_or(self.up),
            fov_deg: view.fov.unwrap_or(self.fov_deg),
            ..self
        };
        let forward = camera.at - camera.from;
        if !(camera.fov_deg > 0.0 && camera.fov_deg < 180.0) {
            return Err(ViewError::Fov(camera.fov_deg));
        }
        if forward.length_squared() == 0.0 {
            return Err(ViewError::SamePoint);
        }
        if forward.cross(camera.up).length_squared()
            <= 1e-12 * forward.length_squared() * camera.up.length_squared()
        {
            return Err(ViewError::UpParallel(camera.up));
        }
        Ok(camera)
    }
}

/// Largest image side accepted from a file (a resolution line is untrusted input).
pub const MAX_RESOLUTION: u32 = 16384;

/// A scene ready for ray shooting: shapes (spheres, cones, patches, polygons of NFF files),
/// then the triangles of an indexed [`Mesh`]. Primitive `i` is `shapes[i]` below
/// `shapes.len()`, and the mesh's triangle `i − shapes.len()` from there ([`Scene::shape`]).
/// The mesh formats (PLY, OBJ, STL, glTF) fill the mesh alone, so primitive `i` is the `i`-th
/// triangle in file order (polygons fanned in order); NFF fills the shapes alone.
#[derive(Clone, Debug)]
pub struct Scene {
    pub shapes: Vec<Shape>,
    /// Triangles with shared vertices, numbered after the shapes.
    pub mesh: Mesh,
    /// Materials by runs: `(first primitive, material index)`, sorted by first primitive.
    pub material_runs: Vec<(u32, u32)>,
    pub materials: Vec<Material>,
    /// Per-vertex normals of patches, indexed by [`Shape::Patch::normals`].
    pub patch_normals: Vec<[Vec3; 3]>,
    pub lights: Vec<Light>,
    pub camera: Camera,
    pub background: Vec3,
}

impl Scene {
    /// Reads a scene file: `.nff`, `.ply`, `.obj`, `.stl`, `.gltf` or `.glb`, each also as `.gz`
    /// (detected by content).
    pub fn load(path: impl AsRef<Path>) -> Result<Scene, SceneError> {
        let path = path.as_ref();
        let name = path.display().to_string();
        let raw = std::fs::read(path).map_err(|e| SceneError::io(&name, e))?;
        Scene::from_bytes(&name, &raw)
    }

    /// A scene by name: `builtin:room[:TRIANGLES]` (the clustered room of [`procedural`]),
    /// `builtin:KIND[:SIZE]` for a generated scene ([`generate::KINDS`]), or a file
    /// ([`Scene::load`]). An instanced scene (`builtin:town`, `builtin:KIND:SIZE:instanced`,
    /// an NFF file with `instance` lines) comes flattened into copies, up to
    /// [`MAX_FLATTENED`] primitives; [`InstancedScene::open`] keeps its instances.
    pub fn open(name: &str) -> Result<Scene, SceneError> {
        match Builtin::parse(name)? {
            None => Scene::load(name),
            Some(Builtin::Flat(scene)) => Ok(scene),
            Some(Builtin::Instanced(scene)) => flatten_for(name, scene),
        }
    }

    /// Parses scene data; `name`'s extension picks the format, as in [`Scene::load`]. An NFF
    /// file's instances come flattened ([`Scene::open`]).
    pub fn from_bytes(name: &str, raw: &[u8]) -> Result<Scene, SceneError> {
        flatten_for(name, parse_any(name, raw, false)?)
    }
}

/// A built-in scene's name parsed and generated: `None` for a name that is not
/// `builtin:...`.
enum Builtin {
    Flat(Scene),
    Instanced(InstancedScene),
}

impl Builtin {
    fn parse(name: &str) -> Result<Option<Builtin>, SceneError> {
        let Some(rest) = name.strip_prefix("builtin:") else {
            return Ok(None);
        };
        let mut parts = rest.splitn(3, ':');
        let kind = parts.next().unwrap_or_default();
        let size = parts.next();
        let instanced = match parts.next() {
            None => kind == "town",
            Some("instanced") => true,
            Some(other) => {
                return Err(SceneError::invalid(
                    name,
                    format!("'{other}' after the size: the one word there is 'instanced'"),
                ));
            }
        };
        let bad = |reason: String| SceneError::invalid(name, reason);
        if kind == "room" && !instanced {
            let n = match size {
                None => 60_000,
                Some(s) => s
                    .parse()
                    .ok()
                    .filter(|n| (1..=100_000_000).contains(n))
                    .ok_or_else(|| {
                        bad(format!("'{s}' is not a triangle count in 1..=100000000"))
                    })?,
            };
            return Ok(Some(Builtin::Flat(procedural::clustered_room(n, 1))));
        }
        let known = if instanced {
            generate::INSTANCED_KINDS.contains(&kind)
        } else {
            generate::KINDS.iter().any(|(k, _, _)| *k == kind)
        };
        if !known {
            let kinds: Vec<&str> = if instanced {
                generate::INSTANCED_KINDS.to_vec()
            } else {
                std::iter::once("room")
                    .chain(generate::KINDS.iter().map(|k| k.0))
                    .chain(["town"])
                    .collect()
            };
            let what = if instanced { "instanced " } else { "" };
            return Err(bad(format!(
                "unknown {what}built-in scene '{kind}' (there are: {})",
                kinds.join(", ")
            )));
        }
        let max = if instanced {
            generate::MAX_INSTANCED_SIZE
        } else {
            generate::max_size(kind)
        };
        let size = match size {
            None => 0,
            Some(s) => s
                .parse()
                .ok()
                .filter(|n| (1..=max).contains(n))
                .ok_or_else(|| bad(format!("'{s}' is not a size in 1..={max}")))?,
        };
        Ok(Some(if instanced {
            Builtin::Instanced(generate::instanced(kind, size, 1).expect("a known kind"))
        } else {
            Builtin::Flat(generate::generate(kind, size, 1).expect("a known kind"))
        }))
    }
}

impl InstancedScene {
    /// A scene by name with its instances kept: `builtin:town[:N]`,
    /// `builtin:KIND:SIZE:instanced` ([`generate::instanced`]), an NFF file with hugrt's
    /// `define` and `instance` lines (`docs/nff-and-spd.md`); any other scene of
    /// [`Scene::open`] as a world of one model.
    pub fn open(name: &str) -> Result<InstancedScene, SceneError> {
        match Builtin::parse(name)? {
            Some(Builtin::Flat(scene)) => Ok(InstancedScene::of_scene(scene)),
            Some(Builtin::Instanced(scene)) => Ok(scene),
            None => {
                let raw = std::fs::read(name).map_err(|e| SceneError::io(name, e))?;
                InstancedScene::from_bytes(name, &raw)
            }
        }
    }

    /// Parses scene data with its instances kept, `name`'s extension picking the format: an
    /// NFF file's models and instances, a glTF file's meshes placed by several nodes
    /// (each a model, each placement an instance); any other as a world of one model.
    pub fn from_bytes(name: &str, raw: &[u8]) -> Result<InstancedScene, SceneError> {
        parse_any(name, raw, true)
    }
}

/// Parses scene data of any format, `name`'s extension picking it: NFF with its models and
/// instances, glTF with its shared meshes as models when `instanced` (else flattened in file
/// order), the others as a world of one model.
fn parse_any(name: &str, raw: &[u8], instanced: bool) -> Result<InstancedScene, SceneError> {
    /// Every model's scene as the loaders hand scenes out ([`Scene::with_tiny_coordinates_zeroed`]).
    fn zeroed(mut scene: InstancedScene) -> InstancedScene {
        for m in &mut scene.models {
            m.scene = std::mem::take(&mut m.scene).with_tiny_coordinates_zeroed();
        }
        scene
    }
    {
        let unzipped;
        let data = if raw.starts_with(&[0x1f, 0x8b]) {
            unzipped = gunzip(raw).map_err(|e| SceneError::io(name, e))?;
            &unzipped[..]
        } else {
            raw
        };
        let name = name.to_string();
        let lower = name.to_ascii_lowercase();
        let stem = lower.strip_suffix(".gz").unwrap_or(&lower);
        let is_text = [".nff", ".obj", ".stl", ".gltf"]
            .iter()
            .any(|e| stem.ends_with(e));
        let transcoded;
        let data = if is_text {
            transcoded = utf8_text(&name, data)?;
            &transcoded[..]
        } else {
            data
        };
        if stem.ends_with(".nff") {
            return nff::parse_instanced(&name, data).map(zeroed);
        }
        let parsed = if stem.ends_with(".ply") {
            ply::parse(&name, data)
        } else if stem.ends_with(".obj") {
            obj::parse(&name, data)
        } else if stem.ends_with(".stl") {
            stl::parse(&name, data)
        } else if stem.ends_with(".gltf") || stem.ends_with(".glb") {
            if instanced {
                return gltf::parse_instanced(&name, data).map(zeroed);
            }
            gltf::parse(&name, data)
        } else {
            Err(SceneError::UnknownFormat { path: name })
        };
        parsed.map(|s| InstancedScene::of_scene(s.with_tiny_coordinates_zeroed()))
    }
}

impl Scene {
    /// The scene with its shapes' tiny coordinates made zero
    /// ([`Shape::with_tiny_coordinates_zeroed`]; a [`Mesh`] is made so): what every loader and
    /// [`Scene::from_triangles`] hand out.
    pub fn with_tiny_coordinates_zeroed(mut self) -> Scene {
        for s in &mut self.shapes {
            *s = s.with_tiny_coordinates_zeroed();
        }
        self
    }

    /// A triangle soup as a mesh ([`Mesh::welded`]: equal vertices stored once) with one
    /// default material, one light at the eye, and the framing camera.
    pub fn from_triangles(triangles: Vec<[Vec3; 3]>) -> Scene {
        Scene::from_mesh(Mesh::welded(&triangles))
    }

    /// A mesh with one default material, one light at the eye, and the framing camera.
    pub fn from_mesh(mesh: Mesh) -> Scene {
        let mut scene = Scene {
            mesh,
            ..Scene::default()
        };
        scene.frame_camera_and_light();
        scene
    }

    /// The number of primitives: shapes and mesh triangles.
    pub fn len(&self) -> usize {
        self.shapes.len() + self.mesh.len()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Primitive `i` as a shape: `shapes[i]`, or the mesh's triangle after them.
    #[inline]
    pub fn shape(&self, i: usize) -> Shape {
        match self.shapes.get(i) {
            Some(s) => *s,
            None => Shape::Triangle(self.mesh.triangle(i - self.shapes.len())),
        }
    }

    /// Every primitive as a shape, in primitive order.
    pub fn primitives(&self) -> impl ExactSizeIterator<Item = Shape> + '_ {
        (0..self.len()).map(|i| self.shape(i))
    }

    fn frame_camera_and_light(&mut self) {
        self.frame_camera_and_light_on(&self.bounds());
    }

    /// The framing camera of box `b` ([`Camera::framing`]), with one light above the eye.
    pub(crate) fn frame_camera_and_light_on(&mut self, b: &Aabb) {
        let b = *b;
        self.camera = Camera::framing(&if b.is_empty() {
            Aabb::new(Vec3::ZERO, Vec3::ONE)
        } else {
            b
        });
        let up = Vec3::Y * b.diagonal().max(1.0);
        self.lights = vec![Light {
            position: self.camera.from + up,
            color: Vec3::ONE,
        }];
    }

    /// The box of every primitive (NaN coordinates left out, as `f32::min` leaves them). A
    /// render asks for it once per frame, so it is folded on every thread (the four kitchens'
    /// 115,284 primitives took 7.0 M instructions on one thread: a 1×1 render took 0.8 ms,
    /// 0.4 on two threads): in order, and `min` and `max` pick the same one of two equal
    /// values (their sign of zero) whichever way an in-order sequence is grouped, so the box
    /// is bit for bit one thread's fold.
    pub fn bounds(&self) -> Aabb {
        let union = |a: Aabb, b: Aabb| a.union(&b);
        let shapes = self
            .shapes
            .par_iter()
            .fold(|| Aabb::EMPTY, |b, s| b.union(&s.bounds()))
            .reduce(|| Aabb::EMPTY, union);
        let vertices = self.mesh.vertices();
        let mesh = self
            .mesh
            .triangles()
            .par_iter()
            .fold(
                || Aabb::EMPTY,
                |b, t| t.iter().fold(b, |b, &k| b.grow(vertices[k as usize])),
            )
            .reduce(|| Aabb::EMPTY, union);
        shapes.union(&mesh)
    }

    pub fn material(&self, prim: u32) -> &Material {
        &self.materials[self.material_index(prim) as usize]
    }

    /// The index in [`Scene::materials`] of primitive `prim`'s material.
    pub fn material_index(&self, prim: u32) -> u32 {
        let run = self
            .material_runs
            .partition_point(|&(first, _)| first <= prim);
        self.material_runs
            .get(run.wrapping_sub(1))
            .map_or(0, |r| r.1)
    }

    /// Bytes held by the primitives, materials and normals.
    pub fn memory_bytes(&self) -> usize {
        self.shapes.capacity() * std::mem::size_of::<Shape>()
            + self.mesh.memory_bytes()
            + self.patch_normals.capacity() * 36
            + self.material_runs.capacity() * 8
            + self.materials.capacity() * std::mem::size_of::<Material>()
    }
}

impl Default for Scene {
    /// No primitives, the default material, no lights, a camera framing the unit cube.
    fn default() -> Self {
        Scene {
            shapes: Vec::new(),
            mesh: Mesh::default(),
            material_runs: vec![(0, 0)],
            materials: vec![Material::default()],
            patch_normals: Vec::new(),
            lights: Vec::new(),
            camera: Camera::framing(&Aabb::new(Vec3::ZERO, Vec3::ONE)),
            background: Vec3::splat(0.05),
        }
    }
}

impl Primitives for Scene {
    fn len(&self) -> usize {
        Scene::len(self)
    }
    /// A mesh triangle's box straight from its vertices, rather than through
    /// [`Scene::shape`], which copies a whole shape: the builds read every box.
    #[inline]
    fn bounds(&self, i: usize) -> Aabb {
        match self.shapes.get(i) {
            Some(s) => s.bounds(),
            None => Aabb::from_points(&self.mesh.triangle(i - self.shapes.len())),
        }
    }
    #[inline]
    fn intersect(&self, i: usize, ray: &PreparedRay, tmin: f32, tmax: f32) -> Option<f32> {
        self.shape(i).intersect(ray, tmin, tmax)
    }
    fn overlaps_box(&self, i: usize, b: &Aabb) -> bool {
        self.shape(i).overlaps_box(b)
    }
    fn mesh_triangle(&self, i: usize) -> Option<[u32; 3]> {
        let k = i.checked_sub(self.shapes.len())?;
        self.mesh.triangles().get(k).copied()
    }
    fn shared_vertices(&self) -> Option<std::sync::Arc<Vec<Vec3>>> {
        Some(self.mesh.shared_vertices())
    }
    #[inline]
    fn kind(&self, i: usize) -> PrimitiveKind {
        match self.shapes.get(i) {
            Some(Shape::Triangle(v) | Shape::Patch { v, .. }) => PrimitiveKind::Triangle(*v),
            Some(Shape::Sphere(s)) => PrimitiveKind::Sphere(*s),
            Some(Shape::Cone(c)) => PrimitiveKind::Cone(*c),
            None => PrimitiveKind::Triangle(self.mesh.triangle(i - self.shapes.len())),
        }
    }
}

/// A text format's bytes as UTF-8 without a byte-order mark: UTF-16 files (a BOM of either
/// byte order, as some Windows tools write them) are decoded, a UTF-8 BOM is dropped, and
/// anything else is passed on as it is (the formats' readers take other bytes in names and
/// comments, and report them where they matter).
fn utf8_text<'a>(name: &str, data: &'a [u8]) -> Result<std::borrow::Cow<'a, [u8]>, SceneError> {
    use std::borrow::Cow;
    let units = |le: bool| {
        data[2..].chunks(2).map(move |c| match c {
            [a, b] if le => u16::from_le_bytes([*a, *b]),
            [a, b] => u16::from_be_bytes([*a, *b]),
            _ => 0xFFFD,
        })
    };
    let decoded = match data {
        [0xEF, 0xBB, 0xBF, rest @ ..] => return Ok(Cow::Borrowed(rest)),
        [0xFF, 0xFE, ..] => char::decode_utf16(units(true)).collect::<Result<String, _>>(),
        [0xFE, 0xFF, ..] => char::decode_utf16(units(false)).collect::<Result<String, _>>(),
        _ => return Ok(Cow::Borrowed(data)),
    };
    decoded
        .map(|s| Cow::Owned(s.into_bytes()))
        .map_err(|e| SceneError::invalid(name, format!("UTF-16 text with a broken character: {e}")))
}

/// Decompressed size limit: far above any real scene, below the machine's memory.
const MAX_DECOMPRESSED: u64 = 8 << 30;

fn gunzip(raw: &[u8]) -> std::io::Result<Vec<u8>> {
    let mut out = Vec::new();
    flate2::read::MultiGzDecoder::new(raw)
        .take(MAX_DECOMPRESSED + 1)
        .read_to_end(&mut out)?;
    if out.len() as u64 > MAX_DECOMPRESSED {
        return Err(std::io::Error::other("decompressed data larger than 8 GiB"));
    }
    Ok(out)
}

/// An instanced scene as a flat one, for the readers whose callers want a [`Scene`]: its
/// copies flattened ([`InstancedScene::flattened`]), when they number at most
/// [`MAX_FLATTENED`]; [`InstancedScene::open`] keeps the instances.
pub(crate) fn flatten_for(name: &str, scene: InstancedScene) -> Result<Scene, SceneError> {
    let scene = match scene.into_flat() {
        Ok(flat) => return Ok(flat),
        Err(instanced) => instanced,
    };
    scene
        .check()
        .map_err(|e| SceneError::invalid(name, e.to_string()))?;
    let n = scene.flattened_counts().last().copied().unwrap_or(0);
    if n > MAX_FLATTENED {
        return Err(SceneError::invalid(
            name,
            format!(
                "an instanced scene of {n} primitives once flattened, past the {MAX_FLATTENED} a flat scene takes here; `hugrt render`, `trace` and `stats` take it with its instances"
            ),
        ));
    }
    scene
        .flattened()
        .map_err(|e| SceneError::invalid(name, e.to_string()))
}

/// The most primitives an instanced scene is flattened to when a flat scene is asked for.
pub const MAX_FLATTENED: u64 = 1 << 26;

/// Checks that a coordinate read from a file is finite, naming what it is otherwise.
pub(crate) fn finite(x: f32) -> Result<f32, String> {
    if x.is_nan() {
        Err("coordinate is NaN".into())
    } else if x.is_infinite() {
        Err("coordinate is infinite".into())
    } else {
        Ok(x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_are_one_threads_fold_bit_for_bit() {
        // Many primitives (so that the threads split them), zeros of both signs tied for the
        // least and greatest coordinates, and NaN coordinates, which the box leaves out.
        let mut triangles = Vec::new();
        let mut shapes = Vec::new();
        for i in 0..50_000u32 {
            let z = if i % 3 == 0 { -0.0 } else { 0.0 };
            let a = Vec3::new(z, (i % 7) as f32, -z);
            let b = Vec3::new(1.0 + (i % 5) as f32, z, 2.0);
            let c = if i % 1000 == 17 {
                Vec3::new(f32::NAN, 1.0, z)
            } else {
                Vec3::new(z, 3.0, z)
            };
            triangles.push([a, b, c]);
            shapes.push(Shape::Triangle([c, a, b]));
        }
        let mut scene = Scene::from_triangles(triangles);
        scene.shapes = shapes;
        let one = scene
            .shapes
            .iter()
            .fold(Aabb::EMPTY, |b, s| b.union(&s.bounds()));
        let one = scene
            .mesh
            .triangles()
            .iter()
            .flatten()
            .fold(one, |b, &k| b.grow(scene.mesh.vertices()[k as usize]));
        let bits = |b: Aabb| [b.min.to_array(), b.max.to_array()].map(|v| v.map(f32::to_bits));
        for _ in 0..20 {
            assert_eq!(bits(scene.bounds()), bits(one));
        }
    }
}
