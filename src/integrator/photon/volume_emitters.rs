//! Photons from emitting media (fire, glowing fog: Cycles' volume emission): each object whose
//! volume emits is a photon source. A medium emits ε(x) radiance per unit length in every
//! direction, so its flux is ∫ 4π ε(x) dV over the object; a photon leaves a point x drawn
//! in the object's bounding box with density pdf(x), in a uniform direction, carrying
//! 4π ε(x) / pdf(x) (Jensen 2001, "Realistic Image Synthesis Using Photon Mapping", §10.3:
//! photons from emitting media are emitted where the medium emits).
//!
//! pdf(x) is piecewise constant over a lattice of cells of the box: a pilot reads the
//! emission at jittered points of each cell (only points inside the object count), and each
//! cell is drawn in proportion to what it saw, mixed with a uniform share so that cells whose
//! emission the pilot missed are still drawn (defensive sampling, Hesterberg 1995): the
//! estimate stays unbiased, and fire concentrated in a corner of its box gets its photons
//! where it burns.

use crate::accel::{Ray, FRAME_TIME};
use crate::integrator::media::MediumStack;
use crate::integrator::Context;
use crate::math::{luminance, Vec2, Vec3};
use crate::rng::Rng;
use crate::sampling::{square_to_uniform_sphere, Distribution1D};
use crate::scene::{instance_bounds, Bounds};
use std::f32::consts::PI;

/// Cells of the pilot's lattice along each axis of an object's box.
const SIDE: usize = 8;
/// Points the pilot reads in each cell.
const PILOT: usize = 2;
/// Share of the cells' probability spread evenly over them.
const UNIFORM_SHARE: f32 = 0.1;
/// Objects that emit photons at most (the pilot's cost grows with them; the rest of an
/// instanced emitting volume's copies stay lit by camera paths alone).
const MAX_OBJECTS: usize = 256;

/// One object whose medium emits.
pub struct VolumeEmitter {
    material: u32,
    /// The object as `accel::Hit` names it: a mesh, or a prototype placed by `instance`.
    mesh: u32,
    instance: u32,
    bounds: Bounds,
    cells: Distribution1D,
    /// The pilot's estimate of the object's flux (for choosing among sources).
    flux: Vec3,
}

/// The objects of `ctx`'s scene whose media emit, each with its pilot. The world's volume
/// emits no photons (its light reaches surfaces through the camera paths' gather rays).
pub fn volume_emitters(ctx: &Context) -> Vec<VolumeEmitter> {
    let scene = ctx.scene;
    let emits = |material: u32| {
        let m = scene.materials.get(material as usize);
        m.and_then(|m| m.volume.as_ref()).is_some_and(|v| v.emits)
    };
    let mut objects = Vec::new();
    for (k, mesh) in scene.meshes.iter().enumerate() {
        if emits(mesh.material) {
            objects.push((mesh.material, k as u32, u32::MAX, mesh.bounds()));
        }
    }
    for (i, instance) in scene.instances.iter().enumerate() {
        let prototype = &scene.prototypes[instance.prototype as usize];
        if emits(prototype.material) {
            let b = instance_bounds(instance, prototype.bounds());
            objects.push((prototype.material, instance.prototype, i as u32, b));
        }
    }
    objects
        .into_iter()
        .take(MAX_OBJECTS)
        .filter(|(.., b)| !b.is_empty())
        .filter_map(|(material, mesh, instance, bounds)| {
            VolumeEmitter::new(ctx, material, mesh, instance, bounds)
        })
        .collect()
}

impl VolumeEmitter {
    fn new(
        ctx: &Context,
        material: u32,
        mesh: u32,
        instance: u32,
        bounds: Bounds,
    ) -> Option<VolumeEmitter> {
        let mut emitter = VolumeEmitter {
            material,
            mesh,
            instance,
            bounds,
            cells: Distribution1D::new(&[]),
            flux: Vec3::ZERO,
        };
        let mut rng = Rng::for_item(0x5eed_f1a3, u64::from(mesh), u64::from(instance));
        let mut seen = vec![0.0f32; SIDE * SIDE * SIDE];
        let mut flux = Vec3::ZERO;
        for (c, weight) in seen.iter_mut().enumerate() {
            for _ in 0..PILOT {
                let p = emitter.point_in(c, rng.uniform2(), rng.uniform());
                let (e, _) = emitter.emission_at(ctx, p, FRAME_TIME);
                flux += e;
                *weight += luminance(e);
            }
        }
        let cell_volume = emitter.cell_size().element_product();
        emitter.flux = flux * (4.0 * PI * cell_volume / PILOT as f32);
        let total: f32 = seen.iter().sum();
        if !(total > 0.0) || !total.is_finite() {
            return None;
        }
        let even = UNIFORM_SHARE / seen.len() as f32;
        let mixed: Vec<f32> = seen
            .iter()
            .map(|w| (1.0 - UNIFORM_SHARE) * w / total + even)
            .collect();
        emitter.cells = Distribution1D::new(&mixed);
        Some(emitter)
    }

    /// The pilot's estimate of the flux the object emits (RGB).
    pub fn flux(&self) -> Vec3 {
        self.flux
    }

    /// One photon: a point drawn by the cells (`u_cell` picks the cell, `u_point` and `u_depth`
    /// place the point in it), a direction by `u_direction`, at moment `time`; its power
    /// 4π ε(x)/pdf(x), and the media at x. `None` where the point is outside the object or
    /// emits nothing.
    pub fn emit(
        &self,
        ctx: &Context,
        (u_cell, u_point, u_depth): (f32, Vec2, f32),
        u_direction: Vec2,
        time: f32,
    ) -> Option<(Ray, Vec3, MediumStack)> {
        let (cell, pmf, _) = self.cells.sample_remapped(u_cell)?;
        let p = self.point_in(cell, u_point, u_depth);
        let (e, media) = self.emission_at(ctx, p, time);
        if e == Vec3::ZERO {
            return None;
        }
        let density = pmf / self.cell_size().element_product();
        let ray = Ray {
            origin: p,
            direction: square_to_uniform_sphere(u_direction),
            t_max: f32::INFINITY,
            time,
        };
        Some((ray, e * (4.0 * PI / density), media))
    }

    fn cell_size(&self) -> Vec3 {
        (self.bounds.max - self.bounds.min) / SIDE as f32
    }

    /// The point of cell `cell` at the unit-cube position (`u`, `w`).
    fn point_in(&self, cell: usize, u: Vec2, w: f32) -> Vec3 {
        let index = Vec3::new(
            (cell % SIDE) as f32,
            ((cell / SIDE) % SIDE) as f32,
            (cell / (SIDE * SIDE)) as f32,
        );
        self.bounds.min + (index + Vec3::new(u.x, u.y, w)) * self.cell_size()
    }

    /// The object's emission at `p` (zero outside it), and the media there.
    fn emission_at(&self, ctx: &Context, p: Vec3, time: f32) -> (Vec3, MediumStack) {
        let scene = ctx.scene;
        let media = MediumStack::at(ctx, p, time);
        let volume = scene.materials[self.material as usize].volume.as_ref();
        let Some(volume) = volume.filter(|_| media.holds(self.material, self.mesh, self.instance))
        else {
            return (Vec3::ZERO, media);
        };
        let e = volume
            .at(scene, Some((self.mesh, self.instance)), p, time)
            .emission;
        match e.is_finite() {
            true => (e.max(Vec3::ZERO), media),
            false => (Vec3::ZERO, media),
        }
    }
}
