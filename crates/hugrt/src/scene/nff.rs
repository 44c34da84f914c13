//! NFF (Neutral File Format) of the SPD scenes, every keyword the SPD files use
//! (`docs/nff-and-spd.md`): `v` view block, `b`, `l`, `f`, `s`, `c`, `p`, `pp`, `#`; and
//! hugrt's extension for instancing: `define NAME` ... `end` makes a model, `instance NAME
//! TRANSFORM` places one ([`super::InstancedScene`]).

use super::{
    Camera, Instance, InstancedScene, Light, MAX_RESOLUTION, Material, Model, Scene, SceneError,
    finite,
};
use crate::geometry::{Cone, Shape, Sphere, Vec3, triangulate_polygon};
use glam::{Affine3A, Mat3};

/// Most vertices one polygon may declare: a guard against absurd counts, far above any SPD file.
const MAX_POLYGON_VERTICES: usize = 1 << 20;

struct Lines<'a> {
    path: &'a str,
    iter: std::iter::Enumerate<std::str::Lines<'a>>,
    line: usize,
}

impl<'a> Lines<'a> {
    fn err(&self, reason: impl Into<String>) -> SceneError {
        SceneError::parse(self.path, self.line, reason)
    }

    /// Next line that is neither empty nor a comment, split into words.
    fn next_words(&mut self) -> Option<Vec<&'a str>> {
        for (i, l) in self.iter.by_ref() {
            self.line = i + 1;
            let l = l.trim();
            if !l.is_empty() && !l.starts_with('#') {
                return Some(l.split_whitespace().collect());
            }
        }
        None
    }

    /// The continuation line of an entity begun at line `start`.
    fn expect_words(&mut self, what: &str, start: usize) -> Result<Vec<&'a str>, SceneError> {
        self.next_words().ok_or_else(|| {
            SceneError::parse(
                self.path,
                self.line + 1,
                format!("unexpected end of file: expected {what} (entity started at line {start})"),
            )
        })
    }

    fn numbers<const N: usize>(&self, words: &[&str], what: &str) -> Result<[f32; N], SceneError> {
        if words.len() != N {
            return Err(self.err(format!(
                "{what}: expected {N} numbers, found {}",
                words.len()
            )));
        }
        let mut out = [0.0; N];
        for (o, w) in out.iter_mut().zip(words) {
            let x: f32 = w
                .parse()
                .map_err(|_| self.err(format!("{what}: '{w}' is not a number")))?;
            *o = finite(x).map_err(|r| self.err(format!("{what}: {r}")))?;
        }
        Ok(out)
    }

    fn vec3(&self, words: &[&str], what: &str) -> Result<Vec3, SceneError> {
        Ok(Vec3::from_array(self.numbers::<3>(words, what)?))
    }
}

/// The file's models and world ([`InstancedScene`]): the models of its `define` blocks in
/// file order, then the world (everything outside them).
pub fn parse_instanced(path: &str, data: &[u8]) -> Result<InstancedScene, SceneError> {
    // Files of the SPD's era often carry Latin-1 in their comments: comments are read
    // leniently, and only the data must be text.
    let text = String::from_utf8_lossy(data);
    if let Some((i, _)) = text.lines().enumerate().find(|(_, l)| {
        let l = l.trim();
        !l.starts_with('#') && l.contains(char::REPLACEMENT_CHARACTER)
    }) {
        return Err(SceneError::parse(
            path,
            i + 1,
            "bytes that are not UTF-8 text outside a comment",
        ));
    }
    let mut l = Lines {
        path,
        iter: text.lines().enumerate(),
        line: 0,
    };
    let mut scene = Scene {
        shapes: Vec::new(),
        mesh: Default::default(),
        material_runs: Vec::new(),
        materials: Vec::new(),
        patch_normals: Vec::new(),
        lights: Vec::new(),
        camera: Camera::framing(&crate::geometry::Aabb::new(Vec3::ZERO, Vec3::ONE)),
        background: Vec3::ZERO,
    };
    let mut have_view = false;
    let mut pending_lights: Vec<(Vec3, Option<Vec3>)> = Vec::new();
    let mut models: Vec<Model> = Vec::new();
    let mut world_instances: Vec<Instance> = Vec::new();
    // The model being defined, its material carried over from the world's.
    let mut defining: Option<Model> = None;
    while let Some(words) = l.next_words() {
        let start = l.line;
        let args = &words[1..];
        let in_definition = defining.is_some();
        if in_definition && matches!(words[0], "v" | "b" | "l") {
            return Err(l.err(format!(
                "'{}' inside a definition: views, backgrounds and lights belong to the world",
                words[0]
            )));
        }
        let (scene, instances) = match &mut defining {
            Some(m) => (&mut m.scene, &mut m.instances),
            None => (&mut scene, &mut world_instances),
        };
        match words[0] {
            "define" => {
                let [name] = args else {
                    return Err(l.err("define: expected one name"));
                };
                if in_definition {
                    return Err(l.err("define inside a definition: end the first one before"));
                }
                if models.iter().any(|m| m.name == *name) {
                    return Err(l.err(format!("define: '{name}' is already defined")));
                }
                let current = scene.material_runs.last().map(|r| r.1 as usize);
                let mut model_scene = Scene {
                    material_runs: Vec::new(),
                    materials: Vec::new(),
                    lights: Vec::new(),
                    ..Scene::default()
                };
                if let Some(m) = current {
                    model_scene.materials.push(scene.materials[m]);
                    model_scene.material_runs.push((0, 0));
                }
                defining = Some(Model {
                    name: name.to_string(),
                    scene: model_scene,
                    instances: Vec::new(),
                });
            }
            "end" => {
                let Some(mut m) = defining.take() else {
                    return Err(l.err("end without a definition"));
                };
                if !args.is_empty() {
                    return Err(l.err("end: expected nothing after it"));
                }
                if m.scene.materials.is_empty() {
                    m.scene.materials.push(Material::default());
                    m.scene.material_runs.push((0, 0));
                }
                models.push(m);
            }
            "instance" => {
                let Some((name, transform)) = args.split_first() else {
                    return Err(l.err("instance: expected a model's name and a transform"));
                };
                let model = models
                    .iter()
                    .position(|m| m.name == *name)
                    .ok_or_else(|| l.err(format!("instance: no model '{name}' defined before")))?;
                let inst = Instance {
                    model: model as u32,
                    transform: parse_transform(&l, transform)?,
                };
                inst.check()
                    .map_err(|reason| l.err(format!("instance of '{name}': {reason}")))?;
                instances.push(inst);
            }
            "v" => {
                scene.camera = parse_view(&mut l, start)?;
                have_view = true;
            }
            "b" => scene.background = l.vec3(args, "background colour")?,
            "l" => match args.len() {
                3 => pending_lights.push((l.vec3(args, "light")?, None)),
                6 => {
                    let v = l.numbers::<6>(args, "light")?;
                    pending_lights.push((
                        Vec3::new(v[0], v[1], v[2]),
                        Some(Vec3::new(v[3], v[4], v[5])),
                    ));
                }
                n => return Err(l.err(format!("light: expected 3 or 6 numbers, found {n}"))),
            },
            "f" => {
                let v = l.numbers::<8>(args, "material")?;
                scene.materials.push(Material {
                    color: Vec3::new(v[0], v[1], v[2]),
                    kd: v[3],
                    ks: v[4],
                    shine: v[5],
                    transmittance: v[6],
                    ior: v[7],
                });
                scene
                    .material_runs
                    .push((scene.shapes.len() as u32, scene.materials.len() as u32 - 1));
            }
            "s" => {
                let v = l.numbers::<4>(args, "sphere")?;
                if v[3] == 0.0 {
                    return Err(l.err("sphere: radius is zero"));
                }
                push(
                    scene,
                    &l,
                    Shape::Sphere(Sphere {
                        center: Vec3::new(v[0], v[1], v[2]),
                        radius: v[3],
                    }),
                )?;
            }
            "c" => {
                // The SPD's own format puts base and apex on two lines after `c`; the SPD
                // generators of this distribution write all eight numbers on the `c` line.
                // Both are read, as the original token-stream readers did.
                let (b, a) = if args.is_empty() {
                    let w = l.expect_words("cone base 'x y z r'", start)?;
                    let b = l.numbers::<4>(&w, "cone base")?;
                    let w = l.expect_words("cone apex 'x y z r'", start)?;
                    (b, l.numbers::<4>(&w, "cone apex")?)
                } else {
                    let v = l.numbers::<8>(args, "cone 'bx by bz br ax ay az ar'")?;
                    ([v[0], v[1], v[2], v[3]], [v[4], v[5], v[6], v[7]])
                };
                let (base, apex) = (Vec3::new(b[0], b[1], b[2]), Vec3::new(a[0], a[1], a[2]));
                if base == apex {
                    return Err(l.err("cone: base and apex coincide"));
                }
                push(
                    scene,
                    &l,
                    Shape::Cone(Cone {
                        base,
                        base_radius: b[3],
                        apex,
                        apex_radius: a[3],
                    }),
                )?;
            }
            kw @ ("p" | "pp") => {
                let patch = kw == "pp";
                let n = polygon_count(&l, args)?;
                let mut pts = Vec::with_capacity(n.min(1024));
                let mut normals = Vec::new();
                for k in 0..n {
                    let what = format!("vertex {} of {n}", k + 1);
                    let w = l.expect_words(&what, start)?;
                    if patch {
                        let v = l.numbers::<6>(&w, &what)?;
                        pts.push(Vec3::new(v[0], v[1], v[2]));
                        normals.push(Vec3::new(v[3], v[4], v[5]));
                    } else {
                        pts.push(l.vec3(&w, &what)?);
                    }
                }
                for t in triangulate_polygon(&pts) {
                    let v = t.map(|i| pts[i]);
                    let shape = if patch {
                        scene.patch_normals.push(t.map(|i| normals[i]));
                        Shape::Patch {
                            v,
                            normals: scene.patch_normals.len() as u32 - 1,
                        }
                    } else {
                        Shape::Triangle(v)
                    };
                    push(scene, &l, shape)?;
                }
            }
            other => return Err(l.err(format!("unknown keyword '{other}'"))),
        }
    }
    if let Some(m) = defining {
        return Err(SceneError::parse(
            path,
            l.line + 1,
            format!(
                "unexpected end of file: definition of '{}' not ended",
                m.name
            ),
        ));
    }
    // Uncoloured lights share the unit intensity: each gets 1/sqrt(number of lights), the
    // common SPD renderer rule, so scenes with many lights do not wash out.
    let scale = 1.0 / (pending_lights.len().max(1) as f32).sqrt();
    scene.lights = pending_lights
        .into_iter()
        .map(|(position, color)| Light {
            position,
            color: color.unwrap_or(Vec3::splat(scale)),
        })
        .collect();
    if scene.materials.is_empty() {
        scene.materials.push(Material::default());
        scene.material_runs.push((0, 0));
    }
    models.push(Model {
        name: "world".into(),
        scene,
        instances: world_instances,
    });
    let mut instanced = InstancedScene { models };
    if !have_view {
        let b = instanced.bounds();
        if !b.is_empty() {
            let world = instanced.models.last_mut().expect("the world");
            world.scene.camera = Camera::framing(&b);
        }
    }
    Ok(instanced)
}

/// An instance's transform: twelve numbers, the rows of `[M | t]` (`p' = M·p + t`), or steps
/// applied to the model in the order written: `translate x y z`, `rotate ax ay az degrees`
/// (about an axis through the origin, counter-clockwise looking down the axis), `scale s` or
/// `scale sx sy sz` (negative for a mirror).
fn parse_transform(l: &Lines, words: &[&str]) -> Result<Affine3A, SceneError> {
    if words.len() == 12 && words[0].parse::<f32>().is_ok() {
        let v = l.numbers::<12>(words, "instance transform")?;
        return Ok(Affine3A::from_mat3_translation(
            Mat3::from_cols_array(&[v[0], v[4], v[8], v[1], v[5], v[9], v[2], v[6], v[10]]),
            Vec3::new(v[3], v[7], v[11]),
        ));
    }
    let mut t = Affine3A::IDENTITY;
    let mut rest = words;
    while let Some((step, after)) = rest.split_first() {
        let take = |n: usize| {
            if after.len() < n {
                Err(l.err(format!("instance: '{step}' expects {n} numbers")))
            } else {
                Ok(&after[..n])
            }
        };
        let (next, used) = match *step {
            "translate" => (
                Affine3A::from_translation(l.vec3(take(3)?, "translate")?),
                3,
            ),
            "rotate" => {
                let v = l.numbers::<4>(take(4)?, "rotate")?;
                let axis = Vec3::new(v[0], v[1], v[2]);
                if axis.length_squared() == 0.0 {
                    return Err(l.err("rotate: the axis is zero"));
                }
                (
                    Affine3A::from_axis_angle(axis.normalize(), v[3].to_radians()),
                    4,
                )
            }
            "scale" => {
                let three = after.len() >= 3 && after[..3].iter().all(|w| w.parse::<f32>().is_ok());
                if three {
                    (Affine3A::from_scale(l.vec3(&after[..3], "scale")?), 3)
                } else {
                    let [s] = l.numbers::<1>(take(1)?, "scale")?;
                    (Affine3A::from_scale(Vec3::splat(s)), 1)
                }
            }
            other => {
                return Err(l.err(format!(
                    "instance: '{other}' is not a transform step (translate, rotate, scale, or twelve numbers)"
                )));
            }
        };
        t = next * t;
        rest = &after[used..];
    }
    Ok(t)
}

fn push(scene: &mut Scene, l: &Lines, shape: Shape) -> Result<(), SceneError> {
    if scene.shapes.len() >= u32::MAX as usize - 1 {
        return Err(l.err("more than 2^32-2 primitives"));
    }
    if scene.material_runs.is_empty() {
        scene.materials.push(Material::default());
        scene.material_runs.push((0, 0));
    }
    scene.shapes.push(shape);
    Ok(())
}

fn polygon_count(l: &Lines, args: &[&str]) -> Result<usize, SceneError> {
    let [w] = args else {
        return Err(l.err("polygon: expected one vertex count"));
    };
    let n: usize = w
        .parse()
        .map_err(|_| l.err(format!("polygon: '{w}' is not a vertex count")))?;
    if !(3..=MAX_POLYGON_VERTICES).contains(&n) {
        return Err(l.err(format!(
            "polygon: vertex count {n} outside 3..={MAX_POLYGON_VERTICES}"
        )));
    }
    Ok(n)
}

/// The `N` numbers of the view's `key` line, read and checked on that line, so that an
/// error names it.
fn view_field<const N: usize>(
    l: &mut Lines,
    key: &str,
    start: usize,
) -> Result<[f32; N], SceneError> {
    let w = l.expect_words(&format!("'{key}' line of the view"), start)?;
    if w[0] != key {
        return Err(l.err(format!("view: expected '{key}', found '{}'", w[0])));
    }
    l.numbers::<N>(&w[1..], key)
}

fn parse_view(l: &mut Lines, start: usize) -> Result<Camera, SceneError> {
    let from = Vec3::from_array(view_field::<3>(l, "from", start)?);
    let at = Vec3::from_array(view_field::<3>(l, "at", start)?);
    let up = Vec3::from_array(view_field::<3>(l, "up", start)?);
    let [fov] = view_field::<1>(l, "angle", start)?;
    if !(fov > 0.0 && fov < 180.0) {
        return Err(l.err(format!("view: angle {fov} outside (0, 180)")));
    }
    view_field::<1>(l, "hither", start)?;
    let [w, h] = view_field::<2>(l, "resolution", start)?;
    let size =
        |x: f32| (x >= 1.0 && x <= MAX_RESOLUTION as f32 && x.fract() == 0.0).then_some(x as u32);
    let (Some(width), Some(height)) = (size(w), size(h)) else {
        return Err(l.err(format!(
            "view: resolution '{w} {h}' is not two whole numbers in 1..={MAX_RESOLUTION}"
        )));
    };
    if from == at || (at - from).cross(up) == Vec3::ZERO {
        return Err(l.err("view: 'from' equals 'at', or 'up' is parallel to the view direction"));
    }
    Ok(Camera {
        from,
        at,
        up,
        fov_deg: fov,
        width,
        height,
    })
}
