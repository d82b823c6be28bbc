//! glTF materials become Principled materials as Blender's importer reads them: the core
//! metallic-roughness model and the KHR_materials extensions (transmission, IOR, volume,
//! specular, clearcoat, sheen, anisotropy, iridescence, diffuse transmission), texture references with
//! KHR_texture_transform, and Photon's subsurface and node-tree extensions.

use super::container::{json_vec3, Loader};
use super::extensions::read_subsurface;
use crate::error::Result;
use crate::math::{Vec2, Vec3, Vec4};
use crate::scene::{AlphaMode, Material, TextureRef, Volume};
use serde_json::Value;

impl Loader {
    pub(super) fn load_materials(&mut self) -> Result<()> {
        let document = self.document.clone();
        for material in document.materials() {
            let converted = self.convert_material(&material)?;
            self.scene.materials.push(converted);
        }
        Ok(())
    }

    /// Scene material index for a glTF material index; `None` is a primitive without a
    /// material, shown as Blender imports it. With vertex colours (`colored`) Blender's
    /// importer gives it a material of its own: a Principled BSDF (roughness 0.5) whose Base
    /// Color is the vertex colour, as glTF's base colour is multiplied by COLOR_0. Without,
    /// it leaves the object without a material, which Cycles shades with its default surface
    /// (`Loader::default_surface`).
    pub(super) fn material_index(
        &mut self,
        gltf_index: Option<usize>,
        colored: bool,
    ) -> Result<u32> {
        if let Some(i) = gltf_index {
            return Ok(i as u32);
        }
        let made = match colored {
            true => self.vertex_color_material,
            false => self.default_material,
        };
        if let Some(i) = made {
            return Ok(i);
        }
        let material = match colored {
            true => Material {
                name: "vertex colour".into(),
                metallic: 0.0,
                roughness: 0.5,
                double_sided: true,
                ..Material::default()
            },
            false => self.default_surface()?,
        };
        self.scene.materials.push(material);
        let index = (self.scene.materials.len() - 1) as u32;
        match colored {
            true => self.vertex_color_material = Some(index),
            false => self.default_material = Some(index),
        }
        Ok(index)
    }

    pub(super) fn convert_material(&mut self, material: &gltf::Material) -> Result<Material> {
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
        if self.imported_tree(material, &mut out, &object)? {
            return Ok(out);
        }
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
            out.sheen_color = self.ext_color(ext, "sheenColorFactor", Vec3::ZERO, &label)?;
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
        if let Some(ext) = material.extension_value("KHR_materials_diffuse_transmission") {
            let label = format!("{object} KHR_materials_diffuse_transmission");
            out.diffuse_transmission =
                self.ext_number(ext, "diffuseTransmissionFactor", 0.0, 0.0, 1.0, &label)?;
            out.diffuse_transmission_texture =
                self.raw_texture_info(ext.get("diffuseTransmissionTexture"), false, &label)?;
            out.diffuse_transmission_color =
                self.ext_color(ext, "diffuseTransmissionColorFactor", Vec3::ONE, &label)?;
            out.diffuse_transmission_color_texture =
                self.raw_texture_info(ext.get("diffuseTransmissionColorTexture"), true, &label)?;
        }
        if let Some(ext) = material.extension_value("KHR_materials_dispersion") {
            let label = format!("{object} KHR_materials_dispersion");
            if self.ext_number(ext, "dispersion", 0.0, 0.0, f32::MAX, &label)? > 0.0 {
                self.scene.warnings.push(format!(
                    "{label}: not rendered (Blender 4.5 and Cycles have no dispersion); the \
                     material refracts at its IOR alone"
                ));
            }
        }
        if let Some(volume) = material.volume() {
            out.thickness = volume.thickness_factor();
            out.attenuation_distance = volume.attenuation_distance();
            out.attenuation_color = Vec3::from(volume.attenuation_color());
        }
        if let Some(sss) = material.extension_value("PHOTON_material_subsurface") {
            out.subsurface = read_subsurface(sss)
                .map_err(|e| self.invalid(&format!("{object} PHOTON_material_subsurface"), e))?;
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
        // (A Volume alone may come without "nodes": glTF writers drop empty lists.)
        let described = |t: &&Value| t.get("nodes").is_some() || t.get("volume").is_some();
        if let Some(tree) = nodes_extension.filter(described) {
            let mut warnings = Vec::new();
            let tree = self.load_node_images(tree, &object)?;
            if let Some(volume) = tree.get("volume").filter(|v| !v.is_null()) {
                let volume = self.load_node_images(volume, &object)?;
                let program =
                    crate::shader::compile(&volume, self.scene.textures.len(), &mut warnings)
                        .map_err(|m| {
                            self.err(format!("{object} PHOTON_material_nodes volume"), m)
                        })?;
                out.volume = Volume::of(program);
                // The medium replaces the absorption Blender's exporter writes as
                // KHR_materials_volume.
                out.attenuation_distance = f32::INFINITY;
            }
            // A Volume without a Surface: the surface only bounds the medium (Cycles passes
            // it as a Transparent BSDF that is no bounce).
            let tree = if tree.get("volume").is_some() && tree.get("output").is_none() {
                serde_json::json!({
                    "nodes": [{"name": "Volume boundary", "type": "ShaderNodeBsdfTransparent",
                               "inputs": {"Color": [1.0, 1.0, 1.0, 1.0]}}],
                    "output": {"node": 0, "output": "BSDF"}
                })
            } else {
                tree
            };
            if let Some(list) = tree.get("warnings").and_then(Value::as_array) {
                warnings.extend(list.iter().filter_map(Value::as_str).map(str::to_string));
            }
            let label = format!("{object} PHOTON_material_nodes");
            self.install_surface_tree(&mut out, &tree, &label, warnings)?;
        }
        let uv_set_warnings = std::mem::take(&mut self.uv_set_warnings);
        self.scene.warnings.extend(uv_set_warnings);
        Ok(out)
    }

    /// Compile the node tree `tree` (a surface; `label` names it in errors) into `out`, which
    /// it then shades at every point, with the compiler's `warnings` and those given.
    pub(super) fn install_surface_tree(
        &mut self,
        out: &mut Material,
        tree: &Value,
        label: &str,
        mut warnings: Vec<String>,
    ) -> Result<()> {
        let program = crate::shader::compile(tree, self.scene.textures.len(), &mut warnings)
            .map_err(|m| self.err(label, m))?;
        for w in warnings {
            self.scene
                .warnings
                .push(format!("material '{}': {w}", out.name));
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
        // The tree's own Normal Map nodes replace the glTF normal texture (Blender's exporter
        // writes one for them), and its UV maps the glTF textures'.
        out.normal_texture = None;
        self.uv_set_warnings.clear();
        out.nodes = Some(std::sync::Arc::new(program));
        Ok(())
    }

    /// The number `key` of an extension object (`default` when absent), clamped to
    /// [lo, hi]; anything but a finite number is refused.
    pub(super) fn ext_number(
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

    /// The colour `key` of an extension object (`default` when absent): three finite numbers
    /// ≥ 0, anything else refused.
    fn ext_color(&self, ext: &Value, key: &str, default: Vec3, object: &str) -> Result<Vec3> {
        match ext.get(key) {
            None => Ok(default),
            Some(v) => json_vec3(v)
                .filter(|c| c.is_finite() && c.min_element() >= 0.0)
                .ok_or_else(|| {
                    self.err(
                        object,
                        format!("'{key}' must be three numbers ≥ 0, found {v}"),
                    )
                }),
        }
    }

    /// A textureInfo object of an extension the gltf crate does not parse: `{"index": i,
    /// "texCoord": n, "extensions": {"KHR_texture_transform": {...}}}`.
    pub(super) fn raw_texture_info(
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

    pub(super) fn warn_tex_coord(&mut self, tex_coord: u32, object: &str) {
        if tex_coord != 0 {
            self.uv_set_warnings.push(format!(
                "{object}: texture uses TEXCOORD_{tex_coord}; Photon reads UV set 0 only"
            ));
        }
    }

    pub(super) fn texture_info(
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

    pub(super) fn texture_ref(
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
}

/// KHR_texture_transform read from raw JSON (the gltf crate models it only on texture infos).
pub(super) fn raw_texture_transform(value: &Value) -> (Vec2, f32, Vec2) {
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
