//! A whole rendering as `hugrt render` runs it: the scene opened, its camera placed, the
//! structure built (and the occluders' for soft shadows), the image rendered, every step
//! timed; each setting checked before any work.

use super::{RenderReport, RenderSettings, Rendered, SoftShadows, render_impl, render_world};
use crate::Error;
use crate::accel::{AnyAccel, Packets};
use crate::scene::{InstancedScene, View};
use crate::world::World;
use std::time::Instant;

/// What `hugrt render` renders when no scene is named: EG95's case, built in, so that it
/// runs anywhere.
pub const DEFAULT_SCENE: &str = "builtin:kitchen";

/// The longest image side a rendering accepts.
pub const MAX_SIDE: u32 = 65536;

/// What to render and how.
#[derive(Clone, Debug)]
pub struct RenderJob {
    /// A scene by name ([`InstancedScene::open`]: a scene of instances keeps them).
    pub scene: String,
    /// The structure's spec ([`AnyAccel::build`]).
    pub accel: String,
    /// Image size; `None` takes the scene's resolution.
    pub width: Option<u32>,
    pub height: Option<u32>,
    /// Bounces after the eye ray ([`RenderSettings::depth`]).
    pub depth: u32,
    /// Gather the papers' counters per level (slower).
    pub counters: bool,
    /// Soft shadows from spherical lights of this radius, a fraction of the scene's
    /// diagonal ([`SoftShadows`]); `None` for hard shadows.
    pub soft_shadows: Option<f32>,
    /// The camera, over the scene's.
    pub view: View,
    /// Render a scene with no primitives (a blank image) rather than fail.
    pub allow_empty: bool,
    /// When eye and shadow rays are walked as packets ([`RenderSettings::packets`]).
    pub packets: Packets,
}

impl RenderJob {
    /// The job of rendering `scene` through `accel` with the SPD's depth and the scene's
    /// own camera and resolution.
    pub fn new(scene: &str, accel: &str) -> RenderJob {
        RenderJob {
            scene: scene.to_string(),
            accel: accel.to_string(),
            width: None,
            height: None,
            depth: 4,
            counters: false,
            soft_shadows: None,
            view: View::default(),
            allow_empty: false,
            packets: Packets::default(),
        }
    }

    /// Checks every setting that can be checked without the scene: the spec, the image
    /// sides, the depth and the light radius.
    pub fn check(&self) -> Result<(), Error> {
        AnyAccel::check(&self.accel).map_err(|e| Error::spec(&self.accel, e))?;
        check_image(self.width, self.height, self.soft_shadows)?;
        if self.depth > super::MAX_BOUNCES {
            return Err(Error::Invalid(format!(
                "depth {}: at most {} bounces",
                self.depth,
                super::MAX_BOUNCES
            )));
        }
        Ok(())
    }

    /// Runs the job on the current rayon pool. `progress(rows, total)` is called with the
    /// corner rows finished since its last call and how many there are in all.
    pub fn run(
        &self,
        progress: &(dyn Fn(u64, u64) + Sync),
    ) -> Result<(Rendered, RenderReport), Error> {
        self.check()?;
        let t = Instant::now();
        let mut scene = match InstancedScene::open(&self.scene)?.into_flat() {
            Ok(scene) => scene,
            Err(instanced) => return self.run_instanced(instanced, t, progress),
        };
        if scene.is_empty() && !self.allow_empty {
            return Err(Error::Empty(self.scene.clone()));
        }
        scene.camera = scene.camera.viewed(&self.view)?;
        let load_seconds = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let spec_error = |e| Error::spec(&self.accel, e);
        let accel = AnyAccel::build(&scene, &self.accel).map_err(spec_error)?;
        let soft = self
            .soft_shadows
            .map(|r| SoftShadows::build(&scene, &self.accel, r))
            .transpose()
            .map_err(spec_error)?;
        let build_seconds = t.elapsed().as_secs_f64();
        let settings = RenderSettings {
            width: self.width.unwrap_or(scene.camera.width),
            height: self.height.unwrap_or(scene.camera.height),
            depth: self.depth,
            counters: self.counters,
            packets: self.packets,
        };
        check_image(Some(settings.width), Some(settings.height), None)?;
        let total = settings.height as u64 + 1;
        let t = Instant::now();
        let out = render_impl(
            &scene,
            &accel,
            soft.as_ref(),
            &settings,
            0..settings.height.max(1),
            &|n| progress(n, total),
        );
        let render_seconds = t.elapsed().as_secs_f64();
        let report = RenderReport {
            counts: out.counts,
            scene: self.scene.clone(),
            accel: self.accel.clone(),
            primitives: scene.len(),
            width: settings.width,
            height: settings.height,
            load_seconds,
            build_seconds,
            render_seconds,
            accel_memory_bytes: accel.memory_bytes()
                + soft.as_ref().map_or(0, |s| s.memory_bytes()),
            soft_shadow_radius: soft.as_ref().map(|s| s.radius()),
            counters_per_level: out.counters.as_ref().map(|k| k.used_levels().to_vec()),
            structure: accel.name(),
            lights: scene.lights.len(),
            instances: None,
        };
        Ok((out, report))
    }
}

impl RenderJob {
    /// [`RenderJob::run`] for a scene of instances: each model's structure built once
    /// ([`World`]), hard shadows.
    fn run_instanced(
        &self,
        mut scene: InstancedScene,
        t: Instant,
        progress: &(dyn Fn(u64, u64) + Sync),
    ) -> Result<(Rendered, RenderReport), Error> {
        if self.soft_shadows.is_some() {
            return Err(Error::Invalid(format!(
                "{}: soft shadows through instances are not offered",
                self.scene
            )));
        }
        let world_scene = &mut scene.models.last_mut().expect("a world").scene;
        world_scene.camera = world_scene.camera.viewed(&self.view)?;
        let load_seconds = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let world = World::build(scene, &self.accel)?;
        if world.flattened_primitives() == 0 && !self.allow_empty {
            return Err(Error::Empty(self.scene.clone()));
        }
        let build_seconds = t.elapsed().as_secs_f64();
        let camera = &world.scene().camera;
        let settings = RenderSettings {
            width: self.width.unwrap_or(camera.width),
            height: self.height.unwrap_or(camera.height),
            depth: self.depth,
            counters: self.counters,
            packets: self.packets,
        };
        check_image(Some(settings.width), Some(settings.height), None)?;
        let total = settings.height as u64 + 1;
        let t = Instant::now();
        let out = render_world(&world, &settings, &|n| progress(n, total));
        let render_seconds = t.elapsed().as_secs_f64();
        let (accel, _) = world.top();
        let report = RenderReport {
            counts: out.counts,
            scene: self.scene.clone(),
            accel: self.accel.clone(),
            primitives: world.flattened_primitives() as usize,
            width: settings.width,
            height: settings.height,
            load_seconds,
            build_seconds,
            render_seconds,
            accel_memory_bytes: world.memory_bytes(),
            soft_shadow_radius: None,
            counters_per_level: out.counters.as_ref().map(|k| k.used_levels().to_vec()),
            structure: accel.name(),
            lights: world.scene().lights.len(),
            instances: Some(world.instances()),
        };
        Ok((out, report))
    }
}

/// Checks an image's sides (1 to [`MAX_SIDE`]) and a soft shadows' light radius (finite, 0
/// or more), where given.
pub fn check_image(
    width: Option<u32>,
    height: Option<u32>,
    soft_shadows: Option<f32>,
) -> Result<(), Error> {
    if let Some(r) = soft_shadows
        && !(r.is_finite() && r >= 0.0)
    {
        return Err(Error::Invalid(format!(
            "soft shadows: a light radius of {r}; it must be a finite fraction of the diagonal, 0 or more"
        )));
    }
    for side in [width, height].into_iter().flatten() {
        if side == 0 || side > MAX_SIDE {
            return Err(Error::Invalid(format!(
                "image size: a side of {side} is not within 1..={MAX_SIDE}"
            )));
        }
    }
    Ok(())
}
