//! numpy arrays in: points and rays as float32 or float64 (any other array-like is converted
//! by numpy first), indices as any integer type.

use hugrt::accel::MAX_PACKET;
use hugrt::geometry::{Ray, Vec3};
use numpy::{PyArray2, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// `x` as a 2-D array of `T`, converted by `numpy.asarray` where it is another dtype or not
/// an array at all.
fn array2<'py, T: numpy::Element>(
    x: &Bound<'py, PyAny>,
    dtype: &str,
) -> PyResult<PyReadonlyArray2<'py, T>> {
    if let Ok(a) = x.extract::<PyReadonlyArray2<'py, T>>() {
        return Ok(a);
    }
    let np = x.py().import("numpy")?;
    let converted = np.call_method1("asarray", (x, dtype))?;
    converted
        .extract::<PyReadonlyArray2<'py, T>>()
        .map_err(|_| {
            PyValueError::new_err(format!(
                "expected a 2-D array, got {} dimensions",
                converted
                    .getattr("ndim")
                    .and_then(|d| d.extract::<usize>())
                    .unwrap_or(0)
            ))
        })
}

fn check_n3(shape: &[usize], what: &str) -> PyResult<usize> {
    if shape.len() != 2 || shape[1] != 3 {
        return Err(PyValueError::new_err(format!(
            "{what} must have shape (n, 3), not {shape:?}"
        )));
    }
    Ok(shape[0])
}

/// An n × 3 array of reals as points (float32 arithmetic, as hugrt's geometry is).
pub fn reals_n3(x: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<Vec3>> {
    let err = |e: PyErr| PyValueError::new_err(format!("{what}: {e}"));
    if let Ok(a) = x.extract::<PyReadonlyArray2<'_, f32>>() {
        check_n3(a.shape(), what)?;
        return Ok(points(&a, |c| c));
    }
    let a = array2::<f64>(x, "float64").map_err(err)?;
    check_n3(a.shape(), what)?;
    Ok(points(&a, |c| c as f32))
}

/// Rows of an n × 3 array as points: contiguous arrays (the usual case) converted on rayon's
/// threads (a tenth of a million-ray query's time otherwise), strided ones row by row.
fn points<T: numpy::Element + Copy + Sync>(
    a: &PyReadonlyArray2<'_, T>,
    f: impl Fn(T) -> f32 + Sync,
) -> Vec<Vec3> {
    use rayon::prelude::*;
    match a.as_slice() {
        Ok(flat) => flat
            .par_chunks_exact(3)
            .with_min_len(4096)
            .map(|c| Vec3::new(f(c[0]), f(c[1]), f(c[2])))
            .collect(),
        Err(_) => a
            .as_array()
            .rows()
            .into_iter()
            .map(|r| Vec3::new(f(r[0]), f(r[1]), f(r[2])))
            .collect(),
    }
}

/// An m × 3 array of integers (any integer dtype).
pub fn ints_n3(x: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<[i64; 3]>> {
    let err = |e: PyErr| PyValueError::new_err(format!("{what}: {e}"));
    macro_rules! try_int {
        ($t:ty) => {
            if let Ok(a) = x.extract::<PyReadonlyArray2<'_, $t>>() {
                check_n3(a.shape(), what)?;
                let a = a.as_array();
                return Ok(a
                    .rows()
                    .into_iter()
                    .map(|r| [r[0] as i64, r[1] as i64, r[2] as i64])
                    .collect());
            }
        };
    }
    try_int!(i64);
    try_int!(i32);
    try_int!(u32);
    if x.is_instance_of::<PyArray2<f64>>() || x.is_instance_of::<PyArray2<f32>>() {
        return Err(PyValueError::new_err(format!(
            "{what} must be integers, not floats"
        )));
    }
    let a = array2::<i64>(x, "int64").map_err(err)?;
    check_n3(a.shape(), what)?;
    let a = a.as_array();
    Ok(a.rows().into_iter().map(|r| [r[0], r[1], r[2]]).collect())
}

/// A ray interval bound: one for all rays, or one per ray.
enum Bound1 {
    All(f32),
    Each(Vec<f32>),
}

impl Bound1 {
    fn read(x: Option<&Bound<'_, PyAny>>, default: f32, n: usize, what: &str) -> PyResult<Self> {
        let Some(x) = x else {
            return Ok(Bound1::All(default));
        };
        if let Ok(v) = x.extract::<f64>() {
            return Ok(Bound1::All(v as f32));
        }
        let np = x.py().import("numpy")?;
        let a = np.call_method1("asarray", (x, "float32"))?;
        let a: PyReadonlyArray1<'_, f32> = a.extract().map_err(|_| {
            PyValueError::new_err(format!(
                "{what} must be a number or a 1-D array of n numbers"
            ))
        })?;
        if a.len() != n {
            return Err(PyValueError::new_err(format!(
                "{what} has {} values for {n} rays",
                a.len()
            )));
        }
        Ok(Bound1::Each(a.as_array().to_vec()))
    }

    #[inline]
    fn get(&self, i: usize) -> f32 {
        match self {
            Bound1::All(v) => *v,
            Bound1::Each(v) => v[i],
        }
    }
}

/// A batch of rays read from numpy, owned so that tracing runs without the interpreter.
pub struct Rays {
    origins: Vec<Vec3>,
    directions: Vec<Vec3>,
    tmin: Bound1,
    tmax: Bound1,
}

impl Rays {
    pub fn read(
        origins: &Bound<'_, PyAny>,
        directions: &Bound<'_, PyAny>,
        tmin: Option<&Bound<'_, PyAny>>,
        tmax: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Rays> {
        let origins = reals_n3(origins, "origins")?;
        let directions = reals_n3(directions, "directions")?;
        if origins.len() != directions.len() {
            return Err(PyValueError::new_err(format!(
                "{} origins for {} directions",
                origins.len(),
                directions.len()
            )));
        }
        let n = origins.len();
        Ok(Rays {
            tmin: Bound1::read(tmin, 0.0, n, "tmin")?,
            tmax: Bound1::read(tmax, f32::INFINITY, n, "tmax")?,
            origins,
            directions,
        })
    }

    pub fn len(&self) -> usize {
        self.origins.len()
    }

    #[inline]
    pub fn ray(&self, i: usize) -> Ray {
        Ray::new(
            self.origins[i],
            self.directions[i],
            self.tmin.get(i),
            self.tmax.get(i),
        )
    }
    /// Rays `start..start + len` (`len` at most [`MAX_PACKET`], the rest of the array repeating
    /// the last), neighbours that the batch queries may walk together.
    pub fn group(&self, start: usize, len: usize) -> [Ray; MAX_PACKET] {
        std::array::from_fn(|k| self.ray(start + k.min(len.max(1) - 1)))
    }
}

/// Rays out as `(origins, directions)`, two n × 3 float32 arrays.
pub fn rays_out<'py>(
    py: Python<'py>,
    rays: &[Ray],
) -> (Bound<'py, PyArray2<f32>>, Bound<'py, PyArray2<f32>>) {
    let flat = |f: fn(&Ray) -> Vec3| {
        let v: Vec<f32> = rays.iter().flat_map(|r| f(r).to_array()).collect();
        numpy::ndarray::Array2::from_shape_vec((rays.len(), 3), v).expect("n × 3")
    };
    use numpy::IntoPyArray;
    (
        flat(|r| r.origin).into_pyarray(py),
        flat(|r| r.dir).into_pyarray(py),
    )
}
