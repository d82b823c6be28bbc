//! Compiling a node tree (`compile`): each node's inputs resolved to registers, closures or
//! constants with socket type conversions decided here, a Bump's Height subtree copied for its
//! two offset points, unread outputs marked, then `optimise`.

use super::bump::{BUMP_INPUTS, HEIGHT_AT_STEPS};
use super::closure::{EMISSION_INPUTS, PRINCIPLED_INPUTS};
use super::geometry::{RAY_LENGTH_OUTPUT, RAY_STATE_OUTPUTS};
use super::inputs::{input, Socket, Ty};
use super::optimise::{fold_constants, fuse_bump_noise};
use super::parse::{const_value, parse_op, setting};
use super::program::{
    input_reads, CompileWarnings, Instr, NodeProgram, Op, Src, MAX_CLOSURES, MAX_REGISTERS,
    MAX_REGS_IN,
};
use super::sockets::spec;
use super::vector::{Euler, MAPPING_INPUTS};
use crate::math::{Vec3, Vec4};
use serde_json::Value;

/// Compile the `PHOTON_material_nodes` extension of a material. Errors (a malformed tree: a link
/// to a later node or a missing output, a value of the wrong kind) refuse the file; nodes the
/// renderer cannot evaluate are replaced by their fallback with a warning in `warnings`.
/// `textures` is the number of textures in the scene (Image Texture nodes name one of them).
/// A `displacement` tree (same form, its `output` a vector: the bumped normal) is compiled
/// alongside; the surface tree then reads its normal (`NodeProgram::eval`). A `displace` tree
/// (its `output` the world-space vector a vertex moves by) is compiled alongside too, for the
/// scene's vertices (`NodeProgram::displacement_at`); shading points never read it. Its
/// `smooth_flat_faces` (default false) shades flat faces smooth under the bump
/// (`NodeProgram::smooths_flat_faces`).
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
    if let Some(tree) = ext.get("displace").filter(|d| !d.is_null()) {
        let vector = compile_tree(tree, textures, warnings, Ty::Vector)
            .map_err(|m| format!("displace: {m}"))?;
        program.displace = Some(Box::new(vector));
        program.smooth_flat_faces = tree
            .get("smooth_flat_faces")
            .and_then(Value::as_bool)
            .unwrap_or(false);
    }
    Ok(program)
}

/// One tree whose `output` is of type `output_type` (a shader, or a vector).
pub(super) fn compile_tree(
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
    let mut placed: Vec<Option<(u16, &'static [Socket])>> = Vec::with_capacity(nodes.len());
    let mut instrs: Vec<Instr> = Vec::new();
    let mut registers = 0usize;
    let mut closures = 0usize;
    let mut emits = false;
    let mut reads_color = false;
    let mut needs_offsets = false;
    let mut shadow_transparent = false;
    let mut may_be_smooth = false;
    let mut ray_portal = false;
    let mut attributes: Vec<String> = Vec::new();
    // Per node: its instruction and the nodes its inputs read (for copying Bump subtrees).
    let mut node_instr: Vec<Option<usize>> = Vec::with_capacity(nodes.len());
    let mut deps: Vec<Vec<usize>> = Vec::with_capacity(nodes.len());
    // Per instruction: the instruction it copies (a Bump's offset copies), else itself.
    let mut anchors: Vec<usize> = Vec::new();
    for (index, node) in nodes.iter().enumerate() {
        let name = setting(node, "name").unwrap_or("?").to_string();
        let kind = setting(node, "type").unwrap_or("?").to_string();
        let op = match parse_op(node, &mut attributes, warnings)
            .map_err(|m| format!("node {index} '{name}': {m}"))?
        {
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
                | Op::Gabor { .. }
        );
        let mut ins = Vec::with_capacity(spec.inputs.len());
        let mut reads = Vec::new();
        for socket in spec.inputs {
            let (id, ty, default) = (socket.name, &socket.ty, &socket.default);
            let given = inputs.and_then(|i| i.get(id));
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
                            let k = outs.iter().position(|s| s.name == output);
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
                            let (from_ty, reg) = (outs[k].ty, base + k as u16);
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
        let shader = spec.outputs.first().is_some_and(|o| o.ty == Ty::Shader);
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
        const COLOR: usize = input(EMISSION_INPUTS, "Color");
        const STRENGTH: usize = input(EMISSION_INPUTS, "Strength");
        const EMISSION_COLOR: usize = input(PRINCIPLED_INPUTS, "Emission Color");
        const EMISSION_STRENGTH: usize = input(PRINCIPLED_INPUTS, "Emission Strength");
        const ALPHA: usize = input(PRINCIPLED_INPUTS, "Alpha");
        let black = |k: usize| matches!(ins[k], Src::Const(v) if v.truncate() == Vec3::ZERO);
        emits |= match op {
            Op::Emission => !black(COLOR) && !black(STRENGTH),
            Op::Principled { .. } => !black(EMISSION_COLOR) && !black(EMISSION_STRENGTH),
            _ => false,
        };
        reads_color |= matches!(op, Op::VertexColor | Op::Attribute { .. });
        ray_portal |= matches!(op, Op::RayPortal { .. });
        shadow_transparent |= match op {
            // Seen from inside its tube a fibre passes light (`crate::material`).
            Op::Transparent | Op::PrincipledHair { .. } | Op::Hair { .. } => true,
            Op::Principled { .. } => !matches!(ins[ALPHA], Src::Const(v) if v.x >= 1.0),
            _ => false,
        };
        may_be_smooth |= matches!(
            op,
            Op::Principled { .. }
                | Op::Glossy { .. }
                | Op::Metallic { .. }
                | Op::Glass { .. }
                | Op::Refraction
                | Op::Toon { glossy: true }
                | Op::RayPortal { .. }
        );
        if matches!(op, Op::Bump { .. }) {
            // The Height subtree again at the two offset points; the heights there are the
            // Bump's inputs `HEIGHT_AT_STEPS`, pushed after its sockets' below.
            const HEIGHT: usize = input(BUMP_INPUTS, "Height");
            const _: () = assert!(HEIGHT_AT_STEPS[0] == BUMP_INPUTS.len());
            let height = ins[HEIGHT];
            // Only what feeds Height: the nodes whose registers Height reads, and upstream.
            let feeds_height = |n: usize, placed: &[Option<(u16, &'static [Socket])>]| {
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
        placed.push(Some((out as u16, spec.outputs)));
        node_instr.push(if shader { None } else { Some(instrs.len()) });
        deps.push(reads);
        needs_offsets |= needs;
        const ROTATION: usize = input(MAPPING_INPUTS, "Rotation");
        let op = match (op, ins.get(ROTATION)) {
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
                Some((base, outs)) => match outs.iter().position(|s| s.name == name) {
                    Some(k) if outs[k].ty == output_type && output_type == Ty::Shader => {
                        Src::Closure(base + k as u16)
                    }
                    Some(k) if outs[k].ty == output_type => Src::Reg(base + k as u16),
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
        if outputs.first().is_some_and(|o| o.ty != Ty::Shader) {
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
        may_be_smooth,
        ray_portal,
        displacement: None,
        displace: None,
        smooth_flat_faces: false,
        attributes,
    })
}
