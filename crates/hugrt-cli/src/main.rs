//! `hugrt`: the command line over the hugrt library. It parses arguments, calls the library
//! and prints; no algorithm lives here.

/// `println!` that returns the write's error instead of panicking, so that a closed pipe
/// (`hugrt stats ... | head`) reaches `main` as an error, which ends the command quietly.
macro_rules! say {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        writeln!(std::io::stdout().lock(), $($arg)*)?
    }};
}

mod bench;
mod report;

use anyhow::{Context, Result, anyhow, bail};
use clap::builder::TypedValueParser as _;
use clap::{Parser, Subcommand};
use hugrt::accel::{AnyAccel, COUNTERS, Packets, STRUCTURES};
use hugrt::batch::{HitFormat, Query};
use hugrt::bench::Workload;
use hugrt::render::{DEFAULT_SCENE, ImageFormat, RenderJob, check_image, save_image};
use hugrt::scene::{InstancedScene, Scene, View, generate};
use hugrt::stats::StatsReport;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::path::PathBuf;
use std::time::Instant;

const ACCEL_HELP: &str = "Spatial structure: NAME[:KEY=VALUE,...], e.g. hug, hug:preset=eg95 (the paper's algorithm; also hug:preset=scg97, rgrid:preset=eg95, octree:preset=eg95, kdtree:preset=havran), grid:density=20, brute; `hugrt structures` lists every key";

#[derive(Parser)]
#[command(
    name = "hugrt",
    version,
    about = "Ray shooting through spatial data structures (HUG, grids, trees)"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene Whitted-style following the SPD test procedure, and report ray counts.
    ///
    /// With no SCENE, renders the built-in kitchen (EG95's case: a room with dense clusters of
    /// small tessellated objects). SCENE is an .nff, .ply, .obj, .stl, .gltf or .glb file (optionally .gz),
    /// builtin:room[:TRIANGLES] or builtin:KIND[:SIZE] (see `hugrt gen`).
    Render(RenderArgs),
    /// Batch ray queries: read a rays file, write a hits file (the embree-peer format).
    ///
    /// Rays: little-endian f32 records `ox oy oz tmin dx dy dz tmax` (32 bytes). Hits: per ray
    /// f32 t (+inf on a miss) then u32 primitive index (0xFFFFFFFF on a miss). With --all-hits:
    /// per ray a u32 count, then that many (f32 t, u32 primitive) pairs in order of t.
    Trace(TraceArgs),
    /// Scene statistics (SCG97 Fig. 4) and the structure's own (cells, references, memory).
    Stats(StatsArgs),
    /// Generate one of the papers' kinds of scene, deterministically per seed, as NFF (with
    /// camera, lights and materials) or binary PLY (triangles only), by the output's extension.
    ///
    /// `--size`'s help says what each kind is and what its size means. The same scenes are
    /// `builtin:KIND[:SIZE]` for the other commands.
    Gen(GenArgs),
    /// Regenerate experiments of the papers: each target writes DIR/TARGET/ with a report
    /// (published beside measured, and a verdict), its data as CSV and JSON.
    ///
    /// Targets: eg95-kitchens (EG95 Figs. 11-13, one kitchen and many kitchens),
    /// scg97-scenes (SCG97 Fig. 4, the test scenes' statistics), scg97-levels (SCG97 Figs.
    /// 12-23, per-level resources, occupancy and rendering counters), scg97-improved (SCG97
    /// 7.5, the tuned HUG against the recursive grid at equal memory), havran-splits (Havran
    /// Tables 4-6, the SAH's planes and its gain over the mid-point split), havran-layouts
    /// (Havran Tables 7-8, the kd-tree's layouts, under cachegrind where valgrind is
    /// installed), rtnews-spd (RTNews' table of grids on the SPD scenes). `all` runs every
    /// target. Plots are SVG and PNG. DIR/index.html then links every report in DIR and
    /// shows its plots.
    Reproduce(ReproduceArgs),
    /// List the structures and the keys of their specs: what each key accepts, its default and
    /// what it does (`--json` for scripts).
    Structures(StructuresArgs),
    /// Measure structures on the same work: build and trace times with their spread, Mrays/s,
    /// memory, Havran's septet and triplet, the papers' counters per ray and level, and whether
    /// every structure gives the first one's answers (an error when not).
    ///
    /// With no scene: the built-in kitchen, building of four kitchens, stadium and a room of a
    /// million primitives. `--rays whitted` renders each scene's image with every structure and
    /// compares the pixels; `camera` and `incoherent` compare the hits ray by ray.
    Bench(BenchArgs),
}

#[derive(clap::Args)]
struct RenderArgs {
    /// Scene file (default: the built-in kitchen).
    scene: Option<String>,
    /// Output image: PNG (8 bits, clamped) or OpenEXR (.exr: float radiance).
    #[arg(short, long, default_value = "hugrt.png")]
    output: PathBuf,
    #[arg(long, default_value = "hug", help = ACCEL_HELP)]
    accel: String,
    #[command(flatten)]
    image: ImageArgs,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Write ray counts and timings as JSON.
    #[arg(long)]
    stats_json: Option<PathBuf>,
    /// Also count ray-primitive tests, ray-box tests and cells visited per level (slower).
    #[arg(long)]
    counters: bool,
    /// No progress bar.
    #[arg(short, long)]
    quiet: bool,
    /// Render a scene with no primitives (a blank image) rather than fail.
    #[arg(long)]
    allow_empty: bool,
    #[command(flatten)]
    view: ViewArgs,
    /// Walk groups of neighbouring eye rays (8 for the bvh, 32 for the grids), and their
    /// shadow rays to each light, together: auto, where a group looks coherent and the
    /// structure's packet walk pays (the bvh's, the grid's, the HUG's, the recursive grid's);
    /// on, every group; off, every ray alone (nor are shadow rays first tried against what
    /// blocked the group before). The image is the same either way.
    #[arg(long, default_value = "auto", value_parser = clap::builder::PossibleValuesParser::new(Packets::NAMES).map(|s| s.parse::<Packets>().expect("a listed mode")))]
    packets: Packets,
}

#[derive(clap::Args)]
struct TraceArgs {
    /// Scene file (.nff, .ply, .obj, .stl, .gltf, .glb, optionally .gz), builtin:room[:TRIANGLES] or builtin:KIND[:SIZE].
    scene: String,
    /// Rays to trace (32-byte records, no header).
    #[arg(long)]
    rays: PathBuf,
    /// Where to write the hits (8-byte records, one per ray, in ray order).
    #[arg(long)]
    hits: PathBuf,
    #[arg(long, default_value = "hug", help = ACCEL_HELP)]
    accel: String,
    /// Occlusion queries: t = 1.0 and index 0 when anything is hit.
    #[arg(long, conflicts_with = "all_hits")]
    any_hit: bool,
    /// Every hit along each ray in [tmin, tmax], each primitive once, in order of t: per
    /// ray a u32 count, then that many (f32 t, u32 primitive) pairs, little-endian.
    #[arg(long)]
    all_hits: bool,
    /// basic: t and primitive (8 bytes a ray, embree-peer's); full: also the barycentric
    /// u, v and the unit geometric normal (28 bytes: f32 t, u32 primitive, f32 u v nx ny nz).
    #[arg(long, default_value = "basic", value_parser = clap::builder::PossibleValuesParser::new(HitFormat::NAMES).map(|s| s.parse::<HitFormat>().expect("a listed format")))]
    hit_format: HitFormat,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Trace this many times and report the median time (as embree-peer's --repeat).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=1000))]
    repeat: u32,
    /// Afterwards, count ray-primitive tests, hits, ray-box tests and cells visited per
    /// ray and level (a second, untimed pass).
    #[arg(long)]
    counters: bool,
    /// Walk groups of neighbouring rays together (8 for the bvh, 32 for the grids; closest
    /// and any hits): auto, where a group looks coherent (directions within 11° in one
    /// octant: a camera's rays, a light's) and the structure's packet walk pays (the bvh's,
    /// the grid's, the HUG's, the recursive grid's); on, every group, in every structure;
    /// off, every ray alone. Where groups are walked, a camera's rays (found row by row in
    /// the file) are grouped in tiles of 4 × 8 pixels and rays to a light by direction. Unless
    /// off, any-hit rays are first tried against what blocked the group before (a shadow
    /// cache). The hits are the same either way.
    #[arg(long, default_value = "auto", value_parser = clap::builder::PossibleValuesParser::new(Packets::NAMES).map(|s| s.parse::<Packets>().expect("a listed mode")))]
    packets: Packets,
}

#[derive(clap::Args)]
struct StatsArgs {
    /// Scene file (.nff, .ply, .obj, .stl, .gltf, .glb, optionally .gz), builtin:room[:TRIANGLES] or builtin:KIND[:SIZE].
    scene: String,
    #[arg(long, default_value = "hug", help = ACCEL_HELP)]
    accel: String,
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
}

#[derive(clap::Args)]
struct GenArgs {
    /// What to generate (town with --instanced only).
    #[arg(value_parser = clap::builder::PossibleValuesParser::new(generate::KINDS.iter().map(|k| k.0).chain(["town"])))]
    kind: String,
    #[arg(long, default_value_t = 0, help = size_help())]
    size: u32,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Write models and their instances (NFF's define/instance), each model once.
    #[arg(long, long_help = format!("Write models and their instances (NFF's define/instance, docs/nff-and-spd.md), each model once: {}", generate::INSTANCED_HELP))]
    instanced: bool,
    /// Output file: .nff or .ply.
    #[arg(short, long)]
    output: PathBuf,
}

#[derive(clap::Args)]
struct ReproduceArgs {
    /// Targets to run.
    #[arg(required = true)]
    targets: Vec<String>,
    /// Folder to write into.
    #[arg(short, long, default_value = "reproduce")]
    output: PathBuf,
    /// Smaller scenes, for a first look.
    #[arg(long)]
    quick: bool,
    /// Where the SPD scenes are (NAME.nff.gz).
    #[arg(long, default_value = "../shared/scenes/spd")]
    spd_dir: PathBuf,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
}

#[derive(clap::Args)]
struct StructuresArgs {
    /// Only this structure.
    name: Option<String>,
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
}

#[derive(clap::Args)]
struct BenchArgs {
    /// Scenes (files, builtin:room[:TRIANGLES] or builtin:KIND[:SIZE]).
    scenes: Vec<String>,
    /// Structures to measure (repeatable; the first is the reference for the answers).
    #[arg(long = "accel", default_value = "hug", help = ACCEL_HELP)]
    accels: Vec<String>,
    /// The work: the SPD Whitted rendering, camera rays or incoherent rays.
    #[arg(long, value_enum, default_value_t = RayKind::Whitted)]
    rays: RayKind,
    /// Incoherent rays per run.
    #[arg(long, default_value_t = 1_000_000, value_parser = clap::value_parser!(u64).range(1..=1_000_000_000))]
    ray_count: u64,
    /// Camera rays: image side (side² rays).
    #[arg(long, default_value_t = 1024, value_parser = clap::value_parser!(u32).range(1..=65536))]
    camera: u32,
    /// The Whitted rendering's image.
    #[command(flatten)]
    image: ImageArgs,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Runs per timing (the median is reported, with the extremes).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=1000))]
    repeat: u32,
    /// Write the rows, per-level counters included, as JSON.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Write the rows as CSV.
    #[arg(long)]
    csv: Option<PathBuf>,
    /// No progress bar.
    #[arg(short, long)]
    quiet: bool,
    /// Packets for camera and Whitted rays (repeatable: each structure is measured with each
    /// mode, e.g. `--packets on --packets off`): auto, groups of neighbouring rays (8 for the
    /// bvh, 32 for the grids) that look coherent walk together where the structure's packet
    /// walk pays (bvh, grid, hug, rgrid); on, every group, in every structure; off, every ray
    /// alone. The counters are one ray's walk whatever the mode, as the papers count, and
    /// `reproduce` walks every ray alone.
    #[arg(long = "packets", default_value = "auto", value_parser = clap::builder::PossibleValuesParser::new(Packets::NAMES).map(|s| s.parse::<Packets>().expect("a listed mode")))]
    packets: Vec<Packets>,
}

/// `gen --size`'s help, from the kinds' own descriptions.
fn size_help() -> String {
    let kinds: Vec<String> = generate::KINDS
        .iter()
        .map(|(k, what, default)| format!("{k}: {what} (default {default})"))
        .collect();
    format!(
        "Detail or extent (0: the kind's default). {}",
        kinds.join("; ")
    )
}

/// Where the camera of `render` stands, overriding the scene's (a mesh's default frames its
/// bounding box from outside).
#[derive(clap::Args, Clone, Copy)]
struct ViewArgs {
    /// Eye position, X,Y,Z.
    #[arg(long, value_parser = parse_point, allow_hyphen_values = true)]
    eye: Option<hugrt::geometry::Vec3>,
    /// Point looked at, X,Y,Z.
    #[arg(long, value_parser = parse_point, allow_hyphen_values = true)]
    look_at: Option<hugrt::geometry::Vec3>,
    /// Up direction, X,Y,Z.
    #[arg(long, value_parser = parse_point, allow_hyphen_values = true)]
    up: Option<hugrt::geometry::Vec3>,
    /// Vertical field of view in degrees, between 0 and 180.
    #[arg(long)]
    fov: Option<f32>,
}

impl ViewArgs {
    fn view(&self) -> View {
        View {
            eye: self.eye,
            look_at: self.look_at,
            up: self.up,
            fov: self.fov,
        }
    }
}

/// `X,Y,Z` as a point with finite coordinates.
fn parse_point(s: &str) -> std::result::Result<hugrt::geometry::Vec3, String> {
    let v: Vec<f32> = s
        .split(',')
        .map(|x| {
            x.trim()
                .parse::<f32>()
                .map_err(|_| format!("'{x}' is not a number"))
        })
        .collect::<std::result::Result<_, _>>()?;
    match v[..] {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok(hugrt::geometry::Vec3::new(x, y, z)),
        [_, _, _] => Err("coordinates must be finite".into()),
        _ => Err(format!("'{s}' is not X,Y,Z")),
    }
}

/// The image of an SPD rendering (`render`, and `bench --rays whitted`).
#[derive(clap::Args, Clone, Copy)]
struct ImageArgs {
    /// Image width (default: the scene's resolution).
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..=65536))]
    width: Option<u32>,
    /// Image height (default: the scene's resolution).
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..=65536))]
    height: Option<u32>,
    /// Bounces after the eye ray (SPD: 4), at most 64.
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u32).range(0..=hugrt::render::MAX_BOUNCES as i64))]
    depth: u32,
    /// Single-sample soft shadows (Parker, Shirley, Smits) from spherical lights of this
    /// radius, as a fraction of the scene's diagonal (0.002 when given without a value).
    #[arg(long, value_name = "RADIUS", num_args = 0..=1, default_missing_value = DEFAULT_RADIUS)]
    soft_shadows: Option<f32>,
}

impl ImageArgs {
    /// Rejects a bad light radius or image side before any work ([`check_image`]).
    fn check(&self) -> Result<()> {
        Ok(check_image(self.width, self.height, self.soft_shadows)?)
    }
}

/// The work `hugrt bench` measures.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
enum RayKind {
    Camera,
    Incoherent,
    Whitted,
}

/// `--soft-shadows` given without a value ([`hugrt::render::DEFAULT_LIGHT_RADIUS`]).
const DEFAULT_RADIUS: &str = "0.002";

fn main() {
    if let Err(e) = run(Cli::parse()) {
        // The reader went away (`hugrt stats ... | head`): nothing more to say to anyone.
        let closed_pipe = e.chain().any(|c| {
            c.downcast_ref::<std::io::Error>()
                .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
        });
        if closed_pipe {
            std::process::exit(0);
        }
        eprintln!("hugrt: error: {e:#}");
        std::process::exit(1);
    }
}

/// Prints every counter ([`hugrt::accel::COUNTERS`]) per ray and per hierarchy level.
fn print_counters(c: &hugrt::accel::RayCounters, rays: u64) -> Result<()> {
    let columns: String = COUNTERS
        .iter()
        .map(|k| format!(" {:>8}", k.column))
        .collect();
    say!("per ray  {columns}");
    for (level, l) in c.used_levels().iter().enumerate() {
        let values: String = l
            .per_ray(rays)
            .iter()
            .map(|(_, v)| format!(" {v:8.2}"))
            .collect();
        say!("level {level:<3}{values}");
    }
    Ok(())
}

/// Loads a scene file or generates a built-in one ([`Scene::open`]).
pub(crate) fn load_scene(name: &str) -> Result<Scene> {
    Ok(Scene::open(name)?)
}

fn build(scene: &Scene, spec: &str) -> Result<(AnyAccel, f64)> {
    let t = Instant::now();
    let accel = AnyAccel::build(scene, spec).with_context(|| format!("--accel {spec}"))?;
    Ok((accel, t.elapsed().as_secs_f64()))
}

/// The most worker threads `--threads` accepts: beyond the cores there is nothing to gain,
/// and creating tens of thousands of threads takes minutes.
const MAX_THREADS: usize = 1024;

fn pool(threads: Option<usize>) -> Result<rayon::ThreadPool> {
    let mut b = rayon::ThreadPoolBuilder::new();
    if let Some(n) = threads {
        if !(1..=MAX_THREADS).contains(&n) {
            bail!("--threads {n}: must be between 1 and {MAX_THREADS}");
        }
        b = b.num_threads(n);
    }
    Ok(b.build()?)
}

/// Checks a spec before any work ([`AnyAccel::check`]).
fn check_spec(spec: &str) -> Result<()> {
    AnyAccel::check(spec).with_context(|| format!("--accel {spec}"))
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Render(a) => a.run(),
        Command::Trace(a) => a.run(),
        Command::Stats(a) => a.run(),
        Command::Gen(a) => a.run(),
        Command::Reproduce(a) => a.run(),
        Command::Structures(a) => a.run(),
        Command::Bench(a) => a.run(),
    }
}

impl RenderArgs {
    fn run(self) -> Result<()> {
        let RenderArgs {
            scene,
            output,
            accel,
            image,
            threads,
            stats_json,
            counters,
            quiet,
            allow_empty,
            view,
            packets,
        } = self;
        let job = RenderJob {
            width: image.width,
            height: image.height,
            depth: image.depth,
            counters,
            soft_shadows: image.soft_shadows,
            view: view.view(),
            allow_empty,
            packets,
            ..RenderJob::new(scene.as_deref().unwrap_or(DEFAULT_SCENE), &accel)
        };
        check_spec(&accel)?;
        job.check()?;
        ImageFormat::for_path(&output)?;
        let pool = pool(threads)?;
        let bar = ProgressBar::new(0);
        bar.set_draw_target(if quiet {
            ProgressDrawTarget::hidden()
        } else {
            ProgressDrawTarget::stderr()
        });
        bar.set_style(
            ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} rows {eta}")?
                .progress_chars("=> "),
        );
        let (out, r) = pool
            .install(|| {
                job.run(&|rows, total| {
                    bar.set_length(total);
                    bar.inc(rows);
                })
            })
            .map_err(|e| match e {
                hugrt::Error::Empty(_) => anyhow!("{e} (--allow-empty renders it anyway)"),
                e => e.into(),
            })?;
        bar.finish_and_clear();
        save_image(&out, &output)?;
        let c = &r.counts;
        say!(
            "scene {}: {} primitives, {} light{}; structure {} ({})",
            r.scene,
            r.primitives,
            r.lights,
            if r.lights == 1 { "" } else { "s" },
            r.structure,
            r.accel
        );
        say!(
            "load {:.3} s, build {:.3} s, render {:.3} s ({:.2} Mrays/s)",
            r.load_seconds,
            r.build_seconds,
            r.render_seconds,
            c.total_rays() as f64 / r.render_seconds / 1e6
        );
        say!(
            "eye rays {} (hit {}), shadow rays {} (blocked {}, in a penumbra {}), reflected {}, refracted {}, secondary hits {}",
            c.eye_rays,
            c.eye_hits,
            c.shadow_rays,
            c.shadow_hits,
            c.penumbra_rays,
            c.reflected_rays,
            c.refracted_rays,
            c.secondary_hits
        );
        say!("wrote {}", output.display());
        if let Some(k) = &out.counters {
            print_counters(k, c.total_rays())?;
        }
        if let Some(path) = stats_json {
            std::fs::write(&path, serde_json::to_string_pretty(&r)? + "\n")
                .with_context(|| format!("writing {}", path.display()))?;
        }
        Ok(())
    }
}

impl TraceArgs {
    fn run(self) -> Result<()> {
        let TraceArgs {
            scene,
            rays,
            hits,
            accel,
            any_hit,
            all_hits,
            hit_format,
            threads,
            repeat,
            counters,
            packets,
        } = self;
        check_spec(&accel)?;
        let query = match (any_hit, all_hits) {
            (true, _) => Query::Any,
            (_, true) => Query::All,
            _ => Query::Closest,
        };
        hugrt::batch::check_format(query, hit_format).context("--hit-format full")?;
        pool(threads)?.install(|| {
            let opened = InstancedScene::open(&scene)?;
            let bytes =
                std::fs::read(&rays).with_context(|| format!("reading {}", rays.display()))?;
            let ray_list =
                hugrt::batch::decode_rays(&bytes).with_context(|| rays.display().to_string())?;
            let scene = match opened.into_flat() {
                Ok(scene) => scene,
                Err(instanced) => {
                    if counters {
                        bail!("--counters: not offered through instances");
                    }
                    let t = std::time::Instant::now();
                    let world = hugrt::world::World::build(instanced, &accel)?;
                    let build_s = t.elapsed().as_secs_f64();
                    let traced = hugrt::batch::trace_world_timed(
                        &world,
                        &ray_list,
                        query,
                        hit_format,
                        repeat as usize,
                    )?;
                    return write_traced(&hits, &traced, build_s, ray_list.len());
                }
            };
            let (acc, build_s) = build(&scene, &accel)?;
            let traced = hugrt::batch::trace_scene_timed(
                &scene,
                &acc,
                &ray_list,
                query,
                hit_format,
                repeat as usize,
                packets,
            )?;
            write_traced(&hits, &traced, build_s, ray_list.len())?;
            if counters {
                let c = hugrt::batch::count(&scene, &acc, &ray_list, query);
                print_counters(&c, ray_list.len() as u64)?;
            }
            Ok(())
        })
    }
}

/// Writes a batch's hits and says what it took.
fn write_traced(
    hits: &std::path::Path,
    traced: &hugrt::batch::Traced,
    build_s: f64,
    rays: usize,
) -> Result<()> {
    std::fs::write(hits, &traced.bytes).with_context(|| format!("writing {}", hits.display()))?;
    let trace_ms = traced.timing.median_ms;
    say!(
        "build {:.1} ms, trace {trace_ms:.1} ms, {rays} rays, {} hits, {:.2} Mrays/s",
        build_s * 1e3,
        traced.hits,
        rays as f64 / (trace_ms * 1e-3).max(1e-9) / 1e6
    );
    Ok(())
}

impl StatsArgs {
    fn run(self) -> Result<()> {
        let StatsArgs {
            scene: name,
            accel,
            json,
        } = self;
        check_spec(&accel)?;
        let r = StatsReport::measure(&name, &accel)?;
        if json {
            say!("{}", serde_json::to_string_pretty(&r)?);
        } else {
            report::print_scene_stats(&name, &r.scene_stats, r.scene_memory_bytes)?;
            report::print_structure_stats(&accel, r.build_seconds, &r.structure)?;
        }
        Ok(())
    }
}

impl GenArgs {
    fn run(self) -> Result<()> {
        let GenArgs {
            kind,
            size,
            seed,
            output,
            instanced,
        } = self;
        if instanced || kind == "town" {
            if !instanced {
                bail!("town is made of instances only: add --instanced");
            }
            if size > generate::MAX_INSTANCED_SIZE {
                bail!("size {size}: at most {}", generate::MAX_INSTANCED_SIZE);
            }
            let (primitives, lights) =
                hugrt::scene::write::save_generated_instanced(&kind, size, seed, &output)?;
            say!(
                "{kind} (size {size}, seed {seed}, instanced): {primitives} primitives once flattened, {lights} lights -> {}",
                output.display()
            );
            return Ok(());
        }
        let size = generate::resolve_size(&kind, size)?;
        let (primitives, lights) = hugrt::scene::write::save_generated(&kind, size, seed, &output)?;
        say!(
            "{kind} (size {size}, seed {seed}): {primitives} primitives, {lights} lights -> {}",
            output.display()
        );
        Ok(())
    }
}

impl ReproduceArgs {
    fn run(self) -> Result<()> {
        let ReproduceArgs {
            targets,
            output,
            quick,
            spd_dir,
            threads,
        } = self;
        let targets = hugrt::reproduce::resolve(&targets)?;
        let options = hugrt::reproduce::Options {
            quick,
            spd_dir,
            hugrt_exe: std::env::current_exe().ok(),
        };
        let bar = ProgressBar::new(targets.len() as u64);
        bar.set_style(
            ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} {msg}")?
                .progress_chars("=> "),
        );
        pool(threads)?.install(|| {
            for t in targets {
                bar.set_message(t.name);
                let dir = hugrt::reproduce::run(t.name, &options, &output)?;
                bar.inc(1);
                bar.suspend(|| -> Result<()> {
                    say!("{}: {}", t.name, dir.join("report.md").display());
                    Ok(())
                })?;
            }
            bar.finish_and_clear();
            let index = hugrt::reproduce::write_index(&output)?;
            say!("index: {}", index.display());
            Ok(())
        })
    }
}

impl StructuresArgs {
    fn run(self) -> Result<()> {
        let StructuresArgs { name, json } = self;
        let table = AnyAccel::describe(name.as_deref())?;
        if json {
            let j: serde_json::Map<String, serde_json::Value> = table
                .iter()
                .map(|(n, k)| Ok((n.to_string(), serde_json::to_value(k)?)))
                .collect::<Result<_>>()?;
            say!("{}", serde_json::to_string_pretty(&j)?);
        } else {
            report::print_structures(&table)?;
        }
        Ok(())
    }
}

impl BenchArgs {
    fn run(self) -> Result<()> {
        let BenchArgs {
            scenes,
            accels,
            rays,
            ray_count,
            camera,
            image,
            threads,
            repeat,
            json,
            csv,
            quiet,
            packets,
        } = self;
        if accels.is_empty() {
            bail!(
                "no structure given; valid structures: {}",
                STRUCTURES.join(", ")
            );
        }
        image.check()?;
        for a in &accels {
            check_spec(a)?;
        }
        let workload = match rays {
            RayKind::Camera => Workload::Camera { side: camera },
            RayKind::Incoherent => Workload::Incoherent {
                rays: ray_count as usize,
            },
            RayKind::Whitted => Workload::Whitted {
                width: image.width,
                height: image.height,
                depth: image.depth,
                soft_shadows: image.soft_shadows,
            },
        };
        pool(threads)?.install(|| {
            bench::run(bench::Options {
                scenes,
                accels,
                packets,
                workload,
                repeat: repeat as usize,
                json,
                csv,
                quiet,
            })
        })
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn soft_shadows_default_is_the_library_default() {
        assert_eq!(
            super::DEFAULT_RADIUS.parse::<f32>().unwrap(),
            hugrt::render::DEFAULT_LIGHT_RADIUS
        );
    }
}
