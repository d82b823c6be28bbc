//! The input nodes: Texture Coordinate, UV Map, Color Attribute, Attribute, Geometry, Object
//! Info, Hair Info and Light Path (read off `ShadingInputs`, its `ObjectInfo` and its
//! `RayPath`).

use super::color::gray;
use super::hash::{hash2, unit};
use super::inputs::{input, splat, v3, Operands, PointInputs, RayPath, ShadingInputs, Socket, Ty};
use crate::math::{Vec3, Vec4};

/// The Texture Coordinate node's outputs.
pub(super) const TEX_COORD_OUTPUTS: &[Socket] = &[
    Socket::output("Generated", Ty::Vector),
    Socket::output("Normal", Ty::Vector),
    Socket::output("UV", Ty::Vector),
    Socket::output("Object", Ty::Vector),
    Socket::output("Reflection", Ty::Vector),
];

/// The UV Map node's outputs.
pub(super) const UV_MAP_OUTPUTS: &[Socket] = &[Socket::output("UV", Ty::Vector)];

/// The Color Attribute node's outputs.
pub(super) const VERTEX_COLOR_OUTPUTS: &[Socket] = &[
    Socket::output("Color", Ty::Color),
    Socket::output("Alpha", Ty::Float),
];

/// The Attribute node's outputs.
pub(super) const ATTRIBUTE_OUTPUTS: &[Socket] = &[
    Socket::output("Color", Ty::Color),
    Socket::output("Vector", Ty::Vector),
    Socket::output("Fac", Ty::Float),
    Socket::output("Alpha", Ty::Float),
];

/// The Object Info node's outputs.
pub(super) const OBJECT_INFO_OUTPUTS: &[Socket] = &[
    Socket::output("Location", Ty::Vector),
    Socket::output("Color", Ty::Color),
    Socket::output("Alpha", Ty::Float),
    Socket::output("Object Index", Ty::Float),
    Socket::output("Material Index", Ty::Float),
    Socket::output("Random", Ty::Float),
];

/// The Hair Info node's outputs (Blender's Curves Info).
pub(super) const HAIR_INFO_OUTPUTS: &[Socket] = &[
    Socket::output("Is Strand", Ty::Float),
    Socket::output("Intercept", Ty::Float),
    Socket::output("Length", Ty::Float),
    Socket::output("Thickness", Ty::Float),
    Socket::output("Tangent Normal", Ty::Vector),
    Socket::output("Random", Ty::Float),
];

/// The Wireframe node's input and output.
pub(super) const WIREFRAME_INPUTS: &[Socket] = &[Socket::float("Size", 0.01)];
pub(super) const WIREFRAME_OUTPUTS: &[Socket] = &[Socket::output("Fac", Ty::Float)];

/// The Geometry node's outputs.
pub(super) const GEOMETRY_OUTPUTS: &[Socket] = &[
    Socket::output("Position", Ty::Vector),
    Socket::output("Normal", Ty::Vector),
    Socket::output("True Normal", Ty::Vector),
    Socket::output("Incoming", Ty::Vector),
    Socket::output("Backfacing", Ty::Float),
];

/// Light Path's outputs, in Blender's order.
pub(super) const LIGHT_PATH_OUTPUTS: &[Socket] = &[
    Socket::output("Is Camera Ray", Ty::Float),
    Socket::output("Is Shadow Ray", Ty::Float),
    Socket::output("Is Diffuse Ray", Ty::Float),
    Socket::output("Is Glossy Ray", Ty::Float),
    Socket::output("Is Singular Ray", Ty::Float),
    Socket::output("Is Reflection Ray", Ty::Float),
    Socket::output("Is Transmission Ray", Ty::Float),
    Socket::output("Is Volume Scatter Ray", Ty::Float),
    Socket::output("Ray Length", Ty::Float),
    Socket::output("Ray Depth", Ty::Float),
    Socket::output("Diffuse Depth", Ty::Float),
    Socket::output("Glossy Depth", Ty::Float),
    Socket::output("Transparent Depth", Ty::Float),
    Socket::output("Transmission Depth", Ty::Float),
];

/// The Value node's outputs.
pub(super) const VALUE_OUTPUTS: &[Socket] = &[Socket::output("Value", Ty::Float)];

/// The RGB node's outputs.
pub(super) const RGB_OUTPUTS: &[Socket] = &[Socket::output("Color", Ty::Color)];

/// The Light Path outputs only a camera path's state tells (the lobe a ray left by and the
/// bounces before it): Is Diffuse … Is Transmission Ray and the depths.
pub(super) const RAY_STATE_OUTPUTS: u32 = 0b11_1110_0111_1100;

/// Light Path's Ray Length.
pub(super) const RAY_LENGTH_OUTPUT: u32 = 1 << 8;

pub(super) fn uv_value(at: &PointInputs, set: u8) -> Vec4 {
    let uv = at.uv[set as usize];
    Vec4::new(uv.x, uv.y, 0.0, 1.0)
}

/// Texture Coordinate: Generated, Normal (object space), UV, Object, Reflection; only the
/// outputs in `used` are computed (often one), the others are zero.
#[inline(always)]
pub(super) fn texture_coordinate(
    inputs: &ShadingInputs,
    at: &PointInputs,
    uv_set: u8,
    used: u32,
) -> [Vec4; 5] {
    let used = |k: u32| used & (1 << k) != 0;
    let mut out = [Vec4::ZERO; 5];
    if used(0) {
        out[0] = v3(at.generated);
    }
    if used(1) {
        out[1] = v3(inputs.object_normal);
    }
    if used(2) {
        out[2] = uv_value(at, uv_set);
    }
    if used(3) {
        out[3] = v3(at.object);
    }
    if used(4) {
        let (n, i) = (inputs.normal, inputs.incoming);
        out[4] = v3(2.0 * n.dot(i) * n - i);
    }
    out
}

/// Color Attribute: the vertex colour and its alpha.
#[inline(always)]
pub(super) fn vertex_color(at: &PointInputs) -> [Vec4; 2] {
    [at.color, splat(at.color.w)]
}

/// Attribute: Color, Vector, Fac, Alpha of its `named` attribute where the object has it (a
/// grid's or a mesh attribute's value; Fac the colour's average as Cycles gives it, Alpha a
/// colour's alpha, else 1), else of COLOR_0.
#[inline(always)]
pub(super) fn attribute(at: &PointInputs, named: Option<Vec4>) -> [Vec4; 4] {
    if let Some(v) = named {
        let rgb = v.truncate().extend(1.0);
        let fac = (v.x + v.y + v.z) / 3.0;
        return [rgb, rgb, splat(fac), splat(v.w)];
    }
    let rgb = at.color.truncate().extend(1.0);
    [rgb, rgb, splat(gray(at.color)), splat(at.color.w)]
}

/// Object Info: the object's location, colour, alpha, pass index and random number
/// (`ShadingInputs::object`), and the material's pass index (`material_index`).
#[inline(always)]
pub(super) fn object_info(inputs: &ShadingInputs, material_index: f32) -> [Vec4; 6] {
    let object = &inputs.object;
    [
        v3(object.location),
        object.color.truncate().extend(1.0),
        splat(object.color.w),
        splat(object.pass_index),
        splat(material_index),
        splat(object.random),
    ]
}

/// Hair Info on a hair tube (the add-on's `points_curves.py`): `fibre` holds the intercept
/// (the fraction of the strand's length from its root), the strand's length and the diameter,
/// `curve` the strand's index, whose hash is Random as Cycles gives each curve its random
/// number (`hash_uint2_to_float(index, 0)`). Is Strand is 1 where the mesh has `fibre`; a mesh
/// without it is no hair and reads 0 everywhere, as Cycles' node does off curves. Tangent
/// Normal is Cycles' `curve_tangent_normal`: the direction to the viewer (`incoming`) made
/// perpendicular to the fibre (`along`, the tube's axis), normalised.
#[inline(always)]
pub(super) fn hair_info(
    fibre: Option<Vec4>,
    curve: Option<Vec4>,
    incoming: Vec3,
    along: Vec3,
) -> [Vec4; 6] {
    let Some(fibre) = fibre else {
        return [Vec4::ZERO; 6];
    };
    // The index is the same at the three corners; interpolation may leave it a rounding off.
    let random = curve.map_or(0.0, |c| unit(hash2(c.x.round().max(0.0) as u32, 0)));
    [
        splat(1.0),
        splat(fibre.x),
        splat(fibre.y),
        splat(fibre.z),
        v3((incoming - along * along.dot(incoming)).normalize_or_zero()),
        splat(random),
    ]
}

/// Wireframe (Cycles' `wireframe`): 1 where the point lies within half of Size of one of its
/// triangle's edges (both triangles beside an edge draw their half), Size in scene units or,
/// with `pixel_size`, in pixels: times the ray's footprint, as Cycles spreads its compact
/// differential over two directions in the surface (`make_orthonormals` of the normal) and
/// measures them across the view.
#[inline(always)]
pub(super) fn eval_wireframe(
    pixel_size: bool,
    inputs: &ShadingInputs,
    at: &PointInputs,
    ins: &impl Operands,
) -> Vec4 {
    const SIZE: usize = input(WIREFRAME_INPUTS, "Size");
    let mut width = 1.0;
    if pixel_size {
        let (dx, dy) = orthonormals(inputs.normal);
        let wi = inputs.incoming;
        let across = |d: Vec3| (d - d.dot(wi) * wi).length();
        width = inputs.pixel_width * 0.5 * (across(dx) + across(dy));
    }
    let reach = 0.5 * ins.float(SIZE) * width;
    let reach2 = reach * reach;
    let co = inputs.triangle;
    let near = (0..3).any(|i| {
        let previous = co[(i + 2) % 3];
        let along = (previous - co[i]).normalize_or_zero();
        (at.position - co[i]).cross(along).length_squared() < reach2
    });
    splat(if near { 1.0 } else { 0.0 })
}

/// Two unit vectors perpendicular to `n` and to each other, as Cycles' `make_orthonormals`
/// chooses them.
fn orthonormals(n: Vec3) -> (Vec3, Vec3) {
    let a = if n.x != n.y || n.x != n.z {
        Vec3::new(n.z - n.y, n.x - n.z, n.y - n.x)
    } else {
        Vec3::new(n.z - n.y, n.x + n.z, -n.y - n.x)
    }
    .normalize_or_zero();
    (a, n.cross(a))
}

/// Geometry: Position, Normal, True Normal, Incoming, Backfacing.
#[inline(always)]
pub(super) fn geometry(inputs: &ShadingInputs, at: &PointInputs) -> [Vec4; 5] {
    [
        v3(at.position),
        v3(inputs.normal),
        v3(inputs.normal),
        v3(inputs.incoming),
        splat(if inputs.backfacing { 1.0 } else { 0.0 }),
    ]
}

/// Light Path: `LIGHT_PATH_OUTPUTS` read off the ray the point is evaluated for.
#[inline(always)]
pub(super) fn light_path(inputs: &ShadingInputs) -> [Vec4; 14] {
    let p = &inputs.path;
    let flag = |f: u8| splat(if p.is(f) { 1.0 } else { 0.0 });
    let count = |n: u16| splat(n as f32);
    [
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
    ]
}
