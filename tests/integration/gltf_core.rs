//! Integration tests of the glTF loader on files other tools write: the Khronos extensions read
//! as Blender's importer reads them (unlit, specular-glossiness, material variants, animation
//! pointers tolerated, GPU instancing, samplers' filters, quantized and sparse accessors), and
//! the clear refusal of an unknown required extension. Each test
//! writes its file here with `support::gltf::Doc`; `tests/blender/test_gltf_import.py` renders
//! the same kinds of file against Cycles.

use crate::gltf_loader::png_bytes;
use crate::support::binary::{render_tiny, temp_dir};
use crate::support::gltf::{triangle_doc, Doc};
use photon::math::{Vec3, Vec4};
use photon::scene::gltf::{load_slice, LoadOptions};
use photon::scene::Scene;
use serde_json::json;

/// `doc` with `materials`, its first primitive showing material 0.
fn with_materials(mut doc: Doc, materials: serde_json::Value) -> Doc {
    doc.json["meshes"][0]["primitives"][0]["material"] = json!(0);
    doc.json["materials"] = materials;
    doc
}

fn load_with(doc: &Doc, options: &LoadOptions) -> photon::error::Result<Scene> {
    load_slice(&doc.glb(), "core.glb", options)
}

fn load(doc: &Doc) -> Scene {
    load_with(doc, &LoadOptions::default()).expect("the file loads")
}

fn require(doc: &mut Doc, extension: &str) {
    for key in ["extensionsUsed", "extensionsRequired"] {
        let list = doc
            .json
            .as_object_mut()
            .unwrap()
            .entry(key)
            .or_insert(json!([]));
        list.as_array_mut().unwrap().push(json!(extension));
    }
}

#[test]
fn unlit_is_a_node_tree_the_camera_sees_as_emission() {
    let mut doc = with_materials(
        triangle_doc(),
        json!([{"name": "Flat", "extensions": {"KHR_materials_unlit": {}},
                "pbrMetallicRoughness": {"baseColorFactor": [0.2, 0.4, 0.6, 0.5]},
                "alphaMode": "BLEND"}]),
    );
    require(&mut doc, "KHR_materials_unlit");
    let scene = load(&doc);
    let material = &scene.materials[0];
    let program = material.nodes.as_ref().expect("a node tree");
    assert!(program.emits);
    // The alpha test still reads the base colour's alpha.
    assert_eq!(material.base_color, Vec4::new(0.2, 0.4, 0.6, 0.5));
}

#[test]
fn specular_glossiness_is_a_principled_tree_with_the_diffuse_colour() {
    let mut doc = with_materials(
        triangle_doc(),
        json!([{"name": "SG", "extensions": {"KHR_materials_pbrSpecularGlossiness": {
            "diffuseFactor": [0.5, 0.25, 0.125, 1.0], "specularFactor": [0.1, 0.1, 0.1],
            "glossinessFactor": 0.25}}}]),
    );
    require(&mut doc, "KHR_materials_pbrSpecularGlossiness");
    let scene = load(&doc);
    let material = &scene.materials[0];
    assert!(material.nodes.is_some());
    assert!(!material.nodes.as_ref().unwrap().emits);
    assert_eq!(material.base_color, Vec4::new(0.5, 0.25, 0.125, 1.0));

    // A malformed factor is refused by name.
    doc.json["materials"][0]["extensions"]["KHR_materials_pbrSpecularGlossiness"]
        ["specularFactor"] = json!([1.0]);
    let error = load_with(&doc, &LoadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(error.contains("specularFactor"), "{error}");
}

fn variants_doc() -> Doc {
    let mut doc = with_materials(
        triangle_doc(),
        json!([{"name": "Red"}, {"name": "Blue"}, {"name": "Gold"}]),
    );
    require(&mut doc, "KHR_materials_variants");
    doc.json["extensions"] = json!({"KHR_materials_variants": {"variants": [
        {"name": "Blue"}, {"name": "Gold"}, {"name": "Plain"}]}});
    doc.json["meshes"][0]["primitives"][0]["extensions"] = json!({"KHR_materials_variants":
        {"mappings": [{"material": 1, "variants": [0]}, {"material": 2, "variants": [1]}]}});
    doc
}

#[test]
fn material_variants_default_to_the_primitives_own_material() {
    let doc = variants_doc();
    let shown = |variant: Option<&str>| {
        let options = LoadOptions {
            variant: variant.map(str::to_string),
            ..LoadOptions::default()
        };
        let scene = load_with(&doc, &options).expect("the file loads");
        scene.materials[scene.meshes[0].material as usize]
            .name
            .clone()
    };
    assert_eq!(shown(None), "Red");
    assert_eq!(shown(Some("Blue")), "Blue");
    assert_eq!(shown(Some("Gold")), "Gold");
    // A variant the primitive does not map keeps its own material.
    assert_eq!(shown(Some("Plain")), "Red");
    let options = LoadOptions {
        variant: Some("Green".into()),
        ..LoadOptions::default()
    };
    let error = load_with(&doc, &options).unwrap_err().to_string();
    assert!(
        error.contains("'Green'") && error.contains("'Blue', 'Gold', 'Plain'"),
        "{error}"
    );
}

#[test]
fn animation_pointer_channels_are_tolerated() {
    let mut doc = triangle_doc();
    doc.json["extensionsUsed"] = json!(["KHR_animation_pointer"]);
    let times = doc.floats(&[0.0, 1.0], "SCALAR");
    let values = doc.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0], "VEC3");
    doc.json["animations"] = json!([{"samplers": [{"input": times, "output": values}],
        "channels": [{"sampler": 0, "target": {"path": "pointer", "extensions":
            {"KHR_animation_pointer": {"pointer": "/nodes/0/translation"}}}}]}]);
    let scene = load(&doc);
    assert_eq!(scene.meshes.len(), 1);
}

#[test]
fn diffuse_transmission_is_read_and_dispersion_is_named() {
    let mut doc = with_materials(
        triangle_doc(),
        json!([{"name": "Leaf", "extensions": {
            "KHR_materials_diffuse_transmission": {
                "diffuseTransmissionFactor": 0.25,
                "diffuseTransmissionColorFactor": [1.0, 0.5, 0.25]},
            "KHR_materials_dispersion": {"dispersion": 0.3}}}]),
    );
    require(&mut doc, "KHR_materials_diffuse_transmission");
    doc.json["extensionsUsed"]
        .as_array_mut()
        .unwrap()
        .push(json!("KHR_materials_dispersion"));
    let scene = load(&doc);
    let material = &scene.materials[0];
    assert_eq!(material.diffuse_transmission, 0.25);
    assert_eq!(
        material.diffuse_transmission_color,
        Vec3::new(1.0, 0.5, 0.25)
    );
    assert!(
        scene
            .warnings
            .iter()
            .any(|w| w.contains("KHR_materials_dispersion") && w.contains("not rendered")),
        "{:?}",
        scene.warnings
    );
    // Required, dispersion is refused with its reason.
    require(&mut doc, "KHR_materials_dispersion");
    let err = load_with(&doc, &LoadOptions::default()).unwrap_err();
    assert!(err.to_string().contains("no dispersion"), "{err}");
}

#[test]
fn an_unknown_required_extension_is_named_with_exit_code_2() {
    // An unknown one, and a known one Photon does not render, with its reason.
    for (extension, reason) in [
        ("EXT_made_up_compression", ""),
        ("KHR_materials_dispersion", "not rendered"),
    ] {
        let mut doc = triangle_doc();
        require(&mut doc, extension);
        let dir = temp_dir("gltf_core_unknown");
        let path = dir.join("unknown.glb");
        std::fs::write(&path, doc.glb()).unwrap();
        let out = render_tiny(&path, &dir);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{stderr}");
        assert!(
            stderr.contains(extension) && stderr.contains(reason),
            "{stderr}"
        );
    }
}

/// `doc`'s first node given EXT_mesh_gpu_instancing with these TRANSLATION and SCALE rows.
fn gpu_instanced(translations: &[f32], scales: &[f32]) -> Doc {
    let mut doc = triangle_doc();
    require(&mut doc, "EXT_mesh_gpu_instancing");
    let t = doc.floats(translations, "VEC3");
    let s = doc.floats(scales, "VEC3");
    doc.json["nodes"][0]["translation"] = json!([0.0, 0.0, -1.0]);
    doc.json["nodes"][0]["extensions"] =
        json!({"EXT_mesh_gpu_instancing": {"attributes": {"TRANSLATION": t, "SCALE": s}}});
    doc
}

#[test]
fn gpu_instances_place_one_prototype() {
    let doc = gpu_instanced(
        &[0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 3.0, 0.0],
        &[1.0, 1.0, 1.0, -1.0, 1.0, 1.0, 2.0, 2.0, 2.0],
    );
    let scene = load(&doc);
    assert!(scene.meshes.is_empty(), "the node's own mesh is not drawn");
    assert_eq!(scene.prototypes.len(), 1);
    assert_eq!(scene.instances.len(), 3);
    let placed: Vec<Vec3> = scene
        .instances
        .iter()
        .map(|i| i.to_world.transform_point3(Vec3::X))
        .collect();
    // Node × instance: the instance's scale and translation, then the node's translation.
    assert_eq!(placed[0], Vec3::new(1.0, 0.0, -1.0));
    assert_eq!(placed[1], Vec3::new(1.0, 0.0, -1.0));
    assert_eq!(placed[2], Vec3::new(2.0, 3.0, -1.0));
    assert!(scene.instances[1].mirrored && !scene.instances[2].mirrored);

    let uneven = gpu_instanced(&[0.0; 6], &[1.0; 3]);
    let error = load_with(&uneven, &LoadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("EXT_mesh_gpu_instancing") && error.contains("SCALE"),
        "{error}"
    );
}

#[test]
fn samplers_filter_by_nearest_texels_as_blenders_importer_decides() {
    // (minFilter, magFilter) → nearest texels?
    let cases = [
        (None, None, false),
        (Some(9728), None, true),
        (None, Some(9728), true),
        (Some(9984), Some(9728), true),
        (Some(9729), Some(9728), false),
        (Some(9728), Some(9729), false),
    ];
    for (min, mag, nearest) in cases {
        let mut doc = with_materials(
            triangle_doc(),
            json!([{"pbrMetallicRoughness":
            {"baseColorTexture": {"index": 0}}}]),
        );
        let rgba = [200u8, 100, 50, 255];
        let png = png_bytes(1, 1, png::ColorType::Rgba, png::BitDepth::Eight, &rgba);
        let view = doc.view(&png);
        let mut sampler = json!({});
        if let Some(min) = min {
            sampler["minFilter"] = json!(min);
        }
        if let Some(mag) = mag {
            sampler["magFilter"] = json!(mag);
        }
        doc.json["images"] = json!([{"bufferView": view, "mimeType": "image/png"}]);
        doc.json["samplers"] = json!([sampler]);
        doc.json["textures"] = json!([{"source": 0, "sampler": 0}]);
        let scene = load(&doc);
        assert_eq!(scene.textures[0].bilinear, !nearest, "{min:?} {mag:?}");
    }
}

#[test]
fn quantized_second_uv_sets_and_sparse_positions_are_read() {
    let mut doc = triangle_doc();
    require(&mut doc, "KHR_mesh_quantization");
    // TEXCOORD_0 as floats, TEXCOORD_1 as normalized unsigned shorts.
    let uv0 = doc.floats(&[0.0; 6], "VEC2");
    let uv1 = doc.integers(&[0, 0, 65535, 0, 0, 32768], 5123, "VEC2", true);
    let attributes = &mut doc.json["meshes"][0]["primitives"][0]["attributes"];
    attributes["TEXCOORD_0"] = json!(uv0);
    attributes["TEXCOORD_1"] = json!(uv1);
    // The third vertex moved by a sparse substitution.
    let indices = doc.view(&[2u8]);
    let values: Vec<u8> = [0.0f32, 2.0, 0.0]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let values = doc.view(&values);
    doc.json["accessors"][0]["sparse"] = json!({"count": 1,
        "indices": {"bufferView": indices, "componentType": 5121},
        "values": {"bufferView": values}});
    doc.json["accessors"][0]["max"] = json!([1.0, 2.0, 0.0]);
    let scene = load(&doc);
    let mesh = &scene.meshes[0];
    assert_eq!(mesh.positions[2], Vec3::new(0.0, 2.0, 0.0));
    assert_eq!(mesh.extra_uvs[0][1].x, 1.0);
    assert!((mesh.extra_uvs[0][2].y - 0.5).abs() < 1e-4);
}

/// The triangle with two morph targets (the first vertex moved along +Z, the second along
/// +Y) at mesh weights 0.5 and 0.25, and a joint "Joint" 2 m along X its third vertex follows.
fn deformed_doc() -> Doc {
    let mut doc = triangle_doc();
    let up = doc.floats(&[0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], "VEC3");
    let side = doc.floats(&[0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0], "VEC3");
    doc.json["meshes"][0]["weights"] = json!([0.5, 0.25]);
    doc.json["meshes"][0]["primitives"][0]["targets"] =
        json!([{"POSITION": up}, {"POSITION": side}]);
    doc
}

fn skinned_doc() -> Doc {
    let mut doc = triangle_doc();
    let joints = doc.integers(&[0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0], 5121, "VEC4", false);
    let weights = doc.floats(&[1.0, 0.0, 0.0, 0.0].repeat(3), "VEC4");
    let attributes = &mut doc.json["meshes"][0]["primitives"][0]["attributes"];
    attributes["JOINTS_0"] = json!(joints);
    attributes["WEIGHTS_0"] = json!(weights);
    let still = doc.node(json!({"name": "Still"}), true);
    let joint = doc.node(
        json!({"name": "Joint", "translation": [2.0, 0.0, 0.0]}),
        true,
    );
    doc.json["skins"] = json!([{"joints": [still, joint]}]);
    doc.json["nodes"][0]["skin"] = json!(0);
    // The skinned node's own transform is ignored.
    doc.json["nodes"][0]["translation"] = json!([0.0, 0.0, 7.0]);
    doc
}

#[test]
fn morph_targets_take_the_meshs_weights_and_skins_their_joints() {
    let scene = load(&deformed_doc());
    let positions = &scene.meshes[0].positions;
    assert_eq!(positions[0], Vec3::new(0.0, 0.0, 0.5));
    assert_eq!(positions[1], Vec3::new(1.0, 0.25, 0.0));

    let scene = load(&skinned_doc());
    let positions = &scene.meshes[0].positions;
    assert_eq!(positions[0], Vec3::ZERO);
    assert_eq!(positions[2], Vec3::new(2.0, 1.0, 0.0));
}

#[test]
fn time_poses_linear_step_cubic_and_pointer_channels() {
    let mut doc = deformed_doc();
    let times = doc.floats(&[0.0, 1.0], "SCALAR");
    let moves = doc.floats(&[0.0, 0.0, 0.0, 4.0, 0.0, 0.0], "VEC3");
    let steps = doc.floats(&[1.0, 1.0, 1.0, 3.0, 3.0, 3.0], "VEC3");
    let weights = doc.floats(&[0.0, 0.0, 1.0, 0.0], "SCALAR");
    // CUBICSPLINE keys (in-tangent, value, out-tangent): 0 with slope 0, then 2 with slope 0.
    let mut cubic_keys = [0.0; 18];
    cubic_keys[13] = 2.0;
    let cubic = doc.floats(&cubic_keys, "VEC3");
    let mut samplers = vec![
        json!({"input": times, "output": moves}),
        json!({"input": times, "output": steps, "interpolation": "STEP"}),
        json!({"input": times, "output": weights}),
    ];
    let mut channels = vec![
        json!({"sampler": 0, "target": {"path": "pointer", "extensions":
            {"KHR_animation_pointer": {"pointer": "/nodes/0/translation"}}}}),
        json!({"sampler": 1, "target": {"node": 0, "path": "scale"}}),
        json!({"sampler": 2, "target": {"node": 0, "path": "weights"}}),
    ];
    samplers.push(json!({"input": times, "output": cubic, "interpolation": "CUBICSPLINE"}));
    channels.push(json!({"sampler": 3, "target": {"node": 1, "path": "translation"}}));
    doc.json["animations"] = json!([{"samplers": samplers, "channels": channels}]);
    let at = |time: Option<f32>| {
        let options = LoadOptions {
            time,
            ..LoadOptions::default()
        };
        load_with(&doc, &options).expect("the file loads")
    };
    // Without a time: the nodes' own values.
    let scene = at(None);
    assert_eq!(scene.meshes[0].positions[0], Vec3::new(0.0, 0.0, 0.5));
    let scene = at(Some(0.5));
    let positions = &scene.meshes[0].positions;
    // Translated by 2 (linear), scaled by 1 (a step holds its key), weights (0.5, 0).
    assert_eq!(positions[0], Vec3::new(2.0, 0.0, 0.5));
    assert_eq!(positions[1], Vec3::new(3.0, 0.0, 0.0));
    // Hermite halfway between 0 and 2 with flat tangents: 1.
    let camera = scene.camera.to_world.translation;
    assert!((camera.y - 1.0).abs() < 1e-6, "{camera:?}");
    // After the last key the last value holds.
    let scene = at(Some(9.0));
    assert_eq!(scene.meshes[0].positions[1], Vec3::new(4.0 + 3.0, 0.0, 0.0));
}
