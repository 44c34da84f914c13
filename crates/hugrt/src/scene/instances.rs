//! Instancing: models placed many times by affine transforms, each model kept once.
//!
//! EG95 §3.1 builds its building of kitchens by copying the kitchen; here a kitchen is a
//! [`Model`], and each placed copy an [`Instance`] (the model and its transform). A model
//! has geometry of its own (a [`Scene`]) and may place models defined before it, so a city of
//! buildings of kitchens is three models, whatever its number of triangles. The models form
//! an [`InstancedScene`]; [`crate::world::World`] builds each model's structure once and
//! walks an instance by taking the ray into its frame.

use super::{Material, Scene};
use crate::geometry::{Aabb, Cone, Shape, Sphere, Vec3};
use glam::{Affine3A, Mat3A};

/// The deepest nesting of models: a world placing buildings placing kitchens is three.
pub const MAX_NESTING: usize = 16;

/// A placed copy of a model: its points are `transform · p` in the frame of the model that
/// places it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Instance {
    /// The placed model's index in [`InstancedScene::models`].
    pub model: u32,
    pub transform: Affine3A,
}

/// Geometry of its own and copies of models defined before it: a kitchen, a building of
/// kitchens. Its primitives are numbered as its scene's, then one per instance.
#[derive(Clone, Debug, Default)]
pub struct Model {
    pub name: String,
    pub scene: Scene,
    pub instances: Vec<Instance>,
}

/// Models, each placing only models before it; the last is the world, whose scene's camera,
/// lights and background are the rendering's.
#[derive(Clone, Debug, Default)]
pub struct InstancedScene {
    pub models: Vec<Model>,
}

/// An instanced scene that cannot be built, with the model and instance it concerns.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum InstanceError {
    #[error("an instanced scene needs at least one model")]
    NoModels,
    #[error(
        "model '{model}', instance {instance}: places model {target}, which is not defined before it"
    )]
    NotBefore {
        model: String,
        instance: usize,
        target: u32,
    },
    #[error("model '{model}', instance {instance}: {reason}")]
    Transform {
        model: String,
        instance: usize,
        reason: &'static str,
    },
    #[error("model '{model}': models nested more than {MAX_NESTING} deep")]
    TooDeep { model: String },
    #[error(
        "model '{model}', primitive {prim}: a {what} under a transform that is not a similarity cannot be flattened"
    )]
    NotSimilar {
        model: String,
        prim: usize,
        what: &'static str,
    },
}

impl Instance {
    /// Why the transform cannot place a model, if it cannot: a coordinate that is not finite,
    /// or a linear part without an inverse in single precision.
    pub fn check(&self) -> Result<(), &'static str> {
        let m = self.transform;
        if !(m.matrix3.is_finite() && m.translation.is_finite()) {
            return Err("the transform has a coordinate that is NaN or infinite");
        }
        let inverse = m.matrix3.as_dmat3().inverse();
        if m.matrix3.determinant() == 0.0 || !inverse.is_finite() || !inverse.as_mat3().is_finite()
        {
            return Err("the transform is singular (it flattens the model)");
        }
        Ok(())
    }
}

impl InstancedScene {
    /// One model: a scene with no instances, as a world of its own.
    pub fn of_scene(scene: Scene) -> InstancedScene {
        InstancedScene {
            models: vec![Model {
                name: "world".into(),
                scene,
                instances: Vec::new(),
            }],
        }
    }

    /// The world: the last model.
    pub fn world(&self) -> Option<&Model> {
        self.models.last()
    }

    /// Checks what a build relies on: some model, every instance placing an earlier model by
    /// a finite invertible transform, nesting at most [`MAX_NESTING`] deep.
    pub fn check(&self) -> Result<(), InstanceError> {
        if self.models.is_empty() {
            return Err(InstanceError::NoModels);
        }
        let mut depth = vec![0usize; self.models.len()];
        for (k, m) in self.models.iter().enumerate() {
            for (j, inst) in m.instances.iter().enumerate() {
                if inst.model as usize >= k {
                    return Err(InstanceError::NotBefore {
                        model: m.name.clone(),
                        instance: j,
                        target: inst.model,
                    });
                }
                inst.check().map_err(|reason| InstanceError::Transform {
                    model: m.name.clone(),
                    instance: j,
                    reason,
                })?;
                depth[k] = depth[k].max(depth[inst.model as usize] + 1);
            }
            if depth[k] >= MAX_NESTING {
                return Err(InstanceError::TooDeep {
                    model: m.name.clone(),
                });
            }
        }
        Ok(())
    }

    /// The world's box: every model's own box and its instances' boxes, transformed.
    pub fn bounds(&self) -> Aabb {
        self.model_bounds().last().copied().unwrap_or(Aabb::EMPTY)
    }

    /// Each model's box: its own primitives' and its instances' boxes, transformed (an
    /// instance of a model not before it, which [`InstancedScene::check`] refuses, adds
    /// nothing).
    pub fn model_bounds(&self) -> Vec<Aabb> {
        let mut boxes: Vec<Aabb> = Vec::with_capacity(self.models.len());
        for m in &self.models {
            let own = m.scene.bounds();
            boxes.push(
                m.instances
                    .iter()
                    .fold(own, |b, i| match boxes.get(i.model as usize) {
                        Some(child) => b.union(&transformed_box(&i.transform, child)),
                        None => b,
                    }),
            );
        }
        boxes
    }

    /// The world's scene when the world places nothing (the flat scene it is: models it
    /// does not place are left out), else the scene of instances itself, given back.
    pub fn into_flat(mut self) -> Result<Scene, InstancedScene> {
        if self.has_instances() {
            return Err(self);
        }
        Ok(self.models.pop().map(|m| m.scene).unwrap_or_default())
    }

    /// Whether the world places any model: otherwise it is a flat scene.
    pub fn has_instances(&self) -> bool {
        self.world().is_some_and(|w| !w.instances.is_empty())
    }

    /// Primitives of each model with its copies flattened (saturating): the world's is the
    /// scene's count as a flattened copy would have it.
    pub fn flattened_counts(&self) -> Vec<u64> {
        let mut counts: Vec<u64> = Vec::with_capacity(self.models.len());
        for m in &self.models {
            let placed = m
                .instances
                .iter()
                .fold(0u64, |n, i| n.saturating_add(counts[i.model as usize]));
            counts.push((m.scene.len() as u64).saturating_add(placed));
        }
        counts
    }

    /// The world with every instance replaced by a transformed copy of its model's
    /// primitives, as shapes, numbered depth first: a model's own primitives, then its
    /// instances' in order. [`crate::world::InstanceHit::flat_prim`] numbers hits the same
    /// way. For tests and small scenes: its size is the flattened count.
    ///
    /// Triangles and patches take any transform (a patch's normals the inverse transpose's);
    /// spheres and cones only a similarity (a turn, a uniform scale, a mirror), else
    /// [`InstanceError::NotSimilar`].
    pub fn flattened(&self) -> Result<Scene, InstanceError> {
        self.check()?;
        let world = self.models.len() - 1;
        let mut out = Scene {
            material_runs: Vec::new(),
            materials: Vec::new(),
            ..self.models[world].scene.clone()
        };
        out.shapes.clear();
        out.mesh = Default::default();
        out.patch_normals.clear();
        let mut material_base = vec![0u32; self.models.len()];
        for (k, m) in self.models.iter().enumerate() {
            material_base[k] = out.materials.len() as u32;
            out.materials.extend_from_slice(&m.scene.materials);
        }
        if out.materials.is_empty() {
            out.materials.push(Material::default());
        }
        self.flatten_into(world, Affine3A::IDENTITY, &material_base, &mut out)?;
        if out.material_runs.is_empty() {
            out.material_runs.push((0, 0));
        }
        Ok(out)
    }

    fn flatten_into(
        &self,
        k: usize,
        to_world: Affine3A,
        material_base: &[u32],
        out: &mut Scene,
    ) -> Result<(), InstanceError> {
        let m = &self.models[k];
        let cofactor = cofactor(&to_world);
        let similar = similarity_scale(&to_world);
        for (i, shape) in m.scene.primitives().enumerate() {
            let first = out.shapes.len() as u32;
            let material = material_base[k] + m.scene.material_index(i as u32);
            if out.material_runs.last().map(|r| r.1) != Some(material) {
                out.material_runs.push((first, material));
            }
            let not_similar = |what| InstanceError::NotSimilar {
                model: m.name.clone(),
                prim: i,
                what,
            };
            let p = |v: Vec3| to_world.transform_point3(v);
            out.shapes.push(match shape {
                Shape::Triangle(v) => Shape::Triangle(v.map(p)),
                Shape::Patch { v, normals } => {
                    let n = m.scene.patch_normals[normals as usize]
                        .map(|n| (cofactor * n).normalize_or_zero());
                    out.patch_normals.push(n);
                    Shape::Patch {
                        v: v.map(p),
                        normals: out.patch_normals.len() as u32 - 1,
                    }
                }
                Shape::Sphere(s) => {
                    let scale = similar.ok_or_else(|| not_similar("sphere"))?;
                    Shape::Sphere(Sphere {
                        center: p(s.center),
                        radius: s.radius * scale,
                    })
                }
                Shape::Cone(c) => {
                    let scale = similar.ok_or_else(|| not_similar("cone"))?;
                    Shape::Cone(Cone {
                        base: p(c.base),
                        base_radius: c.base_radius * scale,
                        apex: p(c.apex),
                        apex_radius: c.apex_radius * scale,
                    })
                }
            });
        }
        for inst in &m.instances {
            self.flatten_into(
                inst.model as usize,
                to_world * inst.transform,
                material_base,
                out,
            )?;
        }
        Ok(())
    }
}

/// The cofactor matrix of a transform's linear part, `det(M)·M⁻ᵀ`: it maps a triangle's
/// winding normal `(v1 − v0) × (v2 − v0)` to the transformed triangle's, mirrors included.
pub(crate) fn cofactor(t: &Affine3A) -> Mat3A {
    let [c0, c1, c2] = [t.matrix3.x_axis, t.matrix3.y_axis, t.matrix3.z_axis];
    Mat3A::from_cols(c1.cross(c2), c2.cross(c0), c0.cross(c1))
}

/// The scale of a similarity (columns orthogonal and of one length, to a relative 10⁻⁵),
/// `None` for any other transform.
fn similarity_scale(t: &Affine3A) -> Option<f32> {
    let c = [t.matrix3.x_axis, t.matrix3.y_axis, t.matrix3.z_axis];
    let s = c[0].length();
    let close = |a: f32, b: f32| (a - b).abs() <= 1e-5 * s * s;
    let similar = close(c[1].length_squared(), s * s)
        && close(c[2].length_squared(), s * s)
        && close(c[0].dot(c[1]), 0.0)
        && close(c[1].dot(c[2]), 0.0)
        && close(c[2].dot(c[0]), 0.0);
    similar.then_some(s)
}

/// The box around a box's eight corners, transformed.
pub(crate) fn transformed_box(t: &Affine3A, b: &Aabb) -> Aabb {
    if b.is_empty() {
        return *b;
    }
    (0..8).fold(Aabb::EMPTY, |a, k| {
        a.grow(t.transform_point3(Vec3::new(
            if k & 1 == 0 { b.min.x } else { b.max.x },
            if k & 2 == 0 { b.min.y } else { b.max.y },
            if k & 4 == 0 { b.min.z } else { b.max.z },
        )))
    })
}
