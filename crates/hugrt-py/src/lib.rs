//! hugrt for Python: scenes from numpy arrays or files, every structure with keyword
//! settings, and batch ray queries with numpy arrays in and out, traced on hugrt's threads
//! with the interpreter's lock released. The Python package (`python/hugrt`) re-exports these
//! classes and adds the trimesh backend and the Ray tasks; `_hugrt.pyi` types them.

mod arrays;
mod render;

use arrays::{Rays, ints_n3, reals_n3};
use hugrt::accel::{AnyAccel, Hit, MAX_PACKET, NoCounters, Packets};
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

/// A scene: primitives, materials, lights and a camera.
#[pyclass(frozen, module = "hugrt")]
struct Scene {
    inner: Arc<hugrt::scene::Scene>,
}

#[pymethods]
impl Scene {
    /// A triangle mesh from `vertices` (n × 3 floats) and `faces` (m × 3 integer indices into
    /// the vertices); triangle `i` is `faces[i]`.
    #[staticmethod]
    fn from_arrays(vertices: &Bound<'_, PyAny>, faces: &Bound<'_, PyAny>) -> PyResult<Scene> {
        let points = reals_n3(vertices, "vertices")?;
        let faces = ints_n3(faces, "faces")?;
        let mut triangles = Vec::with_capacity(faces.len());
        for (i, f) in faces.iter().enumerate() {
            let mut t = [0u32; 3];
            for (k, &v) in f.iter().enumerate() {
                t[k] = u32::try_from(v)
                    .ok()
                    .filter(|&v| (v as usize) < points.len())
                    .ok_or_else(|| {
                        PyValueError::new_err(format!(
                            "faces[{i}] refers to vertex {v}: there are {} vertices",
                            points.len()
                        ))
                    })?;
            }
            triangles.push(t);
        }
        if let Some((i, p)) = points.iter().enumerate().find(|(_, p)| !p.is_finite()) {
            return Err(PyValueError::new_err(format!(
                "vertices[{i}] = {p} is not finite"
            )));
        }
        let mesh = hugrt::scene::Mesh::new(points, triangles)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        Ok(Scene::of(hugrt::scene::Scene::from_mesh(mesh)))
    }

    /// A scene by name: a file (`.nff`, `.ply`, `.obj`, `.stl`, `.gltf`, `.glb`, each optionally gzipped) or
    /// `builtin:KIND[:SIZE]` (`hugrt gen`'s kinds, `builtin:room[:TRIANGLES]`).
    #[staticmethod]
    fn open(py: Python<'_>, name: &str) -> PyResult<Scene> {
        let scene = py
            .detach(|| hugrt::scene::Scene::open(name))
            .map_err(scene_error)?;
        Ok(Scene::of(scene))
    }

    /// Builds a structure over the scene: `structure` is one of `hugrt.structures()` (or a
    /// whole spec, `"grid:density=8"`, as the CLI takes it), each keyword one of its settings
    /// (`hugrt.settings(structure)`), e.g. `scene.build("hug", preset="eg95")` or
    /// `scene.build("grid", density=8)`.
    #[pyo3(signature = (structure, **settings))]
    fn build(
        &self,
        py: Python<'_>,
        structure: &str,
        settings: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Accel> {
        let spec = spec_of(structure, settings)?;
        let scene = self.inner.clone();
        let accel = py
            .detach(|| AnyAccel::build(&*scene, &spec))
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        Ok(Accel { scene, accel, spec })
    }

    fn __len__(&self) -> usize {
        self.inner.len()
    }

    /// The scene's bounding box as two arrays of 3 floats, `(min, max)`.
    #[getter]
    fn bounds<'py>(
        &self,
        py: Python<'py>,
    ) -> (Bound<'py, PyArray1<f32>>, Bound<'py, PyArray1<f32>>) {
        let b = self.inner.bounds();
        (
            b.min.to_array().to_vec().into_pyarray(py),
            b.max.to_array().to_vec().into_pyarray(py),
        )
    }

    /// Bytes held by the scene's primitives, materials and normals.
    #[getter]
    fn memory_bytes(&self) -> usize {
        self.inner.memory_bytes()
    }

    /// Rays as embree-peer's `gen_rays.py incoherent` makes them: origins uniform in the
    /// scene's box, directions uniform on the sphere; `(origins, directions)`, n × 3 float32.
    #[pyo3(signature = (n, seed = 1))]
    fn incoherent_rays<'py>(
        &self,
        py: Python<'py>,
        n: usize,
        seed: u64,
    ) -> (Bound<'py, PyArray2<f32>>, Bound<'py, PyArray2<f32>>) {
        arrays::rays_out(
            py,
            &hugrt::batch::incoherent_rays(&self.inner.bounds(), n, seed),
        )
    }

    /// Pinhole rays as `gen_rays.py camera` makes them (the scene's box framed from outside,
    /// 45°), row by row from the top; `(origins, directions)`, (w·h) × 3 float32.
    fn camera_rays<'py>(
        &self,
        py: Python<'py>,
        width: u32,
        height: u32,
    ) -> (Bound<'py, PyArray2<f32>>, Bound<'py, PyArray2<f32>>) {
        arrays::rays_out(
            py,
            &hugrt::batch::camera_rays(&self.inner.bounds(), width, height),
        )
    }

    fn __repr__(&self) -> String {
        let b = self.inner.bounds();
        format!(
            "hugrt.Scene({} primitives, bounds {} to {})",
            self.inner.len(),
            b.min,
            b.max
        )
    }
}

impl Scene {
    fn of(scene: hugrt::scene::Scene) -> Scene {
        Scene {
            inner: Arc::new(scene),
        }
    }
}

/// The spec string of a structure and its keyword settings; Python's `True`/`False` become
/// `true`/`false`, and a value that would break the spec's syntax is refused.
fn spec_of(structure: &str, settings: Option<&Bound<'_, PyDict>>) -> PyResult<String> {
    let mut spec = structure.to_string();
    let Some(settings) = settings else {
        return Ok(spec);
    };
    // A structure given as a whole spec (`grid:density=8`) takes the keywords after its own.
    let mut first = !structure.contains(':');
    for (key, value) in settings.iter() {
        let key: String = key.extract()?;
        let value = if let Ok(b) = value.cast::<pyo3::types::PyBool>() {
            b.is_true().to_string()
        } else {
            value.str()?.to_string()
        };
        if value.contains([',', '=', ':']) || value.is_empty() {
            return Err(PyValueError::new_err(format!(
                "setting {key}={value:?}: not a value of a structure's setting"
            )));
        }
        spec.push(if first { ':' } else { ',' });
        first = false;
        spec.push_str(&format!("{key}={value}"));
    }
    Ok(spec)
}

/// A structure built over a scene, answering batch queries.
#[pyclass(frozen, module = "hugrt")]
struct Accel {
    scene: Arc<hugrt::scene::Scene>,
    accel: AnyAccel,
    spec: String,
}

/// Thread pools by size, built once: a call with `threads=n` runs on the pool of `n`.
fn pool(threads: Option<usize>) -> PyResult<Option<Arc<rayon::ThreadPool>>> {
    static POOLS: Mutex<Option<HashMap<usize, Arc<rayon::ThreadPool>>>> = Mutex::new(None);
    let Some(n) = threads else {
        return Ok(None);
    };
    if n == 0 {
        return Err(PyValueError::new_err("threads must be at least 1"));
    }
    let mut pools = POOLS.lock().unwrap_or_else(|e| e.into_inner());
    let pools = pools.get_or_insert_with(HashMap::new);
    if let Some(p) = pools.get(&n) {
        return Ok(Some(p.clone()));
    }
    let p = rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .build()
        .map_err(|e| PyOSError::new_err(format!("cannot start {n} threads: {e}")))?;
    let p = Arc::new(p);
    pools.insert(n, p.clone());
    Ok(Some(p))
}

fn on_pool<T: Send>(pool: Option<Arc<rayon::ThreadPool>>, f: impl FnOnce() -> T + Send) -> T {
    match pool {
        Some(p) => p.install(f),
        None => f(),
    }
}

/// The `packets` keyword: `auto`, `on` or `off`.
fn packets_mode(s: &str) -> PyResult<Packets> {
    s.parse().map_err(PyValueError::new_err)
}

/// Rays per rayon task: enough to pay for the task, few enough to balance two threads.
const RAYS_PER_TASK: usize = 512;

#[pymethods]
impl Accel {
    /// The closest hit of every ray `origins[i] + t·directions[i]`, `t` in `[tmin, tmax]`
    /// (scalars or one per ray). Returns `(t, primitive, u, v)`: float32 `t` (inf on a miss),
    /// int64 primitive index (-1 on a miss) and the barycentric weights of a triangle's
    /// vertices 1 and 2 at the hit (0 for other primitives and misses; all 0 with
    /// `barycentrics=False`, which spares computing them: a sixth of a fast query's time).
    /// `packets`: `"auto"` walks neighbouring rays (eight at a time, in array order) together
    /// where they are coherent and the structure's packets pay, `"on"` wherever there are two,
    /// `"off"` one at a time; the hits are the same either way.
    #[pyo3(signature = (origins, directions, tmin = None, tmax = None, threads = None, barycentrics = true, packets = "auto"))]
    #[allow(clippy::type_complexity, clippy::too_many_arguments)]
    fn intersect<'py>(
        &self,
        py: Python<'py>,
        origins: &Bound<'py, PyAny>,
        directions: &Bound<'py, PyAny>,
        tmin: Option<&Bound<'py, PyAny>>,
        tmax: Option<&Bound<'py, PyAny>>,
        threads: Option<usize>,
        barycentrics: bool,
        packets: &str,
    ) -> PyResult<(
        Bound<'py, PyArray1<f32>>,
        Bound<'py, PyArray1<i64>>,
        Bound<'py, PyArray1<f32>>,
        Bound<'py, PyArray1<f32>>,
    )> {
        let rays = Rays::read(origins, directions, tmin, tmax)?;
        let packets = packets_mode(packets)?;
        let pool = pool(threads)?;
        let n = rays.len();
        let (mut t, mut prim, mut u, mut v) =
            (vec![0f32; n], vec![0i64; n], vec![0f32; n], vec![0f32; n]);
        py.detach(|| {
            on_pool(pool, || {
                (
                    t.par_chunks_mut(MAX_PACKET),
                    prim.par_chunks_mut(MAX_PACKET),
                    u.par_chunks_mut(MAX_PACKET),
                    v.par_chunks_mut(MAX_PACKET),
                )
                    .into_par_iter()
                    .with_min_len(RAYS_PER_TASK / MAX_PACKET)
                    .enumerate()
                    .for_each(|(c, (t, prim, u, v))| {
                        let group = &rays.group(c * MAX_PACKET, t.len())[..t.len()];
                        let hits = &mut [None; MAX_PACKET][..group.len()];
                        let scene = &*self.scene;
                        self.accel
                            .closest_hits(scene, group, packets, hits, &mut NoCounters);
                        for (k, (h, ray)) in hits.iter().zip(group).enumerate() {
                            match h {
                                Some(h) if barycentrics => {
                                    let d = h.details(scene, ray);
                                    (t[k], prim[k], u[k], v[k]) = (h.t, h.prim as i64, d.u, d.v);
                                }
                                Some(h) => (t[k], prim[k]) = (h.t, h.prim as i64),
                                None => (t[k], prim[k]) = (f32::INFINITY, -1),
                            }
                        }
                    })
            })
        });
        Ok((
            t.into_pyarray(py),
            prim.into_pyarray(py),
            u.into_pyarray(py),
            v.into_pyarray(py),
        ))
    }

    /// Whether anything blocks each ray in `[tmin, tmax]`: a bool array (shadow rays, line
    /// of sight). `packets` as for [`Accel::intersect`].
    #[pyo3(signature = (origins, directions, tmin = None, tmax = None, threads = None, packets = "auto"))]
    #[allow(clippy::too_many_arguments)]
    fn occluded<'py>(
        &self,
        py: Python<'py>,
        origins: &Bound<'py, PyAny>,
        directions: &Bound<'py, PyAny>,
        tmin: Option<&Bound<'py, PyAny>>,
        tmax: Option<&Bound<'py, PyAny>>,
        threads: Option<usize>,
        packets: &str,
    ) -> PyResult<Bound<'py, PyArray1<bool>>> {
        let rays = Rays::read(origins, directions, tmin, tmax)?;
        let packets = packets_mode(packets)?;
        let pool = pool(threads)?;
        let mut out = vec![false; rays.len()];
        py.detach(|| {
            on_pool(pool, || {
                out.par_chunks_mut(MAX_PACKET)
                    .with_min_len(RAYS_PER_TASK / MAX_PACKET)
                    .enumerate()
                    .for_each(|(c, o)| {
                        let group = &rays.group(c * MAX_PACKET, o.len())[..o.len()];
                        let hits = &mut [None; MAX_PACKET][..group.len()];
                        self.accel
                            .any_hits(&*self.scene, group, packets, hits, &mut NoCounters);
                        for (o, h) in o.iter_mut().zip(hits.iter()) {
                            *o = h.is_some();
                        }
                    })
            })
        });
        Ok(out.into_pyarray(py))
    }

    /// Every hit of every ray in `[tmin, tmax]`, in order of `t` (ties by primitive), as
    /// flat arrays: `(offsets, t, primitive, u, v)`, ray `i`'s hits at
    /// `offsets[i]:offsets[i + 1]` (int64 offsets, n + 1 of them).
    #[pyo3(signature = (origins, directions, tmin = None, tmax = None, threads = None))]
    #[allow(clippy::type_complexity)]
    fn intersect_all<'py>(
        &self,
        py: Python<'py>,
        origins: &Bound<'py, PyAny>,
        directions: &Bound<'py, PyAny>,
        tmin: Option<&Bound<'py, PyAny>>,
        tmax: Option<&Bound<'py, PyAny>>,
        threads: Option<usize>,
    ) -> PyResult<(
        Bound<'py, PyArray1<i64>>,
        Bound<'py, PyArray1<f32>>,
        Bound<'py, PyArray1<i64>>,
        Bound<'py, PyArray1<f32>>,
        Bound<'py, PyArray1<f32>>,
    )> {
        let rays = Rays::read(origins, directions, tmin, tmax)?;
        let pool = pool(threads)?;
        // One flat buffer per task of rays rather than a vector per ray: on camera rays, where
        // most rays hit once or never, the allocations were most of the call.
        type Chunk = (Vec<i64>, Vec<f32>, Vec<i64>, Vec<f32>, Vec<f32>);
        let chunks: Vec<Chunk> = py.detach(|| {
            on_pool(pool, || {
                let starts: Vec<usize> = (0..rays.len()).step_by(RAYS_PER_TASK).collect();
                starts
                    .into_par_iter()
                    .map(|start| {
                        let end = (start + RAYS_PER_TASK).min(rays.len());
                        let mut c: Chunk = Default::default();
                        let mut hits: Vec<Hit> = Vec::new();
                        for i in start..end {
                            let ray = rays.ray(i);
                            hits.clear();
                            self.accel
                                .for_each_hit(&*self.scene, &ray, &mut NoCounters, |h| {
                                    hits.push(h);
                                    std::ops::ControlFlow::Continue(())
                                });
                            hits.sort_by(Hit::order);
                            for h in &hits {
                                let d = h.details(&*self.scene, &ray);
                                c.1.push(h.t);
                                c.2.push(h.prim as i64);
                                c.3.push(d.u);
                                c.4.push(d.v);
                            }
                            c.0.push(hits.len() as i64);
                        }
                        c
                    })
                    .collect()
            })
        });
        let total: usize = chunks.iter().map(|c| c.1.len()).sum();
        let mut offsets = Vec::with_capacity(rays.len() + 1);
        let (mut t, mut prim, mut u, mut v) = (
            Vec::with_capacity(total),
            Vec::with_capacity(total),
            Vec::with_capacity(total),
            Vec::with_capacity(total),
        );
        offsets.push(0i64);
        for (counts, ct, cp, cu, cv) in chunks {
            for n in counts {
                offsets.push(offsets.last().unwrap() + n);
            }
            t.extend(ct);
            prim.extend(cp);
            u.extend(cu);
            v.extend(cv);
        }
        Ok((
            offsets.into_pyarray(py),
            t.into_pyarray(py),
            prim.into_pyarray(py),
            u.into_pyarray(py),
            v.into_pyarray(py),
        ))
    }

    /// The structure's own statistics (`hugrt stats`): a dict with its name, spec, bytes,
    /// named numbers (`entries`), Havran's cell census and, for grid hierarchies, SCG97 §3's
    /// statistics per level.
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let s = self.accel.stats();
        let d = PyDict::new(py);
        d.set_item("structure", self.accel.name())?;
        d.set_item("spec", &self.spec)?;
        d.set_item("memory_bytes", self.accel.memory_bytes())?;
        d.set_item("primitives", self.scene.len())?;
        let entries = PyDict::new(py);
        for (k, v) in &s.entries {
            entries.set_item(k, v)?;
        }
        d.set_item("entries", entries)?;
        d.set_item(
            "census",
            to_python(py, &serde_json::to_value(s.census).unwrap())?,
        )?;
        d.set_item(
            "levels",
            to_python(py, &serde_json::to_value(&s.levels).unwrap())?,
        )?;
        Ok(d)
    }

    /// Renders the scene through this structure with the SPD procedure (Whitted, `depth`
    /// bounces): float32 radiance, height × width × 3, unclamped. `rows=(y0, y1)` renders only
    /// pixel rows `y0..y1` of the image, equal to those rows of the whole image (a tile).
    #[pyo3(signature = (width = 512, height = 512, depth = 4, rows = None, threads = None))]
    fn render<'py>(
        &self,
        py: Python<'py>,
        width: u32,
        height: u32,
        depth: u32,
        rows: Option<(u32, u32)>,
        threads: Option<usize>,
    ) -> PyResult<Bound<'py, numpy::PyArray3<f32>>> {
        render::render(py, self, width, height, depth, rows, threads)
    }

    /// The spec the structure was built from, e.g. `hug:preset=eg95`.
    #[getter]
    fn spec(&self) -> &str {
        &self.spec
    }

    /// The structure's bytes (its own, not the scene's).
    #[getter]
    fn memory_bytes(&self) -> usize {
        self.accel.memory_bytes()
    }

    fn __repr__(&self) -> String {
        format!(
            "hugrt.Accel({:?} over {} primitives, {} bytes)",
            self.spec,
            self.scene.len(),
            self.accel.memory_bytes()
        )
    }
}

fn to_python<'py>(py: Python<'py>, v: &serde_json::Value) -> PyResult<Bound<'py, PyAny>> {
    use serde_json::Value as V;
    Ok(match v {
        V::Null => py.None().into_bound(py),
        V::Bool(b) => pyo3::types::PyBool::new(py, *b).to_owned().into_any(),
        V::Number(n) => match n.as_i64() {
            Some(i) => i.into_pyobject(py)?.into_any(),
            None => n.as_f64().unwrap_or(f64::NAN).into_pyobject(py)?.into_any(),
        },
        V::String(s) => s.into_pyobject(py)?.into_any(),
        V::Array(a) => {
            let l = PyList::empty(py);
            for x in a {
                l.append(to_python(py, x)?)?;
            }
            l.into_any()
        }
        V::Object(o) => {
            let d = PyDict::new(py);
            for (k, x) in o {
                d.set_item(k, to_python(py, x)?)?;
            }
            d.into_any()
        }
    })
}

fn scene_error(e: hugrt::scene::SceneError) -> PyErr {
    use hugrt::scene::SceneError as E;
    match e {
        E::Io { .. } => PyOSError::new_err(e.to_string()),
        _ => PyValueError::new_err(e.to_string()),
    }
}

/// Reads a scene file: `.nff`, `.ply`, `.obj`, `.stl`, `.gltf` or `.glb`, each optionally gzipped
/// (`Scene.open` also takes the built-in scenes' names).
#[pyfunction]
fn load(py: Python<'_>, path: std::path::PathBuf) -> PyResult<Scene> {
    let scene = py
        .detach(|| hugrt::scene::Scene::load(&path))
        .map_err(scene_error)?;
    Ok(Scene::of(scene))
}

/// Names of every structure, in hugrt's order.
#[pyfunction]
fn structures() -> Vec<&'static str> {
    hugrt::accel::STRUCTURES.to_vec()
}

/// The settings a structure takes as keywords of `Scene.build`: a list of dicts with `name`,
/// `accepts`, `default` and `help`.
#[pyfunction]
fn settings<'py>(py: Python<'py>, structure: &str) -> PyResult<Bound<'py, PyList>> {
    let keys = AnyAccel::keys(structure).ok_or_else(|| {
        PyValueError::new_err(format!(
            "unknown structure '{structure}' (there are: {})",
            hugrt::accel::STRUCTURES.join(", ")
        ))
    })?;
    let l = PyList::empty(py);
    for k in keys {
        let d = PyDict::new(py);
        d.set_item("name", k.name)?;
        d.set_item("accepts", k.accepts)?;
        d.set_item("default", k.default)?;
        d.set_item("help", k.help)?;
        l.append(d)?;
    }
    Ok(l)
}

/// Runs one of `hugrt reproduce`'s targets (`reproduce_targets()`), writing its report, data
/// and plots to `out_dir/TARGET/`; returns that folder. `spd_dir` is where the SPD scenes are
/// (`NAME.nff.gz`).
#[pyfunction]
#[pyo3(signature = (target, out_dir, quick = false, spd_dir = None))]
fn reproduce(
    py: Python<'_>,
    target: &str,
    out_dir: std::path::PathBuf,
    quick: bool,
    spd_dir: Option<std::path::PathBuf>,
) -> PyResult<std::path::PathBuf> {
    let options = hugrt::reproduce::Options {
        quick,
        spd_dir: spd_dir.unwrap_or_else(|| "../shared/scenes/spd".into()),
        hugrt_exe: None,
    };
    py.detach(|| hugrt::reproduce::run(target, &options, &out_dir))
        .map_err(|e| PyValueError::new_err(e.to_string()))
}

/// The names of `hugrt reproduce`'s targets.
#[pyfunction]
fn reproduce_targets() -> Vec<&'static str> {
    hugrt::reproduce::TARGETS.iter().map(|t| t.name).collect()
}

#[pymodule]
fn _hugrt(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Scene>()?;
    m.add_class::<Accel>()?;
    m.add_function(wrap_pyfunction!(load, m)?)?;
    m.add_function(wrap_pyfunction!(structures, m)?)?;
    m.add_function(wrap_pyfunction!(settings, m)?)?;
    m.add_function(wrap_pyfunction!(reproduce, m)?)?;
    m.add_function(wrap_pyfunction!(reproduce_targets, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
