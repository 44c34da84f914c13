//! An instanced scene built for ray shooting: each model's structure built once, each
//! instance walked by taking the ray into its frame.
//!
//! A model's structure is built over [`ModelPrimitives`]: the model's own primitives, then
//! one primitive per instance whose box is the placed model's box and whose test walks the
//! placed model's structure with the ray in the model's frame (`origin' = M⁻¹·origin`,
//! `dir' = M⁻¹·dir`, unnormalised, so that `t` is the same on both rays). To the HUG an
//! instance is an object like any other: its filter sorts it by size, its clustering places
//! it, and its grids reference it in the cells it overlaps, as SCG97 §7.2 walks a turned
//! cluster's grid in the cluster's frame; to the bvh it is a leaf of the top level. A
//! model's structure thus stands once in memory however often the model is placed, and
//! nesting (buildings of kitchens) comes from the recursion.
//!
//! A hit found at the top names an instance; [`World::closest_hit`] follows it down, asking
//! each placed model's structure again for the hit it gave (once per ray, not per test), to
//! report the model, its primitive and the instances on the way ([`InstanceHit`]).
//!
//! Every structure of [`crate::accel::STRUCTURES`] can be used at every level; one spec
//! builds them all.

use crate::accel::{
    AnyAccel, Counters, Hit, HitDetails, NoCounters, PrimitiveKind, Primitives, StructureStats,
    Walked,
};
use crate::geometry::{Aabb, PreparedRay, Ray, Shape, SurfacePoint, Vec3};
use crate::scene::{InstancedScene, MAX_NESTING, Material, Scene, cofactor, transformed_box};
use glam::{Affine3A, Mat3A};

/// An instance as the structures see it: the model, both ways of its transform, its box.
#[derive(Clone, Copy, Debug)]
struct Placed {
    model: u32,
    to_world: Affine3A,
    to_local: Affine3A,
    bounds: Aabb,
}

impl Placed {
    /// The ray in the placed model's frame, over `[tmin, tmax]`: the same `t` on both.
    #[inline]
    fn local_ray(&self, ray: &Ray, tmin: f32, tmax: f32) -> Ray {
        ray_in(&self.to_local, ray, tmin, tmax)
    }
}

/// `ray` mapped by `to_local` over `[tmin, tmax]`, its direction not normalised, so that `t`
/// is the same on both.
#[inline]
fn ray_in(to_local: &Affine3A, ray: &Ray, tmin: f32, tmax: f32) -> Ray {
    Ray::new(
        to_local.transform_point3(ray.origin),
        to_local.transform_vector3(ray.dir),
        tmin,
        tmax,
    )
}

/// One model built: its scene, its instances, its structure.
struct BuiltModel {
    name: String,
    scene: Scene,
    placed: Vec<Placed>,
    accel: AnyAccel,
    bounds: Aabb,
    /// The flattened index of instance `j`'s first primitive within this model's copy.
    first_flat: Vec<u64>,
    /// Primitives of one copy of this model, flattened (saturating).
    flat_len: u64,
}

/// A model's primitives as its structure sees them: its scene's, then one per instance.
#[derive(Clone, Copy)]
pub struct ModelPrimitives<'a> {
    models: &'a [BuiltModel],
    scene: &'a Scene,
    placed: &'a [Placed],
}

impl BuiltModel {
    fn primitives<'a>(&'a self, models: &'a [BuiltModel]) -> ModelPrimitives<'a> {
        ModelPrimitives {
            models,
            scene: &self.scene,
            placed: &self.placed,
        }
    }
}

impl Primitives for ModelPrimitives<'_> {
    fn len(&self) -> usize {
        self.scene.len() + self.placed.len()
    }

    fn bounds(&self, i: usize) -> Aabb {
        match i.checked_sub(self.scene.len()) {
            None => self.scene.shape(i).bounds(),
            Some(j) => self.placed[j].bounds,
        }
    }

    #[inline]
    fn intersect(&self, i: usize, ray: &PreparedRay, tmin: f32, tmax: f32) -> Option<f32> {
        let Some(j) = i.checked_sub(self.scene.len()) else {
            return self.scene.shape(i).intersect(ray, tmin, tmax);
        };
        let p = &self.placed[j];
        // A structure's leaf or cell tests every instance it holds: the box first, as it
        // would test a node's, before the ray is taken into the frame and the model walked.
        p.bounds.intersect(ray, tmin, tmax)?;
        let m = &self.models[p.model as usize];
        let local = p.local_ray(&ray.ray, tmin, tmax);
        m.accel
            .closest_hit(&m.primitives(self.models), &local, &mut NoCounters)
            .map(|h| h.t)
    }

    fn overlaps_box(&self, i: usize, b: &Aabb) -> bool {
        match i.checked_sub(self.scene.len()) {
            None => self.scene.shape(i).overlaps_box(b),
            Some(j) => self.placed[j].bounds.overlaps(b),
        }
    }

    fn kind(&self, i: usize) -> PrimitiveKind {
        if i < self.scene.len() {
            self.scene.kind(i)
        } else {
            PrimitiveKind::Opaque
        }
    }

    fn mesh_triangle(&self, i: usize) -> Option<[u32; 3]> {
        if i < self.scene.len() {
            self.scene.mesh_triangle(i)
        } else {
            None
        }
    }

    fn shared_vertices(&self) -> Option<std::sync::Arc<Vec<Vec3>>> {
        self.scene.shared_vertices()
    }
}

/// The instances a hit lies in, from the world's down: `path()[0]` is an instance of the
/// world model, `path()[1]` an instance of the model it places, and so on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct InstancePath {
    len: u8,
    ids: [u32; MAX_NESTING],
}

impl InstancePath {
    pub fn path(&self) -> &[u32] {
        &self.ids[..self.len as usize]
    }

    /// The world's instance the hit lies in; `None` for the world's own geometry.
    pub fn top(&self) -> Option<u32> {
        self.path().first().copied()
    }
}

/// A hit in an instanced world.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InstanceHit {
    pub t: f32,
    /// The model whose own primitive is hit.
    pub model: u32,
    /// The primitive's index in that model's scene.
    pub prim: u32,
    pub instances: InstancePath,
    /// The primitive's index in the flattened world ([`InstancedScene::flattened`]'s order).
    pub flat_prim: u64,
    /// The model's frame: world point = `to_world · model point`.
    pub to_world: Affine3A,
}

/// An instanced scene with every model's structure built.
pub struct World {
    models: Vec<BuiltModel>,
}

impl World {
    /// Builds each model's structure by `spec`, models in order (each after those it places).
    pub fn build(scene: InstancedScene, spec: &str) -> Result<World, crate::Error> {
        scene.check()?;
        AnyAccel::check(spec).map_err(|e| crate::Error::spec(spec, e))?;
        let boxes = scene.model_bounds();
        let counts = scene.flattened_counts();
        let mut models: Vec<BuiltModel> = Vec::with_capacity(scene.models.len());
        for (model, bounds) in scene.models.into_iter().zip(boxes.iter().copied()) {
            let mut first_flat = Vec::with_capacity(model.instances.len());
            let mut next = model.scene.len() as u64;
            let placed: Vec<Placed> = model
                .instances
                .iter()
                .map(|inst| {
                    first_flat.push(next);
                    next = next.saturating_add(counts[inst.model as usize]);
                    Placed {
                        model: inst.model,
                        to_world: inst.transform,
                        to_local: inst.transform.inverse(),
                        bounds: transformed_box(&inst.transform, &boxes[inst.model as usize]),
                    }
                })
                .collect();
            let prims = ModelPrimitives {
                models: &models,
                scene: &model.scene,
                placed: &placed,
            };
            let accel = AnyAccel::build(&prims, spec).map_err(|e| crate::Error::spec(spec, e))?;
            models.push(BuiltModel {
                name: model.name,
                scene: model.scene,
                placed,
                accel,
                bounds,
                first_flat,
                flat_len: next,
            });
        }
        Ok(World { models })
    }

    fn world(&self) -> &BuiltModel {
        self.models.last().expect("a world has a model")
    }

    /// The world model's scene: its own geometry, camera, lights and background.
    pub fn scene(&self) -> &Scene {
        &self.world().scene
    }

    /// The world model's structure and primitives: the top level, for queries in the
    /// structures' own terms (a hit's `prim` is then the world's primitive or instance).
    pub fn top(&self) -> (&AnyAccel, ModelPrimitives<'_>) {
        let w = self.world();
        (&w.accel, w.primitives(&self.models))
    }

    pub fn bounds(&self) -> Aabb {
        self.world().bounds
    }

    /// Primitives of the flattened world (saturating at `u64::MAX`).
    pub fn flattened_primitives(&self) -> u64 {
        self.world().flat_len
    }

    /// Primitives stored: each model's own, once.
    pub fn stored_primitives(&self) -> u64 {
        self.models.iter().map(|m| m.scene.len() as u64).sum()
    }

    /// Instances placed in all models (each counted once, not per copy of its model).
    pub fn instances(&self) -> u64 {
        self.models.iter().map(|m| m.placed.len() as u64).sum()
    }

    pub fn models(&self) -> usize {
        self.models.len()
    }

    /// Bytes of every model's structure and of the instances.
    pub fn memory_bytes(&self) -> usize {
        self.models
            .iter()
            .map(|m| {
                m.accel.memory_bytes()
                    + m.placed.capacity() * std::mem::size_of::<Placed>()
                    + m.first_flat.capacity() * 8
            })
            .sum()
    }

    /// Bytes of every model's scene.
    pub fn scene_memory_bytes(&self) -> usize {
        self.models.iter().map(|m| m.scene.memory_bytes()).sum()
    }

    /// The top level's statistics, with the world's counts ahead of them.
    pub fn stats(&self) -> StructureStats {
        let mut s = self.world().accel.stats();
        let mut head = StructureStats::default();
        head.push("models", self.models.len() as f64);
        head.push("instances", self.instances() as f64);
        head.push("stored_primitives", self.stored_primitives() as f64);
        head.push("flattened_primitives", self.flattened_primitives() as f64);
        head.push("world_memory_bytes", self.memory_bytes() as f64);
        head.push(
            "world_bytes_per_flattened_primitive",
            self.memory_bytes() as f64 / self.flattened_primitives().max(1) as f64,
        );
        head.entries.append(&mut s.entries);
        s.entries = head.entries;
        s
    }

    /// The nearest hit in the ray's `[tmin, tmax]`, followed down to the primitive; the
    /// counters count the top level's walk.
    pub fn closest_hit<C: Counters>(&self, ray: &Ray, counters: &mut C) -> Option<InstanceHit> {
        let (accel, prims) = self.top();
        let walked = accel.closest_hit_walked(&prims, ray, counters)?;
        Some(self.resolve(&walked))
    }

    /// Whether anything is hit in the ray's `[tmin, tmax]`.
    pub fn any_hit<C: Counters>(&self, ray: &Ray, counters: &mut C) -> bool {
        let (accel, prims) = self.top();
        accel.any_hit(&prims, ray, counters).is_some()
    }

    /// A top-level hit followed down: at each instance on the way, the placed model's
    /// structure is asked again for the hit it gave the level above, with the ray that level
    /// walked taken into the model's frame (the same ray the instance's test saw, so the same
    /// walk, and the same primitive or one at the same `t`).
    pub fn resolve(&self, top: &Walked) -> InstanceHit {
        let mut k = self.models.len() - 1;
        let (mut hit, mut ray) = (top.hit, top.ray);
        let mut path = InstancePath {
            len: 0,
            ids: [0; MAX_NESTING],
        };
        let mut to_world = Affine3A::IDENTITY;
        let mut flat = 0u64;
        loop {
            let m = &self.models[k];
            let n = m.scene.len();
            let Some(j) = (hit.prim as usize).checked_sub(n) else {
                return InstanceHit {
                    t: top.t,
                    model: k as u32,
                    prim: hit.prim,
                    instances: path,
                    flat_prim: flat.saturating_add(hit.prim as u64),
                    to_world,
                };
            };
            let p = &m.placed[j];
            path.ids[path.len as usize] = j as u32;
            path.len += 1;
            flat = flat.saturating_add(m.first_flat[j]);
            to_world *= p.to_world;
            let child = &self.models[p.model as usize];
            let prims = child.primitives(&self.models);
            let ask = |tmax| {
                let local = p.local_ray(&ray, ray.tmin, tmax);
                child
                    .accel
                    .closest_hit_walked(&prims, &local, &mut NoCounters)
            };
            // The level above saw the hit's `t` mapped back from the model's own walk of a
            // far ray ([`crate::accel::Reach`]) and rounded: the hit can lie an ulp past it,
            // and is then the nearest over the whole interval.
            let w = ask(hit.t)
                .or_else(|| ask(ray.tmax))
                .expect("an instance's hit is found again in its model");
            hit = w.hit;
            ray = w.ray;
            k = p.model as usize;
        }
    }

    /// The hit's barycentrics and world normal ([`Hit::details`] in the model's frame,
    /// the normal taken to the world's).
    pub fn details(&self, hit: &InstanceHit, ray: &Ray) -> HitDetails {
        let m = &self.models[hit.model as usize];
        let local_ray = ray_in(&hit.to_world.inverse(), ray, ray.tmin, ray.tmax);
        let d = Hit {
            t: hit.t,
            prim: hit.prim,
        }
        .details(&m.scene, &local_ray);
        HitDetails {
            prim: hit.prim,
            normal: world_normal(&hit.to_world, d.normal, m.scene.shape(hit.prim as usize)),
            ..d
        }
    }

    /// The hit's point (on the world ray), normals in the world's frame, and material.
    pub fn surface(&self, hit: &InstanceHit, ray: &Ray) -> (SurfacePoint, &Material) {
        let m = &self.models[hit.model as usize];
        let local_ray = ray_in(&hit.to_world.inverse(), ray, ray.tmin, ray.tmax);
        let shape = m.scene.shape(hit.prim as usize);
        let sp = shape.surface(&PreparedRay::new(&local_ray), hit.t, &m.scene.patch_normals);
        let to_world = |n| world_normal(&hit.to_world, n, shape);
        let surface = SurfacePoint {
            point: ray.at(hit.t),
            geometric_normal: to_world(sp.geometric_normal),
            shading_normal: to_world(sp.shading_normal),
        };
        (surface, m.scene.material(hit.prim))
    }

    /// The name of model `k`.
    pub fn model_name(&self, k: usize) -> &str {
        &self.models[k].name
    }
}

/// A model-frame normal in the world's frame: a triangle's winding normal goes by the
/// cofactor matrix (a mirror turns the winding, as it turns a flattened copy's), a sphere's
/// or cone's outward normal by the inverse transpose (outward stays outward).
fn world_normal(to_world: &Affine3A, n: Vec3, shape: Shape) -> Vec3 {
    let c: Mat3A = cofactor(to_world);
    let w = c * n;
    let w = match shape {
        Shape::Sphere(_) | Shape::Cone(_) if to_world.matrix3.determinant() < 0.0 => -w,
        _ => w,
    };
    w.normalize_or_zero()
}
