//! True displacement when a scene is loaded (`photon::scene::displace`): a material's
//! `displace` tree moves the vertices where an analytic displacement puts them, in world and in
//! object space, on a mesh placed once and on a prototype placed by instances, and a vertex
//! shared by a displaced and an undisplaced primitive moves once, for both.

use crate::support::gltf::Doc;
use photon::math::Vec3;
use photon::scene::gltf::{load_slice, LoadOptions};
use photon::scene::Scene;
use serde_json::{json, Value};

/// An Emission surface whose vertices move by a Displacement node: Height `height` (a tree
/// input: a constant or a link), Midlevel 0, Scale `scale`, in `space`.
fn displaced_material(height: Value, scale: f32, space: &str, extra_nodes: Vec<Value>) -> Value {
    let mut nodes = extra_nodes;
    let at = nodes.len();
    nodes.push(
        json!({"name": "D", "type": "ShaderNodeDisplacement", "space": space,
                      "inputs": {"Height": height, "Midlevel": 0.0, "Scale": scale}}),
    );
    json!({"name": "Displaced", "extensions": {"PHOTON_material_nodes": {
        "nodes": [{"name": "E", "type": "ShaderNodeEmission",
                   "inputs": {"Color": [1.0, 1.0, 1.0, 1.0], "Strength": 1.0}}],
        "output": {"node": 0, "output": "Emission"},
        "displace": {"nodes": nodes, "output": {"node": at, "output": "Displacement"}}
    }}})
}

/// A Displacement Height that is the world position's x (Blender's x is glTF's x).
fn height_is_x() -> (Value, Vec<Value>) {
    (
        json!({"node": 1, "output": "X"}),
        vec![
            json!({"name": "G", "type": "ShaderNodeNewGeometry"}),
            json!({"name": "X", "type": "ShaderNodeSeparateXYZ",
                   "inputs": {"Vector": {"node": 0, "output": "Position"}}}),
        ],
    )
}

/// A 2 × 2 grid of quads over [−1, 1]² in glTF's XZ plane facing +Y (Blender's XY plane
/// facing +Z): positions, normals, indices.
fn grid() -> (Vec<f32>, Vec<f32>, Vec<u32>) {
    let mut positions = Vec::new();
    for k in 0..3 {
        for i in 0..3 {
            positions.extend([i as f32 - 1.0, 0.0, k as f32 - 1.0]);
        }
    }
    let normals = [0.0, 1.0, 0.0].repeat(9);
    let mut indices = Vec::new();
    for k in 0..2 {
        for i in 0..2 {
            let a = 3 * k + i;
            indices.extend([a, a + 3, a + 1, a + 1, a + 3, a + 4]);
        }
    }
    (positions, normals, indices)
}

fn load(doc: &mut Doc, materials: Vec<Value>) -> Scene {
    doc.json["materials"] = json!(materials);
    doc.json["extensionsUsed"] = json!(["PHOTON_material_nodes"]);
    doc.camera("Camera", "CameraData", [0.0, 3.0, 6.0]);
    let scene = load_slice(&doc.glb(), "displaced.glb", &LoadOptions::default()).expect("loads");
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    scene
}

fn close(a: f32, b: f32) -> bool {
    (a - b).abs() < 1e-5
}

#[test]
fn a_plane_rises_by_the_height_of_its_world_position_and_takes_its_new_normal() {
    let (positions, normals, indices) = grid();
    let mut doc = Doc::new();
    let mesh = doc.mesh("Grid", &positions, &normals, &indices);
    doc.json["meshes"][mesh]["primitives"][0]["material"] = json!(0);
    // Placed at x + 1 (world): the height reads the world position.
    doc.node(
        json!({"name": "Grid", "mesh": mesh, "translation": [1.0, 0.0, 0.0]}),
        true,
    );
    let (height, nodes) = height_is_x();
    let scene = load(
        &mut doc,
        vec![displaced_material(height, 0.5, "WORLD", nodes)],
    );
    let plane = &scene.meshes[0];
    // Every vertex at y = x / 2 (the height along Blender's +Z, glTF's +Y).
    for p in &plane.positions {
        assert!(close(p.y, 0.5 * p.x), "{p}");
    }
    let moved: Vec<f32> = plane.positions.iter().map(|p| p.y).collect();
    assert!(moved.iter().any(|&y| close(y, 1.0)), "{moved:?}");
    // Flat faces take the tilted plane's normal; Generated coordinates keep the flat grid.
    let tilted = Vec3::new(-0.5, 1.0, 0.0).normalize();
    for n in &plane.normals {
        assert!((*n - tilted).length() < 1e-5, "{n}");
    }
    assert!(plane.undisplaced.iter().all(|p| p.y == 0.0));
}

#[test]
fn instances_share_a_prototype_displaced_in_its_first_instances_object_space() {
    // The mesh placed twice, the first copy stretched 2× along glTF's y (Blender's z): an
    // object-space displacement of 0.25 is 0.25 in the stored (object) positions, a
    // world-space one 0.25 in the world, so 0.125 in the object.
    for (space, stored) in [("OBJECT", 0.25), ("WORLD", 0.125)] {
        let (positions, normals, indices) = grid();
        let mut doc = Doc::new();
        let mesh = doc.mesh("Grid", &positions, &normals, &indices);
        doc.json["meshes"][mesh]["primitives"][0]["material"] = json!(0);
        doc.node(
            json!({"name": "A", "mesh": mesh, "scale": [1.0, 2.0, 1.0]}),
            true,
        );
        doc.node(
            json!({"name": "B", "mesh": mesh, "translation": [3.0, 0.0, 0.0]}),
            true,
        );
        let scene = load(
            &mut doc,
            vec![displaced_material(json!(1.0), 0.25, space, vec![])],
        );
        assert_eq!((scene.prototypes.len(), scene.instances.len()), (1, 2));
        for p in &scene.prototypes[0].positions {
            assert!(close(p.y, stored), "{space}: {p}");
        }
    }
}

#[test]
fn a_vertex_on_a_border_between_materials_moves_once_for_both() {
    // Two quads side by side, each its own primitive with its own copies of the shared edge's
    // vertices: the left one displaced by 0.3, the right one not.
    let left: [f32; 12] = [
        -1.0, 0.0, -1.0, 0.0, 0.0, -1.0, 0.0, 0.0, 1.0, -1.0, 0.0, 1.0,
    ];
    let right: [f32; 12] = [0.0, 0.0, -1.0, 1.0, 0.0, -1.0, 1.0, 0.0, 1.0, 0.0, 0.0, 1.0];
    let normals = [0.0, 1.0, 0.0].repeat(4);
    let quad = [0, 3, 1, 1, 3, 2];
    let mut doc = Doc::new();
    let mut primitives = Vec::new();
    for (k, positions) in [left, right].iter().enumerate() {
        primitives.push(json!({"attributes": {
            "POSITION": doc.floats(positions, "VEC3"),
            "NORMAL": doc.floats(&normals, "VEC3")},
            "indices": doc.indices(&quad), "material": k}));
    }
    let mesh = doc.push("meshes", json!({"name": "Two", "primitives": primitives}));
    doc.node(json!({"name": "Two", "mesh": mesh}), true);
    let plain = json!({"name": "Plain"});
    let scene = load(
        &mut doc,
        vec![displaced_material(json!(1.0), 0.3, "WORLD", vec![]), plain],
    );
    let (displaced, beside) = (&scene.meshes[0], &scene.meshes[1]);
    assert!(displaced.positions.iter().all(|p| close(p.y, 0.3)));
    for p in &beside.positions {
        let expected = if p.x == 0.0 { 0.3 } else { 0.0 };
        assert!(close(p.y, expected), "{p}");
    }
}

#[test]
fn displacement_and_bump_shades_flat_faces_smooth_only_where_the_material_says_so() {
    // "Displacement and Bump" (a `displacement` tree beside `displace`) over the tilting
    // height: Blender 4's Cycles keeps a flat face's displaced normal, Blender 5's shades it
    // by its vertices' normals from before the move (the flat grid's).
    let tilted = Vec3::new(-0.5, 1.0, 0.0).normalize();
    for (smooth, expected) in [(false, tilted), (true, Vec3::Y)] {
        let (positions, normals, indices) = grid();
        let mut doc = Doc::new();
        let mesh = doc.mesh("Grid", &positions, &normals, &indices);
        doc.json["meshes"][mesh]["primitives"][0]["material"] = json!(0);
        doc.node(json!({"name": "Grid", "mesh": mesh}), true);
        let (height, nodes) = height_is_x();
        let mut material = displaced_material(height, 0.5, "WORLD", nodes);
        let ext = &mut material["extensions"]["PHOTON_material_nodes"];
        ext["displacement"] = json!({
            "nodes": [{"name": "G", "type": "ShaderNodeNewGeometry"}],
            "output": {"node": 0, "output": "Normal"}});
        ext["displace"]["smooth_flat_faces"] = json!(smooth);
        let scene = load(&mut doc, vec![material]);
        let plane = &scene.meshes[0];
        assert!(plane.positions.iter().all(|p| close(p.y, 0.5 * p.x)));
        for &v in plane.indices.iter().flatten() {
            let n = plane.normals[v as usize];
            assert!((n - expected).length() < 1e-5, "smooth {smooth}: {n}");
        }
    }
}
