//! The exported JSON of one node (`PHOTON_material_nodes`, written by the add-on) into its
//! operation `Op` with its settings.

use super::ambient_occlusion::AmbientOcclusion;
use super::brick::BrickLayout;
use super::bump::NormalMapSpace;
use super::closure::HairColoring;
use super::color::{blend_mode, MixData};
use super::gradient::GradientKind;
use super::inputs::{NAMED_ATTRIBUTES, NO_ATTRIBUTE, OBJECT_ATTRIBUTES, UV_SETS};
use super::math::{math_op, MapRangeKind};
use super::program::CompileWarnings;
use super::program::Op;
use super::vector::{MappingKind, VectorOp};
use super::volume::ScatterPhase;
use super::voronoi::{CellHash, Metric, VoronoiFeature, VoronoiKind};
use super::wave::{WaveKind, WaveProfile};
use crate::color_space::WorkingSpace;
use crate::math::Vec4;
use serde_json::Value;

pub(super) fn number(v: &Value) -> Option<f32> {
    v.as_f64().map(|x| x as f32).filter(|x| x.is_finite())
}

pub(super) fn const_value(v: &Value) -> Option<Vec4> {
    if let Some(x) = number(v) {
        return Some(Vec4::new(x, x, x, 1.0));
    }
    let a = v.as_array()?;
    let c: Option<Vec<f32>> = a.iter().map(number).collect();
    let c = c?;
    match c.len() {
        2 => Some(Vec4::new(c[0], c[1], 0.0, 1.0)),
        3 => Some(Vec4::new(c[0], c[1], c[2], 1.0)),
        4 => Some(Vec4::new(c[0], c[1], c[2], c[3])),
        _ => None,
    }
}

/// The working colour space a node's colours are given in (its `working_space`; Rec.709 when
/// absent).
fn working_space(node: &Value) -> Result<WorkingSpace, String> {
    match setting(node, "working_space") {
        None => Ok(WorkingSpace::Rec709),
        Some(id) => {
            WorkingSpace::from_interop_id(id).ok_or_else(|| format!("unknown working space '{id}'"))
        }
    }
}

pub(super) fn setting<'a>(node: &'a Value, key: &str) -> Option<&'a str> {
    node.get(key).and_then(Value::as_str)
}

/// The UV map a node reads (`uv_set`, the `TEXCOORD_n` the add-on resolved its name to; 0
/// when absent).
pub(super) fn uv_set(node: &Value) -> Result<u8, String> {
    match node.get("uv_set").and_then(Value::as_u64) {
        None => Ok(0),
        Some(n) if (n as usize) < UV_SETS => Ok(n as u8),
        Some(n) => Err(format!("uv_set {n}: Photon reads {UV_SETS} UV maps")),
    }
}

/// The slot of the named attribute `name` in `names` (added when new); `NO_ATTRIBUTE` for no
/// name, or past `NAMED_ATTRIBUTES` names (with a warning).
fn attribute_slot(
    name: Option<&str>,
    names: &mut Vec<String>,
    warnings: &mut CompileWarnings,
) -> u8 {
    let Some(name) = name.filter(|n| !n.is_empty()) else {
        return NO_ATTRIBUTE;
    };
    if let Some(k) = names.iter().position(|n| n == name) {
        return k as u8;
    }
    if names.len() == NAMED_ATTRIBUTES {
        warnings.push(format!(
            "attribute '{name}' is not read: Photon reads {NAMED_ATTRIBUTES} named attributes \
             per node tree"
        ));
        return NO_ATTRIBUTE;
    }
    names.push(name.to_string());
    (names.len() - 1) as u8
}

/// The slot of the attribute the node names as `key` of its "attributes" (`attribute_slot`).
fn named_slot(
    node: &Value,
    key: &str,
    names: &mut Vec<String>,
    warnings: &mut CompileWarnings,
) -> u8 {
    let name = node
        .get("attributes")
        .and_then(|a| a.get(key))
        .and_then(Value::as_str);
    attribute_slot(name, names, warnings)
}

/// The operation of one exported node. `Ok(None)`: a node type the renderer does not evaluate.
/// Named attributes the node reads are given slots in `names`.
pub(super) fn parse_op(
    node: &Value,
    names: &mut Vec<String>,
    warnings: &mut CompileWarnings,
) -> Result<Option<Op>, String> {
    let kind = setting(node, "type").ok_or("a node has no 'type'")?;
    let kind = kind.strip_prefix("ShaderNode").unwrap_or(kind);
    let bad = |what: &str| format!("{kind}: unknown {what}");
    Ok(Some(match kind {
        "TexCoord" => Op::TexCoord {
            uv_set: uv_set(node)?,
        },
        "UVMap" => Op::UvMap {
            uv_set: uv_set(node)?,
        },
        "VertexColor" => Op::VertexColor,
        "Attribute" => match setting(node, "attribute_type").unwrap_or("GEOMETRY") {
            "GEOMETRY" => Op::Attribute {
                slot: attribute_slot(setting(node, "attribute_name"), names, warnings),
            },
            // Constant per object or instance: `ObjectInfo::attributes`.
            "OBJECT" | "INSTANCER" => Op::ObjectAttribute {
                slot: match node.get("object_slot") {
                    None => {
                        return Err("Attribute: an object attribute has no 'object_slot'".into())
                    }
                    Some(v) => v
                        .as_u64()
                        .filter(|&k| (k as usize) < OBJECT_ATTRIBUTES)
                        .ok_or_else(|| {
                            format!(
                                "Attribute: 'object_slot' {v} is out of range (0 to {})",
                                OBJECT_ATTRIBUTES - 1
                            )
                        })? as u8,
                },
            },
            // Constant over the render.
            "VIEW_LAYER" => Op::LayerAttribute(
                node.get("value")
                    .and_then(const_value)
                    .ok_or("Attribute: a view layer attribute needs a 'value' (RGBA)")?,
            ),
            other => return Err(format!("Attribute: unknown attribute_type '{other}'")),
        },
        "HairInfo" => Op::HairInfo {
            fibre: named_slot(node, "fibre", names, warnings),
            curve: named_slot(node, "curve", names, warnings),
        },
        "NewGeometry" => Op::Geometry,
        "Wireframe" => Op::Wireframe {
            pixel_size: node
                .get("use_pixel_size")
                .and_then(Value::as_bool)
                .unwrap_or(false),
        },
        "ObjectInfo" => Op::ObjectInfo {
            material_index: node.get("material_index").and_then(number).unwrap_or(0.0),
        },
        "LightPath" => Op::LightPath,
        "AmbientOcclusion" => Op::AmbientOcclusion(AmbientOcclusion {
            samples: node
                .get("samples")
                .and_then(number)
                .map_or(16, |n| n.clamp(1.0, 128.0) as u32),
            inside: node.get("inside").and_then(Value::as_bool).unwrap_or(false),
            only_local: node
                .get("only_local")
                .and_then(Value::as_bool)
                .unwrap_or(false),
        }),
        "Bevel" => Op::Bevel {
            samples: node
                .get("samples")
                .and_then(number)
                .map_or(4, |n| n.clamp(0.0, 128.0) as u32),
        },
        "Value" => Op::Value(
            node.get("value")
                .and_then(number)
                .ok_or("Value: 'value' must be a number")?,
        ),
        "RGB" => Op::Rgb(
            node.get("value")
                .and_then(const_value)
                .ok_or("RGB: 'value' must be a colour")?,
        ),
        "Mapping" => Op::Mapping(
            match setting(node, "vector_type").unwrap_or("POINT") {
                "POINT" => MappingKind::Point,
                "TEXTURE" => MappingKind::Texture,
                "VECTOR" => MappingKind::Vector,
                "NORMAL" => MappingKind::Normal,
                _ => return Err(bad("vector_type")),
            },
            None,
        ),
        "Math" => Op::Math {
            op: match math_op(setting(node, "operation").unwrap_or("ADD")) {
                Some(op) => op,
                None => return Ok(None),
            },
            clamp: node
                .get("use_clamp")
                .and_then(Value::as_bool)
                .unwrap_or(false),
        },
        "Mix" => Op::Mix {
            data: match setting(node, "data_type").unwrap_or("FLOAT") {
                "FLOAT" => MixData::Float,
                "VECTOR" => MixData::Vector,
                "RGBA" => MixData::Color,
                _ => return Ok(None),
            },
            blend: blend_mode(setting(node, "blend_type").unwrap_or("MIX"))
                .ok_or_else(|| bad("blend_type"))?,
            clamp_factor: node
                .get("clamp_factor")
                .and_then(Value::as_bool)
                .unwrap_or(true),
            clamp_result: node
                .get("clamp_result")
                .and_then(Value::as_bool)
                .unwrap_or(false),
        },
        "ValToRGB" => {
            let table: Option<Vec<Vec4>> = node
                .get("table")
                .and_then(Value::as_array)
                .map(|a| a.iter().map(const_value).collect::<Option<Vec<Vec4>>>())
                .unwrap_or(None);
            let table = table
                .filter(|t| t.len() >= 2)
                .ok_or("Color Ramp: 'table' must hold at least 2 RGBA colours")?;
            Op::ColorRamp {
                table,
                interpolate: setting(node, "interpolation").unwrap_or("LINEAR") != "CONSTANT",
            }
        }
        "RGBCurve" => {
            let table: Option<Vec<Vec4>> = node
                .get("table")
                .and_then(Value::as_array)
                .and_then(|a| a.iter().map(const_value).collect());
            let table = table
                .filter(|t| t.len() >= 2)
                .ok_or("RGB Curves: 'table' must hold at least 2 RGB colours")?;
            let min_x = node.get("min_x").and_then(number).unwrap_or(0.0);
            let max_x = node.get("max_x").and_then(number).unwrap_or(1.0);
            if max_x <= min_x {
                return Err("RGB Curves: 'max_x' must exceed 'min_x'".into());
            }
            Op::RgbCurves {
                table,
                min_x,
                range: max_x - min_x,
            }
        }
        "MapRange" => {
            if setting(node, "data_type").unwrap_or("FLOAT") != "FLOAT" {
                return Ok(None);
            }
            Op::MapRange {
                kind: match setting(node, "interpolation_type").unwrap_or("LINEAR") {
                    "LINEAR" => MapRangeKind::Linear,
                    "STEPPED" => MapRangeKind::Stepped,
                    "SMOOTHSTEP" => MapRangeKind::Smoothstep,
                    "SMOOTHERSTEP" => MapRangeKind::Smootherstep,
                    _ => return Err(bad("interpolation_type")),
                },
                clamp: node.get("clamp").and_then(Value::as_bool).unwrap_or(true),
            }
        }
        "Clamp" => Op::Clamp {
            range: setting(node, "clamp_type").unwrap_or("MINMAX") == "RANGE",
        },
        "Invert" => Op::Invert,
        "SeparateXYZ" => Op::SeparateXyz,
        "CombineXYZ" => Op::CombineXyz,
        "SeparateColor" | "CombineColor" => {
            let hsv = match setting(node, "mode").unwrap_or("RGB") {
                "RGB" => false,
                "HSV" => true,
                _ => return Ok(None),
            };
            if kind == "SeparateColor" {
                Op::SeparateColor { hsv }
            } else {
                Op::CombineColor { hsv }
            }
        }
        "TexChecker" => Op::Checker,
        "TexGabor" => Op::Gabor {
            three_d: match setting(node, "gabor_type").unwrap_or("2D") {
                "2D" => false,
                "3D" => true,
                _ => return Err(bad("gabor_type")),
            },
        },
        "TexGradient" => Op::Gradient(match setting(node, "gradient_type").unwrap_or("LINEAR") {
            "LINEAR" => GradientKind::Linear,
            "QUADRATIC" => GradientKind::Quadratic,
            "EASING" => GradientKind::Easing,
            "DIAGONAL" => GradientKind::Diagonal,
            "RADIAL" => GradientKind::Radial,
            "QUADRATIC_SPHERE" => GradientKind::QuadraticSphere,
            "SPHERICAL" => GradientKind::Spherical,
            _ => return Err(bad("gradient_type")),
        }),
        "TexNoise" => {
            if setting(node, "noise_type").unwrap_or("FBM") != "FBM" {
                return Ok(None);
            }
            let dimensions = match setting(node, "noise_dimensions").unwrap_or("3D") {
                "1D" => 1,
                "2D" => 2,
                "3D" => 3,
                _ => return Ok(None),
            };
            Op::Noise {
                dimensions,
                normalize: node
                    .get("normalize")
                    .and_then(Value::as_bool)
                    .unwrap_or(true),
            }
        }
        "TexImage" => {
            if setting(node, "projection").unwrap_or("FLAT") != "FLAT" {
                return Ok(None);
            }
            Op::Image {
                texture: node
                    .get("texture")
                    .and_then(Value::as_u64)
                    .and_then(|t| u32::try_from(t).ok())
                    .ok_or("Image Texture: no image")?,
                clip: setting(node, "extension") == Some("CLIP"),
                uv_set: uv_set(node)?,
            }
        }
        "TexVoronoi" => {
            let dimensions = match setting(node, "voronoi_dimensions").unwrap_or("3D") {
                "2D" => 2,
                "3D" => 3,
                _ => return Ok(None),
            };
            let feature = match setting(node, "feature").unwrap_or("F1") {
                "F1" => VoronoiFeature::F1,
                "F2" => VoronoiFeature::F2,
                "SMOOTH_F1" => VoronoiFeature::SmoothF1,
                _ => return Ok(None),
            };
            let metric = match setting(node, "distance").unwrap_or("EUCLIDEAN") {
                "EUCLIDEAN" => Metric::Euclidean,
                "MANHATTAN" => Metric::Manhattan,
                "CHEBYCHEV" => Metric::Chebychev,
                "MINKOWSKI" => Metric::Minkowski,
                _ => return Err(bad("distance")),
            };
            Op::Voronoi(VoronoiKind {
                dimensions,
                feature,
                metric,
                normalize: node
                    .get("normalize")
                    .and_then(Value::as_bool)
                    .unwrap_or(false),
                cell_hash: match setting(node, "cell_hash").unwrap_or("LOOKUP3") {
                    "LOOKUP3" => CellHash::Lookup3,
                    "PCG" => CellHash::Pcg,
                    _ => return Err(bad("cell_hash")),
                },
            })
        }
        "TexWave" => {
            let bands = setting(node, "wave_type").unwrap_or("BANDS") == "BANDS";
            let direction = if bands {
                setting(node, "bands_direction").unwrap_or("X")
            } else {
                setting(node, "rings_direction").unwrap_or("X")
            };
            Op::Wave(WaveKind {
                bands,
                direction: match direction {
                    "X" => 0,
                    "Y" => 1,
                    "Z" => 2,
                    "DIAGONAL" | "SPHERICAL" => 3,
                    _ => return Err(bad("direction")),
                },
                profile: match setting(node, "wave_profile").unwrap_or("SIN") {
                    "SIN" => WaveProfile::Sine,
                    "SAW" => WaveProfile::Saw,
                    "TRI" => WaveProfile::Triangle,
                    _ => return Err(bad("wave_profile")),
                },
            })
        }
        "TexWhiteNoise" => Op::WhiteNoise {
            dimensions: match setting(node, "noise_dimensions").unwrap_or("3D") {
                "1D" => 1,
                "2D" => 2,
                "3D" => 3,
                "4D" => 4,
                _ => return Err(bad("noise_dimensions")),
            },
        },
        "TexMagic" => Op::Magic {
            depth: node
                .get("turbulence_depth")
                .and_then(number)
                .map_or(2, |d| d.clamp(0.0, 10.0) as u8),
        },
        "TexBrick" => {
            let float = |key: &str, default: f32| node.get(key).and_then(number).unwrap_or(default);
            Op::Brick(BrickLayout {
                offset: float("offset", 0.5),
                offset_frequency: float("offset_frequency", 2.0) as i32,
                squash: float("squash", 1.0),
                squash_frequency: float("squash_frequency", 2.0) as i32,
            })
        }
        "Blackbody" => Op::Blackbody(working_space(node)?),
        "HueSaturation" => Op::HueSaturation,
        "Gamma" => Op::Gamma,
        "BrightContrast" => Op::BrightContrast,
        "VectorMath" => Op::VectorMath(match setting(node, "operation").unwrap_or("ADD") {
            "ADD" => VectorOp::Add,
            "SUBTRACT" => VectorOp::Subtract,
            "MULTIPLY" => VectorOp::Multiply,
            "DIVIDE" => VectorOp::Divide,
            "MULTIPLY_ADD" => VectorOp::MultiplyAdd,
            "CROSS_PRODUCT" => VectorOp::Cross,
            "PROJECT" => VectorOp::Project,
            "REFLECT" => VectorOp::Reflect,
            "DOT_PRODUCT" => VectorOp::Dot,
            "DISTANCE" => VectorOp::Distance,
            "LENGTH" => VectorOp::Length,
            "SCALE" => VectorOp::Scale,
            "NORMALIZE" => VectorOp::Normalize,
            "ABSOLUTE" => VectorOp::Absolute,
            "MINIMUM" => VectorOp::Minimum,
            "MAXIMUM" => VectorOp::Maximum,
            "FLOOR" => VectorOp::Floor,
            "CEIL" => VectorOp::Ceil,
            "FRACTION" => VectorOp::Fraction,
            "MODULO" => VectorOp::Modulo,
            "SNAP" => VectorOp::Snap,
            "SINE" => VectorOp::Sine,
            "COSINE" => VectorOp::Cosine,
            "TANGENT" => VectorOp::Tangent,
            _ => return Ok(None),
        }),
        "Fresnel" => Op::Fresnel,
        "LayerWeight" => Op::LayerWeight,
        "Bump" => Op::Bump {
            invert: node.get("invert").and_then(Value::as_bool).unwrap_or(false),
            object_space: node
                .get("object_space")
                .and_then(Value::as_bool)
                .unwrap_or(false),
        },
        "NormalMap" => Op::NormalMap(match setting(node, "space").unwrap_or("TANGENT") {
            "TANGENT" => NormalMapSpace::Tangent,
            "OBJECT" => NormalMapSpace::Object,
            "WORLD" => NormalMapSpace::World,
            "BLENDER_OBJECT" => NormalMapSpace::BlenderObject,
            "BLENDER_WORLD" => NormalMapSpace::BlenderWorld,
            _ => return Err(bad("space")),
        }),
        "VectorDisplacement" => {
            Op::VectorDisplacement(match setting(node, "space").unwrap_or("TANGENT") {
                "TANGENT" => NormalMapSpace::Tangent,
                "OBJECT" => NormalMapSpace::Object,
                "WORLD" => NormalMapSpace::World,
                _ => return Err(bad("space")),
            })
        }
        "Displacement" => Op::Displacement {
            object_space: match setting(node, "space").unwrap_or("OBJECT") {
                "OBJECT" => true,
                "WORLD" => false,
                _ => return Err(bad("space")),
            },
        },
        "BsdfPrincipled" => {
            let multiscatter = match setting(node, "distribution").unwrap_or("MULTI_GGX") {
                "MULTI_GGX" => true,
                "GGX" => false,
                _ => return Err(bad("distribution")),
            };
            let blender_5_film = match setting(node, "thin_film_model").unwrap_or("BLENDER_4") {
                "BLENDER_4" => false,
                "BLENDER_5" => true,
                _ => return Err(bad("thin_film_model")),
            };
            Op::Principled {
                multiscatter,
                blender_5_film,
            }
        }
        "BsdfDiffuse" => Op::Diffuse,
        "BsdfGlossy" | "BsdfAnisotropic" => {
            match setting(node, "distribution").unwrap_or("MULTI_GGX") {
                "MULTI_GGX" => Op::Glossy { multiscatter: true },
                "GGX" => Op::Glossy {
                    multiscatter: false,
                },
                // Beckmann and Ashikhmin–Shirley microfacets are not rendered.
                _ => return Ok(None),
            }
        }
        "BsdfHairPrincipled" => match setting(node, "model").unwrap_or("CHIANG") {
            "CHIANG" => Op::PrincipledHair {
                coloring: match setting(node, "parametrization").unwrap_or("COLOR") {
                    "COLOR" => HairColoring::Color,
                    "MELANIN" => HairColoring::Melanin,
                    "ABSORPTION" => HairColoring::Absorption,
                    _ => return Err(bad("parametrization")),
                },
            },
            _ => return Ok(None),
        },
        "BsdfHair" => Op::Hair {
            transmission: match setting(node, "component").unwrap_or("Reflection") {
                "Reflection" => false,
                "Transmission" => true,
                _ => return Err(bad("component")),
            },
        },
        "BsdfToon" => Op::Toon {
            glossy: match setting(node, "component").unwrap_or("DIFFUSE") {
                "DIFFUSE" => false,
                "GLOSSY" => true,
                _ => return Err(bad("component")),
            },
        },
        "BsdfMetallic" => Op::Metallic {
            physical: match setting(node, "fresnel_type").unwrap_or("F82") {
                "F82" => false,
                "PHYSICAL_CONDUCTOR" => true,
                _ => return Err(bad("fresnel_type")),
            },
            multiscatter: match setting(node, "distribution").unwrap_or("MULTI_GGX") {
                "MULTI_GGX" => true,
                "GGX" => false,
                // Beckmann microfacets are not rendered.
                _ => return Ok(None),
            },
        },
        "BsdfSheen" => match setting(node, "distribution").unwrap_or("MICROFIBER") {
            "MICROFIBER" => Op::Sheen,
            _ => return Ok(None),
        },
        "BsdfGlass" => match setting(node, "distribution").unwrap_or("MULTI_GGX") {
            "MULTI_GGX" => Op::Glass { multiscatter: true },
            "GGX" => Op::Glass {
                multiscatter: false,
            },
            // Beckmann microfacets are not rendered.
            _ => return Ok(None),
        },
        "BsdfRefraction" => Op::Refraction,
        "Emission" => Op::Emission,
        "BsdfTransparent" => Op::Transparent,
        // An unlinked Position is implicit (the add-on writes no value for it).
        "BsdfRayPortal" => Op::RayPortal {
            position_given: node.get("inputs").and_then(|i| i.get("Position")).is_some(),
        },
        "Holdout" => Op::Holdout,
        "BsdfTranslucent" => Op::Translucent,
        "MixShader" => Op::MixShader,
        "AddShader" => Op::AddShader,
        "VolumePrincipled" => {
            let mut slot = |key: &str| named_slot(node, key, names, warnings);
            Op::PrincipledVolume {
                attributes: [slot("density"), slot("color"), slot("temperature")],
                space: working_space(node)?,
            }
        }
        "VolumeAbsorption" => Op::VolumeAbsorption,
        "VolumeScatter" => match setting(node, "phase").unwrap_or("HENYEY_GREENSTEIN") {
            "HENYEY_GREENSTEIN" => Op::VolumeScatter(ScatterPhase::HenyeyGreenstein),
            "RAYLEIGH" => Op::VolumeScatter(ScatterPhase::Rayleigh),
            "DRAINE" => Op::VolumeScatter(ScatterPhase::Draine),
            "MIE" => Op::VolumeScatter(ScatterPhase::Mie),
            "FOURNIER_FORAND" => Op::VolumeScatter(ScatterPhase::FournierForand),
            _ => return Ok(None),
        },
        _ => return Ok(None),
    }))
}
