//! The compiled program's optimisations: constant inputs put in registers so an instruction
//! reads every input with one load (`fold_constants`), and a Noise Texture fused with its
//! copies at a Bump's offset points (`fuse_bump_noise`).

use super::program::{Instr, Op, Src, MAX_REGISTERS, MAX_REGS_IN};
use crate::math::Vec4;

/// Sets `regs_in` of each instruction whose inputs are all registers or constants, the
/// constants (equal ones shared) numbered from register `registers` on as long as they fit
/// in `MAX_REGISTERS`; returns the constants in register order.
pub(super) fn fold_constants(instrs: &mut [Instr], registers: usize) -> Vec<Vec4> {
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
pub(super) fn fuse_bump_noise(instrs: Vec<Instr>, anchors: &[usize]) -> Vec<Instr> {
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
