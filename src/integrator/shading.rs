//! The shading point: a surface hit turned into what every integrator shades with — the
//! material evaluated there, its BSDF seen from the viewer, the shading frame and geometric
//! normal on the right side of the surface, and the medium a ray leaves into.
//!
//! Sides: opaque surfaces scatter on the viewer's side, so their frame and `ng` are turned to
//! face the viewer (a single-sided plane is lit and shaded from whichever side is looked at);
//! transmissive surfaces keep the winding side, so the BSDF knows inside from outside. Media:
//! inside a transmissive object a ray is attenuated by Beer–Lambert absorption.
//!
//! Blender's Light Paths › Caustics settings change the BSDF by the path that reaches the point
//! (`LightPathFilter`, `Shading::reached_by`), as Cycles builds a point's closures for its path:
//! Reflective and Refractive Caustics off leave out glossy reflection or transmission on a
//! surface met straight after a diffuse bounce; Filter Glossy widens glossy lobes by the
//! smallest density of the path's bounces so far (`PathHistory`).

use super::classify::{diffuse_reflectance, is_lambertian, lambertian_reflectance};
use super::direct::{sample_direct_from, Vertex};
use super::media::MediumStack;
use super::Context;
use crate::accel::{Hit, Ray};
use crate::bsdf::{Bsdf, BsdfSample, PathFilter, Scattering, ViewedBsdf};
use crate::interaction::{SurfaceHit, View};
use crate::irradiance_cache::IrradianceCache;
use crate::material::{eval_surface, Rays, SurfaceMaterial};
use crate::math::{Frame, Vec2, Vec3};
use crate::rng::{hash_combine, Rng};
use crate::scene::Scene;
use crate::shader::RayPath;
use std::f32::consts::PI;

/// A surface hit prepared for shading (module header for the sides).
#[derive(Clone, Copy)]
pub struct Shading {
    pub sh: SurfaceHit,
    pub surface: SurfaceMaterial,
    pub frame: Frame,
    pub ng: Vec3,
    pub opaque: bool,
    /// The BSDF seen from `wo`.
    pub bsdf: ViewedBsdf,
    /// The ray that met the point (what its node tree, and the light samples and shadow rays
    /// from it, read of Light Path).
    pub path: RayPath,
    /// Unit direction towards the viewer (or where the photon came from).
    pub wo: Vec3,
    pub wo_local: Vec3,
    /// The media the viewer is in (where light samples' shadow rays start).
    pub media: MediumStack,
    /// What the path that reached the point did before (`reached_by`).
    pub history: PathHistory,
}

/// What Blender's Light Paths settings read of the path that reaches a shading point (Cycles'
/// "diffuse ray" flag and `min_ray_pdf`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathHistory {
    /// The path's last bounce, transparent passes aside, was a diffuse one on a surface (a
    /// scattering in a medium is not).
    pub after_diffuse: bool,
    /// The smallest solid-angle density of the path's bounces so far, delta ones left out
    /// (infinite: none yet).
    pub min_pdf: f32,
}

impl Default for PathHistory {
    /// A camera ray's.
    fn default() -> Self {
        PathHistory {
            after_diffuse: false,
            min_pdf: f32::INFINITY,
        }
    }
}

impl PathHistory {
    /// A diffuse gather ray's, of unknown density: the largest a cosine-distributed ray has.
    pub const GATHER: PathHistory = PathHistory {
        after_diffuse: true,
        min_pdf: std::f32::consts::FRAC_1_PI,
    };

    /// The path after the BSDF sample `bs` (a transparent pass changes nothing).
    pub fn after(self, bs: &BsdfSample) -> PathHistory {
        if bs.scattering == Scattering::Transparent {
            return self;
        }
        PathHistory {
            after_diffuse: bs.scattering == Scattering::Diffuse,
            min_pdf: match bs.delta {
                true => self.min_pdf,
                false => self.min_pdf.min(bs.pdf),
            },
        }
    }

    /// The path after a scattering in a medium sampled with density `pdf`.
    pub fn after_medium(self, pdf: f32) -> PathHistory {
        PathHistory {
            after_diffuse: false,
            min_pdf: self.min_pdf.min(pdf),
        }
    }
}

/// Blender's Light Paths › Caustics settings (`SceneRenderSettings`) as they change the BSDF a
/// path meets (`crate::bsdf::PathFilter`).
#[derive(Clone, Copy, Debug)]
pub struct LightPathFilter {
    reflective_off: bool,
    refractive_off: bool,
    /// Filter Glossy (0: off).
    filter_glossy: f32,
}

impl LightPathFilter {
    pub fn of(scene: &Scene) -> LightPathFilter {
        let settings = &scene.render_settings;
        LightPathFilter {
            reflective_off: settings.reflective_caustics_off,
            refractive_off: settings.refractive_caustics_off,
            filter_glossy: settings.filter_glossy,
        }
    }

    /// The lobes the caustics switches drop on a surface met straight after a diffuse bounce.
    pub fn after_diffuse(&self) -> PathFilter {
        PathFilter {
            drop_reflection: self.reflective_off,
            drop_refraction: self.refractive_off,
            min_alpha: 0.0,
        }
    }

    /// What a path of `history` leaves of the BSDF it meets: with the caustics switched off,
    /// straight after a diffuse bounce, no glossy reflection or transmission; with Filter
    /// Glossy F and the path's smallest density p, where p / F < 1, every GGX lobe at least as
    /// rough as α = ½ √(1 − p / F) (Cycles' blur, which compares that value to α).
    pub fn at(&self, history: PathHistory) -> PathFilter {
        let blur = history.min_pdf / self.filter_glossy;
        PathFilter {
            drop_reflection: self.reflective_off && history.after_diffuse,
            drop_refraction: self.refractive_off && history.after_diffuse,
            min_alpha: if self.filter_glossy > 0.0 && blur < 1.0 {
                0.5 * (1.0 - blur).sqrt()
            } else {
                0.0
            },
        }
    }
}

/// Beer–Lambert transmittance along `ray` up to `hit` through a medium of absorption
/// coefficient `absorption` (exactly one outside any medium).
pub fn transmittance(absorption: Vec3, hit: &Hit, ray: &Ray) -> Vec3 {
    if absorption == Vec3::ZERO {
        Vec3::ONE
    } else {
        (-absorption * (hit.t * ray.direction.length())).exp()
    }
}

impl Shading {
    /// `camera`: `ray` is a camera ray (node trees' Light Path reads it); any other ray is
    /// one of no kind after no bounce (photons, gathers).
    pub fn new(ctx: &Context, ray: &Ray, hit: &Hit, camera: bool) -> Shading {
        let path = if camera {
            RayPath::camera()
        } else {
            RayPath::default()
        };
        Shading::on_path(ctx, ray, hit, path)
    }

    /// The hit of a ray of camera path `path` (a camera ray starts on the near clip plane, so
    /// its Ray Length counts from there, as Cycles').
    pub fn on_path(ctx: &Context, ray: &Ray, hit: &Hit, path: RayPath) -> Shading {
        let sh = SurfaceHit::new(ctx.scene, ray, hit);
        let wo = -ray.direction.normalize();
        let length = hit.t * ray.direction.length();
        let material = &ctx.scene.materials[sh.material as usize];
        let surface = if material.nodes.is_some() {
            // The closure pick of Mix and Add Shader nodes: a hash of the ray and the hit, so
            // it is deterministic and fresh for every path.
            let h = hash_combine(&[
                ray.origin.x.to_bits() as u64 | ((ray.origin.y.to_bits() as u64) << 32),
                ray.origin.z.to_bits() as u64 | ((ray.direction.x.to_bits() as u64) << 32),
                ray.direction.y.to_bits() as u64 | ((ray.direction.z.to_bits() as u64) << 32),
                hit.triangle as u64 | ((hit.t.to_bits() as u64) << 32),
            ]);
            let u = (h >> 40) as f32 * (1.0 / 16_777_216.0);
            let rays = Rays {
                accel: ctx.accel,
                seed: h,
            };
            eval_surface(
                ctx.scene,
                &sh,
                View::new(&sh, wo, path, length),
                u,
                Some(rays),
            )
        } else {
            eval_surface(ctx.scene, &sh, View::new(&sh, wo, path, length), 0.0, None)
        };
        // A node tree's normal (Bump), on the side of the surface's own.
        let toward = |n: Vec3| if n.dot(sh.frame.n) < 0.0 { -n } else { n };
        let mut frame = match (surface.normal, surface.tangent) {
            // Anisotropic lobes and hair fibres run along the material's tangent.
            (n, Some(t)) if surface.aspect < 1.0 || surface.hair.is_some() => {
                Frame::from_normal_tangent(n.map_or(sh.frame.n, toward), t)
            }
            (Some(n), _) => Frame::from_normal(toward(n)),
            (None, _) => sh.frame,
        };
        let opaque = surface.is_opaque();
        let mut ng = sh.ng;
        if opaque && wo.dot(ng) < 0.0 {
            frame.n = -frame.n;
            frame.t = -frame.t;
            ng = -ng;
        }
        let wo_local = frame.to_local(wo);
        let mut bsdf = Bsdf::new(&surface);
        if let Some(c) = surface.coat_normal.filter(|_| surface.coat_weight > 0.0) {
            let c = if c.dot(frame.n) < 0.0 { -c } else { c };
            bsdf = bsdf.with_coat_normal(frame.to_local(c));
        }
        let bsdf = bsdf.viewed_from(wo_local);
        let mut surface = surface;
        if surface.coat_weight > 0.0 || surface.sheen_weight > 0.0 {
            // Cycles' Principled emission lies below the sheen and the coat.
            surface.emission *= bsdf.layer_transmittance();
        }
        Shading {
            sh,
            frame,
            ng,
            opaque,
            bsdf,
            path,
            wo,
            wo_local,
            surface,
            media: MediumStack::default(),
            history: PathHistory::default(),
        }
    }

    /// This point reached by a path of `history`: its BSDF as Blender's Light Paths settings
    /// leave it for that path (`LightPathFilter`).
    pub fn reached_by(&mut self, scene: &Scene, history: PathHistory) {
        self.history = history;
        let filter = LightPathFilter::of(scene).at(history);
        if !filter.is_none() {
            self.bsdf = self.bsdf.filtered(filter);
        }
    }

    /// Absorption coefficient of the medium a ray leaving along `wi` by `bs` travels through,
    /// `current` being the one it arrived in.
    pub fn absorption_after(&self, bs: &BsdfSample, wi: Vec3, current: Vec3) -> Vec3 {
        if !bs.transmitted {
            current
        } else if wi.dot(self.sh.ng) < 0.0 {
            self.surface.absorption
        } else {
            Vec3::ZERO
        }
    }

    /// Index of refraction of the medium a ray leaving along `wi` by `bs` travels through,
    /// `current` being the one it arrived in: the glass's when it refracted into the object, 1
    /// when it refracted out of it; unchanged by reflections and by crossings that do not bend
    /// light (a Translucent or Transparent lobe), as `absorption_after` follows the medium.
    pub fn ior_after(&self, bs: &BsdfSample, wi: Vec3, current: f32) -> f32 {
        let refracted = bs.transmitted
            && matches!(bs.scattering, Scattering::Glossy | Scattering::Singular)
            && self.bsdf.medium_ior() != 1.0;
        if !refracted {
            current
        } else if wi.dot(self.sh.ng) < 0.0 {
            self.bsdf.medium_ior()
        } else {
            1.0
        }
    }

    /// Sample the BSDF and turn the sample into a world direction; `None` when the path ends
    /// (no sample, or an opaque surface's sample below its geometric surface).
    pub fn sample(&self, u_lobe: f32, u: Vec2) -> Option<(BsdfSample, Vec3)> {
        let bs = self.bsdf.sample(u_lobe, u)?;
        let wi = self.frame.to_world(bs.wi).normalize();
        if self.opaque && wi.dot(self.ng) <= 0.0 {
            return None;
        }
        Some((bs, wi))
    }

    /// One light sample through this point's BSDF, times `beta`, MIS-weighted against BSDF
    /// sampling when `mis` is set (`direct::sample_direct`). An opaque surface is never lit
    /// from behind its geometry, whatever the shading normal says (no light leaking through
    /// interpolated normals), so the light choice leaves out the lights wholly behind it.
    pub fn light_sample(
        &self,
        ctx: &Context,
        beta: Vec3,
        mis: bool,
        rng: &mut Rng,
        rays: &mut u32,
    ) -> Vec3 {
        let horizon = self.horizon();
        sample_direct_from(
            ctx,
            Vertex::Surface(&self.sh),
            horizon,
            self.path,
            &self.media,
            beta,
            mis,
            rng,
            rays,
            |wi| {
                if self.opaque && wi.dot(self.ng) <= 0.0 {
                    (Vec3::ZERO, 0.0)
                } else {
                    self.bsdf.eval_and_pdf(self.frame.to_local(wi))
                }
            },
        )
    }

    /// The normal below which this point scatters no light (`light::Receiver`): an opaque
    /// surface's geometric normal, turned to the viewer; none for a transmissive one.
    pub fn horizon(&self) -> Option<Vec3> {
        self.opaque.then_some(self.ng)
    }

    /// The irradiance cache's answer for this point's diffuse lobe; `None` when it has none or
    /// no record covers the point.
    pub fn cached_diffuse(&self, cache: &IrradianceCache) -> Option<CachedDiffuse> {
        let rho = diffuse_reflectance(&self.bsdf, self.opaque)?;
        let e = cache.lookup(self.sh.p, self.frame.n)?;
        Some(CachedDiffuse {
            rho,
            radiance: rho * e * (1.0 / PI),
            lambertian: lambertian_reflectance(&self.bsdf, self.opaque).is_some(),
        })
    }

    /// True on an opaque surface that scatters as a Lambertian one.
    pub fn is_opaque_lambertian(&self) -> bool {
        self.opaque && is_lambertian(&self.bsdf)
    }
}

/// A BSDF value or sample weight without its diffuse lobe's part: `weight` is f·|cos θ|/`pdf`
/// for direction cosine `cos`, the diffuse lobe's ρ_d/π·|cos θ|/`pdf` (`pdf` 1 for f·|cos θ|
/// itself).
pub fn without_diffuse(weight: Vec3, rho: Vec3, cos: f32, pdf: f32) -> Vec3 {
    let diffuse = rho * (cos.abs() / (PI * pdf));
    (weight - diffuse).max(Vec3::ZERO)
}

/// The irradiance cache's answer for the diffuse lobe at a shading point.
#[derive(Clone, Copy, Debug)]
pub struct CachedDiffuse {
    /// ρ_d of the diffuse lobe (as seen from the viewer).
    pub rho: Vec3,
    /// Its reflected indirect radiance ρ_d/π · E.
    pub radiance: Vec3,
    /// The BSDF is that lobe alone.
    pub lambertian: bool,
}

impl CachedDiffuse {
    /// The weight f·cos/pdf of a BSDF sample without the diffuse lobe's part ρ_d/π·cos/pdf: a
    /// gather ray's estimate counted for the other lobes only.
    pub fn non_diffuse_weight(&self, bs: &BsdfSample) -> Vec3 {
        without_diffuse(bs.weight, self.rho, bs.wi.z, bs.pdf)
    }
}
