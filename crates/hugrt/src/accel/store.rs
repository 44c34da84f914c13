//! The primitive store: a structure's own compact copy of the primitives, laid out for ray
//! shooting.
//!
//! A structure built over [`Primitives`] only knows "bounds of i" and "intersect i"; going
//! through a scene's general `Shape` enum costs a ~44-byte load and a dispatch per test, and
//! the primitives of one cell lie wherever the file put them. The store instead keeps
//!
//! * triangles (and patches, which intersect as triangles) as three plain vertices, 36 bytes,
//!   then spheres, then cones, each kind contiguous so that the dispatch is a range check that
//!   a triangle-only scene always predicts;
//! * every kind sorted by the Morton code of its box centre, so that the primitives one cell
//!   or leaf references lie close together in memory;
//! * `ids`, the permutation back to the primitive's own index, which is what hits report.
//!
//! Primitives of no kind the store knows ([`PrimitiveKind::Opaque`]) are kept by index after
//! the others and intersected through [`Primitives::intersect`].
//!
//! With `store=index` ([`TriangleStorage::Index`]), the triangles of an indexed mesh are kept
//! as their three vertex indices (12 bytes) into the mesh's own vertices, shared with the
//! scene ([`Primitives::shared_vertices`]), instead of a 36-byte copy: a test then reads the
//! indices, then the vertices they name, where the copy reads one line.
//!
//! The store calls the same intersection functions as the scene's shapes
//! ([`intersect_triangle`], [`Sphere::intersect`], [`Cone::intersect`]) on the same numbers, so
//! a hit found through the store is bit for bit the hit brute force finds.

use super::Frame;
use super::sort::radix_sort_high32;
use super::{Counters, HitSink, PrimitiveKind, Primitives, Reach, simd};
use crate::geometry::{Aabb, Cone, PreparedRay, Sphere, Vec3, crossing_t, intersect_triangle};
use glam::{BVec4A, Vec3A, Vec4};
use rayon::prelude::*;

/// How a store holds the triangles (the grid structures' `store` key).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TriangleStorage {
    /// Each triangle's three vertices, 36 bytes, in store order: a test reads one line.
    Copy,
    /// An indexed mesh's triangles as three indices into its vertices, which the scene and
    /// the structure share: 12 bytes a triangle, two dependent reads a test. Primitives that
    /// are not triangles of an indexed mesh ([`Primitives::mesh_triangle`]) make the store
    /// fall back to copies.
    Index,
    /// [`TriangleStorage::Index`] from 2^24 primitives, [`TriangleStorage::Copy`]
    /// below.
    Auto,
}

/// Where `store=auto` stops copying triangles: 2^24 primitives. Measured on the bunny and on
/// terrains of 1M and 16M triangles (`docs/measurements.md`), the indexed store costs up to a
/// third of the incoherent throughput (two dependent reads a test, vertices farther apart
/// than a cell's triangles; the grid's crowded cells pay the most, the HUG's least) and saves
/// 24 bytes a triangle; below 2^24 triangles that is at most 400 MB, above it memory is what
/// limits the scene a machine can hold.
pub const INDEX_FROM: usize = 1 << 24;

crate::accel::settings::choice_value!(TriangleStorage {
    TriangleStorage::Copy => "copy",
    TriangleStorage::Index => "index",
    TriangleStorage::Auto => "auto"
});

/// The help of the `store` key.
pub(crate) const STORAGE_HELP: &str = "index: test an indexed mesh's triangles through their vertex indices and the scene's shared vertices (12 bytes a triangle, no copy); copy: a 36-byte copy of each triangle in store order (faster); auto: index from 2^24 primitives";

pub struct PrimStore {
    /// The triangles' vertices ([`TriangleStorage::Copy`]); empty when indexed.
    tris: Vec<[Vec3; 3]>,
    /// The triangles' vertex indices into `vertices` ([`TriangleStorage::Index`]).
    tri_indices: Vec<[u32; 3]>,
    /// The mesh's vertices, shared with the scene, when the triangles are indexed: every
    /// index of `tri_indices` is below its length (checked by [`PrimStore::build_with`]).
    vertices: Option<std::sync::Arc<Vec<Vec3>>>,
    spheres: Vec<Sphere>,
    cones: Vec<Cone>,
    /// First store index of spheres, cones and opaque primitives.
    sphere_start: u32,
    cone_start: u32,
    opaque_start: u32,
    /// Store index → primitive index.
    ids: Vec<u32>,
    /// Where the primitives lie, for far rays ([`Reach`]).
    reach: Reach,
}

/// Whether a box can be binned: not empty and finite. Three comparisons of three lanes each:
/// `min ≤ max` (false for NaN), `min > −∞` and `max < ∞`, which with the first make every
/// coordinate finite. Coordinate by coordinate (`is_empty`, then `is_finite` on each of the
/// six), it was about 60 instructions a box, asked of every box by the store and again by
/// every grid that bins it.
#[inline]
pub(crate) fn finite(b: &Aabb) -> bool {
    let (lo, hi) = (Vec3A::from(b.min), Vec3A::from(b.max));
    (lo.cmple(hi) & lo.cmpgt(Vec3A::NEG_INFINITY) & hi.cmplt(Vec3A::INFINITY)).all()
}

/// The boxes of a store's entries as a grid build reads them: for the grids' boxes, for
/// binning, and for the box of each cell's contents, once per reference. A copy store's are
/// computed once into a table (24 bytes an entry while the build lasts); an indexed
/// store's, a mesh of 2^24 triangles or more by default where the build's memory is the
/// constraint, are recomputed from the triangles at each reading, as before.
pub(crate) struct EntryBoxes<'a, P> {
    store: &'a PrimStore,
    prims: &'a P,
    /// The box of every entry in store order, or nothing.
    table: Vec<Aabb>,
}

impl<'a, P: Primitives> EntryBoxes<'a, P> {
    /// The boxes of `store`'s entries; `known`, when given, holds them already (in store
    /// order).
    pub(crate) fn new(prims: &'a P, store: &'a PrimStore, known: Option<Vec<Aabb>>) -> Self {
        let table = if store.vertices.is_some() {
            Vec::new()
        } else {
            match known {
                Some(t) => {
                    debug_assert_eq!(t.len(), store.len());
                    t
                }
                None => (0..store.len() as u32)
                    .into_par_iter()
                    .map(|s| store.bounds(prims, s))
                    .collect(),
            }
        };
        EntryBoxes {
            store,
            prims,
            table,
        }
    }

    /// The box of store entry `s`: [`PrimStore::bounds`].
    #[inline(always)]
    pub(crate) fn get(&self, s: u32) -> Aabb {
        match self.table.get(s as usize) {
            Some(b) => *b,
            None => self.store.bounds(self.prims, s),
        }
    }
}

/// Primitive `i`'s vertex indices when it is a triangle of the indexed mesh whose shared
/// vertices number `vertices`, every index in range: what an indexed store holds.
fn indexed_triangle<P: Primitives>(prims: &P, i: usize, vertices: usize) -> Option<[u32; 3]> {
    prims
        .mesh_triangle(i)
        .filter(|t| t.iter().all(|&k| (k as usize) < vertices))
}

/// The shared vertices of `prims` when every primitive is a triangle of that indexed mesh
/// ([`indexed_triangle`]): what an indexed store of all of them needs.
pub(crate) fn indexed_mesh<P: Primitives>(prims: &P) -> Option<std::sync::Arc<Vec<Vec3>>> {
    let v = prims.shared_vertices()?;
    (0..prims.len())
        .into_par_iter()
        .all(|i| indexed_triangle(prims, i, v.len()).is_some())
        .then_some(v)
}

/// Spreads the low 10 bits of `x` to every third bit.
const fn spread3(x: u32) -> u32 {
    let mut x = x & 0x3ff;
    x = (x | x << 16) & 0x0300_00ff;
    x = (x | x << 8) & 0x0300_f00f;
    x = (x | x << 4) & 0x030c_30c3;
    x = (x | x << 2) & 0x0924_9249;
    x
}

/// [`spread3`] of every 10-bit value: three loads from 4 KB a code rather than three
/// dozen shifts and masks.
static SPREAD3: [u32; 1024] = {
    let mut t = [0u32; 1024];
    let mut x = 0;
    while x < 1024 {
        t[x] = spread3(x as u32);
        x += 1;
    }
    t
};

/// Morton codes of up to 10 bits an axis (30 in all) of points inside a box, clamped to it.
/// The three axes are scaled in one vector (each lane `((p − min) / extent).clamp(0, 1) ·
/// (2^bits − 1)`, the same operations on the same numbers as one axis at a time, so the same
/// codes); an axis of no extent, or an empty box, gives 0 along it. One axis at a time, with the box's
/// extent found again for every code, the codes took 213 instructions a primitive: the four
/// kitchens' store took 44.8 M instructions, 31.4 M with the frame (their grid's whole build
/// 125.5 M → 112.1 M).
struct MortonFrame {
    min: Vec4,
    /// The box's extent, 1 along the axes that get 0.
    extent: Vec4,
    /// The axes of positive extent.
    live: BVec4A,
    /// The largest coordinate along an axis: `2^bits − 1`.
    top: f32,
}

impl MortonFrame {
    /// The frame of codes of `bits` bits an axis (at most 10) in box `b`.
    fn new(b: &Aabb, bits: u32) -> MortonFrame {
        debug_assert!((1..=10).contains(&bits));
        let e = b.extent();
        let live = Vec4::from((e, 0.0)).cmpgt(Vec4::ZERO);
        MortonFrame {
            min: Vec4::select(live, Vec4::from((b.min, 0.0)), Vec4::ZERO),
            extent: Vec4::select(live, Vec4::from((e, 1.0)), Vec4::ONE),
            live,
            top: ((1u32 << bits) - 1) as f32,
        }
    }

    fn code(&self, p: Vec3) -> u32 {
        let q = ((Vec4::from((p, 0.0)) - self.min) / self.extent)
            .max(Vec4::ZERO)
            .min(Vec4::ONE)
            * self.top;
        let c = simd::truncate_lanes(Vec4::select(self.live, q, Vec4::ZERO));
        SPREAD3[c[0] as usize & 0x3ff]
            | SPREAD3[c[1] as usize & 0x3ff] << 1
            | SPREAD3[c[2] as usize & 0x3ff] << 2
    }
}

/// Bits an axis of the store's Morton codes for `n` primitives: `2^bits ≥ 2·∛n`, from 1 to 10.
fn morton_bits(n: usize) -> u32 {
    let cells = 2.0 * (n.max(1) as f64).cbrt();
    (cells.log2().ceil() as u32).clamp(1, 10)
}

impl PrimStore {
    /// Copies the primitives into store order ([`PrimStore::build_with`] with
    /// [`TriangleStorage::Copy`]).
    pub fn build<P: Primitives>(prims: &P) -> PrimStore {
        PrimStore::build_with(prims, TriangleStorage::Copy)
    }

    /// Puts the primitives in store order: by kind, then by the Morton code of the box
    /// centre. The codes are taken inside the box of a sample of the primitives (clamped at
    /// its sides): an order, not a bound, so it needs no exact box. Triangles are held as
    /// `storage` says, where the primitives allow it.
    pub fn build_with<P: Primitives>(prims: &P, storage: TriangleStorage) -> PrimStore {
        PrimStore::build_inner(prims, storage, false).0
    }

    /// [`PrimStore::build_with`], and every entry's box ([`PrimStore::bounds`]) in store
    /// order. Copied triangles are bounded as they are copied, where a pass of its own over
    /// the copies took 3.7 ms at two threads on the big SPD terrain (its HUG built in 34.0 ms
    /// rather than 35.9, the bunny's in 4.23 rather than 4.56).
    pub fn build_with_boxes<P: Primitives>(
        prims: &P,
        storage: TriangleStorage,
    ) -> (PrimStore, Vec<Aabb>) {
        let (store, boxes) = PrimStore::build_inner(prims, storage, true);
        let boxes = boxes.unwrap_or_else(|| {
            (0..store.len() as u32)
                .into_par_iter()
                .map(|s| store.bounds(prims, s))
                .collect()
        });
        (store, boxes)
    }

    /// The store, and with `copied_boxes` the entries' boxes where its triangles are copies.
    fn build_inner<P: Primitives>(
        prims: &P,
        storage: TriangleStorage,
        copied_boxes: bool,
    ) -> (PrimStore, Option<Vec<Aabb>>) {
        let n = prims.len();
        assert!(n < u32::MAX as usize, "at most 2^32-2 primitives");
        let step = (n / 4096).max(1);
        let sample = (0..n.div_ceil(step))
            .into_par_iter()
            .map(|k| prims.bounds(k * step))
            .filter(finite)
            .reduce(|| Aabb::EMPTY, |a, b| a.union(&b));
        let rank = |k: PrimitiveKind| -> u64 {
            match k {
                PrimitiveKind::Triangle(_) => 0,
                PrimitiveKind::Sphere(_) => 1,
                PrimitiveKind::Cone(_) => 2,
                PrimitiveKind::Opaque => 3,
            }
        };
        // Key: kind (2 bits), Morton code (`3·bits` bits), primitive index (32 bits). The codes
        // take `2·∛n` cells an axis or more, finer than any grid cut over the primitives at
        // up to 8 cells a primitive, and no finer: up to 2M primitives, 24 bits sort in two
        // passes of the radix sort where 30 took three (the big SPD terrain's grid built in
        // 27.0 ms rather than 29.6, its bvh in 72.4 rather than 79.8, their rays as fast).
        // The same pass gathers the union of the finite boxes, the store's [`Reach`], rather
        // than a second pass over every primitive (with the scene's boxes read without
        // copying its shapes, the bunny's store took 1.7 ms rather than 3.6).
        const CHUNK: usize = 4096;
        let bits = morton_bits(n);
        let frame = MortonFrame::new(&sample, bits);
        let mut keys = vec![0u64; n];
        let reach = keys
            .par_chunks_mut(CHUNK)
            .enumerate()
            .map(|(c, out)| {
                let mut union = Aabb::EMPTY;
                for (j, key) in out.iter_mut().enumerate() {
                    let i = c * CHUNK + j;
                    let b = prims.bounds(i);
                    let code = if finite(&b) {
                        union = union.union(&b);
                        frame.code(b.center())
                    } else {
                        (1 << (3 * bits)) - 1
                    };
                    *key = (rank(prims.kind(i)) << (3 * bits) | code as u64) << 32 | i as u64;
                }
                union
            })
            .reduce(|| Aabb::EMPTY, |a, b| a.union(&b));
        let reach = Reach::from_bounds(reach);
        radix_sort_high32(&mut keys);
        let id = |k: u64| (k & 0xffff_ffff) as usize;
        let start = |r: u64| keys.partition_point(|&k| k >> (32 + 3 * bits) < r);
        let (sphere_start, cone_start, opaque_start) = (start(1), start(2), start(3));
        let index = match storage {
            TriangleStorage::Index => true,
            TriangleStorage::Copy => false,
            TriangleStorage::Auto => n >= INDEX_FROM,
        };
        let shared = if index { prims.shared_vertices() } else { None };
        // Indexed only when every triangle is an indexed mesh's, its indices in range.
        let tri_indices = shared.as_ref().and_then(|v| {
            keys[..sphere_start]
                .par_iter()
                .map(|&k| indexed_triangle(prims, id(k), v.len()))
                .collect::<Option<Vec<[u32; 3]>>>()
        });
        let triangle = |k: &u64| match prims.kind(id(*k)) {
            PrimitiveKind::Triangle(v) => v,
            _ => unreachable!("sorted by kind"),
        };
        let (tris, tri_indices, vertices, tri_boxes) = match tri_indices {
            Some(indices) => (Vec::new(), indices, shared, None),
            None if copied_boxes => {
                let (tris, boxes): (Vec<[Vec3; 3]>, Vec<Aabb>) = keys[..sphere_start]
                    .par_iter()
                    .map(|k| {
                        let v = triangle(k);
                        (v, Aabb::from_points(&v))
                    })
                    .unzip();
                (tris, Vec::new(), None, Some(boxes))
            }
            None => {
                let tris = keys[..sphere_start].par_iter().map(triangle).collect();
                (tris, Vec::new(), None, None)
            }
        };
        let spheres = keys[sphere_start..cone_start]
            .par_iter()
            .map(|&k| match prims.kind(id(k)) {
                PrimitiveKind::Sphere(s) => s,
                _ => unreachable!("sorted by kind"),
            })
            .collect();
        let cones = keys[cone_start..opaque_start]
            .par_iter()
            .map(|&k| match prims.kind(id(k)) {
                PrimitiveKind::Cone(c) => c,
                _ => unreachable!("sorted by kind"),
            })
            .collect();
        let store = PrimStore {
            reach,
            tris,
            tri_indices,
            vertices,
            spheres,
            cones,
            sphere_start: sphere_start as u32,
            cone_start: cone_start as u32,
            opaque_start: opaque_start as u32,
            ids: keys.par_iter().map(|&k| id(k) as u32).collect(),
        };
        // The other entries' boxes after the triangles'.
        let boxes = tri_boxes.map(|mut boxes| {
            boxes.par_extend(
                (sphere_start as u32..n as u32)
                    .into_par_iter()
                    .map(|s| store.bounds(prims, s)),
            );
            boxes
        });
        (store, boxes)
    }

    /// An indexed store of the primitives `order` names, in that order, each an entry: for a
    /// structure whose leaves are ranges of entries (the bvh's `store=index`). `vertices` are
    /// [`indexed_mesh`]'s, which vouched for every primitive.
    pub(crate) fn indexed_in_order<P: Primitives>(
        prims: &P,
        vertices: std::sync::Arc<Vec<Vec3>>,
        order: Vec<u32>,
    ) -> PrimStore {
        let n = order.len() as u32;
        let tri_indices = order
            .par_iter()
            .map(|&i| {
                prims
                    .mesh_triangle(i as usize)
                    .expect("indexed_mesh vouched for every primitive")
            })
            .collect();
        PrimStore {
            reach: Reach::of(prims),
            tris: Vec::new(),
            tri_indices,
            vertices: Some(vertices),
            spheres: Vec::new(),
            cones: Vec::new(),
            sphere_start: n,
            cone_start: n,
            opaque_start: n,
            ids: order,
        }
    }

    /// Where the primitives lie, for far rays.
    pub fn reach(&self) -> &Reach {
        &self.reach
    }

    pub fn len(&self) -> usize {
        self.ids.len()
    }

    pub fn is_empty(&self) -> bool {
        self.ids.is_empty()
    }

    /// The number of triangles: store entries `0..triangle_count()`.
    pub(crate) fn triangle_count(&self) -> usize {
        self.sphere_start as usize
    }

    /// The triangles' copies, when the store holds them as copies (empty when indexed).
    pub(crate) fn copied_triangles(&self) -> &[[Vec3; 3]] {
        &self.tris
    }

    /// How the triangles are held: [`TriangleStorage::Copy`] or [`TriangleStorage::Index`].
    pub fn storage(&self) -> TriangleStorage {
        match self.vertices {
            Some(_) => TriangleStorage::Index,
            None => TriangleStorage::Copy,
        }
    }

    /// The vertices of triangle entry `s` (`s < triangle_count()`).
    #[inline(always)]
    fn tri(&self, s: u32) -> [Vec3; 3] {
        match &self.vertices {
            None => self.tris[s as usize],
            Some(v) => self.tri_indices[s as usize].map(|k| v[k as usize]),
        }
    }

    /// Frees the triangles, for a structure that keeps its own copy: triangle entries can then
    /// no longer be intersected or bounded through the store (their indices panic). An
    /// indexed store lets go of the scene's vertices too, which the structure then no longer
    /// keeps alive.
    pub(crate) fn release_triangles(&mut self) {
        self.tris = Vec::new();
        self.tri_indices = Vec::new();
        self.vertices = None;
    }

    /// The primitive's own index (what hits report) of store entry `s`.
    #[inline(always)]
    pub fn id(&self, s: u32) -> u32 {
        self.ids[s as usize]
    }

    /// Where store entry `s`'s triangle lies (its vertex indices where the store is indexed),
    /// for a prefetch: never read through, so `s` may be past the end.
    #[inline(always)]
    pub fn entry_address(&self, s: u32) -> *const i8 {
        match self.vertices {
            None => self.tris.as_ptr().wrapping_add(s as usize).cast(),
            Some(_) => self.tri_indices.as_ptr().wrapping_add(s as usize).cast(),
        }
    }

    /// Bytes between consecutive entries' triangles at [`PrimStore::entry_address`].
    pub fn entry_bytes(&self) -> usize {
        match self.vertices {
            None => std::mem::size_of::<[Vec3; 3]>(),
            Some(_) => std::mem::size_of::<[u32; 3]>(),
        }
    }

    /// Asks the cache for store entry `s`'s triangle (where indexed, its indices, which the
    /// vertices' loads wait for), so that the loads of a cell's triangles overlap instead of
    /// waiting for each other (a cell's references are known at once).
    #[inline(always)]
    pub fn prefetch(&self, s: u32) {
        crate::accel::simd::prefetch_line(self.entry_address(s));
    }

    /// Hit parameter of store entry `s` in `[tmin, tmax]`, exactly as
    /// `prims.intersect(self.id(s), ..)` computes it.
    #[inline(always)]
    pub fn intersect<P: Primitives>(
        &self,
        prims: &P,
        s: u32,
        ray: &PreparedRay,
        tmin: f32,
        tmax: f32,
    ) -> Option<f32> {
        if s < self.sphere_start {
            intersect_triangle(ray, &self.tri(s), tmin, tmax)
        } else {
            self.intersect_other(prims, s, ray, tmin, tmax)
        }
    }

    #[inline(never)]
    fn intersect_other<P: Primitives>(
        &self,
        prims: &P,
        s: u32,
        ray: &PreparedRay,
        tmin: f32,
        tmax: f32,
    ) -> Option<f32> {
        if s < self.cone_start {
            self.spheres[(s - self.sphere_start) as usize].intersect(ray, tmin, tmax)
        } else if s < self.opaque_start {
            self.cones[(s - self.cone_start) as usize].intersect(ray, tmin, tmax)
        } else {
            prims.intersect(self.id(s) as usize, ray, tmin, tmax)
        }
    }

    /// Tests the triangles `batch[..n]` (`n ≤ 8`, the rest of `batch` repeating one of them)
    /// eight at a time and offers their hits to `sink` in lane order, as testing them one at
    /// a time would (lanes the kernel leaves to the scalar test get it). Counts `n` tests at
    /// `level`. Returns `true` when the sink stops the walk.
    ///
    /// # Safety
    /// The processor must support AVX2 ([`simd::available`]), [`PrimStore::simd_fits`] must
    /// hold, and every entry of `batch` must be a triangle's (below `triangle_count()`).
    #[cfg(target_arch = "x86_64")]
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(crate) unsafe fn offer_triangles8<P: Primitives, C: Counters, S: HitSink>(
        &self,
        prims: &P,
        batch: &[u32; 8],
        n: usize,
        ray: &PreparedRay,
        tmin: f32,
        sink: &mut S,
        counters: &mut C,
        level: usize,
    ) -> bool {
        let source = match &self.vertices {
            None => simd::Source::Copied(&self.tris),
            Some(v) => simd::Source::Indexed {
                indices: &self.tri_indices,
                vertices: v,
            },
        };
        // SAFETY: the caller's contract is the kernel's: AVX2, the offsets within i32
        // (`simd_fits`), every batched entry a triangle's, and (built so) every index of
        // `tri_indices` below the vertices' length.
        let lanes = unsafe { simd::triangles8(source, batch, ray) };
        for _ in 0..n {
            counters.prim_test(level);
        }
        let mut todo = (lanes.crossed | lanes.scalar) & ((1 << n) - 1);
        while todo != 0 {
            let l = todo.trailing_zeros() as usize;
            todo &= todo - 1;
            let t = if lanes.scalar >> l & 1 != 0 {
                self.intersect(prims, batch[l], ray, tmin, sink.tmax())
            } else {
                crossing_t(&self.tri(batch[l]), &ray.ray, tmin, sink.tmax())
            };
            if let Some(t) = t {
                counters.prim_hit(level);
                if sink.offer(t, || self.id(batch[l])) {
                    return true;
                }
            }
        }
        false
    }

    /// Whether the eight-lane kernel's 32-bit gather offsets reach every triangle (an indexed
    /// mesh's: a copy's triangles are read through pointers).
    pub(crate) fn simd_fits(&self) -> bool {
        match &self.vertices {
            None => true,
            Some(v) => {
                self.tri_indices.len() * 3 < i32::MAX as usize && v.len() * 3 < i32::MAX as usize
            }
        }
    }

    /// The box of store entry `s`: what `prims.bounds(self.id(s))` gives, recomputed from the
    /// compact copy (the same arithmetic as the scene's shapes) rather than stored.
    #[inline]
    pub fn bounds<P: Primitives>(&self, prims: &P, s: u32) -> Aabb {
        if s < self.sphere_start {
            Aabb::from_points(&self.tri(s))
        } else if s < self.cone_start {
            self.spheres[(s - self.sphere_start) as usize].bounds()
        } else if s < self.opaque_start {
            self.cones[(s - self.cone_start) as usize].bounds()
        } else {
            prims.bounds(self.id(s) as usize)
        }
    }

    /// The vertices of store entry `s`, if it is a triangle.
    pub fn triangle(&self, s: u32) -> Option<[Vec3; 3]> {
        (s < self.sphere_start).then(|| self.tri(s))
    }

    /// Box of store entry `s` in frame `f` (`world` is its world-space box): tight for
    /// triangles, spheres and cones, the turned world box otherwise.
    pub(crate) fn local_bounds(&self, s: u32, f: &Frame, world: &Aabb) -> Aabb {
        if s < self.sphere_start {
            Aabb::from_points(&self.tri(s).map(|v| f.point(v)))
        } else if s < self.cone_start {
            let sp = &self.spheres[(s - self.sphere_start) as usize];
            Sphere {
                center: f.point(sp.center),
                radius: sp.radius,
            }
            .bounds()
        } else if s < self.opaque_start {
            let c = &self.cones[(s - self.cone_start) as usize];
            Cone {
                base: f.point(c.base),
                apex: f.point(c.apex),
                ..*c
            }
            .bounds()
        } else {
            f.local_box(world)
        }
    }

    /// Bytes held by the store (an indexed store's vertices are the scene's, not counted).
    pub fn memory_bytes(&self) -> usize {
        self.tris.capacity() * std::mem::size_of::<[Vec3; 3]>()
            + self.tri_indices.capacity() * 12
            + self.spheres.capacity() * std::mem::size_of::<Sphere>()
            + self.cones.capacity() * std::mem::size_of::<Cone>()
            + self.ids.capacity() * 4
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An indexed mesh of 30 triangles over 40 vertices.
    fn small_mesh() -> crate::scene::Scene {
        let v: Vec<Vec3> = (0..40)
            .map(|i| Vec3::new((i % 7) as f32, (i % 5) as f32 * 0.5, (i / 3) as f32))
            .collect();
        let t: Vec<[u32; 3]> = (0..30u32).map(|i| [i, i + 3, i + 7]).collect();
        crate::scene::Scene::from_mesh(crate::scene::Mesh::new(v, t).unwrap())
    }

    #[test]
    fn an_indexed_store_holds_indices_and_finds_the_same_triangles() {
        use crate::geometry::{Shape, Sphere};
        let mut scene = small_mesh();
        let copy = PrimStore::build_with(&scene, TriangleStorage::Copy);
        let index = PrimStore::build_with(&scene, TriangleStorage::Index);
        assert_eq!(copy.storage(), TriangleStorage::Copy);
        assert_eq!(index.storage(), TriangleStorage::Index);
        assert_eq!(
            PrimStore::build_with(&scene, TriangleStorage::Auto).storage(),
            TriangleStorage::Copy,
            "auto copies below INDEX_FROM"
        );
        assert!(index.memory_bytes() < copy.memory_bytes() / 2);
        for s in 0..copy.len() as u32 {
            assert_eq!(index.id(s), copy.id(s));
            assert_eq!(index.triangle(s), copy.triangle(s));
            assert_eq!(index.bounds(&scene, s), copy.bounds(&scene, s));
        }
        // A shape that is no mesh triangle: the store copies.
        scene
            .shapes
            .push(Shape::Triangle([Vec3::ZERO, Vec3::X, Vec3::Y]));
        scene.shapes.push(Shape::Sphere(Sphere {
            center: Vec3::ONE,
            radius: 1.0,
        }));
        let mixed = PrimStore::build_with(&scene, TriangleStorage::Index);
        assert_eq!(mixed.storage(), TriangleStorage::Copy);
        assert_eq!(mixed.triangle_count(), 31);
    }

    /// The boxes made beside the store are its entries' boxes, one by one: triangles bounded
    /// as they are copied, then the spheres; or, held through indices, bounded afterwards.
    #[test]
    fn the_boxes_beside_the_store_are_its_entries_boxes() {
        use crate::geometry::{Shape, Sphere};
        let mesh = small_mesh();
        let mut mixed = mesh.clone();
        for k in 0..5 {
            mixed.shapes.push(Shape::Sphere(Sphere {
                center: Vec3::splat(k as f32),
                radius: 0.5 + k as f32,
            }));
            mixed
                .shapes
                .push(Shape::Triangle([Vec3::ZERO, Vec3::X * k as f32, Vec3::Y]));
        }
        for (scene, storage) in [
            (&mesh, TriangleStorage::Copy),
            (&mesh, TriangleStorage::Index),
            (&mixed, TriangleStorage::Copy),
        ] {
            let (store, boxes) = PrimStore::build_with_boxes(scene, storage);
            assert_eq!(store.storage(), storage);
            assert_eq!(boxes.len(), store.len());
            for (s, b) in boxes.iter().enumerate() {
                assert_eq!(*b, store.bounds(scene, s as u32), "entry {s}");
            }
        }
    }

    /// The store gathers its reach in the pass that makes its keys, chunk by chunk: the
    /// same union of the finite boxes that [`Reach::of`] takes, so that every structure moves
    /// a far ray alike. Without the `finite` filter the infinite triangle's box would join it.
    #[test]
    fn the_store_reach_is_every_structures_reach() {
        use crate::geometry::{Ray, Shape};
        use crate::scene::Terrain;
        let mut scene = Terrain::with_triangles(10_000, 5).scene();
        scene.shapes.push(Shape::Triangle([
            Vec3::ZERO,
            Vec3::splat(f32::INFINITY),
            Vec3::X,
        ]));
        let store = PrimStore::build(&scene);
        let reach = Reach::of(&scene);
        assert!(reach.bounds().extent().is_finite());
        assert_eq!(store.reach().bounds(), reach.bounds());
        for far in [10.0, 1e3, 1e6] {
            let ray = Ray::new(Vec3::splat(far), -Vec3::ONE, 0.0, f32::INFINITY);
            assert_eq!(
                store.reach().walks_as_given(&ray),
                reach.walks_as_given(&ray)
            );
        }
    }

    #[test]
    fn finite_boxes_are_those_not_empty_with_finite_corners() {
        let values = [
            0.0,
            -0.0,
            1.0,
            -2.5,
            f32::MAX,
            f32::MIN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
        ];
        let mut k = 0usize;
        for &a in &values {
            for &b in &values {
                for axis in 0..3 {
                    // One axis from `a` to `b`, the others ordinary, and every value also
                    // on the other corners' axes in turn.
                    let mut lo = Vec3::new(1.0, -1.0, 0.5);
                    let mut hi = Vec3::new(2.0, 3.0, 0.5);
                    lo[axis] = a;
                    hi[axis] = b;
                    let other = values[k % values.len()];
                    k += 1;
                    lo[(axis + 1) % 3] = lo[(axis + 1) % 3].min(other);
                    let bx = Aabb::new(lo, hi);
                    let by_coordinate = !bx.is_empty() && bx.min.is_finite() && bx.max.is_finite();
                    assert_eq!(finite(&bx), by_coordinate, "{bx:?}");
                }
            }
        }
    }

    #[test]
    fn morton_interleaves_axes() {
        assert_eq!(spread3(0b11), 0b1001);
        assert_eq!(spread3(0x3ff), 0x0924_9249);
        let b = MortonFrame::new(&Aabb::new(Vec3::ZERO, Vec3::ONE), 10);
        assert_eq!(b.code(Vec3::ZERO), 0);
        assert!(b.code(Vec3::new(1.0, 0.0, 0.0)) < b.code(Vec3::new(0.0, 1.0, 0.0)));
        assert!(b.code(Vec3::new(0.0, 1.0, 0.0)) < b.code(Vec3::new(0.0, 0.0, 1.0)));
        assert_eq!(b.code(Vec3::ONE), (1 << 30) - 1);
        assert_eq!(b.code(Vec3::splat(7.0)), (1 << 30) - 1, "clamped");
        let coarse = MortonFrame::new(&Aabb::new(Vec3::ZERO, Vec3::ONE), 7);
        assert_eq!(coarse.code(Vec3::ONE), (1 << 21) - 1);
        assert_eq!(coarse.code(Vec3::new(0.5, 0.0, 0.0)), spread3(63));
        assert_eq!(
            [1, 8, 9, 70_000, 524_288, 2_097_152, 2_097_153, 1 << 31].map(morton_bits),
            [1, 2, 3, 7, 8, 8, 9, 10]
        );
    }

    /// The codes one axis at a time, as the store took them before the frame's vector.
    fn morton_by_axis(p: Vec3, b: &Aabb) -> u32 {
        let e = b.extent();
        let scale = |a: usize| {
            if e[a] > 0.0 {
                (((p[a] - b.min[a]) / e[a]).clamp(0.0, 1.0) * 1023.0) as u32
            } else {
                0
            }
        };
        spread3(scale(0)) | spread3(scale(1)) << 1 | spread3(scale(2)) << 2
    }

    #[test]
    fn morton_codes_are_those_of_one_axis_at_a_time() {
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 40) as f32 / (1u64 << 24) as f32
        };
        let boxes = [
            Aabb::new(Vec3::new(-3.0, 1.0, 0.5), Vec3::new(5.0, 1.25, 900.0)),
            // Flat along y, a point along z: those axes give 0.
            Aabb::new(Vec3::new(0.0, 2.0, 7.0), Vec3::new(1.0, 2.0, 7.0)),
            Aabb::EMPTY,
        ];
        for b in &boxes {
            let frame = MortonFrame::new(b, 10);
            let (lo, e) = if b.is_empty() {
                (Vec3::ZERO, Vec3::ONE)
            } else {
                (b.min, b.extent())
            };
            for _ in 0..10_000 {
                // Points inside and up to half the box's size outside it on every side.
                let t = Vec3::new(next(), next(), next()) * 2.0 - 0.5;
                let p = lo + t * e;
                assert_eq!(frame.code(p), morton_by_axis(p, b), "{p} in {b:?}");
            }
            for p in [lo, lo + e, Vec3::splat(f32::INFINITY), Vec3::splat(-1e30)] {
                assert_eq!(frame.code(p), morton_by_axis(p, b), "{p} in {b:?}");
            }
        }
    }
}
