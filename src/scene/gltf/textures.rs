//! glTF textures and the images behind them become the scene's textures: each glTF texture
//! once per colour space, its image read from a buffer view, a data URI or a file beside the
//! glTF file (a missing file renders magenta, as in Blender), and the images that node trees'
//! Image Texture nodes name.

use super::container::Loader;
use super::images::{decode_bytes, DecodedImage, EXR_MAGIC};
use crate::color_space::WorkingSpace;
use crate::error::{Error, Result};
use crate::math::{srgb_to_linear, Vec3};
use crate::scene::texture::{Texels, Wrap};
use crate::scene::Texture;
use serde_json::Value;

impl Loader {
    /// The scene texture for this glTF texture in this colour space, created on first use.
    pub(super) fn texture_slot(
        &mut self,
        texture: &gltf::Texture,
        srgb: bool,
        object: &str,
    ) -> Result<u32> {
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
            srgb,
            [
                convert_wrap(sampler.wrap_s()),
                convert_wrap(sampler.wrap_t()),
            ],
            !nearest_filtering(&sampler),
        );
        self.texture_slots.insert((texture.index(), srgb), slot);
        Ok(slot)
    }

    /// The bytes of glTF image `image` (a buffer view, a data URI or a file), decoded. An
    /// external image file that does not exist becomes one magenta texel, with a warning
    /// naming the image: Blender and Cycles show missing textures magenta so that they are
    /// noticed.
    pub(super) fn decode_image(&mut self, image: &gltf::Image) -> Result<DecodedImage> {
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
        decode_bytes(&encoded, label.clone(), declared_mime.or(data_mime))
            .map_err(|m| self.err(&label, m))
    }

    /// The tree of `PHOTON_material_nodes` with each Image Texture node's `image` (`{"uri":
    /// file, "colorspace": "sRGB" | "Linear Rec.709" | "Non-Color"}`, beside the glTF file) loaded as a texture
    /// of the scene and named by its index in `texture`, with the node's `extension` (REPEAT,
    /// EXTEND, CLIP, MIRROR) and `interpolation` (Closest or else bilinear) as its sampler.
    pub(super) fn load_node_images(&mut self, tree: &Value, object: &str) -> Result<Value> {
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
            // Colour images are sRGB-encoded or linear Rec.709; "Non-Color" is data.
            let colorspace = image.get("colorspace").and_then(Value::as_str);
            let color = colorspace != Some("Non-Color");
            let srgb = color && colorspace != Some("Linear Rec.709");
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
                    let label = format!("image '{uri}'");
                    decode_bytes(&bytes, label.clone(), None).map_err(|m| self.err(&label, m))?
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
            let texture = self.push_texture(decoded, srgb, color, [wrap; 2], bilinear);
            node["texture"] = Value::from(texture);
        }
        Ok(tree)
    }

    /// Add a texture of `decoded` sampled with `wrap` (s, t) and `bilinear`; its index. A
    /// `color` image (sRGB-encoded when `srgb`, else linear Rec.709) is taken into the scene's
    /// working colour space, decoded, when that is not Rec.709.
    pub(super) fn push_texture(
        &mut self,
        decoded: DecodedImage,
        srgb: bool,
        color: bool,
        wrap: [Wrap; 2],
        bilinear: bool,
    ) -> u32 {
        let space = self.scene.render_settings.working_space;
        let (texels, srgb) = if color && space != WorkingSpace::Rec709 {
            (to_working_space(decoded.texels, srgb, space), false)
        } else {
            (decoded.texels, srgb)
        };
        let texels = match texels {
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
}

/// Colour texels (sRGB-encoded bytes when `srgb`) as linear RGBA in `space`.
fn to_working_space(texels: Texels, srgb: bool, space: WorkingSpace) -> Texels {
    let decode = |c: f32| if srgb { srgb_to_linear(c) } else { c };
    let convert = |[r, g, b, a]: [f32; 4]| {
        let c = space.convert_rec709(Vec3::new(decode(r), decode(g), decode(b)));
        [c.x, c.y, c.z, a]
    };
    Texels::Linear(match texels {
        Texels::Bytes(bytes) => bytes
            .into_iter()
            .map(|t| convert(t.map(|x| x as f32 / 255.0)))
            .collect(),
        Texels::Linear(values) => values.into_iter().map(convert).collect(),
    })
}

/// Whether a texture is sampled by its nearest texel, as Blender's importer decides it: both
/// filters nearest (mipmapped or not), or one nearest and the other not given; else bilinear.
pub(super) fn nearest_filtering(sampler: &gltf::texture::Sampler) -> bool {
    use gltf::texture::{MagFilter, MinFilter};
    let min = sampler.min_filter().map(|f| {
        matches!(
            f,
            MinFilter::Nearest | MinFilter::NearestMipmapNearest | MinFilter::NearestMipmapLinear
        )
    });
    let mag = sampler.mag_filter().map(|f| f == MagFilter::Nearest);
    matches!(
        (min, mag),
        (Some(true), Some(true)) | (Some(true), None) | (None, Some(true))
    )
}

pub(super) fn convert_wrap(mode: gltf::texture::WrappingMode) -> Wrap {
    match mode {
        gltf::texture::WrappingMode::ClampToEdge => Wrap::ClampToEdge,
        gltf::texture::WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
        gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
    }
}
