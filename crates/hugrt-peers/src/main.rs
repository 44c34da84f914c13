//! Benchmark only (issue 7's peers): the Rust BVH crates a user would pick instead of hugrt,
//! built over a triangle mesh as their documentation recommends for speed, tracing a hugrt
//! rays file on N threads. The report is `hugrt trace`'s line (build ms, median trace ms,
//! Mrays/s) plus bytes per triangle, so the scripts that pair `hugrt trace` with Embree pair
//! these too; `--hits` writes hugrt's hits format for the hit comparison.
//!
//! * `obvhs-cwbvh`, `obvhs-bvh2`: obvhs's PLOC builder at `BvhBuildParams::medium_build()`
//!   (its examples' choice), triangles laid out in the BVH's primitive order (its
//!   `cornell_box_cwbvh` example), its own two-sided Möller–Trumbore test.
//! * `bvh`: the `bvh` crate's `build_par`; its ray–triangle test culls back faces, so the
//!   candidates its `traverse_iterator` yields are tested with hugrt's watertight test. The
//!   crate's nearest-first iterators are "best-effort" ordered (their documentation), which
//!   rules out stopping at the first hit: every candidate is tested.
//!
//! Never a dependency of the library: this crate is not a default member of the workspace.

use anyhow::{Context, Result, bail};
use clap::{Parser, ValueEnum};
use hugrt::accel::Hit;
use hugrt::geometry::{PreparedRay, Ray, Shape, Vec3, intersect_triangle};
use hugrt::scene::Scene;
use rayon::prelude::*;
use std::path::PathBuf;
use std::time::{Duration, Instant};

#[derive(Parser)]
#[command(about = "Trace a hugrt rays file with a Rust BVH crate (benchmark only)")]
struct Args {
    /// A triangle mesh (PLY, OBJ or NFF; every primitive must be a triangle).
    mesh: PathBuf,
    #[arg(long)]
    rays: PathBuf,
    #[arg(long, value_enum)]
    peer: Peer,
    /// Write the hits (hugrt's format).
    #[arg(long)]
    hits: Option<PathBuf>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Runs of the trace; the median is reported.
    #[arg(long, default_value_t = 3)]
    repeat: usize,
}

#[derive(Clone, Copy, ValueEnum)]
enum Peer {
    ObvhsCwbvh,
    ObvhsBvh2,
    Bvh,
}

/// A triangle of the `bvh` crate's world.
struct CrateTriangle {
    v: [Vec3; 3],
    id: u32,
    node: usize,
}

impl bvh::aabb::Bounded<f32, 3> for CrateTriangle {
    fn aabb(&self) -> bvh::aabb::Aabb<f32, 3> {
        let p = |v: Vec3| nalgebra::Point3::new(v.x, v.y, v.z);
        bvh::aabb::Aabb::empty()
            .grow(&p(self.v[0]))
            .grow(&p(self.v[1]))
            .grow(&p(self.v[2]))
    }
}

impl bvh::bounding_hierarchy::BHShape<f32, 3> for CrateTriangle {
    fn set_bh_node_index(&mut self, index: usize) {
        self.node = index;
    }
    fn bh_node_index(&self) -> usize {
        self.node
    }
}

enum Built {
    Cwbvh(obvhs::cwbvh::CwBvh, Vec<obvhs::triangle::Triangle>),
    Bvh2(obvhs::bvh2::Bvh2, Vec<obvhs::triangle::Triangle>),
    Crate(bvh::bvh::Bvh<f32, 3>, Vec<CrateTriangle>),
}

/// The triangles in the BVH's primitive order (obvhs's `cornell_box_cwbvh` example).
fn laid_out(indices: &[u32], tris: &[obvhs::triangle::Triangle]) -> Vec<obvhs::triangle::Triangle> {
    indices.iter().map(|&i| tris[i as usize]).collect()
}

fn obvhs_ray(r: &Ray) -> obvhs::ray::Ray {
    let v = |v: Vec3| glam::Vec3A::new(v.x, v.y, v.z);
    obvhs::ray::Ray::new(v(r.origin), v(r.dir), r.tmin, r.tmax)
}

impl Built {
    fn build(peer: Peer, triangles: &[[Vec3; 3]]) -> Built {
        let obvhs_triangles = || -> Vec<obvhs::triangle::Triangle> {
            let v = |v: Vec3| glam::Vec3A::new(v.x, v.y, v.z);
            triangles
                .iter()
                .map(|t| obvhs::triangle::Triangle {
                    v0: v(t[0]),
                    v1: v(t[1]),
                    v2: v(t[2]),
                })
                .collect()
        };
        let params = obvhs::BvhBuildParams::medium_build();
        match peer {
            Peer::ObvhsCwbvh => {
                let tris = obvhs_triangles();
                let bvh = obvhs::cwbvh::builder::build_cwbvh_from_tris(
                    &tris,
                    params,
                    &mut Duration::default(),
                );
                let laid = laid_out(&bvh.primitive_indices, &tris);
                Built::Cwbvh(bvh, laid)
            }
            Peer::ObvhsBvh2 => {
                let tris = obvhs_triangles();
                let bvh = obvhs::bvh2::builder::build_bvh2_from_tris(
                    &tris,
                    params,
                    &mut Duration::default(),
                );
                let laid = laid_out(&bvh.primitive_indices, &tris);
                Built::Bvh2(bvh, laid)
            }
            Peer::Bvh => {
                use bvh::bounding_hierarchy::BoundingHierarchy;
                let mut tris: Vec<CrateTriangle> = triangles
                    .iter()
                    .enumerate()
                    .map(|(i, &v)| CrateTriangle {
                        v,
                        id: i as u32,
                        node: 0,
                    })
                    .collect();
                let bvh = bvh::bvh::Bvh::build_par(&mut tris);
                Built::Crate(bvh, tris)
            }
        }
    }

    fn bytes(&self) -> usize {
        use std::mem::size_of_val;
        match self {
            Built::Cwbvh(b, t) => {
                size_of_val(&b.nodes[..])
                    + size_of_val(&b.primitive_indices[..])
                    + size_of_val(&t[..])
            }
            Built::Bvh2(b, t) => {
                size_of_val(&b.nodes[..])
                    + size_of_val(&b.primitive_indices[..])
                    + size_of_val(&t[..])
            }
            Built::Crate(b, t) => size_of_val(&b.nodes[..]) + size_of_val(&t[..]),
        }
    }

    fn closest(&self, r: &Ray) -> Option<Hit> {
        let obvhs_hit = |found: bool, hit: obvhs::ray::RayHit, indices: &[u32]| {
            found.then(|| Hit {
                t: hit.t,
                prim: indices[hit.primitive_id as usize],
            })
        };
        match self {
            Built::Cwbvh(b, t) => {
                let mut hit = obvhs::ray::RayHit::none();
                let found = b.ray_traverse(obvhs_ray(r), &mut hit, |ray, id| t[id].intersect(ray));
                obvhs_hit(found, hit, &b.primitive_indices)
            }
            Built::Bvh2(b, t) => {
                let mut hit = obvhs::ray::RayHit::none();
                let found = b.ray_traverse(obvhs_ray(r), &mut hit, |ray, id| t[id].intersect(ray));
                obvhs_hit(found, hit, &b.primitive_indices)
            }
            Built::Crate(b, t) => {
                let p = |v: Vec3| nalgebra::Point3::new(v.x, v.y, v.z);
                let ray = bvh::ray::Ray::new(
                    p(r.origin),
                    nalgebra::Vector3::new(r.dir.x, r.dir.y, r.dir.z),
                );
                let pr = PreparedRay::new(r);
                let mut best: Option<Hit> = None;
                for tri in b.traverse_iterator(&ray, t) {
                    let tmax = best.map_or(r.tmax, |h| h.t);
                    if let Some(th) = intersect_triangle(&pr, &tri.v, r.tmin, tmax)
                        && Hit::improves(&best, th, tri.id)
                    {
                        best = Some(Hit {
                            t: th,
                            prim: tri.id,
                        });
                    }
                }
                best
            }
        }
    }
}

fn main() -> Result<()> {
    let args = Args::parse();
    if let Some(n) = args.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
            .context("thread pool")?;
    }
    let scene = Scene::load(&args.mesh).with_context(|| args.mesh.display().to_string())?;
    let mut triangles = Vec::with_capacity(scene.len());
    for s in scene.primitives() {
        match s {
            Shape::Triangle(v) => triangles.push(v),
            _ => bail!("{}: the peers take triangles only", args.mesh.display()),
        }
    }
    let bytes = std::fs::read(&args.rays).with_context(|| args.rays.display().to_string())?;
    let rays = hugrt::batch::decode_rays(&bytes)?;
    let start = Instant::now();
    let built = Built::build(args.peer, &triangles);
    let build_ms = start.elapsed().as_secs_f64() * 1e3;
    let mut times = Vec::new();
    // One buffer for every run, as `hugrt trace` and embree-peer do.
    let mut hits = vec![None; rays.len()];
    for _ in 0..args.repeat.max(1) {
        let start = Instant::now();
        hits.par_iter_mut()
            .zip(rays.par_iter())
            .for_each(|(h, r)| *h = built.closest(r));
        times.push(start.elapsed().as_secs_f64() * 1e3);
    }
    times.sort_by(f64::total_cmp);
    let trace_ms = times[times.len() / 2];
    eprintln!(
        "build {build_ms:.1} ms, trace {trace_ms:.1} ms, {} rays, {:.3} Mrays/s, {:.1} bytes/triangle",
        rays.len(),
        rays.len() as f64 / trace_ms / 1e3,
        built.bytes() as f64 / triangles.len().max(1) as f64
    );
    if let Some(path) = &args.hits {
        std::fs::write(path, hugrt::batch::encode_hits(&hits))
            .with_context(|| path.display().to_string())?;
    }
    Ok(())
}
