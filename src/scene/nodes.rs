//! Blender shader node trees, compiled once into a flat program and evaluated per shading point.
//!
//! The add-on writes each material's node tree as the `PHOTON_material_nodes` glTF extension
//! (documented in `scene::gltf`): groups flattened, reroutes followed, only the nodes reachable
//! from the active Material Output's Surface, in an order where every link points to an earlier
//! node. `compile` turns it into a `NodeProgram` as Cycles' SVM does (intern/cycles/kernel/svm):
//! a linear list of instructions over a small register file (one `Vec4` per node output) and a
//! small closure array, with unconnected inputs as constants and socket type conversions
//! (colour → float by Rec. 709 luminance, vector → float by the average) decided at compile
//! time. `NodeProgram::eval` runs it on a per-thread register file, allocating nothing.
//!
//! Texture and converter nodes follow Blender's definitions (the manual and Cycles' kernel:
//! `svm_checker`, `svm_gradient`, `svm_math`, `svm_mix`, `noise_fbm` with Jenkins' lookup3 hash
//! and Perlin's improved noise, `svm_magic`, `svm_brick` with its integer noise, the White
//! Noise's hashes of the coordinates' bits, Cycles' piecewise black-body fit,
//! `rgb_ramp_lookup` over the 256-entry table the add-on bakes with Blender's own
//! `ColorRamp.evaluate`), written here from those definitions.
//!
//! Light Path reads the ray the point is evaluated for (`RayPath`): its kind and bounce counts
//! as Cycles' path state keeps them (`path_state_next`), kept by the path walk; shadow rays and
//! sampled emitters read Cycles' shadow and emission conventions (`RayPath::shadow`,
//! `RayPath::emission`).
//!
//! A Bump node's Height subtree is compiled three times: as is, and copies that read the
//! shading point moved a small step along each surface tangent (`Instr::offset`), as Cycles'
//! SVM evaluates it at P + dPdx and P + dPdy; the normal then follows Cycles'
//! `svm_node_set_bump` with those steps as dPdx and dPdy. Each copy runs right after the
//! instruction it copies, and a Noise Texture with its two copies is one instruction
//! (`NoiseAt3`): the three nearby points share each octave's lattice hashes and run as vector
//! lanes, with the scalar code's values bit for bit.
//!
//! Shader nodes become Principled parameter sets (`Closure`); a Principled BSDF's Alpha below 1
//! mixes it with a Transparent BSDF by alpha, as Cycles does. Its coat, sheen and anisotropy
//! inputs are the BSDF's own layers (`crate::bsdf`); an unlinked Tangent is Cycles' default
//! (`default_tangent`), turned by Anisotropic Rotation around the normal. Diffuse BSDF → colour,
//! metallic 0, specular 0, its Roughness the Oren–Nayar lobe's (`crate::bsdf::oren_nayar`); Glossy →
//! metallic 1 with the colour as F0 (Blender's Glossy has no Fresnel: differs at grazing
//! angles), its Anisotropy as Cycles maps it (α (1 − a) along the tangent and α / (1 − a)
//! across, for a > 0); Sheen BSDF (microfiber) → the sheen layer alone; Glass → transmission
//! 1, its colour weighing reflection and each crossing alike (`Closure::glass`); Refraction → the
//! glass's transmission alone (`Closure::refraction`: the colour per crossing, no Fresnel, no
//! reflection); Emission → emission and
//! a black BSDF; Transparent → smooth transmission with IOR 1 (a straight pass-through tinted by
//! the colour, marked `Closure::transparent`: no bounce, and shadow rays pass it); Translucent →
//! the BSDF's Lambertian transmission lobe alone (`Closure::translucent`). Mix Shader mixes emission exactly and picks one BSDF per shading point with
//! probability given by the factor, as Cycles samples one closure by its weight: the BSDF is
//! linear in its closures, so every integrator (path tracing, photon tracing and gathering,
//! caches) gets the exact mixture in expectation, where interpolating parameters would not be
//! exact (a metal and a dielectric of different colours). Add Shader sums emission; of two BSDFs
//! it picks one with probability ½, which halves their sum (approximate; exact when one side
//! only emits, the common case).

use super::node_hash::{self, U32x4, W};
use super::texture::Texture;
use crate::math::{Mat3, Vec2, Vec3, Vec4};
use serde_json::Value;
use std::f32::consts::PI;
use std::ops::{Add, Div, Mul};

/// UV maps node trees read (`TEXCOORD_0` …).
pub const UV_SETS: usize = 4;
const _: () = assert!(UV_SETS == 4, "PointInputs::uv holds UV_SETS maps");

/// Registers (node outputs) a program may use; larger trees are refused.
pub const MAX_REGISTERS: usize = 256;
/// Shader nodes a program may hold.
pub const MAX_CLOSURES: usize = 32;

/// What a node tree reads about a shading point that moves with it, in Blender's axes (Z up):
/// a Bump's offset points differ from the point in these alone.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PointInputs {
    /// World position.
    pub position: Vec3,
    /// The UV maps (`TEXCOORD_n`), in Blender's convention (v up: glTF's 1 − v); zero where
    /// the mesh has none. (`UV_SETS` long: the literal works around a rustc internal error
    /// with a named constant here.)
    pub uv: [Vec2; 4],
    /// Generated coordinates: the object's texture space mapped to [0, 1]³.
    pub generated: Vec3,
    /// Object-space position.
    pub object: Vec3,
    /// Vertex colour COLOR_0 (white when the mesh has none).
    pub color: Vec4,
    /// The mesh's tangent for UV map 0 (world, Blender's axes, not normalised) with the
    /// bitangent sign in `w` (Blender's: bitangent = w × normal × tangent); zero when the mesh
    /// has none.
    pub tangent: Vec4,
}

/// What a node tree reads about the shading point, in Blender's axes (Z up).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ShadingInputs {
    /// The shading point (`points[0]`) and, when the program `needs_offsets`, the points a
    /// small step along its two tangents (else copies of the point), where a Bump node's
    /// Height is read (as Cycles' SVM evaluates it at P + dPdx and P + dPdy).
    pub points: [PointInputs; 3],
    /// Unit shading normal (world).
    pub normal: Vec3,
    /// The normal in object coordinates.
    pub object_normal: Vec3,
    /// Unit direction towards the viewer (world; Cycles' I).
    pub incoming: Vec3,
    /// Seen from behind the surface's winding (`normal` is then turned to the viewer).
    pub backfacing: bool,
    /// The kind and bounces of the ray that reached the point (Light Path's outputs).
    pub path: RayPath,
    /// The distance the ray travelled to the point (Light Path's Ray Length: a camera ray's
    /// from the near clip plane, as in Cycles; for an emitter sampled as a light, its distance
    /// to the shaded point; 0 where photons leave it).
    pub ray_length: f32,
    /// Object-space normals to world space (Blender's axes; not normalising).
    pub object_to_world_normal: Mat3,
}

impl ShadingInputs {
    /// The inputs at one point: `point` at all three (a program without a Bump).
    pub fn at_point(point: PointInputs) -> ShadingInputs {
        ShadingInputs {
            points: [point; 3],
            ..ShadingInputs::default()
        }
    }
}

/// The ray a shading point is evaluated for, as Cycles' path state describes it to the Light
/// Path node (`svm_node_light_path` reading the path flags and the bounce counters kept by
/// `path_state_next`): what kind of ray it is and how many bounces of each kind the path made
/// before it. The default is a ray of no kind after no bounce (photons, and the light the
/// photon methods gather).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayPath {
    /// `RayPath::CAMERA` … `RayPath::TRANSMIT`.
    pub flags: u8,
    /// Bounces so far, transparent ones excluded (Ray Depth; Cycles' `bounce`).
    pub depth: u16,
    /// Diffuse reflections, glossy (and singular) reflections, transmissions other than
    /// transparent ones, and transparent surfaces passed through.
    pub diffuse: u16,
    pub glossy: u16,
    pub transmission: u16,
    pub transparent: u16,
}

/// The Light Path node's outputs, in Blender's order.
const LIGHT_PATH_OUTPUTS: [&str; 14] = [
    "Is Camera Ray",
    "Is Shadow Ray",
    "Is Diffuse Ray",
    "Is Glossy Ray",
    "Is Singular Ray",
    "Is Reflection Ray",
    "Is Transmission Ray",
    "Is Volume Scatter Ray",
    "Ray Length",
    "Ray Depth",
    "Diffuse Depth",
    "Glossy Depth",
    "Transparent Depth",
    "Transmission Depth",
];

/// The Light Path outputs only a camera path's state tells (the lobe a ray left by and the
/// bounces before it): Is Diffuse … Is Transmission Ray and the depths.
const RAY_STATE_OUTPUTS: u32 = 0b11_1110_0111_1100;

/// Light Path's Ray Length.
const RAY_LENGTH_OUTPUT: u32 = 1 << 8;

/// The kind of scattering a BSDF sample made (Cycles' closure labels).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scattering {
    Diffuse,
    Glossy,
    /// A delta lobe (smooth mirror or glass).
    Singular,
    /// Straight through a Transparent BSDF (not a bounce).
    Transparent,
}

impl RayPath {
    pub const CAMERA: u8 = 1;
    pub const SHADOW: u8 = 2;
    pub const DIFFUSE: u8 = 4;
    pub const GLOSSY: u8 = 8;
    pub const SINGULAR: u8 = 16;
    pub const REFLECT: u8 = 32;
    pub const TRANSMIT: u8 = 64;

    /// A camera ray.
    pub const fn camera() -> RayPath {
        RayPath {
            flags: RayPath::CAMERA,
            depth: 0,
            diffuse: 0,
            glossy: 0,
            transmission: 0,
            transparent: 0,
        }
    }

    pub fn is(&self, flag: u8) -> bool {
        self.flags & flag != 0
    }

    /// The ray that leaves after `scattering`, reflected or `transmitted` (Cycles'
    /// `path_state_next`): a transparent pass keeps the ray's kind and counts only as a
    /// transparent bounce; any other replaces the kind and counts as a bounce, of its lobe
    /// when reflected (singular reflections count as glossy) or as a transmission.
    pub fn after(self, scattering: Scattering, transmitted: bool) -> RayPath {
        let mut next = self;
        if scattering == Scattering::Transparent {
            next.transparent = up_one(self.transparent);
            return next;
        }
        next.depth = up_one(self.depth);
        next.flags = if transmitted {
            next.transmission = up_one(self.transmission);
            RayPath::TRANSMIT
        } else {
            match scattering {
                Scattering::Diffuse => next.diffuse = up_one(self.diffuse),
                _ => next.glossy = up_one(self.glossy),
            }
            RayPath::REFLECT
        };
        next.flags |= match scattering {
            Scattering::Diffuse => RayPath::DIFFUSE,
            Scattering::Glossy => RayPath::GLOSSY,
            _ => RayPath::GLOSSY | RayPath::SINGULAR,
        };
        next
    }

    /// What a shadow ray from a vertex of this path reads (Cycles evaluates shadow rays'
    /// shaders with the shadow flag alone, one bounce further).
    pub fn shadow(self) -> RayPath {
        RayPath {
            flags: RayPath::SHADOW,
            depth: up_one(self.depth),
            ..self
        }
    }

    /// What an emitter sampled as a light from a vertex of this path reads (no kind, one
    /// bounce further, as Cycles evaluates it with its emission flag).
    pub fn emission(self) -> RayPath {
        RayPath {
            flags: 0,
            depth: up_one(self.depth),
            ..self
        }
    }
}

fn up_one(n: u16) -> u16 {
    n.saturating_add(1)
}

/// The Normal Map node's spaces (Blender's `space`).
#[derive(Clone, Copy, Debug, PartialEq)]
enum NormalMapSpace {
    Tangent,
    Object,
    World,
    /// Blender's own object and world conventions: y and z negated.
    BlenderObject,
    BlenderWorld,
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
    /// The GGX distribution without Multiscatter GGX's energy compensation of the metal and
    /// specular lobes (a Principled, Glossy or Anisotropic BSDF set to GGX, as scenes made
    /// before Blender 4.0 are).
    pub single_scatter: bool,
    /// What the whole BSDF is multiplied by (1; Add Shader picks one of two BSDFs with
    /// probability ½ and doubles it, so their sum is exact on average).
    pub weight: f32,
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
        transparent: false,
        translucent: false,
        refraction: false,
        glass: false,
        holdout: false,
        single_scatter: false,
        weight: 1.0,
    };
}

/// How an input reads its value.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Src {
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

#[derive(Clone, Copy, Debug, PartialEq)]
enum Ty {
    Float,
    Vector,
    Color,
    Shader,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum MappingKind {
    Point,
    Texture,
    Vector,
    Normal,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum MixData {
    Float,
    Vector,
    Color,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum MapRangeKind {
    Linear,
    Stepped,
    Smoothstep,
    Smootherstep,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum GradientKind {
    Linear,
    Quadratic,
    Easing,
    Diagonal,
    Radial,
    QuadraticSphere,
    Spherical,
}

/// One node's operation with its settings.
#[derive(Clone, Debug, PartialEq)]
enum Op {
    /// Texture Coordinate; its UV output reads this UV map (the mesh's default, Blender's
    /// active render UV map, which the add-on names).
    TexCoord {
        uv_set: u8,
    },
    UvMap {
        uv_set: u8,
    },
    /// Color Attribute and Attribute (COLOR_0).
    VertexColor,
    Attribute,
    Geometry,
    /// Light Path: only what every integrator can tell (Is Camera Ray, Ray Length).
    LightPath,
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
    Blackbody,
    HueSaturation,
    Gamma,
    BrightContrast,
    VectorMath(VectorOp),
    Bump {
        invert: bool,
    },
    NormalMap(NormalMapSpace),
    /// The Displacement node: its height along the normal, in object or world space.
    Displacement {
        object_space: bool,
    },
    Fresnel,
    LayerWeight,
    /// Principled BSDF; `multiscatter`: its distribution is Multiscatter GGX (else GGX).
    Principled {
        multiscatter: bool,
    },
    Diffuse,
    /// Glossy and Anisotropic BSDF; `multiscatter` as the Principled's.
    Glossy {
        multiscatter: bool,
    },
    Sheen,
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
    Translucent,
    MixShader,
    AddShader,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum VoronoiFeature {
    F1,
    F2,
    SmoothF1,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Metric {
    Euclidean,
    Manhattan,
    Chebychev,
    Minkowski,
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct VoronoiKind {
    dimensions: u8,
    feature: VoronoiFeature,
    metric: Metric,
    normalize: bool,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum WaveProfile {
    Sine,
    Saw,
    Triangle,
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct WaveKind {
    bands: bool,
    /// Bands: X, Y, Z, diagonal; rings: X, Y, Z, spherical.
    direction: u8,
    profile: WaveProfile,
}

/// The Brick texture's settings (node properties, not sockets).
#[derive(Clone, Copy, Debug, PartialEq)]
struct BrickLayout {
    offset: f32,
    offset_frequency: i32,
    squash: f32,
    squash_frequency: i32,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum VectorOp {
    Add,
    Subtract,
    Multiply,
    Divide,
    MultiplyAdd,
    Cross,
    Project,
    Reflect,
    Dot,
    Distance,
    Length,
    Scale,
    Normalize,
    Absolute,
    Minimum,
    Maximum,
    Floor,
    Ceil,
    Fraction,
    Modulo,
    Snap,
    Sine,
    Cosine,
    Tangent,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum MathOp {
    Add,
    Subtract,
    Multiply,
    Divide,
    MultiplyAdd,
    Power,
    Logarithm,
    Sqrt,
    InverseSqrt,
    Absolute,
    Exponent,
    Minimum,
    Maximum,
    LessThan,
    GreaterThan,
    Sign,
    Compare,
    SmoothMin,
    SmoothMax,
    Round,
    Floor,
    Ceil,
    Trunc,
    Fraction,
    Modulo,
    FlooredModulo,
    Wrap,
    Snap,
    PingPong,
    Sine,
    Cosine,
    Tangent,
    Arcsine,
    Arccosine,
    Arctangent,
    Arctan2,
    Sinh,
    Cosh,
    Tanh,
    Radians,
    Degrees,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Blend {
    Mix,
    Add,
    Multiply,
    Subtract,
    Screen,
    Divide,
    Difference,
    Exclusion,
    Darken,
    Lighten,
    Overlay,
    Dodge,
    Burn,
    Hue,
    Saturation,
    Value,
    Color,
    SoftLight,
    LinearLight,
}

/// One instruction: an operation, where its inputs come from, and the first register (or the
/// closure slot, for shader nodes) its outputs go to.
#[derive(Clone, Debug, PartialEq)]
struct Instr {
    op: Op,
    ins: Vec<Src>,
    out: u16,
    /// Which shading point it reads: 0 the point itself, 1 and 2 the points a small step
    /// along the two surface tangents (copies of a Bump node's Height subtree, as Cycles'
    /// SVM evaluates it at P + dPdx and P + dPdy).
    offset: u8,
    /// Bit k: output k is read by some instruction (unread outputs may be skipped).
    used: u32,
    /// True when every input is a register or a constant and `regs_in` holds them all.
    all_regs: bool,
    /// Then the register each input reads, the constants' in `NodeProgram::constants`
    /// (`fold_constants`), so reading an input is one load instead of a match on its `Src`.
    /// Held in the instruction (no pointer to follow), and a `u8` indexes every register
    /// (`MAX_REGISTERS` is 256), so the load needs no bounds check.
    regs_in: [u8; MAX_REGS_IN],
}

/// The most inputs an instruction reads through `Instr::regs_in` (more read their `Src`).
const MAX_REGS_IN: usize = 32;

/// Bits of `NodeProgram::reads`: the `ShadingInputs` a program may read besides the position,
/// the normal and the view (the others may be left unset): the UV maps, the vertex colour,
/// the tangent, the Generated and Object coordinates, and the object-space normal with the
/// object-to-world normal matrix.
pub const READS_UV: u8 = 1;
pub const READS_COLOR: u8 = 2;
pub const READS_TANGENT: u8 = 4;
pub const READS_COORDS: u8 = 8;
pub const READS_OBJECT_NORMAL: u8 = 16;
pub const READS_ALL: u8 =
    READS_UV | READS_COLOR | READS_TANGENT | READS_COORDS | READS_OBJECT_NORMAL;

/// The `READS_*` bits of what `instrs` read of the shading points (`run`, `load`).
fn input_reads(instrs: &[Instr]) -> u8 {
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
            Op::VertexColor | Op::Attribute => READS_COLOR,
            Op::NormalMap(_) => READS_TANGENT | READS_OBJECT_NORMAL,
            Op::Displacement { .. } => READS_OBJECT_NORMAL,
            // An unlinked Tangent input (`tangent_input`) reads the Generated coordinates and
            // the object-to-world normal matrix, unless the anisotropy is a constant `run`
            // reads as none.
            Op::Principled { .. } => match instr.ins.get(11) {
                Some(Src::Const(a)) if !(a.x.clamp(0.0, 1.0) > 0.0) => 0,
                _ => READS_COORDS | READS_OBJECT_NORMAL,
            },
            Op::Glossy { .. } => match instr.ins.get(3) {
                Some(Src::Const(a)) if !(a.x.clamp(-0.99, 0.99).abs() > 1e-4) => 0,
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
    instrs: Vec<Instr>,
    registers: usize,
    /// The constant inputs, put in the registers after the first `registers` before each run.
    constants: Vec<Vec4>,
    closures: usize,
    output: Src,
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
    /// The Material Output's Displacement as Cycles' "bump only" method: a program whose
    /// output is the bumped normal, which the surface tree then reads as the shading normal.
    displacement: Option<Box<NodeProgram>>,
}

/// What `compile` found that it could not evaluate: `(node name, message)`. The program
/// replaces such a node by its fallback (named in the message).
pub type CompileWarnings = Vec<String>;

fn number(v: &Value) -> Option<f32> {
    v.as_f64().map(|x| x as f32).filter(|x| x.is_finite())
}

fn const_value(v: &Value) -> Option<Vec4> {
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

/// An input: its identifier, type and Blender's default value.
type InputSpec = (String, Ty, Vec4);
/// An output: its identifier and type.
type OutputSpec = (&'static str, Ty);

/// Input identifiers with their types and Blender's defaults, and output identifiers with types.
struct Spec {
    inputs: Vec<InputSpec>,
    outputs: Vec<OutputSpec>,
}

fn f(x: f32) -> Vec4 {
    Vec4::new(x, x, x, 1.0)
}

fn spec(op: &Op) -> Spec {
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
    };
    Spec { inputs, outputs }
}

fn setting<'a>(node: &'a Value, key: &str) -> Option<&'a str> {
    node.get(key).and_then(Value::as_str)
}

fn math_op(name: &str) -> Option<MathOp> {
    use MathOp::*;
    Some(match name {
        "ADD" => Add,
        "SUBTRACT" => Subtract,
        "MULTIPLY" => Multiply,
        "DIVIDE" => Divide,
        "MULTIPLY_ADD" => MultiplyAdd,
        "POWER" => Power,
        "LOGARITHM" => Logarithm,
        "SQRT" => Sqrt,
        "INVERSE_SQRT" => InverseSqrt,
        "ABSOLUTE" => Absolute,
        "EXPONENT" => Exponent,
        "MINIMUM" => Minimum,
        "MAXIMUM" => Maximum,
        "LESS_THAN" => LessThan,
        "GREATER_THAN" => GreaterThan,
        "SIGN" => Sign,
        "COMPARE" => Compare,
        "SMOOTH_MIN" => SmoothMin,
        "SMOOTH_MAX" => SmoothMax,
        "ROUND" => Round,
        "FLOOR" => Floor,
        "CEIL" => Ceil,
        "TRUNC" => Trunc,
        "FRACT" => Fraction,
        "MODULO" => Modulo,
        "FLOORED_MODULO" => FlooredModulo,
        "WRAP" => Wrap,
        "SNAP" => Snap,
        "PINGPONG" => PingPong,
        "SINE" => Sine,
        "COSINE" => Cosine,
        "TANGENT" => Tangent,
        "ARCSINE" => Arcsine,
        "ARCCOSINE" => Arccosine,
        "ARCTANGENT" => Arctangent,
        "ARCTAN2" => Arctan2,
        "SINH" => Sinh,
        "COSH" => Cosh,
        "TANH" => Tanh,
        "RADIANS" => Radians,
        "DEGREES" => Degrees,
        _ => return None,
    })
}

fn blend_mode(name: &str) -> Option<Blend> {
    use Blend::*;
    Some(match name {
        "MIX" => Mix,
        "ADD" => Add,
        "MULTIPLY" => Multiply,
        "SUBTRACT" => Subtract,
        "SCREEN" => Screen,
        "DIVIDE" => Divide,
        "DIFFERENCE" => Difference,
        "EXCLUSION" => Exclusion,
        "DARKEN" => Darken,
        "LIGHTEN" => Lighten,
        "OVERLAY" => Overlay,
        "DODGE" => Dodge,
        "BURN" => Burn,
        "HUE" => Hue,
        "SATURATION" => Saturation,
        "VALUE" => Value,
        "COLOR" => Color,
        "SOFT_LIGHT" => SoftLight,
        "LINEAR_LIGHT" => LinearLight,
        _ => return None,
    })
}

/// The UV map a node reads (`uv_set`, the `TEXCOORD_n` the add-on resolved its name to; 0
/// when absent).
fn uv_set(node: &Value) -> Result<u8, String> {
    match node.get("uv_set").and_then(Value::as_u64) {
        None => Ok(0),
        Some(n) if (n as usize) < UV_SETS => Ok(n as u8),
        Some(n) => Err(format!("uv_set {n}: Photon reads {UV_SETS} UV maps")),
    }
}

/// The operation of one exported node. `Ok(None)`: a node type the renderer does not evaluate.
fn parse_op(node: &Value) -> Result<Option<Op>, String> {
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
        "Attribute" => Op::Attribute,
        "NewGeometry" => Op::Geometry,
        "LightPath" => Op::LightPath,
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
        "Blackbody" => Op::Blackbody,
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
        },
        "NormalMap" => Op::NormalMap(match setting(node, "space").unwrap_or("TANGENT") {
            "TANGENT" => NormalMapSpace::Tangent,
            "OBJECT" => NormalMapSpace::Object,
            "WORLD" => NormalMapSpace::World,
            "BLENDER_OBJECT" => NormalMapSpace::BlenderObject,
            "BLENDER_WORLD" => NormalMapSpace::BlenderWorld,
            _ => return Err(bad("space")),
        }),
        "Displacement" => Op::Displacement {
            object_space: match setting(node, "space").unwrap_or("OBJECT") {
                "OBJECT" => true,
                "WORLD" => false,
                _ => return Err(bad("space")),
            },
        },
        "BsdfPrincipled" => match setting(node, "distribution").unwrap_or("MULTI_GGX") {
            "MULTI_GGX" => Op::Principled { multiscatter: true },
            "GGX" => Op::Principled {
                multiscatter: false,
            },
            _ => return Err(bad("distribution")),
        },
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
        "Holdout" => Op::Holdout,
        "BsdfTranslucent" => Op::Translucent,
        "MixShader" => Op::MixShader,
        "AddShader" => Op::AddShader,
        _ => return Ok(None),
    }))
}

/// Compile the `PHOTON_material_nodes` extension of a material. Errors (a malformed tree: a link
/// to a later node or a missing output, a value of the wrong kind) refuse the file; nodes the
/// renderer cannot evaluate are replaced by their fallback with a warning in `warnings`.
/// `textures` is the number of textures in the scene (Image Texture nodes name one of them).
/// A `displacement` tree (same form, its `output` a vector: the bumped normal) is compiled
/// alongside; the surface tree then reads its normal (`NodeProgram::eval`).
pub fn compile(
    ext: &Value,
    textures: usize,
    warnings: &mut CompileWarnings,
) -> Result<NodeProgram, String> {
    let mut program = compile_tree(ext, textures, warnings, Ty::Shader)?;
    if let Some(tree) = ext.get("displacement").filter(|d| !d.is_null()) {
        let normal = compile_tree(tree, textures, warnings, Ty::Vector)
            .map_err(|m| format!("displacement: {m}"))?;
        program.needs_offsets |= normal.needs_offsets;
        program.reads_color |= normal.reads_color;
        program.reads |= normal.reads;
        program.reads_ray_state |= normal.reads_ray_state;
        program.displacement = Some(Box::new(normal));
    }
    Ok(program)
}

/// One tree whose `output` is of type `output_type` (a shader, or a vector).
fn compile_tree(
    ext: &Value,
    textures: usize,
    warnings: &mut CompileWarnings,
    output_type: Ty,
) -> Result<NodeProgram, String> {
    let nodes = ext
        .get("nodes")
        .and_then(Value::as_array)
        .ok_or("'nodes' must be an array")?;
    // Per node: (first register or closure slot, output names and types), or None when skipped.
    let mut placed: Vec<Option<(u16, Vec<OutputSpec>)>> = Vec::with_capacity(nodes.len());
    let mut instrs: Vec<Instr> = Vec::new();
    let mut registers = 0usize;
    let mut closures = 0usize;
    let mut emits = false;
    let mut reads_color = false;
    let mut needs_offsets = false;
    let mut shadow_transparent = false;
    // Per node: its instruction and the nodes its inputs read (for copying Bump subtrees).
    let mut node_instr: Vec<Option<usize>> = Vec::with_capacity(nodes.len());
    let mut deps: Vec<Vec<usize>> = Vec::with_capacity(nodes.len());
    // Per instruction: the instruction it copies (a Bump's offset copies), else itself.
    let mut anchors: Vec<usize> = Vec::new();
    for (index, node) in nodes.iter().enumerate() {
        let name = setting(node, "name").unwrap_or("?").to_string();
        let kind = setting(node, "type").unwrap_or("?").to_string();
        let op = match parse_op(node).map_err(|m| format!("node {index} '{name}': {m}"))? {
            Some(op) => op,
            None => {
                warnings.push(format!(
                    "node '{name}' ({kind}) is not evaluated by Photon; what it feeds reads \
                     the input's default value instead"
                ));
                placed.push(None);
                node_instr.push(None);
                deps.push(Vec::new());
                continue;
            }
        };
        if let Op::Image { texture, .. } = op {
            if texture as usize >= textures {
                return Err(format!(
                    "node {index} '{name}': texture {texture} does not exist"
                ));
            }
        }
        let spec = spec(&op);
        let inputs = node.get("inputs");
        let texture_vector = matches!(
            op,
            Op::Checker
                | Op::Gradient(_)
                | Op::Noise { .. }
                | Op::Voronoi(_)
                | Op::Wave(_)
                | Op::Magic { .. }
                | Op::Brick(_)
        );
        let mut ins = Vec::with_capacity(spec.inputs.len());
        let mut reads = Vec::new();
        for (id, ty, default) in &spec.inputs {
            let given = inputs.and_then(|i| i.get(id.as_str()));
            let src = match given {
                None if *ty == Ty::Shader => Src::Const(Vec4::ZERO),
                None if texture_vector && id == "Vector" => Src::Generated,
                None if id == "Vector" && matches!(op, Op::Image { .. }) => match op {
                    Op::Image { uv_set, .. } => Src::Uv(uv_set),
                    _ => Src::Const(*default),
                },
                None => Src::Const(*default),
                Some(v) if v.get("node").is_some() => {
                    let from = v
                        .get("node")
                        .and_then(Value::as_u64)
                        .map(|n| n as usize)
                        .filter(|&n| n < index)
                        .ok_or_else(|| {
                            format!(
                                "node {index} '{name}': input '{id}' links to a node that is \
                                 not earlier in the list"
                            )
                        })?;
                    let output = setting(v, "output").unwrap_or("");
                    match &placed[from] {
                        None => match ty {
                            Ty::Shader => Src::Const(Vec4::ZERO),
                            _ if texture_vector && id == "Vector" => Src::Generated,
                            _ => Src::Const(*default),
                        },
                        Some((base, outs)) => {
                            reads.push(from);
                            let k = outs.iter().position(|(n, _)| *n == output);
                            let Some(k) = k else {
                                // An output the renderer does not provide (e.g. Texture
                                // Coordinate's Camera): fall back to the input's default.
                                warnings.push(format!(
                                    "node '{name}': input '{id}' reads output '{output}' of \
                                     node {from}, which Photon does not provide; the input's \
                                     default is used"
                                ));
                                ins.push(Src::Const(*default));
                                continue;
                            };
                            let (from_ty, reg) = (outs[k].1, base + k as u16);
                            match (from_ty, *ty) {
                                (Ty::Shader, Ty::Shader) => Src::Closure(reg),
                                (Ty::Shader, _) | (_, Ty::Shader) => {
                                    return Err(format!(
                                        "node {index} '{name}': input '{id}' links a shader \
                                         and a value"
                                    ))
                                }
                                (Ty::Color, Ty::Float) => Src::Gray(reg),
                                (Ty::Vector, Ty::Float) => Src::Average(reg),
                                _ => Src::Reg(reg),
                            }
                        }
                    }
                }
                Some(v) => Src::Const(const_value(v).ok_or_else(|| {
                    format!("node {index} '{name}': input '{id}' is not a number or a vector")
                })?),
            };
            ins.push(src);
        }
        let shader = spec.outputs.first().is_some_and(|o| o.1 == Ty::Shader);
        let out = if shader {
            closures += 1;
            closures - 1
        } else {
            registers += spec.outputs.len();
            registers - spec.outputs.len()
        };
        if registers > MAX_REGISTERS || closures > MAX_CLOSURES {
            return Err(format!(
                "the tree needs more than {MAX_REGISTERS} values or {MAX_CLOSURES} shaders"
            ));
        }
        // A light candidate unless its emission inputs are constant black.
        let black = |k: usize| matches!(ins[k], Src::Const(v) if v.truncate() == Vec3::ZERO);
        emits |= match op {
            Op::Emission => !black(0) && !black(1),
            Op::Principled { .. } => !black(8) && !black(9),
            _ => false,
        };
        reads_color |= matches!(op, Op::VertexColor | Op::Attribute);
        shadow_transparent |= match op {
            Op::Transparent => true,
            Op::Principled { .. } => !matches!(ins[4], Src::Const(v) if v.x >= 1.0),
            _ => false,
        };
        if matches!(op, Op::Bump { .. }) {
            // The Height subtree again at the two offset points; the heights there are the
            // Bump's inputs 5 and 6.
            let height = ins[3];
            // Only what feeds Height: the nodes whose registers Height reads, and upstream.
            let feeds_height = |n: usize, placed: &[Option<(u16, Vec<OutputSpec>)>]| {
                placed[n].as_ref().is_some_and(|(b, o)| {
                    let r = match height {
                        Src::Reg(r) | Src::Gray(r) | Src::Average(r) => r,
                        _ => return false,
                    };
                    *b <= r && r < *b + o.len() as u16
                })
            };
            let roots: Vec<usize> = reads
                .iter()
                .copied()
                .filter(|&n| feeds_height(n, &placed))
                .collect();
            let mut keep: Vec<usize> = Vec::new();
            let mut stack = roots;
            while let Some(n) = stack.pop() {
                if !keep.contains(&n) {
                    keep.push(n);
                    stack.extend(deps[n].iter().copied());
                }
            }
            keep.sort_unstable();
            for offset in [1u8, 2] {
                let mut moved: Vec<(u16, u16, u16)> = Vec::new(); // (old base, count, new base)
                for &n in &keep {
                    let Some(k) = node_instr[n] else { continue };
                    let (old, outs) = placed[n].as_ref().expect("kept nodes are placed");
                    let count = outs.len() as u16;
                    let mut copy = instrs[k].clone();
                    let remap = |r: u16, moved: &[(u16, u16, u16)]| {
                        moved
                            .iter()
                            .find(|(b, c, _)| *b <= r && r < b + c)
                            .map_or(r, |(b, _, nb)| nb + (r - b))
                    };
                    for s in copy.ins.iter_mut() {
                        *s = match *s {
                            Src::Reg(r) => Src::Reg(remap(r, &moved)),
                            Src::Gray(r) => Src::Gray(remap(r, &moved)),
                            Src::Average(r) => Src::Average(remap(r, &moved)),
                            other => other,
                        };
                    }
                    copy.out = registers as u16;
                    copy.offset = offset;
                    moved.push((*old, count, registers as u16));
                    registers += count as usize;
                    if registers > MAX_REGISTERS {
                        return Err(format!("the tree needs more than {MAX_REGISTERS} values"));
                    }
                    instrs.push(copy);
                    anchors.push(k);
                }
                let remap = |r: u16| {
                    moved
                        .iter()
                        .find(|(b, c, _)| *b <= r && r < b + c)
                        .map_or(r, |(b, _, nb)| nb + (r - b))
                };
                ins.push(match height {
                    Src::Reg(r) => Src::Reg(remap(r)),
                    Src::Gray(r) => Src::Gray(remap(r)),
                    Src::Average(r) => Src::Average(remap(r)),
                    other => other,
                });
            }
        }
        let needs = matches!(op, Op::Bump { .. });
        placed.push(Some((out as u16, spec.outputs.clone())));
        node_instr.push(if shader { None } else { Some(instrs.len()) });
        deps.push(reads);
        needs_offsets |= needs;
        let op = match (op, ins.get(2)) {
            // A constant rotation's sines and cosines, once.
            (Op::Mapping(kind, None), Some(Src::Const(r))) => {
                Op::Mapping(kind, Some(Euler::new(r.truncate())))
            }
            (op, _) => op,
        };
        anchors.push(instrs.len());
        instrs.push(Instr {
            op,
            ins,
            out: out as u16,
            offset: 0,
            used: u32::MAX,
            all_regs: false,
            regs_in: [0; MAX_REGS_IN],
        });
    }
    let output = match ext.get("output") {
        None | Some(Value::Null) => Src::Const(Vec4::ZERO),
        Some(v) => {
            let from = v
                .get("node")
                .and_then(Value::as_u64)
                .map(|n| n as usize)
                .filter(|&n| n < nodes.len())
                .ok_or("'output' must name a node of the list")?;
            let name = setting(v, "output").unwrap_or("");
            match &placed[from] {
                None => Src::Const(Vec4::ZERO),
                Some((base, outs)) => match outs.iter().position(|(n, _)| *n == name) {
                    Some(k) if outs[k].1 == output_type && output_type == Ty::Shader => {
                        Src::Closure(base + k as u16)
                    }
                    Some(k) if outs[k].1 == output_type => Src::Reg(base + k as u16),
                    _ => {
                        return Err(format!(
                            "'output' must be a {} output, found '{name}'",
                            if output_type == Ty::Shader {
                                "shader"
                            } else {
                                "vector"
                            }
                        ))
                    }
                },
            }
        }
    };
    // Which outputs are read: a texture skips the work of an output nobody reads.
    let mut read = vec![false; registers];
    if let Src::Reg(r) = output {
        read[r as usize] = true;
    }
    for instr in &instrs {
        for s in &instr.ins {
            if let Src::Reg(r) | Src::Gray(r) | Src::Average(r) = *s {
                read[r as usize] = true;
            }
        }
    }
    for instr in instrs.iter_mut() {
        let outputs = spec(&instr.op).outputs;
        if outputs.first().is_some_and(|o| o.1 != Ty::Shader) {
            instr.used = (0..outputs.len())
                .filter(|&k| read[instr.out as usize + k])
                .fold(0, |mask, k| mask | 1 << k);
        }
    }
    let mut instrs = fuse_bump_noise(instrs, &anchors);
    let constants = fold_constants(&mut instrs, registers);
    let light_path_reads = instrs
        .iter()
        .filter(|i| i.op == Op::LightPath)
        .fold(0, |mask, i| mask | i.used);
    if emits && light_path_reads & RAY_LENGTH_OUTPUT != 0 {
        warnings.push(
            "Light Path's Ray Length in a tree that emits: photons leaving the surface read \
             it as 0, so photon mapping's light from it may differ (path tracing and light \
             sampling read the true distance)"
                .to_string(),
        );
    }

    let reads = input_reads(&instrs);
    Ok(NodeProgram {
        instrs,
        registers,
        constants,
        closures,
        output,
        emits,
        reads_color,
        needs_offsets,
        reads,
        reads_ray_state: light_path_reads & RAY_STATE_OUTPUTS != 0,
        shadow_transparent,
        displacement: None,
    })
}

/// Sets `regs_in` of each instruction whose inputs are all registers or constants, the
/// constants (equal ones shared) numbered from register `registers` on as long as they fit
/// in `MAX_REGISTERS`; returns the constants in register order.
fn fold_constants(instrs: &mut [Instr], registers: usize) -> Vec<Vec4> {
    const _: () = assert!(MAX_REGISTERS == 256, "register indices are u8");
    let mut constants: Vec<Vec4> = Vec::new();
    for instr in instrs.iter_mut() {
        let mut regs = Vec::with_capacity(instr.ins.len());
        for s in &instr.ins {
            let r = match *s {
                Src::Reg(r) => r as usize,
                Src::Const(v) => {
                    let bits = |c: &Vec4| c.to_array().map(f32::to_bits);
                    match constants.iter().position(|c| bits(c) == bits(&v)) {
                        Some(k) => registers + k,
                        None if registers + constants.len() < MAX_REGISTERS => {
                            constants.push(v);
                            registers + constants.len() - 1
                        }
                        None => break,
                    }
                }
                _ => break,
            };
            regs.push(r as u8);
        }
        if regs.len() == instr.ins.len() && regs.len() <= MAX_REGS_IN {
            instr.all_regs = true;
            instr.regs_in[..regs.len()].copy_from_slice(&regs);
        }
    }
    constants
}

/// Each of a Bump's offset copies moved to just after the instruction it copies (valid: a
/// copy reads only copies of what its original reads, or what the original reads, all of
/// which come earlier), then every Noise Texture followed by its copies at both offsets fused
/// into one `NoiseAt3`, which shares the lattice hashes of the three nearby points (the same
/// values as three separate evaluations, bit for bit).
fn fuse_bump_noise(instrs: Vec<Instr>, anchors: &[usize]) -> Vec<Instr> {
    let mut order: Vec<(usize, Instr)> = anchors.iter().copied().zip(instrs).collect();
    order.sort_by_key(|(anchor, _)| *anchor);
    let mut fused: Vec<Instr> = Vec::with_capacity(order.len());
    let mut k = 0;
    while k < order.len() {
        let triple = order.get(k..k + 3).filter(|t| {
            matches!(t[0].1.op, Op::Noise { .. })
                && t.iter().all(|(a, i)| *a == t[0].0 && i.op == t[0].1.op)
                && t.iter()
                    .enumerate()
                    .all(|(n, (_, i))| i.offset as usize == n)
        });
        match (triple, &order[k].1.op) {
            (
                Some(t),
                Op::Noise {
                    dimensions,
                    normalize,
                },
            ) => {
                fused.push(Instr {
                    op: Op::NoiseAt3 {
                        dimensions: *dimensions,
                        normalize: *normalize,
                        outs: [t[0].1.out, t[1].1.out, t[2].1.out],
                        used: [t[0].1.used, t[1].1.used, t[2].1.used],
                    },
                    ins: t.iter().flat_map(|(_, i)| i.ins.iter().copied()).collect(),
                    out: t[0].1.out,
                    offset: 0,
                    used: t[0].1.used | t[1].1.used | t[2].1.used,
                    all_regs: false,
                    regs_in: [0; MAX_REGS_IN],
                });
                k += 3;
            }
            _ => {
                fused.push(order[k].1.clone());
                k += 1;
            }
        }
    }
    fused
}

// ----- evaluation --------------------------------------------------------------------------

struct Machine {
    regs: [Vec4; MAX_REGISTERS],
    closures: [Closure; MAX_CLOSURES],
}

impl Machine {
    /// Run `program` on this thread's register file (one per thread, reused: clearing the
    /// registers and closures the program uses costs far less than a fresh 6 KB file), and
    /// return what `run` reads off it. Nothing is allocated per shading point.
    fn with<R>(program: &NodeProgram, run: impl FnOnce(&mut Machine) -> R) -> R {
        thread_local! {
            static MACHINE: std::cell::RefCell<Box<Machine>> =
                std::cell::RefCell::new(Box::new(Machine {
                    regs: [Vec4::ZERO; MAX_REGISTERS],
                    closures: [Closure::BLACK; MAX_CLOSURES],
                }));
        }
        MACHINE.with(|cell| {
            let mut m = cell.borrow_mut();
            m.regs[..program.registers].fill(Vec4::ZERO);
            let end = program.registers + program.constants.len();
            m.regs[program.registers..end].copy_from_slice(&program.constants);
            m.closures[..program.closures].fill(Closure::BLACK);
            run(&mut m)
        })
    }
}

fn gray(c: Vec4) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

fn splat(x: f32) -> Vec4 {
    Vec4::new(x, x, x, 1.0)
}

fn v3(v: Vec3) -> Vec4 {
    v.extend(1.0)
}

impl NodeProgram {
    /// Evaluate the program at a shading point. `u` in [0, 1) picks the BSDF of Mix and Add
    /// Shader nodes (module header).
    /// `at.points` holds the shading point and, when `needs_offsets`, the points a small step
    /// along its two tangents (else three copies of the point).
    /// With a displacement tree, its bumped normal is the shading normal the surface tree
    /// reads, and the normal of its BSDFs whose Normal input is unlinked (Cycles sets the
    /// shading point's N before evaluating the surface).
    pub fn eval(&self, at: &ShadingInputs, textures: &[Texture], mut u: f32) -> Closure {
        let Some(displacement) = &self.displacement else {
            return self.eval_closure(at, textures, &mut u);
        };
        let n = displacement.eval_vector(at, textures);
        let bumped = ShadingInputs { normal: n, ..*at };
        let mut c = self.eval_closure(&bumped, textures, &mut u);
        if c.normal == Vec3::ZERO {
            c.normal = n;
        }
        c
    }

    fn eval_closure(&self, at: &ShadingInputs, textures: &[Texture], u: &mut f32) -> Closure {
        Machine::with(self, |m| {
            run_all(&self.instrs, at, textures, m, u);
            closure(m, self.output)
        })
    }

    /// A vector-output program's value (the displacement tree's normal, unit).
    fn eval_vector(&self, at: &ShadingInputs, textures: &[Texture]) -> Vec3 {
        Machine::with(self, |m| {
            run_all(&self.instrs, at, textures, m, &mut 0.5);
            load(m, &at.points[0], self.output)
                .truncate()
                .normalize_or(at.normal)
        })
    }

    /// Number of instructions (for tests and `photon info`).
    pub fn len(&self) -> usize {
        self.instrs.len()
    }

    pub fn is_empty(&self) -> bool {
        self.instrs.is_empty()
    }

    /// Registers and closure slots the program uses.
    pub fn size(&self) -> (usize, usize) {
        (self.registers, self.closures)
    }
}

#[inline(always)]
fn load(m: &Machine, at: &PointInputs, s: Src) -> Vec4 {
    match s {
        Src::Const(v) => v,
        Src::Reg(r) => m.regs[r as usize],
        Src::Gray(r) => splat(gray(m.regs[r as usize])),
        Src::Average(r) => {
            let v = m.regs[r as usize];
            splat((v.x + v.y + v.z) / 3.0)
        }
        Src::Closure(_) => Vec4::ZERO,
        Src::Generated => v3(at.generated),
        Src::Uv(set) => uv_value(at, set),
    }
}

/// Input `k` of `instr` at the shading point `at`.
#[inline(always)]
fn operand(m: &Machine, at: &PointInputs, instr: &Instr, k: usize) -> Vec4 {
    if instr.all_regs {
        m.regs[instr.regs_in[k] as usize]
    } else {
        load(m, at, instr.ins[k])
    }
}

fn uv_value(at: &PointInputs, set: u8) -> Vec4 {
    let uv = at.uv[set as usize];
    Vec4::new(uv.x, uv.y, 0.0, 1.0)
}

fn closure(m: &Machine, s: Src) -> Closure {
    match s {
        Src::Closure(c) => m.closures[c as usize],
        _ => Closure::BLACK,
    }
}

/// Run `instrs` in order: one call, the instructions' bodies inlined in its loop (a call per
/// instruction cost each its large frame's set-up).
#[inline(never)]
fn run_all(
    instrs: &[Instr],
    inputs: &ShadingInputs,
    textures: &[Texture],
    m: &mut Machine,
    u: &mut f32,
) {
    for instr in instrs {
        // Opaque to the optimiser: else it hoists the shared inputs' conversions (which few
        // instructions read) out of the loop, ~200 instructions per evaluation.
        run(instr, std::hint::black_box(inputs), textures, m, u);
    }
}

#[inline(always)]
fn run(instr: &Instr, inputs: &ShadingInputs, textures: &[Texture], m: &mut Machine, u: &mut f32) {
    let at = &inputs.points[instr.offset as usize];
    let ins = &instr.ins;
    let get = |m: &Machine, k: usize| operand(m, at, instr, k);
    let o = instr.out as usize;
    match &instr.op {
        Op::TexCoord { uv_set } => {
            // Only the outputs some instruction reads (often one).
            let used = |k: u32| instr.used & (1 << k) != 0;
            if used(0) {
                m.regs[o] = v3(at.generated);
            }
            if used(1) {
                m.regs[o + 1] = v3(inputs.object_normal);
            }
            if used(2) {
                m.regs[o + 2] = uv_value(at, *uv_set);
            }
            if used(3) {
                m.regs[o + 3] = v3(at.object);
            }
            if used(4) {
                let (n, i) = (inputs.normal, inputs.incoming);
                m.regs[o + 4] = v3(2.0 * n.dot(i) * n - i);
            }
        }
        Op::UvMap { uv_set } => m.regs[o] = uv_value(at, *uv_set),
        Op::VertexColor => {
            m.regs[o] = at.color;
            m.regs[o + 1] = splat(at.color.w);
        }
        Op::Attribute => {
            m.regs[o] = at.color.truncate().extend(1.0);
            m.regs[o + 1] = at.color.truncate().extend(1.0);
            m.regs[o + 2] = splat(gray(at.color));
            m.regs[o + 3] = splat(at.color.w);
        }
        Op::Geometry => {
            m.regs[o] = v3(at.position);
            m.regs[o + 1] = v3(inputs.normal);
            m.regs[o + 2] = v3(inputs.normal);
            m.regs[o + 3] = v3(inputs.incoming);
            m.regs[o + 4] = splat(if inputs.backfacing { 1.0 } else { 0.0 });
        }
        Op::LightPath => {
            let p = &inputs.path;
            let flag = |f: u8| splat(if p.is(f) { 1.0 } else { 0.0 });
            let count = |n: u16| splat(n as f32);
            let values = [
                flag(RayPath::CAMERA),
                flag(RayPath::SHADOW),
                flag(RayPath::DIFFUSE),
                flag(RayPath::GLOSSY),
                flag(RayPath::SINGULAR),
                flag(RayPath::REFLECT),
                flag(RayPath::TRANSMIT),
                // No volumes: never a volume scatter ray.
                splat(0.0),
                splat(inputs.ray_length),
                count(p.depth),
                count(p.diffuse),
                count(p.glossy),
                count(p.transparent),
                count(p.transmission),
            ];
            for (k, v) in values.into_iter().enumerate() {
                if instr.used & (1 << k) != 0 {
                    m.regs[o + k] = v;
                }
            }
        }
        Op::Value(v) => m.regs[o] = splat(*v),
        Op::Rgb(c) => m.regs[o] = *c,
        Op::Mapping(kind, fixed) => {
            let v = get(m, 0).truncate();
            let loc = get(m, 1).truncate();
            let rot = fixed.unwrap_or_else(|| Euler::new(get(m, 2).truncate()));
            let scale = get(m, 3).truncate();
            m.regs[o] = v3(mapping(*kind, v, loc, &rot, scale));
        }
        Op::Math { op, clamp } => {
            let r = math(*op, get(m, 0).x, get(m, 1).x, get(m, 2).x);
            m.regs[o] = splat(if *clamp { r.clamp(0.0, 1.0) } else { r });
        }
        Op::Mix {
            data,
            blend,
            clamp_factor,
            clamp_result,
        } => {
            let mut t = get(m, 0).x;
            if *clamp_factor {
                t = t.clamp(0.0, 1.0);
            }
            let (a, b) = (get(m, 1), get(m, 2));
            m.regs[o] = match data {
                MixData::Float => splat(a.x + (b.x - a.x) * t),
                MixData::Vector => v3(a.truncate().lerp(b.truncate(), t)),
                MixData::Color => {
                    let c = mix_color(*blend, t, a.truncate(), b.truncate());
                    let c = if *clamp_result {
                        c.clamp(Vec3::ZERO, Vec3::ONE)
                    } else {
                        c
                    };
                    c.extend(a.w)
                }
            };
        }
        Op::RgbCurves {
            table,
            min_x,
            range,
        } => {
            let fac = get(m, 0).x;
            let c = get(m, 1);
            let rel = (c.truncate() - Vec3::splat(*min_x)) / *range;
            let curve = Vec3::new(
                ramp_extrapolated(table, rel.x).x,
                ramp_extrapolated(table, rel.y).y,
                ramp_extrapolated(table, rel.z).z,
            );
            m.regs[o] = ((1.0 - fac) * c.truncate() + fac * curve).extend(c.w);
        }
        Op::ColorRamp { table, interpolate } => {
            let c = ramp_lookup(table, get(m, 0).x, *interpolate);
            m.regs[o] = c;
            m.regs[o + 1] = splat(c.w);
        }
        Op::MapRange { kind, clamp } => {
            let [v, a, b, c, d, steps] = [0, 1, 2, 3, 4, 5].map(|k| get(m, k).x);
            m.regs[o] = splat(map_range(*kind, *clamp, v, a, b, c, d, steps));
        }
        Op::Clamp { range } => {
            let (v, lo, hi) = (get(m, 0).x, get(m, 1).x, get(m, 2).x);
            let r = if *range && lo > hi {
                v.clamp(hi, lo)
            } else {
                v.max(lo).min(hi)
            };
            m.regs[o] = splat(r);
        }
        Op::Invert => {
            let t = get(m, 0).x;
            let c = get(m, 1);
            let inv = Vec3::ONE - c.truncate();
            m.regs[o] = c.truncate().lerp(inv, t).extend(c.w);
        }
        Op::SeparateXyz => {
            let v = get(m, 0);
            m.regs[o] = splat(v.x);
            m.regs[o + 1] = splat(v.y);
            m.regs[o + 2] = splat(v.z);
        }
        Op::CombineXyz => {
            m.regs[o] = Vec4::new(get(m, 0).x, get(m, 1).x, get(m, 2).x, 1.0);
        }
        Op::SeparateColor { hsv } => {
            let c = get(m, 0).truncate();
            let c = if *hsv { rgb_to_hsv(c) } else { c };
            m.regs[o] = splat(c.x);
            m.regs[o + 1] = splat(c.y);
            m.regs[o + 2] = splat(c.z);
        }
        Op::CombineColor { hsv } => {
            let c = Vec3::new(get(m, 0).x, get(m, 1).x, get(m, 2).x);
            m.regs[o] = v3(if *hsv { hsv_to_rgb(c) } else { c });
        }
        Op::Checker => {
            let p = get(m, 0).truncate() * get(m, 3).x;
            let fac = checker(p);
            m.regs[o] = if fac == 1.0 { get(m, 1) } else { get(m, 2) };
            m.regs[o + 1] = splat(fac);
        }
        Op::Gradient(kind) => {
            let fac = gradient(*kind, get(m, 0).truncate());
            m.regs[o] = splat(fac);
            m.regs[o + 1] = splat(fac);
        }
        Op::Noise {
            dimensions,
            normalize,
        } => {
            let scale = get(m, 2).x;
            let p = get(m, 0).truncate() * scale;
            let w = get(m, 1).x * scale;
            let params = Fractal {
                detail: get(m, 3).x.clamp(0.0, 15.0),
                roughness: get(m, 4).x.max(0.0),
                lacunarity: get(m, 5).x,
                normalize: *normalize,
            };
            let distortion = get(m, 8).x;
            let color = instr.used & 2 != 0;
            let (fac, color) = noise_texture(*dimensions, p, w, &params, distortion, color);
            m.regs[o] = splat(fac);
            m.regs[o + 1] = v3(color);
        }
        Op::NoiseAt3 {
            dimensions,
            normalize,
            outs,
            used,
        } => {
            let input = |k: usize| {
                let g = |j: usize| operand(m, &inputs.points[k], instr, 9 * k + j).x;
                let scale = g(2);
                let p = operand(m, &inputs.points[k], instr, 9 * k).truncate() * scale;
                let f = Fractal {
                    detail: g(3).clamp(0.0, 15.0),
                    roughness: g(4).max(0.0),
                    lacunarity: g(5),
                    normalize: *normalize,
                };
                (p, g(1) * scale, f, g(8))
            };
            let color = used.iter().any(|u| u & 2 != 0);
            let values = noise_texture_at3(*dimensions, &[input(0), input(1), input(2)], color);
            for ((fac, color), out) in values.into_iter().zip(outs) {
                m.regs[*out as usize] = splat(fac);
                m.regs[*out as usize + 1] = v3(color);
            }
        }
        Op::Image { texture, clip, .. } => {
            let uv = get(m, 0);
            let outside = !(0.0..=1.0).contains(&uv.x) || !(0.0..=1.0).contains(&uv.y);
            // Blender's image rows go up from the bottom; Photon's from the top.
            let c = match textures.get(*texture as usize) {
                Some(_) if *clip && outside => Vec4::ZERO,
                Some(t) => t.sample_encoded(Vec2::new(uv.x, 1.0 - uv.y)),
                None => Vec4::new(1.0, 0.0, 1.0, 1.0),
            };
            m.regs[o] = c;
            m.regs[o + 1] = splat(c.w);
        }
        Op::Voronoi(kind) => {
            let scale = get(m, 2).x;
            let params = VoronoiParams {
                scale,
                detail: get(m, 3).x.clamp(0.0, 15.0),
                roughness: get(m, 4).x.clamp(0.0, 1.0),
                lacunarity: get(m, 5).x,
                smoothness: (get(m, 6).x / 2.0).clamp(0.0, 0.5),
                exponent: get(m, 7).x,
                randomness: get(m, 8).x.clamp(0.0, 1.0),
                kind: *kind,
            };
            let mut p = get(m, 0).truncate() * scale;
            if kind.dimensions == 2 {
                p.z = 0.0;
            }
            let (distance, color, position) = voronoi(&params, p, instr.used & 2 != 0);
            m.regs[o] = splat(distance);
            m.regs[o + 1] = v3(color);
            m.regs[o + 2] = v3(position);
        }
        Op::Wave(kind) => {
            let p = get(m, 0).truncate() * get(m, 1).x;
            let fac = wave(
                *kind,
                p,
                [
                    get(m, 2).x,
                    get(m, 3).x.clamp(0.0, 15.0),
                    get(m, 4).x,
                    get(m, 5).x,
                    get(m, 6).x,
                ],
            );
            m.regs[o] = splat(fac);
            m.regs[o + 1] = splat(fac);
        }
        Op::WhiteNoise { dimensions } => {
            let (value, color) = white_noise(*dimensions, get(m, 0).truncate(), get(m, 1).x);
            m.regs[o] = splat(value);
            m.regs[o + 1] = v3(color);
        }
        Op::Magic { depth } => {
            let c = magic(get(m, 0).truncate(), get(m, 1).x, *depth, get(m, 2).x);
            m.regs[o] = v3(c);
            m.regs[o + 1] = splat((c.x + c.y + c.z) / 3.0);
        }
        Op::Brick(layout) => {
            let p = get(m, 0).truncate() * get(m, 4).x;
            let [size, smooth, bias, width, height] = [5, 6, 7, 8, 9].map(|k| get(m, k).x);
            let (tint, mortar) = brick(layout, p, [size, smooth, bias, width, height]);
            let (c1, c2, mortar_color) = (get(m, 1), get(m, 2), get(m, 3));
            let brick_color = if mortar != 1.0 {
                c1.truncate().lerp(c2.truncate(), tint)
            } else {
                c1.truncate()
            };
            m.regs[o] = v3(brick_color.lerp(mortar_color.truncate(), mortar));
            m.regs[o + 1] = splat(mortar);
        }
        Op::Blackbody => m.regs[o] = v3(blackbody(get(m, 0).x).max(Vec3::ZERO)),
        Op::HueSaturation => {
            let (hue, sat, val, fac) = (get(m, 0).x, get(m, 1).x, get(m, 2).x, get(m, 3).x);
            let input = get(m, 4);
            let mut hsv = rgb_to_hsv(input.truncate());
            hsv.x = (hsv.x + hue + 0.5) % 1.0;
            hsv.y = (hsv.y * sat).clamp(0.0, 1.0);
            hsv.z *= val;
            let c = hsv_to_rgb(hsv);
            let c = (fac * c + (1.0 - fac) * input.truncate()).max(Vec3::ZERO);
            m.regs[o] = c.extend(input.w);
        }
        Op::Gamma => {
            let c = get(m, 0);
            let g = get(m, 1).x;
            let p = |x: f32| if x > 0.0 { x.powf(g) } else { x };
            m.regs[o] = Vec4::new(p(c.x), p(c.y), p(c.z), c.w);
        }
        Op::BrightContrast => {
            let c = get(m, 0);
            let (bright, contrast) = (get(m, 1).x, get(m, 2).x);
            let a = 1.0 + contrast;
            let b = bright - contrast * 0.5;
            m.regs[o] = (a * c.truncate() + Vec3::splat(b))
                .max(Vec3::ZERO)
                .extend(c.w);
        }
        Op::VectorMath(op) => {
            let (v, value) = vector_math(
                *op,
                get(m, 0).truncate(),
                get(m, 1).truncate(),
                get(m, 2).truncate(),
                get(m, 3).x,
            );
            m.regs[o] = v3(v);
            m.regs[o + 1] = splat(value);
        }
        Op::Fresnel => {
            let n = normal_input(get(m, 1), inputs.normal);
            let eta = get(m, 0).x.max(1e-5);
            let eta = if inputs.backfacing { 1.0 / eta } else { eta };
            m.regs[o] = splat(fresnel_dielectric_cos(inputs.incoming.dot(n), eta));
        }
        Op::LayerWeight => {
            let n = normal_input(get(m, 1), inputs.normal);
            let blend = get(m, 0).x;
            let eta = (1.0 - blend).max(1e-5);
            let eta = if inputs.backfacing { eta } else { 1.0 / eta };
            let cos = inputs.incoming.dot(n);
            m.regs[o] = splat(fresnel_dielectric_cos(cos, eta));
            let mut facing = cos.abs();
            if blend != 0.5 {
                let b = blend.clamp(0.0, 1.0 - 1e-5);
                let b = if b < 0.5 { 2.0 * b } else { 0.5 / (1.0 - b) };
                facing = facing.powf(b);
            }
            m.regs[o + 1] = splat(1.0 - facing);
        }
        Op::Bump { invert } => {
            let strength = get(m, 0).x.max(0.0);
            let distance = if *invert { -get(m, 1).x } else { get(m, 1).x };
            let given = get(m, 4).truncate();
            let n = if given == Vec3::ZERO {
                inputs.normal
            } else {
                given.normalize_or(inputs.normal)
            };
            let (hc, hx, hy) = (get(m, 3).x, get(m, 5).x, get(m, 6).x);
            // Cycles' svm_node_set_bump with our steps as dPdx, dPdy: the normal of the
            // surface displaced by distance × height.
            let dx = inputs.points[1].position - inputs.points[0].position;
            let dy = inputs.points[2].position - inputs.points[0].position;
            let rx = dy.cross(n);
            let ry = n.cross(dx);
            let det = dx.dot(rx);
            let surfgrad = (hx - hc) * rx + (hy - hc) * ry;
            let out = (det.abs() * n - distance * det.signum() * surfgrad).normalize_or_zero();
            let out = if out == Vec3::ZERO {
                n
            } else {
                (strength * out + (1.0 - strength) * n).normalize_or(n)
            };
            m.regs[o] = v3(out);
        }
        Op::Displacement { object_space } => {
            let n = normal_input(get(m, 3), inputs.normal);
            let height = (get(m, 0).x - get(m, 1).x) * get(m, 2).x;
            let direction = if *object_space {
                // Cycles: the normal to object space (normalised), scaled, and back as a
                // direction, so the object's scale scales the displacement.
                let to_object = inputs.object_to_world_normal.inverse();
                to_object.transpose() * (to_object * n).normalize_or_zero()
            } else {
                n
            };
            m.regs[o] = v3(direction * height);
        }
        Op::NormalMap(space) => {
            m.regs[o] = v3(normal_map(
                *space,
                get(m, 1).truncate(),
                get(m, 0).x,
                inputs,
                at,
            ));
        }
        Op::Principled { multiscatter } => {
            let level = get(m, 5).x.max(0.0);
            let tint = get(m, 6).truncate();
            let normal = get(m, 10).truncate();
            let anisotropic = get(m, 11).x.clamp(0.0, 1.0);
            let (aspect, tangent) = if anisotropic > 0.0 {
                let n = normal_input(get(m, 10), inputs.normal);
                let t = tangent_input(get(m, 13), inputs, at);
                let t = crate::math::rotate_around(t, n, get(m, 12).x * 2.0 * PI);
                (principled_aspect(anisotropic), t)
            } else {
                (1.0, Vec3::ZERO)
            };
            let principled = Closure {
                base_color: get(m, 0).truncate(),
                metallic: get(m, 1).x.clamp(0.0, 1.0),
                roughness: get(m, 2).x.clamp(0.0, 1.0),
                ior: get(m, 3).x,
                specular: 1.0,
                specular_color: 2.0 * level * tint,
                transmission: get(m, 7).x.clamp(0.0, 1.0),
                emission: get(m, 8).truncate() * get(m, 9).x,
                normal,
                coat_weight: get(m, 14).x.max(0.0),
                coat_roughness: get(m, 15).x.clamp(0.0, 1.0),
                coat_ior: get(m, 16).x.max(1.0),
                coat_tint: get(m, 17).truncate().max(Vec3::ZERO),
                coat_normal: get(m, 18).truncate(),
                sheen_weight: get(m, 19).x.max(0.0),
                sheen_roughness: get(m, 20).x.clamp(0.0, 1.0),
                sheen_tint: get(m, 21).truncate().max(Vec3::ZERO),
                aspect,
                tangent,
                diffuse_roughness: get(m, 22).x.clamp(0.0, 1.0),
                thin_film_thickness: get(m, 23).x.max(0.0),
                thin_film_ior: get(m, 24).x.max(1e-5),
                transparent: false,
                translucent: false,
                refraction: false,
                glass: false,
                holdout: false,
                single_scatter: !multiscatter,
                weight: 1.0,
            };
            // Alpha as Cycles defines it: the BSDF (and its emission) weighted by alpha, a
            // Transparent BSDF by 1 − alpha.
            let alpha = get(m, 4).x.clamp(0.0, 1.0);
            m.closures[o] = if alpha < 1.0 {
                mix_closures(u, alpha, transparent(Vec3::ONE), principled)
            } else {
                principled
            };
        }
        Op::Diffuse => {
            m.closures[o] = Closure {
                base_color: get(m, 0).truncate(),
                roughness: 1.0,
                diffuse_roughness: get(m, 1).x.clamp(0.0, 1.0),
                normal: get(m, 2).truncate(),
                ..Closure::BLACK
            };
        }
        Op::Glossy { multiscatter } => {
            // Cycles' Glossy BSDF: α_x = α (1 − a), α_y = α / (1 − a) for a > 0 (stretched
            // along the bitangent: the tangent turned a quarter), α / (1 + a) and α (1 + a)
            // for a < 0.
            let a = get(m, 3).x.clamp(-0.99, 0.99);
            let (aspect, tangent) = if a.abs() > 1e-4 {
                let n = normal_input(get(m, 2), inputs.normal);
                let t = tangent_input(get(m, 5), inputs, at);
                let turn = get(m, 4).x + if a > 0.0 { 0.25 } else { 0.0 };
                (
                    1.0 - a.abs(),
                    crate::math::rotate_around(t, n, turn * 2.0 * PI),
                )
            } else {
                (1.0, Vec3::ZERO)
            };
            m.closures[o] = Closure {
                base_color: get(m, 0).truncate(),
                metallic: 1.0,
                roughness: get(m, 1).x.clamp(0.0, 1.0),
                normal: get(m, 2).truncate(),
                aspect,
                tangent,
                single_scatter: !multiscatter,
                ..Closure::BLACK
            };
        }
        Op::Sheen => {
            m.closures[o] = Closure {
                sheen_weight: 1.0,
                sheen_tint: get(m, 0).truncate().max(Vec3::ZERO),
                sheen_roughness: get(m, 1).x.clamp(0.0, 1.0),
                normal: get(m, 2).truncate(),
                ..Closure::BLACK
            };
        }
        Op::Glass { .. } | Op::Refraction => {
            m.closures[o] = Closure {
                base_color: get(m, 0).truncate(),
                roughness: get(m, 1).x.clamp(0.0, 1.0),
                ior: get(m, 2).x,
                transmission: 1.0,
                specular: 1.0,
                specular_color: Vec3::ONE,
                normal: get(m, 3).truncate(),
                refraction: matches!(instr.op, Op::Refraction),
                glass: matches!(instr.op, Op::Glass { .. }),
                single_scatter: matches!(
                    instr.op,
                    Op::Glass {
                        multiscatter: false
                    }
                ),
                ..Closure::BLACK
            };
        }
        Op::Emission => {
            m.closures[o] = Closure {
                emission: get(m, 0).truncate() * get(m, 1).x,
                ..Closure::BLACK
            };
        }
        Op::Transparent => m.closures[o] = transparent(get(m, 0).truncate()),
        Op::Holdout => {
            m.closures[o] = Closure {
                holdout: true,
                ..Closure::BLACK
            }
        }
        Op::Translucent => {
            m.closures[o] = Closure {
                base_color: get(m, 0).truncate(),
                roughness: 1.0,
                transmission: 1.0,
                normal: get(m, 1).truncate(),
                translucent: true,
                ..Closure::BLACK
            };
        }
        Op::MixShader => {
            let t = get(m, 0).x.clamp(0.0, 1.0);
            let (a, b) = (closure(m, ins[1]), closure(m, ins[2]));
            m.closures[o] = mix_closures(u, t, a, b);
        }
        Op::AddShader => {
            let (a, b) = (closure(m, ins[0]), closure(m, ins[1]));
            let emission = a.emission + b.emission;
            let a_bsdf = !is_black_bsdf(&a);
            let b_bsdf = !is_black_bsdf(&b);
            let mut picked = match (a_bsdf, b_bsdf) {
                (true, false) => a,
                (false, true) => b,
                _ => {
                    // One of the two with probability ½, doubled: their sum on average, as
                    // Cycles sums closures. A Transparent BSDF carries it in its colour,
                    // which shadow rays read as their tint.
                    let mut one = if *u < 0.5 {
                        *u *= 2.0;
                        a
                    } else {
                        *u = 2.0 * *u - 1.0;
                        b
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
            m.closures[o] = picked;
        }
    }
}

/// The Transparent BSDF tinted by `color`: smooth transmission at IOR 1 (a straight pass).
fn transparent(color: Vec3) -> Closure {
    Closure {
        base_color: color,
        roughness: 0.0,
        ior: 1.0,
        transmission: 1.0,
        transparent: true,
        ..Closure::BLACK
    }
}

/// Mix Shader: `a` with probability 1 − t, else `b` (`u` picks, and is stretched back to
/// [0, 1) for later picks), with their emissions mixed exactly.
fn mix_closures(u: &mut f32, t: f32, a: Closure, b: Closure) -> Closure {
    let emission = a.emission.lerp(b.emission, t);
    let mut picked = if *u < 1.0 - t {
        *u /= (1.0 - t).max(1e-12);
        a
    } else {
        *u = (*u - (1.0 - t)) / t.max(1e-12);
        b
    };
    *u = u.clamp(0.0, 0.999_999_94);
    picked.emission = emission;
    picked
}

fn is_black_bsdf(c: &Closure) -> bool {
    c.base_color == Vec3::ZERO
        && c.specular_color == Vec3::ZERO
        && c.transmission == 0.0
        && (c.sheen_weight == 0.0 || c.sheen_tint == Vec3::ZERO)
        && c.coat_weight == 0.0
}

// ----- node definitions --------------------------------------------------------------------

/// A Normal input: the given vector, or the shading normal when it is unlinked (zero).
fn normal_input(given: Vec4, normal: Vec3) -> Vec3 {
    let g = given.truncate();
    if g == Vec3::ZERO {
        normal
    } else {
        g.normalize_or(normal)
    }
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
fn tangent_input(given: Vec4, inputs: &ShadingInputs, at: &PointInputs) -> Vec3 {
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

/// Cycles' `svm_node_normal_map`: the colour (each channel 0.5 ↦ 0) as a normal in `space`,
/// world space out, blended with the shading normal by `strength`. In tangent space the
/// colour's x, y, z weigh the tangent, the bitangent and the interpolated normal, on the
/// winding's side (turned to the viewer afterwards, as Cycles does).
fn normal_map(
    space: NormalMapSpace,
    color: Vec3,
    strength: f32,
    inputs: &ShadingInputs,
    at: &PointInputs,
) -> Vec3 {
    let c = 2.0 * (color - Vec3::splat(0.5));
    let n = match space {
        NormalMapSpace::Tangent => {
            if at.tangent == Vec4::ZERO {
                return inputs.normal;
            }
            let winding = if inputs.backfacing {
                -inputs.normal
            } else {
                inputs.normal
            };
            let tangent = at.tangent.truncate();
            let bitangent = at.tangent.w * winding.cross(tangent);
            let n = (c.x * tangent + c.y * bitangent + c.z * winding).normalize_or_zero();
            if inputs.backfacing {
                -n
            } else {
                n
            }
        }
        NormalMapSpace::Object => (inputs.object_to_world_normal * c).normalize_or_zero(),
        NormalMapSpace::BlenderObject => {
            (inputs.object_to_world_normal * Vec3::new(c.x, -c.y, -c.z)).normalize_or_zero()
        }
        NormalMapSpace::World => c.normalize_or_zero(),
        NormalMapSpace::BlenderWorld => Vec3::new(c.x, -c.y, -c.z).normalize_or_zero(),
    };
    let n = if strength != 1.0 {
        (inputs.normal + (n - inputs.normal) * strength.max(0.0)).normalize_or_zero()
    } else {
        n
    };
    if n == Vec3::ZERO {
        inputs.normal
    } else {
        n
    }
}

/// Cycles' `fresnel_dielectric_cos`: unpolarised Fresnel reflectance at cosine `cos` for
/// relative IOR `eta` (1 under total internal reflection).
fn fresnel_dielectric_cos(cos: f32, eta: f32) -> f32 {
    let c = cos.abs();
    let g = eta * eta - 1.0 + c * c;
    if g > 0.0 {
        let g = g.sqrt();
        let a = (g - c) / (g + c);
        let b = (c * (g + c) - 1.0) / (c * (g - c) + 1.0);
        0.5 * a * a * (1.0 + b * b)
    } else {
        1.0
    }
}

/// A rotation by Euler angles, as its angles' sines and cosines.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Euler {
    sin: Vec3,
    cos: Vec3,
}

impl Euler {
    fn new(r: Vec3) -> Euler {
        let (sx, cx) = r.x.sin_cos();
        let (sy, cy) = r.y.sin_cos();
        let (sz, cz) = r.z.sin_cos();
        Euler {
            sin: Vec3::new(sx, sy, sz),
            cos: Vec3::new(cx, cy, cz),
        }
    }
}

/// `v` turned about axis `axis` (0 X, 1 Y, 2 Z) by the angle of sine `s` and cosine `c`.
fn turn(v: Vec3, axis: usize, s: f32, c: f32) -> Vec3 {
    match axis {
        0 => Vec3::new(v.x, c * v.y - s * v.z, s * v.y + c * v.z),
        1 => Vec3::new(c * v.x + s * v.z, v.y, -s * v.x + c * v.z),
        _ => Vec3::new(c * v.x - s * v.y, s * v.x + c * v.y, v.z),
    }
}

/// Blender's Euler XYZ rotation (X first, then Y, then Z).
fn euler_xyz(r: &Euler, v: Vec3) -> Vec3 {
    (0..3).fold(v, |v, k| turn(v, k, r.sin[k], r.cos[k]))
}

/// The inverse of `euler_xyz`.
fn euler_xyz_inverse(r: &Euler, v: Vec3) -> Vec3 {
    (0..3).rev().fold(v, |v, k| turn(v, k, -r.sin[k], r.cos[k]))
}

fn safe_divide3(a: Vec3, b: Vec3) -> Vec3 {
    let d = |x: f32, y: f32| if y != 0.0 { x / y } else { 0.0 };
    Vec3::new(d(a.x, b.x), d(a.y, b.y), d(a.z, b.z))
}

/// The Mapping node (Cycles' `svm_mapping`).
fn mapping(kind: MappingKind, v: Vec3, loc: Vec3, rot: &Euler, scale: Vec3) -> Vec3 {
    match kind {
        MappingKind::Point => euler_xyz(rot, v * scale) + loc,
        MappingKind::Texture => safe_divide3(euler_xyz_inverse(rot, v - loc), scale),
        MappingKind::Vector => euler_xyz(rot, v * scale),
        MappingKind::Normal => euler_xyz(rot, safe_divide3(v, scale)).normalize_or_zero(),
    }
}

/// Blender's Math node, with its safe definitions (division by zero gives 0, and so on).
fn math(op: MathOp, a: f32, b: f32, c: f32) -> f32 {
    use MathOp::*;
    let safe_div = |x: f32, y: f32| if y != 0.0 { x / y } else { 0.0 };
    let safe_mod = |x: f32, y: f32| if y != 0.0 { x % y } else { 0.0 };
    let floored_mod = |x: f32, y: f32| {
        if y != 0.0 {
            x - (x / y).floor() * y
        } else {
            0.0
        }
    };
    let smoothmin = |a: f32, b: f32, c: f32| {
        if c != 0.0 {
            let h = (c - (a - b).abs()).max(0.0) / c;
            a.min(b) - h * h * h * c * (1.0 / 6.0)
        } else {
            a.min(b)
        }
    };
    let wrap = |v: f32, max: f32, min: f32| {
        let range = max - min;
        if range != 0.0 {
            v - range * ((v - min) / range).floor()
        } else {
            min
        }
    };
    match op {
        Add => a + b,
        Subtract => a - b,
        Multiply => a * b,
        Divide => safe_div(a, b),
        MultiplyAdd => a * b + c,
        Power => {
            if a >= 0.0 {
                a.powf(b)
            } else {
                let fraction = b % 1.0;
                if !(0.001..=0.999).contains(&fraction) {
                    let r = a.abs().powf(b.round());
                    if (b.round() as i64) % 2 != 0 {
                        -r
                    } else {
                        r
                    }
                } else {
                    0.0
                }
            }
        }
        Logarithm => {
            if a > 0.0 && b > 0.0 {
                safe_div(a.ln(), b.ln())
            } else {
                0.0
            }
        }
        Sqrt => {
            if a > 0.0 {
                a.sqrt()
            } else {
                0.0
            }
        }
        InverseSqrt => {
            if a > 0.0 {
                1.0 / a.sqrt()
            } else {
                0.0
            }
        }
        Absolute => a.abs(),
        Exponent => a.exp(),
        Minimum => a.min(b),
        Maximum => a.max(b),
        LessThan => (a < b) as u8 as f32,
        GreaterThan => (a > b) as u8 as f32,
        Sign => {
            if a > 0.0 {
                1.0
            } else if a < 0.0 {
                -1.0
            } else {
                0.0
            }
        }
        Compare => ((a - b).abs() <= c.max(1e-5)) as u8 as f32,
        SmoothMin => smoothmin(a, b, c),
        SmoothMax => -smoothmin(-a, -b, c),
        Round => (a + 0.5).floor(),
        Floor => a.floor(),
        Ceil => a.ceil(),
        Trunc => a.trunc(),
        Fraction => a - a.floor(),
        Modulo => safe_mod(a, b),
        FlooredModulo => floored_mod(a, b),
        Wrap => wrap(a, b, c),
        Snap => {
            if b != 0.0 {
                (a / b).floor() * b
            } else {
                0.0
            }
        }
        PingPong => {
            if b != 0.0 {
                (floored_mod(a - b, 2.0 * b) - b).abs()
            } else {
                0.0
            }
        }
        Sine => a.sin(),
        Cosine => a.cos(),
        Tangent => a.tan(),
        Arcsine => {
            if (-1.0..=1.0).contains(&a) {
                a.asin()
            } else {
                0.0
            }
        }
        Arccosine => {
            if (-1.0..=1.0).contains(&a) {
                a.acos()
            } else {
                0.0
            }
        }
        Arctangent => a.atan(),
        Arctan2 => a.atan2(b),
        Sinh => a.sinh(),
        Cosh => a.cosh(),
        Tanh => a.tanh(),
        Radians => a * (PI / 180.0),
        Degrees => a * (180.0 / PI),
    }
}

fn rgb_to_hsv(c: Vec3) -> Vec3 {
    let cmax = c.max_element();
    let cmin = c.min_element();
    let delta = cmax - cmin;
    let v = cmax;
    let s = if cmax != 0.0 { delta / cmax } else { 0.0 };
    if s == 0.0 {
        return Vec3::new(0.0, 0.0, v);
    }
    let cv = (Vec3::splat(cmax) - c) / delta;
    let h = if c.x == cmax {
        cv.z - cv.y
    } else if c.y == cmax {
        2.0 + cv.x - cv.z
    } else {
        4.0 + cv.y - cv.x
    };
    let mut h = h / 6.0;
    if h < 0.0 {
        h += 1.0;
    }
    Vec3::new(h, s, v)
}

fn hsv_to_rgb(hsv: Vec3) -> Vec3 {
    let (mut h, s, v) = (hsv.x, hsv.y, hsv.z);
    if s == 0.0 {
        return Vec3::splat(v);
    }
    if h == 1.0 {
        h = 0.0;
    }
    h *= 6.0;
    let i = h.floor();
    let f = h - i;
    let p = v * (1.0 - s);
    let q = v * (1.0 - s * f);
    let t = v * (1.0 - s * (1.0 - f));
    match i as i32 {
        0 => Vec3::new(v, t, p),
        1 => Vec3::new(q, v, p),
        2 => Vec3::new(p, v, t),
        3 => Vec3::new(p, q, v),
        4 => Vec3::new(t, p, v),
        _ => Vec3::new(v, p, q),
    }
}

/// The Mix node's colour blend modes (Cycles' `svm_mix`, Blender's `ramp_blend`).
fn mix_color(blend: Blend, t: f32, a: Vec3, b: Vec3) -> Vec3 {
    use Blend::*;
    let tm = 1.0 - t;
    let per = |f: &dyn Fn(f32, f32) -> f32| Vec3::new(f(a.x, b.x), f(a.y, b.y), f(a.z, b.z));
    match blend {
        Mix => a.lerp(b, t),
        Add => a + t * b,
        Multiply => a * (Vec3::splat(tm) + t * b),
        Subtract => a - t * b,
        Screen => Vec3::ONE - (Vec3::splat(tm) + t * (Vec3::ONE - b)) * (Vec3::ONE - a),
        Divide => per(&|x, y| if y != 0.0 { tm * x + t * x / y } else { x }),
        Difference => a.lerp((a - b).abs(), t),
        Exclusion => a.lerp(a + b - 2.0 * a * b, t).max(Vec3::ZERO),
        Darken => a.lerp(a.min(b), t),
        Lighten => a.lerp(a.max(b), t),
        Overlay => per(&|x, y| {
            if x < 0.5 {
                x * (tm + 2.0 * t * y)
            } else {
                1.0 - (tm + 2.0 * t * (1.0 - y)) * (1.0 - x)
            }
        }),
        Dodge => per(&|x, y| {
            if x != 0.0 {
                let tmp = 1.0 - t * y;
                if tmp <= 0.0 {
                    1.0
                } else {
                    let r = x / tmp;
                    if r > 1.0 {
                        1.0
                    } else {
                        r
                    }
                }
            } else {
                x
            }
        }),
        Burn => per(&|x, y| {
            let tmp = tm + t * y;
            if tmp <= 0.0 {
                0.0
            } else {
                let r = 1.0 - (1.0 - x) / tmp;
                r.clamp(0.0, 1.0)
            }
        }),
        Hue => {
            let hb = rgb_to_hsv(b);
            if hb.y != 0.0 {
                let ha = rgb_to_hsv(a);
                let c = hsv_to_rgb(Vec3::new(hb.x, ha.y, ha.z));
                a.lerp(c, t)
            } else {
                a
            }
        }
        Saturation => {
            let ha = rgb_to_hsv(a);
            if ha.y != 0.0 {
                let hb = rgb_to_hsv(b);
                hsv_to_rgb(Vec3::new(ha.x, tm * ha.y + t * hb.y, ha.z))
            } else {
                a
            }
        }
        Value => {
            let ha = rgb_to_hsv(a);
            let hb = rgb_to_hsv(b);
            hsv_to_rgb(Vec3::new(ha.x, ha.y, tm * ha.z + t * hb.z))
        }
        Color => {
            let hb = rgb_to_hsv(b);
            if hb.y != 0.0 {
                let ha = rgb_to_hsv(a);
                let c = hsv_to_rgb(Vec3::new(hb.x, hb.y, ha.z));
                a.lerp(c, t)
            } else {
                a
            }
        }
        SoftLight => {
            let scr = Vec3::ONE - (Vec3::ONE - b) * (Vec3::ONE - a);
            tm * a + t * ((Vec3::ONE - a) * b * a + a * scr)
        }
        LinearLight => a + t * (2.0 * b - Vec3::ONE),
    }
}

/// Cycles' `rgb_ramp_lookup` over the baked table (linear interpolation between entries, or
/// the entry below for Constant).
fn ramp_lookup(table: &[Vec4], fac: f32, interpolate: bool) -> Vec4 {
    let n = table.len();
    let fac = if fac.is_finite() {
        fac.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let x = fac * (n - 1) as f32;
    let i = (x as usize).min(n - 1);
    let t = x - i as f32;
    if interpolate && t > 0.0 && i + 1 < n {
        table[i] * (1.0 - t) + table[i + 1] * t
    } else {
        table[i]
    }
}

/// `ramp_lookup` with Cycles' linear extrapolation beyond [0, 1] (curves).
fn ramp_extrapolated(table: &[Vec4], f: f32) -> Vec4 {
    let n = table.len();
    if f < 0.0 {
        table[0] + (table[0] - table[1]) * (-f * (n - 1) as f32)
    } else if f > 1.0 {
        table[n - 1] + (table[n - 1] - table[n - 2]) * ((f - 1.0) * (n - 1) as f32)
    } else {
        ramp_lookup(table, f, true)
    }
}

fn smoothstep(edge0: f32, edge1: f32, x: f32) -> f32 {
    if edge0 == edge1 {
        return if x < edge0 { 0.0 } else { 1.0 };
    }
    let t = ((x - edge0) / (edge1 - edge0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// The Map Range node (float), Cycles' `svm_node_map_range`.
#[allow(clippy::too_many_arguments)]
fn map_range(
    kind: MapRangeKind,
    clamp: bool,
    value: f32,
    from_min: f32,
    from_max: f32,
    to_min: f32,
    to_max: f32,
    steps: f32,
) -> f32 {
    if from_max == from_min {
        return 0.0;
    }
    let factor = match kind {
        MapRangeKind::Linear => (value - from_min) / (from_max - from_min),
        MapRangeKind::Stepped => {
            let f = (value - from_min) / (from_max - from_min);
            if steps > 0.0 {
                (f * (steps + 1.0)).floor() / steps
            } else {
                0.0
            }
        }
        MapRangeKind::Smoothstep => {
            if from_min > from_max {
                1.0 - smoothstep(from_max, from_min, value)
            } else {
                smoothstep(from_min, from_max, value)
            }
        }
        MapRangeKind::Smootherstep => {
            if from_min > from_max {
                1.0 - smootherstep(from_max, from_min, value)
            } else {
                smootherstep(from_min, from_max, value)
            }
        }
    };
    let r = to_min + factor * (to_max - to_min);
    if clamp && matches!(kind, MapRangeKind::Linear | MapRangeKind::Stepped) {
        if to_min > to_max {
            r.clamp(to_max, to_min)
        } else {
            r.clamp(to_min, to_max)
        }
    } else {
        r
    }
}

fn smootherstep(edge0: f32, edge1: f32, x: f32) -> f32 {
    let t = ((x - edge0) / (edge1 - edge0)).clamp(0.0, 1.0);
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

/// Cycles' `svm_checker`: 1 on the cells of Color1, 0 on those of Color2.
pub fn checker(p: Vec3) -> f32 {
    let p = (p + Vec3::splat(0.000_001)) * 0.999_999;
    let xi = (p.x.floor() as i32).abs();
    let yi = (p.y.floor() as i32).abs();
    let zi = (p.z.floor() as i32).abs();
    if (xi % 2 == yi % 2) == (zi % 2 == 1) {
        1.0
    } else {
        0.0
    }
}

/// Cycles' `svm_gradient`, clamped to [0, 1].
fn gradient(kind: GradientKind, p: Vec3) -> f32 {
    let (x, y, z) = (p.x, p.y, p.z);
    let r = match kind {
        GradientKind::Linear => x,
        GradientKind::Quadratic => {
            let r = x.max(0.0);
            r * r
        }
        GradientKind::Easing => {
            let r = x.clamp(0.0, 1.0);
            let t = r * r;
            3.0 * t - 2.0 * t * r
        }
        GradientKind::Diagonal => (x + y) * 0.5,
        GradientKind::Radial => y.atan2(x) / (2.0 * PI) + 0.5,
        GradientKind::QuadraticSphere => {
            let r = (0.999_999 - (x * x + y * y + z * z).sqrt()).max(0.0);
            r * r
        }
        GradientKind::Spherical => (0.999_999 - (x * x + y * y + z * z).sqrt()).max(0.0),
    };
    r.clamp(0.0, 1.0)
}

// ----- Perlin noise as Blender defines it ----------------------------------------------------

/// Jenkins' lookup3 `final` mix of (a, b, c), returning c.
#[inline(always)]
fn lookup3_final(a: u32, b: u32, c: u32) -> u32 {
    node_hash::finish(W(a), W(b), W(c)).0
}

const LOOKUP3_SEED: u32 = 0xdead_beef;

fn hash1(x: u32) -> u32 {
    let s = LOOKUP3_SEED.wrapping_add((1 << 2) + 13);
    lookup3_final(s.wrapping_add(x), s, s)
}

fn hash2(x: u32, y: u32) -> u32 {
    let s = LOOKUP3_SEED.wrapping_add((2 << 2) + 13);
    lookup3_final(s.wrapping_add(x), s.wrapping_add(y), s)
}

fn hash3(x: u32, y: u32, z: u32) -> u32 {
    let s = LOOKUP3_SEED.wrapping_add((3 << 2) + 13);
    lookup3_final(s.wrapping_add(x), s.wrapping_add(y), s.wrapping_add(z))
}

/// `hash_float2_to_float`: the hash of two floats' bits mapped to [0, 1].
fn hash_float2(x: f32, y: f32) -> f32 {
    hash2(x.to_bits(), y.to_bits()) as f32 * (1.0 / 4_294_967_295.0)
}

fn hash_float(x: f32) -> f32 {
    hash1(x.to_bits()) as f32 * (1.0 / 4_294_967_295.0)
}

fn fade(t: f32) -> f32 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

fn negate_if(v: f32, condition: u32) -> f32 {
    if condition != 0 {
        -v
    } else {
        v
    }
}

/// `a` when `c`, else `b`, without a branch (the gradient picks are unpredictable).
fn select(c: bool, a: f32, b: f32) -> f32 {
    let mask = (c as u32).wrapping_neg();
    f32::from_bits((a.to_bits() & mask) | (b.to_bits() & !mask))
}

/// −v when `bit` (0 or 1) is 1, without a branch: a flip of the sign bit, as negation is.
fn flip_sign(v: f32, bit: u32) -> f32 {
    f32::from_bits(v.to_bits() ^ (bit << 31))
}

fn floorfrac(x: f32) -> (i32, f32) {
    let f = floor(x);
    (f as i32, x - f)
}

/// `x.floor()` without the library call baseline x86-64 makes for it (bit for bit the same,
/// −0 and NaN included): beyond 2²³ every float is an integer.
fn floor(x: f32) -> f32 {
    if !(x.abs() < 8_388_608.0) {
        return x;
    }
    let t = x as i32 as f32;
    if t > x {
        t - 1.0
    } else if t < x {
        t
    } else {
        x
    }
}

fn grad1(hash: u32, x: f32) -> f32 {
    let h = hash & 15;
    let g = 1.0 + (h & 7) as f32;
    negate_if(g, h & 8) * x
}

fn grad2(hash: u32, x: f32, y: f32) -> f32 {
    let h = hash & 7;
    let first = h < 4;
    let (u, v) = (select(first, x, y), select(first, 2.0 * y, 2.0 * x));
    flip_sign(u, h & 1) + flip_sign(v, (h >> 1) & 1)
}

/// For each lattice corner (index dx + 2 dy + 4 dz) and hash `h & 15`, where Perlin's gradient's two
/// components are in a cell's offsets `[fx, fy, fz, fx − 1, fy − 1, fz − 1]`: a table read
/// instead of three selects per corner.
const GRAD3_PICKS: [[[u8; 2]; 16]; 8] = {
    let mut picks = [[[0; 2]; 16]; 8];
    let mut corner = 0;
    while corner < 8 {
        let step = [corner & 1, (corner >> 1) & 1, corner >> 2];
        let mut h = 0;
        while h < 16 {
            let [u, v] = node_hash::GRAD3_AXES[h];
            picks[corner][h] = [(u + 3 * step[u]) as u8, (v + 3 * step[v]) as u8];
            h += 1;
        }
        corner += 1;
    }
    picks
};

fn lerp(a: f32, b: f32, t: f32) -> f32 {
    (1.0 - t) * a + t * b
}

fn perlin1(x: f32) -> f32 {
    let (xi, fx) = floorfrac(x);
    let u = fade(fx);
    lerp(
        grad1(hash1(xi as u32), fx),
        grad1(hash1(xi.wrapping_add(1) as u32), fx - 1.0),
        u,
    )
}

fn perlin2(x: f32, y: f32) -> f32 {
    let (xi, fx) = floorfrac(x);
    let (yi, fy) = floorfrac(y);
    let (u, v) = (fade(fx), fade(fy));
    let h = |dx: i32, dy: i32| hash2(xi.wrapping_add(dx) as u32, yi.wrapping_add(dy) as u32);
    let v0 = grad2(h(0, 0), fx, fy);
    let v1 = grad2(h(1, 0), fx - 1.0, fy);
    let v2 = grad2(h(0, 1), fx, fy - 1.0);
    let v3 = grad2(h(1, 1), fx - 1.0, fy - 1.0);
    let x1 = 1.0 - u;
    (1.0 - v) * (v0 * x1 + v1 * u) + v * (v2 * x1 + v3 * u)
}

/// `hash3` of a lattice cell's eight corners (index dx + 2 dy + 4 dz), four at a time
/// (`node_hash::U32x4`): the near face's corners (dz = 0), then the far face's.
fn corner_hashes(xi: i32, yi: i32, zi: i32) -> [U32x4; 2] {
    let s = LOOKUP3_SEED.wrapping_add((3 << 2) + 13);
    let (x0, y0, z0) = (xi as u32, yi as u32, zi as u32);
    let a = U32x4::new([x0, x0.wrapping_add(1), x0, x0.wrapping_add(1)]);
    let b = U32x4::new([y0, y0, y0.wrapping_add(1), y0.wrapping_add(1)]);
    let (a, b) = (a + U32x4::splat(s), b + U32x4::splat(s));
    let near = node_hash::finish(a, b, U32x4::splat(s.wrapping_add(z0)));
    let far = node_hash::finish(a, b, U32x4::splat(s.wrapping_add(z0).wrapping_add(1)));
    [near, far]
}

fn perlin3(x: f32, y: f32, z: f32) -> f32 {
    let (xi, fx) = floorfrac(x);
    let (yi, fy) = floorfrac(y);
    let (zi, fz) = floorfrac(z);
    let (u, v, w) = (fade(fx), fade(fy), fade(fz));
    let [near, far] = corner_hashes(xi, yi, zi);
    // A face's four corners as lanes (dx + 2 dy), each lane the scalar code's operations:
    // z1 · (y1 · (g000 · x1 + g100 · u) + v · (g010 · x1 + g110 · u)) + w · (same, far face).
    let (gx, gy) = (fx - 1.0, fy - 1.0);
    let (xs, ys) = (Vec4::new(fx, gx, fx, gx), Vec4::new(fy, fy, gy, gy));
    let (x1, y1, z1) = (1.0 - u, 1.0 - v, 1.0 - w);
    let along_x = Vec4::new(x1, u, x1, u);
    let n = near.grad3(xs, ys, Vec4::splat(fz)) * along_x;
    let f = far.grad3(xs, ys, Vec4::splat(fz - 1.0)) * along_x;
    let rows = Vec4::new(n.x, n.z, f.x, f.z) + Vec4::new(n.y, n.w, f.y, f.w);
    let faces = rows * Vec4::new(y1, v, y1, v);
    z1 * (faces.x + faces.y) + w * (faces.z + faces.w)
}

/// Signed noise in about [−1, 1], repeating every 100000 (Cycles' `snoise_*d`: each
/// coordinate taken modulo the period, plus ½ where it was at least 10⁶).
fn snoise(dimensions: u8, p: Vec3, w: f32) -> f32 {
    // fmod is the identity below the period (and a library call).
    let m = |x: f32| {
        if x.abs() < 100_000.0 {
            x
        } else if x.abs() < 1_000_000.0 {
            x % 100_000.0
        } else {
            x % 100_000.0 + 0.5
        }
    };
    match dimensions {
        1 => 0.25 * perlin1(m(w)),
        2 => 0.6616 * perlin2(m(p.x), m(p.y)),
        _ => 0.9820 * perlin3_fast(m(p.x), m(p.y), m(p.z)),
    }
}

/// Whether this machine has AVX2, for the eight-lane noise and Voronoi kernels (the
/// detection is cached by the standard library).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn has_avx2() -> bool {
    std::arch::is_x86_feature_detected!("avx2")
}

/// `perlin3`, its eight corners as the lanes of one AVX2 register where the machine has it
/// (`noise_avx2::perlin3`, the same value bit for bit); NaN coordinates take `perlin3`.
#[inline(always)]
fn perlin3_fast(x: f32, y: f32, z: f32) -> f32 {
    #[cfg(target_arch = "x86_64")]
    if has_avx2() && !(x.is_nan() || y.is_nan() || z.is_nan()) {
        // SAFETY: AVX2 is present (checked above).
        return unsafe { noise_avx2::perlin3(x, y, z) };
    }
    perlin3(x, y, z)
}

#[derive(Clone, Copy, PartialEq)]
struct Fractal {
    detail: f32,
    roughness: f32,
    lacunarity: f32,
    normalize: bool,
}

/// Cycles' `noise_fbm`.
fn fbm(dimensions: u8, p: Vec3, w: f32, f: &Fractal) -> f32 {
    #[cfg(target_arch = "x86_64")]
    if dimensions == 3 && has_avx2() {
        // SAFETY: AVX2 is present (checked above).
        return unsafe { noise_avx2::fbm3(p, f) };
    }
    fractal_sum(f, 0.0, |scale| snoise(dimensions, scale * p, scale * w))
}

/// `noise_fbm`'s sum of octaves of `noise` (called with each octave's scale), for one point
/// or several as lanes.
fn fractal_sum<T>(f: &Fractal, zero: T, noise: impl Fn(f32) -> T) -> T
where
    T: Copy + Add<Output = T> + Add<f32, Output = T> + Mul<f32, Output = T> + Div<f32, Output = T>,
{
    let mut fscale = 1.0f32;
    let mut amp = 1.0f32;
    let mut maxamp = 0.0f32;
    let mut sum = zero;
    let octaves = f.detail as i32;
    for _ in 0..=octaves {
        sum = sum + noise(fscale) * amp;
        maxamp += amp;
        amp *= f.roughness;
        fscale *= f.lacunarity;
    }
    let lerp = |a: T, b: T, t: f32| a * (1.0 - t) + b * t;
    let rmd = f.detail - f.detail.floor();
    if rmd != 0.0 {
        let sum2 = sum + noise(fscale) * amp;
        if f.normalize {
            lerp(
                sum * 0.5 / maxamp + 0.5,
                sum2 * 0.5 / (maxamp + amp) + 0.5,
                rmd,
            )
        } else {
            lerp(sum, sum2, rmd)
        }
    } else if f.normalize {
        sum * 0.5 / maxamp + 0.5
    } else {
        sum
    }
}

/// Cycles' random offsets that seed the distortion and colour channels.
fn offset(dimensions: u8, seed: f32) -> (Vec3, f32) {
    if dimensions == 1 {
        return (Vec3::ZERO, 100.0 + hash_float(seed) * 100.0);
    }
    let c = |k: f32| 100.0 + hash_float2(seed, k) * 100.0;
    (Vec3::new(c(0.0), c(1.0), c(2.0)), 0.0)
}

/// The Noise Texture (FBM type): its Fac and Color outputs.
/// Without `color` the Color output is not computed (grey).
fn noise_texture(
    dimensions: u8,
    p: Vec3,
    w: f32,
    f: &Fractal,
    distortion: f32,
    color: bool,
) -> (f32, Vec3) {
    let (mut p, mut w) = (p, w);
    let masked = |v: Vec3| match dimensions {
        2 => Vec3::new(v.x, v.y, 0.0),
        _ => v,
    };
    p = masked(p);
    if distortion != 0.0 {
        match dimensions {
            1 => w += snoise(1, p, w + offset(1, 0.0).1) * distortion,
            _ => {
                let mut d = Vec3::ZERO;
                for (k, seed) in [0.0f32, 1.0, 2.0]
                    .iter()
                    .enumerate()
                    .take(dimensions as usize)
                {
                    d[k] =
                        snoise(dimensions, p + masked(offset(dimensions, *seed).0), w) * distortion;
                }
                p += d;
            }
        }
    }
    let value = fbm(dimensions, p, w, f);
    if !color {
        return (value, Vec3::splat(value));
    }
    let (s1, s2) = match dimensions {
        1 => (1.0, 2.0),
        2 => (2.0, 3.0),
        _ => (3.0, 4.0),
    };
    let shifted = |seed: f32| {
        let (o, ow) = offset(dimensions, seed);
        fbm(dimensions, p + masked(o), w + ow, f)
    };
    (value, Vec3::new(value, shifted(s1), shifted(s2)))
}

// ----- the same noise at a Bump's three points at once ---------------------------------------
//
// A Bump reads its height at the shading point and a small step along each tangent: three
// points that nearly always lie in the same lattice cell of every octave. There the eight
// corner hashes are computed once and the three points' gradients and interpolation run as
// lanes of one vector, each lane the very operations of `perlin3` in the same order (no fused
// multiply-add), so the values are the scalar code's bit for bit; points in different cells,
// far coordinates and other dimensions take the scalar code.

/// Three points' coordinates as lanes (the fourth repeats the first).
fn lanes(v: [f32; 3]) -> Vec4 {
    Vec4::new(v[0], v[1], v[2], v[0])
}

#[inline(always)]
fn fade4(t: Vec4) -> Vec4 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

/// `grad3` for one hash over lanes of points: the hash picks the same components and signs
/// in every lane (a sign is flipped by multiplying by −1, which is exact).
#[inline(always)]
fn grad3_lanes(hash: u32, corner: usize, offsets: &[Vec4; 6]) -> Vec4 {
    let h = hash & 15;
    let [u, v] = GRAD3_PICKS[corner][h as usize];
    let [su, sv] = GRAD3_SIGNS[h as usize];
    offsets[u as usize] * su + offsets[v as usize] * sv
}

/// The signs of `grad3`'s two components for hash `h & 15`: hash bits 0 and 1.
const GRAD3_SIGNS: [[f32; 2]; 16] = {
    let mut signs = [[1.0; 2]; 16];
    let mut h = 0;
    while h < 16 {
        signs[h] = [
            if h & 1 != 0 { -1.0 } else { 1.0 },
            if h & 2 != 0 { -1.0 } else { 1.0 },
        ];
        h += 1;
    }
    signs
};

/// `floor` lane by lane for |v| < 2²² (the same values, −0 included): adding and taking
/// away 1.5 · 2²³ rounds to an integer.
#[inline(always)]
fn floor4(v: Vec4) -> Vec4 {
    const ROUND: f32 = 12_582_912.0;
    let t = (v + ROUND) - ROUND;
    Vec4::select(t.cmpgt(v), t - 1.0, Vec4::select(t.cmplt(v), t, v))
}

/// `0.9820 * perlin3` (`snoise` in 3D) of three points given as lanes.
fn snoise3_lanes(x: Vec4, y: Vec4, z: Vec4) -> Vec4 {
    let near = |v: Vec4| v.abs().cmplt(Vec4::splat(100_000.0)).all();
    let (cx, cy, cz) = (floor4(x), floor4(y), floor4(z));
    let one_cell = |c: Vec4| c.cmpeq(Vec4::splat(c.x)).all();
    if !(near(x) && near(y) && near(z) && one_cell(cx) && one_cell(cy) && one_cell(cz)) {
        let (xs, ys, zs) = (x.to_array(), y.to_array(), z.to_array());
        let n = |k: usize| snoise(3, Vec3::new(xs[k], ys[k], zs[k]), 0.0);
        return lanes([n(0), n(1), n(2)]);
    }
    let [near, far] = corner_hashes(cx.x as i32, cy.x as i32, cz.x as i32);
    let (near, far) = (near.to_array(), far.to_array());
    let h = [
        near[0], near[1], near[2], near[3], far[0], far[1], far[2], far[3],
    ];
    let (fx, fy, fz) = (x - cx, y - cy, z - cz);
    let (u, v, w) = (fade4(fx), fade4(fy), fade4(fz));
    let offsets = [fx, fy, fz, fx - 1.0, fy - 1.0, fz - 1.0];
    let g = |corner: usize| grad3_lanes(h[corner], corner, &offsets);
    let (g000, g100, g010, g110) = (g(0), g(1), g(2), g(3));
    let (g001, g101, g011, g111) = (g(4), g(5), g(6), g(7));
    let (x1, y1, z1) = (Vec4::ONE - u, Vec4::ONE - v, Vec4::ONE - w);
    let p = z1 * (y1 * (g000 * x1 + g100 * u) + v * (g010 * x1 + g110 * u))
        + w * (y1 * (g001 * x1 + g101 * u) + v * (g011 * x1 + g111 * u));
    0.9820 * p
}

/// `fbm` in 3D of three points given as lanes (with AVX2 `noise_avx2::fbm3_lanes`).
fn fbm3_lanes(x: Vec4, y: Vec4, z: Vec4, f: &Fractal) -> Vec4 {
    #[cfg(target_arch = "x86_64")]
    if has_avx2() {
        // SAFETY: AVX2 is present (checked above).
        return unsafe { noise_avx2::fbm3_lanes(x, y, z, f) };
    }
    fractal_sum(f, Vec4::ZERO, |s| snoise3_lanes(s * x, s * y, s * z))
}

/// Perlin noise on AVX2 (x86-64 machines that have it; the callers check): the operations of
/// `perlin3` and `snoise3_lanes`, lane by lane in the same order (no fused multiply-add), so
/// the values are theirs bit for bit.
#[cfg(target_arch = "x86_64")]
mod noise_avx2 {
    use crate::math::{Vec3, Vec4};
    use crate::scene::node_hash::avx2 as hash;
    use crate::scene::nodes::{fractal_sum, snoise, snoise3_lanes, Fractal, LOOKUP3_SEED};
    use std::arch::x86_64::*;

    const SEED3: i32 = LOOKUP3_SEED.wrapping_add((3 << 2) + 13) as i32;

    /// `super::fbm` in 3D, its octaves' noise inlined.
    #[target_feature(enable = "avx2")]
    pub fn fbm3(p: Vec3, f: &Fractal) -> f32 {
        fractal_sum(f, 0.0, |scale| {
            let q = scale * p;
            // `snoise` in 3D, whose coordinates' fmod is the identity below the period.
            let below = |v: f32| v.abs() < 100_000.0;
            if below(q.x) && below(q.y) && below(q.z) {
                0.9820 * perlin3(q.x, q.y, q.z)
            } else {
                snoise(3, q, 0.0)
            }
        })
    }

    /// `super::fbm3_lanes`, the octaves evaluated two at a time (`snoise3_pair`):
    /// `fractal_sum` calls for scales s, s · lacunarity, .. in turn, so a call computes its
    /// octave and the next (the very scale `fractal_sum` passes next), which the next call
    /// returns.
    #[target_feature(enable = "avx2")]
    pub fn fbm3_lanes(x: Vec4, y: Vec4, z: Vec4, f: &Fractal) -> Vec4 {
        let mut pending = None;
        let pending = std::cell::Cell::from_mut(&mut pending);
        // How many times `fractal_sum` calls: the last of an odd number is one octave alone
        // (`snoise3_one`). (Were this count off, the values would be the same.)
        let calls = (f.detail as i32 + 1).max(0) + (f.detail - f.detail.floor() != 0.0) as i32;
        let mut call = 0;
        let call = std::cell::Cell::from_mut(&mut call);
        fractal_sum(f, Vec4::ZERO, |s| {
            call.set(call.get() + 1);
            if let Some(v) = pending.take() {
                return v;
            }
            if call.get() == calls {
                return snoise3_one(s * x, s * y, s * z);
            }
            let t = s * f.lacunarity;
            let [a, b] = snoise3_pair([s * x, t * x], [s * y, t * y], [s * z, t * z]);
            pending.set(Some(b));
            a
        })
    }

    /// `fade` lane by lane.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn fade(t: __m256) -> __m256 {
        let s = _mm256_set1_ps;
        let tt = _mm256_mul_ps(_mm256_mul_ps(t, t), t);
        let inner = _mm256_sub_ps(_mm256_mul_ps(t, s(6.0)), s(15.0));
        _mm256_mul_ps(tt, _mm256_add_ps(_mm256_mul_ps(t, inner), s(10.0)))
    }

    /// Cycles' `grad3` of each lane's hash at that lane's offset (x, y, z), as
    /// `U32x4::grad3`: selects and a flip of the sign bit.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn grad3(h: __m256i, x: __m256, y: __m256, z: __m256) -> __m256 {
        let k = _mm256_set1_epi32;
        let h = _mm256_and_si256(h, k(15));
        let below8 = _mm256_castsi256_ps(_mm256_cmpgt_epi32(k(8), h));
        let below4 = _mm256_castsi256_ps(_mm256_cmpgt_epi32(k(4), h));
        let v_is_x = _mm256_castsi256_ps(_mm256_or_si256(
            _mm256_cmpeq_epi32(h, k(12)),
            _mm256_cmpeq_epi32(h, k(14)),
        ));
        let u = _mm256_blendv_ps(y, x, below8);
        let v = _mm256_blendv_ps(_mm256_blendv_ps(z, x, v_is_x), y, below4);
        let sign_u = _mm256_castsi256_ps(_mm256_slli_epi32::<31>(_mm256_and_si256(h, k(1))));
        let sign_v = _mm256_castsi256_ps(_mm256_slli_epi32::<30>(_mm256_and_si256(h, k(2))));
        _mm256_add_ps(_mm256_xor_ps(u, sign_u), _mm256_xor_ps(v, sign_v))
    }

    /// Lane `K` (0x00, 0x55, 0xAA: lane 0, 1, 2) of `v` in all eight lanes.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn lane<const K: i32>(v: __m128) -> __m256 {
        _mm256_broadcastss_ps(_mm_permute_ps::<K>(v))
    }

    /// `super::perlin3` at one point (coordinates not NaN): its eight lattice corners
    /// (dx + 2 dy + 4 dz) as lanes; the two pairwise sums of the interpolation are
    /// horizontal adds (a + b is b + a bit for bit).
    #[target_feature(enable = "avx2")]
    #[inline]
    pub fn perlin3(x: f32, y: f32, z: f32) -> f32 {
        let p = _mm_set_ps(0.0, z, y, x);
        let cell = _mm_floor_ps(p);
        let f = _mm_sub_ps(p, cell);
        let g = _mm_sub_ps(f, _mm_set1_ps(1.0));
        let t = fade(_mm256_castps128_ps256(f));
        let fade3 = _mm256_castps256_ps128(t);
        let rest = _mm_sub_ps(_mm_set1_ps(1.0), fade3);
        let c = _mm_add_epi32(_mm_cvttps_epi32(cell), _mm_set1_epi32(SEED3));
        let a = _mm256_add_epi32(
            _mm256_broadcastd_epi32(c),
            _mm256_setr_epi32(0, 1, 0, 1, 0, 1, 0, 1),
        );
        let b = _mm256_add_epi32(
            _mm256_broadcastd_epi32(_mm_shuffle_epi32::<0x55>(c)),
            _mm256_setr_epi32(0, 0, 1, 1, 0, 0, 1, 1),
        );
        let c = _mm256_add_epi32(
            _mm256_broadcastd_epi32(_mm_shuffle_epi32::<0xAA>(c)),
            _mm256_setr_epi32(0, 0, 0, 0, 1, 1, 1, 1),
        );
        // SAFETY: this function runs only with AVX2.
        let h = unsafe { hash::finish(a, b, c) };
        let xs = _mm256_blend_ps::<0xAA>(lane::<0x00>(f), lane::<0x00>(g));
        let ys = _mm256_blend_ps::<0xCC>(lane::<0x55>(f), lane::<0x55>(g));
        let zs = _mm256_blend_ps::<0xF0>(lane::<0xAA>(f), lane::<0xAA>(g));
        let along_x = _mm256_blend_ps::<0xAA>(lane::<0x00>(rest), lane::<0x00>(fade3));
        let m = _mm256_mul_ps(grad3(h, xs, ys, zs), along_x);
        // (g000 x1 + g100 u, g010 x1 + g110 u, ..) in lanes 0, 1 (near face), 4, 5 (far).
        let rows = _mm256_hadd_ps(m, m);
        let along_y = _mm256_blend_ps::<0xAA>(lane::<0x55>(rest), lane::<0x55>(fade3));
        let faces = _mm256_mul_ps(rows, along_y);
        let faces = _mm256_hadd_ps(faces, faces);
        let near = _mm_cvtss_f32(_mm256_castps256_ps128(faces));
        let far = _mm_cvtss_f32(_mm256_extractf128_ps::<1>(faces));
        let (z1, w) = (
            _mm_cvtss_f32(_mm_permute_ps::<0xAA>(rest)),
            _mm_cvtss_f32(_mm_permute_ps::<0xAA>(fade3)),
        );
        z1 * near + w * far
    }

    /// `snoise3_lanes` of two sets of lanes (two octaves of a Bump's three points) at once:
    /// each set in one lattice cell, whose eight corner hashes are computed for both sets in
    /// two eight-lane hashes; a set that is not takes `snoise3_lanes`.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub fn snoise3_pair(x: [Vec4; 2], y: [Vec4; 2], z: [Vec4; 2]) -> [Vec4; 2] {
        let join = |v: [Vec4; 2]| _mm256_set_m128(v[1].into(), v[0].into());
        let (px, py, pz) = (join(x), join(y), join(z));
        let abs = |v: __m256| _mm256_andnot_ps(_mm256_set1_ps(-0.0), v);
        let near = |v: __m256| {
            _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(
                abs(v),
                _mm256_set1_ps(100_000.0),
            )) == 0xFF
        };
        let (cx, cy, cz) = (
            _mm256_floor_ps(px),
            _mm256_floor_ps(py),
            _mm256_floor_ps(pz),
        );
        let one_cell = |c: __m256| {
            _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_EQ_OQ>(c, _mm256_permute_ps::<0>(c))) == 0xFF
        };
        if !(near(px) && near(py) && near(pz) && one_cell(cx) && one_cell(cy) && one_cell(cz)) {
            return [0, 1].map(|k| snoise3_lanes(x[k], y[k], z[k]));
        }
        let seeded = |c: __m256| _mm256_add_epi32(_mm256_cvttps_epi32(c), _mm256_set1_epi32(SEED3));
        let a = _mm256_add_epi32(seeded(cx), _mm256_setr_epi32(0, 1, 0, 1, 0, 1, 0, 1));
        let b = _mm256_add_epi32(seeded(cy), _mm256_setr_epi32(0, 0, 1, 1, 0, 0, 1, 1));
        let c = seeded(cz);
        // Corners 0–3 (near face), then 4–7 (far face), of each set's cell.
        // SAFETY: this function runs only with AVX2.
        let (near_h, far_h) = unsafe {
            (
                hash::finish(a, b, c),
                hash::finish(a, b, _mm256_add_epi32(c, _mm256_set1_epi32(1))),
            )
        };
        let one = _mm256_set1_ps(1.0);
        let (fx, fy, fz) = (
            _mm256_sub_ps(px, cx),
            _mm256_sub_ps(py, cy),
            _mm256_sub_ps(pz, cz),
        );
        let (u, v, w) = (fade(fx), fade(fy), fade(fz));
        let (gx, gy, gz) = (
            _mm256_sub_ps(fx, one),
            _mm256_sub_ps(fy, one),
            _mm256_sub_ps(fz, one),
        );
        let g000 = grad3(_mm256_shuffle_epi32::<0x00>(near_h), fx, fy, fz);
        let g100 = grad3(_mm256_shuffle_epi32::<0x55>(near_h), gx, fy, fz);
        let g010 = grad3(_mm256_shuffle_epi32::<0xAA>(near_h), fx, gy, fz);
        let g110 = grad3(_mm256_shuffle_epi32::<0xFF>(near_h), gx, gy, fz);
        let g001 = grad3(_mm256_shuffle_epi32::<0x00>(far_h), fx, fy, gz);
        let g101 = grad3(_mm256_shuffle_epi32::<0x55>(far_h), gx, fy, gz);
        let g011 = grad3(_mm256_shuffle_epi32::<0xAA>(far_h), fx, gy, gz);
        let g111 = grad3(_mm256_shuffle_epi32::<0xFF>(far_h), gx, gy, gz);
        let (x1, y1, z1) = (
            _mm256_sub_ps(one, u),
            _mm256_sub_ps(one, v),
            _mm256_sub_ps(one, w),
        );
        let (add, mul) = (_mm256_add_ps, _mm256_mul_ps);
        let row = |a: __m256, b: __m256| add(mul(a, x1), mul(b, u));
        let face = |r0: __m256, r1: __m256| add(mul(y1, r0), mul(v, r1));
        let p = add(
            mul(z1, face(row(g000, g100), row(g010, g110))),
            mul(w, face(row(g001, g101), row(g011, g111))),
        );
        let p = mul(_mm256_set1_ps(0.9820), p);
        [
            Vec4::from(_mm256_castps256_ps128(p)),
            Vec4::from(_mm256_extractf128_ps::<1>(p)),
        ]
    }

    /// `fade` lane by lane, on four lanes.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn fade4(t: __m128) -> __m128 {
        let s = _mm_set1_ps;
        let tt = _mm_mul_ps(_mm_mul_ps(t, t), t);
        let inner = _mm_sub_ps(_mm_mul_ps(t, s(6.0)), s(15.0));
        _mm_mul_ps(tt, _mm_add_ps(_mm_mul_ps(t, inner), s(10.0)))
    }

    /// `grad3` on four lanes.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn grad3_4(h: __m128i, x: __m128, y: __m128, z: __m128) -> __m128 {
        let k = _mm_set1_epi32;
        let h = _mm_and_si128(h, k(15));
        let below8 = _mm_castsi128_ps(_mm_cmpgt_epi32(k(8), h));
        let below4 = _mm_castsi128_ps(_mm_cmpgt_epi32(k(4), h));
        let v_is_x = _mm_castsi128_ps(_mm_or_si128(
            _mm_cmpeq_epi32(h, k(12)),
            _mm_cmpeq_epi32(h, k(14)),
        ));
        let u = _mm_blendv_ps(y, x, below8);
        let v = _mm_blendv_ps(_mm_blendv_ps(z, x, v_is_x), y, below4);
        let sign_u = _mm_castsi128_ps(_mm_slli_epi32::<31>(_mm_and_si128(h, k(1))));
        let sign_v = _mm_castsi128_ps(_mm_slli_epi32::<30>(_mm_and_si128(h, k(2))));
        _mm_add_ps(_mm_xor_ps(u, sign_u), _mm_xor_ps(v, sign_v))
    }

    /// `snoise3_lanes` of one set of lanes (one octave of a Bump's three points) in one
    /// lattice cell: its eight corner hashes in one eight-lane hash (lane dx + 2 dy + 4 dz),
    /// each broadcast to the four lanes; a set that is not in one cell takes
    /// `snoise3_lanes`.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub fn snoise3_one(x: Vec4, y: Vec4, z: Vec4) -> Vec4 {
        let (px, py, pz): (__m128, __m128, __m128) = (x.into(), y.into(), z.into());
        let abs = |v: __m128| _mm_andnot_ps(_mm_set1_ps(-0.0), v);
        let near = |v: __m128| _mm_movemask_ps(_mm_cmplt_ps(abs(v), _mm_set1_ps(100_000.0))) == 0xF;
        let (cx, cy, cz) = (_mm_floor_ps(px), _mm_floor_ps(py), _mm_floor_ps(pz));
        let one_cell = |c: __m128| _mm_movemask_ps(_mm_cmpeq_ps(c, _mm_permute_ps::<0>(c))) == 0xF;
        if !(near(px) && near(py) && near(pz) && one_cell(cx) && one_cell(cy) && one_cell(cz)) {
            return snoise3_lanes(x, y, z);
        }
        // The cell's coordinates (lane 0 of each) in all eight lanes, seeded.
        let seeded = |c: __m128| {
            _mm256_add_epi32(
                _mm256_broadcastd_epi32(_mm_cvttps_epi32(c)),
                _mm256_set1_epi32(SEED3),
            )
        };
        let a = _mm256_add_epi32(seeded(cx), _mm256_setr_epi32(0, 1, 0, 1, 0, 1, 0, 1));
        let b = _mm256_add_epi32(seeded(cy), _mm256_setr_epi32(0, 0, 1, 1, 0, 0, 1, 1));
        let c = _mm256_add_epi32(seeded(cz), _mm256_setr_epi32(0, 0, 0, 0, 1, 1, 1, 1));
        // SAFETY: this function runs only with AVX2.
        let h = unsafe { hash::finish(a, b, c) };
        let (near_h, far_h) = (_mm256_castsi256_si128(h), _mm256_extracti128_si256::<1>(h));
        let one = _mm_set1_ps(1.0);
        let (fx, fy, fz) = (_mm_sub_ps(px, cx), _mm_sub_ps(py, cy), _mm_sub_ps(pz, cz));
        let (u, v, w) = (fade4(fx), fade4(fy), fade4(fz));
        let (gx, gy, gz) = (
            _mm_sub_ps(fx, one),
            _mm_sub_ps(fy, one),
            _mm_sub_ps(fz, one),
        );
        let g000 = grad3_4(_mm_shuffle_epi32::<0x00>(near_h), fx, fy, fz);
        let g100 = grad3_4(_mm_shuffle_epi32::<0x55>(near_h), gx, fy, fz);
        let g010 = grad3_4(_mm_shuffle_epi32::<0xAA>(near_h), fx, gy, fz);
        let g110 = grad3_4(_mm_shuffle_epi32::<0xFF>(near_h), gx, gy, fz);
        let g001 = grad3_4(_mm_shuffle_epi32::<0x00>(far_h), fx, fy, gz);
        let g101 = grad3_4(_mm_shuffle_epi32::<0x55>(far_h), gx, fy, gz);
        let g011 = grad3_4(_mm_shuffle_epi32::<0xAA>(far_h), fx, gy, gz);
        let g111 = grad3_4(_mm_shuffle_epi32::<0xFF>(far_h), gx, gy, gz);
        let (x1, y1, z1) = (_mm_sub_ps(one, u), _mm_sub_ps(one, v), _mm_sub_ps(one, w));
        let (add, mul) = (_mm_add_ps, _mm_mul_ps);
        let row = |a: __m128, b: __m128| add(mul(a, x1), mul(b, u));
        let face = |r0: __m128, r1: __m128| add(mul(y1, r0), mul(v, r1));
        let p = add(
            mul(z1, face(row(g000, g100), row(g010, g110))),
            mul(w, face(row(g001, g101), row(g011, g111))),
        );
        Vec4::from(mul(_mm_set1_ps(0.9820), p))
    }
}

/// One point's Noise Texture inputs: (scaled position, scaled W, fractal, distortion).
type NoiseInput = (Vec3, f32, Fractal, f32);

/// `noise_texture` at a Bump's three points (its section header).
fn noise_texture_at3(dimensions: u8, at: &[NoiseInput; 3], color: bool) -> [(f32, Vec3); 3] {
    let (_, _, f, distortion) = at[0];
    let shared = at.iter().all(|a| a.2 == f && a.3 == distortion);
    if dimensions != 3 || !shared {
        return at.map(|(p, w, f, d)| noise_texture(dimensions, p, w, &f, d, color));
    }
    let (mut x, mut y, mut z) = (
        lanes(at.map(|a| a.0.x)),
        lanes(at.map(|a| a.0.y)),
        lanes(at.map(|a| a.0.z)),
    );
    if distortion != 0.0 {
        let d = [0.0f32, 1.0, 2.0].map(|seed| {
            let o = offset(3, seed).0;
            snoise3_lanes(x + o.x, y + o.y, z + o.z) * distortion
        });
        (x, y, z) = (x + d[0], y + d[1], z + d[2]);
    }
    let value = fbm3_lanes(x, y, z, &f);
    let shifted = |seed: f32| {
        let o = offset(3, seed).0;
        fbm3_lanes(x + o.x, y + o.y, z + o.z, &f)
    };
    let (g, b) = if color {
        (shifted(3.0), shifted(4.0))
    } else {
        (value, value)
    };
    [0, 1, 2].map(|k| (value[k], Vec3::new(value[k], g[k], b[k])))
}

/// Blender's Vector Math node: the vector and the value outputs.
fn vector_math(op: VectorOp, a: Vec3, b: Vec3, c: Vec3, scale: f32) -> (Vec3, f32) {
    use VectorOp::*;
    let per = |f: &dyn Fn(f32, f32) -> f32| Vec3::new(f(a.x, b.x), f(a.y, b.y), f(a.z, b.z));
    match op {
        Add => (a + b, 0.0),
        Subtract => (a - b, 0.0),
        Multiply => (a * b, 0.0),
        Divide => (safe_divide3(a, b), 0.0),
        MultiplyAdd => (a * b + c, 0.0),
        Cross => (a.cross(b), 0.0),
        Project => {
            let len2 = b.length_squared();
            let v = if len2 != 0.0 {
                b * (a.dot(b) / len2)
            } else {
                Vec3::ZERO
            };
            (v, 0.0)
        }
        Reflect => {
            let n = b.normalize_or_zero();
            (a - 2.0 * a.dot(n) * n, 0.0)
        }
        Dot => (Vec3::ZERO, a.dot(b)),
        Distance => (Vec3::ZERO, a.distance(b)),
        Length => (Vec3::ZERO, a.length()),
        Scale => (a * scale, 0.0),
        Normalize => (a.normalize_or_zero(), 0.0),
        Absolute => (a.abs(), 0.0),
        Minimum => (a.min(b), 0.0),
        Maximum => (a.max(b), 0.0),
        Floor => (a.floor(), 0.0),
        Ceil => (a.ceil(), 0.0),
        Fraction => (a - a.floor(), 0.0),
        Modulo => (per(&|x, y| if y != 0.0 { x % y } else { 0.0 }), 0.0),
        Snap => (
            per(&|x, y| if y != 0.0 { (x / y).floor() * y } else { 0.0 }),
            0.0,
        ),
        Sine => (Vec3::new(a.x.sin(), a.y.sin(), a.z.sin()), 0.0),
        Cosine => (Vec3::new(a.x.cos(), a.y.cos(), a.z.cos()), 0.0),
        Tangent => (Vec3::new(a.x.tan(), a.y.tan(), a.z.tan()), 0.0),
    }
}

/// `hash_floatN_to_float` and `hash_floatN_to_float3` of the White Noise texture: the value
/// and colour of the hash of the point's (and W's) bits, 1D reading W only, 2D x and y.
fn white_noise(dimensions: u8, p: Vec3, w: f32) -> (f32, Vec3) {
    let (x, y, z, w) = (p.x.to_bits(), p.y.to_bits(), p.z.to_bits(), w.to_bits());
    let (one, two) = (1f32.to_bits(), 2f32.to_bits());
    let hashes = match dimensions {
        1 => [hash1(w), hash2(w, one), hash2(w, two)],
        2 => [hash2(x, y), hash3(x, y, one), hash3(x, y, two)],
        3 => [hash3(x, y, z), hash4(x, y, z, one), hash4(x, y, z, two)],
        _ => [hash4(x, y, z, w), hash4(z, x, w, y), hash4(w, z, y, x)],
    };
    let [a, b, c] = hashes.map(unit);
    (a, Vec3::new(a, b, c))
}

/// Cycles' `svm_magic`: Blender's Magic texture, `depth` rounds of sines and cosines feeding
/// each other, the coordinates first wrapped to one period (2π) to keep precision.
fn magic(p: Vec3, scale: f32, depth: u8, distortion: f32) -> Vec3 {
    let wrap = |v: f32| v % (2.0 * PI);
    let (px, py, pz) = (wrap(p.x), wrap(p.y), wrap(p.z));
    let mut x = ((px + py + pz) * 5.0 * scale).sin();
    let mut y = ((-px + py - pz) * 5.0 * scale).cos();
    let mut z = -((-px - py + pz) * 5.0 * scale).cos();
    let d = distortion;
    if depth > 0 {
        x *= d;
        y *= d;
        z *= d;
        y = -(x - y + z).cos() * d;
        // Each further round rewrites one channel from the three.
        for round in 2..=depth.min(10) {
            match round {
                2 => x = (x - y - z).cos() * d,
                3 => z = (-x - y - z).sin() * d,
                4 => x = -(-x + y - z).cos() * d,
                5 => y = -(-x + y + z).sin() * d,
                6 => y = -(-x + y + z).cos() * d,
                7 => x = (x + y + z).cos() * d,
                8 => z = (x + y - z).sin() * d,
                9 => x = -(-x - y + z).cos() * d,
                _ => y = -(x - y + z).sin() * d,
            }
        }
    }
    if d != 0.0 {
        x /= 2.0 * d;
        y /= 2.0 * d;
        z /= 2.0 * d;
    }
    Vec3::new(0.5 - x, 0.5 - y, 0.5 - z)
}

/// The integer noise of Blender's Brick texture (a brick's tint), in [0, 1).
fn brick_noise(n: u32) -> f32 {
    let n = n.wrapping_add(1013) & 0x7fff_ffff;
    let n = (n >> 13) ^ n;
    let nn = n
        .wrapping_mul(
            n.wrapping_mul(n)
                .wrapping_mul(60493)
                .wrapping_add(19_990_303),
        )
        .wrapping_add(1_376_312_589)
        & 0x7fff_ffff;
    0.5 * (nn as f32 / 1_073_741_824.0)
}

/// Cycles' `svm_brick` on the scaled point: the brick's tint (bias added, in [0, 1]) and the
/// mortar factor. `sizes` holds Mortar Size, Mortar Smooth, Bias, Brick Width, Row Height.
/// Every `offset_frequency`-th row is shifted by `offset` bricks and every
/// `squash_frequency`-th row's bricks are `squash` times as wide.
fn brick(layout: &BrickLayout, p: Vec3, sizes: [f32; 5]) -> (f32, f32) {
    let [mortar_size, mortar_smooth, bias, mut width, row_height] = sizes;
    let row = (p.y / row_height).floor() as i32;
    let mut offset = 0.0;
    if layout.offset_frequency != 0 && layout.squash_frequency != 0 {
        if row % layout.squash_frequency == 0 {
            width *= layout.squash;
        }
        if row % layout.offset_frequency == 0 {
            offset = width * layout.offset;
        }
    }
    let column = ((p.x + offset) / width).floor() as i32;
    let x = (p.x + offset) - width * column as f32;
    let y = p.y - row_height * row as f32;
    let id = (row.wrapping_shl(16)).wrapping_add(column & 0xffff) as u32;
    let tint = (brick_noise(id) + bias).clamp(0.0, 1.0);
    let edge = x.min(y).min((width - x).min(row_height - y));
    let mortar = if edge >= mortar_size {
        0.0
    } else if mortar_smooth == 0.0 {
        1.0
    } else {
        let t = ((1.0 - edge / mortar_size) / mortar_smooth).clamp(0.0, 1.0);
        t * t * (3.0 - 2.0 * t)
    };
    (tint, mortar)
}

/// Fits of the black-body colour in Rec.709 (Cycles' `blackbody_table_r/g/b`, fitted to
/// Planck's law normalised to unit luminance), per temperature interval: R and G as
/// a/T + b·T + c, B as ((a·T + b)·T + c)·T + d.
const BLACKBODY_R: [[f32; 3]; 7] = [
    [1.619191e3, -2.0501092e-3, 5.029958],
    [2.4884546e3, -1.1133091e-3, 3.2262154],
    [3.341432e3, -4.865512e-4, 1.7648677],
    [4.0946174e3, -1.2744658e-4, 7.257316e-1],
    [4.6702803e3, 2.912582e-5, 1.2670344e-1],
    [4.595092e3, 2.8749564e-5, 1.5034503e-1],
    [3.7871746e3, 9.359078e-6, 3.9907587e-1],
];
const BLACKBODY_G: [[f32; 3]; 7] = [
    [-4.8899976e2, 6.0433074e-4, -7.558075e-2],
    [-7.5599426e2, 3.167301e-4, 4.7830614e-1],
    [-1.0236398e3, 1.2022347e-4, 9.366623e-1],
    [-1.2657131e3, 4.873409e-6, 1.270545],
    [-1.4252933e3, -4.0115043e-5, 1.4397278],
    [-1.1755482e3, -2.1637805e-5, 1.3040802],
    [-5.0079956e2, -4.59832e-6, 1.0909877],
];
const BLACKBODY_B: [[f32; 4]; 7] = [
    [5.9694534e-11, -4.857429e-8, -9.706223e-5, -4.0793614e-3],
    [2.4043037e-11, 5.5502106e-8, -1.9850371e-4, 2.8931286e-2],
    [-1.40949735e-11, 1.8987897e-7, -3.5663284e-4, 9.107678e-2],
    [-3.6146086e-11, 2.8482202e-7, -4.932113e-4, 1.5672344e-1],
    [-1.9707574e-11, 1.7535935e-7, -2.5054283e-4, -2.2278327e-2],
    [-1.6199795e-13, -1.64216e-8, 3.8621627e-4, -7.380774e-1],
    [6.726503e-13, -2.730788e-8, 4.2409825e-4, -7.5233567e-1],
];

/// The Blackbody node's colour at `t` kelvin (Rec.709, unit luminance, may be negative
/// outside the gamut): Cycles' piecewise fit over 800–12000 K, constant beyond.
fn blackbody(t: f32) -> Vec3 {
    if t >= 12000.0 {
        return Vec3::new(0.826_295_5, 0.994_508, 1.566_307_7);
    }
    if t < 800.0 || t.is_nan() {
        return Vec3::new(5.413_294_5, -0.203_193_9, -0.082_253_52);
    }
    let i = [965.0, 1167.0, 1449.0, 1902.0, 3315.0, 6365.0]
        .iter()
        .filter(|&&edge| t >= edge)
        .count();
    let (r, g, b) = (BLACKBODY_R[i], BLACKBODY_G[i], BLACKBODY_B[i]);
    Vec3::new(
        r[0] / t + r[1] * t + r[2],
        g[0] / t + g[1] * t + g[2],
        ((b[0] * t + b[1]) * t + b[2]) * t + b[3],
    )
}

/// Cycles' `svm_wave` on the scaled point; `detail` holds Distortion, Detail, Detail Scale,
/// Detail Roughness and Phase Offset.
fn wave(kind: WaveKind, p: Vec3, detail: [f32; 5]) -> f32 {
    let [distortion, octaves, detail_scale, detail_roughness, phase] = detail;
    let p = (p + Vec3::splat(0.000_001)) * 0.999_999;
    let mut n = if kind.bands {
        match kind.direction {
            0 => p.x * 20.0,
            1 => p.y * 20.0,
            2 => p.z * 20.0,
            _ => (p.x + p.y + p.z) * 10.0,
        }
    } else {
        let rp = match kind.direction {
            0 => p * Vec3::new(0.0, 1.0, 1.0),
            1 => p * Vec3::new(1.0, 0.0, 1.0),
            2 => p * Vec3::new(1.0, 1.0, 0.0),
            _ => p,
        };
        rp.length() * 20.0
    };
    n += phase;
    if distortion != 0.0 {
        let f = Fractal {
            detail: octaves,
            roughness: detail_roughness,
            lacunarity: 2.0,
            normalize: true,
        };
        n += distortion * (fbm(3, p * detail_scale, 0.0, &f) * 2.0 - 1.0);
    }
    match kind.profile {
        WaveProfile::Sine => 0.5 + 0.5 * (n - std::f32::consts::FRAC_PI_2).sin(),
        WaveProfile::Saw => {
            let n = n / (2.0 * PI);
            n - n.floor()
        }
        WaveProfile::Triangle => {
            let n = n / (2.0 * PI);
            (n - (n + 0.5).floor()).abs() * 2.0
        }
    }
}

// ----- Voronoi as Blender defines it (Cycles' voronoi.h) -----------------------------------

struct VoronoiParams {
    scale: f32,
    detail: f32,
    roughness: f32,
    lacunarity: f32,
    smoothness: f32,
    exponent: f32,
    randomness: f32,
    kind: VoronoiKind,
}

/// Jenkins' lookup3 `mix` of (a, b, c).
#[inline(always)]
fn lookup3_mix(a: u32, b: u32, c: u32) -> (u32, u32, u32) {
    let (a, b, c) = node_hash::mix(W(a), W(b), W(c));
    (a.0, b.0, c.0)
}

fn hash4(x: u32, y: u32, z: u32, w: u32) -> u32 {
    let s = LOOKUP3_SEED.wrapping_add((4 << 2) + 13);
    let (a, b, c) = lookup3_mix(s.wrapping_add(x), s.wrapping_add(y), s.wrapping_add(z));
    lookup3_final(a.wrapping_add(w), b, c)
}

fn unit(h: u32) -> f32 {
    h as f32 * (1.0 / 4_294_967_295.0)
}

/// `hash_float2_to_float2` (2D) or `hash_float3_to_float3` (3D): a cell's point offset.
fn cell_point(dimensions: u8, c: Vec3) -> Vec3 {
    let (x, y, z) = (c.x.to_bits(), c.y.to_bits(), c.z.to_bits());
    if dimensions == 2 {
        Vec3::new(unit(hash2(x, y)), unit(hash3(x, y, 1f32.to_bits())), 0.0)
    } else {
        // hash4(x, y, z, w) for w = 1.0 and 2.0 share their first mix.
        let s = LOOKUP3_SEED.wrapping_add((4 << 2) + 13);
        let (a, b, c) = lookup3_mix(s.wrapping_add(x), s.wrapping_add(y), s.wrapping_add(z));
        Vec3::new(
            unit(hash3(x, y, z)),
            unit(lookup3_final(a.wrapping_add(1f32.to_bits()), b, c)),
            unit(lookup3_final(a.wrapping_add(2f32.to_bits()), b, c)),
        )
    }
}

/// `hash_float2_to_float3` (2D) or `hash_float3_to_float3` (3D): a cell's colour.
fn cell_color(dimensions: u8, c: Vec3) -> Vec3 {
    let (x, y) = (c.x.to_bits(), c.y.to_bits());
    if dimensions == 2 {
        Vec3::new(
            unit(hash2(x, y)),
            unit(hash3(x, y, 1f32.to_bits())),
            unit(hash3(x, y, 2f32.to_bits())),
        )
    } else {
        cell_point(3, c)
    }
}

fn voronoi_distance(metric: Metric, exponent: f32, a: Vec3, b: Vec3) -> f32 {
    let d = (a - b).abs();
    match metric {
        Metric::Euclidean => a.distance(b),
        Metric::Manhattan => d.x + d.y + d.z,
        Metric::Chebychev => d.max_element(),
        Metric::Minkowski => {
            (d.x.powf(exponent) + d.y.powf(exponent) + d.z.powf(exponent)).powf(1.0 / exponent)
        }
    }
}

/// The cell offsets a search visits, in Cycles' order (z outermost, x innermost).
fn cell_offsets(dimensions: u8, reach: i32) -> impl Iterator<Item = Vec3> {
    let zr = if dimensions == 2 { 0 } else { reach };
    (-zr..=zr).flat_map(move |k| {
        (-reach..=reach).flat_map(move |j| {
            (-reach..=reach).map(move |i| Vec3::new(i as f32, j as f32, k as f32))
        })
    })
}

/// One octave: (distance, colour, position).
/// Without `color` the F1 colour is not computed (zero).
fn voronoi_octave(p: &VoronoiParams, coord: Vec3, color: bool) -> (f32, Vec3, Vec3) {
    let dims = p.kind.dimensions;
    let cell = Vec3::new(floor(coord.x), floor(coord.y), floor(coord.z));
    let local = coord - cell;
    let metric = p.kind.metric;
    match p.kind.feature {
        VoronoiFeature::SmoothF1 if p.smoothness != 0.0 => {
            let mut distance = 0.0f32;
            let mut color = Vec3::ZERO;
            let mut position = Vec3::ZERO;
            let mut h = -1.0f32;
            for offset in cell_offsets(dims, 2) {
                let point = offset + cell_point(dims, cell + offset) * p.randomness;
                let d = voronoi_distance(metric, p.exponent, point, local);
                h = if h == -1.0 {
                    1.0
                } else {
                    smoothstep(0.0, 1.0, 0.5 + 0.5 * (distance - d) / p.smoothness)
                };
                let mut correction = p.smoothness * h * (1.0 - h);
                distance = lerp(distance, d, h) - correction;
                correction /= 1.0 + 3.0 * p.smoothness;
                let c = cell_color(dims, cell + offset);
                color = color.lerp(c, h) - Vec3::splat(correction);
                position = position.lerp(point, h) - Vec3::splat(correction);
            }
            (distance, color, cell + position)
        }
        VoronoiFeature::F2 => {
            let (mut d1, mut d2) = (f32::MAX, f32::MAX);
            let (mut o1, mut o2) = (Vec3::ZERO, Vec3::ZERO);
            let (mut p1, mut p2) = (Vec3::ZERO, Vec3::ZERO);
            for offset in cell_offsets(dims, 1) {
                let point = offset + cell_point(dims, cell + offset) * p.randomness;
                let d = voronoi_distance(metric, p.exponent, point, local);
                if d < d1 {
                    (d2, o2, p2) = (d1, o1, p1);
                    (d1, o1, p1) = (d, offset, point);
                } else if d < d2 {
                    (d2, o2, p2) = (d, offset, point);
                }
            }
            (d2, cell_color(dims, cell + o2), p2 + cell)
        }
        _ => {
            // The nearest point, the first in Cycles' order on a tie. A cell's point lies in
            // [offset, offset + randomness] on each axis, so a cell whose box is farther from
            // `local` than the best point so far cannot win: it is skipped unhashed (exact).
            // The cells are visited nearest first (the home cell, then those sharing a face,
            // an edge, a corner), so the best point is found early and most cells are skipped.
            // (As Cycles computes it: cell + 0 turns a −0 coordinate into +0 before hashing.)
            let prune = metric != Metric::Minkowski;
            let mut best = f32::MAX;
            let mut best_index = usize::MAX;
            let (mut target_offset, mut target) = (Vec3::ZERO, Vec3::ZERO);
            let order: &[(u8, [i8; 3])] = if dims == 2 {
                &NEAREST_FIRST_2D
            } else {
                &NEAREST_FIRST_3D
            };
            // Per axis, the squared gap from `local` to the boxes of offset −1, 0 and 1.
            let gap2 = [local.x, local.y, local.z].map(|l| {
                [-1.0f32, 0.0, 1.0].map(|o| {
                    let g = (o - l).max(l - (o + p.randomness)).max(0.0);
                    g * g
                })
            });
            if metric == Metric::Euclidean && dims == 3 {
                let (best, offset, point) =
                    nearest_point_euclidean_3d(cell, local, p.randomness, &gap2);
                let color = if color {
                    cell_color(dims, cell + offset)
                } else {
                    Vec3::ZERO
                };
                return (best, color, point + cell);
            }
            for &(index, [i, j, k]) in order {
                let index = index as usize;
                let offset = Vec3::new(i as f32, j as f32, k as f32);
                if prune && best != f32::MAX {
                    let bound = best * (1.0 + 1e-6);
                    let far = if metric == Metric::Euclidean {
                        // Squared, without the root (the bound's margin covers the rounding).
                        let [a, b, c] = [i, j, k].map(|o| (o + 1) as usize);
                        gap2[0][a] + gap2[1][b] + gap2[2][c] > bound * bound
                    } else {
                        let below = offset - local;
                        let above = local - (offset + Vec3::splat(p.randomness));
                        let gap = below.max(above).max(Vec3::ZERO);
                        voronoi_distance(metric, p.exponent, gap, Vec3::ZERO) > bound
                    };
                    if far {
                        continue;
                    }
                }
                let point = offset + cell_point(dims, cell + offset) * p.randomness;
                let d = voronoi_distance(metric, p.exponent, point, local);
                if d < best || (d == best && index < best_index) {
                    (best, best_index, target_offset, target) = (d, index, offset, point);
                }
            }
            let color = if color {
                cell_color(dims, cell + target_offset)
            } else {
                Vec3::ZERO
            };
            (best, color, target + cell)
        }
    }
}

/// `cell_point` in 3D of four cells given as lanes: the same hashes, lane by lane.
#[inline(always)]
fn cell_points4(x: Vec4, y: Vec4, z: Vec4) -> [Vec4; 3] {
    let bits = |v: Vec4| U32x4::new(v.to_array().map(f32::to_bits));
    let (x, y, z) = (bits(x), bits(y), bits(z));
    let s3 = U32x4::splat(LOOKUP3_SEED.wrapping_add((3 << 2) + 13));
    let first = node_hash::finish(x + s3, y + s3, z + s3);
    // hash4(x, y, z, w) for w = 1.0 and 2.0 share their first mix.
    let s4 = U32x4::splat(LOOKUP3_SEED.wrapping_add((4 << 2) + 13));
    let (a, b, c) = node_hash::mix(x + s4, y + s4, z + s4);
    let second = node_hash::finish(a + U32x4::splat(1f32.to_bits()), b, c);
    let third = node_hash::finish(a + U32x4::splat(2f32.to_bits()), b, c);
    let unit4 = |h: U32x4| Vec4::from_array(h.to_array().map(unit));
    [unit4(first), unit4(second), unit4(third)]
}

/// The Voronoi F1 search in 3D with the Euclidean metric (`voronoi_octave`'s, exact):
/// (distance, offset, point) of the nearest cell point to `local` in `cell`'s frame; `gap2`
/// holds per axis the squared gaps from `local` to the boxes of offsets −1, 0, 1. Eight cells
/// at a time where the machine has AVX2 (`voronoi_avx2`), else four (the same result).
fn nearest_point_euclidean_3d(
    cell: Vec3,
    local: Vec3,
    randomness: f32,
    gap2: &[[f32; 3]; 3],
) -> (f32, Vec3, Vec3) {
    #[cfg(target_arch = "x86_64")]
    if has_avx2() {
        // SAFETY: AVX2 is present (checked above).
        return unsafe { voronoi_avx2::nearest_point_euclidean_3d(cell, local, randomness, gap2) };
    }
    nearest_point_euclidean_3d_lanes4(cell, local, randomness, gap2)
}

/// `nearest_point_euclidean_3d` four cells at a time: the home cell and, per axis, the face
/// neighbour on `local`'s nearer side are searched first, four at once; then the other cells
/// nearest first, skipping those whose box lies farther than the best point so far, the
/// others queued and searched four at a time.
fn nearest_point_euclidean_3d_lanes4(
    cell: Vec3,
    local: Vec3,
    randomness: f32,
    gap2: &[[f32; 3]; 3],
) -> (f32, Vec3, Vec3) {
    let mut nearest = (f32::MAX, usize::MAX, Vec3::ZERO, Vec3::ZERO);
    let side = |l: f32| if l < 0.5 { -1.0f32 } else { 1.0 };
    let (sx, sy, sz) = (side(local.x), side(local.y), side(local.z));
    // Cycles' index of offset (i, j, k): z outermost, x innermost.
    let index = |o: Vec3| (o.x + 1.0 + 3.0 * (o.y + 1.0) + 9.0 * (o.z + 1.0)) as usize;
    let first = [
        Vec3::ZERO,
        Vec3::new(sx, 0.0, 0.0),
        Vec3::new(0.0, sy, 0.0),
        Vec3::new(0.0, 0.0, sz),
    ]
    .map(|o| (index(o), o));
    nearest_of_four(&first, cell, local, randomness, &mut nearest);
    let done = first.iter().fold(0u32, |m, (i, _)| m | 1 << i);
    let mut batch = [first[0]; 4];
    let mut queued = 0;
    // Squared, without the root (the bound's margin covers the rounding); it changes only
    // when a batch finds a nearer point.
    let limit = |nearest: f32| {
        let bound = nearest * (1.0 + 1e-6);
        bound * bound
    };
    let mut far = limit(nearest.0);
    for &(index, [a, b, c], offset) in &NEAREST_FIRST_3D_BOXES {
        if done >> index & 1 != 0 {
            continue;
        }
        if gap2[0][a] + gap2[1][b] + gap2[2][c] > far {
            continue;
        }
        batch[queued] = (index, offset);
        queued += 1;
        if queued == 4 {
            nearest_of_four(&batch, cell, local, randomness, &mut nearest);
            far = limit(nearest.0);
            queued = 0;
        }
    }
    if queued > 0 {
        // The empty lanes repeat the batch's first cell (a tie with itself: no change).
        for k in queued..4 {
            batch[k] = batch[0];
        }
        nearest_of_four(&batch, cell, local, randomness, &mut nearest);
    }
    (nearest.0, nearest.2, nearest.3)
}

/// The Euclidean F1 search over four cells (index in Cycles' order, offset) at once: their
/// points, distances to `local` (`a.distance(b)`'s operations lane by lane) and the update of
/// `nearest` = (distance, index, offset, point) with Cycles' tie rule (the first in its order).
fn nearest_of_four(
    cells: &[(usize, Vec3); 4],
    cell: Vec3,
    local: Vec3,
    randomness: f32,
    nearest: &mut (f32, usize, Vec3, Vec3),
) {
    let lane = |f: fn(Vec3) -> f32| Vec4::from_array(cells.map(|(_, o)| f(o)));
    let (ox, oy, oz) = (lane(|o| o.x), lane(|o| o.y), lane(|o| o.z));
    let [hx, hy, hz] = cell_points4(ox + cell.x, oy + cell.y, oz + cell.z);
    let (px, py, pz) = (
        ox + hx * randomness,
        oy + hy * randomness,
        oz + hz * randomness,
    );
    let (dx, dy, dz) = (px - local.x, py - local.y, pz - local.z);
    let d = (dx * dx + dy * dy + dz * dz).sqrt().to_array();
    let (px, py, pz) = (px.to_array(), py.to_array(), pz.to_array());
    for k in 0..4 {
        let (index, offset) = cells[k];
        if d[k] < nearest.0 || (d[k] == nearest.0 && index < nearest.1) {
            *nearest = (d[k], index, offset, Vec3::new(px[k], py[k], pz[k]));
        }
    }
}

/// The cells around a Voronoi point's home cell as (Cycles' visiting order, offset), nearest
/// first: the home cell, then the cells sharing a face, an edge, a corner with it.
const fn nearest_first<const N: usize>(dims: usize) -> [(u8, [i8; 3]); N] {
    let mut out = [(0u8, [0i8; 3]); N];
    let mut n = 0;
    let mut shared = 0;
    while shared <= dims {
        let mut index = 0;
        while index < N {
            let o = [
                (index % 3) as i8 - 1,
                ((index / 3) % 3) as i8 - 1,
                if dims == 2 { 0 } else { (index / 9) as i8 - 1 },
            ];
            let nonzero = (o[0] != 0) as usize + (o[1] != 0) as usize + (o[2] != 0) as usize;
            if nonzero == shared {
                out[n] = (index as u8, o);
                n += 1;
            }
            index += 1;
        }
        shared += 1;
    }
    out
}

const NEAREST_FIRST_2D: [(u8, [i8; 3]); 9] = nearest_first::<9>(2);
const NEAREST_FIRST_3D: [(u8, [i8; 3]); 27] = nearest_first::<27>(3);

/// `NEAREST_FIRST_3D` as the 3D Euclidean search reads it: (index, the offset's per-axis
/// indices into the box gaps (offset + 1), offset).
const NEAREST_FIRST_3D_BOXES: [(usize, [usize; 3], Vec3); 27] = {
    let mut boxes = [(0, [0; 3], Vec3::ZERO); 27];
    let mut n = 0;
    while n < 27 {
        let (index, [i, j, k]) = NEAREST_FIRST_3D[n];
        boxes[n] = (
            index as usize,
            [(i + 1) as usize, (j + 1) as usize, (k + 1) as usize],
            Vec3::new(i as f32, j as f32, k as f32),
        );
        n += 1;
    }
    boxes
};

/// The Voronoi F1 search in 3D with the Euclidean metric on AVX2 (x86-64 machines that have
/// it; the caller checks): `nearest_point_euclidean_3d`'s result bit for bit. The 2 × 2 × 2
/// cells on `local`'s nearer side along each axis are searched first, eight at once; then the
/// box of each of the other cells is tested against the best distance so far, all at once,
/// and those within it searched eight at a time. The nearest point is the least (distance,
/// Cycles' index) over the searched cells, so the order of the search does not matter.
#[cfg(target_arch = "x86_64")]
mod voronoi_avx2 {
    use crate::math::Vec3;
    use crate::scene::node_hash::avx2 as hash;
    use crate::scene::nodes::LOOKUP3_SEED;
    use std::arch::x86_64::*;

    const SEED3: i32 = LOOKUP3_SEED.wrapping_add((3 << 2) + 13) as i32;
    const SEED4: i32 = LOOKUP3_SEED.wrapping_add((4 << 2) + 13) as i32;

    /// The offset of the cell of Cycles' index `i` (z outermost, x innermost).
    const OFFSETS: [[f32; 3]; 27] = {
        let mut o = [[0.0; 3]; 27];
        let mut i = 0;
        while i < 27 {
            o[i] = [
                (i % 3) as f32 - 1.0,
                ((i / 3) % 3) as f32 - 1.0,
                (i / 9) as f32 - 1.0,
            ];
            i += 1;
        }
        o
    };

    /// For each side of the home cell's centre `local` is on (bit a set where it is at least
    /// ½ along axis a): the Cycles indices of the 2 × 2 × 2 cells on that side (lane
    /// dx + 2 dy + 4 dz) and their set.
    const BLOCKS: [([usize; 8], u32); 8] = {
        let mut blocks = [([0; 8], 0); 8];
        let mut sides = 0;
        while sides < 8 {
            // The sign of each axis' step: 2 · bit − 1.
            let (ix, iy, iz) = (
                2 * (sides & 1) as isize - 1,
                3 * (2 * ((sides >> 1) & 1) as isize - 1),
                9 * (2 * (sides >> 2) as isize - 1),
            );
            let mut lane = 0;
            while lane < 8 {
                let d = (lane & 1) as isize * ix
                    + ((lane >> 1) & 1) as isize * iy
                    + (lane >> 2) as isize * iz;
                let index = (13 + d) as usize;
                blocks[sides].0[lane] = index;
                blocks[sides].1 |= 1 << index;
                lane += 1;
            }
            sides += 1;
        }
        blocks
    };

    /// For group g and each axis, which of the box gaps (offset + 1) the cell of index
    /// 8 g + lane reads (3: none, for the five lanes past the 27 cells).
    const GAP_PICKS: [[[i32; 8]; 3]; 4] = {
        let mut picks = [[[3; 8]; 3]; 4];
        let mut i = 0;
        while i < 27 {
            picks[i / 8][0][i % 8] = (i % 3) as i32;
            picks[i / 8][1][i % 8] = ((i / 3) % 3) as i32;
            picks[i / 8][2][i % 8] = (i / 9) as i32;
            i += 1;
        }
        picks
    };

    /// `unit` lane by lane: `h as f32` exactly (its high and low 16 bits convert exactly, and
    /// their sum rounds once, to nearest even, as the conversion does), times 1 / (2³² − 1).
    #[target_feature(enable = "avx2")]
    #[inline]
    fn unit(h: __m256i) -> __m256 {
        let hi = _mm256_cvtepi32_ps(_mm256_srli_epi32::<16>(h));
        let lo = _mm256_cvtepi32_ps(_mm256_and_si256(h, _mm256_set1_epi32(0xFFFF)));
        let f = _mm256_add_ps(_mm256_mul_ps(hi, _mm256_set1_ps(65536.0)), lo);
        _mm256_mul_ps(f, _mm256_set1_ps(1.0 / 4_294_967_295.0))
    }

    /// `super::cell_points4` on eight cells.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn cell_points8(x: __m256, y: __m256, z: __m256) -> [__m256; 3] {
        let (x, y, z) = (
            _mm256_castps_si256(x),
            _mm256_castps_si256(y),
            _mm256_castps_si256(z),
        );
        let add = _mm256_add_epi32;
        let s3 = _mm256_set1_epi32(SEED3);
        let s4 = _mm256_set1_epi32(SEED4);
        let w = |v: f32| _mm256_set1_epi32(v.to_bits() as i32);
        // SAFETY: this function runs only with AVX2.
        let (first, second, third) = unsafe {
            let first = hash::finish(add(x, s3), add(y, s3), add(z, s3));
            // hash4(x, y, z, w) for w = 1.0 and 2.0 share their first mix.
            let (a, b, c) = hash::mix(add(x, s4), add(y, s4), add(z, s4));
            (
                first,
                hash::finish(add(a, w(1.0)), b, c),
                hash::finish(add(a, w(2.0)), b, c),
            )
        };
        [unit(first), unit(second), unit(third)]
    }

    /// `super::nearest_of_four` on eight cells: Cycles' indices and offsets as lanes.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn nearest_of_eight(
        index: &[usize; 8],
        offset: [__m256; 3],
        cell: Vec3,
        local: Vec3,
        randomness: f32,
        nearest: &mut (f32, usize, Vec3, Vec3),
    ) {
        let s = _mm256_set1_ps;
        let (add, sub, mul) = (_mm256_add_ps, _mm256_sub_ps, _mm256_mul_ps);
        let [ox, oy, oz] = offset;
        let [hx, hy, hz] = cell_points8(add(ox, s(cell.x)), add(oy, s(cell.y)), add(oz, s(cell.z)));
        let r = s(randomness);
        let (px, py, pz) = (
            add(ox, mul(hx, r)),
            add(oy, mul(hy, r)),
            add(oz, mul(hz, r)),
        );
        let (dx, dy, dz) = (
            sub(px, s(local.x)),
            sub(py, s(local.y)),
            sub(pz, s(local.z)),
        );
        let d = _mm256_sqrt_ps(add(add(mul(dx, dx), mul(dy, dy)), mul(dz, dz)));
        let within = _mm256_cmp_ps::<_CMP_LE_OQ>(d, s(nearest.0));
        let hits = _mm256_movemask_ps(within) as u32;
        if hits == 0 {
            return;
        }
        // The least distance among the lanes not farther than the best (NaN never is), then
        // the least index among its lanes: the rule below applied lane by lane in any order
        // keeps the least (distance, index).
        let d = _mm256_blendv_ps(s(f32::INFINITY), d, within);
        let m = _mm256_min_ps(d, _mm256_permute2f128_ps::<1>(d, d));
        let m = _mm256_min_ps(m, _mm256_permute_ps::<0b01_00_11_10>(m));
        let m = _mm256_min_ps(m, _mm256_permute_ps::<0b10_11_00_01>(m));
        let least = _mm_cvtss_f32(_mm256_castps256_ps128(m));
        let mut ties = hits & _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_EQ_OQ>(d, m)) as u32;
        let mut k = ties.trailing_zeros() as usize;
        ties &= ties - 1;
        while ties != 0 {
            let j = ties.trailing_zeros() as usize;
            ties &= ties - 1;
            if index[j] < index[k] {
                k = j;
            }
        }
        if least < nearest.0 || (least == nearest.0 && index[k] < nearest.1) {
            let store = |v: __m256| {
                let mut out = [0.0f32; 8];
                // SAFETY: an unaligned store of eight floats into eight floats.
                unsafe { _mm256_storeu_ps(out.as_mut_ptr(), v) };
                out
            };
            let (px, py, pz) = (store(px), store(py), store(pz));
            let o = OFFSETS[index[k]];
            *nearest = (
                least,
                index[k],
                Vec3::new(o[0], o[1], o[2]),
                Vec3::new(px[k], py[k], pz[k]),
            );
        }
    }

    /// See the module's header; `gap2` as `super::nearest_point_euclidean_3d` takes it.
    #[target_feature(enable = "avx2")]
    pub fn nearest_point_euclidean_3d(
        cell: Vec3,
        local: Vec3,
        randomness: f32,
        gap2: &[[f32; 3]; 3],
    ) -> (f32, Vec3, Vec3) {
        let mut nearest = (f32::MAX, usize::MAX, Vec3::ZERO, Vec3::ZERO);
        let up = |l: f32| !(l < 0.5);
        let sides =
            up(local.x) as usize | (up(local.y) as usize) << 1 | (up(local.z) as usize) << 2;
        let side = |a: usize| _mm256_set1_ps(if sides >> a & 1 != 0 { 1.0 } else { -1.0 });
        // Lane dx + 2 dy + 4 dz: offset (dx sx, dy sy, dz sz), each zero a +0.
        let zero = _mm256_setzero_ps();
        let block = [
            _mm256_blend_ps::<0xAA>(zero, side(0)),
            _mm256_blend_ps::<0xCC>(zero, side(1)),
            _mm256_blend_ps::<0xF0>(zero, side(2)),
        ];
        let (index, done) = &BLOCKS[sides];
        nearest_of_eight(index, block, cell, local, randomness, &mut nearest);
        // The other cells whose box lies within the bound (squared, without the root: its
        // margin covers the rounding), as `super::nearest_point_euclidean_3d` tests them.
        let bound = nearest.0 * (1.0 + 1e-6);
        let far = _mm256_set1_ps(bound * bound);
        let axis = |g: &[f32; 3]| _mm256_setr_ps(g[0], g[1], g[2], f32::MAX, 0.0, 0.0, 0.0, 0.0);
        let (g0, g1, g2) = (axis(&gap2[0]), axis(&gap2[1]), axis(&gap2[2]));
        let mut within = 0u32;
        for (group, picks) in GAP_PICKS.iter().enumerate() {
            let pick = |g: __m256, axis: usize| {
                // SAFETY: an unaligned load of eight words from eight words.
                let i = unsafe { _mm256_loadu_si256(picks[axis].as_ptr() as *const __m256i) };
                _mm256_permutevar8x32_ps(g, i)
            };
            let sum = _mm256_add_ps(_mm256_add_ps(pick(g0, 0), pick(g1, 1)), pick(g2, 2));
            // Not farther: as the test that skips a cell, NaN included.
            let near = _mm256_cmp_ps::<_CMP_NGT_UQ>(sum, far);
            within |= (_mm256_movemask_ps(near) as u32) << (8 * group);
        }
        let mut left = within & !*done & ((1 << 27) - 1);
        while left != 0 {
            let mut index = [0usize; 8];
            let mut offsets = [[0.0f32; 8]; 3];
            let mut n = 0;
            while left != 0 && n < 8 {
                let i = left.trailing_zeros() as usize;
                left &= left - 1;
                index[n] = i;
                for (lane, o) in offsets.iter_mut().zip(OFFSETS[i]) {
                    lane[n] = o;
                }
                n += 1;
            }
            // The empty lanes repeat the batch's first cell (a tie with itself: no change).
            for k in n..8 {
                index[k] = index[0];
                for lane in &mut offsets {
                    lane[k] = lane[0];
                }
            }
            // SAFETY: unaligned loads of eight floats from eight floats.
            let lanes = offsets.map(|o| unsafe { _mm256_loadu_ps(o.as_ptr()) });
            nearest_of_eight(&index, lanes, cell, local, randomness, &mut nearest);
        }
        (nearest.0, nearest.2, nearest.3)
    }
}

/// Cycles' `fractal_voronoi_x_fx` with the node's normalisation: (distance, colour, position).
/// Without `color` the F1 colour is not computed (zero).
fn voronoi(p: &VoronoiParams, coord: Vec3, with_color: bool) -> (f32, Vec3, Vec3) {
    let r = 0.5 + 0.5 * p.randomness;
    let corner = if p.kind.dimensions == 2 {
        Vec3::new(r, r, 0.0)
    } else {
        Vec3::splat(r)
    };
    let f2 = if p.kind.feature == VoronoiFeature::F2 {
        2.0
    } else {
        1.0
    };
    let max_distance = voronoi_distance(p.kind.metric, p.exponent, Vec3::ZERO, corner) * f2;
    let mut amplitude = 1.0f32;
    let mut max_amplitude = 0.0f32;
    let mut scale = 1.0f32;
    let (mut distance, mut color, mut position) = (0.0f32, Vec3::ZERO, Vec3::ZERO);
    let zero_input = p.detail == 0.0 || p.roughness == 0.0;
    let octaves = p.detail.ceil() as i32;
    for i in 0..=octaves {
        let (d, c, pos) = voronoi_octave(p, coord * scale, with_color);
        if zero_input {
            max_amplitude = 1.0;
            (distance, color, position) = (d, c, pos);
            break;
        }
        if i as f32 <= p.detail {
            max_amplitude += amplitude;
            distance += d * amplitude;
            color += c * amplitude;
            position = position.lerp(pos / scale, amplitude);
            scale *= p.lacunarity;
            amplitude *= p.roughness;
        } else {
            let rmd = p.detail - p.detail.floor();
            if rmd != 0.0 {
                max_amplitude = lerp(max_amplitude, max_amplitude + amplitude, rmd);
                distance = lerp(distance, distance + d * amplitude, rmd);
                color = color.lerp(color + c * amplitude, rmd);
                position = position.lerp(position.lerp(pos / scale, amplitude), rmd);
            }
        }
    }
    if p.kind.normalize {
        distance /= max_amplitude * max_distance;
        color /= max_amplitude;
    }
    let position = if p.scale != 0.0 {
        position / p.scale
    } else {
        Vec3::ZERO
    };
    (distance, color, position)
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn at_generated(p: Vec3) -> ShadingInputs {
        ShadingInputs::at_point(PointInputs {
            generated: p,
            ..PointInputs::default()
        })
    }

    /// Shading inputs with `normal` at the three `positions` (the point, then its offsets).
    fn at_positions(positions: [Vec3; 3], normal: Vec3) -> ShadingInputs {
        ShadingInputs {
            points: positions.map(|position| PointInputs {
                position,
                ..PointInputs::default()
            }),
            normal,
            ..ShadingInputs::default()
        }
    }

    fn emission_of(tree: Value, at: &ShadingInputs) -> Vec3 {
        let mut w = Vec::new();
        let program = compile(&tree, 0, &mut w).expect("compiles");
        program.eval(at, &[], 0.5).emission
    }

    #[test]
    fn displacement_bumps_the_normal_the_surface_reads() {
        // Height = x along the normal, as the add-on writes "Bump Only": the normal tilts to
        // (−1, 0, 1)/√2, and the surface's Geometry Normal (into Emission) reads it.
        let displacement = json!({"nodes": [
            {"name": "G", "type": "ShaderNodeNewGeometry"},
            {"name": "X", "type": "ShaderNodeSeparateXYZ",
             "inputs": {"Vector": {"node": 0, "output": "Position"}}},
            {"name": "D", "type": "ShaderNodeDisplacement", "space": "WORLD",
             "inputs": {"Height": {"node": 1, "output": "X"}, "Midlevel": 0.0, "Scale": 1.0}},
            {"name": "N", "type": "ShaderNodeNewGeometry"},
            {"name": "H", "type": "ShaderNodeVectorMath", "operation": "DOT_PRODUCT",
             "inputs": {"Vector": {"node": 2, "output": "Displacement"},
                        "Vector_001": {"node": 3, "output": "Normal"}}},
            {"name": "B", "type": "ShaderNodeBump", "inputs": {
                "Strength": 1.0, "Distance": 1.0, "Height": {"node": 4, "output": "Value"}}}
        ], "output": {"node": 5, "output": "Normal"}});
        let tree = json!({"nodes": [
            {"name": "G", "type": "ShaderNodeNewGeometry"},
            {"name": "E", "type": "ShaderNodeEmission",
             "inputs": {"Color": {"node": 0, "output": "Normal"}, "Strength": 1.0}}
        ], "output": {"node": 1, "output": "Emission"}, "displacement": displacement});
        let mut w = Vec::new();
        let program = compile(&tree, 0, &mut w).expect("compiles");
        assert!(w.is_empty() && program.needs_offsets, "{w:?}");
        let at = at_positions([Vec3::ZERO, Vec3::X * 1e-3, Vec3::Y * 1e-3], Vec3::Z);
        let c = program.eval(&at, &[], 0.5);
        let expected = Vec3::new(-1.0, 0.0, 1.0).normalize();
        assert!((c.emission - expected).length() < 1e-3, "{}", c.emission);
        assert!((c.normal - expected).length() < 1e-3, "{}", c.normal);
    }

    #[test]
    fn normal_map_weighs_tangent_bitangent_and_normal() {
        let at = ShadingInputs {
            normal: Vec3::Z,
            ..ShadingInputs::default()
        };
        let point = PointInputs {
            tangent: Vec4::new(0.0, 1.0, 0.0, -1.0),
            ..PointInputs::default()
        };
        let flat = Vec3::new(0.5, 0.5, 1.0);
        let map = |c: Vec3, strength: f32, at: &ShadingInputs, point: &PointInputs| {
            normal_map(NormalMapSpace::Tangent, c, strength, at, point)
        };
        assert_eq!(map(flat, 1.0, &at, &point), Vec3::Z);
        // Bitangent = sign × N × T = −(Z × Y) = +X.
        let n = map(Vec3::new(0.5, 1.0, 0.5), 1.0, &at, &point);
        assert!((n - Vec3::X).length() < 1e-6, "{n}");
        let n = map(Vec3::new(1.0, 0.5, 0.5), 1.0, &at, &point);
        assert!((n - Vec3::Y).length() < 1e-6, "{n}");
        // Seen from behind, the map is applied on the winding's side and turned to the viewer.
        let behind = ShadingInputs {
            normal: -Vec3::Z,
            backfacing: true,
            ..at
        };
        let n = map(Vec3::new(1.0, 0.5, 0.5), 1.0, &behind, &point);
        assert!((n + Vec3::Y).length() < 1e-6, "{n}");
        // Strength 0 keeps the shading normal; no tangents: the shading normal.
        let world = Vec3::new(1.0, 0.5, 0.5);
        let n = normal_map(NormalMapSpace::World, world, 0.0, &at, &point);
        assert!((n - Vec3::Z).length() < 1e-6);
        let tilted = Vec3::new(1.0, 0.5, 0.5);
        assert_eq!(map(tilted, 1.0, &at, &PointInputs::default()), Vec3::Z);
    }

    #[test]
    fn ray_path_counts_bounces_as_cycles_path_state_does() {
        // Camera → transparent → glossy reflection → smooth refraction → diffuse reflection.
        let p = RayPath::camera().after(Scattering::Transparent, true);
        assert_eq!((p.flags, p.depth, p.transparent), (RayPath::CAMERA, 0, 1));
        let p = p.after(Scattering::Glossy, false);
        assert_eq!(p.flags, RayPath::GLOSSY | RayPath::REFLECT);
        let p = p.after(Scattering::Singular, true);
        assert_eq!(
            p.flags,
            RayPath::GLOSSY | RayPath::SINGULAR | RayPath::TRANSMIT
        );
        let p = p.after(Scattering::Diffuse, false);
        assert_eq!(p.flags, RayPath::DIFFUSE | RayPath::REFLECT);
        assert_eq!(
            (p.depth, p.diffuse, p.glossy, p.transmission, p.transparent),
            (3, 1, 1, 1, 1)
        );
        // Shadow rays and sampled emitters: their own kind, one bounce further.
        assert_eq!((p.shadow().flags, p.shadow().depth), (RayPath::SHADOW, 4));
        assert_eq!((p.emission().flags, p.emission().depth), (0, 4));
        assert_eq!(p.emission().diffuse, 1);
    }

    #[test]
    fn light_path_outputs_read_the_ray_path() {
        let output = |name: &str, path: RayPath| {
            let tree = json!({"nodes": [
                {"name": "L", "type": "ShaderNodeLightPath"},
                {"name": "E", "type": "ShaderNodeEmission",
                 "inputs": {"Color": {"node": 0, "output": name}, "Strength": 1.0}}
            ], "output": {"node": 1, "output": "Emission"}});
            let at = ShadingInputs {
                path,
                ray_length: 2.5,
                ..ShadingInputs::default()
            };
            emission_of(tree, &at).x
        };
        let p = RayPath::camera()
            .after(Scattering::Transparent, true)
            .after(Scattering::Transparent, true)
            .after(Scattering::Singular, true)
            .after(Scattering::Diffuse, false);
        let expected = [
            ("Is Camera Ray", 0.0),
            ("Is Shadow Ray", 0.0),
            ("Is Diffuse Ray", 1.0),
            ("Is Glossy Ray", 0.0),
            ("Is Singular Ray", 0.0),
            ("Is Reflection Ray", 1.0),
            ("Is Transmission Ray", 0.0),
            ("Is Volume Scatter Ray", 0.0),
            ("Ray Length", 2.5),
            ("Ray Depth", 2.0),
            ("Diffuse Depth", 1.0),
            ("Glossy Depth", 0.0),
            ("Transparent Depth", 2.0),
            ("Transmission Depth", 1.0),
        ];
        for (name, value) in expected {
            assert_eq!(output(name, p), value, "{name}");
        }
        assert_eq!(output("Is Shadow Ray", p.shadow()), 1.0);
        assert_eq!(output("Is Camera Ray", RayPath::camera()), 1.0);
        // Only the outputs of a camera path's state make the tree depend on it.
        for (name, depends) in [
            ("Is Camera Ray", false),
            ("Is Shadow Ray", false),
            ("Ray Length", false),
            ("Is Glossy Ray", true),
            ("Transparent Depth", true),
        ] {
            let tree = json!({"nodes": [
                {"name": "L", "type": "ShaderNodeLightPath"},
                {"name": "E", "type": "ShaderNodeEmission",
                 "inputs": {"Color": {"node": 0, "output": name}}}
            ], "output": {"node": 1, "output": "Emission"}});
            let program = compile(&tree, 0, &mut Vec::new()).expect("compiles");
            assert_eq!(program.reads_ray_state, depends, "{name}");
        }
    }

    #[test]
    fn transparent_closures_let_shadows_through() {
        let tree = |alpha: Value| {
            json!({"nodes": [
                {"name": "P", "type": "ShaderNodeBsdfPrincipled", "inputs": {"Alpha": alpha}}
            ], "output": {"node": 0, "output": "BSDF"}})
        };
        let compiled = |t: Value| compile(&t, 0, &mut Vec::new()).expect("compiles");
        assert!(!compiled(tree(json!(1.0))).shadow_transparent);
        assert!(compiled(tree(json!(0.5))).shadow_transparent);
        let transparent = json!({"nodes": [
            {"name": "T", "type": "ShaderNodeBsdfTransparent", "inputs": {"Color": [1, 1, 1, 1]}}
        ], "output": {"node": 0, "output": "BSDF"}});
        let program = compiled(transparent);
        assert!(program.shadow_transparent);
        let c = program.eval(&ShadingInputs::default(), &[], 0.5);
        assert!(c.transparent && c.transmission == 1.0);
    }

    #[test]
    fn blackbody_matches_cycles_values() {
        // Values of Cycles' fit at 6500 K and 3315 K, and its constants past both ends.
        let close = |a: Vec3, b: Vec3| (a - b).abs().max_element() < 2e-4;
        assert!(close(
            blackbody(6500.0),
            Vec3::new(1.042_552, 0.984_052_5, 1.035_271_5)
        ));
        assert!(close(
            blackbody(3315.0),
            Vec3::new(1.631_801, 0.877_736, 0.355_867)
        ));
        assert_eq!(blackbody(20000.0), blackbody(12000.0));
        assert_eq!(blackbody(100.0).x, 5.413_294_5);
        // Nearly continuous across the fit's intervals.
        for edge in [965.0, 1167.0, 1449.0, 1902.0, 3315.0, 6365.0] {
            let jump = (blackbody(edge - 0.01) - blackbody(edge))
                .abs()
                .max_element();
            assert!(jump < 5e-3, "{edge}: {jump}");
        }
    }

    #[test]
    fn brick_tints_stay_in_range_and_mortar_lines_the_bricks() {
        let layout = BrickLayout {
            offset: 0.5,
            offset_frequency: 2,
            squash: 1.0,
            squash_frequency: 2,
        };
        let sizes = [0.02, 0.0, 0.0, 0.5, 0.25];
        let mut tints = Vec::new();
        for i in 0..200 {
            let p = Vec3::new(i as f32 * 0.37 - 30.0, i as f32 * 0.11 - 10.0, 0.0);
            let (tint, _) = brick(&layout, p, sizes);
            assert!((0.0..1.0).contains(&tint));
            tints.push(tint);
        }
        assert!(tints.iter().any(|&t| t != tints[0]), "bricks differ");
        // Inside a brick no mortar; on its edge (hard mortar) full mortar.
        assert_eq!(brick(&layout, Vec3::new(0.25, 0.35, 0.0), sizes).1, 0.0);
        assert_eq!(brick(&layout, Vec3::new(0.01, 0.35, 0.0), sizes).1, 1.0);
        // Row 0 is shifted by half a brick: its x = 0.25 is an edge.
        assert_eq!(brick(&layout, Vec3::new(0.25, 0.1, 0.0), sizes).1, 1.0);
    }

    #[test]
    fn white_noise_colour_starts_with_its_value_and_magic_without_distortion_is_grey() {
        let p = Vec3::new(1.0, 2.0, 3.0);
        for d in 1..=4 {
            let (v, c) = white_noise(d, p, 0.5);
            assert_eq!(v, c.x);
            assert!((0.0..=1.0).contains(&v) && c.y != c.z);
        }
        assert_ne!(white_noise(3, p, 0.0).0, white_noise(2, p, 0.0).0);
        assert_eq!(magic(p, 5.0, 4, 0.0), Vec3::splat(0.5));
    }

    #[test]
    fn checker_alternates_cells_as_cycles() {
        assert_eq!(checker(Vec3::new(0.5, 0.5, 0.5)), 0.0);
        assert_eq!(checker(Vec3::new(1.5, 0.5, 0.5)), 1.0);
        assert_eq!(checker(Vec3::new(0.5, 1.5, 0.5)), 1.0);
        assert_eq!(checker(Vec3::new(1.5, 1.5, 0.5)), 0.0);
        assert_eq!(checker(Vec3::new(0.5, 0.5, 1.5)), 1.0);
        // Negative cells mirror: |floor(−0.5)| = 1.
        assert_eq!(checker(Vec3::new(-0.5, 0.5, 0.5)), 1.0);
    }

    #[test]
    fn gradient_kinds_at_known_points() {
        let p = Vec3::new(0.25, 0.75, 0.0);
        assert_eq!(gradient(GradientKind::Linear, p), 0.25);
        assert_eq!(gradient(GradientKind::Quadratic, p), 0.0625);
        assert_eq!(gradient(GradientKind::Diagonal, p), 0.5);
        assert!((gradient(GradientKind::Easing, p) - 0.15625).abs() < 1e-6);
        assert!((gradient(GradientKind::Radial, Vec3::new(0.0, 1.0, 0.0)) - 0.75).abs() < 1e-6);
        assert_eq!(
            gradient(GradientKind::Linear, Vec3::new(2.0, 0.0, 0.0)),
            1.0
        );
        assert!(
            (gradient(GradientKind::Spherical, Vec3::new(0.5, 0.0, 0.0)) - 0.499_999).abs() < 1e-6
        );
    }

    #[test]
    fn math_ops_follow_blender() {
        assert_eq!(math(MathOp::Divide, 1.0, 0.0, 0.0), 0.0);
        assert_eq!(math(MathOp::Power, -2.0, 3.0, 0.0), -8.0);
        assert_eq!(math(MathOp::Power, -2.0, 0.5, 0.0), 0.0);
        assert_eq!(math(MathOp::FlooredModulo, -1.0, 3.0, 0.0), 2.0);
        assert_eq!(math(MathOp::Modulo, -1.0, 3.0, 0.0), -1.0);
        assert_eq!(math(MathOp::Wrap, 1.25, 1.0, 0.0), 0.25);
        assert_eq!(math(MathOp::PingPong, 1.5, 1.0, 0.0), 0.5);
        assert_eq!(math(MathOp::Sqrt, -4.0, 0.0, 0.0), 0.0);
        assert_eq!(math(MathOp::Compare, 1.0, 1.05, 0.1), 1.0);
        assert_eq!(math(MathOp::Round, -0.5, 0.0, 0.0), 0.0);
    }

    #[test]
    fn color_ramp_interpolates_the_table_as_cycles() {
        let table = vec![Vec4::ZERO, Vec4::ONE, Vec4::new(1.0, 0.0, 0.0, 1.0)];
        assert_eq!(ramp_lookup(&table, 0.25, true), Vec4::splat(0.5));
        assert_eq!(ramp_lookup(&table, 0.25, false), Vec4::ZERO);
        assert_eq!(
            ramp_lookup(&table, 0.75, true),
            Vec4::new(1.0, 0.5, 0.5, 1.0)
        );
        assert_eq!(ramp_lookup(&table, 7.0, true), table[2]);
        assert_eq!(ramp_lookup(&table, f32::NAN, true), table[0]);
        // Curves extrapolate linearly beyond the table (one entry step per 1/(n − 1)).
        assert_eq!(ramp_extrapolated(&table, -0.5), Vec4::splat(-1.0));
        assert_eq!(
            ramp_extrapolated(&table, 1.5),
            Vec4::new(1.0, -1.0, -1.0, 1.0)
        );
    }

    #[test]
    fn noise_is_in_range_and_matches_known_structure() {
        let f = Fractal {
            detail: 2.0,
            roughness: 0.5,
            lacunarity: 2.0,
            normalize: true,
        };
        // Perlin noise is zero at lattice points: one octave of normalized fBm gives 0.5 there.
        let one = Fractal { detail: 0.0, ..f };
        assert!((fbm(3, Vec3::new(3.0, -2.0, 7.0), 0.0, &one) - 0.5).abs() < 1e-6);
        let mut lo = f32::MAX;
        let mut hi = f32::MIN;
        for i in 0..2000 {
            let p = Vec3::new(i as f32 * 0.137, i as f32 * 0.071, i as f32 * 0.029);
            let v = fbm(3, p, 0.0, &f);
            lo = lo.min(v);
            hi = hi.max(v);
        }
        assert!(lo > 0.0 && hi < 1.0 && hi - lo > 0.3, "{lo} {hi}");
        // Continuity: nearby points give nearby values.
        let a = fbm(3, Vec3::new(0.3, 0.4, 0.5), 0.0, &f);
        let b = fbm(3, Vec3::new(0.3001, 0.4, 0.5), 0.0, &f);
        assert!((a - b).abs() < 1e-3);
    }

    #[test]
    fn checker_tree_into_emission() {
        let tree = json!({
            "nodes": [
                {"name": "Checker", "type": "ShaderNodeTexChecker",
                 "inputs": {"Color1": [1.0, 0.0, 0.0, 1.0], "Color2": [0.0, 0.0, 1.0, 1.0],
                            "Scale": 2.0}},
                {"name": "Emission", "type": "ShaderNodeEmission",
                 "inputs": {"Color": {"node": 0, "output": "Color"}, "Strength": 3.0}}
            ],
            "output": {"node": 1, "output": "Emission"}
        });
        let e = emission_of(tree.clone(), &at_generated(Vec3::new(0.1, 0.1, 0.1)));
        assert_eq!(e, Vec3::new(0.0, 0.0, 3.0));
        let e = emission_of(tree, &at_generated(Vec3::new(0.6, 0.1, 0.1)));
        assert_eq!(e, Vec3::new(3.0, 0.0, 0.0));
    }

    #[test]
    fn math_and_conversions_in_a_tree() {
        // Separate the UV, multiply u by v, feed the float into a colour (float → colour).
        let tree = json!({
            "nodes": [
                {"name": "UV", "type": "ShaderNodeUVMap", "uv_set": 2},
                {"name": "Sep", "type": "ShaderNodeSeparateXYZ",
                 "inputs": {"Vector": {"node": 0, "output": "UV"}}},
                {"name": "Mul", "type": "ShaderNodeMath", "operation": "MULTIPLY",
                 "inputs": {"Value": {"node": 1, "output": "X"},
                            "Value_001": {"node": 1, "output": "Y"}}},
                {"name": "Col", "type": "ShaderNodeRGB", "value": [0.0, 1.0, 0.0, 1.0]},
                {"name": "Gray", "type": "ShaderNodeMath", "operation": "ADD",
                 "inputs": {"Value": {"node": 3, "output": "Color"}, "Value_001": 0.0}},
                {"name": "Sum", "type": "ShaderNodeMath", "operation": "ADD",
                 "inputs": {"Value": {"node": 2, "output": "Value"},
                            "Value_001": {"node": 4, "output": "Value"}}},
                {"name": "Emission", "type": "ShaderNodeEmission",
                 "inputs": {"Color": {"node": 5, "output": "Value"}}}
            ],
            "output": {"node": 6, "output": "Emission"}
        });
        let at = ShadingInputs::at_point(PointInputs {
            uv: [Vec2::ZERO, Vec2::ONE, Vec2::new(0.5, 0.25), Vec2::ONE],
            ..PointInputs::default()
        });
        let e = emission_of(tree, &at);
        assert!(
            (e - Vec3::splat(0.125 + 0.7152)).abs().max_element() < 1e-6,
            "{e}"
        );
    }

    #[test]
    fn mix_shader_picks_by_factor_and_mixes_emission() {
        let tree = json!({
            "nodes": [
                {"name": "D", "type": "ShaderNodeBsdfDiffuse", "inputs": {"Color": [1.0, 0.0, 0.0, 1.0]}},
                {"name": "G", "type": "ShaderNodeBsdfGlossy", "inputs": {"Color": [0.0, 1.0, 0.0, 1.0], "Roughness": 0.2}},
                {"name": "E", "type": "ShaderNodeEmission", "inputs": {"Strength": 2.0}},
                {"name": "M", "type": "ShaderNodeMixShader", "inputs": {"Fac": 0.25,
                    "Shader": {"node": 0, "output": "BSDF"}, "Shader_001": {"node": 1, "output": "BSDF"}}},
                {"name": "A", "type": "ShaderNodeAddShader", "inputs": {
                    "Shader": {"node": 3, "output": "Shader"}, "Shader_001": {"node": 2, "output": "Emission"}}}
            ],
            "output": {"node": 4, "output": "Shader"}
        });
        let mut w = Vec::new();
        let p = compile(&tree, 0, &mut w).unwrap();
        let at = ShadingInputs::default();
        let n = 10_000;
        let mut metal = 0;
        for i in 0..n {
            let c = p.eval(&at, &[], (i as f32 + 0.5) / n as f32);
            assert_eq!(c.emission, Vec3::splat(2.0));
            if c.metallic == 1.0 {
                assert_eq!(c.base_color, Vec3::new(0.0, 1.0, 0.0));
                metal += 1;
            } else {
                assert_eq!(c.base_color, Vec3::new(1.0, 0.0, 0.0));
                assert_eq!(c.specular_color, Vec3::ZERO);
            }
        }
        assert_eq!(metal, n / 4);
    }

    #[test]
    fn invalid_programs_are_refused_with_a_reason() {
        let mut w = Vec::new();
        let forward = json!({"nodes": [
            {"name": "E", "type": "ShaderNodeEmission", "inputs": {"Color": {"node": 1, "output": "Color"}}},
            {"name": "C", "type": "ShaderNodeRGB", "value": [1, 1, 1, 1]}
        ], "output": {"node": 0, "output": "Emission"}});
        let e = compile(&forward, 0, &mut w).unwrap_err();
        assert!(e.contains("not earlier"), "{e}");
        let value_as_shader = json!({"nodes": [
            {"name": "C", "type": "ShaderNodeRGB", "value": [1, 1, 1, 1]}
        ], "output": {"node": 0, "output": "Color"}});
        assert!(compile(&value_as_shader, 0, &mut w)
            .unwrap_err()
            .contains("shader output"));
        assert!(compile(&json!({"nodes": 3}), 0, &mut w).is_err());
        let bad_ramp =
            json!({"nodes": [{"name": "R", "type": "ShaderNodeValToRGB", "table": [1]}]});
        assert!(compile(&bad_ramp, 0, &mut w)
            .unwrap_err()
            .contains("Color Ramp"));
    }

    #[test]
    fn unknown_nodes_warn_and_fall_back() {
        let mut w = Vec::new();
        let tree = json!({"nodes": [
            {"name": "Gabor", "type": "ShaderNodeTexGabor"},
            {"name": "E", "type": "ShaderNodeEmission", "inputs": {
                "Color": {"node": 0, "output": "Color"}, "Strength": 1.0}}
        ], "output": {"node": 1, "output": "Emission"}});
        let p = compile(&tree, 0, &mut w).unwrap();
        assert_eq!(w.len(), 1);
        assert!(w[0].contains("Gabor"), "{w:?}");
        // The Emission colour's default (white) is used.
        assert_eq!(
            p.eval(&ShadingInputs::default(), &[], 0.5).emission,
            Vec3::ONE
        );
    }

    #[test]
    fn bump_tilts_the_normal_against_the_height_gradient() {
        // Height = world x: the gradient is +X, so with distance 1 the normal leans to −X by
        // 45°; the Height subtree is copied for the two offset points.
        let tree = json!({"nodes": [
            {"name": "Geometry", "type": "ShaderNodeNewGeometry"},
            {"name": "Sep", "type": "ShaderNodeSeparateXYZ",
             "inputs": {"Vector": {"node": 0, "output": "Position"}}},
            {"name": "Bump", "type": "ShaderNodeBump",
             "inputs": {"Distance": 1.0, "Strength": 1.0,
                        "Height": {"node": 1, "output": "X"}}},
            {"name": "D", "type": "ShaderNodeBsdfDiffuse",
             "inputs": {"Normal": {"node": 2, "output": "Normal"}}}
        ], "output": {"node": 3, "output": "BSDF"}});
        let mut w = Vec::new();
        let p = compile(&tree, 0, &mut w).unwrap();
        assert!(p.needs_offsets && w.is_empty());
        let e = 1e-3;
        let c = p.eval(
            &at_positions([Vec3::ZERO, Vec3::X * e, Vec3::Y * e], Vec3::Z),
            &[],
            0.5,
        );
        let want = Vec3::new(-1.0, 0.0, 1.0).normalize();
        assert!((c.normal - want).length() < 1e-4, "{}", c.normal);
        // Without offsets (all three points equal) the normal is the surface's.
        let flat = p.eval(&at_positions([Vec3::ZERO; 3], Vec3::Z), &[], 0.5);
        assert!((flat.normal - Vec3::Z).length() < 1e-6);
    }

    #[test]
    fn noise_at_a_bumps_three_points_is_the_scalar_noise_bit_for_bit() {
        // Points a small step apart (mostly one lattice cell), some across cell walls, far
        // ones (fmod), with and without distortion and colour, whole and fractional detail.
        let mut rng = crate::rng::Rng::new(9);
        let mut shared_cells = 0;
        for k in 0..20_000 {
            let scale = [1.0, 10.0, 300.0, 2.0e5][k % 4];
            let c = |rng: &mut crate::rng::Rng| (rng.uniform() * 2.0 - 1.0) * scale;
            let p = Vec3::new(c(&mut rng), c(&mut rng), c(&mut rng));
            let step = [1e-4, 1e-2, 0.3][k % 3];
            let points = [p, p + Vec3::X * step, p + Vec3::Y * step];
            let f = Fractal {
                detail: [0.0, 2.0, 3.5][k % 3],
                roughness: 0.5,
                lacunarity: 2.0,
                normalize: k % 2 == 0,
            };
            let distortion = [0.0, 0.0, 1.5][(k / 3) % 3];
            let color = k % 5 == 0;
            let inputs = points.map(|p| (p, 0.0, f, distortion));
            let fused = noise_texture_at3(3, &inputs, color);
            for (q, (fac, col)) in points.iter().zip(fused) {
                let (want, want_col) = noise_texture(3, *q, 0.0, &f, distortion, color);
                assert_eq!(fac.to_bits(), want.to_bits(), "{q:?} {k}");
                assert_eq!(
                    col.to_array().map(f32::to_bits),
                    want_col.to_array().map(f32::to_bits)
                );
            }
            let cell = |v: Vec3| v.floor();
            shared_cells += (cell(points[1]) == cell(p) && cell(points[2]) == cell(p)) as u32;
        }
        // Both paths ran: the shared-cell lanes and the scalar fallback.
        assert!((5_000..19_000).contains(&shared_cells), "{shared_cells}");
    }

    /// Random coordinates at several scales, with −0, integers and cell walls mixed in.
    #[cfg(target_arch = "x86_64")]
    fn awkward_coordinate(rng: &mut crate::rng::Rng, k: usize) -> f32 {
        let scale = [1.0, 10.0, 300.0, 9.0e4][k % 4];
        let v = (rng.uniform() * 2.0 - 1.0) * scale;
        match (k / 4) % 7 {
            0 => -0.0,
            1 => v.floor(),
            2 => v.floor() - f32::EPSILON * v.abs(),
            _ => v,
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn avx2_perlin3_is_perlin3_bit_for_bit() {
        if !has_avx2() {
            return;
        }
        let mut rng = crate::rng::Rng::new(21);
        for k in 0..200_000 {
            let [x, y, z] = [k, k / 3, k / 5].map(|j| awkward_coordinate(&mut rng, j));
            // SAFETY: AVX2 is present (checked above).
            let got = unsafe { noise_avx2::perlin3(x, y, z) };
            assert_eq!(got.to_bits(), perlin3(x, y, z).to_bits(), "{x} {y} {z}");
            let p = Vec3::new(x, y, z) * 37.0;
            let want = 0.9820 * perlin3(p.x % 100_000.0, p.y % 100_000.0, p.z % 100_000.0);
            if p.abs().max_element() < 100_000.0 {
                assert_eq!(snoise(3, p, 0.0).to_bits(), want.to_bits());
            }
            // fBm: the octaves inlined, past the period too.
            let f = Fractal {
                detail: [0.0, 2.0, 3.5, 15.0][k % 4],
                roughness: 0.5,
                lacunarity: [2.0, 1.9][k % 2],
                normalize: k % 3 == 0,
            };
            let m = |v: f32| {
                if v.abs() < 100_000.0 {
                    v
                } else if v.abs() < 1_000_000.0 {
                    v % 100_000.0
                } else {
                    v % 100_000.0 + 0.5
                }
            };
            let reference = fractal_sum(&f, 0.0, |s| {
                let q = s * p;
                0.9820 * perlin3(m(q.x), m(q.y), m(q.z))
            });
            assert_eq!(fbm(3, p, 0.0, &f).to_bits(), reference.to_bits(), "{p}");
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn avx2_octave_pairs_are_snoise3_lanes_bit_for_bit() {
        if !has_avx2() {
            return;
        }
        let mut rng = crate::rng::Rng::new(22);
        for k in 0..100_000 {
            let set = |rng: &mut crate::rng::Rng, j: usize| {
                let p = [j, j + 1, j + 2].map(|i| awkward_coordinate(rng, i));
                let step = [1e-4, 1e-2, 0.3][j % 3];
                let (x, y, z) = (
                    lanes([p[0], p[0] + step, p[0]]),
                    lanes([p[1], p[1], p[1] + step]),
                    Vec4::splat(p[2]),
                );
                (x, y, z)
            };
            let (a, b) = (set(&mut rng, k), set(&mut rng, k / 2 + 1));
            // SAFETY: AVX2 is present (checked above).
            let one = unsafe { noise_avx2::snoise3_one(a.0, a.1, a.2) };
            assert_eq!(
                one.to_array().map(f32::to_bits),
                snoise3_lanes(a.0, a.1, a.2).to_array().map(f32::to_bits)
            );
            // SAFETY: AVX2 is present (checked above).
            let got = unsafe { noise_avx2::snoise3_pair([a.0, b.0], [a.1, b.1], [a.2, b.2]) };
            for (g, (x, y, z)) in got.iter().zip([a, b]) {
                let want = snoise3_lanes(x, y, z);
                assert_eq!(
                    g.to_array().map(f32::to_bits),
                    want.to_array().map(f32::to_bits),
                    "{x} {y} {z}"
                );
            }
        }
        // The octaves in pairs sum as one at a time.
        for k in 0..20_000 {
            let f = Fractal {
                detail: [0.0, 1.0, 2.0, 2.5, 3.25, 15.0][k % 6],
                roughness: 0.5,
                lacunarity: [2.0, 1.7][k % 2],
                normalize: k % 3 == 0,
            };
            let p = [0, 1, 2].map(|j| awkward_coordinate(&mut rng, k + j) * 0.01);
            let (x, y, z) = (
                lanes([p[0], p[0] + 1e-4, p[0]]),
                Vec4::splat(p[1]),
                Vec4::splat(p[2]),
            );
            let want = fractal_sum(&f, Vec4::ZERO, |s| snoise3_lanes(s * x, s * y, s * z));
            assert_eq!(
                fbm3_lanes(x, y, z, &f).to_array().map(f32::to_bits),
                want.to_array().map(f32::to_bits)
            );
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn avx2_voronoi_search_is_the_four_lane_search_bit_for_bit() {
        if !has_avx2() {
            return;
        }
        let mut rng = crate::rng::Rng::new(23);
        for k in 0..200_000 {
            let coord =
                Vec3::from_array([k, k / 3, k / 5].map(|j| awkward_coordinate(&mut rng, j)));
            let randomness = [1.0, 0.5, 0.0, 0.93, 1e-3][k % 5];
            let cell = Vec3::new(floor(coord.x), floor(coord.y), floor(coord.z));
            let local = coord - cell;
            let gap2 = [local.x, local.y, local.z].map(|l| {
                [-1.0f32, 0.0, 1.0].map(|o| {
                    let g = (o - l).max(l - (o + randomness)).max(0.0);
                    g * g
                })
            });
            // SAFETY: AVX2 is present (checked above).
            let got =
                unsafe { voronoi_avx2::nearest_point_euclidean_3d(cell, local, randomness, &gap2) };
            let want = nearest_point_euclidean_3d_lanes4(cell, local, randomness, &gap2);
            let bits = |(d, o, p): (f32, Vec3, Vec3)| {
                (
                    d.to_bits(),
                    o.to_array().map(f32::to_bits),
                    p.to_array().map(f32::to_bits),
                )
            };
            assert_eq!(bits(got), bits(want), "{coord} {randomness}");
        }
    }

    /// Blender's own Noise and Voronoi values at chosen points (near the origin, negative,
    /// −0, on cell walls, large, past Noise's period), recorded by
    /// `tests/blender/record_patterns.py` with Blender's geometry nodes, which evaluate the
    /// same definitions as Cycles' shader nodes.
    fn blender_patterns() -> (Value, Vec<Vec3>) {
        let doc: Value =
            serde_json::from_str(include_str!("../../tests/data/blender_patterns.json"))
                .expect("the recorded patterns are JSON");
        let points = doc["points"]
            .as_array()
            .unwrap()
            .iter()
            .map(vec3_of)
            .collect();
        (doc, points)
    }

    fn dims_of(config: &Value) -> u8 {
        if config["dimensions"] == "2D" {
            2
        } else {
            3
        }
    }

    fn vec3_of(v: &Value) -> Vec3 {
        let c = |k: usize| v[k].as_f64().expect("a number") as f32;
        Vec3::new(c(0), c(1), c(2))
    }

    /// |a − b| within 2e-5 of the larger magnitude (at least 1): Blender's build may contract
    /// multiply-adds where Photon does not.
    fn assert_close(a: Vec3, b: Vec3, what: &str) {
        let scale = a.abs().max(b.abs()).max_element().max(1.0);
        assert!(
            (a - b).abs().max_element() <= 2e-5 * scale,
            "{what}: {a} vs Blender's {b}"
        );
    }

    #[test]
    fn blender_noise_at_chosen_points() {
        let (doc, points) = blender_patterns();
        for n in doc["noise"].as_array().unwrap() {
            let (dims, num) = (dims_of(n), |k: &str| n[k].as_f64().unwrap() as f32);
            let f = Fractal {
                detail: num("detail"),
                roughness: num("roughness"),
                lacunarity: num("lacunarity"),
                normalize: n["normalize"].as_bool().unwrap(),
            };
            for (k, p) in points.iter().enumerate() {
                let (fac, color) = noise_texture(dims, *p, 0.0, &f, num("distortion"), true);
                let what = format!("{n} at {p}");
                let want = n["fac"][k].as_f64().unwrap() as f32;
                assert_close(Vec3::splat(fac), Vec3::splat(want), &what);
                assert_close(color, vec3_of(&n["color"][k]), &what);
            }
        }
    }

    #[test]
    fn blender_voronoi_at_chosen_points() {
        let (doc, points) = blender_patterns();
        for v in doc["voronoi"].as_array().unwrap() {
            let (dims, num) = (dims_of(v), |k: &str| v[k].as_f64().unwrap() as f32);
            let feature = match v["feature"].as_str().unwrap() {
                "F2" => VoronoiFeature::F2,
                "SMOOTH_F1" => VoronoiFeature::SmoothF1,
                _ => VoronoiFeature::F1,
            };
            let metric = match v["metric"].as_str().unwrap() {
                "MANHATTAN" => Metric::Manhattan,
                "CHEBYCHEV" => Metric::Chebychev,
                "MINKOWSKI" => Metric::Minkowski,
                _ => Metric::Euclidean,
            };
            let params = VoronoiParams {
                scale: 1.0,
                detail: num("detail"),
                roughness: 0.5,
                lacunarity: 2.0,
                smoothness: (num("smoothness") / 2.0).clamp(0.0, 0.5),
                exponent: num("exponent"),
                randomness: num("randomness"),
                kind: VoronoiKind {
                    dimensions: dims,
                    feature,
                    metric,
                    normalize: false,
                },
            };
            for (k, p) in points.iter().enumerate() {
                let mut p = *p;
                if dims == 2 {
                    p.z = 0.0;
                }
                let (distance, color, position) = voronoi(&params, p, true);
                let what = format!("{v} at {p}");
                let want = v["distance"][k].as_f64().unwrap() as f32;
                assert_close(Vec3::splat(distance), Vec3::splat(want), &what);
                assert_close(color, vec3_of(&v["color"][k]), &what);
                assert_close(position, vec3_of(&v["position"][k]), &what);
            }
        }
    }

    #[test]
    fn floor_is_the_library_floor() {
        for x in [
            -0.0f32,
            0.0,
            -1.5,
            2.0,
            -3.0,
            1e9,
            -1e9,
            8_388_607.5,
            -8_388_607.5,
        ] {
            assert_eq!(floor(x).to_bits(), x.floor().to_bits(), "{x}");
        }
        assert!(floor(f32::NAN).is_nan());
        let mut rng = crate::rng::Rng::new(5);
        for _ in 0..100_000 {
            let x = (rng.uniform() - 0.5) * 2e7;
            assert_eq!(floor(x).to_bits(), x.floor().to_bits(), "{x}");
        }
    }

    #[test]
    fn voronoi_f1_is_the_nearest_of_the_neighbouring_cells_points() {
        // The pruned, nearest-first search finds what visiting all 27 (or 9) cells finds.
        let mut rng = crate::rng::Rng::new(6);
        for metric in [
            Metric::Euclidean,
            Metric::Manhattan,
            Metric::Chebychev,
            Metric::Minkowski,
        ] {
            for dims in [2u8, 3] {
                for randomness in [1.0f32, 0.6, 0.0] {
                    let p = VoronoiParams {
                        scale: 1.0,
                        detail: 0.0,
                        roughness: 0.5,
                        lacunarity: 2.0,
                        smoothness: 0.0,
                        exponent: 1.5,
                        randomness,
                        kind: VoronoiKind {
                            dimensions: dims,
                            feature: VoronoiFeature::F1,
                            metric,
                            normalize: false,
                        },
                    };
                    for k in 0..5_000 {
                        let s = [2.0, 50.0][k % 2];
                        let c = |rng: &mut crate::rng::Rng| (rng.uniform() * 2.0 - 1.0) * s;
                        let z = if dims == 2 { 0.0 } else { c(&mut rng) };
                        let x = Vec3::new(c(&mut rng), c(&mut rng), z);
                        let cell = x.floor();
                        // Cycles' search: every cell in its order, the first on a tie.
                        let (mut nearest, mut at) = (f32::MAX, Vec3::ZERO);
                        for o in cell_offsets(dims, 1) {
                            let point = o + cell_point(dims, cell + o) * randomness;
                            let d = voronoi_distance(metric, 1.5, point, x - cell);
                            if d < nearest {
                                (nearest, at) = (d, o);
                            }
                        }
                        let position = at + cell_point(dims, cell + at) * randomness + cell;
                        let (d, color, found) = voronoi_octave(&p, x, true);
                        assert_eq!(d.to_bits(), nearest.to_bits(), "{metric:?} {x}");
                        assert_eq!(found, position, "{metric:?} {x}");
                        assert_eq!(color, cell_color(dims, cell + at), "{metric:?} {x}");
                        let (d, _, found) = voronoi_octave(&p, x, false);
                        assert_eq!((d, found), (nearest, position), "{metric:?} {x}");
                    }
                }
            }
        }
    }

    #[test]
    fn a_bumps_noise_copies_fuse_into_one_instruction() {
        // Noise → Bump and Noise → Emission: the Noise and its two offset copies become one
        // NoiseAt3 placed where the Noise was, and the tree's values are unchanged.
        let tree = json!({"nodes": [
            {"name": "T", "type": "ShaderNodeTexCoord"},
            {"name": "N", "type": "ShaderNodeTexNoise", "inputs": {
                "Vector": {"node": 0, "output": "Object"}, "Scale": 3.0, "Detail": 2.0}},
            {"name": "B", "type": "ShaderNodeBump", "inputs": {
                "Distance": 0.1, "Strength": 1.0, "Height": {"node": 1, "output": "Fac"}}},
            {"name": "E", "type": "ShaderNodeEmission", "inputs": {
                "Color": {"node": 1, "output": "Color"}, "Strength": 1.0}},
            {"name": "D", "type": "ShaderNodeBsdfDiffuse",
             "inputs": {"Normal": {"node": 2, "output": "Normal"}}},
            {"name": "A", "type": "ShaderNodeAddShader", "inputs": {
                "Shader": {"node": 3, "output": "Emission"},
                "Shader_001": {"node": 4, "output": "BSDF"}}}
        ], "output": {"node": 5, "output": "Shader"}});
        let mut w = Vec::new();
        let p = compile(&tree, 0, &mut w).unwrap();
        assert!(w.is_empty(), "{w:?}");
        let fused = p
            .instrs
            .iter()
            .filter(|i| matches!(i.op, Op::NoiseAt3 { .. }))
            .count();
        let plain = p
            .instrs
            .iter()
            .filter(|i| matches!(i.op, Op::Noise { .. }))
            .count();
        assert_eq!((fused, plain), (1, 0));
        let q = Vec3::new(0.3, -0.2, 0.1);
        let e = 1e-3;
        let mut at = at_positions([q, q + Vec3::X * e, q + Vec3::Y * e], Vec3::Z);
        for point in &mut at.points {
            point.object = point.position;
        }
        let c = p.eval(&at, &[], 0.5);
        let f = Fractal {
            detail: 2.0,
            roughness: 0.5,
            lacunarity: 2.0,
            normalize: true,
        };
        let (_, color) = noise_texture(3, q * 3.0, 0.0, &f, 0.0, true);
        assert_eq!(c.emission, color);
        let h = |v: Vec3| noise_texture(3, v * 3.0, 0.0, &f, 0.0, false).0;
        let slope = Vec3::new(h(q + Vec3::X * e) - h(q), h(q + Vec3::Y * e) - h(q), 0.0);
        assert!(
            slope.length() > 0.0 && c.normal.dot(slope) < 0.0,
            "{}",
            c.normal
        );
    }

    #[test]
    fn mapping_point_and_texture_are_inverse() {
        let (loc, rot, scale) = (
            Vec3::new(0.3, -1.0, 2.0),
            Vec3::new(0.4, 0.9, -1.2),
            Vec3::new(2.0, 0.5, 3.0),
        );
        let v = Vec3::new(0.7, 0.2, -0.4);
        let rot = Euler::new(rot);
        let p = mapping(MappingKind::Point, v, loc, &rot, scale);
        let back = mapping(MappingKind::Texture, p, loc, &rot, scale);
        assert!((back - v).length() < 1e-5);
        // A 90° turn about Z takes X to Y.
        let r = euler_xyz(&Euler::new(Vec3::new(0.0, 0.0, PI / 2.0)), Vec3::X);
        assert!((r - Vec3::Y).length() < 1e-6);
    }

    #[test]
    fn mix_color_blend_modes() {
        let a = Vec3::new(0.2, 0.4, 0.6);
        let b = Vec3::new(0.5, 0.5, 0.5);
        assert!((mix_color(Blend::Multiply, 1.0, a, b) - a * 0.5).length() < 1e-6);
        assert!((mix_color(Blend::Add, 0.5, a, b) - (a + 0.25)).length() < 1e-6);
        assert!(
            (mix_color(Blend::Screen, 1.0, a, b) - (Vec3::ONE - 0.5 * (Vec3::ONE - a))).length()
                < 1e-6
        );
        assert!((mix_color(Blend::Mix, 0.5, a, b) - (a + b) * 0.5).length() < 1e-6);
        let c = Vec3::new(0.8, 0.2, 0.1);
        assert!((hsv_to_rgb(rgb_to_hsv(c)) - c).length() < 1e-6);
    }
}

/// A timing aid, run by hand: `PHOTON_PROFILE_GLB=scene.glb cargo test --release --lib
/// nodes::profile -- --ignored --nocapture` prints the cost of a whole evaluation of material
/// 0's tree and of each of its instructions (at 256 points spread over the object).
#[cfg(test)]
mod profile {
    use super::*;

    #[test]
    #[ignore]
    fn profile() {
        let Some(path) = std::env::var_os("PHOTON_PROFILE_GLB") else {
            return;
        };
        let scene = crate::scene::gltf::load(
            std::path::Path::new(&path),
            &crate::scene::gltf::LoadOptions::default(),
        )
        .unwrap();
        let program = scene.materials[0].nodes.clone().expect("a node tree");
        let mut rng = crate::rng::Rng::new(1);
        let points: Vec<ShadingInputs> = (0..256)
            .map(|_| {
                let p = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 2.0 - 1.0;
                let at = |d: Vec3| PointInputs {
                    position: p + d,
                    object: p + d,
                    generated: (p + d) * 0.5 + 0.5,
                    ..PointInputs::default()
                };
                ShadingInputs {
                    points: [at(Vec3::ZERO), at(Vec3::X * 1e-4), at(Vec3::Y * 1e-4)],
                    normal: Vec3::Z,
                    incoming: Vec3::new(0.3, 0.2, 0.9).normalize(),
                    ..ShadingInputs::default()
                }
            })
            .collect();
        let textures = &scene.textures;
        let reps = 200;
        {
            let t0 = std::time::Instant::now();
            let mut sink = 0.0;
            for k in 0..1_000_000u32 {
                sink += cell_point(3, Vec3::new(k as f32, 2.0, 3.0)).x;
            }
            println!(
                "cell_point: {:.1} ns ({sink})",
                t0.elapsed().as_secs_f64() * 1e3
            );
            let t0 = std::time::Instant::now();
            let mut sink = 0.0;
            for k in 0..1_000_000u32 {
                sink += perlin3((k % 4096) as f32 * 0.37, 2.1, 3.3);
            }
            println!(
                "perlin3: {:.1} ns ({sink})",
                t0.elapsed().as_secs_f64() * 1e3
            );
            let params = VoronoiParams {
                scale: 4.0,
                detail: 0.0,
                roughness: 0.5,
                lacunarity: 2.0,
                smoothness: 0.5,
                exponent: 0.5,
                randomness: 1.0,
                kind: VoronoiKind {
                    dimensions: 3,
                    feature: VoronoiFeature::F1,
                    metric: Metric::Euclidean,
                    normalize: false,
                },
            };
            let t0 = std::time::Instant::now();
            let mut sink = 0.0;
            for k in 0..200_000u32 {
                sink += voronoi(&params, Vec3::new(k as f32 * 0.37, 2.1, 3.3), false).0;
            }
            println!(
                "voronoi: {:.1} ns ({sink})",
                t0.elapsed().as_secs_f64() * 5e3
            );
            let t0 = std::time::Instant::now();
            let mut sink = 0.0;
            for k in 0..1_000_000u32 {
                let a = (k % 4096) as f32 * 0.37;
                let x = Vec4::new(a, a + 1e-3, a, a);
                sink += snoise3_lanes(x, Vec4::splat(2.1), Vec4::splat(3.3)).x;
            }
            println!(
                "snoise3_lanes: {:.1} ns ({sink})",
                t0.elapsed().as_secs_f64() * 1e3
            );
            let t0 = std::time::Instant::now();
            let mut sink = 0.0;
            for k in 0..1_000_000u32 {
                sink += (k as f32 * 0.37).floor();
            }
            println!("floor: {:.1} ns ({sink})", t0.elapsed().as_secs_f64() * 1e3);
        }
        let t0 = std::time::Instant::now();
        let mut sink = 0.0;
        for _ in 0..reps {
            for at in &points {
                sink += Machine::with(&program, |m| m.regs[3].x + at.points[0].position.x);
            }
        }
        let per = t0.elapsed().as_secs_f64() / (reps * points.len()) as f64;
        println!(
            "machine only: {:.0} ns per evaluation ({sink}) size {:?}",
            per * 1e9,
            program.size()
        );
        let t0 = std::time::Instant::now();
        let mut sink = 0.0;
        for _ in 0..reps {
            for at in &points {
                sink += program.eval(at, textures, 0.5).roughness;
            }
        }
        let per = t0.elapsed().as_secs_f64() / (reps * points.len()) as f64;
        println!("whole tree: {:.0} ns per evaluation ({sink})", per * 1e9);
        Machine::with(&program, |m| {
            for (k, instr) in program.instrs.iter().enumerate() {
                let t0 = std::time::Instant::now();
                let mut u = 0.5;
                for _ in 0..reps {
                    for at in &points {
                        run(instr, at, textures, m, &mut u);
                    }
                }
                let per = t0.elapsed().as_secs_f64() / (reps * points.len()) as f64;
                let name = format!("{:?}", instr.op);
                println!(
                    "{k:3} {:>6.0} ns  offset {}  {}",
                    per * 1e9,
                    instr.offset,
                    &name[..name.len().min(60)]
                );
            }
        });
    }
}
