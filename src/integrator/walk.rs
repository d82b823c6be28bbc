//! The camera path walk, written once for every integrator, and the specular-chain follower.
//!
//! `walk` is the loop of pbrt-v4's path integrator with Mitsuba 3's explicit loop state
//! (`PathState`): find the next surface (or count the light of the world the ray escapes to),
//! attenuate through the medium, record the first hit's AOVs, count emission (MIS-weighted
//! against the light sample of the vertex before), then let the integrator decide at the surface
//! (`Scatter`): end the path there with an estimate (the photon method at its first diffuse
//! surface), move it itself, or sample a light and hand back the BSDF to continue through; the
//! walk samples it, advances the state and plays Russian roulette (pbrt-v4 §13.4: on the
//! throughput, from the fourth bounce).
//!
//! Translucent surfaces (`PathState::subsurface_branch`), before the integrator acts: on a path
//! with no diffuse bounce yet, the walk picks the subsurface part (in proportion to its share
//! of the albedo) and walks through the object (`super::random_walk`), handing the integrator
//! the exit point as a white Lambertian surface, which it shades as any diffuse surface; or it
//! picks the rest of the BSDF. After a diffuse bounce the subsurface part is the Lambertian it
//! replaces (as Cycles turns a BSSRDF into a diffuse BSDF below a diffuse ancestor). The
//! integrator says which materials it walks (`Scatter::walks_subsurface`): the photon method
//! leaves Christensen–Burley ones to its dipole.
//!
//! A Ray Portal BSDF (`PathState::through_portal`), before the integrator acts: the path goes
//! on from the portal's position along its direction, as Cycles' `integrate_surface_ray_portal`
//! (Blender 4.2), with no vertex and no light sample there.
//!
//! Blender's Light Paths › Caustics settings change the BSDF of each surface the walk meets by
//! the path so far (`PathState::history`, `Shading::reached_by`).
//!
//! Blender's Light Paths › Clamping (`Clamp`) is applied where the walk adds a contribution
//! (`PathState::add` and the emission it meets), as Cycles clamps each contribution on its way
//! to the film.
//!
//! `follow_specular` follows the surfaces the photon method ray traces (delta and glossy-only
//! lobes, `classify::stores_photons` false) from a hit to the first surface that stores photons.

use super::classify::stores_photons;
use super::direct::{pass_through_weight, sample_direct_from, Previous, Vertex};
use super::media::{MediumStack, StackMedia};
use super::random_walk;
use super::shading::{transmittance, PathHistory, Shading};
use super::{CameraSample, Context};
use crate::accel::{hit_holdout, hit_mesh, Hit, Ray, Visibility, NO_INSTANCE};
use crate::bsdf::{may_be_smooth, BsdfSample, Scattering, SMOOTH_ROUGHNESS};
use crate::interaction::SurfaceHit;
use crate::light::{emitted_radiance, hit_links, Receiver};
use crate::light_pass::{FirstVertex, LightPass, Passes};
use crate::material::Portal;
use crate::math::{max_component, Vec3};
use crate::medium::{
    fly, transmittance as medium_transmittance, Coefficients, Flight, Media, SegmentSampler,
    WithoutScattering,
};
use crate::rng::Rng;
use crate::scene::{Scene, Subsurface};
use crate::shader::RayPath;

/// Longest chain of specular surfaces `follow_specular` follows.
pub const MAX_SPECULAR_CHAIN: u32 = 12;

/// Blender's Light Paths › Clamping as Cycles applies it: every contribution a camera path adds
/// (throughput × light × MIS weight: one light sample, one emitter or world met) whose summed
/// absolute colour channels exceed three times the limit is scaled down to that sum, its hue
/// kept. Light that reaches the camera after at most one bounce (a light sample at the first
/// hit, emission met by the camera ray or by the first hit's scattered ray) is held to the
/// Direct limit, the rest to the Indirect one; bounces count every scattering but transparent
/// passes, as Cycles counts them.
#[derive(Clone, Copy, Debug)]
pub struct Clamp {
    /// Limits on |r| + |g| + |b| (infinite: off).
    direct: f32,
    indirect: f32,
}

impl Clamp {
    /// No limit.
    pub const NONE: Clamp = Clamp {
        direct: f32::INFINITY,
        indirect: f32::INFINITY,
    };

    /// The scene's Clamp Direct and Clamp Indirect (0: off).
    pub fn of(scene: &Scene) -> Clamp {
        let limit = |c: f32| if c > 0.0 { 3.0 * c } else { f32::INFINITY };
        let settings = &scene.render_settings;
        Clamp {
            direct: limit(settings.clamp_direct),
            indirect: limit(settings.clamp_indirect),
        }
    }

    /// Whether any limit is set.
    pub fn is_on(self) -> bool {
        self.direct.is_finite() || self.indirect.is_finite()
    }

    /// `radiance` (a contribution, throughput included) held to the Direct limit when `direct`,
    /// else to the Indirect one.
    pub fn apply(self, radiance: Vec3, direct: bool) -> Vec3 {
        let limit = if direct { self.direct } else { self.indirect };
        let sum = radiance.abs().element_sum();
        if sum > limit {
            radiance * (limit / sum)
        } else {
            radiance
        }
    }

    /// `radiance` scaled as `apply` scales the contribution `beta` × `radiance`: for estimates
    /// that the throughput multiplies later.
    pub fn behind(self, beta: Vec3, radiance: Vec3, direct: bool) -> Vec3 {
        let limit = if direct { self.direct } else { self.indirect };
        let sum = (beta * radiance).abs().element_sum();
        if sum > limit {
            radiance * (limit / sum)
        } else {
            radiance
        }
    }
}

/// The state of one camera path between its vertices.
pub struct PathState {
    /// The ray to the next vertex.
    pub ray: Ray,
    /// Throughput from the camera to the next vertex.
    pub beta: Vec3,
    /// The vertex the ray left, for MIS.
    pub previous: Previous,
    /// Absorption coefficient of the medium the ray travels through.
    pub absorption: Vec3,
    /// The participating media the ray travels through (`super::media`).
    pub media: MediumStack,
    /// Scatterings in media so far (Blender's Volume bounces limit them).
    pub volume_bounces: u32,
    /// Non-delta vertices so far (surface vertices with a non-delta lobe and scatterings in
    /// media).
    pub diffuse: u32,
    /// Where the first of them lies (meaningful once `diffuse` > 0): it chooses between the
    /// surface and the volume light passes.
    pub first: FirstVertex,
    /// Bounces before the current vertex (0 at the camera ray's hit).
    pub depth: u32,
    /// The path went through a translucent material (its light is `LightPass::Subsurface`).
    pub subsurface: bool,
    /// The path made a diffuse bounce (translucent surfaces then scatter as Lambertian ones).
    pub diffuse_ancestor: bool,
    /// The next surface adds only its emission, then the walk ends.
    pub emission_only: bool,
    /// Only what the camera sees straight on is wanted (`seen_emission`): a surface that
    /// neither emits nor may be a smooth mirror or glass ends the walk unshaded.
    pub straight_only: bool,
    /// Radiance gathered so far, by light pass.
    pub passes: Passes,
    /// Rays traced so far (closest-hit and shadow).
    pub rays: u32,
    /// The kind of the ray to the next vertex and the bounces before it, as node trees'
    /// Light Path reads them.
    pub light_path: RayPath,
    /// Bounces so far as Cycles counts them for clamping: every scattering on a surface or in a
    /// medium but transparent passes.
    pub bounces: u32,
    /// Blender's clamping of the contributions this path adds.
    pub clamp: Clamp,
    /// What the Light Paths settings read of the path so far (the BSDFs it meets depend on it).
    pub history: PathHistory,
}

impl PathState {
    /// A camera ray's path, or (`gather`) a cache record's gather ray's: a diffuse bounce.
    /// `emission_only`: the walk ends at the first surface, after its emission.
    fn new(ray: Ray, gather: bool, emission_only: bool, clamp: Clamp) -> PathState {
        // Emission seen by the camera ray counts in full.
        let previous = Previous {
            p: ray.origin,
            horizon: None,
            pdf: 0.0,
            delta: true,
            lit_by: u64::MAX,
        };
        PathState {
            previous,
            ray,
            beta: Vec3::ONE,
            absorption: Vec3::ZERO,
            media: MediumStack::default(),
            volume_bounces: 0,
            diffuse: 0,
            first: FirstVertex::Surface,
            depth: 0,
            subsurface: false,
            diffuse_ancestor: gather,
            emission_only,
            straight_only: false,
            passes: Passes::default(),
            rays: 0,
            light_path: if gather {
                RayPath::camera().after(Scattering::Diffuse, false)
            } else {
                RayPath::camera()
            },
            bounces: 0,
            clamp,
            history: if gather {
                PathHistory::GATHER
            } else {
                PathHistory::default()
            },
        }
    }

    /// Whether light reaching the camera through this path and `vertices` more vertices (a
    /// light sample counts its own) is held to the Direct clamp (`Clamp`).
    pub fn direct_clamp(&self, vertices: u32) -> bool {
        self.bounces + vertices <= 1
    }

    /// The pass of light reaching the camera through this path and `vertices` more non-delta
    /// vertices (a light sample counts its own vertex), the next of them at `next`.
    pub fn pass(&self, vertices: u32, next: FirstVertex) -> LightPass {
        if self.subsurface {
            LightPass::Subsurface
        } else {
            let first = if self.diffuse > 0 { self.first } else { next };
            LightPass::after_first(self.diffuse + vertices, first)
        }
    }

    /// Add `radiance` (already times `beta`) to the pass after `vertices` more vertices, the
    /// next of them on a surface.
    pub fn add(&mut self, vertices: u32, radiance: Vec3) {
        let radiance = self.clamp.apply(radiance, self.direct_clamp(vertices));
        self.passes
            .add(self.pass(vertices, FirstVertex::Surface), radiance);
    }

    /// Add `radiance` (already times `beta`) to the pass after `vertices` more vertices, the
    /// next of them a scattering in the medium along the ray.
    pub fn add_in_medium(&mut self, vertices: u32, radiance: Vec3) {
        let radiance = self.clamp.apply(radiance, self.direct_clamp(vertices));
        self.passes
            .add(self.pass(vertices, FirstVertex::Medium), radiance);
    }

    /// The light the media along the path's ray over `reach` scatter towards it straight from
    /// the lights, times the throughput: `CAMERA_SEGMENT_POINTS` light samples along the
    /// segment without MIS (`light_scattered_along`), for the photon method's camera paths,
    /// which are only attenuated through media.
    /// Counts its shadow rays in `rays`.
    pub fn light_scattered_on_segment(
        &self,
        ctx: &Context,
        reach: f32,
        rng: &mut Rng,
        rays: &mut u32,
    ) -> Vec3 {
        let (ray, media, kind, beta) = (self.ray, self.media, self.light_path, self.beta);
        let points = CAMERA_SEGMENT_POINTS;
        light_scattered_along(
            ctx, &ray, reach, &media, kind, beta, false, points, rng, rays,
        )
    }

    /// The Emission pass so far: at the first vertex, what the camera sees directly (the light
    /// the media along the camera ray scatter towards it is in the volume passes).
    fn seen_emission(&self) -> Vec3 {
        self.passes.0[LightPass::Emission as usize]
    }

    /// Count one more non-delta vertex, at `kind`.
    fn count_vertex(&mut self, kind: FirstVertex) {
        if self.diffuse == 0 {
            self.first = kind;
        }
        self.diffuse += 1;
    }

    /// Add `estimate` × `beta`, an estimate by pass made at the current vertex
    /// (`Passes::add_after`), all of it Subsurface once the path went through a translucent
    /// material.
    pub fn add_estimate(&mut self, estimate: &Passes) {
        if self.subsurface {
            self.passes
                .add(LightPass::Subsurface, self.beta * estimate.total());
        } else {
            self.passes
                .add_after(estimate, self.beta, self.diffuse, self.first);
        }
    }

    /// At translucent `s` (module header): with the subsurface part's share of the albedo as
    /// probability, walk through the object and replace `s` by the exit; else leave `s` with
    /// the rest of its BSDF. False when the path ends (the walk was dropped).
    fn subsurface_branch(&mut self, ctx: &Context, s: &mut Shading, rng: &mut Rng) -> bool {
        let weight = s.surface.subsurface.weight;
        let entering = weight * s.bsdf.base_transmittance();
        let base = s.surface.base_color.clamp(Vec3::ZERO, Vec3::ONE);
        let share = entering * (base.x + base.y + base.z) / 3.0;
        let rest = s.bsdf.without_subsurface(weight);
        let rest_albedo = rest.albedo();
        let p_walk = share / (share + (rest_albedo.x + rest_albedo.y + rest_albedo.z) / 3.0);
        if !(p_walk > 0.0) {
            s.bsdf = rest;
            return true;
        }
        if rng.uniform() >= p_walk {
            s.bsdf = rest;
            self.beta /= 1.0 - p_walk;
            return true;
        }
        let Some((exit, walked)) = random_walk::walk(ctx, s, rng, &mut self.rays) else {
            return false;
        };
        self.beta *= walked * (entering / p_walk);
        self.subsurface = true;
        *s = Shading {
            media: self.media,
            history: self.history,
            ..exit
        };
        self.beta.is_finite() && self.beta != Vec3::ZERO
    }

    /// The ray left the scene: the world's light, MIS-weighted (`camera`: a camera ray).
    fn escaped(&mut self, ctx: &Context, camera: bool) {
        let pass = self.pass(0, FirstVertex::Surface);
        let (beta, previous) = (self.beta, self.previous);
        let (clamp, direct) = (self.clamp, self.direct_clamp(0));
        let passes = &mut self.passes;
        ctx.lights.escaped(
            previous.receiver(),
            self.ray.direction,
            camera,
            |le, light_pdf| {
                let l = beta * le * previous.weight(light_pdf);
                passes.add(pass, clamp.apply(l, direct));
            },
        );
    }

    /// The lamps the ray to the next vertex meets before `reach` (`Lights::lamps_met`),
    /// attenuated by the medium up to them, MIS-weighted.
    fn lamps(&mut self, ctx: &Context, reach: f32, camera: bool, rng: &mut Rng) {
        if !ctx.lights.has_lamps() {
            return;
        }
        let pass = self.pass(0, FirstVertex::Surface);
        let (beta, previous, absorption) = (self.beta, self.previous, self.absorption);
        let (clamp, direct) = (self.clamp, self.direct_clamp(0));
        let passes = &mut self.passes;
        let (ray, media) = (self.ray, self.media);
        let in_media = !media.is_vacuum(ctx.scene);
        ctx.lights.lamps_met(
            &ray,
            previous.receiver(),
            reach,
            camera,
            |le, light_pdf, t| {
                let mut through = (-absorption * t).exp();
                if in_media {
                    let dir = ray.direction.normalize();
                    through *= medium_transmittance(&media.media(ctx), ray.origin, dir, t, rng);
                }
                let l = beta * through * le * previous.weight(light_pdf);
                passes.add(pass, clamp.apply(l, direct));
            },
        );
    }

    /// The ray to the next vertex through the media over `reach` (its distance to the surface
    /// it meets, or infinity): the media's emission on the way (with `emission`) and a free
    /// flight that may scatter before the surface (with `scatters`; else the flight only
    /// attenuates, `medium::WithoutScattering`).
    fn through_media(
        &mut self,
        ctx: &Context,
        reach: f32,
        emission: bool,
        scatters: bool,
        rng: &mut Rng,
    ) -> Flight {
        let dir = self.ray.direction.normalize();
        let mut emitted = Vec3::ZERO;
        let media = match reach.is_finite() {
            true => self.media,
            false => self.media.escaping(),
        };
        if media.is_vacuum(ctx.scene) {
            return Flight::Passed;
        }
        let in_media = media.media(ctx);
        let (origin, beta) = (self.ray.origin, &mut self.beta);
        let flight = match scatters {
            true => fly(&in_media, origin, dir, reach, beta, &mut emitted, rng),
            false => fly(
                &WithoutScattering(&in_media),
                origin,
                dir,
                reach,
                beta,
                &mut emitted,
                rng,
            ),
        };
        if emission && emitted != Vec3::ZERO {
            self.add(0, emitted);
        }
        flight
    }

    /// The light the media along the ray to the next vertex (over `reach`) scatter towards
    /// it (`light_scattered_along`, MIS-weighted against phase sampling), added to the pass of
    /// a scattering in the medium. The scattering the walk then continues from (`scatter_in_medium`) takes
    /// no light sample of its own.
    fn light_in_media(&mut self, ctx: &Context, reach: f32, rng: &mut Rng) {
        let (ray, path, beta) = (self.ray, self.light_path, self.beta);
        let media = match reach.is_finite() {
            true => self.media,
            false => self.media.escaping(),
        };
        if media.is_vacuum(ctx.scene) {
            return;
        }
        let l = light_scattered_along(
            ctx,
            &ray,
            reach,
            &media,
            path,
            beta,
            true,
            1,
            rng,
            &mut self.rays,
        );
        self.add_in_medium(1, l);
    }

    /// Go straight on through the surface `hit` the ray met, weighted by what it lets through
    /// (`direct::pass_through_weight`; `passed`: the walk's depth, for its Mix Shader picks).
    /// False when it lets nothing through.
    fn pass_through(&mut self, ctx: &Context, hit: &Hit, passed: u32) -> bool {
        let sh = SurfaceHit::new(ctx.scene, &self.ray, hit);
        let path = self.light_path;
        self.beta *= pass_through_weight(ctx, &self.ray, hit, &sh, path, passed);
        if self.beta == Vec3::ZERO || !self.beta.is_finite() {
            return false;
        }
        let entering = self.ray.direction.dot(sh.ng) < 0.0;
        self.media = self.media.crossed(ctx.scene, hit, sh.material, entering);
        self.light_path = path.after(Scattering::Transparent, true);
        self.ray = sh.spawn(self.ray.direction.normalize());
        true
    }

    /// Go on from the Ray Portal BSDF `portal` the ray met at `s`, as Cycles'
    /// `integrate_surface_ray_portal`: from the portal's position (from `s` itself when that is
    /// where it lies) along its direction, weighted by its colour. No vertex: the ray stays the
    /// kind it was (a camera ray one), and as no light sample ran there, the emission it meets
    /// beyond counts in full (Cycles' MIS skip past a portal). False when nothing goes on.
    fn through_portal(&mut self, s: &Shading, portal: &Portal) -> bool {
        self.beta *= portal.weight;
        if self.beta == Vec3::ZERO || !self.beta.is_finite() || portal.direction == Vec3::ZERO {
            return false;
        }
        self.light_path = self.light_path.after(Scattering::Transparent, true);
        self.previous.delta = true;
        self.ray = if (portal.position - s.sh.p).length_squared() > 1e-9 {
            Ray {
                origin: portal.position,
                direction: portal.direction,
                t_max: f32::INFINITY,
                time: self.ray.time,
            }
        } else {
            s.sh.spawn(portal.direction)
        };
        true
    }

    /// A scattering at distance `t` along the ray in media `at`: the path goes on along a
    /// direction drawn from the phase function (counting only the emission it meets once
    /// Blender's Volume bounces are spent). False when the path ends.
    fn scatter_in_medium(
        &mut self,
        ctx: &Context,
        t: f32,
        at: &Coefficients,
        rng: &mut Rng,
    ) -> bool {
        let ray = self.ray;
        let dir = ray.direction.normalize();
        let p = ray.origin + dir * t;
        let phase = at.phase;
        let (wi, f, pdf) = phase.sample(dir, [rng.uniform(), rng.uniform(), rng.uniform()]);
        if !(pdf > 0.0) {
            return false;
        }
        self.beta *= f / pdf;
        self.bounces += 1;
        self.history = self.history.after_medium(pdf);
        self.count_vertex(FirstVertex::Medium);
        self.volume_bounces += 1;
        if self.volume_bounces > ctx.scene.render_settings.volume_bounces {
            self.emission_only = true;
        }
        // Not a camera ray any more (no other Light Path kind fits a volume scattering).
        self.light_path = self.light_path.after(Scattering::Diffuse, false);
        self.previous = Previous {
            p,
            horizon: None,
            pdf,
            delta: false,
            lit_by: u64::MAX,
        };
        self.ray = Ray {
            origin: p,
            direction: wi,
            t_max: f32::INFINITY,
            time: ray.time,
        };
        self.beta.is_finite() && self.beta != Vec3::ZERO
    }

    /// The ray met `s`: its emission, MIS-weighted.
    fn emitted(&mut self, ctx: &Context, s: &Shading) {
        let le = emitted_radiance(ctx.scene, &s.sh, s.wo, s.surface.emission);
        if le != Vec3::ZERO {
            let w = self.previous.weight_at(ctx, &s.sh);
            self.add(0, self.beta * le * w);
        }
    }

    /// One light sample at `s` through its BSDF, MIS-weighted, added to the next vertex's pass.
    pub fn light_sample(&mut self, ctx: &Context, s: &Shading, rng: &mut Rng) {
        let l = s.light_sample(ctx, self.beta, true, rng, &mut self.rays);
        self.add(1, l);
    }

    /// Continue from `s` along the BSDF sample `bs` (world direction `wi`); `light_sampled`:
    /// light sampling ran at `s`, so emission the new ray meets is MIS-weighted. False when the
    /// throughput vanished.
    pub fn advance(
        &mut self,
        scene: &Scene,
        s: &Shading,
        bs: &BsdfSample,
        wi: Vec3,
        light_sampled: bool,
    ) -> bool {
        self.beta *= bs.weight;
        if self.beta == Vec3::ZERO || !self.beta.is_finite() {
            return false;
        }
        if !bs.delta {
            self.count_vertex(FirstVertex::Surface);
        }
        if bs.scattering == Scattering::Diffuse {
            self.diffuse_ancestor = true;
        }
        self.light_path = self.light_path.after(bs.scattering, bs.transmitted);
        self.history = self.history.after(bs);
        // A transparent pass is no vertex: emission met beyond it is weighed against the
        // light sample of the vertex before, whose shadow ray passed it too (as Cycles keeps
        // its MIS state through transparent surfaces).
        if bs.scattering != Scattering::Transparent {
            self.bounces += 1;
            self.previous = Previous {
                p: s.sh.p,
                horizon: s.horizon(),
                pdf: bs.pdf,
                delta: bs.delta || !light_sampled,
                lit_by: hit_links(scene, &s.sh.hit).lit_by,
            };
        }
        self.absorption = s.absorption_after(bs, wi, self.absorption);
        if bs.transmitted {
            let entering = wi.dot(s.sh.ng) < 0.0;
            self.media = self
                .media
                .crossed(scene, &s.sh.hit, s.sh.material, entering);
        }
        self.ray = s.sh.spawn(wi);
        true
    }

    /// Russian roulette on the throughput: false when the path ends, else `beta` is reweighted.
    pub fn roulette(&mut self, rng: &mut Rng) -> bool {
        let q = max_component(self.beta).min(1.0);
        if q < 1.0 {
            if rng.uniform() >= q {
                return false;
            }
            self.beta /= q;
        }
        true
    }
}

/// What an integrator decided at a surface.
pub enum Next {
    /// The path ends here.
    End,
    /// The integrator moved the path itself (`PathState::ray` and `previous` are set).
    Moved,
    /// Continue by sampling the shading point's BSDF (as the integrator left it);
    /// `light_sampled`: the integrator sampled a light here.
    Continue { light_sampled: bool },
}

/// An integrator's part in the walk.
pub trait Scatter {
    /// Whether emission met by the walk counts (debug views of one estimate leave it out).
    fn counts_emission(&self) -> bool {
        true
    }

    /// Whether the walk takes translucent materials of `subsurface` through the random walk
    /// (else the integrator sees them whole).
    fn walks_subsurface(&self, _subsurface: &Subsurface) -> bool {
        true
    }

    /// Whether the walk samples free flights through media, scattering and going on from
    /// there with a light sample along each segment (the default), or only attenuates the path
    /// through them, the integrator adding the light they scatter (`media_segment`).
    fn scatters_in_media(&self) -> bool {
        true
    }

    /// Where `scatters_in_media` is false: add to `path` the light the media along its ray to
    /// the next vertex (`reach` away) scatter towards it. Called where the walk would take its
    /// light sample along the segment.
    fn media_segment(&mut self, _path: &mut PathState, _reach: f32, _rng: &mut Rng) {}

    /// At surface `s`, after its emission counted: add what the integrator estimates here to
    /// `path` and say how the path goes on (the integrator may change the BSDF it continues
    /// with).
    fn scatter(&mut self, path: &mut PathState, s: &mut Shading, rng: &mut Rng) -> Next;
}

/// Walk the path from `ray` (a camera ray, or with `gather` the gather ray of a cache record,
/// which leaves out the emission of its first hit and the world it escapes to).
pub fn walk(
    ctx: &Context,
    ray: Ray,
    rng: &mut Rng,
    gather: bool,
    integrator: &mut impl Scatter,
) -> CameraSample {
    let mut out = CameraSample {
        depth: 1e10,
        ..CameraSample::default()
    };
    let emission = integrator.counts_emission();
    // A cache record's gather ray is clamped whole by the cache's build, as the contribution
    // of the diffuse bounce of a camera path at the record (`cache::build_cache`).
    let clamp = if gather {
        Clamp::NONE
    } else {
        Clamp::of(ctx.scene)
    };
    let mut state = PathState::new(ray, gather, false, clamp);
    state.media = MediumStack::at(ctx, ray.origin, ray.time);
    walk_from(ctx, &mut state, rng, gather, emission, integrator, &mut out);
    out.seen_emission = state.seen_emission();
    out.radiance = state.passes.total();
    out.passes = state.passes;
    out.rays = state.rays;
    out
}

/// What the camera sees directly along `ray`: the emission it meets going straight on
/// (through transparent surfaces and media without scattering, and smooth mirrors and glass)
/// until its first other scattering, or the background it escapes to, exactly as `walk`
/// counts it (`CameraSample::seen_emission`: the Emission pass, light met before any vertex
/// that is not a delta one), with the rays traced.
pub fn seen_emission(ctx: &Context, ray: Ray, rng: &mut Rng) -> (Vec3, u32) {
    /// The walk goes on only through delta lobes: past the first other vertex nothing it
    /// meets is seen directly.
    struct Straight;
    impl Scatter for Straight {
        fn walks_subsurface(&self, _: &Subsurface) -> bool {
            false
        }
        fn scatters_in_media(&self) -> bool {
            false
        }
        fn scatter(&mut self, path: &mut PathState, s: &mut Shading, _: &mut Rng) -> Next {
            let smooth = s.bsdf.has_specular() && s.bsdf.roughness() < SMOOTH_ROUGHNESS;
            match path.diffuse == 0 && smooth {
                true => Next::Continue {
                    light_sampled: false,
                },
                false => Next::End,
            }
        }
    }
    let mut state = PathState::new(ray, false, false, Clamp::of(ctx.scene));
    state.straight_only = true;
    state.media = MediumStack::at(ctx, ray.origin, ray.time);
    let mut out = CameraSample::default();
    walk_from(ctx, &mut state, rng, false, true, &mut Straight, &mut out);
    (state.seen_emission(), state.rays)
}

/// The loop of `walk` from `state`, filling `out`'s first-hit fields.
fn walk_from(
    ctx: &Context,
    state: &mut PathState,
    rng: &mut Rng,
    gather: bool,
    emission: bool,
    integrator: &mut impl Scatter,
    out: &mut CameraSample,
) {
    for depth in 0..=ctx.max_depth {
        // A camera ray stays one through transparent surfaces (as in Cycles).
        let visibility = if state.light_path.is(RayPath::CAMERA) {
            Visibility::Camera
        } else {
            Visibility::Secondary
        };
        let ray = state.ray;
        state.rays += 1;
        let hit = ctx.accel.intersect(ctx.scene, &ray, visibility);
        let counts = emission && !(gather && depth == 0);
        // A camera ray that meets nothing ends on the far clip plane.
        let reach = hit.map_or(ray.t_max, |h| h.t) * ray.direction.length();
        if counts {
            state.lamps(ctx, reach, visibility == Visibility::Camera, rng);
        }
        if !state.media.is_vacuum(ctx.scene) {
            let scatters = integrator.scatters_in_media();
            if emission && !state.emission_only && depth < ctx.max_depth {
                state.depth = depth;
                match scatters {
                    true => state.light_in_media(ctx, reach, rng),
                    false => integrator.media_segment(state, reach, rng),
                }
            }
            match state.through_media(ctx, reach, counts, scatters, rng) {
                Flight::Passed => {}
                Flight::Absorbed => {
                    break;
                }
                Flight::Scattered { t, at } => {
                    if depth == ctx.max_depth
                        || state.emission_only
                        || !state.scatter_in_medium(ctx, t, &at, rng)
                    {
                        break;
                    }
                    if depth >= 3 && !state.roulette(rng) {
                        break;
                    }
                    continue;
                }
            }
        }
        let Some(hit) = hit else {
            if emission && !(depth == 0 && (ctx.transparent_background || gather)) {
                match &ctx.scene.world.camera_background {
                    // No light sample precedes a camera ray: nothing to weigh against. What it
                    // passed (a tinted Transparent BSDF or Ray Portal, a medium) weighs it.
                    Some(seen) if visibility == Visibility::Camera => {
                        state.add(0, state.beta * seen.radiance(ray.direction));
                    }
                    _ => state.escaped(ctx, visibility == Visibility::Camera),
                }
            }
            break;
        };
        if state.absorption != Vec3::ZERO {
            state.beta *= transmittance(state.absorption, &hit, &ray);
        }
        // Only emission is wanted (or only what is seen straight on): a surface that cannot
        // emit (nor be a smooth mirror or glass) ends the walk unshaded, unless the ray goes on
        // through it (a volume's boundary, a Transparent BSDF), as Cycles goes on through
        // transparent surfaces after a path's last bounce.
        let material = &ctx.scene.materials[hit_mesh(ctx.scene, &hit).material as usize];
        let unshaded = match (state.emission_only, state.straight_only) {
            (true, _) => !material.is_emissive(),
            (false, true) => !material.is_emissive() && !may_be_smooth(material),
            (false, false) => false,
        };
        if unshaded {
            if depth < ctx.max_depth && state.pass_through(ctx, &hit, depth) {
                continue;
            }
            break;
        }
        let primary = depth == 0 && !gather;
        let mut s = Shading::on_path(ctx, &ray, &hit, state.light_path);
        s.media = state.media;
        s.reached_by(ctx.scene, state.history);
        // A node tree's Holdout seen by the camera: black, and a hole in the film's alpha.
        if primary && (s.surface.holdout || hit_holdout(ctx.scene, &hit)) {
            out.holdout = true;
            break;
        }
        if depth == 0 {
            out.hit = true;
            out.catcher = primary && hit_catcher(ctx.scene, &hit);
            out.albedo = s.surface.base_color;
            out.normal = s.sh.frame.n;
            // From the camera: its rays start on the near clip plane.
            let near = match primary {
                true => ctx
                    .scene
                    .camera
                    .near_clip_distance(ray.direction.normalize()),
                false => 0.0,
            };
            out.depth = hit.t * ray.direction.length() + near;
        }
        if emission && !(gather && depth == 0) {
            state.emitted(ctx, &s);
        }
        if depth == ctx.max_depth || state.emission_only {
            break;
        }
        // A Ray Portal BSDF: on from elsewhere, in every integrator's camera walk.
        if let Some(portal) = s.surface.portal {
            if !state.through_portal(&s, &portal) {
                break;
            }
            continue;
        }
        state.depth = depth;
        if s.opaque
            && s.surface.subsurface.weight > 0.0
            && !state.diffuse_ancestor
            && integrator.walks_subsurface(&s.surface.subsurface)
            && !random_walk::too_short(&s)
            && !state.subsurface_branch(ctx, &mut s, rng)
        {
            break;
        }
        let light_sampled = match integrator.scatter(state, &mut s, rng) {
            Next::End => break,
            Next::Moved => {
                if depth >= 3 && !state.roulette(rng) {
                    break;
                }
                continue;
            }
            Next::Continue { light_sampled } => light_sampled,
        };
        let (lobe, direction) = rng.uniform3();
        let Some((bs, wi)) = s.sample(lobe, direction) else {
            break;
        };
        if !state.advance(ctx.scene, &s, &bs, wi, light_sampled) {
            break;
        }
        if depth >= 3 && !state.roulette(rng) {
            break;
        }
    }
}

/// Whether `hit` lies on a shadow catcher.
fn hit_catcher(scene: &Scene, hit: &Hit) -> bool {
    if hit.instance == NO_INSTANCE {
        scene.meshes[hit.mesh as usize].shadow_catcher
    } else {
        scene.instances[hit.instance as usize].shadow_catcher
    }
}

/// Points the photon method's camera paths draw on each segment through media for the light
/// the media scatter towards them (`light_scattered_along`). Its other estimates (the
/// irradiance cache, the photon maps) are smooth, so one point per segment would leave most of
/// its noise in fog: stratified along the segment, a few points see a shaft of light crossing
/// it (a sun through a window, a spot's cone) far more evenly, for a shadow ray each. The path
/// tracer, whose noise lies mostly elsewhere, takes one point as Cycles does.
pub const CAMERA_SEGMENT_POINTS: u32 = 4;

/// The light that the media along `ray` (of kind `path`, through `media`, over `reach`)
/// scatter towards its origin straight from the lights, times `beta`: light samples through
/// the phase function (MIS-weighted against phase sampling with `mis`) from points drawn on
/// the segment by distance or equiangular sampling (`medium::SegmentSampler`, centred on a
/// point drawn on a light from the segment's middle), `points` of them stratified in the
/// sampler's distance and averaged. Counts its shadow rays in `rays`.
#[allow(clippy::too_many_arguments)]
pub fn light_scattered_along(
    ctx: &Context,
    ray: &Ray,
    reach: f32,
    media: &MediumStack,
    path: RayPath,
    beta: Vec3,
    mis: bool,
    points: u32,
    rng: &mut Rng,
    rays: &mut u32,
) -> Vec3 {
    let dir = ray.direction.normalize();
    let in_media = media.media(ctx);
    let homogeneous = in_media.homogeneous();
    let middle = if reach.is_finite() {
        ray.origin + dir * (0.5 * reach)
    } else {
        ray.origin
    };
    let (choice, point) = rng.uniform3();
    let centre = ctx
        .lights
        .sample(
            ctx.scene,
            Receiver::at(middle),
            path,
            ray.time,
            true,
            choice,
            point,
        )
        .filter(|ls| !ls.target.distant)
        .map(|ls| ls.target.p);
    let sampler = match homogeneous {
        Some(c) => SegmentSampler::new(ray.origin, dir, reach, c.extinction(), beta, centre),
        None => SegmentSampler::through_majorant(&in_media, ray.origin, dir, reach, centre),
    };
    let segment = Segment {
        ray,
        dir,
        media,
        in_media: &in_media,
        homogeneous,
        path,
        beta,
        mis,
    };
    let n = points.max(1);
    let mut sum = Vec3::ZERO;
    for k in 0..n {
        // Each point's distance in its own stratum; strategy and light drawn freely.
        let stratum = (k as f32 + rng.uniform()) / n as f32;
        let u = [rng.uniform(), stratum, rng.uniform()];
        if let Some((t, pdf)) = sampler.sample(u) {
            sum += segment.light_at(ctx, t, pdf, rng, rays);
        }
    }
    sum / n as f32
}

/// A segment of a ray through media, as `light_scattered_along` takes light samples on it.
struct Segment<'a> {
    ray: &'a Ray,
    /// The ray's unit direction.
    dir: Vec3,
    media: &'a MediumStack,
    in_media: &'a StackMedia<'a>,
    homogeneous: Option<Coefficients>,
    path: RayPath,
    beta: Vec3,
    mis: bool,
}

impl Segment<'_> {
    /// The light scattered towards the ray's origin at distance `t` (drawn with density
    /// `pdf`): one light sample through the phase function there.
    fn light_at(&self, ctx: &Context, t: f32, pdf: f32, rng: &mut Rng, rays: &mut u32) -> Vec3 {
        let (ray, dir) = (self.ray, self.dir);
        let p = ray.origin + dir * t;
        let (through, at) = match self.homogeneous {
            Some(c) => ((-c.extinction() * t).exp(), c),
            None => (
                medium_transmittance(self.in_media, ray.origin, dir, t, rng),
                self.in_media.at(p, rng.uniform()),
            ),
        };
        let weight = self.beta * through * at.scattering / pdf;
        if weight == Vec3::ZERO || !weight.is_finite() {
            return Vec3::ZERO;
        }
        let phase = at.phase;
        let vertex = Vertex::Medium { p, time: ray.time };
        sample_direct_from(
            ctx,
            vertex,
            None,
            self.path,
            self.media,
            weight,
            self.mis,
            rng,
            rays,
            |wi| {
                let cos = dir.dot(wi);
                (Vec3::splat(phase.eval(cos)), phase.pdf(cos))
            },
        )
    }
}

/// The throughput, medium and length of a specular chain as `follow_specular` walks it.
#[derive(Clone, Copy, Debug)]
pub struct Chain {
    pub beta: Vec3,
    pub absorption: Vec3,
    /// Path length from the chain's start (plus whatever the caller started it with).
    pub length: f32,
}

impl Chain {
    /// A chain starting in a medium of absorption `absorption`, with unit throughput.
    pub fn new(absorption: Vec3) -> Chain {
        Chain {
            beta: Vec3::ONE,
            absorption,
            length: 0.0,
        }
    }
}

/// Follow specular surfaces (sampling their BSDF) from `s` to the first surface that stores
/// photons and return it (each surface shaded as the path from `s` reaches it,
/// `Shading::reached_by`), at most `MAX_SPECULAR_CHAIN` surfaces including `s`; with
/// `emission`, add there the emission met on the way (× the chain's throughput, unweighted: nothing on a
/// specular chain samples lights). Counts its rays in `rays`. `None` when the chain escapes,
/// ends or runs too long.
pub fn follow_specular(
    ctx: &Context,
    mut s: Shading,
    chain: &mut Chain,
    rng: &mut Rng,
    rays: &mut u32,
    mut emission: Option<&mut Vec3>,
) -> Option<Shading> {
    for _ in 0..MAX_SPECULAR_CHAIN {
        if stores_photons(&s.bsdf) {
            return Some(s);
        }
        let (lobe, direction) = rng.uniform3();
        let (bs, wi) = s.sample(lobe, direction)?;
        chain.beta *= bs.weight;
        chain.absorption = s.absorption_after(&bs, wi, chain.absorption);
        let ray = s.sh.spawn(wi);
        *rays += 1;
        let hit = ctx.accel.intersect(ctx.scene, &ray, Visibility::Secondary);
        if let Some(le) = emission.as_deref_mut() {
            let (beta, absorption) = (chain.beta, chain.absorption);
            // A camera ray that meets nothing ends on the far clip plane.
            let reach = hit.map_or(ray.t_max, |h| h.t) * ray.direction.length();
            ctx.lights
                .lamps_met(&ray, Receiver::at(ray.origin), reach, false, |l, _, t| {
                    *le += beta * (-absorption * t).exp() * l;
                });
        }
        let Some(hit) = hit else {
            if let Some(le) = emission {
                let beta = chain.beta;
                ctx.lights
                    .escaped(Receiver::at(ray.origin), wi, false, |l, _| *le += beta * l);
            }
            return None;
        };
        chain.length += hit.t * ray.direction.length();
        chain.beta *= transmittance(chain.absorption, &hit, &ray);
        let history = s.history.after(&bs);
        s = Shading::new(ctx, &ray, &hit, false);
        s.reached_by(ctx.scene, history);
        if let Some(le) = emission.as_deref_mut() {
            *le += chain.beta * emitted_radiance(ctx.scene, &s.sh, s.wo, s.surface.emission);
        }
        if chain.beta == Vec3::ZERO || !chain.beta.is_finite() {
            return None;
        }
    }
    None
}
