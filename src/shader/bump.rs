//! The nodes that bend the shading normal: Bump (Cycles' `svm_node_set_bump`, the height read
//! at the point and at two points a small step along its tangents, in world or object space),
//! Displacement (the vector the Material Output's Displacement reads: Cycles' "bump only"
//! method bumps by it, true displacement moves the vertices by it, `crate::scene::displace`)
//! and Normal Map (`svm_node_normal_map`).

use super::inputs::{input, normal_input, v3, Operands, PointInputs, ShadingInputs, Socket, Ty};
use crate::math::{Vec3, Vec4};

/// The Bump node's inputs.
pub(super) const BUMP_INPUTS: &[Socket] = &[
    Socket::float("Strength", 1.0),
    Socket::float("Distance", 1.0),
    Socket::float("Filter Width", 0.1),
    Socket::float("Height", 1.0),
    Socket::vector("Normal", Vec4::ZERO),
];

/// The Bump node's outputs.
pub(super) const BUMP_OUTPUTS: &[Socket] = &[Socket::output("Normal", Ty::Vector)];

/// The Bump's extra inputs after its sockets: the Height at the two points a small step along
/// the tangents (the Height subtree's copies, `compile_tree`).
pub(super) const HEIGHT_AT_STEPS: [usize; 2] = [BUMP_INPUTS.len(), BUMP_INPUTS.len() + 1];

/// The Displacement node's inputs.
pub(super) const DISPLACEMENT_INPUTS: &[Socket] = &[
    Socket::float("Height", 0.0),
    Socket::float("Midlevel", 0.5),
    Socket::float("Scale", 1.0),
    Socket::vector("Normal", Vec4::ZERO),
];

/// The Displacement node's outputs.
pub(super) const DISPLACEMENT_OUTPUTS: &[Socket] = &[Socket::output("Displacement", Ty::Vector)];

/// The Vector Displacement node's inputs (its output is the Displacement node's).
pub(super) const VECTOR_DISPLACEMENT_INPUTS: &[Socket] = &[
    Socket::color("Vector", Vec4::new(0.0, 0.0, 0.0, 1.0)),
    Socket::float("Midlevel", 0.0),
    Socket::float("Scale", 1.0),
];

/// The Normal Map node's inputs.
pub(super) const NORMAL_MAP_INPUTS: &[Socket] = &[
    Socket::float("Strength", 1.0),
    Socket::color("Color", Vec4::new(0.5, 0.5, 1.0, 1.0)),
];

/// The Normal Map node's outputs.
pub(super) const NORMAL_MAP_OUTPUTS: &[Socket] = &[Socket::output("Normal", Ty::Vector)];

/// The Normal Map node's spaces (Blender's `space`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum NormalMapSpace {
    Tangent,
    Object,
    World,
    /// Blender's own object and world conventions: y and z negated.
    BlenderObject,
    BlenderWorld,
}

/// Cycles' `svm_node_normal_map`: the colour (each channel 0.5 ↦ 0) as a normal in `space`,
/// world space out, blended with the shading normal by `strength`. In tangent space the
/// colour's x, y, z weigh the tangent, the bitangent and the interpolated normal, on the
/// winding's side (turned to the viewer afterwards, as Cycles does).
pub(super) fn normal_map(
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

/// The Bump node: Strength, Distance, Filter Width, Height, Normal, and the heights at the
/// two offset points (inputs 5 and 6, the copies of the Height subtree); Cycles'
/// `svm_node_set_bump` with our steps as dPdx, dPdy: the normal of the surface displaced by
/// distance × height. With `object_space` the normal and the steps are taken to object space,
/// the normal bumped there and taken back (Cycles' bump over true displacement: the height is
/// a world length, its slope measured along the object's own axes).
#[inline(always)]
pub(super) fn eval_bump(
    invert: bool,
    object_space: bool,
    inputs: &ShadingInputs,
    ins: &impl Operands,
) -> Vec4 {
    const STRENGTH: usize = input(BUMP_INPUTS, "Strength");
    const DISTANCE: usize = input(BUMP_INPUTS, "Distance");
    const HEIGHT: usize = input(BUMP_INPUTS, "Height");
    const NORMAL: usize = input(BUMP_INPUTS, "Normal");
    let strength = ins.float(STRENGTH).max(0.0);
    let distance = if invert {
        -ins.float(DISTANCE)
    } else {
        ins.float(DISTANCE)
    };
    let given = ins.vector(NORMAL);
    let n = if given == Vec3::ZERO {
        inputs.normal
    } else {
        given.normalize_or(inputs.normal)
    };
    let (hc, hx, hy) = (
        ins.float(HEIGHT),
        ins.float(HEIGHT_AT_STEPS[0]),
        ins.float(HEIGHT_AT_STEPS[1]),
    );
    let mut dx = inputs.points[1].position - inputs.points[0].position;
    let mut dy = inputs.points[2].position - inputs.points[0].position;
    // World to object: directions by the inverse of the linear part (the normal matrix's
    // transpose), normals by its transpose (the normal matrix's inverse).
    let to_world_normal = inputs.object_to_world_normal;
    let world_n = n;
    let n = if object_space {
        dx = to_world_normal.transpose() * dx;
        dy = to_world_normal.transpose() * dy;
        (to_world_normal.inverse() * n).normalize_or(n)
    } else {
        n
    };
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
    if object_space {
        v3((to_world_normal * out).normalize_or(world_n))
    } else {
        v3(out)
    }
}

/// The Displacement node: Height, Midlevel, Scale, Normal to a displacement vector.
#[inline(always)]
pub(super) fn eval_displacement(
    object_space: bool,
    inputs: &ShadingInputs,
    ins: &impl Operands,
) -> Vec4 {
    const HEIGHT: usize = input(DISPLACEMENT_INPUTS, "Height");
    const MIDLEVEL: usize = input(DISPLACEMENT_INPUTS, "Midlevel");
    const SCALE: usize = input(DISPLACEMENT_INPUTS, "Scale");
    const NORMAL: usize = input(DISPLACEMENT_INPUTS, "Normal");
    let n = normal_input(ins.value(NORMAL), inputs.normal);
    let height = (ins.float(HEIGHT) - ins.float(MIDLEVEL)) * ins.float(SCALE);
    let direction = if object_space {
        // Cycles: the normal to object space (normalised), scaled, and back as a
        // direction, so the object's scale scales the displacement.
        let to_object = inputs.object_to_world_normal.inverse();
        to_object.transpose() * (to_object * n).normalize_or_zero()
    } else {
        n
    };
    v3(direction * height)
}

/// The Vector Displacement node (Cycles' `svm_node_vector_displacement`): (Vector − Midlevel)
/// × Scale as a displacement in `space`. In tangent space x runs along the tangent, y along the
/// normal and z along the bitangent, the frame built in object space (the normal and the
/// tangent taken there, the bitangent normal × tangent with the tangent's sign); tangent and
/// object space then go to world space as directions, so the object's scale scales them.
/// Without tangents, tangent space reads the displacement as object space.
#[inline(always)]
pub(super) fn eval_vector_displacement(
    space: NormalMapSpace,
    inputs: &ShadingInputs,
    at: &PointInputs,
    ins: &impl Operands,
) -> Vec4 {
    const VECTOR: usize = input(VECTOR_DISPLACEMENT_INPUTS, "Vector");
    const MIDLEVEL: usize = input(VECTOR_DISPLACEMENT_INPUTS, "Midlevel");
    const SCALE: usize = input(VECTOR_DISPLACEMENT_INPUTS, "Scale");
    let d = (ins.vector(VECTOR) - Vec3::splat(ins.float(MIDLEVEL))) * ins.float(SCALE);
    if space == NormalMapSpace::World {
        return v3(d);
    }
    // World to object: normals by the normal matrix's inverse, directions by its transpose;
    // object directions back to world by its inverse transpose.
    let to_world_normal = inputs.object_to_world_normal;
    let object = if space == NormalMapSpace::Tangent && at.tangent != Vec4::ZERO {
        let normal = (to_world_normal.inverse() * inputs.normal).normalize_or_zero();
        let tangent = (to_world_normal.transpose() * at.tangent.truncate()).normalize_or_zero();
        let bitangent = at.tangent.w * normal.cross(tangent).normalize_or_zero();
        d.x * tangent + d.y * normal + d.z * bitangent
    } else {
        d
    };
    v3(to_world_normal.inverse().transpose() * object)
}

/// The Normal Map node: Strength, Color.
#[inline(always)]
pub(super) fn eval_normal_map(
    space: NormalMapSpace,
    inputs: &ShadingInputs,
    at: &PointInputs,
    ins: &impl Operands,
) -> Vec4 {
    const STRENGTH: usize = input(NORMAL_MAP_INPUTS, "Strength");
    const COLOR: usize = input(NORMAL_MAP_INPUTS, "Color");
    v3(normal_map(
        space,
        ins.vector(COLOR),
        ins.float(STRENGTH),
        inputs,
        at,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Mat3;

    #[test]
    fn vector_displacement_reads_tangent_normal_bitangent_and_scales_with_the_object() {
        let vector = |c: Vec3, space, inputs: &ShadingInputs, at: &PointInputs| {
            let ins = [c.extend(1.0), Vec4::splat(0.0), Vec4::splat(2.0)];
            eval_vector_displacement(space, inputs, at, &ins).truncate()
        };
        let c = Vec3::new(0.1, 0.2, 0.3);
        let inputs = ShadingInputs {
            normal: Vec3::Z,
            object_to_world_normal: Mat3::IDENTITY,
            ..ShadingInputs::default()
        };
        let at = PointInputs {
            tangent: Vec4::new(1.0, 0.0, 0.0, 1.0),
            ..PointInputs::default()
        };
        // Tangent space: x along the tangent, y along the normal, z along normal × tangent.
        let d = vector(c, NormalMapSpace::Tangent, &inputs, &at);
        assert!((d - Vec3::new(0.2, 0.6, 0.4)).length() < 1e-6, "{d}");
        assert_eq!(vector(c, NormalMapSpace::World, &inputs, &at), 2.0 * c);
        // An object stretched 2× along x: object space stretches with it, world space not.
        let stretched = ShadingInputs {
            object_to_world_normal: Mat3::from_diagonal(Vec3::new(0.5, 1.0, 1.0)),
            ..inputs
        };
        let d = vector(c, NormalMapSpace::Object, &stretched, &at);
        assert!((d - Vec3::new(0.4, 0.4, 0.6)).length() < 1e-6, "{d}");
        assert_eq!(vector(c, NormalMapSpace::World, &stretched, &at), 2.0 * c);
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
}
