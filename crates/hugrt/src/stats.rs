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

/// What `hugrt stats` reports: the scene's statistics and the structure's, with the build
/// time. Its JSON (`docs/output-formats.md`) holds `scene`, `accel`, `scene_stats`,
/// `build_seconds`, `scene_memory_bytes`, `structure` (the structure's named figures as one
/// object), `levels` and `depths`; fields are only ever added.
#[derive(Clone, Debug)]
pub struct StatsReport {
    pub scene: String,
    pub accel: String,
    pub scene_stats: SceneStats,
    pub scene_memory_bytes: usize,
    pub build_seconds: f64,
    pub structure: crate::accel::StructureStats,
}

impl StatsReport {
    /// Opens the scene `name` ([`crate::scene::InstancedScene::open`]), builds `spec` over
    /// it and gathers both statistics. A scene of instances is built as a
    /// [`crate::world::World`]: its scene statistics are the world model's objects (its own
    /// primitives and its instances), its structure's those of the top level with the
    /// world's counts ahead (`models`, `instances`, `flattened_primitives`, ...).
    pub fn measure(name: &str, spec: &str) -> Result<StatsReport, crate::Error> {
        crate::accel::AnyAccel::check(spec).map_err(|e| crate::Error::spec(spec, e))?;
        let instanced = crate::scene::InstancedScene::open(name)?;
        let scene = match instanced.into_flat() {
            Ok(scene) => scene,
            Err(instanced) => return Self::measure_world(name, spec, instanced),
        };
        let scene_stats = scene_stats(&scene);
        let t = std::time::Instant::now();
        let accel =
            crate::accel::AnyAccel::build(&scene, spec).map_err(|e| crate::Error::spec(spec, e))?;
        let build_seconds = t.elapsed().as_secs_f64();
        Ok(StatsReport {
            scene: name.to_string(),
            accel: spec.to_string(),
            scene_stats,
            scene_memory_bytes: scene.memory_bytes(),
            build_seconds,
            structure: accel.stats(),
        })
    }
}

impl StatsReport {
    /// [`StatsReport::measure`] of a scene of instances.
    fn measure_world(
        name: &str,
        spec: &str,
        scene: crate::scene::InstancedScene,
    ) -> Result<StatsReport, crate::Error> {
        let t = std::time::Instant::now();
        let world = crate::world::World::build(scene, spec)?;
        let build_seconds = t.elapsed().as_secs_f64();
        Ok(StatsReport {
            scene: name.to_string(),
            accel: spec.to_string(),
            scene_stats: scene_stats(&world.top().1),
            scene_memory_bytes: world.scene_memory_bytes(),
            build_seconds,
            structure: world.stats(),
        })
    }
}

impl Serialize for StatsReport {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeStruct;
        /// The structure's named figures as one object, in their order.
        struct Entries<'a>(&'a [(String, f64)]);
        impl Serialize for Entries<'_> {
            fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
                s.collect_map(self.0.iter().map(|(k, v)| (k, v)))
            }
        }
        let mut r = s.serialize_struct("StatsReport", 8)?;
        r.serialize_field("scene", &self.scene)?;
        r.serialize_field("accel", &self.accel)?;
        r.serialize_field("scene_stats", &self.scene_stats)?;
        r.serialize_field("build_seconds", &self.build_seconds)?;
        r.serialize_field("scene_memory_bytes", &self.scene_memory_bytes)?;
        r.serialize_field("structure", &Entries(&self.structure.entries))?;
        r.serialize_field("levels", &self.structure.levels)?;
        r.serialize_field("depths", &self.structure.depths)?;
        r.end()
    }
}
