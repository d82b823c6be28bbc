//! The pixels whose filter window can see an emitter directly, so that emission rays
//! (`render::see_emission`) are traced only there. Seen directly means met going straight on
//! from the camera: through transparent surfaces and media, and by smooth mirrors and glass.
//!
//! Elsewhere every camera ray meets no emission before it first scatters, so the emission rays
//! would all find zero, as the sample's own ray did: skipping them leaves every pixel's value
//! exactly as it was. The bound is conservative: the image box of each emitting triangle (of a
//! still mesh; the box of a deforming mesh or a placed instance's corners), of each mesh that
//! may be a smooth mirror or glass (which may show any emitter), and of each lamp the camera
//! sees (the cube around its sphere), widened by the pixel filter's radius and a pixel. The whole image
//! counts where no such bound exists: a background or sun disc the camera can see, a lens, a
//! moving camera, a panorama, an emitter reaching behind the camera. (Screen-space bounds of
//! geometry as in a rasteriser's bounding-box setup; nothing here is from a paper.)

use crate::bsdf::may_be_smooth;
use crate::camera::CameraRays;
use crate::integrator::Context;
use crate::light::{lamp_of, LightSource};
use crate::math::{Vec2, Vec3};
use crate::scene::Mesh;

/// Which pixels of a `width` × `height` image may see an emitter directly.
pub struct EmitterPixels {
    width: u32,
    /// Row-major flags; `None`: every pixel may.
    may_see: Option<Vec<bool>>,
}

impl EmitterPixels {
    /// The pixels of `camera`'s image where the pixel filter of radius `filter_radius` (pixels)
    /// may gather emission seen directly; with `mirrors`, also by way of meshes that may be
    /// smooth mirrors or glass (else only emitters seen themselves).
    pub fn new(
        ctx: &Context,
        camera: &CameraRays,
        filter_radius: f32,
        (width, height): (u32, u32),
        mirrors: bool,
    ) -> Self {
        let every = EmitterPixels {
            width,
            may_see: None,
        };
        if !ctx.transparent_background && background_seen(ctx) {
            return every;
        }
        let mut boxes = Boxes::new(width, height, filter_radius);
        let scene = ctx.scene;
        let emits = |m: &Mesh| {
            let material = &scene.materials[m.material as usize];
            material.is_emissive() || (mirrors && may_be_smooth(material))
        };
        for mesh in scene.meshes.iter().filter(|m| m.camera_visible && emits(m)) {
            let fits = if mesh.deformation.is_empty() {
                mesh.indices
                    .iter()
                    .all(|t| boxes.add(camera, t.iter().map(|&i| mesh.positions[i as usize])))
            } else {
                boxes.add(camera, corners(mesh.bounds().min, mesh.bounds().max))
            };
            if !fits {
                return every;
            }
        }
        for instance in scene.instances.iter().filter(|i| i.camera_visible) {
            let prototype = &scene.prototypes[instance.prototype as usize];
            if !emits(prototype) {
                continue;
            }
            let bounds = prototype.bounds();
            let poses = std::iter::once(&instance.to_world).chain(&instance.motion);
            let points = poses
                .flat_map(|pose| corners(bounds.min, bounds.max).map(|c| pose.transform_point3(c)));
            if !boxes.add(camera, points) {
                return every;
            }
        }
        for source in &ctx.lights.sources {
            let Some((position, radius, _)) =
                lamp_of(source).filter(|&(_, radius, lamp)| radius > 0.0 && lamp.camera)
            else {
                continue;
            };
            let r = Vec3::splat(radius);
            if !boxes.add(camera, corners(position - r, position + r)) {
                return every;
            }
        }
        EmitterPixels {
            width,
            may_see: Some(boxes.flags()),
        }
    }

    /// Pixel (x, y) may see an emitter directly.
    pub fn may_see(&self, x: u32, y: u32) -> bool {
        self.may_see
            .as_ref()
            .is_none_or(|f| f[y as usize * self.width as usize + x as usize])
    }

    /// The share of the image's pixels that may see an emitter (1 when all may).
    pub fn share(&self) -> f64 {
        match &self.may_see {
            None => 1.0,
            Some(f) => f.iter().filter(|&&b| b).count() as f64 / f.len().max(1) as f64,
        }
    }
}

/// A camera ray that leaves the scene may see light: the world's (or the camera's own
/// background), or a sun's disc.
fn background_seen(ctx: &Context) -> bool {
    let world = &ctx.scene.world;
    world.emits()
        || world.camera_background.is_some()
        || ctx
            .lights
            .sources
            .iter()
            .any(|s| matches!(s, LightSource::Sun { cos_max, .. } if *cos_max < 1.0))
}

/// The eight corners of the box `min`..`max`.
fn corners(min: Vec3, max: Vec3) -> impl Iterator<Item = Vec3> {
    (0..8).map(move |k| {
        Vec3::new(
            if k & 1 == 0 { min.x } else { max.x },
            if k & 2 == 0 { min.y } else { max.y },
            if k & 4 == 0 { min.z } else { max.z },
        )
    })
}

/// Pixel boxes summed on a 2-D difference grid (each box costs four updates, whatever its size).
struct Boxes {
    width: u32,
    height: u32,
    /// How far a pixel's samples reach from its centre, with a pixel's margin for rounding.
    reach: f32,
    /// (width + 1) × (height + 1) corner increments.
    difference: Vec<i32>,
}

impl Boxes {
    fn new(width: u32, height: u32, filter_radius: f32) -> Self {
        Boxes {
            width,
            height,
            reach: filter_radius + 1.0,
            difference: vec![0; (width as usize + 1) * (height as usize + 1)],
        }
    }

    /// Mark the pixels whose samples may fall where the camera sees the convex hull of
    /// `points`; false when some point has no film position (nothing bounds the hull).
    fn add(&mut self, camera: &CameraRays, points: impl Iterator<Item = Vec3>) -> bool {
        let (mut lo, mut hi) = (Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY));
        for p in points {
            let Some(film) = camera.film_position(p) else {
                return false;
            };
            lo = lo.min(film);
            hi = hi.max(film);
        }
        if lo.x > hi.x {
            return true; // no points
        }
        // Pixel x's samples lie within x + 0.5 ± radius.
        let first = |v: f32| (v - 0.5 - self.reach).floor().max(0.0);
        let last = |v: f32, size: u32| (v - 0.5 + self.reach).ceil().min(size as f32 - 1.0);
        let (x0, x1) = (first(lo.x), last(hi.x, self.width));
        let (y0, y1) = (first(lo.y), last(hi.y, self.height));
        if x0 > x1 || y0 > y1 {
            return true; // outside the image
        }
        let (x0, x1, y0, y1) = (x0 as usize, x1 as usize + 1, y0 as usize, y1 as usize + 1);
        let stride = self.width as usize + 1;
        self.difference[y0 * stride + x0] += 1;
        self.difference[y0 * stride + x1] -= 1;
        self.difference[y1 * stride + x0] -= 1;
        self.difference[y1 * stride + x1] += 1;
        true
    }

    /// The marked pixels, row-major.
    fn flags(mut self) -> Vec<bool> {
        let (w, h) = (self.width as usize, self.height as usize);
        let stride = w + 1;
        for y in 0..=h {
            for x in 0..=w {
                let left = if x > 0 {
                    self.difference[y * stride + x - 1]
                } else {
                    0
                };
                let up = if y > 0 {
                    self.difference[(y - 1) * stride + x]
                } else {
                    0
                };
                let diagonal = if x > 0 && y > 0 {
                    self.difference[(y - 1) * stride + x - 1]
                } else {
                    0
                };
                self.difference[y * stride + x] += left + up - diagonal;
            }
        }
        (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .map(|(x, y)| self.difference[y * stride + x] > 0)
            .collect()
    }
}
