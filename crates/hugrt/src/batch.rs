//! Batch ray queries in the file format of `hugrt trace` (shared with embree-peer):
//! rays are raw little-endian records of 8 `f32` `ox oy oz tmin dx dy dz tmax` (32 bytes, no
//! header); hits are per ray an `f32` `t` (+inf on a miss) and a `u32` primitive index
//! (`0xFFFFFFFF` on a miss). For any-hit queries `t` is 1.0 and the index 0 when the ray is
//! blocked, as embree-peer writes them. The full hits format ([`encode_full_hits`]) adds the
//! barycentrics and the geometric normal of each closest hit: per ray `f32 t`, `u32` index,
//! `f32 u, v`, `f32 nx, ny, nz` (28 bytes; a miss is +inf, `0xFFFFFFFF` and zeros). The
//! all-hits format ([`encode_all_hits`]) holds per ray a `u32` count, then that many pairs
//! `f32 t`, `u32` index in order of `t` (ties by index), records of varying length.
//!
//! The instanced hits format ([`encode_instanced_hits`], for scenes of instances,
//! [`crate::world`]) holds per ray `f32 t`, `u32` model, `u32` primitive in the model, `u32`
//! instance of the world (`0xFFFFFFFF` for the world's own geometry), `u64` index in the
//! flattened world (24 bytes; a miss is +inf and all ones). In the other formats an instanced
//! world's hit is its flattened index, which must then be below 2^32 − 1.

use crate::accel::{AnyAccel, Hit, HitDetails, NoCounters, Packets, Primitives, RayCounters};
use crate::geometry::{Ray, Vec3};
use crate::world::{InstanceHit, World};
use rayon::prelude::*;

pub const RAY_BYTES: usize = 32;
pub const HIT_BYTES: usize = 8;
pub const FULL_HIT_BYTES: usize = 28;
pub const INSTANCED_HIT_BYTES: usize = 24;

#[derive(Debug, thiserror::Error)]
#[error("rays file is {len} bytes, not a multiple of {RAY_BYTES} (8 little-endian f32 per ray)")]
pub struct RaysFileError {
    pub len: usize,
}

pub fn decode_rays(bytes: &[u8]) -> Result<Vec<Ray>, RaysFileError> {
    if !bytes.len().is_multiple_of(RAY_BYTES) {
        return Err(RaysFileError { len: bytes.len() });
    }
    Ok(bytes
        .chunks_exact(RAY_BYTES)
        .map(|r| {
            let f = |k: usize| f32::from_le_bytes(r[4 * k..4 * k + 4].try_into().unwrap());
            Ray::new(
                Vec3::new(f(0), f(1), f(2)),
                Vec3::new(f(4), f(5), f(6)),
                f(3),
                f(7),
            )
        })
        .collect())
}

pub fn encode_rays(rays: &[Ray]) -> Vec<u8> {
    let mut out = Vec::with_capacity(rays.len() * RAY_BYTES);
    for r in rays {
        for x in [
            r.origin.x, r.origin.y, r.origin.z, r.tmin, r.dir.x, r.dir.y, r.dir.z, r.tmax,
        ] {
            out.extend_from_slice(&x.to_le_bytes());
        }
    }
    out
}

pub fn encode_hits(hits: &[Option<Hit>]) -> Vec<u8> {
    let mut out = Vec::with_capacity(hits.len() * HIT_BYTES);
    for h in hits {
        let (t, p) = h.map_or((f32::INFINITY, u32::MAX), |h| (h.t, h.prim));
        out.extend_from_slice(&t.to_le_bytes());
        out.extend_from_slice(&p.to_le_bytes());
    }
    out
}

/// Closest hits in the full format (module documentation), with [`Hit::details`] computed
/// once per hit.
///
/// # Panics
/// When `hits` and `rays` differ in length.
pub fn encode_full_hits<P: Primitives>(prims: &P, rays: &[Ray], hits: &[Option<Hit>]) -> Vec<u8> {
    assert_eq!(hits.len(), rays.len(), "one answer per ray");
    let records: Vec<[u8; FULL_HIT_BYTES]> = hits
        .par_iter()
        .zip(rays.par_iter())
        .map(|(h, r)| full_record(h.map(|h| h.details(prims, r))))
        .collect();
    records.concat()
}

/// One record of the full format: a hit's details, or a miss (+inf, all ones, zeros).
fn full_record(d: Option<HitDetails>) -> [u8; FULL_HIT_BYTES] {
    let (t, p, u, v, n) = match d {
        Some(d) => (d.t, d.prim, d.u, d.v, d.normal),
        None => (f32::INFINITY, u32::MAX, 0.0, 0.0, Vec3::ZERO),
    };
    let mut rec = [0u8; FULL_HIT_BYTES];
    rec[0..4].copy_from_slice(&t.to_le_bytes());
    rec[4..8].copy_from_slice(&p.to_le_bytes());
    for (k, x) in [u, v, n.x, n.y, n.z].into_iter().enumerate() {
        rec[8 + 4 * k..12 + 4 * k].copy_from_slice(&x.to_le_bytes());
    }
    rec
}

/// Which query a batch runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Query {
    /// The nearest hit ([`AnyAccel::closest_hit`]).
    Closest,
    /// Whether anything is hit ([`AnyAccel::any_hit`]).
    Any,
    /// Every hit ([`AnyAccel::all_hits`]).
    All,
}

impl Query {
    /// The query's name on the command line (`trace --any-hit`, `--all-hits`).
    pub fn name(&self) -> &'static str {
        match self {
            Query::Closest => "closest-hit",
            Query::Any => "any-hit",
            Query::All => "all-hits",
        }
    }
}

/// How closest hits are written (module documentation): `basic`, `t` and primitive (8
/// bytes, embree-peer's), or `full`, with the barycentrics and the normal (28 bytes). Any-hit
/// and all-hits answers have one format each.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum HitFormat {
    #[default]
    Basic,
    Full,
    /// Model, primitive, instance and flattened index (module documentation).
    Instanced,
}

impl HitFormat {
    /// Every format's name, as `str::parse` reads it.
    pub const NAMES: &[&str] = &["basic", "full", "instanced"];
}

impl std::str::FromStr for HitFormat {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "basic" => Ok(HitFormat::Basic),
            "full" => Ok(HitFormat::Full),
            "instanced" => Ok(HitFormat::Instanced),
            _ => Err(format!(
                "unknown hit format '{s}'; formats: {}",
                Self::NAMES.join(", ")
            )),
        }
    }
}

/// A query and a hits format that do not go together.
#[derive(Debug, thiserror::Error)]
#[error("the full and instanced hits formats describe closest hits, not the answers of {} queries", .0.name())]
pub struct FormatError(pub Query);

/// Checks that `format` can write the answers of `query`, before any work.
pub fn check_format(query: Query, format: HitFormat) -> Result<(), FormatError> {
    if format != HitFormat::Basic && query != Query::Closest {
        return Err(FormatError(query));
    }
    Ok(())
}

/// A timed batch: the hits file's bytes, the number of hits, and the trace times.
pub struct Traced {
    pub bytes: Vec<u8>,
    pub hits: usize,
    pub timing: crate::bench::Timing,
}

/// Traces `rays` `repeat` times (at least once) on the current rayon pool, timing each run,
/// closest and any hits with `packets` ([`trace_into`]; every hit is walked ray by ray), and encodes the last run's answers to `query` in `format` (one buffer for every run, as
/// [`trace_into`] says why).
pub fn trace_timed<P: Primitives>(
    prims: &P,
    accel: &AnyAccel,
    rays: &[Ray],
    query: Query,
    format: HitFormat,
    repeat: usize,
    packets: Packets,
) -> Result<Traced, FormatError> {
    check_format(query, format)?;
    let mut times = Vec::new();
    let mut timed = |f: &mut dyn FnMut()| {
        for _ in 0..repeat.max(1) {
            let t = std::time::Instant::now();
            f();
            times.push(t.elapsed().as_secs_f64());
        }
    };
    let (bytes, hits) = if query == Query::All {
        let mut result = Vec::new();
        timed(&mut || result = trace_all(prims, accel, rays));
        let hits = result.iter().map(Vec::len).sum();
        (encode_all_hits(&result), hits)
    } else {
        let mut result = vec![None; rays.len()];
        timed(&mut || {
            trace_into(
                prims,
                accel,
                rays,
                query == Query::Any,
                packets,
                &mut result,
            )
        });
        let hits = result.iter().filter(|h| h.is_some()).count();
        let bytes = match format {
            HitFormat::Basic => encode_hits(&result),
            HitFormat::Full => encode_full_hits(prims, rays, &result),
            HitFormat::Instanced => {
                let records: Vec<Option<InstanceRecord>> = result
                    .iter()
                    .map(|h| {
                        h.map(|h| InstanceRecord {
                            t: h.t,
                            model: 0,
                            prim: h.prim,
                            instance: u32::MAX,
                            flat: h.prim as u64,
                        })
                    })
                    .collect();
                encode_instance_records(&records)
            }
        };
        (bytes, hits)
    };
    Ok(Traced {
        bytes,
        hits,
        timing: crate::bench::Timing::from_secs(times),
    })
}

/// [`trace_timed`] over a scene, compiled here: a caller in another crate that instantiated the
/// generic function itself measured the bvh's packets no faster than single rays, where the
/// same code compiled in this crate was 1.3× faster (the compiler inlines differently across
/// crates).
pub fn trace_scene_timed(
    scene: &crate::scene::Scene,
    accel: &AnyAccel,
    rays: &[Ray],
    query: Query,
    format: HitFormat,
    repeat: usize,
    packets: Packets,
) -> Result<Traced, FormatError> {
    trace_timed(scene, accel, rays, query, format, repeat, packets)
}

/// Every hit of every ray, in order of `t` ([`AnyAccel::all_hits`]), on the current rayon
/// pool.
pub fn trace_all<P: Primitives>(prims: &P, accel: &AnyAccel, rays: &[Ray]) -> Vec<Vec<Hit>> {
    rays.par_iter()
        .with_min_len(256)
        .map(|r| accel.all_hits(prims, r, &mut NoCounters))
        .collect()
}

/// Every ray's hits in the all-hits format (module documentation).
pub fn encode_all_hits(hits: &[Vec<Hit>]) -> Vec<u8> {
    let pairs: usize = hits.iter().map(Vec::len).sum();
    let mut out = Vec::with_capacity(4 * hits.len() + HIT_BYTES * pairs);
    for ray in hits {
        let n = u32::try_from(ray.len()).expect("fewer than 2^32 hits a ray");
        out.extend_from_slice(&n.to_le_bytes());
        for h in ray {
            out.extend_from_slice(&h.t.to_le_bytes());
            out.extend_from_slice(&h.prim.to_le_bytes());
        }
    }
    out
}

/// Traces every ray on the current rayon pool, groups of neighbours as packets where
/// `packets` says ([`Packets`]). Any-hit results are reported as `Hit { t: 1.0, prim: 0 }`.
pub fn trace<P: Primitives>(
    prims: &P,
    accel: &AnyAccel,
    rays: &[Ray],
    any_hit: bool,
    packets: Packets,
) -> Vec<Option<Hit>> {
    let mut out = vec![None; rays.len()];
    trace_into(prims, accel, rays, any_hit, packets, &mut out);
    out
}

/// [`trace`] into the caller's buffer, one answer per ray. Timed runs reuse one buffer, as
/// embree-peer does: a fresh one per run made every run pay for the first touch of its pages
/// (an eighth of a camera frame's time on a sparse scene, where rays are cheap).
///
/// # Panics
/// When `out` and `rays` differ in length.
pub fn trace_into<P: Primitives>(
    prims: &P,
    accel: &AnyAccel,
    rays: &[Ray],
    any_hit: bool,
    packets: Packets,
    out: &mut [Option<Hit>],
) {
    assert_eq!(out.len(), rays.len(), "one answer per ray");
    // Windows of whole bands of a camera's rows, so that each call can group them in tiles
    // ([`crate::accel::order`]).
    let window = crate::accel::order::window(rays);
    out.par_chunks_mut(window)
        .zip(rays.par_chunks(window))
        .for_each(|(o, r)| {
            if any_hit {
                accel.any_hits(prims, r, packets, o, &mut NoCounters);
                for h in o.iter_mut() {
                    *h = h.map(|_| Hit { t: 1.0, prim: 0 });
                }
            } else {
                accel.closest_hits(prims, r, packets, o, &mut NoCounters);
            }
        });
}

/// The traversal counters of a batch of queries, summed over the rays: the papers' #pit,
/// #pi, #bbi and #vt per hierarchy level. A separate pass, so that [`trace`] is timed without
/// them.
pub fn count<P: Primitives>(
    prims: &P,
    accel: &AnyAccel,
    rays: &[Ray],
    query: Query,
) -> RayCounters {
    rays.par_iter()
        .with_min_len(256)
        .fold(RayCounters::default, |mut c, r| {
            match query {
                Query::Closest => {
                    accel.closest_hit(prims, r, &mut c);
                }
                Query::Any => {
                    accel.any_hit(prims, r, &mut c);
                }
                Query::All => {
                    accel.for_each_hit(prims, r, &mut c, |_| std::ops::ControlFlow::Continue(()))
                }
            }
            c
        })
        .reduce(RayCounters::default, |mut a, b| {
            a.add(&b);
            a
        })
}

/// Rays as embree-peer's `gen_rays.py incoherent` makes them: origins uniform in the box,
/// directions uniform on the sphere, `t` in `[0, inf]`.
pub fn incoherent_rays(bounds: &crate::geometry::Aabb, n: usize, seed: u64) -> Vec<Ray> {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            let o =
                bounds.min + bounds.extent() * Vec3::new(rng.random(), rng.random(), rng.random());
            let d = loop {
                let v = Vec3::new(rng.random(), rng.random(), rng.random()) * 2.0 - Vec3::ONE;
                let l = v.length_squared();
                if l > 1e-6 && l <= 1.0 {
                    break v / l.sqrt();
                }
            };
            Ray::new(o, d, 0.0, f32::INFINITY)
        })
        .collect()
}

/// Pinhole rays as `gen_rays.py camera` makes them: from 1.5 box diagonals away along
/// (1, 0.6, 1.4), 45° field of view, through pixel centres, row by row from the top.
pub fn camera_rays(bounds: &crate::geometry::Aabb, w: u32, h: u32) -> Vec<Ray> {
    let c = bounds.center();
    let eye = c + Vec3::new(1.0, 0.6, 1.4).normalize() * 1.5 * bounds.diagonal();
    let fwd = (c - eye).normalize();
    let right = fwd.cross(Vec3::Y).normalize();
    let up = right.cross(fwd);
    let s = (45f32.to_radians() / 2.0).tan();
    let mut rays = Vec::with_capacity(w as usize * h as usize);
    for y in 0..h {
        for x in 0..w {
            let u = (2.0 * (x as f32 + 0.5) / w as f32 - 1.0) * s * w as f32 / h as f32;
            let v = (1.0 - 2.0 * (y as f32 + 0.5) / h as f32) * s;
            rays.push(Ray::new(eye, fwd + right * u + up * v, 0.0, f32::INFINITY));
        }
    }
    rays
}

/// One record of the instanced hits format.
struct InstanceRecord {
    t: f32,
    model: u32,
    prim: u32,
    instance: u32,
    flat: u64,
}

fn encode_instance_records(hits: &[Option<InstanceRecord>]) -> Vec<u8> {
    let mut out = Vec::with_capacity(hits.len() * INSTANCED_HIT_BYTES);
    for h in hits {
        match h {
            Some(h) => {
                out.extend_from_slice(&h.t.to_le_bytes());
                for x in [h.model, h.prim, h.instance] {
                    out.extend_from_slice(&x.to_le_bytes());
                }
                out.extend_from_slice(&h.flat.to_le_bytes());
            }
            None => {
                out.extend_from_slice(&f32::INFINITY.to_le_bytes());
                out.extend_from_slice(&[0xFF; INSTANCED_HIT_BYTES - 4]);
            }
        }
    }
    out
}

/// An instanced world's closest hits in the instanced format (module documentation).
pub fn encode_instanced_hits(hits: &[Option<InstanceHit>]) -> Vec<u8> {
    let records: Vec<Option<InstanceRecord>> = hits
        .iter()
        .map(|h| {
            h.map(|h| InstanceRecord {
                t: h.t,
                model: h.model,
                prim: h.prim,
                instance: h.instances.top().unwrap_or(u32::MAX),
                flat: h.flat_prim,
            })
        })
        .collect();
    encode_instance_records(&records)
}

/// [`trace_timed`] for an instanced world: closest or any hits (all-hits through instances
/// is not offered), closest hits in any format, the basic and full ones by flattened index.
pub fn trace_world_timed(
    world: &World,
    rays: &[Ray],
    query: Query,
    format: HitFormat,
    repeat: usize,
) -> Result<Traced, crate::Error> {
    check_format(query, format).map_err(|e| crate::Error::Invalid(e.to_string()))?;
    if query == Query::All {
        return Err(crate::Error::Invalid(
            "all-hits queries through instances are not offered: trace the flattened scene".into(),
        ));
    }
    if format != HitFormat::Instanced && world.flattened_primitives() >= u32::MAX as u64 {
        return Err(crate::Error::Invalid(format!(
            "{} primitives once flattened: more than a u32 index holds; use --hit-format instanced",
            world.flattened_primitives()
        )));
    }
    // Every ray answered `repeat` times (at least once) into one buffer, each run timed.
    fn runs<T: Copy + Send>(
        rays: &[Ray],
        repeat: usize,
        answer: impl Fn(&Ray) -> Option<T> + Sync,
    ) -> (Vec<Option<T>>, Vec<f64>) {
        let mut out = vec![None; rays.len()];
        let times = (0..repeat.max(1))
            .map(|_| {
                let t = std::time::Instant::now();
                out.par_iter_mut()
                    .zip(rays.par_iter())
                    .with_min_len(64)
                    .for_each(|(o, r)| *o = answer(r));
                t.elapsed().as_secs_f64()
            })
            .collect();
        (out, times)
    }
    if query == Query::Any {
        // As `trace` writes any-hit answers: `t = 1`, index 0.
        let blocked = |r: &Ray| {
            world
                .any_hit(r, &mut NoCounters)
                .then_some(Hit { t: 1.0, prim: 0 })
        };
        let (result, times) = runs(rays, repeat, blocked);
        return Ok(Traced {
            bytes: encode_hits(&result),
            hits: result.iter().flatten().count(),
            timing: crate::bench::Timing::from_secs(times),
        });
    }
    let (result, times) = runs(rays, repeat, |r| world.closest_hit(r, &mut NoCounters));
    let hits = result.iter().flatten().count();
    let flat = |h: &InstanceHit| Hit {
        t: h.t,
        prim: h.flat_prim as u32,
    };
    let bytes = match format {
        HitFormat::Basic => encode_hits(
            &result
                .iter()
                .map(|h| h.as_ref().map(flat))
                .collect::<Vec<_>>(),
        ),
        HitFormat::Instanced => encode_instanced_hits(&result),
        HitFormat::Full => {
            let records: Vec<[u8; FULL_HIT_BYTES]> = result
                .par_iter()
                .zip(rays.par_iter())
                .map(|(h, r)| {
                    full_record(h.map(|h| HitDetails {
                        prim: h.flat_prim as u32,
                        ..world.details(&h, r)
                    }))
                })
                .collect();
            records.concat()
        }
    };
    Ok(Traced {
        bytes,
        hits,
        timing: crate::bench::Timing::from_secs(times),
    })
}
