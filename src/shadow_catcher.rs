//! Blender's shadow catcher (Object › Visibility › Shadow Catcher) with a transparent film, as
//! Cycles composes its Combined pass: the catcher is invisible, and where it is seen the image
//! is transparent but for the shadows other objects cast on it.
//!
//! A camera sample whose ray first meets a catcher is traced twice: as usual, with every
//! object (`with`), and once more in a copy of the scene that holds only the catchers
//! (`CatcherScene`, as Cycles' shadow catcher pass sees it), with the same random numbers so
//! the two agree but for the other objects' shadows and light. Per pixel the ratio of the sums,
//! with / without, is the light the catcher keeps (Cycles' Shadow Catcher pass); the colour is
//! that of the samples that met no catcher (Cycles' matte), and the alpha is their coverage,
//! the rest of the pixel covered by the shadow, 1 − the ratio's mean (Cycles'
//! `film_calculate_shadow_catcher_matte_with_shadow`). The ratio over white by the pixel's
//! coverage is Cycles' Shadow Catcher pass (`film_calculate_shadow_catcher`), written beside
//! the Combined pass (`film::Image::shadow_catcher`).

use crate::accel::Accel;
use crate::integrator::Context;
use crate::light::Lights;
use crate::math::Vec3;
use crate::scene::Scene;

/// The scene as the shadow catcher pass sees it: only the catcher objects (and the lights).
pub struct CatcherScene {
    scene: Scene,
    accel: Accel,
    lights: Lights,
}

impl CatcherScene {
    /// `None` when `scene` has no shadow catcher.
    pub fn new(scene: &Scene) -> Option<CatcherScene> {
        let catchers = scene.meshes.iter().any(|m| m.shadow_catcher)
            || scene.instances.iter().any(|i| i.shadow_catcher);
        if !catchers {
            return None;
        }
        let mut only = scene.clone();
        // Meshes keep their indices (lights refer to them), without their triangles.
        for mesh in only.meshes.iter_mut().filter(|m| !m.shadow_catcher) {
            mesh.indices.clear();
        }
        only.instances.retain(|i| i.shadow_catcher);
        let accel = Accel::new(&only);
        let lights = Lights::new(&only);
        Some(CatcherScene {
            scene: only,
            accel,
            lights,
        })
    }

    /// A context like `ctx` over the catchers alone.
    pub fn context<'a>(&'a self, ctx: &Context) -> Context<'a> {
        Context {
            scene: &self.scene,
            accel: &self.accel,
            lights: &self.lights,
            max_depth: ctx.max_depth,
            transparent_background: ctx.transparent_background,
        }
    }
}

/// What a pixel's samples that met a shadow catcher gathered.
#[derive(Clone, Copy, Debug, Default)]
pub struct CatcherSum {
    /// Their radiance with every object.
    pub with: Vec3,
    /// Their radiance with the catchers alone.
    pub without: Vec3,
    pub samples: f32,
}

impl CatcherSum {
    pub fn add(&mut self, with: Vec3, without: Vec3) {
        self.with += with;
        self.without += without;
        self.samples += 1.0;
    }

    /// The pixel's colour and alpha from the sum `sum` of all its `n` samples' radiance, of
    /// which `coverage` met an object, and its Shadow Catcher pass (module header).
    pub fn compose(&self, sum: Vec3, coverage: f32, n: f32) -> ([f32; 4], Vec3) {
        let matte = (sum - self.with) / n;
        let objects = ((coverage - self.samples) / n).clamp(0.0, 1.0);
        let ratio = |w: f32, wo: f32| if wo != 0.0 { w / wo } else { 1.0 };
        let kept = Vec3::new(
            ratio(self.with.x, self.without.x),
            ratio(self.with.y, self.without.y),
            ratio(self.with.z, self.without.z),
        );
        let covered = (coverage / n).clamp(0.0, 1.0);
        let shadow = Vec3::splat(1.0 - covered) + covered * kept;
        let mean = ((shadow.x + shadow.y + shadow.z) / 3.0).clamp(0.0, 1.0);
        let alpha = (1.0 - objects) * (1.0 - mean) + objects;
        ([matte.x, matte.y, matte.z, alpha], shadow)
    }
}
