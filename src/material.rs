//! Material evaluation at a surface point: textures and factors resolved into the small plain
//! `SurfaceMaterial` that shading reads (yocto-gl's `eval_material` habit), following the glTF
//! 2.0 specification §3.9 (metallic-roughness) and the KHR_materials_transmission, _ior,
//! _specular, _emissive_strength and _volume extensions. A material with a Blender node tree
//! (`shader`) is evaluated by its program instead, at the full shading point, its Ambient
//! Occlusion and Bevel nodes tracing rays from the point through the scene's BVH
//! (`TracedScene`).

use crate::accel::{hit_mesh, interpolate, Accel, Hit, Ray, Visibility, NO_INSTANCE};
use crate::bsdf::thin_film::FilmModel;
use crate::interaction::{SurfaceHit, View};
use crate::math::{Vec2, Vec3, Vec4};
use crate::scene::{blender_axes, Material, Scene, Subsurface, TextureRef};
use crate::shader::{Closure, LocalHit, SceneRays, Tracing};

/// A material's values at one point, with textures applied. Colours are linear RGB.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceMaterial {
    pub base_color: Vec3,
    /// Coverage in [0, 1] (base colour alpha × texture alpha).
    pub alpha: f32,
    pub metallic: f32,
    /// Perceptual roughness in [0, 1] (GGX α = roughness²).
    pub roughness: f32,
    pub transmission: f32,
    /// Index of refraction of the object (inside over outside).
    pub ior: f32,
    /// KHR_materials_specular specularFactor and specularColorFactor (Blender writes
    /// 2 × Specular IOR Level × Specular Tint into the colour).
    pub specular: f32,
    pub specular_color: Vec3,
    /// Emitted radiance (W·m⁻²·sr⁻¹).
    pub emission: Vec3,
    /// Beer–Lambert absorption coefficient σ_a per channel (per scene unit) inside the object;
    /// zero when the material has no volume.
    pub absorption: Vec3,
    pub thin_walled: bool,
    /// Blender's subsurface inputs; translucent when `subsurface.weight > 0`.
    pub subsurface: Subsurface,
    /// A shading normal a node tree gives (Bump, or a Normal input), unit, world space;
    /// `None`: the surface's own.
    pub normal: Option<Vec3>,
    /// Blender's Principled coat: Coat Weight, Roughness, IOR, Tint, and its normal (unit,
    /// world; `None`: the shading normal).
    pub coat_weight: f32,
    pub coat_roughness: f32,
    pub coat_ior: f32,
    pub coat_tint: Vec3,
    pub coat_normal: Option<Vec3>,
    /// Blender's Principled sheen: Sheen Weight, Roughness and Tint.
    pub sheen_weight: f32,
    pub sheen_roughness: f32,
    pub sheen_tint: Vec3,
    /// Anisotropy of the specular layer and the metal: α_x = α / aspect along `tangent`,
    /// α_y = α · aspect (1: isotropic; Blender's Anisotropic A gives sqrt(1 − 0.9 A)).
    pub aspect: f32,
    /// The direction α_x runs along (world, any length; Anisotropic Rotation applied);
    /// `None`: the shading frame's own.
    pub tangent: Option<Vec3>,
    /// Oren–Nayar roughness of the diffuse lobe (Blender's Diffuse Roughness; 0: Lambert).
    pub diffuse_roughness: f32,
    /// Blender's Principled Thin Film: thickness (nm; at most 0.1: none) and IOR of a film
    /// on the specular layer and the glass (`bsdf::thin_film`).
    pub thin_film_thickness: f32,
    pub thin_film_ior: f32,
    /// Whose Cycles' film it is (`bsdf::thin_film::FilmModel`).
    pub thin_film_model: FilmModel,
    /// How much of the film's reflectance replaces the film-free one (1: all, as Blender's;
    /// KHR_materials_iridescence's iridescenceFactor).
    pub thin_film_weight: f32,
    /// A node tree's Transparent BSDF (its transmission a straight pass): passing it is no
    /// bounce for Light Path, and shadow rays go through it.
    pub transparent: bool,
    /// A node tree's Translucent BSDF: Lambertian transmission of `base_color` alone (with
    /// `transmission` 1, so light crosses the surface).
    pub translucent: bool,
    /// KHR_materials_diffuse_transmission: the share of the dielectric base's diffuse lobe
    /// that is Lambertian transmission into the other side instead of reflection
    /// (diffuseTransmissionFactor × texture A), and the colour it transmits
    /// (diffuseTransmissionColorFactor × texture RGB).
    pub diffuse_transmission: f32,
    pub diffuse_transmission_color: Vec3,
    /// A node tree's Refraction BSDF: the glass lobe (`transmission` 1) transmits
    /// `base_color` with no Fresnel and reflects nothing.
    pub refraction: bool,
    /// A node tree's Glass BSDF: its colour weighs the glass's reflection and each crossing
    /// (not the Principled BSDF's square root on the transmission alone).
    pub glass: bool,
    /// A node tree's Holdout: no light, and transparent in the film's alpha where the camera
    /// sees it (Cycles' holdout).
    pub holdout: bool,
    /// A node tree's Ray Portal BSDF: the ray goes on from elsewhere (`Portal`).
    pub portal: Option<Portal>,
    /// GGX without Multiscatter GGX's energy compensation of the metal and specular lobes.
    pub single_scatter: bool,
    /// What the whole BSDF is multiplied by (1; a node tree's Add Shader of two BSDFs picks
    /// one and doubles it).
    pub weight: f32,
    /// A node tree's Toon BSDF: its lobe alone, of `base_color`.
    pub toon: Option<crate::shader::Toon>,
    /// A node tree's hair BSDF: the fibre's lobes alone (`bsdf::hair`), the fibre running
    /// along `tangent`.
    pub hair: Option<crate::shader::Hair>,
    /// A node tree's metal F82 tint (`shader::Closure::metal_tint`); `None`: the normalised
    /// specular colour.
    pub metal_tint: Option<Vec3>,
}

impl Default for SurfaceMaterial {
    /// Blender's Principled BSDF node defaults (base 0.8, roughness 0.5, IOR 1.5, level 0.5).
    fn default() -> Self {
        SurfaceMaterial {
            base_color: Vec3::splat(0.8),
            alpha: 1.0,
            metallic: 0.0,
            roughness: 0.5,
            transmission: 0.0,
            ior: 1.5,
            specular: 1.0,
            specular_color: Vec3::ONE,
            emission: Vec3::ZERO,
            absorption: Vec3::ZERO,
            thin_walled: false,
            subsurface: Subsurface::default(),
            normal: None,
            coat_weight: 0.0,
            coat_roughness: 0.03,
            coat_ior: 1.5,
            coat_tint: Vec3::ONE,
            coat_normal: None,
            sheen_weight: 0.0,
            sheen_roughness: 0.5,
            sheen_tint: Vec3::ONE,
            aspect: 1.0,
            tangent: None,
            diffuse_roughness: 0.0,
            thin_film_thickness: 0.0,
            thin_film_ior: 1.33,
            thin_film_model: FilmModel::Blender4,
            thin_film_weight: 1.0,
            transparent: false,
            translucent: false,
            diffuse_transmission: 0.0,
            diffuse_transmission_color: Vec3::ONE,
            refraction: false,
            glass: false,
            holdout: false,
            portal: None,
            single_scatter: false,
            weight: 1.0,
            toon: None,
            hair: None,
            metal_tint: None,
        }
    }
}

/// Where a Ray Portal BSDF sends a ray that meets it (scene axes, world), as Cycles'
/// `integrate_surface_ray_portal`: on from `position` along `direction` (unit), its
/// throughput times `weight` (the closure's colour and weight).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Portal {
    pub position: Vec3,
    pub direction: Vec3,
    pub weight: Vec3,
}

impl SurfaceMaterial {
    /// No light crosses the surface (no glass, Translucent or diffuse-transmission lobe): the
    /// shading point turns it to the viewer's side.
    pub fn is_opaque(&self) -> bool {
        self.transmission <= 0.0 && !(self.diffuse_transmission > 0.0)
    }
}

/// Linear RGBA of `texture` at `uv`; white (the identity for factors) when absent or dangling.
fn lookup(scene: &Scene, texture: &Option<TextureRef>, uv: Vec2) -> Vec4 {
    match texture {
        Some(t) => match scene.textures.get(t.texture as usize) {
            Some(image) => image.sample(t.apply(uv)),
            None => Vec4::ONE,
        },
        None => Vec4::ONE,
    }
}

/// σ_a = −ln(attenuation colour) / attenuation distance, zero for an infinite distance.
/// A zero colour channel is clamped to a tiny value so σ_a stays finite.
pub fn absorption_coefficient(attenuation_color: Vec3, attenuation_distance: f32) -> Vec3 {
    if !(attenuation_distance.is_finite() && attenuation_distance > 0.0) {
        return Vec3::ZERO;
    }
    let c = attenuation_color.clamp(Vec3::splat(1e-6), Vec3::ONE);
    Vec3::new(-c.x.ln(), -c.y.ln(), -c.z.ln()) / attenuation_distance
}

/// Resolve `material` at texture coordinate `uv`: every factor times its texture, as glTF
/// specifies (base colour × RGBA texture, metallic × B, roughness × G, emission × RGB,
/// transmission × R, clearcoat × R, clearcoat roughness × G, sheen colour × RGB, sheen
/// roughness × A, anisotropy strength × B, iridescence × R, iridescence thickness between
/// its minimum and maximum by G, diffuse transmission × A, its colour × RGB). The coat's normal and the anisotropy's direction
/// need the surface point: `eval_surface` adds them.
pub fn eval_material(scene: &Scene, material: &Material, uv: Vec2) -> SurfaceMaterial {
    let base = material.base_color * lookup(scene, &material.base_color_texture, uv);
    let metal_rough = lookup(scene, &material.metallic_roughness_texture, uv);
    let emissive = lookup(scene, &material.emissive_texture, uv);
    let transmission = lookup(scene, &material.transmission_texture, uv);
    let mut s = SurfaceMaterial {
        base_color: base.truncate(),
        alpha: base.w.clamp(0.0, 1.0),
        metallic: (material.metallic * metal_rough.z).clamp(0.0, 1.0),
        roughness: (material.roughness * metal_rough.y).clamp(0.0, 1.0),
        transmission: (material.transmission * transmission.x).clamp(0.0, 1.0),
        ior: material.ior,
        specular: material.specular,
        specular_color: material.specular_color,
        emission: material.emission * emissive.truncate(),
        absorption: absorption_coefficient(
            material.attenuation_color,
            material.attenuation_distance,
        ),
        thin_walled: material.thickness <= 0.0,
        subsurface: material.subsurface,
        ..SurfaceMaterial::default()
    };
    if material.coat > 0.0 {
        s.coat_weight = material.coat * lookup(scene, &material.coat_texture, uv).x;
        s.coat_roughness =
            material.coat_roughness * lookup(scene, &material.coat_roughness_texture, uv).y;
    }
    if material.sheen {
        s.sheen_weight = 1.0;
        s.sheen_tint =
            material.sheen_color * lookup(scene, &material.sheen_color_texture, uv).truncate();
        s.sheen_roughness =
            material.sheen_roughness * lookup(scene, &material.sheen_roughness_texture, uv).w;
    }
    if material.iridescence > 0.0 {
        s.thin_film_weight =
            material.iridescence * lookup(scene, &material.iridescence_texture, uv).x;
        let [lo, hi] = material.iridescence_thickness;
        s.thin_film_thickness = match &material.iridescence_thickness_texture {
            None => hi,
            Some(_) => {
                lo + (hi - lo) * lookup(scene, &material.iridescence_thickness_texture, uv).y
            }
        };
        s.thin_film_ior = material.iridescence_ior;
    }
    if material.diffuse_transmission > 0.0 {
        s.diffuse_transmission = material.diffuse_transmission
            * lookup(scene, &material.diffuse_transmission_texture, uv).w;
        s.diffuse_transmission_color = material.diffuse_transmission_color
            * lookup(scene, &material.diffuse_transmission_color_texture, uv).truncate();
    }
    if material.anisotropy != 0.0 {
        let strength = material.anisotropy * lookup(scene, &material.anisotropy_texture, uv).z;
        s.aspect = crate::shader::principled_aspect(strength);
    }
    s
}

/// Blender's (x, y, z) as glTF's (x, z, −y): node trees' vectors back to the scene's axes.
fn gltf_axes(v: Vec3) -> Vec3 {
    Vec3::new(v.x, v.z, -v.y)
}

/// What a node tree's Ambient Occlusion and Bevel nodes trace where a surface is shaded: the
/// scene's BVH, and the seed of their random numbers (fixed by the path and the point).
#[derive(Clone, Copy)]
pub struct Rays<'a> {
    pub accel: &'a Accel,
    pub seed: u64,
}

/// The material at surface point `sh` seen from `view`: its node tree when it has one (`u` in
/// [0, 1) picks the
/// BSDF of Mix and Add Shader nodes; its Ambient Occlusion and Bevel nodes trace `rays`, or
/// read 1 and the normal without), else `eval_material` at the point's UV with the base
/// colour and alpha times the vertex colour COLOR_0 when the mesh has one (glTF §3.7.2.1),
/// the clearcoat normal texture and the anisotropy's direction.
pub fn eval_surface(
    scene: &Scene,
    sh: &SurfaceHit,
    view: View,
    u: f32,
    rays: Option<Rays>,
) -> SurfaceMaterial {
    let material = &scene.materials[sh.material as usize];
    match &material.nodes {
        None => {
            let mut s = eval_material(scene, material, sh.uv);
            let mesh = hit_mesh(scene, &sh.hit);
            if !mesh.colors.is_empty() {
                let idx = mesh.indices[sh.hit.triangle as usize];
                let c = interpolate(idx.map(|i| mesh.colors[i as usize]), sh.hit.b1, sh.hit.b2);
                s.base_color *= c.truncate();
                s.alpha = (s.alpha * c.w).clamp(0.0, 1.0);
            }
            if s.coat_weight > 0.0 {
                if let Some(tex) = &material.coat_normal_texture {
                    s.coat_normal = sh.normal_from_texture(scene, tex, material.coat_normal_scale);
                }
            }
            if s.aspect < 1.0 {
                let uv_tangent = material
                    .anisotropy_texture
                    .as_ref()
                    .and_then(|_| sh.uv_tangent(scene));
                let n = sh.frame.n;
                let base = uv_tangent.unwrap_or_else(|| {
                    let at = sh.node_inputs(scene, false, crate::shader::READS_ALL, view);
                    gltf_axes(crate::shader::default_tangent(&at, &at.points[0]))
                });
                let mut angle = material.anisotropy_rotation;
                if let Some(t) = &material.anisotropy_texture {
                    let texel = lookup(scene, &Some(*t), sh.uv);
                    angle += (2.0 * texel.y - 1.0).atan2(2.0 * texel.x - 1.0);
                }
                s.tangent = Some(crate::math::rotate_around(base, n, angle));
            }
            s
        }
        Some(program) => {
            let traced = rays.map(|r| TracedScene {
                scene,
                accel: r.accel,
                from: sh,
            });
            let tracing = traced.as_ref().zip(rays).map(|(t, r)| Tracing {
                scene: t,
                seed: r.seed,
            });
            let mut s = program.eval_then(
                &sh.node_inputs(scene, program.needs_offsets, program.reads, view),
                &scene.textures,
                u,
                tracing.as_ref(),
                |c| from_closure(material, c),
            );
            // Cycles' geometric and shading normals are the viewer's side's.
            let side = if view.backfacing { -1.0 } else { 1.0 };
            let (ng, shading) = (side * sh.ng, side * sh.frame.n);
            let valid = |n: Vec3| reflecting_normal(ng, shading, view.wo, n);
            s.normal = s.normal.map(valid);
            s.coat_normal = s.coat_normal.map(valid);
            if s.hair.is_some() {
                on_fibre(scene, sh, view, &mut s);
            }
            s
        }
    }
}

/// A node tree's normal `n` (unit), as Cycles corrects every BSDF node's normal that differs
/// from the `shading` normal (`ensure_valid_specular_reflection`): turned towards the
/// geometric normal `ng`, in the plane of the two, just enough that the mirror direction of
/// the view `i` about it rises above the surface by min(0.9 cos θ, 0.01) (θ the view's angle
/// to `ng`; `ng`, `shading` and `i` on the viewer's side). Cycles bends the normal of its
/// microfacet lobes alone and keeps the diffuse lobe's; Photon's lobes share one frame, and its
/// diffuse lobe is black seen from below its normal, so the bent normal serves them all
/// (closer to Cycles than an unbent one: a Bevel's edges seen at a grazing angle, a strong
/// Bump).
fn reflecting_normal(ng: Vec3, shading: Vec3, i: Vec3, n: Vec3) -> Vec3 {
    if n.dot(shading) > 1.0 - 1e-6 {
        return n;
    }
    let iz = i.dot(ng);
    let rise = (0.9 * iz).min(0.01);
    if (2.0 * n.dot(i) * n - i).dot(ng) >= rise || !(iz > 0.0) {
        return n;
    }
    // With x the unit direction of n across ng, the normal sought is s x + c ng (s, c ≥ 0,
    // s² + c² = 1) whose mirror direction rises by `rise`: 2 (s Ix + c Iz) c − Iz = rise.
    // Squared, a quadratic in z = c²: 4 (Ix² + Iz²) z² − 4 (Ix² + Iz² + Iz rise) z
    // + (Iz + rise)² = 0, of which the root where s c Ix has the sign of rise + Iz − 2 z Iz.
    let x = (n - n.dot(ng) * ng).normalize_or(n);
    let ix = i.dot(x);
    let a = ix * ix + iz * iz;
    let b = a + iz * rise;
    let root = (b * b - a * (iz + rise) * (iz + rise)).max(0.0).sqrt();
    let z = if ix < 0.0 {
        (b + root) / (2.0 * a)
    } else {
        (b - root) / (2.0 * a)
    };
    let z = z.clamp(0.0, 1.0);
    ((1.0 - z).sqrt() * x + z.sqrt() * ng).normalize_or(n)
}

/// The scene as the nodes that trace rays see it from the surface point `from`
/// (`shader::SceneRays`, in Blender's axes). A point's object is its instance, or for a
/// world-space mesh every mesh of the same glTF node (an object's material slots are meshes
/// of their own).
struct TracedScene<'a> {
    scene: &'a Scene,
    accel: &'a Accel,
    from: &'a SurfaceHit,
}

/// Surfaces a segment of `SceneRays::local_hits` (or an Only Local occlusion ray) passes at
/// most: past them the rest of the segment is left.
const MAX_CROSSINGS: usize = 16;

impl TracedScene<'_> {
    /// Whether `hit` lies on the object of the point the rays leave from.
    fn on_own_object(&self, hit: &Hit) -> bool {
        let own = &self.from.hit;
        if hit.instance != NO_INSTANCE || own.instance != NO_INSTANCE {
            return hit.instance == own.instance;
        }
        let node = |mesh: u32| {
            let name = &self.scene.meshes[mesh as usize].name;
            name.split_once('/').map_or(name.as_str(), |(node, _)| node)
        };
        hit.mesh == own.mesh || node(hit.mesh) == node(own.mesh)
    }

    /// Each surface of the point's own object along `ray` in turn, until `visit` returns
    /// false.
    fn own_surfaces(&self, mut ray: Ray, mut visit: impl FnMut(&SurfaceHit) -> bool) {
        for _ in 0..MAX_CROSSINGS {
            let Some(hit) = self
                .accel
                .intersect(self.scene, &ray, Visibility::Secondary)
            else {
                return;
            };
            let at = SurfaceHit::new(self.scene, &ray, &hit);
            if self.on_own_object(&hit) && !visit(&at) {
                return;
            }
            ray = Ray {
                t_max: ray.t_max - hit.t,
                ..at.spawn(ray.direction)
            };
        }
    }
}

impl SceneRays for TracedScene<'_> {
    fn occluded(&self, direction: Vec3, distance: f32, local: bool) -> bool {
        let ray = Ray {
            t_max: distance,
            ..self.from.spawn(gltf_axes(direction))
        };
        if !local {
            return !self.accel.unoccluded(self.scene, &ray);
        }
        let mut met = false;
        self.own_surfaces(ray, |_| {
            met = true;
            false
        });
        met
    }

    fn local_hits(
        &self,
        origin: Vec3,
        direction: Vec3,
        length: f32,
        visit: &mut dyn FnMut(LocalHit),
    ) {
        let ray = Ray {
            origin: gltf_axes(origin),
            direction: gltf_axes(direction),
            t_max: length,
            time: self.from.time,
        };
        self.own_surfaces(ray, |at| {
            visit(LocalHit {
                position: blender_axes(at.p),
                geometric_normal: blender_axes(at.ng),
                normal: blender_axes(at.frame.n),
            });
            true
        });
    }

    fn geometric_normal(&self) -> Vec3 {
        blender_axes(self.from.ng)
    }
}

/// A hair closure on a tube swept along a curve (`blender_addon/points_curves.py`): seen from
/// outside, the fibre runs along the tube's direction at the point (`SurfaceHit::fibre_tangent`), which
/// the shading frame takes as its tangent (the offset h across the fibre then follows from the
/// view and the smooth normal: `bsdf::hair`); seen from inside, the tube is the far side of a
/// fibre whose scattering the BSDF at its near side already holds, and light passes it
/// straight, as a Transparent BSDF (no bounce, and shadow rays cross it).
fn on_fibre(scene: &Scene, sh: &SurfaceHit, view: View, s: &mut SurfaceMaterial) {
    if view.backfacing {
        *s = SurfaceMaterial {
            base_color: Vec3::ONE,
            roughness: 0.0,
            ior: 1.0,
            transmission: 1.0,
            specular: 0.0,
            specular_color: Vec3::ZERO,
            transparent: true,
            emission: s.emission,
            ..SurfaceMaterial::default()
        };
        return;
    }
    s.tangent = Some(sh.fibre_tangent(scene));
}

/// A node tree's closure as the material every integrator reads; the volume and subsurface
/// come from the material (glTF extensions), and node materials are never thin-walled (Cycles
/// has no such notion: every transmissive surface bounds a solid).
pub fn from_closure(material: &Material, c: &Closure) -> SurfaceMaterial {
    // Blender's (x, y, z) is glTF's (x, −z, y): back to the scene's axes.
    let direction = |v: Vec3| {
        (v != Vec3::ZERO)
            .then(|| gltf_axes(v).normalize_or_zero())
            .filter(|n| *n != Vec3::ZERO)
    };
    SurfaceMaterial {
        base_color: c.base_color,
        // A tree's alpha is a Transparent closure picked with probability 1 − alpha.
        alpha: 1.0,
        metallic: c.metallic,
        roughness: c.roughness,
        transmission: c.transmission,
        ior: c.ior,
        specular: c.specular,
        specular_color: c.specular_color,
        emission: c.emission,
        absorption: absorption_coefficient(
            material.attenuation_color,
            material.attenuation_distance,
        ),
        thin_walled: false,
        subsurface: material.subsurface,
        normal: direction(c.normal),
        coat_weight: c.coat_weight,
        coat_roughness: c.coat_roughness,
        coat_ior: c.coat_ior,
        coat_tint: c.coat_tint,
        coat_normal: direction(c.coat_normal),
        sheen_weight: c.sheen_weight,
        sheen_roughness: c.sheen_roughness,
        sheen_tint: c.sheen_tint,
        aspect: c.aspect,
        tangent: direction(c.tangent),
        diffuse_roughness: c.diffuse_roughness,
        thin_film_thickness: c.thin_film_thickness,
        thin_film_ior: c.thin_film_ior,
        thin_film_model: if c.thin_film_blender_5 {
            FilmModel::Blender5
        } else {
            FilmModel::Blender4
        },
        thin_film_weight: 1.0,
        transparent: c.transparent,
        translucent: c.translucent,
        diffuse_transmission: 0.0,
        diffuse_transmission_color: Vec3::ONE,
        refraction: c.refraction,
        glass: c.glass,
        holdout: c.holdout,
        portal: c.portal.map(|p| Portal {
            position: gltf_axes(p.position),
            direction: gltf_axes(p.direction).normalize_or_zero(),
            weight: c.base_color * c.weight,
        }),
        single_scatter: c.single_scatter,
        weight: c.weight,
        toon: c.toon,
        hair: c.hair,
        metal_tint: c.metal_tint,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_normal_turned_from_the_viewer_is_bent_until_its_mirror_direction_clears_the_surface() {
        let ng = Vec3::Z;
        let rises = |i: Vec3, n: Vec3| (2.0 * n.dot(i) * n - i).dot(ng);
        for (i, n) in [
            // A grazing view, the normal leaning away from it (and past it).
            (Vec3::new(0.95, 0.0, 0.3122), Vec3::new(-0.6, 0.0, 0.8)),
            (Vec3::new(0.95, 0.0, 0.3122), Vec3::new(-0.8, 0.3, 0.52)),
            // The normal leaning towards the view too far: the mirror goes under.
            (Vec3::new(0.6, 0.0, 0.8), Vec3::new(0.9, 0.0, 0.4359)),
        ] {
            let (i, n) = (i.normalize(), n.normalize());
            let bent = reflecting_normal(ng, ng, i, n);
            let rise = (0.9 * i.z).min(0.01);
            assert!(rises(i, n) < rise);
            assert!((rises(i, bent) - rise).abs() < 1e-3, "{i} {n} -> {bent}");
            assert!((bent.length() - 1.0).abs() < 1e-5);
        }
        // A valid normal, and the shading normal itself, are kept.
        let i = Vec3::new(0.6, 0.0, 0.8);
        let n = Vec3::new(0.1, 0.2, 0.97).normalize();
        assert_eq!(reflecting_normal(ng, ng, i, n), n);
        let flat = Vec3::new(-0.9, 0.0, 0.1).normalize();
        assert_eq!(reflecting_normal(ng, flat, i, flat), flat);
    }

    #[test]
    fn absorption_follows_beer_lambert() {
        let s = absorption_coefficient(Vec3::new(0.5, 1.0, 0.25), 2.0);
        assert!((s - Vec3::new(0.5f32.ln() / -2.0, 0.0, 0.25f32.ln() / -2.0)).length() < 1e-6);
        assert_eq!(
            absorption_coefficient(Vec3::splat(0.5), f32::INFINITY),
            Vec3::ZERO
        );
        assert!(absorption_coefficient(Vec3::ZERO, 1.0).is_finite());
    }
}
