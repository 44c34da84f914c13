//! The laboratory's measurement: structures compared on the same work (Havran §4.1.1).
//!
//! For one scene and several structures, [`bench_scene`] measures each structure on the same
//! rays — camera rays, incoherent rays, or the SPD Whitted rendering — and reports:
//!
//! - times with their spread: build (`T_CB`) and trace or render (`T_TR`), the median and the
//!   extremes of `repeat` runs (the builds after one untimed build), and Mrays/s from the
//!   median;
//! - Havran's septet Δ = ⟨N_C, R_ETNC, N_ADC, N_AOIFC, R_FVWV, N_RPRT, N_TAC⟩ (eq. 5): the
//!   first five from the structure's cells ([`CellCensus`]), the last two from the counters
//!   (with `N_AT = N_TAC / rays` beside them, the per-ray form of his tables);
//! - the triplet Λ = ⟨T_CB, T_TR, T_TT/T_TR⟩ (eq. 6);
//! - the papers' counters #pit, #pi, #bbi, #vt per ray, in total and per hierarchy level, from
//!   a separate untimed pass: counts do not depend on timing (SCG97 §4);
//! - agreement with the first structure: rays whose nearest primitive differs (and whose `t`
//!   differs too, which allows exact ties), or for Whitted renderings pixels whose colour
//!   differs. Every structure must give the same answers; any difference is a bug (Havran
//!   §4.1.1: "the result of both rendering processes has to be the same image").
//!
//! How `T_TT`, the time spent in the structure, is measured: the image is rendered once more
//! with every query answered from a record of the first rendering ([`render_replayed`]); that
//! rendering does all the work of the image but ask the structure, so `T_TT = T_TR − T_replay`
//! (medians of `repeat` runs each). `T_TT` therefore holds traversal and the intersection tests
//! the structure makes, which is what Havran's `T_TT < T_TR` compares across structures. For
//! batches of rays all the time is in the structure, and `T_TT/T_TR` is not reported.

use crate::accel::{
    AnyAccel, COUNTERS, CellCensus, Counts, Hit, PIT, Packets, RayCounters, SpecError, VT,
};
use crate::batch::{camera_rays, count, incoherent_rays, trace_into};
use crate::geometry::Ray;
use crate::render::{
    RenderSettings, Rendered, SoftShadows, render_recorded, render_replayed, render_soft,
};
use crate::scene::Scene;
use serde::Serialize;
use std::time::Instant;

/// The rays every structure answers.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Workload {
    /// Pinhole rays through pixel centres ([`camera_rays`]), `side²` of them.
    Camera { side: u32 },
    /// Origins uniform in the box, directions uniform on the sphere ([`incoherent_rays`]).
    Incoherent { rays: usize },
    /// The SPD Whitted rendering from the scene's camera.
    Whitted {
        width: Option<u32>,
        height: Option<u32>,
        depth: u32,
        /// Soft shadows with this light radius (fraction of the scene diagonal).
        soft_shadows: Option<f32>,
    },
}

/// One structure to measure: a name for the tables and how to build it.
pub struct Candidate<'a> {
    pub label: String,
    pub build: Box<dyn Fn() -> Result<AnyAccel, SpecError> + Sync + 'a>,
    /// The spec for the soft shadows' structure, when the workload has soft shadows.
    pub spec: String,
    /// When camera and Whitted rays are walked as packets.
    pub packets: Packets,
}

impl<'a> Candidate<'a> {
    /// The structure a spec names, over the scene.
    pub fn spec(scene: &'a Scene, spec: &str) -> Self {
        let s = spec.to_string();
        Candidate {
            label: spec.to_string(),
            build: Box::new(move || AnyAccel::build(scene, &s)),
            spec: spec.to_string(),
            packets: Packets::default(),
        }
    }

    /// The structure a spec names, every ray walked alone: the papers' measurement, whose
    /// counters (#pit, #vt, SCG97 §3) are one ray's walk; a packet's differ (a cell met once
    /// for its rays, more triangles tested), though not its hits.
    pub fn alone(scene: &'a Scene, spec: &str) -> Self {
        Candidate {
            packets: Packets::Off,
            ..Candidate::spec(scene, spec)
        }
    }

    /// A row's name for `spec` measured with `packets`: the spec, with ` packets=MODE` after
    /// it when the mode is not the default or when `always` (several modes are compared).
    pub fn label_of(spec: &str, packets: Packets, always: bool) -> String {
        if always || packets != Packets::default() {
            format!("{spec} packets={packets}")
        } else {
            spec.to_string()
        }
    }
}

/// What `hugrt bench` measures when no scene is named: built in, so that it runs anywhere.
pub const DEFAULT_SCENES: &[&str] = &[
    "builtin:kitchen",
    "builtin:building",
    "builtin:stadium",
    "builtin:room:1000000",
];

/// Median and extremes of repeated timings, in milliseconds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Timing {
    pub median_ms: f64,
    pub min_ms: f64,
    pub max_ms: f64,
}

impl Timing {
    /// From seconds; the upper median of an even count.
    pub fn from_secs(mut secs: Vec<f64>) -> Timing {
        if secs.is_empty() {
            return Timing::default();
        }
        secs.sort_by(f64::total_cmp);
        Timing {
            median_ms: secs[secs.len() / 2] * 1e3,
            min_ms: secs[0] * 1e3,
            max_ms: secs[secs.len() - 1] * 1e3,
        }
    }

    /// Relative spread `(max − min) / median`.
    pub fn spread(&self) -> f64 {
        if self.median_ms > 0.0 {
            (self.max_ms - self.min_ms) / self.median_ms
        } else {
            0.0
        }
    }
}

/// Havran's septet Δ (eq. 5), with `N_AT` beside `N_TAC`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Septet {
    /// Cells (or nodes).
    pub n_c: usize,
    /// Empty cells over all cells.
    pub r_etnc: f64,
    /// Object references per object minus one: how often an object is duplicated.
    pub n_adc: f64,
    /// Object references per full cell.
    pub n_aoifc: f64,
    /// Volume of the full cells over the scene's volume.
    pub r_fvwv: f64,
    /// Ray–object tests over the hits: 1 is a perfect structure.
    pub n_rprt: f64,
    /// Cells (elementary and hierarchical) traversed by all rays.
    pub n_tac: u64,
    /// `N_TAC` per ray.
    pub n_at: f64,
}

/// Havran's triplet Λ (eq. 6).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Triplet {
    /// Build time, median ms.
    pub t_cb_ms: f64,
    /// Trace or render time, median ms.
    pub t_tr_ms: f64,
    /// Share of `T_TR` spent in the structure (Whitted renderings only; see the module doc).
    pub t_tt_over_t_tr: Option<f64>,
}

/// Counters per ray of one level (or all levels), a member per counter of
/// [`crate::accel::COUNTERS`].
pub type PerRay = Counts<f64>;

/// Everything measured for one structure on one scene.
#[derive(Clone, Debug, Serialize)]
pub struct BenchRow {
    pub scene: String,
    pub primitives: usize,
    pub structure: String,
    pub workload: Workload,
    /// Rays traced in one run (for Whitted: eye, shadow, reflected and refracted).
    pub rays: u64,
    /// Rays that hit something (for Whitted: eye and secondary hits and blocked shadow rays).
    pub hits: u64,
    pub build: Timing,
    pub trace: Timing,
    /// Rays per second at the median trace time, in millions.
    pub mrays_per_s: f64,
    /// Bytes of the structure, its primitive copy included (and the soft shadows' structure).
    pub memory_bytes: usize,
    pub bytes_per_primitive: f64,
    pub septet: Septet,
    pub triplet: Triplet,
    pub per_ray: PerRay,
    pub per_ray_levels: Vec<PerRay>,
    /// Rays (or pixels, for Whitted) whose answer differs from the first structure's.
    pub differences: u64,
    /// What was compared: "rays" or "pixels".
    pub compared: &'static str,
}

/// What the first structure answered, for the others to be compared with.
enum Reference {
    Hits(Vec<Option<Hit>>),
    Image(image::RgbImage),
}

/// Measures every candidate on `scene` (named `name` in the rows), one after the other, on
/// the current rayon pool. `done` is called after each candidate with its row.
pub fn bench_scene(
    name: &str,
    scene: &Scene,
    candidates: &[Candidate],
    workload: Workload,
    repeat: usize,
    done: &mut dyn FnMut(&BenchRow),
) -> Result<Vec<BenchRow>, SpecError> {
    let repeat = repeat.max(1);
    let b = scene.bounds();
    let rays: Vec<Ray> = match workload {
        Workload::Camera { side } => camera_rays(&b, side, side),
        Workload::Incoherent { rays } => incoherent_rays(&b, rays, 1),
        Workload::Whitted { .. } => Vec::new(),
    };
    let scene_volume = if b.is_empty() { 0.0 } else { b.volume() as f64 };
    let mut reference: Option<Reference> = None;
    let mut rows = Vec::new();
    for cand in candidates {
        let mut build_secs = Vec::with_capacity(repeat);
        let mut accel = None;
        let mut soft = None;
        // The structure, and the soft shadows' own where the work asks for them.
        let build = || -> Result<_, SpecError> {
            let a = (cand.build)()?;
            let s = match workload {
                Workload::Whitted {
                    soft_shadows: Some(r),
                    ..
                } => Some(SoftShadows::build(scene, &cand.spec, r)?),
                _ => None,
            };
            Ok((a, s))
        };
        // One build first, untimed, and each timed build with the one before it freed: every
        // candidate builds into memory the process has touched already. Timed from a cold
        // start, the first candidate alone paid for the pages the later ones reused (the
        // bunny's HUG built in a median 8.3 ms listed first, 5.2 listed after the grid).
        drop(build()?);
        for _ in 0..repeat {
            drop((accel.take(), soft.take()));
            let t = Instant::now();
            let (a, s) = build()?;
            build_secs.push(t.elapsed().as_secs_f64());
            (accel, soft) = (Some(a), s);
        }
        let accel = accel.expect("repeat >= 1");
        let (trace_secs, counters, rays_traced, hits, differences, t_tt) = match workload {
            Workload::Camera { .. } | Workload::Incoherent { .. } => {
                let mut secs = Vec::with_capacity(repeat);
                let mut answers = vec![None; rays.len()];
                for _ in 0..repeat {
                    let t = Instant::now();
                    trace_into(scene, &accel, &rays, false, cand.packets, &mut answers);
                    secs.push(t.elapsed().as_secs_f64());
                }
                let counters = count(scene, &accel, &rays, crate::batch::Query::Closest);
                let hits = answers.iter().filter(|h| h.is_some()).count() as u64;
                let differences = match &reference {
                    Some(Reference::Hits(r)) => differing_hits(r, &answers),
                    _ => {
                        reference = Some(Reference::Hits(answers));
                        0
                    }
                };
                (secs, counters, rays.len() as u64, hits, differences, None)
            }
            Workload::Whitted {
                width,
                height,
                depth,
                ..
            } => {
                let settings = RenderSettings {
                    width: width.unwrap_or(scene.camera.width),
                    height: height.unwrap_or(scene.camera.height),
                    depth,
                    counters: false,
                    packets: cand.packets,
                };
                let once = |s: &RenderSettings| -> Rendered {
                    match &soft {
                        Some(soft) => render_soft(scene, &accel, soft, s, &|_| {}),
                        None => crate::render::render(scene, &accel, s, &|_| {}),
                    }
                };
                let mut secs = Vec::with_capacity(repeat);
                for _ in 0..repeat {
                    let t = Instant::now();
                    std::hint::black_box(once(&settings));
                    secs.push(t.elapsed().as_secs_f64());
                }
                // The counters are one ray's walk, as the papers count (SCG97 §3) and as the
                // camera and incoherent workloads count them, whatever the packets: a packet
                // meets a cell once for its rays and may test more triangles. The image is the
                // same either way.
                let counted = RenderSettings {
                    counters: true,
                    packets: Packets::Off,
                    ..settings
                };
                let (out, recording) = render_recorded(scene, &accel, soft.as_ref(), &counted);
                let mut replay_secs = Vec::with_capacity(repeat);
                for _ in 0..repeat {
                    let t = Instant::now();
                    std::hint::black_box(render_replayed(scene, &recording, &settings));
                    replay_secs.push(t.elapsed().as_secs_f64());
                }
                let c = out.counts;
                let hits = c.eye_hits + c.secondary_hits + c.shadow_hits;
                let differences = match &reference {
                    Some(Reference::Image(r)) => differing_pixels(r, &out.image),
                    _ => {
                        reference = Some(Reference::Image(out.image));
                        0
                    }
                };
                let t_tr = Timing::from_secs(secs.clone()).median_ms;
                let t_rest = Timing::from_secs(replay_secs).median_ms;
                let share = if t_tr > 0.0 {
                    ((t_tr - t_rest) / t_tr).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let counters = out.counters.unwrap_or_default();
                (
                    secs,
                    counters,
                    c.total_rays(),
                    hits,
                    differences,
                    Some(share),
                )
            }
        };
        let build = Timing::from_secs(build_secs);
        let trace = Timing::from_secs(trace_secs);
        let census = accel.stats().census;
        let memory_bytes = accel.memory_bytes() + soft.as_ref().map_or(0, |s| s.memory_bytes());
        let row = BenchRow {
            scene: name.to_string(),
            primitives: scene.len(),
            structure: cand.label.clone(),
            workload,
            rays: rays_traced,
            hits,
            build,
            trace,
            mrays_per_s: if trace.median_ms > 0.0 {
                rays_traced as f64 / trace.median_ms / 1e3
            } else {
                0.0
            },
            memory_bytes,
            bytes_per_primitive: memory_bytes as f64 / scene.len().max(1) as f64,
            septet: septet(
                &census,
                &counters,
                scene.len(),
                scene_volume,
                rays_traced,
                hits,
            ),
            triplet: Triplet {
                t_cb_ms: build.median_ms,
                t_tr_ms: trace.median_ms,
                t_tt_over_t_tr: t_tt,
            },
            per_ray: counters.total().per_ray(rays_traced),
            per_ray_levels: counters
                .used_levels()
                .iter()
                .map(|l| l.per_ray(rays_traced))
                .collect(),
            differences,
            compared: if matches!(workload, Workload::Whitted { .. }) {
                "pixels"
            } else {
                "rays"
            },
        };
        done(&row);
        rows.push(row);
    }
    Ok(rows)
}

/// The septet from a structure's cells and a workload's counters.
pub fn septet(
    census: &CellCensus,
    counters: &RayCounters,
    objects: usize,
    scene_volume: f64,
    rays: u64,
    hits: u64,
) -> Septet {
    let total = counters.total();
    let ratio = |a: f64, b: f64| if b > 0.0 { a / b } else { 0.0 };
    Septet {
        n_c: census.cells,
        r_etnc: ratio(
            (census.cells - census.full_cells) as f64,
            census.cells as f64,
        ),
        n_adc: ratio(census.object_refs as f64, objects as f64) - 1.0,
        n_aoifc: ratio(census.object_refs as f64, census.full_cells as f64),
        r_fvwv: ratio(census.full_volume, scene_volume),
        n_rprt: ratio(total[PIT] as f64, hits as f64),
        n_tac: total[VT],
        n_at: ratio(total[VT] as f64, rays as f64),
    }
}

/// Rays whose answers differ: not the same primitive, and not a tie at the same `t`.
pub fn differing_hits(a: &[Option<Hit>], b: &[Option<Hit>]) -> u64 {
    a.iter()
        .zip(b)
        .filter(|(x, y)| match (x, y) {
            (None, None) => false,
            (Some(x), Some(y)) => x.prim != y.prim && x.t != y.t,
            _ => true,
        })
        .count() as u64
        + a.len().abs_diff(b.len()) as u64
}

/// Pixels of different colour (all of them when the sizes differ).
pub fn differing_pixels(a: &image::RgbImage, b: &image::RgbImage) -> u64 {
    if a.dimensions() != b.dimensions() {
        return u64::from(a.width() * a.height()).max(u64::from(b.width() * b.height()));
    }
    a.pixels().zip(b.pixels()).filter(|(x, y)| x != y).count() as u64
}

/// A CSV field as serde writes it (so that numbers read as they always have).
#[derive(Serialize)]
#[serde(untagged)]
enum Field<'a> {
    S(&'a str),
    U(u64),
    F(f64),
    O(Option<f64>),
}

/// A CSV column's value in a row.
type CsvValue = for<'a> fn(&'a BenchRow) -> Field<'a>;

/// The CSV's columns before the counters, each with its value; then `KEY_per_ray` per
/// counter of [`COUNTERS`], then `differences`, `compared`.
const CSV_COLUMNS: &[(&str, CsvValue)] = &[
    ("scene", |r| Field::S(&r.scene)),
    ("primitives", |r| Field::U(r.primitives as u64)),
    ("structure", |r| Field::S(&r.structure)),
    ("rays", |r| Field::U(r.rays)),
    ("hits", |r| Field::U(r.hits)),
    ("build_ms", |r| Field::F(r.build.median_ms)),
    ("build_min_ms", |r| Field::F(r.build.min_ms)),
    ("build_max_ms", |r| Field::F(r.build.max_ms)),
    ("trace_ms", |r| Field::F(r.trace.median_ms)),
    ("trace_min_ms", |r| Field::F(r.trace.min_ms)),
    ("trace_max_ms", |r| Field::F(r.trace.max_ms)),
    ("mrays_per_s", |r| Field::F(r.mrays_per_s)),
    ("memory_bytes", |r| Field::U(r.memory_bytes as u64)),
    ("bytes_per_primitive", |r| Field::F(r.bytes_per_primitive)),
    ("n_c", |r| Field::U(r.septet.n_c as u64)),
    ("r_etnc", |r| Field::F(r.septet.r_etnc)),
    ("n_adc", |r| Field::F(r.septet.n_adc)),
    ("n_aoifc", |r| Field::F(r.septet.n_aoifc)),
    ("r_fvwv", |r| Field::F(r.septet.r_fvwv)),
    ("n_rprt", |r| Field::F(r.septet.n_rprt)),
    ("n_tac", |r| Field::U(r.septet.n_tac)),
    ("n_at", |r| Field::F(r.septet.n_at)),
    ("t_tt_over_t_tr", |r| Field::O(r.triplet.t_tt_over_t_tr)),
];

/// Writes `rows` as CSV (`docs/output-formats.md`): one record a row, the table's columns
/// flat, the per-level counters left to the JSON. Columns are only ever added.
pub fn write_csv(out: impl std::io::Write, rows: &[BenchRow]) -> Result<(), csv::Error> {
    let mut w = csv::Writer::from_writer(out);
    let mut header: Vec<String> = CSV_COLUMNS.iter().map(|c| c.0.to_string()).collect();
    header.extend(COUNTERS.iter().map(|c| format!("{}_per_ray", c.key)));
    header.extend(["differences".to_string(), "compared".to_string()]);
    w.write_record(&header)?;
    for r in rows {
        let mut record: Vec<Field> = CSV_COLUMNS.iter().map(|c| (c.1)(r)).collect();
        record.extend(r.per_ray.iter().map(|(_, v)| Field::F(*v)));
        record.extend([Field::U(r.differences), Field::S(r.compared)]);
        w.serialize(&record)?;
    }
    w.flush()?;
    Ok(())
}
