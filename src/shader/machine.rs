//! The machine that runs a `NodeProgram` (Cycles' SVM interpreter): a per-thread register file
//! and closure array, the loop over the instructions, and the dispatch of each instruction to
//! its node family's evaluation.

use super::closure::{Closure, ADD_SHADER_INPUTS, MIX_SHADER_INPUTS};
use super::color::gray;
use super::geometry::uv_value;
use super::inputs::{input, splat, v3, Operands, PointInputs, ShadingInputs, Tracing};
use super::noise::NOISE_INPUTS;
use super::program::{Instr, NodeProgram, Op, Src, MAX_CLOSURES, MAX_REGISTERS};
use super::{ambient_occlusion, bevel};
use super::{
    blackbody, brick, bump, checker, closure, color, convert, fresnel, gabor, geometry, gradient,
    image, magic,
};
use super::{math, noise, vector, volume, voronoi, wave, white_noise};
use crate::math::{Vec3, Vec4};
use crate::medium::Coefficients;
use crate::scene::texture::Texture;

pub(super) struct Machine {
    pub(super) regs: [Vec4; MAX_REGISTERS],
    pub(super) closures: [Closure; MAX_CLOSURES],
}

impl Machine {
    /// Run `program` on this thread's register file (one per thread, reused: clearing the
    /// registers the program uses costs far less than a fresh 15 KB machine), and return what
    /// `run` reads off it. Nothing is allocated per shading point. The closure slots are not
    /// cleared: the compiler gives each shader node its own slot and an instruction that
    /// writes it whole, and a slot is read only by the nodes after its own (and the output),
    /// so every slot a program reads it has written in the same run.
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
            run(&mut m)
        })
    }
}

impl Machine {
    /// Store `values` in the registers from `o` on.
    #[inline(always)]
    fn put<const N: usize>(&mut self, o: usize, values: [Vec4; N]) {
        self.regs[o..o + N].copy_from_slice(&values);
    }

    /// Store the `values` whose bit is set in `used` (the outputs some instruction reads).
    #[inline(always)]
    fn put_used<const N: usize>(&mut self, o: usize, used: u32, values: [Vec4; N]) {
        for (k, v) in values.into_iter().enumerate() {
            if used & (1 << k) != 0 {
                self.regs[o + k] = v;
            }
        }
    }
}

impl NodeProgram {
    /// The medium a volume tree describes at the point `at` (what feeds a Volume socket: its
    /// scattering, absorption, emission and phase function).
    pub fn eval_volume(&self, at: &ShadingInputs, textures: &[Texture]) -> Coefficients {
        self.eval_then(at, textures, 0.5, None, |c| Coefficients {
            scattering: c.volume.scattering,
            absorption: c.volume.absorption,
            emission: c.emission,
            phase: c.volume.phase,
        })
    }
}

impl NodeProgram {
    /// Evaluate the program at a shading point. `u` in [0, 1) picks the BSDF of Mix and Add
    /// Shader nodes (module header).
    /// `at.points` holds the shading point and, when `needs_offsets`, the points a small step
    /// along its two tangents (else three copies of the point).
    /// With a displacement tree, its bumped normal is the shading normal the surface tree
    /// reads, and the normal of its BSDFs whose Normal input is unlinked (Cycles sets the
    /// shading point's N before evaluating the surface).
    pub fn eval(&self, at: &ShadingInputs, textures: &[Texture], u: f32) -> Closure {
        self.eval_tracing(at, textures, u, None)
    }

    /// `eval` where the nodes that trace rays (Ambient Occlusion, Bevel) trace them with
    /// `tracing` (without it they read 1 and the normal).
    pub fn eval_tracing(
        &self,
        at: &ShadingInputs,
        textures: &[Texture],
        u: f32,
        tracing: Option<&Tracing>,
    ) -> Closure {
        self.eval_then(at, textures, u, tracing, |c| *c)
    }

    /// `eval_tracing` handing the closure to `read` where the machine holds it, so that a
    /// caller that keeps part of it does not copy the whole closure. `read` runs while this
    /// thread's machine is in use: it must not evaluate a node program itself.
    pub fn eval_then<R>(
        &self,
        at: &ShadingInputs,
        textures: &[Texture],
        mut u: f32,
        tracing: Option<&Tracing>,
        read: impl FnOnce(&Closure) -> R,
    ) -> R {
        let Some(displacement) = &self.displacement else {
            return self.eval_closure(at, textures, &mut u, tracing, None, read);
        };
        let n = displacement.eval_vector(at, textures, tracing);
        let bumped = ShadingInputs { normal: n, ..*at };
        self.eval_closure(&bumped, textures, &mut u, tracing, Some(n), read)
    }

    /// Run the program and hand its closure to `read`; with `unlinked_normal`, the normal of
    /// a closure without one (zero) is set to it first.
    fn eval_closure<R>(
        &self,
        at: &ShadingInputs,
        textures: &[Texture],
        u: &mut f32,
        tracing: Option<&Tracing>,
        unlinked_normal: Option<Vec3>,
        read: impl FnOnce(&Closure) -> R,
    ) -> R {
        Machine::with(self, |m| {
            run_all(&self.instrs, at, textures, tracing, m, u);
            let c = match self.output {
                Src::Closure(k) => &mut m.closures[k as usize],
                _ => {
                    m.closures[0] = Closure::BLACK;
                    &mut m.closures[0]
                }
            };
            if let Some(n) = unlinked_normal {
                if c.normal == Vec3::ZERO {
                    c.normal = n;
                }
            }
            read(c)
        })
    }

    /// A vector-output program's value (the displacement tree's normal, unit).
    fn eval_vector(
        &self,
        at: &ShadingInputs,
        textures: &[Texture],
        tracing: Option<&Tracing>,
    ) -> Vec3 {
        self.eval_raw_vector(at, textures, tracing)
            .normalize_or(at.normal)
    }

    /// A vector-output program's value as it comes.
    fn eval_raw_vector(
        &self,
        at: &ShadingInputs,
        textures: &[Texture],
        tracing: Option<&Tracing>,
    ) -> Vec3 {
        Machine::with(self, |m| {
            run_all(&self.instrs, at, textures, tracing, m, &mut 0.5);
            load(m, &at.points[0], self.output).truncate()
        })
    }

    /// Whether the material moves its vertices (Cycles' true displacement).
    pub fn displaces(&self) -> bool {
        self.displace.is_some()
    }

    /// Whether the surface keeps the bump of the displacement over the moved vertices
    /// (Cycles' "Displacement and Bump"): their normals are then left as they were; with
    /// "Displacement Only" they are computed again from the displaced surface.
    pub fn bumps_displaced_surface(&self) -> bool {
        self.displace.is_some() && self.displacement.is_some()
    }

    /// Whether flat faces that moved are shaded smooth, by their vertices' normals before the
    /// displacement, under the bump ("Displacement and Bump" as Blender 5's Cycles renders
    /// it), rather than by their displaced face's normal.
    pub fn smooths_flat_faces(&self) -> bool {
        self.bumps_displaced_surface() && self.smooth_flat_faces
    }

    /// The world-space vector (Blender's axes) the vertex at `at` moves by (`at.normal`: the
    /// vertex's smooth normal, seen from its front); `None` when the material does not
    /// move its vertices.
    pub fn displacement_at(&self, at: &ShadingInputs, textures: &[Texture]) -> Option<Vec3> {
        let vector = self.displace.as_ref()?.eval_raw_vector(at, textures, None);
        // Each component that is not finite reads 0, as Cycles keeps vertices finite.
        Some(Vec3::from_array(vector.to_array().map(|x| {
            if x.is_finite() {
                x
            } else {
                0.0
            }
        })))
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
pub(super) fn load(m: &Machine, at: &PointInputs, s: Src) -> Vec4 {
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
pub(super) fn operand(m: &Machine, at: &PointInputs, instr: &Instr, k: usize) -> Vec4 {
    if instr.all_regs {
        m.regs[instr.regs_in[k] as usize]
    } else {
        load(m, at, instr.ins[k])
    }
}

/// An instruction's inputs at one shading point, from its input `first` on (a fused
/// instruction holds several nodes' inputs one after the other).
pub(super) struct Reader<'a> {
    pub(super) m: &'a Machine,
    pub(super) at: &'a PointInputs,
    pub(super) instr: &'a Instr,
    pub(super) first: usize,
}

impl Operands for Reader<'_> {
    #[inline(always)]
    fn value(&self, k: usize) -> Vec4 {
        operand(self.m, self.at, self.instr, self.first + k)
    }
}

/// The closure `s` names (black when it names none), where the machine holds it.
pub(super) fn read_closure(m: &Machine, s: Src) -> &Closure {
    match s {
        Src::Closure(c) => &m.closures[c as usize],
        _ => &Closure::BLACK,
    }
}

/// Run `instrs` in order: one call, the instructions' bodies inlined in its loop (a call per
/// instruction cost each its large frame's set-up).
#[inline(never)]
pub(super) fn run_all(
    instrs: &[Instr],
    inputs: &ShadingInputs,
    textures: &[Texture],
    tracing: Option<&Tracing>,
    m: &mut Machine,
    u: &mut f32,
) {
    for instr in instrs {
        // Opaque to the optimiser: else it hoists the shared inputs' conversions (which few
        // instructions read) out of the loop, ~200 instructions per evaluation.
        run(instr, std::hint::black_box(inputs), textures, tracing, m, u);
    }
}

/// One instruction: its node family's evaluation, its outputs stored.
#[inline(always)]
pub(super) fn run(
    instr: &Instr,
    inputs: &ShadingInputs,
    textures: &[Texture],
    tracing: Option<&Tracing>,
    m: &mut Machine,
    u: &mut f32,
) {
    let at = &inputs.points[instr.offset as usize];
    let o = instr.out as usize;
    let used = instr.used;
    let ins = &Reader {
        m,
        at,
        instr,
        first: 0,
    };
    match &instr.op {
        Op::TexCoord { uv_set } => {
            let values = geometry::texture_coordinate(inputs, at, *uv_set, used);
            m.put_used(o, used, values)
        }
        Op::UvMap { uv_set } => m.regs[o] = geometry::uv_value(at, *uv_set),
        Op::VertexColor => m.put(o, geometry::vertex_color(at)),
        Op::Attribute { slot } => m.put(o, geometry::attribute(at, inputs.attributes.get(*slot))),
        Op::ObjectAttribute { slot } => m.put(
            o,
            geometry::attribute(at, Some(inputs.object.attributes[*slot as usize])),
        ),
        Op::LayerAttribute(value) => m.put(o, geometry::attribute(at, Some(*value))),
        Op::Geometry => m.put(o, geometry::geometry(inputs, at)),
        Op::Wireframe { pixel_size } => {
            m.regs[o] = geometry::eval_wireframe(*pixel_size, inputs, at, ins)
        }
        Op::ObjectInfo { material_index } => {
            m.put(o, geometry::object_info(inputs, *material_index))
        }
        Op::HairInfo { fibre, curve } => m.put(
            o,
            geometry::hair_info(
                inputs.attributes.get(*fibre),
                inputs.attributes.get(*curve),
                inputs.incoming,
                inputs.fibre,
            ),
        ),
        Op::LightPath => m.put_used(o, used, geometry::light_path(inputs)),
        Op::AmbientOcclusion(ao) => m.put(
            o,
            ambient_occlusion::eval_ambient_occlusion(ao, inputs, tracing, o as u64, ins),
        ),
        Op::Bevel { samples } => {
            m.regs[o] = bevel::eval_bevel(*samples, inputs, tracing, o as u64, ins)
        }
        Op::Value(v) => m.regs[o] = splat(*v),
        Op::Rgb(c) => m.regs[o] = *c,
        Op::Mapping(kind, fixed) => m.regs[o] = vector::eval_mapping(*kind, fixed, ins),
        Op::Math { op, clamp } => m.regs[o] = math::eval_math(*op, *clamp, ins),
        Op::Mix {
            data,
            blend,
            clamp_factor,
            clamp_result,
        } => m.regs[o] = color::eval_mix(*data, *blend, *clamp_factor, *clamp_result, ins),
        Op::RgbCurves {
            table,
            min_x,
            range,
        } => m.regs[o] = color::eval_rgb_curves(table, *min_x, *range, ins),
        Op::ColorRamp { table, interpolate } => {
            m.put(o, color::eval_color_ramp(table, *interpolate, ins))
        }
        Op::MapRange { kind, clamp } => m.regs[o] = math::eval_map_range(*kind, *clamp, ins),
        Op::Clamp { range } => m.regs[o] = math::eval_clamp(*range, ins),
        Op::Invert => m.regs[o] = color::eval_invert(ins),
        Op::SeparateXyz => m.put(o, convert::separate_xyz(ins)),
        Op::CombineXyz => m.regs[o] = convert::combine_xyz(ins),
        Op::SeparateColor { hsv } => m.put(o, convert::separate_color(*hsv, ins)),
        Op::CombineColor { hsv } => m.regs[o] = convert::combine_color(*hsv, ins),
        Op::Checker => m.put(o, checker::eval_checker(ins)),
        Op::Gradient(kind) => m.put(o, gradient::eval_gradient(*kind, ins)),
        Op::Noise {
            dimensions,
            normalize,
        } => m.put(o, noise::eval_noise(*dimensions, *normalize, used, ins)),
        Op::NoiseAt3 {
            dimensions,
            normalize,
            outs,
            used,
        } => {
            let at_point = |k: usize| Reader {
                m,
                at: &inputs.points[k],
                instr,
                first: NOISE_INPUTS.len() * k,
            };
            let readers = [at_point(0), at_point(1), at_point(2)];
            let values = noise::eval_noise_at3(
                *dimensions,
                *normalize,
                used,
                [0, 1, 2].map(|k| &readers[k]),
            );
            for (v, out) in values.into_iter().zip(outs) {
                m.put(*out as usize, v);
            }
        }
        Op::Image { texture, clip, .. } => {
            m.put(o, image::eval_image(*texture, *clip, textures, ins))
        }
        Op::Voronoi(kind) => m.put(o, voronoi::eval_voronoi(*kind, used, ins)),
        Op::Wave(kind) => m.put(o, wave::eval_wave(*kind, ins)),
        Op::WhiteNoise { dimensions } => m.put(o, white_noise::eval_white_noise(*dimensions, ins)),
        Op::Magic { depth } => m.put(o, magic::eval_magic(*depth, ins)),
        Op::Gabor { three_d } => m.put(o, gabor::eval_gabor(*three_d, ins)),
        Op::Brick(layout) => m.put(o, brick::eval_brick(layout, ins)),
        Op::Blackbody(space) => m.regs[o] = blackbody::eval_blackbody(*space, ins),
        Op::HueSaturation => m.regs[o] = color::eval_hue_saturation(ins),
        Op::Gamma => m.regs[o] = color::eval_gamma(ins),
        Op::BrightContrast => m.regs[o] = color::eval_bright_contrast(ins),
        Op::VectorMath(op) => m.put(o, vector::eval_vector_math(*op, ins)),
        Op::Fresnel => m.regs[o] = fresnel::eval_fresnel(inputs, ins),
        Op::LayerWeight => m.put(o, fresnel::eval_layer_weight(inputs, ins)),
        Op::Bump {
            invert,
            object_space,
        } => m.regs[o] = bump::eval_bump(*invert, *object_space, inputs, ins),
        Op::Displacement { object_space } => {
            m.regs[o] = bump::eval_displacement(*object_space, inputs, ins)
        }
        Op::NormalMap(space) => m.regs[o] = bump::eval_normal_map(*space, inputs, at, ins),
        Op::VectorDisplacement(space) => {
            m.regs[o] = bump::eval_vector_displacement(*space, inputs, at, ins)
        }
        Op::Principled {
            multiscatter,
            blender_5_film,
        } => {
            m.closures[o] =
                closure::eval_principled(*multiscatter, *blender_5_film, inputs, at, ins, u)
        }
        Op::Diffuse => m.closures[o] = closure::eval_diffuse(ins),
        Op::Glossy { multiscatter } => {
            m.closures[o] = closure::eval_glossy(*multiscatter, inputs, at, ins)
        }
        Op::Metallic {
            physical,
            multiscatter,
        } => m.closures[o] = closure::eval_metallic(*physical, *multiscatter, inputs, at, ins),
        Op::Sheen => m.closures[o] = closure::eval_sheen(ins),
        Op::Toon { glossy } => m.closures[o] = closure::eval_toon(*glossy, ins),
        Op::PrincipledHair { coloring } => {
            m.closures[o] = closure::eval_principled_hair(*coloring, ins)
        }
        Op::Hair { transmission } => m.closures[o] = closure::eval_hair(*transmission, ins),
        Op::Glass { multiscatter } => {
            m.closures[o] = closure::eval_glass(false, *multiscatter, ins)
        }
        Op::Refraction => m.closures[o] = closure::eval_glass(true, true, ins),
        Op::Emission => m.closures[o] = closure::eval_emission(ins),
        Op::Transparent => m.closures[o] = closure::eval_transparent(ins),
        Op::RayPortal { position_given } => {
            m.closures[o] = closure::eval_ray_portal(*position_given, inputs, at, ins)
        }
        Op::Holdout => m.closures[o] = closure::eval_holdout(),
        Op::Translucent => m.closures[o] = closure::eval_translucent(ins),
        Op::MixShader => {
            const A: usize = input(MIX_SHADER_INPUTS, "Shader");
            const B: usize = input(MIX_SHADER_INPUTS, "Shader_001");
            let (a, b) = (read_closure(m, instr.ins[A]), read_closure(m, instr.ins[B]));
            m.closures[o] = closure::eval_mix_shader(ins, a, b, u)
        }
        Op::AddShader => {
            const A: usize = input(ADD_SHADER_INPUTS, "Shader");
            const B: usize = input(ADD_SHADER_INPUTS, "Shader_001");
            let (a, b) = (read_closure(m, instr.ins[A]), read_closure(m, instr.ins[B]));
            m.closures[o] = closure::eval_add_shader(a, b, u)
        }
        Op::PrincipledVolume { attributes, space } => {
            let named = attributes.map(|slot| inputs.attributes.get(slot));
            m.closures[o] = volume::eval_principled_volume(ins, named, *space)
        }
        Op::VolumeScatter(phase) => m.closures[o] = volume::eval_volume_scatter(*phase, ins),
        Op::VolumeAbsorption => m.closures[o] = volume::eval_volume_absorption(ins),
    }
}
/// A timing aid, run by hand: `PHOTON_PROFILE_GLB=scene.glb cargo test --release --lib
/// nodes::profile -- --ignored --nocapture` prints the cost of a whole evaluation of material
/// 0's tree and of each of its instructions (at 256 points spread over the object).
#[cfg(test)]
mod profile {
    use super::*;
    use crate::shader::noise::{perlin3, snoise3_lanes};
    use crate::shader::voronoi::{
        cell_point, voronoi, CellHash, Metric, VoronoiFeature, VoronoiKind, VoronoiParams,
    };

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
                    cell_hash: CellHash::Lookup3,
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
                        run(instr, at, textures, None, m, &mut u);
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
