//! Each node's sockets as Blender names them (each node family's file holds its tables):
//! its inputs with their types and Blender's defaults, and its outputs with their types, in
//! the order the evaluation reads and writes them.

use super::color::MixData;
use super::inputs::Socket;
use super::program::Op;
use super::{ambient_occlusion, bevel};
use super::{blackbody, brick, bump, checker, closure, color, convert, fresnel, gabor, geometry};
use super::{gradient, image, magic, math, noise, vector, volume, voronoi, wave, white_noise};

/// A node's input sockets (identifier, type, Blender's default) and output sockets
/// (identifier, type).
pub(super) struct Spec {
    pub(super) inputs: &'static [Socket],
    pub(super) outputs: &'static [Socket],
}

/// The sockets of the node `op` evaluates.
pub(super) fn spec(op: &Op) -> Spec {
    let (inputs, outputs): (&'static [Socket], &'static [Socket]) = match op {
        Op::TexCoord { .. } => (&[], geometry::TEX_COORD_OUTPUTS),
        Op::UvMap { .. } => (&[], geometry::UV_MAP_OUTPUTS),
        Op::VertexColor => (&[], geometry::VERTEX_COLOR_OUTPUTS),
        Op::Attribute { .. } | Op::ObjectAttribute { .. } | Op::LayerAttribute(_) => {
            (&[], geometry::ATTRIBUTE_OUTPUTS)
        }
        Op::Geometry => (&[], geometry::GEOMETRY_OUTPUTS),
        Op::ObjectInfo { .. } => (&[], geometry::OBJECT_INFO_OUTPUTS),
        Op::HairInfo { .. } => (&[], geometry::HAIR_INFO_OUTPUTS),
        Op::Wireframe { .. } => (geometry::WIREFRAME_INPUTS, geometry::WIREFRAME_OUTPUTS),
        Op::LightPath => (&[], geometry::LIGHT_PATH_OUTPUTS),
        Op::AmbientOcclusion(_) => (ambient_occlusion::AO_INPUTS, ambient_occlusion::AO_OUTPUTS),
        Op::Bevel { .. } => (bevel::BEVEL_INPUTS, bevel::BEVEL_OUTPUTS),
        Op::Value(_) => (&[], geometry::VALUE_OUTPUTS),
        Op::Rgb(_) => (&[], geometry::RGB_OUTPUTS),
        Op::Mapping(..) => (vector::MAPPING_INPUTS, vector::MAPPING_OUTPUTS),
        Op::VectorMath(_) => (vector::VECTOR_MATH_INPUTS, vector::VECTOR_MATH_OUTPUTS),
        Op::Math { .. } => (math::MATH_INPUTS, math::MATH_OUTPUTS),
        Op::MapRange { .. } => (math::MAP_RANGE_INPUTS, math::MAP_RANGE_OUTPUTS),
        Op::Clamp { .. } => (math::CLAMP_INPUTS, math::CLAMP_OUTPUTS),
        Op::RgbCurves { .. } => (color::RGB_CURVES_INPUTS, color::RGB_CURVES_OUTPUTS),
        Op::ColorRamp { .. } => (color::COLOR_RAMP_INPUTS, color::COLOR_RAMP_OUTPUTS),
        Op::Invert => (color::INVERT_INPUTS, color::INVERT_OUTPUTS),
        Op::HueSaturation => (color::HUE_SATURATION_INPUTS, color::HUE_SATURATION_OUTPUTS),
        Op::Gamma => (color::GAMMA_INPUTS, color::GAMMA_OUTPUTS),
        Op::BrightContrast => (
            color::BRIGHT_CONTRAST_INPUTS,
            color::BRIGHT_CONTRAST_OUTPUTS,
        ),
        Op::SeparateXyz => (convert::SEPARATE_XYZ_INPUTS, convert::SEPARATE_XYZ_OUTPUTS),
        Op::CombineXyz => (convert::COMBINE_XYZ_INPUTS, convert::COMBINE_XYZ_OUTPUTS),
        Op::SeparateColor { .. } => (
            convert::SEPARATE_COLOR_INPUTS,
            convert::SEPARATE_COLOR_OUTPUTS,
        ),
        Op::CombineColor { .. } => (
            convert::COMBINE_COLOR_INPUTS,
            convert::COMBINE_COLOR_OUTPUTS,
        ),
        Op::Checker => (checker::CHECKER_INPUTS, checker::CHECKER_OUTPUTS),
        Op::Gradient(_) => (gradient::GRADIENT_INPUTS, gradient::GRADIENT_OUTPUTS),
        Op::Noise { .. } | Op::NoiseAt3 { .. } => (noise::NOISE_INPUTS, noise::NOISE_OUTPUTS),
        Op::Image { .. } => (image::IMAGE_INPUTS, image::IMAGE_OUTPUTS),
        Op::Voronoi(_) => (voronoi::VORONOI_INPUTS, voronoi::VORONOI_OUTPUTS),
        Op::Wave(_) => (wave::WAVE_INPUTS, wave::WAVE_OUTPUTS),
        Op::WhiteNoise { .. } => (
            white_noise::WHITE_NOISE_INPUTS,
            white_noise::WHITE_NOISE_OUTPUTS,
        ),
        Op::Magic { .. } => (magic::MAGIC_INPUTS, magic::MAGIC_OUTPUTS),
        Op::Gabor { .. } => (gabor::GABOR_INPUTS, gabor::GABOR_OUTPUTS),
        Op::Brick(_) => (brick::BRICK_INPUTS, brick::BRICK_OUTPUTS),
        Op::Blackbody(_) => (blackbody::BLACKBODY_INPUTS, blackbody::BLACKBODY_OUTPUTS),
        Op::Fresnel => (fresnel::FRESNEL_INPUTS, fresnel::FRESNEL_OUTPUTS),
        Op::LayerWeight => (fresnel::LAYER_WEIGHT_INPUTS, fresnel::LAYER_WEIGHT_OUTPUTS),
        Op::Bump { .. } => (bump::BUMP_INPUTS, bump::BUMP_OUTPUTS),
        Op::Displacement { .. } => (bump::DISPLACEMENT_INPUTS, bump::DISPLACEMENT_OUTPUTS),
        Op::NormalMap(_) => (bump::NORMAL_MAP_INPUTS, bump::NORMAL_MAP_OUTPUTS),
        Op::VectorDisplacement(_) => (bump::VECTOR_DISPLACEMENT_INPUTS, bump::DISPLACEMENT_OUTPUTS),
        Op::Principled { .. } => (closure::PRINCIPLED_INPUTS, closure::PRINCIPLED_OUTPUTS),
        Op::Mix { data, .. } => match data {
            MixData::Float => (color::MIX_FLOAT_INPUTS, color::MIX_FLOAT_OUTPUTS),
            MixData::Vector => (color::MIX_VECTOR_INPUTS, color::MIX_VECTOR_OUTPUTS),
            MixData::Color => (color::MIX_COLOR_INPUTS, color::MIX_COLOR_OUTPUTS),
        },
        Op::Diffuse => (closure::DIFFUSE_INPUTS, closure::DIFFUSE_OUTPUTS),
        Op::Sheen => (closure::SHEEN_INPUTS, closure::SHEEN_OUTPUTS),
        Op::Glossy { .. } => (closure::GLOSSY_INPUTS, closure::GLOSSY_OUTPUTS),
        Op::Metallic { .. } => (closure::METALLIC_INPUTS, closure::METALLIC_OUTPUTS),
        Op::Toon { .. } => (closure::TOON_INPUTS, closure::TOON_OUTPUTS),
        Op::PrincipledHair { .. } => (
            closure::PRINCIPLED_HAIR_INPUTS,
            closure::PRINCIPLED_HAIR_OUTPUTS,
        ),
        Op::Hair { .. } => (closure::HAIR_INPUTS, closure::HAIR_OUTPUTS),
        Op::Glass { .. } | Op::Refraction => (closure::GLASS_INPUTS, closure::GLASS_OUTPUTS),
        Op::Emission => (closure::EMISSION_INPUTS, closure::EMISSION_OUTPUTS),
        Op::Transparent => (closure::TRANSPARENT_INPUTS, closure::TRANSPARENT_OUTPUTS),
        Op::RayPortal { .. } => (closure::RAY_PORTAL_INPUTS, closure::RAY_PORTAL_OUTPUTS),
        Op::Holdout => (&[], closure::HOLDOUT_OUTPUTS),
        Op::Translucent => (closure::TRANSLUCENT_INPUTS, closure::TRANSLUCENT_OUTPUTS),
        Op::MixShader => (closure::MIX_SHADER_INPUTS, closure::MIX_SHADER_OUTPUTS),
        Op::AddShader => (closure::ADD_SHADER_INPUTS, closure::ADD_SHADER_OUTPUTS),
        Op::PrincipledVolume { .. } => (volume::PRINCIPLED_VOLUME_INPUTS, volume::VOLUME_OUTPUTS),
        Op::VolumeScatter(_) => (volume::SCATTER_INPUTS, volume::VOLUME_OUTPUTS),
        Op::VolumeAbsorption => (volume::ABSORPTION_INPUTS, volume::VOLUME_OUTPUTS),
    };
    Spec { inputs, outputs }
}
