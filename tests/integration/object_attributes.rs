//! What node trees read of objects and meshes beyond their geometry: `PHOTON_object`'s "info"
//! (Object Info: location, colour, pass index, random id; the Object and Instancer attributes'
//! values) on flattened meshes and on instances,
//! and the named vertex attributes (`_NAME`) a material's Attribute nodes read, per slot.

use crate::support::gltf;
use photon::math::{Vec3, Vec4};
use photon::scene::gltf::{load_slice, LoadOptions};
use photon::scene::Scene;
use photon::shader::ObjectInfo;
use serde_json::{json, Value};

/// One triangle with a float attribute `_HEIGHT` (0, 1, 2 at its corners) and a material whose
/// tree reads the attributes "height" and "missing" and Object Info, placed by `nodes`.
fn triangle_glb(nodes: &[Value]) -> Vec<u8> {
    let floats = |v: &[f32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let mut bin = floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    bin.extend(floats(&[0.0, 1.0, 2.0]));
    let tree = json!({"nodes": [
        {"name": "H", "type": "ShaderNodeAttribute", "attribute_name": "height"},
        {"name": "M", "type": "ShaderNodeAttribute", "attribute_name": "missing"},
        {"name": "O", "type": "ShaderNodeObjectInfo"},
        {"name": "E", "type": "ShaderNodeEmission", "inputs": {
            "Color": {"node": 2, "output": "Color"}, "Strength": {"node": 0, "output": "Fac"}}}
    ], "output": {"node": 3, "output": "Emission"}});
    let mut doc = json!({
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": []}],
        "extensionsUsed": ["PHOTON_material_nodes", "PHOTON_object"],
        "materials": [{"extensions": {"PHOTON_material_nodes": tree}}],
        "buffers": [{"byteLength": bin.len()}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36},
                        {"buffer": 0, "byteOffset": 36, "byteLength": 12}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
             "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0]},
            {"bufferView": 1, "componentType": 5126, "count": 3, "type": "SCALAR"}],
        "meshes": [{"primitives": [
            {"attributes": {"POSITION": 0, "_HEIGHT": 1}, "material": 0}]}],
        "nodes": nodes,
    });
    doc["scenes"][0]["nodes"] = json!((0..nodes.len()).collect::<Vec<_>>());
    gltf::glb(&doc, &bin)
}

fn info(random_id: u32, pass_index: u32) -> Value {
    json!({"PHOTON_object": {"info": {"location": [1.0, 2.0, 3.0],
        "color": [0.5, 0.25, 1.0, 0.75], "pass_index": pass_index, "random_id": random_id}}})
}

fn load(glb: &[u8]) -> photon::error::Result<Scene> {
    load_slice(glb, "object.glb", &LoadOptions::default())
}

#[test]
fn object_attributes_object_info_reaches_meshes_and_each_instance() {
    let flat = load(&triangle_glb(&[
        json!({"mesh": 0, "extensions": info(u32::MAX, 4)}),
    ]))
    .expect("loads");
    let object = flat.meshes[0].object_info;
    assert_eq!(object.location, Vec3::new(1.0, 2.0, 3.0));
    assert_eq!(object.color, Vec4::new(0.5, 0.25, 1.0, 0.75));
    assert_eq!((object.pass_index, object.random), (4.0, 1.0));
    let placed = load(&triangle_glb(&[
        json!({"mesh": 0, "extensions": info(0, 1)}),
        json!({"mesh": 0, "translation": [3.0, 0.0, 0.0], "extensions": info(1 << 31, 2)}),
    ]))
    .expect("loads");
    let infos: Vec<ObjectInfo> = placed.instances.iter().map(|i| i.object_info).collect();
    assert_eq!(infos.len(), 2);
    assert_eq!((infos[0].pass_index, infos[0].random), (1.0, 0.0));
    assert_eq!((infos[1].pass_index, infos[1].random), (2.0, 0.5));
}

#[test]
fn object_attributes_named_attributes_fill_the_trees_slots() {
    let scene = load(&triangle_glb(&[json!({"mesh": 0})])).expect("loads");
    let slots = &scene.meshes[0].node_attributes.slots;
    assert_eq!(slots.len(), 2, "height, then missing");
    let height = slots[0].as_ref().expect("_HEIGHT is read for 'height'");
    assert_eq!(height[2], Vec4::new(2.0, 2.0, 2.0, 1.0));
    assert!(slots[1].is_none());
    let at = scene.meshes[0].node_attributes.at([0, 1, 2], 0.25, 0.5);
    assert_eq!(at.get(0), Some(Vec4::new(1.25, 1.25, 1.25, 1.0)));
}

#[test]
fn object_attributes_a_bad_random_id_is_refused_naming_the_field() {
    let bad = json!({"mesh": 0, "extensions": {"PHOTON_object": {"info": {"random_id": -3}}}});
    let message = load(&triangle_glb(&[bad]))
        .expect_err("refused")
        .to_string();
    assert!(message.contains("random_id"), "{message}");
}

#[test]
fn object_attributes_per_object_values_reach_each_instance_and_a_bad_one_is_refused() {
    let with = |attributes: Value, x: f32| {
        json!({"mesh": 0, "translation": [x, 0.0, 0.0],
               "extensions": {"PHOTON_object": {"info": {"attributes": attributes}}}})
    };
    let placed = load(&triangle_glb(&[
        with(json!([[0.5, 0.25, 1.0, 1.0]]), 0.0),
        with(json!([[0.0, 0.0, 0.0, 0.0], [2.0, 3.0, 4.0, 1.0]]), 3.0),
    ]))
    .expect("loads");
    let values: Vec<[Vec4; 2]> = placed
        .instances
        .iter()
        .map(|i| [i.object_info.attributes[0], i.object_info.attributes[1]])
        .collect();
    assert_eq!(
        values,
        [
            [Vec4::new(0.5, 0.25, 1.0, 1.0), Vec4::ZERO],
            [Vec4::ZERO, Vec4::new(2.0, 3.0, 4.0, 1.0)]
        ]
    );
    let message = load(&triangle_glb(&[with(json!([[1.0, "red", 0.0, 1.0]]), 0.0)]))
        .expect_err("refused")
        .to_string();
    assert!(message.contains("attributes"), "{message}");
}
