//! What a shader node gives (`Closure`: Principled parameters and emission) and the shader
//! nodes themselves: the Principled, Diffuse, Glossy, Sheen, Glass, Refraction, Emission,
//! Transparent, Holdout and Translucent BSDFs into `Closure`s, and Mix and Add Shader (see the
//! module header of `shader` for how each maps).

use super::inputs::{input, normal_input, Operands, PointInputs, ShadingInputs, Socket, Ty, GREY};
use crate::math::{Vec3, Vec4};
use crate::phase::Phase;
use std::f32::consts::{FRAC_PI_2, PI};

/// The Principled node's inputs.
pub(super) const PRINCIPLED_INPUTS: &[Socket] = &[
    Socket::color("Base Color", GREY),
    Socket::float("Metallic", 0.0),
    Socket::float("Roughness", 0.5),
    Socket::float("IOR", 1.5),
    Socket::float("Alpha", 1.0),
    Socket::float("Specular IOR Level", 0.5),
    Socket::color("Specular Tint", Vec4::ONE),
    Socket::float("Transmission Weight", 0.0),
    Socket::color("Emission Color", Vec4::ONE),
    Socket::float("Emission Strength", 0.0),
    Socket::vector("Normal", Vec4::ZERO),
    Socket::float("Anisotropic", 0.0),
    Socket::float("Anisotropic Rotation", 0.0),
    Socket::vector("Tangent", Vec4::ZERO),
    Socket::float("Coat Weight", 0.0),
    Socket::float("Coat Roughness", 0.03),
    Socket::float("Coat IOR", 1.5),
    Socket::color("Coat Tint", Vec4::ONE),
    Socket::vector("Coat Normal", Vec4::ZERO),
    Socket::float("Sheen Weight", 0.0),
    Socket::float("Sheen Roughness", 0.5),
    Socket::color("Sheen Tint", Vec4::ONE),
    Socket::float("Diffuse Roughness", 0.0),
    Socket::float("Thin Film Thickness", 0.0),
    Socket::float("Thin Film IOR", 1.33),
];

/// The Principled node's outputs.
pub(super) const PRINCIPLED_OUTPUTS: &[Socket] = &[Socket::output("BSDF", Ty::Shader)];

/// The Diffuse node's inputs.
pub(super) const DIFFUSE_INPUTS: &[Socket] = &[
    Socket::color("Color", GREY),
    Socket::float("Roughness", 0.0),
    Socket::vector("Normal", Vec4::ZERO),
];

/// The Diffuse node's outputs.
pub(super) const DIFFUSE_OUTPUTS: &[Socket] = &[Socket::output("BSDF", Ty::Shader)];

/// The Sheen node's inputs.
pub(super) const SHEEN_INPUTS: &[Socket] = &[
    Socket::color("Color", GREY),
    Socket::float("Roughness", 0.5),
    Socket::vector("Normal", Vec4::ZERO),
];

/// The Sheen node's outputs.
pub(super) const SHEEN_OUTPUTS: &[Socket] = &[Socket::output("BSDF", Ty::Shader)];

/// The Glossy node's inputs.
pub(super) const GLOSSY_INPUTS: &[Socket] = &[
    Socket::color("Color", GREY),
    Socket::float("Roughness", 0.5),
    Socket::vector("Normal", Vec4::ZERO),
    Socket::float("Anisotropy", 0.0),
    Socket::float("Rotation", 0.0),
    Socket::vector("Tangent", Vec4::ZERO),
];

/// The Glossy node's outputs.
pub(super) const GLOSSY_OUTPUTS: &[Socket] = &[Socket::output("BSDF", Ty::Shader)];

/// The Metallic BSDF node's inputs.
pub(super) const METALLIC_INPUTS: &[Socket] = &[
    Socket::color("Base Color", Vec4::new(0.617, 0.577, 0.540, 1.0)),
    Socket::color("Edge Tint", Vec4::new(0.695, 0.726, 0.770, 1.0)),
    Socket::vector("IOR", Vec4::new(2.757, 2.513, 2.231, 1.0)),
    Socket::vector("Extinction", Vec4::new(3.867, 3.404, 3.009, 1.0)),
    Socket::float("Roughness", 0.5),
    Socket::float("Anisotropy", 0.0),
    Socket::float("Rotation", 0.0),
    Socket::vector("Normal", Vec4::ZERO),
    Socket::vector("Tangent", Vec4::ZERO),
];

/// The Metallic BSDF node's outputs.
pub(super) const METALLIC_OUTPUTS: &[Socket] = &[Socket::output("BSDF", Ty::Shader)];

/// The Glass and Refraction BSDF node's inputs.
pub(super) const GLASS_INPUTS: &[Socket] = &[
    Socket::color("Color", Vec4::ONE),
    Socket::float("Roughness", 0.0),
    Socket::float("IOR", 1.5),
    Socket::vector("Normal", Vec4::ZERO),
];

/// The Glass and Refraction BSDF node's outputs.
pub(super) const GLASS_OUTPUTS: &[Socket] = &[Socket::output("BSDF", Ty::Shader)];

/// The Emission node's inputs.
pub(super) const EMISSION_INPUTS: &[Socket] = &[
    Socket::color("Color", Vec4::ONE),
    Socket::float("Strength", 1.0),
];

/// The Emission node's outputs.
pub(super) const EMISSION_OUTPUTS: &[Socket] = &[Socket::output("Emission", Ty::Shader)];

/// The Transparent node's inputs.
pub(super) const TRANSPARENT_INPUTS: &[Socket] = &[Socket::color("Color", Vec4::ONE)];

/// The Transparent node's outputs.
pub(super) const TRANSPARENT_OUTPUTS: &[Socket] = &[Socket::output("BSDF", Ty::Shader)];

/// The Ray Portal node's inputs: Position and Direction unlinked are the shading point and
/// the ray's own direction (`eval_ray_portal`).
pub(super) const RAY_PORTAL_INPUTS: &[Socket] = &[
    Socket::color("Color", Vec4::ONE),
    Socket::vector("Position", Vec4::ZERO),
    Socket::vector("Direction", Vec4::ZERO),
];

/// The Ray Portal node's outputs.
pub(super) const RAY_PORTAL_OUTPUTS: &[Socket] = &[Socket::output("BSDF", Ty::Shader)];

/// The Holdout node's outputs.
pub(super) const HOLDOUT_OUTPUTS: &[Socket] = &[Socket::output("Holdout", Ty::Shader)];

/// The Translucent node's inputs.
pub(super) const TRANSLUCENT_INPUTS: &[Socket] = &[
    Socket::color("Color", Vec4::ONE),
    Socket::vector("Normal", Vec4::ZERO),
];

/// The Translucent node's outputs.
pub(super) const TRANSLUCENT_OUTPUTS: &[Socket] = &[Socket::output("BSDF", Ty::Shader)];

/// The Mix Shader node's inputs.
pub(super) const MIX_SHADER_INPUTS: &[Socket] = &[
    Socket::float("Fac", 0.5),
    Socket::shader("Shader"),
    Socket::shader("Shader_001"),
];

/// The Mix Shader node's outputs.
pub(super) const MIX_SHADER_OUTPUTS: &[Socket] = &[Socket::output("Shader", Ty::Shader)];

/// The Add Shader node's inputs.
pub(super) const ADD_SHADER_INPUTS: &[Socket] =
    &[Socket::shader("Shader"), Socket::shader("Shader_001")];

/// The Add Shader node's outputs.
pub(super) const ADD_SHADER_OUTPUTS: &[Socket] = &[Socket::output("Shader", Ty::Shader)];

/// Blender's Toon BSDF (Cycles' `bsdf_toon`): full intensity within `size` · 90° of its axis
/// (the normal, or with `glossy` the mirror direction of the view), fading linearly to zero
/// over a further `smooth` · 90°, sampled uniformly in the cone out to where it ends (at most
/// 90°), with that cone's density: f·cos = colour · intensity / (2π (1 − cos of the cone)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Toon {
    pub size: f32,
    pub smooth: f32,
    pub glossy: bool,
}

impl Toon {
    /// The cosine of the cone the lobe is sampled in.
    pub fn cos_cone(&self) -> f32 {
        (FRAC_PI_2 * (self.size + self.smooth)).min(FRAC_PI_2).cos()
    }

    /// The intensity at angle `angle` (radians) from the axis.
    pub fn intensity(&self, angle: f32) -> f32 {
        let (max_angle, smooth) = (self.size * FRAC_PI_2, self.smooth * FRAC_PI_2);
        if angle < max_angle {
            1.0
        } else if angle < max_angle + smooth && smooth != 0.0 {
            1.0 - (angle - max_angle) / smooth
        } else {
            0.0
        }
    }
}

/// The Toon node's inputs.
pub(super) const TOON_INPUTS: &[Socket] = &[
    Socket::color("Color", GREY),
    Socket::float("Size", 0.5),
    Socket::float("Smooth", 0.0),
    Socket::vector("Normal", Vec4::ZERO),
];

/// The Toon node's outputs.
pub(super) const TOON_OUTPUTS: &[Socket] = &[Socket::output("BSDF", Ty::Shader)];

/// The Toon BSDF: Color, Size, Smooth, Normal; `glossy`: its Glossy component.
#[inline(always)]
pub(super) fn eval_toon(glossy: bool, ins: &impl Operands) -> Closure {
    const COLOR: usize = input(TOON_INPUTS, "Color");
    const SIZE: usize = input(TOON_INPUTS, "Size");
    const SMOOTH: usize = input(TOON_INPUTS, "Smooth");
    const NORMAL: usize = input(TOON_INPUTS, "Normal");
    Closure {
        base_color: ins.vector(COLOR),
        normal: ins.vector(NORMAL),
        toon: Some(Toon {
            size: ins.float(SIZE).clamp(0.0, 1.0),
            smooth: ins.float(SMOOTH).clamp(0.0, 1.0),
            glossy,
        }),
        ..Closure::BLACK
    }
}

/// A hair fibre's scattering as Blender's hair BSDFs give it, evaluated by `crate::bsdf::hair`
/// along the fibre's tangent.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Hair {
    /// The Principled Hair BSDF, Chiang model (Chiang, Bitterli, Tappan & Burley 2016), with
    /// its inputs resolved as Cycles resolves them: `sigma` the absorption coefficient per
    /// unit of the fibre's diameter, `roughness` and `radial_roughness` Roughness and Radial
    /// Roughness after Random Roughness, `coat` (the primary reflection's roughness is
    /// (1 − coat) × roughness), `ior`, `tilt` the cuticle tilt (Offset, radians).
    Chiang {
        sigma: Vec3,
        roughness: f32,
        radial_roughness: f32,
        coat: f32,
        ior: f32,
        tilt: f32,
    },
    /// Blender's older Hair BSDF, its Reflection or (`transmission`) Transmission component:
    /// `color` times a Gaussian-like lobe of widths `roughness_u` (along the fibre) and
    /// `roughness_v` (around it), its highlight shifted by `offset` (radians).
    Gaussian {
        transmission: bool,
        color: Vec3,
        offset: f32,
        roughness_u: f32,
        roughness_v: f32,
    },
}

/// How the Principled Hair BSDF's colour is given (its Parametrization).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HairColoring {
    /// Direct Coloring: the absorption that gives Color after many scatterings.
    Color,
    /// Melanin Concentration (with Melanin Redness, Tint and Random Color).
    Melanin,
    /// Absorption Coefficient, as given.
    Absorption,
}

/// The Principled Hair node's inputs (Blender 4.5's, Huang's among them, unread).
pub(super) const PRINCIPLED_HAIR_INPUTS: &[Socket] = &[
    Socket::color("Color", Vec4::new(0.017513, 0.005763, 0.002059, 1.0)),
    Socket::float("Melanin", 0.8),
    Socket::float("Melanin Redness", 1.0),
    Socket::color("Tint", Vec4::ONE),
    Socket::vector(
        "Absorption Coefficient",
        Vec4::new(0.245531, 0.52, 1.365, 0.0),
    ),
    Socket::float("Aspect Ratio", 0.85),
    Socket::float("Roughness", 0.3),
    Socket::float("Radial Roughness", 0.3),
    Socket::float("Coat", 0.0),
    Socket::float("IOR", 1.55),
    Socket::float("Offset", 2.0 * PI / 180.0),
    Socket::float("Random Color", 0.0),
    Socket::float("Random Roughness", 0.0),
    Socket::float("Random", 0.0),
];

/// The Principled Hair node's outputs.
pub(super) const PRINCIPLED_HAIR_OUTPUTS: &[Socket] = &[Socket::output("BSDF", Ty::Shader)];

/// Absorption per unit diameter of eumelanin and pheomelanin concentrations (d'Eon et al.
/// 2011's pigment spectra as RGB, the values Cycles uses).
fn hair_sigma_from_melanin(eumelanin: f32, pheomelanin: f32) -> Vec3 {
    eumelanin * Vec3::new(0.506, 0.841, 1.653) + pheomelanin * Vec3::new(0.343, 0.733, 1.924)
}

/// The absorption whose multiply-scattered colour is `color` at radial roughness `radial`
/// (Chiang et al. 2016's fit, §4.2).
fn hair_sigma_from_color(color: Vec3, radial: f32) -> Vec3 {
    let x = radial;
    let fit = (((((0.245 * x) + 5.574) * x - 10.73) * x + 2.532) * x - 0.215) * x + 5.969;
    let per = |c: f32| (c.max(1e-6).ln() / fit).powi(2);
    Vec3::new(per(color.x), per(color.y), per(color.z))
}

/// The Principled Hair BSDF (Chiang model) as Cycles resolves its inputs: Random scales
/// the roughnesses by 1 + 2 (random − ½) × Random Roughness (and Melanin by the same with
/// Random Color); Melanin m in [0, 1) becomes the concentration −ln(1 − m), split by Melanin
/// Redness into pheomelanin and eumelanin, plus the Tint's absorption.
#[inline(always)]
pub(super) fn eval_principled_hair(coloring: HairColoring, ins: &impl Operands) -> Closure {
    const COLOR: usize = input(PRINCIPLED_HAIR_INPUTS, "Color");
    const MELANIN: usize = input(PRINCIPLED_HAIR_INPUTS, "Melanin");
    const REDNESS: usize = input(PRINCIPLED_HAIR_INPUTS, "Melanin Redness");
    const TINT: usize = input(PRINCIPLED_HAIR_INPUTS, "Tint");
    const ABSORPTION: usize = input(PRINCIPLED_HAIR_INPUTS, "Absorption Coefficient");
    const ROUGHNESS: usize = input(PRINCIPLED_HAIR_INPUTS, "Roughness");
    const RADIAL: usize = input(PRINCIPLED_HAIR_INPUTS, "Radial Roughness");
    const COAT: usize = input(PRINCIPLED_HAIR_INPUTS, "Coat");
    const IOR: usize = input(PRINCIPLED_HAIR_INPUTS, "IOR");
    const OFFSET: usize = input(PRINCIPLED_HAIR_INPUTS, "Offset");
    const RANDOM_COLOR: usize = input(PRINCIPLED_HAIR_INPUTS, "Random Color");
    const RANDOM_ROUGHNESS: usize = input(PRINCIPLED_HAIR_INPUTS, "Random Roughness");
    const RANDOM: usize = input(PRINCIPLED_HAIR_INPUTS, "Random");
    let random = ins.float(RANDOM);
    let rough_factor = 1.0 + 2.0 * (random - 0.5) * ins.float(RANDOM_ROUGHNESS);
    let roughness = ins.float(ROUGHNESS) * rough_factor;
    let radial_roughness = ins.float(RADIAL) * rough_factor;
    let sigma = match coloring {
        HairColoring::Absorption => ins.vector(ABSORPTION),
        HairColoring::Color => hair_sigma_from_color(ins.vector(COLOR), radial_roughness),
        HairColoring::Melanin => {
            let random_color = ins.float(RANDOM_COLOR).clamp(0.0, 1.0);
            let melanin = ins.float(MELANIN) * (1.0 + 2.0 * (random - 0.5) * random_color);
            let concentration = -(1.0 - melanin).max(1e-4).ln();
            let redness = ins.float(REDNESS);
            hair_sigma_from_melanin(concentration * (1.0 - redness), concentration * redness)
                + hair_sigma_from_color(ins.vector(TINT), radial_roughness)
        }
    };
    hair_closure(Hair::Chiang {
        sigma: sigma.max(Vec3::ZERO),
        roughness,
        radial_roughness,
        coat: ins.float(COAT),
        ior: ins.float(IOR),
        tilt: ins.float(OFFSET),
    })
}

/// The Hair BSDF node's inputs.
pub(super) const HAIR_INPUTS: &[Socket] = &[
    Socket::color("Color", GREY),
    Socket::float("Offset", 0.0),
    Socket::float("RoughnessU", 0.1),
    Socket::float("RoughnessV", 1.0),
    Socket::vector("Tangent", Vec4::ZERO),
];

/// The Hair BSDF node's outputs.
pub(super) const HAIR_OUTPUTS: &[Socket] = &[Socket::output("BSDF", Ty::Shader)];

/// Blender's Hair BSDF: Color, Offset, RoughnessU, RoughnessV; its Reflection or
/// (`transmission`) Transmission component.
#[inline(always)]
pub(super) fn eval_hair(transmission: bool, ins: &impl Operands) -> Closure {
    const COLOR: usize = input(HAIR_INPUTS, "Color");
    const OFFSET: usize = input(HAIR_INPUTS, "Offset");
    const ROUGHNESS_U: usize = input(HAIR_INPUTS, "RoughnessU");
    const ROUGHNESS_V: usize = input(HAIR_INPUTS, "RoughnessV");
    let mut c = hair_closure(Hair::Gaussian {
        transmission,
        color: ins.vector(COLOR).max(Vec3::ZERO),
        offset: ins.float(OFFSET),
        roughness_u: ins.float(ROUGHNESS_U),
        roughness_v: ins.float(ROUGHNESS_V),
    });
    c.base_color = ins.vector(COLOR).max(Vec3::ZERO);
    c
}

/// A hair closure: light crosses the fibre (`transmission` 1), so no integrator turns its
/// frame to the viewer's side.
fn hair_closure(hair: Hair) -> Closure {
    Closure {
        base_color: Vec3::ONE,
        transmission: 1.0,
        ior: 1.0,
        hair: Some(hair),
        ..Closure::BLACK
    }
}

/// The volume part of a closure.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VolumeClosure {
    pub scattering: Vec3,
    pub absorption: Vec3,
    pub phase: Phase,
}

impl VolumeClosure {
    /// No medium.
    pub const NONE: VolumeClosure = VolumeClosure {
        scattering: Vec3::ZERO,
        absorption: Vec3::ZERO,
        phase: Phase::HenyeyGreenstein(0.0),
    };
}

/// The volume part of a Mix Shader of `a` and `b` by factor `t` (`t` = 1: all `b`), or with
/// `t` = None of an Add Shader.
fn combine(a: &VolumeClosure, b: &VolumeClosure, t: Option<f32>) -> VolumeClosure {
    let (wa, wb) = match t {
        Some(t) => (1.0 - t, t),
        None => (1.0, 1.0),
    };
    let (sa, sb) = (a.scattering * wa, b.scattering * wb);
    VolumeClosure {
        scattering: sa + sb,
        absorption: a.absorption * wa + b.absorption * wb,
        phase: if sb.element_sum() > sa.element_sum() {
            b.phase
        } else {
            a.phase
        },
    }
}

/// A shader node's result: Principled parameters and emission (see the module header).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Closure {
    pub base_color: Vec3,
    pub metallic: f32,
    pub roughness: f32,
    pub transmission: f32,
    pub ior: f32,
    /// glTF's specularFactor and specularColorFactor (Blender's 2 × level × tint).
    pub specular: f32,
    pub specular_color: Vec3,
    /// Emitted radiance (W·m⁻²·sr⁻¹).
    pub emission: Vec3,
    /// Shading normal from a Normal input (Blender's axes, world); zero: the surface's own.
    pub normal: Vec3,
    /// The Principled coat: weight, roughness, IOR, tint and normal (Blender's axes; zero:
    /// the shading normal).
    pub coat_weight: f32,
    pub coat_roughness: f32,
    pub coat_ior: f32,
    pub coat_tint: Vec3,
    pub coat_normal: Vec3,
    /// The sheen: weight, roughness and tint (Principled's sheen layer, or a Sheen BSDF).
    pub sheen_weight: f32,
    pub sheen_roughness: f32,
    pub sheen_tint: Vec3,
    /// Anisotropy as `SurfaceMaterial::aspect` (α_y / α_x), along `tangent` (Blender's axes,
    /// rotation applied; zero: the shading frame's).
    pub aspect: f32,
    pub tangent: Vec3,
    /// Oren–Nayar roughness of the diffuse lobe (0: Lambert).
    pub diffuse_roughness: f32,
    /// The Principled Thin Film: thickness (nm) and IOR.
    pub thin_film_thickness: f32,
    pub thin_film_ior: f32,
    /// Blender 5's thin film (`bsdf::thin_film::FilmModel::Blender5`: the CIE table, and the
    /// metal filmed too); else Blender 4's.
    pub thin_film_blender_5: bool,
    /// A Transparent BSDF: its pass is not a bounce, and shadow rays go through it.
    pub transparent: bool,
    /// A Translucent BSDF: Lambertian transmission of `base_color` and nothing else.
    pub translucent: bool,
    /// A Refraction BSDF: the glass's transmission alone, of `base_color`, without Fresnel.
    pub refraction: bool,
    /// A Glass BSDF: its colour weighs the reflection and each crossing alike (Cycles'
    /// closure weight), where the Principled BSDF's tints only the transmission, by its root.
    pub glass: bool,
    /// A Holdout: black, and transparent in the film's alpha where the camera sees it.
    pub holdout: bool,
    /// A Ray Portal BSDF: the ray goes on from elsewhere, weighted by `base_color`.
    pub portal: Option<RayPortal>,
    /// The GGX distribution without Multiscatter GGX's energy compensation of the metal and
    /// specular lobes (a Principled, Glossy or Anisotropic BSDF set to GGX, as scenes made
    /// before Blender 4.0 are).
    pub single_scatter: bool,
    /// What the whole BSDF is multiplied by (1; Add Shader picks one of two BSDFs with
    /// probability ½ and doubles it, so their sum is exact on average).
    pub weight: f32,
    /// A Toon BSDF: the lobe alone, of `base_color`.
    pub toon: Option<Toon>,
    /// A hair BSDF (`Hair`): the fibre's lobes alone.
    pub hair: Option<Hair>,
    /// The metal's F82 tint as Cycles takes it (the Principled BSDF's Specular Tint, the
    /// Metallic BSDF's Edge Tint); `None`: the normalised `specular_color` (glTF's).
    pub metal_tint: Option<Vec3>,
    /// A volume shader's medium (the volume nodes, `super::volume`); its emission is
    /// `emission`.
    pub volume: VolumeClosure,
}

impl Closure {
    /// No BSDF and no emission (an unlinked Surface: black).
    pub const BLACK: Closure = Closure {
        base_color: Vec3::ZERO,
        metallic: 0.0,
        roughness: 1.0,
        transmission: 0.0,
        ior: 1.5,
        specular: 0.0,
        specular_color: Vec3::ZERO,
        emission: Vec3::ZERO,
        normal: Vec3::ZERO,
        coat_weight: 0.0,
        coat_roughness: 0.03,
        coat_ior: 1.5,
        coat_tint: Vec3::ONE,
        coat_normal: Vec3::ZERO,
        sheen_weight: 0.0,
        sheen_roughness: 0.5,
        sheen_tint: Vec3::ONE,
        aspect: 1.0,
        tangent: Vec3::ZERO,
        diffuse_roughness: 0.0,
        thin_film_thickness: 0.0,
        thin_film_ior: 1.33,
        thin_film_blender_5: false,
        transparent: false,
        translucent: false,
        refraction: false,
        glass: false,
        holdout: false,
        portal: None,
        single_scatter: false,
        weight: 1.0,
        toon: None,
        hair: None,
        metal_tint: None,
        volume: VolumeClosure::NONE,
    };
}

/// The Transparent BSDF tinted by `color`: smooth transmission at IOR 1 (a straight pass).
pub(super) fn transparent(color: Vec3) -> Closure {
    Closure {
        base_color: color,
        roughness: 0.0,
        ior: 1.0,
        transmission: 1.0,
        transparent: true,
        ..Closure::BLACK
    }
}

/// Where a Ray Portal BSDF sends the ray (Blender's axes, world), as Cycles' `RayPortalClosure`:
/// a new ray from `position` along `direction` (not normalised).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayPortal {
    pub position: Vec3,
    pub direction: Vec3,
}

/// The Ray Portal BSDF (Cycles' `bsdf_ray_portal_setup`): its Position, else the shading
/// point (`position_given` false: the input is unlinked); its Direction, else (zero) the
/// incoming ray's, so that by default the ray passes straight on; weighted by its Color.
pub(super) fn eval_ray_portal(
    position_given: bool,
    inputs: &ShadingInputs,
    at: &PointInputs,
    ins: &impl Operands,
) -> Closure {
    const COLOR: usize = input(RAY_PORTAL_INPUTS, "Color");
    const POSITION: usize = input(RAY_PORTAL_INPUTS, "Position");
    const DIRECTION: usize = input(RAY_PORTAL_INPUTS, "Direction");
    let direction = ins.vector(DIRECTION);
    Closure {
        base_color: ins.vector(COLOR),
        portal: Some(RayPortal {
            position: match position_given {
                true => ins.vector(POSITION),
                false => at.position,
            },
            direction: match direction == Vec3::ZERO {
                true => -inputs.incoming,
                false => direction,
            },
        }),
        ..Closure::BLACK
    }
}

/// Mix Shader: `a` with probability 1 − t, else `b` (`u` picks, and is stretched back to
/// [0, 1) for later picks), with their emissions mixed exactly.
pub(super) fn mix_closures(u: &mut f32, t: f32, a: &Closure, b: &Closure) -> Closure {
    let emission = a.emission.lerp(b.emission, t);
    let mut picked = if *u < 1.0 - t {
        *u /= (1.0 - t).max(1e-12);
        *a
    } else {
        *u = (*u - (1.0 - t)) / t.max(1e-12);
        *b
    };
    *u = u.clamp(0.0, 0.999_999_94);
    picked.emission = emission;
    picked
}

pub(super) fn is_black_bsdf(c: &Closure) -> bool {
    c.base_color == Vec3::ZERO
        && c.specular_color == Vec3::ZERO
        && c.transmission == 0.0
        && (c.sheen_weight == 0.0 || c.sheen_tint == Vec3::ZERO)
        && c.coat_weight == 0.0
}

/// Blender's Principled Anisotropic A (clamped to [0, 1]) as α_y / α_x: sqrt(1 − 0.9 A).
pub fn principled_aspect(anisotropic: f32) -> f32 {
    let a = if anisotropic.is_finite() {
        anisotropic.clamp(0.0, 1.0)
    } else {
        0.0
    };
    (1.0 - 0.9 * a).sqrt()
}

/// A Tangent input: the given vector, or Blender's default when it is unlinked (zero).
pub(super) fn tangent_input(given: Vec4, inputs: &ShadingInputs, at: &PointInputs) -> Vec3 {
    let g = given.truncate();
    if g == Vec3::ZERO {
        default_tangent(inputs, at)
    } else {
        g
    }
}

/// The tangent Cycles gives an unlinked Tangent input (its Geometry node's Tangent): around
/// the object's Z axis through the middle of its texture space, from the Generated
/// coordinates (−(y − ½), x − ½, 0) taken to world space as a normal is, then made
/// perpendicular to the shading normal. Blender's axes, unit (zero where it is undefined).
pub fn default_tangent(inputs: &ShadingInputs, at: &PointInputs) -> Vec3 {
    let g = at.generated;
    let radial = inputs.object_to_world_normal * Vec3::new(-(g.y - 0.5), g.x - 0.5, 0.0);
    let n = inputs.normal;
    n.cross(radial.cross(n).normalize_or_zero())
}

/// The Principled BSDF (its inputs in `spec`'s order); Alpha below 1 mixes it with a
/// Transparent BSDF by alpha, as Cycles defines it (the BSDF and its emission weighted by
/// alpha, a Transparent BSDF by 1 − alpha), `u` picking.
#[inline(always)]
pub(super) fn eval_principled(
    multiscatter: bool,
    blender_5_film: bool,
    inputs: &ShadingInputs,
    at: &PointInputs,
    ins: &impl Operands,
    u: &mut f32,
) -> Closure {
    const BASE_COLOR: usize = input(PRINCIPLED_INPUTS, "Base Color");
    const METALLIC: usize = input(PRINCIPLED_INPUTS, "Metallic");
    const ROUGHNESS: usize = input(PRINCIPLED_INPUTS, "Roughness");
    const IOR: usize = input(PRINCIPLED_INPUTS, "IOR");
    const ALPHA: usize = input(PRINCIPLED_INPUTS, "Alpha");
    const SPECULAR_IOR_LEVEL: usize = input(PRINCIPLED_INPUTS, "Specular IOR Level");
    const SPECULAR_TINT: usize = input(PRINCIPLED_INPUTS, "Specular Tint");
    const TRANSMISSION_WEIGHT: usize = input(PRINCIPLED_INPUTS, "Transmission Weight");
    const EMISSION_COLOR: usize = input(PRINCIPLED_INPUTS, "Emission Color");
    const EMISSION_STRENGTH: usize = input(PRINCIPLED_INPUTS, "Emission Strength");
    const NORMAL: usize = input(PRINCIPLED_INPUTS, "Normal");
    const ANISOTROPIC: usize = input(PRINCIPLED_INPUTS, "Anisotropic");
    const ANISOTROPIC_ROTATION: usize = input(PRINCIPLED_INPUTS, "Anisotropic Rotation");
    const TANGENT: usize = input(PRINCIPLED_INPUTS, "Tangent");
    const COAT_WEIGHT: usize = input(PRINCIPLED_INPUTS, "Coat Weight");
    const COAT_ROUGHNESS: usize = input(PRINCIPLED_INPUTS, "Coat Roughness");
    const COAT_IOR: usize = input(PRINCIPLED_INPUTS, "Coat IOR");
    const COAT_TINT: usize = input(PRINCIPLED_INPUTS, "Coat Tint");
    const COAT_NORMAL: usize = input(PRINCIPLED_INPUTS, "Coat Normal");
    const SHEEN_WEIGHT: usize = input(PRINCIPLED_INPUTS, "Sheen Weight");
    const SHEEN_ROUGHNESS: usize = input(PRINCIPLED_INPUTS, "Sheen Roughness");
    const SHEEN_TINT: usize = input(PRINCIPLED_INPUTS, "Sheen Tint");
    const DIFFUSE_ROUGHNESS: usize = input(PRINCIPLED_INPUTS, "Diffuse Roughness");
    const THIN_FILM_THICKNESS: usize = input(PRINCIPLED_INPUTS, "Thin Film Thickness");
    const THIN_FILM_IOR: usize = input(PRINCIPLED_INPUTS, "Thin Film IOR");
    let level = ins.float(SPECULAR_IOR_LEVEL).max(0.0);
    let tint = ins.vector(SPECULAR_TINT);
    let normal = ins.vector(NORMAL);
    let (aspect, tangent) = principled_anisotropy(
        inputs,
        at,
        ins.float(ANISOTROPIC),
        ins.float(ANISOTROPIC_ROTATION),
        ins.value(NORMAL),
        ins.value(TANGENT),
    );
    let principled = Closure {
        base_color: ins.vector(BASE_COLOR),
        metallic: ins.float(METALLIC).clamp(0.0, 1.0),
        roughness: ins.float(ROUGHNESS).clamp(0.0, 1.0),
        ior: ins.float(IOR),
        specular: 1.0,
        specular_color: 2.0 * level * tint,
        transmission: ins.float(TRANSMISSION_WEIGHT).clamp(0.0, 1.0),
        emission: ins.vector(EMISSION_COLOR) * ins.float(EMISSION_STRENGTH),
        normal,
        coat_weight: ins.float(COAT_WEIGHT).max(0.0),
        coat_roughness: ins.float(COAT_ROUGHNESS).clamp(0.0, 1.0),
        coat_ior: ins.float(COAT_IOR).max(1.0),
        coat_tint: ins.vector(COAT_TINT).max(Vec3::ZERO),
        coat_normal: ins.vector(COAT_NORMAL),
        sheen_weight: ins.float(SHEEN_WEIGHT).max(0.0),
        sheen_roughness: ins.float(SHEEN_ROUGHNESS).clamp(0.0, 1.0),
        sheen_tint: ins.vector(SHEEN_TINT).max(Vec3::ZERO),
        aspect,
        tangent,
        diffuse_roughness: ins.float(DIFFUSE_ROUGHNESS).clamp(0.0, 1.0),
        thin_film_thickness: ins.float(THIN_FILM_THICKNESS).max(0.0),
        thin_film_ior: ins.float(THIN_FILM_IOR).max(1e-5),
        thin_film_blender_5: blender_5_film,
        transparent: false,
        translucent: false,
        refraction: false,
        glass: false,
        holdout: false,
        portal: None,
        single_scatter: !multiscatter,
        weight: 1.0,
        toon: None,
        hair: None,
        metal_tint: Some(tint.max(Vec3::ZERO)),
        volume: VolumeClosure::NONE,
    };
    let alpha = ins.float(ALPHA).clamp(0.0, 1.0);
    if alpha < 1.0 {
        mix_closures(u, alpha, &transparent(Vec3::ONE), &principled)
    } else {
        principled
    }
}

/// The Diffuse BSDF: Color, Roughness (Oren–Nayar), Normal.
#[inline(always)]
pub(super) fn eval_diffuse(ins: &impl Operands) -> Closure {
    const COLOR: usize = input(DIFFUSE_INPUTS, "Color");
    const ROUGHNESS: usize = input(DIFFUSE_INPUTS, "Roughness");
    const NORMAL: usize = input(DIFFUSE_INPUTS, "Normal");
    Closure {
        base_color: ins.vector(COLOR),
        roughness: 1.0,
        diffuse_roughness: ins.float(ROUGHNESS).clamp(0.0, 1.0),
        normal: ins.vector(NORMAL),
        ..Closure::BLACK
    }
}

/// The Glossy BSDF: Color, Roughness, Normal, Anisotropy, Rotation, Tangent. Cycles'
/// anisotropy: α_x = α (1 − a), α_y = α / (1 − a) for a > 0 (stretched along the bitangent:
/// the tangent turned a quarter), α / (1 + a) and α (1 + a) for a < 0.
#[inline(always)]
pub(super) fn eval_glossy(
    multiscatter: bool,
    inputs: &ShadingInputs,
    at: &PointInputs,
    ins: &impl Operands,
) -> Closure {
    const COLOR: usize = input(GLOSSY_INPUTS, "Color");
    const ROUGHNESS: usize = input(GLOSSY_INPUTS, "Roughness");
    const NORMAL: usize = input(GLOSSY_INPUTS, "Normal");
    const ANISOTROPY: usize = input(GLOSSY_INPUTS, "Anisotropy");
    const ROTATION: usize = input(GLOSSY_INPUTS, "Rotation");
    const TANGENT: usize = input(GLOSSY_INPUTS, "Tangent");
    let (aspect, tangent) = glossy_anisotropy(
        inputs,
        at,
        ins.float(ANISOTROPY),
        ins.float(ROTATION),
        ins.value(NORMAL),
        ins.value(TANGENT),
    );
    Closure {
        base_color: ins.vector(COLOR),
        metallic: 1.0,
        roughness: ins.float(ROUGHNESS).clamp(0.0, 1.0),
        normal: ins.vector(NORMAL),
        aspect,
        tangent,
        single_scatter: !multiscatter,
        ..Closure::BLACK
    }
}

/// The Principled BSDF's anisotropy (and the Metallic BSDF's, Cycles' conductor closure), as
/// `Closure::aspect` and the tangent α_x runs along: `principled_aspect` of the anisotropy in
/// [0, 1], along the tangent turned by `rotation` (turns) around the normal.
fn principled_anisotropy(
    inputs: &ShadingInputs,
    at: &PointInputs,
    anisotropy: f32,
    rotation: f32,
    normal: Vec4,
    tangent: Vec4,
) -> (f32, Vec3) {
    let anisotropy = anisotropy.clamp(0.0, 1.0);
    if anisotropy > 0.0 {
        let n = normal_input(normal, inputs.normal);
        let t = tangent_input(tangent, inputs, at);
        let t = crate::math::rotate_around(t, n, rotation * 2.0 * PI);
        (principled_aspect(anisotropy), t)
    } else {
        (1.0, Vec3::ZERO)
    }
}

/// Cycles' anisotropy of the Glossy BSDF, as `Closure::aspect` and the tangent
/// α_x runs along: α_x = α (1 − a), α_y = α / (1 − a) for a > 0 (stretched along the
/// bitangent: the tangent turned a quarter), α / (1 + a) and α (1 + a) for a < 0, turned by
/// `rotation` (turns) around the normal.
fn glossy_anisotropy(
    inputs: &ShadingInputs,
    at: &PointInputs,
    anisotropy: f32,
    rotation: f32,
    normal: Vec4,
    tangent: Vec4,
) -> (f32, Vec3) {
    let a = anisotropy.clamp(-0.99, 0.99);
    if a.abs() > 1e-4 {
        let n = normal_input(normal, inputs.normal);
        let t = tangent_input(tangent, inputs, at);
        let turn = rotation + if a > 0.0 { 0.25 } else { 0.0 };
        (
            1.0 - a.abs(),
            crate::math::rotate_around(t, n, turn * 2.0 * PI),
        )
    } else {
        (1.0, Vec3::ZERO)
    }
}

/// The Metallic BSDF: a GGX conductor of F0 Base Color and F82 tint Edge Tint (Cycles'
/// F82-tint Fresnel, as the Principled BSDF's metal), or with `physical` of complex index
/// IOR + i Extinction, given to the same Fresnel model by its exact values at normal
/// incidence and at μ = 1/7 (82°) (Cycles evaluates the conductor's Fresnel exactly; the two
/// curves meet at both angles). Roughness, Anisotropy and Rotation as the Principled BSDF's.
#[inline(always)]
pub(super) fn eval_metallic(
    physical: bool,
    multiscatter: bool,
    inputs: &ShadingInputs,
    at: &PointInputs,
    ins: &impl Operands,
) -> Closure {
    const BASE_COLOR: usize = input(METALLIC_INPUTS, "Base Color");
    const EDGE_TINT: usize = input(METALLIC_INPUTS, "Edge Tint");
    const IOR: usize = input(METALLIC_INPUTS, "IOR");
    const EXTINCTION: usize = input(METALLIC_INPUTS, "Extinction");
    const ROUGHNESS: usize = input(METALLIC_INPUTS, "Roughness");
    const ANISOTROPY: usize = input(METALLIC_INPUTS, "Anisotropy");
    const ROTATION: usize = input(METALLIC_INPUTS, "Rotation");
    const NORMAL: usize = input(METALLIC_INPUTS, "Normal");
    const TANGENT: usize = input(METALLIC_INPUTS, "Tangent");
    let (f0, tint) = if physical {
        let (n, k) = (ins.vector(IOR), ins.vector(EXTINCTION));
        let f0 = conductor_fresnel(1.0, n, k);
        let mu = 1.0f32 / 7.0;
        let schlick_82 = f0 + (Vec3::ONE - f0) * (1.0 - mu).powi(5);
        (
            f0,
            conductor_fresnel(mu, n, k) / schlick_82.max(Vec3::splat(1e-6)),
        )
    } else {
        (ins.vector(BASE_COLOR), ins.vector(EDGE_TINT))
    };
    let (aspect, tangent) = principled_anisotropy(
        inputs,
        at,
        ins.float(ANISOTROPY),
        ins.float(ROTATION),
        ins.value(NORMAL),
        ins.value(TANGENT),
    );
    Closure {
        base_color: f0.clamp(Vec3::ZERO, Vec3::ONE),
        metallic: 1.0,
        roughness: ins.float(ROUGHNESS).clamp(0.0, 1.0),
        normal: ins.vector(NORMAL),
        aspect,
        tangent,
        single_scatter: !multiscatter,
        metal_tint: Some(tint.clamp(Vec3::ZERO, Vec3::ONE)),
        ..Closure::BLACK
    }
}

/// The Fresnel reflectance of a conductor of complex index n + ik per channel, unpolarised,
/// at the cosine `cos_i` of the angle of incidence (from outside, in air).
pub(super) fn conductor_fresnel(cos_i: f32, n: Vec3, k: Vec3) -> Vec3 {
    let c2 = cos_i * cos_i;
    let s2 = 1.0 - c2;
    let t0 = n * n - k * k - Vec3::splat(s2);
    let a2b2 = (t0 * t0 + 4.0 * n * n * k * k).max(Vec3::ZERO);
    let a2b2 = Vec3::new(a2b2.x.sqrt(), a2b2.y.sqrt(), a2b2.z.sqrt());
    let a = (0.5 * (a2b2 + t0)).max(Vec3::ZERO);
    let a = Vec3::new(a.x.sqrt(), a.y.sqrt(), a.z.sqrt());
    let two_ac = 2.0 * cos_i * a;
    let rs = (a2b2 + Vec3::splat(c2) - two_ac) / (a2b2 + Vec3::splat(c2) + two_ac);
    let t1 = c2 * a2b2 + Vec3::splat(s2 * s2);
    let t2 = two_ac * s2;
    let rp = rs * (t1 - t2) / (t1 + t2);
    0.5 * (rs + rp)
}

/// The Sheen BSDF (microfiber): Color, Roughness, Normal.
#[inline(always)]
pub(super) fn eval_sheen(ins: &impl Operands) -> Closure {
    const COLOR: usize = input(SHEEN_INPUTS, "Color");
    const ROUGHNESS: usize = input(SHEEN_INPUTS, "Roughness");
    const NORMAL: usize = input(SHEEN_INPUTS, "Normal");
    Closure {
        sheen_weight: 1.0,
        sheen_tint: ins.vector(COLOR).max(Vec3::ZERO),
        sheen_roughness: ins.float(ROUGHNESS).clamp(0.0, 1.0),
        normal: ins.vector(NORMAL),
        ..Closure::BLACK
    }
}

/// The Glass BSDF (or with `refraction` the Refraction BSDF): Color, Roughness, IOR, Normal.
#[inline(always)]
pub(super) fn eval_glass(refraction: bool, multiscatter: bool, ins: &impl Operands) -> Closure {
    const COLOR: usize = input(GLASS_INPUTS, "Color");
    const ROUGHNESS: usize = input(GLASS_INPUTS, "Roughness");
    const IOR: usize = input(GLASS_INPUTS, "IOR");
    const NORMAL: usize = input(GLASS_INPUTS, "Normal");
    Closure {
        base_color: ins.vector(COLOR),
        roughness: ins.float(ROUGHNESS).clamp(0.0, 1.0),
        ior: ins.float(IOR),
        transmission: 1.0,
        specular: 1.0,
        specular_color: Vec3::ONE,
        normal: ins.vector(NORMAL),
        refraction,
        glass: !refraction,
        single_scatter: !refraction && !multiscatter,
        ..Closure::BLACK
    }
}

/// The Emission shader: Color, Strength.
#[inline(always)]
pub(super) fn eval_emission(ins: &impl Operands) -> Closure {
    const COLOR: usize = input(EMISSION_INPUTS, "Color");
    const STRENGTH: usize = input(EMISSION_INPUTS, "Strength");
    Closure {
        emission: ins.vector(COLOR) * ins.float(STRENGTH),
        ..Closure::BLACK
    }
}

/// The Transparent BSDF: Color.
#[inline(always)]
pub(super) fn eval_transparent(ins: &impl Operands) -> Closure {
    const COLOR: usize = input(TRANSPARENT_INPUTS, "Color");
    transparent(ins.vector(COLOR))
}

/// The Holdout shader.
#[inline(always)]
pub(super) fn eval_holdout() -> Closure {
    Closure {
        holdout: true,
        ..Closure::BLACK
    }
}

/// The Translucent BSDF: Color, Normal.
#[inline(always)]
pub(super) fn eval_translucent(ins: &impl Operands) -> Closure {
    const COLOR: usize = input(TRANSLUCENT_INPUTS, "Color");
    const NORMAL: usize = input(TRANSLUCENT_INPUTS, "Normal");
    Closure {
        base_color: ins.vector(COLOR),
        roughness: 1.0,
        transmission: 1.0,
        normal: ins.vector(NORMAL),
        translucent: true,
        ..Closure::BLACK
    }
}

/// The Mix Shader: Fac, and the two shaders `a` and `b`.
#[inline(always)]
pub(super) fn eval_mix_shader(
    ins: &impl Operands,
    a: &Closure,
    b: &Closure,
    u: &mut f32,
) -> Closure {
    const FAC: usize = input(MIX_SHADER_INPUTS, "Fac");
    let t = ins.float(FAC).clamp(0.0, 1.0);
    let mut mixed = mix_closures(u, t, a, b);
    mixed.volume = combine(&a.volume, &b.volume, Some(t));
    mixed
}

/// The Add Shader: emission summed; of two BSDFs one with probability ½, doubled.
#[inline(always)]
pub(super) fn eval_add_shader(a: &Closure, b: &Closure, u: &mut f32) -> Closure {
    let emission = a.emission + b.emission;
    let a_bsdf = !is_black_bsdf(a);
    let b_bsdf = !is_black_bsdf(b);
    let mut picked = match (a_bsdf, b_bsdf) {
        (true, false) => *a,
        (false, true) => *b,
        _ => {
            // One of the two with probability ½, doubled: their sum on average, as
            // Cycles sums closures. A Transparent BSDF carries it in its colour,
            // which shadow rays read as their tint.
            let mut one = if *u < 0.5 {
                *u *= 2.0;
                *a
            } else {
                *u = 2.0 * *u - 1.0;
                *b
            };
            if one.transparent {
                one.base_color *= 2.0;
            } else {
                one.weight *= 2.0;
            }
            one
        }
    };
    *u = u.clamp(0.0, 0.999_999_94);
    picked.emission = emission;
    picked.volume = combine(&a.volume, &b.volume, None);
    picked
}
