//! `Accel.render`: the SPD rendering as float radiance, whole or a band of rows.

use super::{Accel, on_pool, pool};
use hugrt::render::{RenderSettings, check_image, render_rows};
use numpy::PyArray3;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

pub fn render<'py>(
    py: Python<'py>,
    accel: &Accel,
    width: u32,
    height: u32,
    depth: u32,
    rows: Option<(u32, u32)>,
    threads: Option<usize>,
) -> PyResult<Bound<'py, PyArray3<f32>>> {
    check_image(Some(width), Some(height), None)
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    let (y0, y1) = rows.unwrap_or((0, height));
    if y0 >= y1 || y1 > height {
        return Err(PyValueError::new_err(format!(
            "rows ({y0}, {y1}) of an image {height} high: need 0 <= y0 < y1 <= {height}"
        )));
    }
    let settings = RenderSettings {
        width,
        height,
        depth,
        counters: false,
        packets: Default::default(),
    };
    let pool = pool(threads)?;
    let radiance = py.detach(|| {
        on_pool(pool, || {
            render_rows(&accel.scene, &accel.accel, &settings, y0..y1, &|_| {}).radiance
        })
    });
    let flat: Vec<f32> = radiance.iter().flat_map(|c| c.to_array()).collect();
    let a = numpy::ndarray::Array3::from_shape_vec(((y1 - y0) as usize, width as usize, 3), flat)
        .expect("rows × width × 3");
    Ok(numpy::IntoPyArray::into_pyarray(a, py))
}
