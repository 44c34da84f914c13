//! Scene statistics of SCG97 Fig. 4: how the objects' lengths (bounding-box diagonals,
//! EG95 §2.1) are distributed, which is what decides whether a hierarchy pays.

use crate::accel::Primitives;
use crate::geometry::Aabb;
use serde::Serialize;

/// Number of bins in the length histogram (lengths as fractions of the largest).
pub const HISTOGRAM_BINS: usize = 10;

#[derive(Clone, Debug, Serialize)]
pub struct SceneStats {
    pub objects: usize,
    pub scene_diagonal: f32,
    pub min_length: f32,
    pub max_length: f32,
    /// Shortest over longest object.
    pub min_over_max: f32,
    /// Shortest object over the scene's diagonal.
    pub min_over_diagonal: f32,
    /// Share of objects shorter than 20% of the longest ("%.2" in SCG97).
    pub percent_below_0_2: f32,
    /// Counts of objects whose length / max length falls in `[k/10, (k+1)/10)`.
    pub histogram: [usize; HISTOGRAM_BINS],
}

pub fn scene_stats<P: Primitives>(prims: &P) -> SceneStats {
    let boxes: Vec<Aabb> = (0..prims.len()).map(|i| prims.bounds(i)).collect();
    let scene = boxes.iter().fold(Aabb::EMPTY, |a, b| a.union(b));
    let lengths: Vec<f32> = boxes.iter().map(Aabb::diagonal).collect();
    let max = lengths.iter().cloned().fold(0.0f32, f32::max);
    let min = lengths.iter().cloned().fold(f32::INFINITY, f32::min);
    let mut histogram = [0usize; HISTOGRAM_BINS];
    let mut below = 0;
    for &l in &lengths {
        let f = if max > 0.0 { l / max } else { 0.0 };
        histogram[((f * HISTOGRAM_BINS as f32) as usize).min(HISTOGRAM_BINS - 1)] += 1;
        below += (f < 0.2) as usize;
    }
    let n = lengths.len();
    let ratio = |a: f32, b: f32| if b > 0.0 && a.is_finite() { a / b } else { 0.0 };
    SceneStats {
        objects: n,
        scene_diagonal: scene.diagonal(),
        min_length: if n == 0 { 0.0 } else { min },
        max_length: max,
        min_over_max: ratio(min, max),
        min_over_diagonal: ratio(min, scene.diagonal()),
        percent_below_0_2: if n == 0 {
            0.0
        } else {
            100.0 * below as f32 / n as f32
        },
        histogram,
    }
}
