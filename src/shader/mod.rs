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
//! Ambient Occlusion and Bevel trace rays from the shading point through the scene the
//! integrator gives the evaluation (`NodeProgram::eval_tracing` with a `Tracing`: a
//! `SceneRays` trait object, so this layer knows no BVH, and the seed of the nodes' random
//! numbers); without one they read 1 and the normal.
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
//! the BSDF's Lambertian transmission lobe alone (`Closure::translucent`); Toon → its lobe
//! alone (`Closure::toon`, `crate::bsdf`); Metallic → metallic 1 with Base Color as F0 and Edge
//! Tint as the F82 tint (`Closure::metal_tint`), a physical conductor by its exact Fresnel at
//! 0° and 82°. Mix Shader mixes emission exactly and picks one BSDF per shading point with
//! probability given by the factor, as Cycles samples one closure by its weight: the BSDF is
//! linear in its closures, so every integrator (path tracing, photon tracing and gathering,
//! caches) gets the exact mixture in expectation, where interpolating parameters would not be
//! exact (a metal and a dielectric of different colours). Add Shader sums emission; of two BSDFs
//! it picks one with probability ½, which halves their sum (approximate; exact when one side
//! only emits, the common case).
//!
//! The files, as Cycles' `kernel/svm/` lays out its own: what a tree reads (`inputs`, with the
//! `Socket` tables and `Operands`, inputs read by name checked at compile time) and what a
//! shader node gives (`closure`); compiling: which socket tables a node has (`sockets`), each
//! node's JSON into its operation (`parse`), the tree into a program (`compile`, `program`) and
//! its optimisations (`optimise`); running it (`machine`: the registers and the dispatch loop,
//! each instruction one call into its node family's file); and one file per node family, with
//! its socket tables and evaluation: `geometry` (the input nodes), `ambient_occlusion` and
//! `bevel` (which trace rays: `inputs::Tracing`), `math`, `vector`, `color`,
//! `convert`, `bump`, `fresnel`, `closure` (the shader nodes), and the textures `noise` (with
//! its AVX2 kernels), `voronoi`, `checker`, `gradient`, `brick`, `magic`, `gabor`,
//! `wave`, `white_noise`, `image`, with `blackbody`, and the volume shaders (`volume`); `hash` is Jenkins' lookup3 the textures
//! draw from, and `lanes` the one, four or eight lanes of floats and words the noise and the
//! Voronoi search are written over. ARCHITECTURE.md says how to add a node.

mod ambient_occlusion;
mod bevel;
mod blackbody;
mod brick;
mod bump;
mod checker;
mod closure;
mod color;
mod compile;
mod convert;
mod fresnel;
mod gabor;
mod geometry;
mod gradient;
mod hash;
mod image;
mod inputs;
mod lanes;
mod machine;
mod magic;
mod math;
mod noise;
mod optimise;
mod parse;
mod program;
mod sockets;
mod vector;
mod volume;
mod voronoi;
mod wave;
mod white_noise;

pub use closure::{
    default_tangent, principled_aspect, Closure, Hair, RayPortal, Toon, VolumeClosure,
};
pub use compile::compile;
pub use inputs::{
    LocalHit, NamedAttributes, ObjectInfo, PointInputs, RayPath, Scattering, SceneRays,
    ShadingInputs, Tracing, NAMED_ATTRIBUTES, OBJECT_ATTRIBUTES, UV_SETS,
};
pub use program::{
    CompileWarnings, NodeProgram, MAX_CLOSURES, MAX_REGISTERS, READS_ALL, READS_COLOR,
    READS_COORDS, READS_FIBRE, READS_OBJECT_NORMAL, READS_TANGENT, READS_TRIANGLE, READS_UV,
};

#[cfg(test)]
mod tests;
