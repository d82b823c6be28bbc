//! Lights as the integrators see them: every emitter of the scene (emissive triangles, point,
//! spot and sun lights, the world background) in one list, a light chosen by power or, among a
//! few lights, partly by its irradiance at the shading point (below), with `sample` (a
//! direction towards a light, for next-event estimation) and the matching densities for
//! multiple importance sampling (Veach 1997, ch. 9).
//!
//! An instance of an emitting prototype mesh is one light: a triangle of the prototype is
//! picked in proportion to its object-space area, and the point drawn on it is placed where the
//! instance is at the ray's (or photon's) moment, so moving emitters are sampled where they
//! are; the density is the picking probability over the triangle's area at that moment.
//!
//! Units follow Cycles (docs/ARCHITECTURE.md): triangle and world radiance as given, point and spot
//! intensity in W/sr, sun irradiance in W/m².
//!
//! A point or spot light with a radius is a lamp as Cycles 4 defines it (`kernel/light/point.h`,
//! `spot.h`): uniform radiance I / (πr²) over a disc of radius r facing the point it lights
//! (Blender's Soft Falloff, the default) or over a sphere. Light sampling draws a direction
//! uniformly in the cone the lamp fills; rays that surfaces scatter meet it too
//! (`Lights::lamps_met`, which the camera walk calls on every segment), so both are weighted by
//! MIS with the same density, select probability / the cone's solid angle. Lamps are not
//! geometry: rays pass through them, shadow rays ignore them; past eight lamps a small BVH over
//! their spheres keeps a ray from testing them all.
//!
//! Which light a sample goes to: in proportion to the power of each light for scenes of many
//! lights. With at most `MAX_LOCAL_LIGHTS` (and no emitting instance or deforming emitter), half
//! of the samples still go by power and half in proportion to an estimate of the irradiance
//! each light brings to the shading point (`LocalSelection`: its power over the squared
//! distance, the distance clamped by its size; none from a one-sided triangle behind whose
//! plane the point lies; a sun's irradiance), as Cycles' light tree weighs its leaves by
//! energy, orientation and distance (Conty Estevez and Kulla 2018, "Importance Sampling of Many
//! Lights with Adaptive Tree Splitting"). A near lamp then gets samples a far sun of more total
//! power would take; the half by power (a defensive mixture, Hesterberg 1995) keeps every
//! light's share at least half of what it was, which the estimate, blind to the surface's
//! orientation and to shadows, could otherwise starve. Seen from an opaque surface (a `Receiver`
//! with a horizon), a light wholly below the plane of its geometric normal (a triangle's or
//! lamp's bounding sphere, a sun's disc) can light nothing there, so both halves leave it out,
//! as Cycles' light tree leaves out lights outside the shading normal's hemisphere. The
//! densities MIS reads are computed at the vertex the ray left, from the same `Receiver`.
//!
//! A world of one constant colour is left out of the light samples that are weighed by MIS
//! against BSDF sampling, as Cycles leaves it out ("Background MIS has been disabled" in
//! `LightManager::test_enabled_lights`, unless the background varies or portals exist): BSDF
//! sampling finds a uniform sky as well as a uniform light sample does on a diffuse surface, far
//! better on a glossy one, and never wastes a direction below the horizon, so the light samples
//! all go to the lights that need them (the sun). A light sample without a BSDF counterpart
//! (`mis` false: the photon method's direct light without gather rays) still draws from every
//! light.
//!
//! An environment map (`EnvironmentLight`) is importance-sampled with a 2D piecewise-constant
//! distribution over its pixels weighted by luminance × sin θ, mapped to the sphere with the
//! Jacobian 2π² sin θ (pbrt-v4 §12.5.2, "Image infinite lights").

use crate::accel::Ray;
use crate::bsdf::Bsdf;
use crate::interaction::{LightPoint, SurfaceHit};
use crate::material::{from_closure, SurfaceMaterial};
use crate::math::{luminance, Frame, Vec2, Vec3};
use crate::math::{Affine3A, Mat3};
use crate::sampling::{
    square_to_triangle, square_to_uniform_cone, square_to_uniform_sphere, uniform_cone_pdf,
    Distribution1D, Distribution2D, UNIFORM_SPHERE_PDF,
};
use crate::scene::Lamp;
use crate::scene::{Environment, Light, Mesh, Scene};
use crate::shader::RayPath;
use std::f32::consts::PI;

/// One emitter.
#[derive(Clone, Debug)]
pub enum LightSource {
    /// A triangle of a mesh whose material emits; radiance comes from the material at the point.
    Triangle {
        mesh: u32,
        triangle: u32,
        area: f32,
        two_sided: bool,
    },
    /// An instance of a prototype whose material emits (`Scene::instances`): one of its
    /// triangles, picked by `Lights::prototype_triangles`, where the instance is at the
    /// sample's moment. `area` is its world area when still (for its share of samples).
    Instance {
        instance: u32,
        area: f32,
        two_sided: bool,
    },
    /// `radius` > 0 makes it a lamp of uniform radiance I / (πr²) as Cycles makes Blender's
    /// point light: a disc of that radius facing the viewer (Soft Falloff) or a sphere
    /// (`lamp_cone`); the same intensity far away, soft shadows near it, and seen by the rays
    /// `lamp` names (`Lights::lamps_met`).
    Point {
        position: Vec3,
        intensity: Vec3,
        radius: f32,
        lamp: Lamp,
    },
    /// A spot: a point light (or lamp, as `Point`) within the cone `cos_outer`..`cos_inner`
    /// around `direction`, evaluated along each ray that leaves the lamp.
    Spot {
        position: Vec3,
        direction: Vec3,
        intensity: Vec3,
        cos_inner: f32,
        cos_outer: f32,
        radius: f32,
        lamp: Lamp,
    },
    /// A sun: `to_sun` points from the scene towards the sun; a cone of half-angle θ with
    /// cos θ = `cos_max` (1 for a hard sun, which is then a delta light).
    Sun {
        to_sun: Vec3,
        irradiance: Vec3,
        cos_max: f32,
    },
    /// The world background; `radiance` is its average over the sphere (the constant colour,
    /// or the environment map's mean), which sets its share of light and photon samples.
    World { radiance: Vec3 },
}

/// A sampled direction towards a light.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Radiance arriving along `wi` (for delta lights: intensity / d² or irradiance), before
    /// dividing by `pdf`.
    pub li: Vec3,
    /// Unit direction from the shading point towards the light.
    pub wi: Vec3,
    /// Density per unit solid angle, including the probability of choosing this light; for delta
    /// lights only that probability.
    pub pdf: f32,
    /// The light cannot be reached by BSDF-sampled rays (a point, a hard sun, a lamp hidden
    /// from scattered rays or so far that it is a point): its sample is used without MIS.
    pub delta: bool,
    /// Where the shadow ray must reach.
    pub target: LightPoint,
}

/// Where a light sample is drawn from: the point and, on an opaque surface, its geometric
/// normal turned to the viewer, below whose plane no light reaches what the surface scatters
/// (`LocalSelection` then leaves out the lights wholly below it).
#[derive(Clone, Copy, Debug)]
pub struct Receiver {
    pub p: Vec3,
    pub horizon: Option<Vec3>,
}

impl Receiver {
    /// A point that may be lit from every direction.
    pub fn at(p: Vec3) -> Receiver {
        Receiver { p, horizon: None }
    }
}

/// All emitters of a scene and the distribution that picks one.
pub struct Lights {
    pub sources: Vec<LightSource>,
    /// Picks the light of a sample weighed by MIS against BSDF sampling: every light but a
    /// constant world (module header). The densities MIS reads (`triangle_pdf`, `lamps_met`,
    /// `escaped`) are this one's.
    select: Distribution1D,
    /// Picks the light of a sample without MIS, from every light; `None` when that is `select`.
    select_all: Option<Distribution1D>,
    /// With few lights, `select`'s weights turned into each light's irradiance at the shading
    /// point (module header): samples weighed by MIS pick half by it, half by `select`.
    local: Option<LocalSelection>,
    /// For each mesh, the index of its first triangle light (triangle lights are contiguous).
    mesh_first_light: Vec<Option<u32>>,
    /// For each instance, its light (`LightSource::Instance`) when its prototype emits; empty
    /// when none does.
    instance_light: Vec<Option<u32>>,
    /// For each prototype, the distribution that picks one of its triangles (by object-space
    /// area) when its material emits.
    prototype_triangles: Vec<Option<Distribution1D>>,
    /// Some light can be met by a ray: an emitting mesh, the world, a sun with a disk or a lamp
    /// seen by scattered rays (checked per camera sample by the photon method, so kept, not
    /// searched).
    hittable: bool,
    /// The lamps rays can meet (point and spot lights with a radius, `lamps_met`).
    lamps: LampSet,
    world: Option<u32>,
    environment: Option<EnvironmentLight>,
    suns: Vec<u32>,
    scene_center: Vec3,
    scene_radius: f32,
    /// Some material lets shadow rays through where its node tree gives a Transparent BSDF:
    /// shadow rays then evaluate the surfaces they meet (`direct::shadow_transmittance`).
    pub transparent_shadows: bool,
}

pub fn smoothstep(edge0: f32, edge1: f32, x: f32) -> f32 {
    if edge1 <= edge0 {
        return if x >= edge0 { 1.0 } else { 0.0 };
    }
    let t = ((x - edge0) / (edge1 - edge0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Smallest spread an area light is given: narrower ones are lasers that nothing samples.
const MIN_SPREAD: f32 = 1e-3;

/// Cycles' area-light spread as a factor on the radiance towards a direction at cos a to the
/// normal: a soft-box grid lets through (tan h − tan a) / (tan h − h) for a < h = spread/2, and
/// nothing beyond. The cosine-weighted integral of the factor over the hemisphere is π, so the
/// light's power is unchanged. 1 without a spread.
pub fn spread_factor(spread: Option<f32>, cos: f32) -> f32 {
    let Some(spread) = spread else {
        return 1.0;
    };
    if cos <= 0.0 {
        return 0.0;
    }
    let half = 0.5 * spread.max(MIN_SPREAD);
    let tan_half = half.tan();
    let tan_a = (1.0 - cos * cos).max(0.0).sqrt() / cos;
    // tan h − h loses its digits for small h; its series h³/3 does not.
    let normalize = if half > 0.05 {
        1.0 / (tan_half - half)
    } else {
        3.0 / (half * half * half)
    };
    ((tan_half - tan_a) * normalize).max(0.0)
}

/// Emitted radiance of a surface towards `wo` (unit, pointing away from the surface), whose
/// material evaluated there emits `emission` (`SurfaceMaterial::emission`).
pub fn emitted_radiance(scene: &Scene, hit: &SurfaceHit, wo: Vec3, emission: Vec3) -> Vec3 {
    let material = &scene.materials[hit.material as usize];
    if !material.is_emissive() {
        return Vec3::ZERO;
    }
    if !material.double_sided && wo.dot(hit.ng) <= 0.0 {
        return Vec3::ZERO;
    }
    let spread = crate::accel::hit_mesh(scene, &hit.hit).emission_spread;
    emission * spread_factor(spread, wo.dot(hit.ng).abs())
}

/// A material's emitted radiance at texture coordinate `uv` (emission × emissive texture).
fn material_emission(scene: &Scene, material: &crate::scene::Material, uv: Vec2) -> Vec3 {
    match &material.emissive_texture {
        Some(tex) => {
            material.emission
                * scene.textures[tex.texture as usize]
                    .sample(tex.apply(uv))
                    .truncate()
        }
        None => material.emission,
    }
}

/// The emission of `surface` towards unit direction `wo` at a point whose shading normal `n`
/// faces `wo`'s side, as Cycles evaluates an emitter it samples as a light: dimmed by the
/// coat's tint seen from `wo`, but not by the coat's or the sheen's reflection (Cycles
/// evaluates a sampled emitter without allocating closures, so those layers' albedos are not
/// computed; a ray that meets the surface sees both, as `integrator::shading::Shading` dims
/// it). Light sampling and photon emission read it here.
fn sampled_emission(surface: &SurfaceMaterial, n: Vec3, wo: Vec3) -> Vec3 {
    if surface.coat_weight <= 0.0 || surface.coat_tint == Vec3::ONE {
        return surface.emission;
    }
    let toward = |v: Vec3| if v.dot(n) < 0.0 { -v } else { v };
    let frame = Frame::from_normal(surface.normal.map_or(n, toward));
    let mut bsdf = Bsdf::new(surface);
    if let Some(c) = surface.coat_normal {
        bsdf = bsdf.with_coat_normal(frame.to_local(toward(c)));
    }
    surface.emission * bsdf.coat_tint_seen(frame.to_local(wo))
}

/// A point drawn uniformly on an emissive triangle.
#[derive(Clone, Copy, Debug)]
pub struct EmitterPoint {
    /// Position with its error bound and the unit winding normal (zero if degenerate).
    pub point: LightPoint,
    /// Emitted radiance there (towards the sides the material emits to).
    pub radiance: Vec3,
}

/// A point drawn on an emitter (`LightSource::Triangle` or `Instance`) at some moment.
#[derive(Clone, Copy, Debug)]
pub struct EmitterSample {
    pub emitter: EmitterPoint,
    /// One over the point's density per unit area: the triangle's area divided by the
    /// probability of picking it (an instance's triangle, at the sample's moment).
    pub area: f32,
    pub two_sided: bool,
    /// The emitting mesh's area-light spread (`Mesh::emission_spread`).
    pub spread: Option<f32>,
}

/// Draw a point uniformly on triangle `triangle` of mesh `m` with `u`: the one routine both
/// light sampling and photon emission use. `placed` takes a prototype's triangle, deformed as
/// at moment `time`, to world space (an instance at that moment; `None` for a world-space
/// mesh). A node tree's
/// emission, and the dimming by a coat's tint above it (`sampled_emission`), are
/// evaluated as seen from `seen_from` (light sampling: the shaded point, its distance and the
/// path there, as Cycles evaluates a sampled emitter), or head-on at distance 0 by a ray of no
/// kind (photons leave in a direction drawn afterwards: their coat dimming is the head-on one).
pub fn sample_emitter_point(
    scene: &Scene,
    m: &Mesh,
    triangle: u32,
    placed: Option<Affine3A>,
    time: f32,
    u: Vec2,
    seen_from: Option<(Vec3, RayPath)>,
) -> EmitterPoint {
    let idx = m.indices[triangle as usize];
    let v = m.triangle_at(triangle, time).map(|q| match placed {
        Some(to_world) => to_world.transform_point3(q),
        None => q,
    });
    let b = square_to_triangle(u);
    let b0 = 1.0 - b.x - b.y;
    let p = v[0] * b0 + v[1] * b.x + v[2] * b.y;
    let p_error =
        crate::math::gamma(6) * ((v[0] * b0).abs() + (v[1] * b.x).abs() + (v[2] * b.y).abs());
    let mut n = (v[1] - v[0]).cross(v[2] - v[0]).normalize_or_zero();
    if placed.is_some_and(|to_world| to_world.matrix3.determinant() < 0.0) {
        // A mirrored instance keeps the side of its winding, as `SurfaceHit::new` does.
        n = -n;
    }
    let uv = if m.uvs.is_empty() {
        Vec2::ZERO
    } else {
        let t = idx.map(|i| m.uvs[i as usize]);
        t[0] * b0 + t[1] * b.x + t[2] * b.y
    };
    let material = &scene.materials[m.material as usize];
    // glTF's clearcoat has no tint: only a node tree's coat dims a sampled emitter.
    let radiance = if let Some(program) = &material.nodes {
        let linear = placed.map(|to_world| Mat3::from(to_world.matrix3));
        let normal = |i: u32| match linear {
            Some(l) => l.inverse().transpose() * m.normals[i as usize],
            None => m.normals[i as usize],
        };
        let shading_n = crate::accel::interpolate(idx.map(normal), b.x, b.y).normalize_or(n);
        let view = match seen_from {
            Some((o, path)) => {
                let wo = (o - p).normalize_or(shading_n);
                crate::interaction::View {
                    wo,
                    backfacing: wo.dot(n) < 0.0,
                    path: path.emission(),
                    ray_length: o.distance(p),
                }
            }
            None => crate::interaction::View {
                wo: shading_n,
                backfacing: false,
                path: RayPath::default(),
                ray_length: 0.0,
            },
        };
        let facing = if view.backfacing {
            -shading_n
        } else {
            shading_n
        };
        let at = crate::interaction::node_inputs(m, triangle, b.x, b.y, p, facing, view, linear);
        let surface = from_closure(material, &program.eval(&at, &scene.textures, 0.5));
        sampled_emission(&surface, facing, view.wo)
    } else {
        material_emission(scene, material, uv)
    };
    EmitterPoint {
        point: LightPoint {
            p,
            p_error,
            n,
            distant: false,
        },
        radiance,
    }
}

impl Lights {
    pub fn new(scene: &Scene) -> Self {
        let bounds = scene.bounds();
        let (scene_center, scene_radius) = if bounds.is_empty() {
            (Vec3::ZERO, 1.0)
        } else {
            (bounds.center(), (0.5 * bounds.diagonal()).max(1e-6))
        };
        let mut sources = Vec::new();
        let mut power = Vec::new();
        // For `LocalSelection`: where each light is, and its power over what turns power over
        // squared distance into irradiance.
        let mut reach = Vec::new();
        let mut reach_scale = Vec::new();
        let mut local_possible = true;
        let mut mesh_first_light = vec![None; scene.meshes.len()];
        for (mi, mesh) in scene.meshes.iter().enumerate() {
            let material = &scene.materials[mesh.material as usize];
            if !material.is_emissive() {
                continue;
            }
            mesh_first_light[mi] = Some(sources.len() as u32);
            let sides = if material.double_sided { 2.0 } else { 1.0 };
            for (ti, idx) in mesh.indices.iter().enumerate() {
                let p = idx.map(|i| mesh.positions[i as usize]);
                let area = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length();
                let area = if area.is_finite() { area } else { 0.0 };
                sources.push(LightSource::Triangle {
                    mesh: mi as u32,
                    triangle: ti as u32,
                    area,
                    two_sided: material.double_sided,
                });
                power.push(PI * luminance(material.emission) * area * sides);
                let normal = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
                reach.push(Reach::near(&p, (!material.double_sided).then_some(normal)));
                reach_scale.push(1.0 / (PI * sides));
                local_possible &= mesh.deformation.len() <= 1;
            }
        }
        let prototype_triangles: Vec<Option<Distribution1D>> = scene
            .prototypes
            .iter()
            .map(|mesh| {
                scene.materials[mesh.material as usize]
                    .is_emissive()
                    .then(|| Distribution1D::new(&triangle_areas(mesh)))
            })
            .collect();
        let mut instance_light = Vec::new();
        if prototype_triangles.iter().any(Option::is_some) {
            instance_light = vec![None; scene.instances.len()];
            for (i, instance) in scene.instances.iter().enumerate() {
                let prototype = instance.prototype as usize;
                let Some(triangles) = &prototype_triangles[prototype] else {
                    continue;
                };
                let mesh = &scene.prototypes[prototype];
                let material = &scene.materials[mesh.material as usize];
                // The object-space area scaled by the transform's mean areal factor (exact for
                // uniform scale): the share of samples only, never the density.
                let det = Mat3::from(instance.to_world.matrix3).determinant().abs();
                let area = triangles.total() as f32 * det.powf(2.0 / 3.0);
                let area = if area.is_finite() { area } else { 0.0 };
                let sides = if material.double_sided { 2.0 } else { 1.0 };
                instance_light[i] = Some(sources.len() as u32);
                local_possible = false;
                reach.push(Reach::Distant);
                reach_scale.push(0.0);
                sources.push(LightSource::Instance {
                    instance: i as u32,
                    area,
                    two_sided: material.double_sided,
                });
                power.push(PI * luminance(material.emission) * area * sides);
            }
        }
        let mut suns = Vec::new();
        for light in &scene.lights {
            match *light {
                Light::Point {
                    position,
                    intensity,
                    radius,
                    lamp,
                } => {
                    sources.push(LightSource::Point {
                        position,
                        intensity,
                        radius,
                        lamp,
                    });
                    power.push(4.0 * PI * luminance(intensity));
                    reach.push(Reach::sphere(position, radius));
                    reach_scale.push(1.0 / (4.0 * PI));
                }
                Light::Spot {
                    position,
                    direction,
                    intensity,
                    cos_inner,
                    cos_outer,
                    radius,
                    lamp,
                } => {
                    sources.push(LightSource::Spot {
                        position,
                        direction: direction.normalize_or(-Vec3::Z),
                        intensity,
                        cos_inner,
                        cos_outer,
                        radius,
                        lamp,
                    });
                    power.push(4.0 * PI * luminance(intensity));
                    reach.push(Reach::sphere(position, radius));
                    reach_scale.push(1.0 / (4.0 * PI));
                }
                Light::Sun {
                    direction,
                    irradiance,
                    angle,
                } => {
                    suns.push(sources.len() as u32);
                    let half = (0.5 * angle).clamp(0.0, 0.5 * PI);
                    sources.push(LightSource::Sun {
                        to_sun: -direction.normalize_or(-Vec3::Z),
                        irradiance,
                        cos_max: if half > 0.0 { half.cos() } else { 1.0 },
                    });
                    power.push(luminance(irradiance) * PI * scene_radius * scene_radius);
                    reach.push(Reach::Sun {
                        to_sun: -direction.normalize_or(-Vec3::Z),
                        sin_half: half.sin(),
                    });
                    reach_scale.push(1.0 / (PI * scene_radius * scene_radius));
                }
            }
        }
        let mut world = None;
        let background = &scene.world.background;
        let environment = background.environment.as_ref().map(EnvironmentLight::new);
        let radiance = match &environment {
            Some(env) => env.average,
            None => background.color,
        };
        let mut select_all = None;
        if luminance(radiance) > 0.0 {
            world = Some(sources.len() as u32);
            sources.push(LightSource::World { radiance });
            let world_power = PI * PI * luminance(radiance) * scene_radius * scene_radius;
            reach.push(Reach::Distant);
            reach_scale.push(1.0 / (PI * scene_radius * scene_radius));
            if environment.is_some() {
                power.push(world_power);
            } else {
                let mut all = power.clone();
                all.push(world_power);
                select_all = Some(Distribution1D::new(&all));
                power.push(0.0);
            }
        }
        let soft_sun = suns.iter().any(
            |&s| matches!(sources[s as usize], LightSource::Sun { cos_max, .. } if cos_max < 1.0),
        );
        let emitting_mesh = mesh_first_light.iter().any(Option::is_some)
            || instance_light.iter().any(Option::is_some);
        let transparent_shadows = scene.materials.iter().any(|m| {
            m.nodes
                .as_ref()
                .is_some_and(|program| program.shadow_transparent)
        });
        let lamps = LampSet::new(&sources);
        let local = local_possible
            .then(|| LocalSelection::new(&power, &reach, &reach_scale))
            .flatten();
        Lights {
            transparent_shadows,
            hittable: emitting_mesh || world.is_some() || soft_sun || lamps.seen_by_bounces,
            lamps,
            sources,
            select: Distribution1D::new(&power),
            select_all,
            local,
            mesh_first_light,
            instance_light,
            prototype_triangles,
            world,
            environment,
            suns,
            scene_center,
            scene_radius,
        }
    }

    pub fn is_empty(&self) -> bool {
        self.select.is_empty()
            && self
                .select_all
                .as_ref()
                .is_none_or(Distribution1D::is_empty)
    }

    /// True when a ray can meet some light (an emitting mesh, the world, a sun with a disk, a
    /// lamp seen by scattered rays), so that BSDF sampling can find what light sampling also
    /// does.
    pub fn hittable(&self) -> bool {
        self.hittable
    }

    /// A point far enough along `dir` from `p` to be outside the scene: the end of shadow rays
    /// towards distant lights.
    fn far_point(&self, p: Vec3, dir: Vec3) -> LightPoint {
        let reach = 2.0 * (self.scene_radius + (p - self.scene_center).length());
        LightPoint {
            p: p + dir * reach,
            p_error: Vec3::ZERO,
            n: Vec3::ZERO,
            distant: true,
        }
    }

    /// Pick a light with `u_select` and sample a direction towards it from `from`, seen at moment
    /// `time` of the shutter (where moving emitters are then).
    /// `path`: the path at `from`, which an emitter's node tree reads as it is sampled from
    /// there (`RayPath::emission`). `mis`: the sample will be weighed by MIS against BSDF
    /// sampling, which alone finds a constant world (module header); without it every light
    /// may be picked.
    #[allow(clippy::too_many_arguments)]
    pub fn sample(
        &self,
        scene: &Scene,
        from: Receiver,
        path: RayPath,
        time: f32,
        mis: bool,
        u_select: f32,
        u: Vec2,
    ) -> Option<LightSample> {
        let p = from.p;
        let (index, pmf, u_pick) = match (&self.local, &self.select_all, mis) {
            (_, Some(all), false) => all.sample_remapped(u_select)?,
            (Some(local), _, true) => local.sample(from, u_select, &self.select)?,
            _ => self.select.sample_remapped(u_select)?,
        };
        let mut s = self.sample_source(scene, index, (p, path), time, u_pick, u)?;
        s.pdf *= pmf;
        (s.pdf > 0.0 && s.pdf.is_finite()).then_some(s)
    }

    /// A point on emitting geometry `index` (`LightSource::Triangle` or `Instance`) drawn with
    /// `u` at moment `time`, `u_pick` picking an instance's triangle; `seen_from` as for
    /// `sample_emitter_point`. `None` for other lights and degenerate triangles.
    pub fn sample_emitter(
        &self,
        scene: &Scene,
        index: usize,
        u_pick: f32,
        u: Vec2,
        time: f32,
        seen_from: Option<(Vec3, RayPath)>,
    ) -> Option<EmitterSample> {
        match self.sources[index] {
            LightSource::Triangle {
                mesh,
                triangle,
                area,
                two_sided,
            } => {
                let m = &scene.meshes[mesh as usize];
                (area > 0.0).then(|| EmitterSample {
                    emitter: sample_emitter_point(scene, m, triangle, None, time, u, seen_from),
                    area,
                    two_sided,
                    spread: m.emission_spread,
                })
            }
            LightSource::Instance {
                instance,
                two_sided,
                ..
            } => {
                let instance = &scene.instances[instance as usize];
                let prototype = instance.prototype as usize;
                let (triangle, pmf) = self.prototype_triangles[prototype]
                    .as_ref()?
                    .sample(u_pick)?;
                let m = &scene.prototypes[prototype];
                let to_world = instance.to_world_at(time);
                let area = placed_area(m, triangle as u32, to_world, time);
                let (triangle, placed) = (triangle as u32, Some(to_world));
                let emitter = sample_emitter_point(scene, m, triangle, placed, time, u, seen_from);
                (area > 0.0 && pmf > 0.0).then_some(EmitterSample {
                    emitter,
                    area: area / pmf,
                    two_sided,
                    spread: m.emission_spread,
                })
            }
            _ => None,
        }
    }

    fn sample_source(
        &self,
        scene: &Scene,
        index: usize,
        from: (Vec3, RayPath),
        time: f32,
        u_pick: f32,
        u: Vec2,
    ) -> Option<LightSample> {
        let p = from.0;
        match self.sources[index] {
            LightSource::Triangle { .. } | LightSource::Instance { .. } => {
                let EmitterSample {
                    emitter,
                    area,
                    two_sided,
                    spread,
                } = self.sample_emitter(scene, index, u_pick, u, time, Some(from))?;
                let (q, n) = (emitter.point.p, emitter.point.n);
                let d = q - p;
                let dist2 = d.length_squared();
                if !(dist2 > 0.0) {
                    return None;
                }
                let wi = d / dist2.sqrt();
                let cos_l = -wi.dot(n);
                if cos_l <= 0.0 && !two_sided {
                    return None;
                }
                let cos_l = cos_l.abs();
                if cos_l <= 0.0 {
                    return None;
                }
                let spread = spread_factor(spread, cos_l);
                if spread <= 0.0 {
                    return None;
                }
                Some(LightSample {
                    li: emitter.radiance * spread,
                    wi,
                    pdf: dist2 / (cos_l * area),
                    delta: false,
                    target: emitter.point,
                })
            }
            LightSource::Point {
                position,
                intensity,
                radius,
                lamp,
            } => {
                let s = sample_punctual(position, radius, lamp, None, p, u)?;
                Some(LightSample {
                    li: intensity * s.scale,
                    ..s.sample
                })
            }
            LightSource::Spot {
                position,
                direction,
                intensity,
                cos_inner,
                cos_outer,
                radius,
                lamp,
            } => {
                let spread = spot_spread(&self.sources[index]);
                let s = sample_punctual(position, radius, lamp, spread, p, u)?;
                // As Cycles: the cone is evaluated along the sampled ray, from the sampled point
                // of the lamp, which widens it by about the radius (a point: from the centre).
                let falloff = match s.inside {
                    true => 1.0,
                    false => smoothstep(cos_outer, cos_inner, -s.sample.wi.dot(direction)),
                };
                if falloff <= 0.0 {
                    return None;
                }
                Some(LightSample {
                    li: intensity * (falloff * s.scale),
                    ..s.sample
                })
            }
            LightSource::Sun {
                to_sun,
                irradiance,
                cos_max,
            } => {
                if cos_max >= 1.0 {
                    return Some(LightSample {
                        li: irradiance,
                        wi: to_sun,
                        pdf: 1.0,
                        delta: true,
                        target: self.far_point(p, to_sun),
                    });
                }
                let wi = Frame::from_normal(to_sun).to_world(square_to_uniform_cone(u, cos_max));
                Some(LightSample {
                    li: sun_disk_radiance(irradiance, cos_max),
                    wi,
                    pdf: uniform_cone_pdf(cos_max),
                    delta: false,
                    target: self.far_point(p, wi),
                })
            }
            LightSource::World { .. } => {
                let (wi, li, pdf) = self.sample_world(u)?;
                Some(LightSample {
                    li,
                    wi,
                    pdf,
                    delta: false,
                    target: self.far_point(p, wi),
                })
            }
        }
    }

    /// Solid-angle density with which `sample` would have chosen the point `hit` on an emissive
    /// triangle, seen from `from` (for MIS when a BSDF-sampled ray hits an emitter).
    pub fn triangle_pdf(&self, scene: &Scene, from: Receiver, hit: &SurfaceHit) -> f32 {
        if hit.hit.instance != crate::accel::NO_INSTANCE {
            return self.instance_triangle_pdf(scene, from, hit);
        }
        let Some(first) = self
            .mesh_first_light
            .get(hit.mesh as usize)
            .copied()
            .flatten()
        else {
            return 0.0;
        };
        let index = (first + hit.triangle) as usize;
        let LightSource::Triangle { area, .. } = self.sources[index] else {
            return 0.0;
        };
        let d = hit.p - from.p;
        let dist2 = d.length_squared();
        let cos_l = (d.normalize_or_zero().dot(hit.ng)).abs();
        if area <= 0.0 || cos_l <= 0.0 {
            return 0.0;
        }
        self.pick_pmf(from, index) * dist2 / (cos_l * area)
    }

    /// `triangle_pdf` of a point on an instance: the instance's share, its triangle's, and the
    /// triangle's area where the instance is at the hit's moment.
    fn instance_triangle_pdf(&self, scene: &Scene, from: Receiver, hit: &SurfaceHit) -> f32 {
        let Some(index) = self
            .instance_light
            .get(hit.hit.instance as usize)
            .copied()
            .flatten()
        else {
            return 0.0;
        };
        let instance = &scene.instances[hit.hit.instance as usize];
        let Some(triangles) = &self.prototype_triangles[instance.prototype as usize] else {
            return 0.0;
        };
        let mesh = &scene.prototypes[instance.prototype as usize];
        let area = placed_area(mesh, hit.triangle, instance.to_world_at(hit.time), hit.time);
        let d = hit.p - from.p;
        let dist2 = d.length_squared();
        let cos_l = (d.normalize_or_zero().dot(hit.ng)).abs();
        if !(area > 0.0) || cos_l <= 0.0 {
            return 0.0;
        }
        self.pick_pmf(from, index as usize) * triangles.pmf(hit.triangle as usize) * dist2
            / (cos_l * area)
    }

    /// The lamps (point and spot lights with a radius) `ray` meets before distance `reach`
    /// along it (in units of its direction's length, as `Hit::t` × that length): for each,
    /// `visit(radiance, pdf, distance)` with the radiance arriving along the ray (a spot's cone
    /// evaluated along it, as Cycles does), the density with which light sampling from the
    /// ray's origin draws that direction (with the probability of picking the lamp; for MIS)
    /// and the lamp's distance. `camera`: a camera ray, which sees the lamps Blender shows the
    /// camera; any other ray is one a surface scattered. As in Cycles a lamp is not geometry:
    /// the ray passes through it (Cycles counts a transparent bounce), so every lamp on the way
    /// counts. From inside a sphere lamp a ray meets its far side. `from`: the vertex the ray
    /// left, where the light sample it is weighed against was drawn.
    pub fn lamps_met(
        &self,
        ray: &Ray,
        from: Receiver,
        reach: f32,
        camera: bool,
        mut visit: impl FnMut(Vec3, f32, f32),
    ) {
        if self.lamps.lamps.is_empty() {
            return;
        }
        let length = ray.direction.length();
        if !(length > 0.0 && length.is_finite()) {
            return;
        }
        let (o, w) = (ray.origin, ray.direction / length);
        self.lamps.candidates(o, w, reach, |i| {
            let source = &self.sources[i as usize];
            let Some((position, radius, lamp)) = lamp_of(source) else {
                return;
            };
            if !(if camera { lamp.camera } else { lamp.bounces }) {
                return;
            }
            // Most rays pass wide of a lamp: both its sphere and its disc lie within r of the
            // centre, which the ray must pass ahead of its origin.
            let c = position - o;
            let r2 = radius * radius;
            let ahead = c.dot(w) > 0.0 && w.cross(c).length_squared() <= r2;
            if !ahead && (lamp.soft_falloff || c.length_squared() > r2) {
                return;
            }
            let Some(cone) = lamp_cone(position, radius, lamp.soft_falloff, o) else {
                return;
            };
            let Some(t) = cone.hit(w, radius, lamp.soft_falloff) else {
                return;
            };
            if t >= reach {
                return;
            }
            let radiance = match *source {
                LightSource::Point { intensity, .. } => intensity,
                LightSource::Spot {
                    intensity,
                    direction,
                    cos_inner,
                    cos_outer,
                    ..
                } if !cone.inside => {
                    intensity * smoothstep(cos_outer, cos_inner, -w.dot(direction))
                }
                LightSource::Spot { intensity, .. } => intensity,
                _ => Vec3::ZERO,
            } / (PI * radius * radius);
            if radiance != Vec3::ZERO {
                let pdf = cone.pdf(spot_spread(source));
                visit(radiance, self.pick_pmf(from, i as usize) * pdf, t);
            }
        });
    }

    /// Radiance of distant emitters (world and soft suns) seen along `dir`, each paired with its
    /// light-sampling density for MIS at `from`, the vertex the ray left: returns (radiance,
    /// pdf) per emitter via `visit`.
    pub fn escaped(&self, from: Receiver, dir: Vec3, mut visit: impl FnMut(Vec3, f32)) {
        if let Some(w) = self.world {
            let (radiance, pdf) = self.world_radiance(dir);
            visit(radiance, self.pick_pmf(from, w as usize) * pdf);
        }
        for &s in &self.suns {
            if let LightSource::Sun {
                to_sun,
                irradiance,
                cos_max,
            } = self.sources[s as usize]
            {
                if cos_max < 1.0 && dir.dot(to_sun) >= cos_max {
                    visit(
                        sun_disk_radiance(irradiance, cos_max),
                        self.pick_pmf(from, s as usize) * uniform_cone_pdf(cos_max),
                    );
                }
            }
        }
    }

    /// Probability that a light sample weighed by MIS, drawn from `from`, picks light `index`.
    fn pick_pmf(&self, from: Receiver, index: usize) -> f32 {
        match &self.local {
            Some(local) => local.pmf(from, index, &self.select),
            None => self.select.pmf(index),
        }
    }

    /// A direction towards the world background (for light samples and photon emission), the
    /// radiance arriving along it and its solid-angle density, not counting the probability of
    /// choosing the world: the environment map by importance, a constant colour uniformly.
    pub fn sample_world(&self, u: Vec2) -> Option<(Vec3, Vec3, f32)> {
        let w = self.world?;
        match &self.environment {
            Some(env) => env.sample(u),
            None => {
                let LightSource::World { radiance } = self.sources[w as usize] else {
                    return None;
                };
                Some((square_to_uniform_sphere(u), radiance, UNIFORM_SPHERE_PDF))
            }
        }
    }

    /// Radiance of the world background along `dir` and the density `sample_world` gives it.
    fn world_radiance(&self, dir: Vec3) -> (Vec3, f32) {
        match (&self.environment, self.world) {
            (Some(env), _) => (env.eval(dir), env.pdf(dir)),
            (None, Some(w)) => match self.sources[w as usize] {
                LightSource::World { radiance } => (radiance, UNIFORM_SPHERE_PDF),
                _ => (Vec3::ZERO, 0.0),
            },
            (None, None) => (Vec3::ZERO, 0.0),
        }
    }

    /// Bounding sphere of the scene geometry (centre, radius).
    pub fn scene_sphere(&self) -> (Vec3, f32) {
        (self.scene_center, self.scene_radius)
    }
}

/// Most lights `LocalSelection` weighs one by one at every light sample.
const MAX_LOCAL_LIGHTS: usize = 16;

/// Where a light is, for `LocalSelection`.
#[derive(Clone, Copy, Debug)]
enum Reach {
    /// The world: the same from every point, never below a horizon.
    Distant,
    /// A sun: the same from every point, its disc within the angle of sine `sin_half` of
    /// `to_sun`.
    Sun { to_sun: Vec3, sin_half: f32 },
    /// Within `radius2.sqrt()` of `centre`; with `front`, a one-sided emitter lighting only
    /// the points in front of the plane through `centre` with that normal.
    Near {
        centre: Vec3,
        radius2: f32,
        front: Option<Vec3>,
    },
}

impl Reach {
    /// A triangle `p`, one-sided along `front` when given.
    fn near(p: &[Vec3; 3], front: Option<Vec3>) -> Reach {
        let centre = (p[0] + p[1] + p[2]) / 3.0;
        let radius2 = p
            .iter()
            .map(|&v| (v - centre).length_squared())
            .fold(0.0, f32::max);
        Reach::Near {
            centre,
            radius2,
            front: front.filter(|n| *n != Vec3::ZERO),
        }
    }

    /// A point light, or a lamp of radius `radius`.
    fn sphere(centre: Vec3, radius: f32) -> Reach {
        Reach::Near {
            centre,
            radius2: radius * radius,
            front: None,
        }
    }

    /// What the light's irradiance at `p` is proportional to: 1 far away; near, the inverse
    /// squared distance, clamped at the light's size; zero behind a one-sided emitter.
    fn falloff(&self, p: Vec3) -> f32 {
        match *self {
            Reach::Distant | Reach::Sun { .. } => 1.0,
            Reach::Near {
                centre,
                radius2,
                front,
            } => {
                let d = p - centre;
                if front.is_some_and(|n| d.dot(n) <= 0.0) {
                    return 0.0;
                }
                1.0 / d.length_squared().max(radius2).max(1e-12)
            }
        }
    }

    /// True when every point of the light lies strictly below the plane through `p` of normal
    /// `n`: no direction towards it leaves the front of that plane.
    fn below(&self, p: Vec3, n: Vec3) -> bool {
        match *self {
            Reach::Distant => false,
            Reach::Sun { to_sun, sin_half } => to_sun.dot(n) < -sin_half,
            Reach::Near {
                centre, radius2, ..
            } => (centre - p).dot(n) < -radius2.sqrt(),
        }
    }
}

/// The choice of light for scenes of a few lights: half by power, half by the estimated
/// irradiance at the shading point (module header).
#[derive(Clone, Debug)]
struct LocalSelection {
    /// Per light: its power times the factor that makes power × `Reach::falloff` an
    /// irradiance (zero: never picked), and where it is.
    lights: Vec<(f32, Reach)>,
}

impl LocalSelection {
    /// `None` when there are too many lights, or too few to choose between, or no light whose
    /// share changes from point to point.
    fn new(power: &[f32], reach: &[Reach], scale: &[f32]) -> Option<LocalSelection> {
        let lights: Vec<(f32, Reach)> = power
            .iter()
            .zip(scale)
            .zip(reach)
            .map(|((&p, &s), &r)| {
                let w = p * s;
                (if w.is_finite() && w > 0.0 { w } else { 0.0 }, r)
            })
            .collect();
        let lit = lights.iter().filter(|(w, _)| *w > 0.0).count();
        let near = lights
            .iter()
            .any(|(w, r)| *w > 0.0 && matches!(r, Reach::Near { .. }));
        (lights.len() <= MAX_LOCAL_LIGHTS && lit > 1 && near).then_some(LocalSelection { lights })
    }

    /// The probability of picking each light from `from`: half in proportion to its estimated
    /// irradiance there, half by power, both among the lights not wholly below `from`'s horizon
    /// (a half left with no light gives its share to the other); all zero when none is left.
    fn probabilities(&self, from: Receiver, power: &Distribution1D) -> [f32; MAX_LOCAL_LIGHTS] {
        let mut by_irradiance = [0.0f32; MAX_LOCAL_LIGHTS];
        let mut by_power = [0.0f32; MAX_LOCAL_LIGHTS];
        let (mut irradiance_total, mut power_total) = (0.0, 0.0);
        for (i, (scale, reach)) in self.lights.iter().enumerate() {
            if from.horizon.is_some_and(|n| reach.below(from.p, n)) {
                continue;
            }
            if *scale > 0.0 {
                by_irradiance[i] = scale * reach.falloff(from.p);
            }
            by_power[i] = power.pmf(i);
            irradiance_total += by_irradiance[i];
            power_total += by_power[i];
        }
        let usable = |total: f32| total > 0.0 && total.is_finite();
        let (irradiance_share, power_share) = match (usable(irradiance_total), usable(power_total))
        {
            (true, true) => (0.5 / irradiance_total, 0.5 / power_total),
            (true, false) => (1.0 / irradiance_total, 0.0),
            (false, true) => (0.0, 1.0 / power_total),
            (false, false) => return [0.0; MAX_LOCAL_LIGHTS],
        };
        std::array::from_fn(|i| by_irradiance[i] * irradiance_share + by_power[i] * power_share)
    }

    /// Pick a light for a sample from `from` with `u`: (index, probability, `u` rescaled to
    /// [0, 1) within the light's share), as `Distribution1D::sample_remapped`; `power` is the
    /// choice by power.
    fn sample(&self, from: Receiver, u: f32, power: &Distribution1D) -> Option<(usize, f32, f32)> {
        let probabilities = self.probabilities(from, power);
        let mut below = 0.0;
        let mut last = None;
        for (i, &q) in probabilities[..self.lights.len()].iter().enumerate() {
            if q <= 0.0 {
                continue;
            }
            last = Some((i, below));
            if u < below + q {
                break;
            }
            below += q;
        }
        let (i, below) = last?;
        let remapped = ((u - below) / probabilities[i]).clamp(0.0, 1.0 - f32::EPSILON);
        Some((i, probabilities[i], remapped))
    }

    /// The probability that `sample` from `from` (with the same `power`) picks light `index`.
    fn pmf(&self, from: Receiver, index: usize, power: &Distribution1D) -> f32 {
        self.probabilities(from, power)
            .get(index)
            .copied()
            .unwrap_or(0.0)
    }
}

/// Area of the triangle `p`; zero when not finite.
fn area(p: [Vec3; 3]) -> f32 {
    let a = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length();
    if a.is_finite() {
        a
    } else {
        0.0
    }
}

/// Areas of `mesh`'s triangles in its own space.
fn triangle_areas(mesh: &Mesh) -> Vec<f32> {
    (mesh.indices.iter())
        .map(|idx| area(idx.map(|i| mesh.positions[i as usize])))
        .collect()
}

/// Area of `mesh`'s triangle `triangle` deformed as at `time` and placed by `to_world`.
fn placed_area(mesh: &Mesh, triangle: u32, to_world: Affine3A, time: f32) -> f32 {
    area(
        mesh.triangle_at(triangle, time)
            .map(|q| to_world.transform_point3(q)),
    )
}

/// Position, radius and ray visibility of a point or spot light; `None` for other lights.
pub fn lamp_of(source: &LightSource) -> Option<(Vec3, f32, Lamp)> {
    match *source {
        LightSource::Point {
            position,
            radius,
            lamp,
            ..
        }
        | LightSource::Spot {
            position,
            radius,
            lamp,
            ..
        } => Some((position, radius, lamp)),
        _ => None,
    }
}

/// A spot's own cone as light sampling may draw from it (`LampCone::sampled`): the axis
/// pointing back along the spot's direction and 1 − cos of its outer half-angle; `None` for
/// other lights.
fn spot_spread(source: &LightSource) -> Option<(Vec3, f32)> {
    match *source {
        LightSource::Spot {
            direction,
            cos_outer,
            ..
        } => Some((-direction, 1.0 - cos_outer)),
        _ => None,
    }
}

/// A lamp's cone seen from a point (`lamp_cone`).
#[derive(Clone, Copy, Debug)]
struct LampCone {
    /// Unit direction from the point to the lamp's centre.
    to_centre: Vec3,
    /// Distance to the centre.
    distance: f32,
    /// 1 − cos of the cone's half-angle (kept apart: it is tiny for small lamps); 2 inside
    /// a sphere, whose every direction meets the lamp.
    one_minus_cos: f32,
    /// The point is inside the sphere: rays meet its far side, and a spot's cone does not dim
    /// it (as in Cycles).
    inside: bool,
}

/// The cone of directions in which a lamp of radius `radius` at `position` is seen from `p`:
/// a sphere's (sin θ = r/d; inside it, the whole sphere of directions, drawn uniformly where
/// Cycles draws the hemisphere by cosine) or, with Soft Falloff, a disc's facing `p`
/// (tan θ = r/d), all of uniform radiance. `None` where the lamp is a point from `p`: radius
/// 0, `p` at its centre, or so far that the cone is numerically a point.
fn lamp_cone(position: Vec3, radius: f32, soft_falloff: bool, p: Vec3) -> Option<LampCone> {
    let d = position - p;
    let d2 = d.length_squared();
    let r2 = radius * radius;
    if !(radius > 0.0 && d2 > 0.0 && d2.is_finite()) {
        return None;
    }
    let distance = d2.sqrt();
    let inside = !soft_falloff && d2 <= r2;
    let one_minus_cos = if soft_falloff {
        // 1 − d/h with h² = d² + r², written without cancellation.
        let h = (d2 + r2).sqrt();
        r2 / (h * (h + distance))
    } else if inside {
        2.0
    } else {
        let sin2 = r2 / d2;
        sin2 / (1.0 + (1.0 - sin2).sqrt())
    };
    (one_minus_cos > MIN_LAMP_CONE).then(|| LampCone {
        to_centre: d / distance,
        distance,
        one_minus_cos,
        inside,
    })
}

/// Smallest 1 − cos θ of a lamp's cone that is sampled as a cone; narrower ones are points.
const MIN_LAMP_CONE: f32 = 1e-6;

/// A direction drawn uniformly with `u` in the cone around unit `axis` whose half-angle has
/// 1 − cos = `one_minus_cos` (the sine from 1 − cos, which keeps its digits in narrow cones).
fn cone_direction(axis: Vec3, one_minus_cos: f32, u: Vec2) -> Vec3 {
    let one_minus_z = u.x * one_minus_cos;
    let z = 1.0 - one_minus_z;
    let r = (one_minus_z * (2.0 - one_minus_z)).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Frame::from_normal(axis).to_world(Vec3::new(r * phi.cos(), r * phi.sin(), z))
}

impl LampCone {
    /// The cone light sampling draws from (1 − cos and axis): the lamp's, or, as Cycles does,
    /// a spot's own cone around the reversed spot direction (`spread`: that axis and its
    /// 1 − cos) where it is the narrower, since no direction outside it carries light. Inside a
    /// sphere the lamp's.
    fn sampled(&self, spread: Option<(Vec3, f32)>) -> (Vec3, f32) {
        match spread {
            Some((axis, omc)) if !self.inside && omc < self.one_minus_cos => (axis, omc),
            _ => (self.to_centre, self.one_minus_cos),
        }
    }

    /// Density per solid angle with which light sampling draws a direction that meets the lamp
    /// (uniform in the cone `sampled` gives).
    fn pdf(&self, spread: Option<(Vec3, f32)>) -> f32 {
        1.0 / (2.0 * PI * self.sampled(spread).1)
    }

    /// Distance along unit direction `w` from the cone's apex to the lamp (the near side of
    /// the sphere, its far side from inside, or the disc through the centre facing the apex);
    /// `None` when `w` misses it.
    fn hit(&self, w: Vec3, radius: f32, soft_falloff: bool) -> Option<f32> {
        let c = self.to_centre * self.distance;
        let along = w.dot(c);
        // Squared distance of the centre from the line, from the cross product: no
        // cancellation for nearly head-on rays.
        let off2 = w.cross(c).length_squared();
        let r2 = radius * radius;
        if self.inside {
            return Some(along + (r2 - off2).max(0.0).sqrt());
        }
        if along <= 0.0 {
            return None;
        }
        if soft_falloff {
            // Within the disc: tan α ≤ r/d.
            (off2 * self.distance * self.distance <= r2 * along * along)
                .then(|| self.distance * self.distance / along)
        } else {
            (off2 <= r2).then(|| along - (r2 - off2).max(0.0).sqrt())
        }
    }
}

/// A light sample towards a point or spot light, and the factor that turns its intensity into
/// the radiance arriving along the sample's direction (before a spot's cone).
struct PunctualSample {
    sample: LightSample,
    scale: f32,
    /// `p` is inside a sphere lamp (`LampCone::inside`).
    inside: bool,
}

/// Direction towards a point or spot light seen from `p`. With a lamp's cone (`lamp_cone`) the
/// direction is drawn uniformly in it and the radiance is I / (πr²) (the lamp's projected area
/// is πr²; far away this gives the point's I / d²), a sample BSDF rays can also find when
/// `lamp.bounces` (a spot's `spread`, `spot_spread`, may narrow the cone drawn from:
/// `LampCone::sampled`). Without one, a true point: I / d², density 1, delta.
fn sample_punctual(
    position: Vec3,
    radius: f32,
    lamp: Lamp,
    spread: Option<(Vec3, f32)>,
    p: Vec3,
    u: Vec2,
) -> Option<PunctualSample> {
    let Some(cone) = lamp_cone(position, radius, lamp.soft_falloff, p) else {
        let d = position - p;
        let dist2 = d.length_squared();
        if !(dist2 > 0.0) {
            return None;
        }
        let sample = LightSample {
            li: Vec3::ZERO,
            wi: d / dist2.sqrt(),
            pdf: 1.0,
            delta: true,
            target: LightPoint {
                p: position,
                p_error: Vec3::ZERO,
                n: Vec3::ZERO,
                distant: false,
            },
        };
        return Some(PunctualSample {
            sample,
            scale: 1.0 / dist2,
            inside: false,
        });
    };
    let (axis, one_minus_cos) = cone.sampled(spread);
    let wi = cone_direction(axis, one_minus_cos, u);
    // Drawn in the lamp's cone the direction meets it (to rounding); in a spot's narrower cone
    // it may not.
    let t = match cone.hit(wi, radius, lamp.soft_falloff) {
        Some(t) => t,
        None if one_minus_cos == cone.one_minus_cos => cone.distance,
        None => return None,
    };
    let q = p + wi * t;
    let target = LightPoint {
        p: q,
        p_error: crate::math::gamma(8) * (q.abs() + position.abs()),
        n: (q - position).normalize_or(-wi),
        distant: false,
    };
    let sample = LightSample {
        li: Vec3::ZERO,
        wi,
        pdf: cone.pdf(spread),
        delta: !lamp.bounces,
        target,
    };
    Some(PunctualSample {
        sample,
        scale: 1.0 / (PI * radius * radius),
        inside: cone.inside,
    })
}

/// The lamps (point and spot lights with a radius that some rays see) and, when there are many,
/// a bounding-volume hierarchy over their spheres, so a ray tests only the lamps near it.
#[derive(Default)]
struct LampSet {
    /// Indices into `Lights::sources`, in the hierarchy's order.
    lamps: Vec<u32>,
    /// The hierarchy's nodes, root first; empty when the lamps are few enough to test all.
    nodes: Vec<LampNode>,
    /// Some lamp is seen by scattered rays.
    seen_by_bounces: bool,
}

/// Lamps tested one by one below this count; a hierarchy above it.
const LAMPS_WITHOUT_TREE: usize = 8;

/// A node of `LampSet`'s hierarchy: the bounds of its lamps' spheres and either two children
/// (`count` 0, the second at `index`; the first follows the node) or `count` lamps from
/// `index`.
#[derive(Clone, Copy, Debug)]
struct LampNode {
    min: Vec3,
    max: Vec3,
    index: u32,
    count: u32,
}

impl LampSet {
    fn new(sources: &[LightSource]) -> LampSet {
        let mut lamps: Vec<u32> = Vec::new();
        let mut seen_by_bounces = false;
        for (i, source) in sources.iter().enumerate() {
            if let Some((_, radius, lamp)) = lamp_of(source) {
                if radius > 0.0 && (lamp.camera || lamp.bounces) {
                    lamps.push(i as u32);
                    seen_by_bounces |= lamp.bounces;
                }
            }
        }
        let mut set = LampSet {
            lamps,
            nodes: Vec::new(),
            seen_by_bounces,
        };
        if set.lamps.len() > LAMPS_WITHOUT_TREE {
            let bounds = |i: u32| {
                let (c, r, _) = lamp_of(&sources[i as usize]).unwrap_or_default();
                (c - Vec3::splat(r), c + Vec3::splat(r))
            };
            let n = set.lamps.len();
            set.build(0, n, &bounds);
        }
        set
    }

    /// Append the subtree over `lamps[start..end]`, split at the median of the longest axis.
    fn build(&mut self, start: usize, end: usize, bounds: &impl Fn(u32) -> (Vec3, Vec3)) {
        let (mut min, mut max) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for &i in &self.lamps[start..end] {
            let (lo, hi) = bounds(i);
            min = min.min(lo);
            max = max.max(hi);
        }
        let node = self.nodes.len();
        self.nodes.push(LampNode {
            min,
            max,
            index: start as u32,
            count: (end - start) as u32,
        });
        if end - start <= 2 {
            return;
        }
        let axis = (max - min).max_position();
        let centre = |i: &u32| {
            let (lo, hi) = bounds(*i);
            (lo + hi)[axis]
        };
        let mid = (start + end) / 2;
        self.lamps[start..end]
            .select_nth_unstable_by(mid - start, |a, b| centre(a).total_cmp(&centre(b)));
        self.build(start, mid, bounds);
        let second = self.nodes.len() as u32;
        self.build(mid, end, bounds);
        self.nodes[node].index = second;
        self.nodes[node].count = 0;
    }

    /// Call `visit` with every lamp whose bounds the segment from `o` along unit `w` up to
    /// `reach` passes.
    fn candidates(&self, o: Vec3, w: Vec3, reach: f32, mut visit: impl FnMut(u32)) {
        if self.nodes.is_empty() {
            self.lamps.iter().for_each(|&i| visit(i));
            return;
        }
        let inv = w.recip();
        let mut stack = [0u32; 64];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let at = stack[top];
            let node = self.nodes[at as usize];
            let t0 = (node.min - o) * inv;
            let t1 = (node.max - o) * inv;
            let near = t0.min(t1).max_element().max(0.0);
            let far = t0.max(t1).min_element().min(reach);
            // NaN (a zero direction component on a slab's plane) keeps the node.
            if near > far {
                continue;
            }
            if node.count > 0 {
                let range = node.index as usize..(node.index + node.count) as usize;
                self.lamps[range].iter().for_each(|&i| visit(i));
            } else if top + 2 <= stack.len() {
                stack[top] = node.index;
                stack[top + 1] = at + 1;
                top += 2;
            }
        }
    }
}
/// Radiance of a uniform sun disk of angular radius acos(cos_max) that gives `irradiance` on a
/// surface facing it: E = L · π sin²θ.
fn sun_disk_radiance(irradiance: Vec3, cos_max: f32) -> Vec3 {
    let sin2 = (1.0 - cos_max * cos_max).max(1e-12);
    irradiance / (PI * sin2)
}

/// An equirectangular environment map as a light: radiance lookups by direction and importance
/// sampling of directions (see the module documentation for the method, `scene::Environment`
/// for the mapping).
#[derive(Clone, Debug)]
pub struct EnvironmentLight {
    map: Environment,
    distribution: Distribution2D,
    /// Mean radiance over the sphere, ∫L dω / 4π.
    pub average: Vec3,
}

impl EnvironmentLight {
    pub fn new(map: &Environment) -> Self {
        let (w, h) = (map.width as usize, map.height as usize);
        let lum: Vec<f32> = map.pixels.iter().map(|&c| luminance(c)).collect();
        let mut weights = vec![0.0; w * h];
        let mut sum = Vec3::ZERO;
        for y in 0..h {
            let sin_theta = (PI * (y as f32 + 0.5) / h as f32).sin();
            // Solid angle of a pixel of this row: (2π/w)·(cos θ0 − cos θ1).
            let (theta0, theta1) = (PI * y as f32 / h as f32, PI * (y + 1) as f32 / h as f32);
            let solid_angle = 2.0 * PI / w as f32 * (theta0.cos() - theta1.cos());
            for x in 0..w {
                // Bilinear lookups blend in the neighbours: weigh a pixel by the brightest of
                // its 3×3 neighbourhood so the density is positive wherever radiance is.
                let mut peak = lum[y * w + x];
                if !map.closest {
                    for yy in y.saturating_sub(1)..(y + 2).min(h) {
                        for dx in [w - 1, 0, 1] {
                            peak = peak.max(lum[yy * w + (x + dx) % w]);
                        }
                    }
                }
                weights[y * w + x] = peak * sin_theta;
                sum += map.pixels[y * w + x] * solid_angle;
            }
        }
        let average = sum / (4.0 * PI);
        EnvironmentLight {
            map: map.clone(),
            distribution: Distribution2D::new(&weights, w, h),
            average,
        }
    }

    /// Radiance arriving from direction `dir` (scene space, towards the environment).
    pub fn eval(&self, dir: Vec3) -> Vec3 {
        self.map.radiance(dir)
    }

    /// Solid-angle density with which `sample` picks `dir`.
    pub fn pdf(&self, dir: Vec3) -> f32 {
        let (p, sin_theta) = self.map.to_image(dir);
        if sin_theta <= 0.0 {
            return 0.0;
        }
        self.distribution.pdf(p) / (2.0 * PI * PI * sin_theta)
    }

    /// A direction (scene space, towards the environment), its radiance and solid-angle density.
    pub fn sample(&self, u: Vec2) -> Option<(Vec3, Vec3, f32)> {
        let (p, pdf_image) = self.distribution.sample(u)?;
        let (theta, phi) = (PI * p.y, PI - 2.0 * PI * p.x);
        let sin_theta = theta.sin();
        if sin_theta <= 0.0 {
            return None;
        }
        let d = Vec3::new(sin_theta * phi.cos(), sin_theta * phi.sin(), theta.cos());
        let dir = self.map.to_map.transpose() * d;
        let pdf = pdf_image / (2.0 * PI * PI * sin_theta);
        (pdf > 0.0 && pdf.is_finite()).then(|| (dir, self.eval(dir), pdf))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sun, a point light and a one-sided triangle facing +y, with the powers and scales
    /// `Lights::new` would give them (scene radius 10).
    fn few_lights() -> (LocalSelection, Distribution1D) {
        let triangle = [
            Vec3::new(-1.0, 2.0, 0.0),
            Vec3::new(1.0, 2.0, 0.0),
            Vec3::Y * 2.0 + Vec3::Z,
        ];
        let power = [3.0 * PI * 100.0, 4.0 * PI * 5.0, PI * 40.0 * 1.0];
        let reach = [
            Reach::Sun {
                to_sun: Vec3::Y,
                sin_half: 0.01,
            },
            Reach::sphere(Vec3::new(3.0, 1.0, 0.0), 0.1),
            Reach::near(&triangle, Some(Vec3::Y)),
        ];
        let scale = [1.0 / (PI * 100.0), 1.0 / (4.0 * PI), 1.0 / PI];
        let local = LocalSelection::new(&power, &reach, &scale).expect("a near light");
        (local, Distribution1D::new(&power))
    }

    /// The choice near the shading point is a distribution: its probabilities sum to one, the
    /// share of the unit interval `sample` gives each light is the probability it reports and
    /// `pmf` recomputes, the rescaled number stays in [0, 1), and a light behind a one-sided
    /// emitter keeps only its share by power, and a light wholly below the receiver's horizon
    /// gets nothing.
    #[test]
    fn local_selection_samples_what_its_pmf_says() {
        let (local, power) = few_lights();
        let above = |p: Vec3, n: Vec3| Receiver {
            p,
            horizon: Some(n),
        };
        for from in [
            Receiver::at(Vec3::new(0.0, 3.0, 0.2)),
            Receiver::at(Vec3::new(2.5, 1.2, 0.0)),
            Receiver::at(Vec3::new(0.0, 0.0, 0.0)),
            above(Vec3::new(2.5, 1.2, 0.0), -Vec3::Y),
            above(Vec3::new(0.0, 3.5, 0.2), Vec3::X),
        ] {
            let p = from.p;
            let sum: f32 = (0..3).map(|i| local.pmf(from, i, &power)).sum();
            assert!((sum - 1.0).abs() < 1e-5, "sum {sum} at {p:?}");
            let n = 200_000;
            let mut count = [0usize; 3];
            for k in 0..n {
                let u = (k as f32 + 0.5) / n as f32;
                let (i, pmf, remapped) = local.sample(from, u, &power).expect("a light");
                assert!((pmf - local.pmf(from, i, &power)).abs() < 1e-6);
                assert!((0.0..1.0).contains(&remapped), "remapped {remapped}");
                count[i] += 1;
            }
            for (i, &c) in count.iter().enumerate() {
                let expected = local.pmf(from, i, &power);
                assert!(
                    (c as f32 / n as f32 - expected).abs() < 1e-3,
                    "light {i} at {p:?}: drawn {} expected {expected}",
                    c as f32 / n as f32
                );
            }
        }
        // Below the triangle (y < 2, facing +y): only its half by power.
        let below = Vec3::new(0.0, 0.0, 0.0);
        assert!((local.pmf(Receiver::at(below), 2, &power) - 0.5 * power.pmf(2)).abs() < 1e-6);
        // Next to the point light, it takes most of the local half.
        let near = Vec3::new(2.9, 1.0, 0.0);
        assert!(local.pmf(Receiver::at(near), 1, &power) > 0.5 * power.pmf(1) + 0.45);
        // Under a surface facing away from the sun, the sun is never picked; above the
        // triangle and the point light, facing up, only the sun is left.
        assert_eq!(local.pmf(above(near, -Vec3::Y), 0, &power), 0.0);
        let over = above(Vec3::new(0.0, 3.5, 0.2), Vec3::Y);
        assert_eq!(local.pmf(over, 0, &power), 1.0);
        assert_eq!(local.sample(over, 0.99, &power).map(|s| s.0), Some(0));
    }

    /// The spread keeps the light's power: ∫ factor · cos dω over the hemisphere is π, for wide
    /// and narrow spreads (the narrow ones through the series branch).
    #[test]
    fn spread_factor_keeps_the_power() {
        for degrees in [170.0f32, 90.0, 30.0, 5.0, 1.0] {
            let spread = Some(degrees.to_radians());
            let half = 0.5 * degrees.to_radians();
            let n = 200_000;
            // Midpoint rule in θ over [0, h] (the factor is zero beyond).
            let dtheta = half / n as f32;
            let mut integral = 0.0f64;
            for i in 0..n {
                let theta = (i as f32 + 0.5) * dtheta;
                let f = spread_factor(spread, theta.cos());
                integral += (f * theta.cos() * theta.sin() * dtheta) as f64 * std::f64::consts::TAU;
            }
            let ratio = integral / std::f64::consts::PI;
            assert!((ratio - 1.0).abs() < 2e-3, "{degrees}°: {ratio}");
            assert_eq!(spread_factor(spread, (half * 1.01).cos()), 0.0);
        }
        assert_eq!(spread_factor(None, 0.3), 1.0);
    }
}
