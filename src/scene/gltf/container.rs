//! The glTF container: a `.glb` split into its JSON and binary chunks (every length checked) or
//! a `.gltf`'s JSON, the required extensions checked, the document validated by the gltf crate,
//! and the buffers loaded from the binary chunk, data URIs or files beside the glTF file. The
//! `Loader` defined here carries the document and the scene being built from it; each of the
//! neighbouring files adds the methods of one concern.

use super::encoding::{decode_base64, percent_decode};
use super::extensions::{Invalid, NodeExtensions};
use super::images::DecodedImage;
use crate::error::{Error, Result};
use crate::math::{Affine3A, Quat, Vec2, Vec3};
use crate::scene::{Camera, Projection, Scene, SceneRenderSettings, World};
use serde_json::Value;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::rc::Rc;

/// Extensions Photon reads; any other in `extensionsRequired` makes the file unloadable.
pub(super) const SUPPORTED_EXTENSIONS: &[&str] = &[
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
    "KHR_materials_diffuse_transmission",
    "KHR_materials_unlit",
    "KHR_materials_pbrSpecularGlossiness",
    "KHR_materials_variants",
    "KHR_texture_transform",
    "KHR_mesh_quantization",
    "KHR_animation_pointer",
    "EXT_mesh_gpu_instancing",
    "EXT_texture_webp",
    "EXT_meshopt_compression",
    "KHR_meshopt_compression",
    "KHR_draco_mesh_compression",
    "KHR_texture_basisu",
];

/// A parsed document with its buffers loaded, and the scene being built from it.
pub(super) struct Loader {
    pub(super) path: PathBuf,
    /// Directory external URIs are resolved against; `None` for in-memory files.
    pub(super) base: Option<PathBuf>,
    pub(super) document: gltf::Document,
    pub(super) buffers: Vec<Vec<u8>>,
    /// The bytes of each buffer view stored with `EXT_meshopt_compression` or
    /// `KHR_meshopt_compression`, decoded, by view index: read in place of the view's own
    /// buffer range.
    pub(super) decoded_views: HashMap<usize, Vec<u8>>,
    /// The bytes of each accessor filled from a `KHR_draco_mesh_compression` primitive,
    /// decoded, by accessor index: read in place of the accessor's (absent) buffer view.
    pub(super) decoded_accessors: HashMap<usize, Vec<u8>>,
    /// Scene material index of each glTF material, in document order; the glTF default
    /// material, when used, is appended after them.
    pub(super) default_material: Option<u32>,
    /// The material made for primitives without one that have vertex colours
    /// (`Loader::material_index`).
    pub(super) vertex_color_material: Option<u32>,
    /// Decoded RGBA8 images by glTF image index.
    pub(super) images: HashMap<usize, DecodedImage>,
    /// Scene texture index per (glTF texture index, sRGB).
    pub(super) texture_slots: HashMap<(usize, bool), u32>,
    /// The current material's textures that read a UV set other than 0: warned about unless
    /// the material's node tree replaces them.
    pub(super) uv_set_warnings: Vec<String>,
    pub(super) scene: Scene,
    pub(super) triangle_total: usize,
    pub(super) vertex_total: usize,
    pub(super) node_instances: usize,
    /// The file declares KHR_mesh_quantization: vertex attributes may be stored as integers.
    pub(super) quantized: bool,
    /// glTF meshes stored once as prototypes (`Scene::prototypes`) and placed by instances.
    pub(super) instanced_meshes: std::collections::HashSet<usize>,
    /// Prototype indices of each instanced glTF mesh (one per primitive), once built.
    pub(super) prototype_ids: HashMap<usize, Vec<u32>>,
    /// Each node's `PHOTON_*` extensions, by node index, read once.
    pub(super) node_extensions: Rc<[NodeExtensions]>,
    /// Bytes of voxel grids read so far (`scene::grids::MAX_GRID_BYTES` at most).
    pub(super) grid_bytes: u64,
    /// The file's `animations`, as JSON (posed by `animation` at `LoadOptions::time`).
    pub(super) animations: Vec<Value>,
    /// What the animations set on each node at `LoadOptions::time` (empty without a time).
    pub(super) pose: HashMap<usize, NodePose>,
    /// The `KHR_materials_variants` variant chosen (`LoadOptions::variant`), by index.
    pub(super) variant: Option<usize>,
}

impl Loader {
    pub(super) fn err(&self, object: impl Into<String>, message: impl Into<String>) -> Error {
        Error::scene(&self.path, object, message)
    }

    /// The error for an extension of `object` refused when it was read.
    pub(super) fn invalid(&self, object: &str, invalid: Invalid) -> Error {
        Error::scene(&self.path, invalid.object(object), invalid.message)
    }

    /// Parse JSON (or split a GLB), check required extensions, validate, and load buffers.
    pub(super) fn parse(bytes: &[u8], path: &Path, base: Option<&Path>) -> Result<Loader> {
        let (json, blob) = if bytes.starts_with(b"glTF") {
            split_glb(bytes).map_err(|m| Error::scene(path, "GLB container", m))?
        } else {
            (bytes, None)
        };
        let malformed = |e| Error::scene(path, "JSON", format!("malformed glTF JSON: {e}"));
        let mut json: Value = serde_json::from_slice(json).map_err(malformed)?;
        // Animations are read here (`animation`), not by the gltf crate, whose schema refuses
        // valid channels (KHR_animation_pointer's have no `node`).
        let animations = match json.as_object_mut().and_then(|o| o.remove("animations")) {
            Some(Value::Array(list)) => list,
            _ => Vec::new(),
        };
        let mut root: gltf::json::Root = serde_json::from_value(json).map_err(malformed)?;

        let unsupported: Vec<&String> = root
            .extensions_required
            .iter()
            .filter(|e| !SUPPORTED_EXTENSIONS.contains(&e.as_str()))
            .collect();
        if !unsupported.is_empty() {
            let names: Vec<String> = unsupported
                .iter()
                .map(|name| match unsupported_reason(name) {
                    Some(why) => format!("{name} ({why})"),
                    None => name.to_string(),
                })
                .collect();
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
        use_extension_sources(&mut root).map_err(|(object, m)| Error::scene(path, object, m))?;
        // Everything left is supported here, even the extensions the gltf crate's validation does
        // not list as "enabled" (volume, specular); required-ness has been checked.
        root.extensions_required.clear();
        let quantized = root
            .extensions_used
            .iter()
            .any(|e| e == "KHR_mesh_quantization");

        // Accessors filled from Draco data have neither a buffer view nor sparse values, which
        // the gltf crate's validation reports; the Draco glue gives them their bytes.
        let draco = draco_accessors(&root);
        let mut errors = Vec::new();
        {
            use gltf::json::validation::Validate;
            root.validate(&root, gltf::json::Path::new, &mut |path, error| {
                errors.push((path(), error))
            });
        }
        errors.retain(|(p, e)| {
            !(matches!(e, gltf::json::validation::Error::Missing) && draco.contains(&p.to_string()))
        });
        if !errors.is_empty() {
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
            return Err(Error::scene(
                path,
                "document",
                format!("invalid glTF: {}{suffix}", listed.join("; ")),
            ));
        }
        let document = gltf::Document::from_json_without_validation(root);

        let node_extensions = document
            .nodes()
            .map(|node| {
                NodeExtensions::read(&node).map_err(|(extension, invalid)| {
                    let node = named("node", node.index(), node.name());
                    let object = invalid.object(&format!("{node} {extension}"));
                    Error::scene(path, object, invalid.message)
                })
            })
            .collect::<Result<Rc<[NodeExtensions]>>>()?;
        let mut loader = Loader {
            path: path.to_path_buf(),
            base: base.map(Path::to_path_buf),
            document,
            buffers: Vec::new(),
            decoded_views: HashMap::new(),
            decoded_accessors: HashMap::new(),
            default_material: None,
            vertex_color_material: None,
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
                    far_clip: f32::INFINITY,
                },
                world: World::default(),
                render_settings: SceneRenderSettings::default(),
                warnings: Vec::new(),
                export_notes: Vec::new(),
                light_links: Vec::new(),
            },
            triangle_total: 0,
            vertex_total: 0,
            node_instances: 0,
            grid_bytes: 0,
            quantized,
            instanced_meshes: Default::default(),
            prototype_ids: HashMap::new(),
            node_extensions,
            variant: None,
            animations,
            pose: HashMap::new(),
        };
        loader.load_buffers(blob)?;
        loader.decode_meshopt_views()?;
        loader.decode_draco_primitives()?;
        Ok(loader)
    }

    pub(super) fn load_buffers(&mut self, mut blob: Option<&[u8]>) -> Result<()> {
        let mut buffers = Vec::new();
        for buffer in self.document.buffers() {
            let object = named("buffer", buffer.index(), buffer.name());
            if self.is_meshopt_placeholder(&buffer, blob.is_some()) {
                buffers.push(Vec::new());
                continue;
            }
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
    pub(super) fn read_uri(&self, uri: &str, object: &str) -> Result<Vec<u8>> {
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

    pub(super) fn resolve_file(&self, uri: &str, object: &str) -> Result<PathBuf> {
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
}

/// The validation paths (`accessors[i].bufferView`) of the accessors that primitives with
/// `KHR_draco_mesh_compression` fill from their Draco data.
fn draco_accessors(root: &gltf::json::Root) -> std::collections::HashSet<String> {
    let mut out = std::collections::HashSet::new();
    for mesh in &root.meshes {
        for primitive in &mesh.primitives {
            let compressed = primitive
                .extensions
                .as_ref()
                .and_then(|e| e.others.get("KHR_draco_mesh_compression"))
                .and_then(|e| e.get("attributes"))
                .and_then(Value::as_object);
            let Some(compressed) = compressed else {
                continue;
            };
            let mut add = |index: usize| {
                out.insert(format!("accessors[{index}].bufferView"));
            };
            if let Some(indices) = &primitive.indices {
                add(indices.value());
            }
            for (semantic, accessor) in &primitive.attributes {
                if let gltf::json::validation::Checked::Valid(semantic) = semantic {
                    if compressed.contains_key(&semantic.to_string()) {
                        add(accessor.value());
                    }
                }
            }
        }
    }
    out
}

/// Why Photon does not read a known extension a file may require.
fn unsupported_reason(name: &str) -> Option<&'static str> {
    Some(match name {
        "KHR_materials_dispersion" => {
            "not rendered: Blender 4.5 and Cycles have no dispersion, and Blender's importer does \
             not read it"
        }
        _ => return None,
    })
}

/// "node 3 'Cube'" or "node 3".
pub(super) fn named(kind: &str, index: usize, name: Option<&str>) -> String {
    match name {
        Some(n) => format!("{kind} {index} '{n}'"),
        None => format!("{kind} {index}"),
    }
}

pub(super) fn json_vec3(value: &Value) -> Option<Vec3> {
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

/// Every mesh attribute must name an existing accessor. Checked before the gltf crate's
/// validation, which indexes the POSITION accessor without checking (and would panic).
pub(super) fn check_attribute_indices(
    root: &gltf::json::Root,
) -> std::result::Result<(), (String, String)> {
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
pub(super) type GlbChunk<'a> = (u32, &'a [u8], usize);

/// Split a binary glTF into its JSON chunk and optional BIN chunk, checking every length.
pub(super) fn split_glb(bytes: &[u8]) -> std::result::Result<(&[u8], Option<&[u8]>), String> {
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

/// Point each texture that has `EXT_texture_webp` at the extension's WebP image, and each
/// texture with `KHR_texture_basisu` and no `source` of its own at the extension's KTX2 image
/// (with a PNG or JPEG `source` as well, that is read, as Blender's importer reads it), all of
/// which Photon decodes, so that the rest of the loader reads `source` only. A texture with
/// neither a `source` nor an extension is left for validation to refuse.
pub(super) fn use_extension_sources(
    root: &mut gltf::json::Root,
) -> std::result::Result<(), (String, String)> {
    let images = root.images.len();
    for (index, texture) in root.textures.iter_mut().enumerate() {
        let Some(others) = texture.extensions.as_ref().map(|e| &e.others) else {
            continue;
        };
        let has_source = texture.source.value() < images;
        let extension = if others.contains_key("EXT_texture_webp") {
            "EXT_texture_webp"
        } else if others.contains_key("KHR_texture_basisu") && !has_source {
            "KHR_texture_basisu"
        } else {
            continue;
        };
        let object = || format!("texture {index} ({extension})");
        let source = others[extension]
            .get("source")
            .and_then(|s| s.as_u64())
            .ok_or_else(|| {
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

/// What the animations set on one node at the chosen moment (`animation`).
#[derive(Clone, Debug, Default)]
pub(super) struct NodePose {
    pub(super) translation: Option<Vec3>,
    pub(super) rotation: Option<Quat>,
    pub(super) scale: Option<Vec3>,
    pub(super) weights: Option<Vec<f32>>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn glb_headers_are_checked() {
        assert!(split_glb(b"glTF").is_err());
        let mut glb = b"glTF".to_vec();
        glb.extend(2u32.to_le_bytes());
        glb.extend(1000u32.to_le_bytes());
        assert!(split_glb(&glb).unwrap_err().contains("truncated"));
    }
}
