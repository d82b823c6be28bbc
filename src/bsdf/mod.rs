//! The surface scattering model: Blender 4.5's Principled BSDF (the Cycles closure set) as glTF's
//! metallic-roughness model with KHR_materials_transmission / _ior / _specular describes it.
//! A closed set of lobes with static dispatch and free functions; the lobe math lives beside
//! this file (`microfacet`: GGX, `fresnel`: Fresnel models, `tables`: albedo tables).
//!
//! Composition (Cycles `svm_node_closure_principled`, Multiscatter GGX):
//! - metal, weight `metallic`: GGX conductor with F82-tint Fresnel (F0 = base colour, tint =
//!   specular colour), energy-compensated after Kulla & Conty 2017;
//! - glass, weight `(1 − metallic)·transmission`: rough or smooth dielectric reflection and
//!   refraction (Walter et al. 2007), transmission tinted by sqrt(base colour) per crossing;
//! - dielectric base, weight `(1 − metallic)(1 − transmission)`: an energy-compensated GGX
//!   specular layer over a Lambertian diffuse (or, with Diffuse Roughness, Cycles' Oren–Nayar
//!   lobe: `oren_nayar`), the diffuse scaled by 1 − (the layer's directional albedo), so a
//!   white base conserves energy; with KHR_materials_diffuse_transmission a share of that
//!   diffuse light is instead Lambertian transmission of the extension's colour, into the
//!   other side (the extension's mix(diffuse BRDF, diffuse BTDF, factor), under the same
//!   layers), sampled and evaluated as the Translucent BSDF's lobe (below);
//! - above them, top down as Cycles stacks them: a sheen layer (`sheen`: the microfiber sheen of
//!   Zeltner et al. 2022, weight `sheen weight × sheen tint`, around the normal mixed towards
//!   the coat's by the coat weight), then a coat (an untinted energy-compensated GGX dielectric
//!   of its own IOR, roughness and normal, weight `coat weight`). Each layer scales everything
//!   below it by 1 − (its directional albedo's largest channel) (Cycles'
//!   `closure_layering_weight`), and the coat tints what lies below by `tint^(1/cos θt)` (θt the
//!   view refracted into the coat), mixed in by the coat weight: these factors depend on the
//!   view, as in Cycles, so the layered BSDF is not reciprocal;
//! - Blender's Translucent BSDF (a node tree's `translucent` material) is a lobe of its own,
//!   alone: Lambertian transmission, f = colour / π for directions on the other side of the
//!   surface from the viewer, sampled cosine-weighted into that hemisphere (Cycles'
//!   `bsdf_translucent`); it is reciprocal, so photons scatter by the same lobe;
//! - Blender's Toon BSDF (`SurfaceMaterial::toon`) is a lobe of its own too, alone, as Cycles'
//!   `bsdf_toon`: `shader::Toon`'s intensity around the normal (diffuse) or the mirror
//!   direction (glossy), sampled uniformly in the cone it reaches, with that cone's density;
//! - Blender's hair BSDFs (`SurfaceMaterial::hair`) are their fibre's lobes alone (`hair`:
//!   Chiang et al. 2016's Principled Hair, and the older Hair BSDF), the frame's x axis along
//!   the fibre; light crosses the fibre, so the surface is never turned to the viewer's side;
//! - the specular layer and the metal are anisotropic GGX (α_x = α / aspect along the frame's
//!   x axis, the tangent; α_y = α · aspect), the glass and the coat isotropic.
//!
//! Conventions (all functions):
//! - directions are in the local shading frame, normal = +Z, both `wo` and `wi` point away from
//!   the surface; `wo.z < 0` means the viewer is on the back side (inside, for transmissive
//!   materials). Opaque materials (no glass lobe) scatter nothing for `wo.z ≤ 0`: the integrator
//!   flips their frame to the viewer's side. When a glass lobe exists, the opaque lobes reflect on
//!   the viewer's side (Cycles flips the normal of every closure on back faces) and the glass
//!   sees the inverse relative IOR;
//! - `ViewedBsdf::eval` returns f(wo, wi) · |cos θi| (the cosine is included);
//! - `ViewedBsdf::sample` returns `None` when it produces no direction; its `weight` is
//!   f · |cos θi| / pdf; for delta lobes `pdf` is the discrete probability of the choice and
//!   `delta` is true;
//! - `ViewedBsdf::pdf` is the solid-angle density of `sample` over the non-delta lobes (its
//!   integral is 1 minus the probability of delta lobes and of rejected samples);
//! - refraction does not scale radiance by η² (Cycles' convention): the camera paths' radiance
//!   is unchanged across an interface. That BSDF is not symmetric for a transmitted pair,
//!   f(wo, wi) = (η_i/η_o)² f(wi, wo): photons, which sample it and so conserve their flux, are
//!   scaled by 1/η² where they are stored inside a medium of index η
//!   (`integrator::photon::tracing::adjoint_scale`).

// `!(x > 0.0)` is deliberate throughout: it rejects NaN as well as non-positive values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod fresnel;
pub mod hair;
pub mod microfacet;
pub mod oren_nayar;
pub mod sheen;
pub mod tables;
pub mod thin_film;

use crate::material::SurfaceMaterial;
use crate::math::{max_component, reflect, refract, Frame, Vec2, Vec3};
use crate::sampling::{
    cosine_hemisphere_pdf, square_to_cosine_hemisphere, square_to_uniform_cone, uniform_cone_pdf,
};
pub use crate::shader::Scattering;
use fresnel::{f0_from_ior, fresnel_blend_factor, fresnel_dielectric, ior_from_f0, F82Tint};
use microfacet::{
    ggx_d, ggx_d_aniso, ggx_g2, ggx_g2_aniso, ggx_vndf_pdf, ggx_vndf_pdf_aniso, sample_ggx_vndf,
    sample_ggx_vndf_aniso, MIN_ALPHA,
};
use oren_nayar::OrenNayar;
use sheen::SheenLobe;
use std::f32::consts::FRAC_1_PI;
use tables::albedo_tables;
use thin_film::{
    scale_to_f0, thin_film_reflectance, weigh_film, ConductorFilm, FilmModel, ThinFilm,
};

/// Below this perceptual roughness the specular, metal and glass lobes are perfectly smooth
/// (delta lobes).
pub const SMOOTH_ROUGHNESS: f32 = 0.02;

/// Whether `material` may have a delta lobe (a smooth specular layer, metal, glass or coat),
/// through which a camera ray goes straight on to what it reflects or refracts: a node tree
/// with such a BSDF or a roughness texture may, whatever its factors.
pub fn may_be_smooth(material: &crate::scene::Material) -> bool {
    if let Some(program) = &material.nodes {
        return program.may_be_smooth;
    }
    material.metallic_roughness_texture.is_some()
        || material.roughness < SMOOTH_ROUGHNESS
        || (material.coat > 0.0
            && (material.coat_roughness < SMOOTH_ROUGHNESS
                || material.coat_roughness_texture.is_some()))
}

/// The GGX α of `SMOOTH_ROUGHNESS`: a lobe blurred to at least this is no longer a delta.
const SMOOTH_ALPHA: f32 = SMOOTH_ROUGHNESS * SMOOTH_ROUGHNESS;

/// What the path that reaches a surface leaves of its BSDF: Blender's Light Paths › Caustics
/// settings, as Cycles applies them when it builds a shading point's closures for the path.
/// Reflective and Refractive Caustics off leave out, on a surface reached straight after a
/// diffuse bounce, every glossy and singular reflection lobe (the metal, the specular layer
/// and the coat, which then dim nothing below them; the glass's reflection; the Toon BSDF's
/// glossy lobe) or transmission lobe (the glass's refraction; a Transparent BSDF's pass
/// stays); hair fibres and the sheen stay. Filter Glossy widens every GGX lobe (the specular
/// layer, the metal, the glass and the coat) to at least `min_alpha`, and Chiang's hair fibre
/// (`hair::HairBsdf::widened`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PathFilter {
    pub drop_reflection: bool,
    pub drop_refraction: bool,
    /// Least GGX α of the microfacet lobes (0: none).
    pub min_alpha: f32,
}

impl PathFilter {
    /// It leaves every BSDF as it is.
    pub fn is_none(&self) -> bool {
        !self.drop_reflection && !self.drop_refraction && !(self.min_alpha > 0.0)
    }

    /// Whether the lobe of `bsdf` that drew `bs` is one this filter leaves out.
    pub fn drops(&self, bsdf: &Bsdf, bs: &BsdfSample) -> bool {
        let glossy = matches!(bs.scattering, Scattering::Glossy | Scattering::Singular);
        let left_out = match bs.transmitted {
            true => self.drop_refraction,
            false => self.drop_reflection,
        };
        glossy && left_out && bsdf.hair.is_none()
    }
}

/// Glass whose IOR is this close to 1 neither reflects nor bends light: a delta pass-through.
const IOR_ONE_TOLERANCE: f32 = 1e-4;

/// Smallest rough-glass lobe choice probability (Cycles clamps to [0.125, 0.875] likewise).
const MIN_GLASS_CHOICE: f32 = 0.125;

/// Layer weights below this are absent (Cycles' `CLOSURE_WEIGHT_CUTOFF`).
const WEIGHT_CUTOFF: f32 = 1e-5;

/// The coat: an untinted GGX dielectric above the rest (Cycles' Principled coat).
#[derive(Clone, Copy, Debug)]
struct Coat {
    /// Coat Weight (≥ 0; 0: no coat).
    weight: f32,
    /// Coat IOR (≥ 1) and its F0.
    eta: f32,
    f0: f32,
    roughness: f32,
    alpha: f32,
    smooth: bool,
    /// Coat Tint: what lies below is seen through it.
    tint: Vec3,
    /// Unit coat normal in the local frame (+Z: the shading normal).
    normal: Vec3,
    /// Its reflection is left out (`PathFilter`): it then dims nothing below it, its tint
    /// stays.
    dropped: bool,
}

impl Coat {
    const NONE: Coat = Coat {
        weight: 0.0,
        eta: 1.5,
        f0: 0.04,
        roughness: 0.03,
        alpha: 0.0009,
        smooth: false,
        tint: Vec3::ONE,
        normal: Vec3::Z,
        dropped: false,
    };

    fn present(&self) -> bool {
        self.weight > WEIGHT_CUTOFF
    }

    /// The coat reflects (its IOR is not 1, and its reflection is not left out).
    fn reflects(&self) -> bool {
        self.present() && self.eta - 1.0 > IOR_ONE_TOLERANCE && !self.dropped
    }

    /// What the coat's tint lets through towards a viewer at cosine `cos_i` from the coat's
    /// normal: Beer–Lambert through a coat of unit thickness along the refracted view, mixed
    /// in by the coat weight (Cycles' Principled coat tint).
    fn tint_seen(&self, cos_i: f32) -> Vec3 {
        if !self.present() || self.tint == Vec3::ONE {
            return Vec3::ONE;
        }
        let cos_t = (1.0 - (1.0 - cos_i * cos_i) / (self.eta * self.eta))
            .max(1e-6)
            .sqrt();
        let depth = 1.0 / cos_t;
        let through = Vec3::new(
            self.tint.x.powf(depth),
            self.tint.y.powf(depth),
            self.tint.z.powf(depth),
        );
        mix(Vec3::ONE, through, self.weight.min(1.0))
    }
}

/// The sheen layer: `color` = Sheen Weight × Sheen Tint (zero: no sheen).
#[derive(Clone, Copy, Debug)]
struct Sheen {
    color: Vec3,
    roughness: f32,
}

/// The BSDF at one point, built once per hit from a `SurfaceMaterial`.
#[derive(Clone, Copy, Debug)]
pub struct Bsdf {
    base_color: Vec3,
    /// (1 − metallic)(1 − transmission): the dielectric base (specular layer over diffuse).
    base_weight: f32,
    metal_weight: f32,
    glass_weight: f32,
    /// Perceptual roughness, and GGX α = roughness² clamped to `MIN_ALPHA`.
    roughness: f32,
    alpha: f32,
    /// The specular layer's and the metal's α along the frame's x and y axes.
    alpha_x: f32,
    alpha_y: f32,
    /// Specular, metal and glass lobes are delta lobes.
    smooth: bool,
    /// The specular layer and the metal without energy compensation (GGX, not Multiscatter
    /// GGX: `SurfaceMaterial::single_scatter`).
    single_scatter: bool,
    /// Relative IOR of the dielectric specular layer after the specular-level adjustment; 1 when
    /// the layer is absent.
    spec_eta: f32,
    /// The specular layer is left out (`PathFilter`): the diffuse below it gives nothing up.
    spec_dropped: bool,
    /// F0 of the specular layer times the specular tint.
    spec_f0: Vec3,
    /// The Principled BSDF's thin film (`thin_film`) on the specular layer and the glass;
    /// `None`: no film, and the plain Fresnel.
    film: Option<ThinFilm>,
    /// What the film lies on in the specular layer: its IOR (Cycles' specular-level-adjusted
    /// IOR, below 1 when the material's is) and the real F0 of that IOR.
    spec_film_substrate: f32,
    spec_f0_real: f32,
    /// How much of the film's reflectance replaces the plain one (`weigh_film`).
    film_weight: f32,
    metal_fresnel: F82Tint,
    /// Blender 5's film on the metal (`thin_film::ConductorFilm`); `None`: the plain F82 tint.
    metal_film: Option<ConductorFilm>,
    /// IOR of the glass (inside over outside).
    glass_ior: f32,
    glass_f0: Vec3,
    glass_transmit_tint: Vec3,
    /// What the glass's reflection is multiplied by (a Glass BSDF node's colour; else white).
    glass_reflect_tint: Vec3,
    /// Fraction of the Lambertian part kept (1 − subsurface weight where a subsurface term
    /// replaces the rest; 1 otherwise).
    diffuse_scale: f32,
    coat: Coat,
    sheen: Sheen,
    /// The glass lobe is a Transparent BSDF (`SurfaceMaterial::transparent`).
    transparent: bool,
    /// The glass lobe transmits only, without Fresnel (`SurfaceMaterial::refraction`).
    refraction: bool,
    /// Oren–Nayar roughness of the diffuse lobe (`oren_nayar`; below its cutoff: Lambert).
    diffuse_roughness: f32,
    /// The Translucent BSDF's colour: f = translucent / π for directions on the other side
    /// of the surface from the viewer (zero: no such lobe).
    translucent: Vec3,
    /// KHR_materials_diffuse_transmission: the share of the dielectric base's diffuse lobe
    /// that transmits (Lambertian, into the other side) instead of reflecting, and the
    /// colour it transmits (`SurfaceMaterial::diffuse_transmission`).
    diffuse_transmission: f32,
    diffuse_transmission_color: Vec3,
    /// What the whole BSDF is multiplied by (`SurfaceMaterial::weight`; 1 but for a node
    /// tree's Add Shader): applied to `ViewedBsdf`'s values and samples, not to densities.
    weight: f32,
    /// A Toon BSDF (`SurfaceMaterial::toon`), its lobe alone, of `base_color`.
    toon: Option<crate::shader::Toon>,
    /// A hair fibre (`SurfaceMaterial::hair`), its lobes alone, times `base_color`.
    hair: Option<hair::HairBsdf>,
}

/// One sampled direction.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    pub wi: Vec3,
    /// f · |cos θi| / pdf.
    pub weight: Vec3,
    pub pdf: f32,
    /// A delta lobe (smooth mirror or glass): no light sampling, no MIS.
    pub delta: bool,
    /// `wi` is on the other side of the surface from `wo`.
    pub transmitted: bool,
    /// The lobe's kind, for node trees' Light Path (Cycles' closure labels).
    pub scattering: Scattering,
}

fn average(c: Vec3) -> f32 {
    (c.x + c.y + c.z) * (1.0 / 3.0)
}

fn mix(a: Vec3, b: Vec3, t: f32) -> Vec3 {
    a + (b - a) * t
}

/// Kulla–Conty multiple-scattering Fresnel term as Cycles applies it: the compensated lobe is
/// the single-scattering lobe times 1 + Fms·(1 − E)/E.
fn multiscatter_fresnel(f_avg: Vec3, e_avg: f32) -> Vec3 {
    f_avg * e_avg / (Vec3::ONE - f_avg * (1.0 - e_avg)).max(Vec3::splat(1e-6))
}

impl Bsdf {
    pub fn new(m: &SurfaceMaterial) -> Self {
        let clean = |v: f32, lo: f32, hi: f32| if v.is_finite() { v.clamp(lo, hi) } else { lo };
        let clean3 = |v: Vec3| {
            Vec3::new(
                clean(v.x, 0.0, f32::MAX),
                clean(v.y, 0.0, f32::MAX),
                clean(v.z, 0.0, f32::MAX),
            )
        };
        let base_color = clean3(m.base_color);
        let clamped_base = base_color.min(Vec3::ONE);
        let metallic = clean(m.metallic, 0.0, 1.0);
        let transmission = clean(m.transmission, 0.0, 1.0);
        let roughness = clean(m.roughness, 0.0, 1.0);
        let ior = if m.ior.is_finite() {
            m.ior.max(1e-5)
        } else {
            1.5
        };

        // glTF's specularColorFactor is Blender's 2·level·tint (and specularFactor scales it):
        // the level is its largest component, the tint its normalised colour.
        let specular_color = clean3(m.specular_color);
        let level2 = clean(m.specular, 0.0, f32::MAX) * max_component(specular_color);
        let tint = if max_component(specular_color) > 0.0 {
            specular_color / max_component(specular_color)
        } else {
            Vec3::ONE
        };

        // Cycles scales F0 by 2·level and re-derives the IOR from it.
        let layer_ior = if ior < 1.0 { 1.0 / ior } else { ior };
        let f0 = (f0_from_ior(layer_ior) * level2).min(0.99);
        let (spec_eta, spec_f0) = if f0 > 1e-7 {
            (ior_from_f0(f0), (tint * f0).min(Vec3::ONE))
        } else {
            (1.0, Vec3::ZERO)
        };

        let alpha = (roughness * roughness).max(MIN_ALPHA);
        let aspect = clean(m.aspect, 0.01, 1.0);
        let film_weight = clean(m.thin_film_weight, 0.0, 1.0);
        let film = ThinFilm::new(m.thin_film_thickness, m.thin_film_ior, m.thin_film_model)
            .filter(|_| film_weight > 0.0);
        let metal_fresnel = F82Tint::new(clamped_base, m.metal_tint.unwrap_or(tint));
        let metal_film = film
            .filter(|f| f.model == FilmModel::Blender5)
            .map(|f| ConductorFilm::new(f, &metal_fresnel));

        let coat_weight = clean(m.coat_weight, 0.0, f32::MAX);
        let coat = if coat_weight > WEIGHT_CUTOFF {
            let eta = if m.coat_ior.is_finite() {
                m.coat_ior.max(1.0)
            } else {
                1.5
            };
            let rough = clean(m.coat_roughness, 0.0, 1.0);
            Coat {
                weight: coat_weight,
                eta,
                f0: f0_from_ior(eta),
                roughness: rough,
                alpha: (rough * rough).max(MIN_ALPHA),
                smooth: rough < SMOOTH_ROUGHNESS,
                tint: clean3(m.coat_tint),
                normal: Vec3::Z,
                dropped: false,
            }
        } else {
            Coat::NONE
        };
        let sheen_weight = clean(m.sheen_weight, 0.0, f32::MAX);
        let sheen = Sheen {
            color: if sheen_weight > WEIGHT_CUTOFF {
                clean3(m.sheen_tint) * sheen_weight
            } else {
                Vec3::ZERO
            },
            roughness: clean(m.sheen_roughness, 0.0, 1.0),
        };

        // A Translucent or Toon BSDF is its lobe alone.
        let alone = m.translucent || m.toon.is_some() || m.hair.is_some();
        let (metallic, transmission) = if alone {
            (0.0, 0.0)
        } else {
            (metallic, transmission)
        };
        let dielectric = if alone { 0.0 } else { 1.0 - metallic };
        let diffuse_transmission = if alone {
            0.0
        } else {
            clean(m.diffuse_transmission, 0.0, 1.0)
        };
        Bsdf {
            base_color,
            base_weight: dielectric * (1.0 - transmission),
            metal_weight: metallic,
            glass_weight: dielectric * transmission,
            roughness,
            alpha,
            alpha_x: alpha / aspect,
            alpha_y: alpha * aspect,
            smooth: roughness < SMOOTH_ROUGHNESS,
            single_scatter: m.single_scatter,
            spec_eta,
            spec_dropped: false,
            spec_f0,
            film,
            spec_film_substrate: if ior < 1.0 { 1.0 / spec_eta } else { spec_eta },
            spec_f0_real: f0_from_ior(spec_eta),
            film_weight,
            metal_fresnel,
            metal_film,
            glass_ior: ior,
            glass_f0: (tint * f0_from_ior(ior)).min(Vec3::ONE),
            // A Transparent BSDF passes its colour (Cycles' weight); glass tints by the
            // colour's square root per crossing.
            glass_transmit_tint: if m.transparent || m.refraction || m.glass {
                clamped_base
            } else {
                Vec3::new(
                    clamped_base.x.sqrt(),
                    clamped_base.y.sqrt(),
                    clamped_base.z.sqrt(),
                )
            },
            diffuse_scale: 1.0,
            coat,
            sheen,
            transparent: m.transparent,
            refraction: m.refraction,
            diffuse_roughness: clean(m.diffuse_roughness, 0.0, 1.0),
            translucent: if m.translucent {
                base_color
            } else {
                Vec3::ZERO
            },
            diffuse_transmission,
            diffuse_transmission_color: clean3(m.diffuse_transmission_color),
            glass_reflect_tint: if m.glass { clamped_base } else { Vec3::ONE },
            weight: clean(m.weight, 0.0, f32::MAX),
            toon: m.toon,
            hair: m.hair.as_ref().map(hair::HairBsdf::new),
        }
    }

    /// The diffuse lobe is Lambertian (no Oren–Nayar roughness): `ViewedBsdf::diffuse_reflectance`
    /// over π is then its BRDF.
    pub fn diffuse_is_lambertian(&self) -> bool {
        self.diffuse_roughness < oren_nayar::LAMBERT_BELOW
    }

    /// The same BSDF with the coat's normal `n` (unit, in the local frame of the shading
    /// normal; Cycles' Coat Normal input).
    pub fn with_coat_normal(mut self, n: Vec3) -> Bsdf {
        if n.is_finite() && n.length_squared() > 0.0 {
            self.coat.normal = n.normalize();
        }
        self
    }

    /// What the coat's tint alone lets through towards `wo` (local frame, on the side of the
    /// normal): the dimming of the emission below it that Cycles applies when it evaluates an
    /// emitter for light sampling, which allocates no closures and so leaves out the coat's
    /// and sheen's reflection (`ViewedBsdf::layer_transmittance` has both).
    pub fn coat_tint_seen(&self, wo: Vec3) -> Vec3 {
        let n = self.coat.normal;
        self.coat
            .tint_seen(wo.dot(if n.dot(wo) < 0.0 { -n } else { n }))
    }

    /// The sheen's normal: the shading normal mixed towards the coat's by the coat weight.
    fn sheen_normal(&self) -> Vec3 {
        let t = if self.coat.present() {
            self.coat.weight.min(1.0)
        } else {
            0.0
        };
        Vec3::Z.lerp(self.coat.normal, t).normalize_or(Vec3::Z)
    }

    fn has_sheen(&self) -> bool {
        self.sheen.color != Vec3::ZERO
    }

    /// The same BSDF with `weight` of its Lambertian part removed, for shading a translucent
    /// surface whose subsurface term replaces that part (Principled v2).
    pub fn without_subsurface(mut self, weight: f32) -> Bsdf {
        self.diffuse_scale = (1.0 - weight).clamp(0.0, 1.0);
        self
    }

    /// This BSDF seen from `wo`: what depends on `wo` alone is computed here, once, for any
    /// number of evaluations and samples.
    pub fn viewed_from(&self, wo: Vec3) -> ViewedBsdf {
        match &self.hair {
            Some(fibre) => ViewedBsdf {
                bsdf: *self,
                wo,
                lobes: None,
                hair: fibre.viewed_from(wo),
            },
            None => ViewedBsdf {
                bsdf: *self,
                wo,
                lobes: LobeSet::new(self, wo),
                hair: None,
            },
        }
    }

    /// The dielectric base has a specular layer: its IOR is not 1, or a thin film reflects
    /// (Cycles keeps the layer for a film alone).
    fn has_spec_layer(&self) -> bool {
        self.base_weight > 0.0
            && (self.spec_eta != 1.0 || self.film.is_some())
            && !self.spec_dropped
    }

    /// This BSDF as path filter `f` leaves it (`PathFilter`).
    pub fn filtered(mut self, f: PathFilter) -> Bsdf {
        if f.drop_reflection {
            // The metal's share stays out of the layers below it, as Cycles' weight keeps
            // 1 − metallic when it allocates no metal closure.
            self.metal_weight = 0.0;
            self.spec_dropped = true;
            self.coat.dropped = true;
            self.glass_reflect_tint = Vec3::ZERO;
            if self.toon.is_some_and(|t| t.glossy) {
                self.toon = None;
            }
        }
        if f.drop_refraction && !self.transparent {
            self.glass_transmit_tint = Vec3::ZERO;
        }
        if f.min_alpha > 0.0 {
            // Only the lobes' shape widens: their energy compensation and the layering stay
            // those of the material's roughness (`roughness`, which the albedo tables read),
            // as in Cycles.
            let m = f.min_alpha;
            self.alpha = self.alpha.max(m);
            self.alpha_x = self.alpha_x.max(m);
            self.alpha_y = self.alpha_y.max(m);
            self.smooth &= m < SMOOTH_ALPHA;
            self.coat.alpha = self.coat.alpha.max(m);
            self.coat.smooth &= m < SMOOTH_ALPHA;
            self.hair = self.hair.map(|fibre| fibre.widened(m));
        }
        self
    }

    /// The metal's reflectance for a microfacet (or the macro-surface) at cosine `cos_i`:
    /// the F82 tint, or with Blender 5's film the film's over it.
    fn metal_reflectance(&self, cos_i: f32) -> Vec3 {
        let plain = self.metal_fresnel.eval(cos_i);
        match &self.metal_film {
            None => plain,
            Some(film) => weigh_film(plain, film.reflectance(cos_i), self.film_weight),
        }
    }

    /// The specular layer's reflectance for a microfacet (or the macro-surface) at cosine
    /// `cos_i`: Cycles' tinted dielectric mix(F0·tint, 1, s), or with a thin film its
    /// iridescent reflectance scaled towards the tinted F0 (`thin_film::scale_to_f0`).
    fn spec_fresnel(&self, cos_i: f32) -> Vec3 {
        let plain = || {
            mix(
                self.spec_f0,
                Vec3::ONE,
                fresnel_blend_factor(cos_i, self.spec_eta),
            )
        };
        match &self.film {
            None => plain(),
            Some(film) => {
                let f = scale_to_f0(
                    thin_film_reflectance(cos_i, film, self.spec_film_substrate),
                    self.spec_f0,
                    self.spec_f0_real,
                );
                if self.film_weight >= 1.0 {
                    f
                } else {
                    weigh_film(plain(), f, self.film_weight)
                }
            }
        }
    }

    /// The index of refraction of the medium a glass lobe bounds (inside over outside); 1 when
    /// the surface has no glass lobe or its glass passes light straight (no refraction).
    pub fn medium_ior(&self) -> f32 {
        if self.glass_weight > 0.0 && !self.transparent && !self.glass_passes_straight() {
            self.glass_ior
        } else {
            1.0
        }
    }

    /// True when every lobe but delta ones is glossy and some light crosses through the glass
    /// lobe: a rough (or smooth) dielectric, with no Lambertian, Oren–Nayar or Translucent lobe
    /// (a coat or sheen may lie above it); or a hair fibre, glossy lobes that cross it.
    pub fn is_glossy_dielectric(&self) -> bool {
        (self.glass_weight > 0.0 && self.base_weight == 0.0 && !self.has_translucent())
            || self.hair.is_some()
    }

    fn glass_passes_straight(&self) -> bool {
        (self.glass_ior - 1.0).abs() < IOR_ONE_TOLERANCE
    }

    /// True when some lobe is not a delta: light sampling can contribute.
    pub fn has_non_delta(&self) -> bool {
        self.base_weight > 0.0
            || (!self.smooth
                && (self.metal_weight > 0.0
                    || (self.glass_weight > 0.0 && !self.glass_passes_straight())))
            || self.has_sheen()
            || (self.coat.reflects() && !self.coat.smooth)
            || self.has_translucent()
            || self.hair.is_some()
    }

    fn has_translucent(&self) -> bool {
        self.translucent != Vec3::ZERO || self.transmits_diffusely()
    }

    /// The dielectric base transmits part of its diffuse light (KHR_materials_diffuse_transmission).
    fn transmits_diffusely(&self) -> bool {
        self.base_weight > 0.0
            && self.diffuse_transmission > 0.0
            && self.diffuse_transmission_color != Vec3::ZERO
    }

    /// True when every lobe is a delta (smooth metal or glass): no light sampling, no MIS.
    pub fn is_delta_only(&self) -> bool {
        !self.has_non_delta()
    }

    /// True when some lobe is a delta (a smooth mirror or glass component).
    pub fn has_delta(&self) -> bool {
        let smooth_lobe =
            self.metal_weight > 0.0 || self.glass_weight > 0.0 || self.has_spec_layer();
        (self.smooth && smooth_lobe)
            || (self.glass_weight > 0.0 && self.glass_passes_straight())
            || (self.coat.reflects() && self.coat.smooth)
    }

    /// True when light can cross the surface (a glass or translucent lobe exists): the
    /// integrator must not flip the frame to the viewer's side, and `wo.z < 0` means inside
    /// the object.
    pub fn is_transmissive(&self) -> bool {
        self.glass_weight > 0.0 || self.has_translucent() || self.hair.is_some()
    }

    /// True when some lobe is glossy or specular (anything but the Lambertian base): paths that
    /// leave through it can carry caustics.
    pub fn has_specular(&self) -> bool {
        self.base_has_specular() || self.coat.reflects() || self.hair.is_some()
    }

    fn base_has_specular(&self) -> bool {
        self.metal_weight > 0.0 || self.glass_weight > 0.0 || self.has_spec_layer()
    }

    /// Perceptual roughness of the smoothest glossy lobe (the base's, or the coat's when it is
    /// smoother); the base's when there is none.
    pub fn roughness(&self) -> f32 {
        if let Some(fibre) = &self.hair {
            fibre.roughness()
        } else if self.coat.reflects()
            && (self.coat.roughness < self.roughness || !self.base_has_specular())
        {
            self.coat.roughness
        } else {
            self.roughness
        }
    }
}

/// Everything about the lobes that depends on `wo` only.
#[derive(Clone, Copy, Debug)]
struct LobeSet {
    /// −1 when the frame is mirrored so the viewer is above the surface.
    side: f32,
    /// `wo` in the mirrored frame (z > 0).
    wo: Vec3,
    /// The diffuse lobe's weight: f = diffuse / π (Lambert), or diffuse × the Oren–Nayar
    /// lobe's value.
    diffuse: Vec3,
    /// The Oren–Nayar lobe seen from `wo` (`None`: Lambert).
    rough_diffuse: Option<OrenNayar>,
    /// The Lambertian transmission lobe's weight: f = translucent / π into the hemisphere
    /// opposite the viewer (a Translucent BSDF, or the base's diffuse transmission under the
    /// layers above it).
    translucent: Vec3,
    /// Fraction of the light that crosses the sheen, the coat and the specular layer into the
    /// base (its grey part: the coat's tint is left out).
    base_transmittance: f32,
    /// Specular-layer and metal multipliers (lobe weight × energy compensation × the layers
    /// above).
    spec_scale: Vec3,
    metal_scale: Vec3,
    /// The glass weight times the layers above.
    glass_scale: Vec3,
    /// Relative IOR seen by the glass from the viewer's side.
    glass_eta: f32,
    /// What the sheen and the coat let through to the base (and its emission).
    under: Vec3,
    /// The coat seen from `wo`: its frame in the mirrored frame (`None`: the shading normal),
    /// `wo` in it, and its multiplier (weight × energy compensation × the sheen above).
    coat_frame: Option<Frame>,
    coat_wo: Vec3,
    coat_scale: f32,
    /// The sheen seen from `wo`: its lobe, its frame (x towards the viewer) and f·cos / D.
    sheen: SheenLobe,
    sheen_frame: Frame,
    sheen_color: Vec3,
    /// Estimated directional albedo of each lobe.
    albedo: [Vec3; LOBES],
    /// Probability of sampling each lobe.
    prob: [f32; LOBES],
}

const DIFFUSE: usize = 0;
const SPECULAR: usize = 1;
const METAL: usize = 2;
const GLASS: usize = 3;
const COAT: usize = 4;
const SHEEN: usize = 5;
const TRANSLUCENT: usize = 6;
const TOON: usize = 7;
const LOBES: usize = 8;

/// Energy compensation of a GGX dielectric reflector (Cycles' `microfacet_ggx_preserve_energy`
/// with Fresnel mix(F0·tint, 1, s)) seen at cosine `mu`: its single-scattering multiplier
/// (1 + F_ms·(1 − E)/E) and E times the lobe-averaged Fresnel (the reflector's directional
/// albedo is their product). `film`: the reflectance of a thin film at `mu`, which stands for
/// the lobe-averaged Fresnel (Cycles has no table for films and takes the smooth surface's
/// value), while the compensation keeps the film-free F_ms, as Cycles' does.
fn dielectric_layer(
    smooth: bool,
    rough: f32,
    mu: f32,
    eta: f32,
    f0_tinted: Vec3,
    film: Option<Vec3>,
) -> (Vec3, Vec3) {
    let t = albedo_tables();
    let (e, e_avg) = if smooth {
        (1.0, 1.0)
    } else {
        (t.ggx_e(mu, rough).max(1e-3), t.ggx_e_avg(rough).max(1e-3))
    };
    let s = if smooth {
        fresnel_blend_factor(mu, eta)
    } else {
        t.dielectric_s_bar(mu, rough, eta)
    };
    let f_lobe = film.unwrap_or_else(|| mix(f0_tinted, Vec3::ONE, s));
    let f_avg = mix(f0_tinted, Vec3::ONE, t.dielectric_s_avg(eta));
    let compensation = Vec3::ONE + multiscatter_fresnel(f_avg, e_avg) * ((1.0 - e) / e);
    (compensation, f_lobe * e)
}

/// A frame around `n` whose x axis is `w`'s projection on its plane (any frame when `w` is
/// along `n`).
fn frame_towards(n: Vec3, w: Vec3) -> Frame {
    Frame::from_normal_tangent(n, w)
}

impl LobeSet {
    fn new(b: &Bsdf, wo: Vec3) -> Option<LobeSet> {
        if !wo.is_finite() || wo.z == 0.0 {
            return None;
        }
        let opaque_visible = wo.z > 0.0 || b.is_transmissive();
        if !opaque_visible {
            return None;
        }
        let side = if wo.z > 0.0 { 1.0 } else { -1.0 };
        let wo = Vec3::new(wo.x, wo.y, wo.z * side);
        // Seen from behind, every layer's normal turns to the viewer (as Cycles flips them):
        // a normal n is −n mirrored.
        let turned = |n: Vec3| Vec3::new(n.x * side, n.y * side, n.z);
        let mu = wo.z.min(1.0);
        let t = albedo_tables();
        let rough = b.roughness;

        let mut albedo = [Vec3::ZERO; LOBES];
        let mut spec_scale = Vec3::ZERO;
        let mut metal_scale = Vec3::ZERO;

        // The layers above the base, top down: each scales what lies below by 1 − its albedo.
        let mut above = 1.0f32;
        let mut sheen_frame = Frame {
            s: Vec3::X,
            t: Vec3::Y,
            n: Vec3::Z,
        };
        let mut sheen = SheenLobe {
            a: 1.0,
            b: 0.0,
            albedo: 0.0,
        };
        let mut sheen_color = Vec3::ZERO;
        if b.has_sheen() {
            let sheen_n = turned(b.sheen_normal());
            sheen_frame = frame_towards(sheen_n, wo);
            sheen = SheenLobe::new(wo.dot(sheen_n), b.sheen.roughness);
            sheen_color = b.sheen.color * sheen.albedo;
            albedo[SHEEN] = sheen_color;
            above *= (1.0 - max_component(sheen_color)).clamp(0.0, 1.0);
        }
        let coat_n = turned(b.coat.normal);
        let coat_frame = (coat_n != Vec3::Z).then(|| Frame::from_normal(coat_n));
        let coat_wo = coat_frame.map_or(wo, |f| f.to_local(wo));
        let mut coat_scale = 0.0;
        let mut tint = Vec3::ONE;
        if b.coat.present() {
            let c = &b.coat;
            if c.reflects() && coat_wo.z > 0.0 {
                let (compensation, fresnel_e) = dielectric_layer(
                    c.smooth,
                    c.roughness,
                    coat_wo.z.min(1.0),
                    c.eta,
                    Vec3::splat(c.f0),
                    None,
                );
                coat_scale = c.weight * compensation.x * above;
                let ratio = c.weight * fresnel_e.x * compensation.x;
                albedo[COAT] = Vec3::splat(ratio * above);
                above *= (1.0 - ratio).clamp(0.0, 1.0);
            }
            tint = c.tint_seen(coat_wo.z);
        }
        let under = tint * above;

        let mut layer_albedo = 0.0;
        if b.has_spec_layer() {
            let film = b.film.is_some().then(|| b.spec_fresnel(mu));
            let (compensation, fresnel_e) =
                dielectric_layer(b.smooth, rough, mu, b.spec_eta, b.spec_f0, film);
            let compensation = if b.single_scatter {
                Vec3::ONE
            } else {
                compensation
            };
            // The compensated lobe reflects E·f_lobe·(1 + F_ms·(1 − E)/E): Cycles' estimate of
            // the layer's albedo (bsdf_microfacet_estimate_albedo times the darkening already in
            // the weight), and what the diffuse below must give up.
            let weighted = compensation * b.base_weight;
            let layer = fresnel_e * weighted;
            layer_albedo = max_component(layer) / b.base_weight;
            spec_scale = weighted * under;
            albedo[SPECULAR] = layer * under;
        }
        let base_share = b.base_weight * (1.0 - layer_albedo).max(0.0);
        let base_transmittance = if tint == Vec3::ONE {
            base_share * above
        } else {
            base_share * above * average(tint)
        };
        let diffuse_share = under * (base_share * b.diffuse_scale);
        let diffuse = b.base_color * diffuse_share * (1.0 - b.diffuse_transmission);
        // The spec's mix(diffuse BRDF, diffuse BTDF, diffuseTransmission) under the same layers.
        let translucent = if b.transmits_diffusely() {
            b.translucent + b.diffuse_transmission_color * diffuse_share * b.diffuse_transmission
        } else {
            b.translucent
        };
        let rough_diffuse = OrenNayar::new(b.diffuse_roughness, b.base_color, mu);
        albedo[DIFFUSE] = rough_diffuse.map_or(diffuse, |on| diffuse * on.albedo());

        if b.metal_weight > 0.0 {
            let (e, e_avg) = if b.smooth {
                (1.0, 1.0)
            } else {
                (t.ggx_e(mu, rough).max(1e-3), t.ggx_e_avg(rough).max(1e-3))
            };
            let missing = (1.0 - e) / e;
            let f_view = b.metal_reflectance(mu);
            let f_ms = if b.single_scatter {
                Vec3::ZERO
            } else {
                multiscatter_fresnel(b.metal_fresnel.average(), e_avg)
            };
            albedo[METAL] = (f_view * e + f_ms * (1.0 - e)) * b.metal_weight * under;
            metal_scale = (Vec3::ONE + f_ms * missing) * b.metal_weight * under;
        }

        let glass_eta = if side > 0.0 {
            b.glass_ior
        } else {
            1.0 / b.glass_ior
        };
        // Multiscatter GGX glass: the single-scattering lobe divided by its own albedo (Cycles'
        // `microfacet_ggx_preserve_energy` with the glass tables), so white rough glass loses
        // nothing; GGX glass, the Refraction BSDF and Transparent passes are not compensated.
        let compensated = b.glass_weight > 0.0
            && !b.smooth
            && !b.single_scatter
            && !b.refraction
            && !b.transparent
            && !b.glass_passes_straight();
        let glass_compensation = if compensated {
            1.0 / t.glass_e(mu, rough, glass_eta).max(1e-3)
        } else {
            1.0
        };
        let glass_scale = under * (b.glass_weight * glass_compensation);
        if b.glass_weight > 0.0 {
            let (r, tr) = glass_split(b, mu, glass_eta);
            albedo[GLASS] = (r + tr) * glass_scale;
        }
        albedo[TRANSLUCENT] = translucent;
        if b.toon.is_some() {
            albedo[TOON] = b.base_color;
        }

        // Sample in proportion to the estimated albedo; a tiny floor keeps every lobe that can
        // carry light reachable.
        let mut prob = [0.0f32; LOBES];
        if b.base_weight > 0.0 {
            prob[DIFFUSE] = average(albedo[DIFFUSE]);
            if b.has_spec_layer() {
                prob[SPECULAR] = average(albedo[SPECULAR]).max(1e-4 * b.base_weight);
            }
        }
        if b.metal_weight > 0.0 {
            prob[METAL] = average(albedo[METAL]).max(1e-4 * b.metal_weight);
        }
        if b.glass_weight > 0.0 {
            prob[GLASS] = average(albedo[GLASS]).max(1e-4 * b.glass_weight);
        }
        if coat_scale > 0.0 {
            prob[COAT] = average(albedo[COAT]).max(1e-4 * b.coat.weight.min(1.0));
        }
        if b.has_sheen() {
            prob[SHEEN] = average(albedo[SHEEN]).max(1e-4);
        }
        if b.has_translucent() {
            prob[TRANSLUCENT] = average(albedo[TRANSLUCENT]).max(1e-4);
        }
        if b.toon.is_some() {
            prob[TOON] = average(albedo[TOON]).max(1e-4);
        }
        let total: f32 = prob.iter().sum();
        if !(total > 0.0) || !total.is_finite() {
            return None;
        }
        for p in &mut prob {
            *p /= total;
        }

        Some(LobeSet {
            side,
            wo,
            diffuse,
            rough_diffuse,
            translucent,
            base_transmittance,
            spec_scale,
            metal_scale,
            glass_scale,
            glass_eta,
            under,
            coat_frame,
            coat_wo,
            coat_scale,
            sheen,
            sheen_frame,
            sheen_color,
            albedo,
            prob,
        })
    }

    /// Mirror a direction into (or out of) the viewer-up frame.
    fn mirror(&self, w: Vec3) -> Vec3 {
        Vec3::new(w.x, w.y, w.z * self.side)
    }

    /// A direction of the mirrored frame in the coat's frame.
    fn in_coat_frame(&self, w: Vec3) -> Vec3 {
        self.coat_frame.map_or(w, |f| f.to_local(w))
    }

    fn out_of_coat_frame(&self, w: Vec3) -> Vec3 {
        self.coat_frame.map_or(w, |f| f.to_world(w))
    }
}

/// Glass reflectance and transmittance for a microfacet (or the macro-surface) at cosine `cos_i`
/// from the viewer's side with relative IOR `eta`: Cycles' tinted dielectric
/// F = mix(F0·tint, 1, s), T = (1 − F)·sqrt(base colour) (a Glass BSDF node: both times its
/// colour, `glass_reflect_tint`). Total internal reflection gives F = 1.
///
/// Blender's Refraction BSDF has no Fresnel: it transmits its colour whole, and nothing at
/// total internal reflection (Cycles' microfacet closure without Fresnel).
fn glass_split(b: &Bsdf, cos_i: f32, eta: f32) -> (Vec3, Vec3) {
    if b.glass_passes_straight() {
        return (Vec3::ZERO, b.glass_transmit_tint);
    }
    if b.refraction {
        let total = fresnel_dielectric(cos_i, eta) >= 1.0;
        return (
            Vec3::ZERO,
            if total {
                Vec3::ZERO
            } else {
                b.glass_transmit_tint
            },
        );
    }
    let r = match &b.film {
        None => mix(b.glass_f0, Vec3::ONE, fresnel_blend_factor(cos_i, eta)),
        Some(film) => {
            // Seen from inside (`eta` is the inverse IOR), Cycles reads the stack substrate |
            // film | outside as outside | film / IOR | 1 / IOR: the same reflectances, and
            // the film's index scaled as the substrate's.
            let film = if eta == b.glass_ior {
                *film
            } else {
                ThinFilm {
                    ior: film.ior / b.glass_ior,
                    ..*film
                }
            };
            let f = scale_to_f0(
                thin_film_reflectance(cos_i, &film, eta),
                b.glass_f0,
                f0_from_ior(b.glass_ior),
            );
            if b.film_weight >= 1.0 {
                f
            } else {
                let plain = mix(b.glass_f0, Vec3::ONE, fresnel_blend_factor(cos_i, eta));
                weigh_film(plain, f, b.film_weight)
            }
        }
    };
    (
        r * b.glass_reflect_tint,
        (Vec3::ONE - r) * b.glass_transmit_tint,
    )
}

/// Probability of choosing reflection for glass given its reflectance and transmittance.
fn glass_reflect_probability(r: Vec3, t: Vec3, smooth: bool) -> f32 {
    let (ra, ta) = (average(r), average(t));
    if ta <= 0.0 {
        return 1.0;
    }
    if ra <= 0.0 {
        return 0.0;
    }
    let p = ra / (ra + ta);
    if smooth {
        p
    } else {
        p.clamp(MIN_GLASS_CHOICE, 1.0 - MIN_GLASS_CHOICE)
    }
}

/// Refraction half vector (pointing up) and the terms its density needs, for `wo` above and `wi`
/// below an interface of relative IOR `eta`. `None` when the pair is not a valid refraction.
struct RefractionGeometry {
    h: Vec3,
    cos_oh: f32,
    cos_ih: f32,
    /// (wo·h + η wi·h)².
    denom2: f32,
}

fn refraction_geometry(wo: Vec3, wi: Vec3, eta: f32) -> Option<RefractionGeometry> {
    let mut h = -(wo + wi * eta);
    let len2 = h.length_squared();
    if !(len2 > 1e-12) {
        return None;
    }
    h /= len2.sqrt();
    if h.z < 0.0 {
        h = -h;
    }
    let cos_oh = wo.dot(h);
    let cos_ih = wi.dot(h);
    if cos_oh <= 0.0 || cos_ih >= 0.0 {
        return None;
    }
    let denom = cos_oh + eta * cos_ih;
    let denom2 = denom * denom;
    if !(denom2 > 1e-12) {
        return None;
    }
    Some(RefractionGeometry {
        h,
        cos_oh,
        cos_ih,
        denom2,
    })
}

/// The axis of a Toon lobe in the viewer-up frame: the normal, or the mirror direction of
/// `wo` for the glossy one.
fn toon_axis(toon: &crate::shader::Toon, wo: Vec3) -> Vec3 {
    if toon.glossy {
        Vec3::new(-wo.x, -wo.y, wo.z)
    } else {
        Vec3::Z
    }
}

/// f·|cos θi| and the solid-angle pdf (per lobe, before lobe probabilities), over non-delta
/// lobes, for `wo` and `wi` in the viewer-up frame.
fn eval_and_pdf(b: &Bsdf, l: &LobeSet, wi: Vec3) -> (Vec3, f32) {
    let wo = l.wo;
    let mut f = Vec3::ZERO;
    let mut pdf = 0.0;
    if !wi.is_finite() || wi.z == 0.0 {
        return (f, pdf);
    }
    if wi.z > 0.0 {
        if l.prob[DIFFUSE] > 0.0 {
            f += match &l.rough_diffuse {
                None => l.diffuse * (FRAC_1_PI * wi.z),
                Some(on) => l.diffuse * on.eval(wo, wi) * wi.z,
            };
            pdf += l.prob[DIFFUSE] * cosine_hemisphere_pdf(wi.z);
        }
        if l.prob[SHEEN] > 0.0 {
            let d = l.sheen.density(l.sheen_frame.to_local(wi));
            f += l.sheen_color * d;
            pdf += l.prob[SHEEN] * d;
        }
        if let (Some(toon), true) = (&b.toon, l.prob[TOON] > 0.0) {
            let cos = toon_axis(toon, wo).dot(wi).max(0.0);
            let intensity = toon.intensity(cos.min(1.0).acos());
            if intensity > 0.0 {
                let density = uniform_cone_pdf(toon.cos_cone());
                f += b.base_color * (intensity * density);
                pdf += l.prob[TOON] * density;
            }
        }
        if l.prob[COAT] > 0.0 && !b.coat.smooth {
            let (wo_c, wi_c) = (l.coat_wo, l.in_coat_frame(wi));
            let h = (wo_c + wi_c).normalize_or_zero();
            let cos_oh = wo_c.dot(h);
            if wi_c.z > 0.0 && h.z > 0.0 && cos_oh > 0.0 {
                let a = b.coat.alpha;
                let d = ggx_d(a, h);
                let fr = fresnel_dielectric(cos_oh, b.coat.eta);
                f += Vec3::splat(fr * l.coat_scale * d * ggx_g2(a, wo_c, wi_c) / (4.0 * wo_c.z));
                pdf += l.prob[COAT] * ggx_vndf_pdf(a, wo_c, h) / (4.0 * cos_oh);
            }
        }
        if b.smooth {
            return (f, pdf);
        }
        let h = (wo + wi).normalize_or_zero();
        let cos_oh = wo.dot(h);
        if h.z <= 0.0 || cos_oh <= 0.0 {
            return (f, pdf);
        }
        // The isotropic lobe (glass, and the others when isotropic).
        let isotropic = || {
            let d = ggx_d(b.alpha, h);
            let single = d * ggx_g2(b.alpha, wo, wi) / (4.0 * wo.z);
            (single, ggx_vndf_pdf(b.alpha, wo, h) / (4.0 * cos_oh))
        };
        if l.prob[SPECULAR] > 0.0 || l.prob[METAL] > 0.0 {
            let (ax, ay) = (b.alpha_x, b.alpha_y);
            let (single, reflect_pdf) = if ax == ay {
                isotropic()
            } else {
                let d = ggx_d_aniso(ax, ay, h);
                (
                    d * ggx_g2_aniso(ax, ay, wo, wi) / (4.0 * wo.z),
                    ggx_vndf_pdf_aniso(ax, ay, wo, h) / (4.0 * cos_oh),
                )
            };
            if l.prob[SPECULAR] > 0.0 {
                f += b.spec_fresnel(cos_oh) * l.spec_scale * single;
                pdf += l.prob[SPECULAR] * reflect_pdf;
            }
            if l.prob[METAL] > 0.0 {
                f += b.metal_reflectance(cos_oh) * l.metal_scale * single;
                pdf += l.prob[METAL] * reflect_pdf;
            }
        }
        if l.prob[GLASS] > 0.0 && !b.glass_passes_straight() {
            let (single, reflect_pdf) = isotropic();
            let (r, t) = glass_split(b, cos_oh, l.glass_eta);
            f += r * (l.glass_scale * single);
            pdf += l.prob[GLASS] * reflect_pdf * glass_reflect_probability(r, t, false);
        }
    } else {
        if l.prob[TRANSLUCENT] > 0.0 {
            // Lambertian transmission, into the hemisphere opposite the viewer.
            f += l.translucent * (FRAC_1_PI * -wi.z);
            pdf += l.prob[TRANSLUCENT] * cosine_hemisphere_pdf(-wi.z);
        }
        if !(l.prob[GLASS] > 0.0 && !b.smooth && !b.glass_passes_straight()) {
            return (f, pdf);
        }
        let eta = l.glass_eta;
        if let Some(g) = refraction_geometry(wo, wi, eta) {
            let d = ggx_d(b.alpha, g.h);
            let (r, t) = glass_split(b, g.cos_oh, eta);
            let jacobian = eta * eta * (-g.cos_ih) / g.denom2;
            let value = d * ggx_g2(b.alpha, wo, wi) * g.cos_oh * jacobian / wo.z;
            f += t * (l.glass_scale * value);
            let p_t = 1.0 - glass_reflect_probability(r, t, false);
            pdf += l.prob[GLASS] * ggx_vndf_pdf(b.alpha, wo, g.h) * jacobian * p_t;
        }
    }
    (f, pdf)
}

/// A BSDF seen from a fixed direction `wo` (`Bsdf::viewed_from`): the lobe weights, albedos and
/// sampling probabilities that depend on `wo` alone are computed once, so a shading point that
/// evaluates many directions (a light sample and its MIS density, the photons of a radiance
/// estimate) pays for them once. It dereferences to the `Bsdf` for the view-independent
/// queries.
#[derive(Clone, Copy, Debug)]
pub struct ViewedBsdf {
    bsdf: Bsdf,
    wo: Vec3,
    /// `None` when nothing scatters towards `wo` (an opaque surface seen from behind, or a
    /// hair fibre).
    lobes: Option<LobeSet>,
    /// A hair fibre seen from `wo` (`None`: no fibre, or one seen along its length).
    hair: Option<hair::ViewedHair>,
}

impl std::ops::Deref for ViewedBsdf {
    type Target = Bsdf;
    fn deref(&self) -> &Bsdf {
        &self.bsdf
    }
}

impl ViewedBsdf {
    /// f(wo, wi) · |cos θi| over the non-delta lobes.
    pub fn eval(&self, wi: Vec3) -> Vec3 {
        self.eval_and_pdf(wi).0
    }

    /// Solid-angle density with which `sample` produces `wi` through its non-delta lobes.
    pub fn pdf(&self, wi: Vec3) -> f32 {
        self.eval_and_pdf(wi).1
    }

    /// `eval` and `pdf` together (one half-vector computation).
    pub fn eval_and_pdf(&self, wi: Vec3) -> (Vec3, f32) {
        if let Some(fibre) = &self.hair {
            let (f, pdf) = fibre.eval_and_pdf(wi);
            return (f * self.bsdf.base_color * self.bsdf.weight, pdf);
        }
        match &self.lobes {
            Some(l) => {
                let (f, pdf) = eval_and_pdf(&self.bsdf, l, l.mirror(wi));
                (f * self.bsdf.weight, pdf)
            }
            None => (Vec3::ZERO, 0.0),
        }
    }

    /// Cheap estimate of the directional albedo ∫ f |cos θi| dωi (for Russian roulette and
    /// photon survival); exact for the diffuse and metal-free white cases up to table
    /// interpolation.
    pub fn albedo(&self) -> Vec3 {
        if let Some(fibre) = &self.hair {
            return fibre.albedo() * self.bsdf.base_color * self.bsdf.weight;
        }
        self.lobes
            .as_ref()
            .map_or(Vec3::ZERO, |l| l.albedo.iter().copied().sum::<Vec3>())
            * self.bsdf.weight
    }

    /// The diffuse lobe's directional albedo; when it is Lambertian
    /// (`Bsdf::diffuse_is_lambertian`), the diffuse term of `eval` is `diffuse_reflectance() / π ·
    /// |cos θi|`. It includes the base weight and the attenuation by the specular layer above
    /// it, which depends on the view angle (zero when `wo` cannot see the diffuse).
    pub fn diffuse_reflectance(&self) -> Vec3 {
        self.lobes
            .as_ref()
            .map_or(Vec3::ZERO, |l| l.albedo[DIFFUSE])
            * self.bsdf.weight
    }

    /// Fraction of the light arriving from (or leaving towards) `wo` that crosses the
    /// specular layer into the base (or out of it): (1 − metallic)(1 − transmission)(1 − the
    /// layer's directional albedo). Light entering a translucent base is this times the
    /// subsurface weight.
    pub fn base_transmittance(&self) -> f32 {
        self.lobes.as_ref().map_or(0.0, |l| l.base_transmittance) * self.bsdf.weight
    }

    /// What the sheen and coat layers let through from the base towards `wo` (Cycles
    /// attenuates the Principled BSDF's emission by it too); one without them.
    pub fn layer_transmittance(&self) -> Vec3 {
        self.lobes.as_ref().map_or(Vec3::ONE, |l| l.under)
    }

    /// The same view of `Bsdf::filtered`.
    pub fn filtered(&self, f: PathFilter) -> ViewedBsdf {
        self.bsdf.filtered(f).viewed_from(self.wo)
    }

    /// The same view of `Bsdf::without_subsurface`.
    pub fn without_subsurface(&self, weight: f32) -> ViewedBsdf {
        self.bsdf.without_subsurface(weight).viewed_from(self.wo)
    }

    /// Sample a direction: `u_lobe` picks the lobe (and, remapped, reflection or refraction for
    /// glass), `u` the direction within it.
    pub fn sample(&self, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if self.bsdf.hair.is_some() {
            let s = self.hair.as_ref()?.sample(u_lobe, u)?;
            return Some(BsdfSample {
                wi: s.wi,
                weight: s.f / s.pdf * self.bsdf.base_color * self.bsdf.weight,
                pdf: s.pdf,
                delta: false,
                transmitted: s.wi.z * self.wo.z < 0.0,
                scattering: Scattering::Glossy,
            });
        }
        let mut s = sample(&self.bsdf, self.lobes.as_ref()?, self.wo, u_lobe, u)?;
        s.weight *= self.bsdf.weight;
        Some(s)
    }
}

fn sample(b: &Bsdf, l: &LobeSet, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
    let wo_up = l.wo;
    // Pick the lobe and rescale u_lobe to [0, 1) within it.
    let mut lobe = usize::MAX;
    let mut start = 0.0;
    for (k, &p) in l.prob.iter().enumerate() {
        if p > 0.0 {
            lobe = k;
            if u_lobe < start + p {
                break;
            }
            start += p;
        }
    }
    if lobe == usize::MAX {
        return None;
    }
    let p_lobe = l.prob[lobe];
    let u_choice = ((u_lobe - start) / p_lobe).clamp(0.0, 0.999_999_94);
    let uu = [u.x, u.y];

    let delta = |wi_up: Vec3, value: Vec3, pdf: f32| -> Option<BsdfSample> {
        let transmitted = wi_up.z < 0.0;
        if !(pdf > 0.0) {
            return None;
        }
        let weight = value / pdf;
        if !weight.is_finite() || !wi_up.is_finite() {
            return None;
        }
        let wi = l.mirror(wi_up);
        Some(BsdfSample {
            wi,
            weight,
            pdf,
            delta: true,
            transmitted: wi.z * wo.z < 0.0,
            scattering: if transmitted && b.transparent {
                Scattering::Transparent
            } else {
                Scattering::Singular
            },
        })
    };
    let mirror = Vec3::new(-wo_up.x, -wo_up.y, wo_up.z);

    // The direction in the viewer-up frame, and whether it must lie above the surface.
    let (wi_up, above) = match lobe {
        DIFFUSE => (square_to_cosine_hemisphere(u), true),
        SPECULAR | METAL if b.smooth => {
            let value = if lobe == SPECULAR {
                b.spec_fresnel(wo_up.z) * l.spec_scale
            } else {
                b.metal_reflectance(wo_up.z) * l.metal_scale
            };
            return delta(mirror, value, p_lobe);
        }
        SPECULAR | METAL => {
            let h = sample_ggx_vndf_aniso(b.alpha_x, b.alpha_y, wo_up, uu);
            (reflect(wo_up, h), true)
        }
        COAT => {
            let wo_c = l.coat_wo;
            if b.coat.smooth {
                let wi_up = l.out_of_coat_frame(Vec3::new(-wo_c.x, -wo_c.y, wo_c.z));
                if !(wi_up.z > 0.0) {
                    return None;
                }
                let value = fresnel_dielectric(wo_c.z, b.coat.eta) * l.coat_scale;
                return delta(wi_up, Vec3::splat(value), p_lobe);
            }
            let h = sample_ggx_vndf(b.coat.alpha, wo_c, uu);
            let wi_c = reflect(wo_c, h);
            if !(wi_c.z > 0.0) {
                return None;
            }
            (l.out_of_coat_frame(wi_c), true)
        }
        SHEEN => (l.sheen_frame.to_world(l.sheen.sample(uu)), true),
        TRANSLUCENT => {
            let d = square_to_cosine_hemisphere(u);
            (Vec3::new(d.x, d.y, -d.z), false)
        }
        TOON => {
            let toon = b.toon.as_ref()?;
            let d = square_to_uniform_cone(u, toon.cos_cone());
            (Frame::from_normal(toon_axis(toon, wo_up)).to_world(d), true)
        }
        _ => {
            let eta = l.glass_eta;
            if b.smooth || b.glass_passes_straight() {
                let (r, t) = glass_split(b, wo_up.z, eta);
                let p_r = glass_reflect_probability(r, t, true);
                return if u_choice < p_r {
                    delta(mirror, r * l.glass_scale, p_lobe * p_r)
                } else {
                    let wi_up = refract(wo_up, Vec3::Z, eta)?;
                    delta(wi_up, t * l.glass_scale, p_lobe * (1.0 - p_r))
                };
            }
            let h = sample_ggx_vndf(b.alpha, wo_up, uu);
            let cos_oh = wo_up.dot(h);
            let (r, t) = glass_split(b, cos_oh, eta);
            if u_choice < glass_reflect_probability(r, t, false) {
                (reflect(wo_up, h), true)
            } else {
                (refract(wo_up, h, eta)?, false)
            }
        }
    };
    // Reflections that leave below the surface (and refractions that leave above) are lost:
    // `ViewedBsdf::pdf` does not count them either.
    if (above && !(wi_up.z > 0.0)) || (!above && !(wi_up.z < 0.0)) {
        return None;
    }
    let (f, pdf) = eval_and_pdf(b, l, wi_up);
    if !(pdf > 0.0) || !pdf.is_finite() {
        return None;
    }
    let weight = f / pdf;
    if !weight.is_finite() {
        return None;
    }
    let wi = l.mirror(wi_up);
    Some(BsdfSample {
        wi,
        weight,
        pdf,
        delta: false,
        transmitted: wi.z * wo.z < 0.0,
        scattering: if matches!(lobe, DIFFUSE | SHEEN | TRANSLUCENT)
            || (lobe == TOON && !b.toon.is_some_and(|t| t.glossy))
        {
            Scattering::Diffuse
        } else {
            Scattering::Glossy
        },
    })
}
