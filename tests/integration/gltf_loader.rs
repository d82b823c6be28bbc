//! Integration tests of the glTF loader: the scenes built by `scenes/build_scenes.py`, small
//! fixtures built here (transforms, normals, lights, cameras), and broken files that must give a
//! `Error::Scene` naming the object at fault, never a panic.

use crate::support::binary::{base64, scene_path, temp_dir};
use crate::support::gltf::{triangle_doc, Doc};
use photon::color_space::WorkingSpace;
use photon::error::Error;
use photon::film::{FilterKind, FilterSettings};
use photon::math::{Vec3, Vec4};
use photon::scene::gltf::{load, load_slice, LoadOptions};
use photon::scene::texture::Texels;
use photon::scene::{Lamp, Light, Projection, Scene, SubsurfaceMethod};
use serde_json::{json, Value};
use std::f32::consts::PI;

// ----- fixture builder ----------------------------------------------------------------------

fn load_glb(doc: &Doc) -> photon::error::Result<Scene> {
    load_slice(&doc.glb(), "fixture.glb", &LoadOptions::default())
}

impl Doc {
    /// Give the first primitive material 0, defined by `material`.
    fn set_material(&mut self, material: Value) {
        self.json["meshes"][0]["primitives"][0]["material"] = json!(0);
        self.json["materials"] = json!([material]);
    }
}

/// The triangle fixture with `image` (in the buffer) as texture 0, used by `material`.
fn textured_doc(image: &[u8], mime: &str, material: Value) -> Doc {
    let mut doc = triangle_doc();
    add_png_texture(&mut doc, image, mime);
    doc.set_material(material);
    doc
}

/// Assert a scene error whose text contains every one of `needles`.
fn assert_scene_error(result: photon::error::Result<Scene>, needles: &[&str]) {
    match result {
        Err(e @ Error::Scene { .. }) => {
            let text = e.to_string();
            for needle in needles {
                assert!(
                    text.contains(needle),
                    "'{text}' does not mention '{needle}'"
                );
            }
        }
        Err(other) => panic!("expected a scene error, got {other:?}"),
        Ok(_) => panic!("expected a scene error, the file loaded"),
    }
}

/// Index of the (first) mesh made for a PHOTON_light area light.
fn area_light_index(scene: &Scene) -> usize {
    let found = scene
        .meshes
        .iter()
        .position(|m| m.name.contains("area light"));
    found.expect("no area light mesh")
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).length() < 1e-4
}

/// Unit normal of a triangle from its winding.
fn face_normal(scene: &Scene, mesh: usize, triangle: usize) -> Vec3 {
    let m = &scene.meshes[mesh];
    let [a, b, c] = m.indices[triangle].map(|i| m.positions[i as usize]);
    (b - a).cross(c - a).normalize()
}

pub(crate) fn png_bytes(
    width: u32,
    height: u32,
    color: png::ColorType,
    depth: png::BitDepth,
    data: &[u8],
) -> Vec<u8> {
    let mut out = Vec::new();
    {
        let mut encoder = png::Encoder::new(&mut out, width, height);
        encoder.set_color(color);
        encoder.set_depth(depth);
        let mut writer = encoder.write_header().unwrap();
        writer.write_image_data(data).unwrap();
    }
    out
}

// ----- the built scenes -----------------------------------------------------------------------

fn load_built(name: &str) -> Scene {
    load(&scene_path(name), &LoadOptions::default()).unwrap()
}

fn count_lights(scene: &Scene) -> (usize, usize, usize) {
    let point = scene
        .lights
        .iter()
        .filter(|l| matches!(l, Light::Point { .. }))
        .count();
    let spot = scene
        .lights
        .iter()
        .filter(|l| matches!(l, Light::Spot { .. }))
        .count();
    let sun = scene
        .lights
        .iter()
        .filter(|l| matches!(l, Light::Sun { .. }))
        .count();
    (point, spot, sun)
}

#[test]
fn cornell_box_has_walls_boxes_and_a_lamp() {
    let scene = load_built("cornell_box.glb");
    assert_eq!(scene.materials.len(), 4);
    // The two boxes share one mesh: stored once, placed twice.
    assert_eq!(scene.triangle_count(), 5 * 2 + 2 + 12);
    assert_eq!(scene.placed_triangle_count(), 5 * 2 + 2 + 2 * 12);
    assert_eq!(scene.instances.len(), 2);
    assert!(scene.lights.is_empty());
    assert_eq!(
        scene.materials.iter().filter(|m| m.is_emissive()).count(),
        1
    );
    let red = scene.materials.iter().find(|m| m.name == "Red").unwrap();
    assert!(close(
        red.base_color.truncate(),
        Vec3::new(0.63, 0.065, 0.05)
    ));
    assert_eq!((red.specular, red.roughness, red.metallic), (0.0, 1.0, 0.0));
    assert!(matches!(
        scene.camera.projection,
        Projection::Perspective { .. }
    ));
    assert_eq!(scene.render_settings.width, Some(256));
    assert_eq!(scene.render_settings.height, Some(256));
    // The two boxes share one mesh: both instances are there, inside the room.
    let b = scene.bounds();
    assert!(b.max.y <= 5.56 && b.min.y >= -1e-4);
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
}

#[test]
fn furnace_is_a_closed_inward_sphere_around_the_camera() {
    let scene = load_built("furnace.glb");
    assert!(scene.triangle_count() >= 2000);
    assert_eq!(scene.materials.len(), 1);
    let m = &scene.materials[0];
    assert!(
        close(m.emission, Vec3::splat(0.5)) && close(m.base_color.truncate(), Vec3::splat(0.5))
    );
    assert_eq!(m.specular, 0.0);
    let eye = scene.camera.to_world.translation;
    assert!(Vec3::from(eye).length() < 1.0);
    // Normals and winding point inward, towards the centre.
    let mesh = &scene.meshes[0];
    for (t, tri) in mesh.indices.iter().enumerate().step_by(97) {
        let centroid = tri
            .iter()
            .map(|&i| mesh.positions[i as usize])
            .sum::<Vec3>()
            / 3.0;
        assert!(face_normal(&scene, 0, t).dot(-centroid) > 0.0);
        assert!(mesh.normals[tri[0] as usize].dot(-centroid) > 0.0);
    }
}

#[test]
fn materials_scene_has_glass_metal_texture_sun_and_world() {
    let scene = load_built("materials.glb");
    assert_eq!(scene.materials.len(), 4);
    assert_eq!(scene.textures.len(), 1);
    assert!(scene.textures[0].srgb && !scene.textures[0].bilinear);
    let floor = scene
        .materials
        .iter()
        .find(|m| m.name == "Checker")
        .unwrap();
    let tex = floor.base_color_texture.unwrap();
    assert_eq!(tex.transform[0], 4.0);
    let glass = scene.materials.iter().find(|m| m.name == "Glass").unwrap();
    assert_eq!((glass.transmission, glass.ior), (1.0, 1.5));
    let metal = scene.materials.iter().find(|m| m.name == "Metal").unwrap();
    assert_eq!((metal.metallic, metal.roughness), (1.0, 0.3));
    assert_eq!(count_lights(&scene), (0, 0, 1));
    if let Light::Sun {
        irradiance,
        angle,
        direction,
        ..
    } = &scene.lights[0]
    {
        assert!(close(*irradiance, Vec3::splat(3.0)));
        assert!((angle - 0.0092).abs() < 1e-6);
        assert!(direction.y < 0.0, "the sun shines downwards");
    }
    assert!(close(
        scene.world.background.color,
        Vec3::new(0.2, 0.25, 0.35)
    ));
}

#[test]
fn lights_scene_has_point_spot_and_visible_area_light() {
    let scene = load_built("lights.glb");
    assert_eq!(count_lights(&scene), (1, 1, 0));
    for light in &scene.lights {
        match light {
            Light::Point {
                intensity, radius, ..
            } => {
                assert!((intensity.x - 300.0 / (4.0 * PI)).abs() < 1e-3);
                assert_eq!(*radius, 0.1);
            }
            Light::Spot {
                cos_inner,
                cos_outer,
                intensity,
                ..
            } => {
                assert!((cos_outer - (22.5f32).to_radians().cos()).abs() < 1e-5);
                assert!(cos_inner > cos_outer);
                assert!((intensity.y - 0.9 * 800.0 / (4.0 * PI)).abs() < 1e-2);
            }
            _ => unreachable!(),
        }
    }
    let area = &scene.meshes[area_light_index(&scene)];
    assert!(area.camera_visible);
    let material = &scene.materials[area.material as usize];
    let expected = 200.0 / (PI * 0.5);
    assert!((material.emission.x - expected).abs() < 1e-3 * expected);
    assert_eq!(scene.render_settings.width, Some(320));
    assert_eq!(
        scene.camera.aspect_ratio.map(|a| (a * 3.0).round()),
        Some(4.0)
    );
}

#[test]
fn glass_caustic_scene_has_hidden_area_light_and_glass() {
    let scene = load_built("glass_caustic.glb");
    assert!(scene.lights.is_empty());
    let area = &scene.meshes[area_light_index(&scene)];
    assert!(!area.camera_visible);
    assert!(scene.materials.iter().any(|m| m.transmission == 1.0));
}

#[test]
fn built_scenes_are_small() {
    for name in [
        "cornell_box.glb",
        "furnace.glb",
        "materials.glb",
        "lights.glb",
        "glass_caustic.glb",
    ] {
        let size = std::fs::metadata(scene_path(name)).unwrap().len();
        assert!(size < 500_000, "{name} is {size} bytes");
    }
}

// ----- geometry -----------------------------------------------------------------------------

#[test]
fn hierarchy_transforms_are_flattened_to_world_space() {
    let mut doc = triangle_doc();
    let mesh = 0;
    // Child: scale 2, translation (0, 0, 1). Parent: rotate 90° about +Z, then translate (1, 2, 3).
    let child = doc.node(json!({"name": "Child", "mesh": mesh, "scale": [2.0, 2.0, 2.0], "translation": [0.0, 0.0, 1.0]}), false);
    let s = (PI / 4.0).sin();
    doc.node(
        json!({"name": "Parent", "children": [child], "translation": [1.0, 2.0, 3.0], "rotation": [0.0, 0.0, s, s]}),
        true,
    );
    let scene = load_glb(&doc).unwrap();
    assert_eq!(
        scene.instances.len(),
        2,
        "the mesh is placed twice, stored once"
    );
    let (instance, prototype) = (&scene.instances[1], &scene.prototypes[0]);
    let at = |i: usize| instance.to_world.transform_point3(prototype.positions[i]);
    // Vertex (1, 0, 0): scale → (2, 0, 0), translate → (2, 0, 1), rotate → (0, 2, 1), → (1, 4, 4).
    assert!(close(at(1), Vec3::new(1.0, 4.0, 4.0)), "{:?}", at(1));
    assert!(close(at(0), Vec3::new(1.0, 2.0, 4.0)));
    assert!(close(
        (instance.normal_matrix * prototype.normals[0]).normalize(),
        Vec3::Z
    ));
    // A node with its own ray visibility is an instance carrying it.
    doc.json["nodes"][child]["extensions"] = json!({"PHOTON_object": {"visible_shadow": false}});
    let scene = load_glb(&doc).unwrap();
    assert_eq!(scene.instances.len(), 2);
    assert!(scene.instances[0].casts_shadows && scene.instances[0].camera_visible);
    assert!(!scene.instances[1].casts_shadows && scene.instances[1].camera_visible);
    // Flattened (a mirrored copy is never an instance): the same place, mirrored in x.
    doc.json["nodes"][child]["scale"] = json!([-2.0, 2.0, 2.0]);
    let scene = load_glb(&doc).unwrap();
    let m = &scene.meshes[scene.meshes.len() - 1];
    // Vertex (1, 0, 0): scale → (−2, 0, 0), translate → (−2, 0, 1), rotate → (0, −2, 1).
    assert!(
        close(m.positions[1], Vec3::new(1.0, 0.0, 4.0)),
        "{:?}",
        m.positions[1]
    );
    assert!(close(m.positions[0], Vec3::new(1.0, 2.0, 4.0)));
}

#[test]
fn non_uniform_scale_transforms_normals_by_the_inverse_transpose() {
    let mut doc = Doc::new();
    // A slanted triangle with normal (1, 1, 0)/√2; scaling x by 2 turns it into (1, 2, 0)/√5.
    let n = std::f32::consts::FRAC_1_SQRT_2;
    let mesh = doc.mesh(
        "Slant",
        &[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 0.0, 1.0],
        &[n, n, 0.0, n, n, 0.0, n, n, 0.0],
        &[0, 1, 2],
    );
    doc.node(json!({"mesh": mesh, "scale": [2.0, 1.0, 1.0]}), true);
    let scene = load_glb(&doc).unwrap();
    let expected = Vec3::new(1.0, 2.0, 0.0).normalize();
    assert!(close(scene.meshes[0].normals[0], expected));
    assert!(
        face_normal(&scene, 0, 0).dot(expected) < -0.99
            || face_normal(&scene, 0, 0).dot(expected) > 0.99
    );
}

#[test]
fn missing_normals_are_generated_flat_by_splitting_vertices() {
    let mut doc = Doc::new();
    // Two triangles sharing an edge, folded: one in XY (+Z), one in XZ (+Y by winding).
    let mesh = doc.mesh(
        "Fold",
        &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        &[],
        &[0, 1, 2, 0, 3, 1],
    );
    doc.node(json!({"mesh": mesh}), true);
    let scene = load_glb(&doc).unwrap();
    let m = &scene.meshes[0];
    assert_eq!(m.positions.len(), 6);
    assert_eq!(m.indices, vec![[0, 1, 2], [3, 4, 5]]);
    assert!(m.normals[..3].iter().all(|&n| close(n, Vec3::Z)));
    assert!(m.normals[3..].iter().all(|&n| close(n, Vec3::Y)));
    assert!(scene.warnings.iter().any(|w| w.contains("no camera")));
}

/// An outward-wound tetrahedron with per-face (split) normals omitted.
fn tetrahedron_doc(scale: [f32; 3]) -> Doc {
    let mut doc = Doc::new();
    let mesh = doc.mesh(
        "Tetra",
        &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        &[],
        &[0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3],
    );
    doc.node(
        json!({"mesh": mesh, "scale": scale, "translation": [3.0, 0.0, 0.0]}),
        true,
    );
    doc
}

#[test]
fn negative_scale_flips_winding_so_faces_still_point_outward() {
    for scale in [[1.0, 1.0, 1.0], [-1.0, 1.0, 1.0], [2.0, -1.0, -3.0 + 2.0]] {
        let scene = load_glb(&tetrahedron_doc(scale)).unwrap();
        let m = &scene.meshes[0];
        let centre = m.positions.iter().sum::<Vec3>() / m.positions.len() as f32;
        for t in 0..m.indices.len() {
            let tri = m.indices[t];
            let centroid = tri.iter().map(|&i| m.positions[i as usize]).sum::<Vec3>() / 3.0;
            let n = face_normal(&scene, 0, t);
            assert!(
                n.dot(centroid - centre) > 0.0,
                "scale {scale:?} triangle {t}"
            );
            assert!(close(m.normals[tri[0] as usize], n));
        }
    }
}

#[test]
fn mirrored_normals_with_explicit_normals_stay_outward() {
    let mut doc = Doc::new();
    // Triangle facing +X at x = 1 with explicit +X normals, mirrored in X: must face −X.
    let mesh = doc.mesh(
        "Wall",
        &[1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 1.0, 0.0, 1.0],
        &[1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0],
        &[0, 1, 2],
    );
    doc.node(json!({"mesh": mesh, "scale": [-1.0, 1.0, 1.0]}), true);
    let scene = load_glb(&doc).unwrap();
    assert!(close(scene.meshes[0].normals[0], Vec3::NEG_X));
    assert!(close(face_normal(&scene, 0, 0), Vec3::NEG_X));
}

#[test]
fn strips_are_converted_and_points_are_skipped_with_a_warning() {
    let mut doc = triangle_doc();
    let positions = doc.floats(
        &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0],
        "VEC3",
    );
    doc.push(
        "meshes",
        json!({"name": "Mixed", "primitives": [
            {"attributes": {"POSITION": positions}, "mode": 5},
            {"attributes": {"POSITION": positions}, "mode": 0}
        ]}),
    );
    doc.node(json!({"mesh": 1}), true);
    let scene = load_glb(&doc).unwrap();
    let strip = scene
        .meshes
        .iter()
        .find(|m| m.name.contains("Mixed"))
        .unwrap();
    assert_eq!(strip.indices.len(), 2);
    assert!(scene
        .warnings
        .iter()
        .any(|w| w.contains("Mixed") && w.contains("Points")));
}

// ----- materials and textures ---------------------------------------------------------------

#[test]
fn material_extensions_and_defaults_are_read() {
    let mut doc = triangle_doc();
    doc.set_material(json!({
        "name": "Fancy",
        "pbrMetallicRoughness": {"baseColorFactor": [0.1, 0.2, 0.3, 0.5], "metallicFactor": 0.25, "roughnessFactor": 0.75},
        "emissiveFactor": [1.0, 0.5, 0.2],
        "alphaMode": "MASK", "alphaCutoff": 0.3, "doubleSided": true,
        "extensions": {
            "KHR_materials_emissive_strength": {"emissiveStrength": 10.0},
            "KHR_materials_transmission": {"transmissionFactor": 0.5},
            "KHR_materials_ior": {"ior": 1.33},
            "KHR_materials_specular": {"specularFactor": 0.8, "specularColorFactor": [1.4, 1.4, 1.4]},
            "KHR_materials_volume": {"thicknessFactor": 0.2, "attenuationDistance": 3.0, "attenuationColor": [0.9, 0.5, 0.1]}
        }
    }));
    // A second primitive without material gets Cycles' default surface (a grey diffuse), as
    // after Blender's import.
    let positions = doc.json["meshes"][0]["primitives"][0]["attributes"]["POSITION"].clone();
    doc.json["meshes"][0]["primitives"]
        .as_array_mut()
        .unwrap()
        .push(json!({"attributes": {"POSITION": positions}}));
    // Volume and specular required: the crate's validation would refuse them, Photon reads them.
    doc.json["extensionsRequired"] = json!(["KHR_materials_volume", "KHR_materials_specular"]);
    let scene = load_glb(&doc).unwrap();
    let m = &scene.materials[0];
    assert_eq!(m.base_color, Vec4::new(0.1, 0.2, 0.3, 0.5));
    assert_eq!((m.metallic, m.roughness), (0.25, 0.75));
    assert!(close(m.emission, Vec3::new(10.0, 5.0, 2.0)));
    assert_eq!(m.alpha_mode, photon::scene::AlphaMode::Mask { cutoff: 0.3 });
    assert!(m.double_sided);
    assert_eq!((m.transmission, m.ior, m.specular), (0.5, 1.33, 0.8));
    assert!(close(m.specular_color, Vec3::splat(1.4)));
    assert_eq!((m.thickness, m.attenuation_distance), (0.2, 3.0));
    assert!(close(m.attenuation_color, Vec3::new(0.9, 0.5, 0.1)));
    assert_eq!(scene.materials.len(), 2);
    let default = &scene.materials[1];
    assert_eq!(default.base_color, Vec4::new(0.8, 0.8, 0.8, 1.0));
    assert!(default.nodes.is_some() && default.metallic == 0.0);
    assert!(!default.double_sided);
    assert_eq!(scene.meshes[1].material, 1);
}

#[test]
fn subsurface_extension_is_read_with_blender_defaults_and_checked() {
    let mut doc = triangle_doc();
    doc.set_material(json!({
        "name": "Wax",
        "extensions": {"PHOTON_material_subsurface": {"weight": 0.5, "radius": [2.0, 1.0, 0.5], "ior": 1.3}}
    }));
    doc.json["extensionsUsed"] = json!(["PHOTON_material_subsurface"]);
    let scene = load_glb(&doc).unwrap();
    let s = scene.materials[0].subsurface;
    assert_eq!(
        (s.weight, s.scale, s.ior, s.anisotropy),
        (0.5, 0.05, 1.3, 0.0)
    );
    assert!(close(s.mean_free_path(), Vec3::new(0.1, 0.05, 0.025)));
    assert!(scene.materials[0].is_translucent());
    // Without a method: Blender's default, the random walk.
    assert_eq!(s.method, SubsurfaceMethod::RandomWalk);
    assert!(!scene.materials[0].uses_dipole());
    for (name, method) in [
        ("BURLEY", SubsurfaceMethod::ChristensenBurley),
        ("RANDOM_WALK", SubsurfaceMethod::RandomWalk),
        ("RANDOM_WALK_SKIN", SubsurfaceMethod::RandomWalkSkin),
    ] {
        let mut doc = triangle_doc();
        doc.set_material(json!({"name": "Wax", "extensions":
            {"PHOTON_material_subsurface": {"weight": 0.5, "method": name}}}));
        let scene = load_glb(&doc).unwrap();
        assert_eq!(scene.materials[0].subsurface.method, method, "{name}");
    }
    for bad in [
        json!({"method": "CUBIC"}),
        json!({"method": 1}),
        json!({"weight": 1.5}),
        json!({"radius": [1.0, -1.0, 0.0]}),
        json!({"radius": [1.0]}),
        json!({"ior": 0.0}),
        json!({"scale": "big"}),
    ] {
        let mut doc = triangle_doc();
        doc.set_material(json!({"name": "Wax", "extensions": {"PHOTON_material_subsurface": bad}}));
        assert_scene_error(load_glb(&doc), &["Wax", "PHOTON_material_subsurface"]);
    }
}

/// KHR_materials_clearcoat, _sheen and _anisotropy are read (as Blender imports them), also
/// when required, with their textures; bad values are refused.
#[test]
fn clearcoat_sheen_and_anisotropy_are_read() {
    let png = png_bytes(
        1,
        1,
        png::ColorType::Rgb,
        png::BitDepth::Eight,
        &[255, 128, 0],
    );
    let mut doc = textured_doc(
        &png,
        "image/png",
        json!({
            "name": "Layered",
            "extensions": {
                "KHR_materials_clearcoat": {"clearcoatFactor": 0.7, "clearcoatTexture": {"index": 0}},
                "KHR_materials_sheen": {"sheenColorFactor": [0.5, 0.25, 1.0], "sheenRoughnessFactor": 0.4,
                                        "sheenColorTexture": {"index": 0}},
                "KHR_materials_anisotropy": {"anisotropyStrength": 0.6, "anisotropyRotation": 0.5}
            }
        }),
    );
    doc.json["extensionsRequired"] = json!([
        "KHR_materials_clearcoat",
        "KHR_materials_sheen",
        "KHR_materials_anisotropy"
    ]);
    let scene = load_glb(&doc).unwrap();
    let m = &scene.materials[0];
    assert_eq!(
        (m.coat, m.coat_roughness),
        (0.7, 0.03),
        "Blender's default coat roughness"
    );
    assert!(m.coat_texture.is_some() && m.coat_normal_texture.is_none());
    assert!(m.sheen);
    assert!(close(m.sheen_color, Vec3::new(0.5, 0.25, 1.0)));
    assert_eq!(m.sheen_roughness, 0.4);
    let (color, coat) = (m.sheen_color_texture.unwrap(), m.coat_texture.unwrap());
    assert!(scene.textures[color.texture as usize].srgb);
    assert!(!scene.textures[coat.texture as usize].srgb);
    assert_eq!((m.anisotropy, m.anisotropy_rotation), (0.6, 0.5));
    // At a point: coat × R, sheen colour × RGB (sRGB decoded), Blender's anisotropy.
    let s = photon::material::eval_material(&scene, m, photon::math::Vec2::ZERO);
    assert!((s.coat_weight - 0.7).abs() < 1e-6);
    assert_eq!(s.sheen_weight, 1.0);
    assert!((s.sheen_tint.x - 0.5).abs() < 1e-6 && s.sheen_tint.z == 0.0);
    assert!((s.sheen_tint.y - 0.25 * photon::math::srgb_to_linear(128.0 / 255.0)).abs() < 1e-4);
    assert!((s.aspect - (1.0f32 - 0.9 * 0.6).sqrt()).abs() < 1e-6);
    // A coat makes the material glossy: no instancing, and the photon classifier sees it.
    assert!(photon::integrator::classify::is_specular(&scene, 0));

    for (ext, bad) in [
        (
            "KHR_materials_clearcoat",
            json!({"clearcoatFactor": "thick"}),
        ),
        (
            "KHR_materials_sheen",
            json!({"sheenColorFactor": [1.0, -1.0, 0.0]}),
        ),
        (
            "KHR_materials_anisotropy",
            json!({"anisotropyTexture": {"index": 7}}),
        ),
    ] {
        let mut doc = triangle_doc();
        doc.set_material(json!({"name": "Bad", "extensions": {ext: bad}}));
        assert_scene_error(load_glb(&doc), &["Bad", ext]);
    }
}

/// KHR_materials_iridescence is read as a thin film (Blender's Principled Thin Film, which
/// Blender 4.5's glTF exporter and importer do not carry): the factor (× texture R) weighs the
/// film, the thickness lies between the minimum and maximum by the thickness texture's G (the
/// maximum without one); numbers are clamped to their ranges, other values refused.
#[test]
fn iridescence_is_read_as_a_thin_film() {
    let png = png_bytes(
        1,
        1,
        png::ColorType::Rgb,
        png::BitDepth::Eight,
        &[255, 51, 0],
    );
    let ext = json!({"iridescenceFactor": 0.5, "iridescenceIor": 1.4,
                     "iridescenceThicknessMinimum": 200.0, "iridescenceThicknessMaximum": 600.0,
                     "iridescenceThicknessTexture": {"index": 0}});
    let mut doc = textured_doc(
        &png,
        "image/png",
        json!({"name": "Film", "extensions": {"KHR_materials_iridescence": ext}}),
    );
    doc.json["extensionsRequired"] = json!(["KHR_materials_iridescence"]);
    let scene = load_glb(&doc).unwrap();
    let m = &scene.materials[0];
    assert_eq!((m.iridescence, m.iridescence_ior), (0.5, 1.4));
    assert_eq!(m.iridescence_thickness, [200.0, 600.0]);
    let s = photon::material::eval_material(&scene, m, photon::math::Vec2::ZERO);
    assert_eq!((s.thin_film_weight, s.thin_film_ior), (0.5, 1.4));
    assert!((s.thin_film_thickness - (200.0 + 400.0 * 0.2)).abs() < 1e-3);
    // Without a thickness texture: the maximum; without the extension: no film.
    let mut doc = triangle_doc();
    doc.set_material(
        json!({"extensions": {"KHR_materials_iridescence": {"iridescenceFactor": 1.0}}}),
    );
    let scene = load_glb(&doc).unwrap();
    let s = photon::material::eval_material(&scene, &scene.materials[0], photon::math::Vec2::ZERO);
    assert_eq!(
        (s.thin_film_thickness, s.thin_film_ior, s.thin_film_weight),
        (400.0, 1.3, 1.0)
    );
    let mut doc = triangle_doc();
    doc.set_material(json!({"name": "Plain"}));
    let scene = load_glb(&doc).unwrap();
    let s = photon::material::eval_material(&scene, &scene.materials[0], photon::math::Vec2::ZERO);
    assert_eq!(s.thin_film_thickness, 0.0);
    for bad in [
        json!({"iridescenceFactor": "shiny"}),
        json!({"iridescenceThicknessMaximum": null}),
        json!({"iridescenceTexture": {"index": 7}}),
    ] {
        let mut doc = triangle_doc();
        doc.set_material(json!({"name": "Bad", "extensions": {"KHR_materials_iridescence": bad}}));
        assert_scene_error(load_glb(&doc), &["Bad", "KHR_materials_iridescence"]);
    }
}

/// Make `png` (stored in the buffer) texture 0 of `doc`.
fn add_png_texture(doc: &mut Doc, png: &[u8], mime: &str) {
    let view = doc.view(png);
    doc.json["images"] = json!([{"name": "tex.png", "bufferView": view, "mimeType": mime}]);
    doc.json["samplers"] = json!([{"wrapS": 33071, "wrapT": 33648, "magFilter": 9728}]);
    doc.json["textures"] = json!([{"source": 0, "sampler": 0}]);
}

#[test]
fn textures_are_created_per_colour_space_with_sampler_and_transform() {
    let png = png_bytes(
        2,
        1,
        png::ColorType::Rgb,
        png::BitDepth::Eight,
        &[255, 0, 0, 0, 0, 255],
    );
    let doc = textured_doc(
        &png,
        "image/png",
        json!({
            "pbrMetallicRoughness": {
                "baseColorTexture": {"index": 0, "extensions": {"KHR_texture_transform": {"offset": [0.5, 0.0], "scale": [2.0, 3.0]}}},
                "metallicRoughnessTexture": {"index": 0}
            },
            "emissiveTexture": {"index": 0},
            "normalTexture": {"index": 0, "scale": 0.5, "extensions": {"KHR_texture_transform": {"scale": [5.0, 5.0]}}}
        }),
    );
    let scene = load_glb(&doc).unwrap();
    assert_eq!(scene.textures.len(), 2, "one per colour space");
    let m = &scene.materials[0];
    let base = m.base_color_texture.unwrap();
    let mr = m.metallic_roughness_texture.unwrap();
    assert_eq!(base.texture, m.emissive_texture.unwrap().texture);
    assert!(scene.textures[base.texture as usize].srgb);
    assert!(!scene.textures[mr.texture as usize].srgb);
    assert_eq!(m.normal_texture.unwrap().texture, mr.texture);
    assert_eq!(m.normal_texture.unwrap().transform[0], 5.0);
    assert_eq!(m.normal_scale, 0.5);
    assert_eq!(base.transform, [2.0, 0.0, 0.5, 0.0, 3.0, 0.0]);
    let t = &scene.textures[0];
    assert_eq!((t.width, t.height), (2, 1));
    assert_eq!(
        t.texels,
        Texels::Bytes(vec![[255, 0, 0, 255], [0, 0, 255, 255]])
    );
    assert_eq!(t.wrap_s, photon::scene::texture::Wrap::ClampToEdge);
    assert_eq!(t.wrap_t, photon::scene::texture::Wrap::MirroredRepeat);
    assert!(!t.bilinear);
}

#[test]
fn sixteen_bit_grey_png_keeps_sixteen_bits_decoded_to_linear() {
    let png = png_bytes(
        1,
        1,
        png::ColorType::Grayscale,
        png::BitDepth::Sixteen,
        &[0xAB, 0xCD],
    );
    let doc = textured_doc(
        &png,
        "image/png",
        json!({"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}),
    );
    let scene = load_glb(&doc).unwrap();
    // Base colour is sRGB: decoded when loaded, from all 16 bits.
    let grey = photon::math::srgb_to_linear(0xABCD as f32 / 65535.0);
    assert_eq!(
        scene.textures[0].texels,
        Texels::Linear(vec![[grey, grey, grey, 1.0]])
    );
}

#[test]
fn gltf_with_external_buffer_and_image_loads_from_disk() {
    let dir = temp_dir("external");
    let mut doc = triangle_doc();
    doc.set_material(json!({"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}));
    doc.json["images"] = json!([{"uri": "my%20wood.png"}]);
    doc.json["textures"] = json!([{"source": 0}]);
    let png = png_bytes(
        1,
        1,
        png::ColorType::Rgba,
        png::BitDepth::Eight,
        &[1, 2, 3, 4],
    );
    std::fs::write(dir.join("my wood.png"), png).unwrap();
    std::fs::write(dir.join("scene.bin"), &doc.bin).unwrap();
    let text = serde_json::to_vec(&doc.finish_json(Some("scene.bin"))).unwrap();
    std::fs::write(dir.join("scene.gltf"), text).unwrap();
    let scene = load(&dir.join("scene.gltf"), &LoadOptions::default()).unwrap();
    assert_eq!(scene.textures[0].texels, Texels::Bytes(vec![[1, 2, 3, 4]]));
    assert_eq!(scene.triangle_count(), 1);

    // The same document with the buffer as a data URI loads from memory.
    let uri = format!("data:application/octet-stream;base64,{}", base64(&doc.bin));
    doc.json["images"] = json!([]);
    doc.json["textures"] = json!([]);
    doc.json["materials"] = json!([{}]);
    let text = serde_json::to_vec(&doc.finish_json(Some(&uri))).unwrap();
    let scene = load_slice(&text, "embedded.gltf", &LoadOptions::default()).unwrap();
    assert_eq!(scene.triangle_count(), 1);
}

// ----- lights -------------------------------------------------------------------------------

fn with_light(doc: &mut Doc, light: Value, node: Value) {
    doc.json["extensions"] = json!({"KHR_lights_punctual": {"lights": [light]}});
    doc.json["extensionsRequired"] = json!(["KHR_lights_punctual"]);
    doc.json["extensionsUsed"] = json!(["KHR_lights_punctual"]);
    doc.node(node, true);
}

#[test]
fn blender_default_point_light_is_1000_watts() {
    let mut doc = triangle_doc();
    with_light(
        &mut doc,
        json!({"type": "point", "intensity": 54351.4, "color": [1.0, 1.0, 1.0]}),
        json!({"name": "Light", "translation": [4.0, 5.0, -1.0], "extensions": {"KHR_lights_punctual": {"light": 0}, "PHOTON_light": {"radius": 0.25}}}),
    );
    let scene = load_glb(&doc).unwrap();
    let Light::Point {
        position,
        intensity,
        radius,
        lamp,
    } = &scene.lights[0]
    else {
        panic!("not a point light")
    };
    assert!(close(*position, Vec3::new(4.0, 5.0, -1.0)));
    let expected = 1000.0 / (4.0 * PI);
    assert!((intensity.x - expected).abs() < 1e-3 * expected);
    assert_eq!(*radius, 0.25);
    // Blender's defaults for a light object: Soft Falloff on, hidden from the camera.
    let default = Lamp {
        soft_falloff: true,
        camera: false,
        bounces: true,
    };
    assert_eq!(*lamp, default);
}

/// PHOTON_light's lamp flags (Soft Falloff, camera and scattered-ray visibility) reach the
/// light; a flag that is not a boolean is refused.
#[test]
fn lamp_flags_are_read_and_checked() {
    let light = |flags: Value| {
        let mut doc = triangle_doc();
        let mut extension = json!({"radius": 0.2});
        extension
            .as_object_mut()
            .unwrap()
            .extend(flags.as_object().unwrap().clone());
        with_light(
            &mut doc,
            json!({"type": "spot", "intensity": 100.0, "spot": {"outerConeAngle": 0.5}}),
            json!({"name": "Spot", "extensions": {"KHR_lights_punctual": {"light": 0}, "PHOTON_light": extension}}),
        );
        load_glb(&doc)
    };
    let scene =
        light(json!({"soft_falloff": false, "visible_camera": true, "visible_bounces": false}))
            .unwrap();
    let Light::Spot { lamp, radius, .. } = &scene.lights[0] else {
        panic!("not a spot light")
    };
    assert_eq!(*radius, 0.2);
    let expected = Lamp {
        soft_falloff: false,
        camera: true,
        bounces: false,
    };
    assert_eq!(*lamp, expected);
    let err = light(json!({"visible_camera": 1})).unwrap_err().to_string();
    assert!(err.contains("visible_camera"), "{err}");
}

#[test]
fn sun_direction_is_the_nodes_minus_z_and_lux_become_watts() {
    let mut doc = triangle_doc();
    // Rotate −90° about X: local −Z becomes world −Y.
    let s = (PI / 4.0).sin();
    with_light(
        &mut doc,
        json!({"type": "directional", "intensity": 2049.0}),
        json!({"rotation": [-s, 0.0, 0.0, s], "extensions": {"KHR_lights_punctual": {"light": 0}, "PHOTON_light": {"angle": 0.1}}}),
    );
    let scene = load_glb(&doc).unwrap();
    let Light::Sun {
        direction,
        irradiance,
        angle,
        ..
    } = &scene.lights[0]
    else {
        panic!("not a sun")
    };
    assert!(close(*direction, Vec3::NEG_Y));
    assert!(close(*irradiance, Vec3::splat(3.0)));
    assert_eq!(*angle, 0.1);
}

fn area_light_doc(extension: Value, node_extra: Value) -> Doc {
    let mut doc = triangle_doc();
    let mut node = json!({"name": "AreaL", "extensions": {"PHOTON_light": extension}});
    for (k, v) in node_extra.as_object().unwrap() {
        node[k] = v.clone();
    }
    doc.node(node, true);
    doc
}

#[test]
fn area_light_emits_p_over_pi_a_along_the_nodes_minus_z() {
    let s = (PI / 4.0).sin();
    let doc = area_light_doc(
        json!({"type": "area", "shape": "RECTANGLE", "size": 2.0, "size_y": 0.5, "power": 100.0, "color": [1.0, 0.5, 0.25]}),
        // Rotated so local −Z is world −Y; scaled ×2 in X (area 4 × 0.5 = 2 m²).
        json!({"translation": [0.0, 3.0, 0.0], "rotation": [-s, 0.0, 0.0, s], "scale": [2.0, 1.0, 1.0]}),
    );
    let scene = load_glb(&doc).unwrap();
    let index = area_light_index(&scene);
    let mesh = &scene.meshes[index];
    assert!(!mesh.camera_visible);
    let material = &scene.materials[mesh.material as usize];
    assert!(!material.double_sided);
    assert_eq!(material.base_color.truncate(), Vec3::ZERO);
    assert_eq!(material.metallic, 0.0);
    let radiance = 100.0 / (PI * 2.0);
    assert!(close(
        material.emission,
        Vec3::new(1.0, 0.5, 0.25) * radiance
    ));
    for t in 0..mesh.indices.len() {
        assert!(close(face_normal(&scene, index, t), Vec3::NEG_Y));
    }
    assert!(mesh.normals.iter().all(|&n| close(n, Vec3::NEG_Y)));
    assert!(mesh.positions.iter().all(|p| (p.y - 3.0).abs() < 1e-5));
}

#[test]
fn disk_area_light_conserves_power_with_the_polygon_area() {
    let doc = area_light_doc(
        json!({"type": "area", "shape": "DISK", "size": 1.0, "power": 50.0, "visible_camera": true}),
        json!({}),
    );
    let scene = load_glb(&doc).unwrap();
    let index = area_light_index(&scene);
    let mesh = &scene.meshes[index];
    assert!(mesh.camera_visible);
    assert_eq!(mesh.indices.len(), 32);
    let area: f32 = mesh
        .indices
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
            0.5 * (b - a).cross(c - a).length()
        })
        .sum();
    assert!(area < PI * 0.25 && area > 0.98 * PI * 0.25);
    let emitted = scene.materials[mesh.material as usize].emission.x * PI * area;
    assert!((emitted - 50.0).abs() < 1e-3);
    assert!(close(face_normal(&scene, index, 0), Vec3::NEG_Z));
}

// ----- cameras and scene extensions ---------------------------------------------------------

#[test]
fn cameras_are_selected_by_node_or_camera_name() {
    let mut doc = triangle_doc();
    doc.camera("Second", "SecondData", [0.0, 1.0, 9.0]);
    let pick = |name: &str| {
        let options = LoadOptions {
            camera: Some(name.to_string()),
            ..LoadOptions::default()
        };
        load_slice(&doc.glb(), "fixture.glb", &options)
    };
    let first = load_glb(&doc).unwrap().camera;
    assert_eq!(
        Vec3::from(first.to_world.translation),
        Vec3::new(0.0, 0.0, 5.0)
    );
    assert_eq!(first.projection, Projection::Perspective { yfov: 0.5 });
    assert_eq!(first.aspect_ratio, Some(1.5));
    for name in ["Second", "SecondData"] {
        let camera = pick(name).unwrap().camera;
        assert_eq!(
            Vec3::from(camera.to_world.translation),
            Vec3::new(0.0, 1.0, 9.0)
        );
    }
    assert_scene_error(pick("Nope"), &["Nope", "Camera", "Second"]);
}

#[test]
fn camera_scale_is_removed_and_orthographic_is_read() {
    let mut doc = triangle_doc();
    doc.json["cameras"] = json!([{"type": "orthographic", "orthographic": {"xmag": 2.0, "ymag": 1.0, "znear": 0.1, "zfar": 10.0}}]);
    doc.json["nodes"][1]["scale"] = json!([3.0, 3.0, 3.0]);
    let camera = load_glb(&doc).unwrap().camera;
    assert_eq!(
        camera.projection,
        Projection::Orthographic {
            xmag: 2.0,
            ymag: 1.0
        }
    );
    assert!((camera.to_world.matrix3.x_axis.length() - 1.0).abs() < 1e-5);
}

#[test]
fn without_a_camera_one_is_synthesised_looking_at_the_scene() {
    let mut doc = triangle_doc();
    doc.json["scenes"][0]["nodes"] = json!([0]);
    let scene = load_glb(&doc).unwrap();
    assert!(scene.warnings.iter().any(|w| w.contains("no camera")));
    let eye = Vec3::from(scene.camera.to_world.translation);
    let forward = scene.camera.to_world.transform_vector3(Vec3::NEG_Z);
    let to_centre = (scene.bounds().center() - eye).normalize();
    assert!(forward.dot(to_centre) > 0.999);
    assert!(eye.z > 0.0 && eye.y > scene.bounds().center().y);
}

#[test]
fn world_and_render_extensions_are_read() {
    let mut doc = triangle_doc();
    doc.json["scenes"][0]["extensions"] = json!({
        "PHOTON_world": {"color": [0.5, 0.25, 1.0], "strength": 2.0},
        "PHOTON_render": {"width": 640, "height": 480, "film_transparent": true}
    });
    let scene = load_glb(&doc).unwrap();
    assert!(close(
        scene.world.background.color,
        Vec3::new(1.0, 0.5, 2.0)
    ));
    assert_eq!(scene.render_settings.width, Some(640));
    assert_eq!(scene.render_settings.height, Some(480));
    assert!(scene.render_settings.transparent_film);
    assert_eq!(scene.render_settings.filter, None);
}

#[test]
fn the_pixel_filter_is_read_and_bad_ones_are_refused() {
    let with_filter = |filter: Value| {
        let mut doc = triangle_doc();
        doc.json["scenes"][0]["extensions"] = json!({"PHOTON_render": {"filter": filter}});
        load_glb(&doc)
    };
    let scene = with_filter(json!({"type": "GAUSSIAN", "width": 3.0})).unwrap();
    let gaussian = FilterSettings::new(FilterKind::Gaussian, 3.0).unwrap();
    assert_eq!(scene.render_settings.filter, Some(gaussian));
    let scene = with_filter(json!({"type": "BOX"})).unwrap();
    let box_filter = FilterSettings::new(FilterKind::Box, 1.0).unwrap();
    assert_eq!(scene.render_settings.filter, Some(box_filter));
    assert_scene_error(
        with_filter(json!({"type": "MITCHELL", "width": 1.0})),
        &["PHOTON_render filter", "MITCHELL"],
    );
    assert_scene_error(
        with_filter(json!({"type": "GAUSSIAN", "width": 0.0})),
        &["PHOTON_render filter", "width 0"],
    );
    assert_scene_error(
        with_filter(json!({"type": "BOX", "width": "wide"})),
        &["PHOTON_render filter", "must be a number"],
    );
}

#[test]
fn the_working_space_is_read_and_unknown_ones_are_refused() {
    let with_space = |space: Value| {
        let mut doc = triangle_doc();
        doc.json["scenes"][0]["extensions"] = json!({"PHOTON_render": {"working_space": space}});
        load_glb(&doc)
    };
    let scene = load_glb(&triangle_doc()).unwrap();
    assert_eq!(scene.render_settings.working_space, WorkingSpace::Rec709);
    let scene = with_space(json!("lin_ap1_scene")).unwrap();
    assert_eq!(scene.render_settings.working_space, WorkingSpace::AcesCg);
    let scene = with_space(json!("lin_rec2020_scene")).unwrap();
    assert_eq!(scene.render_settings.working_space, WorkingSpace::Rec2020);
    assert_scene_error(
        with_space(json!("srgb_tx")),
        &["PHOTON_render", "unknown working space 'srgb_tx'"],
    );
}

// ----- bad input ----------------------------------------------------------------------------

#[test]
fn malformed_json_is_a_scene_error() {
    let result = load_slice(
        b"{\"asset\": {\"version\": ",
        "broken.gltf",
        &LoadOptions::default(),
    );
    assert_scene_error(result, &["broken.gltf", "JSON"]);
}

#[test]
fn truncated_glb_is_a_scene_error() {
    let glb = triangle_doc().glb();
    for cut in [3, 11, 20, glb.len() / 2, glb.len() - 1] {
        let result = load_slice(&glb[..cut], "cut.glb", &LoadOptions::default());
        assert!(matches!(result, Err(Error::Scene { .. })), "cut at {cut}");
    }
    assert_scene_error(
        load_slice(&glb[..glb.len() / 2], "cut.glb", &LoadOptions::default()),
        &["truncated"],
    );
}

#[test]
fn missing_external_buffer_is_an_error_and_missing_image_is_magenta() {
    let dir = temp_dir("missing");
    let doc = triangle_doc();
    let text = serde_json::to_vec(&doc.finish_json(Some("gone.bin"))).unwrap();
    std::fs::write(dir.join("a.gltf"), text).unwrap();
    assert_scene_error(
        load(&dir.join("a.gltf"), &LoadOptions::default()),
        &["buffer 0", "gone.bin"],
    );

    let mut doc = triangle_doc();
    doc.set_material(json!({"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}));
    doc.json["images"] = json!([{"uri": "wood.png"}]);
    doc.json["textures"] = json!([{"source": 0}]);
    std::fs::write(dir.join("b.bin"), &doc.bin).unwrap();
    let text = serde_json::to_vec(&doc.finish_json(Some("b.bin"))).unwrap();
    std::fs::write(dir.join("b.gltf"), text).unwrap();
    // A missing image is no error: it renders magenta (as in Blender and Cycles), with a
    // warning naming the image and the file looked for.
    let scene = load(&dir.join("b.gltf"), &LoadOptions::default()).unwrap();
    assert_eq!(scene.textures.len(), 1);
    assert_eq!(
        scene.textures[0].texels,
        Texels::Bytes(vec![[255, 0, 255, 255]])
    );
    assert_eq!((scene.textures[0].width, scene.textures[0].height), (1, 1));
    let warning = scene
        .warnings
        .iter()
        .find(|w| w.contains("image 'wood.png'"))
        .unwrap_or_else(|| panic!("no warning names the image: {:?}", scene.warnings));
    assert!(
        warning.contains("not found") && warning.contains("magenta"),
        "{warning}"
    );
    // From memory, external files cannot be resolved at all.
    let result = load_slice(&doc.glb(), "mem.glb", &LoadOptions::default());
    assert_scene_error(result, &["wood.png", "external"]);
}

#[test]
fn out_of_range_references_are_scene_errors() {
    let mut doc = triangle_doc();
    doc.json["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = json!(99);
    assert_scene_error(
        load_glb(&doc),
        &["mesh 0 'Tri' primitive 0", "POSITION", "accessor 99"],
    );
    // A dangling index elsewhere goes through the gltf crate's validation.
    let mut doc = triangle_doc();
    doc.json["nodes"][0]["mesh"] = json!(42);
    assert_scene_error(load_glb(&doc), &["invalid glTF", "nodes[0].mesh"]);
}

#[test]
fn accessor_past_its_buffer_view_is_refused() {
    let mut doc = triangle_doc();
    doc.json["accessors"][0]["count"] = json!(1_000_000_000_000u64);
    assert_scene_error(load_glb(&doc), &["accessor 0", "do not fit"]);
    let mut doc = triangle_doc();
    doc.json["accessors"][0]["byteOffset"] = json!(4);
    assert_scene_error(load_glb(&doc), &["accessor 0"]);
    let mut doc = triangle_doc();
    doc.json["bufferViews"][0]["byteLength"] = json!(1 << 30);
    assert_scene_error(load_glb(&doc), &["buffer view 0", "outside"]);
}

#[test]
fn huge_accessor_without_buffer_is_refused() {
    let mut doc = triangle_doc();
    // Sparse accessors need no buffer view: their base is all zeros, so only the count limits them.
    let sparse_indices = doc.view(&0u32.to_le_bytes());
    let sparse_values = doc.view(&[0u8; 12]);
    let accessor = doc.push(
        "accessors",
        json!({"componentType": 5126, "count": 4_000_000_000u64, "type": "VEC3",
               "min": [0.0, 0.0, 0.0], "max": [0.0, 0.0, 0.0],
               "sparse": {"count": 1, "indices": {"bufferView": sparse_indices, "componentType": 5125},
                          "values": {"bufferView": sparse_values}}}),
    );
    doc.json["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = json!(accessor);
    doc.json["meshes"][0]["primitives"][0]
        .as_object_mut()
        .unwrap()
        .remove("indices");
    assert_scene_error(load_glb(&doc), &["too large"]);
}

#[test]
fn index_past_the_vertex_count_is_refused() {
    let mut doc = Doc::new();
    let mesh = doc.mesh("Cube", &[0.0; 9], &[], &[0, 1, 7]);
    doc.node(json!({"mesh": mesh}), true);
    assert_scene_error(load_glb(&doc), &["mesh 'Cube' primitive 0", "vertex 7"]);
}

#[test]
fn nan_positions_are_refused() {
    let mut doc = Doc::new();
    let mesh = doc.mesh(
        "Bad",
        &[0.0, 0.0, 0.0, f32::NAN, 0.0, 0.0, 0.0, 1.0, 0.0],
        &[],
        &[0, 1, 2],
    );
    doc.node(json!({"mesh": mesh}), true);
    assert_scene_error(load_glb(&doc), &["mesh 'Bad' primitive 0", "NaN"]);
    let mut doc = Doc::new();
    let mesh = doc.mesh(
        "Inf",
        &[0.0, 0.0, f32::INFINITY, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0],
        &[],
        &[0, 1, 2],
    );
    doc.node(json!({"mesh": mesh}), true);
    assert_scene_error(load_glb(&doc), &["mesh 'Inf'"]);
}

#[test]
fn coordinates_whose_distances_overflow_are_refused() {
    // Found by fuzz_gltf.rs: a vertex at 1.4e27 made the scene's diagonal infinite and
    // the BVH builder index out of bounds. Also reachable through a node's scale.
    let mut doc = Doc::new();
    let mesh = doc.mesh(
        "Far",
        &[0.0, 0.0, 0.0, 1.4e27, 0.0, 0.0, 0.0, 1.0, 0.0],
        &[],
        &[0, 1, 2],
    );
    doc.node(json!({"mesh": mesh}), true);
    assert_scene_error(load_glb(&doc), &["Far primitive 0", "beyond"]);
    let mut doc = triangle_doc();
    doc.json["nodes"][0]["scale"] = json!([1e20, 1.0, 1.0]);
    assert_scene_error(load_glb(&doc), &["beyond"]);
}

#[test]
fn unsupported_required_extension_is_listed() {
    let mut doc = triangle_doc();
    doc.json["extensionsRequired"] = json!(["KHR_lights_punctual", "EXT_made_up_compression"]);
    assert_scene_error(
        load_glb(&doc),
        &["EXT_made_up_compression", "extensionsRequired"],
    );
}

#[test]
fn corrupt_webp_is_a_scene_error() {
    let doc = textured_doc(
        b"RIFF\x10\0\0\0WEBPVP8 fake",
        "image/webp",
        json!({"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}),
    );
    assert_scene_error(
        load_glb(&doc),
        &["image 'tex.png'", "cannot decode the WebP image"],
    );
}

#[test]
fn other_image_formats_are_refused_by_name() {
    let doc = textured_doc(
        b"GIF89a\x01\0\x01\0",
        "image/gif",
        json!({"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}),
    );
    assert_scene_error(
        load_glb(&doc),
        &["image 'tex.png'", "image/gif", "PNG, JPEG and WebP"],
    );
}

/// A lossless WebP of `width` x `height` RGBA texels.
fn webp_bytes(width: u32, height: u32, rgba: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    image::codecs::webp::WebPEncoder::new_lossless(&mut out)
        .encode(rgba, width, height, image::ExtendedColorType::Rgba8)
        .unwrap();
    out
}

/// The triangle fixture with texture 0 as Blender's exporter writes a WebP image without a
/// fallback: no `source`, the image in `EXT_texture_webp`, the extension required.
fn webp_doc(webp: &[u8]) -> Doc {
    let mut doc = triangle_doc();
    let view = doc.view(webp);
    doc.json["images"] = json!([{"name": "Check", "bufferView": view, "mimeType": "image/webp"}]);
    doc.json["textures"] = json!([{"extensions": {"EXT_texture_webp": {"source": 0}}}]);
    doc.json["extensionsUsed"] = json!(["EXT_texture_webp"]);
    doc.json["extensionsRequired"] = json!(["EXT_texture_webp"]);
    doc.set_material(json!({"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}));
    doc
}

#[test]
fn required_ext_texture_webp_is_read_and_decoded() {
    let texels = [
        [255, 0, 0, 255],
        [0, 255, 0, 128],
        [0, 0, 255, 255],
        [10, 20, 30, 0],
    ];
    let webp = webp_bytes(2, 2, texels.as_flattened());
    let scene = load_glb(&webp_doc(&webp)).unwrap();
    let base = scene.materials[0].base_color_texture.unwrap();
    let t = &scene.textures[base.texture as usize];
    assert_eq!((t.width, t.height), (2, 2));
    assert_eq!(t.texels, Texels::Bytes(texels.to_vec()));
    assert!(t.srgb);
}

#[test]
fn ext_texture_webp_is_preferred_to_the_fallback_source() {
    let webp = webp_bytes(1, 1, &[0, 200, 0, 255]);
    let png = png_bytes(
        1,
        1,
        png::ColorType::Rgb,
        png::BitDepth::Eight,
        &[200, 0, 0],
    );
    let mut doc = webp_doc(&webp);
    let png_view = doc.view(&png);
    doc.json["images"]
        .as_array_mut()
        .unwrap()
        .push(json!({"name": "Fallback", "bufferView": png_view, "mimeType": "image/png"}));
    doc.json["textures"][0]["source"] = json!(1);
    doc.json["extensionsRequired"] = json!([]);
    let scene = load_glb(&doc).unwrap();
    assert_eq!(scene.textures.len(), 1);
    assert_eq!(
        scene.textures[0].texels,
        Texels::Bytes(vec![[0, 200, 0, 255]])
    );
}

#[test]
fn ext_texture_webp_without_a_valid_source_is_a_scene_error() {
    let webp = webp_bytes(1, 1, &[0, 200, 0, 255]);
    let mut doc = webp_doc(&webp);
    doc.json["textures"][0]["extensions"]["EXT_texture_webp"]["source"] = json!(3);
    assert_scene_error(
        load_glb(&doc),
        &["texture 0 (EXT_texture_webp)", "'source' 3 is not an image"],
    );
    doc.json["textures"][0]["extensions"]["EXT_texture_webp"] = json!({});
    assert_scene_error(load_glb(&doc), &["texture 0 (EXT_texture_webp)", "missing"]);
}

#[test]
fn corrupt_png_is_a_scene_error() {
    let doc = textured_doc(
        b"\x89PNG\r\n\x1a\nnot really",
        "image/png",
        json!({"emissiveTexture": {"index": 0}}),
    );
    assert_scene_error(load_glb(&doc), &["image 'tex.png'", "decode"]);
}

#[test]
fn node_cycles_are_refused() {
    let mut doc = triangle_doc();
    doc.json["nodes"][0]["children"] = json!([2]);
    doc.node(json!({"name": "Loop", "children": [0]}), false);
    let result = load_glb(&doc);
    assert!(matches!(result, Err(Error::Scene { .. })), "{result:?}");
}

#[test]
fn exponential_instancing_is_refused() {
    // Each node has its successor twice as a child: 2^40 paths to the last node.
    let mut doc = triangle_doc();
    let first = doc.json["nodes"].as_array().unwrap().len();
    for i in 0..40 {
        let next = first + i + 1;
        let children = if i < 39 {
            json!([next, next])
        } else {
            json!([])
        };
        doc.node(
            json!({"name": format!("Level{i}"), "children": children}),
            i == 0,
        );
    }
    assert_scene_error(load_glb(&doc), &["instances more than"]);
}

#[test]
fn wrong_attribute_type_is_refused() {
    let mut doc = triangle_doc();
    doc.json["accessors"][0]["type"] = json!("VEC2");
    doc.json["accessors"][0]["count"] = json!(4);
    let result = load_glb(&doc);
    assert!(matches!(result, Err(Error::Scene { .. })), "{result:?}");
}

#[test]
fn unknown_area_light_shape_is_refused() {
    let doc = area_light_doc(json!({"type": "area", "shape": "STAR"}), json!({}));
    assert_scene_error(load_glb(&doc), &["AreaL", "STAR"]);
}

#[test]
fn garbage_never_panics() {
    // Flip bytes all over a valid file: every outcome must be Ok or a scene error.
    let glb = triangle_doc().glb();
    for i in 0..glb.len() {
        for value in [0x00, 0xFF, 0x7F] {
            let mut bytes = glb.clone();
            bytes[i] = value;
            match load_slice(&bytes, "fuzz.glb", &LoadOptions::default()) {
                Ok(scene) => assert!(scene.validate().is_ok()),
                Err(Error::Scene { .. }) => {}
                Err(other) => panic!("byte {i} = {value}: {other:?}"),
            }
        }
    }
}

// ----- input checks: cameras, quantized attributes, sizes before allocation --------------------

#[test]
fn degenerate_cameras_are_refused() {
    for (field, value) in [
        ("yfov", json!(0.0)),
        ("yfov", json!(-0.5)),
        ("yfov", json!(4.0)),
    ] {
        let mut doc = triangle_doc();
        doc.json["cameras"][0]["perspective"][field] = value;
        assert_scene_error(load_glb(&doc), &["camera 0 'CameraData'", "yfov"]);
    }
    let mut doc = triangle_doc();
    doc.json["cameras"][0]["perspective"]["aspectRatio"] = json!(0.0);
    assert_scene_error(load_glb(&doc), &["aspectRatio"]);
    let mut doc = triangle_doc();
    doc.json["cameras"][0] = json!({"type": "orthographic",
        "orthographic": {"xmag": 0.0, "ymag": 1.0, "znear": 0.1, "zfar": 10.0}});
    assert_scene_error(load_glb(&doc), &["xmag"]);
}

impl Doc {
    /// An accessor of integer components (`component_type` 5120–5123) holding `data`.
    pub(crate) fn integers(
        &mut self,
        data: &[i32],
        component_type: u32,
        kind: &str,
        normalized: bool,
    ) -> usize {
        let bytes: Vec<u8> = match component_type {
            5120 | 5121 => data.iter().map(|&v| v as u8).collect(),
            _ => data
                .iter()
                .flat_map(|&v| (v as u16).to_le_bytes())
                .collect(),
        };
        let width = match kind {
            "VEC2" => 2,
            "VEC3" => 3,
            _ => 4,
        };
        let view = self.view(&bytes);
        let mut accessor = json!({"bufferView": view, "componentType": component_type,
            "count": data.len() / width, "type": kind, "normalized": normalized});
        if kind == "VEC3" {
            let column = |i: usize, f: fn(i32, i32) -> i32| {
                data.iter().skip(i).step_by(3).copied().reduce(f).unwrap()
            };
            accessor["min"] = json!([0, 1, 2].map(|i| column(i, i32::min)));
            accessor["max"] = json!([0, 1, 2].map(|i| column(i, i32::max)));
        }
        self.push("accessors", accessor)
    }

    /// A one-triangle mesh whose POSITION is accessor `positions`, on a node with `node`'s fields.
    fn quantized_triangle(&mut self, positions: usize, node: Value) {
        let mesh = self.push(
            "meshes",
            json!({"name": "Q", "primitives": [{"attributes": {"POSITION": positions}}]}),
        );
        let mut node = node;
        node["mesh"] = json!(mesh);
        self.node(node, true);
    }
}

#[test]
fn integer_positions_without_mesh_quantization_are_refused() {
    for component_type in [5121, 5123] {
        let mut doc = Doc::new();
        let positions = doc.integers(
            &[0, 0, 0, 200, 0, 0, 0, 190, 0],
            component_type,
            "VEC3",
            false,
        );
        doc.quantized_triangle(positions, json!({"name": "Room"}));
        assert_scene_error(
            load_glb(&doc),
            &["POSITION", "KHR_mesh_quantization", "does not declare"],
        );
    }
}

#[test]
fn quantized_positions_normals_and_uvs_are_dequantized() {
    let mut doc = Doc::new();
    doc.json["extensionsUsed"] = json!(["KHR_mesh_quantization"]);
    doc.json["extensionsRequired"] = json!(["KHR_mesh_quantization"]);
    // Unsigned shorts, not normalized, dequantized by the node's scale and translation.
    let positions = doc.integers(&[0, 0, 0, 1000, 0, 0, 0, 1000, 0], 5123, "VEC3", false);
    let normals = doc.integers(&[0, 0, 127, 0, 0, 127, 0, 0, 127], 5120, "VEC3", true);
    let uvs = doc.integers(&[0, 0, 65535, 0, 0, 32768], 5123, "VEC2", true);
    let mesh = doc.push(
        "meshes",
        json!({"name": "Q", "primitives": [{"attributes":
            {"POSITION": positions, "NORMAL": normals, "TEXCOORD_0": uvs}}]}),
    );
    doc.node(
        json!({"name": "Q", "mesh": mesh, "scale": [0.002, 0.002, 0.002],
               "translation": [-1.0, 0.0, 0.0]}),
        true,
    );
    let scene = load_glb(&doc).expect("a quantized file loads");
    let mesh = &scene.meshes[0];
    assert!(
        close(mesh.positions[1], Vec3::new(1.0, 0.0, 0.0)),
        "{:?}",
        mesh.positions
    );
    assert!(
        close(mesh.positions[2], Vec3::new(-1.0, 2.0, 0.0)),
        "{:?}",
        mesh.positions
    );
    assert!(close(mesh.normals[0], Vec3::Z), "{:?}", mesh.normals);
    assert!((mesh.uvs[1].x - 1.0).abs() < 1e-6 && (mesh.uvs[2].y - 0.5).abs() < 1e-4);
}

#[test]
fn normalized_byte_texture_coordinates_need_no_extension() {
    let mut doc = triangle_doc();
    let uvs = doc.integers(&[0, 0, 255, 0, 0, 255], 5121, "VEC2", true);
    doc.json["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = json!(uvs);
    let scene = load_glb(&doc).expect("normalized unsigned byte UVs are core glTF");
    assert_eq!(scene.meshes[0].uvs[1].x, 1.0);
    // Signed normals without the extension are not.
    let mut doc = triangle_doc();
    let normals = doc.integers(&[0, 0, 127, 0, 0, 127, 0, 0, 127], 5120, "VEC3", true);
    doc.json["meshes"][0]["primitives"][0]["attributes"]["NORMAL"] = json!(normals);
    assert_scene_error(load_glb(&doc), &["NORMAL", "KHR_mesh_quantization"]);
}

#[test]
fn instanced_triangle_totals_are_refused_before_any_geometry_is_read() {
    // One mesh of 5 M (degenerate) triangles whose indices have no buffer view, instanced by 41
    // nodes: 205 M triangles. Reading them would take gigabytes; the count alone refuses them.
    let mut doc = triangle_doc();
    let sparse_indices = doc.view(&0u32.to_le_bytes());
    let sparse_values = doc.view(&1u32.to_le_bytes());
    let indices = doc.push(
        "accessors",
        json!({"componentType": 5125, "count": 15_000_000, "type": "SCALAR",
               "sparse": {"count": 1, "indices": {"bufferView": sparse_indices, "componentType": 5125},
                          "values": {"bufferView": sparse_values}}}),
    );
    doc.json["meshes"][0]["primitives"][0]["indices"] = json!(indices);
    // Mirrored copies are flattened, so each counts.
    for i in 0..40 {
        doc.node(
            json!({"name": format!("Copy{i}"), "mesh": 0, "scale": [-1.0, 1.0, 1.0]}),
            true,
        );
    }
    let start = std::time::Instant::now();
    assert_scene_error(
        load_glb(&doc),
        &["200000000 triangles", "refused before loading any geometry"],
    );
    assert!(start.elapsed().as_secs_f32() < 1.0, "{:?}", start.elapsed());
}

#[test]
fn nan_node_transforms_are_refused() {
    let mut doc = triangle_doc();
    doc.json["nodes"][0]["matrix"] =
        json!([1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0]);
    let mut text = serde_json::to_string(&doc.json).unwrap();
    text = text.replacen("[1.0,0.0,0.0,0.0,0.0,1.0", "[1e39,0.0,0.0,0.0,0.0,1.0", 1);
    doc.json = serde_json::from_str(&text).unwrap();
    assert_scene_error(load_glb(&doc), &["TriNode"]);
}

// ----- PHOTON_light: Cycles' colour and power, spot cone, spread -------------------------------

#[test]
fn photon_light_colour_and_power_replace_the_photometric_values() {
    let mut doc = triangle_doc();
    with_light(
        &mut doc,
        json!({"type": "spot", "intensity": 54351.4, "color": [1.0, 1.0, 1.0],
               "spot": {"innerConeAngle": 0.1, "outerConeAngle": 0.6}}),
        json!({"name": "Spot", "extensions": {"KHR_lights_punctual": {"light": 0},
               "PHOTON_light": {"radius": 0.0, "power": 400.0, "color": [0.2, 0.4, 1.0],
                                "spot_size": 1.2, "spot_blend": 0.25}}}),
    );
    let scene = load_glb(&doc).unwrap();
    let Light::Spot {
        intensity,
        cos_inner,
        cos_outer,
        ..
    } = &scene.lights[0]
    else {
        panic!("not a spot")
    };
    let i = 400.0 / (4.0 * PI);
    assert!(
        close(*intensity, Vec3::new(0.2, 0.4, 1.0) * i),
        "{intensity}"
    );
    let c = 0.6f32.cos();
    assert!((cos_outer - c).abs() < 1e-6);
    assert!(
        (cos_inner - (c + 0.25 * (1.0 - c))).abs() < 1e-6,
        "{cos_inner}"
    );
}

#[test]
fn photon_light_values_out_of_range_are_refused() {
    for bad in [
        json!({"power": -1.0, "color": [1, 1, 1]}),
        json!({"color": [1, -1, 1]}),
        json!({"spot_size": 4.0}),
        json!({"spot_blend": 1.5}),
    ] {
        let mut doc = triangle_doc();
        with_light(
            &mut doc,
            json!({"type": "spot", "intensity": 10.0, "spot": {"outerConeAngle": 0.6}}),
            json!({"name": "Spot", "extensions": {"KHR_lights_punctual": {"light": 0},
                   "PHOTON_light": bad}}),
        );
        assert_scene_error(load_glb(&doc), &["Spot", "PHOTON_light"]);
    }
    let doc = area_light_doc(json!({"type": "area", "spread": 4.0}), json!({}));
    assert_scene_error(load_glb(&doc), &["AreaL", "spread"]);
}

#[test]
fn area_light_spread_is_kept_on_its_mesh() {
    let doc = area_light_doc(json!({"type": "area", "spread": 1.0}), json!({}));
    let scene = load_glb(&doc).unwrap();
    assert_eq!(
        scene.meshes[area_light_index(&scene)].emission_spread,
        Some(1.0)
    );
    let doc = area_light_doc(json!({"type": "area", "spread": PI}), json!({}));
    let scene = load_glb(&doc).unwrap();
    assert_eq!(scene.meshes[area_light_index(&scene)].emission_spread, None);
}

#[test]
fn photon_camera_panoramas_are_read_also_on_camera_less_nodes() {
    let mut doc = triangle_doc();
    doc.node(
        json!({"name": "Pano", "translation": [0.0, 1.0, 0.0], "extensions": {"PHOTON_camera":
            {"panorama": {"type": "EQUIRECTANGULAR", "longitude": [-1.0, 2.0]}}}}),
        true,
    );
    let options = LoadOptions {
        camera: Some("Pano".into()),
        ..LoadOptions::default()
    };
    let scene = load_slice(&doc.glb(), "fixture.glb", &options).unwrap();
    assert_eq!(
        scene.camera.projection,
        Projection::Equirectangular {
            longitude: (-1.0, 2.0),
            latitude: (-0.5 * PI, 0.5 * PI)
        }
    );
    for bad in [
        json!({"type": "CUSTOM"}),
        json!({"type": "FISHEYE_EQUIDISTANT", "fov": 0.0}),
        json!({"type": "FISHEYE_EQUISOLID", "sensor": [36.0, -1.0]}),
    ] {
        let mut doc = triangle_doc();
        doc.node(
            json!({"name": "Pano", "extensions": {"PHOTON_camera": {"panorama": bad}}}),
            true,
        );
        assert_scene_error(load_glb(&doc), &["Pano", "PHOTON_camera"]);
    }
}

#[test]
fn photon_camera_shift_and_lens_are_read_and_checked() {
    let mut doc = triangle_doc();
    doc.json["nodes"][1]["extensions"] = json!({"PHOTON_camera": {"shift": [0.1, -0.2],
        "dof": {"aperture_radius": 0.05, "focus_distance": 4.0, "blades": 6, "rotation": 0.2}}});
    let scene = load_glb(&doc).unwrap();
    assert_eq!(scene.camera.shift, photon::math::Vec2::new(0.1, -0.2));
    let lens = scene.camera.lens.expect("a thin lens");
    assert_eq!(
        (lens.radius, lens.focus_distance, lens.blades),
        (0.05, 4.0, 6)
    );
    for bad in [
        json!({"shift": [0.1]}),
        json!({"dof": {"aperture_radius": -1.0}}),
        json!({"dof": {"focus_distance": 0.0}}),
        json!({"dof": {"ratio": 0.0}}),
    ] {
        let mut doc = triangle_doc();
        doc.json["nodes"][1]["extensions"] = json!({"PHOTON_camera": bad});
        assert_scene_error(load_glb(&doc), &["Camera", "PHOTON_camera"]);
    }
}

#[test]
fn photon_camera_motion_is_read_and_checked() {
    let still = [
        1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
    ];
    let mut moved = still;
    moved[12] = 2.0; // translation x, column-major
    moved[0] = 3.0; // a scale, which a camera pose drops
    let mut doc = triangle_doc();
    doc.json["nodes"][1]["extensions"] = json!({"PHOTON_camera": {"motion": [still, moved]}});
    let scene = load_glb(&doc).unwrap();
    let motion = &scene.camera.motion;
    assert_eq!(motion.len(), 2);
    assert_eq!(
        motion[1].translation,
        photon::math::Vec3A::new(2.0, 0.0, 0.0)
    );
    assert!(motion[1]
        .matrix3
        .x_axis
        .abs_diff_eq(photon::math::Vec3A::X, 1e-6));
    let (nan, singular) = (vec![f64::NAN; 16], vec![0.0; 16]);
    for bad in [
        json!({"motion": [still]}),
        json!({"motion": [still, [1.0, 2.0]]}),
        json!({"motion": [still, nan]}),
        json!({"motion": [still, singular]}),
    ] {
        let mut doc = triangle_doc();
        doc.json["nodes"][1]["extensions"] = json!({"PHOTON_camera": bad});
        assert_scene_error(load_glb(&doc), &["Camera", "PHOTON_camera"]);
    }
}

#[test]
fn photon_object_ray_visibility_is_read_and_checked() {
    let mut doc = triangle_doc();
    doc.json["nodes"][0]["extensions"] =
        json!({"PHOTON_object": {"visible_camera": false, "visible_shadow": false}});
    let scene = load_glb(&doc).unwrap();
    assert!(!scene.meshes[0].camera_visible && !scene.meshes[0].casts_shadows);
    let scene = load_glb(&triangle_doc()).unwrap();
    assert!(scene.meshes[0].camera_visible && scene.meshes[0].casts_shadows);
    let mut doc = triangle_doc();
    doc.json["nodes"][0]["extensions"] = json!({"PHOTON_object": {"visible_shadow": 0}});
    assert_scene_error(
        load_glb(&doc),
        &["TriNode", "PHOTON_object", "visible_shadow"],
    );
}
