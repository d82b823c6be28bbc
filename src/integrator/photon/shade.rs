//! Rendering with the photon maps (Jensen 2001, ch. 9, "Rendering"): the camera path is walked
//! as the path tracer walks it (`walk::walk`, with light sampling on glossy surfaces) up to the
//! first surface that stores photons, x, where the reflected radiance is decomposed as
//!
//! L(x) = Le + L_direct + L_specular + L_caustic + L_indirect:
//! - **direct** (paths L D(x) E): one light sample with MIS against the BSDF-sampled gather rays,
//!   which add the emission they hit with the complementary weight;
//! - **specular** (E S* x): a delta lobe of x itself (a smooth coat) is traced to the next
//!   surface that stores photons, which adds its emission and global estimate;
//! - **caustics** (L S+ D(x)): the caustic map's estimate at x, cone-filtered;
//! - **indirect** (L (S|D)* D S* D(x)): final gathering: `gather_rays` BSDF-sampled rays from x
//!   (the first n² stratified); each follows specular surfaces without adding emission (L S+
//!   paths arriving that way are caustics, already counted) and reads the global map at the
//!   first surface that stores photons. The global map holds every stored photon, so its
//!   estimate there is that surface's full reflected radiance.
//!
//! Each light path is counted once: by the first diffuse vertex from the eye it is direct,
//! caustic (only specular vertices between it and the light) or indirect (some diffuse vertex
//! between).
//!
//! **Irradiance cache** (`crate::integrator::cache`): at a Lambertian opaque x, the indirect term is
//! ρ/π × E interpolated from Ward's records, and direct light is one light sample,
//! MIS-weighted with one BSDF ray that counts only emission wherever a ray can meet a light
//! (`Gather::direct_without_gather`). A diffuse lobe under a glossy layer takes ρ_d/π × E from
//! the cache while one gather ray per camera sample carries the rest of the BSDF (its global
//! estimate counted with f − ρ_d/π). Other surfaces, and points no record covers, keep the
//! plain gather rays.
//!
//! A final-gather hit y on an opaque surface with a diffuse lobe reads that lobe's light from
//! the nearest precomputed irradiance record (ρ_d/π × E, `super::estimate`) instead of a full
//! estimate; a glossy layer over it is followed by one BSDF-sampled ray with Russian roulette
//! (`Gather::glossy_rest`), so the photons' directions, which records do not keep, never enter
//! as an approximation: shading y's glossy lobe as if its light came evenly from all
//! directions is a bias that no number of photons removes.
//!
//! **Media** (Jensen & Christensen 1998): along every segment of the camera path and of the
//! final-gather rays that runs through a medium, the light the medium scatters towards the ray
//! is single scattering, one light sample from a point on the segment (not MIS-weighted: the
//! path does not go on by the phase function), plus the volume photon map's beam estimate
//! (`crate::volume_photon_map`), which holds only photons that scattered before, so each light
//! path is counted once; the path itself is only attenuated (`Scatter::scatters_in_media`).
//! Gather rays cross the transparent boundaries of volumes, entering and leaving their media,
//! and the irradiance cache's gather rays find the media at their origin first.
//!
//! Light passes, as seen from x: its light sample and the emission its gather rays find are
//! Direct, emission through its delta lobes Emission, the global estimates and the cache
//! Indirect, the caustic estimate Caustic, the dipole term Subsurface; glossy vertices on the
//! camera path before x move Emission and Direct one step further (`Passes::add_after`). Along
//! the camera path's segments through media, single scattering is Volume Direct and the volume
//! map's estimate Volume Indirect (both Indirect once a glossy vertex came before);
//! what media scatter along x's gather rays is part of x's Indirect light.
//!
//! **Caustics switches and Filter Glossy** (Blender's Light Paths › Caustics): every surface a
//! camera path, a final-gather ray or a specular chain meets is shaded with the BSDF its path
//! leaves it (`Shading::reached_by`), so a final-gather hit loses the glossy lobes the switches
//! drop after a diffuse bounce; photons that reach a surface through such a lobe are not stored
//! and end at their next diffuse bounce (`tracing`), as every camera path that would read them
//! leaves that surface by a diffuse bounce.
//!
//! **Clamping** (Blender's Clamp Direct and Indirect, `walk::Clamp`): the camera path's own
//! contributions are clamped as the path tracer's are. At x, each contribution a Cycles path
//! would add is clamped with the camera path's throughput: the light sample, and each
//! final-gather ray's emission (Direct when x is the first hit) and its estimate (Indirect) as
//! one sample of x's next bounce; the caustic, global and cached estimates, each one Indirect
//! contribution. An estimate averages many light paths, whose rare bright ones Cycles' clamp
//! would have cut: caustic photons carry only the share of their flux that Clamp Indirect
//! leaves of the camera path that would find them (`tracing::caustic_clamp`), so the caustics
//! of a sun or a small lamp mostly vanish at Blender's default limit, as in Cycles.

use super::build::PhotonMaps;
use super::estimate::{nearest_irradiance, radiance_estimate, Walls};
use crate::accel::{Hit, Ray, Visibility};
use crate::bsdf::{BsdfSample, Scattering};
use crate::integrator::classify::{diffuse_reflectance, stores_photons};
use crate::integrator::direct::{sample_direct, Previous};
use crate::integrator::media::MediumStack;
use crate::integrator::shading::{transmittance, without_diffuse, CachedDiffuse, Shading};
use crate::integrator::walk::{
    follow_specular, light_scattered_along, walk, Chain, Clamp, Next, PathState, Scatter,
};
use crate::integrator::{CameraSample, Context};
use crate::irradiance_cache::{Incoming, IrradianceCache};
use crate::light::{emitted_radiance, hit_links};
use crate::light_pass::{LightPass, Passes};
use crate::math::{max_component, Vec2, Vec3};
use crate::medium::{fly, transmittance as medium_transmittance, Flight, Media, WithoutScattering};
use crate::photon_map::{Neighbors, Photon};
use crate::rng::Rng;
use crate::scene::{Subsurface, SubsurfaceMethod};
use crate::shader::RayPath;
use std::f32::consts::PI;

/// Least probability with which a final-gather hit traces its glossy layer (`glossy_rest`):
/// below it the rare traced layers, weighted by 1/q, add more noise than the rays save
/// (docs/bench/photon_method.md, "Glossy layers at final-gather hits").
const MIN_GLOSSY_PROBABILITY: f32 = 0.25;

/// A final-gather hit nearer to the point that gathers than this many times the radius of its
/// estimate is traced one bounce further (`Gather::gather_estimate`).
const SHORT_GATHER: f32 = 1.0;

/// Photons record their bounces up to this count (`Photon::bounces` saturates there).
const MAX_STORED_BOUNCES: u32 = 15;

/// Most transparent volume boundaries a final-gather ray crosses (`Gather::cast`).
const MAX_VOLUME_BOUNDARIES: u32 = 16;

/// The surface a final-gather ray met (`Gather::cast`): the ray's last segment and its hit,
/// the surface shaded (with the media the ray reached it through), the vertex the ray left
/// (for MIS) and the distance travelled.
struct Met {
    ray: Ray,
    hit: Hit,
    y: Shading,
    previous: Previous,
    distance: f32,
}

/// What a final-gather ray met on its way (`Gather::cast`), seen from where it left: the
/// media's transmittance, the light it met (lamps, MIS-weighted, and the media's emission,
/// attenuated) and the light the media scattered towards it.
struct Along {
    through: Vec3,
    lamps: Vec3,
    scattered: Vec3,
}

/// What the photon method shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum View {
    /// The full solution (direct + specular + caustics + final gather).
    Full,
    /// The global map's radiance estimate at the first surface that stores photons, plus
    /// emission.
    Global,
    /// The caustic map's radiance estimate at the first surface that stores photons.
    Caustic,
    /// Photon positions: white dots for global photons, orange for caustic ones.
    Photons,
}

/// Per-sample state of shading from the photon maps: the maps and cache it reads, the
/// k-nearest buffer and the rays it traced.
struct Gather<'a> {
    ctx: &'a Context<'a>,
    maps: &'a PhotonMaps,
    cache: Option<&'a IrradianceCache>,
    buf: Neighbors,
    rays: u32,
    /// Bounces on the camera path before the point being shaded.
    depth: u32,
    /// The camera path's clamping and its throughput to the point being shaded, and whether
    /// light sampled there is held to the Direct limit (`walk::Clamp`).
    clamp: Clamp,
    beta: Vec3,
    direct_clamp: bool,
    /// The photons of one beam estimate in a heterogeneous medium, reused between estimates.
    beam_photons: Vec<(f32, Photon)>,
}

impl<'a> Gather<'a> {
    fn new(ctx: &'a Context<'a>, maps: &'a PhotonMaps, cache: Option<&'a IrradianceCache>) -> Self {
        Gather {
            ctx,
            maps,
            cache,
            buf: Neighbors::default(),
            rays: 0,
            depth: 0,
            clamp: Clamp::NONE,
            beta: Vec3::ONE,
            beam_photons: Vec::new(),
            direct_clamp: false,
        }
    }

    /// `l`, light reaching the shaded point, clamped as the contribution it adds to the camera
    /// path (`direct`: one sampled at the shaded point, else an indirect one).
    fn clamped(&self, l: Vec3, direct: bool) -> Vec3 {
        self.clamp.behind(self.beta, l, direct && self.direct_clamp)
    }

    fn intersect(&mut self, ray: &Ray) -> Option<Hit> {
        self.rays += 1;
        self.ctx
            .accel
            .intersect(self.ctx.scene, ray, Visibility::Secondary)
    }

    /// The bounces a photon may have made before reaching a surface `after` bounces beyond the
    /// shaded point for its light to stay within the render's bounce limit (`Context::max_depth`,
    /// counting the camera path's bounces before that point): `Ok(None)` when every photon
    /// counts, `Err(())` when none does.
    fn bounce_limit(&self, after: u32) -> Result<Option<u32>, ()> {
        let left = self.ctx.max_depth as i64 - self.depth as i64 - after as i64;
        match left {
            l if l < 0 => Err(()),
            l if l >= MAX_STORED_BOUNCES as i64 => Ok(None),
            l => Ok(Some(l as u32)),
        }
    }

    /// The global estimate at a final-gather hit `s`, `after` bounces beyond the shaded point.
    /// On an opaque surface with a diffuse lobe and precomputed irradiance: that lobe's part from
    /// the nearest record, ρ_d(wo)/π × E (exact for a Lambertian lobe), plus the other lobes by
    /// `glossy_rest`. Elsewhere (metals, transmissive surfaces, no record near) the full
    /// estimate, whose photons keep their directions. Records mix every bounce, so a bounce limit
    /// that leaves some photons out takes the full estimate.
    ///
    /// A hit closer to the point that gathers (`distance` along the ray) than `SHORT_GATHER`
    /// times the radius its estimate spans is traced one bounce further instead
    /// (`traced_bounce`): seen from so near, the estimate's blur spans a wide cone of directions,
    /// and next to an edge its disc reaches past the surface, so it reads low wherever surfaces
    /// meet (a room's corners and edges), a bias that shrinks only as slowly as the radii.
    fn gather_estimate(&mut self, s: &Shading, after: u32, distance: f32, rng: &mut Rng) -> Vec3 {
        let record = match (&self.maps.irradiance, self.bounce_limit(after)) {
            (Some(irr), Ok(None)) => diffuse_reflectance(&s.bsdf, s.opaque).and_then(|rho| {
                nearest_irradiance(irr, self.maps.global_radius2, s).map(|(e, r)| (rho, e, r))
            }),
            _ => None,
        };
        let radius = record.map_or(self.maps.global_radius2.sqrt(), |(_, _, r)| r);
        // Without a global map the method renders no indirect diffuse light at all.
        let traced = self.maps.global.is_some() && self.bounce_limit(after + 1).is_ok();
        if traced && distance < SHORT_GATHER * radius {
            return self.traced_bounce(s, after, rng);
        }
        if let Some((rho, e, _)) = record {
            let diffuse = rho * e * (1.0 / PI);
            if s.is_opaque_lambertian() {
                return diffuse;
            }
            return diffuse + self.glossy_rest(s, rho, after, rng);
        }
        self.global(s, after)
    }

    /// The radiance a final-gather hit `s`, `after` bounces beyond the shaded point, reflects
    /// towards its viewer, traced as the shaded point itself is shaded: a light sample, the
    /// caustic estimate, and one BSDF-sampled gather ray to the gather estimate of the surface
    /// it meets (Jensen 2001, §9.3.4: final-gather rays that end close by are traced further).
    fn traced_bounce(&mut self, s: &Shading, after: u32, rng: &mut Rng) -> Vec3 {
        let mut l = self.direct(s, true, rng) + self.caustic(s, after);
        if let Some((bs, wi)) = s.sample(rng.uniform(), rng.uniform2()) {
            let (emission, estimate) = self.gather_ray(s, &bs, wi, true, after, rng);
            l += bs.weight * (emission + estimate);
        }
        l
    }

    /// The radiance the lobes of `s` other than its diffuse one (ρ_d = `rho`) reflect towards
    /// its viewer, `after` bounces beyond the shaded point, as the path tracer finds it: one
    /// light sample and one BSDF sample, MIS-weighted, both counting f − ρ_d/π only, the BSDF
    /// sample continued to the gather estimate of the surface it meets (behind specular ones).
    /// Computed with probability q, the glossy lobes' share of the albedo but at least
    /// `MIN_GLOSSY_PROBABILITY`, and divided by it (Russian roulette): on a Principled surface
    /// the glossy layer reflects a few per cent, and this keeps its cost to a fraction of the
    /// gather hits.
    fn glossy_rest(&mut self, s: &Shading, rho: Vec3, after: u32, rng: &mut Rng) -> Vec3 {
        let share = max_component(s.bsdf.albedo() - rho) / max_component(s.bsdf.albedo());
        if !(share > 0.0) {
            return Vec3::ZERO;
        }
        let q = share.clamp(MIN_GLOSSY_PROBABILITY, 1.0);
        if rng.uniform() >= q || self.bounce_limit(after + 1).is_err() {
            return Vec3::ZERO;
        }
        let ctx = self.ctx;
        let (horizon, rays) = (s.horizon(), &mut self.rays);
        let mut l = sample_direct(
            ctx,
            &s.sh,
            horizon,
            &s.media,
            Vec3::ONE,
            true,
            rng,
            rays,
            |wi| {
                if wi.dot(s.ng) <= 0.0 {
                    return (Vec3::ZERO, 0.0);
                }
                let local = s.frame.to_local(wi);
                let (f, pdf) = s.bsdf.eval_and_pdf(local);
                (without_diffuse(f, rho, local.z, 1.0), pdf)
            },
        );
        if let Some((bs, wi)) = s.sample(rng.uniform(), rng.uniform2()) {
            let weight = match bs.delta {
                true => bs.weight,
                false => without_diffuse(bs.weight, rho, bs.wi.z, bs.pdf),
            };
            if weight != Vec3::ZERO {
                l += weight * self.glossy_ray(s, &bs, wi, after, rng);
            }
        }
        l / q
    }

    /// What a BSDF-sampled ray from a final-gather hit `s` brings back: the emission it meets,
    /// MIS-weighted against `glossy_rest`'s light sample, the light the media along it scatter
    /// towards `s`, and the gather estimate of the surface that stores photons behind specular
    /// ones, `after` + 1 bounces beyond the shaded point.
    fn glossy_ray(
        &mut self,
        s: &Shading,
        bs: &BsdfSample,
        wi: Vec3,
        after: u32,
        rng: &mut Rng,
    ) -> Vec3 {
        let absorption = s.absorption_after(bs, wi, Vec3::ZERO);
        let (met, along) = match self.cast(s, bs, wi, absorption, true, rng) {
            Ok(met) => met,
            Err((escaped, scattered)) => return escaped + scattered,
        };
        let ctx = self.ctx;
        let z = met.y;
        let mut l = emitted_radiance(ctx.scene, &z.sh, z.wo, z.surface.emission);
        if l != Vec3::ZERO {
            l *= met.previous.weight_at(ctx, &z.sh) * along.through;
        }
        l += along.lamps;
        let mut chain = Chain {
            length: met.distance,
            beta: along.through,
            ..Chain::new(Vec3::ZERO)
        };
        if let Some(d) = follow_specular(ctx, z, &mut chain, rng, &mut self.rays, Some(&mut l)) {
            l += chain.beta * self.gather_estimate(&d, after + 1, chain.length, rng);
        }
        if along.scattered != Vec3::ZERO {
            l += along.scattered;
        }
        l
    }

    /// The global map's estimate at `s`, `after` bounces beyond the shaded point (1: at it).
    fn global(&mut self, s: &Shading, after: u32) -> Vec3 {
        let (maps, k) = (self.maps, self.maps.settings.k_global);
        let (Some(m), Ok(limit)) = (&maps.global, self.bounce_limit(after)) else {
            return Vec3::ZERO;
        };
        radiance_estimate(
            m,
            k,
            maps.global_radius2,
            false,
            s,
            &mut self.buf,
            None,
            limit,
        )
    }

    /// The caustic map's estimate at `s`, `after` bounces beyond the shaded point (1: at it),
    /// leaving out photons behind walls.
    fn caustic(&mut self, s: &Shading, after: u32) -> Vec3 {
        let (maps, k) = (self.maps, self.maps.settings.k_caustic);
        let (Some(m), Ok(limit)) = (&maps.caustic, self.bounce_limit(after)) else {
            return Vec3::ZERO;
        };
        let (ctx, rays) = (self.ctx, &mut self.rays);
        let mut walls = |r: f32| Walls::around(ctx, s, r, rays);
        let r2 = maps.caustic_radius2;
        radiance_estimate(m, k, r2, true, s, &mut self.buf, Some(&mut walls), limit)
    }

    /// One light sample at `s`, MIS-weighted against BSDF sampling when `mis` is set.
    fn direct(&mut self, s: &Shading, mis: bool, rng: &mut Rng) -> Vec3 {
        s.light_sample(self.ctx, Vec3::ONE, mis, rng, &mut self.rays)
    }

    /// The lamps `ray` meets before `reach`, through a medium of absorption `absorption` and
    /// the participating `media` when given, MIS-weighted against the light sample at
    /// `previous`.
    fn lamps(
        &self,
        ray: &Ray,
        reach: f32,
        absorption: Vec3,
        media: Option<&MediumStack>,
        previous: &Previous,
        rng: &mut Rng,
    ) -> Vec3 {
        let ctx = self.ctx;
        let mut l = Vec3::ZERO;
        ctx.lights
            .lamps_met(ray, previous.receiver(), reach, false, |le, lpdf, t| {
                let mut through = (-absorption * t).exp();
                if let Some(media) = media {
                    let dir = ray.direction.normalize();
                    through *= medium_transmittance(&media.media(ctx), ray.origin, dir, t, rng);
                }
                l += through * le * previous.weight(lpdf);
            });
        l
    }

    /// The light the media along `ray` (of kind `path`, through `media`, over `reach`)
    /// scatter towards its origin: single scattering by one light sample
    /// (`walk::light_scattered_along`, not MIS-weighted: nothing samples the phase function
    /// here) and the volume photon map's beam estimate for the light scattered more often.
    fn in_media(
        &mut self,
        ray: &Ray,
        reach: f32,
        media: &MediumStack,
        path: RayPath,
        rng: &mut Rng,
    ) -> (Vec3, Vec3) {
        let ctx = self.ctx;
        let single = light_scattered_along(
            ctx,
            ray,
            reach,
            media,
            path,
            Vec3::ONE,
            false,
            1,
            rng,
            &mut self.rays,
        );
        (single, self.volume_estimate(ray, reach, media, rng))
    }

    /// The volume photon map's beam estimate along `ray` through `media` over `reach`
    /// (`crate::volume_photon_map`): each photon weighed by the transmittance to it and the
    /// phase function there between its direction and the ray's.
    fn volume_estimate(
        &mut self,
        ray: &Ray,
        reach: f32,
        media: &MediumStack,
        rng: &mut Rng,
    ) -> Vec3 {
        let Some(map) = &self.maps.volume else {
            return Vec3::ZERO;
        };
        let dir = ray.direction.normalize();
        let in_media = media.media(self.ctx);
        match in_media.homogeneous() {
            Some(c) => {
                let sigma_t = c.extinction();
                map.beam(ray.origin, dir, reach, |t, photon| {
                    (-sigma_t * t).exp() * c.phase.eval(dir.dot(photon.incoming()))
                })
            }
            None => {
                // Transmittance tracked once along the beam, from each photon to the next
                // (the product of independent estimates over consecutive pieces).
                let (mut through, mut tracked) = (Vec3::ONE, 0.0);
                let mut buffer = std::mem::take(&mut self.beam_photons);
                let sum = map.beam_in_order(ray.origin, dir, reach, &mut buffer, |t, photon| {
                    if through == Vec3::ZERO {
                        return Vec3::ZERO;
                    }
                    let from = ray.origin + dir * tracked;
                    through *= medium_transmittance(&in_media, from, dir, t - tracked, rng);
                    tracked = t;
                    let at = in_media.at(photon.position(), rng.uniform());
                    through * at.phase.eval(dir.dot(photon.incoming()))
                });
                self.beam_photons = buffer;
                sum
            }
        }
    }

    /// The ray leaving `s` by the BSDF sample `bs` (world direction `wi`) through a medium of
    /// absorption `absorption`, up to the first surface it meets that is more than a volume's
    /// transparent boundary (those it crosses, entering and leaving their media), with what it
    /// met on the way: the transmittance of the media, the lamps, and with `scattered` the
    /// light the media scatter towards `s` (`in_media`). `Err` with the world's emission and
    /// the lamps (MIS-weighted against light sampling, attenuated) and that scattered light
    /// when it meets no surface.
    fn cast(
        &mut self,
        s: &Shading,
        bs: &BsdfSample,
        wi: Vec3,
        absorption: Vec3,
        scattered: bool,
        rng: &mut Rng,
    ) -> Result<(Met, Along), (Vec3, Vec3)> {
        let ctx = self.ctx;
        let scene = ctx.scene;
        let previous = Previous {
            p: s.sh.p,
            horizon: s.horizon(),
            pdf: bs.pdf,
            delta: bs.delta,
            lit_by: hit_links(scene, &s.sh.hit).lit_by,
        };
        let mut media = s.media;
        if bs.transmitted {
            media = media.crossed(scene, &s.sh.hit, s.sh.material, wi.dot(s.sh.ng) < 0.0);
        }
        // The kind of a ray one bounce from the camera (the light samples in media along it
        // read it; deeper gather rays take it too).
        let path = RayPath::camera().after(bs.scattering, bs.transmitted);
        let mut along = Along {
            through: Vec3::ONE,
            lamps: Vec3::ZERO,
            scattered: Vec3::ZERO,
        };
        let mut distance = 0.0;
        let mut ray = s.sh.spawn(wi);
        for _ in 0..MAX_VOLUME_BOUNDARIES {
            let hit = self.intersect(&ray);
            let reach = hit.map_or(f32::INFINITY, |h| h.t * ray.direction.length());
            let in_media = (!media.is_vacuum(scene)).then_some(&media);
            let lamps = self.lamps(&ray, reach, absorption, in_media, &previous, rng);
            along.lamps += along.through * lamps;
            if let Some(media) = in_media {
                if scattered {
                    let (single, multiple) = self.in_media(&ray, reach, media, path, rng);
                    along.scattered += along.through * (single + multiple);
                }
                let dir = ray.direction.normalize();
                if scene.media_emit() {
                    // The media's emission is light no light sample finds: counted here whole.
                    let (mut beta, mut emitted) = (Vec3::ONE, Vec3::ZERO);
                    let in_media = media.media(ctx);
                    let without = WithoutScattering(&in_media);
                    if fly(
                        &without,
                        ray.origin,
                        dir,
                        reach,
                        &mut beta,
                        &mut emitted,
                        rng,
                    ) == Flight::Absorbed
                    {
                        beta = Vec3::ZERO;
                    }
                    along.lamps += along.through * emitted;
                    along.through *= beta;
                } else {
                    along.through *=
                        medium_transmittance(&media.media(ctx), ray.origin, dir, reach, rng);
                }
            }
            let Some(hit) = hit else {
                let (through, mut l) = (along.through, along.lamps);
                ctx.lights
                    .escaped(previous.receiver(), ray.direction, false, |le, lpdf| {
                        l += through * (le * previous.weight(lpdf))
                    });
                return Err((l, along.scattered));
            };
            distance += reach;
            let mut y = Shading::new(ctx, &ray, &hit, false);
            if scene.materials[y.sh.material as usize].volume.is_some() && y.surface.transparent {
                along.through *= y.surface.base_color.clamp(Vec3::ZERO, Vec3::ONE);
                let entering = ray.direction.dot(y.sh.ng) < 0.0;
                media = media.crossed(scene, &hit, y.sh.material, entering);
                ray = y.sh.spawn(ray.direction);
                continue;
            }
            y.media = media;
            y.reached_by(scene, s.history.after(bs));
            let met = Met {
                ray,
                hit,
                y,
                previous,
                distance,
            };
            return Ok((met, along));
        }
        Err((Vec3::ZERO, along.scattered))
    }

    /// A final-gather ray leaving `s` by the BSDF sample `bs` (world direction `wi`): the
    /// emission it finds, MIS-weighted against light sampling, and with `estimate` the global
    /// estimate at the first surface that stores photons behind specular ones plus the light
    /// the media along the ray scatter towards `s`, returned apart (the passes and the
    /// irradiance cache treat them apart). A ray that left through a delta lobe also counts the
    /// emission along the specular chain, and reads the full global estimate. `s` lies `after`
    /// bounces beyond the shaded point (1: it is the shaded point).
    fn gather_ray(
        &mut self,
        s: &Shading,
        bs: &BsdfSample,
        wi: Vec3,
        estimate: bool,
        after: u32,
        rng: &mut Rng,
    ) -> (Vec3, Vec3) {
        let absorption = s.absorption_after(bs, wi, Vec3::ZERO);
        let (met, along) = match self.cast(s, bs, wi, absorption, estimate, rng) {
            Ok(met) => met,
            Err(escaped) => return escaped,
        };
        let ctx = self.ctx;
        let Met {
            ray,
            hit,
            y,
            previous,
            distance,
        } = met;
        let t = transmittance(absorption, &hit, &ray);
        let mut l = emitted_radiance(ctx.scene, &y.sh, y.wo, y.surface.emission);
        if l != Vec3::ZERO {
            l *= previous.weight_at(ctx, &y.sh) * along.through;
        }
        let mut e = Vec3::ZERO;
        if estimate {
            let mut chain = Chain {
                length: distance,
                beta: along.through,
                ..Chain::new(absorption)
            };
            let emission = previous.delta.then_some(&mut l);
            if let Some(d) = follow_specular(self.ctx, y, &mut chain, rng, &mut self.rays, emission)
            {
                let at_end = match previous.delta {
                    true => self.global(&d, after + 1),
                    false => self.gather_estimate(&d, after + 1, chain.length, rng),
                };
                e = chain.beta * at_end;
            }
        }
        let mut e = t * e;
        if along.scattered != Vec3::ZERO {
            e += along.scattered;
        }
        (t * l + along.lamps, e)
    }

    /// Direct light at `s` when no final-gather ray leaves it (its indirect light is cached):
    /// light sampling alone has unbounded variance where an emitting mesh meets the surface
    /// at a concave corner (the 1/d² of nearby light samples), and speckles where a small
    /// opening shows the world (most of its samples blocked, the few through it weighted by
    /// the inverse of the world's small share of the samples). So wherever a ray can meet a
    /// light, one BSDF-sampled ray adds the emission it finds and both are MIS-weighted, as in
    /// the path tracer. The ray also finds the light of emitting media, which no light sample
    /// draws. Scenes lit only by point, spot and sharp sun lamps, without emitting media, keep
    /// light sampling alone.
    fn direct_without_gather(&mut self, s: &Shading, rng: &mut Rng) -> Vec3 {
        let hittable = self.ctx.lights.hittable();
        if !hittable && !self.ctx.scene.media_emit() {
            let l = self.direct(s, false, rng);
            return self.clamped(l, true);
        }
        let l = self.direct(s, hittable, rng);
        let mut l = self.clamped(l, true);
        if let Some((bs, wi)) = s.sample(rng.uniform(), rng.uniform2()) {
            if !bs.delta {
                let (emission, _) = self.gather_ray(s, &bs, wi, false, 1, rng);
                l += self.clamped(bs.weight * emission, true);
            }
        }
        l
    }

    /// Reflected radiance at a surface that stores photons: direct + caustics + final gather, by
    /// pass as seen from `s` (module header).
    fn shade(&mut self, s: &Shading, rng: &mut Rng) -> Passes {
        let mut passes = Passes::default();
        // Irradiance cache: a Lambertian surface takes its indirect light from the records and
        // samples only the lights; on a mixed one the cache replaces the diffuse lobe's share
        // of the gather rays' global estimates.
        let cached: Option<CachedDiffuse> = self.cache.and_then(|c| s.cached_diffuse(c));
        if let Some(d) = cached.filter(|d| d.lambertian) {
            passes.add(LightPass::Direct, self.direct_without_gather(s, rng));
            let caustic = self.caustic(s, 1);
            passes.add(LightPass::Caustic, self.clamped(caustic, false));
            passes.add(LightPass::Indirect, self.clamped(d.radiance, false));
            return passes;
        }
        // Where the cache serves the diffuse lobe, the gather rays carry only the rest of the
        // BSDF (a glossy layer's indirect light and emission): one per camera sample, as the
        // path tracer's bounce, instead of a full final gather.
        let m = match cached {
            Some(_) => self.maps.settings.gather_rays.min(1),
            None => self.maps.settings.gather_rays,
        };
        let direct = self.direct(s, m > 0, rng);
        passes.add(LightPass::Direct, self.clamped(direct, true));
        let caustic = self.caustic(s, 1);
        passes.add(LightPass::Caustic, self.clamped(caustic, false));
        if m == 0 {
            let global = self.global(s, 1);
            passes.add(LightPass::Indirect, self.clamped(global, false));
            return passes;
        }
        let n = (m as f32).sqrt() as u32;
        // Sums over the gather rays by pass.
        let mut sum = Passes::default();
        for i in 0..m {
            // Stratify the first n² directions on an n × n grid.
            let u = if i < n * n {
                let j = Vec2::new((i % n) as f32, (i / n) as f32);
                ((j + rng.uniform2()) / n as f32).min(Vec2::splat(0.999_999_94))
            } else {
                rng.uniform2()
            };
            let Some((bs, wi)) = s.sample(rng.uniform(), u) else {
                continue;
            };
            let (emission, estimate) = self.gather_ray(s, &bs, wi, true, 1, rng);
            let emission = self.clamped(bs.weight * emission, true);
            if bs.delta {
                sum.add(LightPass::Emission, emission);
                sum.add(
                    LightPass::Indirect,
                    self.clamped(bs.weight * estimate, false),
                );
            } else {
                let w = cached.map_or(bs.weight, |d| d.non_diffuse_weight(&bs));
                sum.add(LightPass::Direct, emission);
                sum.add(LightPass::Indirect, self.clamped(w * estimate, false));
            }
        }
        sum.scale(1.0 / m as f32);
        passes += sum;
        let cached = cached.map_or(Vec3::ZERO, |d| self.clamped(d.radiance, false));
        passes.add(LightPass::Indirect, cached);
        passes
    }

    /// `shade`, where on a translucent surface the subsurface term replaces the subsurface
    /// weight's share of the Lambertian part.
    fn shade_full(&mut self, s: &Shading, rng: &mut Rng) -> Passes {
        let sss = self
            .maps
            .subsurface
            .as_ref()
            .and_then(|m| m.radiance(self.ctx.scene, s));
        match sss {
            None => self.shade(s, rng),
            Some(l) => {
                let weight = s.surface.subsurface.weight;
                let rest = Shading {
                    bsdf: s.bsdf.without_subsurface(weight),
                    ..*s
                };
                let mut passes = self.shade(&rest, rng);
                passes.add(LightPass::Subsurface, self.clamped(l, false));
                passes
            }
        }
    }

    /// Photon dots: the nearest photon within a small radius, white (global) or orange (caustic).
    fn dots(&mut self, s: &Shading) -> Vec3 {
        let maps = self.maps;
        for (map, colour) in [
            (&maps.caustic, Vec3::new(1.0, 0.5, 0.1)),
            (&maps.global, Vec3::ONE),
        ] {
            if let Some(m) = map {
                m.nearest(s.sh.p, 1, maps.dot_radius2, &mut self.buf);
                if !self.buf.is_empty() {
                    return colour;
                }
            }
        }
        Vec3::ZERO
    }
}

/// The photon method's part in the camera walk: glossy surfaces are ray traced as the path
/// tracer does (light sampling with MIS in the full view), and the first surface that stores
/// photons is shaded by the view, which ends the path.
struct PhotonCamera<'a> {
    gather: Gather<'a>,
    view: View,
}

impl Scatter for PhotonCamera<'_> {
    fn counts_emission(&self) -> bool {
        matches!(self.view, View::Full | View::Global)
    }

    /// The full view walks translucent objects; Christensen–Burley materials take the dipole
    /// when its samples were built. The debug views show their estimate on the surface itself.
    fn walks_subsurface(&self, subsurface: &Subsurface) -> bool {
        self.view == View::Full
            && (subsurface.method != SubsurfaceMethod::ChristensenBurley
                || self.gather.maps.subsurface.is_none())
    }

    /// The full view reads media from the volume photon map instead of scattering in them.
    fn scatters_in_media(&self) -> bool {
        self.view != View::Full
    }

    /// Single scattering by a light sample and the volume map's estimate of the rest (the light
    /// of photons that scattered before), the camera path only attenuated through the media.
    fn media_segment(&mut self, path: &mut PathState, reach: f32, rng: &mut Rng) {
        let g = &mut self.gather;
        g.depth = path.depth;
        let single = path.light_scattered_on_segment(g.ctx, reach, rng, &mut g.rays);
        path.add_in_medium(1, single);
        let multiple = g.volume_estimate(&path.ray, reach, &path.media, rng);
        path.add_in_medium(2, path.beta * multiple);
    }

    fn scatter(&mut self, path: &mut PathState, s: &mut Shading, rng: &mut Rng) -> Next {
        let g = &mut self.gather;
        g.depth = path.depth;
        if stores_photons(&s.bsdf) {
            if path.clamp.is_on() {
                g.clamp = path.clamp;
                g.beta = path.beta;
                g.direct_clamp = path.direct_clamp(1);
            }
            let mut l = Passes::default();
            match self.view {
                View::Full => l = g.shade_full(s, rng),
                View::Global => l.add(LightPass::Indirect, g.global(s, 1)),
                View::Caustic => l.add(LightPass::Caustic, g.caustic(s, 1)),
                View::Photons => l.add(LightPass::Indirect, g.dots(s)),
            };
            path.add_estimate(&l);
            return Next::End;
        }
        let light_sampled = self.view == View::Full && s.bsdf.has_non_delta();
        if light_sampled {
            let l = path.beta * g.direct(s, true, rng);
            path.add(1, l);
        }
        Next::Continue { light_sampled }
    }
}

/// One camera sample of the photon method's `view`, with the irradiance cache when given.
pub fn trace(
    ctx: &Context,
    maps: &PhotonMaps,
    cache: Option<&IrradianceCache>,
    view: View,
    camera_ray: Ray,
    rng: &mut Rng,
) -> CameraSample {
    let mut camera = PhotonCamera {
        gather: Gather::new(ctx, maps, cache),
        view,
    };
    let mut out = walk(ctx, camera_ray, rng, false, &mut camera);
    out.rays += camera.gather.rays;
    out
}

/// Radiance arriving at `s` along `wi` for an irradiance-cache record, with the distance of the
/// first hit: the global estimate behind specular surfaces, as a final-gather ray reads it, but
/// without emission (the cached point samples its lights itself); through media, attenuated
/// and with the light they scatter towards `s` (`s.media`: the media at the record, which
/// `cache::build_cache` finds once per record).
pub fn cache_gather(
    ctx: &Context,
    maps: &PhotonMaps,
    s: &Shading,
    wi: Vec3,
    rng: &mut Rng,
) -> Incoming {
    let mut gather = Gather::new(ctx, maps, None);
    let local = s.frame.to_local(wi);
    // The records' gather rays are cosine-distributed: the density Filter Glossy reads.
    let bs = BsdfSample {
        wi: local,
        weight: Vec3::ONE,
        pdf: local.z.abs() / PI,
        delta: false,
        transmitted: false,
        scattering: Scattering::Diffuse,
    };
    let (met, along) = match gather.cast(s, &bs, wi, Vec3::ZERO, true, rng) {
        Ok(met) => met,
        Err((_, scattered)) => {
            return Incoming {
                radiance: scattered,
                ..Incoming::NONE
            }
        }
    };
    let normal = met.y.frame.n;
    let mut chain = Chain {
        length: met.distance,
        beta: along.through,
        ..Chain::new(Vec3::ZERO)
    };
    let mut radiance = match follow_specular(ctx, met.y, &mut chain, rng, &mut gather.rays, None) {
        Some(d) => chain.beta * gather.gather_estimate(&d, 2, chain.length, rng),
        None => Vec3::ZERO,
    };
    if along.scattered != Vec3::ZERO {
        radiance += along.scattered;
    }
    Incoming {
        radiance,
        distance: met.distance,
        normal,
    }
}
