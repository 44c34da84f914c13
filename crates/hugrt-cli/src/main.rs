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

use anyhow::{Context, Result, bail};
use clap::{Parser, Subcommand};
use hugrt::accel::{AnyAccel, STRUCTURES};
use hugrt::bench::Workload;
use hugrt::render::{RenderSettings, SoftShadows, render, render_soft};
use hugrt::scene::Scene;
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
    /// small tessellated objects). SCENE is an .nff, .ply or .obj file (optionally .gz),
    /// builtin:room[:TRIANGLES] or builtin:KIND[:SIZE] (see `hugrt gen`).
    Render {
        /// Scene file (default: the built-in kitchen).
        scene: Option<String>,
        /// Output PNG.
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
    },
    /// Batch ray queries: read a rays file, write a hits file (the embree-peer format).
    ///
    /// Rays: little-endian f32 records `ox oy oz tmin dx dy dz tmax` (32 bytes). Hits: per ray
    /// f32 t (+inf on a miss) then u32 primitive index (0xFFFFFFFF on a miss). With --all-hits:
    /// per ray a u32 count, then that many (f32 t, u32 primitive) pairs in order of t.
    Trace {
        /// Scene file (.nff, .ply, .obj, optionally .gz), builtin:room[:TRIANGLES] or builtin:KIND[:SIZE].
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
        #[arg(long, value_enum, default_value_t = HitFormat::Basic)]
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
    },
    /// Scene statistics (SCG97 Fig. 4) and the structure's own (cells, references, memory).
    Stats {
        /// Scene file (.nff, .ply, .obj, optionally .gz), builtin:room[:TRIANGLES] or builtin:KIND[:SIZE].
        scene: String,
        #[arg(long, default_value = "hug", help = ACCEL_HELP)]
        accel: String,
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Generate one of the papers' kinds of scene, deterministically per seed, as NFF (with
    /// camera, lights and materials) or binary PLY (triangles only), by the output's extension.
    ///
    /// Kinds: kitchen, building, city, garden, sphereflake, stadium (`hugrt gen --help` lists
    /// what SIZE means for each). The same scenes are `builtin:KIND[:SIZE]` for the other
    /// commands.
    Gen {
        /// What to generate.
        #[arg(value_parser = clap::builder::PossibleValuesParser::new(["kitchen", "building", "city", "garden", "sphereflake", "stadium"]))]
        kind: String,
        /// Detail or extent (0: the kind's default). kitchen: detail (2); building: kitchens
        /// (4); city: blocks per side / 4 (2); garden: plants / 16 (2); sphereflake: depth (4);
        /// stadium: detail of the objects in it (2).
        #[arg(long, default_value_t = 0)]
        size: u32,
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Output file: .nff or .ply.
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Regenerate experiments of the papers: each target writes DIR/TARGET/ with a report
    /// (published beside measured, and a verdict), its data as CSV and JSON.
    ///
    /// Targets: scg97-scenes (SCG97 Fig. 4, the test scenes' statistics), rtnews-spd (RTNews'
    /// table of grids on the SPD scenes). `all` runs every target.
    Reproduce {
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
    },
    /// List the structures and the keys of their specs: what each key accepts, its default and
    /// what it does (`--json` for scripts).
    Structures {
        /// Only this structure.
        name: Option<String>,
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Measure structures on the same work: build and trace times with their spread, Mrays/s,
    /// memory, Havran's septet and triplet, the papers' counters per ray and level, and whether
    /// every structure gives the first one's answers (an error when not).
    ///
    /// With no scene: the built-in kitchen, building of four kitchens, stadium and a room of a
    /// million primitives. `--rays whitted` renders each scene's image with every structure and
    /// compares the pixels; `camera` and `incoherent` compare the hits ray by ray.
    Bench {
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
    },
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
    /// The scene's camera with these options applied; an error for a view that cannot be.
    fn apply(&self, mut camera: hugrt::scene::Camera) -> Result<hugrt::scene::Camera> {
        if self.eye.is_none() && self.look_at.is_none() && self.up.is_none() && self.fov.is_none() {
            return Ok(camera);
        }
        camera.from = self.eye.unwrap_or(camera.from);
        camera.at = self.look_at.unwrap_or(camera.at);
        camera.up = self.up.unwrap_or(camera.up);
        camera.fov_deg = self.fov.unwrap_or(camera.fov_deg);
        let forward = camera.at - camera.from;
        if !(camera.fov_deg > 0.0 && camera.fov_deg < 180.0) {
            bail!(
                "--fov {}: must be between 0 and 180 degrees",
                camera.fov_deg
            );
        }
        if forward.length_squared() == 0.0 {
            bail!("the eye and the point looked at are the same point");
        }
        if forward.cross(camera.up).length_squared()
            <= 1e-12 * forward.length_squared() * camera.up.length_squared()
        {
            bail!(
                "the up direction {} is parallel to the view direction",
                camera.up
            );
        }
        Ok(camera)
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
    /// Rejects a bad light radius or image side before any work.
    fn check(&self) -> Result<()> {
        if let Some(r) = self.soft_shadows
            && !(r.is_finite() && r >= 0.0)
        {
            bail!(
                "--soft-shadows {r}: the light radius must be a finite fraction of the diagonal, 0 or more"
            );
        }
        for side in [self.width, self.height].into_iter().flatten() {
            check_side(side)?;
        }
        Ok(())
    }
}

/// An image side hugrt accepts.
fn check_side(side: u32) -> Result<()> {
    if side == 0 || side > 65536 {
        bail!("image size: a side of {side} is not within 1..=65536");
    }
    Ok(())
}

/// What `hugrt trace` writes per ray.
#[derive(Clone, Copy, Debug, PartialEq, clap::ValueEnum)]
enum HitFormat {
    Basic,
    Full,
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

/// Prints the papers' counters per ray and per hierarchy level.
fn print_counters(c: &hugrt::accel::RayCounters, rays: u64) -> Result<()> {
    let per = |x: u64| x as f64 / rays.max(1) as f64;
    say!("per ray      #pit      #pi     #bbi      #vt");
    for (level, l) in c.used_levels().iter().enumerate() {
        say!(
            "level {level}  {:8.2} {:8.3} {:8.2} {:8.2}",
            per(l.pit),
            per(l.pi),
            per(l.bbi),
            per(l.vt)
        );
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

/// Checks a spec before any work: building it over no primitives parses and checks every key
/// and value at no cost.
fn check_spec(spec: &str) -> Result<()> {
    AnyAccel::build(&Scene::from_triangles(Vec::new()), spec)
        .map(drop)
        .with_context(|| format!("--accel {spec}"))
}

/// Fails for a scene with nothing to hit, unless asked to go on.
fn check_not_empty(name: &str, scene: &Scene, allow_empty: bool) -> Result<()> {
    if scene.shapes.is_empty() && !allow_empty {
        bail!("{name}: no primitives (--allow-empty renders it anyway)");
    }
    Ok(())
}

/// Checks that an image can be written where asked, before rendering it.
fn check_image_path(path: &std::path::Path) -> Result<()> {
    if path.is_dir() {
        bail!(
            "-o {}: is a directory; give a file name ending in .png",
            path.display()
        );
    }
    if !path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("png"))
    {
        bail!(
            "-o {}: hugrt writes PNG images; give a name ending in .png",
            path.display()
        );
    }
    Ok(())
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Render {
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
        } => {
            image.check()?;
            check_spec(&accel)?;
            check_image_path(&output)?;
            let name = scene.unwrap_or_else(|| "builtin:kitchen".to_string());
            pool(threads)?.install(|| {
                let t = Instant::now();
                let mut scene = load_scene(&name)?;
                check_not_empty(&name, &scene, allow_empty)?;
                scene.camera = view.apply(scene.camera)?;
                let load_s = t.elapsed().as_secs_f64();
                let (acc, mut build_s) = build(&scene, &accel)?;
                let soft = match image.soft_shadows {
                    Some(r) => {
                        let t = Instant::now();
                        let s = SoftShadows::build(&scene, &accel, r)?;
                        build_s += t.elapsed().as_secs_f64();
                        Some(s)
                    }
                    None => None,
                };
                let settings = RenderSettings {
                    width: image.width.unwrap_or(scene.camera.width),
                    height: image.height.unwrap_or(scene.camera.height),
                    depth: image.depth,
                    counters,
                };
                check_side(settings.width)?;
                check_side(settings.height)?;
                let bar = ProgressBar::new(settings.height as u64 + 1);
                bar.set_draw_target(if quiet { ProgressDrawTarget::hidden() } else { ProgressDrawTarget::stderr() });
                bar.set_style(ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} rows {eta}")?.progress_chars("=> "));
                let t = Instant::now();
                let out = match &soft {
                    Some(s) => render_soft(&scene, &acc, s, &settings, &|n| bar.inc(n)),
                    None => render(&scene, &acc, &settings, &|n| bar.inc(n)),
                };
                let render_s = t.elapsed().as_secs_f64();
                bar.finish_and_clear();
                out.image.save(&output).with_context(|| format!("writing {}", output.display()))?;
                let c = out.counts;
                let lights = scene.lights.len();
                say!("scene {name}: {} primitives, {lights} light{}; structure {} ({})", scene.shapes.len(), if lights == 1 { "" } else { "s" }, acc.name(), accel);
                say!("load {load_s:.3} s, build {build_s:.3} s, render {render_s:.3} s ({:.2} Mrays/s)", c.total_rays() as f64 / render_s / 1e6);
                say!("eye rays {} (hit {}), shadow rays {} (blocked {}, in a penumbra {}), reflected {}, refracted {}, secondary hits {}",
                    c.eye_rays, c.eye_hits, c.shadow_rays, c.shadow_hits, c.penumbra_rays, c.reflected_rays, c.refracted_rays, c.secondary_hits);
                say!("wrote {}", output.display());
                if let Some(k) = &out.counters {
                    print_counters(k, c.total_rays())?;
                }
                if let Some(path) = stats_json {
                    let j = hugrt::render::RenderReport {
                        counts: c,
                        scene: name.clone(),
                        accel: accel.clone(),
                        primitives: scene.shapes.len(),
                        width: settings.width,
                        height: settings.height,
                        load_seconds: load_s,
                        build_seconds: build_s,
                        render_seconds: render_s,
                        accel_memory_bytes: acc.memory_bytes()
                            + soft.as_ref().map_or(0, |s| s.memory_bytes()),
                        soft_shadow_radius: soft.as_ref().map(|s| s.radius()),
                        counters_per_level: out.counters.map(|k| k.used_levels().to_vec()),
                    };
                    std::fs::write(&path, serde_json::to_string_pretty(&j)? + "\n")
                        .with_context(|| format!("writing {}", path.display()))?;
                }
                Ok(())
            })
        }
        Command::Trace {
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
        } => {
            check_spec(&accel)?;
            if (any_hit || all_hits) && hit_format == HitFormat::Full {
                bail!(
                    "--hit-format full describes closest hits, not the answers of --any-hit or --all-hits"
                );
            }
            let query = match (any_hit, all_hits) {
                (true, _) => hugrt::batch::Query::Any,
                (_, true) => hugrt::batch::Query::All,
                _ => hugrt::batch::Query::Closest,
            };
            pool(threads)?.install(|| {
                let scene = load_scene(&scene)?;
                let bytes =
                    std::fs::read(&rays).with_context(|| format!("reading {}", rays.display()))?;
                let ray_list = hugrt::batch::decode_rays(&bytes)
                    .with_context(|| rays.display().to_string())?;
                let (acc, build_s) = build(&scene, &accel)?;
                let mut times = Vec::new();
                let (encoded, hit_count) = if all_hits {
                    let mut result = Vec::new();
                    for _ in 0..repeat {
                        let t = Instant::now();
                        result = hugrt::batch::trace_all(&scene, &acc, &ray_list);
                        times.push(t.elapsed().as_secs_f64());
                    }
                    let count = result.iter().map(Vec::len).sum::<usize>();
                    (hugrt::batch::encode_all_hits(&result), count)
                } else {
                    let mut result = vec![None; ray_list.len()];
                    for _ in 0..repeat {
                        let t = Instant::now();
                        hugrt::batch::trace_into(&scene, &acc, &ray_list, any_hit, &mut result);
                        times.push(t.elapsed().as_secs_f64());
                    }
                    let encoded = match hit_format {
                        HitFormat::Basic => hugrt::batch::encode_hits(&result),
                        HitFormat::Full => {
                            hugrt::batch::encode_full_hits(&scene, &ray_list, &result)
                        }
                    };
                    (encoded, result.iter().filter(|h| h.is_some()).count())
                };
                let trace_s = bench::median(times);
                std::fs::write(&hits, encoded)
                    .with_context(|| format!("writing {}", hits.display()))?;
                say!(
                    "build {:.1} ms, trace {:.1} ms, {} rays, {} hits, {:.2} Mrays/s",
                    build_s * 1e3,
                    trace_s * 1e3,
                    ray_list.len(),
                    hit_count,
                    ray_list.len() as f64 / trace_s.max(1e-9) / 1e6
                );
                if counters {
                    let c = hugrt::batch::count(&scene, &acc, &ray_list, query);
                    print_counters(&c, ray_list.len() as u64)?;
                }
                Ok(())
            })
        }
        Command::Stats {
            scene: name,
            accel,
            json,
        } => {
            check_spec(&accel)?;
            let scene = load_scene(&name)?;
            let s = hugrt::stats::scene_stats(&scene);
            let (acc, build_s) = build(&scene, &accel)?;
            let st = acc.stats();
            if json {
                let j = serde_json::json!({
                    "scene": name, "accel": accel, "scene_stats": s, "build_seconds": build_s,
                    "scene_memory_bytes": scene.memory_bytes(),
                    "structure": st.entries.iter().map(|(k, v)| (k.clone(), serde_json::json!(v))).collect::<serde_json::Map<_, _>>(),
                    "levels": st.levels,
                    "depths": st.depths,
                });
                say!("{}", serde_json::to_string_pretty(&j)?);
            } else {
                report::print_scene_stats(&name, &s, scene.memory_bytes())?;
                report::print_structure_stats(&accel, build_s, &st)?;
            }
            Ok(())
        }
        Command::Gen {
            kind,
            size,
            seed,
            output,
        } => {
            let max = hugrt::scene::generate::max_size(&kind);
            if size > max {
                bail!("--size {size} for {kind}: at most {max}");
            }
            let name = output.to_string_lossy().to_ascii_lowercase();
            type Writer = fn(&Scene, &mut std::io::BufWriter<std::fs::File>) -> std::io::Result<()>;
            let write: Writer = if name.ends_with(".nff") {
                |s, w| hugrt::scene::write::write_nff(s, w)
            } else if name.ends_with(".ply") {
                |s, w| hugrt::scene::write::write_ply(s, w)
            } else {
                bail!("{}: the output must end in .nff or .ply", output.display());
            };
            let size = if size == 0 {
                hugrt::scene::generate::default_size(&kind)
            } else {
                size
            };
            let scene = hugrt::scene::generate::generate(&kind, size, seed)
                .with_context(|| format!("unknown kind {kind}"))?;
            let file = std::fs::File::create(&output)
                .with_context(|| format!("creating {}", output.display()))?;
            let mut w = std::io::BufWriter::new(file);
            write(&scene, &mut w)
                .and_then(|()| std::io::Write::flush(&mut w))
                .with_context(|| format!("writing {}", output.display()))?;
            say!(
                "{kind} (size {size}, seed {seed}): {} primitives, {} lights -> {}",
                scene.shapes.len(),
                scene.lights.len(),
                output.display()
            );
            Ok(())
        }
        Command::Reproduce {
            targets,
            output,
            quick,
            spd_dir,
            threads,
        } => {
            let all: Vec<String> = hugrt::reproduce::TARGETS
                .iter()
                .map(|t| t.name.to_string())
                .collect();
            let targets = if targets.iter().any(|t| t == "all") {
                all.clone()
            } else {
                targets
            };
            for t in &targets {
                if !hugrt::reproduce::TARGETS.iter().any(|x| x.name == t) {
                    bail!("unknown target '{t}'; targets: {}, all", all.join(", "));
                }
            }
            let options = hugrt::reproduce::Options { quick, spd_dir };
            pool(threads)?.install(|| {
                for t in &targets {
                    let dir = hugrt::reproduce::run(t, &options, &output)?;
                    say!("{t}: {}", dir.join("report.md").display());
                }
                Ok(())
            })
        }
        Command::Structures { name, json } => {
            let names: Vec<&str> = match &name {
                Some(n) if !STRUCTURES.contains(&n.as_str()) => bail!(
                    "unknown structure '{n}'; valid structures: {}",
                    STRUCTURES.join(", ")
                ),
                Some(n) => vec![n.as_str()],
                None => STRUCTURES.to_vec(),
            };
            let table: Vec<(&str, Vec<hugrt::accel::KeyHelp>)> = names
                .iter()
                .map(|n| (*n, AnyAccel::keys(n).expect("a listed structure")))
                .collect();
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
        Command::Bench {
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
        } => {
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
                    workload,
                    repeat: repeat as usize,
                    json,
                    csv,
                    quiet,
                })
            })
        }
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
