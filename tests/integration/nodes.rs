//! Blender node trees (`PHOTON_material_nodes`) end to end through the `photon` binary: a
//! Checker on Generated coordinates wired into an Emission shader renders the checker's colours
//! cell by cell; COLOR_0 multiplies a plain material's base colour; an invalid tree is refused
//! with exit code 2 and a message naming the material; `photon info` lists the nodes Photon
//! does not evaluate; a Ray Portal BSDF sends camera rays on along its Direction.

use crate::support::binary;
use binary::*;

use serde_json::{json, Value};
use std::f32::consts::FRAC_1_SQRT_2;
use std::path::Path;

/// A 2 × 2 plane in glTF's XZ plane facing +Y (Blender's XY plane facing +Z) with `material`,
/// vertex colours `colors` (RGBA per corner) when given, seen from above by an orthographic
/// camera that frames it exactly (image right = +X, image up = Blender +Y), under a 1 W/m² sun
/// shining straight down.
fn plane_gltf(material: Value, colors: Option<[[f32; 4]; 4]>) -> String {
    let positions: [f32; 12] = [
        -1.0, 0.0, 1.0, 1.0, 0.0, 1.0, 1.0, 0.0, -1.0, -1.0, 0.0, -1.0,
    ];
    let normals: [f32; 12] = [0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0];
    let indices: [u32; 6] = [0, 1, 2, 0, 2, 3];
    let mut bin: Vec<u8> = Vec::new();
    bin.extend(positions.iter().flat_map(|v| v.to_le_bytes()));
    bin.extend(normals.iter().flat_map(|v| v.to_le_bytes()));
    bin.extend(indices.iter().flat_map(|v| v.to_le_bytes()));
    let mut attributes = json!({"POSITION": 0, "NORMAL": 1});
    let mut views = vec![
        json!({"buffer": 0, "byteOffset": 0, "byteLength": 48}),
        json!({"buffer": 0, "byteOffset": 48, "byteLength": 48}),
        json!({"buffer": 0, "byteOffset": 96, "byteLength": 24}),
    ];
    let mut accessors = vec![
        json!({"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
               "min": [-1, 0, -1], "max": [1, 0, 1]}),
        json!({"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"}),
        json!({"bufferView": 2, "componentType": 5125, "count": 6, "type": "SCALAR"}),
    ];
    if let Some(colors) = colors {
        let offset = bin.len();
        bin.extend(colors.iter().flatten().flat_map(|v| v.to_le_bytes()));
        views.push(json!({"buffer": 0, "byteOffset": offset, "byteLength": 64}));
        accessors.push(json!({"bufferView": 3, "componentType": 5126, "count": 4, "type": "VEC4"}));
        attributes["COLOR_0"] = json!(3);
    }
    // Turned −90° about X: looking (and shining) down glTF's −Y.
    let down = json!([-FRAC_1_SQRT_2, 0, 0, FRAC_1_SQRT_2]);
    let mut doc = json!({
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0, 1]}],
        "extensionsUsed": ["PHOTON_material_nodes"],
        "nodes": [
            {"mesh": 0, "name": "Plane"},
            {"camera": 0, "translation": [0, 3, 0], "rotation": down}
        ],
        "cameras": [{"type": "orthographic",
                     "orthographic": {"xmag": 1, "ymag": 1, "znear": 0.1, "zfar": 10}}],
        "meshes": [{"primitives": [{"attributes": attributes, "indices": 2, "material": 0}]}],
        "materials": [material],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": bin.len(),
                     "uri": format!("data:application/octet-stream;base64,{}", base64(&bin))}]
    });
    // A sun shining straight down (Blender −Z), 683 lx = 1 W/m².
    doc["extensionsUsed"] = json!(["PHOTON_material_nodes", "KHR_lights_punctual"]);
    doc["extensions"] = json!({"KHR_lights_punctual": {"lights": [
        {"type": "directional", "intensity": 683.0, "color": [1, 1, 1]}]}});
    doc["nodes"]
        .as_array_mut()
        .unwrap()
        .push(json!({"name": "Sun", "rotation": down,
                     "extensions": {"KHR_lights_punctual": {"light": 0}}}));
    doc["scenes"][0]["nodes"] = json!([0, 1, 2]);
    doc.to_string()
}

fn checker_material(emission_input: &str) -> Value {
    json!({
        "name": "Board",
        "extensions": {"PHOTON_material_nodes": {
            "nodes": [
                {"name": "Checker", "type": "ShaderNodeTexChecker",
                 "inputs": {"Color1": [0.9, 0.3, 0.1, 1.0], "Color2": [0.05, 0.2, 0.6, 1.0],
                            "Scale": 3.0}},
                {"name": "Particles", "type": "ShaderNodeParticleInfo"},
                {"name": "Emission", "type": "ShaderNodeEmission",
                 "inputs": {"Color": {"node": 0, "output": emission_input}, "Strength": 2.0}}
            ],
            "output": {"node": 2, "output": "Emission"}
        }}
    })
}

fn render(scene: &Path, out: &Path, size: u32) -> std::process::Output {
    photon()
        .args([
            "render",
            &scene.to_string_lossy(),
            "-o",
            &out.to_string_lossy(),
        ])
        .args(["--width", &size.to_string(), "--height", &size.to_string()])
        .args(["--spp", "16", "--method", "path"])
        .output()
        .unwrap()
}

fn pixel(pixels: &[[f32; 4]], width: usize, x: usize, y: usize) -> [f32; 3] {
    let p = pixels[y * width + x];
    [p[0], p[1], p[2]]
}

fn close(a: [f32; 3], b: [f32; 3], tol: f32) -> bool {
    a.iter().zip(b).all(|(x, y)| (x - y).abs() <= tol)
}

#[test]
fn a_checker_on_generated_coordinates_emits_its_colours_cell_by_cell() {
    let dir = temp_dir("checker");
    let scene = dir.join("checker.gltf");
    std::fs::write(&scene, plane_gltf(checker_material("Color"), None)).unwrap();
    let out = dir.join("checker.exr");
    let result = render(&scene, &out, 18);
    assert_success(&result);
    let (w, _, pixels) = photon::image_io::read_exr_rgba(&out).unwrap();
    let (w, c1, c2) = (w as usize, [1.8, 0.6, 0.2], [0.1, 0.4, 1.2]);
    // 3 × 3 cells of 6 px; Generated z is ½ (a flat plane), scaled 1.5: the top-left cell
    // (x cell 0, y cell 2) has Color1, and the colours alternate from cell to cell.
    for (cx, cy) in [
        (0, 0),
        (1, 0),
        (2, 0),
        (0, 1),
        (1, 1),
        (2, 1),
        (0, 2),
        (1, 2),
    ] {
        let got = pixel(&pixels, w, 6 * cx + 3, 6 * cy + 3);
        let want = if (cx + cy) % 2 == 0 { c1 } else { c2 };
        assert!(
            close(got, want, 1e-3),
            "cell ({cx}, {cy}): {got:?}, want {want:?}"
        );
    }
}

#[test]
fn unknown_nodes_are_listed_by_photon_info_and_the_fac_output_converts() {
    let dir = temp_dir("info");
    let scene = dir.join("fac.gltf");
    // The Fac output (a float) feeds a colour input: grey levels 0 and 1 × strength 2.
    std::fs::write(&scene, plane_gltf(checker_material("Fac"), None)).unwrap();
    let info = photon()
        .args(["info", &scene.to_string_lossy()])
        .output()
        .unwrap();
    assert_success(&info);
    let text =
        String::from_utf8_lossy(&info.stdout).to_string() + &String::from_utf8_lossy(&info.stderr);
    assert!(
        text.contains("material 'Board'") && text.contains("Particles"),
        "photon info does not name the node it cannot evaluate: {text}"
    );
    let out = dir.join("fac.exr");
    assert_success(&render(&scene, &out, 18));
    let (w, _, pixels) = photon::image_io::read_exr_rgba(&out).unwrap();
    assert!(close(pixel(&pixels, w as usize, 3, 3), [2.0; 3], 1e-3));
    assert!(close(pixel(&pixels, w as usize, 9, 3), [0.0; 3], 1e-3));
}

#[test]
fn an_invalid_tree_exits_with_2_naming_the_material() {
    let dir = temp_dir("invalid");
    let scene = dir.join("invalid.gltf");
    let material = json!({
        "name": "Broken",
        "extensions": {"PHOTON_material_nodes": {
            "nodes": [
                {"name": "Emission", "type": "ShaderNodeEmission",
                 "inputs": {"Color": {"node": 1, "output": "Color"}}},
                {"name": "RGB", "type": "ShaderNodeRGB", "value": [1, 0, 0, 1]}
            ],
            "output": {"node": 0, "output": "Emission"}
        }}
    });
    std::fs::write(&scene, plane_gltf(material, None)).unwrap();
    let out = dir.join("invalid.exr");
    let result = render(&scene, &out, 8);
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert_eq!(result.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("Broken") && stderr.contains("PHOTON_material_nodes"),
        "{stderr}"
    );
    assert!(stderr.contains("not earlier"), "{stderr}");
    assert!(!out.exists());
}

#[test]
fn vertex_colours_multiply_a_plain_base_colour_and_feed_a_colour_attribute_node() {
    let dir = temp_dir("colors");
    let red = [1.0, 0.0, 0.0, 1.0];
    let colors = Some([red; 4]);
    // A plain emissive-free material lit by nothing renders black either way, so read the
    // colour through emission: a Color Attribute node into an Emission shader.
    let material = json!({
        "name": "Painted",
        "extensions": {"PHOTON_material_nodes": {
            "nodes": [
                {"name": "Color Attribute", "type": "ShaderNodeVertexColor"},
                {"name": "Emission", "type": "ShaderNodeEmission",
                 "inputs": {"Color": {"node": 0, "output": "Color"}, "Strength": 1.0}}
            ],
            "output": {"node": 1, "output": "Emission"}
        }}
    });
    let scene = dir.join("painted.gltf");
    std::fs::write(&scene, plane_gltf(material, colors)).unwrap();
    let out = dir.join("painted.exr");
    assert_success(&render(&scene, &out, 8));
    let (w, h, pixels) = photon::image_io::read_exr_rgba(&out).unwrap();
    for y in 1..h as usize - 1 {
        for x in 1..w as usize - 1 {
            assert!(close(
                pixel(&pixels, w as usize, x, y),
                [1.0, 0.0, 0.0],
                1e-4
            ));
        }
    }
    // Without a tree, glTF's rule: the base colour (white) times COLOR_0 is the albedo: under
    // the sun the plane is red, where without the colours it is grey.
    let plain = json!({"name": "Plain",
                       "pbrMetallicRoughness": {"metallicFactor": 0.0, "roughnessFactor": 1.0}});
    let mut lit = Vec::new();
    for (name, colors) in [("plain_red", colors), ("plain_white", None)] {
        let scene = dir.join(format!("{name}.gltf"));
        std::fs::write(&scene, plane_gltf(plain.clone(), colors)).unwrap();
        let out = dir.join(format!("{name}.exr"));
        assert_success(&render(&scene, &out, 8));
        let (w, _, pixels) = photon::image_io::read_exr_rgba(&out).unwrap();
        lit.push(pixel(&pixels, w as usize, 4, 4));
    }
    let (red, white) = (lit[0], lit[1]);
    assert!(
        white[1] > 0.1 && close(white, [white[0]; 3], 1e-4),
        "{white:?}"
    );
    // Red: the same red channel; green and blue keep only the (colourless) specular layer.
    assert!(
        (red[0] - white[0]).abs() < 1e-4 && red[1] == red[2] && red[1] < 0.02 * white[1],
        "{red:?} vs {white:?}"
    );
}

#[test]
fn what_the_add_on_could_not_describe_is_listed_by_info_and_not_repeated_by_render() {
    let dir = temp_dir("notes");
    let note = "material 'Old': Gabor Texture node 'M' is not evaluated by Photon";
    let material =
        json!({"name": "Old", "extensions": {"PHOTON_material_nodes": {"warnings": [note]}}});
    let scene = dir.join("notes.gltf");
    std::fs::write(&scene, plane_gltf(material, None)).unwrap();
    let info = photon()
        .args(["info", &scene.to_string_lossy()])
        .output()
        .unwrap();
    assert_success(&info);
    assert!(String::from_utf8_lossy(&info.stdout).contains(note));
    let out = dir.join("notes.exr");
    let result = render(&scene, &out, 8);
    assert_success(&result);
    assert!(!String::from_utf8_lossy(&result.stderr).contains("Gabor"));
}

#[test]
fn a_ray_portal_sends_camera_rays_on_along_its_direction_tinted_by_its_colour() {
    let dir = temp_dir("portal");
    let portal = json!({
        "name": "Portal",
        "extensions": {"PHOTON_material_nodes": {
            "nodes": [{"name": "Portal", "type": "ShaderNodeBsdfRayPortal",
                       "inputs": {"Color": [0.5, 1.0, 0.25, 1.0], "Direction": [0.0, 0.0, 1.0]}}],
            "output": {"node": 0, "output": "BSDF"}
        }}
    });
    // Turned up (Blender +Z), the camera rays leave the scene and, still camera rays, see the
    // world's camera background (`camera`), not its light (`color`).
    let mut doc: Value = serde_json::from_str(&plane_gltf(portal, None)).unwrap();
    doc["extensionsUsed"]
        .as_array_mut()
        .unwrap()
        .push(json!("PHOTON_world"));
    doc["scenes"][0]["extensions"] = json!({"PHOTON_world": {
        "color": [1.0, 1.0, 1.0], "camera": {"color": [0.2, 0.4, 0.8]}}});
    let scene = dir.join("portal.gltf");
    std::fs::write(&scene, doc.to_string()).unwrap();
    let out = dir.join("portal.exr");
    assert_success(&render(&scene, &out, 8));
    let (w, _, pixels) = photon::image_io::read_exr_rgba(&out).unwrap();
    let got = pixel(&pixels, w as usize, 4, 4);
    assert!(close(got, [0.1, 0.4, 0.2], 1e-4), "{got:?}");
}
