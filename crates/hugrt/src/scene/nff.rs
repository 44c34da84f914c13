//! NFF (Neutral File Format) of the SPD scenes, every keyword the SPD files use
//! (`docs/nff-and-spd.md`): `v` view block, `b`, `l`, `f`, `s`, `c`, `p`, `pp`, `#`.

use super::{Camera, Light, MAX_RESOLUTION, Material, Scene, SceneError, finite};
use crate::geometry::{Cone, Shape, Sphere, Vec3, triangulate_polygon};

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

pub fn parse(path: &str, data: &[u8]) -> Result<Scene, SceneError> {
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
    while let Some(words) = l.next_words() {
        let start = l.line;
        let args = &words[1..];
        match words[0] {
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
                    &mut scene,
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
                    &mut scene,
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
                    push(&mut scene, &l, shape)?;
                }
            }
            other => return Err(l.err(format!("unknown keyword '{other}'"))),
        }
    }
    if !have_view {
        let b = scene.bounds();
        if !b.is_empty() {
            scene.camera = Camera::framing(&b);
        }
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
    Ok(scene)
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
