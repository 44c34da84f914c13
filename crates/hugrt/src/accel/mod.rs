//! Spatial structures for ray shooting, all behind one interface.
//!
//! A structure is built from a [`Primitives`] set (bounding boxes, an exact box-overlap test,
//! and "intersect primitive i") and answers closest-hit, any-hit and all-hits queries, one
//! walk each offering its hits to a [`HitSink`]. Queries are generic over the primitive set,
//! the sink and the [`Counters`], so the traversal is monomorphised: no virtual call per
//! primitive, and counting costs nothing when [`NoCounters`] is used.
//!
//! Structures are chosen at run time by a spec string `name[:key=value,...]` ([`Spec`]).
//! [`AnyAccel`] holds one of them; the list in `structures!` below is the single place that
//! names them all, and the tests, the CLI and the benchmarks iterate it. Adding a structure is
//! one module and one line there.

mod agrid;
mod block;
mod brute;
mod bvh;
mod counters;
mod frame;
mod grid;
mod hierarchy;
pub mod hug;
mod kdtree;
mod mailbox;
mod margin;
mod octree;
pub(crate) mod order;
pub mod packet;
mod query;
mod reach;
mod rgrid;
pub mod settings;
mod shadow_cache;
mod simd;
mod sort;
mod spec;
mod store;

pub use agrid::{AdaptiveGrid, AdaptiveSettings};
pub use brute::Brute;
pub use bvh::{Bvh, BvhSettings};
pub use counters::{
    BBI, COUNTER_COUNT, COUNTERS, Counter, CounterInfo, Counters, Counts, LevelCounts, MAX_LEVELS,
    NoCounters, PI, PIT, RayCounters, VT,
};
pub(crate) use frame::Frame;
pub use grid::{Grid, GridSettings};
pub use hierarchy::{GridLevelStats, LevelView, Prune, cubical_resolution};
pub use hug::{Hug, HugSettings};
pub use kdtree::{KdTree, KdTreeSettings, Layout as KdTreeLayout, SplitRule as KdTreeSplit};
pub use mailbox::Mailbox;
pub use octree::{Octree, OctreeSettings};
pub use packet::{MAX_PACKET, PACKET, Packets};
pub use query::{AnyHit, Closest, EveryHit, Hit, HitSink, Occlusion};
pub use reach::Reach;
use reach::Route;
pub use rgrid::{RecursiveGrid, RecursiveGridSettings};
pub use settings::{KeyHelp, NoSettings, Settings};
use shadow_cache::ShadowCache;
pub use simd::Simd;
pub use spec::{Preset, Spec, SpecError};

/// The papers' algorithms as structure settings (a structure's `preset` key), each value with
/// the section of its paper: `hugrt stats SCENE --accel hug:preset=eg95` and so on.
pub mod presets {
    pub use super::hug::{EG95 as HUG_EG95, SCG97 as HUG_SCG97};
    pub use super::kdtree::HAVRAN as KDTREE_HAVRAN;
    pub use super::octree::EG95 as OCTREE_EG95;
    pub use super::rgrid::EG95 as RGRID_EG95;

    /// Every preset with the structure it belongs to.
    pub const ALL: &[(&str, super::Preset)] = &[
        ("hug", HUG_EG95),
        ("hug", HUG_SCG97),
        ("rgrid", RGRID_EG95),
        ("octree", OCTREE_EG95),
        ("kdtree", KDTREE_HAVRAN),
    ];
}
pub use store::{PrimStore, TriangleStorage};

use crate::geometry::{Aabb, Cone, PreparedRay, Ray, Sphere, Vec3};
use glam::DVec3;

/// What a primitive is, for structures that keep their own compact copy of it
/// ([`PrimStore`]). `Opaque` primitives are kept by index and intersected through
/// [`Primitives::intersect`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PrimitiveKind {
    Triangle([Vec3; 3]),
    Sphere(Sphere),
    Cone(Cone),
    Opaque,
}

/// A set of primitives as a structure sees it.
pub trait Primitives: Sync {
    fn len(&self) -> usize;
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    fn bounds(&self, i: usize) -> Aabb;
    /// Hit parameter of primitive `i` in `[tmin, tmax]`, if any.
    fn intersect(&self, i: usize, ray: &PreparedRay, tmin: f32, tmax: f32) -> Option<f32>;
    /// Exact overlap of primitive `i` with a box; `true` when unsure (conservative). The
    /// grids' pruning asks it of every primitive their store does not hold as a triangle; a
    /// triangle's test they prepare once from the store's copy for all the cells it spans.
    fn overlaps_box(&self, _i: usize, _b: &Aabb) -> bool {
        true
    }
    /// The primitive as geometry the store can hold. The contract: [`Primitives::intersect`]
    /// of `i` is the geometry module's test of that geometry (`intersect_triangle`,
    /// `Sphere::intersect`, `Cone::intersect`), so that a structure testing its own copy finds
    /// bit for bit the same hits. The default keeps every primitive opaque.
    fn kind(&self, _i: usize) -> PrimitiveKind {
        PrimitiveKind::Opaque
    }
    /// Primitive `i`'s vertex indices into [`Primitives::shared_vertices`], when it is a
    /// triangle of an indexed mesh. The contract: [`Primitives::kind`] of `i` is then
    /// `Triangle(indices.map(|k| vertices[k]))`. A structure built with `store=index` tests
    /// such triangles through the indices and the shared vertices, copying neither.
    fn mesh_triangle(&self, _i: usize) -> Option<[u32; 3]> {
        None
    }
    /// The vertices [`Primitives::mesh_triangle`] indexes, shared with the structures.
    fn shared_vertices(&self) -> Option<std::sync::Arc<Vec<Vec3>>> {
        None
    }
}

/// What renderers and collision code want of a hit besides `t` and the primitive, computed
/// once per hit ([`Hit::details`]), never in a structure's inner loop.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HitDetails {
    pub t: f32,
    pub prim: u32,
    /// Barycentric coordinates of a triangle's hit point, the weights of its vertices 1 and 2
    /// (`p = (1 − u − v)·v0 + u·v1 + v·v2`), in double precision from the point at `t`; 0 for
    /// other primitives.
    pub u: f32,
    pub v: f32,
    /// Unit geometric normal: a triangle's `(v1 − v0) × (v2 − v0)` (its winding decides the
    /// side, not the ray), a sphere's or cone's outward normal; zero for opaque primitives.
    pub normal: Vec3,
}

impl Hit {
    /// The hit's barycentrics and normal, for the ray that found it.
    ///
    /// The hit point is found again in double precision on the ray's line, not taken as
    /// `origin + t·dir` in single precision: the point at the rounded `t` (one rounding, a
    /// fused multiply-add, so on the line to an ulp of itself), then, for a triangle, the
    /// line's crossing of its plane and, for a sphere, the line's nearest crossing of it from
    /// there. A ray from far away ([`Reach`]) thus gets barycentrics and normals as accurate as
    /// a near one's, where the single-precision point would stray by `2⁻²⁴` of its distance.
    pub fn details<P: Primitives>(&self, prims: &P, ray: &Ray) -> HitDetails {
        let d = ray.dir.as_dvec3();
        let at_t = d.mul_add(DVec3::splat(self.t as f64), ray.origin.as_dvec3());
        let (u, v, normal) = match prims.kind(self.prim as usize) {
            PrimitiveKind::Triangle(tri) => {
                let [a, b, c] = tri.map(|x| x.as_dvec3());
                let n = (b - a).cross(c - a);
                let along = n.dot(d);
                let p = if along == 0.0 {
                    at_t
                } else {
                    d.mul_add(DVec3::splat(n.dot(a - at_t) / along), at_t)
                };
                let w = crate::geometry::barycentric(&tri, p.as_vec3());
                (w.y, w.z, n.normalize_or_zero().as_vec3())
            }
            PrimitiveKind::Sphere(s) => {
                // `|w + step·d|² = r²`, the root of least magnitude in its stable form;
                // the closest approach when rounding leaves the line just outside.
                let centre = s.center.as_dvec3();
                let w = at_t - centre;
                let (dd, b) = (d.dot(d), w.dot(d));
                let cc = w.dot(w) - (s.radius as f64).powi(2);
                let disc = b * b - dd * cc;
                let far_root = -(b + disc.max(0.0).sqrt().copysign(b));
                let step = if disc < 0.0 {
                    -b / dd
                } else if far_root == 0.0 {
                    0.0
                } else {
                    cc / far_root
                };
                let p = d.mul_add(DVec3::splat(step), at_t);
                (0.0, 0.0, (p - centre).normalize_or_zero().as_vec3())
            }
            PrimitiveKind::Cone(c) => (0.0, 0.0, c.normal(at_t.as_vec3())),
            PrimitiveKind::Opaque => (0.0, 0.0, Vec3::ZERO),
        };
        HitDetails {
            t: self.t,
            prim: self.prim,
            u,
            v,
            normal,
        }
    }
}

/// Statistics a structure reports about itself (`hugrt stats`): named numbers, in the order
/// the structure finds meaningful, its cells for Havran's septet, and for grid hierarchies the
/// statistics of each level (SCG97 §3).
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct StructureStats {
    pub entries: Vec<(String, f64)>,
    pub census: CellCensus,
    /// SCG97 §3's statistics per level: a HUG's filter levels, the depth elsewhere.
    pub levels: Vec<GridLevelStats>,
    /// The same by nesting depth, where that differs from `levels` (the HUG's).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub depths: Vec<GridLevelStats>,
}

/// What a structure's cells hold: the static half of Havran's septet (Havran §4.1, Table 2),
/// from which [`mod@crate::bench`] derives `N_C`, `R_ETNC`, `N_ADC`, `N_AOIFC` and `R_FVWV`.
/// Cells are Havran's elementary cells: the cells of every grid that are not inner cells of
/// the hierarchy, or a tree's leaves (Havran's `R_ETNC` is over them: his Tables 5–6 give
/// 11–32%); brute force is one cell holding everything.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct CellCensus {
    /// `N_C`.
    pub cells: usize,
    /// Cells holding at least one object reference (`N_C − N_EC`).
    pub full_cells: usize,
    /// `N_RO`: object references from all cells.
    pub object_refs: usize,
    /// `V_SCENE − V_EMPTY`: summed volume of the full cells (cells of nested grids can lie in
    /// full cells of their parents and then count twice).
    pub full_volume: f64,
}

impl CellCensus {
    /// The census of a grid hierarchy from its levels' statistics. Havran's cells are the
    /// elementary ones: a cell holding only sub-grids is an inner cell of the hierarchy and is
    /// not counted (its objects are, in the sub-grids' cells); a cell counts as full when it
    /// holds an object reference.
    pub fn of_levels(levels: &[GridLevelStats]) -> CellCensus {
        levels
            .iter()
            .fold(CellCensus::default(), |c, l| CellCensus {
                cells: c.cells + l.cells - l.grid_only_cells,
                full_cells: c.full_cells + l.object_cells,
                object_refs: c.object_refs + l.object_refs,
                full_volume: c.full_volume + l.object_cell_volume,
            })
    }
}

impl StructureStats {
    pub fn push(&mut self, name: &str, value: f64) {
        self.entries.push((name.to_string(), value));
    }

    /// The memory entries every structure reports: all its bytes, and per primitive the
    /// structure's own (without its copy of the primitives) and all of them.
    pub fn push_memory(&mut self, structure_bytes: usize, all_bytes: usize, primitives: usize) {
        let n = primitives.max(1) as f64;
        self.push("memory_bytes", all_bytes as f64);
        self.push("structure_bytes_per_primitive", structure_bytes as f64 / n);
        self.push("bytes_per_primitive", all_bytes as f64 / n);
    }
}

/// One spatial structure: built from primitives, queried for the closest hit, any hit, or
/// every hit along a ray.
pub trait Accel: Sized + Send + Sync {
    /// Name used in specs.
    const NAME: &'static str;
    /// The structure's settings: its defaults ([`Default`]) and the table of its spec's keys.
    type Settings: Settings;
    /// Whether the structure's packet walk ([`Accel::query_packet`]) is faster than its walk
    /// of one ray on coherent rays, as measured (`docs/measurements.md`, "Packets"): where it
    /// is not, [`Packets::Auto`] walks every ray alone.
    const PACKETS_PAY: bool = false;
    /// Rays a packet of this structure holds (at most [`MAX_PACKET`]): the groups of
    /// neighbouring rays that [`Accel::closest_hits`] and [`Accel::any_hits`] walk together.
    const PACKET_RAYS: usize = PACKET;
    /// Whether grouping a batch's rays by `accel::order` before walking packets (a camera's in
    /// tiles, a light's by direction) repays the grouping, as measured (`docs/measurements.md`,
    /// "Packets"): a grid's packet of 32 rays shares each slice's cells among a tile's rays,
    /// where the bvh's packets of 8 gained less than the grouping cost.
    const ORDER_PAYS: bool = false;
    /// Whether [`Accel::query_each`] walks several rays at once, faster than one at a time as
    /// measured (`docs/measurements.md`, "The bvh's walks interleaved"): the batch queries
    /// then hand it the rays they do not walk in packets, where otherwise they call
    /// [`Accel::query`] ray by ray.
    const INTERLEAVES: bool = false;

    /// Builds the structure with typed settings, e.g. `Bvh::with_settings(&scene,
    /// &BvhSettings { leaf: 4, ..Default::default() })`: an error names a value out of its
    /// key's range ([`Settings::check`]) or a scene the structure cannot hold.
    fn with_settings<P: Primitives>(
        prims: &P,
        settings: &Self::Settings,
    ) -> Result<Self, SpecError> {
        settings.check()?;
        Self::build_checked(prims, settings)
    }

    /// Builds the structure with the settings a spec's keys give ([`Settings::from_spec`]).
    fn build<P: Primitives>(prims: &P, spec: &Spec) -> Result<Self, SpecError> {
        Self::build_checked(prims, &Self::Settings::from_spec(spec)?)
    }

    /// The build itself, with settings already checked: what [`Accel::with_settings`] and
    /// [`Accel::build`] call.
    fn build_checked<P: Primitives>(
        prims: &P,
        settings: &Self::Settings,
    ) -> Result<Self, SpecError>;

    /// The walk itself, for a ray that [`Ray::is_traceable`]: every primitive that may be hit
    /// in `[ray.tmin, sink.tmax()]` is tested and its hit offered to `sink`, until the sink
    /// says stop ([`HitSink`]). Callers go through [`Accel::closest_hit`], [`Accel::any_hit`],
    /// [`Accel::for_each_hit`] and [`Accel::all_hits`], which check the ray once for every
    /// structure.
    fn query<P: Primitives, C: Counters, S: HitSink>(
        &self,
        prims: &P,
        ray: &Ray,
        sink: &mut S,
        counters: &mut C,
    );

    /// The walk of a packet ([`packet`]): up to [`Accel::PACKET_RAYS`] rays, each traceable,
    /// walked as given ([`Reach::walks_as_given`]) and without subnormal direction components
    /// ([`Ray::without_subnormal_direction`]), each offering its hits to its own sink as
    /// [`Accel::query`] would. Callers go through [`Accel::closest_hits`] and
    /// [`Accel::any_hits`]. The default walks the rays one at a time; a structure with a packet
    /// walk overrides it.
    fn query_packet<P: Primitives, C: Counters, S: HitSink>(
        &self,
        prims: &P,
        rays: &[Ray],
        sinks: &mut [S],
        counters: &mut C,
    ) {
        each_alone(self, prims, rays, sinks, counters);
    }

    /// The walk of rays that the batch queries do not walk in packets, `rays[r]` (each
    /// traceable, walked as given and without subnormal direction components, as in
    /// [`Accel::query_packet`]) offering its hits to `sinks[r]` as [`Accel::query`] would.
    /// Called only where [`Accel::INTERLEAVES`]; the default walks the rays one at a time.
    fn query_each<P: Primitives, C: Counters, S: HitSink>(
        &self,
        prims: &P,
        rays: &[Ray],
        sinks: &mut [S],
        counters: &mut C,
    ) {
        each_alone(self, prims, rays, sinks, counters);
    }

    /// Where the primitives lie: far rays are moved to them before the walk ([`Reach`]).
    fn reach(&self) -> &Reach;

    /// Where its occlusion queries walk a ray's segment from: its settings' `occlusion` key.
    fn occlusion(&self) -> Occlusion;

    /// The nearest hit in the ray's `[tmin, tmax]`; none for a ray that is not traceable.
    #[inline]
    fn closest_hit<P: Primitives, C: Counters>(
        &self,
        prims: &P,
        ray: &Ray,
        counters: &mut C,
    ) -> Option<Hit> {
        match self.reach().route(ray) {
            Route::Skip => return None,
            Route::Moved => {
                return far_first_hit(self, prims, ray, counters, Closest::new, Closest::hit);
            }
            Route::AsGiven => {}
        }
        let ray = &ray.without_subnormal_direction();
        let mut sink = Closest::new(ray.tmax);
        self.query(prims, ray, &mut sink, counters);
        sink.hit()
    }

    /// [`Accel::closest_hit`] with the ray the structure walked (a far ray moved to the
    /// primitives, [`Reach`]) and the hit in that ray's terms: what a primitive's test saw,
    /// for following an instance's hit down ([`crate::world::World::resolve`]).
    fn closest_hit_walked<P: Primitives, C: Counters>(
        &self,
        prims: &P,
        ray: &Ray,
        counters: &mut C,
    ) -> Option<Walked> {
        let (walked, moved) = match self.reach().route(ray) {
            Route::Skip => return None,
            Route::AsGiven => (ray.without_subnormal_direction(), None),
            Route::Moved => {
                let m = self.reach().moved(ray)?;
                (m.ray, Some(m))
            }
        };
        let mut sink = Closest::new(walked.tmax);
        self.query(prims, &walked, &mut sink, counters);
        let hit = sink.hit()?;
        Some(Walked {
            ray: walked,
            hit,
            t: moved.map_or(hit.t, |m| m.hit(hit).t),
        })
    }

    /// Some hit in the ray's `[tmin, tmax]`, if there is any; none for a ray that is not
    /// traceable. Where the ray's segment ends outside the scene's box (a shadow ray to a
    /// light outside it, or a ray without end), it is walked from that end back towards its
    /// start ([`HitSink::walked_back`]), unless the structure's settings say
    /// [`Occlusion::Start`].
    #[inline]
    fn any_hit<P: Primitives, C: Counters>(
        &self,
        prims: &P,
        ray: &Ray,
        counters: &mut C,
    ) -> Option<Hit> {
        match self.reach().route(ray) {
            Route::Skip => return None,
            Route::Moved => {
                return far_first_hit(self, prims, ray, counters, AnyHit::new, AnyHit::hit);
            }
            Route::AsGiven => {}
        }
        let ray = &ray.without_subnormal_direction();
        let far =
            self.occlusion() == Occlusion::Auto && query::ends_outside(ray, self.reach().bounds());
        let mut sink = AnyHit::new(ray.tmax).walked_back(far);
        self.query(prims, ray, &mut sink, counters);
        sink.hit()
    }

    /// The closest hit of each ray: `out[i]` is [`Accel::closest_hit`] of `rays[i]`, bit for
    /// bit. Groups of [`PACKET`] neighbouring rays are walked together as `packets` says
    /// ([`Packets`]), neighbours in an order found from the rays where they allow one (a
    /// camera's rays in tiles, rays to a light by direction: `accel::order`), else in the given
    /// order.
    ///
    /// # Panics
    /// When `out` and `rays` differ in length.
    fn closest_hits<P: Primitives, C: Counters>(
        &self,
        prims: &P,
        rays: &[Ray],
        packets: Packets,
        out: &mut [Option<Hit>],
        counters: &mut C,
    ) {
        first_hits(
            self,
            prims,
            rays,
            packets,
            false,
            out,
            counters,
            Closest::new,
            Closest::hit,
        );
    }

    /// Some hit of each ray, if it has any: `out[i]` is `Some` exactly when
    /// [`Accel::any_hit`] of `rays[i]` is, with packets as [`Accel::closest_hits`]. Unless
    /// `packets` is [`Packets::Off`] (every ray on its own), each group of rays is first tested
    /// against the primitive that last blocked a ray of the groups before it (the shadow cache
    /// of Haines and Greenberg, `accel::shadow_cache`), so the hit reported may differ from
    /// [`Accel::any_hit`]'s. A group is walked from its rays' far ends as [`Accel::any_hit`]
    /// walks its first ray, while at least one in 16 of the rays answered before it is blocked
    /// (where almost none is, walks from the start measured 5-10% faster); every group from
    /// its rays' start under [`Occlusion::Start`].
    ///
    /// # Panics
    /// When `out` and `rays` differ in length.
    fn any_hits<P: Primitives, C: Counters>(
        &self,
        prims: &P,
        rays: &[Ray],
        packets: Packets,
        out: &mut [Option<Hit>],
        counters: &mut C,
    ) {
        first_hits(
            self,
            prims,
            rays,
            packets,
            packets != Packets::Off,
            out,
            counters,
            AnyHit::new,
            AnyHit::hit,
        );
    }

    /// Every hit in the ray's `[tmin, tmax]`, each primitive once (its nearest hit there),
    /// handed to `f` in the order the walk finds them, which is front to back by cell or node
    /// but not exactly by `t`; `f` returns [`ControlFlow::Break`](std::ops::ControlFlow) to
    /// stop the walk. Nothing for a ray that is not traceable.
    ///
    /// The triangle test is watertight (Woop et al. 2013), so a ray through an edge or vertex
    /// shared by several triangles hits at least one of them (usually each, at the same `t`),
    /// and each is reported once: no gap and no repeat, which re-shooting from just past the
    /// last hit cannot promise.
    #[inline]
    fn for_each_hit<P: Primitives, C: Counters, F: FnMut(Hit) -> std::ops::ControlFlow<()>>(
        &self,
        prims: &P,
        ray: &Ray,
        counters: &mut C,
        mut f: F,
    ) {
        match self.reach().route(ray) {
            Route::Skip => {}
            Route::AsGiven => {
                let ray = &ray.without_subnormal_direction();
                self.query(prims, ray, &mut EveryHit::new(ray.tmax, f), counters);
            }
            Route::Moved => {
                if let Some(m) = self.reach().moved(ray) {
                    let sink = &mut EveryHit::new(m.ray.tmax, |h| f(m.hit(h)));
                    self.query(prims, &m.ray, sink, counters);
                }
            }
        }
    }

    /// Every hit in the ray's `[tmin, tmax]`, each primitive once, in order of `t` (ties by
    /// index): [`Accel::for_each_hit`] collected and sorted.
    fn all_hits<P: Primitives, C: Counters>(
        &self,
        prims: &P,
        ray: &Ray,
        counters: &mut C,
    ) -> Vec<Hit> {
        let mut hits = Vec::new();
        self.for_each_hit(prims, ray, counters, |h| {
            hits.push(h);
            std::ops::ControlFlow::Continue(())
        });
        hits.sort_by(Hit::order);
        hits
    }

    /// Bytes held by the structure: its nodes or cells and its own copy of the primitives
    /// ([`PrimStore`]), not the scene's.
    fn memory_bytes(&self) -> usize;

    fn stats(&self) -> StructureStats;
}

/// A closest hit with the ray that found it ([`Accel::closest_hit_walked`]).
#[derive(Clone, Copy, Debug)]
pub struct Walked {
    /// The ray the structure walked: the caller's, or a far ray moved to the primitives.
    pub ray: Ray,
    /// The hit on that ray.
    pub hit: Hit,
    /// The hit's `t` on the caller's ray.
    pub t: f32,
}

/// Each of `rays` walked alone ([`Accel::query`]) into its sink of `sinks`: the default of
/// [`Accel::query_packet`] and [`Accel::query_each`].
#[inline]
fn each_alone<A: Accel, P: Primitives, C: Counters, S: HitSink>(
    accel: &A,
    prims: &P,
    rays: &[Ray],
    sinks: &mut [S],
    counters: &mut C,
) {
    for (ray, sink) in rays.iter().zip(sinks) {
        accel.query(prims, ray, sink, counters);
    }
}

/// [`Accel::closest_hit`] (`Closest::new`, `Closest::hit`) or [`Accel::any_hit`] (the same
/// of `AnyHit`) for a ray from far away or with a small direction, moved to the scene or
/// scaled first ([`Reach::moved`]).
#[cold]
#[inline(never)]
fn far_first_hit<A: Accel, P: Primitives, C: Counters, S: HitSink>(
    accel: &A,
    prims: &P,
    ray: &Ray,
    counters: &mut C,
    sink: impl Fn(f32) -> S + Copy,
    hit: impl Fn(&S) -> Option<Hit> + Copy,
) -> Option<Hit> {
    let m = accel.reach().moved(ray)?;
    let mut sink = sink(m.ray.tmax);
    accel.query(prims, &m.ray, &mut sink, counters);
    hit(&sink).map(|h| m.hit(h))
}

/// [`Accel::closest_hits`] (`Closest::new`, `Closest::hit`) or [`Accel::any_hits`] (the same
/// of `AnyHit`): the rays in groups of [`Accel::PACKET_RAYS`], in the order [`order`] finds
/// where packets may be walked and [`Accel::ORDER_PAYS`]; each group that `packets` walks
/// together goes to [`Accel::query_packet`], all but the rays that are not traceable or not
/// near, which are answered one at a time as [`Accel::closest_hit`] and [`Accel::any_hit`]
/// answer them. `sink` and `hit` are generic rather than function pointers: through a pointer
/// `hit` was a call per ray whose answer, written in pieces, the caller read back whole (a
/// stalled load), a quarter of the time of a camera ray that misses the scene.
#[allow(clippy::too_many_arguments)]
#[inline]
fn first_hits<A: Accel, P: Primitives, C: Counters, S: HitSink>(
    accel: &A,
    prims: &P,
    rays: &[Ray],
    packets: Packets,
    cache: bool,
    out: &mut [Option<Hit>],
    counters: &mut C,
    sink: impl Fn(f32) -> S + Copy,
    hit: impl Fn(&S) -> Option<Hit> + Copy,
) {
    assert_eq!(out.len(), rays.len(), "one answer per ray");
    const { assert!(A::PACKET_RAYS <= MAX_PACKET && A::PACKET_RAYS > 0) };
    let regroup = A::ORDER_PAYS && packets.may_walk(A::PACKETS_PAY);
    let avx2 = simd::available();
    let mut shadows = ShadowCache::default();
    // Occlusion rays answered so far and those blocked: where few are blocked, the walks go
    // from the rays' start ([`OFTEN`]).
    let (mut answered, mut blocked) = (0usize, 0usize);
    let mut walk = |rays: &[Ray], at: &[u32], out: &mut [Option<Hit>], counters: &mut C| {
        let often = answered < OFTEN_SEEN || blocked * OFTEN >= answered;
        first_hits_of_group(
            accel,
            prims,
            rays,
            at,
            packets,
            avx2,
            cache.then_some(&mut shadows),
            out,
            counters,
            often,
            sink,
            hit,
        );
        if S::FIRST_ENDS {
            answered += at.len();
            blocked += at.iter().filter(|&&i| out[i as usize].is_some()).count();
        }
    };
    match regroup
        .then(|| order::packet_order(rays, A::PACKET_RAYS))
        .flatten()
    {
        None => {
            let in_order: [u32; MAX_PACKET] = std::array::from_fn(|k| k as u32);
            for (group, answers) in rays
                .chunks(A::PACKET_RAYS)
                .zip(out.chunks_mut(A::PACKET_RAYS))
            {
                walk(group, &in_order[..group.len()], answers, counters);
            }
        }
        Some(order) => {
            for at in order.chunks(A::PACKET_RAYS) {
                walk(rays, at, out, counters);
            }
        }
    }
}

/// A batch of occlusion rays is walked from the far ends of the rays' segments where they end
/// outside the scene ([`query::ends_outside`], [`HitSink::walked_back`]) while at least one
/// ray in `OFTEN` of those answered is blocked, once [`OFTEN_SEEN`] are:
/// where almost every ray reaches its light (the generated city's shadow rays, 1.5% blocked;
/// the stadium's, 0.25%), the walks from the far end cost 5-10% more than from the start
/// (the same cells, tests and instructions within 1%, in another order), and they pay only
/// for the rays they find blocked sooner (the meshes' 15-90%). Measured in
/// docs/measurements.md, "Occlusion walked from the far end".
const OFTEN: usize = 16;

/// Occlusion rays of a batch answered before [`OFTEN`] decides.
const OFTEN_SEEN: usize = 256;

/// [`first_hits`] of one group of at most [`Accel::PACKET_RAYS`] rays, `rays[i]` for each `i`
/// of `at`, whose answers go to `out[i]`: the rays are read and answered in place rather than
/// copied into a group and back. Whether the group is walked together is judged on the rays
/// the packet would walk (traceable and walked as given). Inlined into both of its callers
/// there (as a closure called twice, it was not, and the bvh's camera rays were 1.2× slower).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn first_hits_of_group<A: Accel, P: Primitives, C: Counters, S: HitSink>(
    accel: &A,
    prims: &P,
    rays: &[Ray],
    at: &[u32],
    packets: Packets,
    avx2: bool,
    mut shadows: Option<&mut ShadowCache>,
    out: &mut [Option<Hit>],
    counters: &mut C,
    blocked_often: bool,
    sink: impl Fn(f32) -> S + Copy,
    hit: impl Fn(&S) -> Option<Hit> + Copy,
) {
    let with_order = |t: f32, far: bool| sink(t).walked_back(far);
    // A traceable ray walked as given (subnormal direction components flushed) alone.
    let near_alone = |ray: &Ray, far: bool, counters: &mut C| {
        let mut s = with_order(ray.tmax, far);
        accel.query(prims, ray, &mut s, counters);
        hit(&s)
    };
    let mut walked = [Ray::new(Vec3::ZERO, Vec3::X, 0.0, 0.0); MAX_PACKET];
    let mut lane_of = [0u32; MAX_PACKET];
    let mut n = 0;
    for eight in at.chunks(8) {
        let routes = accel.reach().route8(rays, eight, avx2);
        for (k, &i) in eight.iter().enumerate() {
            let ray = &rays[i as usize];
            if routes.as_given >> k & 1 != 0 {
                // Copied whole, and flushed in place where it must be (rarely): the choice
                // between the two made the copy field by field.
                walked[n] = *ray;
                if routes.subnormal >> k & 1 != 0 {
                    walked[n] = walked[n].without_subnormal_direction();
                }
                lane_of[n] = i;
                n += 1;
            } else {
                out[i as usize] = if routes.moved >> k & 1 != 0 {
                    far_first_hit(accel, prims, ray, counters, sink, hit)
                } else {
                    None
                };
            }
        }
    }
    // Occlusion rays walked from the far end where blockers are not rare in the batch and
    // the first ray's segment ends outside the scene (a light outside it: `ends_outside`).
    let far = S::FIRST_ENDS
        && blocked_often
        && accel.occlusion() == Occlusion::Auto
        && n > 0
        && query::ends_outside(&walked[0], accel.reach().bounds());
    // The cached blocker, if it blocks the group's first ray, is tried on the others: the
    // rays it blocks are answered, the others walked.
    if let Some(cache) = shadows.as_deref_mut().filter(|c| !c.is_empty() && n > 0) {
        if let Some(h) = cache.test(prims, &walked[0], counters) {
            out[lane_of[0] as usize] = Some(h);
            cache.paid();
            let mut blocked = 1u32;
            cache.test_many(prims, &walked[1..n], avx2, counters, |j, h| {
                out[lane_of[j + 1] as usize] = Some(h);
                blocked |= 1 << (j + 1);
            });
            let mut kept = 0;
            for j in 0..n {
                if blocked >> j & 1 == 0 {
                    walked[kept] = walked[j];
                    lane_of[kept] = lane_of[j];
                    kept += 1;
                }
            }
            n = kept;
        } else {
            cache.failed();
        }
    }
    // The walk's last blocker is cached (one a group: its geometry is read from the scene).
    let mut blocker = None;
    let mut answer = |i: u32, h: Option<Hit>| {
        blocker = h.map(|h| h.prim).or(blocker);
        out[i as usize] = h;
    };
    if !packets.walk_together(&walked[..n], A::PACKETS_PAY) {
        if A::INTERLEAVES {
            let mut sinks: [S; MAX_PACKET] =
                std::array::from_fn(|l| with_order(walked[l].tmax, far));
            accel.query_each(prims, &walked[..n], &mut sinks[..n], counters);
            for (s, &i) in sinks[..n].iter().zip(&lane_of) {
                answer(i, hit(s));
            }
        } else {
            for (ray, &i) in walked[..n].iter().zip(&lane_of) {
                answer(i, near_alone(ray, far, counters));
            }
        }
    } else {
        let mut sinks: [S; MAX_PACKET] = std::array::from_fn(|l| with_order(walked[l].tmax, far));
        accel.query_packet(prims, &walked[..n], &mut sinks[..n], counters);
        for (s, &i) in sinks[..n].iter().zip(&lane_of) {
            answer(i, hit(s));
        }
    }
    if let (Some(cache), Some(p)) = (shadows, blocker)
        && !cache.holds(p)
        && cache.may_record()
    {
        cache.record(p, prims.kind(p as usize));
    }
}

/// Declares the list of structures: generates [`AnyAccel`] and [`STRUCTURES`].
macro_rules! structures {
    ($($variant:ident => $ty:ty),* $(,)?) => {
        /// Any of hugrt's structures, chosen by a spec at run time.
        pub enum AnyAccel {
            $($variant($ty),)*
        }

        /// Names of every structure, in the order of the list.
        pub const STRUCTURES: &[&str] = &[$(<$ty as Accel>::NAME),*];

        impl AnyAccel {
            /// Builds the structure a spec string names, e.g. `grid:density=8`.
            pub fn build<P: Primitives>(prims: &P, spec: &str) -> Result<Self, SpecError> {
                let spec = Spec::parse(spec)?;
                $(if spec.name == <$ty as Accel>::NAME {
                    return Ok(AnyAccel::$variant(<$ty as Accel>::build(prims, &spec)?));
                })*
                Err(SpecError::UnknownStructure {
                    name: spec.name.clone(),
                    valid: STRUCTURES.join(", "),
                })
            }

            pub fn name(&self) -> &'static str {
                match self { $(AnyAccel::$variant(_) => <$ty as Accel>::NAME,)* }
            }

            /// Every key of a spec's structure with the value the spec gives it (its preset's or
            /// the default where the spec is silent): what is built, in full.
            pub fn resolve(spec: &str) -> Result<Vec<(&'static str, String)>, SpecError> {
                let spec = Spec::parse(spec)?;
                $(if spec.name == <$ty as Accel>::NAME {
                    let s = <<$ty as Accel>::Settings as Settings>::from_spec(&spec)?;
                    return Ok(<<$ty as Accel>::Settings as Settings>::KEYS
                        .iter()
                        .map(|k| (k.name, (k.show)(&s)))
                        .collect());
                })*
                Err(SpecError::UnknownStructure {
                    name: spec.name.clone(),
                    valid: STRUCTURES.join(", "),
                })
            }

            /// Checks a spec before any work: builds it over no primitives, which parses and
            /// checks every key and value at no cost.
            pub fn check(spec: &str) -> Result<(), SpecError> {
                Self::build(&crate::scene::Scene::from_triangles(Vec::new()), spec).map(drop)
            }

            /// The keys of every structure's spec, or of the one named: `(name, keys)` in
            /// [`STRUCTURES`]' order; an error naming the valid structures for an unknown
            /// name.
            pub fn describe(
                name: Option<&str>,
            ) -> Result<Vec<(&'static str, Vec<KeyHelp>)>, SpecError> {
                let names: Vec<&'static str> = match name {
                    Some(n) => vec![*STRUCTURES.iter().find(|s| **s == n).ok_or_else(|| {
                        SpecError::UnknownStructure {
                            name: n.to_string(),
                            valid: STRUCTURES.join(", "),
                        }
                    })?],
                    None => STRUCTURES.to_vec(),
                };
                Ok(names
                    .into_iter()
                    .map(|n| (n, Self::keys(n).expect("every listed structure has keys")))
                    .collect())
            }

            /// The keys of the named structure's spec: what each accepts, its default, its
            /// help ([`Settings::describe`]).
            pub fn keys(name: &str) -> Option<Vec<KeyHelp>> {
                $(if name == <$ty as Accel>::NAME {
                    return Some(<<$ty as Accel>::Settings as Settings>::describe());
                })*
                None
            }

            #[inline]
            pub fn closest_hit<P: Primitives, C: Counters>(
                &self, prims: &P, ray: &Ray, counters: &mut C,
            ) -> Option<Hit> {
                match self { $(AnyAccel::$variant(a) => a.closest_hit(prims, ray, counters),)* }
            }

            /// The closest hit with the ray that found it ([`Accel::closest_hit_walked`]).
            pub fn closest_hit_walked<P: Primitives, C: Counters>(
                &self, prims: &P, ray: &Ray, counters: &mut C,
            ) -> Option<Walked> {
                match self { $(AnyAccel::$variant(a) => a.closest_hit_walked(prims, ray, counters),)* }
            }

            /// Whether anything is hit in the ray's `[tmin, tmax]`.
            #[inline]
            pub fn any_hit<P: Primitives, C: Counters>(
                &self, prims: &P, ray: &Ray, counters: &mut C,
            ) -> Option<Hit> {
                match self { $(AnyAccel::$variant(a) => a.any_hit(prims, ray, counters),)* }
            }

            /// The closest hit of each ray, packets as `packets` says ([`Accel::closest_hits`]).
            pub fn closest_hits<P: Primitives, C: Counters>(
                &self, prims: &P, rays: &[Ray], packets: Packets, out: &mut [Option<Hit>], counters: &mut C,
            ) {
                match self { $(AnyAccel::$variant(a) => a.closest_hits(prims, rays, packets, out, counters),)* }
            }

            /// Some hit of each ray, packets as `packets` says ([`Accel::any_hits`]).
            pub fn any_hits<P: Primitives, C: Counters>(
                &self, prims: &P, rays: &[Ray], packets: Packets, out: &mut [Option<Hit>], counters: &mut C,
            ) {
                match self { $(AnyAccel::$variant(a) => a.any_hits(prims, rays, packets, out, counters),)* }
            }

            /// Every hit in the ray's `[tmin, tmax]` as the walk finds it ([`Accel::for_each_hit`]).
            #[inline]
            pub fn for_each_hit<P: Primitives, C: Counters, F: FnMut(Hit) -> std::ops::ControlFlow<()>>(
                &self, prims: &P, ray: &Ray, counters: &mut C, f: F,
            ) {
                match self { $(AnyAccel::$variant(a) => a.for_each_hit(prims, ray, counters, f),)* }
            }

            /// Every hit in the ray's `[tmin, tmax]` in order of `t` ([`Accel::all_hits`]).
            pub fn all_hits<P: Primitives, C: Counters>(
                &self, prims: &P, ray: &Ray, counters: &mut C,
            ) -> Vec<Hit> {
                match self { $(AnyAccel::$variant(a) => a.all_hits(prims, ray, counters),)* }
            }

            pub fn memory_bytes(&self) -> usize {
                match self { $(AnyAccel::$variant(a) => a.memory_bytes(),)* }
            }

            pub fn stats(&self) -> StructureStats {
                match self { $(AnyAccel::$variant(a) => a.stats(),)* }
            }
        }
    };
}

structures! {
    Brute => Brute,
    Grid => Grid,
    Hug => Hug,
    RecursiveGrid => RecursiveGrid,
    Octree => Octree,
    AdaptiveGrid => AdaptiveGrid,
    Bvh => Bvh,
    KdTree => KdTree,
}
