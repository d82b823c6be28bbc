//! What a node tree reads about a shading point (`PointInputs`, `ShadingInputs`), the ray it
//! is evaluated for (`RayPath`, as Cycles' path state describes it to the Light Path node),
//! the scene the nodes that trace rays see from the point (`SceneRays`, `Tracing`), and how a
//! node's evaluation reads its inputs (`Operands`).

use crate::math::{Mat3, Vec2, Vec3, Vec4};
use crate::rng::{fraction, hash64, hash_combine};
use crate::sobol::{sample_2d, Seeds};

/// UV maps node trees read (`TEXCOORD_0` …).
pub const UV_SETS: usize = 4;
const _: () = assert!(UV_SETS == 4, "PointInputs::uv holds UV_SETS maps");

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
    /// The named attributes the program reads (`NodeProgram::attributes`) at the point: the
    /// voxel grids of a Volume object, sampled where a volume tree is evaluated.
    pub attributes: NamedAttributes,
    /// The object (or instance) the point lies on, as the Object Info node reads it.
    pub object: ObjectInfo,
    /// The triangle the point lies on (world, Blender's axes), where the program reads it
    /// (`READS_TRIANGLE`: the Wireframe node).
    pub triangle: [Vec3; 3],
    /// The ray's footprint at the point, as Cycles' compact differential `dP` (the width one
    /// pixel of the camera covers there), for the Wireframe node's pixel size.
    pub pixel_width: f32,
    /// The fibre's direction at the point (world, unit; a hair tube's axis), where the program
    /// reads it (`READS_FIBRE`: Hair Info's Tangent Normal).
    pub fibre: Vec3,
}

/// What Blender's Object Info node reads of the object (or the instance) a point lies on,
/// as Cycles keeps it per object (`KernelObject`): its world location, its colour and alpha
/// (`Object.color`), its pass index, and its random number, the object's 32-bit random id
/// (Blender's `DepsgraphObjectInstance.random_id` for an instance, Cycles' hash of the
/// object's name otherwise) scaled to [0, 1] as Cycles scales it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObjectInfo {
    /// World location (Blender's axes).
    pub location: Vec3,
    pub color: Vec4,
    pub pass_index: f32,
    pub random: f32,
    /// The Object and Instancer attributes node trees read (Attribute nodes of those types),
    /// in the scene's slot order, as Cycles finds them per object or instance: (0, 0, 0, 0)
    /// for one found nowhere.
    pub attributes: [Vec4; OBJECT_ATTRIBUTES],
}

/// Object and Instancer attributes a scene's node trees may read.
pub const OBJECT_ATTRIBUTES: usize = 8;

impl Default for ObjectInfo {
    /// Blender's defaults: at the origin, white, index 0, random 0, no attributes.
    fn default() -> ObjectInfo {
        ObjectInfo {
            location: Vec3::ZERO,
            color: Vec4::ONE,
            pass_index: 0.0,
            random: 0.0,
            attributes: [Vec4::ZERO; OBJECT_ATTRIBUTES],
        }
    }
}

impl ObjectInfo {
    /// The random number of an object of 32-bit random id `id`: id / (2³² − 1) in single
    /// precision, as Cycles computes it (the divisor rounds to 2³²).
    pub fn random_of(id: u32) -> f32 {
        id as f32 * (1.0 / u32::MAX as f32)
    }
}

/// Values of a program's named attributes at a point, slot `k` for
/// `NodeProgram::attributes[k]`, with which of them the object has (Cycles' attribute lookup
/// finds or misses each one; a node reading a missed one falls back as Cycles' does).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NamedAttributes {
    pub values: [Vec4; NAMED_ATTRIBUTES],
    /// Bit `k` set: slot `k` was found.
    pub found: u8,
}

/// Named attributes a program reads at most.
pub const NAMED_ATTRIBUTES: usize = 4;

/// The slot of a node that reads no named attribute.
pub const NO_ATTRIBUTE: u8 = u8::MAX;

impl NamedAttributes {
    /// The value of `slot`, when it names an attribute the object has.
    #[inline(always)]
    pub fn get(&self, slot: u8) -> Option<Vec4> {
        let k = slot as usize;
        (k < NAMED_ATTRIBUTES && self.found & (1 << k) != 0).then(|| self.values[k])
    }
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

/// The scene as the nodes that trace rays (Ambient Occlusion, Bevel) see it from the shading
/// point, in Blender's axes: the integrator that shades the point provides it (`Tracing`).
/// Where there is no scene to trace (light tables, emitters sampled as lights, shadow rays'
/// transparency), there is no `Tracing`: Ambient Occlusion reads 1 and Bevel the normal, as
/// Cycles' shaders read them where they cannot trace.
pub trait SceneRays {
    /// Whether a ray from the shading point along the unit `direction` meets a surface before
    /// `distance`: any surface that casts shadows, or with `local` only the surfaces of the
    /// point's own object.
    fn occluded(&self, direction: Vec3, distance: f32, local: bool) -> bool;

    /// Each surface of the shading point's own object that the segment from `origin` along the
    /// unit `direction`, `length` long, crosses, in order along it.
    fn local_hits(
        &self,
        origin: Vec3,
        direction: Vec3,
        length: f32,
        visit: &mut dyn FnMut(LocalHit),
    );

    /// The shading point's unit geometric normal (of the triangle's winding).
    fn geometric_normal(&self) -> Vec3;
}

/// A surface point `SceneRays::local_hits` found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocalHit {
    pub position: Vec3,
    /// The triangle's unit normal (of its winding) and the interpolated smooth normal.
    pub geometric_normal: Vec3,
    pub normal: Vec3,
}

/// What a node tree traces rays with at one shading point: the scene and the seed of the
/// random numbers (fixed by the caller for the path and the point, so renders are
/// deterministic).
#[derive(Clone, Copy)]
pub struct Tracing<'a> {
    pub scene: &'a dyn SceneRays,
    pub seed: u64,
}

impl Tracing<'_> {
    /// Point `k` of the 2D points of the node whose instruction writes register `stream`: an
    /// Owen-scrambled (0, 2)-sequence per node and shading point, so a node's first 2^m
    /// samples fall one in each of 2^m strata of the square, as Cycles stratifies a node's
    /// samples (its branched path samples).
    pub(super) fn point(&self, stream: u64, k: u32) -> Vec2 {
        let a = hash_combine(&[self.seed, stream, 0x0a0b_e7e1_5a3f_c0de]);
        let b = hash64(a);
        let seeds = Seeds {
            shuffle: a as u32,
            x: (a >> 32) as u32,
            y: b as u32,
            z: (b >> 32) as u32,
        };
        let (x, y) = sample_2d(k, seeds);
        Vec2::new(fraction(x), fraction(y))
    }
}

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

pub(super) fn up_one(n: u16) -> u16 {
    n.saturating_add(1)
}

/// A socket's type.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Ty {
    Float,
    Vector,
    Color,
    Shader,
}

/// One socket of a node: its identifier (Blender's socket `identifier`), its type and, for an
/// input, Blender's default value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Socket {
    pub name: &'static str,
    pub ty: Ty,
    pub default: Vec4,
}

/// Blender's default grey (0.8) of colour inputs.
pub const GREY: Vec4 = Vec4::new(0.8, 0.8, 0.8, 1.0);

impl Socket {
    /// A float input of default `x`.
    pub const fn float(name: &'static str, x: f32) -> Socket {
        Socket {
            name,
            ty: Ty::Float,
            default: Vec4::new(x, x, x, 1.0),
        }
    }

    /// A vector input.
    pub const fn vector(name: &'static str, default: Vec4) -> Socket {
        Socket {
            name,
            ty: Ty::Vector,
            default,
        }
    }

    /// A colour input.
    pub const fn color(name: &'static str, default: Vec4) -> Socket {
        Socket {
            name,
            ty: Ty::Color,
            default,
        }
    }

    /// A shader input (unlinked: no shader).
    pub const fn shader(name: &'static str) -> Socket {
        Socket {
            name,
            ty: Ty::Shader,
            default: Vec4::ZERO,
        }
    }

    /// An output.
    pub const fn output(name: &'static str, ty: Ty) -> Socket {
        Socket {
            name,
            ty,
            default: Vec4::ZERO,
        }
    }
}

/// The position of the socket `name` in `sockets`. Called in a `const` (as every evaluation
/// names the inputs it reads), a name not in the table fails the build.
pub const fn input(sockets: &[Socket], name: &str) -> usize {
    let mut k = 0;
    while k < sockets.len() {
        if same_name(sockets[k].name, name) {
            return k;
        }
        k += 1;
    }
    panic!("no socket of that name");
}

const fn same_name(a: &str, b: &str) -> bool {
    let (a, b) = (a.as_bytes(), b.as_bytes());
    if a.len() != b.len() {
        return false;
    }
    let mut k = 0;
    while k < a.len() {
        if a[k] != b[k] {
            return false;
        }
        k += 1;
    }
    true
}

/// A node's inputs as its evaluation reads them: input `k` in the order of the node's socket
/// table, at the point the node is evaluated for.
pub trait Operands {
    /// Input `k`'s value.
    fn value(&self, k: usize) -> Vec4;

    /// Input `k` as a float (its first component).
    #[inline(always)]
    fn float(&self, k: usize) -> f32 {
        self.value(k).x
    }

    /// Input `k` as a vector or a colour without alpha.
    #[inline(always)]
    fn vector(&self, k: usize) -> Vec3 {
        self.value(k).truncate()
    }
}

/// A node's inputs given as values (unit tests of a node's evaluation).
#[cfg(test)]
impl<const N: usize> Operands for [Vec4; N] {
    fn value(&self, k: usize) -> Vec4 {
        self[k]
    }
}

/// A float output: `x` in the three components, alpha 1.
#[inline(always)]
pub fn splat(x: f32) -> Vec4 {
    Vec4::new(x, x, x, 1.0)
}

/// A vector or colour output, alpha 1.
#[inline(always)]
pub fn v3(v: Vec3) -> Vec4 {
    v.extend(1.0)
}

/// A Normal input: the given vector, or the shading normal when it is unlinked (zero).
pub(super) fn normal_input(given: Vec4, normal: Vec3) -> Vec3 {
    let g = given.truncate();
    if g == Vec3::ZERO {
        normal
    } else {
        g.normalize_or(normal)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
