//! The plain-data scene every part of Photon reads: world-space triangle meshes, prototype meshes
//! placed by instances (each stored once), materials, textures, lights, one camera and the world
//! background. Structs of vectors with integer indices,
//! no behaviour beyond small lookups and `validate`. Only `scene::gltf` builds it from files;
//! `scene::builtin` builds the embedded default Cornell box.
//!
//! Units are Cycles' units (docs/ARCHITECTURE.md): radiance in W·m⁻²·sr⁻¹, point/spot intensity in W/sr,
//! sun irradiance in W/m². Conversions from glTF's photometric units live in `scene::units`.

pub mod attributes;
pub mod builtin;
pub mod displace;
pub mod gltf;
pub mod grids;
pub mod load;
pub mod sky;
pub mod sky_hosek;
mod sky_hosek_data;
pub mod sky_multiple_scattering;
pub mod sky_preetham;
pub mod texture;
pub mod units;
pub mod vdb;
mod volume;

use crate::math::{Affine3A, Mat3, Vec2, Vec3, Vec3A, Vec4};
pub use crate::medium::Coefficients;
pub use texture::{Texture, TextureRef};

/// Blender's axes (Z up) for a glTF (Y up) vector: (x, y, z) ↦ (x, −z, y).
pub fn blender_axes(v: Vec3) -> Vec3 {
    BLENDER_AXES * v
}

/// `blender_axes` as a matrix (its columns: the images of x, y, z).
pub const BLENDER_AXES: Mat3 =
    Mat3::from_cols(Vec3::X, Vec3::new(0.0, 0.0, 1.0), Vec3::new(0.0, -1.0, 0.0));

/// A triangle mesh: in world space in `Scene::meshes`, in object space in `Scene::prototypes`.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    /// Name of the glTF node and mesh, for messages ("Cube/Cube.001 primitive 0").
    pub name: String,
    pub positions: Vec<Vec3>,
    /// Unit shading normals, one per vertex (generated from faces when the file has none).
    pub normals: Vec<Vec3>,
    /// UV set 0; empty when the file has none.
    pub uvs: Vec<Vec2>,
    /// UV sets 1, 2, … (`TEXCOORD_1` …, up to `crate::shader::UV_SETS` in all), which node trees read;
    /// each empty when the file has none.
    pub extra_uvs: Vec<Vec<Vec2>>,
    /// Tangents (xyz, w = bitangent sign); empty when the file has none.
    pub tangents: Vec<Vec4>,
    pub indices: Vec<[u32; 3]>,
    /// Index into `Scene::materials`.
    pub material: u32,
    /// Seen by camera rays. False for area-light geometry that Blender hides from the camera.
    pub camera_visible: bool,
    /// Blender's holdout object (or collection): where the camera sees it the image is black
    /// and its alpha 0; every other ray meets its material.
    pub holdout: bool,
    /// Blender's area-light spread (full angle, radians, in (0, π)): the emission narrows
    /// towards the normal as through a soft-box grid, the total power unchanged
    /// (`crate::light::spread_factor`). `None` emits over the whole hemisphere.
    pub emission_spread: Option<f32>,
    /// Blocks shadow rays (direct light). False for objects Blender hides from shadow rays.
    pub casts_shadows: bool,
    /// Vertex colours COLOR_0 (linear RGBA), one per vertex; empty when the file has none.
    pub colors: Vec<Vec4>,
    /// The Blender object the mesh belongs to, for node trees' Object and Generated
    /// coordinates; `None` reads world positions for both.
    pub object_space: Option<ObjectSpace>,
    /// Deformation blur (armatures, shape keys; our `PHOTON_object` "deform"): the stored
    /// positions at evenly spaced moments from the shutter's opening to its closing, each as
    /// long as `positions`; rays meet the triangles interpolated linearly between the two
    /// nearest. Empty: the mesh keeps `positions`, which are always those of the frame (and
    /// what textures read). Only prototypes deform.
    pub deformation: Vec<Vec<Vec3>>,
    /// The voxel grids of a Volume object (its medium's named attributes, read in
    /// `object_space`'s coordinates); `None` for other meshes.
    pub volume_grids: Option<std::sync::Arc<grids::VolumeGrids>>,
    /// Blender's light and shadow linking of the mesh's object (`LightLinks`).
    pub links: LightLinks,
    /// Blender's shadow catcher (`crate::shadow_catcher`).
    pub shadow_catcher: bool,
    /// What node trees' Object Info reads of the mesh's object (a prototype's instances carry
    /// their own: `Instance::object_info`).
    pub object_info: crate::shader::ObjectInfo,
    /// The named attributes its material's node tree reads, per vertex.
    pub node_attributes: attributes::NodeAttributes,
    /// The stored positions before true displacement moved them (`displace`), which
    /// Generated coordinates read as Cycles reads them (an attribute of the undisplaced
    /// mesh); empty when the mesh was not displaced.
    pub undisplaced: Vec<Vec3>,
}

/// Where a mesh's stored positions sit in its Blender object: object coordinates (Blender's
/// axes, Z up) and the object's texture space, which Generated coordinates map to [0, 1]³.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObjectSpace {
    /// Stored positions (world space for `Scene::meshes`, object space for prototypes, both in
    /// glTF's axes) → Blender object coordinates.
    pub to_object: Affine3A,
    /// Texture space centre and half size (Blender's `texspace_location`, `texspace_size`).
    pub texspace_location: Vec3,
    pub texspace_size: Vec3,
}

impl ObjectSpace {
    /// Generated coordinates of object-space point `p`: (p − location) / (2 size) + ½.
    pub fn generated(&self, p: Vec3) -> Vec3 {
        let size = Vec3::select(
            self.texspace_size.cmpeq(Vec3::ZERO),
            Vec3::ONE,
            self.texspace_size,
        );
        (p - self.texspace_location) / (2.0 * size) + Vec3::splat(0.5)
    }
}

/// A placed copy of a prototype mesh (`Scene::prototypes`, in object space): the mesh is
/// stored and put in a BVH once, whatever the number of its instances.
#[derive(Clone, Debug)]
pub struct Instance {
    /// Index into `Scene::prototypes`.
    pub prototype: u32,
    /// Object space → world space (mirrored only for moving copies: still mirrored copies are
    /// flattened).
    pub to_world: Affine3A,
    /// World space → object space (the inverse of `to_world`).
    pub to_object: Affine3A,
    /// Object-space normals → world space (inverse transpose of the linear part).
    pub normal_matrix: Mat3,
    /// Object space → world space at evenly spaced moments from the shutter's opening to its
    /// closing (Blender's motion blur; our `PHOTON_object` "motion"); empty: still at
    /// `to_world`.
    pub motion: Vec<Affine3A>,
    /// `to_world` mirrors (negative determinant): the triangles' winding normals and the
    /// tangents' handedness are flipped in world space, as for a flattened mirrored copy.
    pub mirrored: bool,
    /// Seen by camera rays (Blender's camera ray visibility of the placing object).
    pub camera_visible: bool,
    /// Blocks shadow rays (Blender's shadow ray visibility of the placing object).
    pub casts_shadows: bool,
    /// The placing object is a holdout (`Mesh::holdout`).
    pub holdout: bool,
    /// Blender's light and shadow linking of the placing object (`LightLinks`).
    pub links: LightLinks,
    /// The placing object is a shadow catcher (`Mesh::shadow_catcher`).
    pub shadow_catcher: bool,
    /// What node trees' Object Info reads of this instance.
    pub object_info: crate::shader::ObjectInfo,
}

impl Instance {
    /// An instance of `prototype` placed by `to_world` (invertible, finite).
    pub fn new(prototype: u32, to_world: Affine3A) -> Instance {
        let linear = Mat3::from(to_world.matrix3);
        Instance {
            prototype,
            to_world,
            to_object: to_world.inverse(),
            normal_matrix: linear.inverse().transpose(),
            motion: Vec::new(),
            mirrored: linear.determinant() < 0.0,
            camera_visible: true,
            casts_shadows: true,
            holdout: false,
            links: LightLinks::NONE,
            shadow_catcher: false,
            object_info: Default::default(),
        }
    }

    /// Object space → world space at `time` ∈ [0, 1] of the shutter.
    pub fn to_world_at(&self, time: f32) -> Affine3A {
        if self.motion.is_empty() {
            self.to_world
        } else {
            crate::math::interpolate_transform(&self.motion, time)
        }
    }

    /// World space → object space at `time`.
    pub fn to_object_at(&self, time: f32) -> Affine3A {
        if self.motion.is_empty() {
            self.to_object
        } else {
            self.to_world_at(time).inverse()
        }
    }

    /// Object-space normals → world space at `time`.
    pub fn normal_matrix_at(&self, time: f32) -> Mat3 {
        if self.motion.is_empty() {
            self.normal_matrix
        } else {
            Mat3::from(self.to_world_at(time).matrix3)
                .inverse()
                .transpose()
        }
    }
}

/// How a material's alpha is used (glTF `alphaMode`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AlphaMode {
    Opaque,
    /// Surfaces with alpha below the cutoff are skipped by rays.
    Mask {
        cutoff: f32,
    },
    /// Alpha is the probability that a ray sees the surface (stochastic transparency).
    Blend,
}

/// The glTF metallic-roughness material with the KHR extensions Blender writes, all factors
/// resolved; texture references multiply their factor, as glTF specifies.
#[derive(Clone, Debug)]
pub struct Material {
    pub name: String,
    /// Linear RGB base colour and alpha (baseColorFactor).
    pub base_color: Vec4,
    pub base_color_texture: Option<TextureRef>,
    pub metallic: f32,
    /// Perceptual roughness in [0, 1]; GGX α = roughness².
    pub roughness: f32,
    /// Metallic in B, roughness in G (glTF convention).
    pub metallic_roughness_texture: Option<TextureRef>,
    pub normal_texture: Option<TextureRef>,
    pub normal_scale: f32,
    /// Emitted radiance: emissiveFactor × KHR_materials_emissive_strength.
    pub emission: Vec3,
    pub emissive_texture: Option<TextureRef>,
    pub alpha_mode: AlphaMode,
    pub double_sided: bool,
    /// KHR_materials_transmission factor in [0, 1].
    pub transmission: f32,
    pub transmission_texture: Option<TextureRef>,
    /// KHR_materials_ior (glTF default 1.5).
    pub ior: f32,
    /// KHR_materials_specular: specularFactor (scales the dielectric Fresnel) and specularColorFactor.
    pub specular: f32,
    pub specular_color: Vec3,
    /// KHR_materials_volume: Beer–Lambert attenuation inside the object. `attenuation_distance` is
    /// infinite when there is no absorption.
    pub attenuation_color: Vec3,
    pub attenuation_distance: f32,
    /// KHR_materials_volume thicknessFactor; zero means thin-walled.
    pub thickness: f32,
    /// Blender's Principled subsurface inputs (our `PHOTON_material_subsurface` extension).
    pub subsurface: Subsurface,
    /// KHR_materials_clearcoat: clearcoatFactor (× texture R), clearcoatRoughnessFactor
    /// (× texture G) and the clearcoat normal texture with its scale. Read as Blender imports
    /// them: Blender's coat (IOR 1.5, untinted), roughness 0.03 when the factor and its
    /// texture are absent.
    pub coat: f32,
    pub coat_texture: Option<TextureRef>,
    pub coat_roughness: f32,
    pub coat_roughness_texture: Option<TextureRef>,
    pub coat_normal_texture: Option<TextureRef>,
    pub coat_normal_scale: f32,
    /// KHR_materials_sheen: sheenColorFactor (× texture RGB) and sheenRoughnessFactor
    /// (× texture A); present when the extension is (Blender's Sheen Weight 1 and Tint the
    /// colour).
    pub sheen: bool,
    pub sheen_color: Vec3,
    pub sheen_color_texture: Option<TextureRef>,
    pub sheen_roughness: f32,
    pub sheen_roughness_texture: Option<TextureRef>,
    /// KHR_materials_anisotropy as Blender imports it: anisotropyStrength (× texture B) is
    /// Blender's Anisotropic, the direction is anisotropyRotation (radians) plus, with a
    /// texture, the angle of its (R, G) × 2 − 1, around the UV map's tangent with a texture and
    /// Blender's default tangent (around the object's Z axis) without one.
    pub anisotropy: f32,
    pub anisotropy_rotation: f32,
    pub anisotropy_texture: Option<TextureRef>,
    /// KHR_materials_iridescence: a thin film of `iridescence` strength (× texture R), IOR
    /// `iridescence_ior`, thickness from `iridescence_thickness` [min, max] nanometres by the
    /// thickness texture's G (the maximum without one), rendered as Blender's Principled Thin
    /// Film (`crate::bsdf::thin_film`; a strength below 1 mixes the film-free Fresnel in).
    pub iridescence: f32,
    pub iridescence_texture: Option<TextureRef>,
    pub iridescence_ior: f32,
    pub iridescence_thickness: [f32; 2],
    pub iridescence_thickness_texture: Option<TextureRef>,
    /// KHR_materials_diffuse_transmission: diffuseTransmissionFactor (× texture A) of the
    /// diffuse base transmits, of diffuseTransmissionColorFactor (× texture RGB).
    pub diffuse_transmission: f32,
    pub diffuse_transmission_texture: Option<TextureRef>,
    pub diffuse_transmission_color: Vec3,
    pub diffuse_transmission_color_texture: Option<TextureRef>,
    /// The Blender node tree (our `PHOTON_material_nodes` extension), compiled: when present
    /// it replaces every factor and texture above at each shading point (`crate::material`).
    pub nodes: Option<std::sync::Arc<crate::shader::NodeProgram>>,
    /// What fills the object (Blender's Volume socket): rays that cross its surface into it
    /// travel through this medium until they cross out (`crate::integrator::media`).
    pub volume: Option<Volume>,
}

/// A participating medium: a material's volume (inside its object) or the world's (everywhere
/// outside every object that does not replace it): Blender's volume shaders as a node program
/// evaluated at points in the medium, or coefficients that are the same everywhere.
#[derive(Clone, Debug, PartialEq)]
pub struct Volume {
    /// The coefficients when they are the same at every point (homogeneous).
    pub constant: Option<Coefficients>,
    /// The volume's node program when they are not (heterogeneous).
    pub program: Option<std::sync::Arc<crate::shader::NodeProgram>>,
    /// A grey bound of the extinction coefficient over the medium, per scene unit.
    pub majorant: f32,
    /// Whether the medium emits light somewhere (for heterogeneous media: whether emission
    /// was seen where `Scene::bound_volumes` sampled it).
    pub emits: bool,
}

/// How light travels under a translucent surface: Blender's Principled BSDF "Subsurface
/// Method".
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SubsurfaceMethod {
    /// Christensen–Burley: a diffusion profile. The photon method renders it with the dipole
    /// (`crate::subsurface`); the path tracer with the random walk.
    ChristensenBurley,
    /// Cycles' Random Walk (Blender's default): a volumetric walk entering by refraction at the
    /// IOR (`crate::integrator::random_walk`).
    RandomWalk,
    /// Cycles' Random Walk (Skin): the radius adjusted by the albedo and Subsurface IOR, half
    /// the walks entering diffusely.
    RandomWalkSkin,
}

impl SubsurfaceMethod {
    /// Blender's name of the method (`subsurface_method`), as `PHOTON_material_subsurface`
    /// carries it; `None` for any other.
    pub fn from_blender(name: &str) -> Option<SubsurfaceMethod> {
        match name {
            "BURLEY" => Some(SubsurfaceMethod::ChristensenBurley),
            "RANDOM_WALK" => Some(SubsurfaceMethod::RandomWalk),
            "RANDOM_WALK_SKIN" => Some(SubsurfaceMethod::RandomWalkSkin),
            _ => None,
        }
    }
}

/// Blender's Principled BSDF subsurface inputs. The material is translucent when `weight > 0`:
/// the subsurface part then replaces `weight` × the diffuse part (see `crate::subsurface`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Subsurface {
    /// Subsurface Method.
    pub method: SubsurfaceMethod,
    /// Subsurface Weight in [0, 1].
    pub weight: f32,
    /// Subsurface Radius per channel; the mean free path is `radius × scale` (scene units).
    pub radius: Vec3,
    /// Subsurface Scale.
    pub scale: f32,
    /// Subsurface IOR (relative, inside over outside).
    pub ior: f32,
    /// Subsurface Anisotropy: the random walk's Henyey–Greenstein g (the dipole does not use
    /// it).
    pub anisotropy: f32,
}

impl Default for Subsurface {
    /// Blender's Principled BSDF defaults: Random Walk, weight 0, radius (1, 0.2, 0.1), scale
    /// 0.05, IOR 1.4.
    fn default() -> Self {
        Subsurface {
            method: SubsurfaceMethod::RandomWalk,
            weight: 0.0,
            radius: Vec3::new(1.0, 0.2, 0.1),
            scale: 0.05,
            ior: 1.4,
            anisotropy: 0.0,
        }
    }
}

impl Subsurface {
    /// Mean free path per channel (scene units).
    pub fn mean_free_path(&self) -> Vec3 {
        self.radius * self.scale
    }
}

impl Default for Material {
    /// glTF's defaults for a material with no properties.
    fn default() -> Self {
        Material {
            name: String::from("default"),
            base_color: Vec4::ONE,
            base_color_texture: None,
            metallic: 1.0,
            roughness: 1.0,
            metallic_roughness_texture: None,
            normal_texture: None,
            normal_scale: 1.0,
            emission: Vec3::ZERO,
            emissive_texture: None,
            alpha_mode: AlphaMode::Opaque,
            double_sided: false,
            transmission: 0.0,
            transmission_texture: None,
            ior: 1.5,
            specular: 1.0,
            specular_color: Vec3::ONE,
            attenuation_color: Vec3::ONE,
            attenuation_distance: f32::INFINITY,
            thickness: 0.0,
            subsurface: Subsurface::default(),
            coat: 0.0,
            coat_texture: None,
            coat_roughness: 0.03,
            coat_roughness_texture: None,
            coat_normal_texture: None,
            coat_normal_scale: 1.0,
            sheen: false,
            sheen_color: Vec3::ZERO,
            sheen_color_texture: None,
            sheen_roughness: 0.0,
            sheen_roughness_texture: None,
            anisotropy: 0.0,
            anisotropy_rotation: 0.0,
            anisotropy_texture: None,
            iridescence: 0.0,
            iridescence_texture: None,
            iridescence_ior: 1.3,
            iridescence_thickness: [100.0, 400.0],
            iridescence_thickness_texture: None,
            diffuse_transmission: 0.0,
            diffuse_transmission_texture: None,
            diffuse_transmission_color: Vec3::ONE,
            diffuse_transmission_color_texture: None,
            nodes: None,
            volume: None,
        }
    }
}

/// Largest vertex coordinate a scene may have: squared distances between points must stay
/// finite in single precision (1e38), with room for the renderer's arithmetic.
pub const MAX_COORDINATE: f32 = 1e15;

impl Material {
    /// A Lambert-like diffuse material (dielectric, rough, no specular) of the given colour.
    pub fn diffuse(name: &str, color: Vec3) -> Self {
        Material {
            name: name.to_string(),
            base_color: color.extend(1.0),
            metallic: 0.0,
            roughness: 1.0,
            specular: 0.0,
            double_sided: true,
            ..Material::default()
        }
    }

    /// True when the material has a subsurface (translucent) part.
    pub fn is_translucent(&self) -> bool {
        self.subsurface.weight > 0.0
    }

    /// True when the material is translucent with the Christensen–Burley method, which the
    /// photon method renders with the dipole (its subsurface photons).
    pub fn uses_dipole(&self) -> bool {
        self.is_translucent() && self.subsurface.method == SubsurfaceMethod::ChristensenBurley
    }

    /// True when the material emits light (some texel may be black, but the factor is not).
    pub fn is_emissive(&self) -> bool {
        self.emission.max_element() > 0.0 || self.nodes.as_ref().is_some_and(|n| n.emits)
    }
}

/// A light that is not geometry. Emissive triangles are lights too; they are found from the
/// materials when the renderer prepares the scene.
#[derive(Clone, Debug, PartialEq)]
pub enum Light {
    /// Emits `intensity` W/sr uniformly in all directions (Cycles: power P → I = P/4π).
    Point {
        position: Vec3,
        intensity: Vec3,
        /// Blender's soft-shadow radius; 0 is a true point.
        radius: f32,
        /// How the light looks to rays when `radius` > 0.
        lamp: Lamp,
    },
    /// A point light restricted to a cone around `direction`, with glTF's smooth falloff between
    /// the inner and outer cone angles. Intensity inside the cone as for a point light.
    Spot {
        position: Vec3,
        /// Unit vector the light points along.
        direction: Vec3,
        intensity: Vec3,
        cos_inner: f32,
        cos_outer: f32,
        radius: f32,
        lamp: Lamp,
    },
    /// A distant light: `irradiance` W/m² on a surface facing it.
    Sun {
        /// Unit vector the light travels along (from the sun into the scene).
        direction: Vec3,
        irradiance: Vec3,
        /// Angular diameter in radians (Blender's sun angle); 0 is a hard sun.
        angle: f32,
        /// Camera rays see the disc of a sun with an angle (the light object's
        /// `visible_camera`); other rays always do.
        camera: bool,
    },
}

/// How a point or spot light of radius > 0 meets rays, as Blender sets it: Cycles makes it a
/// lamp of uniform radiance I / (πr²) that light sampling draws from and rays can hit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Lamp {
    /// Blender's Soft Falloff (on by default): the lamp is a disc of the light's radius facing
    /// the point it lights (or the ray that meets it); off, a sphere of that radius.
    pub soft_falloff: bool,
    /// Camera rays see the lamp (the light object's `visible_camera`, off by default).
    pub camera: bool,
    /// Rays that surfaces scatter meet the lamp (the object's diffuse, glossy and transmission
    /// ray visibility all on): BSDF sampling and light sampling then share it by MIS. Off, the
    /// lamp only lights by light sampling.
    pub bounces: bool,
}

impl Default for Lamp {
    /// Blender's defaults for a light object.
    fn default() -> Self {
        Lamp {
            soft_falloff: true,
            camera: false,
            bounces: true,
        }
    }
}

/// The camera projection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// Vertical field of view in radians.
    Perspective { yfov: f32 },
    /// Half-width and half-height of the view in scene units (glTF xmag, ymag).
    Orthographic { xmag: f32, ymag: f32 },
    /// Cycles' equirectangular panorama: longitude from `longitude.0` at the left edge to
    /// `longitude.1` at the right (positive towards the camera's +X), latitude from
    /// `latitude.0` at the bottom to `latitude.1` at the top; longitude and latitude 0 is the
    /// camera's −Z. Radians.
    Equirectangular {
        longitude: (f32, f32),
        latitude: (f32, f32),
    },
    /// Cycles' equidistant fisheye: the angle to the camera's −Z grows linearly with the
    /// distance from the image centre, reaching `fov / 2` at the edges (an ellipse filling the
    /// frame on a non-square image); nothing is seen outside it.
    FisheyeEquidistant { fov: f32 },
    /// Cycles' equisolid fisheye: a sensor of `sensor` (width, height) behind a lens of focal
    /// length `lens` (same unit, millimetres), r = 2 f sin(θ/2), cut at θ = `fov / 2`.
    FisheyeEquisolid {
        lens: f32,
        fov: f32,
        sensor: (f32, f32),
    },
    /// Cycles' polynomial fisheye: on a sensor of `sensor` (width, height, millimetres) the
    /// angle to the camera's −Z at distance r from the centre is −(k0 + k1 r + … + k4 r⁴), cut
    /// at `fov / 2`.
    FisheyePolynomial {
        k: [f32; 5],
        fov: f32,
        sensor: (f32, f32),
    },
    /// Cycles' mirror ball: the image is a unit mirror sphere filling the frame, each pixel the
    /// reflection of the camera's −Z about the sphere's normal there (the centre looks along
    /// −Z, the rim along +Z).
    MirrorBall,
    /// Cycles' central cylindrical panorama: longitude (radians, 0 along the camera's −Z,
    /// positive towards +X) from `longitude.0` at the left edge to `longitude.1` at the right,
    /// and height on a cylinder of radius 1 around the camera's Y axis from `height.0` at the
    /// bottom to `height.1` at the top, each direction pointing at its cylinder point.
    CentralCylindrical {
        longitude: (f32, f32),
        height: (f32, f32),
    },
    /// Cycles' equiangular cube-map face: the 90° square in front of the camera (−Z), the
    /// angle (not its tangent) growing linearly across the image.
    CubeMapFace,
}

impl Projection {
    /// A panoramic projection (rays from one point in all directions the image covers).
    pub fn is_panoramic(&self) -> bool {
        !matches!(
            self,
            Projection::Perspective { .. } | Projection::Orthographic { .. }
        )
    }
}

/// The camera. Looks along its local −Z with +Y up, as glTF and Blender define.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    pub name: String,
    /// Camera space to world space (rigid; scale removed).
    pub to_world: Affine3A,
    pub projection: Projection,
    /// Width / height the file asks for; `None` lets the image size decide.
    pub aspect_ratio: Option<f32>,
    /// Blender's lens shift: the image window moves by this in its plane, in units of the
    /// image height (our `PHOTON_camera` extension; zero without it).
    pub shift: Vec2,
    /// Depth of field; `None` is a pinhole.
    pub lens: Option<ThinLens>,
    /// Camera space to world space (rigid) at evenly spaced moments from the shutter's opening
    /// to its closing (Blender's motion blur; our `PHOTON_camera` "motion"); empty: the camera
    /// stays at `to_world`.
    pub motion: Vec<Affine3A>,
    /// Blender's clip start (glTF `znear`): Cycles starts camera rays on this plane, so its
    /// Light Path Ray Length is measured from there. Zero when the file gives none.
    pub near_clip: f32,
    /// Blender's clip end (glTF `zfar`): Cycles' camera rays end on this plane, and what lies
    /// beyond it is not seen. Infinite when the file gives none.
    pub far_clip: f32,
}

impl Camera {
    /// How far along unit camera-ray direction `dir` (in world space) the near clip plane lies
    /// (Cycles' `nearclip × z_inv`; panoramas: the clip distance itself).
    pub fn near_clip_distance(&self, dir: Vec3) -> f32 {
        let forward = -self.to_world.z_axis.normalize_or(Vec3A::Z);
        let cos = Vec3A::from(dir).dot(forward);
        self.clip_distance(self.near_clip, cos)
    }

    /// How far along a camera ray at angle acos(`cos`) to the camera's axis a clip plane at
    /// `clip` lies: `clip / cos` for planar projections, `clip` itself for panoramas (which
    /// clip on a sphere); 0 for a clip of 0 and for rays that never meet the plane, whose far
    /// clip is then infinite.
    pub fn clip_distance(&self, clip: f32, cos: f32) -> f32 {
        if clip <= 0.0 {
            return 0.0;
        }
        if self.projection.is_panoramic() {
            return clip;
        }
        if cos > 0.0 {
            clip / cos
        } else if clip.is_infinite() {
            clip
        } else {
            0.0
        }
    }
}

/// A thin lens (Blender's depth of field as Cycles renders it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThinLens {
    /// Aperture radius in scene units (Cycles: focal length / (2 × f-stop)).
    pub radius: f32,
    /// Distance of the plane in focus along the camera axis.
    pub focus_distance: f32,
    /// Corners of the polygonal aperture; below 3 it is round.
    pub blades: u32,
    /// Rotation of the polygon's first corner from the camera's +x axis, in radians.
    pub rotation: f32,
    /// Anamorphic ratio: the aperture's x extent is divided by it.
    pub ratio: f32,
}

/// What rays that leave the scene see.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct World {
    /// What lights the scene, and what every ray that escapes sees unless `camera_background`
    /// says otherwise.
    pub background: Background,
    /// What camera rays that escape see instead (Blender's Light Path "Is Camera Ray" choosing
    /// between two backgrounds); `None`: the same as every other ray.
    pub camera_background: Option<Background>,
    /// The world's volume: a medium filling all space (Blender's World Volume socket).
    pub volume: Option<Volume>,
}

impl World {
    /// The background emits light (a non-black colour or an environment image).
    pub fn emits(&self) -> bool {
        match &self.background.environment {
            Some(env) => env.pixels.iter().any(|p| p.max_element() > 0.0),
            None => self.background.color.max_element() > 0.0,
        }
    }
}

/// A background: a constant radiance, or an environment map that replaces it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Background {
    /// Constant radiance (Blender world colour × strength); unused when `environment` is set.
    pub color: Vec3,
    /// An equirectangular environment image (Blender's Environment Texture, or a sky baked
    /// into one).
    pub environment: Option<Environment>,
}

impl Background {
    /// Radiance arriving from scene direction `dir`.
    pub fn radiance(&self, dir: Vec3) -> Vec3 {
        match &self.environment {
            Some(env) => env.radiance(dir),
            None => self.color,
        }
    }
}

/// An equirectangular environment map in Blender's convention (Cycles' Environment Texture):
/// for a direction d in Blender's Z-up frame, u = 0.5 − atan2(d.y, d.x)/2π across the image and
/// θ = acos(d.z) from the top row down (the top row is the +Z pole).
#[derive(Clone, Debug, PartialEq)]
pub struct Environment {
    pub width: u32,
    pub height: u32,
    /// Linear RGB radiance (image × Background strength), row 0 = top; shared, not copied, by
    /// the light that samples it.
    pub pixels: std::sync::Arc<[Vec3]>,
    /// Rotation from scene (glTF, Y-up) directions to the map's Blender frame: the axis change
    /// followed by the rotation of a Mapping node feeding the texture.
    pub to_map: Mat3,
    /// Nearest-pixel lookups (Blender's "Closest") instead of bilinear ("Linear").
    pub closest: bool,
}

impl Environment {
    /// Rotation from glTF's Y-up frame to Blender's Z-up frame: Blender (x, y, z) = glTF
    /// (x, −z, y).
    pub const Y_UP_TO_Z_UP: Mat3 = Mat3::from_cols(Vec3::X, Vec3::Z, Vec3::NEG_Y);

    /// A `width` × `height` map whose pixels are `radiance` (a function of the unit direction in
    /// the map's Blender frame) averaged over `samples` × `samples` directions spread over each
    /// pixel, so that what the map integrates to is kept. Rows are filled in parallel.
    pub fn bake(
        width: u32,
        height: u32,
        to_map: Mat3,
        samples: u32,
        radiance: impl Fn(Vec3) -> Vec3 + Sync,
    ) -> Environment {
        use rayon::prelude::*;
        let (w, h, n) = (width as usize, height as usize, samples.max(1));
        let mut pixels = vec![Vec3::ZERO; w * h];
        pixels.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
            for (x, pixel) in row.iter_mut().enumerate() {
                let mut sum = Vec3::ZERO;
                let mut weight = 0.0;
                for i in 0..n {
                    for j in 0..n {
                        let u = (x as f32 + (i as f32 + 0.5) / n as f32) / w as f32;
                        let t = (y as f32 + (j as f32 + 0.5) / n as f32) / h as f32;
                        let (theta, phi) = (
                            std::f32::consts::PI * t,
                            std::f32::consts::PI * (1.0 - 2.0 * u),
                        );
                        // Weighted by sin θ, each sample's share of the pixel's solid angle.
                        let sin_theta = theta.sin();
                        let d =
                            Vec3::new(sin_theta * phi.cos(), sin_theta * phi.sin(), theta.cos());
                        sum += radiance(d) * sin_theta;
                        weight += sin_theta;
                    }
                }
                // Samples lie inside the pixel, never on a pole: the weight is positive.
                *pixel = sum / weight;
            }
        });
        Environment {
            width,
            height,
            pixels: pixels.into(),
            to_map,
            closest: false,
        }
    }

    /// Image coordinates (u across, t down from the top, both in [0, 1]) of a scene direction,
    /// and sin θ (from x and y, which stay accurate near the poles).
    pub fn to_image(&self, dir: Vec3) -> (Vec2, f32) {
        let d = (self.to_map * dir).normalize_or_zero();
        let sin_theta = d.x.hypot(d.y);
        let u = 0.5 - d.y.atan2(d.x) / (2.0 * std::f32::consts::PI);
        let u = (u - u.floor()).min(1.0 - f32::EPSILON);
        (
            Vec2::new(u, sin_theta.atan2(d.z) / std::f32::consts::PI),
            sin_theta,
        )
    }

    /// Radiance arriving from scene direction `dir` (towards the environment).
    pub fn radiance(&self, dir: Vec3) -> Vec3 {
        let (p, _) = self.to_image(dir);
        let (w, h) = (self.width as usize, self.height as usize);
        let px = &self.pixels;
        if self.closest {
            let x = ((p.x * w as f32) as usize).min(w - 1);
            let y = ((p.y * h as f32) as usize).min(h - 1);
            return px[y * w + x];
        }
        // Bilinear between pixel centres, wrapping around in u and clamped at the poles.
        let fx = p.x * w as f32 - 0.5;
        let fy = (p.y * h as f32 - 0.5).clamp(0.0, (h - 1) as f32);
        let (x0, y0) = (fx.floor(), fy.floor());
        let (ax, ay) = (fx - x0, fy - y0);
        let x0 = (x0 as i64).rem_euclid(w as i64) as usize;
        let x1 = (x0 + 1) % w;
        let y0 = y0 as usize;
        let y1 = (y0 + 1).min(h - 1);
        let row = |y: usize| px[y * w + x0] * (1.0 - ax) + px[y * w + x1] * ax;
        row(y0) * (1.0 - ay) + row(y1) * ay
    }
}

/// Render settings a scene file may carry (our `PHOTON_render` extension); the command line wins.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SceneRenderSettings {
    pub width: Option<u32>,
    pub height: Option<u32>,
    pub transparent_film: bool,
    /// Blender's pixel filter (Cycles' film settings); `None`: Blender's default.
    pub filter: Option<crate::film::FilterSettings>,
    /// Blender's Light Paths › Max Bounces › Volume: scatterings in media a path may continue
    /// from (0, Blender's default: single scattering, each lit by light samples alone).
    pub volume_bounces: u32,
    /// Blender's Light Paths › Clamping › Direct and Indirect (Cycles' sample clamps): the
    /// largest contribution one path sample may add, per colour channel on average; 0: no limit
    /// (`integrator::walk::Clamp`).
    pub clamp_direct: f32,
    pub clamp_indirect: f32,
    /// Blender's Light Paths › Caustics › Reflective and Refractive Caustics switched off
    /// (both on by default): a surface a path reaches straight after a diffuse bounce loses
    /// its glossy reflection, or transmission, lobes (`integrator::shading::LightPathFilter`).
    pub reflective_caustics_off: bool,
    pub refractive_caustics_off: bool,
    /// Blender's Light Paths › Caustics › Filter Glossy (0: off): glossy lobes roughened by the
    /// smallest density of the path's bounces so far.
    pub filter_glossy: f32,
    /// The file's working colour space, the one the image is computed and written in.
    pub working_space: crate::color_space::WorkingSpace,
}

/// Everything there is to render.
#[derive(Clone, Debug)]
pub struct Scene {
    /// World-space meshes.
    pub meshes: Vec<Mesh>,
    /// Object-space meshes placed by `instances`, of any material: lights (`crate::light`),
    /// photon emission, subsurface and caustic aiming see each instance where it is at a
    /// ray's or photon's moment.
    pub prototypes: Vec<Mesh>,
    pub instances: Vec<Instance>,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    pub lights: Vec<Light>,
    pub camera: Camera,
    pub world: World,
    pub render_settings: SceneRenderSettings,
    /// Non-fatal problems found while loading (skipped primitives, unsupported features).
    pub warnings: Vec<String>,
    /// What the exporter could not carry, as the Blender add-on names it in the file (its
    /// pre-flight report already showed each in Blender): `photon info` lists them with the
    /// warnings; a render does not repeat them.
    pub export_notes: Vec<String>,
    /// Light linking of `lights` as emitters, index for index (missing: none).
    pub light_links: Vec<LightLinks>,
}

/// Blender's light and shadow linking (Object › Shading › Light Linking), as Cycles' light
/// sets: an emitter with a receiver collection lights only the objects of its receiver set,
/// one with a blocker collection is shadowed only by the objects of its blocker set. Sets are
/// numbered 1 to 63; set 0 holds every object, for emitters without a collection.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LightLinks {
    /// Bit k: the object is in receiver set k (lit by the emitters of that set).
    pub lit_by: u64,
    /// Bit k: the object is in blocker set k (casts the shadows of that set's emitters).
    pub blocks: u64,
    /// As an emitter: its receiver set and its blocker set (0: none, everything).
    pub receiver_set: u8,
    pub blocker_set: u8,
}

impl LightLinks {
    /// No linking: in every set, an emitter of none.
    pub const NONE: LightLinks = LightLinks {
        lit_by: u64::MAX,
        blocks: u64::MAX,
        receiver_set: 0,
        blocker_set: 0,
    };

    /// Whether an object of these links is lit by `emitter`.
    pub fn lit_by(&self, emitter: &LightLinks) -> bool {
        self.lit_by >> emitter.receiver_set & 1 == 1
    }

    /// Whether an object of these links blocks light from `emitter`.
    pub fn blocks(&self, emitter: &LightLinks) -> bool {
        self.blocks >> emitter.blocker_set & 1 == 1
    }
}

impl Default for LightLinks {
    fn default() -> Self {
        LightLinks::NONE
    }
}

impl Mesh {
    /// Bounds of the mesh's vertices (in its own space), at every step of its deformation.
    pub fn bounds(&self) -> Bounds {
        let mut b = Bounds::EMPTY;
        for &p in self
            .positions
            .iter()
            .chain(self.deformation.iter().flatten())
        {
            b.grow(p);
        }
        b
    }

    /// The stored positions of triangle `t`'s vertices at `time` ∈ [0, 1] of the shutter:
    /// interpolated between the deformation's two nearest steps, or `positions`.
    pub fn triangle_at(&self, t: u32, time: f32) -> [Vec3; 3] {
        let idx = self.indices[t as usize];
        let last = self.deformation.len().saturating_sub(1);
        if last == 0 {
            return idx.map(|i| self.positions[i as usize]);
        }
        let x = time.clamp(0.0, 1.0) * last as f32;
        let k = (x.floor() as usize).min(last - 1);
        let f = x - k as f32;
        let (a, b) = (&self.deformation[k], &self.deformation[k + 1]);
        idx.map(|i| a[i as usize].lerp(b[i as usize], f))
    }
}

/// World bounds of `instance` from its prototype's object-space `local` bounds (the eight
/// corners transformed); for a moving instance, of every place it takes while the shutter is
/// open (sampled finely between its poses, then widened by the largest step between samples).
pub fn instance_bounds(instance: &Instance, local: Bounds) -> Bounds {
    let mut b = Bounds::EMPTY;
    if local.is_empty() {
        return b;
    }
    let corners = |to_world: Affine3A, b: &mut Bounds| {
        for corner in 0..8 {
            let pick = |bit: usize, lo: f32, hi: f32| if corner >> bit & 1 == 0 { lo } else { hi };
            let p = Vec3::new(
                pick(0, local.min.x, local.max.x),
                pick(1, local.min.y, local.max.y),
                pick(2, local.min.z, local.max.z),
            );
            b.grow(to_world.transform_point3(p));
        }
    };
    corners(instance.to_world, &mut b);
    if instance.motion.is_empty() {
        return b;
    }
    const STEPS: usize = 64;
    let mut step = 0.0f32;
    let mut previous = instance.to_world_at(0.0);
    for i in 0..=STEPS {
        let pose = instance.to_world_at(i as f32 / STEPS as f32);
        corners(pose, &mut b);
        for corner in [local.min, local.max] {
            let moved = pose.transform_point3(corner) - previous.transform_point3(corner);
            step = step.max(moved.length());
        }
        previous = pose;
    }
    Bounds {
        min: b.min - Vec3::splat(step),
        max: b.max + Vec3::splat(step),
    }
}

/// Axis-aligned bounds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    pub min: Vec3,
    pub max: Vec3,
}

impl Bounds {
    pub const EMPTY: Bounds = Bounds {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    pub fn grow(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    pub fn is_empty(&self) -> bool {
        !(self.min.x <= self.max.x && self.min.y <= self.max.y && self.min.z <= self.max.z)
    }

    pub fn diagonal(&self) -> f32 {
        if self.is_empty() {
            0.0
        } else {
            (self.max - self.min).length()
        }
    }

    pub fn center(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }
}

impl Scene {
    /// Materials whose node tree reads the camera path's state (Light Path's Is Diffuse Ray
    /// … and depths), which only the path tracer carries to every shading point.
    pub fn ray_state_materials(&self) -> Vec<&str> {
        self.node_materials_where(|p| p.reads_ray_state)
    }

    /// Materials whose node tree has a Ray Portal BSDF, which only the camera paths follow.
    pub fn ray_portal_materials(&self) -> Vec<&str> {
        self.node_materials_where(|p| p.ray_portal)
    }

    /// The names of the materials whose node tree passes `test`.
    fn node_materials_where(
        &self,
        test: impl Fn(&crate::shader::NodeProgram) -> bool,
    ) -> Vec<&str> {
        self.materials
            .iter()
            .filter(|m| m.nodes.as_ref().is_some_and(|p| test(p)))
            .map(|m| m.name.as_str())
            .collect()
    }

    /// Bounds of all geometry (empty for a scene with no triangles).
    pub fn bounds(&self) -> Bounds {
        let mut b = Bounds::EMPTY;
        for m in &self.meshes {
            for &p in &m.positions {
                b.grow(p);
            }
        }
        let local: Vec<Bounds> = self.prototypes.iter().map(Mesh::bounds).collect();
        for instance in &self.instances {
            let bounds = instance_bounds(instance, local[instance.prototype as usize]);
            if !bounds.is_empty() {
                b.grow(bounds.min);
                b.grow(bounds.max);
            }
        }
        b
    }

    /// Triangles placed in the scene, each instance counted.
    pub fn placed_triangle_count(&self) -> usize {
        self.meshes.iter().map(|m| m.indices.len()).sum::<usize>()
            + self
                .instances
                .iter()
                .map(|i| self.prototypes[i.prototype as usize].indices.len())
                .sum::<usize>()
    }

    /// Whether some instance moves or deforms while the shutter is open (`Instance::motion`,
    /// `Mesh::deformation`).
    pub fn has_motion(&self) -> bool {
        self.instances.iter().any(|i| !i.motion.is_empty())
            || self.prototypes.iter().any(|m| !m.deformation.is_empty())
    }

    /// Triangles stored: world-space meshes and prototypes (each once).
    pub fn triangle_count(&self) -> usize {
        self.meshes
            .iter()
            .chain(&self.prototypes)
            .map(|m| m.indices.len())
            .sum()
    }

    /// Check the invariants the renderer relies on; returns a description of the first problem.
    /// The glTF loader calls this, so a `Scene` it returns is always valid.
    pub fn validate(&self) -> Result<(), String> {
        for (i, instance) in self.instances.iter().enumerate() {
            if instance.prototype as usize >= self.prototypes.len() {
                return Err(format!("instance {i}: prototype index out of range"));
            }
            if !instance.to_world.is_finite()
                || !instance.to_object.is_finite()
                || instance.motion.iter().any(|m| !m.is_finite())
                || !instance.normal_matrix.is_finite()
            {
                return Err(format!(
                    "instance {i}: transform is NaN, infinite or singular"
                ));
            }
        }
        for (mi, m) in self.meshes.iter().chain(&self.prototypes).enumerate() {
            let n = m.positions.len();
            if m.material as usize >= self.materials.len() {
                return Err(format!(
                    "mesh {mi} '{}': material index {} out of range",
                    m.name, m.material
                ));
            }
            if m.normals.len() != n {
                return Err(format!(
                    "mesh {mi} '{}': {} normals for {n} positions",
                    m.name,
                    m.normals.len()
                ));
            }
            if let Some(uvs) = std::iter::once(&m.uvs)
                .chain(&m.extra_uvs)
                .find(|uvs| !uvs.is_empty() && uvs.len() != n)
            {
                return Err(format!(
                    "mesh {mi} '{}': {} UVs for {n} positions",
                    m.name,
                    uvs.len()
                ));
            }
            if !m.colors.is_empty() && m.colors.len() != n {
                return Err(format!(
                    "mesh {mi} '{}': {} vertex colours for {n} positions",
                    m.name,
                    m.colors.len()
                ));
            }
            if !m.tangents.is_empty() && m.tangents.len() != n {
                return Err(format!(
                    "mesh {mi} '{}': {} tangents for {n} positions",
                    m.name,
                    m.tangents.len()
                ));
            }
            if let Some(t) = m
                .indices
                .iter()
                .find(|t| t.iter().any(|&i| i as usize >= n))
            {
                return Err(format!(
                    "mesh {mi} '{}': triangle {t:?} indexes past {n} vertices",
                    m.name
                ));
            }
            if m.deformation.len() == 1
                || m.deformation.iter().any(|step| step.len() != n)
                || m.deformation.iter().flatten().any(|p| !p.is_finite())
                || (!m.deformation.is_empty() && mi < self.meshes.len())
            {
                return Err(format!(
                    "mesh {mi} '{}': a deformation needs two or more steps of {n} finite \
                     positions, on a prototype",
                    m.name
                ));
            }
            if m.positions.iter().any(|p| !p.is_finite()) {
                return Err(format!(
                    "mesh {mi} '{}': vertex position is NaN or infinite",
                    m.name
                ));
            }
            if let Some(p) = m
                .positions
                .iter()
                .find(|p| p.abs().max_element() > MAX_COORDINATE)
            {
                return Err(format!(
                    "mesh {mi} '{}': vertex position {p} is beyond ±{MAX_COORDINATE:e} \
                     (distances between such points overflow single precision)",
                    m.name
                ));
            }
            if m.normals.iter().any(|p| !p.is_finite()) {
                return Err(format!(
                    "mesh {mi} '{}': vertex normal is NaN or infinite",
                    m.name
                ));
            }
            if let Some(spread) = m.emission_spread {
                if !(spread > 0.0 && spread <= std::f32::consts::PI) {
                    return Err(format!(
                        "mesh {mi} '{}': emission spread {spread} is not in (0, π]",
                        m.name
                    ));
                }
            }
            if m.uvs.iter().any(|p| !p.is_finite()) {
                return Err(format!("mesh {mi} '{}': UV is NaN or infinite", m.name));
            }
        }
        for m in &self.materials {
            let refs = [
                &m.base_color_texture,
                &m.metallic_roughness_texture,
                &m.normal_texture,
                &m.emissive_texture,
                &m.transmission_texture,
            ];
            for r in refs.into_iter().flatten() {
                if r.texture as usize >= self.textures.len() {
                    return Err(format!(
                        "material '{}': texture index {} out of range",
                        m.name, r.texture
                    ));
                }
            }
            let values = [
                m.metallic,
                m.roughness,
                m.transmission,
                m.ior,
                m.specular,
                m.normal_scale,
            ];
            if values.iter().any(|v| !v.is_finite())
                || !m.base_color.is_finite()
                || !m.emission.is_finite()
            {
                return Err(format!(
                    "material '{}': a factor is NaN or infinite",
                    m.name
                ));
            }
        }
        for (i, l) in self.lights.iter().enumerate() {
            let ok = match l {
                Light::Point {
                    position,
                    intensity,
                    radius,
                    ..
                } => position.is_finite() && intensity.is_finite() && radius.is_finite(),
                Light::Spot {
                    position,
                    direction,
                    intensity,
                    cos_inner,
                    cos_outer,
                    radius,
                    ..
                } => {
                    position.is_finite()
                        && direction.is_finite()
                        && intensity.is_finite()
                        && cos_inner.is_finite()
                        && cos_outer.is_finite()
                        && radius.is_finite()
                }
                Light::Sun {
                    direction,
                    irradiance,
                    angle,
                    ..
                } => direction.is_finite() && irradiance.is_finite() && angle.is_finite(),
            };
            if !ok {
                return Err(format!("light {i}: a parameter is NaN or infinite"));
            }
        }
        for background in
            std::iter::once(&self.world.background).chain(self.world.camera_background.as_ref())
        {
            if !background.color.is_finite() {
                return Err("world colour is NaN or infinite".into());
            }
            if let Some(env) = &background.environment {
                if env.pixels.len() != env.width as usize * env.height as usize || env.width == 0 {
                    return Err("environment image: pixel count does not match its size".into());
                }
                if !env.to_map.is_finite() || env.pixels.iter().any(|p| !p.is_finite()) {
                    return Err("environment image: a value is NaN or infinite".into());
                }
            }
        }
        if self.camera.motion.iter().any(|m| !m.is_finite()) {
            return Err(format!(
                "camera '{}': a motion pose is NaN or infinite",
                self.camera.name
            ));
        }
        if !self.camera.shift.is_finite() {
            return Err(format!(
                "camera '{}': lens shift is NaN or infinite",
                self.camera.name
            ));
        }
        if let Some(l) = &self.camera.lens {
            let ok = l.radius.is_finite()
                && l.radius >= 0.0
                && l.focus_distance.is_finite()
                && l.focus_distance > 0.0
                && l.rotation.is_finite()
                && l.ratio.is_finite()
                && l.ratio > 0.0;
            if !ok {
                return Err(format!(
                    "camera '{}': depth of field needs a finite aperture radius ≥ 0, focus \
                     distance > 0 and ratio > 0",
                    self.camera.name
                ));
            }
        }
        let panorama_ok = match self.camera.projection {
            Projection::Perspective { .. } | Projection::Orthographic { .. } => true,
            Projection::Equirectangular {
                longitude,
                latitude,
            } => [longitude.0, longitude.1, latitude.0, latitude.1]
                .iter()
                .all(|v| v.is_finite()),
            Projection::FisheyeEquidistant { fov } => fov.is_finite() && fov > 0.0,
            Projection::FisheyeEquisolid { lens, fov, sensor } => [lens, fov, sensor.0, sensor.1]
                .iter()
                .all(|v| v.is_finite() && *v > 0.0),
            Projection::FisheyePolynomial { k, fov, sensor } => {
                k.iter().all(|v| v.is_finite())
                    && [fov, sensor.0, sensor.1]
                        .iter()
                        .all(|v| v.is_finite() && *v > 0.0)
            }
            Projection::CentralCylindrical { longitude, height } => {
                [longitude.0, longitude.1, height.0, height.1]
                    .iter()
                    .all(|v| v.is_finite())
            }
            Projection::MirrorBall | Projection::CubeMapFace => true,
        };
        if !panorama_ok {
            return Err(format!(
                "camera '{}': panoramic projection parameters must be finite (and positive \
                 for a fisheye)",
                self.camera.name
            ));
        }
        if !self.camera.to_world.is_finite() {
            return Err(format!(
                "camera '{}': transform is NaN or infinite",
                self.camera.name
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn near_clip_distance_grows_off_axis_as_cycles_z_inv() {
        // Camera at the origin looking down −Z (glTF's convention), clip start 0.5.
        let mut camera = Camera {
            name: "c".into(),
            to_world: Affine3A::IDENTITY,
            projection: Projection::Perspective { yfov: 1.0 },
            aspect_ratio: None,
            shift: Vec2::ZERO,
            lens: None,
            motion: Vec::new(),
            near_clip: 0.5,
            far_clip: f32::INFINITY,
        };
        assert!((camera.near_clip_distance(-Vec3::Z) - 0.5).abs() < 1e-6);
        let off_axis = Vec3::new(0.6, 0.0, -0.8);
        assert!((camera.near_clip_distance(off_axis) - 0.5 / 0.8).abs() < 1e-6);
        camera.near_clip = 0.0;
        assert_eq!(camera.near_clip_distance(off_axis), 0.0);
    }
}
