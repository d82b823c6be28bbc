//! Direct light, written once: one light sample with multiple importance sampling (Veach &
//! Guibas 1995, the power heuristic), and the MIS weight of emission that a BSDF-sampled ray
//! meets instead. Every integrator's next-event estimation goes through `sample_direct`.
//!
//! Shadow rays pass surfaces whose node tree gives a Transparent BSDF for them (Cycles'
//! transparent shadows: the surface's shader is evaluated for the shadow ray, which Light
//! Path's Is Shadow Ray reads, and its transparent weight tints what passes).
//!
//! Blender's light linking: a light sample from an object that the chosen light does not
//! light adds nothing, and emission met by a ray counts only if its emitter lights the object
//! the ray left (`Previous::lit_by`); shadow linking: the shadow rays of a light with a blocker
//! set pass every object outside it.

use super::media::MediumStack;
use super::Context;
use crate::accel::{Hit, Ray, Visibility};
use crate::interaction::{spawn_to, LightPoint, SurfaceHit, View};
use crate::light::{hit_links, LightSample, Receiver};
use crate::material::eval_surface;
use crate::math::Vec3;
use crate::medium::transmittance;
use crate::rng::{hash_combine, Rng};
use crate::sampling::power_heuristic;
use crate::shader::RayPath;

/// Most surfaces a shadow ray passes through (Cycles' default transparent bounces are 8).
const MAX_TRANSPARENT_SHADOW_HITS: u32 = 64;

/// One light sample from `at`, chosen by the lights' power: `beta` × f × Lᵢ × w / pdf, where
/// `scattering(wi)` gives f (with the cosine) and the BSDF density of the direction towards the
/// light, and w is the power heuristic against that density when `mis` is set (1 for delta
/// lights). Counts the shadow ray in `rays`; zero when the light is blocked or not reached.
/// `horizon`: the geometric normal of an opaque surface, below which `scattering` is zero
/// (`light::Receiver`).
#[allow(clippy::too_many_arguments)]
pub fn sample_direct(
    ctx: &Context,
    at: &SurfaceHit,
    horizon: Option<Vec3>,
    media: &MediumStack,
    beta: Vec3,
    mis: bool,
    rng: &mut Rng,
    rays: &mut u32,
    scattering: impl FnOnce(Vec3) -> (Vec3, f32),
) -> Vec3 {
    let path = RayPath::default();
    let at = Vertex::Surface(at);
    sample_direct_from(
        ctx, at, horizon, path, media, beta, mis, rng, rays, scattering,
    )
}

/// `sample_direct` from a vertex of camera path `path` (what node trees of the emitter and of
/// the surfaces the shadow ray passes read), in the media `media`.
#[allow(clippy::too_many_arguments)]
pub fn sample_direct_from(
    ctx: &Context,
    at: Vertex,
    horizon: Option<Vec3>,
    path: RayPath,
    media: &MediumStack,
    beta: Vec3,
    mis: bool,
    rng: &mut Rng,
    rays: &mut u32,
    scattering: impl FnOnce(Vec3) -> (Vec3, f32),
) -> Vec3 {
    let (choice, point) = rng.uniform3();
    let lit_by = match at {
        Vertex::Surface(sh) if ctx.lights.linked() => hit_links(ctx.scene, &sh.hit).lit_by,
        _ => u64::MAX,
    };
    let from = Receiver {
        p: at.p(),
        horizon,
        lit_by,
    };
    let Some(ls) = ctx
        .lights
        .sample(ctx.scene, from, path, at.time(), mis, choice, point)
    else {
        return Vec3::ZERO;
    };
    if ls.li == Vec3::ZERO {
        return Vec3::ZERO;
    }
    let (f, bsdf_pdf) = scattering(ls.wi);
    if f == Vec3::ZERO {
        return Vec3::ZERO;
    }
    let through = shadow_transmittance(ctx, at, &ls, path, media, rng, rays);
    if through == Vec3::ZERO {
        return Vec3::ZERO;
    }
    let w = if ls.delta || !mis {
        1.0
    } else {
        power_heuristic(ls.pdf, bsdf_pdf)
    };
    beta * f * ls.li * through * (w / ls.pdf)
}

/// Where a light sample is drawn from: a surface point, or a point inside a medium.
#[derive(Clone, Copy)]
pub enum Vertex<'a> {
    Surface(&'a SurfaceHit),
    /// A scattering point in a medium at moment `time` of the shutter.
    Medium {
        p: Vec3,
        time: f32,
    },
}

impl Vertex<'_> {
    fn p(&self) -> Vec3 {
        match self {
            Vertex::Surface(sh) => sh.p,
            Vertex::Medium { p, .. } => *p,
        }
    }

    fn time(&self) -> f32 {
        match self {
            Vertex::Surface(sh) => sh.time,
            Vertex::Medium { time, .. } => *time,
        }
    }

    /// The shadow ray from here to `target` (`SurfaceHit::spawn_to`; a medium point needs no
    /// offset).
    fn spawn_to(&self, target: &LightPoint) -> Ray {
        match self {
            Vertex::Surface(sh) => sh.spawn_to(target),
            Vertex::Medium { p, time } => Ray {
                time: *time,
                ..spawn_to(*p, Vec3::ZERO, Vec3::ZERO, target)
            },
        }
    }
}

/// What reaches `at` from the light sample `light` (its target, and its blocker set: only
/// objects in it block) along a shadow ray of path `path` leaving in `media`: one
/// when nothing is in between, zero when something opaque is, and otherwise the product of the
/// transparent weights of the surfaces passed (each evaluated for the shadow ray, its Mix
/// Shader picks drawn from a hash of the ray, so the product is right on average) and of the
/// media's transmittance along the way (`medium::transmittance`; the world's volume stops the
/// light of distant lights entirely). Counts its rays.
pub fn shadow_transmittance(
    ctx: &Context,
    at: Vertex,
    light: &LightSample,
    path: RayPath,
    media: &MediumStack,
    rng: &mut Rng,
    rays: &mut u32,
) -> Vec3 {
    *rays += 1;
    let target = &light.target;
    let mut ray = at.spawn_to(target);
    let scene = ctx.scene;
    let mut media = *media;
    if target.distant && scene.world.volume.is_some() {
        return Vec3::ZERO;
    }
    // The media's transmittance along `ray` up to parameter `t`.
    let through_media = |media: &MediumStack, ray: &Ray, t: f32, rng: &mut Rng| {
        if media.is_vacuum(scene) {
            return Vec3::ONE;
        }
        let length = ray.direction.length();
        let dir = ray.direction / length;
        transmittance(&media.media(ctx), ray.origin, dir, t * length, rng)
    };
    if !ctx.lights.transparent_shadows && light.blockers == 0 {
        return if ctx.accel.unoccluded(scene, &ray) {
            through_media(&media, &ray, ray.t_max, rng)
        } else {
            Vec3::ZERO
        };
    }
    let mut through = Vec3::ONE;
    for passed in 0..MAX_TRANSPARENT_SHADOW_HITS {
        let Some(hit) = ctx.accel.intersect(scene, &ray, Visibility::Shadow) else {
            return through * through_media(&media, &ray, ray.t_max, rng);
        };
        through *= through_media(&media, &ray, hit.t, rng);
        if through == Vec3::ZERO {
            return through;
        }
        let sh = SurfaceHit::new(scene, &ray, &hit);
        if light.blockers != 0 {
            let links = hit_links(scene, &hit);
            if links.blocks >> light.blockers & 1 == 0 {
                // Not in the light's blocker set: the shadow ray passes it.
                media = media.crossed(scene, &hit, sh.material, ray.direction.dot(sh.ng) < 0.0);
                *rays += 1;
                ray = sh.spawn_to(target);
                continue;
            }
            if !ctx.lights.transparent_shadows {
                return Vec3::ZERO;
            }
        }
        through *= pass_through_weight(ctx, &ray, &hit, &sh, path.shadow(), passed);
        if through == Vec3::ZERO {
            return through;
        }
        media = media.crossed(scene, &hit, sh.material, ray.direction.dot(sh.ng) < 0.0);
        *rays += 1;
        ray = sh.spawn_to(target);
    }
    Vec3::ZERO
}

/// The weight with which a ray of kind `path` goes straight on through the surface `sh` it
/// met (`hit`, along `ray`): the colour of the transparent closures its node tree gives for
/// that ray (a Mix Shader's pick drawn from a hash of the ray and of `passed`, the surfaces
/// passed before, so the weight is right on average); zero for a surface that lets nothing
/// through.
pub fn pass_through_weight(
    ctx: &Context,
    ray: &Ray,
    hit: &Hit,
    sh: &SurfaceHit,
    path: RayPath,
    passed: u32,
) -> Vec3 {
    let scene = ctx.scene;
    let material = &scene.materials[sh.material as usize];
    if !material
        .nodes
        .as_ref()
        .is_some_and(|program| program.shadow_transparent)
    {
        return Vec3::ZERO;
    }
    let wo = -ray.direction.normalize();
    let length = hit.t * ray.direction.length();
    let u = hash_combine(&[
        ray.origin.x.to_bits() as u64 | ((ray.origin.y.to_bits() as u64) << 32),
        ray.origin.z.to_bits() as u64 | ((hit.t.to_bits() as u64) << 32),
        hit.triangle as u64 | ((passed as u64) << 32),
    ]);
    let u = (u >> 40) as f32 * (1.0 / 16_777_216.0);
    let view = View::new(sh, wo, path, length);
    let surface = eval_surface(scene, sh, view, u, None);
    if !surface.transparent {
        return Vec3::ZERO;
    }
    surface.base_color.clamp(Vec3::ZERO, Vec3::ONE)
}

/// The scattering vertex a ray left, for the MIS weight of the emission that ray meets.
#[derive(Clone, Copy, Debug)]
pub struct Previous {
    pub p: Vec3,
    /// The horizon the light sample there was drawn below (`light::Receiver`).
    pub horizon: Option<Vec3>,
    /// The BSDF density (solid angle) of the ray's direction.
    pub pdf: f32,
    /// The ray left through a delta lobe, or light sampling did not run there: emission it
    /// meets counts in full.
    pub delta: bool,
    /// The receiver sets of the object the ray left (`Receiver::lit_by`).
    pub lit_by: u64,
}

impl Previous {
    /// Where the light sample weighed against the ray was drawn from.
    pub fn receiver(&self) -> Receiver {
        Receiver {
            p: self.p,
            horizon: self.horizon,
            lit_by: self.lit_by,
        }
    }

    /// Weight of emission the ray meets, which light sampling would have drawn with density
    /// `light_pdf` (solid angle).
    pub fn weight(&self, light_pdf: f32) -> f32 {
        if self.delta {
            1.0
        } else {
            power_heuristic(self.pdf, light_pdf)
        }
    }

    /// Weight of the emission of the surface `hit` the ray met (0 when light linking keeps
    /// its emitter from lighting the object the ray left).
    pub fn weight_at(&self, ctx: &Context, hit: &SurfaceHit) -> f32 {
        if !ctx
            .lights
            .emission_counts(ctx.scene, self.receiver(), &hit.hit)
        {
            return 0.0;
        }
        if self.delta {
            1.0
        } else {
            power_heuristic(
                self.pdf,
                ctx.lights.triangle_pdf(ctx.scene, self.receiver(), hit),
            )
        }
    }
}
