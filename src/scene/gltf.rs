//! The only code that reads glTF: `.glb` and `.gltf` files (external buffers and images, or data
//! URIs) become a plain-data, validated `Scene` in world space. The `gltf` crate parses and
//! validates the JSON; buffers, accessors and images are read here with every byte range checked,
//! so a broken file gives an `Error::Scene` naming the glTF object, never a panic.
//!
//! # Photon's glTF extensions
//!
//! Blender's exporter drops what glTF cannot say; the add-on writes it back in these extensions.
//! They are listed in `extensionsUsed`, never in `extensionsRequired`, and every field is optional.
//!
//! - `PHOTON_world` on a scene: `{"color": [r, g, b], "strength": s, "environment": {...}}`.
//!   The background radiance is `color × strength` (defaults: black, 1). The optional
//!   `environment` is an equirectangular image (Blender's Environment Texture feeding the
//!   Background node), which replaces the colour: `{"uri": "file.exr", "rotation": [x, y, z],
//!   "interpolation": "linear" | "closest"}`. `uri` is an OpenEXR file (R, G, B channels, linear)
//!   relative to the glTF file; the radiance is image × `strength`. The mapping is Cycles': for a
//!   direction d in Blender's Z-up frame (glTF (x, y, z) is Blender (x, −z, y)), the column is
//!   u = 0.5 − atan2(d.y, d.x)/2π and the row θ = acos(d.z)/π from the top. `rotation` (radians,
//!   default 0) is the Euler XYZ rotation of a Mapping node (Point type) applied to d before the
//!   lookup; `interpolation` defaults to linear (bilinear, wrapping around in u).
//!   In place of `environment`, `sky` is Blender's Sky Texture in its Nishita model
//!   (`crate::scene::sky`): `{"type": "NISHITA", "sun_elevation": e, "sun_rotation": r,
//!   "sun_size": a, "sun_intensity": i, "sun_disc": bool, "altitude": m, "air": f, "dust": f,
//!   "ozone": f, "rotation": [x, y, z]}` (radians and metres; defaults Blender's: 15°, 0,
//!   0.545°, 1, true, 0, 1, 1, 1; `rotation` as for `environment`). It is baked × `strength`
//!   into a 1024 × 512 environment map, and its sun disc becomes a sun light. Several
//!   backgrounds are summed with `"mix": [{"weight": w, "color": ..., "strength": s,
//!   "environment" | "sky": ...}, ...]` (in place of the fields above); their maps are resampled
//!   onto the finest one. `"camera": {...}` (the same fields, `mix` included) is what camera
//!   rays that leave the scene see instead of the rest (Blender's Light Path "Is Camera Ray");
//!   a sky's sun there is not drawn. Out-of-range values are refused with an error.
//! - `PHOTON_render` on a scene: `{"width": w, "height": h, "film_transparent": bool, "filter":
//!   {"type": "BLACKMAN_HARRIS" | "GAUSSIAN" | "BOX", "width": px}}`, the render resolution,
//!   whether the background is transparent in the image, and Cycles' pixel filter (Blender's
//!   width; the default width of the type when it is missing). Unknown types and widths outside
//!   0.01–10 px are refused.
//! - `PHOTON_light` on a node:
//!   - with a KHR_lights_punctual point or spot light: `{"radius": r, "soft_falloff": bool,
//!     "visible_camera": bool, "visible_bounces": bool}`, Blender's soft-shadow radius in metres
//!     (default 0), its Soft Falloff (default true), whether camera rays see the lamp (default
//!     false, Blender's default for lights) and whether rays scattered by surfaces meet it (its
//!     diffuse, glossy and transmission visibility all on; default true);
//!   - with a directional light: `{"angle": a}`, the sun's angular diameter in radians (default 0);
//!   - an area light (which the exporter drops): `{"type": "area", "shape": "SQUARE" |
//!     "RECTANGLE" | "DISK" | "ELLIPSE", "size": x, "size_y": y, "power": watts, "color": [r, g,
//!     b], "visible_camera": bool, "spread": a}`. It becomes a one-sided emissive mesh in the node's local XY
//!     plane, centred on the origin (disks and ellipses as a 32-segment fan), emitting along the
//!     node's local −Z. `size` is the X extent (SQUARE, DISK: both), `size_y` the Y extent
//!     (RECTANGLE, ELLIPSE; default `size`); the node's scale applies, as in Blender. Its radiance
//!     is `color × power / (π × area)` with the area of the polygon actually built (Blender's
//!     "normalize"). `spread` (radians, in [0, π]) narrows the emission around the normal as
//!     Cycles' spread does, keeping the power (`crate::light::spread_factor`). Defaults: SQUARE,
//!     size 1, power 10 W, white, `visible_camera` false, spread π.
//!   - with a point, spot or directional light, optional `"color": [r, g, b]` with `"power": W`
//!     (point, spot) or `"strength": W/m²` (sun) replace the KHR light's colour and intensity:
//!     the add-on writes Cycles' combination of the light's colour, blackbody temperature and
//!     node-tree emission. A spot's optional `"spot_size"` (full cone angle, radians) and
//!     `"spot_blend"` (0–1) give Cycles' exact cone, smoothstep((cos θ − cos(size/2)) /
//!     ((1 − cos(size/2)) × blend)), in place of glTF's inner and outer angles.
//!
//! - `PHOTON_camera` on a camera node: `{"shift": [x, y], "dof": {"aperture_radius": r,
//!   "focus_distance": d, "blades": n, "rotation": a, "ratio": q}}`. `shift` is Blender's lens
//!   shift converted to units of the image height (the image window moves by `shift × image
//!   height` in its plane; default 0). `dof` is a thin lens: aperture radius in scene units
//!   (Blender's focal length / (2 × f-stop); 0 is a pinhole), the focus distance along the camera
//!   axis (default 10), the number of polygon corners (below 3 round), the polygon's rotation in
//!   radians and the anamorphic ratio (the aperture's x extent is divided by it; default 1).
//!   Out-of-range values are refused with an error. An optional `"panorama"` replaces the
//!   projection with one of Cycles' panoramic cameras: `{"type": "EQUIRECTANGULAR",
//!   "longitude": [min, max], "latitude": [min, max]}` (radians, left to right and bottom to
//!   top, 0 along the camera's −Z; defaults the whole sphere), `{"type":
//!   "FISHEYE_EQUIDISTANT", "fov": a}` or `{"type": "FISHEYE_EQUISOLID", "lens": mm, "fov": a,
//!   "sensor": [width, height]}` (millimetres, the sensor as Cycles fits it to the image); see
//!   `scene::Projection`. Panoramas ignore `shift` and `dof`. Blender's exporter drops
//!   panoramic cameras but keeps their node: a node with a `panorama` and no glTF camera is a
//!   camera too. An optional `"motion": [m0, m1, ...]` (two or more column-major 4 × 4 world
//!   matrices, glTF axes) gives the camera's poses at evenly spaced moments from the shutter's
//!   opening to its closing (Blender's motion blur): each camera sample takes a uniform moment
//!   and the pose interpolated there (translation linearly, rotation by slerp), as Cycles
//!   blurs camera motion.
//! - `PHOTON_object` on a mesh node: `{"visible_camera": bool, "visible_shadow": bool,
//!   "holdout": bool}` (visibility default true, holdout false), Blender's camera and shadow
//!   ray visibility: camera rays pass through an object hidden from the camera, shadow rays
//!   (direct light) through one that casts no shadows; a holdout object is black with alpha 0
//!   where the camera sees it (`Mesh::holdout`).
//! - `PHOTON_material_subsurface` on a material: `{"method": m, "weight": w, "radius": [r, g, b],
//!   "scale": s, "ior": n, "anisotropy": g}`, Blender's Principled BSDF subsurface inputs
//!   (defaults: method "RANDOM_WALK", weight 0, radius [1.0, 0.2, 0.1], scale 0.05, IOR 1.4,
//!   anisotropy 0; the method is Blender's `subsurface_method`: "BURLEY", "RANDOM_WALK" or
//!   "RANDOM_WALK_SKIN"). With weight > 0 the material is translucent: the subsurface part
//!   replaces weight × the diffuse part, with the base colour as its total diffuse reflectance
//!   and `radius × scale` (scene units) setting the medium (Cycles' random walk,
//!   `crate::integrator::random_walk`; the dipole of `crate::subsurface` for "BURLEY" in the
//!   photon method). Out-of-range values are refused with an error.
//! - `PHOTON_material_nodes` on a material: Blender's shader node tree as `crate::scene::nodes`
//!   compiles it: `{"nodes": [node, ...], "output": {"node": i, "output": "BSDF"}}`. Each node is
//!   `{"name": n, "type": bl_idname, "inputs": {identifier: value or link}, ...settings}` where a
//!   value is a number or a list of 2–4 numbers (Blender's socket value), a link is
//!   `{"node": j, "output": identifier}` with j earlier in the list, and the settings are the
//!   node's own properties under Blender's names (`operation`, `blend_type`, `data_type`,
//!   `gradient_type`, …; a Value or RGB node's `value`; a Color Ramp's `table` of 256 RGBA
//!   entries sampled at i/255 and its `interpolation`). `output` is what feeds the active
//!   Material Output's Surface (absent: black). `displacement`, when present, is a tree of the
//!   same form whose `output` is a vector: the shading normal bumped by what feeds the Material
//!   Output's Displacement (Cycles' "Bump Only"), which the surface tree then reads as its
//!   normal. When present the tree replaces the glTF values
//!   at every shading point (volume, subsurface and alpha mode still come from glTF and the
//!   other extensions). A malformed tree is refused with an error; a node type Photon does not
//!   evaluate gives a warning and what it feeds reads the input's default. Without `nodes`,
//!   `{"warnings": [...]}` lists what the add-on could not describe (the glTF values are
//!   rendered); these go to `Scene::export_notes`, which `photon info` lists.
//! - `PHOTON_object` may also carry `"texture_space": {"location": [x, y, z], "size": [x, y,
//!   z]}`, the object's texture space in Blender object coordinates (Z up), which node trees'
//!   Generated coordinates map to [0, 1]³ (default: the bounds of the mesh).
//! - `PHOTON_object` may also carry `"motion": [m0, m1, ...]`: two or more column-major 4 × 4
//!   world matrices (glTF axes) of the node at evenly spaced moments from the shutter's opening
//!   to its closing (Blender's motion blur). Its mesh becomes a prototype placed by an instance
//!   that each ray meets where it is at the ray's moment (`scene::Instance::motion`), whatever
//!   its material; the node's descendants without poses of their own move with it (Geometry
//!   Nodes and particle instances under a moving object), mirrored or not. A node under a
//!   singular transform stays at its own transform, with a warning.
//! - `PHOTON_object` may also carry `"deform": {"frame": b64, "steps": [b64, ...]}`, a
//!   deforming mesh (Cycles' deformation blur): its object's vertices at the frame and at two
//!   or more evenly spaced moments from the shutter's opening to its closing, each base64 of
//!   little-endian f32 triples in object space (glTF axes). The mesh becomes a prototype
//!   (`scene::Mesh::deformation`); each glTF vertex is found by its exact position among the
//!   frame's (a primitive with a vertex not found stays still, with a warning). Malformed
//!   data is refused with an error.
//!
//! # Coat, sheen and anisotropy
//!
//! `KHR_materials_clearcoat`, `KHR_materials_sheen` and `KHR_materials_anisotropy` are read as
//! Blender's importer turns them into Principled BSDF inputs, so a file renders as Cycles
//! renders it once imported: clearcoat → Coat Weight and Coat Roughness (× the textures' R and
//! G; roughness 0.03, Blender's default, when neither factor nor texture is given; IOR 1.5,
//! untinted) with the clearcoat normal texture as the Coat Normal; sheen → Sheen Weight 1,
//! Sheen Tint = sheenColorFactor (× texture RGB), Sheen Roughness (× texture A);
//! anisotropy → Anisotropic = anisotropyStrength (× texture B), its direction turned by
//! anisotropyRotation (radians) and, with a texture, by the angle of its (R, G) × 2 − 1, from
//! the mesh's UV tangent with a texture and from Blender's default tangent (around the object's
//! Z axis) without one (`crate::material::eval_surface`).
//!
//! `KHR_materials_iridescence` (which Blender 4.5's exporter and importer leave out) is read
//! as Blender's Principled Thin Film: thickness = iridescenceThicknessMinimum + (Maximum −
//! Minimum) × the thickness texture's G (Maximum without a texture), IOR = iridescenceIor,
//! and iridescenceFactor (× texture R) mixing the film's Fresnel over the plain one; the film
//! lies on the specular layer and the glass, not on metals (`crate::bsdf::thin_film`, as
//! Cycles 4.5).
//!
//! Vertex colours `COLOR_0` (VEC3 or VEC4, float or normalized unsigned) are read into
//! `Mesh::colors`: node trees read them (Color Attribute), and a material without a node tree
//! multiplies its base colour by them, as glTF specifies.
//!
//! # Images
//!
//! Textures are PNG, JPEG or WebP. A texture with `EXT_texture_webp` uses the extension's WebP
//! image (its `source`) in place of the fallback, so the extension may be required (Blender's
//! exporter requires it when it writes no PNG or JPEG fallback). 16-bit PNGs keep their 16 bits
//! (decoded to linear floats when loaded); node trees' Image Texture nodes also read OpenEXR
//! files (linear floats).
//!
//! # Limits and conventions
//!
//! Files that would exhaust memory are refused before allocating: accessors must fit in their
//! buffer views, and the hierarchy is counted before any geometry is read: at most
//! `MAX_NODE_INSTANCES` (1 M) node instances, `MAX_TRIANGLES` (200 M) stored triangles and
//! `MAX_VERTICES` (400 M) stored vertices. Only the default scene (or the first) is loaded; UV
//! set 0 only for glTF's textures (node trees read `TEXCOORD_0` to `_3`). Vertex attributes must have the component types glTF allows (integers only
//! with KHR_mesh_quantization, normalized UVs also without).
//!
//! A mesh placed by two or more nodes, whatever its materials, is stored once as a prototype
//! (`Scene::prototypes`) and placed by `Scene::instances` (each with its node's
//! `PHOTON_object` ray visibility), counted once against the limits. Still copies under a
//! mirroring or singular transform and every other mesh are flattened to world space (a
//! moving mirrored copy is a mirrored instance: `scene::Instance::mirrored`); under a mirroring
//! transform the triangle winding is flipped and the tangent's w (bitangent sign) is negated,
//! so both the geometric normal and the tangent frame keep their meaning.
//!
//! # Units
//!
//! Punctual lights are photometric as Blender's exporter writes them in "Standard" mode:
//! point/spot candela and sun lux are converted by `scene::units`. Material emission
//! (`emissiveFactor × KHR_materials_emissive_strength`) is already radiance.

use super::texture::{Texels, Wrap};
use super::{
    AlphaMode, Background, Bounds, Camera, Environment, Lamp, Light, Material, Mesh, Projection,
    Scene, SceneRenderSettings, Subsurface, SubsurfaceMethod, Texture, TextureRef, ThinLens, World,
};
use crate::error::{Error, Result};
use crate::film::{FilterKind, FilterSettings};
use crate::math::{srgb_to_linear, Affine3A, Mat3, Mat4, Vec2, Vec3, Vec4};
use crate::scene::sky::{NishitaSettings, NishitaSky};
use crate::scene::units;
use gltf::accessor::DataType;
use gltf::mesh::Mode;
use serde_json::Value;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Options that change what is loaded.
#[derive(Clone, Debug, Default)]
pub struct LoadOptions {
    /// Use the camera whose glTF node or camera name matches; `None` picks the first camera.
    pub camera: Option<String>,
}

/// Scenes with more triangles than this (after instancing) are refused rather than exhausting
/// memory.
pub const MAX_TRIANGLES: usize = 200_000_000;

/// An accessor without a buffer view is all zeros; refuse absurd counts for those.
const MAX_VIEWLESS_ELEMENTS: usize = 1 << 24;

/// Node instances (nodes reached through the hierarchy, counting each path to a shared node)
/// beyond this are refused: a small file can otherwise describe billions of instances.
pub const MAX_NODE_INSTANCES: usize = 1_000_000;

/// Vertices (after instancing) beyond this are refused.
pub const MAX_VERTICES: usize = 400_000_000;

/// Node hierarchies deeper than this are treated as broken.
const MAX_NODE_DEPTH: usize = 1000;

/// Extensions Photon reads; any other in `extensionsRequired` makes the file unloadable.
const SUPPORTED_EXTENSIONS: &[&str] = &[
    "KHR_lights_punctual",
    "KHR_materials_transmission",
    "KHR_materials_ior",
    "KHR_materials_volume",
    "KHR_materials_emissive_strength",
    "KHR_materials_specular",
    "KHR_materials_clearcoat",
    "KHR_materials_sheen",
    "KHR_materials_anisotropy",
    "KHR_materials_iridescence",
    "KHR_texture_transform",
    "KHR_mesh_quantization",
    "EXT_texture_webp",
];

/// Segments of the fan that approximates disk and ellipse area lights.
const AREA_LIGHT_SEGMENTS: usize = 32;

/// Width of the environment map a sky is baked into (height half of it): 0.35° pixels, each
/// the mean of 3 × 3 lookups of the sky's own table.
const SKY_MAP_WIDTH: u32 = 1024;

/// Load a `.glb` or `.gltf` file.
pub fn load(path: &Path, options: &LoadOptions) -> Result<Scene> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    let base = path.parent().unwrap_or_else(|| Path::new("."));
    Loader::parse(&bytes, path, Some(base))?.build(options)
}

/// Load a `.glb` (or self-contained `.gltf`) held in memory; `name` stands for the path in
/// messages. External files cannot be resolved, so every buffer and image must be embedded.
pub fn load_slice(bytes: &[u8], name: &str, options: &LoadOptions) -> Result<Scene> {
    Loader::parse(bytes, Path::new(name), None)?.build(options)
}

/// A parsed document with its buffers loaded, and the scene being built from it.
struct Loader {
    path: PathBuf,
    /// Directory external URIs are resolved against; `None` for in-memory files.
    base: Option<PathBuf>,
    document: gltf::Document,
    buffers: Vec<Vec<u8>>,
    /// Scene material index of each glTF material, in document order; the glTF default
    /// material, when used, is appended after them.
    default_material: Option<u32>,
    /// Decoded RGBA8 images by glTF image index.
    images: HashMap<usize, DecodedImage>,
    /// Scene texture index per (glTF texture index, sRGB).
    texture_slots: HashMap<(usize, bool), u32>,
    /// The current material's textures that read a UV set other than 0: warned about unless
    /// the material's node tree replaces them.
    uv_set_warnings: Vec<String>,
    scene: Scene,
    triangle_total: usize,
    vertex_total: usize,
    node_instances: usize,
    /// The file declares KHR_mesh_quantization: vertex attributes may be stored as integers.
    quantized: bool,
    /// glTF meshes stored once as prototypes (`Scene::prototypes`) and placed by instances.
    instanced_meshes: std::collections::HashSet<usize>,
    /// Prototype indices of each instanced glTF mesh (one per primitive), once built.
    prototype_ids: HashMap<usize, Vec<u32>>,
}

#[derive(Clone)]
struct DecodedImage {
    name: String,
    width: u32,
    height: u32,
    /// As stored: `Texels::Linear` holds 16-bit and float values still sRGB-encoded when the
    /// texture is (`push_texture` decodes them).
    texels: Texels,
}

/// Where a node's parent is: its world matrix, and its poses over the shutter when it moves
/// (empty: still).
struct Placement {
    world: Mat4,
    motion: Vec<Affine3A>,
}

impl Placement {
    const ROOT: Placement = Placement {
        world: Mat4::IDENTITY,
        motion: Vec::new(),
    };
}

/// A camera found while walking the node tree.
struct FoundCamera {
    node_name: String,
    camera_name: String,
    camera: Camera,
}

impl Loader {
    fn err(&self, object: impl Into<String>, message: impl Into<String>) -> Error {
        Error::scene(&self.path, object, message)
    }

    /// Parse JSON (or split a GLB), check required extensions, validate, and load buffers.
    fn parse(bytes: &[u8], path: &Path, base: Option<&Path>) -> Result<Loader> {
        let (json, blob) = if bytes.starts_with(b"glTF") {
            split_glb(bytes).map_err(|m| Error::scene(path, "GLB container", m))?
        } else {
            (bytes, None)
        };
        let mut root: gltf::json::Root = serde_json::from_slice(json)
            .map_err(|e| Error::scene(path, "JSON", format!("malformed glTF JSON: {e}")))?;

        let unsupported: Vec<&String> = root
            .extensions_required
            .iter()
            .filter(|e| !SUPPORTED_EXTENSIONS.contains(&e.as_str()))
            .collect();
        if !unsupported.is_empty() {
            let names: Vec<&str> = unsupported.iter().map(|s| s.as_str()).collect();
            return Err(Error::scene(
                path,
                "extensionsRequired",
                format!(
                    "the file requires unsupported glTF extension(s) {}; Photon supports {}",
                    names.join(", "),
                    SUPPORTED_EXTENSIONS.join(", ")
                ),
            ));
        }
        check_attribute_indices(&root).map_err(|(object, m)| Error::scene(path, object, m))?;
        use_webp_sources(&mut root).map_err(|(object, m)| Error::scene(path, object, m))?;
        // Everything left is supported here, even the extensions the gltf crate's validation does
        // not list as "enabled" (volume, specular); required-ness has been checked.
        root.extensions_required.clear();
        let quantized = root
            .extensions_used
            .iter()
            .any(|e| e == "KHR_mesh_quantization");

        let document = gltf::Document::from_json(root).map_err(|e| match e {
            gltf::Error::Validation(errors) => {
                let listed: Vec<String> = errors
                    .iter()
                    .take(5)
                    .map(|(p, e)| format!("{p}: {e}"))
                    .collect();
                let more = errors.len().saturating_sub(5);
                let suffix = if more > 0 {
                    format!(" (and {more} more)")
                } else {
                    String::new()
                };
                Error::scene(
                    path,
                    "document",
                    format!("invalid glTF: {}{suffix}", listed.join("; ")),
                )
            }
            other => Error::scene(path, "document", format!("invalid glTF: {other}")),
        })?;

        let mut loader = Loader {
            path: path.to_path_buf(),
            base: base.map(Path::to_path_buf),
            document,
            buffers: Vec::new(),
            default_material: None,
            images: HashMap::new(),
            texture_slots: HashMap::new(),
            uv_set_warnings: Vec::new(),
            scene: Scene {
                meshes: Vec::new(),
                prototypes: Vec::new(),
                instances: Vec::new(),
                materials: Vec::new(),
                textures: Vec::new(),
                lights: Vec::new(),
                camera: Camera {
                    name: String::new(),
                    to_world: Affine3A::IDENTITY,
                    projection: Projection::Perspective { yfov: 0.6981 },
                    aspect_ratio: None,
                    shift: Vec2::ZERO,
                    lens: None,
                    motion: Vec::new(),
                    near_clip: 0.0,
                },
                world: World::default(),
                render_settings: SceneRenderSettings::default(),
                warnings: Vec::new(),
                export_notes: Vec::new(),
            },
            triangle_total: 0,
            vertex_total: 0,
            node_instances: 0,
            quantized,
            instanced_meshes: Default::default(),
            prototype_ids: HashMap::new(),
        };
        loader.load_buffers(blob)?;
        Ok(loader)
    }

    fn load_buffers(&mut self, mut blob: Option<&[u8]>) -> Result<()> {
        let mut buffers = Vec::new();
        for buffer in self.document.buffers() {
            let object = named("buffer", buffer.index(), buffer.name());
            let mut data = match buffer.source() {
                gltf::buffer::Source::Bin => blob
                    .take()
                    .ok_or_else(|| {
                        self.err(&object, "refers to the GLB binary chunk, which is missing")
                    })?
                    .to_vec(),
                gltf::buffer::Source::Uri(uri) => self.read_uri(uri, &object)?,
            };
            if data.len() < buffer.length() {
                return Err(self.err(
                    &object,
                    format!(
                        "declares {} bytes but only {} are present (truncated file?)",
                        buffer.length(),
                        data.len()
                    ),
                ));
            }
            data.truncate(buffer.length());
            buffers.push(data);
        }
        self.buffers = buffers;
        Ok(())
    }

    /// Bytes behind a URI: a base64 data URI or a file relative to the glTF file.
    fn read_uri(&self, uri: &str, object: &str) -> Result<Vec<u8>> {
        if let Some(rest) = uri.strip_prefix("data:") {
            let (_, payload) = rest
                .split_once(";base64,")
                .ok_or_else(|| self.err(object, "data URI is not base64"))?;
            return decode_base64(payload)
                .ok_or_else(|| self.err(object, "data URI holds invalid base64"));
        }
        let file = self.resolve_file(uri, object)?;
        std::fs::read(&file).map_err(|e| {
            self.err(
                object,
                format!("cannot read external file '{}': {e}", file.display()),
            )
        })
    }

    fn resolve_file(&self, uri: &str, object: &str) -> Result<PathBuf> {
        let Some(base) = &self.base else {
            return Err(self.err(
                object,
                format!("refers to external file '{uri}', which an in-memory file cannot resolve"),
            ));
        };
        if uri.contains("://") && !uri.starts_with("file://") {
            return Err(self.err(object, format!("unsupported URI scheme in '{uri}'")));
        }
        let relative = uri
            .strip_prefix("file://")
            .or_else(|| uri.strip_prefix("file:"))
            .unwrap_or(uri);
        let decoded = percent_decode(relative).ok_or_else(|| {
            self.err(object, format!("malformed percent-encoding in URI '{uri}'"))
        })?;
        Ok(base.join(decoded))
    }

    /// Walk the default scene and assemble everything.
    fn build(mut self, options: &LoadOptions) -> Result<Scene> {
        self.load_materials()?;
        let document = self.document.clone();
        let gltf_scene = document
            .default_scene()
            .or_else(|| document.scenes().next());
        let mut cameras = Vec::new();
        if let Some(gltf_scene) = &gltf_scene {
            self.check_sizes(gltf_scene)?;
            for node in gltf_scene.nodes() {
                let mut ancestors = Vec::new();
                self.visit_node(&node, Placement::ROOT, &mut ancestors, &mut cameras)?;
            }
            self.read_scene_extensions(gltf_scene)?;
        } else {
            self.scene.warnings.push("the file has no scene".into());
        }
        self.scene.camera = self.choose_camera(cameras, options)?;
        self.scene
            .validate()
            .map_err(|m| Error::scene(&self.path, "scene", m))?;
        Ok(self.scene)
    }

    /// Count what the scene's hierarchy instantiates (node instances, and triangles and
    /// vertices from the accessors' counts) and refuse it when it is over a limit, before any
    /// geometry is read or allocated.
    fn check_sizes(&mut self, gltf_scene: &gltf::Scene) -> Result<()> {
        let mut per_mesh: HashMap<usize, (usize, usize)> = HashMap::new();
        for mesh in self.document.meshes() {
            let (mut triangles, mut vertices) = (0usize, 0usize);
            for primitive in mesh.primitives() {
                let Some(positions) = primitive.get(&gltf::Semantic::Positions) else {
                    continue;
                };
                self.check_accessor_fits(&positions)?;
                if let Some(indices) = primitive.indices() {
                    self.check_accessor_fits(&indices)?;
                }
                let count = primitive.indices().map_or(positions.count(), |a| a.count());
                triangles = triangles.saturating_add(match primitive.mode() {
                    Mode::Triangles => count / 3,
                    Mode::TriangleStrip | Mode::TriangleFan => count.saturating_sub(2),
                    _ => 0,
                });
                vertices = vertices.saturating_add(positions.count());
            }
            per_mesh.insert(mesh.index(), (triangles, vertices));
        }
        // Meshes placed by two or more nodes become prototypes: stored once, placed by
        // instances.
        // So do meshes of nodes that move while the shutter is open (or whose ancestors do): an
        // instance is placed per ray, at the ray's moment.
        let mut uses: HashMap<usize, usize> = HashMap::new();
        let mut moving = std::collections::HashSet::new();
        let mut visited = 0;
        for node in gltf_scene.nodes() {
            count_mesh_uses(&node, &mut uses, &mut moving, false, 0, &mut visited);
        }
        self.instanced_meshes = uses
            .into_iter()
            .filter(|&(mesh, n)| n >= 2 || moving.contains(&mesh))
            .map(|(mesh, _)| mesh)
            .collect();
        let mut totals = SizeTotals::default();
        for node in gltf_scene.nodes() {
            self.count_node(&node, &per_mesh, &mut Vec::new(), &mut totals)?;
        }
        Ok(())
    }

    /// Whether `node` places its mesh as an instance: an instanced mesh and a transform that
    /// is invertible and, unless the node `moving`, not mirrored (still mirrored copies are
    /// flattened, moving ones are mirrored instances).
    fn places_instance(&self, node: &gltf::Node, world: &Mat4, moving: bool) -> bool {
        let Some(mesh) = node.mesh() else {
            return false;
        };
        let det = Mat3::from_mat4(*world).determinant();
        self.instanced_meshes.contains(&mesh.index())
            && det.is_finite()
            && (det > 0.0 || (moving && det < 0.0))
    }

    /// The checks `read_accessor` makes before allocating, without reading: the elements fit
    /// in the buffer view, or a view-less accessor is not absurdly long.
    fn check_accessor_fits(&self, accessor: &gltf::Accessor) -> Result<()> {
        let object = named("accessor", accessor.index(), accessor.name());
        let element_size = accessor.dimensions().multiplicity() * accessor.data_type().size();
        match accessor.view() {
            Some(view) => {
                self.element_region(
                    &view,
                    accessor.offset(),
                    accessor.count(),
                    element_size,
                    &object,
                )?;
            }
            None if accessor.count() > MAX_VIEWLESS_ELEMENTS => {
                return Err(self.err(
                    &object,
                    format!(
                        "count {} without a buffer view is too large",
                        accessor.count()
                    ),
                ));
            }
            None => {}
        }
        Ok(())
    }

    fn count_node(
        &self,
        node: &gltf::Node,
        per_mesh: &HashMap<usize, (usize, usize)>,
        ancestors: &mut Vec<(usize, Mat4)>,
        totals: &mut SizeTotals,
    ) -> Result<()> {
        let parent = ancestors.last().map_or(Mat4::IDENTITY, |a| a.1);
        let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        let object = named("node", node.index(), node.name());
        if ancestors.iter().any(|a| a.0 == node.index()) {
            return Err(self.err(object, "is its own ancestor (cycle in the node hierarchy)"));
        }
        if ancestors.len() >= MAX_NODE_DEPTH {
            return Err(self.err(
                object,
                format!("node hierarchy deeper than {MAX_NODE_DEPTH}"),
            ));
        }
        totals.instances += 1;
        if totals.instances > MAX_NODE_INSTANCES {
            return Err(self.err(
                object,
                format!("the hierarchy instances more than {MAX_NODE_INSTANCES} nodes"),
            ));
        }
        if let Some(mesh) = node.mesh() {
            let (mut triangles, mut vertices) =
                per_mesh.get(&mesh.index()).copied().unwrap_or_default();
            // Moving mirrored nodes are counted as flattened: an upper bound.
            if world.is_finite() && self.places_instance(node, &world, false) {
                // Stored once, however many instances place it.
                if !totals.counted_prototypes.insert(mesh.index()) {
                    (triangles, vertices) = (0, 0);
                }
            }
            totals.triangles = totals.triangles.saturating_add(triangles);
            totals.vertices = totals.vertices.saturating_add(vertices);
            if totals.triangles > MAX_TRIANGLES {
                return Err(self.err(
                    object,
                    format!(
                        "the scene instances more than Photon's limit of {MAX_TRIANGLES} \
                         triangles (refused before loading any geometry)"
                    ),
                ));
            }
            if totals.vertices > MAX_VERTICES {
                return Err(self.err(
                    object,
                    format!(
                        "the scene instances more than Photon's limit of {MAX_VERTICES} \
                         vertices (refused before loading any geometry)"
                    ),
                ));
            }
        }
        ancestors.push((node.index(), world));
        for child in node.children() {
            self.count_node(&child, per_mesh, ancestors, totals)?;
        }
        ancestors.pop();
        Ok(())
    }

    fn visit_node(
        &mut self,
        node: &gltf::Node,
        parent: Placement,
        ancestors: &mut Vec<usize>,
        cameras: &mut Vec<FoundCamera>,
    ) -> Result<()> {
        let object = named("node", node.index(), node.name());
        if ancestors.contains(&node.index()) {
            return Err(self.err(object, "is its own ancestor (cycle in the node hierarchy)"));
        }
        if ancestors.len() >= MAX_NODE_DEPTH {
            return Err(self.err(
                object,
                format!("node hierarchy deeper than {MAX_NODE_DEPTH}"),
            ));
        }
        self.node_instances += 1;
        if self.node_instances > MAX_NODE_INSTANCES {
            return Err(self.err(
                object,
                format!("the hierarchy instances more than {MAX_NODE_INSTANCES} nodes"),
            ));
        }
        let local = Mat4::from_cols_array_2d(&node.transform().matrix());
        let world = parent.world * local;
        if !world.is_finite() {
            return Err(self.err(object, "transform is NaN or infinite"));
        }
        // Its own poses over the shutter (world matrices), or its moving parent's carrying it.
        let motion = match node
            .extension_value("PHOTON_object")
            .and_then(|v| v.get("motion"))
        {
            Some(poses) => {
                read_poses(poses).map_err(|m| self.err(format!("{object} PHOTON_object"), m))?
            }
            None => parent
                .motion
                .iter()
                .map(|pose| *pose * Affine3A::from_mat4(local))
                .collect(),
        };
        if let Some(mesh) = node.mesh() {
            if self.places_instance(node, &world, !motion.is_empty()) {
                self.add_instance(node, &mesh, &world, &motion)?;
            } else {
                if !motion.is_empty() || moves(node) {
                    self.scene.warnings.push(format!(
                        "{object}: motion blur is not rendered for it (a singular transform: \
                         only invertible ones are placed per moment)"
                    ));
                }
                self.add_mesh(node, &mesh, &world, false)?;
            }
        }
        let extension = node.extension_value("PHOTON_camera");
        if node.camera().is_none() && extension.is_some_and(|e| e.get("panorama").is_some()) {
            // Blender's exporter drops panoramic cameras and keeps their node.
            let (_, rotation, translation) = world.to_scale_rotation_translation();
            let name = node.name().unwrap_or("panoramic camera").to_string();
            let mut camera = Camera {
                name: name.clone(),
                to_world: Affine3A::from_rotation_translation(rotation.normalize(), translation),
                projection: Projection::Perspective { yfov: 0.6981 },
                aspect_ratio: None,
                shift: Vec2::ZERO,
                lens: None,
                motion: Vec::new(),
                near_clip: 0.0,
            };
            if let Some(extension) = extension {
                read_camera_extension(extension, &mut camera)
                    .map_err(|m| self.err(format!("{object} PHOTON_camera"), m))?;
            }
            cameras.push(FoundCamera {
                node_name: name.clone(),
                camera_name: name,
                camera,
            });
        }
        if let Some(camera) = node.camera() {
            let mut converted = convert_camera(node, &camera, &world)
                .map_err(|m| self.err(named("camera", camera.index(), camera.name()), m))?;
            if let Some(extension) = node.extension_value("PHOTON_camera") {
                read_camera_extension(extension, &mut converted)
                    .map_err(|m| self.err(format!("{object} PHOTON_camera"), m))?;
            }
            cameras.push(FoundCamera {
                node_name: node.name().unwrap_or_default().to_string(),
                camera_name: camera.name().unwrap_or_default().to_string(),
                camera: converted,
            });
        }
        self.add_lights(node, &world)?;
        ancestors.push(node.index());
        for child in node.children() {
            let placement = Placement {
                world,
                motion: motion.clone(),
            };
            self.visit_node(&child, placement, ancestors, cameras)?;
        }
        ancestors.pop();
        Ok(())
    }

    // ----- meshes -------------------------------------------------------------------------

    /// Place `mesh` by `world` as instances of its prototypes (built on first use).
    /// `motion` holds its poses over the shutter (empty: still).
    fn add_instance(
        &mut self,
        node: &gltf::Node,
        mesh: &gltf::Mesh,
        world: &Mat4,
        motion: &[Affine3A],
    ) -> Result<()> {
        if !self.prototype_ids.contains_key(&mesh.index()) {
            let first = self.scene.prototypes.len() as u32;
            self.add_mesh(node, mesh, &Mat4::IDENTITY, true)?;
            let ids = (first..self.scene.prototypes.len() as u32).collect();
            self.prototype_ids.insert(mesh.index(), ids);
        }
        let to_world = Affine3A::from_mat4(*world);
        let (camera_visible, casts_shadows, holdout) = self.visibility(node)?;
        for &prototype in &self.prototype_ids[&mesh.index()] {
            let mut instance = super::Instance::new(prototype, to_world);
            instance.motion = motion.to_vec();
            instance.camera_visible = camera_visible;
            instance.casts_shadows = casts_shadows;
            instance.holdout = holdout;
            self.scene.instances.push(instance);
        }
        Ok(())
    }

    /// `PHOTON_object`'s camera and shadow ray visibility of `node` (default: both true) and
    /// whether it is a holdout (default: false).
    fn visibility(&self, node: &gltf::Node) -> Result<(bool, bool, bool)> {
        let Some(v) = node.extension_value("PHOTON_object") else {
            return Ok((true, true, false));
        };
        let flag = |key: &str, default: bool| match v.get(key) {
            None => Ok(default),
            Some(Value::Bool(b)) => Ok(*b),
            Some(other) => Err(self.err(
                format!("{} PHOTON_object", named("node", node.index(), node.name())),
                format!("'{key}' must be true or false, found {other}"),
            )),
        };
        Ok((
            flag("visible_camera", true)?,
            flag("visible_shadow", true)?,
            flag("holdout", false)?,
        ))
    }

    /// Read `mesh`'s primitives placed by `world` into `Scene::meshes`, or with the identity
    /// into `Scene::prototypes` when `prototype`.
    fn add_mesh(
        &mut self,
        node: &gltf::Node,
        mesh: &gltf::Mesh,
        world: &Mat4,
        prototype: bool,
    ) -> Result<()> {
        let mesh_name = mesh.name().map_or_else(
            || format!("mesh {}", mesh.index()),
            |n| format!("mesh '{n}'"),
        );
        let linear = Mat3::from_mat4(*world);
        let normal_matrix = linear.inverse().transpose();
        let mirrored = linear.determinant() < 0.0;
        let visibility = self.visibility(node)?;
        let deform = match node
            .extension_value("PHOTON_object")
            .and_then(|v| v.get("deform"))
        {
            Some(value) if prototype => Some(read_deform(value).map_err(|m| {
                self.err(
                    format!("{} PHOTON_object", named("node", node.index(), node.name())),
                    m,
                )
            })?),
            _ => None,
        };
        for primitive in mesh.primitives() {
            let object = format!("{mesh_name} primitive {}", primitive.index());
            let mode = primitive.mode();
            if !matches!(
                mode,
                Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
            ) {
                self.scene.warnings.push(format!(
                    "{object}: {mode:?} primitives are not rendered, skipped"
                ));
                continue;
            }
            let Some(position_accessor) = primitive.get(&gltf::Semantic::Positions) else {
                self.scene
                    .warnings
                    .push(format!("{object}: no POSITION attribute, skipped"));
                continue;
            };
            // Reading is bounded by the buffer sizes; the total is bounded here.
            let positions = self.read_vec3(&position_accessor, &object, "POSITION")?;
            self.vertex_total = self.vertex_total.saturating_add(positions.len());
            if self.vertex_total > MAX_VERTICES {
                return Err(self.err(
                    &object,
                    format!("the scene exceeds Photon's limit of {MAX_VERTICES} vertices"),
                ));
            }
            if let Some(bad) = positions.iter().position(|p| !p.is_finite()) {
                return Err(self.err(
                    &object,
                    format!("vertex {bad} has a NaN or infinite position"),
                ));
            }
            let vertex_count = positions.len();
            let mut indices = self.primitive_triangles(&primitive, vertex_count, &object)?;
            for (t, tri) in indices.iter().enumerate() {
                if let Some(&i) = tri.iter().find(|&&i| i as usize >= vertex_count) {
                    return Err(self.err(
                        &object,
                        format!(
                            "triangle {t} uses vertex {i}, past the vertex count {vertex_count}"
                        ),
                    ));
                }
            }

            let normals = match primitive.get(&gltf::Semantic::Normals) {
                Some(a) => Some(self.read_vec3(&a, &object, "NORMAL")?),
                None => None,
            };
            let uvs = match primitive.get(&gltf::Semantic::TexCoords(0)) {
                Some(a) => {
                    let flat = self.read_float_attribute(&a, &object, "TEXCOORD_0", 2)?;
                    flat.chunks_exact(2)
                        .map(|c| Vec2::new(c[0], c[1]))
                        .collect()
                }
                None => Vec::new(),
            };
            let mut extra_uvs = Vec::new();
            for set in 1..crate::shader::UV_SETS as u32 {
                let Some(a) = primitive.get(&gltf::Semantic::TexCoords(set)) else {
                    break;
                };
                let label = format!("TEXCOORD_{set}");
                let flat = self.read_float_attribute(&a, &object, &label, 2)?;
                let uvs: Vec<Vec2> = flat
                    .chunks_exact(2)
                    .map(|c| Vec2::new(c[0], c[1]))
                    .collect();
                check_length(&uvs, vertex_count)
                    .map_err(|m| self.err(&object, format!("{label} {m}")))?;
                extra_uvs.push(uvs);
            }
            let tangents = match primitive.get(&gltf::Semantic::Tangents) {
                Some(a) => {
                    let flat = self.read_float_attribute(&a, &object, "TANGENT", 4)?;
                    flat.chunks_exact(4)
                        .map(|c| Vec4::new(c[0], c[1], c[2], c[3]))
                        .collect()
                }
                None => Vec::new(),
            };
            let colors = match primitive.get(&gltf::Semantic::Colors(0)) {
                Some(a) => {
                    let n = a.dimensions().multiplicity();
                    let flat = self.read_float_attribute(&a, &object, "COLOR_0", n.clamp(3, 4))?;
                    if n == 4 {
                        flat.chunks_exact(4)
                            .map(|c| Vec4::new(c[0], c[1], c[2], c[3]))
                            .collect()
                    } else {
                        flat.chunks_exact(3)
                            .map(|c| Vec4::new(c[0], c[1], c[2], 1.0))
                            .collect()
                    }
                }
                None => Vec::new(),
            };
            check_length(&colors, vertex_count)
                .map_err(|m| self.err(&object, format!("COLOR_0 {m}")))?;
            if colors.iter().any(|c: &Vec4| !c.is_finite()) {
                return Err(self.err(&object, "a COLOR_0 value is NaN or infinite"));
            }
            let object_space = Some(self.object_space(node, &positions, world)?);
            check_length(&uvs, vertex_count)
                .map_err(|m| self.err(&object, format!("TEXCOORD_0 {m}")))?;
            check_length(&tangents, vertex_count)
                .map_err(|m| self.err(&object, format!("TANGENT {m}")))?;

            let world_positions: Vec<Vec3> = positions
                .iter()
                .map(|&p| world.transform_point3(p))
                .collect();
            if mirrored {
                for tri in &mut indices {
                    tri.swap(1, 2);
                }
            }
            let world_tangents: Vec<Vec4> = tangents
                .iter()
                .map(|t| {
                    let xyz = (linear * t.truncate()).normalize_or_zero();
                    // A mirror flips the handedness of the tangent frame.
                    let w = if mirrored { -t.w } else { t.w };
                    xyz.extend(w)
                })
                .collect();

            let material = self.material_index(primitive.material().index());
            let (camera_visible, casts_shadows, holdout) = visibility;
            let mut out = Mesh {
                name: format!(
                    "{}/{} primitive {}",
                    node.name().unwrap_or("node"),
                    mesh.name().unwrap_or("mesh"),
                    primitive.index()
                ),
                positions: world_positions,
                normals: Vec::new(),
                uvs,
                extra_uvs,
                tangents: world_tangents,
                indices,
                material,
                camera_visible,
                holdout,
                emission_spread: None,
                casts_shadows,
                colors,
                object_space,
                deformation: Vec::new(),
            };
            match normals {
                Some(normals) => {
                    check_length(&normals, vertex_count)
                        .map_err(|m| self.err(&object, format!("NORMAL {m}")))?;
                    out.normals = normals
                        .iter()
                        .map(|&n| (normal_matrix * n).normalize_or_zero())
                        .collect();
                    if out.normals.iter().any(|n| !n.is_finite()) {
                        return Err(self.err(&object, "a vertex normal is NaN or infinite"));
                    }
                }
                None => make_flat(&mut out),
            }
            if prototype {
                if let Some((frame, steps)) = &deform {
                    match deformation_of(&positions, frame, steps) {
                        Some(deformation) => out.deformation = deformation,
                        None => self.scene.warnings.push(format!(
                            "{object}: its deformation is not blurred (its vertices are not \
                             those of PHOTON_object's \"deform\" frame)"
                        )),
                    }
                }
                self.scene.prototypes.push(out);
            } else {
                self.scene.meshes.push(out);
            }
        }
        Ok(())
    }

    /// The Blender object of `node` for node trees: stored positions (placed by `world`) →
    /// Blender object coordinates (glTF (x, y, z) is Blender (x, −z, y)), and the texture space
    /// from `PHOTON_object`'s `texture_space` or else the bounds of `local` (object-space glTF
    /// positions), as Blender's automatic texture space.
    fn object_space(
        &self,
        node: &gltf::Node,
        local: &[Vec3],
        world: &Mat4,
    ) -> Result<super::ObjectSpace> {
        let axes = Affine3A::from_cols_array(&[
            1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, -1.0, 0.0, 0.0, 0.0, 0.0,
        ]);
        let inverse = world.inverse();
        let to_object = if inverse.is_finite() {
            axes * Affine3A::from_mat4(inverse)
        } else {
            axes
        };
        let mut bounds = Bounds::EMPTY;
        for &p in local {
            bounds.grow(axes.transform_point3(p));
        }
        let (mut location, mut size) = if bounds.is_empty() {
            (Vec3::ZERO, Vec3::ONE)
        } else {
            (bounds.center(), 0.5 * (bounds.max - bounds.min))
        };
        let given = node
            .extension_value("PHOTON_object")
            .and_then(|v| v.get("texture_space"));
        if let Some(space) = given {
            let object = format!(
                "{} PHOTON_object texture_space",
                named("node", node.index(), node.name())
            );
            let read = |key: &str| {
                space
                    .get(key)
                    .and_then(json_vec3)
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| self.err(&object, format!("'{key}' must be three numbers")))
            };
            location = read("location")?;
            size = read("size")?;
        }
        Ok(super::ObjectSpace {
            to_object,
            texspace_location: location,
            texspace_size: size,
        })
    }

    /// The primitive's triangles as index triples (strips and fans converted), or `None` when
    /// the primitive is not made of triangles. Refuses primitives that would take the scene over
    /// `MAX_TRIANGLES` before allocating them.
    fn primitive_triangles(
        &mut self,
        primitive: &gltf::Primitive,
        vertex_count: usize,
        object: &str,
    ) -> Result<Vec<[u32; 3]>> {
        let mode = primitive.mode();
        let index_count = primitive.indices().map_or(vertex_count, |a| a.count());
        let new_triangles = match mode {
            Mode::Triangles => index_count / 3,
            _ => index_count.saturating_sub(2),
        };
        self.triangle_total = self.triangle_total.saturating_add(new_triangles);
        if self.triangle_total > MAX_TRIANGLES {
            return Err(self.err(
                object,
                format!("the scene exceeds Photon's limit of {MAX_TRIANGLES} triangles"),
            ));
        }
        let list: Vec<u32> = match primitive.indices() {
            Some(accessor) => self.read_indices(&accessor, object)?,
            None => {
                let count = u32::try_from(vertex_count)
                    .map_err(|_| self.err(object, "too many vertices for 32-bit indices"))?;
                (0..count).collect()
            }
        };
        let triangles = match mode {
            Mode::Triangles => list.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
            Mode::TriangleStrip => list
                .windows(3)
                .enumerate()
                .map(|(i, w)| {
                    if i % 2 == 0 {
                        [w[0], w[1], w[2]]
                    } else {
                        [w[1], w[0], w[2]]
                    }
                })
                .collect(),
            _ => match list.split_first() {
                Some((&centre, rest)) => rest.windows(2).map(|w| [centre, w[0], w[1]]).collect(),
                None => Vec::new(),
            },
        };
        Ok(triangles)
    }

    // ----- accessors ------------------------------------------------------------------------

    fn read_vec3(&self, accessor: &gltf::Accessor, object: &str, what: &str) -> Result<Vec<Vec3>> {
        let flat = self.read_float_attribute(accessor, object, what, 3)?;
        Ok(flat
            .chunks_exact(3)
            .map(|c| Vec3::new(c[0], c[1], c[2]))
            .collect())
    }

    /// An attribute as floats, `components` per element (checked against the accessor type).
    fn read_float_attribute(
        &self,
        accessor: &gltf::Accessor,
        object: &str,
        what: &str,
        components: usize,
    ) -> Result<Vec<f32>> {
        let found = accessor.dimensions().multiplicity();
        if found != components {
            return Err(self.err(
                format!("{object} {what} (accessor {})", accessor.index()),
                format!("has {found} components per element, expected {components}"),
            ));
        }
        check_attribute_type(
            what,
            accessor.data_type(),
            accessor.normalized(),
            self.quantized,
        )
        .map_err(|m| {
            self.err(
                format!("{object} {what} (accessor {})", accessor.index()),
                m,
            )
        })?;
        self.read_accessor(accessor, component_as_f32)
    }

    fn read_indices(&self, accessor: &gltf::Accessor, object: &str) -> Result<Vec<u32>> {
        let integer = matches!(
            accessor.data_type(),
            DataType::U8 | DataType::U16 | DataType::U32
        );
        if accessor.dimensions().multiplicity() != 1 || !integer {
            return Err(self.err(
                format!("{object} indices (accessor {})", accessor.index()),
                "indices must be scalar unsigned integers",
            ));
        }
        self.read_accessor(accessor, component_as_u32)
    }

    /// Every component of every element, decoded by `decode`, with all byte ranges checked
    /// before anything is allocated. Handles strides and sparse substitution.
    fn read_accessor<T: Copy + Default>(
        &self,
        accessor: &gltf::Accessor,
        decode: fn(&[u8], DataType, bool) -> T,
    ) -> Result<Vec<T>> {
        let object = named("accessor", accessor.index(), accessor.name());
        let count = accessor.count();
        let components = accessor.dimensions().multiplicity();
        let data_type = accessor.data_type();
        let component_size = data_type.size();
        let element_size = components * component_size;
        let normalized = accessor.normalized();
        let total = count
            .checked_mul(components)
            .ok_or_else(|| self.err(&object, format!("count {count} is absurd")))?;

        let mut values = match accessor.view() {
            Some(view) => {
                let region =
                    self.element_region(&view, accessor.offset(), count, element_size, &object)?;
                let mut values = Vec::with_capacity(total);
                if let Some((bytes, stride)) = region {
                    for element in bytes.chunks(stride).take(count) {
                        for c in 0..components {
                            let start = c * component_size;
                            values.push(decode(
                                &element[start..start + component_size],
                                data_type,
                                normalized,
                            ));
                        }
                    }
                }
                values
            }
            None => {
                if count > MAX_VIEWLESS_ELEMENTS {
                    return Err(self.err(
                        &object,
                        format!("count {count} without a buffer view is too large"),
                    ));
                }
                vec![T::default(); total]
            }
        };

        if let Some(sparse) = accessor.sparse() {
            let sparse_count = sparse.count();
            let indices = sparse.indices();
            let index_type = match indices.index_type() {
                gltf::accessor::sparse::IndexType::U8 => DataType::U8,
                gltf::accessor::sparse::IndexType::U16 => DataType::U16,
                gltf::accessor::sparse::IndexType::U32 => DataType::U32,
            };
            let index_region = self.element_region(
                &indices.view(),
                indices.offset(),
                sparse_count,
                index_type.size(),
                &format!("{object} sparse indices"),
            )?;
            let values_view = sparse.values().view();
            let value_region = self.element_region(
                &values_view,
                sparse.values().offset(),
                sparse_count,
                element_size,
                &format!("{object} sparse values"),
            )?;
            if let (Some((index_bytes, index_stride)), Some((value_bytes, value_stride))) =
                (index_region, value_region)
            {
                let targets = index_bytes.chunks(index_stride).take(sparse_count);
                let sources = value_bytes.chunks(value_stride).take(sparse_count);
                for (index_chunk, element) in targets.zip(sources) {
                    let target =
                        component_as_u32(&index_chunk[..index_type.size()], index_type, false)
                            as usize;
                    if target >= count {
                        return Err(self.err(
                            &object,
                            format!("sparse index {target} is past the count {count}"),
                        ));
                    }
                    for c in 0..components {
                        let start = c * component_size;
                        values[target * components + c] = decode(
                            &element[start..start + component_size],
                            data_type,
                            normalized,
                        );
                    }
                }
            }
        }
        Ok(values)
    }

    /// The bytes `count` elements of `element_size` occupy in `view` from `offset`, with the
    /// stride; `None` when `count` is zero. Errors when any of it lies outside the view or buffer.
    fn element_region(
        &self,
        view: &gltf::buffer::View,
        offset: usize,
        count: usize,
        element_size: usize,
        object: &str,
    ) -> Result<Option<(&[u8], usize)>> {
        let view_object = format!("buffer view {}", view.index());
        let buffer = self.buffers.get(view.buffer().index()).ok_or_else(|| {
            self.err(
                &view_object,
                format!("buffer {} is not loaded", view.buffer().index()),
            )
        })?;
        let view_end = view.offset().checked_add(view.length());
        let view_bytes = view_end
            .and_then(|end| buffer.get(view.offset()..end))
            .ok_or_else(|| {
                self.err(
                    &view_object,
                    format!(
                        "bytes {}..{} lie outside buffer {} ({} bytes)",
                        view.offset(),
                        view.offset().saturating_add(view.length()),
                        view.buffer().index(),
                        buffer.len()
                    ),
                )
            })?;
        if count == 0 {
            return Ok(None);
        }
        let stride = view.stride().unwrap_or(element_size);
        if stride < element_size {
            return Err(self.err(
                object,
                format!("byte stride {stride} is smaller than the element size {element_size}"),
            ));
        }
        let needed = stride
            .checked_mul(count - 1)
            .and_then(|n| n.checked_add(element_size))
            .and_then(|n| n.checked_add(offset));
        match needed.and_then(|end| view_bytes.get(offset..end)) {
            Some(bytes) => Ok(Some((bytes, stride))),
            None => Err(self.err(
                object,
                format!(
                    "{count} elements of {element_size} bytes (stride {stride}) from offset \
                     {offset} do not fit in buffer view {} of {} bytes",
                    view.index(),
                    view_bytes.len()
                ),
            )),
        }
    }

    // ----- materials and textures -------------------------------------------------------------

    fn load_materials(&mut self) -> Result<()> {
        let document = self.document.clone();
        for material in document.materials() {
            let converted = self.convert_material(&material)?;
            self.scene.materials.push(converted);
        }
        Ok(())
    }

    /// Scene material index for a glTF material index (`None`: the glTF default material).
    fn material_index(&mut self, gltf_index: Option<usize>) -> u32 {
        match gltf_index {
            Some(i) => i as u32,
            None => *self.default_material.get_or_insert_with(|| {
                self.scene.materials.push(Material::default());
                (self.scene.materials.len() - 1) as u32
            }),
        }
    }

    fn convert_material(&mut self, material: &gltf::Material) -> Result<Material> {
        let index = material.index().unwrap_or(0);
        let name = material
            .name()
            .map_or_else(|| format!("material {index}"), str::to_string);
        let object = format!("material '{name}'");
        let pbr = material.pbr_metallic_roughness();
        let mut out = Material {
            name: name.clone(),
            base_color: Vec4::from(pbr.base_color_factor()),
            metallic: pbr.metallic_factor(),
            roughness: pbr.roughness_factor(),
            emission: Vec3::from(material.emissive_factor())
                * material.emissive_strength().unwrap_or(1.0),
            double_sided: material.double_sided(),
            alpha_mode: match material.alpha_mode() {
                gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
                gltf::material::AlphaMode::Mask => AlphaMode::Mask {
                    cutoff: material.alpha_cutoff().unwrap_or(0.5),
                },
                gltf::material::AlphaMode::Blend => AlphaMode::Blend,
            },
            ior: material.ior().unwrap_or(1.5),
            ..Material::default()
        };
        out.base_color_texture = self.texture_info(pbr.base_color_texture(), true, &object)?;
        out.metallic_roughness_texture =
            self.texture_info(pbr.metallic_roughness_texture(), false, &object)?;
        out.emissive_texture = self.texture_info(material.emissive_texture(), true, &object)?;
        if let Some(normal) = material.normal_texture() {
            let transform = normal.extension_value("KHR_texture_transform");
            out.normal_texture = Some(self.texture_ref(
                &normal.texture(),
                false,
                transform.map(raw_texture_transform),
                &object,
            )?);
            out.normal_scale = normal.scale();
            self.warn_tex_coord(normal.tex_coord(), &object);
        }
        if let Some(transmission) = material.transmission() {
            out.transmission = transmission.transmission_factor();
            out.transmission_texture =
                self.texture_info(transmission.transmission_texture(), false, &object)?;
        }
        if let Some(specular) = material.specular() {
            out.specular = specular.specular_factor();
            out.specular_color = Vec3::from(specular.specular_color_factor());
            if specular.specular_texture().is_some() || specular.specular_color_texture().is_some()
            {
                self.scene
                    .warnings
                    .push(format!("{object}: specular textures are ignored"));
            }
        }
        if let Some(ext) = material.extension_value("KHR_materials_clearcoat") {
            let label = format!("{object} KHR_materials_clearcoat");
            out.coat = self.ext_number(ext, "clearcoatFactor", 0.0, 0.0, 1.0, &label)?;
            out.coat_texture = self.raw_texture_info(ext.get("clearcoatTexture"), false, &label)?;
            out.coat_roughness_texture =
                self.raw_texture_info(ext.get("clearcoatRoughnessTexture"), false, &label)?;
            // Blender's importer: its default coat roughness when neither is given.
            let default = if out.coat_roughness_texture.is_some() {
                0.0
            } else {
                0.03
            };
            out.coat_roughness =
                self.ext_number(ext, "clearcoatRoughnessFactor", default, 0.0, 1.0, &label)?;
            if let Some(normal) = ext.get("clearcoatNormalTexture") {
                out.coat_normal_texture = self.raw_texture_info(Some(normal), false, &label)?;
                out.coat_normal_scale =
                    self.ext_number(normal, "scale", 1.0, f32::MIN, f32::MAX, &label)?;
            }
        }
        if let Some(ext) = material.extension_value("KHR_materials_sheen") {
            let label = format!("{object} KHR_materials_sheen");
            out.sheen = true;
            out.sheen_color = match ext.get("sheenColorFactor") {
                None => Vec3::ZERO,
                Some(v) => json_vec3(v)
                    .filter(|c| c.is_finite() && c.min_element() >= 0.0)
                    .ok_or_else(|| {
                        self.err(
                            &label,
                            format!("'sheenColorFactor' must be three numbers ≥ 0, found {v}"),
                        )
                    })?,
            };
            out.sheen_color_texture =
                self.raw_texture_info(ext.get("sheenColorTexture"), true, &label)?;
            out.sheen_roughness =
                self.ext_number(ext, "sheenRoughnessFactor", 0.0, 0.0, 1.0, &label)?;
            out.sheen_roughness_texture =
                self.raw_texture_info(ext.get("sheenRoughnessTexture"), false, &label)?;
        }
        if let Some(ext) = material.extension_value("KHR_materials_anisotropy") {
            let label = format!("{object} KHR_materials_anisotropy");
            out.anisotropy = self.ext_number(ext, "anisotropyStrength", 0.0, 0.0, 1.0, &label)?;
            out.anisotropy_rotation =
                self.ext_number(ext, "anisotropyRotation", 0.0, f32::MIN, f32::MAX, &label)?;
            out.anisotropy_texture =
                self.raw_texture_info(ext.get("anisotropyTexture"), false, &label)?;
        }
        if let Some(ext) = material.extension_value("KHR_materials_iridescence") {
            let label = format!("{object} KHR_materials_iridescence");
            out.iridescence = self.ext_number(ext, "iridescenceFactor", 0.0, 0.0, 1.0, &label)?;
            out.iridescence_texture =
                self.raw_texture_info(ext.get("iridescenceTexture"), false, &label)?;
            out.iridescence_ior =
                self.ext_number(ext, "iridescenceIor", 1.3, 1e-5, f32::MAX, &label)?;
            out.iridescence_thickness = [
                self.ext_number(
                    ext,
                    "iridescenceThicknessMinimum",
                    100.0,
                    0.0,
                    f32::MAX,
                    &label,
                )?,
                self.ext_number(
                    ext,
                    "iridescenceThicknessMaximum",
                    400.0,
                    0.0,
                    f32::MAX,
                    &label,
                )?,
            ];
            out.iridescence_thickness_texture =
                self.raw_texture_info(ext.get("iridescenceThicknessTexture"), false, &label)?;
        }
        if let Some(volume) = material.volume() {
            out.thickness = volume.thickness_factor();
            out.attenuation_distance = volume.attenuation_distance();
            out.attenuation_color = Vec3::from(volume.attenuation_color());
        }
        if let Some(sss) = material.extension_value("PHOTON_material_subsurface") {
            out.subsurface = self.read_subsurface(sss, &object)?;
        }
        let nodes_extension = material.extension_value("PHOTON_material_nodes");
        if let Some(list) = nodes_extension
            .filter(|t| t.get("nodes").is_none())
            .and_then(|t| t.get("warnings"))
            .and_then(Value::as_array)
        {
            // The add-on could not describe the tree: what it names is lost (glTF's values
            // are rendered).
            for w in list.iter().filter_map(Value::as_str) {
                self.scene.export_notes.push(w.to_string());
            }
        }
        if let Some(tree) = nodes_extension.filter(|t| t.get("nodes").is_some()) {
            let mut warnings = Vec::new();
            let tree = self.load_node_images(tree, &object)?;
            let program = crate::shader::compile(&tree, self.scene.textures.len(), &mut warnings)
                .map_err(|m| self.err(format!("{object} PHOTON_material_nodes"), m))?;
            if let Some(list) = tree.get("warnings").and_then(Value::as_array) {
                warnings.extend(list.iter().filter_map(Value::as_str).map(str::to_string));
            }
            for w in warnings {
                self.scene.warnings.push(format!("{object}: {w}"));
            }
            // Light sampling weighs emitters by this radiance: the tree's value at a default
            // point, or 1 when the tree may emit there and is black at that point.
            if program.emits {
                let at = crate::shader::ShadingInputs::default();
                let e = program.eval(&at, &self.scene.textures, 0.5).emission;
                out.emission = if e.max_element() > 0.0 && e.is_finite() {
                    e
                } else {
                    Vec3::ONE
                };
            } else {
                out.emission = Vec3::ZERO;
            }
            // The tree's own Normal Map nodes replace the glTF normal texture Blender's
            // exporter writes for them, and its UV maps the glTF textures'.
            out.normal_texture = None;
            self.uv_set_warnings.clear();
            out.nodes = Some(std::sync::Arc::new(program));
        }
        let uv_set_warnings = std::mem::take(&mut self.uv_set_warnings);
        self.scene.warnings.extend(uv_set_warnings);
        Ok(out)
    }

    /// The tree of `PHOTON_material_nodes` with each Image Texture node's `image` (`{"uri":
    /// file, "colorspace": "sRGB" | "Non-Color"}`, beside the glTF file) loaded as a texture
    /// of the scene and named by its index in `texture`, with the node's `extension` (REPEAT,
    /// EXTEND, CLIP, MIRROR) and `interpolation` (Closest or else bilinear) as its sampler.
    fn load_node_images(&mut self, tree: &Value, object: &str) -> Result<Value> {
        let mut tree = tree.clone();
        let Some(nodes) = tree.get_mut("nodes").and_then(Value::as_array_mut) else {
            return Ok(tree);
        };
        for node in nodes.iter_mut() {
            let Some(image) = node.get("image").cloned() else {
                continue;
            };
            let label = format!("{object} PHOTON_material_nodes image");
            let uri = image
                .get("uri")
                .and_then(Value::as_str)
                .ok_or_else(|| self.err(&label, "'uri' must be a string"))?;
            let srgb = image.get("colorspace").and_then(Value::as_str) != Some("Non-Color");
            let file = self.resolve_file(uri, &label)?;
            let decoded = if file.exists() {
                let bytes = std::fs::read(&file).map_err(|e| Error::io(&file, e))?;
                if bytes.starts_with(&EXR_MAGIC) {
                    // Float images (OpenEXR): linear values, as Cycles reads them.
                    let (width, height, texels) = crate::image_io::read_exr_rgba(&file)?;
                    DecodedImage {
                        name: uri.to_string(),
                        width,
                        height,
                        texels: Texels::Linear(texels),
                    }
                } else {
                    self.decode_bytes(&bytes, format!("image '{uri}'"), None)?
                }
            } else {
                self.scene.warnings.push(format!(
                    "{object}: image file '{}' not found; it renders magenta (1, 0, 1), as in \
                     Blender",
                    file.display()
                ));
                DecodedImage {
                    name: uri.to_string(),
                    width: 1,
                    height: 1,
                    texels: Texels::Bytes(vec![[255, 0, 255, 255]]),
                }
            };
            let wrap = match node.get("extension").and_then(Value::as_str) {
                Some("EXTEND" | "CLIP") => Wrap::ClampToEdge,
                Some("MIRROR") => Wrap::MirroredRepeat,
                _ => Wrap::Repeat,
            };
            let bilinear = node.get("interpolation").and_then(Value::as_str) != Some("Closest");
            node["texture"] = Value::from(self.push_texture(decoded, srgb, [wrap; 2], bilinear));
        }
        Ok(tree)
    }

    /// Add a texture of `decoded` sampled with `wrap` (s, t) and `bilinear`; its index.
    fn push_texture(
        &mut self,
        decoded: DecodedImage,
        srgb: bool,
        wrap: [Wrap; 2],
        bilinear: bool,
    ) -> u32 {
        let texels = match decoded.texels {
            Texels::Linear(values) if srgb => Texels::Linear(
                values
                    .into_iter()
                    .map(|[r, g, b, a]| {
                        [srgb_to_linear(r), srgb_to_linear(g), srgb_to_linear(b), a]
                    })
                    .collect(),
            ),
            texels => texels,
        };
        self.scene.textures.push(Texture {
            name: decoded.name,
            width: decoded.width,
            height: decoded.height,
            texels,
            srgb,
            wrap_s: wrap[0],
            wrap_t: wrap[1],
            bilinear,
        });
        (self.scene.textures.len() - 1) as u32
    }

    /// `PHOTON_material_subsurface`: every field optional (Blender's defaults), every value
    /// finite; weight in [0, 1], radius and scale ≥ 0, IOR > 0, anisotropy in (−1, 1).
    fn read_subsurface(&self, value: &Value, object: &str) -> Result<Subsurface> {
        let object = format!("{object} PHOTON_material_subsurface");
        let mut out = Subsurface::default();
        let number = |key: &str, ok: fn(f32) -> bool, default: f32| -> Result<f32> {
            match value.get(key) {
                None => Ok(default),
                Some(v) => match v.as_f64().map(|x| x as f32) {
                    Some(x) if x.is_finite() && ok(x) => Ok(x),
                    _ => Err(self.err(&object, format!("'{key}' is out of range: {v}"))),
                },
            }
        };
        out.weight = number("weight", |x| (0.0..=1.0).contains(&x), out.weight)?;
        out.scale = number("scale", |x| x >= 0.0, out.scale)?;
        out.ior = number("ior", |x| x > 0.0, out.ior)?;
        out.anisotropy = number("anisotropy", |x| x.abs() < 1.0, out.anisotropy)?;
        if let Some(v) = value.get("method") {
            out.method = v
                .as_str()
                .and_then(SubsurfaceMethod::from_blender)
                .ok_or_else(|| {
                    self.err(
                        &object,
                        format!(
                            "'method' must be \"BURLEY\", \"RANDOM_WALK\" or \"RANDOM_WALK_SKIN\", found {v}"
                        ),
                    )
                })?;
        }
        if let Some(v) = value.get("radius") {
            out.radius = json_vec3(v)
                .filter(|r| r.is_finite() && r.min_element() >= 0.0)
                .ok_or_else(|| {
                    self.err(
                        &object,
                        format!("'radius' must be three numbers ≥ 0, found {v}"),
                    )
                })?;
        }
        Ok(out)
    }

    /// The number `key` of an extension object (`default` when absent), clamped to
    /// [lo, hi]; anything but a finite number is refused.
    fn ext_number(
        &self,
        ext: &Value,
        key: &str,
        default: f32,
        lo: f32,
        hi: f32,
        object: &str,
    ) -> Result<f32> {
        match ext.get(key) {
            None => Ok(default),
            Some(v) => match v.as_f64().map(|x| x as f32) {
                Some(x) if x.is_finite() => Ok(x.clamp(lo, hi)),
                _ => Err(self.err(object, format!("'{key}' must be a number, found {v}"))),
            },
        }
    }

    /// A textureInfo object of an extension the gltf crate does not parse: `{"index": i,
    /// "texCoord": n, "extensions": {"KHR_texture_transform": {...}}}`.
    fn raw_texture_info(
        &mut self,
        info: Option<&Value>,
        srgb: bool,
        object: &str,
    ) -> Result<Option<TextureRef>> {
        let Some(info) = info else {
            return Ok(None);
        };
        let document = self.document.clone();
        let texture = info
            .get("index")
            .and_then(Value::as_u64)
            .and_then(|i| document.textures().nth(i as usize))
            .ok_or_else(|| {
                self.err(
                    object,
                    format!("texture 'index' must name one of the file's textures, found {info}"),
                )
            })?;
        let tex_coord = info.get("texCoord").and_then(Value::as_u64).unwrap_or(0);
        self.warn_tex_coord(tex_coord as u32, object);
        let transform = info
            .get("extensions")
            .and_then(|e| e.get("KHR_texture_transform"))
            .map(raw_texture_transform);
        self.texture_ref(&texture, srgb, transform, object)
            .map(Some)
    }

    fn warn_tex_coord(&mut self, tex_coord: u32, object: &str) {
        if tex_coord != 0 {
            self.uv_set_warnings.push(format!(
                "{object}: texture uses TEXCOORD_{tex_coord}; Photon reads UV set 0 only"
            ));
        }
    }

    fn texture_info(
        &mut self,
        info: Option<gltf::texture::Info>,
        srgb: bool,
        object: &str,
    ) -> Result<Option<TextureRef>> {
        let Some(info) = info else {
            return Ok(None);
        };
        self.warn_tex_coord(info.tex_coord(), object);
        let transform = info
            .texture_transform()
            .map(|t| (Vec2::from(t.offset()), t.rotation(), Vec2::from(t.scale())));
        self.texture_ref(&info.texture(), srgb, transform, object)
            .map(Some)
    }

    fn texture_ref(
        &mut self,
        texture: &gltf::Texture,
        srgb: bool,
        transform: Option<(Vec2, f32, Vec2)>,
        object: &str,
    ) -> Result<TextureRef> {
        let slot = self.texture_slot(texture, srgb, object)?;
        Ok(match transform {
            Some((offset, rotation, scale)) => {
                TextureRef::with_transform(slot, offset, rotation, scale)
            }
            None => TextureRef::new(slot),
        })
    }

    /// The scene texture for this glTF texture in this colour space, created on first use.
    fn texture_slot(&mut self, texture: &gltf::Texture, srgb: bool, object: &str) -> Result<u32> {
        if let Some(&slot) = self.texture_slots.get(&(texture.index(), srgb)) {
            return Ok(slot);
        }
        let image = texture.source();
        let decoded = match self.images.get(&image.index()) {
            Some(d) => d.clone(),
            None => {
                let d = self.decode_image(&image).map_err(|e| match e {
                    Error::Scene {
                        path,
                        object: image_object,
                        message,
                    } => Error::Scene {
                        path,
                        object: format!("{image_object} (used by {object})"),
                        message,
                    },
                    other => other,
                })?;
                self.images.insert(image.index(), d.clone());
                d
            }
        };
        let sampler = texture.sampler();
        let slot = self.push_texture(
            decoded,
            srgb,
            [
                convert_wrap(sampler.wrap_s()),
                convert_wrap(sampler.wrap_t()),
            ],
            sampler.mag_filter() != Some(gltf::texture::MagFilter::Nearest),
        );
        self.texture_slots.insert((texture.index(), srgb), slot);
        Ok(slot)
    }

    /// Decode a PNG, JPEG or WebP image to RGBA8. An external image file that does not exist becomes
    /// one magenta texel, with a warning naming the image: Blender and Cycles show missing
    /// textures magenta so that they are noticed.
    fn decode_image(&mut self, image: &gltf::Image) -> Result<DecodedImage> {
        let json = self
            .document
            .as_json()
            .images
            .get(image.index())
            .ok_or_else(|| self.err(format!("image {}", image.index()), "does not exist"))?;
        let label = image
            .name()
            .or(json.uri.as_deref().filter(|u| !u.starts_with("data:")))
            .map_or_else(
                || format!("image {}", image.index()),
                |n| format!("image '{n}'"),
            );
        let declared_mime = json.mime_type.as_ref().map(|m| m.0.clone());
        let encoded: Vec<u8> = match (&json.buffer_view, &json.uri) {
            (Some(view_index), _) => {
                let view = self
                    .document
                    .views()
                    .nth(view_index.value())
                    .ok_or_else(|| self.err(&label, "buffer view does not exist"))?;
                let region = self.element_region(&view, 0, 1, view.length().max(1), &label)?;
                region.map(|(bytes, _)| bytes.to_vec()).unwrap_or_default()
            }
            (None, Some(uri)) if !uri.starts_with("data:") => {
                let file = self.resolve_file(uri, &label)?;
                if !file.exists() {
                    self.scene.warnings.push(format!(
                        "{label}: file '{}' not found; it renders magenta (1, 0, 1), as in \
                         Blender",
                        file.display()
                    ));
                    return Ok(DecodedImage {
                        name: label,
                        width: 1,
                        height: 1,
                        texels: Texels::Bytes(vec![[255, 0, 255, 255]]),
                    });
                }
                self.read_uri(uri, &label)?
            }
            (None, Some(uri)) => self.read_uri(uri, &label)?,
            (None, None) => return Err(self.err(&label, "has neither a URI nor a buffer view")),
        };
        let data_mime = json
            .uri
            .as_deref()
            .and_then(|u| u.strip_prefix("data:"))
            .and_then(|r| r.split(';').next())
            .map(str::to_string);
        self.decode_bytes(&encoded, label, declared_mime.or(data_mime))
    }

    /// Decode an encoded PNG, JPEG or WebP image (`claimed`: the MIME type the file states).
    fn decode_bytes(
        &self,
        encoded: &[u8],
        label: String,
        claimed: Option<String>,
    ) -> Result<DecodedImage> {
        let format = sniff_image_format(encoded).ok_or_else(|| {
            let claimed = claimed.unwrap_or_else(|| "unknown format".into());
            self.err(
                &label,
                format!("unsupported image format ({claimed}); Photon reads PNG, JPEG and WebP"),
            )
        })?;
        if format == "image/webp" {
            let (width, height, texels) = decode_webp(encoded)
                .map_err(|e| self.err(&label, format!("cannot decode the WebP image: {e}")))?;
            return Ok(DecodedImage {
                name: label.clone(),
                width,
                height,
                texels: Texels::Bytes(texels),
            });
        }
        // Hand the bytes to the gltf crate's decoder (PNG and JPEG via the image crate) as a
        // data URI: it is the one way to reach it without reading files a second time.
        let uri = format!("data:{format};base64,{}", encode_base64(encoded));
        let data = gltf::image::Data::from_source(
            gltf::image::Source::Uri {
                uri: &uri,
                mime_type: Some(format),
            },
            Some(Path::new(".")),
            &[],
        )
        .map_err(|e| self.err(&label, format!("cannot decode the {format} image: {e}")))?;
        let texels = to_texels(&data).ok_or_else(|| {
            self.err(
                &label,
                format!("unsupported pixel format {:?}", data.format),
            )
        })?;
        Ok(DecodedImage {
            name: label.clone(),
            width: data.width,
            height: data.height,
            texels,
        })
    }

    // ----- lights -------------------------------------------------------------------------

    fn add_lights(&mut self, node: &gltf::Node, world: &Mat4) -> Result<()> {
        let object = named("node", node.index(), node.name());
        let extension = node.extension_value("PHOTON_light");
        let number = |key: &str, default: f32| -> f32 {
            extension
                .and_then(|e| e.get(key))
                .and_then(Value::as_f64)
                .map_or(default, |v| v as f32)
        };
        let position = world.transform_point3(Vec3::ZERO);
        let direction = world
            .transform_vector3(Vec3::NEG_Z)
            .normalize_or(Vec3::NEG_Z);
        if extension
            .and_then(|e| e.get("type"))
            .and_then(Value::as_str)
            == Some("area")
        {
            let area = AreaLight {
                shape: extension
                    .and_then(|e| e.get("shape"))
                    .and_then(Value::as_str)
                    .unwrap_or("SQUARE")
                    .to_string(),
                size: number("size", 1.0),
                size_y: number("size_y", number("size", 1.0)),
                power: number("power", 10.0),
                color: extension
                    .and_then(|e| e.get("color"))
                    .and_then(json_vec3)
                    .unwrap_or(Vec3::ONE),
                visible_camera: extension
                    .and_then(|e| e.get("visible_camera"))
                    .and_then(Value::as_bool)
                    .unwrap_or(false),
                spread: number("spread", std::f32::consts::PI),
            };
            return self.add_area_light(node, world, &area, &object);
        }
        let Some(light) = node.light() else {
            return Ok(());
        };
        let object = format!("{object} PHOTON_light");
        let checked = |key: &str, ok: fn(f32) -> bool| -> Result<Option<f32>> {
            match extension.and_then(|e| e.get(key)) {
                None => Ok(None),
                Some(v) => match v.as_f64().map(|x| x as f32) {
                    Some(x) if x.is_finite() && ok(x) => Ok(Some(x)),
                    _ => Err(self.err(&object, format!("'{key}' is out of range: {v}"))),
                },
            }
        };
        // The extension's colour and power (Cycles' units) replace the photometric values.
        let tint = match extension.and_then(|e| e.get("color")) {
            None => None,
            Some(v) => Some(
                json_vec3(v)
                    .filter(|c| c.is_finite() && c.min_element() >= 0.0)
                    .ok_or_else(|| {
                        self.err(&object, format!("'color' must be three numbers ≥ 0: {v}"))
                    })?,
            ),
        };
        let color = tint.unwrap_or_else(|| Vec3::from(light.color()));
        let power = checked("power", |x| x >= 0.0)?.filter(|_| tint.is_some());
        let intensity = match power {
            Some(watts) => color * units::blender_point_power_to_intensity(watts),
            None => color * units::candela_to_watts_per_sr(light.intensity()),
        };
        let flag = |key: &str, default: bool| -> Result<bool> {
            match extension.and_then(|e| e.get(key)) {
                None => Ok(default),
                Some(v) => v.as_bool().ok_or_else(|| {
                    self.err(&object, format!("'{key}' must be true or false: {v}"))
                }),
            }
        };
        let defaults = Lamp::default();
        let lamp = Lamp {
            soft_falloff: flag("soft_falloff", defaults.soft_falloff)?,
            camera: flag("visible_camera", defaults.camera)?,
            bounces: flag("visible_bounces", defaults.bounces)?,
        };
        let light = match light.kind() {
            gltf::khr_lights_punctual::Kind::Point => Light::Point {
                position,
                intensity,
                radius: number("radius", 0.0),
                lamp,
            },
            gltf::khr_lights_punctual::Kind::Spot {
                inner_cone_angle,
                outer_cone_angle,
            } => {
                // Cycles' cone: smoothstep((cos θ − cos(size/2)) / ((1 − cos(size/2)) × blend)).
                let size = checked("spot_size", |x| x > 0.0 && x <= std::f32::consts::PI)?;
                let blend = checked("spot_blend", |x| (0.0..=1.0).contains(&x))?;
                let (cos_inner, cos_outer) = match size {
                    Some(size) => {
                        let cos_outer = (0.5 * size).cos();
                        let blend = blend.unwrap_or(0.0);
                        (cos_outer + (1.0 - cos_outer) * blend, cos_outer)
                    }
                    None => (inner_cone_angle.cos(), outer_cone_angle.cos()),
                };
                Light::Spot {
                    position,
                    direction,
                    intensity,
                    cos_inner,
                    cos_outer,
                    radius: number("radius", 0.0),
                    lamp,
                }
            }
            gltf::khr_lights_punctual::Kind::Directional => {
                let strength = checked("strength", |x| x >= 0.0)?.filter(|_| tint.is_some());
                Light::Sun {
                    direction,
                    irradiance: match strength {
                        Some(e) => color * e,
                        None => color * units::lux_to_watts_per_m2(light.intensity()),
                    },
                    angle: number("angle", 0.0),
                }
            }
        };
        self.scene.lights.push(light);
        Ok(())
    }

    fn add_area_light(
        &mut self,
        node: &gltf::Node,
        world: &Mat4,
        light: &AreaLight,
        object: &str,
    ) -> Result<()> {
        let (half_x, half_y) = match light.shape.as_str() {
            "SQUARE" | "DISK" => (0.5 * light.size, 0.5 * light.size),
            "RECTANGLE" | "ELLIPSE" => (0.5 * light.size, 0.5 * light.size_y),
            other => {
                return Err(self.err(
                    format!("{object} PHOTON_light"),
                    format!("unknown area light shape '{other}'"),
                ))
            }
        };
        // Local outline, counter-clockwise seen from −Z, so the winding normal points along −Z.
        let outline: Vec<Vec3> = if matches!(light.shape.as_str(), "SQUARE" | "RECTANGLE") {
            vec![
                Vec3::new(-half_x, -half_y, 0.0),
                Vec3::new(-half_x, half_y, 0.0),
                Vec3::new(half_x, half_y, 0.0),
                Vec3::new(half_x, -half_y, 0.0),
            ]
        } else {
            (0..AREA_LIGHT_SEGMENTS)
                .map(|i| {
                    let phi = -std::f32::consts::TAU * i as f32 / AREA_LIGHT_SEGMENTS as f32;
                    Vec3::new(half_x * phi.cos(), half_y * phi.sin(), 0.0)
                })
                .collect()
        };
        let linear = Mat3::from_mat4(*world);
        let mirrored = linear.determinant() < 0.0;
        let mut positions = vec![world.transform_point3(Vec3::ZERO)];
        positions.extend(outline.iter().map(|&p| world.transform_point3(p)));
        let n = outline.len() as u32;
        let indices: Vec<[u32; 3]> = (0..n)
            .map(|i| {
                let (a, b) = (1 + i, 1 + (i + 1) % n);
                if mirrored {
                    [0, b, a]
                } else {
                    [0, a, b]
                }
            })
            .collect();
        let area: f32 = indices
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| positions[i as usize]);
                0.5 * (b - a).cross(c - a).length()
            })
            .sum();
        if !(area > 0.0 && area.is_finite()) {
            return Err(self.err(
                format!("{object} PHOTON_light"),
                format!("area light has zero or invalid area ({area})"),
            ));
        }
        let spread = light.spread;
        if !(0.0..=std::f32::consts::PI).contains(&spread) {
            return Err(self.err(
                format!("{object} PHOTON_light"),
                format!("area light spread {spread} is not an angle in [0, π] radians"),
            ));
        }
        let normal = (linear.inverse().transpose() * Vec3::NEG_Z).normalize_or(Vec3::NEG_Z);
        let name = node.name().unwrap_or("area light").to_string();
        let material = Material {
            name: format!("{name} (area light)"),
            base_color: Vec4::new(0.0, 0.0, 0.0, 1.0),
            metallic: 0.0,
            roughness: 1.0,
            specular: 0.0,
            emission: light.color * units::blender_area_power_to_radiance(light.power, area),
            double_sided: false,
            ..Material::default()
        };
        self.scene.materials.push(material);
        self.scene.meshes.push(Mesh {
            name: format!("{name} (area light)"),
            normals: vec![normal; positions.len()],
            positions,
            uvs: Vec::new(),
            extra_uvs: Vec::new(),
            tangents: Vec::new(),
            indices,
            material: (self.scene.materials.len() - 1) as u32,
            camera_visible: light.visible_camera,
            holdout: false,
            // Narrower than a milliradian is a laser nothing would sample; Cycles clamps too.
            emission_spread: (spread < std::f32::consts::PI).then_some(spread.max(1e-3)),
            casts_shadows: true,
            colors: Vec::new(),
            object_space: None,
            deformation: Vec::new(),
        });
        Ok(())
    }

    // ----- scene-level extensions and the camera ------------------------------------------

    /// The `environment` of PHOTON_world: an EXR beside the glTF file, × `strength`.
    fn load_environment(&self, env: &Value, strength: f32) -> Result<Environment> {
        let object = "scene PHOTON_world environment";
        let uri = env
            .get("uri")
            .and_then(Value::as_str)
            .ok_or_else(|| self.err(object, "'uri' (the environment image) is missing"))?;
        let file = self.resolve_file(uri, object)?;
        if !file.is_file() {
            return Err(self.err(
                object,
                format!("environment image '{uri}' not found ({})", file.display()),
            ));
        }
        let (width, height, rgba) = crate::image_io::read_exr_rgba(&file).map_err(|e| {
            self.err(
                object,
                format!("cannot read environment image '{uri}' as OpenEXR: {e}"),
            )
        })?;
        let mut pixels = Vec::with_capacity(rgba.len());
        for [r, g, b, _] in rgba {
            let c = Vec3::new(r, g, b) * strength;
            if !c.is_finite() {
                return Err(self.err(
                    object,
                    format!("environment image '{uri}' holds NaN or infinite values"),
                ));
            }
            pixels.push(c.max(Vec3::ZERO));
        }
        let closest = match env.get("interpolation").and_then(Value::as_str) {
            None | Some("linear") => false,
            Some("closest") => true,
            Some(other) => {
                return Err(self.err(
                    object,
                    format!("unknown interpolation '{other}' (linear or closest)"),
                ))
            }
        };
        let euler = self.mapping_rotation(env, object)?;
        Ok(Environment {
            width,
            height,
            pixels: pixels.into(),
            to_map: euler * Environment::Y_UP_TO_Z_UP,
            closest,
        })
    }

    /// The `sky` of a PHOTON_world background: Blender's Sky Texture (Nishita) baked × `strength`
    /// into an environment map, and its sun disc as a sun light (in scene directions).
    fn load_sky(&self, sky: &Value, strength: f32) -> Result<(Environment, Option<Light>)> {
        let object = "scene PHOTON_world sky";
        match sky.get("type").and_then(Value::as_str) {
            None | Some("NISHITA") => {}
            Some(other) => {
                return Err(self.err(object, format!("unknown sky type '{other}' (NISHITA)")))
            }
        }
        let defaults = NishitaSettings::default();
        let number = |key: &str, default: f32, valid: fn(f32) -> bool| -> Result<f32> {
            match sky.get(key) {
                None => Ok(default),
                Some(v) => v
                    .as_f64()
                    .map(|x| x as f32)
                    .filter(|&x| x.is_finite() && valid(x))
                    .ok_or_else(|| self.err(object, format!("'{key}' is out of range: {v}"))),
            }
        };
        let any = |_: f32| true;
        let non_negative = |x: f32| x >= 0.0;
        let settings = NishitaSettings {
            sun_elevation: number("sun_elevation", defaults.sun_elevation, any)?,
            sun_rotation: number("sun_rotation", defaults.sun_rotation, any)?,
            sun_size: number("sun_size", defaults.sun_size, |x| {
                (0.0..=std::f32::consts::PI).contains(&x)
            })?,
            sun_intensity: number("sun_intensity", defaults.sun_intensity, non_negative)?,
            sun_disc: sky
                .get("sun_disc")
                .and_then(Value::as_bool)
                .unwrap_or(defaults.sun_disc),
            altitude: number("altitude", defaults.altitude, any)?,
            air: number("air", defaults.air, non_negative)?,
            dust: number("dust", defaults.dust, non_negative)?,
            ozone: number("ozone", defaults.ozone, non_negative)?,
        };
        let rotation = self.mapping_rotation(sky, object)?;
        let to_map = rotation * Environment::Y_UP_TO_Z_UP;
        let model = NishitaSky::new(&settings);
        let map = Environment::bake(SKY_MAP_WIDTH, SKY_MAP_WIDTH / 2, to_map, 3, |d| {
            model.sky_radiance(d) * strength
        });
        let sun = model.sun().map(|sun| Light::Sun {
            direction: -(to_map.transpose() * sun.direction),
            irradiance: sun.irradiance * strength,
            angle: sun.angle,
        });
        Ok((map, sun))
    }

    /// The rotation of a Mapping node (`"rotation": [x, y, z]`, Blender's Euler XYZ, radians)
    /// applied to directions in Blender's frame before a world texture's lookup.
    fn mapping_rotation(&self, texture: &Value, object: &str) -> Result<Mat3> {
        let rotation = match texture.get("rotation") {
            None => Vec3::ZERO,
            Some(v) => json_vec3(v).filter(|r| r.is_finite()).ok_or_else(|| {
                self.err(object, format!("'rotation' must be [x, y, z], found {v}"))
            })?,
        };
        // X first, then Y, then Z.
        Ok(Mat3::from_rotation_z(rotation.z)
            * Mat3::from_rotation_y(rotation.y)
            * Mat3::from_rotation_x(rotation.x))
    }

    /// A background of PHOTON_world (the whole extension, its `camera`, or an entry of `mix`):
    /// a constant colour, an environment image or a sky, each × `strength` × `weight`; a `mix`
    /// sums its entries. Several maps are resampled onto one (the finest) with the constant
    /// colours added. Returns the background and the suns of its skies.
    fn read_background(&self, world: &Value, object: &str) -> Result<(Background, Vec<Light>)> {
        let factor = |layer: &Value, key: &str| -> Result<f32> {
            match layer.get(key) {
                None => Ok(1.0),
                Some(v) => v
                    .as_f64()
                    .map(|x| x as f32)
                    .filter(|x| x.is_finite())
                    .ok_or_else(|| self.err(object, format!("'{key}' must be a number: {v}"))),
            }
        };
        let layers: Vec<&Value> = match world.get("mix") {
            None => vec![world],
            Some(Value::Array(entries)) => entries.iter().collect(),
            Some(v) => return Err(self.err(object, format!("'mix' must be a list, found {v}"))),
        };
        let mut color = Vec3::ZERO;
        let mut maps = Vec::new();
        let mut suns = Vec::new();
        for layer in layers {
            let strength = factor(layer, "strength")? * factor(layer, "weight")?;
            if let Some(env) = layer.get("environment") {
                maps.push(self.load_environment(env, strength)?);
            } else if let Some(sky) = layer.get("sky") {
                let (map, sun) = self.load_sky(sky, strength)?;
                maps.push(map);
                suns.extend(sun);
            } else {
                let c = match layer.get("color") {
                    None => Vec3::ZERO,
                    Some(v) => json_vec3(v).filter(|c| c.is_finite()).ok_or_else(|| {
                        self.err(object, format!("'color' must be [r, g, b], found {v}"))
                    })?,
                };
                color += c * strength;
            }
        }
        let environment = match maps.len() {
            0 => None,
            1 => maps.pop().map(|mut map| {
                if color != Vec3::ZERO {
                    map.pixels = map.pixels.iter().map(|&p| p + color).collect();
                }
                map
            }),
            _ => {
                let finest = maps
                    .iter()
                    .max_by_key(|m| m.width * m.height)
                    .expect("a map");
                let to_map = Environment::Y_UP_TO_Z_UP;
                let back = to_map.transpose();
                let (w, h) = (finest.width, finest.height);
                let mut sum = Environment::bake(w, h, to_map, 1, |d| {
                    let dir = back * d;
                    maps.iter().map(|m| m.radiance(dir)).sum::<Vec3>() + color
                });
                sum.pixels = sum.pixels.iter().map(|p| p.max(Vec3::ZERO)).collect();
                Some(sum)
            }
        };
        Ok((Background { color, environment }, suns))
    }

    fn read_scene_extensions(&mut self, gltf_scene: &gltf::Scene) -> Result<()> {
        if let Some(world) = gltf_scene.extension_value("PHOTON_world") {
            let (background, suns) = self.read_background(world, "scene PHOTON_world")?;
            self.scene.world.background = background;
            self.scene.lights.extend(suns);
            if let Some(camera) = world.get("camera") {
                // A sky's sun disc seen only by the camera is not drawn (see the README).
                let object = "scene PHOTON_world camera";
                let (seen, _suns) = self.read_background(camera, object)?;
                self.scene.world.camera_background = Some(seen);
            }
        }
        if let Some(render) = gltf_scene.extension_value("PHOTON_render") {
            let dimension = |key: &str| -> Result<Option<u32>> {
                match render.get(key) {
                    None => Ok(None),
                    Some(v) => match v.as_u64().and_then(|v| u32::try_from(v).ok()) {
                        Some(d) if d > 0 => Ok(Some(d)),
                        _ => Err(self.err(
                            "scene PHOTON_render",
                            format!("'{key}' must be a positive integer, found {v}"),
                        )),
                    },
                }
            };
            let filter = match render.get("filter") {
                None => None,
                Some(filter) => Some(self.read_filter(filter)?),
            };
            self.scene.render_settings = SceneRenderSettings {
                width: dimension("width")?,
                height: dimension("height")?,
                transparent_film: render
                    .get("film_transparent")
                    .and_then(Value::as_bool)
                    .unwrap_or(false),
                filter,
                volume_bounces: match render.get("volume_bounces") {
                    None => 0,
                    Some(v) => match v.as_u64().filter(|&n| n <= 1024) {
                        Some(n) => n as u32,
                        None => {
                            return Err(self.err(
                                "scene PHOTON_render",
                                format!(
                                    "'volume_bounces' must be an integer in 0..=1024, found {v}"
                                ),
                            ))
                        }
                    },
                },
            };
        }
        Ok(())
    }

    /// `PHOTON_render`'s `filter`: Cycles' pixel filter type and Blender's width.
    fn read_filter(&self, filter: &Value) -> Result<FilterSettings> {
        let object = "scene PHOTON_render filter";
        let name = filter.get("type").and_then(Value::as_str).unwrap_or("");
        let kind = FilterKind::from_name(name).ok_or_else(|| {
            self.err(
                object,
                format!("'type' must be BLACKMAN_HARRIS, GAUSSIAN or BOX, found {name:?}"),
            )
        })?;
        let width = match filter.get("width") {
            None => kind.default_width(),
            Some(w) => w
                .as_f64()
                .ok_or_else(|| self.err(object, format!("'width' must be a number, found {w}")))?
                as f32,
        };
        FilterSettings::new(kind, width).map_err(|e| match e {
            Error::Settings(message) => self.err(object, message),
            e => e,
        })
    }

    fn choose_camera(
        &mut self,
        cameras: Vec<FoundCamera>,
        options: &LoadOptions,
    ) -> Result<Camera> {
        if let Some(wanted) = &options.camera {
            let available: Vec<String> = cameras
                .iter()
                .map(|c| format!("'{}' (camera '{}')", c.node_name, c.camera_name))
                .collect();
            return cameras
                .into_iter()
                .find(|c| &c.node_name == wanted || &c.camera_name == wanted)
                .map(|c| c.camera)
                .ok_or_else(|| {
                    let list = if available.is_empty() {
                        "the file has no cameras".to_string()
                    } else {
                        format!("available: {}", available.join(", "))
                    };
                    self.err(
                        format!("camera '{wanted}'"),
                        format!("no such camera; {list}"),
                    )
                });
        }
        if let Some(first) = cameras.into_iter().next() {
            return Ok(first.camera);
        }
        self.scene
            .warnings
            .push("the file has no camera; using one that frames the scene".into());
        Ok(framing_camera(self.scene.bounds()))
    }
}

/// How many node instances place each mesh, and which meshes move while the shutter is open
/// (placed by a node with a `motion` or under one). Stops after `MAX_NODE_INSTANCES` nodes or at
/// `MAX_NODE_DEPTH` (cycles and depth are refused by `Loader::count_node`, which walks the same
/// hierarchy next).
fn count_mesh_uses(
    node: &gltf::Node,
    uses: &mut HashMap<usize, usize>,
    moving: &mut std::collections::HashSet<usize>,
    moving_above: bool,
    depth: usize,
    visited: &mut usize,
) {
    *visited += 1;
    if depth >= MAX_NODE_DEPTH || *visited > MAX_NODE_INSTANCES {
        return;
    }
    let moves = moving_above || moves(node);
    if let Some(mesh) = node.mesh() {
        *uses.entry(mesh.index()).or_default() += 1;
        if moves {
            moving.insert(mesh.index());
        }
    }
    for child in node.children() {
        count_mesh_uses(&child, uses, moving, moves, depth + 1, visited);
    }
}

/// Running totals of `Loader::check_sizes`.
#[derive(Default)]
struct SizeTotals {
    instances: usize,
    triangles: usize,
    vertices: usize,
    /// Instanced meshes whose triangles are counted already.
    counted_prototypes: std::collections::HashSet<usize>,
}

/// Parameters of a `PHOTON_light` area light.
struct AreaLight {
    shape: String,
    size: f32,
    size_y: f32,
    power: f32,
    color: Vec3,
    visible_camera: bool,
    /// Full spread angle in radians; π emits over the whole hemisphere.
    spread: f32,
}

fn convert_camera(
    node: &gltf::Node,
    camera: &gltf::Camera,
    world: &Mat4,
) -> std::result::Result<Camera, String> {
    let (_, rotation, translation) = world.to_scale_rotation_translation();
    let near_clip = match camera.projection() {
        gltf::camera::Projection::Perspective(p) => p.znear(),
        gltf::camera::Projection::Orthographic(o) => o.znear(),
    };
    let near_clip = if near_clip.is_finite() && near_clip > 0.0 {
        near_clip
    } else {
        0.0
    };
    let (projection, aspect_ratio) = match camera.projection() {
        gltf::camera::Projection::Perspective(p) => {
            let yfov = p.yfov();
            if !(yfov > 0.0 && yfov < std::f32::consts::PI) {
                return Err(format!(
                    "perspective yfov {yfov} is not an angle in (0, π) radians"
                ));
            }
            (Projection::Perspective { yfov }, p.aspect_ratio())
        }
        gltf::camera::Projection::Orthographic(o) => {
            let (xmag, ymag) = (o.xmag(), o.ymag());
            if !(xmag > 0.0 && ymag > 0.0 && xmag.is_finite() && ymag.is_finite()) {
                return Err(format!(
                    "orthographic xmag {xmag} and ymag {ymag} must be positive and finite"
                ));
            }
            (Projection::Orthographic { xmag, ymag }, Some(xmag / ymag))
        }
    };
    if let Some(a) = aspect_ratio {
        if !(a > 0.0 && a.is_finite()) {
            return Err(format!("aspectRatio {a} must be positive and finite"));
        }
    }
    Ok(Camera {
        name: node
            .name()
            .or(camera.name())
            .map_or_else(|| format!("camera {}", camera.index()), str::to_string),
        to_world: Affine3A::from_rotation_translation(rotation.normalize(), translation),
        projection,
        aspect_ratio,
        shift: Vec2::ZERO,
        lens: None,
        motion: Vec::new(),
        near_clip,
    })
}

/// `PHOTON_camera` (see the module documentation) applied to `camera`.
fn read_camera_extension(value: &Value, camera: &mut Camera) -> std::result::Result<(), String> {
    let number =
        |object: &Value, key: &str, default: f32, ok: fn(f32) -> bool| match object.get(key) {
            None => Ok(default),
            Some(v) => match v.as_f64().map(|x| x as f32) {
                Some(x) if x.is_finite() && ok(x) => Ok(x),
                _ => Err(format!("'{key}' is out of range: {v}")),
            },
        };
    if let Some(v) = value.get("shift") {
        camera.shift = match v.as_array().map(Vec::as_slice) {
            Some([x, y]) => match (x.as_f64(), y.as_f64()) {
                (Some(x), Some(y)) => Vec2::new(x as f32, y as f32),
                _ => return Err(format!("'shift' must be two numbers, found {v}")),
            },
            _ => return Err(format!("'shift' must be two numbers, found {v}")),
        };
        if !camera.shift.is_finite() {
            return Err(format!("'shift' must be finite, found {v}"));
        }
    }
    if let Some(panorama) = value.get("panorama") {
        camera.projection = read_panorama(panorama)?;
    }
    if let Some(v) = value.get("motion") {
        // Cameras are rigid: the scale goes.
        camera.motion = read_poses(v)?
            .into_iter()
            .map(|m| {
                let (_, rotation, translation) = m.to_scale_rotation_translation();
                Affine3A::from_rotation_translation(rotation.normalize(), translation)
            })
            .collect();
    }
    if let Some(dof) = value.get("dof") {
        let radius = number(dof, "aperture_radius", 0.0, |x| x >= 0.0)?;
        let focus_distance = number(dof, "focus_distance", 10.0, |x| x > 0.0)?;
        let blades = number(dof, "blades", 0.0, |x| (0.0..=1000.0).contains(&x))?;
        let rotation = number(dof, "rotation", 0.0, |_| true)?;
        let ratio = number(dof, "ratio", 1.0, |x| x > 0.0)?;
        camera.lens = (radius > 0.0).then_some(ThinLens {
            radius,
            focus_distance,
            blades: blades as u32,
            rotation,
            ratio,
        });
    }
    Ok(())
}

/// A "motion" of `PHOTON_camera` or `PHOTON_object`: two or more poses, each 16 numbers (a
/// column-major world matrix, glTF axes), finite and invertible.
fn read_poses(value: &Value) -> std::result::Result<Vec<Affine3A>, String> {
    let poses = value
        .as_array()
        .filter(|p| p.len() >= 2)
        .ok_or_else(|| format!("'motion' must be a list of two or more matrices, found {value}"))?;
    poses
        .iter()
        .map(|pose| {
            let numbers: Vec<f32> = pose
                .as_array()
                .map(|a| {
                    a.iter()
                        .filter_map(|x| x.as_f64().map(|x| x as f32))
                        .collect()
                })
                .unwrap_or_default();
            let bad = || format!("a 'motion' pose must be 16 finite numbers, found {pose}");
            let array: [f32; 16] = numbers.try_into().map_err(|_| bad())?;
            let matrix = Mat4::from_cols_array(&array);
            if !matrix.is_finite() || matrix.determinant().abs() < 1e-12 {
                return Err(bad());
            }
            Ok(Affine3A::from_mat4(matrix))
        })
        .collect()
}

/// Whether `node` moves or deforms while the shutter is open (`PHOTON_object` "motion" or
/// "deform").
fn moves(node: &gltf::Node) -> bool {
    node.extension_value("PHOTON_object")
        .is_some_and(|v| v.get("motion").is_some() || v.get("deform").is_some())
}

/// `PHOTON_object`'s "deform": the positions of the object's vertices at the frame, and at
/// two or more steps of the shutter, each base64 little-endian f32 triples (glTF axes, object
/// space).
fn read_deform(value: &Value) -> std::result::Result<(Vec<Vec3>, Vec<Vec<Vec3>>), String> {
    let positions = |v: &Value| -> std::result::Result<Vec<Vec3>, String> {
        let bytes = v
            .as_str()
            .and_then(decode_base64)
            .filter(|b| b.len() % 12 == 0)
            .ok_or("'deform' positions must be base64 of little-endian float triples")?;
        let floats: Vec<f32> = bytes
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        let out: Vec<Vec3> = floats.chunks_exact(3).map(Vec3::from_slice).collect();
        match out.iter().all(|p| p.is_finite()) {
            true => Ok(out),
            false => Err("a 'deform' position is NaN or infinite".into()),
        }
    };
    let frame = positions(value.get("frame").ok_or("'deform' needs its 'frame'")?)?;
    let steps = value
        .get("steps")
        .and_then(Value::as_array)
        .filter(|s| s.len() >= 2)
        .ok_or("'deform' needs 'steps', a list of two or more")?
        .iter()
        .map(positions)
        .collect::<std::result::Result<Vec<_>, _>>()?;
    if steps.iter().any(|s| s.len() != frame.len()) {
        return Err("every 'deform' step must hold as many positions as 'frame'".into());
    }
    Ok((frame, steps))
}

/// A primitive's deformation: each of its vertices (`positions`) found by its exact position
/// among the object's vertices at the frame, then its place at each step; `None` when a
/// vertex is not among them.
fn deformation_of(
    positions: &[Vec3],
    frame: &[Vec3],
    steps: &[Vec<Vec3>],
) -> Option<Vec<Vec<Vec3>>> {
    // −0.0 + 0.0 is +0.0: both zeros are one key.
    let key = |p: Vec3| (p + Vec3::ZERO).to_array().map(f32::to_bits);
    let mut index: HashMap<[u32; 3], usize> = HashMap::with_capacity(frame.len());
    for (i, &p) in frame.iter().enumerate() {
        index.entry(key(p)).or_insert(i);
    }
    let found: Vec<usize> = positions
        .iter()
        .map(|&p| index.get(&key(p)).copied())
        .collect::<Option<_>>()?;
    Some(
        steps
            .iter()
            .map(|step| found.iter().map(|&i| step[i]).collect())
            .collect(),
    )
}

/// The `panorama` of `PHOTON_camera`: Cycles' equirectangular or fisheye projection.
fn read_panorama(value: &Value) -> std::result::Result<Projection, String> {
    let pair = |key: &str, default: (f32, f32), ok: fn(f32) -> bool| match value.get(key) {
        None => Ok(default),
        Some(v) => match v.as_array().map(Vec::as_slice) {
            Some([a, b]) => match (a.as_f64(), b.as_f64()) {
                (Some(a), Some(b)) if ok(a as f32) && ok(b as f32) => Ok((a as f32, b as f32)),
                _ => Err(format!("'{key}' is out of range: {v}")),
            },
            _ => Err(format!("'{key}' must be two numbers, found {v}")),
        },
    };
    let number = |key: &str, default: f32| match value.get(key) {
        None => Ok(default),
        Some(v) => match v.as_f64().map(|x| x as f32) {
            Some(x) if x.is_finite() && x > 0.0 => Ok(x),
            _ => Err(format!("'{key}' must be a positive number, found {v}")),
        },
    };
    let pi = std::f32::consts::PI;
    match value.get("type").and_then(Value::as_str) {
        Some("EQUIRECTANGULAR") => Ok(Projection::Equirectangular {
            longitude: pair("longitude", (-pi, pi), |x| x.is_finite())?,
            latitude: pair("latitude", (-0.5 * pi, 0.5 * pi), |x| x.is_finite())?,
        }),
        Some("FISHEYE_EQUIDISTANT") => Ok(Projection::FisheyeEquidistant {
            fov: number("fov", pi)?,
        }),
        Some("FISHEYE_EQUISOLID") => Ok(Projection::FisheyeEquisolid {
            lens: number("lens", 10.5)?,
            fov: number("fov", pi)?,
            sensor: pair("sensor", (36.0, 24.0), |x| x.is_finite() && x > 0.0)?,
        }),
        other => Err(format!(
            "unknown panorama type {other:?} (EQUIRECTANGULAR, FISHEYE_EQUIDISTANT or \
             FISHEYE_EQUISOLID)"
        )),
    }
}

/// A 40° perspective camera in front of the bounds (+Z side, slightly above), looking at their
/// centre from far enough that the bounding sphere fits in the view.
fn framing_camera(bounds: Bounds) -> Camera {
    let yfov = 40f32.to_radians();
    let (center, radius) = if bounds.is_empty() {
        (Vec3::ZERO, 1.0)
    } else {
        (bounds.center(), (0.5 * bounds.diagonal()).max(1e-3))
    };
    let distance = 1.1 * radius / (0.5 * yfov).sin();
    let eye = center + distance * Vec3::new(0.0, 0.3, 1.0).normalize();
    Camera {
        name: "framing camera".into(),
        to_world: look_at(eye, center),
        projection: Projection::Perspective { yfov },
        aspect_ratio: None,
        shift: Vec2::ZERO,
        lens: None,
        motion: Vec::new(),
        near_clip: 0.0,
    }
}

/// Camera-to-world transform of a camera at `eye` looking at `target` (−Z forward, +Y up).
fn look_at(eye: Vec3, target: Vec3) -> Affine3A {
    let back = (eye - target).normalize_or(Vec3::Z);
    let right = Vec3::Y.cross(back).normalize_or(Vec3::X);
    let up = back.cross(right);
    Affine3A::from_mat3_translation(Mat3::from_cols(right, up, back), eye)
}

/// Split every triangle's vertices apart and give them the face normal (a mesh without normals
/// is flat shaded in glTF); every per-vertex attribute follows its vertex.
fn make_flat(mesh: &mut Mesh) {
    let corners: Vec<u32> = mesh.indices.iter().flatten().copied().collect();
    fn spread<T: Copy>(values: &[T], corners: &[u32]) -> Vec<T> {
        if values.is_empty() {
            return Vec::new();
        }
        corners.iter().map(|&i| values[i as usize]).collect()
    }
    mesh.normals = mesh
        .indices
        .iter()
        .flat_map(|tri| {
            let [a, b, c] = tri.map(|i| mesh.positions[i as usize]);
            [(b - a).cross(c - a).normalize_or_zero(); 3]
        })
        .collect();
    mesh.positions = spread(&mesh.positions, &corners);
    mesh.uvs = spread(&mesh.uvs, &corners);
    mesh.extra_uvs = mesh
        .extra_uvs
        .iter()
        .map(|set| spread(set, &corners))
        .collect();
    mesh.tangents = spread(&mesh.tangents, &corners);
    mesh.colors = spread(&mesh.colors, &corners);
    mesh.indices = (0..mesh.indices.len() as u32)
        .map(|t| [3 * t, 3 * t + 1, 3 * t + 2])
        .collect();
}

fn check_length<T>(values: &[T], vertex_count: usize) -> std::result::Result<(), String> {
    if values.is_empty() || values.len() == vertex_count {
        Ok(())
    } else {
        Err(format!(
            "has {} elements for {vertex_count} vertices",
            values.len()
        ))
    }
}

/// "node 3 'Cube'" or "node 3".
fn named(kind: &str, index: usize, name: Option<&str>) -> String {
    match name {
        Some(n) => format!("{kind} {index} '{n}'"),
        None => format!("{kind} {index}"),
    }
}

fn json_vec3(value: &Value) -> Option<Vec3> {
    let a = value.as_array()?;
    match a.as_slice() {
        [r, g, b] => Some(Vec3::new(
            r.as_f64()? as f32,
            g.as_f64()? as f32,
            b.as_f64()? as f32,
        )),
        _ => None,
    }
}

/// KHR_texture_transform read from raw JSON (the gltf crate models it only on texture infos).
fn raw_texture_transform(value: &Value) -> (Vec2, f32, Vec2) {
    let pair = |key: &str, default: Vec2| -> Vec2 {
        value
            .get(key)
            .and_then(Value::as_array)
            .and_then(|a| match a.as_slice() {
                [x, y] => Some(Vec2::new(x.as_f64()? as f32, y.as_f64()? as f32)),
                _ => None,
            })
            .unwrap_or(default)
    };
    let rotation = value.get("rotation").and_then(Value::as_f64).unwrap_or(0.0) as f32;
    (
        pair("offset", Vec2::ZERO),
        rotation,
        pair("scale", Vec2::ONE),
    )
}

fn convert_wrap(mode: gltf::texture::WrappingMode) -> Wrap {
    match mode {
        gltf::texture::WrappingMode::ClampToEdge => Wrap::ClampToEdge,
        gltf::texture::WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
        gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
    }
}

/// One accessor component as f32, applying glTF's normalisation of integer types.
fn component_as_f32(bytes: &[u8], data_type: DataType, normalized: bool) -> f32 {
    let raw = |scale: f32, value: f32| {
        if normalized {
            (value / scale).max(-1.0)
        } else {
            value
        }
    };
    match (data_type, bytes) {
        (DataType::F32, &[a, b, c, d]) => f32::from_le_bytes([a, b, c, d]),
        (DataType::U8, &[a]) => raw(255.0, a as f32),
        (DataType::I8, &[a]) => raw(127.0, a as i8 as f32),
        (DataType::U16, &[a, b]) => raw(65535.0, u16::from_le_bytes([a, b]) as f32),
        (DataType::I16, &[a, b]) => raw(32767.0, i16::from_le_bytes([a, b]) as f32),
        (DataType::U32, &[a, b, c, d]) => {
            raw(u32::MAX as f32, u32::from_le_bytes([a, b, c, d]) as f32)
        }
        _ => f32::NAN,
    }
}

/// Whether glTF lets vertex attribute `what` be stored with this component type: floats always;
/// normalized unsigned bytes and shorts for texture coordinates; and with KHR_mesh_quantization
/// (`quantized`) the integer types that extension lists (POSITION and TEXCOORD normalized or not,
/// NORMAL and TANGENT normalized signed). Integers read as they are (normalized ones mapped to
/// [0, 1] or [−1, 1]); the node transform then dequantizes them, as the extension intends.
fn check_attribute_type(
    what: &str,
    data_type: DataType,
    normalized: bool,
    quantized: bool,
) -> std::result::Result<(), String> {
    use DataType::{F32, I16, I8, U16, U8};
    let allowed = match (what, data_type) {
        (_, F32) => !normalized,
        ("TEXCOORD_0" | "COLOR_0", U8 | U16) if normalized => true,
        ("POSITION" | "TEXCOORD_0", I8 | U8 | I16 | U16) => quantized,
        ("NORMAL" | "TANGENT", I8 | I16) => quantized && normalized,
        _ => false,
    };
    if allowed {
        return Ok(());
    }
    let kind = match data_type {
        I8 => "signed bytes",
        U8 => "unsigned bytes",
        I16 => "signed shorts",
        U16 => "unsigned shorts",
        DataType::U32 => "unsigned 32-bit integers",
        F32 => "floats",
    };
    let norm = if normalized { "normalized " } else { "" };
    let quantizable = !matches!(data_type, F32 | DataType::U32);
    Err(if quantizable && !quantized {
        format!(
            "is stored as {norm}{kind}, which glTF allows only with the KHR_mesh_quantization \
             extension, and the file does not declare it (a broken exporter? read as numbers \
             it would give garbage geometry)"
        )
    } else {
        format!("cannot be stored as {norm}{kind} (glTF and KHR_mesh_quantization forbid it)")
    })
}

/// One unsigned integer accessor component.
fn component_as_u32(bytes: &[u8], data_type: DataType, _normalized: bool) -> u32 {
    match (data_type, bytes) {
        (DataType::U8, &[a]) => a as u32,
        (DataType::U16, &[a, b]) => u16::from_le_bytes([a, b]) as u32,
        (DataType::U32, &[a, b, c, d]) => u32::from_le_bytes([a, b, c, d]),
        _ => u32::MAX,
    }
}

/// Every mesh attribute must name an existing accessor. Checked before the gltf crate's
/// validation, which indexes the POSITION accessor without checking (and would panic).
fn check_attribute_indices(root: &gltf::json::Root) -> std::result::Result<(), (String, String)> {
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            for (semantic, accessor) in &primitive.attributes {
                if accessor.value() >= root.accessors.len() {
                    let mesh_name = named("mesh", m, mesh.name.as_deref());
                    let semantic = match semantic {
                        gltf::json::validation::Checked::Valid(s) => s.to_string(),
                        gltf::json::validation::Checked::Invalid => "attribute".into(),
                    };
                    return Err((
                        format!("{mesh_name} primitive {p}"),
                        format!(
                            "{semantic} refers to accessor {}, which does not exist ({} accessors)",
                            accessor.value(),
                            root.accessors.len()
                        ),
                    ));
                }
            }
        }
    }
    Ok(())
}

/// A GLB chunk: its type, its data and the offset of the next chunk.
type GlbChunk<'a> = (u32, &'a [u8], usize);

/// Split a binary glTF into its JSON chunk and optional BIN chunk, checking every length.
fn split_glb(bytes: &[u8]) -> std::result::Result<(&[u8], Option<&[u8]>), String> {
    let word = |at: usize| -> Option<u32> {
        let b = bytes.get(at..at + 4)?;
        Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    };
    let truncated =
        |what: &str| format!("truncated .glb: {what} is missing ({} bytes)", bytes.len());
    let version = word(4).ok_or_else(|| truncated("the header"))?;
    if version != 2 {
        return Err(format!("unsupported GLB version {version} (expected 2)"));
    }
    let declared = word(8).ok_or_else(|| truncated("the header"))? as usize;
    if declared > bytes.len() {
        return Err(format!(
            "truncated .glb: the header says {declared} bytes but the file has {}",
            bytes.len()
        ));
    }
    let bytes = &bytes[..declared.max(12).min(bytes.len())];
    let chunk = |at: usize| -> std::result::Result<Option<GlbChunk>, String> {
        if at >= bytes.len() {
            return Ok(None);
        }
        let length = word(at).ok_or_else(|| truncated("a chunk header"))? as usize;
        let kind = word(at + 4).ok_or_else(|| truncated("a chunk header"))?;
        let data = bytes.get(at + 8..at + 8 + length).ok_or_else(|| {
            format!("truncated .glb: a chunk of {length} bytes at {at} runs past the end")
        })?;
        Ok(Some((kind, data, at + 8 + length)))
    };
    const JSON: u32 = 0x4E4F_534A;
    const BIN: u32 = 0x004E_4942;
    let (kind, json, next) = chunk(12)?.ok_or_else(|| truncated("the JSON chunk"))?;
    if kind != JSON {
        return Err("the first GLB chunk is not JSON".into());
    }
    let bin = match chunk(next)? {
        Some((BIN, data, _)) => Some(data),
        _ => None,
    };
    Ok((json, bin))
}

/// Point each texture that has `EXT_texture_webp` at the extension's WebP image, which Photon
/// decodes, so that the rest of the loader reads `source` only. A texture with neither a
/// `source` nor the extension is left for validation to refuse.
fn use_webp_sources(root: &mut gltf::json::Root) -> std::result::Result<(), (String, String)> {
    let images = root.images.len();
    for (index, texture) in root.textures.iter_mut().enumerate() {
        let Some(webp) = texture
            .extensions
            .as_ref()
            .and_then(|e| e.others.get("EXT_texture_webp"))
        else {
            continue;
        };
        let object = || format!("texture {index} (EXT_texture_webp)");
        let source = webp.get("source").and_then(|s| s.as_u64()).ok_or_else(|| {
            (
                object(),
                "'source' is missing or not an image index".to_string(),
            )
        })?;
        if source >= images as u64 {
            return Err((
                object(),
                format!("'source' {source} is not an image (the file has {images})"),
            ));
        }
        texture.source = gltf::json::Index::new(source as u32);
    }
    Ok(())
}

/// The mime type of PNG, JPEG or WebP bytes, from their signature.
/// The first bytes of an OpenEXR file.
const EXR_MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];

fn sniff_image_format(bytes: &[u8]) -> Option<&'static str> {
    if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
        Some("image/png")
    } else if bytes.starts_with(&[0xFF, 0xD8, 0xFF]) {
        Some("image/jpeg")
    } else if bytes.len() >= 12 && bytes.starts_with(b"RIFF") && &bytes[8..12] == b"WEBP" {
        Some("image/webp")
    } else {
        None
    }
}

/// WebP bytes as 8-bit RGBA, with the image crate (the gltf crate's decoder reads PNG and JPEG
/// only).
fn decode_webp(bytes: &[u8]) -> std::result::Result<(u32, u32, Vec<[u8; 4]>), String> {
    let image = image::load_from_memory_with_format(bytes, image::ImageFormat::WebP)
        .map_err(|e| e.to_string())?
        .into_rgba8();
    let (width, height) = image.dimensions();
    let texels = image
        .into_raw()
        .chunks_exact(4)
        .map(|p| [p[0], p[1], p[2], p[3]])
        .collect();
    Ok((width, height, texels))
}

/// Any decoded glTF image as 8-bit RGBA (16-bit keeps the high byte; grey and RGB gain channels).
/// The decoder's pixels as texels: 8-bit ones as bytes, 16-bit ones as floats in [0, 1] (still
/// encoded: `push_texture` decodes sRGB). Grey and grey-alpha images are spread to RGBA.
fn to_texels(data: &gltf::image::Data) -> Option<Texels> {
    use gltf::image::Format;
    let (channels, bytes_per_channel) = match data.format {
        Format::R8 => (1, 1),
        Format::R8G8 => (2, 1),
        Format::R8G8B8 => (3, 1),
        Format::R8G8B8A8 => (4, 1),
        Format::R16 => (1, 2),
        Format::R16G16 => (2, 2),
        Format::R16G16B16 => (3, 2),
        Format::R16G16B16A16 => (4, 2),
        _ => return None,
    };
    let pixel_count = (data.width as usize).checked_mul(data.height as usize)?;
    let pixel_size = channels * bytes_per_channel;
    if data.pixels.len() != pixel_count.checked_mul(pixel_size)? {
        return None;
    }
    // 16-bit samples are stored in native byte order by the decoder.
    let sample = |p: &[u8], c: usize| -> f32 {
        if bytes_per_channel == 2 {
            u16::from_ne_bytes([p[2 * c], p[2 * c + 1]]) as f32 / 65535.0
        } else {
            p[c] as f32 / 255.0
        }
    };
    let rgba = |p: &[u8]| match channels {
        1 => {
            let g = sample(p, 0);
            [g, g, g, 1.0]
        }
        2 => {
            let g = sample(p, 0);
            [g, g, g, sample(p, 1)]
        }
        3 => [sample(p, 0), sample(p, 1), sample(p, 2), 1.0],
        _ => [sample(p, 0), sample(p, 1), sample(p, 2), sample(p, 3)],
    };
    let pixels = data.pixels.chunks_exact(pixel_size);
    Some(if bytes_per_channel == 1 {
        Texels::Bytes(
            pixels
                .map(|p| rgba(p).map(|v| (v * 255.0).round() as u8))
                .collect(),
        )
    } else {
        Texels::Linear(pixels.map(rgba).collect())
    })
}

const BASE64_ALPHABET: &[u8; 64] =
    b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

fn decode_base64(text: &str) -> Option<Vec<u8>> {
    let mut out = Vec::with_capacity(text.len() / 4 * 3);
    let mut accumulator = 0u32;
    let mut bits = 0;
    for &c in text.trim_end_matches('=').as_bytes() {
        let value = match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' | b'-' => 62,
            b'/' | b'_' => 63,
            b'\r' | b'\n' | b' ' => continue,
            _ => return None,
        };
        accumulator = (accumulator << 6) | value as u32;
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((accumulator >> bits) as u8);
        }
    }
    Some(out)
}

fn encode_base64(bytes: &[u8]) -> String {
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for group in bytes.chunks(3) {
        let n = group
            .iter()
            .enumerate()
            .fold(0u32, |n, (i, &b)| n | (b as u32) << (16 - 8 * i));
        for i in 0..4 {
            if i <= group.len() {
                out.push(BASE64_ALPHABET[(n >> (18 - 6 * i) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// Decode %XX escapes in a URI path; `None` for malformed escapes or non-UTF-8 results.
fn percent_decode(text: &str) -> Option<String> {
    let bytes = text.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while let Some(&b) = bytes.get(i) {
        if b == b'%' {
            let hex = std::str::from_utf8(bytes.get(i + 1..i + 3)?).ok()?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(b);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_round_trips() {
        for len in 0..10 {
            let bytes: Vec<u8> = (0..len).map(|i| (i * 37 + 200) as u8).collect();
            assert_eq!(decode_base64(&encode_base64(&bytes)).unwrap(), bytes);
        }
        assert_eq!(encode_base64(b"Man"), "TWFu");
        assert_eq!(decode_base64("TWE=").unwrap(), b"Ma");
    }

    #[test]
    fn percent_decoding_rejects_malformed_escapes() {
        assert_eq!(percent_decode("my%20wood.png").unwrap(), "my wood.png");
        assert!(percent_decode("bad%zz").is_none());
        assert!(percent_decode("cut%2").is_none());
        assert!(percent_decode("%FF").is_none());
    }

    #[test]
    fn glb_headers_are_checked() {
        assert!(split_glb(b"glTF").is_err());
        let mut glb = b"glTF".to_vec();
        glb.extend(2u32.to_le_bytes());
        glb.extend(1000u32.to_le_bytes());
        assert!(split_glb(&glb).unwrap_err().contains("truncated"));
    }

    #[test]
    fn flat_meshes_keep_every_attribute_per_corner() {
        let mut mesh = Mesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ONE],
            uvs: vec![Vec2::ZERO, Vec2::X, Vec2::Y, Vec2::ONE],
            extra_uvs: vec![vec![Vec2::ONE, Vec2::ZERO, Vec2::X, Vec2::Y]],
            colors: vec![Vec4::X, Vec4::Y, Vec4::Z, Vec4::W],
            indices: vec![[0, 1, 2], [2, 1, 3]],
            ..Mesh::default()
        };
        make_flat(&mut mesh);
        assert_eq!(mesh.positions.len(), 6);
        assert_eq!(mesh.normals.len(), 6);
        assert_eq!(mesh.indices, vec![[0, 1, 2], [3, 4, 5]]);
        assert_eq!(mesh.colors[3], Vec4::Z);
        assert_eq!(mesh.uvs[5], Vec2::ONE);
        assert_eq!(mesh.extra_uvs[0][4], Vec2::ZERO);
        assert!(mesh.tangents.is_empty());
        assert_eq!(mesh.normals[0], Vec3::Z);
    }

    #[test]
    fn sixteen_bit_images_keep_their_sixteen_bits() {
        let data = gltf::image::Data {
            pixels: [0x1234u16, 0xABCD, 0xFFFF]
                .iter()
                .flat_map(|v| v.to_ne_bytes())
                .collect(),
            format: gltf::image::Format::R16G16B16,
            width: 1,
            height: 1,
        };
        let Some(Texels::Linear(texels)) = to_texels(&data) else {
            panic!("16-bit texels are kept as floats");
        };
        let expected = [0x1234 as f32 / 65535.0, 0xABCD as f32 / 65535.0, 1.0, 1.0];
        assert_eq!(texels, vec![expected]);
        let bytes = gltf::image::Data {
            pixels: vec![0x12, 0xAB],
            format: gltf::image::Format::R8G8,
            width: 1,
            height: 1,
        };
        assert!(matches!(
            to_texels(&bytes),
            Some(Texels::Bytes(t)) if t == vec![[0x12, 0x12, 0x12, 0xAB]]
        ));
    }
}
