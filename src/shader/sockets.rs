//! Each node's sockets as Blender names them: its inputs with their types and Blender's
//! defaults, and its outputs with their types, in the order the evaluation reads and writes
//! them.

use super::color::MixData;
use super::geometry::LIGHT_PATH_OUTPUTS;
use super::program::{Op, Ty};
use super::volume::{ABSORPTION_INPUTS, PRINCIPLED_VOLUME_INPUTS, SCATTER_INPUTS};
use crate::math::Vec4;

/// An input: its identifier, type and Blender's default value.
pub(super) type InputSpec = (String, Ty, Vec4);
/// An output: its identifier and type.
pub(super) type OutputSpec = (&'static str, Ty);

/// Input identifiers with their types and Blender's defaults, and output identifiers with types.
pub(super) struct Spec {
    pub(super) inputs: Vec<InputSpec>,
    pub(super) outputs: Vec<OutputSpec>,
}

pub(super) fn f(x: f32) -> Vec4 {
    Vec4::new(x, x, x, 1.0)
}

/// Inputs of a node family whose names are its `const` list (read by index there).
fn named<const N: usize>(names: &[&str; N], types: [(Ty, Vec4); N]) -> Vec<InputSpec> {
    names
        .iter()
        .zip(types)
        .map(|(n, (t, d))| (n.to_string(), t, d))
        .collect()
}

pub(super) fn spec(op: &Op) -> Spec {
    use Ty::*;
    let i = |n: &str, t: Ty, d: Vec4| (n.to_string(), t, d);
    let grey = Vec4::new(0.8, 0.8, 0.8, 1.0);
    let (inputs, outputs): (Vec<InputSpec>, Vec<OutputSpec>) = match op {
        Op::TexCoord { .. } => (
            vec![],
            vec![
                ("Generated", Vector),
                ("Normal", Vector),
                ("UV", Vector),
                ("Object", Vector),
                ("Reflection", Vector),
            ],
        ),
        Op::UvMap { .. } => (vec![], vec![("UV", Vector)]),
        Op::VertexColor => (vec![], vec![("Color", Color), ("Alpha", Float)]),
        Op::Attribute => (
            vec![],
            vec![
                ("Color", Color),
                ("Vector", Vector),
                ("Fac", Float),
                ("Alpha", Float),
            ],
        ),
        Op::Geometry => (
            vec![],
            vec![
                ("Position", Vector),
                ("Normal", Vector),
                ("True Normal", Vector),
                ("Incoming", Vector),
                ("Backfacing", Float),
            ],
        ),
        Op::LightPath => (
            vec![],
            LIGHT_PATH_OUTPUTS.iter().map(|&n| (n, Float)).collect(),
        ),
        Op::Value(_) => (vec![], vec![("Value", Float)]),
        Op::Rgb(_) => (vec![], vec![("Color", Color)]),
        Op::Mapping(..) => (
            vec![
                i("Vector", Vector, Vec4::ZERO),
                i("Location", Vector, Vec4::ZERO),
                i("Rotation", Vector, Vec4::ZERO),
                i("Scale", Vector, Vec4::ONE),
            ],
            vec![("Vector", Vector)],
        ),
        Op::Math { .. } => (
            vec![
                i("Value", Float, f(0.5)),
                i("Value_001", Float, f(0.5)),
                i("Value_002", Float, f(0.5)),
            ],
            vec![("Value", Float)],
        ),
        Op::Mix { data, .. } => {
            let (suffix, t, out) = match data {
                MixData::Float => ("Float", Float, "Result_Float"),
                MixData::Vector => ("Vector", Vector, "Result_Vector"),
                MixData::Color => ("Color", Color, "Result_Color"),
            };
            let (a, b) = match data {
                MixData::Color => (Vec4::new(0.5, 0.5, 0.5, 1.0), Vec4::new(0.5, 0.5, 0.5, 1.0)),
                _ => (Vec4::ZERO, Vec4::ZERO),
            };
            (
                vec![
                    i("Factor_Float", Float, f(0.5)),
                    i(&format!("A_{suffix}"), t, a),
                    i(&format!("B_{suffix}"), t, b),
                ],
                vec![(out, t)],
            )
        }
        Op::RgbCurves { .. } => (
            vec![i("Fac", Float, f(1.0)), i("Color", Color, Vec4::ONE)],
            vec![("Color", Color)],
        ),
        Op::ColorRamp { .. } => (
            vec![i("Fac", Float, f(0.5))],
            vec![("Color", Color), ("Alpha", Float)],
        ),
        Op::MapRange { .. } => (
            vec![
                i("Value", Float, f(1.0)),
                i("From Min", Float, f(0.0)),
                i("From Max", Float, f(1.0)),
                i("To Min", Float, f(0.0)),
                i("To Max", Float, f(1.0)),
                i("Steps", Float, f(4.0)),
            ],
            vec![("Result", Float)],
        ),
        Op::Clamp { .. } => (
            vec![
                i("Value", Float, f(1.0)),
                i("Min", Float, f(0.0)),
                i("Max", Float, f(1.0)),
            ],
            vec![("Result", Float)],
        ),
        Op::Invert => (
            vec![i("Fac", Float, f(1.0)), i("Color", Color, Vec4::ZERO)],
            vec![("Color", Color)],
        ),
        Op::SeparateXyz => (
            vec![i("Vector", Vector, Vec4::ZERO)],
            vec![("X", Float), ("Y", Float), ("Z", Float)],
        ),
        Op::CombineXyz => (
            vec![
                i("X", Float, f(0.0)),
                i("Y", Float, f(0.0)),
                i("Z", Float, f(0.0)),
            ],
            vec![("Vector", Vector)],
        ),
        Op::SeparateColor { .. } => (
            vec![i("Color", Color, grey)],
            vec![("Red", Float), ("Green", Float), ("Blue", Float)],
        ),
        Op::CombineColor { .. } => (
            vec![
                i("Red", Float, f(0.0)),
                i("Green", Float, f(0.0)),
                i("Blue", Float, f(0.0)),
            ],
            vec![("Color", Color)],
        ),
        Op::Checker => (
            vec![
                i("Vector", Vector, Vec4::ZERO),
                i("Color1", Color, grey),
                i("Color2", Color, Vec4::new(0.2, 0.2, 0.2, 1.0)),
                i("Scale", Float, f(5.0)),
            ],
            vec![("Color", Color), ("Fac", Float)],
        ),
        Op::Gradient(_) => (
            vec![i("Vector", Vector, Vec4::ZERO)],
            vec![("Color", Color), ("Fac", Float)],
        ),
        Op::Noise { .. } | Op::NoiseAt3 { .. } => (
            vec![
                i("Vector", Vector, Vec4::ZERO),
                i("W", Float, f(0.0)),
                i("Scale", Float, f(5.0)),
                i("Detail", Float, f(2.0)),
                i("Roughness", Float, f(0.5)),
                i("Lacunarity", Float, f(2.0)),
                i("Offset", Float, f(0.0)),
                i("Gain", Float, f(1.0)),
                i("Distortion", Float, f(0.0)),
            ],
            vec![("Fac", Float), ("Color", Color)],
        ),
        Op::Image { .. } => (
            vec![i("Vector", Vector, Vec4::ZERO)],
            vec![("Color", Color), ("Alpha", Float)],
        ),
        Op::Voronoi(_) => (
            vec![
                i("Vector", Vector, Vec4::ZERO),
                i("W", Float, f(0.0)),
                i("Scale", Float, f(5.0)),
                i("Detail", Float, f(0.0)),
                i("Roughness", Float, f(0.5)),
                i("Lacunarity", Float, f(2.0)),
                i("Smoothness", Float, f(1.0)),
                i("Exponent", Float, f(0.5)),
                i("Randomness", Float, f(1.0)),
            ],
            vec![("Distance", Float), ("Color", Color), ("Position", Vector)],
        ),
        Op::Wave(_) => (
            vec![
                i("Vector", Vector, Vec4::ZERO),
                i("Scale", Float, f(5.0)),
                i("Distortion", Float, f(0.0)),
                i("Detail", Float, f(2.0)),
                i("Detail Scale", Float, f(1.0)),
                i("Detail Roughness", Float, f(0.5)),
                i("Phase Offset", Float, f(0.0)),
            ],
            vec![("Color", Color), ("Fac", Float)],
        ),
        Op::WhiteNoise { .. } => (
            vec![i("Vector", Vector, Vec4::ZERO), i("W", Float, f(0.0))],
            vec![("Value", Float), ("Color", Color)],
        ),
        Op::Magic { .. } => (
            vec![
                i("Vector", Vector, Vec4::ZERO),
                i("Scale", Float, f(5.0)),
                i("Distortion", Float, f(1.0)),
            ],
            vec![("Color", Color), ("Fac", Float)],
        ),
        Op::Brick(_) => (
            vec![
                i("Vector", Vector, Vec4::ZERO),
                i("Color1", Color, grey),
                i("Color2", Color, Vec4::new(0.2, 0.2, 0.2, 1.0)),
                i("Mortar", Color, Vec4::new(0.0, 0.0, 0.0, 1.0)),
                i("Scale", Float, f(5.0)),
                i("Mortar Size", Float, f(0.02)),
                i("Mortar Smooth", Float, f(0.1)),
                i("Bias", Float, f(0.0)),
                i("Brick Width", Float, f(0.5)),
                i("Row Height", Float, f(0.25)),
            ],
            vec![("Color", Color), ("Fac", Float)],
        ),
        Op::Blackbody => (
            vec![i("Temperature", Float, f(1500.0))],
            vec![("Color", Color)],
        ),
        Op::HueSaturation => (
            vec![
                i("Hue", Float, f(0.5)),
                i("Saturation", Float, f(1.0)),
                i("Value", Float, f(1.0)),
                i("Fac", Float, f(1.0)),
                i("Color", Color, grey),
            ],
            vec![("Color", Color)],
        ),
        Op::Gamma => (
            vec![i("Color", Color, Vec4::ONE), i("Gamma", Float, f(1.0))],
            vec![("Color", Color)],
        ),
        Op::BrightContrast => (
            vec![
                i("Color", Color, Vec4::ONE),
                i("Bright", Float, f(0.0)),
                i("Contrast", Float, f(0.0)),
            ],
            vec![("Color", Color)],
        ),
        Op::VectorMath(_) => (
            vec![
                i("Vector", Vector, Vec4::ZERO),
                i("Vector_001", Vector, Vec4::ZERO),
                i("Vector_002", Vector, Vec4::ZERO),
                i("Scale", Float, f(1.0)),
            ],
            vec![("Vector", Vector), ("Value", Float)],
        ),
        Op::Fresnel => (
            vec![i("IOR", Float, f(1.5)), i("Normal", Vector, Vec4::ZERO)],
            vec![("Fac", Float)],
        ),
        Op::LayerWeight => (
            vec![i("Blend", Float, f(0.5)), i("Normal", Vector, Vec4::ZERO)],
            vec![("Fresnel", Float), ("Facing", Float)],
        ),
        Op::Bump { .. } => (
            vec![
                i("Strength", Float, f(1.0)),
                i("Distance", Float, f(1.0)),
                i("Filter Width", Float, f(0.1)),
                i("Height", Float, f(1.0)),
                i("Normal", Vector, Vec4::ZERO),
            ],
            vec![("Normal", Vector)],
        ),
        Op::Displacement { .. } => (
            vec![
                i("Height", Float, f(0.0)),
                i("Midlevel", Float, f(0.5)),
                i("Scale", Float, f(1.0)),
                i("Normal", Vector, Vec4::ZERO),
            ],
            vec![("Displacement", Vector)],
        ),
        Op::NormalMap(_) => (
            vec![
                i("Strength", Float, f(1.0)),
                i("Color", Color, Vec4::new(0.5, 0.5, 1.0, 1.0)),
            ],
            vec![("Normal", Vector)],
        ),
        Op::Principled { .. } => (
            vec![
                i("Base Color", Color, grey),
                i("Metallic", Float, f(0.0)),
                i("Roughness", Float, f(0.5)),
                i("IOR", Float, f(1.5)),
                i("Alpha", Float, f(1.0)),
                i("Specular IOR Level", Float, f(0.5)),
                i("Specular Tint", Color, Vec4::ONE),
                i("Transmission Weight", Float, f(0.0)),
                i("Emission Color", Color, Vec4::ONE),
                i("Emission Strength", Float, f(0.0)),
                i("Normal", Vector, Vec4::ZERO),
                i("Anisotropic", Float, f(0.0)),
                i("Anisotropic Rotation", Float, f(0.0)),
                i("Tangent", Vector, Vec4::ZERO),
                i("Coat Weight", Float, f(0.0)),
                i("Coat Roughness", Float, f(0.03)),
                i("Coat IOR", Float, f(1.5)),
                i("Coat Tint", Color, Vec4::ONE),
                i("Coat Normal", Vector, Vec4::ZERO),
                i("Sheen Weight", Float, f(0.0)),
                i("Sheen Roughness", Float, f(0.5)),
                i("Sheen Tint", Color, Vec4::ONE),
                i("Diffuse Roughness", Float, f(0.0)),
                i("Thin Film Thickness", Float, f(0.0)),
                i("Thin Film IOR", Float, f(1.33)),
            ],
            vec![("BSDF", Shader)],
        ),
        Op::Diffuse | Op::Sheen => (
            vec![
                i("Color", Color, grey),
                // Blender's defaults: a Lambertian Diffuse BSDF, a Sheen BSDF of roughness ½.
                i(
                    "Roughness",
                    Float,
                    f(if *op == Op::Diffuse { 0.0 } else { 0.5 }),
                ),
                i("Normal", Vector, Vec4::ZERO),
            ],
            vec![("BSDF", Shader)],
        ),
        Op::Glossy { .. } => (
            vec![
                i("Color", Color, grey),
                i("Roughness", Float, f(0.5)),
                i("Normal", Vector, Vec4::ZERO),
                i("Anisotropy", Float, f(0.0)),
                i("Rotation", Float, f(0.0)),
                i("Tangent", Vector, Vec4::ZERO),
            ],
            vec![("BSDF", Shader)],
        ),
        Op::Glass { .. } | Op::Refraction => (
            vec![
                i("Color", Color, Vec4::ONE),
                i("Roughness", Float, f(0.0)),
                i("IOR", Float, f(1.5)),
                i("Normal", Vector, Vec4::ZERO),
            ],
            vec![("BSDF", Shader)],
        ),
        Op::Emission => (
            vec![i("Color", Color, Vec4::ONE), i("Strength", Float, f(1.0))],
            vec![("Emission", Shader)],
        ),
        Op::Transparent => (vec![i("Color", Color, Vec4::ONE)], vec![("BSDF", Shader)]),
        Op::Holdout => (vec![], vec![("Holdout", Shader)]),
        Op::Translucent => (
            vec![
                i("Color", Color, Vec4::ONE),
                i("Normal", Vector, Vec4::ZERO),
            ],
            vec![("BSDF", Shader)],
        ),
        Op::MixShader => (
            vec![
                i("Fac", Float, f(0.5)),
                i("Shader", Shader, Vec4::ZERO),
                i("Shader_001", Shader, Vec4::ZERO),
            ],
            vec![("Shader", Shader)],
        ),
        Op::AddShader => (
            vec![
                i("Shader", Shader, Vec4::ZERO),
                i("Shader_001", Shader, Vec4::ZERO),
            ],
            vec![("Shader", Shader)],
        ),
        Op::PrincipledVolume => (
            named(
                &PRINCIPLED_VOLUME_INPUTS,
                [
                    (Color, Vec4::new(0.5, 0.5, 0.5, 1.0)),
                    (Float, f(1.0)),
                    (Float, f(0.0)),
                    (Color, Vec4::new(0.0, 0.0, 0.0, 1.0)),
                    (Float, f(0.0)),
                    (Color, Vec4::ONE),
                    (Float, f(0.0)),
                    (Color, Vec4::ONE),
                    (Float, f(1000.0)),
                ],
            ),
            vec![("Volume", Shader)],
        ),
        Op::VolumeScatter(_) => (
            named(
                &SCATTER_INPUTS,
                [
                    (Color, grey),
                    (Float, f(1.0)),
                    (Float, f(0.0)),
                    (Float, f(0.5)),
                    (Float, f(20.0)),
                ],
            ),
            vec![("Volume", Shader)],
        ),
        Op::VolumeAbsorption => (
            named(&ABSORPTION_INPUTS, [(Color, grey), (Float, f(1.0))]),
            vec![("Volume", Shader)],
        ),
    };
    Spec { inputs, outputs }
}
