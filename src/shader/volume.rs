//! The volume shader nodes (what feeds a Material Output's or World Output's Volume): Principled
//! Volume, Volume Scatter and Volume Absorption into the volume part of a `Closure`
//! (`VolumeClosure`: scattering and absorption coefficients and the phase function; an Emission
//! node in a volume tree is the volume's emission per unit length, `Closure::emission`), as
//! Cycles' `svm_node_principled_volume` and `svm_node_closure_volume` define them (a volume
//! tree is read at a point in the medium by `NodeProgram::eval_volume`, in `machine`).
//!
//! Principled Volume: σ_s = Color × Density, σ_a = max(1 − Color, 0) × max(1 − √Absorption
//! Color, 0) × Density, Henyey–Greenstein of Anisotropy; emission Emission Color × Emission
//! Strength plus, with Blackbody Intensity b > 0, Blackbody Tint × the black body's colour at
//! Temperature T × σ/π·10⁻⁶ × mix(1, T⁴, b) (Stefan–Boltzmann). Volume Scatter: σ_s = Color ×
//! Density with its phase function (`crate::phase`). Volume Absorption: σ_a = (1 − Color) ×
//! Density. Densities below zero count as zero. Mix Shader mixes the coefficients linearly and
//! Add Shader sums them (exact, the media being linear in them); the mixture keeps the phase
//! function of the part that scatters more.

use super::blackbody::blackbody;
use super::closure::{Closure, VolumeClosure};
use super::inputs::{input, Operands, Socket, Ty, GREY};
use crate::color_space::WorkingSpace;
use crate::math::{Vec3, Vec4};
use crate::phase::Phase;

/// Volume Scatter's phase functions (its `phase` setting), with what each reads.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum ScatterPhase {
    HenyeyGreenstein,
    Rayleigh,
    Draine,
    Mie,
    FournierForand,
}

/// Principled Volume's inputs (its attribute names are settings: `Op::PrincipledVolume`).
pub(super) const PRINCIPLED_VOLUME_INPUTS: &[Socket] = &[
    Socket::color("Color", Vec4::new(0.5, 0.5, 0.5, 1.0)),
    Socket::float("Density", 1.0),
    Socket::float("Anisotropy", 0.0),
    Socket::color("Absorption Color", Vec4::new(0.0, 0.0, 0.0, 1.0)),
    Socket::float("Emission Strength", 0.0),
    Socket::color("Emission Color", Vec4::ONE),
    Socket::float("Blackbody Intensity", 0.0),
    Socket::color("Blackbody Tint", Vec4::ONE),
    Socket::float("Temperature", 1000.0),
];

/// Volume Scatter's inputs read.
pub(super) const SCATTER_INPUTS: &[Socket] = &[
    Socket::color("Color", GREY),
    Socket::float("Density", 1.0),
    Socket::float("Anisotropy", 0.0),
    Socket::float("IOR", 1.33),
    Socket::float("Backscatter", 0.1),
    Socket::float("Alpha", 0.5),
    Socket::float("Diameter", 20.0),
];

/// Volume Absorption's inputs.
pub(super) const ABSORPTION_INPUTS: &[Socket] =
    &[Socket::color("Color", GREY), Socket::float("Density", 1.0)];

/// The volume nodes' one output.
pub(super) const VOLUME_OUTPUTS: &[Socket] = &[Socket::output("Volume", Ty::Shader)];

const COLOR: usize = input(PRINCIPLED_VOLUME_INPUTS, "Color");
const DENSITY: usize = input(PRINCIPLED_VOLUME_INPUTS, "Density");
const ANISOTROPY: usize = input(PRINCIPLED_VOLUME_INPUTS, "Anisotropy");
const ABSORPTION: usize = input(PRINCIPLED_VOLUME_INPUTS, "Absorption Color");
const EMISSION_STRENGTH: usize = input(PRINCIPLED_VOLUME_INPUTS, "Emission Strength");
const EMISSION_COLOR: usize = input(PRINCIPLED_VOLUME_INPUTS, "Emission Color");
const BLACKBODY_INTENSITY: usize = input(PRINCIPLED_VOLUME_INPUTS, "Blackbody Intensity");
const BLACKBODY_TINT: usize = input(PRINCIPLED_VOLUME_INPUTS, "Blackbody Tint");
const TEMPERATURE: usize = input(PRINCIPLED_VOLUME_INPUTS, "Temperature");

const ABSORPTION_COLOR: usize = input(ABSORPTION_INPUTS, "Color");
const ABSORPTION_DENSITY: usize = input(ABSORPTION_INPUTS, "Density");
const SCATTER_COLOR: usize = input(SCATTER_INPUTS, "Color");
const SCATTER_DENSITY: usize = input(SCATTER_INPUTS, "Density");
const SCATTER_ANISOTROPY: usize = input(SCATTER_INPUTS, "Anisotropy");
const SCATTER_ALPHA: usize = input(SCATTER_INPUTS, "Alpha");
const SCATTER_DIAMETER: usize = input(SCATTER_INPUTS, "Diameter");
const SCATTER_IOR: usize = input(SCATTER_INPUTS, "IOR");
const SCATTER_BACKSCATTER: usize = input(SCATTER_INPUTS, "Backscatter");

/// The Principled Volume node, with the values of its Density, Color and Temperature
/// attributes where the object has them (`named`): each scales its input, as Cycles'
/// `svm_node_principled_volume` does.
#[inline(always)]
pub(super) fn eval_principled_volume(
    ins: &impl Operands,
    named: [Option<Vec4>; 3],
    space: WorkingSpace,
) -> Closure {
    let [density_attribute, color_attribute, temperature_attribute] = named;
    let mut density = ins.float(DENSITY).max(0.0);
    if let Some(v) = density_attribute {
        density = (density * v.x).max(0.0);
    }
    let mut color = ins.vector(COLOR);
    if let Some(v) = color_attribute {
        color *= v.truncate();
    }
    let mut volume = VolumeClosure::NONE;
    if density > 0.0 {
        let absorption_color = ins.vector(ABSORPTION).max(Vec3::ZERO);
        let root = Vec3::new(
            absorption_color.x.sqrt(),
            absorption_color.y.sqrt(),
            absorption_color.z.sqrt(),
        );
        let absorption = (Vec3::ONE - color).max(Vec3::ZERO) * (Vec3::ONE - root).max(Vec3::ZERO);
        volume = VolumeClosure {
            scattering: (color * density).max(Vec3::ZERO),
            absorption: absorption * density,
            phase: Phase::henyey_greenstein(ins.float(ANISOTROPY)),
        };
    }
    let mut emission = Vec3::ZERO;
    let strength = ins.float(EMISSION_STRENGTH);
    if strength > 0.0 {
        emission += ins.vector(EMISSION_COLOR) * strength;
    }
    let b = ins.float(BLACKBODY_INTENSITY);
    let mut t = ins.float(TEMPERATURE);
    if let Some(v) = temperature_attribute {
        t = (t * v.x).max(0.0);
    }
    if b > 0.0 && t > 0.0 {
        // Stefan–Boltzmann's σ, per steradian, in Cycles' units.
        let sigma = 5.670_373e-8 * 1e-6 / std::f32::consts::PI;
        let intensity = sigma * (1.0 + b * (t * t * t * t - 1.0));
        emission += ins.vector(BLACKBODY_TINT) * space.convert_rec709(blackbody(t)) * intensity;
    }
    Closure {
        emission,
        volume,
        ..Closure::BLACK
    }
}

/// The Volume Scatter node with its `phase`.
#[inline(always)]
pub(super) fn eval_volume_scatter(phase: ScatterPhase, ins: &impl Operands) -> Closure {
    let density = ins.float(SCATTER_DENSITY).max(0.0);
    let g = ins.float(SCATTER_ANISOTROPY);
    let phase = match phase {
        ScatterPhase::HenyeyGreenstein => Phase::henyey_greenstein(g),
        ScatterPhase::Rayleigh => Phase::Rayleigh,
        ScatterPhase::Draine => match Phase::henyey_greenstein(g) {
            Phase::HenyeyGreenstein(g) => Phase::Draine {
                g,
                alpha: ins.float(SCATTER_ALPHA).max(0.0),
            },
            other => other,
        },
        ScatterPhase::Mie => Phase::mie(ins.float(SCATTER_DIAMETER)),
        ScatterPhase::FournierForand => {
            Phase::fournier_forand(ins.float(SCATTER_BACKSCATTER), ins.float(SCATTER_IOR))
        }
    };
    Closure {
        volume: VolumeClosure {
            scattering: (ins.vector(SCATTER_COLOR) * density).max(Vec3::ZERO),
            absorption: Vec3::ZERO,
            phase,
        },
        ..Closure::BLACK
    }
}

/// The Volume Absorption node.
#[inline(always)]
pub(super) fn eval_volume_absorption(ins: &impl Operands) -> Closure {
    let density = ins.float(ABSORPTION_DENSITY).max(0.0);
    Closure {
        volume: VolumeClosure {
            absorption: (Vec3::ONE - ins.vector(ABSORPTION_COLOR)).max(Vec3::ZERO) * density,
            ..VolumeClosure::NONE
        },
        ..Closure::BLACK
    }
}
