//! The nodes that bend the shading normal: Bump (Cycles' `svm_node_set_bump`, the height read
//! at the point and at two points a small step along its tangents), Displacement (as Cycles'
//! "bump only" method) and Normal Map (`svm_node_normal_map`).

use super::inputs::{normal_input, v3, Operands, PointInputs, ShadingInputs};
use crate::math::{Vec3, Vec4};

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
/// distance × height.
#[inline(always)]
pub(super) fn eval_bump(invert: bool, inputs: &ShadingInputs, ins: &impl Operands) -> Vec4 {
    let strength = ins.float(0).max(0.0);
    let distance = if invert { -ins.float(1) } else { ins.float(1) };
    let given = ins.vector(4);
    let n = if given == Vec3::ZERO {
        inputs.normal
    } else {
        given.normalize_or(inputs.normal)
    };
    let (hc, hx, hy) = (ins.float(3), ins.float(5), ins.float(6));
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
    v3(out)
}

/// The Displacement node: Height, Midlevel, Scale, Normal to a displacement vector.
#[inline(always)]
pub(super) fn eval_displacement(
    object_space: bool,
    inputs: &ShadingInputs,
    ins: &impl Operands,
) -> Vec4 {
    let n = normal_input(ins.value(3), inputs.normal);
    let height = (ins.float(0) - ins.float(1)) * ins.float(2);
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

/// The Normal Map node: Strength, Color.
#[inline(always)]
pub(super) fn eval_normal_map(
    space: NormalMapSpace,
    inputs: &ShadingInputs,
    at: &PointInputs,
    ins: &impl Operands,
) -> Vec4 {
    v3(normal_map(space, ins.vector(1), ins.float(0), inputs, at))
}

#[cfg(test)]
mod tests {
    use super::*;

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
