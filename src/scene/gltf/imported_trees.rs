//! Materials that Blender's glTF importer turns into shader node trees of their own rather than
//! Principled inputs, built here as the same trees (`crate::shader` compiles them like
//! `PHOTON_material_nodes`), so a file renders as Cycles renders it once imported:
//! - `KHR_materials_unlit`: an Emission of the base colour seen by camera rays only, every other
//!   ray passing through (a Light Path's "Is Camera Ray" mixing a Transparent BSDF and the
//!   Emission);
//! - `KHR_materials_pbrSpecularGlossiness`: a Principled BSDF with the diffuse colour as Base
//!   Color, the specular colour as Specular Tint, IOR 1000 (a Fresnel of almost 1, so the tint
//!   is the reflectance at normal incidence) and Roughness 1 − glossiness (texture alpha ×
//!   factor), plus the emission and normal texture.
//!
//! - a primitive without a material: Blender's importer leaves its object without one, which
//!   Cycles shades with its default surface, a Diffuse BSDF of colour 0.8 (not glTF's default
//!   material, a white rough metal): `photon render` shows the file as Blender does, and as
//!   Photon shows a Blender object without a material, which Blender's exporter writes so.
//!
//! Texture references follow the importer too: an Image Texture node, through a Mapping node in
//! Blender's UV space for `KHR_texture_transform`, multiplied by its factor; base colours also
//! by the vertex colour `COLOR_0` when the file has one. Alpha stays with the material's glTF
//! alpha mode (`Material::base_color` and its texture, tested during traversal).

use super::container::Loader;
use super::materials::raw_texture_transform;
use crate::error::Result;
use crate::math::Vec4;
use crate::scene::{Material, TextureRef};
use serde_json::{json, Value};

/// A node tree under construction, in the JSON form `crate::shader::compile` reads.
#[derive(Default)]
struct Tree {
    nodes: Vec<Value>,
}

impl Tree {
    /// Add `node` (its `type` without the `ShaderNode` prefix) and return its index.
    fn add(&mut self, kind: &str, mut node: Value) -> usize {
        node["type"] = json!(format!("ShaderNode{kind}"));
        node["name"] = json!(format!("{kind} {}", self.nodes.len()));
        self.nodes.push(node);
        self.nodes.len() - 1
    }

    fn finish(self, output: usize, socket: &str) -> Value {
        json!({"nodes": self.nodes, "output": link(output, socket)})
    }
}

fn link(node: usize, output: &str) -> Value {
    json!({"node": node, "output": output})
}

/// A colour constant as a socket value.
fn rgb_value(c: Vec4) -> Value {
    json!([c.x, c.y, c.z, 1.0])
}

impl Loader {
    /// The tree Blender's importer builds for `material` when it has one of the extensions
    /// above, installed in `out` (whose base colour and texture become the extension's, for
    /// the alpha test); `false` for other materials.
    pub(super) fn imported_tree(
        &mut self,
        material: &gltf::Material,
        out: &mut Material,
        object: &str,
    ) -> Result<bool> {
        // The importer's order: unlit first.
        let tree = if material.extension_value("KHR_materials_unlit").is_some() {
            self.unlit_tree(out)
        } else if let Some(ext) = material.extension_value("KHR_materials_pbrSpecularGlossiness") {
            let label = format!("{object} KHR_materials_pbrSpecularGlossiness");
            self.specular_glossiness_tree(material, ext, out, &label)?
        } else {
            return Ok(false);
        };
        self.install_surface_tree(out, &tree, object, Vec::new())?;
        Ok(true)
    }

    /// The material of primitives without one: Cycles' default surface.
    pub(super) fn default_surface(&mut self) -> Result<Material> {
        let grey = Vec4::new(0.8, 0.8, 0.8, 1.0);
        let mut out = Material {
            name: "default surface".into(),
            base_color: grey,
            metallic: 0.0,
            ..Material::default()
        };
        let mut tree = Tree::default();
        let diffuse = tree.add(
            "BsdfDiffuse",
            json!({"inputs": {"Color": rgb_value(grey), "Roughness": 0.0}}),
        );
        let tree = tree.finish(diffuse, "BSDF");
        self.install_surface_tree(&mut out, &tree, "default surface", Vec::new())?;
        Ok(out)
    }

    /// Unlit: the base colour (factor × texture × vertex colour) as an Emission of strength 1
    /// that only camera rays see.
    fn unlit_tree(&self, out: &Material) -> Value {
        let mut tree = Tree::default();
        let color = self.factor_times_texture(
            &mut tree,
            out.base_color,
            out.base_color_texture.as_ref(),
            true,
        );
        let light_path = tree.add("LightPath", json!({}));
        let transparent = tree.add(
            "BsdfTransparent",
            json!({"inputs": {"Color": [1.0, 1.0, 1.0, 1.0]}}),
        );
        let emission = tree.add(
            "Emission",
            json!({"inputs": {"Color": color, "Strength": 1.0}}),
        );
        let mix = tree.add(
            "MixShader",
            json!({"inputs": {
                "Fac": link(light_path, "Is Camera Ray"),
                "Shader": link(transparent, "BSDF"),
                "Shader_001": link(emission, "Emission"),
            }}),
        );
        tree.finish(mix, "Shader")
    }

    /// Specular-glossiness as a Principled BSDF (see the module's description).
    fn specular_glossiness_tree(
        &mut self,
        material: &gltf::Material,
        ext: &Value,
        out: &mut Material,
        label: &str,
    ) -> Result<Value> {
        let vec4 = |key: &str, default: Vec4| -> Result<Vec4> {
            match ext.get(key) {
                None => Ok(default),
                Some(v) => numbers(v)
                    .filter(|n| n.len() == 4)
                    .map(|n| Vec4::new(n[0], n[1], n[2], n[3]))
                    .ok_or_else(|| {
                        self.err(label, format!("'{key}' must be four numbers, found {v}"))
                    }),
            }
        };
        let diffuse = vec4("diffuseFactor", Vec4::ONE)?;
        let specular = match ext.get("specularFactor") {
            None => Vec4::ONE,
            Some(v) => numbers(v)
                .filter(|n| n.len() == 3)
                .map(|n| Vec4::new(n[0], n[1], n[2], 1.0))
                .ok_or_else(|| {
                    self.err(
                        label,
                        format!("'specularFactor' must be three numbers, found {v}"),
                    )
                })?,
        };
        let glossiness = self.ext_number(ext, "glossinessFactor", 1.0, 0.0, 1.0, label)?;
        out.base_color = diffuse;
        out.base_color_texture = self.raw_texture_info(ext.get("diffuseTexture"), true, label)?;
        let mut tree = Tree::default();
        let base =
            self.factor_times_texture(&mut tree, diffuse, out.base_color_texture.as_ref(), true);
        let specular_texture = ext.get("specularGlossinessTexture");
        let specular_ref = self.raw_texture_info(specular_texture, true, label)?;
        let tint = self.factor_times_texture(&mut tree, specular, specular_ref.as_ref(), false);
        let roughness = match (&specular_ref, glossiness > 0.0) {
            (Some(texture), true) => {
                let image = texture_node(&mut tree, texture);
                let times = tree.add(
                    "Math",
                    json!({"operation": "MULTIPLY", "inputs":
                        {"Value": link(image, "Alpha"), "Value_001": glossiness}}),
                );
                let one_minus = tree.add(
                    "Math",
                    json!({"operation": "SUBTRACT", "inputs":
                        {"Value": 1.0, "Value_001": link(times, "Value")}}),
                );
                link(one_minus, "Value")
            }
            _ => json!(1.0 - glossiness),
        };
        let emissive = Vec4::from((out.emission, 1.0));
        let emissive_texture = out.emissive_texture;
        let emission =
            self.factor_times_texture(&mut tree, emissive, emissive_texture.as_ref(), false);
        let mut inputs = json!({
            "Base Color": base, "Roughness": roughness, "IOR": 1000.0, "Specular Tint": tint,
            "Emission Color": emission, "Emission Strength": 1.0, "Metallic": 0.0,
        });
        if let Some(normal) = material.normal_texture() {
            let transform = normal.extension_value("KHR_texture_transform");
            let texture = self.texture_ref(
                &normal.texture(),
                false,
                transform.map(raw_texture_transform),
                label,
            )?;
            let image = texture_node(&mut tree, &texture);
            let map = tree.add(
                "NormalMap",
                json!({"space": "TANGENT", "inputs":
                    {"Strength": normal.scale(), "Color": link(image, "Color")}}),
            );
            inputs["Normal"] = link(map, "Normal");
        }
        let principled = tree.add("BsdfPrincipled", json!({"inputs": inputs}));
        Ok(tree.finish(principled, "BSDF"))
    }

    /// `factor` × the texture's colour (when there is one) × the vertex colour (for base
    /// colours, when the file has COLOR_0): a socket value.
    fn factor_times_texture(
        &self,
        tree: &mut Tree,
        factor: Vec4,
        texture: Option<&TextureRef>,
        vertex_color: bool,
    ) -> Value {
        let mut value = rgb_value(factor);
        if let Some(texture) = texture {
            let image = texture_node(tree, texture);
            value = multiply(tree, link(image, "Color"), value);
        }
        if vertex_color && self.has_vertex_colors() {
            let colors = tree.add("VertexColor", json!({}));
            value = multiply(tree, link(colors, "Color"), value);
        }
        value
    }

    /// Whether any primitive of the file has a COLOR_0 attribute.
    fn has_vertex_colors(&self) -> bool {
        self.document.meshes().any(|m| {
            m.primitives()
                .any(|p| p.get(&gltf::Semantic::Colors(0)).is_some())
        })
    }
}

/// An Image Texture node reading `texture`'s scene texture at its UVs, transformed as
/// `TextureRef::apply` transforms them.
fn texture_node(tree: &mut Tree, texture: &TextureRef) -> usize {
    let mut node = json!({"texture": texture.texture});
    if texture.transform != TextureRef::IDENTITY {
        // The glTF transform (u, v) ↦ M·(u, v, 1) in Blender's UV space (x, y) = (u, 1 − v),
        // where Blender's importer puts its Mapping node: x' = m0 x − m1 y + m1 + m2 and
        // y' = −m3 x + m4 y + 1 − m4 − m5, each row a dot product plus its offset.
        let m = texture.transform;
        let uv = tree.add("UVMap", json!({}));
        let mut row = |a: f32, b: f32, offset: f32| {
            let dot = tree.add(
                "VectorMath",
                json!({"operation": "DOT_PRODUCT", "inputs":
                    {"Vector": link(uv, "UV"), "Vector_001": [a, b, 0.0]}}),
            );
            let sum = tree.add(
                "Math",
                json!({"operation": "ADD", "inputs": {"Value": link(dot, "Value"), "Value_001": offset}}),
            );
            link(sum, "Value")
        };
        let x = row(m[0], -m[1], m[1] + m[2]);
        let y = row(-m[3], m[4], 1.0 - m[4] - m[5]);
        let combined = tree.add("CombineXYZ", json!({"inputs": {"X": x, "Y": y, "Z": 0.0}}));
        node["inputs"] = json!({"Vector": link(combined, "Vector")});
    }
    tree.add("TexImage", node)
}

/// `a` × `b` (colours) as a Mix node in Multiply mode: a link.
fn multiply(tree: &mut Tree, a: Value, b: Value) -> Value {
    let node = tree.add(
        "Mix",
        json!({"data_type": "RGBA", "blend_type": "MULTIPLY", "inputs":
            {"Factor_Float": 1.0, "A_Color": a, "B_Color": b}}),
    );
    link(node, "Result_Color")
}

fn numbers(value: &Value) -> Option<Vec<f32>> {
    value
        .as_array()?
        .iter()
        .map(|v| v.as_f64().map(|x| x as f32))
        .collect()
}
