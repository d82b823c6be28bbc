//! A compiled node tree (`NodeProgram`): a flat list of instructions (`Instr`, one node's
//! operation `Op` with where its inputs come from, `Src`) over a small register file and a
//! small closure array, as Cycles' SVM lays out its programs.

use super::brick::BrickLayout;
use super::bump::NormalMapSpace;
use super::closure::{GLOSSY_INPUTS, METALLIC_INPUTS, PRINCIPLED_INPUTS};
use super::color::{Blend, MixData};
use super::gradient::GradientKind;
use super::inputs::input;
use super::math::{MapRangeKind, MathOp};
use super::vector::{Euler, MappingKind, VectorOp};
use super::volume::ScatterPhase;
use super::voronoi::VoronoiKind;
use super::wave::WaveKind;
use crate::math::Vec4;

/// Registers (node outputs) a program may use; larger trees are refused.
pub const MAX_REGISTERS: usize = 256;
/// Shader nodes a program may hold.
pub const MAX_CLOSURES: usize = 32;

/// How an input reads its value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Src {
    Const(Vec4),
    Reg(u16),
    /// A colour read as a float (Rec. 709 luminance, as Cycles' default colour space).
    Gray(u16),
    /// A vector read as a float (the average of its components).
    Average(u16),
    Closure(u16),
    /// The implicit Generated coordinates of an unlinked texture Vector input.
    Generated,
    /// The implicit UV (this UV map) of an unlinked Image Texture Vector input.
    Uv(u8),
}

/// One node's operation with its settings.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Op {
    /// Texture Coordinate; its UV output reads this UV map (the mesh's default, Blender's
    /// active render UV map, which the add-on names).
    TexCoord {
        uv_set: u8,
    },
    UvMap {
        uv_set: u8,
    },
    /// Color Attribute, and Attribute: its named attribute's slot in
    /// `NodeProgram::attributes` (a voxel grid where the object has it), else COLOR_0.
    VertexColor,
    Attribute {
        slot: u8,
    },
    /// Attribute of type Object or Instancer: its slot in the object's
    /// `ObjectInfo::attributes` (the values the add-on found for the object or instance).
    ObjectAttribute {
        slot: u8,
    },
    /// Attribute of type View Layer: the value the add-on found (one per render).
    LayerAttribute(Vec4),
    Geometry,
    /// Object Info, with the material's pass index (its Material Index output).
    ObjectInfo {
        material_index: f32,
    },
    /// Hair Info (Blender's Curves Info): the slots of the hair tube's attributes (intercept,
    /// length, thickness per vertex; the curve's index), read as zero where the mesh has none.
    HairInfo {
        fibre: u8,
        curve: u8,
    },
    /// Wireframe: its Size in pixels (`pixel_size`) or in scene units.
    Wireframe {
        pixel_size: bool,
    },
    /// Light Path: only what every integrator can tell (Is Camera Ray, Ray Length).
    LightPath,
    /// Ambient Occlusion: rays traced from the point (`Tracing`).
    AmbientOcclusion(super::ambient_occlusion::AmbientOcclusion),
    /// Bevel with its number of probes, traced from the point (`Tracing`).
    Bevel {
        samples: u32,
    },
    Value(f32),
    Rgb(Vec4),
    /// Mapping; its rotation's sines and cosines when the Rotation input is constant.
    Mapping(MappingKind, Option<Euler>),
    Math {
        op: MathOp,
        clamp: bool,
    },
    Mix {
        data: MixData,
        blend: Blend,
        clamp_factor: bool,
        clamp_result: bool,
    },
    ColorRamp {
        table: Vec<Vec4>,
        interpolate: bool,
    },
    /// RGB Curves: the curves baked over [min_x, min_x + range] (combined curve first, then
    /// each channel's, as Cycles bakes them), read with linear extrapolation.
    RgbCurves {
        table: Vec<Vec4>,
        min_x: f32,
        range: f32,
    },
    MapRange {
        kind: MapRangeKind,
        clamp: bool,
    },
    Clamp {
        range: bool,
    },
    Invert,
    SeparateXyz,
    CombineXyz,
    SeparateColor {
        hsv: bool,
    },
    CombineColor {
        hsv: bool,
    },
    Checker,
    Gradient(GradientKind),
    Noise {
        dimensions: u8,
        normalize: bool,
    },
    /// A Noise Texture and its two copies at a Bump's offset points, fused (`fuse_bump_noise`):
    /// `ins` holds the three nodes' inputs one after the other, `outs` and `used` their first
    /// output registers and read outputs.
    NoiseAt3 {
        dimensions: u8,
        normalize: bool,
        outs: [u16; 3],
        used: [u32; 3],
    },
    /// An Image Texture: its texture in `Scene::textures`, and whether it is transparent black
    /// outside [0, 1]² (Blender's Clip extension).
    Image {
        texture: u32,
        clip: bool,
        uv_set: u8,
    },
    Voronoi(VoronoiKind),
    /// Gabor: 2D, or 3D when `three_d`.
    Gabor {
        three_d: bool,
    },
    Wave(WaveKind),
    /// White Noise: 1 to 4 dimensions.
    WhiteNoise {
        dimensions: u8,
    },
    /// Magic: its turbulence depth.
    Magic {
        depth: u8,
    },
    Brick(BrickLayout),
    /// Blackbody: the working colour space its colour is given in.
    Blackbody(crate::color_space::WorkingSpace),
    HueSaturation,
    Gamma,
    BrightContrast,
    VectorMath(VectorOp),
    /// Bump; `object_space`: its normal and steps taken to object space and back (the bump
    /// Cycles adds over true displacement, "Displacement and Bump").
    Bump {
        invert: bool,
        object_space: bool,
    },
    NormalMap(NormalMapSpace),
    /// The Vector Displacement node, in tangent, object or world space.
    VectorDisplacement(NormalMapSpace),
    /// The Displacement node: its height along the normal, in object or world space.
    Displacement {
        object_space: bool,
    },
    Fresnel,
    LayerWeight,
    /// Principled BSDF; `multiscatter`: its distribution is Multiscatter GGX (else GGX);
    /// `blender_5_film`: its thin film is Blender 5's (`Closure::thin_film_blender_5`).
    Principled {
        multiscatter: bool,
        blender_5_film: bool,
    },
    Diffuse,
    /// Glossy and Anisotropic BSDF; `multiscatter` as the Principled's.
    Glossy {
        multiscatter: bool,
    },
    /// Metallic BSDF: F82 tint, or a physical conductor (`physical`); `multiscatter` as the
    /// Principled's.
    Metallic {
        physical: bool,
        multiscatter: bool,
    },
    Sheen,
    /// Toon BSDF, its Diffuse or (`glossy`) Glossy component.
    Toon {
        glossy: bool,
    },
    /// Principled Hair BSDF (Chiang model) with its colour parametrization.
    PrincipledHair {
        coloring: super::closure::HairColoring,
    },
    /// Hair BSDF, its Reflection or (`transmission`) Transmission component.
    Hair {
        transmission: bool,
    },
    /// Glass BSDF; `multiscatter` as the Principled's (its lobe divided by its albedo).
    Glass {
        multiscatter: bool,
    },
    /// Blender's Refraction BSDF: the glass's transmission lobe alone.
    Refraction,
    /// Blender's Holdout: no light, and a hole in the film's alpha for camera rays.
    Holdout,
    Emission,
    Transparent,
    /// Ray Portal BSDF; `position_given`: its Position input is linked or set (else the
    /// shading point).
    RayPortal {
        position_given: bool,
    },
    Translucent,
    MixShader,
    AddShader,
    /// Principled Volume with the slots of its Density, Color and Temperature attributes.
    PrincipledVolume {
        attributes: [u8; 3],
        /// The working colour space its black body's colour is given in.
        space: crate::color_space::WorkingSpace,
    },
    VolumeScatter(ScatterPhase),
    VolumeAbsorption,
}

/// One instruction: an operation, where its inputs come from, and the first register (or the
/// closure slot, for shader nodes) its outputs go to.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Instr {
    pub(super) op: Op,
    pub(super) ins: Vec<Src>,
    pub(super) out: u16,
    /// Which shading point it reads: 0 the point itself, 1 and 2 the points a small step
    /// along the two surface tangents (copies of a Bump node's Height subtree, as Cycles'
    /// SVM evaluates it at P + dPdx and P + dPdy).
    pub(super) offset: u8,
    /// Bit k: output k is read by some instruction (unread outputs may be skipped).
    pub(super) used: u32,
    /// True when every input is a register or a constant and `regs_in` holds them all.
    pub(super) all_regs: bool,
    /// Then the register each input reads, the constants' in `NodeProgram::constants`
    /// (`fold_constants`), so reading an input is one load instead of a match on its `Src`.
    /// Held in the instruction (no pointer to follow), and a `u8` indexes every register
    /// (`MAX_REGISTERS` is 256), so the load needs no bounds check.
    pub(super) regs_in: [u8; MAX_REGS_IN],
}

/// The most inputs an instruction reads through `Instr::regs_in` (more read their `Src`).
pub(super) const MAX_REGS_IN: usize = 32;

/// Bits of `NodeProgram::reads`: the `ShadingInputs` a program may read besides the position,
/// the normal and the view (the others may be left unset): the UV maps, the vertex colour,
/// the tangent, the Generated and Object coordinates, and the object-space normal with the
/// object-to-world normal matrix.
pub const READS_UV: u8 = 1;
pub const READS_COLOR: u8 = 2;
pub const READS_TANGENT: u8 = 4;
pub const READS_COORDS: u8 = 8;
pub const READS_OBJECT_NORMAL: u8 = 16;
/// The triangle's vertices and the ray's footprint (`ShadingInputs::triangle`, `pixel_width`).
pub const READS_TRIANGLE: u8 = 32;
/// The fibre's direction (`ShadingInputs::fibre`: Hair Info's Tangent Normal).
pub const READS_FIBRE: u8 = 64;
pub const READS_ALL: u8 = READS_UV
    | READS_COLOR
    | READS_TANGENT
    | READS_COORDS
    | READS_OBJECT_NORMAL
    | READS_TRIANGLE
    | READS_FIBRE;

/// The `READS_*` bits of what `instrs` read of the shading points (`run`, `load`).
pub(super) fn input_reads(instrs: &[Instr]) -> u8 {
    let bit = |on: bool, bit: u8| if on { bit } else { 0 };
    let mut reads = 0;
    for instr in instrs {
        for s in &instr.ins {
            reads |= match s {
                Src::Generated => READS_COORDS,
                Src::Uv(_) => READS_UV,
                _ => 0,
            };
        }
        let used = instr.used;
        reads |= match instr.op {
            // Outputs 0 and 3 are Generated and Object, 1 the object-space Normal, 2 the UV.
            Op::TexCoord { .. } => {
                bit(used & 0b1001 != 0, READS_COORDS)
                    | bit(used & 0b10 != 0, READS_OBJECT_NORMAL)
                    | bit(used & 0b100 != 0, READS_UV)
            }
            Op::UvMap { .. } => READS_UV,
            Op::VertexColor | Op::Attribute { .. } => READS_COLOR,
            Op::NormalMap(_) | Op::VectorDisplacement(_) => READS_TANGENT | READS_OBJECT_NORMAL,
            Op::Displacement { .. }
            | Op::Bump {
                object_space: true, ..
            } => READS_OBJECT_NORMAL,
            Op::Wireframe { .. } => READS_TRIANGLE,
            // Output 4 is Tangent Normal.
            Op::HairInfo { .. } => bit(used & 0b10000 != 0, READS_FIBRE),
            // An unlinked Tangent input (`tangent_input`) reads the Generated coordinates and
            // the object-to-world normal matrix, unless the anisotropy is a constant `run`
            // reads as none.
            Op::Principled { .. } => match instr.ins.get(input(PRINCIPLED_INPUTS, "Anisotropic")) {
                Some(Src::Const(a)) if !(a.x.clamp(0.0, 1.0) > 0.0) => 0,
                _ => READS_COORDS | READS_OBJECT_NORMAL,
            },
            Op::Glossy { .. } => match instr.ins.get(input(GLOSSY_INPUTS, "Anisotropy")) {
                Some(Src::Const(a)) if !(a.x.clamp(-0.99, 0.99).abs() > 1e-4) => 0,
                _ => READS_COORDS | READS_OBJECT_NORMAL,
            },
            Op::Metallic { .. } => match instr.ins.get(input(METALLIC_INPUTS, "Anisotropy")) {
                Some(Src::Const(a)) if !(a.x.clamp(0.0, 1.0) > 0.0) => 0,
                _ => READS_COORDS | READS_OBJECT_NORMAL,
            },
            _ => 0,
        };
    }
    reads
}

/// A compiled node tree.
#[derive(Clone, Debug, PartialEq)]
pub struct NodeProgram {
    pub(super) instrs: Vec<Instr>,
    pub(super) registers: usize,
    /// The constant inputs, put in the registers after the first `registers` before each run.
    pub(super) constants: Vec<Vec4>,
    pub(super) closures: usize,
    pub(super) output: Src,
    /// True when some node emits (the material is a light candidate).
    pub emits: bool,
    /// True when some node reads the vertex colours.
    pub reads_color: bool,
    /// True when the program reads the points a step away (it has a Bump node): `eval` then
    /// needs all three `ShadingInputs`.
    pub needs_offsets: bool,
    /// The `READS_*` bits: which position-dependent `ShadingInputs` `eval` reads (with the
    /// displacement tree's).
    pub reads: u8,
    /// True when some Light Path output reads the camera path's state (`RAY_STATE_OUTPUTS`):
    /// only the path tracer carries it to every shading point.
    pub reads_ray_state: bool,
    /// True when the tree can give a Transparent BSDF (a Transparent node, or a Principled
    /// BSDF's Alpha): shadow rays must evaluate it to pass.
    pub shadow_transparent: bool,
    /// True when some node gives a lobe that may be a smooth mirror or glass (the Principled,
    /// Glossy, Metallic, Glass and Refraction BSDFs, the Toon's glossy part, the Ray Portal
    /// BSDF, which sends the ray on from elsewhere): a tree without
    /// one never sends a ray on by a delta reflection or refraction (a volume's boundary, a
    /// diffuse or emitting surface).
    pub may_be_smooth: bool,
    /// True when the tree has a Ray Portal BSDF: camera paths follow it, photons end on it.
    pub ray_portal: bool,
    /// The Material Output's Displacement as Cycles bumps by it ("Bump Only", and over true
    /// displacement "Displacement and Bump"): a program whose
    /// output is the bumped normal, which the surface tree then reads as the shading normal.
    pub(super) displacement: Option<Box<NodeProgram>>,
    /// The Material Output's Displacement as Cycles' true displacement ("Displacement Only",
    /// or "Displacement and Bump" with `displacement` too): a program whose output is the
    /// world-space vector each vertex moves by, evaluated once per vertex when the scene is
    /// built (`crate::scene::displace`), never at shading points.
    pub(super) displace: Option<Box<NodeProgram>>,
    /// With "Displacement and Bump": flat faces are shaded smooth, by their vertices'
    /// normals before the displacement, under the bump (Blender 5's Cycles does; Blender 4's
    /// keeps a flat face's displaced normal under the bump).
    pub(super) smooth_flat_faces: bool,
    /// The named attributes the program reads (Attribute nodes, Principled Volume's attribute
    /// inputs), at most `NAMED_ATTRIBUTES`: `ShadingInputs::attributes` holds their values.
    pub attributes: Vec<String>,
}

impl NodeProgram {
    /// Whether the program's result may differ from point to point: it reads a coordinate, the
    /// geometry, an attribute, the view or the ray (a texture's implicit coordinates included).
    pub fn varies(&self) -> bool {
        self.varies_by(true)
    }

    /// Whether the result may differ from point to point where no named attribute is found
    /// (a volume in objects without grids): as `varies`, but Principled Volume's attribute
    /// inputs, which then read nothing, do not count.
    pub fn varies_without_named_attributes(&self) -> bool {
        self.varies_by(false)
    }

    fn varies_by(&self, named_attributes: bool) -> bool {
        self.instrs.iter().any(|i| {
            i.ins
                .iter()
                .any(|s| matches!(s, Src::Generated | Src::Uv(_)))
                || matches!(
                    i.op,
                    Op::TexCoord { .. }
                        | Op::UvMap { .. }
                        | Op::VertexColor
                        | Op::Attribute { .. }
                        | Op::ObjectAttribute { .. }
                        | Op::Geometry
                        | Op::ObjectInfo { .. }
                        | Op::HairInfo { .. }
                        | Op::Wireframe { .. }
                        | Op::LightPath
                        | Op::AmbientOcclusion(_)
                        | Op::Bevel { .. }
                        | Op::RayPortal { .. }
                        | Op::Bump { .. }
                        | Op::NormalMap(_)
                        | Op::VectorDisplacement(_)
                        | Op::Displacement { .. }
                        | Op::Fresnel
                        | Op::LayerWeight
                        | Op::NoiseAt3 { .. }
                )
                || matches!(i.op, Op::PrincipledVolume { attributes, .. } if named_attributes
                    && attributes.iter().any(|&s| s != super::inputs::NO_ATTRIBUTE))
        }) || self.displacement.is_some()
    }
}

/// What `compile` found that it could not evaluate: `(node name, message)`. The program
/// replaces such a node by its fallback (named in the message).
pub type CompileWarnings = Vec<String>;
